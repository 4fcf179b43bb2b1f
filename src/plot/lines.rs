//! Line plots: [`loglog`] and [`lines`].

use std::ops::Range;
use std::path::Path;

use plotters::prelude::*;
use plotters::style::RGBColor;
use plotters::style::text_anchor::{HPos, VPos};

use super::{Area, Axis, Coords, Layout, Pens, PlotError, Series, count, legend_box, write_png};

const WIDTH: u32 = 1000;
const HEIGHT: u32 = 700;
/// Series with more points than this are drawn as plain lines (no markers).
const MAX_MARKED_POINTS: usize = 60;

/// Tableau-10 palette.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Log-log plot, one line+markers per series, legend, axis labels, 1000x700
/// px PNG. Non-positive and non-finite points are dropped (noted on the plot);
/// if nothing is left, a PNG with a "no data" note is still written.
pub fn loglog(
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
) -> Result<(), PlotError> {
    let pens = Pens::new()?;
    let texts = (title, xlabel, ylabel);
    write_png(path, (WIDTH, HEIGHT), |root| {
        draw_lines(root, &pens, texts, series, true).map(drop)
    })
}

/// Linear-axes line plot (e.g. time series), same style as [`loglog`].
/// Non-finite points are dropped.
pub fn lines(
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
) -> Result<(), PlotError> {
    let pens = Pens::new()?;
    let texts = (title, xlabel, ylabel);
    write_png(path, (WIDTH, HEIGHT), |root| {
        draw_lines(root, &pens, texts, series, false).map(drop)
    })
}

#[derive(Clone, Copy)]
enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
}

const MARKERS: [Marker; 4] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
];

/// Colour and marker of series `i` (colours cycle first).
fn series_style(i: usize) -> (RGBColor, Marker) {
    (
        PALETTE[i % PALETTE.len()],
        MARKERS[(i / PALETTE.len()) % MARKERS.len()],
    )
}

fn draw_marker(
    root: &Area,
    (x, y): (i32, i32),
    marker: Marker,
    color: RGBColor,
) -> Result<(), String> {
    let st = color.filled();
    match marker {
        Marker::Circle => root.draw(&Circle::new((x, y), 5, st)),
        Marker::Square => root.draw(&Rectangle::new([(x - 4, y - 4), (x + 4, y + 4)], st)),
        Marker::Triangle => root.draw(&TriangleMarker::new((x, y), 6, st)),
        Marker::Diamond => root.draw(&Polygon::new(
            vec![(x, y - 6), (x + 6, y), (x, y + 6), (x - 6, y)],
            st,
        )),
    }
    .map_err(|e| e.to_string())
}

/// Pick the plot corner where a `w`x`h` px legend box (inset by `inset`)
/// covers the fewest curve samples; returns the box's top-left corner.
fn legend_origin(
    curves: &[Vec<(i32, i32)>],
    (px, py): &(Range<i32>, Range<i32>),
    (w, h): (i32, i32),
    inset: i32,
) -> (i32, i32) {
    let (left, right) = (px.start + inset, px.end - inset - w);
    let (top, bottom) = (py.start + inset, py.end - inset - h);
    // Preference order on ties: upper right, upper left, lower right, lower left.
    let corners = [(right, top), (left, top), (right, bottom), (left, bottom)];
    let mut counts = [0usize; 4];
    let mut visit = |x: f64, y: f64| {
        let m = 6.0;
        for (k, &(cx, cy)) in corners.iter().enumerate() {
            let (cx, cy) = (cx as f64, cy as f64);
            if x >= cx - m && x <= cx + w as f64 + m && y >= cy - m && y <= cy + h as f64 + m {
                counts[k] += 1;
            }
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
    let best = (0..4).min_by_key(|&k| counts[k]).unwrap_or(0);
    corners[best]
}

/// Draw a line plot on `root`; returns where data coordinates land.
pub(super) fn draw_lines(
    root: &Area,
    pens: &Pens,
    texts: (&str, &str, &str),
    series: &[Series],
    log: bool,
) -> Result<Coords, String> {
    // Filter and (for log plots) transform the data.
    let mut dropped = 0usize;
    let data: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|s| {
            let kept: Vec<(f64, f64)> = (s.points.iter())
                .filter(|(x, y)| x.is_finite() && y.is_finite() && (!log || (*x > 0.0 && *y > 0.0)))
                .map(|&(x, y)| if log { (x.log10(), y.log10()) } else { (x, y) })
                .collect();
            dropped += s.points.len() - kept.len();
            kept
        })
        .collect();
    let (mut xmin, mut xmax, mut ymin, mut ymax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in data.iter().flatten() {
        (xmin, xmax) = (xmin.min(x), xmax.max(x));
        (ymin, ymax) = (ymin.min(y), ymax.max(y));
    }
    let empty = xmin > xmax;
    if empty {
        (xmin, xmax, ymin, ymax) = (0.0, 1.0, 0.0, 1.0);
    }
    let axis = if log { Axis::log } else { Axis::linear };
    let (x_axis, y_axis) = (axis(xmin, xmax), axis(ymin, ymax));
    let layout = Layout::new(pens, texts, x_axis, y_axis, None, 0);
    let mut chart = layout.chart(root, Some((0.16, 0.05)))?;

    // Curves.
    let mut pixel_curves = Vec::with_capacity(data.len());
    for (i, pts) in data.iter().enumerate() {
        let color = series_style(i).0;
        let line = LineSeries::new(pts.iter().copied(), color.stroke_width(2));
        chart.draw_series(line).map_err(|e| e.to_string())?;
        pixel_curves.push(
            pts.iter()
                .map(|p| chart.backend_coord(p))
                .collect::<Vec<_>>(),
        );
    }
    let area = layout.frame(root, &mut chart)?;
    for (i, pix) in pixel_curves.iter().enumerate() {
        if pix.len() <= MAX_MARKED_POINTS {
            for &p in pix {
                draw_marker(root, p, series_style(i).1, series_style(i).0)?;
            }
        }
    }

    // Legend: series with a label and at least one drawable point.
    let entries: Vec<usize> = (0..series.len())
        .filter(|&i| !series[i].label.is_empty() && !data[i].is_empty())
        .collect();
    if !entries.is_empty() {
        let pen = &pens.label;
        let (row_h, sample_w, pad) = (pen.cap() * 2, 34, 12);
        let text_w = (entries.iter().map(|&i| pen.width(&series[i].label)))
            .max()
            .unwrap_or(0);
        let w = pad + sample_w + 10 + text_w + pad;
        let h = 2 * pad + row_h * entries.len() as i32 - pen.cap();
        let (lx, ly) = legend_origin(&pixel_curves, &area, (w, h), 12);
        legend_box(root, [(lx, ly), (lx + w, ly + h)])?;
        for (row, &i) in entries.iter().enumerate() {
            let (color, marker) = series_style(i);
            let (x0, y) = (lx + pad, ly + pad + pen.cap() / 2 + row as i32 * row_h);
            let sample = PathElement::new(vec![(x0, y), (x0 + sample_w, y)], color.stroke_width(2));
            root.draw(&sample).map_err(|e| e.to_string())?;
            if data[i].len() <= MAX_MARKED_POINTS {
                draw_marker(root, (x0 + sample_w / 2, y), marker, color)?;
            }
            let at = (x0 + sample_w + 10, y);
            pen.draw(
                root,
                &series[i].label,
                at,
                (HPos::Left, VPos::Center),
                false,
            )?;
        }
    }

    // Notes.
    let big = empty.then_some(if log {
        "no data to plot (no finite, positive points)"
    } else {
        "no data to plot (no finite points)"
    });
    let what = if log {
        "non-positive or non-finite point"
    } else {
        "non-finite point"
    };
    let small = if dropped > 0 && !empty {
        vec![format!("{} omitted", count(dropped, what))]
    } else {
        vec![]
    };
    layout.notes(root, &area, big.map(|m| (m, true)), &small)?;
    Ok(chart.as_coord_spec().clone())
}
