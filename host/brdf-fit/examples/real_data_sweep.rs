//! Every subset of every bundled measured dataset (see `tests/support/sweep.rs`) and the
//! fooling cases, every model, seeds 1..=20, fitted with the default search and with the
//! earlier one (`FitOptions::without_verification`); prints, per case, the best cost known,
//! how many seeds reached it and the time per fit. The figures in
//! `docs/model-comparison.md` come from this run:
//!
//!     cargo run --release -p brdf-fit --example real_data_sweep

#[path = "../tests/support/sweep.rs"]
mod sweep;

use brdf_core::ModelKind;
use brdf_fit::FitOptions;

fn main() {
    let mut cases = sweep::measured_cases();
    cases.extend(sweep::fooling_cases());
    let searches = [FitOptions::default(), FitOptions::without_verification()];
    let out = sweep::sweep(&cases, &ModelKind::ALL, 1..=20, &searches, sweep::long_search(48));
    sweep::print("search", &out[0]);
    sweep::print("earlier search", &out[1]);
}
