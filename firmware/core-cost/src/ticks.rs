//! Instruction counting under QEMU: with `-icount shift=0` one instruction takes one
//! nanosecond of virtual time, and SysTick, on the core clock, ticks once every
//! `10^9 / SYSTICK_HZ` instructions (40 on the MPS2-AN386's 25 MHz). Wraps of the 24-bit
//! counter are counted by the SysTick exception, so runs of any length can be measured.
//! `bench/firmware_cost.sh --trace` checks these counts against QEMU's instruction log.

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::exception;

/// The core clock SysTick counts on the QEMU board of this target (QEMU 7.2 sources:
/// `hw/arm/mps2.c`, `hw/arm/mps2-tz.c`, `hw/arm/nrf51_soc.c`).
#[cfg(board = "an386")]
pub const SYSTICK_HZ: u64 = 25_000_000;
/// The core clock SysTick counts on the QEMU board of this target.
#[cfg(board = "an505")]
pub const SYSTICK_HZ: u64 = 20_000_000;
/// The core clock SysTick counts on the QEMU board of this target.
#[cfg(board = "microbit")]
pub const SYSTICK_HZ: u64 = 16_000_000;

const RELOAD: u32 = 0x00FF_FFFF;

static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    // Only this handler writes WRAPS (ARMv6-M has no atomic read-modify-write).
    WRAPS.store(WRAPS.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
}

/// A running SysTick, owned.
pub struct Ticks {
    _syst: SYST,
}

impl core::fmt::Debug for Ticks {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("Ticks")
    }
}

impl Ticks {
    /// Takes the core peripherals and starts SysTick counting down from its full reload.
    /// Ends the run (exit failure) if the peripherals were already taken.
    pub fn start() -> Ticks {
        let Some(p) = cortex_m::Peripherals::take() else {
            crate::exit(false)
        };
        let mut syst = p.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
        Ticks { _syst: syst }
    }

    /// Ticks since [`Ticks::start`].
    pub fn now(&self) -> u64 {
        loop {
            let w1 = WRAPS.load(Ordering::Relaxed);
            let current = SYST::get_current();
            let w2 = WRAPS.load(Ordering::Relaxed);
            if w1 == w2 {
                return u64::from(w1) * (u64::from(RELOAD) + 1) + u64::from(RELOAD - current);
            }
        }
    }

    /// Instructions in `ticks` under `-icount shift=0`, to the nearest.
    pub fn instructions(ticks: u64) -> u64 {
        (ticks * 1_000_000_000 + SYSTICK_HZ / 2) / SYSTICK_HZ
    }
}
