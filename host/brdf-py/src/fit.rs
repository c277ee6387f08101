//! `brdf.fit` and `brdf.read`: the fit settings as `brdf fit` builds them, datasets from files or arrays.

use super::*;
use brdf_fit::Stop;

/// Fit settings as `brdf fit` builds them from its options.
#[pyclass(module = "brdf._brdf", frozen)]
#[derive(Clone, Debug)]
pub(crate) struct Settings {
    pub(crate) settings: FitSettings,
    pub(crate) skip_invalid: bool,
    pub(crate) format: Option<Format>,
    /// The channel or band of a file to read.
    pub(crate) pick: Pick,
}

#[pymethods]
impl Settings {
    #[new]
    #[pyo3(signature = (model, seed, residual, engine, chains, agree, hops, anneal_evals,
                        loss, loss_scale, brightening, budget_evals, skip_invalid, format, channel,
                        band, noise_floor, bands))]
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
        loss_scale: Option<f64>,
        brightening: bool,
        budget_evals: Option<u64>,
        skip_invalid: bool,
        format: Option<&str>,
        channel: Option<&str>,
        band: Option<f64>,
        noise_floor: Option<f64>,
        bands: Option<&str>,
    ) -> PyResult<Self> {
        let d = FitRequest::new(kind_of(model)?);
        let request = FitRequest {
            seed,
            residual: parse(residual)?,
            engine: parse(engine)?,
            chains,
            agree,
            hops,
            anneal_evals,
            loss: parse(loss)?,
            loss_scale,
            brightening,
            budget_evals,
            noise_floor,
            bands: bands.map(parse::<brdf_fit::spectral::BandShape>).transpose()?,
            ..d
        };
        let settings =
            FitSettings::from_options(&request).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let format = format.map(parse::<Format>).transpose()?;
        let channel = channel.map(parse::<Channel>).transpose()?;
        let pick = brdf_fit::import::pick_for(format, channel, band).map_err(PyValueError::new_err)?;
        Ok(Settings {
            settings,
            skip_invalid,
            format,
            pick,
        })
    }
}

impl Settings {
    /// Refuses the options that apply to files only (`format`, `channel`, `band`,
    /// `skip_invalid`) when the data are arrays, where they would be ignored.
    pub(crate) fn for_arrays(&self) -> PyResult<()> {
        if self.format.is_some() || self.pick != Pick::default() || self.skip_invalid {
            return Err(PyValueError::new_err(
                "format, channel, band and skip_invalid apply to files; arrays are used as given",
            ));
        }
        Ok(())
    }
}

/// Fits every dataset; returns each report as `brdf fit --json` prints one.
pub(crate) fn fit_datasets(py: Python<'_>, s: &Settings, datasets: Vec<Dataset>) -> PyResult<Vec<String>> {
    let settings = s.settings;
    interruptible(py, move |stop| {
        brdf_fit::fit_streamed_until(&settings, &datasets, stop, |_, _| {})
            .into_iter()
            .map(|r| match r {
                Ok(r) => serde_json::to_string_pretty(&r).map_err(|e| e.to_string()),
                Err(e) => Err(e.to_string()),
            })
            .collect::<Result<Vec<String>, String>>()
    })?
    .map_err(PyValueError::new_err)
}

/// How often a long call looks for Ctrl-C (Python's signal handlers run only on the thread
/// holding the interpreter, so the work runs on another thread meanwhile).
const SIGNAL_POLL: std::time::Duration = std::time::Duration::from_millis(50);

/// Runs `work` on its own thread without the interpreter's lock and returns its result, raising
/// `KeyboardInterrupt` (or whatever a signal handler raises) within [`SIGNAL_POLL`] of Ctrl-C
/// instead of when the work ends (a fit may run for minutes). On the signal, the [`Stop`]
/// handed to `work` is requested: a fit's searches end within a few milliseconds
/// ([`brdf_fit::FitSettings::fit_until`]), a scene's sweep within one aspect
/// (`brdf_scene::lrcs::lrcs_until`), and the result is dropped. Work that does not look at it
/// (a scene's queries, selections, the embedded engine, bounded by their own limits) finishes
/// on its thread in the background.
pub(crate) fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce(&Stop) -> T + Send + 'static,
) -> PyResult<T> {
    let (tx, rx) = std::sync::mpsc::channel();
    let stop = Stop::new();
    let for_work = stop.clone();
    std::thread::Builder::new()
        .name("brdf-fit".into())
        .spawn(move || {
            let _ = tx.send(work(&for_work));
        })
        .map_err(|e| PyValueError::new_err(format!("cannot start the work thread: {e}")))?;
    let mut rx = rx;
    loop {
        // The receiver is `Send`, not `Sync`: it goes to the wait and comes back.
        let (got, back) = py.detach(move || (rx.recv_timeout(SIGNAL_POLL), rx));
        rx = back;
        match got {
            Ok(v) => return Ok(v),
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                if let Err(e) = py.check_signals() {
                    stop.request();
                    return Err(e);
                }
            }
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(PyValueError::new_err(
                    "the work stopped without a result (it panicked)",
                ))
            }
        }
    }
}

/// Reads data files as `brdf fit [--format F] [--skip-invalid] FILES` does; returns the
/// datasets and the messages the CLI prints on standard error.
pub(crate) fn load(s: &Settings, paths: &[String]) -> PyResult<(Vec<Dataset>, Vec<String>)> {
    let mut out = Vec::new();
    let mut notes = Vec::new();
    for f in paths {
        let path = std::path::Path::new(f);
        if let Some(format) = s.format {
            let imp = import(path, format, s.pick)
                .map_err(|e| PyValueError::new_err(format!("cannot import {f}: {e}")))?;
            for r in &imp.rejects {
                notes.push(format!("{f}: rejected line {}: {}", r.line, r.reason));
            }
            notes.extend(imp.warnings);
            out.extend(imp.datasets);
            continue;
        }
        let opts = LoadOptions {
            skip_invalid: s.skip_invalid,
            // Kept: the fit weighs them with a noise floor or refuses them naming the line.
            dark_readings: true,
        };
        let loaded =
            load_csv(path, opts).map_err(|e| PyValueError::new_err(format!("cannot use {f}: {e}")))?;
        for sk in &loaded.skipped {
            notes.push(format!("{f}: skipped line {}: {}", sk.line, sk.reason));
        }
        notes.extend(loaded.warnings);
        out.extend(loaded.datasets);
    }
    Ok((out, notes))
}

/// `brdf fit` on files: (reports as JSON text, rejected/skipped-row notes).
#[pyfunction]
pub(crate) fn fit_paths(
    py: Python<'_>,
    settings: &Settings,
    paths: Vec<String>,
) -> PyResult<(Vec<String>, Vec<String>)> {
    let (datasets, mut notes) = load(settings, &paths)?;
    let (datasets, skipped) = brdf_fit::fittable(&settings.settings, datasets, settings.skip_invalid)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    notes.extend(skipped.iter().map(ToString::to_string));
    Ok((fit_datasets(py, settings, datasets)?, notes))
}

/// Checks one fit result as `brdf pack` reads it (`FittedModel::from_json`: a known model,
/// each of its parameters once as a number, no unknown field, a valid fitted table): a
/// whole report or the hand-written `{"model", "params"}`. The error names the field.
///
/// Each parameter within its range, by the rule `brdf pack` and `eval` apply
/// (`FittedModel::model`, `brdf_core::ranges`): a result with `kb = -1` was accepted and
/// refused only when packed. Only a fit's own report may hold parameters outside their
/// ranges (uncalibrated data fit weights no device takes), and only when its
/// `outside_ranges` lists exactly those (`brdf_fit::report::outside_ranges`): it says so
/// itself, as `brdf fit` prints it.
#[pyfunction]
pub(crate) fn check_fit(text: &str) -> PyResult<()> {
    use brdf_fit::report::{outside_ranges, FitReport, FittedModel};
    let fits = FittedModel::from_json(text, "FitResult").map_err(|e| PyValueError::new_err(e.to_string()))?;
    let stated = FitReport::from_json(text, "FitResult").ok();
    for (k, fit) in fits.iter().enumerate() {
        let Err(e) = fit.model() else { continue };
        let params = fit
            .params_array()
            .map_err(|name| PyValueError::new_err(format!("FitResult: field `params.{name}` is missing")))?;
        let own = outside_ranges(fit.model, &params[..fit.model.param_count()]);
        if stated
            .as_ref()
            .and_then(|r| r.get(k))
            .is_some_and(|r| !own.is_empty() && r.outside_ranges == own)
        {
            continue;
        }
        let field = match e {
            brdf_core::ParamError::OutOfRange { name, .. } | brdf_core::ParamError::NotFinite { name } => {
                format!("field `params.{name}`")
            }
            _ => "field `params`".to_owned(),
        };
        return Err(PyValueError::new_err(format!("FitResult: {field}: {e}")));
    }
    Ok(())
}

/// The band of a dataset name (`FILE[wavelength=0.55]`): its wavelength in µm, or `None`
/// (`brdf_fit::data::split_wavelength`).
#[pyfunction]
pub(crate) fn band_of(name: &str) -> Option<f64> {
    brdf_fit::data::split_wavelength(name).map(|(_, um)| um)
}

/// The first near miss among an array dataset's field names, as the message a CSV header
/// gets (`brdf_fit::data::check_column_names`: the one column rule), or `None`.
#[pyfunction]
pub(crate) fn column_near_miss(names: Vec<String>) -> Option<String> {
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    brdf_fit::data::check_column_names(&names)
        .err()
        .map(|miss| miss.to_string())
}

/// The name of an array dataset of wavelength `um` µm: `name[wavelength=um]`, or `name` when
/// it names that band already (a dataset of `brdf.read`); refused when it names another, or
/// `um` is not a wavelength.
#[pyfunction]
pub(crate) fn named_band(name: &str, um: f64) -> PyResult<String> {
    use brdf_fit::data::{split_wavelength, wavelength_text};
    if !brdf_fit::data::is_wavelength(um) {
        return Err(PyValueError::new_err(format!(
            "data: wavelength {um} is not a wavelength above 0 (µm)"
        )));
    }
    match split_wavelength(name) {
        Some((_, w)) if (w - um).abs() < brdf_fit::import::SAME_BAND_UM => Ok(name.to_owned()),
        Some((_, w)) => Err(PyValueError::new_err(format!(
            "data: wavelength {} µm, but the name `{name}` is of the band {} µm",
            wavelength_text(um),
            wavelength_text(w)
        ))),
        None => Ok(format!("{name}[wavelength={}]", wavelength_text(um))),
    }
}

/// Datasets of files, as `(name, theta_i, theta_r, phi, brdf, sigma, weight)` in degrees.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn read_paths(
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

/// `brdf fit` on one dataset given as arrays (degrees; `sigma`/`weight` optional): (the
/// report as JSON text, the reader's warnings). Checked as [`fit_paths`] checks a file's
/// datasets (`brdf_fit::fittable`: `bands='shared'` is refused, one dataset being no bands of
/// a measurement).
#[pyfunction]
#[pyo3(signature = (settings, name, theta_i, theta_r, phi, brdf, sigma=None, weight=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn fit_arrays<'py>(
    py: Python<'py>,
    settings: &Settings,
    name: String,
    theta_i: PyReadonlyArray1<'py, f64>,
    theta_r: PyReadonlyArray1<'py, f64>,
    phi: PyReadonlyArray1<'py, f64>,
    brdf: PyReadonlyArray1<'py, f64>,
    sigma: Option<PyReadonlyArray1<'py, f64>>,
    weight: Option<PyReadonlyArray1<'py, f64>>,
) -> PyResult<(String, Vec<String>)> {
    let columns = (&theta_i, &theta_r, &phi, &brdf, sigma.as_ref(), weight.as_ref());
    let (d, notes) = dataset(name, settings, columns)?;
    let (datasets, _) = brdf_fit::fittable(&settings.settings, vec![d], false)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let mut reports = fit_datasets(py, settings, datasets)?;
    Ok((reports.remove(0), notes))
}

/// The six columns of an array dataset (degrees; `sigma`/`weight` optional).
pub(crate) type Columns<'a, 'py> = (
    &'a PyReadonlyArray1<'py, f64>,
    &'a PyReadonlyArray1<'py, f64>,
    &'a PyReadonlyArray1<'py, f64>,
    &'a PyReadonlyArray1<'py, f64>,
    Option<&'a PyReadonlyArray1<'py, f64>>,
    Option<&'a PyReadonlyArray1<'py, f64>>,
);

/// A dataset from arrays for `settings` (which must not name file options), each row checked
/// as `brdf fit` checks a CSV row (readings at or below zero kept, as `brdf fit` keeps them),
/// and the warnings a file's reader gives of the same rows (zeniths that look like radians:
/// [`Dataset::radians_warning`], as `load_csv` and the importers warn).
pub(crate) fn dataset(
    name: String,
    settings: &Settings,
    columns: Columns<'_, '_>,
) -> PyResult<(Dataset, Vec<String>)> {
    settings.for_arrays()?;
    let (theta_i, theta_r, phi, brdf, sigma, weight) = columns;
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
            Point::from_degrees(row, true, i as u64 + 1).map_err(|e| Failure::At(i, e.to_string()))
        })
        .collect::<Result<Vec<Point>, Failure>>()?;
    let d = Dataset { name, points };
    let notes = d.radians_warning().into_iter().collect();
    Ok((d, notes))
}

/// What `select_path` and `select_arrays` return, as `pack` does: `((selection JSON,
/// candidate reports as JSON, blob or None, the chosen fit as `--chosen` writes it or None)
/// or None, notes, error or None)`; the notes found
/// before a failure are returned with it, as the CLI prints them before its error.
pub(crate) type Selected<'py> = (
    Option<(String, Vec<String>, Option<Bound<'py, PyBytes>>, Option<String>)>,
    Vec<String>,
    Option<String>,
);

/// `brdf.select`'s options after the data: `(budget, max_theta_i, max_theta_r,
/// allow_nonphysical, sequence)`, as `brdf select --budget --max-theta-i --max-theta-r
/// --allow-nonphysical --sequence`.
pub(crate) type SelectArgs = (f64, f64, f64, bool, u32);

/// The fit (or fits) of `text` that `brdf.eval_fit` evaluates, as weighted parts
/// `(weight, model, params, table)` (the parameters as `name=value,...`, each printed to
/// round-trip exactly; a fitted table's device bytes, checked, which `eval_angles` takes as
/// `table`). With `wavelength` (µm), the file's bands there
/// ([`brdf_fit::spectral::BandFits`]): the band's fit, or the two around it with their
/// weights. Without it, or for a fit without bands (the same at every wavelength), one fit
/// (`FittedModel::one_of`, as `brdf eval --fit`); a file holding several bands of one
/// measurement and no `index` or wavelength is refused by name.
#[pyfunction]
#[pyo3(signature = (text, origin, index=None, wavelength=None))]
pub(crate) fn fitted_at<'py>(
    py: Python<'py>,
    text: &str,
    origin: &str,
    index: Option<usize>,
    wavelength: Option<f64>,
) -> PyResult<Vec<FittedPart<'py>>> {
    use brdf_fit::spectral::{AtWavelength, BandFits};
    let part = |one: &brdf_fit::report::OneFit, w: f64| -> FittedPart<'py> {
        let (model, params) = model_and_params(one);
        (
            w,
            model,
            params,
            one.table.as_ref().map(|b| pyo3::types::PyBytes::new(py, b)),
        )
    };
    let bands = BandFits::read(text, origin, index).map_err(PyValueError::new_err)?;
    match (bands, wavelength) {
        (Some(bands), Some(um)) => match bands.at(um) {
            Ok(AtWavelength::Band(one)) => Ok(vec![part(one, 1.0)]),
            Ok(AtWavelength::Between { lower, upper, weight }) => {
                Ok(vec![part(lower, 1.0 - weight), part(upper, weight)])
            }
            Err(e) => Err(PyValueError::new_err(format!("wavelength: {origin}: {e}"))),
        },
        (Some(bands), None) if bands.bands.len() > 1 && index.is_none() => {
            Err(PyValueError::new_err(format!(
                "{origin} holds {}: give wavelength= (µm), or index= for one fit",
                bands.describe()
            )))
        }
        _ => {
            let one =
                brdf_fit::report::FittedModel::one_of(text, origin, index).map_err(PyValueError::new_err)?;
            Ok(vec![part(&one, 1.0)])
        }
    }
}

/// One weighted part of a fit at a wavelength: `(weight, model, params, table)`.
type FittedPart<'py> = (f64, String, String, Option<Bound<'py, pyo3::types::PyBytes>>);

/// A fit's model name and its parameters as `name=value,...` (every digit kept).
fn model_and_params(one: &brdf_fit::report::OneFit) -> (String, String) {
    let params = one
        .model
        .param_names()
        .iter()
        .zip(one.params)
        .map(|(n, v)| format!("{n}={v:?}"))
        .collect::<Vec<_>>()
        .join(",");
    (one.model.name().to_owned(), params)
}
