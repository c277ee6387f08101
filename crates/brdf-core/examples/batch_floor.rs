//! Where the batch path's time goes, per instruction-set level: the six-parameter model and
//! Lambert (whose model costs nothing) from angles and from unit vectors, the six-parameter
//! model by rings (`Batch::ring`, as the albedo quadrature calls it), and the vectorised
//! `exp` alone, on a 10^6-direction grid (ns per direction, best of 7, one core).
//!
//!     cargo run --release -p brdf-core --features std --example batch_floor
//!
//! Lambert from vectors is the geometry, input checks and copies; Lambert from angles minus
//! that is the five `sin`/`cos`; six-parameter minus Lambert (from vectors) is the model's
//! powers, lobe and `ln_1p`.

use std::time::Instant;

use brdf_core::batch::{exp_in_place, Batch, Level};
use brdf_core::{AnyModel, ModelKind};

fn best(mut f: impl FnMut()) -> f64 {
    let mut b = f64::INFINITY;
    for _ in 0..7 {
        let t = Instant::now();
        f();
        b = b.min(t.elapsed().as_secs_f64());
    }
    b * 1e9 / 1e6
}

fn v(w: &[Vec<f64>; 3]) -> [&[f64]; 3] {
    [&w[0][..], &w[1][..], &w[2][..]]
}

fn main() {
    let n = 100usize;
    let axis = |k: usize, span: f64| ((k as f64 + 0.5) / n as f64 * span).to_radians();
    let mut a: [Vec<f64>; 3] = Default::default();
    for i in 0..n {
        for r in 0..n {
            for p in 0..n {
                a[0].push(axis(i, 85.0));
                a[1].push(axis(r, 85.0));
                a[2].push(axis(p, 360.0));
            }
        }
    }
    let wi = [
        a[0].iter().map(|t| t.sin()).collect(),
        vec![0.0; a[0].len()],
        a[0].iter().map(|t| t.cos()).collect(),
    ];
    let wr: [Vec<f64>; 3] = [
        a[1].iter().zip(&a[2]).map(|(t, p)| t.sin() * p.cos()).collect(),
        a[1].iter().zip(&a[2]).map(|(t, p)| t.sin() * p.sin()).collect(),
        a[1].iter().map(|t| t.cos()).collect(),
    ];
    let six = AnyModel::<f64>::new(ModelKind::Six, &brdf_core::TABLE1[0].1).unwrap();
    let lambert = AnyModel::<f64>::new(ModelKind::Lambert, &[0.5]).unwrap();
    let mut out = vec![0.0; a[0].len()];
    let mut x = vec![0.0; a[0].len()];
    for level in Level::ALL.into_iter().filter(|l| l.is_available()) {
        let b6 = Batch::new(&six).at_level(level).unwrap();
        let bl = Batch::new(&lambert).at_level(level).unwrap();
        let six_angles = best(|| b6.angles(&a[0], &a[1], &a[2], &mut out).unwrap());
        let six_vectors = best(|| b6.vectors(v(&wi), v(&wr), &mut out).unwrap());
        // The same grid as rings: one call per (theta_i, theta_r) pair over its n azimuths.
        let six_rings = best(|| {
            for (k, o) in out.chunks_mut(n).enumerate() {
                b6.ring(a[0][k * n], a[1][k * n], &a[2][k * n..(k + 1) * n], o)
                    .unwrap();
            }
        });
        let lambert_angles = best(|| bl.angles(&a[0], &a[1], &a[2], &mut out).unwrap());
        let lambert_vectors = best(|| bl.vectors(v(&wi), v(&wr), &mut out).unwrap());
        let refill = |x: &mut [f64]| {
            x.iter_mut()
                .enumerate()
                .for_each(|(k, v)| *v = -(k as f64) * 1e-4)
        };
        let with_exp = best(|| {
            refill(&mut x);
            exp_in_place(&mut x, level);
        });
        let fill = best(|| refill(&mut x));
        println!(
            "{:8} six: angles {six_angles:6.2}, rings {six_rings:6.2}, vectors {six_vectors:6.2} | lambert: angles {lambert_angles:6.2}, vectors {lambert_vectors:6.2} | \
             geometry+checks {lambert_vectors:.2}, sin/cos {:.2}, model {:.2}, one exp {:.2} ns",
            level.name(),
            lambert_angles - lambert_vectors,
            six_vectors - lambert_vectors,
            with_exp - fill
        );
    }
}
