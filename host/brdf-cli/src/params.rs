//! Parsing `--model NAME --params name=value,...` into a validated model.

use anyhow::{anyhow, Result};
use brdf_core::{AnyModel, Float, ModelKind, MAX_PARAMS};

/// Parses a model name (`six`, `six-cos2`, `five`, `ggx`, `minnaert`, `lambert`).
pub fn parse_kind(name: &str) -> Result<ModelKind, String> {
    crate::common::named(name)
}

/// Parses `kb=0.25,kr=21.8,...` into the parameter vector of `kind`, in the paper's order
/// (`brdf_fit::params::parse_params`).
pub fn parse_params(kind: ModelKind, text: &str) -> Result<[f64; MAX_PARAMS]> {
    Ok(brdf_fit::params::parse_params(kind, text)?)
}

/// Builds the model in precision `T` from f64 parameters (`brdf_fit::params::build`).
pub fn build<T: Float>(kind: ModelKind, params: &[f64; MAX_PARAMS]) -> Result<AnyModel<T>> {
    brdf_fit::params::build(kind, params).map_err(|e| anyhow!(e))
}
