//! `brdf._brdf`: the compiled half of the Python package `brdf`.
//!
//! The Python half (`python/brdf/__init__.py`) broadcasts, converts dtypes and formats
//! locations; this half takes flat, contiguous `float64` arrays, releases the GIL and calls
//! the same library functions as the `brdf` command, so values and messages are the CLI's.
//! Errors about one element are raised as [`ElementError`] with `(flat index, message)`;
//! the Python half turns the flat index into the caller's array index.
//!
//! One module per part of the API: `eval` (`eval`, `albedo`), `fit` (`fit`, `read`, the
//! settings), `select`, `blob` (`pack`), `scene` (`scene_lrcs`, `scene_domain`, `scene_profile`, `scene_image`,
//! `select_scene`); this file holds what they share (the failure type, name parsing, model
//! building) and the module's contents.

#![warn(missing_docs)]

use brdf_core::batch::par::{self, Inputs};
use brdf_core::batch::{Batch, BatchError};
use brdf_core::names::UnknownName;
use brdf_core::{AnyModel, Brdf, Float, ModelKind};
use brdf_fit::import::{import, Channel, Format, Pick};
use brdf_fit::{load_csv, Dataset, FitOptions, FitRequest, FitSettings, LoadOptions, Point, RowDegrees};
use numpy::{PyArray1, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

mod blob;
mod eval;
mod fit;
mod scene;
mod select;

// One namespace for the modules: each sees the others' items through `use super::*`.
use blob::*;
use eval::*;
use fit::*;
use scene::*;
use select::*;

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
pub(crate) fn parse<T: std::str::FromStr<Err = UnknownName>>(name: &str) -> PyResult<T> {
    name.parse::<T>()
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Parses a model name as `brdf --model` does.
pub(crate) fn parse_kind(name: &str) -> Result<ModelKind, Failure> {
    name.parse::<ModelKind>()
        .map_err(|e| Failure::General(e.to_string()))
}

/// [`parse_kind`] for functions that raise `ValueError` directly.
pub(crate) fn kind_of(name: &str) -> PyResult<ModelKind> {
    Ok(parse_kind(name)?)
}

/// The model `kind` with `params` (`kb=...,kr=...`) in precision `T`, each parameter
/// rounded once to `T`, as `brdf eval` builds it.
pub(crate) fn build<T: Float>(kind: ModelKind, params: &str) -> Result<AnyModel<T>, Failure> {
    let p = brdf_fit::params::parse_params(kind, params).map_err(|e| Failure::General(e.to_string()))?;
    brdf_fit::params::build(kind, &p).map_err(Failure::General)
}

/// A contiguous view of a 1-d float64 array (the Python half makes them contiguous).
pub(crate) fn slice<'a>(a: &'a PyReadonlyArray1<'_, f64>, name: &str) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{name}: internal: array is not contiguous")))
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
    // Laser images' default resolution (one home: brdf_scene::image).
    m.add("IMAGE_PIXELS", brdf_scene::image::IMAGE_PIXELS)?;
    m.add("SWEEP_PIXELS", brdf_scene::image::SWEEP_PIXELS)?;
    m.add("MAX_PIXELS", brdf_scene::image::MAX_PIXELS)?;
    m.add("MAX_SUPERSAMPLE", brdf_scene::image::MAX_SUPERSAMPLE)?;
    m.add("SUPERSAMPLE", brdf_scene::image::SUPERSAMPLE)?;
    m.add_class::<Settings>()?;
    m.add_function(wrap_pyfunction!(eval_angles, m)?)?;
    m.add_function(wrap_pyfunction!(table_covers, m)?)?;
    m.add_function(wrap_pyfunction!(eval_columns, m)?)?;
    m.add_function(wrap_pyfunction!(albedo, m)?)?;
    m.add_function(wrap_pyfunction!(fit_paths, m)?)?;
    m.add_function(wrap_pyfunction!(fit_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(read_paths, m)?)?;
    m.add_function(wrap_pyfunction!(fitted_at, m)?)?;
    m.add_function(wrap_pyfunction!(band_of, m)?)?;
    m.add_function(wrap_pyfunction!(check_fit, m)?)?;
    m.add_function(wrap_pyfunction!(named_band, m)?)?;
    m.add_function(wrap_pyfunction!(column_near_miss, m)?)?;
    m.add_function(wrap_pyfunction!(pack, m)?)?;
    m.add_function(wrap_pyfunction!(select_path, m)?)?;
    m.add_function(wrap_pyfunction!(select_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(scene_lrcs, m)?)?;
    m.add_function(wrap_pyfunction!(scene_domain, m)?)?;
    m.add_function(wrap_pyfunction!(scene_profile, m)?)?;
    m.add_function(wrap_pyfunction!(scene_image, m)?)?;
    m.add_function(wrap_pyfunction!(select_scene, m)?)?;
    Ok(())
}
