//! The one place where this crate evaluates BRDFs: a batch of queries, as slices of
//! cosines, through one material representation.
//!
//! Every σ, every query weight and every candidate's error goes through [`eval_batch`], one
//! call per (aspect, material) (`crate::queries::QueryBatch::sigma`), so that a batch (SIMD)
//! evaluation in the core replaces the loop here without touching the callers.

use brdf_core::batch::Batch;
use brdf_core::fitted::{Corrected, FittedTable};
use brdf_core::table::{SixTable, TableConsts};
use brdf_core::{AnyModel, Brdf};

/// How a material's BRDF is evaluated.
#[derive(Clone, Debug)]
pub enum Evaluator {
    /// The exact model in f64 from f64 cosines: the reference.
    Exact(AnyModel<f64>),
    /// The exact model in f32 from the cosines rounded to f32: the device's exact path.
    Device(AnyModel<f32>),
    /// Six-parameter lookup tables in f32 from the cosines rounded to f32: the device's
    /// tabulated path (`brdf_core::table`).
    Table {
        /// The material's table constants.
        consts: TableConsts,
        /// The node bytes, as they travel in a blob.
        bytes: Vec<u8>,
    },
    /// A base model times a fitted table in f64 from f64 cosines: a fitted table's reference
    /// (scenes, `brdf eval --fit`).
    ExactCorrected {
        /// The base model.
        base: AnyModel<f64>,
        /// The table's bytes, as they travel in a blob.
        bytes: Vec<u8>,
    },
    /// A base model times a fitted table in f32 from the cosines rounded to f32: the device's
    /// path for a fitted table (`brdf_core::fitted::Corrected`).
    Corrected {
        /// The base model, as flashed.
        base: AnyModel<f32>,
        /// The table's bytes, as they travel in a blob.
        bytes: Vec<u8>,
    },
    /// Two bands of a spectral material around a wavelength:
    /// `(1 - weight) f_lower + weight f_upper` (`brdf_fit::spectral::AtWavelength`).
    Blend {
        /// The band below.
        lower: Box<Evaluator>,
        /// The band above.
        upper: Box<Evaluator>,
        /// The upper band's weight.
        weight: f64,
    },
}

impl Evaluator {
    /// The fitted table of a corrected evaluator (the table's coverage is what scenes flag).
    pub fn fitted_table(&self) -> Option<FittedTable<'_>> {
        match self {
            Evaluator::ExactCorrected { bytes, .. } | Evaluator::Corrected { bytes, .. } => {
                FittedTable::new(bytes).ok()
            }
            // The bands of one measurement share its directions, so their tables' coverage.
            Evaluator::Blend { lower, .. } => lower.fitted_table(),
            _ => None,
        }
    }
}

/// `f_r` (1/sr) at each query: `out[k] = f(cos_theta_i[k], cos_theta_r[k], cos_phi[k])`.
/// All four slices have the same length.
pub fn eval_batch(e: &Evaluator, cos_theta_i: &[f64], cos_theta_r: &[f64], cos_phi: &[f64], out: &mut [f64]) {
    debug_assert!(
        cos_theta_i.len() == out.len() && cos_theta_r.len() == out.len() && cos_phi.len() == out.len()
    );
    // The exact model through the core's batch path (vectorised, its instruction set chosen at
    // run time): the scalar formulas to about 1e-15 relative
    // (`brdf_core::tolerance::BATCH_F64_REL`). Input it refuses (a cosine rounded past 1)
    // goes through the scalar path whole.
    if let Evaluator::Exact(m) = e {
        if Batch::new(m)
            .cosines(cos_theta_i, cos_theta_r, cos_phi, out)
            .is_ok()
        {
            return;
        }
    }
    let q = cos_theta_i
        .iter()
        .zip(cos_theta_r)
        .zip(cos_phi)
        .zip(out.iter_mut());
    match e {
        Evaluator::Exact(m) => fill(q, |i, r, p| m.eval_cosines(i, r, p)),
        Evaluator::Device(m) => fill(q, |i, r, p| {
            f64::from(m.eval_cosines(i as f32, r as f32, p as f32))
        }),
        // Constants and bytes come from the same `SixTable::new`, so the lengths match; an
        // unmatched pair evaluates to NaN (never a plausible value).
        Evaluator::Table { consts, bytes } => match SixTable::from_parts(*consts, bytes) {
            Some(t) => fill(q, |i, r, p| {
                f64::from(t.eval_cosines(i as f32, r as f32, p as f32))
            }),
            None => fill(q, |_, _, _| f64::NAN),
        },
        // Bytes that are not a table evaluate to NaN (never a plausible value).
        Evaluator::ExactCorrected { base, bytes } => match FittedTable::new(bytes) {
            Ok(table) => fill(q, |i, r, p| {
                Corrected { base: *base, table }.eval_cosines(i, r, p)
            }),
            Err(_) => fill(q, |_, _, _| f64::NAN),
        },
        Evaluator::Corrected { base, bytes } => match FittedTable::new(bytes) {
            Ok(table) => fill(q, |i, r, p| {
                f64::from(Corrected { base: *base, table }.eval_cosines(i as f32, r as f32, p as f32))
            }),
            Err(_) => fill(q, |_, _, _| f64::NAN),
        },
        Evaluator::Blend { lower, upper, weight } => {
            let mut above = vec![0.0; out.len()];
            eval_batch(lower, cos_theta_i, cos_theta_r, cos_phi, out);
            eval_batch(upper, cos_theta_i, cos_theta_r, cos_phi, &mut above);
            for (o, u) in out.iter_mut().zip(above) {
                *o = (1.0 - weight) * *o + weight * u;
            }
        }
    }
}

/// `out[k] = f(cos_theta_i[k], cos_theta_r[k], cos_phi[k])` over zipped queries.
fn fill<'a>(
    q: impl Iterator<Item = (((&'a f64, &'a f64), &'a f64), &'a mut f64)>,
    f: impl Fn(f64, f64, f64) -> f64,
) {
    for (((&i, &r), &p), o) in q {
        *o = f(i, r, p);
    }
}
