//! Regenerates the golden best costs of the real-data search test
//! (`tests/golden/real_data_best_costs.csv`): for every case and model, the lowest cost of a
//! much longer search (48 chains, every one run, annealing ten times as long, 16 hops) and of
//! every seed of the default and the earlier (unverified) search. Prints, per search, how
//! many pairs reach that best from every seed and the time per fit (about 6 minutes of CPU).
//!
//!     cargo run --release -p brdf-fit --example real_data_golden

#[path = "../tests/fit/real_data_cases.rs"]
mod real_data_cases;

use brdf_fit::{fit, FitOptions, Problem, Residual};
use rayon::prelude::*;
use real_data_cases::{cases, jobs, key, long_search, GOLDEN, REFERENCE_CHAINS, SEEDS, SEED_COST_REL};

/// One search's costs over the seeds, and the seconds they took.
type SearchRuns = (Vec<f64>, f64);

fn main() {
    let cases = cases();
    let jobs = jobs(&cases);
    let searches = [
        ("search", FitOptions::default()),
        ("earlier search", FitOptions::without_verification()),
    ];
    // Per pair: the reference cost, then per search (costs over the seeds, seconds).
    let per_job: Vec<(f64, Vec<SearchRuns>)> = jobs
        .par_iter()
        .map(|&(c, model)| {
            let problem = Problem::from_dataset(model, Residual::Relative, &c.data);
            let runs = searches
                .iter()
                .map(|(_, opts)| {
                    let mut seconds = 0.0;
                    let costs = SEEDS
                        .map(|seed| {
                            let r = fit(&problem, &FitOptions { seed, ..*opts });
                            seconds += r.seconds;
                            r.cost
                        })
                        .collect();
                    (costs, seconds)
                })
                .collect();
            (fit(&problem, &long_search(REFERENCE_CHAINS)).cost, runs)
        })
        .collect();
    let mut out = String::from("case,model,best_cost\n");
    let best: Vec<f64> = per_job
        .iter()
        .map(|(reference, runs)| {
            runs.iter()
                .flat_map(|(c, _)| c.iter().copied())
                .fold(*reference, f64::min)
        })
        .collect();
    for ((c, model), b) in jobs.iter().zip(&best) {
        assert!(!c.name.contains(','), "a case name holds a comma: {}", c.name);
        out.push_str(&format!("{},{b:e}\n", key(&c.name, *model)));
    }
    for (s, (label, _)) in searches.iter().enumerate() {
        let mut failing = 0;
        let mut seconds = 0.0;
        let mut worst: f64 = 1.0;
        for (((c, model), b), (_, runs)) in jobs.iter().zip(&best).zip(&per_job) {
            let (costs, t) = &runs[s];
            seconds += t;
            worst = costs.iter().fold(worst, |w, &x| w.max(x / b));
            let reached = costs.iter().filter(|&&x| (x - b) / b <= SEED_COST_REL).count();
            if reached < costs.len() {
                failing += 1;
            }
            println!(
                "{label}: {:28} {:9} best cost {b:.9e}  seeds reaching it {reached:2}/{}",
                c.name,
                model.name(),
                costs.len()
            );
        }
        let fits = (jobs.len() * SEEDS.count()) as f64;
        println!(
            "{label}: {failing} of {} pairs fail (worst seed at {worst:.2} times the best cost); \
             {:.1} ms per fit on average",
            jobs.len(),
            1e3 * seconds / fits
        );
    }
    // The file reads back as the test reads it, one row per pair.
    assert_eq!(real_data_cases::read_golden(&out).unwrap().len(), jobs.len());
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(GOLDEN);
    std::fs::write(&path, out).unwrap();
    println!("wrote {}", path.display());
}
