//! The device arguments every subcommand that talks to a device shares (`check`, `query`),
//! and where the firmware is.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_link::probe::ProbeRtt;
use brdf_link::serial::Serial;
use brdf_link::{Link, Qemu, Transport};
use brdf_wire::blob::Blob;
use clap::Args;

use crate::common::parse_seconds;

/// A link over whichever transport the user chose.
pub type Device = Link<Box<dyn Transport>>;

/// Which device to talk to, and what to load into it first.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("transport").required(true).args(["qemu", "serial", "probe"])))]
pub struct DeviceArgs {
    /// Run the firmware under QEMU (`--elf`, default: the release build of firmware/, under
    /// $CARGO_TARGET_DIR when that is set).
    #[arg(long)]
    qemu: bool,
    /// A board's UART, e.g. /dev/ttyUSB0 (firmware built with `--features hardware`).
    #[arg(long, value_name = "PORT")]
    serial: Option<String>,
    /// Baud rate for --serial.
    #[arg(long, default_value_t = 115_200, value_parser = clap::value_parser!(u32).range(1..))]
    baud: u32,
    /// A board on a debug probe, frames over RTT (firmware built with
    /// `--features rtt-port`): the probe as `VID:PID[:SERIAL]`, or `auto` for the only one.
    #[arg(long, value_name = "PROBE")]
    probe: Option<String>,
    /// The chip behind --probe (a probe-rs target name).
    #[arg(long, default_value = "STM32F407VGTx")]
    chip: String,
    /// Seconds the device may stay silent: QEMU's first answer after it starts, and each
    /// reply (a FIT sends progress every few seconds). Above 0, at most 86,400.
    #[arg(long, default_value = "30", value_parser = parse_seconds)]
    timeout: std::time::Duration,
    /// Firmware ELF for --qemu (default: the release build in firmware/).
    #[arg(long)]
    elf: Option<PathBuf>,
    /// LOAD this parameter blob first (default: whatever the device runs, which for a fresh
    /// QEMU is the firmware's built-in Table 1).
    #[arg(long)]
    blob: Option<PathBuf>,
}

/// A blob loaded with `--blob`: decoded, its CRC and its bytes.
pub type LoadedBlob = (Blob, u32, Vec<u8>);

impl DeviceArgs {
    /// Opens the transport, LOADs `--blob` if given, and returns the link with that blob and
    /// its CRC.
    pub fn connect(&self) -> Result<(Device, Option<LoadedBlob>)> {
        let timeout = self.timeout;
        let transport: Box<dyn Transport> = if self.qemu {
            let elf = self.elf.clone().unwrap_or_else(default_elf);
            Box::new(Qemu::spawn_with(&elf, None, timeout)?)
        } else if let Some(port) = &self.serial {
            Box::new(Serial::open(port, self.baud, timeout)?)
        } else if let Some(probe) = &self.probe {
            let selector = (probe != "auto").then_some(probe.as_str());
            Box::new(ProbeRtt::open(&self.chip, selector, timeout)?)
        } else {
            bail!("choose a device: --qemu, --serial PORT or --probe PROBE");
        };
        let mut link = Link::new(transport);
        let loaded = match &self.blob {
            Some(path) => {
                let bytes = brdf_fit::data::read_input_bytes(path)
                    .with_context(|| format!("cannot read {}", path.display()))?;
                let blob = Blob::decode(&bytes).map_err(|e| anyhow!("{}: {e}", path.display()))?;
                link.load(&bytes)
                    .with_context(|| format!("the device refused {}", path.display()))?;
                Some((blob, brdf_wire::blob::blob_crc(&bytes), bytes))
            }
            None => None,
        };
        Ok((link, loaded))
    }
}

impl DeviceArgs {
    /// The blob checked against: `--blob`'s file, or the built-in Table 1.
    pub fn blob_name(&self) -> String {
        self.blob
            .as_ref()
            .map_or("the built-in Table 1".into(), |p| p.display().to_string())
    }
}

/// Default firmware: the release build of this checkout's firmware workspace, where `cargo
/// build` puts it (`$CARGO_TARGET_DIR` honoured; `brdf_link::firmware::qemu_elf`).
pub fn default_elf() -> PathBuf {
    brdf_link::firmware::qemu_elf("brdf-fw")
}
