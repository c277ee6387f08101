//! Spectral fits: the bands of one measurement fitted with one shape.
//!
//! A spectral file (`import` of a Cornell spectral file, a CSV with a `wavelength` column)
//! gives one dataset per band, `FILE[wavelength=0.55]`. Fitted band by band the shape
//! parameters jump between neighbouring bands where a band says little about them (dark
//! bands, a weak lobe), although the surface's geometry does not change with wavelength. The
//! dichromatic form shares the **shape** — the nonlinear parameters (`kr`, `b`, `a`, `c`; the
//! microfacet `alpha`, `f0`; Minnaert's `k`) — across the bands of one measurement, and keeps
//! the **weights** the model is linear in (`kb`, `kd`; `rho0`) per band. Variable projection
//! already solves the weights exactly for a shape, band by band, so the shared fit searches
//! the shape alone on the summed cost `F(shape) = sum over bands of min_weights cost_band`:
//!
//! 1. every band's own fit (the full search, in parallel) gives a candidate shape;
//! 2. `F` is evaluated at each candidate; the [`STARTS`] best are polished by Nelder–Mead on
//!    `F` in the search box (each restarted once from where it ended);
//! 3. each band's report is that of its weights at the best shape.
//!
//! "Converged" holds when at least two polishes from different candidates reach the best
//! `F` within [`crate::fit::AGREEMENT`] (or both within the summed cost's rounding floor,
//! [`crate::fit::same_cost`]) and every band's own fit converged; otherwise the
//! reports say why not. Only with the full engine and least squares: a robust loss (whose
//! reweighting the shared polish would not see) and the embedded engine fit bands
//! independently.
//!
//! **Not the default**: judged by held-out error (`cargo run --release -p brdf-fit --example
//! spectral_holdout`), one shape predicts the held-out directions of every band of both
//! bundled paints worse than each band's own fit (median over bands 62.4% against 57.1% for
//! Garnet Red, 41.1% against 40.1% for Krylon Blue, six-parameter model): the bands' shapes
//! differ more than their noise. Sharing is for a device that stores one shape per
//! material, or a spectrum too noisy band by band.

use brdf_core::bands::Located;
use brdf_core::{ModelKind, MAX_PARAMS};
use serde::{Deserialize, Serialize};

use crate::fit::{cost_floor, same_cost, FitOutcome, SearchSummary};
use crate::import::SAME_BAND_UM;
use crate::kernel::{assemble, to_internal, to_natural};
use crate::problem::{nonlinear_indices, Problem};
use crate::report::{FitReport, FittedModel, OneFit};

/// How the bands of one measurement are fitted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BandShape {
    /// One shape for all bands, weights per band.
    Shared,
    /// Every band on its own (the default: it predicts held-out directions better on the
    /// bundled spectral paints, see the module docs).
    #[default]
    Independent,
}

impl brdf_core::names::Named for BandShape {
    const WHAT: &'static str = "bands";
    const ALL: &'static [BandShape] = &[BandShape::Shared, BandShape::Independent];
    /// Name on the command line, in Python and in results.
    fn name(self) -> &'static str {
        match self {
            BandShape::Shared => "shared",
            BandShape::Independent => "independent",
        }
    }
}

brdf_core::named_str!(BandShape);

/// Candidate shapes polished by Nelder–Mead.
pub const STARTS: usize = 3;

/// What a band's report says about the fit it is part of.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BandsInfo {
    /// `shared` or `independent`.
    pub shape: BandShape,
    /// Bands fitted together (this one included).
    pub bands: usize,
    /// The summed cost `F` of all bands at the shared shape (shared fits only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shared_cost: Option<f64>,
}

/// The datasets that are bands of one measurement: groups of indices (in input order) whose
/// names differ only in their `wavelength=` group, two or more bands each.
pub fn families(names: &[&str]) -> Vec<Vec<usize>> {
    let mut out: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, n) in names.iter().enumerate() {
        if let Some((k, _)) = crate::data::split_wavelength(n) {
            match out.iter_mut().find(|(f, _)| *f == k) {
                Some((_, members)) => members.push(i),
                None => out.push((k, vec![i])),
            }
        }
    }
    out.into_iter().map(|(_, m)| m).filter(|m| m.len() > 1).collect()
}

/// The bands of one spectral measurement in a fit-result file, for a consumer that works at
/// a wavelength (`brdf eval --fit` with a `wavelength` column or `--wavelength`, a scene's
/// `[sensor] wavelength_um`, `brdf.eval_fit(..., wavelength=)`).
#[derive(Clone, Debug, PartialEq)]
pub struct BandFits {
    /// The measurement: the dataset name without its wavelength group.
    pub measurement: String,
    /// `(wavelength in µm, the band's fit)`, ascending in wavelength.
    pub bands: Vec<(f64, OneFit)>,
}

/// What a material is at one wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AtWavelength<'a> {
    /// A band's own fit (the wavelength is the band's, within [`SAME_BAND_UM`]).
    Band(&'a OneFit),
    /// Between two neighbouring bands: `f = (1 - weight) f_lower + weight f_upper`, linear in
    /// wavelength (a convex combination, so reciprocity and energy conservation carry over).
    Between {
        /// The band below.
        lower: &'a OneFit,
        /// The band above.
        upper: &'a OneFit,
        /// The upper band's weight, in (0, 1).
        weight: f64,
    },
}

impl BandFits {
    /// The bands of the measurement that fit `index` of `text` belongs to (or of the only
    /// measurement when `index` is `None`); `Ok(None)` when the fits carry no wavelength, or
    /// `index` names a fit without one (a grey material, the same at every wavelength: then
    /// `index` picks a fit as [`FittedModel::one_of`] does). Refused: a `wavelength=` group
    /// that is not a wavelength, a band given twice for one measurement, several
    /// measurements (or bands beside fits without one) without `index`.
    pub fn read(text: &str, origin: &str, index: Option<usize>) -> Result<Option<BandFits>, String> {
        let fits = FittedModel::from_json(text, origin).map_err(|e| e.to_string())?;
        let mut split: Vec<Option<(String, f64)>> = Vec::with_capacity(fits.len());
        for (k, f) in fits.iter().enumerate() {
            let band = match f.dataset.as_deref() {
                Some(name) => crate::data::band_of_name(name)
                    .map_err(|e| format!("{origin}: fit {k}: dataset `{name}`: {e}"))?,
                None => None,
            };
            split.push(band);
        }
        let mut measurements: Vec<&str> = Vec::new();
        for (m, _) in split.iter().flatten() {
            if !measurements.contains(&m.as_str()) {
                measurements.push(m);
            }
        }
        let grey = split.iter().filter(|s| s.is_none()).count();
        if measurements.is_empty() {
            return Ok(None);
        }
        let measurement = match index {
            Some(k) if k >= fits.len() => {
                return Err(format!(
                    "{origin}: holds {} fits; there is no index {k}",
                    fits.len()
                ))
            }
            Some(k) => match &split[k] {
                Some((m, _)) => m.clone(),
                // A fit without a band: the same at every wavelength.
                None => return Ok(None),
            },
            None if measurements.len() == 1 && grey == 0 => measurements[0].to_owned(),
            None => {
                let mut firsts: Vec<String> = measurements
                    .iter()
                    .map(|m| {
                        let k = split.iter().position(|s| s.as_ref().is_some_and(|(n, _)| n == m));
                        format!("{m} (index {})", k.unwrap_or(0))
                    })
                    .collect();
                if grey > 0 {
                    let k = split.iter().position(Option::is_none).unwrap_or(0);
                    firsts.push(format!("{grey} fit(s) without a band (index {k}, ...)"));
                }
                return Err(format!(
                    "{origin}: holds the bands of {} measurement{}{}: say which with the index of \
                     any of its fits: {}",
                    measurements.len(),
                    if measurements.len() == 1 { "" } else { "s" },
                    if grey > 0 { " and fits without a band" } else { "" },
                    firsts.join(", ")
                ));
            }
        };
        let mut bands: Vec<(f64, OneFit)> = Vec::new();
        for (k, s) in split.iter().enumerate() {
            let Some((m, um)) = s else { continue };
            if *m != measurement {
                continue;
            }
            if let Some((_, other)) = bands.iter().find(|(w, _)| (w - um).abs() < SAME_BAND_UM) {
                return Err(format!(
                    "{origin}: fits {} and {k} are both of {measurement} at {} µm: one fit per band",
                    other.index,
                    crate::data::wavelength_text(*um)
                ));
            }
            let fit = FittedModel::one_of(text, origin, Some(k))?;
            bands.push((*um, fit));
        }
        bands.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(Some(BandFits { measurement, bands }))
    }

    /// `31 bands of FILE (0.4–0.7 µm)`, for messages that ask for a wavelength.
    pub fn describe(&self) -> String {
        let text = crate::data::wavelength_text;
        let (lo, hi) = (self.bands[0].0, self.bands[self.bands.len() - 1].0);
        format!(
            "{} bands of {} ({}–{} µm)",
            self.bands.len(),
            self.measurement,
            text(lo),
            text(hi)
        )
    }

    /// The material at `um` µm: a band's fit, or the two bands around it with the upper one's
    /// weight. Refused outside the measured bands (no extrapolation), naming them.
    pub fn at(&self, um: f64) -> Result<AtWavelength<'_>, String> {
        let text = crate::data::wavelength_text;
        let (lo, hi) = (self.bands[0].0, self.bands[self.bands.len() - 1].0);
        if !crate::data::is_wavelength(um) {
            return Err(format!("wavelength {um} µm is not a wavelength above 0"));
        }
        let centres: Vec<f64> = self.bands.iter().map(|b| b.0).collect();
        match brdf_core::bands::locate(&centres, um) {
            Ok(Located::Band(k)) => Ok(AtWavelength::Band(&self.bands[k].1)),
            Ok(Located::Between { lower, weight }) => Ok(AtWavelength::Between {
                lower: &self.bands[lower].1,
                upper: &self.bands[lower + 1].1,
                weight,
            }),
            Err(_) => {
                let range = match self.bands.len() {
                    1 => format!("its only band is {} µm", text(lo)),
                    n => format!("its {n} bands span {}–{} µm", text(lo), text(hi)),
                };
                Err(format!(
                    "{} µm is outside the bands of {}: {range} (a BRDF is not extrapolated in wavelength)",
                    text(um),
                    self.measurement
                ))
            }
        }
    }
}

/// The summed projected cost of `problems` at nonlinear parameters `nl`, and each band's
/// weights there.
fn shared_cost(problems: &[&Problem], nl: &[f64]) -> (f64, Vec<[f64; 2]>) {
    let mut total = 0.0;
    let mut lins = Vec::with_capacity(problems.len());
    for p in problems {
        let (lin, cost) = p.project(nl);
        total += cost;
        lins.push(lin);
    }
    (total, lins)
}

/// Nelder–Mead on `f` over the unit cube (coordinates clamped into it), from `x0`; returns the
/// best point, its value, and whether the simplex met the tolerance — the simplex's values
/// within `tol` of the best, relative, or within `floor` of it (the cost's rounding floor:
/// values that are rounding noise, 1e-30 against 3e-30, never agree relatively), and its size
/// under 1e-9 — (not the iteration limit or a stop).
fn nelder_mead(
    f: &dyn Fn(&[f64]) -> f64,
    x0: &[f64],
    tol: f64,
    floor: f64,
    stop: &dyn Fn() -> bool,
) -> (Vec<f64>, f64, bool) {
    let d = x0.len();
    let clamp = |x: Vec<f64>| -> Vec<f64> { x.into_iter().map(|v| v.clamp(0.0, 1.0)).collect() };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(d + 1);
    simplex.push((x0.to_vec(), f(x0)));
    for j in 0..d {
        let mut x = x0.to_vec();
        x[j] += if x[j] > 0.5 { -0.05 } else { 0.05 };
        let fx = f(&x);
        simplex.push((x, fx));
    }
    let mut met = false;
    for _ in 0..400 * d.max(1) {
        if stop() {
            break;
        }
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (simplex[0].1, simplex[d].1);
        let size = simplex[1..]
            .iter()
            .flat_map(|(x, _)| x.iter().zip(&simplex[0].0).map(|(a, b)| (a - b).abs()))
            .fold(0.0_f64, f64::max);
        let spread = (worst - best).abs();
        if (spread <= tol * best.abs().max(f64::MIN_POSITIVE) || spread <= floor) && size < 1e-9 {
            met = true;
            break;
        }
        let centroid: Vec<f64> = (0..d)
            .map(|j| simplex[..d].iter().map(|(x, _)| x[j]).sum::<f64>() / d as f64)
            .collect();
        let along = |t: f64| -> Vec<f64> {
            clamp(
                centroid
                    .iter()
                    .zip(&simplex[d].0)
                    .map(|(c, w)| c + t * (c - w))
                    .collect(),
            )
        };
        let xr = along(1.0);
        let fr = f(&xr);
        if fr < simplex[0].1 {
            let xe = along(2.0);
            let fe = f(&xe);
            simplex[d] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[d - 1].1 {
            simplex[d] = (xr, fr);
        } else {
            let xc = along(if fr < simplex[d].1 { 0.5 } else { -0.5 });
            let fc = f(&xc);
            if fc < simplex[d].1.min(fr) {
                simplex[d] = (xc, fc);
            } else {
                let x0 = simplex[0].0.clone();
                for (x, fx) in simplex.iter_mut().skip(1) {
                    *x = x.iter().zip(&x0).map(|(a, b)| b + 0.5 * (a - b)).collect();
                    *fx = f(x);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, fx) = simplex.swap_remove(0);
    (x, fx, met)
}

/// Relative spread of the simplex's values under which the shape polish has converged, for
/// small data (the summed cost's rounding sets it for large data, and its rounding floor
/// [`cost_floor`] an absolute spread for costs that are rounding noise: see [`share`]); far below
/// [`crate::fit::AGREEMENT`], so that two polishes that met it and agree are one optimum.
pub const SIMPLEX_TOL: f64 = 1e-13;

/// The shared-shape fit of `problems` (the bands of one measurement, same model and settings)
/// from their own fits `own` (one outcome per band): one outcome per band, each with its
/// weights at the best shape, and the summed cost there.
pub fn share(problems: &[&Problem], own: &[FitOutcome]) -> (Vec<FitOutcome>, f64) {
    let started = std::time::Instant::now();
    let kind: ModelKind = problems[0].kind();
    let idx = nonlinear_indices(kind);
    let (lo, hi) = problems[0].bounds();
    let d = idx.len();
    let to_u = |q: &[f64; MAX_PARAMS]| -> Vec<f64> {
        idx.iter()
            .map(|&j| ((q[j] - lo[j]) / (hi[j] - lo[j])).clamp(0.0, 1.0))
            .collect()
    };
    let to_nl = |u: &[f64]| -> Vec<f64> {
        idx.iter()
            .zip(u)
            .map(|(&j, &v)| lo[j] + (hi[j] - lo[j]) * v)
            .collect()
    };
    let evals = std::cell::Cell::new(0usize);
    let f = |u: &[f64]| {
        evals.set(evals.get() + 1);
        shared_cost(problems, &to_nl(u)).0
    };
    let stop = || problems.iter().any(|p| p.stopped());
    // The summed cost of n points carries rounding up to about n epsilon of itself: a
    // tolerance of 1e-13 alone was below it from some 80,000 points (two bands of 40,000)
    // and a fit that had reached the optimum met the iteration limit instead.
    let points: usize = problems.iter().map(|p| p.len()).sum();
    let tol = SIMPLEX_TOL.max(points as f64 * f64::EPSILON);
    // The summed cost's rounding floor: shapes that all fit to rounding are one optimum, for
    // the simplex's test as for the polishes' agreement.
    let floor: f64 = problems.iter().map(|p| cost_floor(p)).sum();
    // Candidates: every band's own shape, ranked by the summed cost.
    let mut candidates: Vec<(Vec<f64>, f64)> = own
        .iter()
        .map(|o| {
            let u = to_u(&to_internal(kind, &o.params[..kind.param_count()]));
            let fu = f(&u);
            (u, fu)
        })
        .collect();
    candidates.sort_by(|a, b| a.1.total_cmp(&b.1));
    candidates.dedup_by(|a, b| a.0 == b.0);
    if candidates.len() < 2 && d > 0 {
        // Every band's own shape the same: a second start a tenth of the box away, so that
        // two searches can agree.
        let u: Vec<f64> = candidates[0]
            .0
            .iter()
            .map(|v| if *v > 0.5 { v - 0.1 } else { v + 0.1 })
            .collect();
        let fu = f(&u);
        candidates.push((u, fu));
    }
    let polished: Vec<(Vec<f64>, f64, bool)> = if d == 0 {
        vec![(Vec::new(), candidates[0].1, true)]
    } else {
        candidates
            .iter()
            .take(STARTS)
            .map(|(u, _)| {
                // Restarted once from its own end: a simplex that collapsed early moves on.
                let (u1, _, _) = nelder_mead(&f, u, tol, floor, &stop);
                nelder_mead(&f, &u1, tol, floor, &stop)
            })
            .collect()
    };
    let best = polished
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .expect("at least one candidate");
    let agreeing = polished.iter().filter(|p| same_cost(p.1, best.1, floor)).count();
    let nl = to_nl(&best.0);
    let (_, lins) = shared_cost(problems, &nl);
    let why_not = if stop() {
        Some("the fit was stopped before its search ended".to_owned())
    } else if let Some(k) = own.iter().position(|o| !o.converged) {
        Some(format!(
            "band {} of {}: its own fit, a candidate shape, did not converge",
            k + 1,
            own.len()
        ))
    } else if d > 0 && agreeing < 2 {
        // One candidate (every band's own shape the same) is one search: not an agreement.
        Some(format!(
            "{agreeing} of {} shape polishes from different bands' shapes reached the best \
             summed cost (two must)",
            polished.len()
        ))
    } else if !best.2 {
        Some("the shape polish met its iteration limit".to_owned())
    } else {
        None
    };
    let seconds = started.elapsed().as_secs_f64();
    let outcomes: Vec<FitOutcome> = problems
        .iter()
        .zip(&lins)
        .zip(own)
        .map(|((p, lin), o)| {
            let mut q = assemble(kind, &nl, *lin);
            for j in 0..kind.param_count() {
                q[j] = q[j].clamp(lo[j], hi[j]);
            }
            FitOutcome {
                kind,
                q,
                params: to_natural(kind, &q[..kind.param_count()]),
                cost: p.cost(&q),
                chain_costs: polished.iter().map(|p| p.1).collect(),
                evals: o.evals + evals.get(),
                converged: why_not.is_none(),
                search: SearchSummary {
                    chains: o.search.chains,
                    lobe_probes: o.search.lobe_probes,
                    hops: o.search.hops,
                    agreeing,
                    at_cost_floor: best.1 <= floor,
                    not_converged: why_not.clone(),
                    sample: o.search.sample,
                    on_search_box: Vec::new(),
                },
                seconds: o.seconds + seconds,
            }
        })
        .collect();
    // The summed cost as the bands' reports state theirs (after the weights are held in
    // their boxes: the five-parameter `kd` is a ratio clamped to [0, 10]).
    let total = outcomes.iter().map(|o| o.cost).sum();
    (outcomes, total)
}

/// The bands info of the reports of a family fitted with `shape` (see [`BandsInfo`]).
pub fn mark(reports: &mut [FitReport], shape: BandShape, shared_cost: Option<f64>) {
    let bands = reports.len();
    for r in reports {
        r.bands = Some(BandsInfo {
            shape,
            bands,
            shared_cost,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit-result array of Lambertian fits, one per `(dataset, rho0)`.
    fn fits(items: &[(&str, f64)]) -> String {
        let one = |(d, r): &(&str, f64)| {
            format!(r#"{{"dataset": "{d}", "model": "lambert", "params": {{"rho0": {r}}}}}"#)
        };
        format!("[{}]", items.iter().map(one).collect::<Vec<_>>().join(","))
    }

    #[test]
    fn bands_are_picked_or_interpolated_by_wavelength_and_never_extrapolated() {
        let text = fits(&[
            ("a.csv[wavelength=0.5]", 0.5),
            ("a.csv[wavelength=0.6]", 0.6),
            ("b.csv[wavelength=0.5]", 0.9),
            ("a.csv[wavelength=0.4]", 0.4),
        ]);
        let e = BandFits::read(&text, "f.json", None).unwrap_err();
        assert!(
            e.contains("2 measurements") && e.contains("b.csv (index 2)"),
            "{e}"
        );
        let bands = BandFits::read(&text, "f.json", Some(3)).unwrap().unwrap();
        assert_eq!(bands.measurement, "a.csv");
        let w: Vec<f64> = bands.bands.iter().map(|b| b.0).collect();
        assert_eq!(w, [0.4, 0.5, 0.6]);
        let rho = |f: &OneFit| f.params[0];
        match bands.at(0.4 + 1e-7).unwrap() {
            AtWavelength::Band(f) => assert_eq!((rho(f), f.index), (0.4, 3)),
            other => panic!("{other:?}"),
        }
        match bands.at(0.575).unwrap() {
            AtWavelength::Between { lower, upper, weight } => {
                assert_eq!((rho(lower), rho(upper)), (0.5, 0.6));
                assert!((weight - 0.75).abs() < 1e-12, "{weight}");
            }
            other => panic!("{other:?}"),
        }
        for bad in [0.3999, 0.61, 0.0, -0.5, f64::NAN] {
            assert!(bands.at(bad).is_err(), "{bad}");
        }
        assert!(bands.at(0.7).unwrap_err().contains("3 bands span 0.4–0.6 µm"));
        // One band: only its own wavelength.
        let one = BandFits::read(&text, "f.json", Some(2)).unwrap().unwrap();
        assert!(one.at(0.55).unwrap_err().contains("only band is 0.5 µm"));
        // Grey fits: none. A band given twice, or an index of a fit without a band: refused.
        assert_eq!(
            BandFits::read(&fits(&[("a.csv", 0.5)]), "f.json", None).unwrap(),
            None
        );
        let twice = fits(&[("a.csv[wavelength=0.5]", 0.5), ("a.csv[wavelength=0.50]", 0.6)]);
        assert!(BandFits::read(&twice, "f.json", None)
            .unwrap_err()
            .contains("one fit per band"));
        // Bands beside a fit without one: which is meant must be said; the index of the fit
        // without a band picks it (grey), which was refused.
        let mixed = fits(&[("a.csv[wavelength=0.5]", 0.5), ("c.csv", 0.6)]);
        let e = BandFits::read(&mixed, "f.json", None).unwrap_err();
        assert!(e.contains("fits without a band") && e.contains("index 1"), "{e}");
        assert_eq!(BandFits::read(&mixed, "f.json", Some(1)).unwrap(), None);
        assert!(BandFits::read(&mixed, "f.json", Some(0)).unwrap().is_some());
        assert!(BandFits::read(&mixed, "f.json", Some(2))
            .unwrap_err()
            .contains("no index 2"));
        // A `wavelength=` group that is not a wavelength was taken for no band.
        for bad in ["NaN", "-0.5", "0", "inf", "", "1e400", "0.5nm"] {
            let text = fits(&[
                (&format!("a.csv[wavelength={bad}]"), 0.5),
                ("a.csv[wavelength=0.6]", 0.6),
            ]);
            let e = BandFits::read(&text, "f.json", None).unwrap_err();
            assert!(
                e.contains("fit 0") && e.contains(&format!("`wavelength={bad}`")),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn families_are_the_bands_of_one_file_and_sample() {
        let names = [
            "a.csv[wavelength=0.4]",
            "b.csv",
            "a.csv[wavelength=0.5]",
            "a.csv[sample=x,wavelength=0.4]",
            "a.csv[sample=x,wavelength=0.5]",
            "a.csv[sample=y,wavelength=0.4]",
            "c.csv[wavelength=0.4]",
            "a.csv[sample=x]",
        ];
        assert_eq!(families(&names), vec![vec![0, 2], vec![3, 4]]);
    }

    /// A cost that is rounding noise near its minimum (values `NOISE` apart at random, as a
    /// noise-free fit's summed cost is: 1e-30 against 3e-30) over four shape parameters:
    /// the simplex shrinks to below 1e-9 but its values never come within `SIMPLEX_TOL` of
    /// each other, and the polish met its iteration limit at the optimum. Within the cost's
    /// rounding floor (here ten times the noise) the values are one optimum.
    #[test]
    fn nelder_mead_converges_on_a_cost_that_is_rounding_noise() {
        const NOISE: f64 = 1e-30;
        let f = |x: &[f64]| {
            let mut h = 0x9e37_79b9_7f4a_7c15_u64;
            for v in x {
                h = (h ^ v.to_bits()).wrapping_mul(0xbf58_476d_1ce4_e5b9);
                h ^= h >> 31;
            }
            let bowl: f64 = x.iter().map(|v| (v - 0.4).powi(2)).sum();
            NOISE * (1.0 + (h >> 11) as f64 / (1_u64 << 53) as f64 + bowl)
        };
        let x0 = [0.5; 4];
        let (_, _, met) = nelder_mead(&f, &x0, SIMPLEX_TOL, 0.0, &|| false);
        assert!(!met, "with no floor the relative test cannot hold");
        let (_, fx, met) = nelder_mead(&f, &x0, SIMPLEX_TOL, 10.0 * NOISE, &|| false);
        assert!(met, "{fx:e}");
        // A floor never ends a polish whose simplex has not shrunk: far from the minimum of
        // a smooth cost below the floor, it still finds the minimum.
        let g = |x: &[f64]| NOISE * ((x[0] - 0.3).powi(2) + 10.0 * (x[1] - 0.7).powi(2));
        let (x, _, met) = nelder_mead(&g, &[0.9, 0.1], SIMPLEX_TOL, 10.0 * NOISE, &|| false);
        assert!(
            met && (x[0] - 0.3).abs() < 1e-3 && (x[1] - 0.7).abs() < 1e-3,
            "{x:?}"
        );
    }

    #[test]
    fn nelder_mead_finds_a_smooth_minimum_in_the_box() {
        let f = |x: &[f64]| (x[0] - 0.3).powi(2) + 10.0 * (x[1] - 0.7).powi(2) + 1.0;
        let (x, fx, met) = nelder_mead(&f, &[0.9, 0.1], SIMPLEX_TOL, 0.0, &|| false);
        assert!(met && (fx - 1.0).abs() < 1e-12, "{fx}");
        assert!((x[0] - 0.3).abs() < 1e-5 && (x[1] - 0.7).abs() < 1e-5, "{x:?}");
        // A minimum outside the box ends on its face.
        let g = |x: &[f64]| (x[0] + 1.0).powi(2) + (x[1] - 0.5).powi(2);
        let (x, _, _) = nelder_mead(&g, &[0.5, 0.5], SIMPLEX_TOL, 0.0, &|| false);
        assert!(x[0] == 0.0 && (x[1] - 0.5).abs() < 1e-5, "{x:?}");
    }
}

/// One band of a measurement's [`Spectrum`].
#[derive(Clone, Debug, PartialEq)]
pub struct SpectrumBand {
    /// Centre, µm.
    pub wavelength_um: f64,
    /// Index of the band's report among those given to [`spectra`].
    pub fit: usize,
    /// Parameters in paper order.
    pub params: Vec<f64>,
    /// Directional-hemispherical reflectance at normal incidence (the report's energy check),
    /// if the report has it.
    pub albedo_normal: Option<f64>,
    /// RMS relative error over the band's readings (floored as the fit weighed them).
    pub rms_rel: f64,
}

/// A spectral measurement's fits against wavelength: what `brdf fit` tabulates after the
/// bands' reports and `brdf plot spectrum` draws.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum {
    /// The measurement (dataset name without its wavelength group).
    pub measurement: String,
    /// The model of every band.
    pub model: ModelKind,
    /// The bands, ascending in wavelength.
    pub bands: Vec<SpectrumBand>,
}

impl Spectrum {
    /// Indices of the parameters each band has its own of in a shared-shape fit ([`share`]),
    /// which carry a surface's colour; the others are its shape. They are the weights the
    /// model is linear in ([`ModelKind::linear_params`]: `kb`, `kd`; `rho0`; `ks`, `kd`) and,
    /// for the five-parameter model, `kd`, the diffuse part's ratio inside `kb`: the shared
    /// fit solves `kb` and `kb kd` per band ([`crate::problem::projected_ratios`]).
    pub fn weight_indices(&self) -> Vec<usize> {
        let shape = crate::problem::nonlinear_indices(self.model);
        (0..self.model.param_count())
            .filter(|i| !shape.contains(i))
            .collect()
    }
}

/// The spectra among `reports`: every measurement with at least two bands (datasets named
/// `FILE[wavelength=...]`) fitted with one model, in order of first appearance. Bands of a
/// measurement fitted with different models, or a band given twice (the same file fitted
/// twice), make no spectrum.
pub fn spectra(reports: &[FitReport]) -> Vec<Spectrum> {
    let mut out: Vec<Spectrum> = Vec::new();
    let mut mixed: Vec<String> = Vec::new();
    for (k, r) in reports.iter().enumerate() {
        let Some((measurement, um)) = crate::data::split_wavelength(&r.dataset) else {
            continue;
        };
        let band = SpectrumBand {
            wavelength_um: um,
            fit: k,
            params: r.params.0.iter().map(|(_, v)| *v).collect(),
            albedo_normal: r
                .energy
                .albedo
                .iter()
                .find(|a| a.theta_i == 0.0)
                .map(|a| a.albedo),
            rms_rel: r.metrics.rms_rel,
        };
        match out.iter_mut().find(|s| s.measurement == measurement) {
            Some(s)
                if s.bands
                    .iter()
                    .any(|b| (b.wavelength_um - um).abs() < SAME_BAND_UM) =>
            {
                mixed.push(measurement)
            }
            Some(s) if s.model == r.model => s.bands.push(band),
            Some(_) => mixed.push(measurement),
            None => out.push(Spectrum {
                measurement,
                model: r.model,
                bands: vec![band],
            }),
        }
    }
    out.retain(|s| s.bands.len() >= 2 && !mixed.contains(&s.measurement));
    for s in &mut out {
        s.bands
            .sort_by(|a, b| a.wavelength_um.total_cmp(&b.wavelength_um));
    }
    out
}
