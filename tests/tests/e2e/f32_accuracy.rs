//! The f32 paths (the firmware's arithmetic) against f64 at exactly the same f32 inputs.

use brdf_core::tolerance::F32_MAX_REL;
use brdf_core::ModelKind;
use brdf_tests::f32_paths::{worst_error, PATHS};
use brdf_tests::{dense_grid_f32, random_six, SplitMix, TABLE1};

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
                ModelKind::Ggx => vec![
                    six[0],
                    rng.uniform(0.01_f64.ln(), 0.0).exp(),
                    rng.uniform(0.0, 1.0),
                    six[4],
                ],
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

/// What `brdf pack` measures per material (`brdf_core::accuracy::f32_claim_accuracy`) is
/// this test's figure: the same grid, paths and floor.
#[test]
fn the_claim_measured_per_material_is_this_tests_figure() {
    use brdf_core::accuracy::f32_claim_accuracy;
    let grid = dense_grid_f32();
    assert_eq!(grid.len(), 82_432);
    for (name, p) in TABLE1 {
        let p32 = p.map(|v| v as f32);
        for (path_name, path) in PATHS {
            let acc = f32_claim_accuracy(ModelKind::Six, &p32, path).unwrap();
            let (e, at, n) = worst_error(ModelKind::Six, &p, &grid, path);
            assert_eq!(
                (acc.max, acc.worst_at, acc.n),
                (e, Some(at), n),
                "{name} {path_name}"
            );
        }
    }
}
