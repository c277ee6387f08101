//! The BRDF queries a scene makes, the domain each material's representation is judged
//! over: per aspect of the sweep and per material, the facets seen by source and receiver
//! with their cosines and the weight each BRDF value carries in σ ([`QueryBatch`],
//! [`SceneQueries`]); and the same queries as a file: `brdf scene domain` writes one row per
//! (aspect, facet seen) with the facet's local angles and its weight; `brdf check
//! --directions` reads such a file back ([`read_directions`]) to test a device on exactly
//! those directions.
//!
//! File columns: `azimuth,elevation` (the aspect, degrees), `material` (0-based, scene order:
//! the material's index in the blob `brdf select --scene` writes), `part`, `facet` (1-based,
//! mesh order), `theta_i,theta_r,phi` (degrees, canonical convention; `phi` in [0, 180], the
//! models being even in `phi`), `weight` (`4 pi cos(theta_i) cos(theta_r) A`, m² sr, so that
//! σ at an aspect is the sum of `weight * brdf` over its rows).

use std::f64::consts::PI;
use std::io::Write;
use std::path::Path;

use rayon::prelude::*;
use thiserror::Error;

use crate::eval::{eval_batch, Evaluator};
use crate::mesh::v3;
use crate::scene::{Aspect, Mode, Scene};

/// The queries one material receives at one aspect, as slices ([`crate::eval::eval_batch`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QueryBatch {
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

impl QueryBatch {
    /// `out` as `materials` empty batches, their memory kept (a sweep's per-thread scratch).
    pub(crate) fn empty_per_material(out: &mut Vec<QueryBatch>, materials: usize) {
        out.resize_with(materials, QueryBatch::default);
        out.truncate(materials);
        for b in out.iter_mut() {
            b.cos_theta_i.clear();
            b.cos_theta_r.clear();
            b.cos_phi.clear();
            b.weight.clear();
            b.facet.clear();
        }
    }

    /// Queries in the batch.
    pub fn len(&self) -> usize {
        self.weight.len()
    }

    /// No queries.
    pub fn is_empty(&self) -> bool {
        self.weight.is_empty()
    }

    /// `sum_k weight[k] f_r(k)` through `e`: the batch's share of σ, m². `scratch` is reused
    /// between calls.
    pub fn sigma(&self, e: &Evaluator, scratch: &mut Vec<f64>) -> f64 {
        scratch.clear();
        scratch.resize(self.len(), 0.0);
        eval_batch(e, &self.cos_theta_i, &self.cos_theta_r, &self.cos_phi, scratch);
        // From +0: `Sum` of f64 starts at -0, and σ of an aspect that sees nothing printed `-0`.
        self.weight
            .iter()
            .zip(scratch.iter())
            .fold(0.0, |s, (w, f)| s + w * f)
    }
}

impl QueryBatch {
    /// `sum_k weight[k] f_r(k)` over the queries outside `table`'s coverage
    /// (`brdf_core::fitted::FittedTable::covers`), `values` the `f_r` of every query (as
    /// [`QueryBatch::sigma`] leaves them in its scratch).
    pub fn outside_coverage(&self, table: &brdf_core::fitted::FittedTable<'_>, values: &[f64]) -> f64 {
        (0..self.len())
            .filter(|&k| {
                let g = brdf_core::Geometry::from_cosines(
                    self.cos_theta_i[k],
                    self.cos_theta_r[k],
                    self.cos_phi[k],
                );
                !table.covers(&g)
            })
            .fold(0.0, |s, k| s + self.weight[k] * values[k])
    }
}

/// The queries of one aspect, one [`QueryBatch`] per material (scene order). `stack` is scratch
/// space for the occlusion rays.
pub fn aspect_queries(scene: &Scene, aspect: &Aspect, stack: &mut Vec<usize>) -> Vec<QueryBatch> {
    let (v, s) = (aspect.receiver(), aspect.source(scene.sensor.mode));
    let mono = scene.sensor.mode == Mode::Monostatic;
    let occluder = scene.occluder();
    facing_queries(scene, aspect, |k, f| {
        !(occluder.blocked(f.centroid, v, k, stack) || !mono && occluder.blocked(f.centroid, s, k, stack))
    })
}

/// The queries of one aspect's facets that face both source and receiver and that `keep`
/// (facet index, facet) keeps: one [`QueryBatch`] per material, scene order.
pub fn facing_queries(
    scene: &Scene,
    aspect: &Aspect,
    keep: impl FnMut(usize, &crate::mesh::Facet) -> bool,
) -> Vec<QueryBatch> {
    let mut out = Vec::new();
    facing_queries_into(scene, aspect, keep, &mut out);
    out
}

/// [`facing_queries`] into `out`, whose batches' memory is reused (a sweep's per-thread
/// scratch).
pub fn facing_queries_into(
    scene: &Scene,
    aspect: &Aspect,
    mut keep: impl FnMut(usize, &crate::mesh::Facet) -> bool,
    out: &mut Vec<QueryBatch>,
) {
    let v = aspect.receiver();
    let s = aspect.source(scene.sensor.mode);
    let mono = scene.sensor.mode == Mode::Monostatic;
    QueryBatch::empty_per_material(out, scene.materials.len());
    for (k, f) in scene.mesh.facets.iter().enumerate() {
        let Some([mu_i, mu_r, cos_phi]) = facing(f.normal, s, v, mono) else {
            continue;
        };
        if !keep(k, f) {
            continue;
        }
        let b = &mut out[scene.facet_material[k] as usize];
        b.cos_theta_i.push(mu_i);
        b.cos_theta_r.push(mu_r);
        b.cos_phi.push(cos_phi);
        b.weight.push(4.0 * PI * mu_i * mu_r * f.area);
        b.facet.push(k as u32);
    }
}

/// A facet with normal `n` facing source `s` and receiver `v` (both cosines positive):
/// `[cos theta_i, cos theta_r, cos phi]`, `cos phi` 1 monostatic.
#[inline]
pub(crate) fn facing(n: [f64; 3], s: [f64; 3], v: [f64; 3], mono: bool) -> Option<[f64; 3]> {
    let (mu_i, mu_r) = (v3::dot(n, s), v3::dot(n, v));
    if !(mu_i > 0.0 && mu_r > 0.0) {
        return None;
    }
    Some([mu_i, mu_r, if mono { 1.0 } else { cos_phi(n, s, v, mu_i, mu_r) }])
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

/// Every query the scene makes, the domain a representation of its materials is judged over:
/// per aspect, one [`QueryBatch`] per material.
#[derive(Clone, Debug)]
pub struct SceneQueries {
    /// Aspects in sweep order.
    pub aspects: Vec<Aspect>,
    /// `batches[a][m]`: the queries of material `m` at aspect `a`.
    pub batches: Vec<Vec<QueryBatch>>,
}

impl SceneQueries {
    /// Number of queries in all.
    pub fn len(&self) -> usize {
        self.batches.iter().flatten().map(QueryBatch::len).sum()
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
                per.iter().zip(models).map(|(b, m)| b.sigma(m, scratch)).collect()
            })
            .collect()
    }
}

/// Collects the queries of every aspect (in parallel; `progress` once per aspect). Memory:
/// 36 bytes per query.
pub fn collect_queries(scene: &Scene, progress: &(dyn Fn() + Sync)) -> SceneQueries {
    let aspects = scene.aspects();
    let batches = batches_of(scene, &aspects, progress);
    SceneQueries { aspects, batches }
}

/// [`aspect_queries`] of `aspects`, in parallel, in their order.
fn batches_of(scene: &Scene, aspects: &[Aspect], progress: &(dyn Fn() + Sync)) -> Vec<Vec<QueryBatch>> {
    aspects
        .par_iter()
        .map_init(Vec::new, |stack, a| {
            let b = aspect_queries(scene, a, stack);
            progress();
            b
        })
        .collect()
}

/// Degrees of an angle whose cosine is `c` (clamped to [-1, 1]).
fn deg(c: f64) -> f64 {
    c.clamp(-1.0, 1.0).acos().to_degrees()
}

/// One row of the queries file: one query of one aspect (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryRow<'a> {
    /// Aspect azimuth, degrees.
    pub azimuth: f64,
    /// Aspect elevation, degrees.
    pub elevation: f64,
    /// Material index (0-based, scene order).
    pub material: usize,
    /// The mesh part the facet belongs to.
    pub part: &'a str,
    /// Facet number (1-based, mesh order).
    pub facet: usize,
    /// Incidence zenith on the facet, degrees.
    pub theta_i: f64,
    /// Viewing zenith on the facet, degrees.
    pub theta_r: f64,
    /// Relative azimuth, degrees in [0, 180].
    pub phi: f64,
    /// `4 pi cos(theta_i) cos(theta_r) A`, m² sr.
    pub weight: f64,
}

/// Every query of `queries` as rows, in file order (aspect, then material, then facet); what
/// [`write_csv`] writes and `brdf.scene_domain` returns.
pub fn rows<'a>(scene: &'a Scene, queries: &'a SceneQueries) -> impl Iterator<Item = QueryRow<'a>> + 'a {
    queries
        .aspects
        .iter()
        .zip(&queries.batches)
        .flat_map(move |(a, per)| {
            per.iter().enumerate().flat_map(move |(m, b)| {
                (0..b.len()).map(move |k| {
                    let facet = b.facet[k] as usize;
                    QueryRow {
                        azimuth: a.azimuth_deg,
                        elevation: a.elevation_deg,
                        material: m,
                        part: &scene.mesh.parts[scene.mesh.facets[facet].part as usize],
                        facet: facet + 1,
                        theta_i: deg(b.cos_theta_i[k]),
                        theta_r: deg(b.cos_theta_r[k]),
                        phi: deg(b.cos_phi[k]),
                        weight: b.weight[k],
                    }
                })
            })
        })
}

/// Writes the queries as CSV (shortest round-trip decimal for every number).
pub fn write_csv<W: Write>(scene: &Scene, queries: &SceneQueries, out: W) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record(CSV_HEADER)?;
    write_rows(&mut w, scene, queries)?;
    w.flush()?;
    Ok(())
}

/// Columns of [`write_csv`] and [`write_csv_streamed`].
const CSV_HEADER: [&str; 9] = [
    "azimuth",
    "elevation",
    "material",
    "part",
    "facet",
    "theta_i",
    "theta_r",
    "phi",
    "weight",
];

fn write_rows<W: Write>(
    w: &mut csv::Writer<W>,
    scene: &Scene,
    queries: &SceneQueries,
) -> Result<(), csv::Error> {
    for r in rows(scene, queries) {
        w.write_record([
            r.azimuth.to_string(),
            r.elevation.to_string(),
            r.material.to_string(),
            r.part.to_owned(),
            r.facet.to_string(),
            r.theta_i.to_string(),
            r.theta_r.to_string(),
            r.phi.to_string(),
            r.weight.to_string(),
        ])?;
    }
    Ok(())
}

/// Aspects whose queries [`write_csv_streamed`] holds at once: the memory it needs is this many
/// aspects' queries (four f64 and a facet index, about 40 bytes, per facet seen), whatever
/// the sweep's length.
pub const STREAM_ASPECTS: usize = 256;

/// [`write_csv`] of every aspect of `scene`, computed [`STREAM_ASPECTS`] at a time (in
/// parallel within each group) and written in sweep order, so that a sweep of a million aspects
/// does not hold a million aspects' queries. Returns the number of queries written.
pub fn write_csv_streamed<W: Write>(
    scene: &Scene,
    out: W,
    progress: &(dyn Fn() + Sync),
) -> Result<usize, csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record(CSV_HEADER)?;
    let mut written = 0;
    for group in scene.aspects().chunks(STREAM_ASPECTS) {
        let q = SceneQueries {
            aspects: group.to_vec(),
            batches: batches_of(scene, group, progress),
        };
        written += q.len();
        write_rows(&mut w, scene, &q)?;
    }
    w.flush()?;
    Ok(written)
}

/// One direction of a directions file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Direction {
    /// Material index, if the file has a `material` column.
    pub material: Option<usize>,
    /// Degrees.
    pub theta_i: f64,
    /// Degrees.
    pub theta_r: f64,
    /// Degrees.
    pub phi: f64,
    /// Weight in σ, m² sr, if the file has a `weight` column.
    pub weight: Option<f64>,
    /// 1-based line.
    pub line: u64,
}

/// Why a directions file was refused.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DirectionsError {
    /// Unreadable or malformed CSV.
    #[error("{file}: {message}")]
    Csv {
        /// File.
        file: String,
        /// What the reader said.
        message: String,
    },
    /// A missing or repeated column.
    #[error("{file}: line 1: {message}")]
    Header {
        /// File.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A bad value.
    #[error("{file}: line {line}: column {column}: {message}")]
    Value {
        /// File.
        file: String,
        /// 1-based line.
        line: u64,
        /// Column name.
        column: &'static str,
        /// What is wrong.
        message: String,
    },
    /// No rows.
    #[error("{file}: no directions")]
    Empty {
        /// File.
        file: String,
    },
}

/// Reads `theta_i,theta_r,phi` (degrees, zeniths in [0, 90]) and, if present, `material`
/// (non-negative integer) and `weight` (finite, non-negative) from a CSV; other columns are
/// ignored. Every row is checked; the first bad one stops the read with its line and column.
pub fn read_directions(path: &Path) -> Result<Vec<Direction>, DirectionsError> {
    let file = path.display().to_string();
    let csv_err = |e: csv::Error| DirectionsError::Csv {
        file: file.clone(),
        message: e.to_string(),
    };
    let mut r =
        csv::ReaderBuilder::new()
            .has_headers(true)
            .from_reader(
                brdf_fit::data::open_input(path).map_err(|e| DirectionsError::Csv {
                    file: file.clone(),
                    message: e.to_string(),
                })?,
            );
    let headers = r.headers().map_err(csv_err)?.clone();
    let find = |name: &str, required: bool| -> Result<Option<usize>, DirectionsError> {
        let mut hits = headers.iter().enumerate().filter(|(_, h)| h.trim() == name);
        match (hits.next(), hits.next()) {
            (Some((i, _)), None) => Ok(Some(i)),
            (Some(_), Some(_)) => Err(DirectionsError::Header {
                file: file.clone(),
                message: format!("column `{name}` appears twice"),
            }),
            (None, _) if required => Err(DirectionsError::Header {
                file: file.clone(),
                message: format!("missing column `{name}`"),
            }),
            (None, _) => Ok(None),
        }
    };
    let cols = [
        find("theta_i", true)?.unwrap_or(0),
        find("theta_r", true)?.unwrap_or(0),
        find("phi", true)?.unwrap_or(0),
    ];
    let material_col = find("material", false)?;
    let weight_col = find("weight", false)?;
    let mut out = Vec::new();
    for rec in r.records() {
        let rec = rec.map_err(csv_err)?;
        let line = rec.position().map_or(0, |p| p.line());
        let bad = |column: &'static str, message: String| DirectionsError::Value {
            file: file.clone(),
            line,
            column,
            message,
        };
        let num = |i: usize, column: &'static str| -> Result<f64, DirectionsError> {
            let t = rec.get(i).unwrap_or("").trim();
            let v: f64 = t
                .parse()
                .map_err(|_| bad(column, format!("`{t}` is not a number")))?;
            if !v.is_finite() {
                return Err(bad(column, format!("`{t}` is not finite")));
            }
            Ok(v)
        };
        let theta_i = num(cols[0], "theta_i")?;
        let theta_r = num(cols[1], "theta_r")?;
        let phi = num(cols[2], "phi")?;
        for (v, c) in [(theta_i, "theta_i"), (theta_r, "theta_r")] {
            if !(0.0..=90.0).contains(&v) {
                return Err(bad(c, format!("zenith {v} deg is outside [0, 90]")));
            }
        }
        // As every other reader of angles: beyond two turns an azimuth is a unit or column
        // error (1e300 was wrapped and checked as some other direction).
        let limit = brdf_fit::data::PHI_LIMIT_DEG;
        if phi.abs() > limit {
            return Err(bad(
                "phi",
                format!("azimuth {phi} deg is outside [-{limit}, {limit}] (is the unit right?)"),
            ));
        }
        let material = match material_col {
            None => None,
            Some(i) => {
                let t = rec.get(i).unwrap_or("").trim();
                Some(
                    t.parse::<usize>()
                        .map_err(|_| bad("material", format!("`{t}` is not a material index (0, 1, ...)")))?,
                )
            }
        };
        let weight = match weight_col {
            None => None,
            Some(i) => {
                let w = num(i, "weight")?;
                if w < 0.0 {
                    return Err(bad("weight", format!("{w} is negative")));
                }
                Some(w)
            }
        };
        out.push(Direction {
            material,
            theta_i,
            theta_r,
            phi,
            weight,
            line,
        });
    }
    if out.is_empty() {
        return Err(DirectionsError::Empty { file });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every other reader of angles refuses an azimuth beyond two turns; this one wrapped 1e300
    /// and checked the device at some other direction.
    #[test]
    fn a_directions_file_refuses_an_azimuth_beyond_two_turns() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.csv");
        for (phi, ok) in [("1e300", false), ("-721", false), ("720", true), ("-30", true)] {
            std::fs::write(&p, format!("theta_i,theta_r,phi\n10,20,0\n10,20,{phi}\n")).unwrap();
            match read_directions(&p) {
                Ok(d) => assert!(ok && d.len() == 2, "{phi} accepted"),
                Err(e) => {
                    let e = e.to_string();
                    assert!(
                        !ok && e.contains("line 3") && e.contains("column phi"),
                        "{phi}: {e}"
                    );
                }
            }
        }
    }
}
