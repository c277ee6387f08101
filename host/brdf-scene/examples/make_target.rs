//! Writes the bundled target mesh, `data/scenes/target.obj`: a cylindrical hull with flat
//! end caps and a fin (`brdf_scene::shapes::target` at `TargetSpec::BUNDLED`).
//!
//!     cargo run --release -p brdf-scene --example make_target [OUT.obj]

use brdf_scene::shapes::{target, TargetSpec};

fn main() -> std::io::Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/scenes/target.obj").to_owned());
    let b = target(TargetSpec::BUNDLED);
    let file = std::fs::File::create(&out)?;
    b.write_obj(
        std::io::BufWriter::new(file),
        "Bundled target: hull (cylinder along x, 4 m long, radius 0.5 m), caps (flat ends), fin.\n\
         Metres; facets counter-clockwise seen from outside.\n\
         Made by `cargo run --release -p brdf-scene --example make_target`; do not edit.",
    )?;
    eprintln!("wrote {out} ({} facets)", b.len());
    Ok(())
}
