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

use std::f64::consts::PI;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::eval::{sigma, Evaluator};
use crate::mesh::v3;
use crate::scene::{Aspect, Mode, Scene};

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

/// The queries one material receives at one aspect, as slices ([`crate::eval::eval_batch`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Batch {
    /// `cos theta_i` per facet seen.
    pub cos_theta_i: Vec<f64>,
    /// `cos theta_r`.
    pub cos_theta_r: Vec<f64>,
    /// `cos phi`.
    pub cos_phi: Vec<f64>,
    /// `4 pi cos(theta_i) cos(theta_r) A`, m² sr: the facet's σ per unit BRDF.
    pub weight: Vec<f64>,
    /// Facet index (0-based, mesh order).
    pub facet: Vec<u32>,
}

impl Batch {
    /// Queries in the batch.
    pub fn len(&self) -> usize {
        self.weight.len()
    }

    /// No queries.
    pub fn is_empty(&self) -> bool {
        self.weight.is_empty()
    }
}

/// The queries of one aspect, one [`Batch`] per material (scene order). `stack` is scratch
/// space for the occlusion rays.
pub fn queries(scene: &Scene, aspect: &Aspect, stack: &mut Vec<usize>) -> Vec<Batch> {
    let v = aspect.receiver();
    let s = aspect.source(scene.sensor.mode);
    let mono = scene.sensor.mode == Mode::Monostatic;
    let mut out = vec![Batch::default(); scene.materials.len()];
    for (k, f) in scene.mesh.facets.iter().enumerate() {
        let n = f.normal;
        let (mu_i, mu_r) = (v3::dot(n, s), v3::dot(n, v));
        if !(mu_i > 0.0 && mu_r > 0.0) {
            continue;
        }
        if scene.occluder.blocked(f.centroid, v, k, stack) {
            continue;
        }
        if !mono && scene.occluder.blocked(f.centroid, s, k, stack) {
            continue;
        }
        let cos_phi = if mono { 1.0 } else { cos_phi(n, s, v, mu_i, mu_r) };
        let b = &mut out[scene.facet_material[k] as usize];
        b.cos_theta_i.push(mu_i);
        b.cos_theta_r.push(mu_r);
        b.cos_phi.push(cos_phi);
        b.weight.push(4.0 * PI * mu_i * mu_r * f.area);
        b.facet.push(k as u32);
    }
    out
}

/// `cos phi` between the projections of `s` and `v` on the plane with normal `n`; 1 where
/// either projection vanishes (a direction along the normal, where `phi` does not matter).
/// Symmetric in `s` and `v`, operation by operation, so swapping source and receiver gives
/// the same bits.
fn cos_phi(n: [f64; 3], s: [f64; 3], v: [f64; 3], mu_i: f64, mu_r: f64) -> f64 {
    let st = v3::sub(s, v3::scale(n, mu_i));
    let vt = v3::sub(v, v3::scale(n, mu_r));
    let (ss, vv) = (v3::dot(st, st), v3::dot(vt, vt));
    if ss <= 1e-30 || vv <= 1e-30 {
        return 1.0;
    }
    (v3::dot(st, vt) / (ss * vv).sqrt()).clamp(-1.0, 1.0)
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
                let batches = queries(scene, a, stack);
                let by_material: Vec<f64> = batches
                    .iter()
                    .zip(models)
                    .map(|(b, m)| sigma(m, b, scratch))
                    .collect();
                progress();
                AspectSigma {
                    azimuth: a.azimuth_deg,
                    elevation: a.elevation_deg,
                    lrcs: by_material.iter().sum(),
                    by_material,
                    facets_seen: batches.iter().map(Batch::len).sum(),
                }
            },
        )
        .collect();
    Lrcs {
        aspects,
        seconds: started.elapsed().as_secs_f64(),
    }
}

/// Every query the scene makes: per aspect, one [`Batch`] per material.
#[derive(Clone, Debug)]
pub struct Domain {
    /// Aspects in sweep order.
    pub aspects: Vec<Aspect>,
    /// `batches[a][m]`: the queries of material `m` at aspect `a`.
    pub batches: Vec<Vec<Batch>>,
}

impl Domain {
    /// Number of queries in all.
    pub fn len(&self) -> usize {
        self.batches.iter().flatten().map(Batch::len).sum()
    }

    /// No queries at all (nothing seen at any aspect).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// σ of each material at each aspect, `[aspect][material]`, m².
    pub fn sigma(&self, models: &[Evaluator]) -> Vec<Vec<f64>> {
        self.batches
            .par_iter()
            .map_init(Vec::new, |scratch, per| {
                per.iter()
                    .zip(models)
                    .map(|(b, m)| sigma(m, b, scratch))
                    .collect()
            })
            .collect()
    }
}

/// Collects the queries of every aspect (in parallel; `progress` once per aspect). Memory:
/// 36 bytes per query.
pub fn domain(scene: &Scene, progress: &(dyn Fn() + Sync)) -> Domain {
    let aspects = scene.aspects();
    let batches = aspects
        .par_iter()
        .map_init(Vec::new, |stack, a| {
            let b = queries(scene, a, stack);
            progress();
            b
        })
        .collect();
    Domain { aspects, batches }
}
