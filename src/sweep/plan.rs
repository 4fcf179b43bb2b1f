//! `hydrofrac sweep plan FILE --out DIR`: every member resolved, validated and written, before
//! anything runs.
//!
//! The sweep folder after a plan:
//! - `hydrofrac-manifest.txt`: the files the plan wrote (the output-folder rules of
//!   `hydrofrac run`: a non-empty folder without one is refused, and planning again removes
//!   exactly what it lists);
//! - `sweep.ron`: a copy of the sweep file;
//! - `plan.json`: the sweep's inputs and quantities, and per member its id, folder, `--set`
//!   overrides, values and fingerprint ([`crate::checkpoint::fingerprint`]);
//! - `members/NNNN/scenario.ron`: the member's scenario, resolved (the base with the member's
//!   overrides; file paths inside it absolute), which `hydrofrac run` runs as it is. A pipeline
//!   member has `pipeline.ron` and its `stimulation.ron` instead.
//!
//! Planning twice gives the same bytes (`plan.json` holds no time or absolute path of the
//! folder).

use super::spec::{BaseKind, SweepSpec, check_quantity_path, value_text};
use super::{PLAN_FILE, PLAN_VERSION, SweepError, locate};
use crate::output::folder::Plan as FolderPlan;
use crate::pipeline::PipelineSpec;
use crate::scenario::Scenario;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// `plan.json`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
pub struct Plan {
    pub version: u32,
    /// The sweep file's name (a copy is `sweep.ron` in the folder).
    pub sweep: String,
    /// The base file as the sweep file names it.
    pub base: String,
    pub kind: BaseKind,
    /// The varied paths, in the sweep file's order.
    pub inputs: Vec<String>,
    /// The quantities of interest (paths into `summary.json`).
    pub collect: Vec<String>,
    /// Extra x axes of the scatter plots (paths into `summary.json`).
    pub plot_against: Vec<String>,
    /// The varied paths pooled over in `collect/groups.csv` (left out of `plan.json` when
    /// empty).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pool: Vec<String>,
    pub members: Vec<MemberPlan>,
}

/// One member of `plan.json`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
pub struct MemberPlan {
    pub id: usize,
    /// Its folder, relative to the sweep folder (`members/0007`).
    pub dir: String,
    /// Its `--set PATH=VALUE` overrides of the base.
    pub set: Vec<String>,
    /// Its values, one per input.
    pub values: Vec<Value>,
    /// Fingerprint of its physics (16 hex digits): the scenario as resolved, less name,
    /// description and output ([`crate::checkpoint::fingerprint`]); for a pipeline, that of
    /// the stimulation with the pipeline file.
    pub fingerprint: String,
}

impl Plan {
    /// The file a member runs, in its folder: `scenario.ron` or `pipeline.ron`.
    pub fn member_file(&self) -> &'static str {
        match self.kind {
            BaseKind::Scenario => "scenario.ron",
            BaseKind::Pipeline => "pipeline.ron",
        }
    }
}

/// A member resolved: its files (name in its folder, text) and fingerprint.
struct Resolved {
    files: Vec<(&'static str, String)>,
    fingerprint: u64,
}

/// The base, loaded once.
enum Base {
    Scenario(Box<Scenario>),
    Pipeline(Box<(PipelineSpec, Scenario)>),
}

/// Plan the sweep of `file` into `out`: every member is resolved and validated before the
/// folder is touched (the first bad member is reported, with the sweep file's line and column
/// of its entry), then the folder is checked (a foreign folder is refused) and written.
pub fn plan_sweep(file: &Path, out: &Path) -> Result<Plan, SweepError> {
    let (spec, text) = SweepSpec::load(file)?;
    let fname = file.display().to_string();
    for (field, paths) in [
        ("collect", &spec.collect),
        ("plot_against", &spec.plot_against),
    ] {
        for (i, p) in paths.iter().enumerate() {
            check_quantity_path(p).map_err(|why| SweepError::Spec {
                file: fname.clone(),
                at: locate(&text, &format!("\"{p}\"")),
                field: format!("{field}[{i}] ({p})"),
                why,
            })?;
        }
    }
    let rows = spec.members(&fname, &text)?;
    let base = load_base(file, &spec, &text)?;
    let paths: Vec<&str> = spec.vary.iter().map(|v| v.path.as_str()).collect();
    let sweep_name = file
        .file_name()
        .map_or(fname.clone(), |n| n.to_string_lossy().into_owned());
    let header = |id: usize, sets: &[String]| {
        format!(
            "// hydrofrac sweep {sweep_name}, member {id}: {} with --set {}\n",
            spec.base.display(),
            sets.join(" --set ")
        )
    };
    let resolved: Vec<Result<(Vec<String>, Resolved), SweepError>> = rows
        .par_iter()
        .enumerate()
        .map(|(id, row)| {
            let sets: Vec<String> = paths
                .iter()
                .zip(row)
                .map(|(p, v)| format!("{p}={}", value_text(v)))
                .collect();
            // The entry the error names (the first one when it names none).
            let member_err = |why: String| SweepError::Member {
                file: fname.clone(),
                at: locate(&text, &format!("\"{}\"", blamed(&paths, &why))),
                member: id,
                sets: sets.join(" "),
                why,
            };
            let r = resolve(&base, &sets, &header(id, &sets)).map_err(member_err)?;
            Ok((sets, r))
        })
        .collect();
    let width = (rows.len().saturating_sub(1)).to_string().len().max(4);
    let mut members = Vec::with_capacity(rows.len());
    let mut files = Vec::with_capacity(rows.len());
    for (id, (r, values)) in resolved.into_iter().zip(rows).enumerate() {
        let (set, r) = r?;
        members.push(MemberPlan {
            id,
            dir: format!("members/{id:0width$}"),
            set,
            values,
            fingerprint: format!("{:016x}", r.fingerprint),
        });
        files.push(r.files);
    }
    let plan = Plan {
        version: PLAN_VERSION,
        sweep: sweep_name.clone(),
        base: spec.base.display().to_string(),
        kind: spec.kind,
        inputs: paths.iter().map(|p| p.to_string()).collect(),
        collect: spec.collect.clone(),
        plot_against: spec.plot_against.clone(),
        pool: spec.pool.clone(),
        members,
    };
    write_plan(out, &plan, &files, &text)?;
    Ok(plan)
}

/// The varied path an error message names (the longest one it holds), else the first.
fn blamed<'a>(paths: &[&'a str], why: &str) -> &'a str {
    paths
        .iter()
        .filter(|p| why.contains(*p))
        .max_by_key(|p| p.len())
        .unwrap_or(&paths[0])
}

/// Load the base file (relative to the sweep file): the scenario, or the pipeline with its
/// stimulation scenario. File paths inside become absolute, so members run from anywhere.
fn load_base(file: &Path, spec: &SweepSpec, text: &str) -> Result<Base, SweepError> {
    let dir = file.parent().unwrap_or(Path::new(""));
    let base_err = |why: String| SweepError::Spec {
        file: file.display().to_string(),
        at: locate(text, "base"),
        field: "base".into(),
        why,
    };
    let path = std::fs::canonicalize(dir.join(&spec.base)).map_err(|e| {
        base_err(format!(
            "cannot read {}: {e}",
            dir.join(&spec.base).display()
        ))
    })?;
    match spec.kind {
        BaseKind::Scenario => {
            let sc = Scenario::load(&path, &[]).map_err(|e| base_err(e.to_string()))?;
            Ok(Base::Scenario(Box::new(sc.into_inner())))
        }
        BaseKind::Pipeline => {
            let p = PipelineSpec::load(&path).map_err(|e| base_err(e.to_string()))?;
            let stim = Scenario::load(&p.stimulation, &p.stimulation_set)
                .map_err(|e| base_err(format!("its stimulation: {e}")))?;
            Ok(Base::Pipeline(Box::new((p, stim.into_inner()))))
        }
    }
}

/// Resolve one member: the base with its overrides, validated, written as RON and read back
/// to the same scenario (the member runs exactly what was validated).
fn resolve(base: &Base, sets: &[String], header: &str) -> Result<Resolved, String> {
    match base {
        Base::Scenario(sc) => {
            let (text, fingerprint) = resolve_scenario(sc, sets, header)?;
            Ok(Resolved {
                files: vec![("scenario.ron", text)],
                fingerprint,
            })
        }
        Base::Pipeline(b) => {
            let (p, stim) = &**b;
            let (stim_sets, own): (Vec<String>, Vec<String>) = sets
                .iter()
                .cloned()
                .partition(|s| s.starts_with("stimulation."));
            let stim_sets: Vec<String> = stim_sets
                .iter()
                .map(|s| s["stimulation.".len()..].to_string())
                .collect();
            let (stim_text, stim_fp) = resolve_scenario(stim, &stim_sets, header)?;
            let mut root = serde_json::to_value(p).map_err(|e| e.to_string())?;
            for s in &own {
                set_json(&mut root, s)?;
            }
            let mut spec: PipelineSpec =
                read_pipeline_json(root).map_err(|e| format!("--set {}: {e}", own.join(" ")))?;
            spec.stimulation = PathBuf::from("stimulation.ron");
            spec.stimulation_set.clear();
            spec.validate().map_err(|e| e.to_string())?;
            let text = header.to_string() + &to_ron(&spec)?;
            let mut named = spec.clone();
            named.name.clear();
            let key = format!(
                "{stim_fp:016x}{}",
                serde_json::to_string(&named).unwrap_or_default()
            );
            Ok(Resolved {
                files: vec![("pipeline.ron", text), ("stimulation.ron", stim_text)],
                fingerprint: crate::checkpoint::fnv1a(key.as_bytes()),
            })
        }
    }
}

/// A scenario with `sets` applied and validated, as RON text (after `header`), checked to read
/// back to the same scenario; with its fingerprint.
fn resolve_scenario(sc: &Scenario, sets: &[String], header: &str) -> Result<(String, u64), String> {
    let valid = sc
        .with_overrides(sets)
        .and_then(Scenario::validate)
        .map_err(|e| e.to_string())?;
    let text = header.to_string() + &to_ron(&*valid)?;
    let back = Scenario::parse(&text, "resolved member").map_err(|e| e.to_string())?;
    if serde_json::to_value(&back).ok() != serde_json::to_value(&*valid).ok() {
        return Err(
            "the resolved scenario does not read back as written (a value RON cannot \
                    hold exactly)"
                .into(),
        );
    }
    Ok((text, crate::checkpoint::fingerprint(&valid, &[])))
}

/// `x` as pretty RON.
fn to_ron<T: Serialize>(x: &T) -> Result<String, String> {
    let cfg = ron::ser::PrettyConfig::new().indentor("  ".to_string());
    ron::ser::to_string_pretty(x, cfg)
        .map(|s| s + "\n")
        .map_err(|e| format!("cannot write it as RON: {e}"))
}

/// Read a pipeline file's JSON back, naming the field a value fails at.
fn read_pipeline_json(root: Value) -> Result<PipelineSpec, String> {
    serde_json::from_value(root).map_err(|e| e.to_string())
}

/// Apply one `PATH=VALUE` to a pipeline file's JSON (tables only; VALUE read as JSON, else a
/// string).
fn set_json(root: &mut Value, spec: &str) -> Result<(), String> {
    let (path, value) = spec
        .split_once('=')
        .ok_or_else(|| format!("--set {spec}: expected PATH=VALUE"))?;
    let value = serde_json::from_str(value.trim())
        .unwrap_or_else(|_| Value::String(value.trim().to_string()));
    let mut node = root;
    for key in path.split('.') {
        let obj = node
            .as_object_mut()
            .ok_or_else(|| format!("--set {spec}: `{key}` is not in a table"))?;
        if !obj.contains_key(key) {
            let mut valid: Vec<&String> = obj.keys().collect();
            valid.sort();
            let valid: Vec<&str> = valid.into_iter().map(|s| s.as_str()).collect();
            return Err(format!(
                "--set {spec}: no field `{key}` here; fields: {}",
                valid.join(", ")
            ));
        }
        node = obj.get_mut(key).expect("key exists");
    }
    *node = value;
    Ok(())
}

/// Check the folder (refusing a foreign one), remove what a previous plan there listed, and
/// write the sweep file's copy, the members' files and `plan.json` (last: a plan cut short
/// has none and does not run).
fn write_plan(
    out: &Path,
    plan: &Plan,
    files: &[Vec<(&'static str, String)>],
    sweep_text: &str,
) -> Result<(), SweepError> {
    let folder = FolderPlan::check(out, false)?.open()?;
    let io = |p: &Path, e: std::io::Error| SweepError::io(p, e);
    let p = folder.claim("sweep.ron").map_err(|e| io(out, e))?;
    std::fs::write(&p, sweep_text).map_err(|e| io(&p, e))?;
    for (m, fs) in plan.members.iter().zip(files) {
        for (name, text) in fs {
            let p = folder
                .claim(&format!("{}/{name}", m.dir))
                .map_err(|e| io(&out.join(&m.dir), e))?;
            std::fs::write(&p, text).map_err(|e| io(&p, e))?;
        }
    }
    let p = folder.claim(PLAN_FILE).map_err(|e| io(out, e))?;
    let json = serde_json::to_string_pretty(plan).map_err(|e| SweepError::io(&p, e))? + "\n";
    crate::output::write_atomic(&p, json.as_bytes()).map_err(|e| io(&p, e))
}
