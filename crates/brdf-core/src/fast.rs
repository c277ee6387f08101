//! A faster f32 six-parameter evaluation with this crate's own `exp2`/`log2` approximations
//! in place of libm's `powf`, `expf` and `log1pf`: one point on the speed/accuracy chart
//! (`brdf bench`), between the exact f32 path and the tables.
//!
//! - [`log2_fast`]: exponent from the bits, mantissa reduced to `[sqrt(1/2), sqrt(2))`,
//!   `log2(m) = 2/ln 2 * atanh(t)`, `t = (m - 1)/(m + 1)`, by the odd series to `t^9`
//!   (`|t| <= 0.1716`): truncation below 3e-9; error within `3e-7 max(1, |log2 x|)` with the
//!   rounding of the result.
//! - [`exp2_fast`]: `2^x = 2^n * 2^f`, `f` in `[-1/2, 1/2]`, Taylor to degree 6 (truncation
//!   1.5e-7 relative), `2^n` written into the exponent bits; 0 below `2^-126`, infinity above
//!   `2^128`.
//! - `x^y = exp2(y log2 x)`: the relative error grows with `|y log2 x|` (about 1.5e-7 per unit).
//!
//! Measured against f64 on the exact paths' grid (test `fast_six_error_bound`): max relative
//! error 1.7e-6 over the Table 1 sets and 150 random ones, within
//! [`crate::tolerance::FAST_MAX_REL`] (4e-6) for parameters in the paper's range. The lobe
//! `exp(-|b| x^a)` amplifies the error of `|b| x^a` by `|b| x^a`, as in the exact path. On
//! the Cortex-M4F it takes 393 instructions from cosines against 752 for the libm path.

use crate::geometry::Geometry;
use crate::model::Brdf;
use crate::models::{facet, SixParams};
use crate::ParamError;

const LN_2: f32 = core::f32::consts::LN_2;

/// `log2(x)` for finite `x > 0` (error within `3e-7 max(1, |log2 x|)`); NaN for `x < 0` or NaN,
/// infinity for infinity. Subnormal `x` are treated as 0 (`-inf`).
#[inline]
pub fn log2_fast(x: f32) -> f32 {
    if x.is_nan() || x < 0.0 {
        return f32::NAN;
    }
    if x == 0.0 {
        return f32::NEG_INFINITY;
    }
    if x == f32::INFINITY {
        return x;
    }
    let bits = x.to_bits();
    let mut e = ((bits >> 23) & 0xFF) as i32 - 127;
    if e == -127 {
        return f32::NEG_INFINITY;
    }
    let mut m = f32::from_bits((bits & 0x007F_FFFF) | 0x3F80_0000);
    if m > core::f32::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    let t = (m - 1.0) / (m + 1.0);
    let t2 = t * t;
    let series = t * (1.0 + t2 * (1.0 / 3.0 + t2 * (1.0 / 5.0 + t2 * (1.0 / 7.0 + t2 * (1.0 / 9.0)))));
    e as f32 + series * (2.0 / LN_2)
}

/// `2^x` (relative error about 1.5e-7); 0 below `-126`, infinity at or above 128, NaN for NaN.
#[inline]
pub fn exp2_fast(x: f32) -> f32 {
    if x.is_nan() {
        return x;
    }
    if x < -126.0 {
        return 0.0;
    }
    if x >= 128.0 {
        return f32::INFINITY;
    }
    // Round to nearest: n in [-126, 128], f in [-1/2, 1/2].
    let n = (x + 0.5).floor_fast();
    let f = x - n;
    let g = f * LN_2;
    let p = 1.0
        + g * (1.0 + g * (0.5 + g * (1.0 / 6.0 + g * (1.0 / 24.0 + g * (1.0 / 120.0 + g * (1.0 / 720.0))))));
    let n = n as i32;
    if n == 128 {
        // 2^128 overflows the exponent field: scale in two steps.
        return p * f32::from_bits(((127 + 127) as u32) << 23) * 2.0;
    }
    p * f32::from_bits(((n + 127) as u32) << 23)
}

trait FloorFast {
    fn floor_fast(self) -> f32;
}

impl FloorFast for f32 {
    /// `floor` for `|x| < 2^23` without libm (truncation, then one step down for negatives).
    #[inline]
    fn floor_fast(self) -> f32 {
        let t = self as i32 as f32;
        if t > self {
            t - 1.0
        } else {
            t
        }
    }
}

/// `x^y` for `x >= 0` through [`exp2_fast`] and [`log2_fast`]: `0^y = 0` for `y > 0`,
/// `x^0 = 1`.
#[inline]
pub fn pow_fast(x: f32, y: f32) -> f32 {
    if y == 0.0 {
        return 1.0;
    }
    if x == 0.0 {
        return 0.0;
    }
    exp2_fast(y * log2_fast(x))
}

/// The six-parameter model through [`pow_fast`], [`exp2_fast`] and [`log2_fast`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastSix {
    spec_scale: f32,
    kr2: f32,
    abs_b_log2e: f32,
    a: f32,
    diffuse_scale: f32,
    c: f32,
}

impl FastSix {
    /// Validates the parameters and precomputes the per-material constants.
    pub fn new(p: SixParams<f32>) -> Result<Self, ParamError> {
        p.validate()?;
        let (spec_scale, kr2, diffuse_scale) = p.scales();
        Ok(FastSix {
            spec_scale,
            kr2,
            abs_b_log2e: p.b.abs() * core::f32::consts::LOG2_E,
            a: p.a,
            diffuse_scale,
            c: p.c,
        })
    }
}

impl Brdf<f32> for FastSix {
    #[inline]
    fn eval(&self, g: &Geometry<f32>) -> f32 {
        if !g.above_horizon() {
            return if g.cos_theta_i().is_nan() || g.cos_theta_r().is_nan() {
                f32::NAN
            } else {
                0.0
            };
        }
        let m = g.cos_theta_i() * g.cos_theta_r();
        let lobe = exp2_fast(-self.abs_b_log2e * pow_fast(g.one_minus_cos_gamma(), self.a));
        // ln(1 + m) = log2(u) ln 2 * m / (u - 1), u = fl(1 + m): exact-ratio trick, keeps the
        // relative accuracy for small m.
        let u = 1.0 + m;
        let ln1p = if u == 1.0 {
            m
        } else {
            log2_fast(u) * LN_2 * (m / (u - 1.0))
        };
        let spec = self.spec_scale * facet(self.kr2, g) * lobe * ln1p;
        spec + self.diffuse_scale * pow_fast(m, self.c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log2_and_exp2_within_their_stated_errors() {
        let mut worst = (0.0f64, 0.0f64);
        let mut x = 1e-30f32;
        while x < 1e30 {
            let want = f64::from(x).log2();
            let l = f64::from(log2_fast(x)) - want;
            worst.0 = worst.0.max(l.abs() / want.abs().max(1.0));
            x *= 1.0007;
        }
        let mut y = -125.9f32;
        while y < 127.9 {
            let want = f64::from(y).exp2();
            worst.1 = worst.1.max(((f64::from(exp2_fast(y)) - want) / want).abs());
            y += 0.0013;
        }
        assert!(worst.0 < 3e-7 && worst.1 < 3e-7, "{worst:?}");
        assert_eq!(exp2_fast(-200.0), 0.0);
        assert_eq!(exp2_fast(200.0), f32::INFINITY);
        assert!(log2_fast(-1.0).is_nan() && exp2_fast(f32::NAN).is_nan());
        assert_eq!(log2_fast(0.0), f32::NEG_INFINITY);
        assert_eq!((pow_fast(0.0, 0.5), pow_fast(0.3, 0.0)), (0.0, 1.0));
    }
}
