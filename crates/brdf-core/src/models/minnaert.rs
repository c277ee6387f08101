//! Minnaert model, eq. 2.

use crate::error::ParamError;
use crate::float::Float;
use crate::geometry::Geometry;
use crate::model::{check_count, params_array, Brdf, Model, ModelKind, MAX_PARAMS};
use crate::ranges::MINNAERT;

/// Parameters of the Minnaert model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MinnaertParams<T> {
    /// Albedo-like scale, in `[0, 100]`.
    pub rho0: T,
    /// Limb-darkening exponent, `0 < k <= 1` (`k = 1` is Lambert).
    pub k: T,
}

/// Minnaert BRDF (eq. 2), in 1/sr: `f_r = rho0/pi (cos ti cos tr)^(k - 1)`.
///
/// Reciprocal. For `k < 1` it grows without bound at grazing angles, and so does its
/// directional-hemispherical reflectance, `2 rho0 cos(ti)^(k-1) / (k + 1)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Minnaert<T> {
    params: MinnaertParams<T>,
    scale: T,
    exponent: T,
}

impl<T: Float> Minnaert<T> {
    /// Validates `params` (`rho0` in `[0, 100]`, `0 < k <= 1`; [`crate::ranges::MINNAERT`]).
    pub fn new(params: MinnaertParams<T>) -> Result<Self, ParamError> {
        MINNAERT[0].check(params.rho0)?;
        MINNAERT[1].check(params.k)?;
        Ok(Minnaert {
            params,
            scale: params.rho0 * T::FRAC_1_PI,
            exponent: params.k - T::ONE,
        })
    }

    /// The parameters this model was built from.
    pub fn params(&self) -> MinnaertParams<T> {
        self.params
    }

    /// Exact directional-hemispherical reflectance at `cos theta_i`:
    /// `2 rho0 cos(ti)^(k-1) / (k + 1)`.
    pub fn albedo(&self, cos_theta_i: T) -> T {
        if cos_theta_i <= T::ZERO {
            return T::ZERO;
        }
        T::TWO * self.params.rho0 * cos_theta_i.powf(self.exponent) / (self.params.k + T::ONE)
    }
}

impl<T: Float> Brdf<T> for Minnaert<T> {
    #[inline]
    fn eval(&self, g: &Geometry<T>) -> T {
        if let Some(v) = g.outside() {
            return v;
        }
        self.scale * (g.cos_theta_i() * g.cos_theta_r()).powf(self.exponent)
    }
}

impl<T: Float> Model<T> for Minnaert<T> {
    const KIND: ModelKind = ModelKind::Minnaert;
    const LINEAR: &'static [usize] = &[0];

    fn from_params(values: &[T]) -> Result<Self, ParamError> {
        check_count(values.len(), 2)?;
        Self::new(MinnaertParams {
            rho0: values[0],
            k: values[1],
        })
    }

    fn to_params(&self) -> [T; MAX_PARAMS] {
        params_array(&[self.params.rho0, self.params.k])
    }

    /// `rho0` for `k = 1` (Lambert); none for `k < 1` (unbounded at grazing).
    fn energy_bound(&self) -> Option<T> {
        if self.params.k == T::ONE {
            Some(self.params.rho0)
        } else {
            None
        }
    }
}
