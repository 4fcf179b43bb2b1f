//! The sweep file (RON): what to vary, how to combine it, what to collect.

use super::{SweepError, locate};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The default of [`SweepSpec::max_members`].
pub const DEFAULT_MAX_MEMBERS: usize = 100_000;

/// A sweep file: `Sweep(base: ..., vary: [...], ...)`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields, rename = "Sweep")]
pub struct SweepSpec {
    /// The base scenario (or pipeline) file, relative to the sweep file.
    pub base: PathBuf,
    /// Whether `base` is a scenario (`hydrofrac run`) or a pipeline (`hydrofrac pipeline`).
    #[serde(default)]
    pub kind: BaseKind,
    /// The varied entries, each a `--set` path with its values.
    pub vary: Vec<Vary>,
    /// How the entries' values make members.
    #[serde(default)]
    pub combine: Combine,
    /// Quantities of interest: paths into each member's `summary.json`
    /// (`flow.injected_volume`, `flow.boundaries[name=pump].rate`, `production.rows.0.rate`).
    #[serde(default)]
    pub collect: Vec<String>,
    /// Extra x axes of the collected scatter plots: paths into `summary.json` like `collect`
    /// (a network statistic: `fractures.total_length`); each quantity is also plotted
    /// against every numeric varied input.
    #[serde(default)]
    pub plot_against: Vec<String>,
    /// The most members the sweep may have; a sweep with more is refused before anything is
    /// written.
    #[serde(default = "default_max_members")]
    pub max_members: usize,
    /// Varied paths to pool over in `collect/groups.csv` (the network seeds of a study): the
    /// members that differ only in these make one group, whose distribution of each
    /// quantity is tabulated and drawn. Empty (the default): no groups.
    #[serde(default)]
    pub pool: Vec<String>,
}

fn default_max_members() -> usize {
    DEFAULT_MAX_MEMBERS
}

/// What the base file is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
pub enum BaseKind {
    /// A scenario: each member is one `hydrofrac run`.
    #[default]
    Scenario,
    /// A pipeline file: each member is one `hydrofrac pipeline`; a path `stimulation.X` sets
    /// `X` in the stimulation scenario, any other path a field of the pipeline file.
    Pipeline,
}

/// How the varied entries make members.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
pub enum Combine {
    /// Every combination (the last entry changes fastest): the product of the counts.
    #[default]
    Product,
    /// The i-th value of every entry together: every entry has the same count.
    Zip,
}

/// One varied entry.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Vary {
    /// A `--set` path (`material.young`, `network.random.seed`).
    pub path: String,
    pub values: Values,
}

/// The values of a varied entry, in the units of its field.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub enum Values {
    /// These values, as written: numbers, booleans, strings (a string is the `--set` VALUE
    /// text itself: `"None"`, `"Local(0.5)"`).
    List(Vec<Value>),
    /// `count` values evenly spaced from `start` to `end`, both included.
    Range { start: f64, end: f64, count: usize },
    /// `count` values evenly spaced in log from `start` to `end` (both > 0), both included.
    LogRange { start: f64, end: f64, count: usize },
    /// The integers from `start` to `end`, both included (seeds).
    Integers { start: i64, end: i64 },
    /// `count` draws uniform in [`low`, `high`) from ChaCha8 seeded with `seed`.
    Uniform {
        low: f64,
        high: f64,
        count: usize,
        seed: u64,
    },
}

impl SweepSpec {
    /// Read and parse a sweep file; returns it with its text (for error positions).
    pub fn load(path: &Path) -> Result<(Self, String), SweepError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| SweepError::io(path, format!("cannot read the sweep file: {e}")))?;
        let spec = crate::scenario::parse_ron(&text, &path.display().to_string(), "sweep")?;
        Ok((spec, text))
    }

    /// Each entry's values (checked: finite, in order, not empty, each count within
    /// `max_members`), then the members' values, one row per member, after checking the
    /// member count. `file`, `text`: for error messages.
    pub fn members(&self, file: &str, text: &str) -> Result<Vec<Vec<Value>>, SweepError> {
        let spec_err = |field: String, needle: &str, why: String| SweepError::Spec {
            file: file.to_string(),
            at: locate(text, needle),
            field,
            why,
        };
        if self.vary.is_empty() {
            return Err(spec_err(
                "vary".into(),
                "vary",
                "an empty sweep: vary at least one path".into(),
            ));
        }
        for (i, p) in self.pool.iter().enumerate() {
            if !self.vary.iter().any(|v| &v.path == p) {
                let why = "not a varied path (pool lists paths of vary)".to_string();
                return Err(spec_err(
                    format!("pool[{i}] ({p})"),
                    &format!("\"{p}\""),
                    why,
                ));
            }
        }
        let mut columns = Vec::with_capacity(self.vary.len());
        for (i, v) in self.vary.iter().enumerate() {
            let field = format!("vary[{i}] ({})", v.path);
            let needle = format!("\"{}\"", v.path);
            if v.path.trim().is_empty() {
                return Err(spec_err(field, "path", "the path is empty".into()));
            }
            if let Some(j) = self.vary[..i].iter().position(|w| w.path == v.path) {
                let why = format!("the path is varied twice (also vary[{j}])");
                return Err(spec_err(field, &needle, why));
            }
            let vals = v
                .values
                .expand(self.max_members)
                .map_err(|why| spec_err(field, &needle, why))?;
            columns.push(vals);
        }
        let count = self
            .count(&columns)
            .map_err(|why| spec_err("vary".into(), "combine", why))?;
        if count > self.max_members {
            return Err(spec_err(
                "max_members".into(),
                "max_members",
                format!(
                    "the sweep has {count} members, over max_members = {} (raise it to run them all)",
                    self.max_members
                ),
            ));
        }
        Ok(self.combine_rows(&columns, count))
    }

    /// The member count of these columns under `combine` (a product that overflows is
    /// reported as such).
    fn count(&self, columns: &[Vec<Value>]) -> Result<usize, String> {
        match self.combine {
            Combine::Product => columns.iter().try_fold(1usize, |n, c| {
                n.checked_mul(c.len())
                    .ok_or_else(|| "the product of the counts overflows".to_string())
            }),
            Combine::Zip => {
                let n = columns[0].len();
                match columns.iter().position(|c| c.len() != n) {
                    Some(k) => Err(format!(
                        "combine: Zip needs every entry to have the same count: vary[0] has {n}, \
                         vary[{k}] ({}) has {}",
                        self.vary[k].path,
                        columns[k].len()
                    )),
                    None => Ok(n),
                }
            }
        }
    }

    /// The members' rows: the product in odometer order (last entry fastest), or the zip.
    fn combine_rows(&self, columns: &[Vec<Value>], count: usize) -> Vec<Vec<Value>> {
        (0..count)
            .map(|m| match self.combine {
                Combine::Zip => columns.iter().map(|c| c[m].clone()).collect(),
                Combine::Product => {
                    let mut rest = m;
                    let mut row = vec![Value::Null; columns.len()];
                    for (k, c) in columns.iter().enumerate().rev() {
                        row[k] = c[rest % c.len()].clone();
                        rest /= c.len();
                    }
                    row
                }
            })
            .collect()
    }
}

impl Values {
    /// The values, checked: not empty, at most `max` of them, finite numbers, ordered bounds.
    pub fn expand(&self, max: usize) -> Result<Vec<Value>, String> {
        let check_count = |count: usize| {
            if count == 0 {
                Err("count is 0: an empty sweep (at least 1)".to_string())
            } else if count > max {
                Err(format!("count {count} is over max_members = {max}"))
            } else {
                Ok(())
            }
        };
        let finite = |name: &str, x: f64| {
            if x.is_finite() {
                Ok(())
            } else {
                Err(format!("{name} = {x} is not a finite number"))
            }
        };
        let num = |x: f64| serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number);
        match self {
            Values::List(v) => {
                check_count(v.len())?;
                if let Some(k) = v.iter().position(|x| x.is_null()) {
                    return Err(format!("List value {k} is empty (null or unit)"));
                }
                Ok(v.clone())
            }
            Values::Range { start, end, count } | Values::LogRange { start, end, count } => {
                let log = matches!(self, Values::LogRange { .. });
                check_count(*count)?;
                finite("start", *start)?;
                finite("end", *end)?;
                if log && (*start <= 0.0 || *end <= 0.0) {
                    return Err(format!(
                        "LogRange needs start and end > 0 (start = {start}, end = {end})"
                    ));
                }
                Ok((0..*count)
                    .map(|i| num(spaced(*start, *end, i, *count, log)))
                    .collect())
            }
            Values::Integers { start, end } => {
                if end < start {
                    return Err(format!("Integers: end = {end} is below start = {start}"));
                }
                let n = end.abs_diff(*start).saturating_add(1);
                check_count(usize::try_from(n).unwrap_or(usize::MAX))?;
                Ok((*start..=*end).map(Value::from).collect())
            }
            Values::Uniform {
                low,
                high,
                count,
                seed,
            } => {
                check_count(*count)?;
                finite("low", *low)?;
                finite("high", *high)?;
                if high <= low {
                    return Err(format!(
                        "Uniform needs low < high (low = {low}, high = {high})"
                    ));
                }
                let mut rng = ChaCha8Rng::seed_from_u64(*seed);
                Ok((0..*count)
                    .map(|_| num(rng.random_range(*low..*high)))
                    .collect())
            }
        }
    }
}

/// Value `i` of `count` evenly spaced (in log with `log`) from `a` to `b`, both ends exact.
fn spaced(a: f64, b: f64, i: usize, count: usize, log: bool) -> f64 {
    if i == 0 {
        return a;
    }
    if i + 1 == count {
        return b;
    }
    let f = i as f64 / (count - 1) as f64;
    if log {
        (a.ln() + f * (b.ln() - a.ln())).exp()
    } else {
        a + f * (b - a)
    }
}

/// The `--set` VALUE text of a value: a string as it is (`None`, `Local(0.5)`), anything else
/// as JSON (which `--set` reads back to the same number).
pub fn value_text(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// Check the syntax of a quantity path (`a.b.0.c[name=pump].d`): non-empty segments, each a
/// key, an index, or a key with one `[field=value]` selector.
pub fn check_quantity_path(path: &str) -> Result<(), String> {
    if path.trim().is_empty() {
        return Err("the path is empty".into());
    }
    for seg in path.split('.') {
        parse_segment(seg)?;
    }
    Ok(())
}

/// One segment of a quantity path: the key and an optional `[field=value]` selector.
pub(crate) type Segment<'a> = (&'a str, Option<(&'a str, &'a str)>);

/// Parse one segment of a quantity path ([`Segment`]).
pub(crate) fn parse_segment(seg: &str) -> Result<Segment<'_>, String> {
    let bad = || format!("segment `{seg}` is not KEY, INDEX or KEY[FIELD=VALUE]");
    match seg.split_once('[') {
        None if !seg.is_empty() && !seg.contains(']') => Ok((seg, None)),
        None => Err(bad()),
        Some((key, rest)) => {
            let inner = rest.strip_suffix(']').ok_or_else(bad)?;
            let (f, v) = inner.split_once('=').ok_or_else(bad)?;
            if key.is_empty() || f.is_empty() || inner.contains('[') {
                return Err(bad());
            }
            Ok((key, Some((f, v))))
        }
    }
}
