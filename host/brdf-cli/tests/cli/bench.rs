//! `brdf bench eval` and `brdf bench fit` write their CSV and charts, with a Pareto front.

use std::path::PathBuf;

use brdf_core::tolerance::BATCH_F64_REL;

fn repo(p: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(p)
        .display()
        .to_string()
}

fn run(args: &[&str]) -> String {
    let out = crate::brdf(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn eval_bench_writes_csv_charts_and_a_pareto_front() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let small = ["--points", "12", "--reps", "1", "--no-qemu", "--no-numpy"];
    run(&[
        &["bench", "eval", "--out", out, "--material", "yellow"],
        &small[..],
    ]
    .concat());
    let csv = std::fs::read_to_string(dir.path().join("eval.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv::Reader::from_reader(csv.as_bytes())
        .records()
        .map(|r| r.unwrap().iter().map(str::to_owned).collect())
        .collect();
    // Scalar and batch, f64 and f32, three inputs, one core and all cores; three tables and
    // three stand-ins (Minnaert, microfacet, Lambert).
    assert_eq!(rows.len(), 2 * 2 * 3 * 2 + 3 + 3, "{csv}");
    let err = |name: &str| -> f64 {
        rows.iter()
            .find(|r| r[0] == name)
            .unwrap_or_else(|| panic!("{name}"))[4]
            .parse()
            .unwrap()
    };
    // The orderings the chart is about: tables converge with size, the stand-ins are far off.
    assert!(err("f32 table 1024 cosines") < err("f32 table 256 cosines"));
    assert!(err("f32 table 256 cosines") < err("f32 table 64 cosines"));
    assert!(err("f32 scalar angles") < 2e-6);
    assert!(err("f64 batch angles") <= BATCH_F64_REL && err("f32 batch angles") < 2e-6);
    assert!(err("Lambert for six, cosines") > 1e-2);
    assert!(err("microfacet for six, cosines") > 1e-3);
    // The f64 reference (error 0 by definition) is kept out of the front; without QEMU no
    // device figures and no device front. (The front itself is tested in brdf-plot.)
    assert_eq!(
        (rows[0][0].as_str(), rows[0][2].as_str(), rows[0][6].as_str()),
        ("f64 scalar angles", "1", "false")
    );
    assert!(rows.iter().all(|r| r[3].is_empty() && r[7] == "false"), "{csv}");
    for f in ["eval-host.svg", "eval-host.png"] {
        assert!(std::fs::metadata(dir.path().join(f)).unwrap().len() > 1000, "{f}");
    }
}

#[test]
fn eval_bench_json_lists_every_variant() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let text = run(&[
        "bench",
        "eval",
        "--json",
        "--out",
        out,
        "--points",
        "10",
        "--reps",
        "1",
        "--no-qemu",
        "--no-numpy",
    ]);
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let variants = v["variants"].as_array().unwrap();
    for precision in ["f64", "f32"] {
        for path in ["scalar", "batch"] {
            for input in ["angles", "cosines", "vectors"] {
                let name = format!("{precision} {path} {input}");
                let rows: Vec<_> = variants.iter().filter(|r| r["name"] == name.as_str()).collect();
                assert_eq!(rows.len(), 2, "{name}: one core and all cores");
                assert_eq!(rows[0]["threads"], 1);
                for r in rows {
                    assert!(r["ns_per_eval"].as_f64().unwrap() > 0.0, "{r}");
                    let e = r["max_rel_error"].as_f64().unwrap();
                    assert!(e < if precision == "f64" { 1e-12 } else { 4e-6 }, "{r}");
                }
            }
        }
    }
}

#[test]
fn fit_bench_compares_methods_over_seeds() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let text = run(&[
        "bench",
        "fit",
        &repo("data/khaki-synthetic-inplane.csv"),
        "--seeds",
        "3",
        "--no-scipy",
        "--out",
        out,
    ]);
    assert!(text.contains("anneal 300/chain + LM (default)"), "{text}");
    let csv = std::fs::read_to_string(dir.path().join("fit.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 7, "{csv}");
    // The default reaches the best error from every seed on the bundled data.
    let default = csv.lines().find(|l| l.starts_with("anneal 300/chain")).unwrap();
    assert!(
        csv.contains("\"LM, 1 random start\""),
        "names with commas are quoted: {csv}"
    );
    assert!(default.contains(",3/3,"), "{default}");
    assert!(std::fs::metadata(dir.path().join("fit.svg")).unwrap().len() > 1000);
}
