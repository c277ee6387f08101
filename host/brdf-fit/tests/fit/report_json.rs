//! `brdf fit --json` output reads back as the same typed report, and what does not read
//! back is refused naming the source, the fit and the field.

use std::path::PathBuf;

use brdf_core::ModelKind;
use brdf_fit::report::FitReport;
use brdf_fit::{load_csv, FitSettings, LoadOptions};

fn khaki_fits() -> Vec<FitReport> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/khaki-synthetic-inplane.csv");
    let d = load_csv(&path, LoadOptions::default()).unwrap().datasets;
    [ModelKind::Six, ModelKind::Minnaert]
        .iter()
        .flat_map(|&k| brdf_fit::fit_all(&FitSettings::new(k), &d).unwrap())
        .collect()
}

#[test]
fn reports_read_back_equal_one_or_an_array() {
    let fits = khaki_fits();
    let one = serde_json::to_string_pretty(&fits[0]).unwrap();
    let back = FitReport::from_json(&one, "one.json").unwrap();
    assert_eq!(back, vec![fits[0].clone()]);
    // Written again, byte for byte the same text.
    assert_eq!(serde_json::to_string_pretty(&back[0]).unwrap(), one);
    let all = serde_json::to_string(&fits).unwrap();
    let all = FitReport::from_json(&all, "all.json").unwrap();
    assert_eq!(all, fits);
    // The typed conversions agree with the parameters written.
    let p = back[0].params_array().unwrap();
    assert_eq!(back[0].model().unwrap().to_params()[..6], p[..6]);
    assert_eq!(all[1].model, ModelKind::Minnaert);
}

#[test]
fn bad_reports_are_refused_with_their_place() {
    let fits = khaki_fits();
    let text = serde_json::to_string_pretty(&fits).unwrap();
    let at = text.rfind("\"model\": \"minnaert\"").unwrap();
    let line = text[..at].matches('\n').count() + 1;
    let text = text.replacen("\"model\": \"minnaert\"", "\"model\": \"seven\"", 1);
    let e = FitReport::from_json(&text, "fits.json").unwrap_err().to_string();
    assert!(
        e.starts_with(&format!("fits.json: fit 1: line {line}, column "))
            && e.contains("unknown model `seven`"),
        "{e} (expected line {line})"
    );

    let mut v = serde_json::to_value(&fits[0]).unwrap();
    v["params"].as_object_mut().unwrap().remove("kd");
    let e = FitReport::from_json(&v.to_string(), "f.json")
        .unwrap_err()
        .to_string();
    assert_eq!(e, "f.json: fit 0: no parameter `kd` for the six model");

    let e = FitReport::from_json("{\"model\": \"six\",", "t.json")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("t.json: line 1, column "), "{e}");
}

#[test]
fn a_non_finite_metric_reads_back_as_nan() {
    let mut v = serde_json::to_value(&khaki_fits()[0]).unwrap();
    v["metrics"]["max_rel"] = serde_json::Value::Null;
    let r = FitReport::from_json(&v.to_string(), "n.json").unwrap();
    assert!(r[0].metrics.max_rel.is_nan());
}
