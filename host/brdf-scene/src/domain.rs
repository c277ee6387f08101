//! The scene's queries as a file: `brdf scene domain` writes one row per (aspect, facet
//! seen) with the facet's local angles and the weight its BRDF value carries in σ;
//! `brdf check --directions` reads it back to test a device on exactly those directions.
//!
//! Columns: `azimuth,elevation` (the aspect, degrees), `material` (0-based, scene order: the
//! material's index in the blob `brdf select --scene` writes), `part`, `facet` (1-based, mesh
//! order), `theta_i,theta_r,phi` (degrees, canonical convention; `phi` in [0, 180], the
//! models being even in `phi`), `weight` (`4 pi cos(theta_i) cos(theta_r) A`, m² sr, so that
//! σ at an aspect is the sum of `weight * brdf` over its rows).

use std::io::Write;
use std::path::Path;

use thiserror::Error;

use crate::lrcs::Domain;
use crate::scene::Scene;

/// Degrees of an angle whose cosine is `c` (clamped to [-1, 1]).
fn deg(c: f64) -> f64 {
    c.clamp(-1.0, 1.0).acos().to_degrees()
}

/// One row of the domain file: one query of one aspect (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DomainRow<'a> {
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

/// Every query of `domain` as rows, in file order (aspect, then material, then facet); what
/// [`write_csv`] writes and `brdf.scene_domain` returns.
pub fn rows<'a>(scene: &'a Scene, domain: &'a Domain) -> impl Iterator<Item = DomainRow<'a>> + 'a {
    domain
        .aspects
        .iter()
        .zip(&domain.batches)
        .flat_map(move |(a, per)| {
            per.iter().enumerate().flat_map(move |(m, b)| {
                (0..b.len()).map(move |k| {
                    let facet = b.facet[k] as usize;
                    DomainRow {
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

/// Writes the domain as CSV (shortest round-trip decimal for every number).
pub fn write_csv<W: Write>(scene: &Scene, domain: &Domain, out: W) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record([
        "azimuth",
        "elevation",
        "material",
        "part",
        "facet",
        "theta_i",
        "theta_r",
        "phi",
        "weight",
    ])?;
    for r in rows(scene, domain) {
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
    w.flush()?;
    Ok(())
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
    let mut r = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_path(path)
        .map_err(csv_err)?;
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
