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
#[cfg(feature = "qemu")]
pub mod uart;

#[cfg(feature = "qemu")]
use defmt_semihosting as _;

/// The board's serial port and flash slots.
#[cfg(feature = "qemu")]
pub fn board() -> (uart::Uart, flash::QemuFlash) {
    let uart = uart::Uart::uart0();
    uart.init();
    (uart, flash::QemuFlash::open())
}

/// The board's serial port (USART2, or RTT with `rtt-port`) and flash slots; sets up RTT
/// with the defmt log on up channel 0.
#[cfg(feature = "hardware")]
pub fn board() -> (impl port::Port, stm32f4::Stm32f4Flash) {
    let channels = rtt_target::rtt_init! {
        up: {
            0: { size: 1024, name: "defmt" }
            1: { size: 512, mode: rtt_target::ChannelMode::BlockIfFull, name: "brdf" }
        }
        down: {
            0: { size: 512, name: "brdf" }
        }
    };
    rtt_target::set_defmt_channel(channels.up.0);
    #[cfg(feature = "rtt-port")]
    let port = stm32f4::RttPort {
        up: channels.up.1,
        down: channels.down.0,
    };
    #[cfg(not(feature = "rtt-port"))]
    let port = stm32f4::Usart2::init();
    (port, stm32f4::Stm32f4Flash::new())
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
