//! Each point's pull on a fit: leverage, Cook's distance, the dominant points.

use super::*;

/// One point's pull on the fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointInfluence {
    /// 1-based line of the point in its source file.
    pub line: u64,
    /// Incidence zenith, degrees.
    #[serde(deserialize_with = "f64_or_null")]
    pub theta_i: f64,
    /// Viewing zenith, degrees.
    #[serde(deserialize_with = "f64_or_null")]
    pub theta_r: f64,
    /// Relative azimuth, degrees.
    #[serde(deserialize_with = "f64_or_null")]
    pub phi: f64,
    /// Measured value, 1/sr.
    #[serde(deserialize_with = "f64_or_null")]
    pub brdf: f64,
    /// Fitted value there, 1/sr.
    #[serde(deserialize_with = "f64_or_null")]
    pub model: f64,
    /// Residual in the fitted form (a relative error for relative residuals, weighted).
    #[serde(deserialize_with = "f64_or_null")]
    pub residual: f64,
    /// Residual over its standard deviation, `r / (s sqrt(1 - h))`.
    #[serde(deserialize_with = "f64_or_null")]
    pub standardized: f64,
    /// Leverage `h`: the diagonal of the hat matrix at the optimum.
    #[serde(deserialize_with = "f64_or_null")]
    pub leverage: f64,
    /// Fraction of the cost that refitting without this point removes.
    #[serde(deserialize_with = "f64_or_null")]
    pub cost_drop: f64,
    /// RMS relative error of that refit over the remaining points.
    #[serde(deserialize_with = "f64_or_null")]
    pub rms_rel_without: f64,
}

/// The points whose removal changes the fit most.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Influence {
    /// Most influential first (at most [`INFLUENCE_SHOWN`]).
    pub points: Vec<PointInfluence>,
    /// Cost drop above which one point is called dominant for this many points
    /// ([`dominant_fraction`]).
    #[serde(deserialize_with = "f64_or_null")]
    pub dominant_above: f64,
    /// One point alone moves the cost by more than `dominant_above`: the fit rests on it.
    pub dominant: bool,
}

/// Points listed in [`Influence::points`].
pub const INFLUENCE_SHOWN: usize = 3;

/// Candidates (by the linearised leave-one-out cost drop) refitted exactly.
pub const INFLUENCE_CANDIDATES: usize = 5;

/// Cost fraction one point of `n` may remove before it is called dominant:
/// `max(10%, (2 ln n + 14) / n)`. For `n` residuals from one normal distribution the largest
/// squared standardised one exceeds `2 ln n + 14` with probability below 0.1% (union bound on
/// the chi-square tail `exp(-x/2)`), so a larger share is not noise; the 10% floor keeps large
/// datasets from flagging points that matter little.
pub fn dominant_fraction(n: usize) -> f64 {
    let n = n.max(1) as f64;
    ((2.0 * n.ln() + 14.0) / n).max(0.1)
}

/// Leave-one-out influence over distinct rows ([`row_copies`]): a row and its exact copies
/// are one point, left out together (leaving out one copy while its twins stay moves nothing,
/// and copies would otherwise count as points in [`dominant_fraction`] and the residual
/// variance). A row written `c` times weighs `c` times one row: its linearised cost drop is
/// `0.5 c rho(r^2) / (1 - c h)`, its leverage `c h` (the hat matrix's block of `c` equal rows),
/// its standardised residual `sqrt(c) r / (s sqrt(1 - c h))`, `s^2 = 2 cost / (m - p)` over the
/// `m` distinct rows as in [`uncertainty`]. The linearised drop ranks the points,
/// the top [`INFLUENCE_CANDIDATES`] are refitted without the point (a local polish from the
/// optimum, and the whole global search where that already removes more than the dominant
/// fraction, since one point can hold the fit in another basin). No point is listed when
/// the cost is at or below its rounding floor ([`crate::fit::cost_floor`]): the residuals are
/// then rounding, and a share of them says nothing about a point (noise-free data had "lowers
/// the cost by 5%" of a cost of 1e-30).
pub fn influence(dataset: &Dataset, problem: &Problem, outcome: &FitOutcome, opts: &FitOptions) -> Influence {
    let kind = outcome.kind;
    let copies = row_copies(dataset, kind);
    let n = copies.len();
    let dominant_above = dominant_fraction(n);
    let p = kind.param_count();
    if n <= p + 1
        || outcome.cost <= 0.0
        || !outcome.cost.is_finite()
        || outcome.cost <= crate::fit::cost_floor(problem)
    {
        return Influence {
            points: Vec::new(),
            dominant_above,
            dominant: false,
        };
    }
    let (lo, hi) = problem.bounds();
    let gram = problem.jacobian_gram(&outcome.q);
    let free: Vec<usize> = (0..p)
        .filter(|&j| on_bound(outcome.q[j], lo[j], hi[j]).is_none() && gram[j][j] > 0.0)
        .collect();
    let pinv = pseudo_inverse(&gram, &free);
    let values = problem.values(&outcome.q);
    let s2 = 2.0 * outcome.cost / (n - free.len()).max(1) as f64;
    // Leverage of a row and its copies, one Jacobian row at a time (no n x p matrix held).
    let hat = |i: usize, c: f64| -> f64 {
        let row = problem.jacobian_row(i, &outcome.q);
        let mut h = 0.0;
        for (x, &a) in free.iter().enumerate() {
            for (y, &b) in free.iter().enumerate() {
                h += row[a] * pinv[x][y] * row[b];
            }
        }
        (c * h).clamp(0.0, 1.0 - 1e-12)
    };
    let mut ranked: Vec<(&Vec<usize>, f64, f64)> = copies
        .iter()
        .map(|g| {
            let (i, c) = (g[0], g.len() as f64);
            let r = problem.residual_of(i, values[i]);
            let h = hat(i, c);
            (g, 0.5 * c * problem.loss().eval(r * r).0 / (1.0 - h), h)
        })
        .collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut points: Vec<PointInfluence> = ranked
        .iter()
        .take(INFLUENCE_CANDIDATES)
        .map(|&(g, _, h)| {
            let i = g[0];
            let without = problem.without(g);
            let local = crate::lm::minimise(&without, &outcome.q, &lo, &hi, opts.lm);
            let (mut q, mut cost) = (local.q, local.cost);
            if (outcome.cost - cost) / outcome.cost > dominant_above {
                let global = crate::fit::fit(&without, opts);
                if global.cost < cost {
                    (q, cost) = (global.q, global.cost);
                }
            }
            let f = without.values(&q);
            let rel2: f64 = (0..without.len())
                .map(|k| without.relative_error(k, f[k]).powi(2))
                .sum();
            let pt = &dataset.points[i];
            let r = problem.residual_of(i, values[i]);
            PointInfluence {
                line: pt.line,
                theta_i: degrees(pt.theta_i),
                theta_r: degrees(pt.theta_r),
                phi: degrees(pt.phi),
                brdf: pt.brdf,
                model: values[i],
                residual: r,
                standardized: (g.len() as f64).sqrt() * r / (s2 * (1.0 - h)).sqrt(),
                leverage: h,
                cost_drop: ((outcome.cost - cost) / outcome.cost).max(0.0),
                rms_rel_without: (rel2 / without.len().max(1) as f64).sqrt(),
            }
        })
        .collect();
    points.sort_by(|a, b| b.cost_drop.total_cmp(&a.cost_drop));
    points.truncate(INFLUENCE_SHOWN);
    let dominant = points.first().is_some_and(|p| p.cost_drop > dominant_above);
    Influence {
        points,
        dominant_above,
        dominant,
    }
}

/// Pseudo-inverse of `J^T J` restricted to the parameters `free` (rows and columns in the
/// order of `free`), dropping directions below [`SINGULAR_EIGEN_REL`].
pub(crate) fn pseudo_inverse(
    gram: &[[f64; MAX_PARAMS]; MAX_PARAMS],
    free: &[usize],
) -> [[f64; MAX_PARAMS]; MAX_PARAMS] {
    let m = free.len();
    let mut jtj = [[0.0; MAX_PARAMS]; MAX_PARAMS];
    for (x, &a) in free.iter().enumerate() {
        for (y, &b) in free.iter().enumerate() {
            jtj[x][y] = gram[a][b];
        }
    }
    let scale: Vec<f64> = (0..m).map(|x| jtj[x][x].sqrt().max(f64::MIN_POSITIVE)).collect();
    let mut a = [[0.0; MAX_PARAMS]; MAX_PARAMS];
    for x in 0..m {
        for y in 0..m {
            a[x][y] = jtj[x][y] / (scale[x] * scale[y]);
        }
    }
    let (values, vectors) = symmetric_eigen(a, m);
    let largest = values[..m].iter().copied().fold(0.0, f64::max);
    let mut out = [[0.0; MAX_PARAMS]; MAX_PARAMS];
    for x in 0..m {
        for y in 0..m {
            let mut s = 0.0;
            for k in 0..m {
                if values[k] > SINGULAR_EIGEN_REL * largest {
                    s += vectors[x][k] * vectors[y][k] / values[k];
                }
            }
            out[x][y] = s / (scale[x] * scale[y]);
        }
    }
    out
}
