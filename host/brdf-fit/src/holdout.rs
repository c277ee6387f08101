//! The held-out protocol of docs/model-comparison.md, shared by its two studies
//! (`cargo run --release -p brdf-fit --example table_holdout`, `cargo run --release -p
//! brdf-scene --example select_holdout`): the bundled measurements it runs on, five fixed
//! outer folds (each predicted from the other 80%), and the yardstick a representation must
//! beat: inverse-distance interpolation of `ln f` between the 4 nearest training points in
//! `(theta_h, theta_d, theta_i + theta_r, |theta_i - theta_r|)`, which any analyst can build
//! in ten lines. Errors are [`crate::fitted_table::trimmed_rms_rel`].

use std::path::Path;

use crate::data::DataError;
use crate::data::{Dataset, Point};
use crate::fitted_table::coordinates;
use crate::import::{import, Channel, Format};

/// Outer folds: each holds out 20% of the points.
pub const OUTER_FOLDS: usize = 5;

/// Neighbours of the yardstick.
pub const NEIGHBOURS: usize = 4;

/// The outer fold of point `i` (a fixed shuffle, the same for every study).
pub fn outer_fold(i: usize) -> usize {
    (brdf_core::accuracy::splitmix64(&mut (i as u64 ^ 0x0ddc_0ffe_e5ee_d000)) % OUTER_FOLDS as u64) as usize
}

/// The points of `d` in fold `f` (`held`) or outside it; every reading of a direction in the
/// fold of its first reading ([`crate::folds::first_of_direction`]), so that a replicate never
/// predicts its own copy.
pub fn split(d: &Dataset, f: usize, held: bool) -> Vec<Point> {
    let first = crate::folds::first_of_direction(&d.points);
    d.points
        .iter()
        .zip(first)
        .filter(|(_, i)| (outer_fold(*i) == f) == held)
        .map(|(p, _)| *p)
        .collect()
}

fn features(p: &Point) -> [f64; 4] {
    let [th, td, _] = coordinates(p.theta_i, p.theta_r, p.phi);
    [th, td, p.theta_i + p.theta_r, (p.theta_i - p.theta_r).abs()]
}

/// The median of `v` (the mean of the two middle values for an even count; NaN when empty):
/// the summary over bands or datasets of the held-out studies and of `brdf select` of a
/// spectral file.
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// `points` as the yardstick interpolates them: readings at or below zero raised to the
/// smallest positive reading among them (`ln f` has no value there).
pub fn raised_for_ln(points: &[Point]) -> Vec<Point> {
    let lowest = points
        .iter()
        .map(|p| p.brdf)
        .filter(|&v| v > 0.0)
        .fold(f64::INFINITY, f64::min);
    points
        .iter()
        .map(|p| Point {
            brdf: p.brdf.max(lowest),
            ..*p
        })
        .collect()
}

/// The yardstick's prediction at `q` from `train` (an exact hit: that point's value).
///
/// # Panics
/// If `train` is empty.
pub fn nearest_neighbours(train: &[Point], q: &Point) -> f64 {
    Neighbours::new(train).predict(q)
}

/// The yardstick's training points with their coordinates computed once, for predicting many
/// points (each [`Neighbours::predict`] is [`nearest_neighbours`]'s value, bit for bit: the
/// coordinates were recomputed for every training point of every query, about half the time
/// of `brdf select`'s yardstick).
#[derive(Clone, Debug)]
pub struct Neighbours {
    features: Vec<[f64; 4]>,
    ln: Vec<f64>,
}

impl Neighbours {
    /// The training points (readings above zero: see [`raised_for_ln`]).
    pub fn new(train: &[Point]) -> Neighbours {
        Neighbours {
            features: train.iter().map(features).collect(),
            ln: train.iter().map(|p| p.brdf.ln()).collect(),
        }
    }

    /// Inverse-distance interpolation of `ln f` between the [`NEIGHBOURS`] nearest training
    /// points (the first found of equally near ones), or the reading of a training point at
    /// the same coordinates.
    pub fn predict(&self, q: &Point) -> f64 {
        let fq = features(q);
        let mut best: Vec<(f64, f64)> = Vec::with_capacity(NEIGHBOURS + 1);
        for (f, &ln) in self.features.iter().zip(&self.ln) {
            let d = f
                .iter()
                .zip(&fq)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            if best.len() < NEIGHBOURS || d < best[best.len() - 1].0 {
                best.push((d, ln));
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
}

/// The bundled measurements under `root` (`data/measured`), one dataset per channel or
/// wavelength: Cornell's garnet red and krylon blue (R, G, B), NIST's PTFE at four
/// wavelengths, MERL's aluminium in plane.
pub fn bundled(root: &Path) -> Result<Vec<(String, Dataset)>, DataError> {
    let mut sets = Vec::new();
    let cornell = root.join("cornell-medium-gloss-paints");
    for (file, paint) in [
        ("garnet_red_RGB.astm", "garnet"),
        ("krylon_blue_RGB.astm", "krylon"),
    ] {
        for (ch, c) in [(Channel::R, "R"), (Channel::G, "G"), (Channel::B, "B")] {
            // Positive readings only: the nearest-neighbour baseline interpolates `ln f`, and
            // the figures of this study were measured on them.
            let d = import(&cornell.join(file), Format::Cornell, ch)?.positive_only();
            sets.extend(d.datasets.into_iter().map(|d| (format!("{paint} {c}"), d)));
        }
    }
    let ptfe = import(
        &root.join("ptfe-germer-nist/PTFE.data.csv"),
        Format::Nist,
        Channel::R,
    )?
    .positive_only();
    for d in ptfe.datasets {
        let wavelength = d
            .name
            .rsplit('=')
            .next()
            .unwrap_or("")
            .trim_end_matches(']')
            .to_owned();
        sets.push((format!("ptfe {wavelength} um"), d));
    }
    let merl = import(
        &root.join("merl-aluminium-inplane/aluminum_brdf.csv"),
        Format::MerlInPlane,
        Channel::R,
    )?
    .positive_only();
    sets.extend(
        merl.datasets
            .into_iter()
            .map(|d| ("merl aluminium".to_owned(), d)),
    );
    Ok(sets)
}
