//! Time of σ over a sweep for a 100,000-facet target (the bundled hull, caps and fin, finer),
//! 72 x 3 aspects, monostatic and bistatic, on one core and on all cores; prints figures,
//! asserts nothing about time.
//!
//!     cargo run --release -p brdf-scene --example lrcs_speed [FACETS]
//!
//! Accuracy of what is timed: σ equals a brute-force reference (every ray against every
//! facet) to 1e-12 and a Lambertian sphere's closed form within the mesh bound
//! (`tests/analytic.rs`); one core and all cores give the same bits (checked here).

use std::time::Instant;

use brdf_core::{AnyModel, ModelKind, TABLE1};
use brdf_scene::eval::Evaluator;
use brdf_scene::lrcs::lrcs;
use brdf_scene::queries::collect_queries;
use brdf_scene::scene::{Mode, Scene, SceneMaterial, Sensor};
use brdf_scene::shapes::{target, TargetSpec};

/// CPU time of this process (user + system), s, from /proc/self/stat (Linux; clock ticks of
/// 1/100 s); None elsewhere.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn main() {
    let facets: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(100_000);
    let t = Instant::now();
    let mesh = target(TargetSpec::with_facets(facets))
        .build("target")
        .expect("a valid mesh");
    let n = mesh.facets.len();
    let build_mesh = t.elapsed().as_secs_f64();
    let six = |p: [f64; 6]| AnyModel::new(ModelKind::Six, &p).expect("Table 1 parameters");
    let materials = vec![
        SceneMaterial::new("hull", six(TABLE1[0].1)),
        SceneMaterial::new("caps", six(TABLE1[1].1)),
        SceneMaterial::new("fin", six(TABLE1[2].1)),
    ];
    let cores = rayon::current_num_threads();
    println!(
        "target: {n} facets (mesh built and checked in {build_mesh:.2} s); 72 x 3 aspects; {cores} cores"
    );
    println!(
        "{:<11} {:>6} {:>12} {:>9} {:>9} {:>10} {:>9} {:>11} {:>10}",
        "mode", "cores", "BVH build s", "sigma s", "CPU s", "queries", "rays", "CPU ns/ray", "eval share"
    );
    for mode in [Mode::Monostatic, Mode::Bistatic { separation_deg: 30.0 }] {
        let sensor = Sensor {
            mode,
            azimuth_deg: (0..72).map(|k| 5.0 * k as f64).collect(),
            elevation_deg: vec![0.0, 15.0, 30.0],
        };
        let mut first: Option<Vec<f64>> = None;
        for threads in [1, cores] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool");
            let (scene, build) = pool.install(|| {
                let t = Instant::now();
                let s = Scene::new("target".into(), mesh.clone(), materials.clone(), sensor.clone())
                    .expect("every part has a material");
                (s, t.elapsed().as_secs_f64())
            });
            let cpu0 = cpu_seconds();
            let r = pool.install(|| lrcs(&scene, &|| {}));
            let cpu = cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
            let sig: Vec<f64> = r.aspects.iter().map(|a| a.lrcs).collect();
            match &first {
                None => first = Some(sig),
                Some(f) => assert_eq!(f, &sig, "one core and all cores must agree bit for bit"),
            }
            // Split: the queries (geometry and rays) against the BRDF evaluation of them.
            let d = pool.install(|| collect_queries(&scene, &|| {}));
            let models: Vec<Evaluator> = scene.materials.iter().map(|m| m.evaluator()).collect();
            let t = Instant::now();
            let mut scratch = Vec::new();
            let mut total = 0.0;
            for per in &d.batches {
                for (b, m) in per.iter().zip(&models) {
                    total += b.sigma(m, &mut scratch);
                }
            }
            let eval_one_core = t.elapsed().as_secs_f64();
            std::hint::black_box(total);
            let facing: usize = scene
                .aspects()
                .iter()
                .map(|a| {
                    let (s, v) = (a.source(mode), a.receiver());
                    scene
                        .mesh
                        .facets
                        .iter()
                        .filter(|f| {
                            let d =
                                |x: [f64; 3]| f.normal[0] * x[0] + f.normal[1] * x[1] + f.normal[2] * x[2];
                            d(s) > 0.0 && d(v) > 0.0
                        })
                        .count()
                })
                .sum();
            let rays = if mode == Mode::Monostatic {
                facing
            } else {
                2 * facing
            };
            println!(
                "{:<11} {:>6} {:>12.3} {:>9.2} {:>9} {:>10} {:>9} {:>11} {:>9.1}%",
                if mode == Mode::Monostatic {
                    "monostatic"
                } else {
                    "bistatic"
                },
                threads,
                build,
                r.seconds,
                cpu.map_or("-".into(), |c| format!("{c:.2}")),
                d.len(),
                rays,
                cpu.map_or("-".into(), |c| format!("{:.0}", c * 1e9 / rays as f64)),
                100.0 * eval_one_core / cpu.unwrap_or(r.seconds * threads as f64)
            );
        }
    }
    println!(
        "sigma s: wall time of the sweep; CPU s: the process's CPU time meanwhile (on a loaded machine \
         wall time exceeds CPU time / cores); rays: at most one per facet facing both directions (bistatic: \
         two); CPU ns/ray includes the BRDF evaluation; eval share: the BRDF evaluation's part of the \
         CPU time (evaluation timed alone on one core)"
    );
}
