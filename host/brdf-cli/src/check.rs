//! `brdf check`: the device's answers against the host's f64 model.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::tolerance::{F32_FLOOR_OF_MAX, F32_MAX_REL};
use brdf_core::{AnyModel, Brdf};
use brdf_link::{Link, Qemu};
use brdf_wire::blob::{table1_blob, Blob, MAX_BLOB_LEN};
use brdf_wire::frame::Input;
use clap::Args;
use serde::Serialize;

/// Cross-check a device against the host: a dense grid of directions per material (plus edge
/// cases near grazing, near the retro and mirror directions, and in the plane phi = 0, 180 deg)
/// evaluated by the device in f32 and by the host in f64 at the same inputs. Prints the
/// maximum and mean absolute and relative errors per material and region; exits non-zero when
/// a relative error exceeds the f32 tolerance (2e-6, where f >= 1e-6 of its maximum).
#[derive(Debug, Args)]
pub struct CheckCmd {
    #[command(flatten)]
    device: DeviceArgs,
    /// Random directions over the hemisphere per material.
    #[arg(long, default_value_t = 20_000)]
    directions: usize,
    /// Edge-case directions per region and material.
    #[arg(long, default_value_t = 1_000)]
    edge: usize,
    /// Seed of the directions.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// Which device to talk to, and what to load into it first.
#[derive(Debug, Args)]
pub struct DeviceArgs {
    /// Run the firmware under QEMU (the only transport so far).
    #[arg(long, required = true)]
    qemu: bool,
    /// Firmware ELF (default: the release build in firmware/).
    #[arg(long)]
    elf: Option<PathBuf>,
    /// LOAD this parameter blob first (default: the firmware's built-in Table 1).
    #[arg(long)]
    blob: Option<PathBuf>,
}

impl DeviceArgs {
    /// Starts the device, LOADs `--blob` if given, and returns the link with the blob the
    /// device now runs.
    pub fn connect(&self) -> Result<(Link<Qemu>, Blob)> {
        let elf = self.elf.clone().unwrap_or_else(default_elf);
        let mut link = Link::new(Qemu::spawn(&elf)?);
        let blob = match &self.blob {
            Some(path) => {
                let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
                let blob = Blob::decode(&bytes).map_err(|e| anyhow!("{}: {e}", path.display()))?;
                link.load(&bytes)
                    .with_context(|| format!("the device refused {}", path.display()))?;
                blob
            }
            None => table1_blob(),
        };
        Ok((link, blob))
    }
}

/// Default firmware location in this repository.
pub fn default_elf() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../firmware/target/thumbv7em-none-eabihf/release/brdf-fw")
}

#[derive(Debug, Serialize)]
struct Region {
    material: usize,
    region: &'static str,
    n: usize,
    max_abs: f64,
    mean_abs: f64,
    max_rel: f64,
    mean_rel: f64,
    within_tolerance: bool,
}

/// SplitMix64 for reproducible directions.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
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

impl CheckCmd {
    pub fn run(self) -> Result<()> {
        let (mut link, blob) = self.device.connect()?;
        // The device's active blob must be exactly the one checked against.
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = blob.encode(&mut buf).map_err(|e| anyhow!("{e}"))?;
        let expected_crc = brdf_wire::crc32(&buf[..n - 4]);
        let (_, _, active_crc, count) = link.info()?;
        if active_crc != expected_crc || usize::from(count) != blob.materials.len() {
            bail!("the device's active parameters (CRC {active_crc:#010x}) are not the ones checked ({expected_crc:#010x})");
        }
        let dirs = regions(self.directions, self.edge, self.seed);
        let mut table = Vec::new();
        for (m, mat) in blob.materials.iter().enumerate() {
            let p64: Vec<f64> = mat.params[..mat.kind.param_count()]
                .iter()
                .map(|&v| f64::from(v))
                .collect();
            let host = AnyModel::<f64>::new(mat.kind, &p64)?;
            let mut results = Vec::new();
            for (name, xs) in &dirs {
                let dev = link.eval(m as u8, Input::Angles, xs)?;
                let exact: Vec<f64> = xs
                    .iter()
                    .map(|x| host.eval_angles(x[0].into(), x[1].into(), x[2].into()))
                    .collect();
                results.push((*name, dev, exact));
            }
            let max = results
                .iter()
                .flat_map(|r| r.2.iter().copied())
                .fold(0.0, f64::max);
            for (name, dev, exact) in results {
                let (mut max_abs, mut sum_abs, mut max_rel, mut sum_rel, mut nrel) =
                    (0.0f64, 0.0, 0.0f64, 0.0, 0usize);
                for (&d, &e) in dev.iter().zip(&exact) {
                    let a = (f64::from(d) - e).abs();
                    max_abs = max_abs.max(a);
                    sum_abs += a;
                    if e >= F32_FLOOR_OF_MAX * max && e > 0.0 {
                        max_rel = max_rel.max(a / e);
                        sum_rel += a / e;
                        nrel += 1;
                    }
                }
                table.push(Region {
                    material: m,
                    region: name,
                    n: dev.len(),
                    max_abs,
                    mean_abs: sum_abs / dev.len().max(1) as f64,
                    max_rel,
                    mean_rel: sum_rel / nrel.max(1) as f64,
                    within_tolerance: max_rel <= F32_MAX_REL,
                });
            }
        }
        if self.json {
            println!("{}", serde_json::to_string_pretty(&table)?);
        } else {
            println!(
                "{:>3} {:<20} {:>6} {:>11} {:>11} {:>11} {:>11}  (tolerance {F32_MAX_REL:e} relative)",
                "mat", "region", "n", "max abs", "mean abs", "max rel", "mean rel"
            );
            for r in &table {
                println!(
                    "{:>3} {:<20} {:>6} {:>11.3e} {:>11.3e} {:>11.3e} {:>11.3e}  {}",
                    r.material,
                    r.region,
                    r.n,
                    r.max_abs,
                    r.mean_abs,
                    r.max_rel,
                    r.mean_rel,
                    if r.within_tolerance {
                        "ok"
                    } else {
                        "BEYOND TOLERANCE"
                    }
                );
            }
        }
        if let Some(r) = table.iter().find(|r| !r.within_tolerance) {
            bail!(
                "material {} ({}): max relative error {:e} exceeds {F32_MAX_REL:e}",
                r.material,
                r.region,
                r.max_rel
            );
        }
        Ok(())
    }
}
