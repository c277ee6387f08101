//! Talking to a BRDF device: a byte transport behind a small trait, and [`Link`], which
//! frames requests, pairs replies by tag and skips the ERROR replies the device sends for
//! frames it could not read.
//!
//! Transports: QEMU ([`Qemu`]: `qemu-system-arm` runs the firmware ELF on the `mps2-an386`
//! board with UART0 connected to a TCP port this process listens on, in a working directory
//! that holds the device's flash image, with the firmware's defmt log captured from its
//! semihosting output, decoded by [`decode_defmt`]); a serial port ([`serial::Serial`]); a
//! debug probe's RTT channels ([`probe::ProbeRtt`], with the `probe` feature). [`flash`]
//! writes parameter blobs into a device's flash slots through a probe.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

pub mod flash;
#[cfg(feature = "probe")]
pub mod probe;
#[cfg(not(feature = "probe"))]
#[path = "probe_unavailable.rs"]
pub mod probe;
pub mod serial;

use brdf_core::ModelKind;
use brdf_wire::frame::{
    encode_request, parse_response, values, ErrorCode, FrameReader, Input, Request, Response, MAX_BATCH,
    MAX_FRAME,
};

/// Why talking to the device failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
    /// QEMU could not be started.
    #[error("cannot start qemu-system-arm (is it installed?): {0}")]
    QemuMissing(std::io::Error),
    /// A serial port or probe could not be opened.
    #[error("{0}")]
    Open(String),
    /// The firmware ELF does not exist.
    #[error("firmware {0} not found: build it with `cd firmware && cargo build --release -p brdf-fw`")]
    ElfMissing(PathBuf),
    /// I/O on the link.
    #[error("link: {0}")]
    Io(#[from] std::io::Error),
    /// The device answered with an error code.
    #[error("device error: {0:?}")]
    Device(ErrorCode),
    /// The device sent something that is not a valid reply.
    #[error("unexpected reply: {0}")]
    Protocol(String),
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

/// The firmware under QEMU, UART0 over a loopback TCP socket. Dropping it stops QEMU.
pub struct Qemu {
    child: Child,
    stream: TcpStream,
    log: Arc<Mutex<Vec<u8>>>,
    reader: Option<std::thread::JoinHandle<()>>,
    // A private working directory (removed on drop) when none was given.
    _dir: Option<tempfile::TempDir>,
}

impl std::fmt::Debug for Qemu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Qemu").field("pid", &self.child.id()).finish()
    }
}

/// File in QEMU's working directory holding the two flash slots (see `firmware/README.md`).
pub const FLASH_IMAGE: &str = "brdf-flash.bin";

impl Qemu {
    /// Starts `qemu-system-arm` with `elf` in a fresh private directory (erased flash) and
    /// waits for its UART to connect.
    pub fn spawn(elf: &Path) -> Result<Qemu, LinkError> {
        let dir = tempfile::tempdir()?;
        let mut q = Qemu::spawn_in(elf, dir.path())?;
        q._dir = Some(dir);
        Ok(q)
    }

    /// Starts `qemu-system-arm` with `elf` in `dir`, whose [`FLASH_IMAGE`] (created erased if
    /// missing) is the device's flash: a restart in the same directory keeps what was
    /// committed.
    pub fn spawn_in(elf: &Path, dir: &Path) -> Result<Qemu, LinkError> {
        if !elf.is_file() {
            return Err(LinkError::ElfMissing(elf.to_owned()));
        }
        let elf = elf.canonicalize()?;
        let listener = TcpListener::bind("127.0.0.1:0")?;
        let port = listener.local_addr()?.port();
        let mut child = qemu_command()
            .arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port},nodelay=on"))
            .arg("-kernel")
            .arg(&elf)
            .current_dir(dir)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(LinkError::QemuMissing)?;
        let log = Arc::new(Mutex::new(Vec::new()));
        let reader = child.stdout.take().map(|mut out| {
            let log = Arc::clone(&log);
            std::thread::spawn(move || {
                let mut buf = [0u8; 4096];
                while let Ok(n) = out.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    if let Ok(mut l) = log.lock() {
                        l.extend_from_slice(&buf[..n]);
                    }
                }
            })
        });
        let (stream, _) = listener.accept()?;
        stream.set_nodelay(true)?;
        stream.set_read_timeout(Some(Duration::from_secs(30)))?;
        Ok(Qemu {
            child,
            stream,
            log,
            reader,
            _dir: None,
        })
    }

    /// The firmware's log output (defmt frames) so far.
    pub fn log(&self) -> Vec<u8> {
        self.log.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// Stops QEMU (as a power cut would) and returns the complete log output.
    pub fn stop(mut self) -> Vec<u8> {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(r) = self.reader.take() {
            let _ = r.join();
        }
        self.log()
    }
}

/// `qemu-system-arm` for the MPS2-AN386 (Cortex-M4F) with semihosting, no display or monitor.
pub fn qemu_command() -> Command {
    let mut c = Command::new("qemu-system-arm");
    c.args([
        "-machine",
        "mps2-an386",
        "-cpu",
        "cortex-m4",
        "-nographic",
        "-monitor",
        "none",
    ])
    .args(["-semihosting-config", "enable=on,target=native"]);
    c
}

/// Runs a firmware measurement program (`brdf-fw`'s `cost`: lines
/// `path N: NAME : COUNT instructions`) under QEMU with `-icount shift=0`, where counts are
/// exact, and returns each (NAME, COUNT).
pub fn instruction_counts(elf: &Path) -> Result<Vec<(String, f64)>, LinkError> {
    if !elf.is_file() {
        return Err(LinkError::ElfMissing(elf.to_owned()));
    }
    let out = qemu_command()
        .args(["-icount", "shift=0", "-kernel"])
        .arg(elf)
        .output()
        .map_err(LinkError::QemuMissing)?;
    if !out.status.success() {
        return Err(LinkError::Protocol(format!(
            "{} failed under QEMU",
            elf.display()
        )));
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let (_, rest) = l.split_once(": ")?;
            let (name, count) = rest.split_once(" : ")?;
            Some((
                name.to_string(),
                count.trim_end_matches(" instructions").parse().ok()?,
            ))
        })
        .collect())
}

/// Decodes a defmt byte stream with the tables of the firmware `elf`: one line per log
/// frame, `LEVEL message` (no timestamps). A trailing partial frame is ignored.
pub fn decode_defmt(elf: &Path, bytes: &[u8]) -> Result<Vec<String>, LinkError> {
    let data = std::fs::read(elf).map_err(|_| LinkError::ElfMissing(elf.to_owned()))?;
    let table = defmt_decoder::Table::parse(&data)
        .map_err(|e| LinkError::Protocol(format!("{}: defmt tables: {e}", elf.display())))?
        .ok_or_else(|| LinkError::Protocol(format!("{}: no defmt data", elf.display())))?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(bytes);
    let mut lines = Vec::new();
    loop {
        match decoder.decode() {
            Ok(frame) => {
                let level = frame.level().map_or("PRINT", |l| match l.as_str() {
                    "trace" => "TRACE",
                    "debug" => "DEBUG",
                    "info" => "INFO",
                    "warn" => "WARN",
                    _ => "ERROR",
                });
                lines.push(format!("{level} {}", frame.display_message()));
            }
            Err(defmt_decoder::DecodeError::UnexpectedEof) => break,
            Err(defmt_decoder::DecodeError::Malformed) => {
                return Err(LinkError::Protocol("malformed defmt frame in the log".into()))
            }
        }
    }
    Ok(lines)
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(r) = self.reader.take() {
            let _ = r.join();
        }
    }
}

impl Transport for Qemu {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.stream.write_all(bytes)
    }
    fn recv(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.stream.read(buf)?;
        if n == 0 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                "device closed the link",
            ));
        }
        Ok(n)
    }
}

/// Requests and replies over a transport.
pub struct Link<T: Transport> {
    transport: T,
    reader: Box<FrameReader<{ MAX_FRAME }>>,
    pending: Vec<u8>,
    pos: usize,
    tag: u8,
    /// ERROR replies to frames the device could not read (tag 0), seen since the last call.
    pub stray_errors: Vec<ErrorCode>,
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
        }
    }

    /// The transport.
    pub fn transport(&self) -> &T {
        &self.transport
    }

    /// Ends the link, returning the transport.
    pub fn into_transport(self) -> T {
        self.transport
    }

    /// Sends raw bytes (for tests of the device's robustness).
    pub fn send_raw(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        Ok(self.transport.send(bytes)?)
    }

    /// Sends `req` and returns the payload of the reply with its tag.
    pub fn request(&mut self, req: &Request<'_>) -> Result<Vec<u8>, LinkError> {
        self.tag = if self.tag == 255 { 1 } else { self.tag + 1 };
        let mut out = vec![0u8; MAX_FRAME];
        let n = encode_request(req, self.tag, &mut out).map_err(LinkError::Device)?;
        self.transport.send(&out[..n])?;
        loop {
            let payload = self.next_reply()?;
            let (tag, resp) = parse_response(&payload).map_err(|e| LinkError::Protocol(format!("{e:?}")))?;
            if tag == self.tag {
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
        let mut out = Vec::with_capacity(xs.len());
        for chunk in xs.chunks(MAX_BATCH) {
            let bytes: Vec<u8> = chunk
                .iter()
                .flat_map(|x| x.iter().flat_map(|v| v.to_le_bytes()))
                .collect();
            let reply = self.request(&Request::EvalBatch {
                material,
                input,
                points: &bytes,
            })?;
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
