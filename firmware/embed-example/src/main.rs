//! The minimal embedding of `brdf-core` in a Cortex-M firmware: a material compiled into
//! flash as a constant, validated once at start-up, then queried from cosines — the device
//! path, with no trigonometry. Under QEMU it prints the answer and exits:
//!
//! ```text
//! cd firmware && cargo build --release -p embed-example
//! qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -nographic \
//!     -semihosting-config enable=on,target=native \
//!     -kernel target/thumbv7em-none-eabihf/release/embed-example
//! ```
#![no_std]
#![no_main]

use brdf_core::{Brdf, SixParam, SixParams};
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use panic_halt as _;

/// Khaki painted plate (Table 1 of the paper, `brdf_core::TABLE1`), in the paper's order
/// `kb, kr, b, a, kd, c`; your own material is `SixParams::from_array([kb, kr, b, a, kd, c])`
/// with its six `f32` values.
const KHAKI: SixParams<f32> = SixParams::from_array(brdf_core::table1_f32(0));

/// One query: incidence 30 deg, viewing 60 deg, `phi` = 180 deg (the plane of incidence,
/// forward side), as the cosines a sensor's own geometry would supply.
const COS_THETA_I: f32 = 0.866_025_4;
const COS_THETA_R: f32 = 0.5;
const COS_PHI: f32 = -1.0;

#[entry]
fn main() -> ! {
    // Validates the ranges and precomputes the material's constants, once.
    let Ok(khaki) = SixParam::new(KHAKI) else {
        debug::exit(debug::EXIT_FAILURE);
        park()
    };
    let f = khaki.eval_cosines(COS_THETA_I, COS_THETA_R, COS_PHI); // 1/sr
    hprintln!("{}", f);
    debug::exit(debug::EXIT_SUCCESS);
    park()
}

/// Where a board would go on with its work; under QEMU the exit above ends the run.
fn park() -> ! {
    loop {
        core::hint::spin_loop();
    }
}
