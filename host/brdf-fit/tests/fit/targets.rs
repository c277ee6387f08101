//! Acceptance targets of the fitting engine on synthetic Table 1 data.

use brdf_core::ModelKind;
use brdf_fit::report::{metrics, report};
use brdf_fit::{fit, synth, FitOptions, Problem, Residual};

const KHAKI: [f64; 6] = brdf_core::TABLE1[0].1;
const YELLOW: [f64; 6] = brdf_core::TABLE1[1].1;

fn check_recovery(name: &str, truth: &[f64; 6], incidences: &[f64]) {
    let data = synth::in_plane(ModelKind::Six, truth, incidences, 1.0, 0.005, 7).unwrap();
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &data);
    let out = fit(&problem, &FitOptions::default());
    let rep = report(&data, &problem, &out, &FitOptions::default());
    let truth_q = brdf_fit::kernel::to_internal(ModelKind::Six, truth);
    let truth_rms = metrics(
        &problem.values(&truth_q),
        &data.points.iter().map(|p| p.brdf).collect::<Vec<_>>(),
    )
    .rms_rel;
    println!(
        "{name}: n = {}, fit rms_rel {:.5} vs truth {:.5}, {:.1} ms, {} evals; params {:?}",
        rep.n,
        rep.metrics.rms_rel,
        truth_rms,
        out.seconds * 1e3,
        out.evals,
        out.params
    );
    for (pname, u) in &rep.uncertainty.params.0 {
        println!(
            "  {pname}: {:.6} se {:?} determined {} {:?}",
            u.value, u.se, u.determined, u.note
        );
    }
    // Target: no more than 1% above the error of the true parameters. The optimum is
    // expected to lie *below* it: fitting p parameters absorbs chi2_p of the noise, an RMS
    // drop of about p / (2n) (mean) and up to ~3p / (2n); a drop beyond that would mean the
    // metric or the data handling is wrong.
    let (n, p) = (rep.n as f64, 6.0);
    assert!(
        rep.metrics.rms_rel <= 1.01 * truth_rms,
        "{name}: fit worse than truth by over 1%"
    );
    assert!(
        rep.metrics.rms_rel >= truth_rms * (1.0 - 3.0 * p / n).sqrt(),
        "{name}: implausibly low error"
    );
    let rel = |j: usize| ((out.params[j].abs() - truth[j].abs()) / truth[j]).abs();
    for (j, tol) in [(0, 0.05), (3, 0.05), (4, 0.05), (5, 0.05), (2, 0.10)] {
        assert!(
            rel(j) <= tol,
            "{name}: {} off by {:.1}%",
            ModelKind::Six.param_names()[j],
            100.0 * rel(j)
        );
    }
    let kr = &rep.uncertainty.params.0[1].1;
    assert!(
        rel(1) <= 0.10 || !kr.determined,
        "{name}: kr = {} neither within 10% nor flagged",
        out.params[1]
    );
}

#[test]
fn recovers_khaki_from_three_incidences() {
    check_recovery("khaki", &KHAKI, &[0.0, 10.0, 30.0]);
}

#[test]
fn recovers_yellow_from_two_incidences() {
    check_recovery("yellow", &YELLOW, &[0.0, 10.0]);
}

#[test]
fn hundred_seeds_reach_the_same_optimum() {
    for (name, truth, inc) in [
        ("khaki", KHAKI, &[0.0, 10.0, 30.0][..]),
        ("yellow", YELLOW, &[0.0, 10.0][..]),
    ] {
        let data = synth::in_plane(ModelKind::Six, &truth, inc, 2.5, 0.005, 7).unwrap();
        let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &data);
        let costs: Vec<f64> = (0..100)
            .map(|seed| {
                fit(
                    &problem,
                    &FitOptions {
                        seed,
                        ..Default::default()
                    },
                )
                .cost
            })
            .collect();
        let best = costs.iter().copied().fold(f64::INFINITY, f64::min);
        let hits = costs.iter().filter(|&&c| (c - best) / best <= 1e-6).count();
        println!(
            "{name}: {hits}/100 seeds within 1e-6 of the best cost {best:e}; worst {:e}",
            costs.iter().copied().fold(0.0, f64::max)
        );
        assert_eq!(hits, 100, "{name}: only {hits}/100 seeds reached the optimum");
    }
}

/// The kr verdict must hold for every noise draw, not one: over 12 noise seeds and three
/// viewing-angle steps, kr is within 10% of the truth or flagged as undetermined, and (on
/// the denser grids) the other parameters meet their targets.
#[test]
fn kr_is_within_10_percent_or_flagged_for_every_noise_draw() {
    let mut flagged = 0;
    let mut total = 0;
    for (name, truth, inc) in [
        ("khaki", KHAKI, &[0.0, 10.0, 30.0][..]),
        ("yellow", YELLOW, &[0.0, 10.0][..]),
    ] {
        for step in [1.0, 2.5, 5.0] {
            for noise_seed in 1..=12 {
                let data = synth::in_plane(ModelKind::Six, &truth, inc, step, 0.005, noise_seed).unwrap();
                let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &data);
                let out = fit(&problem, &FitOptions::default());
                let rep = report(&data, &problem, &out, &FitOptions::default());
                let rel = |j: usize| ((out.params[j].abs() - truth[j].abs()) / truth[j]).abs();
                let kr = &rep.uncertainty.params.0[1].1;
                total += 1;
                if !kr.determined {
                    flagged += 1;
                }
                assert!(
                    rel(1) <= 0.10 || !kr.determined,
                    "{name} step {step} noise seed {noise_seed}: kr = {} reported as determined",
                    out.params[1]
                );
                // The parameter targets need the denser grids (142+ points); at a 5 degree step
                // yellow has 70 points and |b| scatters by up to ~12% between noise draws.
                if step > 2.5 {
                    continue;
                }
                for (j, tol) in [(0, 0.05), (3, 0.05), (4, 0.05), (5, 0.05), (2, 0.10)] {
                    assert!(
                        rel(j) <= tol,
                        "{name} step {step} noise {noise_seed}: param {j} off by {:.1}%",
                        100.0 * rel(j)
                    );
                }
            }
        }
    }
    println!("kr flagged as undetermined in {flagged}/{total} fits");
}

/// One short annealing chain polished by LM, no grid, hops or probes: a search too weak to
/// find the optimum from every seed.
fn weak_search(seed: u64) -> FitOptions {
    FitOptions {
        seed,
        chains: 1,
        agree: 1,
        min_chains: 1,
        anneal: brdf_fit::anneal::AnnealOptions {
            evals: 21,
            screen: 20,
            ..brdf_fit::anneal::AnnealOptions::default()
        },
        ..FitOptions::without_verification()
    }
}

/// The 100-seed test has teeth: on khaki data with 1% noise the default engine reaches one
/// optimum from every seed, while a single LM polish from a screened random start without
/// annealing does not.
#[test]
fn seed_test_detects_a_weak_global_search() {
    let data = synth::in_plane(ModelKind::Six, &KHAKI, &[0.0, 10.0, 30.0], 2.5, 0.01, 7).unwrap();
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &data);
    let weak = weak_search(0);
    let run = |base: FitOptions| -> Vec<f64> {
        (0..100)
            .map(|seed| fit(&problem, &FitOptions { seed, ..base }).cost)
            .collect()
    };
    let strong = run(FitOptions::default());
    let weak = run(weak);
    let best = strong.iter().chain(&weak).copied().fold(f64::INFINITY, f64::min);
    let hits = |c: &[f64]| c.iter().filter(|&&x| (x - best) / best <= 1e-6).count();
    println!(
        "default engine {}/100, no annealing {}/100",
        hits(&strong),
        hits(&weak)
    );
    assert_eq!(hits(&strong), 100);
    assert!(
        hits(&weak) <= 90,
        "the weak search should miss the optimum from some seeds"
    );
}

/// A search too weak to find the optimum (no grid, one short chain, no hops) calls itself
/// converged on its own tests; the report's profile refits then find a lower cost with one
/// parameter held, and the report withdraws "converged", saying why. Real-data cases and
/// seeds where that happens must exist (or the check is never exercised), and every report
/// whose refits went below its optimum must say not converged.
#[test]
fn a_profile_refit_below_the_optimum_withdraws_converged() {
    let cases = crate::real_data_cases::cases();
    let mut caught = 0;
    for case in cases.iter().take(4) {
        let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &case.data);
        for seed in 0..6 {
            let opts = weak_search(seed);
            let out = fit(&problem, &opts);
            let r = report(&case.data, &problem, &out, &opts);
            if let Some(c) = r.uncertainty.refit_below {
                assert!(c < out.cost);
                assert!(!r.converged, "{} seed {seed}", case.name);
                let why = r.search.not_converged.as_deref().unwrap_or("");
                assert!(why.contains("a profile refit of the report"), "{why}");
                caught += usize::from(out.converged);
            }
        }
    }
    assert!(
        caught > 0,
        "no weak search called itself converged below a refit: the check was not exercised"
    );
}

/// Before: noise-free data fitted to rounding (RMS error 1e-17) were "not converged, the best
/// cost reached by 1 of 32" for every seed, the six-parameter model's and the microfacet
/// model's alike: every search ended at another cost of rounding noise (1e-30 against 2e-30),
/// which the relative agreement test told apart; and the report claimed that refitting
/// without one point lowered that cost by 5%. Costs below the rounding floor
/// (`brdf_fit::fit::cost_floor`) are one optimum, and no point's influence is claimed there.
/// Noisy data lie far above the floor, where the relative test alone decides, as before.
#[test]
fn noise_free_data_converge_and_claim_no_influence() {
    let ggx = [0.3, 0.2, 0.04, 0.5];
    for (kind, truth) in [(ModelKind::Six, &KHAKI[..]), (ModelKind::Ggx, &ggx[..])] {
        let data = synth::hemisphere(kind, truth, &[0.0, 20.0, 40.0], 10.0, 45.0, 0.0, 1).unwrap();
        let problem = Problem::from_dataset(kind, Residual::Relative, &data);
        let floor = brdf_fit::fit::cost_floor(&problem);
        for seed in 1..=4 {
            let opts = FitOptions {
                seed,
                ..Default::default()
            };
            let out = fit(&problem, &opts);
            let rep = report(&data, &problem, &out, &opts);
            assert!(
                out.cost <= floor,
                "{kind:?} seed {seed}: cost {:e} above {floor:e}",
                out.cost
            );
            assert!(
                rep.converged,
                "{kind:?} seed {seed}: {:?}",
                rep.search.not_converged
            );
            assert!(
                rep.influence.points.is_empty(),
                "{kind:?} seed {seed}: {:?}",
                rep.influence
            );
        }
        let noisy = synth::hemisphere(kind, truth, &[0.0, 20.0, 40.0], 10.0, 45.0, 0.005, 1).unwrap();
        let problem = Problem::from_dataset(kind, Residual::Relative, &noisy);
        let out = fit(&problem, &FitOptions::default());
        assert!(
            brdf_fit::fit::cost_floor(&problem) < brdf_fit::fit::AGREEMENT * out.cost,
            "{kind:?}: the floor would decide on noisy data ({:e})",
            out.cost
        );
        // Rows given a sigma of 1e-15 of their readings (one, or every other one): their
        // rounding is not every row's. With the floor a sum over rows (or their median) it
        // rose above every cost of this noisy fit, and any two searches counted as one optimum.
        for heavy_rows in [1, 2] {
            let mut heavy = noisy.clone();
            for (k, p) in heavy.points.iter_mut().enumerate() {
                let tiny = if heavy_rows == 1 { k == 7 } else { k % 2 == 0 };
                p.sigma = Some(if tiny { 1e-15 * p.brdf } else { 0.01 * p.brdf });
            }
            let problem = Problem::from_dataset(kind, Residual::Absolute, &heavy);
            let out = fit(&problem, &FitOptions::default());
            assert!(
                brdf_fit::fit::cost_floor(&problem) < brdf_fit::fit::AGREEMENT * out.cost,
                "{kind:?}, {heavy_rows}: heavy rows set the floor ({:e} against cost {:e})",
                brdf_fit::fit::cost_floor(&problem),
                out.cost
            );
        }
    }
}

/// Noise-free microfacet data with `f0 = kd = 0`. Before: "converged: false: the best cost was
/// reached by 0 of 32 chains" — a grid start's polish had found the data exactly (cost 2e-30,
/// below the cost's rounding floor), while every annealing chain agreed on a worse basin
/// (`ks` about 1e-16, cost 48); and `f0` or `kd` ended a rounding step off their bound
/// (4.9e-32, 1.3e-32), printed as values with huge relative errors or as "at the bound" with
/// another value. A cost at its rounding floor cannot be improved on (no cost is below 0), and
/// a parameter whose move onto its bound changes the cost by less than that floor sits there.
#[test]
fn noise_free_microfacet_data_at_the_bounds_converge_with_the_bounds_held() {
    let cases: [(&[f64], bool); 3] = [
        (&[0.5, 0.3, 0.0, 0.0], false),
        (&[0.6, 0.1, 0.0, 0.0], true),
        (&[0.6, 0.5, 0.0, 0.0], true),
    ];
    for (truth, full) in cases {
        let data = if full {
            synth::hemisphere(ModelKind::Ggx, truth, &[0.0, 20.0, 40.0, 60.0], 5.0, 30.0, 0.0, 7)
        } else {
            synth::in_plane(ModelKind::Ggx, truth, &[0.0, 10.0, 30.0], 5.0, 0.0, 7)
        }
        .unwrap();
        let r = brdf_fit::FitSettings::new(ModelKind::Ggx).fit(&data).unwrap();
        assert!(r.converged, "{truth:?}: {:?}", r.search.not_converged);
        for name in ["f0", "kd"] {
            let u = &r.uncertainty.params.0.iter().find(|(n, _)| n == name).unwrap().1;
            assert_eq!(u.value, 0.0, "{truth:?} {name}: {u:?}");
            assert!(!u.determined && u.se.is_none(), "{truth:?} {name}: {u:?}");
            assert!(
                u.note.as_deref().unwrap_or("").contains("at the search bound 0"),
                "{u:?}"
            );
        }
    }
}

/// A search whose chains disagree says so in one readable sentence: the reason read
/// "(2              needed)", the indentation of a continued line left inside the text.
#[test]
fn a_search_that_did_not_agree_says_so_without_stray_spaces() {
    let case = &crate::real_data_cases::cases()[0];
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &case.data);
    let mut seen = 0;
    for seed in 0..8 {
        let opts = FitOptions {
            chains: 2,
            agree: 2,
            min_chains: 2,
            hops: 0,
            ..weak_search(seed)
        };
        let out = fit(&problem, &opts);
        let Some(why) = out.search.not_converged.as_deref() else {
            continue;
        };
        if why.contains("could still improve") {
            seen += 1;
            assert!(why.contains("(2 needed)"), "{why}");
            assert!(!why.contains("  "), "{why}");
        }
    }
    assert!(
        seen > 0,
        "no weak search disagreed: the message was not exercised"
    );
}
