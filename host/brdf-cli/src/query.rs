//! `brdf query`: ask a device for BRDF values.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_wire::frame::Input;
use clap::Args;

use crate::check::DeviceArgs;
use crate::common::parse_list;

/// Ask a device (the firmware under QEMU) for f_r in 1/sr: one direction with --angles, or
/// every row of a CSV with theta_i,theta_r,phi in degrees (written back with a `brdf` column).
#[derive(Debug, Args)]
pub struct QueryCmd {
    #[command(flatten)]
    device: DeviceArgs,
    /// Material id in the active blob.
    #[arg(long, default_value_t = 0)]
    material: u8,
    /// One direction: theta_i,theta_r,phi in degrees.
    #[arg(long, conflicts_with = "csv")]
    angles: Option<String>,
    /// A CSV of directions (header with theta_i, theta_r, phi in degrees).
    csv: Option<PathBuf>,
}

impl QueryCmd {
    pub fn run(self) -> Result<()> {
        let dirs: Vec<[f64; 3]> = match (&self.angles, &self.csv) {
            (Some(a), None) => {
                let v = parse_list(a).map_err(|e| anyhow!("--angles: {e}"))?;
                if v.len() != 3 {
                    bail!("--angles: need theta_i,theta_r,phi");
                }
                vec![[v[0], v[1], v[2]]]
            }
            (None, Some(path)) => read_csv(path)?,
            _ => bail!("give --angles or a CSV file"),
        };
        let (mut link, _) = self.device.connect()?;
        let xs: Vec<[f32; 3]> = dirs.iter().map(|d| d.map(|v| v.to_radians() as f32)).collect();
        let vals = link.eval(self.material, Input::Angles, &xs)?;
        if self.angles.is_some() {
            println!("{:.8e}", vals[0]);
        } else {
            println!("theta_i,theta_r,phi,brdf");
            for (d, v) in dirs.iter().zip(&vals) {
                println!("{},{},{},{v:.8e}", d[0], d[1], d[2]);
            }
        }
        Ok(())
    }
}

fn read_csv(path: &PathBuf) -> Result<Vec<[f64; 3]>> {
    let file = path.display().to_string();
    let mut r = csv::Reader::from_path(path).with_context(|| format!("cannot open {file}"))?;
    let h = r.headers()?.clone();
    let col = |n: &str| {
        h.iter()
            .position(|c| c.trim() == n)
            .ok_or_else(|| anyhow!("{file}: line 1: missing column `{n}`"))
    };
    let cols = [col("theta_i")?, col("theta_r")?, col("phi")?];
    let mut out = Vec::new();
    for rec in r.records() {
        let rec = rec.with_context(|| format!("{file}: malformed CSV"))?;
        let line = rec.position().map_or(0, |p| p.line());
        let mut d = [0.0; 3];
        for (k, (&c, name)) in cols.iter().zip(["theta_i", "theta_r", "phi"]).enumerate() {
            let t = rec.get(c).unwrap_or("").trim();
            d[k] = t
                .parse()
                .map_err(|_| anyhow!("{file}: line {line}: column {name}: `{t}` is not a number"))?;
        }
        out.push(d);
    }
    Ok(out)
}
