//! Spectral materials: which band, or which two bands, answer at a wavelength.
//!
//! A spectral material holds one parameter set per measured band, each at its centre
//! wavelength (µm, ascending). At a band's wavelength (within [`SAME_BAND_UM`]) that band
//! answers; between two neighbouring bands the BRDF is `(1 - w) f_lower + w f_upper` with `w`
//! linear in wavelength ([`blend`]): a convex combination, so reciprocity and energy
//! conservation (`kb + kd <= 1` in every band) carry over. Outside the bands nothing answers:
//! a BRDF is not extrapolated in wavelength. The host (`brdf_fit::spectral::BandFits`) and the
//! device (a banded material of `brdf_wire::blob`) use this one rule.
//!
//! ```
//! use brdf_core::bands::{blend, locate, Located};
//!
//! let bands = [0.40f32, 0.41, 0.42];
//! assert_eq!(locate(&bands, 0.41), Ok(Located::Band(1)));
//! let Ok(Located::Between { lower, weight }) = locate(&bands, 0.4025) else { panic!() };
//! assert_eq!(lower, 0);
//! assert!((weight - 0.25).abs() < 1e-4);
//! assert!((blend(1.0f32, 2.0, weight) - 1.25).abs() < 1e-4);
//! assert!(locate(&bands, 0.5).is_err());
//! ```

use crate::Float;

/// Two wavelengths closer than this (µm, 1 pm) are one band.
pub const SAME_BAND_UM: f64 = 1e-6;

/// Most bands one material holds on a device (the 31 bands of 400–700 nm at 10 nm fit twice).
pub const MAX_BANDS: usize = 64;

/// Which band answers at a wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Located<F> {
    /// The wavelength is this band's (within [`SAME_BAND_UM`]).
    Band(usize),
    /// Between band `lower` and band `lower + 1`; `weight` in (0, 1) is the upper band's.
    Between {
        /// The band below.
        lower: usize,
        /// The upper band's weight.
        weight: F,
    },
}

/// Why no band answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BandError {
    /// Not a finite wavelength above 0.
    NotAWavelength,
    /// Below the first band or above the last (no extrapolation).
    Outside,
    /// No bands, or wavelengths that are not finite, above 0 and ascending at least
    /// [`SAME_BAND_UM`] apart.
    Malformed,
}

impl core::fmt::Display for BandError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            BandError::NotAWavelength => "not a wavelength above 0",
            BandError::Outside => "outside the bands (a BRDF is not extrapolated in wavelength)",
            BandError::Malformed => "band wavelengths not finite, above 0 and ascending 1e-6 um apart",
        })
    }
}

impl core::error::Error for BandError {}

/// Whether `bands` may be a material's band centres: at least one, each finite and above 0,
/// ascending, neighbours at least [`SAME_BAND_UM`] apart (so [`locate`] is unambiguous).
pub fn valid<F: Float>(bands: &[F]) -> bool {
    let gap = F::from_f64(SAME_BAND_UM);
    !bands.is_empty()
        && bands.iter().all(|&w| w.is_finite() && w > F::ZERO)
        && bands.windows(2).all(|p| p[1] - p[0] >= gap)
}

/// The band, or the two bands, that answer at `um` µm among ascending band centres `bands`
/// (checked by [`valid`]). Binary search: about log2(bands) comparisons.
pub fn locate<F: Float>(bands: &[F], um: F) -> Result<Located<F>, BandError> {
    if !(um.is_finite() && um > F::ZERO) {
        return Err(BandError::NotAWavelength);
    }
    let gap = F::from_f64(SAME_BAND_UM);
    // First band at or above `um`.
    let k = bands.partition_point(|&w| w < um);
    let near = |i: usize| bands.get(i).is_some_and(|&w| (w - um).abs() < gap);
    if k > 0 && near(k - 1) {
        return Ok(Located::Band(k - 1));
    }
    if near(k) {
        return Ok(Located::Band(k));
    }
    if k == 0 || k >= bands.len() {
        return Err(BandError::Outside);
    }
    let (w0, w1) = (bands[k - 1], bands[k]);
    Ok(Located::Between {
        lower: k - 1,
        weight: (um - w0) / (w1 - w0),
    })
}

/// The BRDF between two bands: `(1 - weight) lower + weight upper`.
pub fn blend<F: Float>(lower: F, upper: F, weight: F) -> F {
    (F::ONE - weight) * lower + weight * upper
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_band_within_a_picometre_answers_alone_and_neighbours_blend_linearly() {
        let b = [0.4f64, 0.5, 0.7];
        assert_eq!(locate(&b, 0.5 + 0.9e-6), Ok(Located::Band(1)));
        assert_eq!(locate(&b, 0.4 - 0.9e-6), Ok(Located::Band(0)));
        assert_eq!(locate(&b, 0.7 + 0.9e-6), Ok(Located::Band(2)));
        match locate(&b, 0.65) {
            Ok(Located::Between { lower: 1, weight }) => assert!((weight - 0.75).abs() < 1e-12),
            other => panic!("{other:?}"),
        }
        assert_eq!(locate(&b, 0.4 - 2e-6), Err(BandError::Outside));
        assert_eq!(locate(&b, 0.7 + 2e-6), Err(BandError::Outside));
        for bad in [0.0, -0.5, f64::NAN, f64::INFINITY] {
            assert_eq!(locate(&b, bad), Err(BandError::NotAWavelength));
        }
        assert_eq!(locate(&[0.55f64], 0.55), Ok(Located::Band(0)));
        assert_eq!(locate(&[0.55f64], 0.56), Err(BandError::Outside));
    }

    #[test]
    fn band_centres_must_ascend_apart() {
        assert!(valid(&[0.4f32, 0.41]));
        assert!(!valid::<f32>(&[]));
        assert!(!valid(&[0.41f32, 0.4]));
        assert!(!valid(&[0.4f64, 0.4 + 1e-7]));
        assert!(!valid(&[0.0f32, 0.4]));
        assert!(!valid(&[0.4f32, f32::NAN]));
    }

    #[test]
    fn the_blend_is_convex() {
        assert_eq!(blend(2.0f32, 4.0, 0.0), 2.0);
        assert_eq!(blend(2.0f32, 4.0, 1.0), 4.0);
        assert_eq!(blend(2.0f64, 4.0, 0.5), 3.0);
    }
}
