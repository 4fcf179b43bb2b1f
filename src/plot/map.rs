//! Maps in metres with equal x/y scales and a viridis colour bar:
//! [`network`] (segments as coloured lines) and [`fracture_map`] (filled
//! quads over a light-grey mesh).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::RGBColor;
use plotters::style::colors::colormaps::ViridisRGB;
use plotters::style::text_anchor::{HPos, VPos};

use super::{
    Area, Axis, Chart, ColourScale, Coords, Layout, Pens, PlotError, Segment, boxed_text, count,
    write_png,
};

pub(super) const NET_WIDTH: u32 = 1100;
pub(super) const NET_HEIGHT: u32 = 900;
/// Line width when no widths are given, and for non-finite widths, px.
const NET_LINE_PX: f64 = 2.0;
/// Range that given line widths are clamped to, px.
const NET_LINE_MIN_PX: f64 = 0.75;
const NET_LINE_MAX_PX: f64 = 40.0;
/// Colour of segments and quads without a usable value.
pub(super) const NO_VALUE_GREY: RGBColor = RGBColor(178, 178, 178);
pub(super) const MARKER_FILL: RGBColor = RGBColor(214, 39, 40);
/// Colour bar: gap to the plot frame, width, major tick length (px).
pub(super) const BAR_GAP: i32 = 28;
pub(super) const BAR_W: i32 = 24;
const BAR_TICK: i32 = 6;
/// Margin around a network's data box, fraction of its larger side.
pub(super) const NET_PAD: f64 = 0.04;
/// Margin around a fracture map's quads (default window), fraction of the
/// larger side of their box.
const QUAD_PAD: f64 = 0.1;
/// Colour of a fracture map's mesh edges (1 px lines).
const MESH_GREY: RGBColor = RGBColor(210, 210, 210);

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
    let n = segments.len();
    let mut problem = (values.len() != n).then(|| {
        let v = values.len();
        format!("{v} values given for {n} segments (need one value per segment)")
    });
    if let Some(w) = width_px.filter(|w| w.len() != n) {
        let w = w.len();
        problem = problem.or(Some(format!(
            "{w} line widths given for {n} segments (need one width per segment)"
        )));
    }
    check(path, problem)?;
    let pens = Pens::new()?;
    let net = Network {
        texts: (title, value_label),
        segments,
        values,
        scale,
        width_px,
        markers,
    };
    write_png(path, (NET_WIDTH, NET_HEIGHT), |root| {
        draw_network(root, &pens, &net).map(drop)
    })
}

/// Draw fracture cells as filled polygons over a rock mesh, like the seed
/// paper's Fig. 7: each of `quads` (corners in order around the polygon, m;
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
    let mut problem =
        (v != n).then(|| format!("{v} values given for {n} quads (need one value per quad)"));
    if let Some(w @ [x0, x1, y0, y1]) = window
        && !(w.iter().all(|v| v.is_finite()) && x0 < x1 && y0 < y1)
    {
        problem = problem.or(Some(format!(
            "window {w:?} is not [xmin, xmax, ymin, ymax] with finite xmin < xmax and ymin < ymax"
        )));
    }
    check(path, problem)?;
    let pens = Pens::new()?;
    let map = QuadMap {
        texts: (title, value_label),
        mesh_edges,
        quads,
        values,
        window,
        markers,
    };
    write_png(path, (NET_WIDTH, NET_HEIGHT), |root| {
        draw_fracture_map(root, &pens, &map).map(drop)
    })
}

fn check(path: &Path, problem: Option<String>) -> Result<(), PlotError> {
    problem.map_or(Ok(()), |message| {
        let path = path.to_path_buf();
        Err(PlotError::Input { path, message })
    })
}

/// Viridis colour at `t` in 0..=1 (clamped; non-finite: 0).
pub(super) fn viridis(t: f64) -> RGBColor {
    ViridisRGB::get_color(if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    })
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
            if lmax - lmin > 1e-9 {
                // Drop the margins when at least two labelled ticks remain.
                let inside = |t: &f64| *t >= lmin - 1e-9 && *t <= lmax + 1e-9;
                let major: Vec<f64> = a.major.iter().copied().filter(inside).collect();
                if major.len() >= 2 {
                    a.minor.retain(inside);
                    (a.major, a.lo, a.hi) = (major, lmin, lmax);
                }
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
/// increasing colour fraction. Also returns the number of grey items.
fn colour_order(
    values: &[f64],
    drawable: &[usize],
    scale: ColourScale,
) -> (Option<Axis>, Order, usize) {
    let usable = |v: f64| v.is_finite() && (scale == ColourScale::Linear || v > 0.0);
    let (mut vmin, mut vmax) = (f64::MAX, f64::MIN);
    for v in drawable.iter().map(|&k| values[k]).filter(|&v| usable(v)) {
        (vmin, vmax) = (vmin.min(v), vmax.max(v));
    }
    let bar = (vmin <= vmax).then(|| colour_axis(vmin, vmax, scale));
    let bar_value = |v: f64| {
        if scale == ColourScale::Log {
            v.log10()
        } else {
            v
        }
    };
    let mut order: Order = (drawable.iter())
        .map(|&k| {
            let v = values[k];
            let t = bar.as_ref().filter(|_| usable(v));
            (t.map(|a| colour_fraction(a, bar_value(v))), k)
        })
        .collect();
    order.sort_by(|p, q| match (p.0, q.0) {
        (Some(a), Some(b)) => a.total_cmp(&b),
        (p, q) => p.is_some().cmp(&q.is_some()),
    });
    let greyed = order.iter().filter(|o| o.0.is_none()).count();
    (bar, order, greyed)
}

/// Axes with equal metres per pixel for the data box `[xmin, xmax, ymin,
/// ymax]` plus a margin of `pad` times its larger side, filling `w` x `h` px
/// (the axes' pixel lengths); both get the same tick step.
pub(super) fn equal_axes(bbox: [f64; 4], w: f64, h: f64, pad: f64) -> (Axis, Axis) {
    let try_box = |[xmin, xmax, ymin, ymax]: [f64; 4]| -> Option<(Axis, Axis)> {
        let span = (xmax - xmin).max(ymax - ymin);
        let pad = if span > 0.0 {
            pad * span
        } else {
            let m = xmin.abs().max(ymin.abs());
            if m > 0.0 { 0.1 * m } else { 1.0 }
        };
        let (xs, ys) = (xmax - xmin + 2.0 * pad, ymax - ymin + 2.0 * pad);
        let px_per_m = (w / xs).min(h / ys);
        let (xc, yc) = (xmin / 2.0 + xmax / 2.0, ymin / 2.0 + ymax / 2.0);
        let (hx, hy) = (0.5 * w / px_per_m, 0.5 * h / px_per_m);
        let ends = [xc - hx, xc + hx, yc - hy, yc + hy];
        if !(ends.iter().all(|v| v.is_finite()) && px_per_m > 0.0 && hx > 0.0 && hy > 0.0) {
            return None;
        }
        let x = Axis::linear_exact(xc - hx, xc + hx);
        let y = Axis::linear_exact(yc - hy, yc + hy);
        let step = x.step.max(y.step);
        Some((
            Axis::linear_stepped(x.lo, x.hi, step),
            Axis::linear_stepped(y.lo, y.hi, step),
        ))
    };
    try_box(bbox)
        .or_else(|| try_box([0.0, 1.0, 0.0, 1.0]))
        .unwrap_or_else(|| (Axis::linear(0.0, 1.0), Axis::linear(0.0, 1.0)))
}

/// `bbox` (`[xmin, xmax, ymin, ymax]`) grown to hold the points `ps`.
fn grow_box(bbox: [f64; 4], ps: impl IntoIterator<Item = [f64; 2]>) -> [f64; 4] {
    ps.into_iter().fold(bbox, |b, [x, y]| {
        [b[0].min(x), b[1].max(x), b[2].min(y), b[3].max(y)]
    })
}

const EMPTY_BOX: [f64; 4] = [f64::MAX, f64::MIN, f64::MAX, f64::MIN];

fn finite(p: &[f64; 2]) -> bool {
    p[0].is_finite() && p[1].is_finite()
}

/// A map's layout and colour bar.
struct MapLayout<'a> {
    base: Layout<'a>,
    value_label: &'a str,
    /// Colour-bar axis (`None`: nothing to colour, the bar is left blank).
    bar: Option<Axis>,
    bar_labels: Vec<(f64, String)>,
    bar_tick_w: i32,
}

impl<'a> MapLayout<'a> {
    /// Lay out a map of the data box `bbox` (`[xmin, xmax, ymin, ymax]`, m)
    /// with a margin of `pad` times its larger side, widened to the plotting
    /// area's aspect ratio.
    fn new(
        pens: &'a Pens,
        (title, value_label): (&'a str, &'a str),
        bar: Option<Axis>,
        bbox: [f64; 4],
        pad: f64,
    ) -> Self {
        let bar_labels: Vec<(f64, String)> = (bar.iter())
            .flat_map(|a| a.major.iter().map(|&t| (t, a.label(t))))
            .collect();
        let bar_mult_w = bar
            .as_ref()
            .and_then(Axis::multiplier)
            .map_or(0, |m| pens.tick.width(&m));
        let bar_tick_w = bar_labels
            .iter()
            .map(|(_, l)| pens.tick.width(l))
            .max()
            .unwrap_or(0);
        let bar_desc_w = if value_label.is_empty() {
            0
        } else {
            16 + pens.desc.cap() + 6
        };
        let right = (BAR_GAP + BAR_W + BAR_TICK + 6 + bar_tick_w + bar_desc_w + 20)
            .max(BAR_GAP + bar_mult_w + 16);
        let texts = (title, "x [m]", "y [m]");
        let unit = || Axis::linear(0.0, 1.0);
        let probe = Layout::new(pens, texts, unit(), unit(), Some(right), 0);
        let ax_h = (NET_HEIGHT as i32 - probe.bottom - 1 - probe.top).max(10) as f64;
        // The y tick labels' width sets the plot width, which sets the axes.
        let (mut y_tick_w, mut tries) = (0, 0);
        let axes = loop {
            let left = Layout::left_margin(pens, texts.2, y_tick_w);
            let ax_w = (NET_WIDTH as i32 - right - 1 - left).max(10) as f64;
            let axes = equal_axes(bbox, ax_w, ax_h, pad);
            let y = &axes.1;
            let need = y
                .major
                .iter()
                .map(|&t| pens.tick.width(&y.label(t)))
                .max()
                .unwrap_or(0);
            tries += 1;
            if need <= y_tick_w || tries == 5 {
                break axes;
            }
            y_tick_w = need;
        };
        MapLayout {
            base: Layout::new(pens, texts, axes.0, axes.1, Some(right), y_tick_w),
            value_label,
            bar,
            bar_labels,
            bar_tick_w,
        }
    }

    /// Draw a map with the content drawn by `content` (on the chart, clipped
    /// to the plotting area), labelled markers, axes, colour bar and notes.
    fn draw(
        &self,
        root: &Area,
        grid: bool,
        content: impl FnOnce(&Chart) -> Result<(), String>,
        markers: &[([f64; 2], &str)],
        (big, small): (Option<(&str, bool)>, &[String]),
    ) -> Result<Coords, String> {
        let b = &self.base;
        let mut chart = b.chart(root, grid.then_some((0.12, 0.04)))?;
        content(&chart)?;
        draw_markers(root, &chart, &b.pens.label, markers)?;
        let area = b.frame(root, &mut chart)?;
        let (px, py) = &area;

        // Colour bar, as tall as the plotting area.
        let (bx0, bx1) = (px.end - 1 + BAR_GAP, px.end - 1 + BAR_GAP + BAR_W);
        let (b_top, b_bot) = (py.start, py.end - 1);
        let bar_y = |f: f64| b_bot - (f * (b_bot - b_top) as f64).round() as i32;
        for y in b_top..=b_bot {
            let f = (b_bot - y) as f64 / (b_bot - b_top).max(1) as f64;
            let color = self
                .bar
                .as_ref()
                .map_or(RGBColor(240, 240, 240), |_| viridis(f));
            root.draw(&PathElement::new(vec![(bx0, y), (bx1, y)], color))
                .map_err(|e| e.to_string())?;
        }
        let edge = Rectangle::new([(bx0, b_top), (bx1, b_bot)], BLACK.stroke_width(1));
        root.draw(&edge).map_err(|e| e.to_string())?;
        let tick = &b.pens.tick;
        if let Some(a) = &self.bar {
            let ticks = (a.minor.iter().map(|&t| (t, 3)))
                .chain(self.bar_labels.iter().map(|(t, _)| (*t, BAR_TICK)));
            for (t, len) in ticks {
                let y = bar_y(colour_fraction(a, t));
                root.draw(&PathElement::new(vec![(bx1, y), (bx1 + len, y)], BLACK))
                    .map_err(|e| e.to_string())?;
            }
            for (t, l) in &self.bar_labels {
                let at = (bx1 + BAR_TICK + 6, bar_y(colour_fraction(a, *t)));
                tick.draw(root, l, at, (HPos::Left, VPos::Center), false)?;
            }
            if let Some(m) = a.multiplier() {
                let at = (bx0, b_top - 8);
                tick.draw(root, &m, at, (HPos::Left, VPos::Bottom), false)?;
            }
        }
        if !self.value_label.is_empty() {
            let desc = &b.pens.desc;
            let x = bx1 + BAR_TICK + 6 + self.bar_tick_w + 16 + (desc.cap() + 6) / 2;
            let at = (x, (b_top + b_bot) / 2);
            let center = (HPos::Center, VPos::Center);
            desc.draw(root, self.value_label, at, center, true)?;
        }
        b.notes(root, &area, big, small)?;
        Ok(chart.as_coord_spec().clone())
    }
}

/// Labelled points as red discs with a dark rim on a white halo, each label
/// on a white box beside its point (left of it near the right edge).
fn draw_markers(
    root: &Area,
    chart: &Chart,
    pen: &super::Pen,
    markers: &[([f64; 2], &str)],
) -> Result<(), String> {
    let (px, py) = chart.plotting_area().get_pixel_range();
    let centres: Vec<(i32, i32)> = markers
        .iter()
        .map(|m| chart.backend_coord(&(m.0[0], m.0[1])))
        .collect();
    for &c in &centres {
        for (r, color) in [(8, WHITE), (7, RGBColor(40, 40, 40)), (5, MARKER_FILL)] {
            root.draw(&Circle::new(c, r, color.filled()))
                .map_err(|e| e.to_string())?;
        }
    }
    for (&(cx, cy), &(_, label)) in centres.iter().zip(markers) {
        if label.is_empty() {
            continue;
        }
        let w = pen.width(label);
        let half = pen.cap() / 2 + 10;
        let y = cy.clamp(py.start + half, (py.end - half).max(py.start + half));
        if cx + 16 + w + 10 <= px.end {
            boxed_text(root, pen, label, (cx + 16, y), HPos::Left)?;
        } else {
            boxed_text(root, pen, label, (cx - 16, y), HPos::Right)?;
        }
    }
    Ok(())
}

/// Arguments of [`network`], validated.
pub(super) struct Network<'a> {
    pub texts: (&'a str, &'a str),
    pub segments: &'a [Segment],
    pub values: &'a [f64],
    pub scale: ColourScale,
    pub width_px: Option<&'a [f64]>,
    pub markers: &'a [([f64; 2], &'a str)],
}

pub(super) fn draw_network(root: &Area, pens: &Pens, net: &Network) -> Result<Coords, String> {
    let segs = net.segments;
    let drawable: Vec<usize> = (0..segs.len())
        .filter(|&k| finite(&segs[k].a) && finite(&segs[k].b))
        .collect();
    let no_coords = segs.len() - drawable.len();
    let markers: Vec<([f64; 2], &str)> = net
        .markers
        .iter()
        .filter(|m| finite(&m.0))
        .copied()
        .collect();
    let ends = drawable.iter().flat_map(|&k| [segs[k].a, segs[k].b]);
    let mut bbox = grow_box(EMPTY_BOX, ends.chain(markers.iter().map(|m| m.0)));
    if bbox[0] > bbox[1] {
        bbox = [0.0, 1.0, 0.0, 1.0];
    }
    let (bar, order, greyed) = colour_order(net.values, &drawable, net.scale);
    let layout = MapLayout::new(pens, net.texts, bar, bbox, NET_PAD);

    let content = |chart: &Chart| {
        for &(t, k) in &order {
            let color = t.map_or(NO_VALUE_GREY, viridis);
            let w = match net.width_px.map(|w| w[k]) {
                Some(w) if w.is_finite() => w.clamp(NET_LINE_MIN_PX, NET_LINE_MAX_PX),
                _ => NET_LINE_PX,
            };
            let (a, b) = ((segs[k].a[0], segs[k].a[1]), (segs[k].b[0], segs[k].b[1]));
            let px = w.round().max(1.0) as u32;
            let area = chart.plotting_area();
            (area.draw(&PathElement::new(vec![a, b], color.stroke_width(px))))
                .map_err(|e| e.to_string())?;
            // Round caps (plotters' wide lines end square), which also show
            // segments shorter than a pixel.
            for p in [a, b].into_iter().filter(|_| px >= 2) {
                (area.draw(&Circle::new(p, px / 2, color.filled()))).map_err(|e| e.to_string())?;
            }
        }
        Ok(())
    };

    let big = if segs.is_empty() {
        Some("no segments to plot")
    } else if drawable.is_empty() {
        Some("no segments with finite end points to plot")
    } else if layout.bar.is_none() {
        Some(match net.scale {
            ColourScale::Linear => "no finite values to colour (all segments grey)",
            ColourScale::Log => "no finite, positive values to colour (all segments grey)",
        })
    } else {
        None
    };
    let centred = drawable.is_empty() && markers.is_empty();
    let mut notes = Vec::new();
    if greyed > 0 && layout.bar.is_some() {
        let what = match net.scale {
            ColourScale::Linear => "a non-finite value",
            ColourScale::Log => "a non-positive or non-finite value",
        };
        notes.push(format!(
            "{} with {what} drawn grey",
            count(greyed, "segment")
        ));
    }
    if no_coords > 0 {
        let s = count(no_coords, "segment");
        notes.push(format!("{s} with non-finite end points omitted"));
    }
    let big = big.map(|m| (m, centred));
    layout.draw(root, true, content, &markers, (big, &notes))
}

/// Arguments of [`fracture_map`], validated.
pub(super) struct QuadMap<'a> {
    pub texts: (&'a str, &'a str),
    pub mesh_edges: &'a [Segment],
    pub quads: &'a [[[f64; 2]; 4]],
    pub values: &'a [f64],
    pub window: Option<[f64; 4]>,
    pub markers: &'a [([f64; 2], &'a str)],
}

pub(super) fn draw_fracture_map(root: &Area, pens: &Pens, map: &QuadMap) -> Result<Coords, String> {
    let quads = map.quads;
    let drawable: Vec<usize> = (0..quads.len())
        .filter(|&k| quads[k].iter().all(finite))
        .collect();
    let no_coords = quads.len() - drawable.len();
    let edges: Vec<&Segment> = (map.mesh_edges.iter())
        .filter(|s| finite(&s.a) && finite(&s.b))
        .collect();
    let bad_edges = map.mesh_edges.len() - edges.len();

    // Region shown: the window, else the quads and markers, else the mesh.
    let (bbox, pad) = if let Some(w) = map.window {
        (w, 0.0)
    } else {
        let corners = drawable.iter().flat_map(|&k| quads[k]);
        let mut bbox = grow_box(
            EMPTY_BOX,
            corners.chain(map.markers.iter().map(|m| m.0).filter(finite)),
        );
        if bbox[0] > bbox[1] {
            bbox = grow_box(bbox, edges.iter().flat_map(|s| [s.a, s.b]));
        }
        if bbox[0] > bbox[1] {
            bbox = [0.0, 1.0, 0.0, 1.0];
        }
        (bbox, QUAD_PAD)
    };
    let (bar, order, greyed) = colour_order(map.values, &drawable, ColourScale::Linear);
    let layout = MapLayout::new(pens, map.texts, bar, bbox, pad);
    let (x, y) = (&layout.base.x, &layout.base.y);
    // Whether anything of the points' box lies within the axes.
    let shown = |ps: &[[f64; 2]]| {
        let b = grow_box(EMPTY_BOX, ps.iter().copied());
        b[0] <= x.hi && b[1] >= x.lo && b[2] <= y.hi && b[3] >= y.lo
    };

    let content = |chart: &Chart| {
        let area = chart.plotting_area();
        for s in edges.iter().filter(|s| shown(&[s.a, s.b])) {
            let line = vec![(s.a[0], s.a[1]), (s.b[0], s.b[1])];
            area.draw(&PathElement::new(line, MESH_GREY))
                .map_err(|e| e.to_string())?;
        }
        for &(t, k) in order.iter().filter(|o| shown(&quads[o.1])) {
            let color = t.map_or(NO_VALUE_GREY, viridis);
            let pts: Vec<(f64, f64)> = quads[k].iter().map(|p| (p[0], p[1])).collect();
            let mut edge = pts.clone();
            edge.push(pts[0]);
            area.draw(&Polygon::new(pts, color.filled()))
                .and_then(|()| area.draw(&PathElement::new(edge, color)))
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    };
    let markers: Vec<([f64; 2], &str)> = (map.markers.iter())
        .filter(|m| (x.lo..=x.hi).contains(&m.0[0]) && (y.lo..=y.hi).contains(&m.0[1]))
        .copied()
        .collect();

    let big = if quads.is_empty() {
        Some("no fracture cells to plot")
    } else if drawable.is_empty() {
        Some("no fracture cells with finite corners to plot")
    } else if layout.bar.is_none() {
        Some("no finite values to colour (all cells grey)")
    } else {
        None
    };
    let centred = drawable.is_empty() && markers.is_empty() && edges.is_empty();
    let mut notes = Vec::new();
    if greyed > 0 && layout.bar.is_some() {
        let s = count(greyed, "cell");
        notes.push(format!("{s} with a non-finite value drawn grey"));
    }
    if no_coords > 0 {
        notes.push(format!(
            "{} with non-finite corners omitted",
            count(no_coords, "cell")
        ));
    }
    if bad_edges > 0 {
        let s = count(bad_edges, "mesh edge");
        notes.push(format!("{s} with non-finite end points omitted"));
    }
    let big = big.map(|m| (m, centred));
    layout.draw(root, false, content, &markers, (big, &notes))
}
