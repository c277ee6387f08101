//! The global search on real measurements (the cases of `real_data_cases.rs`), fitted with
//! every model from seeds 1..=20: every fit must reach the best cost known to within
//! `SEED_COST_REL`, and none may beat it by more (the golden file would be stale). The best
//! costs live in `tests/golden/real_data_best_costs.csv`, from a much longer search and every
//! seed of both searches below; regenerate them, with the full figures of both searches,
//! after a change to the cost or the data:
//!
//!     cargo run --release -p brdf-fit --example real_data_golden
//!
//! The earlier search (`FitOptions::without_verification`) must fall short of the best cost
//! somewhere, or the check proves nothing. Prints one line per failing pair:
//!
//!     cargo xtask test -p brdf-fit --test fit real_data -- --nocapture

use brdf_core::ModelKind;
use brdf_fit::{fit, FitOptions, Problem, Residual};
use rayon::prelude::*;

use crate::real_data_cases::{cases, jobs, key, read_golden, SEEDS, SEED_COST_REL};

/// The golden best cost of every pair, or the reason the file cannot be used.
fn golden() -> std::collections::BTreeMap<String, f64> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(crate::real_data_cases::GOLDEN);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    read_golden(&text).unwrap()
}

/// How one seed's cost compares with the golden best.
fn verdict(cost: f64, best: f64) -> Option<String> {
    let excess = (cost - best) / best;
    if excess > SEED_COST_REL {
        Some(format!(
            "misses the best cost {best:e} by {excess:.2e} (cost {cost:e})"
        ))
    } else if excess < -SEED_COST_REL {
        Some(format!(
            "beats the golden best cost {best:e} by {:.2e} (cost {cost:e}): the golden file is stale; \
             regenerate it with `cargo run --release -p brdf-fit --example real_data_golden`",
            -excess
        ))
    } else {
        None
    }
}

#[test]
fn every_seed_reaches_the_best_known_optimum_on_real_data_and_the_earlier_search_does_not() {
    let cases = cases();
    let jobs = jobs(&cases);
    let golden = golden();
    let keys: Vec<String> = jobs.iter().map(|(c, m)| key(&c.name, *m)).collect();
    let missing: Vec<&String> = keys.iter().filter(|k| !golden.contains_key(*k)).collect();
    let extra: Vec<&String> = golden.keys().filter(|k| !keys.contains(k)).collect();
    assert!(
        missing.is_empty() && extra.is_empty(),
        "the golden file does not list exactly the pairs fitted (missing {missing:?}, extra {extra:?}); \
         regenerate it with `cargo run --release -p brdf-fit --example real_data_golden`"
    );
    let seeds: Vec<u64> = SEEDS.collect();
    let runs: Vec<(usize, u64)> = (0..jobs.len())
        .flat_map(|j| seeds.iter().map(move |&s| (j, s)))
        .collect();
    let problem = |j: usize| {
        let (c, model): (&crate::real_data_cases::Case, ModelKind) = jobs[j];
        Problem::from_dataset(model, Residual::Relative, &c.data)
    };
    let failures: Vec<String> = runs
        .par_iter()
        .filter_map(|&(j, seed)| {
            let r = fit(
                &problem(j),
                &FitOptions {
                    seed,
                    ..FitOptions::default()
                },
            );
            verdict(r.cost, golden[&keys[j]]).map(|why| format!("{} seed {seed}: {why}", keys[j]))
        })
        .collect();
    for f in &failures {
        println!("{f}");
    }
    println!(
        "search: {} of {} fits ({} pairs x {} seeds) off the golden best",
        failures.len(),
        runs.len(),
        jobs.len(),
        seeds.len()
    );
    assert!(failures.is_empty(), "{failures:#?}");
    // The earlier search must miss somewhere (the first miss found ends the search).
    let earlier = runs.par_iter().find_any(|&&(j, seed)| {
        let r = fit(
            &problem(j),
            &FitOptions {
                seed,
                ..FitOptions::without_verification()
            },
        );
        (r.cost - golden[&keys[j]]) / golden[&keys[j]] > SEED_COST_REL
    });
    assert!(
        earlier.is_some(),
        "the earlier search reached the best cost everywhere too: the check cannot tell them apart"
    );
    let &(j, seed) = earlier.unwrap();
    println!("earlier search: misses at {} seed {seed}", keys[j]);
}

#[test]
fn a_seed_off_the_golden_cost_either_way_fails() {
    assert!(verdict(1.0, 1.0).is_none());
    assert!(verdict(1.0 + 0.5e-6, 1.0).is_none());
    assert!(verdict(1.0 + 2e-6, 1.0).unwrap().contains("misses"));
    assert!(verdict(1.0 - 2e-6, 1.0).unwrap().contains("stale"));
    assert!(read_golden("case,model,best_cost\na,six,x\n")
        .unwrap_err()
        .contains("line 2"));
    assert!(read_golden("case,model,best_cost\na,six,1\na,six,1\n")
        .unwrap_err()
        .contains("twice"));
}
