//! The importers on the bundled measured files (data/measured): every row kept or reported, and the
//! mapping to the canonical convention checked by where each material's peak lies.

use brdf_fit::import::{import, Channel, Format, Imported, Pick};

/// The largest value at each incidence (from `min_theta_i` degrees up) must lie on the
/// forward side (within 30 degrees of phi = 180) and within `max_offset` degrees of the
/// mirror direction. Real surfaces peak off-specular towards grazing and full-hemisphere
/// grids rarely sample the plane exactly, hence the per-material `max_offset`. Returns how
/// many incidences were checked.
fn peaks_forward(imp: &Imported, min_theta_i: f64, max_offset: f64) -> usize {
    let mut checked = 0;
    for d in &imp.datasets {
        for ti in d.incidences() {
            if ti.to_degrees() < min_theta_i {
                continue;
            }
            let peak = d
                .points
                .iter()
                .filter(|p| (p.theta_i - ti).abs() < 1e-9)
                .max_by(|a, b| a.brdf.total_cmp(&b.brdf))
                .unwrap();
            let phi = peak.phi.to_degrees();
            // Angle between the peak direction and the mirror direction (theta_i, phi = 180).
            let mirror = [-ti.sin(), 0.0, ti.cos()];
            let v = [
                peak.theta_r.sin() * peak.phi.cos(),
                peak.theta_r.sin() * peak.phi.sin(),
                peak.theta_r.cos(),
            ];
            let off = (mirror[0] * v[0] + mirror[1] * v[1] + mirror[2] * v[2])
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees();
            println!(
                "{} theta_i {:5.2}: peak at theta_r {:5.2}, phi {phi:6.1}, {off:4.1} deg from mirror",
                d.name,
                ti.to_degrees(),
                peak.theta_r.to_degrees()
            );
            assert!(
                (phi - 180.0).abs() <= 30.0,
                "{} at {:.2} deg: peak at phi {phi}",
                d.name,
                ti.to_degrees()
            );
            assert!(
                off <= max_offset,
                "{} at {:.2}: peak {off:.1} deg from the mirror direction",
                d.name,
                ti.to_degrees()
            );
            checked += 1;
        }
    }
    checked
}

#[test]
fn cornell_garnet_red_every_row_accounted_for() {
    let imp = import(
        &brdf_tests::measured("cornell-medium-gloss-paints/garnet_red_RGB.astm"),
        Format::Cornell,
        Channel::R,
    )
    .unwrap();
    assert_eq!(imp.rows_in, 1439, "NUM_POINTS of the file");
    assert_eq!(imp.points(), imp.rows_in, "every reading kept");
    assert!(imp.rejects.is_empty());
    // The one R = 0 row of the file is line 1459 (22 header lines, 1439 rows): kept, and
    // moved to the rejects by line only for a study of positive readings.
    let dark: Vec<u64> = imp.datasets[0]
        .points
        .iter()
        .filter(|p| p.brdf <= 0.0)
        .map(|p| p.line)
        .collect();
    assert_eq!(dark, [1459]);
    let positive = imp.clone().positive_only();
    assert_eq!(
        positive.rejects.iter().map(|r| r.line).collect::<Vec<_>>(),
        [1459]
    );
    println!("garnet R: {} points", imp.points());
    // Broad gloss lobe, off-specular towards grazing at large incidence.
    assert_eq!(peaks_forward(&imp, 0.0, 25.0), 8);
    let b = import(
        &brdf_tests::measured("cornell-medium-gloss-paints/garnet_red_RGB.astm"),
        Format::Cornell,
        Channel::G,
    )
    .unwrap();
    assert_eq!(b.points(), 1439);
    assert!(
        b.datasets[0].points.iter().any(|p| p.brdf < 0.0),
        "the G channel has negative values (gamut mapping), each kept"
    );
}

/// The spectral originals: every reading of every band, one dataset per band in file order,
/// each value the file's own (spot-checked against the text of a line).
#[test]
fn cornell_spectral_every_reading_of_every_band() {
    for (file, zeros) in [("garnet_red.astm", 213), ("krylon_blue.astm", 1218)] {
        let path = brdf_tests::measured(&format!("cornell-spectral/{file}"));
        let imp = import(&path, Format::Cornell, Pick::default()).unwrap();
        assert_eq!(imp.datasets.len(), 31, "{file}: 400, 410, ..., 700 nm");
        assert_eq!((imp.points(), imp.rejects.len()), (31 * 1439, 0), "{file}");
        for (k, d) in imp.datasets.iter().enumerate() {
            let nm = 400 + 10 * k;
            let um = brdf_core::Compact(nm as f64 / 1000.0);
            assert!(d.name.ends_with(&format!("[wavelength={um}]")), "{}", d.name);
            assert_eq!(d.points.len(), 1439);
        }
        assert_eq!(
            imp.dark_readings(),
            zeros,
            "{file}: the readings printed as 0.000000"
        );
        // A line's 31 values, as the file prints them, are the bands' values at that line.
        let text = std::fs::read_to_string(&path).unwrap();
        let line = imp.datasets[0].points[700].line;
        let fields: Vec<f64> = text
            .lines()
            .nth(line as usize - 1)
            .unwrap()
            .split(',')
            .map(|f| f.trim().parse().unwrap())
            .collect();
        for (k, d) in imp.datasets.iter().enumerate() {
            assert_eq!(d.points[700].brdf, fields[4 + k], "{file} line {line} band {k}");
            assert_eq!(d.points[700].line, line);
        }
        // Same directions as the RGB file of the same paint (the same 1,439 rows).
        let rgb = brdf_tests::measured(&format!(
            "cornell-medium-gloss-paints/{}_RGB.astm",
            file.trim_end_matches(".astm")
        ));
        let rgb = import(&rgb, Format::Cornell, Channel::R).unwrap();
        for (a, b) in rgb.datasets[0].points.iter().zip(&imp.datasets[15].points) {
            assert!((a.theta_i - b.theta_i).abs() < 1e-12 && (a.phi - b.phi).abs() < 1e-12);
        }
    }
}

#[test]
fn nist_ptfe_every_row_accounted_for() {
    let imp = import(
        &brdf_tests::measured("ptfe-germer-nist/PTFE.data.csv"),
        Format::Nist,
        Channel::R,
    )
    .unwrap();
    assert_eq!(imp.rows_in, 7296);
    assert_eq!(imp.points() + imp.rejects.len(), imp.rows_in);
    assert_eq!(imp.datasets.len(), 4, "one dataset per wavelength");
    println!("PTFE: {} points, {} rejects", imp.points(), imp.rejects.len());
    // Nearly Lambertian: only the large incidences have a forward rise that decides the peak.
    assert_eq!(peaks_forward(&imp, 59.9, 32.0), 8);
}

#[test]
fn merl_aluminium_every_row_accounted_for() {
    let imp = import(
        &brdf_tests::measured("merl-aluminium-inplane/aluminum_brdf.csv"),
        Format::MerlInPlane,
        Channel::R,
    )
    .unwrap();
    assert_eq!(imp.rows_in, 1785);
    assert_eq!(imp.points() + imp.rejects.len(), imp.rows_in);
    println!(
        "MERL aluminium: {} points, {} rejects",
        imp.points(),
        imp.rejects.len()
    );
    // Sharp specular peak: forward, within one sample step of the mirror direction.
    assert_eq!(peaks_forward(&imp, 0.0, 1.0), 7);
}

/// Krylon blue's red channel over its relative-residual Lambert fit (rho0 ~ 7e-6: most readings
/// are near zero): the smoothness cross-validation picked the smallest smoothness, whose
/// cells no reading informs extrapolated to ln f -86..61, beyond what the device stores, and
/// `brdf select` left the table out. The best table that can be stored is chosen now.
#[test]
fn the_chosen_fitted_table_is_one_the_device_can_store() {
    use brdf_fit::fitted_table::{FittedTable, SHAPES};
    let imp = import(
        &brdf_tests::measured("cornell-medium-gloss-paints/krylon_blue_RGB.astm"),
        Format::Cornell,
        Channel::R,
    )
    .unwrap()
    // Positive readings only: the case was found on them (the table fits `ln f`).
    .positive_only();
    let d = &imp.datasets[0];
    let base = brdf_fit::FitSettings::new(brdf_core::ModelKind::Lambert)
        .fit(d)
        .unwrap();
    let rho0 = base.params_array().unwrap()[0];
    assert!(rho0 < 1e-4, "the base this case needs: rho0 {rho0}");
    let base_ln = vec![(rho0 / std::f64::consts::PI).ln(); d.points.len()];
    let table = FittedTable::fit_cv(&d.points, &base_ln, &SHAPES).unwrap();
    assert!(table.to_bytes().is_ok(), "smoothness {}", table.smoothness);
}
