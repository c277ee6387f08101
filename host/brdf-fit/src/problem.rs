//! One least-squares problem: a dataset, a model, a residual form, and the parameter box.

use brdf_core::{ModelKind, MAX_PARAMS};
use serde::Serialize;

use crate::data::{Dataset, Point};
use crate::kernel::{bases, eval, nonlinear_count, Prepared};

/// Residual form. `f` is the model, `y` the measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Residual {
    /// `(f - y) / y`: every point counts by its relative error (default; BRDFs span decades).
    #[default]
    Relative,
    /// `f - y` in 1/sr: dominated by the peak.
    Absolute,
    /// `ln f - ln y`: like relative, symmetric in over- and under-estimation.
    Log,
}

impl Residual {
    /// Name used on the command line and in results.
    pub fn name(self) -> &'static str {
        match self {
            Residual::Relative => "relative",
            Residual::Absolute => "absolute",
            Residual::Log => "log",
        }
    }
}

/// Search box of the internal parameters (see [`crate::kernel`]): `kb` in [0, 1e4] (a metal's
/// mirror peak of ~2000 1/sr needs kb in the thousands), `ln kr`
/// in [ln 0.01, ln 1000], `beta = |b|` in [0, 200], `a` in [0.05, 4], `kd` in [0, 10],
/// `c` in [0, 5]; Minnaert `rho0` in [0, 100], `k` in [0.01, 1]; Lambert `rho0` in [0, 100].
pub fn bounds(kind: ModelKind) -> ([f64; MAX_PARAMS], [f64; MAX_PARAMS]) {
    let lkr = (0.01_f64.ln(), 1000.0_f64.ln());
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => (
            [0.0, lkr.0, 0.0, 0.05, 0.0, 0.0],
            [1.0e4, lkr.1, 200.0, 4.0, 10.0, 5.0],
        ),
        ModelKind::Five => (
            [0.0, lkr.0, 0.0, 0.05, 0.0, 0.0],
            [1.0e4, lkr.1, 200.0, 4.0, 10.0, 0.0],
        ),
        ModelKind::Minnaert => ([0.0, 0.01, 0.0, 0.0, 0.0, 0.0], [100.0, 1.0, 0.0, 0.0, 0.0, 0.0]),
        ModelKind::Lambert => ([0.0; MAX_PARAMS], [100.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
    }
}

/// Indices of the nonlinear parameters (see [`crate::kernel::bases`]) in the internal vector.
pub fn nonlinear_indices(kind: ModelKind) -> &'static [usize] {
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => &[1, 2, 3, 5],
        ModelKind::Five => &[1, 2, 3],
        ModelKind::Minnaert => &[1],
        ModelKind::Lambert => &[],
    }
}

/// A prepared least-squares problem: cost `0.5 * sum r_i^2`.
#[derive(Clone, Debug)]
pub struct Problem {
    kind: ModelKind,
    residual: Residual,
    pts: Vec<Prepared>,
    y: Vec<f64>,
    /// Per-point factor of the residual's weight (sqrt(weight) or from sigma).
    w: Vec<f64>,
}

impl Problem {
    /// Prepares `points` for fitting `kind` with `residual`.
    pub fn new(kind: ModelKind, residual: Residual, points: &[Point]) -> Self {
        let w = points
            .iter()
            .map(|p| match (p.sigma, p.weight) {
                (Some(s), _) => match residual {
                    Residual::Absolute => 1.0 / s,
                    Residual::Relative | Residual::Log => p.brdf / s,
                },
                (None, Some(w)) => w.sqrt(),
                (None, None) => 1.0,
            })
            .collect();
        Problem {
            kind,
            residual,
            pts: points.iter().map(Prepared::from_point).collect(),
            y: points.iter().map(|p| p.brdf).collect(),
            w,
        }
    }

    /// From a whole dataset.
    pub fn from_dataset(kind: ModelKind, residual: Residual, d: &Dataset) -> Self {
        Self::new(kind, residual, &d.points)
    }

    /// The model being fitted.
    pub fn kind(&self) -> ModelKind {
        self.kind
    }

    /// The residual form.
    pub fn residual(&self) -> Residual {
        self.residual
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    /// Number of parameters.
    pub fn dim(&self) -> usize {
        self.kind.param_count()
    }

    #[inline]
    fn residual_at(&self, i: usize, f: f64) -> f64 {
        let (y, w) = (self.y[i], self.w[i]);
        match self.residual {
            Residual::Relative => w * (f - y) / y,
            Residual::Absolute => w * (f - y),
            Residual::Log => {
                if f > 0.0 {
                    w * (f.ln() - y.ln())
                } else {
                    f64::INFINITY
                }
            }
        }
    }

    /// `0.5 * sum r_i^2` at internal parameters `q` (infinite where a log residual sees
    /// `f <= 0`).
    pub fn cost(&self, q: &[f64]) -> f64 {
        let q = &q[..self.dim()];
        let mut s = 0.0;
        for (i, pt) in self.pts.iter().enumerate() {
            let r = self.residual_at(i, eval(self.kind, q, pt, None));
            s += r * r;
        }
        0.5 * s
    }

    /// Cost, gradient `J^T r` and Gauss–Newton matrix `J^T J` at `q` in one pass.
    pub fn normal_equations(
        &self,
        q: &[f64],
        jtj: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
        jtr: &mut [f64; MAX_PARAMS],
    ) -> f64 {
        let n = self.dim();
        let q = &q[..n];
        *jtj = [[0.0; MAX_PARAMS]; MAX_PARAMS];
        *jtr = [0.0; MAX_PARAMS];
        let mut cost = 0.0;
        let mut g = [0.0; MAX_PARAMS];
        for (i, pt) in self.pts.iter().enumerate() {
            let f = eval(self.kind, q, pt, Some(&mut g[..n]));
            let r = self.residual_at(i, f);
            let (y, w) = (self.y[i], self.w[i]);
            let scale = match self.residual {
                Residual::Relative => w / y,
                Residual::Absolute => w,
                Residual::Log => w / f,
            };
            cost += r * r;
            for a in 0..n {
                let ja = scale * g[a];
                jtr[a] += ja * r;
                for b in 0..=a {
                    jtj[a][b] += ja * scale * g[b];
                }
            }
        }
        for a in 0..n {
            for b in 0..a {
                jtj[b][a] = jtj[a][b];
            }
        }
        0.5 * cost
    }

    /// `J^T J` of the residuals' Jacobian with respect to the internal parameters, summed
    /// row by row without holding the Jacobian (constant memory however many points).
    pub fn jacobian_gram(&self, q: &[f64]) -> [[f64; MAX_PARAMS]; MAX_PARAMS] {
        let n = self.dim();
        let mut jtj = [[0.0; MAX_PARAMS]; MAX_PARAMS];
        for (i, pt) in self.pts.iter().enumerate() {
            let mut g = [0.0; MAX_PARAMS];
            let f = eval(self.kind, &q[..n], pt, Some(&mut g[..n]));
            let scale = match self.residual {
                Residual::Relative => self.w[i] / self.y[i],
                Residual::Absolute => self.w[i],
                Residual::Log => self.w[i] / f,
            };
            for v in g.iter_mut() {
                *v *= scale;
            }
            for a in 0..n {
                for b in 0..n {
                    jtj[a][b] += g[a] * g[b];
                }
            }
        }
        jtj
    }

    /// Model values at `q`, one per point.
    pub fn values(&self, q: &[f64]) -> Vec<f64> {
        self.pts
            .iter()
            .map(|pt| eval(self.kind, &q[..self.dim()], pt, None))
            .collect()
    }

    /// Prepared points.
    pub fn points(&self) -> &[Prepared] {
        &self.pts
    }

    /// Scale `s_i` of point `i` in the projected (linear) least-squares problem
    /// `min || s (B lin - y) ||^2`: relative scaling also for log residuals.
    #[inline]
    pub fn projection_scale(&self, i: usize) -> f64 {
        match self.residual {
            Residual::Absolute => self.w[i],
            Residual::Relative | Residual::Log => self.w[i] / self.y[i],
        }
    }

    /// Measurement `y_i`.
    #[inline]
    pub fn target(&self, i: usize) -> f64 {
        self.y[i]
    }

    /// Variable projection: for nonlinear parameters `nl`, the non-negative linear
    /// coefficients minimising the (relative-scaled, for log residuals) cost, and that cost.
    pub fn project(&self, nl: &[f64]) -> ([f64; 2], f64) {
        debug_assert_eq!(nl.len(), nonlinear_count(self.kind));
        let mut sums = ProjectionSums::default();
        let mut basis = [0.0; 2];
        let mut nb = 1;
        for (i, pt) in self.pts.iter().enumerate() {
            nb = bases(self.kind, nl, pt, &mut basis);
            sums.add(self.projection_scale(i), basis, self.y[i]);
        }
        sums.solve(nb)
    }
}

/// Normal equations of the projected problem `min || s (B lin - y) ||^2` with at most two
/// basis columns.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectionSums {
    a00: f64,
    a01: f64,
    a11: f64,
    b0: f64,
    b1: f64,
    yy: f64,
}

impl ProjectionSums {
    /// Adds one point with scale `s`, basis values and target `y`.
    #[inline]
    pub fn add(&mut self, s: f64, basis: [f64; 2], y: f64) {
        let (u, v, t) = (s * basis[0], s * basis[1], s * y);
        self.a00 += u * u;
        self.a01 += u * v;
        self.a11 += v * v;
        self.b0 += u * t;
        self.b1 += v * t;
        self.yy += t * t;
    }

    /// Non-negative least squares over `nb` (1 or 2) columns: coefficients and
    /// `0.5 * residual sum of squares`.
    pub fn solve(&self, nb: usize) -> ([f64; 2], f64) {
        let ProjectionSums {
            a00,
            a01,
            a11,
            b0,
            b1,
            yy,
        } = *self;
        let cost_of = |x0: f64, x1: f64| {
            0.5 * (x0 * x0 * a00 + 2.0 * x0 * x1 * a01 + x1 * x1 * a11 - 2.0 * (x0 * b0 + x1 * b1) + yy)
        };
        let single0 = if a00 > 0.0 { (b0 / a00).max(0.0) } else { 0.0 };
        if nb == 1 {
            return ([single0, 0.0], cost_of(single0, 0.0).max(0.0));
        }
        let single1 = if a11 > 0.0 { (b1 / a11).max(0.0) } else { 0.0 };
        let mut best = ([single0, 0.0], cost_of(single0, 0.0));
        let c1 = cost_of(0.0, single1);
        if c1 < best.1 {
            best = ([0.0, single1], c1);
        }
        let det = a00 * a11 - a01 * a01;
        if det > 1e-300 * a00 * a11 {
            let x0 = (b0 * a11 - b1 * a01) / det;
            let x1 = (a00 * b1 - a01 * b0) / det;
            if x0 >= 0.0 && x1 >= 0.0 {
                let c = cost_of(x0, x1);
                if c < best.1 {
                    best = ([x0, x1], c);
                }
            }
        }
        (best.0, best.1.max(0.0))
    }
}
