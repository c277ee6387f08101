//! A cross-section against azimuth on polar axes, in dB below its largest value.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::common::{circle, err, render, Res, FONT, PALETTE};
use crate::PlotError;

/// One curve of a polar plot: a label and `(azimuth in degrees, value > 0)` points in
/// sweep order.
#[derive(Clone, Debug)]
pub struct PolarCurve {
    /// Legend text, e.g. `elevation 15 deg`.
    pub label: String,
    /// (azimuth, value) pairs; azimuth in degrees, counter-clockwise from +x.
    pub points: Vec<(f64, f64)>,
}

/// Decibels drawn below the largest value: the centre of a polar plot is this far down.
pub const POLAR_RANGE_DB: f64 = 40.0;

/// A polar plot of a cross-section against azimuth, seen from above the mesh frame: azimuth
/// counter-clockwise from +x (right), radius `10 log10(value)` in dB over the
/// [`POLAR_RANGE_DB`] below the largest value (rounded up to 10 dB); values lower than the
/// centre (and zeros) are drawn at the centre, which the subtitle says. A curve whose
/// azimuths go round the full circle is closed.
pub fn polar(path: &Path, title: &str, unit: &str, curves: &[PolarCurve]) -> Result<(), PlotError> {
    let file = path.display().to_string();
    let top = curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.1))
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold(f64::NEG_INFINITY, f64::max);
    if !top.is_finite() {
        return Err(PlotError::Empty {
            file,
            why: "no positive value".into(),
        });
    }
    let hi = (10.0 * top.log10() / 10.0).ceil() * 10.0;
    let lo = hi - POLAR_RANGE_DB;
    let radius = |v: f64| {
        if v > 0.0 {
            ((10.0 * v.log10() - lo) / POLAR_RANGE_DB).clamp(0.0, 1.0)
        } else {
            0.0
        }
    };
    let xy = |az: f64, r: f64| (r * az.to_radians().cos(), r * az.to_radians().sin());
    let lines: Vec<(String, Vec<(f64, f64)>)> = curves
        .iter()
        .map(|c| {
            let mut pts: Vec<(f64, f64)> = c.points.iter().map(|&(az, v)| xy(az, radius(v))).collect();
            if let (Some(first), Some(last)) = (c.points.first(), c.points.last()) {
                let step = if c.points.len() > 1 {
                    (c.points[1].0 - first.0).abs()
                } else {
                    360.0
                };
                if c.points.len() > 2 && (first.0 + 360.0 - last.0 - step).abs() < 1e-6 * step.max(1.0) {
                    pts.push(pts[0]);
                }
            }
            (c.label.clone(), pts)
        })
        .collect();
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        sub: &str,
        lines: &[(String, Vec<(f64, f64)>)],
        rings: &[(f64, String)],
    ) -> Res {
        let (head, body) = root.split_vertically(64);
        head.draw(&Text::new(title.to_string(), (16, 8), (FONT, 18).into_font()))
            .map_err(err)?;
        head.draw(&Text::new(sub.to_string(), (16, 36), (FONT, 14).into_font()))
            .map_err(err)?;
        let mut chart = ChartBuilder::on(&body)
            .margin(30)
            .build_cartesian_2d(-1.15f64..1.15f64, -1.15f64..1.15f64)
            .map_err(err)?;
        let grey = RGBColor(170, 170, 170);
        for (r, label) in rings {
            let ring = circle(*r);
            chart
                .draw_series(LineSeries::new(ring, grey.stroke_width(1)))
                .map_err(err)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    label.clone(),
                    (r * 0.2588, r * 0.9659),
                    (FONT, 12).into_font().color(&RGBColor(110, 110, 110)),
                )))
                .map_err(err)?;
        }
        for k in 0..12 {
            let a = f64::from(k) * 30f64.to_radians();
            chart
                .draw_series(LineSeries::new(
                    vec![(0.0, 0.0), (a.cos(), a.sin())],
                    grey.stroke_width(1),
                ))
                .map_err(err)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("{}°", k * 30),
                    (1.08 * a.cos() - 0.04, 1.08 * a.sin() + 0.02),
                    (FONT, 13).into_font(),
                )))
                .map_err(err)?;
        }
        for (i, (label, pts)) in lines.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()];
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(err)?
                .label(label.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 13))
            .draw()
            .map_err(err)?;
        Ok(())
    }
    let rings: Vec<(f64, String)> = (1..=4)
        .map(|k| {
            let db = lo + 10.0 * f64::from(k);
            (f64::from(k) / 4.0, format!("{db:.0} dB"))
        })
        .collect();
    let sub = format!(
        "radius: 10 log10({unit}) from {lo:.0} dB (centre; lower values drawn there) to {hi:.0} dB; azimuth counter-clockwise from +x"
    );
    render(
        path,
        (820, 880),
        |r| draw(r, title, &sub, &lines, &rings),
        |r| draw(r, title, &sub, &lines, &rings),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_svg_and_refuses_curves_without_a_positive_value() {
        let dir = tempfile::tempdir().unwrap();
        let ring = PolarCurve {
            label: "elevation 0 deg".into(),
            points: (0..36)
                .map(|k| (10.0 * f64::from(k), 1.0 + f64::from(k)))
                .collect(),
        };
        let a = dir.path().join("a.svg");
        polar(&a, "t", "m^2", std::slice::from_ref(&ring)).unwrap();
        let svg = std::fs::read_to_string(&a).unwrap();
        assert!(svg.contains("elevation 0 deg"));
        let zeros = PolarCurve {
            label: "zeros".into(),
            points: vec![(0.0, 0.0), (90.0, 0.0)],
        };
        assert!(matches!(
            polar(&dir.path().join("b.svg"), "t", "m^2", &[zeros]),
            Err(PlotError::Empty { .. })
        ));
    }
}
