//! `brdf bench fit`: fitting methods, time against final error over seeds
//! ([`brdf_bench::fit::MethodBench`]).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

/// Six-parameter fits of one dataset by several methods, each from `--seeds` seeds: the
/// verified search with annealing schedules of three lengths (the default is 300 evaluations
/// per chain), the earlier search (two agreeing chains, no grid, probes or hops),
/// Levenberg-Marquardt alone from one and from eight random starts, the embedded
/// f32 annealer at its default budget, and scipy's `least_squares` (32 starts) and
/// `dual_annealing` when python3 with scipy is present (one run each). Prints and writes
/// median time, median and worst RMS relative error and the share of seeds that reach the
/// best error found (within 0.1%); the chart plots median time against the worst seed's
/// error and marks the Pareto front of those.
#[derive(Debug, Args)]
pub struct FitBench {
    /// Data file (canonical CSV).
    #[arg(default_value = "data/khaki-synthetic-inplane.csv")]
    data: PathBuf,
    /// Seeds per method.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    seeds: u64,
    /// Output directory for fit.csv and the charts.
    #[arg(long, default_value = "docs/bench")]
    out: PathBuf,
    /// Skip the scipy peers.
    #[arg(long)]
    no_scipy: bool,
}

impl FitBench {
    pub fn run(self) -> Result<()> {
        brdf_bench::fit::MethodBench {
            data: self.data,
            seeds: self.seeds,
            out: self.out,
            scipy: !self.no_scipy,
        }
        .run(&mut std::io::stdout().lock())
    }
}
