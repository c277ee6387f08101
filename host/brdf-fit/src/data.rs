//! Measurement files: the canonical CSV (`theta_i,theta_r,phi,brdf`) and the signed in-plane
//! form (`theta_i,theta_s,brdf`), validated row by row.
//!
//! Angles are degrees in files and radians in memory. In the in-plane form `theta_s > 0` is
//! the forward (specular) side, mapped to `phi = 180°, theta_r = theta_s`; `theta_s < 0` the
//! back side, `phi = 0°, theta_r = -theta_s`. Optional columns: `sigma` (1-sigma uncertainty
//! of `brdf`, 1/sr) or `weight` (multiplies the squared residual), and `sample` and/or
//! `wavelength`, which split one file into independent datasets.

use std::collections::HashMap;
use std::path::Path;

use thiserror::Error;

/// One measured BRDF value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Incidence zenith, radians.
    pub theta_i: f64,
    /// Viewing zenith, radians.
    pub theta_r: f64,
    /// Relative azimuth `phi_r - phi_i`, radians (pi = forward/mirror side).
    pub phi: f64,
    /// Measured BRDF, 1/sr.
    pub brdf: f64,
    /// 1-sigma uncertainty of `brdf`, 1/sr, if the file gives one.
    pub sigma: Option<f64>,
    /// Weight of the squared residual, if the file gives one.
    pub weight: Option<f64>,
    /// 1-based line in the source file.
    pub line: u64,
}

/// The points of one dataset (a file, or one `sample`/`wavelength` group of it).
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// `FILE` or `FILE[sample=..,wavelength=..]`.
    pub name: String,
    /// Points in file order.
    pub points: Vec<Point>,
}

/// Most incidence groups a fit's report has (per-incidence metrics, albedo): one per distinct
/// incidence up to this many (a goniometer's 1-degree steps from 0 to 89 fit), 1-degree bins
/// beyond (a scan with continuous incidences had one group per point, and 200,000 groups
/// took 327 s of report).
pub const MAX_INCIDENCE_GROUPS: usize = 90;

/// Zeniths all at most this many degrees look like radians ([`Dataset::radians_warning`]): a
/// zenith in radians is at most pi/2, which files write rounded up as 1.5708 or 1.571 (a
/// hemisphere in radians reaching the horizon, written 1.5708, escaped the warning).
pub const RADIANS_ZENITH_MAX_DEG: f64 = 1.571;

/// ... unless none is above this many degrees: a measurement at or near normal incidence only
/// (a sensor's boresight, within a degree) is read as written. A hemisphere in radians
/// reaches well past 1 (57 degrees).
pub const RADIANS_SPAN_MIN_DEG: f64 = 1.0;

impl Dataset {
    /// The points grouped by incidence, ascending: `(theta_i, point indices)`. Each distinct
    /// incidence (within 1e-9 rad) is a group, `theta_i` its value; when there are more than
    /// [`MAX_INCIDENCE_GROUPS`], the groups are 1-degree bins of `theta_i` and `theta_i` is the
    /// mean over the bin. Every point is in exactly one group. O(n log n).
    pub fn incidence_groups(&self) -> Vec<(f64, Vec<usize>)> {
        let mut order: Vec<usize> = (0..self.points.len()).collect();
        order.sort_by(|&a, &b| self.points[a].theta_i.total_cmp(&self.points[b].theta_i));
        let ti = |k: usize| self.points[k].theta_i;
        let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
        for &k in &order {
            match groups.last_mut() {
                Some((t, members)) if (ti(k) - *t).abs() < 1e-9 => members.push(k),
                _ => groups.push((ti(k), vec![k])),
            }
        }
        if groups.len() <= MAX_INCIDENCE_GROUPS {
            return groups;
        }
        let mut bins: Vec<(f64, Vec<usize>)> = Vec::new();
        let bin = |k: usize| ti(k).to_degrees().floor();
        for &k in &order {
            match bins.last_mut() {
                Some((_, members)) if bin(members[0]) == bin(k) => members.push(k),
                _ => bins.push((0.0, vec![k])),
            }
        }
        for (t, members) in &mut bins {
            *t = members.iter().map(|&k| ti(k)).sum::<f64>() / members.len() as f64;
        }
        bins
    }

    /// Why the zeniths look like radians written in a degree column, or `None`. The rule:
    /// every `theta_i` and `theta_r` (as written, in degrees) is at most
    /// [`RADIANS_ZENITH_MAX_DEG`] (pi/2 rounded up: a radian zenith is at most that) and at least one is
    /// above [`RADIANS_SPAN_MIN_DEG`] (so a set at or near normal incidence only, all within
    /// one degree, is not taken for radians). A hemisphere in radians fitted as degrees raised
    /// no warning and came out 35% off.
    pub fn radians_warning(&self) -> Option<String> {
        let (mut largest, mut all_below) = (0.0_f64, !self.points.is_empty());
        for p in &self.points {
            for z in [p.theta_i.to_degrees(), p.theta_r.to_degrees()] {
                largest = largest.max(z);
                all_below &= z <= RADIANS_ZENITH_MAX_DEG;
            }
        }
        (all_below && largest > RADIANS_SPAN_MIN_DEG).then(|| {
            format!(
                "{}: every theta_i and theta_r is below {:.4} (pi/2), the largest {}: the angle \
                 columns are degrees, and these look like radians (convert them with degrees = \
                 radians * 180 / pi)",
                self.name,
                RADIANS_ZENITH_MAX_DEG,
                brdf_core::Compact(largest)
            )
        })
    }

    /// Distinct incidence angles (radians), ascending.
    pub fn incidences(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.points.iter().map(|p| p.theta_i).collect();
        v.sort_by(f64::total_cmp);
        v.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
        v
    }
}

/// A line left out under `--skip-invalid`, with the reason.
#[derive(Clone, Debug, PartialEq)]
pub struct Skipped {
    /// 1-based line number.
    pub line: u64,
    /// What was wrong with it.
    pub reason: String,
}

/// Everything read from one file.
#[derive(Clone, Debug, PartialEq)]
pub struct Loaded {
    /// One dataset per group (one in all when the file has no `sample`/`wavelength` column).
    pub datasets: Vec<Dataset>,
    /// Lines skipped under `skip_invalid` (always empty otherwise).
    pub skipped: Vec<Skipped>,
    /// What is doubtful but read as written, one line each (a dataset whose zeniths look
    /// like radians: [`Dataset::radians_warning`]); `brdf` prints them as warnings.
    pub warnings: Vec<String>,
}

/// How to read a file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Skip invalid rows (each reported in [`Loaded::skipped`]) instead of failing.
    pub skip_invalid: bool,
    /// Accept readings at or below zero (a dark surface's noisy readings; fits weigh them
    /// with a noise floor, [`crate::noise`]); otherwise `brdf` must be above 0.
    pub dark_readings: bool,
}

/// Why a file cannot be used. Every variant names the file; row errors name line and column.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum DataError {
    /// The file cannot be opened or read.
    #[error("{file}: {source}")]
    Io {
        /// File path.
        file: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// Malformed CSV (e.g. a row with the wrong number of fields).
    #[error("{file}: line {line}: {message}")]
    Csv {
        /// File path.
        file: String,
        /// 1-based line.
        line: u64,
        /// Parser message.
        message: String,
    },
    /// The header lacks a required column.
    #[error(
        "{file}: line 1: missing column `{column}` (need theta_i,theta_r,phi,brdf or theta_i,theta_s,brdf)"
    )]
    MissingColumn {
        /// File path.
        file: String,
        /// Column name.
        column: &'static str,
    },
    /// The header names a column twice.
    #[error("{file}: line 1: column `{column}` appears twice")]
    DuplicateColumn {
        /// File path.
        file: String,
        /// Column name.
        column: String,
    },
    /// A header is a near miss of a column of [`COLUMNS`] ([`near_miss_column`]: in another
    /// case, plural, with a unit, an optional column's name and more): column names are
    /// matched exactly, so it would be missing or, for an optional column, silently ignored
    /// (`Sample` or `sample_id`: samples 1e4 apart in brightness fitted as one; `weights`: an
    /// unweighted fit; `wavelength_nm` renamed `wavelength`: bands 1000 times too long).
    #[error("{file}: line 1: {miss}")]
    MisspeltColumn {
        /// File path.
        file: String,
        /// The header, the column it misses and how.
        miss: NearMiss,
    },
    /// The header has both `sigma` and `weight`, or both `theta_r` and `theta_s`.
    #[error("{file}: line 1: columns `{a}` and `{b}` cannot be used together")]
    ConflictingColumns {
        /// File path.
        file: String,
        /// First column.
        a: &'static str,
        /// Second column.
        b: &'static str,
    },
    /// A field is not a number.
    #[error("{file}: line {line}: column {column}: `{text}` is not a number")]
    NotANumber {
        /// File path.
        file: String,
        /// 1-based line.
        line: u64,
        /// Column name.
        column: &'static str,
        /// Field text.
        text: String,
    },
    /// A field is NaN or infinite.
    #[error("{file}: line {line}: column {column}: `{text}` is not finite")]
    NotFinite {
        /// File path.
        file: String,
        /// 1-based line.
        line: u64,
        /// Column name.
        column: &'static str,
        /// Field text.
        text: String,
    },
    /// A value lies outside its domain.
    #[error("{file}: line {line}: column {column}: {} is outside {range}", brdf_core::Compact(*.value))]
    OutOfRange {
        /// File path.
        file: String,
        /// 1-based line.
        line: u64,
        /// Column name.
        column: &'static str,
        /// The value.
        value: f64,
        /// Accepted range.
        range: &'static str,
    },
    /// The file's name ends in `]`: its datasets' names (`FILE`, `FILE[sample=..]`) would
    /// read as groups of another file's ([`check_file_name`]).
    #[error(
        "{file}: a file name ending in `]` cannot name datasets: `FILE[sample=..,wavelength=..]` \
         names a group of FILE, so `m[wavelength=0.5]` would read as a band of `m` (rename the file)"
    )]
    GroupLikeName {
        /// File path.
        file: String,
    },
    /// The file is empty, or has a header but no data rows (after skipping, if asked).
    #[error("{file}: empty file: no data rows")]
    Empty {
        /// File path.
        file: String,
    },
}

/// A row-level problem, before a file and line are attached: `column theta_i: 95 is outside
/// [0, 90) degrees`. The Python package reports it at an array index.
#[derive(Clone, Debug, PartialEq, Error)]
#[error("column {column}: {kind}")]
pub struct RowError {
    /// The column.
    pub column: &'static str,
    /// What is wrong with its value.
    pub kind: RowErrorKind,
}

/// What is wrong with one value.
#[derive(Clone, Debug, PartialEq, Error)]
pub enum RowErrorKind {
    /// The text is not a number.
    #[error("`{0}` is not a number")]
    NotANumber(String),
    /// The value (as written) is NaN or infinite.
    #[error("`{0}` is not finite")]
    NotFinite(String),
    /// The value lies outside the range named.
    #[error("{shown} is outside {1}", shown = brdf_core::Compact(*.0))]
    OutOfRange(f64, &'static str),
}

/// One measurement in degrees as read (a CSV row, a row of Python's arrays), before
/// [`Point::from_degrees`] validates it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowDegrees {
    /// Incidence zenith, degrees.
    pub theta_i: f64,
    /// Viewing zenith, degrees.
    pub theta_r: f64,
    /// Relative azimuth, degrees.
    pub phi: f64,
    /// BRDF, 1/sr.
    pub brdf: f64,
    /// Standard deviation of `brdf`, if given.
    pub sigma: Option<f64>,
    /// Weight, if given.
    pub weight: Option<f64>,
}

/// Magnitudes a measured BRDF may have, 1/sr. No surface comes near either end (a polished
/// mirror's peak is about 1e7 1/sr); the fit squares values and their inverses, and beyond
/// about 1e150 those overflow or vanish (data scaled by 1e200 fitted to all-zero parameters at
/// 100% error), so a value out here is a unit error and is refused with its line.
pub const BRDF_MAGNITUDE: std::ops::RangeInclusive<f64> = 1e-100..=1e100;

/// Largest `|brdf| / sigma` of a row: its residual is squared (and summed over at most some
/// 1e8 points), so up to 1e100 the cost stays far inside f64; no measurement is 1e100 times
/// more precise than its value.
pub const SIGMA_RATIO_MAX: f64 = 1e100;

/// Largest azimuth magnitude a direction may be given with, degrees: two turns either way
/// covers every convention (`[0, 360)`, `[-180, 180]`, a sweep written past 360). Beyond, the
/// angle is a unit or column error, and a huge one loses its phase in the conversion to
/// radians (1e20 deg evaluated as 280 deg; 1e300 overflowed f32 and was blamed on the model).
pub const PHI_LIMIT_DEG: f64 = 720.0;

impl Point {
    /// Validates a row as `brdf fit` does: every value finite, zeniths in [0, 90) degrees,
    /// `|phi|` at most [`PHI_LIMIT_DEG`],
    /// `brdf > 0` (any sign with `dark_readings`) and, unless 0, its magnitude in
    /// [`BRDF_MAGNITUDE`], `sigma` and
    /// `weight` above 0 and in [`BRDF_MAGNITUDE`]; `line` is where it came from.
    pub fn from_degrees(r: RowDegrees, dark_readings: bool, line: u64) -> Result<Point, RowError> {
        let finite = |v: f64, column| {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(RowError {
                    column,
                    kind: RowErrorKind::NotFinite(v.to_string()),
                })
            }
        };
        let zenith = |v: f64, column| {
            in_range(
                finite(v, column)?,
                (0.0..90.0).contains(&v),
                column,
                "[0, 90) degrees",
            )
        };
        let theta_i = zenith(r.theta_i, "theta_i")?;
        let theta_r = zenith(r.theta_r, "theta_r")?;
        let phi = in_range(
            finite(r.phi, "phi")?,
            r.phi.abs() <= PHI_LIMIT_DEG,
            "phi",
            "[-720, 720] degrees",
        )?;
        let brdf = finite(r.brdf, "brdf")?;
        let brdf = if dark_readings {
            brdf
        } else {
            in_range(brdf, brdf > 0.0, "brdf", "> 0 (this use needs positive readings)")?
        };
        let brdf = in_range(
            brdf,
            brdf == 0.0 || BRDF_MAGNITUDE.contains(&brdf.abs()),
            "brdf",
            "[1e-100, 1e100] 1/sr in magnitude (is the unit right?)",
        )?;
        // Above 0 and within the magnitudes a BRDF may have: a `sigma` of 1e160 made every
        // squared residual underflow to 0 and a fit of garbage "converged" at cost 0.
        let positive = |v: Option<f64>, column| -> Result<Option<f64>, RowError> {
            match v {
                Some(v) => Ok(Some(in_range(
                    finite(v, column)?,
                    v > 0.0 && BRDF_MAGNITUDE.contains(&v),
                    column,
                    "[1e-100, 1e100] (above 0; is the unit right?)",
                )?)),
                None => Ok(None),
            }
        };
        let sigma = positive(r.sigma, "sigma")?;
        // The residual `(f - y) / sigma` is squared: a reading 1e199 times its sigma (each
        // within its own range) overflowed the cost to infinity.
        if let Some(s) = sigma {
            in_range(
                s,
                brdf.abs() / s <= SIGMA_RATIO_MAX,
                "sigma",
                "[|brdf| / 1e100, 1e100] (a reading more than 1e100 times its sigma squares past f64; is the unit of one of them right?)",
            )?;
        }
        Ok(Point {
            theta_i: theta_i.to_radians(),
            theta_r: theta_r.to_radians(),
            phi: phi.to_radians(),
            brdf,
            sigma,
            weight: positive(r.weight, "weight")?,
            line,
        })
    }
}

impl RowError {
    fn into_data_error(self, file: &str, line: u64) -> DataError {
        let file = file.to_owned();
        let column = self.column;
        match self.kind {
            RowErrorKind::NotANumber(text) => DataError::NotANumber {
                file,
                line,
                column,
                text,
            },
            RowErrorKind::NotFinite(text) => DataError::NotFinite {
                file,
                line,
                column,
                text,
            },
            RowErrorKind::OutOfRange(value, range) => DataError::OutOfRange {
                file,
                line,
                column,
                value,
                range,
            },
        }
    }
}

/// Every column the canonical CSV reads, spelt as the header must spell it; any other column
/// is ignored, unless it is a near miss of one of these ([`near_miss_column`]), which is
/// refused.
pub const COLUMNS: [&str; 9] = [
    "theta_i",
    "theta_r",
    "phi",
    "brdf",
    "theta_s",
    "sigma",
    "weight",
    "sample",
    "wavelength",
];

/// The optional columns of [`COLUMNS`]: without them a file still fits, so a near miss of
/// one is not caught as a missing column. A header that begins with one of these names and
/// a separator (`sample_id`, `sigma_rel`, `wavelength in nm`) is refused unless the column
/// itself is there too ([`near_miss_column`]).
pub const OPTIONAL_COLUMNS: [&str; 4] = ["sigma", "weight", "sample", "wavelength"];

/// The angle columns, in degrees.
const ANGLE_COLUMNS: [&str; 4] = ["theta_i", "theta_r", "theta_s", "phi"];

/// What may follow a column's name in a header that is that column with more after it
/// (`sample_id`, `wavelength (nm)`, `wavelength/nm`, `weight.kg`).
const SEPARATORS: [char; 7] = ['_', ' ', '-', '.', '/', '(', '['];

const NANOMETRES: [&str; 5] = ["nm", "nanometre", "nanometres", "nanometer", "nanometers"];
const MICROMETRES: [&str; 9] = [
    "um",
    "µm",
    "μm",
    "micron",
    "microns",
    "micrometre",
    "micrometres",
    "micrometer",
    "micrometers",
];
const DEGREES: [&str; 5] = ["deg", "degs", "degree", "degrees", "°"];
const RADIANS: [&str; 4] = ["rad", "rads", "radian", "radians"];
const PER_SR: [&str; 6] = ["sr", "1/sr", "sr-1", "sr^-1", "persr", "per sr"];

/// Why a header is refused ([`near_miss_column`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NearMiss {
    /// The header as written (trimmed).
    pub column: String,
    /// The column of [`COLUMNS`] it names or begins with.
    pub expected: &'static str,
    /// How it misses.
    pub kind: NearMissKind,
}

/// How a header misses a column of [`COLUMNS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum NearMissKind {
    /// Another case, plural, two neighbouring letters swapped, or with the unit the column
    /// is in already (`Sample`, `weights`, `wavelenght`, `wavelength_um`, `theta_i_deg`).
    Spelling,
    /// `wavelength` in nanometres: renamed as it is, it would be read 1000 times too long.
    Nanometres,
    /// An angle in radians: the angle columns are degrees.
    Radians,
    /// The name of an optional column, a separator and more (`sample_id`, `sigma_rel`,
    /// `wavelength_band`): what it holds is not known, and it would be ignored.
    Prefix,
}

impl std::fmt::Display for NearMiss {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (c, e) = (&self.column, self.expected);
        match self.kind {
            NearMissKind::Spelling => write!(
                f,
                "column `{c}` must be spelt `{e}` (column names are matched exactly: lower case, \
                 singular, without a unit)"
            )?,
            NearMissKind::Nanometres => write!(
                f,
                "column `{c}` is not read: the wavelength column is `wavelength`, in µm (divide \
                 nm by 1000 and name the column `wavelength`)"
            )?,
            NearMissKind::Radians => write!(
                f,
                "column `{c}` is not read: the angle column is `{e}`, in degrees (convert with \
                 degrees = radians * 180 / pi and name the column `{e}`)"
            )?,
            NearMissKind::Prefix => {
                let what = match e {
                    "sample" => "which splits a file into one dataset per sample",
                    "wavelength" => "in µm, which splits a file into one dataset per band",
                    "sigma" => "the 1-sigma uncertainty of brdf, in 1/sr",
                    _ => "the weight of each reading's squared residual",
                };
                write!(
                    f,
                    "column `{c}` is not read, and its name begins with that of the optional \
                     column `{e}` ({what}): column names are matched exactly and other columns \
                     are ignored, so to use it, name it `{e}`"
                )?
            }
        }
        write!(
            f,
            "; if `{c}` is an unrelated column, rename it so that its name does not begin with \
             `{e}`, e.g. `x_{c}`, or keep it beside a `{e}` column"
        )
    }
}

/// The near miss `header` is, or `None`; `present` tells whether a column of [`COLUMNS`] is
/// in the header too. Column names are matched exactly, so a near miss would be missing or,
/// for an optional column, silently ignored. Refused (trimmed; case ignored for matching):
///
/// - a column's name in another case or plural (`Sample`, `samples`, `Weights`), or with two
///   neighbouring letters swapped for an optional column (`wavelenght`, `weigth`);
/// - a column's name (or plural), a separator (`_`, space, `-`, `.`, `/`, `(`, `[`) and a
///   unit: the column's own (`wavelength_um`, `theta_i_deg`, `brdf [1/sr]`), or the wrong
///   one, said so (`wavelength (nm)`: in µm; `phi_rad`: in degrees);
/// - an optional column's name, a separator and anything (`sample_id`, `sigma_rel`,
///   `wavelength_band`, `weight in g`): it reads as that column, and would be ignored.
///
/// Not refused: any of these when the column it names is in the header too (then it is an
/// annotation beside it), and names that only resemble one (`simple`, `sampled`, `sigma2`,
/// `samples_taken`, `phi_i`, `brdf_model`, `height`).
pub fn near_miss_column(header: &str, present: &dyn Fn(&str) -> bool) -> Option<NearMiss> {
    let header = header.trim();
    if COLUMNS.contains(&header) {
        return None;
    }
    let lower = header.to_lowercase();
    let (expected, kind) = whole_name_miss(&lower).or_else(|| suffixed_miss(&lower))?;
    (!present(expected)).then(|| NearMiss {
        column: header.to_owned(),
        expected,
        kind,
    })
}

/// Every header of a file checked with [`near_miss_column`]: the first near miss, if any.
pub fn check_column_names(headers: &[&str]) -> Result<(), NearMiss> {
    let present = |c: &str| headers.iter().any(|h| h.trim() == c);
    for h in headers {
        if let Some(miss) = near_miss_column(h, &present) {
            return Err(miss);
        }
    }
    Ok(())
}

/// `lower` as a whole: a column in another case, plural, or an optional one with two
/// neighbouring letters swapped.
fn whole_name_miss(lower: &str) -> Option<(&'static str, NearMissKind)> {
    let singular = lower.strip_suffix('s');
    COLUMNS
        .iter()
        .find(|c| **c == lower || singular == Some(**c))
        .or_else(|| OPTIONAL_COLUMNS.iter().find(|c| swapped_neighbours(lower, c)))
        .map(|c| (*c, NearMissKind::Spelling))
}

/// `lower` as a column's name (or its plural), a separator and more.
fn suffixed_miss(lower: &str) -> Option<(&'static str, NearMissKind)> {
    for c in COLUMNS {
        for (base, plural) in [(c.to_owned(), false), (format!("{c}s"), true)] {
            let Some(rest) = lower.strip_prefix(base.as_str()) else {
                continue;
            };
            if !rest.starts_with(SEPARATORS) {
                continue;
            }
            let unit = unit_of(rest);
            let is = |units: &[&str]| units.contains(&unit);
            let kind = match c {
                "wavelength" if is(&NANOMETRES) => Some(NearMissKind::Nanometres),
                "wavelength" if is(&MICROMETRES) => Some(NearMissKind::Spelling),
                c if ANGLE_COLUMNS.contains(&c) && is(&RADIANS) => Some(NearMissKind::Radians),
                c if ANGLE_COLUMNS.contains(&c) && is(&DEGREES) => Some(NearMissKind::Spelling),
                "brdf" | "sigma" if is(&PER_SR) => Some(NearMissKind::Spelling),
                // `samples_taken` is not `sample` and something: only a unit makes a plural
                // a near miss.
                c if OPTIONAL_COLUMNS.contains(&c) && !plural => Some(NearMissKind::Prefix),
                _ => None,
            };
            if let Some(kind) = kind {
                return Some((c, kind));
            }
        }
    }
    None
}

/// The unit in what follows a column's name: `_nm`, ` (nm)`, ` [nm]`, ` in nm`, `/nm` and
/// `.nm` are all `nm`.
fn unit_of(rest: &str) -> &str {
    let trimmed = rest.trim_matches(|ch: char| SEPARATORS.contains(&ch) || ch == ')' || ch == ']');
    // `brdf_1/sr` keeps its `/`; `brdf/sr` is `sr`.
    trimmed.strip_prefix("in ").unwrap_or(trimmed).trim()
}

/// Whether `a` is `b` (five letters or more) with two neighbouring letters swapped.
fn swapped_neighbours(a: &str, b: &str) -> bool {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    if a.len() != b.len() || b.len() < 5 || a == b {
        return false;
    }
    let first = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    first + 1 < a.len()
        && a[first] == b[first + 1]
        && a[first + 1] == b[first]
        && a[first + 2..] == b[first + 2..]
}

/// Column positions of one file.
struct Columns {
    theta_i: usize,
    /// `theta_r` and `phi` (full form) or `theta_s` (in-plane form).
    view: View,
    brdf: usize,
    sigma: Option<usize>,
    weight: Option<usize>,
    sample: Option<usize>,
    wavelength: Option<usize>,
}

enum View {
    Full { theta_r: usize, phi: usize },
    InPlane { theta_s: usize },
}

fn find_columns(file: &str, headers: &csv::StringRecord) -> Result<Columns, DataError> {
    let mut seen: HashMap<&str, usize> = HashMap::new();
    for (i, h) in headers.iter().enumerate() {
        let h = h.trim();
        if seen.insert(h, i).is_some() {
            return Err(DataError::DuplicateColumn {
                file: file.to_owned(),
                column: h.to_owned(),
            });
        }
    }
    check_column_names(&headers.iter().collect::<Vec<_>>()).map_err(|miss| DataError::MisspeltColumn {
        file: file.to_owned(),
        miss,
    })?;
    let get = |name: &str| seen.get(name).copied();
    let need = |name: &'static str| {
        get(name).ok_or(DataError::MissingColumn {
            file: file.to_owned(),
            column: name,
        })
    };
    let conflict = |a: &'static str, b: &'static str| DataError::ConflictingColumns {
        file: file.to_owned(),
        a,
        b,
    };
    let view = match (get("theta_r"), get("theta_s")) {
        (Some(_), Some(_)) => return Err(conflict("theta_r", "theta_s")),
        (None, Some(theta_s)) => {
            // The sign of theta_s decides the side; a phi column would be silently ignored.
            if get("phi").is_some() {
                return Err(conflict("theta_s", "phi"));
            }
            View::InPlane { theta_s }
        }
        _ => View::Full {
            theta_r: need("theta_r")?,
            phi: need("phi")?,
        },
    };
    if get("sigma").is_some() && get("weight").is_some() {
        return Err(conflict("sigma", "weight"));
    }
    Ok(Columns {
        theta_i: need("theta_i")?,
        view,
        brdf: need("brdf")?,
        sigma: get("sigma"),
        weight: get("weight"),
        sample: get("sample"),
        wavelength: get("wavelength"),
    })
}

fn number(record: &csv::StringRecord, idx: usize, column: &'static str) -> Result<f64, RowError> {
    let text = record.get(idx).unwrap_or("").trim();
    let v: f64 = text.parse().map_err(|_| RowError {
        column,
        kind: RowErrorKind::NotANumber(text.to_owned()),
    })?;
    if !v.is_finite() {
        return Err(RowError {
            column,
            kind: RowErrorKind::NotFinite(text.to_owned()),
        });
    }
    Ok(v)
}

fn in_range(v: f64, ok: bool, column: &'static str, range: &'static str) -> Result<f64, RowError> {
    if ok {
        Ok(v)
    } else {
        Err(RowError {
            column,
            kind: RowErrorKind::OutOfRange(v, range),
        })
    }
}

fn parse_row(
    record: &csv::StringRecord,
    cols: &Columns,
    opts: LoadOptions,
    line: u64,
) -> Result<Point, RowError> {
    // Numbers first (their messages quote the text), then the one validation of a row.
    let theta_i = number(record, cols.theta_i, "theta_i")?;
    let (theta_r, phi) = match cols.view {
        View::Full { theta_r, phi } => (number(record, theta_r, "theta_r")?, number(record, phi, "phi")?),
        View::InPlane { theta_s } => {
            let ts = number(record, theta_s, "theta_s")?;
            let ts = in_range(ts, ts > -90.0 && ts < 90.0, "theta_s", "(-90, 90) degrees")?;
            if ts > 0.0 {
                (ts, 180.0)
            } else {
                (-ts, 0.0)
            }
        }
    };
    let brdf = number(record, cols.brdf, "brdf")?;
    let optional = |idx: Option<usize>, column| idx.map(|i| number(record, i, column)).transpose();
    let row = RowDegrees {
        theta_i,
        theta_r,
        phi,
        brdf,
        sigma: optional(cols.sigma, "sigma")?,
        weight: optional(cols.weight, "weight")?,
    };
    Point::from_degrees(row, opts.dark_readings, line)
}

/// Refuses a file name (as shown: the path) that ends in `]`. A dataset is named by its file
/// and group, `FILE[sample=..,wavelength=..]` ([`band_of_name`] reads the last `[..]`), so
/// files named `m[wavelength=0.5]` and `m[wavelength=0.6]` packed as two bands of one
/// material `m`; a sample may not hold the delimiters for the same reason ([`Loaded`]). A
/// `[` or `]` elsewhere in the name is harmless and read as written.
pub fn check_file_name(file: &str) -> Result<(), DataError> {
    match file.ends_with(']') {
        true => Err(DataError::GroupLikeName {
            file: file.to_owned(),
        }),
        false => Ok(()),
    }
}

/// Reads and validates one file. Without `skip_invalid` the first bad row is an error; with
/// it, bad rows are listed in [`Loaded::skipped`] and the rest is used.
pub fn load_csv(path: &Path, opts: LoadOptions) -> Result<Loaded, DataError> {
    let file = path.display().to_string();
    check_file_name(&file)?;
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(open_input(path).map_err(|source| DataError::Io {
            file: file.clone(),
            source,
        })?);
    let headers = reader.headers().map_err(|e| csv_error(&file, e))?.clone();
    if headers.iter().all(|h| h.trim().is_empty()) {
        return Err(DataError::Empty { file });
    }
    let cols = find_columns(&file, &headers)?;
    let mut groups: Vec<(String, Vec<Point>)> = Vec::new();
    let mut group_index: HashMap<String, usize> = HashMap::new();
    let mut skipped = Vec::new();
    let mut record = csv::StringRecord::new();
    loop {
        match reader.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                let err = csv_error(&file, e);
                match (&err, opts.skip_invalid) {
                    (DataError::Csv { line, message, .. }, true) => {
                        skipped.push(Skipped {
                            line: *line,
                            reason: message.clone(),
                        });
                        continue;
                    }
                    _ => return Err(err),
                }
            }
        }
        let line = record.position().map_or(0, |p| p.line());
        let point = match parse_row(&record, &cols, opts, line) {
            Ok(p) => p,
            Err(e) => {
                let err = e.into_data_error(&file, line);
                if opts.skip_invalid {
                    skipped.push(Skipped {
                        line,
                        reason: err.to_string(),
                    });
                    continue;
                }
                return Err(err);
            }
        };
        let key = match group_key(&record, &cols) {
            Ok(key) => key,
            Err(message) => {
                if opts.skip_invalid {
                    skipped.push(Skipped {
                        line,
                        reason: message,
                    });
                    continue;
                }
                return Err(DataError::Csv { file, line, message });
            }
        };
        let slot = *group_index.entry(key.clone()).or_insert_with(|| {
            groups.push((key, Vec::new()));
            groups.len() - 1
        });
        groups[slot].1.push(point);
    }
    if groups.is_empty() {
        return Err(DataError::Empty { file });
    }
    let datasets = groups
        .into_iter()
        .map(|(key, mut points)| {
            // Growth by doubling leaves up to as much again unused.
            points.shrink_to_fit();
            (key, points)
        })
        .map(|(key, points)| Dataset {
            name: if key.is_empty() {
                file.clone()
            } else {
                format!("{file}[{key}]")
            },
            points,
        })
        .collect::<Vec<Dataset>>();
    let warnings = datasets.iter().filter_map(Dataset::radians_warning).collect();
    Ok(Loaded {
        datasets,
        skipped,
        warnings,
    })
}

/// Opens an input file: a regular file (or a link to one) only. A device, a directory or a
/// pipe is refused before it is opened: `/dev/zero` read as data grew without bound until the
/// process aborted, and opening a pipe waited for a writer forever. Every reader of a user's
/// file (data, fit results, blobs, scenes, direction lists) opens it here; what it reads is
/// then bounded by the file's size.
pub fn open_input(path: &Path) -> std::io::Result<std::fs::File> {
    if !std::fs::metadata(path)?.is_file() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file (a device, a directory or a pipe)",
        ));
    }
    std::fs::File::open(path)
}

/// Longest line [`open_stream`] passes on, bytes: a row of numbers is a few hundred.
pub const MAX_STREAM_LINE: usize = 1 << 20;

/// Opens an input that is read as it arrives (`brdf eval`'s directions): a regular file or a
/// pipe (`/dev/stdin` fed by another program; a named pipe waits for its writer, as pipes
/// do). A device or a directory is refused, and a line longer than [`MAX_STREAM_LINE`] is an
/// error, so an endless line (`/dev/zero`, a pipe of zeros) cannot grow memory without bound.
pub fn open_stream(path: &Path) -> std::io::Result<LineBounded<std::fs::File>> {
    use std::os::unix::fs::FileTypeExt;
    let kind = std::fs::metadata(path)?.file_type();
    if !(kind.is_file() || kind.is_fifo()) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a regular file or a pipe (a device or a directory)",
        ));
    }
    Ok(LineBounded {
        inner: std::fs::File::open(path)?,
        since_newline: 0,
    })
}

/// A reader that fails once a line exceeds [`MAX_STREAM_LINE`] bytes ([`open_stream`]).
#[derive(Debug)]
pub struct LineBounded<R> {
    inner: R,
    since_newline: usize,
}

impl<R: std::io::Read> std::io::Read for LineBounded<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            if b == b'\n' {
                self.since_newline = 0;
            } else {
                self.since_newline += 1;
                if self.since_newline > MAX_STREAM_LINE {
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!("a line longer than {MAX_STREAM_LINE} bytes: not a table of numbers"),
                    ));
                }
            }
        }
        Ok(n)
    }
}

/// [`open_input`] read whole as text, without a leading UTF-8 byte-order mark (editors on
/// Windows write one; JSON readers refused it while the CSV, TOML and mesh readers skip it).
pub fn read_input(path: &Path) -> std::io::Result<String> {
    let text = std::io::read_to_string(open_input(path)?)?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_owned(),
        None => text,
    })
}

/// [`open_input`] read whole as bytes.
pub fn read_input_bytes(path: &Path) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut open_input(path)?, &mut bytes)?;
    Ok(bytes)
}

/// A wavelength as dataset names and messages print it: to the femtometre (in µm), shortest
/// form, so that one band has one name however a file writes it.
pub fn wavelength_text(um: f64) -> String {
    brdf_core::Compact((um * 1e9).round() / 1e9).to_string()
}

/// A wavelength in µm as every reader and option takes one: a finite number above 0.
pub fn is_wavelength(um: f64) -> bool {
    um.is_finite() && um > 0.0
}

/// `text` as a wavelength in µm ([`is_wavelength`]), or `None`.
pub fn parse_wavelength(text: &str) -> Option<f64> {
    text.parse::<f64>().ok().filter(|&v| is_wavelength(v))
}

/// A dataset name's measurement and band: `FILE[sample=x,wavelength=0.55]` is
/// (`FILE[sample=x]`, 0.55), `FILE[wavelength=0.55]` is (`FILE`, 0.55); `None` for a name
/// without a wavelength group. The inverse of the names [`Loaded`] gives (sample names cannot
/// hold the delimiters, so a name has one reading).
pub fn split_wavelength(name: &str) -> Option<(String, f64)> {
    band_of_name(name).ok().flatten()
}

/// [`split_wavelength`], telling a name without a band (`Ok(None)`) from one whose
/// `wavelength=` group is not a wavelength above 0 (`Err`, naming the text): a fit result
/// edited by hand to `wavelength=NaN` was taken for a fit without a band.
pub fn band_of_name(name: &str) -> Result<Option<(String, f64)>, String> {
    let Some((file, group)) = name.rsplit_once('[') else {
        return Ok(None);
    };
    let Some(group) = group.strip_suffix(']') else {
        return Ok(None);
    };
    let mut um = None;
    let mut rest = Vec::new();
    for g in group.split(',') {
        match g.strip_prefix("wavelength=") {
            Some(v) => match parse_wavelength(v) {
                Some(w) => um = Some(w),
                None => return Err(format!("`wavelength={v}` is not a wavelength above 0 (µm)")),
            },
            None => rest.push(g),
        }
    }
    let Some(um) = um else { return Ok(None) };
    Ok(Some(match rest.is_empty() {
        true => (file.to_owned(), um),
        false => (format!("{file}[{}]", rest.join(",")), um),
    }))
}

/// The dataset a row belongs to: `sample=..,wavelength=..` from its columns. A sample is any
/// text but empty and without `[`, `]`, `,` or `=` (they delimit the name); a wavelength a number above 0, grouped by value (0.5, 0.50 and 5e-1 are one
/// band; they were three datasets, each fitted on a third of the data), written in its
/// shortest form to the femtometre.
fn group_key(record: &csv::StringRecord, cols: &Columns) -> Result<String, String> {
    let mut key = Vec::new();
    if let Some(i) = cols.sample {
        let text = record.get(i).unwrap_or("").trim();
        if text.is_empty() {
            return Err("column sample: empty (name the sample of every row)".to_owned());
        }
        if let Some(c) = text.chars().find(|c| "[],=".contains(*c)) {
            return Err(format!(
                "column sample: `{text}` holds `{c}`, which delimits dataset names (FILE[sample=..,wavelength=..])"
            ));
        }
        key.push(format!("sample={text}"));
    }
    if let Some(i) = cols.wavelength {
        let text = record.get(i).unwrap_or("").trim();
        match parse_wavelength(text) {
            Some(v) => key.push(format!("wavelength={}", wavelength_text(v))),
            None => return Err(format!("column wavelength: `{text}` is not a wavelength above 0")),
        }
    }
    Ok(key.join(","))
}

fn csv_error(file: &str, e: csv::Error) -> DataError {
    let line = e.position().map_or(0, |p| p.line());
    match e.into_kind() {
        csv::ErrorKind::Io(source) => DataError::Io {
            file: file.to_owned(),
            source,
        },
        other => DataError::Csv {
            file: file.to_owned(),
            line,
            message: match other {
                csv::ErrorKind::UnequalLengths {
                    expected_len, len, ..
                } => {
                    format!("found {len} fields, expected {expected_len}")
                }
                csv::ErrorKind::Utf8 { err, .. } => format!("invalid UTF-8: {err}"),
                k => format!("{k:?}"),
            },
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn load(text: &str, opts: LoadOptions) -> (tempfile::NamedTempFile, Result<Loaded, DataError>) {
        let mut f = tempfile::Builder::new().suffix(".csv").tempfile().unwrap();
        f.write_all(text.as_bytes()).unwrap();
        let r = load_csv(f.path(), opts);
        (f, r)
    }

    fn err(text: &str) -> String {
        let (f, r) = load(text, LoadOptions::default());
        let msg = r.unwrap_err().to_string();
        assert!(msg.contains(&f.path().display().to_string()), "{msg}");
        msg
    }

    /// One test per class of bad file: each must name the file, line and column.
    macro_rules! bad_file {
        ($($name:ident: $text:expr => $want:expr;)*) => {$(
            #[test]
            fn $name() {
                let msg = err($text);
                assert!(msg.contains($want), "expected `{}` in: {msg}", $want);
            }
        )*};
    }

    bad_file! {
        not_a_number: "theta_i,theta_r,phi,brdf\n0,0,0,x\n" => "line 2: column brdf: `x` is not a number";
        nan: "theta_i,theta_r,phi,brdf\n0,0,0,0.1\n0,0,NaN,0.1\n" => "line 3: column phi: `NaN` is not finite";
        infinite: "theta_i,theta_r,phi,brdf\n0,0,0,inf\n" => "column brdf: `inf` is not finite";
        negative_brdf: "theta_i,theta_r,phi,brdf\n0,0,0,-0.1\n" => "line 2: column brdf: -0.1 is outside > 0";
        zero_brdf: "theta_i,theta_r,phi,brdf\n0,0,0,0\n" => "column brdf: 0 is outside > 0";
        // Scaled by 1e200 (or 1e-200) the data once fitted to all-zero parameters at 100%.
        huge_brdf: "theta_i,theta_r,phi,brdf\n0,0,0,0.1\n0,10,0,2.5e200\n" => "line 3: column brdf: 2.5e200 is outside [1e-100, 1e100] 1/sr";
        tiny_brdf: "theta_i,theta_r,phi,brdf\n0,0,0,3e-200\n" => "line 2: column brdf: 3e-200 is outside [1e-100, 1e100]";
        // Each within its range, together 1e199 apart: the squared residual overflowed.
        reading_far_above_sigma: "theta_i,theta_r,phi,brdf,sigma\n0,0,0,1,1\n0,10,0,1e99,1e-100\n" => "line 3: column sigma: 1e-100 is outside [|brdf| / 1e100, 1e100]";
        zenith_at_90: "theta_i,theta_r,phi,brdf\n90,0,0,0.1\n" => "column theta_i: 90 is outside [0, 90)";
        negative_zenith: "theta_i,theta_r,phi,brdf\n10,-5,0,0.1\n" => "column theta_r: -5 is outside";
        theta_s_out_of_range: "theta_i,theta_s,brdf\n10,95,0.1\n" => "column theta_s: 95 is outside";
        empty_file: "theta_i,theta_r,phi,brdf\n" => "no data rows";
        missing_phi: "theta_i,theta_r,brdf\n0,0,1\n" => "missing column `phi`";
        missing_brdf: "theta_i,phi,theta_r\n0,0,1\n" => "missing column `brdf`";
        duplicate_column: "theta_i,theta_r,phi,brdf,phi\n0,0,0,1,0\n" => "column `phi` appears twice";
        sigma_and_weight: "theta_i,theta_r,phi,brdf,sigma,weight\n0,0,0,1,1,1\n" => "`sigma` and `weight`";
        short_row: "theta_i,theta_r,phi,brdf\n0,0,0\n" => "line 2: found 3 fields, expected 4";
        zero_sigma: "theta_i,theta_r,phi,brdf,sigma\n0,0,0,1,0\n" => "column sigma: 0 is outside [1e-100, 1e100] (above 0";
        zero_bytes: "" => "empty file";
        theta_s_and_phi: "theta_i,theta_s,phi,brdf\n10,20,77,0.1\n" => "`theta_s` and `phi` cannot be used together";
        // An optional column in capitals was ignored: two samples fitted as one.
        capital_sample: "theta_i,theta_r,phi,brdf,Sample\n0,0,0,0.1,A\n" => "line 1: column `Sample` must be spelt `sample`";
        capital_sigma: "theta_i,theta_r,phi,brdf,SIGMA\n0,0,0,0.1,0.01\n" => "line 1: column `SIGMA` must be spelt `sigma`";
        capital_theta_i: "Theta_i,theta_r,phi,brdf\n0,0,0,0.1\n" => "line 1: column `Theta_i` must be spelt `theta_i`";
        // Near misses of an optional column were ignored as extra columns: `samples` fitted
        // two materials as one, `weights` or `wavelength_um` left the fit unweighted or
        // unbanded without a word.
        plural_sample: "theta_i,theta_r,phi,brdf,samples\n0,0,0,0.1,A\n" => "line 1: column `samples` must be spelt `sample`";
        plural_weight: "theta_i,theta_r,phi,brdf,weights\n0,0,0,0.1,2\n" => "line 1: column `weights` must be spelt `weight`";
        plural_sigma: "theta_i,theta_r,phi,brdf,Sigmas\n0,0,0,0.1,0.01\n" => "line 1: column `Sigmas` must be spelt `sigma`";
        unit_suffix_wavelength: "theta_i,theta_r,phi,brdf,wavelength_um\n0,0,0,0.1,0.5\n" => "line 1: column `wavelength_um` must be spelt `wavelength`";
        unit_suffix_in_brackets: "theta_i,theta_r,phi,brdf,wavelength (nm)\n0,0,0,0.1,500\n" => "line 1: column `wavelength (nm)` is not read: the wavelength column is `wavelength`, in µm (divide nm by 1000";
        unit_suffix_angle: "theta_i_deg,theta_r,phi,brdf\n0,0,0,0.1\n" => "line 1: column `theta_i_deg` must be spelt `theta_i`";
        transposed_letters: "theta_i,theta_r,phi,brdf,wavelenght\n0,0,0,0.1,0.5\n" => "line 1: column `wavelenght` must be spelt `wavelength`";
        one_letter_off: "theta_i,theta_r,phi,brdf,sampel\n0,0,0,0.1,A\n" => "line 1: column `sampel` must be spelt `sample`";
        near_miss_says_how_to_keep_a_column: "theta_i,theta_r,phi,brdf,weigth\n0,0,0,0.1,2\n" => "rename it";
    }

    /// A file named like a dataset group (`m[wavelength=0.5]`) gave datasets whose names
    /// read as bands of `m`: two files packed as one banded material. Such a name is
    /// refused; a `[` or `]` elsewhere in the name is read as written.
    #[test]
    fn a_file_name_that_reads_as_a_group_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let text = "theta_i,theta_r,phi,brdf\n0,0,0,0.1\n0,10,0,0.2\n";
        for name in ["m[wavelength=0.5]", "m[sample=A]", "scan[3]"] {
            let path = dir.path().join(name);
            std::fs::write(&path, text).unwrap();
            let e = load_csv(&path, LoadOptions::default()).unwrap_err().to_string();
            assert!(
                e.contains(&path.display().to_string()) && e.contains("a file name ending in `]`"),
                "{name}: {e}"
            );
        }
        // A group in the middle of the name is read as written, never as a band.
        for name in ["m[1].csv", "[draft] m.csv", "m[wavelength=0.5].csv"] {
            let path = dir.path().join(name);
            std::fs::write(&path, text).unwrap();
            let l = load_csv(&path, LoadOptions::default()).unwrap();
            assert_eq!(l.datasets[0].name, path.display().to_string());
            assert_eq!(split_wavelength(&l.datasets[0].name), None);
        }
    }

    /// Extra columns unlike every known name are ignored, as before; so is a near miss
    /// renamed as the refusal suggests.
    #[test]
    fn unrelated_extra_columns_are_still_ignored() {
        for extra in [
            "operator",
            "x_samples",
            "note",
            "run",
            "temperature_c",
            "phi_i",
            "brdf_model",
        ] {
            let (_f, r) = load(
                &format!("theta_i,theta_r,phi,brdf,{extra}\n0,0,0,0.1,7\n0,10,0,0.2,8\n"),
                LoadOptions::default(),
            );
            let l = r.unwrap_or_else(|e| panic!("{extra}: {e}"));
            assert_eq!((l.datasets.len(), l.datasets[0].points.len()), (1, 2), "{extra}");
        }
    }

    /// The column rule as a table: each header alone beside the four required columns, or
    /// beside the column it resembles. Refused: what reads as a known column and would be
    /// ignored or misread, naming the column and the advice; accepted: what only resembles
    /// one (a trailing digit or letter is no typo), and any of them beside the column itself.
    #[test]
    fn column_names_refused_and_accepted() {
        let base = "theta_i,theta_r,phi,brdf";
        let refused: &[(&str, &str, &str)] = &[
            // Another case, plural, swapped letters, the column's own unit.
            ("Sample", "sample", "must be spelt `sample`"),
            ("samples", "sample", "must be spelt `sample`"),
            ("Weights", "weight", "must be spelt `weight`"),
            ("wavelenght", "wavelength", "must be spelt `wavelength`"),
            ("sampel", "sample", "must be spelt `sample`"),
            ("weigth", "weight", "must be spelt `weight`"),
            ("wavelength_um", "wavelength", "must be spelt `wavelength`"),
            ("wavelength [µm]", "wavelength", "must be spelt `wavelength`"),
            ("wavelengths_um", "wavelength", "must be spelt `wavelength`"),
            ("sigma (1/sr)", "sigma", "must be spelt `sigma`"),
            // Nanometres: renamed `wavelength` as they are, bands 1000 times too long.
            ("wavelength_nm", "wavelength", "in µm (divide nm by 1000"),
            ("wavelength (nm)", "wavelength", "in µm (divide nm by 1000"),
            ("Wavelength [nm]", "wavelength", "in µm (divide nm by 1000"),
            ("wavelength in nm", "wavelength", "in µm (divide nm by 1000"),
            ("wavelength/nm", "wavelength", "in µm (divide nm by 1000"),
            ("wavelength.nm", "wavelength", "in µm (divide nm by 1000"),
            ("wavelength_nanometres", "wavelength", "in µm (divide nm by 1000"),
            // Radians: the angle columns are degrees.
            (
                "phi_rad",
                "phi",
                "in degrees (convert with degrees = radians * 180 / pi",
            ),
            ("phi (rad)", "phi", "in degrees"),
            // An optional column's name and more: it reads as that column.
            (
                "sample_id",
                "sample",
                "begins with that of the optional column `sample`",
            ),
            (
                "sample_name",
                "sample",
                "begins with that of the optional column `sample`",
            ),
            // No longer as a unit (`m` is no unit suffix: `phi_m` is accepted), but as a
            // sample column and more, like `sample_id`.
            (
                "sample_m",
                "sample",
                "begins with that of the optional column `sample`",
            ),
            (
                "Sample ID",
                "sample",
                "begins with that of the optional column `sample`",
            ),
            (
                "wavelength_band",
                "wavelength",
                "begins with that of the optional column `wavelength`",
            ),
            (
                "wavelength_mm",
                "wavelength",
                "begins with that of the optional column `wavelength`",
            ),
            ("sigma_rel", "sigma", "the 1-sigma uncertainty of brdf, in 1/sr"),
            (
                "sigma_brdf",
                "sigma",
                "begins with that of the optional column `sigma`",
            ),
            (
                "sigma_note",
                "sigma",
                "begins with that of the optional column `sigma`",
            ),
            (
                "weight_kg",
                "weight",
                "begins with that of the optional column `weight`",
            ),
        ];
        for &(header, expected, says) in refused {
            // An angle's near miss stands in for the angle; another's is a fifth column.
            let line = match base.contains(expected) {
                true => format!("{},x\n0,0,0,0.1,1\n", base.replace(expected, header)),
                false => format!("{base},{header}\n0,0,0,0.1,1\n"),
            };
            let msg = err(&line);
            assert!(
                msg.contains(&format!("line 1: column `{header}`"))
                    && msg.contains(says)
                    && msg.contains(&format!("does not begin with `{expected}`, e.g. `x_{header}`")),
                "{header}: {msg}"
            );
            // Beside the column it resembles, it is an annotation: accepted, unread.
            let beside = match base.contains(expected) {
                true => format!("{base},{header},x\n0,0,0,0.1,1,2\n0,10,0,0.2,1,2\n"),
                false => format!("{base},{expected},{header}\n0,0,0,0.1,1,2\n0,10,0,0.2,1,2\n"),
            };
            let (_f, r) = load(&beside, LoadOptions::default());
            r.unwrap_or_else(|e| panic!("{header} beside {expected}: {e}"));
        }
        let unit_of_angle = err("theta_i_deg,theta_r,phi,brdf\n0,0,0,0.1\n");
        assert!(
            unit_of_angle.contains("column `theta_i_deg` must be spelt `theta_i`"),
            "{unit_of_angle}"
        );
        for header in [
            "simple",
            "sampled",
            "sampler",
            "sample2",
            "weightx",
            "weight2",
            "sigma1",
            "sigma2",
            "phi_m",
            "brdf_m",
            "height",
            "samples_taken",
            "signal",
            "sigmoid",
            "brdf_sigma",
            "x_sample_id",
            "x_wavelength_nm",
            "phi_i",
            "brdf_model",
            "operator",
            "Unnamed: 0",
            "index",
        ] {
            let (_f, r) = load(
                &format!("{base},{header}\n0,0,0,0.1,7\n0,10,0,0.2,8\n"),
                LoadOptions::default(),
            );
            let l = r.unwrap_or_else(|e| panic!("{header}: {e}"));
            assert_eq!((l.datasets.len(), l.datasets[0].points.len()), (1, 2), "{header}");
        }
        // `wavelength` and `wavelength_nm` both: the bands are `wavelength`'s, in µm.
        let (_f, r) = load(
            &format!("{base},wavelength,wavelength_nm\n0,0,0,0.1,0.5,500\n0,10,0,0.2,0.5,500\n"),
            LoadOptions::default(),
        );
        let names: Vec<String> = r.unwrap().datasets.into_iter().map(|d| d.name).collect();
        assert!(
            names.len() == 1 && names[0].ends_with("[wavelength=0.5]"),
            "{names:?}"
        );
    }

    /// Few distinct incidences are one group each; continuous ones are 1-degree bins; every
    /// point is in one group.
    #[test]
    fn incidence_groups_are_exact_or_binned() {
        let pt = |deg: f64| Point {
            theta_i: deg.to_radians(),
            theta_r: 0.1,
            phi: 0.0,
            brdf: 1.0,
            sigma: None,
            weight: None,
            line: 1,
        };
        let few = Dataset {
            name: "few".into(),
            points: [30.0, 0.0, 30.0, 60.0].map(pt).to_vec(),
        };
        let g = few.incidence_groups();
        assert_eq!(g.len(), 3);
        assert_eq!(g[1], (30f64.to_radians(), vec![0, 2]));
        let n = 20_000;
        let many = Dataset {
            name: "many".into(),
            points: (0..n).map(|k| pt(89.9 * k as f64 / n as f64)).collect(),
        };
        let g = many.incidence_groups();
        assert_eq!(g.len(), MAX_INCIDENCE_GROUPS);
        let mut seen = vec![false; n];
        for (t, members) in &g {
            let lo = t.to_degrees().floor();
            for &k in members {
                assert!(!seen[k]);
                seen[k] = true;
                assert_eq!(many.points[k].theta_i.to_degrees().floor(), lo);
            }
        }
        assert!(seen.iter().all(|&s| s));
    }

    /// The ends of [`BRDF_MAGNITUDE`] are accepted, and zero and negative readings where
    /// dark readings are.
    #[test]
    fn brdf_magnitudes_at_the_ends_are_accepted() {
        let row = |brdf| RowDegrees {
            theta_i: 0.0,
            theta_r: 0.0,
            phi: 0.0,
            brdf,
            sigma: None,
            weight: None,
        };
        for v in [1e-100, 1e100, 0.37] {
            assert_eq!(Point::from_degrees(row(v), false, 1).unwrap().brdf, v);
        }
        assert_eq!(Point::from_degrees(row(0.0), true, 1).unwrap().brdf, 0.0);
        assert_eq!(Point::from_degrees(row(-1e-3), true, 1).unwrap().brdf, -1e-3);
        assert!(Point::from_degrees(row(-1e-3), false, 1).is_err());
        assert!(Point::from_degrees(row(0.0), false, 1).is_err());
        assert!(Point::from_degrees(row(1.0000001e100), true, 1).is_err());
        assert!(Point::from_degrees(row(-1.0000001e100), true, 1).is_err());
        assert!(Point::from_degrees(row(-1e-101), true, 1).is_err());
    }

    #[test]
    fn in_plane_sign_maps_to_forward_and_back() {
        let (_f, r) = load(
            "theta_i,theta_s,brdf\n30,40,0.5\n30,-20,0.2\n",
            LoadOptions::default(),
        );
        let d = &r.unwrap().datasets[0];
        assert_eq!(
            (
                d.points[0].theta_r.to_degrees().round(),
                d.points[0].phi.to_degrees()
            ),
            (40.0, 180.0)
        );
        assert_eq!(
            (
                d.points[1].theta_r.to_degrees().round(),
                d.points[1].phi.to_degrees()
            ),
            (20.0, 0.0)
        );
    }

    #[test]
    fn groups_split_and_skips_are_listed() {
        let text = "sample,wavelength,theta_i,theta_r,phi,brdf\nA,633,0,0,0,1\nB,633,0,0,0,2\nA,633,10,10,0,bad\nA,532,0,5,0,3\n";
        let (_f, r) = load(text, LoadOptions::default());
        assert!(r.is_err());
        let (_f, r) = load(
            text,
            LoadOptions {
                skip_invalid: true,
                ..Default::default()
            },
        );
        let l = r.unwrap();
        assert_eq!(l.datasets.len(), 3);
        assert!(l.datasets[0].name.ends_with("[sample=A,wavelength=633]"));
        assert_eq!(l.skipped.len(), 1);
        assert_eq!(l.skipped[0].line, 4);
        assert!(l.skipped[0].reason.contains("`bad` is not a number"));
        let total: usize = l.datasets.iter().map(|d| d.points.len()).sum();
        assert_eq!(total + l.skipped.len(), 4, "every row is used or listed");
    }

    /// Zeniths written in radians (a hemisphere: all below pi/2, most above 1) are read as
    /// written but warned about; a measurement near normal incidence only, or with one zenith
    /// at pi/2 degrees or beyond, is not.
    #[test]
    fn zeniths_that_look_like_radians_are_warned_about() {
        let rows = |zeniths: &[(f64, f64)]| {
            let mut text = "theta_i,theta_r,phi,brdf\n".to_owned();
            for (ti, tr) in zeniths {
                text.push_str(&format!("{ti},{tr},0,0.1\n"));
            }
            load(&text, LoadOptions::default()).1.unwrap()
        };
        let hemisphere: Vec<(f64, f64)> = (0..8)
            .flat_map(|i| (0..8).map(move |r| (0.15 * f64::from(i), 0.19 * f64::from(r))))
            .collect();
        let l = rows(&hemisphere);
        assert_eq!(l.warnings.len(), 1, "{:?}", l.warnings);
        assert!(
            l.warnings[0].contains(&l.datasets[0].name) && l.warnings[0].contains("look like radians"),
            "{}",
            l.warnings[0]
        );
        // Read as written all the same.
        assert_eq!(l.datasets[0].points.len(), hemisphere.len());
        let near_normal = [(0.0, 0.0), (0.0, 0.5), (0.5, RADIANS_SPAN_MIN_DEG)];
        assert!(rows(&near_normal).warnings.is_empty());
        let one_beyond = [(0.0, 1.2), (1.0, 1.5), (0.5, RADIANS_ZENITH_MAX_DEG + 1e-3)];
        assert!(rows(&one_beyond).warnings.is_empty());
        // Reaching the horizon, pi/2 written rounded up to four decimals: still radians.
        let mut horizon = hemisphere.clone();
        horizon.push((0.0, (std::f64::consts::FRAC_PI_2 * 1e4).ceil() / 1e4));
        assert_eq!(rows(&horizon).warnings.len(), 1);
    }

    /// A band written three ways was three datasets, each fitted on a third of the data; a
    /// wavelength that is not one, or an empty sample, formed a dataset of its own.
    #[test]
    fn a_band_is_one_dataset_however_written_and_bad_groups_are_refused() {
        let text =
            "wavelength,theta_i,theta_r,phi,brdf\n0.5,0,0,0,1\n0.50,0,10,0,1\n5e-1,0,20,0,1\n0.6,0,0,0,1\n";
        let (_f, r) = load(text, LoadOptions::default());
        let l = r.unwrap();
        let names: Vec<&str> = l
            .datasets
            .iter()
            .map(|d| d.name.rsplit_once('[').unwrap().1)
            .collect();
        assert_eq!(names, ["wavelength=0.5]", "wavelength=0.6]"]);
        assert_eq!(l.datasets[0].points.len(), 3);
        for (bad, says) in [
            ("nan", "wavelength: `nan`"),
            ("inf", "wavelength: `inf`"),
            ("-1", "wavelength: `-1`"),
            ("", "wavelength: ``"),
        ] {
            let (_f, r) = load(
                &format!("wavelength,theta_i,theta_r,phi,brdf\n0.5,0,0,0,1\n{bad},0,10,0,1\n"),
                LoadOptions::default(),
            );
            let e = r.unwrap_err().to_string();
            assert!(e.contains("line 3") && e.contains(says), "{bad}: {e}");
        }
        let (_f, r) = load(
            "sample,theta_i,theta_r,phi,brdf\nA,0,0,0,1\n ,0,10,0,1\n",
            LoadOptions::default(),
        );
        let e = r.unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("sample: empty"), "{e}");
        // A sample named like a group (`x,wavelength=0.5`) read back as a band of `x`.
        let (_f, r) = load(
            "sample,theta_i,theta_r,phi,brdf\nA,0,0,0,1\n\"x,wavelength=0.5\",0,10,0,1\n",
            LoadOptions::default(),
        );
        let e = r.unwrap_err().to_string();
        assert!(
            e.contains("line 3") && e.contains("delimits dataset names"),
            "{e}"
        );
        assert_eq!(
            split_wavelength("f.csv[sample=A,wavelength=0.55]"),
            Some(("f.csv[sample=A]".into(), 0.55))
        );
        assert_eq!(
            split_wavelength("f.csv[wavelength=0.55]"),
            Some(("f.csv".into(), 0.55))
        );
        assert_eq!(split_wavelength("f.csv[sample=A]"), None);
        assert_eq!(split_wavelength("f.csv"), None);
        // sigma and weight within the magnitudes a BRDF may have.
        for col in ["sigma", "weight"] {
            let (_f, r) = load(
                &format!("theta_i,theta_r,phi,brdf,{col}\n0,0,0,1,1e160\n"),
                LoadOptions::default(),
            );
            let e = r.unwrap_err().to_string();
            assert!(e.contains(col) && e.contains("[1e-100, 1e100]"), "{e}");
        }
    }
}
