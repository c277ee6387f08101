//! Importers for measurement files in other conventions, each mapping explicitly to the
//! canonical one: zeniths `theta_i`, `theta_r` in [0, 90), relative azimuth
//! `phi = phi_r - phi_i` with the mirror direction at `phi = 180°`.
//!
//! | format | source convention | mapping |
//! |---|---|---|
//! | `cornell` (ASTM E1392 text, `*.astm`) | radians; `VARS theta_i,phi_i,theta_s,phi_s,` then colour channels `R,G,B` or one column per band (`400nm,410nm,…`, `1.064um`); specular at `phi_s - phi_i = 180°` | `theta_r = theta_s`, `phi = phi_s - phi_i`; BRDF = the chosen channel (red unless `--channel`), or every band as its own `wavelength` group in µm (one band with `--band`) |
//! | `nist` (Germer's PTFE CSV) | degrees; `thetai` signed (negative: source on the far side of azimuth `phi`), `phir` outgoing azimuth; specular at `phir = 0` | `theta_i = abs(thetai)`, `phi_i = phi + 180° if thetai < 0`, `phi = phir - phi_i`; `lambda` (µm) becomes the `wavelength` group |
//! | `merl-inplane` (lumos-sat export of MERL) | degrees; columns named `phi_in theta_in phi_out theta_out brdf` with **phi = zenith, theta = azimuth**; `phi_out` signed, positive on the specular side | `theta_i = phi_in`, `phi_i = theta_in`, `theta_r = abs(phi_out)`, `phi_r = theta_out + 180° if phi_out < 0`, `phi = phi_r - phi_i` |
//!
//! Every data row either becomes a point or is reported as a reject with its line and reason
//! (zenith at or beyond 90°, non-finite value, a magnitude no BRDF has): nothing is dropped
//! silently. Readings at or below zero are kept: they are measurements of a dark surface
//! with noise (dark bands near 400 and 700 nm), and dropping them would bias every dark
//! band upward; the fit weighs them with a noise floor (`crate::noise`). A study that needs
//! positive readings only says so with [`Imported::positive_only`]. Rows that cannot be
//! parsed at all make the file an error.

use std::path::Path;

use brdf_core::names::Named;

use crate::data::{wavelength_text as um_text, DataError, Dataset, Point, Skipped};

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

impl Format {
    /// Whether the format writes its angles in degrees (NIST, MERL in-plane), so that zeniths
    /// all below pi/2 look like radians written by mistake; Cornell's are radians by its
    /// convention.
    pub fn angles_in_degrees(self) -> bool {
        match self {
            Format::Cornell => false,
            Format::Nist | Format::MerlInPlane => true,
        }
    }
}

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

/// Which values of a file to import: a colour channel of an RGB file, or one band of a
/// spectral or multi-wavelength one. The default picks red from an RGB file and every band
/// from a spectral one (each its own dataset).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pick {
    /// Colour channel (Cornell RGB files only; red when not given).
    pub channel: Option<Channel>,
    /// One band by its centre wavelength in µm (Cornell spectral and NIST files); every band
    /// when not given.
    pub band_um: Option<f64>,
}

impl From<Channel> for Pick {
    fn from(channel: Channel) -> Pick {
        Pick {
            channel: Some(channel),
            band_um: None,
        }
    }
}

/// Two wavelengths closer than this (µm) are the same band: files print them to a few
/// decimals of a nanometre at most. The rule of host and device, [`brdf_core::bands`].
pub use brdf_core::bands::SAME_BAND_UM;

/// What to import: `channel` and `band_um` as given, checked against `format` (neither
/// applies to the canonical CSV, `format` `None`, nor a channel to anything but `cornell`
/// nor a band to `merl-inplane`: each would be ignored). Whether the file has that channel or
/// band is checked when it is read.
pub fn pick_for(
    format: Option<Format>,
    channel: Option<Channel>,
    band_um: Option<f64>,
) -> Result<Pick, String> {
    if let (Some(c), false) = (channel, format == Some(Format::Cornell)) {
        return Err(format!(
            "channel {c} applies to the cornell format only; it would be ignored"
        ));
    }
    if let Some(b) = band_um {
        if !matches!(format, Some(Format::Cornell | Format::Nist)) {
            return Err(format!(
                "band {b} um applies to the cornell and nist formats only; it would be ignored"
            ));
        }
        if !(b.is_finite() && b > 0.0) {
            return Err(format!("band {b} um is not a wavelength above 0"));
        }
        if channel.is_some() {
            return Err("give a channel (RGB files) or a band (spectral files), not both".to_owned());
        }
    }
    Ok(Pick { channel, band_um })
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
    /// What is doubtful but read as written, one line each: a dataset of a format whose
    /// angles are degrees ([`Format::angles_in_degrees`]) whose zeniths look like radians
    /// ([`Dataset::radians_warning`], the CSV reader's rule). `brdf` prints them as warnings.
    pub warnings: Vec<String>,
}

impl Imported {
    /// Points in all datasets.
    pub fn points(&self) -> usize {
        self.datasets.iter().map(|d| d.points.len()).sum()
    }

    /// Readings at or below zero in all datasets.
    pub fn dark_readings(&self) -> usize {
        self.datasets
            .iter()
            .flat_map(|d| &d.points)
            .filter(|p| p.brdf <= 0.0)
            .count()
    }

    /// The import with every reading at or below zero moved to the rejects (reason given),
    /// for a study or representation that needs positive values (`ln f` tables, the
    /// nearest-neighbour baseline, the golden figures measured before dark readings were
    /// kept). Datasets left empty are dropped with their points listed as rejects.
    pub fn positive_only(mut self) -> Imported {
        for d in &mut self.datasets {
            for p in d.points.iter().filter(|p| p.brdf <= 0.0) {
                self.rejects.push(Skipped {
                    line: p.line,
                    reason: format!("brdf {} is not positive (positive readings only)", p.brdf),
                });
            }
            d.points.retain(|p| p.brdf > 0.0);
        }
        self.datasets.retain(|d| !d.points.is_empty());
        self.rejects.sort_by_key(|r| r.line);
        self
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

/// Wraps degrees into [0, 360) (`-0` to `0`, and a tiny negative that rounds to 360 to 0),
/// so that one azimuth has one value.
pub fn wrap_degrees(phi: f64) -> f64 {
    let w = phi.rem_euclid(360.0) + 0.0;
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
    crate::data::read_input(path).map_err(|source| DataError::Io {
        file: path.display().to_string(),
        source,
    })
}

/// Imports `path` in `format`; `pick` selects a Cornell colour channel or a band (see
/// [`Pick`]; a `Channel` converts into one).
pub fn import(path: &Path, format: Format, pick: impl Into<Pick>) -> Result<Imported, DataError> {
    let pick = pick.into();
    let file = path.display().to_string();
    crate::data::check_file_name(&file)?;
    let text = read_text(path)?;
    let rows = match format {
        Format::Cornell => cornell_rows(&file, &text, pick)?,
        Format::Nist => nist_rows(&file, &text, pick.band_um)?,
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
            } else if r.brdf != 0.0 && !crate::data::BRDF_MAGNITUDE.contains(&r.brdf.abs()) {
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
    let warnings = if format.angles_in_degrees() {
        datasets.iter().filter_map(Dataset::radians_warning).collect()
    } else {
        Vec::new()
    };
    Ok(Imported {
        datasets,
        rows_in,
        rejects,
        warnings,
    })
}

/// The value columns of a Cornell `VARS` line after the four angles.
enum Values {
    /// `R,G,B`: the index of the chosen channel's column.
    Channel(usize),
    /// One column per band: `(column index, wavelength in µm)`, the chosen ones.
    Bands(Vec<(usize, f64)>),
}

/// A wavelength column name: a number and a unit, `400nm`, `1.064um`, `1.064µm` (either
/// micro sign), case-insensitive, a space allowed between; the wavelength in µm.
pub fn wavelength_column(name: &str) -> Option<f64> {
    let lower = name.trim().to_ascii_lowercase();
    // Divided, not multiplied by 1e-3: 410 / 1000 is 0.41, 410 * 1e-3 is 0.41000000000000003.
    let (number, per_um) = [("nm", 1000.0), ("um", 1.0), ("µm", 1.0), ("μm", 1.0)]
        .iter()
        .find_map(|(unit, per_um)| lower.strip_suffix(unit).map(|n| (n.trim_end(), *per_um)))?;
    let v: f64 = number.parse().ok()?;
    (v.is_finite() && v > 0.0).then_some(v / per_um)
}

/// A band's name in a dataset (`wavelength=0.55`) and a CSV's `wavelength` column: µm,
/// shortest round-trip form.
fn band_name(um: f64) -> String {
    format!("wavelength={}", um_text(um))
}

/// Classifies the `VARS` columns after the angles: all colour channels or all bands, each
/// name once; anything else is an error naming the column (nothing is ignored).
fn cornell_values(file: &str, line: u64, cols: &[String], pick: Pick) -> Result<Values, DataError> {
    let err = |message: String| DataError::Csv {
        file: file.to_owned(),
        line,
        message,
    };
    let angles = ["theta_i", "phi_i", "theta_s", "phi_s"];
    let mut channels: Vec<(usize, Channel)> = Vec::new();
    let mut bands: Vec<(usize, f64)> = Vec::new();
    for (i, c) in cols.iter().enumerate() {
        if angles.contains(&c.as_str()) {
            if cols[..i].contains(c) {
                return Err(err(format!("VARS names `{c}` twice")));
            }
        } else if let Some(ch) = Channel::ALL.iter().find(|ch| c == ch.column()) {
            if channels.iter().any(|(_, x)| x == ch) {
                return Err(err(format!("VARS names `{c}` twice")));
            }
            channels.push((i, *ch));
        } else if let Some(um) = wavelength_column(c) {
            if bands.iter().any(|(_, x)| (x - um).abs() < SAME_BAND_UM) {
                return Err(err(format!("VARS names the band `{c}` twice")));
            }
            bands.push((i, um));
        } else {
            return Err(err(format!(
                "VARS column `{c}` is neither an angle, a colour channel (R, G, B) nor a \
                 wavelength (400nm, 1.064um)"
            )));
        }
    }
    let list = |b: &[(usize, f64)]| {
        let mut v: Vec<String> = b.iter().map(|(_, um)| um_text(*um)).collect();
        if v.len() > 8 {
            let last = v.pop().unwrap_or_default();
            v.truncate(3);
            v.push("…".to_owned());
            v.push(last);
        }
        v.join(", ")
    };
    match (channels.is_empty(), bands.is_empty()) {
        (false, false) => Err(err(
            "VARS mixes colour channels and wavelength bands; one file holds one kind".to_owned(),
        )),
        (true, true) => Err(err(
            "VARS has no value column (R,G,B or wavelengths such as 400nm)".to_owned(),
        )),
        (false, true) => {
            if let Some(b) = pick.band_um {
                return Err(err(format!(
                    "band {b} um was asked for, but the file holds colour channels ({}): choose one with channel",
                    channels.iter().map(|(_, c)| c.column()).collect::<Vec<_>>().join(", ")
                )));
            }
            let want = pick.channel.unwrap_or(Channel::R);
            let (i, _) = channels
                .iter()
                .find(|(_, c)| *c == want)
                .copied()
                .ok_or_else(|| {
                    err(format!(
                        "the file has no column `{}` for channel {want}",
                        want.column()
                    ))
                })?;
            Ok(Values::Channel(i))
        }
        (true, false) => {
            if let Some(c) = pick.channel {
                return Err(err(format!(
                    "channel {c} was asked for, but the file is spectral (bands {} um): choose one with band, or none for every band",
                    list(&bands)
                )));
            }
            match pick.band_um {
                None => Ok(Values::Bands(bands)),
                Some(b) => match bands.iter().find(|(_, um)| (um - b).abs() < SAME_BAND_UM) {
                    Some(&found) => Ok(Values::Bands(vec![found])),
                    None => Err(err(format!(
                        "the file has no band at {b} um; its bands are {} um",
                        list(&bands)
                    ))),
                },
            }
        }
    }
}

/// Cornell ASTM E1392: `KEY value` header lines, `VARS` naming the columns, then rows. A
/// spectral file gives one row per band and direction, grouped by band.
fn cornell_rows(file: &str, text: &str, pick: Pick) -> Result<Vec<Row>, DataError> {
    let mut vars: Option<(Vec<String>, [usize; 4], Values)> = None;
    let mut declared: Option<usize> = None;
    let mut directions = 0;
    let mut rows = Vec::new();
    for (k, raw) in text.split('\n').enumerate() {
        let line_no = k as u64 + 1;
        let line = raw.trim_end_matches('\r').trim();
        if line.is_empty() {
            continue;
        }
        let Some((cols, [ti, pi, ts, ps], values)) = &vars else {
            if let Some(rest) = line.strip_prefix("VARS") {
                let cols: Vec<String> = rest.trim().split(',').map(|s| s.trim().to_owned()).collect();
                let idx = |name: &'static str| {
                    cols.iter()
                        .position(|c| c == name)
                        .ok_or(DataError::MissingColumn {
                            file: file.to_owned(),
                            column: name,
                        })
                };
                let angles = [idx("theta_i")?, idx("phi_i")?, idx("theta_s")?, idx("phi_s")?];
                let values = cornell_values(file, line_no, &cols, pick)?;
                vars = Some((cols, angles, values));
            } else if let Some(rest) = line.strip_prefix("NUM_POINTS") {
                declared = Some(rest.trim().parse().map_err(|_| DataError::Csv {
                    file: file.to_owned(),
                    line: line_no,
                    message: format!("NUM_POINTS `{}` is not a count", rest.trim()),
                })?);
            }
            continue;
        };
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != cols.len() {
            return Err(DataError::Csv {
                file: file.to_owned(),
                line: line_no,
                message: format!("found {} fields, expected {}", fields.len(), cols.len()),
            });
        }
        let num = |i: usize| -> Result<f64, DataError> {
            fields[i].parse::<f64>().map_err(|_| DataError::Csv {
                file: file.to_owned(),
                line: line_no,
                message: format!("column {}: `{}` is not a number", cols[i], fields[i]),
            })
        };
        let (theta_i, phi_i) = unsign(num(*ti)?.to_degrees(), num(*pi)?.to_degrees());
        let (theta_r, phi_r) = unsign(num(*ts)?.to_degrees(), num(*ps)?.to_degrees());
        directions += 1;
        let row = |brdf, group| Row {
            line: line_no,
            theta_i,
            theta_r,
            phi: phi_r - phi_i,
            brdf,
            group,
        };
        match values {
            Values::Channel(i) => rows.push(row(num(*i)?, None)),
            Values::Bands(bands) => {
                for &(i, um) in bands {
                    rows.push(row(num(i)?, Some(band_name(um))));
                }
            }
        }
    }
    if vars.is_none() {
        return Err(DataError::MissingColumn {
            file: file.to_owned(),
            column: "VARS",
        });
    }
    if let Some(n) = declared {
        if n != directions {
            return Err(DataError::Csv {
                file: file.to_owned(),
                line: 0,
                message: format!("NUM_POINTS says {n} rows, the file holds {directions}"),
            });
        }
    }
    Ok(rows)
}

/// Germer's NIST CSV: header `lambda,thetai,phi,thetar,phir,f_r11,...`; plain numeric
/// fields, read line by line so that every reported line number is the file's own.
fn nist_rows(file: &str, text: &str, band_um: Option<f64>) -> Result<Vec<Row>, DataError> {
    let mut bands: Vec<f64> = Vec::new();
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
        let lambda = num(cols[0], "lambda")?;
        if !(lambda.is_finite() && lambda > 0.0) {
            return Err(DataError::Csv {
                file: file.to_owned(),
                line,
                message: format!("column lambda: {lambda} is not a wavelength above 0 (um)"),
            });
        }
        if !bands.iter().any(|b| (b - lambda).abs() < SAME_BAND_UM) {
            bands.push(lambda);
        }
        if band_um.is_some_and(|b| (b - lambda).abs() >= SAME_BAND_UM) {
            continue;
        }
        let (theta_i, phi_i) = unsign(num(cols[1], "thetai")?, num(cols[2], "phi")?);
        let (theta_r, phi_r) = unsign(num(cols[3], "thetar")?, num(cols[4], "phir")?);
        rows.push(Row {
            line,
            theta_i,
            theta_r,
            phi: phi_r - phi_i,
            brdf: num(cols[5], "f_r11")?,
            group: Some(band_name(lambda)),
        });
    }
    if header.is_none() {
        return Err(DataError::Empty {
            file: file.to_owned(),
        });
    }
    if let (Some(b), true) = (band_um, rows.is_empty() && !bands.is_empty()) {
        let list: Vec<String> = bands.iter().map(|um| um_text(*um)).collect();
        return Err(DataError::Csv {
            file: file.to_owned(),
            line: 0,
            message: format!(
                "the file has no band at {b} um; its bands are {} um",
                list.join(", ")
            ),
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
/// [0, 360)), plus a `wavelength` (µm) or `group` column when there are several datasets
/// or the one dataset is a band of its file.
pub fn write_canonical<W: std::io::Write>(out: W, datasets: &[Dataset]) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_writer(out);
    // The group column whenever the datasets carry groups (a spectral file's one band keeps
    // its wavelength), and for several datasets in any case.
    let grouped = datasets.len() > 1
        || datasets.iter().any(|d| {
            d.name
                .rsplit_once('[')
                .is_some_and(|(_, g)| g.ends_with(']') && g.contains('='))
        });
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
    fn cornell_maps_and_keeps_dark_readings() {
        let f = tmp("SAMPLE_NAME X\r\nNUM_POINTS 3\r\nVARS theta_i,phi_i,theta_s,phi_s,R,G,B\r\n\r\n0.5,0,0.5,3.14159265,0.2,0.1,0.1\r\n0.5,0,0.4,0,-0.01,0.1,0.1\r\n0.5,0,0.3,-1.0,0.05,0.1,0.1\r\n");
        let imp = import(f.path(), Format::Cornell, Channel::R).unwrap();
        assert_eq!((imp.rows_in, imp.points()), (3, 3));
        assert!(imp.rejects.is_empty());
        assert_eq!(imp.datasets[0].points[1].brdf, -0.01);
        assert_eq!(
            imp.datasets[0].name,
            f.path().display().to_string(),
            "no group for RGB"
        );
        let p = imp.datasets[0].points[0];
        assert!((p.phi.to_degrees() - 180.0).abs() < PRINTED_ANGLE_DEG);
        // phi_s = -1 rad wraps into [0, 360).
        assert!(
            (imp.datasets[0].points[2].phi.to_degrees() - (360.0 - 1f64.to_degrees())).abs()
                < PRINTED_ANGLE_DEG
        );
        // A study that needs positive readings moves the dark one to the rejects, by line.
        let pos = imp.positive_only();
        assert_eq!((pos.points(), pos.rejects.len(), pos.rejects[0].line), (2, 1, 6));
        assert!(
            pos.rejects[0].reason.contains("not positive"),
            "{}",
            pos.rejects[0].reason
        );
    }

    const SPECTRAL: &str = "NUM_POINTS 2\nVARS theta_i,phi_i,theta_s,phi_s,400nm,550nm,1.064um\n0.5,0,0.5,3.14159265,0.000000,0.2,0.3\n0.2,0,0.3,0,0.01,-0.02,0.4\n";

    #[test]
    fn a_spectral_file_gives_every_band_as_a_wavelength_dataset() {
        let f = tmp(SPECTRAL);
        let imp = import(f.path(), Format::Cornell, Pick::default()).unwrap();
        let names: Vec<&str> = imp
            .datasets
            .iter()
            .map(|d| d.name.rsplit_once('[').unwrap().1)
            .collect();
        assert_eq!(
            names,
            ["wavelength=0.4]", "wavelength=0.55]", "wavelength=1.064]"]
        );
        assert_eq!(
            (imp.rows_in, imp.points()),
            (6, 6),
            "every reading kept, zeros too"
        );
        let at = |k: usize| -> Vec<f64> { imp.datasets[k].points.iter().map(|p| p.brdf).collect() };
        assert_eq!(
            (at(0), at(1), at(2)),
            (vec![0.0, 0.01], vec![0.2, -0.02], vec![0.3, 0.4])
        );
        assert_eq!(imp.datasets[2].points[1].line, 4);
        // One band, by wavelength: its dataset keeps the wavelength in the CSV.
        let one = import(
            f.path(),
            Format::Cornell,
            pick_for(Some(Format::Cornell), None, Some(0.55)).unwrap(),
        )
        .unwrap();
        assert_eq!(one.datasets.len(), 1);
        assert!(one.datasets[0].name.ends_with("[wavelength=0.55]"));
        let mut csv = Vec::new();
        write_canonical(&mut csv, &one.datasets).unwrap();
        let csv = String::from_utf8(csv).unwrap();
        assert!(csv.starts_with("theta_i,theta_r,phi,brdf,wavelength\n"), "{csv}");
        assert!(csv.contains(",-2e-2,0.55\n"), "{csv}");
    }

    #[test]
    fn a_band_or_channel_the_file_lacks_is_an_error_listing_what_it_has() {
        let f = tmp(SPECTRAL);
        let band = |b| Pick {
            channel: None,
            band_um: Some(b),
        };
        let e = import(f.path(), Format::Cornell, band(0.6))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2") && e.contains("no band at 0.6 um") && e.contains("0.4, 0.55, 1.064"),
            "{e}"
        );
        let e = import(f.path(), Format::Cornell, Channel::G)
            .unwrap_err()
            .to_string();
        assert!(e.contains("channel g") && e.contains("spectral"), "{e}");
        let rgb = tmp("VARS theta_i,phi_i,theta_s,phi_s,R,G,B\n0.5,0,0.5,0,0.2,0.1,0.1\n");
        let e = import(rgb.path(), Format::Cornell, band(0.55))
            .unwrap_err()
            .to_string();
        assert!(e.contains("colour channels (R, G, B)"), "{e}");
        let only_r = tmp("VARS theta_i,phi_i,theta_s,phi_s,R\n0.5,0,0.5,0,0.2\n");
        let e = import(only_r.path(), Format::Cornell, Channel::B)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no column `B`"), "{e}");
    }

    #[test]
    fn vars_columns_are_each_known_and_named_once() {
        for (vars, says) in [
            ("theta_i,phi_i,theta_s,phi_s,R,G,X", "column `X` is neither"),
            ("theta_i,phi_i,theta_s,phi_s,400nm,0.4um", "band `0.4um` twice"),
            ("theta_i,phi_i,theta_s,phi_s,R,400nm", "mixes"),
            ("theta_i,phi_i,theta_s,phi_s", "no value column"),
            ("theta_i,phi_i,theta_s,phi_s,R,R", "`R` twice"),
            ("theta_i,phi_i,theta_s,phi_s,theta_i,R", "`theta_i` twice"),
            ("theta_i,phi_i,theta_s,phi_s,-400nm", "neither"),
        ] {
            let f = tmp(&format!("VARS {vars}\n"));
            let e = import(f.path(), Format::Cornell, Pick::default())
                .unwrap_err()
                .to_string();
            assert!(e.contains(says) && e.contains("line 1"), "{vars}: {e}");
        }
        let f = tmp("NUM_POINTS x\nVARS theta_i,phi_i,theta_s,phi_s,R\n");
        let e = import(f.path(), Format::Cornell, Pick::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("NUM_POINTS `x`"), "{e}");
    }

    #[test]
    fn wavelength_columns_in_every_unit_spelling() {
        for (name, um) in [
            ("400nm", 0.4),
            ("400 nm", 0.4),
            ("400NM", 0.4),
            ("1.064um", 1.064),
            ("1.064µm", 1.064),
            ("1.064 μm", 1.064),
            ("1550nm", 1.55),
        ] {
            let got = wavelength_column(name).unwrap();
            assert!((got - um).abs() < 1e-12, "{name}: {got}");
        }
        for bad in ["nm", "abc", "400", "-400nm", "0nm", "nannm", "infum", "400 mm"] {
            assert_eq!(wavelength_column(bad), None, "{bad}");
        }
    }

    #[test]
    fn picks_that_would_be_ignored_are_refused() {
        assert!(pick_for(None, Some(Channel::R), None).is_err());
        assert!(pick_for(Some(Format::Nist), Some(Channel::R), None).is_err());
        assert!(pick_for(Some(Format::MerlInPlane), None, Some(0.5)).is_err());
        assert!(pick_for(None, None, Some(0.5)).is_err());
        assert!(pick_for(Some(Format::Cornell), Some(Channel::R), Some(0.5)).is_err());
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(pick_for(Some(Format::Cornell), None, Some(bad)).is_err(), "{bad}");
        }
        assert_eq!(
            pick_for(Some(Format::Nist), None, Some(0.532)).unwrap().band_um,
            Some(0.532)
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
    fn nist_bands_are_picked_by_wavelength() {
        let f = tmp("lambda,thetai,phi,thetar,phir,f_r11\n0.532,-30,0,30,0,0.5\n0.633,-30,0,30,180,0.3\n0.532,-30,0,20,0,-0.1\n");
        let band = |b| Pick {
            channel: None,
            band_um: Some(b),
        };
        let imp = import(f.path(), Format::Nist, band(0.532)).unwrap();
        assert_eq!(imp.datasets.len(), 1);
        assert_eq!(imp.points(), 2, "the dark reading is kept");
        let e = import(f.path(), Format::Nist, band(1.064))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no band at 1.064 um") && e.contains("0.532, 0.633"),
            "{e}"
        );
        let bad = tmp("lambda,thetai,phi,thetar,phir,f_r11\n-1,-30,0,30,0,0.5\n");
        let e = import(bad.path(), Format::Nist, Pick::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2: column lambda"), "{e}");
    }

    #[test]
    fn nist_reject_lines_are_the_files_own_after_comments_and_blanks() {
        let f = tmp("lambda,thetai,phi,thetar,phir,f_r11\n# c\n0.532,-30,0,95,0,0.5\n0.532,-30,0,95,0,0.5\n\n\n0.532,-30,0,95,180,0.3\n0.532,-30,0,30,180,0.3\n");
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

    /// The formats whose angles are degrees get the CSV reader's warning when their zeniths
    /// look like radians (`Dataset::radians_warning`), each dataset once; a Cornell file is in
    /// radians by its convention and gets none. Before, a NIST or MERL file written in radians
    /// was read as degrees without a word.
    #[test]
    fn zeniths_that_look_like_radians_are_warned_of_in_every_degree_format() {
        let nist = tmp("lambda,thetai,phi,thetar,phir,f_r11\n0.532,-0.5236,0,0.5236,0,0.5\n0.532,-0.5236,0,1.0472,180,0.3\n0.633,-0.5236,0,1.0472,180,0.3\n");
        let imp = import(nist.path(), Format::Nist, Pick::default()).unwrap();
        assert_eq!(imp.warnings.len(), 2, "{:?}", imp.warnings);
        for (w, d) in imp.warnings.iter().zip(&imp.datasets) {
            assert!(w.contains(&d.name) && w.contains("look like radians"), "{w}");
        }
        let merl = tmp(
            "# phi_in theta_in phi_out theta_out brdf\n0.5236 180 0.5236 0 50.0\n0.5236 180 -1.0472 0 0.01\n",
        );
        let imp = import(merl.path(), Format::MerlInPlane, Pick::default()).unwrap();
        assert_eq!(imp.warnings.len(), 1, "{:?}", imp.warnings);
        // The same files in degrees, and a Cornell file (radians by convention): no warning.
        let degrees = tmp("# phi_in theta_in phi_out theta_out brdf\n30 180 30 0 50.0\n30 180 -60 0 0.01\n");
        assert!(import(degrees.path(), Format::MerlInPlane, Pick::default())
            .unwrap()
            .warnings
            .is_empty());
        let cornell = tmp("NUM_POINTS 2\nVARS theta_i,phi_i,theta_s,phi_s,R,G,B\n0.5,0,0.5,3.14159265,0.2,0.1,0.1\n0.5,0,1.0,0,0.1,0.1,0.1\n");
        let imp = import(cornell.path(), Format::Cornell, Channel::R).unwrap();
        assert!(imp.warnings.is_empty(), "{:?}", imp.warnings);
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
