//! What a fitted table predicts where its measurements did not reach, by its base model: each
//! bundled measurement with directions off the plane of incidence is split into its in-plane
//! readings (the fit's) and the rest (the test's), as a user with an in-plane goniometer would
//! have it. The base model is fitted to the in-plane readings, the table over it as `brdf
//! select` fits it (`brdf_scene::represent::table_rung_over`), and both predict the
//! off-plane readings in f64 (trimmed RMS of `|f/measured - 1|`, as every held-out figure in
//! docs/model-comparison.md), beside the 4-nearest-neighbour yardstick of the same training
//! points. The figures of docs/model-comparison.md ("Off the measured plane").
//!
//!     cargo run --release -p brdf-scene --example table_extrapolation

use std::path::Path;

use brdf_core::fitted::{Corrected, FittedTable};
use brdf_core::{AnyModel, Brdf, ModelKind};
use brdf_fit::fitted_table::trimmed_rms_rel;
use brdf_fit::holdout::{bundled, Neighbours};
use brdf_fit::{Dataset, FitRequest, FitSettings, Point};
use brdf_scene::represent::{table_rung_over, TABLE_MIN_POINTS};

/// In the plane of incidence: the azimuth within 1° of 0 or 180°, or either direction within
/// 0.5° of the normal (where the azimuth means nothing).
fn in_plane(p: &Point) -> bool {
    let (one, half) = (1f64.to_radians(), 0.5f64.to_radians());
    p.phi.sin().abs() < one.sin() || p.theta_i < half || p.theta_r < half
}

/// Held-out error of `kind`'s fit to `train` alone and with its table, at `test`.
fn errors(kind: ModelKind, train: &Dataset, test: &[Point]) -> (f64, f64) {
    let settings = FitSettings::from_options(&FitRequest::new(kind)).expect("default settings");
    let fit = settings.fit(train).expect("base fit");
    let params = fit.params_array().expect("parameters");
    let model = AnyModel::<f64>::new(kind, &params[..kind.param_count()]).expect("model");
    // The bundled datasets this runs on have no reading at or below zero: no noise floor.
    let (rung, _) = table_rung_over(kind, train, &params, 0.0).expect("fitted table");
    let table = Corrected {
        base: model,
        table: FittedTable::new(rung.table.as_deref().expect("table bytes")).expect("table"),
    };
    let err = |m: &dyn Fn(&Point) -> f64| {
        trimmed_rms_rel(
            &test
                .iter()
                .map(|p| (m(p) / p.brdf - 1.0).abs())
                .collect::<Vec<_>>(),
        )
    };
    (
        err(&|p| model.eval_angles(p.theta_i, p.theta_r, p.phi)),
        err(&|p| table.eval_angles(p.theta_i, p.theta_r, p.phi)),
    )
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/measured");
    let sets = bundled(&root).expect("bundled data");
    println!(
        "| data | in plane (fit) | off plane (test) | lambert | lambert + table | ggx | ggx + table | 4-NN |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (name, d) in &sets {
        let (train, test): (Vec<Point>, Vec<Point>) = d.points.iter().partition(|p| in_plane(p));
        if test.is_empty() || train.len() < TABLE_MIN_POINTS {
            continue;
        }
        let train = Dataset {
            name: d.name.clone(),
            points: train,
        };
        let (l, lt) = errors(ModelKind::Lambert, &train, &test);
        let (g, gt) = errors(ModelKind::Ggx, &train, &test);
        let knn = Neighbours::new(&train.points);
        let nn = trimmed_rms_rel(
            &test
                .iter()
                .map(|p| (knn.predict(p) / p.brdf - 1.0).abs())
                .collect::<Vec<_>>(),
        );
        println!(
            "| {name} | {} | {} | {l:.3} | {lt:.3} | {g:.3} | {gt:.3} | {nn:.3} |",
            train.points.len(),
            test.len()
        );
    }
}
