//! The common model interface: evaluation ([`Brdf`]), parameter vectors ([`Model`]) and
//! run-time dispatch over the family ([`ModelKind`], [`AnyModel`]).

use crate::error::{DomainError, ParamError};
use crate::float::Float;
use crate::geometry::Geometry;
use crate::models::{FiveParam, Ggx, Lambert, Minnaert, SixParam, SixParamCos2};

/// Largest parameter count of any model in the family.
pub const MAX_PARAMS: usize = 6;

/// Most factors, over all linear terms of a model, that [`Model::TERM_FACTORS`] may declare
/// (the annealer keeps two buffers of one value per sample for each).
pub const MAX_TERM_FACTORS: usize = 4;

/// A bidirectional reflectance distribution function `f_r` in 1/sr.
///
/// Implementors provide [`Brdf::eval`] on a precomputed [`Geometry`]; the other methods
/// build the geometry first. Evaluation never panics. Directions at or below the horizon
/// (`cos theta <= 0`) give 0; NaN input gives NaN (use the `try_` methods to reject it).
pub trait Brdf<T: Float> {
    /// `f_r` in 1/sr for a precomputed geometry.
    fn eval(&self, g: &Geometry<T>) -> T;

    /// `f_r` from `theta_i`, `theta_r`, `phi` in radians (canonical convention).
    #[inline]
    fn eval_angles(&self, theta_i: T, theta_r: T, phi: T) -> T {
        self.eval(&Geometry::from_angles(theta_i, theta_r, phi))
    }

    /// `f_r` from `cos theta_i`, `cos theta_r`, `cos phi` (no trigonometric call).
    #[inline]
    fn eval_cosines(&self, cos_theta_i: T, cos_theta_r: T, cos_phi: T) -> T {
        self.eval(&Geometry::from_cosines(cos_theta_i, cos_theta_r, cos_phi))
    }

    /// `f_r` from unit vectors towards source and receiver (`z` = surface normal).
    #[inline]
    fn eval_vectors(&self, wi: [T; 3], wr: [T; 3]) -> T {
        self.eval(&Geometry::from_vectors(wi, wr))
    }

    /// Checked [`Brdf::eval_angles`]: rejects non-finite input and zeniths outside `[0, pi]`.
    fn try_eval_angles(&self, theta_i: T, theta_r: T, phi: T) -> Result<T, DomainError> {
        Geometry::try_from_angles(theta_i, theta_r, phi).map(|g| self.eval(&g))
    }

    /// Checked [`Brdf::eval_cosines`]: rejects non-finite input and cosines outside `[-1, 1]`.
    fn try_eval_cosines(&self, cos_theta_i: T, cos_theta_r: T, cos_phi: T) -> Result<T, DomainError> {
        Geometry::try_from_cosines(cos_theta_i, cos_theta_r, cos_phi).map(|g| self.eval(&g))
    }

    /// Checked [`Brdf::eval_vectors`]: rejects non-finite and non-unit vectors.
    fn try_eval_vectors(&self, wi: [T; 3], wr: [T; 3]) -> Result<T, DomainError> {
        Geometry::try_from_vectors(wi, wr).map(|g| self.eval(&g))
    }
}

/// A model of the family with a parameter vector in the paper's order.
pub trait Model<T: Float>: Brdf<T> + Sized {
    /// Which member of the family this is.
    const KIND: ModelKind;

    /// Indices of parameters the model is linear in (a weight times a parameter-free
    /// shape), e.g. `kb` and `kd` of the six-parameter model. Fitters solve these exactly.
    const LINEAR: &'static [usize] = &[];

    /// How many factors the term weighted by each `LINEAR` parameter is the product of, in
    /// the annealer's caches (at most [`MAX_TERM_FACTORS`] in all). Default: one per term,
    /// the term itself.
    const TERM_FACTORS: &'static [usize] = &[1, 1];

    /// Whether factor `factor` of the term weighted by `LINEAR[term]` changes with the
    /// nonlinear parameter `param` (paper order). After a move of one parameter the annealer
    /// re-evaluates only the factors that change. Default: every factor changes with every
    /// parameter.
    fn factor_uses(term: usize, factor: usize, param: usize) -> bool {
        let _ = (term, factor, param);
        true
    }

    /// Factor `factor` of the term weighted by `LINEAR[term]`, for a model whose linear
    /// weights are 1 for that term and 0 for the others (the annealer's basis models). The
    /// product of a term's factors, left to right, is bit for bit what [`Brdf::eval`]
    /// returns for such a model. Default: [`Brdf::eval`] (one factor).
    fn eval_factor(&self, term: usize, factor: usize, g: &Geometry<T>) -> T {
        let _ = (term, factor);
        self.eval(g)
    }

    /// Builds the model from `KIND.param_names().len()` values in that order, validating
    /// each (see each model's constructor for the ranges).
    fn from_params(values: &[T]) -> Result<Self, ParamError>;

    /// The parameter vector in the paper's order; entries past the count are zero.
    fn to_params(&self) -> [T; MAX_PARAMS];

    /// Sufficient energy bound: an upper bound on the directional-hemispherical reflectance
    /// at every incidence, if the model has one (`kb + kd` for the six-parameter model).
    fn energy_bound(&self) -> Option<T>;
}

/// The members of the model family, for run-time selection (CLI, wire formats).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ModelKind {
    /// Six-parameter model, eq. 3 (canonical).
    Six,
    /// Six-parameter model with the `cos^2(alpha)` denominator of eq. 4 (a variant).
    SixCos2,
    /// Five-parameter model, eq. 1, with the V-groove Torrance–Sparrow shadowing factor.
    Five,
    /// Minnaert model, eq. 2.
    Minnaert,
    /// Microfacet model: GGX distribution, height-correlated Smith masking, Schlick's Fresnel
    /// and a Lambertian term (the glossy rung; [`Ggx`]).
    Ggx,
    /// Lambertian reflector.
    Lambert,
}

impl ModelKind {
    /// Every member, simplest last.
    pub const ALL: [ModelKind; 6] = [
        ModelKind::Six,
        ModelKind::SixCos2,
        ModelKind::Five,
        ModelKind::Ggx,
        ModelKind::Minnaert,
        ModelKind::Lambert,
    ];

    /// The model ladder `brdf select` climbs, simplest first: Lambert (1 parameter), Minnaert
    /// (2), microfacet (4), five-parameter (5), six-parameter (6) and its cos² variant (6).
    pub const LADDER: [ModelKind; 6] = [
        ModelKind::Lambert,
        ModelKind::Minnaert,
        ModelKind::Ggx,
        ModelKind::Five,
        ModelKind::Six,
        ModelKind::SixCos2,
    ];

    /// Short name used on the command line and in files.
    pub const fn name(self) -> &'static str {
        match self {
            ModelKind::Six => "six",
            ModelKind::SixCos2 => "six-cos2",
            ModelKind::Five => "five",
            ModelKind::Minnaert => "minnaert",
            ModelKind::Ggx => "ggx",
            ModelKind::Lambert => "lambert",
        }
    }

    /// Parameter names in the paper's order.
    pub const fn param_names(self) -> &'static [&'static str] {
        match self {
            ModelKind::Six | ModelKind::SixCos2 => &["kb", "kr", "b", "a", "kd", "c"],
            ModelKind::Five => &["kb", "kr", "b", "a", "kd"],
            ModelKind::Minnaert => &["rho0", "k"],
            ModelKind::Ggx => &["ks", "alpha", "f0", "kd"],
            ModelKind::Lambert => &["rho0"],
        }
    }

    /// Indices (in [`ModelKind::param_names`] order) of the parameters the model is linear
    /// in, [`Model::LINEAR`]: the weights, which scale with the readings' unit (`kb`, `kd`;
    /// `rho0`; `ks`, `kd`). The five-parameter `kd` is not one: it is the diffuse part's
    /// ratio inside `kb`, and the same in any unit. The one place this is said: the embedded
    /// engine scales these, the energy check scales them into range, the fitter searches the
    /// others.
    pub const fn linear_params(self) -> &'static [usize] {
        use crate::{FiveParam, Ggx, Lambert, Minnaert, SixParam, SixParamCos2};
        match self {
            ModelKind::Six => <SixParam<f64> as Model<f64>>::LINEAR,
            ModelKind::SixCos2 => <SixParamCos2<f64> as Model<f64>>::LINEAR,
            ModelKind::Five => <FiveParam<f64> as Model<f64>>::LINEAR,
            ModelKind::Minnaert => <Minnaert<f64> as Model<f64>>::LINEAR,
            ModelKind::Ggx => <Ggx<f64> as Model<f64>>::LINEAR,
            ModelKind::Lambert => <Lambert<f64> as Model<f64>>::LINEAR,
        }
    }

    /// Number of parameters.
    pub const fn param_count(self) -> usize {
        self.param_names().len()
    }

    /// Whether `f(i, r) = f(r, i)` holds for every parameter set.
    pub const fn is_reciprocal(self) -> bool {
        !matches!(self, ModelKind::Five)
    }
}

impl crate::names::Named for ModelKind {
    const WHAT: &'static str = "model";
    const ALL: &'static [ModelKind] = &ModelKind::ALL;
    fn name(self) -> &'static str {
        ModelKind::name(self)
    }
}

crate::named_str!(ModelKind);

/// Any model of the family, chosen at run time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnyModel<T> {
    /// See [`SixParam`].
    Six(SixParam<T>),
    /// See [`SixParamCos2`].
    SixCos2(SixParamCos2<T>),
    /// See [`FiveParam`].
    Five(FiveParam<T>),
    /// See [`Minnaert`].
    Minnaert(Minnaert<T>),
    /// See [`Ggx`].
    Ggx(Ggx<T>),
    /// See [`Lambert`].
    Lambert(Lambert<T>),
}

macro_rules! dispatch {
    ($self:expr, $m:ident => $e:expr) => {
        match $self {
            AnyModel::Six($m) => $e,
            AnyModel::SixCos2($m) => $e,
            AnyModel::Five($m) => $e,
            AnyModel::Minnaert($m) => $e,
            AnyModel::Ggx($m) => $e,
            AnyModel::Lambert($m) => $e,
        }
    };
}

impl<T: Float> AnyModel<T> {
    /// Builds the model `kind` from its parameter vector (paper order), validated.
    pub fn new(kind: ModelKind, values: &[T]) -> Result<Self, ParamError> {
        Ok(match kind {
            ModelKind::Six => AnyModel::Six(SixParam::from_params(values)?),
            ModelKind::SixCos2 => AnyModel::SixCos2(SixParamCos2::from_params(values)?),
            ModelKind::Five => AnyModel::Five(FiveParam::from_params(values)?),
            ModelKind::Minnaert => AnyModel::Minnaert(Minnaert::from_params(values)?),
            ModelKind::Ggx => AnyModel::Ggx(Ggx::from_params(values)?),
            ModelKind::Lambert => AnyModel::Lambert(Lambert::from_params(values)?),
        })
    }

    /// Which member this is.
    pub fn kind(&self) -> ModelKind {
        match self {
            AnyModel::Six(_) => ModelKind::Six,
            AnyModel::SixCos2(_) => ModelKind::SixCos2,
            AnyModel::Five(_) => ModelKind::Five,
            AnyModel::Minnaert(_) => ModelKind::Minnaert,
            AnyModel::Ggx(_) => ModelKind::Ggx,
            AnyModel::Lambert(_) => ModelKind::Lambert,
        }
    }

    /// The parameter vector (paper order); entries past the count are zero.
    pub fn to_params(&self) -> [T; MAX_PARAMS] {
        dispatch!(self, m => m.to_params())
    }

    /// Helmholtz reciprocity: `f(i, r) = f(r, i)` for every pair of directions. Every member
    /// but the five-parameter model (its `kd / cos ti` term) is reciprocal.
    pub fn reciprocal(&self) -> bool {
        !matches!(self, AnyModel::Five(_))
    }

    /// The directional-hemispherical reflectance (the energy reflected) stays bounded as the
    /// incidence approaches the horizon. Not so for the five-parameter model (`kb kd / cos ti`),
    /// Minnaert with `k < 1` (`rho0 (cos ti cos tr)^(k - 1)`) and the six-parameter models with
    /// `c < 0` (`kd (cos ti cos tr)^c`), whose values and albedos both grow without bound there
    /// — unless that term's weight is 0 (`kb` or `kd`, `rho0`, `kd`): a term that weighs
    /// nothing diverges nowhere, and the rest of each model is bounded. The microfacet model's
    /// value is unbounded only at the grazing mirror direction, as a mirror's is, while its
    /// albedo stays at most `ks + kd` ([`Ggx`]): bounded.
    pub fn bounded_at_grazing(&self) -> bool {
        let p = self.to_params();
        match self {
            AnyModel::Five(_) => p[0] == T::ZERO || p[4] == T::ZERO,
            AnyModel::Minnaert(_) => p[1] >= T::ONE || p[0] == T::ZERO,
            AnyModel::Six(_) | AnyModel::SixCos2(_) => p[5] >= T::ZERO || p[4] == T::ZERO,
            AnyModel::Ggx(_) | AnyModel::Lambert(_) => true,
        }
    }

    /// See [`Model::energy_bound`].
    pub fn energy_bound(&self) -> Option<T> {
        dispatch!(self, m => m.energy_bound())
    }
}

impl<T: Float> Brdf<T> for AnyModel<T> {
    #[inline]
    fn eval(&self, g: &Geometry<T>) -> T {
        dispatch!(self, m => m.eval(g))
    }
}

/// Validation helpers shared by the model constructors.
pub(crate) fn check_count(values_len: usize, expected: usize) -> Result<(), ParamError> {
    if values_len != expected {
        return Err(ParamError::WrongCount {
            expected,
            got: values_len,
        });
    }
    Ok(())
}

pub(crate) fn params_array<T: Float>(values: &[T]) -> [T; MAX_PARAMS] {
    let mut out = [T::ZERO; MAX_PARAMS];
    out[..values.len()].copy_from_slice(values);
    out
}
