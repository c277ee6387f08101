//! Fitted tables: a measured material as an analytic base model times a tabulated correction,
//! `f = f_base * exp(t)`, with `t` interpolated trilinearly on a grid in Rusinkiewicz's
//! half-vector coordinates. The representation for measured paints and metals that no
//! analytic model of the family fits: `brdf_fit::fitted_table` fits `t` to measurements by
//! regularised least squares; this module is how a device (and the host, bit for bit)
//! evaluates it, with no trigonometric call.
//!
//! # Axes
//!
//! Each axis is a function of the half-angle sines of one Rusinkiewicz angle, computed from
//! [`Geometry`]'s cancellation-free `1 - cos` terms (`alpha` = `theta_h`, the tilt of the
//! half vector; `gamma` = `theta_d`, the angle between either direction and it):
//!
//! | axis | value in `[0, 1]` | near |
//! |---|---|---|
//! | `theta_h` | `(1 - cos theta_h)^(1/4)`, smooth below 0.03° ([`THETA_H_KNEE`]) | `sqrt(theta_h / sqrt 2)`: nodes dense at the mirror direction, where lobes change fastest |
//! | `theta_d` | `sqrt(1 - cos theta_d)` | `theta_d / sqrt 2` |
//! | `phi_d` | `sin^2 phi_d = 1 - cos^2 phi_d`, `|cos phi_d| = |cos theta_i - cos theta_r| / (2 sin theta_h sin theta_d)` | nodes at 0, 30, 45, 60, 90 degrees for five |
//!
//! An isotropic, reciprocal BRDF is even in `phi_d` about both 0 and `pi/2` (`phi_d`, `-phi_d`
//! and `pi - phi_d` are the same pair of directions), and so is `sin^2 phi_d`: interpolation
//! along it keeps that symmetry without a kink, the fold costs nothing, and the axis is well
//! conditioned everywhere (a square-root axis would amplify one rounding of `|cos phi_d|`
//! near 1 a thousandfold). Every axis is symmetric in the two directions in floating point
//! too, so a fitted table is exactly reciprocal.
//! Where `phi_d` is undefined (`theta_h = 0` or `theta_d = 0`, where an isotropic BRDF does
//! not depend on it) it is taken as 0.
//!
//! # Bytes
//!
//! Little-endian, [`FittedShape::encoded_len`] bytes:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 3 | nodes along `theta_h`, `theta_d`, `phi_d` (u8 each, [`MIN_FITTED_NODES`] to [`MAX_FITTED_NODES`]) |
//! | 3 | 1 | reserved (0) |
//! | 4 | 4 | `lo`: f32, finite |
//! | 8 | 4 | `step`: f32, finite, > 0; `lo + 65535 step` finite; both within [`FITTED_LN_LIMIT`] |
//! | 12 | 4 | reserved (0) |
//! | 16 | 2 c | per cell `(i, j, k)` at `(i * n_d + j) * n_p + k`: `q` (u16), `t = lo + q step` |
//! | 16 + 2 c | ceil(c / 8) | coverage: bit `c % 8` of byte `c / 8` set when data constrain cell `c`; unused bits 0 |

use crate::float::Float;
use crate::geometry::Geometry;
use crate::model::Brdf;

/// Bytes before the cells.
pub const FITTED_HEADER_LEN: usize = 16;
/// Fewest nodes along an axis.
pub const MIN_FITTED_NODES: usize = 2;
/// Most nodes along an axis.
pub const MAX_FITTED_NODES: usize = 64;
/// Largest `|t|` a table may hold: `exp(80)` is 5.5e34, within f32 (3.4e38) with room for the
/// base model's factor, so a correction never overflows on its own.
pub const FITTED_LN_LIMIT: f32 = 80.0;
/// A query is covered when the cells the data constrain carry at least this share of its
/// trilinear weight: the nearer half of its stencil was measured.
pub const COVERED_SHARE: f64 = 0.5;

/// Largest difference of an axis value ([`axes`]) computed in f32 from what f64 computes
/// from the same f32 input: a few ulp of 1 on each axis (measured up to 1e-7 on
/// `theta_d`; `test axes_are_the_rusinkiewicz_half_angle_sines_and_reciprocal` holds them
/// to this), ten times that for room.
pub const F32_AXIS_ERROR: [f64; 3] = [1e-6, 1e-6, 1e-6];

/// The `theta_h` axis is `(1 - cos theta_h)^(1/4)` (nodes dense at the mirror direction)
/// except within `1 - cos theta_h` of about `THETA_H_KNEE^4` = 1e-7 (`theta_h` below 0.03°),
/// where it turns smooth: the fourth root's infinite slope at 0 would make the mirror
/// direction's value hang on the last bit of the input (one f32 rounding of `phi = pi` moved
/// a metal's peak by 0.7%), and a BRDF is even in `theta_h` there.
pub const THETA_H_KNEE: f32 = 0.017_782_794;

/// Grid nodes per axis of a fitted table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FittedShape {
    /// Nodes along `theta_h`.
    pub theta_h: usize,
    /// Nodes along `theta_d`.
    pub theta_d: usize,
    /// Nodes along the folded `phi_d`.
    pub phi_d: usize,
}

impl FittedShape {
    /// Cells (grid nodes).
    pub const fn cells(&self) -> usize {
        self.theta_h * self.theta_d * self.phi_d
    }

    /// Bytes of a table of this shape (header, cells, coverage bits).
    pub const fn encoded_len(&self) -> usize {
        let c = self.cells();
        FITTED_HEADER_LEN + 2 * c + c.div_ceil(8)
    }

    /// Every axis within [`MIN_FITTED_NODES`]..=[`MAX_FITTED_NODES`].
    pub const fn is_valid(&self) -> bool {
        const fn ok(n: usize) -> bool {
            n >= MIN_FITTED_NODES && n <= MAX_FITTED_NODES
        }
        ok(self.theta_h) && ok(self.theta_d) && ok(self.phi_d)
    }
}

/// Why bytes are not a fitted table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FittedError {
    /// Shorter than the header, or the length differs from the shape's (bytes given).
    Length(usize),
    /// An axis outside [`MIN_FITTED_NODES`]..=[`MAX_FITTED_NODES`].
    Shape,
    /// A reserved field is not 0, or an unused coverage bit is set.
    Reserved,
    /// `lo`/`step` not finite, `step <= 0`, or the range beyond [`FITTED_LN_LIMIT`].
    Range,
    /// Values to encode that are not finite or do not match the shape.
    Values,
    /// More bytes than a parameter blob holds (bytes given).
    TooLarge(usize),
}

impl core::fmt::Display for FittedError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FittedError::Length(n) => write!(f, "{n} bytes do not match a fitted table's header and shape"),
            FittedError::Shape => write!(
                f,
                "fitted table axes must have {MIN_FITTED_NODES} to {MAX_FITTED_NODES} nodes"
            ),
            FittedError::Reserved => {
                write!(f, "fitted table: a reserved field or unused coverage bit is set")
            }
            FittedError::Range => write!(
                f,
                "fitted table: its ln range is not finite, not increasing or beyond +-{FITTED_LN_LIMIT}"
            ),
            FittedError::Values => write!(f, "fitted table: values not finite or not one per cell"),
            FittedError::TooLarge(n) => write!(
                f,
                "fitted table of {n} bytes: more than a parameter blob holds (4096 bytes); use fewer nodes"
            ),
        }
    }
}

impl core::error::Error for FittedError {}

/// The three axis values of a direction pair, each in `[0, 1]` (see the module docs); NaN
/// for a geometry built from NaN. Only meaningful above the horizon (the models return
/// there before asking).
#[inline]
pub fn axes<T: Float>(g: &Geometry<T>) -> [T; 3] {
    let omca = g.one_minus_cos_alpha();
    let omcg = g.one_minus_cos_gamma();
    // Clamped to [0, 1]; NaN stays NaN.
    let unit = |x: T| {
        if x > T::ONE {
            T::ONE
        } else if x < T::ZERO {
            T::ZERO
        } else {
            x
        }
    };
    // ((1 - cos theta_h)^2 + e^2)^(1/8), e = THETA_H_KNEE^4, shifted and scaled to [0, 1].
    let knee = T::from_f32(THETA_H_KNEE);
    let k2 = knee * knee;
    let e = k2 * k2;
    let s = unit(omca);
    let u = unit(((s * s + e * e).sqrt().sqrt().sqrt() - knee) / (T::ONE - knee));
    let v = unit(omcg).sqrt();
    // sin^2(theta_h) sin^2(theta_d), each as (1 - cos)(1 + cos): no cancellation.
    let s2 = (omca * (T::ONE + g.cos_alpha())) * (omcg * (T::ONE + g.cos_gamma()));
    let num = g.cos_theta_i_minus_cos_theta_r().abs();
    let den = T::TWO * s2.sqrt();
    // |cos phi_d|; 1 (phi_d = 0) where undefined (0 / 0) or rounded beyond 1; NaN for NaN.
    let c = if num < den {
        num / den
    } else if num >= den {
        T::ONE
    } else {
        num + den
    };
    [u, v, T::ONE - c * c]
}

/// The 8 cells of a point's trilinear stencil and their weights (summing to 1).
#[inline]
pub fn stencil<T: Float>(shape: FittedShape, x: [T; 3]) -> [(usize, T); 8] {
    let corner = |x: T, n: usize| -> (usize, T) {
        let s = x * T::from_index(n - 1);
        let i = s.to_index().min(n - 2);
        (i, s - T::from_index(i))
    };
    let (i, a) = corner(x[0], shape.theta_h);
    let (j, b) = corner(x[1], shape.theta_d);
    let (k, c) = corner(x[2], shape.phi_d);
    let (nd, np) = (shape.theta_d, shape.phi_d);
    let mut out = [(0, T::ZERO); 8];
    let mut m = 0;
    for (di, wi) in [(0, T::ONE - a), (1, a)] {
        for (dj, wj) in [(0, T::ONE - b), (1, b)] {
            for (dk, wk) in [(0, T::ONE - c), (1, c)] {
                out[m] = (((i + di) * nd + j + dj) * np + k + dk, wi * wj * wk);
                m += 1;
            }
        }
    }
    out
}

/// The header of a fitted table, read and checked once by [`FittedTable::new`]; with
/// [`FittedTable::from_parts`] a device rebinds it to the bytes it keeps in its blob buffer
/// without reading or checking the header again on every query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FittedConsts {
    shape: FittedShape,
    lo: f32,
    step: f32,
}

/// A fitted table over its bytes (checked by [`FittedTable::new`]).
#[derive(Clone, Copy, Debug)]
pub struct FittedTable<'t> {
    shape: FittedShape,
    lo: f32,
    step: f32,
    bytes: &'t [u8],
}

impl<'t> FittedTable<'t> {
    /// Checks the header, the length, the range and the unused coverage bits.
    pub fn new(bytes: &'t [u8]) -> Result<Self, FittedError> {
        if bytes.len() < FITTED_HEADER_LEN {
            return Err(FittedError::Length(bytes.len()));
        }
        let shape = FittedShape {
            theta_h: usize::from(bytes[0]),
            theta_d: usize::from(bytes[1]),
            phi_d: usize::from(bytes[2]),
        };
        if !shape.is_valid() {
            return Err(FittedError::Shape);
        }
        if bytes.len() != shape.encoded_len() {
            return Err(FittedError::Length(bytes.len()));
        }
        let f32_at = |i: usize| f32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
        if bytes[3] != 0 || bytes[12..16] != [0; 4] {
            return Err(FittedError::Reserved);
        }
        let (lo, step) = (f32_at(4), f32_at(8));
        let hi = lo + 65535.0 * step;
        let within = |x: f32| x.is_finite() && x.abs() <= FITTED_LN_LIMIT;
        if !(within(lo) && within(hi) && step > 0.0) {
            return Err(FittedError::Range);
        }
        let cells = shape.cells();
        let last = bytes[bytes.len() - 1];
        let used = cells % 8;
        if used != 0 && last >> used != 0 {
            return Err(FittedError::Reserved);
        }
        Ok(FittedTable {
            shape,
            lo,
            step,
            bytes,
        })
    }

    /// The checked header, for [`FittedTable::from_parts`].
    pub fn consts(&self) -> FittedConsts {
        FittedConsts {
            shape: self.shape,
            lo: self.lo,
            step: self.step,
        }
    }

    /// Rebinds a header from [`FittedTable::consts`] to table bytes; `None` unless the length
    /// matches. The bytes should be the ones the header was read from (and checked).
    #[inline]
    pub fn from_parts(c: FittedConsts, bytes: &'t [u8]) -> Option<Self> {
        (bytes.len() == c.shape.encoded_len()).then_some(FittedTable {
            shape: c.shape,
            lo: c.lo,
            step: c.step,
            bytes,
        })
    }

    /// Nodes per axis.
    pub fn shape(&self) -> FittedShape {
        self.shape
    }

    /// The quantised value of cell `c` (0 past the last cell, which [`stencil`] never gives).
    #[inline(always)]
    fn q(&self, c: usize) -> u16 {
        let at = FITTED_HEADER_LEN + 2 * c;
        match self.bytes.get(at..at + 2) {
            Some(b) => u16::from_le_bytes([b[0], b[1]]),
            None => 0,
        }
    }

    /// `t` at cell `c`.
    pub fn cell(&self, c: usize) -> f64 {
        f64::from(self.lo) + f64::from(self.q(c)) * f64::from(self.step)
    }

    /// Whether data constrain cell `c`.
    pub fn cell_covered(&self, c: usize) -> bool {
        let at = FITTED_HEADER_LEN + 2 * self.shape.cells() + c / 8;
        self.bytes.get(at).is_some_and(|b| b >> (c % 8) & 1 == 1)
    }

    /// The largest relative difference between this table's correction evaluated in f32 and
    /// in f64 from the same input: per axis, [`F32_AXIS_ERROR`] times the axis's node count
    /// less one times the largest step between neighbouring cells along it, plus the f32
    /// arithmetic of the interpolation and `exp` (1e-6 of `1 + max |t|`).
    pub fn f32_max_rel(&self) -> f64 {
        let FittedShape {
            theta_h: nh,
            theta_d: nd,
            phi_d: np,
        } = self.shape;
        let at = |i: usize, j: usize, k: usize| self.cell((i * nd + j) * np + k);
        let mut steps = [0.0f64; 3];
        let mut largest = 0.0f64;
        for i in 0..nh {
            for j in 0..nd {
                for k in 0..np {
                    let t = at(i, j, k);
                    largest = largest.max(t.abs());
                    if i + 1 < nh {
                        steps[0] = steps[0].max((at(i + 1, j, k) - t).abs());
                    }
                    if j + 1 < nd {
                        steps[1] = steps[1].max((at(i, j + 1, k) - t).abs());
                    }
                    if k + 1 < np {
                        steps[2] = steps[2].max((at(i, j, k + 1) - t).abs());
                    }
                }
            }
        }
        let n = [nh, nd, np];
        let mut dt = 1e-6 * (1.0 + largest);
        for a in 0..3 {
            dt += F32_AXIS_ERROR[a] * (n[a] - 1) as f64 * steps[a];
        }
        libm::expm1(dt)
    }

    /// Fraction of cells the data constrain.
    pub fn coverage(&self) -> f64 {
        let cells = self.shape.cells();
        (0..cells).filter(|&c| self.cell_covered(c)).count() as f64 / cells as f64
    }

    /// The correction `t = ln(f / f_base)` at `g` (above the horizon).
    #[inline]
    pub fn ln_correction<T: Float>(&self, g: &Geometry<T>) -> T {
        let x = axes(g);
        // A geometry that is not finite (NaN input) has no cell: NaN, never a plausible value.
        if !(x[0].is_finite() && x[1].is_finite() && x[2].is_finite()) {
            return x[0] + x[1] + x[2];
        }
        let mut acc = T::ZERO;
        for (c, w) in stencil(self.shape, x) {
            acc = acc + w * T::from_index(usize::from(self.q(c)));
        }
        T::from_f32(self.lo) + T::from_f32(self.step) * acc
    }

    /// Whether the data constrain the table at `g`: the covered cells of its stencil carry
    /// at least [`COVERED_SHARE`] of its weight. Outside, the table holds the smoothness
    /// term's extrapolation, not a measurement.
    pub fn covers<T: Float>(&self, g: &Geometry<T>) -> bool {
        let mut share = 0.0;
        for (c, w) in stencil(self.shape, axes(g)) {
            if self.cell_covered(c) {
                share += w.to_f64();
            }
        }
        share >= COVERED_SHARE
    }
}

/// Writes a table of `shape` holding `t` per cell (`ln_values`, quantised to u16 over their
/// own range) and `covered` per cell into `out`; returns the bytes written.
pub fn encode_fitted(
    shape: FittedShape,
    ln_values: &[f64],
    covered: &[bool],
    out: &mut [u8],
) -> Result<usize, FittedError> {
    if !shape.is_valid() {
        return Err(FittedError::Shape);
    }
    let cells = shape.cells();
    if ln_values.len() != cells || covered.len() != cells || ln_values.iter().any(|v| !v.is_finite()) {
        return Err(FittedError::Values);
    }
    let n = shape.encoded_len();
    if out.len() < n {
        return Err(FittedError::Length(out.len()));
    }
    let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in ln_values {
        min = min.min(v);
        max = max.max(v);
    }
    let lo = min as f32;
    // A flat table still needs a positive step; the f32 step is rounded up so that the largest
    // value's code stays within 65535.
    let step = (((max - f64::from(lo)) / 65535.0).max(1e-30) as f32) * (1.0 + f32::EPSILON);
    let out = &mut out[..n];
    out.fill(0);
    out[0] = shape.theta_h as u8;
    out[1] = shape.theta_d as u8;
    out[2] = shape.phi_d as u8;
    out[4..8].copy_from_slice(&lo.to_le_bytes());
    out[8..12].copy_from_slice(&step.to_le_bytes());
    for (c, &v) in ln_values.iter().enumerate() {
        let q = libm::round((v - f64::from(lo)) / f64::from(step)).clamp(0.0, 65535.0) as u16;
        out[FITTED_HEADER_LEN + 2 * c..FITTED_HEADER_LEN + 2 * c + 2].copy_from_slice(&q.to_le_bytes());
        if covered[c] {
            out[FITTED_HEADER_LEN + 2 * cells + c / 8] |= 1 << (c % 8);
        }
    }
    FittedTable::new(out)?;
    Ok(n)
}

/// A base model corrected by a fitted table: `f = f_base * exp(t)` above the horizon, the
/// base model's value (0, or NaN for NaN input) elsewhere.
#[derive(Clone, Copy, Debug)]
pub struct Corrected<'t, M> {
    /// The analytic base model.
    pub base: M,
    /// The correction.
    pub table: FittedTable<'t>,
}

impl<T: Float, M: Brdf<T>> Brdf<T> for Corrected<'_, M> {
    #[inline]
    fn eval(&self, g: &Geometry<T>) -> T {
        let f = self.base.eval(g);
        if !g.above_horizon() {
            return f;
        }
        f * self.table.ln_correction(g).exp()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::{Lambert, LambertParams};
    use std::vec;

    const SHAPE: FittedShape = FittedShape {
        theta_h: 6,
        theta_d: 5,
        phi_d: 3,
    };

    /// Rusinkiewicz angles by vectors and `acos`, the textbook way, for the axes' check.
    fn rusinkiewicz(ti: f64, tr: f64, phi: f64) -> [f64; 3] {
        let wi = [ti.sin(), 0.0, ti.cos()];
        let wo = [tr.sin() * phi.cos(), tr.sin() * phi.sin(), tr.cos()];
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        let h = [s[0] / n, s[1] / n, s[2] / n];
        let th = h[2].clamp(-1.0, 1.0).acos();
        let td = (wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2])
            .clamp(-1.0, 1.0)
            .acos();
        // phi_d: the angle between wi and the normal, both projected off h.
        let ci = wi[2];
        let pi_ = [
            wi[0] - td.cos() * h[0],
            wi[1] - td.cos() * h[1],
            wi[2] - td.cos() * h[2],
        ];
        let pn = [-th.cos() * h[0], -th.cos() * h[1], 1.0 - th.cos() * h[2]];
        let dot = pi_[0] * pn[0] + pi_[1] * pn[1] + pi_[2] * pn[2];
        let norm = (pi_.iter().map(|x| x * x).sum::<f64>() * pn.iter().map(|x| x * x).sum::<f64>()).sqrt();
        let _ = ci;
        let pd = (dot / norm).clamp(-1.0, 1.0).acos();
        [th, td, pd.min(core::f64::consts::PI - pd)]
    }

    #[test]
    fn axes_are_the_rusinkiewicz_half_angle_sines_and_reciprocal() {
        let mut s = 7u64;
        for _ in 0..2000 {
            let mut r = || crate::accuracy::splitmix64_unit(&mut s);
            let (ti, tr, phi) = (1.5 * r(), 1.5 * r(), 6.0 * r());
            let [th, td, pd] = rusinkiewicz(ti, tr, phi);
            let g = Geometry::<f64>::from_angles(ti, tr, phi);
            let [u, v, w] = axes(&g);
            let knee = f64::from(THETA_H_KNEE);
            let smooth = (((1.0 - th.cos()).powi(2) + knee.powi(8)).powf(0.125) - knee) / (1.0 - knee);
            let want = [smooth, (1.0 - td.cos()).sqrt(), pd.sin().powi(2)];
            for (m, (a, b)) in [u, v, w].iter().zip(want).enumerate() {
                // phi_d is ill-conditioned where theta_h or theta_d vanish; the check skips
                // those (below 0.05 rad).
                if m == 2 && (th < 0.05 || td < 0.05) {
                    continue;
                }
                assert!((a - b).abs() < 1e-6, "axis {m} at {ti} {tr} {phi}: {a} vs {b}");
            }
            let g2 = Geometry::<f32>::from_angles(tr as f32, ti as f32, phi as f32);
            let g1 = Geometry::<f32>::from_angles(ti as f32, tr as f32, phi as f32);
            assert_eq!(axes(&g1), axes(&g2), "reciprocal in f32 at {ti} {tr} {phi}");
            // f32 against f64 from the same f32 input, here and at the places where an axis
            // could lose it: near normal, near the mirror, in the plane, near grazing.
            let (a, b, c) = (ti as f32, tr as f32, phi as f32);
            let tiny = a * 1e-3;
            for (x, y, z) in [
                (a, b, c),
                (tiny, tiny * 0.4, c),
                (a, a + tiny * 1e-2, core::f32::consts::PI + tiny * 1e-2),
                (a, b, core::f32::consts::PI),
                (a, b, 0.0),
                (1.5, b, c),
            ] {
                let x32 = axes(&Geometry::<f32>::from_angles(x, y, z));
                let x64 = axes(&Geometry::<f64>::from_angles(x.into(), y.into(), z.into()));
                for m in 0..3 {
                    let e = (f64::from(x32[m]) - x64[m]).abs();
                    assert!(e <= F32_AXIS_ERROR[m], "axis {m} at {x} {y} {z}: {e:e}");
                }
            }
            assert!([u, v, w].iter().all(|x| (0.0..=1.0).contains(x)));
        }
        // Degenerate: mirror (theta_h = 0) and retro (theta_d = 0) stay finite.
        for g in [
            Geometry::<f32>::from_cosines(0.6, 0.6, -1.0),
            Geometry::<f32>::from_cosines(0.6, 0.6, 1.0),
        ] {
            assert!(axes(&g).iter().all(|x| x.is_finite()), "{:?}", axes(&g));
        }
    }

    fn values(shape: FittedShape) -> (vec::Vec<f64>, vec::Vec<bool>) {
        let c = shape.cells();
        (
            (0..c).map(|k| -1.0 + 0.01 * k as f64).collect(),
            (0..c).map(|k| k % 3 == 0).collect(),
        )
    }

    #[test]
    fn encode_round_trips_and_corrects_the_base() {
        let (v, cov) = values(SHAPE);
        let mut buf = vec![0u8; SHAPE.encoded_len()];
        assert_eq!(
            encode_fitted(SHAPE, &v, &cov, &mut buf).unwrap(),
            SHAPE.encoded_len()
        );
        let t = FittedTable::new(&buf).unwrap();
        for c in 0..SHAPE.cells() {
            assert!((t.cell(c) - v[c]).abs() < 2e-5, "{c}");
            assert_eq!(t.cell_covered(c), cov[c]);
        }
        // Rebound to the same bytes, the header read once gives the same table.
        let back = FittedTable::from_parts(t.consts(), &buf).unwrap();
        let g0 = Geometry::<f32>::from_cosines(0.3, 0.8, -0.4);
        assert_eq!(back.ln_correction(&g0), t.ln_correction(&g0));
        assert!(FittedTable::from_parts(t.consts(), &buf[..buf.len() - 1]).is_none());
        // At a node, the correction is that node's value.
        let base = Lambert::new(LambertParams { rho0: 0.5f32 }).unwrap();
        let m = Corrected { base, table: t };
        let g = Geometry::<f32>::from_cosines(1.0, 1.0, 1.0);
        let got = m.eval(&g);
        let want = base.eval(&g) * (t.cell(0) as f32).exp();
        assert!(((got - want) / want).abs() < 1e-5, "{got} vs {want}");
        assert_eq!(m.eval(&Geometry::from_cosines(0.0, 0.5, 1.0)), 0.0);
        assert!(m.eval(&Geometry::from_cosines(f32::NAN, 0.5, 1.0)).is_nan());
        // An azimuth that rounds to infinity in f32 gives NaN, not the value of cell 0 (the
        // base alone does not depend on phi and stays finite there).
        assert!(m.eval(&Geometry::from_angles(0.5, 0.5, f32::INFINITY)).is_nan());
        assert!(base
            .eval(&Geometry::from_angles(0.5, 0.5, f32::INFINITY))
            .is_finite());
        assert_eq!(
            m.eval(&Geometry::from_cosines(0.3, 0.8, -0.4)),
            m.eval(&Geometry::from_cosines(0.8, 0.3, -0.4))
        );
    }

    #[test]
    fn every_malformed_table_is_refused() {
        let (v, cov) = values(SHAPE);
        let mut buf = vec![0u8; SHAPE.encoded_len()];
        encode_fitted(SHAPE, &v, &cov, &mut buf).unwrap();
        let bad = |f: &dyn Fn(&mut vec::Vec<u8>)| {
            let mut c = buf.clone();
            f(&mut c);
            FittedTable::new(&c).unwrap_err()
        };
        assert_eq!(bad(&|c| c.truncate(10)), FittedError::Length(10));
        assert_eq!(bad(&|c| c.push(0)), FittedError::Length(buf.len() + 1));
        assert_eq!(bad(&|c| c[0] = 1), FittedError::Shape);
        assert_eq!(bad(&|c| c[2] = 65), FittedError::Shape);
        assert_eq!(bad(&|c| c[3] = 1), FittedError::Reserved);
        assert_eq!(bad(&|c| c[13] = 1), FittedError::Reserved);
        assert_eq!(
            bad(&|c| c[4..8].copy_from_slice(&f32::NAN.to_le_bytes())),
            FittedError::Range
        );
        assert_eq!(
            bad(&|c| c[8..12].copy_from_slice(&0f32.to_le_bytes())),
            FittedError::Range
        );
        assert_eq!(
            bad(&|c| c[8..12].copy_from_slice(&1f32.to_le_bytes())),
            FittedError::Range
        );
        // 90 cells: bits 2..8 of the last coverage byte are unused.
        assert_eq!(bad(&|c| *c.last_mut().unwrap() |= 0x80), FittedError::Reserved);
        let mut short = [0u8; 8];
        assert_eq!(
            encode_fitted(SHAPE, &v, &cov, &mut short).unwrap_err(),
            FittedError::Length(8)
        );
        assert_eq!(
            encode_fitted(SHAPE, &v[1..], &cov, &mut buf).unwrap_err(),
            FittedError::Values
        );
        let mut nan = v.clone();
        nan[3] = f64::NAN;
        assert_eq!(
            encode_fitted(SHAPE, &nan, &cov, &mut buf).unwrap_err(),
            FittedError::Values
        );
        let mut huge = v.clone();
        huge[3] = 200.0;
        assert_eq!(
            encode_fitted(SHAPE, &huge, &cov, &mut buf).unwrap_err(),
            FittedError::Range
        );
    }
}
