//! Held-out error of the fitted table (`brdf_fit::fitted_table`) against the nearest-neighbour
//! yardstick on every bundled measurement: five outer folds, each fold predicted from the
//! other 80% (the table, over the microfacet fit to those 80% as `brdf select` builds it,
//! choosing its grid and smoothness by its own inner cross-validation on them only;
//! "seconds per fit" is the table's alone), error = trimmed RMS of |f/measured - 1| (`fitted_table::trimmed_rms_rel`). "4-NN" is
//! inverse-distance interpolation of ln f between the 4 nearest training points in
//! (theta_h, theta_d, theta_i + theta_r, |theta_i - theta_r|), a yardstick any analyst can build
//! in ten lines. The figures of docs/model-comparison.md ("Fitted table").
//!
//!     cargo run --release -p brdf-fit --example table_holdout

use std::path::Path;

use brdf_core::{AnyModel, Brdf, ModelKind};
use brdf_fit::fitted_table::{trimmed_rms_rel, FittedTable, SHAPES};
use brdf_fit::holdout::{bundled, split, Neighbours, OUTER_FOLDS};
use brdf_fit::{Dataset, FitSettings, Point};
use rayon::prelude::*;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/measured");
    let sets = bundled(&root).expect("bundled data");
    let nodes = |s: &brdf_fit::fitted_table::FittedShape| format!("{}x{}x{}", s.theta_h, s.theta_d, s.phi_d);
    println!(
        "fitted table: grid chosen by cross-validation from {}\n",
        SHAPES
            .iter()
            .map(|s| format!("{} ({} bytes)", nodes(s), s.encoded_len()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!(
        "| data | points | fitted table | 4-NN | ratio | grids chosen | table coverage | seconds per fit |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let rows: Vec<(String, usize, f64, f64, String, f64, f64)> = sets
        .par_iter()
        .map(|(name, d)| {
            let (mut et, mut en, mut cov, mut secs) = (0.0, 0.0, 0.0, 0.0);
            let mut chosen: Vec<String> = Vec::new();
            for f in 0..OUTER_FOLDS {
                let (train, test) = (split(d, f, false), split(d, f, true));
                // The base `brdf select` puts under its table: the microfacet fit to the same
                // training points.
                let data = Dataset {
                    name: d.name.clone(),
                    points: train.clone(),
                };
                let fit = FitSettings::new(ModelKind::Ggx).fit(&data).expect("base fit");
                let p = fit.params_array().expect("base parameters");
                let base = AnyModel::<f64>::new(ModelKind::Ggx, &p[..4]).expect("base model");
                let base_f = |p: &Point| base.eval_angles(p.theta_i, p.theta_r, p.phi);
                let base_ln: Vec<f64> = train.iter().map(|p| base_f(p).ln()).collect();
                let t = std::time::Instant::now();
                let table = FittedTable::fit_cv(&train, &base_ln, &SHAPES).expect("table fit");
                secs += t.elapsed().as_secs_f64();
                cov += table.coverage();
                if !chosen.contains(&nodes(&table.shape)) {
                    chosen.push(nodes(&table.shape));
                }
                let rel = |pred: &dyn Fn(&Point) -> f64| -> Vec<f64> {
                    test.iter().map(|p| (pred(p) / p.brdf - 1.0).abs()).collect()
                };
                et += trimmed_rms_rel(&rel(&|p| base_f(p) * table.eval(p.theta_i, p.theta_r, p.phi)));
                let nn = Neighbours::new(&train);
                en += trimmed_rms_rel(&rel(&|p| nn.predict(p)));
            }
            let k = OUTER_FOLDS as f64;
            (
                name.clone(),
                d.points.len(),
                et / k,
                en / k,
                chosen.join(", "),
                cov / k,
                secs / k,
            )
        })
        .collect();
    let mut ratios = Vec::new();
    for (name, n, et, en, chosen, cov, secs) in &rows {
        ratios.push(et / en);
        println!(
            "| {name} | {n} | {et:.3} | {en:.3} | {:.2} | {chosen} | {:.0}% | {secs:.2} |",
            et / en,
            cov * 100.0
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
