//! Laser radar cross-section: for each aspect of the sweep,
//!
//! ```text
//! sigma = sum over facets seen by both source and receiver of 4 pi f_r cos(theta_i) cos(theta_r) A   (m^2)
//! ```
//!
//! with each facet's local angles in the canonical convention (directions point away from
//! the surface; `theta_i` to the source, `theta_r` to the receiver, measured from the facet's
//! outward normal; `phi = phi_r - phi_i` between their projections on the facet, 0 for the
//! retro direction, 180° for the mirror). A facet counts when both directions are above its
//! plane and the rays from its centroid towards source and receiver leave the target without
//! hitting another facet ([`crate::occlusion`]). A facet is seen whole or not at all: where
//! a shadow edge crosses a facet the error is at most that facet's contribution, so meshes
//! should be finer where parts shadow each other.

use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::eval::Evaluator;
use crate::queries::{aspect_queries, QueryBatch};
use crate::scene::{Mode, Scene};

/// What `brdf scene lrcs --json` prints and `brdf.scene_lrcs(...).to_json()` returns: the
/// scene, its materials and σ at every aspect.
#[derive(Debug, Serialize)]
pub struct LrcsReport<'a> {
    /// The scene file as given.
    pub scene: String,
    /// The mesh file.
    pub mesh: String,
    /// Facets in the mesh.
    pub facets: usize,
    /// `monostatic` or `bistatic`.
    pub mode: &'static str,
    /// Source-receiver separation of a bistatic sweep, degrees.
    pub separation_deg: Option<f64>,
    /// The materials in scene order.
    pub materials: Vec<LrcsMaterial>,
    /// Wall time of the sweep, s.
    pub seconds: f64,
    /// σ per aspect.
    pub aspects: &'a [AspectSigma],
}

/// One material of an [`LrcsReport`].
#[derive(Debug, Serialize)]
pub struct LrcsMaterial {
    /// The mesh part it covers.
    pub part: String,
    /// Its model's name.
    pub model: &'static str,
    /// Its parameters, in the model's order.
    pub params: Vec<f64>,
}

impl<'a> LrcsReport<'a> {
    /// The report of `result`, the sweep of `scene` loaded from the file named `name`.
    pub fn new(name: String, scene: &Scene, result: &'a Lrcs) -> Self {
        let (mode, separation_deg) = match scene.sensor.mode {
            Mode::Monostatic => ("monostatic", None),
            Mode::Bistatic { separation_deg } => ("bistatic", Some(separation_deg)),
        };
        LrcsReport {
            scene: name,
            mesh: scene.mesh.file.display().to_string(),
            facets: scene.mesh.facets.len(),
            mode,
            separation_deg,
            materials: scene
                .materials
                .iter()
                .map(|m| LrcsMaterial {
                    part: m.part.clone(),
                    model: m.model.kind().name(),
                    params: m.model.to_params()[..m.model.kind().param_count()].to_vec(),
                })
                .collect(),
            seconds: result.seconds,
            aspects: &result.aspects,
        }
    }
}

/// σ over a sweep.
#[derive(Clone, Debug, Serialize)]
pub struct Lrcs {
    /// Aspects in sweep order.
    pub aspects: Vec<AspectSigma>,
    /// Wall time, s.
    pub seconds: f64,
}

/// σ at one aspect.
#[derive(Clone, Debug, Serialize)]
pub struct AspectSigma {
    /// Receiver azimuth, degrees.
    pub azimuth: f64,
    /// Receiver elevation, degrees.
    pub elevation: f64,
    /// σ, m².
    pub lrcs: f64,
    /// Each material's share, m² (scene order).
    pub by_material: Vec<f64>,
    /// Facets seen by both source and receiver.
    pub facets_seen: usize,
}

/// σ at every aspect with each material's exact model (f64), in parallel over aspects;
/// `progress` is called once per aspect done.
pub fn lrcs(scene: &Scene, progress: &(dyn Fn() + Sync)) -> Lrcs {
    let models: Vec<Evaluator> = scene
        .materials
        .iter()
        .map(|m| Evaluator::Exact(m.model))
        .collect();
    lrcs_with(scene, &models, progress)
}

/// σ at every aspect with the given representation of each material (scene order).
pub fn lrcs_with(scene: &Scene, models: &[Evaluator], progress: &(dyn Fn() + Sync)) -> Lrcs {
    let started = Instant::now();
    let aspects: Vec<AspectSigma> = scene
        .aspects()
        .par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(stack, scratch), a| {
                let batches = aspect_queries(scene, a, stack);
                let by_material: Vec<f64> = batches
                    .iter()
                    .zip(models)
                    .map(|(b, m)| b.sigma(m, scratch))
                    .collect();
                progress();
                AspectSigma {
                    azimuth: a.azimuth_deg,
                    elevation: a.elevation_deg,
                    lrcs: by_material.iter().fold(0.0, |s, m| s + m), // from +0, as `QueryBatch::sigma`
                    by_material,
                    facets_seen: batches.iter().map(QueryBatch::len).sum(),
                }
            },
        )
        .collect();
    Lrcs {
        aspects,
        seconds: started.elapsed().as_secs_f64(),
    }
}
