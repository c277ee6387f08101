//! What a fit says: metrics (overall and per incidence), parameter uncertainty with plain
//! flags on what the data do not determine, and the energy check.

use brdf_core::checks::{albedo, AlbedoRule};
use brdf_core::{AnyModel, ModelKind, MAX_PARAMS};
use serde::ser::SerializeMap;
use serde::{Serialize, Serializer};

use crate::data::Dataset;
use crate::fit::FitOutcome;
use crate::kernel::natural_per_internal;
use crate::lm::cholesky_solve;
use crate::problem::{bounds, Problem};

/// A name-to-value map that keeps its order in JSON.
#[derive(Clone, Debug, PartialEq)]
pub struct Ordered<T>(pub Vec<(String, T)>);

impl<T: Serialize> Serialize for Ordered<T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

/// Goodness of fit, unweighted, on the BRDF values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Metrics {
    /// Root-mean-square error, 1/sr.
    pub rmse: f64,
    /// Mean squared error, 1/sr^2.
    pub mse: f64,
    /// Root-mean-square relative error `(f - y) / y`.
    pub rms_rel: f64,
    /// Largest `|f - y| / y`.
    pub max_rel: f64,
    /// Root-mean-square of `ln f - ln y`.
    pub log_rmse: f64,
}

/// Metrics of model values `f` against measurements `y`.
pub fn metrics(f: &[f64], y: &[f64]) -> Metrics {
    let n = f.len().max(1) as f64;
    let (mut se, mut sr, mut mr, mut sl) = (0.0, 0.0, 0.0_f64, 0.0);
    for (&f, &y) in f.iter().zip(y) {
        se += (f - y) * (f - y);
        let rel = (f - y) / y;
        sr += rel * rel;
        mr = mr.max(rel.abs());
        let l = if f > 0.0 { f.ln() - y.ln() } else { f64::INFINITY };
        sl += l * l;
    }
    Metrics {
        rmse: (se / n).sqrt(),
        mse: se / n,
        rms_rel: (sr / n).sqrt(),
        max_rel: mr,
        log_rmse: (sl / n).sqrt(),
    }
}

/// Radians to degrees, rounded to 1e-9 so that 30 prints as 30.
fn degrees(rad: f64) -> f64 {
    (rad.to_degrees() * 1e9).round() / 1e9
}

/// Metrics of the points at one incidence angle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct IncidenceMetrics {
    /// Incidence zenith, degrees.
    pub theta_i: f64,
    /// Points at this incidence.
    pub n: usize,
    /// Their metrics.
    #[serde(flatten)]
    pub metrics: Metrics,
}

/// What is known about one parameter.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ParamUncertainty {
    /// Fitted value (paper units and sign).
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
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Uncertainty {
    /// Per parameter, paper order.
    pub params: Ordered<ParamUncertainty>,
    /// Correlation matrix of the parameters (paper order); `None` where undefined.
    pub correlation: Vec<Vec<Option<f64>>>,
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

/// Smallest rise of `chi^2` when parameter `j` is held at half or twice its value or at a
/// bound and the others are refitted; `None` if the parameter is zero or no move is
/// possible.
fn profile_rise(problem: &Problem, outcome: &FitOutcome, j: usize, s2: f64) -> Option<f64> {
    let kind = outcome.kind;
    let (lo, hi) = bounds(kind);
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
    let mut rise: Option<f64> = None;
    for target in moves {
        let v = target.clamp(lo[j], hi[j]);
        if (v - q0).abs() <= 1e-12 * (1.0 + q0.abs()) {
            continue;
        }
        let (mut flo, mut fhi) = (lo, hi);
        flo[j] = v;
        fhi[j] = v;
        let mut start = outcome.q;
        start[j] = v;
        let r = crate::lm::minimise(problem, &start, &flo, &fhi, crate::lm::LmOptions::default());
        let d = 2.0 * (r.cost - outcome.cost).max(0.0) / s2;
        rise = Some(rise.map_or(d, |x: f64| x.min(d)));
    }
    rise
}

/// Standard errors and correlations from `J^T J` at the optimum, scaled by the residual
/// variance `2 cost / (n - p)`. Parameters at a search bound are held fixed there.
pub fn uncertainty(problem: &Problem, outcome: &FitOutcome) -> Uncertainty {
    let kind = outcome.kind;
    let p = kind.param_count();
    let names = kind.param_names();
    let (lo, hi) = bounds(kind);
    let jtj = problem.jacobian_gram(&outcome.q);
    let at_bound: Vec<bool> = (0..p)
        .map(|j| {
            let tol = 1e-7 * (hi[j] - lo[j]);
            outcome.q[j] <= lo[j] + tol || outcome.q[j] >= hi[j] - tol
        })
        .collect();
    let free: Vec<usize> = (0..p).filter(|&j| !at_bound[j]).collect();
    let dof = problem.len().saturating_sub(free.len());
    let s2 = if dof > 0 {
        2.0 * outcome.cost / dof as f64
    } else {
        f64::NAN
    };
    // Inverse of J^T J on the free parameters, column by column; scaled by the
    // diagonal first so that parameters of very different size do not defeat Cholesky.
    let m = free.len();
    let scale: Vec<f64> = free.iter().map(|&j| jtj[j][j].sqrt().max(1e-300)).collect();
    let mut a = [[0.0; MAX_PARAMS]; MAX_PARAMS];
    for (x, &i) in free.iter().enumerate() {
        for (y, &j) in free.iter().enumerate() {
            a[x][y] = jtj[i][j] / (scale[x] * scale[y]);
        }
    }
    let mut cov = [[f64::NAN; MAX_PARAMS]; MAX_PARAMS];
    let mut singular = false;
    for x in 0..m {
        let mut e = [0.0; MAX_PARAMS];
        e[x] = 1.0;
        match cholesky_solve(&a, &e, m) {
            Some(col) => {
                for y in 0..m {
                    cov[free[y]][free[x]] = s2 * col[y] / (scale[x] * scale[y]);
                }
            }
            None => singular = true,
        }
    }
    let d = natural_per_internal(kind, &outcome.q);
    let mut params = Vec::with_capacity(p);
    for j in 0..p {
        let value = outcome.params[j];
        let (se, rel_se, determined, note) = if at_bound[j] {
            let bound = if outcome.q[j] <= lo[j] + 1e-7 * (hi[j] - lo[j]) {
                lo[j]
            } else {
                hi[j]
            };
            let shown = crate::kernel::to_natural(kind, &{
                let mut q = outcome.q;
                q[j] = bound;
                q
            })[j];
            (
                None,
                None,
                false,
                Some(format!("at the search bound {shown}: held there, not estimated")),
            )
        } else if singular || !cov[j][j].is_finite() || cov[j][j] < 0.0 {
            (
                None,
                None,
                false,
                Some("J^T J is singular: the data do not constrain it".to_owned()),
            )
        } else {
            let se = cov[j][j].sqrt() * d[j].abs();
            let rel = if value != 0.0 {
                se / value.abs()
            } else {
                f64::INFINITY
            };
            let flat = if s2 > 0.0 {
                profile_rise(problem, outcome, j, s2)
            } else {
                None
            };
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
    }
}

/// Quadrature albedo at one measured incidence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct IncidenceAlbedo {
    /// Incidence zenith, degrees.
    pub theta_i: f64,
    /// Directional-hemispherical reflectance (default rule, accurate to
    /// `brdf_core::tolerance::ALBEDO_DEFAULT_REL`).
    pub albedo: f64,
}

/// The energy check of a fitted model.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Energy {
    /// Analytic sufficient bound (`kb + kd` for the six-parameter model), if the model has one.
    pub bound: Option<f64>,
    /// The bound is at most 1.
    pub bound_conserves: bool,
    /// Albedo at each measured incidence.
    pub albedo: Vec<IncidenceAlbedo>,
    /// Every albedo is at most 1.
    pub albedo_conserves: bool,
}

/// Energy check of `model` at the incidences (radians) of a dataset.
pub fn energy(model: &AnyModel<f64>, incidences: &[f64]) -> Energy {
    let bound = model.energy_bound();
    let albedo: Vec<IncidenceAlbedo> = incidences
        .iter()
        .map(|&ti| IncidenceAlbedo {
            theta_i: degrees(ti),
            albedo: albedo(model, ti, AlbedoRule::DEFAULT),
        })
        .collect();
    Energy {
        bound,
        bound_conserves: matches!(bound, Some(b) if b <= 1.0),
        albedo_conserves: albedo.iter().all(|a| a.albedo <= 1.0),
        albedo,
    }
}

/// Everything `brdf fit --json` prints for one dataset.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FitReport {
    /// Dataset name (file, and group if any).
    pub dataset: String,
    /// Model name.
    pub model: &'static str,
    /// Fitted parameters, paper names and order (`b` negative, as in the paper).
    pub params: Ordered<f64>,
    /// Goodness of fit over all points.
    pub metrics: Metrics,
    /// The same per incidence angle.
    pub per_incidence: Vec<IncidenceMetrics>,
    /// Number of points.
    pub n: usize,
    /// Number of parameters.
    pub k: usize,
    /// Akaike information criterion `n ln(RSS/n) + 2k` on the fitted residuals.
    pub aic: f64,
    /// Bayesian information criterion `n ln(RSS/n) + k ln n`.
    pub bic: f64,
    /// Wall time of the fit, seconds.
    pub seconds: f64,
    /// Residual form.
    pub residual: &'static str,
    /// Seed of the run.
    pub seed: u64,
    /// `0.5 * sum r^2` at the optimum.
    pub cost: f64,
    /// Passes over the data.
    pub evals: usize,
    /// The local polish met its convergence test.
    pub converged: bool,
    /// Parameter uncertainty and undetermined-parameter flags.
    pub uncertainty: Uncertainty,
    /// Energy check.
    pub energy: Energy,
}

impl FitReport {
    /// Names of the parameters flagged as not determined by the data, in paper order.
    pub fn undetermined(&self) -> Vec<&str> {
        self.uncertainty
            .params
            .0
            .iter()
            .filter(|(_, u)| !u.determined)
            .map(|(n, _)| n.as_str())
            .collect()
    }
}

/// Builds the report of a finished fit.
pub fn report(dataset: &Dataset, problem: &Problem, outcome: &FitOutcome, seed: u64) -> FitReport {
    let kind: ModelKind = outcome.kind;
    let values = problem.values(&outcome.q);
    let y: Vec<f64> = dataset.points.iter().map(|p| p.brdf).collect();
    let incidences = dataset.incidences();
    let per_incidence = incidences
        .iter()
        .map(|&ti| {
            let (f, yy): (Vec<f64>, Vec<f64>) = dataset
                .points
                .iter()
                .zip(&values)
                .filter(|(p, _)| (p.theta_i - ti).abs() < 1e-9)
                .map(|(p, &f)| (f, p.brdf))
                .unzip();
            IncidenceMetrics {
                theta_i: degrees(ti),
                n: f.len(),
                metrics: metrics(&f, &yy),
            }
        })
        .collect();
    let n = problem.len();
    let k = kind.param_count();
    let rss = 2.0 * outcome.cost;
    let nf = n as f64;
    let ll = nf * (rss / nf).max(1e-300).ln();
    let model =
        AnyModel::new(kind, &outcome.params[..k]).expect("fitted parameters lie inside the valid box");
    FitReport {
        dataset: dataset.name.clone(),
        model: kind.name(),
        params: Ordered(
            kind.param_names()
                .iter()
                .zip(&outcome.params)
                .map(|(n, v)| ((*n).to_owned(), *v))
                .collect(),
        ),
        metrics: metrics(&values, &y),
        per_incidence,
        n,
        k,
        aic: ll + 2.0 * k as f64,
        bic: ll + k as f64 * nf.ln(),
        seconds: outcome.seconds,
        residual: problem.residual().name(),
        seed,
        cost: outcome.cost,
        evals: outcome.evals,
        converged: outcome.converged,
        uncertainty: uncertainty(problem, outcome),
        energy: energy(&model, &incidences),
    }
}
