//! `monitor`: advances the clock, stops a run whose state has blown up (non-finite or runaway
//! speeds, negative fluid mass), updates the static residual and decides when the run ends.

use crate::RunError;
use crate::flow::FlowPart;
use crate::state::SolidPart;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::scenario::End;

/// A speed above this fraction of the P-wave speed implies strains of order 100 %: far outside
/// small-strain elasticity, so the run is treated as blown up.
pub const SPEED_LIMIT_FRACTION: f64 = 1.0;

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Finish {
    /// Reached the end time.
    EndTime,
    /// Static (or steady) residual below tolerance.
    Converged,
    /// Hit `time.max_steps` first.
    MaxSteps,
    /// Stopped between steps on request (SIGINT or SIGTERM, see [`crate::StopFlag`]).
    Interrupted,
}

/// Where the run is in time, and the step it takes next: the state of time stepping (the
/// run's parameters, `RunParams`, do not change after setup).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Clock {
    /// Steps taken.
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// The next step's length, s: set at setup, shortened after splits (`split::shorten_step`),
    /// adapted by quasi-static coupled runs ([`next_step`]).
    pub dt: f64,
    /// Multiplier of all boundary loads and prescribed displacements in the step being taken
    /// (the scenario's `boundary_schedule` at its end; 1 without one).
    pub load_factor: f64,
    /// The time (s) the current adaptive step is meant to land on exactly (the end or a figure
    /// time), if any.
    pub aim: Option<f64>,
    /// A stage holds the step as it is set (the production stage's relaxations): neither
    /// adapted nor shortened after splits.
    pub held: bool,
    /// Steps to run for an `End::Time` scenario.
    pub steps_to_end: Option<u64>,
    /// Static residual after the last step (solid and flow, the larger).
    pub residual: f64,
    pub finish: Option<Finish>,
}

impl Clock {
    /// A clock at t = 0 before the first step of length `dt` (s).
    pub fn start(dt: f64, steps_to_end: Option<u64>) -> Self {
        Clock {
            step: 0,
            time: 0.0,
            dt,
            load_factor: 1.0,
            aim: None,
            held: false,
            steps_to_end,
            residual: f64::INFINITY,
            finish: None,
        }
    }

    /// Whether the step adapts to the quasi-static solver's effort (`time.adaptive`, unless a
    /// stage holds it).
    pub fn adaptive(&self, p: &RunParams) -> bool {
        p.time.adaptive && !self.held
    }

    /// Whether the step keeps its length after splits (the user's `time.dt`, or held).
    pub fn forced(&self, p: &RunParams) -> bool {
        p.time.forced_dt || self.held
    }

    /// Hold the step at `dt` (s) from now on: [`Clock::adaptive`] and shortening are off.
    pub fn hold(&mut self, dt: f64) {
        self.dt = dt;
        self.held = true;
        self.aim = None;
    }
}

/// The end of the step that started at `t0`, s: t0 + dt, or exactly the time an adaptive step
/// was aimed at (the end or a figure time) when it lands there.
pub fn step_end(t0: f64, clock: &Clock) -> f64 {
    let t1 = t0 + clock.dt;
    match clock.aim {
        Some(aim) if (t1 - aim).abs() <= 1e-9 * clock.dt => aim,
        _ => t1,
    }
}

/// `monitor`: the step [t0, t0 + dt] is done; check it and decide whether the run ends.
pub fn monitor<E: hydrofrac_core::dim::Element>(
    clock: &mut Clock,
    t0: f64,
    solid: &SolidPart<E>,
    flow: Option<&FlowPart>,
    p: &RunParams,
) -> Result<(), RunError> {
    clock.step += 1;
    clock.time = step_end(t0, clock);
    let (st, v) = (&solid.stats, &solid.view);
    let blow = |entity: String, quantity: &'static str, value: f64, why: String, dt: f64| {
        RunError::BlowUp {
            step: clock.step,
            time: clock.time,
            entity,
            quantity,
            value,
            why,
            dt,
        }
    };
    let node = |i: usize| {
        let x: Vec<String> = v.x0[i].as_ref().iter().map(|c| format!("{c:.4}")).collect();
        format!("node {} at ({}) m", v.node_id[i], x.join(", "))
    };
    if let Some(i) = st.non_finite {
        // The first non-finite velocity component (the last one when all are finite: the
        // displacement went first).
        let vel = v.v[i];
        let vel = vel.as_ref();
        let value = vel
            .iter()
            .copied()
            .find(|c| !c.is_finite())
            .unwrap_or(vel[vel.len() - 1]);
        return Err(blow(
            node(i),
            "velocity",
            value,
            "a non-finite value".into(),
            clock.dt,
        ));
    }
    let limit = SPEED_LIMIT_FRACTION * p.c_p;
    if v.n_nodes() > 0 && st.vmax > limit {
        return Err(blow(
            node(st.vmax_node),
            "speed",
            st.vmax,
            format!(
                "above {SPEED_LIMIT_FRACTION} c_p = {limit:.4e} m/s (strain of order 100 %: the step \
                 exceeds the stability limit {:.3e} s or the loading is not physical)",
                solid.dt_crit
            ),
            clock.dt,
        ));
    }
    let mut residual = if v.n_nodes() > 0 { st.residual() } else { 0.0 };
    if let Some(f) = flow {
        // The explicit sub-step's bound is checked where it is chosen
        // ([`crate::flow::check_substep`]), at that step's state: a split later in
        // the step changes the network (and `f.dt_crit`), not the step already taken.
        if let Some(c) = f.stats.bad_cell {
            return Err(blow(
                f.view.cell_label(c),
                "fluid mass",
                f.view.excess[c] + p.fluid.rho_r * f.view.volume[c],
                match f.implicit {
                    None => format!(
                        "negative or non-finite: the flow step exceeds its stability limit {:.3e} s",
                        f.dt_crit
                    ),
                    Some(_) => {
                        "negative or non-finite: more fluid withdrawn than the cell holds".into()
                    }
                },
                f.dt,
            ));
        }
        if !f.residual.is_finite() {
            return Err(blow(
                "the fracture flow".into(),
                "steady residual",
                f.residual,
                "the cells' net inflow overflows: the flow boundaries' values are not \
                 physical"
                    .into(),
                f.dt,
            ));
        }
        residual = residual.max(f.residual);
    }
    if !residual.is_finite() {
        return Err(blow(
            "the rock".into(),
            "static residual",
            residual,
            "the nodal forces overflow: the loads or the material are not physical".into(),
            clock.dt,
        ));
    }
    clock.residual = residual;
    // A quasi-static step is an equilibrium: a static run is one step.
    let quasi_static = p.time.solid_scheme == hydrofrac_core::scenario::SolidScheme::QuasiStatic;
    if let End::Static { tol, min_steps } = p.time.end
        && (clock.step >= min_steps || quasi_static)
        && clock.residual < tol
    {
        clock.finish = Some(Finish::Converged);
    }
    if let Some(n) = clock.steps_to_end
        && clock.step >= n
    {
        clock.finish = Some(Finish::EndTime);
    }
    if let End::Time(te) = p.time.end
        && clock.adaptive(p)
        && clock.time >= te
    {
        clock.finish = Some(Finish::EndTime);
    }
    if clock.finish.is_none() && clock.step >= p.time.max_steps {
        clock.finish = Some(Finish::MaxSteps);
    }
    Ok(())
}

/// How hard the last quasi-static step was: the adaptive step's input.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Effort {
    /// Newton iterations of the step's solve (not of its re-solves after splits).
    pub iterations: u64,
    /// Largest cell pressure change over the step relative to the largest pressure.
    pub pressure_change: f64,
    /// Fracture cells the step's splits created.
    pub new_cells: usize,
}

/// Newton iterations at or below which the step grows (the default of `time.newton_easy`);
/// above [`NEWTON_HARD_FACTOR`] times it the step shrinks.
pub const NEWTON_EASY: u64 = hydrofrac_core::scenario::DEFAULT_NEWTON_EASY;
pub const NEWTON_HARD_FACTOR: u64 = 3;
/// Growth factor of an easy step.
pub const GROWTH: f64 = 1.5;
/// Target relative pressure change per step.
pub const PRESSURE_CHANGE: f64 = 0.1;
/// Target number of new fracture cells per step.
pub const NEW_CELLS: usize = 1;

/// The next adaptive quasi-static step after the step that ended at `clock.time`: grown by
/// [`GROWTH`] after an easy Newton solve (at most `time.newton_easy` iterations), halved after
/// a hard one, shortened so the pressure
/// changes by about [`PRESSURE_CHANGE`] and at most [`NEW_CELLS`] cells open per step (never
/// below half the last step), kept in [`dt_min`, `dt_max`], and landing exactly on the next
/// figure time or the end (a step within twice its length of it is split in two equal ones).
pub fn next_step(clock: &mut Clock, p: &RunParams, e: Effort) {
    let dt = clock.dt;
    let easy = p.time.newton_easy;
    let mut f = if e.iterations <= easy {
        GROWTH
    } else if e.iterations <= NEWTON_HARD_FACTOR * easy {
        1.0
    } else {
        0.5
    };
    if e.pressure_change > 0.0 {
        f = f.min((PRESSURE_CHANGE / e.pressure_change).max(0.5));
    }
    if e.new_cells > NEW_CELLS {
        f = f.min((NEW_CELLS as f64 / e.new_cells as f64).max(0.5));
    }
    let mut next = (dt * f).clamp(p.time.dt_min, p.time.dt_max);
    let t = clock.time;
    let end = match p.time.end {
        End::Time(te) => te,
        End::Static { .. } | End::SteadyDirect => f64::INFINITY,
    };
    let target = p
        .output
        .figure_times
        .iter()
        .copied()
        .filter(|&tf| tf > t)
        .fold(end, f64::min);
    clock.aim = None;
    let rem = target - t;
    if rem <= next * (1.0 + 1e-9) {
        next = rem;
        clock.aim = Some(target);
    } else if rem < 2.0 * next {
        next = 0.5 * rem;
    }
    clock.dt = next;
}
