//! `brdf scene lrcs`, `brdf scene domain`, `brdf select --scene` and `brdf check
//! --directions` on the bundled scene, end to end.

use std::path::PathBuf;

use brdf_core::tolerance::F64_REFORMULATION_REL;
use brdf_core::{AnyModel, Brdf, ModelKind};

use crate::brdf;

fn scene() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/scenes/target.toml")
        .display()
        .to_string()
}

fn ok(out: &std::process::Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout.clone()).unwrap()
}

/// The bundled scene's materials (hull, caps, fin): Table 1 khaki, yellow, white.
fn models() -> [AnyModel<f64>; 3] {
    brdf_core::TABLE1.map(|(_, p)| AnyModel::new(ModelKind::Six, &p).unwrap())
}

#[test]
fn lrcs_is_the_weighted_sum_of_the_domain_rows_and_draws_its_plot() {
    let dir = tempfile::tempdir().unwrap();
    let plot = dir.path().join("lrcs.svg");
    let csv = ok(&brdf(&[
        "scene",
        "lrcs",
        &scene(),
        "--plot",
        plot.to_str().unwrap(),
    ]));
    let rows: Vec<(f64, f64, f64)> = csv
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[0], v[1], v[2])
        })
        .collect();
    assert_eq!(csv.lines().next(), Some("azimuth,elevation,lrcs"));
    assert_eq!(rows.len(), 72 * 3);
    assert_eq!((rows[1].0, rows[1].1), (5.0, 0.0), "sweep order: azimuth fastest");
    assert!(rows.iter().all(|r| r.2 > 0.0));
    assert!(std::fs::read_to_string(&plot).unwrap().contains("<svg"));

    // sigma at each aspect = sum over its domain rows of weight * f(theta_i, theta_r, phi).
    let queries = dir.path().join("q.csv");
    ok(&brdf(&[
        "scene",
        "domain",
        &scene(),
        "-o",
        queries.to_str().unwrap(),
    ]));
    let text = std::fs::read_to_string(&queries).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("azimuth,elevation,material,part,facet,theta_i,theta_r,phi,weight")
    );
    let m = models();
    let mut sums = vec![0.0; rows.len()];
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        let (az, el): (f64, f64) = (f[0].parse().unwrap(), f[1].parse().unwrap());
        let k = (el / 15.0) as usize * 72 + (az / 5.0) as usize;
        let mat: usize = f[2].parse().unwrap();
        let [ti, tr, phi, w] = [5, 6, 7, 8].map(|i| f[i].parse::<f64>().unwrap());
        assert_eq!(phi, 0.0, "monostatic: every query is in the retro direction");
        sums[k] += w * m[mat].eval_angles(ti.to_radians(), tr.to_radians(), phi.to_radians());
    }
    for (r, s) in rows.iter().zip(&sums) {
        let rel = (r.2 - s).abs() / r.2;
        assert!(
            rel <= F64_REFORMULATION_REL,
            "({}, {}): {} against {s}",
            r.0,
            r.1,
            r.2
        );
    }

    let json: serde_json::Value =
        serde_json::from_str(&ok(&brdf(&["scene", "lrcs", &scene(), "--json"]))).unwrap();
    assert_eq!(json["aspects"].as_array().unwrap().len(), 216);
    assert_eq!(json["aspects"][0]["lrcs"].as_f64(), Some(rows[0].2));
}

#[test]
fn select_scene_picks_within_budget_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let blob = dir.path().join("scene.bin");
    let text = ok(&brdf(&[
        "select",
        "--scene",
        &scene(),
        "--budget",
        "1%",
        "-o",
        blob.to_str().unwrap(),
    ]));
    println!("{text}");
    assert_eq!(text.matches("  chosen: ").count(), 3, "one choice per material");
    for name in [
        "lambert fitted",
        "minnaert fitted",
        "six exact",
        "six table 64",
        "six table 256",
    ] {
        let rows = text
            .lines()
            .filter(|l| l.starts_with(&format!("  {name} ")))
            .count();
        assert_eq!(rows, 3, "{name} is a candidate for every material");
    }
    let bytes = std::fs::read(&blob).unwrap();
    let b = brdf_wire::blob::Blob::decode(&bytes).unwrap();
    assert_eq!(b.materials.len(), 3);

    let json: serde_json::Value = serde_json::from_str(&ok(&brdf(&[
        "select",
        "--scene",
        &scene(),
        "--budget",
        "1%",
        "--json",
    ])))
    .unwrap();
    for m in json["materials"].as_array().unwrap() {
        let cands = m["candidates"].as_array().unwrap();
        let chosen = m["chosen"].as_u64().unwrap() as usize;
        let err = |c: &serde_json::Value| c["worst_sigma_error"].as_f64().unwrap();
        assert!(err(&cands[chosen]) <= 0.01);
        // Nothing cheaper was within the budget and fitted a slot.
        let cost = |c: &serde_json::Value| c["device_instructions"].as_u64().unwrap();
        for c in cands {
            if cost(c) < cost(&cands[chosen]) {
                assert!(err(c) > 0.01 || !c["fits_blob"].as_bool().unwrap(), "{c}");
            }
        }
    }
    assert!(json["scene_worst_sigma_error"].as_f64().unwrap() <= 0.01);

    // A budget of 0 is refused (the f32 path cannot equal the f64 model); one nothing meets
    // writes nothing and says so.
    let zero = brdf(&["select", "--scene", &scene(), "--budget", "0"]);
    assert!(!zero.status.success());
    assert!(
        String::from_utf8_lossy(&zero.stderr).contains("budget 0 is not a finite fraction greater than 0")
    );
    let none = brdf(&[
        "select",
        "--scene",
        &scene(),
        "--budget",
        "1e-12",
        "-o",
        blob.to_str().unwrap(),
    ]);
    assert!(!none.status.success());
    assert!(String::from_utf8_lossy(&none.stderr).contains("nothing written"));
}

#[test]
fn check_runs_the_device_on_exactly_the_scenes_directions() {
    let dir = tempfile::tempdir().unwrap();
    // Directions files are checked row by row.
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "theta_i,theta_r,phi\n10,95,0\n").unwrap();
    let out = brdf(&["check", "--qemu", "--directions", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    if brdf_tests::qemu::firmware().is_none() {
        return;
    }
    assert!(
        err.contains("bad.csv: line 2: column theta_r: zenith 95"),
        "{err}"
    );
    let queries = dir.path().join("q.csv");
    let blob = dir.path().join("scene.bin");
    ok(&brdf(&[
        "scene",
        "domain",
        &scene(),
        "-o",
        queries.to_str().unwrap(),
    ]));
    ok(&brdf(&[
        "select",
        "--scene",
        &scene(),
        "--budget",
        "1%",
        "-o",
        blob.to_str().unwrap(),
    ]));
    let text = ok(&brdf(&[
        "check",
        "--qemu",
        "--blob",
        blob.to_str().unwrap(),
        "--directions",
        queries.to_str().unwrap(),
    ]));
    println!("{text}");
    let judged: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("scene directions ["))
        .collect();
    assert_eq!(judged.len(), 3, "one judged region per material");
    assert!(judged.iter().all(|l| l.ends_with("ok")));
}

#[test]
fn select_scene_refuses_what_it_cannot_apply_and_honours_allow_nonphysical() {
    // Options about reading or weighing data, and angular limits, do not apply to a scene's
    // queries: refused before any work, naming the flag.
    let path = scene();
    for extra in [
        &["--max-theta", "40"][..],
        &["--max-theta-i", "40"],
        &["--residual", "log"],
        &["--loss", "huber"],
        &["--brightening"],
        &["--channel", "g"],
    ] {
        let mut args = vec!["select", "--scene", path.as_str()];
        args.extend_from_slice(extra);
        let out = brdf(&args);
        assert!(!out.status.success(), "{extra:?} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(extra[0]), "{extra:?}: {err}");
    }
    let json: serde_json::Value = serde_json::from_str(&ok(&brdf(&[
        "select",
        "--scene",
        &scene(),
        "--allow-nonphysical",
        "--json",
    ])))
    .unwrap();
    assert_eq!(json["allow_nonphysical"], true);
}

/// A chart format `brdf` cannot write is refused before any work: with a scene that does not
/// even exist the error is the chart's (it once came only after the whole sweep).
#[test]
fn lrcs_refuses_an_unknown_chart_format_before_the_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let out = brdf(&[
        "scene",
        "lrcs",
        dir.path().join("missing.toml").to_str().unwrap(),
        "--plot",
        dir.path().join("p.jpg").to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(e.contains("p.jpg: unknown plot format (use .svg or .png)"), "{e}");
    assert!(!e.contains("missing.toml"), "{e}");
}

/// A sheet seen only from behind at every aspect (an open shell wound inside out looks the
/// same) gives σ = +0 everywhere and says why, instead of printing zeros without a word.
#[test]
fn lrcs_that_sees_no_facet_at_any_aspect_says_so() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let scene = |el: &str| {
        let p = dir.path().join(format!("s{el}.toml"));
        std::fs::write(
            &p,
            format!(
                "mesh = \"t.obj\"\n[[material]]\npart = \"*\"\nmodel = \"lambert\"\nparams = \"rho0=0.3\"\n\
                 [sensor]\nmode = \"monostatic\"\nazimuth_deg = [0, 360, 90]\nelevation_deg = [{el}, 90, 200]\n"
            ),
        )
        .unwrap();
        brdf(&["scene", "lrcs", p.to_str().unwrap()])
    };
    let below = scene("-60");
    let csv = ok(&below);
    assert!(csv.lines().skip(1).all(|l| l.ends_with(",0")), "{csv}");
    let e = String::from_utf8_lossy(&below.stderr);
    assert!(e.contains("no facet faces the sensor at any aspect"), "{e}");
    let above = scene("60");
    ok(&above);
    assert!(!String::from_utf8_lossy(&above.stderr).contains("no facet faces"));
    // A plate facing the sensor, hidden under a wider one turned away: seen nowhere, but
    // not wound inside out, and the warning says which.
    std::fs::write(
        dir.path().join("t.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv -10 -10 1\nv 30 -10 1\nv -10 30 1\nf 1 2 3\nf 4 6 5\n",
    )
    .unwrap();
    let hidden = scene("80");
    let csv = ok(&hidden);
    assert!(csv.lines().skip(1).all(|l| l.ends_with(",0")), "{csv}");
    let e = String::from_utf8_lossy(&hidden.stderr);
    assert!(
        e.contains("hide each one's centroid") && !e.contains("inside out"),
        "{e}"
    );
}

/// The bundled target's hull painted with the 31 bands of Garnet Red (one `brdf fit` of the
/// spectral file), seen at one wavelength and at a list: one σ column per wavelength, the
/// column between two bands the mean of theirs, the JSON naming each wavelength's bands, and
/// `brdf select --scene` refusing the list.
#[test]
fn a_scene_takes_a_spectral_fit_at_one_wavelength_or_a_list() {
    let dir = tempfile::tempdir().unwrap();
    let data = brdf_tests::measured("cornell-spectral/garnet_red.astm");
    let fits = dir.path().join("garnet.json");
    std::fs::write(
        &fits,
        ok(&brdf(&[
            "fit",
            "--format",
            "cornell",
            data.to_str().unwrap(),
            "--json",
        ])),
    )
    .unwrap();
    let target = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes/target.obj");
    std::fs::copy(&target, dir.path().join("target.obj")).unwrap();
    let write = |name: &str, wavelength: &str| {
        let toml = format!(
            "mesh = \"target.obj\"\n[[material]]\npart = \"*\"\nfit = \"garnet.json\"\n[sensor]\n\
             mode = \"monostatic\"\nwavelength_um = {wavelength}\nazimuth_deg = [0, 360, 30]\n\
             elevation_deg = [0, 31, 30]\n"
        );
        let p = dir.path().join(name);
        std::fs::write(&p, toml).unwrap();
        p.to_str().unwrap().to_owned()
    };
    let one = write("one.toml", "0.55");
    let list = write("list.toml", "[0.55, 0.555, 0.56]");
    let column = |csv: &str, k: usize| -> Vec<f64> {
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
            .collect()
    };
    let at_055 = ok(&brdf(&["scene", "lrcs", &one]));
    assert!(at_055.starts_with("azimuth,elevation,lrcs\n"), "{at_055}");
    let spectral = ok(&brdf(&["scene", "lrcs", &list]));
    assert!(
        spectral.starts_with("azimuth,elevation,lrcs_0.55um,lrcs_0.555um,lrcs_0.56um\n"),
        "{spectral}"
    );
    assert_eq!(column(&spectral, 2), column(&at_055, 2));
    let (a, mid, b) = (column(&spectral, 2), column(&spectral, 3), column(&spectral, 4));
    assert_eq!(a.len(), 24);
    for k in 0..a.len() {
        assert!(
            (mid[k] - 0.5 * (a[k] + b[k])).abs() <= 1e-12 * a[k].max(b[k]),
            "{k}"
        );
    }
    assert!(a.iter().zip(&b).any(|(x, y)| x != y), "two bands that differ");
    let json: serde_json::Value =
        serde_json::from_str(&ok(&brdf(&["scene", "lrcs", &list, "--json"]))).unwrap();
    assert_eq!(json["wavelengths_um"], serde_json::json!([0.55, 0.555, 0.56]));
    let bands = json["materials"][0]["bands_by_wavelength"].as_array().unwrap();
    assert_eq!(bands.len(), 3);
    assert!(bands[1].as_str().unwrap().contains(" x 0.5 + "), "{bands:?}");
    assert_eq!(json["aspects"][0]["by_wavelength"].as_array().unwrap().len(), 3);
    let refused = brdf(&["select", "--scene", &list]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && err.contains("lists 3 wavelengths"),
        "{err}"
    );
    // What works at one wavelength refuses the list by name (it took the first, unsaid).
    let png = dir.path().join("i.png");
    for args in [
        vec!["scene", "profile", &list, "--bin-m", "0.1"],
        vec!["scene", "image", &list, "-o", png.to_str().unwrap()],
        vec!["scene", "lrcs", &list, "--visibility", "area"],
    ] {
        let o = brdf(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains("lists 3 wavelengths"),
            "{args:?}: {err}"
        );
    }
}

/// `brdf scene profile`: each aspect's bins sum to its σ of `brdf scene lrcs`, with and
/// without a pulse; bin widths that are no length, or too fine for the target, are refused
/// before the sweep.
#[test]
fn profile_bins_sum_to_each_aspects_sigma() {
    let lrcs = ok(&brdf(&["scene", "lrcs", &scene()]));
    let sigma: Vec<(String, f64)> = lrcs
        .lines()
        .skip(1)
        .map(|l| {
            let (key, v) = l.rsplit_once(',').unwrap();
            (key.to_owned(), v.parse().unwrap())
        })
        .collect();
    for extra in [&[][..], &["--pulse-m", "0.3"][..]] {
        let csv = ok(&brdf(
            &[&["scene", "profile", &scene(), "--bin-m", "0.1"], extra].concat(),
        ));
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("azimuth,elevation,range_m,lrcs"));
        let mut sums: Vec<(String, f64)> = Vec::new();
        for l in lines {
            let f: Vec<&str> = l.split(',').collect();
            let key = format!("{},{}", f[0], f[1]);
            let v: f64 = f[3].parse().unwrap();
            // Bin centres on the 0.1 m grid: k/10 + 0.05.
            let r: f64 = f[2].parse().unwrap();
            assert!(
                ((r - 0.05) * 10.0 - ((r - 0.05) * 10.0).round()).abs() < 1e-6,
                "{l}"
            );
            match sums.last_mut() {
                Some((k, s)) if *k == key => *s += v,
                _ => sums.push((key, v)),
            }
        }
        assert_eq!(sums.len(), sigma.len());
        for ((k, s), (k2, want)) in sums.iter().zip(&sigma) {
            assert_eq!(k, k2);
            assert!(
                (s - want).abs() <= 1e-9 * want,
                "{k}: {s} against {want} {extra:?}"
            );
        }
    }
    for (bin, says) in [
        ("0", "not a length above 0"),
        ("nan", "not a length above 0"),
        ("1e-6", "more than 100000"),
    ] {
        let out = brdf(&["scene", "profile", &scene(), "--bin-m", bin]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says), "{bin}: {err}");
    }
    let out = brdf(&["scene", "profile", &scene(), "--bin-m", "0.1", "--pulse-m", "-1"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--pulse-m -1.0: not a length above 0"));
    // --plot: the picture beside the CSV, the CSV unchanged; a format or folder the plot
    // cannot take, or -o naming the same file, refused before the sweep (no CSV written).
    let dir = tempfile::tempdir().unwrap();
    let (png, csv) = (dir.path().join("p.png"), dir.path().join("p.csv"));
    let plotted = |output: &std::path::Path, plot: &std::path::Path| {
        brdf(&[
            "scene",
            "profile",
            &scene(),
            "--bin-m",
            "0.1",
            "-o",
            output.to_str().unwrap(),
            "--plot",
            plot.to_str().unwrap(),
        ])
    };
    let out = plotted(&csv, &png);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
    let plain = ok(&brdf(&["scene", "profile", &scene(), "--bin-m", "0.1"]));
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), plain);
    let jpg = dir.path().join("p.jpg");
    let gone = dir.path().join("none").join("p.png");
    let (csv2, png2) = (dir.path().join("q.csv"), dir.path().join("q.png"));
    for (output, plot, says) in [
        (&csv2, &jpg, "unknown plot format"),
        (&csv2, &gone, "does not exist"),
        (&png2, &png2, "same file"),
    ] {
        let o = plotted(output, plot);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains(says) && !output.exists(), "{e}");
    }
}

/// `brdf scene image`: the picture, and the pixels as CSV summing to the σ it states (by the
/// area seen, within its sampling bound of the facet-centroid σ on the bundled target, whose
/// facets are small); bad aspects and sizes refused by name.
#[test]
fn image_draws_sigma_and_range_and_its_pixels_sum_to_sigma() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("i.png");
    let csv = dir.path().join("i.csv");
    let out = brdf(&[
        "scene",
        "image",
        &scene(),
        "--aspect",
        "30,20",
        "--pixels",
        "200",
        "-o",
        png.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
    let stated = |key: &str| -> f64 {
        let at = err.find(key).unwrap_or_else(|| panic!("{key}: {err}"));
        err[..at].rsplit(' ').nth(1).unwrap().parse().unwrap()
    };
    let (area, bound, centroid) = (
        stated("m^2 by the area seen"),
        err.split("sampling bound ")
            .nth(1)
            .unwrap()
            .split(')')
            .next()
            .unwrap()
            .parse::<f64>()
            .unwrap(),
        stated("by facet centroids"),
    );
    assert!((area - centroid).abs() <= bound, "{err}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("column,row,x_m,y_m,lrcs,range_m"));
    let (mut sum, mut seen) = (0.0, 0);
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        sum += f[4].parse::<f64>().unwrap();
        if !f[5].is_empty() {
            seen += 1;
        }
    }
    assert!((sum - area).abs() <= 1e-6 * area, "{sum} {area}");
    assert!(seen > 1000);
    for (args, says) in [
        (&["--aspect", "30"][..], "need AZ,EL"),
        (&["--aspect", "30,95"][..], "elevation `95`"),
        (&["--aspect", "nan,10"][..], "azimuth `nan`"),
        (&["--pixels", "0"][..], "--pixels 0"),
        (&["--supersample", "17"][..], "--supersample 17"),
    ] {
        let o = brdf(&[&["scene", "image", &scene(), "-o", png.to_str().unwrap()], args].concat());
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains(says), "{args:?}: {e}");
    }
    let o = brdf(&[
        "scene",
        "image",
        &scene(),
        "-o",
        dir.path().join("x.jpg").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    // A rod 100 m long and 1 cm thick seen broadside at 64 pixels (samples 39 cm wide): no
    // sample sees it; refused naming the bound and the sample size, no picture written.
    let rod = dir.path().join("rod.obj");
    let mut text = String::from("o rod\n");
    for x in [0.0, 100.0] {
        for (y, z) in [(0.0, 0.0), (0.01, 0.0), (0.01, 0.01), (0.0, 0.01)] {
            text += &format!("v {x} {y} {z}\n");
        }
    }
    text += "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    std::fs::write(&rod, text).unwrap();
    let toml = dir.path().join("rod.toml");
    std::fs::write(
        &toml,
        "mesh = \"rod.obj\"\n[[material]]\npart = \"*\"\nmodel = \"lambert\"\nparams = \"rho0=0.4\"\n\
         [sensor]\nmode = \"monostatic\"\nazimuth_deg = [0, 1, 5]\nelevation_deg = [0, 1, 5]\n",
    )
    .unwrap();
    let out_png = dir.path().join("rod.png");
    let o = brdf(&[
        "scene",
        "image",
        toml.to_str().unwrap(),
        "--aspect",
        "90,0",
        "--pixels",
        "64",
        "-o",
        out_png.to_str().unwrap(),
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("no sample sees a lit facet") && e.contains("give more --pixels"),
        "{e}"
    );
    assert!(!out_png.exists());
}

/// `brdf scene lrcs --visibility area`: every aspect's σ by the part of each facet seen, each
/// with its sampling bound in the JSON; on the bundled target (small facets, little shadow)
/// it agrees with the centroid σ to within that bound plus the centroid's own shadow error.
/// At a sweep's default resolution, which the summary line names.
#[test]
fn lrcs_by_area_states_each_aspects_bound() {
    let run = brdf(&["scene", "lrcs", &scene(), "--visibility", "area", "--json"]);
    let area: serde_json::Value = serde_json::from_str(&ok(&run)).unwrap();
    let said = format!(
        "visibility by area ({} pixels, {1}x{1} samples each)",
        brdf_scene::image::SWEEP_PIXELS,
        brdf_scene::image::SUPERSAMPLE
    );
    assert!(String::from_utf8_lossy(&run.stderr).contains(&said), "{said}");
    // The help states the same defaults.
    let help = ok(&brdf(&["scene", "lrcs", "--help"]));
    let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
    for (default, flag) in [
        (brdf_scene::image::SWEEP_PIXELS, "pixels"),
        (brdf_scene::image::SUPERSAMPLE, "supersample"),
    ] {
        assert!(
            help.contains(&format!("{default} unless given")),
            "--{flag}: {help}"
        );
    }
    let centroid: serde_json::Value =
        serde_json::from_str(&ok(&brdf(&["scene", "lrcs", &scene(), "--json"]))).unwrap();
    let (a, c) = (
        area["aspects"].as_array().unwrap(),
        centroid["aspects"].as_array().unwrap(),
    );
    assert_eq!(a.len(), c.len());
    let mut close = 0;
    for (x, y) in a.iter().zip(c) {
        let (sa, sc) = (x["lrcs"].as_f64().unwrap(), y["lrcs"].as_f64().unwrap());
        let bound = x["sampling_bound"].as_f64().unwrap();
        // The bound takes every sample an edge between facets of different σ per area
        // crosses at its worst, and every sample a silhouette crosses at the brightest
        // facet's σ per area (what lies beyond may be it): 69% of σ at most at 128 pixels
        // (README, "Pixels against time and accuracy").
        assert!(bound > 0.0 && bound < sa, "{x}");
        assert!(y.get("sampling_bound").is_none());
        // The parts add up.
        let parts: f64 = x["by_material"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .sum();
        assert!((parts - sa).abs() <= 1e-12 * sa);
        if (sa - sc).abs() <= bound {
            close += 1;
        }
    }
    assert!(close >= a.len() * 9 / 10, "{close} of {}", a.len());
    let bad = brdf(&["scene", "lrcs", &scene(), "--visibility", "area", "--pixels", "0"]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--pixels 0"));
    // A resolution without area visibility is refused, not ignored.
    let bad = brdf(&["scene", "lrcs", &scene(), "--pixels", "256"]);
    assert!(String::from_utf8_lossy(&bad.stderr).contains("set the resolution of --visibility area"));
}

/// `--shard K/N` for job arrays: the shards' CSVs, merged in order, are one run's CSV byte for
/// byte (by centroids and by area); merge refuses a missing, repeated or reordered shard, a
/// shard of another split, another header, and --shard with --json or --plot.
#[test]
fn shards_merge_into_one_runs_csv_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    for extra in [&[][..], &["--visibility", "area", "--pixels", "32"][..]] {
        let whole = ok(&brdf(&[&["scene", "lrcs", &scene()][..], extra].concat()));
        let shards: Vec<String> = (0..3)
            .map(|k| {
                let p = dir.path().join(format!("s{k}.csv"));
                let shard = format!("{k}/3");
                ok(&brdf(
                    &[
                        &[
                            "scene",
                            "lrcs",
                            &scene(),
                            "--shard",
                            &shard,
                            "-o",
                            p.to_str().unwrap(),
                        ][..],
                        extra,
                    ]
                    .concat(),
                ));
                p.to_str().unwrap().to_owned()
            })
            .collect();
        let s: Vec<&str> = shards.iter().map(String::as_str).collect();
        let merged = ok(&merge(&s));
        assert_eq!(merged, whole, "{extra:?}");
        // The shards split the 216 aspects 72 each, in order.
        let rows = |p: &str| std::fs::read_to_string(p).unwrap().lines().count() - 1;
        assert_eq!(s.iter().map(|p| rows(p)).collect::<Vec<_>>(), [72, 72, 72]);
        for (bad, says) in [
            (vec![s[0], s[1]], "72 aspects where shard 0 of 2 holds 108"),
            (vec![s[0], s[2], s[1]], "where shard 1 of 3 holds"),
            (vec![s[0], s[0], s[2]], "where shard 1 of 3 holds"),
            (
                vec![s[0], s[1], s[2], s[2]],
                "shard 0 of 4 holds 54 aspects of the sweep's 216; this row is one more",
            ),
        ] {
            refused(&merge(&bad), says);
        }
    }
    // Another split's shards, another header.
    let two = dir.path().join("two.csv");
    ok(&brdf(&[
        "scene",
        "lrcs",
        &scene(),
        "--shard",
        "0/2",
        "-o",
        two.to_str().unwrap(),
    ]));
    let s1 = dir.path().join("s1.csv");
    refused(
        &merge(&[two.to_str().unwrap(), s1.to_str().unwrap()]),
        "where shard 1 of 2 holds",
    );
    let other = dir.path().join("other.csv");
    let text = std::fs::read_to_string(&s1)
        .unwrap()
        .replacen("lrcs", "lrcs_0.55um", 1);
    std::fs::write(&other, text).unwrap();
    let (s0, s2) = (dir.path().join("s0.csv"), dir.path().join("s2.csv"));
    let (s0, s1, s2) = (s0.to_str().unwrap(), s1.to_str().unwrap(), s2.to_str().unwrap());
    let other_s = other.to_str().unwrap();
    refused(&merge(&[s0, other_s, s2]), "is not the `azimuth,elevation,lrcs`");
    // A row with a field dropped or not a number (it was copied through).
    // Nor a sigma that is no cross-section (NaN, infinite, negative), nor a field written
    // otherwise than one run writes it (the merge would not be that run's bytes).
    for (edit, says) in [
        ("drop", "2 fields where the header names 3"),
        ("word", "sigma `hello`"),
        ("nan", "sigma `NaN` is not a finite cross-section"),
        ("-inf", "sigma `-inf` is not a finite cross-section"),
        ("-5", "sigma `-5` is not a finite cross-section"),
        ("-0", "sigma `-0` is not a finite cross-section"),
        ("plus", "is not written as `brdf scene lrcs` writes it"),
    ] {
        let text = std::fs::read_to_string(s1).unwrap();
        let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let fields: Vec<String> = lines[4].split(',').map(str::to_owned).collect();
        let angles = fields[..2].join(",");
        lines[4] = match edit {
            "drop" => angles,
            "word" => format!("{angles},hello"),
            "nan" => format!("{angles},NaN"),
            "-inf" => format!("{angles},-inf"),
            "-5" => format!("{angles},-5"),
            "-0" => format!("{angles},-0"),
            _ => format!("+{},{},{}", fields[0], fields[1], fields[2]),
        };
        std::fs::write(&other, lines.join("\n") + "\n").unwrap();
        refused(&merge(&[s0, other_s, s2]), says);
        refused(&merge(&[s0, other_s, s2]), "line 5");
    }
    // A shard cut short inside its last number (no final line break).
    let text = std::fs::read_to_string(s1).unwrap();
    std::fs::write(&other, &text[..text.len() - 4]).unwrap();
    refused(&merge(&[s0, other_s, s2]), "does not end with a line break");
    // -o onto a shard or the scene would destroy an input.
    refused(&merge(&[s0, s1, s2, "-o", s1]), "-o names the shard");
    refused(&merge(&[s0, s1, s2, "-o", &scene()]), "-o");
    for (args, says) in [
        (vec!["--shard", "3/3"], "need 0 <= K < N"),
        (vec!["--shard", "0/217"], "give at most 216"),
        (vec!["--shard", "0/2", "--json"], "--shard writes CSV"),
        (vec!["--shard", "0/2", "--plot", "p.png"], "--shard writes CSV"),
        (vec!["--shard", "1/0"], "need 0 <= K < N"),
        (vec!["--shard=-1/3"], "is not a shard index"),
        (vec!["--shard", "1/nan"], "is not a shard count"),
        (vec!["--shard", ""], "is not of the form K/N"),
    ] {
        refused(
            &brdf(&[&["scene", "lrcs", &scene()][..], &args[..]].concat()),
            says,
        );
    }
}

/// `brdf scene merge` of the bundled scene with `args` (shards, options).
fn merge(args: &[&str]) -> std::process::Output {
    brdf(&[&["scene", "merge", &scene()][..], args].concat())
}

/// A run that failed saying `says`.
fn refused(out: &std::process::Output, says: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains(says),
        "wanted `{says}`: {err}"
    );
}
