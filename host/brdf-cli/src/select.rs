//! `brdf select`: the simplest model of the family, and the cheapest representation on the
//! device, that meet an error budget over the angular domain a scene uses.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::ModelKind;
use brdf_fit::report::FitReport;
use brdf_fit::Dataset;
use brdf_scene::represent::{choose, representations, Choice, Representation};
use clap::Args;
use serde::Serialize;

use crate::common::{parse_fraction, write_blob, EngineArgs};

/// Fit the model ladder to a dataset over the angular domain a scene uses, name the simplest
/// model whose RMS relative error meets the budget, and the cheapest representation on the
/// device (Lambert, Minnaert, five- or six-parameter exact, six-parameter tables of 64, 256 or
/// 1024 nodes) that meets it, with its cost per lookup (Cortex-M4F instructions from
/// `brdf_core::cost`, host ns measured now) and its error against the data; `-o` writes it as
/// a parameter blob for `brdf flash`.
#[derive(Debug, Args)]
pub struct SelectCmd {
    /// Largest acceptable RMS relative error over the domain, e.g. 2% or 0.02.
    #[arg(long, value_parser = parse_fraction, default_value = "2%")]
    budget: f64,
    /// Angular domain: only points with theta_i and theta_r at most this (degrees).
    #[arg(long, default_value_t = 90.0, value_parser = crate::common::degrees(0.0, 90.0))]
    max_theta: f64,
    /// Largest incidence zenith of the domain (degrees; default --max-theta).
    #[arg(long, value_parser = crate::common::degrees(0.0, 90.0))]
    max_theta_i: Option<f64>,
    /// Largest viewing zenith of the domain (degrees; default --max-theta).
    #[arg(long, value_parser = crate::common::degrees(0.0, 90.0))]
    max_theta_r: Option<f64>,
    /// Write the chosen representation as a parameter blob.
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
    /// Sequence number of the blob written with -o.
    #[arg(long, default_value_t = 1)]
    sequence: u32,
    #[command(flatten)]
    engine: EngineArgs,
    /// Print JSON instead of the table.
    #[arg(long)]
    json: bool,
    /// Also choose models that are not reciprocal or whose BRDF is unbounded at grazing (the
    /// five-parameter model, Minnaert with k < 1, six-parameter with c < 0); they are always
    /// listed, and marked.
    #[arg(long)]
    allow_nonphysical: bool,
    /// Data file (one dataset; use `brdf fit` for batches).
    #[arg(required_unless_present = "scene", conflicts_with = "scene")]
    data: Option<PathBuf>,
    /// Instead of data: a scene file. Per material, the cheapest device representation whose
    /// laser radar cross-section stays within --budget of the exact model's at every aspect.
    #[arg(long, value_name = "SCENE.toml")]
    scene: Option<PathBuf>,
}

#[derive(Serialize)]
struct Selection<'a> {
    dataset: &'a str,
    budget: f64,
    max_theta_i: f64,
    max_theta_r: f64,
    n: usize,
    allow_nonphysical: bool,
    /// The representation chosen, if any meets the budget.
    chosen: Option<String>,
    /// Why it was chosen, or why nothing was.
    reason: String,
    candidates: &'a [FitReport],
    representations: &'a [Representation],
}

impl SelectCmd {
    pub fn run(self) -> Result<()> {
        let Some(data) = self.data.clone() else {
            return self.run_scene();
        };
        let datasets = self.engine.load(std::slice::from_ref(&data))?;
        if datasets.len() != 1 {
            bail!(
                "{}: holds {} datasets (sample/wavelength groups); select works on one",
                data.display(),
                datasets.len()
            );
        }
        let (max_i, max_r) = (
            self.max_theta_i.unwrap_or(self.max_theta),
            self.max_theta_r.unwrap_or(self.max_theta),
        );
        let tol = brdf_core::tolerance::ANGLE_FILTER_DEG;
        let (limit_i, limit_r) = ((max_i + tol).to_radians(), (max_r + tol).to_radians());
        let d = &datasets[0];
        let domain = Dataset {
            name: d.name.clone(),
            points: d
                .points
                .iter()
                .filter(|p| p.theta_i <= limit_i && p.theta_r <= limit_r)
                .copied()
                .collect(),
        };
        let beyond_i = d.points.iter().filter(|p| p.theta_i > limit_i).count();
        let beyond_r = d
            .points
            .iter()
            .filter(|p| p.theta_i <= limit_i && p.theta_r > limit_r)
            .count();
        if beyond_i + beyond_r > 0 {
            eprintln!(
                "{}: left out {} of {} points: {beyond_i} with theta_i > {max_i} deg, {beyond_r} more with \
                 theta_r > {max_r} deg (limits kept within {tol} deg)",
                d.name,
                beyond_i + beyond_r,
                d.points.len()
            );
        }
        if domain.points.len() < 7 {
            bail!(
                "{}: only {} points with theta_i <= {max_i} and theta_r <= {max_r} deg; too few to compare models",
                d.name,
                domain.points.len(),
            );
        }
        let reports: Vec<FitReport> = ModelKind::LADDER
            .iter()
            .flat_map(|&k| brdf_fit::fit_all(&self.engine.settings(k), std::slice::from_ref(&domain)))
            .collect();
        let (reprs, materials) = representations(&reports, &domain).map_err(|e| anyhow!(e))?;
        let Choice { best, reason } = choose(&reprs, self.budget, self.allow_nonphysical);
        if let (Some(path), Some(i)) = (&self.output, best) {
            let (m, table) = materials[i].clone();
            write_blob(&brdf_fit::pack::encode(&[m], &[table], self.sequence)?, path)?;
        } else if self.output.is_some() {
            bail!("no representation meets the budget; nothing written");
        }
        let stdout = std::io::stdout();
        let mut out = stdout.lock();
        if self.json {
            let s = Selection {
                dataset: &domain.name,
                budget: self.budget,
                max_theta_i: max_i,
                max_theta_r: max_r,
                n: domain.points.len(),
                allow_nonphysical: self.allow_nonphysical,
                chosen: best.map(|i| reprs[i].name.clone()),
                reason: reason.clone(),
                candidates: &reports,
                representations: &reprs,
            };
            writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?;
            return Ok(());
        }
        writeln!(
            out,
            "{}: {} points with theta_i <= {max_i} deg, theta_r <= {max_r} deg; budget: RMS relative error <= {:.2}%",
            domain.name,
            domain.points.len(),
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
        writeln!(out)?;
        writeln!(
            out,
            "{:<16} {:>10} {:>10} {:>13} {:>12} {:>8} {:>7}  caveat",
            "representation", "rms rel %", "max rel %", "table vs exact", "M4F instr", "host ns", "bytes"
        )?;
        for r in &reprs {
            writeln!(
                out,
                "{:<16} {:>10.3} {:>10.3} {:>13} {:>12} {:>8.1} {:>7}  {}{}",
                r.name,
                100.0 * r.rms_rel,
                100.0 * r.max_rel,
                r.table_vs_exact.map_or("-".into(), |e| format!("{e:.1e}")),
                r.device_instructions,
                r.host_ns,
                r.blob_bytes,
                r.caveat(),
                if r.fits_blob { "" } else { " (over a slot)" }
            )?;
        }
        match best {
            Some(i) => writeln!(
                out,
                "chosen: {}: {reason}{}",
                reprs[i].name,
                self.output
                    .as_ref()
                    .map_or(String::new(), |p| format!("; written to {}", p.display()))
            )?,
            None => writeln!(out, "chosen: none: {reason}")?,
        }
        Ok(())
    }
}

impl SelectCmd {
    /// `--scene`: the selection is `brdf_scene::select`; this prints it and writes the blob.
    fn run_scene(&self) -> Result<()> {
        use brdf_scene::select::{select, SelectOptions};
        let path = self
            .scene
            .as_ref()
            .ok_or_else(|| anyhow!("give a data file or --scene"))?;
        let scene = brdf_scene::scene::Scene::load(path)
            .map_err(|e| anyhow!(e).context(format!("cannot use scene {}", path.display())))?;
        let bar = brdf_scene::progress::terminal_bar(scene.aspects().len(), "aspects");
        let domain = brdf_scene::lrcs::domain(&scene, &|| bar.inc(1));
        bar.finish_and_clear();
        let opts = SelectOptions {
            budget: self.budget,
            seed: self.engine.seed,
            sequence: self.sequence,
            ..SelectOptions::default()
        };
        let s = select(&scene, &domain, &opts);
        let mut out = std::io::stdout().lock();
        if self.json {
            writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?;
        } else {
            s.write_report(&mut out)?;
        }
        if let Some(o) = &self.output {
            let blob = s.blob().ok_or_else(|| {
                anyhow!(
                    "nothing written to {}: {}",
                    o.display(),
                    s.blob_note.clone().unwrap_or_default()
                )
            })?;
            std::fs::write(o, blob).with_context(|| format!("cannot write {}", o.display()))?;
            eprintln!(
                "wrote {} ({} bytes, {} materials in scene order)",
                o.display(),
                blob.len(),
                s.materials.len()
            );
        }
        Ok(())
    }
}
