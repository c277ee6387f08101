//! The firmware under QEMU (`mps2-an386`, Cortex-M4F): its answers against the host's f64
//! model, and its behaviour under a stream of garbage, truncated and corrupted frames.
//!
//! Needs `qemu-system-arm` and the `thumbv7em-none-eabihf` target. Without them the test
//! fails, unless `BRDF_SKIP_QEMU=1` is set (`.ci/run` sets it after printing a `SKIPPED:` line
//! when it cannot install them).

use brdf_core::accuracy::compare;
use brdf_core::anneal::{anneal, AnnealConfig, Samples, SearchBox, DEVICE_SEED};
use brdf_core::tolerance::F32_MAX_REL;
use brdf_core::{AnyModel, Brdf, ModelKind, SixParam};
use brdf_link::{Link, Qemu};
use brdf_tests::qemu::firmware;
use brdf_tests::{SplitMix, TABLE1};
use brdf_wire::blob::{table1_blob, Blob, TableRef, BLOB_VERSION, MAX_BLOB_LEN};
use brdf_wire::frame::{encode_request, parse_response, Input, Request, Response, MAX_BATCH, MAX_FRAME};
use rand_core::SeedableRng;

#[test]
fn firmware_answers_like_the_host_and_survives_bad_frames() {
    let Some(elf) = firmware() else { return };
    let mut dev = Link::new(Qemu::spawn(&elf).unwrap());
    let (_, format_version, _, materials) = dev.info().unwrap();
    assert_eq!((materials, format_version), (3, BLOB_VERSION));

    // 2,048 directions per Table 1 material, f32 angles: bit for bit the host's f32 path (the
    // one `tests/e2e/f32_accuracy` measures against f64 on dense grids), and within the f32
    // tolerance of f64 at the same inputs. (QEMU's UART takes about 50 ms per 64-direction
    // frame: a denser sample would only repeat the host's own grid at 50 times the cost.)
    let mut rng = SplitMix(2026);
    let dirs: Vec<[f32; 3]> = (0..32 * MAX_BATCH)
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
        let device = dev.eval(m as u8, Input::Angles, &dirs).unwrap();
        let host32 = AnyModel::<f32>::new(ModelKind::Six, &p.map(|v| v as f32)).unwrap();
        for (x, d) in dirs.iter().zip(&device) {
            assert_eq!(
                d.to_bits(),
                host32.eval_angles(x[0], x[1], x[2]).to_bits(),
                "{name} at {x:?}"
            );
        }
        let exact: Vec<f64> = dirs
            .iter()
            .map(|x| host.eval_angles(x[0].into(), x[1].into(), x[2].into()))
            .collect();
        let worst = compare(0..dirs.len(), |k| device[k], |k| exact[k]).max;
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
        // A copy of the valid frame to damage (it never decodes, so its tag does not matter).
        let mut frame = vec![0u8; MAX_FRAME];
        let n = encode_request(
            &Request::Eval {
                material: 0,
                input: Input::Angles,
                x,
            },
            0,
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
        dev.send_raw(&noise).unwrap();
        dev.stray_errors.clear();
        let reply = dev
            .request(&Request::Eval {
                material: 0,
                input: Input::Angles,
                x,
            })
            .unwrap();
        sent += noise.len() + frame.len();
        let (_, Response::Value(v)) = parse_response(&reply).unwrap() else {
            panic!("no VALUE for a valid EVAL")
        };
        let e = host.eval_angles(x[0].into(), x[1].into(), x[2].into());
        assert!(((f64::from(v) - e) / e).abs() <= F32_MAX_REL);
        assert_eq!(
            dev.stray_errors.len(),
            expected_errors,
            "one ERROR reply per bad frame"
        );
    }
    dev.info().expect("still serving");
    // No reset either: the firmware logged its boot exactly once.
    let log = brdf_link::decode_defmt(&elf, &dev.transport().log()).unwrap();
    let boots = log
        .iter()
        .filter(|l| l.starts_with("INFO boot: brdf-fw build"))
        .count();
    assert_eq!(boots, 1, "{log:?}");

    // FIT on the device equals the same annealer run on the host, bit for bit (same f32
    // arithmetic through libm, same generator and seed).
    let mut samples4 = Vec::new();
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
            samples4.push([ti, tr, phi, y]);
        }
    }
    let (params, rms_rel, evals) = dev.fit(ModelKind::Six, 3000, &samples4).unwrap();
    let cfg = AnnealConfig {
        budget: 3000,
        ..AnnealConfig::default()
    };
    let mut rng = rand_pcg::Pcg32::seed_from_u64(DEVICE_SEED);
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

#[test]
fn firmware_serves_tabulated_materials_like_the_host() {
    use brdf_core::table::{fill_six_table, table_len, SixTable};
    use brdf_core::tolerance::{TABLE_MAX_REL, TABLE_MAX_ZENITH_DEG};

    let Some(elf) = firmware() else { return };
    let mut dev = Link::new(Qemu::spawn(&elf).unwrap());
    let (_, _, crc_default, _) = dev.info().unwrap();
    let (nodes, bound) = TABLE_MAX_REL[1];

    // White paint (the steepest lobe) with a 256-node table, yellow without one.
    let mut blob = table1_blob();
    blob.materials.swap(0, 2);
    blob.materials.truncate(2);
    blob.sequence = 5;
    let white = blob.materials[0].six_params().unwrap();
    let white64 = brdf_tests::six_params(TABLE1[2].1.map(|v| f64::from(v as f32)));
    let mut nodes_bytes = vec![0u8; table_len(nodes)];
    fill_six_table(&white64, nodes, &mut nodes_bytes).unwrap();
    blob.materials[0].table = Some(TableRef {
        nodes: nodes as u16,
        offset: 0,
    });
    let mut buf = [0u8; MAX_BLOB_LEN];
    let n = blob
        .encode_with_tables(&[Some(&nodes_bytes), None], &mut buf)
        .unwrap();
    let crc = dev.load(&buf[..n]).unwrap();
    assert_eq!(crc, brdf_wire::blob::blob_crc(&buf[..n]));

    let host_table = SixTable::new(white, &nodes_bytes).unwrap();
    let exact = SixParam::new(white64).unwrap();
    let limit = TABLE_MAX_ZENITH_DEG.to_radians();
    let mut rng = SplitMix(85);
    let dirs: Vec<[f32; 3]> = (0..32 * MAX_BATCH)
        .map(|_| {
            [
                rng.uniform(0.0, limit).cos() as f32,
                rng.uniform(0.0, limit).cos() as f32,
                rng.uniform(-1.0, 1.0) as f32,
            ]
        })
        .collect();
    let device = dev.eval(0, Input::Cosines, &dirs).unwrap();
    let values: Vec<f64> = dirs
        .iter()
        .map(|x| exact.eval_cosines(x[0].into(), x[1].into(), x[2].into()))
        .collect();
    for (x, d) in dirs.iter().zip(&device) {
        // The device runs the host's table code: bit for bit the same answer.
        assert_eq!(
            d.to_bits(),
            host_table.eval_cosines(x[0], x[1], x[2]).to_bits(),
            "at {x:?}"
        );
    }
    let worst = compare(0..dirs.len(), |k| device[k], |k| values[k]).max;
    println!(
        "device table ({nodes} nodes), white paint, {} directions: max relative error {worst:.2e}",
        dirs.len()
    );
    assert!(worst <= bound, "{worst:e} > {bound:e}");
    // The material without a table in the same blob is evaluated exactly: the host's f32 model.
    let yellow = dev.eval(1, Input::Cosines, &dirs[..64]).unwrap();
    let y32 = blob.materials[1].model().unwrap();
    for (x, d) in dirs.iter().zip(&yellow) {
        assert_eq!(
            d.to_bits(),
            y32.eval_cosines(x[0], x[1], x[2]).to_bits(),
            "at {x:?}"
        );
    }

    // A table that does not belong to its parameters is refused and the active set stays.
    let mut bad = buf;
    let at = 16 + 4 + 4 * 5; // white's c
    bad[at..at + 4].copy_from_slice(&0.3f32.to_le_bytes());
    let c = brdf_wire::blob::blob_crc(&bad[..n]);
    bad[n - 4..n].copy_from_slice(&c.to_le_bytes());
    assert!(Blob::decode(&bad[..n]).is_err());
    assert!(dev.load(&bad[..n]).is_err());
    let (_, _, active, materials) = dev.info().unwrap();
    assert_eq!((active, materials), (crc, 2));
    assert_ne!(active, crc_default);
}

/// A fitted table over the microfacet base `brdf select` uses (a blob of version 3) is served by the device bit for bit as
/// the host's f32 path computes it, from cosines and from angles, beside an analytic
/// material; the largest table that fits a slot loads.
#[test]
fn firmware_serves_a_fitted_table_like_the_host() {
    use brdf_core::fitted::{encode_fitted, Corrected, FittedShape, FittedTable};

    let Some(elf) = firmware() else { return };
    let mut dev = Link::new(Qemu::spawn(&elf).unwrap());
    let shape = FittedShape {
        theta_h: 20,
        theta_d: 19,
        phi_d: 5,
    };
    // A rough correction with a mirror peak along theta_h and a phi_d ramp.
    let values: Vec<f64> = (0..shape.cells())
        .map(|c| {
            let (i, j, k) = (
                c / (shape.theta_d * shape.phi_d),
                c / shape.phi_d % shape.theta_d,
                c % shape.phi_d,
            );
            3.0 * (-(i as f64) / 3.0).exp() - 0.05 * j as f64 + 0.1 * k as f64
        })
        .collect();
    let covered: Vec<bool> = (0..shape.cells()).map(|c| c % 4 != 0).collect();
    let mut bytes = vec![0u8; shape.encoded_len()];
    encode_fitted(shape, &values, &covered, &mut bytes).unwrap();
    let base_with_table = brdf_wire::blob::Material::from_params(ModelKind::Ggx, &[0.8, 0.2, 0.04, 0.3])
        .unwrap()
        .with_fitted(&bytes)
        .unwrap();
    let mut blob = table1_blob();
    blob.materials.truncate(1);
    blob.materials.insert(0, base_with_table).unwrap();
    blob.sequence = 9;
    let mut buf = vec![0u8; 2 * MAX_BLOB_LEN];
    // With khaki beside it the blob is too large for one slot: refused before it is sent.
    assert!(blob.encoded_len() > MAX_BLOB_LEN);
    blob.materials.truncate(1);
    let n = blob.encode_with_tables(&[Some(&bytes)], &mut buf).unwrap();
    assert!(n <= MAX_BLOB_LEN);
    let crc = dev.load(&buf[..n]).unwrap();
    assert_eq!(crc, brdf_wire::blob::blob_crc(&buf[..n]));

    let host = Corrected {
        base: base_with_table.model().unwrap(),
        table: FittedTable::new(&bytes).unwrap(),
    };
    let mut rng = SplitMix(31);
    let angles: Vec<[f32; 3]> = (0..8 * MAX_BATCH)
        .map(|_| {
            [
                rng.uniform(0.0, 1.5) as f32,
                rng.uniform(0.0, 1.5) as f32,
                rng.uniform(0.0, std::f64::consts::TAU) as f32,
            ]
        })
        .collect();
    let device = dev.eval(0, Input::Angles, &angles).unwrap();
    for (x, d) in angles.iter().zip(&device) {
        assert_eq!(
            d.to_bits(),
            host.eval_angles(x[0], x[1], x[2]).to_bits(),
            "at {x:?}"
        );
    }
    let cosines: Vec<[f32; 3]> = angles
        .iter()
        .map(|x| [x[0].cos(), x[1].cos(), x[2].cos()])
        .collect();
    let device = dev.eval(0, Input::Cosines, &cosines).unwrap();
    for (x, d) in cosines.iter().zip(&device) {
        assert_eq!(
            d.to_bits(),
            host.eval_cosines(x[0], x[1], x[2]).to_bits(),
            "at {x:?}"
        );
    }
    // The correction is not the base model: a table the device ignored would fail here.
    let base = base_with_table.model().unwrap();
    assert!(angles.iter().zip(&device).any(|(x, d)| (d / base.eval_cosines(
        x[0].cos(),
        x[1].cos(),
        x[2].cos()
    ) - 1.0)
        .abs()
        > 0.5));
    let (_, _, active, materials) = dev.info().unwrap();
    assert_eq!((active, materials), (crc, 1));
}

/// A banded material (a blob of version 4: 31 bands of the six-parameter model, as `brdf pack`
/// makes of a spectral fit) answers EVAL_AT by its band at a centre and by the two bands around
/// a wavelength between them, bit for bit as the host's f32 path computes it; it refuses plain
/// EVAL and EVAL_BATCH, wavelengths outside its bands and ones that are not wavelengths. A
/// material without bands beside it is the same at every wavelength.
#[test]
fn firmware_serves_a_banded_material_like_the_host() {
    use brdf_core::bands::{blend, Located};
    use brdf_link::LinkError;
    use brdf_wire::blob::Material;
    use brdf_wire::frame::ErrorCode;

    let Some(elf) = firmware() else { return };
    let mut dev = Link::new(Qemu::spawn(&elf).unwrap());
    let khaki = TABLE1[0].1;
    let bands: Vec<(f64, Material)> = (0..31)
        .map(|k| {
            let mut p = khaki;
            // A spectrum: kd and the lobe's width vary smoothly with the band.
            p[4] = 0.1 + 0.02 * k as f64;
            p[1] = 10.0 + k as f64;
            (
                0.4 + 0.01 * k as f64,
                Material::from_params(ModelKind::Six, &p).unwrap(),
            )
        })
        .collect();
    let mut extra = vec![0u8; MAX_BLOB_LEN];
    let (banded, len) = Material::banded(&bands, &mut extra).unwrap();
    let mut blob = table1_blob();
    blob.materials.truncate(1);
    blob.materials.push(banded).unwrap();
    blob.sequence = 11;
    let mut buf = vec![0u8; MAX_BLOB_LEN];
    let n = blob
        .encode_with_tables(&[None, Some(&extra[..len])], &mut buf)
        .unwrap();
    assert_eq!(u16::from_le_bytes([buf[4], buf[5]]), BLOB_VERSION);
    let crc = dev.load(&buf[..n]).unwrap();
    assert_eq!(crc, brdf_wire::blob::blob_crc(&buf[..n]));
    let decoded = Blob::decode(&buf[..n]).unwrap();
    let m = decoded.materials[1];
    let bytes = &buf[..n];
    let host = |um: f32, x: &[f32; 3]| -> f32 {
        let f = |k: usize| m.band_model(bytes, k).unwrap().eval_angles(x[0], x[1], x[2]);
        match m.locate(bytes, um).unwrap() {
            Located::Band(k) => f(k),
            Located::Between { lower, weight } => blend(f(lower), f(lower + 1), weight),
        }
    };
    let mut rng = SplitMix(5);
    let angles: Vec<[f32; 3]> = (0..MAX_BATCH)
        .map(|_| {
            [
                rng.uniform(0.0, 1.5) as f32,
                rng.uniform(0.0, 1.5) as f32,
                rng.uniform(0.0, std::f64::consts::TAU) as f32,
            ]
        })
        .collect();
    // Every centre, every midpoint, and the ends of the range.
    let mut wavelengths: Vec<f32> = (0..31).map(|k| 0.4 + 0.01 * k as f32).collect();
    wavelengths.extend((0..30).map(|k| 0.405 + 0.01 * k as f32));
    wavelengths.extend([0.4003, 0.6997]);
    let mut blended = 0;
    for &um in &wavelengths {
        let device = dev.eval_at(1, Input::Angles, Some(um), &angles).unwrap();
        for (x, d) in angles.iter().zip(&device) {
            assert_eq!(d.to_bits(), host(um, x).to_bits(), "at {um} µm, {x:?}");
        }
        if matches!(m.locate(bytes, um), Ok(Located::Between { .. })) {
            blended += 1;
            // Strictly between its neighbours' values where they differ.
            let Ok(Located::Between { lower, .. }) = m.locate(bytes, um) else {
                unreachable!()
            };
            let x = angles[0];
            let (a, b) = (
                m.band_model(bytes, lower).unwrap().eval_angles(x[0], x[1], x[2]),
                m.band_model(bytes, lower + 1)
                    .unwrap()
                    .eval_angles(x[0], x[1], x[2]),
            );
            assert!(
                device[0] > a.min(b) && device[0] < a.max(b),
                "{um}: {a} {} {b}",
                device[0]
            );
        }
    }
    assert_eq!(blended, 32);
    let refused = |r: Result<Vec<f32>, LinkError>| match r {
        Err(LinkError::Device(code)) => code,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        refused(dev.eval(1, Input::Angles, &angles[..3])),
        ErrorCode::NeedsWavelength
    );
    for um in [0.39f32, 0.701, 0.0, -0.5, f32::NAN, f32::INFINITY] {
        assert_eq!(
            refused(dev.eval_at(1, Input::Angles, Some(um), &angles[..3])),
            ErrorCode::OutOfDomain,
            "{um}"
        );
    }
    let plain = dev.eval(0, Input::Angles, &angles).unwrap();
    assert_eq!(
        dev.eval_at(0, Input::Angles, Some(1.064), &angles).unwrap(),
        plain
    );
    // A wavelength that is none is refused for a material without bands too.
    for um in [0.0f32, -1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(
            refused(dev.eval_at(0, Input::Angles, Some(um), &angles[..3])),
            ErrorCode::OutOfDomain,
            "{um}"
        );
    }
    let (_, _, active, materials) = dev.info().unwrap();
    assert_eq!((active, materials), (crc, 2));

    // A material of one band answers plain EVAL with it, and EVAL_AT at its wavelength only.
    let (one, len) = Material::banded(&bands[7..8], &mut extra).unwrap();
    let mut blob = table1_blob();
    blob.materials.truncate(0);
    blob.materials.push(one).unwrap();
    blob.sequence = 12;
    let n = blob.encode_with_tables(&[Some(&extra[..len])], &mut buf).unwrap();
    dev.load(&buf[..n]).unwrap();
    let want: Vec<f32> = angles
        .iter()
        .map(|x| bands[7].1.model().unwrap().eval_angles(x[0], x[1], x[2]))
        .collect();
    assert_eq!(dev.eval(0, Input::Angles, &angles).unwrap(), want);
    assert_eq!(dev.eval_at(0, Input::Angles, Some(0.47), &angles).unwrap(), want);
    assert_eq!(
        refused(dev.eval_at(0, Input::Angles, Some(0.48), &angles[..3])),
        ErrorCode::OutOfDomain
    );
}
