//! The energy check of a fit: albedo by quadrature at the measured incidences and at fixed
//! incidences to 89.99° ([`ENERGY_INCIDENCES_DEG`]), and the analytic bound (`kb + kd <= 1`).

use super::*;

/// Quadrature albedo at one measured incidence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IncidenceAlbedo {
    /// Incidence zenith, degrees.
    #[serde(deserialize_with = "f64_or_null")]
    pub theta_i: f64,
    /// Directional-hemispherical reflectance (`AlbedoRule::for_model`: the default rule,
    /// accurate to `brdf_core::tolerance::ALBEDO_DEFAULT_REL`, or more panels for a narrow
    /// microfacet peak).
    #[serde(deserialize_with = "f64_or_null")]
    pub albedo: f64,
}

/// The energy check of a fitted model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Energy {
    /// Analytic sufficient bound (`kb + kd` for the six-parameter model), if the model has one.
    pub bound: Option<f64>,
    /// The bound is at most 1.
    pub bound_conserves: bool,
    /// Albedo at each measured incidence and at [`ENERGY_INCIDENCES_DEG`], in increasing
    /// incidence.
    pub albedo: Vec<IncidenceAlbedo>,
    /// Every albedo is at most 1 (at the measured incidences and the fixed ones: a model's
    /// albedo may rise towards grazing beyond the data, as the microfacet model's Fresnel
    /// term makes it), and the model's albedo is bounded at grazing (false whenever
    /// [`Energy::unbounded`] says why not).
    pub albedo_conserves: bool,
    /// Why the albedo is unbounded at grazing, when [`brdf_core::AnyModel::bounded_at_grazing`]
    /// says it is (the five-parameter model, Minnaert with `k < 1`, the six-parameter models
    /// with `c < 0`): past the last incidence checked it grows without bound, so no list of
    /// albedos at most 1 shows that the model conserves energy (a six-parameter fit with
    /// `c = -0.1` had 0.80 at 89°, 1.05 at 89.99° and 1.34 at 89.999°).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unbounded: Option<String>,
}

impl Energy {
    /// Sets [`Energy::albedo_conserves`] from the albedos and [`Energy::unbounded`]: after
    /// the albedos were changed (scaled, or of another representation of the model).
    pub fn recheck(&mut self) {
        self.albedo_conserves = self.unbounded.is_none() && self.albedo.iter().all(|a| a.albedo <= 1.0);
    }
}

/// Why `model`'s albedo is unbounded at grazing (see [`Energy::unbounded`]), or `None` when
/// [`brdf_core::AnyModel::bounded_at_grazing`] says it is bounded.
pub fn unbounded_at_grazing(model: &AnyModel<f64>) -> Option<String> {
    if model.bounded_at_grazing() {
        return None;
    }
    let p = model.to_params();
    Some(match model.kind() {
        ModelKind::Six | ModelKind::SixCos2 => format!(
            "albedo unbounded at grazing: c = {} < 0, and (cos ti cos tr)^c grows without bound \
             towards the horizon",
            short(p[5])
        ),
        ModelKind::Minnaert => format!(
            "albedo unbounded at grazing: k = {} < 1, and (cos ti cos tr)^(k - 1) grows without \
             bound towards the horizon",
            short(p[1])
        ),
        ModelKind::Five => {
            "albedo unbounded at grazing: the kd / cos ti term grows without bound towards the horizon"
                .to_owned()
        }
        ModelKind::Ggx | ModelKind::Lambert => "albedo unbounded at grazing".to_owned(),
    })
}

/// Incidences (degrees) where every fit's albedo is checked besides the measured ones: a fit to
/// data from 0–30° that conserved energy there reached 1.14 at 80° (a microfacet fit, its
/// Fresnel term rising towards grazing) while the report said it conserved energy. Up to
/// 89.99°, where a bounded albedo has come to within a fraction of a percent of its grazing
/// limit: a microfacet fit with `ks + kd` of 1.55 had 0.967 at 89° ("all <= 1") and 1.031 at
/// 89.9°, 1.039 at 89.99°.
pub const ENERGY_INCIDENCES_DEG: [f64; 10] = [0.0, 30.0, 45.0, 60.0, 70.0, 80.0, 85.0, 89.0, 89.9, 89.99];

/// A measured incidence this close (radians, 0.006 degrees) to one of
/// [`ENERGY_INCIDENCES_DEG`] stands for it: files write radians to six decimals (Cornell's
/// 30 degrees is 0.523599, 8e-7 rad off), and the report listed "30.0 deg" twice.
pub const SAME_INCIDENCE_RAD: f64 = 1e-4;

/// The measured incidences (radians) and [`ENERGY_INCIDENCES_DEG`], sorted, each once (a
/// measured incidence within [`SAME_INCIDENCE_RAD`] of a fixed one stands for it).
pub fn checked_incidences(measured: &[f64]) -> Vec<f64> {
    let mut all: Vec<f64> = measured.to_vec();
    for d in ENERGY_INCIDENCES_DEG {
        let t = d.to_radians();
        if !measured.iter().any(|m| (m - t).abs() < SAME_INCIDENCE_RAD) {
            all.push(t);
        }
    }
    all.sort_by(f64::total_cmp);
    all
}

/// Energy check of `model` at the incidences (radians) of a dataset.
pub fn energy(model: &AnyModel<f64>, incidences: &[f64]) -> Energy {
    let bound = model.energy_bound();
    let batch = Batch::new(model);
    let rule = AlbedoRule::for_model(model);
    let albedo: Vec<IncidenceAlbedo> = incidences
        .par_iter()
        .map(|&ti| IncidenceAlbedo {
            theta_i: degrees(ti),
            albedo: albedo_batch(&batch, ti, rule),
        })
        .collect();
    let mut e = Energy {
        bound,
        bound_conserves: matches!(bound, Some(b) if b <= 1.0),
        albedo_conserves: false,
        albedo,
        unbounded: unbounded_at_grazing(model),
    };
    e.recheck();
    e
}

/// Energy check of a fitted parameter vector (paper order and signs), which may hold linear
/// weights above their ranges (see [`FitReport::outside_ranges`]). The bound and every albedo
/// are linear in the weights, so the check runs on the weights scaled into range and
/// scales the results back.
pub fn energy_of(kind: ModelKind, params: &[f64], incidences: &[f64]) -> Energy {
    let ranges = kind.ranges();
    // The weights alone: the model, and so the bound and every albedo, is linear in them
    // (the five-parameter `kd` is a ratio inside `kb`, and scaled with it changed the model).
    let linear = kind.linear_params();
    let scale = linear
        .iter()
        .map(|&i| params[i] / f64::from(ranges[i].max))
        .fold(1.0_f64, f64::max);
    let mut scaled = params.to_vec();
    for &i in linear {
        // `min`: only the division's rounding can carry the largest weight past its bound.
        scaled[i] = (scaled[i] / scale).min(f64::from(ranges[i].max));
    }
    let model = AnyModel::new(kind, &scaled).expect("the fitter's nonlinear box lies inside the ranges");
    let mut e = energy(&model, incidences);
    if scale > 1.0 {
        e.bound = e.bound.map(|b| b * scale);
        for a in &mut e.albedo {
            a.albedo *= scale;
        }
        e.bound_conserves = matches!(e.bound, Some(b) if b <= 1.0);
        e.recheck();
    }
    e
}

#[cfg(test)]
mod incidence_tests {
    use super::*;

    /// The energy check scales the weights a model is linear in into their ranges and the
    /// albedo back. Before, the five-parameter `kd` (the diffuse part's ratio inside `kb`,
    /// not a weight) was scaled with `kb`: a fit in a unit that put `kb` above 1e4 reported
    /// an albedo that was not the model's. The albedo is linear in the weights alone.
    #[test]
    fn the_albedo_of_a_weight_beyond_its_range_is_the_model_s() {
        for (kind, p) in [
            (ModelKind::Five, vec![0.5, 1.0, -5.0, 1.0, 0.4]),
            (ModelKind::Six, vec![0.5, 2.0, -5.0, 1.0, 0.4, 1.0]),
            (ModelKind::Ggx, vec![0.5, 0.3, 0.5, 0.4]),
        ] {
            let at = checked_incidences(&[0.0, 0.5]);
            let unit = energy_of(kind, &p, &at);
            let factor = 1e6;
            let mut big = p.clone();
            for &i in kind.linear_params() {
                big[i] *= factor;
            }
            let scaled = energy_of(kind, &big, &at);
            for (a, b) in unit.albedo.iter().zip(&scaled.albedo) {
                assert!(
                    (b.albedo - factor * a.albedo).abs() <= 1e-9 * b.albedo,
                    "{kind}: {} against {} x {factor:e}",
                    b.albedo,
                    a.albedo
                );
            }
        }
    }

    /// Cornell's 30 degrees written to six decimals of a radian was listed beside the fixed 30.
    #[test]
    fn a_measured_incidence_written_to_six_decimals_stands_for_the_fixed_one() {
        // 30 degrees as a file writes it: six decimals of a radian, 8e-7 off.
        let written = (30f64.to_radians() * 1e6).round() / 1e6;
        let all = checked_incidences(&[written, 0.2]);
        let thirty = all
            .iter()
            .filter(|t| (t.to_degrees() - 30.0).abs() < 0.05)
            .count();
        assert_eq!(thirty, 1, "{all:?}");
        assert!(all.contains(&written) && all.contains(&0.2));
        assert_eq!(all.len(), 2 + ENERGY_INCIDENCES_DEG.len() - 1);
    }

    /// A six-parameter fit with `c = -0.1` (`--brightening`) was said to conserve energy
    /// ("all <= 1": 0.80 at 89°) while its albedo grows without bound towards grazing (1.05 at
    /// 89.99°, 1.34 at 89.999°). The same weights with `c >= 0` are bounded and conserve.
    /// Every albedo up to 89 degrees at most 1 (where the check once stopped).
    fn at_most_one_up_to_89(e: &Energy) -> bool {
        e.albedo
            .iter()
            .filter(|a| a.theta_i <= 89.0)
            .all(|a| a.albedo <= 1.0)
    }

    /// A microfacet fit (bounded at grazing) with `ks` 1.55: its albedo is at most 0.967 up to
    /// 89°, where the check stopped ("all <= 1"), and 1.039 by 89.99°, now checked.
    #[test]
    fn an_albedo_above_one_only_near_grazing_does_not_conserve_energy() {
        let ggx = [1.55, 0.03, 0.0, 0.0];
        let model = AnyModel::new(ModelKind::Ggx, &ggx).unwrap();
        assert!(model.bounded_at_grazing());
        let e = energy_of(ModelKind::Ggx, &ggx, &checked_incidences(&[0.0]));
        assert!(at_most_one_up_to_89(&e), "{e:?}");
        assert!(e.unbounded.is_none() && !e.albedo_conserves, "{e:?}");
    }

    #[test]
    fn an_albedo_unbounded_at_grazing_does_not_conserve_energy() {
        let measured: Vec<f64> = [0.0, 20.0, 40.0, 60.0].map(f64::to_radians).to_vec();
        let brightening = [0.05, 1.0, -5.0, 1.0, 0.4, -0.1];
        let e = energy_of(ModelKind::Six, &brightening, &checked_incidences(&measured));
        assert!(at_most_one_up_to_89(&e), "{e:?}");
        assert!(!e.albedo_conserves, "{e:?}");
        let why = e.unbounded.as_deref().unwrap_or("");
        assert!(
            why.contains("unbounded at grazing") && why.contains("c = -0.1 < 0"),
            "{why}"
        );
        let grazing = AnyModel::new(ModelKind::Six, &brightening).unwrap();
        let rule = AlbedoRule::for_model(&grazing);
        assert!(brdf_core::checks::albedo(&grazing, 89.999f64.to_radians(), rule) > 1.0);
        // Reports without the field read back as bounded.
        let mut v = serde_json::to_value(&e).unwrap();
        v.as_object_mut().unwrap().remove("unbounded");
        assert_eq!(serde_json::from_value::<Energy>(v).unwrap().unbounded, None);

        for c in [0.0, 0.1] {
            let mut p = brightening;
            p[5] = c;
            let e = energy_of(ModelKind::Six, &p, &checked_incidences(&measured));
            assert!(e.albedo_conserves && e.unbounded.is_none(), "c = {c}: {e:?}");
            assert!(!serde_json::to_string(&e).unwrap().contains("unbounded"));
        }
        // Scaled weights (above their ranges) keep the verdict.
        let mut big = brightening;
        big[4] = 1e6;
        assert!(energy_of(ModelKind::Six, &big, &measured).unbounded.is_some());
        let minnaert = energy_of(ModelKind::Minnaert, &[0.5, 0.9], &measured);
        assert!(!minnaert.albedo_conserves && minnaert.unbounded.unwrap().contains("k = 0.9 < 1"));
    }

    /// A term with zero weight cannot make the albedo unbounded: `c < 0` with `kd = 0`, Minnaert
    /// `k < 1` with `rho0 = 0`, the five-parameter model with `kd = 0` or `kb = 0` were called
    /// unbounded at grazing (their diverging term weighed 0). Their albedo at 89.999° is the
    /// proof: at most the 89.99° albedo's neighbourhood, where the unbounded ones have risen
    /// past it. The same models with the weight back stay unbounded.
    #[test]
    fn a_term_with_zero_weight_leaves_the_albedo_bounded() {
        let grazing = |kind: ModelKind, p: &[f64]| {
            let m = AnyModel::new(kind, p).unwrap();
            let rule = AlbedoRule::for_model(&m);
            let at = |deg: f64| brdf_core::checks::albedo(&m, f64::to_radians(deg), rule);
            (m.bounded_at_grazing(), at(89.99), at(89.9999))
        };
        let cases: [(ModelKind, &[f64], &[f64]); 4] = [
            (
                ModelKind::Six,
                &[0.05, 1.0, -5.0, 1.0, 0.0, -0.1],
                &[0.05, 1.0, -5.0, 1.0, 0.4, -0.1],
            ),
            (ModelKind::Minnaert, &[0.0, 0.9], &[0.5, 0.9]),
            (
                ModelKind::Five,
                &[0.5, 1.0, -5.0, 1.0, 0.0],
                &[0.5, 1.0, -5.0, 1.0, 0.4],
            ),
            (
                ModelKind::Five,
                &[0.0, 1.0, -5.0, 1.0, 0.4],
                &[0.5, 1.0, -5.0, 1.0, 0.4],
            ),
        ];
        for (kind, off, on) in cases {
            let (bounded, near, nearer) = grazing(kind, off);
            assert!(bounded, "{kind} {off:?}: {near} then {nearer}");
            assert!(
                nearer <= near + GRAZING_RISE_ABS,
                "{kind} {off:?}: {near} then {nearer}"
            );
            let e = energy_of(kind, off, &checked_incidences(&[0.0]));
            assert!(e.unbounded.is_none(), "{kind} {off:?}: {e:?}");
            let (bounded, near, nearer) = grazing(kind, on);
            assert!(
                !bounded && nearer > near + GRAZING_RISE_ABS,
                "{kind} {on:?}: {near} then {nearer}"
            );
        }
    }

    /// How much a bounded albedo may still rise from 89.99° to 89.9999°: it has come to within
    /// a fraction of a percent of its grazing limit by 89.99° ([`ENERGY_INCIDENCES_DEG`]'s
    /// reason), while an unbounded one with `c = -0.1`, `k = 0.9` or `kd / cos ti` rises by
    /// far more over the same hundredfold step towards the horizon.
    const GRAZING_RISE_ABS: f64 = 1e-3;
}
