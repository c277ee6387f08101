//! `brdf bench eval` and `brdf bench fit` write their CSV and charts, with a Pareto front.

use std::path::PathBuf;
use std::process::Command;

fn repo(p: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(p)
        .display()
        .to_string()
}

fn run(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_brdf"))
        .args(args)
        .output()
        .unwrap();
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
    run(&["bench", "eval", "--no-qemu", "--out", out, "--material", "yellow"]);
    let csv = std::fs::read_to_string(dir.path().join("eval.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv::Reader::from_reader(csv.as_bytes())
        .records()
        .map(|r| r.unwrap().iter().map(str::to_owned).collect())
        .collect();
    assert_eq!(rows.len(), 9, "{csv}");
    let err = |name: &str| -> f64 {
        rows.iter()
            .find(|r| r[0] == name)
            .unwrap_or_else(|| panic!("{name}"))[3]
            .parse()
            .unwrap()
    };
    // The orderings the chart is about: tables converge with size, the stand-ins are far off.
    assert!(err("f32 table 1024, cosines") < err("f32 table 256, cosines"));
    assert!(err("f32 table 256, cosines") < err("f32 table 64, cosines"));
    assert!(err("f32 exact, cosines") < 2e-6 && err("f32 own exp2/log2, cosines") < 4e-6);
    assert!(err("Lambert for six, cosines") > 1e-2);
    // The f64 reference (error 0 by definition) is kept out of the front; without QEMU no
    // device figures and no device front. (The front itself is tested in brdf-plot.)
    assert_eq!(
        (rows[0][0].as_str(), rows[0][5].as_str()),
        ("f64 exact, angles", "false")
    );
    assert!(rows.iter().all(|r| r[2].is_empty() && r[6] == "false"), "{csv}");
    for f in ["eval-host.svg", "eval-host.png"] {
        assert!(std::fs::metadata(dir.path().join(f)).unwrap().len() > 1000, "{f}");
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
    assert_eq!(csv.lines().count(), 1 + 6, "{csv}");
    // The default reaches the best error from every seed on the bundled data.
    let default = csv.lines().find(|l| l.starts_with("anneal 300/chain")).unwrap();
    assert!(
        csv.contains("\"LM, 1 random start\""),
        "names with commas are quoted: {csv}"
    );
    assert!(default.contains(",3/3,"), "{default}");
    assert!(std::fs::metadata(dir.path().join("fit.svg")).unwrap().len() > 1000);
}
