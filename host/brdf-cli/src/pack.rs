//! `brdf pack`: a parameter blob from fit results.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::table::{promise_accuracy, table_len, SixTable, TableError, MAX_TABLE_NODES, MIN_TABLE_NODES};
use brdf_core::tolerance::{table_max_rel, TABLE_MAX_REL, TABLE_MAX_ZENITH_DEG};
use brdf_fit::report::FittedModel;
use brdf_wire::blob::{Material, MAX_MATERIALS};
use clap::Args;

use crate::common::write_blob;

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

impl PackCmd {
    pub fn run(self) -> Result<()> {
        let mut materials: heapless::Vec<Material, MAX_MATERIALS> = heapless::Vec::new();
        // Where each material came from, for messages.
        let mut origin_of: Vec<String> = Vec::new();
        for path in &self.fits {
            let file = path.display().to_string();
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {file}"))?;
            for (i, r) in FittedModel::from_json(&text, &file)?.iter().enumerate() {
                let origin = format!("{file}: fit {i}");
                let params = r
                    .params_array()
                    .map_err(|p| anyhow!("{origin}: no parameter `{p}`"))?;
                // The range is checked on the value as written and again (in the model) on
                // its f32 rounding; both are exact at the bounds (brdf_core::ranges).
                let m =
                    Material::from_params(r.model, &params).map_err(|e| anyhow!("{origin}: refused: {e}"))?;
                let name = r.model.name();
                match m
                    .model()
                    .map_err(|e| anyhow!("{origin}: refused: {e}"))?
                    .energy_bound()
                {
                    Some(b) if b <= 1.0 => {}
                    Some(b) => eprintln!(
                        "warning: {origin} ({name}): energy bound {b} > 1, conservation not guaranteed"
                    ),
                    None => eprintln!("warning: {origin} ({name}): the model has no energy bound"),
                }
                if materials.push(m).is_err() {
                    bail!("more than {MAX_MATERIALS} materials: a blob holds at most {MAX_MATERIALS}");
                }
                origin_of.push(origin);
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
                let mut bytes = vec![0u8; table_len(nodes)];
                let mut build = || -> Result<_, TableError> {
                    m.tabulate(nodes, &mut bytes)?;
                    let p = m.six_params().ok_or(TableError::Model(m.kind))?;
                    promise_accuracy(&SixTable::new(p, &bytes)?)
                };
                let acc = build()
                    .map_err(|e| anyhow!("{}: material {i}: {nodes}-node tables: {e}", origin_of[i]))?;
                let (worst, n) = (acc.max, acc.n);
                eprintln!(
                    "material {i}: {nodes}-node tables, measured max relative error {worst:.2e} over {n} \
                     directions up to {TABLE_MAX_ZENITH_DEG} degrees zenith"
                );
                let bound = table_max_rel(nodes);
                if bound.is_some_and(|b| worst > b) {
                    eprintln!(
                        "warning: that exceeds the {:e} promised for parameters in the paper's range: \
                         `brdf check` will fail; use more nodes",
                        bound.unwrap_or(0.0)
                    );
                }
                *t = Some(bytes);
            }
            match table_max_rel(nodes) {
                Some(e) => eprintln!(
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
