//! Smallest program that builds a six-parameter model at run time and evaluates it from
//! cosines: its `.text` is the flash cost of the model on a Cortex-M4F.
#![no_std]
#![no_main]

use brdf_core::{Brdf, Model, SixParam};
use core::hint::black_box;

#[no_mangle]
pub extern "C" fn _start() -> ! {
    let p = black_box(brdf_core::table1_f32(0));
    let m = match SixParam::from_params(&p) {
        Ok(m) => m,
        Err(_) => halt(),
    };
    loop {
        black_box(m.eval_cosines(black_box(0.9), black_box(0.8), black_box(-0.5)));
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    halt()
}

/// Parks the core; a real program would reset or report instead.
fn halt() -> ! {
    loop {
        core::hint::spin_loop();
    }
}
