//! A spectral measurement's fits against wavelength: the weights (the parameters the model is
//! linear in, which carry the colour), the albedo at normal incidence and the RMS relative
//! error, one panel each.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use brdf_fit::spectral::Spectrum;

use crate::common::{err, log_range, render, Res, FONT, PALETTE};
use crate::PlotError;

/// Draws `s` (at least two bands) in three panels sharing the wavelength axis: each weight
/// (log axis; a weight at 0 is a gap, counted in the legend), the albedo at normal
/// incidence, the RMS relative error in percent.
pub fn spectrum(path: &Path, title: &str, s: &Spectrum) -> Result<(), PlotError> {
    let empty = |why: &str| PlotError::Empty {
        file: path.display().to_string(),
        why: why.to_owned(),
    };
    if s.bands.len() < 2 {
        return Err(empty("fewer than two bands"));
    }
    let names = s.model.param_names();
    let weights: Vec<(String, Vec<(f64, f64)>)> = s
        .weight_indices()
        .into_iter()
        .map(|i| {
            let pts = s.bands.iter().map(|b| (b.wavelength_um, b.params[i])).collect();
            (names[i].to_owned(), pts)
        })
        .collect();
    let albedo: Vec<(f64, f64)> = s
        .bands
        .iter()
        .filter_map(|b| b.albedo_normal.map(|a| (b.wavelength_um, a)))
        .collect();
    let error: Vec<(f64, f64)> = s
        .bands
        .iter()
        .map(|b| (b.wavelength_um, 100.0 * b.rms_rel))
        .collect();
    let (x0, x1) = (s.bands[0].wavelength_um, s.bands[s.bands.len() - 1].wavelength_um);
    let pad = 0.02 * (x1 - x0);
    let x = (x0 - pad)..(x1 + pad);
    let subtitle = format!("{title}: {} bands, {}", s.bands.len(), s.model.name());
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        subtitle: &str,
        x: std::ops::Range<f64>,
        weights: &[(String, Vec<(f64, f64)>)],
        albedo: &[(f64, f64)],
        error: &[(f64, f64)],
    ) -> Res {
        let (head, body) = root.split_vertically(40);
        head.draw(&Text::new(subtitle.to_owned(), (16, 8), (FONT, 20).into_font()))
            .map_err(err)?;
        let panels = body.split_evenly((3, 1));
        // Weights on a log axis (they span decades across bands); a weight at 0 in a band is
        // a gap in its line, and its legend says in how many.
        let positive: Vec<f64> = weights
            .iter()
            .flat_map(|w| w.1.iter().map(|p| p.1))
            .filter(|v| *v > 0.0 && v.is_finite())
            .collect();
        let lo = positive.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = positive.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let (a, b) = if positive.is_empty() {
            (1e-3, 1.0)
        } else {
            log_range(lo, hi)
        };
        let mut chart = ChartBuilder::on(&panels[0])
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(70)
            .build_cartesian_2d(x.clone(), (a..b).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .y_desc("weight")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 14))
            .draw()
            .map_err(err)?;
        for (k, (name, pts)) in weights.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            let drawn = |v: f64| v > 0.0 && v.is_finite();
            let zero = pts.iter().filter(|p| !drawn(p.1)).count();
            let label = match zero {
                0 => name.clone(),
                n => format!(
                    "{name} (0 in {n} band{}, not drawn)",
                    if n == 1 { "" } else { "s" }
                ),
            };
            // Runs of positive values, each its own line.
            let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for &p in pts {
                if drawn(p.1) {
                    if let Some(r) = runs.last_mut() {
                        r.push(p);
                    }
                } else if runs.last().is_some_and(|r| !r.is_empty()) {
                    runs.push(Vec::new());
                }
            }
            for (j, run) in runs.iter().enumerate() {
                let series = chart
                    .draw_series(LineSeries::new(run.iter().copied(), c.stroke_width(2)))
                    .map_err(err)?;
                if j == 0 {
                    series
                        .label(label.clone())
                        .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], c.stroke_width(2)));
                }
                chart
                    .draw_series(run.iter().map(|&p| Circle::new(p, 3, c.filled())))
                    .map_err(err)?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((FONT, 14))
            .draw()
            .map_err(err)?;
        for (panel, pts, desc, c, bottom) in [
            (&panels[1], albedo, "albedo at 0 deg", PALETTE[1], false),
            (&panels[2], error, "RMS relative error (%)", PALETTE[0], true),
        ] {
            let top = pts.iter().map(|p| p.1).fold(0.0f64, f64::max).max(1e-12) * 1.1;
            let mut chart = ChartBuilder::on(panel)
                .margin(10)
                .x_label_area_size(if bottom { 46 } else { 30 })
                .y_label_area_size(70)
                .build_cartesian_2d(x.clone(), 0.0..top)
                .map_err(err)?;
            let mut mesh = chart.configure_mesh();
            mesh.y_desc(desc)
                .label_style((FONT, 13))
                .axis_desc_style((FONT, 14));
            if bottom {
                mesh.x_desc("wavelength (µm)");
            }
            mesh.draw().map_err(err)?;
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
                .map_err(err)?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                .map_err(err)?;
        }
        Ok(())
    }
    render(
        path,
        (1000, 900),
        |r| draw(r, &subtitle, x.clone(), &weights, &albedo, &error),
        |r| draw(r, &subtitle, x.clone(), &weights, &albedo, &error),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_fit::spectral::SpectrumBand;

    fn three() -> Spectrum {
        Spectrum {
            measurement: "paint".into(),
            model: brdf_core::ModelKind::Six,
            bands: [0.4, 0.5, 0.6]
                .iter()
                .enumerate()
                .map(|(k, &um)| SpectrumBand {
                    wavelength_um: um,
                    fit: k,
                    params: vec![0.2 * (k + 1) as f64, 20.0, -27.0, 0.7, 0.01 * (k + 1) as f64, 1.2],
                    albedo_normal: Some(0.1 * (k + 1) as f64),
                    rms_rel: 0.05,
                })
                .collect(),
        }
    }

    #[test]
    fn draws_the_weights_albedo_and_error_against_wavelength() {
        let dir = tempfile::tempdir().unwrap();
        for ext in ["svg", "png"] {
            let p = dir.path().join(format!("s.{ext}"));
            spectrum(&p, "t", &three()).unwrap();
            assert!(std::fs::metadata(&p).unwrap().len() > 1000, "{}", p.display());
        }
        let svg = std::fs::read_to_string(dir.path().join("s.svg")).unwrap();
        for text in ["3 bands, six", "kb", "kd", "albedo at 0 deg", "wavelength (µm)"] {
            assert!(svg.contains(text), "{text}");
        }
        // A weight at 0 is a gap, counted in the legend; one band is refused.
        let mut zero = three();
        zero.bands[1].params[0] = 0.0;
        spectrum(&dir.path().join("z.svg"), "t", &zero).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("z.svg")).unwrap();
        assert!(svg.contains("kb (0 in 1 band, not drawn)"));
        let mut one = three();
        one.bands.truncate(1);
        assert!(spectrum(&dir.path().join("o.svg"), "t", &one).is_err());
    }
}
