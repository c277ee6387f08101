//! The scene file: a target mesh, a material per part, and a sensor sweep (TOML).
//!
//! ```toml
//! mesh = "target.obj"            # relative to this file; OBJ (objects/groups = parts) or STL; metres
//! [[material]]
//! part = "hull"                  # OBJ object or group name; "*" = every part no other entry names
//! model = "six"                  # model and params as in `brdf eval` ...
//! params = "kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676,c=1.2"
//! # ... or fit = "hull.json" (a `brdf fit --json` or `brdf select --chosen` result, a fitted
//! #     table included; index = k for the k-th of a batch; the bands of a spectral fit at
//! #     [sensor] wavelength_um, index = any fit of the measurement when it holds several)
//! # ... or blob = "params.bin" with index = 0 (a parameter blob's material: its fitted table is
//! #     used, its six-parameter lookup tables are not: sigma is computed in f64; a banded
//! #     material's band at [sensor] wavelength_um, or the two around it blended)
//! [sensor]
//! mode = "monostatic"            # or "bistatic" with separation_deg
//! wavelength_um = 0.55           # optional: each spectral fit's band there, or the two bands
//!                                # around it interpolated linearly (never extrapolated); or a
//!                                # list, [0.45, 0.55, 0.65]: sigma at each (one column each)
//! azimuth_deg = [0, 360, 5]      # start, stop (exclusive), step
//! elevation_deg = [0, 31, 15]
//! ```
//!
//! The receiver direction in the mesh frame is `(cos el cos az, cos el sin az, sin el)`
//! (pointing from the target towards the receiver); in bistatic mode the source direction is
//! the receiver's rotated by `separation_deg` about `z` (azimuth `az + separation`, same
//! elevation). Aspects run elevation by elevation, azimuth fastest.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use brdf_core::bands::Located;
use brdf_core::{AnyModel, ModelKind, MAX_PARAMS};
use brdf_fit::report::FittedModel;
use brdf_fit::spectral::{AtWavelength, BandFits};
use serde::Deserialize;
use thiserror::Error;
use toml::Spanned;

use crate::mesh::{Mesh, MeshError, Origin};
use crate::occlusion::Occluder;

/// Most aspects a sweep may have (a typo such as a step of 0.0001 would otherwise run for
/// days): 10^6.
pub const MAX_ASPECTS: usize = 1_000_000;

/// A scene file that cannot be used, with the file named: `cannot use scene PATH: why`
/// ([`Scene::open`]).
#[derive(Debug, Error)]
#[error("cannot use scene {path}: {source}")]
pub struct LoadError {
    /// The scene file as given.
    pub path: String,
    /// Why.
    #[source]
    pub source: Box<SceneError>,
}

/// Why a scene was refused.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The scene file (or a file it names) could not be read.
    #[error("{file}: cannot read: {source}")]
    Io {
        /// File.
        file: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Not valid TOML, or a key of the wrong type, missing or unknown (the message names
    /// line and column).
    #[error("{file}: {message}")]
    Toml {
        /// Scene file.
        file: String,
        /// The parser's message.
        message: String,
    },
    /// A value that is well-formed but unusable.
    #[error("{file}: line {line}: {field}: {message}")]
    Field {
        /// Scene file.
        file: String,
        /// 1-based line of the value.
        line: u64,
        /// Key.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The mesh was refused.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A part of the mesh that no material entry covers.
    #[error(
        "{mesh}: part `{part}` (first facet at {at}) has no material: add a [[material]] with \
         part = \"{part}\" or part = \"*\" to {scene}"
    )]
    Uncovered {
        /// Mesh file.
        mesh: String,
        /// Scene file.
        scene: String,
        /// The part.
        part: String,
        /// Its first facet.
        at: Origin,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    mesh: Spanned<String>,
    #[serde(rename = "material", default)]
    materials: Vec<Spanned<MaterialEntry>>,
    sensor: Spanned<SensorEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialEntry {
    part: Spanned<String>,
    model: Option<Spanned<String>>,
    params: Option<Spanned<String>>,
    fit: Option<Spanned<String>>,
    blob: Option<Spanned<String>>,
    index: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorEntry {
    mode: Spanned<String>,
    wavelength_um: Option<Spanned<Wavelengths>>,
    separation_deg: Option<Spanned<f64>>,
    azimuth_deg: Spanned<Vec<f64>>,
    elevation_deg: Spanned<Vec<f64>>,
}

/// `wavelength_um = 0.55` or `wavelength_um = [0.45, 0.55]`.
#[derive(Deserialize)]
#[serde(untagged)]
enum Wavelengths {
    One(f64),
    Many(Vec<f64>),
}

/// Most wavelengths one scene lists (`[sensor] wavelength_um = [...]`): the bands of a
/// spectral fit on a device ([`brdf_core::bands::MAX_BANDS`]).
pub const MAX_WAVELENGTHS: usize = brdf_core::bands::MAX_BANDS;

/// Where a material's parameters came from.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// `model` and `params` in the scene file.
    Params,
    /// A `brdf fit --json` result (file, index in a batch).
    Fit(PathBuf, usize),
    /// A parameter blob's material (file, index).
    Blob(PathBuf, usize),
}

/// One `[[material]]` entry, resolved.
#[derive(Clone, Debug)]
pub struct SceneMaterial {
    /// The part it covers (`*` for the rest).
    pub part: String,
    /// The model, f64 (a fitted table's base when `table` is given).
    pub model: AnyModel<f64>,
    /// A fitted table's device bytes (`brdf_core::fitted`): the material is then `model`
    /// times the tabulated correction (a `brdf select --chosen` fit, or a blob material
    /// that carries one).
    pub table: Option<Vec<u8>>,
    /// Where the parameters came from.
    pub source: Source,
    /// Line of the entry's `part` in the scene file (0 for scenes built in memory).
    pub line: u64,
    /// At a wavelength between two bands of a spectral fit, the band above: the material is
    /// then `(1 - weight) f(model, table) + weight f(upper)` (`model` and `table` are the band
    /// below; [`brdf_fit::spectral::AtWavelength`]).
    pub upper: Option<Upper>,
    /// When the material was taken from bands at the scene's wavelength (one band, or two
    /// with `upper`): the band used (the lower of two): its fit's index in a fit file, its
    /// band's index in a blob material.
    pub band: Option<usize>,
}

/// The band above a scene's wavelength, for a material interpolated between two bands.
#[derive(Clone, Debug)]
pub struct Upper {
    /// The band's model, f64.
    pub model: AnyModel<f64>,
    /// Its fitted table's device bytes, if any.
    pub table: Option<Vec<u8>>,
    /// Its index in the fit file.
    pub index: usize,
    /// Its weight, in (0, 1).
    pub weight: f64,
}

impl SceneMaterial {
    /// A material for `part` from a model and its parameters.
    pub fn new(part: &str, model: AnyModel<f64>) -> SceneMaterial {
        SceneMaterial {
            part: part.to_owned(),
            model,
            table: None,
            source: Source::Params,
            line: 0,
            upper: None,
            band: None,
        }
    }

    /// How σ evaluates this material: the exact f64 model, or its base times its fitted
    /// table in f64; between two bands, the two blended.
    pub fn evaluator(&self) -> crate::eval::Evaluator {
        use crate::eval::Evaluator;
        let exact = |model: AnyModel<f64>, table: &Option<Vec<u8>>| match table {
            Some(bytes) => Evaluator::ExactCorrected {
                base: model,
                bytes: bytes.clone(),
            },
            None => Evaluator::Exact(model),
        };
        let own = exact(self.model, &self.table);
        match &self.upper {
            Some(u) => Evaluator::Blend {
                lower: Box::new(own),
                upper: Box::new(exact(u.model, &u.table)),
                weight: u.weight,
            },
            None => own,
        }
    }
}

/// Monostatic or bistatic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// Source and receiver in the same direction.
    Monostatic,
    /// The source direction is the receiver's rotated about `z` by this many degrees.
    Bistatic {
        /// Degrees.
        separation_deg: f64,
    },
}

/// One sensor position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aspect {
    /// Receiver azimuth, degrees.
    pub azimuth_deg: f64,
    /// Receiver elevation, degrees.
    pub elevation_deg: f64,
}

/// Unit vector at azimuth `az` and elevation `el` (degrees) in the mesh frame.
pub fn direction(az_deg: f64, el_deg: f64) -> [f64; 3] {
    let (sa, ca) = az_deg.to_radians().sin_cos();
    let (se, ce) = el_deg.to_radians().sin_cos();
    [ce * ca, ce * sa, se]
}

impl Aspect {
    /// Unit vector towards the receiver, mesh frame.
    pub fn receiver(&self) -> [f64; 3] {
        direction(self.azimuth_deg, self.elevation_deg)
    }

    /// Unit vector towards the source, mesh frame.
    pub fn source(&self, mode: Mode) -> [f64; 3] {
        match mode {
            Mode::Monostatic => self.receiver(),
            Mode::Bistatic { separation_deg } => {
                direction(self.azimuth_deg + separation_deg, self.elevation_deg)
            }
        }
    }
}

/// The sensor and its sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Sensor {
    /// Monostatic or bistatic.
    pub mode: Mode,
    /// Azimuths, degrees.
    pub azimuth_deg: Vec<f64>,
    /// Elevations, degrees.
    pub elevation_deg: Vec<f64>,
}

impl Sensor {
    /// Every aspect, elevation by elevation, azimuth fastest.
    pub fn aspects(&self) -> Vec<Aspect> {
        self.elevation_deg
            .iter()
            .flat_map(|&el| {
                self.azimuth_deg.iter().map(move |&az| Aspect {
                    azimuth_deg: az,
                    elevation_deg: el,
                })
            })
            .collect()
    }
}

/// A target, its materials and a sensor, ready to trace.
pub struct Scene {
    /// Scene file (or a label).
    pub file: PathBuf,
    /// The target.
    pub mesh: Mesh,
    /// Materials, in scene-file order (the order of a blob `brdf select --scene` writes).
    pub materials: Vec<SceneMaterial>,
    /// Material of each facet (index into `materials`).
    pub facet_material: Vec<u32>,
    /// Sensor.
    pub sensor: Sensor,
    /// The BVH for occlusion rays, built on first use ([`Scene::occluder`]: visibility by
    /// area never needs it).
    occluder: OnceLock<Occluder>,
    /// The mesh laid out for depth buffers, built on first use ([`Scene::raster_mesh`]).
    raster: OnceLock<crate::image::RasterMesh>,
    /// The sensor's wavelength, µm (`[sensor] wavelength_um`): the band of each spectral
    /// material used (the first of a list).
    pub wavelength_um: Option<f64>,
    /// With a list of wavelengths (`wavelength_um = [0.45, 0.55]`): every one with the
    /// materials there, in scene order (the first's are `materials`); empty otherwise.
    /// [`crate::lrcs::lrcs`] gives σ at each (`AspectSigma::by_wavelength`).
    pub spectrum: Vec<(f64, Vec<SceneMaterial>)>,
    /// Shard `k` of `n` of the sweep ([`Scene::with_shard`]), or the whole sweep.
    shard: Option<(usize, usize)>,
}

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("file", &self.file)
            .field("mesh", &self.mesh)
            .field("materials", &self.materials)
            .field("mode", &self.sensor.mode)
            .field("aspects", &self.aspects().len())
            .finish()
    }
}

/// 1-based line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> u64 {
    text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count() as u64
        + 1
}

impl Scene {
    /// Builds a scene from a mesh, materials and a sensor (the part of each material must
    /// name a part of the mesh, or be `*`).
    pub fn new(
        file: PathBuf,
        mesh: Mesh,
        materials: Vec<SceneMaterial>,
        sensor: Sensor,
    ) -> Result<Scene, SceneError> {
        let scene = file.display().to_string();
        let mut facet_material = vec![u32::MAX; mesh.facets.len()];
        let mut part_material = vec![None; mesh.parts.len()];
        let mut star = None;
        for (m, mat) in materials.iter().enumerate() {
            let dup = |what: String| SceneError::Field {
                file: scene.clone(),
                line: mat.line,
                field: "part",
                message: what,
            };
            if mat.part == "*" {
                if star.replace(m).is_some() {
                    return Err(dup("a second entry with part = \"*\"".into()));
                }
                continue;
            }
            let Some(p) = mesh.parts.iter().position(|p| *p == mat.part) else {
                return Err(dup(format!(
                    "no part `{}` in {} (its parts: {})",
                    mat.part,
                    mesh.file.display(),
                    mesh.parts.join(", ")
                )));
            };
            if part_material[p].replace(m).is_some() {
                return Err(dup(format!("part `{}` has a material already", mat.part)));
            }
        }
        for (k, f) in mesh.facets.iter().enumerate() {
            let p = f.part as usize;
            match part_material[p].or(star) {
                Some(m) => facet_material[k] = m as u32,
                None => {
                    return Err(SceneError::Uncovered {
                        mesh: mesh.file.display().to_string(),
                        scene,
                        part: mesh.parts[p].clone(),
                        at: mesh.origins[k],
                    })
                }
            }
        }
        // An entry that colours nothing is a mistake the sweep would not show.
        if let Some(m) = star {
            if part_material.iter().all(Option::is_some) {
                return Err(SceneError::Field {
                    file: scene,
                    line: materials[m].line,
                    field: "part",
                    message: format!(
                        "\"*\" covers no part: every part of {} has its own entry",
                        mesh.file.display()
                    ),
                });
            }
        }
        Ok(Scene {
            file,
            mesh,
            materials,
            facet_material,
            sensor,
            occluder: OnceLock::new(),
            raster: OnceLock::new(),
            wavelength_um: None,
            spectrum: Vec::new(),
            shard: None,
        })
    }

    /// The BVH for occlusion rays (built on the first call).
    pub fn occluder(&self) -> &Occluder {
        self.occluder.get_or_init(|| Occluder::new(&self.mesh))
    }

    /// The mesh laid out for depth buffers (built on the first call).
    pub fn raster_mesh(&self) -> &crate::image::RasterMesh {
        self.raster
            .get_or_init(|| crate::image::RasterMesh::new(&self.mesh, &self.facet_material))
    }

    /// The scene with its sweep cut to shard `k` of `n` (for job arrays): of the sweep's `N`
    /// aspects in order, those from `k N / n` up to `(k + 1) N / n`, so that the shards' rows
    /// in shard order are one run's rows, each computed alike (`brdf scene merge` joins them).
    /// Refused when `k >= n` or there are more shards than aspects.
    pub fn with_shard(mut self, k: usize, n: usize) -> Result<Scene, String> {
        let total = self.sensor.aspects().len();
        if n == 0 || k >= n {
            return Err(format!("shard {k}/{n}: need 0 <= K < N"));
        }
        if n > total {
            return Err(format!(
                "shard {k}/{n}: {n} shards of {total} aspects would leave some empty; give at most {total}"
            ));
        }
        self.shard = Some((k, n));
        Ok(self)
    }

    /// The aspects of shard `k` of `n` among `total`: `[k total / n, (k + 1) total / n)`.
    pub fn shard_range(k: usize, n: usize, total: usize) -> std::ops::Range<usize> {
        k * total / n..(k + 1) * total / n
    }

    /// [`Scene::load`] with the file named in the error, as every command reports a scene it
    /// cannot use (`brdf scene`, `brdf select --scene`, the Python package's scene functions).
    pub fn open(path: &Path) -> Result<Scene, LoadError> {
        Scene::load(path).map_err(|source| LoadError {
            path: path.display().to_string(),
            source: Box::new(source),
        })
    }

    /// Reads a scene file, its mesh and any fit or blob files it names (paths relative to
    /// the scene file).
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let file = path.display().to_string();
        let text = brdf_fit::data::read_input(path).map_err(|source| SceneError::Io {
            file: file.clone(),
            source,
        })?;
        let parsed: SceneFile = toml::from_str(&text).map_err(|e| SceneError::Toml {
            file: file.clone(),
            message: e.to_string().trim_end().to_owned(),
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let field = |span: Range<usize>, field: &'static str, message: String| SceneError::Field {
            file: file.clone(),
            line: line_of(&text, span.start),
            field,
            message,
        };
        let wavelengths: Vec<(f64, Range<usize>)> = match &parsed.sensor.get_ref().wavelength_um {
            None => Vec::new(),
            Some(w) => {
                let list = match w.get_ref() {
                    Wavelengths::One(x) => vec![*x],
                    Wavelengths::Many(v) => v.clone(),
                };
                let bad = |message: String| field(w.span(), "wavelength_um", message);
                if list.is_empty() || list.len() > MAX_WAVELENGTHS {
                    return Err(bad(format!(
                        "{} wavelengths: give 1 to {MAX_WAVELENGTHS}",
                        list.len()
                    )));
                }
                if let Some(x) = list.iter().find(|x| !brdf_fit::data::is_wavelength(**x)) {
                    return Err(bad(format!("{x} is not a wavelength above 0 (µm)")));
                }
                for (k, a) in list.iter().enumerate() {
                    if let Some(b) = list[..k]
                        .iter()
                        .find(|b| (*b - a).abs() < brdf_core::bands::SAME_BAND_UM)
                    {
                        return Err(bad(format!("{b} and {a} µm are one wavelength: each once")));
                    }
                }
                list.into_iter().map(|x| (x, w.span())).collect()
            }
        };
        // The materials at each wavelength (once without one).
        let mut spectrum: Vec<(f64, Vec<SceneMaterial>)> = Vec::new();
        let runs: Vec<Option<(f64, Range<usize>)>> = match wavelengths.len() {
            0 => vec![None],
            _ => wavelengths.iter().cloned().map(Some).collect(),
        };
        for wavelength in runs {
            let mut at = Vec::new();
            for entry in &parsed.materials {
                let e = entry.get_ref();
                let line = line_of(&text, e.part.span().start);
                let (model, source, table, upper, band) =
                    resolve_material(e, dir, wavelength.clone(), &field)?;
                at.push(SceneMaterial {
                    part: e.part.get_ref().clone(),
                    model,
                    table,
                    source,
                    line,
                    upper,
                    band,
                });
            }
            spectrum.push((wavelength.map_or(0.0, |w| w.0), at));
        }
        let materials = spectrum[0].1.clone();
        if spectrum.len() < 2 {
            spectrum.clear();
        }
        let wavelength = wavelengths.first().cloned();
        if materials.is_empty() {
            return Err(SceneError::Field {
                file,
                line: 1,
                field: "material",
                message: "no [[material]] entries".into(),
            });
        }
        let s = parsed.sensor.get_ref();
        let mode =
            match (s.mode.get_ref().as_str(), &s.separation_deg) {
                ("monostatic", None) => Mode::Monostatic,
                ("monostatic", Some(sep)) => return Err(field(
                    sep.span(),
                    "separation_deg",
                    "given for a monostatic sensor (source and receiver coincide); use mode = \"bistatic\""
                        .into(),
                )),
                ("bistatic", Some(sep)) => {
                    let v = *sep.get_ref();
                    // Within two turns, as every azimuth: 1e300 lost its phase in the conversion.
                    let limit = brdf_fit::data::PHI_LIMIT_DEG;
                    if !(v.is_finite() && v.abs() <= limit) {
                        return Err(field(
                            sep.span(),
                            "separation_deg",
                            format!("{v} is not in [-{limit}, {limit}] degrees"),
                        ));
                    }
                    Mode::Bistatic { separation_deg: v }
                }
                ("bistatic", None) => {
                    return Err(field(
                        parsed.sensor.span(),
                        "separation_deg",
                        "missing: a bistatic sensor needs the angle between source and receiver".into(),
                    ))
                }
                (other, _) => {
                    return Err(field(
                        s.mode.span(),
                        "mode",
                        format!("`{other}`: expected \"monostatic\" or \"bistatic\""),
                    ))
                }
            };
        let turns = brdf_fit::data::PHI_LIMIT_DEG;
        let azimuth_deg = sweep(&s.azimuth_deg, -turns, turns)
            .map_err(|m| field(s.azimuth_deg.span(), "azimuth_deg", m))?;
        let elevation_deg = sweep(&s.elevation_deg, -90.0, 90.0)
            .map_err(|m| field(s.elevation_deg.span(), "elevation_deg", m))?;
        if azimuth_deg.len() * elevation_deg.len() > MAX_ASPECTS {
            return Err(field(
                parsed.sensor.span(),
                "sensor",
                format!(
                    "{} x {} aspects: more than {MAX_ASPECTS}",
                    azimuth_deg.len(),
                    elevation_deg.len()
                ),
            ));
        }
        if parsed.mesh.get_ref().trim().is_empty() {
            return Err(field(
                parsed.mesh.span(),
                "mesh",
                "empty: name the target's OBJ or STL file (relative to the scene file)".into(),
            ));
        }
        let mesh_path = dir.join(parsed.mesh.get_ref());
        let mesh = Mesh::load(&mesh_path)?;
        let mut scene = Scene::new(
            path.to_path_buf(),
            mesh,
            materials,
            Sensor {
                mode,
                azimuth_deg,
                elevation_deg,
            },
        )?;
        scene.wavelength_um = wavelength.map(|w| w.0);
        scene.spectrum = spectrum;
        Ok(scene)
    }

    /// The files the scene was read from: the scene file, its mesh and every fit or blob
    /// file a material names (a command refuses to write its output over one of them).
    pub fn files(&self) -> Vec<&Path> {
        let mut files = vec![self.file.as_path(), self.mesh.file.as_path()];
        for m in &self.materials {
            if let Source::Fit(path, _) | Source::Blob(path, _) = &m.source {
                files.push(path.as_path());
            }
        }
        files
    }

    /// For what works at one wavelength (`what`: selecting, whose blob holds one choice per
    /// material; an image; a range profile; visibility by area): refused, naming the list,
    /// when the scene lists several.
    pub fn one_wavelength(&self, what: &str) -> Result<(), String> {
        match self.spectrum.len() {
            0 => Ok(()),
            n => Err(format!(
                "{}: [sensor] wavelength_um lists {n} wavelengths; {what} works at one: give one \
                 wavelength",
                self.file.display()
            )),
        }
    }

    /// Every aspect of the sweep, in order (of its shard only, with [`Scene::with_shard`]).
    pub fn aspects(&self) -> Vec<Aspect> {
        let all = self.sensor.aspects();
        match self.shard {
            None => all,
            Some((k, n)) => all[Scene::shard_range(k, n, all.len())].to_vec(),
        }
    }

    /// What material `m` is: its model (`six`, `six + table`), or between two bands at the
    /// scene's wavelength each with its weight (`six (fit 15) x 0.25 + six (fit 16) x 0.75`).
    pub fn material_description(&self, m: usize) -> String {
        self.materials[m].description()
    }

    /// For a material taken from a spectral fit at the scene's wavelength: the band used, or
    /// the two blended ([`Scene::material_description`] with the fit's index); `None` for a
    /// scene without a wavelength or a material without bands.
    pub fn band_used(&self, m: usize) -> Option<String> {
        self.materials[m].band_used(self.wavelength_um)
    }

    /// A short name for material `m`: its part (`*` reads "other parts").
    pub fn material_label(&self, m: usize) -> String {
        match self.materials[m].part.as_str() {
            "*" => "* (other parts)".into(),
            p => p.to_owned(),
        }
    }
}

impl SceneMaterial {
    /// What the material is ([`Scene::material_description`]).
    pub fn description(&self) -> String {
        let mat = self;
        let one = |model: &AnyModel<f64>, table: bool| match table {
            true => format!("{} + table", model.kind().name()),
            false => model.kind().name().to_owned(),
        };
        let own = one(&mat.model, mat.table.is_some());
        // Weights to nine decimals (0.75, not 0.7500000000000003).
        let w = |x: f64| brdf_core::Compact((x * 1e9).round() / 1e9);
        match (&mat.upper, &mat.source) {
            (Some(u), Source::Blob(_, k)) => format!(
                "{own} (band {}) x {} + {} (band {}) x {} of blob material {k}",
                u.index - 1,
                w(1.0 - u.weight),
                one(&u.model, u.table.is_some()),
                u.index,
                w(u.weight)
            ),
            (Some(u), Source::Fit(_, k)) => format!(
                "{own} (fit {k}) x {} + {} (fit {}) x {}",
                w(1.0 - u.weight),
                one(&u.model, u.table.is_some()),
                u.index,
                w(u.weight)
            ),
            _ => own,
        }
    }

    /// At `wavelength`, for a material taken from a spectral fit: the band used, or the two
    /// blended ([`Scene::band_used`]).
    pub fn band_used(&self, wavelength: Option<f64>) -> Option<String> {
        match (&self.source, &self.upper, wavelength) {
            (_, Some(_), Some(_)) => Some(self.description()),
            (Source::Fit(_, k), None, Some(_)) if self.band.is_some() => {
                Some(format!("{} (fit {k})", self.description()))
            }
            (Source::Blob(_, k), None, _) => self
                .band
                .map(|b| format!("{} (band {b} of blob material {k})", self.description())),
            _ => None,
        }
    }
}

/// `[start, stop, step]`: start, start + step, ... below stop; every value in `[lo, hi]`.
fn sweep(v: &Spanned<Vec<f64>>, lo: f64, hi: f64) -> Result<Vec<f64>, String> {
    let v = v.get_ref();
    let [start, stop, step] = v[..] else {
        return Err(format!(
            "expected [start, stop, step] in degrees, got {} numbers",
            v.len()
        ));
    };
    if !(start.is_finite() && stop.is_finite() && step.is_finite()) {
        return Err("start, stop and step must be finite".into());
    }
    if step <= 0.0 {
        return Err(format!("step {step} must be positive"));
    }
    if stop <= start {
        return Err(format!(
            "stop {stop} must exceed start {start} (stop is exclusive)"
        ));
    }
    let n = ((stop - start) / step).ceil();
    if n > MAX_ASPECTS as f64 {
        return Err(format!("{n} values: more than {MAX_ASPECTS}"));
    }
    // Values after the first within 1e-9 steps of stop are taken as stop itself (excluded);
    // the first, `start`, is below stop, so it is always a value (a range narrower than
    // 1e-9 steps once gave no value at all, hence no aspect and an empty result).
    let out: Vec<f64> = (0..n as usize)
        .map(|k| start + k as f64 * step)
        .enumerate()
        .filter(|(k, x)| *k == 0 || *x < stop - 1e-9 * step)
        .map(|(_, x)| x)
        .collect();
    if let Some(bad) = out.iter().find(|x| **x < lo || **x > hi) {
        return Err(format!("{bad} is outside [{lo}, {hi}]"));
    }
    // A step below the values' resolution repeated one value (aspects that were one).
    if out.windows(2).any(|w| w[1] <= w[0]) {
        return Err(format!(
            "step {step} is below the resolution of values near {start}: they repeat"
        ));
    }
    Ok(out)
}

/// A material entry resolved: its model, where it came from, a fitted table's bytes, the band
/// above when it lies between two bands at the scene's wavelength, and the band used when it
/// was taken from bands at all ([`SceneMaterial::band`]).
type Resolved = (
    AnyModel<f64>,
    Source,
    Option<Vec<u8>>,
    Option<Upper>,
    Option<usize>,
);

/// The model of one `[[material]]` entry: exactly one of `model`+`params`, `fit`, `blob`; a
/// spectral fit at `wavelength` (µm, and the span of `wavelength_um`), when given.
fn resolve_material(
    e: &MaterialEntry,
    dir: &Path,
    wavelength: Option<(f64, Range<usize>)>,
    field: &dyn Fn(Range<usize>, &'static str, String) -> SceneError,
) -> Result<Resolved, SceneError> {
    let given = [
        e.model.is_some() || e.params.is_some(),
        e.fit.is_some(),
        e.blob.is_some(),
    ];
    if given.iter().filter(|g| **g).count() != 1 {
        return Err(field(
            e.part.span(),
            "material",
            format!(
                "part `{}`: give exactly one of model + params, fit, or blob",
                e.part.get_ref()
            ),
        ));
    }
    let index = match &e.index {
        None => None,
        Some(i) if *i.get_ref() >= 0 => Some(*i.get_ref() as usize),
        Some(i) => return Err(field(i.span(), "index", format!("{} is negative", i.get_ref()))),
    };
    let build = |kind: ModelKind, p: &[f64; MAX_PARAMS], span: Range<usize>, key: &'static str| {
        brdf_fit::params::build(kind, p).map_err(|err| field(span, key, err))
    };
    if e.model.is_some() || e.params.is_some() {
        if let Some(i) = &e.index {
            return Err(field(i.span(), "index", "only for fit or blob".into()));
        }
        let (Some(model), Some(params)) = (&e.model, &e.params) else {
            return Err(field(
                e.part.span(),
                "material",
                format!("part `{}`: model and params go together", e.part.get_ref()),
            ));
        };
        let kind = model
            .get_ref()
            .parse::<ModelKind>()
            .map_err(|err| field(model.span(), "model", err.to_string()))?;
        let p = brdf_fit::params::parse_params(kind, params.get_ref())
            .map_err(|err| field(params.span(), "params", err.to_string()))?;
        return Ok((
            build(kind, &p, params.span(), "params")?,
            Source::Params,
            None,
            None,
            None,
        ));
    }
    if let Some(fit) = &e.fit {
        let path = dir.join(fit.get_ref());
        let shown = path.display().to_string();
        let text = brdf_fit::data::read_input(&path)
            .map_err(|err| field(fit.span(), "fit", format!("{shown}: {err}")))?;
        let bands = BandFits::read(&text, &shown, index).map_err(|m| field(fit.span(), "fit", m))?;
        let banded = bands.is_some() && wavelength.is_some();
        let (one, upper) = match (&bands, wavelength) {
            (Some(bands), Some((um, span))) => match bands.at(um) {
                Ok(AtWavelength::Band(one)) => (one.clone(), None),
                Ok(AtWavelength::Between { lower, upper, weight }) => (
                    lower.clone(),
                    Some(Upper {
                        model: build(upper.model, &upper.params, fit.span(), "fit")?,
                        table: upper.table.clone(),
                        index: upper.index,
                        weight,
                    }),
                ),
                Err(m) => {
                    return Err(field(
                        span,
                        "wavelength_um",
                        format!("part `{}`: {shown}: {m}", e.part.get_ref()),
                    ))
                }
            },
            (Some(bands), None) if bands.bands.len() > 1 && index.is_none() => {
                return Err(field(
                    fit.span(),
                    "fit",
                    format!(
                        "{shown} holds {}: give [sensor] wavelength_um, or index = k for one fit",
                        bands.describe()
                    ),
                ));
            }
            _ => (
                FittedModel::one_of(&text, &shown, index).map_err(|m| field(fit.span(), "fit", m))?,
                None,
            ),
        };
        return Ok((
            build(one.model, &one.params, fit.span(), "fit")?,
            Source::Fit(path, one.index),
            one.table,
            upper,
            banded.then_some(one.index),
        ));
    }
    let blob = e.blob.as_ref().expect("exactly one source is given");
    let path = dir.join(blob.get_ref());
    let shown = path.display().to_string();
    let bytes = brdf_fit::data::read_input_bytes(&path)
        .map_err(|err| field(blob.span(), "blob", format!("{shown}: {err}")))?;
    let decoded = brdf_wire::blob::Blob::decode(&bytes)
        .map_err(|err| field(blob.span(), "blob", format!("{shown}: {err}")))?;
    let n = decoded.materials.len();
    let k = match index {
        Some(k) => k,
        None if n == 1 => 0,
        None => {
            return Err(field(
                blob.span(),
                "index",
                format!("{shown} holds {n} materials: say which with index = 0..{}", n - 1),
            ))
        }
    };
    let Some(m) = decoded.materials.get(k) else {
        return Err(field(
            blob.span(),
            "index",
            format!("{shown} holds {n} materials; there is no index {k}"),
        ));
    };
    // Blob::decode checked the table.
    let table = m.fitted.and_then(|f| f.bytes(&bytes)).map(<[u8]>::to_vec);
    let widen = |params: [f32; MAX_PARAMS]| {
        let mut p = [0.0; MAX_PARAMS];
        for (dst, src) in p.iter_mut().zip(params) {
            *dst = f64::from(src);
        }
        p
    };
    let count = m.band_count();
    if count == 0 {
        return Ok((
            build(m.kind, &widen(m.params), blob.span(), "blob")?,
            Source::Blob(path, k),
            table,
            None,
            None,
        ));
    }
    // A banded (spectral) material: its band at the scene's wavelength, or the two around it
    // blended, as the device answers EVAL_AT (its centres in f32, widened).
    let centres: Vec<f64> = (0..count)
        .filter_map(|b| m.band_centre(&bytes, b).map(f64::from))
        .collect();
    let band = |b: usize| -> Result<AnyModel<f64>, SceneError> {
        let p = m.band_params(&bytes, b).ok_or_else(|| {
            field(
                blob.span(),
                "blob",
                format!("{shown}: material {k}: band {b} missing"),
            )
        })?;
        build(m.kind, &widen(p), blob.span(), "blob")
    };
    let text = brdf_fit::data::wavelength_text;
    // The centres as the blob holds them (f32, shortest form).
    let range = format!(
        "{count} band{} at {}–{} µm",
        if count == 1 { "" } else { "s" },
        centres[0] as f32,
        centres[centres.len() - 1] as f32
    );
    let Some((um, span)) = wavelength else {
        if count == 1 {
            return Ok((band(0)?, Source::Blob(path, k), None, None, Some(0)));
        }
        return Err(field(
            blob.span(),
            "blob",
            format!("{shown}: material {k} is spectral ({range}): give [sensor] wavelength_um"),
        ));
    };
    match brdf_core::bands::locate(&centres, um) {
        Ok(Located::Band(b)) => Ok((band(b)?, Source::Blob(path, k), None, None, Some(b))),
        Ok(Located::Between { lower, weight }) => Ok((
            band(lower)?,
            Source::Blob(path, k),
            None,
            Some(Upper {
                model: band(lower + 1)?,
                table: None,
                index: lower + 1,
                weight,
            }),
            Some(lower),
        )),
        Err(_) => Err(field(
            span,
            "wavelength_um",
            format!(
                "{} µm is outside the bands of material {k} of {shown} ({range}; a BRDF is not \
                 extrapolated in wavelength)",
                text(um)
            ),
        )),
    }
}
