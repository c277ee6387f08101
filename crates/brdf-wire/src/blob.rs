//! The parameter blob: the materials a device evaluates, as flashed or loaded.
//!
//! Little-endian layout, version 1:
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 4 | magic `BRDF` |
//! | 4 | 2 | format version (1) |
//! | 6 | 2 | flags (0; readers reject unknown flags) |
//! | 8 | 4 | sequence number (newer blobs have larger numbers) |
//! | 12 | 2 | material count (1 to [`MAX_MATERIALS`]) |
//! | 14 | 2 | reserved (0) |
//! | 16 | 4 + 4 n | per material: model id, parameter count n, 2 reserved bytes, n f32 parameters |
//! | end - 4 | 4 | CRC-32 (ISO-HDLC) of every byte before it |
//!
//! A reader rejects a wrong magic, a version or flag it does not know, any length mismatch, a
//! bad CRC, an unknown model id, a wrong parameter count and parameters outside the model's
//! valid ranges, each with its own [`BlobError`].

use brdf_core::{AnyModel, ModelKind, MAX_PARAMS};

use crate::crc32;

/// `BRDF`.
pub const BLOB_MAGIC: [u8; 4] = *b"BRDF";
/// The blob format version this crate reads and writes.
pub const BLOB_VERSION: u16 = 1;
/// Most materials in one blob.
pub const MAX_MATERIALS: usize = 8;
/// Largest encoded blob.
pub const MAX_BLOB_LEN: usize = HEADER_LEN + MAX_MATERIALS * (4 + 4 * MAX_PARAMS) + 4;

const HEADER_LEN: usize = 16;

/// Model id on the wire.
pub const fn model_id(kind: ModelKind) -> u8 {
    match kind {
        ModelKind::Six => 1,
        ModelKind::SixCos2 => 2,
        ModelKind::Five => 3,
        ModelKind::Minnaert => 4,
        ModelKind::Lambert => 5,
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
        _ => None,
    }
}

/// The paper's Table 1 (khaki, yellow, white painted plates) as a blob with sequence 0: the
/// firmware's built-in default materials, known to the host too.
pub fn table1_blob() -> Blob {
    const TABLE1: [[f32; 6]; 3] = [
        [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2],
        [0.1932, 11.8999, -39.5679, 0.8295, 0.3723, 0.0420],
        [49.3261, 0.1020, -35.4609, 0.6465, 0.6268, 0.2415],
    ];
    let mut materials = heapless::Vec::new();
    for params in TABLE1 {
        // Capacity MAX_MATERIALS = 8 > 3.
        let _ = materials.push(Material {
            kind: ModelKind::Six,
            params,
        });
    }
    Blob {
        sequence: 0,
        materials,
    }
}

/// One material: a model and its parameters (paper order, f32).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// The model.
    pub kind: ModelKind,
    /// Parameters; entries past the model's count are zero.
    pub params: [f32; MAX_PARAMS],
}

impl Material {
    /// Validates and builds the f32 model.
    pub fn model(&self) -> Result<AnyModel<f32>, brdf_core::ParamError> {
        AnyModel::new(self.kind, &self.params[..self.kind.param_count()])
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
            BlobError::Crc => write!(f, "blob CRC mismatch"),
            BlobError::MaterialCount(n) => write!(f, "material count {n} outside 1..={MAX_MATERIALS}"),
            BlobError::ModelId(i, id) => write!(f, "material {i}: unknown model id {id}"),
            BlobError::ParamCount(i) => write!(f, "material {i}: wrong parameter count"),
            BlobError::Params(i) => write!(f, "material {i}: parameters out of range"),
            BlobError::BufferTooSmall => write!(f, "output buffer too small"),
        }
    }
}

impl core::error::Error for BlobError {}

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
        HEADER_LEN
            + self
                .materials
                .iter()
                .map(|m| 4 + 4 * m.kind.param_count())
                .sum::<usize>()
            + 4
    }

    /// Writes the blob into `out`; returns the length written.
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, BlobError> {
        let n = self.encoded_len();
        if out.len() < n {
            return Err(BlobError::BufferTooSmall);
        }
        if self.materials.is_empty() {
            return Err(BlobError::MaterialCount(0));
        }
        out[0..4].copy_from_slice(&BLOB_MAGIC);
        out[4..6].copy_from_slice(&BLOB_VERSION.to_le_bytes());
        out[6..8].copy_from_slice(&0u16.to_le_bytes());
        out[8..12].copy_from_slice(&self.sequence.to_le_bytes());
        out[12..14].copy_from_slice(&(self.materials.len() as u16).to_le_bytes());
        out[14..16].copy_from_slice(&0u16.to_le_bytes());
        let mut at = HEADER_LEN;
        for m in &self.materials {
            let k = m.kind.param_count();
            out[at] = model_id(m.kind);
            out[at + 1] = k as u8;
            out[at + 2] = 0;
            out[at + 3] = 0;
            at += 4;
            for p in &m.params[..k] {
                out[at..at + 4].copy_from_slice(&p.to_le_bytes());
                at += 4;
            }
        }
        let crc = crc32(&out[..at]);
        out[at..at + 4].copy_from_slice(&crc.to_le_bytes());
        Ok(at + 4)
    }

    /// Reads and validates a blob. Never panics, whatever the bytes.
    pub fn decode(bytes: &[u8]) -> Result<Blob, BlobError> {
        if bytes.len() < HEADER_LEN + 4 {
            return Err(BlobError::Length);
        }
        if bytes[0..4] != BLOB_MAGIC {
            return Err(BlobError::Magic);
        }
        let u16_at = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]);
        let version = u16_at(4);
        if version != BLOB_VERSION {
            return Err(BlobError::Version(version));
        }
        let flags = u16_at(6);
        if flags != 0 {
            return Err(BlobError::Flags(flags));
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
            let m = Material { kind, params };
            m.model().map_err(|_| BlobError::Params(i))?;
            // Capacity is MAX_MATERIALS and count <= MAX_MATERIALS was checked.
            materials.push(m).map_err(|_| BlobError::MaterialCount(count))?;
        }
        if at != body {
            return Err(BlobError::Length);
        }
        Ok(Blob { sequence, materials })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn khaki() -> Material {
        let mut params = [0.0; MAX_PARAMS];
        params.copy_from_slice(&[0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2]);
        Material {
            kind: ModelKind::Six,
            params,
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
        assert_eq!(bad(&|c| c[4] = 2), BlobError::Version(2));
        assert_eq!(bad(&|c| c[20] ^= 1), BlobError::Crc);
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
