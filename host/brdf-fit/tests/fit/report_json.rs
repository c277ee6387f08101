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

/// The same direction written another way (incidence and viewing swapped, `phi` as
/// `360 - phi`) is no new direction to a reciprocal model: four directions, three of them also
/// written swapped or mirrored, gave every microfacet parameter "determined" with standard
/// error 2e-14; two directions written three ways each passed for six and were fitted. To the
/// five-parameter model (not reciprocal) a swap is a new direction.
#[test]
fn a_direction_written_another_way_is_not_another_direction() {
    let rows = |text: &[[f64; 4]]| brdf_fit::Dataset {
        name: "written twice".into(),
        points: text
            .iter()
            .enumerate()
            .map(|(i, &[theta_i, theta_r, phi, brdf])| {
                let r = brdf_fit::data::RowDegrees {
                    theta_i,
                    theta_r,
                    phi,
                    brdf,
                    sigma: None,
                    weight: None,
                };
                brdf_fit::Point::from_degrees(r, false, i as u64 + 2).unwrap()
            })
            .collect(),
    };
    let four = rows(&[
        [0.0, 10.0, 180.0, 0.2],
        [30.0, 30.0, 180.0, 0.5],
        [10.0, 20.0, 0.0, 0.1],
        [50.0, 40.0, 180.0, 2.0],
        [10.0, 0.0, 180.0, 0.2],
        [20.0, 10.0, 360.0, 0.1],
        [40.0, 50.0, 180.0, 2.0],
    ]);
    assert_eq!(brdf_fit::report::distinct_directions(&four, ModelKind::Ggx, 7), 4);
    assert_eq!(
        brdf_fit::report::distinct_directions(&four, ModelKind::Five, 7),
        7
    );
    let r = FitSettings::new(ModelKind::Ggx).fit(&four).unwrap();
    for (name, u) in &r.uncertainty.params.0 {
        assert!(!u.determined && u.se.is_none(), "{name}: {u:?}");
    }
    let two = rows(&[
        [10.0, 20.0, 90.0, 0.3],
        [20.0, 10.0, 90.0, 0.3],
        [10.0, 20.0, 270.0, 0.3],
        [30.0, 40.0, 60.0, 0.25],
        [40.0, 30.0, 60.0, 0.25],
        [40.0, 30.0, 300.0, 0.25],
    ]);
    let e = FitSettings::new(ModelKind::Ggx)
        .fit(&two)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("2 distinct direction(s) cannot determine 4 parameters"),
        "{e}"
    );
}

/// Before: six distinct directions read ten times each, fitted with the six-parameter model,
/// reported every parameter "determined" with standard error 0: the fit passes through the
/// six directions exactly, whatever the number of copies, and leaves no noise estimate.
#[test]
fn copies_of_as_many_directions_as_parameters_determine_nothing() {
    let khaki = [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2];
    let all = brdf_fit::synth::in_plane(ModelKind::Six, &khaki, &[0.0, 30.0], 10.0, 0.0, 1).unwrap();
    let six: Vec<_> = all.points.iter().step_by(3).take(6).copied().collect();
    let d = brdf_fit::Dataset {
        name: "six directions x 10".into(),
        points: (0..10).flat_map(|_| six.iter().copied()).collect(),
    };
    assert_eq!(brdf_fit::report::distinct_directions(&d, ModelKind::Six, 7), 6);
    let r = FitSettings::new(ModelKind::Six).fit(&d).unwrap();
    for (name, u) in &r.uncertainty.params.0 {
        assert!(!u.determined, "{name} called determined: {u:?}");
        assert!(u.se.is_none(), "{name}: {u:?}");
        let note = u.note.as_deref().unwrap_or("");
        assert!(
            note.contains("no more distinct directions than parameters"),
            "{name}: {note}"
        );
    }
    // One more direction, and the same copies, give a noise estimate again.
    let mut seven = d.clone();
    seven.points.push(*all.points.last().unwrap());
    assert_eq!(
        brdf_fit::report::distinct_directions(&seven, ModelKind::Six, 8),
        7
    );
    let r = FitSettings::new(ModelKind::Six).fit(&seven).unwrap();
    for (name, u) in &r.uncertainty.params.0 {
        let note = u.note.as_deref().unwrap_or("");
        assert!(!note.contains("no more distinct directions"), "{name}: {note}");
    }
}

/// Two fits of the same rows, one of them with every row written ten times, reach the same
/// optimum to the polish's tolerances (`LmOptions`: steps below 1e-10 of the residual norm),
/// so their standard errors, smooth functions of the optimum, agree far closer than this;
/// the defect this guards against changed them by a factor of about sqrt(10).
const SAME_SE_REL: f64 = 1e-6;

/// Before: eight rows written ten times each made `kb`, `a` and `kd` "determined" where the
/// eight rows alone did not, and every standard error about five times smaller (`n - p` grew
/// from 3 to 75 while the copies added nothing). An exact copy adds to `J^T J` and the cost
/// what its row already does: the same standard errors and verdicts, the degrees of freedom
/// counted over distinct rows. Replicates, the same directions read again with other readings,
/// are information and keep counting.
#[test]
fn exact_copies_of_rows_change_no_standard_error_and_no_verdict() {
    use brdf_fit::report::distinct_rows;
    let khaki = brdf_core::TABLE1[0].1;
    let read = |seed: u64| -> Vec<brdf_fit::Point> {
        let all =
            brdf_fit::synth::hemisphere(ModelKind::Six, &khaki, &[0.0, 20.0, 40.0], 10.0, 45.0, 0.01, seed)
                .unwrap();
        all.points.iter().step_by(17).take(8).copied().collect()
    };
    let eight = read(1);
    let once = brdf_fit::Dataset {
        name: "eight rows".into(),
        points: eight.clone(),
    };
    let mut tenfold = brdf_fit::Dataset {
        name: "eight rows x 10".into(),
        points: (0..10).flat_map(|_| eight.iter().copied()).collect(),
    };
    // One copy written the other way round (incidence and viewing swapped, phi mirrored): to
    // a reciprocal model the same row.
    let p = tenfold.points[3];
    tenfold.points[3] = brdf_fit::Point {
        theta_i: p.theta_r,
        theta_r: p.theta_i,
        phi: -p.phi,
        ..p
    };
    assert_eq!(distinct_rows(&once, ModelKind::Six), 8);
    assert_eq!(distinct_rows(&tenfold, ModelKind::Six), 8);
    let replicated = brdf_fit::Dataset {
        name: "eight directions read ten times".into(),
        points: (1..=10).flat_map(read).collect(),
    };
    assert_eq!(distinct_rows(&replicated, ModelKind::Six), 80);

    let a = FitSettings::new(ModelKind::Six).fit(&once).unwrap();
    let b = FitSettings::new(ModelKind::Six).fit(&tenfold).unwrap();
    let mut compared = 0;
    for ((name, u), (_, v)) in a.uncertainty.params.0.iter().zip(&b.uncertainty.params.0) {
        assert_eq!(u.determined, v.determined, "{name}: {u:?} against {v:?}");
        match (u.se, v.se) {
            (Some(x), Some(y)) => {
                assert!((x - y).abs() <= SAME_SE_REL * x, "{name}: {x:e} against {y:e}");
                compared += 1;
            }
            (x, y) => assert_eq!(x.is_some(), y.is_some(), "{name}"),
        }
    }
    assert!(compared >= 4, "{compared} standard errors compared");
    // Ten readings of each direction: every standard error smaller than one reading's.
    let c = FitSettings::new(ModelKind::Six).fit(&replicated).unwrap();
    for ((name, u), (_, v)) in a.uncertainty.params.0.iter().zip(&c.uncertainty.params.0) {
        if let (Some(x), Some(y)) = (u.se, v.se) {
            assert!(
                y < x,
                "{name}: {y:e} from replicates against {x:e} from one reading"
            );
        }
    }
}

/// A misspelt or null `fitted_table` dropped the table without a word (a Lambert base alone:
/// 1.7e-3 where the table gave 6e-2); every field not in a fit result is now refused by name,
/// and the list of fields is the report's own.
#[test]
fn unknown_fields_and_a_null_table_are_refused() {
    use brdf_fit::report::{FittedModel, FIT_RESULT_FIELDS};
    let fits = khaki_fits();
    let v = serde_json::to_value(&fits[0]).unwrap();
    let mut written: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    // Written only when a table was chosen, a noise floor used, bands fitted together.
    written.extend(["fitted_table", "noise_floor", "bands"]);
    written.sort_unstable();
    let mut known = FIT_RESULT_FIELDS.to_vec();
    known.sort_unstable();
    assert_eq!(written, known, "FIT_RESULT_FIELDS must list the report's fields");

    let hand = r#"{"model": "lambert", "params": {"rho0": 0.5}, "fitted_tabel": {}}"#;
    for e in [
        FittedModel::from_json(hand, "h.json").unwrap_err().to_string(),
        FitReport::from_json(&v.to_string().replacen('{', "{\"fited_table\": 1, ", 1), "r.json")
            .unwrap_err()
            .to_string(),
    ] {
        assert!(e.contains("unknown field `"), "{e}");
    }
    let null = r#"{"model": "lambert", "params": {"rho0": 0.5}, "fitted_table": null}"#;
    let e = FittedModel::from_json(null, "n.json").unwrap_err().to_string();
    assert!(e.starts_with("n.json: fit 0: fitted_table: null"), "{e}");
    // The hand-written form without a table still reads.
    let ok = r#"{"model": "lambert", "params": {"rho0": 0.5}}"#;
    assert_eq!(FittedModel::from_json(ok, "ok.json").unwrap().len(), 1);
}

/// Influence and the information criteria of two fits of the same rows, one with every row
/// written ten times: the optimum is the same to the polish's tolerances ([`SAME_SE_REL`]'s
/// reason), and so are the residuals, leverages and refits these are made of. Before, the
/// copies counted as points: AIC was -1243 against the rows' -113, and leaving one copy out
/// moved nothing (its nine twins held the fit), so no point had influence.
#[test]
fn exact_copies_of_rows_change_no_influence_and_no_information_criterion() {
    let khaki = brdf_core::TABLE1[0].1;
    let all =
        brdf_fit::synth::hemisphere(ModelKind::Six, &khaki, &[0.0, 20.0, 40.0], 10.0, 45.0, 0.05, 3).unwrap();
    let rows: Vec<brdf_fit::Point> = all.points.iter().step_by(7).take(20).copied().collect();
    let once = brdf_fit::Dataset {
        name: "twenty rows".into(),
        points: rows.clone(),
    };
    let tenfold = brdf_fit::Dataset {
        name: "twenty rows x 10".into(),
        points: (0..10).flat_map(|_| rows.iter().copied()).collect(),
    };
    let a = FitSettings::new(ModelKind::Six).fit(&once).unwrap();
    let b = FitSettings::new(ModelKind::Six).fit(&tenfold).unwrap();
    let close = |x: f64, y: f64| (x - y).abs() <= SAME_SE_REL * x.abs().max(1.0);
    assert!(close(a.aic, b.aic), "AIC {} against {}", a.aic, b.aic);
    assert!(close(a.bic, b.bic), "BIC {} against {}", a.bic, b.bic);
    assert!(!a.influence.points.is_empty(), "{:?}", a.influence);
    assert_eq!(a.influence.dominant_above, b.influence.dominant_above);
    assert_eq!(a.influence.dominant, b.influence.dominant);
    assert_eq!(a.influence.points.len(), b.influence.points.len());
    for (u, v) in a.influence.points.iter().zip(&b.influence.points) {
        assert_eq!(u.line, v.line, "{u:?} against {v:?}");
        for (name, x, y) in [
            ("leverage", u.leverage, v.leverage),
            ("cost_drop", u.cost_drop, v.cost_drop),
            ("standardized", u.standardized, v.standardized),
        ] {
            assert!(
                (x - y).abs() <= SAME_INFLUENCE_ABS,
                "line {}: {name} {x} against {y}",
                u.line
            );
        }
    }
}

/// Leverages, cost shares and standardised residuals of the same optimum reached twice: their
/// refits without a point stop at the polish's tolerances, so they agree to far better than
/// this, while the defect moved a cost share from about 0.1 to about 0.001.
const SAME_INFLUENCE_ABS: f64 = 1e-4;
