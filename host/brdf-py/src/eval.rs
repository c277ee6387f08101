//! `brdf.eval` and `brdf.albedo`: arrays through the batch path (f64) or the scalar f32 path, with `brdf eval`'s checks and messages.

use super::*;

/// The first non-finite value as the CLI reports it.
pub(crate) fn finite<T: Float>(values: &[T], kind: ModelKind) -> Result<(), Failure> {
    match values.iter().position(|f| !f.is_finite()) {
        None => Ok(()),
        Some(i) => Err(Failure::At(i, brdf_fit::params::not_finite(values[i], kind))),
    }
}

pub(crate) fn batch_failure(e: BatchError) -> Failure {
    match e {
        BatchError::Domain { index, error } => Failure::At(index, error.to_string()),
        other => Failure::General(other.to_string()),
    }
}

/// Validates angles in degrees as `brdf eval` validates its CSV rows.
pub(crate) fn check_degrees(cols: [&[f64]; 3]) -> Result<(), Failure> {
    for i in 0..cols[0].len() {
        brdf_fit::params::check_eval_degrees([cols[0][i], cols[1][i], cols[2][i]])
            .map_err(|e| Failure::At(i, e))?;
    }
    Ok(())
}

/// Angles in degrees to radians in f64, rounded once to `T` (as `brdf eval`).
pub(crate) fn radians<T: Float>(deg: &[f64]) -> Vec<T> {
    deg.iter().map(|d| T::from_f64(d.to_radians())).collect()
}

/// Most threads a call may ask for: far above any machine's cores, a bound on what one call
/// can create.
pub(crate) const MAX_THREADS: usize = 256;

/// Where an evaluation runs: every core (rayon's global pool), this thread alone, or a pool of
/// a given size. One such pool is kept for the next call of the same size; a call of another
/// size replaces it, and a replaced pool's threads end when the calls running in it return:
/// asking for many sizes in turn leaves one pool, not one per size (a pool kept per size let
/// threads=2..256 start 33,000 threads and starve the machine).
pub(crate) enum Threads {
    All,
    One,
    Pool(std::sync::Arc<rayon::ThreadPool>),
}

impl Threads {
    /// 0: all cores; 1: one thread; `n`: a pool of `n` (at most [`MAX_THREADS`]).
    pub(crate) fn new(threads: usize) -> PyResult<Threads> {
        type Kept = Option<(usize, std::sync::Arc<rayon::ThreadPool>)>;
        static KEPT: std::sync::Mutex<Kept> = std::sync::Mutex::new(None);
        match threads {
            0 => Ok(Threads::All),
            1 => Ok(Threads::One),
            n if n > MAX_THREADS => Err(PyValueError::new_err(format!(
                "threads {n}: at most {MAX_THREADS}"
            ))),
            n => {
                let mut kept = KEPT.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                if let Some((size, p)) = kept.as_ref() {
                    if *size == n {
                        return Ok(Threads::Pool(p.clone()));
                    }
                }
                // The old pool goes first, so that its threads and the new ones never add up.
                *kept = None;
                let p = std::sync::Arc::new(
                    rayon::ThreadPoolBuilder::new()
                        .num_threads(n)
                        .build()
                        .map_err(|e| PyValueError::new_err(format!("threads {n}: {e}")))?,
                );
                *kept = Some((n, p.clone()));
                Ok(Threads::Pool(p))
            }
        }
    }

    /// Runs `f`, telling it whether to spread its work (`true`) over the pool it runs in.
    pub(crate) fn run<R: Send>(&self, f: impl FnOnce(bool) -> R + Send) -> R {
        match self {
            Threads::All => f(true),
            Threads::One => f(false),
            Threads::Pool(p) => p.install(|| f(true)),
        }
    }
}

/// `brdf eval` on arrays: f64 through the batch path, f32 through the scalar path (the
/// firmware's arithmetic); on `threads` threads ([`Threads`]; each value the same bit for bit
/// whatever the count).
///
/// With `table` (a fitted table's device bytes, as `fitted` returns them) the model is its
/// base and every value is `f_model * exp(t)` (`brdf_core::fitted::Corrected`), in both
/// precisions through the scalar path.
#[pyfunction]
#[pyo3(signature = (model, params, theta_i, theta_r, phi, precision, threads, table=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn eval_angles<'py>(
    py: Python<'py>,
    model: &str,
    params: &str,
    theta_i: PyReadonlyArray1<'py, f64>,
    theta_r: PyReadonlyArray1<'py, f64>,
    phi: PyReadonlyArray1<'py, f64>,
    precision: &str,
    threads: usize,
    table: Option<&[u8]>,
) -> PyResult<Bound<'py, PyAny>> {
    let kind = parse_kind(model)?;
    let pool = Threads::new(threads)?;
    let cols = [
        slice(&theta_i, "theta_i")?,
        slice(&theta_r, "theta_r")?,
        slice(&phi, "phi")?,
    ];
    let table = match table {
        Some(bytes) => Some(
            brdf_core::fitted::FittedTable::new(bytes)
                .map_err(|e| PyValueError::new_err(format!("fitted table: {e}")))?,
        ),
        None => None,
    };
    if let Some(table) = table {
        return match precision {
            "f64" => {
                let base: AnyModel<f64> = build(kind, params)?;
                let out = py.detach(|| pool.run(|parallel| corrected(base, table, cols, kind, parallel)))?;
                Ok(PyArray1::from_vec(py, out).into_any())
            }
            "f32" => {
                let base: AnyModel<f32> = build(kind, params)?;
                let out = py.detach(|| pool.run(|parallel| corrected(base, table, cols, kind, parallel)))?;
                Ok(PyArray1::from_vec(py, out).into_any())
            }
            other => Err(PyValueError::new_err(format!(
                "unknown precision `{other}` (expected f64 or f32)"
            ))),
        };
    }
    match precision {
        "f64" => {
            let m: AnyModel<f64> = build(kind, params)?;
            let out = py.detach(|| pool.run(|parallel| batch_angles(&m, cols, kind, parallel)))?;
            Ok(PyArray1::from_vec(py, out).into_any())
        }
        "f32" => {
            let m: AnyModel<f32> = build(kind, params)?;
            let out = py.detach(|| pool.run(|parallel| scalar_angles(&m, cols, kind, parallel)))?;
            Ok(PyArray1::from_vec(py, out).into_any())
        }
        other => Err(PyValueError::new_err(format!(
            "unknown precision `{other}` (expected f64 or f32)"
        ))),
    }
}

/// The f64 batch path at angles in degrees, by chunks of [`par::PAR_CHUNK`] directions
/// (in parallel when asked): each chunk's angles checked as `brdf eval` checks them, turned
/// into radians in buffers of the chunk's own and evaluated into its part of the output, so
/// that no pass over the whole input runs on one thread and no whole-input copy is made.
/// Failures are the ones a pass over everything in turn would report: the first bad angle
/// anywhere, else the first direction outside the model's domain, else the first value that
/// is not finite.
fn batch_angles(
    m: &AnyModel<f64>,
    cols: [&[f64]; 3],
    kind: ModelKind,
    parallel: bool,
) -> Result<Vec<f64>, Failure> {
    use rayon::prelude::*;
    let b = Batch::new(m);
    let n = cols[0].len();
    let mut out = vec![0.0; n];
    // (bad angle, domain error, non-finite value) of one chunk, each its first.
    type Found = [Option<(usize, String)>; 3];
    let chunk = |k: usize, o: &mut [f64]| -> Found {
        let start = k * par::PAR_CHUNK;
        let len = o.len();
        // On the heap: a Python thread's stack may be small.
        let mut rad = vec![0.0f64; 3 * len];
        let (ti, rest) = rad.split_at_mut(len);
        let (tr, ph) = rest.split_at_mut(len);
        for i in 0..len {
            let deg = [cols[0][start + i], cols[1][start + i], cols[2][start + i]];
            if let Err(e) = brdf_fit::params::check_eval_degrees(deg) {
                return [Some((start + i, e)), None, None];
            }
            (ti[i], tr[i], ph[i]) = (deg[0].to_radians(), deg[1].to_radians(), deg[2].to_radians());
        }
        if let Err(e) = b.angles(ti, tr, ph, o) {
            return match batch_failure(e) {
                Failure::At(i, e) => [None, Some((start + i, e)), None],
                Failure::General(e) => [None, Some((start, e)), None],
            };
        }
        match o.iter().position(|f| !f.is_finite()) {
            Some(i) => [
                None,
                None,
                Some((start + i, brdf_fit::params::not_finite(o[i], kind))),
            ],
            None => [None, None, None],
        }
    };
    let found: Vec<Found> = if parallel {
        out.par_chunks_mut(par::PAR_CHUNK)
            .enumerate()
            .map(|(k, o)| chunk(k, o))
            .collect()
    } else {
        out.chunks_mut(par::PAR_CHUNK)
            .enumerate()
            .map(|(k, o)| chunk(k, o))
            .collect()
    };
    for kind in 0..3 {
        // Chunks are in order: the first one holding a failure of this kind holds the first.
        if let Some((i, e)) = found.iter().find_map(|f| f[kind].clone()) {
            return Err(Failure::At(i, e));
        }
    }
    Ok(out)
}

/// A base model times a fitted table at angles in degrees, through [`scalar_angles`].
/// Per direction (degrees, checked as `brdf eval` does), whether the fitted table `table`
/// covers it (`brdf_core::fitted::FittedTable::covers`: its measurements informed it);
/// `brdf.eval_fit` warns about the others, as `brdf eval --fit` does.
#[pyfunction]
pub(crate) fn table_covers<'py>(
    py: Python<'py>,
    table: &[u8],
    theta_i: PyReadonlyArray1<'py, f64>,
    theta_r: PyReadonlyArray1<'py, f64>,
    phi: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let table = brdf_core::fitted::FittedTable::new(table)
        .map_err(|e| PyValueError::new_err(format!("fitted table: {e}")))?;
    let cols = [
        slice(&theta_i, "theta_i")?,
        slice(&theta_r, "theta_r")?,
        slice(&phi, "phi")?,
    ];
    let out = py.detach(|| -> Result<Vec<bool>, Failure> {
        check_degrees(cols)?;
        let [a, b, c] = cols.map(radians::<f64>);
        Ok((0..a.len())
            .map(|i| table.covers(&brdf_core::Geometry::from_angles(a[i], b[i], c[i])))
            .collect())
    });
    Ok(PyArray1::from_vec(py, out?))
}

fn corrected<T: Float + Send + Sync>(
    base: AnyModel<T>,
    table: brdf_core::fitted::FittedTable<'_>,
    cols: [&[f64]; 3],
    kind: ModelKind,
    parallel: bool,
) -> Result<Vec<T>, Failure> {
    scalar_angles(
        &brdf_core::fitted::Corrected { base, table },
        cols,
        kind,
        parallel,
    )
}

/// `m` at angles in degrees through the scalar path (radians in f64, rounded once to `T`),
/// on all cores when `parallel` (each value the same bit for bit), with `brdf eval`'s checks.
fn scalar_angles<T: Float + Send + Sync, M: Brdf<T> + Sync>(
    m: &M,
    cols: [&[f64]; 3],
    kind: ModelKind,
    parallel: bool,
) -> Result<Vec<T>, Failure> {
    use rayon::prelude::*;
    check_degrees(cols)?;
    let [a, b, c] = cols.map(radians::<T>);
    let one = |i: usize| m.eval_angles(a[i], b[i], c[i]);
    let out: Vec<T> = if parallel {
        (0..a.len())
            .into_par_iter()
            .with_min_len(par::PAR_CHUNK)
            .map(one)
            .collect()
    } else {
        (0..a.len()).map(one).collect()
    };
    finite(&out, kind)?;
    Ok(out)
}

/// Directional-hemispherical reflectance at incidences `theta_i` (degrees) through the batch
/// path, by `brdf_core::checks::albedo_batch` with `panels` panels (`AlbedoRule::new`: a
/// count outside its range is a `ValueError`), or (`None`) the fit
/// report's rule for the model (`AlbedoRule::for_model`).
#[pyfunction]
pub(crate) fn albedo<'py>(
    py: Python<'py>,
    model: &str,
    params: &str,
    theta_i: PyReadonlyArray1<'py, f64>,
    panels: Option<u64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    use brdf_core::checks::{albedo_batch, AlbedoRule};
    let kind = parse_kind(model)?;
    let m: AnyModel<f64> = build(kind, params)?;
    let rule = match panels {
        Some(p) => AlbedoRule::new(p).map_err(|e| PyValueError::new_err(e.to_string()))?,
        None => AlbedoRule::for_model(&m),
    };
    let ti = slice(&theta_i, "theta_i")?;
    let out = py.detach(|| -> Result<Vec<f64>, Failure> {
        for (i, &v) in ti.iter().enumerate() {
            if !(v.is_finite() && (0.0..=90.0).contains(&v)) {
                return Err(Failure::At(
                    i,
                    format!("theta_i: zenith {v} deg is outside [0, 90]"),
                ));
            }
        }
        let b = Batch::new(&m);
        Ok(ti
            .iter()
            .map(|d| albedo_batch(&b, d.to_radians(), rule))
            .collect())
    })?;
    Ok(PyArray1::from_vec(py, out))
}

/// Evaluates cosines or vectors in precision `T` through the batch path (on all cores when
/// `parallel`).
pub(crate) fn eval_batch<T: Float + Send + Sync>(
    kind: ModelKind,
    params: &str,
    inputs: &[&[f64]],
    parallel: bool,
) -> Result<Vec<T>, Failure> {
    let m: AnyModel<T> = build(kind, params)?;
    if let [ci, cr, cp] = inputs[..] {
        check_zenith_cosines::<T>([ci, cr, cp])?;
    }
    let cols: Vec<Vec<T>> = inputs
        .iter()
        .map(|c| c.iter().map(|&v| T::from_f64(v)).collect())
        .collect();
    let mut out = vec![T::ZERO; inputs[0].len()];
    let what = if cols.len() == 3 {
        Inputs::Cosines([&cols[0], &cols[1], &cols[2]])
    } else {
        Inputs::Vectors([&cols[0], &cols[1], &cols[2]], [&cols[3], &cols[4], &cols[5]])
    };
    par::eval(&Batch::new(&m), what, &mut out, parallel).map_err(batch_failure)?;
    finite(&out, kind)?;
    Ok(out)
}

/// Refuses a zenith cosine below 0 (a zenith beyond 90 deg, below the horizon) as
/// `brdf.eval` refuses a zenith beyond 90 deg ([`brdf_fit::params::check_eval_degrees`]); the
/// core takes zenith cosines in [-1, 1] and gives 0 below the horizon. The first direction any
/// check fails is the one named: at a value the core refuses (not finite, outside [-1, 1])
/// this stops and leaves the core to name it. Each value is judged as the core sees it,
/// rounded to `T`, and named as given.
pub(crate) fn check_zenith_cosines<T: Float>(cols: [&[f64]; 3]) -> Result<(), Failure> {
    const NAMES: [&str; 3] = ["cos_theta_i", "cos_theta_r", "cos_phi"];
    for i in 0..cols[0].len() {
        for (k, name) in NAMES.iter().enumerate() {
            let given = cols[k][i];
            let c = T::from_f64(given).to_f64();
            if !(-1.0..=1.0).contains(&c) {
                return Ok(());
            }
            if k < 2 && c < 0.0 {
                return Err(Failure::At(
                    i,
                    format!(
                        "{name} = {} is outside [0, 1] (a zenith beyond 90 deg, below the horizon)",
                        brdf_core::Compact(given)
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// `Batch::cosines` (3 arrays) or `Batch::vectors` (6 arrays: wi x, y, z, wr x, y, z).
#[pyfunction]
pub(crate) fn eval_columns<'py>(
    py: Python<'py>,
    model: &str,
    params: &str,
    columns: Vec<PyReadonlyArray1<'py, f64>>,
    precision: &str,
    threads: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let kind = parse_kind(model)?;
    let pool = Threads::new(threads)?;
    if columns.len() != 3 && columns.len() != 6 {
        return Err(PyValueError::new_err("internal: need 3 or 6 columns"));
    }
    let cols: Vec<&[f64]> = columns
        .iter()
        .map(|c| slice(c, "input"))
        .collect::<PyResult<_>>()?;
    match precision {
        "f64" => {
            let out = py.detach(|| pool.run(|parallel| eval_batch::<f64>(kind, params, &cols, parallel)))?;
            Ok(PyArray1::from_vec(py, out).into_any())
        }
        "f32" => {
            let out = py.detach(|| pool.run(|parallel| eval_batch::<f32>(kind, params, &cols, parallel)))?;
            Ok(PyArray1::from_vec(py, out).into_any())
        }
        other => Err(PyValueError::new_err(format!(
            "unknown precision `{other}` (expected f64 or f32)"
        ))),
    }
}
