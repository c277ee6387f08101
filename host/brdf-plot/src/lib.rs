//! Plots of measured and fitted BRDFs, as the paper shows them: in-plane curves per
//! incidence angle (its Fig. 2a–c), a BRDF map over the viewing hemisphere (Fig. 2d–f), and
//! relative residuals against angle. The output format follows the file extension (`.svg`
//! or `.png`). Text uses the bundled DejaVu Sans, so a PNG is the same on every machine.
//!
//! ```no_run
//! use brdf_core::{AnyModel, ModelKind};
//! use brdf_fit::synth;
//! use brdf_plot::{in_plane, Fitted};
//!
//! let p = [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2];
//! let data = synth::in_plane(ModelKind::Six, &p, &[0.0, 10.0, 30.0], 5.0, 0.01, 7).unwrap();
//! let model = AnyModel::new(ModelKind::Six, &p).unwrap();
//! let fits = [Fitted { label: "six".into(), model }];
//! in_plane("khaki.png".as_ref(), "Khaki, in-plane", &data, &fits).unwrap();
//! ```

use std::path::Path;
use std::sync::OnceLock;

use brdf_core::{AnyModel, Brdf};
use brdf_fit::Dataset;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

/// Why a plot could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The backend failed (file not writable, ...).
    #[error("{file}: {message}")]
    Draw {
        /// Output path.
        file: String,
        /// Backend message.
        message: String,
    },
    /// The extension is neither `.svg` nor `.png`.
    #[error("{0}: unknown plot format (use .svg or .png)")]
    Format(String),
    /// Nothing to draw (e.g. no in-plane points).
    #[error("{file}: nothing to plot: {why}")]
    Empty {
        /// Output path.
        file: String,
        /// What was missing.
        why: String,
    },
}

/// A fitted model to draw, with its legend text (say the model and its error).
#[derive(Clone, Debug)]
pub struct Fitted {
    /// Legend text, e.g. `six (RMS rel 4.9%)`.
    pub label: String,
    /// The model.
    pub model: AnyModel<f64>,
}

const FONT: &str = "sans-serif";
const PALETTE: [RGBColor; 5] = [
    RGBColor(213, 94, 0),
    RGBColor(0, 114, 178),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
];

fn ensure_font() {
    static DONE: OnceLock<()> = OnceLock::new();
    DONE.get_or_init(|| {
        // The bundled font is valid TrueType; a failure would only lose the text.
        let _ = register_font(FONT, FontStyle::Normal, include_bytes!("../fonts/DejaVuSans.ttf"));
    });
}

type Res = Result<(), String>;

fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

/// Renders with the backend the extension names.
fn render(
    path: &Path,
    size: (u32, u32),
    svg: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Res,
    png: impl FnOnce(&DrawingArea<BitMapBackend, Shift>) -> Res,
) -> Result<(), PlotError> {
    ensure_font();
    let file = path.display().to_string();
    let wrap = |message: String| PlotError::Draw {
        file: file.clone(),
        message,
    };
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => {
            let root = SVGBackend::new(path, size).into_drawing_area();
            root.fill(&WHITE).map_err(err).map_err(wrap)?;
            svg(&root).map_err(wrap)?;
            root.present().map_err(err).map_err(wrap)
        }
        Some("png") => {
            let root = BitMapBackend::new(path, size).into_drawing_area();
            root.fill(&WHITE).map_err(err).map_err(wrap)?;
            png(&root).map_err(wrap)?;
            root.present().map_err(err).map_err(wrap)
        }
        _ => Err(PlotError::Format(file)),
    }
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

/// Degrees with up to two decimals, trailing zeros dropped (11.25, 30, 78.75).
fn deg(rad: f64) -> String {
    let s = format!("{:.2}", rad.to_degrees());
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
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

/// Log-axis range around the data spanning at least two decades, so that the axis always
/// carries labelled ticks.
fn log_range(lo: f64, hi: f64) -> (f64, f64) {
    let (lo, hi) = (lo / 3.0, hi * 3.0);
    if hi / lo >= 100.0 {
        return (lo, hi);
    }
    let mid = (lo * hi).sqrt();
    (mid / 10.0, mid * 10.0)
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
            let lo = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
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

/// Five-stop viridis, `t` in [0, 1].
fn viridis(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = t.clamp(0.0, 1.0) * 4.0;
    let k = (t.floor() as usize).min(3);
    let f = t - k as f64;
    let (a, b) = (STOPS[k], STOPS[k + 1]);
    let mix = |x: f64, y: f64| (x + (y - x) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

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
            let ring: Vec<(f64, f64)> = (0..=180)
                .map(|k| {
                    let a = f64::from(k) * std::f64::consts::TAU / 180.0;
                    (r * a.cos(), r * a.sin())
                })
                .collect();
            chart
                .draw_series(LineSeries::new(ring, WHITE.mix(0.6).stroke_width(1)))
                .map_err(err)?;
        }
        let mut bar = ChartBuilder::on(&bar_area)
            .caption("log10 BRDF (1/sr)", (FONT, 15))
            .margin_top(40)
            .margin_bottom(56)
            .margin_right(50)
            .y_label_area_size(50)
            .build_cartesian_2d(0f64..1f64, lo..lo + span)
            .map_err(err)?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .label_style((FONT, 14))
            .draw()
            .map_err(err)?;
        let steps = 100;
        bar.draw_series((0..steps).map(|k| {
            let a = lo + span * k as f64 / steps as f64;
            let b = lo + span * (k + 1) as f64 / steps as f64;
            Rectangle::new([(0.0, a), (1.0, b)], viridis((a - lo) / span).filled())
        }))
        .map_err(err)?;
        Ok(())
    }
    render(
        path,
        (820, 770),
        |r| draw(r, title, theta_i, &cells, (lo, span)),
        |r| draw(r, title, theta_i, &cells, (lo, span)),
    )
}

/// (c) Relative residuals `(f - y) / y` in percent against the viewing angle: the signed
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
                (s * p.theta_r.to_degrees(), 100.0 * (f - p.brdf) / p.brdf)
            })
            .collect();
        series.push((ti, pts));
    }
    let all = series.iter().flat_map(|s| s.1.iter().map(|p| p.1));
    let bound = all.fold(1.0f64, |m, v| m.max(v.abs())).min(1000.0) * 1.1;
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        label: &str,
        series: &[(f64, Vec<(f64, f64)>)],
        bound: f64,
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
            .y_desc("(model - measured) / measured (%)")
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
        |r| draw(r, title, &fit.label, &series, bound),
        |r| draw(r, title, &fit.label, &series, bound),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf_core::ModelKind;
    use brdf_fit::synth;

    #[test]
    fn writes_svg_and_png_and_refuses_unknown_formats() {
        let p = [0.2545, 21.8031, -27.5721, 0.6705, 0.3676, 1.2];
        let data = synth::in_plane(ModelKind::Six, &p, &[0.0, 30.0], 5.0, 0.01, 7).unwrap();
        let model = AnyModel::new(ModelKind::Six, &p).unwrap();
        let fit = Fitted {
            label: "six".into(),
            model,
        };
        let dir = tempfile::tempdir().unwrap();
        for ext in ["svg", "png"] {
            let a = dir.path().join(format!("a.{ext}"));
            in_plane(&a, "t", &data, std::slice::from_ref(&fit)).unwrap();
            let b = dir.path().join(format!("b.{ext}"));
            hemisphere_map(&b, "t", &fit.model, 0.5).unwrap();
            let c = dir.path().join(format!("c.{ext}"));
            residuals(&c, "t", &data, &fit).unwrap();
            for f in [a, b, c] {
                assert!(std::fs::metadata(&f).unwrap().len() > 1000, "{}", f.display());
            }
        }
        let svg = std::fs::read_to_string(dir.path().join("a.svg")).unwrap();
        assert!(svg.contains("theta_i = 30 deg") && svg.contains("BRDF (1/sr)"));
        assert!(matches!(
            in_plane(&dir.path().join("x.gif"), "t", &data, &[fit]),
            Err(PlotError::Format(_))
        ));
    }
}

/// One method on a cost/accuracy chart.
#[derive(Clone, Debug)]
pub struct TradePoint {
    /// Method name, printed beside its marker.
    pub label: String,
    /// Cost (x, log scale), > 0.
    pub cost: f64,
    /// Error (y, log scale), > 0.
    pub error: f64,
    /// Spread of the error over repetitions (worst), drawn as a bar up from `error`; `None`
    /// for a single figure.
    pub worst: Option<f64>,
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
        pts.iter()
            .map(|p| p.worst.unwrap_or(p.error).max(p.error))
            .fold(0.0, f64::max),
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
            if let Some(w) = p.worst.filter(|w| *w > p.error) {
                chart
                    .draw_series(LineSeries::new(
                        [(p.cost, p.error), (p.cost, w)],
                        colour.stroke_width(1),
                    ))
                    .map_err(err)?;
            }
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
            worst: None,
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
            let ring: Vec<(f64, f64)> = (0..=180)
                .map(|k| {
                    let a = f64::from(k) * std::f64::consts::TAU / 180.0;
                    (r * a.cos(), r * a.sin())
                })
                .collect();
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
