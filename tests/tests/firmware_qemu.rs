//! The firmware under QEMU (`mps2-an386`, Cortex-M4F): its answers against the host's f64
//! model, and its behaviour under a stream of garbage, truncated and corrupted frames.
//!
//! Needs `qemu-system-arm` and the `thumbv7em-none-eabihf` target. Without them the test
//! fails, unless `BRDF_SKIP_QEMU=1` is set (`.ci/run` sets it after printing a `SKIPPED:` line
//! when it cannot install them).

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use brdf_core::anneal::{anneal, AnnealConfig, Samples, SearchBox};
use brdf_core::tolerance::{F32_FLOOR_OF_MAX, F32_MAX_REL};
use brdf_core::{AnyModel, Brdf, ModelKind, SixParam};
use brdf_tests::{SplitMix, TABLE1};
use brdf_wire::frame::{
    encode_request, parse_response, values, FrameReader, Input, Request, Response, MAX_BATCH, MAX_FRAME,
};
use rand_core::SeedableRng;

fn firmware_elf() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../firmware");
    let status = Command::new(env!("CARGO"))
        .args(["build", "--release", "-p", "brdf-fw"])
        .current_dir(&dir)
        .status()
        .ok()?;
    status
        .success()
        .then(|| dir.join("target/thumbv7em-none-eabihf/release/brdf-fw"))
}

struct Device {
    qemu: Child,
    link: TcpStream,
    reader: FrameReader<{ MAX_FRAME }>,
    tag: u8,
}

impl Drop for Device {
    fn drop(&mut self) {
        let _ = self.qemu.kill();
        let _ = self.qemu.wait();
    }
}

impl Device {
    fn start(elf: &PathBuf) -> Device {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let qemu = Command::new("qemu-system-arm")
            .args([
                "-machine",
                "mps2-an386",
                "-cpu",
                "cortex-m4",
                "-nographic",
                "-monitor",
                "none",
            ])
            .args(["-semihosting-config", "enable=on,target=native"])
            .arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port},nodelay=on"))
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .spawn()
            .expect("qemu-system-arm");
        listener.set_nonblocking(false).unwrap();
        let (link, _) = listener.accept().unwrap();
        link.set_nodelay(true).unwrap();
        link.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        Device {
            qemu,
            link,
            reader: FrameReader::new(),
            tag: 0,
        }
    }

    fn send_raw(&mut self, bytes: &[u8]) {
        self.link.write_all(bytes).unwrap();
    }

    /// Reads replies until one with `tag` (others are collected and returned too).
    fn replies_until(&mut self, tag: Option<u8>, count: usize) -> Vec<(u8, Vec<u8>)> {
        let mut got = Vec::new();
        let mut byte = [0u8; 1];
        let deadline = Instant::now() + Duration::from_secs(60);
        while Instant::now() < deadline {
            if got.len() >= count && tag.is_none() {
                break;
            }
            self.link
                .read_exact(&mut byte)
                .expect("the firmware stopped answering");
            if let Some(r) = self.reader.push(byte[0]) {
                r.expect("the firmware sent a corrupted frame");
                let payload = self.reader.payload().to_vec();
                let (t, _) = parse_response(&payload).expect("unparsable reply");
                got.push((t, payload));
                if Some(t) == tag {
                    break;
                }
            }
        }
        got
    }

    fn request(&mut self, req: &Request<'_>) -> Vec<u8> {
        self.tag = self.tag.wrapping_add(1).max(1);
        let mut out = vec![0u8; MAX_FRAME];
        let n = encode_request(req, self.tag, &mut out).unwrap();
        self.send_raw(&out[..n]);
        let tag = self.tag;
        let replies = self.replies_until(Some(tag), 1);
        replies.into_iter().find(|(t, _)| *t == tag).expect("reply").1
    }
}

fn available() -> Option<PathBuf> {
    let qemu = Command::new("qemu-system-arm").arg("--version").output().is_ok();
    let elf = if qemu { firmware_elf() } else { None };
    if elf.is_none() {
        assert!(
            std::env::var("BRDF_SKIP_QEMU").as_deref() == Ok("1"),
            "qemu-system-arm or the thumbv7em-none-eabihf build is missing (set BRDF_SKIP_QEMU=1 to skip)"
        );
        eprintln!("SKIPPED: firmware QEMU test (BRDF_SKIP_QEMU=1)");
    }
    elf
}

#[test]
fn firmware_answers_like_the_host_and_survives_bad_frames() {
    let Some(elf) = available() else { return };
    let mut dev = Device::start(&elf);

    let info = dev.request(&Request::Info);
    let (
        _,
        Response::Info {
            materials,
            format_version,
            ..
        },
    ) = parse_response(&info).unwrap()
    else {
        panic!("not an INFO reply")
    };
    assert_eq!((materials, format_version), (3, 1));

    // 10,240 directions per Table 1 material, f32 angles, against f64 at the same inputs.
    let mut rng = SplitMix(2026);
    let dirs: Vec<[f32; 3]> = (0..160 * MAX_BATCH)
        .map(|_| {
            [
                (rng.unit() * 89.9f64).to_radians() as f32,
                (rng.unit() * 89.9f64).to_radians() as f32,
                (rng.unit() * 360.0f64).to_radians() as f32,
            ]
        })
        .collect();
    for (m, (name, p)) in TABLE1.iter().enumerate() {
        let p64: Vec<f64> = p.iter().map(|&v| f64::from(v as f32)).collect();
        let host = AnyModel::<f64>::new(ModelKind::Six, &p64).unwrap();
        let mut device = Vec::with_capacity(dirs.len());
        for chunk in dirs.chunks(MAX_BATCH) {
            let bytes: Vec<u8> = chunk
                .iter()
                .flat_map(|x| x.iter().flat_map(|v| v.to_le_bytes()))
                .collect();
            let reply = dev.request(&Request::EvalBatch {
                material: m as u8,
                input: Input::Angles,
                points: &bytes,
            });
            let (_, Response::Values(v)) = parse_response(&reply).unwrap() else {
                panic!("not VALUES")
            };
            device.extend(values(v));
        }
        let exact: Vec<f64> = dirs
            .iter()
            .map(|x| host.eval_angles(x[0].into(), x[1].into(), x[2].into()))
            .collect();
        let max = exact.iter().copied().fold(0.0, f64::max);
        let worst = exact
            .iter()
            .zip(&device)
            .filter(|(e, _)| **e >= F32_FLOOR_OF_MAX * max && **e > 0.0)
            .map(|(e, d)| ((f64::from(*d) - e) / e).abs())
            .fold(0.0, f64::max);
        println!(
            "firmware vs host f64, {name}: {} directions, max relative error {worst:.2e}",
            dirs.len()
        );
        assert!(worst <= F32_MAX_REL, "{name}: {worst}");
    }

    // Garbage, truncated and corrupted frames between valid EVALs: every valid one answered
    // correctly, every bad frame answered with an ERROR, the device still serving afterwards.
    let host = AnyModel::<f64>::new(ModelKind::Six, &TABLE1[0].1.map(|v| f64::from(v as f32))).unwrap();
    let mut sent = 0usize;
    let mut bad_frames = 0usize;
    let mut k = 0u32;
    while sent < 100_000 {
        k += 1;
        let x = [0.3f32 + (k % 50) as f32 * 0.01, 0.5, 2.0];
        let mut frame = vec![0u8; MAX_FRAME];
        dev.tag = (k % 200 + 1) as u8;
        let n = encode_request(
            &Request::Eval {
                material: 0,
                input: Input::Angles,
                x,
            },
            dev.tag,
            &mut frame,
        )
        .unwrap();
        frame.truncate(n);
        let mut noise: Vec<u8> = match k % 3 {
            0 => (0..(rng.next_u64() % 80)).map(|_| rng.next_u64() as u8).collect(),
            1 => frame[..(rng.next_u64() as usize % (frame.len() - 1))].to_vec(),
            _ => {
                let mut g = frame.clone();
                let i = rng.next_u64() as usize % (g.len() - 1);
                g[i] = if g[i] == 0xff { 0x01 } else { g[i] + 1 };
                g.pop();
                g
            }
        };
        noise.push(0);
        // Each non-empty run of bytes ended by a 0 is one bad frame (an empty run is no frame).
        let expected_errors = noise.split(|&b| b == 0).filter(|run| !run.is_empty()).count();
        bad_frames += expected_errors;
        dev.send_raw(&noise);
        dev.send_raw(&frame);
        sent += noise.len() + frame.len();
        let replies = dev.replies_until(Some(dev.tag), 1);
        let (_, payload) = replies.last().unwrap();
        let (_, Response::Value(v)) = parse_response(payload).unwrap() else {
            panic!("no VALUE for a valid EVAL")
        };
        let e = host.eval_angles(x[0].into(), x[1].into(), x[2].into());
        assert!(((f64::from(v) - e) / e).abs() <= F32_MAX_REL);
        let errors = &replies[..replies.len() - 1];
        assert_eq!(errors.len(), expected_errors, "one ERROR reply per bad frame");
        for (_, p) in errors {
            assert!(
                matches!(parse_response(p).unwrap().1, Response::Error(_)),
                "non-error reply to a bad frame"
            );
        }
    }
    let info = dev.request(&Request::Info);
    assert!(matches!(parse_response(&info).unwrap().1, Response::Info { .. }));

    // FIT on the device equals the same annealer run on the host, bit for bit (same f32
    // arithmetic through libm, same generator and seed).
    let mut sample_bytes = Vec::new();
    let mut host_samples: Samples<f32, 256> = Samples::new();
    let khaki32 = AnyModel::<f32>::new(ModelKind::Six, &TABLE1[0].1.map(|v| v as f32)).unwrap();
    for ti in [0.0f32, 10.0, 30.0] {
        for k in 0..20 {
            let ts = -80.0 + 160.0 * k as f32 / 19.0;
            let (tr, phi) = if ts > 0.0 {
                (ts, std::f32::consts::PI)
            } else {
                (-ts, 0.0)
            };
            let (ti, tr) = (ti.to_radians(), tr.to_radians());
            let y = khaki32.eval_angles(ti, tr, phi);
            host_samples.push_angles(ti, tr, phi, y).unwrap();
            for v in [ti, tr, phi, y] {
                sample_bytes.extend(v.to_le_bytes());
            }
        }
    }
    let reply = dev.request(&Request::Fit {
        model: ModelKind::Six,
        budget: 3000,
        samples: &sample_bytes,
    });
    let (
        _,
        Response::Fitted {
            params,
            rms_rel,
            evals,
            ..
        },
    ) = parse_response(&reply).unwrap()
    else {
        panic!("not FITTED")
    };
    let cfg = AnnealConfig {
        budget: 3000,
        ..AnnealConfig::default()
    };
    let mut rng = rand_pcg::Pcg32::seed_from_u64(1);
    let host = anneal::<f32, SixParam<f32>, _, 256>(
        &host_samples,
        &SearchBox::for_kind(ModelKind::Six),
        &cfg,
        &mut rng,
    )
    .unwrap();
    println!("device FIT: rms_rel {rms_rel:.3e} after {evals} evaluations, params {params:?}");
    assert_eq!((params, rms_rel, evals), (host.params, host.rms_rel, host.evals));
    assert!(rms_rel < 0.01);
    println!("{sent} bytes with {bad_frames} bad frames: each answered with an ERROR, every valid EVAL with its value");
}
