//! `brdf check --qemu`: the firmware under QEMU agrees with the host f64 model for every
//! Table 1 material and for a material freshly fitted from the bundled measurements.
//!
//! The checks run on 2,000 random directions and 100 per edge region (`SAMPLE`), a tenth of
//! the command's default: QEMU's UART takes about 50 ms per 64-direction frame. The device's
//! arithmetic is held bit for bit to the host's f32 path in `tests/e2e` (`firmware_qemu`),
//! whose accuracy against f64 is measured on dense grids on the host (`f32_accuracy`), so the
//! sample here checks the command and its verdicts, not every corner of the arithmetic.
//!
//! Needs `qemu-system-arm` and the cross target; fails without them unless `BRDF_SKIP_QEMU=1`
//! (set by `.ci/run` after printing a `SKIPPED:` line).

use crate::brdf;

/// The directions checked per material (see the module's note).
const SAMPLE: &[&str] = &["--directions", "2000", "--edge", "100"];

/// A directions file naming only material 1 checks material 1 and says that 0 and 2 were
/// not checked (they were left out without a word).
#[test]
fn check_names_the_materials_a_directions_file_leaves_out() {
    if brdf_tests::qemu::firmware().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("d.csv");
    std::fs::write(&f, "theta_i,theta_r,phi,material\n10,20,180,1\n40,30,90,1\n").unwrap();
    let out = brdf(&["check", "--qemu", "--directions", f.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    for m in [0, 2] {
        assert!(err.contains(&format!("material {m} (six) not checked")), "{err}");
    }
    assert!(!err.contains("material 1 (six) not checked"), "{err}");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.lines().any(|l| l.trim_start().starts_with("1 ")), "{text}");
    assert!(!text.lines().any(|l| l.trim_start().starts_with("0 ")), "{text}");
}

#[test]
fn check_qemu_passes_for_table1_and_a_fresh_fit() {
    let Some(elf) = brdf_tests::qemu::firmware() else {
        return;
    };
    // The CLI's default ELF is the build cargo made (here, wherever the target directory is).
    assert_eq!(
        brdf_link::firmware::qemu_elf("brdf-fw").canonicalize().unwrap(),
        elf.canonicalize().unwrap()
    );
    let out = brdf(&[&["check", "--qemu"], SAMPLE].concat());
    let text = String::from_utf8_lossy(&out.stdout);
    println!("{text}");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(
        text.lines().filter(|l| l.ends_with("ok")).count(),
        15,
        "3 materials x 5 regions"
    );

    // `brdf query` answers exactly what `brdf eval --precision f32` computes on the host.
    let dir = tempfile::tempdir().unwrap();
    let angles = dir.path().join("a.csv");
    std::fs::write(&angles, "theta_i,theta_r,phi\n10,10,0\n30,45,180\n60,75,90\n").unwrap();
    let device = brdf(&["query", "--qemu", angles.to_str().unwrap()]);
    assert!(
        device.status.success(),
        "{}",
        String::from_utf8_lossy(&device.stderr)
    );
    let host = brdf(&[
        "eval",
        "--model",
        "six",
        "--params",
        &brdf_tests::table1_params_arg(0),
        "--precision",
        "f32",
        angles.to_str().unwrap(),
    ]);
    assert!(host.status.success());
    assert_eq!(
        String::from_utf8_lossy(&device.stdout),
        String::from_utf8_lossy(&host.stdout)
    );
    let one = brdf(&["query", "--qemu", "--material", "1", "--angles", "10,10,180"]);
    assert!(one.status.success());
    assert!(
        String::from_utf8_lossy(&one.stdout)
            .trim()
            .parse::<f32>()
            .unwrap()
            > 0.0
    );

    let fit = brdf(&[
        "fit",
        "--format",
        "cornell",
        brdf_tests::measured("cornell-medium-gloss-paints/garnet_red_RGB.astm")
            .to_str()
            .unwrap(),
        "--json",
    ]);
    assert!(fit.status.success());
    let json = dir.path().join("garnet.json");
    std::fs::write(&json, &fit.stdout).unwrap();
    let blob = dir.path().join("garnet.bin");
    let pack = brdf(&[
        "pack",
        json.to_str().unwrap(),
        "-o",
        blob.to_str().unwrap(),
        "--sequence",
        "2",
    ]);
    assert!(pack.status.success(), "{}", String::from_utf8_lossy(&pack.stderr));
    let out = brdf(
        &[
            &["check", "--qemu", "--blob", blob.to_str().unwrap(), "--json"],
            SAMPLE,
        ]
        .concat(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 5);
    assert!(rows.iter().all(|r| r["within_tolerance"] == true));
    let worst = rows
        .iter()
        .map(|r| r["max_rel"].as_f64().unwrap())
        .fold(0.0, f64::max);
    println!("freshly fitted Garnet Red: worst relative error {worst:.2e}");

    // The same fit with 256-node tables: held to the table bound up to 85 degrees zenith,
    // the rest reported.
    let tabled = dir.path().join("garnet-table.bin");
    let pack = brdf(&[
        "pack",
        json.to_str().unwrap(),
        "-o",
        tabled.to_str().unwrap(),
        "--sequence",
        "3",
        "--table-nodes",
        "256",
    ]);
    assert!(pack.status.success(), "{}", String::from_utf8_lossy(&pack.stderr));
    let out = brdf(
        &[
            &["check", "--qemu", "--blob", tabled.to_str().unwrap(), "--json"],
            SAMPLE,
        ]
        .concat(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v.as_array().unwrap();
    let judged: Vec<_> = rows.iter().filter(|r| !r["tolerance"].is_null()).collect();
    assert!(judged.len() >= 4, "{rows:?}");
    assert!(judged
        .iter()
        .all(|r| r["tolerance"] == 1.5e-3 && r["tabulated"] == 256));
    assert!(rows
        .iter()
        .any(|r| r["tolerance"].is_null() && r["region"] == "grazing (>85 deg)"));
    let worst = judged
        .iter()
        .map(|r| r["max_rel"].as_f64().unwrap())
        .fold(0.0, f64::max);
    println!("Garnet Red with 256-node tables: worst relative error {worst:.2e} up to 85 deg");
    assert!(worst > 1e-6, "a table this coarse cannot be exact: {worst:e}");
}

/// The 31 bands of a spectral measurement, fitted in one command, pack into one banded
/// material that `brdf check --qemu` passes at every band centre and every midpoint; `brdf
/// query --wavelength` answers it as `brdf eval --fit --wavelength --precision f32` does at
/// a band, refuses without a wavelength and outside the bands by name.
#[test]
fn a_spectral_fit_packs_into_one_banded_material_the_device_passes_in_every_band() {
    if brdf_tests::qemu::firmware().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let data = brdf_tests::measured("cornell-spectral/garnet_red.astm");
    // The microfacet model: its parameters on these bands lie where the f32 promise holds
    // (the six-parameter fits of three dark bands do not: below).
    let fit = brdf(&[
        "fit",
        "--format",
        "cornell",
        "--model",
        "ggx",
        data.to_str().unwrap(),
        "--json",
    ]);
    assert!(fit.status.success(), "{}", String::from_utf8_lossy(&fit.stderr));
    let json = dir.path().join("bands.json");
    std::fs::write(&json, &fit.stdout).unwrap();
    let blob = dir.path().join("bands.bin");
    let pack = brdf(&["pack", json.to_str().unwrap(), "-o", blob.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&pack.stderr);
    assert!(pack.status.success(), "{err}");
    assert!(err.contains("material 0: 31 bands of"), "{err}");
    assert!(err.contains("fits 0–30"), "{err}");
    assert!(!err.contains("warning"), "{err}");
    // Six-parameter fits of the same bands: pack warns of each band whose parameters leave
    // the f32 promise (its device error measured), so a check failing there is foretold.
    let six = brdf(&["fit", "--format", "cornell", data.to_str().unwrap(), "--json"]);
    let six_json = dir.path().join("six.json");
    std::fs::write(&six_json, &six.stdout).unwrap();
    let six_pack = brdf(&[
        "pack",
        six_json.to_str().unwrap(),
        "-o",
        dir.path().join("six.bin").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&six_pack.stderr);
    assert!(six_pack.status.success(), "{err}");
    assert!(err.contains("the device's f32 evaluation errs by up to"), "{err}");
    let out = brdf(
        &[
            &["check", "--qemu", "--blob", blob.to_str().unwrap(), "--json"],
            SAMPLE,
        ]
        .concat(),
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v.as_array().unwrap();
    // Five regions, each at the centres and at the midpoints.
    assert_eq!(rows.len(), 10, "{rows:?}");
    assert!(rows.iter().all(|r| r["within_tolerance"] == true), "{rows:?}");
    let centres: Vec<&serde_json::Value> = rows
        .iter()
        .filter(|r| r["region"] == "hemisphere @ 31 of 31 bands")
        .collect();
    let mids: Vec<&serde_json::Value> = rows
        .iter()
        .filter(|r| r["region"] == "hemisphere @ 30 of 30 midpoints")
        .collect();
    assert_eq!(centres[0]["wavelengths"].as_array().unwrap().len(), 31);
    assert_eq!(mids[0]["wavelengths"].as_array().unwrap().len(), 30);
    assert!(mids[0]["tolerance"].as_f64().unwrap() > centres[0]["tolerance"].as_f64().unwrap());

    let angles = dir.path().join("a.csv");
    std::fs::write(&angles, "theta_i,theta_r,phi\n10,10,0\n30,45,180\n60,75,90\n").unwrap();
    let query = |extra: &[&str]| {
        brdf(
            &[
                &["query", "--qemu", "--blob", blob.to_str().unwrap()],
                extra,
                &[angles.to_str().unwrap()],
            ]
            .concat(),
        )
    };
    let device = query(&["--wavelength", "0.55"]);
    assert!(
        device.status.success(),
        "{}",
        String::from_utf8_lossy(&device.stderr)
    );
    let host = brdf(&[
        "eval",
        "--fit",
        json.to_str().unwrap(),
        "--wavelength",
        "0.55",
        "--precision",
        "f32",
        angles.to_str().unwrap(),
    ]);
    assert!(host.status.success(), "{}", String::from_utf8_lossy(&host.stderr));
    assert_eq!(
        String::from_utf8_lossy(&device.stdout),
        String::from_utf8_lossy(&host.stdout)
    );
    // Between two bands the answer lies between theirs.
    let values = |o: &std::process::Output| -> Vec<f64> {
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect()
    };
    let (a, b, mid) = (
        values(&query(&["--wavelength", "0.55"])),
        values(&query(&["--wavelength", "0.56"])),
        values(&query(&["--wavelength", "0.555"])),
    );
    for k in 0..3 {
        assert!(
            mid[k] >= a[k].min(b[k]) && mid[k] <= a[k].max(b[k]),
            "{a:?} {b:?} {mid:?}"
        );
    }
    let none = query(&[]);
    assert!(!none.status.success());
    let err = String::from_utf8_lossy(&none.stderr);
    assert!(
        err.contains("material 0 is spectral (banded)") && err.contains("--wavelength"),
        "{err}"
    );
    let outside = query(&["--wavelength", "1.064"]);
    let err = String::from_utf8_lossy(&outside.stderr);
    assert!(
        !outside.status.success() && err.contains("--wavelength 1.064: the device refused it"),
        "{err}"
    );
    // Between bands and near their edges the device and `brdf eval --precision f32` decide
    // and weigh alike (both in f32), so they print the same bytes; near an edge both refuse.
    for um in ["0.4321", "0.400001002", "0.410000995"] {
        let host = brdf(&[
            "eval",
            "--fit",
            json.to_str().unwrap(),
            "--wavelength",
            um,
            "--precision",
            "f32",
            angles.to_str().unwrap(),
        ]);
        let device = query(&["--wavelength", um]);
        assert_eq!(
            String::from_utf8_lossy(&device.stdout),
            String::from_utf8_lossy(&host.stdout),
            "{um}: {}",
            String::from_utf8_lossy(&device.stderr)
        );
    }
    let edge = query(&["--wavelength", "0.399999005"]);
    let err = String::from_utf8_lossy(&edge.stderr);
    assert!(
        err.contains("--wavelength 0.399999005: the device refused it"),
        "{err}"
    );
    // A small sample reaches some of the wavelengths only, and the report says which.
    let few = brdf(&[
        "check",
        "--qemu",
        "--blob",
        blob.to_str().unwrap(),
        "--json",
        "--directions",
        "3",
        "--edge",
        "0",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&few.stdout).unwrap();
    assert_eq!(v[0]["region"], "hemisphere @ 2 of 31 bands", "{v}");
    assert_eq!(v[0]["wavelengths"], serde_json::json!([0.4, 0.41]));
    assert_eq!(v[1]["region"], "hemisphere @ 1 of 30 midpoints", "{v}");
    for (bad, says) in [
        ("-0.5", "--wavelength -0.5: not a wavelength above 0"),
        ("0", "--wavelength 0.0: not a wavelength above 0"),
        ("nan", "--wavelength NaN: not a wavelength above 0"),
        ("1e-50", "--wavelength 1e-50: beyond what a device holds"),
        ("1e39", "--wavelength 1e39: beyond what a device holds"),
    ] {
        let o = query(&["--wavelength", bad]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(says), "{bad}: {err}");
    }
}

#[test]
fn flash_reads_slot_addresses_from_the_elf_and_needs_a_probe() {
    let Some(elf) = brdf_tests::qemu::firmware() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let blob = dir.path().join("t1.bin");
    let json = dir.path().join("k.json");
    std::fs::write(
        &json,
        r#"{"model":"six","params":{"kb":0.2545,"kr":21.8031,"b":-27.5721,"a":0.6705,"kd":0.3676,"c":1.2}}"#,
    )
    .unwrap();
    assert!(
        brdf(&["pack", json.to_str().unwrap(), "-o", blob.to_str().unwrap()])
            .status
            .success()
    );
    let args = |extra: &[&str]| {
        let mut a = vec![
            "flash",
            blob.to_str().unwrap(),
            "--chip",
            "STM32F407VGTx",
            "--elf",
            elf.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        brdf(&a)
    };
    // No probe on this machine: a dry run still reports the slots from the ELF's symbols.
    let dry = args(&["--dry-run"]);
    let text = String::from_utf8_lossy(&dry.stdout);
    assert!(dry.status.success(), "{}", String::from_utf8_lossy(&dry.stderr));
    assert!(
        text.contains("slot A at 0x00300000, slot B at 0x00340000"),
        "{text}"
    );
    // A real write without a probe fails with a clear reason.
    let real = args(&[]);
    assert!(!real.status.success());
    let err = String::from_utf8_lossy(&real.stderr);
    assert!(err.contains("probe"), "{err}");
    // A file that is not a blob is refused by name.
    let bad = brdf(&[
        "flash",
        json.to_str().unwrap(),
        "--chip",
        "STM32F407VGTx",
        "--dry-run",
    ]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("k.json"));
}
