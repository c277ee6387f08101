//! `brdf check`: the device's answers against the host's f64 model.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::accuracy::compare_above;
use brdf_core::bands::{blend, Located};
use brdf_core::fitted::Corrected;
use brdf_core::tolerance::{
    table_max_rel, BAND_BLEND_MAX_REL, F32_FLOOR_OF_MAX, F32_MAX_REL, TABLE_MAX_ZENITH_DEG,
};
use brdf_core::{AnyModel, Brdf};
use brdf_wire::blob::{table1_blob, Material, MAX_BLOB_LEN};
use brdf_wire::frame::Input;
use clap::Args;
use serde::Serialize;

use crate::common::count;
use crate::device::DeviceArgs;

/// Cross-check a device against the host: a dense grid of directions per material (plus edge
/// cases near grazing, near the retro and mirror directions, and in the plane phi = 0, 180 deg)
/// evaluated by the device in f32 and by the host in f64 at the same inputs. Prints the
/// maximum and mean absolute and relative errors per material and region; exits non-zero when
/// a relative error exceeds the f32 tolerance (2e-6, where f >= 1e-6 of its maximum). A
/// banded (spectral) material is checked in every band: the directions are asked in turn at
/// each band centre and each midpoint between neighbouring bands (EVAL_AT), against the f64
/// bands blended on the host (within 2e-6 at the centres, 2.5e-6 at the midpoints).
#[derive(Debug, Args)]
pub struct CheckCmd {
    #[command(flatten)]
    device: DeviceArgs,
    /// Random directions over the hemisphere per material (1 to 10,000,000), or a CSV of
    /// directions (`theta_i,theta_r,phi` in degrees, optional `material`), e.g. from `brdf
    /// scene domain`: then exactly those are checked (each distinct direction once), each
    /// against its material.
    #[arg(long, default_value = "20000", value_parser = parse_directions)]
    directions: Directions,
    /// Edge-case directions per region and material (0 to 1,000,000).
    #[arg(long, default_value_t = 1_000, value_parser = count(0, 1_000_000))]
    edge: usize,
    /// Seed of the directions.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// How many random directions, or which file of directions.
#[derive(Clone, Debug)]
pub enum Directions {
    /// Random directions per material (plus the edge regions).
    Count(usize),
    /// A CSV of directions.
    File(PathBuf),
}

fn parse_directions(text: &str) -> Result<Directions, String> {
    let t = text.trim();
    // A number (of any form) is a count, checked as one; anything else must name a file.
    if t.parse::<f64>().is_ok() {
        return match t.parse::<usize>() {
            Ok(n) if (1..=10_000_000).contains(&n) => Ok(Directions::Count(n)),
            _ => Err(format!(
                "`{text}`: need a whole number of directions in 1..=10000000, or a CSV file"
            )),
        };
    }
    let path = PathBuf::from(text);
    if path.is_file() {
        Ok(Directions::File(path))
    } else {
        Err(format!(
            "`{text}`: neither a whole number of directions in 1..=10000000 nor an existing CSV file"
        ))
    }
}

#[derive(Debug, Serialize)]
struct Region {
    material: usize,
    region: String,
    /// Table nodes, for a tabulated material.
    tabulated: Option<u16>,
    /// For a banded material: the wavelengths (µm) this region's directions were asked at
    /// (each direction at one, in turn): its band centres, or the midpoints between them.
    wavelengths: Option<Vec<f32>>,
    n: usize,
    max_abs: f64,
    mean_abs: f64,
    max_rel: f64,
    mean_rel: f64,
    /// The relative bound this region is held to (`None`: reported, not judged).
    tolerance: Option<f64>,
    within_tolerance: bool,
}

/// SplitMix64 for reproducible directions.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        brdf_core::accuracy::splitmix64_unit(&mut self.0)
    }
}

/// Directions (radians, f32) per region.
fn regions(n: usize, edge: usize, seed: u64) -> Vec<(&'static str, Vec<[f32; 3]>)> {
    let mut r = Rng(seed);
    let max_z = 89.9f64.to_radians();
    let pi = std::f64::consts::PI;
    let mut out = Vec::new();
    let dir = |a: f64, b: f64, c: f64| [a as f32, b as f32, c as f32];
    out.push((
        "hemisphere",
        (0..n)
            .map(|_| dir(r.unit() * max_z, r.unit() * max_z, r.unit() * 2.0 * pi))
            .collect(),
    ));
    out.push((
        "grazing",
        (0..edge)
            .map(|k| {
                let g = (89.0 + 0.9 * r.unit()).to_radians();
                let o = r.unit() * max_z;
                if k % 2 == 0 {
                    dir(g, o, r.unit() * 2.0 * pi)
                } else {
                    dir(o, g, r.unit() * 2.0 * pi)
                }
            })
            .collect(),
    ));
    for (name, centre) in [("near retro", 0.0), ("near mirror", pi)] {
        out.push((
            name,
            (0..edge)
                .map(|_| {
                    let ti = r.unit() * 85f64.to_radians();
                    let d = (r.unit() - 0.5) * 2e-4;
                    let p = centre + (r.unit() - 0.5) * 2e-4;
                    dir(ti, (ti + d).max(0.0), p)
                })
                .collect(),
        ));
    }
    out.push((
        "plane phi = 0, 180",
        (0..edge)
            .map(|k| {
                dir(
                    r.unit() * max_z,
                    r.unit() * max_z,
                    if k % 2 == 0 { 0.0 } else { pi },
                )
            })
            .collect(),
    ));
    out
}

/// How a banded material is checked: its band centres and the midpoints between neighbours,
/// the f64 model of every band (from the device's f32 parameters), the host's blend.
struct BandPlan {
    centres: Vec<f32>,
    /// The centres widened, as the host's blend locates a wavelength among them.
    centres_f64: Vec<f64>,
    midpoints: Vec<f32>,
    models: Vec<AnyModel<f64>>,
}

/// The plan of material `m` if it is banded.
fn band_plan(mat: &Material, blob: &[u8], m: usize, blob_name: &str) -> Result<Option<BandPlan>> {
    let count = mat.band_count();
    if count == 0 {
        return Ok(None);
    }
    let mut centres = Vec::with_capacity(count);
    let mut models = Vec::with_capacity(count);
    for k in 0..count {
        let (Some(c), Some(p)) = (mat.band_centre(blob, k), mat.band_params(blob, k)) else {
            bail!("{blob_name}: material {m}: band {k} is not in the blob");
        };
        let p64: Vec<f64> = p[..mat.kind.param_count()]
            .iter()
            .map(|&v| f64::from(v))
            .collect();
        centres.push(c);
        models.push(
            AnyModel::<f64>::new(mat.kind, &p64)
                .with_context(|| format!("{blob_name}: material {m}: band {k}"))?,
        );
    }
    // The midpoint in f32, as sent; the host blends at that same wavelength.
    let midpoints = centres.windows(2).map(|w| w[0] + 0.5 * (w[1] - w[0])).collect();
    Ok(Some(BandPlan {
        centres_f64: centres.iter().map(|&c| f64::from(c)).collect(),
        centres,
        midpoints,
        models,
    }))
}

/// Directions of a region asked and judged together.
struct Part {
    /// The region's row label.
    label: String,
    /// The directions.
    xs: Vec<[f32; 3]>,
    /// The wavelength each is asked at (`None`: plain EVAL_BATCH).
    at: Vec<Option<f32>>,
    /// Tolerance on top of the material's.
    extra: f64,
    /// The wavelengths asked at, for the report.
    asked: Option<Vec<f32>>,
}

impl BandPlan {
    /// The region's directions as two parts, at the centres and between the bands; direction
    /// `k` is asked at the `k`-th of the `2 m - 1` wavelengths (centres and midpoints in
    /// wavelength order), in turn.
    fn split(&self, name: &str, xs: &[[f32; 3]]) -> Vec<Part> {
        // Centre 0, midpoint 0, centre 1, ...: in wavelength order, so a small sample reaches
        // both kinds.
        let all: Vec<(f32, bool)> = self
            .centres
            .iter()
            .enumerate()
            .flat_map(|(k, &c)| std::iter::once((c, true)).chain(self.midpoints.get(k).map(|&m| (m, false))))
            .collect();
        let mut centre = (Vec::new(), Vec::new());
        let mut between = (Vec::new(), Vec::new());
        for (k, x) in xs.iter().enumerate() {
            let (um, at_centre) = all[k % all.len()];
            let part = if at_centre { &mut centre } else { &mut between };
            part.0.push(*x);
            part.1.push(Some(um));
        }
        // The wavelengths a part's directions were asked at (a sample smaller than 2 m - 1
        // reaches only some of them: the report says which).
        let asked = |at: &[Option<f32>]| -> Vec<f32> {
            let mut w: Vec<f32> = at.iter().flatten().copied().collect();
            w.sort_by(f32::total_cmp);
            w.dedup();
            w
        };
        let (c, b) = (asked(&centre.1), asked(&between.1));
        vec![
            Part {
                label: format!("{name} @ {} of {} bands", c.len(), self.centres.len()),
                xs: centre.0,
                at: centre.1,
                extra: 0.0,
                asked: Some(c),
            },
            Part {
                label: format!("{name} @ {} of {} midpoints", b.len(), self.midpoints.len()),
                xs: between.0,
                at: between.1,
                extra: BAND_BLEND_MAX_REL,
                asked: Some(b),
            },
        ]
    }

    /// The host's f64 value at `um` (a centre or a midpoint) from angles in radians.
    fn eval_angles(&self, um: f32, ti: f64, tr: f64, phi: f64) -> f64 {
        let f = |k: usize| self.models[k].eval_angles(ti, tr, phi);
        match brdf_core::bands::locate(&self.centres_f64, f64::from(um)) {
            Ok(Located::Band(k)) => f(k),
            Ok(Located::Between { lower, weight }) => blend(f(lower), f(lower + 1), weight),
            // Never asked: the plan's wavelengths lie within the bands.
            Err(_) => f64::NAN,
        }
    }
}

impl CheckCmd {
    pub fn run(self) -> Result<()> {
        // A directions file is read (and every row checked) before the device is opened.
        let (random_n, file) = match &self.directions {
            Directions::Count(n) => (*n, None),
            Directions::File(p) => (0, Some((p.clone(), brdf_scene::queries::read_directions(p)?))),
        };
        let (mut link, loaded) = self.device.connect()?;
        // Without --blob the device must run the built-in Table 1, the only set the host
        // then knows.
        let (blob, expected_crc, blob_bytes) = match loaded {
            Some(b) => b,
            None => {
                let default = table1_blob();
                let mut buf = [0u8; MAX_BLOB_LEN];
                let n = default.encode(&mut buf).map_err(|e| anyhow!("{e}"))?;
                (default, brdf_wire::blob::blob_crc(&buf[..n]), buf[..n].to_vec())
            }
        };
        // The device's active blob must be exactly the one checked against.
        let (_, _, active_crc, count) = link.info()?;
        if active_crc != expected_crc || usize::from(count) != blob.materials.len() {
            bail!(
                "the device's active parameters (CRC {active_crc:#010x}) are not the ones checked \
                 ({expected_crc:#010x}): pass the blob it runs with --blob"
            );
        }
        let (random, file) = match file {
            None => (regions(random_n, self.edge, self.seed), None),
            Some((p, rows)) => {
                let n = blob.materials.len();
                if let Some(r) = rows.iter().find(|r| r.material.is_some_and(|k| k >= n)) {
                    bail!(
                        "{}: line {}: material {}: the device holds {n} materials (0..{})",
                        p.display(),
                        r.line,
                        r.material.unwrap_or(0),
                        n - 1
                    );
                }
                (Vec::new(), Some(rows))
            }
        };
        let mut table = Vec::new();
        for (m, mat) in blob.materials.iter().enumerate() {
            // The file's directions of this material (all of them without a material column),
            // converted as `brdf eval --precision f32` does: degrees to radians in f64, then f32.
            let dirs = match &file {
                None => random.clone(),
                Some(rows) => {
                    let mut xs: Vec<[f32; 3]> = rows
                        .iter()
                        .filter(|r| r.material.is_none_or(|k| k == m))
                        // phi 180, -180 and 540 are one direction: asked once.
                        .map(|r| {
                            [r.theta_i, r.theta_r, brdf_fit::import::wrap_degrees(r.phi)]
                                .map(|d| d.to_radians() as f32)
                        })
                        .collect();
                    // Facets that share angles (a ring of a hull) ask the same question: each
                    // distinct direction is asked once.
                    xs.sort_by_key(|x| x.map(f32::to_bits));
                    xs.dedup_by_key(|x| x.map(f32::to_bits));
                    vec![("scene directions", xs)]
                }
            };
            if dirs.iter().all(|d| d.1.is_empty()) {
                // Only a file can leave a material without directions: say so, a silent
                // pass of the other materials read as a pass of all of them.
                eprintln_lossy!(
                    "note: material {m} ({}) not checked: {} has no direction of it",
                    mat.kind.name(),
                    file.as_ref().map_or("the sample", |_| "the directions file")
                );
                continue;
            }
            let p64: Vec<f64> = mat.params[..mat.kind.param_count()]
                .iter()
                .map(|&v| f64::from(v))
                .collect();
            let host = AnyModel::<f64>::new(mat.kind, &p64).with_context(|| {
                format!("{}: material {m} ({})", self.device.blob_name(), mat.kind.name())
            })?;
            // A fitted table's reference is the same table in f64 over its f64 base.
            let fitted = mat
                .fitted_table(&blob_bytes)
                .map(|table| Corrected { base: host, table });
            // A tabulated material is held to its table's bound within the promised zenith
            // range; beyond it the errors are reported, not judged. A fitted table is held to
            // its own f32 bound (`FittedTable::f32_max_rel`) on top of its base's.
            let promise = match (mat.table, &fitted) {
                (_, Some(f)) => Some((F32_MAX_REL + f.table.f32_max_rel(), 90.0)),
                (None, None) => Some((F32_MAX_REL, 90.0)),
                (Some(t), None) => table_max_rel(usize::from(t.nodes)).map(|b| (b, TABLE_MAX_ZENITH_DEG)),
            };
            // A banded material: its centres, then the midpoints between them, each with the
            // extra tolerance of a blend there; the f64 model of every band.
            let banded = band_plan(mat, &blob_bytes, m, &self.device.blob_name())?;
            let mut results = Vec::new();
            for (name, xs) in dirs.iter().filter(|d| !d.1.is_empty()) {
                let parts: Vec<Part> = match &banded {
                    None => vec![Part {
                        label: name.to_string(),
                        xs: xs.clone(),
                        at: vec![None; xs.len()],
                        extra: 0.0,
                        asked: None,
                    }],
                    Some(plan) => plan.split(name, xs),
                };
                for Part {
                    label,
                    xs,
                    at,
                    extra,
                    asked,
                } in parts
                {
                    if xs.is_empty() {
                        continue;
                    }
                    let mut dev = vec![0.0f32; xs.len()];
                    let mut distinct: Vec<Option<f32>> = at.clone();
                    distinct.sort_by(|a, b| a.map(f32::to_bits).cmp(&b.map(f32::to_bits)));
                    distinct.dedup();
                    for um in distinct {
                        let idx: Vec<usize> = (0..xs.len()).filter(|&k| at[k] == um).collect();
                        let sub: Vec<[f32; 3]> = idx.iter().map(|&k| xs[k]).collect();
                        let got = link.eval_at(m as u8, Input::Angles, um, &sub).with_context(|| {
                            format!(
                                "material {m}: the {name} directions{}",
                                um.map_or(String::new(), |w| format!(" at {w} µm"))
                            )
                        })?;
                        for (&k, v) in idx.iter().zip(got) {
                            dev[k] = v;
                        }
                    }
                    let exact: Vec<f64> = xs
                        .iter()
                        .zip(&at)
                        .map(|(x, um)| {
                            let (ti, tr, phi) = (x[0].into(), x[1].into(), x[2].into());
                            match (&banded, um) {
                                (Some(plan), Some(um)) => plan.eval_angles(*um, ti, tr, phi),
                                _ => match &fitted {
                                    Some(f) => f.eval_angles(ti, tr, phi),
                                    None => host.eval_angles(ti, tr, phi),
                                },
                            }
                        })
                        .collect();
                    let limit = promise.map_or(-1.0, |p| p.1.to_radians() as f32);
                    let inside = |x: &[f32; 3]| x[0] <= limit && x[1] <= limit;
                    let split = |keep: bool| -> (Vec<f32>, Vec<f64>) {
                        xs.iter()
                            .zip(dev.iter().zip(&exact))
                            .filter(|(x, _)| inside(x) == keep)
                            .map(|(_, (d, e))| (*d, *e))
                            .unzip()
                    };
                    let (d_in, e_in) = split(true);
                    let (d_out, e_out) = split(false);
                    if !d_in.is_empty() {
                        results.push((
                            label.clone(),
                            d_in,
                            e_in,
                            promise.map(|p| p.0 + extra),
                            asked.clone(),
                        ));
                    }
                    if !d_out.is_empty() {
                        let label = match promise {
                            Some((_, z)) => format!("{label} (>{z} deg)"),
                            None => format!("{label} (table size not measured)"),
                        };
                        results.push((label, d_out, e_out, None, asked));
                    }
                }
            }
            let max = results
                .iter()
                .flat_map(|r| r.2.iter().copied())
                .fold(0.0, f64::max);
            for (name, dev, exact, tolerance, wavelengths) in results {
                let a = compare_above(0..dev.len(), |k| dev[k], |k| exact[k], F32_FLOOR_OF_MAX * max);
                table.push(Region {
                    material: m,
                    region: name,
                    tabulated: mat.table.map(|t| t.nodes),
                    wavelengths,
                    n: dev.len(),
                    max_abs: a.max_abs,
                    mean_abs: a.mean_abs,
                    max_rel: a.max,
                    mean_rel: a.mean,
                    tolerance,
                    within_tolerance: tolerance.is_none_or(|t| a.max <= t),
                });
            }
        }
        if self.json {
            println!("{}", serde_json::to_string_pretty(&table)?);
        } else {
            println!(
                "{:>3} {:<40} {:>6} {:>11} {:>11} {:>11} {:>11} {:>10}",
                "mat", "region", "n", "max abs", "mean abs", "max rel", "mean rel", "tolerance"
            );
            for r in &table {
                println!(
                    "{:>3} {:<40} {:>6} {:>11.3e} {:>11.3e} {:>11.3e} {:>11.3e} {:>10}  {}",
                    r.material,
                    match r.tabulated {
                        Some(n) => format!("{} [table {n}]", r.region),
                        None => r.region.clone(),
                    },
                    r.n,
                    r.max_abs,
                    r.mean_abs,
                    r.max_rel,
                    r.mean_rel,
                    r.tolerance.map_or("-".to_owned(), |t| format!("{t:.1e}")),
                    match (r.tolerance, r.within_tolerance) {
                        (None, _) => "reported",
                        (_, true) => "ok",
                        (_, false) => "BEYOND TOLERANCE",
                    }
                );
            }
        }
        if let Some(r) = table.iter().find(|r| !r.within_tolerance) {
            bail!(
                "material {} ({}): max relative error {:e} exceeds {:e}",
                r.material,
                r.region,
                r.max_rel,
                r.tolerance.unwrap_or(0.0)
            );
        }
        Ok(())
    }
}
