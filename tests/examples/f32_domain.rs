//! Worst f32 relative error (all three paths) over many random six-parameter sets, for the
//! ranges the accuracy claim covers and for the fitter's whole search box.
//!
//!     cargo run --release -p brdf-tests --example f32_domain [-- SETS]
use brdf_core::ModelKind;
use brdf_tests::f32_paths::{worst_error, PATHS};
use brdf_tests::{dense_grid_f32, SplitMix};

fn worst(p: &[f64; 6], grid: &[[f32; 3]]) -> f64 {
    PATHS
        .iter()
        .map(|(_, path)| worst_error(ModelKind::Six, p, grid, *path).0)
        .fold(0.0, f64::max)
}

fn main() {
    let sets: usize = std::env::args().nth(1).map_or(100, |s| s.parse().unwrap());
    let grid = dense_grid_f32();
    let mut rng = SplitMix(7);
    let domains: [(&str, [(f64, f64); 6]); 3] = [
        (
            "claim: |b| <= 40, a <= 1, c <= 1.5",
            [
                (0.01, 2.0),
                (0.05, 50.0),
                (-40.0, 40.0),
                (0.2, 1.0),
                (0.0, 1.0),
                (0.0, 1.5),
            ],
        ),
        (
            "wide: |b| <= 60, a <= 2",
            [
                (0.01, 2.0),
                (0.05, 50.0),
                (-60.0, 60.0),
                (0.2, 2.0),
                (0.0, 1.0),
                (0.0, 2.0),
            ],
        ),
        (
            "fit box",
            [
                (0.0, 100.0),
                (0.01, 1000.0),
                (0.0, 200.0),
                (0.05, 4.0),
                (0.0, 10.0),
                (0.0, 5.0),
            ],
        ),
    ];
    for (name, r) in domains {
        let mut errs: Vec<f64> = Vec::new();
        for _ in 0..sets {
            let mut p = [0.0; 6];
            for j in 0..6 {
                p[j] = if j == 1 {
                    rng.log_uniform(r[j].0, r[j].1)
                } else {
                    rng.uniform(r[j].0, r[j].1)
                };
            }
            let e = worst(&p, &grid);
            if e > 1.5e-6 {
                println!(
                    "   {e:.2e} at kb {:.3} kr {:.3} b {:.1} a {:.2} kd {:.3} c {:.2}  a|b| = {:.1}",
                    p[0],
                    p[1],
                    p[2],
                    p[3],
                    p[4],
                    p[5],
                    p[3] * p[2].abs()
                );
            }
            errs.push(e);
        }
        errs.sort_by(f64::total_cmp);
        let over = errs.iter().filter(|&&e| e > 2e-6).count();
        println!(
            "{name:30}: {sets} sets, median {:.2e}, max {:.2e}, {over} above 2e-6",
            errs[sets / 2],
            errs[sets - 1]
        );
    }
}
