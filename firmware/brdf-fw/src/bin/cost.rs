//! Instruction cost of one evaluation on the Cortex-M4F, measured under QEMU by
//! `bench/firmware_cost.sh`: each path runs between two marker functions, and the script
//! counts the instructions QEMU executes between the markers (exact, repeatable).
#![no_std]
#![no_main]

use brdf_core::{Brdf, Model, SixParam};
use brdf_fw::exit;
use core::hint::black_box;
use cortex_m_rt::entry;

/// Evaluations per measured run.
const N: usize = 100;

#[inline(never)]
#[no_mangle]
extern "C" fn cost_marker_start(id: u32) -> u32 {
    black_box(id + 1)
}

#[inline(never)]
#[no_mangle]
extern "C" fn cost_marker_end(id: u32) -> u32 {
    black_box(id + 2)
}

#[entry]
fn main() -> ! {
    let p = black_box([0.2545_f32, 21.8031, -27.5721, 0.6705, 0.3676, 1.2]);
    let m = match SixParam::from_params(&p) {
        Ok(m) => m,
        Err(_) => exit(false),
    };
    let mut acc = 0.0f32;
    // Path 1: from angles (radians).
    cost_marker_start(1);
    for k in 0..N {
        let x = k as f32 * 0.005;
        acc += m.eval_angles(black_box(0.2 + x), black_box(0.7 - x), black_box(1.0 + x));
    }
    cost_marker_end(1);
    // Path 2: from cosines.
    cost_marker_start(2);
    for k in 0..N {
        let x = k as f32 * 0.002;
        acc += m.eval_cosines(black_box(0.9 - x), black_box(0.7 + x), black_box(-0.3 + x));
    }
    cost_marker_end(2);
    black_box(acc);
    exit(true)
}
