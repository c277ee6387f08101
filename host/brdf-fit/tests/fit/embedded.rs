//! The on-sensor f32 annealer against the host engine on the same data: its RMS relative
//! error must be within 10% of the host optimum's, on Table 1 synthetic data and on the
//! forward in-plane rows (at most 256) of every measured dataset.

use brdf_core::tolerance::{EMBEDDED_RMS_OF_HOST, EMBEDDED_UNIT_SCALE_REL, EMBEDDED_WEIGHT_OF_HOST_REL};
use brdf_core::ModelKind;
use brdf_fit::embedded::{fit_embedded, DEFAULT_BUDGET};
use brdf_fit::import::{import, Channel, Format};
use brdf_fit::report::metrics;
use brdf_fit::{fit, synth, Dataset, FitOptions, Problem, Residual};

/// Forward-side in-plane rows (phi = 180 deg, theta_r > 0), every k-th so that at most 256.
fn forward_in_plane(d: &Dataset) -> Dataset {
    let rows: Vec<_> = d
        .points
        .iter()
        .filter(|p| p.phi.sin().abs() < 0.02 && p.phi.cos() < 0.0 && p.theta_r > 0.0)
        .copied()
        .collect();
    let k = rows.len().div_ceil(256).max(1);
    Dataset {
        name: d.name.clone(),
        points: rows.into_iter().step_by(k).collect(),
    }
}

fn rms(problem: &Problem, d: &Dataset, q: &[f64]) -> f64 {
    let y: Vec<f64> = d.points.iter().map(|p| p.brdf).collect();
    metrics(&problem.values(q), &y).rms_rel
}

#[test]
fn embedded_within_10_percent_of_host() {
    let mut sets: Vec<Dataset> = Vec::new();
    for (name, p, inc) in [
        ("khaki", brdf_core::TABLE1[0].1, &[0.0, 10.0, 30.0][..]),
        ("yellow", brdf_core::TABLE1[1].1, &[0.0, 10.0][..]),
        ("white", brdf_core::TABLE1[2].1, &[30.0][..]),
    ] {
        let mut d = synth::in_plane(ModelKind::Six, &p, inc, 2.5, 0.005, 7).unwrap();
        d.name = format!("synthetic {name}");
        sets.push(d);
    }
    for (file, format) in [
        ("cornell-medium-gloss-paints/garnet_red_RGB.astm", Format::Cornell),
        ("ptfe-germer-nist/PTFE.data.csv", Format::Nist),
        ("merl-aluminium-inplane/aluminum_brdf.csv", Format::MerlInPlane),
    ] {
        // Positive readings only: the embedded engine has no noise floor.
        let imp = import(&brdf_tests::measured(file), format, Channel::R)
            .unwrap()
            .positive_only();
        sets.extend(imp.datasets.iter().map(forward_in_plane));
    }
    for d in &sets {
        assert!(
            !d.points.is_empty() && d.points.len() <= 256,
            "{}: {}",
            d.name,
            d.points.len()
        );
        let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, d);
        let host = fit(&problem, &FitOptions::default());
        let emb = fit_embedded(ModelKind::Six, d, &problem, DEFAULT_BUDGET, 1).unwrap();
        let (h, e) = (rms(&problem, d, &host.q), rms(&problem, d, &emb.q));
        println!(
            "{:70} n {:3}: host {:.4}%  embedded {:.4}%  ratio {:.3}  ({:.0} ms)",
            d.name,
            d.points.len(),
            100.0 * h,
            100.0 * e,
            e / h,
            emb.seconds * 1e3
        );
        assert!(
            e <= EMBEDDED_RMS_OF_HOST * h,
            "{}: embedded {e} vs host {h}",
            d.name
        );
    }
}

/// Khaki with `kd` = 20 (inside the model's range [0, 100]) on a hemisphere grid.
fn khaki_kd20(noise: f64) -> Dataset {
    let mut p = brdf_core::TABLE1[0].1;
    p[4] = 20.0;
    synth::hemisphere(ModelKind::Six, &p, &[0.0, 20.0, 40.0], 10.0, 45.0, noise, 3).unwrap()
}

/// Before: the embedded box held `kd` to [0, 10] in the data's own units, so `kd` = 20
/// fitted 9.92 with `kb` 10.5 (exit 0, nothing flagged). The search now runs on readings of
/// unit size and `kd` comes back at 20, as close to the host's fit as the cross-check asks.
#[test]
fn embedded_fits_a_diffuse_weight_beyond_ten() {
    let d = khaki_kd20(0.005);
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &d);
    let host = fit(&problem, &FitOptions::default());
    let emb = fit_embedded(ModelKind::Six, &d, &problem, DEFAULT_BUDGET, 1).unwrap();
    let (h, e) = (rms(&problem, &d, &host.q), rms(&problem, &d, &emb.q));
    println!(
        "host {h:.5} kd {}; embedded {e:.5} kd {}",
        host.params[4], emb.params[4]
    );
    assert!(e <= EMBEDDED_RMS_OF_HOST * h, "embedded {e} vs host {h}");
    let kd_rel = (emb.params[4] - host.params[4]).abs() / host.params[4];
    assert!(
        kd_rel < EMBEDDED_WEIGHT_OF_HOST_REL,
        "kd {} vs host {}",
        emb.params[4],
        host.params[4]
    );
}

/// Before: the embedded fit depended on the data's units (x100: `kd` pinned at 10, 3.7%
/// off; x1e-20: an all-zero model at 100% error; x1e-60: refused, "brdf must be > 0"). The
/// same readings in any unit now fit the same shape, the weights scaled by the unit.
#[test]
fn embedded_fit_does_not_depend_on_the_units_of_the_data() {
    let base = synth::hemisphere(
        ModelKind::Six,
        &brdf_core::TABLE1[0].1,
        &[0.0, 20.0, 40.0],
        10.0,
        45.0,
        0.005,
        5,
    )
    .unwrap();
    let run = |scale: f64| {
        let mut d = base.clone();
        for p in &mut d.points {
            p.brdf *= scale;
        }
        let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &d);
        let o = fit_embedded(ModelKind::Six, &d, &problem, DEFAULT_BUDGET, 1).unwrap();
        (o.params, rms(&problem, &d, &o.q))
    };
    let (p1, e1) = run(1.0);
    assert!(e1 < 0.02, "unit data fit to {e1}");
    for scale in [100.0, 1e-20, 1e-60, 1e20] {
        let (p, e) = run(scale);
        for j in 0..6 {
            // The weights (kb, kd) scale with the data; kr, b, a, c do not.
            let weight = ModelKind::Six.linear_params().contains(&j);
            let want = if weight { p1[j] * scale } else { p1[j] };
            assert!(
                (p[j] - want).abs() <= EMBEDDED_UNIT_SCALE_REL * want.abs(),
                "x{scale:e}: parameter {j} is {} against {want}",
                p[j]
            );
        }
        assert!(
            (e - e1).abs() <= EMBEDDED_UNIT_SCALE_REL * e1,
            "x{scale:e}: rms {e} vs {e1}"
        );
    }
}

/// The embedded box bounds the weights relative to the largest reading (`kd` to 10 times
/// it). Data only near grazing, where `(cos ti cos tr)^c` is small, need `kd` far beyond:
/// the weight ends on the bound, and the result says so instead of passing it silently.
#[test]
fn a_weight_on_the_embedded_search_bound_is_reported() {
    let p = [0.0, 21.8, -27.6, 0.67, 0.5, 4.0];
    let d = synth::hemisphere(ModelKind::Six, &p, &[70.0, 75.0], 2.5, 45.0, 0.0, 3).unwrap();
    let d = Dataset {
        points: d
            .points
            .into_iter()
            .filter(|q| q.theta_r.to_degrees() >= 70.0)
            .collect(),
        ..d
    };
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &d);
    let emb = fit_embedded(ModelKind::Six, &d, &problem, DEFAULT_BUDGET, 1).unwrap();
    let largest = d.points.iter().map(|q| q.brdf).fold(0.0, f64::max);
    println!(
        "kd {} (10 x largest {}); {:?}",
        emb.params[4],
        10.0 * largest,
        emb.search.on_search_box
    );
    assert!(
        (emb.params[4] - 10.0 * largest).abs() <= EMBEDDED_UNIT_SCALE_REL * emb.params[4],
        "kd {} not on the bound",
        emb.params[4]
    );
    assert_eq!(
        emb.search.on_search_box.len(),
        1,
        "{:?}",
        emb.search.on_search_box
    );
    assert!(
        emb.search.on_search_box[0].starts_with("kd = ")
            && emb.search.on_search_box[0].contains("on the embedded engine's search bound"),
        "{:?}",
        emb.search.on_search_box
    );
    // A fit away from the bound says nothing.
    let ok = khaki_kd20(0.0);
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &ok);
    let emb = fit_embedded(ModelKind::Six, &ok, &problem, DEFAULT_BUDGET, 1).unwrap();
    assert!(
        emb.search.on_search_box.is_empty(),
        "{:?}",
        emb.search.on_search_box
    );
}

/// Before: readings of one dataset spanning 1e20 (largest over smallest) fitted an all-zero
/// model at rms_rel 1.0 and reported success: the f32 search squares each basis over its
/// reading, and at the smallest readings that overflowed. Such data are refused for the
/// embedded engine, naming the dataset and the spread and pointing to the full engine,
/// which fits them; a spread within the limit is fitted as before.
#[test]
fn readings_spanning_beyond_f32_are_refused_by_the_embedded_engine() {
    let base = synth::hemisphere(ModelKind::Lambert, &[0.5], &[0.0, 20.0, 40.0], 10.0, 45.0, 0.0, 5).unwrap();
    let spread_by = |factor: f64| {
        let mut d = base.clone();
        d.name = format!("spread {factor:e}");
        for p in d.points.iter_mut().step_by(2) {
            p.brdf /= factor;
        }
        d
    };
    let d = spread_by(1e20);
    let problem = Problem::from_dataset(ModelKind::Lambert, Residual::Relative, &d);
    let e = fit_embedded(ModelKind::Lambert, &d, &problem, DEFAULT_BUDGET, 1)
        .map(|o| o.params[0])
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("spread 1e20: ")
            && e.contains("span a factor of 1e20")
            && e.contains("the full engine"),
        "{e}"
    );
    // The full engine fits them: half the readings at rho0 / pi, half 1e20 below.
    let full = fit(&problem, &FitOptions::default());
    assert!(full.params[0] > 0.0, "{:?}", full.params);
    // Within the limit the embedded engine fits what the full one does: Lambert's one weight,
    // scaled out, is the same to rounding (as between units, EMBEDDED_UNIT_SCALE_REL).
    let d = spread_by(1e14);
    let problem = Problem::from_dataset(ModelKind::Lambert, Residual::Relative, &d);
    let emb = fit_embedded(ModelKind::Lambert, &d, &problem, DEFAULT_BUDGET, 1).unwrap();
    let full = fit(&problem, &FitOptions::default());
    let (e, f) = (rms(&problem, &d, &emb.q), rms(&problem, &d, &full.q));
    assert!(
        e <= f * (1.0 + EMBEDDED_UNIT_SCALE_REL) && e < 1.0,
        "embedded {e}, full {f}"
    );
}
