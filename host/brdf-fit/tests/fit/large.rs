//! Large measurements: above `SEARCH_POINTS` points the global search runs on a subsample
//! stratified by reading and the polish on every point. A hemisphere of a glossy surface
//! (21,840 points, 2% noise) must reach a cost no worse than its true parameters', say that the
//! search saw a subsample, and converge; the subsample must span the readings.

use brdf_core::ModelKind;
use brdf_fit::fit::{search_sample, SEARCH_POINTS};
use brdf_fit::kernel::to_internal;
use brdf_fit::synth::hemisphere;
use brdf_fit::{fit, FitOptions, Problem, Residual};

/// Relative difference of one cost summed in two orders (the polish's pass and the cost's)
/// over some 20,000 terms: a few units of 1e-16 each.
const SAME_SUM_REL: f64 = 1e-12;

/// A glossy paint: a narrow lobe over a modest diffuse part.
const TRUE: [f64; 6] = [0.6, 8.0, -4.0, 0.9, 0.15, 1.3];

#[test]
fn a_large_fit_searches_a_subsample_and_reaches_the_true_cost() {
    let data = hemisphere(
        ModelKind::Six,
        &TRUE,
        &[0.0, 25.0, 50.0, 70.0],
        1.5,
        2.0,
        0.02,
        11,
    )
    .unwrap();
    assert!(data.points.len() > SEARCH_POINTS, "{} points", data.points.len());
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &data);
    let out = fit(&problem, &FitOptions::default());
    let truth = problem.cost(&to_internal(ModelKind::Six, &TRUE));
    assert_eq!(out.search.sample, Some(SEARCH_POINTS));
    assert!(out.converged, "{:?}", out.search.not_converged);
    assert!(
        out.cost <= truth,
        "cost {} above the true parameters' {truth}",
        out.cost
    );
    // The cost reported is every point's (the subsample's would be about 25% lower here).
    let every = problem.cost(&out.q);
    assert!(
        (out.cost - every).abs() <= SAME_SUM_REL * every,
        "{} against {every}",
        out.cost
    );
}

#[test]
fn the_search_sample_spans_the_readings_and_is_fixed() {
    let data = hemisphere(ModelKind::Six, &TRUE, &[10.0, 60.0], 1.0, 1.0, 0.02, 5).unwrap();
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &data);
    let (n, m) = (problem.len(), 1000);
    let s = search_sample(&problem, m);
    assert_eq!(s.len(), m);
    assert!(s.windows(2).all(|w| w[0] < w[1]), "ascending, distinct");
    assert_eq!(s, search_sample(&problem, m), "the same subsample every time");
    let mut ys: Vec<f64> = (0..n).map(|i| problem.target(i)).collect();
    ys.sort_by(f64::total_cmp);
    let stratum = n.div_ceil(m);
    let max = s.iter().map(|&i| problem.target(i)).fold(f64::MIN, f64::max);
    let min = s.iter().map(|&i| problem.target(i)).fold(f64::MAX, f64::min);
    assert!(max >= ys[n - stratum], "the peak's stratum is drawn from: {max}");
    assert!(min <= ys[stratum - 1], "the darkest stratum is drawn from: {min}");
    assert_eq!(search_sample(&problem, n + 1), (0..n).collect::<Vec<_>>());
}
