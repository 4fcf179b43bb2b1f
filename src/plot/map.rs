//! Maps in metres with equal x/y scales and a viridis colour bar:
//! [`network`] (segments as coloured lines) and [`fracture_map`] (filled
//! quads over a light-grey mesh).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::RGBColor;
use plotters::style::colors::colormaps::ViridisRGB;
use plotters::style::text_anchor::{HPos, VPos};

use super::{Area, Axis, Chart, ColourScale, Coords, DESC, Drawn, LABEL, Layout, PixelBox};
use super::{PlotError, RIGHT_OF, Segment, TICK, boxed_text, count, labels, labels_width};
use super::{notes, write_png};

pub(super) const NET_WIDTH: u32 = 1100;
pub(super) const NET_HEIGHT: u32 = 900;
/// Line width when no widths are given, and for non-finite widths, px.
const NET_LINE_PX: f64 = 2.0;
/// Range that given line widths are clamped to, px.
const NET_LINE_PX_RANGE: (f64, f64) = (0.75, 40.0);
/// Colour of segments and quads without a usable value.
pub(super) const NO_VALUE_GREY: RGBColor = RGBColor(178, 178, 178);
pub(super) const MARKER_FILL: RGBColor = RGBColor(214, 39, 40);
/// Colour of a fracture map's mesh edges (1 px lines).
const MESH_GREY: RGBColor = RGBColor(210, 210, 210);
/// Colour bar: gap to the plot frame, width, major tick length (px).
pub(super) const BAR_GAP: i32 = 28;
pub(super) const BAR_W: i32 = 24;
const BAR_TICK: i32 = 6;
/// Margin around a network's data box, fraction of its larger side.
pub(super) const NET_PAD: f64 = 0.04;
/// Margin around a fracture map's quads (default window), fraction of the
/// larger side of their box.
const QUAD_PAD: f64 = 0.1;

/// Draw a fracture network: each segment as a line coloured by `values[k]`
/// (viridis colormap), `width_px[k]` px wide when given (e.g. scaled
/// aperture; non-finite widths use the 2 px default, others are clamped to
/// 0.75..=40 px and drawn in whole pixels), equal x/y scales in metres, a
/// vertical colour bar labelled `value_label`, and `title` on top; 1100x900
/// px PNG, written atomically.
///
/// Non-finite values are drawn grey (below the coloured segments, which are
/// drawn in increasing value order); [`ColourScale::Log`] also greys out
/// non-positive values and labels the colour bar in powers of ten. Segments
/// with non-finite end points are left out. Both are counted in a note.
/// `markers` are labelled points (e.g. a pump) drawn as filled circles. An
/// empty network or one without any colourable value still gives a PNG,
/// with a note. `values` (and `width_px`) must have one entry per segment,
/// else [`PlotError::Input`].
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
    let (texts, shapes) = ((title, value_label), Shapes::Lines(segments, width_px));
    write_png(path, (NET_WIDTH, NET_HEIGHT), |root| {
        draw_map(root, texts, &shapes, values, scale, markers)
    })
}

/// Draw fracture cells as filled polygons over a rock mesh, like the seed's
/// Fig. 7 (`docs/seed-method.md`, Example I): each of `quads` (corners in order around the polygon, m;
/// e.g. a fracture cell as wide as its magnified aperture) filled with the
/// viridis colour of `values[k]` (linear scale) and edged with a 1 px line
/// of the same colour, so quads thinner than a pixel still show; the
/// `mesh_edges` as thin light-grey lines below them; equal x/y scales in
/// metres, a vertical colour bar labelled `value_label`, and `title` on top;
/// 1100x900 px PNG, written atomically.
///
/// `window` (`[xmin, xmax, ymin, ymax]`, m) is the region shown (widened to
/// the plot's aspect ratio); by default the bounding box of the quads and
/// markers plus 10 % of its larger side on each side (of the mesh when there
/// are neither). As in [`network`], non-finite values are drawn grey (below
/// the coloured quads, which are drawn in increasing value order); quads with
/// a non-finite corner and mesh edges with a non-finite end are left out; all
/// three are counted in a note. `markers` are labelled points (e.g. a pump)
/// drawn as filled circles when inside the window. No quads, or none with a
/// colourable value, still gives a PNG, with a note. `values` must have one
/// entry per quad, and `window`, when given, finite bounds with xmin < xmax
/// and ymin < ymax, else [`PlotError::Input`].
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
    let (texts, shapes) = (
        (title, value_label),
        Shapes::Quads(quads, mesh_edges, window),
    );
    let linear = ColourScale::Linear;
    write_png(path, (NET_WIDTH, NET_HEIGHT), |root| {
        draw_map(root, texts, &shapes, values, linear, markers)
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
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        0.5
    }
}

/// Items to draw in order, with their colour fractions (`None`: grey).
type Order = Vec<(Option<f64>, usize)>;

/// Colour bar of the `values` of the `drawable` items and their drawing
/// order: items without a usable value (grey, `None`) first, then by
/// increasing colour fraction.
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
        let x = Axis::linear_exact(ends[0], ends[1]);
        let y = Axis::linear_exact(ends[2], ends[3]);
        let step = x.step.max(y.step);
        let x = Axis::linear_stepped(x.lo, x.hi, step);
        Some((x, Axis::linear_stepped(y.lo, y.hi, step)))
    };
    (try_box(bbox).or_else(|| try_box([0.0, 1.0, 0.0, 1.0])))
        .unwrap_or_else(|| (Axis::linear(0.0, 1.0), Axis::linear(0.0, 1.0)))
}

/// The box (`[xmin, xmax, ymin, ymax]`) of the points `ps`; xmin > xmax
/// when there are none.
fn bounding_box<'p>(ps: impl IntoIterator<Item = &'p [f64; 2]>) -> [f64; 4] {
    let grow =
        |b: [f64; 4], &[x, y]: &[f64; 2]| [b[0].min(x), b[1].max(x), b[2].min(y), b[3].max(y)];
    ps.into_iter()
        .fold([f64::MAX, f64::MIN, f64::MAX, f64::MIN], grow)
}

fn finite(p: &[f64; 2]) -> bool {
    p[0].is_finite() && p[1].is_finite()
}

/// What a map draws.
pub(super) enum Shapes<'a> {
    /// Segments as lines, with their widths (px) if given (see [`network`]).
    Lines(&'a [Segment], Option<&'a [f64]>),
    /// Filled quads over mesh edges, in a window if given (see
    /// [`fracture_map`]).
    Quads(&'a [[[f64; 2]; 4]], &'a [Segment], Option<[f64; 4]>),
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
    };
    let (mesh, window, widths) = match *shapes {
        Shapes::Lines(_, widths) => (&[][..], None, widths),
        Shapes::Quads(_, mesh, window) => (mesh, window, None),
    };
    let lines = matches!(shapes, Shapes::Lines(..));
    let drawable: Vec<usize> = (0..items.len())
        .filter(|&k| items[k].iter().all(finite))
        .collect();
    let edges: Vec<&Segment> = mesh
        .iter()
        .filter(|s| finite(&s.a) && finite(&s.b))
        .collect();

    // Region shown: the window, else the items and markers, else the mesh.
    let finite_markers = markers.iter().map(|m| &m.0).filter(|p| finite(p));
    let mut bbox = bounding_box(
        drawable
            .iter()
            .flat_map(|&k| &items[k])
            .chain(finite_markers),
    );
    if bbox[0] > bbox[1] {
        bbox = bounding_box(edges.iter().flat_map(|s| [&s.a, &s.b]));
    }
    if bbox[0] > bbox[1] {
        bbox = [0.0, 1.0, 0.0, 1.0];
    }
    let pad = if lines { NET_PAD } else { QUAD_PAD };
    let (bbox, pad) = window.map_or((bbox, pad), |w| (w, 0.0));
    let (bar, order) = colour_order(values, &drawable, scale);
    let layout = map_layout(texts.0, bar_margin(bar.as_ref(), texts.1), bbox, pad);
    let (x, y) = (&layout.x, &layout.y);
    // Whether any of the box of the points `ps` lies within the axes.
    let shown = |ps: &[[f64; 2]]| {
        let b = bounding_box(ps);
        b[0] <= x.hi && b[1] >= x.lo && b[2] <= y.hi && b[3] >= y.lo
    };

    let mut chart = layout.chart(root, lines.then_some((0.12, 0.04)))?;
    let area = chart.plotting_area();
    for s in edges.iter().filter(|s| shown(&[s.a, s.b])) {
        let line = vec![(s.a[0], s.a[1]), (s.b[0], s.b[1])];
        area.draw(&PathElement::new(line, MESH_GREY))?;
    }
    for &(t, k) in order.iter().filter(|o| shown(&items[o.1])) {
        let color = t.map_or(NO_VALUE_GREY, viridis);
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
    let inside =
        |m: &&([f64; 2], &str)| (x.lo..=x.hi).contains(&m.0[0]) && (y.lo..=y.hi).contains(&m.0[1]);
    let shown_markers: Vec<_> = markers.iter().filter(inside).collect();
    draw_markers(root, &chart, &shown_markers)?;
    let frame = layout.frame(root, &mut chart)?;
    draw_bar(root, &frame, bar.as_ref(), texts.1)?;

    // Notes.
    let [many, one, ends] = if lines { NETWORK_NOUNS } else { QUAD_NOUNS };
    let log = scale == ColourScale::Log;
    let big = if items.is_empty() {
        Some(format!("no {many} to plot"))
    } else if drawable.is_empty() {
        Some(format!("no {many} with finite {ends} to plot"))
    } else if bar.is_none() {
        let positive = if log { ", positive" } else { "" };
        Some(format!(
            "no finite{positive} values to colour (all {one}s grey)"
        ))
    } else {
        None
    };
    let centred = drawable.is_empty() && shown_markers.is_empty() && edges.is_empty();
    let greyed = order.iter().filter(|o| o.0.is_none()).count();
    let what = if log {
        "a non-positive or non-finite"
    } else {
        "a non-finite"
    };
    let (no_coords, bad_edges) = (items.len() - drawable.len(), mesh.len() - edges.len());
    let mut small = Vec::new();
    if greyed > 0 && bar.is_some() {
        small.push(format!(
            "{} with {what} value drawn grey",
            count(greyed, one)
        ));
    }
    if no_coords > 0 {
        small.push(format!(
            "{} with non-finite {ends} omitted",
            count(no_coords, one)
        ));
    }
    if bad_edges > 0 {
        let n = count(bad_edges, "mesh edge");
        small.push(format!("{n} with non-finite end points omitted"));
    }
    notes(root, &frame, big.as_deref().map(|m| (m, centred)), &small)?;
    Ok(chart.as_coord_spec().clone())
}

/// Width in whole pixels of a network line `w` px wide (non-finite: the
/// default, else clamped).
fn line_px(w: f64) -> u32 {
    let (lo, hi) = NET_LINE_PX_RANGE;
    let w = if w.is_finite() {
        w.clamp(lo, hi)
    } else {
        NET_LINE_PX
    };
    w.round().max(1.0) as u32
}

/// What the notes of a network and of a fracture map call their items and
/// those items' points.
const NETWORK_NOUNS: [&str; 3] = ["segments", "segment", "end points"];
const QUAD_NOUNS: [&str; 3] = ["fracture cells", "cell", "corners"];

/// Labelled points as red discs with a dark rim on a white halo, each label
/// on a white box beside its point (left of it near the right edge).
fn draw_markers(root: &Area, chart: &Chart, markers: &[&([f64; 2], &str)]) -> Drawn {
    let (px, py) = chart.plotting_area().get_pixel_range();
    let centres: Vec<_> = markers
        .iter()
        .map(|m| chart.backend_coord(&(m.0[0], m.0[1])))
        .collect();
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
    let desc_w = if label.is_empty() { 0 } else { DESC.cap() + 22 };
    (bar_w + desc_w).max(BAR_GAP + mult_w + 16)
}

/// Lay out a map of the data box `bbox` (`[xmin, xmax, ymin, ymax]`, m)
/// with a margin of `pad` times its larger side, widened to the plotting
/// area's aspect ratio, with `right` px right of it.
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
    let edge = [(bx0, b_top), (bx1, b_bot)];
    root.draw(&Rectangle::new(edge, BLACK.stroke_width(1)))?;
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
            TICK.draw(root, &m, (bx0, b_top - 8), (HPos::Left, VPos::Bottom))?;
        }
    }
    let tick_w = bar.map_or(0, |a| labels_width(a, 0));
    let x = bx1 + BAR_TICK + 6 + tick_w + 16 + (DESC.cap() + 6) / 2;
    DESC.draw_up(root, label, (x, (b_top + b_bot) / 2))
}
