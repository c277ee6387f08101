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
    ($t:ident, $splitter:expr, $sqrt:ident, $exp:ident, $ln:ident, $ln1p:ident, $pow:ident, $sin:ident,
     $cos:ident, $sincos:ident, $fabs:ident) => {
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
                libm::$sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                libm::$cos(self)
            }
            #[inline]
            fn sin_cos(self) -> (Self, Self) {
                libm::$sincos(self)
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

impl_float!(f32, 4097.0, sqrt_f32, expf, logf, log1pf, powf_f32, sinf, cosf, sincosf, fabsf);
impl_float!(
    f64,
    134_217_729.0,
    sqrt_f64,
    exp,
    log,
    log1p,
    pow_f64,
    sin,
    cos,
    sincos,
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
