//! Parameter uncertainty: standard errors, correlations and the plain flags on what the data
//! do not determine (profile rises, bounds, near-null directions).

use super::*;

/// What is known about one parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamUncertainty {
    /// Fitted value (paper units and sign).
    #[serde(deserialize_with = "f64_or_null")]
    pub value: f64,
    /// Standard error from the Jacobian at the optimum; `None` where it is not defined.
    pub se: Option<f64>,
    /// `se / |value|`.
    pub rel_se: Option<f64>,
    /// False when the data do not pin the parameter down.
    pub determined: bool,
    /// Why it is not determined.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// Parameter uncertainty: per-parameter standard errors and the correlation matrix.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Uncertainty {
    /// Per parameter, paper order.
    pub params: Ordered<ParamUncertainty>,
    /// Correlation matrix of the parameters (paper order); `None` where undefined.
    pub correlation: Vec<Vec<Option<f64>>>,
    /// The least cost a profile refit reached when it lies below the optimum's (by more than
    /// [`crate::fit::AGREEMENT`] and the cost's rounding floor, [`crate::fit::below`]): with one
    /// parameter held the others found a better point, so
    /// the search missed the optimum ([`crate::report::report`] then withdraws "converged").
    #[serde(skip)]
    pub refit_below: Option<f64>,
}

/// A parameter is called undetermined when its standard error exceeds this fraction of
/// its value: the data are then consistent with values at least twice or half as large.
pub const UNDETERMINED_REL_SE: f64 = 0.5;

/// Profile test: a parameter is also called undetermined when holding it at twice or half
/// its fitted value, or at either end of its search box, and refitting the others raises
/// `chi^2 = RSS / s^2` by less than this: 3.84 is the 95% point of chi-square with one
/// degree of freedom, so the factor-2 move lies inside the 95% profile interval. This
/// catches flat directions the linearised standard error misses (kr >> 1 from in-plane
/// data, where the cost is flat from the optimum up to the bound).
pub const PROFILE_DELTA_CHI2: f64 = 3.84;

/// Distinct direction pairs among the points of `d` to the model `kind`, counted up to
/// `limit` (`O(n limit)`): the rule of `brdf_core::anneal::distinct_geometries` (`phi` and
/// `-phi` one pair, and for a reciprocal model a pair and its swap), so that a direction
/// written twice never passes for two (it made the report call parameters determined with
/// standard error 0 from two directions written three ways).
pub fn distinct_directions(d: &Dataset, kind: ModelKind, limit: usize) -> usize {
    let mut seen: Vec<brdf_core::Geometry<f64>> = Vec::with_capacity(limit);
    for p in &d.points {
        if seen.len() >= limit {
            break;
        }
        let g = brdf_core::Geometry::<f64>::from_angles(p.theta_i, p.theta_r, p.phi);
        if !seen.iter().any(|s| s.same_pair(&g, kind.is_reciprocal())) {
            seen.push(g);
        }
    }
    seen.len()
}

/// Distinct rows among the points of `d` to the model `kind`: rows that differ in their
/// direction pair (as [`distinct_directions`] tells pairs apart), reading, sigma or weight.
/// An exact copy of a row (its pair written the same way or another, with the same reading,
/// sigma and weight) adds the same residual and the same Jacobian row once more: it adds to
/// `J^T J` and to the cost exactly what the row already does, and no information, so it is
/// not counted (the degrees of freedom of [`uncertainty`], the information criteria of
/// [`crate::report::report`], the points of [`crate::report::influence`]). A replicate (the
/// same pair read again, another reading) is counted. The number of [`row_copies`].
pub fn distinct_rows(d: &Dataset, kind: ModelKind) -> usize {
    row_copies(d, kind).len()
}

/// The distinct rows of `d` to the model `kind` ([`distinct_rows`]), each as the indices of
/// its exact copies in `d.points` (ascending; the first is the row as first written), ordered
/// by their first index. `O(n log n)` for readings that differ; a direction is compared only
/// with the rows of the same reading, sigma and weight whose `cos gamma` lies within the pair
/// rule's tolerance of its own.
pub fn row_copies(d: &Dataset, kind: ModelKind) -> Vec<Vec<usize>> {
    use std::cmp::Ordering;
    let pts = &d.points;
    let geo: Vec<brdf_core::Geometry<f64>> = pts
        .iter()
        .map(|p| brdf_core::Geometry::<f64>::from_angles(p.theta_i, p.theta_r, p.phi))
        .collect();
    let option = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => a.total_cmp(&b),
        (a, b) => a.is_some().cmp(&b.is_some()),
    };
    let reading = |a: usize, b: usize| {
        let (p, q) = (&pts[a], &pts[b]);
        p.brdf
            .total_cmp(&q.brdf)
            .then(option(p.sigma, q.sigma))
            .then(option(p.weight, q.weight))
    };
    let mut order: Vec<usize> = (0..pts.len()).collect();
    order.sort_unstable_by(|&a, &b| {
        reading(a, b)
            .then(geo[a].cos_gamma().total_cmp(&geo[b].cos_gamma()))
            .then(a.cmp(&b))
    });
    // `same_pair` holds only where `cos gamma` agrees within `tol` relative (plus `tol eps`):
    // in `order` such rows lie within that window of one another.
    let tol = brdf_core::tolerance::SAME_PAIR_EPS * f64::EPSILON;
    let reciprocal = kind.is_reciprocal();
    // Kept rows (their group's first member in `order`) and their groups.
    let mut kept: Vec<(usize, Vec<usize>)> = Vec::new();
    for &i in &order {
        let g = geo[i].cos_gamma();
        let mut copy = None;
        for (at, (k, _)) in kept.iter().enumerate().rev() {
            let h = geo[*k].cos_gamma();
            if reading(*k, i) != Ordering::Equal || g - h > tol * (g.abs().max(h.abs()) + f64::EPSILON) {
                break;
            }
            if geo[*k].same_pair(&geo[i], reciprocal) {
                copy = Some(at);
                break;
            }
        }
        match copy {
            Some(at) => kept[at].1.push(i),
            None => kept.push((i, vec![i])),
        }
    }
    let mut groups: Vec<Vec<usize>> = kept
        .into_iter()
        .map(|(_, mut g)| {
            g.sort_unstable();
            g
        })
        .collect();
    groups.sort_unstable_by_key(|g| g[0]);
    groups
}

/// The profile test of parameter `j`: the least rise of `2 (cost - cost_min) / s2` over refits
/// with `q_j` held at half, twice and each end of its box, and the least cost they reached.
/// On a large problem (`sample` given, see [`crate::fit::SEARCH_POINTS`]) each refit starts on
/// the subsample and is finished on every point from there: the rise is every point's, at a
/// few passes over them.
pub(crate) fn profile_rise(
    problem: &Problem,
    sample: Option<&Problem>,
    outcome: &FitOutcome,
    j: usize,
    s2: f64,
) -> Option<(f64, f64)> {
    let kind = outcome.kind;
    let (lo, hi) = problem.bounds();
    let log_param = matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five) && j == 1;
    let q0 = outcome.q[j];
    // Half, twice, and both ends of the search box: a profile still flat at a bound means
    // the interval runs into the bound.
    let moves: [f64; 4] = if log_param {
        [
            q0 - std::f64::consts::LN_2,
            q0 + std::f64::consts::LN_2,
            lo[j],
            hi[j],
        ]
    } else {
        [q0 * 0.5, q0 * 2.0, lo[j], hi[j]]
    };
    if !log_param && q0 == 0.0 {
        return None;
    }
    // The refits are independent: all of them at once, on all cores.
    moves
        .par_iter()
        .filter_map(|&target| {
            let v = target.clamp(lo[j], hi[j]);
            if !v.is_finite() || (v - q0).abs() <= 1e-12 * (1.0 + q0.abs()) {
                return None;
            }
            let (mut flo, mut fhi) = (lo, hi);
            flo[j] = v;
            fhi[j] = v;
            let mut start = outcome.q;
            start[j] = v;
            let lm = crate::lm::LmOptions::default();
            if let Some(sample) = sample {
                start = crate::lm::minimise(sample, &start, &flo, &fhi, lm).q;
            }
            let r = crate::lm::minimise(problem, &start, &flo, &fhi, lm);
            Some((2.0 * (r.cost - outcome.cost).max(0.0) / s2, r.cost))
        })
        .reduce_with(|a, b| (a.0.min(b.0), a.1.min(b.1)))
}

/// `x` with six significant digits and no trailing zeros (1000, not 999.9999999999998).
pub(crate) fn short(x: f64) -> String {
    let s = format!(
        "{:.*}",
        (5 - x.abs().log10().floor() as i32).clamp(0, 12) as usize,
        x
    );
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}

/// The bound `q` sits on: within 1e-7 of the box's width of a finite bound, exactly on the
/// lower bound of a half-open range (the non-negative weights, which the projection and the
/// polish set to exactly 0).
pub(crate) fn on_bound(q: f64, lo: f64, hi: f64) -> Option<f64> {
    let tol = if (hi - lo).is_finite() {
        1e-7 * (hi - lo)
    } else {
        0.0
    };
    if q <= lo + tol {
        Some(lo)
    } else if q >= hi - tol {
        Some(hi)
    } else {
        None
    }
}

/// Eigen-decomposition of a symmetric `n x n` matrix by cyclic Jacobi rotations:
/// eigenvalues and eigenvectors (column `k` of the second result belongs to value `k`).
pub(crate) fn symmetric_eigen(
    mut a: [[f64; MAX_PARAMS]; MAX_PARAMS],
    n: usize,
) -> ([f64; MAX_PARAMS], [[f64; MAX_PARAMS]; MAX_PARAMS]) {
    let mut v = [[0.0; MAX_PARAMS]; MAX_PARAMS];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..64 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        let diag: f64 = (0..n).map(|i| a[i][i] * a[i][i]).sum();
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
                for row in v.iter_mut().take(n) {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    let mut values = [0.0; MAX_PARAMS];
    for i in 0..n {
        values[i] = a[i][i];
    }
    (values, v)
}

/// An eigenvalue of the unit-diagonal `J^T J` below this fraction of the largest marks a
/// direction the data do not constrain: its variance would exceed the best-determined
/// direction's by a factor of 1e10, i.e. a standard error 1e5 times larger.
pub const SINGULAR_EIGEN_REL: f64 = 1e-10;

/// A parameter whose share of such a direction (squared component of the unit eigenvector)
/// exceeds this is reported as confounded with the others in it.
const CONFOUNDED_SHARE: f64 = 0.01;

/// Standard errors and correlations from `J^T J` at the optimum, scaled by the residual
/// variance `2 cost / (m - p)`, `m` the distinct rows of the data ([`distinct_rows`]).
///
/// Exact copies of rows count once in `m`: `k` copies of every row multiply `J^T J` and the
/// cost by `k`, so with `m` the data's own the standard errors, the profile rises and the
/// verdicts are the original's (with `n - p` every standard error shrank by about `sqrt(k)`
/// and parameters the data do not determine were called determined). With no more distinct
/// rows than free parameters the fit passes through them and leaves no noise estimate.
///
/// Parameters on a search bound are held there; parameters with no effect on the model at
/// the optimum (the lobe's `kr`, `b`, `a` when `kb = 0`) are reported as such; directions in
/// which `J^T J` is singular name the parameters that share them, and only those. Every
/// other parameter gets its standard error and the profile test.
pub fn uncertainty(problem: &Problem, outcome: &FitOutcome, distinct_rows: usize) -> Uncertainty {
    let kind = outcome.kind;
    let p = kind.param_count();
    let names = kind.param_names();
    let (lo, hi) = problem.bounds();
    let jtj = problem.jacobian_gram(&outcome.q);
    let lobe_model = matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five);
    let lobe_off = lobe_model && outcome.q[0] == 0.0;
    let mut note: Vec<Option<String>> = vec![None; p];
    for j in 0..p {
        if problem.is_fixed(j) {
            note[j] =
                Some("held: shared with the other bands of its measurement, not estimated here".to_owned());
        } else if let Some(bound) = on_bound(outcome.q[j], lo[j], hi[j]) {
            let shown = crate::kernel::to_natural(kind, &{
                let mut q = outcome.q;
                q[j] = bound;
                q
            })[j];
            note[j] = Some(if lobe_off && j == 0 {
                "kb = 0 (on its bound): the fit has no specular lobe".to_owned()
            } else {
                format!("at the search bound {}: held there, not estimated", short(shown))
            });
        } else if lobe_off && (1..=3).contains(&j) {
            note[j] = Some("lobe off (kb = 0): kr, b, a have no effect".to_owned());
        } else if jtj[j][j] == 0.0 || !jtj[j][j].is_finite() {
            note[j] = Some(format!("{} has no effect on the model at the optimum", names[j]));
        }
    }
    let free: Vec<usize> = (0..p).filter(|&j| note[j].is_none()).collect();
    // The noise is estimated from the residuals of distinct rows: copies of as many rows as
    // free parameters are fitted exactly, whatever their number, and leave no residual to
    // estimate it from (every standard error would be 0); copies of more rows add to the cost
    // what their rows already do, and no degree of freedom.
    let no_noise_estimate = distinct_rows <= free.len();
    let dof = if no_noise_estimate {
        0
    } else {
        distinct_rows.min(problem.len()) - free.len()
    };
    let s2 = if dof > 0 {
        2.0 * outcome.cost / dof as f64
    } else {
        f64::NAN
    };
    // Scaled to unit diagonal so that parameters of very different size compare, then
    // decomposed: small eigenvalues are the directions the data leave free.
    let m = free.len();
    let scale: Vec<f64> = free.iter().map(|&j| jtj[j][j].sqrt()).collect();
    let mut a = [[0.0; MAX_PARAMS]; MAX_PARAMS];
    for (x, &i) in free.iter().enumerate() {
        for (y, &j) in free.iter().enumerate() {
            a[x][y] = jtj[i][j] / (scale[x] * scale[y]);
        }
    }
    let (values, vectors) = symmetric_eigen(a, m);
    let largest = values[..m].iter().copied().fold(0.0, f64::max);
    let mut confounded = [false; MAX_PARAMS];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for k in 0..m {
        if values[k] > SINGULAR_EIGEN_REL * largest {
            continue;
        }
        let group: Vec<usize> = (0..m)
            .filter(|&x| vectors[x][k] * vectors[x][k] > CONFOUNDED_SHARE)
            .collect();
        for &x in &group {
            confounded[x] = true;
        }
        groups.push(group);
    }
    for (x, &j) in free.iter().enumerate() {
        if !confounded[x] {
            continue;
        }
        let mut others: Vec<&str> = groups
            .iter()
            .filter(|g| g.contains(&x))
            .flatten()
            .filter(|&&y| y != x)
            .map(|&y| names[free[y]])
            .collect();
        others.sort_unstable();
        others.dedup();
        note[j] = Some(if others.is_empty() {
            format!("J^T J is singular in {}: the data do not constrain it", names[j])
        } else {
            format!(
                "J^T J is singular in {} with {}: the data do not separate them",
                names[j],
                others.join(", ")
            )
        });
    }
    // Covariance from the directions the data do constrain (a pseudo-inverse).
    let mut cov = [[f64::NAN; MAX_PARAMS]; MAX_PARAMS];
    for x in 0..m {
        for y in 0..m {
            if confounded[x] || confounded[y] {
                continue;
            }
            let mut s = 0.0;
            for k in 0..m {
                if values[k] > SINGULAR_EIGEN_REL * largest {
                    s += vectors[x][k] * vectors[y][k] / values[k];
                }
            }
            cov[free[x]][free[y]] = s2 * s / (scale[x] * scale[y]);
        }
    }
    let d = natural_per_internal(kind, &outcome.q);
    // Profile refits of every parameter that gets a standard error, all in parallel.
    let sample = (problem.len() > crate::fit::SEARCH_POINTS)
        .then(|| crate::fit::search_sample(problem, crate::fit::SEARCH_POINTS).problem(problem));
    let refits: Vec<Option<(f64, f64)>> = (0..p)
        .into_par_iter()
        .map(|j| {
            let estimated = note[j].is_none() && cov[j][j].is_finite() && cov[j][j] >= 0.0;
            if estimated && s2 > 0.0 {
                profile_rise(problem, sample.as_ref(), outcome, j, s2)
            } else {
                None
            }
        })
        .collect();
    let rises: Vec<Option<f64>> = refits.iter().map(|r| r.map(|r| r.0)).collect();
    let floor = crate::fit::cost_floor(problem);
    let refit_below = refits
        .iter()
        .filter_map(|r| r.map(|r| r.1))
        .filter(|&c| crate::fit::below(c, outcome.cost, floor))
        .reduce(f64::min);
    let mut params = Vec::with_capacity(p);
    for j in 0..p {
        let value = outcome.params[j];
        let (se, rel_se, determined, note) = if let Some(n) = note[j].take() {
            (None, None, false, Some(n))
        } else if !cov[j][j].is_finite() || cov[j][j] < 0.0 {
            (
                None,
                None,
                false,
                Some(if no_noise_estimate {
                    "its variance is not defined (no more distinct directions than parameters: \
                     the fit passes through them and leaves no noise estimate; exact copies of \
                     a row count once)"
                        .to_owned()
                } else {
                    "its variance is not defined (fewer points than parameters)".to_owned()
                }),
            )
        } else {
            let se = cov[j][j].sqrt() * d[j].abs();
            let rel = if value != 0.0 {
                se / value.abs()
            } else {
                f64::INFINITY
            };
            let flat = rises[j];
            if rel > UNDETERMINED_REL_SE {
                let note = format!(
                    "standard error is {:.0}% of the value: the data do not determine {}",
                    100.0 * rel,
                    names[j]
                );
                (Some(se), Some(rel), false, Some(note))
            } else if let Some(rise) = flat.filter(|&r| r < PROFILE_DELTA_CHI2) {
                let note = format!(
                    "holding {} at half or twice its value or at a search bound and refitting \
                     raises chi^2 by only {rise:.2} (< {PROFILE_DELTA_CHI2}): the data do not determine it",
                    names[j]
                );
                (Some(se), Some(rel), false, Some(note))
            } else {
                (Some(se), Some(rel), true, None)
            }
        };
        params.push((
            names[j].to_owned(),
            ParamUncertainty {
                value,
                se,
                rel_se,
                determined,
                note,
            },
        ));
    }
    let correlation = (0..p)
        .map(|i| {
            (0..p)
                .map(|j| {
                    let c = cov[i][j] / (cov[i][i] * cov[j][j]).sqrt();
                    c.is_finite().then_some(c)
                })
                .collect()
        })
        .collect();
    Uncertainty {
        params: Ordered(params),
        correlation,
        refit_below,
    }
}
