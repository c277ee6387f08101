//! Simulated annealing over the nonlinear parameters, with the linear ones (`kb`, `kd`, or
//! `rho0`) solved exactly at every step (variable projection). This is the paper's global
//! method, made scale-free: the energy is `ln(cost)`, so one temperature schedule serves
//! every dataset and residual form.
//!
//! Each proposal moves one coordinate (Corana et al. 1987), cycling through them. For the
//! lobe models the per-point factors of the bases are cached, so a move of `kr` costs a
//! division per point, of `|b|` or `c` one `exp`, of `a` two — instead of three `exp` and a
//! division for a full evaluation.

use brdf_core::{ModelKind, MAX_PARAMS};
use rand_core::RngCore;

use crate::kernel::{assemble, factors};
use crate::problem::{nonlinear_indices, Problem, ProjectionSums};

/// Schedule of one annealing chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnnealOptions {
    /// Cost evaluations per chain, including the screening points.
    pub evals: usize,
    /// Random points screened for the chain's starting point.
    pub screen: usize,
    /// Initial temperature, in units of `ln(cost)`.
    pub t_start: f64,
    /// Final temperature.
    pub t_end: f64,
    /// Initial proposal standard deviation, as a fraction of each parameter's range.
    pub step_start: f64,
    /// Final proposal standard deviation.
    pub step_end: f64,
    /// Explore only points where the projection keeps the specular lobe on (`kb > 0`): a
    /// probe for a lobe-on optimum when the best fit has the lobe off (six-parameter models;
    /// ignored for the others).
    pub lobe_on: bool,
}

impl Default for AnnealOptions {
    fn default() -> Self {
        AnnealOptions {
            evals: 300,
            screen: 20,
            t_start: 1.0,
            t_end: 1e-3,
            step_start: 0.3,
            step_end: 0.003,
            lobe_on: false,
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

/// Projected cost as a function of the nonlinear parameters (internal units).
trait Landscape {
    /// Evaluates a whole new point and makes it current.
    fn reset(&mut self, nl: &[f64; 4]) -> ([f64; 2], f64);
    /// Evaluates the current point with coordinate `j` set to `value`, without committing.
    fn propose(&mut self, nl: &[f64; 4], j: usize, value: f64) -> ([f64; 2], f64);
    /// Makes the last proposal current.
    fn commit(&mut self);
}

/// Generic landscape: every evaluation is a full projection.
struct Full<'a>(&'a Problem);

impl Landscape for Full<'_> {
    fn reset(&mut self, nl: &[f64; 4]) -> ([f64; 2], f64) {
        let d = crate::kernel::nonlinear_count(self.0.kind());
        self.0.project(&nl[..d])
    }
    fn propose(&mut self, nl: &[f64; 4], j: usize, value: f64) -> ([f64; 2], f64) {
        let mut x = *nl;
        x[j] = value;
        self.reset(&x)
    }
    fn commit(&mut self) {}
}

/// Cached landscape of the lobe models (six, six-cos2, five): per point the facet term,
/// `x^a`, the lobe and the second basis; a move recomputes only what its coordinate touches.
struct Lobe<'a> {
    problem: &'a Problem,
    kind: ModelKind,
    weight: Vec<f64>,
    scale: Vec<f64>,
    facet: Vec<f64>,
    power: Vec<f64>,
    lobe: Vec<f64>,
    second: Vec<f64>,
    new_a: Vec<f64>,
    new_b: Vec<f64>,
    pending: Option<usize>,
}

impl<'a> Lobe<'a> {
    fn new(problem: &'a Problem) -> Self {
        let kind = problem.kind();
        let n = problem.len();
        let pts = problem.points();
        Lobe {
            problem,
            kind,
            weight: pts.iter().map(|p| factors::weight(kind, p)).collect(),
            scale: (0..n).map(|i| problem.projection_scale(i)).collect(),
            facet: vec![0.0; n],
            power: vec![0.0; n],
            lobe: vec![0.0; n],
            second: pts.iter().map(|p| factors::second(kind, 0.0, p)).collect(),
            new_a: vec![0.0; n],
            new_b: vec![0.0; n],
            pending: None,
        }
    }

    fn sums(&self, facet: &[f64], lobe: &[f64], second: &[f64]) -> ([f64; 2], f64) {
        let mut s = ProjectionSums::default();
        for i in 0..self.scale.len() {
            let b0 = self.weight[i] * facet[i] * lobe[i];
            s.add(self.scale[i], [b0, second[i]], self.problem.target(i));
        }
        s.solve(2)
    }
}

impl Landscape for Lobe<'_> {
    fn reset(&mut self, nl: &[f64; 4]) -> ([f64; 2], f64) {
        let k = (2.0 * nl[0]).exp();
        for (i, p) in self.problem.points().iter().enumerate() {
            self.facet[i] = factors::facet(self.kind, k, p);
            self.power[i] = factors::power(nl[2], p);
            self.lobe[i] = (-nl[1] * self.power[i]).exp();
            if self.kind != ModelKind::Five {
                self.second[i] = factors::second(self.kind, nl[3], p);
            }
        }
        self.pending = None;
        self.sums(&self.facet, &self.lobe, &self.second)
    }

    fn propose(&mut self, nl: &[f64; 4], j: usize, value: f64) -> ([f64; 2], f64) {
        let pts = self.problem.points();
        self.pending = Some(j);
        match j {
            0 => {
                let k = (2.0 * value).exp();
                for (i, p) in pts.iter().enumerate() {
                    self.new_a[i] = factors::facet(self.kind, k, p);
                }
                self.sums(&self.new_a, &self.lobe, &self.second)
            }
            1 => {
                for i in 0..pts.len() {
                    self.new_a[i] = (-value * self.power[i]).exp();
                }
                self.sums(&self.facet, &self.new_a, &self.second)
            }
            2 => {
                for (i, p) in pts.iter().enumerate() {
                    self.new_b[i] = factors::power(value, p);
                    self.new_a[i] = (-nl[1] * self.new_b[i]).exp();
                }
                self.sums(&self.facet, &self.new_a, &self.second)
            }
            _ => {
                for (i, p) in pts.iter().enumerate() {
                    self.new_a[i] = factors::second(self.kind, value, p);
                }
                self.sums(&self.facet, &self.lobe, &self.new_a)
            }
        }
    }

    fn commit(&mut self) {
        match self.pending.take() {
            Some(0) => std::mem::swap(&mut self.facet, &mut self.new_a),
            Some(1) => std::mem::swap(&mut self.lobe, &mut self.new_a),
            Some(2) => {
                std::mem::swap(&mut self.lobe, &mut self.new_a);
                std::mem::swap(&mut self.power, &mut self.new_b);
            }
            Some(_) => std::mem::swap(&mut self.second, &mut self.new_a),
            None => {}
        }
    }
}

/// Runs one annealing chain on `problem` with the generator it is handed.
pub fn anneal<R: RngCore>(problem: &Problem, rng: &mut R, opts: AnnealOptions) -> AnnealResult {
    match problem.kind() {
        ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five => {
            run(problem, &mut Lobe::new(problem), rng, opts)
        }
        ModelKind::Minnaert | ModelKind::Ggx | ModelKind::Lambert => {
            run(problem, &mut Full(problem), rng, opts)
        }
    }
}

fn run<R: RngCore, L: Landscape>(
    problem: &Problem,
    land: &mut L,
    rng: &mut R,
    opts: AnnealOptions,
) -> AnnealResult {
    let kind = problem.kind();
    let idx = nonlinear_indices(kind);
    let (lo, hi) = problem.bounds();
    let d = idx.len();
    let to_nl = |u: &[f64; 4]| -> [f64; 4] {
        let mut nl = [0.0; 4];
        for (k, &j) in idx.iter().enumerate() {
            nl[k] = lo[j] + (hi[j] - lo[j]) * u[k];
        }
        nl
    };
    // A lobe-on probe treats every point where the projection switches the lobe off as
    // infinitely costly.
    let lobe_on = opts.lobe_on && matches!(kind, ModelKind::Six | ModelKind::SixCos2);
    let admissible = |lin: &[f64; 2], cost: f64| {
        if lobe_on && lin[0] <= 0.0 {
            f64::INFINITY
        } else {
            cost
        }
    };
    let energy = |cost: f64| (cost + 1e-300).ln();
    // Start from the best of a few random points (a probe screens up to ten times as many
    // until one keeps the lobe on).
    let screen = opts.screen.clamp(1, opts.evals.max(1));
    let mut start: Option<([f64; 4], [f64; 2], f64)> = None;
    let mut screened = 0;
    while screened < screen
        || (lobe_on && screened < 10 * screen && start.as_ref().is_none_or(|s| s.2.is_infinite()))
    {
        screened += 1;
        let mut u = [0.0; 4];
        for v in u.iter_mut().take(d) {
            *v = unit(rng);
        }
        let (lin, cost) = land.reset(&to_nl(&u));
        let cost = admissible(&lin, cost);
        if start.as_ref().is_none_or(|s| cost < s.2) {
            start = Some((u, lin, cost));
        }
    }
    let screen = screened;
    let (mut u, lin, mut cost) = start.expect("screen >= 1");
    let mut best = (u, lin, cost);
    let mut evals = screen;
    if d > 0 {
        land.reset(&to_nl(&u));
        evals += 1;
        let steps = opts.evals.saturating_sub(evals);
        for k in 0..steps {
            if k % crate::problem::Stop::EVERY == 0 && problem.stopped() {
                break;
            }
            let frac = k as f64 / steps.max(1) as f64;
            let t = opts.t_start * (opts.t_end / opts.t_start).powf(frac);
            let sigma = opts.step_start * (opts.step_end / opts.step_start).powf(frac);
            let j = k % d;
            // Reflect into [0, 1].
            let mut x = (u[j] + sigma * normal(rng)).rem_euclid(2.0);
            if x > 1.0 {
                x = 2.0 - x;
            }
            let nl = to_nl(&u);
            let value = lo[idx[j]] + (hi[idx[j]] - lo[idx[j]]) * x;
            let (lin2, cost2) = land.propose(&nl, j, value);
            let cost2 = admissible(&lin2, cost2);
            evals += 1;
            let de = energy(cost2) - energy(cost);
            if de <= 0.0 || unit(rng) < (-de / t).exp() {
                land.commit();
                u[j] = x;
                cost = cost2;
                if cost < best.2 {
                    best = (u, lin2, cost);
                }
            }
        }
    }
    let nl = to_nl(&best.0);
    let mut q = assemble(kind, &nl[..d], best.1);
    for j in 0..problem.dim() {
        q[j] = q[j].clamp(lo[j], hi[j]);
    }
    AnnealResult {
        q,
        cost: best.2,
        evals,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{synth, Residual};
    use brdf_core::tolerance::F64_REFORMULATION_REL;

    #[test]
    fn cached_moves_equal_full_projection() {
        for kind in [ModelKind::Six, ModelKind::SixCos2, ModelKind::Five] {
            let p: Vec<f64> = match kind {
                ModelKind::Five => vec![0.2545, 1.8, -27.5721, 0.6705, 0.3676],
                _ => brdf_core::TABLE1[0].1.to_vec(),
            };
            let d = synth::in_plane(kind, &p, &[0.0, 30.0], 5.0, 0.01, 3).unwrap();
            let pr = Problem::from_dataset(kind, Residual::Relative, &d);
            let mut cached = Lobe::new(&pr);
            let mut full = Full(&pr);
            let mut nl = [1.0, 20.0, 0.7, 1.1];
            let (a, b) = (cached.reset(&nl), full.reset(&nl));
            assert!(
                (a.1 - b.1).abs() <= F64_REFORMULATION_REL * b.1,
                "{kind:?}: {a:?} vs {b:?}"
            );
            for (j, v) in [(0, 2.0), (1, 35.0), (2, 0.5), (3, 0.9)] {
                if j >= crate::kernel::nonlinear_count(kind) {
                    continue;
                }
                let a = cached.propose(&nl, j, v);
                cached.commit();
                nl[j] = v;
                let b = full.reset(&nl);
                assert!(
                    (a.1 - b.1).abs() <= F64_REFORMULATION_REL * b.1,
                    "{kind:?} coordinate {j}: {a:?} vs {b:?}"
                );
            }
        }
    }
}
