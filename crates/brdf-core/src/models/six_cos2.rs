//! The `cos^2(alpha)` variant of the six-parameter model (the paper's eq. 4 denominator).

use super::six::{SixParam, SixParams};
use super::Lobe;
use crate::error::ParamError;
use crate::float::Float;
use crate::geometry::Geometry;
use crate::model::{Brdf, Model, ModelKind, MAX_PARAMS};

/// Six-parameter BRDF with the facet term as printed in eq. 4, in 1/sr:
///
/// ```text
/// f_r = kb/(pi ln 2) * kr^2 cos(alpha) / (1 + (kr^2 - 1) cos^2(alpha))
///                    * exp(-|b| (1 - cos(gamma))^a) * ln(1 + cos ti cos tr)
///     + kd/pi * (cos ti cos tr)^c
/// ```
///
/// A named variant, never the default (docs/model.md, open point 1): for `kr > sqrt(2)` the facet
/// term exceeds 1 off the mirror direction and the `kb + kd` energy bound no longer holds,
/// so [`Model::energy_bound`] returns `None` there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SixParamCos2<T> {
    params: SixParams<T>,
    spec_scale: T,
    kr2: T,
    lobe: Lobe<T>,
    diffuse_scale: T,
}

impl<T: Float> SixParamCos2<T> {
    /// Validates `params` (same ranges as [`SixParams`]) and precomputes constants.
    pub fn new(params: SixParams<T>) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(SixParamCos2 {
            params,
            spec_scale: params.kb / (T::PI * T::LN_2),
            kr2: params.kr * params.kr,
            lobe: Lobe::new(params.b, params.a),
            diffuse_scale: params.kd * T::FRAC_1_PI,
        })
    }

    /// The parameters this model was built from.
    pub fn params(&self) -> SixParams<T> {
        self.params
    }
}

impl<T: Float> SixParamCos2<T> {
    /// The facet term `kr^2 cos(alpha) / (1 + (kr^2 - 1) cos^2(alpha))`.
    #[inline]
    fn facet(&self, g: &Geometry<T>) -> T {
        let ca = g.cos_alpha();
        // 1 + (kr^2 - 1) cos^2 = kr^2 cos^2 + (1 - cos)(1 + cos), without cancellation.
        self.kr2 * ca / (self.kr2 * ca * ca + g.one_minus_cos_alpha() * (T::ONE + ca))
    }
}

impl<T: Float> Brdf<T> for SixParamCos2<T> {
    #[inline]
    fn eval(&self, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return v;
        }
        let m = g.cos_theta_i() * g.cos_theta_r();
        let spec = self.spec_scale * self.facet(g) * self.lobe.eval(g) * m.ln_1p();
        spec + self.diffuse_scale * m.powf(self.params.c)
    }
}

impl<T: Float> Model<T> for SixParamCos2<T> {
    const KIND: ModelKind = ModelKind::SixCos2;
    const LINEAR: &'static [usize] = &[0, 4];

    /// As the six-parameter model: `spec_scale facet(kr)`, the lobe, `ln(1 + m)`; `kd`'s
    /// term one factor.
    const TERM_FACTORS: &'static [usize] = SixParam::<T>::TERM_FACTORS;

    fn factor_uses(term: usize, factor: usize, param: usize) -> bool {
        SixParam::<T>::factor_uses(term, factor, param)
    }

    fn eval_factor(&self, term: usize, factor: usize, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return if factor == 0 { v } else { T::ONE };
        }
        let m = g.cos_theta_i() * g.cos_theta_r();
        match (term, factor) {
            (0, 0) => self.spec_scale * self.facet(g),
            (0, 1) => self.lobe.eval(g),
            (0, _) => m.ln_1p(),
            _ => self.diffuse_scale * m.powf(self.params.c),
        }
    }

    fn from_params(values: &[T]) -> Result<Self, ParamError> {
        Self::new(SixParams::from_slice(values)?)
    }

    fn to_params(&self) -> [T; MAX_PARAMS] {
        self.params.to_array()
    }

    /// `kb + kd` while `kr <= sqrt(2)` (the facet term then peaks at the mirror direction
    /// with value 1); no bound otherwise.
    fn energy_bound(&self) -> Option<T> {
        if self.kr2 <= T::TWO && self.params.c >= T::ZERO {
            Some(self.params.kb + self.params.kd)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::SixParam;
    use crate::tolerance::F64_REFORMULATION_REL;

    #[test]
    fn equals_canonical_at_mirror_and_normal() {
        let p = crate::TABLE1[0].1; // khaki
        let six = SixParam::from_params(&p).unwrap();
        let cos2 = SixParamCos2::from_params(&p).unwrap();
        // cos(alpha) = 1 at the mirror direction: both denominators equal kr^2.
        let g = Geometry::from_angles(0.5, 0.5, core::f64::consts::PI);
        assert!((six.eval(&g) - cos2.eval(&g)).abs() < F64_REFORMULATION_REL * six.eval(&g));
        // Off the mirror they differ.
        let g = Geometry::from_angles(0.5, 0.9, 1.0);
        assert!((six.eval(&g) - cos2.eval(&g)).abs() > 1e-6);
    }

    #[test]
    fn facet_exceeds_one_for_large_kr() {
        // kr = 21.8: peak of kr^2 c/(1 + (kr^2-1) c^2) is at c = 1/sqrt(kr^2 - 1) with value
        // about kr/2, so the kb + kd bound is void.
        let m = SixParamCos2::from_params(&crate::TABLE1[0].1).unwrap();
        assert_eq!(m.energy_bound(), None);
        let m = SixParamCos2::from_params(&[0.2_f64, 1.2, -5.0, 0.7, 0.3, 1.0]).unwrap();
        assert_eq!(m.energy_bound(), Some(0.5));
    }
}
