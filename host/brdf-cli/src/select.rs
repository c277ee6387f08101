//! `brdf select`: the simplest model of the family that meets an error budget.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Result};
use brdf_core::ModelKind;
use brdf_fit::report::FitReport;
use brdf_fit::Dataset;
use clap::Args;
use serde::Serialize;

use crate::common::{parse_fraction, EngineArgs};
use crate::fit::fit_all;

/// The model ladder, simplest first: Lambert (1 parameter), Minnaert (2), five-parameter
/// (5), six-parameter (6) and its cos^2 variant (6).
pub const LADDER: [ModelKind; 5] = [
    ModelKind::Lambert,
    ModelKind::Minnaert,
    ModelKind::Five,
    ModelKind::Six,
    ModelKind::SixCos2,
];

/// Fit the model ladder to a dataset over the angular domain a scene uses and name the
/// simplest model whose RMS relative error meets the budget.
#[derive(Debug, Args)]
pub struct SelectCmd {
    /// Largest acceptable RMS relative error over the domain, e.g. 2% or 0.02.
    #[arg(long, value_parser = parse_fraction, default_value = "2%")]
    budget: f64,
    /// Angular domain: only points with theta_i and theta_r at most this (degrees).
    #[arg(long, default_value_t = 90.0)]
    max_theta: f64,
    #[command(flatten)]
    engine: EngineArgs,
    /// Print JSON instead of the table.
    #[arg(long)]
    json: bool,
    /// Data file (one dataset; use `brdf fit` for batches).
    data: PathBuf,
}

#[derive(Serialize)]
struct Selection<'a> {
    dataset: &'a str,
    budget: f64,
    max_theta: f64,
    n: usize,
    chosen: Option<&'static str>,
    candidates: &'a [FitReport],
}

impl SelectCmd {
    pub fn run(self) -> Result<()> {
        let datasets = self.engine.load(std::slice::from_ref(&self.data))?;
        if datasets.len() != 1 {
            bail!(
                "{}: holds {} datasets (sample/wavelength groups); select works on one",
                self.data.display(),
                datasets.len()
            );
        }
        let limit = self.max_theta.to_radians() + 1e-12;
        let d = &datasets[0];
        let domain = Dataset {
            name: d.name.clone(),
            points: d
                .points
                .iter()
                .filter(|p| p.theta_i <= limit && p.theta_r <= limit)
                .copied()
                .collect(),
        };
        if domain.points.len() < 7 {
            bail!(
                "{}: only {} points with both zeniths <= {} deg; too few to compare models",
                d.name,
                domain.points.len(),
                self.max_theta
            );
        }
        let residual = self.engine.residual.into();
        let opts = self.engine.fit_options();
        let reports: Vec<FitReport> = LADDER
            .iter()
            .flat_map(|&k| fit_all(k, residual, opts, std::slice::from_ref(&domain)))
            .collect();
        let chosen = reports
            .iter()
            .find(|r| r.metrics.rms_rel <= self.budget)
            .map(|r| r.model);
        let stdout = std::io::stdout();
        let mut out = stdout.lock();
        if self.json {
            let s = Selection {
                dataset: &domain.name,
                budget: self.budget,
                max_theta: self.max_theta,
                n: domain.points.len(),
                chosen,
                candidates: &reports,
            };
            writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?;
            return Ok(());
        }
        writeln!(
            out,
            "{}: {} points with theta_i, theta_r <= {} deg; budget: RMS relative error <= {:.2}%",
            domain.name,
            domain.points.len(),
            self.max_theta,
            100.0 * self.budget
        )?;
        writeln!(
            out,
            "{:<9} {:>2} {:>10} {:>10} {:>11} {:>9} {:>11} {:>11}  undetermined",
            "model", "k", "rms rel %", "max rel %", "rmse 1/sr", "log rmse", "AIC", "BIC"
        )?;
        for r in &reports {
            let und = r.undetermined();
            writeln!(
                out,
                "{:<9} {:>2} {:>10.3} {:>10.3} {:>11.4e} {:>9.4} {:>11.2} {:>11.2}  {}",
                r.model,
                r.k,
                100.0 * r.metrics.rms_rel,
                100.0 * r.metrics.max_rel,
                r.metrics.rmse,
                r.metrics.log_rmse,
                r.aic,
                r.bic,
                if und.is_empty() {
                    "-".to_owned()
                } else {
                    und.join(" ")
                }
            )?;
        }
        match chosen {
            Some(m) => writeln!(out, "simplest model within budget: {m}")?,
            None => {
                let best = reports
                    .iter()
                    .min_by(|a, b| a.metrics.rms_rel.total_cmp(&b.metrics.rms_rel))
                    .expect("ladder is not empty");
                writeln!(
                    out,
                    "no model meets the budget; the closest is {} at {:.3}%",
                    best.model,
                    100.0 * best.metrics.rms_rel
                )?
            }
        }
        Ok(())
    }
}
