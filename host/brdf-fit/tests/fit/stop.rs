//! A fit abandoned part way (`Stop`, the Python package's Ctrl-C) ends promptly and never
//! claims to have converged.

use brdf_core::ModelKind;
use brdf_fit::{synth, FitSettings, Stop};

/// Khaki's six parameters at three incidences, 1% noise.
fn khaki() -> brdf_fit::Dataset {
    synth::in_plane(
        ModelKind::Six,
        &brdf_core::TABLE1[0].1,
        &[0.0, 30.0, 60.0],
        5.0,
        0.01,
        1,
    )
    .unwrap()
}

/// A stop and the thread that requests it after `ms` milliseconds.
fn stop_after(ms: u64) -> (Stop, std::thread::JoinHandle<()>) {
    let stop = Stop::new();
    let trigger = stop.clone();
    let waker = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(ms));
        trigger.request();
    });
    (stop, waker)
}

fn settings(anneal_evals: usize) -> FitSettings {
    let mut s = FitSettings::new(ModelKind::Six);
    s.options.anneal.evals = anneal_evals;
    s.options.chains = 64;
    s
}

#[test]
fn a_stop_requested_before_the_fit_runs_no_chain() {
    let d = khaki();
    let stop = Stop::new();
    stop.request();
    let r = settings(1_000_000).fit_until(&d, &stop).unwrap();
    assert!(!r.converged, "a stopped fit claimed convergence");
    assert_eq!(r.search.chains, 0);
    assert!(
        r.search
            .not_converged
            .as_deref()
            .is_some_and(|w| w.contains("stopped")),
        "{:?}",
        r.search.not_converged
    );
    // The same fit without the stop runs its chains and converges.
    let full = settings(300).fit(&d).unwrap();
    assert!(full.converged && full.search.chains >= 3);
}

/// A stop requested while a chain anneals (10^8 evaluations: minutes) ends it: the chain
/// looks at the flag every `Stop::EVERY` moves. Without that the test would run for minutes
/// and its evaluation count would reach 10^8.
#[test]
fn a_stop_requested_during_a_chain_ends_it() {
    let d = khaki();
    let (stop, waker) = stop_after(200);
    let r = settings(100_000_000).fit_until(&d, &stop).unwrap();
    waker.join().unwrap();
    assert!(!r.converged);
    assert!(r.search.chains <= 1, "chains {}", r.search.chains);
    assert!(r.evals < 100_000_000, "evaluations {}", r.evals);
}

/// Under a robust loss the fit runs reweighted rounds; a stop between two of them left the
/// first round's outcome, which could say converged. Whenever the stop arrives before the fit
/// returns, the fit must not claim convergence.
#[test]
fn a_stopped_robust_fit_never_claims_convergence() {
    let d = khaki();
    for delay_ms in [0, 5, 30] {
        let mut s = settings(3000);
        s.loss = brdf_fit::Loss {
            kind: brdf_fit::LossKind::Cauchy,
            scale: 0.1,
        };
        let (stop, waker) = stop_after(delay_ms);
        let r = s.fit_until(&d, &stop).unwrap();
        let stopped_before_the_end = stop.requested();
        waker.join().unwrap();
        assert!(
            !(r.converged && stopped_before_the_end),
            "delay {delay_ms} ms: a stopped fit said converged"
        );
    }
}
