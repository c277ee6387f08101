//! The six-parameter BRDF model family, `no_std` and heap-free, in `f32` and `f64`.
//!
//! The six-parameter model of Yang, Wu and Cao (Acta Optica Sinica 32(2), 2012) and the
//! models around it — the five-parameter model it replaced, Minnaert and Lambert — with a
//! geometry that stays accurate in `f32` near the retro and mirror directions and at
//! grazing angles, evaluation from angles, cosines or unit vectors, and physical checks
//! (reciprocity, energy bound, albedo by quadrature). The f32 path computes its elementary
//! functions (`exp`, `ln`, `ln_1p`, `powf`, `sin`/`cos`) in f32 arithmetic alone
//! (the [`Float`] implementation for `f32`), and the f64 path through `libm`, so the host runs exactly the arithmetic the
//! Cortex-M4F firmware runs.
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
//!
//! # Modules
//!
//! | module | what it holds | use it when |
//! |---|---|---|
//! | crate root | the models ([`SixParam`], [`FiveParam`], [`Minnaert`], [`Lambert`], [`SixParamCos2`], [`Ggx`]), [`AnyModel`] and [`ModelKind`], the [`Brdf`] and [`Model`] traits, [`Geometry`], [`Float`] | you evaluate one material at one direction pair (exact, `f32` or `f64`) |
//! | [`models`] | one file per model with its parameter struct; [`TABLE1`], the paper's three materials ([`table1_f32`] for a row in `f32`) | you need a model's parameter names, order or derived terms, or the paper's reference materials |
//! | [`names`] | the [`names::Named`] vocabulary: one spelling per model (and, in `brdf-fit`, residual, loss, format, channel, engine) and the "expected one of" message | you parse a name from a user, a file or Python |
//! | [`ranges`] | the valid range of every parameter, used by every constructor | you validate parameters coming from outside (files, frames, fits) |
//! | [`tolerance`] | every promised accuracy, with its reason | a test or a check compares two values |
//! | [`checks`] | reciprocity, the energy bound, albedo by quadrature | you judge whether a parameter set is physical |
//! | [`table`] | the tabulated six-parameter path, its byte layout and accuracy | a device repeats lookups of one material and can spare `table_len(n)` bytes |
//! | [`bands`] | which band, or which two bands blended, answer at a wavelength | a material holds one parameter set per measured band |
//! | [`batch`] | one material over many directions (`std` feature: AVX2/AVX-512 chosen at run time) | the host evaluates thousands of directions (renderers, scenes, quadrature) |
//! | [`anneal`] | the heap-free simulated annealer and its degenerate-sample rule | a device refits a material from its own measurements |
//! | [`fitted`] | fitted tables: an analytic base model times a measured correction tabulated in Rusinkiewicz coordinates ([`fitted::Corrected`]), their bytes and coverage | you serve a measured material no analytic model fits |
//! | [`cost`] | Cortex-M4F instructions per evaluation, per model and path | you choose a representation for an instruction budget |
//!
//! # Tables
//!
//! Three 1-D tables of `n` nodes each, generated once (the host does it in `f64`) and read in
//! place; [`table::table_accuracy`] measures them against the exact `f64` model.
//!
//! ```
//! use brdf_core::table::{fill_six_table, table_accuracy, table_len, SixTable};
//! use brdf_core::tolerance::{TABLE_MAX_REL, TABLE_MAX_ZENITH_DEG};
//! use brdf_core::{Brdf, SixParam, SixParams};
//!
//! let khaki = [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2];
//! let exact = SixParam::new(SixParams::<f64>::from_array(khaki))?;
//! let params32 = SixParams::<f32>::from_array(khaki.map(|v| v as f32));
//!
//! // 256 nodes: 3 tables x 256 nodes x 4 bytes, as they travel in a blob.
//! let mut bytes = [0u8; table_len(256)];
//! fill_six_table(&SixParams::<f64>::from_array(khaki), 256, &mut bytes)?;
//! let table = SixTable::new(params32, &bytes)?;
//! table.verify()?;
//!
//! // One lookup from cosines, close to the exact value at normal incidence and viewing.
//! let (t, e) = (table.eval_cosines(1.0, 1.0, 1.0), exact.eval_cosines(1.0, 1.0, 1.0));
//! assert!(((f64::from(t) - e) / e).abs() < 1e-3);
//!
//! // The promise: within TABLE_MAX_REL for 256 nodes over zeniths up to 85 degrees.
//! let steps = 24;
//! let max_mu = (TABLE_MAX_ZENITH_DEG.to_radians()).cos() as f32;
//! let grid = (0..=steps).flat_map(move |i| {
//!     (0..=steps).flat_map(move |r| {
//!         (0..=steps).map(move |p| {
//!             let mu = |k: usize| max_mu + (1.0 - max_mu) * k as f32 / steps as f32;
//!             [mu(i), mu(r), -1.0 + 2.0 * p as f32 / steps as f32]
//!         })
//!     })
//! });
//! let acc = table_accuracy(&table, &exact, grid);
//! let promised = TABLE_MAX_REL.iter().find(|(n, _)| *n == 256).unwrap().1;
//! assert!(acc.n > 0 && acc.max <= promised, "{acc:?}");
//! # Ok::<(), Box<dyn core::error::Error>>(())
//! ```
//!
//! # Annealer
//!
//! The device's refit: samples in a fixed-capacity buffer, the host engine's search box, and
//! an RNG handed in through `rand_core` (here `rand_pcg`, seeded, so the run is repeatable).
//!
//! ```
//! use brdf_core::anneal::{anneal, AnnealConfig, Samples, SearchBox};
//! use brdf_core::{Brdf, ModelKind, SixParam, SixParams};
//! use rand_core::SeedableRng;
//!
//! // Measurements of a known material: the khaki plate at 36 direction pairs.
//! let khaki = SixParam::new(SixParams::<f32>::from_array([0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2]))?;
//! let mut samples: Samples<f32, 64> = Samples::new();
//! for i in 0..6 {
//!     for r in 0..6 {
//!         let (ti, tr, phi) = (0.1 + 0.2 * i as f32, 0.05 + 0.25 * r as f32, 0.5 * r as f32);
//!         samples.push_angles(ti, tr, phi, khaki.eval_angles(ti, tr, phi))?;
//!     }
//! }
//!
//! let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
//! let cfg = AnnealConfig::default();
//! let fit = anneal::<f32, SixParam<f32>, _, 64>(&samples, &SearchBox::for_kind(ModelKind::Six), &cfg, &mut rng)?;
//! assert!(fit.evals <= cfg.budget);
//! assert!(fit.rms_rel < 1e-3, "rms relative error {}", fit.rms_rel); // noise-free data: about 3e-5
//!
//! // The same seed gives the same fit.
//! let again = anneal::<f32, SixParam<f32>, _, 64>(
//!     &samples, &SearchBox::for_kind(ModelKind::Six), &cfg, &mut rand_pcg::Pcg32::seed_from_u64(7),
//! )?;
//! assert_eq!(fit.params, again.params);
//! # Ok::<(), Box<dyn core::error::Error>>(())
//! ```
#![no_std]
#![deny(missing_docs)]

// The `std` feature adds run-time instruction-set detection to the batch path (host only).
#[cfg(feature = "std")]
extern crate std;

pub mod accuracy;
pub mod anneal;
pub mod bands;
pub mod batch;
pub mod checks;
pub mod cost;
mod error;
pub mod fitted;
mod float;
mod geometry;
mod model;
pub mod models;
pub mod names;
pub mod ranges;
pub mod table;
pub mod tolerance;

pub use error::{Compact, DomainError, ParamError};
pub use float::Float;
pub use geometry::{Geometry, UNIT_NORM_TOLERANCE};
pub use model::{AnyModel, Brdf, Model, ModelKind, MAX_PARAMS, MAX_TERM_FACTORS};
pub use models::{
    table1_f32, FiveParam, FiveParams, Ggx, GgxParams, Lambert, LambertParams, Minnaert, MinnaertParams,
    SixParam, SixParamCos2, SixParams, TABLE1,
};

/// The README's example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
