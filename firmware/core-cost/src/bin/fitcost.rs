//! Instruction cost of one on-sensor FIT at N = 256 samples and the default budget on the
//! target's core, measured under QEMU with `-icount shift=0` by `bench/firmware_cost.sh` (see
//! `core_cost::ticks`).
//!
//! The samples are the khaki plate of Table 1 on an in-plane grid (incidences 0, 10 and 30
//! degrees, viewing zeniths on both sides, 256 in all) with a deterministic +-0.5 % ripple;
//! the same annealer, schedule and seed as the firmware's FIT command.
#![no_std]
#![no_main]

use brdf_core::anneal::{anneal, AnnealConfig, Samples, SearchBox, DEVICE_SEED};
use brdf_core::{Brdf, Model, ModelKind, SixParam};
use core_cost::exit;
use core_cost::ticks::Ticks;
use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use rand_core::SeedableRng;

const N: usize = 256;

/// The khaki plate, Table 1 of the paper.
const KHAKI: [f32; 6] = brdf_core::table1_f32(0);

#[entry]
fn main() -> ! {
    let ticks = Ticks::start();
    let Ok(khaki) = SixParam::from_params(&KHAKI) else {
        exit(false)
    };
    let mut s: Samples<f32, N> = Samples::new();
    let deg = core::f32::consts::PI / 180.0;
    let per_incidence = N / 3;
    for (j, ti) in [0.0f32, 10.0, 30.0].into_iter().enumerate() {
        let count = if j == 2 {
            N - 2 * per_incidence
        } else {
            per_incidence
        };
        for k in 0..count {
            // Viewing zenith -80..80 degrees in the plane; negative = forward side (phi = pi).
            let v = -80.0 + 160.0 * k as f32 / (count - 1) as f32;
            let (tr, phi) = if v < 0.0 {
                (-v, core::f32::consts::PI)
            } else {
                (v, 0.0)
            };
            let f = khaki.eval_angles(ti * deg, tr * deg, phi);
            let ripple = 1.0 + 0.005 * (((k * 7 + j * 3) % 11) as f32 / 5.0 - 1.0);
            if s.push_angles(ti * deg, tr * deg, phi, f * ripple).is_err() {
                exit(false);
            }
        }
    }
    let cfg = AnnealConfig::default();
    let mut rng = rand_pcg::Pcg32::seed_from_u64(DEVICE_SEED);
    let t0 = ticks.now();
    let r = anneal::<f32, SixParam<f32>, _, N>(&s, &SearchBox::for_kind(ModelKind::Six), &cfg, &mut rng);
    let t1 = ticks.now();
    let Ok(out) = r else { exit(false) };
    let instr = Ticks::instructions(t1 - t0);
    hprintln!(
        "fit: six-parameter, {} samples, budget {} evaluations: {} instructions ({} per evaluation, {} per sample), RMS relative error {}",
        s.len(),
        out.evals,
        instr,
        instr / u64::from(out.evals),
        instr / (u64::from(out.evals) * s.len() as u64),
        out.rms_rel
    );
    hprintln!(
        "fit: samples buffer {} bytes",
        core::mem::size_of::<Samples<f32, N>>()
    );
    exit(true)
}
