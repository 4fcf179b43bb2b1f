//! Line plots: [`loglog`] and [`lines`].

use std::path::Path;

use plotters::prelude::*;
use plotters::style::RGBColor;

use super::{Area, Axis, Coords, Drawn, LABEL, Layout, PixelBox, PlotError, RIGHT_OF, Series};
use super::{Texts, bounding_box, count, legend_box, notes, value_words, write_png};

const SIZE: (u32, u32) = (1000, 700);
const MAX_MARKED_POINTS: usize = 60;

/// Tableau-10 palette (0xRRGGBB).
const PALETTE: [u32; 10] = [
    0x1f77b4, 0xff7f0e, 0x2ca02c, 0xd62728, 0x9467bd, 0x8c564b, 0xe377c2, 0x7f7f7f, 0xbcbd22,
    0x17becf,
];

/// Log-log plot, 1000x700 px PNG: one line per series, with markers unless
/// it has over 60 points; a legend in the plot corner covering the fewest
/// curve samples; axis labels; power-of-ten tick labels. Non-positive and
/// non-finite points are dropped (noted on the plot); if nothing is left, a
/// PNG with a "no data" note is still written.
pub fn loglog(
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    s: &[Series],
) -> Result<(), PlotError> {
    write_png(path, SIZE, |root| {
        draw_lines(root, (title, xlabel, ylabel), s, true)
    })
}

/// Linear-axes line plot (e.g. time series), same style as [`loglog`].
/// Non-finite points are dropped.
pub fn lines(
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    s: &[Series],
) -> Result<(), PlotError> {
    write_png(path, SIZE, |root| {
        draw_lines(root, (title, xlabel, ylabel), s, false)
    })
}

/// Scatter plot on linear axes, same style as [`lines`]: every point marked,
/// no connecting lines (e.g. a quantity of a sweep against one of its
/// inputs). Non-finite points are dropped.
pub fn scatter(
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    s: &[Series],
) -> Result<(), PlotError> {
    write_png(path, SIZE, |root| {
        draw_plot(root, (title, xlabel, ylabel), s, false, true)
    })
}

/// One panel of [`stacked`]: title, x and y labels, series, and whether it is a scatter
/// plot (markers only) rather than lines.
#[derive(Clone, Debug)]
pub struct Panel {
    pub title: String,
    pub xlabel: String,
    pub ylabel: String,
    pub series: Vec<Series>,
    pub points: bool,
}

/// Panels stacked top to bottom on one 1000 px wide PNG, 450 px per panel, each drawn as
/// [`lines`] or [`scatter`] (e.g. magnitudes against time above the injection pressure on
/// the same time axis).
pub fn stacked(path: &Path, panels: &[Panel]) -> Result<(), PlotError> {
    let n = panels.len().max(1);
    let (w, h) = (SIZE.0, PANEL_HEIGHT);
    write_png(path, (w, h * n as u32), |root| {
        // Each panel is drawn on a bitmap of its own (the plot's layout works in the pixels of
        // a whole image) and copied into its place.
        for (i, p) in panels.iter().enumerate() {
            let mut buf = vec![255u8; (w * h * 3) as usize];
            {
                let area = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                let texts = (&p.title[..], &p.xlabel[..], &p.ylabel[..]);
                draw_plot(&area, texts, &p.series, false, p.points)?;
                area.present()?;
            }
            let y0 = (i as u32 * h) as i32;
            for (k, px) in buf.chunks_exact(3).enumerate() {
                let (x, y) = ((k as u32 % w) as i32, (k as u32 / w) as i32);
                root.draw_pixel((x, y0 + y), &RGBColor(px[0], px[1], px[2]))?;
            }
        }
        Ok(())
    })
}

/// Height of one panel of [`stacked`], px.
const PANEL_HEIGHT: u32 = 450;

/// Colour of series `i` (cycling), and its marker: circle, square, triangle
/// or diamond, changing after each cycle of colours.
fn series_style(i: usize) -> (RGBColor, usize) {
    let c = PALETTE[i % PALETTE.len()];
    let rgb = RGBColor((c >> 16) as u8, (c >> 8) as u8, c as u8);
    (rgb, (i / PALETTE.len()) % 4)
}

fn draw_marker(root: &Area, (x, y): (i32, i32), (color, marker): (RGBColor, usize)) -> Drawn {
    let st = color.filled();
    let diamond = vec![(x, y - 6), (x + 6, y), (x, y + 6), (x - 6, y)];
    match marker {
        0 => root.draw(&Circle::new((x, y), 5, st)),
        1 => root.draw(&Rectangle::new([(x - 4, y - 4), (x + 4, y + 4)], st)),
        2 => root.draw(&TriangleMarker::new((x, y), 6, st)),
        _ => root.draw(&Polygon::new(diamond, st)),
    }
}

/// Top-left corner of a `w`x`h` px legend box, inset 12 px into the corner of
/// the plotting area `(px, py)` where it covers the fewest curve samples.
fn legend_origin(curves: &[Vec<(i32, i32)>], (px, py): &PixelBox, w: i32, h: i32) -> (i32, i32) {
    let (left, right) = (px.start + 12, px.end - 12 - w);
    let (top, bottom) = (py.start + 12, py.end - 12 - h);
    // Preference order on ties: upper right, upper left, lower right, lower left.
    let corners = [(right, top), (left, top), (right, bottom), (left, bottom)];
    let mut counts = [0usize; 4];
    let mut visit = |x: f64, y: f64| {
        for (k, &(cx, cy)) in corners.iter().enumerate() {
            let (x0, y0) = ((cx - 6) as f64, (cy - 6) as f64);
            let (x1, y1) = (x0 + (w + 12) as f64, y0 + (h + 12) as f64);
            counts[k] += usize::from(x >= x0 && x <= x1 && y >= y0 && y <= y1);
        }
    };
    for pts in curves {
        for seg in pts.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
            let n = ((dx * dx + dy * dy).sqrt() / 3.0).ceil().clamp(1.0, 1000.0) as usize;
            for i in 0..n {
                let f = i as f64 / n as f64;
                visit(a.0 as f64 + f * dx, a.1 as f64 + f * dy);
            }
        }
        if let Some(&(x, y)) = pts.last() {
            visit(x as f64, y as f64);
        }
    }
    corners[(0..4).min_by_key(|&k| counts[k]).unwrap_or(0)]
}

/// Draw a line plot on `root`; returns where data coordinates land.
pub(super) fn draw_lines(root: &Area, texts: Texts, series: &[Series], log: bool) -> Drawn<Coords> {
    draw_plot(root, texts, series, log, false)
}

/// Draw a line plot, or with `points` a scatter plot (markers only, every point), on `root`;
/// returns where data coordinates land.
fn draw_plot(
    root: &Area,
    texts: Texts,
    series: &[Series],
    log: bool,
    points: bool,
) -> Drawn<Coords> {
    // Filter and (for log plots) transform the data.
    let keep =
        |&&(x, y): &&(f64, f64)| x.is_finite() && y.is_finite() && (!log || x > 0.0 && y > 0.0);
    let to_plot = |&(x, y): &(f64, f64)| if log { (x.log10(), y.log10()) } else { (x, y) };
    let kept = |s: &Series| s.points.iter().filter(keep).map(to_plot).collect();
    let data: Vec<Vec<(f64, f64)>> = series.iter().map(kept).collect();
    let dropped: usize = series.iter().map(|s| s.points.len()).sum::<usize>()
        - data.iter().map(Vec::len).sum::<usize>();
    let b = bounding_box(data.iter().flatten().map(|&(x, y)| [x, y]));
    let empty = b[0] > b[1];
    let [xmin, xmax, ymin, ymax] = if empty { [0.0, 1.0, 0.0, 1.0] } else { b };
    let axis = if log { Axis::log } else { Axis::linear };
    let layout = Layout::new(texts, axis(xmin, xmax), axis(ymin, ymax), None, 0);
    let mut chart = layout.chart(root, Some((0.16, 0.05)))?;
    for (i, pts) in data.iter().enumerate().filter(|_| !points) {
        let line = LineSeries::new(pts.iter().copied(), series_style(i).0.stroke_width(2));
        chart.draw_series(line)?;
    }
    let to_px = |pts: &Vec<(f64, f64)>| pts.iter().map(|p| chart.backend_coord(p)).collect();
    let curves: Vec<Vec<(i32, i32)>> = data.iter().map(to_px).collect();
    let area = layout.frame(root, &mut chart)?;
    for (i, pix) in curves.iter().enumerate() {
        for &p in pix
            .iter()
            .filter(|_| points || pix.len() <= MAX_MARKED_POINTS)
        {
            draw_marker(root, p, series_style(i))?;
        }
    }

    // Legend: series with a label and at least one drawable point.
    let entries: Vec<usize> = (0..series.len())
        .filter(|&i| !series[i].label.is_empty() && !data[i].is_empty())
        .collect();
    if !entries.is_empty() {
        let (row_h, sample_w, pad) = (LABEL.cap() * 2, 34, 12);
        let text_w = entries.iter().map(|&i| LABEL.width(&series[i].label)).max();
        let w = pad + sample_w + 10 + text_w.unwrap_or(0) + pad;
        let h = 2 * pad + row_h * entries.len() as i32 - LABEL.cap();
        let (lx, ly) = legend_origin(&curves, &area, w, h);
        legend_box(root, [(lx, ly), (lx + w, ly + h)])?;
        for (row, &i) in entries.iter().enumerate() {
            let (x0, y) = (lx + pad, ly + pad + LABEL.cap() / 2 + row as i32 * row_h);
            let style = series_style(i);
            let sample = vec![(x0, y), (x0 + sample_w, y)];
            if !points {
                root.draw(&PathElement::new(sample, style.0.stroke_width(2)))?;
            }
            if points || data[i].len() <= MAX_MARKED_POINTS {
                draw_marker(root, (x0 + sample_w / 2, y), style)?;
            }
            LABEL.draw(root, &series[i].label, (x0 + sample_w + 10, y), RIGHT_OF)?;
        }
    }

    let [good, bad] = value_words(log);
    let big = format!("no data to plot (no {good} points)");
    let omitted = format!("{} omitted", count(dropped, &format!("{bad} point")));
    let small = (dropped > 0 && !empty).then_some(omitted);
    notes(root, &area, empty.then_some((&big, true)), small.as_slice())?;
    Ok(chart.as_coord_spec().clone())
}
