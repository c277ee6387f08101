//! How far an `f32` evaluation path is from the exact `f64` model: the one comparator every
//! accuracy claim goes through (the exact path, the tables, the batch path, the device's
//! answers), and the direction grid the claims are checked on.
//!
//! An `f32` path is judged at its own `f32` inputs, widened exactly for the `f64` reference,
//! so that the comparison measures the path's arithmetic, not the rounding of its inputs.
//! Relative errors are taken where the reference is above
//! [`crate::tolerance::F32_FLOOR_OF_MAX`] of its largest value over the set:
//! below it the value is a negligible share of the signal, and a relative error there says
//! nothing about what a sensor sees.
//!
//! ```
//! use brdf_core::accuracy::{compare, regular_grid};
//! use brdf_core::{Brdf, SixParam, SixParams};
//!
//! // The f64 reference holds the f32 parameters, widened: only the arithmetic differs.
//! let single = SixParam::new(SixParams { kb: 0.2545_f32, kr: 21.8031, b: -27.5721, a: 0.6705, kd: 0.3676, c: 1.2 })?;
//! let exact = SixParam::new(single.params().widen())?;
//! let cosines = regular_grid(85.0, 10, 7).map(|d| d.map(|x| x.cos() as f32));
//! let acc = compare(
//!     cosines,
//!     |c| single.eval_cosines(c[0], c[1], c[2]),
//!     |c| exact.eval_cosines(c[0].into(), c[1].into(), c[2].into()),
//! );
//! assert!(acc.n > 500 && acc.max < brdf_core::tolerance::F32_MAX_REL);
//! # Ok::<(), brdf_core::ParamError>(())
//! ```

use crate::tolerance::F32_FLOOR_OF_MAX;
use crate::{AnyModel, Brdf, ModelKind, ParamError};

/// How far an evaluation path (`f32` or `f64`) is from the exact model over a set of inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Accuracy<X = [f32; 3]> {
    /// Largest relative error (infinite where the path returned a non-finite value).
    pub max: f64,
    /// RMS relative error.
    pub rms: f64,
    /// Mean relative error.
    pub mean: f64,
    /// The input of the largest relative error.
    pub worst_at: Option<X>,
    /// Inputs judged: those where the reference is above the floor.
    pub n: usize,
    /// Largest absolute error over every input (floor or not).
    pub max_abs: f64,
    /// Mean absolute error over every input.
    pub mean_abs: f64,
    /// Every input.
    pub total: usize,
}

/// Relative error of `path` against `exact` at each of `inputs` (any inputs the two
/// closures agree on: `f32` cosines, angles, or indices into values computed elsewhere),
/// over the inputs where `exact` is above [`F32_FLOOR_OF_MAX`] of its maximum over the set.
/// A non-finite path value counts as an infinite error. Two passes over `inputs` (the
/// reference is evaluated twice), no allocation.
pub fn compare<X, V, I, P, E>(inputs: I, path: P, mut exact: E) -> Accuracy<X>
where
    X: Copy,
    V: Into<f64>,
    I: IntoIterator<Item = X> + Clone,
    P: FnMut(X) -> V,
    E: FnMut(X) -> f64,
{
    let top = inputs.clone().into_iter().map(&mut exact).fold(0.0, f64::max);
    compare_above(inputs, path, exact, F32_FLOOR_OF_MAX * top)
}

/// [`compare`] with the floor given: relative errors where `exact > floor`, absolute errors
/// everywhere. One pass.
pub fn compare_above<X, V, I, P, E>(inputs: I, mut path: P, mut exact: E, floor: f64) -> Accuracy<X>
where
    X: Copy,
    V: Into<f64>,
    I: IntoIterator<Item = X>,
    P: FnMut(X) -> V,
    E: FnMut(X) -> f64,
{
    let mut acc = Accuracy {
        max: 0.0,
        rms: 0.0,
        mean: 0.0,
        worst_at: None,
        n: 0,
        max_abs: 0.0,
        mean_abs: 0.0,
        total: 0,
    };
    for x in inputs {
        let e = exact(x);
        let t: f64 = path(x).into();
        let a = if t.is_finite() {
            (t - e).abs()
        } else {
            f64::INFINITY
        };
        acc.total += 1;
        acc.mean_abs += a;
        acc.max_abs = acc.max_abs.max(a);
        if e > floor {
            let r = a / e;
            acc.rms += r * r;
            acc.mean += r;
            acc.n += 1;
            if r > acc.max || acc.worst_at.is_none() {
                acc.max = acc.max.max(r);
                acc.worst_at = Some(x);
            }
        }
    }
    if acc.n > 0 {
        acc.rms = libm::sqrt(acc.rms / acc.n as f64);
        acc.mean /= acc.n as f64;
    }
    if acc.total > 0 {
        acc.mean_abs /= acc.total as f64;
    }
    acc
}

/// The regular direction grid accuracy claims are checked on: `n_zenith` incidence zeniths
/// times `n_zenith` viewing zeniths, both from 0 to `max_zenith_deg` inclusive, times
/// `n_azimuth` relative azimuths from 0 to π inclusive, as `(theta_i, theta_r, phi)` in
/// radians (`f64`; round them, or their cosines, to the path's inputs). Incidence
/// outermost, azimuth innermost.
pub fn regular_grid(
    max_zenith_deg: f64,
    n_zenith: usize,
    n_azimuth: usize,
) -> impl Iterator<Item = [f64; 3]> + Clone {
    let zmax = max_zenith_deg.to_radians();
    let over = |x: f64, k: usize, n: usize| if n > 1 { x * k as f64 / (n - 1) as f64 } else { 0.0 };
    (0..n_zenith * n_zenith * n_azimuth).map(move |k| {
        let (i, j, l) = (
            k / (n_zenith * n_azimuth),
            k / n_azimuth % n_zenith,
            k % n_azimuth,
        );
        [
            over(zmax, i, n_zenith),
            over(zmax, j, n_zenith),
            over(core::f64::consts::PI, l, n_azimuth),
        ]
    })
}

/// One step of SplitMix64 (Steele, Lea and Flood 2014): advances `state` and returns 64
/// random bits. The generator of the reproducible random directions and parameter sets the
/// accuracy checks draw (`brdf check --seed`, the cross-check tests): the same sequence on
/// every machine, from a seed alone.
pub fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The next [`splitmix64`] draw as a uniform `f64` in `[0, 1)` (its top 53 bits).
pub fn splitmix64_unit(state: &mut u64) -> f64 {
    (splitmix64(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// The grid the f32 claim ([`crate::tolerance::F32_MAX_REL`]) is checked on, as f32 angles
/// `(theta_i, theta_r, phi)`: [`regular_grid`]`(89.9, 46, 37)` and, at each of its 46
/// incidences, 90 directions near retro (`phi` = 0 to 1e-4) and mirror (`phi` = π minus
/// those) with `theta_r` within 1e-4 rad of `theta_i`: 82,432 directions, incidence
/// outermost.
pub fn claim_grid() -> impl Iterator<Item = [f32; 3]> + Clone {
    const N_ZENITH: usize = 46;
    const N_AZIMUTH: usize = 37;
    const DT: [f64; 9] = [0.0, 1e-7, -1e-7, 1e-6, -1e-6, 1e-5, -1e-5, 1e-4, -1e-4];
    const DP: [f64; 5] = [0.0, 1e-7, 1e-6, 1e-5, 1e-4];
    let zmax = 89.9_f64.to_radians();
    (0..N_ZENITH).flat_map(move |i| {
        let ti = zmax * i as f64 / (N_ZENITH - 1) as f64;
        let block = (0..N_ZENITH * N_AZIMUTH).map(move |k| {
            let (j, l) = (k / N_AZIMUTH, k % N_AZIMUTH);
            let tr = zmax * j as f64 / (N_ZENITH - 1) as f64;
            let phi = core::f64::consts::PI * l as f64 / (N_AZIMUTH - 1) as f64;
            [ti as f32, tr as f32, phi as f32]
        });
        let near = (0..DT.len() * DP.len() * 2).map(move |k| {
            let (t, p, mirror) = (k / (DP.len() * 2), k / 2 % DP.len(), k % 2 == 1);
            let tr = (ti + DT[t]).clamp(0.0, zmax);
            let phi = if mirror {
                core::f64::consts::PI - DP[p]
            } else {
                DP[p]
            };
            [ti as f32, tr as f32, phi as f32]
        });
        block.chain(near)
    })
}

/// One f32 evaluation path at a direction of [`claim_grid`] (f32 angles): its f32 value and
/// the f64 model's at exactly the same f32 inputs.
pub type F32Path = fn(&AnyModel<f32>, &AnyModel<f64>, [f32; 3]) -> (f32, f64);

/// From angles: the f32 angles themselves.
pub fn path_angles(m32: &AnyModel<f32>, m64: &AnyModel<f64>, x: [f32; 3]) -> (f32, f64) {
    let [ti, tr, phi] = x;
    (
        m32.eval_angles(ti, tr, phi),
        m64.eval_angles(ti.into(), tr.into(), phi.into()),
    )
}

/// From cosines: the angles' cosines rounded to f32 (what a device receives).
pub fn path_cosines(m32: &AnyModel<f32>, m64: &AnyModel<f64>, x: [f32; 3]) -> (f32, f64) {
    let c = x.map(|a| libm::cos(f64::from(a)) as f32);
    (
        m32.eval_cosines(c[0], c[1], c[2]),
        m64.eval_cosines(c[0].into(), c[1].into(), c[2].into()),
    )
}

/// From vectors: the unit vectors of the angles rounded to f32 (incidence in the x-z plane).
pub fn path_vectors(m32: &AnyModel<f32>, m64: &AnyModel<f64>, x: [f32; 3]) -> (f32, f64) {
    let [ti, tr, phi] = x.map(f64::from);
    let wi = [libm::sin(ti) as f32, 0.0, libm::cos(ti) as f32];
    let wr = [
        (libm::sin(tr) * libm::cos(phi)) as f32,
        (libm::sin(tr) * libm::sin(phi)) as f32,
        libm::cos(tr) as f32,
    ];
    (
        m32.eval_vectors(wi, wr),
        m64.eval_vectors(wi.map(f64::from), wr.map(f64::from)),
    )
}

/// The three f32 paths the claim covers, by name.
pub const F32_PATHS: [(&str, F32Path); 3] = [
    ("angles", path_angles),
    ("cosines", path_cosines),
    ("vectors", path_vectors),
];

/// The exact f32 model of `kind` with `params` (as a device holds them) measured on
/// [`claim_grid`] through `path` (one of [`F32_PATHS`]) against the f64 model of the same f32
/// parameters: what [`crate::tolerance::F32_MAX_REL`] promises for parameters in the paper's
/// range, measured for these. `brdf pack` warns when it exceeds the promise.
pub fn f32_claim_accuracy(kind: ModelKind, params: &[f32], path: F32Path) -> Result<Accuracy, ParamError> {
    let m32 = AnyModel::<f32>::new(kind, params)?;
    let mut wide = [0.0f64; crate::MAX_PARAMS];
    for (w, &p) in wide.iter_mut().zip(params) {
        *w = f64::from(p);
    }
    let m64 = AnyModel::<f64>::new(kind, &wide[..params.len()])?;
    let top = claim_grid().map(|x| path(&m32, &m64, x).1).fold(0.0, f64::max);
    let values = claim_grid().map(|x| {
        let (single, double) = path(&m32, &m64, x);
        (x, single, double)
    });
    let a = compare_above(values, |v| v.1, |v| v.2, F32_FLOOR_OF_MAX * top);
    Ok(Accuracy {
        max: a.max,
        rms: a.rms,
        mean: a.mean,
        worst_at: a.worst_at.map(|v| v.0),
        n: a.n,
        max_abs: a.max_abs,
        mean_abs: a.mean_abs,
        total: a.total,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_is_the_published_sequence() {
        // The reference implementation (Vigna, splitmix64.c) from state 0.
        let mut s = 0u64;
        assert_eq!(splitmix64(&mut s), 0xE220_A839_7B1D_CDAF);
        assert_eq!(splitmix64(&mut s), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(splitmix64(&mut s), 0x06C4_5D18_8009_454F);
        let u = splitmix64_unit(&mut s);
        assert!((0.0..1.0).contains(&u));
    }

    #[test]
    fn a_non_finite_answer_is_an_infinite_error_and_the_floor_applies() {
        let exact = [1.0, 2.0, 1e-9];
        let path = [1.0f32, f32::NAN, 5.0];
        let a = compare(0..3, |k| path[k], |k| exact[k]);
        // The third input is below 1e-6 of the largest reference: not judged.
        assert_eq!((a.n, a.total), (2, 3));
        assert!(a.max.is_infinite());
        assert_eq!(a.worst_at, Some(1));
        let b = compare(0..2, |k| [1.5f64, 2.0][k], |k| exact[k]);
        assert_eq!((b.max, b.mean, b.worst_at), (0.5, 0.25, Some(0)));
    }
}
