//! `brdf plot`: fit models to a dataset and draw them.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use brdf_core::ModelKind;
use brdf_fit::report::FitReport;
use brdf_fit::Dataset;
use brdf_plot::Fitted;
use clap::{Args, ValueEnum};

use crate::common::{legend, EngineArgs};
use crate::params::parse_kind;

/// What to draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PlotKind {
    /// Measured points and fitted models against the signed scattering angle, one panel per
    /// incidence angle.
    InPlane,
    /// The first model over the viewing hemisphere at --theta-i, heat-mapped polar projection.
    Map,
    /// Relative residuals of the first model against angle.
    Residuals,
    /// The first model fitted to every band of a spectral file: its weights, the albedo at
    /// normal incidence and the RMS relative error against wavelength.
    Spectrum,
}

/// Fit one or more models to a dataset and plot them (SVG or PNG, by the extension of -o).
#[derive(Debug, Args)]
pub struct PlotCmd {
    /// Plot kind.
    #[arg(value_enum)]
    kind: PlotKind,
    /// Data file (canonical CSV, or any format with --format).
    data: PathBuf,
    /// Models to fit and draw, comma-separated (first one for map and residuals).
    #[arg(long, value_delimiter = ',', value_parser = parse_kind, default_value = "six")]
    models: Vec<ModelKind>,
    /// Incidence angle of the map, degrees.
    #[arg(long, default_value_t = 30.0, value_parser = crate::common::degrees(0.0, 90.0))]
    theta_i: f64,
    /// Title (default: the dataset name).
    #[arg(long)]
    title: Option<String>,
    /// Which dataset of a file with `sample`/`wavelength` groups, e.g. `wavelength=0.532`.
    #[arg(long)]
    group: Option<String>,
    /// Output file, .svg or .png.
    #[arg(short = 'o', long)]
    output: PathBuf,
    #[command(flatten)]
    engine: EngineArgs,
}

/// Fits `models` to `data` and returns the legend entries with the reports.
pub fn fit_models(
    data: &Dataset,
    models: &[ModelKind],
    engine: &EngineArgs,
) -> Result<Vec<(FitReport, Fitted)>> {
    let mut out = Vec::new();
    for &m in models {
        let r = brdf_fit::fit_all(&engine.settings(m)?, std::slice::from_ref(data))?
            .pop()
            .context("one report")?;
        let f = legend(&r)?;
        out.push((r, f));
    }
    Ok(out)
}

impl PlotCmd {
    pub fn run(self) -> Result<()> {
        crate::common::not_an_input("-o", &self.output, [self.data.as_path()])?;
        brdf_plot::check_path(&self.output)?;
        let mut datasets = self.engine.load(std::slice::from_ref(&self.data))?;
        if self.kind == PlotKind::Spectrum {
            return self.spectrum(datasets);
        }
        if let Some(g) = &self.group {
            let tag = format!("[{g}]");
            datasets.retain(|d| d.name.ends_with(&tag));
            if datasets.is_empty() {
                bail!("{}: no dataset {tag}", self.data.display());
            }
        }
        if datasets.len() != 1 {
            let names: Vec<&str> = datasets.iter().map(|d| d.name.as_str()).collect();
            bail!(
                "{}: holds {} datasets; choose one with --group (the part in brackets of {})",
                self.data.display(),
                datasets.len(),
                names.join(", ")
            );
        }
        let data = &datasets[0];
        if self.models.is_empty() {
            bail!("--models: name at least one model");
        }
        let fits = fit_models(data, &self.models, &self.engine)?;
        let title = self.title.clone().unwrap_or_else(|| data.name.clone());
        let curves: Vec<Fitted> = fits.iter().map(|(_, f)| f.clone()).collect();
        match self.kind {
            PlotKind::InPlane => brdf_plot::in_plane(&self.output, &title, data, &curves)?,
            PlotKind::Map => brdf_plot::hemisphere_map(
                &self.output,
                &format!("{title}, {}", curves[0].label),
                &curves[0].model,
                self.theta_i.to_radians(),
            )?,
            PlotKind::Residuals => brdf_plot::residuals(&self.output, &title, data, &curves[0])?,
            PlotKind::Spectrum => unreachable!("drawn by `spectrum` above"),
        }
        eprintln_lossy!("wrote {}", self.output.display());
        Ok(())
    }

    /// `spectrum`: every band of the file's one spectral measurement, fitted with the first
    /// model (in parallel, as `brdf fit`), drawn against wavelength.
    fn spectrum(&self, datasets: Vec<Dataset>) -> Result<()> {
        if self.group.is_some() {
            bail!("--group picks one dataset; spectrum draws every band of the file");
        }
        let Some(&model) = self.models.first() else {
            bail!("--models: name a model");
        };
        if self.models.len() > 1 {
            eprintln_lossy!(
                "note: spectrum draws the first model, {}; the others are not fitted",
                model.name()
            );
        }
        let settings = self.engine.settings(model)?;
        let (datasets, skipped) = brdf_fit::fittable(&settings, datasets, self.engine.skip_invalid)?;
        for s in &skipped {
            eprintln_lossy!("{s}");
        }
        let reports = brdf_fit::fit_all(&settings, &datasets)?;
        let spectra = brdf_fit::spectral::spectra(&reports);
        let s = match &spectra[..] {
            [one] => one,
            [] => bail!(
                "{}: no spectral measurement with two or more bands (datasets named FILE[wavelength=...]: \
                 a spectral --format cornell or nist file, or a CSV with a wavelength column)",
                self.data.display()
            ),
            many => bail!(
                "{}: holds {} spectral measurements ({}); give a file of one",
                self.data.display(),
                many.len(),
                many.iter()
                    .map(|s| s.measurement.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        };
        let title = self.title.clone().unwrap_or_else(|| s.measurement.clone());
        brdf_plot::spectrum(&self.output, &title, s)?;
        crate::fit::write_spectrum(&mut std::io::stdout().lock(), s)?;
        eprintln_lossy!("wrote {}", self.output.display());
        Ok(())
    }
}
