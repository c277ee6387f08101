//! Per-lane f64 kernels of the batch path, written without data-dependent branches so that a
//! loop calling them vectorises: every `if` below chooses between two already computed values
//! (a select), integers are taken from the bits of a float (no float-to-int conversion, which
//! AVX2 lacks for 64-bit lanes), and each kernel states the domain it is accurate on. The
//! polynomials and reductions are fdlibm's (as in `libm`), so each function errs by about
//! 1 ulp, like the scalar path's `libm` calls.

// fdlibm's constants are kept digit for digit as published (each rounds to the double fdlibm
// lists in hex), so that they can be checked against the source.
#![allow(clippy::excessive_precision)]

/// How a lane computes `a * b + c`: rounded twice (portable) or fused (the FMA levels). The
/// fused form changes results by about an ulp, never the error bounds.
pub(crate) trait Arith: Copy {
    /// `a * b + c`.
    fn mad(a: f64, b: f64, c: f64) -> f64;
    /// `a * b - fl(a * b)` exactly, given `p = fl(a * b)` and Veltkamp halves of `a`.
    fn product_error(a: f64, a_hi: f64, a_lo: f64, b: f64, p: f64) -> f64;
}

/// Separate multiply and add; Dekker's TwoProduct for the product error.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Plain;

impl Arith for Plain {
    #[inline(always)]
    fn mad(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
    #[inline(always)]
    fn product_error(_a: f64, a_hi: f64, a_lo: f64, b: f64, p: f64) -> f64 {
        crate::float::product_error(a_hi, a_lo, b, p)
    }
}

/// Fused multiply-add (compiled only into the FMA levels).
#[cfg(feature = "std")]
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fused;

#[cfg(feature = "std")]
impl Arith for Fused {
    #[inline(always)]
    fn mad(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
    #[inline(always)]
    fn product_error(a: f64, _a_hi: f64, _a_lo: f64, b: f64, p: f64) -> f64 {
        a.mul_add(b, -p)
    }
}

/// `1.5 * 2^52`: adding it rounds a float of magnitude below `2^51` to an integer, which then
/// sits in the low bits of the sum's mantissa.
const SHIFT: f64 = 6_755_399_441_055_744.0;
/// `2^52`, the float whose bits plus a small integer `k` encode `2^52 + k`.
const TWO52: f64 = 4_503_599_627_370_496.0;
/// `2^54`, the scale that makes a subnormal normal.
const TWO54: f64 = 18_014_398_509_481_984.0;

const LN2_HI: f64 = 6.931_471_803_691_238_164_90e-1;
const LN2_LO: f64 = 1.908_214_929_270_587_700_02e-10;
const INV_LN2: f64 = core::f64::consts::LOG2_E;

/// `round(x)` for `|x| < 2^51`, and that integer's low bits.
#[inline(always)]
fn round_with_bits(x: f64) -> (f64, u64) {
    let t = x + SHIFT;
    (t - SHIFT, t.to_bits())
}

/// `e^x` for finite `x`; 0 below -745.2, infinity above 709.8. Reduction as fdlibm's
/// (`x = k ln 2 + r`, `|r| <= ln2/2`, `ln 2` in two parts), then `e^r` as its Taylor
/// polynomial of degree 12 (truncation below 2e-17 relative): no division. NaN gives NaN. Within 2 ulp of libm (tested).
#[inline(always)]
pub(crate) fn exp<A: Arith>(x: f64) -> f64 {
    // Keep the reduction's integer within range; the result saturates to 0 or infinity.
    let xc = if x < -746.0 { -746.0 } else { x };
    let xc = if xc > 710.0 { 710.0 } else { xc };
    let (kf, bits) = round_with_bits(xc * INV_LN2);
    let hi = A::mad(-kf, LN2_HI, xc); // exact: kf * LN2_HI has at most 43 bits
    let lo = kf * LN2_LO;
    let r = hi - lo;
    // q = sum of r^j / (j + 2)! for j = 0..=10, in Estrin's scheme (a short dependency chain,
    // so that consecutive vectors overlap in the pipeline).
    const A0: f64 = 0.5;
    const A1: f64 = 1.666_666_666_666_666_6e-1;
    const A2: f64 = 4.166_666_666_666_666_4e-2;
    const A3: f64 = 8.333_333_333_333_333e-3;
    const A4: f64 = 1.388_888_888_888_889e-3;
    const A5: f64 = 1.984_126_984_126_984e-4;
    const A6: f64 = 2.480_158_730_158_73e-5;
    const A7: f64 = 2.755_731_922_398_589_3e-6;
    const A8: f64 = 2.755_731_922_398_589e-7;
    const A9: f64 = 2.505_210_838_544_172e-8;
    const A10: f64 = 2.087_675_698_786_81e-9;
    let r2 = r * r;
    let r4 = r2 * r2;
    let c0 = A::mad(r2, A::mad(r, A3, A2), A::mad(r, A1, A0));
    let c1 = A::mad(r2, A::mad(r, A7, A6), A::mad(r, A5, A4));
    let c2 = A::mad(r2, A10, A::mad(r, A9, A8));
    let q = A::mad(r4, A::mad(r4, c2, c1), c0);
    // e^r = 1 + r + r^2 q, with r = hi - lo kept in two parts for the leading terms.
    let y = 1.0 + (hi + A::mad(r2, q, -lo));
    // 2^k in two factors so that neither overflows nor underflows (k in [-1077, 1025]).
    // `u = k + 2^51` (the low mantissa bits of the rounding sum) is positive, so the halving
    // is a logical shift: k1 = floor(k/2), k2 = k - k1.
    let u = bits & 0x000F_FFFF_FFFF_FFFF;
    let half = u >> 1;
    // Modulo 2^64 on purpose: for a negative k1 the subtraction wraps, and the shift keeps
    // only the exponent bits, which are right either way.
    let s1 = f64::from_bits((half.wrapping_sub(1u64 << 50).wrapping_add(1023)) << 52);
    let s2 = f64::from_bits(((u - half).wrapping_sub(1u64 << 50).wrapping_add(1023)) << 52);
    y * s1 * s2
}

/// `k ln 2 + ln(1 + f)` for `f` in `[sqrt(1/2) - 1, sqrt(2) - 1]` (fdlibm's `log` kernel,
/// within 1 ulp).
#[inline(always)]
fn log_kernel<A: Arith>(f: f64, k: f64) -> f64 {
    const LG1: f64 = 6.666_666_666_666_735_130e-1;
    const LG2: f64 = 3.999_999_999_940_941_908e-1;
    const LG3: f64 = 2.857_142_874_366_239_149e-1;
    const LG4: f64 = 2.222_219_843_214_978_396e-1;
    const LG5: f64 = 1.818_357_216_161_805_012e-1;
    const LG6: f64 = 1.531_383_769_920_937_332e-1;
    const LG7: f64 = 1.479_819_860_511_658_591e-1;
    let hfsq = 0.5 * f * f;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * A::mad(w, A::mad(w, LG6, LG4), LG2);
    let t2 = z * A::mad(w, A::mad(w, A::mad(w, LG7, LG5), LG3), LG1);
    let r = t2 + t1;
    A::mad(s, hfsq + r, k * LN2_LO) - hfsq + f + k * LN2_HI
}

/// Natural logarithm of `x >= 0` (finite; subnormals included); `-inf` at 0.
#[inline(always)]
pub(crate) fn ln<A: Arith>(x: f64) -> f64 {
    let sub = x < f64::MIN_POSITIVE;
    let xs = if sub { x * TWO54 } else { x };
    let k_adjust = if sub { -54.0 } else { 0.0 };
    let bits = xs.to_bits();
    // Mantissa into [sqrt(1/2), sqrt(2)), exponent adjusted to match (fdlibm/musl).
    let hx = (bits >> 32) + (0x3ff0_0000 - 0x3fe6_a09e);
    let e = (hx >> 20) & 0x7ff;
    let k = f64::from_bits(0x4330_0000_0000_0000 | e) - TWO52 - 1023.0 + k_adjust;
    let hm = (hx & 0x000f_ffff) + 0x3fe6_a09e;
    let m = f64::from_bits((hm << 32) | (bits & 0xffff_ffff));
    let r = log_kernel::<A>(m - 1.0, k);
    if x == 0.0 {
        f64::NEG_INFINITY
    } else {
        r
    }
}

/// `ln(1 + m)` for `m` in `[0, 1]`, accurate for small `m` (no rounding of `1 + m`).
#[inline(always)]
pub(crate) fn ln_1p<A: Arith>(m: f64) -> f64 {
    const SQRT2_MINUS_1: f64 = 0.414_213_562_373_095_03;
    let big = m >= SQRT2_MINUS_1;
    // (1 + m) / 2 - 1 = (m - 1) / 2: one rounding of at most 2^-55.
    let f = if big { (m - 1.0) * 0.5 } else { m };
    let k = if big { 1.0 } else { 0.0 };
    log_kernel::<A>(f, k)
}

/// `x^y` for `x >= 0`, as the scalar f64 path computes it (`Float::powf`): `exp(y ln x)`,
/// `x^0 = 1`, `0^y = 0` for `y > 0`.
#[inline(always)]
pub(crate) fn pow<A: Arith>(x: f64, y: f64) -> f64 {
    let p = exp::<A>(y * ln::<A>(x));
    let p = if x == 0.0 && y > 0.0 { 0.0 } else { p };
    if y == 0.0 {
        1.0
    } else {
        p
    }
}

/// Largest `|x|` that [`sin_cos`] reduces accurately (its products with the quotient by pi/2
/// stay exact); beyond it the batch path evaluates the lane with the scalar path.
pub(crate) const SIN_COS_MAX: f64 = 1024.0;

/// `(sin x, cos x)` for `|x| <= SIN_COS_MAX`: Cody–Waite reduction by pi/2 in two rounds
/// (119 bits of pi/2, the rounding of the second carried exactly), then fdlibm's kernels on
/// `|r| <= pi/4` with the reduction's tail; within 1 ulp.
#[inline(always)]
pub(crate) fn sin_cos<A: Arith>(x: f64) -> (f64, f64) {
    const INV_PIO2: f64 = core::f64::consts::FRAC_2_PI;
    const PIO2_1: f64 = 1.570_796_326_734_125_614_17;
    const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11;
    const PIO2_2T: f64 = 2.022_266_248_795_950_631_54e-21;
    let (n, bits) = round_with_bits(x * INV_PIO2);
    let r1 = A::mad(-n, PIO2_1, x); // exact: n has at most 11 bits, PIO2_1 33
    let p2 = n * PIO2_2; // exact
    let r2 = r1 - p2;
    let e2 = (r1 - r2) - p2; // exact rounding error of r2
    let tail = A::mad(-n, PIO2_2T, e2);
    let y0 = r2 + tail;
    let y1 = (r2 - y0) + tail;
    let s = k_sin::<A>(y0, y1);
    let c = k_cos::<A>(y0, y1);
    let q = bits & 3;
    let swap = q & 1 == 1;
    let (s, c) = if swap { (c, s) } else { (s, c) };
    let s = if q >= 2 { -s } else { s };
    let c = if q == 1 || q == 2 { -c } else { c };
    (s, c)
}

/// `sin x` alone, as [`sin_cos`].
#[inline(always)]
pub(crate) fn sin<A: Arith>(x: f64) -> f64 {
    sin_cos::<A>(x).0
}

/// fdlibm `__kernel_sin(x, y, 1)` on `|x| <= pi/4` with tail `y`.
#[inline(always)]
fn k_sin<A: Arith>(x: f64, y: f64) -> f64 {
    const S1: f64 = -1.666_666_666_666_663_243_48e-1;
    const S2: f64 = 8.333_333_333_322_489_461_24e-3;
    const S3: f64 = -1.984_126_982_985_794_931_34e-4;
    const S4: f64 = 2.755_731_370_707_006_767_89e-6;
    const S5: f64 = -2.505_076_025_340_686_341_95e-8;
    const S6: f64 = 1.589_690_995_211_550_102_21e-10;
    let z = x * x;
    let w = z * z;
    let r = A::mad(z, A::mad(z, S4, S3), S2) + z * w * A::mad(z, S6, S5);
    let v = z * x;
    x - ((z * (0.5 * y - v * r) - y) - v * S1)
}

/// fdlibm `__kernel_cos(x, y)` on `|x| <= pi/4` with tail `y`.
#[inline(always)]
fn k_cos<A: Arith>(x: f64, y: f64) -> f64 {
    const C1: f64 = 4.166_666_666_666_660_190_37e-2;
    const C2: f64 = -1.388_888_888_887_410_957_49e-3;
    const C3: f64 = 2.480_158_728_947_672_941_78e-5;
    const C4: f64 = -2.755_731_435_139_066_330_35e-7;
    const C5: f64 = 2.087_572_321_298_174_827_90e-9;
    const C6: f64 = -1.135_964_755_778_819_482_65e-11;
    let z = x * x;
    let w = z * z;
    let r = z * A::mad(z, A::mad(z, C3, C2), C1) + w * w * A::mad(z, A::mad(z, C6, C5), C4);
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    w + (((1.0 - w) - hz) + (z * r - x * y))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        (a.to_bits() as i64).abs_diff(b.to_bits() as i64)
    }

    /// Deterministic spread of test arguments.
    fn args(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f64> {
        let mut s = 0x2545_f491_4f6c_dd1d_u64;
        (0..n).map(move |_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
        })
    }

    #[test]
    fn exp_and_logs_within_two_ulp_of_libm() {
        exp_and_logs::<Plain>();
        #[cfg(feature = "std")]
        exp_and_logs::<Fused>();
    }

    #[test]
    fn sin_cos_within_two_ulp_of_libm() {
        sin_cos_check::<Plain>();
        #[cfg(feature = "std")]
        sin_cos_check::<Fused>();
    }

    fn exp_and_logs<A: Arith>() {
        let mut worst = [0u64; 3];
        for x in args(-745.0, 709.0, 20_000).chain(args(-1.0, 1.0, 20_000)) {
            worst[0] = worst[0].max(ulps(exp::<A>(x), libm::exp(x)));
        }
        for x in args(-300.0, 300.0, 20_000) {
            let x = libm::exp(x);
            worst[1] = worst[1].max(ulps(ln::<A>(x), libm::log(x)));
        }
        for m in args(0.0, 1.0, 20_000).chain(args(0.0, 1e-6, 2_000)) {
            worst[2] = worst[2].max(ulps(ln_1p::<A>(m), libm::log1p(m)));
        }
        assert!(worst.iter().all(|&w| w <= 2), "{worst:?}");
        assert_eq!(exp::<A>(-800.0), 0.0);
        assert_eq!(exp::<A>(800.0), f64::INFINITY);
        assert!(exp::<A>(f64::NAN).is_nan());
        assert_eq!(exp::<A>(f64::NEG_INFINITY), 0.0);
        assert_eq!(exp::<A>(f64::INFINITY), f64::INFINITY);
        assert_eq!(ln::<A>(0.0), f64::NEG_INFINITY);
        assert!(ulps(ln::<A>(4.9e-324), libm::log(4.9e-324)) <= 1);
        assert!(ulps(ln::<A>(3e-310), libm::log(3e-310)) <= 1);
        assert_eq!(
            (pow::<A>(0.0, 1.2), pow::<A>(0.0, 0.0), pow::<A>(0.3, 0.0)),
            (0.0, 1.0, 1.0)
        );
    }

    fn sin_cos_check<A: Arith>() {
        let mut worst = 0u64;
        let near = [
            0.0,
            core::f64::consts::FRAC_PI_2,
            core::f64::consts::PI,
            3.0 * core::f64::consts::FRAC_PI_2,
        ];
        let points = args(-SIN_COS_MAX, SIN_COS_MAX, 20_000)
            .chain(args(0.0, core::f64::consts::PI, 20_000))
            .chain(near.iter().flat_map(|&c| args(c - 1e-9, c + 1e-9, 500)));
        for x in points {
            let (s, c) = sin_cos::<A>(x);
            worst = worst.max(ulps(s, libm::sin(x)).max(ulps(c, libm::cos(x))));
        }
        assert!(worst <= 2, "{worst}");
        assert_eq!(sin_cos::<A>(0.0), (0.0, 1.0));
    }
}
