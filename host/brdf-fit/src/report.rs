//! What a fit says: metrics (overall and per incidence), parameter uncertainty with plain
//! flags on what the data do not determine, and the energy check.

use brdf_core::batch::Batch;
use brdf_core::checks::{albedo_batch, AlbedoRule};
use brdf_core::{AnyModel, ModelKind, MAX_PARAMS};
use rayon::prelude::*;
use serde::de::{MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::data::Dataset;
use crate::fit::{FitOptions, FitOutcome, SearchSummary};
use crate::kernel::natural_per_internal;
use crate::problem::{Loss, Problem, Residual};

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

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Ordered<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct InOrder<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for InOrder<T> {
            type Value = Ordered<T>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an object")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Ordered<T>, A::Error> {
                let mut v = Vec::new();
                while let Some(entry) = map.next_entry()? {
                    v.push(entry);
                }
                Ok(Ordered(v))
            }
        }
        d.deserialize_map(InOrder(std::marker::PhantomData))
    }
}

impl<T> Ordered<T> {
    /// The value named `name`.
    pub fn get(&self, name: &str) -> Option<&T> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }
}

/// JSON has no NaN or infinity: serde_json writes them as `null`, and this reads `null` back
/// as NaN (a metric of data with zeros, say), so that every report written can be read.
fn f64_or_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// A [`ModelKind`] as its name (`"six"`, `"lambert"`, ...), as the CLI spells it.
pub mod model_name {
    use brdf_core::ModelKind;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the name.
    pub fn serialize<S: Serializer>(kind: &ModelKind, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(kind.name())
    }

    /// Reads a name, naming the known ones when it is not one of them.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<ModelKind, D::Error> {
        let name = String::deserialize(d)?;
        name.parse::<ModelKind>().map_err(serde::de::Error::custom)
    }
}

/// Goodness of fit, unweighted, on the BRDF values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Root-mean-square error, 1/sr.
    #[serde(deserialize_with = "f64_or_null")]
    pub rmse: f64,
    /// Mean squared error, 1/sr^2.
    #[serde(deserialize_with = "f64_or_null")]
    pub mse: f64,
    /// Root-mean-square relative error `(f - y) / y`.
    #[serde(deserialize_with = "f64_or_null")]
    pub rms_rel: f64,
    /// Largest `|f - y| / y`.
    #[serde(deserialize_with = "f64_or_null")]
    pub max_rel: f64,
    /// Root-mean-square of `ln f - ln y`.
    #[serde(deserialize_with = "f64_or_null")]
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

/// [`IncidenceMetrics`] as written, read without `#[serde(flatten)]`: serde buffers flattened
/// fields, and a buffered number does not read back as `f64` when serde_json's
/// `arbitrary_precision` feature is on anywhere in the build.
#[derive(Deserialize)]
struct FlatIncidenceMetrics {
    #[serde(deserialize_with = "f64_or_null")]
    theta_i: f64,
    n: usize,
    #[serde(deserialize_with = "f64_or_null")]
    rmse: f64,
    #[serde(deserialize_with = "f64_or_null")]
    mse: f64,
    #[serde(deserialize_with = "f64_or_null")]
    rms_rel: f64,
    #[serde(deserialize_with = "f64_or_null")]
    max_rel: f64,
    #[serde(deserialize_with = "f64_or_null")]
    log_rmse: f64,
}

impl From<FlatIncidenceMetrics> for IncidenceMetrics {
    fn from(f: FlatIncidenceMetrics) -> Self {
        IncidenceMetrics {
            theta_i: f.theta_i,
            n: f.n,
            metrics: Metrics {
                rmse: f.rmse,
                mse: f.mse,
                rms_rel: f.rms_rel,
                max_rel: f.max_rel,
                log_rmse: f.log_rmse,
            },
        }
    }
}

/// Metrics of the points at one incidence angle.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "FlatIncidenceMetrics")]
pub struct IncidenceMetrics {
    /// Incidence zenith, degrees.
    #[serde(deserialize_with = "f64_or_null")]
    pub theta_i: f64,
    /// Points at this incidence.
    pub n: usize,
    /// Their metrics.
    #[serde(flatten)]
    pub metrics: Metrics,
}

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
            let r = crate::lm::minimise(problem, &start, &flo, &fhi, crate::lm::LmOptions::default());
            Some(2.0 * (r.cost - outcome.cost).max(0.0) / s2)
        })
        .reduce_with(f64::min)
}

/// `x` with six significant digits and no trailing zeros (1000, not 999.9999999999998).
fn short(x: f64) -> String {
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
fn on_bound(q: f64, lo: f64, hi: f64) -> Option<f64> {
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
fn symmetric_eigen(
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
/// variance `2 cost / (n - p)`.
///
/// Parameters on a search bound are held there; parameters with no effect on the model at
/// the optimum (the lobe's `kr`, `b`, `a` when `kb = 0`) are reported as such; directions in
/// which `J^T J` is singular name the parameters that share them, and only those. Every
/// other parameter gets its standard error and the profile test.
pub fn uncertainty(problem: &Problem, outcome: &FitOutcome) -> Uncertainty {
    let kind = outcome.kind;
    let p = kind.param_count();
    let names = kind.param_names();
    let (lo, hi) = problem.bounds();
    let jtj = problem.jacobian_gram(&outcome.q);
    let lobe_model = matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five);
    let lobe_off = lobe_model && outcome.q[0] == 0.0;
    let mut note: Vec<Option<String>> = vec![None; p];
    for j in 0..p {
        if let Some(bound) = on_bound(outcome.q[j], lo[j], hi[j]) {
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
    let dof = problem.len().saturating_sub(free.len());
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
    let rises: Vec<Option<f64>> = (0..p)
        .into_par_iter()
        .map(|j| {
            let estimated = note[j].is_none() && cov[j][j].is_finite() && cov[j][j] >= 0.0;
            if estimated && s2 > 0.0 {
                profile_rise(problem, outcome, j, s2)
            } else {
                None
            }
        })
        .collect();
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
                Some("its variance is not defined (fewer points than parameters)".to_owned()),
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
    }
}

/// Quadrature albedo at one measured incidence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IncidenceAlbedo {
    /// Incidence zenith, degrees.
    #[serde(deserialize_with = "f64_or_null")]
    pub theta_i: f64,
    /// Directional-hemispherical reflectance (default rule, accurate to
    /// `brdf_core::tolerance::ALBEDO_DEFAULT_REL`).
    #[serde(deserialize_with = "f64_or_null")]
    pub albedo: f64,
}

/// The energy check of a fitted model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
    let batch = Batch::new(model);
    let albedo: Vec<IncidenceAlbedo> = incidences
        .par_iter()
        .map(|&ti| IncidenceAlbedo {
            theta_i: degrees(ti),
            albedo: albedo_batch(&batch, ti, AlbedoRule::DEFAULT),
        })
        .collect();
    Energy {
        bound,
        bound_conserves: matches!(bound, Some(b) if b <= 1.0),
        albedo_conserves: albedo.iter().all(|a| a.albedo <= 1.0),
        albedo,
    }
}

/// Energy check of a fitted parameter vector (paper order and signs), which may hold linear
/// weights above their ranges (see [`FitReport::outside_ranges`]). The bound and every albedo
/// are linear in the weights, so the check runs on the weights scaled into range and
/// scales the results back.
pub fn energy_of(kind: ModelKind, params: &[f64], incidences: &[f64]) -> Energy {
    let ranges = kind.ranges();
    let linear: Vec<usize> = (0..params.len())
        .filter(|i| !crate::problem::nonlinear_indices(kind).contains(i))
        .collect();
    let scale = linear
        .iter()
        .map(|&i| params[i] / f64::from(ranges[i].max))
        .fold(1.0_f64, f64::max);
    let mut scaled = params.to_vec();
    for &i in &linear {
        // `min`: only the division's rounding can carry the largest weight past its bound.
        scaled[i] = (scaled[i] / scale).min(f64::from(ranges[i].max));
    }
    let model = AnyModel::new(kind, &scaled).expect("the fitter's nonlinear box lies inside the ranges");
    let mut e = energy(&model, incidences);
    if scale > 1.0 {
        e.bound = e.bound.map(|b| b * scale);
        for a in &mut e.albedo {
            a.albedo *= scale;
        }
        e.bound_conserves = matches!(e.bound, Some(b) if b <= 1.0);
        e.albedo_conserves = e.albedo.iter().all(|a| a.albedo <= 1.0);
    }
    e
}

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

/// Leave-one-out influence: the linearised cost drop `0.5 r^2 / (1 - h)` ranks the points,
/// the top [`INFLUENCE_CANDIDATES`] are refitted without the point (a local polish from the
/// optimum, and the whole global search where that already removes more than the dominant
/// fraction, since one point can hold the fit in another basin).
pub fn influence(dataset: &Dataset, problem: &Problem, outcome: &FitOutcome, opts: &FitOptions) -> Influence {
    let n = problem.len();
    let dominant_above = dominant_fraction(n);
    let kind = outcome.kind;
    let p = kind.param_count();
    if n <= p + 1 || outcome.cost <= 0.0 || !outcome.cost.is_finite() {
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
    // Leverage, one Jacobian row at a time (no n x p matrix held).
    let hat = |i: usize| -> f64 {
        let row = problem.jacobian_row(i, &outcome.q);
        let mut h = 0.0;
        for (x, &a) in free.iter().enumerate() {
            for (y, &b) in free.iter().enumerate() {
                h += row[a] * pinv[x][y] * row[b];
            }
        }
        h.clamp(0.0, 1.0 - 1e-12)
    };
    let mut ranked: Vec<(usize, f64, f64)> = (0..n)
        .map(|i| {
            let r = problem.residual_of(i, values[i]);
            let h = hat(i);
            (i, 0.5 * problem.loss().eval(r * r).0 / (1.0 - h), h)
        })
        .collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut points: Vec<PointInfluence> = ranked
        .iter()
        .take(INFLUENCE_CANDIDATES)
        .map(|&(i, _, h)| {
            let without = problem.without(i);
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
                .map(|k| ((f[k] - without.target(k)) / without.target(k)).powi(2))
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
                standardized: r / (s2 * (1.0 - h)).sqrt(),
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
fn pseudo_inverse(gram: &[[f64; MAX_PARAMS]; MAX_PARAMS], free: &[usize]) -> [[f64; MAX_PARAMS]; MAX_PARAMS] {
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

/// Everything `brdf fit --json` prints for one dataset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// Dataset name (file, and group if any).
    pub dataset: String,
    /// The model (written as its name).
    #[serde(with = "model_name")]
    pub model: ModelKind,
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
    #[serde(deserialize_with = "f64_or_null")]
    pub aic: f64,
    /// Bayesian information criterion `n ln(RSS/n) + k ln n`.
    #[serde(deserialize_with = "f64_or_null")]
    pub bic: f64,
    /// Wall time of the fit, seconds.
    #[serde(deserialize_with = "f64_or_null")]
    pub seconds: f64,
    /// Residual form.
    pub residual: Residual,
    /// Seed of the run.
    pub seed: u64,
    /// `0.5 * sum r^2` at the optimum.
    #[serde(deserialize_with = "f64_or_null")]
    pub cost: f64,
    /// Passes over the data.
    pub evals: usize,
    /// The global search met every convergence test (see `brdf_fit::fit`); when false,
    /// `search.not_converged` says why.
    pub converged: bool,
    /// How the global search went.
    pub search: SearchSummary,
    /// Robust loss of the fit.
    pub loss: Loss,
    /// The six-parameter `c` was searched below 0 (`--brightening`).
    pub brightening: bool,
    /// The points whose removal changes the fit most.
    pub influence: Influence,
    /// Parameter uncertainty and undetermined-parameter flags.
    pub uncertainty: Uncertainty,
    /// Energy check.
    pub energy: Energy,
    /// Parameters outside the model's valid ranges (`brdf_core::ranges`), each as
    /// `"kb = 12000 is not in [0, 10000]"`. The fitter bounds the linear weights only below
    /// (a bound above would make the fit depend on the data's units), so an uncalibrated
    /// dataset can fit weights no device accepts: such a fit cannot be packed.
    pub outside_ranges: Vec<String>,
}

/// Why a fit result could not be read back.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// Not JSON, or not shaped like `brdf fit --json` output.
    #[error("{origin}: line {line}, column {column}: {message}")]
    Json {
        /// File, and fit index in an array (`fits.json: fit 2`).
        origin: String,
        /// Line in the file (1-based).
        line: usize,
        /// Column in that line (1-based).
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A parameter of the model is missing.
    #[error("{origin}: no parameter `{name}` for the {model} model")]
    MissingParam {
        /// File and fit index.
        origin: String,
        /// The parameter.
        name: &'static str,
        /// The model.
        model: &'static str,
    },
}

impl ReadError {
    /// A serde_json error in `part`, a slice of `text` (positions made absolute in `text`).
    fn json(origin: String, text: &str, part: &str, e: &serde_json::Error) -> ReadError {
        let offset = (part.as_ptr() as usize)
            .saturating_sub(text.as_ptr() as usize)
            .min(text.len());
        let before = &text[..offset];
        let lines_before = before.matches('\n').count();
        let line_start_col = before.len() - before.rfind('\n').map_or(0, |k| k + 1);
        let (line, column) = match e.line() {
            0 => (lines_before + 1, line_start_col + 1),
            1 => (lines_before + 1, line_start_col + e.column()),
            l => (lines_before + l, e.column()),
        };
        let full = e.to_string();
        let suffix = format!(" at line {} column {}", e.line(), e.column());
        ReadError::Json {
            origin,
            line,
            column,
            message: full.strip_suffix(&suffix).unwrap_or(&full).to_owned(),
        }
    }
}

/// The part of a fit result a device or a scene needs: the model and its parameters. Reads
/// whole `brdf fit --json` output (the other fields are skipped) as well as a hand-written
/// `{"model": "six", "params": {"kb": 0.25, ...}}`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
pub struct FittedModel {
    /// The model (written as its name).
    #[serde(with = "model_name")]
    pub model: ModelKind,
    /// Parameters by name, paper order and signs (`b` negative).
    pub params: Ordered<f64>,
}

/// The parameters of `kind` from a name-to-value map, in paper order (unused entries 0), or
/// the name of one that is missing.
fn params_in_order(kind: ModelKind, params: &Ordered<f64>) -> Result<[f64; MAX_PARAMS], &'static str> {
    let mut p = [0.0; MAX_PARAMS];
    for (v, name) in p.iter_mut().zip(kind.param_names()) {
        *v = *params.get(name).ok_or(*name)?;
    }
    Ok(p)
}

/// One fit result, or an array of them, from `text`, each checked to name every parameter
/// of its model.
fn read_fits<T: serde::de::DeserializeOwned>(
    text: &str,
    origin: &str,
    params: impl Fn(&T) -> (ModelKind, Result<[f64; MAX_PARAMS], &'static str>),
) -> Result<Vec<T>, ReadError> {
    let items: Vec<&serde_json::value::RawValue> = if text.trim_start().starts_with('[') {
        serde_json::from_str(text).map_err(|e| ReadError::json(origin.to_owned(), text, text, &e))?
    } else {
        vec![serde_json::from_str(text).map_err(|e| ReadError::json(origin.to_owned(), text, text, &e))?]
    };
    let mut out = Vec::with_capacity(items.len());
    for (i, item) in items.into_iter().enumerate() {
        let origin = format!("{origin}: fit {i}");
        let part = item.get();
        let r: T = serde_json::from_str(part).map_err(|e| ReadError::json(origin.clone(), text, part, &e))?;
        let (kind, p) = params(&r);
        p.map_err(|name| ReadError::MissingParam {
            origin,
            name,
            model: kind.name(),
        })?;
        out.push(r);
    }
    Ok(out)
}

impl FittedModel {
    /// Reads one fit result or an array of them (see [`FitReport::from_json`]).
    pub fn from_json(text: &str, origin: &str) -> Result<Vec<FittedModel>, ReadError> {
        read_fits(text, origin, |r: &FittedModel| (r.model, r.params_array()))
    }

    /// The parameters in paper order (unused entries 0), or the name of one that is missing.
    pub fn params_array(&self) -> Result<[f64; MAX_PARAMS], &'static str> {
        params_in_order(self.model, &self.params)
    }

    /// The model in f64, refused naming the parameter when one is missing or outside its
    /// range.
    pub fn model(&self) -> Result<AnyModel<f64>, brdf_core::ParamError> {
        let p = self.params_array().unwrap_or([f64::NAN; MAX_PARAMS]);
        AnyModel::new(self.model, &p[..self.model.param_count()])
    }
}

impl FitReport {
    /// Reads `brdf fit --json` output: one report, or an array of them (a batch fit).
    /// `origin` names the source in errors (`fits.json: fit 2: line 40, column 12: ...`).
    pub fn from_json(text: &str, origin: &str) -> Result<Vec<FitReport>, ReadError> {
        read_fits(text, origin, |r: &FitReport| (r.model, r.params_array()))
    }

    /// The model and parameters alone.
    pub fn fitted(&self) -> FittedModel {
        FittedModel {
            model: self.model,
            params: self.params.clone(),
        }
    }

    /// The parameters in paper order (unused entries 0), or the name of one that is missing.
    pub fn params_array(&self) -> Result<[f64; MAX_PARAMS], &'static str> {
        params_in_order(self.model, &self.params)
    }

    /// The fitted model in f64 (refused, naming the parameter, when a parameter is outside
    /// its range: see [`FitReport::outside_ranges`]).
    pub fn model(&self) -> Result<AnyModel<f64>, brdf_core::ParamError> {
        self.fitted().model()
    }

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
pub fn report(dataset: &Dataset, problem: &Problem, outcome: &FitOutcome, opts: &FitOptions) -> FitReport {
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
    let params = &outcome.params[..k];
    let outside_ranges: Vec<String> = kind
        .ranges()
        .iter()
        .zip(params)
        .filter(|(r, &v)| !r.contains(v))
        .map(|(r, v)| format!("{} = {v} is not {}", r.name, r.text))
        .collect();
    FitReport {
        dataset: dataset.name.clone(),
        model: kind,
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
        residual: problem.residual(),
        seed: opts.seed,
        cost: outcome.cost,
        evals: outcome.evals,
        converged: outcome.converged,
        search: outcome.search.clone(),
        loss: problem.loss(),
        brightening: problem.brightening(),
        influence: influence(dataset, problem, outcome, opts),
        uncertainty: uncertainty(problem, outcome),
        energy: energy_of(kind, params, &incidences),
        outside_ranges,
    }
}
