//! `brdf flash`: a parameter blob into a board's inactive flash slot through a debug probe.

use std::path::PathBuf;

use anyhow::{anyhow, Context, Result};
use brdf_link::flash::{flash_blob, SlotMap};
use brdf_link::probe::ProbeTarget;
use brdf_wire::blob::Blob;
use brdf_wire::slots::SLOT_IMAGE_LEN;
use clap::Args;

/// Write a parameter blob (from `brdf pack`) into the board's inactive parameter slot with
/// probe-rs: the slot addresses come from the firmware ELF's symbols, both slots are read,
/// the slot not holding the newest valid blob is erased and written, read back and
/// verified, and the board is reset to boot from it. The blob's sequence number must be
/// above the newest valid slot's. No interruption can leave both slots invalid.
#[derive(Debug, Args)]
pub struct FlashCmd {
    /// The parameter blob.
    blob: PathBuf,
    /// The chip (a probe-rs target name, e.g. STM32F407VGTx).
    #[arg(long)]
    chip: String,
    /// The probe as `VID:PID[:SERIAL]` (default: the only one attached).
    #[arg(long)]
    probe: Option<String>,
    /// The firmware the board runs (default: the `hardware` release build in firmware/).
    #[arg(long)]
    elf: Option<PathBuf>,
    /// Read the slots and print what would be written where, without writing. With no
    /// probe attached, prints the slot addresses and the image size.
    #[arg(long)]
    dry_run: bool,
}

/// Default firmware location of the hardware build in this repository.
fn default_hardware_elf() -> PathBuf {
    brdf_link::firmware::in_repo(brdf_link::firmware::hardware_elf())
}

impl FlashCmd {
    pub fn run(self) -> Result<()> {
        let file = self.blob.display().to_string();
        let bytes =
            brdf_fit::data::read_input_bytes(&self.blob).with_context(|| format!("cannot read {file}"))?;
        let blob = Blob::decode(&bytes).map_err(|e| anyhow!("{file}: {e}"))?;
        let elf = self.elf.clone().unwrap_or_else(default_hardware_elf);
        let map = SlotMap::from_elf(&elf)?;
        println!(
            "{file}: {} bytes, sequence {}, {} materials; {}: slot A at {:#010x}, slot B at {:#010x} ({} bytes each)",
            bytes.len(),
            blob.sequence,
            blob.materials.len(),
            elf.display(),
            map.a,
            map.b,
            map.size
        );
        let mut target = match ProbeTarget::open(&self.chip, self.probe.as_deref()) {
            Ok(t) => t,
            Err(e) if self.dry_run => {
                println!(
                    "dry run without a device ({e}): would write a {}-byte slot image (of at most {SLOT_IMAGE_LEN}) \
                     to whichever slot does not hold the newest valid blob",
                    bytes.len() + 4
                );
                return Ok(());
            }
            Err(e) => return Err(e.into()),
        };
        let plan = flash_blob(&mut target, &map, &bytes, self.dry_run)?;
        println!("{plan}");
        Ok(())
    }
}
