//! Parsing `--model NAME --params name=value,...` into a validated model.

use anyhow::{anyhow, bail, Result};
use brdf_core::{AnyModel, Float, ModelKind, MAX_PARAMS};

/// Parses a model name (`six`, `six-cos2`, `five`, `minnaert`, `lambert`).
pub fn parse_kind(name: &str) -> Result<ModelKind, String> {
    ModelKind::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = ModelKind::ALL.iter().map(|k| k.name()).collect();
        format!("unknown model `{name}` (expected one of: {})", names.join(", "))
    })
}

/// Parses `kb=0.25,kr=21.8,...` into the parameter vector of `kind`, in the paper's order.
/// Every parameter must appear exactly once; unknown names are errors.
pub fn parse_params(kind: ModelKind, text: &str) -> Result<[f64; MAX_PARAMS]> {
    let names = kind.param_names();
    let mut values: [Option<f64>; MAX_PARAMS] = [None; MAX_PARAMS];
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (name, value) = item
            .split_once('=')
            .ok_or_else(|| anyhow!("parameter `{item}` is not of the form name=value"))?;
        let (name, value) = (name.trim(), value.trim());
        let idx = names.iter().position(|n| *n == name).ok_or_else(|| {
            anyhow!(
                "unknown parameter `{name}` for model {} (expected {})",
                kind.name(),
                names.join(", ")
            )
        })?;
        let v: f64 = value
            .parse()
            .map_err(|_| anyhow!("parameter {name}: `{value}` is not a number"))?;
        if values[idx].replace(v).is_some() {
            bail!("parameter {name} given twice");
        }
    }
    let mut out = [0.0; MAX_PARAMS];
    for (i, name) in names.iter().enumerate() {
        out[i] = values[i].ok_or_else(|| {
            anyhow!(
                "missing parameter {name} for model {} (expected {})",
                kind.name(),
                names.join(", ")
            )
        })?;
    }
    Ok(out)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_in_any_order_and_rejects_bad_lists() {
        let p = parse_params(ModelKind::Minnaert, "k=0.5, rho0=0.3").unwrap();
        assert_eq!(&p[..2], &[0.3, 0.5]);
        let err = |t: &str| parse_params(ModelKind::Minnaert, t).unwrap_err().to_string();
        assert!(err("rho0=0.3").contains("missing parameter k"));
        assert!(err("rho0=0.3,k=0.5,kb=1").contains("unknown parameter `kb`"));
        assert!(err("rho0=0.3,k=x").contains("`x` is not a number"));
        assert!(err("rho0=0.3,k=0.5,k=0.6").contains("given twice"));
        assert!(err("rho0").contains("name=value"));
    }
}
