//! Pieces shared by the fitting subcommands.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use brdf_core::names::{Named, UnknownName};
use brdf_core::ModelKind;
use brdf_fit::import::{Channel, Format};
use brdf_fit::request::{Limit, AGREE, ANNEAL_EVALS, CHAINS, HOPS};
use brdf_fit::spectral::BandShape;
use brdf_fit::{load_csv, Dataset, FitRequest, FitSettings, LoadOptions, LossKind, Residual};
use clap::Args;

use crate::formats::import_reporting;

/// Options of the fitting engine.
#[derive(Clone, Debug, Args)]
pub struct EngineArgs {
    /// Seed of the run (annealing chains); the same seed gives the same result.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Residual form: relative ((f - y) / y), absolute (f - y in 1/sr) or log (ln f - ln y).
    #[arg(long, value_parser = named::<Residual>, default_value_t = Residual::Relative)]
    pub residual: Residual,
    /// Most annealing chains, each polished by Levenberg-Marquardt (1 to 64; default 32; full
    /// engine).
    #[arg(long, value_parser = limit(CHAINS))]
    pub chains: Option<u64>,
    /// Independent searches (chains or basin hops) that must reach the best cost before
    /// the fit is called converged; at least this many chains run (1 to 64; default 3; full
    /// engine).
    #[arg(long, value_parser = limit(AGREE))]
    pub agree: Option<u64>,
    /// Basin-hopping moves from the best point that must all fail to improve it before the
    /// fit is called converged (0 to 64; default 4; full engine). More hops and agreeing
    /// searches catch more local optima on noisy data from few incidences, at more time (see
    /// the README).
    #[arg(long, value_parser = limit(HOPS))]
    pub hops: Option<u64>,
    /// Cost evaluations per annealing chain (1 to 100,000,000; default 300; full engine).
    #[arg(long, value_parser = limit(ANNEAL_EVALS))]
    pub anneal_evals: Option<u64>,
    /// Robust loss (as scipy's least_squares): linear (least squares), huber, soft-l1 or
    /// cauchy. Residuals beyond --loss-scale count less than squared.
    #[arg(long, value_parser = named::<LossKind>, default_value_t = LossKind::Linear)]
    pub loss: LossKind,
    /// Scale C of a robust loss, in the residual's units (default 0.1 = a 10% relative
    /// error; not with the linear loss).
    #[arg(long, value_parser = parse_positive)]
    pub loss_scale: Option<f64>,
    /// Let the six-parameter diffuse term brighten towards grazing: search c down to -0.99
    /// (Minnaert's k - 1) instead of 0. The kb + kd energy bound then no longer applies;
    /// the albedo is still checked by quadrature.
    #[arg(long)]
    pub brightening: bool,
    /// Noise floor S of the relative residual, 1/sr: readings count by (f - y) / sqrt(y^2 +
    /// S^2), relative above S and absolute below, so readings at or below zero (a dark
    /// surface's noise) are fitted, not dropped. Default: estimated for each dataset that has
    /// such readings (none otherwise); 0 for none (such readings then refused). Not with log
    /// residuals or the embedded engine.
    #[arg(long, value_parser = parse_non_negative)]
    pub noise_floor: Option<f64>,
    /// The bands of a spectral file (datasets that differ only in `wavelength`): independent
    /// fits each on its own (default: it predicts held-out directions better on the bundled
    /// paints), shared one shape to all with per-band weights (kb, kd; full engine, linear
    /// loss).
    #[arg(long, value_parser = named::<BandShape>)]
    pub bands: Option<BandShape>,
    /// Skip invalid rows (each is listed on standard error) instead of stopping; `brdf fit`
    /// also skips, and lists, the datasets it cannot fit (too few distinct directions).
    #[arg(long)]
    pub skip_invalid: bool,
    /// Read the files in this format (cornell, nist, merl-inplane; converted on the fly,
    /// rejects listed) instead of the canonical CSV.
    #[arg(long, value_parser = named::<Format>)]
    pub format: Option<Format>,
    /// Colour channel for `--format cornell` RGB files (r, g, b; either case; default r).
    #[arg(long, value_parser = named::<Channel>)]
    pub channel: Option<Channel>,
    /// One band, by its wavelength in um, of a spectral `--format cornell` file or a `--format
    /// nist` file (default: every band, each its own dataset).
    #[arg(long, value_parser = parse_positive)]
    pub band: Option<f64>,
}

impl EngineArgs {
    /// The options as a command line without any of them gives them.
    pub fn defaults() -> EngineArgs {
        #[derive(clap::Parser)]
        struct Only {
            #[command(flatten)]
            engine: EngineArgs,
        }
        <Only as clap::Parser>::parse_from(["brdf"]).engine
    }

    /// The options as the library takes them, for `kind` with the full engine.
    pub fn request(&self, kind: ModelKind) -> FitRequest {
        FitRequest {
            model: kind,
            seed: self.seed,
            residual: self.residual,
            chains: self.chains,
            agree: self.agree,
            hops: self.hops,
            anneal_evals: self.anneal_evals,
            loss: self.loss,
            loss_scale: self.loss_scale,
            brightening: self.brightening,
            noise_floor: self.noise_floor,
            bands: self.bands,
            ..FitRequest::new(kind)
        }
    }

    /// Everything that defines a fit of `kind` with these options (full engine).
    pub fn settings(&self, kind: ModelKind) -> Result<FitSettings> {
        Ok(FitSettings::from_options(&self.request(kind))?)
    }

    /// Loads every file; lists skipped rows and the reader's warnings on standard error.
    pub fn load(&self, files: &[PathBuf]) -> Result<Vec<Dataset>> {
        let opts = LoadOptions {
            skip_invalid: self.skip_invalid,
            // Kept: the fit weighs them with a noise floor or refuses them naming the line.
            dark_readings: true,
        };
        let mut out = Vec::new();
        let pick = brdf_fit::import::pick_for(self.format, self.channel, self.band)
            .map_err(|e| anyhow::anyhow!(e))?;
        if let Some(format) = self.format {
            for f in files {
                out.extend(import_reporting(f, format, pick)?.datasets);
            }
            return Ok(out);
        }
        for f in files {
            let loaded = load_csv(f, opts).with_context(|| format!("cannot use {}", f.display()))?;
            for s in &loaded.skipped {
                eprintln_lossy!("{}: skipped line {}: {}", f.display(), s.line, s.reason);
            }
            if !loaded.skipped.is_empty() {
                eprintln_lossy!("{}: {} line(s) skipped", f.display(), loaded.skipped.len());
            }
            for w in &loaded.warnings {
                eprintln_lossy!("warning: {w}");
            }
            out.extend(loaded.datasets);
        }
        Ok(out)
    }
}

/// A clap value parser for a name of the libraries' vocabulary ([`Named`]): the library's
/// `FromStr`, so the message is the one Python and scene files give.
pub fn named<T: std::str::FromStr<Err = UnknownName> + Named>(text: &str) -> Result<T, String> {
    text.parse::<T>().map_err(|e| e.to_string())
}

/// A clap value parser for a whole-number option of the library ([`Limit`]): its range and
/// its message.
pub fn limit(l: Limit) -> impl Fn(&str) -> Result<u64, String> + Clone + Send + Sync + 'static {
    move |text: &str| {
        let v: u64 = text
            .trim()
            .parse()
            .map_err(|_| format!("`{text}` is not a whole number"))?;
        l.check(v).map_err(|e| e.to_string())
    }
}

/// A clap value parser for a whole number in `lo..=hi` (a count or a size): anything else,
/// negative numbers and `1e3` included, is a usage error naming the range.
pub fn count(lo: u64, hi: u64) -> impl clap::builder::TypedValueParser<Value = usize> {
    clap::builder::RangedU64ValueParser::<usize>::new().range(lo..=hi)
}

/// Parses a number of seconds, above 0 and at most a day, into a duration.
pub fn parse_seconds(text: &str) -> Result<std::time::Duration, String> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a number of seconds"))?;
    if !(v.is_finite() && v > 0.0 && v <= 86_400.0) {
        return Err(format!(
            "`{text}` seconds: need a number above 0 and at most 86400"
        ));
    }
    std::time::Duration::try_from_secs_f64(v).map_err(|e| format!("`{text}` seconds: {e}"))
}

/// A clap value parser for an angle in degrees within `[lo, hi]` (finite).
pub fn degrees(lo: f64, hi: f64) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |text: &str| {
        let v: f64 = text
            .trim()
            .parse()
            .map_err(|_| format!("`{text}` is not a number of degrees"))?;
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            return Err(format!("`{text}` degrees: need a value in [{lo}, {hi}]"));
        }
        Ok(v)
    }
}

/// Largest value of a fraction option (`--budget`, `--noise`): 100%. Beyond, an error
/// budget or a relative noise level is a unit mix-up: `--budget 2` meant 2% and was read as
/// 200%, `--noise 50` wrote readings of 4e14.
pub const MAX_FRACTION: f64 = 1.0;

/// Parses `2%` or `0.02` into a fraction in `[0, MAX_FRACTION]`; above, the message says how
/// to write a percentage.
pub fn parse_fraction(text: &str) -> Result<f64, String> {
    let t = text.trim();
    let percent = t.strip_suffix('%');
    let v = match percent {
        Some(p) => p.trim().parse::<f64>().map(|v| v / 100.0),
        None => t.parse::<f64>(),
    }
    .map_err(|_| format!("`{text}` is not a fraction (e.g. 2% or 0.02)"))?;
    if !(v.is_finite() && v >= 0.0) {
        return Err(format!("`{text}` must be a non-negative fraction"));
    }
    if v > MAX_FRACTION {
        let most = brdf_core::Compact(100.0 * MAX_FRACTION);
        return Err(match percent {
            Some(_) => format!("`{text}` is above {most}%"),
            None => format!(
                "`{text}` is a fraction, {}%, above {most}%: for {t} percent write {t}% (or {})",
                brdf_core::Compact(100.0 * v),
                brdf_core::Compact(v / 100.0)
            ),
        });
    }
    Ok(v)
}

/// Parses a finite number greater than zero.
pub fn parse_positive(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{text}` is not a finite number greater than 0")),
    }
}

/// Parses a finite number at or above 0 (`--noise-floor`).
pub fn parse_non_negative(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{text}` is not a finite number at or above 0")),
    }
}

/// Parses `K/N` (0 <= K < N) for `--shard`.
pub fn parse_shard(text: &str) -> Result<(usize, usize), String> {
    let (k, n) = text
        .split_once('/')
        .ok_or_else(|| format!("`{text}` is not of the form K/N"))?;
    let k: usize = k
        .trim()
        .parse()
        .map_err(|_| format!("`{k}` is not a shard index"))?;
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| format!("`{n}` is not a shard count"))?;
    if n == 0 || k >= n {
        return Err(format!("shard {k}/{n}: need 0 <= K < N"));
    }
    Ok((k, n))
}

/// Parses a comma-separated list of numbers.
pub fn parse_list(text: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(|s| {
            let s = s.trim();
            s.parse::<f64>().with_context(|| format!("`{s}` is not a number"))
        })
        .collect::<Result<Vec<_>>>()
        .and_then(|v| {
            if v.is_empty() {
                bail!("empty list")
            }
            Ok(v)
        })
}

/// Writes an encoded blob (`brdf_fit::pack`) to `output`, saying what was written.
pub fn write_blob(packed: &brdf_fit::pack::Packed, output: &std::path::Path) -> Result<()> {
    std::fs::write(output, &packed.bytes).with_context(|| format!("cannot write {}", output.display()))?;
    eprintln_lossy!(
        "wrote {} ({} bytes, {} materials, sequence {}, CRC {:#010x})",
        output.display(),
        packed.bytes.len(),
        packed.materials,
        packed.blob.sequence,
        packed.crc
    );
    Ok(())
}

/// Significant figures of a parameter or a standard error in a table.
pub const SIGNIFICANT: usize = 6;

/// A parameter or standard error as a table prints it: [`SIGNIFICANT`] significant figures,
/// positional when the value rounded to them lies from 1e-4 to below 1e6, and with an
/// exponent outside (a weight of 2.6e-7 printed
/// as `0.000000` with six decimals). Width and alignment as given (`{:>14}`).
#[derive(Clone, Copy, Debug)]
pub struct Sig(pub f64);

impl std::fmt::Display for Sig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        let a = v.abs();
        let text = if !(a.is_finite() && a != 0.0) {
            format!("{v}")
        } else {
            // Rounded to SIGNIFICANT figures first: the form follows the rounded value's
            // decade (999999.7 rounds to 1.00000e6, which is not below 1e6; chosen by the
            // unrounded value it printed `1000000`, seven figures).
            let sci = format!("{v:.*e}", SIGNIFICANT - 1);
            let exponent: i64 = sci[sci.find('e').expect("an exponent") + 1..]
                .parse()
                .expect("an integer exponent");
            if (-4..6).contains(&exponent) {
                // Digits after the point that leave SIGNIFICANT in all.
                let decimals = (SIGNIFICANT as i64 - 1 - exponent).max(0) as usize;
                format!("{v:.decimals$}")
            } else {
                sci
            }
        };
        f.pad(&text)
    }
}

/// Legend entry of a fit (model name and RMS relative error) with its model, for plots.
pub fn legend(r: &brdf_fit::report::FitReport) -> Result<brdf_plot::Fitted> {
    Ok(brdf_plot::Fitted {
        label: format!("{} (RMS rel {:.1}%)", r.model.name(), 100.0 * r.metrics.rms_rel),
        model: r.model()?,
        floor: r.noise_floor.as_ref().map_or(0.0, |f| f.value),
    })
}

/// Whether `a` and `b` name the same file: the same inode when both exist (symbolic and hard
/// links included), else the same path once `..`, `.` and symbolic links of the existing
/// directories are resolved. Used to refuse an output that would overwrite an input or
/// another output of the same command.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return (x.dev(), x.ino()) == (y.dev(), y.ino());
        }
    }
    fn resolved(p: &Path) -> Option<PathBuf> {
        if let Ok(c) = std::fs::canonicalize(p) {
            return Some(c);
        }
        let abs = std::path::absolute(p).ok()?;
        let dir = std::fs::canonicalize(abs.parent()?).ok()?;
        Some(dir.join(abs.file_name()?))
    }
    match (resolved(a), resolved(b)) {
        (Some(x), Some(y)) => x == y,
        _ => std::path::absolute(a).ok() == std::path::absolute(b).ok(),
    }
}

/// Refuses an output (`flag` and its path `out`) that is one of the command's `inputs`
/// ([`same_file`]): writing it would destroy what the command read.
pub fn not_an_input<'a>(flag: &str, out: &Path, inputs: impl IntoIterator<Item = &'a Path>) -> Result<()> {
    for input in inputs {
        if same_file(input, out) {
            bail!(
                "{flag} {} is the input {}: it would be overwritten",
                out.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// Refuses outputs (flags and their paths, `None` where not given) that are one of the
/// command's `inputs` ([`not_an_input`]) or name the same file as each other.
pub fn distinct_outputs(outputs: &[(&str, Option<&Path>)], inputs: &[&Path]) -> Result<()> {
    let given: Vec<(&str, &Path)> = outputs.iter().filter_map(|&(f, p)| p.map(|p| (f, p))).collect();
    for (k, &(flag, out)) in given.iter().enumerate() {
        not_an_input(flag, out, inputs.iter().copied())?;
        if let Some(&(other, _)) = given[..k].iter().find(|(_, p)| same_file(p, out)) {
            bail!(
                "{other} and {flag} name the same file {}: one would overwrite the other",
                out.display()
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Six significant figures at every magnitude: a small parameter is not `0.000000`, a
    /// large one no longer than its figures, and the text reads back within half a unit of the
    /// last figure.
    #[test]
    fn table_numbers_keep_their_significant_figures() {
        for v in [
            2.5678912e-7,
            -4.8545e-9,
            1.23456789e-4,
            0.5,
            -3.0,
            123.456789,
            999_999.4,
            1e6,
            6.02e23,
            // Rounding to six figures carries into another decade: the form is chosen after
            // rounding (999999.7 printed `1000000`, seven figures; 0.000099999996 `1.00000e-4`
            // beside the positional 1e-4).
            999_999.7,
            -999_999.5,
            99_999.95,
            9.999_995,
            9.999_999_9,
            0.000_099_999_996,
            0.000_099_999_94,
            1e21,
            9.999_999e20,
            1e-300,
        ] {
            let text = Sig(v).to_string();
            let back: f64 = text.parse().unwrap();
            let figures: String = text
                .split('e')
                .next()
                .unwrap()
                .chars()
                .filter(char::is_ascii_digit)
                .collect::<String>()
                .trim_start_matches('0')
                .to_owned();
            assert_eq!(figures.len(), SIGNIFICANT, "{v}: {text}");
            let half_unit =
                0.5 * 10f64.powi(back.abs().max(v.abs()).log10().floor() as i32 + 1 - SIGNIFICANT as i32);
            assert!((back - v).abs() <= half_unit * (1.0 + 1e-9), "{v}: {text}");
        }
        assert_eq!(format!("{:>8}", Sig(0.0)), "       0");
    }

    /// The help states each default the library applies when an option is not given.
    #[test]
    fn the_help_states_the_library_defaults() {
        #[derive(clap::Parser)]
        struct Only {
            #[command(flatten)]
            engine: EngineArgs,
        }
        let cmd = <Only as clap::CommandFactory>::command();
        let help = |id: &str| {
            cmd.get_arguments()
                .find(|a| a.get_id() == id)
                .and_then(|a| a.get_long_help().or(a.get_help()))
                .map(|h| h.to_string())
                .unwrap()
        };
        let d = brdf_fit::FitOptions::default();
        for (id, v) in [
            ("chains", d.chains),
            ("agree", d.agree),
            ("hops", d.hops),
            ("anneal_evals", d.anneal.evals),
        ] {
            assert!(help(id).contains(&format!("default {v};")), "{id}: {}", help(id));
        }
        assert!(help("loss_scale").contains(&format!("default {}", brdf_fit::request::DEFAULT_LOSS_SCALE)));
    }
}
