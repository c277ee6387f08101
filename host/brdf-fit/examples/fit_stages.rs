//! Where a `brdf fit` process spends its time on one dataset, stage by stage, in one process:
//! loading, preparing, the fit, the uncertainty with its profile refits, the energy check, the
//! whole report; and one pass of the cost and of the normal equations (ns per point).
//!
//!     cargo run --release -p brdf-fit --example fit_stages -- DATA.csv

use std::time::Instant;

use brdf_core::{AnyModel, ModelKind, MAX_PARAMS};
use brdf_fit::report::{distinct_rows, energy, report, uncertainty};
use brdf_fit::{fit, load_csv, FitOptions, LoadOptions, Problem, Residual};

fn main() {
    let path = std::env::args().nth(1).expect("usage: fit_stages DATA.csv");
    let t = Instant::now();
    let loaded = load_csv(std::path::Path::new(&path), LoadOptions::default()).expect("readable data");
    let data = &loaded.datasets[0];
    let load = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, data);
    let prepare = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let outcome = fit(&problem, &FitOptions::default());
    let fitted = t.elapsed().as_secs_f64();
    let t = Instant::now();
    std::hint::black_box(uncertainty(
        &problem,
        &outcome,
        distinct_rows(data, problem.kind()),
    ));
    let unc = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let model = AnyModel::new(ModelKind::Six, &outcome.params[..6]).expect("fitted parameters are valid");
    std::hint::black_box(energy(&model, &data.incidences()));
    let en = t.elapsed().as_secs_f64();
    let t = Instant::now();
    std::hint::black_box(report(data, &problem, &outcome, &FitOptions::default()));
    let rep = t.elapsed().as_secs_f64();
    let (mut jtj, mut jtr) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
    let per_point = |f: &mut dyn FnMut()| {
        let t = Instant::now();
        for _ in 0..10 {
            f();
        }
        t.elapsed().as_secs_f64() / 10.0 * 1e9 / problem.len() as f64
    };
    let ne = per_point(&mut || {
        std::hint::black_box(problem.normal_equations(&outcome.q, &mut jtj, &mut jtr));
    });
    let cost = per_point(&mut || {
        std::hint::black_box(problem.cost(&outcome.q));
    });
    println!(
        "{} points: load {load:.4} s, prepare {prepare:.4} s, fit {fitted:.4} s, uncertainty and profiles {unc:.4} s, \
         energy {en:.4} s, whole report {rep:.4} s; one pass: normal equations {ne:.1} ns/point, cost {cost:.1} ns/point",
        problem.len()
    );
}
