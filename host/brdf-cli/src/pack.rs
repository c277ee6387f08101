//! `brdf pack`: a parameter blob from fit results.

use std::path::PathBuf;

use anyhow::Result;
use brdf_core::table::{MAX_TABLE_NODES, MIN_TABLE_NODES};
use brdf_fit::pack::{pack, FitSource, PackOptions};
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
        crate::common::not_an_input("-o", &self.output, self.fits.iter().map(|p| p.as_path()))?;
        let sources: Vec<FitSource> = self.fits.iter().map(|p| FitSource::File(p)).collect();
        let options = PackOptions {
            sequence: self.sequence,
            table_nodes: self.table_nodes,
        };
        let packed = pack(&sources, &options, |n| eprintln_lossy!("{}", n.text))?;
        write_blob(&packed, &self.output)
    }
}
