//! PNG line plots (log-log and linear) and fracture-network maps, drawn with
//! plotters' bitmap backend and an embedded DejaVu Sans font
//! (`assets/DejaVuSans.ttf`).
//!
//! Log plots are drawn in log10 space with power-of-ten tick labels. Series
//! with more than 60 points get no markers. The legend goes in the plot
//! corner covering the fewest curve samples. PNGs are written atomically
//! (`crate::atomic`: a temporary file in the same folder, then renamed).
//!
//! Network maps ([`network`]) draw each segment as an anti-aliased line
//! coloured by a hand-made viridis colormap, with equal x/y scales and a
//! colour bar. Fracture maps ([`fracture_map`]) share their layout and draw
//! filled, anti-aliased polygons (fracture cells with magnified apertures)
//! over a light-grey mesh.
//!
//! All text is drawn by this module glyph by glyph (`Pen`), not by
//! plotters' text path, to work around its letter-spacing bug.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use plotters::style::{FontStyle, RGBColor};

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

/// Error from [`loglog`] / [`lines`] / [`network`].
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

const WIDTH: u32 = 1000;
const HEIGHT: u32 = 700;
/// Series with more points than this are drawn as plain lines (no markers).
const MAX_MARKED_POINTS: usize = 60;

static FONT_BYTES: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/DejaVuSans.ttf"
));

fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

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
    render(path, title, xlabel, ylabel, series, true)
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
    render(path, title, xlabel, ylabel, series, false)
}

/// Draw a fracture network: each segment as a line coloured by `values[k]`
/// (viridis colormap), `width_px[k]` px wide when given (e.g. scaled
/// aperture; non-finite widths use the 2 px default, others are clamped to
/// 0.75..=40 px), equal x/y scales in metres, a vertical colour bar labelled
/// `value_label`, and `title` on top; 1100x900 px PNG, written atomically.
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
    let input_err = |message: String| PlotError::Input {
        path: path.to_path_buf(),
        message,
    };
    if values.len() != segments.len() {
        return Err(input_err(format!(
            "{} values given for {} segments (need one value per segment)",
            values.len(),
            segments.len()
        )));
    }
    if let Some(w) = width_px
        && w.len() != segments.len()
    {
        return Err(input_err(format!(
            "{} line widths given for {} segments (need one width per segment)",
            w.len(),
            segments.len()
        )));
    }
    ensure_font()?;
    let net = Network {
        title,
        segments,
        values,
        value_label,
        scale,
        width_px,
        markers,
    };
    write_atomically(path, |tmp| {
        draw_map_file(tmp, path, |root| draw_network(root, &net))
    })
}

/// Draw fracture cells as filled polygons over a rock mesh, like the seed
/// paper's Fig. 7: each of `quads` (corners in order around the polygon, m;
/// e.g. a fracture cell as wide as its magnified aperture) filled with the
/// viridis colour of `values[k]` (linear scale) and edged with a 1.5 px line
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
    let input_err = |message: String| PlotError::Input {
        path: path.to_path_buf(),
        message,
    };
    if values.len() != quads.len() {
        return Err(input_err(format!(
            "{} values given for {} quads (need one value per quad)",
            values.len(),
            quads.len()
        )));
    }
    if let Some(w @ [x0, x1, y0, y1]) = window
        && !(w.iter().all(|v| v.is_finite()) && x0 < x1 && y0 < y1)
    {
        return Err(input_err(format!(
            "window {w:?} is not [xmin, xmax, ymin, ymax] with finite xmin < xmax and ymin < ymax"
        )));
    }
    ensure_font()?;
    let map = QuadMap {
        title,
        mesh_edges,
        quads,
        values,
        value_label,
        window,
        markers,
    };
    write_atomically(path, |tmp| {
        draw_map_file(tmp, path, |root| draw_fracture_map(root, &map).map(drop))
    })
}

// ---------------------------------------------------------------------------
// Axis ranges, ticks and labels
// ---------------------------------------------------------------------------

#[derive(Clone)]
struct Axis {
    lo: f64,
    hi: f64,
    major: Vec<f64>,
    minor: Vec<f64>,
    /// Log axis: values are log10 of data.
    log: bool,
    /// Linear: tick step. Log: unused.
    step: f64,
    /// Plain decimal labels (vs. scientific).
    plain: bool,
    /// Log axis spanning too little for 1..9 x 10^k ticks: linear ticks
    /// (in value space) and their labels.
    fine: Option<Box<Axis>>,
}

const SUPERSCRIPT: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];

fn superscript(k: i32) -> String {
    let mut s = String::new();
    if k < 0 {
        s.push('⁻');
    }
    for d in k.unsigned_abs().to_string().bytes() {
        s.push(SUPERSCRIPT[(d - b'0') as usize]);
    }
    s
}

/// `m × 10^k` written out in plain decimal (m, k integers, m in 1..=9).
fn plain_decimal(m: i64, k: i32) -> String {
    if k >= 0 {
        format!("{}{}", m, "0".repeat(k as usize))
    } else {
        format!("0.{}{}", "0".repeat((-k - 1) as usize), m)
    }
}

impl Axis {
    /// Linear axis over the data extent plus 5% margins.
    fn linear(dmin: f64, dmax: f64) -> Axis {
        let (lo, hi) = if dmax > dmin {
            let pad = 0.05 * (dmax - dmin);
            (dmin - pad, dmax + pad)
        } else {
            let pad = if dmin == 0.0 { 1.0 } else { 0.1 * dmin.abs() };
            (dmin - pad, dmin + pad)
        };
        Axis::linear_exact(lo.max(-f64::MAX), hi.min(f64::MAX))
    }

    /// Linear axis over exactly `lo..hi`, ~8 ticks at 1/2/2.5/5 x 10^k.
    fn linear_exact(lo: f64, hi: f64) -> Axis {
        // Divide first so huge ranges do not overflow.
        let raw = hi / 8.0 - lo / 8.0;
        let raw = if raw > 0.0 && raw.is_finite() {
            raw
        } else {
            1.0
        };
        let mag = 10f64.powf(raw.log10().floor());
        let step = [1.0, 2.0, 2.5, 5.0, 10.0]
            .iter()
            .map(|f| f * mag)
            .find(|&s| s >= raw * (1.0 - 1e-12))
            .unwrap_or(10.0 * mag);
        Axis::linear_stepped(lo, hi, step)
    }

    /// Linear axis over exactly `lo..hi` with major ticks every `step`
    /// (a 1/2/2.5/5 x 10^k value).
    fn linear_stepped(lo: f64, hi: f64, step: f64) -> Axis {
        let step = if step > 0.0 && step.is_finite() {
            step
        } else {
            1.0
        };
        let mag = 10f64.powf((step.log10() + 1e-9).floor());
        let minor_step = if (step / mag - 2.0).abs() < 1e-9 {
            step / 4.0
        } else {
            step / 5.0
        };
        let multiples = |s: f64| -> Vec<f64> {
            let first = (lo / s).ceil() as i64;
            let last = (hi / s).floor() as i64;
            (first..=last.max(first - 1))
                .map(|i| {
                    let v = i as f64 * s;
                    if v.abs() < s * 1e-9 { 0.0 } else { v }
                })
                .collect()
        };
        let major = multiples(step);
        let minor = multiples(minor_step);
        let big = lo.abs().max(hi.abs());
        let plain = (1e-3..1e6).contains(&big) && step >= 1e-6;
        Axis {
            lo,
            hi,
            major,
            minor,
            log: false,
            step,
            plain,
            fine: None,
        }
    }

    /// `lmin`, `lmax` are log10 of the positive data extent.
    fn log(lmin: f64, lmax: f64) -> Axis {
        // Margins in decades: 5% of the span (at least 0.05), half a decade
        // each side when all values are equal.
        let (lo, hi) = if lmax - lmin < 1e-9 {
            (lmin - 0.5, lmax + 0.5)
        } else {
            let m = (0.05 * (lmax - lmin)).max(0.05);
            (lmin - m, lmax + m)
        };

        let in_range = |t: f64| t >= lo && t <= hi;
        let first = lo.floor() as i64;
        let last = hi.ceil() as i64;
        let decades: Vec<f64> = (first..=last)
            .map(|k| k as f64)
            .filter(|&t| in_range(t))
            .collect();
        let with_mults = |ms: &[i64]| -> Vec<f64> {
            (first..=last)
                .flat_map(|k| ms.iter().map(move |&m| k as f64 + (m as f64).log10()))
                .filter(|&t| in_range(t))
                .collect()
        };
        let all = with_mults(&[1, 2, 3, 4, 5, 6, 7, 8, 9]);
        let major = if decades.len() >= 3 {
            let stride = decades.len().div_ceil(10);
            decades
                .iter()
                .copied()
                .filter(|t| (*t as i64).rem_euclid(stride as i64) == 0)
                .collect()
        } else {
            let m125 = with_mults(&[1, 2, 5]);
            if m125.len() >= 3 { m125 } else { all.clone() }
        };
        if major.len() < 2 {
            // Less than a factor ~2 in range: linear ticks in value space.
            let fine = Axis::linear_exact(10f64.powf(lo), 10f64.powf(hi));
            let to_log = |v: &Vec<f64>| v.iter().filter(|&&x| x > 0.0).map(|x| x.log10()).collect();
            return Axis {
                lo,
                hi,
                major: to_log(&fine.major),
                minor: to_log(&fine.minor),
                log: true,
                step: 0.0,
                plain: false,
                fine: Some(Box::new(fine)),
            };
        }
        let minor = if decades.len() <= 8 { all } else { decades };
        let plain = major
            .iter()
            .all(|&t| (-3.0 - 1e-9..=5.0 + 1e-9).contains(&t));
        Axis {
            lo,
            hi,
            major,
            minor,
            log: true,
            step: 0.0,
            plain,
            fine: None,
        }
    }

    /// Tick label for axis value `v` (log10 of the data on log axes).
    fn label(&self, v: f64) -> String {
        // Typographic minus sign.
        self.label_ascii(v).replacen('-', "\u{2212}", 1)
    }

    fn label_ascii(&self, v: f64) -> String {
        if let Some(fine) = &self.fine {
            fine.label_ascii(10f64.powf(v))
        } else if self.log {
            let k = (v + 1e-9).floor();
            let m = 10f64.powf(v - k).round() as i64;
            let (m, k) = if m >= 10 {
                (1, k as i32 + 1)
            } else {
                (m.max(1), k as i32)
            };
            if self.plain {
                plain_decimal(m, k)
            } else if m == 1 {
                format!("10{}", superscript(k))
            } else {
                format!("{m}×10{}", superscript(k))
            }
        } else {
            // Decimal places needed to distinguish multiples of the tick step.
            let ks = (self.step.log10() + 1e-9).floor();
            let extra = if (self.step / 10f64.powf(ks) - 2.5).abs() < 1e-6 {
                1.0
            } else {
                0.0
            };
            if self.plain {
                let decimals = (extra - ks).clamp(0.0, 12.0) as usize;
                let s = format!("{v:.decimals$}");
                // Avoid "-0.0" for values that round to zero.
                if s.trim_start_matches(['-', '0', '.']).is_empty() {
                    s.trim_start_matches('-').to_string()
                } else {
                    s
                }
            } else {
                let e = self.exponent();
                let decimals = (e as f64 - ks + extra).clamp(0.0, 10.0) as usize;
                let s = format!("{:.decimals$}", v / 10f64.powi(e));
                if s.trim_start_matches(['-', '0', '.']).is_empty() {
                    s.trim_start_matches('-').to_string()
                } else {
                    s
                }
            }
        }
    }

    /// Common power of ten of a scientific linear axis.
    fn exponent(&self) -> i32 {
        let big = self.lo.abs().max(self.hi.abs());
        if big > 0.0 && big.is_finite() {
            (big.log10() + 1e-9).floor() as i32
        } else {
            0
        }
    }

    /// Axis multiplier label ("×10⁻⁵") for scientific linear axes.
    fn multiplier(&self) -> Option<String> {
        if let Some(fine) = &self.fine {
            return fine.multiplier();
        }
        (!self.log && !self.plain).then(|| format!("×10{}", superscript(self.exponent())))
    }
}

/// Linear mapping of `lo..hi` with our own major (labelled) and minor ticks.
impl Ranged for Axis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let f = (*v - self.lo) / (self.hi - self.lo);
        let f = if f.is_finite() {
            f.clamp(-10.0, 10.0)
        } else {
            0.5
        };
        limit.0 + ((limit.1 - limit.0) as f64 * f + 1e-3).floor() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

// ---------------------------------------------------------------------------
// Rendering
// ---------------------------------------------------------------------------

fn draw_err(path: &Path, e: impl std::fmt::Display) -> PlotError {
    PlotError::Draw {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn render(
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
    log: bool,
) -> Result<(), PlotError> {
    ensure_font()?;
    write_atomically(path, |tmp| {
        draw_to(tmp, path, title, xlabel, ylabel, series, log)
    })
}

/// Run `draw` on a temporary PNG next to `path`, then sync and rename it to `path`.
fn write_atomically(
    path: &Path,
    draw: impl FnOnce(&Path) -> Result<(), PlotError>,
) -> Result<(), PlotError> {
    crate::atomic::write_via_path(path, draw, |source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    })
}

// Text is drawn glyph by glyph: plotters 0.3.7's ab_glyph path drops each
// glyph's left side bearing, which gives visibly uneven letter spacing. Here
// each glyph's ink is placed at pen + left side bearing (read from the
// embedded font's `cmap`/`hmtx`; centred in its advance box as a fallback).

/// Big-endian reads from the font file, `None` when out of bounds.
fn be_u16(d: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_be_bytes([*d.get(at)?, *d.get(at + 1)?]))
}

fn be_u32(d: &[u8], at: usize) -> Option<u32> {
    Some(((be_u16(d, at)? as u32) << 16) | be_u16(d, at + 2)? as u32)
}

fn ttf_table(d: &[u8], tag: &[u8; 4]) -> Option<usize> {
    let n = be_u16(d, 4)? as usize;
    (0..n).find_map(|i| {
        let rec = 12 + 16 * i;
        (d.get(rec..rec + 4)? == tag).then(|| be_u32(d, rec + 8).map(|o| o as usize))?
    })
}

/// Glyph id of `c` from a format-4 (BMP) `cmap` subtable.
fn ttf_glyph(d: &[u8], c: char) -> Option<u16> {
    let c = u16::try_from(c as u32).ok()?;
    let cmap = ttf_table(d, b"cmap")?;
    let n = be_u16(d, cmap + 2)? as usize;
    let sub = (0..n).find_map(|i| {
        let rec = cmap + 4 + 8 * i;
        let (pid, eid) = (be_u16(d, rec)?, be_u16(d, rec + 2)?);
        let off = cmap + be_u32(d, rec + 4)? as usize;
        ((pid == 3 && eid == 1) || pid == 0)
            .then_some(off)
            .filter(|&o| be_u16(d, o) == Some(4))
    })?;
    let seg_count = be_u16(d, sub + 6)? as usize / 2;
    let ends = sub + 14;
    let starts = ends + 2 * seg_count + 2;
    let deltas = starts + 2 * seg_count;
    let range_offsets = deltas + 2 * seg_count;
    for i in 0..seg_count {
        if be_u16(d, ends + 2 * i)? < c {
            continue;
        }
        let start = be_u16(d, starts + 2 * i)?;
        if start > c {
            return None;
        }
        let delta = be_u16(d, deltas + 2 * i)?;
        let ro = be_u16(d, range_offsets + 2 * i)? as usize;
        if ro == 0 {
            return Some(c.wrapping_add(delta));
        }
        let g = be_u16(d, range_offsets + 2 * i + ro + 2 * (c - start) as usize)?;
        return (g != 0).then(|| g.wrapping_add(delta));
    }
    None
}

/// (advance, left side bearing) of `c` in font units.
fn ttf_h_metrics(d: &[u8], c: char) -> Option<(u16, i16)> {
    let g = ttf_glyph(d, c)? as usize;
    let hhea = ttf_table(d, b"hhea")?;
    let hmtx = ttf_table(d, b"hmtx")?;
    let long = be_u16(d, hhea + 34)? as usize;
    if long == 0 {
        return None;
    }
    let advance = be_u16(d, hmtx + 4 * g.min(long - 1))?;
    let lsb = if g < long {
        be_u16(d, hmtx + 4 * g + 2)?
    } else {
        be_u16(d, hmtx + 4 * long + 2 * (g - long))?
    };
    Some((advance, lsb as i16))
}

struct Pen {
    font: FontDesc<'static>,
    color: RGBColor,
    /// Local y of the cap top and the baseline, as produced by `FontDesc::draw`.
    cap_top: f64,
    baseline: f64,
    /// Pixels per font unit (`None`: font tables unreadable, centre glyphs).
    px_per_unit: Option<f64>,
}

impl Pen {
    fn new(size: f64, color: RGBColor) -> Pen {
        let font = FontDesc::new(FontFamily::SansSerif, size, FontStyle::Normal);
        let (mut top, mut bottom) = (i32::MAX, i32::MIN);
        let _ = font.draw("H", (0, 0), |_, y, a| {
            if a > 0.5 {
                top = top.min(y);
                bottom = bottom.max(y + 1);
            }
            Ok::<(), ()>(())
        });
        let (cap_top, baseline) = if top < bottom {
            (top as f64, bottom as f64)
        } else {
            (0.0, 0.6 * size)
        };
        let px_per_unit =
            ttf_h_metrics(FONT_BYTES, 'H')
                .filter(|m| m.0 > 0)
                .and_then(|(adv, _)| {
                    let w = font.box_size("HHHHHHHHHHHHHHHHHHHH").ok()?.0 as f64;
                    Some(w / (20.0 * adv as f64))
                });
        Pen {
            font,
            color,
            cap_top,
            baseline,
            px_per_unit,
        }
    }

    fn width(&self, s: &str) -> i32 {
        self.font.box_size(s).map(|b| b.0 as i32).unwrap_or(0)
    }

    /// Cap height in pixels.
    fn cap(&self) -> i32 {
        (self.baseline - self.cap_top).round() as i32
    }

    /// Draw `s` anchored at `pos` (vertical anchor relative to the cap
    /// height); `vertical` text reads bottom-to-top.
    fn draw(
        &self,
        area: &DrawingArea<BitMapBackend, Shift>,
        s: &str,
        pos: (i32, i32),
        (h, v): (HPos, VPos),
        vertical: bool,
    ) -> Result<(), String> {
        let w = self.width(s) as f64;
        let dx = match h {
            HPos::Left => 0.0,
            HPos::Center => -w / 2.0,
            HPos::Right => -w,
        };
        let dy = match v {
            VPos::Top => -self.cap_top,
            VPos::Center => -(self.cap_top + self.baseline) / 2.0,
            VPos::Bottom => -self.baseline,
        };
        let mut glyph = Vec::new();
        for (i, c) in s.char_indices() {
            let cs = &s[i..i + c.len_utf8()];
            glyph.clear();
            self.font
                .draw(cs, (0, 0), |x, y, a| {
                    glyph.push((x, y, a));
                    Ok::<(), ()>(())
                })
                .map_err(|e| e.to_string())?
                .map_err(|()| "glyph rasterisation failed".to_string())?;
            let Some(ink) = glyph.iter().map(|g| g.0 + 1).max() else {
                continue;
            };
            let pen = self.width(&s[..i]) as f64;
            // Whole-pixel offsets, so every glyph row/column maps one-to-one.
            let lsb = match (self.px_per_unit, ttf_h_metrics(FONT_BYTES, c)) {
                (Some(k), Some((_, lsb))) => (lsb as f64 * k).floor(),
                _ => ((self.width(cs) - ink) as f64 / 2.0).round(),
            };
            let ox = (pen + dx + 0.5).floor() as i32 + lsb as i32;
            let oy = (dy + 0.5).floor() as i32;
            for &(x, y, a) in &glyph {
                if a <= 0.0 {
                    continue;
                }
                let (lx, ly) = (ox + x, oy + y);
                let p = if vertical {
                    (pos.0 + ly, pos.1 - lx)
                } else {
                    (pos.0 + lx, pos.1 + ly)
                };
                area.draw_pixel(p, &self.color.mix(a.min(1.0) as f64))
                    .map_err(|e| e.to_string())?;
            }
        }
        Ok(())
    }
}

#[derive(Clone, Copy)]
enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
}

fn draw_marker(
    area: &DrawingArea<BitMapBackend, Shift>,
    (x, y): (i32, i32),
    marker: Marker,
    color: RGBColor,
) -> Result<(), String> {
    let st = color.filled();
    let r = match marker {
        Marker::Circle => area.draw(&Circle::new((x, y), 5, st)),
        Marker::Square => area.draw(&Rectangle::new([(x - 4, y - 4), (x + 4, y + 4)], st)),
        Marker::Triangle => area.draw(&TriangleMarker::new((x, y), 6, st)),
        Marker::Diamond => area.draw(&Polygon::new(
            vec![(x, y - 6), (x + 6, y), (x, y + 6), (x - 6, y)],
            st,
        )),
    };
    r.map_err(|e| e.to_string())
}

/// Pick the plot corner where a `w`x`h` px legend box (inset by `inset`)
/// covers the fewest curve samples; returns the box's top-left corner.
fn legend_origin(
    curves: &[Vec<(i32, i32)>],
    (px, py): (std::ops::Range<i32>, std::ops::Range<i32>),
    (w, h): (i32, i32),
    inset: i32,
) -> (i32, i32) {
    let left = px.start + inset;
    let right = px.end - inset - w;
    let top = py.start + inset;
    let bottom = py.end - inset - h;
    // Preference order on ties: upper right, upper left, lower right, lower left.
    let corners = [(right, top), (left, top), (right, bottom), (left, bottom)];
    let mut counts = [0usize; 4];
    let mut visit = |x: f64, y: f64| {
        let m = 6.0;
        for (k, &(cx, cy)) in corners.iter().enumerate() {
            if x >= (cx as f64 - m)
                && x <= ((cx + w) as f64 + m)
                && y >= (cy as f64 - m)
                && y <= ((cy + h) as f64 + m)
            {
                counts[k] += 1;
            }
        }
    };
    for pts in curves {
        for seg in pts.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            let (ddx, ddy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
            let n = ((ddx * ddx + ddy * ddy).sqrt() / 3.0)
                .ceil()
                .clamp(1.0, 1000.0) as usize;
            for i in 0..n {
                let f = i as f64 / n as f64;
                visit(a.0 as f64 + f * ddx, a.1 as f64 + f * ddy);
            }
        }
        if let Some(&(x, y)) = pts.last() {
            visit(x as f64, y as f64);
        }
    }
    let best = (0..4).min_by_key(|&k| counts[k]).unwrap_or(0);
    corners[best]
}

const TITLE_SIZE: f64 = 28.0;
const DESC_SIZE: f64 = 21.0;
const TICK_SIZE: f64 = 17.0;
const LEGEND_SIZE: f64 = 17.0;
const TICK_GAP: i32 = 10;

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

fn draw_to(
    tmp: &Path,
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series],
    log: bool,
) -> Result<(), PlotError> {
    // Filter and (for log plots) transform the data.
    let mut dropped = 0usize;
    let data: Vec<Vec<(f64, f64)>> = series
        .iter()
        .map(|s| {
            let kept: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|(x, y)| x.is_finite() && y.is_finite() && (!log || (*x > 0.0 && *y > 0.0)))
                .map(|&(x, y)| if log { (x.log10(), y.log10()) } else { (x, y) })
                .collect();
            dropped += s.points.len() - kept.len();
            kept
        })
        .collect();
    let (mut xmin, mut xmax, mut ymin, mut ymax) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in data.iter().flatten() {
        xmin = xmin.min(x);
        xmax = xmax.max(x);
        ymin = ymin.min(y);
        ymax = ymax.max(y);
    }
    let empty = xmin > xmax;
    let (x_axis, y_axis) = match (empty, log) {
        (true, true) => (Axis::log(0.0, 1.0), Axis::log(0.0, 1.0)),
        (true, false) => (Axis::linear(0.0, 1.0), Axis::linear(0.0, 1.0)),
        (false, true) => (Axis::log(xmin, xmax), Axis::log(ymin, ymax)),
        (false, false) => (Axis::linear(xmin, xmax), Axis::linear(ymin, ymax)),
    };

    let black = RGBColor(0, 0, 0);
    let title_pen = Pen::new(TITLE_SIZE, black);
    let desc_pen = Pen::new(DESC_SIZE, black);
    let tick_pen = Pen::new(TICK_SIZE, RGBColor(30, 30, 30));
    let legend_pen = Pen::new(LEGEND_SIZE, black);

    let x_labels: Vec<(f64, String)> = x_axis.major.iter().map(|&t| (t, x_axis.label(t))).collect();
    let y_labels: Vec<(f64, String)> = y_axis.major.iter().map(|&t| (t, y_axis.label(t))).collect();
    let y_tick_w = y_labels
        .iter()
        .map(|(_, l)| tick_pen.width(l))
        .max()
        .unwrap_or(0);
    let last_x_w = x_labels.last().map(|(_, l)| tick_pen.width(l)).unwrap_or(0);

    // Layout in pixels.
    let desc_h = desc_pen.cap() + 6;
    let ydesc_w = if ylabel.is_empty() { 0 } else { desc_h + 18 };
    let xdesc_h = if xlabel.is_empty() { 0 } else { 18 + desc_h };
    let y_area = 16 + ydesc_w + y_tick_w + TICK_GAP;
    let x_area = TICK_GAP + tick_pen.cap() + 8 + xdesc_h + 14;
    let top = if title.is_empty() {
        24
    } else {
        18 + title_pen.cap() + 26
    };
    let right = (last_x_w / 2 + 12).max(32);

    let root = BitMapBackend::new(tmp, (WIDTH, HEIGHT)).into_drawing_area();
    let inner = || -> Result<(), String> {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let no_label = |_: &f64| String::new();
        let mut chart = ChartBuilder::on(&root)
            .margin_top(top)
            .margin_right(right)
            .x_label_area_size(x_area)
            .y_label_area_size(y_area)
            .build_cartesian_2d(x_axis.clone(), y_axis.clone())
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_label_formatter(&no_label)
            .y_label_formatter(&no_label)
            .bold_line_style(BLACK.mix(0.16))
            .light_line_style(BLACK.mix(0.05))
            .axis_style(BLACK.stroke_width(1))
            .set_all_tick_mark_size(6)
            .draw()
            .map_err(|e| e.to_string())?;
        let (px, py) = chart.plotting_area().get_pixel_range();
        // Close the frame on the top and right.
        root.draw(&PathElement::new(
            vec![
                (px.start, py.start),
                (px.end - 1, py.start),
                (px.end - 1, py.end - 1),
            ],
            BLACK.stroke_width(1),
        ))
        .map_err(|e| e.to_string())?;

        // Tick labels, axis descriptions, title.
        for (t, l) in &x_labels {
            let (x, _) = chart.backend_coord(&(*t, y_axis.lo));
            let at = (x, py.end + TICK_GAP);
            tick_pen.draw(&root, l, at, (HPos::Center, VPos::Top), false)?;
        }
        for (t, l) in &y_labels {
            let (_, y) = chart.backend_coord(&(x_axis.lo, *t));
            let at = (px.start - TICK_GAP, y);
            tick_pen.draw(&root, l, at, (HPos::Right, VPos::Center), false)?;
        }
        let cx = (px.start + px.end) / 2;
        let cy = (py.start + py.end) / 2;
        let center = (HPos::Center, VPos::Center);
        let center_top = (HPos::Center, VPos::Top);
        if !xlabel.is_empty() {
            let y = py.end + TICK_GAP + tick_pen.cap() + 8 + 18;
            desc_pen.draw(&root, xlabel, (cx, y), center_top, false)?;
        }
        if !ylabel.is_empty() {
            let x = px.start - TICK_GAP - y_tick_w - 18 - desc_h / 2;
            desc_pen.draw(&root, ylabel, (x, cy), center, true)?;
        }
        if !title.is_empty() {
            title_pen.draw(&root, title, (cx, 18), center_top, false)?;
        }
        if let Some(m) = x_axis.multiplier() {
            let at = (px.end, py.end + TICK_GAP + tick_pen.cap() + 8 + 18);
            tick_pen.draw(&root, &m, at, (HPos::Right, VPos::Top), false)?;
        }
        if let Some(m) = y_axis.multiplier() {
            let at = (px.start, py.start - 8);
            tick_pen.draw(&root, &m, at, (HPos::Left, VPos::Bottom), false)?;
        }

        // Curves.
        let mut pixel_curves = Vec::with_capacity(data.len());
        for (i, pts) in data.iter().enumerate() {
            let (color, marker) = series_style(i);
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
                .map_err(|e| e.to_string())?;
            let pix: Vec<(i32, i32)> = pts.iter().map(|p| chart.backend_coord(p)).collect();
            if pts.len() <= MAX_MARKED_POINTS {
                for &p in &pix {
                    draw_marker(&root, p, marker, color)?;
                }
            }
            pixel_curves.push(pix);
        }

        // Legend: series with a label and at least one drawable point.
        let entries: Vec<usize> = (0..series.len())
            .filter(|&i| !series[i].label.is_empty() && !data[i].is_empty())
            .collect();
        if !entries.is_empty() {
            let row_h = legend_pen.cap() * 2;
            let sample_w = 34;
            let pad = 12;
            let text_w = entries
                .iter()
                .map(|&i| legend_pen.width(&series[i].label))
                .max()
                .unwrap_or(0);
            let w = pad + sample_w + 10 + text_w + pad;
            let h = 2 * pad + row_h * entries.len() as i32 - legend_pen.cap();
            let (lx, ly) = legend_origin(&pixel_curves, (px.clone(), py.clone()), (w, h), 12);
            let corners = [(lx, ly), (lx + w, ly + h)];
            root.draw(&Rectangle::new(corners, WHITE.mix(0.92).filled()))
                .map_err(|e| e.to_string())?;
            root.draw(&Rectangle::new(corners, BLACK.mix(0.35)))
                .map_err(|e| e.to_string())?;
            for (row, &i) in entries.iter().enumerate() {
                let (color, marker) = series_style(i);
                let y = ly + pad + legend_pen.cap() / 2 + row as i32 * row_h;
                let x0 = lx + pad;
                root.draw(&PathElement::new(
                    vec![(x0, y), (x0 + sample_w, y)],
                    color.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
                if data[i].len() <= MAX_MARKED_POINTS {
                    draw_marker(&root, (x0 + sample_w / 2, y), marker, color)?;
                }
                let at = (x0 + sample_w + 10, y);
                legend_pen.draw(
                    &root,
                    &series[i].label,
                    at,
                    (HPos::Left, VPos::Center),
                    false,
                )?;
            }
        }

        // Notes.
        if empty {
            let pen = Pen::new(22.0, RGBColor(90, 90, 90));
            let msg = if log {
                "no data to plot (no finite, positive points)"
            } else {
                "no data to plot (no finite points)"
            };
            pen.draw(&root, msg, (cx, cy), center, false)?;
        } else if dropped > 0 {
            let what = if log {
                "non-positive or non-finite"
            } else {
                "non-finite"
            };
            let plural = if dropped == 1 { "" } else { "s" };
            let msg = format!("{dropped} {what} point{plural} omitted");
            let pen = Pen::new(15.0, RGBColor(110, 110, 110));
            let at = (12, HEIGHT as i32 - 12);
            pen.draw(&root, &msg, at, (HPos::Left, VPos::Bottom), false)?;
        }
        root.present().map_err(|e| e.to_string())
    };
    let r = inner();
    drop(root);
    r.map_err(|m| draw_err(path, m))
}

// ---------------------------------------------------------------------------
// Network maps
// ---------------------------------------------------------------------------

const NET_WIDTH: u32 = 1100;
const NET_HEIGHT: u32 = 900;
/// Line width when no widths are given, and for non-finite widths, px.
const NET_LINE_PX: f64 = 2.0;
/// Range that given line widths are clamped to, px.
const NET_LINE_MIN_PX: f64 = 0.75;
const NET_LINE_MAX_PX: f64 = 40.0;
/// Colour of segments without a usable value.
const NO_VALUE_GREY: RGBColor = RGBColor(178, 178, 178);
const MARKER_FILL: RGBColor = RGBColor(214, 39, 40);
/// Colour bar: gap to the plot frame, width, major tick length (px).
const BAR_GAP: i32 = 28;
const BAR_W: i32 = 24;
const BAR_TICK: i32 = 6;
/// Margin around a network's data box, fraction of its larger side.
const NET_PAD: f64 = 0.04;
/// Margin around a fracture map's quads (default window), fraction of the
/// larger side of their box.
const QUAD_PAD: f64 = 0.1;
/// Width of the line edging each quad of a fracture map, px (quads thinner
/// than this still show as a line of this width).
const QUAD_EDGE_PX: f64 = 1.5;
/// Colour and width (px) of a fracture map's mesh edges.
const MESH_GREY: RGBColor = RGBColor(200, 200, 200);
const MESH_LINE_PX: f64 = 0.8;

/// Viridis (matplotlib) at t = 0, 1/8, ..., 1.
const VIRIDIS: [(u8, u8, u8); 9] = [
    (68, 1, 84),
    (71, 45, 123),
    (59, 82, 139),
    (44, 114, 142),
    (33, 145, 140),
    (40, 174, 128),
    (94, 201, 98),
    (173, 220, 48),
    (253, 231, 37),
];

/// Viridis colour at `t` in 0..=1 (clamped), linear between the anchors.
fn viridis(t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let (p, q) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let lerp = |p: u8, q: u8| (p as f64 + f * (q as f64 - p as f64)).round() as u8;
    RGBColor(lerp(p.0, q.0), lerp(p.1, q.1), lerp(p.2, q.2))
}

/// Arguments of [`network`], validated.
struct Network<'a> {
    title: &'a str,
    segments: &'a [Segment],
    values: &'a [f64],
    value_label: &'a str,
    scale: ColourScale,
    width_px: Option<&'a [f64]>,
    markers: &'a [([f64; 2], &'a str)],
}

impl Network<'_> {
    /// Whether `v` gets a colour (else grey).
    fn usable(&self, v: f64) -> bool {
        v.is_finite() && (self.scale == ColourScale::Linear || v > 0.0)
    }

    /// Value in colour-bar space (log10 for log scales).
    fn bar_value(&self, v: f64) -> f64 {
        match self.scale {
            ColourScale::Linear => v,
            ColourScale::Log => v.log10(),
        }
    }

    fn line_width(&self, k: usize) -> f64 {
        match self.width_px.map(|w| w[k]) {
            Some(w) if w.is_finite() => w.clamp(NET_LINE_MIN_PX, NET_LINE_MAX_PX),
            _ => NET_LINE_PX,
        }
    }
}

/// Colour-bar axis over exactly `vmin..=vmax` (positive for log scales; the
/// axis is then in log10 space with power-of-ten labels).
fn colour_axis(vmin: f64, vmax: f64, scale: ColourScale) -> Axis {
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
                    a.major = major;
                    a.lo = lmin;
                    a.hi = lmax;
                }
            }
            a
        }
    }
}

/// Position of `v` (colour-bar space) on `axis`, 0..=1.
fn colour_fraction(axis: &Axis, v: f64) -> f64 {
    // Halve first so extreme ranges do not overflow.
    let f = (v / 2.0 - axis.lo / 2.0) / (axis.hi / 2.0 - axis.lo / 2.0);
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        0.5
    }
}

/// Axes with equal metres per pixel for the data box `[xmin, xmax, ymin,
/// ymax]` plus a margin of `pad` times its larger side, filling `w` x `h` px
/// (the axes' pixel lengths); both get the same tick step.
fn equal_axes(bbox: [f64; 4], w: f64, h: f64, pad: f64) -> (Axis, Axis) {
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
        let ok = [xc - hx, xc + hx, yc - hy, yc + hy]
            .iter()
            .all(|v| v.is_finite())
            && px_per_m > 0.0
            && hx > 0.0
            && hy > 0.0;
        if !ok {
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

/// Anti-aliased line from `a` to `b` (continuous pixel coordinates: pixel
/// `(i, j)` covers `[i, i+1) x [j, j+1)`), `w` px wide with round caps,
/// clipped to the pixel ranges `clip`. `a == b` gives a disc.
fn draw_aa_segment(
    area: &DrawingArea<BitMapBackend, Shift>,
    a: (f64, f64),
    b: (f64, f64),
    w: f64,
    color: RGBColor,
    clip: &(std::ops::Range<i32>, std::ops::Range<i32>),
) -> Result<(), String> {
    // Work with pixel centres on integers.
    let a = (a.0 - 0.5, a.1 - 0.5);
    let (dx, dy) = (b.0 - 0.5 - a.0, b.1 - 0.5 - a.1);
    let len2 = dx * dx + dy * dy;
    let r = 0.5 * w;
    let reach = r + 0.5;
    // Walk along the longer direction u; cover a band across it (v).
    let steep = dy.abs() > dx.abs();
    let (au, av, du, dv) = if steep {
        (a.1, a.0, dy, dx)
    } else {
        (a.0, a.1, dx, dy)
    };
    let (clip_u, clip_v) = if steep {
        (&clip.1, &clip.0)
    } else {
        (&clip.0, &clip.1)
    };
    let slope = if du != 0.0 { dv / du } else { 0.0 };
    let band = reach * (1.0 + slope * slope).sqrt() + 0.5;
    let u_lo = (au.min(au + du) - reach).floor().max(clip_u.start as f64);
    let u_hi = (au.max(au + du) + reach)
        .ceil()
        .min((clip_u.end - 1) as f64);
    if u_lo.is_nan() || u_hi.is_nan() || u_lo > u_hi {
        return Ok(());
    }
    for u in u_lo as i32..=u_hi as i32 {
        let s = if du != 0.0 {
            ((u as f64 - au) / du).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let vc = av + s * dv;
        let v_lo = (vc - band).floor().max(clip_v.start as f64);
        let v_hi = (vc + band).ceil().min((clip_v.end - 1) as f64);
        if v_lo.is_nan() || v_hi.is_nan() || v_lo > v_hi {
            continue;
        }
        for v in v_lo as i32..=v_hi as i32 {
            let (x, y) = if steep { (v, u) } else { (u, v) };
            let (qx, qy) = (x as f64 - a.0, y as f64 - a.1);
            let t = if len2 > 0.0 {
                ((qx * dx + qy * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (ex, ey) = (qx - t * dx, qy - t * dy);
            let cover = (reach - (ex * ex + ey * ey).sqrt()).min(1.0);
            if cover > 0.0 {
                area.draw_pixel((x, y), &color.mix(cover))
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    Ok(())
}

/// Text on a legend-style box (white, thin grey border).
fn boxed_text(
    area: &DrawingArea<BitMapBackend, Shift>,
    pen: &Pen,
    s: &str,
    pos: (i32, i32),
    h: HPos,
) -> Result<(), String> {
    let w = pen.width(s);
    let x0 = match h {
        HPos::Left => pos.0,
        HPos::Center => pos.0 - w / 2,
        HPos::Right => pos.0 - w,
    };
    // Room for descenders below the baseline.
    let (pad_x, pad_y, desc) = (8, 7, pen.cap() / 4);
    let corners = [
        (x0 - pad_x, pos.1 - pen.cap() / 2 - pad_y),
        (x0 + w + pad_x, pos.1 + (pen.cap() + 1) / 2 + desc + pad_y),
    ];
    area.draw(&Rectangle::new(corners, WHITE.mix(0.92).filled()))
        .map_err(|e| e.to_string())?;
    area.draw(&Rectangle::new(corners, BLACK.mix(0.35)))
        .map_err(|e| e.to_string())?;
    pen.draw(area, s, (x0, pos.1), (HPos::Left, VPos::Center), false)
}

/// Pens of the map figures.
struct MapPens {
    title: Pen,
    desc: Pen,
    tick: Pen,
    label: Pen,
}

/// Layout of a map ([`network`], [`fracture_map`]), computed before
/// drawing: equal x/y axes in metres, title on top, axis descriptions, a
/// vertical colour bar on the right; `NET_WIDTH` x `NET_HEIGHT` px.
struct MapLayout<'a> {
    title: &'a str,
    value_label: &'a str,
    pens: MapPens,
    /// Colour-bar axis (`None`: nothing to colour, the bar is left blank).
    bar: Option<Axis>,
    bar_labels: Vec<(f64, String)>,
    bar_mult: Option<String>,
    bar_tick_w: i32,
    desc_h: i32,
    top: i32,
    bottom: i32,
    left: i32,
    right: i32,
    y_tick_w: i32,
    x_axis: Axis,
    y_axis: Axis,
    x_labels: Vec<(f64, String)>,
    y_labels: Vec<(f64, String)>,
}

/// Where a map's plotting area landed, from [`MapLayout::draw_base`].
struct MapFrame {
    /// Pixel ranges of the plotting area.
    px: std::ops::Range<i32>,
    py: std::ops::Range<i32>,
    /// Pixel column of each major x tick, pixel row of each major y tick.
    x_ticks: Vec<i32>,
    y_ticks: Vec<i32>,
    /// Axis ranges (m) and the pixels of their (lo, lo) and (hi, hi) corners.
    x: (f64, f64),
    y: (f64, f64),
    lo_px: (i32, i32),
    hi_px: (i32, i32),
}

impl MapFrame {
    /// Metres to continuous pixel coordinates (pixel `(i, j)` covers
    /// `[i, i+1) x [j, j+1)`).
    fn to_px(&self, p: [f64; 2]) -> (f64, f64) {
        let fx = (p[0] - self.x.0) / (self.x.1 - self.x.0);
        let fy = (p[1] - self.y.0) / (self.y.1 - self.y.0);
        (
            self.lo_px.0 as f64 + fx * (self.hi_px.0 - self.lo_px.0) as f64,
            self.lo_px.1 as f64 + fy * (self.hi_px.1 - self.lo_px.1) as f64,
        )
    }

    fn clip(&self) -> (std::ops::Range<i32>, std::ops::Range<i32>) {
        (self.px.clone(), self.py.clone())
    }

    /// Whether the point `p` (m) lies within the axes.
    fn shows(&self, p: [f64; 2]) -> bool {
        (self.x.0..=self.x.1).contains(&p[0]) && (self.y.0..=self.y.1).contains(&p[1])
    }
}

impl<'a> MapLayout<'a> {
    /// Lay out a map of the data box `bbox` (`[xmin, xmax, ymin, ymax]`, m)
    /// with a margin of `pad` times its larger side, widened to the plotting
    /// area's aspect ratio.
    fn new(
        title: &'a str,
        value_label: &'a str,
        bar: Option<Axis>,
        bbox: [f64; 4],
        pad: f64,
    ) -> Self {
        let black = RGBColor(0, 0, 0);
        let pens = MapPens {
            title: Pen::new(TITLE_SIZE, black),
            desc: Pen::new(DESC_SIZE, black),
            tick: Pen::new(TICK_SIZE, RGBColor(30, 30, 30)),
            label: Pen::new(LEGEND_SIZE, black),
        };
        let bar_labels: Vec<(f64, String)> = bar
            .iter()
            .flat_map(|a| a.major.iter().map(|&t| (t, a.label(t))))
            .collect();
        let bar_mult = bar.as_ref().and_then(Axis::multiplier);
        let bar_tick_w = bar_labels
            .iter()
            .map(|(_, l)| pens.tick.width(l))
            .max()
            .unwrap_or(0);

        // Layout in pixels (margins around the plotting area).
        let desc_h = pens.desc.cap() + 6;
        let top = if title.is_empty() {
            24
        } else {
            18 + pens.title.cap() + 26
        };
        let bottom = TICK_GAP + pens.tick.cap() + 8 + 18 + desc_h + 14;
        let bar_desc_w = if value_label.is_empty() {
            0
        } else {
            16 + desc_h
        };
        let right = (BAR_GAP + BAR_W + BAR_TICK + 6 + bar_tick_w + bar_desc_w + 20)
            .max(BAR_GAP + bar_mult.as_deref().map_or(0, |m| pens.tick.width(m)) + 16);
        let (w_px, h_px) = (NET_WIDTH as i32, NET_HEIGHT as i32);
        let mut y_tick_w = 0;
        let (mut left, mut axes);
        let mut tries = 0;
        loop {
            left = 16 + desc_h + 18 + y_tick_w + TICK_GAP;
            // Pixel lengths of the axes as plotters maps them.
            let ax_w = (w_px - right - 1 - left).max(10) as f64;
            let ax_h = (h_px - bottom - 1 - top).max(10) as f64;
            axes = equal_axes(bbox, ax_w, ax_h, pad);
            let need = axes
                .1
                .major
                .iter()
                .map(|&t| pens.tick.width(&axes.1.label(t)))
                .max()
                .unwrap_or(0);
            tries += 1;
            if need <= y_tick_w || tries == 5 {
                break;
            }
            y_tick_w = need;
        }
        let (x_axis, y_axis) = axes;
        let x_labels = x_axis.major.iter().map(|&t| (t, x_axis.label(t))).collect();
        let y_labels = y_axis.major.iter().map(|&t| (t, y_axis.label(t))).collect();
        MapLayout {
            title,
            value_label,
            pens,
            bar,
            bar_labels,
            bar_mult,
            bar_tick_w,
            desc_h,
            top,
            bottom,
            left,
            right,
            y_tick_w,
            x_axis,
            y_axis,
            x_labels,
            y_labels,
        }
    }

    /// Fill the image white and draw the axes with their tick marks (and a
    /// grid when `grid`); returns where the plotting area landed.
    fn draw_base(
        &self,
        root: &DrawingArea<BitMapBackend, Shift>,
        grid: bool,
    ) -> Result<MapFrame, String> {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let no_label = |_: &f64| String::new();
        let mut chart = ChartBuilder::on(root)
            .margin_top(self.top)
            .margin_right(self.right)
            .x_label_area_size(self.bottom)
            .y_label_area_size(self.left)
            .build_cartesian_2d(self.x_axis.clone(), self.y_axis.clone())
            .map_err(|e| e.to_string())?;
        let mut mesh = chart.configure_mesh();
        mesh.x_label_formatter(&no_label)
            .y_label_formatter(&no_label)
            .bold_line_style(BLACK.mix(0.12))
            .light_line_style(BLACK.mix(0.04))
            .axis_style(BLACK.stroke_width(1))
            .set_all_tick_mark_size(6);
        if !grid {
            mesh.disable_mesh();
        }
        mesh.draw().map_err(|e| e.to_string())?;
        let (px, py) = chart.plotting_area().get_pixel_range();
        let (xa, ya) = (&self.x_axis, &self.y_axis);
        Ok(MapFrame {
            px,
            py,
            x_ticks: (self.x_labels.iter())
                .map(|(t, _)| chart.backend_coord(&(*t, ya.lo)).0)
                .collect(),
            y_ticks: (self.y_labels.iter())
                .map(|(t, _)| chart.backend_coord(&(xa.lo, *t)).1)
                .collect(),
            x: (xa.lo, xa.hi),
            y: (ya.lo, ya.hi),
            lo_px: chart.backend_coord(&(xa.lo, ya.lo)),
            hi_px: chart.backend_coord(&(xa.hi, ya.hi)),
        })
    }

    /// Draw over the map's content: the frame's top and right sides, tick
    /// labels, axis descriptions, title, colour bar, a big note (`(text,
    /// centred)`: centred in the plot, else boxed near its top) and small
    /// notes in the lower left corner.
    fn draw_overlay(
        &self,
        root: &DrawingArea<BitMapBackend, Shift>,
        frame: &MapFrame,
        big_note: Option<(&str, bool)>,
        notes: &[String],
    ) -> Result<(), String> {
        let (px, py) = (&frame.px, &frame.py);
        let pens = &self.pens;
        // Close the frame on the top and right (over the content).
        root.draw(&PathElement::new(
            vec![
                (px.start, py.start),
                (px.end - 1, py.start),
                (px.end - 1, py.end - 1),
            ],
            BLACK.stroke_width(1),
        ))
        .map_err(|e| e.to_string())?;

        // Axis tick labels, descriptions, title.
        for ((_, l), &x) in self.x_labels.iter().zip(&frame.x_ticks) {
            let at = (x, py.end + TICK_GAP);
            pens.tick
                .draw(root, l, at, (HPos::Center, VPos::Top), false)?;
        }
        for ((_, l), &y) in self.y_labels.iter().zip(&frame.y_ticks) {
            let at = (px.start - TICK_GAP, y);
            pens.tick
                .draw(root, l, at, (HPos::Right, VPos::Center), false)?;
        }
        let cx = (px.start + px.end) / 2;
        let cy = (py.start + py.end) / 2;
        let center = (HPos::Center, VPos::Center);
        let center_top = (HPos::Center, VPos::Top);
        let y = py.end + TICK_GAP + pens.tick.cap() + 8 + 18;
        pens.desc.draw(root, "x [m]", (cx, y), center_top, false)?;
        let x = px.start - TICK_GAP - self.y_tick_w - 18 - self.desc_h / 2;
        pens.desc.draw(root, "y [m]", (x, cy), center, true)?;
        if !self.title.is_empty() {
            pens.title
                .draw(root, self.title, (cx, 18), center_top, false)?;
        }
        if let Some(m) = self.x_axis.multiplier() {
            let at = (px.end, py.end + TICK_GAP + pens.tick.cap() + 8 + 18);
            pens.tick
                .draw(root, &m, at, (HPos::Right, VPos::Top), false)?;
        }
        if let Some(m) = self.y_axis.multiplier() {
            let at = (px.start, py.start - 8);
            pens.tick
                .draw(root, &m, at, (HPos::Left, VPos::Bottom), false)?;
        }

        // Colour bar, as tall as the plotting area.
        let bx0 = px.end - 1 + BAR_GAP;
        let bx1 = bx0 + BAR_W;
        let (b_top, b_bot) = (py.start, py.end - 1);
        let bar_y = |f: f64| b_bot - (f * (b_bot - b_top) as f64).round() as i32;
        for yy in b_top..=b_bot {
            let color = if self.bar.is_some() {
                viridis((b_bot - yy) as f64 / (b_bot - b_top).max(1) as f64)
            } else {
                RGBColor(240, 240, 240)
            };
            root.draw(&PathElement::new(vec![(bx0, yy), (bx1, yy)], color))
                .map_err(|e| e.to_string())?;
        }
        root.draw(&Rectangle::new(
            [(bx0, b_top), (bx1, b_bot)],
            BLACK.stroke_width(1),
        ))
        .map_err(|e| e.to_string())?;
        if let Some(a) = &self.bar {
            for &t in &a.minor {
                let y = bar_y(colour_fraction(a, t));
                root.draw(&PathElement::new(vec![(bx1, y), (bx1 + 3, y)], BLACK))
                    .map_err(|e| e.to_string())?;
            }
            for (t, l) in &self.bar_labels {
                let y = bar_y(colour_fraction(a, *t));
                root.draw(&PathElement::new(
                    vec![(bx1, y), (bx1 + BAR_TICK, y)],
                    BLACK,
                ))
                .map_err(|e| e.to_string())?;
                let at = (bx1 + BAR_TICK + 6, y);
                pens.tick
                    .draw(root, l, at, (HPos::Left, VPos::Center), false)?;
            }
        }
        if let Some(m) = &self.bar_mult {
            let at = (bx0, b_top - 8);
            pens.tick
                .draw(root, m, at, (HPos::Left, VPos::Bottom), false)?;
        }
        if !self.value_label.is_empty() {
            let x = bx1 + BAR_TICK + 6 + self.bar_tick_w + 16 + self.desc_h / 2;
            let at = (x, (b_top + b_bot) / 2);
            pens.desc.draw(root, self.value_label, at, center, true)?;
        }

        // Notes.
        if let Some((msg, centred)) = big_note {
            let pen = Pen::new(22.0, RGBColor(90, 90, 90));
            if centred {
                pen.draw(root, msg, (cx, cy), center, false)?;
            } else {
                // Near the top, to hide little of the drawing.
                let at = (cx, py.start + 24 + pen.cap() / 2);
                boxed_text(root, &pen, msg, at, HPos::Center)?;
            }
        }
        if !notes.is_empty() {
            let pen = Pen::new(15.0, RGBColor(110, 110, 110));
            let at = (12, NET_HEIGHT as i32 - 12);
            pen.draw(
                root,
                &notes.join("; "),
                at,
                (HPos::Left, VPos::Bottom),
                false,
            )?;
        }
        Ok(())
    }
}

/// Labelled points as red discs with a dark rim on a white halo, each label
/// on a white box beside its point (left of it near the right edge).
fn draw_map_markers(
    root: &DrawingArea<BitMapBackend, Shift>,
    frame: &MapFrame,
    pen: &Pen,
    markers: &[([f64; 2], &str)],
) -> Result<(), String> {
    let clip = frame.clip();
    let (px, py) = (&frame.px, &frame.py);
    for &(p, _) in markers {
        let c = frame.to_px(p);
        draw_aa_segment(root, c, c, 17.0, WHITE, &clip)?;
        draw_aa_segment(root, c, c, 14.0, RGBColor(40, 40, 40), &clip)?;
        draw_aa_segment(root, c, c, 11.0, MARKER_FILL, &clip)?;
    }
    for &(p, label) in markers {
        if label.is_empty() {
            continue;
        }
        let (cx, cy) = frame.to_px(p);
        let (cx, cy) = (cx.floor() as i32, cy.floor() as i32);
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

/// Draw a `NET_WIDTH` x `NET_HEIGHT` px map with `draw` into the PNG file
/// `tmp`; errors name `path`.
fn draw_map_file(
    tmp: &Path,
    path: &Path,
    draw: impl FnOnce(&DrawingArea<BitMapBackend, Shift>) -> Result<(), String>,
) -> Result<(), PlotError> {
    let root = BitMapBackend::new(tmp, (NET_WIDTH, NET_HEIGHT)).into_drawing_area();
    let r = draw(&root).and_then(|()| root.present().map_err(|e| e.to_string()));
    drop(root);
    r.map_err(|m| draw_err(path, m))
}

fn draw_network(root: &DrawingArea<BitMapBackend, Shift>, net: &Network) -> Result<(), String> {
    let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
    let drawable: Vec<usize> = (0..net.segments.len())
        .filter(|&k| finite(&net.segments[k].a) && finite(&net.segments[k].b))
        .collect();
    let no_coords = net.segments.len() - drawable.len();
    let markers: Vec<([f64; 2], &str)> = (net.markers.iter())
        .filter(|m| finite(&m.0))
        .copied()
        .collect();

    // Data box of the drawable segments and markers.
    let mut bbox = [f64::MAX, f64::MIN, f64::MAX, f64::MIN];
    let points = drawable
        .iter()
        .flat_map(|&k| [net.segments[k].a, net.segments[k].b])
        .chain(markers.iter().map(|m| m.0));
    for p in points {
        bbox = grow_box(bbox, p);
    }
    if bbox[0] > bbox[1] {
        bbox = [0.0, 1.0, 0.0, 1.0];
    }

    // Colour range of the usable values of drawable segments.
    let (mut vmin, mut vmax) = (f64::MAX, f64::MIN);
    for &k in &drawable {
        let v = net.values[k];
        if net.usable(v) {
            vmin = vmin.min(v);
            vmax = vmax.max(v);
        }
    }
    let bar = (vmin <= vmax).then(|| colour_axis(vmin, vmax, net.scale));
    let greyed = drawable
        .iter()
        .filter(|&&k| !net.usable(net.values[k]))
        .count();
    let layout = MapLayout::new(net.title, net.value_label, bar, bbox, NET_PAD);

    // Drawing order: grey segments first, then by increasing value.
    let mut order: Vec<(Option<f64>, usize)> = drawable
        .iter()
        .map(|&k| {
            let v = net.values[k];
            let t = match &layout.bar {
                Some(a) if net.usable(v) => Some(colour_fraction(a, net.bar_value(v))),
                _ => None,
            };
            (t, k)
        })
        .collect();
    sort_for_drawing(&mut order);

    let frame = layout.draw_base(root, true)?;
    let clip = frame.clip();
    for &(t, k) in &order {
        let color = t.map_or(NO_VALUE_GREY, viridis);
        let s = &net.segments[k];
        let w = net.line_width(k);
        draw_aa_segment(root, frame.to_px(s.a), frame.to_px(s.b), w, color, &clip)?;
    }
    draw_map_markers(root, &frame, &layout.pens.label, &markers)?;

    let big_note = if net.segments.is_empty() {
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
        let s = if greyed == 1 { "" } else { "s" };
        notes.push(format!("{greyed} segment{s} with {what} drawn grey"));
    }
    if no_coords > 0 {
        let s = if no_coords == 1 { "" } else { "s" };
        notes.push(format!(
            "{no_coords} segment{s} with non-finite end points omitted"
        ));
    }
    layout.draw_overlay(root, &frame, big_note.map(|m| (m, centred)), &notes)
}

/// `bbox` (`[xmin, xmax, ymin, ymax]`) grown to hold `p`.
fn grow_box(bbox: [f64; 4], [x, y]: [f64; 2]) -> [f64; 4] {
    [
        bbox[0].min(x),
        bbox[1].max(x),
        bbox[2].min(y),
        bbox[3].max(y),
    ]
}

/// Sort `(colour fraction, item)` pairs for drawing: items without a colour
/// (grey) first, then by increasing fraction.
fn sort_for_drawing(order: &mut [(Option<f64>, usize)]) {
    order.sort_by(|p, q| match (p.0, q.0) {
        (Some(a), Some(b)) => a.total_cmp(&b),
        (p, q) => p.is_some().cmp(&q.is_some()),
    });
}

// ---------------------------------------------------------------------------
// Fracture maps
// ---------------------------------------------------------------------------

/// Arguments of [`fracture_map`], validated.
struct QuadMap<'a> {
    title: &'a str,
    mesh_edges: &'a [Segment],
    quads: &'a [[[f64; 2]; 4]],
    values: &'a [f64],
    value_label: &'a str,
    window: Option<[f64; 4]>,
    markers: &'a [([f64; 2], &'a str)],
}

/// Anti-aliased filled polygon `pts` (continuous pixel coordinates, as in
/// [`draw_aa_segment`]; even-odd rule, 4 x 4 samples per pixel), clipped to
/// the pixel ranges `clip`.
fn fill_aa_polygon(
    area: &DrawingArea<BitMapBackend, Shift>,
    pts: &[(f64, f64)],
    color: RGBColor,
    clip: &(std::ops::Range<i32>, std::ops::Range<i32>),
) -> Result<(), String> {
    const N: i64 = 4;
    let n = pts.len();
    if n < 3 {
        return Ok(());
    }
    let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        (x_lo, x_hi) = (x_lo.min(x), x_hi.max(x));
        (y_lo, y_hi) = (y_lo.min(y), y_hi.max(y));
    }
    let i_lo = x_lo.floor().max(clip.0.start as f64);
    let i_hi = x_hi.floor().min((clip.0.end - 1) as f64);
    let j_lo = y_lo.floor().max(clip.1.start as f64);
    let j_hi = y_hi.floor().min((clip.1.end - 1) as f64);
    // Also false for NaN.
    if !(i_lo <= i_hi && j_lo <= j_hi) {
        return Ok(());
    }
    let (i0, i1, j0, j1) = (i_lo as i32, i_hi as i32, j_lo as i32, j_hi as i32);
    let cols = (i1 - i0 + 1) as usize;
    let samples = cols as i64 * N;
    let mut cover = vec![0u16; cols];
    let mut xs: Vec<f64> = Vec::with_capacity(n);
    for j in j0..=j1 {
        cover.fill(0);
        for r in 0..N {
            let sy = j as f64 + (r as f64 + 0.5) / N as f64;
            xs.clear();
            for k in 0..n {
                let (p, q) = (pts[k], pts[(k + 1) % n]);
                if (p.1 <= sy) != (q.1 <= sy) {
                    xs.push(p.0 + (sy - p.1) * (q.0 - p.0) / (q.1 - p.1));
                }
            }
            xs.sort_by(f64::total_cmp);
            for span in xs.chunks_exact(2) {
                // Sample columns s at x = i0 + (s + 1/2) / N with span[0] <= x < span[1].
                let first =
                    |x: f64| (((x - i0 as f64) * N as f64 - 0.5).ceil() as i64).clamp(0, samples);
                for s in first(span[0])..first(span[1]) {
                    cover[(s / N) as usize] += 1;
                }
            }
        }
        for (c, &hits) in cover.iter().enumerate() {
            if hits > 0 {
                let a = hits as f64 / (N * N) as f64;
                area.draw_pixel((i0 + c as i32, j), &color.mix(a))
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    Ok(())
}

fn draw_fracture_map(
    root: &DrawingArea<BitMapBackend, Shift>,
    map: &QuadMap,
) -> Result<MapFrame, String> {
    let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
    let drawable: Vec<usize> = (0..map.quads.len())
        .filter(|&k| map.quads[k].iter().all(finite))
        .collect();
    let no_coords = map.quads.len() - drawable.len();
    let edges: Vec<&Segment> = (map.mesh_edges.iter())
        .filter(|s| finite(&s.a) && finite(&s.b))
        .collect();
    let bad_edges = map.mesh_edges.len() - edges.len();

    // Region shown: the window, else the quads and markers, else the mesh.
    let mut bbox = [f64::MAX, f64::MIN, f64::MAX, f64::MIN];
    let (bbox, pad) = if let Some([x0, x1, y0, y1]) = map.window {
        ([x0, x1, y0, y1], 0.0)
    } else {
        let corners = drawable.iter().flat_map(|&k| map.quads[k]);
        for p in corners.chain(map.markers.iter().map(|m| m.0).filter(finite)) {
            bbox = grow_box(bbox, p);
        }
        if bbox[0] > bbox[1] {
            for p in edges.iter().flat_map(|s| [s.a, s.b]) {
                bbox = grow_box(bbox, p);
            }
        }
        if bbox[0] > bbox[1] {
            bbox = [0.0, 1.0, 0.0, 1.0];
        }
        (bbox, QUAD_PAD)
    };

    // Colour range of the finite values of drawable quads.
    let (mut vmin, mut vmax) = (f64::MAX, f64::MIN);
    for &k in &drawable {
        let v = map.values[k];
        if v.is_finite() {
            vmin = vmin.min(v);
            vmax = vmax.max(v);
        }
    }
    let bar = (vmin <= vmax).then(|| colour_axis(vmin, vmax, ColourScale::Linear));
    let greyed = drawable
        .iter()
        .filter(|&&k| !map.values[k].is_finite())
        .count();
    let layout = MapLayout::new(map.title, map.value_label, bar, bbox, pad);

    // Drawing order: grey quads first, then by increasing value.
    let mut order: Vec<(Option<f64>, usize)> = drawable
        .iter()
        .map(|&k| {
            let v = map.values[k];
            let t = match &layout.bar {
                Some(a) if v.is_finite() => Some(colour_fraction(a, v)),
                _ => None,
            };
            (t, k)
        })
        .collect();
    sort_for_drawing(&mut order);

    let frame = layout.draw_base(root, false)?;
    let clip = frame.clip();
    for s in &edges {
        let (a, b) = (frame.to_px(s.a), frame.to_px(s.b));
        draw_aa_segment(root, a, b, MESH_LINE_PX, MESH_GREY, &clip)?;
    }
    for &(t, k) in &order {
        let color = t.map_or(NO_VALUE_GREY, viridis);
        let pts = map.quads[k].map(|p| frame.to_px(p));
        fill_aa_polygon(root, &pts, color, &clip)?;
        for e in 0..4 {
            draw_aa_segment(root, pts[e], pts[(e + 1) % 4], QUAD_EDGE_PX, color, &clip)?;
        }
    }
    let markers: Vec<([f64; 2], &str)> = (map.markers.iter())
        .filter(|m| frame.shows(m.0))
        .copied()
        .collect();
    draw_map_markers(root, &frame, &layout.pens.label, &markers)?;

    let big_note = if map.quads.is_empty() {
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
        let s = if greyed == 1 { "" } else { "s" };
        notes.push(format!(
            "{greyed} cell{s} with a non-finite value drawn grey"
        ));
    }
    if no_coords > 0 {
        let s = if no_coords == 1 { "" } else { "s" };
        notes.push(format!(
            "{no_coords} cell{s} with non-finite corners omitted"
        ));
    }
    if bad_edges > 0 {
        let s = if bad_edges == 1 { "" } else { "s" };
        notes.push(format!(
            "{bad_edges} mesh edge{s} with non-finite end points omitted"
        ));
    }
    layout.draw_overlay(root, &frame, big_note.map(|m| (m, centred)), &notes)?;
    Ok(frame)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn tmp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("plot_test_{}_{name}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn assert_png(path: &Path) {
        let bytes = fs::read(path).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert!(
            bytes.len() > 5000,
            "suspiciously small PNG: {}",
            bytes.len()
        );
    }

    fn convergence() -> Vec<Series> {
        let h: Vec<f64> = (0..6).map(|i| 0.1 / 2f64.powi(i)).collect();
        vec![
            Series {
                label: "L2 error (displacement)".into(),
                points: h.iter().map(|&h| (h, 0.8 * h * h)).collect(),
            },
            Series {
                label: "energy error".into(),
                points: h.iter().map(|&h| (h, 0.3 * h)).collect(),
            },
        ]
    }

    #[test]
    fn loglog_two_series_writes_png() {
        let dir = tmp_dir("loglog");
        let p = dir.join("conv.png");
        loglog(&p, "Convergence", "h", "error", &convergence()).unwrap();
        assert_png(&p);
        let names: Vec<_> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("conv.png")]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn lines_two_series_writes_png() {
        let dir = tmp_dir("lines");
        let p = dir.join("ts.png");
        let s = vec![
            Series {
                label: "pressure".into(),
                points: (0..500)
                    .map(|i| (i as f64 * 0.01, (i as f64 * 0.03).sin()))
                    .collect(),
            },
            Series {
                label: "aperture".into(),
                points: (0..500)
                    .map(|i| (i as f64 * 0.01, 0.5 * (i as f64 * 0.01)))
                    .collect(),
            },
        ];
        lines(&p, "Time series", "t [s]", "value", &s).unwrap();
        assert_png(&p);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn degenerate_input_does_not_panic() {
        let dir = tmp_dir("degenerate");
        let bad = vec![
            Series {
                label: "negative".into(),
                points: vec![(-1.0, 2.0), (1.0, -3.0), (0.0, 0.0), (f64::NAN, 1.0)],
            },
            Series {
                label: "empty".into(),
                points: vec![],
            },
        ];
        loglog(&dir.join("a.png"), "all dropped", "x", "y", &bad).unwrap();
        assert_png(&dir.join("a.png"));
        loglog(&dir.join("b.png"), "no series", "x", "y", &[]).unwrap();
        lines(&dir.join("c.png"), "no series", "x", "y", &[]).unwrap();
        let single = vec![Series {
            label: "one point".into(),
            points: vec![(3.0, 3.0), (3.0, 3.0)],
        }];
        loglog(&dir.join("d.png"), "single", "x", "y", &single).unwrap();
        lines(&dir.join("e.png"), "single", "x", "y", &single).unwrap();
        let huge = vec![Series {
            label: String::new(),
            points: vec![(-f64::MAX, 0.0), (f64::MAX, 1e-300), (0.0, f64::INFINITY)],
        }];
        lines(&dir.join("f.png"), "huge", "x", "y", &huge).unwrap();
        let many: Vec<Series> = (0..25)
            .map(|i| Series {
                label: format!("s{i}"),
                points: vec![(1.0, 1.0 + i as f64), (1e12, 1e-12 * (1.0 + i as f64))],
            })
            .collect();
        loglog(&dir.join("g.png"), "many", "x", "y", &many).unwrap();
        for f in ["b.png", "c.png", "d.png", "e.png", "f.png", "g.png"] {
            assert_png(&dir.join(f));
        }
        fs::remove_dir_all(&dir).unwrap();
    }

    /// Deterministic pseudo-random numbers in 0..1.
    fn rng(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// `n` random segments in two orientation families over 200 m x 120 m.
    fn random_network(n: usize, seed: u64) -> Vec<Segment> {
        let mut s = seed;
        (0..n)
            .map(|i| {
                let (cx, cy) = (200.0 * rng(&mut s), 120.0 * rng(&mut s));
                let base = if i % 2 == 0 { 30f64 } else { 115.0 };
                let ang = (base + 20.0 * (rng(&mut s) - 0.5)).to_radians();
                let half = 0.5 * (5.0 + 35.0 * rng(&mut s));
                let (dx, dy) = (half * ang.cos(), half * ang.sin());
                Segment {
                    a: [cx - dx, cy - dy],
                    b: [cx + dx, cy + dy],
                }
            })
            .collect()
    }

    fn only_file(dir: &Path, name: &str) {
        let names: Vec<_> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from(name)]);
    }

    #[test]
    fn network_random_linear_and_log_write_png() {
        let dir = tmp_dir("network");
        let segs = random_network(200, 7);
        let mut s = 99;
        let mut lin: Vec<f64> = segs.iter().map(|g| 1e7 - 2e4 * g.a[0]).collect();
        lin[3] = f64::NAN;
        lin[4] = f64::INFINITY;
        let p = dir.join("lin.png");
        let none: &[([f64; 2], &str)] = &[];
        network(
            &p,
            "Pressure",
            &segs,
            &lin,
            "p [Pa]",
            ColourScale::Linear,
            None,
            none,
        )
        .unwrap();
        assert_png(&p);
        only_file(&dir, "lin.png");

        let mut q: Vec<f64> = (0..segs.len())
            .map(|_| 10f64.powf(-9.0 + 5.0 * rng(&mut s)))
            .collect();
        q[0] = 0.0;
        q[1] = -1e-6;
        q[2] = f64::NAN;
        let widths: Vec<f64> = q.iter().map(|v| 1.0 + (v.log10() + 9.0)).collect();
        let markers = [([20.0, 60.0], "pump"), ([180.0, 60.0], "production")];
        let p = dir.join("log.png");
        let label = "q [m³/s]";
        network(
            &p,
            "Flow",
            &segs,
            &q,
            label,
            ColourScale::Log,
            Some(&widths),
            &markers,
        )
        .unwrap();
        assert_png(&p);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn network_degenerate_input_does_not_panic() {
        let dir = tmp_dir("network_degenerate");
        let none: &[([f64; 2], &str)] = &[];
        let lin = ColourScale::Linear;
        let log = ColourScale::Log;
        network(&dir.join("a.png"), "empty", &[], &[], "v", lin, None, none).unwrap();
        network(&dir.join("b.png"), "", &[], &[], "", log, Some(&[]), none).unwrap();
        let segs = random_network(50, 3);
        let nan = vec![f64::NAN; segs.len()];
        network(
            &dir.join("c.png"),
            "all NaN",
            &segs,
            &nan,
            "v",
            lin,
            None,
            none,
        )
        .unwrap();
        let neg = vec![-1.0; segs.len()];
        network(
            &dir.join("d.png"),
            "all negative",
            &segs,
            &neg,
            "v",
            log,
            None,
            none,
        )
        .unwrap();
        let one = [Segment {
            a: [5.0, 5.0],
            b: [5.0, 5.0],
        }];
        let markers = [([5.0, 5.0], "well")];
        network(
            &dir.join("e.png"),
            "point",
            &one,
            &[2.0],
            "v",
            log,
            None,
            &markers,
        )
        .unwrap();
        let odd = [
            Segment {
                a: [f64::NAN, 0.0],
                b: [1.0, 1.0],
            },
            Segment {
                a: [0.0, 0.0],
                b: [1e3, 0.0],
            },
            Segment {
                a: [-f64::MAX, 0.0],
                b: [f64::MAX, 1e-300],
            },
        ];
        let w = [f64::NAN, 1e9, -3.0];
        let v = [1.0, 1.0, 1.0];
        network(
            &dir.join("f.png"),
            "odd",
            &odd,
            &v,
            "v",
            lin,
            Some(&w),
            none,
        )
        .unwrap();
        let far = [([f64::INFINITY, 0.0], "lost"), ([1.0, 2.0], "")];
        network(
            &dir.join("g.png"),
            "markers only",
            &[],
            &[],
            "v",
            lin,
            None,
            &far,
        )
        .unwrap();
        for f in [
            "a.png", "b.png", "c.png", "d.png", "e.png", "f.png", "g.png",
        ] {
            assert_png(&dir.join(f));
        }
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn network_length_mismatch_is_err() {
        let dir = tmp_dir("network_mismatch");
        let segs = random_network(10, 1);
        let p = dir.join("x.png");
        let none: &[([f64; 2], &str)] = &[];
        let lin = ColourScale::Linear;
        let e = network(&p, "t", &segs, &[1.0; 9], "v", lin, None, none).unwrap_err();
        assert!(matches!(e, PlotError::Input { .. }), "{e:?}");
        assert!(
            e.to_string().contains("9 values given for 10 segments"),
            "{e}"
        );
        let w = [2.0; 11];
        let e = network(&p, "t", &segs, &[1.0; 10], "v", lin, Some(&w), none).unwrap_err();
        assert!(
            e.to_string()
                .contains("11 line widths given for 10 segments"),
            "{e}"
        );
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 0);
        fs::remove_dir_all(&dir).unwrap();
    }

    /// Example maps for looking at: written to `$PLOT_EXAMPLES_DIR` when set
    /// (kept), else to a temporary folder (removed).
    #[test]
    fn network_examples_render() {
        let keep = std::env::var_os("PLOT_EXAMPLES_DIR").map(PathBuf::from);
        let dir = match &keep {
            Some(d) => {
                fs::create_dir_all(d).unwrap();
                d.clone()
            }
            None => tmp_dir("network_examples"),
        };

        // Grid network, 150 m x 110 m, pressure falling from left to right.
        let (nx, ny, h) = (16, 12, 10.0);
        let mut segs = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let p = [i as f64 * h, j as f64 * h];
                if i + 1 < nx {
                    segs.push(Segment {
                        a: p,
                        b: [p[0] + h, p[1]],
                    });
                }
                if j + 1 < ny {
                    segs.push(Segment {
                        a: p,
                        b: [p[0], p[1] + h],
                    });
                }
            }
        }
        let mut s = 5;
        let pressure: Vec<f64> = segs
            .iter()
            .map(|g| {
                let x = 0.5 * (g.a[0] + g.b[0]);
                2.0e7 - 5.0e6 * x / 150.0 + 1.0e5 * (rng(&mut s) - 0.5)
            })
            .collect();
        let p = dir.join("network_grid_pressure.png");
        let none: &[([f64; 2], &str)] = &[];
        let (title, lin) = ("Grid network: fluid pressure", ColourScale::Linear);
        network(
            &p,
            title,
            &segs,
            &pressure,
            "pressure [Pa]",
            lin,
            None,
            none,
        )
        .unwrap();
        assert_png(&p);

        // Random network, log-scale flow rate, widths by flow rate.
        let segs = random_network(180, 11);
        let q: Vec<f64> = segs
            .iter()
            .enumerate()
            .map(|(k, g)| match k {
                5 => f64::NAN,
                6 => 0.0,
                _ => {
                    let y = 0.5 * (g.a[1] + g.b[1]);
                    10f64.powf(-4.0 - 5.0 * ((y - 60.0).abs() / 60.0) - rng(&mut s))
                }
            })
            .collect();
        let widths: Vec<f64> = q.iter().map(|v| 0.8 + 1.2 * (v.log10() + 10.0)).collect();
        let markers = [([20.0, 60.0], "pump"), ([180.0, 60.0], "production")];
        let p = dir.join("network_flow_log.png");
        let (title, log) = ("Fracture network: flow rate", ColourScale::Log);
        let label = "flow rate [m³/s]";
        network(&p, title, &segs, &q, label, log, Some(&widths), &markers).unwrap();
        assert_png(&p);

        if keep.is_none() {
            fs::remove_dir_all(&dir).unwrap();
        }
    }

    /// Width and height from a PNG's IHDR chunk.
    fn png_size(path: &Path) -> (u32, u32) {
        let b = fs::read(path).unwrap();
        assert_eq!(&b[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(&b[12..16], b"IHDR");
        let be = |i: usize| u32::from_be_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        (be(16), be(20))
    }

    /// Edges of a grid of `nx` x `ny` squares of 1 m from the origin.
    fn grid_edges(nx: usize, ny: usize) -> Vec<Segment> {
        let mut e = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                let p = [i as f64, j as f64];
                if i < nx {
                    e.push(Segment {
                        a: p,
                        b: [p[0] + 1.0, p[1]],
                    });
                }
                if j < ny {
                    e.push(Segment {
                        a: p,
                        b: [p[0], p[1] + 1.0],
                    });
                }
            }
        }
        e
    }

    /// Axis-aligned quad `[x0, x1] x [y0, y1]`.
    fn rect(x0: f64, x1: f64, y0: f64, y1: f64) -> [[f64; 2]; 4] {
        [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    /// A big quad (value 5), a 1 mm thin one (value 1) and one without a
    /// value over a 10 m x 4 m grid.
    fn small_fracture_map() -> (Vec<Segment>, Vec<[[f64; 2]; 4]>, Vec<f64>) {
        let quads = vec![
            rect(1.0, 9.0, 1.0, 3.0),
            rect(2.0, 5.0, 3.5495, 3.5505),
            rect(6.0, 8.0, 3.3, 3.9),
        ];
        (grid_edges(10, 4), quads, vec![5.0, 1.0, f64::NAN])
    }

    /// Render a fracture map into memory: RGB pixels and the frame.
    fn render_fracture_map(map: &QuadMap) -> (Vec<u8>, MapFrame) {
        ensure_font().unwrap();
        let mut buf = vec![0u8; (NET_WIDTH * NET_HEIGHT * 3) as usize];
        let frame = {
            let root =
                BitMapBackend::with_buffer(&mut buf, (NET_WIDTH, NET_HEIGHT)).into_drawing_area();
            let frame = draw_fracture_map(&root, map).unwrap();
            root.present().unwrap();
            frame
        };
        (buf, frame)
    }

    /// RGB of the pixel holding the point `p` (m).
    fn pixel_at(buf: &[u8], frame: &MapFrame, p: [f64; 2]) -> [u8; 3] {
        let (x, y) = frame.to_px(p);
        let (x, y) = (x.floor() as usize, y.floor() as usize);
        let i = 3 * (y * NET_WIDTH as usize + x);
        [buf[i], buf[i + 1], buf[i + 2]]
    }

    #[test]
    fn fracture_map_writes_png_of_expected_size() {
        let dir = tmp_dir("fracture_map");
        let (edges, quads, values) = small_fracture_map();
        let p = dir.join("fractures.png");
        let markers = [([1.0, 2.0], "pump"), ([500.0, 2.0], "far away")];
        let label = "pressure [MPa]";
        fracture_map(&p, "Fig. 7", &edges, &quads, &values, label, None, &markers).unwrap();
        assert_png(&p);
        assert_eq!(png_size(&p), (NET_WIDTH, NET_HEIGHT));
        only_file(&dir, "fractures.png");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn fracture_map_pixels() {
        let (edges, quads, values) = small_fracture_map();
        let mut map = QuadMap {
            title: "t",
            mesh_edges: &edges,
            quads: &quads,
            values: &values,
            value_label: "v",
            window: None,
            markers: &[],
        };
        let (buf, frame) = render_fracture_map(&map);
        // Inside the big quad: the top of the colour bar.
        let top = viridis(1.0);
        assert_eq!(pixel_at(&buf, &frame, [5.5, 2.5]), [top.0, top.1, top.2]);
        assert_eq!(pixel_at(&buf, &frame, [1.5, 1.5]), [top.0, top.1, top.2]);
        // The quad without a value: grey.
        let g = NO_VALUE_GREY;
        assert_eq!(pixel_at(&buf, &frame, [7.5, 3.6]), [g.0, g.1, g.2]);
        // The 1 mm quad (0.1 px) still shows, dark (bottom of the bar).
        let [r, gr, b] = pixel_at(&buf, &frame, [3.5, 3.55]);
        assert!(gr < 128 && r < 160 && b < 180, "{r} {gr} {b}");
        // Between mesh lines outside the quads: white; on a mesh line: grey.
        assert_eq!(pixel_at(&buf, &frame, [5.5, 0.5]), [255, 255, 255]);
        let [r, gr, b] = pixel_at(&buf, &frame, [5.5, 4.0]);
        assert!(r == gr && gr == b && r < 250, "{r} {gr} {b}");
        // Default window: the quads' box plus 10 %, widened to the aspect ratio.
        assert!(frame.x.0 < 0.3 && frame.x.1 > 9.7, "{:?}", frame.x);
        assert!(frame.x.1 - frame.x.0 < 11.0, "{:?}", frame.x);
        assert!(frame.y.0 < 1.0 && frame.y.1 > 3.9, "{:?}", frame.y);

        // A window shows just that region; the quads outside it are clipped.
        map.window = Some([5.0, 6.0, 2.0, 2.5]);
        let (buf, frame) = render_fracture_map(&map);
        assert!(frame.x.0 <= 5.0 && frame.x.1 >= 6.0, "{:?}", frame.x);
        assert!(frame.x.1 - frame.x.0 < 1.5, "{:?}", frame.x);
        assert_eq!(pixel_at(&buf, &frame, [5.5, 2.25]), [top.0, top.1, top.2]);

        // The default window follows the quads, not the mesh.
        let big = grid_edges(100, 100);
        let q = [rect(40.0, 45.0, 50.0, 50.2)];
        map.mesh_edges = &big;
        map.quads = &q;
        map.values = &[2.0];
        map.window = None;
        let (buf, frame) = render_fracture_map(&map);
        assert!(frame.x.0 > 35.0 && frame.x.1 < 50.0, "{:?}", frame.x);
        let one = viridis(0.5);
        assert_eq!(pixel_at(&buf, &frame, [42.5, 50.1]), [one.0, one.1, one.2]);
    }

    #[test]
    fn fracture_map_bad_input_is_err() {
        let dir = tmp_dir("fracture_map_bad");
        let (edges, quads, values) = small_fracture_map();
        let p = dir.join("x.png");
        let e = fracture_map(&p, "t", &edges, &quads, &values[..2], "v", None, &[]).unwrap_err();
        assert!(matches!(e, PlotError::Input { .. }), "{e:?}");
        assert!(e.to_string().contains("2 values given for 3 quads"), "{e}");
        for w in [
            [0.0, 1.0, 2.0, 2.0],
            [1.0, 0.0, 0.0, 1.0],
            [f64::NAN, 1.0, 0.0, 1.0],
            [0.0, f64::INFINITY, 0.0, 1.0],
        ] {
            let e = fracture_map(&p, "t", &edges, &quads, &values, "v", Some(w), &[]).unwrap_err();
            assert!(matches!(e, PlotError::Input { .. }), "{e:?}");
            assert!(e.to_string().contains("window"), "{e}");
        }
        assert_eq!(fs::read_dir(&dir).unwrap().count(), 0);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn fracture_map_degenerate_input_does_not_panic() {
        let dir = tmp_dir("fracture_map_degenerate");
        let edges = grid_edges(3, 3);
        let none: &[([f64; 2], &str)] = &[];
        fracture_map(&dir.join("a.png"), "", &[], &[], &[], "", None, none).unwrap();
        fracture_map(
            &dir.join("b.png"),
            "mesh",
            &edges,
            &[],
            &[],
            "v",
            None,
            none,
        )
        .unwrap();
        let quads = [rect(0.0, 1.0, 0.0, 0.1), rect(1.0, 2.0, 0.0, 0.1)];
        let nan = [f64::NAN; 2];
        fracture_map(
            &dir.join("c.png"),
            "nan",
            &edges,
            &quads,
            &nan,
            "v",
            None,
            none,
        )
        .unwrap();
        let odd = [
            [[f64::NAN, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            [[2.0, 2.0]; 4],
            rect(-f64::MAX, f64::MAX, 0.0, 1e-300),
        ];
        let bad_edges = [Segment {
            a: [0.0, f64::INFINITY],
            b: [1.0, 1.0],
        }];
        let v = [1.0, 2.0, 3.0];
        let m = [([2.0, 2.0], "point")];
        fracture_map(
            &dir.join("d.png"),
            "odd",
            &bad_edges,
            &odd,
            &v,
            "v",
            None,
            &m,
        )
        .unwrap();
        let w = Some([0.0, 1e-9, 0.0, 1e-9]);
        fracture_map(
            &dir.join("e.png"),
            "tiny",
            &edges,
            &quads,
            &v[..2],
            "v",
            w,
            &m,
        )
        .unwrap();
        for f in ["a.png", "b.png", "c.png", "d.png", "e.png"] {
            assert_png(&dir.join(f));
        }
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn network_colours_and_axes() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(0.5), RGBColor(33, 145, 140));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
        // Equal metres per pixel on both axes, same tick step.
        let (x, y) = equal_axes([0.0, 200.0, 0.0, 50.0], 800.0, 700.0, NET_PAD);
        let (mx, my) = ((x.hi - x.lo) / 800.0, (y.hi - y.lo) / 700.0);
        assert!((mx / my - 1.0).abs() < 1e-12, "{mx} {my}");
        assert_eq!(x.step, y.step);
        assert!(x.lo < 0.0 && x.hi > 200.0 && y.lo < 0.0 && y.hi > 50.0);
        // Log colour bar: exact data range, power-of-ten labels.
        let a = colour_axis(1e-9, 1e-4, ColourScale::Log);
        let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
        assert_eq!(labels, ["10⁻⁹", "10⁻⁸", "10⁻⁷", "10⁻⁶", "10⁻⁵", "10⁻⁴"]);
        assert_eq!(colour_fraction(&a, -9.0), 0.0);
        assert_eq!(colour_fraction(&a, -4.0), 1.0);
        let a = colour_axis(0.5, 20.0, ColourScale::Log);
        let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
        assert_eq!(labels, ["5×10⁻¹", "10⁰", "2×10⁰", "5×10⁰", "10¹", "2×10¹"]);
        let a = colour_axis(3.0, 3.0, ColourScale::Linear);
        assert_eq!(colour_fraction(&a, 3.0), 0.5);
    }

    #[test]
    fn tick_labels() {
        let a = Axis::log(-3.0, 0.0);
        let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
        assert!(labels.contains(&"0.001".to_string()), "{labels:?}");
        assert!(labels.contains(&"1".to_string()), "{labels:?}");
        let a = Axis::log(-12.0, -6.0);
        let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
        assert!(labels.contains(&"10⁻⁹".to_string()), "{labels:?}");
        let a = Axis::linear(0.0, 1.0);
        let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
        assert_eq!(labels, ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        assert_eq!(a.multiplier(), None);
        let a = Axis::linear(-1.0, 0.0);
        let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
        assert_eq!(labels.first().map(String::as_str), Some("\u{2212}1.0"));
        assert_eq!(labels.last().map(String::as_str), Some("0.0"));
        let a = Axis::linear(0.0, 3e-7);
        let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
        assert_eq!(labels, ["0.0", "0.5", "1.0", "1.5", "2.0", "2.5", "3.0"]);
        assert_eq!(a.multiplier().as_deref(), Some("×10⁻⁷"));
        // Narrow log range still gets at least two labelled ticks.
        let a = Axis::log(2f64.log10(), 4f64.log10());
        let labels: Vec<_> = a.major.iter().map(|&t| a.label(t)).collect();
        assert_eq!(labels, ["2", "3", "4"]);
    }

    #[test]
    fn embedded_font_metrics_are_read() {
        // 'H' and 'r' in DejaVu Sans (font units).
        assert_eq!(ttf_h_metrics(FONT_BYTES, 'H'), Some((1540, 201)));
        assert!(ttf_h_metrics(FONT_BYTES, 'r').is_some());
        assert!(ttf_h_metrics(FONT_BYTES, '⁻').is_some());
        assert!(ttf_glyph(FONT_BYTES, '\u{10FFFF}').is_none());
        ensure_font().unwrap();
        assert!(Pen::new(17.0, RGBColor(0, 0, 0)).px_per_unit.is_some());
    }
}
