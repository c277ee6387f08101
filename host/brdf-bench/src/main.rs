//! `brdf-bench fit DATA.csv`: this fitting engine against scipy's `least_squares` from 32
//! random starts and `dual_annealing` on the same data and parameter box (`bench/fit.sh`
//! installs scipy). The benchmark itself is [`brdf_bench::fit::engine_vs_scipy`]; the
//! method comparison and the evaluation benchmark are `brdf bench fit` and `brdf bench eval`.

use anyhow::{bail, Context, Result};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("fit") => {
            let path = args.get(1).context("usage: brdf-bench fit DATA.csv")?;
            brdf_bench::fit::engine_vs_scipy(path.as_ref(), &mut std::io::stdout().lock())
        }
        Some("eval") => bail!("evaluation speed moved to `brdf bench eval` (bench/eval.sh)"),
        _ => bail!("usage: brdf-bench fit DATA.csv"),
    }
}
