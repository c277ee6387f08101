//! The fast f32 six-parameter path (`brdf_core::fast`, own exp2/log2) against exact f64 at
//! the same f32 inputs, on the grid of the exact f32 paths' test (zeniths to 89.9 degrees,
//! points within 1e-7 to 1e-4 rad of retro and mirror).

use brdf_core::accuracy::compare;
use brdf_core::fast::FastSix;
use brdf_core::tolerance::FAST_MAX_REL;
use brdf_core::{Brdf, SixParam, SixParams};
use brdf_tests::{dense_grid_f32, random_six, SplitMix, TABLE1};

fn worst(p: [f64; 6], grid: &[[f32; 3]]) -> (f64, [f32; 3]) {
    let p32 = p.map(|v| v as f32);
    let fast = FastSix::new(SixParams::from_array(p32)).unwrap();
    let exact = SixParam::new(brdf_tests::six_params(p32.map(f64::from))).unwrap();
    let pts: Vec<([f32; 3], f32, f64)> = grid
        .iter()
        .map(|&x| {
            let c = [x[0].cos(), x[1].cos(), x[2].cos()];
            (
                x,
                fast.eval_cosines(c[0], c[1], c[2]),
                exact.eval_cosines(c[0].into(), c[1].into(), c[2].into()),
            )
        })
        .collect();
    let a = compare(0..pts.len(), |k| pts[k].1, |k| pts[k].2);
    (a.max, a.worst_at.map_or([0.0; 3], |k| pts[k].0))
}

#[test]
fn fast_six_error_bound() {
    let grid = dense_grid_f32();
    let mut rng = SplitMix(0xfa57);
    let mut all = 0.0f64;
    for (name, p) in TABLE1
        .iter()
        .map(|(n, p)| (n.to_string(), *p))
        .chain((0..150).map(|i| (format!("random {i}"), random_six(&mut rng))))
    {
        let (e, at) = worst(p, &grid);
        assert!(e <= FAST_MAX_REL, "{name} {p:?}: {e:e} at {at:?}");
        all = all.max(e);
    }
    println!(
        "fast f32 path, Table 1 and 150 random sets, {} directions to 89.9 deg: max relative error {all:.2e}",
        grid.len()
    );
}
