//! `brdf-bench`: benchmarks that print figures against peers measured in the same run.
//!
//! - `brdf-bench fit DATA.csv`: this fitting engine against scipy's `least_squares` from 32
//!   random starts and `dual_annealing` on the same data and parameter box (`bench/fit.sh`
//!   installs scipy).
//!
//! Evaluation speed against numpy is `brdf bench eval` (`bench/eval.sh`), which times every
//! evaluation path in one run.
//!
//! Nothing here asserts a time: it prints figures and ratios.

mod fit;

use anyhow::{bail, Context, Result};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("fit") => fit::run(args.get(1).context("usage: brdf-bench fit DATA.csv")?),
        Some("eval") => bail!("evaluation speed moved to `brdf bench eval` (bench/eval.sh)"),
        _ => bail!("usage: brdf-bench fit DATA.csv"),
    }
}
