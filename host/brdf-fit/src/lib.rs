//! Fitting the BRDF model family to measurements: datasets, global search plus local
//! polish, metrics, parameter uncertainty and model selection, all in f64.
//!
//! ```
//! use brdf_core::ModelKind;
//! use brdf_fit::{fit, synth, FitOptions, Problem, Residual};
//!
//! // Synthetic in-plane data from the paper's khaki plate, 0.5% noise.
//! let khaki = [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2];
//! let data = synth::in_plane(ModelKind::Six, &khaki, &[0.0, 10.0, 30.0], 5.0, 0.005, 7).unwrap();
//! let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &data);
//! let result = fit(&problem, &FitOptions::default());
//! assert!((result.params[0] - 0.2545).abs() < 0.02); // kb
//! ```

pub mod anneal;
pub mod batch;
pub mod data;
pub mod embedded;
pub mod fit;
pub mod fitted_table;
pub mod folds;
pub mod grid;
pub mod holdout;
pub mod import;
pub mod kernel;
pub mod lm;
pub mod noise;
pub mod pack;
pub mod params;
pub mod problem;
pub mod report;
pub mod request;
pub mod spectral;
pub mod synth;

pub use batch::{
    fit_all, fit_streamed, fit_streamed_until, fittable, Engine, FitError, FitSettings, SkippedDataset,
};
pub use data::{load_csv, DataError, Dataset, LoadOptions, Loaded, Point, RowDegrees, RowError, Skipped};
pub use fit::{fit, FitOptions, FitOutcome};
pub use problem::{Loss, LossKind, Problem, Residual, Stop};
pub use request::{EngineKind, FitRequest, OptionError};
