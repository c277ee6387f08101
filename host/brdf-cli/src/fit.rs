//! `brdf fit`: fit a model to one or many datasets.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use brdf_core::ModelKind;
use brdf_fit::report::FitReport;
use brdf_fit::request::{EngineKind, BUDGET_EVALS};
use brdf_fit::{FitError, FitRequest, FitSettings};
use clap::Args;

use crate::common::{limit, named, parse_shard, EngineArgs, Sig};
use crate::params::parse_kind;

/// Fit a model to measured data: one joint fit across all incidence angles of each dataset.
/// Files are CSV with `theta_i,theta_r,phi,brdf` (degrees, canonical convention) or
/// `theta_i,theta_s,brdf` (signed in-plane, theta_s > 0 forward); optional `sigma` or
/// `weight`; `sample`/`wavelength` columns split a file into datasets.
#[derive(Debug, Args)]
pub struct FitCmd {
    /// Model: six, six-cos2, five, ggx, minnaert, lambert.
    #[arg(long, value_parser = parse_kind, default_value = "six")]
    model: ModelKind,
    #[command(flatten)]
    engine: EngineArgs,
    /// Print JSON: one object for one dataset, an array for several.
    #[arg(long)]
    json: bool,
    /// Also write one row per dataset to this CSV file.
    #[arg(long, short = 'o')]
    output: Option<PathBuf>,
    /// Engine: `full` (annealing + Levenberg-Marquardt in f64) or `embedded` (the on-sensor
    /// f32 annealer of brdf-core, fixed memory and budget, run on the host).
    #[arg(long = "engine", value_parser = named::<EngineKind>, default_value_t = EngineKind::Full)]
    engine_kind: EngineKind,
    /// Evaluation budget of the embedded engine (65 to 10,000,000: above its 64-point
    /// screen; default 20,000; embedded engine only).
    #[arg(long, value_parser = limit(BUDGET_EVALS))]
    budget_evals: Option<u64>,
    /// Fit only datasets i with i % N == K (0-based K), for job arrays across machines.
    #[arg(long, value_parser = parse_shard)]
    shard: Option<(usize, usize)>,
    /// Data files.
    #[arg(required = true)]
    data: Vec<PathBuf>,
}

impl FitCmd {
    pub fn run(self) -> Result<()> {
        if let Some(out) = &self.output {
            for d in &self.data {
                if crate::common::same_file(d, out) {
                    bail!(
                        "-o {} is one of the data files: it would be overwritten",
                        out.display()
                    );
                }
            }
        }
        let mut datasets = self.engine.load(&self.data)?;
        if let (Some(_), Some(brdf_fit::spectral::BandShape::Shared)) = (self.shard, self.engine.bands) {
            // A shard would fit its own shape to part of a measurement's bands.
            bail!("--shard splits the bands of a measurement; --bands shared fits them together: give one");
        }
        if let Some((k, n)) = self.shard {
            datasets = datasets
                .into_iter()
                .enumerate()
                .filter(|(i, _)| i % n == k)
                .map(|(_, d)| d)
                .collect();
            if datasets.is_empty() {
                bail!("shard {k}/{n} selects no dataset");
            }
        }
        let settings = FitSettings::from_options(&FitRequest {
            engine: self.engine_kind,
            budget_evals: self.budget_evals,
            ..self.engine.request(self.model)
        })?;
        // Every dataset is checked before any is fitted: a batch fails before it writes, or,
        // with --skip-invalid, leaves out (and lists) the datasets it cannot fit.
        let (datasets, skipped) = brdf_fit::fittable(&settings, datasets, self.engine.skip_invalid)?;
        for s in &skipped {
            eprintln_lossy!("{s}");
        }
        let mut csv = match &self.output {
            Some(path) => {
                let mut w =
                    ResultsCsv::create(path).with_context(|| format!("cannot write {}", path.display()))?;
                // Every dataset has its row: the ones left out first, saying why.
                for s in &skipped {
                    w.skipped_row(s, settings.kind.name())
                        .with_context(|| format!("cannot write {}", path.display()))?;
                }
                Some(w)
            }
            None => None,
        };
        let bar = crate::progress::bar(datasets.len(), "datasets");
        let stdout = std::io::stdout();
        let many = datasets.len() > 1;
        let mut failure: Option<anyhow::Error> = None;
        // In text, the bands of a spectral measurement are tabulated against wavelength after
        // their reports.
        let mut written: Vec<FitReport> = Vec::new();
        let mut write_one = |i: usize, r: &Result<FitReport, FitError>| -> Result<()> {
            bar.inc(1);
            let r = match r {
                Ok(r) => r,
                Err(e) => bail!("{e}"),
            };
            if !self.json && brdf_fit::data::split_wavelength(&r.dataset).is_some() {
                written.push(r.clone());
            }
            if let Some(note) = r.noise_floor.as_ref().and_then(|f| f.note.as_ref()) {
                eprintln_lossy!("warning: {}: {note}", r.dataset);
            }
            for note in &r.search.on_search_box {
                eprintln_lossy!("warning: {}: {note}", r.dataset);
            }
            if let (Some(w), Some(path)) = (csv.as_mut(), &self.output) {
                w.row(r)
                    .with_context(|| format!("cannot write {}", path.display()))?;
            }
            let mut out = stdout.lock();
            if self.json {
                let text = serde_json::to_string_pretty(r)?;
                match (many, i) {
                    (false, _) => writeln!(out, "{text}")?,
                    (true, 0) => write!(out, "[\n{text}")?,
                    (true, _) => write!(out, ",\n{text}")?,
                }
            } else {
                write_text(&mut out, r)?;
            }
            out.flush()?;
            Ok(())
        };
        brdf_fit::fit_streamed(&settings, &datasets, |i, r| {
            if failure.is_none() {
                if let Err(e) = write_one(i, r) {
                    failure = Some(e);
                }
            }
        });
        bar.finish_and_clear();
        if let Some(e) = failure {
            return Err(e);
        }
        if self.json && many {
            writeln!(stdout.lock(), "\n]")?;
        }
        for s in brdf_fit::spectral::spectra(&written) {
            write_spectrum(&mut stdout.lock(), &s)?;
        }
        Ok(())
    }
}

/// A spectral measurement's bands against wavelength: every parameter (the weights, which
/// carry the colour, marked), the albedo at normal incidence and the RMS relative error.
pub fn write_spectrum(out: &mut impl Write, s: &brdf_fit::spectral::Spectrum) -> Result<()> {
    let names = s.model.param_names();
    let weights = s.weight_indices();
    writeln!(
        out,
        "{}: {} bands, {} ({} the weights, per band; the rest the shape)",
        s.measurement,
        s.bands.len(),
        s.model.name(),
        weights.iter().map(|&i| names[i]).collect::<Vec<_>>().join(", ")
    )?;
    write!(out, "  {:>9}", "um")?;
    for (i, n) in names.iter().enumerate() {
        let mark = if weights.contains(&i) { "*" } else { "" };
        write!(out, " {:>11}", format!("{n}{mark}"))?;
    }
    writeln!(out, " {:>11} {:>9}", "albedo 0deg", "rms rel")?;
    for b in &s.bands {
        write!(out, "  {:>9}", brdf_fit::data::wavelength_text(b.wavelength_um))?;
        for v in &b.params {
            write!(out, " {:>11}", Sig(*v))?;
        }
        let albedo = b.albedo_normal.map_or("-".to_owned(), |a| format!("{a:.5}"));
        writeln!(out, " {albedo:>11} {:>8.3}%", 100.0 * b.rms_rel)?;
    }
    Ok(())
}

/// `-o results.csv`: one row per dataset, written as each fit finishes.
struct ResultsCsv {
    w: csv::Writer<std::fs::File>,
    header_done: bool,
}

impl ResultsCsv {
    fn create(path: &std::path::Path) -> Result<Self> {
        Ok(ResultsCsv {
            w: csv::Writer::from_path(path)?,
            header_done: false,
        })
    }

    /// A dataset left out (`--skip-invalid`): its name and points, `converged` false, and why
    /// in `flags`; the fit's columns empty.
    fn skipped_row(&mut self, s: &brdf_fit::SkippedDataset, model: &str) -> Result<()> {
        self.header()?;
        let mut row = vec![s.dataset.clone(), model.to_owned(), s.points.to_string()];
        row.extend(std::iter::repeat_n(String::new(), 12 + 8));
        row.push("false".to_owned());
        row.extend(std::iter::repeat_n(String::new(), 6));
        row.push(format!("not fitted: {}", s.reason));
        self.w.write_record(&row)?;
        self.w.flush()?;
        Ok(())
    }

    /// The header row, once.
    fn header(&mut self) -> Result<()> {
        if !self.header_done {
            let mut header = vec!["dataset".to_owned(), "model".to_owned(), "n".to_owned()];
            for j in 0..6 {
                header.push(format!("p{j}_name"));
                header.push(format!("p{j}"));
            }
            for m in [
                "rmse",
                "mse",
                "rms_rel",
                "max_rel",
                "log_rmse",
                "aic",
                "bic",
                "cost",
                "converged",
                "energy_bound",
                "max_albedo",
                "albedo_conserves",
                "dominant_point_line",
                "seconds",
                "undetermined",
                "flags",
            ] {
                header.push(m.to_owned());
            }
            self.w.write_record(&header)?;
            self.header_done = true;
        }
        Ok(())
    }

    /// Parameters, metrics, cost, convergence, the energy check and the flagged parameters.
    fn row(&mut self, r: &FitReport) -> Result<()> {
        self.header()?;
        let mut row = vec![r.dataset.clone(), r.model.name().to_owned(), r.n.to_string()];
        for j in 0..6 {
            match r.params.0.get(j) {
                Some((name, v)) => {
                    row.push(name.clone());
                    row.push(format!("{v:e}"));
                }
                None => row.extend([String::new(), String::new()]),
            }
        }
        let m = r.metrics;
        for v in [
            m.rmse, m.mse, m.rms_rel, m.max_rel, m.log_rmse, r.aic, r.bic, r.cost,
        ] {
            row.push(format!("{v:e}"));
        }
        row.push(r.converged.to_string());
        row.push(r.energy.bound.map_or(String::new(), |b| format!("{b:e}")));
        let max_albedo = r.energy.albedo.iter().map(|a| a.albedo).fold(f64::NAN, f64::max);
        row.push(format!("{max_albedo:e}"));
        row.push(r.energy.albedo_conserves.to_string());
        row.push(if r.influence.dominant {
            r.influence.points[0].line.to_string()
        } else {
            String::new()
        });
        row.push(format!("{:e}", r.seconds));
        row.push(r.undetermined().join(" "));
        let flags: Vec<String> = r
            .uncertainty
            .params
            .0
            .iter()
            .filter_map(|(n, u)| u.note.as_ref().map(|note| format!("{n}: {note}")))
            .chain(r.outside_ranges.iter().map(|o| format!("{o}: cannot be packed")))
            .chain(r.search.on_search_box.iter().cloned())
            .collect();
        row.push(flags.join("; "));
        self.w.write_record(&row)?;
        self.w.flush()?;
        Ok(())
    }
}

/// The readable form of a report.
pub fn write_text(out: &mut impl Write, r: &FitReport) -> Result<()> {
    let loss = if r.loss.is_linear() {
        String::new()
    } else {
        format!(
            ", {} loss at scale {}",
            r.loss.kind,
            brdf_core::Compact(r.loss.scale)
        )
    };
    writeln!(
        out,
        "{}: model {}{}, {} points, {} residuals{loss}, seed {}, {:.1} ms",
        r.dataset,
        r.model.name(),
        if r.brightening {
            " (brightening: c down to -0.99)"
        } else {
            ""
        },
        r.n,
        r.residual,
        r.seed,
        r.seconds * 1e3
    )?;
    let s = &r.search;
    match &s.not_converged {
        None => {
            let reached = if s.at_cost_floor {
                format!(
                    "the best cost {:e} is at its rounding floor: the data are fitted to rounding, and no search can improve on it; {} of {} chains and hops reached it",
                    r.cost,
                    s.agreeing,
                    s.chains + s.hops
                )
            } else {
                format!(
                    "{} of {} chains and hops reached the best cost",
                    s.agreeing,
                    s.chains + s.hops
                )
            };
            writeln!(
                out,
                "  converged: true ({reached}; {} chains, {} lobe-on probes, {} basin hops)",
                s.chains, s.lobe_probes, s.hops
            )?
        }
        Some(why) => writeln!(out, "  converged: false: {why}")?,
    }
    for note in &s.on_search_box {
        writeln!(out, "  on the search bound: {note}")?;
    }
    if let Some(m) = s.sample {
        writeln!(
            out,
            "  the search ran on {m} of the {} points (drawn by weight and reading); the polish on all of them",
            r.n
        )?;
    }
    writeln!(
        out,
        "  {:<6} {:>14} {:>12}  determined by the data?",
        "param", "value", "std. error"
    )?;
    for (name, u) in &r.uncertainty.params.0 {
        let se = u.se.map_or("-".to_owned(), |s| Sig(s).to_string());
        let verdict = if u.determined {
            "yes".to_owned()
        } else {
            format!("NO: {}", u.note.as_deref().unwrap_or(""))
        };
        writeln!(out, "  {name:<6} {:>14} {se:>12}  {verdict}", Sig(u.value))?;
    }
    let m = r.metrics;
    writeln!(
        out,
        "  rmse {:.4e} 1/sr, rms relative {:.3}%, max relative {:.3}%, rmse of ln f {}",
        m.rmse,
        100.0 * m.rms_rel,
        100.0 * m.max_rel,
        if m.log_rmse.is_nan() {
            // ln of a reading at or below zero (`Metrics::log_rmse`).
            "undefined (readings at or below 0)".to_owned()
        } else {
            format!("{:.4}", m.log_rmse)
        }
    )?;
    for pi in &r.per_incidence {
        writeln!(
            out,
            "    theta_i {:>5.1} deg: {:>4} points, rms relative {:.3}%, max relative {:.3}%",
            pi.theta_i,
            pi.n,
            100.0 * pi.metrics.rms_rel,
            100.0 * pi.metrics.max_rel
        )?;
    }
    for o in &r.outside_ranges {
        writeln!(
            out,
            "  out of range: {o}; no device accepts this fit (brdf pack refuses it)"
        )?;
    }
    let e = &r.energy;
    match e.bound {
        Some(b) => writeln!(
            out,
            "  energy: analytic bound {b:.4} ({})",
            if e.bound_conserves {
                "<= 1, conserves at every incidence"
            } else {
                "> 1, proves nothing"
            }
        )?,
        None => writeln!(out, "  energy: the model has no analytic bound")?,
    }
    let albedos: Vec<String> = e
        .albedo
        .iter()
        .map(|a| format!("{:.1} deg {:.4}", a.theta_i, a.albedo))
        .collect();
    writeln!(
        out,
        "  albedo (measured incidences and 0-89.99 deg): {} ({})",
        albedos.join(", "),
        match (&e.unbounded, e.albedo_conserves) {
            (Some(why), _) => format!("does not conserve energy: {why}"),
            (None, true) => "all <= 1".to_owned(),
            (None, false) => "VIOLATES energy conservation".to_owned(),
        }
    )?;
    let inf = &r.influence;
    if let Some(p) = inf.points.first() {
        writeln!(
            out,
            "  most influential point: line {} (theta_i {:.2}, theta_r {:.2}, phi {:.2}; measured {:.4e}, fitted {:.4e}): \
             refitting without it lowers the cost by {:.1}% (RMS relative error of the rest {:.3}%){}",
            p.line,
            p.theta_i,
            p.theta_r,
            p.phi,
            p.brdf,
            p.model,
            100.0 * p.cost_drop,
            100.0 * p.rms_rel_without,
            if inf.dominant {
                format!(
                    " -- DOMINANT: one point moves the cost by more than {:.1}%; check that reading",
                    100.0 * inf.dominant_above
                )
            } else {
                String::new()
            }
        )?;
    }
    writeln!(out, "  AIC {:.2}, BIC {:.2}", r.aic, r.bic)?;
    Ok(())
}
