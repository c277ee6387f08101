//! The fitting engine: annealing chains, each polished by Levenberg–Marquardt, until the best
//! optimum has been reached independently often enough; then basin-hopping moves from it,
//! which must all fail to improve it, before the fit is called converged.
//!
//! What "converged" means here (every part must hold):
//!
//! 1. The best cost was reached (within [`AGREEMENT`]) by at least [`FitOptions::agree`]
//!    independent searches — annealing chains from random starts, or basin-hopping moves
//!    from a perturbed best point — in the same lobe state: a chain that ended with the lobe
//!    switched off (`kb = 0`, where `kr`, `b`, `a` have no effect) never counts as agreeing
//!    with a lobe-on optimum, and the reverse.
//! 2. When the best fit has its lobe off, [`FitOptions::lobe_probes`] chains that explore only
//!    lobe-on points, polished, found nothing better: a lobe-off optimum is only accepted
//!    once lobe-on optima have been searched for specifically.
//! 3. The last [`FitOptions::hops`] basin-hopping moves from the best point (one or two of
//!    its nonlinear parameters redrawn over their whole range, the linear ones solved, then
//!    polished) found nothing better.
//! 4. The final polish met its convergence test.
//!
//! A run that reaches [`FitOptions::chains`] chains without (1)–(3) reports
//! `converged: false` and why, with the best point it found.
//!
//! A robust loss (see [`crate::problem::Loss`]) is fitted by iteratively reweighted rounds:
//! the global search works on least squares weighted by the loss at the previous round's
//! optimum, the polish on the robust cost itself.

use std::time::Instant;

use brdf_core::{ModelKind, MAX_PARAMS};
use rand_core::SeedableRng;
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use crate::anneal::{anneal, unit, AnnealOptions};
use crate::grid::{grid_starts, GRID_STARTS};
use crate::kernel::{assemble, to_natural};
use crate::lm::{minimise, LmOptions, LmResult};
use crate::problem::{nonlinear_indices, Problem};

/// Settings of one fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// Seed of the run; the same seed gives the same result bit for bit.
    pub seed: u64,
    /// Most annealing chains (each polished by LM) to run.
    pub chains: usize,
    /// Run at least this many chains.
    pub min_chains: usize,
    /// Independent arrivals at the best cost required (see the module docs).
    pub agree: usize,
    /// Basin-hopping moves from the best point that must all fail to improve it.
    pub hops: usize,
    /// Starting points taken from the fixed grid over the nonlinear parameters (see
    /// [`crate::grid`]), polished before the chains run.
    pub grid_starts: usize,
    /// Lobe-on probe chains run when the best fit has its lobe off (six-parameter models).
    pub lobe_probes: usize,
    /// Schedule of each chain.
    pub anneal: AnnealOptions,
    /// Local polish settings.
    pub lm: LmOptions,
    /// Iteratively reweighted rounds of the global search under a robust loss.
    pub irls_rounds: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            seed: 1,
            chains: 32,
            min_chains: 3,
            agree: 3,
            hops: 4,
            grid_starts: GRID_STARTS,
            lobe_probes: 2,
            anneal: AnnealOptions::default(),
            lm: LmOptions::default(),
            irls_rounds: 3,
        }
    }
}

impl FitOptions {
    /// The search of earlier releases: two chains agreeing on the cost end the search, lobe
    /// state ignored, no probes, no basin hopping, at most 8 chains. Kept to show what the
    /// real-data suite catches.
    pub fn without_verification() -> Self {
        FitOptions {
            chains: 8,
            min_chains: 2,
            agree: 2,
            hops: 0,
            grid_starts: 0,
            lobe_probes: 0,
            ..FitOptions::default()
        }
    }
}

/// Relative cost difference under which two polished searches count as the same optimum.
pub const AGREEMENT: f64 = 1e-9;

/// How the global search went.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SearchSummary {
    /// Annealing chains run (probes included).
    pub chains: usize,
    /// Lobe-on probe chains among them.
    pub lobe_probes: usize,
    /// Basin-hopping moves made.
    pub hops: usize,
    /// Independent searches that reached the best cost.
    pub agreeing: usize,
    /// Why the fit is not called converged, if it is not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub not_converged: Option<String>,
}

/// The optimum found.
#[derive(Clone, Debug, PartialEq)]
pub struct FitOutcome {
    /// Model fitted.
    pub kind: ModelKind,
    /// Internal parameters (`ln kr`, `|b|`).
    pub q: [f64; MAX_PARAMS],
    /// The paper's parameters, core order (`b` negative).
    pub params: [f64; MAX_PARAMS],
    /// The cost at the optimum: `0.5 * sum r^2`, or the robust cost under a robust loss.
    pub cost: f64,
    /// Final cost of every chain after its polish, in chain order.
    pub chain_costs: Vec<f64>,
    /// Cost evaluations in all (passes over the data).
    pub evals: usize,
    /// The search met every test of the module docs.
    pub converged: bool,
    /// Chains, probes, hops and agreement.
    pub search: SearchSummary,
    /// Wall time of the fit.
    pub seconds: f64,
}

fn lobe_off(kind: ModelKind, q: &[f64; MAX_PARAMS]) -> bool {
    matches!(kind, ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five) && q[0] == 0.0
}

fn same_optimum(kind: ModelKind, a: &LmResult, best: &LmResult) -> bool {
    (a.cost - best.cost).abs() <= AGREEMENT * best.cost.abs().max(f64::MIN_POSITIVE)
        && lobe_off(kind, &a.q) == lobe_off(kind, &best.q)
}

/// Fits `problem` with `opts`.
pub fn fit(problem: &Problem, opts: &FitOptions) -> FitOutcome {
    let started = Instant::now();
    let mut out = if problem.loss().is_linear() {
        search(problem, opts)
    } else {
        // Iteratively reweighted: each round's global search sees least squares weighted by
        // the loss at the previous round's optimum; every polish minimises the robust cost.
        let mut p = problem.clone();
        let mut best = search(&p, opts);
        let mut evals = best.evals;
        for round in 1..opts.irls_rounds.max(1) {
            if problem.stopped() {
                break;
            }
            p.reweight(&best.q);
            let r = search(
                &p,
                &FitOptions {
                    seed: opts.seed.wrapping_add(round as u64),
                    ..*opts
                },
            );
            evals += r.evals;
            if r.cost < best.cost {
                best = r;
            }
        }
        best.evals = evals;
        best
    };
    if problem.stopped() {
        // A stop between reweighted rounds leaves an earlier round's outcome, which may have
        // converged on its own problem: the fit as asked for did not.
        out.converged = false;
        out.search.not_converged = Some("the fit was stopped before its search ended".to_owned());
    }
    out.seconds = started.elapsed().as_secs_f64();
    out
}

/// The global search on one (possibly reweighted) problem.
fn search(problem: &Problem, opts: &FitOptions) -> FitOutcome {
    let kind = problem.kind();
    let (lo, hi) = problem.bounds();
    let probes_apply = matches!(kind, ModelKind::Six | ModelKind::SixCos2) && opts.lobe_probes > 0;
    let need = opts.agree.max(1);
    let max_chains = opts.chains.max(1);
    // Hops are cheaper than chains (no annealing); as many as the chain limit.
    let max_hops = max_chains.max(opts.hops);
    let mut found: Vec<LmResult> = Vec::new();
    let mut chain_costs = Vec::with_capacity(opts.chains);
    let (mut evals, mut chains, mut probes, mut hops, mut quiet_hops) = (0, 0, 0, 0, 0);
    let mut hopping = false;
    let mut hop_rng = Pcg64Mcg::seed_from_u64(opts.seed ^ 0xB0B5_1ED5_5EED_0001);
    let best_of = |found: &[LmResult]| -> LmResult {
        *found
            .iter()
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
            .expect("at least one search")
    };
    // Grid polishes are seed-independent and often start side by side: they may supply the
    // best point but never count as independent arrivals at it. Only chains and hops do.
    let mut grid_n = 0;
    let agreeing = |found: &[LmResult], grid_n: usize| -> usize {
        let best = best_of(found);
        found[grid_n..]
            .iter()
            .filter(|f| same_optimum(kind, f, &best))
            .count()
    };
    let probes_done = |best: &LmResult, probes: usize| {
        !probes_apply || !lobe_off(kind, &best.q) || probes >= opts.lobe_probes
    };
    // The seed-independent part: polish the best nodes of the fixed grid.
    for start in grid_starts(problem, opts.grid_starts) {
        let r = minimise(problem, &start, &lo, &hi, opts.lm);
        evals += r.evals + 1;
        found.push(r);
        grid_n += 1;
    }
    loop {
        if problem.stopped() {
            break;
        }
        if !hopping {
            if chains >= max_chains {
                break;
            }
            // A lobe-on probe when the best so far has its lobe off and probes remain.
            let probe = probes_apply
                && !found.is_empty()
                && lobe_off(kind, &best_of(&found).q)
                && probes < opts.lobe_probes;
            let seed = opts
                .seed
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .wrapping_add(chains as u64);
            let mut rng = Pcg64Mcg::seed_from_u64(seed);
            let schedule = AnnealOptions {
                lobe_on: probe,
                ..opts.anneal
            };
            let a = anneal(problem, &mut rng, schedule);
            let r = minimise(problem, &a.q, &lo, &hi, opts.lm);
            evals += a.evals + r.evals;
            chain_costs.push(r.cost);
            found.push(r);
            chains += 1;
            probes += usize::from(probe);
            hopping = chains >= opts.min_chains
                && agreeing(&found, grid_n) >= need
                && probes_done(&best_of(&found), probes);
        } else {
            if hops >= max_hops || quiet_hops >= opts.hops {
                break;
            }
            // Basin hopping: must fail `hops` times in a row; an arrival at the best cost
            // counts towards the agreement.
            let before = best_of(&found);
            let start = hop_start(problem, &before.q, &mut hop_rng);
            let r = minimise(problem, &start, &lo, &hi, opts.lm);
            evals += r.evals + 1;
            hops += 1;
            let improved = r.cost < before.cost * (1.0 - AGREEMENT);
            found.push(r);
            quiet_hops = if improved { 0 } else { quiet_hops + 1 };
            if improved && !probes_done(&best_of(&found), probes) {
                // The new best has its lobe off: probe for lobe-on optima first.
                hopping = false;
            }
        }
    }
    let best = best_of(&found);
    let agree_n = agreeing(&found, grid_n);
    let not_converged = if problem.stopped() {
        Some("the fit was stopped before its search ended".to_owned())
    } else if agree_n < need {
        Some(format!(
            "the best cost was reached by {agree_n} of {} chains and hops ({need} needed): the search could still improve",
            found.len() - grid_n
        ))
    } else if !probes_done(&best, probes) {
        Some("the lobe is off and the lobe-on probes were not run (chain limit)".to_owned())
    } else if quiet_hops < opts.hops {
        Some(format!(
            "basin hopping still improved the best point ({quiet_hops} of {} moves since without improvement)",
            opts.hops
        ))
    } else if !best.converged {
        Some("the local polish stopped at its iteration limit".to_owned())
    } else {
        None
    };
    FitOutcome {
        kind,
        q: best.q,
        params: to_natural(kind, &best.q[..kind.param_count()]),
        cost: best.cost,
        chain_costs,
        evals,
        converged: not_converged.is_none(),
        search: SearchSummary {
            chains,
            lobe_probes: probes,
            hops,
            agreeing: agree_n,
            not_converged,
        },
        seconds: 0.0,
    }
}

/// A basin-hopping start: the best point with one or two of its nonlinear parameters redrawn
/// uniformly over their search range and the linear ones solved for the new shape.
fn hop_start(problem: &Problem, q: &[f64; MAX_PARAMS], rng: &mut Pcg64Mcg) -> [f64; MAX_PARAMS] {
    let kind = problem.kind();
    let idx = nonlinear_indices(kind);
    if idx.is_empty() {
        return *q;
    }
    let (lo, hi) = problem.bounds();
    let mut nl: Vec<f64> = idx.iter().map(|&j| q[j]).collect();
    let moves = 1 + usize::from(idx.len() > 1 && unit(rng) < 0.5);
    for _ in 0..moves {
        let k = ((unit(rng) * idx.len() as f64) as usize).min(idx.len() - 1);
        let j = idx[k];
        nl[k] = lo[j] + (hi[j] - lo[j]) * unit(rng);
    }
    let (lin, _) = problem.project(&nl);
    assemble(kind, &nl, lin)
}
