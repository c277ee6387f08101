//! The paper's Fig. 2a–c: measured points and fitted models along the plane of incidence,
//! one panel per incidence angle.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use brdf_core::{AnyModel, Brdf};
use brdf_fit::Dataset;

use crate::common::{deg, err, log_range, render, Res, FONT, PALETTE};
use crate::{Fitted, PlotError};

/// (a) In-plane curves: measured points and the fitted models against the signed
/// scattering angle, one panel per incidence angle, log BRDF axis.
pub fn in_plane(path: &Path, title: &str, data: &Dataset, fits: &[Fitted]) -> Result<(), PlotError> {
    let incidences: Vec<f64> = data
        .incidences()
        .into_iter()
        .filter(|&ti| !in_plane_points(data, ti).is_empty())
        .collect();
    if incidences.is_empty() {
        return Err(PlotError::Empty {
            file: path.display().to_string(),
            why: "no points in the plane of incidence".into(),
        });
    }
    let (rows, cols) = grid(incidences.len());
    let size = (460 * cols as u32, 120 + 340 * rows as u32);
    // Per panel: measured points, axis range, and the model curves.
    let panels: Vec<Panel> = incidences
        .iter()
        .map(|&ti| {
            let pts = in_plane_points(data, ti);
            // The log axis spans the positive readings; dark ones (at or below zero, kept by
            // the fit's noise floor) cannot be placed on it.
            let lo = pts
                .iter()
                .map(|p| p.1)
                .filter(|&v| v > 0.0)
                .fold(f64::INFINITY, f64::min);
            let hi = pts.iter().map(|p| p.1).fold(0.0, f64::max);
            let (lo, hi) = log_range(lo, hi);
            let curves = fits
                .iter()
                .map(|f| runs_in_range(&model_curve(&f.model, ti), lo, hi))
                .collect();
            Panel {
                ti,
                pts,
                lo,
                hi,
                curves,
            }
        })
        .collect();
    // A model that never enters any panel's range says so in the legend.
    let labels: Vec<String> = fits
        .iter()
        .enumerate()
        .map(|(k, f)| {
            if panels.iter().all(|p| p.curves[k].is_empty()) {
                format!("{} (off scale)", f.label)
            } else {
                f.label.clone()
            }
        })
        .collect();
    struct Panel {
        ti: f64,
        pts: Vec<(f64, f64)>,
        lo: f64,
        hi: f64,
        curves: Vec<Vec<Vec<(f64, f64)>>>,
    }
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        labels: &[String],
        panels: &[Panel],
        (rows, cols): (usize, usize),
    ) -> Res {
        let (head, body) = root.split_vertically(110);
        head.draw(&Text::new(title, (20, 10), (FONT, 26).into_font()))
            .map_err(err)?;
        // Legend row under the title: measured points, then each model.
        let mut x = 20;
        head.draw(&Circle::new((x + 6, 70), 4, BLACK.filled()))
            .map_err(err)?;
        head.draw(&Text::new("measured", (x + 18, 60), (FONT, 18).into_font()))
            .map_err(err)?;
        x += 140;
        for (k, label) in labels.iter().enumerate() {
            let c = PALETTE[k % PALETTE.len()];
            head.draw(&PathElement::new(vec![(x, 70), (x + 28, 70)], c.stroke_width(3)))
                .map_err(err)?;
            head.draw(&Text::new(label.as_str(), (x + 36, 60), (FONT, 18).into_font()))
                .map_err(err)?;
            x += 46 + 10 * label.len() as i32;
        }
        let areas = body.split_evenly((rows, cols));
        for (area, p) in areas.iter().zip(panels) {
            let mut chart = ChartBuilder::on(area)
                .caption(format!("theta_i = {} deg", deg(p.ti)), (FONT, 18))
                .margin(8)
                .x_label_area_size(42)
                .y_label_area_size(64)
                .build_cartesian_2d(-90f64..90f64, (p.lo..p.hi).log_scale())
                .map_err(err)?;
            chart
                .configure_mesh()
                .x_desc("scattering angle theta_s (deg), + forward")
                .y_desc("BRDF (1/sr)")
                .x_labels(7)
                .y_labels(6)
                .label_style((FONT, 14))
                .axis_desc_style((FONT, 15))
                .light_line_style(WHITE)
                .draw()
                .map_err(err)?;
            for (k, runs) in p.curves.iter().enumerate() {
                let color = PALETTE[k % PALETTE.len()];
                for run in runs {
                    chart
                        .draw_series(LineSeries::new(run.iter().copied(), color.stroke_width(2)))
                        .map_err(err)?;
                }
            }
            chart
                .draw_series(p.pts.iter().map(|&q| Circle::new(q, 3, BLACK.filled())))
                .map_err(err)?;
        }
        Ok(())
    }
    let g = (rows, cols);
    render(
        path,
        size,
        |r| draw(r, title, &labels, &panels, g),
        |r| draw(r, title, &labels, &panels, g),
    )
}

/// In-plane points of one incidence: (signed scattering angle in degrees, positive on the
/// forward side; measured value).
fn in_plane_points(data: &Dataset, theta_i: f64) -> Vec<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = data
        .points
        .iter()
        .filter(|p| (p.theta_i - theta_i).abs() < 1e-9)
        .filter(|p| p.phi.sin().abs() < 0.02 || p.theta_r < 1e-6)
        .map(|p| {
            let s = if p.phi.cos() < 0.0 { 1.0 } else { -1.0 };
            (s * p.theta_r.to_degrees(), p.brdf)
        })
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v
}

/// Model along the plane of incidence, signed scattering angle -89..89 degrees.
fn model_curve(model: &AnyModel<f64>, theta_i: f64) -> Vec<(f64, f64)> {
    (-890..=890)
        .step_by(2)
        .map(|k| {
            let ts = f64::from(k) / 10.0;
            let phi = if ts >= 0.0 { std::f64::consts::PI } else { 0.0 };
            (ts, model.eval_angles(theta_i, ts.abs().to_radians(), phi))
        })
        .collect()
}

/// Splits a curve into runs of points inside `[lo, hi]`, so that a curve leaving the axis
/// range is cut there instead of being joined across the gap.
fn runs_in_range(c: &[(f64, f64)], lo: f64, hi: f64) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur = Vec::new();
    for &(x, y) in c {
        if y >= lo && y <= hi {
            cur.push((x, y));
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

fn grid(n: usize) -> (usize, usize) {
    let cols = if n <= 3 {
        n.max(1)
    } else if n <= 4 {
        2
    } else {
        3
    };
    (n.div_ceil(cols), cols)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_svg_and_png_and_refuses_unknown_formats() {
        let (data, fit) = crate::common::khaki();
        let dir = tempfile::tempdir().unwrap();
        for ext in ["svg", "png"] {
            let a = dir.path().join(format!("a.{ext}"));
            in_plane(&a, "t", &data, std::slice::from_ref(&fit)).unwrap();
            assert!(std::fs::metadata(&a).unwrap().len() > 1000, "{}", a.display());
        }
        let svg = std::fs::read_to_string(dir.path().join("a.svg")).unwrap();
        assert!(svg.contains("theta_i = 30 deg") && svg.contains("BRDF (1/sr)"));
        assert!(matches!(
            in_plane(&dir.path().join("x.gif"), "t", &data, std::slice::from_ref(&fit)),
            Err(PlotError::Format(_))
        ));
        // A folder that does not exist is named before anything is drawn.
        let e = crate::check_path(&dir.path().join("no/such/a.svg"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not exist"), "{e}");
        assert!(crate::check_path(std::path::Path::new("a.svg")).is_ok());
        // Upper case names the same formats.
        let upper = dir.path().join("A.SVG");
        in_plane(&upper, "t", &data, std::slice::from_ref(&fit)).unwrap();
        assert!(std::fs::read_to_string(&upper).unwrap().starts_with("<svg"));
    }
}
