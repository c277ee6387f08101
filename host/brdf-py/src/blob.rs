//! `brdf.pack`: fit results to a device blob, as `brdf pack`.

use super::*;

/// `brdf pack` through the same library function (`brdf_fit::pack::pack`). `sources` are
/// `(path, None)` for a `brdf fit --json` file or `(origin, Some(json))` for report text named
/// `origin` in messages. Returns `(blob or None, notes as (is_warning, text), error or
/// None)`: the notes found before a failure are returned with it, as the CLI prints them
/// before its error.
#[pyfunction]
#[pyo3(signature = (sources, table_nodes, sequence))]
#[allow(clippy::type_complexity)]
pub(crate) fn pack<'py>(
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
