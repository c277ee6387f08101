//! `brdf.scene_lrcs`, `brdf.scene_domain`, `brdf.select_scene`: the scene commands through the same library calls, each interrupted at once by Ctrl-C.

use super::*;

/// The scene at `path`, or the message `brdf scene` prints when it cannot be used.
pub(crate) fn scene_at(path: &str) -> PyResult<brdf_scene::scene::Scene> {
    brdf_scene::scene::Scene::open(std::path::Path::new(path))
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// σ per aspect, as `brdf scene lrcs` computes it.
pub(crate) type SceneLrcs = (
    String,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
    Vec<Vec<f64>>,
    Vec<usize>,
    Vec<String>,
);

/// `brdf scene lrcs` through the same library calls (`brdf_scene::lrcs::lrcs`, or with
/// `area` (pixels, supersample) `lrcs_by_area`; `LrcsReport`): the JSON `--json` prints, then
/// per aspect azimuth, elevation, σ, each material's share and the facets seen, then the
/// materials' parts.
#[pyfunction]
#[pyo3(signature = (path, area=None))]
pub(crate) fn scene_lrcs(py: Python<'_>, path: String, area: Option<(usize, usize)>) -> PyResult<SceneLrcs> {
    use brdf_scene::lrcs::{lrcs_by_area, lrcs_until, LrcsReport};
    let scene = scene_at(&path)?;
    // Ctrl-C raises at once (`interruptible`); the sweep then ends within one aspect's work.
    crate::fit::interruptible(py, move |stop| -> Result<SceneLrcs, String> {
        let result = match area {
            None => lrcs_until(&scene, &|| {}, stop),
            Some((pixels, supersample)) => {
                let options = brdf_scene::image::ImageOptions { pixels, supersample };
                lrcs_by_area(&scene, &options, &|| {}, stop).map_err(|e| e.to_string())?
            }
        }
        .ok_or("the sweep was stopped")?;
        let text = serde_json::to_string_pretty(&LrcsReport::new(path, &scene, &result))
            .map_err(|e| e.to_string())?;
        let a = &result.aspects;
        Ok((
            text,
            a.iter().map(|x| x.azimuth).collect(),
            a.iter().map(|x| x.elevation).collect(),
            a.iter().map(|x| x.lrcs).collect(),
            a.iter().map(|x| x.by_material.clone()).collect(),
            a.iter().map(|x| x.facets_seen).collect(),
            scene.materials.iter().map(|m| m.part.clone()).collect(),
        ))
    })?
    .map_err(PyValueError::new_err)
}

/// The scene's queries, as `brdf scene domain` writes them.
pub(crate) type SceneDomain = (
    Vec<f64>,
    Vec<f64>,
    Vec<usize>,
    Vec<String>,
    Vec<usize>,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
    Vec<f64>,
);

/// `brdf scene domain` through the same library calls (`brdf_scene::queries::collect_queries`,
/// `brdf_scene::queries::rows`): its columns, in its row order.
#[pyfunction]
pub(crate) fn scene_domain(py: Python<'_>, path: String) -> PyResult<SceneDomain> {
    let scene = scene_at(&path)?;
    crate::fit::interruptible(py, move |_| {
        let d = brdf_scene::queries::collect_queries(&scene, &|| {});
        let mut c: SceneDomain = Default::default();
        for r in brdf_scene::queries::rows(&scene, &d) {
            c.0.push(r.azimuth);
            c.1.push(r.elevation);
            c.2.push(r.material);
            c.3.push(r.part.to_owned());
            c.4.push(r.facet);
            c.5.push(r.theta_i);
            c.6.push(r.theta_r);
            c.7.push(r.phi);
            c.8.push(r.weight);
        }
        c
    })
}

/// A scene's range profiles, as `brdf scene profile` writes them: azimuth, elevation,
/// range_m, lrcs per row.
pub(crate) type SceneProfile = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// `brdf scene profile` through the same library call (`brdf_scene::profile::profile`): its
/// columns, in its row order.
#[pyfunction]
#[pyo3(signature = (path, bin_m, pulse_m=None))]
pub(crate) fn scene_profile(
    py: Python<'_>,
    path: String,
    bin_m: f64,
    pulse_m: Option<f64>,
) -> PyResult<SceneProfile> {
    use brdf_scene::profile::{check, profile, ProfileOptions};
    let scene = scene_at(&path)?;
    let options = ProfileOptions { bin_m, pulse_m };
    check(&scene, &options).map_err(|e| PyValueError::new_err(e.to_string()))?;
    crate::fit::interruptible(py, move |_| -> Result<SceneProfile, String> {
        let profiles = profile(&scene, &options, &|| {}).map_err(|e| e.to_string())?;
        let mut c: SceneProfile = Default::default();
        for p in &profiles {
            for (j, v) in p.sigma.iter().enumerate() {
                c.0.push(p.azimuth);
                c.1.push(p.elevation);
                c.2.push(p.range_m(j, bin_m));
                c.3.push(*v);
            }
        }
        Ok(c)
    })?
    .map_err(PyValueError::new_err)
}

/// A laser image: width, height, pixel side, σ and range per pixel (row by row from the
/// top), the sampling bound, the lower left corner on the image's axes.
pub(crate) type SceneImage = (usize, usize, f64, Vec<f64>, Vec<f64>, f64, [f64; 2]);

/// `brdf scene image` through the same library call (`brdf_scene::image::image`), at the
/// aspect given or the sweep's first.
#[pyfunction]
#[pyo3(signature = (path, azimuth=None, elevation=None, pixels=brdf_scene::image::IMAGE_PIXELS, supersample=brdf_scene::image::SUPERSAMPLE))]
pub(crate) fn scene_image(
    py: Python<'_>,
    path: String,
    azimuth: Option<f64>,
    elevation: Option<f64>,
    pixels: usize,
    supersample: usize,
) -> PyResult<SceneImage> {
    use brdf_scene::image::{image, ImageOptions};
    use brdf_scene::scene::Aspect;
    let scene = scene_at(&path)?;
    let aspect = match (azimuth, elevation) {
        (None, None) => scene.aspects()[0],
        (Some(az), Some(el)) => {
            let turns = brdf_fit::data::PHI_LIMIT_DEG;
            if !(az.is_finite() && az.abs() <= turns) {
                return Err(PyValueError::new_err(format!(
                    "azimuth {az}: not in [-{turns}, {turns}] degrees"
                )));
            }
            if !(el.is_finite() && el.abs() <= 90.0) {
                return Err(PyValueError::new_err(format!(
                    "elevation {el}: not in [-90, 90] degrees"
                )));
            }
            Aspect {
                azimuth_deg: az,
                elevation_deg: el,
            }
        }
        _ => {
            return Err(PyValueError::new_err(
                "give azimuth and elevation together, or neither",
            ))
        }
    };
    let options = ImageOptions { pixels, supersample };
    crate::fit::interruptible(py, move |_| -> Result<SceneImage, String> {
        let img = image(&scene, &aspect, &options).map_err(|e| e.to_string())?;
        let bound = img.sigma_bound();
        Ok((
            img.width,
            img.height,
            img.pixel_m,
            img.sigma,
            img.range,
            bound,
            img.origin_m,
        ))
    })?
    .map_err(PyValueError::new_err)
}

/// `brdf select --scene` through the same library calls (`brdf_scene::queries::collect_queries`,
/// `brdf_scene::select::select`): the JSON `--json` prints, the blob `-o` writes (or None)
/// and why there is none.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn select_scene<'py>(
    py: Python<'py>,
    path: String,
    budget: f64,
    seed: u64,
    sequence: u32,
    allow_nonphysical: bool,
) -> PyResult<(String, Option<Bound<'py, PyBytes>>, Option<String>)> {
    use brdf_scene::select::{select, SelectOptions};
    check_budget(budget).map_err(PyValueError::new_err)?;
    let scene = scene_at(&path)?;
    brdf_scene::select::selectable(&scene).map_err(PyValueError::new_err)?;
    let opts = SelectOptions {
        budget,
        fit: FitOptions {
            seed,
            ..FitOptions::default()
        },
        sequence,
        allow_nonphysical,
        ..SelectOptions::default()
    };
    let (text, blob, note) = crate::fit::interruptible(py, move |_| {
        let domain = brdf_scene::queries::collect_queries(&scene, &|| {});
        let s = select(&scene, &domain, &opts);
        let text = serde_json::to_string_pretty(&s).map_err(|e| e.to_string());
        (text, s.blob().map(<[u8]>::to_vec), s.blob_note.clone())
    })?;
    let text = text.map_err(PyValueError::new_err)?;
    Ok((text, blob.map(|b| PyBytes::new(py, &b)), note))
}
