//! The on-sensor annealer of `brdf-core` (f32, fixed memory, fixed budget) run on the host,
//! with results in the same form as the full engine's, so the two compare side by side.
//!
//! **Units.** The annealer's search box bounds the linear weights (`kb` and `ks` to 1e4, `kd`
//! to 10, `rho0` to 100: [`SearchBox::for_kind`]; the five-parameter `kd` is a ratio, not a
//! weight, [`ModelKind::linear_params`]) and squares readings over their sum in f32, so on
//! readings as given its answer depended on their unit (`kd` = 20 fitted as 9.92; readings
//! of 1e-20 fitted an all-zero model, of 1e-60 were refused). The model is linear in those
//! weights and the cost is relative, so the host divides the readings by the largest (in
//! f64) before the search and multiplies the weights back after: the same readings in any
//! unit fit the same shape, the weights in that unit, and the box bounds the weights relative
//! to the largest reading. A weight that ends on the box's upper bound is reported
//! ([`crate::fit::SearchSummary::on_search_box`]): the best fit may lie beyond it. The device's
//! FIT fits the readings it is sent as they are, its box in their unit (documented with
//! [`SearchBox`]); a host sending readings of unit size gets the answer this engine gives.
//! Readings spanning more than [`MAX_READING_SPREAD`] overflow the f32 search even so, and
//! are refused.

use std::time::Instant;

use brdf_core::anneal::{anneal_kind, AnnealConfig, AnnealError, SampleError, Samples, SearchBox};
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
    /// The readings span more than [`MAX_READING_SPREAD`] (largest over smallest): the f32
    /// search would overflow at the smallest.
    #[error(
        "{dataset}: the readings span a factor of {} (largest {}, smallest {}), beyond the {:e} \
         the embedded engine's f32 search can weigh (it squares the model over each reading, \
         which overflows f32 at the smallest readings and gives an all-zero model): fit this dataset \
         with the full engine (the default; no such limit)",
        brdf_core::Compact(*.spread),
        brdf_core::Compact(*.largest),
        brdf_core::Compact(*.smallest),
        MAX_READING_SPREAD
    )]
    ReadingSpread {
        /// Dataset name.
        dataset: String,
        /// Largest reading over smallest.
        spread: f64,
        /// Largest reading.
        largest: f64,
        /// Smallest reading.
        smallest: f64,
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

/// Largest spread of one dataset's readings (largest over smallest) the embedded engine
/// fits. Its f32 search sums squares of each basis over its reading, `(B / y)^2`, over up to
/// [`HOST_CAPACITY`] readings: with the largest reading 1, a basis of up to 1e2 and 4096
/// readings at the smallest, f32's 3.4e38 is reached at a spread of about 3e15 (a Lambertian
/// dataset with half its readings 1e20 below the rest fitted an all-zero model at
/// rms_rel 1.0). No measurement of one surface spans this much; the full engine, in f64,
/// fits such data.
pub const MAX_READING_SPREAD: f64 = 1e15;

/// Fits `kind` to `data` with the embedded f32 annealer and `budget` evaluations, on the
/// readings divided by the largest and the linear weights multiplied back (module docs:
/// the fit does not depend on the readings' unit); the result is scored in f64 on `problem`
/// exactly as a full fit is. With `seed` = [`brdf_core::anneal::DEVICE_SEED`] (the default
/// fit seed) the parameters are the device's FIT answer for the same samples so divided and
/// the same budget, the weights multiplied back.
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
    // Readings of unit size: the largest is 1 (readings at or below 0 are refused below).
    let largest = data.points.iter().map(|p| p.brdf).fold(0.0, f64::max);
    let scale = if largest > 0.0 && largest.is_finite() {
        largest
    } else {
        1.0
    };
    let smallest = data.points.iter().map(|p| p.brdf).fold(f64::INFINITY, f64::min);
    if smallest > 0.0 && largest / smallest > MAX_READING_SPREAD {
        return Err(EmbeddedError::ReadingSpread {
            dataset: data.name.clone(),
            spread: largest / smallest,
            largest,
            smallest,
        });
    }
    let mut samples: Box<Samples<f32, HOST_CAPACITY>> = Box::default();
    for p in &data.points {
        let y = (p.brdf / scale) as f32;
        samples
            .push_angles(p.theta_i as f32, p.theta_r as f32, p.phi as f32, y)
            .map_err(|e: SampleError<f32>| EmbeddedError::Sample {
                dataset: data.name.clone(),
                line: p.line,
                reason: match e {
                    SampleError::NonPositiveBrdf if p.brdf > 0.0 => format!(
                        "brdf {} is below f32's range relative to the largest reading {} (the \
                         embedded engine searches in f32 on readings divided by the largest)",
                        brdf_core::Compact(p.brdf),
                        brdf_core::Compact(largest)
                    ),
                    e => e.to_string(),
                },
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
    // The weights in the readings' unit; a weight on the box's upper bound (the solved
    // weight clamped to it) is said, never silently kept.
    let search_box = SearchBox::<f32>::for_kind(kind);
    // The weights the model is linear in scale with the readings; the rest do not.
    let linear = kind.linear_params();
    let mut on_search_box = Vec::new();
    let natural: Vec<f64> = params[..kind.param_count()]
        .iter()
        .enumerate()
        .map(|(j, &v)| {
            if !linear.contains(&j) {
                return f64::from(v);
            }
            let w = f64::from(v) * scale;
            if v >= search_box.hi[j] {
                on_search_box.push(format!(
                    "{} = {} is on the embedded engine's search bound ({} times the largest \
                     reading, {}): the best fit may lie beyond it (the full engine has no such \
                     bound)",
                    kind.param_names()[j],
                    brdf_core::Compact(w),
                    search_box.hi[j],
                    brdf_core::Compact(largest)
                ));
            }
            w
        })
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
            on_search_box,
        },
        seconds: started.elapsed().as_secs_f64(),
    })
}
