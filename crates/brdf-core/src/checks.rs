//! Physical checks: reciprocity, the analytic energy bound and the directional-hemispherical
//! reflectance (albedo) by heap-free quadrature.

use crate::batch::Batch;
use crate::float::Float;
use crate::model::{Brdf, Model};

/// `(f(ti, tr, phi), f(tr, ti, phi))`: a reciprocal BRDF returns two equal values.
/// Angles in radians.
pub fn reciprocity_pair<T: Float, M: Brdf<T>>(model: &M, theta_i: T, theta_r: T, phi: T) -> (T, T) {
    (
        model.eval_angles(theta_i, theta_r, phi),
        model.eval_angles(theta_r, theta_i, phi),
    )
}

/// Outcome of [`energy_check`] at one incidence angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnergyCheck<T> {
    /// The model's analytic sufficient bound (`kb + kd` for the six-parameter model), if any.
    pub bound: Option<T>,
    /// The analytic bound is at most 1, which proves energy conservation at every incidence.
    pub bound_conserves: bool,
    /// Directional-hemispherical reflectance at the checked incidence, by quadrature.
    pub albedo: T,
    /// `albedo <= 1` at the checked incidence (within the quadrature's stated accuracy).
    pub albedo_conserves: bool,
}

/// Energy check at incidence `theta_i` (radians): the analytic bound and the quadrature
/// albedo with [`AlbedoRule::DEFAULT`].
pub fn energy_check<T: Float, M: Model<T>>(model: &M, theta_i: T) -> EnergyCheck<T> {
    let bound = model.energy_bound();
    let albedo = albedo(model, theta_i, AlbedoRule::DEFAULT);
    EnergyCheck {
        bound,
        bound_conserves: matches!(bound, Some(b) if b <= T::ONE),
        albedo,
        albedo_conserves: albedo <= T::ONE,
    }
}

/// A composite Gauss–Legendre rule over the viewing hemisphere.
///
/// `theta_r` is split at `theta_i` (so the retro and mirror features, both at
/// `theta_r = theta_i`, lie on panel edges) and each side into `panels` panels, the one at
/// the horizon in the variable `s = sqrt(pi/2 - theta_r)`; `phi` over `[0, pi]` (the family
/// depends on `cos phi` only) into `panels` panels, half on each side of `pi/2`. The panels
/// next to the retro and mirror features are halved geometrically 6 times (smallest width
/// 1/64 of a panel), so mirror peaks as narrow as `kr = 0.01` are resolved. 8 nodes per panel
/// and dimension: `8 (2 panels + 12) * 8 (panels + 12)` model evaluations (35,840 for 8).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AlbedoRule {
    /// Panels per `theta_r` side and along `phi`; at least 2.
    pub panels: u16,
}

/// A panel count outside [`AlbedoRule::MIN_PANELS`]`..=`[`AlbedoRule::MAX_PANELS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PanelsError {
    /// The count asked for.
    pub panels: u64,
}

impl core::fmt::Display for PanelsError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "panels {} is outside {}..={} (the quadrature's cost grows as panels squared: {} \
             panels take about a second per incidence)",
            self.panels,
            AlbedoRule::MIN_PANELS,
            AlbedoRule::MAX_PANELS,
            AlbedoRule::MAX_PANELS
        )
    }
}

impl core::error::Error for PanelsError {}

impl AlbedoRule {
    /// Fewest panels: one on each side of `pi/2` along `phi`.
    pub const MIN_PANELS: u16 = 2;

    /// Most panels a rule may be asked for. The cost grows as panels squared,
    /// `8 (2 p + 12) * 8 (p + 12)` evaluations: 1024 panels are 136 million, about 0.9 s per
    /// incidence through the batch path (1000 measured at 0.83 s), four times the finest rule
    /// [`AlbedoRule::for_model`] chooses and twice the 512 its accuracy is measured against.
    /// 65,535 panels ran for about an hour per incidence.
    pub const MAX_PANELS: u16 = 1024;

    /// The rule with `panels` panels, within [`AlbedoRule::MIN_PANELS`]`..=`
    /// [`AlbedoRule::MAX_PANELS`].
    pub fn new(panels: u64) -> Result<AlbedoRule, PanelsError> {
        match u16::try_from(panels) {
            Ok(p) if (Self::MIN_PANELS..=Self::MAX_PANELS).contains(&p) => Ok(AlbedoRule { panels: p }),
            _ => Err(PanelsError { panels }),
        }
    }

    /// 8 panels (35,840 evaluations), relative accuracy
    /// [`crate::tolerance::ALBEDO_DEFAULT_REL`] (see there for where it is measured).
    pub const DEFAULT: AlbedoRule = AlbedoRule { panels: 8 };

    /// The rule that resolves `model`'s narrowest feature: [`AlbedoRule::DEFAULT`], or for
    /// the microfacet model with `alpha < 1/32` (its mirror peak narrower than the default
    /// rule resolves near grazing) `0.25 / alpha` panels rounded up to a power of two, at most
    /// 256. Measured at 89° incidence (`f0 = 1`): with 8 panels `alpha = 0.01` errs by 2.2%,
    /// 0.003 by 15%, 1/1024 by 82%; with this rule all agree with 512 panels within 4e-5
    /// (test `albedo_rule_resolves_narrow_microfacet_peaks`). 256 panels cost 0.08 s per
    /// incidence through the batch path.
    pub fn for_model<T: crate::Float>(model: &crate::AnyModel<T>) -> AlbedoRule {
        let crate::AnyModel::Ggx(m) = model else {
            return Self::DEFAULT;
        };
        let alpha = m.params().alpha.to_f64();
        if alpha >= 1.0 / 32.0 {
            return Self::DEFAULT;
        }
        // `as` truncates (no `ceil` without std): one more panel than 0.25 / alpha.
        let want = (0.25 / alpha) as u16 + 1;
        AlbedoRule {
            panels: want.next_power_of_two().clamp(Self::DEFAULT.panels, 256),
        }
    }
}

/// 8-point Gauss–Legendre nodes on [-1, 1] (positive half) and weights.
const GL8_X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const GL8_W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// Calls `f(x, w)` for the 8-point rule's nodes `x` and weights `w` on `[lo, hi]`.
#[inline]
fn gl8<T: Float>(lo: T, hi: T, mut f: impl FnMut(T, T)) {
    let mid = (lo + hi) * T::HALF;
    let half = (hi - lo) * T::HALF;
    for k in 0..4 {
        let dx = half * T::from_f64(GL8_X[k]);
        let w = half * T::from_f64(GL8_W[k]);
        f(mid - dx, w);
        f(mid + dx, w);
    }
}

/// Directional-hemispherical reflectance `rho(theta_i) = int f_r cos(theta_r) d omega_r`
/// (dimensionless) at incidence `theta_i` (radians), by the composite rule `rule`.
/// No heap; evaluate in f64 for reference figures. [`albedo_batch`] is the same rule through
/// the batch path.
pub fn albedo<T: Float, M: Brdf<T>>(model: &M, theta_i: T, rule: AlbedoRule) -> T {
    albedo_by(theta_i, rule, |theta_r, phi, out| {
        for (o, &p) in out.iter_mut().zip(phi) {
            *o = model.eval_angles(theta_i, theta_r, p);
        }
    })
}

/// [`albedo`] through the batch path ([`crate::batch`]): each ring's azimuth nodes in one
/// [`Batch::ring`] call. Agrees with [`albedo`] to [`crate::tolerance::BATCH_F64_REL`] in f64.
pub fn albedo_batch<T: Float>(model: &Batch<T>, theta_i: T, rule: AlbedoRule) -> T {
    albedo_by(theta_i, rule, |theta_r, phi, out| {
        // An invalid ring (a NaN theta_r from a NaN theta_i) leaves NaN, which the sum carries.
        let _ = model.ring(theta_i, theta_r, phi, out);
    })
}

/// Azimuth nodes evaluated per call in [`albedo_by`].
const RING: usize = 256;

/// The rule, with `eval_ring(theta_r, phis, out)` evaluating the model at `theta_i` and one
/// `theta_r` for up to [`RING`] azimuths; sums in node order.
fn albedo_by<T: Float>(theta_i: T, rule: AlbedoRule, mut eval_ring: impl FnMut(T, &[T], &mut [T])) -> T {
    let panels = rule.panels.max(2);
    let half_pi = T::PI * T::HALF;
    let mut total = T::ZERO;
    // Inner integral over phi in [0, pi], times sin(theta_r) cos(theta_r); refined towards
    // phi = 0 (retro) and phi = pi (mirror).
    let mut ring = |theta_r: T| -> T {
        let (s, c) = theta_r.sin_cos();
        let mut inner = T::ZERO;
        let mut phis = [T::ZERO; RING];
        let mut weights = [T::ZERO; RING];
        let mut values = [T::ZERO; RING];
        let mut n = 0;
        let mut flush = |phis: &[T], weights: &[T], values: &mut [T], inner: &mut T| {
            eval_ring(theta_r, phis, values);
            for (&w, &v) in weights.iter().zip(values.iter()) {
                *inner = *inner + w * v;
            }
        };
        let mut add = |a: T, b: T| {
            gl8(a, b, |phi, wp| {
                phis[n] = phi;
                weights[n] = wp;
                n += 1;
                if n == RING {
                    flush(&phis, &weights, &mut values, &mut inner);
                    n = 0;
                }
            });
        };
        refined_panels(T::ZERO, half_pi, false, panels / 2, &mut add);
        refined_panels(half_pi, T::PI, true, panels / 2, &mut add);
        flush(&phis[..n], &weights[..n], &mut values[..n], &mut inner);
        s * c * inner
    };
    // theta_r in [0, theta_i], refined towards theta_i.
    if theta_i > T::ZERO {
        refined_panels(T::ZERO, theta_i, true, panels, &mut |a, b| {
            gl8(a, b, |theta_r, w| total = total + w * ring(theta_r));
        });
    }
    // theta_r in [theta_i, pi/2], refined towards theta_i; the panel at the horizon in the
    // variable s = sqrt(pi/2 - theta_r), where grazing factors such as cos(theta_r)^k
    // (Minnaert, small c) are smooth.
    let span = half_pi - theta_i;
    if span > T::ZERO {
        let step = span / T::from_f64(f64::from(panels));
        refined_panels(theta_i, half_pi - step, false, panels - 1, &mut |a, b| {
            gl8(a, b, |theta_r, w| total = total + w * ring(theta_r));
        });
        gl8(T::ZERO, step.sqrt(), |s, w| {
            total = total + w * T::TWO * s * ring(half_pi - s * s);
        });
    }
    T::TWO * total
}

/// Geometric refinement of the panel next to a feature: it is halved this many times.
const REFINE: u32 = 6;

/// Calls `f(a, b)` for `n` uniform panels over `[lo, hi]`, the one next to `hi`
/// (`towards_hi`) or `lo` split geometrically into `REFINE + 1` panels whose widths halve
/// towards that end, so that a narrow peak there is resolved.
fn refined_panels<T: Float>(lo: T, hi: T, towards_hi: bool, n: u16, f: &mut impl FnMut(T, T)) {
    if hi <= lo || n == 0 {
        return;
    }
    let step = (hi - lo) / T::from_f64(f64::from(n));
    for k in 0..n - 1 {
        let k = T::from_f64(f64::from(if towards_hi { k } else { k + 1 }));
        f(lo + step * k, lo + step * (k + T::ONE));
    }
    // The refined panel: [edge, edge + step] or [edge - step, edge] towards `edge`.
    let (edge, dir) = if towards_hi { (hi, -T::ONE) } else { (lo, T::ONE) };
    let mut w = step;
    for _ in 0..REFINE {
        let half = w * T::HALF;
        let (a, b) = (edge + dir * w, edge + dir * half);
        if towards_hi {
            f(a, b);
        } else {
            f(b, a);
        }
        w = half;
    }
    if towards_hi {
        f(edge - w, edge);
    } else {
        f(edge, edge + w);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::{Lambert, Minnaert};
    use crate::tolerance::{F64_REFORMULATION_REL, MINNAERT_QUADRATURE_REL};

    /// A panel count is refused outside its range (65,535 ran for an hour per incidence;
    /// 10^6 did not fit the type and overflowed in the Python package).
    #[test]
    fn panel_counts_are_bounded() {
        let (lo, hi) = (AlbedoRule::MIN_PANELS, AlbedoRule::MAX_PANELS);
        for ok in [lo, AlbedoRule::DEFAULT.panels, hi] {
            assert_eq!(AlbedoRule::new(u64::from(ok)), Ok(AlbedoRule { panels: ok }));
        }
        for bad in [
            0,
            u64::from(lo) - 1,
            u64::from(hi) + 1,
            65_535,
            1_000_000,
            u64::MAX,
        ] {
            assert_eq!(AlbedoRule::new(bad), Err(PanelsError { panels: bad }));
        }
        // The finest rule the fit report chooses (the narrowest microfacet peak) is within.
        let narrowest = crate::models::Ggx::<f64>::new(crate::models::GgxParams {
            ks: 0.5,
            alpha: f64::from(crate::ranges::GGX[1].min),
            f0: 1.0,
            kd: 0.0,
        })
        .unwrap();
        assert!(AlbedoRule::for_model(&crate::AnyModel::Ggx(narrowest)).panels <= hi);
    }

    #[test]
    fn lambert_albedo_is_rho0() {
        let m = Lambert::<f64>::from_params(&[0.7]).unwrap();
        for ti in [0.0, 0.5, 1.3] {
            let a = albedo(&m, ti, AlbedoRule::DEFAULT);
            assert!((a - 0.7).abs() < F64_REFORMULATION_REL, "{a}");
        }
    }

    #[test]
    fn minnaert_albedo_matches_closed_form() {
        for k in [1.0, 0.8, 0.5] {
            let m = Minnaert::<f64>::from_params(&[0.6, k]).unwrap();
            for ti in [0.0_f64, 0.7, 1.2] {
                let exact = m.albedo(libm::cos(ti));
                let q = albedo(&m, ti, AlbedoRule::DEFAULT);
                assert!(
                    ((q - exact) / exact).abs() < MINNAERT_QUADRATURE_REL,
                    "k={k} ti={ti}: {q} vs {exact}"
                );
            }
        }
    }
}
