//! A deterministic grid over the nonlinear parameters, the part of the global search that
//! does not depend on the seed: the projected cost (linear parameters solved exactly) at every
//! node of a fixed grid that includes the box's edges, and the best nodes of distinct basins
//! as starting points for the polish.
//!
//! Real measurements put optima where random chains rarely go — on the box's edges (`|b| = 0`,
//! `kr` near its bound, `c = 0`) or in narrow basins — and the chains then agree on a worse
//! optimum. The grid visits those places on every run, whatever the seed. For the lobe models
//! the bases factor per point (facet by `kr`, `x^a` by `a`, the lobe by `|b|` and `a`, the
//! diffuse term by `c`), so the whole grid costs a few passes over the data.

use brdf_core::{ModelKind, MAX_PARAMS};

use crate::kernel::{assemble, factors};
use crate::problem::{Problem, ProjectionSums, GGX_LN_ALPHA};

/// `kr` nodes (searched as `ln kr`): log-spaced over the search box [0.01, 1000].
const KR: [f64; 7] = [0.01, 0.0681, 0.464, 3.16, 21.5, 147.0, 1000.0];
/// `|b|` nodes over [0, 200]: dense near 0, where the lobe switches from flat to peaked.
const BETA: [f64; 6] = [0.0, 2.0, 8.0, 25.0, 70.0, 200.0];
/// `a` nodes over [0.05, 4].
const A: [f64; 6] = [0.05, 0.25, 0.6, 1.2, 2.2, 4.0];
/// `c` nodes over [0, 5], and below 0 with brightening (denser at small `c`, where diffuse
/// materials sit and where the lobe can stand in for a wrong `c`).
const C: [f64; 9] = [0.0, 0.15, 0.3, 0.5, 0.8, 1.2, 1.8, 3.0, 5.0];
const C_BRIGHT: [f64; 3] = [-0.9, -0.6, -0.3];
/// Microfacet `alpha` nodes (searched as `ln alpha`) inside the box's ends ([`GGX_LN_ALPHA`],
/// the grid's first and last nodes: 1/1024 and 4), log-spaced but denser where paints and
/// metals sit (0.01–0.5).
const ALPHA: [f64; 9] = [0.003, 0.01, 0.025, 0.06, 0.13, 0.25, 0.45, 0.8, 1.5];
/// Microfacet `f0` nodes over [0, 1]: dielectrics at 0.02–0.06, metals above 0.5.
const F0: [f64; 6] = [0.0, 0.02, 0.05, 0.15, 0.4, 1.0];
/// Minnaert `k` nodes over [0.01, 1].
const K: [f64; 8] = [0.01, 0.1, 0.25, 0.4, 0.55, 0.7, 0.85, 1.0];

/// Starting points per fit taken from the grid.
pub const GRID_STARTS: usize = 6;

/// The best grid nodes of up to `starts` distinct basins (no two adjacent on the grid, at most
/// one with the lobe off), best first, as internal parameter vectors with their linear
/// parameters solved.
pub fn grid_starts(problem: &Problem, starts: usize) -> Vec<[f64; MAX_PARAMS]> {
    let kind = problem.kind();
    let c_nodes: Vec<f64> = if problem.brightening() {
        C_BRIGHT.iter().chain(C.iter()).copied().collect()
    } else {
        C.to_vec()
    };
    // Axes of the grid in internal units, in the order of `nonlinear_indices`.
    let axes: Vec<Vec<f64>> = match kind {
        ModelKind::Six | ModelKind::SixCos2 => vec![
            KR.iter().map(|k| k.ln()).collect(),
            BETA.to_vec(),
            A.to_vec(),
            c_nodes,
        ],
        ModelKind::Five => vec![KR.iter().map(|k| k.ln()).collect(), BETA.to_vec(), A.to_vec()],
        ModelKind::Minnaert => vec![K.to_vec()],
        ModelKind::Ggx => vec![
            std::iter::once(GGX_LN_ALPHA.0)
                .chain(ALPHA.iter().map(|a| a.ln()))
                .chain(std::iter::once(GGX_LN_ALPHA.1))
                .collect(),
            F0.to_vec(),
        ],
        ModelKind::Lambert => vec![],
    };
    let nodes: Vec<(Vec<usize>, [f64; 2], f64)> = match kind {
        ModelKind::Six | ModelKind::SixCos2 | ModelKind::Five => lobe_grid(problem, &axes),
        ModelKind::Minnaert | ModelKind::Ggx | ModelKind::Lambert => full_grid(problem, &axes),
    };
    let mut order: Vec<usize> = (0..nodes.len()).filter(|&i| nodes[i].2.is_finite()).collect();
    order.sort_by(|&a, &b| nodes[a].2.total_cmp(&nodes[b].2));
    // With the lobe off (kb = 0) the lobe's shape has no effect: every such node is the same
    // optimum, however far apart on the grid, so at most one of them is taken.
    let lobe_off =
        |i: usize| kind != ModelKind::Minnaert && kind != ModelKind::Lambert && nodes[i].1[0] <= 0.0;
    let mut picked: Vec<usize> = Vec::new();
    for i in order {
        if picked.len() >= starts {
            break;
        }
        if lobe_off(i) && picked.iter().any(|&p| lobe_off(p)) {
            continue;
        }
        // Equal cost: the same model (e.g. any `a` when `|b| = 0`).
        if picked
            .iter()
            .any(|&p| (nodes[p].2 - nodes[i].2).abs() <= 1e-12 * nodes[i].2.abs())
        {
            continue;
        }
        let adjacent = picked.iter().any(|&p| {
            nodes[p]
                .0
                .iter()
                .zip(&nodes[i].0)
                .all(|(a, b)| a.abs_diff(*b) <= 1)
        });
        if !adjacent {
            picked.push(i);
        }
    }
    picked
        .into_iter()
        .map(|i| {
            let nl: Vec<f64> = nodes[i].0.iter().zip(&axes).map(|(&k, ax)| ax[k]).collect();
            assemble(kind, &nl, nodes[i].1)
        })
        .collect()
}

/// Every node of the lobe models' grid: (indices, linear parameters, projected cost).
fn lobe_grid(problem: &Problem, axes: &[Vec<f64>]) -> Vec<(Vec<usize>, [f64; 2], f64)> {
    let kind = problem.kind();
    let pts = problem.points();
    let n = pts.len();
    let s: Vec<f64> = (0..n).map(|i| problem.projection_scale(i)).collect();
    let sy: Vec<f64> = (0..n).map(|i| s[i] * problem.target(i)).collect();
    let yy: f64 = sy.iter().map(|t| t * t).sum();
    let w: Vec<f64> = pts.iter().map(|p| factors::weight(kind, p)).collect();
    let facet: Vec<Vec<f64>> = axes[0]
        .iter()
        .map(|lkr| {
            let k = (2.0 * lkr).exp();
            pts.iter().map(|p| factors::facet(kind, k, p)).collect()
        })
        .collect();
    let power: Vec<Vec<f64>> = axes[2]
        .iter()
        .map(|&a| pts.iter().map(|p| factors::power(a, p)).collect())
        .collect();
    // The second basis: (cos ti cos tr)^c for the six-parameter models, 1/cos ti for five.
    let seconds: Vec<Vec<f64>> = if kind == ModelKind::Five {
        vec![(0..n)
            .map(|i| s[i] * factors::second(kind, 0.0, &pts[i]))
            .collect()]
    } else {
        axes[3]
            .iter()
            .map(|&c| (0..n).map(|i| s[i] * factors::second(kind, c, &pts[i])).collect())
            .collect()
    };
    let a11: Vec<f64> = seconds.iter().map(|v| v.iter().map(|x| x * x).sum()).collect();
    let b1: Vec<f64> = seconds
        .iter()
        .map(|v| v.iter().zip(&sy).map(|(x, t)| x * t).sum())
        .collect();
    let mut out = Vec::new();
    let mut u = vec![0.0; n];
    for (k, fk) in facet.iter().enumerate() {
        for (j, &beta) in axes[1].iter().enumerate() {
            for (m, pm) in power.iter().enumerate() {
                for i in 0..n {
                    u[i] = s[i] * w[i] * fk[i] * (-beta * pm[i]).exp();
                }
                let a00: f64 = u.iter().map(|x| x * x).sum();
                let b0: f64 = u.iter().zip(&sy).map(|(x, t)| x * t).sum();
                for (c, v) in seconds.iter().enumerate() {
                    let a01: f64 = u.iter().zip(v).map(|(x, y)| x * y).sum();
                    let sums = ProjectionSums::from_sums(a00, a01, a11[c], b0, b1[c], yy);
                    let (lin, cost) = sums.solve(2);
                    let mut idx = vec![k, j, m];
                    if kind != ModelKind::Five {
                        idx.push(c);
                    }
                    out.push((idx, lin, cost));
                }
            }
        }
    }
    out
}

/// Every node for the models without cached factors (one full projection per node; the
/// microfacet model's 11 x 6 nodes, Minnaert's 8, Lambert's one).
fn full_grid(problem: &Problem, axes: &[Vec<f64>]) -> Vec<(Vec<usize>, [f64; 2], f64)> {
    let count: usize = axes.iter().map(Vec::len).product();
    (0..count)
        .map(|mut flat| {
            // Mixed-radix digits of `flat`, last axis fastest.
            let mut idx = vec![0; axes.len()];
            for (k, ax) in axes.iter().enumerate().rev() {
                idx[k] = flat % ax.len();
                flat /= ax.len();
            }
            let nl: Vec<f64> = idx.iter().zip(axes).map(|(&i, ax)| ax[i]).collect();
            let (lin, cost) = problem.project(&nl);
            (idx, lin, cost)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{synth, Residual};
    use brdf_core::tolerance::F64_REFORMULATION_REL;

    #[test]
    fn grid_costs_equal_full_projections() {
        for kind in [
            ModelKind::Six,
            ModelKind::SixCos2,
            ModelKind::Five,
            ModelKind::Minnaert,
            ModelKind::Ggx,
        ] {
            let p: Vec<f64> = match kind {
                ModelKind::Five => vec![0.2545, 1.8, -27.5721, 0.6705, 0.3676],
                ModelKind::Minnaert => vec![0.6, 0.7],
                ModelKind::Ggx => vec![1.2, 0.2, 0.05, 0.3],
                _ => brdf_core::TABLE1[0].1.to_vec(),
            };
            let d = synth::in_plane(kind, &p, &[0.0, 30.0], 5.0, 0.01, 3).unwrap();
            let pr = Problem::from_dataset(kind, Residual::Relative, &d);
            let starts = grid_starts(&pr, GRID_STARTS);
            assert!(!starts.is_empty(), "{kind:?}");
            for q in starts {
                let idx = crate::problem::nonlinear_indices(kind);
                let nl: Vec<f64> = idx.iter().map(|&j| q[j]).collect();
                let (lin, cost) = pr.project(&nl);
                let again = assemble(kind, &nl, lin);
                assert!(
                    (0..kind.param_count()).all(|j| (again[j] - q[j]).abs() <= 1e-9 * (1.0 + q[j].abs())),
                    "{kind:?}: {q:?} vs {again:?}"
                );
                assert!(
                    (pr.cost(&q) - cost).abs() <= 1e-9 * cost.max(F64_REFORMULATION_REL),
                    "{kind:?}: {} vs {cost}",
                    pr.cost(&q)
                );
            }
        }
    }
}
