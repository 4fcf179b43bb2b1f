//! Axis ranges, ticks and tick labels (log axes in log10 space with
//! power-of-ten labels), and their linear mapping onto pixels for plotters.

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

#[derive(Clone)]
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
    pub(super) fn linear(dmin: f64, dmax: f64) -> Axis {
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
    pub(super) fn linear_exact(lo: f64, hi: f64) -> Axis {
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
    pub(super) fn linear_stepped(lo: f64, hi: f64, step: f64) -> Axis {
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
    pub(super) fn log(lmin: f64, lmax: f64) -> Axis {
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
    pub(super) fn label(&self, v: f64) -> String {
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
            let (v, decimals) = if self.plain {
                (v, (extra - ks).clamp(0.0, 12.0))
            } else {
                let e = self.exponent();
                (v / 10f64.powi(e), (e as f64 - ks + extra).clamp(0.0, 10.0))
            };
            let prec = decimals as usize;
            let s = format!("{v:.prec$}");
            // Avoid "-0.0" for values that round to zero.
            if s.trim_start_matches(['-', '0', '.']).is_empty() {
                s.trim_start_matches('-').to_string()
            } else {
                s
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
