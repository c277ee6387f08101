//! Fit results packed into a device's parameter blob: what `brdf pack` writes and
//! `brdf.pack` returns.
//!
//! Each fit becomes a [`Material`] (parameters checked against `brdf_core::ranges`), is
//! checked for an energy bound and for the f32 accuracy its parameters get on the device,
//! optionally gets lookup tables measured against their promise
//! ([`promise_accuracy`]), and the whole is encoded as a [`Blob`]. What the caller should
//! show besides the blob (energy warnings, the tables' measured errors) arrives as [`Note`]s,
//! in order, as they are found.
//!
//! ```
//! use brdf_fit::pack::{pack, FitSource, PackOptions};
//!
//! let json = r#"{"model": "lambert", "params": {"rho0": 0.5}}"#;
//! let sources = [FitSource::Text { origin: "results", json }];
//! let mut notes = Vec::new();
//! let packed = pack(&sources, &PackOptions::default(), |n| notes.push(n)).unwrap();
//! assert_eq!(packed.materials, 1);
//! assert_eq!(packed.bytes.len(), brdf_wire::blob::encoded_len(&[packed.blob.materials[0]]));
//! assert!(notes.is_empty()); // a Lambertian of albedo 0.5 conserves energy
//! ```

use std::path::Path;

use brdf_core::accuracy::{f32_claim_accuracy, F32_PATHS};
use brdf_core::table::{promise_accuracy, table_len, SixTable, TableError, MAX_TABLE_NODES, MIN_TABLE_NODES};
use brdf_core::tolerance::{table_max_rel, F32_MAX_REL, TABLE_MAX_REL, TABLE_MAX_ZENITH_DEG};
use brdf_wire::blob::{blob_crc, Blob, BlobError, Material, MAX_BLOB_LEN, MAX_MATERIALS};

use crate::report::{FittedModel, ReadError};

/// Where fit results come from: a `brdf fit --json` file, or such JSON text already in
/// memory.
#[derive(Clone, Copy, Debug)]
pub enum FitSource<'a> {
    /// A file of `brdf fit --json` output (one report or an array), named in messages as
    /// written.
    File(&'a Path),
    /// JSON text of one report or an array; `origin` names it in messages.
    Text {
        /// What messages call the text (`results`, say): `results: fit 2: refused: ...`.
        origin: &'a str,
        /// The JSON.
        json: &'a str,
    },
}

/// How to pack.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PackOptions {
    /// Sequence number: a device keeps the valid blob with the newer one, in serial-number
    /// order (N + 1 is always newer than N; 0 follows 4294967295).
    pub sequence: u32,
    /// Lookup tables of this many nodes for every six-parameter material (the device's fast
    /// path), or none.
    pub table_nodes: Option<usize>,
}

impl Default for PackOptions {
    /// Sequence 1, no tables (the defaults of `brdf pack`).
    fn default() -> Self {
        PackOptions {
            sequence: 1,
            table_nodes: None,
        }
    }
}

/// How much a [`Note`] matters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// A measurement worth reporting (a table's error, a table size's promise).
    Info,
    /// Something the user should act on or know before flashing: no proof of energy
    /// conservation, a table above its promise, a table size without a promise.
    Warning,
}

/// A message about the packing, besides the blob.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Note {
    /// How much it matters.
    pub level: Level,
    /// The text as `brdf pack` prints it on standard error (one or more lines, without the
    /// final newline; warnings start with `warning:` or `note:`).
    pub text: String,
}

/// Why packing failed. The messages are the ones `brdf pack` prints after `error:`.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    /// A results file could not be read (the OS error is part of the message, so that every
    /// caller shows the same text).
    #[error("cannot read {file}: {error}")]
    Read {
        /// The file as given.
        file: String,
        /// Why.
        error: std::io::Error,
    },
    /// The results are not `brdf fit --json` output, or lack a parameter.
    #[error(transparent)]
    Json(#[from] ReadError),
    /// A parameter is outside its model's range (or the model is refused).
    #[error("{origin}: refused: {error}")]
    Refused {
        /// File and fit index (`fits.json: fit 2`).
        origin: String,
        /// What the core refused.
        error: brdf_core::ParamError,
    },
    /// More fits than a blob holds.
    #[error("more than {MAX_MATERIALS} materials: a blob holds at most {MAX_MATERIALS}")]
    TooManyMaterials,
    /// A table size outside what the tables support.
    #[error("{0} table nodes: outside {MIN_TABLE_NODES}..={MAX_TABLE_NODES}")]
    TableNodes(usize),
    /// A material's tables could not be built or measured.
    #[error("{origin}: material {material}: {nodes}-node tables: {error}")]
    Table {
        /// File and fit index.
        origin: String,
        /// The material's index in the blob.
        material: usize,
        /// The table size asked for.
        nodes: usize,
        /// What the core refused.
        error: TableError,
    },
    /// A fit's fitted table is not a valid table.
    #[error("{origin}: {message}")]
    FittedTable {
        /// File and fit index.
        origin: String,
        /// What is wrong with it.
        message: String,
    },
    /// The encoded blob would not fit in a slot.
    #[error(
        "the blob would be {0} bytes, more than a slot's {MAX_BLOB_LEN}: use fewer materials or fewer table nodes"
    )]
    TooLarge(usize),
    /// The bands of one spectral measurement could not become one device material.
    #[error("{origin}: {message}")]
    Bands {
        /// File and fit indices.
        origin: String,
        /// Why.
        message: String,
    },
    /// The blob could not be encoded.
    #[error("{0}")]
    Encode(BlobError),
}

/// An encoded blob.
#[derive(Clone, Debug, PartialEq)]
pub struct Packed {
    /// The bytes a device's slot holds (what `brdf pack` writes).
    pub bytes: Vec<u8>,
    /// The blob the bytes encode.
    pub blob: Blob,
    /// How many materials it holds.
    pub materials: usize,
    /// Its CRC, as a device's INFO reports it.
    pub crc: u32,
}

/// Encodes `materials` (with `tables[i]` the table bytes of material `i`, if any; missing
/// entries mean none) under `sequence`, refusing a blob larger than a slot.
pub fn encode(
    materials: &[Material],
    tables: &[Option<Vec<u8>>],
    sequence: u32,
) -> Result<Packed, PackError> {
    let materials = heapless::Vec::from_slice(materials).map_err(|_| PackError::TooManyMaterials)?;
    let blob = Blob { sequence, materials };
    if blob.encoded_len() > MAX_BLOB_LEN {
        return Err(PackError::TooLarge(blob.encoded_len()));
    }
    let refs: Vec<Option<&[u8]>> = tables.iter().map(|t| t.as_deref()).collect();
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let n = blob
        .encode_with_tables(&refs, &mut buf)
        .map_err(PackError::Encode)?;
    buf.truncate(n);
    Ok(Packed {
        crc: blob_crc(&buf),
        materials: blob.materials.len(),
        bytes: buf,
        blob,
    })
}

/// The device's exact f32 path for `m` measured on the f32 claim's grid from angles and from
/// cosines (the two inputs EVAL takes; `brdf_core::accuracy::f32_claim_accuracy`): a
/// sentence saying how far it errs when that exceeds [`F32_MAX_REL`], which is promised only
/// for parameters in the paper's range (steep lobes and large `c` over the fitter's search
/// box reach 9.5e-6); `None` within it.
fn f32_beyond_claim(m: &Material) -> Result<Option<String>, brdf_core::ParamError> {
    let p = &m.params[..m.kind.param_count()];
    let mut worst: Option<(f64, &str, [f32; 3])> = None;
    for (path_name, path) in &F32_PATHS[..2] {
        let a = f32_claim_accuracy(m.kind, p, *path)?;
        if a.max > F32_MAX_REL && worst.is_none_or(|w| a.max > w.0) {
            worst = Some((a.max, path_name, a.worst_at.unwrap_or_default()));
        }
    }
    Ok(worst.map(|(e, path_name, at)| {
        let deg = at.map(|x| f64::from(x).to_degrees());
        format!(
            "the device's f32 evaluation errs by up to {e:.2e} (from {path_name}, at theta_i \
             {:.2}, theta_r {:.2}, phi {:.2} deg) against f64, above the {F32_MAX_REL:e} \
             promised for parameters in the paper's range (|b| <= 40, a <= 1, c <= 1.5)",
            deg[0], deg[1], deg[2]
        )
    }))
}

/// Zenith and azimuth steps (degrees) of the grid [`fitted_f32_beyond_bound`] checks.
const FITTED_CHECK_STEP_DEG: (usize, usize) = (5, 15);

/// A fitted-table material's f32 evaluation (the device's) against f64 over a grid of
/// directions (zeniths 0 to 85 degrees, 89 and 89.9, azimuths 0 to 180): a sentence when some value is not
/// finite in f32, or differs by more than the table's f32 bound
/// (`brdf_core::fitted::FittedTable::f32_max_rel` on top of [`F32_MAX_REL`]), which a table
/// near the ends of its range does (f32 underflows to 0 or overflows); `None` otherwise.
fn fitted_f32_beyond_bound(m: &Material, bytes: &[u8]) -> Result<Option<String>, brdf_core::ParamError> {
    use brdf_core::fitted::{Corrected, FittedTable};
    use brdf_core::Brdf;
    let Ok(table) = FittedTable::new(bytes) else {
        return Ok(Some("its table bytes are not a table".into()));
    };
    let p64: Vec<f64> = m.params[..m.kind.param_count()]
        .iter()
        .map(|&v| f64::from(v))
        .collect();
    let f32m = Corrected {
        base: m.model()?,
        table,
    };
    let f64m = Corrected {
        base: brdf_core::AnyModel::<f64>::new(m.kind, &p64)?,
        table,
    };
    let bound = F32_MAX_REL + table.f32_max_rel();
    let (dz, dp) = FITTED_CHECK_STEP_DEG;
    // Up to 85 degrees in steps, and two zeniths by the horizon, where a base that grows
    // towards grazing (Minnaert with k < 1) overflows f32 first.
    let zeniths: Vec<f64> = (0..90).step_by(dz).map(f64::from).chain([89.0, 89.9]).collect();
    for &ti in &zeniths {
        for &tr in &zeniths {
            for phi in (0..=180).step_by(dp) {
                // The same f32 input to both, as `brdf check` compares them.
                let a = [ti, tr, f64::from(phi)].map(|d| d.to_radians() as f32);
                let want = f64m.eval_angles(a[0].into(), a[1].into(), a[2].into());
                let got = f64::from(f32m.eval_angles(a[0], a[1], a[2]));
                let off = !got.is_finite() || (want != 0.0 && (got / want - 1.0).abs() > bound);
                if off {
                    return Ok(Some(format!(
                        "the device's f32 evaluation gives {got:e} where f64 gives {want:e} (theta_i \
                         {ti}, theta_r {tr}, phi {phi} deg): beyond the table's f32 bound {bound:.1e}; \
                         `brdf check` will fail"
                    )));
                }
            }
        }
    }
    Ok(None)
}

/// Makes the bands of each spectral measurement one banded material (at the place of its
/// first band): fits, in any of the sources, whose datasets name one measurement at a
/// wavelength (`FILE[wavelength=0.55]`); a measurement's only band too, which then answers at
/// its own wavelength (and without one) only, as the host's fit of one band does. Once a
/// banded material is made, every material's origin is noted (indices move). Refused: bands
/// with fitted tables (a device's banded material holds analytic bands; 31 fitted tables do
/// not fit a slot), one band given twice (within [`brdf_core::bands::SAME_BAND_UM`], or
/// closer than that once rounded to f32 as the device holds them), a wavelength f32 cannot
/// hold, bands of different models, more than [`brdf_wire::blob::MAX_BANDS`].
#[allow(clippy::type_complexity)]
fn group_bands(
    materials: Vec<Material>,
    tables: Vec<Option<Vec<u8>>>,
    origins: Vec<String>,
    band_of: &[(usize, Option<(String, f64)>)],
    say: &mut impl FnMut(Level, String),
) -> Result<(Vec<Material>, Vec<Option<Vec<u8>>>, Vec<String>), PackError> {
    use brdf_core::bands::SAME_BAND_UM;
    use brdf_wire::blob::MAX_BANDS;
    let text = crate::data::wavelength_text;
    let same = |i: usize, j: usize| match (&band_of[i].1, &band_of[j].1) {
        (Some((mi, _)), Some((mj, _))) => mi == mj,
        _ => false,
    };
    let n = materials.len();
    let mut taken = vec![false; n];
    let (mut out_m, mut out_t, mut out_o) = (Vec::new(), Vec::new(), Vec::new());
    // Per material made: whether it is banded.
    let mut banded: Vec<bool> = Vec::new();
    for i in 0..n {
        if taken[i] {
            continue;
        }
        let Some((measurement, _)) = &band_of[i].1 else {
            out_m.push(materials[i]);
            out_t.push(tables[i].clone());
            out_o.push(origins[i].clone());
            banded.push(false);
            continue;
        };
        let members: Vec<usize> = (i..n).filter(|&j| same(i, j)).collect();
        if members.len() == 1 && tables[i].is_some() {
            // A banded material holds analytic bands: one band's fitted table stays a
            // material of its own, which a device answers at every wavelength.
            say(
                Level::Warning,
                format!(
                    "note: {}: the only band of {measurement} ({} µm) with a fitted table: packed \
                     as a material the device answers at every wavelength (the host at {} µm only)",
                    origins[i],
                    text(band_of[i].1.as_ref().map_or(0.0, |b| b.1)),
                    text(band_of[i].1.as_ref().map_or(0.0, |b| b.1)),
                ),
            );
            out_m.push(materials[i]);
            out_t.push(tables[i].clone());
            out_o.push(origins[i].clone());
            banded.push(false);
            continue;
        }
        // `FILE: fits 0–30` (and `, OTHER: fits 0–4` for bands in several files).
        let mut by_file: Vec<(&str, Vec<usize>)> = Vec::new();
        for &k in &members {
            let (file, index) = origins[k]
                .rsplit_once(": fit ")
                .map_or((origins[k].as_str(), k), |(f, x)| (f, x.parse().unwrap_or(k)));
            match by_file.iter_mut().find(|(f, _)| *f == file) {
                Some((_, v)) => v.push(index),
                None => by_file.push((file, vec![index])),
            }
        }
        let origin = by_file
            .iter()
            .map(|(file, v)| match v.len() {
                1 => format!("{file}: fit {}", v[0]),
                _ => format!("{file}: fits {}", index_ranges(v)),
            })
            .collect::<Vec<_>>()
            .join(", ");
        let refuse = |message: String| PackError::Bands {
            origin: origin.clone(),
            message,
        };
        if let Some(&k) = members.iter().find(|&&k| tables[k].is_some()) {
            return Err(refuse(format!(
                "{} has a fitted table: a banded device material holds one analytic fit per band \
                 (a fitted table per band would not fit a {MAX_BLOB_LEN}-byte slot); pack `brdf fit` \
                 results of the bands, or one band's fit alone",
                origins[k]
            )));
        }
        if members.len() > MAX_BANDS {
            return Err(refuse(format!(
                "{} bands: a device material holds at most {MAX_BANDS}",
                members.len()
            )));
        }
        let mut bands: Vec<(f64, Material, usize)> = members
            .iter()
            .map(|&k| (band_of[k].1.as_ref().map_or(0.0, |b| b.1), materials[k], k))
            .collect();
        bands.sort_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((um, _, k)) = bands
            .iter()
            .find(|(um, _, _)| !crate::data::is_wavelength(f64::from(*um as f32)))
        {
            return Err(refuse(format!(
                "{}: {um:e} µm is not a wavelength a device holds (an f32 above 0)",
                origins[*k]
            )));
        }
        for w in bands.windows(2) {
            let (a, b) = (w[0].0, w[1].0);
            let in_f32 = f64::from(b as f32) - f64::from(a as f32);
            if b - a < SAME_BAND_UM || !brdf_core::bands::valid(&[a as f32, b as f32]) {
                return Err(refuse(format!(
                    "{} ({} µm) and {} ({} µm) are one band: closer than {SAME_BAND_UM:e} µm{}; one \
                     fit per band",
                    origins[w[0].2],
                    text(a),
                    origins[w[1].2],
                    text(b),
                    if b - a >= SAME_BAND_UM {
                        format!(" once rounded to f32 as a device holds them ({in_f32:e} µm apart)")
                    } else {
                        String::new()
                    }
                )));
            }
            if w[0].1.kind != w[1].1.kind {
                return Err(refuse(format!(
                    "{} is {} and {} is {}: a banded material has one model in every band",
                    origins[w[0].2],
                    w[0].1.kind.name(),
                    origins[w[1].2],
                    w[1].1.kind.name()
                )));
            }
        }
        let pairs: Vec<(f64, Material)> = bands.iter().map(|b| (b.0, b.1)).collect();
        let mut bytes = vec![0u8; MAX_BLOB_LEN];
        let (m, len) = Material::banded(&pairs, &mut bytes).map_err(|e| refuse(e.to_string()))?;
        bytes.truncate(len);
        let span = match pairs.len() {
            1 => format!("1 band of {measurement} ({} µm", text(pairs[0].0)),
            k => format!(
                "{k} bands of {measurement} ({}–{} µm",
                text(pairs[0].0),
                text(pairs[k - 1].0)
            ),
        };
        say(
            Level::Info,
            format!(
                "material {}: {span}, {}), from {origin}: the device answers it at a wavelength \
                 (EVAL_AT): a band's fit at its centre, the two around it blended between, \
                 nothing outside{}",
                out_m.len(),
                m.kind.name(),
                if pairs.len() == 1 {
                    "; plain EVAL with its one band"
                } else {
                    ""
                },
            ),
        );
        for &k in &members {
            taken[k] = true;
        }
        out_m.push(m);
        out_t.push(Some(bytes));
        out_o.push(origin);
        banded.push(true);
    }
    // Bands grouped: indices no longer follow the fits, so every other material says where
    // it came from too.
    if banded.iter().any(|b| *b) {
        for (i, (m, origin)) in out_m.iter().zip(&out_o).enumerate() {
            if !banded[i] {
                say(Level::Info, format!("material {i}: {origin} ({})", m.kind.name()));
            }
        }
    }
    Ok((out_m, out_t, out_o))
}

/// `0–30` or `0, 2, 4–6`: ascending indices as runs.
fn index_ranges(indices: &[usize]) -> String {
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for &k in indices {
        match runs.last_mut() {
            Some(r) if r.1 + 1 == k => r.1 = k,
            _ => runs.push((k, k)),
        }
    }
    let text: Vec<String> = runs
        .iter()
        .map(|&(a, b)| {
            if a == b {
                a.to_string()
            } else {
                format!("{a}–{b}")
            }
        })
        .collect();
    text.join(", ")
}

/// Packs every fit of `sources`, in order (an array adds each of its fits), into one blob.
/// Parameters outside a model's ranges are refused; a material without a proof of energy
/// conservation (`kb + kd > 1`, or no bound), or whose f32 evaluation errs beyond
/// [`F32_MAX_REL`] on the claim's grid, is packed with a [`Level::Warning`] note. With
/// `table_nodes`, every six-parameter material gets tables, each measured against the
/// promise of its size (a note per material, then one on the size).
pub fn pack(
    sources: &[FitSource<'_>],
    options: &PackOptions,
    mut note: impl FnMut(Note),
) -> Result<Packed, PackError> {
    let mut say = |level, text| note(Note { level, text });
    if let Some(nodes) = options.table_nodes {
        if !(MIN_TABLE_NODES..=MAX_TABLE_NODES).contains(&nodes) {
            return Err(PackError::TableNodes(nodes));
        }
    }
    let mut materials: Vec<Material> = Vec::new();
    // Per material: its fitted table's bytes, if it has one.
    let mut fitted_tables: Vec<Option<Vec<u8>>> = Vec::new();
    // Where each material came from, for messages.
    let mut origin_of: Vec<String> = Vec::new();
    // Per material: its source, and its measurement and band if its dataset names one.
    let mut band_of: Vec<(usize, Option<(String, f64)>)> = Vec::new();
    for (source_index, source) in sources.iter().enumerate() {
        let (file, fits) = match *source {
            FitSource::File(path) => {
                let file = path.display().to_string();
                let text = crate::data::read_input(path).map_err(|error| PackError::Read {
                    file: file.clone(),
                    error,
                })?;
                let fits = FittedModel::from_json(&text, &file)?;
                (file, fits)
            }
            FitSource::Text { origin, json } => (origin.to_owned(), FittedModel::from_json(json, origin)?),
        };
        for (i, r) in fits.iter().enumerate() {
            let origin = format!("{file}: fit {i}");
            let refused = |error| PackError::Refused {
                origin: origin.clone(),
                error,
            };
            // `from_json` has checked that every parameter is named.
            let params = r.params_array().unwrap_or([f64::NAN; brdf_core::MAX_PARAMS]);
            // The range is checked on the value as written and again (in the model) on its
            // f32 rounding; both are exact at the bounds (brdf_core::ranges).
            let m = Material::from_params(r.model, &params).map_err(refused)?;
            let name = r.model.name();
            let fitted = r.table_bytes().map_err(|message| PackError::FittedTable {
                origin: origin.clone(),
                message,
            })?;
            let band = match r.dataset.as_deref() {
                Some(d) => crate::data::band_of_name(d).map_err(|message| PackError::Bands {
                    origin: origin.clone(),
                    message: format!("dataset `{d}`: {message}"),
                })?,
                None => None,
            };
            band_of.push((source_index, band));
            if let Some(bytes) = fitted {
                let m = m.with_fitted(&bytes).map_err(|e| PackError::FittedTable {
                    origin: origin.clone(),
                    message: e.to_string(),
                })?;
                say(
                    Level::Warning,
                    format!(
                        "note: {origin} ({name} times a fitted table): a measured correction, \
                         evaluated as tabulated; no energy bound is claimed for it"
                    ),
                );
                if let Some(text) = fitted_f32_beyond_bound(&m, &bytes).map_err(refused)? {
                    say(
                        Level::Warning,
                        format!("warning: {origin} ({name} + table): {text}"),
                    );
                }
                materials.push(m);
                fitted_tables.push(Some(bytes));
                origin_of.push(origin);
                continue;
            }
            match m.model().map_err(refused)?.energy_bound() {
                Some(b) if b <= 1.0 => {}
                Some(b) => say(
                    Level::Warning,
                    format!("warning: {origin} ({name}): energy bound {b} > 1, conservation not guaranteed"),
                ),
                // Why, when the albedo grows without bound at grazing (the report's
                // `energy.unbounded`, in the same words).
                None => say(
                    Level::Warning,
                    match r
                        .model()
                        .ok()
                        .as_ref()
                        .and_then(crate::report::unbounded_at_grazing)
                    {
                        Some(why) => {
                            format!("warning: {origin} ({name}): the model has no energy bound: {why}")
                        }
                        None => format!("warning: {origin} ({name}): the model has no energy bound"),
                    },
                ),
            }
            if let Some(text) = f32_beyond_claim(&m).map_err(refused)? {
                say(Level::Warning, format!("warning: {origin} ({name}): {text}"));
            }
            // A parameter below f32's normal numbers is rounded to 0 or to a few bits (the
            // claim above is measured on the f32 parameters, so it cannot see this).
            for ((p, &x), &f) in r.model.param_names().iter().zip(&params).zip(&m.params) {
                if x != 0.0 && !f.is_normal() {
                    say(
                        Level::Warning,
                        format!(
                            "warning: {origin} ({name}): {p} = {x:e} is below f32's normal numbers \
                             (1.18e-38); the device holds {:e}",
                            f64::from(f)
                        ),
                    );
                }
            }
            materials.push(m);
            fitted_tables.push(None);
            origin_of.push(origin);
        }
    }
    let (mut materials, mut tables, origin_of) =
        group_bands(materials, fitted_tables, origin_of, &band_of, &mut say)?;
    if materials.len() > MAX_MATERIALS {
        return Err(PackError::TooManyMaterials);
    }
    let mut tabulated = 0;
    if let Some(nodes) = options.table_nodes {
        for (i, (m, t)) in materials.iter_mut().zip(&mut tables).enumerate() {
            if m.six_params().is_none() || m.fitted.is_some() || m.bands.is_some() {
                continue;
            }
            let mut bytes = vec![0u8; table_len(nodes)];
            let mut build = || -> Result<_, TableError> {
                m.tabulate(nodes, &mut bytes)?;
                let p = m.six_params().ok_or(TableError::Model(m.kind))?;
                promise_accuracy(&SixTable::new(p, &bytes)?)
            };
            let acc = build().map_err(|error| PackError::Table {
                origin: origin_of[i].clone(),
                material: i,
                nodes,
                error,
            })?;
            let (worst, n) = (acc.max, acc.n);
            let measured = format!(
                "material {i}: {nodes}-node tables, measured max relative error {worst:.2e} over {n} \
                 directions up to {TABLE_MAX_ZENITH_DEG} degrees zenith"
            );
            match table_max_rel(nodes) {
                Some(b) if worst > b => say(
                    Level::Warning,
                    format!(
                        "{measured}\nwarning: that exceeds the {b:e} promised for parameters in the \
                         paper's range: `brdf check` will fail; use more nodes"
                    ),
                ),
                _ => say(Level::Info, measured),
            }
            *t = Some(bytes);
            tabulated += 1;
        }
        match table_max_rel(nodes) {
            // No six-parameter material without a fitted table: nothing was tabulated.
            _ if tabulated == 0 => say(
                Level::Warning,
                format!(
                    "note: --table-nodes {nodes}: no material took lookup tables (six-parameter \
                     materials without a fitted table or bands only)"
                ),
            ),
            Some(e) => say(
                Level::Info,
                format!(
                    "tables of {nodes} nodes: promised max relative error {e:e} up to {TABLE_MAX_ZENITH_DEG} \
                     degrees zenith (parameters in the paper's range)"
                ),
            ),
            None => say(
                Level::Warning,
                format!(
                    "note: {nodes} nodes has no promised bound (sizes with one: {:?}); `brdf check` \
                     reports such materials without judging them",
                    TABLE_MAX_REL.map(|t| t.0)
                ),
            ),
        }
    }
    encode(&materials, &tables, options.sequence)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KHAKI: &str = r#"{"model": "six", "params": {"kb": 0.2545, "kr": 21.8031, "b": -27.5721,
        "a": 0.6705, "kd": 0.3676, "c": 1.2}}"#;

    fn pack_text(json: &str, table_nodes: Option<usize>) -> (Result<Packed, PackError>, Vec<Note>) {
        let mut notes = Vec::new();
        let sources = [FitSource::Text {
            origin: "results",
            json,
        }];
        let options = PackOptions {
            sequence: 7,
            table_nodes,
        };
        (pack(&sources, &options, |n| notes.push(n)), notes)
    }

    /// A fit whose albedo grows without bound at grazing (`c < 0`, `k < 1`, the five-parameter
    /// `kd / cos ti`) said only "the model has no energy bound"; it now says why, in the words
    /// of the report's `energy.unbounded`. A model bounded at grazing with no analytic bound
    /// (the `cos^2` variant with `kr > sqrt 2`) still says only that.
    #[test]
    fn a_model_unbounded_at_grazing_is_packed_with_the_reason() {
        let warning = |json: &str| {
            let (packed, notes) = pack_text(json, None);
            packed.unwrap();
            notes
                .into_iter()
                .find(|n| n.text.contains("energy bound"))
                .map(|n| n.text)
                .unwrap_or_default()
        };
        let six =
            r#"{"model": "six", "params": {"kb": 0.05, "kr": 1, "b": -5, "a": 1, "kd": 0.4, "c": -0.1}}"#;
        let text = warning(six);
        assert!(
            text.contains("no energy bound: albedo unbounded at grazing: c = -0.1 < 0"),
            "{text}"
        );
        let minnaert = r#"{"model": "minnaert", "params": {"rho0": 0.5, "k": 0.9}}"#;
        assert!(warning(minnaert).contains("k = 0.9 < 1"), "{}", warning(minnaert));
        let five = r#"{"model": "five", "params": {"kb": 0.5, "kr": 1, "b": -5, "a": 1, "kd": 0.4}}"#;
        assert!(warning(five).contains("kd / cos ti"), "{}", warning(five));
        let cos2 =
            r#"{"model": "six-cos2", "params": {"kb": 0.05, "kr": 3, "b": -5, "a": 1, "kd": 0.4, "c": 1}}"#;
        let text = warning(cos2);
        assert!(text.ends_with("the model has no energy bound"), "{text}");
    }

    #[test]
    fn the_bytes_decode_to_the_fits_in_order() {
        let json = format!("[{KHAKI}, {{\"model\": \"lambert\", \"params\": {{\"rho0\": 0.5}}}}]");
        let (packed, notes) = pack_text(&json, None);
        let p = packed.unwrap();
        let back = Blob::decode(&p.bytes).unwrap();
        assert_eq!(back, p.blob);
        assert_eq!((back.sequence, back.materials.len(), p.materials), (7, 2, 2));
        assert_eq!(back.materials[0].params[0], 0.2545f32);
        assert_eq!(p.crc, blob_crc(&p.bytes));
        assert!(notes.is_empty(), "{notes:?}");
    }

    #[test]
    fn tables_are_measured_and_noted() {
        let (packed, notes) = pack_text(KHAKI, Some(256));
        let p = packed.unwrap();
        assert!(p.blob.materials[0].table.is_some());
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes[0]
            .text
            .starts_with("material 0: 256-node tables, measured max relative error"));
        assert!(notes.iter().all(|n| n.level == Level::Info), "{notes:?}");
        // A size without a promise is a warning.
        let (_, notes) = pack_text(KHAKI, Some(100));
        assert_eq!(notes.last().map(|n| n.level), Some(Level::Warning));
        assert!(notes
            .last()
            .unwrap()
            .text
            .starts_with("note: 100 nodes has no promised bound"));
    }

    #[test]
    fn bad_input_is_refused_naming_the_fit() {
        let bad = r#"{"model": "six", "params": {"kb": 0.25, "kr": 21.8, "b": -27.5, "a": 0.67, "kd": -1, "c": 1.2}}"#;
        let err = pack_text(bad, None).0.unwrap_err().to_string();
        assert!(err.starts_with("results: fit 0: refused: "), "{err}");
        let too_many = MAX_TABLE_NODES + 1;
        let err = pack_text(KHAKI, Some(too_many)).0.unwrap_err().to_string();
        assert_eq!(
            err,
            format!("{too_many} table nodes: outside {MIN_TABLE_NODES}..={MAX_TABLE_NODES}")
        );
        let nine = format!("[{}]", [KHAKI; MAX_MATERIALS + 1].join(","));
        assert!(matches!(
            pack_text(&nine, None).0,
            Err(PackError::TooManyMaterials)
        ));
        let err = pack(
            &[FitSource::File(Path::new("/nonexistent/a.json"))],
            &PackOptions::default(),
            |_| {},
        )
        .unwrap_err();
        assert!(
            err.to_string().starts_with("cannot read /nonexistent/a.json: "),
            "{err}"
        );
    }

    #[test]
    fn a_steep_material_beyond_the_f32_claim_is_packed_with_a_warning() {
        // Inside the fitter's search box, outside the paper's range: a steep lobe (a = 3,
        // |b| = 150) and c = 4; it conserves energy (kb + kd = 1), so the one warning is f32's.
        let steep =
            r#"{"model": "six", "params": {"kb": 0.5, "kr": 20, "b": -150, "a": 3, "kd": 0.5, "c": 4}}"#;
        let (packed, notes) = pack_text(steep, None);
        packed.unwrap();
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert_eq!(notes[0].level, Level::Warning);
        let text = &notes[0].text;
        assert!(
            text.starts_with("warning: results: fit 0 (six): the device's f32 evaluation errs by up to"),
            "{text}"
        );
        let e: f64 = text
            ["warning: results: fit 0 (six): the device's f32 evaluation errs by up to ".len()..]
            .split_whitespace()
            .next()
            .and_then(|w| w.parse().ok())
            .unwrap();
        assert!(e > F32_MAX_REL && e < 10.0 * F32_MAX_REL, "{text}");
        // A parameter f32 holds as 0 was packed with no word.
        let (packed, notes) = pack_text(r#"{"model": "lambert", "params": {"rho0": 1e-50}}"#, None);
        packed.unwrap();
        assert!(
            notes
                .iter()
                .any(|n| n.text.contains("rho0 = 1e-50 is below f32's normal numbers")),
            "{notes:?}"
        );
        // Khaki, in the paper's range, gets no note at all.
        let (_, notes) = pack_text(KHAKI, None);
        assert!(notes.is_empty(), "{notes:?}");
    }

    #[test]
    fn energy_warnings_name_the_fit() {
        let hot = r#"{"model": "six", "params": {"kb": 0.8, "kr": 21.8, "b": -27.5, "a": 0.67, "kd": 0.5, "c": 1.2}}"#;
        let (packed, notes) = pack_text(hot, None);
        packed.unwrap();
        assert_eq!(notes.len(), 1);
        assert_eq!(notes[0].level, Level::Warning);
        assert!(
            notes[0]
                .text
                .starts_with("warning: results: fit 0 (six): energy bound"),
            "{notes:?}"
        );
    }
}

#[cfg(test)]
mod band_tests {
    use super::*;

    /// A fit of `dataset` with the khaki shape and `kd`.
    fn band(dataset: &str, kd: f64) -> String {
        format!(
            r#"{{"dataset": "{dataset}", "model": "six", "params": {{"kb": 0.2545, "kr": 21.8031,
            "b": -27.5721, "a": 0.6705, "kd": {kd}, "c": 1.2}}}}"#
        )
    }

    fn pack_text(json: &str) -> (Result<Packed, PackError>, Vec<Note>) {
        let mut notes = Vec::new();
        let sources = [FitSource::Text {
            origin: "fits.json",
            json,
        }];
        (pack(&sources, &PackOptions::default(), |n| notes.push(n)), notes)
    }

    #[test]
    fn the_bands_of_a_measurement_become_one_material_beside_the_others() {
        // Bands out of order, a grey fit between them, and a second measurement's only band.
        let json = format!(
            "[{}, {}, {}, {}, {}]",
            band("paint.astm[wavelength=0.5]", 0.5),
            band("plate", 0.3),
            band("paint.astm[wavelength=0.4]", 0.4),
            band("other.astm[wavelength=0.55]", 0.2),
            band("paint.astm[wavelength=0.7]", 0.7),
        );
        let (packed, notes) = pack_text(&json);
        let p = packed.unwrap();
        assert_eq!(p.materials, 3);
        let back = Blob::decode(&p.bytes).unwrap();
        let m = back.materials[0];
        assert_eq!(m.band_count(), 3);
        let centres: Vec<f32> = (0..3).map(|k| m.band_centre(&p.bytes, k).unwrap()).collect();
        assert_eq!(centres, [0.4, 0.5, 0.7]);
        let kd: Vec<f32> = (0..3).map(|k| m.band_params(&p.bytes, k).unwrap()[4]).collect();
        assert_eq!(kd, [0.4, 0.5, 0.7]);
        assert_eq!(back.materials[1].params[4], 0.3);
        // The second measurement's only band is a material of one band.
        assert_eq!(
            (back.materials[1].band_count(), back.materials[2].band_count()),
            (0, 1)
        );
        let says = |start: &str| {
            assert!(
                notes.iter().any(|n| n.text.starts_with(start)),
                "{start}: {notes:?}"
            )
        };
        says("material 0: 3 bands of paint.astm (0.4–0.7 µm, six), from fits.json: fits 0, 2, 4");
        says("material 2: 1 band of other.astm (0.55 µm, six), from fits.json: fit 3");
        // Indices moved: the grey fit says which material it became.
        says("material 1: fits.json: fit 1 (six)");

        // Bands split over several sources (files, or Python's one FitResult each) are one
        // material; a band given in two of them is refused.
        let mut notes = Vec::new();
        let (a, b) = (
            band("paint.astm[wavelength=0.5]", 0.5),
            band("paint.astm[wavelength=0.4]", 0.4),
        );
        let two = [
            FitSource::Text {
                origin: "a.json",
                json: &a,
            },
            FitSource::Text {
                origin: "b.json",
                json: &b,
            },
        ];
        let p = pack(&two, &PackOptions::default(), |n| notes.push(n)).unwrap();
        assert_eq!(p.materials, 1);
        assert_eq!(Blob::decode(&p.bytes).unwrap().materials[0].band_count(), 2);
        assert!(
            notes
                .iter()
                .any(|n| n.text.contains("from a.json: fit 0, b.json: fit 0")),
            "{notes:?}"
        );
        let again = [
            FitSource::Text {
                origin: "a.json",
                json: &a,
            },
            FitSource::Text {
                origin: "c.json",
                json: &a,
            },
        ];
        let e = pack(&again, &PackOptions::default(), |_| {})
            .unwrap_err()
            .to_string();
        assert!(e.contains("are one band"), "{e}");
    }

    #[test]
    fn bands_that_cannot_be_one_material_are_refused_by_fit() {
        let err = |json: String| pack_text(&json).0.unwrap_err().to_string();
        let twice = err(format!(
            "[{}, {}]",
            band("p[wavelength=0.5]", 0.5),
            band("p[wavelength=0.5000000001]", 0.4)
        ));
        assert!(
            twice.contains("fit 0 (0.5 µm) and fits.json: fit 1 (0.5 µm) are one band: closer than 1e-6 µm;"),
            "{twice}"
        );
        // Apart in f64 but not once the device rounds them to f32.
        let close = err(format!(
            "[{}, {}]",
            band("p[wavelength=0.3]", 0.5),
            band("p[wavelength=0.30000101]", 0.4)
        ));
        assert!(close.contains("once rounded to f32"), "{close}");
        let tiny = err(format!(
            "[{}, {}]",
            band("p[wavelength=1e-310]", 0.5),
            band("p[wavelength=0.5]", 0.4)
        ));
        assert!(
            tiny.contains("fit 0: 1e-310 µm is not a wavelength a device holds"),
            "{tiny}"
        );
        let lambert = r#"{"dataset": "p[wavelength=0.6]", "model": "lambert", "params": {"rho0": 0.3}}"#;
        let mixed = err(format!("[{}, {lambert}]", band("p[wavelength=0.5]", 0.5)));
        assert!(mixed.contains("one model in every band"), "{mixed}");
        // (Lambertian bands: each fit's f32 accuracy is measured before the bands are grouped.)
        let many: Vec<String> = (0..65)
            .map(|k| {
                let um = 0.4 + 0.01 * k as f64;
                format!(
                    r#"{{"dataset": "p[wavelength={um}]", "model": "lambert", "params": {{"rho0": 0.3}}}}"#
                )
            })
            .collect();
        let many = err(format!("[{}]", many.join(",")));
        assert!(
            many.contains("65 bands: a device material holds at most 64"),
            "{many}"
        );
        // Bands with fitted tables (what `brdf select --chosen` writes of a spectral file).
        let shape = brdf_core::fitted::FittedShape {
            theta_h: 4,
            theta_d: 4,
            phi_d: 2,
        };
        let mut bytes = vec![0u8; shape.encoded_len()];
        let cells = shape.cells();
        brdf_core::fitted::encode_fitted(shape, &vec![0.1; cells], &vec![true; cells], &mut bytes).unwrap();
        let base = [0.2, 0.3, 0.04, 0.8];
        let check = crate::fitted_table::TableRecord::check_of(brdf_core::ModelKind::Ggx, &base, &bytes);
        let tabled = |um: f64| {
            format!(
                r#"{{"dataset": "p[wavelength={um}]", "model": "ggx", "params": {{"kd": 0.8,
                "ks": 0.2, "f0": 0.04, "alpha": 0.3}}, "fitted_table": {{"nodes": [4, 4, 2],
                "smoothness": 1.0, "coverage": 1.0, "bytes": "{}", "check": "{check}"}}}}"#,
                hex::encode(&bytes)
            )
        };
        // One band alone packs (a material the same at every wavelength); two are refused.
        assert!(
            pack_text(&tabled(0.5)).0.is_ok(),
            "{:?}",
            pack_text(&tabled(0.5)).0
        );
        let tables = err(format!("[{}, {}]", tabled(0.5), tabled(0.6)));
        assert!(
            tables.contains("fits.json: fits 0–1: fits.json: fit 0 has a fitted table")
                && tables.contains("one analytic fit per band"),
            "{tables}"
        );
        let bad = err(format!("[{}]", band("p[wavelength=-1]", 0.5)));
        assert!(
            bad.starts_with("fits.json: fit 0: dataset `p[wavelength=-1]`"),
            "{bad}"
        );
    }
}
