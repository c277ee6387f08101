//! The on-sensor f32 annealer against the host engine on the same data: its RMS relative
//! error must be within 10% of the host optimum's, on Table 1 synthetic data and on the
//! forward in-plane rows (at most 256) of every measured dataset.

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
        assert!(e <= 1.10 * h, "{}: embedded {e} vs host {h}", d.name);
    }
}
