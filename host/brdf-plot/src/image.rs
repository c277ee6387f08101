//! A laser image: σ per pixel (log colour scale) and the range image beside it, each with its
//! colour bar.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::common::{colour_bar, err, render, viridis, Res, FONT};
use crate::PlotError;

/// One image to draw: `width` × `height` pixels of side `pixel_m`, row by row from the top.
#[derive(Clone, Copy, Debug)]
pub struct Pixels<'a> {
    /// Pixels across.
    pub width: usize,
    /// Pixels down.
    pub height: usize,
    /// Pixel side, m.
    pub pixel_m: f64,
    /// σ per pixel, m² (0 where nothing is seen).
    pub sigma: &'a [f64],
    /// Range per pixel, m (NaN where nothing is seen).
    pub range: &'a [f64],
}

/// Draws σ per pixel on a log10 colour scale (pixels at 0 left white) and the range image on
/// a linear one, side by side, axes in metres across the line of sight.
pub fn laser_image(path: &Path, title: &str, image: &Pixels<'_>) -> Result<(), PlotError> {
    let n = image.width * image.height;
    if n == 0 || image.sigma.len() != n || image.range.len() != n {
        return Err(PlotError::Empty {
            file: path.display().to_string(),
            why: "no pixels, or pixel arrays of another size".into(),
        });
    }
    let positive: Vec<f64> = image.sigma.iter().copied().filter(|v| *v > 0.0).collect();
    if positive.is_empty() {
        return Err(PlotError::Empty {
            file: path.display().to_string(),
            why: "no pixel returns any σ at this aspect".into(),
        });
    }
    let log_hi = positive.iter().copied().fold(f64::NEG_INFINITY, f64::max).log10();
    // Six decades below the brightest pixel at most: dimmer ones share the darkest colour.
    let log_lo = positive
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .log10()
        .max(log_hi - 6.0);
    let ranges: Vec<f64> = image.range.iter().copied().filter(|r| r.is_finite()).collect();
    let r_lo = ranges.iter().copied().fold(f64::INFINITY, f64::min);
    let r_hi = ranges.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    fn panel<DB: DrawingBackend>(
        area: &DrawingArea<DB, Shift>,
        img: &Pixels<'_>,
        value: &dyn Fn(usize) -> Option<f64>,
        (lo, hi): (f64, f64),
        bar_desc: &str,
    ) -> Res {
        let span = (hi - lo).max(1e-12);
        let (w, h) = (img.width as f64 * img.pixel_m, img.height as f64 * img.pixel_m);
        let (map_area, bar_area) = area.split_horizontally(area.dim_in_pixel().0 as i32 - 130);
        let mut chart = ChartBuilder::on(&map_area)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(0f64..w, 0f64..h)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("across (m)")
            .y_desc("up (m)")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 14))
            .draw()
            .map_err(err)?;
        let p = img.pixel_m;
        chart
            .draw_series((0..img.width * img.height).filter_map(|k| {
                let v = value(k)?;
                let (col, row) = (k % img.width, k / img.width);
                let (x, y) = (col as f64 * p, h - (row + 1) as f64 * p);
                Some(Rectangle::new(
                    [(x, y), (x + p, y + p)],
                    viridis((v - lo) / span).filled(),
                ))
            }))
            .map_err(err)?;
        colour_bar(&bar_area, bar_desc, (lo, span), (13, 30, 50, 40))?;
        Ok(())
    }
    fn both<DB: DrawingBackend>(
        root: &DrawingArea<DB, Shift>,
        title: &str,
        img: &Pixels<'_>,
        sigma_scale: (f64, f64),
        range_scale: (f64, f64),
    ) -> Res {
        let (head, body) = root.split_vertically(40);
        head.draw(&Text::new(title.to_owned(), (16, 8), (FONT, 18).into_font()))
            .map_err(err)?;
        let (left, right) = body.split_horizontally(body.dim_in_pixel().0 as i32 / 2);
        let (lo, _) = sigma_scale;
        let sigma = |k: usize| {
            let v = img.sigma[k];
            (v > 0.0).then(|| v.log10().max(lo))
        };
        panel(&left, img, &sigma, sigma_scale, "log10 σ per pixel (m²)")?;
        let range = |k: usize| img.range[k].is_finite().then(|| img.range[k]);
        panel(&right, img, &range, range_scale, "range (m)")
    }
    let size = (1400, 640);
    render(
        path,
        size,
        |r| both(r, title, image, (log_lo, log_hi), (r_lo, r_hi)),
        |r| both(r, title, image, (log_lo, log_hi), (r_lo, r_hi)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_sigma_and_range_side_by_side() {
        let (w, h) = (8, 6);
        let sigma: Vec<f64> = (0..w * h)
            .map(|k| if k % 5 == 0 { 0.0 } else { k as f64 * 1e-3 })
            .collect();
        let range: Vec<f64> = (0..w * h)
            .map(|k| if k % 5 == 0 { f64::NAN } else { k as f64 * 0.1 })
            .collect();
        let img = Pixels {
            width: w,
            height: h,
            pixel_m: 0.25,
            sigma: &sigma,
            range: &range,
        };
        let dir = tempfile::tempdir().unwrap();
        for ext in ["svg", "png"] {
            let p = dir.path().join(format!("i.{ext}"));
            laser_image(&p, "t", &img).unwrap();
            assert!(std::fs::metadata(&p).unwrap().len() > 1000);
        }
        let svg = std::fs::read_to_string(dir.path().join("i.svg")).unwrap();
        assert!(svg.contains("log10 σ per pixel") && svg.contains("range (m)"));
        let dark = vec![0.0; w * h];
        let none = Pixels { sigma: &dark, ..img };
        assert!(laser_image(&dir.path().join("n.svg"), "t", &none).is_err());
    }
}
