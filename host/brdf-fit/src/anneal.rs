//! Simulated annealing over the nonlinear parameters, with the linear ones (`kb`, `kd`, or
//! `rho0`) solved exactly at every step (variable projection). This is the paper's global
//! method, made scale-free: the energy is `ln(cost)`, so one temperature schedule serves
//! every dataset and residual form.

use brdf_core::MAX_PARAMS;
use rand_core::RngCore;

use crate::problem::{bounds, nonlinear_indices, Problem};

/// Schedule of one annealing chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnnealOptions {
    /// Cost evaluations (passes over the data) per chain.
    pub evals: usize,
    /// Initial temperature, in units of `ln(cost)`.
    pub t_start: f64,
    /// Final temperature.
    pub t_end: f64,
    /// Initial proposal standard deviation, as a fraction of each parameter's range.
    pub step_start: f64,
    /// Final proposal standard deviation.
    pub step_end: f64,
}

impl Default for AnnealOptions {
    fn default() -> Self {
        AnnealOptions {
            evals: 400,
            t_start: 1.0,
            t_end: 1e-3,
            step_start: 0.3,
            step_end: 0.003,
        }
    }
}

/// Best point of one chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnnealResult {
    /// Internal parameters (nonlinear from the chain, linear from the projection).
    pub q: [f64; MAX_PARAMS],
    /// Projected cost there.
    pub cost: f64,
    /// Evaluations used.
    pub evals: usize,
}

/// Uniform in [0, 1) from 53 random bits.
pub fn unit<R: RngCore>(rng: &mut R) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// Standard normal deviate (Box–Muller; one of the pair is discarded for simplicity).
pub fn normal<R: RngCore>(rng: &mut R) -> f64 {
    let u1 = 1.0 - unit(rng);
    let u2 = unit(rng);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Runs one annealing chain on `problem` with the generator it is handed.
pub fn anneal<R: RngCore>(problem: &Problem, rng: &mut R, opts: AnnealOptions) -> AnnealResult {
    let kind = problem.kind();
    let idx = nonlinear_indices(kind);
    let (lo, hi) = bounds(kind);
    let d = idx.len();
    let to_nl = |u: &[f64; 4]| -> [f64; 4] {
        let mut nl = [0.0; 4];
        for (k, &j) in idx.iter().enumerate() {
            nl[k] = lo[j] + (hi[j] - lo[j]) * u[k];
        }
        nl
    };
    let energy = |u: &[f64; 4]| -> (f64, [f64; 2], f64) {
        let nl = to_nl(u);
        let (lin, cost) = problem.project(&nl[..d]);
        ((cost + 1e-300).ln(), lin, cost)
    };
    let mut u = [0.0; 4];
    for v in u.iter_mut().take(d) {
        *v = unit(rng);
    }
    let (mut e, mut lin, mut cost) = energy(&u);
    let mut best = (u, lin, cost);
    let mut evals = 1;
    let steps = opts.evals.max(2) - 1;
    if d > 0 {
        for k in 0..steps {
            let frac = k as f64 / steps as f64;
            let t = opts.t_start * (opts.t_end / opts.t_start).powf(frac);
            let sigma = opts.step_start * (opts.step_end / opts.step_start).powf(frac);
            let mut cand = u;
            for v in cand.iter_mut().take(d) {
                let mut x = *v + sigma * normal(rng);
                // Reflect into [0, 1].
                x = x.rem_euclid(2.0);
                if x > 1.0 {
                    x = 2.0 - x;
                }
                *v = x;
            }
            let (e2, lin2, cost2) = energy(&cand);
            evals += 1;
            if e2 <= e || unit(rng) < (-(e2 - e) / t).exp() {
                u = cand;
                e = e2;
                lin = lin2;
                cost = cost2;
                if cost < best.2 {
                    best = (u, lin, cost);
                }
            }
        }
    }
    let nl = to_nl(&best.0);
    let mut q = crate::kernel::assemble(kind, &nl[..d], best.1);
    for j in 0..problem.dim() {
        q[j] = q[j].clamp(lo[j], hi[j]);
    }
    AnnealResult {
        q,
        cost: best.2,
        evals,
    }
}
