//! The production stage of `hydrofrac run` (`production:` in a scenario; the seed's Example II,
//! Table 1 and Fig. 10): the steady flow between an injection and a production well held at
//! pressures, with apertures that respond to the fluid pressure through the joint model, on the
//! network at setup ("before") and at the end of the run ("after"); and the same with frozen
//! apertures. The derivation is in `docs/production.md`.
//!
//! Each (state, pressure drop) is a fixed-point iteration between two solves the engine has:
//! 1. the rock's equilibrium under the in-situ stress and a pressure p_c on both faces of every
//!    fracture cell c: the quasi-static scheme's Newton solve (`production.rock`, default), or
//!    dynamic relaxation, with the run's own systems (`internal_force`,
//!    `external_load`, `contact`, `fluid_pressure`, `damping`, `integrate`, and the fracture
//!    criterion and `split`, so a fracture may grow), the network's flow switched off and its
//!    mean pressures held at p; the hydraulic apertures a_c = max(delta_n, a_r) of that
//!    equilibrium (seed (12));
//! 2. the network's steady flow through those apertures between the wells
//!    ([`doublet_flow`]): new cell pressures G(p).
//!
//! p_0 = 0 (the pump off, the fractures drained): its apertures give the frozen rate. Then
//! p_{k+1} = p_k + w (G(p_k) - p_k) until max_c |G(p_k) - p_k| / dp and the rate's change are
//! below `production.tolerance`. SI units: m, Pa, s; rates m^2/s per metre of thickness.

use crate::checkpoint::State as SimState;
use crate::error::SetupError;
use crate::reservoir::NetworkFlow;
use crate::reservoir::doublet::{
    PressureWell, doublet_flow, doublet_wells, network_of_view, reaches,
};
use crate::scenario::{Damping, End, Inertia, ProductionStage, Scenario, SolidScheme};
use crate::sim::{Simulation, StopFlag};
use crate::systems::RunError;
use std::time::Instant;

/// Which network a production state is solved on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NetworkState {
    /// The model at setup (the pre-existing fractures).
    Before,
    /// The state at the end of the run (after the stimulation).
    After,
}

impl NetworkState {
    pub fn name(self) -> &'static str {
        match self {
            NetworkState::Before => "before",
            NetworkState::After => "after",
        }
    }
}

/// One production state at one pressure drop (a row of `production.csv`).
#[derive(Clone, Debug, PartialEq)]
pub struct ProductionRow {
    pub state: NetworkState,
    /// Pressure drop between the wells, Pa.
    pub dp: f64,
    /// Production rate of the coupled steady state, m^2/s per metre (0: a well reaches no
    /// fracture).
    pub rate: f64,
    /// The same through the apertures of the rock's equilibrium without fluid pressure.
    pub rate_frozen: f64,
    /// Fixed-point iterations taken, whether the tolerance was met, and the last change
    /// (max of the relative pressure and rate changes).
    pub iterations: usize,
    pub converged: bool,
    pub change: f64,
    /// Steps of the rock in all the equilibria of this state (quasi-static solves, or
    /// dynamic-relaxation steps).
    pub relax_steps: u64,
    /// Of those, the steps of implicit dynamics in the iteration's equilibria where the
    /// quasi-static solve found none from the last one (`production_stage::settle`; 0 where
    /// none was needed).
    pub settle_steps: u64,
    /// Fracture cells the production pressure opened (0: no fracture grew).
    pub new_cells: usize,
    /// Largest hydraulic aperture of the coupled state, m.
    pub max_aperture: f64,
    /// Wall time of this state, s.
    pub wall_s: f64,
    /// The rock that found the equilibria: `quasi-static`, or `relaxation` (by choice, or
    /// after the quasi-static Newton solve found no equilibrium: see `fallback`).
    pub rock: &'static str,
    /// Why the quasi-static solve was given up for this state, if it was.
    pub fallback: Option<String>,
    /// Whether the rock without fluid pressure reached its equilibrium before `rate_frozen`
    /// was taken: false where a fracture grew in each of the `max_iterations` relaxations
    /// (cells opening at tips without fluid pressure), so `rate_frozen` is of a rock that had
    /// not settled.
    pub frozen_settled: bool,
}

/// A solved production state: its row, and the coupled and frozen flows (for figures).
#[derive(Clone, Debug)]
pub struct StateSolve {
    pub row: ProductionRow,
    pub flow: NetworkFlow,
    pub frozen: NetworkFlow,
}

/// Errors of the production stage.
#[derive(Debug, thiserror::Error)]
pub enum ProductionError {
    #[error(transparent)]
    Setup(#[from] SetupError),
    #[error("production ({state}, dp = {dp:.4e} Pa): {error}")]
    Run {
        state: &'static str,
        dp: f64,
        error: RunError,
    },
    #[error("production: cannot start from the end of the run: {0}")]
    Adopt(String),
    /// A signal asked the run to stop (`Simulation::set_stop`): the stage ends between two
    /// steps of an equilibrium.
    #[error("production interrupted by signal {0}")]
    Interrupted(usize),
    #[error("production ({state}, dp = {dp:.4e} Pa): {why}")]
    Flow {
        state: &'static str,
        dp: f64,
        why: String,
    },
}

/// The scenario the production equilibria run: the run's model and joints, the rock of
/// `production.rock` (the quasi-static scheme's Newton solve, or the explicit scheme with local
/// damping 0.8 as dynamic relaxation; their static answer does not depend on the damping), no
/// outputs, no production stage. The flow boundaries stay (they make the run coupled, so the
/// fluid loads the faces) but the flow system is switched off.
pub fn production_scenario(sc: &Scenario) -> Scenario {
    let mut p = sc.clone();
    p.production = None;
    p.time.solid_scheme = sc
        .production
        .as_ref()
        .map_or(SolidScheme::QuasiStatic, |s| s.rock);
    p.time.end = End::Static {
        tol: sc.production.as_ref().map_or(1e-6, |s| s.static_tol),
        min_steps: 1,
    };
    p.time.max_steps = u64::MAX;
    p.time.dt = None;
    // Equilibria, no time: the rock's inertia (`time.inertia`) has no step to act over.
    p.time.inertia = Inertia::Off;
    // The relaxation sets fictitious masses of its own (`fictitious_masses`).
    p.time.selective_mass_scaling = None;
    p.output.checkpoint_every = None;
    p.output.figure_times.clear();
    p.damping = Damping::Local(0.8);
    p.boundary_schedule.clear();
    p
}

/// A simulation of [`production_scenario`] at setup, or from `start` (the end of the run). Its
/// step is the explicit bound of the rock and the joints without the fluid's stiffness (the
/// fluid does not move here: its pressure is a load).
pub fn production_sim(
    sc: &Scenario,
    start: Option<SimState>,
    stop: Option<&StopFlag>,
) -> Result<Simulation, ProductionError> {
    // The run's scenario, edited for the production stage: validated again.
    let edited = production_scenario(sc).validate()?;
    let mut sim = Simulation::new(edited, &["flow_substeps".to_string()])?;
    if let Some(stop) = stop {
        sim.set_stop(stop.clone());
    }
    if let Some(state) = start {
        sim.adopt(state).map_err(ProductionError::Adopt)?;
    }
    set_relaxation_step(&mut sim);
    if let (Some(qs), Some(stage)) = (sim.quasi_static_mut(), sc.production.as_ref()) {
        // The Newton solve's relative residual, as the relaxation's.
        qs.tol = stage.static_tol;
        // A signal ends a long solve between two Newton iterations: `equilibrate` rolls the
        // failed solve back and then stops.
        qs.interrupt = stop.cloned();
        // No time passes for the rock here (the fluid's pressure is a load), so halving a
        // step that found no equilibrium would retry the same problem: a failure is final
        // (and the state goes to relaxation, `run_production`): the step is held
        // (`set_relaxation_step`).
    }
    Ok(sim)
}

fn set_relaxation_step(sim: &mut Simulation) {
    let p = sim.params();
    let bound = crate::stability::solid(
        sim.model(),
        p.c_p,
        p.joint.k_max(),
        0.0,
        p.residual_aperture,
    );
    let mut dt = p.time.safety * bound;
    if p.time.solid_scheme == SolidScheme::Explicit {
        dt = fictitious_masses(sim, dt);
    }
    sim.hold_step(dt);
}

/// Dynamic relaxation's masses are fictitious (its answer is the static equilibrium, which
/// does not depend on them), so each node gets the mass that makes one common step stable
/// for it instead of every node taking the step of the smallest element (edges of 1.3 cm at
/// near-misses of fractures on a conforming mesh). Node i's Gershgorin bound is
/// dt_i = 2 sqrt(m_i / g_i), with g_i the larger of its two row sums of |K|
/// ([`crate::systems::solid::gershgorin_rows`], joints at max(K_n, K_t)), as
/// `time.mass_scaling` uses for static relaxation; unlike it, a node keeps its own mass where
/// that is already heavy enough, since the step is the larger of `dt`
/// and `safety` times the median dt_i, and m_i becomes max(m_i, g_i (dt / (2 safety))^2), so
/// every node satisfies dt <= safety dt_i. Returns the step (s); the view's masses are
/// changed (a rebuild after a split restores the model's, and the caller scales again).
fn fictitious_masses(sim: &mut Simulation, dt: f64) -> f64 {
    let p = sim.params();
    let (safety, kj) = (p.time.safety, p.joint.k_max());
    let v = sim.solid();
    let rows = crate::systems::solid::gershgorin_rows(v, &p.solid, |_| kj);
    let mut dt_node: Vec<f64> = rows
        .iter()
        .zip(&v.mass)
        .map(|(&r, m)| (r, m))
        .filter(|(gi, m)| *gi > 0.0 && **m > 0.0)
        .map(|(gi, m)| 2.0 * (m / gi).sqrt())
        .collect();
    if dt_node.is_empty() {
        return dt;
    }
    let mid = dt_node.len() / 2;
    let median = *dt_node.select_nth_unstable_by(mid, f64::total_cmp).1;
    let dt = dt.max(safety * median);
    crate::systems::solid::raise_masses(sim.solid_mut(), &rows, dt / safety);
    dt
}

/// Hold every cell's face pressure at `pressure` (Pa) and bring the rock to equilibrium (one
/// quasi-static step, or dynamic relaxation until the residual is below `tol`).
/// Returns the steps taken and whether the topology changed (a fracture grew: the views were
/// rebuilt and `pressure` no longer fits).
fn relax(
    sim: &mut Simulation,
    pressure: &[f64],
    tol: f64,
    max_steps: u64,
    report: &dyn Fn(&str),
) -> Result<Relaxed, RunError> {
    if sim.params().time.solid_scheme == SolidScheme::QuasiStatic {
        return equilibrate(sim, pressure, report);
    }
    let generation = sim.model().topology_generation;
    hold(sim, pressure);
    for k in 1..=max_steps {
        if sim.stop_signal().is_some() {
            return Ok(Relaxed::steps(k - 1, false));
        }
        sim.step_once()?;
        if sim.model().topology_generation != generation {
            // The new cells arrive empty; the caller solves the flow on the new network.
            set_relaxation_step(sim);
            return Ok(Relaxed::steps(k, true));
        }
        if sim.stats().residual() < tol {
            return Ok(Relaxed::steps(k, false));
        }
        if k % RELAX_REPORT_EVERY == 0 {
            report(&format!(
                "relaxation step {k}, residual {:.2e} (tolerance {tol:.0e})",
                sim.stats().residual()
            ));
        }
    }
    Ok(Relaxed::steps(max_steps, false))
}

/// What one equilibrium of the rock took: its steps (quasi-static solves or relaxation steps,
/// the settling steps included), the settling steps of [`settle`], and whether a fracture grew.
#[derive(Clone, Copy, Debug, Default)]
struct Relaxed {
    steps: u64,
    settle: u64,
    grew: bool,
}

impl Relaxed {
    fn steps(steps: u64, grew: bool) -> Self {
        Self {
            steps,
            settle: 0,
            grew,
        }
    }
}

/// Hold `pressure` (Pa, per cell) on the faces.
fn hold(sim: &mut Simulation, pressure: &[f64]) {
    let f = sim.flow_mut().expect("coupled run");
    f.view.pressure.copy_from_slice(pressure);
    let c = f.coupling.as_mut().expect("coupled run");
    c.p_mean.copy_from_slice(pressure);
}

/// Smallest share of a pressure change that [`equilibrate`] applies as one load increment.
pub const MIN_LOAD_INCREMENT: f64 = 1.0 / 64.0;

/// The quasi-static rock's equilibrium under `pressure`: one Newton solve from the last
/// equilibrium; where it finds none (1,690 joints switched to slip at once when Example II's
/// network on a conforming mesh took 9 MPa, and the iteration diverged), the change from the
/// pressure the rock holds now is applied in smaller increments, halved on each failure down
/// to [`MIN_LOAD_INCREMENT`] and doubled after two successes in a row, each an equilibrium with the
/// joints' slip committed (a quasi-static loading path, as a relaxation follows one).
/// Returns the solves that converged and whether a fracture grew.
fn equilibrate(
    sim: &mut Simulation,
    pressure: &[f64],
    report: &dyn Fn(&str),
) -> Result<Relaxed, RunError> {
    let generation = sim.model().topology_generation;
    let from = sim.flow().expect("coupled run").view.pressure.clone();
    let (mut done, mut inc, mut solves, mut streak) = (0.0f64, 1.0f64, 0, 0);
    let mut trial = vec![0.0; pressure.len()];
    while done < 1.0 {
        if sim.stop_signal().is_some() {
            break;
        }
        let s = (done + inc).min(1.0);
        for ((t, a), b) in trial.iter_mut().zip(&from).zip(pressure) {
            *t = a + s * (b - a);
        }
        hold(sim, &trial);
        let trial_state = Trial::take(sim, "a load increment")?;
        match sim.step_once() {
            Ok(()) => {
                solves += 1;
                if sim.model().topology_generation != generation {
                    return Ok(Relaxed::steps(solves, true));
                }
                done = s;
                // Grow after two successes in a row: doubling right after a failure retries
                // the step that failed.
                if streak > 0 {
                    inc = (2.0 * inc).min(1.0);
                }
                streak += 1;
            }
            Err(e @ RunError::QuasiStatic { .. }) => {
                let e = trial_state.undo(sim, generation, e)?;
                // A stop request interrupted the solve: end at the last equilibrium.
                if sim.stop_signal().is_some() {
                    break;
                }
                if inc <= MIN_LOAD_INCREMENT {
                    report(&format!(
                        "no equilibrium at {:.1} % increments ({e}); settling by implicit \
                         dynamics",
                        100.0 * inc
                    ));
                    return settle(sim, pressure, report)
                        .map(|(n, grew)| Relaxed {
                            steps: solves + n,
                            settle: n,
                            grew,
                        })
                        .map_err(|why| match (e, why) {
                            (
                                RunError::QuasiStatic { step, time, why: a },
                                RunError::QuasiStatic { why: b, .. },
                            ) => RunError::QuasiStatic {
                                step,
                                time,
                                why: format!("{a}; settling by implicit dynamics: {b}"),
                            },
                            (_, other) => other,
                        });
                }
                inc *= 0.5;
                streak = 0;
                report(&format!(
                    "no equilibrium at {:.0} % of the pressure change; increments of {:.1} %",
                    100.0 * s,
                    100.0 * inc
                ));
            }
            Err(e) => return Err(e),
        }
    }
    Ok(Relaxed::steps(solves, false))
}

/// The most steps [`settle`] takes.
pub const MAX_SETTLE_STEPS: u64 = 400;

/// The most Newton iterations of one settling step (a failed step is retried four times
/// shorter, which is cheaper than a long failed solve).
pub const SETTLE_MAX_ITER: usize = 20;

/// Steps of [`settle`] at its step's cap (half the shortest step that failed) before the cap
/// doubles.
pub const SETTLE_CAP_STEPS: u32 = 5;

/// [`settle`] tries the static solve again once the static residual is below this and a
/// tenth of what it was at the last try.
pub const SETTLE_STATIC_TRY: f64 = 1e-2;

/// The relative residual to which [`settle`] solves its steps while the static residual is
/// above 100 times `production.static_tol` (then, and for its static tries, to it): the
/// march's intermediate states are a path to the equilibrium, not the answer. Most long steps
/// that failed at the tolerance stalled between 1e-5 and 1e-4, a few joints flipping between
/// stick and slip. On Example II's production stage (from its 60 s checkpoint) 0.80 of the
/// stage's time, 833 settling steps against 909, the rates within 0.011 % (2026-12-07,
/// docs/example2.md); 1e-3 gave 0.78 with rates within 0.07 %.
pub const SETTLE_STEP_TOL: f64 = 1e-4;

/// The rock's equilibrium under `pressure` where the quasi-static Newton solve finds none from
/// the last equilibrium even in the smallest load increment (a block held only by joints that
/// slide: the Newton matrix is singular there, as no static equilibrium is near). The rock
/// moves by implicit dynamics with its real mass from rest (the quasi-static step with
/// `time.inertia: BackwardEuler`): each step solves F(u) = M (u - u_n - dt v_n) / dt^2, whose
/// mass term keeps the Newton matrix regular and moves a free block with its true
/// acceleration; backward Euler damps the rock's vibration, friction the sliding. The step
/// starts at 10 times the rock's explicit bound and doubles after each step, up to half the
/// shortest step that found no equilibrium (a failed step is taken back and quartered; the
/// cap doubles after [`SETTLE_CAP_STEPS`] steps at it; each solved to [`SETTLE_STEP_TOL`] until
/// the march nears the end). A step's static residual is its inertia force, F(u). Once that is below
/// [`SETTLE_STATIC_TRY`] (and a tenth of its value at the last try) the static Newton solve is
/// tried again from there; the march ends when that converges or when the static residual
/// itself is below `production.static_tol` of the loads and reactions: the state is then a
/// static equilibrium like any other row's. The path to it is the rock's motion, one of the
/// many that friction allows; the row counts the steps (`settle_steps`). Returns the steps and
/// whether a fracture grew.
fn settle(
    sim: &mut Simulation,
    pressure: &[f64],
    report: &dyn Fn(&str),
) -> Result<(u64, bool), RunError> {
    let generation = sim.model().topology_generation;
    let dt_rock = sim.dt();
    let qs = sim
        .quasi_static_mut()
        .expect("settling is the quasi-static rock's");
    let (tol, max_iter) = (qs.tol, qs.max_iter);
    qs.max_iter = SETTLE_MAX_ITER;
    hold(sim, pressure);
    // From rest: the last equilibrium.
    sim.solid_mut().v.iter_mut().for_each(|v| *v = [0.0; 2]);
    let out = settle_steps(sim, dt_rock, tol, generation, report);
    sim.set_inertia(Inertia::Off);
    // The last step's velocity is the pseudo-time's, not the rock's.
    sim.solid_mut().v.iter_mut().for_each(|v| *v = [0.0; 2]);
    if let Some(qs) = sim.quasi_static_mut() {
        qs.step_start = None;
        qs.max_iter = max_iter;
        qs.tol = tol;
        qs.forget_factor();
    }
    sim.hold_step(dt_rock);
    out
}

/// One step of [`settle`]: the step of length `dt` (with the inertia `sim` has now) from the
/// current state, taken back where it finds no equilibrium (`Ok(false)`, [`Trial::undo`]);
/// `Ok(true)` when it converged.
fn settle_step(sim: &mut Simulation, dt: f64, generation: u64) -> Result<bool, RunError> {
    let trial = Trial::take(sim, "a settling step")?;
    sim.hold_step(dt);
    match sim.step_once() {
        Ok(()) => Ok(true),
        Err(e @ RunError::QuasiStatic { .. }) => trial.undo(sim, generation, e).map(|_| false),
        Err(e) => Err(e),
    }
}

/// The rock's state before a trial step of the production stage ([`equilibrate`]'s load
/// increments, [`settle`]'s steps): displacements, velocities and the joints' contact states,
/// and where a criterion can split faces the whole state, since a step that splits faces and
/// then fails has changed the topology (the trial split's nodes).
struct Trial {
    u: Vec<[f64; 2]>,
    v: Vec<[f64; 2]>,
    joints: Vec<crate::components::JointState>,
    whole: Option<crate::checkpoint::State>,
}

impl Trial {
    /// The state now, before `what` (for a message).
    fn take(sim: &Simulation, what: &str) -> Result<Self, RunError> {
        let whole = match sim.params().criterion {
            Some(_) => Some(
                sim.checkpoint_state()
                    .map_err(|why| RunError::QuasiStatic {
                        step: sim.step(),
                        time: sim.time(),
                        why: format!("production stage: the state before {what}: {why}"),
                    })?
                    .1,
            ),
            None => None,
        };
        let v = sim.solid();
        Ok(Self {
            u: v.u.clone(),
            v: v.v.clone(),
            joints: v.joint_state.clone(),
            whole,
        })
    }

    /// Take back the trial step that failed with `e` (the topology `generation` before it):
    /// the whole state where it split faces, else the displacements, velocities and contact
    /// states; the kept factor is dropped (its joint axes are the failed iterate's). `Ok(e)`
    /// once taken back; `Err(e)` where a split cannot be (no whole state was taken).
    fn undo(
        self,
        sim: &mut Simulation,
        generation: u64,
        e: RunError,
    ) -> Result<RunError, RunError> {
        if sim.model().topology_generation != generation {
            let Some(state) = self.whole else {
                return Err(e);
            };
            sim.adopt(state).map_err(|why| RunError::QuasiStatic {
                step: sim.step(),
                time: sim.time(),
                why: format!("production stage: rolling back a failed split: {why}"),
            })?;
        } else {
            let v = sim.solid_mut();
            v.u.copy_from_slice(&self.u);
            v.v.copy_from_slice(&self.v);
            v.joint_state.copy_from_slice(&self.joints);
        }
        if let Some(qs) = sim.quasi_static_mut() {
            qs.forget_factor();
        }
        Ok(e)
    }
}

fn settle_steps(
    sim: &mut Simulation,
    dt_rock: f64,
    tol: f64,
    generation: u64,
    report: &dyn Fn(&str),
) -> Result<(u64, bool), RunError> {
    let fail = |sim: &Simulation, why: String| RunError::QuasiStatic {
        step: sim.step(),
        time: sim.time(),
        why,
    };
    let (mut dt, mut dt_fail, mut at_cap) = (10.0 * dt_rock, f64::INFINITY, 0);
    let (mut residual, mut last_try) = (f64::INFINITY, f64::INFINITY);
    // The march's steps are solved to SETTLE_STEP_TOL until the static residual is within
    // 100 times the tolerance; from there on, and for every static try, to the tolerance.
    let loose = SETTLE_STEP_TOL.max(tol);
    let mut strict = loose <= tol;
    let set_tol = |sim: &mut Simulation, t: f64| {
        if let Some(q) = sim.quasi_static_mut() {
            q.tol = t;
        }
    };
    for k in 1..=MAX_SETTLE_STEPS {
        set_tol(sim, if strict { tol } else { loose });
        if sim.stop_signal().is_some() {
            return Err(fail(sim, "interrupted".into()));
        }
        sim.set_inertia(Inertia::BackwardEuler);
        if !settle_step(sim, dt, generation)? {
            (dt_fail, at_cap) = (dt_fail.min(dt), 0);
            dt *= 0.25;
            if dt < dt_rock {
                return Err(fail(
                    sim,
                    format!("the step fell below the rock's explicit bound ({dt_rock:.2e} s)"),
                ));
            }
            continue;
        }
        if sim.model().topology_generation != generation {
            return Ok((k, true));
        }
        // The step's inertia force balances F(u): it is the static residual.
        let start = sim.quasi_static().and_then(|q| q.step_start.as_ref());
        let r2 = start.expect("a step with inertia").force_norm2(sim.solid());
        residual = (r2 / sim.stats().ref2.max(f64::MIN_POSITIVE)).sqrt();
        if residual < tol && strict {
            return Ok((k, false));
        }
        if residual < 100.0 * tol {
            strict = true;
        }
        if residual < SETTLE_STATIC_TRY && residual < 0.1 * last_try {
            last_try = residual;
            set_tol(sim, tol);
            sim.set_inertia(Inertia::Off);
            if settle_step(sim, dt, generation)? {
                return Ok((k, sim.model().topology_generation != generation));
            }
        }
        // The cap lifts after SETTLE_CAP_STEPS steps at it: the motion may allow longer
        // steps as it slows.
        if 2.0 * dt > 0.5 * dt_fail {
            at_cap += 1;
            if at_cap >= SETTLE_CAP_STEPS {
                (dt_fail, at_cap) = (2.0 * dt_fail, 0);
            }
        }
        dt = (2.0 * dt).min(0.5 * dt_fail).max(dt);
        if k % 20 == 0 {
            report(&format!(
                "settling step {k}, static residual {residual:.2e} (tolerance {tol:.0e}), \
                 step {dt:.2e} s"
            ));
        }
    }
    Err(fail(
        sim,
        format!(
            "not settled in {MAX_SETTLE_STEPS} steps: static residual {residual:.2e} \
             (tolerance {tol:.0e})"
        ),
    ))
}

/// The hydraulic apertures max(delta_n, a_r) of the rock's current state, per cell, m (seed
/// (12); cells without a joint keep their aperture).
pub fn apertures(sim: &Simulation) -> Vec<f64> {
    let f = sim.flow().expect("coupled run");
    let c = f.coupling.as_ref().expect("coupled run");
    let a_r = sim.params().residual_aperture;
    (0..f.view.n_cells())
        .map(|cell| match c.cell_joint[cell] {
            u32::MAX => f.view.aperture[cell],
            k => crate::fractures::hydraulic_aperture(
                crate::view::joint_frame(sim.solid(), k as usize).dn,
                a_r,
            ),
        })
        .collect()
}

/// The network of the rock's current state with apertures `a`.
fn network(sim: &Simulation, a: &[f64]) -> NetworkFlow {
    let mut net = network_of_view(&sim.flow().expect("coupled run").view, None);
    for (cell, &ap) in net.cells.iter_mut().zip(a) {
        cell.2 = ap;
    }
    net
}

/// The steady flow of `net` between the wells: (production rate, cell pressures, the flow).
/// A network that a well does not reach produces nothing (zero pressures).
fn steady(
    net: &NetworkFlow,
    wells: &[PressureWell; 2],
    viscosity: f64,
    reach: f64,
) -> Result<(f64, Vec<f64>, NetworkFlow), String> {
    if !reaches(net, wells, reach) {
        return Ok((0.0, vec![0.0; net.cells.len()], net.clone()));
    }
    let prod = doublet_flow(net, wells, viscosity, reach).map_err(|e| e.to_string())?;
    // 0 - q, not -q: no negative zero in the table.
    Ok((0.0 - prod.wells[1].1, prod.pressure, prod.flow))
}

/// Relaxation steps between two progress reports.
const RELAX_REPORT_EVERY: u64 = 2000;

/// Solve one production state at pressure drop `dp` (Pa) on `sim` (freshly made by
/// [`production_sim`]: the iteration moves its rock).
pub fn solve_state(
    sim: &mut Simulation,
    stage: &ProductionStage,
    state: NetworkState,
    dp: f64,
) -> Result<StateSolve, ProductionError> {
    solve_state_reporting(sim, stage, state, dp, &|_| {})
}

/// [`solve_state`], telling `report` where the iteration is (each fixed-point iteration, and
/// every [`RELAX_REPORT_EVERY`] relaxation steps), so a slow state can be told from a stuck one.
pub fn solve_state_reporting(
    sim: &mut Simulation,
    stage: &ProductionStage,
    state: NetworkState,
    dp: f64,
    report: &dyn Fn(&str),
) -> Result<StateSolve, ProductionError> {
    let on = Solving {
        stage,
        state,
        dp,
        wells: doublet_wells(&stage.wells, dp),
        mu: sim.params().fluid.mu,
        cells0: cell_count(sim),
        t0: Instant::now(),
    };
    // p_0 = 0: the frozen apertures.
    let (steps, frozen_settled) = relax_frozen(sim, stage, report).map_err(|e| on.run_err(e))?;
    let frozen_net = network(sim, &apertures(sim));
    let (rate_frozen, target, frozen) = on.steady(&frozen_net)?;
    // The first iterate is G(p_0) itself; the later ones are under-relaxed.
    let mut it = FixedPoint {
        p: vec![0.0; target.len()],
        target,
        rate: rate_frozen,
        flow: frozen.clone(),
        a: Vec::new(),
        iterations: 0,
        converged: false,
        change: f64::INFINITY,
        steps,
        settle_steps: 0,
    };
    on.iterate(sim, &mut it, report)?;
    let row = on.row(sim, &it, rate_frozen, frozen_settled);
    Ok(StateSolve {
        row,
        flow: it.flow,
        frozen,
    })
}

/// Fracture cells of the simulation's network now.
fn cell_count(sim: &Simulation) -> usize {
    sim.flow().map_or(0, |f| f.view.n_cells())
}

/// The rock without fluid pressure (p_0 = 0, the frozen apertures), relaxed again after any
/// growth until none, at most `max_iterations` times. Returns the steps and whether it
/// settled (no fracture grew in the last relaxation).
fn relax_frozen(
    sim: &mut Simulation,
    stage: &ProductionStage,
    report: &dyn Fn(&str),
) -> Result<(u64, bool), RunError> {
    let mut steps = 0;
    for _ in 0..stage.max_iterations {
        if sim.stop_signal().is_some() {
            break;
        }
        let p0 = vec![0.0; cell_count(sim)];
        report("the rock without fluid pressure (frozen apertures)");
        let r = relax(sim, &p0, stage.static_tol, stage.max_steps, report)?;
        steps += r.steps;
        if !r.grew {
            return Ok((steps, true));
        }
    }
    Ok((steps, false))
}

/// One production state being solved: the stage, the network state, the pressure drop (Pa)
/// and its wells, the viscosity (Pa s), the fracture cells at the start and the start time.
struct Solving<'a> {
    stage: &'a ProductionStage,
    state: NetworkState,
    dp: f64,
    wells: [PressureWell; 2],
    mu: f64,
    cells0: usize,
    t0: Instant,
}

/// The fixed-point iteration p_{k+1} = p_k + w (G(p_k) - p_k) as it stands.
struct FixedPoint {
    /// The cells' pressures p_k, Pa.
    p: Vec<f64>,
    /// G(p_k): the steady flow's cell pressures through p_k's apertures, Pa.
    target: Vec<f64>,
    /// The production rate of the last steady flow, m^2/s, and that flow.
    rate: f64,
    flow: NetworkFlow,
    /// The hydraulic apertures of the last equilibrium, m.
    a: Vec<f64>,
    iterations: usize,
    converged: bool,
    /// The last change (max of the relative pressure and rate changes).
    change: f64,
    /// Steps of the rock in all the equilibria.
    steps: u64,
    /// Of those, the settling steps ([`settle`]) of the iteration's equilibria.
    settle_steps: u64,
}

impl Solving<'_> {
    fn run_err(&self, error: RunError) -> ProductionError {
        ProductionError::Run {
            state: self.state.name(),
            dp: self.dp,
            error,
        }
    }

    /// [`steady`] between the state's wells.
    fn steady(&self, net: &NetworkFlow) -> Result<(f64, Vec<f64>, NetworkFlow), ProductionError> {
        steady(net, &self.wells, self.mu, self.stage.wells.reach).map_err(|why| {
            ProductionError::Flow {
                state: self.state.name(),
                dp: self.dp,
                why,
            }
        })
    }

    /// Iterate until the change is below `production.tolerance`, `max_iterations` or a stop
    /// signal: each iterate an equilibrium of the rock under p_k and the steady flow through
    /// its apertures. Where a fracture grew the iteration starts again from the new network.
    fn iterate(
        &self,
        sim: &mut Simulation,
        it: &mut FixedPoint,
        report: &dyn Fn(&str),
    ) -> Result<(), ProductionError> {
        let stage = self.stage;
        let mut first = true;
        while it.iterations < stage.max_iterations && sim.stop_signal().is_none() {
            it.iterations += 1;
            let k = it.iterations;
            let omega = if first { 1.0 } else { stage.relaxation };
            first = false;
            for (pc, tc) in it.p.iter_mut().zip(&it.target) {
                *pc += omega * (tc - *pc);
            }
            let Relaxed {
                steps: n,
                settle,
                grew,
            } = relax(sim, &it.p, stage.static_tol, stage.max_steps, report)
                .map_err(|e| self.run_err(e))?;
            it.steps += n;
            it.settle_steps += settle;
            it.a = apertures(sim);
            let (r, next, fl) = self.steady(&network(sim, &it.a))?;
            if grew {
                // A fracture grew: start again from the flow of the new network.
                report(&format!(
                    "iteration {k}: a fracture grew ({} new cells in this state); rate \
                     {r:.4e} m^2/s on the new network",
                    cell_count(sim).saturating_sub(self.cells0)
                ));
                (it.p, it.target, it.rate, it.flow) = (next.clone(), next, r, fl);
                first = true;
                continue;
            }
            it.change = iteration_change(&it.p, &next, self.dp, r, it.rate);
            (it.target, it.rate, it.flow) = (next, r, fl);
            report(&format!(
                "iteration {k}: rate {:.4e} m^2/s, change {:.2e} (tolerance {:.0e}), {:.0} s",
                it.rate,
                it.change,
                stage.tolerance,
                self.t0.elapsed().as_secs_f64()
            ));
            if it.change < stage.tolerance {
                it.converged = true;
                break;
            }
        }
        Ok(())
    }

    /// The state's row of `production.csv` once the iteration ended.
    fn row(
        &self,
        sim: &Simulation,
        it: &FixedPoint,
        rate_frozen: f64,
        frozen_settled: bool,
    ) -> ProductionRow {
        ProductionRow {
            state: self.state,
            dp: self.dp,
            rate: it.rate,
            rate_frozen,
            iterations: it.iterations,
            converged: it.converged,
            change: it.change,
            relax_steps: it.steps,
            settle_steps: it.settle_steps,
            new_cells: cell_count(sim).saturating_sub(self.cells0),
            max_aperture: it.a.iter().fold(0.0, |m: f64, &x| m.max(x)),
            wall_s: self.t0.elapsed().as_secs_f64(),
            rock: match sim.params().time.solid_scheme {
                SolidScheme::QuasiStatic => "quasi-static",
                SolidScheme::Explicit => "relaxation",
            },
            fallback: None,
            frozen_settled,
        }
    }
}

/// The fixed-point iteration's change: the largest change of a cell's pressure relative to
/// `dp`, and the largest of that and the rate's relative change (`r` the new rate, `rate` the
/// last) unless nothing flows.
fn iteration_change(p: &[f64], next: &[f64], dp: f64, r: f64, rate: f64) -> f64 {
    let dp_change = p
        .iter()
        .zip(next)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / dp;
    let rate_change = (r - rate).abs() / r.abs().max(f64::MIN_POSITIVE);
    if r == 0.0 && rate == 0.0 {
        dp_change
    } else {
        dp_change.max(rate_change)
    }
}

/// Every production state of `sc.production`: before (from setup) and after (from `end`, the
/// state at the end of the run), at each pressure drop, each from its own start. Also returns
/// the solved states at the middle pressure drop (the seed's Fig. 10).
/// The before and the after states run side by side (`rayon::join`: independent simulations,
/// so the same bits for any number of threads; rows in the order before, after).
/// `report` hears where the stage is (the state, its iteration), for a progress display.
pub fn run_production(
    sc: &Scenario,
    end: SimState,
    stop: Option<&StopFlag>,
    report: &(dyn Fn(&str) + Sync),
) -> Result<StageResult, ProductionError> {
    let stage = sc
        .production
        .as_ref()
        .ok_or_else(|| SetupError::invalid("production", "the scenario has no production"))?;
    let (before, after) = rayon::join(
        || run_states(sc, stage, NetworkState::Before, None, stop, report),
        || run_states(sc, stage, NetworkState::After, Some(&end), stop, report),
    );
    let (mut out, after) = (before?, after?);
    out.rows.extend(after.rows);
    out.figures.extend(after.figures);
    out.failed.extend(after.failed);
    Ok(out)
}

/// The production states of one network `state` (from setup, or from `end`), at each pressure
/// drop in turn, each from its own start.
fn run_states(
    sc: &Scenario,
    stage: &ProductionStage,
    state: NetworkState,
    end: Option<&SimState>,
    stop: Option<&StopFlag>,
    report: &(dyn Fn(&str) + Sync),
) -> Result<StageResult, ProductionError> {
    let states = States {
        sc,
        stage,
        state,
        end,
        stop,
        report,
    };
    let drops = &stage.wells.pressure_drops;
    let middle = drops.len() / 2;
    let mut out = StageResult::default();
    // Where the quasi-static rock found no equilibrium at a lower drop of this state, a
    // higher drop (more pressure, more sliding) goes to relaxation without trying it.
    let mut failed_at: Option<String> = None;
    for (k, &dp) in drops.iter().enumerate() {
        let s = match states.solve_drop(dp, &mut failed_at) {
            Ok(s) => s,
            // A state that fails (a blow-up: a block expelled where no static equilibrium
            // holds it, say) is reported and the stage goes on with the next one, so the
            // states solved are kept.
            Err(e @ (ProductionError::Run { .. } | ProductionError::Flow { .. })) => {
                tracing::warn!("{e}");
                report(&format!("{}: failed ({e})", states.label(dp)));
                out.failed.push(FailedState {
                    state,
                    dp,
                    error: e.to_string(),
                });
                continue;
            }
            Err(e) => return Err(e),
        };
        tracing::info!(
            "production {} dp = {:.1} MPa: rate {:.4e} (frozen {:.4e}) m^2/s, {} iterations",
            state.name(),
            dp / 1e6,
            s.row.rate,
            s.row.rate_frozen,
            s.row.iterations
        );
        out.rows.push(s.row.clone());
        if k == middle {
            out.figures.push(s);
        }
    }
    Ok(out)
}

/// The states of one network being solved: the scenario and its stage, the network state, its
/// start (`None`: setup), the stop signal and the progress report.
struct States<'a> {
    sc: &'a Scenario,
    stage: &'a ProductionStage,
    state: NetworkState,
    end: Option<&'a SimState>,
    stop: Option<&'a StopFlag>,
    report: &'a (dyn Fn(&str) + Sync),
}

impl States<'_> {
    /// How the progress report names the state at `dp`.
    fn label(&self, dp: f64) -> String {
        format!("production {} dp = {:.1} MPa", self.state.name(), dp / 1e6)
    }

    /// The state at pressure drop `dp` with the rock of `production.rock`; where the
    /// quasi-static rock fails, or failed at a lower drop (`failed_at`, then set), by dynamic
    /// relaxation.
    fn solve_drop(
        &self,
        dp: f64,
        failed_at: &mut Option<String>,
    ) -> Result<StateSolve, ProductionError> {
        let (state, report, label) = (self.state, self.report, self.label(dp));
        if let Some(lower) = failed_at {
            report(&format!("{label}: relaxation ({lower})"));
            return self.relaxed(dp, lower.clone());
        }
        let tell = |m: &str| report(&format!("{label}: {m}"));
        let mut sim = production_sim(self.sc, self.end.cloned(), self.stop)?;
        let solved = solve_state_reporting(&mut sim, self.stage, state, dp, &tell);
        if let Some(sig) = sim.stop_signal() {
            return Err(ProductionError::Interrupted(sig));
        }
        match solved {
            // Past the friction limit the rock may have no static equilibrium under a trial
            // pressure (a block held by sliding joints alone): the Newton solve cannot find
            // one, the relaxation follows the sliding until it stops.
            Err(ProductionError::Run {
                error: error @ RunError::QuasiStatic { .. },
                ..
            }) => {
                tracing::warn!(
                    "production {} dp = {:.1} MPa: the quasi-static rock failed \
                     ({error}); dynamic relaxation instead",
                    state.name(),
                    dp / 1e6
                );
                report(&format!(
                    "{label}: the quasi-static rock failed ({error}); relaxation instead"
                ));
                *failed_at = Some(format!(
                    "not tried: the quasi-static rock failed at dp = {:.1} MPa of this \
                     state",
                    dp / 1e6
                ));
                self.relaxed(dp, error.to_string())
            }
            r => r,
        }
    }

    /// The state at `dp` by dynamic relaxation, `why` the quasi-static rock was not used.
    fn relaxed(&self, dp: f64, why: String) -> Result<StateSolve, ProductionError> {
        let mut relaxed = self.sc.clone();
        if let Some(p) = relaxed.production.as_mut() {
            p.rock = SolidScheme::Explicit;
        }
        let mut sim = production_sim(&relaxed, self.end.cloned(), self.stop)?;
        let label = self.label(dp);
        let tell = |m: &str| (self.report)(&format!("{label} (relaxation): {m}"));
        let solved = solve_state_reporting(&mut sim, self.stage, self.state, dp, &tell);
        if let Some(sig) = sim.stop_signal() {
            return Err(ProductionError::Interrupted(sig));
        }
        let mut s = solved?;
        s.row.fallback = Some(why);
        Ok(s)
    }
}

/// A production state that failed (`summary.json` `production.failed`; no row).
#[derive(Clone, Debug)]
pub struct FailedState {
    pub state: NetworkState,
    pub dp: f64,
    pub error: String,
}

/// What [`run_production`] solved: a row per state solved, the middle drop's flows (figures),
/// and the states that failed.
#[derive(Clone, Debug, Default)]
pub struct StageResult {
    pub rows: Vec<ProductionRow>,
    pub figures: Vec<StateSolve>,
    pub failed: Vec<FailedState>,
}

/// `production.csv`: `state,dp,rate,rate_frozen` (Pa, m^2/s per metre) and the iteration's
/// record (`iterations,converged,change,relax_steps,new_cells,max_aperture,wall_s,rock`).
pub fn production_csv(rows: &[ProductionRow]) -> String {
    let mut s = String::from(
        "state,dp,rate,rate_frozen,iterations,converged,change,relax_steps,new_cells,max_aperture,wall_s,rock\n",
    );
    for r in rows {
        s += &format!(
            "{},{},{:e},{:e},{},{},{:e},{},{},{:e},{:.3},{}\n",
            r.state.name(),
            r.dp,
            r.rate,
            r.rate_frozen,
            r.iterations,
            r.converged,
            if r.change.is_finite() { r.change } else { 0.0 },
            r.relax_steps,
            r.new_cells,
            r.max_aperture,
            r.wall_s,
            r.rock
        );
    }
    s
}

/// The stage's `summary.json` warnings: a state that did not converge, a rock without fluid
/// pressure that did not settle, a state that failed.
pub fn stage_warnings(rows: &[ProductionRow], failed: &[FailedState]) -> Vec<String> {
    let mut warnings = Vec::new();
    for r in rows {
        let (state, dp) = (r.state.name(), r.dp / 1e6);
        if !r.converged {
            // The change is measured from the second iteration on.
            let change = if r.change.is_finite() {
                format!("last change {:.1e}", r.change)
            } else {
                "no change measured".to_string()
            };
            warnings.push(format!(
                "production {state} dp = {dp:.1} MPa did not converge in {} iterations \
                 ({change})",
                r.iterations
            ));
        }
        if !r.frozen_settled {
            warnings.push(format!(
                "production {state} dp = {dp:.1} MPa: the rock without fluid pressure did \
                 not settle (a fracture grew in each relaxation), so rate_frozen is \
                 not an equilibrium's"
            ));
        }
    }
    for f in failed {
        warnings.push(format!(
            "production {} dp = {:.1} MPa failed, no row: {}",
            f.state.name(),
            f.dp / 1e6,
            f.error
        ));
    }
    warnings
}

/// `summary.json`'s `production`: the wells and one entry per row (ratios after / before).
pub fn production_json(
    stage: &ProductionStage,
    rows: &[ProductionRow],
    failed: &[FailedState],
) -> serde_json::Value {
    let w = &stage.wells;
    let entries: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let mut e = serde_json::json!({
                "state": r.state.name(), "dp": r.dp, "rate": r.rate, "rate_frozen": r.rate_frozen,
                "iterations": r.iterations, "converged": r.converged,
                "change": if r.change.is_finite() { r.change } else { 0.0 },
                "relax_steps": r.relax_steps, "settle_steps": r.settle_steps,
                "new_cells": r.new_cells,
                "max_aperture": r.max_aperture, "wall_s": r.wall_s, "rock": r.rock,
                "frozen_settled": r.frozen_settled,
            });
            if let Some(why) = &r.fallback {
                e["quasi_static_failed"] = serde_json::json!(why);
            }
            e
        })
        .collect();
    let ratios: Vec<serde_json::Value> = w
        .pressure_drops
        .iter()
        .map(|&dp| {
            let rate = |s: NetworkState, frozen: bool| {
                rows.iter()
                    .find(|r| r.state == s && r.dp == dp)
                    .map(|r| if frozen { r.rate_frozen } else { r.rate })
            };
            // Omitted (not null) when nothing flows before or a state failed.
            let mut v = serde_json::json!({"dp": dp});
            for (key, frozen) in [
                ("after_over_before", false),
                ("after_over_before_frozen", true),
            ] {
                let b = rate(NetworkState::Before, frozen);
                if let (Some(b), Some(a)) = (b, rate(NetworkState::After, frozen))
                    && b > 0.0
                {
                    v[key] = serde_json::json!(a / b);
                }
            }
            v
        })
        .collect();
    let mut v = serde_json::json!({
        "injection": w.injection, "production": w.production,
        "production_pressure": w.production_pressure, "reach": w.reach,
        "rows": entries, "ratios": ratios,
        "fractures_grew": rows.iter().any(|r| r.new_cells > 0),
    });
    if !failed.is_empty() {
        v["failed"] = failed
            .iter()
            .map(|f| serde_json::json!({"state": f.state.name(), "dp": f.dp, "error": f.error}))
            .collect();
    }
    v
}

/// The seed's Fig. 9: the network of `view` (reference positions), new fracture cells coloured
/// by the time they opened (s), pre-existing ones grey.
pub fn network_figure(
    path: &std::path::Path,
    title: &str,
    view: &crate::flow::FlowView,
    markers: &[([f64; 2], &str)],
) -> Result<(), crate::plot::PlotError> {
    let segments: Vec<crate::plot::Segment> = view
        .cell_nodes
        .iter()
        .map(|n| crate::plot::Segment {
            a: view.node_ref[n[0] as usize],
            b: view.node_ref[n[1] as usize],
        })
        .collect();
    let values: Vec<f64> = view
        .kind
        .iter()
        .zip(&view.created_t)
        .map(|(k, &t)| {
            if *k == crate::components::CellKind::New {
                t
            } else {
                f64::NAN
            }
        })
        .collect();
    crate::plot::network(
        path,
        title,
        &segments,
        &values,
        "new fracture: time opened [s] (grey: pre-existing)",
        crate::plot::ColourScale::Linear,
        None,
        markers,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square block of rock (4 m x 4 m, in a 20 m x 20 m body under sigma_xx = -20 MPa,
    /// sigma_yy = -10 MPa) enclosed by four fractures, all held at 25 MPa: every face opens,
    /// the block floats and the quasi-static Newton matrix is singular (its rigid motions have
    /// no stiffness), so the static solve fails. Settling by implicit dynamics finds the
    /// equilibrium: the uniform pressure puts no net force on the block, so it stays about
    /// where it is (its mean displacement within 5 % of the faces' opening) and every face
    /// is open.
    #[test]
    fn a_floating_block_settles_where_the_static_solve_fails() {
        let text = r#"(
            name: "island",
            mesh: Regular(width: 20.0, height: 20.0, h: 1.0),
            material: (young: 20e9, poisson: 0.2, density: 2700.0),
            boundary: InSitu(sxx: -20e6, syy: -10e6),
            initial_state: InSitu,
            fracture: Some((
                residual_aperture: 5e-4,
                preexisting: [
                    (from: (8.0, 8.0), to: (12.0, 8.0)),
                    (from: (12.0, 8.0), to: (12.0, 12.0)),
                    (from: (12.0, 12.0), to: (8.0, 12.0)),
                    (from: (8.0, 12.0), to: (8.0, 8.0)),
                ],
                friction_deg: 30.0,
                normal_stiffness: Some(20e9),
                shear_stiffness: Some(8.3e9),
            )),
            flow_boundaries: [(name: "well", at: Node((8.0, 8.0)), kind: Pressure(0.0))],
            time: (end: Time(1.0), flow_scheme: Implicit, solid_scheme: QuasiStatic),
            production: Some((wells: (injection: (8.0, 8.0), production: (12.0, 12.0),
                production_pressure: 0.0, pressure_drops: [9e6], reach: 0.5))),
        )"#;
        let sc = Scenario::parse(text, "island.ron").unwrap();
        let sc = sc.validate().unwrap().into_inner();
        let p = vec![25e6; 16];
        // The static solve alone, in the smallest increment too, finds no equilibrium.
        let mut sim = production_sim(&sc, None, None).unwrap();
        assert_eq!(cell_count(&sim), 16);
        hold(&mut sim, &p);
        let e = sim
            .step_once()
            .expect_err("a floating block has no static Newton solve");
        assert!(e.to_string().contains("quasi-static"), "{e}");
        // Settling: an equilibrium, reached by implicit dynamics.
        let mut sim = production_sim(&sc, None, None).unwrap();
        let r = equilibrate(&mut sim, &p, &|_| {}).expect("settled");
        assert!(r.settle > 0 && !r.grew, "{r:?}");
        let v = sim.solid();
        let c = sim.flow().unwrap().coupling.as_ref().unwrap();
        let opening: Vec<f64> = v.joint_state.iter().map(|j| j.opening).collect();
        assert!(!opening.is_empty() && c.joint_cell.len() == opening.len());
        let (min, max) = opening
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &o| (a.min(o), b.max(o)));
        assert!(min > 0.0, "a face stayed closed: openings {min:e}..{max:e}");
        let (mut mean, mut n) = ([0.0; 2], 0.0);
        for i in 0..v.n_nodes() {
            let x = v.x0[i];
            if (8.5..11.5).contains(&x[0]) && (8.5..11.5).contains(&x[1]) {
                mean[0] += v.u[i][0];
                mean[1] += v.u[i][1];
                n += 1.0;
            }
        }
        let (mx, my) = (mean[0] / n, mean[1] / n);
        assert!(n >= 9.0);
        // Any position of a floating block under no net force is an equilibrium; the motion
        // from rest leaves it where it was (the in-situ displacement at the centre (10, 10) is
        // zero) to within 5 % of the faces' opening (measured 1.9 %, in y).
        assert!(
            mx.hypot(my) < 0.05 * max,
            "block drifted by ({mx:e}, {my:e}), opening {max:e}"
        );
        // And the state is an equilibrium, checked on its own: with every face open the
        // joints carry nothing, so the rock's internal force and the fluid's pressure on the
        // faces balance at every free dof.
        let mut w = v.clone();
        crate::systems::solid::internal_force(&mut w, &sim.params().solid);
        crate::systems::fracture::fluid_pressure(&mut w, &c.joint_cell, &p);
        let (mut free, mut fixed) = (0.0, 0.0);
        for i in 0..w.n_nodes() {
            for d in 0..2 {
                let f = w.force[i][d] * w.force[i][d];
                if w.fixed[i] & (1 << d) == 0 {
                    free += f;
                } else {
                    fixed += f;
                }
            }
        }
        let r = (free / fixed).sqrt();
        // The solve's own test is 1e-6 of the reactions and loads (no loads here, the
        // boundaries are displacements): measured 7.8e-7; 2e-6 leaves room for the order of
        // summation, not for a state out of balance.
        assert!(r < 2e-6, "static residual {r:e}");
    }

    /// A state that failed leaves its drop without a ratio (not a ratio against a zero rate)
    /// and is listed under `failed`; the rest of the summary is as with every state solved.
    #[test]
    fn a_failed_state_is_listed_and_leaves_no_ratio() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/example2_small.ron");
        let sc = Scenario::load(std::path::Path::new(path), &[]).unwrap();
        let stage = sc.production.clone().unwrap();
        let row = |state, dp, rate| ProductionRow {
            state,
            dp,
            rate,
            rate_frozen: rate,
            iterations: 1,
            converged: true,
            change: 0.0,
            relax_steps: 1,
            settle_steps: 0,
            new_cells: 0,
            max_aperture: 5e-4,
            wall_s: 0.1,
            rock: "quasi-static",
            fallback: None,
            frozen_settled: true,
        };
        use NetworkState::{After, Before};
        let rows = [
            row(Before, 9e6, 1e-3),
            row(Before, 12e6, 2e-3),
            row(After, 9e6, 3e-3),
        ];
        let failed = [FailedState {
            state: After,
            dp: 12e6,
            error: "blow-up".into(),
        }];
        let v = production_json(&stage, &rows, &failed);
        let ratio = |k: usize| v["ratios"][k].get("after_over_before").map(|x| x.as_f64());
        assert_eq!(ratio(0), Some(Some(3.0)));
        assert_eq!(ratio(1), None, "{v}");
        assert_eq!(v["failed"][0]["state"], "after");
        assert_eq!(v["failed"][0]["dp"], 12e6);
        assert!(!v.to_string().contains("null"), "{v}");
        let all = production_json(&stage, &rows, &[]);
        assert!(all.get("failed").is_none());
    }
}
