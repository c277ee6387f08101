//! Time to build and check meshes whose facet sizes are spread (the coplanar-overlap check's
//! grid in levels, `mesh::coincidence_grid`): a 327,680-facet sphere beside one facet 1e9 m
//! away and above a 2 km ground plate; a flat ground of 720,000 facets with 691,200 facets of
//! building walls standing on it; a tube of 80,000 full-length slivers beside small facets;
//! a 1,310,720-facet sphere alone; 4,000 stacked copies of a box (refused); and, read from an
//! OBJ written to six decimals, an 81,920-facet sphere at survey coordinates (5e6 m out).
//! Prints each time; asserts nothing about time.
//!
//!     cargo run --release -p brdf-scene --example mesh_check_speed

use std::time::Instant;

use brdf_scene::shapes::MeshBuilder;

fn time(label: &str, b: &MeshBuilder) {
    let t = Instant::now();
    let result = b.build(label);
    let seconds = t.elapsed().as_secs_f64();
    let verdict = match &result {
        Ok(m) => format!("accepted, {} facets", m.facets.len()),
        Err(e) => format!("refused: {e}"),
    };
    println!(
        "{label}: {seconds:.2} s, {}",
        verdict.chars().take(140).collect::<String>()
    );
}

fn main() {
    // A small sphere beside one facet 1e9 m away (its in-plane tolerance 1e4 m).
    let mut b = MeshBuilder::new();
    b.icosphere(1.0, 7, "ball");
    let far = b.part("far");
    let v = [[1e9, 0.0, 0.0], [1e9, 1.0, 0.0], [1e9, 0.0, 1.0]].map(|p| b.vertex(p));
    b.triangle(v, far);
    time("sphere (level 7) beside a facet 1e9 m away", &b);

    // The same sphere above a 2 km ground plate of two facets.
    let mut b = MeshBuilder::new();
    b.icosphere(1.0, 7, "ball");
    b.plate(
        [-1000.0, -1000.0, -2.0],
        [2000.0, 0.0, 0.0],
        [0.0, 2000.0, 0.0],
        (1, 1),
        "ground",
    );
    time("sphere (level 7) above a 2 km ground plate", &b);

    // A city: a flat ground of 1 m squares, and 600 open boxes of walls (10 m x 10 m, 12 m
    // high, each wall in 12 x 12 cells) standing 5 cm above it.
    let mut b = MeshBuilder::new();
    b.plate(
        [-300.0, -300.0, 0.0],
        [600.0, 0.0, 0.0],
        [0.0, 600.0, 0.0],
        (600, 600),
        "ground",
    );
    for k in 0..600 {
        let (x, y) = (-290.0 + 24.0 * (k % 24) as f64, -290.0 + 23.0 * (k / 24) as f64);
        let corners = [[x, y], [x + 10.0, y], [x + 10.0, y + 10.0], [x, y + 10.0]];
        for w in 0..4 {
            let (p, q) = (corners[w], corners[(w + 1) % 4]);
            b.plate(
                [p[0], p[1], 0.05],
                [q[0] - p[0], q[1] - p[1], 0.0],
                [0.0, 0.0, 12.0],
                (12, 12),
                "walls",
            );
        }
    }
    time("a flat ground and building walls", &b);

    // A tube of 80,000 full-length slivers (10 m long, 0.5 m radius) beside 99,856 small
    // facets: the slivers sit in a few large cells of a level of their own.
    let mut b = MeshBuilder::new();
    let tube = b.part("tube");
    let k = 80_000;
    let rim = |i: usize| {
        let a = std::f64::consts::TAU * i as f64 / k as f64;
        (0.5 * a.cos(), 0.5 * a.sin())
    };
    for i in 0..k {
        let ((y0, z0), (y1, z1)) = (rim(i), rim(i + 1));
        let v = [[-5.0, y0, z0], [5.0, y1, z1], [5.0, y0, z0]].map(|p| b.vertex(p));
        b.triangle(v, tube);
    }
    b.plate(
        [0.0, 0.0, 10.0],
        [3.16, 0.0, 0.0],
        [0.0, 3.16, 0.0],
        (158, 316),
        "small",
    );
    time("a tube of slivers beside small facets", &b);

    let mut b = MeshBuilder::new();
    b.icosphere(1.0, 8, "ball");
    time("sphere (level 8) alone", &b);

    let mut b = MeshBuilder::new();
    for k in 0..4000 {
        b.cuboid([0.0; 3], [1.0; 3], [1, 1, 1], &format!("box{k}"));
    }
    time("4,000 stacked copies of a box", &b);

    // A sphere of 2 m radius 5e6 m out, written to six decimals as a survey export would be,
    // then read and checked (the in-plane tolerance comes from the digits: about 1e-5 m).
    let mut b = MeshBuilder::new();
    b.icosphere(2.0, 6, "ball");
    let mut text = Vec::new();
    b.write_obj(&mut text, "").expect("writing to memory");
    let offset = [5e6 + 0.123457, 4.2e6 + 0.654321, 3.3e6 + 0.271828];
    let text: String = String::from_utf8(text)
        .expect("OBJ text")
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(c) => {
                let c: Vec<f64> = c.split(' ').map(|x| x.parse().expect("a coordinate")).collect();
                format!(
                    "v {:.6} {:.6} {:.6}\n",
                    c[0] + offset[0],
                    c[1] + offset[1],
                    c[2] + offset[2]
                )
            }
            None => format!("{l}\n"),
        })
        .collect();
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("survey.obj");
    std::fs::write(&path, text).expect("writing the OBJ");
    let t = Instant::now();
    let result = brdf_scene::mesh::Mesh::load(&path);
    let seconds = t.elapsed().as_secs_f64();
    println!(
        "sphere (level 6) 5e6 m out, read from six decimals: {seconds:.2} s, {}",
        match result {
            Ok(m) => format!(
                "accepted, {} facets, tolerance from {:?}",
                m.facets.len(),
                m.precision
            ),
            Err(e) => format!("refused: {e}"),
        }
    );
}
