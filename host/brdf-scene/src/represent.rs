//! "No more model than the data need": the device representations of fitted models (each
//! model of the ladder exact in f32, the six-parameter model's lookup tables), each with its
//! error against measured data over a domain, its cost on the device (`brdf_core::cost`) and
//! on this host, and its size in flash; and the choice among them (`brdf select DATA`). The
//! scene version, judged on σ instead of on data, is [`crate::select`].

use brdf_core::table::{table_accuracy, table_len, SixTable, TABLE_SIZES};
use brdf_core::{Brdf, ModelKind};
use brdf_fit::report::FitReport;
use brdf_fit::Dataset;
use brdf_wire::blob::{Material, MAX_BLOB_LEN};
use serde::Serialize;

/// One way the device could answer lookups for this data.
#[derive(Clone, Debug, Serialize)]
pub struct Representation {
    /// `six exact`, `six table 256`, ...
    pub name: String,
    pub model: &'static str,
    /// Table nodes, if tabulated.
    pub nodes: Option<usize>,
    /// Cortex-M4F instructions per lookup from cosines (`brdf_core::cost`).
    pub device_instructions: u32,
    /// Host nanoseconds per f32 lookup from cosines, measured in this run.
    pub host_ns: f64,
    /// RMS relative error against the data over the domain.
    pub rms_rel: f64,
    /// Largest relative error against the data over the domain.
    pub max_rel: f64,
    /// Max relative error of the table against the exact model at the data points.
    pub table_vs_exact: Option<f64>,
    /// Bytes of a blob holding this representation alone.
    pub blob_bytes: usize,
    /// That blob fits a flash slot (4,096 bytes).
    pub fits_blob: bool,
    /// `f(i, r) = f(r, i)` (the five-parameter model is not reciprocal).
    pub reciprocal: bool,
    /// `f` stays bounded towards the horizon (not so for the five-parameter model, Minnaert
    /// with `k < 1`, the six-parameter models with `c < 0`).
    pub bounded: bool,
}

impl Representation {
    /// Reciprocal and bounded at grazing.
    pub fn physical(&self) -> bool {
        self.reciprocal && self.bounded
    }

    /// Why it is not [`Representation::physical`] (empty when it is).
    pub fn caveat(&self) -> String {
        match (self.reciprocal, self.bounded) {
            (true, true) => String::new(),
            (false, true) => "not reciprocal".into(),
            (true, false) => "unbounded at grazing".into(),
            (false, false) => "not reciprocal, unbounded at grazing".into(),
        }
    }
}

/// The chosen representation (index into `reprs`) and why; or why none.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    /// The cheapest eligible representation within the budget.
    pub best: Option<usize>,
    /// Why it was chosen, or why nothing was.
    pub reason: String,
}

/// Chooses, among `reprs` that fit a flash slot (and, without `allow_nonphysical`, are
/// reciprocal and bounded at grazing), the cheapest per lookup whose RMS relative error meets
/// `budget`: then the smallest in flash, then the most accurate.
pub fn choose(reprs: &[Representation], budget: f64, allow_nonphysical: bool) -> Choice {
    let eligible = |r: &Representation| r.fits_blob && (allow_nonphysical || r.physical());
    let best = reprs
        .iter()
        .enumerate()
        .filter(|(_, r)| r.rms_rel <= budget && eligible(r))
        // Cheapest per lookup, then smallest in flash, then most accurate.
        .min_by(|a, b| {
            (a.1.device_instructions, a.1.blob_bytes, a.1.rms_rel)
                .partial_cmp(&(b.1.device_instructions, b.1.blob_bytes, b.1.rms_rel))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .map(|(i, _)| i);
    let reason =
        match best {
            Some(i) => format!(
            "the cheapest representation on the device ({} Cortex-M4F instructions per lookup) whose RMS \
             relative error over the domain, {:.3}%, meets the {:.2}% budget{}",
            reprs[i].device_instructions,
            100.0 * reprs[i].rms_rel,
            100.0 * budget,
            if allow_nonphysical { "" } else { ", among reciprocal models bounded at grazing" }
        ),
            None => {
                let closest = reprs
                    .iter()
                    .filter(|r| eligible(r))
                    .min_by(|a, b| a.rms_rel.total_cmp(&b.rms_rel));
                let excluded = reprs
                    .iter()
                    .filter(|r| r.rms_rel <= budget && r.fits_blob && !r.physical())
                    .map(|r| format!("{} ({})", r.name, r.caveat()))
                    .collect::<Vec<_>>();
                let mut why = match closest {
                    Some(c) => format!(
                        "nothing meets the {:.2}% budget; the closest is {} at {:.3}%",
                        100.0 * budget,
                        c.name,
                        100.0 * c.rms_rel
                    ),
                    None => "no representation fits a flash slot".to_owned(),
                };
                if !allow_nonphysical && !excluded.is_empty() {
                    why.push_str(&format!(
                        "; within budget but not chosen without --allow-nonphysical: {}",
                        excluded.join(", ")
                    ));
                }
                why
            }
        };
    Choice { best, reason }
}

/// Every representation of every fitted model, with its error against the data over the
/// domain and its cost; and the material (with table bytes) each would be flashed as.
#[allow(clippy::type_complexity)]
pub fn representations(
    reports: &[FitReport],
    domain: &Dataset,
) -> Result<(Vec<Representation>, Vec<(Material, Option<Vec<u8>>)>), String> {
    let mut reprs = Vec::new();
    let mut materials = Vec::new();
    let cos: Vec<[f32; 3]> = domain
        .points
        .iter()
        .map(|p| [p.theta_i.cos() as f32, p.theta_r.cos() as f32, p.phi.cos() as f32])
        .collect();
    let errors = |f: &dyn Fn(&[f32; 3]) -> f64| -> (f64, f64) {
        let rel: Vec<f64> = domain
            .points
            .iter()
            .zip(&cos)
            .map(|(p, c)| ((f(c) - p.brdf) / p.brdf).abs())
            .collect();
        let rms = (rel.iter().map(|r| r * r).sum::<f64>() / rel.len() as f64).sqrt();
        (rms, rel.iter().copied().fold(0.0, f64::max))
    };
    let host_ns = |f: &dyn Fn(&[f32; 3]) -> f32| -> f64 {
        let reps = (200_000 / cos.len()).max(1);
        let t = std::time::Instant::now();
        let mut acc = 0.0f32;
        for _ in 0..reps {
            for c in &cos {
                acc += f(std::hint::black_box(c));
            }
        }
        std::hint::black_box(acc);
        t.elapsed().as_secs_f64() * 1e9 / (reps * cos.len()) as f64
    };
    for r in reports {
        let kind = r.model;
        let params = r
            .params_array()
            .map_err(|p| format!("{}: no parameter `{p}`", r.dataset))?;
        let material =
            Material::from_params(kind, &params).map_err(|e| format!("{}: refused: {e}", r.dataset))?;
        let exact = material.model().map_err(|e| format!("{}: {e}", r.model))?;
        let (reciprocal, bounded) = (exact.reciprocal(), exact.bounded_at_grazing());
        let (rms, max) = errors(&|c| f64::from(exact.eval_cosines(c[0], c[1], c[2])));
        let blob_bytes = brdf_wire::blob::encoded_len(&[material]);
        reprs.push(Representation {
            name: format!("{} exact", r.model),
            model: r.model.name(),
            nodes: None,
            device_instructions: brdf_core::cost::exact_instructions(kind),
            host_ns: host_ns(&|c| exact.eval_cosines(c[0], c[1], c[2])),
            rms_rel: rms,
            max_rel: max,
            table_vs_exact: None,
            blob_bytes,
            fits_blob: blob_bytes <= MAX_BLOB_LEN,
            reciprocal,
            bounded,
        });
        materials.push((material, None));
        // Tables hold mu^c, unbounded at the horizon for c < 0.
        if kind != ModelKind::Six || !bounded {
            continue;
        }
        for nodes in TABLE_SIZES {
            let mut m = material;
            let mut bytes = vec![0u8; table_len(nodes)];
            m.tabulate(nodes, &mut bytes).map_err(|e| format!("{e}"))?;
            let p = m
                .six_params()
                .ok_or_else(|| "six-parameter material".to_owned())?;
            let table = SixTable::new(p, &bytes).map_err(|e| format!("{e}"))?;
            let (rms, max) = errors(&|c| f64::from(table.eval_cosines(c[0], c[1], c[2])));
            let exact64 = brdf_core::SixParam::new(p.widen()).map_err(|e| format!("{e}"))?;
            let vs_exact = table_accuracy(&table, &exact64, cos.iter().copied()).max;
            let blob_bytes = brdf_wire::blob::encoded_len(&[m]);
            reprs.push(Representation {
                name: format!("six table {nodes}"),
                model: r.model.name(),
                nodes: Some(nodes),
                device_instructions: brdf_core::cost::TABLE_INSTRUCTIONS,
                host_ns: host_ns(&|c| table.eval_cosines(c[0], c[1], c[2])),
                rms_rel: rms,
                max_rel: max,
                table_vs_exact: Some(vs_exact),
                blob_bytes,
                fits_blob: blob_bytes <= MAX_BLOB_LEN,
                reciprocal,
                bounded,
            });
            materials.push((m, Some(bytes)));
        }
    }
    Ok((reprs, materials))
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
    let candidates: Vec<FitReport> = ModelKind::LADDER
        .iter()
        .flat_map(|&k| brdf_fit::fit_all(&settings(k), std::slice::from_ref(domain)))
        .collect();
    let (reprs, mut materials) = representations(&candidates, domain)?;
    let Choice { best, reason } = choose(&reprs, budget, allow_nonphysical);
    Ok(DataSelection {
        dataset: domain.name.clone(),
        budget,
        max_theta_i,
        max_theta_r,
        n: domain.points.len(),
        allow_nonphysical,
        chosen: best.map(|i| reprs[i].name.clone()),
        reason,
        candidates,
        representations: reprs,
        material: best.map(|i| materials.swap_remove(i)),
    })
}
