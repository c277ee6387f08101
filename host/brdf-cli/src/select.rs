//! `brdf select`: the simplest model of the family, and the cheapest representation on the
//! device, that meet an error budget over the angular domain a scene uses.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_scene::represent::{one_dataset, select_data, DataDomain};
use clap::Args;

use brdf_core::ModelKind;
use brdf_fit::FitSettings;

use crate::common::{parse_fraction, write_blob, EngineArgs};

/// `--budget`: a fraction (`2%`, `0.02`) that meets the library's budget rule.
fn parse_budget(text: &str) -> Result<f64, String> {
    brdf_scene::ladder::check_budget(parse_fraction(text)?)
}

/// Fit the model ladder to a dataset over the angular domain a scene uses, name the simplest
/// model whose RMS relative error meets the budget, and the cheapest representation on the
/// device (Lambert, Minnaert, five- or six-parameter exact, six-parameter tables of 64, 256 or
/// 1024 nodes) that meets it, with its cost per lookup (Cortex-M4F instructions from
/// `brdf_core::cost`, host ns measured now) and its error against the data; `-o` writes it as
/// a parameter blob for `brdf flash`.
#[derive(Debug, Args)]
pub struct SelectCmd {
    /// Largest acceptable error, above 0 and at most 100%, e.g. 2% or 0.02: the held-out
    /// (cross-validated) RMS relative error over the data's domain, the largest 2% of the held-out errors left out
    /// (`rms rel %` of the representations is trimmed alike; the models' is not) (when nothing
    /// meets it, the most accurate
    /// representation is chosen and written, with a warning); with --scene, the worst relative
    /// error of a material's σ at any aspect (when nothing meets it for a material, nothing
    /// is written).
    #[arg(long, value_parser = parse_budget, default_value_t = brdf_scene::select::DEFAULT_BUDGET)]
    budget: f64,
    /// Angular domain: only points with theta_i and theta_r at most this (degrees; not with
    /// --scene, whose domain is its own queries).
    #[arg(long, default_value_t = 90.0, value_parser = crate::common::degrees(0.0, 90.0), conflicts_with = "scene")]
    max_theta: f64,
    /// Largest incidence zenith of the domain (degrees; default --max-theta).
    #[arg(long, value_parser = crate::common::degrees(0.0, 90.0), conflicts_with = "scene")]
    max_theta_i: Option<f64>,
    /// Largest viewing zenith of the domain (degrees; default --max-theta).
    #[arg(long, value_parser = crate::common::degrees(0.0, 90.0), conflicts_with = "scene")]
    max_theta_r: Option<f64>,
    /// Write the chosen representation as a parameter blob.
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
    /// Write the fit the chosen representation comes from, as `brdf fit --json` prints it,
    /// with its fitted table when that was chosen (for `brdf eval --fit` and `brdf pack`; add
    /// `--table-nodes N` there for a six-parameter table rung). Not with --scene.
    #[arg(long, value_name = "FILE.json", conflicts_with = "scene")]
    chosen: Option<PathBuf>,
    /// Sequence number of the blob written with -o.
    #[arg(long, default_value_t = 1)]
    sequence: u32,
    #[command(flatten)]
    engine: EngineArgs,
    /// Print JSON instead of the table.
    #[arg(long)]
    json: bool,
    /// Also choose models that are not reciprocal or whose albedo is unbounded at grazing (the
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

impl SelectCmd {
    pub fn run(self) -> Result<()> {
        let inputs: Vec<&std::path::Path> = [self.data.as_deref(), self.scene.as_deref()]
            .into_iter()
            .flatten()
            .collect();
        crate::common::distinct_outputs(
            &[
                ("-o", self.output.as_deref()),
                ("--chosen", self.chosen.as_deref()),
            ],
            &inputs,
        )?;
        // Each band is selected on its own (a scene's materials too): shared bands would be
        // ignored.
        if self.engine.bands == Some(brdf_fit::spectral::BandShape::Shared) {
            bail!(
                "--bands shared: `brdf select` chooses each band's representation on its own \
                 (one shape shared by the bands is a `brdf fit` option); it would be ignored"
            );
        }
        let Some(data) = self.data.clone() else {
            return self.run_scene();
        };
        let datasets = self.engine.load(std::slice::from_ref(&data))?;
        if datasets.len() > 1 {
            let names: Vec<&str> = datasets.iter().map(|d| d.name.as_str()).collect();
            let families = brdf_fit::spectral::families(&names);
            if families.len() == 1 && families[0].len() == datasets.len() {
                return self.run_bands(&datasets);
            }
        }
        let d = &one_dataset(&data.display().to_string(), datasets).map_err(|e| anyhow!(e))?;
        let (max_i, max_r) = self.limits();
        let (kept, s) = self.select_one(d, &|note| eprintln_lossy!("{note}"))?;
        let domain = &kept.domain;
        match (&self.output, &s.material) {
            (Some(path), Some((m, table))) => write_blob(
                &brdf_fit::pack::encode(&[*m], std::slice::from_ref(table), self.sequence)?,
                path,
            )?,
            (Some(_), None) => bail!("no representation could be chosen; nothing written: {}", s.reason),
            _ => {}
        }
        if let Some(path) = &self.chosen {
            let Some(fit) = s.chosen_report() else {
                bail!(
                    "no representation could be chosen; {} not written: {}",
                    path.display(),
                    s.reason
                );
            };
            let text = serde_json::to_string_pretty(&fit)?;
            std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))?;
        }
        for n in &s.notes {
            eprintln_lossy!("{n}");
        }
        warn_floor(&s);
        if s.chosen.is_some() && !s.within_budget {
            eprintln_lossy!("warning: {}", s.reason);
        }
        let (reports, reprs, reason) = (&s.candidates, &s.representations, &s.reason);
        let stdout = std::io::stdout();
        let mut out = stdout.lock();
        if self.json {
            writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?;
            return Ok(());
        }
        writeln!(
            out,
            "{}: {} points with theta_i <= {} deg, theta_r <= {} deg; budget: held-out RMS relative error <= {}%",
            domain.name,
            domain.points.len(),
            brdf_core::Compact(max_i),
            brdf_core::Compact(max_r),
            brdf_core::Compact(100.0 * self.budget)
        )?;
        writeln!(
            out,
            "{:<9} {:>2} {:>10} {:>10} {:>11} {:>9} {:>11} {:>11}  undetermined",
            "model", "k", "rms rel %", "max rel %", "rmse 1/sr", "log rmse", "AIC", "BIC"
        )?;
        for r in reports {
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
            "{:<16} {:>9} {:>10} {:>10} {:>13} {:>12} {:>8} {:>7}  caveat",
            "representation",
            "cv rms %",
            "rms rel %",
            "max rel %",
            "table vs exact",
            "M4F instr",
            "host ns",
            "bytes"
        )?;
        for r in reprs {
            writeln!(
                out,
                "{:<16} {:>9} {:>10.3} {:>10.3} {:>13} {:>12} {:>8.1} {:>7}  {}{}",
                r.rung.name,
                r.cv_rms_rel.map_or("-".into(), |e| format!("{:.3}", 100.0 * e)),
                100.0 * r.rms_rel,
                100.0 * r.max_rel,
                r.table_vs_exact.map_or("-".into(), |e| format!("{e:.1e}")),
                r.rung.device_instructions,
                r.host_ns,
                r.rung.blob_bytes,
                r.rung.caveat(),
                if r.rung.fits_blob { "" } else { " (over a slot)" }
            )?;
        }
        writeln!(
            out,
            "yardstick: 4-nearest-neighbour interpolation of the same points, held out alike: {}{}",
            s.knn_cv_rms_rel
                .map_or("- (one fold holds every point)".into(), |e| format!(
                    "{:.3}%",
                    100.0 * e
                )),
            s.noise_floor.as_ref().map_or(String::new(), |f| format!(
                " (errors relative over the noise floor {} 1/sr: {} readings at or below zero)",
                brdf_core::Compact(f.value),
                f.at_or_below_zero
            ))
        )?;
        match &s.chosen {
            Some(name) => writeln!(
                out,
                "chosen: {name}: {reason}{}",
                self.output
                    .as_ref()
                    .map_or(String::new(), |p| format!("; written to {}", p.display()))
            )?,
            None => writeln!(out, "chosen: none: {reason}")?,
        }
        Ok(())
    }
}

/// The doubt about an estimated noise floor (`brdf_fit::noise::NoiseFloor::note`: a floor
/// above most readings, where every error becomes an absolute one and the relative errors
/// shown are small however far off the fit is), as `brdf fit` warns of it.
fn warn_floor(s: &brdf_scene::represent::DataSelection) {
    if let Some(note) = s.noise_floor.as_ref().and_then(|f| f.note.as_ref()) {
        eprintln_lossy!("warning: {}: {note}", s.dataset);
    }
}

impl SelectCmd {
    /// The angular domain's limits (degrees): `(max theta_i, max theta_r)`.
    fn limits(&self) -> (f64, f64) {
        (
            self.max_theta_i.unwrap_or(self.max_theta),
            self.max_theta_r.unwrap_or(self.max_theta),
        )
    }

    /// One dataset's selection over the domain, `note` told what the domain left out.
    fn select_one(
        &self,
        d: &brdf_fit::Dataset,
        note: &dyn Fn(&str),
    ) -> Result<(DataDomain, brdf_scene::represent::DataSelection)> {
        let (max_i, max_r) = self.limits();
        let kept = DataDomain::new(d, max_i, max_r);
        if let Some(n) = kept.left_out_note() {
            note(&n);
        }
        let base = self.engine.settings(ModelKind::Six)?;
        let s = select_data(
            &kept,
            &|kind| FitSettings { kind, ..base },
            self.budget,
            self.allow_nonphysical,
        )
        .map_err(|e| anyhow!(e))?;
        Ok((kept, s))
    }

    /// The bands of one spectral measurement (datasets that differ only in `wavelength`): each
    /// band selected on its own, one line per band; `--chosen` writes every band's chosen fit
    /// (an array in band order, which `brdf eval --fit`, scenes and `brdf.eval_fit` take at a
    /// wavelength). A device's banded material holds one analytic fit per band, and the
    /// chosen fitted tables of 31 bands do not fit a slot, so `-o` is refused.
    fn run_bands(&self, bands: &[brdf_fit::Dataset]) -> Result<()> {
        if let Some(o) = &self.output {
            bail!(
                "-o {}: a device's banded material holds one analytic fit per band, and {} bands' \
                 fitted tables do not fit a slot; write the bands with --chosen, `brdf pack` the \
                 bands of `brdf fit --json` for the device, or select one band (--band with \
                 --format cornell or nist; for a CSV, a file of that band's rows)",
                o.display(),
                bands.len()
            );
        }
        let (max_i, max_r) = self.limits();
        let mut order: Vec<(f64, &brdf_fit::Dataset)> = bands
            .iter()
            .map(|d| {
                (
                    brdf_fit::data::split_wavelength(&d.name).map_or(0.0, |(_, w)| w),
                    d,
                )
            })
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let bar = crate::progress::bar(order.len(), "bands");
        let mut selections = Vec::with_capacity(order.len());
        for (_, d) in &order {
            let (_, s) = self.select_one(d, &|note| bar.suspend(|| eprintln_lossy!("{note}")))?;
            bar.inc(1);
            selections.push(s);
        }
        bar.finish_and_clear();
        if let Some(path) = &self.chosen {
            let mut fits = Vec::with_capacity(selections.len());
            for s in &selections {
                fits.push(s.chosen_report().ok_or_else(|| {
                    anyhow!(
                        "{}: no representation could be chosen; {} not written: {}",
                        s.dataset,
                        path.display(),
                        s.reason
                    )
                })?);
            }
            let text = serde_json::to_string_pretty(&fits)?;
            std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))?;
        }
        for s in &selections {
            for n in &s.notes {
                eprintln_lossy!("{}: {n}", s.dataset);
            }
            warn_floor(s);
        }
        let short: Vec<&brdf_fit::Dataset> = order.iter().map(|(_, d)| *d).collect();
        let missed = selections.iter().filter(|s| !s.within_budget).count();
        if missed > 0 {
            eprintln_lossy!(
                "warning: {missed} of {} bands: nothing meets the {}% budget; the most accurate chosen",
                selections.len(),
                brdf_core::Compact(100.0 * self.budget)
            );
        }
        let mut out = std::io::stdout().lock();
        if self.json {
            writeln!(out, "{}", serde_json::to_string_pretty(&selections)?)?;
            return Ok(());
        }
        let measurement = brdf_fit::data::split_wavelength(&short[0].name).map_or(String::new(), |(m, _)| m);
        writeln!(
            out,
            "{measurement}: {} bands, theta_i <= {} deg, theta_r <= {} deg; budget: held-out RMS relative error <= {}% (over each band's noise floor where it has readings at or below zero)",
            selections.len(),
            brdf_core::Compact(max_i),
            brdf_core::Compact(max_r),
            brdf_core::Compact(100.0 * self.budget)
        )?;
        writeln!(
            out,
            "{:>9} {:>6} {:>7} {:>10}  {:<18} {:>9}  {:<16} {:>9} {:>7} {:>9}",
            "band um",
            "points",
            "<= 0",
            "floor",
            "best analytic",
            "cv rms %",
            "chosen",
            "cv rms %",
            "bytes",
            "4-NN cv %"
        )?;
        for ((um, _), s) in order.iter().zip(&selections) {
            let cv = |r: &brdf_scene::represent::Representation| r.cv_rms_rel.unwrap_or(f64::INFINITY);
            let analytic = s
                .representations
                .iter()
                .filter(|r| r.rung.table.is_none() && !r.rung.name.contains("table"))
                .min_by(|a, b| cv(a).total_cmp(&cv(b)));
            let chosen = s
                .chosen
                .as_ref()
                .and_then(|c| s.representations.iter().find(|r| &r.rung.name == c));
            let pct = |r: Option<&brdf_scene::represent::Representation>| {
                r.and_then(|r| r.cv_rms_rel)
                    .map_or("-".into(), |e| format!("{:.2}", 100.0 * e))
            };
            writeln!(
                out,
                "{:>9} {:>6} {:>7} {:>10}  {:<18} {:>9}  {:<16} {:>9} {:>7} {:>9}",
                brdf_fit::data::wavelength_text(*um),
                s.n,
                s.noise_floor.as_ref().map_or(0, |f| f.at_or_below_zero),
                s.noise_floor
                    .as_ref()
                    .map_or("-".into(), |f| format!("{:.2e}", f.value)),
                analytic.map_or("-", |r| r.rung.name.as_str()),
                pct(analytic),
                s.chosen.as_deref().unwrap_or("none"),
                pct(chosen),
                chosen.map_or("-".into(), |r| r.rung.blob_bytes.to_string()),
                s.knn_cv_rms_rel
                    .map_or("-".into(), |e| format!("{:.2}", 100.0 * e))
            )?;
        }
        let median = brdf_fit::holdout::median;
        let chosen_cv: Vec<f64> = selections
            .iter()
            .map(|s| {
                s.chosen
                    .as_ref()
                    .and_then(|c| s.representations.iter().find(|r| &r.rung.name == c))
                    .and_then(|r| r.cv_rms_rel)
                    .unwrap_or(f64::INFINITY)
            })
            .collect();
        let knn: Vec<f64> = selections
            .iter()
            .map(|s| s.knn_cv_rms_rel.unwrap_or(f64::INFINITY))
            .collect();
        writeln!(
            out,
            "median over bands: chosen {:.2}%, 4-NN {:.2}%; chosen at least as good as 4-NN in {} of {} bands",
            100.0 * median(chosen_cv.clone()),
            100.0 * median(knn.clone()),
            chosen_cv.iter().zip(&knn).filter(|(c, k)| c <= k).count(),
            selections.len()
        )?;
        if let Some(p) = &self.chosen {
            writeln!(out, "chosen fits of every band written to {}", p.display())?;
        }
        Ok(())
    }

    /// `--scene`: the selection is `brdf_scene::select`; this prints it and writes the blob.
    fn run_scene(&self) -> Result<()> {
        use brdf_scene::select::{select, SelectOptions};
        let path = self
            .scene
            .as_ref()
            .ok_or_else(|| anyhow!("give a data file or --scene"))?;
        // The scene ladder fits the exact model's values at the scene's own queries (relative
        // residuals, least squares): options about reading or weighing data do not apply.
        let e = &self.engine;
        let defaults = crate::common::EngineArgs::defaults();
        for (given, flag) in [
            (e.residual != defaults.residual, "--residual"),
            (e.loss != defaults.loss, "--loss"),
            (e.loss_scale != defaults.loss_scale, "--loss-scale"),
            (e.brightening, "--brightening"),
            (e.skip_invalid, "--skip-invalid"),
            (e.format.is_some(), "--format"),
            (e.channel.is_some(), "--channel"),
        ] {
            if given {
                bail!(
                    "{flag} does not apply to --scene: the ladder is fitted to the exact model's values at \
                     the scene's queries, with relative residuals and least squares"
                );
            }
        }
        let scene = brdf_scene::scene::Scene::open(path)?;
        brdf_scene::select::selectable(&scene).map_err(anyhow::Error::msg)?;
        if let Some(out) = &self.output {
            crate::common::not_an_input("-o", out, scene.files())?;
        }
        let bar = crate::progress::bar(scene.aspects().len(), "aspects");
        let domain = brdf_scene::queries::collect_queries(&scene, &|| bar.inc(1));
        bar.finish_and_clear();
        let opts = SelectOptions {
            budget: self.budget,
            fit: self.engine.settings(ModelKind::Six)?.options,
            sequence: self.sequence,
            allow_nonphysical: self.allow_nonphysical,
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
            eprintln_lossy!(
                "wrote {} ({} bytes, {} materials in scene order)",
                o.display(),
                blob.len(),
                s.materials.len()
            );
        }
        Ok(())
    }
}
