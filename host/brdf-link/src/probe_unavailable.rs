//! Stand-ins for [`ProbeRtt`] and [`ProbeTarget`] in a build without the `probe` feature:
//! opening one fails with the command that builds the probe support in, so `brdf flash` and
//! `--probe` say what to do instead of being absent. Neither type can be constructed.

use std::convert::Infallible;
use std::time::Duration;

use crate::flash::{FlashError, SlotTarget};
use crate::{LinkError, Transport};

/// Why a debug probe cannot be used by this build, and how to get one that can.
pub const NOT_BUILT: &str = "this brdf was built without debug-probe support (probe-rs); rebuild it \
     with the `probe` feature: `cargo build --release -p brdf-cli --features probe` (or \
     `cargo install --path host/brdf-cli --features probe`)";

/// A board's RTT channels; unavailable in this build.
#[derive(Debug)]
pub struct ProbeRtt(Infallible);

impl ProbeRtt {
    /// Always fails: see [`NOT_BUILT`].
    pub fn open(_chip: &str, _selector: Option<&str>, _timeout: Duration) -> Result<ProbeRtt, LinkError> {
        Err(LinkError::Open(NOT_BUILT.into()))
    }
}

impl Transport for ProbeRtt {
    fn send(&mut self, _: &[u8]) -> std::io::Result<()> {
        match self.0 {}
    }
    fn recv(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
        match self.0 {}
    }
}

/// A board's flash through a probe; unavailable in this build.
#[derive(Debug)]
pub struct ProbeTarget(Infallible);

impl ProbeTarget {
    /// Always fails: see [`NOT_BUILT`].
    pub fn open(_chip: &str, _selector: Option<&str>) -> Result<ProbeTarget, FlashError> {
        Err(FlashError::Target(NOT_BUILT.into()))
    }
}

impl SlotTarget for ProbeTarget {
    fn read(&mut self, _: u64, _: &mut [u8]) -> Result<(), FlashError> {
        match self.0 {}
    }
    fn program(&mut self, _: u64, _: &[u8]) -> Result<(), FlashError> {
        match self.0 {}
    }
    fn reset(&mut self) -> Result<(), FlashError> {
        match self.0 {}
    }
}
