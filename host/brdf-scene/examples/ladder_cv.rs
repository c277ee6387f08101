//! Every rung of `brdf select` on every bundled measurement, training error beside held-out
//! error: `brdf select --budget 0.1%` (the library call, `select_data`) on the whole
//! dataset, each exact model and the fitted table as `brdf select --json` reports them
//! (`rms_rel`: trimmed RMS relative error of the fit to all points; `cv_rms_rel`: the same
//! over each point predicted by the refit without its fold, 5-fold cross-validation by
//! direction). The table of docs/model-comparison.md ("Every rung, trained and held out").
//!
//!     cargo run --release -p brdf-scene --example ladder_cv

use std::path::Path;

use brdf_core::ModelKind;
use brdf_fit::holdout::bundled;
use brdf_fit::{FitRequest, FitSettings};
use brdf_scene::represent::{select_data, DataDomain};

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/measured");
    let sets = bundled(&root).expect("bundled data");
    let rungs: Vec<String> = ModelKind::LADDER
        .iter()
        .map(|k| format!("{} exact", k.name()))
        .chain(std::iter::once("ggx + table".to_owned()))
        .collect();
    println!("training / held-out trimmed RMS relative error (%)\n");
    println!("| data | {} |", rungs.join(" | "));
    println!("|---|{}", "---|".repeat(rungs.len()));
    let base = FitSettings::from_options(&FitRequest::new(ModelKind::Six)).expect("default settings");
    for (name, d) in &sets {
        let kept = DataDomain::new(d, 90.0, 90.0);
        let s = select_data(&kept, &|kind| FitSettings { kind, ..base }, 0.001, false).expect("select");
        let cells: Vec<String> = rungs
            .iter()
            .map(|r| match s.representations.iter().find(|x| &x.rung.name == r) {
                Some(x) => match x.cv_rms_rel {
                    Some(cv) => format!("{:.1} / {:.1}", 100.0 * x.rms_rel, 100.0 * cv),
                    None => format!("{:.1} / -", 100.0 * x.rms_rel),
                },
                None => "-".to_owned(),
            })
            .collect();
        println!("| {name} | {} |", cells.join(" | "));
    }
}
