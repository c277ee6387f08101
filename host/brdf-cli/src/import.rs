//! `brdf import`: a measurement file in another convention to the canonical CSV.

use std::path::PathBuf;

use anyhow::{Context, Result};
use brdf_fit::import::write_canonical;
use clap::Args;

use brdf_fit::import::{Channel, Format};

use crate::common::named;
use crate::formats::import_reporting;

/// Convert a measurement file to the canonical CSV (theta_i,theta_r,phi,brdf in degrees,
/// phi = 180 on the mirror side; plus `wavelength` in um for spectral and multi-wavelength
/// files, every band kept unless --band picks one). Readings at or below zero are kept (a
/// dark surface's noise; fits weigh them with a noise floor); rejected rows (zenith >= 90 deg,
/// non-finite values) are listed on standard error with their lines.
#[derive(Debug, Args)]
pub struct ImportCmd {
    /// Source format: cornell, nist, merl-inplane.
    #[arg(value_parser = named::<Format>)]
    format: Format,
    /// Source file.
    input: PathBuf,
    /// Output CSV (standard output if omitted).
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
    /// Colour channel (cornell RGB files only): r, g, b, either case; default r.
    #[arg(long, value_parser = named::<Channel>)]
    channel: Option<Channel>,
    /// One band by its wavelength in um (cornell spectral and nist files; default every band).
    #[arg(long, value_parser = crate::common::parse_positive)]
    band: Option<f64>,
}

impl ImportCmd {
    pub fn run(self) -> Result<()> {
        if let Some(out) = &self.output {
            if crate::common::same_file(&self.input, out) {
                anyhow::bail!("-o {} is the input: it would be overwritten", out.display());
            }
        }
        let pick = brdf_fit::import::pick_for(Some(self.format), self.channel, self.band)
            .map_err(|e| anyhow::anyhow!(e))?;
        let imp = import_reporting(&self.input, self.format, pick)?;
        match &self.output {
            Some(path) => {
                let f = std::fs::File::create(path)
                    .with_context(|| format!("cannot create {}", path.display()))?;
                write_canonical(std::io::BufWriter::new(f), &imp.datasets)
                    .with_context(|| format!("cannot write {}", path.display()))?;
            }
            None => {
                write_canonical(std::io::stdout().lock(), &imp.datasets).context("cannot write output")?
            }
        }
        Ok(())
    }
}
