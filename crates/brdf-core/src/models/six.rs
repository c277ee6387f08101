//! Six-parameter model of Yang, Wu and Cao (2012), eq. 3 — the project's canonical model.

use super::{facet, Lobe};
use crate::error::ParamError;
use crate::float::Float;
use crate::geometry::Geometry;
use crate::model::{check_count, params_array, Brdf, Model, ModelKind, MAX_PARAMS};
use crate::ranges::SIX;

/// Parameters of the six-parameter model, named as in the paper; valid ranges in
/// [`crate::ranges`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SixParams<T> {
    /// Specular (facet) weight, in `[0, 10000]`.
    pub kb: T,
    /// Facet shape parameter, in `[1/1024, 1024]` (beyond, the facet term is narrower than
    /// f32 resolves, or 1 to f32 precision).
    pub kr: T,
    /// Lobe steepness, in `[-1000, 1000]`; used as `|b|` (the paper prints it negative).
    pub b: T,
    /// Lobe exponent, in `(0, 10]`.
    pub a: T,
    /// Diffuse weight, in `[0, 100]`.
    pub kd: T,
    /// Diffuse (Minnaert-like) exponent, in `(-1, 10]`. With `c >= 0` the diffuse term darkens
    /// towards grazing and `kb + kd` bounds the albedo; with `-1 < c < 0` it brightens
    /// towards grazing as Minnaert's `k - 1` does (unbounded at the horizon), and only
    /// quadrature can check energy.
    pub c: T,
}

impl SixParams<f32> {
    /// The same parameters in f64 (exact widening): the host reference of a device material.
    pub fn widen(&self) -> SixParams<f64> {
        SixParams::from_array(self.as_array().map(f64::from))
    }
}

impl<T: Float> SixParams<T> {
    /// Checks every parameter against its range ([`crate::ranges::SIX`]).
    pub fn validate(&self) -> Result<(), ParamError> {
        for (range, v) in SIX.iter().zip(self.as_array()) {
            range.check(v)?;
        }
        Ok(())
    }

    /// From `[kb, kr, b, a, kd, c]` (paper order), unchecked (see [`SixParams::validate`]).
    pub const fn from_array(p: [T; 6]) -> Self {
        SixParams {
            kb: p[0],
            kr: p[1],
            b: p[2],
            a: p[3],
            kd: p[4],
            c: p[5],
        }
    }

    /// `[kb, kr, b, a, kd, c]`.
    pub fn as_array(&self) -> [T; 6] {
        [self.kb, self.kr, self.b, self.a, self.kd, self.c]
    }

    /// The per-material constants every six-parameter evaluation path uses:
    /// `(kb/(pi ln 2), kr^2, kd/pi)`.
    pub(crate) fn scales(&self) -> (T, T, T) {
        (
            self.kb / (T::PI * T::LN_2),
            self.kr * self.kr,
            self.kd * T::FRAC_1_PI,
        )
    }

    pub(crate) fn from_slice(values: &[T]) -> Result<Self, ParamError> {
        check_count(values.len(), 6)?;
        let p = SixParams {
            kb: values[0],
            kr: values[1],
            b: values[2],
            a: values[3],
            kd: values[4],
            c: values[5],
        };
        p.validate()?;
        Ok(p)
    }

    pub(crate) fn to_array(self) -> [T; MAX_PARAMS] {
        params_array(&[self.kb, self.kr, self.b, self.a, self.kd, self.c])
    }
}

/// Six-parameter BRDF (eq. 3), in 1/sr:
///
/// ```text
/// f_r = kb/(pi ln 2) * kr^2 cos(alpha) / (1 + (kr^2 - 1) cos(alpha))
///                    * exp(-|b| (1 - cos(gamma))^a) * ln(1 + cos ti cos tr)
///     + kd/pi * (cos ti cos tr)^c
/// ```
///
/// Reciprocal by construction (exactly, in floating point, with this crate's geometry).
/// Energy: the directional-hemispherical reflectance is at most `kb + kd` (eq. 5).
/// Per-material constants (`kb/(pi ln 2)`, `kr^2`, `|b|`, `kd/pi`) are computed once here.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SixParam<T> {
    params: SixParams<T>,
    spec_scale: T,
    kr2: T,
    lobe: Lobe<T>,
    diffuse_scale: T,
}

impl<T: Float> SixParam<T> {
    /// Validates `params` and precomputes the per-material constants.
    pub fn new(params: SixParams<T>) -> Result<Self, ParamError> {
        params.validate()?;
        let (spec_scale, kr2, diffuse_scale) = params.scales();
        Ok(SixParam {
            params,
            spec_scale,
            kr2,
            lobe: Lobe::new(params.b, params.a),
            diffuse_scale,
        })
    }

    /// The parameters this model was built from.
    pub fn params(&self) -> SixParams<T> {
        self.params
    }

    /// The specular (facet) term alone, 1/sr; 0 below the horizon.
    #[inline]
    pub fn specular(&self, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return v;
        }
        let m = g.cos_theta_i() * g.cos_theta_r();
        self.spec_scale * facet(self.kr2, g) * self.lobe.eval(g) * m.ln_1p()
    }

    /// The diffuse term alone, `kd/pi (cos ti cos tr)^c`, 1/sr; 0 below the horizon.
    #[inline]
    pub fn diffuse(&self, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return v;
        }
        self.diffuse_scale * (g.cos_theta_i() * g.cos_theta_r()).powf(self.params.c)
    }
}

impl<T: Float> Brdf<T> for SixParam<T> {
    #[inline]
    fn eval(&self, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return v;
        }
        let m = g.cos_theta_i() * g.cos_theta_r();
        let spec = self.spec_scale * facet(self.kr2, g) * self.lobe.eval(g) * m.ln_1p();
        spec + self.diffuse_scale * m.powf(self.params.c)
    }
}

impl<T: Float> Model<T> for SixParam<T> {
    const KIND: ModelKind = ModelKind::Six;
    const LINEAR: &'static [usize] = &[0, 4];

    /// The `kb` term (specular) is `spec_scale facet(kr)`, times the lobe (`b`, `a`), times
    /// `ln(1 + cos ti cos tr)` (no parameter); the `kd` term (diffuse) is one factor (`c`).
    const TERM_FACTORS: &'static [usize] = &[3, 1];

    fn factor_uses(term: usize, factor: usize, param: usize) -> bool {
        match (term, factor) {
            (0, 0) => param == 1,
            (0, 1) => param == 2 || param == 3,
            (0, _) => false,
            _ => param == 5,
        }
    }

    /// The factors of [`SixParam::specular`] and [`SixParam::diffuse`], in their order.
    fn eval_factor(&self, term: usize, factor: usize, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return if factor == 0 { v } else { T::ONE };
        }
        let m = g.cos_theta_i() * g.cos_theta_r();
        match (term, factor) {
            (0, 0) => self.spec_scale * facet(self.kr2, g),
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

    /// `kb + kd` when `c >= 0` (eq. 5 needs `(cos ti cos tr)^c <= 1`); none for `c < 0`.
    fn energy_bound(&self) -> Option<T> {
        (self.params.c >= T::ZERO).then_some(self.params.kb + self.params.kd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constructor_rejects_each_bad_parameter() {
        let good = [0.25_f64, 21.8, -27.6, 0.67, 0.37, 1.2];
        assert!(SixParam::from_params(&good).is_ok());
        let cases: [(usize, f64, &str); 6] = [
            (0, -0.1, "kb"),
            (1, 0.0, "kr"),
            (2, f64::NAN, "b"),
            (3, 0.0, "a"),
            (4, -1.0, "kd"),
            (5, -1.0, "c"),
        ];
        for (i, v, name) in cases {
            let mut p = good;
            p[i] = v;
            let err = SixParam::from_params(&p).unwrap_err();
            match err {
                ParamError::OutOfRange { name: n, .. } | ParamError::NotFinite { name: n } => {
                    assert_eq!(n, name)
                }
                other => panic!("unexpected {other:?}"),
            }
        }
        // -1 < c < 0 brightens towards grazing: valid, but without the kb + kd bound.
        let mut bright = good;
        bright[5] = -0.5;
        let m = SixParam::from_params(&bright).unwrap();
        assert_eq!(m.energy_bound(), None);
        let diffuse = |t: f64| m.diffuse(&Geometry::from_angles(t, t, 1.0));
        assert!(diffuse(1.5) > diffuse(0.1));
        assert_eq!(
            SixParam::<f32>::from_params(&[1.0; 5]).unwrap_err(),
            ParamError::WrongCount { expected: 6, got: 5 }
        );
    }

    #[test]
    fn terms_add_up_and_horizon_gives_zero() {
        let m = SixParam::from_params(&crate::TABLE1[0].1).unwrap();
        let g = Geometry::from_angles(0.3, 0.9, 2.0);
        assert_eq!(m.eval(&g), m.specular(&g) + m.diffuse(&g));
        assert_eq!(m.eval_angles(0.3, 1.7, 2.0), 0.0);
        assert_eq!(m.eval_cosines(-0.1, 0.5, 0.0), 0.0);
        assert!(m.eval_angles(f64::NAN, 0.5, 0.0).is_nan());
    }
}
