//! End-to-end tests of `brdf eval`: values, formats and every class of bad input.

use std::path::PathBuf;
use std::sync::LazyLock;

use brdf_core::tolerance::{BATCH_F64_REL, F64_REFERENCE_REL, F64_REFORMULATION_REL};
use brdf_core::{AnyModel, Brdf, ModelKind};

/// Khaki (Table 1) as a `--params` argument.
static KHAKI: LazyLock<String> = LazyLock::new(|| brdf_tests::table1_params_arg(0));

fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    p
}

use crate::brdf;

fn eval_ok(args: &[&str]) -> Vec<Vec<String>> {
    let out = brdf(args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect()
}

fn eval_err(args: &[&str]) -> String {
    let out = brdf(args);
    assert!(!out.status.success(), "expected failure for {args:?}");
    assert!(
        out.stdout.is_empty(),
        "a failed run must not leave partial output"
    );
    String::from_utf8(out.stderr).unwrap()
}

#[test]
fn f64_output_reproduces_reference_values_with_17_digits_and_passes_columns_through() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(
        &dir,
        "a.csv",
        "label,theta_i,theta_r,phi\nnormal,0,0,0\nmirror,10,10,180\nretro,10,10,0\ngrazing,0,89,180\n",
    );
    let rows = eval_ok(&["eval", "--model", "six", "--params", &KHAKI, f.to_str().unwrap()]);
    assert_eq!(rows[0], ["label", "theta_i", "theta_r", "phi", "brdf"]);
    let expect = [
        0.198020580194936,
        0.127789612947914,
        0.192021427058205,
        0.000908779161217468,
    ];
    assert_eq!(rows.len(), 1 + expect.len(), "no row may be dropped");
    for (row, want) in rows[1..].iter().zip(expect) {
        let text = &row[4];
        let mantissa = text.split('e').next().unwrap().replace(['.', '-'], "");
        assert_eq!(
            mantissa.len(),
            17,
            "{text} is not printed with 17 significant digits"
        );
        let got: f64 = text.parse().unwrap();
        assert!(
            ((got - want) / want).abs() <= F64_REFERENCE_REL,
            "{got} vs {want}"
        );
    }
    assert_eq!(rows[2][0], "mirror");
}

#[test]
fn f32_output_is_the_core_f32_path_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(
        &dir,
        "a.csv",
        "theta_i,theta_r,phi\n30,45,180\n60,75,90\n10,10.0001,0.0001\n",
    );
    let rows = eval_ok(&[
        "eval",
        "--model",
        "six",
        "--params",
        &KHAKI,
        "--precision",
        "f32",
        f.to_str().unwrap(),
    ]);
    let p = brdf_core::table1_f32(0).to_vec();
    let model = AnyModel::<f32>::new(ModelKind::Six, &p).unwrap();
    for row in &rows[1..] {
        let [ti, tr, phi] = [0, 1, 2].map(|k| (row[k].parse::<f64>().unwrap().to_radians()) as f32);
        let got: f32 = row[3].parse().unwrap();
        assert_eq!(got, model.eval_angles(ti, tr, phi), "row {row:?}");
        assert_eq!(row[3].split('e').next().unwrap().replace(['.', '-'], "").len(), 9);
    }
}

#[test]
fn other_models_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(&dir, "a.csv", "theta_i,theta_r,phi\n0,0,0\n");
    let rows = eval_ok(&[
        "eval",
        "--model",
        "lambert",
        "--params",
        "rho0=0.5",
        f.to_str().unwrap(),
    ]);
    let v: f64 = rows[1][3].parse().unwrap();
    assert!((v - 0.5 / std::f64::consts::PI).abs() < F64_REFORMULATION_REL);
    for (model, params) in [
        ("minnaert", "rho0=0.5,k=0.7"),
        ("five", "kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676"),
        ("six-cos2", &KHAKI),
    ] {
        let rows = eval_ok(&["eval", "--model", model, "--params", params, f.to_str().unwrap()]);
        assert!(rows[1][3].parse::<f64>().unwrap() > 0.0);
    }
}

#[test]
fn bad_input_names_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("missing.csv", "theta_i,phi\n0,0\n", "missing column `theta_r`"),
        (
            "dup.csv",
            "theta_i,theta_r,phi,phi\n0,0,0,0\n",
            "column `phi` appears twice",
        ),
        (
            "nan.csv",
            "theta_i,theta_r,phi\n0,0,0\n10,abc,0\n",
            "line 3: column theta_r: `abc` is not a number",
        ),
        (
            "inf.csv",
            "theta_i,theta_r,phi\n0,0,inf\n",
            "line 2: column phi: `inf` is not finite",
        ),
        (
            "range.csv",
            "theta_i,theta_r,phi\n0,0,0\n0,0,0\n95,0,0\n",
            "line 4: column theta_i: zenith 95 deg is outside [0, 90]",
        ),
        (
            "neg.csv",
            "theta_i,theta_r,phi\n0,-1,0\n",
            "line 2: column theta_r: zenith -1 deg",
        ),
        ("short.csv", "theta_i,theta_r,phi\n0,0\n", "malformed CSV"),
        (
            "clash.csv",
            "theta_i,theta_r,phi,brdf\n0,0,0,1\n",
            "already has a column `brdf`",
        ),
    ];
    for (name, text, want) in cases {
        let f = write(&dir, name, text);
        let err = eval_err(&["eval", "--model", "six", "--params", &KHAKI, f.to_str().unwrap()]);
        assert!(
            err.contains(name),
            "{name}: message does not name the file: {err}"
        );
        assert!(err.contains(want), "{name}: expected `{want}` in: {err}");
    }
    let f = write(&dir, "ok.csv", "theta_i,theta_r,phi\n0,0,0\n");
    let path = f.to_str().unwrap();
    let param_cases = [
        ("kb=0.2,kr=2,b=-3,a=0.5,kd=0.3", "missing parameter c"),
        ("kb=0.2,kr=2,b=-3,a=0.5,kd=0.3,c=1,q=2", "unknown parameter `q`"),
        (
            "kb=0.2,kr=2,b=-3,a=0,kd=0.3,c=1",
            "parameter a = 0 is out of range",
        ),
        ("kb=0.2,kr=two,b=-3,a=0.5,kd=0.3,c=1", "`two` is not a number"),
    ];
    for (params, want) in param_cases {
        let err = eval_err(&["eval", "--model", "six", "--params", params, path]);
        assert!(err.contains(want), "expected `{want}` in: {err}");
    }
    let err = eval_err(&["eval", "--model", "seven", "--params", "x=1", path]);
    assert!(err.contains("unknown model `seven`"), "{err}");
    let err = eval_err(&[
        "eval",
        "--model",
        "six",
        "--params",
        &KHAKI,
        "/nonexistent/angles.csv",
    ]);
    assert!(err.contains("/nonexistent/angles.csv"), "{err}");
}

#[test]
fn ninety_degrees_is_the_horizon_in_both_precisions() {
    let dir = tempfile::tempdir().unwrap();
    let f = write(&dir, "h.csv", "theta_i,theta_r,phi\n90,0,0\n0,90,0\n");
    for (model, params) in [
        ("minnaert", "rho0=0.5,k=0.5"),
        ("five", "kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676"),
        ("lambert", "rho0=0.5"),
    ] {
        for precision in ["f64", "f32"] {
            let rows = eval_ok(&[
                "eval",
                "--model",
                model,
                "--params",
                params,
                "--precision",
                precision,
                f.to_str().unwrap(),
            ]);
            for row in &rows[1..] {
                assert_eq!(row[3].parse::<f64>().unwrap(), 0.0, "{model} {precision} {row:?}");
            }
        }
    }
}

#[test]
fn large_files_are_evaluated_in_chunks_in_order_and_match_the_scalar_path() {
    // More rows than one evaluation chunk (65,536), so the order across chunks and the
    // batch path's agreement with the scalar path are both exercised.
    let dir = tempfile::tempdir().unwrap();
    let n = 70_000;
    let mut text = String::from("id,theta_i,theta_r,phi\n");
    let mut s = 0x9e37_79b9_u64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    for k in 0..n {
        text += &format!("{k},{},{},{}\n", 89.9 * next(), 89.9 * next(), 360.0 * next());
    }
    let f = write(&dir, "big.csv", &text);
    let rows = eval_ok(&["eval", "--model", "six", "--params", &KHAKI, f.to_str().unwrap()]);
    assert_eq!(rows.len(), n + 1);
    let model = AnyModel::<f64>::new(ModelKind::Six, &brdf_core::TABLE1[0].1).unwrap();
    for (k, row) in rows[1..].iter().enumerate() {
        assert_eq!(row[0], k.to_string());
        let [ti, tr, phi] = [1, 2, 3].map(|c| row[c].parse::<f64>().unwrap().to_radians());
        let want = model.eval_angles(ti, tr, phi);
        let got: f64 = row[4].parse().unwrap();
        assert!(
            (got - want).abs() <= BATCH_F64_REL * want,
            "row {k}: {got} vs {want}"
        );
    }
    // A bad row after the first chunks is reported at its line; eval streams, so the whole
    // chunks of 4,096 rows before the one holding it have been written, and nothing more.
    text += "70000,30,90.5,180\n";
    let f = write(&dir, "bad.csv", &text);
    let out = brdf(&["eval", "--model", "six", "--params", &KHAKI, f.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains(&format!("line {}: column theta_r", n + 2)), "{err}");
    let written = String::from_utf8(out.stdout).unwrap().lines().count();
    assert_eq!(
        written,
        1 + n / 4096 * 4096,
        "header and the whole chunks before the bad row"
    );
}

#[test]
fn a_fit_result_evaluates_as_its_model_and_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let angles = write(
        &dir,
        "a.csv",
        "theta_i,theta_r,phi\n0,0,0\n10,10,0\n30,40,180\n60,85,90\n",
    );
    // A batch of two fits (two hand-written results), as `brdf fit --json` prints a batch.
    let fits = write(
        &dir,
        "fits.json",
        r#"[{"model": "lambert", "params": {"rho0": 0.25}},
            {"model": "six", "params": {"kb": 0.2545, "kr": 21.8031, "b": -27.5721, "a": 0.6705, "kd": 0.3676, "c": 1.2}}]"#,
    );
    let (a, f) = (angles.to_str().unwrap(), fits.to_str().unwrap());
    for precision in ["f64", "f32"] {
        let by_fit = eval_ok(&["eval", "--fit", f, "--index", "1", "--precision", precision, a]);
        let by_params = eval_ok(&[
            "eval",
            "--model",
            "six",
            "--params",
            KHAKI.as_str(),
            "--precision",
            precision,
            a,
        ]);
        assert_eq!(by_fit, by_params, "{precision}");
        let lambert = eval_ok(&["eval", "--fit", f, "--index", "0", "--precision", precision, a]);
        assert_eq!(
            lambert,
            eval_ok(&[
                "eval",
                "--model",
                "lambert",
                "--params",
                "rho0=0.25",
                "--precision",
                precision,
                a
            ])
        );
    }
    // Which fit must be said for a batch, and must exist.
    let e = eval_err(&["eval", "--fit", f, a]);
    assert!(e.contains("holds 2 fits: say which with index 0..1"), "{e}");
    let e = eval_err(&["eval", "--fit", f, "--index", "2", a]);
    assert!(e.contains("holds 2 fits; there is no index 2"), "{e}");
    // --fit excludes --model and --params; --index needs --fit.
    assert!(eval_err(&["eval", "--fit", f, "--model", "six", a]).contains("cannot be used with"));
    assert!(eval_err(&[
        "eval",
        "--model",
        "six",
        "--params",
        KHAKI.as_str(),
        "--index",
        "0",
        a
    ])
    .contains("--fit"));
    // A parameter the model does not have, or one given twice, is refused (it would be
    // ignored, or one value silently win), by eval and by pack alike.
    for (json, says) in [
        (
            r#"{"model": "five", "params": {"kb": 0.25, "kr": 21.8, "b": -27.6, "a": 0.67, "kd": 0.37, "c": 1.2}}"#,
            "unknown parameter `c` for the five model (expected kb, kr, b, a, kd)",
        ),
        (
            r#"{"model": "lambert", "params": {"rho0": 0.3, "rho0": 0.9}}"#,
            "parameter `rho0` given twice",
        ),
        ("[]", "holds no fit"),
    ] {
        let f = write(&dir, "odd.json", json);
        let e = eval_err(&["eval", "--fit", f.to_str().unwrap(), a]);
        assert!(e.contains(says), "{e}");
        if json != "[]" {
            let out = brdf(&[
                "pack",
                f.to_str().unwrap(),
                "-o",
                dir.path().join("x.bin").to_str().unwrap(),
            ]);
            assert!(!out.status.success());
            assert!(String::from_utf8_lossy(&out.stderr).contains(says));
        }
    }
    // A fit whose parameters are out of range is refused, naming the parameter.
    let bad = write(
        &dir,
        "bad.json",
        r#"{"model": "lambert", "params": {"rho0": -1}}"#,
    );
    let e = eval_err(&["eval", "--fit", bad.to_str().unwrap(), a]);
    assert!(
        e.contains("invalid parameters for model lambert") && e.contains("rho0"),
        "{e}"
    );
}

/// A spectral fit (the bands of one measurement) at `--wavelength` or at each row's
/// `wavelength`: the band there, or the two around it blended linearly; a wavelength outside
/// the bands, or none for several bands, is refused with its line.
#[test]
fn a_spectral_fit_evaluates_at_each_rows_wavelength() {
    let dir = tempfile::tempdir().unwrap();
    let fits = write(
        &dir,
        "fits.json",
        r#"[{"dataset": "p.csv[wavelength=0.6]", "model": "lambert", "params": {"rho0": 0.5}},
            {"dataset": "p.csv[wavelength=0.5]", "model": "six", "params": {"kb": 0.2545, "kr": 21.8031, "b": -27.5721, "a": 0.6705, "kd": 0.3676, "c": 1.2}}]"#,
    );
    let f = fits.to_str().unwrap();
    let rows = write(
        &dir,
        "rows.csv",
        "theta_i,theta_r,phi,wavelength\n30,40,180,0.5\n30,40,180,0.575\n10,20,90,0.6\n30,40,180,0.5000\n",
    );
    let out = eval_ok(&["eval", "--fit", f, rows.to_str().unwrap()]);
    let v: Vec<f64> = out[1..].iter().map(|r| r[4].parse().unwrap()).collect();
    let six =
        AnyModel::<f64>::new(ModelKind::Six, &[0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2]).unwrap();
    let rad = f64::to_radians;
    let six_at = six.eval_angles(rad(30.0), rad(40.0), rad(180.0));
    let lambert = 0.5 / std::f64::consts::PI;
    assert!(
        (v[0] - six_at).abs() <= F64_REFERENCE_REL * six_at,
        "{} {six_at}",
        v[0]
    );
    let blend = 0.25 * six_at + 0.75 * lambert;
    assert!(
        (v[1] - blend).abs() <= F64_REFERENCE_REL * blend,
        "{} {blend}",
        v[1]
    );
    assert!((v[2] - lambert).abs() <= F64_REFERENCE_REL * lambert);
    assert_eq!(v[3], v[0], "0.5 and 0.5000 are one band");
    // --wavelength for rows without one; f32 within f32 rounding of f64.
    let plain = write(&dir, "plain.csv", "theta_i,theta_r,phi\n30,40,180\n");
    for precision in ["f64", "f32"] {
        let out = eval_ok(&[
            "eval",
            "--fit",
            f,
            "--wavelength",
            "0.575",
            "--precision",
            precision,
            plain.to_str().unwrap(),
        ]);
        let got: f64 = out[1][3].parse().unwrap();
        assert!((got - blend).abs() <= 1e-6 * blend, "{precision}: {got} {blend}");
    }
    // Refused: several bands and no wavelength; both a column and --wavelength; a wavelength
    // outside the bands (no extrapolation) or that is none, each with its line.
    let e = eval_err(&["eval", "--fit", f, plain.to_str().unwrap()]);
    assert!(
        e.contains("holds 2 bands of p.csv (0.5–0.6 µm): give --wavelength"),
        "{e}"
    );
    let e = eval_err(&["eval", "--fit", f, "--wavelength", "0.55", rows.to_str().unwrap()]);
    assert!(e.contains("both give the wavelength"), "{e}");
    let e = eval_err(&["eval", "--fit", f, "--wavelength", "0.7", plain.to_str().unwrap()]);
    assert!(e.contains("--wavelength") && e.contains("span 0.5–0.6 µm"), "{e}");
    // The flag's own hostile values: not wavelengths, refused naming the flag.
    for bad in ["nan", "inf", "-0.5", "0"] {
        let e = eval_err(&["eval", "--fit", f, "--wavelength", bad, plain.to_str().unwrap()]);
        assert!(
            e.contains("--wavelength") && e.contains("not a wavelength above 0"),
            "{bad}: {e}"
        );
    }
    let e = eval_err(&["eval", "--fit", f, "--wavelength", "", plain.to_str().unwrap()]);
    assert!(e.contains("--wavelength"), "{e}");
    let e = eval_err(&[
        "eval",
        "--model",
        "lambert",
        "--params",
        "rho0=0.5",
        "--wavelength",
        "0.5",
        plain.to_str().unwrap(),
    ]);
    assert!(e.contains("--wavelength"), "{e}");
    for (bad, says) in [
        ("0.45", "outside the bands"),
        ("x", "`x` is not a wavelength"),
        ("-0.5", "not a wavelength"),
        ("", "not a wavelength"),
    ] {
        let p = write(
            &dir,
            "bad.csv",
            &format!("theta_i,theta_r,phi,wavelength\n30,40,180,0.5\n30,40,180,{bad}\n"),
        );
        let e = eval_err(&["eval", "--fit", f, p.to_str().unwrap()]);
        assert!(
            e.contains("bad.csv: line 3: column wavelength") && e.contains(says),
            "{bad}: {e}"
        );
    }
    // A grey fit has no bands: the same at every wavelength, given by --wavelength (with a
    // note) or a column (passed through), as a scene takes it.
    let grey = write(
        &dir,
        "grey.json",
        r#"{"model": "lambert", "params": {"rho0": 0.5}}"#,
    );
    let out = brdf(&[
        "eval",
        "--fit",
        grey.to_str().unwrap(),
        "--wavelength",
        "0.5",
        plain.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("has no band: it is the same at every wavelength"));
    let v: f64 = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .nth(1)
        .unwrap()
        .rsplit(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!((v - lambert).abs() <= F64_REFERENCE_REL * lambert);
    let out = eval_ok(&["eval", "--fit", grey.to_str().unwrap(), rows.to_str().unwrap()]);
    assert_eq!(out[0], ["theta_i", "theta_r", "phi", "wavelength", "brdf"]);
}
