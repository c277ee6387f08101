//! Fitting kernels: each model evaluated with its gradient on precomputed geometry.
//!
//! Everything that does not depend on the parameters (the geometry of `brdf-core`,
//! `ln(1 - cos gamma)`, `ln(cos ti cos tr)`, `ln(1 + cos ti cos tr)`, the five-parameter
//! shadowing) is computed once per point, so one model evaluation costs two or three `exp`.
//! Values equal `brdf_core`'s f64 evaluation to ~1e-15 (test `kernels_match_core`).
//!
//! The fitter works in an *internal* parameter vector `q`: the paper's parameters except
//! `kr`, searched as `ln kr`, and `b`, searched as `beta = |b| >= 0` (reported as `b = -beta`,
//! the paper's sign).

use std::f64::consts::{LN_2, PI};

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
    p
}

/// `d natural_j / d internal_j` (the transform is diagonal).
pub fn natural_per_internal(kind: ModelKind, q: &[f64]) -> [f64; MAX_PARAMS] {
    let mut d = [1.0; MAX_PARAMS];
    if matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five) {
        d[1] = q[1].exp();
        d[2] = -1.0;
    }
    d
}

/// Lobe `exp(-beta x^a)` and `x^a`, with `x^a = 0` at the retro direction.
#[inline]
fn lobe(beta: f64, a: f64, ln_x: f64) -> (f64, f64) {
    let p = if ln_x == f64::NEG_INFINITY {
        0.0
    } else {
        (a * ln_x).exp()
    };
    ((-beta * p).exp(), p)
}

/// `f` at one point and, if `grad` is given, `df/dq` for the internal vector `q`.
#[inline]
pub fn eval(kind: ModelKind, q: &[f64], pt: &Prepared, grad: Option<&mut [f64]>) -> f64 {
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => {
            let (kb, lkr, beta, a, kd, c) = (q[0], q[1], q[2], q[3], q[4], q[5]);
            let k = (2.0 * lkr).exp();
            let (ca, o) = (pt.cos_alpha, pt.one_minus_cos_alpha);
            let (facet, dfacet_dlkr) = if kind == ModelKind::Six {
                let den = k * ca + o;
                (k * ca / den, 2.0 * k * ca * o / (den * den))
            } else {
                let den = k * ca * ca + o * (1.0 + ca);
                (k * ca / den, 2.0 * k * ca * o * (1.0 + ca) / (den * den))
            };
            let (l, p) = lobe(beta, a, pt.ln_x);
            let s = pt.ln1p_m / (PI * LN_2);
            let d = (c * pt.ln_m).exp() / PI;
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
            let (kb, lkr, beta, a, kd) = (q[0], q[1], q[2], q[3], q[4]);
            let k = (2.0 * lkr).exp();
            let (ca, o) = (pt.cos_alpha, pt.one_minus_cos_alpha);
            let den = k * ca + o;
            let facet = k * ca / den;
            let dfacet_dlkr = 2.0 * k * ca * o / (den * den);
            let (l, p) = lobe(beta, a, pt.ln_x);
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
            let (rho0, k) = (q[0], q[1]);
            let d = ((k - 1.0) * pt.ln_m).exp() / PI;
            if let Some(g) = grad {
                g[0] = d;
                g[1] = rho0 * d * pt.ln_m;
            }
            rho0 * d
        }
        ModelKind::Lambert => {
            if let Some(g) = grad {
                g[0] = 1.0 / PI;
            }
            q[0] / PI
        }
    }
}

/// Linear structure for variable projection: `f = sum_j lin_j * basis_j(nonlinear)`.
/// Writes the bases at `pt` for the nonlinear parameters `nl` and returns how many there are.
/// Nonlinear parameters: six `[ln kr, beta, a, c]`, five `[ln kr, beta, a]`, Minnaert `[k]`,
/// Lambert none. Linear: six `(kb, kd)`, five `(kb, kb kd)`, Minnaert and Lambert `rho0`.
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
            ModelKind::Six | ModelKind::SixCos2 => vec![0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2],
            ModelKind::Five => vec![0.2545, 1.8, -27.5721, 0.6705, 0.3676],
            ModelKind::Minnaert => vec![0.6, 0.7],
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
                ModelKind::Lambert => vec![],
            };
            let lin = match kind {
                ModelKind::Six | ModelKind::SixCos2 => [q[0], q[4]],
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
