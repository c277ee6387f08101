//! `brdf import`: a measurement file in another convention to the canonical CSV.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use brdf_fit::import::{import, write_canonical, Channel, Format};
use clap::{Args, ValueEnum};

/// Source format on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    /// Cornell PCG ASTM E1392 text (`*.astm`, radians, specular at phi_s = 180 deg, R,G,B).
    Cornell,
    /// NIST PTFE CSV (Germer 2017: signed thetai, specular at phir = 0, lambda in um).
    Nist,
    /// MERL in-plane slice in the lumos-sat layout (zenith and azimuth names swapped).
    MerlInplane,
}

impl From<FormatArg> for Format {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Cornell => Format::Cornell,
            FormatArg::Nist => Format::Nist,
            FormatArg::MerlInplane => Format::MerlInPlane,
        }
    }
}

/// Colour channel of Cornell RGB files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ChannelArg {
    /// Red.
    R,
    /// Green.
    G,
    /// Blue.
    B,
}

impl From<ChannelArg> for Channel {
    fn from(c: ChannelArg) -> Self {
        match c {
            ChannelArg::R => Channel::R,
            ChannelArg::G => Channel::G,
            ChannelArg::B => Channel::B,
        }
    }
}

/// Convert a measurement file to the canonical CSV (theta_i,theta_r,phi,brdf in degrees,
/// phi = 180 on the mirror side; plus `wavelength` for multi-wavelength files). Rejected rows
/// (negative or zero BRDF, zenith >= 90 deg) are listed on standard error with their lines.
#[derive(Debug, Args)]
pub struct ImportCmd {
    /// Source format.
    #[arg(value_enum)]
    format: FormatArg,
    /// Source file.
    input: PathBuf,
    /// Output CSV (standard output if omitted).
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
    /// Colour channel (cornell only).
    #[arg(long, value_enum, ignore_case = true, default_value_t = ChannelArg::R)]
    channel: ChannelArg,
}

/// Imports and lists the rejects on standard error.
pub fn import_reporting(path: &Path, format: Format, channel: Channel) -> Result<brdf_fit::import::Imported> {
    let imp = import(path, format, channel).with_context(|| format!("cannot import {}", path.display()))?;
    for r in &imp.rejects {
        eprintln!("{}: rejected line {}: {}", path.display(), r.line, r.reason);
    }
    eprintln!(
        "{}: {} rows in, {} points out, {} rejected",
        path.display(),
        imp.rows_in,
        imp.points(),
        imp.rejects.len()
    );
    Ok(imp)
}

impl ImportCmd {
    pub fn run(self) -> Result<()> {
        let imp = import_reporting(&self.input, self.format.into(), self.channel.into())?;
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
