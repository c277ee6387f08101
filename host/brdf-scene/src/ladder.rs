//! The device representations a fitted model can be flashed as, and the one rule that says
//! which of them may be chosen: shared by `brdf select DATA` ([`crate::represent`], judged on
//! measured data) and `brdf select --scene` ([`crate::select`], judged on the scene's σ).
//!
//! Every fitted model of the ladder ([`ModelKind::LADDER`]) is a rung exact in f32; a
//! six-parameter model bounded at grazing also gives the lookup tables of
//! [`TABLE_SIZES`] nodes. Each rung carries its device cost (`brdf_core::cost`, Cortex-M4F
//! instructions per lookup from cosines), its bytes and whether it is physical (reciprocal
//! and bounded at grazing: its albedo stays bounded as the incidence approaches the horizon,
//! [`brdf_core::AnyModel::bounded_at_grazing`]). [`eligible`] is the rule: the rung's blob fits a flash slot and,
//! unless non-physical models are allowed, it is physical. [`choose`] picks, among eligible
//! rungs whose error meets the budget, the cheapest per lookup, then the smallest, then the
//! most accurate; when none meets the budget, it names the most accurate eligible one.

use brdf_core::cost::{exact_instructions, FITTED_INSTRUCTIONS, TABLE_INSTRUCTIONS};
use brdf_core::table::{table_len, SixTable, TABLE_SIZES};
use brdf_core::{ModelKind, MAX_PARAMS};
use brdf_wire::blob::{encoded_len, Material, MAX_BLOB_LEN};
use serde::Serialize;

use crate::eval::Evaluator;

/// One way the device could answer a material's lookups.
#[derive(Clone, Debug, Serialize)]
pub struct Rung {
    /// `six exact`, `lambert fitted`, `six table 256`, ...
    pub name: String,
    /// The model.
    pub model: &'static str,
    /// Table nodes, if tabulated.
    pub nodes: Option<usize>,
    /// Parameters as flashed (f32, shown in f64), paper order.
    pub params: Vec<f64>,
    /// Cortex-M4F instructions per lookup from cosines (`brdf_core::cost`).
    pub device_instructions: u32,
    /// Bytes of this material in a blob (model id, parameters, tables).
    pub bytes: usize,
    /// Bytes of a blob holding this material alone.
    pub blob_bytes: usize,
    /// That blob fits a flash slot (4,096 bytes).
    pub fits_blob: bool,
    /// `f(i, r) = f(r, i)` (the five-parameter model is not reciprocal).
    pub reciprocal: bool,
    /// The albedo stays bounded towards the horizon (not so for the five-parameter model,
    /// Minnaert with `k < 1`, the six-parameter models with `c < 0`, whose values and albedos
    /// both grow without bound; the microfacet model's value grows only at the grazing mirror
    /// direction, its albedo stays at most `ks + kd`).
    pub bounded: bool,
    /// The kind, for the code.
    #[serde(skip)]
    pub kind: ModelKind,
    /// The material as flashed (with its table reference, if tabulated).
    #[serde(skip)]
    pub material: Material,
    /// The table's node bytes, if tabulated.
    #[serde(skip)]
    pub table: Option<Vec<u8>>,
    /// How the device evaluates it, as the host reproduces it bit for bit.
    #[serde(skip)]
    pub eval: Evaluator,
}

impl Rung {
    /// Reciprocal and bounded at grazing.
    pub fn physical(&self) -> bool {
        self.reciprocal && self.bounded
    }

    /// Why it is not [`Rung::physical`] (empty when it is).
    pub fn caveat(&self) -> String {
        match (self.reciprocal, self.bounded) {
            (true, true) => String::new(),
            (false, true) => "not reciprocal".into(),
            (true, false) => "unbounded at grazing".into(),
            (false, false) => "not reciprocal, unbounded at grazing".into(),
        }
    }
}

/// The rungs of one fitted model (`label` names it: `six` or `six fitted`): exact in f32 and,
/// for a six-parameter model bounded at grazing, its tables. `Err` says why the parameters
/// cannot become a device material (outside the ranges the device accepts).
pub fn rungs(label: &str, kind: ModelKind, params: &[f64; MAX_PARAMS]) -> Result<Vec<Rung>, String> {
    let material = Material::from_params(kind, params)
        .map_err(|e| format!("{label}: not representable on the device: {e}"))?;
    let exact = material.model().map_err(|e| format!("{label}: {e}"))?;
    let (reciprocal, bounded) = (exact.reciprocal(), exact.bounded_at_grazing());
    let rung =
        |name: String, nodes: Option<usize>, material: Material, table: Option<Vec<u8>>, eval: Evaluator| {
            let blob_bytes = encoded_len(&[material]);
            Rung {
                name,
                model: kind.name(),
                nodes,
                params: material.params[..kind.param_count()]
                    .iter()
                    .map(|&p| f64::from(p))
                    .collect(),
                device_instructions: match nodes {
                    Some(_) => TABLE_INSTRUCTIONS,
                    None => exact_instructions(kind),
                },
                bytes: material.encoded_len(),
                blob_bytes,
                fits_blob: blob_bytes <= MAX_BLOB_LEN,
                reciprocal,
                bounded,
                kind,
                material,
                table,
                eval,
            }
        };
    let mut out = vec![rung(
        format!("{label} exact"),
        None,
        material,
        None,
        Evaluator::Device(exact),
    )];
    // Tables hold mu^c, unbounded at the horizon for c < 0.
    if kind != ModelKind::Six || !bounded {
        return Ok(out);
    }
    let base = label.trim_end_matches(" exact");
    for nodes in TABLE_SIZES {
        let mut m = material;
        let mut bytes = vec![0u8; table_len(nodes)];
        m.tabulate(nodes, &mut bytes)
            .map_err(|e| format!("{base} table {nodes}: {e}"))?;
        let p = m
            .six_params()
            .ok_or_else(|| format!("{base} table {nodes}: not a six-parameter material"))?;
        let consts = SixTable::new(p, &bytes)
            .map_err(|e| format!("{base} table {nodes}: {e}"))?
            .consts();
        out.push(rung(
            format!("{base} table {nodes}"),
            Some(nodes),
            m,
            Some(bytes.clone()),
            Evaluator::Table { consts, bytes },
        ));
    }
    Ok(out)
}

/// The fitted-table rung over `base` (a material whose model is the table's base and which
/// carries the table, [`Material::with_fitted`]) with the table's `bytes`: named
/// `{base model} + table`, reciprocal by construction, bounded where its base is.
pub fn fitted_rung(base: Material, bytes: Vec<u8>) -> Result<Rung, String> {
    let kind = base.kind;
    let label = format!("{} + table", kind.name());
    let model = base.model().map_err(|e| format!("{label}: {e}"))?;
    if base.fitted.map(|f| usize::from(f.len)) != Some(bytes.len()) {
        return Err(format!("{label}: the material does not carry these table bytes"));
    }
    let blob_bytes = encoded_len(&[base]);
    Ok(Rung {
        name: label,
        model: kind.name(),
        nodes: None,
        params: base.params[..kind.param_count()]
            .iter()
            .map(|&p| f64::from(p))
            .collect(),
        device_instructions: exact_instructions(kind) + FITTED_INSTRUCTIONS,
        bytes: base.encoded_len(),
        blob_bytes,
        fits_blob: blob_bytes <= MAX_BLOB_LEN,
        reciprocal: model.reciprocal(),
        bounded: model.bounded_at_grazing(),
        kind,
        material: base,
        table: Some(bytes.clone()),
        eval: Evaluator::Corrected { base: model, bytes },
    })
}

/// The one rule for a budget (`brdf select --budget`, `brdf.select`, `brdf.select_scene`): a
/// finite fraction above 0 (a budget of 0 would ask the f32 path to equal the f64 model) and
/// at most [`MAX_BUDGET`].
pub fn check_budget(budget: f64) -> Result<f64, String> {
    if !(budget.is_finite() && budget > 0.0) {
        return Err(format!("budget {budget} is not a finite fraction greater than 0"));
    }
    if budget > MAX_BUDGET {
        return Err(format!(
            "budget {} is a fraction, {}%, above {} (100%): for {} percent give {}",
            brdf_core::Compact(budget),
            brdf_core::Compact(100.0 * budget),
            brdf_core::Compact(MAX_BUDGET),
            brdf_core::Compact(budget),
            brdf_core::Compact(budget / 100.0)
        ));
    }
    Ok(budget)
}

/// Largest error budget: 1 (100%). Beyond, it is a percentage given as a fraction:
/// `budget=2` meant 2% and was read as 200%.
pub const MAX_BUDGET: f64 = 1.0;

/// The one eligibility rule: the rung's blob fits a flash slot and, without
/// `allow_nonphysical`, the rung is reciprocal and bounded at grazing.
pub fn eligible(r: &Rung, allow_nonphysical: bool) -> bool {
    r.fits_blob && (allow_nonphysical || r.physical())
}

/// The chosen rung (index into the list) and why; or why none.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    /// The cheapest eligible rung within the budget.
    pub best: Option<usize>,
    /// The eligible rung with the smallest error (whether or not it meets the budget).
    pub closest: Option<usize>,
    /// Why it was chosen, or why nothing was.
    pub reason: String,
}

/// Chooses among `rungs` with their `errors` (same order; what the budget bounds, named by
/// `measure`, e.g. "RMS relative error over the domain"): the cheapest eligible rung per
/// lookup whose error meets `budget`, then the smallest in flash, then the most accurate.
pub fn choose(
    rungs: &[&Rung],
    errors: &[f64],
    measure: &str,
    budget: f64,
    allow_nonphysical: bool,
) -> Choice {
    debug_assert_eq!(rungs.len(), errors.len());
    let key = |i: usize| (rungs[i].device_instructions, rungs[i].bytes, errors[i]);
    let best = (0..rungs.len())
        .filter(|&i| errors[i] <= budget && eligible(rungs[i], allow_nonphysical))
        .min_by(|&a, &b| key(a).partial_cmp(&key(b)).unwrap_or(std::cmp::Ordering::Equal));
    // An error that is not finite (a rung that could not be judged) is never the closest.
    let closest = (0..rungs.len())
        .filter(|&i| eligible(rungs[i], allow_nonphysical) && errors[i].is_finite())
        .min_by(|&a, &b| errors[a].total_cmp(&errors[b]));
    let physical_note = if allow_nonphysical {
        ""
    } else {
        ", among reciprocal models whose albedo is bounded at grazing"
    };
    let reason = match best {
        Some(i) => format!(
            "the cheapest representation on the device ({} Cortex-M4F instructions per lookup) whose {measure}, \
             {:.3}%, meets the {:.2}% budget{physical_note}",
            rungs[i].device_instructions,
            100.0 * errors[i],
            100.0 * budget,
        ),
        None => {
            let excluded: Vec<String> = (0..rungs.len())
                .filter(|&i| errors[i] <= budget && rungs[i].fits_blob && !rungs[i].physical())
                .map(|i| format!("{} ({})", rungs[i].name, rungs[i].caveat()))
                .collect();
            let mut why = match closest {
                Some(c) => format!(
                    "nothing meets the {:.2}% budget; the closest is {} at {:.3}%",
                    100.0 * budget,
                    rungs[c].name,
                    100.0 * errors[c]
                ),
                None if (0..rungs.len()).any(|i| eligible(rungs[i], allow_nonphysical)) => {
                    format!("nothing meets the {:.2}% budget, and no representation has a finite {measure}", 100.0 * budget)
                }
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
    Choice {
        best,
        closest,
        reason,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn six(c: f64) -> [f64; MAX_PARAMS] {
        [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, c]
    }

    /// Rungs that could not be judged (infinite error) were offered as "the closest ... at
    /// inf%"; none of them is the closest, and the reason says nothing was judged.
    #[test]
    fn rungs_without_a_finite_error_are_never_the_closest() {
        let r = rungs("six", ModelKind::Six, &six(1.2)).unwrap();
        let refs: Vec<&Rung> = r.iter().collect();
        let c = choose(
            &refs,
            &vec![f64::INFINITY; refs.len()],
            "held-out error",
            0.02,
            false,
        );
        assert_eq!((c.best, c.closest), (None, None));
        assert!(
            c.reason.contains("no representation has a finite held-out error"),
            "{}",
            c.reason
        );
        let mut errors = vec![f64::INFINITY; refs.len()];
        errors[1] = 0.5;
        assert_eq!(choose(&refs, &errors, "e", 0.02, false).closest, Some(1));
    }

    #[test]
    fn a_bounded_six_parameter_model_gives_its_tables_and_a_brightening_one_none() {
        let r = rungs("six", ModelKind::Six, &six(1.2)).unwrap();
        assert_eq!(r.len(), 1 + TABLE_SIZES.len());
        assert!(r.iter().all(Rung::physical));
        assert_eq!(r[1].device_instructions, TABLE_INSTRUCTIONS);
        let b = rungs("six", ModelKind::Six, &six(-0.5)).unwrap();
        assert_eq!(b.len(), 1);
        assert_eq!(b[0].caveat(), "unbounded at grazing");
    }

    #[test]
    fn the_rule_refuses_non_physical_rungs_unless_allowed_and_picks_the_cheapest() {
        let five = rungs("five", ModelKind::Five, &six(0.0)).unwrap();
        let six = rungs("six", ModelKind::Six, &six(1.2)).unwrap();
        let all: Vec<&Rung> = five.iter().chain(&six).collect();
        // The five-parameter model and the exact six-parameter one meet the budget, the tables
        // do not: the physical one is chosen unless non-physical models are allowed.
        let errors: Vec<f64> = all
            .iter()
            .map(|r| if r.nodes.is_some() { 0.5 } else { 0.001 })
            .collect();
        let strict = choose(&all, &errors, "error", 0.01, false);
        assert_eq!(all[strict.best.unwrap()].name, "six exact");
        assert!(!eligible(&five[0], false) && eligible(&five[0], true));
        let loose = choose(&all, &errors, "error", 0.01, true);
        assert_eq!(all[loose.best.unwrap()].model, "five");
        assert!(
            strict.reason.contains("among reciprocal models"),
            "{}",
            strict.reason
        );
        let none = choose(&all, &vec![0.5; all.len()], "error", 0.01, false);
        assert_eq!(none.best, None);
        assert!(none.reason.contains("nothing meets"), "{}", none.reason);
    }
}
