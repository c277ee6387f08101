//! Cross-validation folds that keep equal directions together: every held-out error in the
//! toolkit (`brdf select`'s folds, a fitted table's smoothness search, the held-out studies)
//! holds out *directions*, not rows. A file with replicate readings, or with the same
//! direction written twice (incidence and viewing swapped, the azimuth mirrored: one
//! direction to an isotropic, reciprocal BRDF), would otherwise put copies of a held-out
//! reading in the training folds, and a table that interpolates the copies would score a
//! held-out error it does not have (60 directions read 5 times each: 0.47% claimed, 13% on
//! fresh directions).

use std::collections::HashMap;

use crate::data::Point;
use crate::fitted_table::coordinates;

/// Directions closer than this (radians, in each Rusinkiewicz coordinate) are the same
/// direction: far above the rounding of degrees converted to radians (~1e-16), far below any
/// instrument's step.
pub const SAME_DIRECTION_RAD: f64 = 1e-9;

/// The direction of `p` as an isotropic, reciprocal BRDF sees it: Rusinkiewicz `theta_h`,
/// `theta_d` and folded `phi_d` in units of [`SAME_DIRECTION_RAD`], `phi_d` taken as 0 where
/// it is undefined (`theta_h = 0` or `theta_d = 0`).
pub fn direction_key(p: &Point) -> [i64; 3] {
    let [th, td, pd] = coordinates(p.theta_i, p.theta_r, p.phi);
    let q = |x: f64| (x / SAME_DIRECTION_RAD).round() as i64;
    let (kh, kd) = (q(th), q(td));
    [kh, kd, if kh == 0 || kd == 0 { 0 } else { q(pd) }]
}

/// For every point, the index of the first point with its direction ([`direction_key`]).
pub fn first_of_direction(points: &[Point]) -> Vec<usize> {
    let mut first: HashMap<[i64; 3], usize> = HashMap::with_capacity(points.len());
    points
        .iter()
        .enumerate()
        .map(|(i, p)| *first.entry(direction_key(p)).or_insert(i))
        .collect()
}

/// The fold (`0..k`) of every point: the directions, in a fixed pseudo-random order (a hash of
/// `seed` and the direction's first row), each dealt with all its readings to the fold with
/// the fewest points so far (ties: the lowest fold). With no direction repeated this is the
/// order dealt round-robin, so folds differ in size by at most one.
///
/// # Panics
/// If `k` is 0.
pub fn grouped_folds(points: &[Point], k: usize, seed: u64) -> Vec<usize> {
    assert!(k > 0, "at least one fold");
    let first = first_of_direction(points);
    let mut members: HashMap<usize, Vec<usize>> = HashMap::new();
    for (i, &f) in first.iter().enumerate() {
        members.entry(f).or_default().push(i);
    }
    let mut groups: Vec<usize> = members.keys().copied().collect();
    groups.sort_by_key(|&g| (brdf_core::accuracy::splitmix64(&mut (g as u64 ^ seed)), g));
    let mut size = vec![0usize; k];
    let mut fold = vec![0; points.len()];
    for g in groups {
        let f = (0..k).min_by_key(|&f| (size[f], f)).expect("k > 0");
        for &i in &members[&g] {
            fold[i] = f;
        }
        size[f] += members[&g].len();
    }
    fold
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(ti: f64, tr: f64, phi: f64) -> Point {
        Point {
            theta_i: ti.to_radians(),
            theta_r: tr.to_radians(),
            phi: phi.to_radians(),
            brdf: 0.1,
            sigma: None,
            weight: None,
            line: 0,
        }
    }

    #[test]
    fn equal_directions_share_a_fold_and_distinct_ones_are_dealt_evenly() {
        let mut pts = Vec::new();
        for k in 0..40 {
            let (ti, tr, phi) = (f64::from(k), 70.0 - f64::from(k), 10.0 + 7.0 * f64::from(k));
            pts.push(point(ti, tr, phi));
            pts.push(point(tr, ti, phi)); // swapped: the same direction
            pts.push(point(ti, tr, 360.0 - phi)); // mirrored azimuth: the same direction
        }
        let fold = grouped_folds(&pts, 5, 7);
        for c in pts.chunks(3).zip(fold.chunks(3)) {
            assert!(c.1.iter().all(|&f| f == c.1[0]), "copies split: {:?}", c.1);
        }
        let mut size = [0; 5];
        for &f in &fold {
            size[f] += 1;
        }
        assert!(size.iter().all(|&s| s == 24), "{size:?}");
        // Distinct directions: dealt round-robin in the hashed order.
        let distinct: Vec<Point> = (0..23)
            .map(|k| point(f64::from(k), 40.0, 3.0 * f64::from(k)))
            .collect();
        let fold = grouped_folds(&distinct, 5, 7);
        let mut order: Vec<usize> = (0..23).collect();
        order.sort_by_key(|&i| brdf_core::accuracy::splitmix64(&mut (i as u64 ^ 7)));
        for (rank, &i) in order.iter().enumerate() {
            assert_eq!(fold[i], rank % 5);
        }
    }

    #[test]
    fn phi_d_does_not_separate_mirror_or_retro_directions() {
        // At the mirror direction phi_d is undefined: any azimuth label is the same direction.
        let a = point(30.0, 30.0, 180.0);
        let b = point(30.0, 30.0, 180.0 + 1e-12);
        assert_eq!(direction_key(&a), direction_key(&b));
        assert_ne!(direction_key(&a), direction_key(&point(30.0, 31.0, 180.0)));
    }
}
