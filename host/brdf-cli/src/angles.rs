//! The angle CSV that `brdf eval` and `brdf query` read and the CSV they write: one reader
//! and one writer, so that both accept exactly the same files, report the same errors at
//! the same lines and pass every input column through with its original text. Both stream:
//! rows are read, evaluated and written in chunks of [`CHUNK_ROWS`], so memory does not
//! grow with the file, and a chunk is written only once every row in it has been evaluated.

use std::io::Write;
use std::path::Path;

use anyhow::{bail, Context, Result};
use brdf_core::Float;

/// Rows read, evaluated and written at a time.
pub const CHUNK_ROWS: usize = 4096;

/// The three angle columns, in the order they are evaluated.
pub const ANGLE_COLUMNS: [&str; 3] = ["theta_i", "theta_r", "phi"];

/// Parses the texts of one direction (`theta_i`, `theta_r`, `phi` in degrees) as the CSV
/// rows and `brdf query --angles` are parsed: numbers, finite, zeniths in [0, 90]. Errors
/// start with `at` (e.g. `FILE: line 3`).
pub fn parse_direction(at: &str, texts: [&str; 3]) -> Result<[f64; 3]> {
    let mut deg = [0.0_f64; 3];
    for (k, (text, name)) in texts.into_iter().zip(ANGLE_COLUMNS).enumerate() {
        let text = text.trim();
        let v: f64 = text
            .parse()
            .map_err(|_| anyhow::anyhow!("{at}: column {name}: `{text}` is not a number"))?;
        deg[k] = v;
    }
    brdf_fit::params::check_eval_degrees(deg).map_err(|e| anyhow::anyhow!("{at}: {e}"))?;
    Ok(deg)
}

/// Degrees to radians in f64, rounded once to `T`: the inputs of both `eval` and the device.
pub fn radians<T: Float>(deg: [f64; 3]) -> [T; 3] {
    deg.map(|d| T::from_f64(d.to_radians()))
}

/// A value as `eval --precision f64` prints it: 17 significant digits.
pub fn f64_text(v: f64) -> String {
    format!("{v:.16e}")
}

/// A value as `eval --precision f32` and `query` print it: 9 significant digits.
pub fn f32_text(v: f32) -> String {
    format!("{v:.8e}")
}

/// Rows of one chunk: the records as read, their lines and their validated angles.
#[derive(Debug, Default)]
pub struct Chunk {
    records: Vec<csv::StringRecord>,
    lines: Vec<u64>,
    degrees: Vec<[f64; 3]>,
}

impl Chunk {
    /// Rows in the chunk.
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    /// The angles (degrees) of each row.
    pub fn degrees(&self) -> &[[f64; 3]] {
        &self.degrees
    }

    /// The source line of row `i`.
    pub fn line(&self, i: usize) -> u64 {
        self.lines[i]
    }

    /// The text of column `col` in row `i` (empty when the row is short).
    pub fn field(&self, i: usize, col: usize) -> &str {
        self.records[i].get(col).unwrap_or("")
    }
}

/// Reads an angle CSV: a header naming `theta_i`, `theta_r` and `phi` once each and not
/// already holding the output column, then rows validated by [`parse_direction`].
#[derive(Debug)]
pub struct AngleReader {
    file: String,
    reader: csv::Reader<brdf_fit::data::LineBounded<std::fs::File>>,
    headers: csv::StringRecord,
    cols: [usize; 3],
    record: csv::StringRecord,
}

impl AngleReader {
    /// Opens `path` and checks its header against the output column `output`.
    pub fn open(path: &Path, output: &str) -> Result<AngleReader> {
        let file = path.display().to_string();
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .from_reader(brdf_fit::data::open_stream(path).with_context(|| format!("cannot open {file}"))?);
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
        if headers.iter().any(|h| h.trim() == output) {
            bail!(
                "{file}: line 1: input already has a column `{output}`; choose another with --output-column"
            );
        }
        Ok(AngleReader {
            file,
            reader,
            headers,
            cols,
            record: csv::StringRecord::new(),
        })
    }

    /// The file name as given.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The header row as read.
    pub fn headers(&self) -> &csv::StringRecord {
        &self.headers
    }

    /// The index of column `name` in the header, if it is there once; an error when twice.
    pub fn column(&self, name: &str) -> Result<Option<usize>> {
        let mut found = self.headers.iter().enumerate().filter(|(_, h)| h.trim() == name);
        match (found.next(), found.next()) {
            (Some(_), Some(_)) => bail!("{}: line 1: column `{name}` appears twice in header", self.file),
            (first, _) => Ok(first.map(|(i, _)| i)),
        }
    }

    /// Replaces `chunk` with the next rows (at most [`CHUNK_ROWS`]); returns how many (0 at
    /// the end of the file). Stops at the first invalid row with its file, line and column.
    pub fn next_chunk(&mut self, chunk: &mut Chunk) -> Result<usize> {
        chunk.lines.clear();
        chunk.degrees.clear();
        while chunk.lines.len() < CHUNK_ROWS {
            match self.reader.read_record(&mut self.record) {
                Ok(false) => break,
                Ok(true) => {}
                Err(e) => return Err(anyhow::Error::new(e).context(format!("{}: malformed CSV", self.file))),
            }
            let line = self.record.position().map_or(0, |p| p.line());
            let texts = self.cols.map(|c| self.record.get(c).unwrap_or(""));
            let deg = parse_direction(&format!("{}: line {line}", self.file), texts)?;
            let i = chunk.lines.len();
            if chunk.records.len() == i {
                chunk.records.push(csv::StringRecord::new());
            }
            // Swapped, not copied: the old record's buffers take the next row.
            std::mem::swap(&mut chunk.records[i], &mut self.record);
            chunk.lines.push(line);
            chunk.degrees.push(deg);
        }
        Ok(chunk.len())
    }
}

/// Writes the output CSV: the input header plus the output column, then each input record
/// as read plus its value. Nothing is written before the first chunk has been evaluated, so
/// a file whose first chunk fails leaves no output at all.
#[derive(Debug)]
pub struct AngleWriter<W: Write> {
    w: csv::Writer<W>,
    header: Option<csv::StringRecord>,
}

impl<W: Write> AngleWriter<W> {
    /// A writer whose header row is `reader`'s plus `output`.
    pub fn new(out: W, reader: &AngleReader, output: &str) -> Result<Self> {
        let mut header = reader.headers().clone();
        header.push_field(output);
        Ok(AngleWriter {
            w: csv::Writer::from_writer(out),
            header: Some(header),
        })
    }

    fn write_header(&mut self) -> Result<()> {
        if let Some(h) = self.header.take() {
            self.w.write_record(&h)?;
        }
        Ok(())
    }

    /// Writes every row of `chunk` with its value text, then flushes: what has been written
    /// reaches the reader of the output before the next chunk is read.
    pub fn write_chunk(&mut self, chunk: &Chunk, values: impl IntoIterator<Item = String>) -> Result<()> {
        self.write_header()?;
        for (record, v) in chunk.records[..chunk.len()].iter().zip(values) {
            self.w
                .write_record(record.iter().chain(std::iter::once(v.as_str())))?;
        }
        self.w.flush().context("cannot write to standard output")?;
        Ok(())
    }

    /// Writes the header if no row came, and flushes.
    pub fn finish(mut self) -> Result<()> {
        self.write_header()?;
        self.w.flush().context("cannot write to standard output")?;
        Ok(())
    }
}
