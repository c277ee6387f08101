//! Microfacet model: GGX (Trowbridge–Reitz) distribution, height-correlated Smith
//! masking–shadowing, Schlick's Fresnel, and a Lambertian term — the glossy rung.

use crate::error::ParamError;
use crate::float::Float;
use crate::geometry::Geometry;
use crate::model::{check_count, params_array, Brdf, Model, ModelKind, MAX_PARAMS};
use crate::ranges::GGX;

/// Parameters of the microfacet model, in the order `[ks, alpha, f0, kd]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GgxParams<T> {
    /// Specular weight, in `[0, 10000]` (1 for a calibrated dielectric or metal).
    pub ks: T,
    /// GGX roughness (the distribution's width in slope), in `[1/1024, 4]`.
    pub alpha: T,
    /// Fresnel reflectance at normal incidence (Schlick), in `[0, 1]`.
    pub f0: T,
    /// Diffuse albedo, in `[0, 100]`.
    pub kd: T,
}

/// Microfacet BRDF, in 1/sr (Walter et al. 2007; Heitz 2014 for the masking):
///
/// ```text
/// f_r = ks F(cos theta_d) D(cos theta_h) V(cos ti, cos tr) + kd / pi
/// D = alpha^2 / (pi (alpha^2 cos^2 theta_h + sin^2 theta_h)^2)
/// V = 1 / (2 (cos tr S(cos ti) + cos ti S(cos tr))),  S(c) = sqrt(c^2 + alpha^2 (1 - c^2))
/// F = f0 + (1 - f0) (1 - cos theta_d)^5
/// ```
///
/// with `theta_h` the tilt of the half vector from the normal (`alpha` of the six-parameter
/// model) and `theta_d` the angle between the half vector and either direction (`gamma`).
/// `V` is the height-correlated Smith term `G2 / (4 cos ti cos tr)`.
///
/// Reciprocal by construction (`D`, `F` depend on the pair symmetrically, `V` is symmetric in
/// `ti`, `tr`). Conserves energy when `ks + kd <= 1`: with `F <= 1` the specular term's
/// directional-hemispherical reflectance is at most that of `D G2 / (4 cos ti cos tr)`, which is
/// at most `integral of D(h) G1(i) (i.h)/cos ti dh = 1` (`G2 <= G1`; the visible-normal
/// normalisation). Its **value** is unbounded only where both directions approach the
/// horizon together at the mirror direction (`V -> 1 / (2 alpha (cos ti + cos tr))`), as a
/// mirror's is; its energy stays bounded at every incidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx<T> {
    params: GgxParams<T>,
    alpha2: T,
    /// `ks alpha^2 / pi`.
    spec_scale: T,
    diffuse: T,
}

impl<T: Float> Ggx<T> {
    /// Validates `params` (ranges in [`crate::ranges::GGX`]) and precomputes constants.
    pub fn new(params: GgxParams<T>) -> Result<Self, ParamError> {
        for (r, v) in GGX.iter().zip([params.ks, params.alpha, params.f0, params.kd]) {
            r.check(v)?;
        }
        let alpha2 = params.alpha * params.alpha;
        Ok(Ggx {
            params,
            alpha2,
            spec_scale: params.ks * alpha2 * T::FRAC_1_PI,
            diffuse: params.kd * T::FRAC_1_PI,
        })
    }

    /// The parameters this model was built from.
    pub fn params(&self) -> GgxParams<T> {
        self.params
    }

    /// The specular term for `ks = 1`: `F D V`, in 1/sr, for both directions above the
    /// horizon. `V` grows without bound as both cosines approach 0 and overflows to infinity
    /// in f32 below about 1e-33; `F = 0` (`f0 = 0` at `theta_d = 0`) then gives 0, not NaN.
    #[inline]
    pub fn specular_shape(&self, g: &Geometry<T>) -> T {
        let (ci, cr) = (g.cos_theta_i(), g.cos_theta_r());
        let ch = g.cos_alpha();
        // alpha^2 cos^2 + sin^2 with sin^2 = (1 - cos)(1 + cos): no cancellation near the mirror.
        let den = self.alpha2 * ch * ch + g.one_minus_cos_alpha() * (T::ONE + ch);
        let s = |c: T| (c * c + self.alpha2 * (T::ONE - c) * (T::ONE + c)).sqrt();
        let v = T::ONE / (T::TWO * (cr * s(ci) + ci * s(cr)));
        let w = g.one_minus_cos_gamma();
        let w2 = w * w;
        let f = self.params.f0 + (T::ONE - self.params.f0) * (w2 * w2 * w);
        if f == T::ZERO {
            return T::ZERO;
        }
        self.alpha2 * T::FRAC_1_PI / (den * den) * v * f
    }
}

impl<T: Float> Brdf<T> for Ggx<T> {
    #[inline]
    fn eval(&self, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return v;
        }
        if self.params.ks == T::ZERO {
            // No specular term (and no `0 * inf` where V overflows).
            return self.diffuse;
        }
        self.params.ks * self.specular_shape(g) + self.diffuse
    }
}

impl<T: Float> Model<T> for Ggx<T> {
    const KIND: ModelKind = ModelKind::Ggx;
    const LINEAR: &'static [usize] = &[0, 3];

    fn from_params(values: &[T]) -> Result<Self, ParamError> {
        check_count(values.len(), 4)?;
        Self::new(GgxParams {
            ks: values[0],
            alpha: values[1],
            f0: values[2],
            kd: values[3],
        })
    }

    fn to_params(&self) -> [T; MAX_PARAMS] {
        params_array(&[self.params.ks, self.params.alpha, self.params.f0, self.params.kd])
    }

    /// `ks + kd` (module documentation).
    fn energy_bound(&self) -> Option<T> {
        Some(self.params.ks + self.params.kd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::checks::{albedo, AlbedoRule};
    use core::f64::consts::PI;

    fn model(ks: f64, alpha: f64, f0: f64, kd: f64) -> Ggx<f64> {
        Ggx::from_params(&[ks, alpha, f0, kd]).unwrap()
    }

    /// The half-vector form against a direct vector computation of the same textbook formula
    /// (`D` from `1 + (alpha^2 - 1) cos^2`, `G2` from Smith's `Lambda`).
    #[test]
    fn matches_the_textbook_formula() {
        for &(alpha, f0) in &[(0.05, 0.04), (0.3, 0.9), (1.0, 0.5), (2.5, 0.0)] {
            let m = model(1.3, alpha, f0, 0.2);
            for &(ti, tr, phi) in &[(0.1, 0.2, 3.0), (0.7, 0.7, PI), (1.2, 0.4, 2.0), (0.0, 1.4, 0.5)] {
                let wi = [ti.sin(), 0.0, ti.cos()];
                let wr = [tr.sin() * phi.cos(), tr.sin() * phi.sin(), tr.cos()];
                let h = [wi[0] + wr[0], wi[1] + wr[1], wi[2] + wr[2]];
                let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
                let ch = h[2] / n;
                let cd = (wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]) / n;
                let a2 = alpha * alpha;
                let d = a2 / (PI * (1.0 + (a2 - 1.0) * ch * ch).powi(2));
                let lambda = |c: f64| (-1.0 + (1.0 + a2 * (1.0 - c * c) / (c * c)).sqrt()) / 2.0;
                let g2 = 1.0 / (1.0 + lambda(wi[2]) + lambda(wr[2]));
                let f = f0 + (1.0 - f0) * (1.0 - cd).powi(5);
                let want = 1.3 * f * d * g2 / (4.0 * wi[2] * wr[2]) + 0.2 / PI;
                let got = m.eval_angles(ti, tr, phi);
                assert!(
                    ((got - want) / want).abs() < 1e-12,
                    "{alpha} {f0} {ti} {tr} {phi}: {got} vs {want}"
                );
            }
        }
    }

    /// Near the horizon V overflows f32; the value is then +inf (the device reports an error
    /// for it), never NaN, whatever the weights.
    #[test]
    fn grazing_gives_a_number_or_infinity_never_nan() {
        for p in [
            [1.0f32, 0.001, 0.0, 0.0],
            [0.0, 0.001, 0.0, 0.5],
            [1e4, 1.0 / 1024.0, 1.0, 100.0],
        ] {
            let m = Ggx::<f32>::from_params(&p).unwrap();
            for c in [1e-45f32, 1e-38, 1e-20, 1e-8, 1e-3] {
                for cos_phi in [1.0f32, -1.0, 0.0] {
                    let f = m.eval_cosines(c, c, cos_phi);
                    assert!(
                        !f.is_nan() && f >= 0.0,
                        "{p:?} at cos {c}, cos phi {cos_phi}: {f}"
                    );
                }
            }
        }
    }

    /// The energy check's rule for this model ([`AlbedoRule::for_model`]) resolves its mirror
    /// peak at grazing incidence however narrow: within 1e-4 of a 512-panel rule at 89°,
    /// where 8 panels err by 2.2% (`alpha = 0.01`) to 82% (1/1024).
    #[test]
    fn albedo_rule_resolves_narrow_microfacet_peaks() {
        for alpha in [0.01, 1.0 / 1024.0] {
            let m = model(1.0, alpha, 1.0, 0.0);
            let rule = AlbedoRule::for_model(&crate::AnyModel::Ggx(m));
            let ti = 89f64.to_radians();
            let a = albedo(&m, ti, rule);
            let fine = albedo(&m, ti, AlbedoRule { panels: 512 });
            assert!(
                (a / fine - 1.0).abs() < 1e-4,
                "alpha {alpha}: {a} vs {fine} ({rule:?})"
            );
            let coarse = albedo(&m, ti, AlbedoRule::DEFAULT);
            assert!(
                (coarse / fine - 1.0).abs() > 0.02,
                "alpha {alpha}: the default rule resolves it"
            );
        }
        assert_eq!(
            AlbedoRule::for_model(&crate::AnyModel::Ggx(model(1.0, 0.2, 1.0, 0.0))),
            AlbedoRule::DEFAULT
        );
    }

    #[test]
    fn reciprocal_and_zero_below_the_horizon() {
        let m = model(2.0, 0.2, 0.05, 0.3);
        for &(ti, tr, phi) in &[(0.1, 0.9, 1.0), (1.3, 0.2, 2.9), (0.5, 1.5, 0.1)] {
            assert_eq!(m.eval_angles(ti, tr, phi), m.eval_angles(tr, ti, phi));
        }
        assert_eq!(m.eval_angles(0.3, 1.7, 0.0), 0.0);
    }

    /// The energy bound holds: the albedo (8-panel rule, checked against 40 panels) never
    /// exceeds `ks + kd` at incidences to 89°, for smooth to very rough surfaces and `f0 = 1`
    /// (the largest Fresnel factor); smooth surfaces lose little (the single-scattering
    /// model's loss grows with roughness: `1 - ln 2` is left at `alpha = 1`).
    #[test]
    fn albedo_is_within_the_energy_bound() {
        for &alpha in &[0.02, 0.1, 0.5, 1.0, 4.0] {
            let m = model(1.0, alpha, 1.0, 0.0);
            for deg in [0.0_f64, 30.0, 60.0, 80.0, 89.0] {
                let a = albedo(&m, deg.to_radians(), AlbedoRule::DEFAULT);
                let fine = albedo(&m, deg.to_radians(), AlbedoRule { panels: 40 });
                assert!(
                    (a - fine).abs() <= 1e-3 * fine,
                    "alpha {alpha} at {deg}°: {a} vs {fine}"
                );
                assert!(a <= 1.0 + 1e-6, "alpha {alpha} at {deg}°: albedo {a}");
                if alpha <= 0.1 && deg <= 80.0 {
                    assert!(a > 0.89, "alpha {alpha} at {deg}°: albedo {a}");
                }
            }
        }
        // A closed form: at alpha = 1 (D = 1/pi) and normal incidence the albedo is 1 - ln 2.
        let a = albedo(&model(1.0, 1.0, 1.0, 0.0), 0.0, AlbedoRule::DEFAULT);
        assert!((a - (1.0 - core::f64::consts::LN_2)).abs() < 1e-12, "{a}");
    }
}
