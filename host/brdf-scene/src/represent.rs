//! "No more model than the data need": the device representations of fitted models
//! ([`crate::ladder`]: each model of the ladder exact in f32, the six-parameter model's lookup
//! tables), each with its error against measured data over a domain, its cost on the device
//! (`brdf_core::cost`) and on this host, and its size in flash; and the choice among them
//! (`brdf select DATA`) by the ladder's one rule ([`crate::ladder::choose`]). The scene
//! version, judged on σ instead of on data, is [`crate::select`].

use brdf_core::table::{table_accuracy, SixTable};
use brdf_core::ModelKind;
use brdf_fit::report::FitReport;
use brdf_fit::Dataset;
use brdf_wire::blob::Material;
use serde::Serialize;

use crate::eval::{eval_batch, Evaluator};
use crate::ladder::{choose, rungs, Choice, Rung};

/// One way the device could answer lookups for this data: a rung of the ladder with its
/// error against the data.
#[derive(Clone, Debug, Serialize)]
pub struct Representation {
    /// The representation (name, model, cost, bytes, physicality).
    #[serde(flatten)]
    pub rung: Rung,
    /// Host nanoseconds per f32 lookup from cosines, measured in this run.
    pub host_ns: f64,
    /// RMS relative error against the data over the domain.
    pub rms_rel: f64,
    /// Largest relative error against the data over the domain.
    pub max_rel: f64,
    /// Max relative error of the table against the exact model at the data points.
    pub table_vs_exact: Option<f64>,
}

/// Every representation of every fitted model, with its error against the data over the
/// domain and its cost.
pub fn representations(reports: &[FitReport], domain: &Dataset) -> Result<Vec<Representation>, String> {
    let n = domain.points.len();
    let col = |f: fn(&brdf_fit::Point) -> f64| -> Vec<f64> { domain.points.iter().map(f).collect() };
    let (ci, cr, cp) = (
        col(|p| p.theta_i.cos()),
        col(|p| p.theta_r.cos()),
        col(|p| p.phi.cos()),
    );
    let cos32: Vec<[f32; 3]> = (0..n)
        .map(|k| [ci[k] as f32, cr[k] as f32, cp[k] as f32])
        .collect();
    let mut values = vec![0.0; n];
    let host_ns = |e: &Evaluator, out: &mut Vec<f64>| -> f64 {
        let reps = (200_000 / n.max(1)).max(1);
        let t = std::time::Instant::now();
        for _ in 0..reps {
            eval_batch(e, &ci, &cr, &cp, std::hint::black_box(out));
        }
        t.elapsed().as_secs_f64() * 1e9 / (reps * n.max(1)) as f64
    };
    let mut reprs = Vec::new();
    for r in reports {
        let params = r
            .params_array()
            .map_err(|p| format!("{}: no parameter `{p}`", r.dataset))?;
        let label = r.model.name();
        for rung in rungs(label, r.model, &params).map_err(|e| format!("{}: {e}", r.dataset))? {
            let ns = host_ns(&rung.eval, &mut values);
            let rel: Vec<f64> = values
                .iter()
                .zip(&domain.points)
                .map(|(f, p)| ((f - p.brdf) / p.brdf).abs())
                .collect();
            let rms = (rel.iter().map(|r| r * r).sum::<f64>() / rel.len() as f64).sqrt();
            let max = rel.iter().copied().fold(0.0, f64::max);
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
                rung,
                host_ns: ns,
                rms_rel: rms,
                max_rel: max,
                table_vs_exact,
            });
        }
    }
    Ok(reprs)
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
                self.max_theta_i,
                self.max_theta_r,
                brdf_core::tolerance::ANGLE_FILTER_DEG
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
    pub allow_nonphysical: bool,
    /// The representation chosen, if any meets the budget.
    pub chosen: Option<String>,
    /// Why it was chosen, or why nothing was.
    pub reason: String,
    /// The ladder's fits, simplest first.
    pub candidates: Vec<FitReport>,
    pub representations: Vec<Representation>,
    /// The chosen representation as a device material, with its table bytes if tabulated.
    #[serde(skip)]
    pub material: Option<(Material, Option<Vec<u8>>)>,
}

/// Fits every model of [`ModelKind::LADDER`] to the points `kept` with `settings(kind)`, measures every
/// representation and chooses among them ([`choose`]). Fails with a message naming the
/// dataset when the domain has fewer than 7 points (too few to compare models) or a fitted
/// model cannot become a device material.
pub fn select_data(
    kept: &DataDomain,
    settings: &dyn Fn(ModelKind) -> brdf_fit::FitSettings,
    budget: f64,
    allow_nonphysical: bool,
) -> Result<DataSelection, String> {
    let (domain, max_theta_i, max_theta_r) = (&kept.domain, kept.max_theta_i, kept.max_theta_r);
    if domain.points.len() < 7 {
        return Err(format!(
            "{}: only {} points with theta_i <= {max_theta_i} and theta_r <= {max_theta_r} deg; too few to compare models",
            domain.name,
            domain.points.len(),
        ));
    }
    let mut candidates: Vec<FitReport> = Vec::new();
    for &k in ModelKind::LADDER.iter() {
        candidates.extend(
            brdf_fit::fit_all(&settings(k), std::slice::from_ref(domain)).map_err(|e| e.to_string())?,
        );
    }
    let reprs = representations(&candidates, domain)?;
    let all: Vec<&Rung> = reprs.iter().map(|r| &r.rung).collect();
    let errors: Vec<f64> = reprs.iter().map(|r| r.rms_rel).collect();
    let Choice { best, reason } = choose(
        &all,
        &errors,
        "RMS relative error over the domain",
        budget,
        allow_nonphysical,
    );
    let material = best.map(|i| (reprs[i].rung.material, reprs[i].rung.table.clone()));
    Ok(DataSelection {
        dataset: domain.name.clone(),
        budget,
        max_theta_i,
        max_theta_r,
        n: domain.points.len(),
        allow_nonphysical,
        chosen: best.map(|i| reprs[i].rung.name.clone()),
        reason,
        candidates,
        representations: reprs,
        material,
    })
}
