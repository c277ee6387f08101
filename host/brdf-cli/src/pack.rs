//! `brdf pack`: a parameter blob from fit results.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::table::{fill_six_table, table_len, MAX_TABLE_NODES, MIN_TABLE_NODES};
use brdf_core::tolerance::{TABLE_MAX_REL, TABLE_MAX_ZENITH_DEG};
use brdf_core::{ModelKind, MAX_PARAMS};
use brdf_wire::blob::{Blob, Material, TableRef, MAX_BLOB_LEN, MAX_MATERIALS};
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
    /// Sequence number: a device keeps the valid blob with the newer one, in serial-number
    /// order (N + 1 is always newer than N; 0 follows 4294967295).
    #[arg(long, default_value_t = 1)]
    sequence: u32,
    /// Add lookup tables with this many nodes to every six-parameter material (the
    /// device's fast path; 256 nodes = 3,072 bytes per material, max relative error 1.5e-3
    /// up to 85 degrees zenith).
    #[arg(long, value_name = "NODES",
          value_parser = crate::common::count(MIN_TABLE_NODES as u64, MAX_TABLE_NODES as u64))]
    table_nodes: Option<usize>,
}

/// One material from one `brdf fit --json` result (refusing invalid parameters, warning on
/// energy).
pub(crate) fn material(file: &str, index: usize, v: &serde_json::Value, warn: bool) -> Result<Material> {
    let name = v["model"]
        .as_str()
        .ok_or_else(|| anyhow!("{file}: fit {index}: no `model`"))?;
    let kind =
        ModelKind::from_name(name).ok_or_else(|| anyhow!("{file}: fit {index}: unknown model `{name}`"))?;
    let mut params = [0.0f32; MAX_PARAMS];
    for (j, (p, range)) in kind.param_names().iter().zip(kind.ranges()).enumerate() {
        let x = v["params"][*p]
            .as_f64()
            .ok_or_else(|| anyhow!("{file}: fit {index}: parameter `{p}` missing or not a number"))?;
        // The range is checked on the value as written and again (in the model) on its f32
        // rounding; both are exact at the bounds (brdf_core::ranges).
        range
            .check(x)
            .map_err(|e| anyhow!("{file}: fit {index}: refused: {e}"))?;
        params[j] = x as f32;
    }
    let m = Material {
        kind,
        params,
        table: None,
    };
    let model = m
        .model()
        .map_err(|e| anyhow!("{file}: fit {index}: refused: {e}"))?;
    match model.energy_bound() {
        _ if !warn => {}
        Some(b) if b <= 1.0 => {}
        Some(b) => eprintln!(
            "warning: {file}: fit {index} ({name}): energy bound {b} > 1, conservation not guaranteed"
        ),
        None => eprintln!("warning: {file}: fit {index} ({name}): the model has no energy bound"),
    }
    Ok(m)
}

/// Maximum relative error of a table against the exact f64 model over a regular grid of
/// zeniths up to `TABLE_MAX_ZENITH_DEG` (46 x 46) and azimuths (37), where the exact value
/// is above `F32_FLOOR_OF_MAX` of its maximum. Returns (max, points).
fn table_error(
    p: brdf_core::SixParams<f32>,
    p64: brdf_core::SixParams<f64>,
    bytes: &[u8],
) -> Result<(f64, usize)> {
    use brdf_core::table::{table_accuracy, SixTable};
    let table = SixTable::new(p, bytes).map_err(|e| anyhow!("{e}"))?;
    let exact = brdf_core::SixParam::new(p64).map_err(|e| anyhow!("{e}"))?;
    let zmax = TABLE_MAX_ZENITH_DEG.to_radians();
    let grid = (0..46 * 46 * 37).map(|n| {
        let (i, j, k) = (n / (46 * 37), n / 37 % 46, n % 37);
        let (ti, tr) = (zmax * i as f64 / 45.0, zmax * j as f64 / 45.0);
        let phi = std::f64::consts::PI * k as f64 / 36.0;
        [ti.cos() as f32, tr.cos() as f32, phi.cos() as f32]
    });
    let a = table_accuracy(&table, &exact, grid);
    Ok((a.max, a.n))
}

/// Gives a six-parameter material `nodes`-node tables built from its f32 parameters (the
/// device checks the nodes against those). Returns the node bytes and the measured maximum
/// relative error of the table against the exact model with the points it was taken over.
pub(crate) fn add_tables(m: &mut Material, nodes: usize) -> Result<(Vec<u8>, f64, usize)> {
    if !(MIN_TABLE_NODES..=MAX_TABLE_NODES).contains(&nodes) {
        bail!("{nodes} table nodes: outside {MIN_TABLE_NODES}..={MAX_TABLE_NODES}");
    }
    let p = m
        .six_params()
        .ok_or_else(|| anyhow!("tables exist for the six-parameter model only"))?;
    let p64 = p.widen();
    let mut bytes = vec![0u8; table_len(nodes)];
    fill_six_table(&p64, nodes, &mut bytes).map_err(|e| anyhow!("{e}"))?;
    let (worst, n) = table_error(p, p64, &bytes)?;
    m.table = Some(TableRef {
        nodes: nodes as u16,
        offset: 0,
    });
    Ok((bytes, worst, n))
}

/// Encodes `materials` (with `tables[i]` for those that have tables) and writes the blob.
pub(crate) fn write_blob(
    materials: heapless::Vec<Material, MAX_MATERIALS>,
    tables: &[Option<Vec<u8>>],
    sequence: u32,
    output: &std::path::Path,
) -> Result<()> {
    let blob = Blob { sequence, materials };
    if blob.encoded_len() > MAX_BLOB_LEN {
        bail!(
            "the blob would be {} bytes, more than a slot's {MAX_BLOB_LEN}: use fewer materials or fewer table nodes",
            blob.encoded_len()
        );
    }
    let refs: Vec<Option<&[u8]>> = tables.iter().map(|t| t.as_deref()).collect();
    let mut buf = [0u8; MAX_BLOB_LEN];
    let n = blob
        .encode_with_tables(&refs, &mut buf)
        .map_err(|e| anyhow!("{e}"))?;
    std::fs::write(output, &buf[..n]).with_context(|| format!("cannot write {}", output.display()))?;
    eprintln!(
        "wrote {} ({} bytes, {} materials, sequence {}, CRC {:#010x})",
        output.display(),
        n,
        blob.materials.len(),
        sequence,
        brdf_wire::blob::blob_crc(&buf[..n])
    );
    Ok(())
}

impl PackCmd {
    pub fn run(self) -> Result<()> {
        let mut materials: heapless::Vec<Material, MAX_MATERIALS> = heapless::Vec::new();
        // Where each material came from, for messages.
        let mut origin: Vec<String> = Vec::new();
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
                if materials.push(material(&file, i, f, true)?).is_err() {
                    bail!("more than {MAX_MATERIALS} materials: a blob holds at most {MAX_MATERIALS}");
                }
                origin.push(format!("{file}: fit {i}"));
            }
        }
        let mut tables: Vec<Option<Vec<u8>>> = vec![None; materials.len()];

        if let Some(nodes) = self.table_nodes {
            if !(MIN_TABLE_NODES..=MAX_TABLE_NODES).contains(&nodes) {
                bail!("--table-nodes {nodes}: outside {MIN_TABLE_NODES}..={MAX_TABLE_NODES}");
            }
            for (i, (m, t)) in materials.iter_mut().zip(&mut tables).enumerate() {
                if m.six_params().is_none() {
                    continue;
                }
                let (bytes, worst, n) = add_tables(m, nodes)
                    .with_context(|| format!("{}: material {i}: {nodes}-node tables", origin[i]))?;
                eprintln!(
                    "material {i}: {nodes}-node tables, measured max relative error {worst:.2e} over {n} \
                     directions up to {TABLE_MAX_ZENITH_DEG} degrees zenith"
                );
                let bound = TABLE_MAX_REL.iter().find(|t| t.0 == nodes).map(|t| t.1);
                if bound.is_some_and(|b| worst > b) {
                    eprintln!(
                        "warning: that exceeds the {:e} promised for parameters in the paper's range: \
                         `brdf check` will fail; use more nodes",
                        bound.unwrap_or(0.0)
                    );
                }
                *t = Some(bytes);
            }
            match TABLE_MAX_REL.iter().find(|t| t.0 == nodes) {
                Some((_, e)) => eprintln!(
                    "tables of {nodes} nodes: promised max relative error {e:e} up to {TABLE_MAX_ZENITH_DEG} \
                     degrees zenith (parameters in the paper's range)"
                ),
                None => eprintln!(
                    "note: {nodes} nodes has no promised bound (sizes with one: {:?}); `brdf check` \
                     reports such materials without judging them",
                    TABLE_MAX_REL.map(|t| t.0)
                ),
            }
        }
        write_blob(materials, &tables, self.sequence, &self.output)?;
        Ok(())
    }
}
