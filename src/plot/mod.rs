//! PNG line plots (log-log and linear, [`lines`]) and fracture-network maps
//! ([`map`]), drawn with plotters' bitmap backend and elements, plotters'
//! viridis colormap and the embedded DejaVu Sans font
//! (`assets/DejaVuSans.ttf`).
//!
//! Log plots are drawn in log10 space with power-of-ten tick labels. Series
//! with more than 60 points get no markers. The legend goes in the plot
//! corner covering the fewest curve samples. PNGs are written atomically
//! (`crate::atomic`: a temporary file in the same folder, then renamed).
//!
//! Text is laid out and rasterised by `ab_glyph` (the crate behind plotters'
//! own text path) through [`Pen`], not by plotters' text elements: plotters
//! 0.3.7 places each glyph's ink at the pen position, dropping the glyph's
//! left side bearing, and at odd pixel sizes it rounds glyphs whose top lies
//! below half the font size one pixel up. Both are visible (uneven letter
//! spacing, "x" hopping above the baseline of "H"); the test
//! `plotters_text_is_uneven` measures them.

mod axis;
mod lines;
mod map;

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, GlyphId, ScaleFont, point};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use plotters::style::{FontStyle, RGBColor};

use axis::Axis;
pub use lines::{lines, loglog};
pub use map::{fracture_map, network};

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
type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<Axis, Axis>>;
/// Where data coordinates land on the image.
type Coords = Cartesian2d<Axis, Axis>;

const TITLE_SIZE: f32 = 28.0;
const DESC_SIZE: f32 = 21.0;
const TICK_SIZE: f32 = 17.0;
const LABEL_SIZE: f32 = 17.0;
const TICK_GAP: i32 = 10;
const BLACK_TEXT: RGBColor = RGBColor(0, 0, 0);

static FONT_BYTES: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/DejaVuSans.ttf"
));

/// The embedded font, also registered with plotters (its mesh code lays out
/// the empty tick labels it is given with the "sans-serif" font).
fn font() -> Result<FontRef<'static>, PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT_BYTES).is_ok()
    });
    match FontRef::try_from_slice(FONT_BYTES) {
        Ok(f) if ok => Ok(f),
        _ => Err(PlotError::Font),
    }
}

/// Text of one size and colour, laid out with the font's advances, kerning
/// and side bearings (see the module docs).
#[derive(Clone)]
struct Pen {
    font: FontRef<'static>,
    size: f32,
    color: RGBColor,
}

impl Pen {
    fn new(font: &FontRef<'static>, size: f32, color: RGBColor) -> Pen {
        let font = font.clone();
        Pen { font, size, color }
    }

    /// The glyphs of `s` with their pen positions, and the advance width (px).
    fn layout(&self, s: &str) -> (Vec<(GlyphId, f32)>, f32) {
        let f = self.font.as_scaled(self.size);
        let (mut x, mut prev, mut glyphs) = (0.0, None, Vec::new());
        for c in s.chars() {
            let id = f.glyph_id(c);
            x += prev.map_or(0.0, |p| f.kern(p, id));
            glyphs.push((id, x));
            x += f.h_advance(id);
            prev = Some(id);
        }
        (glyphs, x)
    }

    fn width(&self, s: &str) -> i32 {
        self.layout(s).1.round() as i32
    }

    /// Cap height in pixels.
    fn cap(&self) -> i32 {
        let f = self.font.as_scaled(self.size);
        let h = self.font.outline(f.glyph_id('H'));
        h.map_or(0.7 * self.size, |o| {
            (o.bounds.max.y - o.bounds.min.y).abs() * f.v_scale_factor()
        })
        .round() as i32
    }

    /// Draw `s` anchored at `pos` (vertical anchor relative to the cap
    /// height); `vertical` text reads bottom-to-top.
    fn draw(
        &self,
        area: &Area,
        s: &str,
        pos: (i32, i32),
        (h, v): (HPos, VPos),
        vertical: bool,
    ) -> Result<(), String> {
        let (glyphs, w) = self.layout(s);
        let x0 = match h {
            HPos::Left => 0.0,
            HPos::Center => -w / 2.0,
            HPos::Right => -w,
        };
        let baseline = match v {
            VPos::Top => self.cap(),
            VPos::Center => self.cap() / 2,
            VPos::Bottom => 0,
        } as f32;
        let f = self.font.as_scaled(self.size);
        let mut result = Ok(());
        for (id, x) in glyphs {
            let at = point(x0 + x, baseline);
            let Some(g) = f.outline_glyph(id.with_scale_and_position(self.size, at)) else {
                continue;
            };
            let min = g.px_bounds().min;
            g.draw(|gx, gy, a| {
                let (lx, ly) = (min.x as i32 + gx as i32, min.y as i32 + gy as i32);
                let p = if vertical {
                    (pos.0 + ly, pos.1 - lx)
                } else {
                    (pos.0 + lx, pos.1 + ly)
                };
                if a > 0.0 && result.is_ok() {
                    let c = self.color.mix(a.min(1.0) as f64);
                    result = area.draw_pixel(p, &c).map_err(|e| e.to_string());
                }
            });
        }
        result
    }
}

/// The pens of a figure.
struct Pens {
    title: Pen,
    desc: Pen,
    tick: Pen,
    label: Pen,
    note: Pen,
    big_note: Pen,
}

impl Pens {
    fn new() -> Result<Pens, PlotError> {
        let f = font()?;
        Ok(Pens {
            title: Pen::new(&f, TITLE_SIZE, BLACK_TEXT),
            desc: Pen::new(&f, DESC_SIZE, BLACK_TEXT),
            tick: Pen::new(&f, TICK_SIZE, RGBColor(30, 30, 30)),
            label: Pen::new(&f, LABEL_SIZE, BLACK_TEXT),
            note: Pen::new(&f, 15.0, RGBColor(110, 110, 110)),
            big_note: Pen::new(&f, 22.0, RGBColor(90, 90, 90)),
        })
    }
}

fn draw_err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Draw a `size` px PNG with `draw` into a temporary file next to `path`,
/// then sync and rename it to `path` (`crate::atomic`).
fn write_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<(), String>,
) -> Result<(), PlotError> {
    let io = |source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    };
    crate::atomic::write_via_path(
        path,
        |tmp| {
            let root = BitMapBackend::new(tmp, size).into_drawing_area();
            let r = draw(&root).and_then(|()| root.present().map_err(|e| e.to_string()));
            drop(root);
            r.map_err(|m| draw_err(path, m))
        },
        io,
    )
}

/// Axes, texts and margins (px) around the plotting area of a figure.
struct Layout<'a> {
    pens: &'a Pens,
    title: &'a str,
    xlabel: &'a str,
    ylabel: &'a str,
    x: Axis,
    y: Axis,
    x_labels: Vec<(f64, String)>,
    y_labels: Vec<(f64, String)>,
    y_tick_w: i32,
    top: i32,
    right: i32,
    bottom: i32,
    left: i32,
}

impl<'a> Layout<'a> {
    /// Margin left of the plotting area for y tick labels `y_tick_w` px wide.
    fn left_margin(pens: &Pens, ylabel: &str, y_tick_w: i32) -> i32 {
        let ydesc_w = if ylabel.is_empty() {
            0
        } else {
            pens.desc.cap() + 6 + 18
        };
        16 + ydesc_w + y_tick_w + TICK_GAP
    }

    /// Layout with `right` px right of the plotting area (`None`: room for
    /// the last x tick label) and y tick labels at least `min_y_tick_w` wide.
    #[allow(clippy::too_many_arguments)]
    fn new(
        pens: &'a Pens,
        (title, xlabel, ylabel): (&'a str, &'a str, &'a str),
        x: Axis,
        y: Axis,
        right: Option<i32>,
        min_y_tick_w: i32,
    ) -> Self {
        let labels =
            |a: &Axis| -> Vec<(f64, String)> { a.major.iter().map(|&t| (t, a.label(t))).collect() };
        let (x_labels, y_labels) = (labels(&x), labels(&y));
        let y_tick_w =
            (y_labels.iter().map(|(_, l)| pens.tick.width(l))).fold(min_y_tick_w, i32::max);
        let last_x_w = x_labels.last().map_or(0, |(_, l)| pens.tick.width(l));
        let xdesc_h = if xlabel.is_empty() {
            0
        } else {
            18 + pens.desc.cap() + 6
        };
        Layout {
            top: if title.is_empty() {
                24
            } else {
                18 + pens.title.cap() + 26
            },
            right: right.unwrap_or((last_x_w / 2 + 12).max(32)),
            bottom: TICK_GAP + pens.tick.cap() + 8 + xdesc_h + 14,
            left: Layout::left_margin(pens, ylabel, y_tick_w),
            pens,
            title,
            xlabel,
            ylabel,
            x,
            y,
            x_labels,
            y_labels,
            y_tick_w,
        }
    }

    /// White background, the chart and its grid (`grid`: opacity of the
    /// major and the minor grid lines).
    fn chart<'c, 'b>(
        &self,
        root: &'c Area<'b>,
        grid: Option<(f64, f64)>,
    ) -> Result<Chart<'c, 'b>, String> {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut chart = ChartBuilder::on(root)
            .margin_top(self.top)
            .margin_right(self.right)
            .x_label_area_size(self.bottom)
            .y_label_area_size(self.left)
            .build_cartesian_2d(self.x.clone(), self.y.clone())
            .map_err(|e| e.to_string())?;
        if let Some((major, minor)) = grid {
            (chart.configure_mesh().disable_axes())
                .bold_line_style(BLACK.mix(major))
                .light_line_style(BLACK.mix(minor))
                .draw()
                .map_err(|e| e.to_string())?;
        }
        Ok(chart)
    }

    /// Over the content: white outside the plotting area (clipping the
    /// content to it), the axes with tick marks, the frame's top and right
    /// sides, tick labels, axis descriptions, title and multipliers. Returns
    /// the pixel ranges of the plotting area.
    fn frame(&self, root: &Area, chart: &mut Chart) -> Result<(Range<i32>, Range<i32>), String> {
        let (px, py) = chart.plotting_area().get_pixel_range();
        let (w, h) = root.dim_in_pixel();
        let (w, h) = (w as i32, h as i32);
        let outside = [
            [(0, 0), (w, py.start - 1)],
            [(0, py.end), (w, h)],
            [(0, 0), (px.start - 1, h)],
            [(px.end, 0), (w, h)],
        ];
        for r in outside {
            root.draw(&Rectangle::new(r, WHITE.filled()))
                .map_err(|e| e.to_string())?;
        }
        let no_label = |_: &f64| String::new();
        (chart.configure_mesh().disable_mesh())
            .x_label_formatter(&no_label)
            .y_label_formatter(&no_label)
            .axis_style(BLACK.stroke_width(1))
            .set_all_tick_mark_size(6)
            .draw()
            .map_err(|e| e.to_string())?;
        let corner = vec![
            (px.start, py.start),
            (px.end - 1, py.start),
            (px.end - 1, py.end - 1),
        ];
        root.draw(&PathElement::new(corner, BLACK.stroke_width(1)))
            .map_err(|e| e.to_string())?;

        let pens = self.pens;
        let tick = &pens.tick;
        for (t, l) in &self.x_labels {
            let (x, _) = chart.backend_coord(&(*t, self.y.lo));
            let at = (x, py.end + TICK_GAP);
            tick.draw(root, l, at, (HPos::Center, VPos::Top), false)?;
        }
        for (t, l) in &self.y_labels {
            let (_, y) = chart.backend_coord(&(self.x.lo, *t));
            let at = (px.start - TICK_GAP, y);
            tick.draw(root, l, at, (HPos::Right, VPos::Center), false)?;
        }
        let (cx, cy) = ((px.start + px.end) / 2, (py.start + py.end) / 2);
        let below = py.end + TICK_GAP + tick.cap() + 8 + 18;
        let center_top = (HPos::Center, VPos::Top);
        if !self.xlabel.is_empty() {
            pens.desc
                .draw(root, self.xlabel, (cx, below), center_top, false)?;
        }
        if !self.ylabel.is_empty() {
            let x = px.start - TICK_GAP - self.y_tick_w - 18 - (pens.desc.cap() + 6) / 2;
            let center = (HPos::Center, VPos::Center);
            pens.desc.draw(root, self.ylabel, (x, cy), center, true)?;
        }
        if !self.title.is_empty() {
            pens.title
                .draw(root, self.title, (cx, 18), center_top, false)?;
        }
        if let Some(m) = self.x.multiplier() {
            tick.draw(root, &m, (px.end, below), (HPos::Right, VPos::Top), false)?;
        }
        if let Some(m) = self.y.multiplier() {
            let at = (px.start, py.start - 8);
            tick.draw(root, &m, at, (HPos::Left, VPos::Bottom), false)?;
        }
        Ok((px, py))
    }

    /// A big note (`(text, centred)`: centred in the plotting area `(px,
    /// py)`, else boxed near its top) and small notes in the lower left
    /// corner of the image.
    fn notes(
        &self,
        root: &Area,
        (px, py): &(Range<i32>, Range<i32>),
        big: Option<(&str, bool)>,
        small: &[String],
    ) -> Result<(), String> {
        let pen = &self.pens.big_note;
        let cx = (px.start + px.end) / 2;
        match big {
            Some((msg, true)) => {
                let at = (cx, (py.start + py.end) / 2);
                pen.draw(root, msg, at, (HPos::Center, VPos::Center), false)?;
            }
            Some((msg, false)) => {
                let at = (cx, py.start + 24 + pen.cap() / 2);
                boxed_text(root, pen, msg, at, HPos::Center)?;
            }
            None => {}
        }
        if !small.is_empty() {
            let at = (12, root.dim_in_pixel().1 as i32 - 12);
            let lower_left = (HPos::Left, VPos::Bottom);
            (self.pens.note).draw(root, &small.join("; "), at, lower_left, false)?;
        }
        Ok(())
    }
}

/// A legend-style box (nearly opaque white, thin grey border).
fn legend_box(root: &Area, corners: [(i32, i32); 2]) -> Result<(), String> {
    root.draw(&Rectangle::new(corners, WHITE.mix(0.92).filled()))
        .and_then(|()| root.draw(&Rectangle::new(corners, BLACK.mix(0.35))))
        .map_err(|e| e.to_string())
}

/// Text on a legend-style box, vertically centred on `pos.1`.
fn boxed_text(root: &Area, pen: &Pen, s: &str, pos: (i32, i32), h: HPos) -> Result<(), String> {
    let w = pen.width(s);
    let x0 = match h {
        HPos::Left => pos.0,
        HPos::Center => pos.0 - w / 2,
        HPos::Right => pos.0 - w,
    };
    // Room for descenders below the baseline.
    let (pad_x, pad_y, desc) = (8, 7, pen.cap() / 4);
    legend_box(
        root,
        [
            (x0 - pad_x, pos.1 - pen.cap() / 2 - pad_y),
            (x0 + w + pad_x, pos.1 + (pen.cap() + 1) / 2 + desc + pad_y),
        ],
    )?;
    pen.draw(root, s, (x0, pos.1), (HPos::Left, VPos::Center), false)
}

/// `n` things, with a plural "s" on `what` unless `n` is 1.
fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

#[cfg(test)]
mod tests;
