//! Fitting many datasets: in parallel on all cores, each result handed on as soon as it and
//! every result before it are done (input order, streamed), so a long batch shows results
//! while it runs.

use std::sync::mpsc;

use brdf_core::anneal::{check_directions, AnnealError};
use brdf_core::{Geometry, ModelKind};
use rayon::prelude::*;
use thiserror::Error;

use crate::embedded::{fit_embedded, EmbeddedError};
use crate::noise::{floor_for, FloorChoice, NoiseError, NoiseFloor};
use crate::problem::{Loss, Problem, Residual, Stop};
use crate::report::{report, FitReport};
use crate::spectral::{families, mark, share, BandShape};
use crate::{fit, Dataset, FitOptions, FitOutcome};

/// Why a dataset was not fitted.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FitError {
    /// Fewer distinct directions than the model has parameters: the rule every fit applies,
    /// on the device and on the host ([`check_directions`]).
    #[error("{dataset}: {source}")]
    Directions {
        /// Dataset name.
        dataset: String,
        /// The rule's error.
        source: AnnealError,
    },
    /// Weighted data (`sigma` or `weight`) for the embedded engine, which would ignore them.
    #[error(
        "{dataset}: line {line}: the embedded engine weighs every point alike; it cannot use sigma or weight"
    )]
    Weighted {
        /// Dataset name.
        dataset: String,
        /// The first weighted point's line.
        line: u64,
    },
    /// `--skip-invalid` left no dataset to fit.
    #[error("no dataset left to fit: all {skipped} were skipped")]
    NothingLeft {
        /// Datasets skipped.
        skipped: usize,
    },
    /// The embedded engine could not run.
    #[error(transparent)]
    Embedded(#[from] EmbeddedError),
    /// A reading at or below zero that these settings cannot weigh.
    #[error("{dataset}: line {line}: brdf {value} is at or below zero, and {why}")]
    Dark {
        /// Dataset name.
        dataset: String,
        /// The first such reading's line.
        line: u64,
        /// Its value.
        value: f64,
        /// Why the settings cannot use it, and what can.
        why: &'static str,
    },
    /// Shared bands asked for, and no two datasets are bands of one measurement.
    #[error(
        "bands shared: no two datasets are bands of one measurement (datasets that differ only in \
         `wavelength`); it would be ignored"
    )]
    NoBands,
    /// No noise floor can be estimated.
    #[error("{dataset}: {source}")]
    Noise {
        /// Dataset name.
        dataset: String,
        /// Why.
        source: NoiseError,
    },
}

/// Which fitting engine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    /// Host engine: annealing chains polished by Levenberg–Marquardt, f64.
    Full,
    /// The on-sensor f32 annealer of brdf-core with this evaluation budget.
    Embedded {
        /// Cost evaluations.
        budget: u32,
    },
}

/// Everything that defines one fit besides the data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitSettings {
    /// The model.
    pub kind: ModelKind,
    /// Residual form.
    pub residual: Residual,
    /// Robust loss.
    pub loss: Loss,
    /// Six-parameter `c` searched below 0 (see [`Problem::with_brightening`]).
    pub brightening: bool,
    /// The noise floor of the relative residual ([`crate::noise`]).
    pub noise_floor: FloorChoice,
    /// How the bands of one spectral measurement are fitted ([`crate::spectral`]; shared
    /// only with the full engine and least squares; independent by default).
    pub bands: BandShape,
    /// Search settings of the full engine (its seed also seeds the embedded one).
    pub options: FitOptions,
    /// The engine.
    pub engine: Engine,
}

impl FitSettings {
    /// Default settings for `kind`: relative residuals, least squares, the full engine.
    pub fn new(kind: ModelKind) -> Self {
        FitSettings {
            kind,
            residual: Residual::Relative,
            loss: Loss::default(),
            brightening: false,
            noise_floor: FloorChoice::Auto,
            bands: BandShape::Independent,
            options: FitOptions::default(),
            engine: Engine::Full,
        }
    }

    /// The noise floor these settings give `d` (`None`: none), as the report states it.
    pub fn floor(&self, d: &Dataset) -> Result<Option<NoiseFloor>, FitError> {
        floor_for(self.noise_floor, &d.points).map_err(|source| FitError::Noise {
            dataset: d.name.clone(),
            source,
        })
    }

    /// The least-squares problem these settings pose on `d`.
    pub fn problem(&self, d: &Dataset) -> Result<Problem, FitError> {
        let floor = self.floor(d)?.map_or(0.0, |f| f.value);
        Ok(Problem::with_floor(self.kind, self.residual, &d.points, floor)
            .with_loss(self.loss)
            .with_brightening(self.brightening))
    }

    /// Whether these settings can fit `d`: one distinct direction per parameter, and for the
    /// embedded engine no `sigma` or `weight` (its annealer weighs every point alike). A batch
    /// checks every dataset before fitting any, so that it fails before writing anything.
    pub fn check(&self, d: &Dataset) -> Result<(), FitError> {
        let geometries = d
            .points
            .iter()
            .map(|p| Geometry::<f64>::from_angles(p.theta_i, p.theta_r, p.phi));
        check_directions(self.kind, geometries).map_err(|source| FitError::Directions {
            dataset: d.name.clone(),
            source,
        })?;
        if let Engine::Embedded { .. } = self.engine {
            if let Some(p) = d.points.iter().find(|p| p.sigma.is_some() || p.weight.is_some()) {
                return Err(FitError::Weighted {
                    dataset: d.name.clone(),
                    line: p.line,
                });
            }
        }
        if let Some(p) = d.points.iter().find(|p| p.brdf <= 0.0) {
            let why = match (self.engine, self.residual) {
                (Engine::Embedded { .. }, _) => Some(
                    "the embedded engine has no noise floor (fit with the full engine, or leave \
                     the dark readings out)",
                ),
                (_, Residual::Log) => Some(
                    "log residuals take the logarithm of every reading (relative residuals \
                     weigh dark readings with a noise floor)",
                ),
                (_, Residual::Relative) if matches!(self.noise_floor, FloorChoice::Given(s) if s <= 0.0 || s.is_nan()) => {
                    Some(
                        "noise floor 0 leaves relative residuals no scale for it (give a floor, \
                     or leave it to be estimated)",
                    )
                }
                _ => None,
            };
            if let Some(why) = why {
                return Err(FitError::Dark {
                    dataset: d.name.clone(),
                    line: p.line,
                    value: p.brdf,
                    why,
                });
            }
            self.floor(d)?;
        }
        Ok(())
    }

    /// Fits one dataset and builds its report, after [`FitSettings::check`].
    pub fn fit(&self, d: &Dataset) -> Result<FitReport, FitError> {
        self.fit_until(d, &Stop::default())
    }

    /// [`FitSettings::fit`], abandoned when `stop` is requested (the full engine's searches
    /// end early and the report says "not converged"; the embedded engine runs to its
    /// budget, at most [`crate::request::BUDGET_EVALS`] evaluations).
    pub fn fit_until(&self, d: &Dataset, stop: &Stop) -> Result<FitReport, FitError> {
        let (problem, outcome) = self.search_until(d, stop)?;
        self.report_of(d, &problem, &outcome, stop)
    }

    /// Whether these settings fit the bands of one measurement with one shape.
    pub fn shares_bands(&self) -> bool {
        self.bands == BandShape::Shared
            && self.engine == Engine::Full
            && self.loss.is_linear()
            && self.residual != Residual::Log
    }

    /// The search of [`FitSettings::fit_until`], without the report.
    fn search_until(&self, d: &Dataset, stop: &Stop) -> Result<(Problem, FitOutcome), FitError> {
        self.check(d)?;
        let problem = self.problem(d)?.with_stop(stop.clone());
        let outcome = match self.engine {
            Engine::Full => fit(&problem, &self.options),
            Engine::Embedded { budget } => fit_embedded(self.kind, d, &problem, budget, self.options.seed)?,
        };
        Ok((problem, outcome))
    }

    /// The report of [`FitSettings::fit_until`] for `outcome`.
    fn report_of(
        &self,
        d: &Dataset,
        problem: &Problem,
        outcome: &FitOutcome,
        stop: &Stop,
    ) -> Result<FitReport, FitError> {
        let mut r = report(d, problem, outcome, &self.options);
        r.noise_floor = self.floor(d)?;
        // A stop that arrived after the search but during the report (whose profile refits
        // end early on it) still makes the result a stopped one: never "converged".
        if stop.requested() {
            r.converged = false;
        }
        Ok(r)
    }
}

/// A dataset a batch left out ([`fittable`] with `skip`): printed as `skipped dataset
/// REASON`, and a row of its own in `brdf fit -o`'s CSV.
#[derive(Clone, Debug, PartialEq)]
pub struct SkippedDataset {
    /// Its name.
    pub dataset: String,
    /// Its points.
    pub points: usize,
    /// Why it cannot be fitted ([`FitSettings::check`]'s error, naming the dataset).
    pub reason: String,
}

impl std::fmt::Display for SkippedDataset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "skipped dataset {}", self.reason)
    }
}

/// The datasets of a batch that `settings` can fit ([`FitSettings::check`]), checked before
/// any is fitted so that a batch fails before it writes: the first refusal is the error, or,
/// with `skip`, each refused dataset is left out and returned with its reason (`brdf fit
/// --skip-invalid`, `brdf.fit(skip_invalid=True)`). An error when none is left.
pub fn fittable(
    settings: &FitSettings,
    datasets: Vec<Dataset>,
    skip: bool,
) -> Result<(Vec<Dataset>, Vec<SkippedDataset>), FitError> {
    let mut kept = Vec::with_capacity(datasets.len());
    let mut skipped = Vec::new();
    for d in datasets {
        match settings.check(&d) {
            Ok(()) => kept.push(d),
            Err(e) if skip => skipped.push(SkippedDataset {
                reason: e.to_string(),
                points: d.points.len(),
                dataset: d.name,
            }),
            Err(e) => return Err(e),
        }
    }
    if kept.is_empty() && !skipped.is_empty() {
        return Err(FitError::NothingLeft {
            skipped: skipped.len(),
        });
    }
    if settings.bands == BandShape::Shared {
        let names: Vec<&str> = kept.iter().map(|d| d.name.as_str()).collect();
        if families(&names).is_empty() {
            return Err(FitError::NoBands);
        }
    }
    Ok((kept, skipped))
}

/// Fits every dataset in parallel and calls `each(index, result)` in input order, each as
/// soon as it and all before it are done. Returns every result in input order.
pub fn fit_streamed(
    settings: &FitSettings,
    datasets: &[Dataset],
    each: impl FnMut(usize, &Result<FitReport, FitError>),
) -> Vec<Result<FitReport, FitError>> {
    fit_streamed_until(settings, datasets, &Stop::default(), each)
}

/// [`fit_streamed`], every fit abandoned when `stop` is requested ([`FitSettings::fit_until`]).
/// The bands of one spectral measurement ([`crate::spectral::families`]) are fitted with one
/// shape when the settings share bands ([`FitSettings::shares_bands`]); then every result
/// comes when all are done (no streaming).
pub fn fit_streamed_until(
    settings: &FitSettings,
    datasets: &[Dataset],
    stop: &Stop,
    mut each: impl FnMut(usize, &Result<FitReport, FitError>),
) -> Vec<Result<FitReport, FitError>> {
    let names: Vec<&str> = datasets.iter().map(|d| d.name.as_str()).collect();
    let families = families(&names);
    if families.is_empty() || !settings.shares_bands() {
        return fit_each_streamed(settings, datasets, stop, each);
    }
    // Every dataset's own search in parallel; then each family's shared shape.
    let mut searched: Vec<Option<Result<(Problem, FitOutcome), FitError>>> = datasets
        .par_iter()
        .map(|d| Some(settings.search_until(d, stop)))
        .collect();
    let mut out: Vec<Option<Result<FitReport, FitError>>> = (0..datasets.len()).map(|_| None).collect();
    for family in &families {
        let ok: Vec<(&Problem, &FitOutcome)> = family
            .iter()
            .filter_map(|&i| match &searched[i] {
                Some(Ok((p, o))) => Some((p, o)),
                _ => None,
            })
            .collect();
        // A band whose own search failed reports its error; the rest are fitted alone.
        if ok.len() < family.len() {
            continue;
        }
        let problems: Vec<&Problem> = ok.iter().map(|(p, _)| *p).collect();
        let own: Vec<FitOutcome> = ok.iter().map(|(_, o)| (*o).clone()).collect();
        let (shared, total) = share(&problems, &own);
        // Each band's report with the shape held where the bands share it: its influence
        // refits and profiles would otherwise slide to the band's own optimum and report what
        // sharing cost the band as the effect of one point or one parameter.
        let reports: Result<Vec<FitReport>, FitError> = family
            .par_iter()
            .zip(&shared)
            .zip(&problems)
            .map(|((&i, o), p)| {
                let held = (*p)
                    .clone()
                    .with_fixed(crate::problem::nonlinear_indices(o.kind), &o.q);
                settings.report_of(&datasets[i], &held, o, stop)
            })
            .collect();
        match reports {
            Ok(mut reports) => {
                mark(&mut reports, BandShape::Shared, Some(total));
                for (&i, r) in family.iter().zip(reports) {
                    out[i] = Some(Ok(r));
                }
            }
            Err(e) => out[family[0]] = Some(Err(e)),
        }
    }
    let mut pending = Vec::new();
    for i in 0..datasets.len() {
        if out[i].is_none() {
            match searched[i].take().expect("each search is taken once") {
                Ok(found) => pending.push((i, found)),
                Err(e) => out[i] = Some(Err(e)),
            }
        }
    }
    let reports: Vec<Result<FitReport, FitError>> = pending
        .par_iter()
        .map(|(i, (p, o))| settings.report_of(&datasets[*i], p, o, stop))
        .collect();
    for ((i, _), r) in pending.iter().zip(reports) {
        out[*i] = Some(r);
    }
    let out: Vec<Result<FitReport, FitError>> = out
        .into_iter()
        .map(|r| r.expect("every dataset has a result"))
        .collect();
    for (i, r) in out.iter().enumerate() {
        each(i, r);
    }
    out
}

/// Every dataset fitted on its own, each result handed on in input order as soon as it and
/// all before it are done.
fn fit_each_streamed(
    settings: &FitSettings,
    datasets: &[Dataset],
    stop: &Stop,
    mut each: impl FnMut(usize, &Result<FitReport, FitError>),
) -> Vec<Result<FitReport, FitError>> {
    let (tx, rx) = mpsc::channel();
    let mut done: Vec<Option<Result<FitReport, FitError>>> = (0..datasets.len()).map(|_| None).collect();
    let mut next = 0;
    std::thread::scope(|scope| {
        scope.spawn(move || {
            datasets.par_iter().enumerate().for_each_with(tx, |tx, (i, d)| {
                // The receiver lives until every result is in.
                let _ = tx.send((i, settings.fit_until(d, stop)));
            });
        });
        for (i, r) in rx {
            done[i] = Some(r);
            while let Some(Some(r)) = done.get(next) {
                each(next, r);
                next += 1;
            }
        }
    });
    done.into_iter()
        .map(|r| r.expect("every dataset was fitted"))
        .collect()
}

/// Fits every dataset with the full engine, in input order; the first dataset the
/// distinct-direction rule refuses is the error.
pub fn fit_all(settings: &FitSettings, datasets: &[Dataset]) -> Result<Vec<FitReport>, FitError> {
    let full = FitSettings {
        engine: Engine::Full,
        ..*settings
    };
    fit_streamed(&full, datasets, |_, _| {}).into_iter().collect()
}
