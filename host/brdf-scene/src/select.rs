//! "No more model than the scene needs": per material, the cheapest representation on the
//! device whose σ stays within a budget of the exact model's σ at every aspect.
//!
//! Candidates are the rungs of `brdf select` ([`crate::ladder`]) with the same device costs
//! and the same eligibility rule (physical models only unless `allow_nonphysical`): the model
//! ladder exact in f32 (Lambert, Minnaert, five-parameter, six-parameter, six-cos2) and the
//! six-parameter model's lookup tables of 64, 256 and 1024 nodes. The material's own model keeps its parameters (rounded to f32, as flashed); the
//! other models of the ladder are fitted to the material's exact values at the scene's own
//! queries (relative residuals, each query weighted by its share of its aspect's σ: a
//! systematic sample of at most [`SelectOptions::fit_points`] queries drawn with probability
//! proportional to that share), and tables are built from the six-parameter candidate.
//!
//! Each candidate is judged on its σ, evaluated as the device would (f32, cosines rounded to
//! f32), against the exact f64 σ of the same material's facets: the worst relative error
//! over the aspects that see the material must not exceed the budget. Holding every
//! material's share to the budget holds the whole scene's σ to it too (all shares are
//! non-negative), which the report checks. The chosen set is written as one blob
//! (`brdf_fit::pack::encode`), materials in scene order; when tables would overflow the
//! blob's 4,096 bytes, the material whose next-cheapest eligible alternative costs the fewest
//! extra instructions gives up its table first.

use brdf_core::anneal::check_directions;
use brdf_core::{Geometry, ModelKind, MAX_PARAMS};
use brdf_fit::{fit, FitOptions, Point, Problem, Residual};
use brdf_wire::blob::{encoded_len, Material, MAX_BLOB_LEN, MAX_MATERIALS};
use rayon::prelude::*;
use serde::Serialize;

use crate::eval::{eval_batch, Evaluator};
use crate::ladder::{choose, eligible, rungs, Rung};
use crate::queries::SceneQueries;
use crate::scene::Scene;

/// Settings of a selection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectOptions {
    /// Largest relative σ error at any aspect, e.g. 0.02.
    pub budget: f64,
    /// The search settings of the ladder fits (seed, chains, agreement, hops, annealing).
    pub fit: FitOptions,
    /// Most queries a ladder fit uses.
    pub fit_points: usize,
    /// Sequence number of the blob.
    pub sequence: u32,
    /// Also choose rungs that are not reciprocal or unbounded at grazing
    /// ([`crate::ladder::eligible`]).
    pub allow_nonphysical: bool,
}

/// The default budget of every selection (`brdf select`, `brdf select --scene`, Python's
/// `brdf.select` and `brdf.select_scene`): 2%.
pub const DEFAULT_BUDGET: f64 = 0.02;

impl Default for SelectOptions {
    fn default() -> Self {
        SelectOptions {
            budget: DEFAULT_BUDGET,
            fit: FitOptions::default(),
            fit_points: 2000,
            sequence: 1,
            allow_nonphysical: false,
        }
    }
}

/// One representation a material could be flashed as, with its σ error on the scene.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// The representation (name, model, parameters, cost, bytes, physicality).
    #[serde(flatten)]
    pub rung: Rung,
    /// Largest `|sigma - sigma_exact| / sigma_exact` of this material's share over the
    /// aspects that see it.
    pub worst_sigma_error: f64,
    /// Where (azimuth, elevation in degrees).
    pub worst_at: Option<[f64; 2]>,
    /// RMS of that relative error over the same aspects.
    pub rms_sigma_error: f64,
    /// Within the budget.
    pub within_budget: bool,
    /// May be chosen ([`crate::ladder::eligible`]: fits a slot and, unless non-physical
    /// models are allowed, physical).
    pub eligible: bool,
}

/// The choice for one material.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialChoice {
    /// Index in the scene (and in the blob).
    pub index: usize,
    /// Its part (`*`: the other parts).
    pub part: String,
    /// The material's own model.
    pub model: String,
    /// Queries it receives over the sweep.
    pub queries: usize,
    /// Aspects that see it.
    pub aspects_seen: usize,
    /// Every candidate, cheapest first.
    pub candidates: Vec<Candidate>,
    /// Index into `candidates` of the one written.
    pub chosen: Option<usize>,
    /// Why it was chosen, or why nothing was ([`crate::ladder::choose`]).
    pub reason: String,
    /// Remarks (fits that failed, a material never seen).
    pub notes: Vec<String>,
}

/// The selection for a whole scene.
#[derive(Clone, Debug, Serialize)]
pub struct SceneSelection {
    /// Scene file.
    pub scene: String,
    /// The budget.
    pub budget: f64,
    /// Non-physical rungs could be chosen.
    pub allow_nonphysical: bool,
    /// Aspects.
    pub aspects: usize,
    /// Queries in all.
    pub queries: usize,
    /// Per material.
    pub materials: Vec<MaterialChoice>,
    /// Worst relative error of the whole scene's σ with the chosen set (None if a material
    /// has no choice).
    pub scene_worst_sigma_error: Option<f64>,
    /// Size of the blob, if one could be made.
    pub blob_bytes: Option<usize>,
    /// Why there is no blob.
    pub blob_note: Option<String>,
    #[serde(skip)]
    blob: Option<Vec<u8>>,
}

impl SceneSelection {
    /// The encoded blob of the chosen set (materials in scene order).
    pub fn blob(&self) -> Option<&[u8]> {
        self.blob.as_deref()
    }

    /// The human-readable report `brdf select --scene` prints.
    pub fn write_report(&self, out: &mut dyn std::io::Write) -> std::io::Result<()> {
        writeln!(
            out,
            "{}: {} aspects, {} queries; budget: |sigma - sigma_exact| <= {:.2}% of sigma_exact at every aspect, per material \
             (errors below are relative)",
            self.scene,
            self.aspects,
            self.queries,
            100.0 * self.budget
        )?;
        for m in &self.materials {
            writeln!(out)?;
            writeln!(
                out,
                "material {} `{}` ({}; {} queries at {} aspects)",
                m.index, m.part, m.model, m.queries, m.aspects_seen
            )?;
            writeln!(
                out,
                "  {:<22} {:>15} {:>18} {:>10} {:>7}",
                "representation", "worst sigma err", "at (az, el) deg", "M4F instr", "bytes"
            )?;
            for c in &m.candidates {
                let r = &c.rung;
                let mark = if !r.fits_blob {
                    "  (over a slot)".to_owned()
                } else if !c.eligible {
                    format!("  ({}; not chosen without --allow-nonphysical)", r.caveat())
                } else if !c.within_budget {
                    "  over budget".to_owned()
                } else {
                    String::new()
                };
                writeln!(
                    out,
                    "  {:<22} {:>15} {:>18} {:>10} {:>7}{mark}",
                    r.name,
                    format!("{:.2e}", c.worst_sigma_error),
                    c.worst_at.map_or("-".to_owned(), |[a, e]| format!("({a}, {e})")),
                    r.device_instructions,
                    r.bytes,
                )?;
            }
            for n in &m.notes {
                writeln!(out, "  note: {n}")?;
            }
            match m.chosen {
                Some(i) => {
                    let c = &m.candidates[i];
                    writeln!(
                        out,
                        "  chosen: {} ({} instructions per lookup, worst sigma error {:.2e})",
                        c.rung.name, c.rung.device_instructions, c.worst_sigma_error
                    )?;
                }
                None => writeln!(out, "  no representation meets the budget: {}", m.reason)?,
            }
        }
        writeln!(out)?;
        if let Some(e) = self.scene_worst_sigma_error {
            writeln!(out, "whole scene with the chosen set: worst sigma error {e:.2e}")?;
        }
        match (self.blob_bytes, &self.blob_note) {
            (Some(n), _) => writeln!(out, "blob: {} materials, {n} bytes", self.materials.len())?,
            (None, Some(why)) => writeln!(out, "no blob: {why}")?,
            (None, None) => {}
        }
        Ok(())
    }
}

/// A systematic sample of material `m`'s queries, each drawn with probability proportional to
/// its share of its aspect's σ, as fitting points (exact value; weight = times drawn).
fn fit_sample(
    domain: &SceneQueries,
    m: usize,
    exact: &Evaluator,
    sigma: &[Vec<f64>],
    n: usize,
) -> Vec<Point> {
    let mut all: Vec<(usize, usize, f64, f64)> = Vec::new(); // aspect, query, share, f
    let mut f = Vec::new();
    for (a, per) in domain.batches.iter().enumerate() {
        let b = &per[m];
        if b.is_empty() || sigma[a][m] <= 0.0 {
            continue;
        }
        f.clear();
        f.resize(b.len(), 0.0);
        eval_batch(exact, &b.cos_theta_i, &b.cos_theta_r, &b.cos_phi, &mut f);
        for k in 0..b.len() {
            if f[k] > 0.0 {
                all.push((a, k, b.weight[k] * f[k] / sigma[a][m], f[k]));
            }
        }
    }
    let total: f64 = all.iter().map(|q| q.2).sum();
    let n = n.min(all.len());
    if n == 0 || total <= 0.0 {
        return Vec::new();
    }
    let step = total / n as f64;
    let mut next = step / 2.0;
    let mut acc = 0.0;
    let mut out = Vec::new();
    for &(a, k, share, fv) in &all {
        acc += share;
        let mut count = 0;
        while next < acc {
            count += 1;
            next += step;
        }
        if count > 0 {
            let b = &domain.batches[a][m];
            out.push(Point {
                theta_i: b.cos_theta_i[k].clamp(-1.0, 1.0).acos(),
                theta_r: b.cos_theta_r[k].clamp(-1.0, 1.0).acos(),
                phi: b.cos_phi[k].clamp(-1.0, 1.0).acos(),
                brdf: fv,
                sigma: None,
                weight: Some(f64::from(count)),
                line: 0,
            });
        }
    }
    out
}

/// The rungs of material `m`: its own model with its own parameters (as flashed), or its
/// fitted table as it is; every other model of the ladder fitted to `points`, each with its
/// tables where it has them.
fn drafts(
    scene: &Scene,
    m: usize,
    points: &[Point],
    opts: &SelectOptions,
    notes: &mut Vec<String>,
) -> Vec<Rung> {
    let material = &scene.materials[m];
    let own = &material.model;
    // A fitted table's base, or the band below a wavelength between two bands, is not the
    // material: every model of the ladder is fitted to it.
    let own_kind = (material.table.is_none() && material.upper.is_none()).then(|| own.kind());
    let mut out = Vec::new();
    if let Some(bytes) = material.table.as_ref().filter(|_| material.upper.is_none()) {
        let built = brdf_wire::blob::Material::from_params(own.kind(), &own.to_params())
            .map_err(|e| e.to_string())
            .and_then(|base| base.with_fitted(bytes).map_err(|e| e.to_string()))
            .and_then(|base| crate::ladder::fitted_rung(base, bytes.clone()));
        match built {
            Ok(r) => out.push(r),
            Err(e) => notes.push(e),
        }
    }
    for kind in ModelKind::LADDER {
        let (label, params): (String, [f64; MAX_PARAMS]) = if Some(kind) == own_kind {
            (kind.name().to_owned(), own.to_params())
        } else if points.len() < kind.param_count() + 1 {
            if !points.is_empty() {
                notes.push(format!("{}: too few queries to fit", kind.name()));
            }
            continue;
        } else if let Err(e) = check_directions(
            kind,
            points
                .iter()
                .map(|p| Geometry::<f64>::from_angles(p.theta_i, p.theta_r, p.phi)),
        ) {
            // The rule every fit applies (`brdf_fit::FitSettings::fit`).
            notes.push(format!("{}: not fitted: {e}", kind.name()));
            continue;
        } else {
            let problem = Problem::new(kind, Residual::Relative, points);
            (format!("{} fitted", kind.name()), fit(&problem, &opts.fit).params)
        };
        match rungs(&label, kind, &params) {
            Ok(r) => out.extend(r),
            Err(e) => notes.push(e),
        }
    }
    out
}

/// Whether `scene` can be selected for: at one wavelength only (a blob holds one
/// representation per material); the error names the scene (`brdf select --scene`,
/// `brdf.select_scene`).
pub fn selectable(scene: &Scene) -> Result<(), String> {
    scene.one_wavelength("selecting (a blob holds one representation per material)")
}

/// Chooses, per material of `scene`, the cheapest representation within `opts.budget` over
/// the queries of `domain` (from [`crate::queries::collect_queries`]), and encodes the chosen set.
pub fn select(scene: &Scene, domain: &SceneQueries, opts: &SelectOptions) -> SceneSelection {
    let exact: Vec<Evaluator> = scene.materials.iter().map(|m| m.evaluator()).collect();
    let sigma = domain.sigma(&exact);
    let mut materials = Vec::new();
    for m in 0..scene.materials.len() {
        let mut notes = Vec::new();
        let queries: usize = domain.batches.iter().map(|per| per[m].len()).sum();
        let seen: Vec<usize> = (0..domain.aspects.len()).filter(|&a| sigma[a][m] > 0.0).collect();
        if seen.is_empty() {
            notes.push("seen from no aspect: every representation gives the same (zero) sigma".into());
        }
        let points = fit_sample(domain, m, &exact[m], &sigma, opts.fit_points);
        let drafts = drafts(scene, m, &points, opts, &mut notes);
        // sigma of every candidate at every aspect, in parallel over aspects.
        let cand_sigma: Vec<Vec<f64>> = domain
            .batches
            .par_iter()
            .map_init(Vec::new, |scratch, per| {
                drafts.iter().map(|d| per[m].sigma(&d.eval, scratch)).collect()
            })
            .collect();
        let mut candidates: Vec<Candidate> = drafts
            .into_iter()
            .enumerate()
            .map(|(c, rung)| {
                let (mut worst, mut at, mut sum2) = (0.0f64, None, 0.0);
                for &a in &seen {
                    let e = (cand_sigma[a][c] - sigma[a][m]).abs() / sigma[a][m];
                    let e = if e.is_finite() { e } else { f64::INFINITY };
                    sum2 += e * e;
                    if e > worst || at.is_none() {
                        worst = e;
                        at = Some([domain.aspects[a].azimuth_deg, domain.aspects[a].elevation_deg]);
                    }
                }
                Candidate {
                    worst_sigma_error: worst,
                    worst_at: at,
                    rms_sigma_error: if seen.is_empty() {
                        0.0
                    } else {
                        (sum2 / seen.len() as f64).sqrt()
                    },
                    within_budget: worst <= opts.budget,
                    eligible: eligible(&rung, opts.allow_nonphysical),
                    rung,
                }
            })
            .collect();
        candidates.sort_by(|a, b| {
            (a.rung.device_instructions, a.rung.bytes)
                .cmp(&(b.rung.device_instructions, b.rung.bytes))
                .then(a.worst_sigma_error.total_cmp(&b.worst_sigma_error))
        });
        let rungs_sorted: Vec<&Rung> = candidates.iter().map(|c| &c.rung).collect();
        let errors: Vec<f64> = candidates.iter().map(|c| c.worst_sigma_error).collect();
        let choice = choose(
            &rungs_sorted,
            &errors,
            "worst relative sigma error over the aspects",
            opts.budget,
            opts.allow_nonphysical,
        );
        materials.push(MaterialChoice {
            index: m,
            part: scene.material_label(m),
            model: scene.material_description(m),
            queries,
            aspects_seen: seen.len(),
            candidates,
            chosen: choice.best,
            reason: choice.reason,
            notes,
        });
    }
    let (blob, blob_note) = assemble(&mut materials, opts.sequence);
    let scene_worst_sigma_error = if materials.iter().all(|m| m.chosen.is_some()) {
        let mut worst = 0.0f64;
        for (a, per) in domain.batches.iter().enumerate() {
            let total: f64 = sigma[a].iter().sum();
            if total <= 0.0 {
                continue;
            }
            let mut scratch = Vec::new();
            let got: f64 = materials
                .iter()
                .map(|mc| {
                    let c = &mc.candidates[mc.chosen.unwrap_or(0)];
                    per[mc.index].sigma(&c.rung.eval, &mut scratch)
                })
                .sum();
            worst = worst.max((got - total).abs() / total);
        }
        Some(worst)
    } else {
        None
    };
    SceneSelection {
        scene: scene.file.display().to_string(),
        budget: opts.budget,
        allow_nonphysical: opts.allow_nonphysical,
        aspects: domain.aspects.len(),
        queries: domain.len(),
        materials,
        scene_worst_sigma_error,
        blob_bytes: blob.as_ref().map(Vec::len),
        blob_note,
        blob,
    }
}

/// Encodes the chosen set (`brdf_fit::pack::encode`); if it overflows a slot, trades
/// tables for smaller eligible candidates within the budget.
fn assemble(materials: &mut [MaterialChoice], sequence: u32) -> (Option<Vec<u8>>, Option<String>) {
    if let Some(m) = materials.iter().find(|m| m.chosen.is_none()) {
        return (
            None,
            Some(format!(
                "material {} `{}` has no representation within the budget",
                m.index, m.part
            )),
        );
    }
    if materials.len() > MAX_MATERIALS {
        return (
            None,
            Some(format!("a blob holds at most {MAX_MATERIALS} materials")),
        );
    }
    loop {
        let set: Vec<Material> = materials.iter().map(|m| chosen_rung(m).material).collect();
        if encoded_len(&set) <= MAX_BLOB_LEN {
            break;
        }
        // The cheapest swap (fewest extra instructions) to a smaller choosable candidate.
        let mut best: Option<(usize, usize, u32)> = None;
        for (mi, m) in materials.iter().enumerate() {
            let cur = chosen_rung(m);
            for (ci, c) in m.candidates.iter().enumerate() {
                if c.within_budget && c.eligible && c.rung.bytes < cur.bytes {
                    let extra = c.rung.device_instructions.saturating_sub(cur.device_instructions);
                    if best.is_none_or(|b| extra < b.2) {
                        best = Some((mi, ci, extra));
                    }
                }
            }
        }
        match best {
            Some((mi, ci, _)) => materials[mi].chosen = Some(ci),
            None => {
                return (
                    None,
                    Some(format!(
                        "the chosen representations need {} bytes, more than a slot's {MAX_BLOB_LEN}, and no smaller one meets the budget",
                        encoded_len(&set)
                    )),
                )
            }
        }
    }
    let rungs: Vec<&Rung> = materials.iter().map(chosen_rung).collect();
    let set: Vec<Material> = rungs.iter().map(|r| r.material).collect();
    let tables: Vec<Option<Vec<u8>>> = rungs.iter().map(|r| r.table.clone()).collect();
    match brdf_fit::pack::encode(&set, &tables, sequence) {
        Ok(packed) => (Some(packed.bytes), None),
        Err(e) => (None, Some(format!("cannot encode the blob: {e}"))),
    }
}

/// The rung chosen for `m` (the first candidate when none is: only called once every
/// material has a choice).
fn chosen_rung(m: &MaterialChoice) -> &Rung {
    &m.candidates[m.chosen.unwrap_or(0)].rung
}
