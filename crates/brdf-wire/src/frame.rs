//! Query frames over a byte stream.
//!
//! A frame is `COBS(payload ++ CRC-32(payload)) ++ 0x00`, where the payload is
//! `[format version (1), kind, tag, body...]` in little-endian. COBS leaves no 0 byte inside
//! a frame, so a reader that meets garbage resynchronises at the next 0; the CRC rejects
//! corrupted frames; the tag is echoed in the reply so a host can pair them.
//!
//! | kind | request | body |
//! |---|---|---|
//! | 0x01 | INFO | — |
//! | 0x02 | EVAL | material u8, input u8 (0 angles in rad, 1 cosines), 3 × f32 |
//! | 0x03 | EVAL_BATCH | material u8, input u8, count u16, count × 3 × f32 (count ≤ [`MAX_BATCH`]) |
//! | 0x04 | LOAD | a parameter blob, into RAM |
//! | 0x05 | COMMIT | a parameter blob, into the inactive flash slot |
//! | 0x06 | FIT | model id u8, budget u32, count u16, count × (theta_i, theta_r, phi, brdf) f32 |
//! | 0x07 | EVAL_AT | material u8, input u8, wavelength f32 (µm), count u16, count × 3 × f32 (count ≤ [`MAX_BATCH`]) |
//!
//! | kind | reply | body |
//! |---|---|---|
//! | 0x81 | INFO | build id u32, blob format version u16, CRC of the active blob u32, materials u8 |
//! | 0x82 | VALUE | f32 |
//! | 0x83 | VALUES | count u16, count × f32 |
//! | 0x84 | DONE | CRC of the now active blob u32 |
//! | 0x86 | FITTED | model id u8, 6 × f32 parameters, RMS relative error f32, evaluations u32 |
//! | 0x87 | PROGRESS | evaluations done u32, budget u32 (sent during a FIT, with its tag) |
//! | 0xEE | ERROR | [`ErrorCode`] u8 |
//!
//! A FIT can take minutes on a device. While it runs, the device sends a PROGRESS reply with
//! the FIT's tag at least every [`PROGRESS_SAMPLE_EVALS`] sample evaluations (so a host's
//! silence timeout never expires during a fit it is waiting for) and answers every other
//! request with ERROR `Busy`; the FITTED reply ends it.
//!
//! EVAL_AT is EVAL_BATCH at a wavelength, answered with VALUES: a banded material
//! (`brdf_wire::blob`, version 4) answers by its band there, or the two bands around it
//! blended ([`brdf_core::bands`]); outside its bands with `OutOfDomain`. A material without
//! bands is the same at every wavelength. A wavelength that is not finite and above 0 is
//! refused with `OutOfDomain` for any material. EVAL and EVAL_BATCH of a material of several
//! bands are refused with `NeedsWavelength` (one of one band answers with it).

use brdf_core::{ModelKind, MAX_PARAMS};

use crate::blob::{kind_from_id, model_id};
use crate::crc32;

/// The frame format version this crate reads and writes.
pub const FRAME_VERSION: u8 = 1;
/// Most points in one EVAL_BATCH request or VALUES reply.
pub const MAX_BATCH: usize = 64;
/// Most samples in one FIT request.
pub const MAX_FIT_SAMPLES: usize = 256;
/// Largest evaluation budget of one FIT: 256 samples at this budget take about 2.5 minutes
/// under QEMU and 5 on a 168 MHz Cortex-M4F.
pub const MAX_FIT_BUDGET: u32 = 100_000;
/// A device busy with a FIT sends PROGRESS after at most this many sample evaluations
/// (annealer evaluations times samples): about 0.75 s under QEMU, 1.5 s on a 168 MHz
/// Cortex-M4F for the six-parameter model.
pub const PROGRESS_SAMPLE_EVALS: u32 = 1 << 17;
/// Largest payload (FIT with [`MAX_FIT_SAMPLES`] samples), without the CRC.
pub const MAX_PAYLOAD: usize = 3 + 1 + 4 + 2 + 16 * MAX_FIT_SAMPLES;
// A LOAD or COMMIT frame carries the largest blob.
const _: () = assert!(3 + crate::blob::MAX_BLOB_LEN <= MAX_PAYLOAD);
/// Largest encoded frame including the 0 delimiter.
pub const MAX_FRAME: usize = cobs::max_encoding_length(MAX_PAYLOAD + 4) + 1;

/// Error codes carried by ERROR replies (and returned by the reader).
/// With the `defmt` feature it logs as its name, as [`ErrorCode::name`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum ErrorCode {
    /// The frame's CRC does not match (or its COBS encoding is broken).
    BadCrc = 1,
    /// A frame format version this side does not know.
    UnknownVersion = 2,
    /// No material with that id.
    UnknownMaterial = 3,
    /// An angle or cosine outside its domain, or a non-finite input.
    OutOfDomain = 4,
    /// The frame exceeded the receive buffer before its delimiter.
    FrameTooLarge = 5,
    /// The device is busy (e.g. writing flash).
    Busy = 6,
    /// The body does not match its kind (lengths, counts).
    Malformed = 7,
    /// Unknown request or reply kind.
    UnknownKind = 8,
    /// A LOAD or COMMIT blob was refused.
    InvalidBlob = 9,
    /// The on-sensor fit could not run (no valid samples, unknown model, ...).
    FitFailed = 10,
    /// A COMMIT blob whose sequence number is not above the active one's (after a restart
    /// the older blob would win).
    StaleSequence = 11,
    /// Writing or verifying a flash slot failed; the active parameters are unchanged.
    FlashFailed = 12,
    /// EVAL or EVAL_BATCH of a material of several bands: it answers only at a wavelength
    /// (EVAL_AT).
    NeedsWavelength = 13,
}

impl ErrorCode {
    /// From the wire byte.
    pub fn from_u8(b: u8) -> Option<ErrorCode> {
        use ErrorCode::*;
        [
            BadCrc,
            UnknownVersion,
            UnknownMaterial,
            OutOfDomain,
            FrameTooLarge,
            Busy,
            Malformed,
            UnknownKind,
            InvalidBlob,
            FitFailed,
            StaleSequence,
            FlashFailed,
            NeedsWavelength,
        ]
        .into_iter()
        .find(|c| *c as u8 == b)
    }
}

/// The code's name as the host prints it (`OutOfDomain`, `StaleSequence`, ...): a stable
/// identifier to search the documentation of [`ErrorCode`] for.
impl core::fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

impl ErrorCode {
    /// The code's name (`"OutOfDomain"`, ...), as [`Display`](core::fmt::Display) and the
    /// firmware's log print it.
    pub const fn name(self) -> &'static str {
        match self {
            ErrorCode::BadCrc => "BadCrc",
            ErrorCode::UnknownVersion => "UnknownVersion",
            ErrorCode::UnknownMaterial => "UnknownMaterial",
            ErrorCode::OutOfDomain => "OutOfDomain",
            ErrorCode::FrameTooLarge => "FrameTooLarge",
            ErrorCode::Busy => "Busy",
            ErrorCode::Malformed => "Malformed",
            ErrorCode::UnknownKind => "UnknownKind",
            ErrorCode::InvalidBlob => "InvalidBlob",
            ErrorCode::FitFailed => "FitFailed",
            ErrorCode::StaleSequence => "StaleSequence",
            ErrorCode::FlashFailed => "FlashFailed",
            ErrorCode::NeedsWavelength => "NeedsWavelength",
        }
    }
}

/// What the three numbers of an EVAL are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// `theta_i`, `theta_r`, `phi` in radians.
    Angles = 0,
    /// `cos theta_i`, `cos theta_r`, `cos phi`.
    Cosines = 1,
}

/// A request, borrowing variable-length bodies from the frame buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Request<'a> {
    /// Build id, format version, CRC of the active parameters.
    Info,
    /// One evaluation.
    Eval {
        /// Material id (index into the active blob).
        material: u8,
        /// Angles or cosines.
        input: Input,
        /// The three inputs.
        x: [f32; 3],
    },
    /// Up to [`MAX_BATCH`] evaluations.
    EvalBatch {
        /// Material id.
        material: u8,
        /// Angles or cosines.
        input: Input,
        /// `count * 12` bytes of little-endian f32 triples; see [`points`].
        points: &'a [u8],
    },
    /// Up to [`MAX_BATCH`] evaluations at a wavelength.
    EvalAt {
        /// Material id.
        material: u8,
        /// Angles or cosines.
        input: Input,
        /// Wavelength in µm.
        wavelength: f32,
        /// `count * 12` bytes of little-endian f32 triples; see [`points`].
        points: &'a [u8],
    },
    /// Load a blob into RAM.
    Load(&'a [u8]),
    /// Write a blob to the inactive flash slot, then activate it.
    Commit(&'a [u8]),
    /// Refit on the device.
    Fit {
        /// Model to fit.
        model: ModelKind,
        /// Evaluation budget.
        budget: u32,
        /// `count * 16` bytes of (theta_i, theta_r, phi, brdf); see [`samples`].
        samples: &'a [u8],
    },
}

/// A reply.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Response<'a> {
    /// Reply to INFO.
    Info {
        /// Firmware build id.
        build_id: u32,
        /// Blob format version the firmware reads.
        format_version: u16,
        /// CRC of the active blob.
        active_crc: u32,
        /// Materials in the active blob.
        materials: u8,
    },
    /// Reply to EVAL: `f_r` in 1/sr.
    Value(f32),
    /// Reply to EVAL_BATCH: `count * 4` bytes of f32; see [`values`].
    Values(&'a [u8]),
    /// Reply to LOAD and COMMIT: CRC of the now active blob.
    Done(u32),
    /// Reply to FIT.
    Fitted {
        /// The model fitted.
        model: ModelKind,
        /// Parameters (paper order; unused entries zero).
        params: [f32; MAX_PARAMS],
        /// RMS relative error over the samples.
        rms_rel: f32,
        /// Evaluations used.
        evals: u32,
    },
    /// A FIT is still running.
    Progress {
        /// Evaluations done so far.
        done: u32,
        /// The FIT's budget.
        budget: u32,
    },
    /// Refusal.
    Error(ErrorCode),
}

/// Little-endian f32 triples of an EVAL_BATCH body.
pub fn points(bytes: &[u8]) -> impl Iterator<Item = [f32; 3]> + '_ {
    bytes
        .chunks_exact(12)
        .map(|c| [f32_at(c, 0), f32_at(c, 4), f32_at(c, 8)])
}

/// Little-endian (theta_i, theta_r, phi, brdf) quadruples of a FIT body.
pub fn samples(bytes: &[u8]) -> impl Iterator<Item = [f32; 4]> + '_ {
    bytes
        .chunks_exact(16)
        .map(|c| [f32_at(c, 0), f32_at(c, 4), f32_at(c, 8), f32_at(c, 12)])
}

/// Little-endian f32 values of a VALUES body.
pub fn values(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes.chunks_exact(4).map(|c| f32_at(c, 0))
}

fn f32_at(b: &[u8], i: usize) -> f32 {
    f32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

fn u16_at(b: &[u8], i: usize) -> u16 {
    u16::from_le_bytes([b[i], b[i + 1]])
}

fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

/// Builds payloads in a fixed buffer.
struct Writer<'a> {
    buf: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) -> Result<(), ErrorCode> {
        let end = self.at + bytes.len();
        if end > self.buf.len() {
            return Err(ErrorCode::FrameTooLarge);
        }
        self.buf[self.at..end].copy_from_slice(bytes);
        self.at = end;
        Ok(())
    }
}

/// Writes `payload ++ CRC` COBS-encoded and 0-terminated into `out`; returns its length.
/// Encodes in a stream, without a copy of the payload.
fn seal(payload: &[u8], out: &mut [u8]) -> Result<usize, ErrorCode> {
    if payload.len() > MAX_PAYLOAD || out.is_empty() {
        return Err(ErrorCode::FrameTooLarge);
    }
    let last = out.len() - 1;
    let mut enc = cobs::CobsEncoder::new(&mut out[..last]);
    enc.push(payload).map_err(|_| ErrorCode::FrameTooLarge)?;
    enc.push(&crc32(payload).to_le_bytes())
        .map_err(|_| ErrorCode::FrameTooLarge)?;
    let n = enc.finalize();
    out[n] = 0;
    Ok(n + 1)
}

/// Encodes a request with `tag` into `out` (at least [`MAX_FRAME`] bytes for any request).
pub fn encode_request(req: &Request<'_>, tag: u8, out: &mut [u8]) -> Result<usize, ErrorCode> {
    let mut p = [0u8; MAX_PAYLOAD];
    let mut w = Writer { buf: &mut p, at: 0 };
    let kind = match req {
        Request::Info => 0x01,
        Request::Eval { .. } => 0x02,
        Request::EvalBatch { .. } => 0x03,
        Request::Load(_) => 0x04,
        Request::Commit(_) => 0x05,
        Request::Fit { .. } => 0x06,
        Request::EvalAt { .. } => 0x07,
    };
    w.put(&[FRAME_VERSION, kind, tag])?;
    match req {
        Request::Info => {}
        Request::Eval { material, input, x } => {
            w.put(&[*material, *input as u8])?;
            for v in x {
                w.put(&v.to_le_bytes())?;
            }
        }
        Request::EvalBatch {
            material,
            input,
            points,
        } => {
            if points.len() % 12 != 0 || points.len() / 12 > MAX_BATCH {
                return Err(ErrorCode::Malformed);
            }
            w.put(&[*material, *input as u8])?;
            w.put(&((points.len() / 12) as u16).to_le_bytes())?;
            w.put(points)?;
        }
        Request::EvalAt {
            material,
            input,
            wavelength,
            points,
        } => {
            if points.len() % 12 != 0 || points.len() / 12 > MAX_BATCH {
                return Err(ErrorCode::Malformed);
            }
            w.put(&[*material, *input as u8])?;
            w.put(&wavelength.to_le_bytes())?;
            w.put(&((points.len() / 12) as u16).to_le_bytes())?;
            w.put(points)?;
        }
        Request::Load(blob) | Request::Commit(blob) => w.put(blob)?,
        Request::Fit {
            model,
            budget,
            samples,
        } => {
            if samples.len() % 16 != 0 || samples.len() / 16 > MAX_FIT_SAMPLES {
                return Err(ErrorCode::Malformed);
            }
            w.put(&[model_id(*model)])?;
            w.put(&budget.to_le_bytes())?;
            w.put(&((samples.len() / 16) as u16).to_le_bytes())?;
            w.put(samples)?;
        }
    }
    let n = w.at;
    seal(&p[..n], out)
}

/// Encodes a reply with `tag` into `out`.
pub fn encode_response(resp: &Response<'_>, tag: u8, out: &mut [u8]) -> Result<usize, ErrorCode> {
    let mut p = [0u8; 3 + 2 + 4 * MAX_BATCH + 32];
    let mut w = Writer { buf: &mut p, at: 0 };
    let kind = match resp {
        Response::Info { .. } => 0x81,
        Response::Value(_) => 0x82,
        Response::Values(_) => 0x83,
        Response::Done(_) => 0x84,
        Response::Fitted { .. } => 0x86,
        Response::Progress { .. } => 0x87,
        Response::Error(_) => 0xEE,
    };
    w.put(&[FRAME_VERSION, kind, tag])?;
    match resp {
        Response::Info {
            build_id,
            format_version,
            active_crc,
            materials,
        } => {
            w.put(&build_id.to_le_bytes())?;
            w.put(&format_version.to_le_bytes())?;
            w.put(&active_crc.to_le_bytes())?;
            w.put(&[*materials])?;
        }
        Response::Value(v) => w.put(&v.to_le_bytes())?,
        Response::Values(v) => {
            if v.len() % 4 != 0 || v.len() / 4 > MAX_BATCH {
                return Err(ErrorCode::Malformed);
            }
            w.put(&((v.len() / 4) as u16).to_le_bytes())?;
            w.put(v)?;
        }
        Response::Done(crc) => w.put(&crc.to_le_bytes())?,
        Response::Fitted {
            model,
            params,
            rms_rel,
            evals,
        } => {
            w.put(&[model_id(*model)])?;
            for v in params {
                w.put(&v.to_le_bytes())?;
            }
            w.put(&rms_rel.to_le_bytes())?;
            w.put(&evals.to_le_bytes())?;
        }
        Response::Progress { done, budget } => {
            w.put(&done.to_le_bytes())?;
            w.put(&budget.to_le_bytes())?;
        }
        Response::Error(code) => w.put(&[*code as u8])?,
    }
    let n = w.at;
    seal(&p[..n], out)
}

/// Parses a checked payload (from [`FrameReader`]) as a request: `(tag, request)`.
pub fn parse_request(payload: &[u8]) -> Result<(u8, Request<'_>), ErrorCode> {
    let (kind, tag, body) = split(payload)?;
    let req = match kind {
        0x01 if body.is_empty() => Request::Info,
        0x02 if body.len() == 14 => Request::Eval {
            material: body[0],
            input: input(body[1])?,
            x: [f32_at(body, 2), f32_at(body, 6), f32_at(body, 10)],
        },
        0x03 if body.len() >= 4 => {
            let n = usize::from(u16_at(body, 2));
            if n > MAX_BATCH || body.len() != 4 + 12 * n {
                return Err(ErrorCode::Malformed);
            }
            Request::EvalBatch {
                material: body[0],
                input: input(body[1])?,
                points: &body[4..],
            }
        }
        0x04 => Request::Load(body),
        0x05 => Request::Commit(body),
        0x06 if body.len() >= 7 => {
            let model = kind_from_id(body[0]).ok_or(ErrorCode::Malformed)?;
            let n = usize::from(u16_at(body, 5));
            if n > MAX_FIT_SAMPLES || body.len() != 7 + 16 * n {
                return Err(ErrorCode::Malformed);
            }
            Request::Fit {
                model,
                budget: u32_at(body, 1),
                samples: &body[7..],
            }
        }
        0x07 if body.len() >= 8 => {
            let n = usize::from(u16_at(body, 6));
            if n > MAX_BATCH || body.len() != 8 + 12 * n {
                return Err(ErrorCode::Malformed);
            }
            Request::EvalAt {
                material: body[0],
                input: input(body[1])?,
                wavelength: f32_at(body, 2),
                points: &body[8..],
            }
        }
        0x01..=0x07 => return Err(ErrorCode::Malformed),
        _ => return Err(ErrorCode::UnknownKind),
    };
    Ok((tag, req))
}

/// Parses a checked payload as a reply: `(tag, reply)`.
pub fn parse_response(payload: &[u8]) -> Result<(u8, Response<'_>), ErrorCode> {
    let (kind, tag, body) = split(payload)?;
    let resp = match kind {
        0x81 if body.len() == 11 => Response::Info {
            build_id: u32_at(body, 0),
            format_version: u16_at(body, 4),
            active_crc: u32_at(body, 6),
            materials: body[10],
        },
        0x82 if body.len() == 4 => Response::Value(f32_at(body, 0)),
        0x83 if body.len() >= 2 => {
            let n = usize::from(u16_at(body, 0));
            if n > MAX_BATCH || body.len() != 2 + 4 * n {
                return Err(ErrorCode::Malformed);
            }
            Response::Values(&body[2..])
        }
        0x84 if body.len() == 4 => Response::Done(u32_at(body, 0)),
        0x86 if body.len() == 1 + 4 * MAX_PARAMS + 8 => {
            let model = kind_from_id(body[0]).ok_or(ErrorCode::Malformed)?;
            let mut params = [0.0f32; MAX_PARAMS];
            for (j, p) in params.iter_mut().enumerate() {
                *p = f32_at(body, 1 + 4 * j);
            }
            Response::Fitted {
                model,
                params,
                rms_rel: f32_at(body, 1 + 4 * MAX_PARAMS),
                evals: u32_at(body, 5 + 4 * MAX_PARAMS),
            }
        }
        0x87 if body.len() == 8 => Response::Progress {
            done: u32_at(body, 0),
            budget: u32_at(body, 4),
        },
        0xEE if body.len() == 1 => Response::Error(ErrorCode::from_u8(body[0]).ok_or(ErrorCode::Malformed)?),
        0x81..=0x87 | 0xEE => return Err(ErrorCode::Malformed),
        _ => return Err(ErrorCode::UnknownKind),
    };
    Ok((tag, resp))
}

fn split(payload: &[u8]) -> Result<(u8, u8, &[u8]), ErrorCode> {
    if payload.len() < 3 {
        return Err(ErrorCode::Malformed);
    }
    if payload[0] != FRAME_VERSION {
        return Err(ErrorCode::UnknownVersion);
    }
    Ok((payload[1], payload[2], &payload[3..]))
}

fn input(b: u8) -> Result<Input, ErrorCode> {
    match b {
        0 => Ok(Input::Angles),
        1 => Ok(Input::Cosines),
        _ => Err(ErrorCode::Malformed),
    }
}

/// Reassembles frames from a byte stream in a fixed buffer of `N` bytes, checking COBS and
/// CRC. Feed it bytes one at a time; constant work per byte, no panic on any input.
#[derive(Debug)]
pub struct FrameReader<const N: usize> {
    buf: [u8; N],
    len: usize,
    frame_len: usize,
    overflow: bool,
}

impl<const N: usize> Default for FrameReader<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameReader<N> {
    /// An empty reader.
    pub const fn new() -> Self {
        FrameReader {
            buf: [0; N],
            len: 0,
            frame_len: 0,
            overflow: false,
        }
    }

    /// Feeds one byte. At a frame delimiter returns `Some(Ok(()))` when a frame with a good
    /// CRC is ready in [`FrameReader::payload`], `Some(Err(code))` for a bad one (which is
    /// dropped; reading resumes with the next byte), and `None` otherwise.
    pub fn push(&mut self, byte: u8) -> Option<Result<(), ErrorCode>> {
        if byte != 0 {
            if self.len < N {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let (len, overflow) = (self.len, self.overflow);
        self.len = 0;
        self.overflow = false;
        self.frame_len = 0;
        if overflow {
            return Some(Err(ErrorCode::FrameTooLarge));
        }
        if len == 0 {
            return None;
        }
        let n = match cobs::decode_in_place(&mut self.buf[..len]) {
            Ok(n) if n >= 4 && n <= len => n,
            _ => return Some(Err(ErrorCode::BadCrc)),
        };
        let body = n - 4;
        let stored = u32_at(&self.buf, body);
        if crc32(&self.buf[..body]) != stored {
            return Some(Err(ErrorCode::BadCrc));
        }
        self.frame_len = body;
        Some(Ok(()))
    }

    /// The payload of the last good frame (empty if none since the last delimiter).
    pub fn payload(&self) -> &[u8] {
        &self.buf[..self.frame_len]
    }
}
