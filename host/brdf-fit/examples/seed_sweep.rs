//! How often the fitting engine reaches the same optimum from 100 seeds, and how long a fit
//! takes, over the Table 1 materials and six random parameter sets at 1%, 10% and 20% noise.
//! With no arguments it runs the default options; `CHAINS AGREE EVALS MIN_CHAINS SCREEN`
//! override them (this is how the defaults were chosen); the environment variables `AGREE`
//! (agreeing searches, also the least number of chains), `HOPS` (quiet basin hops) and
//! `SKIP` (leave out the first N parameter sets) do too.
//!
//!     cargo run --release -p brdf-fit --example seed_sweep [-- 8 2 300 2 20]

use brdf_core::ModelKind;
use brdf_fit::anneal::{unit, AnnealOptions};
use brdf_fit::{fit, synth, FitOptions, Problem, Residual};
use rand_core::SeedableRng;

fn main() {
    let mut opts = FitOptions::default();
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("integer"))
        .collect();
    if let [chains, agree, evals, min_chains, screen] = args[..] {
        opts = FitOptions {
            chains,
            agree,
            min_chains,
            anneal: AnnealOptions {
                evals,
                screen,
                ..AnnealOptions::default()
            },
            ..opts
        };
    }
    let mut sets: Vec<(&str, [f64; 6], Vec<f64>)> = vec![
        ("khaki", brdf_core::TABLE1[0].1, vec![0.0, 10.0, 30.0]),
        ("yellow", brdf_core::TABLE1[1].1, vec![0.0, 10.0]),
        ("white", brdf_core::TABLE1[2].1, vec![30.0]),
    ];
    let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(99);
    for k in 0..6 {
        let mut u = || unit(&mut rng);
        let p = [
            0.05 + 0.5 * u(),
            (0.1_f64.ln() + (100.0_f64.ln() - 0.1_f64.ln()) * u()).exp(),
            -(5.0 + 60.0 * u()),
            0.3 + 1.2 * u(),
            0.05 + 0.6 * u(),
            1.5 * u(),
        ];
        let inc = if k % 2 == 0 {
            vec![0.0, 20.0, 45.0]
        } else {
            vec![15.0, 60.0]
        };
        sets.push(("random", p, inc));
    }
    let env = |k: &str| {
        std::env::var(k)
            .ok()
            .map(|v| v.parse::<usize>().expect("integer"))
    };
    if let Some(h) = env("HOPS") {
        opts.hops = h;
    }
    if let Some(h) = env("AGREE") {
        opts.agree = h;
        opts.min_chains = h;
    }
    if let Some(h) = env("SKIP") {
        sets.drain(..h);
    }
    println!("{opts:?}");
    for (name, p, inc) in &sets {
        for noise in [0.01, 0.1, 0.2] {
            let d = synth::in_plane(ModelKind::Six, p, inc, 2.5, noise, 7).expect("valid parameters");
            let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, &d);
            let runs: Vec<_> = (0..100)
                .map(|seed| fit(&problem, &FitOptions { seed, ..opts }))
                .collect();
            let best = runs.iter().map(|r| r.cost).fold(f64::INFINITY, f64::min);
            let hits = runs.iter().filter(|r| (r.cost - best) / best <= 1e-6).count();
            let mut gaps: Vec<f64> = runs
                .iter()
                .map(|r| (r.cost - best) / best)
                .filter(|&g| g > 1e-6)
                .collect();
            gaps.sort_by(f64::total_cmp);
            let ms = runs.iter().map(|r| r.seconds).sum::<f64>() * 10.0;
            let chains = runs.iter().map(|r| r.chain_costs.len()).sum::<usize>() as f64 / 100.0;
            println!(
                "{name:6} {:?} noise {:>4.0}%: {hits}/100 seeds at the optimum, {ms:.2} ms per fit, {chains:.1} chains",
                p.map(|v| (v * 1e3).round() / 1e3),
                noise * 100.0
            );
            let claimed = runs
                .iter()
                .filter(|r| (r.cost - best) / best > 1e-6 && r.converged)
                .count();
            if let (Some(lo), Some(hi)) = (gaps.first(), gaps.last()) {
                println!(
                    "       misses: relative cost gap {lo:.1e} to {hi:.1e}; {claimed} of {} said converged",
                    gaps.len()
                );
            }
        }
    }
}
