//! `hydrofrac sweep collect DIR`: every member's inputs and quantities of interest in one
//! table, into `DIR/collect/` (an output folder of its own, with its manifest):
//! - `table.csv`: one row per member: `member`, `status` (`ok`, `failed`, `interrupted`,
//!   `not_run`), the varied inputs, the quantities (`collect`, then `plot_against`), `error`;
//!   an empty cell where a member has no value;
//! - `table.json`: the same, with the failed members and their errors listed apart;
//! - `timing.csv`: each member's wall time, s (kept out of the table, which is the same on
//!   every machine);
//! - `hist_Q.png`: the distribution of each numeric quantity Q over the finished members;
//! - `scatter_Q_vs_X.png`: each numeric quantity against each numeric varied input and each
//!   `plot_against` path.

use super::spec::parse_segment;
use super::{Plan, RUN_DIR, SweepError, read_plan};
use crate::output::folder::Folder;
use crate::plot::Series;
use rayon::prelude::*;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// Options of `hydrofrac sweep collect`.
#[derive(Clone, Debug)]
pub struct CollectOptions {
    /// Draw the figures (`--no-figures` leaves them out).
    pub figures: bool,
}

/// What [`collect`] found and wrote.
#[derive(Clone, Debug, Default)]
pub struct CollectReport {
    pub out: PathBuf,
    pub total: usize,
    pub ok: usize,
    /// (member, error).
    pub failed: Vec<(usize, String)>,
    /// Members not run (or not finished, or run for another plan).
    pub not_run: Vec<usize>,
    /// Quantities missing in some finished members, figures not drawn.
    pub warnings: Vec<String>,
}

/// One member's row.
struct Row {
    status: &'static str,
    /// Per quantity (collect, then plot_against): its value, or why there is none.
    quantities: Vec<Result<Value, String>>,
    /// Per quantity: missing, but the path up to its last key is there (a value the run
    /// leaves out, such as a ratio against a zero rate, not a misspelt path).
    leaf_only: Vec<bool>,
    error: Option<String>,
    wall_s: Option<f64>,
}

/// The quantity paths of a plan: `collect`, then the `plot_against` paths not among them.
fn quantity_paths(plan: &Plan) -> Vec<String> {
    let mut q = plan.collect.clone();
    for p in &plan.plot_against {
        if !q.contains(p) {
            q.push(p.clone());
        }
    }
    q
}

/// Collect the sweep in `dir` into `dir/collect/`.
pub fn collect(dir: &Path, opts: &CollectOptions) -> Result<CollectReport, SweepError> {
    let plan = read_plan(dir)?;
    let paths = quantity_paths(&plan);
    let rows: Vec<Row> = plan
        .members
        .par_iter()
        .map(|m| read_row(&dir.join(&m.dir), &m.fingerprint, &paths))
        .collect();
    let mut report = CollectReport {
        out: dir.join("collect"),
        total: rows.len(),
        ..Default::default()
    };
    for (k, p) in paths.iter().enumerate() {
        let ok: Vec<&Row> = rows.iter().filter(|r| r.status == "ok").collect();
        let missing: Vec<&String> = ok
            .iter()
            .filter_map(|r| r.quantities[k].as_ref().err())
            .collect();
        // Missing everywhere: a misspelt path, unless some member has all but its last key
        // (then the runs left the value out: a warning).
        let leaf = ok.iter().any(|r| r.leaf_only[k]);
        if !ok.is_empty() && missing.len() == ok.len() && !leaf {
            return Err(SweepError::Other(format!(
                "quantity `{p}` is in no member's summary.json: {}",
                missing[0]
            )));
        }
        if let Some(why) = missing.first() {
            report.warnings.push(format!(
                "quantity `{p}` is missing in {} of {} finished members ({why})",
                missing.len(),
                ok.len()
            ));
        }
    }
    for (m, r) in plan.members.iter().zip(&rows) {
        match r.status {
            "ok" => report.ok += 1,
            "failed" => report
                .failed
                .push((m.id, r.error.clone().unwrap_or_default())),
            _ => report.not_run.push(m.id),
        }
    }
    let folder = Folder::prepare(&report.out, false)?;
    write_tables(&folder, &plan, &paths, &rows)?;
    let groups = group_members(&plan);
    if !plan.pool.is_empty() {
        write_groups(&folder, &plan, &groups, &rows)?;
    }
    if opts.figures {
        let warnings = figures(&folder, &plan, &paths, &rows, &groups)?;
        report.warnings.extend(warnings);
    }
    Ok(report)
}

/// Members that differ only in the pooled inputs (`pool`): the values of the other inputs
/// and the members' indices, in the order of their first member. Empty without `pool`.
struct Group {
    key: Vec<Value>,
    members: Vec<usize>,
}

fn group_members(plan: &Plan) -> Vec<Group> {
    if plan.pool.is_empty() {
        return Vec::new();
    }
    let kept: Vec<usize> = (0..plan.inputs.len())
        .filter(|&k| !plan.pool.contains(&plan.inputs[k]))
        .collect();
    let mut out: Vec<Group> = Vec::new();
    for (i, m) in plan.members.iter().enumerate() {
        let key: Vec<Value> = kept.iter().map(|&k| m.values[k].clone()).collect();
        match out.iter_mut().find(|g| g.key == key) {
            Some(g) => g.members.push(i),
            None => out.push(Group {
                key,
                members: vec![i],
            }),
        }
    }
    out
}

/// A quantity as a number: numbers as they are, booleans as 1 and 0.
fn numeric(v: &Result<Value, String>) -> Option<f64> {
    match v.as_ref().ok()? {
        Value::Bool(b) => Some(if *b { 1.0 } else { 0.0 }),
        other => other.as_f64(),
    }
}

/// The median of `xs` (sorted in place; the mean of the middle two for an even count).
fn median(xs: &mut [f64]) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

/// `groups.csv`: one row per group (the inputs not pooled, `members`, `ok`), and for each
/// `collect` quantity over the group's finished members that have it: `Q:n` (how many),
/// `Q:nonzero` (the fraction not zero or false), `Q:min`, `Q:median`, `Q:max` (empty when
/// none has it).
fn write_groups(
    folder: &Folder,
    plan: &Plan,
    groups: &[Group],
    rows: &[Row],
) -> Result<(), SweepError> {
    let kept: Vec<&String> = plan
        .inputs
        .iter()
        .filter(|p| !plan.pool.contains(p))
        .collect();
    let mut csv: Vec<String> = kept.iter().map(|p| csv_text(p)).collect();
    csv.extend(["members".into(), "ok".into()]);
    for q in &plan.collect {
        for stat in ["n", "nonzero", "min", "median", "max"] {
            csv.push(csv_text(&format!("{q}:{stat}")));
        }
    }
    let mut text = csv.join(",") + "\n";
    for g in groups {
        let ok: Vec<usize> = g
            .members
            .iter()
            .copied()
            .filter(|&i| rows[i].status == "ok")
            .collect();
        let mut cells: Vec<String> = g.key.iter().map(cell).collect();
        cells.extend([g.members.len().to_string(), ok.len().to_string()]);
        for k in 0..plan.collect.len() {
            let mut xs: Vec<f64> = ok
                .iter()
                .filter_map(|&i| numeric(&rows[i].quantities[k]))
                .collect();
            cells.push(xs.len().to_string());
            if xs.is_empty() {
                cells.extend(std::iter::repeat_n(String::new(), 4));
                continue;
            }
            let nonzero = xs.iter().filter(|&&x| x != 0.0).count() as f64 / xs.len() as f64;
            // `median` sorts: the ends are the extremes.
            let mid = median(&mut xs);
            let (lo, hi) = (xs[0], xs[xs.len() - 1]);
            cells.extend([nonzero, lo, mid, hi].iter().map(|x| x.to_string()));
        }
        text += &(cells.join(",") + "\n");
    }
    let p = folder
        .claim("groups.csv")
        .map_err(|e| SweepError::io(&folder.dir, e))?;
    crate::output::write_atomic(&p, text.as_bytes()).map_err(|e| SweepError::io(&p, e))
}

/// A member's row from its `status.json` and `run/summary.json`.
fn read_row(mdir: &Path, fingerprint: &str, paths: &[String]) -> Row {
    let status = super::run::read_status(mdir).filter(|s| s.fingerprint == fingerprint);
    let none = |status: &'static str, error: Option<String>| Row {
        status,
        quantities: paths.iter().map(|_| Err(String::new())).collect(),
        leaf_only: vec![false; paths.len()],
        error,
        wall_s: None,
    };
    let Some(s) = status else {
        return none("not_run", None);
    };
    let wall = Some(s.wall_s);
    match s.status.as_str() {
        "ok" => {}
        "failed" => {
            return Row {
                wall_s: wall,
                ..none("failed", s.error)
            };
        }
        "interrupted" => {
            return Row {
                wall_s: wall,
                ..none("interrupted", s.error)
            };
        }
        _ => return none("not_run", None),
    }
    let path = mdir.join(RUN_DIR).join("summary.json");
    let summary: Value = match std::fs::read_to_string(&path)
        .map_err(|e| e.to_string())
        .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
    {
        Ok(v) => v,
        Err(e) => {
            let why = format!("{}: {e}", path.display());
            return Row {
                wall_s: wall,
                ..none("failed", Some(why))
            };
        }
    };
    let quantities: Vec<Result<Value, String>> = paths
        .iter()
        .map(|p| extract(&summary, p).cloned())
        .collect();
    let leaf_only = paths
        .iter()
        .zip(&quantities)
        .map(|(p, q)| {
            q.is_err()
                && p.rsplit_once('.')
                    .is_some_and(|(parent, _)| extract(&summary, parent).is_ok())
        })
        .collect();
    Row {
        status: "ok",
        quantities,
        leaf_only,
        error: None,
        wall_s: wall,
    }
}

/// The value at `path` in `v` (`a.b`, `a.0.b`, `a[name=pump].b`), or why there is none (with
/// the fields where the path leaves the document).
pub fn extract<'a>(v: &'a Value, path: &str) -> Result<&'a Value, String> {
    let mut node = v;
    let mut at = String::new();
    for seg in path.split('.') {
        let (key, sel) = parse_segment(seg)?;
        let next = match (node, key.parse::<usize>()) {
            (Value::Array(a), Ok(i)) => a.get(i),
            (Value::Object(o), _) => o.get(key),
            _ => None,
        };
        let Some(mut next) = next else {
            let fields = match node {
                Value::Object(o) => {
                    let mut k: Vec<&str> = o.keys().map(|s| s.as_str()).collect();
                    k.sort();
                    format!("fields: {}", k.join(", "))
                }
                Value::Array(a) => format!("a list of {}", a.len()),
                other => format!("a value ({other})"),
            };
            let here = if at.is_empty() {
                "summary.json".into()
            } else {
                format!("`{at}`")
            };
            return Err(format!("no `{key}` in {here} ({fields})"));
        };
        if let Some((f, want)) = sel {
            let hit = next.as_array().and_then(|a| {
                a.iter().find(|e| match &e[f] {
                    Value::String(s) => s == want,
                    Value::Null => false,
                    other => want.parse::<Value>().ok().as_ref() == Some(other),
                })
            });
            next = hit.ok_or_else(|| format!("no element of `{key}` has {f} = {want}"))?;
        }
        if !at.is_empty() {
            at.push('.');
        }
        at += seg;
        node = next;
    }
    Ok(node)
}

/// A CSV cell: numbers and booleans as JSON writes them, strings quoted when they need it.
fn cell(v: &Value) -> String {
    match v {
        Value::Null => String::new(),
        Value::String(s) => csv_text(s),
        Value::Array(_) | Value::Object(_) => csv_text(&v.to_string()),
        other => other.to_string(),
    }
}

fn csv_text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// `table.csv`, `table.json` and `timing.csv`.
fn write_tables(
    folder: &Folder,
    plan: &Plan,
    paths: &[String],
    rows: &[Row],
) -> Result<(), SweepError> {
    let mut csv = String::from("member,status");
    for name in plan.inputs.iter().chain(paths) {
        csv += ",";
        csv += &csv_text(name);
    }
    csv += ",error\n";
    let mut timing = String::from("member,status,wall_s\n");
    let mut members = Vec::with_capacity(rows.len());
    let mut failed = Vec::new();
    for (m, r) in plan.members.iter().zip(rows) {
        csv += &format!("{},{}", m.id, r.status);
        for v in &m.values {
            csv += ",";
            csv += &cell(v);
        }
        let mut q = serde_json::Map::new();
        for (p, v) in paths.iter().zip(&r.quantities) {
            csv += ",";
            if let Ok(v) = v {
                csv += &cell(v);
                q.insert(p.clone(), v.clone());
            }
        }
        csv += ",";
        csv += &r.error.as_deref().map(csv_text).unwrap_or_default();
        csv += "\n";
        if let Some(w) = r.wall_s {
            timing += &format!("{},{},{w}\n", m.id, r.status);
        }
        let mut row =
            json!({"member": m.id, "status": r.status, "inputs": m.values, "quantities": q});
        if let Some(e) = &r.error {
            row["error"] = json!(e);
            if r.status == "failed" {
                failed.push(json!({"member": m.id, "error": e}));
            }
        }
        members.push(row);
    }
    let table =
        json!({"inputs": plan.inputs, "quantities": paths, "members": members, "failed": failed});
    let text = serde_json::to_string_pretty(&table).expect("json") + "\n";
    for (name, bytes) in [
        ("table.csv", csv.as_bytes()),
        ("table.json", text.as_bytes()),
        ("timing.csv", timing.as_bytes()),
    ] {
        let p = folder
            .claim(name)
            .map_err(|e| SweepError::io(&folder.dir, e))?;
        crate::output::write_atomic(&p, bytes).map_err(|e| SweepError::io(&p, e))?;
    }
    Ok(())
}

/// A file-name part for a path: letters and digits, the rest `_`.
fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

/// The most figures one collect draws.
const MAX_FIGURES: usize = 200;

/// The histograms and scatter plots; returns the figures not drawn.
fn figures(
    folder: &Folder,
    plan: &Plan,
    paths: &[String],
    rows: &[Row],
    groups: &[Group],
) -> Result<Vec<String>, SweepError> {
    let ok: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].status == "ok")
        .collect();
    let number = |v: &Result<Value, String>| v.as_ref().ok().and_then(Value::as_f64);
    let quantity = |k: usize| -> Vec<(usize, f64)> {
        ok.iter()
            .filter_map(|&i| number(&rows[i].quantities[k]).map(|y| (i, y)))
            .collect()
    };
    // The x axes: the numeric inputs, then the plot_against quantities.
    let mut axes: Vec<(String, Vec<Option<f64>>)> = Vec::new();
    for (k, name) in plan.inputs.iter().enumerate() {
        let xs: Vec<Option<f64>> = plan.members.iter().map(|m| m.values[k].as_f64()).collect();
        if ok.iter().any(|&i| xs[i].is_some()) {
            axes.push((name.clone(), xs));
        }
    }
    for p in &plan.plot_against {
        let k = paths.iter().position(|q| q == p).expect("listed");
        axes.push((
            p.clone(),
            rows.iter().map(|r| number(&r.quantities[k])).collect(),
        ));
    }
    let mut jobs: Vec<(String, String, String, String, Vec<Series>, bool)> = Vec::new();
    for (k, q) in plan.collect.iter().enumerate() {
        let ys = quantity(k);
        if ys.is_empty() {
            continue;
        }
        let title = format!("{}: distribution of {q} ({} members)", plan.sweep, ys.len());
        let hist = histogram(&ys.iter().map(|p| p.1).collect::<Vec<_>>());
        jobs.push((
            format!("hist_{}.png", slug(q)),
            title,
            q.clone(),
            "members".into(),
            hist,
            false,
        ));
        if !groups.is_empty() {
            jobs.push((
                format!("groups_{}.png", slug(q)),
                format!("{q} by group"),
                "group (row of groups.csv)".into(),
                q.clone(),
                group_series(groups, rows, k),
                true,
            ));
        }
        for (name, xs) in axes.iter().filter(|(n, _)| n != q) {
            let pts: Vec<(f64, f64)> = ys
                .iter()
                .filter_map(|&(i, y)| xs[i].map(|x| (x, y)))
                .collect();
            let title = format!("{q} against {name}");
            let s = vec![Series {
                label: String::new(),
                points: pts,
            }];
            jobs.push((
                format!("scatter_{}_vs_{}.png", slug(q), slug(name)),
                title,
                name.clone(),
                q.clone(),
                s,
                true,
            ));
        }
    }
    let mut warnings = Vec::new();
    if jobs.len() > MAX_FIGURES {
        warnings.push(format!(
            "{} figures not drawn (at most {MAX_FIGURES})",
            jobs.len() - MAX_FIGURES
        ));
        jobs.truncate(MAX_FIGURES);
    }
    let mut claimed = Vec::with_capacity(jobs.len());
    for j in &jobs {
        claimed.push(
            folder
                .claim(&j.0)
                .map_err(|e| SweepError::io(&folder.dir, e))?,
        );
    }
    let drawn: Vec<Option<String>> = jobs
        .par_iter()
        .zip(&claimed)
        .map(|((name, title, xl, yl, s, scatter), path)| {
            let r = if *scatter {
                crate::plot::scatter(path, title, xl, yl, s)
            } else {
                crate::plot::lines(path, title, xl, yl, s)
            };
            r.err().map(|e| format!("{name} not drawn: {e}"))
        })
        .collect();
    warnings.extend(drawn.into_iter().flatten());
    Ok(warnings)
}

/// The strip plot of quantity `k` by group: group g's finished members at x = g + 1 (spread
/// over +-0.3 in member order so that equal values stay apart), one series per group. The
/// series have no labels (a legend of a dozen groups would hide the points): group g is row g
/// of `groups.csv`.
fn group_series(groups: &[Group], rows: &[Row], k: usize) -> Vec<Series> {
    groups
        .iter()
        .enumerate()
        .map(|(g, grp)| {
            let ys: Vec<f64> = grp
                .members
                .iter()
                .filter(|&&i| rows[i].status == "ok")
                .filter_map(|&i| numeric(&rows[i].quantities[k]))
                .collect();
            let n = ys.len();
            let points = ys
                .into_iter()
                .enumerate()
                .map(|(j, y)| {
                    let dx = if n > 1 {
                        0.6 * (j as f64 / (n - 1) as f64 - 0.5)
                    } else {
                        0.0
                    };
                    ((g + 1) as f64 + dx, y)
                })
                .collect();
            Series {
                label: String::new(),
                points,
            }
        })
        .collect()
}

/// A histogram's outline (a step line from zero to zero) of `xs`: about sqrt(n) bins (1 to
/// 50) over their range (a range of zero width gets one bin of width 1 % of the value, or 1).
fn histogram(xs: &[f64]) -> Vec<Series> {
    let (lo, hi) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let bins = ((xs.len() as f64).sqrt().ceil() as usize).clamp(1, 50);
    let (lo, hi, bins) = if hi > lo {
        (lo, hi, bins)
    } else {
        let w = if lo != 0.0 { lo.abs() * 0.01 } else { 1.0 };
        (lo - w / 2.0, lo + w / 2.0, 1)
    };
    let width = (hi - lo) / bins as f64;
    let mut counts = vec![0usize; bins];
    for &x in xs {
        let b = (((x - lo) / width) as usize).min(bins - 1);
        counts[b] += 1;
    }
    let mut pts = vec![(lo, 0.0)];
    for (b, &c) in counts.iter().enumerate() {
        let (a, z) = (lo + b as f64 * width, lo + (b + 1) as f64 * width);
        pts.push((a, c as f64));
        pts.push((z, c as f64));
    }
    pts.push((hi, 0.0));
    vec![Series {
        label: String::new(),
        points: pts,
    }]
}
