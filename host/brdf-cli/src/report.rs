//! `brdf report`: the model-comparison report over the bundled measured datasets (data/measured).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use brdf_core::ModelKind;
use brdf_fit::import::{Channel, Format};
use brdf_fit::report::FitReport;
use brdf_fit::Dataset;
use clap::Args;

use crate::common::{parse_fraction, EngineArgs};
use crate::import::import_reporting;
use crate::plot::fitted;
use crate::select::LADDER;

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
const SOURCES: [(&str, &str, Format, &str, Channel); 3] = [
    (
        "garnet-red",
        "Garnet Red lacquer (Cornell), R channel",
        Format::Cornell,
        "cornell-medium-gloss-paints/garnet_red_RGB.astm",
        Channel::R,
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
            let imp = import_reporting(&path, format, channel)?;
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
        // ladder[m][d]: model m fitted to dataset d.
        let ladder: Vec<Vec<FitReport>> = LADDER
            .iter()
            .map(|&k| brdf_fit::fit_all(&self.engine.settings(k), &datasets))
            .collect();
        let mut md = String::new();
        let mut json = Vec::new();
        writeln!(
            md,
            "<!-- Generated by `brdf report`; do not edit. Seed {}, {} residuals, budget {}% RMS relative error. -->\n",
            self.engine.seed,
            self.engine.residual_name(),
            pct(self.budget)
        )?;
        for (d, e) in entries.iter().enumerate() {
            let fits: Vec<&FitReport> = ladder.iter().map(|m| &m[d]).collect();
            let chosen = fits
                .iter()
                .find(|r| r.metrics.rms_rel <= self.budget)
                .map(|r| r.model);
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
                    r.model,
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
                chosen.unwrap_or("none")
            )?;
            writeln!(md, "RMS relative error (%) per incidence:\n")?;
            let names: Vec<&str> = fits.iter().map(|r| r.model).collect();
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
        write(&self.out.join("table.md"), md.as_bytes())?;
        write(
            &self.out.join("results.json"),
            (serde_json::to_string_pretty(&json)? + "\n").as_bytes(),
        )?;
        eprintln!("wrote {} datasets to {}", entries.len(), self.out.display());
        Ok(())
    }

    fn figures(&self, e: &Entry, fits: &[&FitReport]) -> Result<()> {
        let pick = |k: ModelKind| fits.iter().find(|r| r.model == k.name()).copied();
        let six = fitted(pick(ModelKind::Six).context("six fit")?)?;
        let curves = [ModelKind::Six, ModelKind::Five, ModelKind::Minnaert]
            .into_iter()
            .filter_map(pick)
            .map(fitted)
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
