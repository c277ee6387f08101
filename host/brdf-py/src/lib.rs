//! `brdf._brdf`: the compiled half of the Python package `brdf`.
//!
//! The Python half (`python/brdf/__init__.py`) broadcasts, converts dtypes and formats
//! locations; this half takes flat, contiguous `float64` arrays, releases the GIL and calls
//! the same library functions as the `brdf` command, so values and messages are the CLI's.
//! Errors about one element are raised as [`ElementError`] with `(flat index, message)`;
//! the Python half turns the flat index into the caller's array index.

#![warn(missing_docs)]

use brdf_core::batch::par::{self, Inputs};
use brdf_core::batch::{Batch, BatchError};
use brdf_core::names::UnknownName;
use brdf_core::{AnyModel, Brdf, Float, ModelKind};
use brdf_fit::import::{import, Channel, Format};
use brdf_fit::{
    load_csv, Dataset, FitOptions, FitRequest, FitSettings, LoadOptions, Point, Residual, RowDegrees,
};
use numpy::{PyArray1, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

create_exception!(
    _brdf,
    ElementError,
    PyValueError,
    "A bad input element: args are (flat index, message)."
);

/// A failure located at one element (flat index) or at no element.
enum Failure {
    /// Element `0` is bad: `1` says why.
    At(usize, String),
    /// Not about one element.
    General(String),
}

impl From<Failure> for PyErr {
    fn from(f: Failure) -> PyErr {
        match f {
            Failure::At(i, m) => ElementError::new_err((i, m)),
            Failure::General(m) => PyValueError::new_err(m),
        }
    }
}

/// Parses a name of the libraries' vocabulary as the CLI does (the same message).
fn parse<T: std::str::FromStr<Err = UnknownName>>(name: &str) -> PyResult<T> {
    name.parse::<T>()
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Parses a model name as `brdf --model` does.
fn parse_kind(name: &str) -> Result<ModelKind, Failure> {
    name.parse::<ModelKind>()
        .map_err(|e| Failure::General(e.to_string()))
}

/// [`parse_kind`] for functions that raise `ValueError` directly.
fn kind_of(name: &str) -> PyResult<ModelKind> {
    Ok(parse_kind(name)?)
}

/// The model `kind` with `params` (`kb=...,kr=...`) in precision `T`, each parameter
/// rounded once to `T`, as `brdf eval` builds it.
fn build<T: Float>(kind: ModelKind, params: &str) -> Result<AnyModel<T>, Failure> {
    let p = brdf_fit::params::parse_params(kind, params).map_err(|e| Failure::General(e.to_string()))?;
    brdf_fit::params::build(kind, &p).map_err(Failure::General)
}

/// A contiguous view of a 1-d float64 array (the Python half makes them contiguous).
fn slice<'a>(a: &'a PyReadonlyArray1<'_, f64>, name: &str) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name}: internal: array is not contiguous")))
}

/// The first non-finite value as the CLI reports it.
fn finite<T: Float>(values: &[T], kind: ModelKind) -> Result<(), Failure> {
    match values.iter().position(|f| !f.is_finite()) {
        None => Ok(()),
        Some(i) => Err(Failure::At(i, brdf_fit::params::not_finite(values[i], kind))),
    }
}

fn batch_failure(e: BatchError) -> Failure {
    match e {
        BatchError::Domain { index, error } => Failure::At(index, error.to_string()),
        other => Failure::General(other.to_string()),
    }
}

/// Validates angles in degrees as `brdf eval` validates its CSV rows.
fn check_degrees(cols: [&[f64]; 3]) -> Result<(), Failure> {
    for i in 0..cols[0].len() {
        brdf_fit::params::check_eval_degrees([cols[0][i], cols[1][i], cols[2][i]])
            .map_err(|e| Failure::At(i, e))?;
    }
    Ok(())
}

/// Angles in degrees to radians in f64, rounded once to `T` (as `brdf eval`).
fn radians<T: Float>(deg: &[f64]) -> Vec<T> {
    deg.iter().map(|d| T::from_f64(d.to_radians())).collect()
}

/// `brdf eval` on arrays: f64 through the batch path, f32 through the scalar path (the
/// firmware's arithmetic); on all cores when `parallel` (each value the same bit for bit).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn eval_angles<'py>(
    py: Python<'py>,
    model: &str,
    params: &str,
    theta_i: PyReadonlyArray1<'py, f64>,
    theta_r: PyReadonlyArray1<'py, f64>,
    phi: PyReadonlyArray1<'py, f64>,
    precision: &str,
    parallel: bool,
) -> PyResult<Bound<'py, PyAny>> {
    use rayon::prelude::*;
    let kind = parse_kind(model)?;
    let cols = [
        slice(&theta_i, "theta_i")?,
        slice(&theta_r, "theta_r")?,
        slice(&phi, "phi")?,
    ];
    match precision {
        "f64" => {
            let m: AnyModel<f64> = build(kind, params)?;
            let out = py.detach(|| -> Result<Vec<f64>, Failure> {
                check_degrees(cols)?;
                let [a, b, c] = cols.map(radians::<f64>);
                let mut out = vec![0.0; a.len()];
                par::eval(&Batch::new(&m), Inputs::Angles([&a, &b, &c]), &mut out, parallel)
                    .map_err(batch_failure)?;
                finite(&out, kind)?;
                Ok(out)
            })?;
            Ok(PyArray1::from_vec(py, out).into_any())
        }
        "f32" => {
            let m: AnyModel<f32> = build(kind, params)?;
            let out = py.detach(|| -> Result<Vec<f32>, Failure> {
                check_degrees(cols)?;
                let [a, b, c] = cols.map(radians::<f32>);
                let one = |i: usize| m.eval_angles(a[i], b[i], c[i]);
                let out: Vec<f32> = if parallel {
                    (0..a.len())
                        .into_par_iter()
                        .with_min_len(par::PAR_CHUNK)
                        .map(one)
                        .collect()
                } else {
                    (0..a.len()).map(one).collect()
                };
                finite(&out, kind)?;
                Ok(out)
            })?;
            Ok(PyArray1::from_vec(py, out).into_any())
        }
        other => Err(PyValueError::new_err(format!(
            "unknown precision `{other}` (expected f64 or f32)"
        ))),
    }
}

/// Directional-hemispherical reflectance at incidences `theta_i` (degrees) through the batch
/// path, by `brdf_core::checks::albedo_batch` with `panels` panels (the fit report's energy
/// check uses the default 8).
#[pyfunction]
fn albedo<'py>(
    py: Python<'py>,
    model: &str,
    params: &str,
    theta_i: PyReadonlyArray1<'py, f64>,
    panels: u16,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    use brdf_core::checks::{albedo_batch, AlbedoRule};
    let kind = parse_kind(model)?;
    let m: AnyModel<f64> = build(kind, params)?;
    if panels < 2 {
        return Err(PyValueError::new_err(format!("panels {panels}: need at least 2")));
    }
    let ti = slice(&theta_i, "theta_i")?;
    let out = py.detach(|| -> Result<Vec<f64>, Failure> {
        for (i, &v) in ti.iter().enumerate() {
            if !(v.is_finite() && (0.0..=90.0).contains(&v)) {
                return Err(Failure::At(
                    i,
                    format!("theta_i: zenith {v} deg is outside [0, 90]"),
                ));
            }
        }
        let b = Batch::new(&m);
        Ok(ti
            .iter()
            .map(|d| albedo_batch(&b, d.to_radians(), AlbedoRule { panels }))
            .collect())
    })?;
    Ok(PyArray1::from_vec(py, out))
}

/// Evaluates cosines or vectors in precision `T` through the batch path (on all cores when
/// `parallel`).
fn eval_batch<T: Float + Send + Sync>(
    kind: ModelKind,
    params: &str,
    inputs: &[&[f64]],
    parallel: bool,
) -> Result<Vec<T>, Failure> {
    let m: AnyModel<T> = build(kind, params)?;
    let cols: Vec<Vec<T>> = inputs
        .iter()
        .map(|c| c.iter().map(|&v| T::from_f64(v)).collect())
        .collect();
    let mut out = vec![T::ZERO; inputs[0].len()];
    let what = if cols.len() == 3 {
        Inputs::Cosines([&cols[0], &cols[1], &cols[2]])
    } else {
        Inputs::Vectors([&cols[0], &cols[1], &cols[2]], [&cols[3], &cols[4], &cols[5]])
    };
    par::eval(&Batch::new(&m), what, &mut out, parallel).map_err(batch_failure)?;
    finite(&out, kind)?;
    Ok(out)
}

/// `Batch::cosines` (3 arrays) or `Batch::vectors` (6 arrays: wi x, y, z, wr x, y, z).
#[pyfunction]
fn eval_columns<'py>(
    py: Python<'py>,
    model: &str,
    params: &str,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    precision: &str,
    parallel: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let kind = parse_kind(model)?;
    if columns.len() != 3 && columns.len() != 6 {
        return Err(PyValueError::new_err("internal: need 3 or 6 columns"));
    }
    let cols: Vec<&[f64]> = columns
        .iter()
        .map(|c| slice(c, "input"))
        .collect::<PyResult<_>>()?;
    match precision {
        "f64" => {
            let out = py.detach(|| eval_batch::<f64>(kind, params, &cols, parallel))?;
            Ok(PyArray1::from_vec(py, out).into_any())
        }
        "f32" => {
            let out = py.detach(|| eval_batch::<f32>(kind, params, &cols, parallel))?;
            Ok(PyArray1::from_vec(py, out).into_any())
        }
        other => Err(PyValueError::new_err(format!(
            "unknown precision `{other}` (expected f64 or f32)"
        ))),
    }
}

/// Fit settings as `brdf fit` builds them from its options.
#[pyclass(module = "brdf._brdf", frozen)]
#[derive(Clone, Debug)]
struct Settings {
    settings: FitSettings,
    skip_invalid: bool,
    format: Option<Format>,
    channel: Channel,
}

#[pymethods]
impl Settings {
    #[new]
    #[pyo3(signature = (model, seed, residual, engine, chains, agree, hops, anneal_evals,
                        loss, loss_scale, brightening, budget_evals, skip_invalid, format, channel))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        model: &str,
        seed: u64,
        residual: &str,
        engine: &str,
        chains: Option<u64>,
        agree: Option<u64>,
        hops: Option<u64>,
        anneal_evals: Option<u64>,
        loss: &str,
        loss_scale: f64,
        brightening: bool,
        budget_evals: Option<u64>,
        skip_invalid: bool,
        format: Option<&str>,
        channel: &str,
    ) -> PyResult<Self> {
        let d = FitRequest::new(kind_of(model)?);
        let request = FitRequest {
            seed,
            residual: parse(residual)?,
            engine: parse(engine)?,
            chains: chains.unwrap_or(d.chains),
            agree: agree.unwrap_or(d.agree),
            hops: hops.unwrap_or(d.hops),
            anneal_evals: anneal_evals.unwrap_or(d.anneal_evals),
            loss: parse(loss)?,
            loss_scale,
            brightening,
            budget_evals: budget_evals.unwrap_or(d.budget_evals),
            ..d
        };
        let settings =
            FitSettings::from_options(&request).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let format = format.map(parse::<Format>).transpose()?;
        let channel = parse::<Channel>(channel)?;
        Ok(Settings {
            settings,
            skip_invalid,
            format,
            channel,
        })
    }
}

/// Fits every dataset; returns each report as `brdf fit --json` prints one.
fn fit_datasets(py: Python<'_>, s: &Settings, datasets: Vec<Dataset>) -> PyResult<Vec<String>> {
    let settings = s.settings;
    py.detach(move || {
        brdf_fit::fit_streamed(&settings, &datasets, |_, _| {})
            .into_iter()
            .map(|r| match r {
                Ok(r) => serde_json::to_string_pretty(&r).map_err(|e| e.to_string()),
                Err(e) => Err(e.to_string()),
            })
            .collect::<Result<Vec<String>, String>>()
    })
    .map_err(PyValueError::new_err)
}

/// Reads data files as `brdf fit [--format F] [--skip-invalid] FILES` does; returns the
/// datasets and the messages the CLI prints on standard error.
fn load(s: &Settings, paths: &[String]) -> PyResult<(Vec<Dataset>, Vec<String>)> {
    let mut out = Vec::new();
    let mut notes = Vec::new();
    for f in paths {
        let path = std::path::Path::new(f);
        if let Some(format) = s.format {
            let imp = import(path, format, s.channel)
                .map_err(|e| PyValueError::new_err(format!("cannot import {f}: {e}")))?;
            for r in &imp.rejects {
                notes.push(format!("{f}: rejected line {}: {}", r.line, r.reason));
            }
            out.extend(imp.datasets);
            continue;
        }
        let opts = LoadOptions {
            skip_invalid: s.skip_invalid,
            allow_zero_brdf: s.settings.residual == Residual::Absolute,
        };
        let loaded =
            load_csv(path, opts).map_err(|e| PyValueError::new_err(format!("cannot use {f}: {e}")))?;
        for sk in &loaded.skipped {
            notes.push(format!("{f}: skipped line {}: {}", sk.line, sk.reason));
        }
        out.extend(loaded.datasets);
    }
    Ok((out, notes))
}

/// `brdf fit` on files: (reports as JSON text, rejected/skipped-row notes).
#[pyfunction]
fn fit_paths(
    py: Python<'_>,
    settings: &Settings,
    paths: Vec<String>,
) -> PyResult<(Vec<String>, Vec<String>)> {
    let (datasets, notes) = load(settings, &paths)?;
    Ok((fit_datasets(py, settings, datasets)?, notes))
}

/// Datasets of files, as `(name, theta_i, theta_r, phi, brdf, sigma, weight)` in degrees.
#[pyfunction]
#[allow(clippy::type_complexity)]
fn read_paths(
    settings: &Settings,
    paths: Vec<String>,
) -> PyResult<(
    Vec<(
        String,
        Vec<f64>,
        Vec<f64>,
        Vec<f64>,
        Vec<f64>,
        Vec<Option<f64>>,
        Vec<Option<f64>>,
    )>,
    Vec<String>,
)> {
    let (datasets, notes) = load(settings, &paths)?;
    let sets = datasets
        .into_iter()
        .map(|d| {
            let p = &d.points;
            (
                d.name.clone(),
                p.iter().map(|q| q.theta_i.to_degrees()).collect(),
                p.iter().map(|q| q.theta_r.to_degrees()).collect(),
                p.iter().map(|q| q.phi.to_degrees()).collect(),
                p.iter().map(|q| q.brdf).collect(),
                p.iter().map(|q| q.sigma).collect(),
                p.iter().map(|q| q.weight).collect(),
            )
        })
        .collect();
    Ok((sets, notes))
}

/// `brdf fit` on one dataset given as arrays (degrees; `sigma`/`weight` optional).
#[pyfunction]
#[pyo3(signature = (settings, name, theta_i, theta_r, phi, brdf, sigma=None, weight=None))]
#[allow(clippy::too_many_arguments)]
fn fit_arrays<'py>(
    py: Python<'py>,
    settings: &Settings,
    name: String,
    theta_i: PyReadonlyArray1<'py, f64>,
    theta_r: PyReadonlyArray1<'py, f64>,
    phi: PyReadonlyArray1<'py, f64>,
    brdf: PyReadonlyArray1<'py, f64>,
    sigma: Option<PyReadonlyArray1<'py, f64>>,
    weight: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<String> {
    let allow_zero = settings.settings.residual == Residual::Absolute;
    let columns = (
        &theta_i,
        &theta_r,
        &phi,
        &brdf,
        sigma.as_ref(),
        weight.as_ref(),
        allow_zero,
    );
    let mut reports = fit_datasets(py, settings, vec![dataset(name, columns)?])?;
    Ok(reports.remove(0))
}

/// The six columns of an array dataset (degrees; `sigma`/`weight` optional).
type Columns<'a, 'py> = (
    &'a PyReadonlyArray1<'py, f64>,
    &'a PyReadonlyArray1<'py, f64>,
    &'a PyReadonlyArray1<'py, f64>,
    &'a PyReadonlyArray1<'py, f64>,
    Option<&'a PyReadonlyArray1<'py, f64>>,
    Option<&'a PyReadonlyArray1<'py, f64>>,
    bool,
);

/// A dataset from arrays, each row checked as `brdf fit` checks a CSV row (`allow_zero`: a
/// BRDF of 0 is allowed, for absolute residuals).
fn dataset(name: String, columns: Columns<'_, '_>) -> PyResult<Dataset> {
    let (theta_i, theta_r, phi, brdf, sigma, weight, allow_zero) = columns;
    if sigma.is_some() && weight.is_some() {
        return Err(PyValueError::new_err("sigma and weight cannot be used together"));
    }
    let n = theta_i.len();
    if n == 0 {
        return Err(PyValueError::new_err("no data points"));
    }
    let ti = slice(theta_i, "theta_i")?;
    let tr = slice(theta_r, "theta_r")?;
    let ph = slice(phi, "phi")?;
    let f = slice(brdf, "brdf")?;
    let sg = sigma.map(|a| slice(a, "sigma")).transpose()?;
    let wt = weight.map(|a| slice(a, "weight")).transpose()?;
    let points = (0..n)
        .map(|i| {
            let row = RowDegrees {
                theta_i: ti[i],
                theta_r: tr[i],
                phi: ph[i],
                brdf: f[i],
                sigma: sg.map(|s| s[i]),
                weight: wt.map(|w| w[i]),
            };
            // `line` is the 1-based row number, as a CSV file's data rows would count.
            Point::from_degrees(row, allow_zero, i as u64 + 1).map_err(|e| Failure::At(i, e.to_string()))
        })
        .collect::<Result<Vec<Point>, Failure>>()?;
    Ok(Dataset { name, points })
}

/// What `select_path` and `select_arrays` return, as `pack` does: `((selection JSON,
/// candidate reports as JSON, blob or None) or None, notes, error or None)`; the notes found
/// before a failure are returned with it, as the CLI prints them before its error.
type Selected<'py> = (
    Option<(String, Vec<String>, Option<Bound<'py, PyBytes>>)>,
    Vec<String>,
    Option<String>,
);

/// `brdf.select`'s options after the data: `(budget, max_theta_i, max_theta_r,
/// allow_nonphysical, sequence)`, as `brdf select --budget --max-theta-i --max-theta-r
/// --allow-nonphysical --sequence`.
type SelectArgs = (f64, f64, f64, bool, u32);

/// `brdf select DATA` on one dataset: the ladder fitted over the domain with `settings` (its
/// model is ignored), through the same library call (`brdf_scene::represent::select_data`).
/// Returns (see [`Selected`]) the JSON `brdf select --json` prints, each candidate's report
/// as `brdf fit --json` prints it and the chosen representation's blob (as `brdf select -o`
/// writes it) or None, or the error; with either, `notes` and then what the CLI prints on
/// standard error first (the points left out).
fn select_dataset<'py>(
    py: Python<'py>,
    settings: &Settings,
    d: Dataset,
    options: SelectArgs,
    mut notes: Vec<String>,
) -> Selected<'py> {
    use brdf_scene::represent::{select_data, DataDomain};
    let (budget, max_theta_i, max_theta_r, allow_nonphysical, sequence) = options;
    let limits = (max_theta_i, max_theta_r);
    #[allow(clippy::type_complexity)]
    let result = (|| -> Result<(String, Vec<String>, Option<Bound<'py, PyBytes>>), String> {
        check_budget(budget)?;
        for (name, v) in [("max_theta_i", limits.0), ("max_theta_r", limits.1)] {
            if !(0.0..=90.0).contains(&v) {
                return Err(format!("{name} {v} is outside 0..=90 degrees"));
            }
        }
        let kept = DataDomain::new(&d, limits.0, limits.1);
        notes.extend(kept.left_out_note());
        let base = settings.settings;
        let (text, candidates, blob) = py.detach(move || -> Result<_, String> {
            let s = select_data(
                &kept,
                &|kind| FitSettings { kind, ..base },
                budget,
                allow_nonphysical,
            )?;
            let blob = match &s.material {
                Some((m, table)) => Some(
                    brdf_fit::pack::encode(&[*m], std::slice::from_ref(table), sequence)
                        .map_err(|e| e.to_string())?,
                ),
                None => None,
            };
            let text = serde_json::to_string_pretty(&s).map_err(|e| e.to_string())?;
            let candidates = s
                .candidates
                .iter()
                .map(serde_json::to_string_pretty)
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| e.to_string())?;
            Ok((text, candidates, blob))
        })?;
        Ok((text, candidates, blob.map(|b| PyBytes::new(py, &b.bytes))))
    })();
    match result {
        Ok(v) => (Some(v), notes, None),
        Err(e) => (None, notes, Some(e)),
    }
}

/// A selection budget is a finite fraction greater than 0 (`budget` as `brdf select
/// --budget` parses it).
fn check_budget(budget: f64) -> Result<(), String> {
    if budget.is_finite() && budget > 0.0 {
        Ok(())
    } else {
        Err(format!("budget {budget} is not a finite fraction greater than 0"))
    }
}

/// `brdf select` on a file: see [`select_dataset`] and [`Selected`]; the notes are the
/// skipped or rejected rows, then the points left out.
#[pyfunction]
fn select_path<'py>(
    py: Python<'py>,
    settings: &Settings,
    path: String,
    options: SelectArgs,
) -> PyResult<Selected<'py>> {
    let (datasets, notes) = load(settings, std::slice::from_ref(&path))?;
    let d = match brdf_scene::represent::one_dataset(&path, datasets) {
        Ok(d) => d,
        Err(e) => return Ok((None, notes, Some(e))),
    };
    Ok(select_dataset(py, settings, d, options, notes))
}

/// `brdf select` on one dataset given as arrays: see [`select_dataset`] and [`Selected`].
#[pyfunction]
#[pyo3(signature = (settings, name, theta_i, theta_r, phi, brdf, sigma, weight, options))]
#[allow(clippy::too_many_arguments)]
fn select_arrays<'py>(
    py: Python<'py>,
    settings: &Settings,
    name: String,
    theta_i: PyReadonlyArray1<'py, f64>,
    theta_r: PyReadonlyArray1<'py, f64>,
    phi: PyReadonlyArray1<'py, f64>,
    brdf: PyReadonlyArray1<'py, f64>,
    sigma: Option<PyReadonlyArray1<'py, f64>>,
    weight: Option<PyReadonlyArray1<'py, f64>>,
    options: SelectArgs,
) -> PyResult<Selected<'py>> {
    let allow_zero = settings.settings.residual == Residual::Absolute;
    let d = dataset(
        name,
        (
            &theta_i,
            &theta_r,
            &phi,
            &brdf,
            sigma.as_ref(),
            weight.as_ref(),
            allow_zero,
        ),
    )?;
    Ok(select_dataset(py, settings, d, options, Vec::new()))
}

/// `brdf pack` through the same library function (`brdf_fit::pack::pack`). `sources` are
/// `(path, None)` for a `brdf fit --json` file or `(origin, Some(json))` for report text named
/// `origin` in messages. Returns `(blob or None, notes as (is_warning, text), error or
/// None)`: the notes found before a failure are returned with it, as the CLI prints them
/// before its error.
#[pyfunction]
#[pyo3(signature = (sources, table_nodes, sequence))]
#[allow(clippy::type_complexity)]
fn pack<'py>(
    py: Python<'py>,
    sources: Vec<(String, Option<String>)>,
    table_nodes: Option<usize>,
    sequence: u32,
) -> (Option<Bound<'py, PyBytes>>, Vec<(bool, String)>, Option<String>) {
    use brdf_fit::pack::{FitSource, Level, PackOptions};
    let options = PackOptions {
        sequence,
        table_nodes,
    };
    let (result, notes) = py.detach(|| {
        let sources: Vec<FitSource> = sources
            .iter()
            .map(|(name, json)| match json {
                None => FitSource::File(std::path::Path::new(name)),
                Some(json) => FitSource::Text { origin: name, json },
            })
            .collect();
        let mut notes = Vec::new();
        let result = brdf_fit::pack::pack(&sources, &options, |n| {
            notes.push((n.level == Level::Warning, n.text))
        });
        (result, notes)
    });
    match result {
        Ok(p) => (Some(PyBytes::new(py, &p.bytes)), notes, None),
        Err(e) => (None, notes, Some(e.to_string())),
    }
}

/// The scene at `path`, or the message `brdf scene` prints when it cannot be used.
fn scene_at(path: &str) -> PyResult<brdf_scene::scene::Scene> {
    brdf_scene::scene::Scene::open(std::path::Path::new(path))
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// σ per aspect, as `brdf scene lrcs` computes it.
type SceneLrcs = (
    String,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
    Vec<Vec<f64>>,
    Vec<usize>,
    Vec<String>,
);

/// `brdf scene lrcs` through the same library calls (`brdf_scene::lrcs::lrcs`,
/// `LrcsReport`): the JSON `--json` prints, then per aspect azimuth, elevation, σ, each
/// material's share and the facets seen, then the materials' parts.
#[pyfunction]
fn scene_lrcs(py: Python<'_>, path: String) -> PyResult<SceneLrcs> {
    use brdf_scene::lrcs::{lrcs, LrcsReport};
    let scene = scene_at(&path)?;
    py.detach(|| {
        let result = lrcs(&scene, &|| {});
        let text = serde_json::to_string_pretty(&LrcsReport::new(path, &scene, &result))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let a = &result.aspects;
        Ok((
            text,
            a.iter().map(|x| x.azimuth).collect(),
            a.iter().map(|x| x.elevation).collect(),
            a.iter().map(|x| x.lrcs).collect(),
            a.iter().map(|x| x.by_material.clone()).collect(),
            a.iter().map(|x| x.facets_seen).collect(),
            scene.materials.iter().map(|m| m.part.clone()).collect(),
        ))
    })
}

/// The scene's queries, as `brdf scene domain` writes them.
type SceneDomain = (
    Vec<f64>,
    Vec<f64>,
    Vec<usize>,
    Vec<String>,
    Vec<usize>,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
);

/// `brdf scene domain` through the same library calls (`brdf_scene::queries::collect_queries`,
/// `brdf_scene::queries::rows`): its columns, in its row order.
#[pyfunction]
fn scene_domain(py: Python<'_>, path: String) -> PyResult<SceneDomain> {
    let scene = scene_at(&path)?;
    Ok(py.detach(|| {
        let d = brdf_scene::queries::collect_queries(&scene, &|| {});
        let mut c: SceneDomain = Default::default();
        for r in brdf_scene::queries::rows(&scene, &d) {
            c.0.push(r.azimuth);
            c.1.push(r.elevation);
            c.2.push(r.material);
            c.3.push(r.part.to_owned());
            c.4.push(r.facet);
            c.5.push(r.theta_i);
            c.6.push(r.theta_r);
            c.7.push(r.phi);
            c.8.push(r.weight);
        }
        c
    }))
}

/// `brdf select --scene` through the same library calls (`brdf_scene::queries::collect_queries`,
/// `brdf_scene::select::select`): the JSON `--json` prints, the blob `-o` writes (or None)
/// and why there is none.
#[pyfunction]
#[allow(clippy::type_complexity)]
fn select_scene<'py>(
    py: Python<'py>,
    path: String,
    budget: f64,
    seed: u64,
    sequence: u32,
    allow_nonphysical: bool,
) -> PyResult<(String, Option<Bound<'py, PyBytes>>, Option<String>)> {
    use brdf_scene::select::{select, SelectOptions};
    check_budget(budget).map_err(PyValueError::new_err)?;
    let scene = scene_at(&path)?;
    let opts = SelectOptions {
        budget,
        fit: FitOptions {
            seed,
            ..FitOptions::default()
        },
        sequence,
        allow_nonphysical,
        ..SelectOptions::default()
    };
    let (text, blob, note) = py.detach(|| {
        let domain = brdf_scene::queries::collect_queries(&scene, &|| {});
        let s = select(&scene, &domain, &opts);
        let text = serde_json::to_string_pretty(&s).map_err(|e| e.to_string());
        (text, s.blob().map(<[u8]>::to_vec), s.blob_note.clone())
    });
    let text = text.map_err(PyValueError::new_err)?;
    Ok((text, blob.map(|b| PyBytes::new(py, &b)), note))
}

/// The compiled module.
#[pymodule]
fn _brdf(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("ElementError", m.py().get_type::<ElementError>())?;
    m.add(
        "MODELS",
        ModelKind::ALL.iter().map(|k| k.name()).collect::<Vec<_>>(),
    )?;
    // The core's named tolerances, for the tests (one home: brdf_core::tolerance).
    m.add("BATCH_F64_REL", brdf_core::tolerance::BATCH_F64_REL)?;
    m.add("ALBEDO_DEFAULT_REL", brdf_core::tolerance::ALBEDO_DEFAULT_REL)?;
    m.add(
        "F64_REFORMULATION_REL",
        brdf_core::tolerance::F64_REFORMULATION_REL,
    )?;
    m.add_class::<Settings>()?;
    m.add_function(wrap_pyfunction!(eval_angles, m)?)?;
    m.add_function(wrap_pyfunction!(eval_columns, m)?)?;
    m.add_function(wrap_pyfunction!(albedo, m)?)?;
    m.add_function(wrap_pyfunction!(fit_paths, m)?)?;
    m.add_function(wrap_pyfunction!(fit_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(read_paths, m)?)?;
    m.add_function(wrap_pyfunction!(pack, m)?)?;
    m.add_function(wrap_pyfunction!(select_path, m)?)?;
    m.add_function(wrap_pyfunction!(select_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(scene_lrcs, m)?)?;
    m.add_function(wrap_pyfunction!(scene_domain, m)?)?;
    m.add_function(wrap_pyfunction!(select_scene, m)?)?;
    Ok(())
}
