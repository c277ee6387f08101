//! Dark readings and the noise floor of the relative residual.
//!
//! A gonioreflectometer's reading is the true BRDF `m` plus noise with a part proportional
//! to it (`sigma_r m`: source drift, calibration) and a part that is not (`sigma_a`: detector
//! dark noise, stray light). Where a surface is dark — absorbing bands near 400 and 700 nm,
//! far from the mirror peak — readings scatter around zero and some are at or below it. They
//! are measurements, not invalid rows: dropping them keeps only the readings that noise
//! pushed up and biases a dark band upward. The relative residual `(f - m) / m` is undefined
//! there; with a **noise floor** `S` it becomes
//!
//! ```text
//! r = (f - m) / sqrt(m^2 + S^2)
//! ```
//!
//! the relative error above `S`, the absolute error in units of `S` below it. This is the
//! residual `(f - m) / sigma` of the noise model `sigma^2 = (sigma_r m)^2 + sigma_a^2`,
//! times `sigma_r`, when `S = sigma_a / sigma_r`: every point counts by its noise. `S` is given
//! (`--noise-floor`, `noise_floor=`) or estimated per dataset ([`estimate`]); a dataset with
//! no reading at or below zero gets no floor, and its fit is exactly the fit without one.

use serde::{Deserialize, Serialize};

use crate::data::Point;

/// An estimated floor above more than this share of the readings, from dark readings fewer
/// than [`FEW_DARK`] of them, is doubted in [`NoiseFloor::note`]: a band whose readings lie
/// mostly at the noise has many at or below zero (Krylon Blue at 400 nm: 194 of 1,439, the
/// floor above 66% of the band, rightly), while a floor above most readings from a handful
/// of zeros says the zeros are something else — Krylon Blue's bright bands
/// (430–530 nm) have three readings at 0.000000 each, whose mirror images (the three smallest
/// positive readings, RMS 0.0009 to 0.033 1/sr) are far above the darkest directions' noise:
/// the estimated floors (0.018 to 0.67 1/sr) lie above 60–99% of each band, so the band is
/// fitted almost by absolute error.
pub const FLOOR_ABOVE_MOST: f64 = 0.5;

/// An estimated floor above this share of the readings is doubted however many are dark:
/// nearly every reading then counts by absolute error, and the floored relative errors look
/// small however far off a fit is (three zeros among 60 readings of 1% noise gave a floor 20
/// times the signal, and `brdf select` reported 0.95% for a fit 5% low).
pub const FLOOR_ABOVE_ALL: f64 = 0.9;

/// See [`FLOOR_ABOVE_MOST`]: dark readings fewer than 1% of a dataset's.
pub const FEW_DARK: f64 = 0.01;

/// The relative noise `sigma_r` assumed when the floor is estimated: 5%. The Cornell paints'
/// held-out points are predicted to 5–9% by a four-nearest-neighbour interpolant of their
/// other points (docs/model-comparison.md), which bounds their relative scatter from above;
/// 5% is the lower end, so the floor errs high (dark points count a little less).
pub const ASSUMED_RELATIVE_NOISE: f64 = 0.05;

/// The relative error of a prediction `f` of a reading `y` over the noise floor `floor`
/// (1/sr): `(f - y) / sqrt(y^2 + floor^2)`, relative above the floor and absolute (in units of
/// the floor) below it; the plain relative error `(f - y) / y` with no floor. Every relative
/// error of a fit, its report and `brdf select` is this one.
pub fn floored_relative(f: f64, y: f64, floor: f64) -> f64 {
    (f - y) / y.hypot(floor)
}

/// How a fit chooses its noise floor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum FloorChoice {
    /// Estimated per dataset when it has readings at or below zero ([`estimate`]); none
    /// otherwise (the default).
    #[default]
    Auto,
    /// This floor, 1/sr, for every dataset; 0 for none (readings at or below zero are then
    /// refused by relative residuals, naming their line).
    Given(f64),
}

/// The floor a fit used, as its report states it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoiseFloor {
    /// The floor `S`, 1/sr.
    pub value: f64,
    /// `"given"` or `"estimated"`.
    pub source: String,
    /// Estimated absolute noise `sigma_a`, 1/sr (estimated floors only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_a: Option<f64>,
    /// The relative noise assumed, [`ASSUMED_RELATIVE_NOISE`] (estimated floors only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relative_noise: Option<f64>,
    /// Readings at or below zero.
    pub at_or_below_zero: usize,
    /// Readings at or below the floor (they count by absolute error more than relative).
    pub at_or_below_floor: usize,
    /// A doubt about an estimated floor: it lies above most readings though few are dark
    /// ([`FLOOR_ABOVE_MOST`]), as when the readings at zero are dropouts in a bright band.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// An estimate of the absolute noise from the readings themselves: `None` when no reading is
/// at or below zero (no floor is needed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// `sigma_a`, 1/sr: the root mean square of the `k` smallest positive readings, where `k`
    /// is the number of readings at or below zero. Noise centred on a value near zero puts
    /// as many readings just above zero as at or below it; the ones above mirror the ones
    /// below, whose values may have been clipped to 0 (Cornell's files print every negative
    /// reading as 0.000000) and so cannot be used themselves. Exact in the mean for noise
    /// centred on zero (tested); where the dark readings are the low tail of a signal above
    /// zero it is too small (a uniform surface read with noise of 2/3 of its value: 3.7 times
    /// too small), and the floor `sigma_a /` [`ASSUMED_RELATIVE_NOISE`] still lies above
    /// those readings (3.6 times the signal there), so they count by absolute error.
    pub sigma_a: f64,
    /// Readings at or below zero (`k`).
    pub at_or_below_zero: usize,
}

/// Why no floor can be estimated.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum NoiseError {
    /// Every reading is at or below zero: nothing to fit, and no scale to estimate.
    #[error("all {0} readings are at or below zero: there is no signal to fit")]
    NoSignal(usize),
}

/// Estimates the absolute noise of `points` (see [`Estimate::sigma_a`]).
pub fn estimate(points: &[Point]) -> Result<Option<Estimate>, NoiseError> {
    let k = points.iter().filter(|p| p.brdf <= 0.0).count();
    if k == 0 {
        return Ok(None);
    }
    let mut positive: Vec<f64> = points.iter().map(|p| p.brdf).filter(|&b| b > 0.0).collect();
    if positive.is_empty() {
        return Err(NoiseError::NoSignal(k));
    }
    positive.sort_by(f64::total_cmp);
    let mirror = &positive[..k.min(positive.len())];
    let sigma_a = (mirror.iter().map(|b| b * b).sum::<f64>() / mirror.len() as f64).sqrt();
    Ok(Some(Estimate {
        sigma_a,
        at_or_below_zero: k,
    }))
}

/// The floor `choice` gives `points`, and how the report states it (`None`: no floor).
pub fn floor_for(choice: FloorChoice, points: &[Point]) -> Result<Option<NoiseFloor>, NoiseError> {
    let at_or_below = |s: f64| points.iter().filter(|p| p.brdf <= s).count();
    let zero = at_or_below(0.0);
    Ok(match choice {
        FloorChoice::Given(s) if s > 0.0 => {
            let below = at_or_below(s);
            let share = below as f64 / points.len().max(1) as f64;
            Some(NoiseFloor {
                value: s,
                source: "given".to_owned(),
                sigma_a: None,
                relative_noise: None,
                at_or_below_zero: zero,
                at_or_below_floor: below,
                // A floor above most readings weighs them by absolute error in units of the
                // floor: their relative errors then look small however far off the fit is.
                note: (share > FLOOR_ABOVE_MOST).then(|| {
                    format!(
                        "the given noise floor {} 1/sr lies above {:.0}% of the readings: the fit weighs \
                         this dataset almost by absolute error in units of the floor, and its relative \
                         errors look small however far off it is",
                        brdf_core::Compact(s),
                        100.0 * share
                    )
                }),
            })
        }
        FloorChoice::Given(_) => None,
        FloorChoice::Auto => estimate(points)?.map(|e| {
            let s = e.sigma_a / ASSUMED_RELATIVE_NOISE;
            let below = at_or_below(s);
            let share = below as f64 / points.len() as f64;
            NoiseFloor {
                value: s,
                source: "estimated".to_owned(),
                sigma_a: Some(e.sigma_a),
                relative_noise: Some(ASSUMED_RELATIVE_NOISE),
                at_or_below_zero: zero,
                at_or_below_floor: below,
                note: ((share > FLOOR_ABOVE_MOST && (zero as f64) < FEW_DARK * points.len() as f64)
                    || share > FLOOR_ABOVE_ALL)
                    .then(|| {
                        format!(
                            "the estimated noise floor {} 1/sr lies above {:.0}% of the readings: the {zero} \
                             reading(s) at or below zero may be dropouts rather than noise around zero, \
                             and the fit weighs this dataset almost by absolute error (its relative \
                             errors then look small however far off it is); give a floor \
                             (noise_floor) if that is not meant",
                            brdf_core::Compact(s),
                            100.0 * share
                        )
                    }),
            }
        }),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts(values: &[f64]) -> Vec<Point> {
        values
            .iter()
            .enumerate()
            .map(|(k, &brdf)| Point {
                theta_i: 0.1,
                theta_r: 0.2,
                phi: 0.3,
                brdf,
                sigma: None,
                weight: None,
                line: k as u64 + 2,
            })
            .collect()
    }

    #[test]
    fn no_dark_reading_no_floor() {
        assert_eq!(estimate(&pts(&[1.0, 2.0, 1e-9])).unwrap(), None);
        assert_eq!(floor_for(FloorChoice::Auto, &pts(&[1.0, 2.0])).unwrap(), None);
    }

    #[test]
    fn the_estimate_mirrors_the_dark_readings_in_the_smallest_positive_ones() {
        // Two readings at or below zero: the two smallest positive ones (3 and 4) are mirrored.
        let e = estimate(&pts(&[0.0, -1.0, 4.0, 3.0, 100.0, 50.0]))
            .unwrap()
            .unwrap();
        assert_eq!(e.at_or_below_zero, 2);
        assert!((e.sigma_a - 12.5f64.sqrt()).abs() < 1e-15, "{}", e.sigma_a);
        let f = floor_for(FloorChoice::Auto, &pts(&[0.0, -1.0, 4.0, 3.0, 100.0, 50.0]))
            .unwrap()
            .unwrap();
        assert!((f.value - e.sigma_a / ASSUMED_RELATIVE_NOISE).abs() < 1e-12);
        assert_eq!((f.at_or_below_zero, f.at_or_below_floor), (2, 5));
    }

    #[test]
    fn gaussian_noise_around_zero_estimates_its_sigma() {
        // Normal deviates with sigma 0.01 around 0, clipped at 0 as Cornell prints them: the
        // estimate is within 10% (4,000 readings: its own scatter is about 2%).
        use rand_core::SeedableRng;
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(11);
        let v: Vec<f64> = (0..4000)
            .map(|_| (0.01 * crate::anneal::normal(&mut rng)).max(0.0))
            .collect();
        let e = estimate(&pts(&v)).unwrap().unwrap();
        assert!((e.sigma_a / 0.01 - 1.0).abs() < 0.1, "{}", e.sigma_a);
    }

    #[test]
    fn all_dark_is_an_error_and_a_given_floor_wins() {
        assert_eq!(estimate(&pts(&[0.0, -1.0])), Err(NoiseError::NoSignal(2)));
        let f = floor_for(FloorChoice::Given(0.5), &pts(&[0.0, 1.0, 0.4]))
            .unwrap()
            .unwrap();
        assert_eq!(
            (f.value, f.source.as_str(), f.at_or_below_floor),
            (0.5, "given", 2)
        );
        assert_eq!(
            floor_for(FloorChoice::Given(0.0), &pts(&[0.0, 1.0])).unwrap(),
            None
        );
    }
}
