//! `hydrofrac run`: load a scenario, run it with per-system timing, write the outputs.

use crate::error::SetupError;
use crate::output::folder::{FolderError, Plan};
use crate::output::{Outputs, write_atomic};
use crate::params::Criterion;
use crate::scenario::{Scenario, ValidScenario};
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
    /// Cleared (set false) when the run is about to create its output folder: the binary's
    /// signal handlers end the process at once while it is true (nothing is written during
    /// setup, which can take long on a large mesh), and stop it between steps after.
    pub exit_until_output: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
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
    /// Bounding box of the rock mesh in reference positions, `[xmin, xmax, ymin, ymax]` m
    /// (infinite bounds when the scene has no rock mesh).
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

/// Run a validated scenario, stage by stage: check resources, set up, the step loop, the
/// run's summary and figures, the production stage, write the results.
pub fn run_scenario(scenario: ValidScenario, opts: &RunOptions) -> Result<RunReport, DriverError> {
    let out = opts
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&scenario.name));
    if scenario.is_3d() {
        return crate::driver3::run_scenario_3d(scenario, opts, out);
    }
    check_resources(&scenario, opts)?;
    let loading = NetworkLoading::of(&scenario);
    let sim = Simulation::new(scenario, &opts.disable)?;
    let mut run = set_up(sim, opts, &out)?;
    let stepped = step_loop(&mut run, opts.quiet);
    let mut summary = run_summary(&mut run, &stepped);
    if let Some(n) = network_json(run.sim.placed(), run.sim.model().bbox, &loading) {
        summary["network"] = n;
    }
    network_outputs(&mut run, &mut summary)?;
    if let Some(s) = crate::catalogue::outputs(&mut run.sim, &mut run.warnings) {
        summary["seismicity"] = s;
    }
    let production = if stepped.result.is_ok() && run.sim.interrupted_by().is_none() {
        production_stage(&mut run, &mut summary, opts)?
    } else {
        StageEnd::Done
    };
    write_results(run, stepped, summary, production, opts, out)
}

/// A run set up: the simulation with its outputs open, and what the later stages report
/// from its start.
struct Run {
    sim: Simulation,
    /// The `--trace` file, emptied, for the step loop.
    trace: Option<std::fs::File>,
    /// The fracture cells at setup (the production stage's and the pipeline's "before").
    start_network: Option<crate::flow::FlowView>,
    /// The checkpoint the run continued from: its file, step and time.
    restarted_from: Option<(String, u64, f64)>,
    /// The outputs' estimated size, bytes (`summary.json` `output_estimate_bytes`).
    output_estimate: f64,
    /// Figures or tables that were not written (the run goes on): `summary.json` `warnings`.
    warnings: Vec<String>,
}

/// What the step loop hands on: its outcome, its wall time and the systems' timing.
pub(crate) struct Stepped {
    pub(crate) result: Result<Finish, RunError>,
    pub(crate) wall: f64,
    /// Per system: name, enabled, calls, seconds.
    pub(crate) rows: Vec<(String, bool, u64, f64)>,
    pub(crate) timing_table: String,
    /// The first error writing the trace file, if any.
    trace_error: TraceError,
}

/// How the production stage ended.
enum StageEnd {
    /// Solved and written, or not run (no `production:`, or the run did not end).
    Done,
    /// Stopped by this signal: the run's outputs are complete, the stage's are not written.
    Interrupted(usize),
    /// Failed: the run's outputs and summary are written, then the run fails with this.
    Failed(crate::production_stage::ProductionError),
}

/// Check resources: refuse a scenario whose mesh and network need more memory than
/// `--max-memory` (default: the machine's), estimated before anything is allocated.
pub(crate) fn check_resources(
    scenario: &ValidScenario,
    opts: &RunOptions,
) -> Result<(), DriverError> {
    let (limit, source) = match opts.max_memory {
        Some(b) => (b, "set by --max-memory".to_string()),
        None => crate::resources::default_limit(),
    };
    crate::resources::check(scenario, limit, &source)?;
    Ok(())
}

/// Set up: the restart, the stop signal, the disk check, then the output folder (with the
/// trace file) and the outputs written at setup. Everything that can refuse the run is
/// checked before the folder is touched.
fn set_up(mut sim: Simulation, opts: &RunOptions, out: &Path) -> Result<Run, DriverError> {
    let start_network = network_now(&sim);
    // Read and checked before the output folder is touched: a refused checkpoint leaves it
    // as it was (and a checkpoint inside it can be restarted from into the same folder).
    let restarted_from = match &opts.restart {
        Some(path) => Some(restart(&mut sim, path, &opts.disable)?),
        None => None,
    };
    if let Some(stop) = &opts.stop {
        sim.set_stop(stop.clone());
    }
    // From here on the run writes: a signal stops it between steps with its outputs finished.
    if let Some(armed) = &opts.exit_until_output {
        armed.store(false, std::sync::atomic::Ordering::SeqCst);
    }
    crate::resources::check_output_place(out).map_err(|why| {
        DriverError::Output(std::io::Error::other(format!(
            "cannot create output folder {}: {why}",
            out.display()
        )))
    })?;
    let (disk_limit, disk_source) = match opts.max_disk {
        Some(b) => (b, "set by --max-disk".to_string()),
        None => crate::resources::default_disk_limit(out),
    };
    let disk = crate::resources::check_disk(&output_plan(&sim), disk_limit, &disk_source)?;
    let (folder, trace) = open_folder(out, opts)?;
    let outputs = Outputs::new(folder, &sim.params().output.fields, &sim.series_columns())
        .map_err(DriverError::Output)?;
    let warnings = setup_outputs(&sim, &outputs)?;
    sim.set_output(outputs);
    Ok(Run {
        sim,
        trace,
        start_network,
        restarted_from,
        output_estimate: disk.total,
        warnings,
    })
}

/// Continue from the checkpoint at `path`: read, checked against the scenario, `--set` and
/// `--disable`, and restored. Returns its file, step and time.
fn restart(
    sim: &mut Simulation,
    path: &Path,
    disable: &[String],
) -> Result<(String, u64, f64), DriverError> {
    let (header, state) = crate::checkpoint::read(path)?;
    crate::checkpoint::check_scenario(path, &header, sim.scenario(), disable)?;
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
    Ok((path.display().to_string(), header.step, header.time))
}

/// Open the output folder (and `frames/` in it) with the `--trace` file: every path is
/// checked before anything in the folder is removed or written. Returns the folder and the
/// trace file, emptied.
pub(crate) fn open_folder(
    out: &Path,
    opts: &RunOptions,
) -> Result<(crate::output::folder::Folder, Option<std::fs::File>), DriverError> {
    let mut plan = Plan::check(out, opts.force)?;
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
    Ok((folder, trace))
}

/// A table not written because it has non-finite values (a `summary.json` warning).
const NOT_FINITE: &str = "not written: the table has non-finite values";

/// The outputs of the setup: the generated network's and the pre-existing fractures' tables.
/// Returns the warnings (tables not written, fractures that zigzag on the mesh).
fn setup_outputs(sim: &Simulation, outputs: &Outputs) -> Result<Vec<String>, DriverError> {
    let mut warnings = Vec::new();
    if let Some(f) = sim.flow()
        && !outputs
            .write_fractures_csv(&f.network.fractures)
            .map_err(DriverError::Output)?
    {
        warnings.push(format!("network_generated.csv {NOT_FINITE}"));
    }
    // (Printed on stderr with the summary's other warnings at the end of the run.)
    warnings.extend(zigzag_warning(sim.placed()));
    warnings.extend(clipped_warning(sim.placed(), sim.model().bbox));
    if !sim.placed().is_empty()
        && !outputs
            .write_preexisting_csv(sim.placed())
            .map_err(DriverError::Output)?
    {
        warnings.push(format!("preexisting_fractures.csv {NOT_FINITE}"));
    }
    Ok(warnings)
}

/// The step loop ([`Simulation::run`]: checkpoints and the stop signal as the scenario and
/// the options set them), with a progress bar, each system timed by a tracing layer and,
/// with `--trace`, traced into the trace file.
fn step_loop(run: &mut Run, quiet: bool) -> Stepped {
    let (sim, trace) = (&mut run.sim, run.trace.take());
    timed_loop(trace, quiet, |bar| {
        let result = sim.run(|s| show_progress(bar, s.params(), s.time(), s.residual()));
        (result, sim.schedule().clone())
    })
}

/// Run `steps` (a simulation's step loop, given the progress bar) under the timing layer and,
/// with a trace file, the Chrome trace; the systems' rows follow the schedule it returns.
pub(crate) fn timed_loop(
    trace: Option<std::fs::File>,
    quiet: bool,
    steps: impl FnOnce(&ProgressBar) -> (Result<Finish, RunError>, crate::schedule::Schedule),
) -> Stepped {
    let timing = TimingLayer::default();
    let table = timing.table.clone();
    let trace_error = TraceError::default();
    let (chrome, guard) = match trace {
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
    let bar = progress_bar(quiet);
    let t0 = Instant::now();
    let (result, schedule) = tracing::subscriber::with_default(subscriber, || steps(&bar));
    let wall = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    drop(guard);
    let times = table.lock().expect("timing table").clone();
    let rows: Vec<(String, bool, u64, f64)> = schedule
        .entries
        .iter()
        .map(|(s, st)| {
            let t = times.get(s.name()).copied().unwrap_or_default();
            let enabled = *st == Status::Enabled;
            (
                s.name().to_string(),
                enabled,
                t.calls,
                t.total.as_secs_f64(),
            )
        })
        .collect();
    Stepped {
        result,
        wall,
        timing_table: format_table(&rows),
        rows,
        trace_error,
    }
}

/// The run's `summary.json` as the step loop left it ([`summary_json`]), with the
/// interruption, the quasi-static counts, the tips, the output estimate, the checkpoints and
/// the restart.
fn run_summary(run: &mut Run, stepped: &Stepped) -> serde_json::Value {
    let sim = &mut run.sim;
    let mut summary = summary_json(sim, &stepped.result, stepped.wall, &stepped.rows);
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
    if stepped.result.is_ok() && sim.interrupted_by().is_none() && sim.params().has_fractures {
        let (tips, warning) = tips_summary(sim);
        summary["tips"] = tips;
        run.warnings.extend(warning);
    }
    summary["output_estimate_bytes"] = json!(run.output_estimate);
    if sim.params().output.checkpoint_every.is_some() {
        summary["checkpoints"] = json!(sim.checkpoint_stats());
    }
    if let Some((path, step, time)) = &run.restarted_from {
        // The quasi-static solver's factor is rebuilt at the restart (not in the checkpoint):
        // that run continues to the solver's tolerance, every other one bit for bit.
        let exact = sim.quasi_static_counts().is_none();
        summary["restarted_from"] =
            json!({"file": path, "step": step, "time": time, "bit_identical": exact});
    }
    summary
}

/// The network and fracture outputs at the end of the run: `network.csv`, the fracture and
/// flow figures, and `summary.json` `fractures`.
fn network_outputs(run: &mut Run, summary: &mut serde_json::Value) -> Result<(), DriverError> {
    let (sim, warnings) = (&mut run.sim, &mut run.warnings);
    if let (Some(v), Some(o)) = (sim.fracture_view(), sim.output()) {
        if !o.write_network_csv(&v).map_err(DriverError::Output)? {
            warnings.push(format!("network.csv {NOT_FINITE}"));
        }
        summary["fractures"] = fractures_json(&v);
        fracture_figures(sim, v, warnings)?;
    }
    if sim.flow().is_some_and(|f| f.coupling.is_some()) {
        if let Some(o) = sim.output() {
            o.claim("fractures_pressure.png")
                .map_err(DriverError::Output)?;
        }
        sim.fracture_pressure_figure("fractures_pressure.png");
        let f = sim.flow().expect("coupled");
        summary["fractures"] = fractures_json(&f.view);
        summary["fractures"]["max_aperture"] =
            json!(f.view.aperture.iter().fold(0.0f64, |a, &b| a.max(b)));
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
    Ok(())
}

/// What the slip statistics of `summary.json` `network` are measured under: the in-situ
/// stress (Pa, tension positive) where the rock starts from a uniform one without gravity,
/// and the joints' friction angle (degrees).
struct NetworkLoading {
    stress: Option<[f64; 2]>,
    friction_deg: f64,
}

impl NetworkLoading {
    fn of(sc: &crate::scenario::Scenario) -> Self {
        use crate::scenario::{Boundary, InitialState};
        let stress = match (&sc.boundary, sc.initial_state, sc.gravity) {
            (Boundary::InSitu { sxx, syy }, InitialState::InSitu, None) => Some([*sxx, *syy]),
            _ => None,
        };
        Self {
            stress,
            friction_deg: sc.fracture.as_ref().map_or(0.0, |f| f.friction_deg),
        }
    }
}

/// `summary.json` `network`: statistics of the pre-existing fractures as placed (the listed,
/// the file's and the generated ones, clipped to the domain `bbox`): count, length, P21,
/// intersections, the percolation parameter ([`crate::network::statistics`]) and, under a
/// uniform in-situ stress, their slip pressures ([`crate::network::slip_pressure`]): the
/// length-weighted mean (`mean_slip_pressure`, Pa) and the fraction of the length that is
/// critically stressed below the least principal compression (`critically_stressed_fraction`:
/// it slips by Coulomb's law at a fluid pressure under `critical_pressure`, before any
/// fracture can open in tension). `None` without pre-existing fractures.
fn network_json(
    placed: &[crate::fractures::Placed],
    bbox: [f64; 4],
    loading: &NetworkLoading,
) -> Option<serde_json::Value> {
    use crate::network::{slip_pressure, statistics};
    if placed.is_empty() {
        return None;
    }
    let segs: Vec<([f64; 2], [f64; 2])> = placed.iter().map(|p| (p.from, p.to)).collect();
    let area = (bbox[2] - bbox[0]) * (bbox[3] - bbox[1]);
    let mut v = json!(statistics(&segs, area));
    if let Some([sxx, syy]) = loading.stress {
        let p_open = -sxx.max(syy);
        let (mut critical, mut total, mut weighted) = (0.0, 0.0, 0.0);
        for &(a, b) in &segs {
            let (len, p) = (
                (b[0] - a[0]).hypot(b[1] - a[1]),
                slip_pressure(a, b, sxx, syy, loading.friction_deg),
            );
            total += len;
            // A frictionless joint's -inf counts as slipping at no pressure.
            weighted += len * p.max(-p_open.abs());
            if p < p_open {
                critical += len;
            }
        }
        v["critically_stressed_fraction"] = json!(critical / total);
        v["critical_pressure"] = json!(p_open);
        v["mean_slip_pressure"] = json!(weighted / total);
    }
    Some(v)
}

/// `summary.json` `fractures`: the cells, their total length and the new cells of `v`.
fn fractures_json(v: &crate::flow::FlowView) -> serde_json::Value {
    let length: f64 = v.length.iter().sum();
    let new = v
        .kind
        .iter()
        .filter(|k| **k == crate::components::CellKind::New)
        .count();
    json!({"cells": v.n_cells(), "total_length": length, "new_cells": new})
}

/// The fracture figures of a run with an output folder: the fractures, and the seed's Fig. 7
/// view (the mesh with apertures magnified 20x, coloured by the prescribed face pressure,
/// zero without one). A figure that fails is a warning.
fn fracture_figures(
    sim: &Simulation,
    mut v: crate::flow::FlowView,
    warnings: &mut Vec<String>,
) -> Result<(), DriverError> {
    let Some(o) = sim.output() else {
        return Ok(());
    };
    let name = &sim.params().name;
    if let Err(e) = crate::output::plots::fracture_figure(name, sim.time(), &v, o.folder()) {
        warnings.push(format!("figures not written: {e}"));
    }
    let p = sim.params().face_pressure.unwrap_or(0.0);
    v.pressure.iter_mut().for_each(|x| *x = p);
    let title = format!("{name}: fractures, apertures x20, t = {:.4} s", sim.time());
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
    Ok(())
}

/// The production stage (`production:`, [`crate::production_stage`]): the coupled steady
/// states before and after the run, after a run that ended, with a spinner; then
/// `summary.json` `production`, its warnings, `production.csv` and its figures.
fn production_stage(
    run: &mut Run,
    summary: &mut serde_json::Value,
    opts: &RunOptions,
) -> Result<StageEnd, DriverError> {
    use crate::production_stage::{ProductionError, StageResult};
    let Some(stage) = run.sim.scenario().production.clone() else {
        return Ok(StageEnd::Done);
    };
    let t = Instant::now();
    let solved = solve_production(&run.sim, opts)?;
    let StageResult {
        rows,
        figures,
        failed,
    } = match solved {
        Ok(x) => x,
        Err(ProductionError::Interrupted(sig)) => {
            // Stopped between two steps of an equilibrium: the run's outputs are complete,
            // the production table is not written.
            summary["status"] = json!("interrupted");
            summary["reason"] = json!(format!(
                "interrupted by {} during the production stage, after {:.1} s of it",
                signal_name(sig),
                t.elapsed().as_secs_f64()
            ));
            summary["production"] = json!({"interrupted": true});
            return Ok(StageEnd::Interrupted(sig));
        }
        Err(e) => {
            summary["production"] = json!({"error": e.to_string()});
            return Ok(StageEnd::Failed(e));
        }
    };
    summary["production"] = crate::production_stage::production_json(&stage, &rows, &failed);
    summary["production"]["wall_s"] = json!(t.elapsed().as_secs_f64());
    run.warnings
        .extend(crate::production_stage::stage_warnings(&rows, &failed));
    let start = run.start_network.as_ref();
    let written = write_production(&run.sim, &stage, &rows, &figures, start)?;
    run.warnings.extend(written);
    Ok(StageEnd::Done)
}

/// Solve the production states from the end of the run ([`run_production`]), with a spinner:
/// the before and the after states run side by side, and it shows the latest message of each.
///
/// [`run_production`]: crate::production_stage::run_production
fn solve_production(
    sim: &Simulation,
    opts: &RunOptions,
) -> Result<
    Result<crate::production_stage::StageResult, crate::production_stage::ProductionError>,
    DriverError,
> {
    let end = sim
        .checkpoint_state()
        .map_err(|e| DriverError::Output(std::io::Error::other(format!("production: {e}"))))?
        .1;
    let bar = production_bar(opts.quiet);
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
    Ok(solved)
}

/// The production stage's outputs in a run with an output folder: `production.csv`, the flow
/// at the middle pressure drop of each state (`production_flow_{state}.png`) and the network
/// before and after (`network_{before,after}.png`). Returns the figures not written.
fn write_production(
    sim: &Simulation,
    stage: &crate::scenario::ProductionStage,
    rows: &[crate::production_stage::ProductionRow],
    figures: &[crate::production_stage::StateSolve],
    start_network: Option<&crate::flow::FlowView>,
) -> Result<Vec<String>, DriverError> {
    let Some(o) = sim.output() else {
        return Ok(Vec::new());
    };
    let mut warnings = Vec::new();
    let csv = crate::production_stage::production_csv(rows);
    write_atomic(
        &o.claim("production.csv").map_err(DriverError::Output)?,
        csv.as_bytes(),
    )
    .map_err(DriverError::Output)?;
    let w = &stage.wells;
    let markers = [(w.injection, "injection"), (w.production, "production")];
    let name = &sim.params().name;
    for s in figures {
        let (state, dp) = (s.row.state.name(), s.row.dp / 1e6);
        let file = format!("production_flow_{state}.png");
        let title = format!(
            "{name}: production flow {state}, dp = {dp:.0} MPa, coupled; rate {:.3e} m^2/s",
            s.row.rate
        );
        let path = o.claim(&file).map_err(DriverError::Output)?;
        if let Err(e) = crate::reservoir::doublet::flow_map(&path, &title, &s.flow, &markers) {
            warnings.push(format!("{file} not written: {e}"));
        }
    }
    let now = network_now(sim);
    let views = [
        ("before", start_network, 0.0),
        ("after", now.as_ref(), sim.time()),
    ];
    for (state, view, time) in views {
        let Some(view) = view else { continue };
        let file = format!("network_{state}.png");
        let title = format!("{name}: fracture network {state} (t = {time:.3} s)");
        let path = o.claim(&file).map_err(DriverError::Output)?;
        if let Err(e) = crate::production_stage::network_figure(&path, &title, view, &markers) {
            warnings.push(format!("{file} not written: {e}"));
        }
    }
    Ok(warnings)
}

/// Write the results: the trace's and the stages' warnings into `summary.json`, written last
/// (into the folder, or beside it without outputs), the temporaries removed; then the run's
/// outcome: the production stage's error, the step loop's, or the report.
fn write_results(
    run: Run,
    stepped: Stepped,
    mut summary: serde_json::Value,
    production: StageEnd,
    opts: &RunOptions,
    out: PathBuf,
) -> Result<RunReport, DriverError> {
    let Run {
        sim,
        start_network,
        mut warnings,
        ..
    } = run;
    let trace_error = stepped.trace_error.lock().expect("trace error").take();
    if let (Some(e), Some(path)) = (trace_error, &opts.trace) {
        warnings.push(format!(
            "trace {} is incomplete: writing it failed: {e}",
            path.display()
        ));
    }
    if !warnings.is_empty() {
        summary["warnings"] = json!(warnings);
    }
    crate::output::json::finite_summary(&mut summary);
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
    let production_interrupted = match production {
        StageEnd::Failed(e) => return Err(DriverError::Production(Box::new(e))),
        StageEnd::Interrupted(sig) => Some(sig),
        StageEnd::Done => None,
    };
    if let Err(e) = stepped.result {
        return Err(DriverError::Run {
            error: e,
            out: out.display().to_string(),
        });
    }
    Ok(RunReport {
        out,
        summary,
        timing_table: stepped.timing_table,
        interrupted_by: sim.interrupted_by().or(production_interrupted),
        networks: start_network.zip(network_now(&sim)).map(|(a, b)| [a, b]),
        mesh_box: mesh_box(&sim),
        residual_aperture: sim.params().residual_aperture,
    })
}

/// Bounding box of the rock mesh in reference positions, `[xmin, xmax, ymin, ymax]` m.
fn mesh_box(sim: &Simulation) -> [f64; 4] {
    let empty = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    sim.solid().x0.iter().fold(empty, |b, p| {
        [
            b[0].min(p[0]),
            b[1].max(p[0]),
            b[2].min(p[1]),
            b[3].max(p[1]),
        ]
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

/// Show the run's progress on the bar: where it is in per mille, the time (s) and the static
/// residual.
pub(crate) fn show_progress(
    bar: &ProgressBar,
    p: &crate::params::RunParams,
    time: f64,
    residual: f64,
) {
    bar.set_position(progress_position(p, time, residual));
    bar.set_message(format!("t = {time:.4e} s  residual {residual:.2e}"));
}

/// Progress in per mille at time `time` (s) with static residual `residual`: by time for
/// timed runs, by residual decades for static ones.
fn progress_position(p: &crate::params::RunParams, time: f64, residual: f64) -> u64 {
    match p.time.end {
        crate::scenario::End::Time(te) => (1000.0 * time / te) as u64,
        crate::scenario::End::SteadyDirect => 1000,
        crate::scenario::End::Static { tol, .. } => {
            let done = (residual.max(tol).log10() / tol.log10()).clamp(0.0, 1.0);
            (1000.0 * done) as u64
        }
    }
    .min(1000)
}

/// `summary.json` of the run as the step loop left it: its outcome, the mesh, the steps, the
/// flow, the fractures' counts, the stress range and the systems' timing (`rows`).
fn summary_json(
    sim: &Simulation,
    result: &Result<Finish, RunError>,
    wall: f64,
    rows: &[(String, bool, u64, f64)],
) -> serde_json::Value {
    let (mean, min, max) = sim.solid().stress_summary(&sim.params().solid);
    let (status, finish, error) = match result {
        Ok(f) => ("ok", Some(*f), None),
        Err(e) => ("failed", None, Some(e.to_string())),
    };
    let stress = |s: [f64; 3]| json!({"xx": s[0], "yy": s[1], "xy": s[2]});
    let mut s = json!({
        "scenario": sim.params().name,
        "flow": flow_json(sim),
        "solid_scheme": if sim.quasi_static_counts().is_some() { "quasi_static" } else { "explicit" },
        "status": status,
        "finish": finish,
        "error": error,
        "elements": sim.solid().n_elems(),
        "nodes": sim.solid().n_nodes(),
        "edges": sim.model().edge_count(),
        "steps": sim.step(),
        "time": sim.time(),
        "dt": sim.dt(),
        "dt_critical": finite(sim.dt_crit()),
        "mass_scaling": mass_scaling_json(sim),
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
        "stress_mean": stress(mean),
        "stress_min": stress(min),
        "stress_max": stress(max),
        "systems": systems_json(sim.schedule(), rows),
    });
    omit_if_null(&mut s, OPTIONAL);
    if let Some(flow) = s.get_mut("flow") {
        omit_if_null(flow, OPTIONAL_FLOW);
    }
    s
}

/// `summary.json` `systems`: per system of the schedule, its status and timing (`rows`).
pub(crate) fn systems_json(
    schedule: &crate::schedule::Schedule,
    rows: &[(String, bool, u64, f64)],
) -> Vec<serde_json::Value> {
    schedule
        .entries
        .iter()
        .zip(rows)
        .map(|((_, st), (name, enabled, calls, total))| {
            json!({"name": name, "enabled": enabled, "status": st, "calls": calls, "total_s": total})
        })
        .collect()
}

/// `summary.json` `flow` (`None` without a network): the network, the step and scheme, the
/// boundaries' volumes and the mass balance.
pub(crate) fn flow_json<E: crate::dim::Element>(sim: &Simulation<E>) -> Option<serde_json::Value> {
    let f = sim.flow()?;
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
    let implicit = f.implicit.as_ref();
    Some(json!({
        "cells": f.view.n_cells(),
        "pairs": f.view.pairs.len(),
        "dt": f.dt,
        "dt_critical": finite(f.dt_crit),
        "substeps": f.substeps,
        "scheme": if implicit.is_some() { "implicit" } else { "explicit" },
        "newton_iterations": implicit.map(|s| s.total_iterations),
        "lu_factorisations": implicit.map(|s| s.factorisations),
        "chord_iterations": implicit.map(|s| s.chord_iterations),
        "residual": f.residual,
        "boundaries": bcs,
        "injected_volume": inj,
        "produced_volume": prod,
        "stored_volume_change": stored,
        "mass_balance_error": err,
    }))
}

/// `summary.json` `mass_scaling` (`None` without `time.selective_mass_scaling`): the critical
/// steps with and without it, the nodes it made heavier and the mass it added.
pub(crate) fn mass_scaling_json<E: crate::dim::Element>(
    sim: &crate::sim::Simulation<E>,
) -> Option<serde_json::Value> {
    sim.params().time.selective.map(|j| {
        let (nodes, added) = sim.raised_masses();
        let total: f64 = sim.solid().mass.iter().sum();
        json!({"critical_step": j.dt_crit, "unscaled_critical_step": j.dt_unscaled,
               "nodes": nodes, "added_mass_fraction": added / (total - added)})
    })
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

/// The warning for listed pre-existing fractures that reach outside the domain (`bbox`, m:
/// x0, y0, x1, y1): only their part inside is placed.
pub fn clipped_warning(placed: &[crate::fractures::Placed], bbox: [f64; 4]) -> Option<String> {
    let bad: Vec<String> = placed
        .iter()
        .filter(|p| p.clipped)
        .map(|p| format!("from {:?} to {:?} m", p.from, p.to))
        .collect();
    if bad.is_empty() {
        return None;
    }
    let [x0, y0, x1, y1] = bbox;
    Some(format!(
        "{} of {} pre-existing fractures reach outside the domain [{x0}, {x1}] x [{y0}, {y1}] \
         m and are cut at its boundary (only the part inside is a fracture): {}",
        bad.len(),
        placed.len(),
        bad.join("; ")
    ))
}

/// The fracture tips at the end of a run in `summary.json` (`tips`), whatever the criterion:
/// their number and the largest K_eq (Pa sqrt(m), the interaction integral and the maximum
/// hoop stress, `systems::toughness`) with its K_I, K_II and tip position (m), over the tips
/// whose integrals are trusted (no other fracture within
/// `toughness::TRUSTED_RADIUS_EDGES` edges); the others as `untrusted`, the same fields. It
/// tells how far the tips are from growing: under the strength criterion compare K_eq with
/// the toughness the strength test acts like, about 3.5 (s0 + lambda T0) sqrt(h) (README,
/// "Example II"). Under `Toughness` without an `initiation` strength nothing decides at an
/// untrusted tip (the strength test would): the warning says so when one is past K_Ic.
fn tips_summary(sim: &mut Simulation) -> (serde_json::Value, Option<String>) {
    use crate::systems::toughness::TRUSTED_RADIUS_EDGES;
    let states = sim.measure_tips().to_vec();
    let trusted: Vec<bool> = sim
        .fracture()
        .tips
        .geometry
        .iter()
        .map(|g| g.trusted)
        .collect();
    let x0 = &sim.solid().x0;
    let best = |want: bool| {
        states
            .iter()
            .zip(&trusted)
            .filter(|(t, tr)| {
                **tr == want && t.k_eq.is_finite() && t.k1.is_finite() && t.k2.is_finite()
            })
            .map(|(t, _)| *t)
            .max_by(|a, b| a.k_eq.total_cmp(&b.k_eq).then(b.node.cmp(&a.node)))
    };
    let fields = |v: &mut serde_json::Value, t: &crate::systems::toughness::TipState| {
        v["k_eq_max"] = json!(t.k_eq);
        v["k1"] = json!(t.k1);
        v["k2"] = json!(t.k2);
        v["at"] = json!(x0[t.node as usize]);
    };
    let untrusted_count = trusted.iter().filter(|t| !**t).count();
    let mut v = json!({ "count": states.len() });
    if let Some(t) = best(true) {
        fields(&mut v, &t);
    }
    let mut warning = None;
    if untrusted_count > 0 {
        let mut u = json!({ "count": untrusted_count });
        if let Some(t) = best(false) {
            fields(&mut u, &t);
            if let Some(Criterion::Toughness {
                k_ic,
                initiation: None,
            }) = sim.params().criterion.map(|c| c.kind)
                && t.k_eq >= k_ic
            {
                let past = states
                    .iter()
                    .zip(&trusted)
                    .filter(|(s, tr)| !**tr && s.k_eq >= k_ic)
                    .count();
                let at = x0[t.node as usize];
                warning = Some(format!(
                    "{past} fracture tips have K_eq >= K_Ic = {:.2e} Pa m^0.5 (up to {:.2e} at \
                     ({:.1}, {:.1}) m) but lie within {TRUSTED_RADIUS_EDGES} edges of another \
                     fracture, where the toughness criterion does not decide growth and the \
                     strength test would; give fracture.criterion's initiation strength so \
                     those tips can grow (summary.json tips.untrusted)",
                    k_ic, t.k_eq, at[0], at[1]
                ));
            }
        }
        v["untrusted"] = u;
    }
    (v, warning)
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
        "kind": match c.kind {
            Criterion::Strength { .. } => "strength",
            Criterion::Toughness { .. } => "toughness",
        },
        "faces_evaluated": fr.strength_counts.evaluated,
        "faces_screened": fr.strength_counts.screened,
    });
    if let Some(k_ic) = c.kind.k_ic() {
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
