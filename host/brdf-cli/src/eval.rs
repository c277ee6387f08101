//! `brdf eval`: a model over a CSV of angles.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use brdf_core::batch::{Batch, BatchError};
use brdf_core::{AnyModel, Brdf, Float, ModelKind, MAX_PARAMS};
use clap::{Args, ValueEnum};

use crate::batch::Inputs;
use crate::params::{build, parse_kind, parse_params};

/// Evaluate a model at every row of a CSV with columns `theta_i,theta_r,phi` (degrees,
/// canonical convention: phi = 180 is the mirror direction). Writes the input columns plus
/// the BRDF in 1/sr to standard output.
#[derive(Debug, Args)]
pub struct EvalCmd {
    /// Model: six, six-cos2, five, minnaert, lambert.
    #[arg(long, value_parser = parse_kind)]
    model: ModelKind,
    /// Parameters as name=value pairs, e.g. kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676,c=1.2
    #[arg(long, allow_hyphen_values = true)]
    params: String,
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

/// Arithmetic precision of the evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Precision {
    /// Double precision (reference; 17 significant digits printed).
    F64,
    /// Single precision, the device path (9 significant digits printed).
    F32,
}

/// Rows evaluated per call of the model (a few hundred KiB of input and output).
const EVAL_CHUNK: usize = 65_536;

/// Parsed rows waiting for evaluation: the records, their lines and the angles (radians).
struct Chunk<T> {
    rows: Vec<csv::StringRecord>,
    lines: Vec<u64>,
    angles: [Vec<T>; 3],
    values: Vec<T>,
}

impl<T> Default for Chunk<T> {
    fn default() -> Self {
        Chunk {
            rows: Vec::new(),
            lines: Vec::new(),
            angles: [Vec::new(), Vec::new(), Vec::new()],
            values: Vec::new(),
        }
    }
}

impl<T> Chunk<T> {
    fn push(&mut self, row: csv::StringRecord, line: u64, angles: [T; 3]) {
        self.rows.push(row);
        self.lines.push(line);
        for (col, a) in self.angles.iter_mut().zip(angles) {
            col.push(a);
        }
    }
}

impl EvalCmd {
    pub fn run(self) -> Result<()> {
        let params = parse_params(self.model, &self.params)?;
        let stdout = std::io::stdout();
        let out = std::io::BufWriter::new(stdout.lock());
        match self.precision {
            Precision::F64 => self.eval::<f64>(&params, true, out, |v| format!("{v:.16e}")),
            Precision::F32 => self.eval::<f32>(&params, false, out, |v| format!("{v:.8e}")),
        }
    }

    fn eval<T: Float + Send + Sync>(
        &self,
        params: &[f64; MAX_PARAMS],
        use_batch: bool,
        out: impl Write,
        fmt: impl Fn(T) -> String,
    ) -> Result<()> {
        let model: AnyModel<T> = build(self.model, params)?;
        let file = self.angles.display();
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .from_path(&self.angles)
            .with_context(|| format!("cannot open {file}"))?;
        let headers = reader
            .headers()
            .with_context(|| format!("{file}: cannot read the header row"))?
            .clone();
        if headers.iter().all(|h| h.trim().is_empty()) {
            bail!("{file}: empty file (no header row)");
        }
        let column = |name: &str| -> Result<usize> {
            let mut found = headers.iter().enumerate().filter(|(_, h)| h.trim() == name);
            match (found.next(), found.next()) {
                (Some((i, _)), None) => Ok(i),
                (None, _) => bail!("{file}: line 1: missing column `{name}` in header"),
                (Some(_), Some(_)) => bail!("{file}: line 1: column `{name}` appears twice in header"),
            }
        };
        let cols = [column("theta_i")?, column("theta_r")?, column("phi")?];
        if headers.iter().any(|h| h.trim() == self.output_column) {
            bail!(
                "{file}: line 1: input already has a column `{}`; choose another with --output-column",
                self.output_column
            );
        }
        // Rows are written to memory first, so a bad row leaves no partial CSV behind.
        let mut writer = csv::Writer::from_writer(Vec::new());
        let mut header_out = headers.clone();
        header_out.push_field(&self.output_column);
        writer.write_record(&header_out)?;
        // Rows are evaluated in chunks: the f64 reference through the core's batch path (within
        // 1e-12 of the scalar path, on all cores), f32 through the scalar path, which is the
        // firmware's arithmetic bit for bit.
        let batch = use_batch.then(|| Batch::new(&model));
        let mut chunk = Chunk::<T>::default();
        let mut record = csv::StringRecord::new();
        loop {
            match reader.read_record(&mut record) {
                Ok(false) => break,
                Ok(true) => {}
                Err(e) => return Err(anyhow::Error::new(e).context(format!("{file}: malformed CSV"))),
            }
            let line = record.position().map_or(0, |p| p.line());
            let mut deg = [0.0_f64; 3];
            for (k, (&c, name)) in cols.iter().zip(["theta_i", "theta_r", "phi"]).enumerate() {
                let text = record[c].trim();
                let v: f64 = text.parse().map_err(|_| {
                    anyhow::anyhow!("{file}: line {line}: column {name}: `{text}` is not a number")
                })?;
                if !v.is_finite() {
                    bail!("{file}: line {line}: column {name}: `{text}` is not finite");
                }
                if k < 2 && !(0.0..=90.0).contains(&v) {
                    bail!("{file}: line {line}: column {name}: zenith {v} deg is outside [0, 90]");
                }
                deg[k] = v;
            }
            chunk.push(record.clone(), line, deg.map(|d| T::from_f64(d.to_radians())));
            if chunk.rows.len() == EVAL_CHUNK {
                self.flush(&model, batch.as_ref(), &mut chunk, &mut writer, &fmt)?;
            }
        }
        self.flush(&model, batch.as_ref(), &mut chunk, &mut writer, &fmt)?;
        let bytes = writer.into_inner().map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut out = out;
        out.write_all(&bytes).context("cannot write to standard output")?;
        out.flush().context("cannot write to standard output")?;
        Ok(())
    }

    /// Evaluates the waiting rows, checks each value and writes the rows with it.
    fn flush<T: Float + Send + Sync>(
        &self,
        model: &AnyModel<T>,
        batch: Option<&Batch<T>>,
        chunk: &mut Chunk<T>,
        writer: &mut csv::Writer<Vec<u8>>,
        fmt: impl Fn(T) -> String,
    ) -> Result<()> {
        let file = self.angles.display();
        let n = chunk.rows.len();
        chunk.values.clear();
        chunk.values.resize(n, T::ZERO);
        let [ti, tr, phi] = &chunk.angles;
        match batch {
            Some(b) => {
                let inputs = Inputs::Angles([&ti[..], &tr[..], &phi[..]]);
                if let Err(e) = crate::batch::eval(b, inputs, &mut chunk.values, true) {
                    let line = match e {
                        BatchError::Domain { index, .. } => chunk.lines[index],
                        _ => 0,
                    };
                    bail!("{file}: line {line}: {e}");
                }
            }
            None => {
                for (k, v) in chunk.values.iter_mut().enumerate() {
                    *v = model.eval_angles(ti[k], tr[k], phi[k]);
                }
            }
        }
        for ((row, &line), &f) in chunk.rows.iter_mut().zip(&chunk.lines).zip(&chunk.values) {
            if !f.is_finite() {
                bail!(
                    "{file}: line {line}: the model is not finite here ({f}); {} diverges at this \
                     geometry (five-parameter and Minnaert models grow without bound at grazing)",
                    self.model.name()
                );
            }
            row.push_field(&fmt(f));
            writer.write_record(&*row)?;
        }
        chunk.rows.clear();
        chunk.lines.clear();
        for col in &mut chunk.angles {
            col.clear();
        }
        Ok(())
    }
}
