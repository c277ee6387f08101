//! Batch evaluation: one material over many directions, structure of arrays in, one slice
//! out — the host's fast path (renderers, scene simulators, `brdf eval`, the albedo
//! quadrature). No heap, `no_std`.
//!
//! ```
//! use brdf_core::batch::Batch;
//! use brdf_core::{AnyModel, ModelKind};
//!
//! let khaki = AnyModel::<f64>::new(ModelKind::Six, &[0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2])?;
//! let deg = core::f64::consts::PI / 180.0;
//! let theta_i = [10.0 * deg, 30.0 * deg];
//! let theta_r = [10.0 * deg, 45.0 * deg];
//! let phi = [0.0, 180.0 * deg];
//! let mut f = [0.0; 2];
//! Batch::new(&khaki).angles(&theta_i, &theta_r, &phi, &mut f)?;
//! assert!((f[0] - 0.192_021_427_058_205).abs() < 1e-14);
//! # Ok::<(), Box<dyn core::error::Error>>(())
//! ```
//!
//! **What it computes.** Exactly the scalar path's formulas — the same cancellation-free
//! geometry (half-vector sums of squares, TwoSum for `cos((ti + tr)/2)`, TwoProduct for the
//! lobe exponent) and the same model expressions — with this module's own `exp`, `ln`,
//! `ln_1p` and `sin_cos` ([`lanes`]: fdlibm's polynomials, about 1 ulp, written without
//! data-dependent branches so that the compiler vectorises the loop over directions). f64
//! results agree with the scalar f64 path to about 1e-15 relative
//! ([`crate::tolerance::BATCH_F64_REL`] bounds it); reciprocity stays bit-exact (the lane code
//! is symmetric operation by operation, as the scalar code is).
//!
//! **f32.** The f32 entry points take and return f32 and compute each lane in f64: they are
//! as accurate as f64 rounded once (well within [`crate::tolerance::F32_MAX_REL`]) and cost
//! about what f64 does. The scalar f32 path stays the device's arithmetic, bit for bit.
//!
//! **Invalid input.** Every lane is checked exactly as the scalar `try_eval_*` methods check
//! it (finite, zeniths in `[0, pi]`, cosines in `[-1, 1]`, unit vectors to
//! [`crate::UNIT_NORM_TOLERANCE`]), chunk by chunk before the chunk is evaluated. At the first
//! invalid lane `i` the call returns [`BatchError::Domain`] with `i` and the scalar path's
//! [`crate::DomainError`]; `out[..i]` then hold their values and `out[i..]` hold NaN, so no
//! value is ever returned for an input the scalar path rejects. Slices of different lengths
//! give [`BatchError::Length`] and leave `out` untouched.
//!
//! **Instruction sets.** With the `std` feature on x86-64, the kernel is compiled three times
//! — portable (SSE2), AVX2+FMA and AVX-512 — and the best one the CPU supports is picked at
//! run time, once ([`Level::detected`]); no `-C target-cpu` is needed. Without `std` (the
//! firmware, or any `no_std` user) the portable copy runs. The AVX2 and AVX-512 copies fuse
//! the polynomials' multiply-adds, so their results differ from the portable copy's by about
//! an ulp (each level is tested against the scalar path); AVX2 and AVX-512 agree bit for bit.

pub mod lanes;
#[cfg(feature = "rayon")]
pub mod par;

use core::fmt;

use crate::error::DomainError;
use crate::float::{split, Float};
use crate::geometry::{check_cosine, check_unit, check_zenith};
use crate::model::{AnyModel, ModelKind};
use lanes::Arith;

/// Directions per chunk: validated together, then evaluated from stack arrays.
const CHUNK: usize = 256;

/// A slice-length mismatch or an input the scalar path would reject.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum BatchError {
    /// An input or the output slice has a different length from the first input.
    Length {
        /// Which slice (`"theta_r"`, `"out"`, ...).
        what: &'static str,
        /// Its length.
        len: usize,
        /// The first input's length.
        expected: usize,
    },
    /// Lane `index` is invalid; `out[index..]` are NaN.
    Domain {
        /// Position of the first invalid lane.
        index: usize,
        /// What the scalar checked path says about it.
        error: DomainError,
    },
}

impl fmt::Display for BatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BatchError::Length { what, len, expected } => {
                write!(f, "slice {what} has {len} elements, expected {expected}")
            }
            BatchError::Domain { index, error } => write!(f, "direction {index}: {error}"),
        }
    }
}

impl core::error::Error for BatchError {}

/// An instruction-set level the batch kernel is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Level {
    /// The target's baseline (SSE2 on x86-64; whatever the target has elsewhere).
    Portable,
    /// x86-64 with AVX2 and FMA (4 f64 lanes per instruction).
    Avx2,
    /// x86-64 with AVX-512 F, DQ, VL and BW (8 f64 lanes).
    Avx512,
}

impl Level {
    /// Every level, slowest first.
    pub const ALL: [Level; 3] = [Level::Portable, Level::Avx2, Level::Avx512];

    /// Short name (`portable`, `avx2`, `avx512`).
    pub const fn name(self) -> &'static str {
        match self {
            Level::Portable => "portable",
            Level::Avx2 => "avx2",
            Level::Avx512 => "avx512",
        }
    }

    /// Whether this CPU can run the level (always true for [`Level::Portable`]; false for
    /// the others without the `std` feature or off x86-64).
    pub fn is_available(self) -> bool {
        match self {
            Level::Portable => true,
            _ => dispatch::available(self),
        }
    }

    /// The best available level, detected once and cached.
    pub fn detected() -> Level {
        dispatch::detected()
    }
}

/// Per-material constants of one model, in f64, as the scalar f64 model computes them.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kernel {
    Six(Lobed),
    SixCos2(Lobed),
    Five(Lobed),
    Minnaert { scale: f64, exponent: f64 },
    Ggx(Microfacet),
    Lambert { value: f64 },
}

/// Constants of the microfacet model (as `Ggx` holds them).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Microfacet {
    ks: f64,
    alpha2: f64,
    f0: f64,
    diffuse: f64,
}

/// Constants of the lobe models. For the five-parameter model `spec_scale` is `kb` and
/// `diffuse_scale` is `kd`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Lobed {
    spec_scale: f64,
    kr2: f64,
    abs_b: f64,
    abs_b_hi: f64,
    abs_b_lo: f64,
    a: f64,
    diffuse_scale: f64,
    c: f64,
}

impl Kernel {
    fn new(kind: ModelKind, p: &[f64]) -> Self {
        let lobed = |spec_scale: f64, diffuse_scale: f64, c: f64| {
            let abs_b = p[2].abs();
            let (abs_b_hi, abs_b_lo) = split(abs_b);
            Lobed {
                spec_scale,
                kr2: p[1] * p[1],
                abs_b,
                abs_b_hi,
                abs_b_lo,
                a: p[3],
                diffuse_scale,
                c,
            }
        };
        match kind {
            ModelKind::Six | ModelKind::SixCos2 => {
                let l = lobed(
                    p[0] / (core::f64::consts::PI * core::f64::consts::LN_2),
                    p[4] * core::f64::consts::FRAC_1_PI,
                    p[5],
                );
                if kind == ModelKind::Six {
                    Kernel::Six(l)
                } else {
                    Kernel::SixCos2(l)
                }
            }
            ModelKind::Five => Kernel::Five(lobed(p[0], p[4], 0.0)),
            ModelKind::Minnaert => Kernel::Minnaert {
                scale: p[0] * core::f64::consts::FRAC_1_PI,
                exponent: p[1] - 1.0,
            },
            ModelKind::Ggx => Kernel::Ggx(Microfacet {
                ks: p[0],
                alpha2: p[1] * p[1],
                f0: p[2],
                diffuse: p[3] * core::f64::consts::FRAC_1_PI,
            }),
            ModelKind::Lambert => Kernel::Lambert {
                value: p[0] * core::f64::consts::FRAC_1_PI,
            },
        }
    }
}

/// One material prepared for batch evaluation at one instruction-set level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Batch<T> {
    kernel: Kernel,
    level: Level,
    _precision: core::marker::PhantomData<T>,
}

impl<T: Float> Batch<T> {
    /// Prepares `model` (its parameters widened to f64) at [`Level::detected`].
    pub fn new(model: &AnyModel<T>) -> Self {
        let kind = model.kind();
        let p = model.to_params().map(T::to_f64);
        Batch {
            kernel: Kernel::new(kind, &p[..kind.param_count()]),
            level: Level::detected(),
            _precision: core::marker::PhantomData,
        }
    }

    /// The same at `level`, or `None` if this CPU cannot run it (for tests and benchmarks).
    pub fn at_level(self, level: Level) -> Option<Self> {
        level.is_available().then_some(Batch { level, ..self })
    }

    /// The instruction-set level in use.
    pub fn level(&self) -> Level {
        self.level
    }

    /// `f_r` at zenith angles `theta_i`, `theta_r` and relative azimuth `phi` (radians,
    /// canonical convention), lane by lane, into `out`. Checked like
    /// [`crate::Brdf::try_eval_angles`]; see the module documentation for errors.
    pub fn angles(&self, theta_i: &[T], theta_r: &[T], phi: &[T], out: &mut [T]) -> Result<(), BatchError> {
        lengths(
            &[("theta_r", theta_r.len()), ("phi", phi.len())],
            theta_i.len(),
            out.len(),
        )?;
        self.run(
            out,
            |range| {
                first_invalid(
                    range,
                    |i| {
                        check_zenith(theta_i[i], "theta_i")?;
                        check_zenith(theta_r[i], "theta_r")?;
                        check_azimuth(phi[i])
                    },
                    |i| {
                        let ok = |t: T| t >= T::ZERO && t <= T::PI;
                        ok(theta_i[i]) && ok(theta_r[i]) && phi[i].is_finite()
                    },
                )
            },
            |start, n, dst| {
                let mut x = [[0.0; CHUNK]; 3];
                widen(&theta_i[start..start + n], &mut x[0]);
                widen(&theta_r[start..start + n], &mut x[1]);
                widen(&phi[start..start + n], &mut x[2]);
                dispatch::chunk(
                    self.level,
                    &self.kernel,
                    Input::Angles(&x[0], &x[1], &x[2]),
                    n,
                    dst,
                );
                // Azimuths beyond the vector reduction's range: libm's sin/cos for that lane.
                for i in 0..n {
                    if x[2][i].abs() > 2.0 * lanes::SIN_COS_MAX {
                        dst[i] = eval_lane_far_phi(&self.kernel, x[0][i], x[1][i], x[2][i]);
                    }
                }
            },
        )
    }

    /// `f_r` at one incidence zenith `theta_i` and one viewing zenith `theta_r` for every
    /// azimuth of `phi` (radians): a ring of the hemisphere, as quadratures over `phi` need
    /// it. The terms that depend on the zeniths alone (their `sin`/`cos`, and the powers and
    /// logarithm of `m = cos theta_i cos theta_r`) are computed once, so a lane costs about
    /// half of what [`Batch::angles`] costs; each value is bit for bit what
    /// [`Batch::angles`] returns for the same three angles.
    ///
    /// Checked like [`crate::Brdf::try_eval_angles`]: an invalid zenith makes every lane
    /// invalid (the error is reported at index 0 and `out` is all NaN); an invalid azimuth
    /// as in [`Batch::angles`].
    pub fn ring(&self, theta_i: T, theta_r: T, phi: &[T], out: &mut [T]) -> Result<(), BatchError> {
        lengths(&[], phi.len(), out.len())?;
        let zeniths = check_zenith(theta_i, "theta_i").and_then(|()| check_zenith(theta_r, "theta_r"));
        if let Err(error) = zeniths {
            if out.is_empty() {
                return Ok(());
            }
            out.fill(T::from_f64(f64::NAN));
            return Err(BatchError::Domain { index: 0, error });
        }
        let (ti, tr) = (theta_i.to_f64(), theta_r.to_f64());
        self.run(
            out,
            |range| first_invalid(range, |i| check_azimuth(phi[i]), |i| phi[i].is_finite()),
            |start, n, dst| {
                let mut x = [0.0; CHUNK];
                widen(&phi[start..start + n], &mut x);
                dispatch::chunk(self.level, &self.kernel, Input::Ring(ti, tr, &x), n, dst);
                for i in 0..n {
                    if x[i].abs() > 2.0 * lanes::SIN_COS_MAX {
                        dst[i] = eval_lane_far_phi(&self.kernel, ti, tr, x[i]);
                    }
                }
            },
        )
    }

    /// `f_r` from `cos theta_i`, `cos theta_r`, `cos phi`, lane by lane. Checked like
    /// [`crate::Brdf::try_eval_cosines`].
    pub fn cosines(
        &self,
        cos_theta_i: &[T],
        cos_theta_r: &[T],
        cos_phi: &[T],
        out: &mut [T],
    ) -> Result<(), BatchError> {
        lengths(
            &[("cos_theta_r", cos_theta_r.len()), ("cos_phi", cos_phi.len())],
            cos_theta_i.len(),
            out.len(),
        )?;
        self.run(
            out,
            |range| {
                first_invalid(
                    range,
                    |i| {
                        check_cosine(cos_theta_i[i], "cos_theta_i")?;
                        check_cosine(cos_theta_r[i], "cos_theta_r")?;
                        check_cosine(cos_phi[i], "cos_phi")
                    },
                    |i| {
                        let ok = |c: T| c >= -T::ONE && c <= T::ONE;
                        ok(cos_theta_i[i]) && ok(cos_theta_r[i]) && ok(cos_phi[i])
                    },
                )
            },
            |start, n, dst| {
                let mut x = [[0.0; CHUNK]; 3];
                widen(&cos_theta_i[start..start + n], &mut x[0]);
                widen(&cos_theta_r[start..start + n], &mut x[1]);
                widen(&cos_phi[start..start + n], &mut x[2]);
                dispatch::chunk(
                    self.level,
                    &self.kernel,
                    Input::Cosines(&x[0], &x[1], &x[2]),
                    n,
                    dst,
                );
            },
        )
    }

    /// `f_r` from unit vectors `wi` (to the source) and `wr` (to the receiver), given by
    /// component (`wi[0]` the x components, ...), `z` along the normal. Checked like
    /// [`crate::Brdf::try_eval_vectors`].
    pub fn vectors(&self, wi: [&[T]; 3], wr: [&[T]; 3], out: &mut [T]) -> Result<(), BatchError> {
        lengths(
            &[
                ("wi[1]", wi[1].len()),
                ("wi[2]", wi[2].len()),
                ("wr[0]", wr[0].len()),
                ("wr[1]", wr[1].len()),
                ("wr[2]", wr[2].len()),
            ],
            wi[0].len(),
            out.len(),
        )?;
        let at = |w: [&[T]; 3], i: usize| [w[0][i], w[1][i], w[2][i]];
        self.run(
            out,
            |range| {
                first_invalid(
                    range,
                    |i| {
                        check_unit(at(wi, i), "wi")?;
                        check_unit(at(wr, i), "wr")
                    },
                    |i| {
                        let ok = |w: [T; 3]| {
                            let n2 = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).to_f64();
                            (n2 - 1.0).abs() <= crate::UNIT_NORM_TOLERANCE
                        };
                        ok(at(wi, i)) && ok(at(wr, i))
                    },
                )
            },
            |start, n, dst| {
                let mut x = [[0.0; CHUNK]; 6];
                for (k, s) in wi.iter().chain(wr.iter()).enumerate() {
                    widen(&s[start..start + n], &mut x[k]);
                }
                let [a, b, c, d, e, f] = &x;
                dispatch::chunk(
                    self.level,
                    &self.kernel,
                    Input::Vectors([a, b, c], [d, e, f]),
                    n,
                    dst,
                );
            },
        )
    }

    /// Chunk loop shared by the three inputs: `check(range)` finds the first invalid lane of
    /// a chunk, `eval(start, n, dst)` evaluates `n` valid lanes from `start` into `dst`.
    fn run(
        &self,
        out: &mut [T],
        check: impl Fn(core::ops::Range<usize>) -> Option<(usize, DomainError)>,
        eval: impl Fn(usize, usize, &mut [f64; CHUNK]),
    ) -> Result<(), BatchError> {
        let mut start = 0;
        let mut dst = [0.0; CHUNK];
        while start < out.len() {
            let end = (start + CHUNK).min(out.len());
            let bad = check(start..end);
            let valid_end = bad.map_or(end, |(i, _)| i);
            if valid_end > start {
                eval(start, valid_end - start, &mut dst);
                for (o, &v) in out[start..valid_end].iter_mut().zip(&dst) {
                    *o = T::from_f64(v);
                }
            }
            if let Some((index, error)) = bad {
                for o in &mut out[index..] {
                    *o = T::from_f64(f64::NAN);
                }
                return Err(BatchError::Domain { index, error });
            }
            start = end;
        }
        Ok(())
    }
}

/// `e^x` of every element of `x`, in place, with this module's kernel (within 2 ulp of
/// libm's `exp`; 0 below -745.2, infinity above 709.8; NaN stays NaN) at `level` — the
/// building block of host code that vectorises its own loops (the fitting kernels).
/// A `level` this CPU cannot run falls back to [`Level::Portable`].
pub fn exp_in_place(x: &mut [f64], level: Level) {
    let level = if level.is_available() {
        level
    } else {
        Level::Portable
    };
    dispatch::exp_slice(level, x)
}

/// An azimuth is any finite angle (the scalar `try_eval_angles` rule).
fn check_azimuth<T: Float>(phi: T) -> Result<(), DomainError> {
    if phi.is_finite() {
        Ok(())
    } else {
        Err(DomainError::NotFinite { what: "phi" })
    }
}

/// Checks that every slice has `expected` elements and `out` too.
fn lengths(inputs: &[(&'static str, usize)], expected: usize, out: usize) -> Result<(), BatchError> {
    for &(what, len) in inputs.iter().chain(&[("out", out)]) {
        if len != expected {
            return Err(BatchError::Length { what, len, expected });
        }
    }
    Ok(())
}

/// First invalid lane of `range`: a branch-free pass (`valid`) over the chunk, and only if it
/// finds something the scalar checks (`check`) for the exact error.
fn first_invalid(
    range: core::ops::Range<usize>,
    check: impl Fn(usize) -> Result<(), DomainError>,
    valid: impl Fn(usize) -> bool,
) -> Option<(usize, DomainError)> {
    let all_valid = range.clone().fold(true, |acc, i| acc & valid(i));
    if all_valid {
        return None;
    }
    range.into_iter().find_map(|i| check(i).err().map(|e| (i, e)))
}

fn widen<T: Float>(src: &[T], dst: &mut [f64; CHUNK]) {
    for (d, &s) in dst.iter_mut().zip(src) {
        *d = s.to_f64();
    }
}

/// One chunk's inputs, widened to f64.
#[derive(Clone, Copy)]
enum Input<'a> {
    Angles(&'a [f64; CHUNK], &'a [f64; CHUNK], &'a [f64; CHUNK]),
    /// One `theta_i`, one `theta_r`, many `phi`.
    Ring(f64, f64, &'a [f64; CHUNK]),
    Cosines(&'a [f64; CHUNK], &'a [f64; CHUNK], &'a [f64; CHUNK]),
    Vectors([&'a [f64; CHUNK]; 3], [&'a [f64; CHUNK]; 3]),
}

/// Geometry of one lane (see [`crate::Geometry`]) and whether both directions are above the
/// horizon.
#[derive(Clone, Copy)]
struct Lane {
    mi: f64,
    mr: f64,
    cos_gamma: f64,
    one_minus_cos_gamma: f64,
    cos_alpha: f64,
    one_minus_cos_alpha: f64,
    inside: bool,
}

#[inline(always)]
fn sqrt(x: f64) -> f64 {
    #[cfg(feature = "std")]
    {
        x.sqrt()
    }
    #[cfg(not(feature = "std"))]
    {
        libm::sqrt(x)
    }
}

/// `Geometry::from_parts` without branches: a lane with `cos^2(gamma) = 0` is outside.
#[inline(always)]
fn from_parts<A: Arith>(mi: f64, mr: f64, sin2_gamma: f64, cos2_gamma: f64, p: f64) -> Lane {
    let defined = cos2_gamma > 0.0;
    let c2 = if defined { cos2_gamma } else { 1.0 };
    let cos_gamma = sqrt(c2);
    let cos_alpha = (mi + mr) / (2.0 * cos_gamma);
    Lane {
        mi,
        mr,
        cos_gamma,
        one_minus_cos_gamma: sin2_gamma / (1.0 + cos_gamma),
        cos_alpha,
        one_minus_cos_alpha: p / ((2.0 + 2.0) * c2 * (1.0 + cos_alpha)),
        inside: defined & (mi > 0.0) & (mr > 0.0),
    }
}

/// The terms of `Geometry::from_angles` that depend on the two zeniths only.
#[derive(Clone, Copy)]
struct Zeniths {
    cos_i: f64,
    cos_r: f64,
    sin_hd: f64,
    cos_hs: f64,
    ss: f64,
}

#[inline(always)]
fn zeniths<A: Arith>(ti: f64, tr: f64) -> Zeniths {
    use lanes::{sin, sin_cos};
    let (sin_i, cos_i) = sin_cos::<A>(ti);
    let (sin_r, cos_r) = sin_cos::<A>(tr);
    let half_pi = core::f64::consts::FRAC_PI_2;
    let cos_i = if ti >= half_pi { 0.0 } else { cos_i };
    let cos_r = if tr >= half_pi { 0.0 } else { cos_r };
    let sin_hd = sin::<A>((ti - tr) * 0.5);
    let sum = ti + tr;
    let v = sum - ti;
    let e = (ti - (sum - v)) + (tr - v);
    let (sin_hs, cos_hs) = sin_cos::<A>(sum * 0.5);
    let cos_hs = cos_hs - sin_hs * e * 0.5;
    Zeniths {
        cos_i,
        cos_r,
        sin_hd,
        cos_hs,
        ss: sin_i * sin_r,
    }
}

/// `Geometry::from_angles`, given the zenith terms and `sin` and `cos` of `phi/2`.
#[inline(always)]
fn lane_angles<A: Arith>(z: &Zeniths, sin_hp: f64, cos_hp: f64) -> Lane {
    let ss = z.ss;
    let sin2_gamma = z.sin_hd * z.sin_hd + ss * (sin_hp * sin_hp);
    let cos2_gamma = z.cos_hs * z.cos_hs + ss * (cos_hp * cos_hp);
    let diff = z.cos_hs * z.sin_hd;
    let p = (2.0 + 2.0) * (diff * diff + ss * (cos_hp * cos_hp));
    from_parts::<A>(z.cos_i, z.cos_r, sin2_gamma, cos2_gamma, p)
}

/// `Geometry::from_cosines`.
#[inline(always)]
fn lane_cosines<A: Arith>(mi: f64, mr: f64, cos_phi: f64) -> Lane {
    let (sin2_gamma, cos2_gamma, p) = crate::geometry::cosine_sums(mi, mr, cos_phi, sqrt);
    from_parts::<A>(mi, mr, sin2_gamma, cos2_gamma, p)
}

/// `Geometry::from_vectors`.
#[inline(always)]
fn lane_vectors<A: Arith>(wi: [f64; 3], wr: [f64; 3]) -> Lane {
    let s = [wi[0] + wr[0], wi[1] + wr[1], wi[2] + wr[2]];
    let d = [wi[0] - wr[0], wi[1] - wr[1], wi[2] - wr[2]];
    let p = s[0] * s[0] + s[1] * s[1];
    let quarter = 0.5 * 0.5;
    let sin2_gamma = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * quarter;
    let cos2_gamma = (p + s[2] * s[2]) * quarter;
    from_parts::<A>(wi[2], wr[2], sin2_gamma, cos2_gamma, p)
}

/// The lobe `exp(-|b| (1 - cos gamma)^a)` with the exponent as an exact sum (as `Lobe::eval`).
#[inline(always)]
fn lobe<A: Arith>(k: &Lobed, g: &Lane) -> f64 {
    let p = lanes::pow::<A>(g.one_minus_cos_gamma, k.a);
    let e_hi = k.abs_b * p;
    let e_lo = A::product_error(k.abs_b, k.abs_b_hi, k.abs_b_lo, p, e_hi);
    lanes::exp::<A>(-e_hi) * (1.0 - e_lo)
}

/// The factors of a model that depend on `m = cos theta_i cos theta_r` only.
#[derive(Clone, Copy)]
struct MTerms {
    /// `ln(1 + m)` (the lobe models' specular factor).
    ln_1p: f64,
    /// `m^c` (six-parameter models), `m^(k - 1)` (Minnaert).
    power: f64,
}

#[inline(always)]
fn m_terms<A: Arith>(kernel: &Kernel, mi: f64, mr: f64) -> MTerms {
    let m = mi * mr;
    match kernel {
        Kernel::Six(k) | Kernel::SixCos2(k) => MTerms {
            ln_1p: lanes::ln_1p::<A>(m),
            power: lanes::pow::<A>(m, k.c),
        },
        Kernel::Minnaert { exponent, .. } => MTerms {
            ln_1p: 0.0,
            power: lanes::pow::<A>(m, *exponent),
        },
        Kernel::Five(_) | Kernel::Ggx(_) | Kernel::Lambert { .. } => MTerms {
            ln_1p: 0.0,
            power: 0.0,
        },
    }
}

/// The model at one lane above the horizon (the scalar models' `eval` bodies), given the
/// lane's [`m_terms`].
#[inline(always)]
fn model_lane<A: Arith>(kernel: &Kernel, g: &Lane, mt: &MTerms) -> f64 {
    match kernel {
        Kernel::Six(k) => {
            let x = k.kr2 * g.cos_alpha;
            let facet = x / (x + g.one_minus_cos_alpha);
            let spec = k.spec_scale * facet * lobe::<A>(k, g) * mt.ln_1p;
            spec + k.diffuse_scale * mt.power
        }
        Kernel::SixCos2(k) => {
            let ca = g.cos_alpha;
            let facet = k.kr2 * ca / (k.kr2 * ca * ca + g.one_minus_cos_alpha * (1.0 + ca));
            let spec = k.spec_scale * facet * lobe::<A>(k, g) * mt.ln_1p;
            spec + k.diffuse_scale * mt.power
        }
        Kernel::Five(k) => {
            let x = k.kr2 * g.cos_alpha;
            let facet = x / (x + g.one_minus_cos_alpha);
            let s = 2.0 * g.cos_alpha / g.cos_gamma;
            let (a, b) = (s * g.mr, s * g.mi);
            let shadow = if a < 1.0 { a } else { 1.0 };
            let shadow = if b < shadow { b } else { shadow };
            let spec = facet * lobe::<A>(k, g) * shadow / (g.mi * g.mr);
            k.spec_scale * (spec + k.diffuse_scale / g.mi)
        }
        Kernel::Minnaert { scale, .. } => scale * mt.power,
        Kernel::Ggx(k) => {
            // Ggx::specular_shape, operation for operation.
            let ch = g.cos_alpha;
            let den = k.alpha2 * ch * ch + g.one_minus_cos_alpha * (1.0 + ch);
            let s_i = sqrt(g.mi * g.mi + k.alpha2 * (1.0 - g.mi) * (1.0 + g.mi));
            let s_r = sqrt(g.mr * g.mr + k.alpha2 * (1.0 - g.mr) * (1.0 + g.mr));
            let v = 1.0 / (2.0 * (g.mr * s_i + g.mi * s_r));
            let w = g.one_minus_cos_gamma;
            let w2 = w * w;
            let f = k.f0 + (1.0 - k.f0) * (w2 * w2 * w);
            let shape = k.alpha2 * core::f64::consts::FRAC_1_PI / (den * den) * v * f;
            let shape = if f == 0.0 { 0.0 } else { shape };
            if k.ks == 0.0 {
                k.diffuse
            } else {
                k.ks * shape + k.diffuse
            }
        }
        Kernel::Lambert { value } => *value,
    }
}

/// [`model_lane`] with the lane's own [`m_terms`], zero below the horizon.
#[inline(always)]
fn value<A: Arith>(kernel: &Kernel, g: &Lane) -> f64 {
    let f = model_lane::<A>(kernel, g, &m_terms::<A>(kernel, g.mi, g.mr));
    if g.inside {
        f
    } else {
        0.0
    }
}

/// One lane whose azimuth is beyond [`lanes::SIN_COS_MAX`]: `libm` reduces `phi/2`.
fn eval_lane_far_phi(kernel: &Kernel, ti: f64, tr: f64, phi: f64) -> f64 {
    let (s, c) = libm::sincos(phi * 0.5);
    value::<lanes::Plain>(
        kernel,
        &lane_angles::<lanes::Plain>(&zeniths::<lanes::Plain>(ti, tr), s, c),
    )
}

/// The chunk loop every level compiles: model matched once, then a branch-free loop.
#[inline(always)]
fn chunk_body<A: Arith>(kernel: &Kernel, input: Input<'_>, n: usize, out: &mut [f64; CHUNK]) {
    #[inline(always)]
    fn each<A: Arith>(kernel: &Kernel, input: Input<'_>, n: usize, out: &mut [f64; CHUNK]) {
        let n = n.min(CHUNK);
        match input {
            Input::Angles(ti, tr, phi) => {
                for i in 0..n {
                    let (s, c) = lanes::sin_cos::<A>(phi[i] * 0.5);
                    out[i] = value::<A>(kernel, &lane_angles::<A>(&zeniths::<A>(ti[i], tr[i]), s, c));
                }
            }
            Input::Ring(ti, tr, phi) => {
                // The zenith terms and the m terms once; per lane only what phi changes.
                let z = zeniths::<A>(ti, tr);
                let mt = m_terms::<A>(kernel, z.cos_i, z.cos_r);
                for i in 0..n {
                    let (s, c) = lanes::sin_cos::<A>(phi[i] * 0.5);
                    let g = lane_angles::<A>(&z, s, c);
                    let f = model_lane::<A>(kernel, &g, &mt);
                    out[i] = if g.inside { f } else { 0.0 };
                }
            }
            Input::Cosines(ci, cr, cp) => {
                for i in 0..n {
                    out[i] = value::<A>(kernel, &lane_cosines::<A>(ci[i], cr[i], cp[i]));
                }
            }
            Input::Vectors(wi, wr) => {
                for i in 0..n {
                    let g = lane_vectors::<A>([wi[0][i], wi[1][i], wi[2][i]], [wr[0][i], wr[1][i], wr[2][i]]);
                    out[i] = value::<A>(kernel, &g);
                }
            }
        }
    }
    // One copy of the loop per model, so that the loop body holds no match.
    match *kernel {
        k @ Kernel::Six(_) => each::<A>(&k, input, n, out),
        k @ Kernel::SixCos2(_) => each::<A>(&k, input, n, out),
        k @ Kernel::Five(_) => each::<A>(&k, input, n, out),
        k @ Kernel::Minnaert { .. } => each::<A>(&k, input, n, out),
        k @ Kernel::Ggx(_) => each::<A>(&k, input, n, out),
        k @ Kernel::Lambert { .. } => each::<A>(&k, input, n, out),
    }
}

/// `exp` over a slice, branch-free so that the loop vectorises.
#[inline(always)]
fn exp_body<A: Arith>(x: &mut [f64]) {
    // NaN stays NaN: the kernel's clamps keep a NaN argument, and the arithmetic carries it.
    for v in x.iter_mut() {
        *v = lanes::exp::<A>(*v);
    }
}

/// Run-time choice of the compiled copy (x86-64 with `std`), or the portable copy alone.
mod dispatch {
    use super::{chunk_body, exp_body, Input, Kernel, Level, CHUNK};

    pub(super) fn exp_slice(level: Level, x: &mut [f64]) {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            // SAFETY: as in `chunk`: callers pass only levels `available` confirmed.
            #[allow(unsafe_code)]
            unsafe {
                match level {
                    Level::Avx512 => return x86::exp_avx512(x),
                    Level::Avx2 => return x86::exp_avx2(x),
                    Level::Portable => {}
                }
            }
        }
        let _ = level;
        exp_body::<super::lanes::Plain>(x)
    }

    pub(super) fn chunk(level: Level, kernel: &Kernel, input: Input<'_>, n: usize, out: &mut [f64; CHUNK]) {
        #[cfg(all(feature = "std", target_arch = "x86_64"))]
        {
            // SAFETY: a `Batch` holds a level other than `Portable` only after
            // `available(level)` confirmed that this CPU has its instruction set
            // (`Batch::new` takes `detected()`, `Batch::at_level` checks).
            #[allow(unsafe_code)]
            unsafe {
                match level {
                    Level::Avx512 => return x86::avx512(kernel, input, n, out),
                    Level::Avx2 => return x86::avx2(kernel, input, n, out),
                    Level::Portable => {}
                }
            }
        }
        let _ = level;
        chunk_body::<super::lanes::Plain>(kernel, input, n, out)
    }

    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    mod x86 {
        use super::super::lanes::Fused;
        use super::super::{chunk_body, exp_body, Input, Kernel, CHUNK};

        #[target_feature(enable = "avx2,fma")]
        pub(in super::super) fn exp_avx2(x: &mut [f64]) {
            exp_body::<Fused>(x)
        }

        #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")]
        pub(in super::super) fn exp_avx512(x: &mut [f64]) {
            exp_body::<Fused>(x)
        }

        #[target_feature(enable = "avx2,fma")]
        pub(in super::super) fn avx2(kernel: &Kernel, input: Input<'_>, n: usize, out: &mut [f64; CHUNK]) {
            chunk_body::<Fused>(kernel, input, n, out)
        }

        #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")]
        pub(in super::super) fn avx512(kernel: &Kernel, input: Input<'_>, n: usize, out: &mut [f64; CHUNK]) {
            chunk_body::<Fused>(kernel, input, n, out)
        }
    }

    #[cfg(all(feature = "std", target_arch = "x86_64"))]
    pub(super) fn available(level: Level) -> bool {
        match level {
            Level::Portable => true,
            Level::Avx2 => std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma"),
            Level::Avx512 => {
                available(Level::Avx2)
                    && std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx512dq")
                    && std::is_x86_feature_detected!("avx512vl")
                    && std::is_x86_feature_detected!("avx512bw")
            }
        }
    }

    #[cfg(not(all(feature = "std", target_arch = "x86_64")))]
    pub(super) fn available(level: Level) -> bool {
        level == Level::Portable
    }

    /// 0: not yet detected; otherwise 1 + index in `Level::ALL`.
    static DETECTED: core::sync::atomic::AtomicU8 = core::sync::atomic::AtomicU8::new(0);

    pub(super) fn detected() -> Level {
        use core::sync::atomic::Ordering::Relaxed;
        match DETECTED.load(Relaxed) {
            0 => {
                let best = Level::ALL
                    .iter()
                    .rev()
                    .copied()
                    .find(|&l| available(l))
                    .unwrap_or(Level::Portable);
                let code = Level::ALL.iter().position(|&l| l == best).unwrap_or(0) as u8 + 1;
                DETECTED.store(code, Relaxed);
                best
            }
            code => Level::ALL[usize::from(code - 1).min(Level::ALL.len() - 1)],
        }
    }
}
