//! The firmware under QEMU: [`Qemu`] (a [`Transport`]), the commands that start QEMU for a
//! core, instruction counting runs (with a time limit) and the defmt log decoder.

use std::io::{Read, Write};
use std::os::fd::OwnedFd;
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use brdf_wire::frame::{encode_request, parse_response, FrameReader, Request, Response, MAX_FRAME};

use crate::{firmware, LinkError, Transport, DEFAULT_TIMEOUT};

/// What went wrong with a QEMU run: what was seen, QEMU's exit status (if it exited) and
/// standard error, the firmware ELF and the command line.
#[derive(Debug, Clone)]
pub struct QemuFailure {
    /// What the link saw.
    pub what: String,
    /// QEMU's exit status, `None` while it still runs.
    pub status: Option<ExitStatus>,
    /// QEMU's standard error (at most its first [`STDERR_KEPT`] bytes).
    pub stderr: String,
    /// The firmware ELF.
    pub elf: PathBuf,
    /// The command line.
    pub command: String,
}

/// Bytes of QEMU's standard error kept for messages.
pub const STDERR_KEPT: usize = 16 * 1024;

impl std::fmt::Display for QemuFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "firmware {} under QEMU: {}; ", self.elf.display(), self.what)?;
        match self.status {
            Some(s) => write!(f, "QEMU exited ({s})")?,
            None => write!(f, "QEMU is still running")?,
        }
        write!(f, "; command: {}", self.command)?;
        let err = self.stderr.trim();
        if err.is_empty() {
            return write!(f, "; QEMU wrote nothing on standard error");
        }
        // The first lines say what happened (a register dump may follow).
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        write!(
            f,
            "; QEMU's standard error: {}",
            lines[..lines.len().min(4)].join(" / ")
        )?;
        if lines.len() > 4 {
            write!(f, " / ({} more lines)", lines.len() - 4)?;
        }
        Ok(())
    }
}

impl std::error::Error for QemuFailure {}

/// The firmware under QEMU. Its UART0 is one end of a socket pair handed to QEMU as its
/// standard input (`-chardev socket,fd=0`); the other end is this process's, and no other
/// process can reach it: there is no listening socket to connect to first. Dropping it
/// stops QEMU.
pub struct Qemu {
    child: Child,
    stream: UnixStream,
    log: Arc<Mutex<Vec<u8>>>,
    stderr: Arc<Mutex<Vec<u8>>>,
    readers: Vec<std::thread::JoinHandle<()>>,
    elf: PathBuf,
    command: String,
    timeout: Duration,
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

/// Copies everything `from` yields into `into` (at most `cap` bytes kept) until EOF.
fn drain(
    mut from: impl Read + Send + 'static,
    into: Arc<Mutex<Vec<u8>>>,
    cap: usize,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while let Ok(n) = from.read(&mut buf) {
            if n == 0 {
                break;
            }
            if let Ok(mut l) = into.lock() {
                let room = cap.saturating_sub(l.len()).min(n);
                l.extend_from_slice(&buf[..room]);
            }
        }
    })
}

impl Qemu {
    /// Starts `qemu-system-arm` with `elf` in a fresh private directory (erased flash) and
    /// waits, up to [`DEFAULT_TIMEOUT`], for the firmware to answer.
    pub fn spawn(elf: &Path) -> Result<Qemu, LinkError> {
        Qemu::spawn_with(elf, None, DEFAULT_TIMEOUT)
    }

    /// Starts `qemu-system-arm` with `elf` in `dir`, whose [`FLASH_IMAGE`] (created erased if
    /// missing) is the device's flash: a restart in the same directory keeps what was
    /// committed.
    pub fn spawn_in(elf: &Path, dir: &Path) -> Result<Qemu, LinkError> {
        Qemu::spawn_with(elf, Some(dir), DEFAULT_TIMEOUT)
    }

    /// Starts QEMU with `elf` in `dir` (a fresh private directory if `None`) and waits up to
    /// `timeout` for the firmware's first answer (an INFO exchange); `timeout` is then how
    /// long each reply may take. A QEMU that exits, or a firmware that does not answer,
    /// is reported with QEMU's exit status and standard error, the ELF and the command.
    pub fn spawn_with(elf: &Path, dir: Option<&Path>, timeout: Duration) -> Result<Qemu, LinkError> {
        if !elf.is_file() {
            return Err(LinkError::ElfMissing(elf.to_owned()));
        }
        let elf = elf.canonicalize().map_err(LinkError::Io)?;
        let private = match dir {
            Some(_) => None,
            None => Some(tempfile::tempdir().map_err(LinkError::Io)?),
        };
        let workdir = dir
            .or(private.as_ref().map(|d| d.path()))
            .unwrap_or(Path::new("."));
        let (ours, theirs) = UnixStream::pair().map_err(LinkError::Io)?;
        let mut child = {
            // The command (holding QEMU's end of the pair) is dropped right after the spawn,
            // so that QEMU's exit closes the link.
            let mut cmd = qemu_command();
            cmd.args([
                "-chardev",
                "socket,id=uart,fd=0",
                "-serial",
                "chardev:uart",
                "-kernel",
            ])
            .arg(&elf)
            .current_dir(workdir)
            .stdin(Stdio::from(OwnedFd::from(theirs)))
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
            let command = command_line(&cmd);
            let child = cmd
                .spawn()
                .map_err(|e| LinkError::QemuMissing(e, command.clone()))?;
            (child, command)
        };
        let (log, stderr) = (Arc::new(Mutex::new(Vec::new())), Arc::new(Mutex::new(Vec::new())));
        let mut readers = Vec::new();
        if let Some(out) = child.0.stdout.take() {
            readers.push(drain(out, Arc::clone(&log), usize::MAX));
        }
        if let Some(err) = child.0.stderr.take() {
            readers.push(drain(err, Arc::clone(&stderr), STDERR_KEPT));
        }
        let mut q = Qemu {
            child: child.0,
            stream: ours,
            log,
            stderr,
            readers,
            elf,
            command: child.1,
            timeout,
            _dir: private,
        };
        q.handshake()?;
        Ok(q)
    }

    /// One INFO exchange (tag 0): the firmware is running and answers frames.
    fn handshake(&mut self) -> Result<(), LinkError> {
        let mut frame = vec![0u8; MAX_FRAME];
        let n = encode_request(&Request::Info, 0, &mut frame).map_err(LinkError::Device)?;
        self.send(&frame[..n])?;
        let mut reader: FrameReader<64> = FrameReader::new();
        let mut buf = [0u8; 64];
        loop {
            let got = self.recv(&mut buf)?;
            for &b in &buf[..got] {
                match reader.push(b) {
                    Some(Ok(())) => {
                        return match parse_response(reader.payload()) {
                            Ok((0, Response::Info { .. })) => Ok(()),
                            other => Err(self
                                .failure(format!(
                                    "the first reply to INFO is not INFO but {other:?}: not a brdf-fw build?"
                                ))
                                .into()),
                        }
                    }
                    Some(Err(e)) => {
                        return Err(self
                            .failure(format!("a corrupted first reply ({e:?}): not a brdf-fw build?"))
                            .into())
                    }
                    None => {}
                }
            }
        }
    }

    /// How long a reply may take from now on.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// The command line QEMU was started with.
    pub fn command(&self) -> &str {
        &self.command
    }

    /// The firmware's log output (defmt frames) so far.
    pub fn log(&self) -> Vec<u8> {
        self.log.lock().map(|l| l.clone()).unwrap_or_default()
    }

    /// Stops QEMU (as a power cut would) and returns the complete log output.
    pub fn stop(mut self) -> Vec<u8> {
        self.kill();
        self.log()
    }

    fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        for r in self.readers.drain(..) {
            let _ = r.join();
        }
    }

    /// An I/O error carrying a [`QemuFailure`]: gives an exiting QEMU up to two seconds to
    /// finish, so that its status and complete standard error are reported.
    fn failure(&mut self, what: String) -> std::io::Error {
        let deadline = Instant::now() + Duration::from_secs(2);
        let mut status = self.child.try_wait().ok().flatten();
        while status.is_none() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
            status = self.child.try_wait().ok().flatten();
        }
        if status.is_some() {
            // QEMU has exited: its pipes reach EOF, and the readers end.
            for r in self.readers.drain(..) {
                let _ = r.join();
            }
        }
        let stderr = self
            .stderr
            .lock()
            .map(|e| String::from_utf8_lossy(&e).into_owned())
            .unwrap_or_default();
        std::io::Error::other(QemuFailure {
            what,
            status,
            stderr,
            elf: self.elf.clone(),
            command: self.command.clone(),
        })
    }
}

/// The program and its arguments as one line.
fn command_line(cmd: &Command) -> String {
    std::iter::once(cmd.get_program())
        .chain(cmd.get_args())
        .map(|a| a.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ")
}

/// `qemu-system-arm` for the MPS2-AN386 (Cortex-M4F) with semihosting, no display or monitor.
pub fn qemu_command() -> Command {
    qemu_command_for(firmware::Core::M4F)
}

/// `qemu-system-arm` for `core`'s stand-in board with semihosting, no display or monitor.
pub fn qemu_command_for(core: firmware::Core) -> Command {
    let mut c = Command::new("qemu-system-arm");
    c.args(core.qemu_machine())
        .args(["-nographic", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native"]);
    c
}

/// Runs a firmware measurement program (`core-cost`'s `cost`: lines
/// `path N: NAME : COUNT instructions`) on the Cortex-M4F under QEMU with `-icount shift=0`,
/// where counts are exact, and returns each (NAME, COUNT).
pub fn instruction_counts(elf: &Path) -> Result<Vec<(String, f64)>, LinkError> {
    instruction_counts_on(firmware::Core::M4F, elf)
}

/// Longest a counting run may take before it is killed and reported: the cost programs
/// finish in about a second under `-icount shift=0` (the Cortex-M0+'s, the slowest, 0.7 s on a
/// 2-core x86 host), so a run that lasts a minute is hung, not slow.
pub const COUNT_TIMEOUT: Duration = Duration::from_secs(60);

/// [`instruction_counts`] on `core`'s board (`elf` built for its target), killed and
/// reported after [`COUNT_TIMEOUT`].
pub fn instruction_counts_on(core: firmware::Core, elf: &Path) -> Result<Vec<(String, f64)>, LinkError> {
    if !elf.is_file() {
        return Err(LinkError::ElfMissing(elf.to_owned()));
    }
    let mut cmd = qemu_command_for(core);
    cmd.args(["-icount", "shift=0", "-kernel"]).arg(elf);
    let stdout = run_with_timeout(cmd, COUNT_TIMEOUT, &format!("{} under QEMU", elf.display()))?;
    Ok(String::from_utf8_lossy(&stdout)
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

/// Runs `cmd` to completion and returns its standard output; a run that fails, or outlasts
/// `limit` (it is then killed), is an error naming `what`.
fn run_with_timeout(mut cmd: Command, limit: Duration, what: &str) -> Result<Vec<u8>, LinkError> {
    let line = command_line(&cmd);
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| LinkError::QemuMissing(e, line.clone()))?;
    // Drain the pipes while waiting, so a chatty program cannot block on a full pipe.
    let mut out_pipe = child.stdout.take().expect("piped");
    let mut err_pipe = child.stderr.take().expect("piped");
    let out_reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = out_pipe.read_to_end(&mut b);
        b
    });
    let err_reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        let _ = err_pipe.read_to_end(&mut b);
        b
    });
    let deadline = Instant::now() + limit;
    let status = loop {
        if let Some(status) = child.try_wait().map_err(LinkError::Io)? {
            break status;
        }
        if Instant::now() >= deadline {
            let _ = child.kill();
            let _ = child.wait();
            return Err(LinkError::Protocol(format!(
                "{what}: no result after {} s, killed (command: {line})",
                limit.as_secs_f64()
            )));
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let stdout = out_reader.join().unwrap_or_default();
    let stderr = err_reader.join().unwrap_or_default();
    if !status.success() {
        return Err(LinkError::Protocol(format!(
            "{what} failed ({status}): {}",
            String::from_utf8_lossy(&stderr).trim()
        )));
    }
    Ok(stdout)
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
        self.kill();
    }
}

impl Transport for Qemu {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.stream
            .write_all(bytes)
            .map_err(|e| self.failure(format!("cannot send to the firmware's UART ({e})")))
    }
    fn recv(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.stream
            .set_read_timeout(Some(self.timeout.max(Duration::from_millis(1))))?;
        match self.stream.read(buf) {
            Ok(0) => Err(self.failure("the firmware's UART closed".into())),
            Ok(n) => Ok(n),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                Err(self.failure(format!("no reply within {:?}", self.timeout)))
            }
            Err(e) => Err(self.failure(format!("reading the firmware's UART failed ({e})"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Before: a counting run had no time limit, so a hung QEMU hung `brdf bench eval` and
    /// the cost tests for ever.
    #[test]
    fn a_hung_counting_run_is_killed_and_reported() {
        let mut cmd = Command::new("sh");
        cmd.args(["-c", "sleep 30"]);
        let started = Instant::now();
        let err = run_with_timeout(cmd, Duration::from_millis(300), "cost").unwrap_err();
        assert!(
            started.elapsed() < Duration::from_secs(5),
            "{:?}",
            started.elapsed()
        );
        assert!(err.to_string().contains("no result after 0.3 s, killed"), "{err}");
        let mut ok = Command::new("sh");
        ok.args(["-c", "echo 'path 1: x : 5 instructions'"]);
        assert_eq!(
            run_with_timeout(ok, COUNT_TIMEOUT, "cost").unwrap(),
            b"path 1: x : 5 instructions\n"
        );
        let mut failing = Command::new("sh");
        failing.args(["-c", "echo boom >&2; exit 3"]);
        let err = run_with_timeout(failing, COUNT_TIMEOUT, "cost")
            .unwrap_err()
            .to_string();
        assert!(err.contains("boom") && err.contains("failed"), "{err}");
    }
}
