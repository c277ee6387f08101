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

/// Most cells drawn along an image's longer side. Each panel of the picture is about 560
/// pixels wide, so finer cells cannot be seen; a cell is a rectangle of its own in an SVG (a
/// 4,094-pixel image wrote a 2.27 GB SVG in 27 s). Larger images are drawn in square blocks
/// of pixels: σ the mean per pixel of the block, range the mean of the block's pixels that
/// see a surface.
pub const MAX_DRAWN_CELLS: usize = 280;

/// `image` in blocks of `b` × `b` pixels (see [`MAX_DRAWN_CELLS`]): widths, σ and range.
fn blocks(image: &Pixels<'_>, b: usize) -> (usize, usize, Vec<f64>, Vec<f64>) {
    let (w, h) = (image.width.div_ceil(b), image.height.div_ceil(b));
    let (mut sigma, mut range, mut seen) = (vec![0.0; w * h], vec![0.0; w * h], vec![0u32; w * h]);
    for k in 0..image.width * image.height {
        let (col, row) = (k % image.width, k / image.width);
        let at = (row / b) * w + col / b;
        sigma[at] += image.sigma[k];
        if image.range[k].is_finite() {
            range[at] += image.range[k];
            seen[at] += 1;
        }
    }
    for (at, s) in sigma.iter_mut().enumerate() {
        // The block's pixels inside the image (edge blocks are cut).
        let cols = (image.width - (at % w) * b).min(b);
        let rows = (image.height - (at / w) * b).min(b);
        *s /= (cols * rows) as f64;
        range[at] = if seen[at] == 0 {
            f64::NAN
        } else {
            range[at] / f64::from(seen[at])
        };
    }
    (w, h, sigma, range)
}

/// Draws σ per pixel on a log10 colour scale (pixels at 0 left white) and the range image on
/// a linear one, side by side, axes in metres across the line of sight; an image wider than
/// 280 cells (`MAX_DRAWN_CELLS`) in blocks of pixels (the title says so).
pub fn laser_image(path: &Path, title: &str, image: &Pixels<'_>) -> Result<(), PlotError> {
    let n = image.width * image.height;
    if n == 0 || image.sigma.len() != n || image.range.len() != n {
        return Err(PlotError::Empty {
            file: path.display().to_string(),
            why: "no pixels, or pixel arrays of another size".into(),
        });
    }
    let b = image.width.max(image.height).div_ceil(MAX_DRAWN_CELLS);
    if b > 1 {
        let (width, height, sigma, range) = blocks(image, b);
        let drawn = Pixels {
            width,
            height,
            pixel_m: image.pixel_m * b as f64,
            sigma: &sigma,
            range: &range,
        };
        let title = format!("{title} (drawn in blocks of {b} x {b} pixels: σ their mean per pixel)");
        return laser_image(path, &title, &drawn);
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

    /// A large image is drawn in blocks (a 4,094-pixel image wrote a 2.27 GB SVG): the SVG
    /// stays small, the title says so, and a block's σ is the mean per pixel of its pixels
    /// (edge blocks cut to the image), its range the mean of those that see a surface.
    #[test]
    fn a_large_image_is_drawn_in_blocks() {
        let (w, h) = (1001, 700);
        let sigma: Vec<f64> = (0..w * h).map(|k| if k % 2 == 0 { 2.0 } else { 4.0 }).collect();
        let range: Vec<f64> = (0..w * h)
            .map(|k| if k % 3 == 0 { f64::NAN } else { 5.0 })
            .collect();
        let img = Pixels {
            width: w,
            height: h,
            pixel_m: 0.01,
            sigma: &sigma,
            range: &range,
        };
        let b = w.div_ceil(MAX_DRAWN_CELLS);
        let (bw, bh, bs, br) = blocks(&img, b);
        assert_eq!((bw, bh), (w.div_ceil(b), h.div_ceil(b)));
        assert!(bs.iter().all(|s| (s - 3.0).abs() < 0.02), "{:?}", &bs[..4]);
        assert!(br.iter().all(|r| *r == 5.0));
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("big.svg");
        laser_image(&p, "t", &img).unwrap();
        assert!(std::fs::metadata(&p).unwrap().len() < 40_000_000);
        assert!(std::fs::read_to_string(&p)
            .unwrap()
            .contains(&format!("blocks of {b} x {b} pixels")));
    }
}
