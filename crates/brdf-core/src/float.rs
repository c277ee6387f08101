//! The one float abstraction of the core: f32 and f64.
//!
//! - f64 (the host reference): `libm`.
//! - f32 (the device path, and the host's `--precision f32`): `exp`, `ln`, `ln_1p`, `powf`
//!   and the sine/cosine pair are computed here in IEEE single-precision operations alone
//!   (no fused multiply-add), within a few units of `2^-24` relative
//!   ([`crate::tolerance::F32_EXP_ULPS`], [`crate::tolerance::F32_LN_ULPS`],
//!   [`crate::tolerance::f32_pow_ulps`]). libm's f32 routines compute in f64 internally,
//!   which the Cortex-M4F does in software: through them one six-parameter evaluation took
//!   750 instructions from cosines and 1,104 from angles, against 378 and 574 here. The
//!   square root is the FPU instruction on the M4F and libm's elsewhere (both correctly
//!   rounded).
//!
//! The trait is sealed (only `f32` and `f64` implement it) so that host code and the
//! firmware always run the same arithmetic, bit for bit; num-traits' `Float` is avoided on
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
    /// The smallest positive normal number.
    const MIN_POSITIVE: Self;
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
    /// `x^y` for `x >= 0` (`0^y = 0` for `y > 0`, `x^0 = 1`). f32: in f32 arithmetic, the
    /// exponent in two parts (within `2 + 1.8 |y|` units of `2^-24`). f64: `exp(y ln x)`,
    /// relative error below `(|y ln x| + 2)` ulp — under 1e-14 for the model's exponents — at
    /// a third of libm `pow`'s cost.
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
    /// `self as usize`: truncated towards zero, saturating (negative and NaN give 0).
    fn to_index(self) -> usize;
    /// `i` as this type (rounded to nearest for large `i`).
    fn from_index(i: usize) -> Self;
    /// `x` as this type (exact: f32 widens or stays).
    fn from_f32(x: f32) -> Self;
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
    ($t:ident, $splitter:expr, $sqrt:ident, $exp:path, $ln:path, $ln1p:path, $pow:ident, $sin:path,
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
            const MIN_POSITIVE: Self = $t::MIN_POSITIVE;
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
                $exp(self)
            }
            #[inline]
            fn ln(self) -> Self {
                $ln(self)
            }
            #[inline]
            fn ln_1p(self) -> Self {
                $ln1p(self)
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
            #[inline]
            fn to_index(self) -> usize {
                self as usize
            }
            #[inline]
            fn from_index(i: usize) -> Self {
                i as $t
            }
            #[inline]
            fn from_f32(x: f32) -> Self {
                x as $t
            }
        }
    };
}

impl_float!(
    f32,
    4097.0,
    sqrt_f32,
    exp_f32,
    ln_f32,
    ln_1p_f32,
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
    libm::exp,
    libm::log,
    libm::log1p,
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

/// Correctly rounded f32 square root. On a hard-float Arm target (the Cortex-M4F and M33) it
/// is a call to the C library's `sqrtf`, which LLVM turns into the FPU's `vsqrt.f32` (14
/// cycles) and a test of its result: 4 instructions in all, with a call to the software
/// `sqrtf` (which `compiler_builtins` supplies) only when the result is NaN, to set `errno`
/// as C requires. Both are IEEE 754 correctly rounded, as libm's `sqrtf` on the host is, so
/// host and device results stay bit-identical. (Inline assembly cannot name an `s` register
/// on these targets, since Rust's `sreg` class needs the double-precision `vfp2` feature, and
/// moving the operand through a core register costs 6 instructions.)
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        sqrtf(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

// The C library's square root: `compiler_builtins` defines the symbol on bare-metal targets;
// declaring it here lets LLVM recognise it and emit the FPU instruction (see `sqrt_f32`).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[allow(unsafe_code)]
unsafe extern "C" {
    safe fn sqrtf(x: f32) -> f32;
}

#[inline]
fn sqrt_f64(x: f64) -> f64 {
    libm::sqrt(x)
}

/// 1.5 * 2^23: adding it to `|v| < 2^22` rounds `v` to the nearest integer `n` (ties to
/// even), and the sum's bits are `SHIFT`'s plus `n`.
const SHIFT: f32 = 12_582_912.0;

/// The integer `n` that `t = v + SHIFT` holds (see [`SHIFT`]).
#[inline(always)]
fn shifted_int(t: f32) -> i32 {
    t.to_bits() as i32 - SHIFT.to_bits() as i32
}

/// `2^k` for `k` in `[-126, 127]` (a normal f32), from its exponent bits.
#[inline(always)]
fn pow2(k: i32) -> f32 {
    f32::from_bits(((k + 127) as u32) << 23)
}

/// `p 2^n` for `p` in `[1/2, 2]`, rounding once (subnormal results included); 0 for
/// `n < -151`, infinity for `n > 128` (where `p 2^n` is beyond half the smallest subnormal
/// or the largest f32).
#[inline(always)]
fn times_pow2(p: f32, n: i32) -> f32 {
    if ((n + 126) as u32) <= 253 {
        p * pow2(n)
    } else {
        times_pow2_edges(p, n)
    }
}

/// [`times_pow2`] outside the normal exponents.
#[cold]
#[inline(never)]
fn times_pow2_edges(p: f32, n: i32) -> f32 {
    if n < -151 {
        0.0
    } else if n < -126 {
        // The first product is exact; the second rounds into the subnormal range.
        p * pow2(n + 64) * pow2(-64)
    } else if n <= 128 {
        p * pow2(127) * pow2(n - 127)
    } else {
        f32::INFINITY
    }
}

/// `ln 2` in two parts: `LN2_HI` has 15 significant bits, so `n LN2_HI` is exact for
/// `|n| < 2^9`; `LN2_LO` is the rest, to f32 precision.
// Each literal is a prefix of the exact binary value's digits and rounds to the intended f32.
#[allow(clippy::excessive_precision)]
const LN2_HI: f32 = 0.693_145_751_953_125;
#[allow(clippy::excessive_precision)]
const LN2_LO: f32 = 1.428_606_765_330_187_045_e-6;

/// `x = 2^e m` with `m` in `[sqrt(1/2), sqrt(2))`, for positive normal `x`: returns
/// `(e, t)` with `t = (m - 1)/(m + 1)`, so that `ln m = 2 atanh t` and `|t| <= 0.1716`.
/// `m - 1` is exact (Sterbenz); `t` is within about 1.5 ulp.
#[inline(always)]
fn log_reduce(x: f32) -> (f32, f32) {
    // The bits of sqrt(1/2): offsetting by them puts the mantissa's break at sqrt(1/2).
    const SQRT_HALF_BITS: u32 = 0x3F35_04F3;
    let bits = x.to_bits() + (0x3F80_0000 - SQRT_HALF_BITS);
    let e = (bits >> 23) as i32 - 127;
    let f = f32::from_bits((bits & 0x007F_FFFF) + SQRT_HALF_BITS) - 1.0;
    (e as f32, f / (2.0 + f))
}

/// `ln m = 2 atanh t = 2t + t^3 R(t^2)` for `|t| <= 0.1716`: `R` is the minimax polynomial
/// of degree 2 (relative error of the result below 1e-9 before rounding).
#[allow(clippy::excessive_precision)]
#[inline(always)]
fn ln_series(t: f32) -> f32 {
    const L0: f32 = 0.666_667_82;
    const L1: f32 = 0.399_766_36;
    const L2: f32 = 0.298_981_52;
    let s = t * t;
    2.0 * t + t * s * (L0 + s * (L1 + s * L2))
}

/// `e^x` in f32 arithmetic: `x = n ln 2 + r` (Cody–Waite with [`LN2_HI`], [`LN2_LO`]: `r`
/// good to an ulp), `e^r = 1 + r + r^2 Q(r)` on `|r| <= 0.354` with `Q` the minimax
/// polynomial of degree 4 (relative error below 5e-9), times `2^n`. Within
/// [`crate::tolerance::F32_EXP_ULPS`] units of `2^-24` relative (measured 1.50, test
/// `f32_elementary_functions_within_their_ulps`). 0 below -104, infinity above 88.8, NaN
/// for NaN.
#[allow(clippy::excessive_precision)]
fn exp_f32(x: f32) -> f32 {
    const E0: f32 = 0.499_999_94;
    const E1: f32 = 0.166_665_09;
    const E2: f32 = 0.041_668_53;
    const E3: f32 = 0.008_370_141;
    const E4: f32 = 0.001_381_165_1;
    // One comparison on the common path: NaN fails `x > -104` too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(x > -104.0) {
        return if x.is_nan() { x } else { 0.0 };
    }
    if x > 88.8 {
        return f32::INFINITY;
    }
    let t = x * core::f32::consts::LOG2_E + SHIFT;
    let n = t - SHIFT;
    // n LN2_HI is exact and so is the first subtraction (Sterbenz).
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let q = E0 + r * (E1 + r * (E2 + r * (E3 + r * E4)));
    times_pow2(1.0 + (r + r * r * q), shifted_int(t))
}

/// Natural logarithm in f32 arithmetic: `e ln 2 + ln m` from [`log_reduce`] and
/// [`ln_series`], `e ln 2` in two parts. Within [`crate::tolerance::F32_LN_ULPS`] units of
/// `2^-24` relative (measured 2.95, near `x = 1`, where the result is `ln m` alone and carries
/// the rounding of `t`). NaN below 0, `-inf` at 0.
fn ln_f32(x: f32) -> f32 {
    if x.is_nan() || x < 0.0 {
        return f32::NAN;
    }
    if x == 0.0 {
        return f32::NEG_INFINITY;
    }
    if x == f32::INFINITY {
        return x;
    }
    if x < f32::MIN_POSITIVE {
        // Subnormal: 2^25 x is normal (and exact).
        return ln_f32(x * 33_554_432.0) - 25.0 * LN2_HI - 25.0 * LN2_LO;
    }
    let (e, t) = log_reduce(x);
    e * LN2_HI + (e * LN2_LO + ln_series(t))
}

/// `ln(1 + x)` in f32 arithmetic, keeping its relative accuracy for small `x`:
/// - `sqrt(1/2) - 1 <= x <= sqrt(2) - 1`: `2 atanh(x / (2 + x))`, no rounding of `1 + x`;
/// - `sqrt(2) - 1 < x <= 1` (the model's `ln(1 + cos ti cos tr)`): `ln 2 + 2 atanh((x - 1)/(x + 3))`;
/// - elsewhere: `ln(u)` of `u = fl(1 + x)` plus the correction `(x - (u - 1))/u`.
///
/// Within [`crate::tolerance::F32_LN_ULPS`] units of `2^-24` relative (measured 2.95). For
/// `|x| < 2^-125` the result is subnormal and keeps only the bits a subnormal `t` holds (the
/// model never asks there: such values are far below its floor). NaN below -1, `-inf` at -1.
#[allow(clippy::excessive_precision)]
fn ln_1p_f32(x: f32) -> f32 {
    const LOW: f32 = -0.292_893_22;
    const HIGH: f32 = 0.414_213_56;
    if (LOW..=HIGH).contains(&x) {
        return ln_series(x / (2.0 + x));
    }
    if x > HIGH && x <= 1.0 {
        return LN2_HI + (LN2_LO + ln_series((x - 1.0) / (x + 3.0)));
    }
    if x.is_nan() || x < -1.0 {
        return f32::NAN;
    }
    if x == -1.0 {
        return f32::NEG_INFINITY;
    }
    let u = 1.0 + x;
    if u == f32::INFINITY {
        return u;
    }
    ln_f32(u) + (x - (u - 1.0)) / u
}

/// `x^y` for `x >= 0` in f32 arithmetic: `2^(y log2 x)` with `y log2 x` carried in two
/// parts, so that its rounding does not grow with `|y log2 x|` (a plain
/// `exp2(y * log2(x))` in f32 loses `|y log2 x|` ulp):
/// - `log2 x = e + s`, `e` an integer, `|s| <= 1/2` ([`log_reduce`], [`ln_series`]);
/// - `y = yh + yl`, `yh` the leading 12 bits of `y`: `yh e` is exact and holds the large
///   part, `zs = yl e + y s` the small one (`|zs| <= 0.58 |y|` for normal `y`);
/// - `n` the integer nearest `yh e + zs`, `f = (yh e - n) + zs` (the subtraction exact) on
///   `|f| <= 0.5001`, `2^f = 1 + f P(f)` with `P` of degree 5 (relative error below
///   3.5e-9), times `2^n`.
///
/// Error: within [`crate::tolerance::f32_pow_ulps`] (`2 + 1.8 |y|`) units of `2^-24`
/// relative (test `f32_elementary_functions_within_their_ulps`). What grows with `|y|` is
/// `y` times the error of `s` (up to 1.02 units of `s`'s size over every mantissa: `t` and
/// the series round, and so does the product with `log2 e`) and the roundings of `y s` and
/// `zs`, whose absolute errors grow with them; libm's `powf` rounds correctly but computes in
/// f64 (software on the Cortex-M4F). `x^0 = 1`; zero, infinite, negative and NaN `x`, and
/// `|y| > 16`, go to `libm::powf` (`0^y = 0` for `y > 0`).
fn powf_f32(x: f32, y: f32) -> f32 {
    // One unsigned comparison each (NaN and infinities fail both): x positive and normal,
    // |y| <= 16.
    let normal_x = x.to_bits().wrapping_sub(0x0080_0000) < 0x7F00_0000;
    if !(normal_x && y.to_bits() & 0x7FFF_FFFF <= 16.0f32.to_bits()) {
        return powf_f32_edges(x, y);
    }
    pow_normal(x, y, 0.0)
}

/// `2^e_extra x^y` for positive normal `x`, `|y| <= 16` and integer `e_extra` (see
/// [`powf_f32`]).
#[allow(clippy::excessive_precision)]
#[inline(always)]
fn pow_normal(x: f32, y: f32, e_extra: f32) -> f32 {
    // ln 2 (in f32) for degree 1, the rest fitted to it (minimax, each rounded to f32):
    // relative error of the polynomial below 3.5e-9 on |f| <= 0.5002.
    const P0: f32 = core::f32::consts::LN_2;
    const P1: f32 = 0.240_226_48;
    const P2: f32 = 0.055_503_596;
    const P3: f32 = 0.009_618_519;
    const P4: f32 = 0.001_339_106_8;
    const P5: f32 = 0.000_153_241_4;
    let (e, t) = log_reduce(x);
    let e = e + e_extra;
    let s = ln_series(t) * core::f32::consts::LOG2_E;
    let yh = f32::from_bits(y.to_bits() & 0xFFFF_F000);
    let yl = y - yh;
    // yh has 12 significant bits and |e| <= 150 has 8: the product is exact.
    let zb = yh * e;
    let zs = yl * e + y * s;
    // |zb + zs| <= 16 * 150 < 2^22, within SHIFT's range.
    let t = (zb + zs) + SHIFT;
    let n = shifted_int(t);
    let f = (zb - (t - SHIFT)) + zs;
    let p = 1.0 + f * (P0 + f * (P1 + f * (P2 + f * (P3 + f * (P4 + f * P5)))));
    times_pow2(p, n)
}

/// [`powf_f32`] where `x` is not a positive normal number or `|y| > 16`: a subnormal `x` is
/// scaled by `2^24` (exactly) and its exponent corrected; the rest is libm's `powf` (zero,
/// infinite, negative and NaN `x`, large `|y|`).
#[cold]
#[inline(never)]
fn powf_f32_edges(x: f32, y: f32) -> f32 {
    if x > 0.0 && x < f32::MIN_POSITIVE && libm::fabsf(y) <= 16.0 {
        return pow_normal(x * 16_777_216.0, y, -24.0);
    }
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
/// The model's angles mostly need no reduction: zeniths lie in `[0, pi/2]`, and so do the
/// half sums and half azimuths of [`crate::Geometry::from_angles`]. So:
/// - `|x| <= pi/4`: the kernels directly;
/// - `|x| <= fl(pi/2)`: `sin x = cos d`, `cos x = sin d` for `d = pi/2 - |x|`, with `pi/2` in
///   three parts (f32, then 4.4e-8, then 1.7e-15): the first subtraction is exact
///   (Sterbenz), the second's rounding is carried as the kernels' tail (Fast2Sum), so `d` is
///   good to about 2^-48 relative even where it is tiny (the zeniths at the horizon);
/// - beyond: [`sin_cos_reduced`].
#[inline]
fn sin_cos_f32(x: f32) -> (f32, f32) {
    const FRAC_PI_4: f32 = core::f32::consts::FRAC_PI_4;
    const PIO2_HI: f32 = core::f32::consts::FRAC_PI_2;
    // pi/2 - PIO2_HI in two further f32 parts (each literal rounds to the f32 meant).
    #[allow(clippy::excessive_precision)]
    const PIO2_LO: f32 = -4.371_138_828_673_793e-8;
    #[allow(clippy::excessive_precision)]
    const PIO2_LO2: f32 = -1.715_124_510_005_882e-15;
    let ax = f32::from_bits(x.to_bits() & 0x7FFF_FFFF);
    if ax <= FRAC_PI_4 {
        return (k_sinf(x, 0.0), k_cosf(x, 0.0));
    }
    if ax <= PIO2_HI {
        let a = PIO2_HI - ax;
        let d = a + PIO2_LO;
        let y = (PIO2_LO - (d - a)) + PIO2_LO2;
        let s = k_cosf(d, y);
        return (if x < 0.0 { -s } else { s }, k_sinf(d, y));
    }
    sin_cos_reduced(x)
}

/// [`sin_cos_f32`] beyond `pi/2`. For `|x| <= 4096`: `x = n pi/2 + r`, with `pi/2` in four
/// parts of 8, 12, 12 and 24 bits (`n < 2^12`, so the first three products are exact, `x - n P1` is exact by Sterbenz and
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
#[inline(never)]
fn sin_cos_reduced(x: f32) -> (f32, f32) {
    const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_512_969_970_703e-4;
    const P3: f32 = 7.549_533_620_476_723e-8;
    const P4: f32 = 2.563_344_068_257_089_6e-12;
    if x.is_nan() || libm::fabsf(x) > SIN_COS_F32_MAX {
        return sin_cos_libm(x);
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

/// libm's `sincosf`, kept out of line so that its frame stays off the common path.
#[cold]
#[inline(never)]
fn sin_cos_libm(x: f32) -> (f32, f32) {
    libm::sincosf(x)
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

    /// Worst error, in units of `2^-24` relative (see [`ulps`]), of `f` against `exact` over
    /// `xs`, with the argument where it occurs.
    fn worst_ulps(xs: &[f32], f: impl Fn(f32) -> f32, exact: impl Fn(f64) -> f64) -> (f64, f32) {
        let mut worst = (0.0f64, 0.0f32);
        for &x in xs {
            let (got, want) = (f(x), exact(f64::from(x)));
            if want.abs() > f64::from(f32::MAX) {
                // Beyond f32: infinity, or the largest finite value when rounding down.
                assert!(got.abs() >= f32::MAX, "{x}: {got} for {want}");
                continue;
            }
            let e = ulps(got, want);
            if e > worst.0 || e.is_nan() {
                worst = (e, x);
            }
        }
        worst
    }

    /// An even spread of f32 bit patterns over `[lo, hi]` (same sign), about `n` of them.
    fn spread(lo: f32, hi: f32, n: u32) -> Vec<f32> {
        let (a, b) = (lo.to_bits().min(hi.to_bits()), lo.to_bits().max(hi.to_bits()));
        let step = ((b - a) / n).max(1);
        (0..=(b - a) / step)
            .map(|k| f32::from_bits(a + k * step))
            .collect()
    }

    #[test]
    fn f32_elementary_functions_within_their_ulps() {
        use crate::tolerance::{f32_pow_ulps, F32_EXP_ULPS, F32_LN_ULPS};
        let mut pos = spread(1e-44, 3e38, 2_000_000);
        // Every f32 within 1% of 1, where ln x is the series alone (worst near 1.0079).
        pos.extend(spread(0.99, 1.01, 300_000));
        let mut exp_in = spread(1e-30, 88.8, 1_000_000);
        exp_in.extend(spread(-1e-30, -104.0, 1_000_000));
        // Every f32 around the worst measured (-88.03, a subnormal result).
        exp_in.extend(spread(-88.1, -87.9, 30_000));
        let e = worst_ulps(&exp_in, exp_f32, libm::exp);
        assert!(e.0 <= F32_EXP_ULPS, "exp {e:?}");
        let l = worst_ulps(&pos, ln_f32, libm::log);
        assert!(l.0 <= F32_LN_ULPS, "ln {l:?}");
        let mut l1_in = spread(1e-30, 1e30, 1_000_000);
        l1_in.extend(spread(-1e-30, -0.999_999, 1_000_000));
        // The model's range, cos ti cos tr, densely, and every f32 around the worst measured.
        l1_in.extend(spread(1e-6, 1.0, 1_000_000));
        l1_in.extend(spread(0.0078, 0.008, 250_000));
        let l1 = worst_ulps(&l1_in, ln_1p_f32, libm::log1p);
        assert!(l1.0 <= F32_LN_ULPS, "ln_1p {l1:?}");
        // Exponents: the ends of the model's ranges, the worst measured (15.999856 and
        // 8.9308414 at the bases below) and random ones across [-16, 16].
        let mut ys = std::vec![1e-3f32, 0.5, 1.0, 2.0, 10.0, 16.0, -0.5, -0.999, -16.0];
        ys.extend([15.999_856f32, -15.999_856, 8.930_841, -1.010_563_4]);
        let mut state = 7u64;
        ys.extend((0..88).map(|_| {
            (crate::accuracy::splitmix64(&mut state) >> 40) as f32 / (1u64 << 24) as f32 * 32.0 - 16.0
        }));
        let mut bases = spread(1e-40, 1e6, 20_000);
        bases.extend(spread(0.999, 1.001, 5_000));
        // Mantissas next to sqrt(2) and sqrt(1/2), where |log2 m| is largest and so is its
        // error times y, in binades across the range.
        for scale in [
            1.0f32,
            2.0f32.powi(-120),
            2.0f32.powi(-40),
            2.0f32.powi(7),
            2.0f32.powi(100),
        ] {
            let (sqrt2, sqrt_half) = (core::f32::consts::SQRT_2, core::f32::consts::FRAC_1_SQRT_2);
            bases.extend(spread(1.405 * scale, sqrt2 * scale, 8_000));
            bases.extend(spread(sqrt_half * scale, 0.712 * scale, 4_000));
        }
        bases.extend([180.822_07f32, 22.618_917, 0.704_597_9]);
        // The figures tolerance.rs quotes (`cargo test --release -p brdf-core --lib
        // f32_elementary -- --nocapture`).
        std::println!("units of 2^-24: exp {e:?}, ln {l:?}, ln_1p {l1:?}");
        let mut most = (0.0f64, 0.0f32, 0.0f32);
        for y in ys {
            let p = worst_ulps(&bases, |x| powf_f32(x, y), |x| x.powf(f64::from(y)));
            assert!(p.0 <= f32_pow_ulps(f64::from(y)), "pow y={y} {p:?}");
            if p.0 > most.0 {
                most = (p.0, p.1, y);
            }
        }
        std::println!(
            "powf: worst {:.2} units at x = {}, y = {}",
            most.0,
            most.1,
            most.2
        );
        // The edges: libm's special cases, over- and underflow, subnormal results.
        assert_eq!(exp_f32(0.0), 1.0);
        assert_eq!(exp_f32(-200.0), 0.0);
        assert_eq!(exp_f32(89.0), f32::INFINITY);
        assert_eq!(exp_f32(f32::NEG_INFINITY), 0.0);
        assert!(exp_f32(f32::NAN).is_nan() && ln_f32(-1.0).is_nan() && ln_1p_f32(-2.0).is_nan());
        assert_eq!((ln_f32(0.0), ln_f32(1.0)), (f32::NEG_INFINITY, 0.0));
        assert_eq!((ln_1p_f32(-1.0), ln_1p_f32(0.0)), (f32::NEG_INFINITY, 0.0));
        assert_eq!(ln_1p_f32(f32::INFINITY), f32::INFINITY);
        assert_eq!((powf_f32(0.0, 0.5), powf_f32(0.0, -0.5)), (0.0, f32::INFINITY));
        assert_eq!((powf_f32(0.3, 0.0), powf_f32(1.0, 7.3)), (1.0, 1.0));
        assert_eq!(powf_f32(1e30, 5.0), f32::INFINITY);
        assert_eq!(powf_f32(1e-30, 6.0), 0.0);
        assert!(powf_f32(1e-20, 2.1) > 0.0 && powf_f32(1e-20, 2.1) < f32::MIN_POSITIVE);
        assert!(powf_f32(-1.0, 0.5).is_nan() && powf_f32(f32::NAN, 2.0).is_nan());
    }
}
