//! The peers the benchmarks measure in the same run: scipy's fitters on a dataset
//! (`bench/scipy_fit.py`) and numpy's vectorised evaluation of a grid
//! (`bench/numpy_eval.py`). Each runner returns the peer's figures, or why it could not run
//! (python3, scipy or numpy missing), so that a benchmark reports the peer as skipped.

use std::path::Path;
use std::process::Command;

/// The scripts' directory, `bench/` at the repository root.
fn script(name: &str) -> String {
    format!("{}/../../bench/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// Runs `python3 SCRIPT ARGS...`; its standard output, or the last line of its standard
/// error (or why python3 could not start).
fn python(script_name: &str, args: &[&std::ffi::OsStr]) -> Result<Vec<u8>, String> {
    match Command::new("python3")
        .arg(script(script_name))
        .args(args)
        .output()
    {
        Ok(o) if o.status.success() => Ok(o.stdout),
        Ok(o) => {
            let err = String::from_utf8_lossy(&o.stderr);
            Err(err.lines().last().unwrap_or("python3 failed").to_owned())
        }
        Err(e) => Err(format!("cannot run python3: {e}")),
    }
}

/// One scipy fit of a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct PeerFit {
    /// Method, as printed: `scipy least_squares, 32 starts` or `scipy dual_annealing`.
    pub name: &'static str,
    /// Wall-clock seconds of the run.
    pub seconds: f64,
    /// RMS relative error of its fit over the data.
    pub rms_rel: f64,
}

/// The JSON keys of `bench/scipy_fit.py` and the names the benchmarks print.
const SCIPY_METHODS: [(&str, &str); 2] = [
    ("least_squares_32", "scipy least_squares, 32 starts"),
    ("dual_annealing", "scipy dual_annealing"),
];

/// scipy's `least_squares` from 32 random starts and `dual_annealing`, one run each, on the
/// six-parameter model with relative residuals over the CSV dataset `data` and the host
/// engine's parameter box. `Err` says why the peers were skipped.
pub fn scipy_fit(data: &Path) -> Result<[PeerFit; 2], String> {
    let stdout = python("scipy_fit.py", &[data.as_os_str()])?;
    let v: serde_json::Value =
        serde_json::from_slice(&stdout).map_err(|e| format!("unexpected output: {e}"))?;
    let one = |(key, name): (&str, &'static str)| -> Result<PeerFit, String> {
        let field = |f: &str| {
            v[key][f]
                .as_f64()
                .ok_or_else(|| format!("unexpected output: no {key}.{f}"))
        };
        Ok(PeerFit {
            name,
            seconds: field("seconds")?,
            rms_rel: field("rms_rel")?,
        })
    };
    Ok([one(SCIPY_METHODS[0])?, one(SCIPY_METHODS[1])?])
}

/// numpy's vectorised f64 evaluation of the six-parameter model `p` on the grid of
/// `brdf bench eval` (`points` per axis, zeniths to `max_theta` degrees): the best
/// nanoseconds per point and its values (read back from the raw f64 file it writes in
/// `dir`). `Err` says why the peer was skipped.
pub fn numpy_eval(
    points: usize,
    max_theta: f64,
    p: &[f64; 6],
    dir: &Path,
) -> Result<(f64, Vec<f64>), String> {
    let values = dir.join("numpy-values.f64");
    let params = p.map(|v| v.to_string()).join(",");
    let (points, max_theta) = (points.to_string(), max_theta.to_string());
    let stdout = python(
        "numpy_eval.py",
        &[
            points.as_ref(),
            max_theta.as_ref(),
            params.as_ref(),
            values.as_os_str(),
        ],
    )?;
    let text = String::from_utf8_lossy(&stdout);
    let ns = text.split_whitespace().next().and_then(|t| t.parse::<f64>().ok());
    let bytes = std::fs::read(&values).ok();
    let _ = std::fs::remove_file(&values);
    match (ns, bytes) {
        (Some(ns), Some(b)) => Ok((
            ns,
            b.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect(),
        )),
        _ => Err(format!("unexpected output {text:?}")),
    }
}
