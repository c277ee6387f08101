//! Range profiles over a sweep: σ per range bin (log colour scale), one column per aspect.

use std::path::Path;

use plotters::prelude::*;

use crate::common::{colour_bar, err, render, viridis, Res, FONT};
use crate::image::MAX_DRAWN_CELLS;
use crate::PlotError;

/// One aspect's range profile to draw.
#[derive(Clone, Copy, Debug)]
pub struct ProfileColumn<'a> {
    /// Receiver azimuth, degrees.
    pub azimuth: f64,
    /// Receiver elevation, degrees.
    pub elevation: f64,
    /// Index `k` of its first bin, `[k b, (k + 1) b)`.
    pub first_bin: i64,
    /// σ per bin from `first_bin` on, m².
    pub sigma: &'a [f64],
}

/// The cells drawn: per column (block of `bc` aspects) and row (block of `br` bins from bin
/// `k0`), σ summed over the block's bins and averaged over its aspects.
fn cells(columns: &[ProfileColumn<'_>], k0: i64, rows: usize, bc: usize, br: usize) -> Vec<f64> {
    let (w, h) = (columns.len().div_ceil(bc), rows.div_ceil(br));
    let mut cell = vec![0.0; w * h];
    for (a, c) in columns.iter().enumerate() {
        for (j, &v) in c.sigma.iter().enumerate() {
            let row = (c.first_bin + j as i64 - k0) as usize / br;
            cell[row * w + a / bc] += v;
        }
    }
    for (at, v) in cell.iter_mut().enumerate() {
        // Edge blocks hold fewer aspects.
        *v /= (columns.len() - (at % w) * bc).min(bc) as f64;
    }
    cell
}

/// Draws σ per range bin against aspect, in bins of `bin_m` (range upwards, aspects in the
/// sweep's order left to right), on a log10 colour scale six decades deep (bins at 0 left
/// white). More than 280 aspects or bins (`MAX_DRAWN_CELLS`) are drawn in blocks (σ summed over a
/// block's bins, averaged over its aspects; the title says so).
pub fn range_profile(
    path: &Path,
    title: &str,
    bin_m: f64,
    columns: &[ProfileColumn<'_>],
) -> Result<(), PlotError> {
    let empty = |why: &str| PlotError::Empty {
        file: path.display().to_string(),
        why: why.into(),
    };
    let held = || columns.iter().filter(|c| !c.sigma.is_empty());
    let (Some(k0), Some(k1)) = (
        held().map(|c| c.first_bin).min(),
        held().map(|c| c.first_bin + c.sigma.len() as i64).max(),
    ) else {
        return Err(empty("no aspect sees any facet"));
    };
    if !(bin_m > 0.0 && bin_m.is_finite()) {
        return Err(empty("a bin that is no length"));
    }
    let rows = (k1 - k0) as usize;
    let (bc, br) = (
        columns.len().div_ceil(MAX_DRAWN_CELLS),
        rows.div_ceil(MAX_DRAWN_CELLS),
    );
    let cell = cells(columns, k0, rows, bc, br);
    let w = columns.len().div_ceil(bc);
    let positive = || cell.iter().copied().filter(|v| *v > 0.0);
    let Some(hi) = positive().reduce(f64::max) else {
        return Err(empty("no range bin returns any σ"));
    };
    let log_hi = hi.log10();
    let log_lo = positive().fold(f64::INFINITY, f64::min).log10().max(log_hi - 6.0);
    let title = if bc > 1 || br > 1 {
        format!("{title} (drawn in blocks of {bc} aspects x {br} bins: σ summed over the bins, mean over the aspects)")
    } else {
        title.to_owned()
    };
    let first = &columns[0];
    let last = &columns[columns.len() - 1];
    let x_desc = format!(
        "aspect, in the sweep's order (azimuth {}, elevation {} to azimuth {}, elevation {})",
        first.azimuth, first.elevation, last.azimuth, last.elevation
    );
    let view = View {
        title,
        x_desc,
        cell,
        w,
        block: (bc, br),
        aspects: columns.len(),
        range: (k0 as f64 * bin_m, k1 as f64 * bin_m),
        bin_m,
        log: (log_lo, log_hi),
    };
    render(path, (1100, 640), |r| view.draw(r), |r| view.draw(r))
}

/// What [`range_profile`] draws.
struct View {
    title: String,
    x_desc: String,
    /// Cells row by row from the nearest range, `w` a row ([`cells`]).
    cell: Vec<f64>,
    w: usize,
    /// Aspects and bins a cell.
    block: (usize, usize),
    aspects: usize,
    /// Range from the first bin's start to the last's end, m.
    range: (f64, f64),
    bin_m: f64,
    /// log10 σ at the colour scale's ends.
    log: (f64, f64),
}

impl View {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, plotters::coord::Shift>) -> Res {
        let (head, body) = root.split_vertically(40);
        head.draw(&Text::new(self.title.clone(), (16, 8), (FONT, 18).into_font()))
            .map_err(err)?;
        let (map_area, bar_area) = body.split_horizontally(body.dim_in_pixel().0 as i32 - 130);
        let (r0, r1) = self.range;
        let mut chart = ChartBuilder::on(&map_area)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..self.aspects as f64, r0..r1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(self.x_desc.as_str())
            .y_desc("range (m)")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 14))
            .draw()
            .map_err(err)?;
        let (log_lo, log_hi) = self.log;
        let span = (log_hi - log_lo).max(1e-12);
        let (bc, br) = self.block;
        chart
            .draw_series(
                self.cell
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| **v > 0.0)
                    .map(|(at, v)| {
                        let (col, row) = (at % self.w, at / self.w);
                        let x = (col * bc) as f64;
                        let y = r0 + (row * br) as f64 * self.bin_m;
                        let x1 = ((col + 1) * bc).min(self.aspects) as f64;
                        let y1 = (y + br as f64 * self.bin_m).min(r1);
                        let t = (v.log10().max(log_lo) - log_lo) / span;
                        Rectangle::new([(x, y), (x1, y1)], viridis(t).filled())
                    }),
            )
            .map_err(err)?;
        let caption = if bc > 1 || br > 1 {
            "log10 σ per block (m²)"
        } else {
            "log10 σ per bin (m²)"
        };
        colour_bar(&bar_area, caption, (log_lo, span), (13, 30, 50, 40))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Draws a sweep's profiles, and in blocks a sweep too long to draw cell by cell (the
    /// title and colour bar say so), whose blocks keep each aspect's σ (summed over bins,
    /// averaged over aspects); a sweep that sees nothing is refused.
    #[test]
    fn draws_sigma_per_bin_and_blocks_keep_the_sums() {
        let sigma: Vec<Vec<f64>> = (0..20)
            .map(|a| (0..30).map(|j| (a + j) as f64 * 1e-3).collect())
            .collect();
        let columns: Vec<ProfileColumn<'_>> = sigma
            .iter()
            .enumerate()
            .map(|(a, s)| ProfileColumn {
                azimuth: 5.0 * a as f64,
                elevation: 0.0,
                first_bin: a as i64 - 10,
                sigma: s,
            })
            .collect();
        let dir = tempfile::tempdir().unwrap();
        for ext in ["svg", "png"] {
            let p = dir.path().join(format!("p.{ext}"));
            range_profile(&p, "t", 0.1, &columns).unwrap();
            assert!(std::fs::metadata(&p).unwrap().len() > 1000);
        }
        let svg = std::fs::read_to_string(dir.path().join("p.svg")).unwrap();
        assert!(svg.contains("range (m)") && svg.contains("log10 σ per bin"));
        // 2 x 3 blocks: each block's σ is its aspects' mean of their sums over its bins.
        let total: f64 = sigma.iter().flatten().sum();
        let k0 = -10;
        let rows = 49;
        let cell = cells(&columns, k0, rows, 2, 3);
        assert_eq!(cell.len(), 10 * 17);
        assert!((cell.iter().sum::<f64>() * 2.0 - total).abs() < 1e-12 * total);
        // 600 aspects: drawn in blocks of 3, as the title and the colour bar say.
        let many: Vec<ProfileColumn<'_>> = (0..600).map(|a| columns[a % 20]).collect();
        let p = dir.path().join("many.svg");
        range_profile(&p, "t", 0.1, &many).unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        assert!(
            svg.contains("blocks of 3 aspects x 1 bins") && svg.contains("σ per block"),
            "title"
        );
        let none: Vec<ProfileColumn<'_>> = columns
            .iter()
            .map(|c| ProfileColumn { sigma: &[], ..*c })
            .collect();
        assert!(range_profile(&dir.path().join("n.svg"), "t", 0.1, &none).is_err());
        let zero = vec![0.0; 30];
        let dark: Vec<ProfileColumn<'_>> = columns
            .iter()
            .map(|c| ProfileColumn { sigma: &zero, ..*c })
            .collect();
        assert!(range_profile(&dir.path().join("d.svg"), "t", 0.1, &dark).is_err());
    }
}
