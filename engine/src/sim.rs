//! A simulation: the model, its dense views, the schedule, and the step loop.
//!
//! Setup turns the scenario into the model ([`crate::setup`]) and typed run parameters
//! ([`RunParams`]), which do not change after it; what changes is state (the clock, the views,
//! the parts of `systems/`). The step is the literal list of [`SystemId::ORDER`]: each system
//! is a function in `systems/` called here with what it reads and writes; the loop owns only
//! the order ([`Simulation::run_system`]). The views live here: rebuilt from the components
//! when the model's topology generation moves (after `split`, or an
//! [`Simulation::edit_model`]). Checkpoints of the state are `crate::checkpoint`'s.

use crate::checkpoint::CheckpointStats;
use crate::schedule::{Schedule, Status};
use hydrofrac_core::dim::{Cst, Element};
use hydrofrac_core::error::SetupError;
use hydrofrac_core::fractures::Placed;
use hydrofrac_core::model::Model;
use hydrofrac_core::output::Outputs;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::scenario::{End, Scenario, schedule_factor};
use hydrofrac_core::view::SolidView;
use hydrofrac_systems::flow::FlowPart;
use hydrofrac_systems::fracture::FractureState;
use hydrofrac_systems::output::Scene;
use hydrofrac_systems::solid::StepStats;
use hydrofrac_systems::state::SolidPart;
use hydrofrac_systems::{
    RunError, SystemId, coupling, criterion, flow, fracture, monitor, output, quasi_static,
    quasi_static_step, seismicity, solid, split,
};

pub use hydrofrac_systems::monitor::{Clock, Finish, SPEED_LIMIT_FRACTION};

pub use crate::setup::FLOW_ONLY_SUBSTEPS;

/// The stop request ([`hydrofrac_systems::StopFlag`]), checked by [`Simulation::run`] before
/// every step.
pub use hydrofrac_systems::StopFlag;

pub struct Simulation<E: Element = Cst> {
    /// The scenario as given (read by reports only; the step reads `params`).
    pub(crate) scenario: Scenario,
    pub(crate) model: Model,
    pub(crate) params: RunParams,
    pub(crate) solid: SolidPart<E>,
    pub(crate) flow: Option<FlowPart>,
    pub(crate) fracture: FractureState,
    pub(crate) clock: Clock,
    pub(crate) schedule: Schedule,
    pub(crate) output: Option<Outputs>,
    /// Pre-existing fractures as placed on the mesh.
    pub(crate) placed: Vec<Placed>,
    /// The rock mesh's kind and quality (default without a rock).
    pub(crate) mesh_info: crate::setup::MeshInfo,
    /// How hard the current quasi-static step was (the adaptive step's input), and the cells
    /// at its start.
    pub(crate) effort: monitor::Effort,
    pub(crate) cells_at_start: usize,
    /// Checked before every step ([`Simulation::set_stop`]).
    pub(crate) stop: Option<StopFlag>,
    /// The signal number that stopped the run, if one did.
    pub(crate) interrupted_by: Option<usize>,
    /// Systems switched off on the command line (part of a checkpoint's fingerprint).
    pub(crate) extra_disable: Vec<String>,
    /// `output.checkpoint_every: Time`: the simulated time the next checkpoint is due at, s.
    pub(crate) next_checkpoint_time: f64,
    /// Checkpoints written by this process.
    pub(crate) checkpoints: CheckpointStats,
    /// The event catalogue (`seismicity:`).
    pub(crate) seismicity: Option<seismicity::Catalogue>,
}

/// Which pass of the schedule's systems a call is part of.
#[derive(Clone, Copy, Debug)]
enum Pass {
    /// The step that starts at `t0`.
    Step { t0: f64 },
    /// A quasi-static re-solve at `t1` after a split (zero-length: `solve`, the flow's
    /// commit, the criterion and `split`; the other systems do nothing).
    Resolve { t1: f64 },
}

impl<E: Element> Simulation<E> {
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
    /// The fracture flow part (`None` without flow).
    pub fn flow(&self) -> Option<&FlowPart> {
        self.flow.as_ref()
    }
    /// Label of flow boundary `index`.
    pub fn bc_name(&self, index: usize) -> &str {
        &self.params.bc_names[index]
    }
    /// Flow volumes and mass-balance error ([`FlowPart::balance`]).
    pub fn flow_balance(&self) -> Option<(f64, f64, f64, f64)> {
        Some(self.flow.as_ref()?.balance(&self.params.fluid))
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

    /// The fracture systems' state (criterion marks, split counts, tips).
    pub fn fracture(&self) -> &FractureState {
        &self.fracture
    }
    pub fn model(&self) -> &Model {
        &self.model
    }

    pub fn params(&self) -> &RunParams {
        &self.params
    }

    /// The rock's dense view (state between syncs).
    pub fn solid(&self) -> &SolidView<E> {
        &self.solid.view
    }
    /// For tests and benchmarks that drive a kernel on the view directly.
    pub fn solid_mut(&mut self) -> &mut SolidView<E> {
        &mut self.solid.view
    }

    pub fn clock(&self) -> &Clock {
        &self.clock
    }

    pub fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    /// The rock mesh's kind and quality statistics.
    pub fn mesh_info(&self) -> &crate::setup::MeshInfo {
        &self.mesh_info
    }

    /// Statistics of the last solid step.
    pub fn stats(&self) -> &StepStats {
        &self.solid.stats
    }

    /// Critical solid step of the current topology, s.
    pub fn dt_crit(&self) -> f64 {
        self.solid.dt_crit
    }

    /// Time step, s.
    pub fn dt(&self) -> f64 {
        self.clock.dt
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
        let view = crate::setup::solid_view(&model, &p, dt_crit, flow.as_mut());
        let mut disabled = scenario.systems.disable.clone();
        disabled.extend(extra_disable.iter().cloned());
        let schedule = crate::setup::schedule(&disabled, &view, &p, flow.is_some())?;
        let mut qs = crate::setup::quasi_static(&schedule);
        if let Some(q) = qs.as_mut() {
            q.linear = scenario.time.linear_solver;
            q.tol = scenario.time.newton_tol;
        }
        let seismicity = p.seismicity.as_ref().filter(|_| has_solid).map(|s| {
            let mut c = seismicity::Catalogue::new(seismicity::Settings {
                v_start: s.v_start,
                v_stop: s.v_stop(),
                width: s.width,
                shear_modulus: p.material.shear(),
            });
            c.follow(&view);
            c
        });
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
                dt_elements: f64::INFINITY,
                quasi_static: qs,
                linear: None,
            },
            flow,
            fracture: FractureState::default(),
            clock: Clock::start(dt, steps_to_end),
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
            seismicity,
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
        self.close_catalogue();
        self.sync();
        Ok(self.clock.finish.expect("loop ends with a finish"))
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

    /// One step: every enabled system of the schedule in order, each in its span.
    pub fn step_once(&mut self) -> Result<(), RunError> {
        self.rebuild_views_if_needed();
        let t0 = self.clock.time;
        self.clock.load_factor =
            schedule_factor(&self.params.boundary_schedule, t0 + self.clock.dt);
        // By index, not through an iterator over the schedule: a collected list would allocate
        // every step.
        for k in 0..self.schedule.entries.len() {
            let (sys, status) = self.schedule.entries[k];
            if status != Status::Enabled {
                continue;
            }
            let split_at = {
                let _span = sys.span().entered();
                self.run_system(sys, Pass::Step { t0 })?
            };
            // Quasi-static propagation runs after the `split` span closes: its re-solves run
            // under their own systems' spans, so no time is counted twice.
            if let Some(t1) = split_at {
                self.propagate(t1)?;
            }
        }
        Ok(())
    }

    /// Run system `sys` in `pass`. Returns the time of a quasi-static step's split that opened
    /// faces in a [`Pass::Step`] (the step then propagates, [`Simulation::propagate`]); in a
    /// [`Pass::Resolve`], `Some` when the split opened faces.
    fn run_system(&mut self, sys: SystemId, pass: Pass) -> Result<Option<f64>, RunError> {
        let (p, v, clock) = (&self.params, &mut self.solid.view, &mut self.clock);
        let quasi_static = self.solid.quasi_static.is_some();
        let flow_on = self.schedule.is_enabled(SystemId::FlowSubsteps);
        match (sys, pass) {
            (SystemId::InternalForce, Pass::Step { .. }) => solid::internal_force(v, &p.solid),
            (SystemId::ExternalLoad, Pass::Step { .. }) => {
                solid::external_load(v, clock.load_factor)
            }
            (SystemId::Contact, Pass::Step { .. }) => fracture::contact(v, &p.joint),
            (SystemId::FluidPressure, Pass::Step { .. }) => {
                if let Some(c) = self.flow.as_ref().and_then(|f| f.coupling.as_ref()) {
                    fracture::fluid_pressure(v, &c.joint_cell, &c.p_mean);
                }
            }
            (SystemId::Damping, Pass::Step { .. }) => solid::damping(v, &p.solid, clock.dt),
            (SystemId::Integrate, Pass::Step { .. }) => {
                self.solid.stats = solid::integrate(v, clock.dt, clock.load_factor)
            }
            (SystemId::Solve, Pass::Step { t0 }) => {
                self.cells_at_start = self.flow.as_ref().map_or(0, |f| f.view.n_cells());
                if let Some(qs) = self.solid.quasi_static.as_mut() {
                    qs.step_resolves = 0;
                }
                let (s, f, e) = (&mut self.solid, self.flow.as_mut(), &mut self.effort);
                quasi_static_step::solve_step(s, f, flow_on, clock, p, e, t0)?;
            }
            (SystemId::Solve, Pass::Resolve { t1 }) => {
                let (s, f) = (&mut self.solid, self.flow.as_mut());
                quasi_static_step::resolve_at(s, f, flow_on, clock, p, t1)?;
            }
            (SystemId::FlowSubsteps, pass) => {
                let Some(f) = self.flow.as_mut() else {
                    return Ok(None);
                };
                match (self.solid.quasi_static.as_ref(), pass) {
                    (Some(qs), Pass::Step { .. }) if f.coupling.is_some() => {
                        quasi_static_step::commit(qs, f, p, clock.dt)
                    }
                    (Some(qs), Pass::Resolve { .. }) if f.coupling.is_some() => {
                        quasi_static_step::commit(qs, f, p, 0.0)
                    }
                    (_, Pass::Step { t0 }) => {
                        let (dt, step) = (clock.dt, clock.step + 1);
                        flow::flow_substeps(
                            f,
                            coupling::opening_2d(&self.solid.view),
                            p,
                            t0,
                            dt,
                            step,
                        )?
                    }
                    (_, Pass::Resolve { .. }) => {}
                }
            }
            (SystemId::FractureCriterion, _) => {
                if let Some(c) = p.criterion {
                    let (fr, f) = (&mut self.fracture, self.flow.as_ref());
                    criterion::criterion(v, fr, f, p, c, quasi_static);
                }
            }
            (SystemId::Split, pass) => {
                let t1 = match pass {
                    Pass::Step { t0 } => monitor::step_end(t0, clock),
                    Pass::Resolve { t1 } => t1,
                };
                if !self.split_now(t1) {
                    return Ok(None);
                }
                if quasi_static || matches!(pass, Pass::Resolve { .. }) {
                    return Ok(Some(t1));
                }
                let (m, s, c) = (&self.model, &mut self.solid, &mut self.clock);
                split::shorten_step(m, s, c, &self.params, t1);
            }
            (SystemId::Monitor, Pass::Step { t0 }) => {
                let f = self.flow.as_ref();
                monitor::monitor(clock, t0, &self.solid, f, p)?;
                if clock.adaptive(p) && clock.finish.is_none() {
                    let cells = self.flow.as_ref().map_or(0, |f| f.view.n_cells());
                    self.effort.new_cells = cells.saturating_sub(self.cells_at_start);
                    monitor::next_step(clock, p, self.effort);
                }
            }
            (SystemId::Seismicity, Pass::Step { t0 }) => {
                if let Some(c) = self.seismicity.as_mut() {
                    let inj = seismicity::injection(self.flow.as_ref());
                    seismicity::seismicity(c, v, t0, clock.time, inj);
                }
            }
            (SystemId::Output, Pass::Step { t0 }) => {
                if let Some(out) = self.output.as_mut() {
                    let scene = Scene {
                        solid: &self.solid,
                        clock: &self.clock,
                        fracture: &self.fracture,
                        params: &self.params,
                    };
                    let flow = self.flow.as_mut();
                    if output::output(&mut self.model, flow, &scene, out, t0)? {
                        let js = &mut self.solid.view.joint_state;
                        js.iter_mut().for_each(|s| s.slid = false);
                    }
                }
            }
            (_, Pass::Resolve { .. }) => {}
        }
        Ok(None)
    }

    /// K_I, K_II and the growth direction at every fracture tip of the current state
    /// (`systems::criterion::measure_tips`), whatever the criterion; the faces carry their
    /// cell's pressure in coupled runs (the quasi-static solve's, or the explicit step's mean),
    /// else `fracture.pressure`.
    pub fn measure_tips(&mut self) -> &[hydrofrac_systems::toughness::TipState] {
        let (v, fr, f) = (&self.solid.view, &mut self.fracture, self.flow.as_ref());
        let quasi_static = self.solid.quasi_static.is_some();
        criterion::measure_tips(v, fr, f, &self.params, quasi_static, None)
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

    /// Quasi-static propagation: after a split at `t1`, the schedule's systems from `solve` to
    /// `split` run again at the same time ([`Pass::Resolve`]: no flow time passes, each cell
    /// keeps its mass, the new cells arrive empty) until nothing more opens or
    /// `time.max_resolves` re-solves were made (counted as a cap hit). Each system runs under
    /// its own span.
    fn propagate(&mut self, t1: f64) -> Result<(), RunError> {
        let order = SystemId::ORDER;
        let (from, to) = (SystemId::Solve, SystemId::Split);
        let systems: Vec<SystemId> = order
            .into_iter()
            .filter(|s| (from..=to).contains(s) && self.schedule.is_enabled(*s))
            .collect();
        let cap = self.params.time.max_resolves;
        let mut rounds = 0;
        loop {
            if rounds == cap {
                tracing::warn!(
                    "t = {t1:.6e} s: faces still open after time.max_resolves = {cap} \
                     re-solves; the step ends here"
                );
                self.qs_counts_mut().resolve_cap_hits += 1;
                break;
            }
            rounds += 1;
            let mut opened = false;
            for &sys in &systems {
                let _span = sys.span().entered();
                opened = self.run_system(sys, Pass::Resolve { t1 })?.is_some();
            }
            if !opened {
                break;
            }
        }
        if let Some(qs) = self.solid.quasi_static.as_mut() {
            qs.step_resolves = rounds;
        }
        let counts = self.qs_counts_mut();
        counts.resolves += rounds;
        counts.max_resolves_in_step = counts.max_resolves_in_step.max(rounds);
        Ok(())
    }

    fn qs_counts_mut(&mut self) -> &mut quasi_static::QsCounts {
        let qs = self.solid.quasi_static.as_mut();
        &mut qs.expect("quasi-static scheme").counts
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

    /// The event catalogue (`seismicity:` in the scenario).
    pub fn catalogue(&self) -> Option<&seismicity::Catalogue> {
        self.seismicity.as_ref()
    }

    /// Close the catalogue's running events at the current time (the run ended, or failed and
    /// its outputs are being kept); a second call finds none.
    pub fn close_catalogue(&mut self) {
        if let Some(c) = self.seismicity.as_mut() {
            let inj = seismicity::injection(self.flow.as_ref());
            c.finish(&self.solid.view, self.clock.time, inj);
        }
    }

    /// The run continued from its state under another damping (`damping` in the scenario): a
    /// new simulation of the scenario with `damping`, which adopts this one's state (a study's
    /// second phase, e.g. relaxed, then free; the run parameters of a simulation do not change
    /// after setup). No output folder is attached.
    pub fn with_damping(
        &self,
        damping: hydrofrac_core::scenario::Damping,
    ) -> Result<Simulation, RunError> {
        // The edited scenario is validated again.
        let mut sc = self.scenario.clone();
        sc.damping = damping;
        let mut sim = Simulation::new(sc.validate()?, &self.extra_disable)?;
        let adopted = self
            .checkpoint_state()
            .and_then(|(_, state)| sim.adopt(state));
        adopted.map_err(|why| SetupError::invalid("damping", why))?;
        Ok(sim)
    }

    /// Hold the step at `dt` (s) from now on: not adapted, not shortened after splits (the
    /// production stage's relaxations, `Clock::hold`).
    pub fn hold_step(&mut self, dt: f64) {
        self.clock.hold(dt);
    }
    /// Switch the quasi-static step's inertia (`time.inertia`) during a run: the production
    /// stage's settling steps (`production_stage::settle`) turn it on, and off again.
    pub fn set_inertia(&mut self, inertia: hydrofrac_core::scenario::Inertia) {
        self.params.time.inertia = inertia;
    }
    pub fn flow_mut(&mut self) -> Option<&mut FlowPart> {
        self.flow.as_mut()
    }

    /// The fracture systems' state, to change (e.g. `tips.no_screen` for a comparison).
    pub fn fracture_mut(&mut self) -> &mut FractureState {
        &mut self.fracture
    }
    pub fn placed(&self) -> &[Placed] {
        &self.placed
    }

    /// What the quasi-static solver did (`None` with the explicit scheme).
    pub fn quasi_static_counts(&self) -> Option<quasi_static::QsCounts> {
        self.solid.quasi_static.as_ref().map(|q| q.counts)
    }
    /// The quasi-static solver (`None` with the explicit scheme), to read its state.
    pub fn quasi_static(&self) -> Option<&quasi_static::QuasiStatic> {
        self.solid.quasi_static.as_ref()
    }
    /// The quasi-static solver, to change its settings (tolerance, W updates) before a run.
    pub fn quasi_static_mut(&mut self) -> Option<&mut quasi_static::QuasiStatic> {
        self.solid.quasi_static.as_mut()
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
