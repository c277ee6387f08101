//! The parameter blob: the materials a device evaluates, as flashed or loaded.
//!
//! Little-endian layout, version 4 (version 3 is version 4 without banded materials, version
//! 2 version 3 without fitted tables, version 1 version 2 without lookup tables; all are still
//! read, and a blob is written in the oldest version that holds it, so devices that know only
//! an older version still take it):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | magic `BRDF` |
//! | 4 | 2 | format version (2, 3 or 4) |
//! | 6 | 2 | flags (0; readers reject unknown flags) |
//! | 8 | 4 | sequence number (newer blobs have larger numbers) |
//! | 12 | 2 | material count (1 to [`MAX_MATERIALS`]) |
//! | 14 | 2 | reserved (0; readers reject anything else) |
//! | 16 | 4 + 4 n + ... | per material: model id, parameter count n, table word w (u16), n f32 parameters, then: for w = 0 nothing; for w in 2..=4096, w x 3 f32 lookup-table nodes ([`brdf_core::table`]; six-parameter model only); for w = [`FITTED_WORD`] (version 3), a fitted table ([`brdf_core::fitted`]: the model is its base, its length follows from its header); for w = [`BANDED_WORD`] + m with m in 1..=[`MAX_BANDS`] (version 4), a spectral material of m bands: the n parameters above are band 0's, then m f32 band centres in µm (ascending, [`brdf_core::bands::valid`]), then n f32 parameters for each of bands 1 to m - 1 |
//! | end - 4 | 4 | CRC-32 (ISO-HDLC) of every byte before it |
//!
//! A reader rejects a wrong magic, a version or flag it does not know, a non-zero reserved
//! field, any length mismatch, a bad CRC, an unknown model id, a wrong parameter count, parameters outside the model's
//! valid ranges and a table that is malformed or belongs to other parameters (checked with
//! [`SixTable::verify`]), each with its own [`BlobError`]; a banded material whose centres are
//! not ascending or whose band's parameters are out of range is refused too.
//!
//! A banded material answers at a wavelength ([`Material::locate`], the rule of
//! [`brdf_core::bands`]): one band's model at its centre, the two neighbours' blended between
//! them, nothing outside.

pub use brdf_core::bands::MAX_BANDS;
use brdf_core::bands::{BandError, Located};
use brdf_core::fitted::{FittedShape, FittedTable, FITTED_HEADER_LEN};
use brdf_core::table::{table_len, SixTable, MAX_TABLE_NODES, MIN_TABLE_NODES};
use brdf_core::{table1_f32, AnyModel, ModelKind, SixParams, MAX_PARAMS, TABLE1};

use crate::crc32;

/// `BRDF`.
pub const BLOB_MAGIC: [u8; 4] = *b"BRDF";
/// The newest blob format version this crate reads and writes (banded materials).
pub const BLOB_VERSION: u16 = 4;
/// The version written for a blob with fitted tables and no banded material.
pub const BLOB_VERSION_WITHOUT_BANDS: u16 = 3;
/// The version written for a blob without fitted tables or banded materials.
pub const BLOB_VERSION_WITHOUT_FITTED: u16 = 2;
/// The table word of a material followed by a fitted table (version 3).
pub const FITTED_WORD: u16 = 0x8000;
/// The table word of a banded material is this plus its band count (version 4).
pub const BANDED_WORD: u16 = 0x4000;
/// Most materials in one blob.
pub const MAX_MATERIALS: usize = 8;
/// Largest encoded blob: one flash slot, and what one LOAD frame carries. Eight materials
/// without tables take 244 bytes; a 256-node table takes 3,072 (so one material's table of
/// up to 337 nodes fits, or several smaller ones).
pub const MAX_BLOB_LEN: usize = 4096;

const HEADER_LEN: usize = 16;

/// Encoded length of a blob holding `materials` (what [`Blob::encoded_len`] returns for
/// them; no limit on their number is applied).
pub fn encoded_len(materials: &[Material]) -> usize {
    HEADER_LEN + materials.iter().map(Material::encoded_len).sum::<usize>() + 4
}

/// The CRC that identifies a blob (what INFO reports): CRC-32 of every byte before its
/// trailing CRC. Equal to that trailer for any blob that decodes.
pub fn blob_crc(bytes: &[u8]) -> u32 {
    crc32(&bytes[..bytes.len().saturating_sub(4)])
}

/// Model id on the wire. The microfacet model (6) came after the versions' layouts were
/// fixed: it needs no new field, so any version may carry it, and a reader that predates it
/// rejects it as an unknown model id.
pub const fn model_id(kind: ModelKind) -> u8 {
    match kind {
        ModelKind::Six => 1,
        ModelKind::SixCos2 => 2,
        ModelKind::Five => 3,
        ModelKind::Minnaert => 4,
        ModelKind::Lambert => 5,
        ModelKind::Ggx => 6,
    }
}

/// Model of a wire id.
pub const fn kind_from_id(id: u8) -> Option<ModelKind> {
    match id {
        1 => Some(ModelKind::Six),
        2 => Some(ModelKind::SixCos2),
        3 => Some(ModelKind::Five),
        4 => Some(ModelKind::Minnaert),
        5 => Some(ModelKind::Lambert),
        6 => Some(ModelKind::Ggx),
        _ => None,
    }
}

/// The paper's Table 1 (khaki, yellow, white painted plates) as a blob with sequence 0: the
/// firmware's built-in default materials, known to the host too.
pub fn table1_blob() -> Blob {
    let mut materials = heapless::Vec::new();
    for row in 0..TABLE1.len() {
        let params = table1_f32(row);
        // Capacity MAX_MATERIALS = 8 > 3.
        let _ = materials.push(Material {
            kind: ModelKind::Six,
            params,
            table: None,
            fitted: None,
            bands: None,
        });
    }
    Blob {
        sequence: 0,
        materials,
    }
}

/// One material: a model and its parameters (paper order, f32), and optionally its tables.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// The model.
    pub kind: ModelKind,
    /// Parameters; entries past the model's count are zero.
    pub params: [f32; MAX_PARAMS],
    /// Where this material's lookup tables are (six-parameter model only).
    pub table: Option<TableRef>,
    /// Where this material's fitted table is: the model is then its base, `f = f_base *
    /// exp(t)` ([`brdf_core::fitted::Corrected`]). Never together with `table`.
    pub fitted: Option<FittedRef>,
    /// Where this spectral material's other bands are; `params` are then band 0's. Never
    /// together with `table` or `fitted`.
    pub bands: Option<BandsRef>,
}

/// A banded material's band centres and other bands' parameters inside an encoded blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BandsRef {
    /// Bands (1 to [`MAX_BANDS`]).
    pub count: u8,
    /// Byte offset of the first band centre in the encoded blob (set by [`Blob::decode`];
    /// ignored by [`Blob::encode_with_tables`]).
    pub offset: u16,
}

impl BandsRef {
    /// Bytes after band 0's parameters: the centres, then bands 1.. of `params` parameters.
    pub fn len(&self, params: usize) -> usize {
        let m = usize::from(self.count);
        4 * m + 4 * params * m.saturating_sub(1)
    }
}

/// A material's fitted table inside an encoded blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FittedRef {
    /// Bytes of the table ([`FittedShape::encoded_len`] of its shape).
    pub len: u16,
    /// Byte offset of the table in the encoded blob (set by [`Blob::decode`]; ignored by
    /// [`Blob::encode_with_tables`]).
    pub offset: u16,
}

impl FittedRef {
    /// The table's bytes inside `blob`, the bytes this reference was decoded from.
    pub fn bytes<'b>(&self, blob: &'b [u8]) -> Option<&'b [u8]> {
        let at = usize::from(self.offset);
        blob.get(at..at + usize::from(self.len))
    }
}

/// A material's tables inside an encoded blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TableRef {
    /// Nodes per table.
    pub nodes: u16,
    /// Byte offset of the first node in the encoded blob (set by [`Blob::decode`]; ignored
    /// by [`Blob::encode_with_tables`]).
    pub offset: u16,
}

impl TableRef {
    /// Bytes of the tables.
    pub fn len(&self) -> usize {
        table_len(usize::from(self.nodes))
    }

    /// Never true for a valid table (at least two nodes).
    pub fn is_empty(&self) -> bool {
        self.nodes == 0
    }

    /// The node bytes inside `blob`, the bytes this reference was decoded from.
    pub fn bytes<'b>(&self, blob: &'b [u8]) -> Option<&'b [u8]> {
        let at = usize::from(self.offset);
        blob.get(at..at + self.len())
    }
}

impl Material {
    /// The material a device holds for f64 parameters (paper order and signs, at least the
    /// model's count): each is checked against its range as given, then rounded to f32 and
    /// the f32 model validated (both checks are exact at the bounds: [`brdf_core::ranges`]).
    pub fn from_params(kind: ModelKind, values: &[f64]) -> Result<Material, brdf_core::ParamError> {
        if values.len() < kind.param_count() {
            return Err(brdf_core::ParamError::WrongCount {
                expected: kind.param_count(),
                got: values.len(),
            });
        }
        let mut params = [0.0f32; MAX_PARAMS];
        for ((p, &x), range) in params.iter_mut().zip(values).zip(kind.ranges()) {
            *p = range.check(x)? as f32;
        }
        let m = Material {
            kind,
            params,
            table: None,
            fitted: None,
            bands: None,
        };
        m.model()?;
        Ok(m)
    }

    /// A spectral material of `bands` (centre in µm, that band's material: one model, no
    /// tables), ascending at least [`brdf_core::bands::SAME_BAND_UM`] apart once rounded to
    /// f32, 1 to [`MAX_BANDS`] of them (one band answers at its own wavelength only). Writes its band bytes into `out` and returns the
    /// material and their length; pass them with it to [`Blob::encode_with_tables`].
    pub fn banded(bands: &[(f64, Material)], out: &mut [u8]) -> Result<(Material, usize), BandError> {
        let (Some((_, first)), true) = (bands.first(), (1..=MAX_BANDS).contains(&bands.len())) else {
            return Err(BandError::Malformed);
        };
        let k = first.kind.param_count();
        let mut centres = [0.0f32; MAX_BANDS];
        for ((c, (um, m)), _) in centres.iter_mut().zip(bands).zip(0..) {
            if m.kind != first.kind || m.table.is_some() || m.fitted.is_some() || m.bands.is_some() {
                return Err(BandError::Malformed);
            }
            *c = *um as f32;
        }
        if !brdf_core::bands::valid(&centres[..bands.len()]) {
            return Err(BandError::Malformed);
        }
        let r = BandsRef {
            count: bands.len() as u8,
            offset: 0,
        };
        let len = r.len(k);
        let out = out.get_mut(..len).ok_or(BandError::Malformed)?;
        let mut at = 0;
        for c in &centres[..bands.len()] {
            out[at..at + 4].copy_from_slice(&c.to_le_bytes());
            at += 4;
        }
        for (_, m) in &bands[1..] {
            for p in &m.params[..k] {
                out[at..at + 4].copy_from_slice(&p.to_le_bytes());
                at += 4;
            }
        }
        let mut material = *first;
        material.bands = Some(r);
        Ok((material, len))
    }

    /// Bands of this material: 0 unless it is banded.
    pub fn band_count(&self) -> usize {
        self.bands.map_or(0, |b| usize::from(b.count))
    }

    /// Band `i`'s centre (µm) over `blob`, the bytes this material was decoded from.
    pub fn band_centre(&self, blob: &[u8], i: usize) -> Option<f32> {
        let r = self.bands?;
        if i >= usize::from(r.count) {
            return None;
        }
        let at = usize::from(r.offset) + 4 * i;
        Some(f32::from_le_bytes(blob.get(at..at + 4)?.try_into().ok()?))
    }

    /// Band `i`'s parameters over `blob` (band 0's are [`Material::params`]).
    pub fn band_params(&self, blob: &[u8], i: usize) -> Option<[f32; MAX_PARAMS]> {
        let r = self.bands?;
        let m = usize::from(r.count);
        if i >= m {
            return None;
        }
        if i == 0 {
            return Some(self.params);
        }
        let k = self.kind.param_count();
        let start = usize::from(r.offset) + 4 * m + 4 * k * (i - 1);
        let bytes = blob.get(start..start + 4 * k)?;
        let mut p = [0.0f32; MAX_PARAMS];
        for (v, c) in p.iter_mut().zip(bytes.chunks_exact(4)) {
            *v = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        }
        Some(p)
    }

    /// Band `i`'s exact f32 model over `blob`.
    pub fn band_model(&self, blob: &[u8], i: usize) -> Option<AnyModel<f32>> {
        let p = self.band_params(blob, i)?;
        AnyModel::new(self.kind, &p[..self.kind.param_count()]).ok()
    }

    /// Which band, or which two, answer at `um` µm ([`brdf_core::bands::locate`] over the
    /// centres in `blob`); [`BandError::Malformed`] for a material without bands.
    pub fn locate(&self, blob: &[u8], um: f32) -> Result<Located<f32>, BandError> {
        let m = self.band_count();
        if m > MAX_BANDS {
            // Never from `Blob::decode`; a hand-built reference.
            return Err(BandError::Malformed);
        }
        let mut centres = [0.0f32; MAX_BANDS];
        for (i, c) in centres.iter_mut().enumerate().take(m) {
            *c = self.band_centre(blob, i).ok_or(BandError::Malformed)?;
        }
        if m == 0 {
            return Err(BandError::Malformed);
        }
        brdf_core::bands::locate(&centres[..m], um)
    }

    /// Gives this six-parameter material `nodes`-node tables: fills `out`
    /// ([`table_len`]`(nodes)` bytes) from its f32 parameters, the values a device verifies
    /// the nodes against, and records them in [`Material::table`]. Pass `out` with the
    /// material to [`Blob::encode_with_tables`].
    pub fn tabulate(&mut self, nodes: usize, out: &mut [u8]) -> Result<(), brdf_core::table::TableError> {
        let p = self
            .six_params()
            .ok_or(brdf_core::table::TableError::Model(self.kind))?;
        brdf_core::table::fill_six_table(&p.widen(), nodes, out)?;
        self.table = Some(TableRef {
            nodes: nodes as u16,
            offset: 0,
        });
        Ok(())
    }

    /// Gives this material (its model the base) the fitted table `bytes` ([`brdf_core::fitted`]),
    /// checked; pass the same bytes with the material to [`Blob::encode_with_tables`].
    pub fn with_fitted(mut self, bytes: &[u8]) -> Result<Material, brdf_core::fitted::FittedError> {
        // A blob holds at most MAX_BLOB_LEN bytes; a longer table could not travel in one.
        if bytes.len() > MAX_BLOB_LEN {
            return Err(brdf_core::fitted::FittedError::TooLarge(bytes.len()));
        }
        FittedTable::new(bytes)?;
        self.table = None;
        self.fitted = Some(FittedRef {
            len: bytes.len() as u16,
            offset: 0,
        });
        Ok(self)
    }

    /// Bytes this material takes in an encoded blob (model id, counts, parameters, tables,
    /// bands).
    pub fn encoded_len(&self) -> usize {
        4 + 4 * self.kind.param_count()
            + self.table.map_or(0, |t| t.len())
            + self.fitted.map_or(0, |f| usize::from(f.len))
            + self.bands.map_or(0, |b| b.len(self.kind.param_count()))
    }

    /// The fitted table over `blob` (the bytes this material was decoded from), if the
    /// material has one. O(1) after [`Blob::decode`] checked it.
    pub fn fitted_table<'b>(&self, blob: &'b [u8]) -> Option<FittedTable<'b>> {
        FittedTable::new(self.fitted?.bytes(blob)?).ok()
    }

    /// Validates and builds the exact f32 model.
    pub fn model(&self) -> Result<AnyModel<f32>, brdf_core::ParamError> {
        AnyModel::new(self.kind, &self.params[..self.kind.param_count()])
    }

    /// The six-parameter parameters, if this is a six-parameter material.
    pub fn six_params(&self) -> Option<SixParams<f32>> {
        let p = self.params;
        (self.kind == ModelKind::Six).then_some(SixParams::from_array([p[0], p[1], p[2], p[3], p[4], p[5]]))
    }

    /// The tabulated model over `blob` (the bytes this material was decoded from), if the
    /// material has tables. O(1): the nodes were verified by [`Blob::decode`].
    pub fn table<'b>(&self, blob: &'b [u8]) -> Option<SixTable<'b>> {
        let bytes = self.table?.bytes(blob)?;
        SixTable::new(self.six_params()?, bytes).ok()
    }
}

/// Why a blob was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum BlobError {
    /// Shorter than its header and CRC, or its length disagrees with its contents.
    Length,
    /// Not `BRDF`.
    Magic,
    /// A format version this reader does not know.
    Version(u16),
    /// Flags this reader does not know.
    Flags(u16),
    /// A non-zero reserved field.
    Reserved(u16),
    /// The CRC does not match.
    Crc,
    /// No material, or more than [`MAX_MATERIALS`].
    MaterialCount(u16),
    /// Unknown model id (material index, id).
    ModelId(u8, u8),
    /// Wrong parameter count for the model (material index).
    ParamCount(u8),
    /// Parameters the model rejects (material index).
    Params(u8),
    /// A table that is malformed, on a model without tables, in a version-1 blob, or not
    /// matching the material's parameters (material index).
    Table(u8),
    /// Bands that are none or too many, not ascending, in a blob older than version 4, or
    /// a band's parameters out of range (material index).
    Bands(u8),
    /// The output buffer is too small to encode into.
    BufferTooSmall,
}

impl core::fmt::Display for BlobError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BlobError::Length => write!(f, "blob length does not match its contents"),
            BlobError::Magic => write!(f, "not a BRDF parameter blob"),
            BlobError::Version(v) => write!(f, "unknown blob version {v}"),
            BlobError::Flags(x) => write!(f, "unknown blob flags {x:#06x}"),
            BlobError::Reserved(x) => write!(f, "reserved header field is {x:#06x}, not 0"),
            BlobError::Crc => write!(f, "blob CRC mismatch"),
            BlobError::MaterialCount(n) => write!(f, "material count {n} outside 1..={MAX_MATERIALS}"),
            BlobError::ModelId(i, id) => write!(f, "material {i}: unknown model id {id}"),
            BlobError::ParamCount(i) => write!(f, "material {i}: wrong parameter count"),
            BlobError::Params(i) => write!(f, "material {i}: parameters out of range"),
            BlobError::Table(i) => write!(f, "material {i}: table malformed or not matching its parameters"),
            BlobError::Bands(i) => write!(
                f,
                "material {i}: bands malformed (count, centres not ascending, or a band's parameters out of range)"
            ),
            BlobError::BufferTooSmall => write!(f, "output buffer too small"),
        }
    }
}

impl core::error::Error for BlobError {}

/// The firmware's log names the fault in a word or two (`CRC`, `version`, `table`); the
/// host prints the [`Display`](core::fmt::Display) sentence.
#[cfg(feature = "defmt")]
impl defmt::Format for BlobError {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            BlobError::Length => defmt::write!(f, "length"),
            BlobError::Magic => defmt::write!(f, "magic"),
            BlobError::Version(_) => defmt::write!(f, "version"),
            BlobError::Flags(_) => defmt::write!(f, "flags"),
            BlobError::Reserved(_) => defmt::write!(f, "reserved field"),
            BlobError::Crc => defmt::write!(f, "CRC"),
            BlobError::MaterialCount(_) => defmt::write!(f, "material count"),
            BlobError::ModelId(..) => defmt::write!(f, "model id"),
            BlobError::ParamCount(_) => defmt::write!(f, "parameter count"),
            BlobError::Params(_) => defmt::write!(f, "parameters"),
            BlobError::Table(_) => defmt::write!(f, "table"),
            BlobError::Bands(_) => defmt::write!(f, "bands"),
            BlobError::BufferTooSmall => defmt::write!(f, "buffer too small"),
        }
    }
}

/// A decoded, validated parameter blob.
#[derive(Clone, Debug, PartialEq)]
pub struct Blob {
    /// Sequence number.
    pub sequence: u32,
    /// The materials, indexed by material id.
    pub materials: heapless::Vec<Material, MAX_MATERIALS>,
}

impl Blob {
    /// Encoded length.
    pub fn encoded_len(&self) -> usize {
        encoded_len(&self.materials)
    }

    /// Writes a blob without tables into `out`; returns the length written.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, BlobError> {
        self.encode_with_tables(&[], out)
    }

    /// Writes the blob into `out`, with `tables[i]` the node bytes of material `i` wherever
    /// that material has a [`TableRef`], its fitted table's bytes where it has a
    /// [`FittedRef`], its band bytes ([`Material::banded`]) where it has a [`BandsRef`];
    /// returns the length written.
    pub fn encode_with_tables(&self, tables: &[Option<&[u8]>], out: &mut [u8]) -> Result<usize, BlobError> {
        let n = self.encoded_len();
        if out.len() < n {
            return Err(BlobError::BufferTooSmall);
        }
        if self.materials.is_empty() {
            return Err(BlobError::MaterialCount(0));
        }
        let version = if self.materials.iter().any(|m| m.bands.is_some()) {
            BLOB_VERSION
        } else if self.materials.iter().any(|m| m.fitted.is_some()) {
            BLOB_VERSION_WITHOUT_BANDS
        } else {
            BLOB_VERSION_WITHOUT_FITTED
        };
        out[0..4].copy_from_slice(&BLOB_MAGIC);
        out[4..6].copy_from_slice(&version.to_le_bytes());
        out[6..8].copy_from_slice(&0u16.to_le_bytes());
        out[8..12].copy_from_slice(&self.sequence.to_le_bytes());
        out[12..14].copy_from_slice(&(self.materials.len() as u16).to_le_bytes());
        out[14..16].copy_from_slice(&0u16.to_le_bytes());
        let mut at = HEADER_LEN;
        for (i, m) in self.materials.iter().enumerate() {
            let k = m.kind.param_count();
            let word = match (m.table, m.fitted, m.bands) {
                (Some(t), None, None) => t.nodes,
                (None, Some(_), None) => FITTED_WORD,
                (None, None, Some(b)) if (1..=MAX_BANDS).contains(&usize::from(b.count)) => {
                    BANDED_WORD + u16::from(b.count)
                }
                (None, None, Some(_)) => return Err(BlobError::Bands(i as u8)),
                (None, None, None) => 0,
                _ => return Err(BlobError::Table(i as u8)),
            };
            out[at] = model_id(m.kind);
            out[at + 1] = k as u8;
            out[at + 2..at + 4].copy_from_slice(&word.to_le_bytes());
            at += 4;
            for p in &m.params[..k] {
                out[at..at + 4].copy_from_slice(&p.to_le_bytes());
                at += 4;
            }
            let want = m
                .table
                .map(|t| t.len())
                .or(m.fitted.map(|f| usize::from(f.len)))
                .or(m.bands.map(|b| b.len(k)));
            if let Some(len) = want {
                match tables.get(i).copied().flatten() {
                    Some(bytes) if bytes.len() == len => {
                        if m.fitted.is_some() && FittedTable::new(bytes).is_err() {
                            return Err(BlobError::Table(i as u8));
                        }
                        if let Some(b) = m.bands {
                            check_bands(m, b.count, bytes).map_err(|_| BlobError::Bands(i as u8))?;
                        }
                        out[at..at + bytes.len()].copy_from_slice(bytes);
                        at += bytes.len();
                    }
                    _ => return Err(BlobError::Table(i as u8)),
                }
            }
        }
        let crc = crc32(&out[..at]);
        out[at..at + 4].copy_from_slice(&crc.to_le_bytes());
        Ok(at + 4)
    }

    /// Reads and validates a blob. Never panics, whatever the bytes.
    pub fn decode(bytes: &[u8]) -> Result<Blob, BlobError> {
        if bytes.len() < HEADER_LEN + 4 || bytes.len() > MAX_BLOB_LEN {
            return Err(BlobError::Length);
        }
        if bytes[0..4] != BLOB_MAGIC {
            return Err(BlobError::Magic);
        }
        let u16_at = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]);
        let version = u16_at(4);
        if !(1..=BLOB_VERSION).contains(&version) {
            return Err(BlobError::Version(version));
        }
        let flags = u16_at(6);
        if flags != 0 {
            return Err(BlobError::Flags(flags));
        }
        let reserved = u16_at(14);
        if reserved != 0 {
            return Err(BlobError::Reserved(reserved));
        }
        let body = bytes.len() - 4;
        let stored = u32::from_le_bytes([bytes[body], bytes[body + 1], bytes[body + 2], bytes[body + 3]]);
        if crc32(&bytes[..body]) != stored {
            return Err(BlobError::Crc);
        }
        let sequence = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        let count = u16_at(12);
        if count == 0 || usize::from(count) > MAX_MATERIALS {
            return Err(BlobError::MaterialCount(count));
        }
        let mut materials = heapless::Vec::new();
        let mut at = HEADER_LEN;
        for i in 0..count as u8 {
            if at + 4 > body {
                return Err(BlobError::Length);
            }
            let kind = kind_from_id(bytes[at]).ok_or(BlobError::ModelId(i, bytes[at]))?;
            let k = usize::from(bytes[at + 1]);
            if k != kind.param_count() {
                return Err(BlobError::ParamCount(i));
            }
            let nodes = u16_at(at + 2);
            at += 4;
            if at + 4 * k > body {
                return Err(BlobError::Length);
            }
            let mut params = [0.0f32; MAX_PARAMS];
            for (j, p) in params.iter_mut().enumerate().take(k) {
                let o = at + 4 * j;
                *p = f32::from_le_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
            }
            at += 4 * k;
            let mut m = Material {
                kind,
                params,
                table: None,
                fitted: None,
                bands: None,
            };
            m.model().map_err(|_| BlobError::Params(i))?;
            if nodes & !(MAX_BANDS as u16 * 2 - 1) == BANDED_WORD {
                let count = nodes - BANDED_WORD;
                if version < 4 || !(1..=MAX_BANDS).contains(&usize::from(count)) {
                    return Err(BlobError::Bands(i));
                }
                let r = BandsRef {
                    count: count as u8,
                    // at <= body < MAX_BLOB_LEN = 4096 was checked.
                    offset: at as u16,
                };
                let len = r.len(k);
                if at + len > body {
                    return Err(BlobError::Length);
                }
                check_bands(&m, r.count, &bytes[at..at + len]).map_err(|_| BlobError::Bands(i))?;
                m.bands = Some(r);
                at += len;
            } else if nodes == FITTED_WORD {
                if version < 3 || at + FITTED_HEADER_LEN > body {
                    return Err(if version < 3 {
                        BlobError::Table(i)
                    } else {
                        BlobError::Length
                    });
                }
                let shape = FittedShape {
                    theta_h: usize::from(bytes[at]),
                    theta_d: usize::from(bytes[at + 1]),
                    phi_d: usize::from(bytes[at + 2]),
                };
                if !shape.is_valid() {
                    return Err(BlobError::Table(i));
                }
                let len = shape.encoded_len();
                if at + len > body {
                    return Err(BlobError::Length);
                }
                FittedTable::new(&bytes[at..at + len]).map_err(|_| BlobError::Table(i))?;
                m.fitted = Some(FittedRef {
                    // at + len <= body < MAX_BLOB_LEN = 4096 was checked.
                    len: len as u16,
                    offset: at as u16,
                });
                at += len;
            } else if nodes != 0 {
                let n = usize::from(nodes);
                if version == 1 || kind != ModelKind::Six || !(MIN_TABLE_NODES..=MAX_TABLE_NODES).contains(&n)
                {
                    return Err(BlobError::Table(i));
                }
                let t = TableRef {
                    nodes,
                    // at < body <= MAX_BLOB_LEN = 4096 was checked above.
                    offset: at as u16,
                };
                if at + t.len() > body {
                    return Err(BlobError::Length);
                }
                m.table = Some(t);
                let table = m.table(bytes).ok_or(BlobError::Table(i))?;
                table.verify().map_err(|_| BlobError::Table(i))?;
                at += t.len();
            }
            // Capacity is MAX_MATERIALS and count <= MAX_MATERIALS was checked.
            materials.push(m).map_err(|_| BlobError::MaterialCount(count))?;
        }
        if at != body {
            return Err(BlobError::Length);
        }
        Ok(Blob { sequence, materials })
    }
}

/// Checks a banded material's band bytes (centres, then bands 1.. of `m`'s model).
fn check_bands(m: &Material, count: u8, bytes: &[u8]) -> Result<(), BandError> {
    let probe = Material {
        bands: Some(BandsRef { count, offset: 0 }),
        ..*m
    };
    let n = usize::from(count);
    if !(1..=MAX_BANDS).contains(&n) {
        return Err(BandError::Malformed);
    }
    let mut centres = [0.0f32; MAX_BANDS];
    for (i, c) in centres.iter_mut().enumerate().take(n) {
        *c = probe.band_centre(bytes, i).ok_or(BandError::Malformed)?;
    }
    if !brdf_core::bands::valid(&centres[..n]) {
        return Err(BandError::Malformed);
    }
    for i in 1..n {
        probe.band_model(bytes, i).ok_or(BandError::Malformed)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn khaki() -> Material {
        let mut params = [0.0; MAX_PARAMS];
        params.copy_from_slice(&table1_f32(0));
        Material {
            kind: ModelKind::Six,
            params,
            table: None,
            fitted: None,
            bands: None,
        }
    }

    fn blob() -> Blob {
        let mut materials = heapless::Vec::new();
        materials.push(khaki()).unwrap();
        let mut l = [0.0; MAX_PARAMS];
        l[0] = 0.5;
        materials
            .push(Material {
                kind: ModelKind::Lambert,
                params: l,
                table: None,
                fitted: None,
                bands: None,
            })
            .unwrap();
        Blob {
            sequence: 7,
            materials,
        }
    }

    #[test]
    fn round_trip_and_each_refusal() {
        let b = blob();
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = b.encode(&mut buf).unwrap();
        assert_eq!(n, b.encoded_len());
        assert_eq!(Blob::decode(&buf[..n]).unwrap(), b);
        let bad = |f: &dyn Fn(&mut [u8])| {
            let mut c = buf;
            f(&mut c[..n]);
            Blob::decode(&c[..n]).unwrap_err()
        };
        assert_eq!(bad(&|c| c[0] = b'X'), BlobError::Magic);
        assert_eq!(bad(&|c| c[4] = 5), BlobError::Version(5));
        assert_eq!(bad(&|c| c[20] ^= 1), BlobError::Crc);
        // A non-zero reserved field, even correctly signed, is refused.
        let mut c = buf;
        c[15] = 1;
        let crc = crc32(&c[..n - 4]);
        c[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Reserved(0x0100));
        assert_eq!(Blob::decode(&buf[..n - 1]).unwrap_err(), BlobError::Crc);
        assert_eq!(Blob::decode(&buf[..10]).unwrap_err(), BlobError::Length);
        // Re-sign a blob whose first parameter (kb) is negative: refused by the model.
        let mut c = buf;
        c[20..24].copy_from_slice(&(-1.0f32).to_le_bytes());
        let crc = crc32(&c[..n - 4]);
        c[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Params(0));
        let mut small = [0u8; 8];
        assert_eq!(b.encode(&mut small).unwrap_err(), BlobError::BufferTooSmall);
    }
}

#[cfg(test)]
mod table_tests {
    extern crate std;
    use super::*;
    use brdf_core::table::fill_six_table;
    use brdf_core::Brdf;

    const KHAKI: [f32; 6] = table1_f32(0);

    fn tabled(nodes: u16) -> (Blob, std::vec::Vec<u8>) {
        let six = SixParams::from_array(KHAKI).widen();
        let mut nodes_bytes = std::vec![0u8; table_len(usize::from(nodes))];
        fill_six_table(&six, usize::from(nodes), &mut nodes_bytes).unwrap();
        let mut b = table1_blob();
        b.materials[0].table = Some(TableRef { nodes, offset: 0 });
        (b, nodes_bytes)
    }

    #[test]
    fn tables_round_trip_and_bad_tables_are_refused() {
        let (b, t) = tabled(64);
        let mut buf = [0u8; MAX_BLOB_LEN];
        assert_eq!(b.encode(&mut buf).unwrap_err(), BlobError::Table(0));
        let n = b.encode_with_tables(&[Some(&t)], &mut buf).unwrap();
        assert_eq!(n, b.encoded_len());
        let d = Blob::decode(&buf[..n]).unwrap();
        let r = d.materials[0].table.unwrap();
        assert_eq!((r.nodes, r.offset), (64, 44));
        assert_eq!(r.bytes(&buf[..n]).unwrap(), &t[..]);
        let table = d.materials[0].table(&buf[..n]).unwrap();
        let exact = d.materials[0].model().unwrap().eval_cosines(0.8, 0.6, -0.5);
        let tab = table.eval_cosines(0.8, 0.6, -0.5);
        assert!(((tab - exact) / exact).abs() < 2e-2);
        assert!(d.materials[1].table(&buf[..n]).is_none());

        let resign = |c: &mut [u8]| {
            let crc = crc32(&c[..n - 4]);
            c[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        };
        // A node of the wrong material (c changed after the table was made).
        let mut c = buf;
        c[16 + 4 + 20..16 + 4 + 24].copy_from_slice(&0.5f32.to_le_bytes());
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Table(0));
        // A NaN node.
        let mut c = buf;
        c[44 + 8..44 + 12].copy_from_slice(&f32::NAN.to_le_bytes());
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Table(0));
        // A table on a version-1 blob.
        let mut c = buf;
        c[4] = 1;
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Table(0));
        // A node count that runs past the end.
        let mut c = buf;
        c[18..20].copy_from_slice(&300u16.to_le_bytes());
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Length);
        // One node: not a table.
        let mut c = buf;
        c[18..20].copy_from_slice(&1u16.to_le_bytes());
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Table(0));
        // The largest table that fits one slot.
        let (b, t) = tabled(256);
        let n = b.encode_with_tables(&[Some(&t)], &mut buf).unwrap();
        assert!(n <= MAX_BLOB_LEN);
        assert!(Blob::decode(&buf[..n]).is_ok());
    }
}

#[cfg(test)]
mod fitted_tests {
    extern crate std;
    use super::*;
    use brdf_core::fitted::{encode_fitted, Corrected, FittedShape};
    use brdf_core::Brdf;

    /// The largest shape `brdf select` writes (20 x 19 x 5) over its microfacet base
    /// (4 parameters: 4,094 bytes as a blob, 2 under a slot).
    const SHAPE: FittedShape = FittedShape {
        theta_h: 20,
        theta_d: 19,
        phi_d: 5,
    };

    fn ggx_with_table() -> (Blob, std::vec::Vec<u8>) {
        let cells = SHAPE.cells();
        let v: std::vec::Vec<f64> = (0..cells).map(|k| ((k % 37) as f64 - 18.0) / 9.0).collect();
        let cov: std::vec::Vec<bool> = (0..cells).map(|k| k % 5 != 0).collect();
        let mut t = std::vec![0u8; SHAPE.encoded_len()];
        encode_fitted(SHAPE, &v, &cov, &mut t).unwrap();
        let m = Material::from_params(ModelKind::Ggx, &[0.8, 0.2, 0.04, 0.3])
            .unwrap()
            .with_fitted(&t)
            .unwrap();
        let mut materials = heapless::Vec::new();
        materials.push(m).unwrap();
        (
            Blob {
                sequence: 3,
                materials,
            },
            t,
        )
    }

    #[test]
    fn a_fitted_table_round_trips_in_one_slot_and_is_checked() {
        let (b, t) = ggx_with_table();
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = b.encode_with_tables(&[Some(&t)], &mut buf).unwrap();
        assert_eq!(n, b.encoded_len());
        assert!(n <= MAX_BLOB_LEN, "{n}");
        assert_eq!(
            u16::from_le_bytes([buf[4], buf[5]]),
            3,
            "version 3 when a fitted table is present"
        );
        let d = Blob::decode(&buf[..n]).unwrap();
        let r = d.materials[0].fitted.unwrap();
        // Header 16, model id and counts 4, four parameters 16.
        assert_eq!((usize::from(r.len), r.offset), (t.len(), 36));
        let table = d.materials[0].fitted_table(&buf[..n]).unwrap();
        let m = Corrected {
            base: d.materials[0].model().unwrap(),
            table,
        };
        let base = d.materials[0].model().unwrap().eval_cosines(0.8, 0.6, -0.5);
        let f = m.eval_cosines(0.8, 0.6, -0.5);
        assert!(f.is_finite() && f != base, "{f} {base}");
        // Without its bytes, or with bytes that are not a table, nothing is written.
        assert_eq!(b.encode(&mut buf).unwrap_err(), BlobError::Table(0));
        let mut bad = t.clone();
        bad[3] = 1;
        assert_eq!(
            b.encode_with_tables(&[Some(&bad)], &mut buf).unwrap_err(),
            BlobError::Table(0)
        );
        let n = b.encode_with_tables(&[Some(&t)], &mut buf).unwrap();

        let resign = |c: &mut [u8]| {
            let crc = crate::crc32(&c[..n - 4]);
            c[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        };
        // A fitted table in a version-2 blob.
        let mut c = buf;
        c[4] = 2;
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Table(0));
        // A shape that runs past the end, a shape of one node, a reserved byte set.
        let at = usize::from(r.offset);
        let mut c = buf;
        c[at] = 21;
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Length);
        let mut c = buf;
        c[at + 1] = 1;
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Table(0));
        let mut c = buf;
        c[at + 3] = 1;
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Table(0));
        // A smaller shape leaves bytes over: the length no longer matches.
        let mut c = buf;
        c[at + 2] = 4;
        resign(&mut c);
        assert_eq!(Blob::decode(&c[..n]).unwrap_err(), BlobError::Length);
        // Both a lookup table and a fitted table: refused when encoding.
        let mut both = b.clone();
        both.materials[0].table = Some(TableRef { nodes: 16, offset: 0 });
        let mut big = std::vec![0u8; 2 * MAX_BLOB_LEN];
        assert_eq!(
            both.encode_with_tables(&[Some(&t)], &mut big).unwrap_err(),
            BlobError::Table(0)
        );
        // A blob without fitted tables is still written as version 2.
        let mut buf2 = [0u8; MAX_BLOB_LEN];
        let n2 = table1_blob().encode(&mut buf2).unwrap();
        assert_eq!(u16::from_le_bytes([buf2[4], buf2[5]]), 2);
        assert!(Blob::decode(&buf2[..n2]).is_ok());
    }
}

#[cfg(test)]
mod band_tests {
    extern crate std;
    use super::*;
    use brdf_core::Brdf;

    /// Three bands of the khaki plate with kd scaled per band.
    fn bands() -> std::vec::Vec<(f64, Material)> {
        let khaki = TABLE1[0].1;
        [(0.4, 0.2), (0.5, 0.5), (0.7, 0.9)]
            .into_iter()
            .map(|(um, kd)| {
                let mut p = khaki;
                p[4] = kd;
                (um, Material::from_params(ModelKind::Six, &p).unwrap())
            })
            .collect()
    }

    fn encoded() -> (std::vec::Vec<u8>, usize) {
        let mut extra = [0u8; 256];
        let (m, len) = Material::banded(&bands(), &mut extra).unwrap();
        let mut b = table1_blob();
        b.materials[1] = m;
        let mut buf = std::vec![0u8; MAX_BLOB_LEN];
        let n = b
            .encode_with_tables(&[None, Some(&extra[..len]), None], &mut buf)
            .unwrap();
        assert_eq!(n, b.encoded_len());
        buf.truncate(n);
        (buf, len)
    }

    #[test]
    fn a_banded_material_round_trips_and_answers_by_band() {
        let (buf, len) = encoded();
        // Three centres and two more bands of six parameters.
        assert_eq!(len, 4 * 3 + 2 * 24);
        assert_eq!(u16::from_le_bytes([buf[4], buf[5]]), BLOB_VERSION);
        let d = Blob::decode(&buf).unwrap();
        let m = d.materials[1];
        assert_eq!(m.band_count(), 3);
        assert_eq!(d.materials[0].band_count(), 0);
        assert_eq!(m.band_centre(&buf, 2), Some(0.7));
        assert_eq!(m.band_centre(&buf, 3), None);
        assert_eq!(m.band_params(&buf, 1).unwrap()[4], 0.5);
        assert_eq!(m.locate(&buf, 0.5), Ok(Located::Band(1)));
        let Ok(Located::Between { lower: 1, weight }) = m.locate(&buf, 0.65) else {
            panic!("{:?}", m.locate(&buf, 0.65))
        };
        assert!((weight - 0.75).abs() < 1e-6);
        assert_eq!(m.locate(&buf, 0.8), Err(BandError::Outside));
        assert_eq!(d.materials[0].locate(&buf, 0.5), Err(BandError::Malformed));
        // Band 2's model is the khaki plate with kd = 0.9.
        let f = m.band_model(&buf, 2).unwrap().eval_cosines(1.0, 1.0, 1.0);
        let mut p = table1_f32(0);
        p[4] = 0.9;
        let want = AnyModel::new(ModelKind::Six, &p)
            .unwrap()
            .eval_cosines(1.0, 1.0, 1.0);
        assert_eq!(f, want);
    }

    #[test]
    fn malformed_bands_are_refused() {
        let mut out = [0u8; MAX_BLOB_LEN];
        let b = bands();
        // None, not ascending, two centres within a picometre once in f32; one is a material
        // of one band.
        assert!(Material::banded(&[], &mut out).is_err());
        assert_eq!(Material::banded(&b[..1], &mut out).unwrap().0.band_count(), 1);
        let mut swapped = b.clone();
        swapped.swap(0, 1);
        assert!(Material::banded(&swapped, &mut out).is_err());
        let mut close = b.clone();
        close[1].0 = 0.4 + 1e-8;
        assert!(Material::banded(&close, &mut out).is_err());
        // Bands of two models, or a band with a table.
        let mut mixed = b.clone();
        mixed[2].1 = Material::from_params(ModelKind::Lambert, &[0.3]).unwrap();
        assert!(Material::banded(&mixed, &mut out).is_err());
        // Too many bands.
        let many: std::vec::Vec<(f64, Material)> =
            (0..=MAX_BANDS).map(|i| (0.4 + 0.01 * i as f64, b[0].1)).collect();
        assert!(Material::banded(&many, &mut out).is_err());
        assert!(Material::banded(&many[..MAX_BANDS], &mut out).is_ok());

        let (buf, _) = encoded();
        let n = buf.len();
        // Material 1 starts after the header and material 0 (4 + 24 bytes); its centres after
        // its own 4 + 24.
        let word = 16 + 28 + 2;
        let centres = 16 + 28 + 28;
        let resign = |c: &mut [u8]| {
            let crc = crc32(&c[..n - 4]);
            c[n - 4..n].copy_from_slice(&crc.to_le_bytes());
        };
        let refused = |f: &dyn Fn(&mut [u8])| {
            let mut c = buf.clone();
            f(&mut c);
            resign(&mut c);
            Blob::decode(&c).unwrap_err()
        };
        // Centres out of order, a NaN centre, a zero one.
        assert_eq!(
            refused(&|c| c[centres..centres + 4].copy_from_slice(&0.6f32.to_le_bytes())),
            BlobError::Bands(1)
        );
        assert_eq!(
            refused(&|c| c[centres + 4..centres + 8].copy_from_slice(&f32::NAN.to_le_bytes())),
            BlobError::Bands(1)
        );
        assert_eq!(
            refused(&|c| c[centres..centres + 4].copy_from_slice(&0.0f32.to_le_bytes())),
            BlobError::Bands(1)
        );
        // Band 2's kb negative.
        let band2 = centres + 12 + 24;
        assert_eq!(
            refused(&|c| c[band2..band2 + 4].copy_from_slice(&(-1.0f32).to_le_bytes())),
            BlobError::Bands(1)
        );
        // A band count of 0, of 65, or bands in a version-3 blob.
        assert_eq!(
            refused(&|c| c[word..word + 2].copy_from_slice(&BANDED_WORD.to_le_bytes())),
            BlobError::Bands(1)
        );
        assert_eq!(
            refused(&|c| c[word..word + 2].copy_from_slice(&(BANDED_WORD + 65).to_le_bytes())),
            BlobError::Bands(1)
        );
        assert_eq!(refused(&|c| c[4] = 3), BlobError::Bands(1));
        // More bands than the bytes hold (four would take material 2's bytes for bands).
        assert_eq!(
            refused(&|c| c[word..word + 2].copy_from_slice(&(BANDED_WORD + 5).to_le_bytes())),
            BlobError::Length
        );
        // Every truncation is refused, never a panic.
        for cut in 0..n {
            assert!(Blob::decode(&buf[..cut]).is_err());
        }
    }
}
