//! The CMSDK APB UART of the MPS2 boards (UART0 at 0x4000_4000 on `mps2-an386`): polled,
//! no interrupts.

use core::ptr::{read_volatile, write_volatile};

const DATA: usize = 0x0;
const STATE: usize = 0x4;
const CTRL: usize = 0x8;
const BAUDDIV: usize = 0x10;
const TX_FULL: u32 = 1;
const RX_FULL: u32 = 2;

/// One CMSDK UART.
pub struct Uart {
    base: usize,
}

impl Uart {
    /// UART0 of the MPS2 boards.
    pub const fn uart0() -> Uart {
        Uart { base: 0x4000_4000 }
    }

    fn reg(&self, offset: usize) -> *mut u32 {
        (self.base + offset) as *mut u32
    }

    /// Enables transmitter and receiver (the divider must be at least 16).
    pub fn init(&self) {
        // SAFETY: fixed MMIO registers of the CMSDK UART on this board.
        unsafe {
            write_volatile(self.reg(BAUDDIV), 16);
            write_volatile(self.reg(CTRL), 0b11);
        }
    }

    /// Blocks until a byte arrives.
    pub fn read_byte(&self) -> u8 {
        // SAFETY: as in `init`.
        unsafe {
            while read_volatile(self.reg(STATE)) & RX_FULL == 0 {}
            read_volatile(self.reg(DATA)) as u8
        }
    }

    /// A byte if one has arrived.
    pub fn try_read_byte(&self) -> Option<u8> {
        // SAFETY: as in `init`.
        unsafe {
            (read_volatile(self.reg(STATE)) & RX_FULL != 0).then(|| read_volatile(self.reg(DATA)) as u8)
        }
    }

    /// Sends every byte, waiting while the transmitter is full.
    pub fn write_bytes(&self, bytes: &[u8]) {
        for &b in bytes {
            // SAFETY: as in `init`.
            unsafe {
                while read_volatile(self.reg(STATE)) & TX_FULL != 0 {}
                write_volatile(self.reg(DATA), u32::from(b));
            }
        }
    }
}

impl crate::port::Port for Uart {
    fn read(&mut self) -> u8 {
        self.read_byte()
    }
    fn try_read(&mut self) -> Option<u8> {
        self.try_read_byte()
    }
    fn write_all(&mut self, bytes: &[u8]) {
        self.write_bytes(bytes);
    }
}
