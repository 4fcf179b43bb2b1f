//! PNG line plots (log-log and linear) and fracture-network maps, drawn with
//! plotters' bitmap backend and elements, its viridis colormap and the
//! embedded DejaVu Sans font (`assets/DejaVuSans.ttf`), written atomically.
//!
//! Text is laid out and rasterised by `ab_glyph` (behind plotters' text path)
//! through [`Pen`], not by plotters' text elements: plotters 0.3.7 puts each
//! glyph's ink at the pen position, dropping its left side bearing, and at odd
//! pixel sizes rounds glyphs whose top lies below half the font size one pixel
//! up. Both show (uneven letter spacing, "x" above the baseline of "H"); the
//! test `plotters_text_is_uneven` measures them.

mod axis;
mod lines;
mod map;
#[cfg(test)]
mod tests;

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, GlyphId, ScaleFont, point};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use plotters::style::{FontStyle, RGBColor};

use axis::Axis;
pub use lines::{Panel, lines, loglog, scatter, stacked};
pub use map::{event_map, fracture_map, network};

/// One named polyline (drawn in the given order).
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// How a scalar maps to colour (see [`network`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColourScale {
    Linear,
    Log,
}

/// One line segment of a fracture network, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub a: [f64; 2],
    pub b: [f64; 2],
}

/// Error from [`loglog`] / [`lines`] / [`network`] / [`fracture_map`].
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("the embedded plot font could not be loaded")]
    Font,
    #[error("invalid input for plot {path}: {message}")]
    Input { path: PathBuf, message: String },
    #[error("cannot draw plot {path}: {message}")]
    Draw { path: PathBuf, message: String },
    #[error("cannot write plot {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

type Area<'b> = DrawingArea<BitMapBackend<'b>, Shift>;
type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Coords>;
/// Where data coordinates land on the image.
type Coords = Cartesian2d<Axis, Axis>;
type Drawn<T = ()> = DrawResult<T, BitMapBackend<'static>>;
/// Title, x and y axis descriptions.
type Texts<'a> = (&'a str, &'a str, &'a str);
/// Pixel ranges of a plotting area.
type PixelBox = (Range<i32>, Range<i32>);

static FONT_BYTES: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../assets/DejaVuSans.ttf"
));
static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();

/// Load the embedded font, and register it with plotters (whose mesh code
/// lays out the empty tick labels it is given in "sans-serif").
fn ensure_font() -> Result<(), PlotError> {
    let font = FONT.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT_BYTES).ok()?;
        FontRef::try_from_slice(FONT_BYTES).ok()
    });
    font.as_ref().map(drop).ok_or(PlotError::Font)
}

/// Text of one size (px) and colour, laid out with the font's advances,
/// kerning and side bearings (module docs); draws nothing before [`ensure_font`].
#[derive(Clone, Copy)]
struct Pen(f32, RGBColor);

const TITLE: Pen = Pen(28.0, RGBColor(0, 0, 0));
const DESC: Pen = Pen(21.0, RGBColor(0, 0, 0));
const TICK: Pen = Pen(17.0, RGBColor(30, 30, 30));
const LABEL: Pen = Pen(17.0, RGBColor(0, 0, 0));
const NOTE: Pen = Pen(15.0, RGBColor(110, 110, 110));
const BIG_NOTE: Pen = Pen(22.0, RGBColor(90, 90, 90));
const TICK_GAP: i32 = 10;

/// Text anchors: which point of the text goes to the given position
/// (vertically relative to the cap height).
type Anchor = (HPos, VPos);
const CENTRE: Anchor = (HPos::Center, VPos::Center);
const BELOW: Anchor = (HPos::Center, VPos::Top);
const RIGHT_OF: Anchor = (HPos::Left, VPos::Center);
const LEFT_OF: Anchor = (HPos::Right, VPos::Center);
const ABOVE_RIGHT: Anchor = (HPos::Left, VPos::Bottom);

fn font() -> Option<&'static FontRef<'static>> {
    FONT.get().and_then(Option::as_ref)
}

/// The share of a text's width left of its anchor.
fn share(h: HPos) -> f32 {
    match h {
        HPos::Left => 0.0,
        HPos::Center => 0.5,
        HPos::Right => 1.0,
    }
}

impl Pen {
    /// The glyphs of `s` with their pen positions, and the advance width (px).
    fn layout(self, s: &str) -> (Vec<(GlyphId, f32)>, f32) {
        let (mut x, mut prev, mut glyphs) = (0.0, None, Vec::new());
        let Some(f) = font().map(|f| f.as_scaled(self.0)) else {
            return (glyphs, x);
        };
        for c in s.chars() {
            let id = f.glyph_id(c);
            x += prev.map_or(0.0, |p| f.kern(p, id));
            glyphs.push((id, x));
            x += f.h_advance(id);
            prev = Some(id);
        }
        (glyphs, x)
    }

    fn width(self, s: &str) -> i32 {
        self.layout(s).1.round() as i32
    }

    /// Cap height in pixels.
    fn cap(self) -> i32 {
        let h = font().and_then(|f| {
            let b = f.outline(f.glyph_id('H'))?.bounds;
            Some((b.max.y - b.min.y).abs() * f.as_scaled(self.0).v_scale_factor())
        });
        h.unwrap_or(0.7 * self.0).round() as i32
    }

    /// Draw `s` with its `anchor` at `pos`.
    fn draw(self, area: &Area, s: &str, pos: (i32, i32), anchor: Anchor) -> Drawn {
        self.put(area, s, pos, anchor, false)
    }

    /// Draw `s` reading bottom-to-top, centred on `pos`.
    fn draw_up(self, area: &Area, s: &str, pos: (i32, i32)) -> Drawn {
        self.put(area, s, pos, CENTRE, true)
    }

    fn put(self, area: &Area, s: &str, pos: (i32, i32), (h, v): Anchor, up: bool) -> Drawn {
        let (glyphs, w) = self.layout(s);
        let x0 = -w * share(h);
        let base = match v {
            VPos::Top => self.cap(),
            VPos::Center => self.cap() / 2,
            VPos::Bottom => 0,
        };
        let mut result = Ok(());
        for (id, x) in glyphs {
            let glyph = id.with_scale_and_position(self.0, point(x0 + x, base as f32));
            let Some(g) = font().and_then(|f| f.outline_glyph(glyph)) else {
                continue;
            };
            let min = g.px_bounds().min;
            g.draw(|gx, gy, a| {
                let (x, y) = (min.x as i32 + gx as i32, min.y as i32 + gy as i32);
                let (x, y) = if up { (y, -x) } else { (x, y) };
                if a > 0.0 && result.is_ok() {
                    let p = (pos.0 + x, pos.1 + y);
                    result = area.draw_pixel(p, &self.1.mix(a.min(1.0) as f64));
                }
            });
        }
        result
    }
}

/// Draw a `size` px PNG at `path` with `draw`, atomically (`crate::atomic`).
fn write_png<T>(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Drawn<T>,
) -> Result<(), PlotError> {
    ensure_font()?;
    let draw_file = |tmp: &Path| {
        let root = BitMapBackend::new(tmp, size).into_drawing_area();
        let drawn = draw(&root).and_then(|_| root.present());
        drawn.map_err(|e| PlotError::Draw {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    };
    let io = |source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    };
    crate::atomic::write_via_path(path, draw_file, io)
}

/// Axes, texts and margins (px: top, right, bottom, left) around the
/// plotting area of a figure.
struct Layout<'a> {
    texts: Texts<'a>,
    x: Axis,
    y: Axis,
    y_tick_w: i32,
    margin: [i32; 4],
}

/// Tick labels of the major ticks of `a`.
fn labels(a: &Axis) -> impl Iterator<Item = (f64, String)> + '_ {
    a.major.iter().map(|&t| (t, a.label(t)))
}

/// Width of the widest tick label of `a`, at least `min`.
fn labels_width(a: &Axis, min: i32) -> i32 {
    labels(a).map(|(_, l)| TICK.width(&l)).fold(min, i32::max)
}

/// Room (px) for the text `s` in `pen` plus `gap`; none for no text.
fn room(s: &str, pen: Pen, gap: i32) -> i32 {
    if s.is_empty() { 0 } else { pen.cap() + gap }
}

impl<'a> Layout<'a> {
    /// Margin left of the plotting area for y tick labels `y_tick_w` px wide.
    fn left_margin(ylabel: &str, y_tick_w: i32) -> i32 {
        16 + room(ylabel, DESC, 24) + y_tick_w + TICK_GAP
    }

    /// Layout with `right` px right of the plotting area (`None`: room for
    /// the last x tick label) and y tick labels at least `min_y_tick_w` wide.
    fn new(texts: Texts<'a>, x: Axis, y: Axis, right: Option<i32>, min_y_tick_w: i32) -> Self {
        let y_tick_w = labels_width(&y, min_y_tick_w);
        let last_x_w = labels(&x).last().map_or(0, |(_, l)| TICK.width(&l));
        let top = 24 + room(texts.0, TITLE, 20);
        let right = right.unwrap_or((last_x_w / 2 + 12).max(32));
        let bottom = TICK_GAP + TICK.cap() + 22 + room(texts.1, DESC, 24);
        let margin = [top, right, bottom, Layout::left_margin(texts.2, y_tick_w)];
        Layout {
            texts,
            x,
            y,
            y_tick_w,
            margin,
        }
    }

    /// White background, the chart and its grid (`grid`: major, minor line opacity).
    fn chart<'c, 'b>(&self, root: &'c Area<'b>, grid: Option<(f64, f64)>) -> Drawn<Chart<'c, 'b>> {
        root.fill(&WHITE)?;
        let [top, right, bottom, left] = self.margin;
        let mut builder = ChartBuilder::on(root);
        builder.margin_top(top).margin_right(right);
        builder.x_label_area_size(bottom).y_label_area_size(left);
        let mut chart = builder.build_cartesian_2d(self.x.clone(), self.y.clone())?;
        if let Some((major, minor)) = grid {
            let mut mesh = chart.configure_mesh();
            mesh.disable_axes().bold_line_style(BLACK.mix(major));
            mesh.light_line_style(BLACK.mix(minor)).draw()?;
        }
        Ok(chart)
    }

    /// Over the content: white outside the plotting area (clipping the
    /// content to it), the axes with tick marks, the frame's top and right
    /// sides, tick labels, axis descriptions, title and multipliers. Returns
    /// the pixel ranges of the plotting area.
    fn frame(&self, root: &Area, chart: &mut Chart) -> Drawn<PixelBox> {
        let (px, py) = chart.plotting_area().get_pixel_range();
        let (w, h) = root.dim_in_pixel();
        let (w, h) = (w as i32, h as i32);
        let (top, bottom) = ([(0, 0), (w, py.start - 1)], [(0, py.end), (w, h)]);
        let (left, right) = ([(0, 0), (px.start - 1, h)], [(px.end, 0), (w, h)]);
        for r in [top, bottom, left, right] {
            root.draw(&Rectangle::new(r, WHITE.filled()))?;
        }
        let no_label = |_: &f64| String::new();
        let mut mesh = chart.configure_mesh();
        mesh.disable_mesh().x_label_formatter(&no_label);
        mesh.y_label_formatter(&no_label).axis_style(BLACK);
        mesh.set_all_tick_mark_size(6).draw()?;
        let (x1, y1) = (px.end - 1, py.end - 1);
        let corner = vec![(px.start, py.start), (x1, py.start), (x1, y1)];
        root.draw(&PathElement::new(corner, BLACK))?;

        for (t, l) in labels(&self.x) {
            let x = chart.backend_coord(&(t, self.y.lo)).0;
            TICK.draw(root, &l, (x, py.end + TICK_GAP), BELOW)?;
        }
        for (t, l) in labels(&self.y) {
            let y = chart.backend_coord(&(self.x.lo, t)).1;
            TICK.draw(root, &l, (px.start - TICK_GAP, y), LEFT_OF)?;
        }
        let (title, xlabel, ylabel) = self.texts;
        let (cx, cy) = ((px.start + px.end) / 2, (py.start + py.end) / 2);
        let below = py.end + TICK_GAP + TICK.cap() + 26;
        DESC.draw(root, xlabel, (cx, below), BELOW)?;
        let x = px.start - TICK_GAP - self.y_tick_w - 18 - (DESC.cap() + 6) / 2;
        DESC.draw_up(root, ylabel, (x, cy))?;
        TITLE.draw(root, title, (cx, 18), BELOW)?;
        if let Some(m) = self.x.multiplier() {
            TICK.draw(root, &m, (px.end, below), (HPos::Right, VPos::Top))?;
        }
        if let Some(m) = self.y.multiplier() {
            TICK.draw(root, &m, (px.start, py.start - 8), ABOVE_RIGHT)?;
        }
        Ok((px, py))
    }
}

/// A big note (`(text, centred)`: centred in the plotting area `(px, py)`,
/// else boxed near its top) and small notes in the image's lower left corner.
fn notes(root: &Area, (px, py): &PixelBox, big: Option<(&str, bool)>, small: &[String]) -> Drawn {
    let cx = (px.start + px.end) / 2;
    let top = py.start + 24 + BIG_NOTE.cap() / 2;
    match big {
        Some((msg, true)) => BIG_NOTE.draw(root, msg, (cx, (py.start + py.end) / 2), CENTRE)?,
        Some((msg, false)) => boxed_text(root, BIG_NOTE, msg, (cx, top), HPos::Center)?,
        None => {}
    }
    let at = (12, root.dim_in_pixel().1 as i32 - 12);
    NOTE.draw(root, &small.join("; "), at, ABOVE_RIGHT)
}

/// A legend-style box (nearly opaque white, thin grey border).
fn legend_box(root: &Area, corners: [(i32, i32); 2]) -> Drawn {
    root.draw(&Rectangle::new(corners, WHITE.mix(0.92).filled()))?;
    root.draw(&Rectangle::new(corners, BLACK.mix(0.35)))
}

/// Text on a legend-style box, vertically centred on `pos.1`.
fn boxed_text(root: &Area, pen: Pen, s: &str, pos: (i32, i32), h: HPos) -> Drawn {
    let w = pen.width(s);
    let x0 = pos.0 - (w as f32 * share(h)) as i32;
    // Room for descenders below the baseline.
    let top = pos.1 - pen.cap() / 2 - 7;
    let bottom = pos.1 + (pen.cap() + 1) / 2 + pen.cap() / 4 + 7;
    legend_box(root, [(x0 - 8, top), (x0 + w + 8, bottom)])?;
    pen.draw(root, s, (x0, pos.1), RIGHT_OF)
}

/// `[xmin, xmax, ymin, ymax]` of the points `ps`; xmin > xmax if there are none.
fn bounding_box(ps: impl IntoIterator<Item = [f64; 2]>) -> [f64; 4] {
    let grow = |b: [f64; 4], [x, y]: [f64; 2]| [b[0].min(x), b[1].max(x), b[2].min(y), b[3].max(y)];
    ps.into_iter()
        .fold([f64::MAX, f64::MIN, f64::MAX, f64::MIN], grow)
}

/// `n` things, with a plural "s" on `what` unless `n` is 1.
fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// What notes call values that can (log scale: positive) and cannot be plotted.
fn value_words(log: bool) -> [&'static str; 2] {
    match log {
        true => ["finite, positive", "non-positive or non-finite"],
        false => ["finite", "non-finite"],
    }
}
