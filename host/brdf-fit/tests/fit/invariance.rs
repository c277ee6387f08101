//! The fit must not depend on the data's units or on the size of uniform weights: relative
//! residuals are scale-free and `kb`, `kd` are linear, so the bundled khaki data in other
//! units (x1e-6 .. x1e6) or with a uniform weight of any size give the same relative fit and
//! the same flags.

use std::path::PathBuf;

use brdf_core::ModelKind;
use brdf_fit::report::FitReport;
use brdf_fit::{load_csv, Dataset, FitSettings, LoadOptions};

/// Relative agreement of the RMS relative error and of every parameter (linear ones divided
/// by the scale) between a scaled fit and the original: the search and the polish see the
/// same landscape up to rounding, so only the polish's stopping noise (relative cost change
/// 1e-12, i.e. parameters to about 1e-6 relative) separates them.
const SCALED_FIT_REL: f64 = 1e-5;

fn khaki() -> Dataset {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/khaki-synthetic-inplane.csv");
    load_csv(&path, LoadOptions::default())
        .unwrap()
        .datasets
        .remove(0)
}

fn fit(d: &Dataset) -> FitReport {
    brdf_fit::fit_all(&FitSettings::new(ModelKind::Six), std::slice::from_ref(d))
        .unwrap()
        .remove(0)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= SCALED_FIT_REL * a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}

fn check(base: &FitReport, other: &FitReport, linear_scale: f64, label: &str) {
    assert!(
        close(base.metrics.rms_rel, other.metrics.rms_rel),
        "{label}: RMS relative error {} against {}",
        other.metrics.rms_rel,
        base.metrics.rms_rel
    );
    for (j, ((name, a), (_, b))) in base.params.0.iter().zip(&other.params.0).enumerate() {
        let a = if j == 0 || j == 4 { a * linear_scale } else { *a };
        // kr is not determined by in-plane data (flagged): compare the determined ones.
        if base.uncertainty.params.0[j].1.determined {
            assert!(close(a, *b), "{label}: {name} {b} against {a}");
        }
    }
    assert_eq!(base.undetermined(), other.undetermined(), "{label}: flags");
    // The energy check is linear in the weights, also for weights beyond the device's
    // ranges, which are named instead of refused.
    let (bb, ob) = (base.energy.bound.unwrap(), other.energy.bound.unwrap());
    assert!(
        close(bb * linear_scale, ob),
        "{label}: energy bound {ob} against {bb}"
    );
    for (a, b) in base.energy.albedo.iter().zip(&other.energy.albedo) {
        assert!(
            close(a.albedo * linear_scale, b.albedo),
            "{label}: albedo {} against {}",
            b.albedo,
            a.albedo
        );
    }
    let (kb, kd) = (other.params.0[0].1, other.params.0[4].1);
    let expected: Vec<&str> = [("kb", kb > 10_000.0), ("kd", kd > 100.0)]
        .iter()
        .filter(|(_, out)| *out)
        .map(|(n, _)| *n)
        .collect();
    let named: Vec<&str> = other
        .outside_ranges
        .iter()
        .map(|o| o.split(' ').next().unwrap())
        .collect();
    assert_eq!(
        named, expected,
        "{label}: parameters outside the ranges: {:?}",
        other.outside_ranges
    );
    assert_eq!(base.converged, other.converged, "{label}: converged");
}

#[test]
fn other_units_give_the_same_relative_fit() {
    let d = khaki();
    let base = fit(&d);
    assert!(base.converged);
    let mut beyond = 0;
    for scale in [1e-6, 1e-4, 1e-2, 1e2, 1e4, 1e6] {
        let mut s = d.clone();
        for p in &mut s.points {
            p.brdf *= scale;
        }
        let other = fit(&s);
        beyond += usize::from(!other.outside_ranges.is_empty());
        check(&base, &other, scale, &format!("x{scale:e}"));
    }
    assert!(beyond > 0, "some scale puts a weight beyond its range");
}

#[test]
fn uniform_weights_of_any_size_give_the_same_fit() {
    let d = khaki();
    let base = fit(&d);
    for weight in [1e-10, 1e-3, 1e3, 1e10] {
        let mut s = d.clone();
        for p in &mut s.points {
            p.weight = Some(weight);
        }
        check(&base, &fit(&s), 1.0, &format!("weight {weight:e}"));
    }
}
