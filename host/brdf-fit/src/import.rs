//! Importers for measurement files in other conventions, each mapping explicitly to the
//! canonical one: zeniths `theta_i`, `theta_r` in [0, 90), relative azimuth
//! `phi = phi_r - phi_i` with the mirror direction at `phi = 180°`.
//!
//! | format | source convention | mapping |
//! |---|---|---|
//! | `cornell` (ASTM E1392 text, `*.astm`) | radians; `theta_i,phi_i,theta_s,phi_s,R,G,B`; specular at `phi_s - phi_i = 180°` | `theta_r = theta_s`, `phi = phi_s - phi_i`, BRDF = the chosen channel |
//! | `nist` (Germer's PTFE CSV) | degrees; `thetai` signed (negative: source on the far side of azimuth `phi`), `phir` outgoing azimuth; specular at `phir = 0` | `theta_i = abs(thetai)`, `phi_i = phi + 180° if thetai < 0`, `phi = phir - phi_i`; `lambda` (µm) becomes the `wavelength` group |
//! | `merl-inplane` (lumos-sat export of MERL) | degrees; columns named `phi_in theta_in phi_out theta_out brdf` with **phi = zenith, theta = azimuth**; `phi_out` signed, positive on the specular side | `theta_i = phi_in`, `phi_i = theta_in`, `theta_r = abs(phi_out)`, `phi_r = theta_out + 180° if phi_out < 0`, `phi = phi_r - phi_i` |
//!
//! Every data row either becomes a point or is reported as a reject with its line and reason
//! (negative or zero BRDF, zenith at or beyond 90°, non-finite value): nothing is dropped
//! silently. Rows that cannot be parsed at all make the file an error.

use std::path::Path;

use brdf_core::names::Named;

use crate::data::{DataError, Dataset, Point, Skipped};

/// Supported source formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Cornell PCG ASTM E1392 text files.
    Cornell,
    /// NIST (Germer 2017) Mueller-matrix BRDF CSV; `f_r11` is used.
    Nist,
    /// MERL in-plane slice in the lumos-sat layout.
    MerlInPlane,
}

impl Named for Format {
    const WHAT: &'static str = "format";
    const ALL: &'static [Format] = &[Format::Cornell, Format::Nist, Format::MerlInPlane];
    /// Name on the command line and in Python.
    fn name(self) -> &'static str {
        match self {
            Format::Cornell => "cornell",
            Format::Nist => "nist",
            Format::MerlInPlane => "merl-inplane",
        }
    }
    /// The name, or with `_` for `-` (`merl_inplane`).
    fn matches(self, given: &str) -> bool {
        given == self.name() || given.replace('_', "-") == self.name()
    }
}

brdf_core::named_str!(Format);

/// Colour channel of the Cornell RGB files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    /// Red.
    R,
    /// Green.
    G,
    /// Blue.
    B,
}

impl Channel {
    fn column(self) -> &'static str {
        match self {
            Channel::R => "R",
            Channel::G => "G",
            Channel::B => "B",
        }
    }
}

impl Named for Channel {
    const WHAT: &'static str = "channel";
    const ALL: &'static [Channel] = &[Channel::R, Channel::G, Channel::B];
    /// Name on the command line and in Python.
    fn name(self) -> &'static str {
        match self {
            Channel::R => "r",
            Channel::G => "g",
            Channel::B => "b",
        }
    }
    /// The name in either case (`R` is the file's column name).
    fn matches(self, given: &str) -> bool {
        given.eq_ignore_ascii_case(self.name())
    }
}

brdf_core::named_str!(Channel);

/// The channel to read: `channel` if given, which only the Cornell format has (red when
/// not given); an error when given for another format or for the canonical CSV (`format`
/// `None`), where it would be ignored.
pub fn channel_for(format: Option<Format>, channel: Option<Channel>) -> Result<Channel, String> {
    match (format, channel) {
        (_, None) => Ok(Channel::R),
        (Some(Format::Cornell), Some(c)) => Ok(c),
        (_, Some(c)) => Err(format!(
            "channel {c} applies to the cornell format only; it would be ignored"
        )),
    }
}

/// What an import produced.
#[derive(Clone, Debug, PartialEq)]
pub struct Imported {
    /// Datasets in canonical convention (one per wavelength for `nist`).
    pub datasets: Vec<Dataset>,
    /// Data rows read from the file.
    pub rows_in: usize,
    /// Rows not used, with line and reason. `rows_in = points + rejects.len()`.
    pub rejects: Vec<Skipped>,
}

impl Imported {
    /// Points in all datasets.
    pub fn points(&self) -> usize {
        self.datasets.iter().map(|d| d.points.len()).sum()
    }
}

/// One source row in canonical terms, before validation (degrees).
struct Row {
    line: u64,
    theta_i: f64,
    theta_r: f64,
    phi: f64,
    brdf: f64,
    group: Option<String>,
}

fn parse_error(file: &str, line: u64, column: &'static str, text: &str) -> DataError {
    DataError::NotANumber {
        file: file.to_owned(),
        line,
        column,
        text: text.to_owned(),
    }
}

/// Wraps degrees into [0, 360).
fn wrap_degrees(phi: f64) -> f64 {
    let w = phi.rem_euclid(360.0);
    if w >= 360.0 {
        0.0
    } else {
        w
    }
}

/// Signed zenith and its azimuth to (zenith >= 0, azimuth).
fn unsign(zenith: f64, azimuth: f64) -> (f64, f64) {
    if zenith < 0.0 {
        (-zenith, azimuth + 180.0)
    } else {
        (zenith, azimuth)
    }
}

fn read_text(path: &Path) -> Result<String, DataError> {
    std::fs::read_to_string(path).map_err(|source| DataError::Io {
        file: path.display().to_string(),
        source,
    })
}

/// Imports `path` in `format`; `channel` selects the Cornell colour channel.
pub fn import(path: &Path, format: Format, channel: Channel) -> Result<Imported, DataError> {
    let file = path.display().to_string();
    let text = read_text(path)?;
    let rows = match format {
        Format::Cornell => cornell_rows(&file, &text, channel)?,
        Format::Nist => nist_rows(&file, &text)?,
        Format::MerlInPlane => merl_rows(&file, &text)?,
    };
    let rows_in = rows.len();
    if rows_in == 0 {
        return Err(DataError::Empty { file });
    }
    let mut datasets: Vec<Dataset> = Vec::new();
    let mut rejects = Vec::new();
    for r in rows {
        let reason =
            if !(r.theta_i.is_finite() && r.theta_r.is_finite() && r.phi.is_finite() && r.brdf.is_finite()) {
                Some("a value is not finite".to_owned())
            } else if !(0.0..90.0).contains(&r.theta_i) {
                Some(format!(
                    "theta_i {} deg is outside [0, 90)",
                    brdf_core::Compact(r.theta_i)
                ))
            } else if !(0.0..90.0).contains(&r.theta_r) {
                Some(format!(
                    "theta_r {} deg is outside [0, 90)",
                    brdf_core::Compact(r.theta_r)
                ))
            } else if r.brdf <= 0.0 {
                Some(format!("brdf {} is not positive", r.brdf))
            } else if !crate::data::BRDF_MAGNITUDE.contains(&r.brdf) {
                Some(format!(
                    "brdf {} is outside [1e-100, 1e100] 1/sr (is the unit right?)",
                    r.brdf
                ))
            } else {
                None
            };
        if let Some(reason) = reason {
            rejects.push(Skipped { line: r.line, reason });
            continue;
        }
        let name = match &r.group {
            Some(g) => format!("{file}[{g}]"),
            None => file.clone(),
        };
        let point = Point {
            theta_i: r.theta_i.to_radians(),
            theta_r: r.theta_r.to_radians(),
            phi: wrap_degrees(r.phi).to_radians(),
            brdf: r.brdf,
            sigma: None,
            weight: None,
            line: r.line,
        };
        match datasets.iter_mut().find(|d| d.name == name) {
            Some(d) => d.points.push(point),
            None => datasets.push(Dataset {
                name,
                points: vec![point],
            }),
        }
    }
    Ok(Imported {
        datasets,
        rows_in,
        rejects,
    })
}

/// Cornell ASTM E1392: `KEY value` header lines, `VARS` naming the columns, then rows.
fn cornell_rows(file: &str, text: &str, channel: Channel) -> Result<Vec<Row>, DataError> {
    let mut vars: Option<Vec<String>> = None;
    let mut declared: Option<usize> = None;
    let mut rows = Vec::new();
    for (k, raw) in text.split('\n').enumerate() {
        let line_no = k as u64 + 1;
        let line = raw.trim_end_matches('\r').trim();
        if line.is_empty() {
            continue;
        }
        let Some(cols) = &vars else {
            if let Some(rest) = line.strip_prefix("VARS") {
                vars = Some(rest.trim().split(',').map(|s| s.trim().to_owned()).collect());
            } else if let Some(rest) = line.strip_prefix("NUM_POINTS") {
                declared = rest.trim().parse().ok();
            }
            continue;
        };
        let idx = |name: &'static str| {
            cols.iter()
                .position(|c| c == name)
                .ok_or(DataError::MissingColumn {
                    file: file.to_owned(),
                    column: name,
                })
        };
        let (ti, pi, ts, ps, ch) = (
            idx("theta_i")?,
            idx("phi_i")?,
            idx("theta_s")?,
            idx("phi_s")?,
            idx(channel.column())?,
        );
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != cols.len() {
            return Err(DataError::Csv {
                file: file.to_owned(),
                line: line_no,
                message: format!("found {} fields, expected {}", fields.len(), cols.len()),
            });
        }
        let num = |i: usize, column: &'static str| -> Result<f64, DataError> {
            fields[i]
                .parse::<f64>()
                .map_err(|_| parse_error(file, line_no, column, fields[i]))
        };
        let (theta_i, phi_i) = unsign(num(ti, "theta_i")?.to_degrees(), num(pi, "phi_i")?.to_degrees());
        let (theta_r, phi_r) = unsign(num(ts, "theta_s")?.to_degrees(), num(ps, "phi_s")?.to_degrees());
        rows.push(Row {
            line: line_no,
            theta_i,
            theta_r,
            phi: phi_r - phi_i,
            brdf: num(ch, channel.column())?,
            group: None,
        });
    }
    if vars.is_none() {
        return Err(DataError::MissingColumn {
            file: file.to_owned(),
            column: "VARS",
        });
    }
    if let Some(n) = declared {
        if n != rows.len() {
            return Err(DataError::Csv {
                file: file.to_owned(),
                line: 0,
                message: format!("NUM_POINTS says {n} rows, the file holds {}", rows.len()),
            });
        }
    }
    Ok(rows)
}

/// Germer's NIST CSV: header `lambda,thetai,phi,thetar,phir,f_r11,...`; plain numeric
/// fields, read line by line so that every reported line number is the file's own.
fn nist_rows(file: &str, text: &str) -> Result<Vec<Row>, DataError> {
    let mut header: Option<Vec<String>> = None;
    let mut cols = [0usize; 6];
    let mut rows = Vec::new();
    for (k, raw) in text.split('\n').enumerate() {
        let line = k as u64 + 1;
        let t = raw.trim_end_matches('\r').trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = t.split(',').map(str::trim).collect();
        let Some(h) = &header else {
            let h: Vec<String> = fields.iter().map(|f| (*f).to_owned()).collect();
            for (slot, name) in cols
                .iter_mut()
                .zip(["lambda", "thetai", "phi", "thetar", "phir", "f_r11"])
            {
                *slot = h.iter().position(|c| c == name).ok_or(DataError::MissingColumn {
                    file: file.to_owned(),
                    column: name,
                })?;
            }
            header = Some(h);
            continue;
        };
        if fields.len() != h.len() {
            return Err(DataError::Csv {
                file: file.to_owned(),
                line,
                message: format!("found {} fields, expected {}", fields.len(), h.len()),
            });
        }
        let num = |i: usize, column: &'static str| -> Result<f64, DataError> {
            fields[i]
                .parse::<f64>()
                .map_err(|_| parse_error(file, line, column, fields[i]))
        };
        let (theta_i, phi_i) = unsign(num(cols[1], "thetai")?, num(cols[2], "phi")?);
        let (theta_r, phi_r) = unsign(num(cols[3], "thetar")?, num(cols[4], "phir")?);
        rows.push(Row {
            line,
            theta_i,
            theta_r,
            phi: phi_r - phi_i,
            brdf: num(cols[5], "f_r11")?,
            group: Some(format!("wavelength={}", fields[cols[0]])),
        });
    }
    if header.is_none() {
        return Err(DataError::Empty {
            file: file.to_owned(),
        });
    }
    Ok(rows)
}

/// lumos-sat MERL slice: `#` comments, then five whitespace-separated columns
/// `phi_in theta_in phi_out theta_out brdf` (phi = zenith, theta = azimuth).
fn merl_rows(file: &str, text: &str) -> Result<Vec<Row>, DataError> {
    let mut rows = Vec::new();
    for (k, raw) in text.split('\n').enumerate() {
        let line = k as u64 + 1;
        let t = raw.trim_end_matches('\r').trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = t.split_whitespace().collect();
        if f.len() != 5 {
            return Err(DataError::Csv {
                file: file.to_owned(),
                line,
                message: format!("found {} fields, expected 5", f.len()),
            });
        }
        const NAMES: [&str; 5] = ["phi_in", "theta_in", "phi_out", "theta_out", "brdf"];
        let mut v = [0.0; 5];
        for (j, name) in NAMES.iter().enumerate() {
            v[j] = f[j].parse().map_err(|_| parse_error(file, line, name, f[j]))?;
        }
        let (theta_i, phi_i) = unsign(v[0], v[1]);
        let (theta_r, phi_r) = unsign(v[2], v[3]);
        rows.push(Row {
            line,
            theta_i,
            theta_r,
            phi: phi_r - phi_i,
            brdf: v[4],
            group: None,
        });
    }
    Ok(rows)
}

/// Writes datasets as canonical CSV: `theta_i,theta_r,phi,brdf` in degrees (phi in
/// [0, 360)), plus a `wavelength` or `group` column when there are several datasets.
pub fn write_canonical<W: std::io::Write>(out: W, datasets: &[Dataset]) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    let grouped = datasets.len() > 1;
    let group_col = datasets
        .first()
        .and_then(|d| d.name.rsplit_once('[').map(|(_, g)| g.trim_end_matches(']')))
        .and_then(|g| g.split_once('=').map(|(k, _)| k.to_owned()))
        .unwrap_or_else(|| "group".to_owned());
    let mut header = vec!["theta_i", "theta_r", "phi", "brdf"];
    if grouped {
        header.push(&group_col);
    }
    w.write_record(&header)?;
    for d in datasets {
        let group = d
            .name
            .rsplit_once('[')
            .map(|(_, g)| g.trim_end_matches(']'))
            .and_then(|g| g.split_once('=').map(|(_, v)| v.to_owned()))
            .unwrap_or_default();
        for p in &d.points {
            let mut row = vec![
                fmt_deg(p.theta_i),
                fmt_deg(p.theta_r),
                fmt_deg(p.phi),
                format!("{:e}", p.brdf),
            ];
            if grouped {
                row.push(group.clone());
            }
            w.write_record(&row)?;
        }
    }
    w.flush()?;
    Ok(())
}

/// Degrees with 9 decimals, trailing zeros removed.
fn fmt_deg(rad: f64) -> String {
    let s = format!("{:.9}", rad.to_degrees());
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::tolerance::PRINTED_ANGLE_DEG;
    use std::io::Write;

    fn tmp(text: &str) -> tempfile::NamedTempFile {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(text.as_bytes()).unwrap();
        f
    }

    #[test]
    fn cornell_maps_and_reports_negative_rows() {
        let f = tmp("SAMPLE_NAME X\r\nNUM_POINTS 3\r\nVARS theta_i,phi_i,theta_s,phi_s,R,G,B\r\n\r\n0.5,0,0.5,3.14159265,0.2,0.1,0.1\r\n0.5,0,0.4,0,-0.01,0.1,0.1\r\n0.5,0,0.3,-1.0,0.05,0.1,0.1\r\n");
        let imp = import(f.path(), Format::Cornell, Channel::R).unwrap();
        assert_eq!(imp.rows_in, 3);
        assert_eq!(imp.points() + imp.rejects.len(), 3);
        assert_eq!(imp.rejects[0].line, 6);
        assert!(imp.rejects[0].reason.contains("not positive"));
        let p = imp.datasets[0].points[0];
        assert!((p.phi.to_degrees() - 180.0).abs() < PRINTED_ANGLE_DEG);
        // phi_s = -1 rad wraps into [0, 360).
        assert!(
            (imp.datasets[0].points[1].phi.to_degrees() - (360.0 - 1f64.to_degrees())).abs()
                < PRINTED_ANGLE_DEG
        );
    }

    #[test]
    fn nist_signed_incidence_puts_specular_at_180() {
        let f = tmp("lambda,thetai,phi,thetar,phir,f_r11\n0.532,-30,0,30,0,0.5\n0.532,-30,0,30,180,0.3\n0.633,-0.001,0,10,45,0.3\n");
        let imp = import(f.path(), Format::Nist, Channel::R).unwrap();
        assert_eq!(imp.datasets.len(), 2);
        assert!(imp.datasets[0].name.ends_with("[wavelength=0.532]"));
        let d = &imp.datasets[0].points;
        assert!(
            (d[0].phi.to_degrees() - 180.0).abs() < 1e-9,
            "specular phir = 0 -> phi 180"
        );
        assert!(d[1].phi.to_degrees().abs() < 1e-9, "phir = 180 -> retro side");
    }

    #[test]
    fn nist_reject_lines_are_the_files_own_after_comments_and_blanks() {
        let f = tmp("lambda,thetai,phi,thetar,phir,f_r11\n# c\n0.532,-30,0,30,0,-0.5\n0.532,-30,0,30,0,-0.5\n\n\n0.532,-30,0,30,180,-0.3\n0.532,-30,0,30,180,0.3\n");
        let imp = import(f.path(), Format::Nist, Channel::R).unwrap();
        let lines: Vec<u64> = imp.rejects.iter().map(|r| r.line).collect();
        assert_eq!(lines, [3, 4, 7]);
        assert_eq!(imp.datasets[0].points[0].line, 8);
    }

    #[test]
    fn merl_swapped_names_and_signed_zenith() {
        let f = tmp("# comment\n# phi_in theta_in phi_out theta_out brdf\n30     180     30     0     50.0\n30     180     -30     0     0.01\n30     180     95     0     0.01\n");
        let imp = import(f.path(), Format::MerlInPlane, Channel::R).unwrap();
        assert_eq!(imp.rows_in, 3);
        assert_eq!(imp.rejects.len(), 1);
        assert!(imp.rejects[0].reason.contains("theta_r 95"));
        let d = &imp.datasets[0].points;
        assert!((d[0].phi.to_degrees() - 180.0).abs() < 1e-9);
        assert!(d[1].phi.to_degrees().abs() < 1e-9);
        assert!((d[0].theta_i.to_degrees() - 30.0).abs() < PRINTED_ANGLE_DEG);
    }

    #[test]
    fn bad_numbers_are_errors_with_line_and_column() {
        let f = tmp("30 180 x 0 1\n");
        let e = import(f.path(), Format::MerlInPlane, Channel::R)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1: column phi_out: `x`"), "{e}");
    }
}
