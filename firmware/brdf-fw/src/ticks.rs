//! Instruction counting under QEMU: with `-icount shift=0` one instruction takes one
//! nanosecond of virtual time and SysTick, on the core clock (25 MHz on the MPS2 boards),
//! ticks once every 40 instructions. Wraps of the 24-bit counter are counted by the SysTick
//! exception, so runs of any length can be measured. On hardware the same code counts core
//! clock cycles / 40 instead.

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::exception;

/// Instructions per SysTick tick under `-icount shift=0` on the MPS2 (1 GHz virtual
/// instruction clock over a 25 MHz SysTick clock).
pub const INSTRUCTIONS_PER_TICK: u64 = 40;

const RELOAD: u32 = 0x00FF_FFFF;

static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
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

    /// Instructions in `ticks` under `-icount shift=0`.
    pub fn instructions(ticks: u64) -> u64 {
        ticks * INSTRUCTIONS_PER_TICK
    }
}
