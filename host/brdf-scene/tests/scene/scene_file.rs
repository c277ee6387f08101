//! Scene files: the bundled example, material sources (params, fit JSON, blob), STL meshes,
//! and the errors a bad scene or mesh gets (file, line, field).

use std::path::{Path, PathBuf};

use brdf_scene::scene::{Mode, Scene, SceneError, Source};
use brdf_scene::shapes::{target, TargetSpec};

fn bundled() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes")
}

const KHAKI: &str = "kb=0.2545,kr=21.8031,b=-27.5721,a=0.6705,kd=0.3676,c=1.2";

/// A scratch directory holding the bundled mesh and `scene.toml` with `text`.
fn scene_with(text: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(bundled().join("target.obj"), dir.path().join("target.obj")).unwrap();
    let p = dir.path().join("scene.toml");
    std::fs::write(&p, text).unwrap();
    (dir, p)
}

fn err(text: &str) -> String {
    let (_d, p) = scene_with(text);
    Scene::load(&p).unwrap_err().to_string()
}

const SENSOR: &str =
    "[sensor]\nmode = \"monostatic\"\nazimuth_deg = [0, 360, 90]\nelevation_deg = [0, 1, 1]\n";

/// A sweep whose range is narrower than its step has one value, its start (the values near
/// stop are dropped as stop itself; the start once was too, leaving no aspect at all).
#[test]
fn a_sweep_narrower_than_its_step_has_its_start() {
    let (_d, p) = scene_with(
        "mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nmodel = \"lambert\"\nparams = \"rho0=0.3\"\n\
         [sensor]\nmode = \"monostatic\"\nazimuth_deg = [0, 1e-10, 1]\nelevation_deg = [10, 10.5, 7]\n",
    );
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.sensor.azimuth_deg, vec![0.0]);
    assert_eq!(s.sensor.elevation_deg, vec![10.0]);
    assert_eq!(s.aspects().len(), 1);
}

/// A start of 1e17 with a step of 1 repeated one azimuth a hundred times, and a separation of
/// 1e300 lost its phase: azimuths and separations stay within two turns, and values repeat no
/// more.
#[test]
fn sweeps_and_separations_stay_within_two_turns() {
    let head =
        "mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nmodel = \"lambert\"\nparams = \"rho0=0.3\"\n";
    for (sensor, says) in [
        (
            "mode = \"monostatic\"\nazimuth_deg = [1e17, 1.00000000000001e17, 1]",
            "outside [-720, 720]",
        ),
        (
            "mode = \"monostatic\"\nazimuth_deg = [700, 700.000000001, 1e-14]",
            "repeat",
        ),
        (
            "mode = \"bistatic\"\nseparation_deg = 1e300\nazimuth_deg = [0, 10, 5]",
            "not in [-720, 720]",
        ),
    ] {
        let e = err(&format!("{head}[sensor]\n{sensor}\nelevation_deg = [0, 1, 1]\n"));
        assert!(e.contains(says), "{sensor}: {e}");
    }
}

/// A `part = "*"` entry when every part has its own entry colours nothing: refused by line.
#[test]
fn a_star_entry_that_covers_nothing_is_refused() {
    let entry =
        |part: &str| format!("[[material]]\npart = \"{part}\"\nmodel = \"lambert\"\nparams = \"rho0=0.3\"\n");
    let all: String = ["hull", "caps", "fin"].iter().map(|p| entry(p)).collect();
    let e = err(&format!("mesh = \"target.obj\"\n{all}{}{SENSOR}", entry("*")));
    assert!(e.contains("line 15") && e.contains("\"*\" covers no part"), "{e}");
    let two: String = ["hull", "caps"].iter().map(|p| entry(p)).collect();
    let (_d, p) = scene_with(&format!("mesh = \"target.obj\"\n{two}{}{SENSOR}", entry("*")));
    assert!(Scene::load(&p).is_ok(), "\"*\" covering the fin");
}

/// `scene domain` streams groups of aspects; what it writes is exactly the CSV of all queries
/// collected at once, across group boundaries.
#[test]
fn the_streamed_domain_is_the_collected_one() {
    let text = std::fs::read_to_string(bundled().join("target.toml"))
        .unwrap()
        .replace("azimuth_deg = [0, 360, 5]", "azimuth_deg = [0, 360, 1.25]");
    let (_d, p) = scene_with(&text);
    let s = Scene::load(&p).unwrap();
    assert!(s.aspects().len() > 2 * brdf_scene::queries::STREAM_ASPECTS);
    let all = brdf_scene::queries::collect_queries(&s, &|| {});
    let mut once = Vec::new();
    brdf_scene::queries::write_csv(&s, &all, &mut once).unwrap();
    let mut streamed = Vec::new();
    let n = brdf_scene::queries::write_csv_streamed(&s, &mut streamed, &|| {}).unwrap();
    assert_eq!(n, all.len());
    assert!(once == streamed, "the streamed CSV differs");
}

#[test]
fn the_bundled_scene_loads_and_its_mesh_is_what_the_generator_makes() {
    let s = Scene::load(&bundled().join("target.toml")).unwrap();
    assert_eq!(s.mesh.parts, vec!["hull", "caps", "fin"]);
    assert_eq!(s.mesh.facets.len(), TargetSpec::BUNDLED.facets());
    assert_eq!(s.aspects().len(), 72 * 3);
    assert_eq!(s.sensor.mode, Mode::Monostatic);
    assert_eq!(s.sensor.elevation_deg, vec![0.0, 15.0, 30.0]);
    // `cargo run -p brdf-scene --example make_target` regenerates the file exactly.
    let text = std::fs::read_to_string(bundled().join("target.obj")).unwrap();
    let mut made = Vec::new();
    target(TargetSpec::BUNDLED).write_obj(&mut made, "x").unwrap();
    let body = |t: &str| {
        t.lines()
            .filter(|l| !l.starts_with('#'))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(body(&text), body(&String::from_utf8(made).unwrap()));
}

#[test]
fn materials_come_from_params_a_fit_result_or_a_blob() {
    let (dir, p) = scene_with("");
    let fit = r#"[{"model": "lambert", "params": {"rho0": 0.3}}, {"model": "minnaert", "params": {"rho0": 0.3, "k": 0.8}}]"#;
    std::fs::write(dir.path().join("fits.json"), fit).unwrap();
    let mut buf = [0u8; 4096];
    let n = brdf_wire::blob::table1_blob().encode(&mut buf).unwrap();
    std::fs::write(dir.path().join("p.bin"), &buf[..n]).unwrap();
    std::fs::write(
        &p,
        format!(
            "mesh = \"target.obj\"\n[[material]]\npart = \"hull\"\nmodel = \"six\"\nparams = \"{KHAKI}\"\n\
             [[material]]\npart = \"fin\"\nfit = \"fits.json\"\nindex = 1\n\
             [[material]]\npart = \"*\"\nblob = \"p.bin\"\nindex = 2\n{SENSOR}"
        ),
    )
    .unwrap();
    let s = Scene::load(&p).unwrap();
    assert_eq!(s.materials[0].source, Source::Params);
    assert_eq!(s.materials[1].model.kind().name(), "minnaert");
    assert_eq!(
        s.materials[1].source,
        Source::Fit(dir.path().join("fits.json"), 1)
    );
    assert_eq!(s.materials[2].model.to_params()[0], f64::from(49.3261f32));
    // The caps take the `*` entry.
    let caps = s.mesh.parts.iter().position(|p| p == "caps").unwrap() as u32;
    let k = s.mesh.facets.iter().position(|f| f.part == caps).unwrap();
    assert_eq!(s.facet_material[k], 2);
    // Index errors name the file and the line.
    std::fs::write(
        &p,
        format!("mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nblob = \"p.bin\"\nindex = 5\n{SENSOR}"),
    )
    .unwrap();
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("line 4") && e.contains("holds 3 materials; there is no index 5"),
        "{e}"
    );
    std::fs::write(
        &p,
        format!("mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nfit = \"fits.json\"\n{SENSOR}"),
    )
    .unwrap();
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(e.contains("line 4") && e.contains("holds 2 fits"), "{e}");
}

#[test]
fn bad_scenes_are_refused_with_file_line_and_field() {
    let head =
        format!("mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nmodel = \"six\"\nparams = \"{KHAKI}\"\n");
    // A part no material covers: named with the mesh file and the facet's line.
    let e = err(&format!(
        "mesh = \"target.obj\"\n[[material]]\npart = \"hull\"\nmodel = \"lambert\"\nparams = \"rho0=0.3\"\n\
         [[material]]\npart = \"fin\"\nmodel = \"lambert\"\nparams = \"rho0=0.3\"\n{SENSOR}"
    ));
    assert!(
        e.contains("target.obj") && e.contains("part `caps`") && e.contains("line "),
        "{e}"
    );
    let e = err(&format!(
        "{head}[[material]]\npart = \"keel\"\nmodel = \"lambert\"\nparams = \"rho0=0.3\"\n{SENSOR}"
    ));
    assert!(e.contains("scene.toml: line 7: part: no part `keel`"), "{e}");
    let e = err(&format!(
        "mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nmodel = \"six\"\nparams = \"kb=1\"\n{SENSOR}"
    ));
    assert!(e.contains("line 5: params: missing parameter kr"), "{e}");
    let e = err(&format!("mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nmodel = \"lambert\"\nparams = \"rho0=-1\"\n{SENSOR}"));
    assert!(e.contains("line 5: params: invalid parameters"), "{e}");
    let e = err(&format!(
        "mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nmodel = \"sixx\"\nparams = \"rho0=1\"\n{SENSOR}"
    ));
    assert!(e.contains("line 4: model: unknown model `sixx`"), "{e}");
    let e = err(&format!(
        "{head}[sensor]\nmode = \"bistatic\"\nazimuth_deg = [0, 360, 5]\nelevation_deg = [0, 1, 1]\n"
    ));
    assert!(e.contains("separation_deg: missing"), "{e}");
    let e = err(&format!(
        "{head}[sensor]\nmode = \"monostatic\"\nazimuth_deg = [0, 360, 0]\nelevation_deg = [0, 1, 1]\n"
    ));
    assert!(e.contains("line 8: azimuth_deg: step 0 must be positive"), "{e}");
    let e = err(&format!(
        "{head}[sensor]\nmode = \"monostatic\"\nazimuth_deg = [0, 360, 5]\nelevation_deg = [60, 121, 30]\n"
    ));
    assert!(
        e.contains("line 9: elevation_deg: 120 is outside [-90, 90]"),
        "{e}"
    );
    let e = err(&format!(
        "{head}[sensor]\nmode = \"sideways\"\nazimuth_deg = [0, 360, 5]\nelevation_deg = [0, 1, 1]\n"
    ));
    assert!(e.contains("line 7: mode: `sideways`"), "{e}");
    let e = err(&format!("{head}colour = 3\n{SENSOR}"));
    assert!(e.contains("scene.toml") && e.contains("colour"), "{e}");
    let e = err(&format!(
        "mesh = \"nothere.obj\"\n{}{SENSOR}",
        &head[head.find('[').unwrap()..]
    ));
    assert!(e.contains("nothere.obj") && e.contains("cannot read"), "{e}");
}

fn ascii_stl(facets: &[[[f32; 3]; 3]]) -> String {
    let mut s = String::from("solid t\n");
    for f in facets {
        s += "facet normal 0 0 0\nouter loop\n";
        for v in f {
            s += &format!("vertex {} {} {}\n", v[0], v[1], v[2]);
        }
        s += "endloop\nendfacet\n";
    }
    s + "endsolid t\n"
}

fn load_stl(
    dir: &Path,
    facets: &[[[f32; 3]; 3]],
) -> Result<brdf_scene::mesh::Mesh, brdf_scene::mesh::MeshError> {
    let p = dir.join("shape.stl");
    std::fs::write(&p, ascii_stl(facets)).unwrap();
    brdf_scene::mesh::Mesh::load(&p)
}

#[test]
fn stl_meshes_are_one_part_named_after_the_file_and_checked_alike() {
    let dir = tempfile::tempdir().unwrap();
    let (o, x, y, z) = (
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    );
    let tetra = [[o, y, x], [o, x, z], [x, y, z], [o, z, y]];
    let m = load_stl(dir.path(), &tetra).unwrap();
    assert_eq!(m.parts, vec!["shape"]);
    assert_eq!(m.facets.len(), 4);
    assert_eq!(m.vertices.len(), 4, "shared corners are welded");
    let mut flipped = tetra;
    flipped[2] = [x, z, y];
    let e = load_stl(dir.path(), &flipped).unwrap_err().to_string();
    assert!(
        e.contains("shape.stl") && e.contains("facet 3") && e.contains("inconsistent winding"),
        "{e}"
    );
    let e = load_stl(dir.path(), &[[o, x, [2.0, 0.0, 0.0]]])
        .unwrap_err()
        .to_string();
    assert!(e.contains("facet 1") && e.contains("degenerate"), "{e}");
}

#[test]
fn a_scene_error_is_a_scene_error() {
    let e = Scene::load(Path::new("/nonexistent/scene.toml")).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }));
}

/// A spectral fit's bands at `[sensor] wavelength_um`: the band there, or the two around it
/// blended linearly; never extrapolated, never silently one band.
#[test]
fn spectral_materials_are_taken_at_the_sensors_wavelength() {
    // Lambertian bands 0.2 at 0.5 µm, 0.6 at 0.7 µm (and a second measurement), out of order.
    let fits = r#"[
        {"dataset": "p.csv[wavelength=0.7]", "model": "lambert", "params": {"rho0": 0.6}},
        {"dataset": "p.csv[wavelength=0.5]", "model": "lambert", "params": {"rho0": 0.2}},
        {"dataset": "q.csv[wavelength=0.5]", "model": "lambert", "params": {"rho0": 0.9}}
    ]"#;
    let scene = |wavelength: &str, index: &str| {
        let (dir, p) = scene_with(&format!(
            "mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nfit = \"fits.json\"\n{index}\
             [sensor]\nmode = \"monostatic\"\n{wavelength}azimuth_deg = [0, 360, 90]\nelevation_deg = [0, 31, 30]\n"
        ));
        std::fs::write(dir.path().join("fits.json"), fits).unwrap();
        (dir, Scene::load(&p))
    };
    let sigma = |s: &Scene| -> Vec<f64> {
        brdf_scene::lrcs::lrcs(s, &|| {})
            .aspects
            .iter()
            .map(|a| a.lrcs)
            .collect()
    };
    let (_d, at_05) = scene("wavelength_um = 0.5\n", "index = 0\n");
    let at_05 = at_05.unwrap();
    assert_eq!(at_05.materials[0].model.to_params()[0], 0.2);
    assert!(at_05.materials[0].upper.is_none());
    // 0.65 µm: three quarters of the way to 0.7, so rho = 0.5, and sigma is linear in rho.
    let (_d, at_065) = scene("wavelength_um = 0.65\n", "index = 1\n");
    let at_065 = at_065.unwrap();
    let m = &at_065.materials[0];
    let upper = m.upper.as_ref().unwrap();
    assert_eq!(
        (m.model.to_params()[0], upper.model.to_params()[0], upper.index),
        (0.2, 0.6, 0)
    );
    assert!((upper.weight - 0.75).abs() < 1e-12, "{}", upper.weight);
    assert!(
        at_065.material_description(0).contains("x 0.25")
            && at_065.material_description(0).contains("x 0.75")
    );
    // What the sweep's JSON says was used: the band (with its fit), or the blend.
    let band = |s: &Scene| {
        let result = brdf_scene::lrcs::lrcs(s, &|| {});
        brdf_scene::lrcs::LrcsReport::new("s".into(), s, &result).materials[0]
            .band
            .clone()
    };
    assert_eq!(band(&at_05).as_deref(), Some("lambert (fit 1)"));
    assert_eq!(
        band(&at_065).as_deref(),
        Some("lambert (fit 1) x 0.25 + lambert (fit 0) x 0.75")
    );
    for (a, b) in sigma(&at_065).iter().zip(sigma(&at_05)) {
        assert!((a / b - 2.5).abs() < 1e-12, "{a} {b}");
    }
    // Refused: outside the bands (naming the line of wavelength_um), no wavelength for a
    // banded fit, two measurements without index, a wavelength that is none.
    let (_d, e) = scene("wavelength_um = 0.45\n", "index = 0\n");
    let e = e.unwrap_err().to_string();
    assert!(
        e.contains("line 8: wavelength_um") && e.contains("span 0.5–0.7 µm"),
        "{e}"
    );
    let (_d, e) = scene("", "index = 1\n");
    assert_eq!(
        e.unwrap().materials[0].model.to_params()[0],
        0.2,
        "index alone picks one fit"
    );
    let (_d, e) = scene("wavelength_um = 0.6\n", "");
    let e = e.unwrap_err().to_string();
    assert!(e.contains("line 4: fit") && e.contains("2 measurements"), "{e}");
    for bad in ["0", "-0.5", "nan", "inf"] {
        let (_d, e) = scene(&format!("wavelength_um = {bad}\n"), "index = 0\n");
        let e = e.unwrap_err().to_string();
        assert!(
            e.contains("wavelength_um") && e.contains("not a wavelength"),
            "{bad}: {e}"
        );
    }
    // A list: sigma at each wavelength from one sweep, the first also as `lrcs`; each
    // wavelength's bands stated; a list entry outside the bands, repeated, or empty refused.
    let (_d, list) = scene("wavelength_um = [0.5, 0.65, 0.7]\n", "index = 0\n");
    let list = list.unwrap();
    assert_eq!(list.wavelength_um, Some(0.5));
    assert_eq!(list.spectrum.len(), 3);
    let result = brdf_scene::lrcs::lrcs(&list, &|| {});
    for ((a, b05), b065) in result.aspects.iter().zip(sigma(&at_05)).zip(sigma(&at_065)) {
        assert_eq!(a.by_wavelength.len(), 3);
        assert_eq!((a.lrcs, a.by_wavelength[0]), (b05, b05));
        assert!((a.by_wavelength[1] - b065).abs() <= 1e-15 * b065, "{a:?} {b065}");
        // rho 0.6 at 0.7 µm: three times 0.2's sigma.
        assert!((a.by_wavelength[2] / b05 - 3.0).abs() < 1e-12, "{a:?}");
    }
    let report = brdf_scene::lrcs::LrcsReport::new("s".into(), &list, &result);
    assert_eq!(report.wavelengths_um.as_deref(), Some(&[0.5, 0.65, 0.7][..]));
    let bands = report.materials[0].bands_by_wavelength.clone().unwrap();
    assert_eq!(bands[0].as_deref(), Some("lambert (fit 1)"));
    assert_eq!(bands[2].as_deref(), Some("lambert (fit 0)"));
    assert!(list
        .one_wavelength("x")
        .unwrap_err()
        .contains("lists 3 wavelengths; x works at one"));
    assert!(at_05.one_wavelength("x").is_ok());
    for (bad, says) in [
        ("[0.5, 0.8]", "span 0.5–0.7 µm"),
        ("[0.5, 0.6, 0.5]", "0.5 and 0.5 µm are one wavelength"),
        ("[]", "0 wavelengths"),
        ("[0.5, -1]", "-1 is not a wavelength"),
    ] {
        let (_d, e) = scene(&format!("wavelength_um = {bad}\n"), "index = 0\n");
        let e = e.unwrap_err().to_string();
        assert!(
            e.contains("line 8: wavelength_um") && e.contains(says),
            "{bad}: {e}"
        );
    }
    // The same bands packed as one banded blob material: taken at the wavelength as the fit
    // file's (their parameters rounded to f32), refused without one or outside the bands.
    let mut extra = vec![0u8; 4096];
    let lambert =
        |rho: f64| brdf_wire::blob::Material::from_params(brdf_core::ModelKind::Lambert, &[rho]).unwrap();
    let (m, len) =
        brdf_wire::blob::Material::banded(&[(0.5, lambert(0.2)), (0.7, lambert(0.6))], &mut extra).unwrap();
    let mut blob = brdf_wire::blob::table1_blob();
    blob.materials.truncate(0);
    blob.materials.push(m).unwrap();
    let mut bytes = vec![0u8; 4096];
    let n = blob
        .encode_with_tables(&[Some(&extra[..len])], &mut bytes)
        .unwrap();
    let from_blob = |wavelength: &str| {
        let (dir, p) = scene_with(&format!(
            "mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nblob = \"b.bin\"\n[sensor]\n\
             mode = \"monostatic\"\n{wavelength}azimuth_deg = [0, 360, 90]\nelevation_deg = [0, 31, 30]\n"
        ));
        std::fs::write(dir.path().join("b.bin"), &bytes[..n]).unwrap();
        (dir, Scene::load(&p))
    };
    let (_d, b065) = from_blob("wavelength_um = 0.65\n");
    let b065 = b065.unwrap();
    // (The device's centres are f32: 0.65 lies a quarter of the way up to within 5e-8.)
    assert_eq!(
        b065.band_used(0).as_deref(),
        Some("lambert (band 0) x 0.249999955 + lambert (band 1) x 0.750000045 of blob material 0")
    );
    for (a, b) in sigma(&b065).iter().zip(sigma(&at_065)) {
        assert!((a / b - 1.0).abs() < 1e-6, "{a} {b}");
    }
    // At a band's centre the band is named (it was "a band of blob material 0").
    let (_d, b07) = from_blob("wavelength_um = 0.7\n");
    assert_eq!(
        b07.unwrap().band_used(0).as_deref(),
        Some("lambert (band 1 of blob material 0)")
    );
    let (_d, e) = from_blob("");
    let e = e.unwrap_err().to_string();
    assert!(
        e.contains("material 0 is spectral (2 bands at 0.5–0.7 µm)"),
        "{e}"
    );
    let (_d, e) = from_blob("wavelength_um = 0.8\n");
    let e = e.unwrap_err().to_string();
    assert!(
        e.contains("line 7: wavelength_um") && e.contains("outside the bands of material 0"),
        "{e}"
    );
    // The second measurement has one band: only its own wavelength.
    let (_d, e) = scene("wavelength_um = 0.6\n", "index = 2\n");
    assert!(e.unwrap_err().to_string().contains("only band is 0.5 µm"));
    // Without an index or a wavelength, a single measurement's bands are refused by name.
    let (dir, p) = scene_with(&format!(
        "mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nfit = \"fits.json\"\n{SENSOR}"
    ));
    std::fs::write(
        dir.path().join("fits.json"),
        fits.replace("q.csv", "p.csv").replace(
            "0.5]\", \"model\": \"lambert\", \"params\": {\"rho0\": 0.9",
            "0.6]\", \"model\": \"lambert\", \"params\": {\"rho0\": 0.9",
        ),
    )
    .unwrap();
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("holds 3 bands of p.csv (0.5–0.7 µm): give [sensor] wavelength_um"),
        "{e}"
    );
}

/// `mesh = ""` was reported as ": unknown mesh format", naming no file.
#[test]
fn an_empty_mesh_path_is_refused_by_line() {
    let e = err(&format!(
        "mesh = \"\"\n[[material]]\npart = \"*\"\nmodel = \"lambert\"\nparams = \"rho0=0.3\"\n{SENSOR}"
    ));
    assert!(e.contains("line 1: mesh: empty"), "{e}");
}

/// A sweep stopped part way (the Python package's Ctrl-C) ends within the aspects in flight
/// and returns nothing; it used to run to the end in the background.
#[test]
fn a_stopped_sweep_ends_early_and_returns_nothing() {
    use brdf_scene::lrcs::{lrcs, lrcs_until};
    use std::sync::atomic::{AtomicUsize, Ordering};
    let s = Scene::load(&bundled().join("target.toml")).unwrap();
    let whole = lrcs(&s, &|| {});
    let stop = brdf_fit::Stop::new();
    let same = lrcs_until(&s, &|| {}, &stop).expect("not stopped");
    let sigma = |l: &brdf_scene::lrcs::Lrcs| l.aspects.iter().map(|a| a.lrcs).collect::<Vec<_>>();
    assert_eq!(sigma(&same), sigma(&whole));
    let done = AtomicUsize::new(0);
    let stopped = lrcs_until(
        &s,
        &|| {
            if done.fetch_add(1, Ordering::SeqCst) == 5 {
                stop.request();
            }
        },
        &stop,
    );
    assert!(stopped.is_none());
    let n = done.load(Ordering::SeqCst);
    assert!(
        n < 6 + 2 * rayon::current_num_threads(),
        "{n} of {} aspects traced after the stop",
        whole.aspects.len()
    );
}

/// A sweep by area counts each facet's samples instead of drawing pixels: per aspect its σ,
/// each material's share, its bound and the facets seen are the laser image's, to rounding,
/// on the bundled target monostatic and bistatic (three materials, shadows).
#[test]
fn a_sweep_by_area_sums_what_the_images_show() {
    use brdf_scene::image::{image, ImageOptions};
    use brdf_scene::lrcs::lrcs_by_area;
    let options = ImageOptions {
        pixels: 80,
        supersample: 3,
    };
    for mode in [
        "mode = \"monostatic\"",
        "mode = \"bistatic\"\nseparation_deg = 40",
    ] {
        let text = std::fs::read_to_string(bundled().join("target.toml"))
            .unwrap()
            .replace("mode = \"monostatic\"", mode)
            .replace("azimuth_deg = [0, 360, 5]", "azimuth_deg = [0, 360, 40]");
        let (_d, p) = scene_with(&text);
        let s = Scene::load(&p).unwrap();
        assert_eq!(s.aspects().len(), 27);
        assert_eq!(
            matches!(s.sensor.mode, Mode::Bistatic { .. }),
            mode.contains("bistatic")
        );
        let sweep = lrcs_by_area(&s, &options, &|| {}, &brdf_fit::Stop::new())
            .unwrap()
            .unwrap();
        assert_eq!(sweep.aspects.len(), s.aspects().len());
        for (got, a) in sweep.aspects.iter().zip(s.aspects()) {
            let img = image(&s, &a, &options).unwrap();
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * y.abs().max(1e-300);
            assert!(img.lrcs() > 0.0, "{mode} {a:?}");
            assert!(
                close(got.lrcs, img.lrcs()),
                "{mode} {a:?}: {} against {}",
                got.lrcs,
                img.lrcs()
            );
            for (x, y) in got.by_material.iter().zip(&img.by_material) {
                assert!(close(*x, *y), "{mode} {a:?}: {x} against {y}");
            }
            let bound = got.sampling_bound.unwrap();
            assert!(
                close(bound, img.sigma_bound()),
                "{mode} {a:?}: bound {bound} against {}",
                img.sigma_bound()
            );
            assert_eq!(got.facets_seen, img.facets_seen, "{mode} {a:?}");
        }
    }
}
