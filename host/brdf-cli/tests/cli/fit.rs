//! End-to-end tests of `brdf synth`, `brdf fit` and `brdf select`.

use std::sync::LazyLock;

/// Khaki (Table 1) as a `--params` argument.
static KHAKI: LazyLock<String> = LazyLock::new(|| brdf_tests::table1_params_arg(0));

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

fn repo(path: &str) -> String {
    format!("{}/../../{path}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn bundled_dataset_is_what_the_readme_says() {
    let made = ok(&[
        "synth",
        "--model",
        "six",
        "--params",
        &KHAKI,
        "--theta-i",
        "0,10,30",
        "--noise",
        "0.5%",
        "--seed",
        "7",
        "--step",
        "2.5",
    ]);
    let bundled = std::fs::read_to_string(repo("data/khaki-synthetic-inplane.csv")).unwrap();
    assert_eq!(made, bundled);
}

#[test]
fn fit_json_contract_and_flags() {
    let text = ok(&[
        "fit",
        &repo("data/khaki-synthetic-inplane.csv"),
        "--model",
        "six",
        "--json",
        "--seed",
        "3",
    ]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "model",
        "params",
        "metrics",
        "n",
        "seconds",
        "uncertainty",
        "energy",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    for key in ["rmse", "mse", "rms_rel", "max_rel", "log_rmse"] {
        assert!(v["metrics"][key].as_f64().is_some(), "missing metrics.{key}");
    }
    assert_eq!(v["model"], "six");
    assert_eq!(v["n"], 213);
    let kb = v["params"]["kb"].as_f64().unwrap();
    let truth = brdf_tests::TABLE1[0].1[0];
    assert!((kb - truth).abs() / truth < 0.05, "{kb}");
    // kr is not determined by in-plane data of a kr >> 1 material: flagged, not printed as known.
    assert_eq!(v["uncertainty"]["params"]["kr"]["determined"], false);
    assert_eq!(v["uncertainty"]["params"]["kd"]["determined"], true);
    assert_eq!(v["energy"]["bound_conserves"], true);
    // Same seed, same answer.
    let again: serde_json::Value = serde_json::from_str(&ok(&[
        "fit",
        &repo("data/khaki-synthetic-inplane.csv"),
        "--json",
        "--seed",
        "3",
    ]))
    .unwrap();
    assert_eq!(v["params"], again["params"]);
}

#[test]
fn batch_groups_shards_and_csv_output() {
    let dir = tempfile::tempdir().unwrap();
    let one = ok(&[
        "synth",
        "--model",
        "lambert",
        "--params",
        "rho0=0.5",
        "--theta-i",
        "0,30",
        "--noise",
        "1%",
    ]);
    let mut grouped = String::from("sample,theta_i,theta_s,brdf\n");
    for (k, s) in ["A", "B", "C"].iter().enumerate() {
        for line in one.lines().skip(1) {
            let mut f: Vec<String> = line.split(',').map(str::to_owned).collect();
            let y: f64 = f[2].parse().unwrap();
            f[2] = format!("{}", y * (1.0 + k as f64));
            grouped.push_str(&format!("{s},{}\n", f.join(",")));
        }
    }
    let path = dir.path().join("groups.csv");
    std::fs::write(&path, grouped).unwrap();
    let out_csv = dir.path().join("results.csv");
    let text = ok(&[
        "fit",
        path.to_str().unwrap(),
        "--model",
        "lambert",
        "--json",
        "-o",
        out_csv.to_str().unwrap(),
    ]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let arr = v.as_array().unwrap();
    assert_eq!(arr.len(), 3);
    for (k, r) in arr.iter().enumerate() {
        let rho = r["params"]["rho0"].as_f64().unwrap();
        assert!(
            (rho - 0.5 * (1.0 + k as f64)).abs() < 0.01 * (1.0 + k as f64),
            "{rho}"
        );
    }
    let table = std::fs::read_to_string(&out_csv).unwrap();
    assert_eq!(table.lines().count(), 4);
    assert!(table.lines().nth(2).unwrap().contains("[sample=B]"));
    // The parameters round-trip: the CSV holds the JSON's values exactly (it held 11
    // significant digits).
    for (k, line) in table.lines().skip(1).enumerate() {
        let fields: Vec<&str> = line.split(',').collect();
        let p0: f64 = fields[4].parse().unwrap();
        assert_eq!(p0, arr[k]["params"]["rho0"].as_f64().unwrap(), "{line}");
    }
    // Shard 1/2 takes the second dataset only.
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "fit",
        path.to_str().unwrap(),
        "--model",
        "lambert",
        "--json",
        "--shard",
        "1/2",
    ]))
    .unwrap();
    assert!(v["dataset"].as_str().unwrap().ends_with("[sample=B]"));
    let bad = brdf(&["fit", path.to_str().unwrap(), "--shard", "2/2"]);
    assert!(!bad.status.success());
}

#[test]
fn skip_invalid_lists_every_skipped_line() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = ok(&[
        "synth",
        "--model",
        "lambert",
        "--params",
        "rho0=0.5",
        "--theta-i",
        "0",
    ]);
    text.push_str("10,20,abc\n10,95,0.1\n");
    let path = dir.path().join("d.csv");
    std::fs::write(&path, &text).unwrap();
    let fail = brdf(&["fit", path.to_str().unwrap(), "--model", "lambert"]);
    assert!(!fail.status.success());
    let msg = String::from_utf8_lossy(&fail.stderr);
    assert!(
        msg.contains("d.csv") && msg.contains("column brdf: `abc` is not a number"),
        "{msg}"
    );
    let out = brdf(&[
        "fit",
        path.to_str().unwrap(),
        "--model",
        "lambert",
        "--skip-invalid",
    ]);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    let n = text.lines().count();
    assert!(err.contains(&format!("skipped line {}", n - 1)), "{err}");
    assert!(err.contains(&format!("skipped line {}", n)), "{err}");
    assert!(err.contains("2 line(s) skipped"), "{err}");
}

#[test]
fn select_chooses_a_nonphysical_model_only_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    // Minnaert data: Lambert cannot meet 2%, Minnaert can.
    let text = ok(&[
        "synth",
        "--model",
        "minnaert",
        "--params",
        "rho0=0.6,k=0.3",
        "--theta-i",
        "0,20,40",
        "--noise",
        "0.5%",
    ]);
    let path = dir.path().join("m.csv");
    std::fs::write(&path, text).unwrap();
    let select = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["select", path.to_str().unwrap(), "--budget", "2%", "--json"];
        args.extend_from_slice(extra);
        serde_json::from_str(&ok(&args)).unwrap()
    };
    // Minnaert with k = 0.3 is unbounded at grazing: listed and marked, never chosen unasked
    // (with k = 0.7 the microfacet model, physical and cheaper, fits within 2% up to 40°).
    let v = select(&[]);
    let models: Vec<&str> = v["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["model"].as_str().unwrap())
        .collect();
    assert_eq!(models, ["lambert", "minnaert", "ggx", "five", "six", "six-cos2"]);
    let minnaert = v["representations"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["name"] == "minnaert exact")
        .unwrap();
    assert_eq!(minnaert["bounded"], false);
    assert_ne!(v["chosen"], "minnaert exact");
    let reason = v["reason"].as_str().unwrap();
    assert!(
        v["chosen"].is_string() || reason.contains("not chosen without --allow-nonphysical: minnaert exact"),
        "{reason}"
    );
    let v = select(&["--allow-nonphysical"]);
    assert_eq!(v["chosen"], "minnaert exact", "{}", v["reason"]);
    // One decision, one reason in the text output.
    let table = ok(&[
        "select",
        path.to_str().unwrap(),
        "--max-theta",
        "40",
        "--allow-nonphysical",
    ]);
    assert_eq!(table.matches("chosen:").count(), 1, "{table}");
    assert!(table.contains("chosen: minnaert exact: the cheapest"), "{table}");
}

#[test]
fn select_names_the_cheapest_representation_and_writes_its_blob() {
    let dir = tempfile::tempdir().unwrap();
    let data = repo("data/khaki-synthetic-inplane.csv");
    let blob = dir.path().join("scene.bin");
    // 1%: only the six-parameter fits meet it; the 64-node table is the cheapest of those
    // on the device (285 against 753 instructions) and the smallest table.
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "select",
        &data,
        "--budget",
        "1%",
        "--max-theta-i",
        "40",
        "--max-theta-r",
        "60",
        "--json",
        "-o",
        blob.to_str().unwrap(),
    ]))
    .unwrap();
    assert_eq!(v["chosen"], "six table 64");
    let reprs = v["representations"].as_array().unwrap();
    let names: Vec<&str> = reprs.iter().map(|r| r["name"].as_str().unwrap()).collect();
    assert!(
        names.contains(&"six table 1024") && names.contains(&"lambert exact"),
        "{names:?}"
    );
    let big = reprs.iter().find(|r| r["name"] == "six table 1024").unwrap();
    assert_eq!(big["fits_blob"], false);
    let bytes = std::fs::read(&blob).unwrap();
    let b = brdf_wire::blob::Blob::decode(&bytes).unwrap();
    assert_eq!(b.materials.len(), 1);
    assert_eq!(b.materials[0].table.map(|t| t.nodes), Some(64));
    // A budget Lambert meets within 40 degrees: the cheapest representation of all.
    let v: serde_json::Value = serde_json::from_str(&ok(&[
        "select",
        &data,
        "--budget",
        "40%",
        "--max-theta",
        "40",
        "--json",
    ]))
    .unwrap();
    assert_eq!(v["chosen"], "lambert exact");
    // A budget nothing meets: the most accurate by held-out error is chosen and written, with
    // a warning, exit 0; --chosen writes its fit as `brdf fit --json` does, which `pack` reads.
    let chosen = dir.path().join("chosen.json");
    let none = brdf(&[
        "select",
        &data,
        "--budget",
        "0.01%",
        "-o",
        blob.to_str().unwrap(),
        "--chosen",
        chosen.to_str().unwrap(),
        "--json",
    ]);
    assert!(none.status.success(), "{}", String::from_utf8_lossy(&none.stderr));
    let err = String::from_utf8_lossy(&none.stderr);
    assert!(
        err.contains("warning: nothing meets the 0.01% budget")
            && err.contains("chosen as the most accurate"),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_slice(&none.stdout).unwrap();
    assert_eq!(v["within_budget"], false);
    let cv = |r: &serde_json::Value| r["cv_rms_rel"].as_f64().unwrap_or(f64::INFINITY);
    let reprs = v["representations"].as_array().unwrap();
    let best = reprs
        .iter()
        .filter(|r| r["fits_blob"] == true && r["reciprocal"] == true && r["bounded"] == true)
        .min_by(|a, b| cv(a).total_cmp(&cv(b)))
        .unwrap();
    assert_eq!(v["chosen"], best["name"]);
    let mut fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&chosen).unwrap()).unwrap();
    assert_eq!(fit["model"], best["model"]);
    // A fitted table is written with its base fit; any other rung is its fit alone.
    let table = fit.as_object_mut().unwrap().remove("fitted_table");
    assert_eq!(table.is_some(), best["name"] == "ggx + table", "{}", best["name"]);
    let i = v["chosen_fit"].as_u64().unwrap() as usize;
    assert_eq!(fit, v["candidates"][i]);
    let packed = dir.path().join("packed.bin");
    ok(&["pack", chosen.to_str().unwrap(), "-o", packed.to_str().unwrap()]);
}

#[test]
fn select_chooses_by_held_out_error_not_training_error() {
    // Before: `brdf select` ranked by the error over the points each model was fitted to, so
    // a richer model won by fitting the noise. Now a rung whose training error meets the
    // budget but whose held-out error does not is never chosen.
    let dir = tempfile::tempdir().unwrap();
    let text = ok(&[
        "synth",
        "--model",
        "minnaert",
        "--params",
        "rho0=0.6,k=0.9",
        "--theta-i",
        "0,30,50",
        "--noise",
        "3%",
    ]);
    let path = dir.path().join("m.csv");
    std::fs::write(&path, text).unwrap();
    let select = |budget: &str| -> serde_json::Value {
        serde_json::from_str(&ok(&[
            "select",
            path.to_str().unwrap(),
            "--budget",
            budget,
            "--json",
            "--allow-nonphysical",
        ]))
        .unwrap()
    };
    let v = select("2%");
    let reprs = v["representations"].as_array().unwrap();
    for r in reprs {
        let (train, held) = (r["rms_rel"].as_f64().unwrap(), r["cv_rms_rel"].as_f64());
        let held = held.unwrap_or_else(|| panic!("{} was not cross-validated", r["name"]));
        assert!(held.is_finite() && held > 0.0, "{r}");
        // Held-out points were not fitted: on noisy data they are predicted worse.
        assert!(held > train, "{}: held-out {held} <= training {train}", r["name"]);
    }
    // The budget between the cheapest rung's training and held-out errors.
    let cheapest = reprs
        .iter()
        .min_by_key(|r| r["device_instructions"].as_u64().unwrap())
        .unwrap();
    let (train, held) = (
        cheapest["rms_rel"].as_f64().unwrap(),
        cheapest["cv_rms_rel"].as_f64().unwrap(),
    );
    let budget = format!("{}", 0.5 * (train + held));
    let v = select(&budget);
    assert_ne!(v["chosen"], cheapest["name"], "{}", v["reason"]);
    assert!(
        v["reason"]
            .as_str()
            .unwrap()
            .contains("held-out RMS relative error"),
        "{}",
        v["reason"]
    );
}

#[test]
fn pack_builds_a_blob_the_firmware_format_reads_and_refuses_bad_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let six = ok(&["fit", &repo("data/khaki-synthetic-inplane.csv"), "--json"]);
    let lam = ok(&[
        "fit",
        &repo("data/khaki-synthetic-inplane.csv"),
        "--model",
        "lambert",
        "--json",
    ]);
    let (a, b) = (dir.path().join("six.json"), dir.path().join("lambert.json"));
    std::fs::write(&a, &six).unwrap();
    std::fs::write(&b, &lam).unwrap();
    let out = dir.path().join("p.bin");
    ok(&[
        "pack",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--sequence",
        "9",
    ]);
    let blob = brdf_wire::blob::Blob::decode(&std::fs::read(&out).unwrap()).unwrap();
    assert_eq!(blob.sequence, 9);
    assert_eq!(blob.materials.len(), 2);
    let v: serde_json::Value = serde_json::from_str(&six).unwrap();
    assert_eq!(blob.materials[0].kind, brdf_core::ModelKind::Six);
    assert_eq!(
        blob.materials[0].params[0],
        v["params"]["kb"].as_f64().unwrap() as f32
    );
    assert_eq!(blob.materials[1].kind, brdf_core::ModelKind::Lambert);
    // Invalid parameters are refused, naming the file.
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, six.replacen("\"kb\": ", "\"kb\": -", 1)).unwrap();
    let r = brdf(&["pack", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert!(!r.status.success());
    let msg = String::from_utf8_lossy(&r.stderr);
    assert!(msg.contains("bad.json") && msg.contains("kb"), "{msg}");
}

#[test]
fn angular_limits_keep_points_at_the_limit_and_say_what_they_drop() {
    // The Cornell importer stores the 40 deg incidence as 40.000017 deg (radians in the file).
    let garnet = brdf_tests::measured("cornell-medium-gloss-paints/garnet_red_RGB.astm");
    let n = |limit: &str| -> (u64, String) {
        let out = brdf(&[
            "select",
            "--format",
            "cornell",
            garnet.to_str().unwrap(),
            "--max-theta-i",
            limit,
            "--budget",
            "90%",
            "--json",
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (
            v["n"].as_u64().unwrap(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (at, said) = n("40");
    let (below, _) = n("39.99");
    assert!(
        at > below + 100,
        "40 deg keeps the 40 deg incidence: {at} against {below}"
    );
    assert!(
        said.contains("left out") && said.contains("theta_i > 40 deg"),
        "{said}"
    );
}

#[test]
fn every_fitting_command_refuses_repeated_directions() {
    // Eight readings of one direction pair (and its mirror-azimuth twin): enough rows for
    // `select`, one direction for the models' two or more parameters.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("one-direction.csv");
    let mut text = String::from("theta_i,theta_r,phi,brdf\n");
    for k in 0..8 {
        let phi = if k % 2 == 0 { 30 } else { -30 };
        text.push_str(&format!("20,35,{phi},{}\n", 0.1 + 0.001 * k as f64));
    }
    std::fs::write(&path, text).unwrap();
    let p = path.to_str().unwrap();
    let png = dir.path().join("p.png");
    for args in [
        vec!["fit", p],
        vec!["fit", p, "--model", "minnaert"],
        vec!["plot", "in-plane", p, "-o", png.to_str().unwrap()],
    ] {
        let out = brdf(&args);
        assert!(!out.status.success(), "{args:?} fitted one direction");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("1 distinct direction(s) cannot determine"),
            "{args:?}: {err}"
        );
    }
    // `select` compares what the data can determine (Lambert's one parameter) and names the
    // models it left out.
    let out = brdf(&["select", p, "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let models: Vec<&str> = v["candidates"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["model"].as_str().unwrap())
        .collect();
    assert_eq!(models, ["lambert"]);
    let notes = v["notes"].as_array().unwrap();
    // Five models not fitted, and no fitted table for 8 points.
    assert_eq!(notes.len(), 6, "{notes:?}");
    assert!(
        notes[5]
            .as_str()
            .unwrap()
            .starts_with("fitted table: not offered"),
        "{notes:?}"
    );
    assert!(
        notes[0].as_str().unwrap().starts_with("minnaert: not fitted: "),
        "{notes:?}"
    );
    // A batch with one such dataset fails before it writes anything.
    let good = repo("data/khaki-synthetic-inplane.csv");
    let rows = dir.path().join("rows.csv");
    let out = brdf(&["fit", "--json", &good, p, "-o", rows.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(out.stdout.is_empty(), "{}", String::from_utf8_lossy(&out.stdout));
    assert!(!rows.exists(), "the CSV was started");
    // With --skip-invalid the batch fits the rest and lists the dataset it left out; with
    // nothing left it fails.
    let out = brdf(&["fit", "--json", "--skip-invalid", &good, p]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        v["dataset"]
            .as_str()
            .unwrap()
            .ends_with("khaki-synthetic-inplane.csv"),
        "{v}"
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!(
            "skipped dataset {p}: 1 distinct direction(s) cannot determine"
        )),
        "{err}"
    );
    // The CSV has a row for the dataset left out, saying why (it had none).
    let out = brdf(&["fit", "--skip-invalid", &good, p, "-o", rows.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&rows).unwrap();
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let header = reader.headers().unwrap().clone();
    let records: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
    assert_eq!(records.len(), 2, "{text}");
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let left = records
        .iter()
        .find(|r| r[col("dataset")] == *p)
        .expect("a row for the skipped dataset");
    assert_eq!((&left[col("converged")], &left[col("model")]), ("false", "six"));
    assert!(
        left[col("flags")].starts_with("not fitted: ") && left[col("rms_rel")].is_empty(),
        "{text}"
    );
    assert!(records.iter().any(
        |r| r[col("dataset")].ends_with("khaki-synthetic-inplane.csv") && &r[col("converged")] == "true"
    ));
    let out = brdf(&["fit", "--skip-invalid", p]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no dataset left to fit: all 1 were skipped"));
}

#[test]
fn select_judges_every_model_on_few_points_and_guards_its_outputs() {
    // Seven exact six-parameter points: five folds would leave five points to refit six
    // parameters, so the six-parameter model would go unjudged and Lambert win at 300%.
    // Leave-one-out judges it.
    let dir = tempfile::tempdir().unwrap();
    let exact = ok(&[
        "synth",
        "--model",
        "six",
        "--params",
        &KHAKI,
        "--theta-i",
        "0,10,30",
        "--step",
        "5",
    ]);
    let mut lines = exact.lines();
    let mut seven = format!("{}\n", lines.next().unwrap());
    for l in lines.step_by(15).take(7) {
        seven.push_str(l);
        seven.push('\n');
    }
    let path = dir.path().join("seven.csv");
    std::fs::write(&path, seven).unwrap();
    let p = path.to_str().unwrap();
    let v: serde_json::Value = serde_json::from_str(&ok(&["select", p, "--json"])).unwrap();
    let chosen = v["chosen"].as_str().unwrap();
    assert!(chosen.starts_with("six"), "{chosen}: {}", v["reason"]);
    assert!(
        v["reason"].as_str().unwrap().contains("leave-one-out"),
        "{}",
        v["reason"]
    );
    // -o and --chosen may not name the same file; a budget must be above 0.
    let same = dir.path().join("same");
    let s = same.to_str().unwrap();
    let out = brdf(&["select", p, "-o", s, "--chosen", s]);
    assert!(!out.status.success() && !same.exists());
    assert!(String::from_utf8_lossy(&out.stderr).contains("name the same file"));
    let out = brdf(&["select", p, "--budget", "0"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("budget 0 is not a finite fraction greater than 0"));
}

#[test]
fn options_that_would_be_ignored_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = repo("data/khaki-synthetic-inplane.csv");
    // Weighted data for the embedded engine, which weighs every point alike.
    let text = std::fs::read_to_string(&data).unwrap();
    let mut weighted = String::new();
    for (i, l) in text.lines().enumerate() {
        weighted.push_str(l);
        weighted.push_str(if i == 0 { ",weight\n" } else { ",2\n" });
    }
    let w = dir.path().join("w.csv");
    std::fs::write(&w, weighted).unwrap();
    let ws = w.to_str().unwrap();
    for (args, says) in [
        (
            vec!["fit", "--engine", "embedded", ws],
            "the embedded engine weighs every point alike",
        ),
        (
            vec!["fit", "--engine", "embedded", "--hops", "2", &data],
            "hops applies to the full engine only",
        ),
        (
            vec!["fit", "--budget-evals", "5000", &data],
            "budget_evals applies to the embedded engine only",
        ),
        (
            vec!["fit", "--loss-scale", "0.05", &data],
            "loss_scale scales a robust loss",
        ),
        (
            vec!["fit", "--channel", "g", &data],
            "channel g applies to the cornell format only",
        ),
        (
            vec!["fit", "--agree", "10", "--chains", "4", &data],
            "agree 10 is more than chains 4",
        ),
        (
            vec!["fit", ws, "-o", ws],
            "is one of the data files: it would be overwritten",
        ),
    ] {
        let out = brdf(&args);
        assert!(!out.status.success(), "{args:?} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{args:?}: {err}");
    }
    let kept = std::fs::read_to_string(&w).unwrap();
    assert!(
        kept.starts_with("theta_i") && kept.lines().count() > 100,
        "the data were overwritten"
    );
}

/// A spectral Cornell file: `brdf import` writes every reading of every band with its
/// wavelength (µm), zeros included; `--band` picks one, or says which bands there are;
/// `brdf fit --format cornell --band` fits a dark band with every reading and the report
/// states the noise floor; `--noise-floor 0` refuses the dark readings naming a line.
#[test]
fn spectral_files_import_every_band_and_fit_dark_bands_with_a_noise_floor() {
    let astm = repo("data/measured/cornell-spectral/krylon_blue.astm");
    let csv = ok(&["import", "cornell", &astm]);
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("theta_i,theta_r,phi,brdf,wavelength"));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 31 * 1439);
    let zeros = rows
        .iter()
        .filter(|r| r[3].parse::<f64>().unwrap() <= 0.0)
        .count();
    assert_eq!(zeros, 1218, "every reading at zero kept");
    assert_eq!((rows[0][4], rows[31 * 1439 - 1][4]), ("0.4", "0.7"));
    // The canonical CSV reads back as 31 datasets, one per wavelength.
    let dir = tempfile::tempdir().unwrap();
    let one = ok(&["import", "cornell", &astm, "--band", "0.4"]);
    assert_eq!(one.lines().count(), 1440);
    let path = dir.path().join("krylon-400.csv");
    std::fs::write(&path, &one).unwrap();
    let json = ok(&["fit", "--model", "lambert", "--json", path.to_str().unwrap()]);
    let r: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(
        r["dataset"].as_str().unwrap().ends_with("[wavelength=0.4]"),
        "{}",
        r["dataset"]
    );
    assert_eq!(r["n"], 1439);
    assert_eq!(r["noise_floor"]["source"], "estimated");
    assert_eq!(r["noise_floor"]["at_or_below_zero"], 194);
    // The same band read on the fly.
    let json = ok(&[
        "fit", "--model", "lambert", "--json", "--format", "cornell", "--band", "0.4", &astm,
    ]);
    let direct: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(direct["params"], r["params"]);
    // The floored fit reads back: it packs into a blob.
    let fits = dir.path().join("krylon-400.json");
    std::fs::write(&fits, &json).unwrap();
    let blob = dir.path().join("krylon-400.bin");
    ok(&["pack", fits.to_str().unwrap(), "-o", blob.to_str().unwrap()]);
    assert!(std::fs::metadata(&blob).unwrap().len() > 0);
    // With a byte-order mark (an editor on Windows) it reads the same: it was refused.
    std::fs::write(&fits, format!("\u{feff}{json}")).unwrap();
    let again = dir.path().join("krylon-400-bom.bin");
    ok(&["pack", fits.to_str().unwrap(), "-o", again.to_str().unwrap()]);
    assert_eq!(std::fs::read(&again).unwrap(), std::fs::read(&blob).unwrap());
    let given = ok(&[
        "fit",
        "--model",
        "lambert",
        "--json",
        "--noise-floor",
        "0.01",
        path.to_str().unwrap(),
    ]);
    let given: serde_json::Value = serde_json::from_str(&given).unwrap();
    assert_eq!(
        (
            given["noise_floor"]["source"].as_str(),
            given["noise_floor"]["value"].as_f64()
        ),
        (Some("given"), Some(0.01))
    );
    // A given floor above most readings gets the warning an estimated one gets.
    let out = brdf(&[
        "fit",
        "--model",
        "lambert",
        "--noise-floor",
        "100",
        path.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && err.contains("the given noise floor 100 1/sr lies above"),
        "{err}"
    );
    for (args, says) in [
        (
            vec!["import", "cornell", &astm, "--band", "0.405"],
            "no band at 0.405 um; its bands are 0.4, 0.41, 0.42",
        ),
        (vec!["import", "cornell", &astm, "--channel", "r"], "spectral"),
        (
            vec!["import", "merl-inplane", &astm, "--band", "0.4"],
            "cornell and nist formats only",
        ),
        (vec!["fit", "--noise-floor", "0", path.to_str().unwrap()], "line "),
        (
            vec!["fit", "--noise-floor=-1", path.to_str().unwrap()],
            "at or above 0",
        ),
        (
            vec!["fit", "--noise-floor", "nan", path.to_str().unwrap()],
            "at or above 0",
        ),
        // Every residual underflowed to 0: a grid node "converged" at 0.000%.
        (
            vec!["fit", "--noise-floor", "1e200", path.to_str().unwrap()],
            "neither 0 nor within [1e-100, 1e100]",
        ),
        (
            vec!["fit", "--residual", "log", path.to_str().unwrap()],
            "logarithm",
        ),
        (
            vec![
                "fit",
                "--residual",
                "log",
                "--noise-floor",
                "0.1",
                path.to_str().unwrap(),
            ],
            "ignored",
        ),
        (
            vec![
                "fit", "--format", "cornell", "--bands", "shared", "--shard", "0/2", &astm,
            ],
            "--shard splits the bands",
        ),
        (
            vec!["fit", "--bands", "shared", path.to_str().unwrap()],
            "no two datasets are bands",
        ),
        (
            vec!["select", "--bands", "shared", "--format", "cornell", &astm],
            "it would be ignored",
        ),
        (vec!["fit", "--bands", "both", path.to_str().unwrap()], "bands"),
        (vec!["fit", "--bands", "", path.to_str().unwrap()], "bands"),
        (
            vec!["import", "cornell", &astm, "--band", "nan"],
            "greater than 0",
        ),
        (vec!["import", "cornell", &astm, "--band=-0.4"], "greater than 0"),
        (vec!["import", "cornell", &astm, "--band", ""], "greater than 0"),
        (
            vec!["import", "cornell", &astm, "--band", "0.4", "--channel", "r"],
            "not both",
        ),
        (
            vec!["fit", "--format", "cornell", "--band", "inf", &astm],
            "greater than 0",
        ),
        (
            vec!["fit", "--noise-floor", "", path.to_str().unwrap()],
            "at or above 0",
        ),
        (
            vec![
                "fit",
                "--engine",
                "embedded",
                "--noise-floor",
                "0.1",
                path.to_str().unwrap(),
            ],
            "noise_floor",
        ),
    ] {
        let out = brdf(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says), "{args:?}: {err}");
    }
}

/// The documented smallest steps asked for 1.6e8 points, all held in memory, and the process
/// died of it; the count is bounded and checked before anything is made.
#[test]
fn synth_refuses_more_points_than_it_holds() {
    let synth = |step: &str| {
        brdf(&[
            "synth",
            "--model",
            "lambert",
            "--params",
            "rho0=0.5",
            "--theta-i",
            "10",
            "--form",
            "full",
            "--step",
            step,
            "--phi-step",
            step,
        ])
    };
    let out = synth("0.01");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("1.620e8 points") && err.contains("at most 1e7"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
    let full = synth("1");
    assert!(full.status.success());
    assert_eq!(
        String::from_utf8_lossy(&full.stdout).lines().count(),
        1 + 90 * 181
    );
}

/// The bands of a spectral file against wavelength: `brdf fit` tabulates them after their
/// reports (one row per band, the weights marked), `brdf plot spectrum` draws them and prints
/// the same table; a file without bands, or one band, is refused by name.
#[test]
fn the_bands_of_a_spectral_file_are_tabulated_and_drawn_against_wavelength() {
    let data = brdf_tests::measured("cornell-spectral/krylon_blue.astm");
    let data = data.to_str().unwrap();
    let fit = brdf(&["fit", "--format", "cornell", data]);
    assert!(fit.status.success(), "{}", String::from_utf8_lossy(&fit.stderr));
    let text = String::from_utf8_lossy(&fit.stdout);
    let head = format!("{data}: 31 bands, six (kb, kd the weights, per band; the rest the shape)");
    let at = text.find(&head).unwrap_or_else(|| panic!("{text}"));
    let table: Vec<&str> = text[at..].lines().skip(2).take(31).collect();
    assert!(table[0].trim_start().starts_with("0.4 ") && table[30].trim_start().starts_with("0.7 "));
    // Each row: wavelength, six parameters, albedo, error; the reports' own values.
    let row: Vec<&str> = table[5].split_whitespace().collect();
    assert_eq!(row.len(), 9, "{row:?}");
    assert!(text.contains("[wavelength=0.45]: model six"));
    // Dark readings make ln f undefined: said in words, not NaN.
    assert!(!text.contains("NaN"), "{text}");
    // The same file twice: every band twice, so no table (it listed 62 bands, each twice).
    let twice = brdf(&["fit", "--format", "cornell", data, data]);
    assert!(twice.status.success());
    assert!(!String::from_utf8_lossy(&twice.stdout).contains("bands, six"));

    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("s.png");
    let plot = brdf(&[
        "plot",
        "spectrum",
        "--format",
        "cornell",
        data,
        "-o",
        png.to_str().unwrap(),
    ]);
    assert!(plot.status.success(), "{}", String::from_utf8_lossy(&plot.stderr));
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
    assert_eq!(String::from_utf8_lossy(&plot.stdout), text[at..]);
    let one = brdf(&[
        "plot",
        "spectrum",
        "--format",
        "cornell",
        "--band",
        "0.55",
        data,
        "-o",
        png.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&one.stderr);
    assert!(
        !one.status.success() && err.contains("no spectral measurement with two or more bands"),
        "{err}"
    );
}

/// Before: `Sample`, `Wavelength`, `Sigma` or `Weight` in capitals were ignored (two samples
/// 1e4 apart in brightness fitted as one, exit 0) while `Theta_i` was "missing". A column
/// that differs from a known one only in case is refused, naming file, line and spelling.
#[test]
fn a_known_column_in_another_case_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    for (column, spelt) in [
        ("Sample", "sample"),
        ("WAVELENGTH", "wavelength"),
        ("Sigma", "sigma"),
        ("Weight", "weight"),
        ("Theta_i", "theta_i"),
    ] {
        // The fifth column is the one in another case, or for a required one `sample`.
        let mut text = if spelt == "theta_i" {
            format!("{column},theta_r,phi,brdf,sample\n")
        } else {
            format!("theta_i,theta_r,phi,brdf,{column}\n")
        };
        for (k, (sample, value)) in [("1", 0.15), ("2", 1.5e3)].into_iter().enumerate() {
            for tr in [0, 20, 40, 60] {
                text.push_str(&format!("{},{tr},0,{value},{sample}\n", 10 * k));
            }
        }
        let path = dir.path().join(format!("{column}.csv"));
        std::fs::write(&path, text).unwrap();
        let out = brdf(&["fit", "--model", "lambert", path.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{column}: accepted");
        assert!(
            err.contains(path.to_str().unwrap())
                && err.contains(&format!("line 1: column `{column}` must be spelt `{spelt}`")),
            "{column}: {err}"
        );
    }
}

/// Before: a near miss of an optional column (`samples`, `weights`, `wavelength_um`) was an
/// extra column, ignored: two samples fitted as one material (reported converged), a
/// weighted file fitted unweighted. It is refused like a column in another case, naming the
/// file, the column, the spelling and how to keep an unrelated column, which is still
/// ignored once renamed.
#[test]
fn a_near_miss_of_a_known_column_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, column: &str| {
        let mut text = format!("theta_i,theta_r,phi,brdf,{column}\n");
        for (k, (sample, value)) in [("1", 0.15), ("2", 1.5e3)].into_iter().enumerate() {
            for tr in [0, 20, 40, 60] {
                text.push_str(&format!("{},{tr},0,{value},{sample}\n", 10 * k));
            }
        }
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_owned()
    };
    let spelt = |c: &str| format!("must be spelt `{c}`");
    let nm = "`wavelength`, in µm (divide nm by 1000".to_owned();
    let begins = |c: &str| format!("begins with that of the optional column `{c}`");
    for (column, expected, says) in [
        ("samples", "sample", spelt("sample")),
        ("weights", "weight", spelt("weight")),
        ("sigmas", "sigma", spelt("sigma")),
        ("wavelength_um", "wavelength", spelt("wavelength")),
        ("wavelenght", "wavelength", spelt("wavelength")),
        ("Samples", "sample", spelt("sample")),
        // Renamed `wavelength` as the refusal once said, bands of nm read as µm.
        ("wavelength (nm)", "wavelength", nm.clone()),
        ("wavelength_nanometres", "wavelength", nm.clone()),
        // Read as nothing, two samples fitted as one.
        ("sample_id", "sample", begins("sample")),
        ("wavelength_band", "wavelength", begins("wavelength")),
    ] {
        let path = write(&format!("{column}.csv"), column);
        let out = brdf(&["fit", "--model", "lambert", &path]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{column}: accepted");
        assert!(
            err.contains(&path)
                && err.contains(&format!("line 1: column `{column}` "))
                && err.contains(&says)
                && err.contains(&format!(
                    "rename it so that its name does not begin with `{expected}`, e.g. `x_{column}`"
                )),
            "{column}: {err}"
        );
    }
    // Renamed as suggested, or unlike any known name, or only like one: ignored, one
    // dataset of 8 points.
    for column in [
        "x_samples",
        "operator",
        "x_sample_id",
        "simple",
        "sample2",
        "phi_m",
    ] {
        let path = write(&format!("{column}.csv"), column);
        let out = ok(&["fit", "--model", "lambert", "--json", &path]);
        let r: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(r["n"], 8, "{column}");
    }
    // Spelt right, the two samples are two fits.
    let path = write("sample.csv", "sample");
    let out = ok(&["fit", "--model", "lambert", "--json", &path]);
    let r: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(r.as_array().map(Vec::len), Some(2), "{out}");
}

/// Before: files named `m[wavelength=0.5]` and `m[wavelength=0.6]` (two materials) fitted as
/// datasets of those names, and `brdf pack` read them as two bands of one material `m`.
/// A file name ending in `]` is refused, as a sample name holding the delimiters is.
#[test]
fn a_file_named_like_a_band_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = ok(&["synth", "--model", "lambert", "--params", "rho0=0.5"]);
    let mut paths = Vec::new();
    for band in ["0.5", "0.6"] {
        let path = dir.path().join(format!("m[wavelength={band}]"));
        std::fs::write(&path, &data).unwrap();
        paths.push(path.to_str().unwrap().to_owned());
    }
    let out = brdf(&["fit", "--model", "lambert", "--json", &paths[0], &paths[1]]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "accepted: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(
        err.contains(&paths[0]) && err.contains("a file name ending in `]` cannot name datasets"),
        "{err}"
    );
    // A bracket elsewhere in the name is read as written.
    let path = dir.path().join("m[1].csv");
    std::fs::write(&path, &data).unwrap();
    let out = ok(&["fit", "--model", "lambert", "--json", path.to_str().unwrap()]);
    let r: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(r["dataset"], path.to_str().unwrap());
}

/// Before: the embedded engine held `kd` to [0, 10] in the data's own units without a word
/// (its fit always reads "converged: false" for its fixed budget, so nothing told). Its box
/// now bounds the weights relative to the largest reading, and a weight that ends on the
/// bound is said in the text, on standard error, in the JSON and in the CSV flags.
#[test]
fn the_embedded_engine_says_when_a_weight_ends_on_its_search_bound() {
    let dir = tempfile::tempdir().unwrap();
    // Grazing only, c = 4: the diffuse term is tiny and kd must be far above the readings.
    let all = ok(&[
        "synth",
        "--model",
        "six",
        "--params",
        "kb=0,kr=21.8,b=-27.6,a=0.67,kd=0.5,c=4",
        "--form",
        "full",
        "--theta-i",
        "70,75",
        "--step",
        "2.5",
        "--phi-step",
        "45",
    ]);
    let mut lines = all.lines();
    let mut text = format!("{}\n", lines.next().unwrap());
    for l in lines {
        let tr: f64 = l.split(',').nth(1).unwrap().parse().unwrap();
        if tr >= 70.0 {
            text.push_str(l);
            text.push('\n');
        }
    }
    let grazing = dir.path().join("grazing.csv");
    std::fs::write(&grazing, text).unwrap();
    let grazing = grazing.to_str().unwrap();
    let out = brdf(&["fit", "--engine", "embedded", grazing]);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stderr}");
    let said = "is on the embedded engine's search bound (10 times the largest reading";
    assert!(
        stdout.contains("  on the search bound: kd = ") && stdout.contains(said),
        "{stdout}"
    );
    assert!(
        stderr.contains(&format!("warning: {grazing}: kd = ")) && stderr.contains(said),
        "{stderr}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&ok(&["fit", "--engine", "embedded", "--json", grazing])).unwrap();
    let notes = r["search"]["on_search_box"].as_array().expect("on_search_box");
    assert_eq!(notes.len(), 1, "{notes:?}");
    let csv = dir.path().join("fits.csv");
    ok(&[
        "fit",
        "--engine",
        "embedded",
        grazing,
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(std::fs::read_to_string(&csv).unwrap().contains(said));
    // Nothing is said of a fit inside the box.
    let full = dir.path().join("full.csv");
    std::fs::write(
        &full,
        ok(&[
            "synth",
            "--model",
            "six",
            "--params",
            KHAKI.as_str(),
            "--form",
            "full",
        ]),
    )
    .unwrap();
    let out = brdf(&["fit", "--engine", "embedded", full.to_str().unwrap()]);
    assert!(
        out.status.success() && out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!String::from_utf8_lossy(&out.stdout).contains("search bound:"));
}

/// Before: a file whose zeniths were written in radians was fitted as degrees without a
/// word (35% off, exit 0). It is still read as written, with a warning; the same directions
/// in degrees, and a set at normal incidence only, are not warned about.
#[test]
fn zeniths_that_look_like_radians_are_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, scale: f64, zeniths: &[f64]| {
        let mut text = String::from("theta_i,theta_r,phi,brdf\n");
        for &ti in &zeniths[..3] {
            for &tr in zeniths {
                text.push_str(&format!("{},{},0,0.15\n", ti * scale, tr * scale));
            }
        }
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        path
    };
    let radians = [0.0, 0.3, 0.6, 0.9, 1.2, 1.5];
    let warned = |path: &std::path::Path| {
        let out = brdf(&["fit", "--model", "lambert", path.to_str().unwrap()]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        err.contains("look like radians") && err.contains(path.to_str().unwrap())
    };
    assert!(warned(&write("radians.csv", 1.0, &radians)));
    assert!(!warned(&write(
        "degrees.csv",
        180.0 / std::f64::consts::PI,
        &radians
    )));
    // Normal incidence and views within a degree of it.
    assert!(!warned(&write(
        "boresight.csv",
        1.0,
        &[0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    )));
}

/// The importers whose angles are degrees (NIST, MERL in-plane) warn as the CSV reader does,
/// for `brdf import` and for a fit through `--format`; before, only CSV files were checked.
#[test]
fn imported_zeniths_that_look_like_radians_are_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("radians.merl");
    let mut text = String::from("# phi_in theta_in phi_out theta_out brdf\n");
    for ti in [0.0, 0.3, 0.6] {
        for tr in [-1.2, -0.6, 0.3, 0.9, 1.5] {
            text.push_str(&format!("{ti} 180 {tr} 0 0.15\n"));
        }
    }
    std::fs::write(&path, text).unwrap();
    let file = path.to_str().unwrap();
    let out_csv = dir.path().join("out.csv");
    for args in [
        vec!["fit", "--model", "lambert", "--format", "merl-inplane", file],
        vec!["import", "merl-inplane", file, "-o", out_csv.to_str().unwrap()],
    ] {
        let out = brdf(&args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.matches("look like radians").count(), 1, "{args:?}: {err}");
        assert!(err.contains(file), "{err}");
    }
}

/// Before: `--budget 2` and `--noise 2` meant 200% (`--noise 50` wrote readings of 4e14). A
/// fraction above 100% is refused; written without `%`, the message says how to write it.
#[test]
fn fractions_above_one_hundred_percent_are_refused() {
    let synth = |noise: &str| {
        brdf(&[
            "synth",
            "--model",
            "lambert",
            "--params",
            "rho0=0.5",
            "--theta-i",
            "0",
            "--noise",
            noise,
        ])
    };
    for (noise, want) in [
        ("2", "for 2 percent write 2% (or 0.02)"),
        ("50", "for 50 percent write 50%"),
        ("150%", "`150%` is above 100%"),
    ] {
        let out = synth(noise);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(want),
            "--noise {noise}: {err}"
        );
    }
    for noise in ["2%", "0.02", "100%", "1"] {
        let out = synth(noise);
        assert!(
            out.status.success(),
            "--noise {noise}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let data = repo("data/khaki-synthetic-inplane.csv");
    let out = brdf(&["select", &data, "--budget", "2"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("write 2%"), "{err}");
}

/// Before: the text table printed parameters with six decimals, so a reflectance in other
/// units (data scaled by 1e-6) read `0.000000` while the JSON held 2e-7. Every parameter
/// (and standard error) keeps six significant figures, whatever its magnitude.
#[test]
fn the_text_table_keeps_small_parameters_significant() {
    let dir = tempfile::tempdir().unwrap();
    let text = ok(&["synth", "--model", "six", "--params", &KHAKI, "--noise", "1%"]);
    let mut lines = text.lines();
    let mut scaled = format!("{}\n", lines.next().unwrap());
    for l in lines {
        let (angles, brdf) = l.rsplit_once(',').unwrap();
        scaled.push_str(&format!("{angles},{:e}\n", brdf.parse::<f64>().unwrap() * 1e-6));
    }
    let path = dir.path().join("scaled.csv");
    std::fs::write(&path, scaled).unwrap();
    let path = path.to_str().unwrap();
    let report: serde_json::Value = serde_json::from_str(&ok(&["fit", "--json", path])).unwrap();
    let table = ok(&["fit", path]);
    let params = report["params"].as_object().unwrap();
    for (name, value) in params {
        let want = value.as_f64().unwrap();
        let row = table
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name.as_str()))
            .unwrap_or_else(|| panic!("no row {name}: {table}"));
        let shown: f64 = row.split_whitespace().nth(1).unwrap().parse().unwrap();
        // Six significant figures: within half a unit of the sixth.
        assert!(
            (shown - want).abs() <= 5e-6 * want.abs(),
            "{name}: {want} shown as {shown}: {row}"
        );
    }
    // The weights (kb, kd) are what the scale moved: the case the table got wrong.
    assert!(params["kb"].as_f64().unwrap().abs() < 1e-4, "{report}");
}

/// Before: the report's header printed `--loss-scale 1e-100` as a hundred-digit decimal.
#[test]
fn the_header_prints_a_tiny_loss_scale_briefly() {
    let data = repo("data/khaki-synthetic-inplane.csv");
    for (scale, shown) in [("1e-100", "1e-100"), ("2.5e99", "2.5e99"), ("0.25", "0.25")] {
        let text = ok(&[
            "fit",
            "--model",
            "lambert",
            "--loss",
            "huber",
            "--loss-scale",
            scale,
            &data,
        ]);
        let header = text.lines().next().unwrap();
        assert!(
            header.contains(&format!("huber loss at scale {shown},")) && header.len() < 200,
            "{header}"
        );
    }
}

/// A fit whose albedo is unbounded at grazing (c < 0: `(cos ti cos tr)^c` grows towards the
/// horizon) was printed "all <= 1" from albedos that stop at 89°; the text now says it does
/// not conserve energy, and why, as the JSON does.
#[test]
fn the_text_says_why_an_albedo_unbounded_at_grazing_does_not_conserve_energy() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bright.csv");
    let data = ok(&[
        "synth",
        "--model",
        "six",
        "--params",
        "kb=0.05,kr=1,b=-5,a=1,kd=0.4,c=-0.1",
        "--form",
        "full",
        "--theta-i",
        "0,20,40,60",
        "--step",
        "10",
        "--phi-step",
        "45",
    ]);
    std::fs::write(&path, data).unwrap();
    let text = ok(&["fit", "--brightening", path.to_str().unwrap()]);
    let line = text
        .lines()
        .find(|l| l.contains("albedo (measured incidences"))
        .unwrap();
    assert!(
        line.contains("does not conserve energy: albedo unbounded at grazing") && !line.contains("all <= 1"),
        "{line}"
    );
}

/// Noise-free microfacet data with `f0 = kd = 0`: the fit is exact (cost at its rounding
/// floor) and says so, instead of "converged: false: the best cost was reached by 0 of 32
/// chains"; `f0` and `kd` print as 0 at their bound, not as a rounding step off it.
#[test]
fn noise_free_microfacet_data_at_the_bounds_fit_converged() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ggx.csv");
    let data = ok(&[
        "synth",
        "--model",
        "ggx",
        "--params",
        "ks=0.6,alpha=0.1,f0=0,kd=0",
        "--form",
        "full",
        "--theta-i",
        "0,20,40,60",
    ]);
    std::fs::write(&path, data).unwrap();
    let text = ok(&["fit", "--model", "ggx", path.to_str().unwrap()]);
    assert!(
        text.contains("converged: true (the best cost") && text.contains("is at its rounding floor"),
        "{text}"
    );
    for name in ["f0", "kd"] {
        let line = text.lines().find(|l| l.trim_start().starts_with(name)).unwrap();
        let fields: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(&fields[1..3], ["0", "-"], "{line}");
        assert!(line.contains("at the search bound 0"), "{line}");
    }
}
