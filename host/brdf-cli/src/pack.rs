//! `brdf pack`: a parameter blob from fit results.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::{ModelKind, MAX_PARAMS};
use brdf_wire::blob::{Blob, Material, MAX_BLOB_LEN, MAX_MATERIALS};
use clap::Args;

/// Build a parameter blob for the firmware from `brdf fit --json` outputs: one material per
/// fit, in the order given (an array from a batch fit adds each of its fits). Parameters
/// outside a model's valid ranges are refused; a material without a proof of energy
/// conservation (`kb + kd > 1`, or no bound) is packed with a warning.
#[derive(Debug, Args)]
pub struct PackCmd {
    /// Fit results (JSON from `brdf fit --json`).
    #[arg(required = true)]
    fits: Vec<PathBuf>,
    /// Output blob.
    #[arg(short = 'o', long)]
    output: PathBuf,
    /// Sequence number: a device keeps the valid blob with the larger one.
    #[arg(long, default_value_t = 1)]
    sequence: u32,
}

fn material(file: &str, index: usize, v: &serde_json::Value) -> Result<Material> {
    let name = v["model"]
        .as_str()
        .ok_or_else(|| anyhow!("{file}: fit {index}: no `model`"))?;
    let kind =
        ModelKind::from_name(name).ok_or_else(|| anyhow!("{file}: fit {index}: unknown model `{name}`"))?;
    let mut params = [0.0f32; MAX_PARAMS];
    for (j, p) in kind.param_names().iter().enumerate() {
        let x = v["params"][*p]
            .as_f64()
            .ok_or_else(|| anyhow!("{file}: fit {index}: parameter `{p}` missing or not a number"))?;
        params[j] = x as f32;
    }
    let m = Material { kind, params };
    let model = m
        .model()
        .map_err(|e| anyhow!("{file}: fit {index}: refused: {e}"))?;
    match model.energy_bound() {
        Some(b) if b <= 1.0 => {}
        Some(b) => eprintln!(
            "warning: {file}: fit {index} ({name}): energy bound {b} > 1, conservation not guaranteed"
        ),
        None => eprintln!("warning: {file}: fit {index} ({name}): the model has no energy bound"),
    }
    Ok(m)
}

impl PackCmd {
    pub fn run(self) -> Result<()> {
        let mut materials: heapless::Vec<Material, MAX_MATERIALS> = heapless::Vec::new();
        for path in &self.fits {
            let file = path.display().to_string();
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {file}"))?;
            let v: serde_json::Value =
                serde_json::from_str(&text).with_context(|| format!("{file}: not JSON"))?;
            let fits: Vec<&serde_json::Value> = match &v {
                serde_json::Value::Array(a) => a.iter().collect(),
                other => vec![other],
            };
            for (i, f) in fits.into_iter().enumerate() {
                if materials.push(material(&file, i, f)?).is_err() {
                    bail!("more than {MAX_MATERIALS} materials: a blob holds at most {MAX_MATERIALS}");
                }
            }
        }
        let blob = Blob {
            sequence: self.sequence,
            materials,
        };
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = blob.encode(&mut buf).map_err(|e| anyhow!("{e}"))?;
        std::fs::write(&self.output, &buf[..n])
            .with_context(|| format!("cannot write {}", self.output.display()))?;
        eprintln!(
            "wrote {} ({} bytes, {} materials, sequence {}, CRC {:#010x})",
            self.output.display(),
            n,
            blob.materials.len(),
            self.sequence,
            brdf_wire::crc32(&buf[..n - 4])
        );
        Ok(())
    }
}
