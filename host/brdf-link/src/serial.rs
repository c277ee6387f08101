//! A board's UART through a serial port (USB-serial adapter), with the `serialport` crate.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use crate::{LinkError, Transport};

/// A serial port at a baud rate, 8N1.
pub struct Serial {
    port: Box<dyn serialport::SerialPort>,
    timeout: Duration,
}

impl std::fmt::Debug for Serial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Serial").field("port", &self.port.name()).finish()
    }
}

impl Serial {
    /// Opens `path` (e.g. `/dev/ttyUSB0`) at `baud`; a reply that takes longer than
    /// `timeout` is an error.
    pub fn open(path: &str, baud: u32, timeout: Duration) -> Result<Serial, LinkError> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(100))
            .open()
            .map_err(|e| LinkError::Open(format!("serial port {path}: {e}")))?;
        Ok(Serial { port, timeout })
    }
}

impl Transport for Serial {
    fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn recv(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let start = Instant::now();
        loop {
            match self.port.read(buf) {
                Ok(0) => {}
                Ok(n) => return Ok(n),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => return Err(e),
            }
            if start.elapsed() > self.timeout {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::TimedOut,
                    format!(
                        "no reply on {} within {:?}",
                        self.port.name().unwrap_or_default(),
                        self.timeout
                    ),
                ));
            }
        }
    }
}
