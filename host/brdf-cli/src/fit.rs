//! `brdf fit`: fit a model to one or many datasets.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::anneal::check_directions;
use brdf_core::{Geometry, ModelKind};
use brdf_fit::embedded::fit_embedded;
use brdf_fit::report::{report, FitReport};
use brdf_fit::{fit, Dataset, FitOptions, Problem, Residual};
use clap::Args;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;

use crate::common::{parse_shard, EngineArgs};
use crate::params::parse_kind;

/// Fit a model to measured data: one joint fit across all incidence angles of each dataset.
/// Files are CSV with `theta_i,theta_r,phi,brdf` (degrees, canonical convention) or
/// `theta_i,theta_s,brdf` (signed in-plane, theta_s > 0 forward); optional `sigma` or
/// `weight`; `sample`/`wavelength` columns split a file into datasets.
#[derive(Debug, Args)]
pub struct FitCmd {
    /// Model: six, six-cos2, five, minnaert, lambert.
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
    #[arg(long = "engine", value_enum, default_value_t = EngineKind::Full)]
    engine_kind: EngineKind,
    /// Evaluation budget of the embedded engine (65 to 10,000,000: above its 64-point
    /// screen).
    #[arg(long, default_value_t = brdf_fit::embedded::DEFAULT_BUDGET,
          value_parser = clap::value_parser!(u32).range(65..=10_000_000))]
    budget_evals: u32,
    /// Fit only datasets i with i % N == K (0-based K), for job arrays across machines.
    #[arg(long, value_parser = parse_shard)]
    shard: Option<(usize, usize)>,
    /// Data files.
    #[arg(required = true)]
    data: Vec<PathBuf>,
}

/// Which fitting engine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum EngineKind {
    /// Host engine: annealing chains polished by Levenberg-Marquardt, f64.
    Full,
    /// The on-sensor f32 annealer of brdf-core (relative residuals only).
    Embedded,
}

/// Fits every dataset in parallel, in input order, with a progress bar on a terminal.
pub fn fit_all(
    kind: ModelKind,
    residual: Residual,
    opts: FitOptions,
    datasets: &[Dataset],
) -> Vec<FitReport> {
    fit_all_with(kind, residual, opts, datasets, None).expect("the full engine does not fail")
}

/// [`fit_all`], with the embedded engine when `embedded_budget` is given.
pub fn fit_all_with(
    kind: ModelKind,
    residual: Residual,
    opts: FitOptions,
    datasets: &[Dataset],
    embedded_budget: Option<u32>,
) -> Result<Vec<FitReport>> {
    use std::io::IsTerminal;
    // Only for a person watching: not when results are piped or redirected.
    let watched = std::io::stderr().is_terminal() && std::io::stdout().is_terminal();
    let bar = if datasets.len() > 1 && watched {
        ProgressBar::with_draw_target(Some(datasets.len() as u64), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} datasets, {elapsed} elapsed, eta {eta}")
            .expect("static template"),
    );
    let out: Result<Vec<FitReport>> = datasets
        .par_iter()
        .map(|d| {
            let problem = Problem::from_dataset(kind, residual, d);
            let outcome = match embedded_budget {
                None => fit(&problem, &opts),
                Some(budget) => fit_embedded(kind, d, &problem, budget, opts.seed)?,
            };
            let r = report(d, &problem, &outcome, opts.seed);
            bar.inc(1);
            Ok(r)
        })
        .collect();
    bar.finish_and_clear();
    out
}

impl FitCmd {
    pub fn run(self) -> Result<()> {
        let mut datasets = self.engine.load(&self.data)?;
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
        for d in &datasets {
            // The rule the device's FIT applies too: one distinct direction per parameter.
            let geometries = d
                .points
                .iter()
                .map(|p| Geometry::<f64>::from_angles(p.theta_i, p.theta_r, p.phi));
            check_directions(self.model, geometries).map_err(|e| anyhow!("{}: {e}", d.name))?;
        }
        let embedded = match self.engine_kind {
            EngineKind::Full => None,
            EngineKind::Embedded => {
                if self.engine.residual != crate::common::ResidualArg::Relative {
                    bail!("the embedded engine fits relative residuals only");
                }
                Some(self.budget_evals)
            }
        };
        let reports = fit_all_with(
            self.model,
            self.engine.residual.into(),
            self.engine.fit_options(),
            &datasets,
            embedded,
        )?;
        if let Some(path) = &self.output {
            write_csv(path, &reports).with_context(|| format!("cannot write {}", path.display()))?;
        }
        let stdout = std::io::stdout();
        let mut out = stdout.lock();
        if self.json {
            let text = if reports.len() == 1 {
                serde_json::to_string_pretty(&reports[0])?
            } else {
                serde_json::to_string_pretty(&reports)?
            };
            writeln!(out, "{text}")?;
        } else {
            for r in &reports {
                write_text(&mut out, r)?;
            }
        }
        Ok(())
    }
}

/// One row per dataset: parameters, metrics and the undetermined parameters.
fn write_csv(path: &PathBuf, reports: &[FitReport]) -> Result<()> {
    let mut w = csv::Writer::from_path(path)?;
    let max_k = reports.iter().map(|r| r.k).max().unwrap_or(0);
    let mut header = vec!["dataset".to_owned(), "model".to_owned(), "n".to_owned()];
    for j in 0..max_k {
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
        "seconds",
        "undetermined",
    ] {
        header.push(m.to_owned());
    }
    w.write_record(&header)?;
    for r in reports {
        let mut row = vec![r.dataset.clone(), r.model.to_owned(), r.n.to_string()];
        for j in 0..max_k {
            match r.params.0.get(j) {
                Some((name, v)) => {
                    row.push(name.clone());
                    row.push(format!("{v:.10e}"));
                }
                None => row.extend([String::new(), String::new()]),
            }
        }
        let m = r.metrics;
        for v in [
            m.rmse, m.mse, m.rms_rel, m.max_rel, m.log_rmse, r.aic, r.bic, r.seconds,
        ] {
            row.push(format!("{v:.10e}"));
        }
        let undetermined = r.undetermined();
        row.push(undetermined.join(" "));
        w.write_record(&row)?;
    }
    w.flush()?;
    Ok(())
}

/// The readable form of a report.
pub fn write_text(out: &mut impl Write, r: &FitReport) -> Result<()> {
    writeln!(
        out,
        "{}: model {}, {} points, {} residuals, seed {}, {:.1} ms",
        r.dataset,
        r.model,
        r.n,
        r.residual,
        r.seed,
        r.seconds * 1e3
    )?;
    writeln!(
        out,
        "  {:<6} {:>14} {:>12}  determined by the data?",
        "param", "value", "std. error"
    )?;
    for (name, u) in &r.uncertainty.params.0 {
        let se = u.se.map_or("-".to_owned(), |s| format!("{s:.4e}"));
        let verdict = if u.determined {
            "yes".to_owned()
        } else {
            format!("NO: {}", u.note.as_deref().unwrap_or(""))
        };
        writeln!(out, "  {name:<6} {:>14.6} {se:>12}  {verdict}", u.value)?;
    }
    let m = r.metrics;
    writeln!(
        out,
        "  rmse {:.4e} 1/sr, rms relative {:.3}%, max relative {:.3}%, rmse of ln f {:.4}",
        m.rmse,
        100.0 * m.rms_rel,
        100.0 * m.max_rel,
        m.log_rmse
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
        "  albedo at measured incidences: {} ({})",
        albedos.join(", "),
        if e.albedo_conserves {
            "all <= 1"
        } else {
            "VIOLATES energy conservation"
        }
    )?;
    writeln!(out, "  AIC {:.2}, BIC {:.2}", r.aic, r.bic)?;
    Ok(())
}
