//! Held-out error of band-by-band fits of the spectral Cornell paints
//! (`data/measured/cornell-spectral`, 31 bands each, every reading kept) against the
//! nearest-neighbour yardstick: five outer folds (`brdf_fit::holdout`), each band's fit to the
//! other 80% with the noise floor `brdf fit` estimates from them, error = trimmed RMS of
//! `|f - y| / sqrt(y^2 + S^2)` (`fitted_table::trimmed_rms_rel` of the floored relative error,
//! `S` the training fit's floor, 0 for a band without dark readings). "4-NN" interpolates
//! `ln f` between the 4 nearest training points (`holdout::nearest_neighbours`), its training
//! readings at or below zero raised to the band's smallest positive reading (`ln` has no value
//! there). The medians over bands are the figures of docs/model-comparison.md ("Spectral").
//!
//!     cargo run --release -p brdf-fit --example spectral_holdout [MODEL]

use std::path::Path;

use brdf_core::{AnyModel, Brdf, ModelKind};
use brdf_fit::fitted_table::trimmed_rms_rel;
use brdf_fit::holdout::{nearest_neighbours, split, OUTER_FOLDS};
use brdf_fit::import::{import, Format, Pick};
use brdf_fit::{Dataset, FitSettings, Point};
use rayon::prelude::*;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() {
    let model: ModelKind = std::env::args()
        .nth(1)
        .map(|m| m.parse().expect("a model name"))
        .unwrap_or(ModelKind::Six);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/measured/cornell-spectral");
    let started = std::time::Instant::now();
    for file in ["garnet_red.astm", "krylon_blue.astm"] {
        let imp = import(&root.join(file), Format::Cornell, Pick::default()).expect("bundled data");
        let rows: Vec<(String, usize, f64, f64)> = imp
            .datasets
            .par_iter()
            .map(|d| {
                let band = d
                    .name
                    .rsplit_once('=')
                    .map_or("", |(_, b)| b.trim_end_matches(']'));
                let dark = d.points.iter().filter(|p| p.brdf <= 0.0).count();
                let (mut em, mut en) = (0.0, 0.0);
                for f in 0..OUTER_FOLDS {
                    let (train, test) = (split(d, f, false), split(d, f, true));
                    let data = Dataset {
                        name: d.name.clone(),
                        points: train.clone(),
                    };
                    let fit = FitSettings::new(model).fit(&data).expect("band fit");
                    let s = fit.noise_floor.as_ref().map_or(0.0, |n| n.value);
                    let p = fit.params_array().expect("parameters");
                    let m = AnyModel::<f64>::new(model, &p[..model.param_count()]).expect("model");
                    let lowest = train
                        .iter()
                        .map(|p| p.brdf)
                        .filter(|&b| b > 0.0)
                        .fold(f64::INFINITY, f64::min);
                    let raised: Vec<Point> = train
                        .iter()
                        .map(|p| Point {
                            brdf: p.brdf.max(lowest),
                            ..*p
                        })
                        .collect();
                    let rel = |pred: &dyn Fn(&Point) -> f64| -> Vec<f64> {
                        test.iter()
                            .map(|p| ((pred(p) - p.brdf) / p.brdf.hypot(s)).abs())
                            .collect()
                    };
                    em += trimmed_rms_rel(&rel(&|p| m.eval_angles(p.theta_i, p.theta_r, p.phi)));
                    en += trimmed_rms_rel(&rel(&|p| nearest_neighbours(&raised, p)));
                }
                let k = OUTER_FOLDS as f64;
                (band.to_owned(), dark, em / k, en / k)
            })
            .collect();
        println!("{file}, {model}: held-out error per band (readings at or below zero)");
        println!("| band (um) | dark | {model} | 4-NN | ratio |");
        println!("|---|---|---|---|---|");
        for (band, dark, em, en) in &rows {
            println!(
                "| {band} | {dark} | {:.1}% | {:.1}% | {:.2} |",
                100.0 * em,
                100.0 * en,
                em / en
            );
        }
        let med = |k: usize| median(rows.iter().map(|r| if k == 0 { r.2 } else { r.3 }).collect());
        let better = rows.iter().filter(|r| r.2 <= r.3).count();
        println!(
            "median over bands: {model} {:.1}%, 4-NN {:.1}%; {better} of {} bands at least as good as 4-NN\n",
            100.0 * med(0),
            100.0 * med(1),
            rows.len()
        );
    }
    println!("{:.1} s", started.elapsed().as_secs_f64());
}
