//! Fitting kernels: each model evaluated with its gradient on precomputed geometry.
//!
//! Everything that does not depend on the parameters (the geometry of `brdf-core`,
//! `ln(1 - cos gamma)`, `ln(cos ti cos tr)`, `ln(1 + cos ti cos tr)`, the five-parameter
//! shadowing) is computed once per point, so one model evaluation costs two or three `exp`.
//! Values equal `brdf_core`'s f64 evaluation to ~1e-15 (test `kernels_match_core`).
//!
//! The fitter works in an *internal* parameter vector `q`: the paper's parameters except
//! `kr`, searched as `ln kr`, and `b`, searched as `beta = |b| >= 0` (reported as `b = -beta`,
//! the paper's sign); the microfacet model's `alpha` is searched as `ln alpha`.

use std::f64::consts::{LN_2, PI};

use brdf_core::batch::{exp_in_place, Level};
use brdf_core::{FiveParam, Geometry, ModelKind, MAX_PARAMS};

use crate::data::Point;

/// Parameter-independent quantities of one data point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prepared {
    cos_alpha: f64,
    one_minus_cos_alpha: f64,
    /// `ln(1 - cos gamma)`; `-inf` at the retro direction.
    ln_x: f64,
    /// `ln(cos ti cos tr)`.
    ln_m: f64,
    /// `ln(1 + cos ti cos tr)`.
    ln1p_m: f64,
    /// `1 / cos ti`.
    inv_mi: f64,
    /// Five-parameter `G / (cos ti cos tr)`.
    g_over_m: f64,
    /// `cos ti`, `cos tr` (the microfacet model's masking).
    mi: f64,
    mr: f64,
    /// `(1 - cos gamma)^5` (Schlick's Fresnel factor).
    w5: f64,
}

impl Prepared {
    /// Precomputes one point (angles in radians, both zeniths below 90°).
    pub fn new(theta_i: f64, theta_r: f64, phi: f64) -> Self {
        let g = Geometry::<f64>::from_angles(theta_i, theta_r, phi);
        let (mi, mr) = (g.cos_theta_i(), g.cos_theta_r());
        let m = mi * mr;
        Prepared {
            cos_alpha: g.cos_alpha(),
            one_minus_cos_alpha: g.one_minus_cos_alpha(),
            ln_x: g.one_minus_cos_gamma().ln(),
            ln_m: m.ln(),
            ln1p_m: m.ln_1p(),
            inv_mi: 1.0 / mi,
            g_over_m: FiveParam::shadowing(&g) / m,
            mi,
            mr,
            w5: g.one_minus_cos_gamma().powi(5),
        }
    }

    /// From a data point.
    pub fn from_point(p: &Point) -> Self {
        Self::new(p.theta_i, p.theta_r, p.phi)
    }
}

/// Internal parameter vector of `kind` from the paper's parameters (core order).
pub fn to_internal(kind: ModelKind, natural: &[f64]) -> [f64; MAX_PARAMS] {
    let mut q = [0.0; MAX_PARAMS];
    q[..natural.len()].copy_from_slice(natural);
    if matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five) {
        q[1] = natural[1].ln();
        q[2] = natural[2].abs();
    }
    if kind == ModelKind::Ggx {
        q[1] = natural[1].ln();
    }
    q
}

/// The paper's parameters (core order) from the internal vector.
pub fn to_natural(kind: ModelKind, q: &[f64]) -> [f64; MAX_PARAMS] {
    let mut p = [0.0; MAX_PARAMS];
    p[..q.len()].copy_from_slice(q);
    if matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five) {
        p[1] = q[1].exp();
        // b = -|b| as in the paper; |b| = 0 is reported as +0.
        p[2] = if q[2] == 0.0 { 0.0 } else { -q[2] };
    }
    if kind == ModelKind::Ggx {
        p[1] = q[1].exp();
    }
    p
}

/// `d natural_j / d internal_j` (the transform is diagonal).
pub fn natural_per_internal(kind: ModelKind, q: &[f64]) -> [f64; MAX_PARAMS] {
    let mut d = [1.0; MAX_PARAMS];
    if matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five) {
        d[1] = q[1].exp();
        d[2] = -1.0;
    }
    if kind == ModelKind::Ggx {
        d[1] = q[1].exp();
    }
    d
}

/// The exponentials one evaluation needs, given the internal vector `q`: `x^a = exp(a ln x)`
/// (0 at the retro direction), the lobe `exp(-beta x^a)` and `(cos ti cos tr)^e = exp(e ln m)`
/// with `e = c` (six) or `k - 1` (Minnaert). [`eval`] computes them one point at a time,
/// [`eval_many`] for many points at once through the core's vectorised `exp`.
#[derive(Clone, Copy, Debug, Default)]
struct Exps {
    power: f64,
    lobe: f64,
    m_pow: f64,
}

/// The exponent of `cos ti cos tr` in the model's second factor.
#[inline]
fn m_exponent(kind: ModelKind, q: &[f64]) -> f64 {
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => q[5],
        ModelKind::Minnaert => q[1] - 1.0,
        ModelKind::Five | ModelKind::Ggx | ModelKind::Lambert => 0.0,
    }
}

/// `f` at one point and, if `grad` is given, `df/dq` for the internal vector `q`.
#[inline]
pub fn eval(kind: ModelKind, q: &[f64], pt: &Prepared, grad: Option<&mut [f64]>) -> f64 {
    let k = if q.len() > 1 { (2.0 * q[1]).exp() } else { 0.0 };
    let lobed = matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five);
    let power = if !lobed || pt.ln_x == f64::NEG_INFINITY {
        0.0
    } else {
        (q[3] * pt.ln_x).exp()
    };
    let e = Exps {
        power,
        lobe: if lobed { (-q[2] * power).exp() } else { 1.0 },
        m_pow: (m_exponent(kind, q) * pt.ln_m).exp(),
    };
    finish(kind, q, k, pt, e, grad)
}

/// Points per call of the vectorised exponential in [`eval_many`].
const LANES: usize = 256;

/// [`eval`] at every point of `pts` into `f` (and the gradients into `grad`, one row per
/// point): the per-parameter constants once, the exponentials of up to 256 points per call of
/// `brdf_core::batch::exp_in_place` (vectorised, AVX2/AVX-512 when the CPU has them). Equal
/// to [`eval`] within `F64_REFORMULATION_REL` (test `many_points_match_one_at_a_time`).
pub fn eval_many(
    kind: ModelKind,
    q: &[f64],
    pts: &[Prepared],
    f: &mut [f64],
    mut grad: Option<&mut [[f64; MAX_PARAMS]]>,
) {
    let level = Level::detected();
    let k = if q.len() > 1 { (2.0 * q[1]).exp() } else { 0.0 };
    let lobed = matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five);
    let e_m = m_exponent(kind, q);
    let mut power = [0.0; LANES];
    let mut lobe = [1.0; LANES];
    let mut m_pow = [0.0; LANES];
    for (c, chunk) in pts.chunks(LANES).enumerate() {
        let n = chunk.len();
        if lobed {
            for (x, pt) in power.iter_mut().zip(chunk) {
                // ln x = -inf at the retro direction: exp(-inf) = 0 = x^a.
                *x = q[3] * pt.ln_x;
            }
            exp_in_place(&mut power[..n], level);
            for (l, &p) in lobe.iter_mut().zip(&power[..n]) {
                *l = -q[2] * p;
            }
            exp_in_place(&mut lobe[..n], level);
        }
        for (x, pt) in m_pow.iter_mut().zip(chunk) {
            *x = e_m * pt.ln_m;
        }
        exp_in_place(&mut m_pow[..n], level);
        for (i, pt) in chunk.iter().enumerate() {
            let e = Exps {
                power: power[i],
                lobe: lobe[i],
                m_pow: m_pow[i],
            };
            let at = c * LANES + i;
            let g = grad.as_deref_mut().map(|g| &mut g[at][..q.len()]);
            f[at] = finish(kind, q, k, pt, e, g);
        }
    }
}

/// The model and its gradient at one point from the exponentials; `k = kr^2 = exp(2 ln kr)`.
#[inline(always)]
fn finish(kind: ModelKind, q: &[f64], k: f64, pt: &Prepared, e: Exps, grad: Option<&mut [f64]>) -> f64 {
    let (p, l) = (e.power, e.lobe);
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => {
            let (kb, beta, kd) = (q[0], q[2], q[4]);
            let (ca, o) = (pt.cos_alpha, pt.one_minus_cos_alpha);
            let (facet, dfacet_dlkr) = if kind == ModelKind::Six {
                let den = k * ca + o;
                (k * ca / den, 2.0 * k * ca * o / (den * den))
            } else {
                let den = k * ca * ca + o * (1.0 + ca);
                (k * ca / den, 2.0 * k * ca * o * (1.0 + ca) / (den * den))
            };
            let s = pt.ln1p_m / (PI * LN_2);
            let d = e.m_pow / PI;
            let spec = kb * s * facet * l;
            if let Some(g) = grad {
                g[0] = s * facet * l;
                g[1] = kb * s * l * dfacet_dlkr;
                g[2] = -spec * p;
                g[3] = if p == 0.0 { 0.0 } else { -spec * beta * p * pt.ln_x };
                g[4] = d;
                g[5] = kd * d * pt.ln_m;
            }
            spec + kd * d
        }
        ModelKind::Five => {
            let (kb, beta, kd) = (q[0], q[2], q[4]);
            let (ca, o) = (pt.cos_alpha, pt.one_minus_cos_alpha);
            let den = k * ca + o;
            let facet = k * ca / den;
            let dfacet_dlkr = 2.0 * k * ca * o / (den * den);
            let spec = facet * l * pt.g_over_m;
            if let Some(g) = grad {
                g[0] = spec + kd * pt.inv_mi;
                g[1] = kb * l * pt.g_over_m * dfacet_dlkr;
                g[2] = -kb * spec * p;
                g[3] = if p == 0.0 {
                    0.0
                } else {
                    -kb * spec * beta * p * pt.ln_x
                };
                g[4] = kb * pt.inv_mi;
            }
            kb * (spec + kd * pt.inv_mi)
        }
        ModelKind::Minnaert => {
            let rho0 = q[0];
            let d = e.m_pow / PI;
            if let Some(g) = grad {
                g[0] = d;
                g[1] = rho0 * d * pt.ln_m;
            }
            rho0 * d
        }
        ModelKind::Ggx => {
            let (ks, kd) = (q[0], q[3]);
            let (shape, d_shape_dl, d_shape_df0) = microfacet(q[1], q[2], pt);
            if let Some(g) = grad {
                g[0] = shape;
                g[1] = ks * d_shape_dl;
                g[2] = ks * d_shape_df0;
                g[3] = 1.0 / PI;
            }
            ks * shape + kd / PI
        }
        ModelKind::Lambert => {
            if let Some(g) = grad {
                g[0] = 1.0 / PI;
            }
            q[0] / PI
        }
    }
}

/// The microfacet model's specular shape `F D V` (`brdf_core::Ggx::specular_shape`) at
/// `ln alpha = l` and `f0`, with its derivatives in `l` and `f0`.
#[inline]
fn microfacet(l: f64, f0: f64, pt: &Prepared) -> (f64, f64, f64) {
    let a2 = (2.0 * l).exp();
    let (ch, o) = (pt.cos_alpha, pt.one_minus_cos_alpha);
    let den = a2 * ch * ch + o * (1.0 + ch);
    let d = a2 / (PI * den * den);
    // dD/d(a2) = D (1/a2 - 2 ch^2 / den).
    let dd = d * (1.0 / a2 - 2.0 * ch * ch / den);
    let (si2, sr2) = ((1.0 - pt.mi) * (1.0 + pt.mi), (1.0 - pt.mr) * (1.0 + pt.mr));
    let s_i = (pt.mi * pt.mi + a2 * si2).sqrt();
    let s_r = (pt.mr * pt.mr + a2 * sr2).sqrt();
    let v = 1.0 / (2.0 * (pt.mr * s_i + pt.mi * s_r));
    // V = 1/(2T): dV/d(a2) = -2 V^2 dT/d(a2), dS/d(a2) = sin^2 / (2 S).
    let dt = pt.mr * si2 / (2.0 * s_i) + pt.mi * sr2 / (2.0 * s_r);
    let dv = -2.0 * v * v * dt;
    let fresnel = f0 + (1.0 - f0) * pt.w5;
    let shape = d * v * fresnel;
    // d(a2)/dl = 2 a2.
    let d_dl = (dd * v + d * dv) * fresnel * 2.0 * a2;
    (shape, d_dl, d * v * (1.0 - pt.w5))
}

/// Linear structure for variable projection: `f = sum_j lin_j * basis_j(nonlinear)`.
/// Writes the bases at `pt` for the nonlinear parameters `nl` and returns how many there are.
/// Nonlinear parameters: six `[ln kr, beta, a, c]`, five `[ln kr, beta, a]`, microfacet
/// `[ln alpha, f0]`, Minnaert `[k]`, Lambert none. Linear: six `(kb, kd)`, five `(kb, kb kd)`,
/// microfacet `(ks, kd)`, Minnaert and Lambert `rho0`.
#[inline]
pub fn bases(kind: ModelKind, nl: &[f64], pt: &Prepared, out: &mut [f64; 2]) -> usize {
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => {
            let q = [1.0, nl[0], nl[1], nl[2], 0.0, nl[3]];
            let mut g = [0.0; MAX_PARAMS];
            eval(kind, &q, pt, Some(&mut g));
            out[0] = g[0];
            out[1] = g[4];
            2
        }
        ModelKind::Five => {
            let q = [1.0, nl[0], nl[1], nl[2], 0.0];
            out[0] = eval(kind, &q, pt, None);
            out[1] = pt.inv_mi;
            2
        }
        ModelKind::Minnaert => {
            out[0] = ((nl[0] - 1.0) * pt.ln_m).exp() / PI;
            1
        }
        ModelKind::Ggx => {
            out[0] = microfacet(nl[0], nl[1], pt).0;
            out[1] = 1.0 / PI;
            2
        }
        ModelKind::Lambert => {
            out[0] = 1.0 / PI;
            1
        }
    }
}

/// Factors of the lobe models' bases, for annealing moves that change one parameter at a
/// time: `basis0 = weight * facet(kr) * exp(-beta * power(a))`, `basis1 = second(c)`.
pub mod factors {
    use super::*;

    /// `ln(1 + m)/(pi ln 2)` (six) or `G/m` (five): the parameter-free part of basis 0.
    #[inline]
    pub fn weight(kind: ModelKind, pt: &Prepared) -> f64 {
        if kind == ModelKind::Five {
            pt.g_over_m
        } else {
            pt.ln1p_m / (PI * LN_2)
        }
    }

    /// Facet term for `kr^2 = k`.
    #[inline]
    pub fn facet(kind: ModelKind, k: f64, pt: &Prepared) -> f64 {
        let (ca, o) = (pt.cos_alpha, pt.one_minus_cos_alpha);
        if kind == ModelKind::SixCos2 {
            k * ca / (k * ca * ca + o * (1.0 + ca))
        } else {
            k * ca / (k * ca + o)
        }
    }

    /// `(1 - cos gamma)^a`, 0 at the retro direction.
    #[inline]
    pub fn power(a: f64, pt: &Prepared) -> f64 {
        if pt.ln_x == f64::NEG_INFINITY {
            0.0
        } else {
            (a * pt.ln_x).exp()
        }
    }

    /// Basis 1: `(cos ti cos tr)^c / pi` (six) or `1 / cos ti` (five).
    #[inline]
    pub fn second(kind: ModelKind, c: f64, pt: &Prepared) -> f64 {
        if kind == ModelKind::Five {
            pt.inv_mi
        } else {
            (c * pt.ln_m).exp() / PI
        }
    }
}

/// Number of nonlinear parameters of `kind` in [`bases`].
pub const fn nonlinear_count(kind: ModelKind) -> usize {
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => 4,
        ModelKind::Five => 3,
        ModelKind::Ggx => 2,
        ModelKind::Minnaert => 1,
        ModelKind::Lambert => 0,
    }
}

/// Internal vector from nonlinear parameters and the linear coefficients of [`bases`].
pub fn assemble(kind: ModelKind, nl: &[f64], lin: [f64; 2]) -> [f64; MAX_PARAMS] {
    let mut q = [0.0; MAX_PARAMS];
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => {
            q[..6].copy_from_slice(&[lin[0], nl[0], nl[1], nl[2], lin[1], nl[3]]);
        }
        ModelKind::Five => {
            let kd = if lin[0] > 0.0 { lin[1] / lin[0] } else { 0.0 };
            q[..5].copy_from_slice(&[lin[0], nl[0], nl[1], nl[2], kd]);
        }
        ModelKind::Minnaert => q[..2].copy_from_slice(&[lin[0], nl[0]]),
        ModelKind::Ggx => q[..4].copy_from_slice(&[lin[0], nl[0], nl[1], lin[1]]),
        ModelKind::Lambert => q[0] = lin[0],
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::tolerance::F64_REFORMULATION_REL;
    use brdf_core::{AnyModel, Brdf};

    fn params(kind: ModelKind) -> Vec<f64> {
        match kind {
            ModelKind::Six | ModelKind::SixCos2 => brdf_core::TABLE1[0].1.to_vec(),
            ModelKind::Five => vec![0.2545, 1.8, -27.5721, 0.6705, 0.3676],
            ModelKind::Minnaert => vec![0.6, 0.7],
            ModelKind::Ggx => vec![1.7, 0.15, 0.3, 0.2],
            ModelKind::Lambert => vec![0.6],
        }
    }

    #[test]
    fn kernels_match_core() {
        for kind in ModelKind::ALL {
            let p = params(kind);
            let core = AnyModel::<f64>::new(kind, &p).unwrap();
            let q = to_internal(kind, &p);
            for &(ti, tr, phi) in &[(0.1, 0.2, 0.3), (0.5, 0.5, 0.0), (1.2, 0.4, 3.0), (0.0, 1.5, 1.0)] {
                let want = core.eval_angles(ti, tr, phi);
                let got = eval(kind, &q[..kind.param_count()], &Prepared::new(ti, tr, phi), None);
                assert!(
                    ((got - want) / want).abs() < F64_REFORMULATION_REL,
                    "{kind:?}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn many_points_match_one_at_a_time() {
        // More points than one vectorised call, with retro directions (x^a = 0) among them.
        let pts: Vec<Prepared> = (0..600)
            .map(|i| {
                let t = f64::from(i);
                let ti = (t * 0.618).fract() * 1.5;
                let tr = if i % 7 == 0 { ti } else { (t * 0.414).fract() * 1.5 };
                Prepared::new(
                    ti,
                    tr,
                    if i % 7 == 0 {
                        0.0
                    } else {
                        (t * 0.732).fract() * 6.0
                    },
                )
            })
            .collect();
        for kind in ModelKind::ALL {
            let n = kind.param_count();
            let q = to_internal(kind, &params(kind));
            let mut f = vec![0.0; pts.len()];
            let mut g = vec![[0.0; MAX_PARAMS]; pts.len()];
            eval_many(kind, &q[..n], &pts, &mut f, Some(&mut g));
            for (i, pt) in pts.iter().enumerate() {
                let mut want_g = [0.0; MAX_PARAMS];
                let want = eval(kind, &q[..n], pt, Some(&mut want_g[..n]));
                let close = |a: f64, b: f64| (a - b).abs() <= F64_REFORMULATION_REL * b.abs().max(1e-300);
                assert!(close(f[i], want), "{kind:?} point {i}: {} vs {want}", f[i]);
                for j in 0..n {
                    assert!(
                        close(g[i][j], want_g[j]) || (g[i][j] - want_g[j]).abs() < 1e-15 * want.abs(),
                        "{kind:?} point {i} grad {j}"
                    );
                }
            }
        }
    }

    #[test]
    fn gradients_match_finite_differences() {
        for kind in ModelKind::ALL {
            let n = kind.param_count();
            let q = to_internal(kind, &params(kind));
            let pt = Prepared::new(0.4, 0.7, 2.0);
            let mut g = [0.0; MAX_PARAMS];
            let f = eval(kind, &q[..n], &pt, Some(&mut g));
            for j in 0..n {
                let h = 1e-6 * q[j].abs().max(1e-3);
                let (mut up, mut dn) = (q, q);
                up[j] += h;
                dn[j] -= h;
                let fd = (eval(kind, &up[..n], &pt, None) - eval(kind, &dn[..n], &pt, None)) / (2.0 * h);
                // Central differences: truncation ~1e-12 relative, rounding ~1e-16 f / h.
                let tol = 1e-7 * fd.abs() + 1e-9 * f;
                assert!((fd - g[j]).abs() <= tol, "{kind:?} param {j}: {fd} vs {}", g[j]);
            }
        }
    }

    #[test]
    fn bases_reassemble_the_model() {
        for kind in ModelKind::ALL {
            let q = to_internal(kind, &params(kind));
            let nl: Vec<f64> = match kind {
                ModelKind::Six | ModelKind::SixCos2 => vec![q[1], q[2], q[3], q[5]],
                ModelKind::Five => vec![q[1], q[2], q[3]],
                ModelKind::Minnaert => vec![q[1]],
                ModelKind::Ggx => vec![q[1], q[2]],
                ModelKind::Lambert => vec![],
            };
            let lin = match kind {
                ModelKind::Six | ModelKind::SixCos2 => [q[0], q[4]],
                ModelKind::Ggx => [q[0], q[3]],
                ModelKind::Five => [q[0], q[0] * q[4]],
                _ => [q[0], 0.0],
            };
            let pt = Prepared::new(0.3, 0.9, 1.0);
            let mut b = [0.0; 2];
            let nb = bases(kind, &nl, &pt, &mut b);
            let f: f64 = (0..nb).map(|j| lin[j] * b[j]).sum();
            let want = eval(kind, &q[..kind.param_count()], &pt, None);
            assert!((f - want).abs() < F64_REFORMULATION_REL * want, "{kind:?}");
            let back = assemble(kind, &nl, lin);
            assert!((0..kind.param_count())
                .all(|j| (back[j] - q[j]).abs() < F64_REFORMULATION_REL * (1.0 + q[j].abs())));
        }
    }
}
