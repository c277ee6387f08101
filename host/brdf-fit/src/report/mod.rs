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

mod energy;
mod influence;
mod uncertainty;

pub use energy::*;
pub use influence::*;
pub use uncertainty::*;

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
pub(crate) fn f64_or_null<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
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
    /// Root-mean-square relative error `(f - y) / y` (`(f - y) / sqrt(y^2 + S^2)` under a
    /// noise floor `S`, [`crate::noise`]).
    #[serde(deserialize_with = "f64_or_null")]
    pub rms_rel: f64,
    /// Largest `|f - y| / y` (floored as `rms_rel`).
    #[serde(deserialize_with = "f64_or_null")]
    pub max_rel: f64,
    /// Root-mean-square of `ln f - ln y` (undefined, `null`, with readings at or below zero).
    #[serde(deserialize_with = "f64_or_null")]
    pub log_rmse: f64,
}

/// Metrics of model values `f` against measurements `y`.
pub fn metrics(f: &[f64], y: &[f64]) -> Metrics {
    metrics_floored(f, y, 0.0)
}

/// [`metrics`] with the relative errors taken over `sqrt(y^2 + floor^2)` (a noise floor,
/// [`crate::noise`]; `floor` 0 gives [`metrics`]). `log_rmse` is NaN when a reading is at or
/// below zero.
pub fn metrics_floored(f: &[f64], y: &[f64], floor: f64) -> Metrics {
    let n = f.len().max(1) as f64;
    let (mut se, mut sr, mut mr, mut sl) = (0.0, 0.0, 0.0_f64, 0.0);
    for (&f, &y) in f.iter().zip(y) {
        se += (f - y) * (f - y);
        let rel = crate::noise::floored_relative(f, y, floor);
        sr += rel * rel;
        mr = mr.max(rel.abs());
        let l = if y <= 0.0 {
            f64::NAN
        } else if f > 0.0 {
            f.ln() - y.ln()
        } else {
            f64::INFINITY
        };
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
pub(crate) fn degrees(rad: f64) -> f64 {
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
    /// Incidence zenith, degrees (the mean over a 1-degree bin when the data have more than
    /// `data::MAX_INCIDENCE_GROUPS` distinct incidences: `Dataset::incidence_groups`).
    #[serde(deserialize_with = "f64_or_null")]
    pub theta_i: f64,
    /// Points at this incidence.
    pub n: usize,
    /// Their metrics.
    #[serde(flatten)]
    pub metrics: Metrics,
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
    /// Akaike information criterion `m ln(RSS/m) + 2k` on the fitted residuals, `m` the
    /// distinct rows and `RSS` their residuals' sum, each once (an exact copy of a row is no
    /// second observation: [`distinct_rows`]).
    #[serde(deserialize_with = "f64_or_null")]
    pub aic: f64,
    /// Bayesian information criterion `m ln(RSS/m) + k ln m`, as [`FitReport::aic`].
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
    /// A correction tabulated over this model (`brdf select --chosen` when a fitted table
    /// was chosen): the representation is then `f = f_model * exp(t)`, and `metrics` above
    /// are the base model's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fitted_table: Option<crate::fitted_table::TableRecord>,
    /// The noise floor of the relative residual and of the relative metrics
    /// ([`crate::noise`]), when the data had readings at or below zero or a floor was given
    /// ([`crate::FitSettings::fit`] sets it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_floor: Option<crate::noise::NoiseFloor>,
    /// When the dataset is one band of a spectral measurement fitted with one shape shared
    /// by its other bands: how many, and the summed cost ([`crate::spectral`]); absent for a
    /// band fitted on its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bands: Option<crate::spectral::BandsInfo>,
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
    /// A parameter the model does not have (it would be ignored).
    #[error("{origin}: unknown parameter `{name}` for the {model} model (expected {expected})")]
    UnknownParam {
        /// File and fit index.
        origin: String,
        /// The name given.
        name: String,
        /// The model.
        model: &'static str,
        /// Its parameter names.
        expected: String,
    },
    /// A parameter given twice (which value was meant is unknown).
    #[error("{origin}: parameter `{name}` given twice")]
    DuplicateParam {
        /// File and fit index.
        origin: String,
        /// The parameter.
        name: String,
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
    /// A field no fit result has (a misspelt `fitted_table` would drop the table unnoticed),
    /// or `fitted_table: null` (a fit without a table leaves the key out).
    #[error("{origin}: {problem}")]
    Field {
        /// File and fit index.
        origin: String,
        /// What is wrong.
        problem: String,
    },
}

/// Every field of a fit result ([`FitReport`] as `brdf fit --json` and `brdf select
/// --chosen` write it; a test keeps the list equal to the struct's). A reader refuses any
/// other ([`ReadError::Field`]): consumers that need only the model read whole reports, so
/// without the list a misspelt key would be skipped as one of the report's own.
pub const FIT_RESULT_FIELDS: [&str; 25] = [
    "dataset",
    "model",
    "params",
    "metrics",
    "per_incidence",
    "n",
    "k",
    "aic",
    "bic",
    "seconds",
    "residual",
    "seed",
    "cost",
    "evals",
    "converged",
    "search",
    "loss",
    "brightening",
    "influence",
    "uncertainty",
    "energy",
    "outside_ranges",
    "fitted_table",
    "noise_floor",
    "bands",
];

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
    /// The dataset the fit is of (`FILE[wavelength=0.55]` for a band of a spectral
    /// measurement); absent in a hand-written result.
    #[serde(default)]
    pub dataset: Option<String>,
    /// The model (written as its name).
    #[serde(with = "model_name")]
    pub model: ModelKind,
    /// Parameters by name, paper order and signs (`b` negative).
    pub params: Ordered<f64>,
    /// A correction tabulated over the model ([`FitReport::fitted_table`]).
    #[serde(default)]
    pub fitted_table: Option<crate::fitted_table::TableRecord>,
}

/// One fit of a fit-result file: its model, parameters in paper order and, for a fitted
/// table, the table's device bytes (checked).
#[derive(Clone, Debug, PartialEq)]
pub struct OneFit {
    /// The model (the base, with a table).
    pub model: ModelKind,
    /// Parameters in paper order (unused entries 0).
    pub params: [f64; MAX_PARAMS],
    /// The fitted table's bytes ([`brdf_core::fitted`]), if any.
    pub table: Option<Vec<u8>>,
    /// Index of the fit in the file.
    pub index: usize,
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
/// of its model once and nothing else.
fn read_fits<T: serde::de::DeserializeOwned>(
    text: &str,
    origin: &str,
    params: impl Fn(&T) -> (ModelKind, &Ordered<f64>),
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
        if let Ok(fields) = serde_json::from_str::<serde_json::Map<String, serde_json::Value>>(part) {
            if let Some(name) = fields.keys().find(|k| !FIT_RESULT_FIELDS.contains(&k.as_str())) {
                return Err(ReadError::Field {
                    origin,
                    problem: format!(
                        "unknown field `{name}` (a fit result has: {})",
                        FIT_RESULT_FIELDS.join(", ")
                    ),
                });
            }
            if fields.get("fitted_table").is_some_and(serde_json::Value::is_null) {
                return Err(ReadError::Field {
                    origin,
                    problem: "fitted_table: null: leave the field out for a fit without a table".into(),
                });
            }
        }
        let (kind, given) = params(&r);
        for (k, (name, _)) in given.0.iter().enumerate() {
            if !kind.param_names().contains(&name.as_str()) {
                return Err(ReadError::UnknownParam {
                    origin,
                    name: name.clone(),
                    model: kind.name(),
                    expected: kind.param_names().join(", "),
                });
            }
            if given.0[..k].iter().any(|(n, _)| n == name) {
                return Err(ReadError::DuplicateParam {
                    origin,
                    name: name.clone(),
                });
            }
        }
        params_in_order(kind, given).map_err(|name| ReadError::MissingParam {
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
        read_fits(text, origin, |r: &FittedModel| (r.model, &r.params))
    }

    /// The parameters in paper order (unused entries 0), or the name of one that is missing.
    pub fn params_array(&self) -> Result<[f64; MAX_PARAMS], &'static str> {
        params_in_order(self.model, &self.params)
    }

    /// The one fit of `text` that a consumer of one material means: the only one, or the
    /// `index`-th of a batch (`brdf eval --fit`, a scene file's `fit =`, `brdf.eval_fit`).
    /// Returns its model, its parameters in paper order and its index; the error says how
    /// many fits the text holds and which indices exist.
    pub fn one_of(text: &str, origin: &str, index: Option<usize>) -> Result<OneFit, String> {
        let fits = FittedModel::from_json(text, origin).map_err(|e| e.to_string())?;
        let n = fits.len();
        if n == 0 {
            return Err(format!("{origin}: holds no fit"));
        }
        let k = match index {
            Some(k) if k < n => k,
            Some(k) if n == 1 => return Err(format!("{origin}: holds one fit; there is no index {k}")),
            Some(k) => return Err(format!("{origin}: holds {n} fits; there is no index {k}")),
            None if n == 1 => 0,
            None => {
                return Err(format!(
                    "{origin}: holds {n} fits: say which with index 0..{}",
                    n.saturating_sub(1)
                ))
            }
        };
        let p = fits[k]
            .params_array()
            .map_err(|p| format!("{origin}: parameter `{p}` missing"))?;
        let table = fits[k]
            .table_bytes()
            .map_err(|e| format!("{origin}: fit {k}: {e}"))?;
        Ok(OneFit {
            model: fits[k].model,
            params: p,
            table,
            index: k,
        })
    }

    /// The fitted table's device bytes, checked and verified against this base
    /// ([`crate::fitted_table::TableRecord::verify`]), if the fit carries one.
    pub fn table_bytes(&self) -> Result<Option<Vec<u8>>, String> {
        let Some(t) = &self.fitted_table else {
            return Ok(None);
        };
        let p = params_in_order(self.model, &self.params).map_err(|p| format!("parameter `{p}` missing"))?;
        t.verify(self.model, &p).map(Some)
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
        read_fits(text, origin, |r: &FitReport| (r.model, &r.params))
    }

    /// The model and parameters alone.
    pub fn fitted(&self) -> FittedModel {
        FittedModel {
            dataset: Some(self.dataset.clone()),
            model: self.model,
            params: self.params.clone(),
            fitted_table: self.fitted_table.clone(),
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

/// The parameters of `kind` (paper order) outside their ranges (`brdf_core::ranges`), as a
/// report lists them ([`FitReport::outside_ranges`]): `"kd = 30 is not in [0, 10]"`.
pub fn outside_ranges(kind: ModelKind, params: &[f64]) -> Vec<String> {
    kind.ranges()
        .iter()
        .zip(params)
        .filter(|(r, &v)| !r.contains(v))
        .map(|(r, v)| format!("{} = {v} is not {}", r.name, r.text))
        .collect()
}

/// Builds the report of a finished fit.
pub fn report(dataset: &Dataset, problem: &Problem, outcome: &FitOutcome, opts: &FitOptions) -> FitReport {
    let kind: ModelKind = outcome.kind;
    let values = problem.values(&outcome.q);
    let y: Vec<f64> = dataset.points.iter().map(|p| p.brdf).collect();
    let floor = problem.floor();
    let groups = dataset.incidence_groups();
    let incidences: Vec<f64> = groups.iter().map(|g| g.0).collect();
    let per_incidence = groups
        .iter()
        .map(|(ti, members)| {
            let (f, yy): (Vec<f64>, Vec<f64>) = members
                .iter()
                .map(|&k| (values[k], dataset.points[k].brdf))
                .unzip();
            IncidenceMetrics {
                theta_i: degrees(*ti),
                n: f.len(),
                metrics: metrics_floored(&f, &yy, floor),
            }
        })
        .collect();
    let n = problem.len();
    let k = kind.param_count();
    // The information criteria over distinct rows, each once ([`row_copies`]): an exact copy
    // of a row is no second observation. The cost less what the copies add (the cost itself,
    // to the bit, when there are none).
    let copies = row_copies(dataset, kind);
    let repeated: f64 = copies
        .iter()
        .filter(|g| g.len() > 1)
        .map(|g| {
            let r = problem.residual_of(g[0], values[g[0]]);
            (g.len() - 1) as f64 * problem.loss().eval(r * r).0
        })
        .sum();
    let rss = 2.0 * outcome.cost - repeated;
    let nf = copies.len() as f64;
    let ll = nf * (rss / nf).max(1e-300).ln();
    let params = &outcome.params[..k];
    let outside_ranges = outside_ranges(kind, params);
    let unc = uncertainty(problem, outcome, copies.len());
    // A profile refit below the optimum: the search missed it, whatever it said.
    let (mut converged, mut search) = (outcome.converged, outcome.search.clone());
    if let Some(c) = unc.refit_below {
        converged = false;
        search.not_converged = Some(format!(
            "a profile refit of the report (one parameter held, the others refitted) reached cost \
             {c:e}, below the optimum's {:e}: the search missed the optimum",
            outcome.cost
        ));
    }
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
        metrics: metrics_floored(&values, &y, floor),
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
        converged,
        search,
        loss: problem.loss(),
        brightening: problem.brightening(),
        influence: influence(dataset, problem, outcome, opts),
        uncertainty: unc,
        energy: energy_of(kind, params, &energy::checked_incidences(&incidences)),
        outside_ranges,
        fitted_table: None,
        noise_floor: None,
        bands: None,
    }
}
