//! The fitted-table rung end to end: `brdf select` offers it and judges it by held-out error,
//! `--chosen` writes it, `brdf eval --fit`, `brdf pack` and `brdf check --qemu` serve it, and
//! every reader refuses a damaged one by name.

use crate::brdf;

fn ok(args: &[&str]) -> String {
    let out = brdf(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

fn fails(args: &[&str]) -> String {
    let out = brdf(args);
    assert!(!out.status.success(), "{args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn repo(path: &str) -> String {
    format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR"))
}

/// The trimmed RMS relative error (`brdf_fit::fitted_table::trimmed_rms_rel`) of `eval --fit`
/// output (column `f`) against the data's `brdf` column.
fn trimmed_error(csv: &str) -> f64 {
    let mut rows = csv.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (y, f) = (col("brdf"), col("f"));
    let rel: Vec<f64> = rows
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[f] / v[y] - 1.0).abs()
        })
        .collect();
    brdf_fit::fitted_table::trimmed_rms_rel(&rel)
}

#[test]
fn a_measured_metal_gets_a_fitted_table_that_every_reader_serves() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    // MERL's aluminium, in plane: a metal no analytic rung fits within 30%.
    ok(&[
        "import",
        "merl-inplane",
        &repo("data/measured/merl-aluminium-inplane/aluminum_brdf.csv"),
        "-o",
        &p("al.csv"),
    ]);
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "select",
        &p("al.csv"),
        "--budget",
        "0.1%",
        "--chosen",
        &p("chosen.json"),
        "-o",
        &p("select.bin"),
        "--json",
    ]))
    .unwrap();
    let reprs = v["representations"].as_array().unwrap();
    let cv = |r: &serde_json::Value| r["cv_rms_rel"].as_f64().unwrap_or(f64::INFINITY);
    let table = reprs.iter().find(|r| r["name"] == "ggx + table").unwrap();
    let coverage = table["coverage"].as_f64().unwrap();
    assert!(
        coverage > 0.0 && coverage < 1.0,
        "in-plane data cover part of the grid: {coverage}"
    );
    assert_eq!(table["fits_blob"], true);
    // The table is the most accurate held out, by a wide margin over every analytic rung.
    let best_analytic = reprs
        .iter()
        .filter(|r| r["name"] != "ggx + table")
        .map(cv)
        .fold(f64::INFINITY, f64::min);
    assert!(
        cv(table) < 0.5 * best_analytic,
        "table {} vs {best_analytic}",
        cv(table)
    );
    assert_eq!(v["chosen"], "ggx + table", "{}", v["reason"]);

    // --chosen: the base fit with its table; eval --fit reproduces the training error.
    let chosen: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(p("chosen.json")).unwrap()).unwrap();
    assert_eq!(chosen["model"], "ggx");
    // Its energy is the representation's (base times table), not the bare base's: no
    // analytic bound, and aluminium's table reflects far more than its base (albedo about 1.5
    // at 60° against 0.04; the data are not in absolute units).
    let energy = &chosen["energy"];
    assert!(
        energy["bound"].is_null() && energy["bound_conserves"] == false,
        "{energy}"
    );
    let albedos: Vec<f64> = energy["albedo"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["albedo"].as_f64().unwrap())
        .collect();
    assert_eq!(energy["albedo_conserves"], albedos.iter().all(|&a| a <= 1.0));
    assert!(albedos.iter().any(|&a| a > 1.0), "{albedos:?}");
    let nodes = &chosen["fitted_table"]["nodes"];
    assert!(
        brdf_fit::fitted_table::SHAPES
            .iter()
            .any(|s| *nodes == serde_json::json!([s.theta_h, s.theta_d, s.phi_d])),
        "{nodes}"
    );
    let evaluated = ok(&[
        "eval",
        "--fit",
        &p("chosen.json"),
        &p("al.csv"),
        "--output-column",
        "f",
    ]);
    let train = trimmed_error(&evaluated);
    let reported = table["rms_rel"].as_f64().unwrap();
    // eval --fit is the f64 path, select measured the device's f32 path: each value within
    // the table's f32 bound (2.1e-3 relative here), so the errors within that of each other.
    assert!((train - reported).abs() < 3e-3, "{train} vs {reported}");
    let f32_out = ok(&[
        "eval",
        "--fit",
        &p("chosen.json"),
        &p("al.csv"),
        "--output-column",
        "f",
        "--precision",
        "f32",
    ]);
    let hex = chosen["fitted_table"]["bytes"].as_str().unwrap();
    let table_bytes = hex::decode(hex).unwrap();
    let bound = brdf_core::fitted::FittedTable::new(&table_bytes)
        .unwrap()
        .f32_max_rel()
        + brdf_core::tolerance::F32_MAX_REL;
    assert!(bound < 0.01, "{bound}");
    let column = |csv: &str| -> Vec<f64> {
        csv.lines()
            .skip(1)
            .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
            .collect()
    };
    let (f64s, f32s) = (column(&evaluated), column(&f32_out));
    assert_eq!(f64s.len(), f32s.len());
    let worst = f64s
        .iter()
        .zip(&f32s)
        .map(|(a, b)| (b / a - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(worst <= bound, "f32 against f64: {worst:e} > {bound:e}");

    // pack makes the blob select wrote; the device serves it within its bound.
    ok(&["pack", &p("chosen.json"), "-o", &p("pack.bin")]);
    assert_eq!(
        std::fs::read(p("pack.bin")).unwrap(),
        std::fs::read(p("select.bin")).unwrap()
    );
    let bytes = std::fs::read(p("pack.bin")).unwrap();
    let blob = brdf_wire::blob::Blob::decode(&bytes).unwrap();
    assert!(blob.materials[0].fitted.is_some());
    if brdf_tests::qemu::firmware().is_some() {
        ok(&[
            "check",
            "--qemu",
            "--blob",
            &p("pack.bin"),
            "--directions",
            "2000",
            "--edge",
            "100",
        ]);
    }

    // Damaged tables are refused by name, by every reader.
    let text = std::fs::read_to_string(p("chosen.json")).unwrap();
    let damaged = |what: &str, new: String, said: &str| {
        let path = p(&format!("{what}.json"));
        std::fs::write(&path, new).unwrap();
        for args in [
            vec![
                "eval",
                "--fit",
                path.as_str(),
                &p("al.csv"),
                "--output-column",
                "f",
            ],
            vec!["pack", path.as_str(), "-o", &p("x.bin")],
        ] {
            let err = fails(&args);
            assert!(err.contains(said), "{what}: {args:?}: {err}");
        }
    };
    // A reserved header byte set (hex digits 6..8 are byte 3).
    damaged(
        "reserved",
        text.replacen(hex, &format!("{}01{}", &hex[..6], &hex[8..]), 1),
        "fitted_table.bytes: fitted table: a reserved field",
    );
    damaged(
        "not-hex",
        text.replacen(hex, &format!("zz{}", &hex[2..]), 1),
        "fitted_table.bytes: not hex",
    );
    damaged(
        "short",
        text.replacen(hex, &hex[..hex.len() - 2], 1),
        "fitted_table.bytes",
    );
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let nodes: Vec<u64> = json["fitted_table"]["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_u64().unwrap())
        .collect();
    let (nh, nd, np) = (nodes[0], nodes[1], nodes[2]);
    damaged(
        "nodes",
        text.replacen(&format!("[\n      {nh},"), &format!("[\n      {},", nh + 1), 1),
        &format!(
            "fitted_table: nodes [{}, {nd}, {np}] but the bytes hold a {nh} x {nd} x {np} table",
            nh + 1
        ),
    );
    damaged(
        "unknown-key",
        text.replacen("\"smoothness\"", "\"smoothnes\"", 1),
        "unknown field `smoothnes`",
    );
    // A valid table with one cell edited, or under another base, was read back without a
    // word (one hex digit changed the BRDF by up to 95%): the seal no longer matches.
    let edited = |change: &dyn Fn(&mut serde_json::Value)| {
        let mut v = json.clone();
        change(&mut v);
        serde_json::to_string_pretty(&v).unwrap()
    };
    // The low digit of the first cell (after the header; the coverage bits come last).
    let cells = 2 * brdf_core::fitted::FITTED_HEADER_LEN + 1;
    let flipped = if &hex[cells..cells + 1] == "0" { "1" } else { "0" };
    let cell = format!("{}{flipped}{}", &hex[..cells], &hex[cells + 1..]);
    damaged(
        "edited-cell",
        edited(&|v| v["fitted_table"]["bytes"] = cell.clone().into()),
        "does not match the table and its base",
    );
    damaged(
        "no-check",
        edited(&|v| {
            v["fitted_table"].as_object_mut().unwrap().remove("check");
        }),
        "no `check`",
    );
    damaged(
        "other-base",
        edited(&|v| {
            let params = v["params"].as_object_mut().unwrap();
            let (_, first) = params.iter_mut().next().unwrap();
            *first = (first.as_f64().unwrap() * 1.5).into();
        }),
        "does not match the table and its base",
    );
    // A scene evaluates it (base times table, f64) and says how much of the material's sigma
    // comes from directions the in-plane measurements did not cover.
    let scene = p("scene.toml");
    let bundled = std::fs::read_to_string(repo("data/scenes/target.toml")).unwrap();
    let hull = "model = \"six\"\nparams = \"kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676,c=1.2\"";
    assert!(bundled.contains(hull));
    let with = |fit: &str| {
        bundled
            .replace(
                "mesh = \"target.obj\"",
                &format!("mesh = \"{}\"", repo("data/scenes/target.obj")),
            )
            .replace(hull, fit)
    };
    std::fs::write(&scene, with(&format!("fit = \"{}\"", p("chosen.json")))).unwrap();
    let out = brdf(&["scene", "lrcs", &scene, "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let hull_report = &report["materials"][0];
    assert_eq!(hull_report["fitted_table"], true);
    let outside = hull_report["outside_coverage"].as_f64().unwrap();
    assert!(outside > 0.0 && outside < 1.0, "{outside}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("a fitted table") && err.contains("did not cover"),
        "{err}"
    );
    // Its sigma is the table's, not the base model's: the same scene with the bare base differs.
    std::fs::write(
        p("base.toml"),
        with(&format!(
            "model = \"{}\"\nparams = \"{}\"",
            chosen["model"].as_str().unwrap(),
            chosen["params"]
                .as_object()
                .unwrap()
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(",")
        )),
    )
    .unwrap();
    let base: serde_json::Value =
        serde_json::from_str(&ok(&["scene", "lrcs", &p("base.toml"), "--json"])).unwrap();
    let sigma = |r: &serde_json::Value| -> f64 {
        r["aspects"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a["by_material"][0].as_f64().unwrap())
            .sum()
    };
    assert!(
        (sigma(&report) / sigma(&base) - 1.0).abs() > 0.1,
        "{} vs {}",
        sigma(&report),
        sigma(&base)
    );
    // select --scene offers the table as it is, beside the ladder fitted to it.
    let sel: serde_json::Value =
        serde_json::from_str(&ok(&["select", "--scene", &scene, "--budget", "1%", "--json"])).unwrap();
    let names: Vec<&str> = sel["materials"][0]["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    assert!(names.contains(&"ggx + table"), "{names:?}");
    assert_eq!(sel["materials"][0]["model"], "ggx + table");
}

/// `brdf synth` of Lambert (rho0 0.5) at incidences `theta_i` (degrees, comma-separated),
/// viewing zeniths every `step` degrees, with `extra` options.
fn lambert_csv(theta_i: &str, step: &str, extra: &[&str]) -> String {
    let mut args = vec![
        "synth",
        "--model",
        "lambert",
        "--params",
        "rho0=0.5",
        "--theta-i",
        theta_i,
        "--step",
        step,
    ];
    args.extend_from_slice(extra);
    ok(&args)
}

#[test]
fn small_data_get_no_table_and_are_told_why() {
    let dir = tempfile::tempdir().unwrap();
    let text = lambert_csv("0,30", "20", &["--noise", "1%"]);
    let n = text.lines().filter(|l| !l.starts_with('#')).count() - 1;
    let path = dir.path().join("few.csv");
    std::fs::write(&path, &text).unwrap();
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["select", path.to_str().unwrap(), "--json"])).unwrap();
    let has_table = v["representations"]
        .as_array()
        .unwrap()
        .iter()
        .any(|r| r["name"] == "ggx + table");
    let note = v["notes"].as_array().unwrap().iter().any(|s| {
        s.as_str()
            .is_some_and(|s| s.contains("fitted table: not offered"))
    });
    assert!(n < brdf_scene::represent::TABLE_MIN_POINTS, "{n} points");
    assert!(!has_table);
    assert!(note, "{}", v["notes"]);
}

#[test]
fn outputs_never_overwrite_inputs_or_each_other() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    let text = lambert_csv("0,30", "20", &[]);
    std::fs::write(p("d.csv"), &text).unwrap();
    std::fs::create_dir(p("sub")).unwrap();
    std::fs::write(p("out.bin"), b"x").unwrap();
    std::os::unix::fs::symlink(p("out.bin"), p("link.bin")).unwrap();
    // The same file by `..`, by a symbolic link, or the input itself: refused before any work.
    for args in [
        vec![
            "select",
            &p("d.csv"),
            "-o",
            &p("out.bin"),
            "--chosen",
            &p("sub/../out.bin"),
        ],
        vec![
            "select",
            &p("d.csv"),
            "-o",
            &p("out.bin"),
            "--chosen",
            &p("link.bin"),
        ],
        vec!["select", &p("d.csv"), "--chosen", &p("sub/../d.csv")],
        vec!["fit", &p("d.csv"), "-o", &p("sub/../d.csv")],
    ] {
        let err = fails(&args);
        assert!(err.contains("overwrit"), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read(p("out.bin")).unwrap(), b"x");
    assert_eq!(std::fs::read_to_string(p("d.csv")).unwrap(), text);
    let merl = repo("data/measured/merl-aluminium-inplane/aluminum_brdf.csv");
    std::fs::copy(&merl, p("al.csv")).unwrap();
    let err = fails(&["import", "merl-inplane", &p("al.csv"), "-o", &p("sub/../al.csv")]);
    assert!(err.contains("would be overwritten"), "{err}");

    // pack over its fit file, a scene's outputs over the scene, its mesh or a fit file it
    // names: each destroyed its input with exit 0.
    let fit = r#"{"model": "lambert", "params": {"rho0": 0.5}}"#;
    std::fs::write(p("fit.json"), fit).unwrap();
    std::fs::copy(repo("data/scenes/target.obj"), p("t.obj")).unwrap();
    let scene = "mesh = \"t.obj\"\n[[material]]\npart = \"*\"\nfit = \"fit.json\"\n\
                 [sensor]\nmode = \"monostatic\"\nazimuth_deg = [0, 10, 5]\nelevation_deg = [0, 10, 5]\n";
    std::fs::write(p("s.toml"), scene).unwrap();
    for args in [
        vec!["pack", &p("fit.json"), "-o", &p("sub/../fit.json")],
        vec!["scene", "lrcs", &p("s.toml"), "-o", &p("s.toml")],
        vec!["scene", "lrcs", &p("s.toml"), "-o", &p("fit.json")],
        vec!["scene", "domain", &p("s.toml"), "-o", &p("t.obj")],
        vec!["select", "--scene", &p("s.toml"), "-o", &p("sub/../fit.json")],
        vec!["select", "--scene", &p("s.toml"), "-o", &p("t.obj")],
    ] {
        let err = fails(&args);
        assert!(
            err.contains("is the input") && err.contains("would be overwritten"),
            "{args:?}: {err}"
        );
    }
    assert_eq!(std::fs::read_to_string(p("fit.json")).unwrap(), fit);
    assert_eq!(std::fs::read_to_string(p("s.toml")).unwrap(), scene);
    assert_eq!(
        std::fs::read(p("t.obj")).unwrap(),
        std::fs::read(repo("data/scenes/target.obj")).unwrap()
    );
    let err = fails(&[
        "scene",
        "lrcs",
        &p("s.toml"),
        "-o",
        &p("x.svg"),
        "--plot",
        &p("sub/../x.svg"),
    ]);
    assert!(err.contains("-o and --plot name the same file"), "{err}");
    // Elsewhere they write.
    ok(&["scene", "lrcs", &p("s.toml"), "-o", &p("sigma.csv")]);
    ok(&["pack", &p("fit.json"), "-o", &p("fit.bin")]);
}

#[test]
fn a_table_the_device_cannot_take_is_left_out_or_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    // Readings 4000 times too large: Lambert's rho0 beyond the device's 100. With 50 points
    // the table over it used to abort the selection; it is left out with a note.
    let text = lambert_csv("0,20,40,60", "10", &[]);
    let mut rows = text.lines();
    let mut scaled = format!("{}\n", rows.next().unwrap());
    for l in rows {
        let (head, v) = l.rsplit_once(',').unwrap();
        scaled.push_str(&format!("{head},{}\n", v.parse::<f64>().unwrap() * 4000.0));
    }
    std::fs::write(p("big.csv"), &scaled).unwrap();
    let v: serde_json::Value = serde_json::from_str(&ok(&["select", &p("big.csv"), "--json"])).unwrap();
    assert!(v["n"].as_u64().unwrap() >= 50, "{}", v["n"]);
    let notes = v["notes"].to_string();
    assert!(
        notes.contains("fitted table left out") && notes.contains("rho0"),
        "{notes}"
    );

    // A table whose every cell is -80: in f32 the device underflows to 0 where f64 does not;
    // pack says so (`brdf check` would fail).
    use brdf_core::fitted::{encode_fitted, FittedShape};
    let shape = FittedShape {
        theta_h: 4,
        theta_d: 3,
        phi_d: 2,
    };
    let mut bytes = vec![0u8; shape.encoded_len()];
    encode_fitted(
        shape,
        &vec![-80.0; shape.cells()],
        &vec![true; shape.cells()],
        &mut bytes,
    )
    .unwrap();
    let seal = |kind: brdf_core::ModelKind, params: &[f64], bytes: &[u8]| {
        brdf_fit::fitted_table::TableRecord::check_of(kind, params, bytes)
    };
    let fit = |coverage: f64| {
        serde_json::json!({
            "model": "lambert",
            "params": {"rho0": 1e-20},
            "fitted_table": {"nodes": [4, 3, 2], "smoothness": 1.0, "coverage": coverage, "bytes": hex::encode(&bytes),
                             "check": seal(brdf_core::ModelKind::Lambert, &[1e-20], &bytes)}
        })
        .to_string()
    };
    std::fs::write(p("under.json"), fit(1.0)).unwrap();
    let out = brdf(&["pack", &p("under.json"), "-o", &p("under.bin")]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("the device's f32 evaluation gives 0e0"), "{err}");
    // A base that grows towards grazing (Minnaert, k = 0.01) times e^80 overflows f32 only
    // beyond 85 degrees, where pack's check grid stopped: it packed with no word and `brdf
    // check` died with a bare OutOfDomain.
    let mut over = vec![0u8; shape.encoded_len()];
    encode_fitted(
        shape,
        &vec![80.0; shape.cells()],
        &vec![true; shape.cells()],
        &mut over,
    )
    .unwrap();
    let minnaert = serde_json::json!({
        "model": "minnaert",
        "params": {"rho0": 100.0, "k": 0.01},
        "fitted_table": {"nodes": [4, 3, 2], "smoothness": 1.0, "coverage": 1.0, "bytes": hex::encode(&over),
                         "check": seal(brdf_core::ModelKind::Minnaert, &[100.0, 0.01], &over)}
    });
    std::fs::write(p("over.json"), minnaert.to_string()).unwrap();
    let out = brdf(&["pack", &p("over.json"), "-o", &p("over.bin")]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("the device's f32 evaluation gives inf") && err.contains("89.9"),
        "{err}"
    );
    // A coverage that is not the bytes' is refused.
    std::fs::write(p("cov.json"), fit(0.5)).unwrap();
    let err = fails(&["pack", &p("cov.json"), "-o", &p("cov.bin")]);
    assert!(err.contains("coverage 0.5 but the bytes cover 1"), "{err}");
}

/// A spectral file: `brdf select` selects every band (one line each, the 4-NN yardstick
/// beside), judges a band's dark readings over its noise floor, and `--chosen` writes every
/// band's fit, which `brdf eval --fit` takes at a wavelength; a blob (`-o`) holds one set per
/// material and is refused. (Two bands: each selection fits a table six times, 3 s.)
#[test]
fn select_takes_every_band_of_a_spectral_file() {
    let dir = tempfile::tempdir().unwrap();
    let six = brdf_core::AnyModel::<f64>::new(
        brdf_core::ModelKind::Six,
        &[0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2],
    )
    .unwrap();
    let mut text = String::from("wavelength,theta_i,theta_r,phi,brdf\n");
    let mut seed = 9u64;
    for (b, um) in ["0.5", "0.6"].iter().enumerate() {
        // 5 x 11 = 55 directions: above leave-one-out (50) and the table's minimum.
        for ti in (0..80).step_by(16) {
            for tr in (0..85).step_by(8) {
                let (i, r) = ((ti as f64).to_radians(), (tr as f64).to_radians());
                let f =
                    (0.5 + 0.5 * b as f64) * brdf_core::Brdf::eval_angles(&six, i, r, std::f64::consts::PI);
                let noise = 1.0 + 0.05 * (brdf_core::accuracy::splitmix64_unit(&mut seed) - 0.5);
                text.push_str(&format!("{um},{ti},{tr},180,{}\n", f * noise));
            }
        }
    }
    // One dark reading (a zero) in the first band.
    text.push_str("0.5,85,85,180,0\n");
    let data = dir.path().join("bands.csv");
    std::fs::write(&data, text).unwrap();
    let (d, chosen) = (data.to_str().unwrap(), dir.path().join("chosen.json"));
    let c = chosen.to_str().unwrap();
    let out = ok(&["select", d, "--budget", "5%", "--chosen", c]);
    let rows: Vec<&str> = out.lines().filter(|l| l.trim_start().starts_with("0.")).collect();
    assert_eq!(rows.len(), 2, "{out}");
    assert!(
        rows[0].split_whitespace().nth(2) == Some("1"),
        "one reading <= 0 in 0.5: {}",
        rows[0]
    );
    assert!(out.contains("median over bands: chosen"), "{out}");
    let fits: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(&chosen).unwrap()).unwrap();
    let names: Vec<&str> = fits.iter().map(|f| f["dataset"].as_str().unwrap()).collect();
    assert!(
        names[0].ends_with("[wavelength=0.5]") && names[1].ends_with("[wavelength=0.6]"),
        "{names:?}"
    );
    assert!(
        fits[0]["noise_floor"].is_object(),
        "the dark band's fit states its floor"
    );
    // Between bands: the two chosen fits blended.
    let angles = dir.path().join("a.csv");
    std::fs::write(&angles, "theta_i,theta_r,phi\n30,30,180\n").unwrap();
    let at = |w: &str| -> f64 {
        let o = ok(&["eval", "--fit", c, "--wavelength", w, angles.to_str().unwrap()]);
        o.lines()
            .nth(1)
            .unwrap()
            .rsplit(',')
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let (lo, mid, hi) = (at("0.5"), at("0.55"), at("0.6"));
    assert!((mid - 0.5 * (lo + hi)).abs() < 1e-12 * mid, "{lo} {mid} {hi}");
    // The yardstick's column holds a number for each band.
    assert!(rows.iter().all(|r| r
        .split_whitespace()
        .last()
        .is_some_and(|v| v.parse::<f64>().is_ok())));
    // -o refused (before any fit).
    let blob = dir.path().join("b.bin");
    let e = fails(&["select", d, "-o", blob.to_str().unwrap()]);
    assert!(e.contains("2 bands' fitted tables do not fit a slot"), "{e}");
}
