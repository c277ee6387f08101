//! `brdf eval`: a model over a CSV of angles.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use brdf_core::batch::{Batch, BatchError};
use brdf_core::fitted::{Corrected, FittedTable};
use brdf_core::{AnyModel, Brdf, Float, Geometry, ModelKind, MAX_PARAMS};
use clap::{Args, ValueEnum};

use crate::angles::{f32_text, f64_text, radians, AngleReader, AngleWriter, Chunk, CHUNK_ROWS};
use crate::params::{build, parse_kind, parse_params};
use brdf_core::bands::Located;
use brdf_fit::spectral::BandFits;

/// Evaluate a model at every row of a CSV with columns `theta_i,theta_r,phi` (degrees,
/// canonical convention: phi = 180 is the mirror direction). Writes the input columns plus
/// the BRDF in 1/sr to standard output, as it reads (4,096 rows at a time). The model is
/// `--model` with `--params`, or a fit result (`--fit`).
#[derive(Debug, Args)]
pub struct EvalCmd {
    /// Model: six, six-cos2, five, ggx, minnaert, lambert.
    #[arg(long, value_parser = parse_kind, required_unless_present = "fit", requires = "params")]
    model: Option<ModelKind>,
    /// Parameters as name=value pairs, e.g. kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676,c=1.2
    #[arg(long, allow_hyphen_values = true, requires = "model")]
    params: Option<String>,
    /// A fit result as `brdf fit --json` or `brdf select --chosen` writes it (or a
    /// hand-written `{"model": ..., "params": {...}}`): its model and parameters, and its
    /// fitted table when it carries one (`f = f_model * exp(t)`, the device's arithmetic in
    /// f32, the same table in f64).
    #[arg(long, value_name = "FIT.json", conflicts_with_all = ["model", "params"])]
    fit: Option<PathBuf>,
    /// Which fit of a batch result (`brdf fit --json` on several datasets), from 0. For a
    /// spectral fit (the bands of several measurements), any fit of the measurement meant.
    #[arg(long, requires = "fit")]
    index: Option<usize>,
    /// Wavelength in µm at which to evaluate a spectral fit (the bands of one measurement,
    /// `brdf fit` of a spectral file): the band there, or the two bands around it blended
    /// linearly in wavelength; never extrapolated. Without it, each row's `wavelength` column
    /// (µm) is used when the file has one. A fit without bands is the same at every
    /// wavelength.
    #[arg(long, requires = "fit", value_name = "UM", allow_hyphen_values = true)]
    wavelength: Option<f64>,
    /// f64 (reference) or f32 (the firmware's arithmetic: angles converted to radians in
    /// f64, then rounded once to f32; parameters rounded once to f32).
    #[arg(long, value_enum, default_value_t = Precision::F64)]
    precision: Precision,
    /// Name of the output column.
    #[arg(long, default_value = "brdf")]
    output_column: String,
    /// CSV file with a header row containing theta_i, theta_r and phi; other columns are
    /// passed through unchanged.
    angles: PathBuf,
}

/// Most wavelengths whose materials `brdf eval --fit` keeps while it streams rows (a file of
/// a million distinct wavelengths held 420 MB); beyond, the cache starts again.
const BAND_CACHE: usize = 1024;

/// A spectral material at one wavelength: each band's weight, model and fitted table.
type Parts<'a, T> = Vec<(T, AnyModel<T>, Option<FittedTable<'a>>)>;

/// One band of a spectral fit as a weighted part.
fn band_part<T: Float>(
    fit: &brdf_fit::report::OneFit,
    w: T,
) -> Result<(T, AnyModel<T>, Option<FittedTable<'_>>), String> {
    let at = |e: String| format!("fit {}: {e}", fit.index);
    // The ranges hold for the parameters as given (before any rounding to f32).
    build::<f64>(fit.model, &fit.params).map_err(|e| at(e.to_string()))?;
    let model: AnyModel<T> = build(fit.model, &fit.params).map_err(|e| at(e.to_string()))?;
    let table = match &fit.table {
        Some(bytes) => Some(FittedTable::new(bytes).map_err(|e| at(format!("fitted table: {e}")))?),
        None => None,
    };
    Ok((w, model, table))
}

/// A spectral fit at `um` µm: one band, or the two around it with their weights, decided
/// and weighed in `T` from the band centres and the wavelength rounded to `T`
/// (`brdf_core::bands`): in f32 exactly as a device that holds these bands answers EVAL_AT
/// (the same band or blend, the same weight, the same bits), in f64 as [`BandFits::at`].
fn material_at<T: Float>(bands: &BandFits, um: f64) -> Result<Parts<'_, T>, String> {
    // The host's rule and its message first (not a wavelength, outside the bands).
    bands.at(um)?;
    let centres: Vec<T> = bands.bands.iter().map(|b| T::from_f64(b.0)).collect();
    let fit = |k: usize| &bands.bands[k].1;
    Ok(match brdf_core::bands::locate(&centres, T::from_f64(um)) {
        Ok(Located::Band(k)) => vec![band_part(fit(k), T::ONE)?],
        Ok(Located::Between { lower, weight }) => vec![
            band_part(fit(lower), T::ONE - weight)?,
            band_part(fit(lower + 1), weight)?,
        ],
        Err(e) => {
            return Err(format!(
                "{} µm, rounded to the evaluation's precision: {e}",
                brdf_fit::data::wavelength_text(um)
            ))
        }
    })
}

/// Arithmetic precision of the evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Precision {
    /// Double precision (reference; 17 significant digits printed).
    F64,
    /// Single precision, the device path (9 significant digits printed).
    F32,
}

/// Evaluates `model` at every direction (radians) of one chunk into `values`: through the
/// core's batch path when `batch` is given (the f64 reference, within 1e-12 of the scalar
/// path), else through the scalar path (f32: the firmware's arithmetic bit for bit). The
/// reader has validated every angle, so the batch path has no direction to refuse.
pub fn evaluate_chunk<T: Float>(
    model: &AnyModel<T>,
    batch: Option<&Batch<T>>,
    directions: &[[T; 3]],
    values: &mut Vec<T>,
) -> Result<(), BatchError> {
    values.clear();
    match batch {
        Some(b) => {
            let column = |k: usize| directions.iter().map(|d| d[k]).collect::<Vec<T>>();
            values.resize(directions.len(), T::ZERO);
            b.angles(&column(0), &column(1), &column(2), values)
        }
        None => {
            values.extend(
                directions
                    .iter()
                    .map(|&[ti, tr, phi]| model.eval_angles(ti, tr, phi)),
            );
            Ok(())
        }
    }
}

impl EvalCmd {
    pub fn run(self) -> Result<()> {
        let mut table: Option<Vec<u8>> = None;
        let (kind, params) = match (&self.fit, self.model, &self.params) {
            (Some(path), _, _) => {
                let shown = path.display().to_string();
                let text =
                    brdf_fit::data::read_input(path).with_context(|| format!("cannot read {shown}"))?;
                if let Some(bands) = BandFits::read(&text, &shown, self.index).map_err(|e| anyhow!(e))? {
                    return self.eval_bands(&shown, &bands);
                }
                if let Some(um) = self.wavelength.filter(|um| !brdf_fit::data::is_wavelength(*um)) {
                    bail!("--wavelength {um}: not a wavelength above 0 (µm)");
                }
                if self.wavelength.is_some() {
                    // As a scene takes a grey material at its wavelength.
                    eprintln_lossy!(
                        "note: --wavelength: the fit of {shown} has no band: it is the same at every wavelength"
                    );
                }
                let one = brdf_fit::report::FittedModel::one_of(&text, &shown, self.index)
                    .map_err(|e| anyhow!(e))?;
                table = one.table;
                (one.model, one.params)
            }
            // (clap does not apply `requires = "fit"` once --model, which --fit excludes, is given.)
            (None, _, _) if self.index.is_some() => bail!("--index picks a fit of --fit; give --fit"),
            (None, _, _) if self.wavelength.is_some() => {
                bail!("--wavelength picks the bands of --fit; give --fit")
            }
            (None, Some(kind), Some(text)) => (kind, parse_params(kind, text)?),
            _ => bail!("give --model with --params, or --fit"),
        };
        let stdout = std::io::stdout();
        let out = stdout.lock();
        let table = match &table {
            Some(bytes) => Some(FittedTable::new(bytes).map_err(|e| anyhow!("fitted table: {e}"))?),
            None => None,
        };
        match self.precision {
            Precision::F64 => self.eval::<f64>(kind, &params, table, out, f64_text, true),
            Precision::F32 => {
                // The ranges hold for the parameters as given: rounding to f32 must not bring
                // `alpha = 4.0000001` inside.
                build::<f64>(kind, &params)?;
                self.eval::<f32>(kind, &params, table, out, f32_text, false)
            }
        }
    }

    /// A spectral fit: at `--wavelength`, or at each row's `wavelength`.
    fn eval_bands(&self, shown: &str, bands: &BandFits) -> Result<()> {
        let stdout = std::io::stdout();
        match self.precision {
            Precision::F64 => self.eval_bands_in::<f64>(shown, bands, stdout.lock(), f64_text),
            Precision::F32 => self.eval_bands_in::<f32>(shown, bands, stdout.lock(), f32_text),
        }
    }

    fn eval_bands_in<T: Float>(
        &self,
        shown: &str,
        bands: &BandFits,
        out: impl Write,
        text: fn(T) -> String,
    ) -> Result<()> {
        let mut reader = AngleReader::open(&self.angles, &self.output_column)?;
        let column = reader.column("wavelength")?;
        enum Where<'a, T: Float> {
            /// One wavelength for every row.
            Fixed(Parts<'a, T>),
            /// Each row's, from this column.
            Column(usize),
        }
        let at_fixed = |um: f64| -> Result<Where<'_, T>> {
            Ok(Where::Fixed(
                material_at(bands, um).map_err(|e| anyhow!("--wavelength: {shown}: {e}"))?,
            ))
        };
        let source = match (self.wavelength, column) {
            (Some(_), Some(_)) => bail!(
                "--wavelength and the `wavelength` column of {} both give the wavelength: drop one",
                reader.file()
            ),
            (None, None) if bands.bands.len() > 1 => bail!(
                "{shown} holds {}: give --wavelength, or a `wavelength` column (µm) in {}",
                bands.describe(),
                reader.file()
            ),
            (None, None) => at_fixed(bands.bands[0].0)?,
            (Some(um), None) => at_fixed(um)?,
            (None, Some(col)) => Where::Column(col),
        };
        let mut by_band: std::collections::HashMap<u64, Parts<'_, T>> = std::collections::HashMap::new();
        let mut writer = AngleWriter::new(out, &reader, &self.output_column)?;
        let mut chunk = Chunk::default();
        let mut values: Vec<T> = Vec::with_capacity(CHUNK_ROWS);
        while reader.next_chunk(&mut chunk)? > 0 {
            values.clear();
            for (i, &d) in chunk.degrees().iter().enumerate() {
                let parts = match &source {
                    Where::Fixed(parts) => parts,
                    Where::Column(col) => {
                        let at = || format!("{}: line {}: column wavelength", reader.file(), chunk.line(i));
                        let t = chunk.field(i, *col).trim();
                        let Some(um) = brdf_fit::data::parse_wavelength(t) else {
                            bail!("{}: `{t}` is not a wavelength above 0 (µm)", at())
                        };
                        // Rows of many distinct wavelengths: the cache is bounded (each entry
                        // is two bands' models, a few hundred bytes).
                        if by_band.len() >= BAND_CACHE {
                            by_band.clear();
                        }
                        match by_band.entry(um.to_bits()) {
                            std::collections::hash_map::Entry::Occupied(e) => &*e.into_mut(),
                            std::collections::hash_map::Entry::Vacant(e) => &*e.insert(
                                material_at(bands, um).map_err(|m| anyhow!("{}: {shown}: {m}", at()))?,
                            ),
                        }
                    }
                };
                let [ti, tr, phi] = radians::<T>(d);
                let g = Geometry::from_angles(ti, tr, phi);
                let mut f = T::ZERO;
                for (w, model, table) in parts {
                    let v = match table {
                        Some(table) => Corrected {
                            base: *model,
                            table: *table,
                        }
                        .eval(&g),
                        None => model.eval(&g),
                    };
                    f = f + *w * v;
                }
                if !f.is_finite() {
                    bail!(
                        "{}: line {}: {}",
                        reader.file(),
                        chunk.line(i),
                        brdf_fit::params::not_finite(f, parts[0].1.kind())
                    );
                }
                values.push(f);
            }
            writer.write_chunk(&chunk, values.iter().map(|&v| text(v)))?;
        }
        writer.finish()
    }

    fn eval<T: Float>(
        &self,
        kind: ModelKind,
        params: &[f64; MAX_PARAMS],
        table: Option<FittedTable<'_>>,
        out: impl Write,
        text: fn(T) -> String,
        use_batch: bool,
    ) -> Result<()> {
        let model: AnyModel<T> = build(kind, params)?;
        // A fitted table goes through the scalar path (the core's batch kernels are analytic).
        let batch = (use_batch && table.is_none()).then(|| Batch::new(&model));
        let mut reader = AngleReader::open(&self.angles, &self.output_column)?;
        let mut writer = AngleWriter::new(out, &reader, &self.output_column)?;
        let mut chunk = Chunk::default();
        let mut directions: Vec<[T; 3]> = Vec::with_capacity(CHUNK_ROWS);
        let mut values: Vec<T> = Vec::with_capacity(CHUNK_ROWS);
        // Directions outside the table's coverage (the smoothness term's extrapolation), and
        // the first one's line.
        let (mut outside, mut rows, mut first_outside) = (0usize, 0usize, None);
        while reader.next_chunk(&mut chunk)? > 0 {
            directions.clear();
            directions.extend(chunk.degrees().iter().map(|&d| radians::<T>(d)));
            if let Some(table) = table {
                let corrected = Corrected { base: model, table };
                values.clear();
                for (i, &[ti, tr, phi]) in directions.iter().enumerate() {
                    // One geometry for the value and the coverage.
                    let g = Geometry::from_angles(ti, tr, phi);
                    values.push(corrected.eval(&g));
                    if !table.covers(&g) {
                        outside += 1;
                        first_outside.get_or_insert(chunk.line(i));
                    }
                }
                rows += directions.len();
            } else if let Err(e) = evaluate_chunk(&model, batch.as_ref(), &directions, &mut values) {
                let line = match e {
                    BatchError::Domain { index, .. } => chunk.line(index),
                    _ => chunk.line(0),
                };
                bail!("{}: line {line}: {e}", reader.file());
            }
            if let Some(i) = values.iter().position(|f| !f.is_finite()) {
                bail!(
                    "{}: line {}: {}",
                    reader.file(),
                    chunk.line(i),
                    brdf_fit::params::not_finite(values[i], kind)
                );
            }
            writer.write_chunk(&chunk, values.iter().map(|&v| text(v)))?;
        }
        if let Some(line) = first_outside {
            eprintln_lossy!(
                "warning: {outside} of {rows} directions (the first on line {line} of {}) lie outside \
                 the fitted table's coverage: its measurements did not inform them, and the table \
                 extrapolates there",
                reader.file()
            );
        }
        writer.finish()
    }
}
