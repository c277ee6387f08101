//! One least-squares problem: a dataset, a model, a residual form, and the parameter box.

use brdf_core::names::Named;
use brdf_core::{ModelKind, MAX_PARAMS};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::data::{Dataset, Point};
use crate::kernel::{bases, eval_many, nonlinear_count, Prepared};

/// Points per call of [`eval_many`] in the passes over the data.
const CHUNK: usize = 1024;

/// Points from which a pass over the data (cost, normal equations) runs on all cores, in
/// blocks of [`BLOCK`]: below, one thread is quicker than the pool's start-up (a pass costs
/// 10–50 ns per point).
pub const PARALLEL_POINTS: usize = 65_536;

/// Points per block of a parallel pass (a multiple of the kernels' chunk).
pub const BLOCK: usize = 8 * CHUNK;

/// Partial sums of one pass: `sum rho`, `J^T r`, the lower triangle of `J^T J`.
#[derive(Clone, Copy)]
struct Sums {
    cost: f64,
    jtj: [[f64; MAX_PARAMS]; MAX_PARAMS],
    jtr: [f64; MAX_PARAMS],
}

impl Sums {
    fn add(mut self, o: Sums) -> Sums {
        self.cost += o.cost;
        for a in 0..MAX_PARAMS {
            self.jtr[a] += o.jtr[a];
            for b in 0..MAX_PARAMS {
                self.jtj[a][b] += o.jtj[a][b];
            }
        }
        self
    }
}

/// Residual form. `f` is the model, `y` the measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
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

impl Named for Residual {
    const WHAT: &'static str = "residual";
    const ALL: &'static [Residual] = &[Residual::Relative, Residual::Absolute, Residual::Log];
    /// Name on the command line, in Python and in results.
    fn name(self) -> &'static str {
        match self {
            Residual::Relative => "relative",
            Residual::Absolute => "absolute",
            Residual::Log => "log",
        }
    }
}

brdf_core::named_str!(Residual);

/// Robust loss applied to the residuals, as scipy's `least_squares` defines them: the cost
/// is `0.5 * sum C^2 rho(r_i^2 / C^2)` with `C` the loss scale (`f_scale`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum LossKind {
    /// `rho(z) = z`: ordinary least squares (default).
    #[default]
    Linear,
    /// `rho(z) = z` for `z <= 1`, `2 sqrt(z) - 1` beyond: quadratic near zero, linear tails.
    Huber,
    /// `rho(z) = 2 (sqrt(1 + z) - 1)`: a smooth Huber.
    SoftL1,
    /// `rho(z) = ln(1 + z)`: a residual far beyond `C` barely counts.
    Cauchy,
}

impl Named for LossKind {
    const WHAT: &'static str = "loss";
    const ALL: &'static [LossKind] = &[
        LossKind::Linear,
        LossKind::Huber,
        LossKind::SoftL1,
        LossKind::Cauchy,
    ];
    /// Name on the command line, in Python and in results.
    fn name(self) -> &'static str {
        match self {
            LossKind::Linear => "linear",
            LossKind::Huber => "huber",
            LossKind::SoftL1 => "soft-l1",
            LossKind::Cauchy => "cauchy",
        }
    }
    /// The name, or with `_` for `-` (`soft_l1`, scipy's spelling).
    fn matches(self, given: &str) -> bool {
        given == self.name() || given.replace('_', "-") == self.name()
    }
}

brdf_core::named_str!(LossKind);

/// A loss and its scale `C` (in the residual's units: a relative error for relative
/// residuals, so `C = 0.1` lets residuals beyond 10% count less than squared).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Loss {
    /// The function.
    pub kind: LossKind,
    /// Its scale `C > 0`.
    pub scale: f64,
}

impl Default for Loss {
    fn default() -> Self {
        Loss {
            kind: LossKind::Linear,
            scale: 1.0,
        }
    }
}

impl Loss {
    /// For `r^2`: `C^2 rho(z)`, `rho'(z)` and `rho''(z) / C^2` with `z = r^2 / C^2` (scipy's
    /// convention, so that `sum` of the first is twice the cost).
    #[inline]
    pub fn eval(self, r2: f64) -> (f64, f64, f64) {
        let c2 = self.scale * self.scale;
        let z = r2 / c2;
        let (rho, d1, d2) = match self.kind {
            LossKind::Linear => return (r2, 1.0, 0.0),
            LossKind::Huber => {
                if z <= 1.0 {
                    (z, 1.0, 0.0)
                } else {
                    let s = z.sqrt();
                    (2.0 * s - 1.0, 1.0 / s, -0.5 / (z * s))
                }
            }
            // Both written without cancellation: with a large scale, z is tiny and
            // `sqrt(1 + z) - 1` or `ln(1 + z)` would lose every digit (`--loss-scale 1e8` made
            // every residual cost 0 and a grid node "converged").
            LossKind::SoftL1 => {
                let t = 1.0 + z;
                let s = t.sqrt();
                (2.0 * z / (s + 1.0), 1.0 / s, -0.5 / (t * s))
            }
            LossKind::Cauchy => {
                let t = 1.0 + z;
                (z.ln_1p(), 1.0 / t, -1.0 / (t * t))
            }
        };
        (c2 * rho, d1, d2 / c2)
    }

    /// True for the ordinary least-squares loss.
    pub fn is_linear(self) -> bool {
        self.kind == LossKind::Linear
    }
}

/// Lowest six-parameter `c` searched with brightening: Minnaert's `k - 1` for the smallest `k`
/// the fitter searches (0.01), so the diffuse term can brighten towards grazing as much as
/// Minnaert's. The core accepts any `c > -1`.
pub const BRIGHTENING_C_MIN: f64 = -0.99;

/// The microfacet roughness `alpha` the fitter searches, as `ln alpha`: the device's whole
/// range (`brdf_core::ranges::GGX`, 1/1024 to 4), each end moved in by 1e-12 in `ln alpha`
/// so that `exp` of a bound rounds inside the range.
pub const GGX_LN_ALPHA: (f64, f64) = (-6.931_471_805_598_2, 1.386_294_361_118_9);

/// Search box of the internal parameters (see [`crate::kernel`]): `ln kr` in
/// [ln 0.01, ln 1000], `beta = |b|` in [0, 200], `a` in [0.05, 4], `c` in [0, 5], the
/// five-parameter `kd` in [0, 10], Minnaert `k` in [0.01, 1], the microfacet `ln alpha` in
/// [ln 1/1024, ln 4] ([`GGX_LN_ALPHA`]) and `f0` in [0, 1]. The weights the model is
/// linear in (`kb`, the six-parameter `kd`, `ks`, `rho0`) are only non-negative: they carry the
/// data's units, so any upper bound would make the fit depend on them (data in other units
/// must give the same relative fit).
///
/// Sign convention: the box holds `beta = |b| = -b`, never the paper's `b <= 0`; the device
/// annealer's box (`brdf_core::anneal::SearchBox`) holds the paper's `b` in `[-200, 0]`, and
/// says why the two stay apart.
pub fn bounds(kind: ModelKind) -> ([f64; MAX_PARAMS], [f64; MAX_PARAMS]) {
    let lkr = (0.01_f64.ln(), 1000.0_f64.ln());
    let inf = f64::INFINITY;
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => (
            [0.0, lkr.0, 0.0, 0.05, 0.0, 0.0],
            [inf, lkr.1, 200.0, 4.0, inf, 5.0],
        ),
        ModelKind::Five => (
            [0.0, lkr.0, 0.0, 0.05, 0.0, 0.0],
            [inf, lkr.1, 200.0, 4.0, 10.0, 0.0],
        ),
        ModelKind::Minnaert => ([0.0, 0.01, 0.0, 0.0, 0.0, 0.0], [inf, 1.0, 0.0, 0.0, 0.0, 0.0]),
        ModelKind::Ggx => (
            [0.0, GGX_LN_ALPHA.0, 0.0, 0.0, 0.0, 0.0],
            [inf, GGX_LN_ALPHA.1, 1.0, inf, 0.0, 0.0],
        ),
        ModelKind::Lambert => ([0.0; MAX_PARAMS], [inf, 0.0, 0.0, 0.0, 0.0, 0.0]),
    }
}

/// Parameters variable projection solves from its linear coefficients although the model is
/// not linear in them: the five-parameter `kd`, the ratio of the coefficients `(kb, kb kd)`
/// of its two bases ([`crate::kernel::bases`], [`crate::kernel::assemble`]). With the
/// weights ([`ModelKind::linear_params`]) they are what a fit solves per dataset, and per
/// band in a shared-shape fit ([`crate::spectral::share`]).
pub fn projected_ratios(kind: ModelKind) -> &'static [usize] {
    match kind {
        ModelKind::Five => &[4],
        _ => &[],
    }
}

/// Indices of the nonlinear parameters (see [`crate::kernel::bases`]) in the internal vector:
/// every parameter but the weights ([`ModelKind::linear_params`], the one statement of them)
/// and the [`projected_ratios`].
pub fn nonlinear_indices(kind: ModelKind) -> &'static [usize] {
    static TABLE: std::sync::OnceLock<Vec<Vec<usize>>> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        ModelKind::ALL
            .iter()
            .map(|&k| {
                (0..k.param_count())
                    .filter(|i| !k.linear_params().contains(i) && !projected_ratios(k).contains(i))
                    .collect()
            })
            .collect()
    });
    let at = ModelKind::ALL
        .iter()
        .position(|&k| k == kind)
        .expect("ModelKind::ALL lists every kind");
    &table[at]
}

/// A prepared least-squares problem: cost `0.5 * sum r_i^2`.
#[derive(Clone, Debug)]
pub struct Problem {
    kind: ModelKind,
    residual: Residual,
    pts: Vec<Prepared>,
    y: Vec<f64>,
    /// Denominator of the relative residual: `y`, or `sqrt(y^2 + floor^2)` under a noise
    /// floor ([`Problem::with_floor`]), so that readings at or below zero stay finite.
    d: Vec<f64>,
    /// The noise floor, 1/sr (0: none): in the relative residual and relative errors.
    floor: f64,
    /// Per-point factor of the residual's weight (sqrt(weight) or from sigma).
    w: Vec<f64>,
    /// Robust loss of the cost.
    loss: Loss,
    /// Six-parameter models: search `c` down to [`BRIGHTENING_C_MIN`] instead of 0.
    brightening: bool,
    /// Iteratively reweighted least squares: the robust loss's `rho'` at a current point,
    /// per point, used by the projection (the global search solves linear least squares).
    irls: Vec<f64>,
    /// Asked to stop (see [`Stop`]).
    stop: Stop,
    /// Parameters held at a value (internal units): their search box is that value
    /// ([`Problem::with_fixed`]).
    fixed: [Option<f64>; MAX_PARAMS],
}

/// A request to abandon a fit part way (the Python package's Ctrl-C): shared by the caller
/// and every search on the problem, which look at it between annealing moves (every
/// [`Stop::EVERY`] moves), polish iterations, chains and hops, and end early. A stopped fit's
/// outcome is never "converged" (`fit::FitOutcome`); its result is meant to be dropped.
#[derive(Clone, Debug, Default)]
pub struct Stop(Option<std::sync::Arc<std::sync::atomic::AtomicBool>>);

impl Stop {
    /// Annealing moves between looks at the flag (about a millisecond on a 1,000-point
    /// problem).
    pub const EVERY: usize = 256;

    /// A stop that [`Stop::request`] triggers.
    pub fn new() -> Self {
        Stop(Some(std::sync::Arc::default()))
    }

    /// Asks every search holding a clone of this stop to end.
    pub fn request(&self) {
        if let Some(flag) = &self.0 {
            flag.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    }

    /// Whether a stop was requested (never, for [`Stop::default`]).
    pub fn requested(&self) -> bool {
        self.0
            .as_ref()
            .is_some_and(|flag| flag.load(std::sync::atomic::Ordering::Relaxed))
    }
}

impl Problem {
    /// Prepares `points` for fitting `kind` with `residual` (no noise floor: every reading
    /// must be above zero for relative and log residuals; see [`Problem::with_floor`]).
    pub fn new(kind: ModelKind, residual: Residual, points: &[Point]) -> Self {
        Self::with_floor(kind, residual, points, 0.0)
    }

    /// [`Problem::new`] with a noise floor `floor >= 0` (1/sr) on the relative residual,
    /// which becomes `(f - y) / sqrt(y^2 + floor^2)`: the relative error above the floor, the
    /// absolute error in units of the floor below it, finite for readings at or below zero
    /// ([`crate::noise`]). A point with a `sigma` keeps the residual `(f - y) / sigma`. With
    /// `floor` 0 this is exactly [`Problem::new`]. Log residuals take no floor (`ln y` of a
    /// dark reading has none) and absolute ones need none: for them the floor only enters
    /// [`Problem::relative_error`] (the report's relative metrics).
    pub fn with_floor(kind: ModelKind, residual: Residual, points: &[Point], floor: f64) -> Self {
        let d: Vec<f64> = points
            .iter()
            .map(|p| {
                if floor > 0.0 && residual == Residual::Relative {
                    p.brdf.hypot(floor)
                } else {
                    p.brdf
                }
            })
            .collect();
        let w = points
            .iter()
            .zip(&d)
            .map(|(p, &d)| match (p.sigma, p.weight) {
                (Some(s), _) => match residual {
                    Residual::Absolute => 1.0 / s,
                    Residual::Relative | Residual::Log => d / s,
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
            d,
            floor,
            w,
            loss: Loss::default(),
            brightening: false,
            irls: vec![1.0; points.len()],
            stop: Stop::default(),
            fixed: [None; MAX_PARAMS],
        }
    }

    /// The same problem, abandoned by its searches when `stop` is requested.
    pub fn with_stop(mut self, stop: Stop) -> Self {
        self.stop = stop;
        self
    }

    /// Whether the searches on this problem were asked to stop.
    pub fn stopped(&self) -> bool {
        self.stop.requested()
    }

    /// The same problem with the six-parameter diffuse exponent `c` searched down to
    /// [`BRIGHTENING_C_MIN`], so that the diffuse term can brighten towards grazing (as
    /// Minnaert's `k - 1` does); other models are unaffected.
    pub fn with_brightening(mut self, on: bool) -> Self {
        self.brightening = on;
        self
    }

    /// True when `c` may be negative (see [`Problem::with_brightening`]).
    pub fn brightening(&self) -> bool {
        self.brightening && matches!(self.kind, ModelKind::Six | ModelKind::SixCos2)
    }

    /// The search box of this problem: [`bounds`], with `c` down to [`BRIGHTENING_C_MIN`]
    /// under [`Problem::with_brightening`], and the parameters held by
    /// [`Problem::with_fixed`] at their values.
    pub fn bounds(&self) -> ([f64; MAX_PARAMS], [f64; MAX_PARAMS]) {
        let (mut lo, mut hi) = bounds(self.kind);
        if self.brightening() {
            lo[5] = BRIGHTENING_C_MIN;
        }
        for (j, v) in self.fixed.iter().enumerate() {
            if let Some(v) = *v {
                (lo[j], hi[j]) = (v, v);
            }
        }
        (lo, hi)
    }

    /// The same problem with the parameters at `indices` held at their values in `q`
    /// (internal units): every search, polish and profile on it leaves them there (the shape
    /// a band shares with the other bands of its measurement, `crate::spectral`).
    pub fn with_fixed(mut self, indices: &[usize], q: &[f64; MAX_PARAMS]) -> Self {
        for &j in indices {
            self.fixed[j] = Some(q[j]);
        }
        self
    }

    /// Whether parameter `j` is held ([`Problem::with_fixed`]).
    pub fn is_fixed(&self, j: usize) -> bool {
        self.fixed[j].is_some()
    }

    /// The same problem with a robust loss.
    pub fn with_loss(mut self, loss: Loss) -> Self {
        self.loss = loss;
        self
    }

    /// The robust loss.
    pub fn loss(&self) -> Loss {
        self.loss
    }

    /// Sets the projection's per-point IRLS weights to the loss's `rho'` at `q` (all 1 for
    /// the linear loss).
    pub fn reweight(&mut self, q: &[f64]) {
        if self.loss.is_linear() {
            return;
        }
        let q = &q[..self.dim()];
        for i in 0..self.pts.len() {
            let r = self.residual_at(i, crate::kernel::eval(self.kind, q, &self.pts[i], None));
            self.irls[i] = if r.is_finite() {
                self.loss.eval(r * r).1
            } else {
                0.0
            };
        }
    }

    /// A copy without the points `rows` (influence analysis: a row and its exact copies).
    /// Linear in the points and rows (a row written 400,000 times took 15 s: each point was
    /// looked for among the rows).
    pub fn without(&self, rows: &[usize]) -> Problem {
        let mut dropped = vec![false; self.len()];
        for &i in rows {
            if let Some(d) = dropped.get_mut(i) {
                *d = true;
            }
        }
        let keep: Vec<usize> = (0..self.len()).filter(|&i| !dropped[i]).collect();
        self.subset_scaled(&keep, &vec![1.0; keep.len()])
    }

    /// The problem on the points `indices` only (in that order), everything else alike, with
    /// point `indices[k]`'s squared residual weighted by `factors[k]` (its residual by the
    /// square root): a subsample standing for more points than it holds
    /// ([`crate::fit::search_sample`]).
    pub fn subset_scaled(&self, indices: &[usize], factors: &[f64]) -> Problem {
        Problem {
            pts: indices.iter().map(|&i| self.pts[i]).collect(),
            y: indices.iter().map(|&i| self.y[i]).collect(),
            d: indices.iter().map(|&i| self.d[i]).collect(),
            w: indices
                .iter()
                .zip(factors)
                .map(|(&i, &f)| self.w[i] * f.sqrt())
                .collect(),
            irls: indices.iter().map(|&i| self.irls[i]).collect(),
            stop: self.stop.clone(),
            ..*self
        }
    }

    /// How much point `i` can weigh in the cost: its squared residual were the model off by
    /// its reading's size (the noise floor's, for a dark reading): `(s_i max(|y_i|, floor))^2`
    /// with `s_i` the point's [`Problem::projection_scale`] — its weight (or sigma) squared
    /// for relative and log residuals, times the squared reading for absolute ones.
    pub fn importance(&self, i: usize) -> f64 {
        let y = self.y[i].abs().max(self.floor);
        let s = match self.residual {
            Residual::Absolute => self.w[i] * y,
            Residual::Relative => self.w[i] * y / self.d[i],
            Residual::Log => self.w[i],
        };
        s * s
    }

    /// Residual `r_i` (weighted, in the residual form) of model value `f` at point `i`.
    pub fn residual_of(&self, i: usize, f: f64) -> f64 {
        self.residual_at(i, f)
    }

    /// Relative error of model value `f` at point `i`, unweighted: `(f - y) / y`, or
    /// `(f - y) / sqrt(y^2 + floor^2)` under a noise floor (whatever the residual form).
    pub fn relative_error(&self, i: usize, f: f64) -> f64 {
        crate::noise::floored_relative(f, self.y[i], self.floor)
    }

    /// The noise floor of the relative residual, 1/sr (0: none).
    pub fn floor(&self) -> f64 {
        self.floor
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
            Residual::Relative => w * (f - y) / self.d[i],
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

    /// `0.5 * sum C^2 rho(r_i^2 / C^2)` (`0.5 * sum r_i^2` for the linear loss) at internal
    /// parameters `q`; infinite where a log residual sees `f <= 0`.
    pub fn cost(&self, q: &[f64]) -> f64 {
        0.5 * self.pass(|r| self.cost_sum(q, r), |a, b| a + b)
    }

    /// `f` over every point: below [`PARALLEL_POINTS`] in one range on this thread, above in
    /// blocks of [`BLOCK`] on all cores, their results joined by `add` in block order (the
    /// same bits whatever the thread count).
    fn pass<T: Send>(&self, f: impl Fn(std::ops::Range<usize>) -> T + Sync, add: impl Fn(T, T) -> T) -> T {
        if self.len() < PARALLEL_POINTS {
            return f(0..self.len());
        }
        let blocks: Vec<T> = (0..self.len().div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| f(b * BLOCK..((b + 1) * BLOCK).min(self.len())))
            .collect();
        blocks.into_iter().reduce(add).expect("at least one block")
    }

    /// `sum rho(r_i^2)` over the points in `range`.
    fn cost_sum(&self, q: &[f64], range: std::ops::Range<usize>) -> f64 {
        let q = &q[..self.dim()];
        let mut s = 0.0;
        let mut f = [0.0; CHUNK];
        for (c, pts) in self.pts[range.clone()].chunks(CHUNK).enumerate() {
            eval_many(self.kind, q, pts, &mut f[..pts.len()], None);
            for (k, &fk) in f[..pts.len()].iter().enumerate() {
                let r = self.residual_at(range.start + c * CHUNK + k, fk);
                s += self.loss.eval(r * r).0;
            }
        }
        s
    }

    /// Cost, gradient `J^T r` and Gauss–Newton matrix `J^T J` at `q` in one pass (over
    /// blocks of [`BLOCK`] points on all cores above [`PARALLEL_POINTS`] points, the blocks'
    /// sums added in order: the same bits whatever the thread count).
    pub fn normal_equations(
        &self,
        q: &[f64],
        jtj: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
        jtr: &mut [f64; MAX_PARAMS],
    ) -> f64 {
        let sums = self.pass(|r| self.normal_sums(q, r), Sums::add);
        let n = self.dim();
        (*jtj, *jtr) = (sums.jtj, sums.jtr);
        for a in 0..n {
            for b in 0..a {
                jtj[b][a] = jtj[a][b];
            }
        }
        0.5 * sums.cost
    }

    /// `sum rho`, `J^T r` and the lower triangle of `J^T J` over the points in `range`.
    fn normal_sums(&self, q: &[f64], range: std::ops::Range<usize>) -> Sums {
        let n = self.dim();
        let q = &q[..n];
        let (mut jtj, mut jtr) = ([[0.0; MAX_PARAMS]; MAX_PARAMS], [0.0; MAX_PARAMS]);
        let mut cost = 0.0;
        let mut fs = [0.0; CHUNK];
        let mut gs = [[0.0; MAX_PARAMS]; CHUNK];
        let linear = self.loss.is_linear();
        for (c, pts) in self.pts[range.clone()].chunks(CHUNK).enumerate() {
            eval_many(
                self.kind,
                q,
                pts,
                &mut fs[..pts.len()],
                Some(&mut gs[..pts.len()]),
            );
            // Residuals and Jacobian rows in place, then the sums with the parameter count
            // known at compile time (the accumulators stay in registers).
            for (k, (f, g)) in fs.iter_mut().zip(&mut gs).take(pts.len()).enumerate() {
                let i = range.start + c * CHUNK + k;
                let r = self.residual_at(i, *f);
                let (d, w) = (self.d[i], self.w[i]);
                let mut scale = match self.residual {
                    Residual::Relative => w / d,
                    Residual::Absolute => w,
                    Residual::Log => w / *f,
                };
                *f = r;
                if !linear {
                    // Robust loss, scaled as scipy's least_squares does: residual
                    // `r rho' / sqrt(k)` and row `J sqrt(k)` with the curvature
                    // `k = rho' + 2 rho'' r^2`, so that Gauss-Newton sees the loss.
                    let (rho, d1, d2) = self.loss.eval(r * r);
                    cost += rho;
                    let k = (d1 + 2.0 * d2 * r * r).max(f64::EPSILON).sqrt();
                    *f = r * d1 / k;
                    scale *= k;
                }
                for v in g.iter_mut() {
                    *v *= scale;
                }
            }
            let (fs, gs) = (&fs[..pts.len()], &gs[..pts.len()]);
            let squares = match n {
                6 => accumulate::<6>(fs, gs, &mut jtj, &mut jtr),
                5 => accumulate::<5>(fs, gs, &mut jtj, &mut jtr),
                2 => accumulate::<2>(fs, gs, &mut jtj, &mut jtr),
                1 => accumulate::<1>(fs, gs, &mut jtj, &mut jtr),
                _ => accumulate::<MAX_PARAMS>(fs, gs, &mut jtj, &mut jtr),
            };
            // Under a robust loss the cost was summed above (the scaled residuals are not it).
            if linear {
                cost += squares;
            }
        }
        Sums { cost, jtj, jtr }
    }

    /// Row `i` of the Jacobian of the residuals with respect to the internal parameters
    /// (under a robust loss scaled by the square root of the loss's curvature there, as the
    /// polish sees it).
    pub fn jacobian_row(&self, i: usize, q: &[f64]) -> [f64; MAX_PARAMS] {
        let n = self.dim();
        let mut g = [0.0; MAX_PARAMS];
        let f = crate::kernel::eval(self.kind, &q[..n], &self.pts[i], Some(&mut g[..n]));
        let robust = if self.loss.is_linear() {
            1.0
        } else {
            let r = self.residual_at(i, f);
            let (_, d1, d2) = self.loss.eval(r * r);
            (d1 + 2.0 * d2 * r * r).max(f64::EPSILON).sqrt()
        };
        let scale = robust
            * match self.residual {
                Residual::Relative => self.w[i] / self.d[i],
                Residual::Absolute => self.w[i],
                Residual::Log => self.w[i] / f,
            };
        for v in g.iter_mut() {
            *v *= scale;
        }
        g
    }

    /// `J^T J` of the residuals' Jacobian ([`Problem::jacobian_row`]), summed row by row
    /// without holding the Jacobian (constant memory however many points).
    /// Above [`PARALLEL_POINTS`] points, on all cores in blocks added in order (the same bits
    /// whatever the thread count).
    pub fn jacobian_gram(&self, q: &[f64]) -> [[f64; MAX_PARAMS]; MAX_PARAMS] {
        self.pass(
            |r| self.gram_sum(q, r),
            |mut a, b| {
                for (ra, rb) in a.iter_mut().zip(&b) {
                    for (x, y) in ra.iter_mut().zip(rb) {
                        *x += y;
                    }
                }
                a
            },
        )
    }

    /// `J^T J` over the rows in `range`.
    fn gram_sum(&self, q: &[f64], range: std::ops::Range<usize>) -> [[f64; MAX_PARAMS]; MAX_PARAMS] {
        let n = self.dim();
        let mut jtj = [[0.0; MAX_PARAMS]; MAX_PARAMS];
        for i in range {
            let g = self.jacobian_row(i, q);
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
        let mut f = vec![0.0; self.len()];
        eval_many(self.kind, &q[..self.dim()], &self.pts, &mut f, None);
        f
    }

    /// Prepared points.
    pub fn points(&self) -> &[Prepared] {
        &self.pts
    }

    /// Scale `s_i` of point `i` in the projected (linear) least-squares problem
    /// `min || s (B lin - y) ||^2`: relative scaling also for log residuals.
    #[inline]
    pub fn projection_scale(&self, i: usize) -> f64 {
        let s = match self.residual {
            Residual::Absolute => self.w[i],
            Residual::Relative => self.w[i] / self.d[i],
            Residual::Log => self.w[i] / self.y[i],
        };
        s * self.irls[i].sqrt()
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

/// Adds `sum r^2`, `J^T r` and the lower triangle of `J^T J` over rows `j` with residuals
/// `r`, for the first `N` parameters; returns `sum r^2`.
#[inline]
fn accumulate<const N: usize>(
    r: &[f64],
    j: &[[f64; MAX_PARAMS]],
    jtj: &mut [[f64; MAX_PARAMS]; MAX_PARAMS],
    jtr: &mut [f64; MAX_PARAMS],
) -> f64 {
    let mut a_jtj = [[0.0; N]; N];
    let mut a_jtr = [0.0; N];
    let mut rr = 0.0;
    for (&r, row) in r.iter().zip(j) {
        rr += r * r;
        for a in 0..N {
            a_jtr[a] += row[a] * r;
            for b in 0..=a {
                a_jtj[a][b] += row[a] * row[b];
            }
        }
    }
    for a in 0..N {
        jtr[a] += a_jtr[a];
        for b in 0..=a {
            jtj[a][b] += a_jtj[a][b];
        }
    }
    rr
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
    /// From sums accumulated elsewhere: `sum u^2`, `sum u v`, `sum v^2`, `sum u t`,
    /// `sum v t`, `sum t^2` with `u`, `v` the scaled bases and `t` the scaled targets.
    pub fn from_sums(a00: f64, a01: f64, a11: f64, b0: f64, b1: f64, yy: f64) -> Self {
        ProjectionSums {
            a00,
            a01,
            a11,
            b0,
            b1,
            yy,
        }
    }

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

#[cfg(test)]
mod loss_tests {
    use super::*;

    /// Before: `sqrt(1 + z) - 1` and `ln(1 + z)` cancelled for a tiny `z` (a large loss
    /// scale), so every residual cost 0. With a scale far above the residuals every robust
    /// loss is least squares to rounding.
    #[test]
    fn a_large_scale_makes_every_loss_least_squares_to_rounding() {
        for kind in [LossKind::Huber, LossKind::SoftL1, LossKind::Cauchy] {
            for r in [1e-6_f64, 1e-3, 0.3, 2.0] {
                let loss = Loss { kind, scale: 1e8 };
                let (rho, d1, d2) = loss.eval(r * r);
                assert!(((rho - r * r) / (r * r)).abs() < 1e-12, "{kind:?} r={r}: {rho}");
                assert!((d1 - 1.0).abs() < 1e-12, "{kind:?} r={r}: {d1}");
                assert!(d2.abs() < 1e-12, "{kind:?} r={r}: {d2}");
            }
        }
    }

    /// The rewritten forms equal the textbook ones where those are accurate.
    #[test]
    fn the_losses_are_scipys_at_moderate_scale() {
        let c = 0.1_f64;
        for r in [0.01_f64, 0.1, 1.0] {
            let z = r * r / (c * c);
            let soft = Loss {
                kind: LossKind::SoftL1,
                scale: c,
            }
            .eval(r * r)
            .0;
            assert!((soft - c * c * 2.0 * ((1.0 + z).sqrt() - 1.0)).abs() < 1e-15 * (1.0 + soft));
            let cauchy = Loss {
                kind: LossKind::Cauchy,
                scale: c,
            }
            .eval(r * r)
            .0;
            assert!((cauchy - c * c * (1.0 + z).ln()).abs() < 1e-15 * (1.0 + cauchy));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Leaving out a row and its exact copies keeps every other point, in order, and takes
    /// time linear in the points: 300,000 copies of one row (each point was looked for among
    /// the copies, 4.5e10 comparisons) are left out well within a second.
    #[test]
    fn leaving_out_many_copies_is_linear() {
        let kind = ModelKind::Lambert;
        let d = crate::synth::in_plane(kind, &[0.3], &[0.0, 30.0, 60.0], 5.0, 0.0, 1).unwrap();
        let copies = 300_000;
        let mut points = d.points.clone();
        points.extend(std::iter::repeat_n(d.points[0], copies));
        let problem = Problem::new(kind, Residual::Relative, &points);
        let mut rows: Vec<usize> = (d.points.len()..points.len()).collect();
        rows.push(0);
        let started = std::time::Instant::now();
        let without = problem.without(&rows);
        let seconds = started.elapsed().as_secs_f64();
        assert_eq!(without.len(), d.points.len() - 1);
        assert_eq!(without.y, problem.y[1..d.points.len()]);
        assert!(seconds < 1.0, "{seconds} s");
    }

    /// The microfacet `alpha` box is the device's range, from inside: every `alpha` the fitter
    /// reports passes `brdf_core::ranges::GGX`, and the ends are within 1e-11 of the range's.
    #[test]
    fn the_alpha_box_is_the_device_range_from_inside() {
        let range = brdf_core::ranges::GGX[1];
        for (ln, edge) in [
            (GGX_LN_ALPHA.0, f64::from(range.min)),
            (GGX_LN_ALPHA.1, f64::from(range.max)),
        ] {
            let alpha = ln.exp();
            assert!(range.contains(alpha) && range.contains(alpha as f32), "{alpha}");
            assert!((alpha / edge - 1.0).abs() < 1e-11, "{alpha} vs {edge}");
        }
    }
}
