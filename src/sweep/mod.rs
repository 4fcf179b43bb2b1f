//! Ensembles: `hydrofrac sweep` (`docs/sweep.md`). A sweep file names a base scenario (or
//! pipeline), the `--set` paths to vary with their values, and the quantities of interest to
//! collect from each member's `summary.json`. Stages, each its own command:
//!
//! 1. [`plan`]: every member's scenario resolved, validated and written into the sweep
//!    folder (`members/NNNN/scenario.ron`), with `plan.json` listing each member's values
//!    and fingerprint; planning twice gives the same bytes.
//! 2. [`run`]: one member = one ordinary run in `members/NNNN/run/` (the output-folder rules
//!    of `hydrofrac run`), its outcome in `members/NNNN/status.json`. The local runner spawns
//!    `hydrofrac sweep member DIR ID` per member, `--jobs` at a time, and skips finished
//!    members; [`slurm`] writes (and submits) a Slurm job array doing the same.
//! 3. [`collect`]: one table (CSV and JSON) of every member's inputs and quantities, the
//!    failed members with their errors, and figures, in `collect/`.
//!
//! The sweep folder's own files are listed in its `hydrofrac-manifest.txt` (written by the
//! plan); `collect/` and `slurm/` are output folders of their own, with their own manifests.

pub mod collect;
pub mod plan;
pub mod run;
pub mod slurm;
pub mod spec;

use crate::error::SetupError;
use crate::output::folder::FolderError;
use std::path::{Path, PathBuf};

pub use collect::{CollectOptions, CollectReport, collect, extract};
pub use plan::{MemberPlan, Plan, plan_sweep};
pub use run::{
    LocalOptions, MemberOutcome, MemberStatus, RunSummary, parse_members, read_status, run_local,
    run_member,
};
pub use slurm::{SlurmOptions, SlurmReport, write_slurm};
pub use spec::{BaseKind, Combine, SweepSpec, Values, Vary};

/// The plan's member list and values, in the sweep folder.
pub const PLAN_FILE: &str = "plan.json";
/// A member's outcome, in its folder.
pub const STATUS_FILE: &str = "status.json";
/// A member's run output folder, in its folder.
pub const RUN_DIR: &str = "run";
/// The version of `plan.json`'s layout.
pub const PLAN_VERSION: u32 = 1;

/// Why a sweep cannot be planned, run or collected. Every message is one line naming the
/// file (with line and column where the sweep file has them), the member or the folder.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The sweep file cannot be read or parsed (file:line:col: why (field)).
    #[error(transparent)]
    Parse(#[from] SetupError),
    /// A value of the sweep file that parses but makes no sweep.
    #[error("{file}{at}: {field}: {why}")]
    Spec {
        file: String,
        /// `:line:col` of the offending entry when it can be found, else empty.
        at: String,
        field: String,
        why: String,
    },
    /// A member whose scenario does not load or validate.
    #[error("{file}{at}: member {member} ({sets}): {why}")]
    Member {
        file: String,
        at: String,
        member: usize,
        sets: String,
        why: String,
    },
    #[error(transparent)]
    Folder(#[from] FolderError),
    #[error("{}: {why}", .path.display())]
    Io { path: PathBuf, why: String },
    /// Anything else about a sweep folder or a member (one line).
    #[error("{0}")]
    Other(String),
}

impl SweepError {
    pub(crate) fn io(path: &Path, e: impl std::fmt::Display) -> Self {
        SweepError::Io {
            path: path.to_path_buf(),
            why: e.to_string(),
        }
    }
}

/// Line and column (1-based) of the first occurrence of `needle` in `text`, as `:line:col`,
/// or an empty string when it is not there.
pub(crate) fn locate(text: &str, needle: &str) -> String {
    match text.find(needle) {
        Some(pos) => {
            let before = &text[..pos];
            let line = before.matches('\n').count() + 1;
            let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!(":{line}:{col}")
        }
        None => String::new(),
    }
}

/// Read a sweep folder's `plan.json` (written by [`plan_sweep`]).
pub fn read_plan(dir: &Path) -> Result<Plan, SweepError> {
    let path = dir.join(PLAN_FILE);
    if !dir.is_dir() {
        return Err(SweepError::Other(format!(
            "sweep folder {} does not exist (plan it with `hydrofrac sweep plan FILE --out {}`)",
            dir.display(),
            dir.display()
        )));
    }
    let text = std::fs::read_to_string(&path).map_err(|e| {
        SweepError::Other(format!(
            "{} is not a planned sweep folder: cannot read {PLAN_FILE}: {e}",
            dir.display()
        ))
    })?;
    let plan: Plan = serde_json::from_str(&text).map_err(|e| SweepError::io(&path, e))?;
    if plan.version != PLAN_VERSION {
        return Err(SweepError::io(
            &path,
            format!(
                "plan version {}, this hydrofrac reads version {PLAN_VERSION}: plan the sweep again",
                plan.version
            ),
        ));
    }
    Ok(plan)
}
