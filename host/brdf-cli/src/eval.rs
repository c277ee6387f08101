//! `brdf eval`: a model over a CSV of angles.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use brdf_core::{AnyModel, Brdf, Float, ModelKind, MAX_PARAMS};
use clap::{Args, ValueEnum};

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

impl EvalCmd {
    pub fn run(self) -> Result<()> {
        let params = parse_params(self.model, &self.params)?;
        let stdout = std::io::stdout();
        let out = std::io::BufWriter::new(stdout.lock());
        match self.precision {
            Precision::F64 => self.eval::<f64>(&params, out, |v| format!("{v:.16e}")),
            Precision::F32 => self.eval::<f32>(&params, out, |v| format!("{v:.8e}")),
        }
    }

    fn eval<T: Float>(
        &self,
        params: &[f64; MAX_PARAMS],
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
            let [ti, tr, phi] = deg.map(|d| T::from_f64(d.to_radians()));
            let f = model.eval_angles(ti, tr, phi);
            if !f.is_finite() {
                bail!(
                    "{file}: line {line}: the model is not finite here ({f}); {} diverges at this \
                     geometry (five-parameter and Minnaert models grow without bound at grazing)",
                    self.model.name()
                );
            }
            let mut row = record.clone();
            row.push_field(&fmt(f));
            writer.write_record(&row)?;
        }
        let bytes = writer.into_inner().map_err(|e| anyhow::anyhow!("{e}"))?;
        let mut out = out;
        out.write_all(&bytes).context("cannot write to standard output")?;
        out.flush().context("cannot write to standard output")?;
        Ok(())
    }
}
