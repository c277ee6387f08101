//! Lambertian reflector.

use crate::error::ParamError;
use crate::float::Float;
use crate::geometry::Geometry;
use crate::model::{check_count, params_array, Brdf, Model, ModelKind, MAX_PARAMS};
use crate::ranges::LAMBERT;

/// Parameters of the Lambertian reflector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LambertParams<T> {
    /// Directional-hemispherical reflectance (albedo), in `[0, 100]`.
    pub rho0: T,
}

/// Lambertian BRDF, in 1/sr: `f_r = rho0 / pi` above the horizon. Its albedo is `rho0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert<T> {
    params: LambertParams<T>,
    value: T,
}

impl<T: Float> Lambert<T> {
    /// Validates `params` (`rho0` in `[0, 100]`; [`crate::ranges::LAMBERT`]).
    pub fn new(params: LambertParams<T>) -> Result<Self, ParamError> {
        LAMBERT[0].check(params.rho0)?;
        Ok(Lambert {
            params,
            value: params.rho0 * T::FRAC_1_PI,
        })
    }

    /// The parameters this model was built from.
    pub fn params(&self) -> LambertParams<T> {
        self.params
    }
}

impl<T: Float> Brdf<T> for Lambert<T> {
    #[inline]
    fn eval(&self, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return v;
        }
        self.value
    }
}

impl<T: Float> Model<T> for Lambert<T> {
    const KIND: ModelKind = ModelKind::Lambert;
    const LINEAR: &'static [usize] = &[0];

    fn from_params(values: &[T]) -> Result<Self, ParamError> {
        check_count(values.len(), 1)?;
        Self::new(LambertParams { rho0: values[0] })
    }

    fn to_params(&self) -> [T; MAX_PARAMS] {
        params_array(&[self.params.rho0])
    }

    fn energy_bound(&self) -> Option<T> {
        Some(self.params.rho0)
    }
}
