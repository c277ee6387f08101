//! `brdf bench fit`: fitting methods, time against final error over seeds.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{anyhow, Context, Result};
use brdf_core::ModelKind;
use brdf_fit::anneal::AnnealOptions;
use brdf_fit::embedded::fit_embedded;
use brdf_fit::{fit, load_csv, FitOptions, LoadOptions, Problem, Residual};
use brdf_plot::{pareto_front, TradePoint};
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

struct Method {
    name: String,
    seconds: Vec<f64>,
    errors: Vec<f64>,
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

impl FitBench {
    pub fn run(self) -> Result<()> {
        let file = self.data.display().to_string();
        let loaded =
            load_csv(&self.data, LoadOptions::default()).with_context(|| format!("cannot load {file}"))?;
        let data = loaded
            .datasets
            .first()
            .ok_or_else(|| anyhow!("{file}: no dataset"))?;
        let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, data);
        let hybrid = |evals: usize| FitOptions {
            anneal: AnnealOptions {
                evals,
                ..AnnealOptions::default()
            },
            ..FitOptions::default()
        };
        let lm_only = |chains: usize| FitOptions {
            chains,
            min_chains: chains,
            agree: chains,
            anneal: AnnealOptions {
                evals: 1,
                screen: 1,
                ..AnnealOptions::default()
            },
            // No grid starts, probes or hops: the polish alone.
            ..FitOptions::without_verification()
        };
        let configs: Vec<(String, FitOptions)> = vec![
            ("anneal 50/chain + LM".into(), hybrid(50)),
            ("anneal 300/chain + LM (default)".into(), hybrid(300)),
            ("anneal 2000/chain + LM".into(), hybrid(2000)),
            (
                "earlier search: 2 chains agree".into(),
                FitOptions::without_verification(),
            ),
            ("LM, 1 random start".into(), lm_only(1)),
            ("LM, 8 random starts".into(), lm_only(8)),
        ];
        let mut methods = Vec::new();
        for (name, base) in configs {
            let mut m = Method {
                name,
                seconds: Vec::new(),
                errors: Vec::new(),
            };
            for seed in 0..self.seeds {
                let opts = FitOptions { seed, ..base };
                let out = fit(&problem, &opts);
                m.seconds.push(out.seconds);
                m.errors.push(rms_rel(data, &problem, &out.q));
            }
            methods.push(m);
        }
        let budget = brdf_fit::embedded::DEFAULT_BUDGET;
        let mut m = Method {
            name: format!("embedded f32 annealer, {budget}"),
            seconds: Vec::new(),
            errors: Vec::new(),
        };
        for seed in 0..self.seeds {
            let out = fit_embedded(ModelKind::Six, data, &problem, budget, seed)?;
            m.seconds.push(out.seconds);
            m.errors.push(rms_rel(data, &problem, &out.q));
        }
        methods.push(m);
        if !self.no_scipy {
            methods.extend(scipy(&self.data));
        }

        let best = methods
            .iter()
            .flat_map(|m| m.errors.iter().copied())
            .fold(f64::INFINITY, f64::min);
        // Charted and ranked by the worst seed: a method is only as good as its failures.
        let points: Vec<TradePoint> = methods
            .iter()
            .map(|m| TradePoint {
                label: m.name.clone(),
                cost: median(&m.seconds),
                error: m.errors.iter().copied().fold(0.0, f64::max),
                worst: None,
            })
            .collect();
        let front = pareto_front(&points);
        println!(
            "six-parameter fit of {file} ({} points), relative residuals, one core; best RMS relative error found {best:.6e}",
            data.points.len()
        );
        println!(
            "{:<34} {:>6} {:>12} {:>13} {:>13} {:>9}  pareto",
            "method", "runs", "median s", "median error", "worst error", "reach best"
        );
        std::fs::create_dir_all(&self.out)
            .with_context(|| format!("cannot create {}", self.out.display()))?;
        let csv_path = self.out.join("fit.csv");
        let mut csv = csv::Writer::from_path(&csv_path)
            .with_context(|| format!("cannot write {}", csv_path.display()))?;
        csv.write_record([
            "method",
            "runs",
            "median_seconds",
            "median_rms_rel",
            "worst_rms_rel",
            "reach_best",
            "pareto",
        ])?;
        for (i, (m, p)) in methods.iter().zip(&points).enumerate() {
            let med = median(&m.errors);
            let reach = m.errors.iter().filter(|&&e| e <= best * 1.001).count();
            let share = format!("{reach}/{}", m.errors.len());
            let on = front.contains(&i);
            println!(
                "{:<34} {:>6} {:>12.5} {:>13.6e} {:>13.6e} {:>9}  {}",
                m.name,
                m.errors.len(),
                p.cost,
                med,
                p.error,
                share,
                if on { "yes" } else { "" }
            );
            csv.write_record([
                m.name.clone(),
                m.errors.len().to_string(),
                format!("{:.6}", p.cost),
                format!("{med:.6e}"),
                format!("{:.6e}", p.error),
                share,
                on.to_string(),
            ])?;
        }
        csv.flush()?;
        for ext in ["svg", "png"] {
            brdf_plot::tradeoff(
                &self.out.join(format!("fit.{ext}")),
                &format!("six-parameter fit of {}: time against error", short(&self.data)),
                "median seconds per fit (one core)",
                "RMS relative error of the worst seed",
                &points,
            )
            .map_err(|e| anyhow!("{e}"))?;
        }
        println!("wrote {}/fit.csv and fit (.svg, .png)", self.out.display());
        Ok(())
    }
}

fn short(p: &Path) -> String {
    p.file_name()
        .map_or_else(|| p.display().to_string(), |f| f.to_string_lossy().into_owned())
}

/// scipy's peers on the same data (bench/scipy_fit.py), one run each; none if python3 or
/// scipy is missing (said on standard error).
fn scipy(data: &Path) -> Vec<Method> {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench/scipy_fit.py");
    let out = match Command::new("python3").arg(script).arg(data).output() {
        Ok(o) if o.status.success() => o,
        Ok(o) => {
            let err = String::from_utf8_lossy(&o.stderr);
            eprintln!(
                "scipy peers skipped: {}",
                err.lines().last().unwrap_or("python3 failed")
            );
            return Vec::new();
        }
        Err(e) => {
            eprintln!("scipy peers skipped: cannot run python3: {e}");
            return Vec::new();
        }
    };
    let Ok(v) = serde_json::from_slice::<serde_json::Value>(&out.stdout) else {
        eprintln!("scipy peers skipped: unexpected output");
        return Vec::new();
    };
    [
        ("least_squares_32", "scipy least_squares, 32 starts"),
        ("dual_annealing", "scipy dual_annealing"),
    ]
    .iter()
    .filter_map(|(key, name)| {
        Some(Method {
            name: name.to_string(),
            seconds: vec![v[key]["seconds"].as_f64()?],
            errors: vec![v[key]["rms_rel"].as_f64()?],
        })
    })
    .collect()
}

/// RMS relative error of the fit with internal parameters `q` over the data.
fn rms_rel(data: &brdf_fit::Dataset, problem: &Problem, q: &[f64]) -> f64 {
    let y: Vec<f64> = data.points.iter().map(|p| p.brdf).collect();
    brdf_fit::report::metrics(&problem.values(q), &y).rms_rel
}
