//! Plots of measured and fitted BRDFs, as the paper shows them: in-plane curves per
//! incidence angle (its Fig. 2a–c), a BRDF map over the viewing hemisphere (Fig. 2d–f), and
//! relative residuals against angle; for the benchmarks and scenes, cost against accuracy with
//! its Pareto front, and a cross-section on polar axes. The output format follows the file
//! extension (`.svg` or `.png`). Text uses the bundled DejaVu Sans, so a PNG is the same on
//! every machine.
//!
//! ```no_run
//! use brdf_core::{AnyModel, ModelKind};
//! use brdf_fit::synth;
//! use brdf_plot::{in_plane, Fitted};
//!
//! let p = [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2];
//! let data = synth::in_plane(ModelKind::Six, &p, &[0.0, 10.0, 30.0], 5.0, 0.01, 7).unwrap();
//! let model = AnyModel::new(ModelKind::Six, &p).unwrap();
//! let fits = [Fitted { label: "six".into(), model, floor: 0.0 }];
//! in_plane("khaki.png".as_ref(), "Khaki, in-plane", &data, &fits).unwrap();
//! ```
//!
//! One file per chart: `in_plane.rs` ([`in_plane`]), `map.rs` ([`hemisphere_map`]),
//! `residuals.rs` ([`residuals`]), `tradeoff.rs` ([`tradeoff`], [`pareto_front`]),
//! `polar.rs` ([`polar`]), `spectrum.rs` ([`spectrum`]: a spectral fit against wavelength) and
//! `image.rs` ([`laser_image`]: σ per pixel and range), `profile.rs` ([`range_profile`]: σ per
//! range bin against aspect); `common.rs` holds what they share (font, palette, the SVG/PNG
//! backend choice, log ranges).

use brdf_core::AnyModel;

mod common;
mod image;
mod in_plane;
mod map;
mod polar;
mod profile;
mod residuals;
mod spectrum;
mod tradeoff;

pub use common::check_path;
pub use image::{laser_image, Pixels};
pub use in_plane::in_plane;
pub use map::hemisphere_map;
pub use polar::{polar, PolarCurve, POLAR_RANGE_DB};
pub use profile::{range_profile, ProfileColumn};
pub use residuals::residuals;
pub use spectrum::spectrum;
pub use tradeoff::{pareto_front, tradeoff, TradePoint, SAME_ERROR};

/// Why a plot could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The backend failed (file not writable, ...).
    #[error("{file}: {message}")]
    Draw {
        /// Output path.
        file: String,
        /// Backend message.
        message: String,
    },
    /// The extension is neither `.svg` nor `.png`.
    #[error("{0}: unknown plot format (use .svg or .png)")]
    Format(String),
    /// Nothing to draw (e.g. no in-plane points).
    #[error("{file}: nothing to plot: {why}")]
    Empty {
        /// Output path.
        file: String,
        /// What was missing.
        why: String,
    },
}

/// A fitted model to draw, with its legend text (say the model and its error).
#[derive(Clone, Debug)]
pub struct Fitted {
    /// Legend text, e.g. `six (RMS rel 4.9%)`.
    pub label: String,
    /// The model.
    pub model: AnyModel<f64>,
    /// The fit's noise floor, 1/sr (0: none): relative residuals are drawn over
    /// `sqrt(y^2 + floor^2)`, as the fit weighed them (`brdf_fit::noise`).
    pub floor: f64,
}
