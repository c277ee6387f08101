//! The global search on real measurements. Every fit of a selection of the bundled measured
//! data (each incidence of Garnet Red, Krylon Blue, PTFE at 0.532 um and MERL aluminium alone:
//! the cases where the earlier search most often stopped in a local optimum) and of synthetic
//! cases built to fool the agreement test must reach, from every seed, the best cost known
//! (from a much longer search and every seed) to within `SEED_COST_REL`. The earlier search
//! (`FitOptions::without_verification`) must fail the same check on some of them, or the
//! check proves nothing.
//!
//! The full sweep (every subset of every dataset, every model, seeds 1..=20) is
//! `cargo run --release -p brdf-fit --example real_data_sweep`.

#[path = "support/sweep.rs"]
mod sweep;

use brdf_core::ModelKind;
use brdf_fit::FitOptions;

use sweep::{fooling_cases, long_search, measured_cases, print, sweep};

/// Seeds per case: enough for the earlier search to fail somewhere (it reached the best cost
/// from 1 to 19 of 20 seeds on the cases it failed), few enough for the test suite (about 15 s).
const SEEDS: std::ops::RangeInclusive<u64> = 1..=8;

#[test]
fn every_seed_reaches_the_best_known_optimum_on_real_data_and_the_old_search_does_not() {
    let mut cases: Vec<_> = measured_cases()
        .into_iter()
        .filter(|c| {
            c.name.contains("ti=")
                && !c.name.starts_with("ptfe 0.351")
                && !c.name.starts_with("ptfe 0.633")
                && !c.name.starts_with("ptfe 1.064")
        })
        .collect();
    cases.extend(fooling_cases());
    let models = [ModelKind::Six, ModelKind::SixCos2, ModelKind::Five];
    let searches = [FitOptions::default(), FitOptions::without_verification()];
    let out = sweep(&cases, &models, SEEDS, &searches, long_search(16));
    print("search", &out[0]);
    print("earlier search", &out[1]);
    let failed: Vec<String> = out[0]
        .iter()
        .filter(|o| !o.passed())
        .map(|o| format!("{} {}: {}/{}", o.name, o.model.name(), o.reached, o.seeds))
        .collect();
    assert!(failed.is_empty(), "seeds missing the best known cost: {failed:?}");
    let old_failed = out[1].iter().filter(|o| !o.passed()).count();
    assert!(
        old_failed > 0,
        "the earlier search reached the best cost everywhere too: the check cannot tell them apart"
    );
}
