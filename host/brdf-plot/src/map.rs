//! The paper's Fig. 2d–f: the BRDF over the viewing hemisphere as a polar heat map.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use brdf_core::{AnyModel, Brdf};

use crate::common::{circle, colour_bar, deg, err, render, viridis, Res, FONT};
use crate::PlotError;

/// (b) The BRDF over the viewing hemisphere for incidence `theta_i` (radians), as a
/// heat-mapped polar projection: `(sin theta_r cos phi, sin theta_r sin phi)`, mirror
/// direction on the left (`phi = 180°`), colour = log10 BRDF.
pub fn hemisphere_map(
    path: &Path,
    title: &str,
    model: &AnyModel<f64>,
    theta_i: f64,
) -> Result<(), PlotError> {
    const N: usize = 90;
    let mut cells = Vec::with_capacity(N * N);
    for i in 0..N {
        for j in 0..N {
            let x = -1.0 + (i as f64 + 0.5) * 2.0 / N as f64;
            let y = -1.0 + (j as f64 + 0.5) * 2.0 / N as f64;
            let r = (x * x + y * y).sqrt();
            if r >= 0.999 {
                continue;
            }
            let theta_r = r.asin();
            let phi = y.atan2(x);
            let f = model.eval_angles(theta_i, theta_r, phi);
            if f > 0.0 {
                cells.push((x, y, f.log10()));
            }
        }
    }
    if cells.is_empty() {
        return Err(PlotError::Empty {
            file: path.display().to_string(),
            why: "the model is zero over the hemisphere".into(),
        });
    }
    let lo = cells.iter().map(|c| c.2).fold(f64::INFINITY, f64::min);
    let hi = cells.iter().map(|c| c.2).fold(f64::NEG_INFINITY, f64::max);
    let span = (hi - lo).max(1e-9);
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        theta_i: f64,
        cells: &[(f64, f64, f64)],
        (lo, span): (f64, f64),
    ) -> Res {
        let (head, body) = root.split_vertically(70);
        head.draw(&Text::new(title, (16, 8), (FONT, 18).into_font()))
            .map_err(err)?;
        head.draw(&Text::new(
            format!("theta_i = {} deg; colour: log10 BRDF (1/sr)", deg(theta_i)),
            (16, 38),
            (FONT, 16).into_font(),
        ))
        .map_err(err)?;
        let (map_area, bar_area) = body.split_horizontally(640);
        let mut chart = ChartBuilder::on(&map_area)
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(56)
            .build_cartesian_2d(-1f64..1f64, -1f64..1f64)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("sin(theta_r) cos(phi)   (mirror side: left)")
            .y_desc("sin(theta_r) sin(phi)")
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .draw()
            .map_err(err)?;
        let h = 1.0 / N as f64;
        chart
            .draw_series(cells.iter().map(|&(x, y, v)| {
                Rectangle::new(
                    [(x - h, y - h), (x + h, y + h)],
                    viridis((v - lo) / span).filled(),
                )
            }))
            .map_err(err)?;
        // Zenith rings at 30 and 60 degrees.
        for deg in [30.0f64, 60.0] {
            let r = deg.to_radians().sin();
            let ring = circle(r);
            chart
                .draw_series(LineSeries::new(ring, WHITE.mix(0.6).stroke_width(1)))
                .map_err(err)?;
        }
        colour_bar(&bar_area, "log10 BRDF (1/sr)", (lo, span), (15, 40, 56, 50))?;
        Ok(())
    }
    render(
        path,
        (820, 770),
        |r| draw(r, title, theta_i, &cells, (lo, span)),
        |r| draw(r, title, theta_i, &cells, (lo, span)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_svg_and_png() {
        let model = crate::common::khaki().1.model;
        let dir = tempfile::tempdir().unwrap();
        for ext in ["svg", "png"] {
            let b = dir.path().join(format!("b.{ext}"));
            hemisphere_map(&b, "t", &model, 0.5).unwrap();
            assert!(std::fs::metadata(&b).unwrap().len() > 1000, "{}", b.display());
        }
    }
}
