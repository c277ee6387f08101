//! A board on a debug probe, through probe-rs: the frames over RTT ([`ProbeRtt`]) and the
//! parameter slots written with the target's flash algorithm ([`ProbeTarget`]).
//!
//! The firmware's `hardware` build with the `rtt-port` feature serves frames on RTT up
//! channel 1 and down channel 0 (both named `brdf`); up channel 0 carries its defmt log.

use std::time::{Duration, Instant};

use probe_rs::flashing::DownloadOptions;
use probe_rs::probe::list::Lister;
use probe_rs::rtt::Rtt;
use probe_rs::{MemoryInterface, Permissions, Session};

use crate::flash::{FlashError, SlotTarget};
use crate::{LinkError, Transport};

/// Opens the probe `selector` (`VID:PID` or `VID:PID:SERIAL`, as `probe-rs list` prints
/// them), or the only probe attached, and attaches to `chip` (e.g. `STM32F407VGTx`).
pub fn attach(chip: &str, selector: Option<&str>) -> Result<Session, String> {
    let lister = Lister::new();
    let probe = match selector {
        Some(s) => {
            let sel: probe_rs::probe::DebugProbeSelector =
                s.parse().map_err(|e| format!("probe selector `{s}`: {e}"))?;
            lister.open(sel).map_err(|e| format!("probe {s}: {e}"))?
        }
        None => {
            let probes = lister.list_all();
            match probes.as_slice() {
                [one] => one.open().map_err(|e| format!("probe {one}: {e}"))?,
                [] => return Err("no debug probe found".into()),
                many => {
                    let names: Vec<String> = many.iter().map(|p| p.to_string()).collect();
                    return Err(format!(
                        "{} probes found, choose one with --probe: {}",
                        many.len(),
                        names.join(", ")
                    ));
                }
            }
        }
    };
    probe
        .attach(chip, Permissions::default())
        .map_err(|e| format!("attach to {chip}: {e}"))
}

/// Frames over RTT: requests to down channel 0, replies from up channel 1.
pub struct ProbeRtt {
    session: Session,
    rtt: Rtt,
    timeout: Duration,
}

impl std::fmt::Debug for ProbeRtt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProbeRtt").finish()
    }
}

/// RTT up channel of the replies.
pub const RTT_UP: usize = 1;
/// RTT down channel of the requests.
pub const RTT_DOWN: usize = 0;

impl ProbeRtt {
    /// Attaches to `chip` through the probe and finds the firmware's RTT control block.
    pub fn open(chip: &str, selector: Option<&str>, timeout: Duration) -> Result<ProbeRtt, LinkError> {
        let mut session = attach(chip, selector).map_err(LinkError::Open)?;
        let rtt = {
            let mut core = session
                .core(0)
                .map_err(|e| LinkError::Open(format!("core 0: {e}")))?;
            Rtt::attach(&mut core).map_err(|e| LinkError::Open(format!("RTT: {e} (is brdf-fw running?)")))?
        };
        let mut link = ProbeRtt {
            session,
            rtt,
            timeout,
        };
        if link.rtt.up_channel(RTT_UP).is_none() || link.rtt.down_channel(RTT_DOWN).is_none() {
            return Err(LinkError::Open(
                "the firmware has no `brdf` RTT channels (build it with --features hardware,rtt-port)".into(),
            ));
        }
        let _ = link.session.core(0);
        Ok(link)
    }
}

fn io(e: impl std::fmt::Display) -> std::io::Error {
    std::io::Error::other(e.to_string())
}

impl Transport for ProbeRtt {
    fn send(&mut self, mut bytes: &[u8]) -> std::io::Result<()> {
        let start = Instant::now();
        let mut core = self.session.core(0).map_err(io)?;
        let down = self
            .rtt
            .down_channel(RTT_DOWN)
            .ok_or_else(|| io("no RTT down channel"))?;
        while !bytes.is_empty() {
            let n = down.write(&mut core, bytes).map_err(io)?;
            bytes = &bytes[n..];
            if n == 0 {
                if start.elapsed() > self.timeout {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::TimedOut,
                        "RTT down channel full",
                    ));
                }
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let start = Instant::now();
        let mut core = self.session.core(0).map_err(io)?;
        let up = self
            .rtt
            .up_channel(RTT_UP)
            .ok_or_else(|| io("no RTT up channel"))?;
        loop {
            let n = up.read(&mut core, buf).map_err(io)?;
            if n > 0 {
                return Ok(n);
            }
            if start.elapsed() > self.timeout {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::TimedOut,
                    "no reply on RTT",
                ));
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    }
}

/// The device's flash through probe-rs: reads over the debug port, writes with the chip's
/// flash algorithm (erasing the sectors it covers, verifying), resets through the core.
pub struct ProbeTarget {
    session: Session,
}

impl std::fmt::Debug for ProbeTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProbeTarget").finish()
    }
}

impl ProbeTarget {
    /// Attaches to `chip` through the probe.
    pub fn open(chip: &str, selector: Option<&str>) -> Result<ProbeTarget, FlashError> {
        attach(chip, selector)
            .map(|session| ProbeTarget { session })
            .map_err(FlashError::Target)
    }
}

fn target(e: impl std::fmt::Display) -> FlashError {
    FlashError::Target(e.to_string())
}

impl SlotTarget for ProbeTarget {
    fn read(&mut self, address: u64, buf: &mut [u8]) -> Result<(), FlashError> {
        let mut core = self.session.core(0).map_err(target)?;
        core.read_8(address, buf).map_err(target)
    }

    fn program(&mut self, address: u64, data: &[u8]) -> Result<(), FlashError> {
        let mut loader = self.session.target().flash_loader();
        loader.add_data(address, data).map_err(target)?;
        let mut options = DownloadOptions::default();
        options.verify = true;
        loader.commit(&mut self.session, options).map_err(target)
    }

    fn reset(&mut self) -> Result<(), FlashError> {
        let mut core = self.session.core(0).map_err(target)?;
        core.reset().map_err(target)
    }
}
