//! Scattering geometry: the facet angles `alpha` and `gamma` of docs/model.md, computed so that
//! they stay accurate in f32 near the retro and mirror directions and at grazing angles.
//!
//! Convention (docs/model.md): directions point away from the surface; `phi = phi_r - phi_i`;
//! the mirror direction is `theta_r = theta_i, phi = pi`, the retro direction
//! `theta_r = theta_i, phi = 0`. With unit vectors `wi` (to the source) and `wr` (to the
//! receiver) and the half vector `h = (wi + wr) / |wi + wr|`:
//!
//! - `cos(gamma) = |wi + wr| / 2`, `sin(gamma) = |wi - wr| / 2` (gamma: local incidence angle
//!   on the facet that mirrors source into receiver);
//! - `cos(alpha) = h_z = (cos theta_i + cos theta_r) / (2 cos gamma)` (alpha: that facet's tilt).
//!
//! Every constructor reduces its input to three non-negative sums of squares, none of which
//! cancels:
//!
//! - `S = sin^2(gamma) = |wi - wr|^2 / 4`,
//! - `C = cos^2(gamma) = |wi + wr|^2 / 4`,
//! - `P = (wi + wr)_x^2 + (wi + wr)_y^2`,
//!
//! and then forms `1 - cos(gamma) = S / (1 + cos gamma)` and
//! `1 - cos(alpha) = (h_x^2 + h_y^2) / (1 + h_z) = P / (4 C (1 + cos alpha))`.
//! The textbook `1 - sqrt(C)` loses every digit at the retro direction in f32; these forms
//! keep a few ulp of relative error (measured in `tests/f32_accuracy.rs`).

use crate::error::DomainError;
use crate::float::Float;

/// Everything a model of the family needs about one (incidence, viewing) pair.
///
/// Build it once per direction pair with [`Geometry::from_angles`],
/// [`Geometry::from_cosines`] or [`Geometry::from_vectors`] and evaluate any number of
/// models on it. A direction at or below the horizon (`cos theta <= 0`) is kept as is; the
/// models return 0 for it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry<T> {
    cos_theta_i: T,
    cos_theta_r: T,
    cos_gamma: T,
    one_minus_cos_gamma: T,
    cos_alpha: T,
    one_minus_cos_alpha: T,
    cos_i_minus_cos_r: T,
}

impl<T: Float> Geometry<T> {
    /// From the three sums of squares described in the module documentation.
    #[inline]
    fn from_parts(cos_theta_i: T, cos_theta_r: T, sin2_gamma: T, cos2_gamma: T, p: T, diff: T) -> Self {
        if cos2_gamma == T::ZERO {
            // wi = -wr: both directions on the horizon (or so close that cos^2(gamma)
            // underflows); the facet angles are undefined and every model gives 0 there.
            return Geometry {
                cos_theta_i: T::ZERO,
                cos_theta_r: T::ZERO,
                cos_gamma: T::ZERO,
                one_minus_cos_gamma: T::ONE,
                cos_alpha: T::ONE,
                one_minus_cos_alpha: T::ZERO,
                cos_i_minus_cos_r: T::ZERO,
            };
        }
        let cos_gamma = cos2_gamma.sqrt();
        let one_minus_cos_gamma = sin2_gamma / (T::ONE + cos_gamma);
        let cos_alpha = (cos_theta_i + cos_theta_r) / (T::TWO * cos_gamma);
        let one_minus_cos_alpha = p / ((T::TWO + T::TWO) * cos2_gamma * (T::ONE + cos_alpha));
        Geometry {
            cos_theta_i,
            cos_theta_r,
            cos_gamma,
            one_minus_cos_gamma,
            cos_alpha,
            one_minus_cos_alpha,
            cos_i_minus_cos_r: diff,
        }
    }

    /// From zenith angles `theta_i`, `theta_r` and relative azimuth `phi = phi_r - phi_i`
    /// (radians, canonical convention). Intended domain: zeniths in `[0, pi/2]`, any `phi`.
    ///
    /// Uses `sin((theta_i - theta_r)/2)`, `cos((theta_i + theta_r)/2)` and `sin`, `cos` of
    /// `phi/2` so that neither `sin^2(gamma)` nor `1 - cos(alpha)` cancels:
    /// `S = sin^2((ti-tr)/2) + sin ti sin tr sin^2(phi/2)`,
    /// `C = cos^2((ti+tr)/2) + sin ti sin tr cos^2(phi/2)`,
    /// `P = 4 cos^2((ti+tr)/2) sin^2((ti-tr)/2) + 4 sin ti sin tr cos^2(phi/2)`.
    ///
    /// A zenith at or beyond the rounded `pi/2` of `T` is the horizon (`cos theta = 0`), so
    /// 90° is treated alike in f32 (where `cos(fl(pi/2)) < 0`) and f64 (where it is 6e-17).
    #[inline]
    pub fn from_angles(theta_i: T, theta_r: T, phi: T) -> Self {
        let (sin_i, cos_i) = theta_i.sin_cos();
        let (sin_r, cos_r) = theta_r.sin_cos();
        let cos_i = if theta_i >= T::FRAC_PI_2 { T::ZERO } else { cos_i };
        let cos_r = if theta_r >= T::FRAC_PI_2 { T::ZERO } else { cos_r };
        let (sin_hp, cos_hp) = (phi * T::HALF).sin_cos();
        let sin_hd = ((theta_i - theta_r) * T::HALF).sin();
        // cos((ti+tr)/2) is ill-conditioned near pi/2 (both directions grazing): correct
        // for the rounding error `e` of the sum (TwoSum), cos(x + e/2) ~ cos x - sin x * e/2.
        let sum = theta_i + theta_r;
        let v = sum - theta_i;
        let e = (theta_i - (sum - v)) + (theta_r - v);
        let (sin_hs, cos_hs) = (sum * T::HALF).sin_cos();
        let cos_hs = cos_hs - sin_hs * e * T::HALF;
        let ss = sin_i * sin_r;
        let sin2_gamma = sin_hd * sin_hd + ss * (sin_hp * sin_hp);
        let cos2_gamma = cos_hs * cos_hs + ss * (cos_hp * cos_hp);
        let four = T::TWO + T::TWO;
        let diff = cos_hs * sin_hd;
        let p = four * (diff * diff + ss * (cos_hp * cos_hp));
        // cos ti - cos tr = -2 sin((ti+tr)/2) sin((ti-tr)/2): accurate where both cosines
        // round to the same value (near normal incidence and view).
        let cos_diff = if theta_i >= T::FRAC_PI_2 || theta_r >= T::FRAC_PI_2 {
            cos_i - cos_r
        } else {
            -(T::TWO * sin_hs * sin_hd)
        };
        Self::from_parts(cos_i, cos_r, sin2_gamma, cos2_gamma, p, cos_diff)
    }

    /// From `cos theta_i`, `cos theta_r` and `cos phi` — the device path, with no
    /// trigonometric call (two square roots and six divisions).
    ///
    /// Accurate to a few ulp for the given cosines. `sin ti sin tr = sqrt((1 - cos^2 ti)(1 -
    /// cos^2 tr))` is the only square root; each sum that would cancel is rewritten as a
    /// quotient of terms that do not (`1 - x` is exact for `x` in `[1/2, 2]`, by Sterbenz, so
    /// `(1 - x)(1 + x)` rounds once):
    /// - `1 - cos(ti - tr) = (cos ti - cos tr)^2 / (1 - cos(ti + tr))`,
    /// - `1 + cos(ti + tr) = (cos ti + cos tr)^2 / (1 + cos(ti - tr))`,
    /// - `(sin ti - sin tr)^2 = (sin^2 ti - sin^2 tr)^2 / (sin ti + sin tr)^2`,
    ///
    /// with `2 (1 -+ cos ti cos tr)` written as the symmetric sum of two products, so the
    /// result is exactly reciprocal. `1 - cos phi` and `1 + cos phi` are exact where they are
    /// small (Sterbenz). Resolution near the retro direction is limited by how finely
    /// `cos phi` itself can say `phi` (in f32, `phi` below about 3e-4 rad rounds `cos phi` to
    /// 1); callers who need that region should use [`Geometry::from_angles`] or
    /// [`Geometry::from_vectors`].
    #[inline]
    pub fn from_cosines(cos_theta_i: T, cos_theta_r: T, cos_phi: T) -> Self {
        let (sin2_gamma, cos2_gamma, p) = cosine_sums(cos_theta_i, cos_theta_r, cos_phi, T::sqrt);
        Self::from_parts(
            cos_theta_i,
            cos_theta_r,
            sin2_gamma,
            cos2_gamma,
            p,
            cos_theta_i - cos_theta_r,
        )
    }

    /// From unit vectors `wi` (towards the source) and `wr` (towards the receiver), `z` along
    /// the surface normal. Exact differences make this the most accurate constructor near
    /// the retro direction. Vectors are not renormalised; see [`Geometry::try_from_vectors`].
    #[inline]
    pub fn from_vectors(wi: [T; 3], wr: [T; 3]) -> Self {
        let s = [wi[0] + wr[0], wi[1] + wr[1], wi[2] + wr[2]];
        let d = [wi[0] - wr[0], wi[1] - wr[1], wi[2] - wr[2]];
        let p = s[0] * s[0] + s[1] * s[1];
        let quarter = T::HALF * T::HALF;
        let sin2_gamma = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * quarter;
        let cos2_gamma = (p + s[2] * s[2]) * quarter;
        Self::from_parts(wi[2], wr[2], sin2_gamma, cos2_gamma, p, d[2])
    }

    /// [`Geometry::from_angles`] for checked input: every value finite, zeniths in
    /// `[0, pi]` (above `pi/2` is below the horizon and evaluates to 0), `phi` finite.
    pub fn try_from_angles(theta_i: T, theta_r: T, phi: T) -> Result<Self, DomainError> {
        check_zenith(theta_i, "theta_i")?;
        check_zenith(theta_r, "theta_r")?;
        if !phi.is_finite() {
            return Err(DomainError::NotFinite { what: "phi" });
        }
        Ok(Self::from_angles(theta_i, theta_r, phi))
    }

    /// [`Geometry::from_cosines`] for checked input: all three finite and within `[-1, 1]`.
    pub fn try_from_cosines(cos_theta_i: T, cos_theta_r: T, cos_phi: T) -> Result<Self, DomainError> {
        check_cosine(cos_theta_i, "cos_theta_i")?;
        check_cosine(cos_theta_r, "cos_theta_r")?;
        check_cosine(cos_phi, "cos_phi")?;
        Ok(Self::from_cosines(cos_theta_i, cos_theta_r, cos_phi))
    }

    /// [`Geometry::from_vectors`] for checked input: finite components and
    /// `| |w|^2 - 1 | <= 1e-4` for both vectors (catches unnormalised or garbage input;
    /// results are accurate to the caller's normalisation).
    pub fn try_from_vectors(wi: [T; 3], wr: [T; 3]) -> Result<Self, DomainError> {
        check_unit(wi, "wi")?;
        check_unit(wr, "wr")?;
        Ok(Self::from_vectors(wi, wr))
    }

    /// `cos theta_i` (may be <= 0: below the horizon).
    #[inline]
    pub fn cos_theta_i(&self) -> T {
        self.cos_theta_i
    }
    /// `cos theta_r` (may be <= 0: below the horizon).
    #[inline]
    pub fn cos_theta_r(&self) -> T {
        self.cos_theta_r
    }
    /// `cos gamma`, gamma the local incidence angle on the mirroring facet.
    #[inline]
    pub fn cos_gamma(&self) -> T {
        self.cos_gamma
    }
    /// `1 - cos gamma`, computed without cancellation (exactly 0 at the retro direction).
    #[inline]
    pub fn one_minus_cos_gamma(&self) -> T {
        self.one_minus_cos_gamma
    }
    /// `cos alpha`, alpha the tilt of the mirroring facet from the surface normal.
    #[inline]
    pub fn cos_alpha(&self) -> T {
        self.cos_alpha
    }
    /// `1 - cos alpha`, computed without cancellation (exactly 0 at the mirror direction).
    #[inline]
    pub fn one_minus_cos_alpha(&self) -> T {
        self.one_minus_cos_alpha
    }
    /// `cos theta_i - cos theta_r`, from angles without the cancellation of the two rounded
    /// cosines (`-2 sin((ti + tr)/2) sin((ti - tr)/2)`); from cosines or vectors their
    /// difference, exact (Sterbenz) where it is small.
    #[inline]
    pub fn cos_theta_i_minus_cos_theta_r(&self) -> T {
        self.cos_i_minus_cos_r
    }
    /// Whether `self` and `other` are one direction pair to the family: every model depends
    /// on `cos phi` only, so `phi` and `-phi` (or `360 - phi`) are one pair; with `reciprocal`
    /// (for a reciprocal model) incidence and viewing swapped are one pair too. The
    /// quantities the models read agree within [`crate::tolerance::SAME_PAIR_EPS`] times `T::EPSILON`, relative
    /// (the two ways of writing a pair round differently by an ulp or two).
    pub fn same_pair(&self, other: &Self, reciprocal: bool) -> bool {
        let tol = T::from_f64(crate::tolerance::SAME_PAIR_EPS) * T::EPSILON;
        // The floor `tol * EPSILON`: at the exact mirror or retro direction a `1 - cos` is 0
        // written one way and ~1e-32 (f64) or ~1e-14 (f32) written another (`phi` 0 or 360).
        let close = |a: T, b: T| {
            let m = if a.abs() > b.abs() { a.abs() } else { b.abs() };
            (a - b).abs() <= tol * m + tol * T::EPSILON
        };
        let shared = close(self.cos_gamma, other.cos_gamma)
            && close(self.one_minus_cos_gamma, other.one_minus_cos_gamma)
            && close(self.cos_alpha, other.cos_alpha)
            && close(self.one_minus_cos_alpha, other.one_minus_cos_alpha);
        let as_is = close(self.cos_theta_i, other.cos_theta_i) && close(self.cos_theta_r, other.cos_theta_r);
        let swapped = reciprocal
            && close(self.cos_theta_i, other.cos_theta_r)
            && close(self.cos_theta_r, other.cos_theta_i);
        shared && (as_is || swapped)
    }

    /// Both directions strictly above the horizon. False for NaN input.
    #[inline]
    pub fn above_horizon(&self) -> bool {
        self.cos_theta_i > T::ZERO && self.cos_theta_r > T::ZERO
    }
    /// The value every model returns without evaluating: `Some(0)` when either direction is
    /// at or below the horizon, `Some(NaN)` when an input was NaN, `None` otherwise.
    #[inline]
    pub(crate) fn outside(&self) -> Option<T> {
        if self.above_horizon() {
            None
        } else if self.cos_theta_i <= T::ZERO || self.cos_theta_r <= T::ZERO {
            Some(T::ZERO)
        } else {
            Some(self.cos_theta_i * self.cos_theta_r)
        }
    }
}

/// `sin^2(gamma)`, `cos^2(gamma)` and `P` (module documentation) from `cos theta_i`,
/// `cos theta_r` and `cos phi`, as [`Geometry::from_cosines`] describes; `sqrt` is the square
/// root to use (the batch path passes its vectorisable one).
#[inline(always)]
pub(crate) fn cosine_sums<T: Float>(mi: T, mr: T, cos_phi: T, sqrt: impl Fn(T) -> T) -> (T, T, T) {
    let (pi, qi, pr, qr) = (T::ONE - mi, T::ONE + mi, T::ONE - mr, T::ONE + mr);
    // sin^2 ti, sin^2 tr and sin ti sin tr.
    let (a, b) = (pi * qi, pr * qr);
    let ss = sqrt(a * b);
    let ss2 = ss + ss;
    // Denominators are at least the smallest normal number, so that the 0/0 at normal
    // incidence and view (and on the horizon) gives 0; adding it to any denominator that is
    // not 0 changes nothing (they are at least 2^-24 there).
    let tiny = T::MIN_POSITIVE;
    let (dm, sm) = (mi - mr, mi + mr);
    // 2 (1 - cos(ti + tr)) and 2 (1 + cos(ti - tr)).
    let den_sum = (pi * qr + qi * pr) + ss2 + tiny;
    let den_diff = (qi * qr + pi * pr) + ss2 + tiny;
    // (sin ti - sin tr)^2, from sin^2 ti - sin^2 tr = (cos tr - cos ti)(cos tr + cos ti).
    let d2 = dm * sm;
    let sin_dr2 = (d2 * d2) / ((a + b) + ss2 + tiny);
    let half_ss = ss * T::HALF;
    let one_plus_cp = T::ONE + cos_phi;
    // sin^2(gamma) = (1 - cos(ti - tr) + ss (1 - cos phi)) / 2, and cos^2(gamma) alike.
    let sin2_gamma = (dm * dm) / den_sum + half_ss * (T::ONE - cos_phi);
    let cos2_gamma = (sm * sm) / den_diff + half_ss * one_plus_cp;
    (sin2_gamma, cos2_gamma, sin_dr2 + ss2 * one_plus_cp)
}

pub(crate) fn check_zenith<T: Float>(theta: T, what: &'static str) -> Result<(), DomainError> {
    if !theta.is_finite() {
        return Err(DomainError::NotFinite { what });
    }
    if theta < T::ZERO || theta > T::PI {
        return Err(DomainError::OutOfRange {
            what,
            value: theta.to_f64(),
            range: "[0, pi] rad",
        });
    }
    Ok(())
}

pub(crate) fn check_cosine<T: Float>(c: T, what: &'static str) -> Result<(), DomainError> {
    if !c.is_finite() {
        return Err(DomainError::NotFinite { what });
    }
    if c < -T::ONE || c > T::ONE {
        return Err(DomainError::OutOfRange {
            what,
            value: c.to_f64(),
            range: "[-1, 1]",
        });
    }
    Ok(())
}

pub(crate) fn check_unit<T: Float>(w: [T; 3], what: &'static str) -> Result<(), DomainError> {
    if !(w[0].is_finite() && w[1].is_finite() && w[2].is_finite()) {
        return Err(DomainError::NotFinite { what });
    }
    let n2 = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).to_f64();
    if (n2 - 1.0).abs() > UNIT_NORM_TOLERANCE {
        return Err(DomainError::NotUnitVector {
            what,
            norm_squared: n2,
        });
    }
    Ok(())
}

/// Largest accepted `| |w|^2 - 1 |` in [`Geometry::try_from_vectors`].
pub const UNIT_NORM_TOLERANCE: f64 = 1e-4;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tolerance::F64_REFORMULATION_REL;
    use core::f64::consts::PI;

    fn vectors(ti: f64, tr: f64, phi: f64) -> ([f64; 3], [f64; 3]) {
        let wi = [libm::sin(ti), 0.0, libm::cos(ti)];
        let wr = [
            libm::sin(tr) * libm::cos(phi),
            libm::sin(tr) * libm::sin(phi),
            libm::cos(tr),
        ];
        (wi, wr)
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
    }

    #[test]
    fn three_constructors_agree_on_generic_directions() {
        for &(ti, tr, phi) in &[(0.3, 0.7, 1.1), (1.2, 0.1, 2.9), (0.5, 0.5, 0.4), (1.5, 1.4, 3.0)] {
            let a = Geometry::from_angles(ti, tr, phi);
            let c = Geometry::from_cosines(libm::cos(ti), libm::cos(tr), libm::cos(phi));
            let (wi, wr) = vectors(ti, tr, phi);
            let v = Geometry::from_vectors(wi, wr);
            for g in [c, v] {
                assert!(
                    close(a.cos_gamma, g.cos_gamma, F64_REFORMULATION_REL),
                    "{a:?} {g:?}"
                );
                assert!(close(
                    a.one_minus_cos_gamma,
                    g.one_minus_cos_gamma,
                    F64_REFORMULATION_REL
                ));
                assert!(close(a.cos_alpha, g.cos_alpha, F64_REFORMULATION_REL));
                assert!(close(
                    a.one_minus_cos_alpha,
                    g.one_minus_cos_alpha,
                    F64_REFORMULATION_REL
                ));
            }
        }
    }

    #[test]
    fn retro_and_mirror_are_exact_zeros() {
        // Retro: gamma = 0 exactly; mirror: alpha = 0 exactly.
        let retro = Geometry::from_angles(0.4_f32, 0.4, 0.0);
        assert_eq!(retro.one_minus_cos_gamma, 0.0);
        let mirror = Geometry::from_angles(0.4_f64, 0.4, PI);
        assert!(mirror.one_minus_cos_alpha < 1e-32);
        let mirror_c = Geometry::from_cosines(0.6_f32, 0.6, -1.0);
        assert_eq!(mirror_c.one_minus_cos_alpha, 0.0);
        let retro_c = Geometry::from_cosines(0.6_f32, 0.6, 1.0);
        assert_eq!(retro_c.one_minus_cos_gamma, 0.0);
    }

    #[test]
    fn angle_identities_hold() {
        // gamma is half the angle between wi and wr; at the mirror, gamma = theta_i.
        let g = Geometry::from_angles(0.3_f64, 0.3, PI);
        assert!(close(g.cos_gamma, libm::cos(0.3), F64_REFORMULATION_REL));
        // At the retro direction alpha = theta_i.
        let g = Geometry::from_angles(0.3_f64, 0.3, 0.0);
        assert!(close(g.cos_alpha, libm::cos(0.3), F64_REFORMULATION_REL));
        assert!(close(g.cos_gamma, 1.0, F64_REFORMULATION_REL));
    }

    #[test]
    fn ninety_degrees_is_the_horizon_in_both_precisions() {
        assert_eq!(
            Geometry::from_angles(core::f64::consts::FRAC_PI_2, 0.3, 1.0).cos_theta_i,
            0.0
        );
        assert_eq!(
            Geometry::from_angles(0.3_f32, core::f32::consts::FRAC_PI_2, 1.0).cos_theta_r,
            0.0
        );
        // Opposite grazing directions: cos^2(gamma) underflows; no NaN escapes.
        let g = Geometry::from_vectors([1.0_f64, 0.0, 1e-200], [-1.0, 0.0, 1e-200]);
        assert!(!g.above_horizon() && g.outside() == Some(0.0));
        let g = Geometry::from_cosines(1e-30_f32, 1e-30, -1.0);
        assert!(
            g.one_minus_cos_alpha.is_finite() && g.cos_alpha.is_finite(),
            "{g:?}"
        );
    }

    #[test]
    fn checked_constructors_reject_bad_input() {
        assert!(matches!(
            Geometry::try_from_angles(f64::NAN, 0.1, 0.0),
            Err(DomainError::NotFinite { what: "theta_i" })
        ));
        assert!(matches!(
            Geometry::try_from_angles(0.1_f32, -0.1, 0.0),
            Err(DomainError::OutOfRange { what: "theta_r", .. })
        ));
        assert!(matches!(
            Geometry::try_from_angles(0.1_f32, 0.1, f32::INFINITY),
            Err(DomainError::NotFinite { what: "phi" })
        ));
        assert!(matches!(
            Geometry::try_from_cosines(1.5_f64, 0.1, 0.0),
            Err(DomainError::OutOfRange {
                what: "cos_theta_i",
                ..
            })
        ));
        assert!(matches!(
            Geometry::try_from_vectors([1.0_f64, 1.0, 0.0], [0.0, 0.0, 1.0]),
            Err(DomainError::NotUnitVector { what: "wi", .. })
        ));
        assert!(Geometry::try_from_angles(0.1_f64, 2.0, 0.3).is_ok());
    }
}
