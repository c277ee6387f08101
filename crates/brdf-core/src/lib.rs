//! The six-parameter BRDF model family, `no_std` and heap-free, in `f32` and `f64`.
//!
//! The six-parameter model of Yang, Wu and Cao (Acta Optica Sinica 32(2), 2012) and the
//! models around it — the five-parameter model it replaced, Minnaert and Lambert — with a
//! geometry that stays accurate in `f32` near the retro and mirror directions and at
//! grazing angles, evaluation from angles, cosines or unit vectors, and physical checks
//! (reciprocity, energy bound, albedo by quadrature). All math goes through `libm`, so
//! the host runs exactly the arithmetic the Cortex-M4F firmware runs.
//!
//! Angles are in radians in the canonical convention of `docs/model.md`: directions point away
//! from the surface, `phi = phi_r - phi_i`, mirror at `(theta_r = theta_i, phi = pi)`, retro
//! at `(theta_r = theta_i, phi = 0)`. BRDF values are in 1/sr.
//!
//! ```
//! use brdf_core::{Brdf, SixParam, SixParams};
//!
//! // Khaki painted plate, Table 1 of the paper.
//! let khaki = SixParam::new(SixParams {
//!     kb: 0.2545_f32, kr: 21.8031, b: -27.5721, a: 0.6705, kd: 0.3676, c: 1.2,
//! })?;
//! let deg = core::f32::consts::PI / 180.0;
//! let f = khaki.eval_angles(10.0 * deg, 10.0 * deg, 0.0); // retro direction, 1/sr
//! assert!((f - 0.192_021_43).abs() < 1e-6);
//!
//! // The device path: cosines in, no trigonometry.
//! let g = khaki.eval_cosines(1.0, 1.0, 1.0);
//! assert!((g - 0.198_020_58).abs() < 1e-6);
//! # Ok::<(), brdf_core::ParamError>(())
//! ```
#![no_std]
#![deny(missing_docs)]

// The `std` feature adds run-time instruction-set detection to the batch path (host only).
#[cfg(feature = "std")]
extern crate std;

pub mod accuracy;
pub mod anneal;
pub mod batch;
pub mod checks;
pub mod cost;
mod error;
pub mod fast;
mod float;
mod geometry;
mod model;
pub mod models;
pub mod ranges;
pub mod table;
pub mod tolerance;

pub use error::{Compact, DomainError, ParamError};
pub use float::Float;
pub use geometry::{Geometry, UNIT_NORM_TOLERANCE};
pub use model::{AnyModel, Brdf, Model, ModelKind, MAX_PARAMS};
pub use models::{
    FiveParam, FiveParams, Lambert, LambertParams, Minnaert, MinnaertParams, SixParam, SixParamCos2,
    SixParams,
};

/// The README's example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
