//! A fit as a user asks for it — by the names and numbers the CLI, the Python package and
//! scene files take — checked in one place into [`FitSettings`]: every range, every
//! combination an engine cannot honour, with one message each, whoever asked.

use std::ops::RangeInclusive;

use brdf_core::names::Named;
use brdf_core::ModelKind;
use thiserror::Error;

use crate::anneal::AnnealOptions;
use crate::batch::{Engine, FitSettings};
use crate::embedded::DEFAULT_BUDGET;
use crate::noise::FloorChoice;
use crate::problem::{Loss, LossKind, Residual};
use crate::spectral::BandShape;
use crate::FitOptions;

/// Which fitting engine, by name (`full`, `embedded`); [`Engine`] adds the embedded budget.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum EngineKind {
    /// Annealing chains polished by Levenberg–Marquardt, f64.
    #[default]
    Full,
    /// The on-sensor f32 annealer of brdf-core (relative residuals, least squares).
    Embedded,
}

impl Named for EngineKind {
    const WHAT: &'static str = "engine";
    const ALL: &'static [EngineKind] = &[EngineKind::Full, EngineKind::Embedded];
    fn name(self) -> &'static str {
        match self {
            EngineKind::Full => "full",
            EngineKind::Embedded => "embedded",
        }
    }
}

brdf_core::named_str!(EngineKind);

/// A whole-number option and its valid range.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Limit {
    /// The option's name (as Python spells it; the CLI adds `--` and hyphens).
    pub name: &'static str,
    /// Valid values.
    pub range: RangeInclusive<u64>,
}

impl Limit {
    /// `value` if it lies in the range, else the error naming the option and the range.
    pub fn check(&self, value: u64) -> Result<u64, OptionError> {
        if self.range.contains(&value) {
            Ok(value)
        } else {
            Err(OptionError::OutOfRange {
                name: self.name,
                value,
                lo: *self.range.start(),
                hi: *self.range.end(),
            })
        }
    }
}

/// Annealing chains, each polished (at least one; 64 already finds every optimum of the
/// bundled and held-out data, see the README).
pub const CHAINS: Limit = Limit {
    name: "chains",
    range: 1..=64,
};
/// Independent searches that must agree before a fit is called converged.
pub const AGREE: Limit = Limit {
    name: "agree",
    range: 1..=64,
};
/// Basin-hopping moves that must all fail to improve the best point.
pub const HOPS: Limit = Limit {
    name: "hops",
    range: 0..=64,
};
/// Cost evaluations per annealing chain (at least one; at most 1e8 keeps one fit under
/// minutes).
pub const ANNEAL_EVALS: Limit = Limit {
    name: "anneal_evals",
    range: 1..=100_000_000,
};
/// Evaluation budget of the embedded engine: above its 64-point screen, at most 1e7.
pub const BUDGET_EVALS: Limit = Limit {
    name: "budget_evals",
    range: 65..=10_000_000,
};

/// Why options cannot make a fit.
#[derive(Clone, Debug, PartialEq, Error)]
#[non_exhaustive]
pub enum OptionError {
    /// A whole-number option outside its range.
    #[error("{name} {value} is not in {lo}..={hi}")]
    OutOfRange {
        /// The option.
        name: &'static str,
        /// The value given.
        value: u64,
        /// Smallest valid value.
        lo: u64,
        /// Largest valid value.
        hi: u64,
    },
    /// The robust loss's scale is not in [`LOSS_SCALE`].
    #[error("loss_scale {} is not in [1e-100, 1e100] (a number greater than 0, in the residual's units)", brdf_core::Compact(*.0))]
    LossScale(f64),
    /// The embedded engine minimises relative least squares only.
    #[error(
        "the embedded engine fits relative residuals with the linear loss, no brightening and no noise floor; {0} is set"
    )]
    Embedded(String),
    /// The noise floor is neither 0 nor within a reading's magnitude.
    #[error("noise_floor {} is neither 0 nor within [1e-100, 1e100] 1/sr (a reading's magnitude)", brdf_core::Compact(*.0))]
    NoiseFloor(f64),
    /// More agreeing searches asked for than chains run.
    #[error("agree {agree} is more than chains {chains}: the fit could never converge")]
    AgreeAboveChains {
        /// Agreeing searches asked for.
        agree: usize,
        /// Chains that run.
        chains: usize,
    },
    /// An option the chosen engine or loss would ignore.
    #[error("{name} {applies}; it would be ignored")]
    Ignored {
        /// The option.
        name: &'static str,
        /// Where it applies.
        applies: &'static str,
    },
}

/// Every option of a fit by its user-facing name, as [`FitRequest::new`] gives them. An
/// option that applies to one engine or loss only is `None` unless given, so that giving it
/// where it would be ignored is an error ([`OptionError::Ignored`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FitRequest {
    /// The model.
    pub model: ModelKind,
    /// Seed of the search.
    pub seed: u64,
    /// Residual form.
    pub residual: Residual,
    /// Engine.
    pub engine: EngineKind,
    /// [`CHAINS`] (full engine; default [`FitOptions::default`]'s).
    pub chains: Option<u64>,
    /// [`AGREE`] (full engine).
    pub agree: Option<u64>,
    /// [`HOPS`] (full engine).
    pub hops: Option<u64>,
    /// [`ANNEAL_EVALS`] (full engine).
    pub anneal_evals: Option<u64>,
    /// Robust loss.
    pub loss: LossKind,
    /// Its scale, in the residual's units (a robust loss only; default
    /// [`DEFAULT_LOSS_SCALE`]).
    pub loss_scale: Option<f64>,
    /// Six-parameter `c` searched below 0.
    pub brightening: bool,
    /// [`BUDGET_EVALS`] (embedded engine only; default [`DEFAULT_BUDGET`]).
    pub budget_evals: Option<u64>,
    /// The noise floor of the relative residual, 1/sr, `>= 0` (0: none); estimated per
    /// dataset when `None` ([`crate::noise`]). Not for log residuals or the embedded engine.
    pub noise_floor: Option<f64>,
    /// How the bands of one spectral measurement are fitted ([`crate::spectral`]); `None`:
    /// independently. Shared needs the full engine and the linear loss.
    pub bands: Option<BandShape>,
}

/// Scales a robust loss may have: the magnitudes of [`crate::data::BRDF_MAGNITUDE`], so that
/// an absolute residual's scale can follow the data's units; beyond, the scale's square
/// overflows or vanishes (1e300 and 1e-300 left an unpolished grid point reported as a fit).
pub const LOSS_SCALE: RangeInclusive<f64> = 1e-100..=1e100;

/// Default scale of a robust loss: a 10% relative error.
pub const DEFAULT_LOSS_SCALE: f64 = 0.1;

impl FitRequest {
    /// The defaults for `model`: those of [`FitOptions::default`] and [`FitSettings::new`].
    pub fn new(model: ModelKind) -> Self {
        FitRequest {
            model,
            seed: FitOptions::default().seed,
            residual: Residual::default(),
            engine: EngineKind::Full,
            chains: None,
            agree: None,
            hops: None,
            anneal_evals: None,
            loss: LossKind::default(),
            loss_scale: None,
            brightening: false,
            budget_evals: None,
            noise_floor: None,
            bands: None,
        }
    }
}

impl FitSettings {
    /// Checks every option of `r` and builds the settings, or says which option is wrong.
    pub fn from_options(r: &FitRequest) -> Result<FitSettings, OptionError> {
        let d = FitOptions::default();
        let checked = |v: Option<u64>, limit: &Limit, default: usize| -> Result<usize, OptionError> {
            Ok(v.map(|v| limit.check(v))
                .transpose()?
                .map_or(default, |v| v as usize))
        };
        let chains = checked(r.chains, &CHAINS, d.chains)?;
        let agree = checked(r.agree, &AGREE, d.agree)?;
        let hops = checked(r.hops, &HOPS, d.hops)?;
        let evals = checked(r.anneal_evals, &ANNEAL_EVALS, d.anneal.evals)?;
        let budget = checked(r.budget_evals, &BUDGET_EVALS, DEFAULT_BUDGET as usize)?;
        // At least `agree` chains run, and no more than `chains`: more agreeing searches than
        // chains could never be met, and no fit would ever converge.
        if agree > chains {
            return Err(OptionError::AgreeAboveChains { agree, chains });
        }
        if let Some(scale) = r.loss_scale {
            if !LOSS_SCALE.contains(&scale) {
                return Err(OptionError::LossScale(scale));
            }
            if r.loss == LossKind::Linear {
                return Err(OptionError::Ignored {
                    name: "loss_scale",
                    applies: "scales a robust loss (huber, soft-l1, cauchy), not the linear one",
                });
            }
        }
        if let Some(s) = r.noise_floor {
            // 0 (none), or a reading's magnitude: a floor of 1e200 made every residual
            // underflow to 0 and a grid node "converged" at 0.000%.
            if !(s == 0.0 || crate::data::BRDF_MAGNITUDE.contains(&s)) {
                return Err(OptionError::NoiseFloor(s));
            }
        }
        if r.bands == Some(BandShape::Shared) && (r.loss != LossKind::Linear || r.residual == Residual::Log) {
            return Err(OptionError::Ignored {
                name: "bands shared",
                applies: "fits the bands of a spectral file with least squares (the linear loss) on \
                          relative or absolute residuals only",
            });
        }
        let ignored = |given: bool, name: &'static str, applies: &'static str| {
            if given {
                Err(OptionError::Ignored { name, applies })
            } else {
                Ok(())
            }
        };
        ignored(
            r.brightening && !matches!(r.model, ModelKind::Six | ModelKind::SixCos2),
            "brightening",
            "lets the six-parameter models' c go below 0 (six, six-cos2 only)",
        )?;
        ignored(
            r.noise_floor.is_some() && r.residual == Residual::Log,
            "noise_floor",
            "applies to relative residuals (and the relative metrics of absolute ones), not log ones",
        )?;
        let engine = match r.engine {
            EngineKind::Full => {
                ignored(
                    r.budget_evals.is_some(),
                    "budget_evals",
                    "applies to the embedded engine only",
                )?;
                Engine::Full
            }
            EngineKind::Embedded => {
                let set = [
                    (
                        r.residual != Residual::Relative,
                        format!("residual {}", r.residual),
                    ),
                    (r.loss != LossKind::Linear, format!("loss {}", r.loss)),
                    (r.brightening, "brightening".to_owned()),
                    (r.noise_floor.is_some(), "noise_floor".to_owned()),
                    (r.bands == Some(BandShape::Shared), "bands shared".to_owned()),
                ];
                if let Some((_, what)) = set.into_iter().find(|(bad, _)| *bad) {
                    return Err(OptionError::Embedded(what));
                }
                for (v, name) in [
                    (r.chains, "chains"),
                    (r.agree, "agree"),
                    (r.hops, "hops"),
                    (r.anneal_evals, "anneal_evals"),
                ] {
                    ignored(v.is_some(), name, "applies to the full engine only")?;
                }
                Engine::Embedded {
                    // At most 1e7: fits a u32.
                    budget: budget as u32,
                }
            }
        };
        Ok(FitSettings {
            kind: r.model,
            residual: r.residual,
            loss: Loss {
                kind: r.loss,
                scale: r.loss_scale.unwrap_or(DEFAULT_LOSS_SCALE),
            },
            brightening: r.brightening,
            noise_floor: r.noise_floor.map_or(FloorChoice::Auto, FloorChoice::Given),
            bands: r.bands.unwrap_or_default(),
            options: FitOptions {
                seed: r.seed,
                chains,
                agree,
                min_chains: agree,
                hops,
                anneal: AnnealOptions {
                    evals,
                    ..AnnealOptions::default()
                },
                ..FitOptions::default()
            },
            engine,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_the_default_settings() {
        for &k in ModelKind::ALL.iter() {
            let s = FitSettings::from_options(&FitRequest::new(k)).unwrap();
            let d = FitSettings::new(k);
            assert_eq!(s.options, d.options);
            assert_eq!(
                (s.kind, s.residual, s.engine, s.brightening),
                (d.kind, d.residual, d.engine, d.brightening)
            );
            assert_eq!(s.loss.kind, LossKind::Linear);
        }
    }

    #[test]
    fn each_range_is_checked_at_both_ends() {
        for limit in [CHAINS, AGREE, HOPS, ANNEAL_EVALS, BUDGET_EVALS] {
            let set = |v: u64| {
                let mut r = FitRequest::new(ModelKind::Six);
                match limit.name {
                    // (with the other at the value that keeps agree <= chains)
                    "chains" => (r.chains, r.agree) = (Some(v), Some(1)),
                    "agree" => (r.agree, r.chains) = (Some(v), Some(64)),
                    "hops" => r.hops = Some(v),
                    "anneal_evals" => r.anneal_evals = Some(v),
                    _ => {
                        r.engine = EngineKind::Embedded;
                        r.budget_evals = Some(v)
                    }
                }
                FitSettings::from_options(&r)
            };
            let (lo, hi) = (*limit.range.start(), *limit.range.end());
            assert!(set(lo).is_ok() && set(hi).is_ok(), "{}", limit.name);
            for bad in [lo.checked_sub(1), Some(hi + 1)].into_iter().flatten() {
                let e = set(bad).unwrap_err();
                assert_eq!(
                    e.to_string(),
                    format!("{} {bad} is not in {lo}..={hi}", limit.name)
                );
            }
        }
    }

    #[test]
    fn the_embedded_engine_refuses_what_it_would_ignore() {
        let base = FitRequest {
            engine: EngineKind::Embedded,
            ..FitRequest::new(ModelKind::Six)
        };
        assert!(FitSettings::from_options(&base).is_ok());
        for (r, what) in [
            (
                FitRequest {
                    residual: Residual::Log,
                    ..base.clone()
                },
                "residual log",
            ),
            (
                FitRequest {
                    loss: LossKind::Huber,
                    ..base.clone()
                },
                "loss huber",
            ),
            (
                FitRequest {
                    brightening: true,
                    ..base.clone()
                },
                "brightening",
            ),
        ] {
            let e = FitSettings::from_options(&r).unwrap_err().to_string();
            assert!(e.ends_with(&format!("; {what} is set")), "{e}");
        }
    }

    #[test]
    fn an_option_the_engine_or_loss_would_ignore_is_refused() {
        let embedded = FitRequest {
            engine: EngineKind::Embedded,
            ..FitRequest::new(ModelKind::Six)
        };
        let full = FitRequest::new(ModelKind::Six);
        for (r, name) in [
            (
                FitRequest {
                    chains: Some(4),
                    ..embedded.clone()
                },
                "chains",
            ),
            (
                FitRequest {
                    hops: Some(0),
                    ..embedded.clone()
                },
                "hops",
            ),
            (
                FitRequest {
                    budget_evals: Some(5000),
                    ..full.clone()
                },
                "budget_evals",
            ),
            (
                FitRequest {
                    loss_scale: Some(0.05),
                    ..full.clone()
                },
                "loss_scale",
            ),
        ] {
            let e = FitSettings::from_options(&r).unwrap_err();
            assert!(
                matches!(e, OptionError::Ignored { name: n, .. } if n == name),
                "{e}"
            );
            assert!(
                e.to_string().starts_with(name) && e.to_string().ends_with("it would be ignored"),
                "{e}"
            );
        }
    }

    #[test]
    fn more_agreeing_searches_than_chains_are_refused() {
        let r = FitRequest {
            agree: Some(10),
            chains: Some(4),
            ..FitRequest::new(ModelKind::Six)
        };
        assert_eq!(
            FitSettings::from_options(&r).unwrap_err().to_string(),
            "agree 10 is more than chains 4: the fit could never converge"
        );
        let r = FitRequest {
            agree: Some(4),
            chains: Some(4),
            ..FitRequest::new(ModelKind::Six)
        };
        assert!(FitSettings::from_options(&r).is_ok());
    }

    #[test]
    fn a_loss_scale_must_be_positive_and_finite() {
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e300, 1e-300, 1.0000001e100] {
            let r = FitRequest {
                loss: LossKind::Huber,
                loss_scale: Some(bad),
                ..FitRequest::new(ModelKind::Lambert)
            };
            let e = FitSettings::from_options(&r).unwrap_err();
            assert!(
                matches!(e, OptionError::LossScale(v) if v.to_bits() == bad.to_bits()),
                "{e}"
            );
            // Printed briefly (1e-300 was 300 digits).
            assert!(e.to_string().len() < 120, "{e}");
        }
    }

    #[test]
    fn names_parse_with_their_documented_spellings() {
        assert_eq!("soft_l1".parse::<LossKind>().unwrap(), LossKind::SoftL1);
        assert_eq!(
            "merl_inplane".parse::<crate::import::Format>().unwrap(),
            crate::import::Format::MerlInPlane
        );
        assert_eq!(
            "G".parse::<crate::import::Channel>().unwrap(),
            crate::import::Channel::G
        );
        assert_eq!(
            "ful".parse::<EngineKind>().unwrap_err().to_string(),
            "unknown engine `ful` (expected one of: full, embedded)"
        );
        assert_eq!(
            "l2".parse::<LossKind>().unwrap_err().to_string(),
            "unknown loss `l2` (expected one of: linear, huber, soft-l1, cauchy)"
        );
        for r in <Residual as Named>::ALL {
            assert_eq!(r.to_string().parse::<Residual>().unwrap(), *r);
        }
    }
}
