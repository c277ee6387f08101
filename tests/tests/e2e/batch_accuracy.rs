//! The batch path (`brdf_core::batch`) against the 50-digit references and the scalar path,
//! at every instruction-set level this CPU runs; reciprocity; invalid input.

use brdf_core::accuracy::compare;
use brdf_core::batch::{Batch, BatchError, Level};
use brdf_core::tolerance::{BATCH_F64_REL, F32_MAX_REL, F64_REFERENCE_REL, SEVEN_DIGIT_REFERENCE_REL};
use brdf_core::{AnyModel, Brdf, DomainError, ModelKind};
use brdf_tests::{dense_grid_f32, rad, random_six, rel_err, SplitMix, FIVE_REFERENCE, SIX_REFERENCE, TABLE1};

/// Structure-of-arrays directions in the three input forms, computed in f64.
struct Dirs {
    angles: [Vec<f64>; 3],
    cosines: [Vec<f64>; 3],
    wi: [Vec<f64>; 3],
    wr: [Vec<f64>; 3],
}

fn dirs(list: &[[f64; 3]]) -> Dirs {
    let col = |f: &dyn Fn(&[f64; 3]) -> f64| list.iter().map(f).collect::<Vec<f64>>();
    Dirs {
        angles: [col(&|a| a[0]), col(&|a| a[1]), col(&|a| a[2])],
        cosines: [col(&|a| a[0].cos()), col(&|a| a[1].cos()), col(&|a| a[2].cos())],
        wi: [col(&|a| a[0].sin()), col(&|_| 0.0), col(&|a| a[0].cos())],
        wr: [
            col(&|a| a[1].sin() * a[2].cos()),
            col(&|a| a[1].sin() * a[2].sin()),
            col(&|a| a[1].cos()),
        ],
    }
}

fn w(v: &[Vec<f64>; 3]) -> [&[f64]; 3] {
    [&v[0][..], &v[1][..], &v[2][..]]
}

fn levels() -> Vec<Level> {
    let v: Vec<Level> = Level::ALL.into_iter().filter(|l| l.is_available()).collect();
    println!("levels on this CPU: {v:?} (detected {:?})", Level::detected());
    v
}

/// Batch values of every input form at `level`, with the scalar values at the same inputs.
fn both(m: &AnyModel<f64>, d: &Dirs, level: Level) -> Vec<(&'static str, Vec<f64>, Vec<f64>)> {
    let b = Batch::new(m).at_level(level).unwrap();
    let n = d.angles[0].len();
    let mut out = Vec::new();
    let mut f = vec![0.0; n];
    b.angles(&d.angles[0], &d.angles[1], &d.angles[2], &mut f)
        .unwrap();
    let s = (0..n)
        .map(|k| m.eval_angles(d.angles[0][k], d.angles[1][k], d.angles[2][k]))
        .collect();
    out.push(("angles", f.clone(), s));
    b.cosines(&d.cosines[0], &d.cosines[1], &d.cosines[2], &mut f)
        .unwrap();
    let s = (0..n)
        .map(|k| m.eval_cosines(d.cosines[0][k], d.cosines[1][k], d.cosines[2][k]))
        .collect();
    out.push(("cosines", f.clone(), s));
    b.vectors(w(&d.wi), w(&d.wr), &mut f).unwrap();
    let s = (0..n)
        .map(|k| {
            m.eval_vectors(
                [d.wi[0][k], d.wi[1][k], d.wi[2][k]],
                [d.wr[0][k], d.wr[1][k], d.wr[2][k]],
            )
        })
        .collect();
    out.push(("vectors", f, s));
    out
}

#[test]
fn f64_batch_reproduces_every_reference_value() {
    let list: Vec<[f64; 3]> = SIX_REFERENCE
        .iter()
        .map(|r| [rad(r.0), rad(r.1), rad(r.2)])
        .collect();
    let d = dirs(&list);
    let mut worst = 0.0_f64;
    for level in levels() {
        for (m, (name, p)) in TABLE1.iter().enumerate() {
            let model = AnyModel::new(ModelKind::Six, p).unwrap();
            for (path, f, _) in both(&model, &d, level) {
                for (k, r) in SIX_REFERENCE.iter().enumerate() {
                    let e = rel_err(f[k], r.3[m]);
                    worst = worst.max(e);
                    assert!(
                        e <= F64_REFERENCE_REL,
                        "{level:?} {name} {path} {r:?}: {} ({e:e})",
                        f[k]
                    );
                }
            }
        }
        let five = AnyModel::new(ModelKind::Five, &TABLE1[0].1[..5]).unwrap();
        let list: Vec<[f64; 3]> = FIVE_REFERENCE
            .iter()
            .map(|r| [rad(r.0), rad(r.1), rad(r.2)])
            .collect();
        for (path, f, _) in both(&five, &dirs(&list), level) {
            for (k, r) in FIVE_REFERENCE.iter().enumerate() {
                let tol = if k == 0 {
                    SEVEN_DIGIT_REFERENCE_REL
                } else {
                    F64_REFERENCE_REL
                };
                assert!(rel_err(f[k], r.3) <= tol, "{level:?} five {path} {r:?}: {}", f[k]);
            }
        }
    }
    println!("f64 batch: worst relative error against MODEL.md references {worst:.2e}");
}

/// The dense grid of the f32 tests (zeniths to 89.9°, 1e-7 to 1e-4 rad from retro and
/// mirror) in f64, plus azimuths over [-2 pi, 4 pi] and a few beyond the vector reduction's
/// range (evaluated through libm lane by lane).
fn hemisphere() -> Vec<[f64; 3]> {
    let mut v: Vec<[f64; 3]> = dense_grid_f32().iter().map(|a| a.map(f64::from)).collect();
    let mut rng = SplitMix(0xba7c_4a11);
    for _ in 0..4000 {
        v.push([
            rng.uniform(0.0, rad(89.9)),
            rng.uniform(0.0, rad(89.9)),
            rng.uniform(-2.0 * std::f64::consts::PI, 4.0 * std::f64::consts::PI),
        ]);
    }
    for phi in [3000.0, -1e6, 1e300, 2049.0 + 1e-9] {
        v.push([0.3, 0.5, phi]);
    }
    // Below the horizon and exactly at it.
    v.push([rad(90.0), 0.3, 1.0]);
    v.push([0.3, 2.0, 1.0]);
    v
}

fn random_params(kind: ModelKind, rng: &mut SplitMix) -> Vec<f64> {
    let six = random_six(rng);
    match kind {
        ModelKind::Six | ModelKind::SixCos2 => six.to_vec(),
        ModelKind::Five => six[..5].to_vec(),
        ModelKind::Minnaert => vec![six[0], rng.uniform(0.05, 1.0)],
        ModelKind::Ggx => vec![
            six[0],
            rng.uniform(0.01_f64.ln(), 0.0).exp(),
            rng.uniform(0.0, 1.0),
            six[4],
        ],
        ModelKind::Lambert => vec![six[0]],
    }
}

#[test]
fn f64_batch_matches_the_scalar_path_everywhere() {
    let d = dirs(&hemisphere());
    let mut rng = SplitMix(0x0b47_c4ed);
    let mut sets: Vec<(ModelKind, Vec<f64>)> =
        TABLE1.iter().map(|(_, p)| (ModelKind::Six, p.to_vec())).collect();
    for kind in ModelKind::ALL {
        for _ in 0..8 {
            sets.push((kind, random_params(kind, &mut rng)));
        }
    }
    for level in levels() {
        let mut worst = 0.0_f64;
        for (kind, p) in &sets {
            let m = AnyModel::new(*kind, p).unwrap();
            for (path, f, s) in both(&m, &d, level) {
                for k in 0..f.len() {
                    if s[k] == 0.0 {
                        assert_eq!(f[k], 0.0, "{level:?} {kind:?} {path} lane {k}");
                        continue;
                    }
                    let e = rel_err(f[k], s[k]);
                    worst = worst.max(e);
                    assert!(
                        e <= BATCH_F64_REL,
                        "{level:?} {kind:?} {p:?} {path} at {:?}: {} vs {} ({e:e})",
                        [d.angles[0][k], d.angles[1][k], d.angles[2][k]],
                        f[k],
                        s[k]
                    );
                }
            }
        }
        println!(
            "f64 batch ({}) against scalar f64, {} directions x 3 inputs x {} parameter sets: max rel {worst:.2e}",
            level.name(),
            d.angles[0].len(),
            sets.len()
        );
    }
}

#[test]
fn f32_batch_within_the_f32_tolerance_of_f64() {
    let grid = dense_grid_f32();
    let n = grid.len();
    let mut rng = SplitMix(0xf32b_a7c4);
    let mut sets: Vec<(ModelKind, Vec<f64>)> =
        TABLE1.iter().map(|(_, p)| (ModelKind::Six, p.to_vec())).collect();
    for kind in ModelKind::ALL {
        for _ in 0..6 {
            sets.push((kind, random_params(kind, &mut rng)));
        }
    }
    let col = |k: usize| grid.iter().map(|a| a[k]).collect::<Vec<f32>>();
    let ang = [col(0), col(1), col(2)];
    let cos: [Vec<f32>; 3] = [0, 1, 2].map(|k| ang[k].iter().map(|&a| f64::from(a).cos() as f32).collect());
    let mut worst = 0.0_f64;
    for level in levels() {
        for (kind, p) in &sets {
            let p32: Vec<f32> = p.iter().map(|&v| v as f32).collect();
            let m32 = AnyModel::<f32>::new(*kind, &p32).unwrap();
            let m64 =
                AnyModel::<f64>::new(*kind, &p32.iter().map(|&v| f64::from(v)).collect::<Vec<_>>()).unwrap();
            let b = Batch::new(&m32).at_level(level).unwrap();
            let mut fa = vec![0.0_f32; n];
            let mut fc = vec![0.0_f32; n];
            b.angles(&ang[0], &ang[1], &ang[2], &mut fa).unwrap();
            b.cosines(&cos[0], &cos[1], &cos[2], &mut fc).unwrap();
            for (name, f, reference) in [
                (
                    "angles",
                    &fa,
                    (0..n)
                        .map(|k| m64.eval_angles(ang[0][k].into(), ang[1][k].into(), ang[2][k].into()))
                        .collect::<Vec<f64>>(),
                ),
                (
                    "cosines",
                    &fc,
                    (0..n)
                        .map(|k| m64.eval_cosines(cos[0][k].into(), cos[1][k].into(), cos[2][k].into()))
                        .collect(),
                ),
            ] {
                let a = compare(0..n, |k| f[k], |k| reference[k]);
                worst = worst.max(a.max);
                assert!(
                    a.max <= F32_MAX_REL,
                    "{level:?} {kind:?} {name} lane {:?}: {:e}",
                    a.worst_at,
                    a.max
                );
            }
        }
    }
    println!("f32 batch against f64 at the same f32 inputs: max rel {worst:.2e}");
}

#[test]
fn batch_reciprocity_is_bit_exact() {
    let mut rng = SplitMix(0x7ec1_9a0c);
    let n = 4000;
    let ti: Vec<f64> = (0..n).map(|_| rng.uniform(0.0, rad(89.9))).collect();
    let tr: Vec<f64> = (0..n).map(|_| rng.uniform(0.0, rad(89.9))).collect();
    let phi: Vec<f64> = (0..n).map(|_| rng.uniform(0.0, std::f64::consts::TAU)).collect();
    let (ci, cr, cp): (Vec<f64>, Vec<f64>, Vec<f64>) = (
        ti.iter().map(|x| x.cos()).collect(),
        tr.iter().map(|x| x.cos()).collect(),
        phi.iter().map(|x| x.cos()).collect(),
    );
    for level in levels() {
        for kind in [
            ModelKind::Six,
            ModelKind::SixCos2,
            ModelKind::Minnaert,
            ModelKind::Lambert,
        ] {
            for _ in 0..4 {
                let m = AnyModel::new(kind, &random_params(kind, &mut rng)).unwrap();
                let b = Batch::new(&m).at_level(level).unwrap();
                let (mut f, mut g) = (vec![0.0; n], vec![0.0; n]);
                b.angles(&ti, &tr, &phi, &mut f).unwrap();
                b.angles(&tr, &ti, &phi, &mut g).unwrap();
                assert!(
                    f.iter().zip(&g).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{level:?} {kind:?} angles"
                );
                b.cosines(&ci, &cr, &cp, &mut f).unwrap();
                b.cosines(&cr, &ci, &cp, &mut g).unwrap();
                assert!(
                    f.iter().zip(&g).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{level:?} {kind:?} cosines"
                );
            }
        }
        // The five-parameter model is not reciprocal; the check can fail.
        let five = AnyModel::new(ModelKind::Five, &TABLE1[0].1[..5]).unwrap();
        let b = Batch::new(&five).at_level(level).unwrap();
        let (mut f, mut g) = ([0.0], [0.0]);
        b.angles(&[rad(10.0)], &[rad(60.0)], &[rad(30.0)], &mut f)
            .unwrap();
        b.angles(&[rad(60.0)], &[rad(10.0)], &[rad(30.0)], &mut g)
            .unwrap();
        assert!(rel_err(f[0], g[0]) > 0.1);
    }
}

#[test]
fn invalid_lanes_are_reported_like_the_scalar_path_and_get_nan() {
    let m = AnyModel::new(ModelKind::Six, &TABLE1[0].1).unwrap();
    let b = Batch::new(&m);
    let n = 700; // spans three chunks
    let ok = vec![0.4_f64; n];
    let cases: [(usize, &str, f64); 5] = [
        (0, "theta_i", f64::NAN),
        (300, "theta_r", -1e-9),
        (699, "theta_i", 3.2),
        (256, "phi", f64::INFINITY),
        (511, "theta_r", f64::NEG_INFINITY),
    ];
    for (bad, what, value) in cases {
        let mut cols = [ok.clone(), ok.clone(), ok.clone()];
        let col = ["theta_i", "theta_r", "phi"]
            .iter()
            .position(|w| *w == what)
            .unwrap();
        cols[col][bad] = value;
        let mut out = vec![7.0; n];
        let err = b.angles(&cols[0], &cols[1], &cols[2], &mut out).unwrap_err();
        let scalar = m
            .try_eval_angles(cols[0][bad], cols[1][bad], cols[2][bad])
            .unwrap_err();
        assert_eq!(
            err,
            BatchError::Domain {
                index: bad,
                error: scalar
            },
            "{what}"
        );
        let good = m.eval_angles(0.4, 0.4, 0.4);
        assert!(
            out[..bad].iter().all(|&v| rel_err(v, good) <= BATCH_F64_REL),
            "{what}"
        );
        assert!(out[bad..].iter().all(|v| v.is_nan()), "{what}");
    }
    // Cosines out of [-1, 1], a vector that is not of unit length, f32 zenith above pi.
    let mut out = [0.0; 2];
    let err = b
        .cosines(&[0.5, 0.5], &[0.5, 1.0 + 1e-12], &[0.0, 0.0], &mut out)
        .unwrap_err();
    assert!(matches!(
        err,
        BatchError::Domain {
            index: 1,
            error: DomainError::OutOfRange {
                what: "cos_theta_r",
                ..
            }
        }
    ));
    let (x, z) = ([0.0, 0.6], [1.0, 0.8001]);
    let err = b
        .vectors(
            [&x, &[0.0, 0.0], &z],
            [&[0.0, 0.0], &[0.0, 0.0], &[1.0, 1.0]],
            &mut out,
        )
        .unwrap_err();
    assert!(matches!(
        err,
        BatchError::Domain {
            index: 1,
            error: DomainError::NotUnitVector { what: "wi", .. }
        }
    ));
    let m32 = AnyModel::<f32>::new(ModelKind::Lambert, &[0.5]).unwrap();
    let mut o32 = [0.0_f32; 2];
    // f32's pi rounds up: the largest accepted zenith is f32::consts::PI itself.
    Batch::new(&m32)
        .angles(&[std::f32::consts::PI, 0.1], &[0.1, 0.1], &[0.0, 0.0], &mut o32)
        .unwrap();
    assert_eq!(o32[0], 0.0);
    // Length mismatches leave the output untouched.
    let mut out = [5.0; 3];
    assert_eq!(
        b.angles(&[0.1; 3], &[0.1; 2], &[0.1; 3], &mut out),
        Err(BatchError::Length {
            what: "theta_r",
            len: 2,
            expected: 3
        })
    );
    assert_eq!(out, [5.0; 3]);
    assert!(b.angles(&[0.1; 3], &[0.1; 3], &[0.1; 3], &mut [0.0; 4]).is_err());
}

#[test]
fn albedo_through_the_batch_path_matches_the_scalar_rule() {
    use brdf_core::checks::{albedo, albedo_batch, AlbedoRule};
    let mut rng = SplitMix(0x00a1_bed0);
    let mut models: Vec<AnyModel<f64>> = TABLE1
        .iter()
        .map(|(_, p)| AnyModel::new(ModelKind::Six, p).unwrap())
        .collect();
    for kind in ModelKind::ALL {
        models.push(AnyModel::new(kind, &random_params(kind, &mut rng)).unwrap());
    }
    let mut worst = 0.0_f64;
    for m in &models {
        for ti in [0.0, 0.3, 1.0, 1.5] {
            let (a, b) = (
                albedo(m, ti, AlbedoRule::DEFAULT),
                albedo_batch(&Batch::new(m), ti, AlbedoRule::DEFAULT),
            );
            let e = rel_err(b, a);
            worst = worst.max(e);
            assert!(e <= BATCH_F64_REL, "{:?} at {ti}: {b} vs {a}", m.kind());
        }
    }
    // A rule with more azimuth nodes than one call takes.
    let m = &models[0];
    let fine = AlbedoRule { panels: 40 };
    assert!(rel_err(albedo_batch(&Batch::new(m), 0.5, fine), albedo(m, 0.5, fine)) <= BATCH_F64_REL);
    println!("albedo, batch against scalar rule: max rel {worst:.2e}");
}

#[test]
fn a_ring_is_bit_for_bit_what_angles_gives() {
    let mut rng = SplitMix(0x0072_1a6e);
    let mut sets: Vec<(ModelKind, Vec<f64>)> =
        TABLE1.iter().map(|(_, p)| (ModelKind::Six, p.to_vec())).collect();
    for kind in ModelKind::ALL {
        for _ in 0..4 {
            sets.push((kind, random_params(kind, &mut rng)));
        }
    }
    // Zenith pairs: retro/mirror (equal), at and beyond the horizon, the ends of [0, pi].
    let mut zeniths: Vec<(f64, f64)> = vec![
        (0.0, 0.0),
        (0.3, 0.3),
        (0.3, 0.3 + 1e-7),
        (rad(89.9), rad(89.9)),
        (rad(90.0), 0.3),
        (0.3, 2.0),
        (std::f64::consts::PI, 0.0),
    ];
    for _ in 0..40 {
        zeniths.push((rng.uniform(0.0, rad(89.9)), rng.uniform(0.0, rad(89.9))));
    }
    // More azimuths than one chunk holds, near retro and mirror, and beyond the vector
    // reduction's range.
    let mut phi: Vec<f64> = (0..600)
        .map(|_| rng.uniform(-2.0 * std::f64::consts::PI, 4.0 * std::f64::consts::PI))
        .collect();
    phi.extend([
        0.0,
        1e-7,
        std::f64::consts::PI,
        std::f64::consts::PI - 1e-7,
        3000.0,
        -1e6,
        1e300,
    ]);
    let n = phi.len();
    let mut checked = 0usize;
    for level in levels() {
        for (kind, p) in &sets {
            let m = AnyModel::<f64>::new(*kind, p).unwrap();
            let b = Batch::new(&m).at_level(level).unwrap();
            let m32 = AnyModel::<f32>::new(*kind, &p.iter().map(|&v| v as f32).collect::<Vec<_>>()).unwrap();
            let b32 = Batch::new(&m32).at_level(level).unwrap();
            // (1e300 is infinite in f32: the largest finite f32 instead.)
            let phi32: Vec<f32> = phi.iter().map(|&v| (v as f32).min(f32::MAX)).collect();
            for &(ti, tr) in &zeniths {
                let (mut ring, mut each) = (vec![0.0; n], vec![0.0; n]);
                b.ring(ti, tr, &phi, &mut ring).unwrap();
                b.angles(&vec![ti; n], &vec![tr; n], &phi, &mut each).unwrap();
                for k in 0..n {
                    assert_eq!(
                        ring[k].to_bits(),
                        each[k].to_bits(),
                        "{level:?} {kind:?} {p:?} at ({ti}, {tr}, {}): {} vs {}",
                        phi[k],
                        ring[k],
                        each[k]
                    );
                }
                let (ti32, tr32) = (ti as f32, tr as f32);
                let (mut ring, mut each) = (vec![0.0f32; n], vec![0.0f32; n]);
                b32.ring(ti32, tr32, &phi32, &mut ring).unwrap();
                b32.angles(&vec![ti32; n], &vec![tr32; n], &phi32, &mut each)
                    .unwrap();
                assert!(ring.iter().zip(&each).all(|(a, b)| a.to_bits() == b.to_bits()));
                checked += 2 * n;
            }
        }
    }
    println!("ring against angles: {checked} values, all bit-identical");

    // Errors: an invalid zenith makes every lane NaN and is reported at index 0; an invalid
    // azimuth as `angles` reports it; a length mismatch leaves `out` alone.
    let b = Batch::new(&AnyModel::<f64>::new(ModelKind::Six, &TABLE1[0].1).unwrap());
    let mut out = [5.0; 3];
    assert_eq!(
        b.ring(f64::NAN, 0.3, &[0.1; 3], &mut out),
        Err(BatchError::Domain {
            index: 0,
            error: DomainError::NotFinite { what: "theta_i" }
        })
    );
    assert!(out.iter().all(|v| v.is_nan()));
    assert!(matches!(
        b.ring(0.3, 4.0, &[0.1; 3], &mut out),
        Err(BatchError::Domain {
            index: 0,
            error: DomainError::OutOfRange { what: "theta_r", .. }
        })
    ));
    let mut out = [5.0; 3];
    assert_eq!(
        b.ring(0.3, 0.4, &[0.1, f64::INFINITY, 0.2], &mut out),
        Err(BatchError::Domain {
            index: 1,
            error: DomainError::NotFinite { what: "phi" }
        })
    );
    assert!(out[0].is_finite() && out[1].is_nan() && out[2].is_nan());
    let mut out = [5.0; 4];
    assert!(matches!(
        b.ring(0.3, 0.4, &[0.1; 3], &mut out),
        Err(BatchError::Length { .. })
    ));
    assert_eq!(out, [5.0; 4]);
    assert_eq!(b.ring(f64::NAN, 0.3, &[], &mut []), Ok(()));
}
