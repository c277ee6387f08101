//! Tabulated six-parameter evaluation: the device's fast path for repeated lookups of one
//! material.
//!
//! The model factorises over the scattering geometry (docs/model.md, eq. 3):
//!
//! ```text
//! f_r = kb/(pi ln 2) * F(alpha) * L(gamma) * ln(1 + cos ti cos tr) + kd/pi * cos(ti)^c * cos(tr)^c
//! ```
//!
//! The facet term `F` is a multiply, an add and a divide and is computed exactly. The three
//! transcendental pieces are read from 1-D tables of `n` nodes each, uniform on `[0, 1]`,
//! with linear interpolation:
//!
//! - the lobe `L = exp(-|b| (1 - cos gamma)^a)`, indexed by `u = (1 - cos gamma)^(1/8)`
//!   (three square roots, 4 instructions each on the Cortex-M4F). In `1 - cos gamma`
//!   itself the lobe has an unbounded slope at the retro direction for `a < 1` (every
//!   Table 1 material); in `u` it is `exp(-|b| u^(8a))`, whose slope is finite for
//!   `a >= 1/8` (with `u^(1/4)` instead, random sets with `a` near 0.2 erred 10x more);
//! - `ln(1 + m)` indexed by `m = cos ti cos tr`;
//! - `mu^c` indexed by `mu`, looked up once at `mu = v = sqrt(cos ti cos tr)` and squared:
//!   `cos(ti)^c cos(tr)^c = (v^c)^2`. One lookup where one per direction took two (about 20
//!   instructions each), and the diffuse term keeps its exact reciprocity because the
//!   product does. `v` is at least the smaller cosine, so it sits no nearer the table's
//!   steep end than the two lookups did: when it replaced them, `examples/table_domain.rs`
//!   gave the same worst errors per size up to 89°, and smaller ones beyond.
//!
//! The geometry is the exact cancellation-free [`Geometry`], so the table adds only the
//! interpolation error of three smooth 1-D functions, and the result is still exactly
//! reciprocal. Where it fails: `mu^c` has an unbounded slope at `mu = 0`, so the relative
//! error grows in the last cell before the horizon (`v` below `1/(n-1)`: for 64 nodes both
//! zeniths beyond 89.1°, or one beyond 89.986° with the other at normal; for 1024 nodes
//! 89.94° and 89.9999°); and a steep lobe (large `a |b|`) needs more nodes.
//! Measured maximum errors per size are in [`crate::tolerance`] and tested in
//! `tests/table_accuracy.rs`.
//!
//! The nodes are stored as little-endian f32 bytes, lobe then `ln(1 + m)` then `mu^c`
//! ([`table_len`] bytes), exactly as they travel in a parameter blob, so the device reads them
//! in place from flash. [`fill_six_table`] generates them (the host does it in f64);
//! [`SixTable::new`] checks any byte slice before it is used.

use crate::error::ParamError;
use crate::float::Float;
use crate::geometry::Geometry;
use crate::model::Brdf;
use crate::models::{facet, SixParams};

/// Fewest nodes per table (one interpolation interval).
pub const MIN_TABLE_NODES: usize = 2;
/// Most nodes per table: 4096 nodes are 48 KiB, most of a small part's flash.
pub const MAX_TABLE_NODES: usize = 4096;
/// The table sizes whose accuracy is measured and promised ([`crate::tolerance`]).
pub const TABLE_SIZES: [usize; 3] = {
    let t = crate::tolerance::TABLE_MAX_REL;
    [t[0].0, t[1].0, t[2].0]
};

/// Bytes of a table set with `nodes` nodes per table (three tables of f32).
pub const fn table_len(nodes: usize) -> usize {
    12 * nodes
}

/// Why a table was refused.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum TableError {
    /// Node count outside [`MIN_TABLE_NODES`]`..=`[`MAX_TABLE_NODES`].
    Nodes(usize),
    /// Byte length is not [`table_len`] of a valid node count.
    Length(usize),
    /// The material parameters are invalid.
    Params(ParamError),
    /// A node is negative, infinite or NaN (node index over all three tables).
    Node(usize),
    /// Tables exist for the six-parameter model only.
    Model(crate::ModelKind),
    /// A node disagrees with the parameters beyond [`crate::tolerance::TABLE_NODE_REL`]
    /// (node index over all three tables): the table belongs to another material.
    Mismatch(usize),
}

impl core::fmt::Display for TableError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            TableError::Nodes(n) => {
                write!(
                    f,
                    "{n} table nodes, outside {MIN_TABLE_NODES}..={MAX_TABLE_NODES}"
                )
            }
            TableError::Length(n) => write!(f, "table of {n} bytes is not 12 bytes per node"),
            TableError::Params(e) => write!(f, "table parameters: {e}"),
            TableError::Node(i) => write!(f, "table node {i} is negative or not finite"),
            TableError::Mismatch(i) => write!(f, "table node {i} does not match the parameters"),
            TableError::Model(k) => write!(
                f,
                "tables exist for the six-parameter model only, not {}",
                k.name()
            ),
        }
    }
}

impl core::error::Error for TableError {}

/// Parameters a table can hold: valid, and `c >= 0` (for `c < 0` the node `mu^c` at the
/// horizon is infinite).
fn table_params<T: Float>(p: &SixParams<T>) -> Result<(), TableError> {
    p.validate().map_err(TableError::Params)?;
    if p.c < T::ZERO {
        return Err(TableError::Params(ParamError::OutOfRange {
            name: "c",
            value: p.c.to_f64(),
            range: ">= 0 in a table (mu^c is unbounded at the horizon for c < 0)",
        }));
    }
    Ok(())
}

/// Node `k` of each of the three tables, in `T`: `(exp(-|b| (u^8)^a), ln(1 + u), u^c)` at
/// `u = k/(n-1)`.
fn node_values<T: Float>(p: &SixParams<T>, k: usize, nodes: usize) -> (T, T, T) {
    let u = T::from_f64(k as f64) / T::from_f64((nodes - 1) as f64);
    let y = ((u * u) * (u * u)) * ((u * u) * (u * u));
    let lobe = (-(p.b.abs() * y.powf(p.a))).exp();
    (lobe, u.ln_1p(), u.powf(p.c))
}

/// Writes the tables of `params` with `nodes` nodes each into `out` (exactly
/// [`table_len`]`(nodes)` bytes), computing in `T` and rounding each node to f32 once.
pub fn fill_six_table<T: Float>(
    params: &SixParams<T>,
    nodes: usize,
    out: &mut [u8],
) -> Result<(), TableError> {
    table_params(params)?;
    if !(MIN_TABLE_NODES..=MAX_TABLE_NODES).contains(&nodes) {
        return Err(TableError::Nodes(nodes));
    }
    if out.len() != table_len(nodes) {
        return Err(TableError::Length(out.len()));
    }
    for k in 0..nodes {
        let (lobe, log1p, power) = node_values(params, k, nodes);
        for (t, v) in [lobe, log1p, power].into_iter().enumerate() {
            let at = 4 * (t * nodes + k);
            out[at..at + 4].copy_from_slice(&(v.to_f64() as f32).to_le_bytes());
        }
    }
    Ok(())
}

/// The per-material constants of a table set, computed once by [`SixTable::new`]; with
/// [`SixTable::from_parts`] a device rebinds them to node bytes it keeps elsewhere (its blob
/// buffer) in a few instructions per query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableConsts {
    params: SixParams<f32>,
    spec_scale: f32,
    kr2: f32,
    diffuse_scale: f32,
    /// `nodes - 1` as f32: maps `[0, 1]` onto node positions.
    scale: f32,
    nodes: usize,
}

/// How far a table is from the exact model (the [`crate::accuracy`] comparator's result).
pub type TableAccuracy = crate::accuracy::Accuracy;

/// Relative error of `table` against the exact f64 model `exact` at each of `cosines`
/// (the f32 inputs, widened exactly for the reference), with [`crate::accuracy::compare`].
pub fn table_accuracy<I>(table: &SixTable<'_>, exact: &crate::SixParam<f64>, cosines: I) -> TableAccuracy
where
    I: IntoIterator<Item = [f32; 3]> + Clone,
{
    crate::accuracy::compare(
        cosines,
        |c| table.eval_cosines(c[0], c[1], c[2]),
        |c| exact.eval_cosines(c[0].to_f64(), c[1].to_f64(), c[2].to_f64()),
    )
}

/// The accuracy [`crate::tolerance::TABLE_MAX_REL`] promises, measured for one table: over
/// [`crate::accuracy::regular_grid`] of zeniths up to
/// [`crate::tolerance::TABLE_MAX_ZENITH_DEG`] ([`PROMISE_GRID`]), at f32 cosines, against
/// the exact f64 model of the table's own f32 parameters. `brdf pack` prints it for every
/// table it builds.
pub fn promise_accuracy(table: &SixTable<'_>) -> Result<TableAccuracy, TableError> {
    let exact = crate::SixParam::new(table.c.params.widen()).map_err(TableError::Params)?;
    let (nz, na) = PROMISE_GRID;
    let grid = crate::accuracy::regular_grid(crate::tolerance::TABLE_MAX_ZENITH_DEG, nz, na);
    Ok(table_accuracy(
        table,
        &exact,
        grid.map(|d| d.map(|x| libm::cos(x) as f32)),
    ))
}

/// Zeniths (each of incidence and view) and azimuths of [`promise_accuracy`]'s grid:
/// 46 x 46 x 37 = 78,292 directions, 1.9 degrees apart in zenith up to 85, 5 in azimuth.
pub const PROMISE_GRID: (usize, usize) = (46, 37);

/// A six-parameter material evaluated through its tables; borrows the node bytes.
#[derive(Clone, Copy, Debug)]
pub struct SixTable<'t> {
    c: TableConsts,
    bytes: &'t [u8],
}

impl<'t> SixTable<'t> {
    /// Checks the parameters and the byte length; O(1), so a device can build one per query
    /// from bytes it has verified once. Until [`SixTable::verify`] has passed on these bytes
    /// the values are only as good as the bytes.
    pub fn new(params: SixParams<f32>, bytes: &'t [u8]) -> Result<Self, TableError> {
        table_params(&params)?;
        if !bytes.len().is_multiple_of(12) {
            return Err(TableError::Length(bytes.len()));
        }
        let nodes = bytes.len() / 12;
        if !(MIN_TABLE_NODES..=MAX_TABLE_NODES).contains(&nodes) {
            return Err(TableError::Nodes(nodes));
        }
        let (spec_scale, kr2, diffuse_scale) = params.scales();
        let c = TableConsts {
            params,
            spec_scale,
            kr2,
            diffuse_scale,
            scale: (nodes - 1) as f32,
            nodes,
        };
        Ok(SixTable { c, bytes })
    }

    /// The constants of this table, to rebind later with [`SixTable::from_parts`].
    pub fn consts(&self) -> TableConsts {
        self.c
    }

    /// Rebinds constants from [`SixTable::consts`] to node bytes; `None` unless the length
    /// matches. The bytes should be the ones the constants were made with (and verified).
    #[inline]
    pub fn from_parts(c: TableConsts, bytes: &'t [u8]) -> Option<Self> {
        (bytes.len() == table_len(c.nodes)).then_some(SixTable { c, bytes })
    }

    /// Checks every node: finite and non-negative, and equal within
    /// [`crate::tolerance::TABLE_NODE_REL`] to the node recomputed in f32 from the
    /// parameters, so a table shipped with another material's parameters is refused. About
    /// 640 instructions per node index on the Cortex-M4F (three tables).
    pub fn verify(&self) -> Result<(), TableError> {
        let tol = crate::tolerance::TABLE_NODE_REL as f32;
        let n = self.c.nodes;
        for k in 0..n {
            let (lobe, log1p, power) = node_values(&self.c.params, k, n);
            for (t, want) in [lobe, log1p, power].into_iter().enumerate() {
                let i = t * n + k;
                let got = self.node(i);
                if !(got.is_finite() && got >= 0.0) {
                    return Err(TableError::Node(i));
                }
                // Nodes below 1e-30 are lobe tails that no longer affect any value.
                if (got - want).abs() > tol * want.max(1e-30) {
                    return Err(TableError::Mismatch(i));
                }
            }
        }
        Ok(())
    }

    /// The material's parameters.
    pub fn params(&self) -> SixParams<f32> {
        self.c.params
    }

    /// Nodes per table.
    pub fn nodes(&self) -> usize {
        self.c.nodes
    }

    #[inline(always)]
    fn node(&self, i: usize) -> f32 {
        match self.bytes.as_chunks::<4>().0.get(i) {
            Some(&b) => f32::from_le_bytes(b),
            None => f32::NAN,
        }
    }

    /// The three tables (lobe, `ln(1 + m)`, `mu^c`), each of `nodes >= 2` nodes; `None`
    /// only if the bytes are shorter than `new` checked, which cannot happen. Splitting once
    /// lets the compiler prove every interpolation's two reads in bounds.
    #[inline(always)]
    fn tables(&self) -> Option<[&[[u8; 4]]; 3]> {
        let n = self.c.nodes;
        let all = self.bytes.as_chunks::<4>().0;
        if n < 2 {
            return None;
        }
        Some([all.get(..n)?, all.get(n..2 * n)?, all.get(2 * n..3 * n)?])
    }
}

/// Linear interpolation in `nodes` (at least two; `scale = nodes - 1`) at `x` in `[0, 1]`.
#[inline(always)]
fn lerp(nodes: &[[u8; 4]], scale: f32, x: f32) -> f32 {
    let s = x * scale;
    // `as` saturates (negative and NaN give 0); the last interval serves x = 1.
    let i = (s as usize).min(nodes.len().saturating_sub(2));
    let w = s - i as f32;
    match (nodes.get(i), nodes.get(i + 1)) {
        (Some(&a), Some(&b)) => {
            let (a, b) = (f32::from_le_bytes(a), f32::from_le_bytes(b));
            a + w * (b - a)
        }
        _ => f32::NAN,
    }
}

impl Brdf<f32> for SixTable<'_> {
    #[inline(always)]
    fn eval(&self, g: &Geometry<f32>) -> f32 {
        if let Some(v) = g.outside() {
            return v;
        }
        let Some([lobe, log1p, power]) = self.tables() else {
            return f32::NAN;
        };
        let (mi, mr) = (g.cos_theta_i(), g.cos_theta_r());
        let m = mi * mr;
        // (1 - cos gamma)^(1/8), the lobe table's variable.
        let u = g.one_minus_cos_gamma().sqrt().sqrt().sqrt();
        let c = &self.c;
        let spec = c.spec_scale * facet(c.kr2, g) * lerp(lobe, c.scale, u) * lerp(log1p, c.scale, m);
        // cos(ti)^c cos(tr)^c = (v^c)^2 at v = sqrt(cos ti cos tr): one lookup, and exactly
        // reciprocal because the product is.
        let root = lerp(power, c.scale, m.sqrt());
        spec + c.diffuse_scale * (root * root)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KHAKI: SixParams<f64> = SixParams::from_array(crate::TABLE1[0].1);

    fn f32_params(p: SixParams<f64>) -> SixParams<f32> {
        SixParams::from_array(p.as_array().map(|v| v as f32))
    }

    #[test]
    fn nodes_are_exact_at_the_nodes_and_refusals_are_typed() {
        let mut bytes = [0u8; 12 * 16];
        fill_six_table(&KHAKI, 16, &mut bytes).unwrap();
        let t = SixTable::new(f32_params(KHAKI), &bytes).unwrap();
        t.verify().unwrap();
        // At normal incidence and view (u = 0, m = 1, mu = 1) every lookup is a node.
        let exact = crate::SixParam::new(f32_params(KHAKI))
            .unwrap()
            .eval_cosines(1.0, 1.0, 1.0);
        let tab = t.eval_cosines(1.0, 1.0, 1.0);
        assert!(((tab - exact) / exact).abs() < 1e-6, "{tab} vs {exact}");
        assert_eq!(t.eval_cosines(0.0, 0.5, 1.0), 0.0);
        assert!(t.eval_cosines(f32::NAN, 0.5, 1.0).is_nan());

        assert_eq!(
            SixTable::new(f32_params(KHAKI), &bytes[..13]).unwrap_err(),
            TableError::Length(13)
        );
        assert_eq!(
            SixTable::new(f32_params(KHAKI), &bytes[..12]).unwrap_err(),
            TableError::Nodes(1)
        );
        let mut bad = bytes;
        bad[4 * 5..4 * 6].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(
            SixTable::new(f32_params(KHAKI), &bad)
                .unwrap()
                .verify()
                .unwrap_err(),
            TableError::Node(5)
        );
        let mut other = KHAKI;
        other.c = 0.5;
        let t2 = SixTable::new(f32_params(other), &bytes).unwrap();
        let back = SixTable::from_parts(t.consts(), &bytes).unwrap();
        assert_eq!(back.eval_cosines(0.3, 0.9, -0.2), t.eval_cosines(0.3, 0.9, -0.2));
        assert!(SixTable::from_parts(t.consts(), &bytes[..12 * 15]).is_none());
        assert!(matches!(t2.verify(), Err(TableError::Mismatch(i)) if i >= 32));
        let mut short = [0u8; 12];
        assert_eq!(
            fill_six_table(&KHAKI, 1, &mut short).unwrap_err(),
            TableError::Nodes(1)
        );
        assert_eq!(
            fill_six_table(&KHAKI, 2, &mut short).unwrap_err(),
            TableError::Length(12)
        );
        let mut neg = KHAKI;
        neg.kd = -1.0;
        assert!(matches!(
            fill_six_table(&neg, 16, &mut bytes),
            Err(TableError::Params(_))
        ));
    }

    #[test]
    fn exactly_reciprocal() {
        let mut bytes = [0u8; 12 * 64];
        fill_six_table(&KHAKI, 64, &mut bytes).unwrap();
        let t = SixTable::new(f32_params(KHAKI), &bytes).unwrap();
        for k in 0..500 {
            let x = k as f32 / 500.0;
            let (ti, tr, phi) = (1.5 * x, 1.4 * (1.0 - x), 6.0 * x * x);
            assert_eq!(t.eval_angles(ti, tr, phi), t.eval_angles(tr, ti, phi));
        }
    }
}
