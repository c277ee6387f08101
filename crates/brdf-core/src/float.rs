//! The one float abstraction of the core: f32 and f64, all math through `libm` (the f32
//! square root uses the FPU instruction on the Cortex-M4F; both are correctly rounded).
//!
//! The trait is sealed (only `f32` and `f64` implement it) so that host code and the
//! firmware always run the same `libm` arithmetic; num-traits' `Float` is avoided on
//! purpose because its `std` feature would switch the host to std math.

use core::fmt::{Debug, Display};
use core::ops::{Add, Div, Mul, Neg, Sub};

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A floating-point type the models can be evaluated in: `f32` (the device path) or
/// `f64` (the host reference). Sealed: it cannot be implemented outside this crate.
pub trait Float:
    sealed::Sealed
    + Copy
    + Debug
    + Display
    + Default
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// 0
    const ZERO: Self;
    /// 1
    const ONE: Self;
    /// 2
    const TWO: Self;
    /// 1/2
    const HALF: Self;
    /// pi
    const PI: Self;
    /// 1/pi
    const FRAC_1_PI: Self;
    /// pi/2, rounded to this type.
    const FRAC_PI_2: Self;
    /// ln 2
    const LN_2: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    /// Veltkamp splitting constant `2^ceil(p/2) + 1` (p = mantissa bits) for exact products.
    const SPLITTER: Self;

    /// Nearest value of this type to `x` (rounds once).
    fn from_f64(x: f64) -> Self;
    /// Exact widening (f32) or identity (f64).
    fn to_f64(self) -> f64;

    /// `sqrt(x)`, correctly rounded.
    fn sqrt(self) -> Self;
    /// `e^x`.
    fn exp(self) -> Self;
    /// Natural logarithm.
    fn ln(self) -> Self;
    /// `ln(1 + x)`, accurate for small `x`.
    fn ln_1p(self) -> Self;
    /// `x^y` for `x >= 0` (`0^y = 0` for `y > 0`, `x^0 = 1`). f32: libm `powf` (within
    /// 0.65 ulp measured). f64: `exp(y ln x)`, relative error below `(|y ln x| + 2)` ulp —
    /// under 1e-14 for the model's exponents — at a third of libm `pow`'s cost.
    fn powf(self, y: Self) -> Self;
    /// Sine of radians.
    fn sin(self) -> Self;
    /// Cosine of radians.
    fn cos(self) -> Self;
    /// `(sin x, cos x)` with one argument reduction.
    fn sin_cos(self) -> (Self, Self);
    /// Absolute value.
    fn abs(self) -> Self;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> bool;
    /// Smaller of the two; NaN if either is NaN is not guaranteed (use on finite values).
    fn min(self, other: Self) -> Self {
        if other < self {
            other
        } else {
            self
        }
    }
    /// Larger of the two (use on finite values).
    fn max(self, other: Self) -> Self {
        if other > self {
            other
        } else {
            self
        }
    }
}

macro_rules! impl_float {
    ($t:ident, $splitter:expr, $sqrt:ident, $exp:ident, $ln:ident, $ln1p:ident, $pow:ident, $sin:path,
     $cos:path, $sincos:path, $fabs:ident) => {
        impl Float for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const TWO: Self = 2.0;
            const HALF: Self = 0.5;
            const PI: Self = core::$t::consts::PI;
            const FRAC_1_PI: Self = core::$t::consts::FRAC_1_PI;
            const FRAC_PI_2: Self = core::$t::consts::FRAC_PI_2;
            const LN_2: Self = core::$t::consts::LN_2;
            const EPSILON: Self = $t::EPSILON;
            const SPLITTER: Self = $splitter;

            #[inline]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn sqrt(self) -> Self {
                $sqrt(self)
            }
            #[inline]
            fn exp(self) -> Self {
                libm::$exp(self)
            }
            #[inline]
            fn ln(self) -> Self {
                libm::$ln(self)
            }
            #[inline]
            fn ln_1p(self) -> Self {
                libm::$ln1p(self)
            }
            #[inline]
            fn powf(self, y: Self) -> Self {
                $pow(self, y)
            }
            #[inline]
            fn sin(self) -> Self {
                $sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                $cos(self)
            }
            #[inline]
            fn sin_cos(self) -> (Self, Self) {
                $sincos(self)
            }
            #[inline]
            fn abs(self) -> Self {
                libm::$fabs(self)
            }
            #[inline]
            fn is_finite(self) -> bool {
                $t::is_finite(self)
            }
        }
    };
}

impl_float!(
    f32,
    4097.0,
    sqrt_f32,
    expf,
    logf,
    log1pf,
    powf_f32,
    sin_f32,
    cos_f32,
    sin_cos_f32,
    fabsf
);
impl_float!(
    f64,
    134_217_729.0,
    sqrt_f64,
    exp,
    log,
    log1p,
    pow_f64,
    libm::sin,
    libm::cos,
    libm::sincos,
    fabs
);

/// Veltkamp split: `x = hi + lo` exactly, each half with at most half the mantissa bits.
#[inline]
pub(crate) fn split<T: Float>(x: T) -> (T, T) {
    let t = T::SPLITTER * x;
    let hi = t - (t - x);
    (hi, x - hi)
}

/// Dekker's TwoProduct error term: with `p = fl(a * b)` and `a = a_hi + a_lo` from
/// [`split`], returns `a * b - p` exactly (barring underflow), without an FMA.
#[inline]
pub(crate) fn product_error<T: Float>(a_hi: T, a_lo: T, b: T, p: T) -> T {
    let (b_hi, b_lo) = split(b);
    ((a_hi * b_hi - p) + a_hi * b_lo + a_lo * b_hi) + a_lo * b_lo
}

/// Correctly rounded f32 square root. On a hard-float Arm target (the Cortex-M4F) it is the
/// FPU's `vsqrt.f32` (14 cycles; 6 instructions with its operand moves) instead of libm's
/// software routine (about 51 instructions); both are IEEE 754 correctly rounded, so host and device results stay
/// bit-identical.
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        let bits: u32;
        // Rust's `sreg` operand class needs the double-precision `vfp2` feature, which the
        // single-precision FPU of the M4F lacks; so the operand travels in a core register
        // and s15 is saved around the instruction (6 instructions in all).
        // SAFETY: s15 is restored before the block ends; the stack use is balanced; no
        // memory visible to Rust is touched; every eabihf target has `vsqrt.f32`.
        #[allow(unsafe_code)]
        unsafe {
            core::arch::asm!(
                "vpush {{s15}}",
                "vmov s15, {0}",
                "vsqrt.f32 s15, s15",
                "vmov {0}, s15",
                "vpop {{s15}}",
                inout(reg) x.to_bits() => bits,
                options(pure, nomem, preserves_flags),
            );
        }
        f32::from_bits(bits)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

#[inline]
fn sqrt_f64(x: f64) -> f64 {
    libm::sqrt(x)
}

#[inline]
fn powf_f32(x: f32, y: f32) -> f32 {
    libm::powf(x, y)
}

#[inline]
fn pow_f64(x: f64, y: f64) -> f64 {
    if y == 0.0 {
        1.0
    } else {
        libm::exp(y * libm::log(x))
    }
}

/// Largest `|x|` that [`sin_cos_f32`] reduces itself; beyond it `libm::sincosf` does.
const SIN_COS_F32_MAX: f32 = 4096.0;

/// `(sin x, cos x)` in f32 arithmetic alone — the device has no double-precision FPU, and
/// libm's `sincosf` computes in software f64 (about 2,000 instructions on the Cortex-M4F).
///
/// For `|x| <= 4096`: `x = n pi/2 + r`, with `pi/2` in four parts of 8, 12, 12 and 24 bits
/// (`n < 2^12`, so the first three products are exact, `x - n P1` is exact by Sterbenz and
/// `- n P2` is exact on the 2^-24 grid below 1); the third subtraction's rounding is carried
/// as a tail `y` (TwoSum), and the fourth part's product joins it. What is left of `pi/2`
/// (8e-20 per unit of `n`) moves `r` by at most 3.2e-9 relative at the f32 nearest to any
/// multiple of `pi/2` below 4096 (searched exhaustively), so `r` is good to about an f32
/// ulp even where it is tiny — the zeniths at the horizon and the azimuths near the mirror
/// that the cancellation-free geometry needs to relative accuracy. Then fdlibm's f32
/// kernels (`k_sinf`, `k_cosf` with the tail) to degree 9 and 10 on `|r| <= pi/4`
/// (truncation below 3e-9 relative): within 1.1 x 2^-24 relative of the exact value
/// (tested at 4 million arguments). IEEE single operations only, no fused multiply-add,
/// so the host and the device compute the same bits. Beyond 4096, and for non-finite `x`,
/// `libm::sincosf`.
// The parts of pi/2 are written with the digits of their exact binary values.
#[allow(clippy::excessive_precision)]
fn sin_cos_f32(x: f32) -> (f32, f32) {
    const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;
    // 1.5 * 2^23: adding it rounds |v| < 2^22 to an integer.
    const SHIFT: f32 = 12_582_912.0;
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_512_969_970_703e-4;
    const P3: f32 = 7.549_533_620_476_723e-8;
    const P4: f32 = 2.563_344_068_257_089_6e-12;
    if x.is_nan() || libm::fabsf(x) > SIN_COS_F32_MAX {
        return libm::sincosf(x);
    }
    let t = x * FRAC_2_PI + SHIFT;
    let n = t - SHIFT;
    let q = t.to_bits() & 3;
    // Exact (see above).
    let r2 = (x - n * P1) - n * P2;
    // n P3 is exact; TwoSum: r + e = r2 - n P3 exactly, whichever of the two is larger.
    let mp3 = -(n * P3);
    let r = r2 + mp3;
    let bb = r - r2;
    let e = (r2 - (r - bb)) + (mp3 - bb);
    let y = e - n * P4;
    let s = k_sinf(r, y);
    let c = k_cosf(r, y);
    match q {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

fn sin_f32(x: f32) -> f32 {
    sin_cos_f32(x).0
}

fn cos_f32(x: f32) -> f32 {
    sin_cos_f32(x).1
}

/// fdlibm `__kernel_sinf(x, y, 1)` to degree 9 on `|x| <= pi/4`, tail `y`.
// fdlibm's constants, digit for digit as published.
#[allow(clippy::excessive_precision)]
#[inline(always)]
fn k_sinf(x: f32, y: f32) -> f32 {
    const S1: f32 = -1.666_666_716_3e-1;
    const S2: f32 = 8.333_333_768_0e-3;
    const S3: f32 = -1.984_127_011_4e-4;
    const S4: f32 = 2.755_731_429_7e-6;
    let z = x * x;
    let v = z * x;
    let r = S2 + z * (S3 + z * S4);
    x - ((z * (0.5 * y - v * r) - y) - v * S1)
}

/// fdlibm `__kernel_cosf` to degree 10 on `|x| <= pi/4`, tail `y`, with the exact
/// compensation of `1 - x^2/2` (as in musl's `__cos`).
#[allow(clippy::excessive_precision)]
#[inline(always)]
fn k_cosf(x: f32, y: f32) -> f32 {
    const C1: f32 = 4.166_666_790_8e-2;
    const C2: f32 = -1.388_888_922_5e-3;
    const C3: f32 = 2.480_158_764_2e-5;
    const C4: f32 = -2.755_731_429_7e-7;
    let z = x * x;
    let r = z * (C1 + z * (C2 + z * (C3 + z * C4)));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    w + (((1.0 - w) - hz) + (z * r - x * y))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    /// Relative error of `got` against the f64 value at the same f32 input, in f32 ulps of
    /// the exact value (`2^-24` relative), with an absolute floor of one f32 subnormal step.
    fn ulps(got: f32, exact: f64) -> f64 {
        let scale = exact.abs().max(f64::from(f32::MIN_POSITIVE));
        (f64::from(got) - exact).abs() / scale * f64::from(1u32 << 24)
    }

    /// Every f32 in `[lo, hi]` when the range is small, otherwise an even spread plus the
    /// neighbours of every multiple of pi/2 in range (where `r` is tiny).
    fn inputs(lo: f32, hi: f32) -> Vec<f32> {
        let mut v = Vec::new();
        let (a, b) = (lo.to_bits(), hi.to_bits());
        let step = ((b - a) / 2_000_000).max(1);
        let mut u = a;
        while u <= b {
            v.push(f32::from_bits(u));
            u += step;
        }
        let mut k = 0.0f64;
        while k * core::f64::consts::FRAC_PI_2 <= f64::from(hi) {
            let c = (k * core::f64::consts::FRAC_PI_2) as f32;
            let bits = c.to_bits();
            for d in 0..8u32 {
                v.push(f32::from_bits(bits + d));
                v.push(f32::from_bits(bits.saturating_sub(d)));
            }
            k += 1.0;
        }
        v
    }

    #[test]
    fn f32_sin_cos_is_within_one_and_a_half_units_of_2_pow_minus_24_relative() {
        let mut worst = (0.0f64, 0.0f32);
        for x in inputs(1e-30, SIN_COS_F32_MAX) {
            for x in [x, -x] {
                let (s, c) = sin_cos_f32(x);
                let (es, ec) = libm::sincos(f64::from(x));
                for e in [ulps(s, es), ulps(c, ec)] {
                    if e > worst.0 {
                        worst = (e, x);
                    }
                }
                assert_eq!((sin_f32(x), cos_f32(x)), (s, c));
            }
        }
        // 1.5 units of 2^-24 relative (measured 1.10 at 3125.3057; libm's sincosf, which
        // computes in f64, rounds correctly: 0.5): well inside the f32 tolerance.
        assert!(worst.0 <= 1.5, "{worst:?}");
        // The exact ends and beyond the reduction's range.
        assert_eq!(sin_cos_f32(0.0), (0.0, 1.0));
        let far = sin_cos_f32(1e6);
        assert_eq!(far, libm::sincosf(1e6));
        assert!(sin_cos_f32(f32::NAN).0.is_nan() && sin_cos_f32(f32::INFINITY).1.is_nan());
    }
}
