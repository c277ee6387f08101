//! Measurement formats on the command line (`--format`, `--channel`) and importing with the
//! rejected rows listed: shared by `import` and by every subcommand that reads data.

use std::path::Path;

use anyhow::{Context, Result};
use brdf_fit::import::{import, Channel, Format};
use clap::ValueEnum;

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
