//! Instruction counts of `brdf-core` on the cores users put in sensors, under QEMU: the
//! binaries `cost` (instructions per evaluation of each model and path) and `fitcost` (one
//! on-sensor FIT at N = 256), built for the Cortex-M0+ (`thumbv6m-none-eabi`, QEMU
//! `microbit`), the Cortex-M4F (`thumbv7em-none-eabihf`, `mps2-an386`, the firmware's board)
//! and the Cortex-M33 (`thumbv8m.main-none-eabihf`, `mps2-an505`). `bench/firmware_cost.sh`
//! runs them; the release profile is the firmware's (`opt-level = "s"`, LTO).
//!
//! This crate holds what the two binaries share: the exit path, the panic handler and the
//! SysTick instruction counter ([`ticks`]).
#![no_std]

pub mod ticks;

/// Ends the QEMU run with success or failure (semihosting exit code).
pub fn exit(ok: bool) -> ! {
    cortex_m_semihosting::debug::exit(if ok {
        cortex_m_semihosting::debug::EXIT_SUCCESS
    } else {
        cortex_m_semihosting::debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(l) => cortex_m_semihosting::hprintln!("panic at {}:{}", l.file(), l.line()),
        None => cortex_m_semihosting::hprintln!("panic"),
    }
    exit(false)
}
