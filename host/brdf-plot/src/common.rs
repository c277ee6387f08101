//! What every chart shares: the bundled font, the palette, the SVG/PNG backend choice, log
//! axis ranges and angle labels.

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::PlotError;

pub(crate) const FONT: &str = "sans-serif";
pub(crate) const PALETTE: [RGBColor; 5] = [
    RGBColor(213, 94, 0),
    RGBColor(0, 114, 178),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
];

pub(crate) fn ensure_font() {
    static DONE: OnceLock<()> = OnceLock::new();
    DONE.get_or_init(|| {
        // The bundled font is valid TrueType; a failure would only lose the text.
        let _ = register_font(FONT, FontStyle::Normal, include_bytes!("../fonts/DejaVuSans.ttf"));
    });
}

pub(crate) type Res = Result<(), String>;

pub(crate) fn err<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

/// Renders with the backend the extension names.
pub(crate) fn render(
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
    match format_of(path)? {
        "svg" => {
            let root = SVGBackend::new(path, size).into_drawing_area();
            root.fill(&WHITE).map_err(err).map_err(wrap)?;
            svg(&root).map_err(wrap)?;
            root.present().map_err(err).map_err(wrap)
        }
        _ => {
            let root = BitMapBackend::new(path, size).into_drawing_area();
            root.fill(&WHITE).map_err(err).map_err(wrap)?;
            png(&root).map_err(wrap)?;
            root.present().map_err(err).map_err(wrap)
        }
    }
}

/// The chart format `path` names, `"svg"` or `"png"` (the extension in either case), after
/// [`check_path`].
fn format_of(path: &Path) -> Result<&'static str, PlotError> {
    check_path(path)?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    Ok(if ext.eq_ignore_ascii_case("svg") {
        "svg"
    } else {
        "png"
    })
}

/// Whether `path` names a chart format this crate writes (`.svg`, `.png`) in a folder that
/// exists: the one rule, checked by the drawing and by commands before long work whose result
/// a chart shows.
pub fn check_path(path: &Path) -> Result<(), PlotError> {
    match path.extension().and_then(|e| e.to_str()) {
        // Either case, as the mesh readers take `.OBJ` and `.STL`.
        Some(e) if e.eq_ignore_ascii_case("svg") || e.eq_ignore_ascii_case("png") => {}
        _ => return Err(PlotError::Format(path.display().to_string())),
    }
    // A folder that does not exist failed only when the drawing was written, after the work.
    match path.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(dir) if !dir.is_dir() => Err(PlotError::Draw {
            file: path.display().to_string(),
            message: format!("the folder {} does not exist", dir.display()),
        }),
        _ => Ok(()),
    }
}

/// Five-stop viridis, `t` in [0, 1].
pub(crate) fn viridis(t: f64) -> RGBColor {
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

/// A vertical viridis colour bar over `lo..lo + span` with its caption; `(font, top, bottom,
/// right)`: the caption's size and the margins, pixels.
pub(crate) fn colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    (lo, span): (f64, f64),
    (font, top, bottom, right): (u32, u32, u32, u32),
) -> Res {
    let mut bar = ChartBuilder::on(area)
        .caption(caption, (FONT, font))
        .margin_top(top)
        .margin_bottom(bottom)
        .margin_right(right)
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

/// Degrees with up to two decimals, trailing zeros dropped (11.25, 30, 78.75).
pub(crate) fn deg(rad: f64) -> String {
    let s = format!("{:.2}", rad.to_degrees());
    s.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// Log-axis range around the data spanning at least two decades, so that the axis always
/// carries labelled ticks.
pub(crate) fn log_range(lo: f64, hi: f64) -> (f64, f64) {
    let (lo, hi) = (lo / 3.0, hi * 3.0);
    if hi / lo >= 100.0 {
        return (lo, hi);
    }
    let mid = (lo * hi).sqrt();
    (mid / 10.0, mid * 10.0)
}

/// The circle of radius `r` about the origin as 181 points, the last equal to the first.
pub(crate) fn circle(r: f64) -> Vec<(f64, f64)> {
    (0..=180)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::TAU / 180.0;
            (r * a.cos(), r * a.sin())
        })
        .collect()
}

/// The charts' test fixture: synthetic in-plane khaki data at 0 and 30 degrees incidence,
/// and the model that made it.
#[cfg(test)]
pub(crate) fn khaki() -> (brdf_fit::Dataset, crate::Fitted) {
    use brdf_core::{AnyModel, ModelKind};
    let p = brdf_core::TABLE1[0].1;
    let data = brdf_fit::synth::in_plane(ModelKind::Six, &p, &[0.0, 30.0], 5.0, 0.01, 7).unwrap();
    let model = AnyModel::new(ModelKind::Six, &p).unwrap();
    let fit = crate::Fitted {
        label: "six".into(),
        model,
        floor: 0.0,
    };
    (data, fit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_runs_from_purple_to_yellow() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(-1.0), viridis(0.0));
    }
}
