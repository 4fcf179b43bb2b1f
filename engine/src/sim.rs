//! A simulation: the model, its dense views, the schedule, and the step loop.
//!
//! Setup turns the scenario into the model ([`crate::setup`]) and typed run parameters
//! ([`RunParams`]); from then on only the parameters are read. The step is the literal list of
//! [`SystemId::ORDER`]: each system is a function in `systems/` called here with what it reads
//! and writes. The views live here: rebuilt from the components when the model's topology
//! generation moves (after `split`, or an [`Simulation::edit_model`]).

use crate::checkpoint::{FlowState, Header, State, WorldRecords};
use crate::schedule::{Schedule, Status};
use hydrofrac_core::error::SetupError;
use hydrofrac_core::fractures::Placed;
use hydrofrac_core::model::Model;
use hydrofrac_core::output::Outputs;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::scenario::{End, Filling, Scenario};
use hydrofrac_core::view::SolidView;
use hydrofrac_systems::flow::FlowPart;
use hydrofrac_systems::fracture::FractureState;
use hydrofrac_systems::output::Scene;
use hydrofrac_systems::solid::StepStats;
use hydrofrac_systems::state::SolidPart;
use hydrofrac_systems::{
    RunError, SystemId, coupling, flow, fracture, monitor, output, solid, split,
};
use hydrofrac_systems::{quasi_static, quasi_static_flow};

pub use hydrofrac_systems::monitor::{Clock, Finish, SPEED_LIMIT_FRACTION};

pub use crate::setup::FLOW_ONLY_SUBSTEPS;

/// A request to stop a run between steps: 0 while none, else the number of the signal that
/// asked (the binary's SIGINT and SIGTERM handlers store 2 or 15 here). Checked by
/// [`Simulation::run`] before every step.
pub type StopFlag = std::sync::Arc<std::sync::atomic::AtomicUsize>;

pub struct Simulation {
    /// The scenario as given (read by reports only; the step reads `params`).
    scenario: Scenario,
    model: Model,
    params: RunParams,
    solid: SolidPart,
    flow: Option<FlowPart>,
    fracture: FractureState,
    clock: Clock,
    schedule: Schedule,
    output: Option<Outputs>,
    /// Pre-existing fractures as placed on the mesh.
    placed: Vec<Placed>,
    /// The rock mesh's kind and quality (default without a rock).
    mesh_info: crate::setup::MeshInfo,
    /// How hard the current quasi-static step was (the adaptive step's input), and the cells
    /// at its start.
    effort: monitor::Effort,
    cells_at_start: usize,
    /// Checked before every step ([`Simulation::set_stop`]).
    stop: Option<StopFlag>,
    /// The signal number that stopped the run, if one did.
    interrupted_by: Option<usize>,
    /// Systems switched off on the command line (part of a checkpoint's fingerprint).
    extra_disable: Vec<String>,
    /// `output.checkpoint_every: Time`: the simulated time the next checkpoint is due at, s.
    next_checkpoint_time: f64,
    /// Checkpoints written by this process.
    checkpoints: CheckpointStats,
}

/// What writing checkpoints cost this process.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct CheckpointStats {
    /// Checkpoints written, the step of the last one, its size (bytes) and the wall time of
    /// all of them (state capture, encoding and the atomic write), s.
    pub written: u64,
    pub last_step: Option<u64>,
    pub last_bytes: u64,
    pub seconds: f64,
}

/// The flow system's commit of a coupled quasi-static step of length `dt` (s).
fn commit_step(qs: &quasi_static::QuasiStatic, f: &mut FlowPart, p: &RunParams, dt: f64) {
    f.stats = quasi_static_flow::commit(&qs.rows, f, &p.fluid, dt);
    f.dt = dt;
    flow::steady_residual(f);
}

impl Simulation {
    /// Set up a validated scenario; `extra_disable` adds system names to switch off.
    pub fn new(
        scenario: hydrofrac_core::scenario::ValidScenario,
        extra_disable: &[String],
    ) -> Result<Self, SetupError> {
        let scenario = scenario.into_inner();
        let (mut model, placed, mesh_info) = crate::setup::build_model(&scenario)?;
        let mut p = RunParams::resolve(&scenario, model.material);
        let has_solid = scenario.mesh.is_some();
        let mut dt_crit = if has_solid {
            hydrofrac_core::stability::solid(
                &model,
                p.c_p,
                p.joint.k_max(),
                p.k_fluid(),
                p.residual_aperture,
            )
        } else {
            f64::INFINITY
        };
        if let (Some(f), true) = (scenario.time.selective_mass_scaling, has_solid) {
            let s = hydrofrac_core::params::SelectiveScaling {
                dt_crit: f * dt_crit,
                dt_unscaled: dt_crit,
            };
            dt_crit = s.dt_crit;
            p.time.selective = Some(s);
        }
        let mut flow = crate::setup::build_flow(&mut model, &scenario, &p)?;
        let (dt, steps_to_end) =
            crate::setup::time_step(&p.time, &scenario.time, has_solid, dt_crit, flow.as_mut())?;
        p.solid.dt = dt;
        let view = crate::setup::solid_view(&model, &p, dt_crit, flow.as_mut());
        let mut disabled = scenario.systems.disable.clone();
        disabled.extend(extra_disable.iter().cloned());
        let schedule = crate::setup::schedule(&disabled, &view, &p, flow.is_some())?;
        let mut qs = crate::setup::quasi_static(&schedule);
        if let Some(q) = qs.as_mut() {
            q.linear = scenario.time.linear_solver;
            q.tol = scenario.time.newton_tol;
        }
        let next_checkpoint_time = match p.output.checkpoint_every {
            Some(hydrofrac_core::scenario::CheckpointEvery::Time(t)) => t,
            _ => f64::INFINITY,
        };
        Ok(Simulation {
            scenario,
            model,
            params: p,
            solid: SolidPart {
                view,
                stats: StepStats::default(),
                dt_crit,
                quasi_static: qs,
            },
            flow,
            fracture: FractureState::default(),
            clock: Clock {
                step: 0,
                time: 0.0,
                steps_to_end,
                residual: f64::INFINITY,
                finish: None,
            },
            schedule,
            output: None,
            placed,
            mesh_info,
            effort: monitor::Effort::default(),
            cells_at_start: 0,
            stop: None,
            interrupted_by: None,
            extra_disable: extra_disable.to_vec(),
            next_checkpoint_time,
            checkpoints: CheckpointStats::default(),
        })
    }

    /// Run to the end. `progress` is called every few hundred steps.
    pub fn run(&mut self, mut progress: impl FnMut(&Simulation)) -> Result<Finish, RunError> {
        self.rebuild_views_if_needed();
        if self.params.time.end == End::SteadyDirect {
            let f = self
                .flow
                .as_mut()
                .ok_or_else(|| SetupError::invalid("time.end", "SteadyDirect needs a network"))?;
            flow::steady_direct(f, &self.params, self.clock.time)?;
            self.clock.residual = f.residual;
            self.clock.finish = Some(Finish::Converged);
            self.write_now()?;
            self.sync();
            return Ok(Finish::Converged);
        }
        if self.clock.step == 0 && self.schedule.is_enabled(SystemId::Output) {
            self.write_now()?;
        }
        while self.clock.finish.is_none() {
            if let Some(sig) = self.stop_signal() {
                self.interrupt(sig)?;
                break;
            }
            self.step_once()?;
            if self.clock.finish.is_none() && self.checkpoint_due() {
                self.write_checkpoint()?;
            }
            if self.clock.step.is_multiple_of(256) {
                progress(self);
            }
        }
        self.sync();
        Ok(self.clock.finish.expect("loop ends with a finish"))
    }

    /// Check `stop` before every step of [`Simulation::run`]: when it is set (non-zero) the run
    /// ends after the step in progress, as [`Finish::Interrupted`], with a last frame and series
    /// row of the state reached.
    pub fn set_stop(&mut self, stop: StopFlag) {
        self.stop = Some(stop);
    }

    /// The signal number that stopped the run ([`Simulation::set_stop`]), if one did.
    pub fn interrupted_by(&self) -> Option<usize> {
        self.interrupted_by
    }

    /// The signal that asked the run to stop ([`Simulation::set_stop`]), if one has, whether
    /// or not a run has acted on it (the production stage's equilibria check it between
    /// steps).
    pub fn stop_signal(&self) -> Option<usize> {
        let sig = self
            .stop
            .as_ref()?
            .load(std::sync::atomic::Ordering::SeqCst);
        (sig != 0).then_some(sig)
    }

    /// End the run now (between steps) on signal `sig`: the last frame and series row of the
    /// state reached, unless the step just taken wrote them already.
    fn interrupt(&mut self, sig: usize) -> Result<(), RunError> {
        self.interrupted_by = Some(sig);
        // The state to resume from: the one before the run is marked finished.
        // (Unless the step just taken wrote it.)
        if self.params.output.checkpoint_every.is_some()
            && self.clock.step > 0
            && self.checkpoints.last_step != Some(self.clock.step)
        {
            self.write_checkpoint()?;
        }
        self.clock.finish = Some(Finish::Interrupted);
        if !self.schedule.is_enabled(SystemId::Output) {
            return Ok(());
        }
        let Some(out) = self.output.as_mut() else {
            return Ok(());
        };
        let (step, o) = (self.clock.step, &self.params.output);
        // Step 0's frame and row were written before the loop; a step's own output wrote them
        // when due.
        let frame = !(step == 0 || (o.frame_every > 0 && step.is_multiple_of(o.frame_every)));
        let row = !(step == 0 || step.is_multiple_of(o.series_every));
        let scene = Scene {
            solid: &self.solid,
            clock: &self.clock,
            fracture: &self.fracture,
            params: &self.params,
        };
        output::write(&mut self.model, self.flow.as_mut(), &scene, out, frame, row)
    }

    /// Whether `output.checkpoint_every` asks for a checkpoint after the step just taken (and
    /// moves the next due time on).
    fn checkpoint_due(&mut self) -> bool {
        use hydrofrac_core::scenario::CheckpointEvery;
        match self.params.output.checkpoint_every {
            None => false,
            Some(CheckpointEvery::Steps(n)) => self.clock.step.is_multiple_of(n),
            Some(CheckpointEvery::Time(t)) => {
                if self.clock.time < self.next_checkpoint_time {
                    return false;
                }
                self.next_checkpoint_time = ((self.clock.time / t).floor() + 1.0) * t;
                true
            }
        }
    }

    /// The state between steps as a checkpoint ([`crate::checkpoint`]), read as it is in
    /// memory: nothing is synced, so taking it does not change the run.
    pub fn checkpoint_state(&self) -> Result<(Header, State), String> {
        let m = &self.model;
        let p = &self.params;
        let header = Header {
            crate_version: env!("CARGO_PKG_VERSION").to_string(),
            scenario_name: self.scenario.name.clone(),
            fingerprint: crate::checkpoint::fingerprint(&self.scenario, &self.extra_disable),
            step: self.clock.step,
            time: self.clock.time,
        };
        let flow = self.flow.as_ref().map(|f| FlowState {
            view: f.view.clone(),
            dt: f.dt,
            substeps: f.substeps,
            dt_crit: f.dt_crit,
            substep_bound: f.substep_bound,
            stats: f.stats,
            initial_excess: f.initial_excess,
            residual: f.residual,
            initial_volume: f.initial_volume,
            coupling: f.coupling.clone(),
            implicit: f.implicit.as_ref().map(|s| s.counters()),
        });
        let state = State {
            world: WorldRecords::capture(m)?,
            topology_generation: m.topology_generation,
            next_ids: [
                m.next_node_id,
                m.next_elem_id,
                m.next_edge_id,
                m.next_cell_id,
                m.next_joint_id,
            ],
            clock: self.clock.clone(),
            dt: p.solid.dt,
            load_factor: p.solid.load_factor,
            aim: p.time.aim,
            solid_view: self.solid.view.clone(),
            solid_stats: self.solid.stats,
            dt_crit: self.solid.dt_crit,
            qs_counts: self.solid.quasi_static.as_ref().map(|q| q.counts),
            flow,
            fracture: self.fracture.clone(),
            effort: self.effort,
            cells_at_start: self.cells_at_start,
            next_checkpoint_time: self.next_checkpoint_time,
        };
        Ok((header, state))
    }

    /// Continue from a checkpoint's state: this simulation must be freshly set up from the
    /// scenario the checkpoint was written for ([`crate::checkpoint::check_scenario`]).
    pub fn restore(&mut self, state: State) -> Result<(), String> {
        let qs = (state.qs_counts.is_some(), self.solid.quasi_static.is_some());
        if qs.0 != qs.1 {
            return Err("its flow network or solid scheme differs from this scenario's".into());
        }
        self.take_state(state)
    }

    /// Take over the model and the state of another run of the same model (the production
    /// stage starts from the end of a stimulation, `crate::production`): as
    /// [`Simulation::restore`], but the other run's solid scheme may differ from this one's;
    /// its step length and adaptive-step state are taken too and are for the caller to set.
    pub fn adopt(&mut self, state: State) -> Result<(), String> {
        self.take_state(state)
    }

    fn take_state(&mut self, state: State) -> Result<(), String> {
        let parts = (state.flow.is_some(), self.flow.is_some());
        if parts.0 != parts.1 {
            return Err("its flow network or solid scheme differs from this scenario's".into());
        }
        let m = &mut self.model;
        m.world = state.world.restore()?;
        m.topology_generation = state.topology_generation;
        [
            m.next_node_id,
            m.next_elem_id,
            m.next_edge_id,
            m.next_cell_id,
            m.next_joint_id,
        ] = state.next_ids;
        self.clock = state.clock;
        let p = &mut self.params;
        p.solid.dt = state.dt;
        p.solid.load_factor = state.load_factor;
        p.time.aim = state.aim;
        self.solid.view = state.solid_view;
        self.solid.stats = state.solid_stats;
        self.solid.dt_crit = state.dt_crit;
        if let (Some(q), Some(c)) = (self.solid.quasi_static.as_mut(), state.qs_counts) {
            q.counts = c;
        }
        if let (Some(f), Some(s)) = (self.flow.as_mut(), state.flow) {
            f.view = s.view;
            f.dt = s.dt;
            f.substeps = s.substeps;
            f.dt_crit = s.dt_crit;
            f.substep_bound = s.substep_bound;
            f.stats = s.stats;
            f.initial_excess = s.initial_excess;
            f.residual = s.residual;
            f.initial_volume = s.initial_volume;
            if f.coupling.is_some() != s.coupling.is_some() {
                return Err("its coupling differs from this scenario's".into());
            }
            f.coupling = s.coupling;
            if let (Some(solver), Some(c)) = (f.implicit.as_mut(), s.implicit) {
                solver.set_counters(c);
            }
        }
        self.fracture = state.fracture;
        self.fracture.tips.invalidate();
        if self.solid.quasi_static.is_none() {
            self.fracture.screen.track_motion(&mut self.solid.view);
        }
        self.effort = state.effort;
        self.cells_at_start = state.cells_at_start;
        self.next_checkpoint_time = state.next_checkpoint_time;
        let has_load = self.solid.view.has_load();
        self.schedule.set_data(SystemId::ExternalLoad, has_load);
        Ok(())
    }

    /// Write a checkpoint of the state now into the output folder (`checkpoint.ckpt`, the one
    /// before renamed to `checkpoint.prev.ckpt`; both listed in the folder's manifest; each
    /// written atomically). Without an output folder nothing is written. Returns the file.
    pub fn write_checkpoint(&mut self) -> Result<Option<std::path::PathBuf>, RunError> {
        let Some(out) = self.output.as_ref() else {
            return Ok(None);
        };
        let t = std::time::Instant::now();
        let (header, state) = self
            .checkpoint_state()
            .map_err(|e| RunError::Io(std::io::Error::other(format!("checkpoint: {e}"))))?;
        let bytes = crate::checkpoint::encode(&header, &state)
            .map_err(|e| RunError::Io(std::io::Error::other(format!("checkpoint: {e}"))))?;
        let path = out.claim(crate::checkpoint::FILE)?;
        let prev = out.claim(crate::checkpoint::PREV_FILE)?;
        if path.exists() {
            std::fs::rename(&path, &prev)?;
        }
        hydrofrac_core::output::write_atomic(&path, &bytes)?;
        let c = &mut self.checkpoints;
        c.written += 1;
        c.last_step = Some(self.clock.step);
        c.last_bytes = bytes.len() as u64;
        c.seconds += t.elapsed().as_secs_f64();
        Ok(Some(path))
    }

    /// What writing checkpoints cost so far.
    pub fn checkpoint_stats(&self) -> CheckpointStats {
        self.checkpoints
    }

    /// One step: every enabled system in order, each in its span.
    pub fn step_once(&mut self) -> Result<(), RunError> {
        self.rebuild_views_if_needed();
        let t0 = self.clock.time;
        let p = &mut self.params;
        p.solid.load_factor =
            hydrofrac_core::scenario::schedule_factor(&p.boundary_schedule, t0 + p.solid.dt);
        // By index, not through an iterator over the schedule: a collected list would allocate
        // every step.
        for k in 0..self.schedule.entries.len() {
            let (sys, status) = self.schedule.entries[k];
            if status != Status::Enabled {
                continue;
            }
            // Quasi-static propagation runs after the `split` span closes: its re-solves run
            // under their own systems' spans, so no time is counted twice.
            let mut propagate_at = None;
            let span = sys.span().entered();
            let (p, v) = (&mut self.params, &mut self.solid.view);
            match sys {
                SystemId::InternalForce => solid::internal_force(v, &p.solid),
                SystemId::ExternalLoad => solid::external_load(v, &p.solid),
                SystemId::Contact => fracture::contact(v, &p.joint),
                SystemId::FluidPressure => {
                    if let Some(c) = self.flow.as_ref().and_then(|f| f.coupling.as_ref()) {
                        fracture::fluid_pressure(v, &c.joint_cell, &c.p_mean);
                    }
                }
                SystemId::Damping => solid::damping(v, &p.solid),
                SystemId::Integrate => self.solid.stats = solid::integrate(v, &p.solid),
                SystemId::Solve => self.solve_step(t0)?,
                SystemId::FlowSubsteps => self.flow_step(t0)?,
                SystemId::FractureCriterion => self.criterion(),
                SystemId::Split => {
                    let t1 = monitor::step_end(t0, &self.params);
                    if self.split_now(t1) {
                        if self.solid.quasi_static.is_some() {
                            propagate_at = Some(t1);
                        } else {
                            let (m, s, c) = (&self.model, &mut self.solid, &mut self.clock);
                            split::shorten_step(m, s, c, &mut self.params, t1);
                        }
                    }
                }
                SystemId::Monitor => {
                    let f = self.flow.as_ref();
                    monitor::monitor(&mut self.clock, t0, &self.solid, f, p)?;
                    if p.time.adaptive && self.clock.finish.is_none() {
                        let cells = self.flow.as_ref().map_or(0, |f| f.view.n_cells());
                        self.effort.new_cells = cells.saturating_sub(self.cells_at_start);
                        monitor::next_step(&self.clock, &mut self.params, self.effort);
                    }
                }
                SystemId::Output => {
                    if let Some(out) = self.output.as_mut() {
                        let scene = Scene {
                            solid: &self.solid,
                            clock: &self.clock,
                            fracture: &self.fracture,
                            params: &self.params,
                        };
                        let flow = self.flow.as_mut();
                        if output::output(&mut self.model, flow, &scene, out, t0)? {
                            self.solid
                                .view
                                .joint_state
                                .iter_mut()
                                .for_each(|s| s.slid = false);
                        }
                    }
                }
            }
            drop(span);
            if let Some(t1) = propagate_at {
                self.propagate(t1)?;
            }
        }
        Ok(())
    }

    /// `solve` (quasi-static) over the step from `t0`: an adaptive step whose Newton iteration
    /// fails is halved and retried from the step's start (down to `time.dt_min`).
    fn solve_step(&mut self, t0: f64) -> Result<(), RunError> {
        let adaptive = self.params.time.adaptive;
        let v = &self.solid.view;
        let saved = adaptive.then(|| (v.u.clone(), v.joint_state.clone()));
        self.cells_at_start = self.flow.as_ref().map_or(0, |f| f.view.n_cells());
        loop {
            let dt = self.params.solid.dt;
            let Err(e) = self.solve_at(t0, dt) else {
                let qs = self
                    .solid
                    .quasi_static
                    .as_ref()
                    .expect("quasi-static scheme");
                self.effort.iterations = qs.counts.last_iterations;
                self.effort.pressure_change = qs.rows.pressure_change();
                return Ok(());
            };
            let Some((u, js)) = saved.as_ref() else {
                return Err(e);
            };
            let p = &mut self.params;
            if 0.5 * dt < p.time.dt_min {
                return Err(match e {
                    RunError::QuasiStatic { step, time, why } => RunError::QuasiStatic {
                        step,
                        time,
                        why: format!(
                            "{why} (the step was halved down to time.dt_min = {dt:.3e} s)"
                        ),
                    },
                    e => e,
                });
            }
            tracing::debug!("quasi-static step from t = {t0:.6e} s failed at dt = {dt:.3e} s: {e}");
            let v = &mut self.solid.view;
            v.u.copy_from_slice(u);
            v.joint_state.copy_from_slice(js);
            p.solid.dt = 0.5 * dt;
            p.time.aim = None;
            let qs = self
                .solid
                .quasi_static
                .as_mut()
                .expect("quasi-static scheme");
            qs.counts.cutbacks += 1;
        }
    }

    /// One quasi-static solve over [t0, t0 + dt] (dt = 0: again at t0, after a split), with
    /// the network's rows when the run is coupled and `flow_substeps` is on.
    fn solve_at(&mut self, t0: f64, dt: f64) -> Result<(), RunError> {
        let p = &mut self.params;
        p.solid.load_factor =
            hydrofrac_core::scenario::schedule_factor(&p.boundary_schedule, t0 + dt);
        let p = &self.params;
        let qs = self
            .solid
            .quasi_static
            .as_mut()
            .expect("quasi-static scheme");
        let faces = qs.on.fluid;
        let flow_on = self.schedule.is_enabled(SystemId::FlowSubsteps);
        // With `flow_substeps` off the network's pressures stay where they are and load the
        // faces, as the explicit scheme's `fluid_pressure` holds them.
        let (flow, held) = match self.flow.as_mut() {
            Some(part) if part.coupling.is_some() && flow_on => (
                Some(quasi_static_flow::FlowStep {
                    part,
                    specs: &p.flow_boundaries,
                    fluid: &p.fluid,
                    faces,
                    t0,
                    dt,
                }),
                None,
            ),
            Some(part) => (
                None,
                part.coupling.as_ref().map(|c| quasi_static::Held {
                    joint_cell: &c.joint_cell,
                    pressure: &part.view.pressure,
                }),
            ),
            None => (None, None),
        };
        let (step, t1) = (self.clock.step + 1, t0 + dt);
        self.solid.stats = quasi_static::solve(&mut self.solid.view, qs, flow, held, p, step, t1)?;
        Ok(())
    }

    /// `flow_substeps` over the step from `t0` (of length `p.solid.dt`): the quasi-static
    /// scheme commits its coupled solve, the explicit one steps the network.
    fn flow_step(&mut self, t0: f64) -> Result<(), RunError> {
        let Some(f) = self.flow.as_mut() else {
            return Ok(());
        };
        let p = &self.params;
        match self.solid.quasi_static.as_ref() {
            Some(qs) if f.coupling.is_some() => {
                commit_step(qs, f, p, p.solid.dt);
                Ok(())
            }
            _ => flow::flow_substeps(f, &self.solid.view, p, t0, self.clock.step + 1),
        }
    }

    /// `fracture_criterion`: mark the faces ready to split.
    fn criterion(&mut self) {
        let Some(c) = self.params.criterion else {
            return;
        };
        if let Some(k_ic) = c.toughness {
            self.measure_tips_screened(Some(k_ic));
            self.fracture.tips.mark(&mut self.solid.view, k_ic);
        }
        let (v, fr) = (&mut self.solid.view, &mut self.fracture);
        // The explicit scheme's element stresses come from the displacements before this
        // step's `integrate`; the quasi-static solve leaves them at its solution.
        let stress_lags = self.solid.quasi_static.is_none();
        let skip = c.toughness.map(|_| &fr.tips.near_tip[..]);
        if let Some(strength) = c.strength {
            let mut new = std::mem::take(&mut fr.new_marks);
            fracture::fracture_criterion(
                v,
                strength,
                c.by_elements,
                Some((&mut fr.screen, &self.params.solid, stress_lags)),
                skip,
                &mut fr.strength_counts,
                &mut new,
            );
            if c.tip_handover && c.toughness.is_none() {
                let n = fracture::hand_over(v, &mut fr.handover, &mut new);
                fr.strength_counts.ready += n;
                fr.handed_over += n;
            }
            // Initiation away from tips: one new fracture per neighbourhood and pass.
            if c.toughness.is_some() {
                for k in hydrofrac_systems::toughness::one_per_neighbourhood(v, &mut new) {
                    fr.screen.recheck(k);
                }
            }
            fr.new_marks = new;
        }
        fr.ready_edges = match (c.toughness, c.strength) {
            (None, Some(_)) => fr.strength_counts.ready,
            _ => v.edge_ready.iter().filter(|r| **r).count(),
        };
    }

    /// K_I, K_II and the growth direction at every fracture tip of the current state
    /// (`systems::toughness`), whatever the criterion; the faces carry their cell's pressure in
    /// coupled runs (the quasi-static solve's, or the explicit step's mean), else
    /// `fracture.pressure`.
    pub fn measure_tips(&mut self) -> &[hydrofrac_systems::toughness::TipState] {
        self.measure_tips_screened(None)
    }

    /// [`Simulation::measure_tips`], passing over tips whose displacement-correlation estimate
    /// is below `DC_SCREEN` times `k_ic` (the criterion's screen).
    fn measure_tips_screened(
        &mut self,
        k_ic: Option<f64>,
    ) -> &[hydrofrac_systems::toughness::TipState] {
        let p = &self.params;
        let m = p.material;
        let e_prime = m.young / (1.0 - m.poisson * m.poisson);
        let quasi_static = self.solid.quasi_static.is_some();
        let flow = self.flow.as_ref();
        let joint_pressure = |k: usize| -> f64 {
            match flow.and_then(|f| f.coupling.as_ref().map(|c| (f, c))) {
                Some((f, c)) => match c.joint_cell[k] {
                    u32::MAX => 0.0,
                    // The quasi-static step's face load is its pressures unless filling
                    // cells carry their front's (`Filling::FrontInCell`, in `p_mean`).
                    cell if quasi_static && p.fluid.filling == Filling::Dry => {
                        f.view.pressure[cell as usize]
                    }
                    cell => c.p_mean[cell as usize],
                },
                None => p.face_pressure.unwrap_or(0.0),
            }
        };
        let tips = &mut self.fracture.tips;
        tips.measure(&self.solid.view, &p.solid, e_prime, joint_pressure, k_ic);
        &tips.state
    }

    /// `split` at time `t1`; returns whether faces opened (the views are then rebuilt).
    fn split_now(&mut self, t1: f64) -> bool {
        let flow = self.flow.as_ref();
        let (v, p) = (&mut self.solid.view, &self.params);
        let opened = split::split(&mut self.model, v, flow, &mut self.fracture, p, t1);
        if opened {
            self.rebuild_views_if_needed();
        }
        opened
    }

    /// Quasi-static propagation: after a split at `t1`, the step is solved again at the same
    /// time (no flow time passes: each cell keeps its mass, the new cells arrive empty), the
    /// criterion checked and split again, until nothing more opens or `time.max_resolves`
    /// re-solves were made (counted as a cap hit). Each pass runs under its systems' spans.
    fn propagate(&mut self, t1: f64) -> Result<(), RunError> {
        let cap = self.params.time.max_resolves;
        let mut rounds = 0;
        loop {
            if rounds == cap {
                tracing::warn!(
                    "t = {t1:.6e} s: faces still open after time.max_resolves = {cap} \
                     re-solves; the step ends here"
                );
                let qs = self
                    .solid
                    .quasi_static
                    .as_mut()
                    .expect("quasi-static scheme");
                qs.counts.resolve_cap_hits += 1;
                break;
            }
            rounds += 1;
            {
                let _span = SystemId::Solve.span().entered();
                self.solve_at(t1, 0.0)?;
            }
            if self.schedule.is_enabled(SystemId::FlowSubsteps)
                && let (Some(f), Some(qs)) = (self.flow.as_mut(), self.solid.quasi_static.as_ref())
                && f.coupling.is_some()
            {
                let _span = SystemId::FlowSubsteps.span().entered();
                commit_step(qs, f, &self.params, 0.0);
            }
            if self.schedule.is_enabled(SystemId::FractureCriterion) {
                let _span = SystemId::FractureCriterion.span().entered();
                self.criterion();
            }
            let _span = SystemId::Split.span().entered();
            if !self.split_now(t1) {
                break;
            }
        }
        let qs = self
            .solid
            .quasi_static
            .as_mut()
            .expect("quasi-static scheme");
        qs.counts.resolves += rounds;
        qs.counts.max_resolves_in_step = qs.counts.max_resolves_in_step.max(rounds);
        Ok(())
    }

    /// A frame and a series row now (the first one, and the steady solution).
    fn write_now(&mut self) -> Result<(), RunError> {
        let Some(out) = self.output.as_mut() else {
            return Ok(());
        };
        let scene = Scene {
            solid: &self.solid,
            clock: &self.clock,
            fracture: &self.fracture,
            params: &self.params,
        };
        output::write(&mut self.model, self.flow.as_mut(), &scene, out, true, true)
    }

    /// Copy the hot state into the ECS components, and bring the view's element stresses to
    /// the current displacements (they lag by a step between `internal_force` calls).
    pub fn sync(&mut self) {
        hydrofrac_systems::sync::write_back(
            &mut self.model,
            &self.solid.view,
            self.flow.as_ref(),
            &self.params,
        );
        solid::update_stress(&mut self.solid.view, &self.params.solid);
    }

    /// Change the model (boundary conditions, loads, topology) between steps: the state is
    /// synced first and the views are rebuilt if the topology generation moved.
    pub fn edit_model(&mut self, f: impl FnOnce(&mut Model)) {
        self.sync();
        f(&mut self.model);
        self.rebuild_views_if_needed();
    }

    /// Rebuild the views from the components when the topology generation moved.
    fn rebuild_views_if_needed(&mut self) {
        let p = &self.params;
        let generation = self.model.topology_generation;
        if self.solid.view.generation != generation {
            let mut view = SolidView::build(&self.model);
            crate::setup::scale_masses(&mut view, p, self.solid.dt_crit);
            let has_load = view.has_load();
            self.schedule.set_data(SystemId::ExternalLoad, has_load);
            self.solid.view = view;
        }
        if let Some(f) = self.flow.as_mut()
            && f.view.generation != generation
        {
            f.view = hydrofrac_core::flow::FlowView::build(&self.model, &p.fluid);
            f.view.set_bc_kinds(&p.flow_boundaries);
            f.dt_crit = f.view.critical_step(&p.fluid);
            if let Some(c) = f.coupling.as_mut() {
                *c = coupling::Coupling::build(
                    &self.model,
                    &self.solid.view,
                    &f.view,
                    &p.fluid,
                    c.a_r,
                );
            }
        }
    }

    /// Attach an output folder: frames, series rows and figures are written there.
    pub fn set_output(&mut self, out: Outputs) {
        self.output = Some(out);
    }
    pub fn output(&self) -> Option<&Outputs> {
        self.output.as_ref()
    }
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }
    pub fn model(&self) -> &Model {
        &self.model
    }
    pub fn params(&self) -> &RunParams {
        &self.params
    }
    /// For studies that change a parameter between steps (e.g. the damping).
    pub fn params_mut(&mut self) -> &mut RunParams {
        &mut self.params
    }
    /// The rock's dense view (state between syncs).
    pub fn solid(&self) -> &SolidView {
        &self.solid.view
    }
    /// For tests and benchmarks that drive a kernel on the view directly.
    pub fn solid_mut(&mut self) -> &mut SolidView {
        &mut self.solid.view
    }
    pub fn flow(&self) -> Option<&FlowPart> {
        self.flow.as_ref()
    }
    pub fn flow_mut(&mut self) -> Option<&mut FlowPart> {
        self.flow.as_mut()
    }
    pub fn clock(&self) -> &Clock {
        &self.clock
    }
    pub fn schedule(&self) -> &Schedule {
        &self.schedule
    }
    pub fn fracture(&self) -> &FractureState {
        &self.fracture
    }

    /// The fracture systems' state, to change (e.g. `tips.no_screen` for a comparison).
    pub fn fracture_mut(&mut self) -> &mut FractureState {
        &mut self.fracture
    }
    pub fn placed(&self) -> &[Placed] {
        &self.placed
    }

    /// The rock mesh's kind and quality statistics.
    pub fn mesh_info(&self) -> &crate::setup::MeshInfo {
        &self.mesh_info
    }
    /// Statistics of the last solid step.
    pub fn stats(&self) -> &StepStats {
        &self.solid.stats
    }
    /// What the quasi-static solver did (`None` with the explicit scheme).
    pub fn quasi_static_counts(&self) -> Option<quasi_static::QsCounts> {
        self.solid.quasi_static.as_ref().map(|q| q.counts)
    }
    /// The quasi-static solver, to change its settings (tolerance, W updates) before a run.
    pub fn quasi_static_mut(&mut self) -> Option<&mut quasi_static::QuasiStatic> {
        self.solid.quasi_static.as_mut()
    }
    /// The nodes whose mass in the view is above their lumped mass (`time.mass_scaling`,
    /// `time.selective_mass_scaling`), and the mass they add, kg/m. Reads the components:
    /// for summaries, not for the step.
    pub fn raised_masses(&self) -> (usize, f64) {
        let v = &self.solid.view;
        let mut out = (0, 0.0);
        for (&e, &m) in v.node_entity.iter().zip(&v.mass) {
            let own = self
                .model
                .world
                .get::<&hydrofrac_components::NodeMass>(e)
                .map_or(m, |n| n.0);
            if m > own {
                out.0 += 1;
                out.1 += m - own;
            }
        }
        out
    }
    /// Critical solid step of the current topology, s.
    pub fn dt_crit(&self) -> f64 {
        self.solid.dt_crit
    }
    /// Time step, s.
    pub fn dt(&self) -> f64 {
        self.params.solid.dt
    }
    /// Steps taken.
    pub fn step(&self) -> u64 {
        self.clock.step
    }
    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.clock.time
    }
    /// Static residual after the last step.
    pub fn residual(&self) -> f64 {
        self.clock.residual
    }
    pub fn finish(&self) -> Option<Finish> {
        self.clock.finish
    }
    /// Label of flow boundary `index`.
    pub fn bc_name(&self, index: usize) -> &str {
        &self.params.bc_names[index]
    }
    /// Flow volumes and mass-balance error ([`FlowPart::balance`]).
    pub fn flow_balance(&self) -> Option<(f64, f64, f64, f64)> {
        Some(self.flow.as_ref()?.balance(&self.params.fluid))
    }
    /// Names of the time-series columns of this scene.
    pub fn series_columns(&self) -> Vec<String> {
        output::series_columns(&self.solid.view, self.flow.as_ref(), &self.params)
    }
    /// Values of the time-series columns now.
    pub fn series_values(&self) -> Vec<f64> {
        let scene = Scene {
            solid: &self.solid,
            clock: &self.clock,
            fracture: &self.fracture,
            params: &self.params,
        };
        output::series_values(&scene, self.flow.as_ref())
    }
    /// The rock's fractures as a network view (scenes with joints but no flow network).
    pub fn fracture_view(&self) -> Option<hydrofrac_core::flow::FlowView> {
        output::fracture_view(
            &self.model,
            &self.solid.view,
            self.flow.as_ref(),
            &self.params,
        )
    }
    /// Coupled runs with an output folder: the fracture-pressure figure `name` there.
    pub fn fracture_pressure_figure(&mut self, name: &str) {
        let Some(dir) = self.output.as_ref().map(|o| o.dir.clone()) else {
            return;
        };
        let (time, flow) = (self.clock.time, self.flow.as_mut());
        output::fracture_pressure_figure(
            &mut self.model,
            &self.solid.view,
            flow,
            &self.params,
            &dir,
            name,
            time,
        );
    }
}
