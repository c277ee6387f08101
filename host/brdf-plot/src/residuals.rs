//! Relative residuals of one fit against the viewing angle, one colour per incidence.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use brdf_core::Brdf;
use brdf_fit::Dataset;

use crate::common::{deg, err, render, Res, FONT};
use crate::{Fitted, PlotError};

/// (c) Relative residuals `(f - y) / y` in percent (over `sqrt(y^2 + S^2)` under the fit's
/// noise floor `S`) against the viewing angle: the signed
/// scattering angle for in-plane points, `theta_r` (marked as such) otherwise; one colour per
/// incidence angle.
pub fn residuals(path: &Path, title: &str, data: &Dataset, fit: &Fitted) -> Result<(), PlotError> {
    let incidences = data.incidences();
    let mut series: Vec<(f64, Vec<(f64, f64)>)> = Vec::new();
    for &ti in &incidences {
        let pts: Vec<(f64, f64)> = data
            .points
            .iter()
            .filter(|p| (p.theta_i - ti).abs() < 1e-9)
            .map(|p| {
                let f = fit.model.eval_angles(p.theta_i, p.theta_r, p.phi);
                let in_plane = p.phi.sin().abs() < 0.02 || p.theta_r < 1e-6;
                let s = if in_plane && p.phi.cos() > 0.0 { -1.0 } else { 1.0 };
                (
                    s * p.theta_r.to_degrees(),
                    100.0 * (f - p.brdf) / p.brdf.hypot(fit.floor),
                )
            })
            .collect();
        series.push((ti, pts));
    }
    let y_desc = if fit.floor > 0.0 {
        format!("(model - measured) / sqrt(measured^2 + {:.2e}^2) (%)", fit.floor)
    } else {
        "(model - measured) / measured (%)".to_owned()
    };
    let all = series.iter().flat_map(|s| s.1.iter().map(|p| p.1));
    let bound = all.fold(1.0f64, |m, v| m.max(v.abs())).min(1000.0) * 1.1;
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        label: &str,
        series: &[(f64, Vec<(f64, f64)>)],
        bound: f64,
        y_desc: &str,
    ) -> Res {
        // Title and legend above the chart, so that no data point hides behind them.
        let (head, body) = root.split_vertically(100);
        head.draw(&Text::new(
            format!("{title}: residuals of {label}"),
            (16, 8),
            (FONT, 20).into_font(),
        ))
        .map_err(err)?;
        // Legend entries in rows that wrap before the right edge.
        let (mut x, mut y) = (16, 48);
        for (k, (ti, _)) in series.iter().enumerate() {
            let c = Palette99::pick(k).to_rgba();
            let text = format!("theta_i {} deg", deg(*ti));
            let width = 30 + 8 * text.len() as i32;
            if x + width > 990 {
                x = 16;
                y += 26;
            }
            head.draw(&Circle::new((x + 6, y), 5, c.filled())).map_err(err)?;
            head.draw(&Text::new(text, (x + 16, y - 9), (FONT, 15).into_font()))
                .map_err(err)?;
            x += width;
        }
        let mut chart = ChartBuilder::on(&body)
            .margin(12)
            .x_label_area_size(46)
            .y_label_area_size(70)
            .build_cartesian_2d(-90f64..90f64, -bound..bound)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("viewing angle (deg): signed theta_s in plane (+ forward), theta_r off plane")
            .y_desc(y_desc)
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .light_line_style(WHITE)
            .draw()
            .map_err(err)?;
        chart
            .draw_series(LineSeries::new(
                [(-90.0, 0.0), (90.0, 0.0)],
                BLACK.stroke_width(1),
            ))
            .map_err(err)?;
        for (k, (_, pts)) in series.iter().enumerate() {
            let c = Palette99::pick(k).to_rgba();
            let clipped = pts.iter().map(|&(x, y)| (x, y.clamp(-bound, bound)));
            chart
                .draw_series(clipped.map(|p| Circle::new(p, 3, c.filled())))
                .map_err(err)?;
        }
        Ok(())
    }
    render(
        path,
        (1000, 700),
        |r| draw(r, title, &fit.label, &series, bound, &y_desc),
        |r| draw(r, title, &fit.label, &series, bound, &y_desc),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_svg_and_png() {
        let (data, fit) = crate::common::khaki();
        let dir = tempfile::tempdir().unwrap();
        for ext in ["svg", "png"] {
            let c = dir.path().join(format!("c.{ext}"));
            residuals(&c, "t", &data, &fit).unwrap();
            assert!(std::fs::metadata(&c).unwrap().len() > 1000, "{}", c.display());
        }
        let svg = std::fs::read_to_string(dir.path().join("c.svg")).unwrap();
        assert!(svg.contains("residuals of six") && svg.contains("theta_i 30 deg"));
    }
}
