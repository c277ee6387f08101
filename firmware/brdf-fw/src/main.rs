//! BRDF query firmware: serves the frames of `brdf-wire` on a serial port.
//!
//! Boots from the newer valid of its two flash slots, falls back to the other, then to the
//! built-in default materials (the paper's Table 1: khaki, yellow, white), and logs which
//! with defmt. Then answers INFO, EVAL, EVAL_BATCH, LOAD (a blob into RAM), COMMIT (a blob
//! into the inactive flash slot, then active) and FIT (the on-sensor annealer; while it
//! runs, PROGRESS replies keep the host waiting and every other request is answered
//! `Busy`); every bad frame gets an ERROR reply and reading resumes at the next frame.
//! Nothing on the query path panics; a panic would end a QEMU run with exit code 1 (reset
//! on hardware).
#![no_std]
#![no_main]

use brdf_core::anneal::{anneal_kind, AnnealConfig, Samples, DEVICE_SEED};
use brdf_core::bands::{blend, Located};
use brdf_core::fitted::{Corrected, FittedConsts, FittedTable};
use brdf_core::table::{SixTable, TableConsts};
use brdf_core::{AnyModel, Brdf, Geometry, ModelKind};
use brdf_wire::blob::{blob_crc, table1_blob, Blob, FittedRef, TableRef, BLOB_VERSION, MAX_BLOB_LEN};
use brdf_wire::frame::{
    encode_response, parse_request, samples, ErrorCode, FrameReader, Input, Request, Response, MAX_BATCH,
    MAX_FIT_BUDGET, MAX_FIT_SAMPLES, MAX_FRAME, PROGRESS_SAMPLE_EVALS,
};
use brdf_wire::slots::{plan_commit, CommitError, SlotId, SlotPair, SlotState, SLOT_IMAGE_LEN};
use cortex_m_rt::entry;
use rand_core::SeedableRng;

use brdf_fw::exit;
use brdf_fw::flash::{write_slot, Flash};
use brdf_fw::port::Port;

/// Build id reported by INFO.
const BUILD_ID: u32 = 0x0001_0000;

/// The active blob (its bytes, since tables are read in place), its decoded materials,
/// their exact models and the CRC reported by INFO.
struct Active {
    bytes: [u8; MAX_BLOB_LEN],
    len: usize,
    blob: Blob,
    models: heapless::Vec<AnyModel<f32>, 8>,
    /// Per material with tables: where its nodes are and its precomputed constants.
    tables: heapless::Vec<Option<(TableRef, TableConsts)>, 8>,
    /// Per material with a fitted table: where it is and its header, read once.
    fitted: heapless::Vec<Option<(FittedRef, FittedConsts)>, 8>,
    crc: u32,
}

impl Active {
    /// Decodes and checks `src` (CRC, parameters, tables against their parameters).
    fn from_bytes(src: &[u8]) -> Option<Active> {
        Active::from_decoded(Blob::decode(src).ok()?, src)
    }

    /// `blob`, already decoded and checked from `src`, as the active set.
    fn from_decoded(blob: Blob, src: &[u8]) -> Option<Active> {
        let mut models = heapless::Vec::new();
        let mut tables = heapless::Vec::new();
        let mut fitted = heapless::Vec::new();
        for m in &blob.materials {
            let f = match m.fitted {
                Some(r) => Some((r, m.fitted_table(src)?.consts())),
                None => None,
            };
            fitted.push(f).ok()?;
            models.push(m.model().ok()?).ok()?;
            let t = match m.table {
                Some(r) => Some((r, m.table(src)?.consts())),
                None => None,
            };
            tables.push(t).ok()?;
        }
        let mut bytes = [0u8; MAX_BLOB_LEN];
        bytes.get_mut(..src.len())?.copy_from_slice(src);
        let crc = blob_crc(src);
        Some(Active {
            bytes,
            len: src.len(),
            blob,
            models,
            tables,
            fitted,
            crc,
        })
    }

    /// The built-in default: the paper's Table 1.
    fn default_materials() -> Option<Active> {
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = table1_blob().encode(&mut buf).ok()?;
        Active::from_bytes(&buf[..n])
    }

    /// What answers for material `id` at `wavelength`, resolved once per request: its lookup
    /// tables if it has them, its base model times its correction if it has a fitted table,
    /// its band at `wavelength` (or the two around it, blended) if it is banded, else the
    /// exact model. A material of several bands needs a wavelength (one of one band answers
    /// with it without); any other is the same at every wavelength. A wavelength outside the
    /// bands, or not finite and above 0, is refused, never clamped.
    fn resolve(&self, id: u8, wavelength: Option<f32>) -> Result<Answer<'_>, ErrorCode> {
        let i = usize::from(id);
        let (Some(model), Some(table), Some(fitted), Some(m)) = (
            self.models.get(i),
            self.tables.get(i),
            self.fitted.get(i),
            self.blob.materials.get(i),
        ) else {
            return Err(ErrorCode::UnknownMaterial);
        };
        let blob = &self.bytes[..self.len];
        // A wavelength, for any material, is a finite number above 0.
        if wavelength.is_some_and(|um| !(um.is_finite() && um > 0.0)) {
            return Err(ErrorCode::OutOfDomain);
        }
        if m.bands.is_some() {
            // Decoded and checked at LOAD: a band that does not build is not served.
            let band = |k: usize| m.band_model(blob, k).ok_or(ErrorCode::OutOfDomain);
            let um = match wavelength {
                Some(um) => um,
                // A material of one band answers with it, as the host's fit of one band.
                None if m.band_count() == 1 => return Ok(Answer::Exact(band(0)?)),
                None => return Err(ErrorCode::NeedsWavelength),
            };
            return match m.locate(blob, um).map_err(|_| ErrorCode::OutOfDomain)? {
                Located::Band(k) => Ok(Answer::Exact(band(k)?)),
                Located::Between { lower, weight } => {
                    Ok(Answer::Blend(band(lower)?, band(lower + 1)?, weight))
                }
            };
        }
        let table = table.and_then(|(r, c)| SixTable::from_parts(c, r.bytes(blob)?));
        let fitted = fitted.and_then(|(r, c)| FittedTable::from_parts(c, r.bytes(blob)?));
        Ok(match (table, fitted) {
            (Some(t), _) => Answer::Table(t),
            (None, Some(table)) => Answer::Fitted(Corrected { base: *model, table }),
            (None, None) => Answer::Exact(*model),
        })
    }
}

/// One material at one wavelength, ready to evaluate ([`Active::resolve`]).
enum Answer<'b> {
    /// The exact model (a material without tables, or one band).
    Exact(AnyModel<f32>),
    /// Lookup tables.
    Table(SixTable<'b>),
    /// A base model times its fitted table.
    Fitted(Corrected<'b, AnyModel<f32>>),
    /// Two bands and the upper one's weight.
    Blend(AnyModel<f32>, AnyModel<f32>, f32),
}

impl Answer<'_> {
    /// f_r at one input. Out-of-domain inputs are refused, never clamped.
    fn eval(&self, input: Input, x: [f32; 3]) -> Result<f32, ErrorCode> {
        let g = match input {
            Input::Angles => Geometry::try_from_angles(x[0], x[1], x[2]),
            Input::Cosines => Geometry::try_from_cosines(x[0], x[1], x[2]),
        }
        .map_err(|_| ErrorCode::OutOfDomain)?;
        let f = match self {
            Answer::Exact(m) => m.eval(&g),
            Answer::Table(t) => t.eval(&g),
            Answer::Fitted(c) => c.eval(&g),
            Answer::Blend(lower, upper, w) => blend(lower.eval(&g), upper.eval(&g), *w),
        };
        if f.is_finite() {
            Ok(f)
        } else {
            Err(ErrorCode::OutOfDomain)
        }
    }
}

/// A FIT request with its samples copied out of the frame buffer.
struct FitJob {
    model: ModelKind,
    budget: u32,
    samples: Samples<f32, MAX_FIT_SAMPLES>,
}

impl FitJob {
    /// Checks the budget and every sample (the annealer then checks that the samples hold
    /// one distinct direction per parameter, as the host's fit does).
    fn new(model: ModelKind, budget: u32, bytes: &[u8]) -> Result<FitJob, ErrorCode> {
        if budget > MAX_FIT_BUDGET {
            return Err(ErrorCode::FitFailed);
        }
        let mut s: Samples<f32, MAX_FIT_SAMPLES> = Samples::new();
        for [ti, tr, phi, y] in samples(bytes) {
            if s.push_angles(ti, tr, phi, y).is_err() {
                return Err(ErrorCode::FitFailed);
            }
        }
        Ok(FitJob {
            model,
            budget,
            samples: s,
        })
    }
}

/// Runs a FIT (request tag `tag`). After every evaluation it answers the requests that have
/// arrived meanwhile with `Busy` (bad frames with their error, as always), and after every
/// `PROGRESS_SAMPLE_EVALS` sample evaluations it sends PROGRESS with the FIT's tag.
fn run_fit<P: Port>(
    job: &FitJob,
    tag: u8,
    port: &mut P,
    reader: &mut FrameReader<MAX_FRAME>,
    out: &mut [u8],
) -> Response<'static> {
    let per_eval = (job.samples.len() as u32).max(1);
    let every = (PROGRESS_SAMPLE_EVALS / per_eval).max(1);
    let budget = job.budget;
    let progress = |done: u32| {
        while let Some(byte) = port.try_read() {
            let reply = match reader.push(byte) {
                None => continue,
                Some(Err(code)) => (Response::Error(code), 0),
                Some(Ok(())) => match parse_request(reader.payload()) {
                    Ok((t, _)) => (Response::Error(ErrorCode::Busy), t),
                    Err(code) => (Response::Error(code), 0),
                },
            };
            if let Ok(n) = encode_response(&reply.0, reply.1, out) {
                port.write_all(&out[..n]);
            }
        }
        if done.is_multiple_of(every) && done < budget {
            if let Ok(n) = encode_response(&Response::Progress { done, budget }, tag, out) {
                port.write_all(&out[..n]);
            }
        }
    };
    let cfg = AnnealConfig {
        budget,
        ..AnnealConfig::default()
    };
    let mut rng = rand_pcg::Pcg32::seed_from_u64(DEVICE_SEED);
    match anneal_kind(job.model, &job.samples, &cfg, &mut rng, progress) {
        Ok(o) => Response::Fitted {
            model: job.model,
            params: o.params,
            rms_rel: o.rms_rel,
            evals: o.evals,
        },
        Err(_) => Response::Error(ErrorCode::FitFailed),
    }
}

/// Handles one request other than FIT (see [`run_fit`]); the reply's variable part goes
/// into `values`.
fn handle<'v, F: Flash>(
    req: Request<'_>,
    active: &mut Active,
    flash: &mut F,
    values: &'v mut [u8; 4 * MAX_BATCH],
) -> Response<'v> {
    match req {
        Request::Info => Response::Info {
            build_id: BUILD_ID,
            format_version: BLOB_VERSION,
            active_crc: active.crc,
            materials: active.blob.materials.len() as u8,
        },
        Request::Eval { material, input, x } => {
            match active.resolve(material, None).and_then(|a| a.eval(input, x)) {
                Ok(f) => Response::Value(f),
                Err(e) => Response::Error(e),
            }
        }
        Request::EvalBatch {
            material,
            input,
            points,
        } => eval_batch(active, material, input, None, points, values),
        Request::EvalAt {
            material,
            input,
            wavelength,
            points,
        } => eval_batch(active, material, input, Some(wavelength), points, values),
        Request::Load(bytes) => match Active::from_bytes(bytes) {
            Some(a) => {
                *active = a;
                Response::Done(active.crc)
            }
            None => Response::Error(ErrorCode::InvalidBlob),
        },
        Request::Commit(bytes) => match commit(bytes, flash) {
            Ok(a) => {
                *active = a;
                Response::Done(active.crc)
            }
            Err(e) => Response::Error(e),
        },
        // `serve` runs FIT itself (it needs the port while fitting).
        Request::Fit { .. } => Response::Error(ErrorCode::Malformed),
    }
}

/// EVAL_BATCH and EVAL_AT: every point of `points` (at `wavelength`), the first refusal
/// ending the reply.
fn eval_batch<'v>(
    active: &Active,
    material: u8,
    input: Input,
    wavelength: Option<f32>,
    points: &[u8],
    values: &'v mut [u8; 4 * MAX_BATCH],
) -> Response<'v> {
    // The material at the wavelength once per request (a banded one's bands are found and
    // built here), then every point.
    let answer = match active.resolve(material, wavelength) {
        Ok(a) => a,
        Err(e) => return Response::Error(e),
    };
    let mut n = 0;
    for x in brdf_wire::frame::points(points) {
        match answer.eval(input, x) {
            Ok(f) => values[4 * n..4 * n + 4].copy_from_slice(&f.to_le_bytes()),
            Err(e) => return Response::Error(e),
        }
        n += 1;
    }
    Response::Values(&values[..4 * n])
}

/// Reads both slots, logs what each holds, and returns the newest valid one's contents.
fn boot<F: Flash>(flash: &F) -> Active {
    let slots = SlotPair::read(flash.slot(SlotId::A), flash.slot(SlotId::B));
    for (id, state) in [(SlotId::A, &slots.a), (SlotId::B, &slots.b)] {
        if matches!(state, SlotState::Empty | SlotState::Valid { .. }) {
            defmt::info!("boot: slot {} {}", id, state);
        } else {
            defmt::warn!("boot: slot {} {}", id, state);
        }
    }
    if let Some((id, bytes, blob)) = slots.into_active() {
        if let Some(a) = Active::from_decoded(blob, bytes) {
            defmt::info!(
                "boot: active slot {}, sequence {=u32}, {=usize} materials",
                id,
                a.blob.sequence,
                a.blob.materials.len()
            );
            return a;
        }
    }
    defmt::warn!("boot: no valid slot, built-in default (Table 1)");
    match Active::default_materials() {
        Some(a) => a,
        None => exit(false),
    }
}

/// COMMIT: checks the blob, writes it to the slot that is not the newest valid one
/// ([`plan_commit`]), and returns it as the new active set. The newest valid slot is never
/// touched.
fn commit<F: Flash>(bytes: &[u8], flash: &mut F) -> Result<Active, ErrorCode> {
    let mut image = [0u8; SLOT_IMAGE_LEN];
    let plan = match plan_commit(flash.slot(SlotId::A), flash.slot(SlotId::B), bytes, &mut image) {
        Ok(p) => p,
        Err(e @ CommitError::Stale { .. }) => {
            defmt::warn!("commit refused: {}", e);
            return Err(ErrorCode::StaleSequence);
        }
        Err(CommitError::Blob(_)) => return Err(ErrorCode::InvalidBlob),
    };
    let target = plan.target;
    let next = Active::from_decoded(plan.blob, bytes).ok_or(ErrorCode::InvalidBlob)?;
    match write_slot(flash, target, &image[..plan.image_len]) {
        Ok(()) => {
            defmt::info!(
                "commit: slot {}, sequence {=u32}, {=usize} bytes, CRC {=u32:#010x}",
                target,
                next.blob.sequence,
                bytes.len(),
                next.crc
            );
            Ok(next)
        }
        Err(e) => {
            defmt::error!("commit: writing slot {} failed: {}", target, e);
            Err(ErrorCode::FlashFailed)
        }
    }
}

fn serve<P: Port, F: Flash>(port: &mut P, flash: &mut F, mut active: Active) -> ! {
    let mut reader: FrameReader<MAX_FRAME> = FrameReader::new();
    let mut out = [0u8; 512];
    let mut values = [0u8; 4 * MAX_BATCH];
    loop {
        let byte = port.read();
        let reply = match reader.push(byte) {
            None => continue,
            Some(Err(code)) => encode_response(&Response::Error(code), 0, &mut out),
            Some(Ok(())) => match parse_request(reader.payload()) {
                Ok((
                    tag,
                    Request::Fit {
                        model,
                        budget,
                        samples,
                    },
                )) => {
                    let resp = match FitJob::new(model, budget, samples) {
                        Ok(job) => run_fit(&job, tag, port, &mut reader, &mut out),
                        Err(e) => Response::Error(e),
                    };
                    encode_response(&resp, tag, &mut out)
                }
                Ok((tag, req)) => {
                    let resp = handle(req, &mut active, flash, &mut values);
                    encode_response(&resp, tag, &mut out)
                }
                Err(code) => encode_response(&Response::Error(code), 0, &mut out),
            },
        };
        if let Ok(n) = reply {
            port.write_all(&out[..n]);
        }
    }
}

#[entry]
fn main() -> ! {
    let (mut port, mut flash) = brdf_fw::board();
    defmt::info!(
        "boot: brdf-fw build {=u32:#010x}, blob format {=u16}",
        BUILD_ID,
        BLOB_VERSION
    );
    let active = boot(&flash);
    serve(&mut port, &mut flash, active)
}
