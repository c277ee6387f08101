//! The fitting engine: annealing chains, each polished by Levenberg–Marquardt, run one after
//! another until two of them agree on the best cost (or the chain limit is reached).

use std::time::Instant;

use brdf_core::{ModelKind, MAX_PARAMS};
use rand_core::SeedableRng;
use rand_pcg::Pcg64Mcg;

use crate::anneal::{anneal, AnnealOptions};
use crate::kernel::to_natural;
use crate::lm::{minimise, LmOptions};
use crate::problem::{bounds, Problem};

/// Settings of one fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// Seed of the run; the same seed gives the same result bit for bit.
    pub seed: u64,
    /// Most annealing chains (each polished by LM) to run: the multi-start.
    pub chains: usize,
    /// Run at least this many chains before stopping on agreement.
    pub min_chains: usize,
    /// Stop early once this many polished chains agree on the best cost (within
    /// [`AGREEMENT`]): the optimum has then been reached from independent starts.
    pub agree: usize,
    /// Schedule of each chain.
    pub anneal: AnnealOptions,
    /// Local polish settings.
    pub lm: LmOptions,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            seed: 1,
            chains: 8,
            min_chains: 2,
            agree: 2,
            anneal: AnnealOptions::default(),
            lm: LmOptions::default(),
        }
    }
}

/// Relative cost difference under which two polished chains count as the same optimum.
pub const AGREEMENT: f64 = 1e-9;

/// The optimum found.
#[derive(Clone, Debug, PartialEq)]
pub struct FitOutcome {
    /// Model fitted.
    pub kind: ModelKind,
    /// Internal parameters (`ln kr`, `|b|`).
    pub q: [f64; MAX_PARAMS],
    /// The paper's parameters, core order (`b` negative).
    pub params: [f64; MAX_PARAMS],
    /// `0.5 * sum r^2` at the optimum.
    pub cost: f64,
    /// Final cost of every chain after its polish, in chain order.
    pub chain_costs: Vec<f64>,
    /// Cost evaluations in all (passes over the data).
    pub evals: usize,
    /// The winning polish met a convergence test.
    pub converged: bool,
    /// Wall time of the fit.
    pub seconds: f64,
}

/// Fits `problem` with `opts`.
pub fn fit(problem: &Problem, opts: &FitOptions) -> FitOutcome {
    let started = Instant::now();
    let kind = problem.kind();
    let (lo, hi) = bounds(kind);
    let mut best: Option<(crate::lm::LmResult, usize)> = None;
    let mut chain_costs = Vec::with_capacity(opts.chains);
    let mut evals = 0;
    for chain in 0..opts.chains.max(1) {
        let seed = opts
            .seed
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add(chain as u64);
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let a = anneal(problem, &mut rng, opts.anneal);
        let r = minimise(problem, &a.q, &lo, &hi, opts.lm);
        evals += a.evals + r.evals;
        chain_costs.push(r.cost);
        if best.as_ref().is_none_or(|(b, _)| r.cost < b.cost) {
            best = Some((r, chain));
        }
        let best_cost = best.as_ref().map_or(f64::INFINITY, |(b, _)| b.cost);
        let agreeing = chain_costs
            .iter()
            .filter(|&&c| (c - best_cost).abs() <= AGREEMENT * best_cost.abs().max(f64::MIN_POSITIVE))
            .count();
        if chain + 1 >= opts.min_chains && agreeing >= opts.agree.max(1) {
            break;
        }
    }
    let (r, _) = best.expect("at least one chain");
    FitOutcome {
        kind,
        q: r.q,
        params: to_natural(kind, &r.q[..kind.param_count()]),
        cost: r.cost,
        chain_costs,
        evals,
        converged: r.converged,
        seconds: started.elapsed().as_secs_f64(),
    }
}
