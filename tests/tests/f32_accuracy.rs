//! The f32 paths (the firmware's arithmetic) against f64 at exactly the same f32 inputs.

use brdf_core::tolerance::{F32_FLOOR_OF_MAX, F32_MAX_REL};
use brdf_core::{AnyModel, Brdf, ModelKind};
use brdf_tests::{dense_grid_f32, random_six, SplitMix, TABLE1};

/// One evaluation path: the f32 and the f64 value at one direction.
type Path = fn(&AnyModel<f32>, &AnyModel<f64>, [f32; 3]) -> (f32, f64);

/// Worst relative error of `path` over `grid` where the f64 value is above the floor.
/// Returns (worst relative error, where, number of points compared).
fn worst_error(kind: ModelKind, params: &[f64], grid: &[[f32; 3]], path: Path) -> (f64, [f32; 3], usize) {
    let p32: Vec<f32> = params.iter().map(|&v| v as f32).collect();
    let p64: Vec<f64> = p32.iter().map(|&v| f64::from(v)).collect();
    let m32 = AnyModel::<f32>::new(kind, &p32).unwrap();
    let m64 = AnyModel::<f64>::new(kind, &p64).unwrap();
    let values: Vec<(f32, f64)> = grid.iter().map(|&x| path(&m32, &m64, x)).collect();
    let max = values.iter().map(|v| v.1).fold(0.0, f64::max);
    let floor = F32_FLOOR_OF_MAX * max;
    let mut worst = (0.0, [0.0; 3], 0);
    for (x, &(a, b)) in grid.iter().zip(&values) {
        assert!(
            a.is_finite() && b.is_finite(),
            "{kind:?} {params:?} at {x:?}: {a} {b}"
        );
        if b >= floor && b > 0.0 {
            worst.2 += 1;
            let e = ((f64::from(a) - b) / b).abs();
            if e > worst.0 {
                worst = (e, *x, worst.2);
            }
        }
    }
    worst
}

fn angles(m32: &AnyModel<f32>, m64: &AnyModel<f64>, x: [f32; 3]) -> (f32, f64) {
    let [ti, tr, phi] = x;
    (
        m32.eval_angles(ti, tr, phi),
        m64.eval_angles(ti.into(), tr.into(), phi.into()),
    )
}

fn cosines(m32: &AnyModel<f32>, m64: &AnyModel<f64>, x: [f32; 3]) -> (f32, f64) {
    // The device receives f32 cosines; the f64 reference evaluates at the same cosines.
    let c = x.map(|a| f64::from(a).cos() as f32);
    (
        m32.eval_cosines(c[0], c[1], c[2]),
        m64.eval_cosines(c[0].into(), c[1].into(), c[2].into()),
    )
}

fn vectors(m32: &AnyModel<f32>, m64: &AnyModel<f64>, x: [f32; 3]) -> (f32, f64) {
    let [ti, tr, phi] = x.map(f64::from);
    let wi = [ti.sin() as f32, 0.0, ti.cos() as f32];
    let wr = [
        (tr.sin() * phi.cos()) as f32,
        (tr.sin() * phi.sin()) as f32,
        tr.cos() as f32,
    ];
    (
        m32.eval_vectors(wi, wr),
        m64.eval_vectors(wi.map(f64::from), wr.map(f64::from)),
    )
}

const PATHS: [(&str, Path); 3] = [("angles", angles), ("cosines", cosines), ("vectors", vectors)];

#[test]
fn f32_matches_f64_for_table1_materials() {
    let grid = dense_grid_f32();
    let mut overall = 0.0_f64;
    for (name, p) in TABLE1 {
        for (path_name, path) in PATHS {
            let (e, at, n) = worst_error(ModelKind::Six, &p, &grid, path);
            println!(
                "six {name:6} from {path_name:7}: max rel error {e:.2e} over {n} points (worst at {at:?})"
            );
            overall = overall.max(e);
            assert!(e <= F32_MAX_REL, "{name} from {path_name}: {e:e} at {at:?}");
        }
    }
    println!(
        "f32 vs f64, Table 1, {} directions: max relative error {overall:.2e}",
        grid.len()
    );
}

#[test]
fn f32_matches_f64_for_random_parameters_of_every_model() {
    let grid = dense_grid_f32();
    let mut rng = SplitMix(0x5eed_b4df);
    for kind in ModelKind::ALL {
        let mut worst = 0.0_f64;
        for _ in 0..24 {
            let six = random_six(&mut rng);
            let params: Vec<f64> = match kind {
                ModelKind::Six | ModelKind::SixCos2 => six.to_vec(),
                ModelKind::Five => six[..5].to_vec(),
                ModelKind::Minnaert => vec![six[0], rng.uniform(0.05, 1.0)],
                ModelKind::Lambert => vec![six[0]],
            };
            for (path_name, path) in PATHS {
                let (e, at, _) = worst_error(kind, &params, &grid, path);
                worst = worst.max(e);
                assert!(
                    e <= F32_MAX_REL,
                    "{kind:?} {params:?} from {path_name}: {e:e} at {at:?}"
                );
            }
        }
        println!("{:9} random parameters: max rel error {worst:.2e}", kind.name());
    }
}
