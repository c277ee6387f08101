//! Pieces shared by the firmware's binaries: the serial port and flash drivers of each
//! board, the exit path and the panic handler.
//!
//! Exactly one board feature is enabled: `qemu` (MPS2-AN386 under QEMU, the default) or
//! `hardware` (STM32F407). Both provide a [`port::Port`] (the byte stream frames arrive on)
//! and a [`flash::Flash`] (the two parameter slots).
#![no_std]

pub mod flash;
pub mod port;
#[cfg(feature = "hardware")]
pub mod stm32f4;
pub mod ticks;
#[cfg(feature = "qemu")]
pub mod uart;

#[cfg(feature = "qemu")]
use defmt_semihosting as _;

#[cfg(feature = "hardware")]
use defmt_rtt as _;

/// The board's serial port and flash slots.
#[cfg(feature = "qemu")]
pub fn board() -> (uart::Uart, flash::QemuFlash) {
    let uart = uart::Uart::uart0();
    uart.init();
    (uart, flash::QemuFlash::open())
}

/// The board's serial port and flash slots.
#[cfg(feature = "hardware")]
pub fn board() -> (stm32f4::Usart2, stm32f4::Stm32f4Flash) {
    (stm32f4::Usart2::init(), stm32f4::Stm32f4Flash::new())
}

/// Ends a QEMU run with success or failure (semihosting exit code).
#[cfg(feature = "qemu")]
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

/// On hardware: a failure resets the chip (it boots again from its slots); success parks.
#[cfg(feature = "hardware")]
pub fn exit(ok: bool) -> ! {
    if !ok {
        cortex_m::peripheral::SCB::sys_reset();
    }
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    match info.location() {
        Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
        None => defmt::error!("panic"),
    }
    exit(false)
}
