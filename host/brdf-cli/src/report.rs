//! `brdf report`: the model-comparison report over the bundled measured datasets (data/measured).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use brdf_core::Brdf;
use brdf_core::ModelKind;
use brdf_fit::import::{Channel, Format};
use brdf_fit::report::FitReport;
use brdf_fit::{Dataset, Loss, LossKind};
use clap::Args;

use crate::common::{legend, parse_fraction, EngineArgs};
use crate::formats::import_reporting;

/// Regenerate the model-comparison report: every measured dataset (Garnet Red R channel,
/// each PTFE wavelength, MERL aluminium) through the model ladder, one table (`table.md`),
/// the fits (`results.json`) and three figures per dataset. Seeded and free of timings, so
/// the output is the same bit for bit on every run.
#[derive(Debug, Args)]
pub struct ReportCmd {
    /// Folder holding the bundled third-party measurements (`data/measured` in the repository).
    #[arg(long, default_value = "data/measured")]
    data: PathBuf,
    /// Output folder.
    #[arg(long, short = 'o', default_value = "docs/comparison")]
    out: PathBuf,
    /// Error budget for naming the simplest adequate model (RMS relative error).
    #[arg(long, value_parser = parse_fraction, default_value = "2%")]
    budget: f64,
    #[command(flatten)]
    engine: EngineArgs,
}

/// The datasets of the report: (slug, title, format, file under `data`, channel).
const SOURCES: [(&str, &str, Format, &str, Channel); 4] = [
    (
        "garnet-red",
        "Garnet Red lacquer (Cornell), R channel",
        Format::Cornell,
        "cornell-medium-gloss-paints/garnet_red_RGB.astm",
        Channel::R,
    ),
    (
        "krylon-blue",
        "Krylon Blue enamel (Cornell), B channel",
        Format::Cornell,
        "cornell-medium-gloss-paints/krylon_blue_RGB.astm",
        Channel::B,
    ),
    (
        "ptfe",
        "Sintered PTFE (NIST, Germer 2017)",
        Format::Nist,
        "ptfe-germer-nist/PTFE.data.csv",
        Channel::R,
    ),
    (
        "merl-aluminium",
        "MERL aluminium, in-plane slice",
        Format::MerlInPlane,
        "merl-aluminium-inplane/aluminum_brdf.csv",
        Channel::R,
    ),
];

/// Rows the report also leaves out, in a second, clearly named entry of the same dataset:
/// (source slug, lines, why). Nothing is dropped from the as-measured entry.
const EXCLUSIONS: [(&str, &[u64], &str); 1] = [(
    "garnet-red",
    &[1458, 1460],
    "two grazing readings (80 deg incidence) of 1.4e-4 and 3.2e-4 sr^-1, 40x and 20x below the paint's diffuse floor and beside the 11.6 sr^-1 spike",
)];

struct Entry {
    slug: String,
    title: String,
    data: Dataset,
    rows_in: usize,
    rejects: usize,
    note: Option<String>,
}

fn pct(x: f64) -> String {
    format!("{:.2}", 100.0 * x)
}

impl ReportCmd {
    pub fn run(self) -> Result<()> {
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("cannot create {}", self.out.display()))?;
        let mut entries = Vec::new();
        for (slug, title, format, file, channel) in SOURCES {
            let path = self.data.join(file);
            let imp = import_reporting(&path, format, channel.into())?;
            // The report's pages compare representations in relative error and `ln f`, which
            // readings at or below zero have none of: they are left out, and said so.
            let dark = imp.dark_readings();
            if dark > 0 {
                eprintln_lossy!(
                    "{}: {dark} reading(s) at or below zero left out of the report (positive readings only)",
                    path.display()
                );
            }
            let imp = imp.positive_only();
            let many = imp.datasets.len() > 1;
            for d in imp.datasets.iter() {
                let group = d
                    .name
                    .rsplit_once('[')
                    .map(|(_, g)| g.trim_end_matches(']').to_owned());
                let (slug, title) = match (&group, many) {
                    (Some(g), true) => {
                        let wl = g.split_once('=').map_or(g.as_str(), |(_, v)| v);
                        (format!("{slug}-{wl}um"), format!("{title}, {wl} um"))
                    }
                    _ => (slug.to_owned(), title.to_owned()),
                };
                let name = format!("{file}{}", group.map(|g| format!("[{g}]")).unwrap_or_default());
                entries.push(Entry {
                    slug: slug.clone(),
                    title: title.clone(),
                    data: Dataset {
                        name: name.clone(),
                        points: d.points.clone(),
                    },
                    rows_in: imp.rows_in,
                    rejects: imp.rejects.len(),
                    note: None,
                });
                for (src, lines, why) in EXCLUSIONS {
                    if src == slug {
                        let points: Vec<_> = d
                            .points
                            .iter()
                            .filter(|p| !lines.contains(&p.line))
                            .copied()
                            .collect();
                        let listed: Vec<String> = lines.iter().map(u64::to_string).collect();
                        entries.push(Entry {
                            slug: format!("{slug}-without-outliers"),
                            title: format!("{title}, without lines {}", listed.join(" and ")),
                            data: Dataset {
                                name: format!("{name} without lines {}", listed.join(", ")),
                                points,
                            },
                            rows_in: imp.rows_in,
                            rejects: imp.rejects.len(),
                            note: Some(format!(
                                "Left out here (kept in the entry above): lines {}: {why}.",
                                listed.join(", ")
                            )),
                        });
                    }
                }
            }
        }
        let datasets: Vec<Dataset> = entries.iter().map(|e| e.data.clone()).collect();
        // ladder[m][d]: rung m fitted to dataset d. The six-parameter model twice: with the
        // paper's c >= 0, and with c down to -0.99 (brightening towards grazing).
        let rungs: Vec<(ModelKind, bool)> = ModelKind::LADDER
            .iter()
            .flat_map(|&k| {
                let twice = k == ModelKind::Six;
                std::iter::once((k, false)).chain(twice.then_some((k, true)))
            })
            .collect();
        let ladder: Vec<Vec<FitReport>> = rungs
            .iter()
            .map(|&(k, brightening)| {
                let mut settings = self.engine.settings(k)?;
                settings.brightening = brightening;
                Ok(brdf_fit::fit_all(&settings, &datasets)?)
            })
            .collect::<Result<_>>()?;
        let mut md = String::new();
        let mut json = Vec::new();
        let mut summary: Vec<(String, String, String, Option<String>)> = Vec::new();
        writeln!(
            md,
            "<!-- Generated by `brdf report`; do not edit. Seed {}, {} residuals, budget {}% RMS relative error. -->\n",
            self.engine.seed,
            self.engine.residual,
            pct(self.budget)
        )?;
        for (d, e) in entries.iter().enumerate() {
            let fits: Vec<&FitReport> = ladder.iter().map(|m| &m[d]).collect();
            let chosen = fits
                .iter()
                .find(|r| r.metrics.rms_rel <= self.budget)
                .map(|r| label(r));
            let best = fits
                .iter()
                .min_by(|a, b| a.metrics.rms_rel.total_cmp(&b.metrics.rms_rel))
                .map(|r| label(r))
                .expect("a ladder");
            let best_bic = fits
                .iter()
                .min_by(|a, b| a.bic.total_cmp(&b.bic))
                .map(|r| label(r))
                .expect("a ladder");
            summary.push((e.title.clone(), best.clone(), best_bic.clone(), chosen.clone()));
            writeln!(md, "## {}\n", e.title)?;
            if let Some(n) = &e.note {
                writeln!(md, "{n}\n")?;
            }
            writeln!(
                md,
                "`{}`: {} points (the file: {} rows read, {} rejected), incidences {}.\n",
                e.data.name,
                e.data.points.len(),
                e.rows_in,
                e.rejects,
                e.data
                    .incidences()
                    .iter()
                    .map(|t| format!("{:.4}", t.to_degrees())
                        .trim_end_matches('0')
                        .trim_end_matches('.')
                        .to_owned())
                    .collect::<Vec<_>>()
                    .join(", ")
            )?;
            writeln!(
                md,
                "| model | k | RMS rel % | max rel % | RMSE 1/sr | RMSE ln f | AIC | BIC | not determined |"
            )?;
            writeln!(md, "|---|---|---|---|---|---|---|---|---|")?;
            for r in &fits {
                let und = r.undetermined();
                writeln!(
                    md,
                    "| {} | {} | {} | {} | {:.4e} | {:.4} | {:.1} | {:.1} | {} |",
                    label(r),
                    r.k,
                    pct(r.metrics.rms_rel),
                    pct(r.metrics.max_rel),
                    r.metrics.rmse,
                    r.metrics.log_rmse,
                    r.aic,
                    r.bic,
                    if und.is_empty() {
                        "-".to_owned()
                    } else {
                        und.join(", ")
                    }
                )?;
            }
            writeln!(
                md,
                "\nSimplest model within {}%: **{}**.\n",
                pct(self.budget),
                chosen.as_deref().unwrap_or("none")
            )?;
            writeln!(
                md,
                "Lowest RMS relative error: **{best}**; lowest BIC: **{best_bic}**.\n"
            )?;
            if let Some(p) = fits.iter().find(|r| r.model == ModelKind::Six).and_then(|r| {
                r.influence
                    .points
                    .first()
                    .map(|p| (p, r.influence.dominant, r.influence.dominant_above))
            }) {
                let (p, dominant, above) = p;
                writeln!(
                    md,
                    "Most influential point of the six-parameter fit: line {} (theta_i {}, theta_r {}, phi {}; \
                     {:.3e} 1/sr measured, {:.3e} fitted); refitting without it lowers the cost by {}%{}.\n",
                    p.line,
                    p.theta_i,
                    p.theta_r,
                    p.phi,
                    p.brdf,
                    p.model,
                    pct(p.cost_drop),
                    if dominant {
                        format!(" -- more than the {}% one point may move, so the fit rests on it", pct(above))
                    } else {
                        String::new()
                    }
                )?;
            }
            writeln!(md, "RMS relative error (%) per incidence:\n")?;
            let names: Vec<String> = fits.iter().map(|r| label(r)).collect();
            writeln!(md, "| theta_i (deg) | n | {} |", names.join(" | "))?;
            writeln!(md, "|---|---|{}", "---|".repeat(names.len()))?;
            for (k, inc) in fits[0].per_incidence.iter().enumerate() {
                let cols: Vec<String> = fits
                    .iter()
                    .map(|r| pct(r.per_incidence[k].metrics.rms_rel))
                    .collect();
                writeln!(md, "| {:.2} | {} | {} |", inc.theta_i, inc.n, cols.join(" | "))?;
            }
            writeln!(md)?;
            for (kind, caption) in [
                ("inplane", "in-plane curves"),
                ("map", "six-parameter fit over the hemisphere"),
                ("residuals", "six-parameter residuals"),
            ] {
                writeln!(md, "![{}: {caption}]({}-{kind}.png)", e.title, e.slug)?;
            }
            writeln!(md)?;
            self.figures(e, &fits)?;
            let mut v = serde_json::json!({
                "dataset": e.data.name,
                "slug": e.slug,
                "rows_in": e.rows_in,
                "rejected": e.rejects,
                "chosen": chosen,
                "fits": fits,
            });
            // Wall times differ between runs; the report must not.
            if let Some(arr) = v["fits"].as_array_mut() {
                for f in arr {
                    if let Some(o) = f.as_object_mut() {
                        o.remove("seconds");
                    }
                }
            }
            json.push(v);
        }
        let mut head = String::new();
        writeln!(head, "## Which model wins\n")?;
        writeln!(
            head,
            "| dataset | lowest RMS relative error | lowest BIC | simplest within {}% |",
            pct(self.budget)
        )?;
        writeln!(head, "|---|---|---|---|")?;
        for (title, best, bic, chosen) in &summary {
            writeln!(
                head,
                "| {title} | {best} | {bic} | {} |",
                chosen.as_deref().unwrap_or("none")
            )?;
        }
        writeln!(head)?;
        head.push_str(&self.robust_section(&entries)?);
        let md = match md.split_once("-->\n\n") {
            Some((first, rest)) => format!("{first}-->\n\n{head}{rest}"),
            None => head + &md,
        };
        write(&self.out.join("table.md"), md.as_bytes())?;
        write(
            &self.out.join("results.json"),
            (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
        )?;
        eprintln_lossy!("wrote {} datasets to {}", entries.len(), self.out.display());
        Ok(())
    }

    /// The six-parameter fit of the first entry with an outlier note (Garnet Red) under each
    /// robust loss, against least squares with and without the outlying lines.
    fn robust_section(&self, entries: &[Entry]) -> Result<String> {
        let mut md = String::new();
        let Some(without) = entries.iter().find(|e| e.note.is_some()) else {
            return Ok(md);
        };
        let Some(with) = entries
            .iter()
            .find(|e| without.slug == format!("{}-without-outliers", e.slug))
        else {
            return Ok(md);
        };
        let kept: std::collections::HashSet<u64> = without.data.points.iter().map(|p| p.line).collect();
        writeln!(md, "## Robust losses on {}\n", with.title)?;
        writeln!(
            md,
            "Six-parameter fits of all {} points; the last column scores each fit on the {} points \
             without the outlying lines. `--loss-scale` {} (relative error).\n",
            with.data.points.len(),
            without.data.points.len(),
            self.engine
                .loss_scale
                .unwrap_or(brdf_fit::request::DEFAULT_LOSS_SCALE)
        )?;
        writeln!(
            md,
            "| fitted to | loss | kb | kr | b | a | kd | c | RMS rel % (all points) | RMS rel % (without outliers) |"
        )?;
        writeln!(md, "|---|---|---|---|---|---|---|---|---|---|")?;
        let losses = [
            LossKind::Linear,
            LossKind::Huber,
            LossKind::SoftL1,
            LossKind::Cauchy,
        ];
        let mut rows: Vec<(&Entry, LossKind)> = losses.iter().map(|&l| (with, l)).collect();
        rows.push((without, LossKind::Linear));
        for (e, loss) in rows {
            let mut settings = self.engine.settings(ModelKind::Six)?;
            settings.loss = Loss {
                kind: loss,
                scale: self
                    .engine
                    .loss_scale
                    .unwrap_or(brdf_fit::request::DEFAULT_LOSS_SCALE),
            };
            let r = brdf_fit::fit_all(&settings, std::slice::from_ref(&e.data))?.remove(0);
            let model = r.model()?;
            let rms = |pts: &mut dyn Iterator<Item = &brdf_fit::Point>| -> f64 {
                let (mut s, mut n) = (0.0, 0usize);
                for p in pts {
                    let f = model.eval_angles(p.theta_i, p.theta_r, p.phi);
                    s += ((f - p.brdf) / p.brdf).powi(2);
                    n += 1;
                }
                (s / n.max(1) as f64).sqrt()
            };
            let all = rms(&mut with.data.points.iter());
            let clean = rms(&mut with.data.points.iter().filter(|p| kept.contains(&p.line)));
            let params: Vec<String> = r.params.0.iter().map(|(_, v)| format!("{v:.4}")).collect();
            writeln!(
                md,
                "| {} | {} | {} | {} | {} |",
                if e.note.is_some() {
                    "without outliers"
                } else {
                    "all points"
                },
                loss,
                params.join(" | "),
                pct(all),
                pct(clean)
            )?;
        }
        writeln!(md)?;
        Ok(md)
    }

    fn figures(&self, e: &Entry, fits: &[&FitReport]) -> Result<()> {
        let pick = |k: ModelKind| fits.iter().find(|r| r.model == k).copied();
        let six = legend(pick(ModelKind::Six).context("six fit")?)?;
        let curves = [
            ModelKind::Six,
            ModelKind::Five,
            ModelKind::Ggx,
            ModelKind::Minnaert,
        ]
        .into_iter()
        .filter_map(pick)
        .map(legend)
        .collect::<Result<Vec<_>>>()?;
        // The map at the measured incidence closest to 30 degrees.
        let map_ti = e
            .data
            .incidences()
            .into_iter()
            .min_by(|a, b| {
                (a - 30f64.to_radians())
                    .abs()
                    .total_cmp(&(b - 30f64.to_radians()).abs())
            })
            .context("no incidence")?;
        for ext in ["svg", "png"] {
            let f = |kind: &str| self.out.join(format!("{}-{kind}.{ext}", e.slug));
            brdf_plot::in_plane(&f("inplane"), &e.title, &e.data, &curves)?;
            brdf_plot::hemisphere_map(
                &f("map"),
                &format!("{}, {}", e.title, six.label),
                &six.model,
                map_ti,
            )?;
            brdf_plot::residuals(&f("residuals"), &e.title, &e.data, &six)?;
        }
        Ok(())
    }
}

fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// A fit's name in the tables: the model, and the brightening variant marked.
fn label(r: &FitReport) -> String {
    if r.brightening {
        format!("{}, c < 0 allowed", r.model.name())
    } else {
        r.model.name().to_owned()
    }
}
