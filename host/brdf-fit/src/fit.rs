//! The fitting engine: annealing chains, each polished by Levenberg–Marquardt, until the best
//! optimum has been reached independently often enough; then basin-hopping moves from it,
//! which must all fail to improve it, before the fit is called converged.
//!
//! What "converged" means here (every part must hold):
//!
//! 1. The best cost was reached (within [`AGREEMENT`], or both at the cost's rounding floor,
//!    [`cost_floor`]) by at least [`FitOptions::agree`]
//!    independent searches — annealing chains from random starts, or basin-hopping moves
//!    from a perturbed best point — in the same lobe state: a chain that ended with the lobe
//!    switched off (`kb = 0`, where `kr`, `b`, `a` have no effect) never counts as agreeing
//!    with a lobe-on optimum, and the reverse. Or the best cost lies at or below the rounding
//!    floor itself: no cost lies below 0, so no search can improve on it but by rounding (a
//!    grid start's polish fitted noise-free data exactly while every chain agreed on a worse
//!    basin, and the fit said "reached by 0 of 32 chains").
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
use rayon::prelude::*;
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

/// Relative error of one model value as the fit computes it, at the rounding level: the
/// fitting kernels and any other f64 evaluation of the same model (the core's, which made a
/// synthetic reading, or another formulation) agree within
/// [`brdf_core::tolerance::F64_REFORMULATION_REL`] (a few dozen roundings of 1.1e-16, the lobe's
/// `exp` multiplying its argument's by `|b|`). Residuals this small are rounding, not misfit:
/// see [`cost_floor`].
pub const VALUE_ROUNDING_REL: f64 = brdf_core::tolerance::F64_REFORMULATION_REL;

/// The cost's rounding floor of `problem`: the cost if every model value were off by
/// [`VALUE_ROUNDING_REL`] of its reading, with every row as light as the lightest:
/// `0.5 VALUE_ROUNDING_REL^2 n min(u_i)` over rows with `u_i > 0`, `u_i` the squared residual
/// of a model off by its whole reading ([`Problem::importance`]: the reading over its sigma,
/// or times its weight, squared). Costs below it are rounding noise: on noise-free data every
/// search ends somewhere below it, at costs that differ by factors of several (1e-30 against
/// 3e-30), and [`AGREEMENT`]'s relative test alone called such a fit not converged; two costs
/// both below it are one optimum ([`same_cost`]). Noisy data's costs lie some 1e20 times above
/// it (1% noise: `0.5 sum_i u_i 1e-4`), where it changes nothing. The lightest row, not the
/// sum nor the median: rows given sigmas of 1e-15 of their readings (one row, or half of
/// them) raised the floor above every cost of a noisy fit, and searches 23 times apart each
/// said "converged".
pub fn cost_floor(problem: &Problem) -> f64 {
    let lightest = (0..problem.len())
        .map(|i| problem.importance(i))
        .filter(|u| *u > 0.0)
        .fold(f64::INFINITY, f64::min);
    if lightest.is_finite() {
        0.5 * VALUE_ROUNDING_REL * VALUE_ROUNDING_REL * problem.len() as f64 * lightest
    } else {
        0.0
    }
}

/// Whether the costs `a` and `best` count as the same optimum: within [`AGREEMENT`] of
/// `best`, or within `floor` (the problem's [`cost_floor`]) of each other.
pub fn same_cost(a: f64, best: f64, floor: f64) -> bool {
    let d = (a - best).abs();
    d <= AGREEMENT * best.abs().max(f64::MIN_POSITIVE) || d <= floor
}

/// Whether the cost `a` lies below `b` by more than [`same_cost`] allows: a better optimum,
/// not the same one reached again.
pub fn below(a: f64, b: f64, floor: f64) -> bool {
    a < b * (1.0 - AGREEMENT) && b - a > floor
}

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
    /// The best cost lies at or below the cost's rounding floor ([`cost_floor`]): the data are
    /// fitted to rounding, and no search can improve on it (part (1) of the module's rule
    /// holds whatever [`SearchSummary::agreeing`] says).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub at_cost_floor: bool,
    /// Why the fit is not called converged, if it is not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub not_converged: Option<String>,
    /// Points the global search saw, when it ran on a subsample of a large problem
    /// ([`SEARCH_POINTS`]); the polish saw every point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample: Option<usize>,
    /// Parameters the search left on a bound of its box that the model's range lies beyond,
    /// each as a sentence: the embedded engine's linear weights on their upper bound
    /// ([`crate::embedded`]), where the best fit may lie further out. Empty for the full
    /// engine, whose weights are bounded only below.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub on_search_box: Vec<String>,
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

fn same_optimum(kind: ModelKind, a: &LmResult, best: &LmResult, floor: f64) -> bool {
    same_cost(a.cost, best.cost, floor) && lobe_off(kind, &a.q) == lobe_off(kind, &best.q)
}

/// Points above which the global search runs on a subsample of [`SEARCH_POINTS`] points
/// (drawn by weight and reading, see [`search_sample`]) and only the final polish sees them
/// all.
///
/// A pass over 16,384 points costs about 0.2 ms, so the search (a few thousand passes) takes
/// about a second whatever the file's size, and the polish on all points (tens of passes,
/// on all cores) adds about 50 ns per point per pass.
pub const SEARCH_POINTS: usize = 16_384;

/// Largest relative difference, at the optimum, between the search subsample's cost and the
/// share of every point's it stands for ([`SearchSample::scale`]) for a large fit to be called
/// converged. For Gaussian noise the subsample's 16,384 draws estimate the share to about 1%
/// (the relative spread of `r^2`, sqrt 2, over sqrt 16,384); 10% is far beyond that, and is
/// what a handful of heavy points missed by the draws gives.
pub const SAMPLE_COST_REL: f64 = 0.1;

/// Under a robust loss the search runs on a subsample only when every point's factor
/// ([`SearchSample::factors`]) is within this of 1: a residual then moves by under 0.5%, far
/// inside the loss's scale, and no point changes between inlier and outlier.
pub const ROBUST_FACTOR_REL: f64 = 0.01;

/// Fits `problem` with `opts`.
///
/// Up to [`SEARCH_POINTS`] points the search of the module docs runs on every point. Above,
/// it runs on [`search_sample`]'s subsample, and its optimum is polished on every point; the
/// fit is "converged" when the search on the subsample met every test of the module docs, the
/// subsample's cost at the final point is within [`SAMPLE_COST_REL`] of the share of every
/// point's it stands for, and the polish on every point met its convergence test. The
/// outcome's cost is every point's; its `chain_costs` are the subsample's; `search.sample`
/// says how many points the search saw. Under a robust loss with points of unequal weight the
/// search runs on every point (a subsample's factors would change which points are outliers;
/// [`ROBUST_FACTOR_REL`]).
pub fn fit(problem: &Problem, opts: &FitOptions) -> FitOutcome {
    let started = Instant::now();
    let drawn = (problem.len() > SEARCH_POINTS).then(|| search_sample(problem, SEARCH_POINTS));
    // A robust loss is not linear in a point's weight: a subsample standing for other points
    // than it holds (factors away from 1) would move its outliers, so it searches them all.
    let drawn = drawn.filter(|d| {
        problem.loss().is_linear() || d.factors.iter().all(|&f| (f - 1.0).abs() <= ROBUST_FACTOR_REL)
    });
    let mut out = match drawn {
        None => fit_points(problem, opts),
        Some(drawn) => fit_sampled(problem, &drawn, opts),
    };
    settle_on_bounds(problem, &mut out);
    out.seconds = started.elapsed().as_secs_f64();
    out
}

/// Puts on its bound a parameter that ended a rounding step off it: one whose move onto the
/// bound changes the cost by at most the cost's rounding floor ([`cost_floor`]: the two points
/// are one optimum), when it lies within the report's bound tolerance of a finite box's bound
/// (`report::on_bound`) or anywhere above the lower bound 0 of a weight's half-open range.
/// The polish's projected steps stop where a step lands, a rounding error past the bound
/// (`f0` 4.9e-32, `kd` 4e-41 on noise-free data): reported as values with standard errors of
/// 31137% of a denormal, or as "at the search bound 0" beside another value.
fn settle_on_bounds(problem: &Problem, out: &mut FitOutcome) {
    let (lo, hi) = problem.bounds();
    let floor = cost_floor(problem);
    let p = out.kind.param_count();
    for j in 0..p {
        if problem.is_fixed(j) {
            continue;
        }
        let bound = if (hi[j] - lo[j]).is_finite() {
            crate::report::on_bound(out.q[j], lo[j], hi[j])
        } else {
            lo[j].is_finite().then_some(lo[j])
        };
        let Some(b) = bound.filter(|&b| b != out.q[j]) else {
            continue;
        };
        let mut q = out.q;
        q[j] = b;
        let cost = problem.cost(&q);
        if cost <= out.cost + floor {
            out.q = q;
            out.cost = cost;
            out.params = to_natural(out.kind, &q[..p]);
            out.evals += 1;
        }
    }
}

/// The search on `drawn`'s subsample of `problem`, polished on every point (see [`fit`]).
fn fit_sampled(problem: &Problem, drawn: &SearchSample, opts: &FitOptions) -> FitOutcome {
    let sample = drawn.problem(problem);
    let mut out = fit_points(&sample, opts);
    let (lo, hi) = problem.bounds();
    let r = minimise(problem, &out.q, &lo, &hi, opts.lm);
    out.q = r.q;
    out.params = to_natural(out.kind, &r.q[..out.kind.param_count()]);
    out.cost = r.cost;
    out.evals += r.evals;
    out.search.sample = Some(sample.len());
    // The subsample must stand for the data where the search ended: its cost there within
    // SAMPLE_COST_REL of its share of every point's (a few draws in the wrong places misled
    // the search, and the polish cannot leave the basin it was handed), or both within the
    // subsample's rounding floor (noise-free data: both are rounding noise). A NaN difference
    // stands for nothing either.
    let (estimate, share) = (sample.cost(&r.q), drawn.scale * r.cost);
    let gap = (estimate - share).abs();
    let stands = gap <= SAMPLE_COST_REL * share || gap <= cost_floor(&sample);
    if problem.stopped() {
        out.search.not_converged = Some("the fit was stopped before its search ended".to_owned());
    } else if out.search.not_converged.is_none() && !stands {
        out.search.not_converged = Some(format!(
            "the search's subsample does not stand for the data at the optimum (its cost \
             {estimate:e} against the {share:e} it stands for): the search may have missed the \
             optimum"
        ));
    } else if out.search.not_converged.is_none() && !r.converged() {
        out.search.not_converged = Some(format!("the polish on every point {}", r.stop.why()));
    }
    out.converged = out.search.not_converged.is_none();
    out
}

/// A subsample of a problem's points for the global search ([`search_sample`]): the points,
/// ascending, and the factor on each one's squared residual.
#[derive(Clone, Debug, PartialEq)]
pub struct SearchSample {
    /// Indices of the points, ascending.
    pub indices: Vec<usize>,
    /// Factor on each point's squared residual: the share of the whole data's cost it
    /// stands for, all 1 when every point weighs alike ([`Problem::importance`]).
    pub factors: Vec<f64>,
    /// The subsample's cost estimates this times the whole data's (under the linear loss, or
    /// with every factor 1): `m / sum u`.
    pub scale: f64,
}

impl SearchSample {
    /// The problem on the subsample, each point weighted by its factor.
    pub fn problem(&self, problem: &Problem) -> Problem {
        problem.subset_scaled(&self.indices, &self.factors)
    }
}

/// `m` of `problem`'s points for the global search, drawn so that the subsample's cost
/// stands for the whole data's at every parameter set (a stratified, probability-
/// proportional-to-size sample): each point weighs [`Problem::importance`] `u_i`; a point
/// weighing at least `1/m` of the rest is taken for certain (heavy weights, small sigmas, an
/// absolute residual's peak); the others, sorted by reading (ties by index), fall into strata
/// of equal total weight, and one point is drawn from each with chance proportional to its
/// weight by a fixed generator (the same subsample for every seed). Each point's squared
/// residual is weighted by the weight it stands for over its own, times `m / sum u` (so all 1
/// when every point weighs alike: strata of equal count, the peak's and the darkest always
/// drawn from). All points, factors 1, when there are at most `m`.
pub fn search_sample(problem: &Problem, m: usize) -> SearchSample {
    let n = problem.len();
    if n <= m || m == 0 {
        return SearchSample {
            indices: (0..n).collect(),
            factors: vec![1.0; n],
            scale: 1.0,
        };
    }
    let mut u: Vec<f64> = (0..n).map(|i| problem.importance(i)).collect();
    // A reading of 0 under absolute residuals weighs 0 by this measure (its residual is the
    // model's whole value): it is drawn like the lightest other point, not never (and the
    // others are not drawn as if alike because of it).
    let lightest = u
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold(f64::INFINITY, f64::min);
    for v in &mut u {
        if !(v.is_finite() && *v > 0.0) {
            *v = if lightest.is_finite() { lightest } else { 1.0 };
        }
    }
    let mut total: f64 = u.iter().sum();
    let alike = u.iter().all(|&v| v == u[0]);
    if alike || !total.is_finite() {
        // Every point alike (or weights beyond what f64 sums, drawn as if alike, which the
        // test at the optimum then judges): strata of equal count, each point for itself.
        u = vec![1.0; n];
        total = n as f64;
    }
    let scale = m as f64 / total;
    let mut picked: Vec<(usize, f64)> = Vec::with_capacity(m);
    // The certain: heaviest first, while one weighs at least the rest's share of a draw.
    let mut by_weight: Vec<usize> = (0..n).collect();
    by_weight.sort_unstable_by(|&a, &b| u[b].total_cmp(&u[a]).then(a.cmp(&b)));
    let (mut rest, mut draws) = (total, m);
    let mut certain = vec![false; n];
    for &i in &by_weight {
        if draws == 0 || u[i] * (draws as f64) < rest {
            break;
        }
        certain[i] = true;
        picked.push((i, scale));
        rest -= u[i];
        draws -= 1;
    }
    // The rest, by reading, systematically: the draws at `(k + r) step` along the running
    // sum of weights, one per stratum (no point weighs a whole step, so none twice).
    let mut order: Vec<usize> = (0..n).filter(|&i| !certain[i]).collect();
    order.sort_unstable_by(|&a, &b| problem.target(a).total_cmp(&problem.target(b)).then(a.cmp(&b)));
    if draws > 0 && !order.is_empty() {
        let rest: f64 = order.iter().map(|&i| u[i]).sum();
        let step = rest / draws as f64;
        let mut rng = Pcg64Mcg::seed_from_u64(0x5EA5_C4ED_5A3B_1E00);
        let mut next = unit(&mut rng) * step;
        let (mut run, mut k) = (0.0, 0);
        for &i in &order {
            run += u[i];
            if k < draws && run > next {
                // Exactly 1 for points alike (`m/n * n/m` rounds otherwise).
                let factor = if alike { 1.0 } else { scale * step / u[i] };
                picked.push((i, factor));
                k += 1;
                next = (k as f64 + unit(&mut rng)) * step;
            }
        }
    }
    picked.sort_unstable_by_key(|p| p.0);
    SearchSample {
        indices: picked.iter().map(|p| p.0).collect(),
        factors: picked.iter().map(|p| p.1).collect(),
        scale,
    }
}

/// The fit of the module docs on every point of `problem`.
fn fit_points(problem: &Problem, opts: &FitOptions) -> FitOutcome {
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
    out
}

/// One unit of the global search: an annealing chain (its index seeds it) polished, or a
/// basin-hopping move from `start` polished.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Unit {
    Chain { index: usize, probe: bool },
    Hop { start: [f64; MAX_PARAMS] },
}

/// Where the global search stands: everything the next unit and the stopping rules depend on.
#[derive(Clone)]
struct SearchState {
    found: Vec<LmResult>,
    /// Grid polishes at the front of `found` (never counted as independent arrivals).
    grid_n: usize,
    chain_costs: Vec<f64>,
    evals: usize,
    chains: usize,
    probes: usize,
    hops: usize,
    quiet_hops: usize,
    hopping: bool,
    hop_rng: Pcg64Mcg,
}

impl SearchState {
    fn best(&self) -> LmResult {
        *self
            .found
            .iter()
            .min_by(|a, b| a.cost.total_cmp(&b.cost))
            .expect("at least one search")
    }

    fn agreeing(&self, kind: ModelKind, floor: f64) -> usize {
        let best = self.best();
        self.found[self.grid_n..]
            .iter()
            .filter(|f| same_optimum(kind, f, &best, floor))
            .count()
    }
}

/// The global search's rules, separate from the work they order, so that the next unit can be
/// run before the current one ends (see [`search`]).
struct Rules<'a> {
    problem: &'a Problem,
    opts: &'a FitOptions,
    probes_apply: bool,
    need: usize,
    max_chains: usize,
    max_hops: usize,
    /// The problem's [`cost_floor`].
    floor: f64,
}

impl Rules<'_> {
    /// Part (1) of the module's rule: enough searches reached the best cost, or it lies at or
    /// below the cost's rounding floor (where nothing can improve on it).
    fn agreed(&self, s: &SearchState) -> bool {
        s.best().cost <= self.floor || s.agreeing(self.problem.kind(), self.floor) >= self.need
    }

    fn probes_done(&self, best: &LmResult, probes: usize) -> bool {
        !self.probes_apply || !lobe_off(self.problem.kind(), &best.q) || probes >= self.opts.lobe_probes
    }

    /// The next unit and the hop generator after it, or `None` when the search is over.
    fn next(&self, s: &SearchState) -> Option<(Unit, Pcg64Mcg)> {
        let kind = self.problem.kind();
        if !s.hopping {
            if s.chains >= self.max_chains {
                return None;
            }
            // A lobe-on probe when the best so far has its lobe off and probes remain.
            let probe = self.probes_apply
                && !s.found.is_empty()
                && lobe_off(kind, &s.best().q)
                && s.probes < self.opts.lobe_probes;
            Some((
                Unit::Chain {
                    index: s.chains,
                    probe,
                },
                s.hop_rng.clone(),
            ))
        } else {
            if s.hops >= self.max_hops || s.quiet_hops >= self.opts.hops {
                return None;
            }
            let mut rng = s.hop_rng.clone();
            let start = hop_start(self.problem, &s.best().q, &mut rng);
            Some((Unit::Hop { start }, rng))
        }
    }

    /// Runs `unit`: the polished point and the passes over the data it took.
    fn run(&self, unit: Unit) -> (LmResult, usize) {
        let (lo, hi) = self.problem.bounds();
        match unit {
            Unit::Chain { index, probe } => {
                let seed = self
                    .opts
                    .seed
                    .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                    .wrapping_add(index as u64);
                let mut rng = Pcg64Mcg::seed_from_u64(seed);
                let schedule = AnnealOptions {
                    lobe_on: probe,
                    ..self.opts.anneal
                };
                let a = anneal(self.problem, &mut rng, schedule);
                let r = minimise(self.problem, &a.q, &lo, &hi, self.opts.lm);
                (r, a.evals + r.evals)
            }
            Unit::Hop { start } => {
                let r = minimise(self.problem, &start, &lo, &hi, self.opts.lm);
                (r, r.evals + 1)
            }
        }
    }

    /// `s` after `unit` gave `r` (`None`: as if it found nothing, for planning ahead).
    fn apply(&self, s: &mut SearchState, unit: Unit, rng: Pcg64Mcg, r: Option<(LmResult, usize)>) {
        match unit {
            Unit::Chain { probe, .. } => {
                if let Some((r, evals)) = r {
                    s.evals += evals;
                    s.chain_costs.push(r.cost);
                    s.found.push(r);
                }
                s.chains += 1;
                s.probes += usize::from(probe);
                // (Planning ahead of the first chain with no grid: nothing found yet.)
                s.hopping = s.chains >= self.opts.min_chains
                    && !s.found.is_empty()
                    && self.agreed(s)
                    && self.probes_done(&s.best(), s.probes);
            }
            Unit::Hop { .. } => {
                // Basin hopping: must fail `hops` times in a row; an arrival at the best
                // cost counts towards the agreement.
                s.hop_rng = rng;
                s.hops += 1;
                let Some((r, evals)) = r else {
                    s.quiet_hops += 1;
                    return;
                };
                let before = s.best();
                s.evals += evals;
                let improved = below(r.cost, before.cost, self.floor);
                s.found.push(r);
                s.quiet_hops = if improved { 0 } else { s.quiet_hops + 1 };
                if improved && !self.probes_done(&s.best(), s.probes) {
                    // The new best has its lobe off: probe for lobe-on optima first.
                    s.hopping = false;
                }
            }
        }
    }
}

/// The global search on one (possibly reweighted) problem.
///
/// The rules order the work one unit at a time. On more than one thread the unit after the
/// current one (as it would be if the current one found nothing) runs beside it, and its
/// result is used only when the rules, given the current unit's real result, ask for exactly
/// that unit; so the outcome is the same bits whatever the thread count.
fn search(problem: &Problem, opts: &FitOptions) -> FitOutcome {
    let kind = problem.kind();
    let max_chains = opts.chains.max(1);
    let rules = Rules {
        problem,
        opts,
        probes_apply: matches!(kind, ModelKind::Six | ModelKind::SixCos2) && opts.lobe_probes > 0,
        need: opts.agree.max(1),
        max_chains,
        // Hops are cheaper than chains (no annealing); as many as the chain limit.
        max_hops: max_chains.max(opts.hops),
        floor: cost_floor(problem),
    };
    let (lo, hi) = problem.bounds();
    // The seed-independent part: polish the best nodes of the fixed grid (in parallel, kept
    // in grid order).
    let grid: Vec<LmResult> = grid_starts(problem, opts.grid_starts)
        .par_iter()
        .map(|start| minimise(problem, start, &lo, &hi, opts.lm))
        .collect();
    let mut s = SearchState {
        evals: grid.iter().map(|r| r.evals + 1).sum(),
        grid_n: grid.len(),
        found: grid,
        chain_costs: Vec::with_capacity(opts.chains),
        chains: 0,
        probes: 0,
        hops: 0,
        quiet_hops: 0,
        hopping: false,
        hop_rng: Pcg64Mcg::seed_from_u64(opts.seed ^ 0xB0B5_1ED5_5EED_0001),
    };
    let ahead = rayon::current_num_threads() > 1;
    let mut pending: Option<(Unit, (LmResult, usize))> = None;
    while !problem.stopped() {
        let Some((unit, rng)) = rules.next(&s) else {
            break;
        };
        let result = match pending.take() {
            Some((u, r)) if u == unit => r,
            _ => {
                let after = ahead
                    .then(|| {
                        let mut t = s.clone();
                        rules.apply(&mut t, unit, rng.clone(), None);
                        rules.next(&t)
                    })
                    .flatten();
                match after {
                    Some((next, _)) => {
                        let (r, r_next) = rayon::join(|| rules.run(unit), || rules.run(next));
                        pending = Some((next, r_next));
                        r
                    }
                    None => rules.run(unit),
                }
            }
        };
        rules.apply(&mut s, unit, rng, Some(result));
    }
    let best = s.best();
    let agree_n = s.agreeing(kind, rules.floor);
    let need = rules.need;
    let not_converged = if problem.stopped() {
        Some("the fit was stopped before its search ended".to_owned())
    } else if !rules.agreed(&s) {
        // Say where the best came from when no chain or hop reached it, and where they went.
        let searches = &s.found[s.grid_n..];
        let from_grid = if s.found[..s.grid_n]
            .iter()
            .any(|g| same_optimum(kind, g, &best, rules.floor))
        {
            " (found by a grid start's polish)"
        } else {
            ""
        };
        let theirs = match searches.iter().min_by(|a, b| a.cost.total_cmp(&b.cost)) {
            Some(own) if agree_n == 0 => {
                let with = searches
                    .iter()
                    .filter(|f| same_optimum(kind, f, own, rules.floor))
                    .count();
                format!("; their own best, {:e}, was reached by {with}", own.cost)
            }
            _ => String::new(),
        };
        Some(format!(
            "the best cost {:e}{from_grid} was reached by {agree_n} of {} chains and hops ({need} needed){theirs}: the search could still improve",
            best.cost,
            searches.len()
        ))
    } else if !rules.probes_done(&best, s.probes) {
        Some("the lobe is off and the lobe-on probes were not run (chain limit)".to_owned())
    } else if s.quiet_hops < opts.hops {
        Some(format!(
            "basin hopping still improved the best point ({} of {} moves since without improvement)",
            s.quiet_hops, opts.hops
        ))
    } else if !best.converged() {
        Some(format!("the local polish {}", best.stop.why()))
    } else {
        None
    };
    FitOutcome {
        kind,
        q: best.q,
        params: to_natural(kind, &best.q[..kind.param_count()]),
        cost: best.cost,
        chain_costs: s.chain_costs,
        evals: s.evals,
        converged: not_converged.is_none(),
        search: SearchSummary {
            chains: s.chains,
            lobe_probes: s.probes,
            hops: s.hops,
            agreeing: agree_n,
            at_cost_floor: best.cost <= rules.floor,
            not_converged,
            sample: None,
            on_search_box: Vec::new(),
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
