//! σ by area (`--visibility area`, each aspect's laser image summed) for a Lambertian
//! icosphere of 20 x 4^LEVEL facets (level 8: 1,310,720) over 72 x 3 aspects, against the
//! closed form (8/3) pi rho r^2; prints the mesh's build time, the sweep's wall time and the
//! worst relative error and sampling bound. Asserts nothing about time. With `OUT.obj`, also
//! writes the sphere there (level 8: a 70 MB OBJ), for timing `brdf scene lrcs` on it.
//!
//!     cargo run --release -p brdf-scene --example area_speed [LEVEL] [PIXELS] [SUPERSAMPLE] [OUT.obj]

use std::f64::consts::PI;
use std::time::Instant;

use brdf_core::{AnyModel, ModelKind};
use brdf_scene::image::ImageOptions;
use brdf_scene::lrcs::lrcs_by_area;
use brdf_scene::scene::{Mode, Scene, SceneMaterial, Sensor};
use brdf_scene::shapes::MeshBuilder;

fn main() {
    let arg = |k: usize, default: usize| {
        std::env::args()
            .nth(k)
            .and_then(|a| a.parse().ok())
            .unwrap_or(default)
    };
    let (level, pixels, supersample) = (
        arg(1, 8) as u32,
        arg(2, brdf_scene::image::SWEEP_PIXELS),
        arg(3, brdf_scene::image::SUPERSAMPLE),
    );
    let (r, rho) = (1.0, 0.4);
    let t = Instant::now();
    let mut b = MeshBuilder::new();
    b.icosphere(r, level, "ball");
    let mesh = b.build("icosphere").expect("a valid mesh");
    let n = mesh.facets.len();
    let build = t.elapsed().as_secs_f64();
    if let Some(out) = std::env::args().nth(4) {
        let file = std::fs::File::create(&out).expect("OUT.obj can be written");
        b.write_obj(
            std::io::BufWriter::new(file),
            &format!("icosphere of radius {r} m, level {level}"),
        )
        .expect("OUT.obj written");
    }
    let sensor = Sensor {
        mode: Mode::Monostatic,
        azimuth_deg: (0..72).map(|k| 5.0 * k as f64).collect(),
        elevation_deg: vec![0.0, 15.0, 30.0],
    };
    let lambert = AnyModel::new(ModelKind::Lambert, &[rho]).expect("rho in range");
    let t = Instant::now();
    let scene = Scene::new(
        "sphere".into(),
        mesh,
        vec![SceneMaterial::new("*", lambert)],
        sensor,
    )
    .expect("one material covers the sphere");
    let prepare = t.elapsed().as_secs_f64();
    let options = ImageOptions { pixels, supersample };
    let t = Instant::now();
    let result = lrcs_by_area(&scene, &options, &|| {}, &brdf_fit::Stop::new())
        .expect("image sizes in range")
        .expect("not stopped");
    let sweep = t.elapsed().as_secs_f64();
    let exact = 8.0 / 3.0 * PI * rho * r * r;
    let worst = result
        .aspects
        .iter()
        .map(|a| ((a.lrcs - exact) / exact).abs())
        .fold(0.0, f64::max);
    let bound = result
        .aspects
        .iter()
        .filter_map(|a| a.sampling_bound)
        .fold(0.0, f64::max)
        / exact;
    println!(
        "icosphere level {level}: {n} facets, built and checked in {build:.2} s, scene {prepare:.2} s; \
         {} aspects by area at {pixels} pixels x {supersample}^2 samples on {} cores in {sweep:.2} s; \
         worst |sigma / (8/3 pi rho r^2) - 1| {worst:.2e}, sampling bound up to {bound:.2e}",
        result.aspects.len(),
        rayon::current_num_threads()
    );
}
