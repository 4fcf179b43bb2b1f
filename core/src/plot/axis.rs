//! Axis ranges, ticks and tick labels (log axes in log10 space with
//! power-of-ten labels), mapped linearly onto pixels for plotters.

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

/// An axis over `lo..hi` with major (labelled) and minor ticks.
#[derive(Clone, Default)]
pub(super) struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub major: Vec<f64>,
    pub minor: Vec<f64>,
    /// Log axis: values are log10 of data.
    log: bool,
    /// Linear: tick step. Log: unused.
    pub step: f64,
    /// Plain decimal labels (vs. scientific).
    pub plain: bool,
    /// Log axis spanning too little for 1..9 x 10^k ticks: linear ticks
    /// (in value space) and their labels.
    fine: Option<Box<Axis>>,
}

/// `k` in superscript digits.
fn superscript(k: i32) -> String {
    const DIGITS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let sup = |c: char| c.to_digit(10).map_or('⁻', |d| DIGITS[d as usize]);
    k.to_string().chars().map(sup).collect()
}

/// `m × 10^k` written out in plain decimal (m, k integers, m in 1..=9).
fn plain_decimal(m: i64, k: i32) -> String {
    match k >= 0 {
        true => format!("{m}{}", "0".repeat(k as usize)),
        false => format!("0.{}{m}", "0".repeat((-k - 1) as usize)),
    }
}

/// `x` when positive and finite, else 1.
fn or_one(x: f64) -> f64 {
    if x > 0.0 && x.is_finite() { x } else { 1.0 }
}

/// `f` clamped to `lo..=hi`; 0.5 when not finite.
pub(super) fn clamp_or_half(f: f64, lo: f64, hi: f64) -> f64 {
    if f.is_finite() { f.clamp(lo, hi) } else { 0.5 }
}

impl Axis {
    fn new(lo: f64, hi: f64, major: Vec<f64>, minor: Vec<f64>) -> Axis {
        Axis {
            lo,
            hi,
            major,
            minor,
            ..Axis::default()
        }
    }

    /// Linear axis over the data extent plus 5% margins.
    pub(super) fn linear(dmin: f64, dmax: f64) -> Axis {
        let pad = match (dmax > dmin, dmin == 0.0) {
            (true, _) => 0.05 * (dmax - dmin),
            (false, true) => 1.0,
            (false, false) => 0.1 * dmin.abs(),
        };
        let hi = (dmax.max(dmin) + pad).min(f64::MAX);
        Axis::linear_exact((dmin - pad).max(-f64::MAX), hi)
    }

    /// Linear axis over exactly `lo..hi`, ~8 ticks at 1/2/2.5/5 x 10^k.
    pub(super) fn linear_exact(lo: f64, hi: f64) -> Axis {
        // Divide first so huge ranges do not overflow.
        let raw = or_one(hi / 8.0 - lo / 8.0);
        let mag = 10f64.powf(raw.log10().floor());
        let steps = [1.0, 2.0, 2.5, 5.0, 10.0].map(|f| f * mag);
        let step = steps.into_iter().find(|&s| s >= raw * (1.0 - 1e-12));
        Axis::linear_stepped(lo, hi, step.unwrap_or(10.0 * mag))
    }

    /// Linear axis over exactly `lo..hi` with major ticks every `step`
    /// (a 1/2/2.5/5 x 10^k value).
    pub(super) fn linear_stepped(lo: f64, hi: f64, step: f64) -> Axis {
        let step = or_one(step);
        let mag = 10f64.powf((step.log10() + 1e-9).floor());
        let quarters = (step / mag - 2.0).abs() < 1e-9;
        let minor_step = step / if quarters { 4.0 } else { 5.0 };
        let multiples = |s: f64| -> Vec<f64> {
            let (first, last) = ((lo / s).ceil() as i64, (hi / s).floor() as i64);
            let snap = |v: f64| if v.abs() < s * 1e-9 { 0.0 } else { v };
            (first..=last.max(first - 1))
                .map(|i| snap(i as f64 * s))
                .collect()
        };
        let mut a = Axis::new(lo, hi, multiples(step), multiples(minor_step));
        let big = lo.abs().max(hi.abs());
        (a.step, a.plain) = (step, (1e-3..1e6).contains(&big) && step >= 1e-6);
        a
    }

    /// `lmin`, `lmax` are log10 of the positive data extent.
    pub(super) fn log(lmin: f64, lmax: f64) -> Axis {
        // Margins in decades: 5% of the span (at least 0.05), half a decade
        // each side when all values are equal.
        let m = (0.05 * (lmax - lmin)).max(0.05);
        let m = if lmax - lmin < 1e-9 { 0.5 } else { m };
        let (lo, hi) = (lmin - m, lmax + m);
        let (first, last) = (lo.floor() as i64, hi.ceil() as i64);
        // Ticks at m x 10^k for the given m within the axis.
        let ticks = |ms: &[i64]| -> Vec<f64> {
            let at = |k: i64| ms.iter().map(move |&m| k as f64 + (m as f64).log10());
            (first..=last)
                .flat_map(at)
                .filter(|&t| t >= lo && t <= hi)
                .collect()
        };
        let (decades, all) = (ticks(&[1]), ticks(&[1, 2, 3, 4, 5, 6, 7, 8, 9]));
        let major: Vec<f64> = if decades.len() >= 3 {
            let stride = decades.len().div_ceil(10) as i64;
            let on_stride = |t: &&f64| (**t as i64).rem_euclid(stride) == 0;
            decades.iter().filter(on_stride).copied().collect()
        } else {
            let m125 = ticks(&[1, 2, 5]);
            if m125.len() >= 3 { m125 } else { all.clone() }
        };
        let mut a = if major.len() < 2 {
            // Less than a factor ~2 in range: linear ticks in value space.
            let fine = Axis::linear_exact(10f64.powf(lo), 10f64.powf(hi));
            let to_log = |v: &[f64]| v.iter().filter(|&&x| x > 0.0).map(|x| x.log10()).collect();
            let mut a = Axis::new(lo, hi, to_log(&fine.major), to_log(&fine.minor));
            a.fine = Some(Box::new(fine));
            a
        } else {
            let plain = -3.0 - 1e-9..=5.0 + 1e-9;
            let minor = if decades.len() <= 8 { all } else { decades };
            let mut a = Axis::new(lo, hi, major, minor);
            a.plain = a.major.iter().all(|t| plain.contains(t));
            a
        };
        a.log = true;
        a
    }

    /// Tick label for axis value `v` (log10 of the data on log axes).
    pub(super) fn label(&self, v: f64) -> String {
        // Typographic minus sign.
        self.label_ascii(v).replacen('-', "\u{2212}", 1)
    }

    fn label_ascii(&self, v: f64) -> String {
        if let Some(fine) = &self.fine {
            return fine.label_ascii(10f64.powf(v));
        }
        if self.log {
            let k = (v + 1e-9).floor() as i32;
            let m = 10f64.powf(v - k as f64).round() as i64;
            let (m, k) = if m >= 10 { (1, k + 1) } else { (m.max(1), k) };
            return match (self.plain, m) {
                (true, _) => plain_decimal(m, k),
                (false, 1) => format!("10{}", superscript(k)),
                _ => format!("{m}×10{}", superscript(k)),
            };
        }
        // Decimal places needed to distinguish multiples of the tick step.
        let ks = (self.step.log10() + 1e-9).floor();
        let extra = f64::from((self.step / 10f64.powf(ks) - 2.5).abs() < 1e-6);
        let e = self.exponent();
        let (v, decimals) = match self.plain {
            true => (v, (extra - ks).clamp(0.0, 12.0)),
            false => (v / 10f64.powi(e), (e as f64 - ks + extra).clamp(0.0, 10.0)),
        };
        let s = format!("{:.*}", decimals as usize, v);
        // Avoid "-0.0" for values that round to zero.
        let zero = s.trim_start_matches(['-', '0', '.']).is_empty();
        if zero { s.replace('-', "") } else { s }
    }

    /// Common power of ten of a scientific linear axis.
    fn exponent(&self) -> i32 {
        let big = self.lo.abs().max(self.hi.abs());
        let e = (big.log10() + 1e-9).floor() as i32;
        if big > 0.0 && big.is_finite() { e } else { 0 }
    }

    /// Axis multiplier label ("×10⁻⁵") for scientific linear axes.
    pub(super) fn multiplier(&self) -> Option<String> {
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
        let f = clamp_or_half((*v - self.lo) / (self.hi - self.lo), -10.0, 10.0);
        limit.0 + ((limit.1 - limit.0) as f64 * f + 1e-3).floor() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        let light = hint.weight().allow_light_points();
        (if light { &self.minor } else { &self.major }).clone()
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}
