//! The on-sensor annealer of `brdf-core` (f32, fixed memory, fixed budget) run on the host,
//! with results in the same form as the full engine's, so the two compare side by side.

use std::time::Instant;

use brdf_core::anneal::{anneal_kind, AnnealConfig, AnnealError, SampleError, Samples};
use brdf_core::{ModelKind, MAX_PARAMS};
use rand_core::SeedableRng;
use rand_pcg::Pcg32;
use thiserror::Error;

use crate::data::Dataset;
use crate::fit::FitOutcome;
use crate::kernel::to_internal;
use crate::problem::Problem;

/// Default evaluation budget: enough for the 10% target of the cross-check (test
/// `embedded_within_10_percent_of_host`).
pub const DEFAULT_BUDGET: u32 = 20_000;

/// Largest sample count the host runs the embedded annealer with (its buffer capacity).
pub const HOST_CAPACITY: usize = 4096;

/// Why the embedded engine could not run.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum EmbeddedError {
    /// More points than the sample buffer holds.
    #[error("{dataset}: {n} points exceed the embedded engine's {cap} samples")]
    TooManyPoints {
        /// Dataset name.
        dataset: String,
        /// Points given.
        n: usize,
        /// Capacity.
        cap: usize,
    },
    /// A point the annealer refuses (it needs zeniths below 90 degrees and brdf > 0).
    #[error("{dataset}: line {line}: {reason}")]
    Sample {
        /// Dataset name.
        dataset: String,
        /// Source line.
        line: u64,
        /// Reason.
        reason: String,
    },
    /// The annealer's own error.
    #[error("{dataset}: {source}")]
    Anneal {
        /// Dataset name.
        dataset: String,
        /// Error.
        source: AnnealError,
    },
}

/// Fits `kind` to `data` with the embedded f32 annealer and `budget` evaluations; the result
/// is scored in f64 on `problem` exactly as a full fit is. With `seed` =
/// [`brdf_core::anneal::DEVICE_SEED`] (the default fit seed) the parameters are the device's
/// FIT answer for the same samples and budget.
pub fn fit_embedded(
    kind: ModelKind,
    data: &Dataset,
    problem: &Problem,
    budget: u32,
    seed: u64,
) -> Result<FitOutcome, EmbeddedError> {
    let started = Instant::now();
    if data.points.len() > HOST_CAPACITY {
        return Err(EmbeddedError::TooManyPoints {
            dataset: data.name.clone(),
            n: data.points.len(),
            cap: HOST_CAPACITY,
        });
    }
    let mut samples: Box<Samples<f32, HOST_CAPACITY>> = Box::default();
    for p in &data.points {
        samples
            .push_angles(p.theta_i as f32, p.theta_r as f32, p.phi as f32, p.brdf as f32)
            .map_err(|e: SampleError<f32>| EmbeddedError::Sample {
                dataset: data.name.clone(),
                line: p.line,
                reason: e.to_string(),
            })?;
    }
    let cfg = AnnealConfig {
        budget,
        ..AnnealConfig::default()
    };
    let mut rng = Pcg32::seed_from_u64(seed);
    let params = anneal_kind(kind, &samples, &cfg, &mut rng, |_| {})
        .map_err(|source| EmbeddedError::Anneal {
            dataset: data.name.clone(),
            source,
        })?
        .params;
    let natural: Vec<f64> = params[..kind.param_count()]
        .iter()
        .map(|&v| f64::from(v))
        .collect();
    let q = to_internal(kind, &natural);
    let mut params64 = [0.0; MAX_PARAMS];
    params64[..natural.len()].copy_from_slice(&natural);
    Ok(FitOutcome {
        kind,
        q,
        params: params64,
        cost: problem.cost(&q),
        chain_costs: Vec::new(),
        evals: budget as usize,
        converged: false,
        search: crate::fit::SearchSummary {
            chains: 1,
            lobe_probes: 0,
            hops: 0,
            agreeing: 1,
            at_cost_floor: false,
            not_converged: Some(
                "the embedded annealer runs a fixed budget with no convergence test".to_owned(),
            ),
            sample: None,
        },
        seconds: started.elapsed().as_secs_f64(),
    })
}
