//! The valid range of every model parameter: one definition, used by every model
//! constructor in f32 and in f64 — and so, identically, by `brdf pack`, the firmware's LOAD
//! and COMMIT, `brdf check` and `brdf fit` (whose search box lies inside these ranges).
//!
//! Every bound is a number exactly representable in f32 (0, integers, powers of two). A
//! value held in f32 is therefore in range in f32 exactly when its exact f64 widening is in
//! range in f64, and an f64 value inside a closed range stays inside when rounded to f32
//! (rounding is monotone and leaves the bound unchanged): the host and the device cannot
//! disagree about a parameter.
//!
//! The ranges are physical, and bound what a device can be made to answer: the
//! six-parameter model with `c >= 0` never exceeds `(kb + kd) / pi` ([`six_max_value`]), at most
//! `(10,000 + 100) / pi = 3,215` 1/sr. Why each bound is where it is:
//!
//! | parameter | range | why |
//! |---|---|---|
//! | `kb` | [0, 10,000] | a metal's mirror peak of ~2,000 1/sr needs `kb` in the thousands; the fitter searches the same range |
//! | `kr` | [1/1024, 1024] | the facet term's peak is `kr^2` wide in `1 - cos(alpha)`: below 1/1024 (`kr^2 < 1e-6`) it is narrower than f32 resolves near the mirror direction; above 1024 the term is 1 to f32 precision everywhere |
//! | `b` | [-1000, 1000] (used as `abs(b)`) | at `abs(b) = 1000` the lobe falls to 1/e where `(1 - cos(gamma))^a = 0.001`; the fitter searches [0, 200] |
//! | `a` | (0, 10] | the lobe exponent; `(1 - cos gamma)^a` reaches `2^a`, and `abs(b) 2^a` stays finite; the fitter searches [0.05, 4] |
//! | `kd`, `rho0` | [0, 100] | a diffuse albedo; energy conservation needs at most 1, the rest is room for uncalibrated data |
//! | `c` | (-1, 10] | the diffuse exponent; below 0 the diffuse term brightens towards grazing as Minnaert's `k - 1` does; the fitter searches [0, 5], or [-0.99, 5] with `--brightening` |
//! | `k` (Minnaert) | (0, 1] | `k = 1` is Lambert; above 1 the model is not Minnaert's |
//! | `ks` (microfacet) | [0, 10,000] | as `kb`: a calibrated surface has `ks <= 1`, the rest is room for uncalibrated data |
//! | `alpha` (microfacet) | [1/1024, 4] | GGX roughness: at 1/1024 the peak is `alpha^2 ~ 1e-6` wide in `1 - cos theta_h`, as narrow as `kr`'s lower bound; `alpha = 1` spreads the half vector uniformly over the hemisphere, 4 leaves room for rougher data |
//! | `f0` (microfacet) | [0, 1] | Schlick's reflectance at normal incidence; `F <= 1` is what makes `ks + kd` an energy bound |

use crate::error::ParamError;
use crate::float::Float;
use crate::model::ModelKind;

/// The valid range of one parameter: `[min, max]`, or `(min, max]` when `min_open`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamRange {
    /// Paper name of the parameter.
    pub name: &'static str,
    /// Lower bound (an f32 number).
    pub min: f32,
    /// The lower bound itself is excluded.
    pub min_open: bool,
    /// Upper bound (an f32 number), included.
    pub max: f32,
    /// The range as text, for messages (e.g. `"in [0, 10000]"`).
    pub text: &'static str,
}

impl ParamRange {
    /// `v` if it is finite and inside the range, else the error naming the parameter.
    pub fn check<T: Float>(&self, v: T) -> Result<T, ParamError> {
        if !v.is_finite() {
            return Err(ParamError::NotFinite { name: self.name });
        }
        // Exact in f32 and f64 (the bounds are f32 numbers).
        let (lo, hi) = (T::from_f64(f64::from(self.min)), T::from_f64(f64::from(self.max)));
        let above = if self.min_open { v > lo } else { v >= lo };
        if above && v <= hi {
            Ok(v)
        } else {
            Err(ParamError::OutOfRange {
                name: self.name,
                value: v.to_f64(),
                range: self.text,
            })
        }
    }

    /// Whether `v` is inside the range.
    pub fn contains<T: Float>(&self, v: T) -> bool {
        self.check(v).is_ok()
    }
}

const fn closed(name: &'static str, min: f32, max: f32, text: &'static str) -> ParamRange {
    ParamRange {
        name,
        min,
        min_open: false,
        max,
        text,
    }
}

const KB: ParamRange = closed("kb", 0.0, 10_000.0, "in [0, 10000]");
const KR: ParamRange = closed("kr", 1.0 / 1024.0, 1024.0, "in [1/1024, 1024]");
const B: ParamRange = closed("b", -1000.0, 1000.0, "in [-1000, 1000]");
const A: ParamRange = ParamRange {
    name: "a",
    min: 0.0,
    min_open: true,
    max: 10.0,
    text: "in (0, 10]",
};
const KD: ParamRange = closed("kd", 0.0, 100.0, "in [0, 100]");
const C: ParamRange = ParamRange {
    name: "c",
    min: -1.0,
    min_open: true,
    max: 10.0,
    text: "in (-1, 10]",
};
const KS: ParamRange = closed("ks", 0.0, 10_000.0, "in [0, 10000]");
const ALPHA: ParamRange = closed("alpha", 1.0 / 1024.0, 4.0, "in [1/1024, 4]");
const F0: ParamRange = closed("f0", 0.0, 1.0, "in [0, 1]");
const RHO0: ParamRange = closed("rho0", 0.0, 100.0, "in [0, 100]");
const K: ParamRange = ParamRange {
    name: "k",
    min: 0.0,
    min_open: true,
    max: 1.0,
    text: "in (0, 1]",
};

/// Six-parameter model and its `cos^2` variant: `kb, kr, b, a, kd, c`.
pub const SIX: [ParamRange; 6] = [KB, KR, B, A, KD, C];
/// Five-parameter model: `kb, kr, b, a, kd`.
pub const FIVE: [ParamRange; 5] = [KB, KR, B, A, KD];
/// Minnaert: `rho0, k`.
pub const MINNAERT: [ParamRange; 2] = [RHO0, K];
/// Microfacet (GGX): `ks, alpha, f0, kd`.
pub const GGX: [ParamRange; 4] = [KS, ALPHA, F0, KD];
/// Lambert: `rho0`.
pub const LAMBERT: [ParamRange; 1] = [RHO0];

impl ModelKind {
    /// The valid range of each parameter, in the paper's order.
    pub const fn ranges(self) -> &'static [ParamRange] {
        match self {
            ModelKind::Six | ModelKind::SixCos2 => &SIX,
            ModelKind::Five => &FIVE,
            ModelKind::Minnaert => &MINNAERT,
            ModelKind::Ggx => &GGX,
            ModelKind::Lambert => &LAMBERT,
        }
    }
}

/// Largest value the six-parameter model (eq. 3) takes for weights `kb`, `kd` and `c >= 0`:
/// the facet term, the lobe and `ln(1 + cos ti cos tr) / ln 2` are at most 1 and
/// `(cos ti cos tr)^c` is at most 1, so `f_r <= (kb + kd) / pi`. (With `c < 0`, as with
/// Minnaert's `k < 1`, the diffuse term grows without bound towards the horizon.) (in exact arithmetic; an f32 evaluation may
/// round past it by [`crate::tolerance::F32_MAX_REL`]).
pub fn six_max_value(kb: f64, kd: f64) -> f64 {
    (kb + kd) / core::f64::consts::PI
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bound_is_an_f32_number_and_the_ranges_match_the_names() {
        for kind in ModelKind::ALL {
            let r = kind.ranges();
            assert_eq!(r.len(), kind.param_count());
            for (range, name) in r.iter().zip(kind.param_names()) {
                assert_eq!(range.name, *name);
                assert!(range.min < range.max);
                for b in [range.min, range.max] {
                    assert_eq!(f64::from(b) as f32, b);
                }
            }
        }
    }

    #[test]
    fn the_on_sensor_search_box_lies_inside_the_ranges() {
        for kind in ModelKind::ALL {
            let b = crate::anneal::SearchBox::<f32>::for_kind(kind);
            for (j, r) in kind.ranges().iter().enumerate() {
                assert!(r.contains(b.lo[j]) && r.contains(b.hi[j]), "{kind:?} {}", r.name);
            }
        }
    }

    #[test]
    fn f32_and_f64_agree_at_every_bound() {
        for kind in ModelKind::ALL {
            for r in kind.ranges() {
                for edge in [r.min, r.max] {
                    let mut x = edge;
                    // The bound and its eight f32 neighbours on each side.
                    for _ in 0..8 {
                        x = x.next_down();
                    }
                    for _ in 0..17 {
                        assert_eq!(r.contains(x), r.contains(f64::from(x)), "{} at {x:e}", r.name);
                        x = x.next_up();
                    }
                }
                assert!(!r.contains(f32::NAN) && !r.contains(f64::INFINITY));
            }
        }
    }
}
