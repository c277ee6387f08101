//! Range profiles: each aspect's σ spread along the line of sight, as a ranging seeker
//! sees its return spread in time.
//!
//! A point `p` of the target lies at range `-(p · r)` beyond the plane through the mesh
//! origin perpendicular to the line of sight, `r` the unit vector towards the receiver
//! (monostatic); bistatic, at half the extra path, `-(p · r + p · s) / 2`, `s` towards the
//! source. A facet's σ (the same BRDF over its whole area in the far field, seen whole or not
//! at all as in [`crate::lrcs`]) is split over range bins by the share of its area in each:
//! range is linear over a triangle, so the share below `t` is quadratic in `t` on either side
//! of the middle vertex ([`area_below`]), and the bins of an aspect sum to its σ (to rounding).
//! Bins are fixed in range, `[k b, (k + 1) b)` for bin width `b`, so the profiles of
//! different aspects line up; each aspect lists the bins from its nearest facet seen to its
//! farthest. A pulse of full width at half maximum `W` (Gaussian) is optional: each bin's σ
//! is spread over the bins by the pulse's share in each, which keeps the sum.
//!
//! Memory: the profile of every aspect, `8 (bins + 4 W / b)` bytes each; the bins of one
//! aspect are at most [`MAX_BINS`] (the target's extent over the bin width), the bins of a
//! sweep at most [`MAX_SWEEP_BINS`], both checked before the sweep.

use rayon::prelude::*;

use crate::eval::{eval_batch, Evaluator};
use crate::queries::aspect_queries;
use crate::scene::{Mode, Scene};

/// Most range bins of one aspect (the target's extent over the bin width, plus a pulse's
/// tails).
pub const MAX_BINS: usize = 100_000;

/// Farthest bin from the mesh origin, in bins: below 2^52, where `(k + 0.5) b` still tells
/// neighbouring bins apart.
pub const MAX_BIN_INDEX: f64 = 4.5e15;

/// Most range bins over a whole sweep (aspects times the bins of each): 160 MB of σ values.
pub const MAX_SWEEP_BINS: usize = 20_000_000;

/// Tails of the pulse kept each side, in full widths at half maximum: beyond 3 FWHM (7.1
/// standard deviations) a Gaussian holds less than 1e-12 of its area.
const PULSE_TAIL_FWHM: f64 = 3.0;

/// How to bin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfileOptions {
    /// Bin width along the line of sight, m.
    pub bin_m: f64,
    /// A Gaussian pulse's full width at half maximum, m, or none.
    pub pulse_m: Option<f64>,
}

/// One aspect's profile.
#[derive(Clone, Debug, PartialEq)]
pub struct AspectProfile {
    /// Receiver azimuth, degrees.
    pub azimuth: f64,
    /// Receiver elevation, degrees.
    pub elevation: f64,
    /// Index `k` of the first bin, `[k b, (k + 1) b)`.
    pub first_bin: i64,
    /// σ per bin, m², from `first_bin` on (empty when nothing is seen).
    pub sigma: Vec<f64>,
}

impl AspectProfile {
    /// Centre of bin `j` of this aspect (its `j`-th value), m.
    pub fn range_m(&self, j: usize, bin_m: f64) -> f64 {
        (self.first_bin as f64 + j as f64 + 0.5) * bin_m
    }

    /// [`AspectProfile::range_m`] rounded to a millionth of a bin in decimal significant digits,
    /// for printing (-1.95, not -1.9500000000000002): neighbouring bins stay apart at every
    /// bin width and range (a fixed nanometre merged bins of 2e-10 m and overflowed at 1e300).
    pub fn range_label(&self, j: usize, bin_m: f64) -> f64 {
        let r = self.range_m(j, bin_m);
        if r == 0.0 {
            return r;
        }
        let digits = ((r.abs() / bin_m).log10().ceil().max(0.0) + 7.0).min(17.0) as usize;
        format!("{:.*e}", digits - 1, r).parse().unwrap_or(r)
    }
}

/// Why a profile cannot be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ProfileError {
    /// A bin width or pulse that is not a positive finite length.
    #[error("{0}")]
    Option(String),
    /// More bins than the limits allow.
    #[error("{0}")]
    TooManyBins(String),
}

/// Share of a triangle's area at range below `t`, its vertices at ranges `a <= b <= c`.
pub fn area_below(t: f64, [a, b, c]: [f64; 3]) -> f64 {
    if t <= a {
        0.0
    } else if t >= c {
        1.0
    } else if t <= b {
        // a < t <= b, so b > a and c > a.
        (t - a) * (t - a) / ((b - a) * (c - a))
    } else {
        // b < t < c.
        1.0 - (c - t) * (c - t) / ((c - b) * (c - a))
    }
}

/// The range of point `p` at an aspect whose receiver and source directions are `r` and `s`.
fn range_of(p: [f64; 3], r: [f64; 3], s: [f64; 3]) -> f64 {
    let dot = |u: [f64; 3]| p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
    -0.5 * (dot(r) + dot(s))
}

/// Checks `options` against `scene`: one wavelength, a bin width and pulse that are positive
/// finite lengths, no more bins than [`MAX_BINS`] per aspect and [`MAX_SWEEP_BINS`] over the
/// sweep, and a target no farther than [`MAX_BIN_INDEX`] bins from the mesh origin.
pub fn check(scene: &Scene, options: &ProfileOptions) -> Result<(), ProfileError> {
    scene
        .one_wavelength("a range profile")
        .map_err(ProfileError::Option)?;
    let b = options.bin_m;
    if !(b.is_finite() && b > 0.0) {
        return Err(ProfileError::Option(format!(
            "--bin-m {b:?}: not a length above 0 (m)"
        )));
    }
    if let Some(w) = options.pulse_m {
        if !(w.is_finite() && w > 0.0) {
            return Err(ProfileError::Option(format!(
                "--pulse-m {w:?}: not a length above 0 (m)"
            )));
        }
    }
    // The target's extent bounds the range spread of any aspect.
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for v in &scene.mesh.vertices {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let extent = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
    let tails = options.pulse_m.map_or(0.0, |w| 2.0 * PULSE_TAIL_FWHM * w);
    let bins = ((extent + tails) / b).ceil() + 2.0;
    if bins > MAX_BINS as f64 {
        let with_tails = if tails > 0.0 {
            format!(" and the pulse's tails {tails:.4} m more")
        } else {
            String::new()
        };
        return Err(ProfileError::TooManyBins(format!(
            "--bin-m {b:?}: the target spans up to {extent:.4} m{with_tails}, {bins:.0} bins per aspect: \
             more than {MAX_BINS}; give a wider bin"
        )));
    }
    // Bin indices are counted from the mesh origin: a target far from it in bins of this width
    // would lose them to rounding (and overflow the count).
    let far = scene
        .mesh
        .vertices
        .iter()
        .map(|v| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt())
        .fold(0.0f64, f64::max)
        + tails;
    if far / b > MAX_BIN_INDEX {
        return Err(ProfileError::TooManyBins(format!(
            "--bin-m {b:?}: the target lies up to {far:.4e} m from the mesh origin, {:.1e} bins away: \
             more than {MAX_BIN_INDEX:e}, where bins no longer resolve; move the mesh near the origin \
             or give a wider bin",
            far / b
        )));
    }
    let total = bins * scene.aspects().len() as f64;
    if total > MAX_SWEEP_BINS as f64 {
        return Err(ProfileError::TooManyBins(format!(
            "{} aspects x up to {bins:.0} bins: more than {MAX_SWEEP_BINS} bins over the sweep; give a \
             wider bin or fewer aspects",
            scene.aspects().len()
        )));
    }
    Ok(())
}

/// The range profile of every aspect with each material's exact model (f64), in parallel over
/// aspects; `progress` once per aspect. The bins of an aspect sum to its σ of
/// [`crate::lrcs::lrcs`] (to rounding).
pub fn profile(
    scene: &Scene,
    options: &ProfileOptions,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<AspectProfile>, ProfileError> {
    check(scene, options)?;
    let models: Vec<Evaluator> = scene.materials.iter().map(|m| m.evaluator()).collect();
    let b = options.bin_m;
    let mode = scene.sensor.mode;
    Ok(scene
        .aspects()
        .par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(stack, values), a| {
                let r = a.receiver();
                let s = match mode {
                    Mode::Monostatic => r,
                    Mode::Bistatic { .. } => a.source(mode),
                };
                // Each facet seen: its σ and the ranges of its corners.
                let mut parts: Vec<(f64, [f64; 3])> = Vec::new();
                for (batch, model) in aspect_queries(scene, a, stack).iter().zip(&models) {
                    values.clear();
                    values.resize(batch.len(), 0.0);
                    eval_batch(
                        model,
                        &batch.cos_theta_i,
                        &batch.cos_theta_r,
                        &batch.cos_phi,
                        values,
                    );
                    for k in 0..batch.len() {
                        let f = &scene.mesh.facets[batch.facet[k] as usize];
                        let mut t = f
                            .vertices
                            .map(|v| range_of(scene.mesh.vertices[v as usize], r, s));
                        t.sort_by(f64::total_cmp);
                        parts.push((batch.weight[k] * values[k], t));
                    }
                }
                progress();
                let mut out = AspectProfile {
                    azimuth: a.azimuth_deg,
                    elevation: a.elevation_deg,
                    first_bin: 0,
                    sigma: Vec::new(),
                };
                if parts.is_empty() {
                    return out;
                }
                // A facet's bins: from the one holding its nearest corner to the one whose
                // upper edge its farthest reaches (a corner on an edge adds no empty bin).
                let bins = |t: &[f64; 3]| {
                    let k0 = (t[0] / b).floor() as i64;
                    (k0, ((t[2] / b).ceil() as i64 - 1).max(k0))
                };
                let first = parts.iter().map(|p| bins(&p.1).0).min().unwrap_or(0);
                let last = parts.iter().map(|p| bins(&p.1).1).max().unwrap_or(0);
                let mut sigma = vec![0.0; (last - first + 1) as usize];
                for (value, t) in &parts {
                    let (k0, k1) = bins(t);
                    if k0 == k1 {
                        sigma[(k0 - first) as usize] += value;
                        continue;
                    }
                    let mut below = 0.0;
                    for k in k0..=k1 {
                        let upto = if k == k1 {
                            1.0
                        } else {
                            area_below((k + 1) as f64 * b, *t)
                        };
                        sigma[(k - first) as usize] += value * (upto - below);
                        below = upto;
                    }
                }
                out.first_bin = first;
                out.sigma = match options.pulse_m {
                    None => sigma,
                    Some(w) => {
                        let (shifted, sigma) = convolve(first, &sigma, b, w);
                        out.first_bin = shifted;
                        sigma
                    }
                };
                out
            },
        )
        .collect())
}

/// `sigma` (bins from `first`) spread by a Gaussian pulse of full width at half maximum `w`:
/// each bin's value goes to the bins by the pulse's area in each, centred on the bin's
/// centre. Returns the new first bin and the values.
fn convolve(first: i64, sigma: &[f64], b: f64, w: f64) -> (i64, Vec<f64>) {
    let sd = w / (2.0 * (2.0 * std::f64::consts::LN_2).sqrt());
    let pad = (PULSE_TAIL_FWHM * w / b).ceil() as i64 + 1;
    let start = first - pad;
    let n = sigma.len() + 2 * pad as usize;
    let mut out = vec![0.0; n];
    // Normal CDF.
    let cdf = |x: f64| 0.5 * (1.0 + libm::erf(x / (sd * std::f64::consts::SQRT_2)));
    // The pulse's share in the bin `o` bins away from the one it is centred on: the same for
    // every bin (bins are uniform), so computed once.
    let share: Vec<f64> = (-pad..=pad)
        .map(|o| cdf((o as f64 + 0.5) * b) - cdf((o as f64 - 0.5) * b))
        .collect();
    for (j, &v) in sigma.iter().enumerate() {
        if v == 0.0 {
            continue;
        }
        for (o, w) in share.iter().enumerate() {
            out[j + o] += v * w;
        }
    }
    (start, out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Printed centres were rounded to a nanometre: bins of 2e-10 m shared labels, and at a
    /// bin of 1e300 m the rounding overflowed to -inf.
    #[test]
    fn range_labels_keep_bins_apart_at_every_scale() {
        for (first_bin, bin) in [
            (-3, 0.1),
            (0, 2e-10),
            (-1, 1e300),
            (4_000_000_000_000, 0.25),
            (-7, 1e-300),
        ] {
            let p = AspectProfile {
                azimuth: 0.0,
                elevation: 0.0,
                first_bin,
                sigma: vec![1.0; 6],
            };
            let labels: Vec<f64> = (0..6).map(|j| p.range_label(j, bin)).collect();
            for (j, l) in labels.iter().enumerate() {
                let exact = p.range_m(j, bin);
                assert!(
                    l.is_finite() && (l - exact).abs() <= 1e-6 * bin,
                    "{bin}: {l} against {exact}"
                );
            }
            assert!(labels.windows(2).all(|w| w[0] < w[1]), "{bin}: {labels:?}");
        }
        let p = AspectProfile {
            azimuth: 0.0,
            elevation: 0.0,
            first_bin: -20,
            sigma: vec![1.0],
        };
        assert_eq!(p.range_label(0, 0.1).to_string(), "-1.95");
    }

    #[test]
    fn a_triangles_area_below_a_range_is_quadratic_on_either_side_of_its_middle_vertex() {
        let t = [0.0, 1.0, 2.0];
        assert_eq!(area_below(-1.0, t), 0.0);
        assert_eq!(area_below(0.5, t), 0.125);
        assert_eq!(area_below(1.0, t), 0.5);
        assert_eq!(area_below(1.5, t), 0.875);
        assert_eq!(area_below(3.0, t), 1.0);
        // Two corners at one range: all the area on one side of the middle.
        assert_eq!(area_below(0.5, [0.0, 0.0, 1.0]), 0.75);
        assert_eq!(area_below(0.5, [0.0, 1.0, 1.0]), 0.25);
    }

    #[test]
    fn a_pulse_spreads_a_bin_and_keeps_its_sum() {
        let (start, out) = convolve(10, &[0.0, 2.0, 0.0], 0.1, 0.3);
        let sum: f64 = out.iter().sum();
        assert!((sum - 2.0).abs() < 1e-12, "{sum}");
        // Symmetric about the bin it came from (bin 11).
        let centre = (11 - start) as usize;
        for d in 1..5 {
            assert!((out[centre - d] - out[centre + d]).abs() < 1e-12);
        }
        // Half its height at half the full width from the centre, of the continuous pulse.
        assert!(out[centre] > out[centre + 1] && out[centre + 1] > out[centre + 2]);
    }
}
