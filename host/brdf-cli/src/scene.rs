//! `brdf scene`: a target's laser radar cross-section over a sensor sweep, and the BRDF
//! queries it makes (`brdf_scene`).

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::progress;
use anyhow::{Context, Result};
use brdf_scene::lrcs::{lrcs, LrcsReport};
use brdf_scene::scene::{Mode, Scene};
use clap::{Args, Subcommand};

/// Scenes: a target mesh with a material per part and a sensor sweep (a TOML scene file).
#[derive(Debug, Args)]
pub struct SceneCmd {
    #[command(subcommand)]
    command: SceneSub,
}

#[derive(Debug, Subcommand)]
enum SceneSub {
    /// Laser radar cross-section per aspect: sigma = sum over facets seen by source and
    /// receiver of 4 pi f_r cos(theta_i) cos(theta_r) A (m^2), as CSV
    /// `azimuth,elevation,lrcs` (with a list of wavelengths, `[sensor] wavelength_um = [0.45,
    /// 0.55]`, one column per wavelength: `azimuth,elevation,lrcs_0.45um,lrcs_0.55um`).
    Lrcs(LrcsCmd),
    /// The (theta_i, theta_r, phi) queries the scene makes, one row per aspect and facet
    /// seen, with the weight each carries in sigma (m^2 sr).
    Domain(DomainCmd),
    /// Range profile per aspect: sigma per range bin along the line of sight (each facet's
    /// sigma split over the bins by the share of its area in each), as CSV
    /// `azimuth,elevation,range_m,lrcs`; each aspect's bins sum to its sigma. range_m is the
    /// bin's centre beyond the plane through the mesh origin across the line of sight
    /// (bistatic: half the extra path); bins are fixed, [k b, (k + 1) b).
    Profile(ProfileCmd),
    /// Laser image of one aspect: sigma per pixel (m^2) with visibility by the part of each
    /// facet seen (a depth buffer along the line of sight), and the range image beside it, as
    /// a PNG or SVG (and, with --csv, the pixels as CSV `column,row,x_m,y_m,lrcs,range_m`:
    /// x_m, y_m the pixel's centre on the image's right and up axes through the mesh origin).
    Image(ImageCmd),
    /// Joins the CSVs of `brdf scene lrcs --shard K/N` (every shard, in order) into the CSV
    /// of one run, byte for byte; refuses shards that are missing, repeated, out of order, of
    /// another sweep, with another header than this scene writes, or with rows that are not
    /// numbers. A shard of another scene with the same sweep and columns, or run with another
    /// --visibility, cannot be told from its CSV: keep each job array's shards together.
    Merge(MergeCmd),
}

/// `brdf scene image`.
#[derive(Debug, Args)]
pub struct ImageCmd {
    /// Scene file (TOML).
    scene: PathBuf,
    /// The aspect: receiver azimuth and elevation in degrees (default: the sweep's first).
    #[arg(long, value_name = "AZ,EL", allow_hyphen_values = true)]
    aspect: Option<String>,
    /// Pixels along the image's longer side (1 to 4096, and pixels x supersample at most
    /// 4096: at most 1022 with the default --supersample 4).
    #[arg(long, default_value_t = brdf_scene::image::IMAGE_PIXELS)]
    pixels: usize,
    /// Depth-buffer samples per pixel along each side (1 to 16).
    #[arg(long, default_value_t = brdf_scene::image::SUPERSAMPLE)]
    supersample: usize,
    /// The picture (.png or .svg).
    #[arg(short = 'o', long)]
    output: PathBuf,
    /// Also write the pixels as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
}

/// `brdf scene profile`.
#[derive(Debug, Args)]
pub struct ProfileCmd {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Bin width along the line of sight, m.
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    bin_m: f64,
    /// Spread each bin by a Gaussian pulse of this full width at half maximum, m (the sum is
    /// kept).
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    pulse_m: Option<f64>,
    /// Write the CSV here instead of standard output.
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
    /// Draw sigma per range bin against aspect, log colour scale (.svg or .png).
    #[arg(long)]
    plot: Option<PathBuf>,
}

/// `brdf scene lrcs`.
#[derive(Debug, Args)]
pub struct LrcsCmd {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Write the CSV here instead of standard output.
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
    /// Print JSON (per aspect: sigma, each material's share, facets seen) instead of CSV.
    #[arg(long)]
    json: bool,
    /// Draw sigma against azimuth, one curve per elevation (.svg or .png).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Which part of a facet counts: all of it when its centroid is seen (`centroid`, fast),
    /// or the part seen (`area`: each aspect's laser image summed, with a sampling bound per
    /// aspect; `--pixels`, `--supersample` set its resolution).
    #[arg(long, value_enum, default_value = "centroid")]
    visibility: Visibility,
    /// With --visibility area: pixels along each aspect's longer side (1 to 4096, and pixels
    /// x supersample at most 4096: at most 1022 with the default --supersample 4; 128 unless
    /// given, 512 samples a side: the stated sampling bound shrinks about as the pixel size,
    /// the time grows up to its square).
    #[arg(long)]
    pixels: Option<usize>,
    /// With --visibility area: depth-buffer samples per pixel along each side (1 to 16; 4
    /// unless given).
    #[arg(long)]
    supersample: Option<usize>,
    /// Only shard K of N of the sweep (0 <= K < N): of its aspects in order, those from K x
    /// total / N up to (K + 1) x total / N, for a job array; `brdf scene merge` joins the
    /// shards' CSVs into one run's. CSV only.
    #[arg(long, value_parser = crate::common::parse_shard)]
    shard: Option<(usize, usize)>,
}

/// The header of `brdf scene lrcs`'s CSV: `azimuth,elevation,lrcs`, or one column per
/// wavelength of a list (`lrcs_0.55um`).
fn lrcs_header(scene: &Scene) -> String {
    if scene.spectrum.is_empty() {
        return "azimuth,elevation,lrcs".to_owned();
    }
    let columns: Vec<String> = scene
        .spectrum
        .iter()
        .map(|(um, _)| format!("lrcs_{}um", brdf_fit::data::wavelength_text(*um)))
        .collect();
    format!("azimuth,elevation,{}", columns.join(","))
}

/// `brdf scene merge`.
#[derive(Debug, Args)]
pub struct MergeCmd {
    /// Scene file (TOML) the shards were computed from.
    scene: PathBuf,
    /// The shards' CSVs, shard 0 first.
    #[arg(required = true)]
    shards: Vec<PathBuf>,
    /// Write the CSV here instead of standard output.
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
}

/// What part of a facet counts in σ.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Visibility {
    /// The whole facet when the rays from its centroid to source and receiver are free.
    Centroid,
    /// The part of it seen and lit (a depth buffer along the line of sight).
    Area,
}

/// `brdf scene domain`.
#[derive(Debug, Args)]
pub struct DomainCmd {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Write the CSV here instead of standard output.
    #[arg(short = 'o', long)]
    output: Option<PathBuf>,
}

fn load(path: &Path) -> Result<Scene> {
    Ok(Scene::open(path)?)
}

/// Standard output or a file, buffered.
fn sink(output: &Option<PathBuf>) -> Result<Box<dyn Write>> {
    Ok(match output {
        Some(p) => Box::new(std::io::BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("cannot write {}", p.display()))?,
        )),
        None => Box::new(std::io::BufWriter::new(std::io::stdout().lock())),
    })
}

impl SceneCmd {
    pub fn run(self) -> Result<()> {
        match self.command {
            SceneSub::Lrcs(c) => c.run(),
            SceneSub::Domain(c) => c.run(),
            SceneSub::Profile(c) => c.run(),
            SceneSub::Image(c) => c.run(),
            SceneSub::Merge(c) => c.run(),
        }
    }
}

impl LrcsCmd {
    fn run(self) -> Result<()> {
        if let Some(plot) = &self.plot {
            brdf_plot::check_path(plot)?; // before the sweep, not after it
        }
        let mut scene = load(&self.scene)?;
        if let Some((k, n)) = self.shard {
            if self.json || self.plot.is_some() {
                anyhow::bail!(
                    "--shard writes CSV for `brdf scene merge`; --json and --plot describe the whole \
                     sweep: run them without --shard"
                );
            }
            scene = scene.with_shard(k, n).map_err(anyhow::Error::msg)?;
        }
        crate::common::distinct_outputs(
            &[("-o", self.output.as_deref()), ("--plot", self.plot.as_deref())],
            &scene.files(),
        )?;
        let n = scene.aspects().len();
        let bar = progress::bar(n, "aspects");
        let by_area = brdf_scene::image::ImageOptions {
            pixels: self.pixels.unwrap_or(brdf_scene::image::SWEEP_PIXELS),
            supersample: self.supersample.unwrap_or(brdf_scene::image::SUPERSAMPLE),
        };
        let result = match self.visibility {
            Visibility::Centroid => {
                if self.pixels.is_some() || self.supersample.is_some() {
                    anyhow::bail!("--pixels and --supersample set the resolution of --visibility area");
                }
                lrcs(&scene, &|| bar.inc(1))
            }
            Visibility::Area => {
                brdf_scene::lrcs::lrcs_by_area(&scene, &by_area, &|| bar.inc(1), &brdf_fit::Stop::new())?
                    .context("the sweep was stopped")?
            }
        };
        bar.finish_and_clear();
        let (lo, hi) = result
            .aspects
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), a| {
                (lo.min(a.lrcs), hi.max(a.lrcs))
            });
        eprintln_lossy!(
            "{}: {} facets, {} aspects in {:.2} s; sigma from {lo:.4e} to {hi:.4e} m^2",
            self.scene.display(),
            scene.mesh.facets.len(),
            n,
            result.seconds
        );
        if let Some((a, b)) = result
            .aspects
            .iter()
            .filter_map(|a| a.sampling_bound.map(|b| (a, b)))
            .max_by(|x, y| {
                (x.1 / x.0.lrcs.max(f64::MIN_POSITIVE)).total_cmp(&(y.1 / y.0.lrcs.max(f64::MIN_POSITIVE)))
            })
        {
            // Where sigma is 0 the bound is no fraction of it: say it in m^2.
            let worst = if a.lrcs > 0.0 {
                format!("at most {:.2e} of sigma", b / a.lrcs)
            } else {
                format!("{b:.4e} m^2 where sigma is 0")
            };
            eprintln_lossy!(
                "visibility by area ({} pixels, {}x{} samples each): sampling bound {worst} \
                 (azimuth {}, elevation {})",
                by_area.pixels,
                by_area.supersample,
                by_area.supersample,
                a.azimuth,
                a.elevation
            );
        }
        if result.aspects.iter().all(|a| a.facets_seen == 0) {
            // Facing but unseen (hidden by other facets, or thinner than a sample) is not wound
            // inside out.
            let facing = scene.aspects().iter().any(|a| {
                brdf_scene::queries::facing_queries(&scene, a, |_, _| true)
                    .iter()
                    .any(|b| !b.is_empty())
            });
            if !facing {
                eprintln_lossy!(
                    "warning: no facet faces the sensor at any aspect, so sigma is 0 everywhere: \
                     is the mesh wound inside out (facets are counter-clockwise seen from \
                     outside), or does the sweep see only back faces?"
                );
            } else if self.visibility == Visibility::Area {
                eprintln_lossy!(
                    "warning: no sample of any aspect sees a lit facet, so sigma is 0 everywhere \
                     (each aspect's sampling bound says how much may be missing): facets face \
                     source and receiver, but others hide them, or they are thinner than a \
                     sample (give more --pixels)"
                );
            } else {
                eprintln_lossy!(
                    "warning: no facet is seen at any aspect, so sigma is 0 everywhere: facets \
                     face source and receiver, but other facets hide each one's centroid from \
                     one or the other"
                );
            }
        }
        for (k, m) in scene.materials.iter().enumerate() {
            let share = result.outside_coverage(k);
            if m.table.is_some() && share > 0.0 {
                eprintln_lossy!(
                    "warning: material {k} ({}, a fitted table): {:.1}% of its sigma over the sweep comes \
                     from directions its measurements did not cover (the table's smoothness term \
                     extrapolated there)",
                    m.part,
                    100.0 * share
                );
            }
        }
        let mut out = sink(&self.output)?;
        if self.json {
            let j = LrcsReport::new(self.scene.display().to_string(), &scene, &result);
            writeln!(out, "{}", serde_json::to_string_pretty(&j)?)?;
        } else if scene.spectrum.is_empty() {
            writeln!(out, "{}", lrcs_header(&scene))?;
            for a in &result.aspects {
                writeln!(out, "{},{},{}", a.azimuth, a.elevation, a.lrcs)?;
            }
        } else {
            writeln!(out, "{}", lrcs_header(&scene))?;
            for a in &result.aspects {
                let values: Vec<String> = a.by_wavelength.iter().map(f64::to_string).collect();
                writeln!(out, "{},{},{}", a.azimuth, a.elevation, values.join(","))?;
            }
        }
        out.flush().context("cannot write the output")?;
        if let Some(plot) = &self.plot {
            // One curve per elevation, and per wavelength of a list.
            let columns: Vec<Option<(usize, f64)>> = match scene.spectrum.len() {
                0 => vec![None],
                _ => scene.spectrum.iter().map(|w| w.0).enumerate().map(Some).collect(),
            };
            let curves: Vec<brdf_plot::PolarCurve> = scene
                .sensor
                .elevation_deg
                .iter()
                .flat_map(|&el| columns.iter().map(move |c| (el, *c)))
                .map(|(el, column)| brdf_plot::PolarCurve {
                    label: match column {
                        None => format!("elevation {el}°"),
                        Some((_, um)) => {
                            format!("elevation {el}°, {} µm", brdf_fit::data::wavelength_text(um))
                        }
                    },
                    points: result
                        .aspects
                        .iter()
                        .filter(|a| a.elevation == el)
                        .map(|a| (a.azimuth, column.map_or(a.lrcs, |(k, _)| a.by_wavelength[k])))
                        .collect(),
                })
                .collect();
            let mode = match scene.sensor.mode {
                Mode::Monostatic => "monostatic".to_owned(),
                Mode::Bistatic { separation_deg } => format!("bistatic, {separation_deg}° separation"),
            };
            let title = format!("Laser radar cross-section of {} ({mode})", self.scene.display());
            brdf_plot::polar(plot, &title, "sigma / m^2", &curves)?;
            eprintln_lossy!("wrote {}", plot.display());
        }
        Ok(())
    }
}

impl ImageCmd {
    fn run(self) -> Result<()> {
        use brdf_scene::image::{image, ImageOptions};
        use brdf_scene::scene::Aspect;
        brdf_plot::check_path(&self.output)?;
        let scene = load(&self.scene)?;
        crate::common::distinct_outputs(
            &[
                ("-o", Some(self.output.as_path())),
                ("--csv", self.csv.as_deref()),
            ],
            &scene.files(),
        )?;
        let aspect = match &self.aspect {
            None => scene.aspects()[0],
            Some(text) => {
                let parts: Vec<&str> = text.split(',').collect();
                let [az, el] = parts[..] else {
                    anyhow::bail!("--aspect `{text}`: need AZ,EL in degrees");
                };
                let number = |t: &str, what: &str, lo: f64, hi: f64| -> Result<f64> {
                    match t.trim().parse::<f64>() {
                        Ok(v) if v.is_finite() && (lo..=hi).contains(&v) => Ok(v),
                        _ => anyhow::bail!(
                            "--aspect `{text}`: {what} `{t}` is not a number of degrees in [{lo}, {hi}]"
                        ),
                    }
                };
                let turns = brdf_fit::data::PHI_LIMIT_DEG;
                Aspect {
                    azimuth_deg: number(az, "azimuth", -turns, turns)?,
                    elevation_deg: number(el, "elevation", -90.0, 90.0)?,
                }
            }
        };
        let options = ImageOptions {
            pixels: self.pixels,
            supersample: self.supersample,
        };
        let started = std::time::Instant::now();
        let img = image(&scene, &aspect, &options)?;
        let seconds = started.elapsed().as_secs_f64();
        // σ with visibility by centroid at the same aspect, for comparison.
        let centroid: f64 = brdf_scene::queries::aspect_queries(&scene, &aspect, &mut Vec::new())
            .iter()
            .zip(&scene.materials)
            .map(|(b, m)| b.sigma(&m.evaluator(), &mut Vec::new()))
            .fold(0.0, |s, x| s + x);
        eprintln_lossy!(
            "{}: azimuth {}, elevation {}: {} x {} pixels of {:.4e} m ({}x{} samples each) in {seconds:.2} s; \
             sigma {:.6e} m^2 by the area seen (sampling bound {:.2e}), {centroid:.6e} by facet centroids",
            self.scene.display(),
            aspect.azimuth_deg,
            aspect.elevation_deg,
            img.width,
            img.height,
            img.pixel_m,
            self.supersample,
            self.supersample,
            img.lrcs(),
            img.sigma_bound(),
        );
        if img.sigma.iter().all(|&v| v == 0.0) && img.sigma_bound() == 0.0 {
            anyhow::bail!(
                "{}: no facet faces source and receiver at azimuth {}, elevation {}, or every \
                 one is in shadow, so sigma is 0 and there is nothing to draw",
                self.scene.display(),
                aspect.azimuth_deg,
                aspect.elevation_deg
            );
        }
        if img.sigma.iter().all(|&v| v == 0.0) {
            // A target thinner than a sample is missed by every sample; say so, with the
            // bound, rather than the plot's bare "nothing to plot".
            anyhow::bail!(
                "{}: no sample sees a lit facet at azimuth {}, elevation {}, so sigma is 0 and \
                 there is nothing to draw; the sampling bound says up to {:.4e} m^2 may be \
                 missed (parts thinner than a sample, {:.4e} m, slip between samples: give \
                 more --pixels or --supersample)",
                self.scene.display(),
                aspect.azimuth_deg,
                aspect.elevation_deg,
                img.sigma_bound(),
                img.pixel_m / self.supersample as f64
            );
        }
        let title = format!(
            "{}: azimuth {}°, elevation {}°, σ = {:.4e} m²",
            self.scene.display(),
            aspect.azimuth_deg,
            aspect.elevation_deg,
            img.lrcs()
        );
        let pixels = brdf_plot::Pixels {
            width: img.width,
            height: img.height,
            pixel_m: img.pixel_m,
            sigma: &img.sigma,
            range: &img.range,
        };
        brdf_plot::laser_image(&self.output, &title, &pixels)?;
        eprintln_lossy!("wrote {}", self.output.display());
        if let Some(path) = &self.csv {
            let mut out = sink(&Some(path.clone()))?;
            writeln!(out, "column,row,x_m,y_m,lrcs,range_m")?;
            for (k, (s, r)) in img.sigma.iter().zip(&img.range).enumerate() {
                let (col, row) = (k % img.width, k / img.width);
                // On the image's axes through the mesh origin.
                let x = img.origin_m[0] + (col as f64 + 0.5) * img.pixel_m;
                let y = img.origin_m[1] + (img.height - row) as f64 * img.pixel_m - 0.5 * img.pixel_m;
                let r = if r.is_finite() {
                    r.to_string()
                } else {
                    String::new()
                };
                writeln!(out, "{col},{row},{x},{y},{s},{r}")?;
            }
            out.flush().context("cannot write the CSV")?;
            eprintln_lossy!("wrote {}", path.display());
        }
        Ok(())
    }
}

impl ProfileCmd {
    fn run(self) -> Result<()> {
        use brdf_scene::profile::{check, profile, ProfileOptions};
        if let Some(plot) = &self.plot {
            brdf_plot::check_path(plot)?; // before the sweep, not after it
        }
        let scene = load(&self.scene)?;
        crate::common::distinct_outputs(
            &[("-o", self.output.as_deref()), ("--plot", self.plot.as_deref())],
            &scene.files(),
        )?;
        let options = ProfileOptions {
            bin_m: self.bin_m,
            pulse_m: self.pulse_m,
        };
        // Refused before the sweep: a bin that is no length, or too many bins.
        check(&scene, &options)?;
        let n = scene.aspects().len();
        let bar = progress::bar(n, "aspects");
        let started = std::time::Instant::now();
        let profiles = profile(&scene, &options, &|| bar.inc(1))?;
        bar.finish_and_clear();
        let rows: usize = profiles.iter().map(|p| p.sigma.len()).sum();
        eprintln_lossy!(
            "{}: {} facets, {n} aspects, {rows} range bins of {} m{} in {:.2} s",
            self.scene.display(),
            scene.mesh.facets.len(),
            self.bin_m,
            self.pulse_m.map_or(String::new(), |w| format!(" (pulse {w} m)")),
            started.elapsed().as_secs_f64()
        );
        let mut out = sink(&self.output)?;
        writeln!(out, "azimuth,elevation,range_m,lrcs")?;
        for p in &profiles {
            for (j, v) in p.sigma.iter().enumerate() {
                let range = brdf_core::Compact(p.range_label(j, self.bin_m));
                writeln!(out, "{},{},{range},{v}", p.azimuth, p.elevation)?;
            }
        }
        out.flush().context("cannot write the output")?;
        if let Some(plot) = &self.plot {
            let columns: Vec<brdf_plot::ProfileColumn<'_>> = profiles
                .iter()
                .map(|p| brdf_plot::ProfileColumn {
                    azimuth: p.azimuth,
                    elevation: p.elevation,
                    first_bin: p.first_bin,
                    sigma: &p.sigma,
                })
                .collect();
            let title = format!(
                "{}: σ per {} m range bin{}",
                self.scene.display(),
                self.bin_m,
                self.pulse_m.map_or(String::new(), |w| format!(", pulse {w} m"))
            );
            brdf_plot::range_profile(plot, &title, self.bin_m, &columns)?;
            eprintln_lossy!("wrote {}", plot.display());
        }
        Ok(())
    }
}

impl MergeCmd {
    fn run(self) -> Result<()> {
        let scene = load(&self.scene)?;
        if let Some(out) = &self.output {
            crate::common::not_an_input("-o", out, scene.files())?;
            if let Some(s) = self.shards.iter().find(|s| crate::common::same_file(out, s)) {
                anyhow::bail!("-o names the shard {}", s.display());
            }
        }
        let aspects = scene.aspects();
        let n = self.shards.len();
        let header = lrcs_header(&scene);
        let width = header.split(',').count();
        let mut rows = Vec::with_capacity(aspects.len());
        for (k, path) in self.shards.iter().enumerate() {
            let text = brdf_fit::data::read_input(path)
                .with_context(|| format!("cannot read shard {}", path.display()))?;
            // A shard cut short mid-row would otherwise pass with its last number truncated.
            if !text.is_empty() && !text.ends_with('\n') {
                anyhow::bail!(
                    "{}: does not end with a line break: cut short while being written?",
                    path.display()
                );
            }
            let mut lines = text.lines();
            let head = lines
                .next()
                .with_context(|| format!("{}: empty: not a shard's CSV", path.display()))?;
            if head != header {
                anyhow::bail!(
                    "{}: line 1: header `{head}` is not the `{header}` {} writes (a shard of \
                     another scene, or of another list of wavelengths?)",
                    path.display(),
                    self.scene.display()
                );
            }
            // Shard k of n holds exactly these aspects, in order.
            let want = &aspects[Scene::shard_range(k, n, aspects.len())];
            let mut got = 0;
            for (j, line) in lines.enumerate() {
                let at = |what: String| anyhow::anyhow!("{}: line {}: {what}", path.display(), j + 2);
                let mut cols = line.split(',');
                let mut angle = |name: &str| -> Result<f64> {
                    let t = cols.next().unwrap_or("");
                    t.parse::<f64>()
                        .map_err(|_| at(format!("{name} `{t}` is not a number")))
                };
                let (az, el) = (angle("azimuth")?, angle("elevation")?);
                // Every field a number, as many as the header names.
                let fields = line.split(',').count();
                if fields != width {
                    return Err(at(format!("{fields} fields where the header names {width}")));
                }
                // Each field as one run writes it (the shortest form that reads back, so the
                // merge is that run's bytes), and each sigma a finite number, not negative.
                for (i, t) in line.split(',').enumerate() {
                    let name = ["azimuth", "elevation"].get(i).copied().unwrap_or("sigma");
                    let v = t
                        .parse::<f64>()
                        .map_err(|_| at(format!("{name} `{t}` is not a number")))?;
                    if i >= 2 && !(v.is_finite() && v >= 0.0 && v.is_sign_positive()) {
                        return Err(at(format!(
                            "sigma `{t}` is not a finite cross-section (0 or more)"
                        )));
                    }
                    if format!("{v}") != t {
                        return Err(at(format!(
                            "{name} `{t}` is not written as `brdf scene lrcs` writes it (`{v}`): an \
                             edited shard?"
                        )));
                    }
                }
                let Some(a) = want.get(j) else {
                    return Err(at(format!(
                        "shard {k} of {n} holds {} aspects of the sweep's {}; this row is one more \
                         (shards out of order, repeated, or of another sweep?)",
                        want.len(),
                        aspects.len()
                    )));
                };
                if (az, el) != (a.azimuth_deg, a.elevation_deg) {
                    return Err(at(format!(
                        "aspect ({az}, {el}) where shard {k} of {n} holds ({}, {}) (shards out of \
                         order, or of another sweep?)",
                        a.azimuth_deg, a.elevation_deg
                    )));
                }
                rows.push(line.to_owned());
                got += 1;
            }
            if got != want.len() {
                anyhow::bail!(
                    "{}: {got} aspects where shard {k} of {n} holds {} (a shard cut short, or the \
                     shards of another split?)",
                    path.display(),
                    want.len()
                );
            }
        }
        let mut out = sink(&self.output)?;
        writeln!(out, "{header}")?;
        for r in rows {
            writeln!(out, "{r}")?;
        }
        out.flush().context("cannot write the output")?;
        eprintln_lossy!("{}: {n} shards, {} aspects", self.scene.display(), aspects.len());
        Ok(())
    }
}

impl DomainCmd {
    fn run(self) -> Result<()> {
        let scene = load(&self.scene)?;
        if let Some(out) = &self.output {
            crate::common::not_an_input("-o", out, scene.files())?;
        }
        let aspects = scene.aspects().len();
        let bar = progress::bar(aspects, "aspects");
        let out = sink(&self.output)?;
        // Streamed: the queries of a few hundred aspects at a time (a million aspects held at
        // once ran out of memory).
        let n = brdf_scene::queries::write_csv_streamed(&scene, out, &|| bar.inc(1))
            .context("cannot write the queries")?;
        bar.finish_and_clear();
        eprintln_lossy!("{}: {n} queries over {aspects} aspects", self.scene.display());
        Ok(())
    }
}
