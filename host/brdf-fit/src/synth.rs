//! Synthetic datasets from known parameters, for demonstrations and tests.
//!
//! Noise is multiplicative and log-normal: `y = f exp(sigma z)`, `z ~ N(0, 1)`, so a
//! "2%" noise level is `sigma = 0.02` and every value stays positive.

use brdf_core::{AnyModel, Brdf, ModelKind, ParamError};
use rand_core::SeedableRng;
use rand_pcg::Pcg64Mcg;

use crate::anneal::normal;
use crate::data::{Dataset, Point};

/// Signed viewing angles `-limit..=limit` degrees in steps of `step` (`limit` the largest
/// multiple of `step` below 90).
pub fn theta_s_grid(step: f64) -> Vec<f64> {
    let n = ((90.0 - 1e-9) / step).floor() as i64;
    let n = if (n as f64) * step >= 90.0 { n - 1 } else { n };
    (-n..=n).map(|k| k as f64 * step).collect()
}

/// The point at (degrees) `ti`, `tr`, `phi` with the model value times the noise factor.
fn noisy_point(
    model: &AnyModel<f64>,
    (ti, tr, phi): (f64, f64, f64),
    noise: f64,
    rng: &mut Pcg64Mcg,
    line: u64,
) -> Point {
    let (ti, tr, phi) = (ti.to_radians(), tr.to_radians(), phi.to_radians());
    let f = model.eval_angles(ti, tr, phi);
    let brdf = if noise > 0.0 {
        f * (noise * normal(rng)).exp()
    } else {
        f
    };
    Point {
        theta_i: ti,
        theta_r: tr,
        phi,
        brdf,
        sigma: None,
        weight: None,
        line,
    }
}

/// In-plane data: for each incidence (degrees), viewing angles on [`theta_s_grid`]`(step)`,
/// forward side `phi = 180°`, back side `phi = 0°`.
pub fn in_plane(
    kind: ModelKind,
    params: &[f64],
    theta_i: &[f64],
    step: f64,
    noise: f64,
    seed: u64,
) -> Result<Dataset, ParamError> {
    let model = AnyModel::<f64>::new(kind, params)?;
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut points = Vec::new();
    for &ti in theta_i {
        for ts in theta_s_grid(step) {
            let (tr, phi) = if ts > 0.0 { (ts, 180.0) } else { (-ts, 0.0) };
            let line = points.len() as u64 + 2;
            points.push(noisy_point(&model, (ti, tr, phi), noise, &mut rng, line));
        }
    }
    Ok(Dataset {
        name: format!("synthetic {}", kind.name()),
        points,
    })
}

/// Full-hemisphere data: for each incidence, `theta_r` on `0..90` in steps of `step` and
/// `phi` on `0..=180` in steps of `phi_step` (degrees).
pub fn hemisphere(
    kind: ModelKind,
    params: &[f64],
    theta_i: &[f64],
    step: f64,
    phi_step: f64,
    noise: f64,
    seed: u64,
) -> Result<Dataset, ParamError> {
    let model = AnyModel::<f64>::new(kind, params)?;
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut points = Vec::new();
    let n_r = ((90.0 - 1e-9) / step).floor() as i64;
    let n_p = (180.0 / phi_step).floor() as i64;
    for &ti in theta_i {
        for r in 0..=n_r {
            let tr = r as f64 * step;
            if tr >= 90.0 {
                continue;
            }
            for p in 0..=n_p {
                let phi = p as f64 * phi_step;
                let line = points.len() as u64 + 2;
                points.push(noisy_point(&model, (ti, tr, phi), noise, &mut rng, line));
            }
        }
    }
    Ok(Dataset {
        name: format!("synthetic {}", kind.name()),
        points,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_symmetric_and_below_90() {
        let g = theta_s_grid(5.0);
        assert_eq!(g.first(), Some(&-85.0));
        assert_eq!(g.last(), Some(&85.0));
        assert_eq!(g.len(), 35);
        assert_eq!(theta_s_grid(2.5).len(), 71);
        assert_eq!(*theta_s_grid(30.0).last().unwrap(), 60.0);
    }

    #[test]
    fn noise_is_reproducible_and_of_the_stated_size() {
        let p = brdf_core::TABLE1[0].1; // khaki
        let a = in_plane(ModelKind::Six, &p, &[0.0, 30.0], 1.0, 0.02, 7).unwrap();
        let b = in_plane(ModelKind::Six, &p, &[0.0, 30.0], 1.0, 0.02, 7).unwrap();
        assert_eq!(a, b);
        let clean = in_plane(ModelKind::Six, &p, &[0.0, 30.0], 1.0, 0.0, 7).unwrap();
        let logs: Vec<f64> = a
            .points
            .iter()
            .zip(&clean.points)
            .map(|(n, c)| (n.brdf / c.brdf).ln())
            .collect();
        let sd = (logs.iter().map(|x| x * x).sum::<f64>() / logs.len() as f64).sqrt();
        assert!((sd - 0.02).abs() < 0.003, "{sd}");
    }
}
