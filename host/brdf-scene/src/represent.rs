//! "No more model than the data need": the device representations of fitted models
//! ([`crate::ladder`]: each model of the ladder exact in f32, the six-parameter model's lookup
//! tables), each with its error against measured data over a domain, its cost on the device
//! (`brdf_core::cost`) and on this host, and its size in flash; and the choice among them
//! (`brdf select DATA`) by the ladder's one rule ([`crate::ladder::choose`]). The scene
//! version, judged on σ instead of on data, is [`crate::select`].

use brdf_core::table::{table_accuracy, SixTable};
use brdf_core::ModelKind;
use brdf_fit::report::FitReport;
use brdf_fit::{Dataset, Stop};
use brdf_wire::blob::Material;
use serde::Serialize;

use crate::eval::{eval_batch, Evaluator};
use crate::ladder::{choose, fitted_rung, rungs, Choice, Rung};
use brdf_core::{Brdf, MAX_PARAMS};
use brdf_fit::fitted_table::{trimmed_rms_rel, FittedTable, TableRecord, SHAPES};
use brdf_fit::noise::floored_relative;

/// One way the device could answer lookups for this data: a rung of the ladder with its
/// error against the data.
#[derive(Clone, Debug, Serialize)]
pub struct Representation {
    /// The representation (name, model, cost, bytes, physicality).
    #[serde(flatten)]
    pub rung: Rung,
    /// Host nanoseconds per f32 lookup from cosines, measured in this run.
    pub host_ns: f64,
    /// RMS relative error against the data over the domain, the largest 2% left out as in
    /// `cv_rms_rel` (training error: the model was fitted to these points).
    pub rms_rel: f64,
    /// Held-out error: the RMS relative error over the points of the domain, each predicted
    /// by the model refitted without its fold ([`CV_FOLDS`]-fold cross-validation), the
    /// largest 2% left out (`brdf_fit::fitted_table::trimmed_rms_rel`: one dropout reading in
    /// fifty must not decide). What `brdf select` chooses by. `None` when some fold could not be refitted (fewer distinct
    /// directions than parameters left, or parameters no device material takes).
    pub cv_rms_rel: Option<f64>,
    /// Largest relative error against the data over the domain.
    pub max_rel: f64,
    /// Max relative error of the table against the exact model at the data points.
    pub table_vs_exact: Option<f64>,
    /// For a fitted table: the fraction of its cells the data constrain (a query elsewhere
    /// gets the smoothness term's extrapolation).
    pub coverage: Option<f64>,
}

/// A rung measured against the data over the domain (training error, host time), not yet
/// cross-validated; relative errors over the noise floor `floor` (1/sr, 0 for none:
/// `brdf_fit::noise::floored_relative`).
fn measured(rung: Rung, domain: &Dataset, coverage: Option<f64>, floor: f64) -> Representation {
    let n = domain.points.len();
    let col = |f: fn(&brdf_fit::Point) -> f64| -> Vec<f64> { domain.points.iter().map(f).collect() };
    let (ci, cr, cp) = (
        col(|p| p.theta_i.cos()),
        col(|p| p.theta_r.cos()),
        col(|p| p.phi.cos()),
    );
    let mut values = vec![0.0; n];
    let reps = (200_000 / n.max(1)).max(1);
    let t = std::time::Instant::now();
    for _ in 0..reps {
        eval_batch(&rung.eval, &ci, &cr, &cp, std::hint::black_box(&mut values));
    }
    let host_ns = t.elapsed().as_secs_f64() * 1e9 / (reps * n.max(1)) as f64;
    let rel: Vec<f64> = values
        .iter()
        .zip(&domain.points)
        .map(|(f, p)| floored_relative(*f, p.brdf, floor).abs())
        .collect();
    Representation {
        rung,
        host_ns,
        rms_rel: trimmed_rms_rel(&rel),
        cv_rms_rel: None,
        max_rel: rel.iter().copied().fold(0.0, f64::max),
        table_vs_exact: None,
        coverage,
    }
}

/// Every representation of every fitted model, with its error against the data over the
/// domain (relative over the noise floor `floor`, 1/sr; 0 for none) and its cost.
/// A fit whose parameters no device accepts (an uncalibrated weight far beyond its range)
/// gives no representation; it is named in `notes`, and the others are still compared.
pub fn representations(
    reports: &[FitReport],
    domain: &Dataset,
    floor: f64,
    notes: &mut Vec<String>,
) -> Result<Vec<Representation>, String> {
    let cos32: Vec<[f32; 3]> = domain
        .points
        .iter()
        .map(|p| [p.theta_i.cos() as f32, p.theta_r.cos() as f32, p.phi.cos() as f32])
        .collect();
    let mut reprs = Vec::new();
    for r in reports {
        let params = r
            .params_array()
            .map_err(|p| format!("{}: no parameter `{p}`", r.dataset))?;
        let label = r.model.name();
        let built = match rungs(label, r.model, &params) {
            Ok(b) => b,
            Err(e) => {
                notes.push(format!("{e}; left out"));
                continue;
            }
        };
        for rung in built {
            let table_vs_exact = match (&rung.eval, rung.material.six_params()) {
                (Evaluator::Table { consts, bytes }, Some(p)) => {
                    let table =
                        SixTable::from_parts(*consts, bytes).ok_or("table constants and bytes differ")?;
                    let exact64 = brdf_core::SixParam::new(p.widen()).map_err(|e| format!("{e}"))?;
                    Some(table_accuracy(&table, &exact64, cos32.iter().copied()).max)
                }
                _ => None,
            };
            reprs.push(Representation {
                table_vs_exact,
                ..measured(rung, domain, None, floor)
            });
        }
    }
    Ok(reprs)
}

/// Fewest points a fitted table is offered for: below this, cross-validation is
/// leave-one-out, and each of `n` refits would choose its smoothness by its own inner
/// cross-validation (about 80 s at 49 points); and a table of 1,710 or 1,900 cells
/// ([`SHAPES`]) on fewer than 50 points is shaped by its smoothness term far more than by the
/// data.
pub const TABLE_MIN_POINTS: usize = CV_LEAVE_ONE_OUT_BELOW;

/// The base model of a fitted table: the microfacet model, so that where the measurements do
/// not reach (outside the table's coverage, where its correction fades to none) the prediction
/// still follows a physical glossy lobe. Fitted to the in-plane readings only and judged off the
/// plane, the table over it predicts better than over a Lambert base on each of the ten
/// bundled datasets with off-plane readings (garnet R 0.149 vs 0.286, krylon B 0.168 vs 0.290;
/// `cargo run --release -p brdf-scene --example table_extrapolation`,
/// docs/model-comparison.md), and as well inside the coverage (median held-out ratio to 4-NN
/// 0.81 against 0.83). The larger table ([`SHAPES`]: 20 x 19 x 5) with this base is a
/// 4,094-byte blob, one flash slot (with a six-parameter base it would not fit).
pub const TABLE_BASE: ModelKind = ModelKind::Ggx;

/// The fitted-table rung over the base fit `base_params` (a [`TABLE_BASE`] fit to `train`):
/// the table fitted to `ln(f / f_base)` at `train`'s points with its smoothness chosen by
/// cross-validation on them, over the noise floor `floor` (1/sr; 0 for none:
/// `FittedTable::fit_cv_floored`), and its record for `--chosen`.
pub fn table_rung(
    train: &Dataset,
    base_params: &[f64; MAX_PARAMS],
    floor: f64,
) -> Result<(Rung, TableRecord), String> {
    table_rung_over(TABLE_BASE, train, base_params, floor)
}

/// [`table_rung`] over a base of any model `kind` (`base_params` its fit to `train`), for
/// studies that compare bases (`cargo run --release -p brdf-scene --example
/// table_extrapolation`).
pub fn table_rung_over(
    kind: ModelKind,
    train: &Dataset,
    base_params: &[f64; MAX_PARAMS],
    floor: f64,
) -> Result<(Rung, TableRecord), String> {
    let name = &train.name;
    let base = Material::from_params(kind, base_params).map_err(|e| format!("{name}: table base: {e}"))?;
    let model = base.model().map_err(|e| format!("{name}: table base: {e}"))?;
    let base_ln: Vec<f64> = train
        .points
        .iter()
        .map(|p| f64::from(model.eval_angles(p.theta_i as f32, p.theta_r as f32, p.phi as f32)).ln())
        .collect();
    let table = FittedTable::fit_cv_floored(&train.points, &base_ln, &SHAPES, floor)
        .map_err(|e| format!("{name}: fitted table: {e}"))?;
    let record = TableRecord::new(&table).map_err(|e| format!("{name}: fitted table: {e}"))?;
    let bytes = table
        .to_bytes()
        .map_err(|e| format!("{name}: fitted table: {e}"))?;
    let material = base
        .with_fitted(&bytes)
        .map_err(|e| format!("{name}: fitted table: {e}"))?;
    Ok((fitted_rung(material, bytes)?, record))
}

/// Folds of the cross-validation `brdf select` judges representations by: every point is held
/// out once, each model refitted on the other 80% (the split of the held-out comparisons in
/// docs/model-comparison.md). Five refits per model: enough that each training set is most
/// of the data, few enough that a selection costs about six fits per model.
pub const CV_FOLDS: usize = 5;

/// Below this many points every point is its own fold (leave-one-out): with five folds, 7
/// points would leave 5 to train on, too few for the six-parameter model, which would then go
/// unjudged however well it fits. Leave-one-out keeps `n - 1`; its cost (`n` refits of small
/// data) stays below that of five refits of larger data.
pub const CV_LEAVE_ONE_OUT_BELOW: usize = 10 * CV_FOLDS;

/// The number of folds for `n` points ([`CV_FOLDS`], or `n` below
/// [`CV_LEAVE_ONE_OUT_BELOW`]).
pub fn cv_fold_count(n: usize) -> usize {
    if n < CV_LEAVE_ONE_OUT_BELOW {
        n
    } else {
        CV_FOLDS
    }
}

/// Seed of the fold assignment (fixed: the same data always give the same folds).
const CV_SEED: u64 = 0x5eed_c0ff_ee00_0005;

/// The fold of each point ([`cv_fold_count`] folds of its count): its direction's, every
/// reading of a direction in one fold ([`brdf_fit::folds::grouped_folds`]), in a fixed
/// pseudo-random order so that the folds do not follow the file's order (measurements are
/// usually sorted by incidence, and a fold of one incidence would test extrapolation) and a
/// replicate reading never predicts its own copy.
pub fn cv_folds(points: &[brdf_fit::Point]) -> Vec<usize> {
    brdf_fit::folds::grouped_folds(points, cv_fold_count(points.len()), CV_SEED)
}

/// Sets `cv_rms_rel` of every representation: per fold and model of the ladder, the model
/// refitted with `settings` on the points outside the fold, each of its rungs evaluated at the
/// fold's points (errors relative over the domain's noise floor `floor`). A rung gets a value
/// only when every point was predicted.
fn cross_validate(
    domain: &Dataset,
    settings: &(dyn Fn(ModelKind) -> brdf_fit::FitSettings + Sync),
    with_table: bool,
    floor: f64,
    reprs: &mut [Representation],
    stop: &Stop,
) {
    use rayon::prelude::*;
    let fold = cv_folds(&domain.points);
    let jobs: Vec<(usize, ModelKind)> = (0..cv_fold_count(domain.points.len()))
        .flat_map(|f| ModelKind::LADDER.into_iter().map(move |k| (f, k)))
        .collect();
    // Per job: (rung name, relative error at each held-out point) for every rung it built.
    let errors: Vec<Vec<(String, Vec<f64>)>> = jobs
        .par_iter()
        .map(|&(f, kind)| {
            let split = |held: bool| Dataset {
                name: domain.name.clone(),
                points: domain
                    .points
                    .iter()
                    .zip(&fold)
                    .filter(|(_, &g)| (g == f) == held)
                    .map(|(p, _)| *p)
                    .collect(),
            };
            let (train, test) = (split(false), split(true));
            if test.points.is_empty() || stop.requested() {
                return Vec::new();
            }
            // `FitSettings::fit`, not `fit_all`: this runs on the thread pool already, and
            // `fit_all` would wait on it for its own tasks.
            let Ok(fit) = settings(kind).fit_until(&train, stop) else {
                return Vec::new();
            };
            let Ok(params) = fit.params_array() else {
                return Vec::new();
            };
            let Ok(mut built) = rungs(kind.name(), kind, &params) else {
                return Vec::new();
            };
            if with_table && kind == TABLE_BASE {
                if let Ok((r, _)) = table_rung(&train, &params, floor) {
                    built.push(r);
                }
            }
            let col = |g: fn(&brdf_fit::Point) -> f64| -> Vec<f64> { test.points.iter().map(g).collect() };
            let (ci, cr, cp) = (
                col(|p| p.theta_i.cos()),
                col(|p| p.theta_r.cos()),
                col(|p| p.phi.cos()),
            );
            let mut values = vec![0.0; test.points.len()];
            built
                .into_iter()
                .map(|rung| {
                    eval_batch(&rung.eval, &ci, &cr, &cp, &mut values);
                    let rel: Vec<f64> = values
                        .iter()
                        .zip(&test.points)
                        .map(|(v, p)| floored_relative(*v, p.brdf, floor).abs())
                        .collect();
                    (rung.name, rel)
                })
                .collect()
        })
        .collect();
    let n = domain.points.len();
    for r in reprs.iter_mut() {
        let all: Vec<f64> = errors
            .iter()
            .flatten()
            .filter(|(name, _)| *name == r.rung.name)
            .flat_map(|(_, rel)| rel.iter().copied())
            .collect();
        // Infinite when a value is not finite anywhere (`trimmed_rms_rel`).
        r.cv_rms_rel = (all.len() == n).then(|| trimmed_rms_rel(&all));
    }
}

/// The yardstick of the held-out errors: four-nearest-neighbour interpolation of `ln f`
/// (`brdf_fit::holdout::Neighbours`) of each fold's points from the other folds' —
/// the same folds and the same floored relative error as the representations, so that a
/// representation's `cv_rms_rel` above it says the data hold detail the representation
/// misses. Training readings at or below zero are raised to the smallest positive training
/// reading (`brdf_fit::holdout::raised_for_ln`); every held-out reading is judged as it is. `None` when a fold
/// leaves nothing to interpolate from (every reading of one direction).
fn knn_yardstick(domain: &Dataset, floor: f64) -> Option<f64> {
    use rayon::prelude::*;
    let fold = cv_folds(&domain.points);
    let folds = cv_fold_count(domain.points.len());
    if (0..folds).any(|f| fold.iter().all(|&g| g == f)) {
        return None;
    }
    let errors: Vec<f64> = (0..folds)
        .into_par_iter()
        .flat_map_iter(|f| {
            let kept: Vec<brdf_fit::Point> = domain
                .points
                .iter()
                .zip(&fold)
                .filter(|(_, &g)| g != f)
                .map(|(p, _)| *p)
                .collect();
            let train = brdf_fit::holdout::Neighbours::new(&brdf_fit::holdout::raised_for_ln(&kept));
            domain
                .points
                .iter()
                .zip(&fold)
                .filter(|(_, &g)| g == f)
                .map(|(p, _)| {
                    let v = train.predict(p);
                    floored_relative(v, p.brdf, floor).abs()
                })
                .collect::<Vec<f64>>()
        })
        .collect();
    Some(trimmed_rms_rel(&errors))
}

/// The one dataset of `origin` that `brdf select DATA` works on; an error naming `origin` when
/// it holds several (sample or wavelength groups) or none.
pub fn one_dataset(origin: &str, mut datasets: Vec<Dataset>) -> Result<Dataset, String> {
    if datasets.len() != 1 {
        return Err(format!(
            "{origin}: holds {} datasets (sample/wavelength groups); select works on one",
            datasets.len()
        ));
    }
    Ok(datasets.remove(0))
}

/// The points of a dataset within an angular domain (`theta_i <= max_theta_i`, `theta_r <=
/// max_theta_r`, in degrees, each kept within [`brdf_core::tolerance::ANGLE_FILTER_DEG`]), and
/// how many were left out.
#[derive(Clone, Debug)]
pub struct DataDomain {
    /// The points kept, under the dataset's name.
    pub domain: Dataset,
    /// The `theta_i` limit (degrees).
    pub max_theta_i: f64,
    /// The `theta_r` limit (degrees).
    pub max_theta_r: f64,
    /// Points left out for `theta_i` beyond the limit.
    pub beyond_i: usize,
    /// Points left out for `theta_r` beyond its limit (among those within the `theta_i` one).
    pub beyond_r: usize,
}

impl DataDomain {
    /// Keeps the points of `d` within the limits (degrees).
    pub fn new(d: &Dataset, max_theta_i: f64, max_theta_r: f64) -> DataDomain {
        let tol = brdf_core::tolerance::ANGLE_FILTER_DEG;
        let (li, lr) = ((max_theta_i + tol).to_radians(), (max_theta_r + tol).to_radians());
        let beyond_i = d.points.iter().filter(|p| p.theta_i > li).count();
        let beyond_r = d
            .points
            .iter()
            .filter(|p| p.theta_i <= li && p.theta_r > lr)
            .count();
        let domain = Dataset {
            name: d.name.clone(),
            points: d
                .points
                .iter()
                .filter(|p| p.theta_i <= li && p.theta_r <= lr)
                .copied()
                .collect(),
        };
        DataDomain {
            domain,
            max_theta_i,
            max_theta_r,
            beyond_i,
            beyond_r,
        }
    }

    /// What was left out, for the user (`None` when every point is kept).
    pub fn left_out_note(&self) -> Option<String> {
        let (bi, br) = (self.beyond_i, self.beyond_r);
        (bi + br > 0).then(|| {
            format!(
                "{}: left out {} of {} points: {bi} with theta_i > {} deg, {br} more with \
                 theta_r > {} deg (limits kept within {} deg)",
                self.domain.name,
                bi + br,
                // Kept, left out for theta_i and for theta_r partition the dataset.
                self.domain.points.len() + bi + br,
                brdf_core::Compact(self.max_theta_i),
                brdf_core::Compact(self.max_theta_r),
                brdf_core::Compact(brdf_core::tolerance::ANGLE_FILTER_DEG)
            )
        })
    }
}

/// `brdf select DATA` (and `brdf.select` in Python): every model of the ladder fitted over the
/// domain, every device representation of each, and the one chosen. Serialised, it is the
/// JSON `brdf select --json` prints.
#[derive(Clone, Debug, Serialize)]
pub struct DataSelection {
    pub dataset: String,
    /// Largest acceptable RMS relative error over the domain.
    pub budget: f64,
    /// The domain's limits (degrees).
    pub max_theta_i: f64,
    pub max_theta_r: f64,
    /// Points in the domain.
    pub n: usize,
    /// The yardstick: the held-out error of four-nearest-neighbour interpolation of the same
    /// points over the same folds (`knn_yardstick`). A representation whose `cv_rms_rel` is
    /// above it misses detail the data hold. `None` when a fold holds every point (one
    /// direction read several times: nothing to interpolate from).
    pub knn_cv_rms_rel: Option<f64>,
    /// The noise floor the relative errors are taken over (`brdf_fit::noise`), when the data
    /// have readings at or below zero or a floor was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub noise_floor: Option<brdf_fit::noise::NoiseFloor>,
    pub allow_nonphysical: bool,
    /// The representation chosen: the cheapest within the budget, or the most accurate when
    /// none is; `None` only when none could be cross-validated or fits a slot.
    pub chosen: Option<String>,
    /// Whether the chosen representation meets the budget.
    pub within_budget: bool,
    /// Index in `candidates` of the fit the chosen representation comes from (`--chosen`).
    pub chosen_fit: Option<usize>,
    /// The fitted table, when the chosen representation is one (its base is
    /// `candidates[chosen_fit]`; `--chosen` writes them together).
    #[serde(skip)]
    pub chosen_table: Option<TableRecord>,
    /// Why it was chosen, or why nothing was.
    pub reason: String,
    /// Models of the ladder left out (the data cannot determine them), with why.
    pub notes: Vec<String>,
    /// The ladder's fits, simplest first.
    pub candidates: Vec<FitReport>,
    pub representations: Vec<Representation>,
    /// The chosen representation as a device material, with its table bytes if tabulated.
    #[serde(skip)]
    pub material: Option<(Material, Option<Vec<u8>>)>,
}

impl DataSelection {
    /// The fit the chosen representation comes from, with its fitted table when that was
    /// chosen: what `brdf select --chosen` writes and `brdf.select(...).chosen_fit` is.
    ///
    /// With a fitted table its `energy` is the representation's, base times table: the albedo
    /// by quadrature at the base fit's incidences, and no analytic bound (the table has none).
    /// The base's own check described a surface the device does not serve: MERL aluminium's
    /// base conserved energy (albedo 0.04) where the chosen representation reflects 1.5.
    pub fn chosen_report(&self) -> Option<FitReport> {
        let mut fit = self.candidates.get(self.chosen_fit?)?.clone();
        fit.fitted_table = self.chosen_table.clone();
        let (kind, params) = (fit.model, fit.params_array().ok()?);
        if let Some(record) = &mut fit.fitted_table {
            record.seal(kind, &params).ok()?;
        }
        if let Some(record) = &fit.fitted_table {
            let bytes = record.decode().ok()?;
            let base = brdf_core::AnyModel::<f64>::new(kind, &params[..kind.param_count()]).ok()?;
            let table = brdf_core::fitted::FittedTable::new(&bytes).ok()?;
            let corrected = brdf_core::fitted::Corrected { base, table };
            let rule = brdf_core::checks::AlbedoRule::for_model(&base);
            for a in &mut fit.energy.albedo {
                a.albedo = brdf_core::checks::albedo(&corrected, a.theta_i.to_radians(), rule);
            }
            fit.energy.bound = None;
            fit.energy.bound_conserves = false;
            // The table scales a base whose albedo may be unbounded at grazing (which the
            // report states), so the one rule decides.
            fit.energy.recheck();
        }
        Some(fit)
    }
}

/// Fits every model of [`ModelKind::LADDER`] to the points `kept` with `settings(kind)`,
/// measures every representation against the data and by cross-validation, and chooses among
/// them ([`choose`]) by the held-out error: the cheapest within the budget or, when none is,
/// the most accurate (`within_budget` false, the reason says so). Fails with a message naming
/// the dataset when the domain has fewer than 7 points (too few to compare models) or a
/// fitted model cannot become a device material.
pub fn select_data(
    kept: &DataDomain,
    settings: &(dyn Fn(ModelKind) -> brdf_fit::FitSettings + Sync),
    budget: f64,
    allow_nonphysical: bool,
) -> Result<DataSelection, String> {
    select_data_until(kept, settings, budget, allow_nonphysical, &Stop::default())
}

/// [`select_data`] whose fits are abandoned when `stop` is requested
/// ([`brdf_fit::FitSettings::fit_until`]; the Python package's Ctrl-C): the selection then
/// ends within moments and its result is meant to be dropped.
pub fn select_data_until(
    kept: &DataDomain,
    settings: &(dyn Fn(ModelKind) -> brdf_fit::FitSettings + Sync),
    budget: f64,
    allow_nonphysical: bool,
    stop: &Stop,
) -> Result<DataSelection, String> {
    let (domain, max_theta_i, max_theta_r) = (&kept.domain, kept.max_theta_i, kept.max_theta_r);
    if domain.points.len() < 7 {
        return Err(format!(
            "{}: only {} points with theta_i <= {max_theta_i} and theta_r <= {max_theta_r} deg; too few to compare models",
            domain.name,
            domain.points.len(),
        ));
    }
    // Representations are judged by relative error over the noise floor the fits use: the
    // floor estimated from readings at or below zero (or given); with none, such a reading
    // leaves the error undefined.
    let noise_floor = brdf_fit::noise::floor_for(settings(TABLE_BASE).noise_floor, &domain.points)
        .map_err(|e| format!("{}: {e}", domain.name))?;
    let floor = noise_floor.as_ref().map_or(0.0, |f| f.value);
    if let Some(p) = domain.points.iter().find(|p| p.brdf <= 0.0 && floor == 0.0) {
        return Err(format!(
            "{}: line {}: brdf {}: select judges representations by relative error, undefined at a \
             zero reading without a noise floor (leave --noise-floor out to estimate one, or give one above 0)",
            domain.name,
            p.line,
            brdf_core::Compact(p.brdf)
        ));
    }
    let mut candidates: Vec<FitReport> = Vec::new();
    let mut notes = Vec::new();
    for &k in ModelKind::LADDER.iter() {
        // A model the data cannot determine is left out, said in the notes; the others are
        // still compared.
        let full = brdf_fit::FitSettings {
            engine: brdf_fit::Engine::Full,
            ..settings(k)
        };
        let fitted = brdf_fit::fit_streamed_until(&full, std::slice::from_ref(domain), stop, |_, _| {});
        match fitted.into_iter().collect::<Result<Vec<_>, _>>() {
            Ok(r) => candidates.extend(r),
            Err(e @ brdf_fit::FitError::Directions { .. }) => {
                notes.push(format!("{}: not fitted: {e}", k.name()))
            }
            Err(e) => return Err(e.to_string()),
        }
    }
    if stop.requested() {
        return Err(format!("{}: the selection was stopped", domain.name));
    }
    let mut reprs = representations(&candidates, domain, floor, &mut notes)?;
    // The fitted table over the base model's fit to the whole domain.
    let with_table = domain.points.len() >= TABLE_MIN_POINTS;
    let mut table_record = None;
    if with_table {
        if let Some(base) = candidates.iter().find(|c| c.model == TABLE_BASE) {
            let params = base
                .params_array()
                .map_err(|p| format!("{}: no parameter `{p}`", base.dataset))?;
            // A base the device cannot take (an uncalibrated reading scale) leaves the table
            // out, said in the notes, as any other unrepresentable fit.
            match table_rung(domain, &params, floor) {
                Ok((rung, record)) => {
                    let coverage = record.coverage;
                    reprs.push(measured(rung, domain, Some(coverage), floor));
                    table_record = Some(record);
                }
                Err(e) => notes.push(format!("{e}; fitted table left out")),
            }
        }
    } else {
        notes.push(format!(
            "fitted table: not offered: {} points, fewer than {TABLE_MIN_POINTS}",
            domain.points.len()
        ));
    }
    cross_validate(domain, settings, with_table, floor, &mut reprs, stop);
    if stop.requested() {
        return Err(format!("{}: the selection was stopped", domain.name));
    }
    let all: Vec<&Rung> = reprs.iter().map(|r| &r.rung).collect();
    // A rung that could not be cross-validated is never within a budget nor the closest.
    let errors: Vec<f64> = reprs
        .iter()
        .map(|r| r.cv_rms_rel.unwrap_or(f64::INFINITY))
        .collect();
    let Choice {
        best,
        closest,
        reason,
    } = choose(
        &all,
        &errors,
        &format!(
            "held-out RMS relative error ({}{})",
            match cv_fold_count(domain.points.len()) {
                k if k == domain.points.len() => "leave-one-out cross-validation".to_owned(),
                k => format!("{k}-fold cross-validation"),
            },
            match floor {
                0.0 => String::new(),
                s => format!(", over the noise floor {} 1/sr", brdf_core::Compact(s)),
            }
        ),
        budget,
        allow_nonphysical,
    );
    let within_budget = best.is_some();
    // `choose` never names a rung without a finite error as the closest.
    let chosen = best.or(closest);
    let mut reason = match (within_budget, chosen) {
        (false, Some(c)) => format!("{reason}; chosen as the most accurate: {}", reprs[c].rung.name),
        _ => reason,
    };
    let unjudged: Vec<&str> = reprs
        .iter()
        .filter(|r| r.cv_rms_rel.is_none())
        .map(|r| r.rung.name.as_str())
        .collect();
    if !unjudged.is_empty() {
        reason.push_str(&format!(
            "; not cross-validated (a fold left too few distinct directions to refit, or no device material): {}",
            unjudged.join(", ")
        ));
    }
    let material = chosen.map(|i| (reprs[i].rung.material, reprs[i].rung.table.clone()));
    let chosen_fit = chosen.and_then(|i| candidates.iter().position(|c| c.model == reprs[i].rung.kind));
    let chosen_table = chosen
        .filter(|&i| reprs[i].rung.material.fitted.is_some())
        .and(table_record);
    Ok(DataSelection {
        dataset: domain.name.clone(),
        budget,
        max_theta_i,
        max_theta_r,
        n: domain.points.len(),
        knn_cv_rms_rel: knn_yardstick(domain, floor),
        noise_floor,
        allow_nonphysical,
        chosen: chosen.map(|i| reprs[i].rung.name.clone()),
        within_budget,
        chosen_fit,
        chosen_table,
        reason,
        notes,
        candidates,
        representations: reprs,
        material,
    })
}

#[cfg(test)]
mod cv_tests {
    use super::*;

    #[test]
    fn folds_are_balanced_fixed_and_not_in_file_order() {
        for n in [7, 10, 49, 50, 213, 1000] {
            // Distinct directions, sorted by incidence as files are.
            let pts: Vec<brdf_fit::Point> = (0..n)
                .map(|i| brdf_fit::Point {
                    theta_i: (i as f64 * 0.07).to_radians(),
                    theta_r: (10.0 + (i % 7) as f64).to_radians(),
                    phi: (i as f64 * 1.3).to_radians(),
                    brdf: 0.1,
                    sigma: None,
                    weight: None,
                    line: i as u64 + 2,
                })
                .collect();
            let f = cv_folds(&pts);
            assert_eq!(f, cv_folds(&pts), "the same points give the same folds");
            let k = cv_fold_count(n);
            assert_eq!(k, if n < CV_LEAVE_ONE_OUT_BELOW { n } else { CV_FOLDS });
            assert!(f.iter().all(|&g| g < k));
            let sizes: Vec<usize> = (0..k).map(|k| f.iter().filter(|&&g| g == k).count()).collect();
            let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
            assert!(hi - lo <= 1, "{n}: {sizes:?}");
            // A file sorted by incidence must not give a fold of consecutive rows.
            let runs = f.windows(2).filter(|w| w[0] == w[1]).count();
            assert!(runs < n / 2 || k == n, "{n}: {runs} neighbours share a fold");
        }
    }
}

#[cfg(test)]
mod unrepresentable_tests {
    use super::*;
    use brdf_fit::{FitRequest, FitSettings, Point};

    /// A fit whose weight no device accepts (an uncalibrated measurement, `kb` = 2e18 on a
    /// fold of Cornell's garnet blue) is left out with a note; it used to abort the whole
    /// selection.
    #[test]
    fn an_unrepresentable_fit_is_left_out_with_a_note() {
        let points: Vec<Point> = (0..40)
            .map(|k| Point {
                theta_i: 0.02 * k as f64,
                theta_r: 0.5 + 0.01 * k as f64,
                phi: 0.1 * k as f64,
                brdf: 0.1 + 0.001 * k as f64,
                sigma: None,
                weight: None,
                line: k + 2,
            })
            .collect();
        let d = Dataset {
            name: "d.csv".into(),
            points,
        };
        let s = FitSettings::from_options(&FitRequest::new(ModelKind::Lambert)).unwrap();
        let mut reports = brdf_fit::fit_all(&s, std::slice::from_ref(&d)).unwrap();
        let mut bad = reports[0].clone();
        bad.params.0[0].1 = 2e18;
        reports.push(bad);
        let mut notes = Vec::new();
        let reprs = representations(&reports, &d, 0.0, &mut notes).unwrap();
        assert_eq!(reprs.len(), 1, "only the good fit's rung");
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("not representable on the device") && notes[0].contains("left out"),
            "{notes:?}"
        );
    }
}
