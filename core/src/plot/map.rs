//! Maps in metres with equal x/y scales and a viridis colour bar:
//! [`network`] (segments as coloured lines) and [`fracture_map`] (filled
//! quads over a light-grey mesh).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::RGBColor;
use plotters::style::colors::colormaps::ViridisRGB;
use plotters::style::text_anchor::HPos;

use super::axis::clamp_or_half;
use super::{ABOVE_RIGHT, Area, Axis, Chart, ColourScale, Coords, DESC, Drawn, LABEL, Layout};
use super::{PixelBox, PlotError, RIGHT_OF, Segment, TICK, boxed_text, count, labels};
use super::{bounding_box, labels_width, notes, room, value_words, write_png};

pub(super) const NET_WIDTH: u32 = 1100;
pub(super) const NET_HEIGHT: u32 = 900;
/// Network line width (px) when none, or a non-finite one, is given.
const NET_LINE_PX: f64 = 2.0;
/// Colour of segments and quads without a usable value.
pub(super) const NO_VALUE_GREY: RGBColor = RGBColor(178, 178, 178);
pub(super) const MARKER_FILL: RGBColor = RGBColor(214, 39, 40);
/// Colour of a fracture map's mesh edges (1 px lines).
const MESH_GREY: RGBColor = RGBColor(210, 210, 210);
/// Colour bar: gap to the plot frame, width, major tick length (px).
pub(super) const BAR_GAP: i32 = 28;
pub(super) const BAR_W: i32 = 24;
const BAR_TICK: i32 = 6;
/// Margin around the box shown by a network and (default window) a fracture
/// map, fraction of the box's larger side.
pub(super) const NET_PAD: f64 = 0.04;
const QUAD_PAD: f64 = 0.1;

/// Draw a fracture network, 1100x900 px PNG: each segment as a line coloured
/// by `values[k]` (viridis colormap; [`ColourScale::Log`]: colour bar in
/// powers of ten), `width_px[k]` px wide when given (e.g. scaled aperture;
/// clamped to 0.75..=40 px, whole pixels; non-finite: the 2 px default),
/// equal x/y scales in metres, a colour bar labelled `value_label`, `title`
/// on top, and `markers` (labelled points, e.g. a pump) as filled circles.
///
/// Segments without a colourable value (non-finite, or non-positive on a log
/// scale) are drawn grey, below the others (drawn in increasing value order);
/// those with non-finite end points are left out; both are counted in a
/// note. Nothing to draw or colour still gives a PNG, with a note. `values`
/// (and `width_px`) must have one entry per segment, else [`PlotError::Input`].
#[allow(clippy::too_many_arguments)]
pub fn network(
    path: &Path,
    title: &str,
    segments: &[Segment],
    values: &[f64],
    value_label: &str,
    scale: ColourScale,
    width_px: Option<&[f64]>,
    markers: &[([f64; 2], &str)],
) -> Result<(), PlotError> {
    let (n, v) = (segments.len(), values.len());
    let w = width_px.map_or(n, <[f64]>::len);
    let what = [(v, "values", "value"), (w, "line widths", "width")];
    if let Some((k, what, one)) = what.into_iter().find(|c| c.0 != n) {
        let message = format!("{k} {what} given for {n} segments (need one {one} per segment)");
        return Err(input_error(path, message));
    }
    let shapes = Shapes::Lines(segments, width_px);
    write_png(path, (NET_WIDTH, NET_HEIGHT), |root| {
        draw_map(root, (title, value_label), &shapes, values, scale, markers)
    })
}

/// Draw fracture cells over a rock mesh, like the seed's Fig. 7
/// (`docs/seed-method.md`, Example I): each of `quads` (corners in order
/// around the polygon, m; e.g. a fracture cell as wide as its magnified
/// aperture) filled and edged (1 px, so quads thinner than a pixel still
/// show) with the viridis colour of `values[k]` (linear scale), over the
/// `mesh_edges` as thin light-grey lines; the rest as in [`network`].
///
/// `window` (`[xmin, xmax, ymin, ymax]`, m; widened to the plot's aspect
/// ratio) is the region shown, by default the box of the quads and markers
/// (else of the mesh) plus 10 % of its larger side on each side. Quads with
/// a non-finite corner and mesh edges with a non-finite end are left out,
/// and counted in a note. `values` must have one entry per quad, and
/// `window` finite bounds with xmin < xmax and ymin < ymax, else
/// [`PlotError::Input`].
#[allow(clippy::too_many_arguments)]
pub fn fracture_map(
    path: &Path,
    title: &str,
    mesh_edges: &[Segment],
    quads: &[[[f64; 2]; 4]],
    values: &[f64],
    value_label: &str,
    window: Option<[f64; 4]>,
    markers: &[([f64; 2], &str)],
) -> Result<(), PlotError> {
    let (v, n) = (values.len(), quads.len());
    let bad = |w: &[f64; 4]| !(w.iter().all(|v| v.is_finite()) && w[0] < w[1] && w[2] < w[3]);
    if v != n {
        let message = format!("{v} values given for {n} quads (need one value per quad)");
        return Err(input_error(path, message));
    }
    if let Some(w) = window.filter(bad) {
        let ok = "[xmin, xmax, ymin, ymax] with finite xmin < xmax and ymin < ymax";
        return Err(input_error(path, format!("window {w:?} is not {ok}")));
    }
    let shapes = Shapes::Quads(quads, mesh_edges, window);
    let linear = ColourScale::Linear;
    write_png(path, (NET_WIDTH, NET_HEIGHT), |root| {
        draw_map(root, (title, value_label), &shapes, values, linear, markers)
    })
}

/// Draw an event map, 1100x900 px PNG: the fracture network `fractures` as grey lines and
/// each event as a disc at `centres[k]` (m) of radius `radius_px[k]` px (e.g. growing with
/// the magnitude), coloured by `values[k]` (viridis, e.g. the event's time; colour bar
/// labelled `value_label`), larger discs drawn first. `values` and `radius_px` must have one
/// entry per centre, else [`PlotError::Input`].
pub fn event_map(
    path: &Path,
    title: &str,
    fractures: &[Segment],
    centres: &[[f64; 2]],
    radius_px: &[f64],
    values: &[f64],
    value_label: &str,
) -> Result<(), PlotError> {
    let n = centres.len();
    if values.len() != n || radius_px.len() != n {
        let message = format!(
            "{} values and {} radii given for {n} events (need one of each per event)",
            values.len(),
            radius_px.len()
        );
        return Err(input_error(path, message));
    }
    let shapes = Shapes::Discs(centres, radius_px, fractures);
    let linear = ColourScale::Linear;
    write_png(path, (NET_WIDTH, NET_HEIGHT), |root| {
        draw_map(root, (title, value_label), &shapes, values, linear, &[])
    })
}

fn input_error(path: &Path, message: String) -> PlotError {
    PlotError::Input {
        path: path.to_path_buf(),
        message,
    }
}

/// Viridis colour at `t` in 0..=1 (clamped; non-finite: 0).
pub(super) fn viridis(t: f64) -> RGBColor {
    ViridisRGB::get_color(if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) })
}

/// Colour-bar axis over exactly `vmin..=vmax` (positive for log scales; the
/// axis is then in log10 space with power-of-ten labels).
pub(super) fn colour_axis(vmin: f64, vmax: f64, scale: ColourScale) -> Axis {
    match scale {
        ColourScale::Linear if vmax > vmin => Axis::linear_exact(vmin, vmax),
        ColourScale::Linear => Axis::linear(vmin, vmax),
        ColourScale::Log => {
            let (lmin, lmax) = (vmin.log10(), vmax.log10());
            let mut a = Axis::log(lmin, lmax);
            a.plain = false;
            // Drop the margins when at least two labelled ticks remain.
            let inside = |t: &f64| *t >= lmin - 1e-9 && *t <= lmax + 1e-9;
            let major: Vec<f64> = a.major.iter().copied().filter(inside).collect();
            if lmax - lmin > 1e-9 && major.len() >= 2 {
                a.minor.retain(inside);
                (a.major, a.lo, a.hi) = (major, lmin, lmax);
            }
            a
        }
    }
}

/// Position of `v` (colour-bar space) on `axis`, 0..=1.
pub(super) fn colour_fraction(axis: &Axis, v: f64) -> f64 {
    // Halve first so extreme ranges do not overflow.
    let f = (v / 2.0 - axis.lo / 2.0) / (axis.hi / 2.0 - axis.lo / 2.0);
    clamp_or_half(f, 0.0, 1.0)
}

/// Items to draw in order, with their colour fractions (`None`: grey).
type Order = Vec<(Option<f64>, usize)>;

/// Colour bar of the `values` of the `drawable` items, and the items in
/// drawing order: grey (`None`) first, then by increasing colour fraction.
fn colour_order(values: &[f64], drawable: &[usize], scale: ColourScale) -> (Option<Axis>, Order) {
    let usable = |v: f64| v.is_finite() && (scale == ColourScale::Linear || v > 0.0);
    let (mut vmin, mut vmax) = (f64::MAX, f64::MIN);
    for v in drawable.iter().map(|&k| values[k]).filter(|&v| usable(v)) {
        (vmin, vmax) = (vmin.min(v), vmax.max(v));
    }
    let bar = (vmin <= vmax).then(|| colour_axis(vmin, vmax, scale));
    let log = scale == ColourScale::Log;
    let fraction = |v: f64| {
        let bar_value = if log { v.log10() } else { v };
        Some(colour_fraction(bar.as_ref()?, bar_value)).filter(|_| usable(v))
    };
    let mut order: Order = drawable.iter().map(|&k| (fraction(values[k]), k)).collect();
    order.sort_by(|p, q| match (p.0, q.0) {
        (Some(a), Some(b)) => a.total_cmp(&b),
        (p, q) => p.is_some().cmp(&q.is_some()),
    });
    (bar, order)
}

/// Axes with equal metres per pixel for the data box `[xmin, xmax, ymin,
/// ymax]` plus a margin of `pad` times its larger side, filling `w` x `h` px
/// (the axes' pixel lengths); both get the same tick step.
pub(super) fn equal_axes(bbox: [f64; 4], w: f64, h: f64, pad: f64) -> (Axis, Axis) {
    let try_box = |[xmin, xmax, ymin, ymax]: [f64; 4]| -> Option<(Axis, Axis)> {
        let span = (xmax - xmin).max(ymax - ymin);
        let m = xmin.abs().max(ymin.abs());
        let pad = match (span > 0.0, m > 0.0) {
            (true, _) => pad * span,
            (false, true) => 0.1 * m,
            (false, false) => 1.0,
        };
        let px_per_m = (w / (xmax - xmin + 2.0 * pad)).min(h / (ymax - ymin + 2.0 * pad));
        let (xc, yc) = (xmin / 2.0 + xmax / 2.0, ymin / 2.0 + ymax / 2.0);
        let (hx, hy) = (0.5 * w / px_per_m, 0.5 * h / px_per_m);
        let ends = [xc - hx, xc + hx, yc - hy, yc + hy];
        if !(ends.iter().all(|v| v.is_finite()) && px_per_m > 0.0 && hx > 0.0 && hy > 0.0) {
            return None;
        }
        let step = |lo, hi| Axis::linear_exact(lo, hi).step;
        let step = step(ends[0], ends[1]).max(step(ends[2], ends[3]));
        let axis = |lo, hi| Axis::linear_stepped(lo, hi, step);
        Some((axis(ends[0], ends[1]), axis(ends[2], ends[3])))
    };
    (try_box(bbox).or_else(|| try_box([0.0, 1.0, 0.0, 1.0])))
        .unwrap_or_else(|| (Axis::linear(0.0, 1.0), Axis::linear(0.0, 1.0)))
}

fn finite(ps: &[[f64; 2]]) -> bool {
    ps.iter().flatten().all(|v| v.is_finite())
}

/// What a map draws: [`network`]'s segments and line widths (px), or
/// [`fracture_map`]'s quads, mesh edges and window.
pub(super) enum Shapes<'a> {
    Lines(&'a [Segment], Option<&'a [f64]>),
    Quads(&'a [[[f64; 2]; 4]], &'a [Segment], Option<[f64; 4]>),
    /// [`event_map`]'s disc centres, radii (px) and the fractures under them.
    Discs(&'a [[f64; 2]], &'a [f64], &'a [Segment]),
}

/// Draw a map (arguments of [`network`] or [`fracture_map`], validated) on
/// `root`; returns where data coordinates land.
pub(super) fn draw_map(
    root: &Area,
    texts: (&str, &str),
    shapes: &Shapes,
    values: &[f64],
    scale: ColourScale,
    markers: &[([f64; 2], &str)],
) -> Drawn<Coords> {
    let items: Vec<Vec<[f64; 2]>> = match *shapes {
        Shapes::Lines(segments, _) => segments.iter().map(|s| vec![s.a, s.b]).collect(),
        Shapes::Quads(quads, ..) => quads.iter().map(|q| q.to_vec()).collect(),
        Shapes::Discs(centres, ..) => centres.iter().map(|c| vec![*c]).collect(),
    };
    let (mesh, window, widths, pad, lines) = match *shapes {
        Shapes::Lines(_, widths) => (&[][..], None, widths, NET_PAD, true),
        Shapes::Quads(_, mesh, window) => (mesh, window, None, QUAD_PAD, false),
        Shapes::Discs(_, _, fractures) => (fractures, None, None, NET_PAD, false),
    };
    let discs = match *shapes {
        Shapes::Discs(_, radii, _) => Some(radii),
        _ => None,
    };
    let background = if discs.is_some() {
        RGBColor(120, 120, 120)
    } else {
        MESH_GREY
    };
    let drawable: Vec<usize> = (0..items.len()).filter(|&k| finite(&items[k])).collect();
    let edges: Vec<&Segment> = mesh.iter().filter(|s| finite(&[s.a, s.b])).collect();

    // Region shown: the window, else the items and markers, else the mesh
    // (else, all empty, `equal_axes`' unit box).
    let marks = markers.iter().map(|m| m.0).filter(|p| finite(&[*p]));
    let mut bbox = bounding_box(drawable.iter().flat_map(|&k| items[k].clone()).chain(marks));
    if bbox[0] > bbox[1] {
        bbox = bounding_box(edges.iter().flat_map(|s| [s.a, s.b]));
    }
    let (bbox, pad) = window.map_or((bbox, pad), |w| (w, 0.0));
    let (bar, order) = colour_order(values, &drawable, scale);
    let layout = map_layout(texts.0, bar_margin(bar.as_ref(), texts.1), bbox, pad);
    let (x, y) = (&layout.x, &layout.y);
    // Whether any of the box of the points `ps` lies within the axes.
    let shown = |ps: &[[f64; 2]]| {
        let b = bounding_box(ps.iter().copied());
        b[0] <= x.hi && b[1] >= x.lo && b[2] <= y.hi && b[3] >= y.lo
    };

    let mut chart = layout.chart(root, lines.then_some((0.12, 0.04)))?;
    let area = chart.plotting_area();
    for s in edges.iter().filter(|s| shown(&[s.a, s.b])) {
        let line = vec![(s.a[0], s.a[1]), (s.b[0], s.b[1])];
        area.draw(&PathElement::new(line, background))?;
    }
    let mut order = order;
    if let Some(r) = discs {
        // Large discs first, so small ones stay visible on top.
        order.sort_by(|p, q| disc_px(r[q.1]).cmp(&disc_px(r[p.1])));
    }
    for &(t, k) in order.iter().filter(|o| shown(&items[o.1])) {
        let color = t.map_or(NO_VALUE_GREY, viridis);
        if let Some(r) = discs {
            let (c, px) = ((items[k][0][0], items[k][0][1]), disc_px(r[k]));
            area.draw(&Circle::new(c, px, color.mix(0.85).filled()))?;
            area.draw(&Circle::new(c, px, RGBColor(40, 40, 40)))?;
            continue;
        }
        let mut pts: Vec<(f64, f64)> = items[k].iter().map(|p| (p[0], p[1])).collect();
        if lines {
            let px = line_px(widths.map_or(NET_LINE_PX, |w| w[k]));
            // Round caps (plotters' wide lines end square), which also show
            // segments shorter than a pixel.
            for &p in pts.iter().filter(|_| px >= 2) {
                area.draw(&Circle::new(p, px / 2, color.filled()))?;
            }
            area.draw(&PathElement::new(pts, color.stroke_width(px)))?;
        } else {
            area.draw(&Polygon::new(pts.clone(), color.filled()))?;
            pts.push(pts[0]);
            area.draw(&PathElement::new(pts, color))?;
        }
    }
    let shown_markers: Vec<_> = markers.iter().filter(|m| shown(&[m.0])).collect();
    draw_markers(root, &chart, &shown_markers)?;
    let frame = layout.frame(root, &mut chart)?;
    draw_bar(root, &frame, bar.as_ref(), texts.1)?;

    // Notes.
    let [many, one, ends] = if lines {
        ["segments", "segment", "end points"]
    } else if discs.is_some() {
        ["events", "event", "centres"]
    } else {
        ["fracture cells", "cell", "corners"]
    };
    let [good, bad] = value_words(scale == ColourScale::Log);
    let big = if items.is_empty() {
        Some(format!("no {many} to plot"))
    } else if drawable.is_empty() {
        Some(format!("no {many} with finite {ends} to plot"))
    } else if bar.is_none() {
        Some(format!("no {good} values to colour (all {one}s grey)"))
    } else {
        None
    };
    let centred = drawable.is_empty() && shown_markers.is_empty() && edges.is_empty();
    let greyed = order.iter().filter(|o| o.0.is_none()).count();
    let grey = format!("with a {bad} value drawn grey");
    let no_ends = format!("with non-finite {ends} omitted");
    let lost = mesh.len() - edges.len();
    let small: Vec<String> = [
        (bar.as_ref().map_or(0, |_| greyed), one, &grey[..]),
        (items.len() - drawable.len(), one, &no_ends[..]),
        (lost, "mesh edge", "with non-finite end points omitted"),
    ]
    .into_iter()
    .filter(|s| s.0 > 0)
    .map(|(n, what, rest)| format!("{} {rest}", count(n, what)))
    .collect();
    notes(root, &frame, big.as_deref().map(|m| (m, centred)), &small)?;
    Ok(chart.as_coord_spec().clone())
}

/// Radius in whole pixels of an event disc `r` px wide, clamped to 2..=60 (non-finite: 2).
fn disc_px(r: f64) -> u32 {
    if r.is_finite() {
        r.clamp(2.0, 60.0).round() as u32
    } else {
        2
    }
}

/// Width in whole pixels of a network line `w` px wide, clamped to 0.75..=40.
fn line_px(w: f64) -> u32 {
    let w = if w.is_finite() { w } else { NET_LINE_PX };
    w.clamp(0.75, 40.0).round() as u32
}

/// Labelled points as red discs with a dark rim on a white halo, each label
/// on a white box beside its point (left of it near the right edge).
fn draw_markers(root: &Area, chart: &Chart, markers: &[&([f64; 2], &str)]) -> Drawn {
    let (px, py) = chart.plotting_area().get_pixel_range();
    let to_px = |p: [f64; 2]| chart.backend_coord(&(p[0], p[1]));
    let centres: Vec<_> = markers.iter().map(|m| to_px(m.0)).collect();
    for &c in &centres {
        for (r, color) in [(8, WHITE), (7, RGBColor(40, 40, 40)), (5, MARKER_FILL)] {
            root.draw(&Circle::new(c, r, color.filled()))?;
        }
    }
    for (&(cx, cy), &&(_, label)) in centres.iter().zip(markers).filter(|m| !m.1.1.is_empty()) {
        let half = LABEL.cap() / 2 + 10;
        let y = cy.clamp(py.start + half, (py.end - half).max(py.start + half));
        if cx + 16 + LABEL.width(label) + 10 <= px.end {
            boxed_text(root, LABEL, label, (cx + 16, y), HPos::Left)?;
        } else {
            boxed_text(root, LABEL, label, (cx - 16, y), HPos::Right)?;
        }
    }
    Ok(())
}

/// Width right of a map's plotting area for its colour bar over `bar`
/// (`None`: nothing to colour, the bar is left blank) labelled `label`.
fn bar_margin(bar: Option<&Axis>, label: &str) -> i32 {
    let mult_w = bar.and_then(Axis::multiplier).map_or(0, |m| TICK.width(&m));
    let bar_w = BAR_GAP + BAR_W + BAR_TICK + 26 + bar.map_or(0, |a| labels_width(a, 0));
    let desc_w = room(label, DESC, 22);
    (bar_w + desc_w).max(BAR_GAP + mult_w + 16)
}

/// Layout of a map of `bbox` (`[xmin, xmax, ymin, ymax]`, m; see
/// [`equal_axes`]) with `right` px right of the plotting area.
fn map_layout(title: &str, right: i32, bbox: [f64; 4], pad: f64) -> Layout<'_> {
    let texts = (title, "x [m]", "y [m]");
    let unit = || Axis::linear(0.0, 1.0);
    let [top, _, bottom, _] = Layout::new(texts, unit(), unit(), Some(right), 0).margin;
    let ax_h = (NET_HEIGHT as i32 - bottom - 1 - top).max(10) as f64;
    // The y tick labels' width sets the plot width, which sets the axes.
    let (mut y_tick_w, mut tries) = (0, 0);
    let (x, y) = loop {
        let left = Layout::left_margin(texts.2, y_tick_w);
        let ax_w = (NET_WIDTH as i32 - right - 1 - left).max(10) as f64;
        let axes = equal_axes(bbox, ax_w, ax_h, pad);
        let need = labels_width(&axes.1, 0);
        tries += 1;
        if need <= y_tick_w || tries == 5 {
            break axes;
        }
        y_tick_w = need;
    };
    Layout::new(texts, x, y, Some(right), y_tick_w)
}

/// The colour bar over `bar` (see [`bar_margin`]) labelled `label`, right of
/// the plotting area `(px, py)` and as tall as it.
fn draw_bar(root: &Area, (px, py): &PixelBox, bar: Option<&Axis>, label: &str) -> Drawn {
    let (bx0, bx1) = (px.end - 1 + BAR_GAP, px.end - 1 + BAR_GAP + BAR_W);
    let (b_top, b_bot) = (py.start, py.end - 1);
    let bar_y = |f: f64| b_bot - (f * (b_bot - b_top) as f64).round() as i32;
    for y in b_top..=b_bot {
        let f = (b_bot - y) as f64 / (b_bot - b_top).max(1) as f64;
        let color = bar.map_or(RGBColor(240, 240, 240), |_| viridis(f));
        root.draw(&PathElement::new(vec![(bx0, y), (bx1, y)], color))?;
    }
    root.draw(&Rectangle::new([(bx0, b_top), (bx1, b_bot)], BLACK))?;
    if let Some(a) = bar {
        let minor = a.minor.iter().map(|&t| (t, 3));
        for (t, len) in minor.chain(a.major.iter().map(|&t| (t, BAR_TICK))) {
            let y = bar_y(colour_fraction(a, t));
            root.draw(&PathElement::new(vec![(bx1, y), (bx1 + len, y)], BLACK))?;
        }
        for (t, l) in labels(a) {
            let at = (bx1 + BAR_TICK + 6, bar_y(colour_fraction(a, t)));
            TICK.draw(root, &l, at, RIGHT_OF)?;
        }
        if let Some(m) = a.multiplier() {
            TICK.draw(root, &m, (bx0, b_top - 8), ABOVE_RIGHT)?;
        }
    }
    let tick_w = bar.map_or(0, |a| labels_width(a, 0));
    let x = bx1 + BAR_TICK + 6 + tick_w + 16 + (DESC.cap() + 6) / 2;
    DESC.draw_up(root, label, (x, (b_top + b_bot) / 2))
}
