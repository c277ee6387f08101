//! Pieces shared by the firmware's binaries: the UART driver, the exit path and the panic
//! handler (a panic ends a QEMU run with a failure the host sees).
#![no_std]

pub mod ticks;
pub mod uart;

/// Ends a QEMU run with success or failure (semihosting); parks the core on hardware.
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
fn panic(_: &core::panic::PanicInfo) -> ! {
    exit(false)
}
