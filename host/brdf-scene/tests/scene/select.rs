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
