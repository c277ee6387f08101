//! `select --scene` chooses by the ladder's one rule (`brdf_scene::ladder`): before, it could
//! choose the five-parameter model or Minnaert with `k < 1` (not reciprocal, or unbounded at
//! grazing), which `brdf select DATA` refuses without `--allow-nonphysical`.

use brdf_core::{AnyModel, ModelKind};
use brdf_scene::queries::collect_queries;
use brdf_scene::scene::{Mode, Scene, SceneMaterial, Sensor};
use brdf_scene::select::{select, SelectOptions, DEFAULT_BUDGET};
use brdf_scene::shapes::MeshBuilder;

fn ball(kind: ModelKind, params: &[f64]) -> Scene {
    let mut b = MeshBuilder::new();
    b.icosphere(1.0, 2, "ball");
    let model = AnyModel::new(kind, params).unwrap();
    let sensor = Sensor {
        mode: Mode::Monostatic,
        azimuth_deg: vec![0.0, 40.0],
        elevation_deg: vec![0.0, 30.0],
    };
    Scene::new(
        "ball".into(),
        b.build("ball").unwrap(),
        vec![SceneMaterial::new("*", model)],
        sensor,
    )
    .unwrap()
}

#[test]
fn non_physical_models_are_chosen_only_when_allowed() {
    for (kind, params) in [
        (ModelKind::Five, &[0.2545, 21.8031, -27.5721, 0.6705, 0.3676][..]),
        (ModelKind::Minnaert, &[0.4, 0.5][..]),
    ] {
        let scene = ball(kind, params);
        let queries = collect_queries(&scene, &|| {});
        // A budget only the material's own model meets (its f32 rounding, about 1e-7).
        let opts = SelectOptions {
            budget: 1e-5,
            ..SelectOptions::default()
        };
        let strict = select(&scene, &queries, &opts);
        let m = &strict.materials[0];
        let own = m
            .candidates
            .iter()
            .find(|c| c.rung.name == format!("{} exact", kind.name()))
            .unwrap();
        assert!(
            own.within_budget && !own.eligible,
            "{kind:?}: {:?}",
            own.rung.name
        );
        assert_eq!(m.chosen, None, "{kind:?}: {}", m.reason);
        assert!(m.reason.contains("--allow-nonphysical"), "{}", m.reason);
        assert!(strict.blob().is_none());
        let loose = select(
            &scene,
            &queries,
            &SelectOptions {
                allow_nonphysical: true,
                ..opts
            },
        );
        let m = &loose.materials[0];
        let c = &m.candidates[m.chosen.expect("the own model within budget")];
        assert_eq!(c.rung.name, format!("{} exact", kind.name()));
        assert!(loose.blob().is_some());
    }
}

#[test]
fn the_default_budget_is_the_command_lines() {
    assert_eq!(SelectOptions::default().budget, DEFAULT_BUDGET);
    assert_eq!(DEFAULT_BUDGET, 0.02);
}

/// Before: data with a zero reading (allowed with absolute residuals) gave every
/// representation an infinite error and the reason "closest ... at inf%".
#[test]
fn data_selection_refuses_a_zero_reading_naming_its_line() {
    use brdf_scene::represent::{select_data, DataDomain};
    let mut d = brdf_fit::synth::in_plane(ModelKind::Lambert, &[0.5], &[0.0, 30.0], 10.0, 0.0, 1).unwrap();
    d.points[3].brdf = 0.0;
    let line = d.points[3].line;
    let kept = DataDomain::new(&d, 90.0, 90.0);
    let settings = |kind| brdf_fit::FitSettings {
        residual: brdf_fit::Residual::Absolute,
        ..brdf_fit::FitSettings::new(kind)
    };
    let e = select_data(&kept, &settings, 0.02, false).unwrap_err();
    assert!(
        e.contains(&format!(
            "line {line}: brdf 0: select judges representations by relative error"
        )),
        "{e}"
    );
}
