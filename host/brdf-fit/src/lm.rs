//! Levenberg–Marquardt with box constraints (projected steps, active set), on the normal
//! equations of at most six parameters: no allocation per iteration.
//!
//! Damping follows Nielsen (1999): `lambda *= max(1/3, 1 - (2 rho - 1)^3)` on success,
//! `lambda *= nu, nu *= 2` on failure, scaled by `diag(J^T J)` (Marquardt). A parameter at a
//! bound whose gradient points outward is held there.

use brdf_core::MAX_PARAMS;

use crate::problem::Problem;

/// Outcome of one local minimisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmResult {
    /// Internal parameters at the minimum.
    pub q: [f64; MAX_PARAMS],
    /// `0.5 * sum r^2` there.
    pub cost: f64,
    /// Iterations taken.
    pub iterations: usize,
    /// Cost evaluations (each a pass over the data).
    pub evals: usize,
    /// Why it stopped.
    pub stop: LmStop,
}

impl LmResult {
    /// Stopped on a convergence test ([`LmStop::Converged`]).
    pub fn converged(&self) -> bool {
        self.stop == LmStop::Converged
    }
}

/// Why a local minimisation stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LmStop {
    /// A convergence test held: a step too small to matter, or an accepted step that lowered
    /// the cost by less than [`LmOptions::cost_tolerance`].
    Converged,
    /// [`LmOptions::max_iterations`] reached while steps were still being taken or tried.
    IterationLimit,
    /// No step was accepted while the damping rose past [`MAX_DAMPING`]: no downhill step
    /// could be found at any damping (the normal equations not solvable, or every trial's cost
    /// not below the current one, or not finite). Not a passed convergence test.
    Stalled,
    /// The problem's [`crate::Stop`] was requested.
    Stopped,
    /// The cost at the start is not finite: no step can be judged from there.
    NotFinite,
}

impl LmStop {
    /// What the polish did, for a fit's "not converged" reason (`"the local polish {why}"`).
    pub fn why(self) -> &'static str {
        match self {
            LmStop::Converged => "converged",
            LmStop::IterationLimit => "stopped at its iteration limit",
            LmStop::Stalled => {
                "stalled: no step lowered the cost at any damping (the damping reached its limit)"
            }
            LmStop::Stopped => "was stopped",
            LmStop::NotFinite => "started where the cost is not finite",
        }
    }
}

/// The damping `lambda` above which a polish that has accepted no step since is called
/// stalled ([`LmStop::Stalled`]): the step is then `1e-30` of the undamped gradient step in
/// each scaled coordinate, far below any step the step tolerance would still take, so no
/// damping left would find one.
pub const MAX_DAMPING: f64 = 1e30;

/// Stopping rules.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmOptions {
    /// Iteration limit.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub cost_tolerance: f64,
    /// Stop when no parameter's step changes the residual vector by more than this fraction
    /// of its norm (`|step_j| sqrt((J^T J)_jj) <= tol * |r|`): free of the data's units, the
    /// weights' scale and each parameter's own units.
    pub step_tolerance: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            max_iterations: 300,
            cost_tolerance: 1e-12,
            step_tolerance: 1e-10,
        }
    }
}

/// Solves `a x = b` for a symmetric positive definite `a` of size `n` (Cholesky).
/// Returns `None` if `a` is not positive definite.
pub fn cholesky_solve(
    a: &[[f64; MAX_PARAMS]; MAX_PARAMS],
    b: &[f64; MAX_PARAMS],
    n: usize,
) -> Option<[f64; MAX_PARAMS]> {
    let mut l = [[0.0; MAX_PARAMS]; MAX_PARAMS];
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if s <= 0.0 || !s.is_finite() {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut y = [0.0; MAX_PARAMS];
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s / l[i][i];
    }
    let mut x = [0.0; MAX_PARAMS];
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    Some(x)
}

/// Minimises `problem`'s cost from `start` within `[lo, hi]`.
pub fn minimise(
    problem: &Problem,
    start: &[f64; MAX_PARAMS],
    lo: &[f64; MAX_PARAMS],
    hi: &[f64; MAX_PARAMS],
    opts: LmOptions,
) -> LmResult {
    let n = problem.dim();
    let mut q = *start;
    for j in 0..n {
        q[j] = q[j].clamp(lo[j], hi[j]);
    }
    let mut jtj = [[0.0; MAX_PARAMS]; MAX_PARAMS];
    let mut jtr = [0.0; MAX_PARAMS];
    let mut cost = problem.normal_equations(&q, &mut jtj, &mut jtr);
    let mut evals = 1;
    if !cost.is_finite() {
        return LmResult {
            q,
            cost,
            iterations: 0,
            evals,
            stop: LmStop::NotFinite,
        };
    }
    // Marquardt damping `J^T J + lambda diag(J^T J)`: lambda is dimensionless, so neither the
    // data's units nor the weights' size nor a parameter's own units change the path.
    let mut lambda = 1e-3;
    let mut nu = 2.0;
    let mut stop = LmStop::IterationLimit;
    let mut iterations = 0;
    while iterations < opts.max_iterations {
        if problem.stopped() {
            stop = LmStop::Stopped;
            break;
        }
        iterations += 1;
        // Active set: at a bound with the descent direction pointing outside. A parameter
        // with no effect on the residuals (a zero column: the lobe's shape when kb = 0) is
        // held too: no step can be computed for it.
        let mut free = [false; MAX_PARAMS];
        for j in 0..n {
            let at_lo = q[j] <= lo[j] && jtr[j] > 0.0;
            let at_hi = q[j] >= hi[j] && jtr[j] < 0.0;
            free[j] = !(at_lo || at_hi) && jtj[j][j] > 0.0;
        }
        let mut a = [[0.0; MAX_PARAMS]; MAX_PARAMS];
        let mut b = [0.0; MAX_PARAMS];
        for i in 0..n {
            for j in 0..n {
                a[i][j] = if free[i] && free[j] { jtj[i][j] } else { 0.0 };
            }
            a[i][i] = if free[i] { jtj[i][i] * (1.0 + lambda) } else { 1.0 };
            b[i] = if free[i] { -jtr[i] } else { 0.0 };
        }
        let Some(step) = cholesky_solve(&a, &b, n) else {
            lambda *= nu;
            nu *= 2.0;
            if lambda > MAX_DAMPING {
                // Not solvable at any damping (a Jacobian too large or not finite): before,
                // this ran on to the iteration limit and said so.
                stop = LmStop::Stalled;
                break;
            }
            continue;
        };
        let mut trial = q;
        let mut step_effect = 0.0_f64;
        for j in 0..n {
            trial[j] = (q[j] + step[j]).clamp(lo[j], hi[j]);
            step_effect = step_effect.max((trial[j] - q[j]).abs() * jtj[j][j].sqrt());
        }
        if step_effect <= opts.step_tolerance * (2.0 * cost).sqrt() {
            stop = LmStop::Converged;
            break;
        }
        // The trial's normal equations come with its cost: an accepted step (the common
        // case) then needs no second pass over the data.
        let mut trial_jtj = [[0.0; MAX_PARAMS]; MAX_PARAMS];
        let mut trial_jtr = [0.0; MAX_PARAMS];
        let trial_cost = problem.normal_equations(&trial, &mut trial_jtj, &mut trial_jtr);
        evals += 1;
        // Predicted reduction of the quadratic model for the projected step.
        let mut predicted = 0.0;
        for i in 0..n {
            let d = trial[i] - q[i];
            let mut hd = 0.0;
            for j in 0..n {
                hd += jtj[i][j] * (trial[j] - q[j]);
            }
            predicted -= d * jtr[i] + 0.5 * d * hd;
        }
        if trial_cost.is_finite() && trial_cost < cost {
            let rho = if predicted > 0.0 {
                (cost - trial_cost) / predicted
            } else {
                1.0
            };
            let small = cost - trial_cost <= opts.cost_tolerance * cost;
            q = trial;
            cost = trial_cost;
            jtj = trial_jtj;
            jtr = trial_jtr;
            lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            nu = 2.0;
            if small {
                stop = LmStop::Converged;
                break;
            }
        } else {
            lambda *= nu;
            nu *= 2.0;
            if lambda > MAX_DAMPING {
                // No downhill step at any damping: stalled, not a passed convergence test.
                stop = LmStop::Stalled;
                break;
            }
        }
    }
    LmResult {
        q,
        cost,
        iterations,
        evals,
        stop,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::tolerance::F64_REFORMULATION_REL;

    #[test]
    fn cholesky_solves_and_refuses_indefinite() {
        let mut a = [[0.0; MAX_PARAMS]; MAX_PARAMS];
        a[0][0] = 4.0;
        a[0][1] = 2.0;
        a[1][0] = 2.0;
        a[1][1] = 3.0;
        let mut b = [0.0; MAX_PARAMS];
        b[0] = 2.0;
        b[1] = 1.0;
        let x = cholesky_solve(&a, &b, 2).unwrap();
        assert!((4.0 * x[0] + 2.0 * x[1] - 2.0).abs() < F64_REFORMULATION_REL);
        assert!((2.0 * x[0] + 3.0 * x[1] - 1.0).abs() < F64_REFORMULATION_REL);
        a[1][1] = 1.0;
        assert!(cholesky_solve(&a, &b, 2).is_none());
    }
}

/// A stalled polish says so. Log residuals of data at 0.3 from a Lambertian albedo of 1e-300:
/// `J^T J` (of `1/rho0` squared) overflows, no damping makes the normal equations solvable, no
/// step is taken, and the polish ran its 300 iterations and said "iteration limit". From 0 the
/// cost itself is not finite.
#[cfg(test)]
mod stall {
    use super::*;

    #[test]
    fn a_polish_that_takes_no_step_at_any_damping_stalls() {
        use brdf_core::ModelKind;
        let kind = ModelKind::Lambert;
        let d = crate::synth::in_plane(kind, &[0.3], &[0.0, 30.0, 60.0], 5.0, 0.0, 1).unwrap();
        let problem = Problem::new(kind, crate::Residual::Log, &d.points);
        let (lo, hi) = problem.bounds();
        let from = |rho: f64| {
            let q = crate::kernel::to_internal(kind, &[rho]);
            minimise(&problem, &q, &lo, &hi, LmOptions::default())
        };
        let r = from(1e-300);
        assert_eq!(r.stop, LmStop::Stalled, "{r:?}");
        assert!(r.iterations < LmOptions::default().max_iterations, "{r:?}");
        assert_eq!(r.q[0], 1e-300, "no step was taken");
        assert_eq!(from(0.0).stop, LmStop::NotFinite);
        // The same data from a start it can leave: converged, at the albedo.
        let r = from(0.1);
        assert!(r.converged() && (r.q[0] - 0.3).abs() < 1e-9, "{r:?}");
    }
}
