//! STM32F407 drivers for the `hardware` feature: USART2 (PA2 TX, PA3 RX, 115200 baud from
//! the 16 MHz HSI the chip boots on) and the flash controller for the two slots (sectors 10
//! and 11, 128 KiB each). Register-level, no HAL. They compile in CI; they have not been run
//! on a board here (no hardware is attached to CI).

use crate::flash::{Flash, FlashError};
use brdf_wire::slots::SlotId;
use core::ptr::{read_volatile, write_volatile};

const RCC_AHB1ENR: usize = 0x4002_3830;
const RCC_APB1ENR: usize = 0x4002_3840;
const GPIOA_MODER: usize = 0x4002_0000;
const GPIOA_AFRL: usize = 0x4002_0020;
const USART2: usize = 0x4000_4400;
const SR: usize = 0x00;
const DR: usize = 0x04;
const BRR: usize = 0x08;
const CR1: usize = 0x0C;

fn reg(addr: usize) -> *mut u32 {
    addr as *mut u32
}

/// USART2 on PA2/PA3.
pub struct Usart2;

impl Usart2 {
    /// Clocks GPIOA and USART2, muxes PA2/PA3 to AF7, 115200 8N1 from 16 MHz.
    pub fn init() -> Usart2 {
        // SAFETY: documented STM32F407 registers (RM0090), read-modify-write of our own bits.
        unsafe {
            write_volatile(reg(RCC_AHB1ENR), read_volatile(reg(RCC_AHB1ENR)) | 1);
            write_volatile(reg(RCC_APB1ENR), read_volatile(reg(RCC_APB1ENR)) | (1 << 17));
            let moder = read_volatile(reg(GPIOA_MODER)) & !(0b1111 << 4);
            write_volatile(reg(GPIOA_MODER), moder | (0b1010 << 4));
            let afrl = read_volatile(reg(GPIOA_AFRL)) & !(0xFF << 8);
            write_volatile(reg(GPIOA_AFRL), afrl | (0x77 << 8));
            // 16 MHz / (16 * 8.6875) = 115,108 baud (0.08 % off 115,200).
            write_volatile(reg(USART2 + BRR), (8 << 4) | 11);
            write_volatile(reg(USART2 + CR1), (1 << 13) | (1 << 3) | (1 << 2));
        }
        Usart2
    }
}

impl crate::port::Port for Usart2 {
    fn read(&mut self) -> u8 {
        loop {
            if let Some(b) = self.try_read() {
                return b;
            }
        }
    }

    fn try_read(&mut self) -> Option<u8> {
        // SAFETY: USART2 status and data registers.
        unsafe {
            let sr = read_volatile(reg(USART2 + SR));
            if sr & (1 << 5) != 0 {
                return Some(read_volatile(reg(USART2 + DR)) as u8);
            }
            if sr & 0b1111 != 0 {
                // Overrun, noise, framing or parity error: reading DR clears it; the frame
                // CRC rejects the damaged frame.
                let _ = read_volatile(reg(USART2 + DR));
            }
            None
        }
    }

    fn write_all(&mut self, bytes: &[u8]) {
        for &b in bytes {
            // SAFETY: USART2 status and data registers.
            unsafe {
                while read_volatile(reg(USART2 + SR)) & (1 << 7) == 0 {}
                write_volatile(reg(USART2 + DR), u32::from(b));
            }
        }
    }
}

const FLASH_KEYR: usize = 0x4002_3C04;
const FLASH_SR: usize = 0x4002_3C0C;
const FLASH_CR: usize = 0x4002_3C10;
const SR_BSY: u32 = 1 << 16;
/// PGSERR, PGPERR, PGAERR, WRPERR, OPERR.
const SR_ERRORS: u32 = 0b1111_0010;
const CR_PG: u32 = 1;
const CR_SER: u32 = 1 << 1;
const CR_PSIZE_X32: u32 = 0b10 << 8;
const CR_STRT: u32 = 1 << 16;
const CR_LOCK: u32 = 1 << 31;

/// The flash controller, slots in sectors 10 (A) and 11 (B).
pub struct Stm32f4Flash;

impl Stm32f4Flash {
    /// The controller, locked until a write.
    pub fn new() -> Stm32f4Flash {
        Stm32f4Flash
    }

    fn sector(slot: SlotId) -> u32 {
        match slot {
            SlotId::A => 10,
            SlotId::B => 11,
        }
    }

    /// Unlocks, runs `f`, waits for the controller, checks errors, locks.
    fn operate(&mut self, f: impl FnOnce()) -> Result<(), FlashError> {
        // SAFETY: the documented unlock sequence and status/control registers (RM0090 3.6).
        unsafe {
            while read_volatile(reg(FLASH_SR)) & SR_BSY != 0 {}
            write_volatile(reg(FLASH_SR), SR_ERRORS);
            if read_volatile(reg(FLASH_CR)) & CR_LOCK != 0 {
                write_volatile(reg(FLASH_KEYR), 0x4567_0123);
                write_volatile(reg(FLASH_KEYR), 0xCDEF_89AB);
            }
            f();
            while read_volatile(reg(FLASH_SR)) & SR_BSY != 0 {}
            let sr = read_volatile(reg(FLASH_SR)) & SR_ERRORS;
            write_volatile(reg(FLASH_CR), CR_LOCK);
            if sr != 0 {
                return Err(FlashError::Controller(sr));
            }
        }
        Ok(())
    }
}

impl Default for Stm32f4Flash {
    fn default() -> Self {
        Self::new()
    }
}

impl Flash for Stm32f4Flash {
    fn slot(&self, slot: SlotId) -> &[u8] {
        crate::flash::mapped_slot(slot)
    }

    fn erase(&mut self, slot: SlotId) -> Result<(), FlashError> {
        let snb = Self::sector(slot) << 3;
        // SAFETY: sector erase of a slot sector, outside the program (memory-stm32f4.x).
        self.operate(|| unsafe {
            write_volatile(reg(FLASH_CR), CR_SER | snb | CR_PSIZE_X32);
            write_volatile(reg(FLASH_CR), CR_SER | snb | CR_PSIZE_X32 | CR_STRT);
        })
    }

    fn program(&mut self, slot: SlotId, offset: usize, bytes: &[u8]) -> Result<(), FlashError> {
        crate::flash::check_program(offset, bytes.len())?;
        let base = crate::flash::slot_address(slot) + offset;
        for (i, w) in bytes.chunks_exact(4).enumerate() {
            let word = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
            // SAFETY: a word-aligned address inside the erased slot sector.
            self.operate(|| unsafe {
                write_volatile(reg(FLASH_CR), CR_PG | CR_PSIZE_X32);
                write_volatile((base + 4 * i) as *mut u32, word);
            })?;
        }
        Ok(())
    }
}

/// The frames over RTT (`rtt-port`): requests from down channel 0, replies to up channel 1
/// (blocking while the host has not drained it).
#[cfg(feature = "rtt-port")]
pub struct RttPort {
    /// Replies.
    pub up: rtt_target::UpChannel,
    /// Requests.
    pub down: rtt_target::DownChannel,
}

#[cfg(feature = "rtt-port")]
impl crate::port::Port for RttPort {
    fn read(&mut self) -> u8 {
        loop {
            if let Some(b) = self.try_read() {
                return b;
            }
        }
    }

    fn try_read(&mut self) -> Option<u8> {
        let mut b = [0u8; 1];
        (self.down.read(&mut b) == 1).then_some(b[0])
    }

    fn write_all(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() {
            let n = self.up.write(bytes);
            bytes = &bytes[n..];
        }
    }
}
