//! Parsing `--model NAME --params name=value,...` into a validated model.

use anyhow::{anyhow, Result};
use brdf_core::{AnyModel, Float, ModelKind, MAX_PARAMS};

/// Parses a model name (`six`, `six-cos2`, `five`, `minnaert`, `lambert`).
pub fn parse_kind(name: &str) -> Result<ModelKind, String> {
    ModelKind::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = ModelKind::ALL.iter().map(|k| k.name()).collect();
        format!("unknown model `{name}` (expected one of: {})", names.join(", "))
    })
}

/// Parses `kb=0.25,kr=21.8,...` into the parameter vector of `kind`, in the paper's order
/// (`brdf_fit::params::parse_params`).
pub fn parse_params(kind: ModelKind, text: &str) -> Result<[f64; MAX_PARAMS]> {
    Ok(brdf_fit::params::parse_params(kind, text)?)
}

/// Builds the model in precision `T` from f64 parameters (each rounded once to `T`).
pub fn build<T: Float>(kind: ModelKind, params: &[f64; MAX_PARAMS]) -> Result<AnyModel<T>> {
    let mut v = [T::ZERO; MAX_PARAMS];
    for (dst, src) in v.iter_mut().zip(params) {
        *dst = T::from_f64(*src);
    }
    AnyModel::new(kind, &v[..kind.param_count()])
        .map_err(|e| anyhow!("invalid parameters for model {}: {e}", kind.name()))
}
