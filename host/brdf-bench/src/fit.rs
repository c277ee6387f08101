//! Fitting speed and final error against scipy on the same dataset.

use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};
use brdf_core::ModelKind;
use brdf_fit::report::report;
use brdf_fit::{fit, load_csv, FitOptions, LoadOptions, Problem, Residual};

/// Seeds timed for this engine; the median time and the worst error are reported.
const SEEDS: u64 = 50;

pub fn run(path: &str) -> Result<()> {
    let loaded = load_csv(Path::new(path), LoadOptions::default())?;
    let data = loaded.datasets.first().context("no dataset")?;
    let problem = Problem::from_dataset(ModelKind::Six, Residual::Relative, data);
    let mut times = Vec::new();
    let mut worst_err: f64 = 0.0;
    let mut best_err = f64::INFINITY;
    for seed in 0..SEEDS {
        let opts = FitOptions {
            seed,
            ..FitOptions::default()
        };
        let out = fit(&problem, &opts);
        let r = report(data, &problem, &out, &opts);
        times.push(out.seconds);
        worst_err = worst_err.max(r.metrics.rms_rel);
        best_err = best_err.min(r.metrics.rms_rel);
    }
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    println!(
        "six-parameter fit of {path} ({} points, {} incidences), relative residuals, one core",
        data.points.len(),
        data.incidences().len()
    );
    println!("{:<34} {:>12} {:>14}", "method", "seconds", "rms rel error");
    println!(
        "{:<34} {:>12.5} {:>14.6e}",
        format!("this engine (median of {SEEDS} seeds)"),
        median,
        worst_err
    );
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench/scipy_fit.py");
    let out = Command::new("python3").arg(script).arg(path).output();
    let out = match out {
        Ok(o) if o.status.success() => o,
        Ok(o) => {
            let err = String::from_utf8_lossy(&o.stderr);
            println!(
                "scipy peers: SKIPPED ({})",
                err.lines().last().unwrap_or("python3 failed")
            );
            return Ok(());
        }
        Err(e) => {
            println!("scipy peers: SKIPPED (cannot run python3: {e})");
            return Ok(());
        }
    };
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).context("scipy peer output")?;
    let mut scipy_best = f64::INFINITY;
    for (key, label) in [
        ("least_squares_32", "scipy least_squares, 32 starts"),
        ("dual_annealing", "scipy dual_annealing"),
    ] {
        let secs = v[key]["seconds"].as_f64().context("seconds")?;
        let err = v[key]["rms_rel"].as_f64().context("rms_rel")?;
        scipy_best = scipy_best.min(err);
        println!(
            "{label:<34} {secs:>12.5} {err:>14.6e}   ({:.0}x this engine's time)",
            secs / median
        );
    }
    let ls = v["least_squares_32"]["seconds"].as_f64().context("seconds")?;
    let reached = worst_err <= scipy_best * 1.001;
    println!(
        "goal: scipy's best error (within 0.1%) at least 100x faster than 32-start least_squares: \
         error {} (worst seed {:.6e} vs scipy best {:.6e}), speed-up {:.0}x",
        if reached { "reached" } else { "NOT reached" },
        worst_err,
        scipy_best,
        ls / median
    );
    if best_err > scipy_best * 1.001 {
        bail!("this engine never reached scipy's best error");
    }
    Ok(())
}
