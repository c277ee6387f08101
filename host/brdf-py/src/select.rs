//! `brdf.select`: the ladder chosen for one dataset, from a file or arrays, as `brdf select` chooses it.

use super::*;

/// `brdf select DATA` on one dataset: the ladder fitted over the domain with `settings` (its
/// model is ignored), through the same library call (`brdf_scene::represent::select_data`).
/// Returns (see [`Selected`]) the JSON `brdf select --json` prints, each candidate's report
/// as `brdf fit --json` prints it and the chosen representation's blob (as `brdf select -o`
/// writes it) or None, or the error; with either, `notes` and then what the CLI prints on
/// standard error first (the points left out). Raises only what a signal handler raises
/// (Ctrl-C).
pub(crate) fn select_dataset<'py>(
    py: Python<'py>,
    settings: &Settings,
    d: Dataset,
    options: SelectArgs,
    mut notes: Vec<String>,
) -> PyResult<Selected<'py>> {
    use brdf_scene::represent::{select_data_until, DataDomain};
    let (budget, max_theta_i, max_theta_r, allow_nonphysical, sequence) = options;
    let limits = (max_theta_i, max_theta_r);
    let checked = (|| -> Result<(), String> {
        // One dataset is no bands of a measurement (a file's bands are refused before, by
        // `one_dataset`): shared bands would be ignored, refused as `brdf fit` refuses them.
        if settings.settings.bands == brdf_fit::spectral::BandShape::Shared {
            return Err(brdf_fit::FitError::NoBands.to_string());
        }
        check_budget(budget)?;
        for (name, v) in [("max_theta_i", limits.0), ("max_theta_r", limits.1)] {
            if !(0.0..=90.0).contains(&v) {
                return Err(format!("{name} {v} is outside 0..=90 degrees"));
            }
        }
        Ok(())
    })();
    if let Err(e) = checked {
        return Ok((None, notes, Some(e)));
    }
    let kept = DataDomain::new(&d, limits.0, limits.1);
    notes.extend(kept.left_out_note());
    let base = settings.settings;
    // Ctrl-C raises at once (`interruptible`); the selection's own errors come back as text.
    let work = crate::fit::interruptible(py, move |stop| -> Result<_, String> {
        let s = select_data_until(
            &kept,
            &|kind| FitSettings { kind, ..base },
            budget,
            allow_nonphysical,
            stop,
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
        let chosen = s
            .chosen_report()
            .map(|f| serde_json::to_string_pretty(&f))
            .transpose()
            .map_err(|e| e.to_string())?;
        Ok((text, candidates, blob, chosen, s.notes))
    })?;
    Ok(match work {
        Ok((text, candidates, blob, chosen, left_out)) => {
            notes.extend(left_out);
            (
                Some((text, candidates, blob.map(|b| PyBytes::new(py, &b.bytes)), chosen)),
                notes,
                None,
            )
        }
        Err(e) => (None, notes, Some(e)),
    })
}

/// A selection budget as `brdf select --budget` takes it (the library's one rule).
pub(crate) fn check_budget(budget: f64) -> Result<(), String> {
    brdf_scene::ladder::check_budget(budget).map(|_| ())
}

/// `brdf select` on a file: see [`select_dataset`] and [`Selected`]; the notes are the
/// skipped or rejected rows, then the points left out.
#[pyfunction]
pub(crate) fn select_path<'py>(
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
    select_dataset(py, settings, d, options, notes)
}

/// `brdf select` on one dataset given as arrays: see [`select_dataset`] and [`Selected`]; the
/// notes are the reader's warnings of the rows (as a file's), then the points left out.
#[pyfunction]
#[pyo3(signature = (settings, name, theta_i, theta_r, phi, brdf, sigma, weight, options))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn select_arrays<'py>(
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
    let columns = (&theta_i, &theta_r, &phi, &brdf, sigma.as_ref(), weight.as_ref());
    let (d, notes) = dataset(name, settings, columns)?;
    select_dataset(py, settings, d, options, notes)
}
