//! Typed errors of the core: no allocation, `Display` and `core::error::Error`.

use core::fmt;

/// A number for a message: plain decimal where that is short (`0.25`, `1200`), otherwise
/// scientific (`-1e-300`, `3e38`), so that no value prints as hundreds of digits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compact(pub f64);

impl fmt::Display for Compact {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-4..1e16).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// A parameter set a model cannot be built from.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum ParamError {
    /// The slice holds the wrong number of values for the model.
    WrongCount {
        /// Number of parameters the model takes.
        expected: usize,
        /// Number supplied.
        got: usize,
    },
    /// A parameter is NaN or infinite.
    NotFinite {
        /// Paper name of the parameter.
        name: &'static str,
    },
    /// A parameter lies outside the model's valid range.
    OutOfRange {
        /// Paper name of the parameter.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// The valid range, as text (e.g. `"> 0"`).
        range: &'static str,
    },
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamError::WrongCount { expected, got } => {
                write!(f, "expected {expected} parameters, got {got}")
            }
            ParamError::NotFinite { name } => write!(f, "parameter {name} is not finite"),
            ParamError::OutOfRange { name, value, range } => {
                write!(
                    f,
                    "parameter {name} = {} is out of range (must be {range})",
                    Compact(*value)
                )
            }
        }
    }
}

impl core::error::Error for ParamError {}

/// An input direction the checked evaluation API refuses.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum DomainError {
    /// An input is NaN or infinite.
    NotFinite {
        /// Which input (`"theta_i"`, `"cos_phi"`, `"wr"`, ...).
        what: &'static str,
    },
    /// An input lies outside its domain.
    OutOfRange {
        /// Which input.
        what: &'static str,
        /// The rejected value.
        value: f64,
        /// The accepted range, as text.
        range: &'static str,
    },
    /// A direction vector is not of unit length.
    NotUnitVector {
        /// Which vector (`"wi"` or `"wr"`).
        what: &'static str,
        /// Its squared norm.
        norm_squared: f64,
    },
}

impl fmt::Display for DomainError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DomainError::NotFinite { what } => write!(f, "{what} is not finite"),
            DomainError::OutOfRange { what, value, range } => {
                write!(f, "{what} = {} is outside {range}", Compact(*value))
            }
            DomainError::NotUnitVector { what, norm_squared } => {
                write!(
                    f,
                    "{what} is not a unit vector (|{what}|^2 = {})",
                    Compact(*norm_squared)
                )
            }
        }
    }
}

impl core::error::Error for DomainError {}
