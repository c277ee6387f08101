//! Cost against accuracy on log-log axes, with the Pareto front.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::common::{err, log_range, render, Res, FONT, PALETTE};
use crate::PlotError;

/// One method on a cost/accuracy chart.
#[derive(Clone, Debug)]
pub struct TradePoint {
    /// Method name, printed beside its marker.
    pub label: String,
    /// Cost (x, log scale), > 0.
    pub cost: f64,
    /// Error (y, log scale), > 0.
    pub error: f64,
}

/// Errors within this relative difference count as equal when comparing methods (fits that
/// reach the same optimum differ in the last digits).
pub const SAME_ERROR: f64 = 1e-3;

/// Indices of the Pareto front of `points`: no other point is at most as costly and at
/// most as wrong (errors within [`SAME_ERROR`] count as equal) while strictly better in one.
/// Sorted by cost.
pub fn pareto_front(points: &[TradePoint]) -> Vec<usize> {
    let not_worse = |q: f64, p: f64| q <= p * (1.0 + SAME_ERROR);
    let better = |q: f64, p: f64| q < p * (1.0 - SAME_ERROR);
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| {
            let p = &points[i];
            !points.iter().enumerate().any(|(j, q)| {
                j != i
                    && q.cost <= p.cost
                    && not_worse(q.error, p.error)
                    && (q.cost < p.cost || better(q.error, p.error))
            })
        })
        .collect();
    front.sort_by(|&a, &b| points[a].cost.total_cmp(&points[b].cost));
    front
}

/// A log-log chart of error against cost, the Pareto front joined by a line and its points
/// filled, the others hollow; every point labelled.
pub fn tradeoff(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    points: &[TradePoint],
) -> Result<(), PlotError> {
    let file = path.display().to_string();
    let pts: Vec<&TradePoint> = points.iter().filter(|p| p.cost > 0.0 && p.error > 0.0).collect();
    if pts.is_empty() {
        return Err(PlotError::Empty {
            file,
            why: "no point with positive cost and error".into(),
        });
    }
    let (xlo, xhi) = log_range(
        pts.iter().map(|p| p.cost).fold(f64::INFINITY, f64::min),
        pts.iter().map(|p| p.cost).fold(0.0, f64::max),
    );
    let (ylo, yhi) = log_range(
        pts.iter().map(|p| p.error).fold(f64::INFINITY, f64::min),
        pts.iter().map(|p| p.error).fold(0.0, f64::max),
    );
    let front = pareto_front(points);
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        axes: (&str, &str),
        range: ((f64, f64), (f64, f64)),
        points: &[TradePoint],
        front: &[usize],
    ) -> Res {
        // Header: title, the key to the numbered markers (wrapped), the Pareto note.
        let mut key: Vec<Vec<String>> = vec![Vec::new()];
        let mut width = 0;
        for (i, p) in points.iter().enumerate() {
            let item = format!("{} {}", i + 1, p.label);
            let w = 8 * item.len() + 24;
            if width + w > 960 && !key[key.len() - 1].is_empty() {
                key.push(Vec::new());
                width = 0;
            }
            width += w;
            let last = key.len() - 1;
            key[last].push(item);
        }
        let head_h = 64 + 22 * key.len() as u32;
        let (head, body) = root.split_vertically(head_h);
        head.draw(&Text::new(title.to_string(), (16, 8), (FONT, 20).into_font()))
            .map_err(err)?;
        for (r, line) in key.iter().enumerate() {
            head.draw(&Text::new(
                line.join("   "),
                (16, 36 + 22 * r as i32),
                (FONT, 14).into_font(),
            ))
            .map_err(err)?;
        }
        head.draw(&Text::new(
            "filled, joined: Pareto front (nothing both cheaper and more accurate)".to_string(),
            (16, 36 + 22 * key.len() as i32),
            (FONT, 14).into_font(),
        ))
        .map_err(err)?;
        let ((xlo, xhi), (ylo, yhi)) = range;
        let mut chart = ChartBuilder::on(&body)
            .margin(16)
            .x_label_area_size(46)
            .y_label_area_size(80)
            .build_cartesian_2d((xlo..xhi).log_scale(), (ylo..yhi).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(axes.0)
            .y_desc(axes.1)
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 15))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(err)?;
        let line: Vec<(f64, f64)> = front.iter().map(|&i| (points[i].cost, points[i].error)).collect();
        chart
            .draw_series(LineSeries::new(line, PALETTE[1].stroke_width(2)))
            .map_err(err)?;
        for (i, p) in points.iter().enumerate() {
            if !(p.cost > 0.0 && p.error > 0.0) {
                continue;
            }
            let on_front = front.contains(&i);
            let colour = if on_front { PALETTE[1] } else { PALETTE[0] };
            let style = if on_front {
                colour.filled()
            } else {
                colour.stroke_width(2)
            };
            chart
                .draw_series([Circle::new((p.cost, p.error), 6, style)])
                .map_err(err)?;
            // Each marker carries its number; the names are listed above the chart, so
            // that markers at nearly the same place stay unambiguous.
            chart
                .draw_series([Text::new(
                    format!("{}", i + 1),
                    (p.cost * 1.12, p.error * 1.12),
                    (FONT, 14).into_font(),
                )])
                .map_err(err)?;
        }
        Ok(())
    }
    let axes = (x_desc, y_desc);
    let range = ((xlo, xhi), (ylo, yhi));
    render(
        path,
        (1000, 700),
        |r| draw(r, title, axes, range, points, &front),
        |r| draw(r, title, axes, range, points, &front),
    )
}

#[cfg(test)]
mod tradeoff_tests {
    use super::*;

    fn tp(cost: f64, error: f64) -> TradePoint {
        TradePoint {
            label: String::new(),
            cost,
            error,
        }
    }

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let pts = [
            tp(1.0, 1e-2),
            tp(2.0, 1e-4),
            tp(3.0, 1e-3),
            tp(4.0, 1e-4 * (1.0 + 1e-5)),
            tp(5.0, 1e-6),
        ];
        // (3, 1e-3) is dominated by (2, 1e-4); (4, ~1e-4) ties (2, 1e-4) in error and costs more.
        assert_eq!(pareto_front(&pts), vec![0, 1, 4]);
    }
}
