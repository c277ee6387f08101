//! Held-out error of spectral fits of the Cornell paints (`data/measured/cornell-spectral`,
//! 31 bands each, every reading kept): one shape shared by all bands (`--bands shared`,
//! `brdf_fit::spectral`), each band free (`brdf fit`'s default), and the nearest-neighbour
//! yardstick. Five outer folds (`brdf_fit::holdout`, the same directions held out in every
//! band), the fits to the other 80% with the noise floor `brdf fit` estimates from them,
//! error = trimmed RMS of `|f - y| / sqrt(y^2 + S^2)` (`fitted_table::trimmed_rms_rel` of the
//! floored relative error, `S` the floor estimated from the whole band, 0 for a band without
//! dark readings). "4-NN" interpolates
//! `ln f` between the 4 nearest training points (`holdout::nearest_neighbours`), its training
//! readings at or below zero raised to the band's smallest positive reading (`ln` has no value
//! there). The medians over bands are the figures of docs/model-comparison.md ("Spectral").
//!
//!     cargo run --release -p brdf-fit --example spectral_holdout [MODEL]

use std::path::Path;

use brdf_core::{AnyModel, Brdf, ModelKind};
use brdf_fit::fitted_table::trimmed_rms_rel;
use brdf_fit::holdout::{median, raised_for_ln, split, Neighbours, OUTER_FOLDS};
use brdf_fit::import::{import, Format, Pick};
use brdf_fit::noise::{floor_for, FloorChoice};
use brdf_fit::spectral::BandShape;
use brdf_fit::{fit_streamed, Dataset, FitSettings, Point};
use rayon::prelude::*;

fn main() {
    let model: ModelKind = std::env::args()
        .nth(1)
        .map(|m| m.parse().expect("a model name"))
        .unwrap_or(ModelKind::Six);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/measured/cornell-spectral");
    let started = std::time::Instant::now();
    let settings = FitSettings {
        bands: BandShape::Shared,
        ..FitSettings::new(model)
    };
    for file in ["garnet_red.astm", "krylon_blue.astm"] {
        let bands = import(&root.join(file), Format::Cornell, Pick::default())
            .expect("bundled data")
            .datasets;
        let n = bands.len();
        // The measurement's noise floor, band by band, for the error metric of every fold.
        let floors: Vec<f64> = bands
            .iter()
            .map(|d| {
                floor_for(FloorChoice::Auto, &d.points)
                    .expect("a floor")
                    .map_or(0.0, |f| f.value)
            })
            .collect();
        let (mut shared, mut own, mut knn) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let mut shared_seconds = 0.0;
        for f in 0..OUTER_FOLDS {
            let train: Vec<Dataset> = bands
                .iter()
                .map(|d| Dataset {
                    name: d.name.clone(),
                    points: split(d, f, false),
                })
                .collect();
            let test: Vec<Vec<Point>> = bands.iter().map(|d| split(d, f, true)).collect();
            let t = std::time::Instant::now();
            let fits_shared = fit_streamed(&settings, &train, |_, _| {});
            shared_seconds += t.elapsed().as_secs_f64();
            let independent = FitSettings {
                bands: BandShape::Independent,
                ..settings
            };
            let fits_own = fit_streamed(&independent, &train, |_, _| {});
            let errors: Vec<(f64, f64, f64)> = (0..n)
                .into_par_iter()
                .map(|b| {
                    let s = floors[b];
                    let rel = |pred: &dyn Fn(&Point) -> f64| -> f64 {
                        let e: Vec<f64> = test[b]
                            .iter()
                            .map(|p| ((pred(p) - p.brdf) / p.brdf.hypot(s)).abs())
                            .collect();
                        trimmed_rms_rel(&e)
                    };
                    let of = |r: &brdf_fit::report::FitReport| {
                        let p = r.params_array().expect("parameters");
                        AnyModel::<f64>::new(model, &p[..model.param_count()]).expect("model")
                    };
                    let ms = of(fits_shared[b].as_ref().expect("shared fit"));
                    let mo = of(fits_own[b].as_ref().expect("band fit"));
                    let raised = Neighbours::new(&raised_for_ln(&train[b].points));
                    (
                        rel(&|p| ms.eval_angles(p.theta_i, p.theta_r, p.phi)),
                        rel(&|p| mo.eval_angles(p.theta_i, p.theta_r, p.phi)),
                        rel(&|p| raised.predict(p)),
                    )
                })
                .collect();
            for (b, (es, eo, en)) in errors.into_iter().enumerate() {
                shared[b] += es / OUTER_FOLDS as f64;
                own[b] += eo / OUTER_FOLDS as f64;
                knn[b] += en / OUTER_FOLDS as f64;
            }
        }
        println!("{file}, {model}: held-out error per band");
        println!("| band (um) | readings <= 0 | floor (1/sr) | shared shape | each band free | 4-NN |");
        println!("|---|---|---|---|---|---|");
        for b in 0..n {
            let band = bands[b]
                .name
                .rsplit_once('=')
                .map_or("", |(_, v)| v.trim_end_matches(']'));
            let dark = bands[b].points.iter().filter(|p| p.brdf <= 0.0).count();
            println!(
                "| {band} | {dark} | {:.2e} | {:.1}% | {:.1}% | {:.1}% |",
                floors[b],
                100.0 * shared[b],
                100.0 * own[b],
                100.0 * knn[b]
            );
        }
        println!(
            "median over bands: shared {:.1}%, each band free {:.1}%, 4-NN {:.1}%; shared at least as good as 4-NN in {} of {n} bands, as each band free in {}; shared fit of {n} bands {:.1} s per fold\n",
            100.0 * median(shared.clone()),
            100.0 * median(own.clone()),
            100.0 * median(knn.clone()),
            (0..n).filter(|&b| shared[b] <= knn[b]).count(),
            (0..n).filter(|&b| shared[b] <= own[b]).count(),
            shared_seconds / OUTER_FOLDS as f64
        );
    }
    println!("{:.1} s", started.elapsed().as_secs_f64());
}
