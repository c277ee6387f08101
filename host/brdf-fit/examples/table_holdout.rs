//! Held-out error of the fitted table (`brdf_fit::fitted_table`) against the nearest-neighbour
//! yardstick on every bundled measurement: five outer folds, each fold predicted from the
//! other 80% (the table choosing its smoothness by its own inner cross-validation on those 80%
//! only), error = trimmed RMS of |f/measured - 1| (`fitted_table::trimmed_rms_rel`). "4-NN" is
//! inverse-distance interpolation of ln f between the 4 nearest training points in
//! (theta_h, theta_d, theta_i + theta_r, |theta_i - theta_r|), a yardstick any analyst can build
//! in ten lines. The figures of docs/model-comparison.md ("Fitted table").
//!
//!     cargo run --release -p brdf-fit --example table_holdout

use std::path::Path;

use brdf_fit::fitted_table::{coordinates, trimmed_rms_rel, FittedTable, DEFAULT_SHAPE};
use brdf_fit::import::{import, Channel, Format};
use brdf_fit::{Dataset, Point};
use rayon::prelude::*;

const OUTER_FOLDS: usize = 5;
const NEIGHBOURS: usize = 4;

fn features(p: &Point) -> [f64; 4] {
    let [th, td, _] = coordinates(p.theta_i, p.theta_r, p.phi);
    [th, td, p.theta_i + p.theta_r, (p.theta_i - p.theta_r).abs()]
}

/// 4-NN inverse-distance interpolation of ln f (exact hit: that point's value).
fn nearest(train: &[Point], q: &Point) -> f64 {
    let fq = features(q);
    let mut best: Vec<(f64, f64)> = Vec::with_capacity(NEIGHBOURS + 1);
    for p in train {
        let f = features(p);
        let d = f
            .iter()
            .zip(&fq)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        if best.len() < NEIGHBOURS || d < best[best.len() - 1].0 {
            best.push((d, p.brdf.ln()));
            best.sort_by(|a, b| a.0.total_cmp(&b.0));
            best.truncate(NEIGHBOURS);
        }
    }
    if best[0].0 < 1e-12 {
        return best[0].1.exp();
    }
    let (num, den) = best
        .iter()
        .fold((0.0, 0.0), |(n, d), &(dist, ly)| (n + ly / dist, d + 1.0 / dist));
    (num / den).exp()
}

/// Outer fold of point `i` (a fixed shuffle dealt round-robin).
fn fold(i: usize) -> usize {
    (brdf_core::accuracy::splitmix64(&mut (i as u64 ^ 0x0ddc_0ffe_e5ee_d000)) % OUTER_FOLDS as u64) as usize
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/measured");
    let mut sets: Vec<(String, Dataset)> = Vec::new();
    let cornell = root.join("cornell-medium-gloss-paints");
    for (file, paint) in [
        ("garnet_red_RGB.astm", "garnet"),
        ("krylon_blue_RGB.astm", "krylon"),
    ] {
        for (ch, c) in [(Channel::R, "R"), (Channel::G, "G"), (Channel::B, "B")] {
            let d = import(&cornell.join(file), Format::Cornell, ch).expect("bundled data");
            sets.push((format!("{paint} {c}"), d.datasets.into_iter().next().unwrap()));
        }
    }
    let ptfe = import(
        &root.join("ptfe-germer-nist/PTFE.data.csv"),
        Format::Nist,
        Channel::R,
    )
    .expect("bundled data");
    for d in ptfe.datasets {
        let wavelength = d.name.rsplit('=').next().unwrap_or("").trim_end_matches(']');
        sets.push((format!("ptfe {wavelength} um"), d));
    }
    let merl = import(
        &root.join("merl-aluminium-inplane/aluminum_brdf.csv"),
        Format::MerlInPlane,
        Channel::R,
    )
    .expect("bundled data");
    sets.push(("merl aluminium".into(), merl.datasets.into_iter().next().unwrap()));

    println!(
        "fitted table {}x{}x{} ({} bytes stored)\n",
        DEFAULT_SHAPE.theta_h,
        DEFAULT_SHAPE.theta_d,
        DEFAULT_SHAPE.phi_d,
        DEFAULT_SHAPE.encoded_len()
    );
    println!("| data | points | fitted table | 4-NN | ratio | table coverage | seconds per fit |");
    println!("|---|---|---|---|---|---|---|");
    let rows: Vec<(String, usize, f64, f64, f64, f64)> = sets
        .par_iter()
        .map(|(name, d)| {
            let (mut et, mut en, mut cov, mut secs) = (0.0, 0.0, 0.0, 0.0);
            for f in 0..OUTER_FOLDS {
                let pick = |held: bool| -> Vec<Point> {
                    d.points
                        .iter()
                        .enumerate()
                        .filter(|(i, _)| (fold(*i) == f) == held)
                        .map(|(_, p)| *p)
                        .collect()
                };
                let (train, test) = (pick(false), pick(true));
                let t = std::time::Instant::now();
                let table = FittedTable::fit_cv(&train, &vec![0.0; train.len()], DEFAULT_SHAPE).expect("table fit");
                secs += t.elapsed().as_secs_f64();
                cov += table.coverage();
                let rel = |pred: &dyn Fn(&Point) -> f64| -> Vec<f64> {
                    test.iter().map(|p| (pred(p) / p.brdf - 1.0).abs()).collect()
                };
                et += trimmed_rms_rel(&rel(&|p| table.eval(p.theta_i, p.theta_r, p.phi)));
                en += trimmed_rms_rel(&rel(&|p| nearest(&train, p)));
            }
            let k = OUTER_FOLDS as f64;
            (name.clone(), d.points.len(), et / k, en / k, cov / k, secs / k)
        })
        .collect();
    let mut ratios = Vec::new();
    for (name, n, et, en, cov, secs) in &rows {
        ratios.push(et / en);
        println!(
            "| {name} | {n} | {et:.3} | {en:.3} | {:.2} | {:.0}% | {secs:.2} |",
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
