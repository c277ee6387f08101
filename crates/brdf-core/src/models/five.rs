//! Five-parameter model (Cao et al. 2008; Zhang et al. 2010), eq. 1 — the baseline the
//! six-parameter model replaced.

use super::{facet, Lobe};
use crate::error::ParamError;
use crate::float::Float;
use crate::geometry::Geometry;
use crate::model::{check_count, params_array, Brdf, Model, ModelKind, MAX_PARAMS};
use crate::ranges::FIVE;

/// Parameters of the five-parameter model, named as in the paper; valid ranges in
/// [`crate::ranges`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiveParams<T> {
    /// Overall weight, in `[0, 10000]`.
    pub kb: T,
    /// Facet shape parameter, in `[1/1024, 1024]`.
    pub kr: T,
    /// Lobe steepness, in `[-1000, 1000]`, used as `|b|` (negative in the papers).
    pub b: T,
    /// Lobe exponent, in `(0, 10]`.
    pub a: T,
    /// Diffuse weight (inside `kb`), in `[0, 100]`.
    pub kd: T,
}

/// Five-parameter BRDF (eq. 1), in 1/sr:
///
/// ```text
/// f_r = kb * [ kr^2 cos(alpha) / (1 + (kr^2 - 1) cos(alpha)) * exp(-|b| (1 - cos(gamma))^a)
///              * G / (cos ti cos tr)  +  kd / cos ti ]
/// G = min(1, 2 cos(alpha) cos(tr) / cos(gamma), 2 cos(alpha) cos(ti) / cos(gamma))
/// ```
///
/// `G` is the V-groove Torrance–Sparrow shadowing/masking factor (docs/model.md default). The
/// model is **not reciprocal** (`kd / cos ti`) and **diverges at grazing incidence** like
/// `1 / cos ti`; it has no energy bound. Kept as the baseline the six-parameter model
/// improved on, and so that those failures can be shown.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FiveParam<T> {
    params: FiveParams<T>,
    kr2: T,
    lobe: Lobe<T>,
}

impl<T: Float> FiveParam<T> {
    /// Validates `params` and precomputes constants.
    pub fn new(params: FiveParams<T>) -> Result<Self, ParamError> {
        let p = &params;
        for (range, v) in FIVE.iter().zip([p.kb, p.kr, p.b, p.a, p.kd]) {
            range.check(v)?;
        }
        Ok(FiveParam {
            params,
            kr2: params.kr * params.kr,
            lobe: Lobe::new(params.b, params.a),
        })
    }

    /// The parameters this model was built from.
    pub fn params(&self) -> FiveParams<T> {
        self.params
    }

    /// V-groove shadowing/masking factor `G` in `[0, 1]`.
    #[inline]
    pub fn shadowing(g: &Geometry<T>) -> T {
        let k = T::TWO * g.cos_alpha() / g.cos_gamma();
        T::ONE.min(k * g.cos_theta_r()).min(k * g.cos_theta_i())
    }
}

impl<T: Float> Brdf<T> for FiveParam<T> {
    #[inline]
    fn eval(&self, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return v;
        }
        let (mi, mr) = (g.cos_theta_i(), g.cos_theta_r());
        let spec = facet(self.kr2, g) * self.lobe.eval(g) * Self::shadowing(g) / (mi * mr);
        self.params.kb * (spec + self.params.kd / mi)
    }
}

impl<T: Float> Model<T> for FiveParam<T> {
    const KIND: ModelKind = ModelKind::Five;
    const LINEAR: &'static [usize] = &[0];

    fn from_params(values: &[T]) -> Result<Self, ParamError> {
        check_count(values.len(), 5)?;
        Self::new(FiveParams {
            kb: values[0],
            kr: values[1],
            b: values[2],
            a: values[3],
            kd: values[4],
        })
    }

    fn to_params(&self) -> [T; MAX_PARAMS] {
        let p = self.params;
        params_array(&[p.kb, p.kr, p.b, p.a, p.kd])
    }

    /// None: the model diverges at grazing incidence.
    fn energy_bound(&self) -> Option<T> {
        None
    }
}
