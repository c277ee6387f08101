//! Physical properties: reciprocity, energy bound, albedo quadrature accuracy.

use brdf_core::checks::{albedo, energy_check, reciprocity_pair, AlbedoRule};
use brdf_core::tolerance::{ALBEDO_DEFAULT_REL, MODEL_DOC_ALBEDO_ABS, RECIPROCITY_ULPS};
use brdf_core::{AnyModel, FiveParam, Model, ModelKind, SixParam};
use brdf_tests::{rad, random_six, rel_err, six_params, ulps, SplitMix, TABLE1};
use proptest::prelude::*;

fn reciprocal_models() -> Vec<AnyModel<f64>> {
    let mut models: Vec<AnyModel<f64>> = TABLE1
        .iter()
        .map(|(_, p)| AnyModel::new(ModelKind::Six, p).unwrap())
        .collect();
    models.push(AnyModel::new(ModelKind::SixCos2, &TABLE1[0].1).unwrap());
    models.push(AnyModel::new(ModelKind::Minnaert, &[0.8, 0.6]).unwrap());
    models.push(AnyModel::new(ModelKind::Lambert, &[0.8]).unwrap());
    models.push(AnyModel::new(ModelKind::Ggx, &[0.9, 0.08, 0.04, 0.1]).unwrap());
    models.push(AnyModel::new(ModelKind::Ggx, &[1.0, 0.6, 0.9, 0.0]).unwrap());
    models
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn six_minnaert_lambert_ggx_are_reciprocal(
        ti in 0.0..std::f64::consts::FRAC_PI_2,
        tr in 0.0..std::f64::consts::FRAC_PI_2,
        phi in 0.0..std::f64::consts::TAU,
    ) {
        for m in reciprocal_models() {
            let (a, b) = reciprocity_pair(&m, ti, tr, phi);
            prop_assert!(a >= 0.0 && a.is_finite());
            prop_assert!(ulps(a, b) <= RECIPROCITY_ULPS, "{:?}: {a:e} vs {b:e}", m.kind());
        }
    }

    #[test]
    fn random_six_parameter_sets_are_reciprocal(seed in any::<u64>(), ti in 0.0..std::f64::consts::FRAC_PI_2, tr in 0.0..std::f64::consts::FRAC_PI_2, phi in 0.0..std::f64::consts::TAU) {
        let p = random_six(&mut SplitMix(seed));
        let m = SixParam::<f64>::from_params(&p).unwrap();
        let (a, b) = reciprocity_pair(&m, ti, tr, phi);
        prop_assert!(ulps(a, b) <= RECIPROCITY_ULPS);
    }
}

#[test]
fn five_parameter_model_is_not_reciprocal() {
    let m = FiveParam::<f64>::from_params(&TABLE1[0].1[..5]).unwrap();
    let (a, b) = reciprocity_pair(&m, rad(10.0), rad(60.0), rad(30.0));
    // kd / cos(theta_i) alone makes the two values differ by far more than rounding.
    assert!(rel_err(a, b) > 0.1, "{a} vs {b}");
    assert!(!ModelKind::Five.is_reciprocal());
}

#[test]
fn energy_khaki_and_yellow_conserve_white_violates() {
    for (name, p) in TABLE1 {
        let m = SixParam::new(six_params(p)).unwrap();
        let bound = p[0] + p[4];
        for ti in [0.0, 10.0, 30.0, 60.0, 80.0] {
            let e = energy_check(&m, rad(ti));
            assert_eq!(e.bound, Some(bound));
            assert!(
                e.albedo < bound,
                "{name} at {ti}: albedo {} >= kb + kd {bound}",
                e.albedo
            );
            if name == "white" {
                assert!(
                    !e.bound_conserves,
                    "white kb + kd = {bound} must be reported as violating"
                );
            } else {
                assert!(e.bound_conserves && e.albedo_conserves, "{name} at {ti}: {e:?}");
            }
            println!(
                "{name:6} theta_i = {ti:2}: albedo {:.6}, kb + kd = {bound:.4}",
                e.albedo
            );
        }
    }
    // docs/model.md: khaki at normal incidence has an albedo of about 0.247.
    let khaki = SixParam::new(six_params(TABLE1[0].1)).unwrap();
    let a0 = energy_check(&khaki, 0.0).albedo;
    assert!((a0 - 0.247).abs() < MODEL_DOC_ALBEDO_ABS, "{a0}");
}

#[test]
fn albedo_default_rule_accuracy() {
    let fine = AlbedoRule { panels: 40 };
    let mut sets: Vec<[f64; 6]> = TABLE1.iter().map(|t| t.1).collect();
    let mut rng = SplitMix(42);
    sets.extend((0..8).map(|_| random_six(&mut rng)));
    // Narrow mirror peaks: the facet term's width is about kr radians.
    sets.extend([
        [0.5, 0.01, 0.0, 0.7, 0.3, 1.0],
        [0.5, 0.03, -5.0, 0.7, 0.3, 1.0],
        [2.0, 0.1, -60.0, 2.0, 0.0, 1.2],
    ]);
    let mut worst = 0.0_f64;
    for p in &sets {
        let m = SixParam::<f64>::from_params(p).unwrap();
        for ti in [0.0, 10.0, 30.0, 45.0, 60.0, 80.0] {
            let coarse = albedo(&m, rad(ti), AlbedoRule::DEFAULT);
            let reference = albedo(&m, rad(ti), fine);
            let e = rel_err(coarse, reference);
            worst = worst.max(e);
            assert!(
                e <= ALBEDO_DEFAULT_REL,
                "{p:?} at {ti}: {coarse} vs {reference} ({e:e})"
            );
        }
    }
    println!("albedo, default 8-panel rule against 40 panels: max relative error {worst:.2e}");
}
