//! The byte stream the firmware serves frames on: a board's UART, or an RTT channel.

/// A blocking, polled byte stream.
pub trait Port {
    /// Blocks until a byte arrives.
    fn read(&mut self) -> u8;
    /// A byte if one has arrived, without waiting.
    fn try_read(&mut self) -> Option<u8>;
    /// Sends every byte.
    fn write_all(&mut self, bytes: &[u8]);
}
