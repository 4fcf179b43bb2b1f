//! `hydrofrac sweep slurm DIR`: a Slurm job array running `hydrofrac sweep member DIR ID` for
//! every member (`slurm/sweep.sbatch`, an output folder of its own; the tasks' output in
//! `slurm/logs/`), optionally submitted with `sbatch`.
//!
//! Slurm limits an array's indices to `MaxArraySize - 1` (1001 by default): a sweep of more
//! members gets one script per block of `max_array_size` members (`sweep-1.sbatch`, ...), each
//! task adding its block's offset to its index.

use super::{SweepError, read_plan};
use crate::output::folder::Folder;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Options of `hydrofrac sweep slurm`.
#[derive(Clone, Debug)]
pub struct SlurmOptions {
    /// `#SBATCH --partition`.
    pub partition: Option<String>,
    /// `#SBATCH --time` (Slurm's format: `MM`, `HH:MM:SS`, `D-HH`).
    pub time: Option<String>,
    /// At most this many members run at once (`--array=...%M`).
    pub max_parallel: Option<usize>,
    /// Members per array (Slurm's `MaxArraySize`, 1001 by default, less one).
    pub max_array_size: usize,
    /// The `hydrofrac` executable the tasks run (must be reachable from the compute nodes).
    pub exe: PathBuf,
    /// Submit the scripts with `sbatch`.
    pub submit: bool,
    /// With `submit`: `sbatch --wait` (return when the array has finished).
    pub wait: bool,
}

/// What [`write_slurm`] wrote and submitted.
#[derive(Clone, Debug, Default)]
pub struct SlurmReport {
    pub scripts: Vec<PathBuf>,
    /// `sbatch`'s output per submitted script (the job id).
    pub submitted: Vec<String>,
}

/// Write the job array scripts for the sweep in `dir` into `dir/slurm/` and, with `submit`,
/// submit them (in order; with `wait` each returns when its array has finished).
pub fn write_slurm(dir: &Path, opts: &SlurmOptions) -> Result<SlurmReport, SweepError> {
    let plan = read_plan(dir)?;
    let n = plan.members.len();
    if opts.max_parallel == Some(0) {
        return Err(SweepError::Other(
            "--max-parallel must be at least 1".into(),
        ));
    }
    if opts.max_array_size == 0 {
        return Err(SweepError::Other(
            "--max-array-size must be at least 1".into(),
        ));
    }
    for (name, v) in [("--partition", &opts.partition), ("--time", &opts.time)] {
        if let Some(v) = v
            && (v.is_empty()
                || !v
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_:,.".contains(c)))
        {
            return Err(SweepError::Other(format!(
                "{name} {v:?}: only letters, digits and - _ : , . are allowed"
            )));
        }
    }
    let abs = std::fs::canonicalize(dir).map_err(|e| SweepError::io(dir, e))?;
    let folder = Folder::prepare(&dir.join("slurm"), false)?;
    let logs = folder
        .claim("logs/.keep")
        .map_err(|e| SweepError::io(&folder.dir, e))?;
    std::fs::write(&logs, "").map_err(|e| SweepError::io(&logs, e))?;
    let blocks = n.div_ceil(opts.max_array_size);
    let mut report = SlurmReport::default();
    for b in 0..blocks {
        let (offset, size) = (
            b * opts.max_array_size,
            opts.max_array_size.min(n - b * opts.max_array_size),
        );
        let name = if blocks == 1 {
            "sweep.sbatch".to_string()
        } else {
            format!("sweep-{b}.sbatch")
        };
        let path = folder
            .claim(&name)
            .map_err(|e| SweepError::io(&folder.dir, e))?;
        let text = script(&abs, &plan.sweep, offset, size, opts);
        crate::output::write_atomic(&path, text.as_bytes())
            .map_err(|e| SweepError::io(&path, e))?;
        report.scripts.push(path);
    }
    if opts.submit {
        for s in &report.scripts {
            report.submitted.push(submit(s, opts.wait)?);
        }
    }
    Ok(report)
}

/// A shell word in single quotes.
fn quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', "'\\''"))
}

/// The sbatch script of members `offset .. offset + size`.
fn script(dir: &Path, sweep: &str, offset: usize, size: usize, opts: &SlurmOptions) -> String {
    let d = dir.display().to_string();
    let mut s = String::from("#!/bin/bash\n");
    let job: String = sweep
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    s += &format!("#SBATCH --job-name=hydrofrac-sweep-{job}\n");
    let par = opts.max_parallel.map_or(String::new(), |m| format!("%{m}"));
    s += &format!("#SBATCH --array=0-{}{par}\n", size - 1);
    s += "#SBATCH --ntasks=1\n#SBATCH --cpus-per-task=1\n";
    s += &format!("#SBATCH --output={d}/slurm/logs/member-%a-of-block-{offset}.out\n");
    if let Some(p) = &opts.partition {
        s += &format!("#SBATCH --partition={p}\n");
    }
    if let Some(t) = &opts.time {
        s += &format!("#SBATCH --time={t}\n");
    }
    s += &format!(
        "# hydrofrac sweep {sweep}: members {offset} to {}, one array task each; a finished\n\
         # member is skipped, an interrupted one continues from its checkpoint.\n",
        offset + size - 1
    );
    s += &format!(
        "exec {} sweep member {} \"$((SLURM_ARRAY_TASK_ID + {offset}))\" --quiet\n",
        quote(&opts.exe.display().to_string()),
        quote(&d)
    );
    s
}

/// `sbatch [--wait] SCRIPT`: its output (the job id line).
fn submit(script: &Path, wait: bool) -> Result<String, SweepError> {
    let mut cmd = Command::new("sbatch");
    if wait {
        cmd.arg("--wait");
    }
    let out = cmd
        .arg(script)
        .output()
        .map_err(|e| SweepError::Other(format!("cannot run sbatch: {e}")))?;
    let text = String::from_utf8_lossy(&out.stdout).trim().to_string();
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(SweepError::Other(format!(
            "sbatch {} failed ({}): {} {}",
            script.display(),
            out.status,
            crate::error::one_line(text.trim()),
            crate::error::one_line(err.trim())
        )));
    }
    Ok(text)
}
