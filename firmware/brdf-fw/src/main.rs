//! BRDF query firmware: serves the frames of `brdf-wire` on a UART.
//!
//! Boots with the built-in default materials (the paper's Table 1: khaki, yellow, white),
//! then answers INFO, EVAL, EVAL_BATCH, LOAD (a blob into RAM) and FIT (the on-sensor
//! annealer); every bad frame gets an ERROR reply and reading resumes at the next frame.
//! COMMIT (flash slots) is not implemented yet and is answered with `UnknownKind`.
//! Nothing on the query path panics; a panic would end a QEMU run with exit code 1.
#![no_std]
#![no_main]

use brdf_core::anneal::{anneal, AnnealConfig, Samples, SearchBox};
use brdf_core::table::{SixTable, TableConsts};
use brdf_core::{
    AnyModel, Brdf, FiveParam, Geometry, Lambert, Minnaert, Model, ModelKind, SixParam, SixParamCos2,
};
use brdf_wire::blob::{table1_blob, Blob, TableRef, BLOB_VERSION, MAX_BLOB_LEN};
use brdf_wire::frame::{
    encode_response, parse_request, samples, ErrorCode, FrameReader, Input, Request, Response, MAX_BATCH,
    MAX_FIT_SAMPLES, MAX_FRAME,
};
use cortex_m_rt::entry;
use rand_core::SeedableRng;

use brdf_fw::exit;
use brdf_fw::uart::Uart;

/// Build id reported by INFO.
const BUILD_ID: u32 = 0x0001_0000;

/// Largest FIT budget accepted: a larger one would keep the device from serving for minutes.
const MAX_FIT_BUDGET: u32 = 100_000;

/// The active blob (its bytes, since tables are read in place), its decoded materials,
/// their exact models and the CRC reported by INFO.
struct Active {
    bytes: [u8; MAX_BLOB_LEN],
    len: usize,
    blob: Blob,
    models: heapless::Vec<AnyModel<f32>, 8>,
    /// Per material with tables: where its nodes are and its precomputed constants.
    tables: heapless::Vec<Option<(TableRef, TableConsts)>, 8>,
    crc: u32,
}

impl Active {
    /// Decodes and checks `src` (CRC, parameters, tables against their parameters).
    fn from_bytes(src: &[u8]) -> Option<Active> {
        let blob = Blob::decode(src).ok()?;
        let mut models = heapless::Vec::new();
        let mut tables = heapless::Vec::new();
        for m in &blob.materials {
            models.push(m.model().ok()?).ok()?;
            let t = match m.table {
                Some(r) => Some((r, m.table(src)?.consts())),
                None => None,
            };
            tables.push(t).ok()?;
        }
        let mut bytes = [0u8; MAX_BLOB_LEN];
        bytes.get_mut(..src.len())?.copy_from_slice(src);
        let crc = brdf_wire::crc32(&src[..src.len() - 4]);
        Some(Active {
            bytes,
            len: src.len(),
            blob,
            models,
            tables,
            crc,
        })
    }

    /// The built-in default: the paper's Table 1.
    fn default_materials() -> Option<Active> {
        let mut buf = [0u8; MAX_BLOB_LEN];
        let n = table1_blob().encode(&mut buf).ok()?;
        Active::from_bytes(&buf[..n])
    }

    /// Evaluates material `id`: through its tables if it has them, else the exact model.
    /// Out-of-domain inputs are refused, never clamped.
    fn eval(&self, id: u8, input: Input, x: [f32; 3]) -> Result<f32, ErrorCode> {
        let i = usize::from(id);
        let (Some(model), Some(table)) = (self.models.get(i), self.tables.get(i)) else {
            return Err(ErrorCode::UnknownMaterial);
        };
        let g = match input {
            Input::Angles => Geometry::try_from_angles(x[0], x[1], x[2]),
            Input::Cosines => Geometry::try_from_cosines(x[0], x[1], x[2]),
        }
        .map_err(|_| ErrorCode::OutOfDomain)?;
        let table = table.and_then(|(r, c)| SixTable::from_parts(c, r.bytes(&self.bytes[..self.len])?));
        let f = match table {
            Some(t) => t.eval(&g),
            None => model.eval(&g),
        };
        if f.is_finite() {
            Ok(f)
        } else {
            Err(ErrorCode::OutOfDomain)
        }
    }
}

fn fit<M: Model<f32>>(
    s: &Samples<f32, MAX_FIT_SAMPLES>,
    budget: u32,
) -> Result<([f32; 6], f32, u32), ErrorCode> {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(1);
    let cfg = AnnealConfig {
        budget,
        ..AnnealConfig::default()
    };
    anneal::<f32, M, _, MAX_FIT_SAMPLES>(s, &SearchBox::for_kind(M::KIND), &cfg, &mut rng)
        .map(|o| (o.params, o.rms_rel, o.evals))
        .map_err(|_| ErrorCode::FitFailed)
}

/// Handles one request; the reply's variable part goes into `values`.
fn handle<'v>(req: Request<'_>, active: &mut Active, values: &'v mut [u8; 4 * MAX_BATCH]) -> Response<'v> {
    match req {
        Request::Info => Response::Info {
            build_id: BUILD_ID,
            format_version: BLOB_VERSION,
            active_crc: active.crc,
            materials: active.blob.materials.len() as u8,
        },
        Request::Eval { material, input, x } => match active.eval(material, input, x) {
            Ok(f) => Response::Value(f),
            Err(e) => Response::Error(e),
        },
        Request::EvalBatch {
            material,
            input,
            points,
        } => {
            let mut n = 0;
            for x in brdf_wire::frame::points(points) {
                match active.eval(material, input, x) {
                    Ok(f) => values[4 * n..4 * n + 4].copy_from_slice(&f.to_le_bytes()),
                    Err(e) => return Response::Error(e),
                }
                n += 1;
            }
            if n == 0 && usize::from(material) >= active.blob.materials.len() {
                return Response::Error(ErrorCode::UnknownMaterial);
            }
            Response::Values(&values[..4 * n])
        }
        Request::Load(bytes) => match Active::from_bytes(bytes) {
            Some(a) => {
                *active = a;
                Response::Done(active.crc)
            }
            None => Response::Error(ErrorCode::InvalidBlob),
        },
        Request::Commit(_) => Response::Error(ErrorCode::UnknownKind),
        Request::Fit {
            model,
            budget,
            samples: bytes,
        } => {
            if budget > MAX_FIT_BUDGET {
                return Response::Error(ErrorCode::FitFailed);
            }
            let mut s: Samples<f32, MAX_FIT_SAMPLES> = Samples::new();
            for [ti, tr, phi, y] in samples(bytes) {
                if s.push_angles(ti, tr, phi, y).is_err() {
                    return Response::Error(ErrorCode::FitFailed);
                }
            }
            let r = match model {
                ModelKind::Six => fit::<SixParam<f32>>(&s, budget),
                ModelKind::SixCos2 => fit::<SixParamCos2<f32>>(&s, budget),
                ModelKind::Five => fit::<FiveParam<f32>>(&s, budget),
                ModelKind::Minnaert => fit::<Minnaert<f32>>(&s, budget),
                ModelKind::Lambert => fit::<Lambert<f32>>(&s, budget),
            };
            match r {
                Ok((params, rms_rel, evals)) => Response::Fitted {
                    model,
                    params,
                    rms_rel,
                    evals,
                },
                Err(e) => Response::Error(e),
            }
        }
    }
}

#[entry]
fn main() -> ! {
    let uart = Uart::uart0();
    uart.init();
    let mut active = match Active::default_materials() {
        Some(a) => a,
        None => exit(false),
    };
    let mut reader: FrameReader<MAX_FRAME> = FrameReader::new();
    let mut out = [0u8; 512];
    let mut values = [0u8; 4 * MAX_BATCH];
    loop {
        let byte = uart.read();
        let reply = match reader.push(byte) {
            None => continue,
            Some(Err(code)) => encode_response(&Response::Error(code), 0, &mut out),
            Some(Ok(())) => match parse_request(reader.payload()) {
                Ok((tag, req)) => {
                    let resp = handle(req, &mut active, &mut values);
                    encode_response(&resp, tag, &mut out)
                }
                Err(code) => encode_response(&Response::Error(code), 0, &mut out),
            },
        };
        if let Ok(n) = reply {
            uart.write_all(&out[..n]);
        }
    }
}
