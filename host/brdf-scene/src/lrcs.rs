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

use brdf_fit::Stop;

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
    /// The sensor's wavelength, µm (`[sensor] wavelength_um`), at which spectral materials
    /// are taken.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wavelength_um: Option<f64>,
    /// A list of wavelengths (µm), σ at each in every aspect's `by_wavelength`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wavelengths_um: Option<Vec<f64>>,
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
    /// Its parameters, in the model's order (a fitted table's base).
    pub params: Vec<f64>,
    /// Whether it carries a fitted table (the model is then its base).
    pub fitted_table: bool,
    /// A spectral fit at the sensor's wavelength: the band used (`six (fit 15)`), or the two
    /// blended (`six (fit 15) x 0.25 + six (fit 16) x 0.75`; `model` and `params` are then the
    /// band below's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub band: Option<String>,
    /// With a list of wavelengths: the band or bands used at each, as `band`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bands_by_wavelength: Option<Vec<Option<String>>>,
    /// With a fitted table: the share of the material's σ, summed over the sweep, that comes
    /// from lookups outside the table's coverage (where it holds the smoothness term's
    /// extrapolation, not a measurement).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub outside_coverage: Option<f64>,
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
            wavelength_um: scene.wavelength_um,
            wavelengths_um: (!scene.spectrum.is_empty())
                .then(|| scene.spectrum.iter().map(|w| w.0).collect()),
            materials: scene
                .materials
                .iter()
                .enumerate()
                .map(|(k, m)| LrcsMaterial {
                    part: m.part.clone(),
                    model: m.model.kind().name(),
                    params: m.model.to_params()[..m.model.kind().param_count()].to_vec(),
                    fitted_table: m.table.is_some(),
                    band: scene.band_used(k),
                    bands_by_wavelength: (!scene.spectrum.is_empty()).then(|| {
                        scene
                            .spectrum
                            .iter()
                            .map(|(um, mats)| mats[k].band_used(Some(*um)))
                            .collect()
                    }),
                    outside_coverage: m.table.as_ref().map(|_| result.outside_coverage(k)),
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
    /// σ at each wavelength of the scene's list (`Scene::spectrum`), m²; empty without one.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub by_wavelength: Vec<f64>,
    /// With visibility by area ([`lrcs_by_area`]): the bound on σ's sampling error, m².
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampling_bound: Option<f64>,
    /// Each material's share of σ from lookups outside its fitted table's coverage, m² (0
    /// for materials without one).
    #[serde(skip)]
    pub outside_coverage: Vec<f64>,
}

impl Lrcs {
    /// The share of material `m`'s σ, summed over the sweep, from lookups outside its fitted
    /// table's coverage (0 when it has none or is never seen).
    pub fn outside_coverage(&self, m: usize) -> f64 {
        let (mut out, mut all) = (0.0, 0.0);
        for a in &self.aspects {
            out += a.outside_coverage.get(m).copied().unwrap_or(0.0);
            all += a.by_material.get(m).copied().unwrap_or(0.0);
        }
        if all > 0.0 {
            out / all
        } else {
            0.0
        }
    }
}

/// σ at every aspect with each material's exact model (f64), in parallel over aspects;
/// `progress` is called once per aspect done.
/// With a list of wavelengths, σ at each too (`AspectSigma::by_wavelength`, the visibility
/// traced once).
pub fn lrcs(scene: &Scene, progress: &(dyn Fn() + Sync)) -> Lrcs {
    let models: Vec<Evaluator> = scene.materials.iter().map(|m| m.evaluator()).collect();
    lrcs_with_until(scene, &models, &spectral_models(scene), progress, &Stop::new())
}

/// The evaluators of every wavelength of the scene's list.
fn spectral_models(scene: &Scene) -> Vec<Vec<Evaluator>> {
    scene
        .spectrum
        .iter()
        .map(|(_, mats)| mats.iter().map(|m| m.evaluator()).collect())
        .collect()
}

/// σ at every aspect with the given representation of each material (scene order).
pub fn lrcs_with(scene: &Scene, models: &[Evaluator], progress: &(dyn Fn() + Sync)) -> Lrcs {
    lrcs_with_until(scene, models, &[], progress, &Stop::new())
}

/// [`lrcs`] that ends within one aspect's work once `stop` is requested (the Python package's
/// Ctrl-C): `None` then, and the sweep's threads are free.
pub fn lrcs_until(scene: &Scene, progress: &(dyn Fn() + Sync), stop: &Stop) -> Option<Lrcs> {
    let models: Vec<Evaluator> = scene.materials.iter().map(|m| m.evaluator()).collect();
    let result = lrcs_with_until(scene, &models, &spectral_models(scene), progress, stop);
    (!stop.requested()).then_some(result)
}

/// [`lrcs_with`], each aspect skipped once `stop` is requested (the result is then partial,
/// its skipped aspects zero, and meant to be dropped: [`lrcs_until`]).
fn lrcs_with_until(
    scene: &Scene,
    models: &[Evaluator],
    spectral: &[Vec<Evaluator>],
    progress: &(dyn Fn() + Sync),
    stop: &Stop,
) -> Lrcs {
    let started = Instant::now();
    let aspects: Vec<AspectSigma> = scene
        .aspects()
        .par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(stack, scratch), a| {
                if stop.requested() {
                    return AspectSigma {
                        azimuth: a.azimuth_deg,
                        elevation: a.elevation_deg,
                        lrcs: 0.0,
                        by_material: Vec::new(),
                        facets_seen: 0,
                        by_wavelength: Vec::new(),
                        sampling_bound: None,
                        outside_coverage: Vec::new(),
                    };
                }
                let batches = aspect_queries(scene, a, stack);
                let (by_material, outside_coverage): (Vec<f64>, Vec<f64>) = batches
                    .iter()
                    .zip(models)
                    .map(|(b, m)| {
                        let sigma = b.sigma(m, scratch);
                        // `scratch` holds the values `sigma` summed.
                        let outside = m.fitted_table().map_or(0.0, |t| b.outside_coverage(&t, scratch));
                        (sigma, outside)
                    })
                    .unzip();
                let by_wavelength: Vec<f64> = spectral
                    .iter()
                    .map(|ms| {
                        batches
                            .iter()
                            .zip(ms)
                            .map(|(b, m)| b.sigma(m, scratch))
                            .fold(0.0, |s, x| s + x)
                    })
                    .collect();
                progress();
                AspectSigma {
                    azimuth: a.azimuth_deg,
                    elevation: a.elevation_deg,
                    lrcs: by_material.iter().fold(0.0, |s, m| s + m), // from +0, as `QueryBatch::sigma`
                    by_material,
                    facets_seen: batches.iter().map(QueryBatch::len).sum(),
                    by_wavelength,
                    sampling_bound: None,
                    outside_coverage,
                }
            },
        )
        .collect();
    Lrcs {
        aspects,
        seconds: started.elapsed().as_secs_f64(),
    }
}

/// σ at every aspect with visibility by the part of each facet seen: each aspect's laser
/// image ([`crate::image::image`]) summed, in parallel over aspects, each with its sampling
/// bound ([`AspectSigma::sampling_bound`]); `None` once `stop` is requested. At one
/// wavelength only (a scene's list of wavelengths is refused).
pub fn lrcs_by_area(
    scene: &Scene,
    options: &crate::image::ImageOptions,
    progress: &(dyn Fn() + Sync),
    stop: &Stop,
) -> Result<Option<Lrcs>, crate::image::ImageError> {
    scene
        .one_wavelength("visibility by area")
        .map_err(crate::image::ImageError::Refused)?;
    let started = Instant::now();
    let aspects: Vec<Result<Option<AspectSigma>, crate::image::ImageError>> = scene
        .aspects()
        .par_iter()
        .map_init(crate::image::Scratch::default, |scratch, a| {
            if stop.requested() {
                return Ok(None);
            }
            let img = crate::image::sigma_by_area(scene, a, options, scratch)?;
            progress();
            Ok(Some(AspectSigma {
                azimuth: a.azimuth_deg,
                elevation: a.elevation_deg,
                lrcs: img.by_material.iter().fold(0.0, |s, m| s + m),
                facets_seen: img.facets_seen,
                by_wavelength: Vec::new(),
                sampling_bound: Some(img.bound),
                outside_coverage: img.outside_coverage,
                by_material: img.by_material,
            }))
        })
        .collect();
    let mut out = Vec::with_capacity(aspects.len());
    for a in aspects {
        match a? {
            Some(a) => out.push(a),
            None => return Ok(None),
        }
    }
    Ok(Some(Lrcs {
        aspects: out,
        seconds: started.elapsed().as_secs_f64(),
    }))
}
