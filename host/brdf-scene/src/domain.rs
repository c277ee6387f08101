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
    for (a, per) in domain.aspects.iter().zip(&domain.batches) {
        for (m, b) in per.iter().enumerate() {
            for k in 0..b.len() {
                let facet = b.facet[k] as usize;
                let part = &scene.mesh.parts[scene.mesh.facets[facet].part as usize];
                w.write_record([
                    a.azimuth_deg.to_string(),
                    a.elevation_deg.to_string(),
                    m.to_string(),
                    part.clone(),
                    (facet + 1).to_string(),
                    deg(b.cos_theta_i[k]).to_string(),
                    deg(b.cos_theta_r[k]).to_string(),
                    deg(b.cos_phi[k]).to_string(),
                    b.weight[k].to_string(),
                ])?;
            }
        }
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
