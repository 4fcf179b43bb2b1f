//! `solve` and the coupled `flow_substeps` as the quasi-static step runs them: one solve over
//! [t0, t0 + dt] with the network's rows in the same Newton iteration
//! ([`crate::quasi_static::solve`], [`crate::quasi_static_flow`]), the adaptive step's retry
//! with half the step when Newton fails, and the flow system's commit of the converged rows.
//! A zero-length solve (dt = 0) is the re-solve at the same time after a split.

use crate::RunError;
use crate::flow::{self, FlowPart};
use crate::monitor::{Clock, Effort};
use crate::quasi_static::{self, Held, QuasiStatic};
use crate::quasi_static_flow::{self, FlowStep};
use crate::state::SolidPart;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::scenario::schedule_factor;

/// The flow system's commit of a coupled quasi-static step of length `dt` (s): the network's
/// state of the converged solve, its statistics and steady residual.
pub fn commit(qs: &QuasiStatic, f: &mut FlowPart, p: &RunParams, dt: f64) {
    f.stats = quasi_static_flow::commit(&qs.rows, f, &p.fluid, dt);
    f.dt = dt;
    flow::steady_residual(f);
}

/// One quasi-static solve over [t0, t0 + dt] (dt = 0: again at t0, after a split) under the
/// boundary schedule's load factor at t0 + dt (set on the clock). With `flow_on` (the
/// `flow_substeps` system enabled) a coupled network's rows are solved with the rock; without
/// it, the network's pressures stay where they are and load the faces, as the explicit
/// scheme's `fluid_pressure` holds them.
pub fn solve_at(
    solid: &mut SolidPart,
    flow: Option<&mut FlowPart>,
    flow_on: bool,
    clock: &mut Clock,
    p: &RunParams,
    t0: f64,
    dt: f64,
) -> Result<(), RunError> {
    clock.load_factor = schedule_factor(&p.boundary_schedule, t0 + dt);
    let qs = solid.quasi_static.as_mut().expect("quasi-static scheme");
    let faces = qs.on.fluid;
    let (rows, held) = match flow {
        Some(part) if part.coupling.is_some() && flow_on => (
            Some(FlowStep {
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
            part.coupling.as_ref().map(|c| Held {
                joint_cell: &c.joint_cell,
                pressure: &part.view.pressure,
            }),
        ),
        None => (None, None),
    };
    let at = quasi_static::StepEnd {
        step: clock.step + 1,
        time: t0 + dt,
        lf: clock.load_factor,
        dt,
    };
    solid.stats = quasi_static::solve(&mut solid.view, qs, rows, held, p, at)?;
    Ok(())
}

/// A re-solve at `t1` after a split ([`solve_at`] with no time passing). Under
/// `time.linear_solver: Auto` on the Cholesky tangent, a re-solve whose Newton iteration fails
/// is solved again by LU, which then holds as after a failed step ([`solve_step`]): a re-solve
/// cannot be halved, so this is its only second chance before the run stops.
pub fn resolve_at(
    solid: &mut SolidPart,
    mut flow: Option<&mut FlowPart>,
    flow_on: bool,
    clock: &mut Clock,
    p: &RunParams,
    t1: f64,
) -> Result<(), RunError> {
    let auto = solid
        .quasi_static
        .as_ref()
        .is_some_and(QuasiStatic::may_retry_lu);
    let saved = auto.then(|| Saved::of(solid));
    let solved = solve_at(solid, flow.as_deref_mut(), flow_on, clock, p, t1, 0.0);
    let (Err(e), Some(saved)) = (&solved, saved) else {
        return solved;
    };
    tracing::debug!("quasi-static re-solve at t = {t1:.6e} s failed: {e}; again by LU");
    hold_lu(solid.quasi_static.as_mut().expect("quasi-static scheme"));
    saved.restore(solid);
    solve_at(solid, flow, flow_on, clock, p, t1, 0.0)
}

/// The rock's state before a solve (displacements, joint states), for a retry.
struct Saved {
    u: Vec<[f64; 2]>,
    joints: Vec<hydrofrac_components::JointState>,
}

impl Saved {
    fn of(solid: &SolidPart) -> Self {
        let v = &solid.view;
        Saved {
            u: v.u.clone(),
            joints: v.joint_state.clone(),
        }
    }

    fn restore(&self, solid: &mut SolidPart) {
        let v = &mut solid.view;
        v.u.copy_from_slice(&self.u);
        v.joint_state.copy_from_slice(&self.joints);
    }
}

/// Directions from the LU for the next [`QuasiStatic::lu_hold`] steps after a retry
/// ([`quasi_static::LU_HOLD_FIRST`], doubled at each later retry).
fn hold_lu(qs: &mut QuasiStatic) {
    qs.counts.lu_retries += 1;
    qs.lu_hold = match qs.lu_hold {
        0 => quasi_static::LU_HOLD_FIRST,
        h => 2 * h,
    };
    qs.lu_left = qs.lu_hold;
}

/// `solve` over the step from `t0` of the clock's length. Under `time.linear_solver: Auto`, a
/// step whose Newton iteration fails is first solved again at the same length with every
/// direction from the full matrix's LU (the exact joint tangent; the Cholesky path adds the
/// sliding joints' Coulomb term by Sherman-Morrison-Woodbury, and on the fluid-driven shear
/// crack of `verify shear_crack` its Newton failed at every step once the front joints began
/// to slide), and the run keeps the LU for [`quasi_static::LU_HOLD_FIRST`] steps, twice as
/// many after each later retry, then goes back to the Cholesky tangent. Where the sliding
/// that defeated the Cholesky path persists (the shear crack: retrying at every step cost 5x
/// the LU's time) that is one failed Cholesky solve per doubling (Auto 2.88 s against `Lu`
/// 2.61 s); where it failed once (Example I cross at 0.2 s), the run goes back to the
/// cheaper path (18.6 s for the 1.5 s, against 50 s when the LU was kept to the end). Then an
/// adaptive step is halved and retried from the step's start (down to `time.dt_min`). Records
/// how hard the solve was in `effort` (the adaptive step's input).
pub fn solve_step(
    solid: &mut SolidPart,
    mut flow: Option<&mut FlowPart>,
    flow_on: bool,
    clock: &mut Clock,
    p: &RunParams,
    effort: &mut Effort,
    t0: f64,
) -> Result<(), RunError> {
    // The step's start is kept only if a retry can use it: an LU retry (Auto, not yet on
    // the LU) or a halving (adaptive).
    let auto = solid
        .quasi_static
        .as_ref()
        .is_some_and(QuasiStatic::may_retry_lu);
    let saved = (auto || clock.adaptive(p)).then(|| Saved::of(solid));
    loop {
        let dt = clock.dt;
        let solved = solve_at(solid, flow.as_deref_mut(), flow_on, clock, p, t0, dt);
        let qs = solid.quasi_static.as_mut().expect("quasi-static scheme");
        let retry_lu = solved.is_err() && qs.may_retry_lu();
        if retry_lu {
            hold_lu(qs);
        }
        let Err(e) = solved else {
            effort.iterations = qs.counts.last_iterations;
            effort.pressure_change = qs.rows.pressure_change();
            qs.lu_left = qs.lu_left.saturating_sub(1);
            return Ok(());
        };
        let Some(saved) = saved.as_ref() else {
            return Err(e);
        };
        if retry_lu {
            tracing::debug!("quasi-static step from t = {t0:.6e} s failed: {e}; again by LU");
            saved.restore(solid);
            continue;
        }
        if !clock.adaptive(p) {
            return Err(e);
        }
        if 0.5 * dt < p.time.dt_min {
            return Err(match e {
                RunError::QuasiStatic { step, time, why } => RunError::QuasiStatic {
                    step,
                    time,
                    why: format!("{why} (the step was halved down to time.dt_min = {dt:.3e} s)"),
                },
                e => e,
            });
        }
        tracing::debug!("quasi-static step from t = {t0:.6e} s failed at dt = {dt:.3e} s: {e}");
        saved.restore(solid);
        clock.dt = 0.5 * dt;
        clock.aim = None;
        let qs = solid.quasi_static.as_mut().expect("quasi-static scheme");
        qs.counts.cutbacks += 1;
    }
}
