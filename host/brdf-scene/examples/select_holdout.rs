//! What `brdf select --budget 0.1% --chosen chosen.json` picks from 80% of a measurement,
//! judged on the other 20% as `brdf eval --fit chosen.json` evaluates it (f64), against the
//! 4-nearest-neighbour yardstick of the same training points (`brdf_fit::holdout`), on every
//! bundled measurement and all five outer folds. The figures of docs/model-comparison.md
//! ("What `brdf select` picks, held out").
//!
//!     cargo run --release -p brdf-scene --example select_holdout [-- NAME_PART]

use std::path::Path;

use brdf_core::fitted::{Corrected, FittedTable};
use brdf_core::{AnyModel, Brdf, ModelKind};
use brdf_fit::fitted_table::trimmed_rms_rel;
use brdf_fit::holdout::{bundled, split, Neighbours, OUTER_FOLDS};
use brdf_fit::report::FittedModel;
use brdf_fit::Dataset;
use brdf_fit::{FitRequest, FitSettings};
use brdf_scene::represent::{select_data, DataDomain};

/// The chosen representation's held-out error through the `--chosen` JSON, and its name.
fn chosen_error(train: &Dataset, test: &[brdf_fit::Point]) -> (f64, String) {
    let base = FitSettings::from_options(&FitRequest::new(ModelKind::Six)).expect("default settings");
    let kept = DataDomain::new(train, 90.0, 90.0);
    let s = select_data(&kept, &|kind| FitSettings { kind, ..base }, 0.001, false).expect("select");
    let fit = s.chosen_report().expect("a representation is chosen");
    // Written and read back as `--chosen` and `brdf eval --fit` do.
    let text = serde_json::to_string_pretty(&fit).unwrap();
    let one = FittedModel::one_of(&text, "chosen.json", None).unwrap();
    let model = AnyModel::<f64>::new(one.model, &one.params[..one.model.param_count()]).unwrap();
    let rel: Vec<f64> = match &one.table {
        Some(bytes) => {
            let m = Corrected {
                base: model,
                table: FittedTable::new(bytes).unwrap(),
            };
            test.iter()
                .map(|p| (m.eval_angles(p.theta_i, p.theta_r, p.phi) / p.brdf - 1.0).abs())
                .collect()
        }
        None => test
            .iter()
            .map(|p| (model.eval_angles(p.theta_i, p.theta_r, p.phi) / p.brdf - 1.0).abs())
            .collect(),
    };
    (trimmed_rms_rel(&rel), s.chosen.unwrap_or_default())
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/measured");
    // An optional argument keeps the datasets whose name contains it (`-- krylon`).
    let only = std::env::args().nth(1).unwrap_or_default();
    let sets: Vec<_> = bundled(&root)
        .expect("bundled data")
        .into_iter()
        .filter(|(name, _)| name.contains(only.as_str()))
        .collect();
    println!("| data | points | chosen (folds) | chosen, held out | 4-NN | ratio |");
    println!("|---|---|---|---|---|---|");
    let mut ratios = Vec::new();
    for (name, d) in &sets {
        let (mut ec, mut en) = (0.0, 0.0);
        let mut names: Vec<String> = Vec::new();
        for f in 0..OUTER_FOLDS {
            let (train, test) = (split(d, f, false), split(d, f, true));
            // Select refuses readings at or below zero (relative error is undefined there).
            let train = Dataset {
                name: d.name.clone(),
                points: train,
            };
            let (e, chosen) = chosen_error(&train, &test);
            ec += e;
            let nn = Neighbours::new(&train.points);
            en += trimmed_rms_rel(
                &test
                    .iter()
                    .map(|p| (nn.predict(p) / p.brdf - 1.0).abs())
                    .collect::<Vec<_>>(),
            );
            if !names.contains(&chosen) {
                names.push(chosen);
            }
        }
        let k = OUTER_FOLDS as f64;
        let (ec, en) = (ec / k, en / k);
        ratios.push(ec / en);
        println!(
            "| {name} | {} | {} | {ec:.3} | {en:.3} | {:.2} |",
            d.points.len(),
            names.join(", "),
            ec / en
        );
    }
    ratios.sort_by(f64::total_cmp);
    let wins = ratios.iter().filter(|&&r| r <= 1.0).count();
    println!(
        "\nmedian ratio {:.2}; at or below 4-NN on {wins} of {}",
        ratios[ratios.len() / 2],
        ratios.len()
    );
}
