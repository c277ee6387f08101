//! Parameter lists as people write them: `kb=0.2545,kr=21.8031,...` (`brdf eval --params`,
//! the `params` of a scene file's material).

use brdf_core::{AnyModel, Float, ModelKind, MAX_PARAMS};
use thiserror::Error;

/// Why a parameter list was refused.
#[derive(Clone, Debug, PartialEq, Error)]
#[non_exhaustive]
pub enum ParamsError {
    /// An item without `=`.
    #[error("parameter `{0}` is not of the form name=value")]
    Form(String),
    /// A name the model does not have.
    #[error("unknown parameter `{name}` for model {model} (expected {expected})")]
    Unknown {
        /// The name given.
        name: String,
        /// The model.
        model: &'static str,
        /// Its parameter names, comma-separated.
        expected: String,
    },
    /// A value that is not a number.
    #[error("parameter {name}: `{value}` is not a number")]
    NotANumber {
        /// Parameter name.
        name: String,
        /// The text given.
        value: String,
    },
    /// The same parameter twice.
    #[error("parameter {0} given twice")]
    Repeated(String),
    /// A parameter the model needs is missing.
    #[error("missing parameter {name} for model {model} (expected {expected})")]
    Missing {
        /// Parameter name.
        name: &'static str,
        /// The model.
        model: &'static str,
        /// Its parameter names, comma-separated.
        expected: String,
    },
}

/// Parses `kb=0.25,kr=21.8,...` into the parameter vector of `kind`, in the paper's order.
/// Every parameter must appear exactly once; unknown names are errors. Ranges are checked
/// where the model is built (`AnyModel::new`), not here.
pub fn parse_params(kind: ModelKind, text: &str) -> Result<[f64; MAX_PARAMS], ParamsError> {
    let names = kind.param_names();
    let expected = || names.join(", ");
    let mut values: [Option<f64>; MAX_PARAMS] = [None; MAX_PARAMS];
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (name, value) = item
            .split_once('=')
            .ok_or_else(|| ParamsError::Form(item.to_owned()))?;
        let (name, value) = (name.trim(), value.trim());
        let idx = names
            .iter()
            .position(|n| *n == name)
            .ok_or_else(|| ParamsError::Unknown {
                name: name.to_owned(),
                model: kind.name(),
                expected: expected(),
            })?;
        let v: f64 = value.parse().map_err(|_| ParamsError::NotANumber {
            name: name.to_owned(),
            value: value.to_owned(),
        })?;
        if values[idx].replace(v).is_some() {
            return Err(ParamsError::Repeated(name.to_owned()));
        }
    }
    let mut out = [0.0; MAX_PARAMS];
    for (i, name) in names.iter().enumerate() {
        out[i] = values[i].ok_or_else(|| ParamsError::Missing {
            name,
            model: kind.name(),
            expected: expected(),
        })?;
    }
    Ok(out)
}

/// The model `kind` in precision `T` from f64 parameters in the paper's order, each rounded
/// once to `T`: how `brdf eval`, the Python package and scene files build a model. The error
/// names the model and the parameter.
pub fn build<T: Float>(kind: ModelKind, params: &[f64; MAX_PARAMS]) -> Result<AnyModel<T>, String> {
    let mut v = [T::ZERO; MAX_PARAMS];
    for (dst, src) in v.iter_mut().zip(params) {
        *dst = T::from_f64(*src);
    }
    AnyModel::new(kind, &v[..kind.param_count()])
        .map_err(|e| format!("invalid parameters for model {}: {e}", kind.name()))
}

/// Why an evaluation returned `value`, not finite, for `kind`: the message `brdf eval` and
/// the Python package give at the row or index where it happens.
pub fn not_finite(value: impl std::fmt::Display, kind: ModelKind) -> String {
    format!(
        "the model is not finite here ({value}); {} diverges at this geometry \
         (five-parameter and Minnaert models grow without bound at grazing)",
        kind.name()
    )
}

/// Checks one direction of `brdf eval` in degrees (`theta_i`, `theta_r`, `phi`): finite,
/// zeniths in [0, 90] (90 is the horizon, where the models are defined; fitting data stops
/// below it, [`crate::data::Point::from_degrees`]) and `|phi|` at most
/// [`crate::data::PHI_LIMIT_DEG`]. The error names the column.
pub fn check_eval_degrees(deg: [f64; 3]) -> Result<(), String> {
    const NAMES: [&str; 3] = ["theta_i", "theta_r", "phi"];
    for (k, (&v, name)) in deg.iter().zip(NAMES).enumerate() {
        if !v.is_finite() {
            return Err(format!("column {name}: `{v}` is not finite"));
        }
        if k < 2 && !(0.0..=90.0).contains(&v) {
            return Err(format!(
                "column {name}: zenith {} deg is outside [0, 90]",
                brdf_core::Compact(v)
            ));
        }
        if k == 2 && v.abs() > crate::data::PHI_LIMIT_DEG {
            return Err(format!(
                "column {name}: azimuth {} deg is outside [-{lim}, {lim}]",
                brdf_core::Compact(v),
                lim = crate::data::PHI_LIMIT_DEG
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An azimuth of 1e20 deg was evaluated as 280 deg (its phase lost converting to
    /// radians), and 1e300 overflowed f32 and was blamed on the model.
    #[test]
    fn azimuths_beyond_two_turns_are_refused_by_every_reader() {
        for phi in [720.0, -720.0, 359.9, -180.0] {
            assert!(check_eval_degrees([30.0, 30.0, phi]).is_ok(), "{phi}");
        }
        for phi in [720.5, -721.0, 1e20, 1e300] {
            let e = check_eval_degrees([30.0, 30.0, phi]).unwrap_err();
            assert!(
                e.starts_with("column phi: azimuth") && e.contains("[-720, 720]"),
                "{e}"
            );
            let row = crate::data::RowDegrees {
                theta_i: 30.0,
                theta_r: 30.0,
                phi,
                brdf: 0.1,
                sigma: None,
                weight: None,
            };
            let e = crate::data::Point::from_degrees(row, false, 7).unwrap_err();
            assert_eq!(e.column, "phi", "{e}");
        }
    }

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
