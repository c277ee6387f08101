//! Names of the toolkit's choices — models here; residuals, losses, formats, channels and
//! engines in `brdf-fit` — with one spelling on the command line, in files, in Python and in
//! messages, and one message for a name that is none of them:
//! ``unknown model `sixx` (expected one of: six, six-cos2, five, ggx, minnaert, lambert)``.
//!
//! A type implements [`Named`] and derives `FromStr` and `Display` from it
//! ([`Named::parse_name`], [`Named::name`]); the CLI, the Python package and scene files parse
//! through `FromStr`, so their messages are the same text.

use core::fmt;

/// A closed set of named values.
pub trait Named: Copy + Sized + 'static {
    /// What the values are, in messages (`"model"`, `"residual"`).
    const WHAT: &'static str;
    /// Every value, in the order messages and help list them.
    const ALL: &'static [Self];

    /// The value's name.
    fn name(self) -> &'static str;

    /// Whether `given` names this value: its name, or another accepted spelling (an
    /// underscore for a hyphen, a capital letter) that a type documents.
    fn matches(self, given: &str) -> bool {
        self.name() == given
    }

    /// The value `given` names, or the "expected one of" error.
    fn parse_name(given: &str) -> Result<Self, UnknownName> {
        Self::ALL
            .iter()
            .copied()
            .find(|v| v.matches(given))
            .ok_or_else(|| UnknownName::new::<Self>(given))
    }
}

/// Bytes of an unknown name kept for the message; a longer one is cut (at a character
/// boundary) and marked with `...`, so the error stays heap-free and of fixed size.
pub const SHOWN_NAME_BYTES: usize = 40;

/// A name that is none of a [`Named`] type's values.
#[derive(Clone, Copy)]
pub struct UnknownName {
    what: &'static str,
    given: [u8; SHOWN_NAME_BYTES],
    len: usize,
    cut: bool,
    list: fn(&mut fmt::Formatter<'_>) -> fmt::Result,
}

impl UnknownName {
    /// The error for `given` among the values of `T`.
    pub fn new<T: Named>(given: &str) -> Self {
        let mut len = given.len().min(SHOWN_NAME_BYTES);
        while !given.is_char_boundary(len) {
            len -= 1;
        }
        let mut bytes = [0u8; SHOWN_NAME_BYTES];
        bytes[..len].copy_from_slice(&given.as_bytes()[..len]);
        UnknownName {
            what: T::WHAT,
            given: bytes,
            len,
            cut: len < given.len(),
            list: list::<T>,
        }
    }

    /// What was being named (`"model"`).
    pub fn what(&self) -> &'static str {
        self.what
    }

    /// The name given (cut to [`SHOWN_NAME_BYTES`]).
    pub fn given(&self) -> &str {
        // Cut at a character boundary of a `str`, so always valid.
        core::str::from_utf8(&self.given[..self.len]).unwrap_or("")
    }
}

fn list<T: Named>(f: &mut fmt::Formatter<'_>) -> fmt::Result {
    for (i, v) in T::ALL.iter().enumerate() {
        if i > 0 {
            f.write_str(", ")?;
        }
        f.write_str(v.name())?;
    }
    Ok(())
}

impl fmt::Display for UnknownName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown {} `{}", self.what, self.given())?;
        if self.cut {
            f.write_str("...")?;
        }
        f.write_str("` (expected one of: ")?;
        (self.list)(f)?;
        f.write_str(")")
    }
}

impl fmt::Debug for UnknownName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "UnknownName({self})")
    }
}

impl core::error::Error for UnknownName {}

/// Implements `FromStr` (through [`Named::parse_name`]) and `Display` (the name; width and
/// alignment flags apply) for a
/// [`Named`] type.
#[macro_export]
macro_rules! named_str {
    ($t:ty) => {
        impl ::core::str::FromStr for $t {
            type Err = $crate::names::UnknownName;
            fn from_str(s: &str) -> Result<Self, Self::Err> {
                <$t as $crate::names::Named>::parse_name(s)
            }
        }
        impl ::core::fmt::Display for $t {
            fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                f.pad($crate::names::Named::name(*self))
            }
        }
    };
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::ToString;

    use super::*;
    use crate::ModelKind;

    #[test]
    fn every_model_name_parses_back_and_others_list_the_names() {
        for k in ModelKind::ALL {
            assert_eq!(k.name().parse::<ModelKind>().unwrap(), k);
            assert_eq!(k.to_string(), k.name());
        }
        let e = "sixx".parse::<ModelKind>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown model `sixx` (expected one of: six, six-cos2, five, ggx, minnaert, lambert)"
        );
        assert_eq!(e.what(), "model");
        // Case matters for models: `Six` is not a model name.
        assert!("Six".parse::<ModelKind>().is_err());
    }

    #[test]
    fn a_long_or_multibyte_name_is_cut_at_a_character_boundary() {
        let long = "é".repeat(30); // 60 bytes
        let e = long.parse::<ModelKind>().unwrap_err();
        assert!(e.given().len() <= SHOWN_NAME_BYTES && e.given().len() % 2 == 0);
        assert!(e.to_string().contains("...` (expected one of:"), "{e}");
        let e = "".parse::<ModelKind>().unwrap_err();
        assert!(e.to_string().starts_with("unknown model `` (expected"), "{e}");
    }
}
