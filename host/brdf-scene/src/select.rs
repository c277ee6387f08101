//! "No more model than the scene needs": per material, the cheapest representation on the
//! device whose σ stays within a budget of the exact model's σ at every aspect.
//!
//! Candidates are those of `brdf select` with the same device costs
//! (`brdf_core::cost`): the model ladder exact in f32 (Lambert, Minnaert, five-parameter,
//! six-parameter, six-cos2) and the six-parameter model's lookup tables of 64, 256 and 1024
//! nodes. The material's own model keeps its parameters (rounded to f32, as flashed); the
//! other models of the ladder are fitted to the material's exact values at the scene's own
//! queries (relative residuals, each query weighted by its share of its aspect's σ: a
//! systematic sample of at most [`SelectOptions::fit_points`] queries drawn with probability
//! proportional to that share), and tables are built from the six-parameter candidate.
//!
//! Each candidate is judged on its σ, evaluated as the device would (f32, cosines rounded to
//! f32), against the exact f64 σ of the same material's facets: the worst relative error
//! over the aspects that see the material must not exceed the budget. Holding every
//! material's share to the budget holds the whole scene's σ to it too (all shares are
//! non-negative), which the report checks. The chosen set is written as one blob, materials
//! in scene order; when tables would overflow the blob's 4,096 bytes, the material whose
//! next-cheapest alternative costs the fewest extra instructions gives up its table first.

use brdf_core::cost::{exact_instructions, TABLE_INSTRUCTIONS};
use brdf_core::table::{table_len, SixTable, TABLE_SIZES};
use brdf_core::{AnyModel, ModelKind, MAX_PARAMS};
use brdf_fit::{fit, FitOptions, Point, Problem, Residual};
use brdf_wire::blob::{encoded_len, Blob, Material, MAX_BLOB_LEN, MAX_MATERIALS};
use rayon::prelude::*;
use serde::Serialize;

use crate::eval::{eval_batch, Evaluator};
use crate::lrcs::Domain;
use crate::scene::Scene;

/// Settings of a selection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectOptions {
    /// Largest relative σ error at any aspect, e.g. 0.01.
    pub budget: f64,
    /// Seed of the fits.
    pub seed: u64,
    /// Most queries a ladder fit uses.
    pub fit_points: usize,
    /// Sequence number of the blob.
    pub sequence: u32,
}

impl Default for SelectOptions {
    fn default() -> Self {
        SelectOptions {
            budget: 0.01,
            seed: 1,
            fit_points: 2000,
            sequence: 1,
        }
    }
}

/// One representation a material could be flashed as, with its σ error on the scene.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    /// `six exact`, `lambert fitted`, `six table 256`, ...
    pub name: String,
    /// Model.
    pub model: &'static str,
    /// Table nodes, if tabulated.
    pub nodes: Option<usize>,
    /// Parameters as flashed (f32, shown in f64), paper order.
    pub params: Vec<f64>,
    /// Cortex-M4F instructions per lookup from cosines (`brdf_core::cost`).
    pub device_instructions: u32,
    /// Bytes of this material in a blob (model id, parameters, tables).
    pub bytes: usize,
    /// A blob of this material alone fits a flash slot.
    pub fits_blob: bool,
    /// Largest `|sigma - sigma_exact| / sigma_exact` of this material's share over the
    /// aspects that see it.
    pub worst_sigma_error: f64,
    /// Where (azimuth, elevation in degrees).
    pub worst_at: Option<[f64; 2]>,
    /// RMS of that relative error over the same aspects.
    pub rms_sigma_error: f64,
    /// Within the budget.
    pub within_budget: bool,
    #[serde(skip)]
    material: Material,
    #[serde(skip)]
    table: Option<Vec<u8>>,
    #[serde(skip)]
    eval: Evaluator,
}

/// The choice for one material.
#[derive(Clone, Debug, Serialize)]
pub struct MaterialChoice {
    /// Index in the scene (and in the blob).
    pub index: usize,
    /// Its part (`*`: the other parts).
    pub part: String,
    /// The material's own model.
    pub model: &'static str,
    /// Queries it receives over the sweep.
    pub queries: usize,
    /// Aspects that see it.
    pub aspects_seen: usize,
    /// Every candidate, cheapest first.
    pub candidates: Vec<Candidate>,
    /// Index into `candidates` of the one written.
    pub chosen: Option<usize>,
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
                writeln!(
                    out,
                    "  {:<22} {:>15} {:>18} {:>10} {:>7}{}{}",
                    c.name,
                    format!("{:.2e}", c.worst_sigma_error),
                    c.worst_at.map_or("-".to_owned(), |[a, e]| format!("({a}, {e})")),
                    c.device_instructions,
                    c.bytes,
                    if c.fits_blob { "" } else { "  (over a slot)" },
                    if c.within_budget && c.fits_blob {
                        ""
                    } else if c.fits_blob {
                        "  over budget"
                    } else {
                        ""
                    }
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
                        c.name, c.device_instructions, c.worst_sigma_error
                    )?;
                }
                None => writeln!(out, "  no representation meets the budget")?,
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

/// A candidate before it is judged.
struct Draft {
    name: String,
    kind: ModelKind,
    nodes: Option<usize>,
    material: Material,
    table: Option<Vec<u8>>,
    eval: Evaluator,
}

/// The material the device holds for f64 parameters ([`Material::from_params`]) and its f32
/// model, or why not.
fn device_material(kind: ModelKind, p: &[f64; MAX_PARAMS]) -> Result<(Material, AnyModel<f32>), String> {
    let m = Material::from_params(kind, p).map_err(|e| e.to_string())?;
    let model = m.model().map_err(|e| e.to_string())?;
    Ok((m, model))
}

/// A systematic sample of material `m`'s queries, each drawn with probability proportional to
/// its share of its aspect's σ, as fitting points (exact value; weight = times drawn).
fn fit_sample(domain: &Domain, m: usize, exact: &Evaluator, sigma: &[Vec<f64>], n: usize) -> Vec<Point> {
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

/// The candidates of material `m`.
fn drafts(
    scene: &Scene,
    m: usize,
    points: &[Point],
    opts: &SelectOptions,
    notes: &mut Vec<String>,
) -> Vec<Draft> {
    let own = &scene.materials[m].model;
    let own_kind = own.kind();
    let own_params = own.to_params();
    let mut out = Vec::new();
    let mut six: Option<(String, [f64; MAX_PARAMS])> = None;
    for kind in ModelKind::LADDER {
        let (label, params) = if kind == own_kind {
            (format!("{} exact", kind.name()), own_params)
        } else if points.len() < kind.param_count() + 1 {
            if !points.is_empty() {
                notes.push(format!("{}: too few queries to fit", kind.name()));
            }
            continue;
        } else {
            let problem = Problem::new(kind, Residual::Relative, points);
            let o = fit(
                &problem,
                &FitOptions {
                    seed: opts.seed,
                    ..FitOptions::default()
                },
            );
            (format!("{} fitted", kind.name()), o.params)
        };
        match device_material(kind, &params) {
            Ok((material, model)) => {
                if kind == ModelKind::Six {
                    six = Some((label.trim_end_matches(" exact").to_owned(), params));
                }
                out.push(Draft {
                    name: label,
                    kind,
                    nodes: None,
                    material,
                    table: None,
                    eval: Evaluator::Device(model),
                });
            }
            Err(e) => notes.push(format!("{label}: not representable on the device: {e}")),
        }
    }
    if let Some((label, params)) = six {
        for nodes in TABLE_SIZES {
            let Ok((mut material, _)) = device_material(ModelKind::Six, &params) else {
                continue;
            };
            let mut bytes = vec![0u8; table_len(nodes)];
            if let Err(e) = material.tabulate(nodes, &mut bytes) {
                notes.push(format!("{label} table {nodes}: {e}"));
                continue;
            }
            let Some(p) = material.six_params() else { continue };
            let consts = match SixTable::new(p, &bytes) {
                Ok(t) => t.consts(),
                Err(e) => {
                    notes.push(format!("{label} table {nodes}: {e}"));
                    continue;
                }
            };
            out.push(Draft {
                name: format!("{label} table {nodes}"),
                kind: ModelKind::Six,
                nodes: Some(nodes),
                material,
                table: Some(bytes.clone()),
                eval: Evaluator::Table { consts, bytes },
            });
        }
    }
    out
}

/// Chooses, per material of `scene`, the cheapest representation within `opts.budget` over
/// the queries of `domain` (from [`crate::lrcs::domain`]), and encodes the chosen set.
pub fn select(scene: &Scene, domain: &Domain, opts: &SelectOptions) -> SceneSelection {
    let exact: Vec<Evaluator> = scene
        .materials
        .iter()
        .map(|m| Evaluator::Exact(m.model))
        .collect();
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
                drafts
                    .iter()
                    .map(|d| crate::eval::sigma(&d.eval, &per[m], scratch))
                    .collect()
            })
            .collect();
        let mut candidates: Vec<Candidate> = drafts
            .into_iter()
            .enumerate()
            .map(|(c, d)| {
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
                let bytes = d.material.encoded_len();
                Candidate {
                    name: d.name,
                    model: d.kind.name(),
                    nodes: d.nodes,
                    params: d.material.params[..d.kind.param_count()]
                        .iter()
                        .map(|&p| f64::from(p))
                        .collect(),
                    device_instructions: match d.nodes {
                        Some(_) => TABLE_INSTRUCTIONS,
                        None => exact_instructions(d.kind),
                    },
                    bytes,
                    fits_blob: encoded_len(&[d.material]) <= MAX_BLOB_LEN,
                    worst_sigma_error: worst,
                    worst_at: at,
                    rms_sigma_error: if seen.is_empty() {
                        0.0
                    } else {
                        (sum2 / seen.len() as f64).sqrt()
                    },
                    within_budget: worst <= opts.budget,
                    material: d.material,
                    table: d.table,
                    eval: d.eval,
                }
            })
            .collect();
        candidates.sort_by(|a, b| {
            (a.device_instructions, a.bytes)
                .cmp(&(b.device_instructions, b.bytes))
                .then(a.worst_sigma_error.total_cmp(&b.worst_sigma_error))
        });
        let chosen = candidates.iter().position(|c| c.within_budget && c.fits_blob);
        materials.push(MaterialChoice {
            index: m,
            part: scene.material_label(m),
            model: scene.materials[m].model.kind().name(),
            queries,
            aspects_seen: seen.len(),
            candidates,
            chosen,
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
                    crate::eval::sigma(&c.eval, &per[mc.index], &mut scratch)
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
        aspects: domain.aspects.len(),
        queries: domain.len(),
        materials,
        scene_worst_sigma_error,
        blob_bytes: blob.as_ref().map(Vec::len),
        blob_note,
        blob,
    }
}

/// Encodes the chosen set; if it overflows a slot, trades tables for smaller candidates.
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
        let chosen: Vec<Material> = materials
            .iter()
            .map(|m| m.candidates[m.chosen.unwrap_or(0)].material)
            .collect();
        if encoded_len(&chosen) <= MAX_BLOB_LEN {
            break;
        }
        // The cheapest swap (fewest extra instructions) to a smaller candidate within budget.
        let mut best: Option<(usize, usize, u32)> = None;
        for (mi, m) in materials.iter().enumerate() {
            let cur = &m.candidates[m.chosen.unwrap_or(0)];
            for (ci, c) in m.candidates.iter().enumerate() {
                if c.within_budget && c.fits_blob && c.bytes < cur.bytes {
                    let extra = c.device_instructions.saturating_sub(cur.device_instructions);
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
                        encoded_len(&chosen)
                    )),
                )
            }
        }
    }
    let mut list = heapless::Vec::<Material, MAX_MATERIALS>::new();
    let mut tables: Vec<Option<&[u8]>> = Vec::new();
    for m in materials.iter() {
        let c = &m.candidates[m.chosen.unwrap_or(0)];
        let _ = list.push(c.material);
        tables.push(c.table.as_deref());
    }
    let blob = Blob {
        sequence,
        materials: list,
    };
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    match blob.encode_with_tables(&tables, &mut buf) {
        Ok(n) => {
            buf.truncate(n);
            (Some(buf), None)
        }
        Err(e) => (None, Some(format!("cannot encode the blob: {e}"))),
    }
}
