//! `brdf-bench`: benchmarks that print figures against peers measured in the same run.
//!
//! - `brdf-bench eval`: nanoseconds per six-parameter evaluation on a 10^6-point grid, f64
//!   and f32, from angles and from cosines, against numpy's vectorised evaluation of the same
//!   grid (`bench/eval.sh` installs numpy).
//! - `brdf-bench fit DATA.csv`: this fitting engine against scipy's `least_squares` from 32
//!   random starts and `dual_annealing` on the same data and parameter box (`bench/fit.sh`
//!   installs scipy).
//!
//! Nothing here asserts a time: it prints figures and ratios.

mod fit;

use std::hint::black_box;
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use brdf_core::{Brdf, Float, Model, SixParam};

/// Grid points per axis: theta_i x theta_r x phi = N^3 points.
const N: usize = 100;
/// Timed repetitions; the fastest is reported (least disturbed by the machine).
const REPS: usize = 7;
const KHAKI: [f64; 6] = [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2];

/// The grid, identical to `bench/numpy_eval.py`: zeniths `(k + 0.5) / N * 90` degrees,
/// `phi = (k + 0.5) / N * 360` degrees, radians.
fn axis(k: usize, span_deg: f64) -> f64 {
    ((k as f64 + 0.5) / N as f64 * span_deg).to_radians()
}

struct Grid<T> {
    angles: Vec<[T; 3]>,
    cosines: Vec<[T; 3]>,
}

fn grid<T: Float>() -> Grid<T> {
    let mut angles = Vec::with_capacity(N * N * N);
    let mut cosines = Vec::with_capacity(N * N * N);
    for i in 0..N {
        for r in 0..N {
            for p in 0..N {
                let a = [axis(i, 90.0), axis(r, 90.0), axis(p, 360.0)];
                angles.push(a.map(T::from_f64));
                cosines.push(a.map(|x| T::from_f64(x.cos())));
            }
        }
    }
    Grid { angles, cosines }
}

/// Best-of-REPS nanoseconds per point, and the sum of the values (a checksum that also keeps
/// the optimiser from removing the work).
fn time(points: usize, mut f: impl FnMut() -> f64) -> (f64, f64) {
    let mut best = f64::INFINITY;
    let mut sum = 0.0;
    for _ in 0..REPS {
        let t = Instant::now();
        sum = black_box(f());
        best = best.min(t.elapsed().as_secs_f64());
    }
    (best * 1e9 / points as f64, sum)
}

fn bench<T: Float>(label: &str) -> Result<Vec<(String, f64, f64)>> {
    let p: Vec<T> = KHAKI.iter().map(|&v| T::from_f64(v)).collect();
    let m = SixParam::<T>::from_params(&p).context("khaki parameters")?;
    let g = grid::<T>();
    let n = g.angles.len();
    let from_angles = time(n, || {
        g.angles
            .iter()
            .map(|&[ti, tr, phi]| m.eval_angles(ti, tr, phi).to_f64())
            .sum()
    });
    let from_cosines = time(n, || {
        g.cosines
            .iter()
            .map(|&[ci, cr, cp]| m.eval_cosines(ci, cr, cp).to_f64())
            .sum()
    });
    Ok(vec![
        (format!("{label} from angles"), from_angles.0, from_angles.1),
        (format!("{label} from cosines"), from_cosines.0, from_cosines.1),
    ])
}

/// Runs the numpy peer; `None` (with the reason printed) when python3 or numpy is missing.
fn numpy_peer() -> Option<(f64, f64)> {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench/numpy_eval.py");
    let out = match Command::new("python3").arg(script).arg(N.to_string()).output() {
        Ok(o) => o,
        Err(e) => {
            println!("numpy peer: SKIPPED (cannot run python3: {e})");
            return None;
        }
    };
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        println!(
            "numpy peer: SKIPPED ({})",
            err.lines().last().unwrap_or("python3 failed")
        );
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let mut it = text.split_whitespace().map(str::parse::<f64>);
    match (it.next(), it.next()) {
        (Some(Ok(ns)), Some(Ok(sum))) => Some((ns, sum)),
        _ => {
            println!("numpy peer: SKIPPED (unexpected output {text:?})");
            None
        }
    }
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("eval") | None => eval(),
        Some("fit") => fit::run(args.get(1).context("usage: brdf-bench fit DATA.csv")?),
        Some(other) => bail!("unknown benchmark `{other}` (eval, fit)"),
    }
}

fn eval() -> Result<()> {
    println!(
        "six-parameter model (khaki), {} points ({N}^3 grid of theta_i, theta_r in (0, 90) deg, phi in (0, 360) deg), best of {REPS}, one core",
        N * N * N
    );
    let mut rows = bench::<f64>("f64")?;
    rows.extend(bench::<f32>("f32")?);
    let reference_sum = rows[0].2;
    for (name, _, sum) in &rows {
        let rel = ((sum - reference_sum) / reference_sum).abs();
        if rel > 1e-5 {
            bail!("{name}: checksum {sum} differs from the f64 reference {reference_sum}");
        }
    }
    let peer = numpy_peer();
    if let Some((_, sum)) = peer {
        let rel = ((sum - reference_sum) / reference_sum).abs();
        if rel > 1e-9 {
            bail!("numpy checksum {sum} differs from the f64 reference {reference_sum} (rel {rel:e})");
        }
    }
    println!("{:<24} {:>10} {:>14}", "path", "ns/eval", "numpy / this");
    for (name, ns, _) in &rows {
        let ratio = peer.map_or("-".to_owned(), |(np, _)| format!("{:.1}x", np / ns));
        println!("{name:<24} {ns:>10.2} {ratio:>14}");
    }
    if let Some((np, _)) = peer {
        println!("{:<24} {np:>10.2} {:>14}", "numpy f64 (vectorised)", "1.0x");
        println!(
            "goal: f64 from angles at least 10x faster than numpy: {:.1}x",
            np / rows[0].1
        );
    }
    Ok(())
}
