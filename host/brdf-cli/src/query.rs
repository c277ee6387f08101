//! `brdf query`: ask a device for BRDF values.

use std::path::PathBuf;

use anyhow::{bail, Result};
use brdf_link::LinkError;
use brdf_wire::frame::{ErrorCode, Input};
use clap::Args;

use crate::angles::{f32_text, parse_direction, radians, AngleReader, AngleWriter, Chunk};
use crate::device::{Device, DeviceArgs};

/// Ask a device (the firmware under QEMU, a board's UART or a probe) for f_r in 1/sr: one
/// direction with --angles, or every row of a CSV with theta_i,theta_r,phi in degrees. The
/// CSV is read, checked and written exactly as `brdf eval --precision f32` does, so on any
/// file `eval` accepts the two print the same bytes.
#[derive(Debug, Args)]
pub struct QueryCmd {
    #[command(flatten)]
    device: DeviceArgs,
    /// Material id in the active blob.
    #[arg(long, default_value_t = 0)]
    material: u8,
    /// One direction: theta_i,theta_r,phi in degrees.
    #[arg(long, conflicts_with = "csv", allow_hyphen_values = true)]
    angles: Option<String>,
    /// Wavelength in µm (EVAL_AT): a banded (spectral) material answers by its band there, or
    /// the two bands around it blended; it refuses to answer without one. A material without
    /// bands is the same at every wavelength.
    #[arg(long, value_name = "UM", allow_hyphen_values = true)]
    wavelength: Option<f64>,
    /// Name of the output column.
    #[arg(long, default_value = "brdf")]
    output_column: String,
    /// A CSV of directions (header with theta_i, theta_r, phi in degrees; other columns are
    /// passed through unchanged).
    csv: Option<PathBuf>,
}

/// Asks the device for `xs` (radians) at `um` µm; a refusal is reported at the line of the
/// first direction the device refuses on its own (`line(i)` names row `i`), or as the
/// wavelength's when the device refuses it at normal incidence and viewing too.
fn ask(
    link: &mut Device,
    material: u8,
    um: Option<f32>,
    typed: Option<f64>,
    xs: &[[f32; 3]],
    at: impl Fn(usize) -> String,
) -> Result<Vec<f32>> {
    match link.eval_at(material, Input::Angles, um, xs) {
        Ok(v) => Ok(v),
        Err(LinkError::Device(ErrorCode::NeedsWavelength)) => bail!(
            "material {material} is spectral (banded): the device answers it at a wavelength; give --wavelength UM"
        ),
        Err(LinkError::Device(code)) => {
            if let Some((w, typed)) = um.zip(typed) {
                // Refused at normal incidence and viewing too: the wavelength, not a direction.
                if let Err(LinkError::Device(ErrorCode::OutOfDomain)) =
                    link.eval_at(material, Input::Angles, Some(w), &[[0.0; 3]])
                {
                    bail!("--wavelength {typed:?}: the device refused it for material {material} (outside its bands)");
                }
            }
            for (i, x) in xs.iter().enumerate() {
                if let Err(LinkError::Device(code)) =
                    link.eval_at(material, Input::Angles, um, std::slice::from_ref(x))
                {
                    bail!("{}: the device refused this direction ({code:?})", at(i));
                }
            }
            bail!("the device refused a batch ({code:?}) but none of its directions alone")
        }
        Err(e) => Err(e.into()),
    }
}

impl QueryCmd {
    pub fn run(self) -> Result<()> {
        let um = match self.wavelength {
            Some(w) if !brdf_fit::data::is_wavelength(w) => {
                bail!("--wavelength {w:?}: not a wavelength above 0 (µm)")
            }
            // The device holds wavelengths in f32.
            Some(w) if !brdf_fit::data::is_wavelength(f64::from(w as f32)) => {
                bail!("--wavelength {w:?}: beyond what a device holds (an f32 above 0)")
            }
            w => w.map(|w| w as f32),
        };
        match (&self.angles, &self.csv) {
            (Some(a), None) => {
                let texts: Vec<&str> = a.split(',').collect();
                let [ti, tr, phi] = texts[..] else {
                    bail!("--angles: need theta_i,theta_r,phi, got `{a}`");
                };
                let deg = parse_direction("--angles", [ti, tr, phi])?;
                let (mut link, _) = self.device.connect()?;
                let v = ask(
                    &mut link,
                    self.material,
                    um,
                    self.wavelength,
                    &[radians::<f32>(deg)],
                    |_| "--angles".into(),
                )?;
                println!("{}", f32_text(v[0]));
                Ok(())
            }
            (None, Some(path)) => {
                // The file is opened and its header checked before the device is started.
                let mut reader = AngleReader::open(path, &self.output_column)?;
                let (mut link, _) = self.device.connect()?;
                let stdout = std::io::stdout();
                let mut writer = AngleWriter::new(stdout.lock(), &reader, &self.output_column)?;
                let mut chunk = Chunk::default();
                while reader.next_chunk(&mut chunk)? > 0 {
                    let xs: Vec<[f32; 3]> = chunk.degrees().iter().map(|&d| radians::<f32>(d)).collect();
                    let file = reader.file();
                    let values = ask(&mut link, self.material, um, self.wavelength, &xs, |i| {
                        format!("{file}: line {}", chunk.line(i))
                    })?;
                    writer.write_chunk(&chunk, values.into_iter().map(f32_text))?;
                }
                writer.finish()
            }
            _ => bail!("give --angles or a CSV file"),
        }
    }
}
