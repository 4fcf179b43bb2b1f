//! Running members: [`run_member`] (one member, `hydrofrac sweep member DIR ID`) and the local
//! runner [`run_local`] (`hydrofrac sweep run DIR --jobs N`), which spawns the first as a
//! process per member.
//!
//! A member runs as `hydrofrac run` (or `hydrofrac pipeline`) would, into its `run/` folder
//! (the same output-folder rules), and records its outcome in its `status.json`: `running`
//! while it runs, then `ok`, `failed` (with the error) or `interrupted`, with the fingerprint of
//! what it ran and its wall time. A member whose `status.json` says `ok` for the planned
//! fingerprint is finished: it is skipped. An interrupted member with a checkpoint in `run/`
//! (`output.checkpoint_every`) continues from it, bit for bit; one without starts again.

use super::{Plan, RUN_DIR, STATUS_FILE, SweepError, read_plan};
use crate::driver::{DriverError, RunOptions, run_file};
use crate::pipeline::{PipelineError, PipelineOptions, run_pipeline};
use crate::sim::StopFlag;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::{Deserialize, Serialize};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A member's `status.json`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
pub struct MemberStatus {
    pub member: usize,
    /// The fingerprint of the plan the member ran (`plan.json`).
    pub fingerprint: String,
    /// `running`, `ok`, `failed` or `interrupted`.
    pub status: String,
    /// Why it failed (one line).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Wall time of the member's run (this attempt), s.
    #[serde(default)]
    pub wall_s: f64,
    /// Whether this attempt continued from the member's checkpoint.
    #[serde(default)]
    pub restarted: bool,
}

impl MemberStatus {
    /// Whether this records a finished member of the planned fingerprint `fp`.
    pub fn is_done(&self, fp: &str) -> bool {
        self.status == "ok" && self.fingerprint == fp
    }
}

/// What [`run_member`] did.
#[derive(Clone, Debug, PartialEq)]
pub enum MemberOutcome {
    Ok,
    /// Finished before: not run again.
    AlreadyDone,
    Failed(String),
    /// Stopped by this signal (its outputs are finished; a checkpoint lets it continue).
    Interrupted(usize),
}

/// Read a member's `status.json`, if it has a readable one.
pub fn read_status(member_dir: &Path) -> Option<MemberStatus> {
    let text = std::fs::read_to_string(member_dir.join(STATUS_FILE)).ok()?;
    serde_json::from_str(&text).ok()
}

/// Write a member's `status.json`: an outcome atomically and synced, the `running` marker
/// (replaced when the member ends) plainly.
fn write_status(member_dir: &Path, s: &MemberStatus) -> Result<(), SweepError> {
    let path = member_dir.join(STATUS_FILE);
    let json = serde_json::to_string_pretty(s).expect("status serialises") + "\n";
    if s.status == "running" {
        std::fs::write(&path, json)
    } else {
        crate::output::write_atomic(&path, json.as_bytes())
    }
    .map_err(|e| SweepError::io(&path, e))
}

/// Run member `id` of the sweep in `dir` (unless it finished before): its scenario into its
/// `run/` folder, continuing from its checkpoint when it has one for the same fingerprint;
/// the outcome is written to its `status.json` and returned. `stop`: the binary's signal
/// flag, checked between steps. `exit_until_output`: the binary's flag that makes a signal end
/// the process at once, which the run clears before it creates its output folder
/// (`RunOptions::exit_until_output`): a signal during a long setup ends the member at once, its
/// `status.json` still `running` (the local runner then records it as interrupted).
pub fn run_member(
    dir: &Path,
    id: usize,
    stop: Option<StopFlag>,
    exit_until_output: Option<Arc<AtomicBool>>,
) -> Result<MemberOutcome, SweepError> {
    let plan = read_plan(dir)?;
    let m = plan.members.get(id).ok_or_else(|| {
        SweepError::Other(format!(
            "member {id}: the sweep in {} has {} members (0 to {})",
            dir.display(),
            plan.members.len(),
            plan.members.len().saturating_sub(1)
        ))
    })?;
    let mdir = dir.join(&m.dir);
    if read_status(&mdir).is_some_and(|s| s.is_done(&m.fingerprint)) {
        return Ok(MemberOutcome::AlreadyDone);
    }
    let out = mdir.join(RUN_DIR);
    let restart = checkpoint_for(&out, &m.fingerprint);
    let mut status = MemberStatus {
        member: id,
        fingerprint: m.fingerprint.clone(),
        status: "running".into(),
        error: None,
        wall_s: 0.0,
        restarted: restart.is_some(),
    };
    write_status(&mdir, &status)?;
    let t0 = Instant::now();
    let file = mdir.join(plan.member_file());
    let mut outcome = run_one(
        &plan,
        &file,
        &out,
        restart.clone(),
        stop.clone(),
        exit_until_output.clone(),
    );
    if restart.is_some() && matches!(&outcome, Err(Restart::Refused)) {
        // A checkpoint the run cannot use (cut short while written): start again.
        status.restarted = false;
        outcome = run_one(&plan, &file, &out, None, stop, exit_until_output);
    }
    let outcome = match outcome {
        Ok(o) => o,
        Err(Restart::Refused) => MemberOutcome::Failed("its checkpoint was refused".into()),
        Err(Restart::Failed(e)) => MemberOutcome::Failed(e),
    };
    status.wall_s = t0.elapsed().as_secs_f64();
    (status.status, status.error) = match &outcome {
        MemberOutcome::Ok | MemberOutcome::AlreadyDone => ("ok".into(), None),
        MemberOutcome::Failed(e) => ("failed".into(), Some(e.clone())),
        MemberOutcome::Interrupted(sig) => (
            "interrupted".into(),
            Some(format!(
                "interrupted by {}",
                crate::driver::signal_name(*sig)
            )),
        ),
    };
    write_status(&mdir, &status)?;
    Ok(outcome)
}

/// Why [`run_one`] did not give an outcome.
enum Restart {
    /// The checkpoint was refused (run again without it).
    Refused,
    Failed(String),
}

/// Run the member's file into `out`: a scenario as `hydrofrac run --quiet`, a pipeline as
/// `hydrofrac pipeline --quiet`.
fn run_one(
    plan: &Plan,
    file: &Path,
    out: &Path,
    restart: Option<PathBuf>,
    stop: Option<StopFlag>,
    exit_until_output: Option<Arc<AtomicBool>>,
) -> Result<MemberOutcome, Restart> {
    let line = |e: &dyn std::fmt::Display| crate::error::one_line(&e.to_string()).into_owned();
    match plan.kind {
        super::BaseKind::Scenario => {
            let opts = RunOptions {
                out: Some(out.to_path_buf()),
                quiet: true,
                stop,
                restart,
                exit_until_output,
                ..Default::default()
            };
            match run_file(file, &opts) {
                Ok(r) => Ok(r
                    .interrupted_by
                    .map_or(MemberOutcome::Ok, MemberOutcome::Interrupted)),
                Err(DriverError::Checkpoint(_)) => Err(Restart::Refused),
                Err(e) => Err(Restart::Failed(line(&e))),
            }
        }
        super::BaseKind::Pipeline => {
            let opts = PipelineOptions {
                out: Some(out.to_path_buf()),
                quiet: true,
                force: false,
                stop,
                exit_until_output,
            };
            match run_pipeline(file, &opts) {
                Ok(_) => Ok(MemberOutcome::Ok),
                Err(PipelineError::Interrupted { signal, .. }) => {
                    Ok(MemberOutcome::Interrupted(signal))
                }
                Err(e) => Err(Restart::Failed(line(&e))),
            }
        }
    }
}

/// The member's checkpoint in its run folder, when there is one written for its fingerprint.
fn checkpoint_for(out: &Path, fingerprint: &str) -> Option<PathBuf> {
    let path = out.join(crate::checkpoint::FILE);
    if !path.is_file() {
        return None;
    }
    let fp = u64::from_str_radix(fingerprint, 16).ok()?;
    let (header, _) = crate::checkpoint::read(&path).ok()?;
    (header.fingerprint == fp).then_some(path)
}

/// What the local runner did.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    pub total: usize,
    /// Finished before (not run again).
    pub skipped: usize,
    /// Failed before and not retried.
    pub skipped_failed: usize,
    /// Run now and finished.
    pub ok: usize,
    /// Run now and failed: (member, error).
    pub failed: Vec<(usize, String)>,
    /// Not run (or not finished) because a signal stopped the runner.
    pub not_run: usize,
    /// Left out by `--members`.
    pub not_selected: usize,
    pub interrupted_by: Option<usize>,
}

/// Options of the local runner.
#[derive(Clone, Debug)]
pub struct LocalOptions {
    /// Members run at a time.
    pub jobs: usize,
    /// Run members that failed before again (else they are skipped).
    pub retry_failed: bool,
    pub quiet: bool,
    /// The runner's signal flag: no member starts after it is set, and running ones are sent
    /// SIGTERM (they finish as interrupted, with their checkpoint).
    pub stop: Option<StopFlag>,
    /// The `hydrofrac` executable each member runs in.
    pub exe: PathBuf,
    /// Run only these members, in this order (`--members`, [`parse_members`]); `None`: all,
    /// in plan order.
    pub members: Option<String>,
    /// Threads each member's process uses (`RAYON_NUM_THREADS` in its environment); `None`:
    /// the member's own default (every CPU). Results are the same bits for any count.
    pub threads: Option<usize>,
}

/// Parse a `--members` list: ids and ranges separated by commas, `A-B` from A to B inclusive
/// (descending when A > B), e.g. `95-60,3`. Each id below `total`, none twice.
pub fn parse_members(spec: &str, total: usize) -> Result<Vec<usize>, String> {
    let mut out = Vec::new();
    let mut seen = vec![false; total];
    for part in spec.split(',').map(str::trim) {
        let id = |t: &str| -> Result<usize, String> {
            let k: usize = t
                .trim()
                .parse()
                .map_err(|_| format!("`{t}` in `{part}` is not a member id"))?;
            if k >= total {
                return Err(format!(
                    "member {k} does not exist (the plan has members 0 to {})",
                    total.saturating_sub(1)
                ));
            }
            Ok(k)
        };
        let ids: Vec<usize> = match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (id(a)?, id(b)?);
                if a <= b {
                    (a..=b).collect()
                } else {
                    (b..=a).rev().collect()
                }
            }
            None if part.is_empty() => return Err("an empty entry".into()),
            None => vec![id(part)?],
        };
        for k in ids {
            if std::mem::replace(&mut seen[k], true) {
                return Err(format!("member {k} is listed twice"));
            }
            out.push(k);
        }
    }
    Ok(out)
}

/// Run the sweep in `dir` on this machine: every member not finished, `jobs` at a time, each
/// as `EXE sweep member DIR ID --quiet` (its output in its folder's `log.txt`), with a
/// progress bar over the members. A failed member does not stop the others.
pub fn run_local(dir: &Path, opts: &LocalOptions) -> Result<RunSummary, SweepError> {
    let plan = read_plan(dir)?;
    let mut summary = RunSummary {
        total: plan.members.len(),
        ..Default::default()
    };
    let mut pending = Vec::new();
    let order: Vec<usize> = match &opts.members {
        Some(spec) => {
            let list = parse_members(spec, plan.members.len())
                .map_err(|why| SweepError::Other(format!("--members {spec}: {why}")))?;
            summary.not_selected = plan.members.len() - list.len();
            list
        }
        None => (0..plan.members.len()).collect(),
    };
    for m in order.iter().map(|&k| &plan.members[k]) {
        match read_status(&dir.join(&m.dir)) {
            Some(s) if s.is_done(&m.fingerprint) => summary.skipped += 1,
            Some(s)
                if s.status == "failed" && s.fingerprint == m.fingerprint && !opts.retry_failed =>
            {
                summary.skipped_failed += 1
            }
            _ => pending.push(m.id),
        }
    }
    let selected = summary.total - summary.not_selected;
    let bar = runner_bar(opts.quiet, selected as u64);
    bar.set_position((selected - pending.len()) as u64);
    // Without a terminal (a log file, `nohup`, a batch job) the bar is not drawn: one line
    // per member instead.
    let log_lines = !opts.quiet && !std::io::stderr().is_terminal();
    let done = AtomicUsize::new(selected - pending.len());
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, MemberOutcome)>> = Mutex::new(Vec::new());
    let spawn_error: Mutex<Option<SweepError>> = Mutex::new(None);
    let stopped = || {
        opts.stop
            .as_ref()
            .is_some_and(|s| s.load(Ordering::Relaxed) != 0)
    };
    std::thread::scope(|scope| {
        for _ in 0..opts.jobs.max(1).min(pending.len().max(1)) {
            scope.spawn(|| {
                while !stopped() {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&id) = pending.get(k) else { break };
                    let m = &plan.members[id];
                    let t0 = std::time::Instant::now();
                    match spawn_member(dir, id, &m.dir, &m.fingerprint, opts) {
                        Ok(o) => {
                            if let MemberOutcome::Failed(e) = &o {
                                bar.println(format!("member {id} failed: {e}"));
                            }
                            if log_lines {
                                let what = match &o {
                                    MemberOutcome::Ok => "ok",
                                    MemberOutcome::AlreadyDone => "finished before",
                                    MemberOutcome::Failed(_) => "failed",
                                    MemberOutcome::Interrupted(_) => "interrupted",
                                };
                                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                                eprintln!(
                                    "member {id}: {what} in {:.0} s ({n} of {} members done)",
                                    t0.elapsed().as_secs_f64(),
                                    selected
                                );
                            }
                            results.lock().expect("results").push((id, o));
                        }
                        Err(e) => {
                            *spawn_error.lock().expect("error") = Some(e);
                            break;
                        }
                    }
                    bar.inc(1);
                }
            });
        }
    });
    bar.finish_and_clear();
    if let Some(e) = spawn_error.into_inner().expect("error") {
        return Err(e);
    }
    let mut results = results.into_inner().expect("results");
    results.sort_by_key(|r| r.0);
    for (id, o) in results {
        match o {
            MemberOutcome::Ok | MemberOutcome::AlreadyDone => summary.ok += 1,
            MemberOutcome::Failed(e) => summary.failed.push((id, e)),
            MemberOutcome::Interrupted(_) => summary.not_run += 1,
        }
    }
    summary.not_run += pending
        .len()
        .saturating_sub(next.load(Ordering::Relaxed).min(pending.len()));
    summary.interrupted_by = opts
        .stop
        .as_ref()
        .map(|s| s.load(Ordering::Relaxed))
        .filter(|&s| s != 0);
    Ok(summary)
}

/// Run one member as a child process and read its outcome from its `status.json` (a child
/// that ended without one is recorded there as failed, with how it ended).
fn spawn_member(
    dir: &Path,
    id: usize,
    rel: &str,
    fingerprint: &str,
    opts: &LocalOptions,
) -> Result<MemberOutcome, SweepError> {
    let mdir = dir.join(rel);
    let log_path = mdir.join("log.txt");
    let log = std::fs::File::create(&log_path).map_err(|e| SweepError::io(&log_path, e))?;
    let log2 = log.try_clone().map_err(|e| SweepError::io(&log_path, e))?;
    let mut cmd = Command::new(&opts.exe);
    if let Some(t) = opts.threads {
        cmd.env("RAYON_NUM_THREADS", t.to_string());
    }
    let mut child = cmd
        .args(["sweep", "member"])
        .arg(dir)
        .arg(id.to_string())
        .arg("--quiet")
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(log2)
        .spawn()
        .map_err(|e| SweepError::io(&opts.exe, format!("cannot start a member: {e}")))?;
    let mut signalled = false;
    let exit = loop {
        match child.try_wait() {
            Ok(Some(st)) => break st,
            Ok(None) => {}
            Err(e) => return Err(SweepError::io(&opts.exe, e)),
        }
        let sig = opts.stop.as_ref().map_or(0, |s| s.load(Ordering::Relaxed));
        if sig != 0 && !signalled {
            // Forward the runner's signal: the member finishes as interrupted.
            // SAFETY: kill(2) on our own child's pid, with a valid signal number.
            unsafe { libc::kill(child.id() as libc::pid_t, sig as libc::c_int) };
            signalled = true;
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    match read_status(&mdir) {
        Some(s) if s.fingerprint == fingerprint && s.status != "running" => {
            Ok(match s.status.as_str() {
                "ok" => MemberOutcome::Ok,
                "interrupted" => MemberOutcome::Interrupted(exit_signal(&exit)),
                _ => MemberOutcome::Failed(s.error.unwrap_or_default()),
            })
        }
        prev => {
            // Signalled by the runner before it recorded an outcome: it ended at once during
            // its setup (nothing written in its run folder yet), so interrupted, not failed.
            let in_setup = signalled && prev.as_ref().is_none_or(|s| s.status == "running");
            let (status, error, outcome) = if in_setup {
                let sig = exit_signal(&exit);
                let why = format!(
                    "interrupted by {} during its setup",
                    crate::driver::signal_name(sig)
                );
                ("interrupted", why, MemberOutcome::Interrupted(sig))
            } else {
                let why = format!(
                    "the member process ended ({exit}) without recording its outcome; its output is in {}",
                    log_path.display()
                );
                ("failed", why.clone(), MemberOutcome::Failed(why))
            };
            let status = MemberStatus {
                member: id,
                fingerprint: fingerprint.to_string(),
                status: status.into(),
                error: Some(error),
                wall_s: prev.map_or(0.0, |p| p.wall_s),
                restarted: false,
            };
            write_status(&mdir, &status)?;
            Ok(outcome)
        }
    }
}

/// The signal a member's exit status reports (128 + N), else SIGTERM's number.
fn exit_signal(exit: &std::process::ExitStatus) -> usize {
    use std::os::unix::process::ExitStatusExt;
    exit.signal()
        .or(exit.code().filter(|c| *c > 128).map(|c| c - 128))
        .map_or(15, |s| s as usize)
}

fn runner_bar(quiet: bool, total: u64) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} members (eta {eta})",
        )
        .expect("template"),
    );
    bar.enable_steady_tick(Duration::from_millis(250));
    bar
}
