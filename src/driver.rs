//! `hydrofrac run`: load a scenario, run it with per-system timing, write the outputs.

use crate::error::SetupError;
use crate::output::folder::{FolderError, Plan};
use crate::output::{Outputs, write_atomic};
use crate::scenario::Scenario;
use crate::schedule::Status;
use crate::sim::{Finish, Simulation};
use crate::systems::RunError;
use crate::timing::{TimingLayer, format_table};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tracing_subscriber::layer::SubscriberExt;

/// Options of `hydrofrac run`.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Output folder (default `out/<scenario name>`).
    pub out: Option<PathBuf>,
    pub disable: Vec<String>,
    pub set: Vec<String>,
    /// Write a Chrome/Perfetto trace here.
    pub trace: Option<PathBuf>,
    pub quiet: bool,
    /// Write into a non-empty folder that has no manifest (nothing in it is deleted; files
    /// with the names the run writes are overwritten). See [`crate::output::folder`].
    pub force: bool,
    /// Stop between steps when this is set (the binary's SIGINT/SIGTERM handlers): the run
    /// ends as `interrupted` with its outputs finished ([`Simulation::set_stop`]).
    pub stop: Option<crate::sim::StopFlag>,
    /// Refuse a scenario whose mesh and network need more memory than this, bytes (estimated
    /// before anything is allocated, [`crate::resources`]). Default: the machine's memory.
    pub max_memory: Option<u64>,
    /// Refuse a run whose outputs (frames, time series, figures) would take more than this,
    /// bytes (estimated after setup, before anything is written, [`crate::resources::check_disk`]).
    /// Default: the free space of the output folder's disk.
    pub max_disk: Option<u64>,
    /// Continue from this checkpoint ([`crate::checkpoint`]): it must have been written for
    /// the same scenario, `set` overrides and `disable` list.
    pub restart: Option<PathBuf>,
}

/// What a finished run reports.
#[derive(Debug)]
pub struct RunReport {
    pub out: PathBuf,
    pub summary: serde_json::Value,
    pub timing_table: String,
    /// The signal number that stopped the run between steps, if one did (`summary.json`
    /// `status` is then `interrupted`).
    pub interrupted_by: Option<usize>,
    /// The fracture network (cells, apertures) at the start and at the end of the run, for a
    /// scene with fractures (the reservoir pipeline's before and after).
    pub networks: Option<[crate::flow::FlowView; 2]>,
    /// Bounding box of the rock mesh in reference positions, `[xmin, xmax, ymin, ymax]` m.
    pub mesh_box: [f64; 4],
    /// The joints' residual hydraulic aperture, m.
    pub residual_aperture: f64,
}

/// The name of a signal number the run may be stopped by: `SIGINT`, `SIGTERM`, else
/// `signal N`.
pub fn signal_name(sig: usize) -> String {
    match sig {
        2 => "SIGINT".into(),
        15 => "SIGTERM".into(),
        n => format!("signal {n}"),
    }
}

/// Errors of a run, with the output folder when one was prepared (earlier outputs stay there).
#[derive(Debug, thiserror::Error)]
pub enum DriverError {
    #[error(transparent)]
    Setup(#[from] SetupError),
    #[error("{error} (outputs written so far are in {out})")]
    Run { error: RunError, out: String },
    #[error("{0}")]
    Output(std::io::Error),
    #[error(transparent)]
    Folder(#[from] FolderError),
    #[error(transparent)]
    Checkpoint(#[from] crate::checkpoint::CheckpointError),
    /// Boxed: a production error carries a run error, and every `Result` of the driver would
    /// grow with it.
    #[error(transparent)]
    Production(Box<crate::production_stage::ProductionError>),
    #[error("--trace {}: {why}", .path.display())]
    Trace { path: PathBuf, why: String },
}

/// Run a scenario file.
pub fn run_file(path: &Path, opts: &RunOptions) -> Result<RunReport, DriverError> {
    let scenario = Scenario::load(path, &opts.set)?;
    run_scenario(scenario, opts)
}

/// Run a parsed scenario.
pub fn run_scenario(scenario: Scenario, opts: &RunOptions) -> Result<RunReport, DriverError> {
    let out = opts
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scenario.name));
    let (limit, source) = match opts.max_memory {
        Some(b) => (b, "set by --max-memory"),
        None => crate::resources::default_limit(),
    };
    scenario.validate()?;
    crate::resources::check(&scenario, limit, source)?;
    let mut sim = Simulation::new(scenario, &opts.disable)?;
    let start_network = network_now(&sim);
    // Read and checked before the output folder is touched: a refused checkpoint leaves it
    // as it was (and a checkpoint inside it can be restarted from into the same folder).
    let restarted_from = match &opts.restart {
        Some(path) => {
            let (header, state) = crate::checkpoint::read(path)?;
            crate::checkpoint::check_scenario(path, &header, sim.scenario(), &opts.disable)?;
            sim.restore(state)
                .map_err(|why| crate::checkpoint::CheckpointError::Refused {
                    path: path.display().to_string(),
                    why,
                })?;
            if sim.quasi_static_counts().is_some() {
                tracing::warn!(
                    "quasi-static restart: the solver's factor is rebuilt, so the run continues \
                     to the solver's tolerance, not bit for bit"
                );
            }
            Some((path.display().to_string(), header.step, header.time))
        }
        None => None,
    };
    if let Some(stop) = &opts.stop {
        sim.set_stop(stop.clone());
    }
    let (disk_limit, disk_source) = match opts.max_disk {
        Some(b) => (b, "set by --max-disk".to_string()),
        None => crate::resources::default_disk_limit(&out),
    };
    let disk = crate::resources::check_disk(&output_plan(&sim), disk_limit, &disk_source)?;
    // Every path is checked before anything in the folder is removed or written.
    let mut plan = Plan::check(&out, opts.force)?;
    plan.require_folder("frames")?;
    let trace = match &opts.trace {
        Some(path) => Some(open_trace(path, &mut plan)?),
        None => None,
    };
    let folder = plan.open()?;
    let trace = match trace {
        Some((file, rel)) => {
            if let Some(rel) = &rel {
                folder.claim(rel).map_err(DriverError::Output)?;
            }
            Some(truncate(file).map_err(DriverError::Output)?)
        }
        None => None,
    };
    let outputs = Outputs::new(folder, &sim.params().output.fields, &sim.series_columns())
        .map_err(DriverError::Output)?;
    // Figures or tables that were not written (the run goes on): summary.json `warnings`.
    let mut warnings: Vec<String> = Vec::new();
    const NOT_FINITE: &str = "not written: the table has non-finite values";
    if let Some(f) = sim.flow()
        && !outputs
            .write_fractures_csv(&f.network.fractures)
            .map_err(DriverError::Output)?
    {
        warnings.push(format!("network_generated.csv {NOT_FINITE}"));
    }
    if let Some(w) = zigzag_warning(sim.placed()) {
        tracing::warn!("{w}");
        warnings.push(w);
    }
    if !sim.placed().is_empty()
        && !outputs
            .write_preexisting_csv(sim.placed())
            .map_err(DriverError::Output)?
    {
        warnings.push(format!("preexisting_fractures.csv {NOT_FINITE}"));
    }
    sim.set_output(outputs);

    let timing = TimingLayer::default();
    let table = timing.table.clone();
    let trace_error = TraceError::default();
    let (chrome, _guard) = match trace {
        Some(file) => {
            let (layer, guard) = tracing_chrome::ChromeLayerBuilder::new()
                .writer(TraceWriter {
                    file,
                    error: trace_error.clone(),
                })
                .include_args(true)
                .build();
            (Some(layer), Some(guard))
        }
        None => (None, None),
    };
    let subscriber = tracing_subscriber::registry().with(timing).with(chrome);

    let bar = progress_bar(opts.quiet);
    let t0 = Instant::now();
    let result = tracing::subscriber::with_default(subscriber, || {
        sim.run(|s| {
            bar.set_position(progress_position(s));
            bar.set_message(format!(
                "t = {:.4e} s  residual {:.2e}",
                s.time(),
                s.residual()
            ));
        })
    });
    let wall = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    drop(_guard);

    let times = table.lock().expect("timing table").clone();
    let rows: Vec<(String, bool, u64, f64)> = sim
        .schedule()
        .entries
        .iter()
        .map(|(s, st)| {
            let t = times.get(s.name()).copied().unwrap_or_default();
            (
                s.name().to_string(),
                *st == Status::Enabled,
                t.calls,
                t.total.as_secs_f64(),
            )
        })
        .collect();
    let timing_table = format_table(&rows);
    let mut summary = summary_json(&sim, &result, wall, &rows);
    if let Some(sig) = sim.interrupted_by() {
        summary["status"] = json!("interrupted");
        summary["reason"] = json!(format!(
            "interrupted by {} at the end of step {}",
            signal_name(sig),
            sim.step()
        ));
    }
    if let Some(c) = sim.quasi_static_counts() {
        summary["quasi_static"] = json!(c);
    }
    if result.is_ok() && sim.interrupted_by().is_none() && sim.params().has_fractures {
        summary["tips"] = tips_summary(&mut sim);
    }
    summary["output_estimate_bytes"] = json!(disk.total);
    if sim.params().output.checkpoint_every.is_some() {
        summary["checkpoints"] = json!(sim.checkpoint_stats());
    }
    if let Some((path, step, time)) = restarted_from {
        // The quasi-static solver's factor is rebuilt at the restart (not in the checkpoint):
        // that run continues to the solver's tolerance, every other one bit for bit.
        let exact = sim.quasi_static_counts().is_none();
        summary["restarted_from"] =
            json!({"file": path, "step": step, "time": time, "bit_identical": exact});
    }
    if let (Some(v), Some(o)) = (sim.fracture_view(), sim.output()) {
        if !o.write_network_csv(&v).map_err(DriverError::Output)? {
            warnings.push(format!("network.csv {NOT_FINITE}"));
        }
        let length: f64 = v.length.iter().sum();
        summary["fractures"] = json!({"cells": v.n_cells(), "total_length": length,
            "new_cells": v.kind.iter().filter(|k| **k == crate::components::CellKind::New).count()});
        if let Err(e) =
            crate::output::plots::fracture_figure(&sim.params().name, sim.time(), &v, o.folder())
        {
            warnings.push(format!("figures not written: {e}"));
        }
        // The seed's Fig. 7 view: the mesh with apertures magnified 20x, coloured by the
        // prescribed face pressure (zero without one).
        let mut v = v;
        let p = sim.params().face_pressure.unwrap_or(0.0);
        v.pressure.iter_mut().for_each(|x| *x = p);
        let title = format!(
            "{}: fractures, apertures x20, t = {:.4} s",
            sim.params().name,
            sim.time()
        );
        if let Err(e) = crate::output::plots::fracture_pressure_figure(
            &o.claim("fractures_mesh.png").map_err(DriverError::Output)?,
            &title,
            sim.solid(),
            &v,
            20.0,
            None,
        ) {
            warnings.push(format!("figures not written: {e}"));
        }
    }
    if sim.flow().is_some_and(|f| f.coupling.is_some()) {
        if let Some(o) = sim.output() {
            o.claim("fractures_pressure.png")
                .map_err(DriverError::Output)?;
        }
        sim.fracture_pressure_figure("fractures_pressure.png");
        let f = sim.flow().expect("coupled");
        let length: f64 = f.view.length.iter().sum();
        summary["fractures"] = json!({"cells": f.view.n_cells(), "total_length": length,
            "new_cells": f.view.kind.iter().filter(|k| **k == crate::components::CellKind::New).count(),
            "max_aperture": f.view.aperture.iter().fold(0.0f64, |a, &b| a.max(b))});
    }
    if let (Some(f), Some(o)) = (sim.flow(), sim.output()) {
        if !o.write_network_csv(&f.view).map_err(DriverError::Output)? {
            warnings.push(format!("network.csv {NOT_FINITE}"));
        }
        if let Err(e) =
            crate::output::plots::flow_figures(&f.view, sim.params(), sim.time(), o.folder())
        {
            warnings.push(format!("figures not written: {e}"));
        }
    }
    // The production stage (`production:`): before and after the run, after a run that ended.
    let mut production_error = None;
    let mut production_interrupted = None;
    if result.is_ok()
        && sim.interrupted_by().is_none()
        && let Some(stage) = sim.scenario().production.clone()
    {
        let t = Instant::now();
        let end = sim
            .checkpoint_state()
            .map_err(|e| DriverError::Output(std::io::Error::other(format!("production: {e}"))))?
            .1;
        let bar = production_bar(opts.quiet);
        // The before and the after states run side by side: the spinner shows the latest
        // message of each.
        let lines = std::sync::Mutex::new([String::new(), String::new()]);
        let solved = crate::production_stage::run_production(
            sim.scenario(),
            end,
            opts.stop.as_ref(),
            &|m: &str| {
                let mut l = lines.lock().unwrap_or_else(|e| e.into_inner());
                l[usize::from(m.starts_with("production after"))] = m.to_string();
                let shown: Vec<&str> = l
                    .iter()
                    .filter(|x| !x.is_empty())
                    .map(|x| x.as_str())
                    .collect();
                bar.set_message(shown.join("\n  "));
            },
        );
        bar.finish_and_clear();
        let stage_result = match solved {
            Ok(x) => x,
            Err(crate::production_stage::ProductionError::Interrupted(sig)) => {
                // Stopped between two steps of an equilibrium: the run's outputs are complete,
                // the production table is not written.
                summary["status"] = json!("interrupted");
                summary["reason"] = json!(format!(
                    "interrupted by {} during the production stage, after {:.1} s of it",
                    signal_name(sig),
                    t.elapsed().as_secs_f64()
                ));
                summary["production"] = json!({"interrupted": true});
                production_interrupted = Some(sig);
                Default::default()
            }
            Err(e) => {
                summary["production"] = json!({"error": e.to_string()});
                production_error = Some(e);
                Default::default()
            }
        };
        let crate::production_stage::StageResult {
            rows,
            figures,
            failed,
        } = stage_result;
        if production_error.is_none() && production_interrupted.is_none() {
            summary["production"] = crate::production_stage::production_json(&stage, &rows, &failed);
            summary["production"]["wall_s"] = json!(t.elapsed().as_secs_f64());
            for r in &rows {
                if !r.converged {
                    warnings.push(format!(
                        "production {} dp = {:.1} MPa did not converge in {} iterations \
                         (last change {:.1e})",
                        r.state.name(),
                        r.dp / 1e6,
                        r.iterations,
                        r.change
                    ));
                }
                if !r.frozen_settled {
                    warnings.push(format!(
                        "production {} dp = {:.1} MPa: the rock without fluid pressure did \
                         not settle (a fracture grew in each relaxation), so rate_frozen is \
                         not an equilibrium's",
                        r.state.name(),
                        r.dp / 1e6
                    ));
                }
            }
            for f in &failed {
                warnings.push(format!(
                    "production {} dp = {:.1} MPa failed, no row: {}",
                    f.state.name(),
                    f.dp / 1e6,
                    f.error
                ));
            }
        }
        if let (Some(o), None, None) = (sim.output(), &production_error, production_interrupted) {
            let csv = crate::production_stage::production_csv(&rows);
            write_atomic(
                &o.claim("production.csv").map_err(DriverError::Output)?,
                csv.as_bytes(),
            )
            .map_err(DriverError::Output)?;
            let w = &stage.wells;
            let markers = [(w.injection, "injection"), (w.production, "production")];
            for s in &figures {
                let name = format!("production_flow_{}.png", s.row.state.name());
                let title = format!(
                    "{}: production flow {}, dp = {:.0} MPa, coupled; rate {:.3e} m^2/s",
                    sim.params().name,
                    s.row.state.name(),
                    s.row.dp / 1e6,
                    s.row.rate
                );
                let path = o.claim(&name).map_err(DriverError::Output)?;
                if let Err(e) =
                    crate::reservoir::doublet::flow_map(&path, &title, &s.flow, &markers)
                {
                    warnings.push(format!("{name} not written: {e}"));
                }
            }
            let now = network_now(&sim);
            let views = [
                ("before", start_network.as_ref(), 0.0),
                ("after", now.as_ref(), sim.time()),
            ];
            for (state, view, time) in views {
                let Some(view) = view else { continue };
                let name = format!("network_{state}.png");
                let title = format!(
                    "{}: fracture network {state} (t = {time:.3} s)",
                    sim.params().name
                );
                let path = o.claim(&name).map_err(DriverError::Output)?;
                if let Err(e) = crate::production_stage::network_figure(&path, &title, view, &markers) {
                    warnings.push(format!("{name} not written: {e}"));
                }
            }
        }
    }
    if let (Some(e), Some(path)) = (trace_error.lock().expect("trace error").take(), &opts.trace) {
        warnings.push(format!(
            "trace {} is incomplete: writing it failed: {e}",
            path.display()
        ));
    }
    if !warnings.is_empty() {
        summary["warnings"] = json!(warnings);
    }
    let summary_path = match sim.output() {
        Some(o) => o.claim("summary.json").map_err(DriverError::Output)?,
        None => out.join("summary.json"),
    };
    write_atomic(
        &summary_path,
        serde_json::to_string_pretty(&summary)
            .expect("json")
            .as_bytes(),
    )
    .map_err(DriverError::Output)?;
    if let Some(o) = sim.output() {
        o.folder().remove_temporaries();
    }
    if let Some(e) = production_error {
        return Err(DriverError::Production(Box::new(e)));
    }
    if let Err(e) = result {
        return Err(DriverError::Run {
            error: e,
            out: out.display().to_string(),
        });
    }
    Ok(RunReport {
        out,
        summary,
        timing_table,
        interrupted_by: sim.interrupted_by().or(production_interrupted),
        networks: start_network.zip(network_now(&sim)).map(|(a, b)| [a, b]),
        mesh_box: sim.solid().x0.iter().fold(
            [
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ],
            |b, p| {
                [
                    b[0].min(p[0]),
                    b[1].max(p[0]),
                    b[2].min(p[1]),
                    b[3].max(p[1]),
                ]
            },
        ),
        residual_aperture: sim.params().residual_aperture,
    })
}

/// What decides the run's output size ([`crate::resources::output_estimate`]), from the
/// simulation after setup (or after a restart: the steps left).
fn output_plan(sim: &Simulation) -> crate::resources::OutputPlan {
    let p = sim.params();
    let solid = sim.solid();
    let cells = match sim.flow() {
        Some(f) => f.view.n_cells(),
        None => sim.fracture_view().map_or(0, |v| v.n_cells()),
    };
    let end = match p.time.end {
        crate::scenario::End::Time(te) => Some(te - sim.time()),
        _ => None,
    };
    let left = p.time.max_steps.saturating_sub(sim.step());
    let (steps, steps_from) = crate::resources::planned_steps(end, sim.dt(), left);
    crate::resources::OutputPlan {
        nodes: solid.x0.len() as f64,
        triangles: solid.conn.len() as f64,
        cells: cells as f64,
        fields: p.output.fields.clone(),
        frame_every: p.output.frame_every,
        series_every: p.output.series_every,
        series_columns: sim.series_columns().len(),
        figures: p.output.figure_times.len(),
        steps,
        steps_from,
    }
}

/// The fracture cells as they are now: the coupled flow's view, else the fractures' view.
fn network_now(sim: &Simulation) -> Option<crate::flow::FlowView> {
    sim.flow()
        .map(|f| f.view.clone())
        .or_else(|| sim.fracture_view())
}

/// Open the `--trace` file before the folder is touched: an existing file must be a writable
/// file (it is truncated only after every check passed), a new one is created in an existing
/// folder. Returns the file and, when it lies in the output folder, its path there (kept out of
/// the previous run's removal and listed in the manifest).
fn open_trace(
    path: &Path,
    plan: &mut Plan,
) -> Result<(std::fs::File, Option<String>), DriverError> {
    let err = |why: String| DriverError::Trace {
        path: path.to_path_buf(),
        why,
    };
    if path.is_dir() {
        return Err(err("is a folder, not a file".into()));
    }
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(dir) = parent
        && !dir.is_dir()
    {
        return Err(err(format!("folder {} does not exist", dir.display())));
    }
    let file = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .map_err(|e| err(format!("cannot be written: {e}")))?;
    let rel = plan.inside(path);
    if let Some(r) = &rel {
        plan.keep(r);
    }
    Ok((file, rel))
}

/// Empty the opened trace file (after the folder checks passed); a device (`/dev/null`) is
/// written as it is.
fn truncate(file: std::fs::File) -> std::io::Result<std::fs::File> {
    if file.metadata()?.is_file() {
        file.set_len(0)?;
    }
    Ok(file)
}

/// The first error writing the trace file, if any.
type TraceError = std::sync::Arc<std::sync::Mutex<Option<std::io::Error>>>;

/// The trace file as tracing-chrome's writer thread sees it: that thread unwraps every write,
/// so a failing write (a full disk) would panic it. Here the first error is kept (reported as
/// a `summary.json` warning) and every write from then on is dropped as if it succeeded: the
/// run goes on, the trace file is left incomplete.
struct TraceWriter {
    file: std::fs::File,
    error: TraceError,
}

impl TraceWriter {
    /// `op` on the file, unless a write failed before; its error is kept and hidden (the call
    /// "succeeds" with `n`), except an interruption, which the caller retries.
    fn guard(
        &mut self,
        op: impl FnOnce(&mut std::fs::File) -> std::io::Result<usize>,
        n: usize,
    ) -> std::io::Result<usize> {
        let mut err = self.error.lock().expect("trace error");
        if err.is_some() {
            return Ok(n);
        }
        match op(&mut self.file) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => Err(e),
            Err(e) => {
                *err = Some(e);
                Ok(n)
            }
            ok => ok,
        }
    }
}

impl std::io::Write for TraceWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.guard(|f| f.write(buf), buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.guard(|f| f.flush().map(|()| 0), 0).map(|_| ())
    }
}

fn progress_bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(1000), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {bar:40} {percent:>3}% {msg}")
            .expect("template"),
    );
    bar
}

/// The production stage's spinner: the state and where its iteration is.
fn production_bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}").expect("template"),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    bar
}

/// Progress in per mille: by time for timed runs, by residual decades for static ones.
fn progress_position(s: &Simulation) -> u64 {
    match s.params().time.end {
        crate::scenario::End::Time(te) => (1000.0 * s.time() / te) as u64,
        crate::scenario::End::SteadyDirect => 1000,
        crate::scenario::End::Static { tol, .. } => {
            let done = (s.residual().max(tol).log10() / tol.log10()).clamp(0.0, 1.0);
            (1000.0 * done) as u64
        }
    }
    .min(1000)
}

fn summary_json(
    sim: &Simulation,
    result: &Result<Finish, RunError>,
    wall: f64,
    rows: &[(String, bool, u64, f64)],
) -> serde_json::Value {
    let (mean, min, max) = sim.solid().stress_summary(&sim.params().solid);
    let systems: Vec<serde_json::Value> = sim
        .schedule()
        .entries
        .iter()
        .zip(rows)
        .map(|((_, st), (name, enabled, calls, total))| {
            json!({"name": name, "enabled": enabled, "status": st, "calls": calls, "total_s": total})
        })
        .collect();
    let (status, finish, error) = match result {
        Ok(f) => ("ok", Some(*f), None),
        Err(e) => ("failed", None, Some(e.to_string())),
    };
    let flow = sim.flow().map(|f| {
        let (inj, prod, stored, err) = sim.flow_balance().unwrap_or_default();
        let bcs: Vec<serde_json::Value> = f
            .view
            .bcs
            .iter()
            .map(|b| {
                json!({"name": sim.bc_name(b.index), "pressure": b.pressure, "rate": b.rate,
                       "volume_in": b.volume_in, "volume_out": b.volume_out})
            })
            .collect();
        json!({
            "cells": f.view.n_cells(),
            "pairs": f.view.pairs.len(),
            "dt": f.dt,
            "dt_critical": finite(f.dt_crit),
            "substeps": f.substeps,
            "scheme": if f.implicit.is_some() { "implicit" } else { "explicit" },
            "newton_iterations": f.implicit.as_ref().map(|s| s.total_iterations),
            "lu_factorisations": f.implicit.as_ref().map(|s| s.factorisations),
            "chord_iterations": f.implicit.as_ref().map(|s| s.chord_iterations),
            "residual": f.residual,
            "boundaries": bcs,
            "injected_volume": inj,
            "produced_volume": prod,
            "stored_volume_change": stored,
            "mass_balance_error": err,
        })
    });
    let mut s = json!({
        "scenario": sim.params().name,
        "flow": flow,
        "solid_scheme": if sim.quasi_static_counts().is_some() { "quasi_static" } else { "explicit" },
        "status": status,
        "finish": finish,
        "error": error,
        "elements": sim.solid().n_elems(),
        "nodes": sim.solid().n_nodes(),
        "edges": sim.model().edge_count(),
        "steps": sim.step(),
        "time": sim.time(),
        "dt": sim.params().solid.dt,
        "dt_critical": finite(sim.dt_crit()),
        "mass_scaling": sim.params().time.selective.map(|j| {
            let (nodes, added) = sim.raised_masses();
            let total: f64 = sim.solid().mass.iter().sum();
            json!({"critical_step": j.dt_crit, "unscaled_critical_step": j.dt_unscaled,
                   "nodes": nodes, "added_mass_fraction": added / (total - added)})
        }),
        "wall_s": wall,
        "residual": sim.residual(),
        "kinetic_energy": sim.stats().kinetic,
        "frames": sim.output().map_or(0, |o| o.frames),
        "fracture_ready_edges": sim.params().has_fractures.then_some(sim.fracture().ready_edges),
        "criterion": criterion_summary(sim),
        "splits": sim.fracture().splits,
        "opened_edges": sim.fracture().opened_edges,
        "joints": sim.solid().joint_nodes.len(),
        "preexisting_fractures": sim.placed(),
        "mesh": (sim.solid().n_elems() > 0).then(|| sim.mesh_info()),
        "stress_mean": {"xx": mean[0], "yy": mean[1], "xy": mean[2]},
        "stress_min": {"xx": min[0], "yy": min[1], "xy": min[2]},
        "stress_max": {"xx": max[0], "yy": max[1], "xy": max[2]},
        "systems": systems,
    });
    omit_if_null(&mut s, OPTIONAL);
    if let Some(flow) = s.get_mut("flow") {
        omit_if_null(flow, OPTIONAL_FLOW);
    }
    s
}

/// The warning for pre-existing fractures whose mesh path zigzags (orientation not a mesh
/// direction), or `None` when every one follows its mesh edges.
pub fn zigzag_warning(placed: &[crate::fractures::Placed]) -> Option<String> {
    let bad: Vec<&crate::fractures::Placed> = placed
        .iter()
        .filter(|p| p.zigzag_deg > crate::fractures::ZIGZAG_WARN_DEG)
        .collect();
    let worst = bad.iter().copied().max_by(|a, b| {
        a.snap_error_h
            .total_cmp(&b.snap_error_h)
            .then(a.zigzag_deg.total_cmp(&b.zigzag_deg))
    })?;
    let zig = bad.iter().map(|p| p.zigzag_deg).fold(0.0, f64::max);
    Some(format!(
        "{} of {} pre-existing fractures do not follow a mesh direction: their mesh paths \
         zigzag by up to {zig:.0} degrees, with snapping errors up to {:.2} h (from {:?} to {:?} \
         m; per fracture in preexisting_fractures.csv). Opening and slip along a zigzag are \
         distorted (docs/conforming.md: a closed crack at 20 degrees slips about 70 % less); \
         `mesh: Conforming(..)` makes the mesh follow the fractures",
        bad.len(),
        placed.len(),
        worst.snap_error_h,
        worst.from,
        worst.to
    ))
}

/// The fracture tips at the end of a run in `summary.json` (`tips`), whatever the criterion:
/// their number and the largest K_eq (Pa sqrt(m), the interaction integral and the maximum
/// hoop stress, `systems::toughness`) with its K_I, K_II and tip position (m). It tells how far
/// the tips are from growing: under the strength criterion compare K_eq with the toughness
/// the strength test acts like, about 3.5 (s0 + lambda T0) sqrt(h) (README, "Example II").
fn tips_summary(sim: &mut Simulation) -> serde_json::Value {
    let tips = sim.measure_tips();
    let count = tips.len();
    let best = tips
        .iter()
        .filter(|t| t.k_eq.is_finite() && t.k1.is_finite() && t.k2.is_finite())
        .max_by(|a, b| a.k_eq.total_cmp(&b.k_eq).then(b.node.cmp(&a.node)))
        .copied();
    let mut v = json!({ "count": count });
    if let Some(t) = best {
        v["k_eq_max"] = json!(t.k_eq);
        v["k1"] = json!(t.k1);
        v["k2"] = json!(t.k2);
        v["at"] = json!(sim.solid().x0[t.node as usize]);
    }
    v
}

/// The fracture criterion's work in `summary.json` (`null`, omitted, without a criterion):
/// which one, the strength test's evaluated and screened faces, and under `Toughness` the
/// tips now, the tip evaluations and those the displacement-correlation screen passed over.
fn criterion_summary(sim: &Simulation) -> serde_json::Value {
    let Some(c) = sim.params().criterion else {
        return serde_json::Value::Null;
    };
    let fr = sim.fracture();
    let mut v = json!({
        "kind": if c.toughness.is_some() { "toughness" } else { "strength" },
        "faces_evaluated": fr.strength_counts.evaluated,
        "faces_screened": fr.strength_counts.screened,
    });
    if let Some(k_ic) = c.toughness {
        v["k_ic"] = json!(k_ic);
        v["tips"] = json!(fr.tips.geometry.len());
        v["tip_evaluations"] = json!(fr.tips.evaluations);
        v["tips_screened"] = json!(fr.tips.screened);
    }
    v
}

/// Fields of `summary.json` that do not apply to every run, omitted when they do not (a
/// successful run's summary has no `null`): no `flow` without a network, no `finish` and
/// `error` of the other outcome, no `dt_critical` without a stability bound (the implicit
/// or quasi-static schemes, a scene without a solid), no `mass_scaling` without
/// `time.selective_mass_scaling`, no `fracture_ready_edges` without a fracture criterion.
const OPTIONAL: &[&str] = &[
    "flow",
    "finish",
    "error",
    "dt_critical",
    "mass_scaling",
    "fracture_ready_edges",
    "criterion",
    "mesh",
];
/// The same in `summary.json`'s `flow`: `newton_iterations`, `lu_factorisations` and
/// `chord_iterations` (implicit only), `dt_critical`.
const OPTIONAL_FLOW: &[&str] = &[
    "newton_iterations",
    "lu_factorisations",
    "chord_iterations",
    "dt_critical",
];

fn omit_if_null(v: &mut serde_json::Value, keys: &[&str]) {
    if let Some(obj) = v.as_object_mut() {
        for k in keys {
            if obj.get(*k).is_some_and(|x| x.is_null()) {
                obj.remove(*k);
            }
        }
    }
}

/// A bound that may be infinite (no limit): `None` then, so the field is omitted.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}
