//! Talking to a BRDF device: a byte transport behind a small trait, and [`Link`], which
//! frames requests, pairs replies by tag and skips the ERROR replies the device sends for
//! frames it could not read.
//!
//! Transports: QEMU ([`Qemu`]: `qemu-system-arm` runs the firmware ELF on the `mps2-an386`
//! board with UART0 on one end of a socket pair whose other end only this process holds,
//! in a working directory that holds the device's flash image, with the firmware's defmt log
//! captured from its semihosting output, decoded by [`decode_defmt`]); a serial port
//! ([`serial::Serial`]); a debug probe's RTT channels ([`probe::ProbeRtt`], with the `probe` feature). [`flash`]
//! writes parameter blobs into a device's flash slots through a probe.

use std::path::PathBuf;
use std::time::Duration;

pub mod firmware;
pub mod flash;
#[cfg(feature = "probe")]
pub mod probe;
#[cfg(not(feature = "probe"))]
#[path = "probe_unavailable.rs"]
pub mod probe;
mod qemu;
pub mod serial;

pub use qemu::{
    decode_defmt, instruction_counts, instruction_counts_on, qemu_command, qemu_command_for, Qemu,
    QemuFailure, COUNT_TIMEOUT, FLASH_IMAGE, STDERR_KEPT,
};

use brdf_core::ModelKind;
use brdf_wire::frame::{
    encode_request, parse_response, values, ErrorCode, FrameReader, Input, Request, Response, MAX_BATCH,
    MAX_FRAME,
};

/// Why talking to the device failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// QEMU could not be started (the error and the command line).
    #[error("cannot start qemu-system-arm (is it installed?): {0}; command: {1}")]
    QemuMissing(std::io::Error, String),
    /// A serial port or probe could not be opened.
    #[error("{0}")]
    Open(String),
    /// The firmware ELF does not exist.
    #[error("firmware {0} not found: build it with `cd firmware && cargo build --release -p brdf-fw`")]
    ElfMissing(PathBuf),
    /// QEMU exited, or its firmware did not answer in time.
    #[error("{0}")]
    Qemu(QemuFailure),
    /// I/O on the link.
    #[error("link: {0}")]
    Io(std::io::Error),
    /// The device answered with an error code.
    #[error("device error: {0}")]
    Device(ErrorCode),
    /// The device sent something that is not a valid reply.
    #[error("unexpected reply: {0}")]
    Protocol(String),
}

impl From<std::io::Error> for LinkError {
    /// A [`QemuFailure`] carried by an I/O error (from [`Qemu`]'s transport) keeps its own
    /// variant.
    fn from(e: std::io::Error) -> Self {
        if e.get_ref().is_some_and(|inner| inner.is::<QemuFailure>()) {
            if let Some(Ok(f)) = e.into_inner().map(|inner| inner.downcast::<QemuFailure>()) {
                return LinkError::Qemu(*f);
            }
            return LinkError::Protocol("QEMU failure".into());
        }
        LinkError::Io(e)
    }
}

/// A byte stream to a device.
pub trait Transport {
    /// Sends every byte.
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()>;
    /// Receives at least one byte into `buf`; returns how many.
    fn recv(&mut self, buf: &mut [u8]) -> std::io::Result<usize>;
}

impl<T: Transport + ?Sized> Transport for Box<T> {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        (**self).send(bytes)
    }
    fn recv(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        (**self).recv(buf)
    }
}

/// Default for how long the firmware may stay silent: its first answer after QEMU starts,
/// and each reply after a request (a FIT sends PROGRESS at least every few seconds).
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(30);

/// Requests and replies over a transport.
pub struct Link<T: Transport> {
    transport: T,
    reader: Box<FrameReader<{ MAX_FRAME }>>,
    pending: Vec<u8>,
    pos: usize,
    tag: u8,
    /// ERROR replies to frames the device could not read (tag 0), seen since the last call.
    pub stray_errors: Vec<ErrorCode>,
    /// PROGRESS replies received while waiting for a FIT.
    pub progress_replies: usize,
}

impl<T: Transport> std::fmt::Debug for Link<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Link").field("tag", &self.tag).finish()
    }
}

impl<T: Transport> Link<T> {
    /// A link over `transport`.
    pub fn new(transport: T) -> Self {
        Link {
            transport,
            reader: Box::new(FrameReader::new()),
            pending: Vec::new(),
            pos: 0,
            tag: 0,
            stray_errors: Vec::new(),
            progress_replies: 0,
        }
    }

    /// The transport.
    pub fn transport(&self) -> &T {
        &self.transport
    }

    /// The transport, to change its settings (e.g. [`Qemu::set_timeout`]).
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    /// Ends the link, returning the transport.
    pub fn into_transport(self) -> T {
        self.transport
    }

    /// Sends raw bytes (for tests of the device's robustness).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        Ok(self.transport.send(bytes)?)
    }

    /// Sends `req` with the next tag (1 to 255) without waiting for its reply; returns the
    /// tag. [`Link::request`] is the usual way; this one lets a test overlap requests.
    pub fn send(&mut self, req: &Request<'_>) -> Result<u8, LinkError> {
        self.tag = if self.tag == 255 { 1 } else { self.tag + 1 };
        let mut out = vec![0u8; MAX_FRAME];
        let n = encode_request(req, self.tag, &mut out).map_err(LinkError::Device)?;
        self.transport.send(&out[..n])?;
        Ok(self.tag)
    }

    /// The next reply's payload, whatever its tag.
    pub fn next_payload(&mut self) -> Result<Vec<u8>, LinkError> {
        self.next_reply()
    }

    /// Sends `req` and returns the payload of the reply with its tag (PROGRESS replies to a
    /// FIT are counted in [`Link::progress_replies`] and waited through).
    pub fn request(&mut self, req: &Request<'_>) -> Result<Vec<u8>, LinkError> {
        let sent = self.send(req)?;
        loop {
            let payload = self.next_reply()?;
            let (tag, resp) = parse_response(&payload).map_err(|e| LinkError::Protocol(format!("{e:?}")))?;
            if tag == sent {
                if let Response::Progress { .. } = resp {
                    self.progress_replies += 1;
                    continue;
                }
                return Ok(payload);
            }
            match resp {
                Response::Error(code) if tag == 0 => self.stray_errors.push(code),
                other => return Err(LinkError::Protocol(format!("reply with tag {tag}: {other:?}"))),
            }
        }
    }

    fn next_reply(&mut self) -> Result<Vec<u8>, LinkError> {
        let mut buf = [0u8; 256];
        loop {
            while self.pos < self.pending.len() {
                let b = self.pending[self.pos];
                self.pos += 1;
                match self.reader.push(b) {
                    Some(Ok(())) => return Ok(self.reader.payload().to_vec()),
                    Some(Err(e)) => return Err(LinkError::Protocol(format!("corrupted reply ({e:?})"))),
                    None => {}
                }
            }
            self.pending.clear();
            self.pos = 0;
            let n = self.transport.recv(&mut buf)?;
            self.pending.extend_from_slice(&buf[..n]);
        }
    }

    /// INFO: (build id, blob format version, CRC of the active blob, materials).
    pub fn info(&mut self) -> Result<(u32, u16, u32, u8), LinkError> {
        match parse_response(&self.request(&Request::Info)?).map(|r| r.1) {
            Ok(Response::Info {
                build_id,
                format_version,
                active_crc,
                materials,
            }) => Ok((build_id, format_version, active_crc, materials)),
            Ok(Response::Error(e)) => Err(LinkError::Device(e)),
            other => Err(LinkError::Protocol(format!("{other:?}"))),
        }
    }

    /// Evaluates any number of inputs (sent in batches of [`MAX_BATCH`]).
    pub fn eval(&mut self, material: u8, input: Input, xs: &[[f32; 3]]) -> Result<Vec<f32>, LinkError> {
        self.eval_at(material, input, None, xs)
    }

    /// Evaluates any number of inputs at a wavelength in µm (EVAL_AT; a banded material
    /// answers by its bands there), or without one (EVAL_BATCH).
    pub fn eval_at(
        &mut self,
        material: u8,
        input: Input,
        wavelength: Option<f32>,
        xs: &[[f32; 3]],
    ) -> Result<Vec<f32>, LinkError> {
        let mut out = Vec::with_capacity(xs.len());
        for chunk in xs.chunks(MAX_BATCH) {
            let bytes: Vec<u8> = chunk
                .iter()
                .flat_map(|x| x.iter().flat_map(|v| v.to_le_bytes()))
                .collect();
            let req = match wavelength {
                Some(wavelength) => Request::EvalAt {
                    material,
                    input,
                    wavelength,
                    points: &bytes,
                },
                None => Request::EvalBatch {
                    material,
                    input,
                    points: &bytes,
                },
            };
            let reply = self.request(&req)?;
            match parse_response(&reply).map(|r| r.1) {
                Ok(Response::Values(v)) => out.extend(values(v)),
                Ok(Response::Error(e)) => return Err(LinkError::Device(e)),
                other => return Err(LinkError::Protocol(format!("{other:?}"))),
            }
        }
        Ok(out)
    }

    /// LOAD a blob into the device's RAM; returns the CRC of the now active blob.
    pub fn load(&mut self, blob: &[u8]) -> Result<u32, LinkError> {
        match parse_response(&self.request(&Request::Load(blob))?).map(|r| r.1) {
            Ok(Response::Done(crc)) => Ok(crc),
            Ok(Response::Error(e)) => Err(LinkError::Device(e)),
            other => Err(LinkError::Protocol(format!("{other:?}"))),
        }
    }

    /// COMMIT a blob to the device's inactive flash slot; returns the CRC of the now active
    /// blob.
    pub fn commit(&mut self, blob: &[u8]) -> Result<u32, LinkError> {
        match parse_response(&self.request(&Request::Commit(blob))?).map(|r| r.1) {
            Ok(Response::Done(crc)) => Ok(crc),
            Ok(Response::Error(e)) => Err(LinkError::Device(e)),
            other => Err(LinkError::Protocol(format!("{other:?}"))),
        }
    }

    /// FIT on the device: (parameters, RMS relative error, evaluations).
    pub fn fit(
        &mut self,
        model: ModelKind,
        budget: u32,
        samples: &[[f32; 4]],
    ) -> Result<([f32; 6], f32, u32), LinkError> {
        let bytes: Vec<u8> = samples
            .iter()
            .flat_map(|s| s.iter().flat_map(|v| v.to_le_bytes()))
            .collect();
        match parse_response(&self.request(&Request::Fit {
            model,
            budget,
            samples: &bytes,
        })?)
        .map(|r| r.1)
        {
            Ok(Response::Fitted {
                params,
                rms_rel,
                evals,
                ..
            }) => Ok((params, rms_rel, evals)),
            Ok(Response::Error(e)) => Err(LinkError::Device(e)),
            other => Err(LinkError::Protocol(format!("{other:?}"))),
        }
    }
}
