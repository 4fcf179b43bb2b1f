//! Time control (`time:`): the end of a run, the solid and flow schemes, the steps and their
//! defaults, and the section's checks.

use super::{finite, positive};
use crate::error::SetupError;
use serde::{Deserialize, Serialize};

/// Time control.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TimeControl {
    pub end: End,
    /// Fraction of the critical step used, in (0, 1]. The critical step is the smallest
    /// triangle altitude over the P-wave speed; lumped-mass CST meshes are stable up to about
    /// 0.98 of it, so the default 0.9 keeps a margin.
    #[serde(default = "default_safety")]
    pub safety: f64,
    /// Force this time step, s, instead of `safety` times the critical one. A step above the
    /// stability limit is allowed (for studies) and is caught as a blow-up.
    #[serde(default)]
    pub dt: Option<f64>,
    /// Force the flow sub-step, s (studies; above the flow stability limit it is caught as a
    /// blow-up). Default: `safety` times the flow critical step.
    #[serde(default)]
    pub flow_dt: Option<f64>,
    /// Time integration of the fracture-network flow (default `Explicit`). `Explicit`: N
    /// forward-Euler sub-steps per step, each below the stability bound V/(K sum kappa) (s),
    /// which shrinks with the aperture squared. `Implicit`: one backward-Euler step (Newton,
    /// sparse LU) per step, stable for any length: in a scene with a rock mesh it is the solid
    /// step; in a flow-only scene it is `time.dt`, else `time.flow_dt`, else the explicit
    /// flow-only step (32 x `safety` x the explicit bound). Backward Euler is first order in
    /// time: choose the step for the accuracy wanted, not for stability.
    #[serde(default)]
    pub flow_scheme: FlowScheme,
    /// Time integration of the rock (default `Explicit`, the seed's central difference).
    /// `QuasiStatic`: equilibrium at the end of every step (Newton, sparse Cholesky) with the
    /// same forces, joints and friction; no inertia, no stability limit. `end: Static` is then
    /// one solve. With fracture flow (flow boundaries on the rock's fractures) each step solves
    /// the rock and the network's backward-Euler step together (one Newton iteration;
    /// `time.flow_scheme` is then not used), and the step adapts: it starts at `time.dt`
    /// (default: the end time / 1000), grows with easy steps, shrinks with hard ones or fast
    /// pressure change or fracture growth, stays within [`time.dt_min`, `time.dt_max`], is
    /// halved and retried when Newton fails, and lands on the end time and every
    /// `output.figure_times`. After a split the step is solved again at the same time until
    /// nothing more opens (at most `time.max_resolves` times). Without flow a timed run takes
    /// `time.dt` steps (default: the end time in 100 steps).
    #[serde(default)]
    pub solid_scheme: SolidScheme,
    /// Quasi-static scheme: the rock's inertia in each step's equation (default `Off`:
    /// equilibrium at the end of the step). `BackwardEuler`: implicit dynamics with the rock's
    /// true lumped mass, M (u - u_n - dt v_n) / dt^2 + f_int(u) = f_ext, v = (u - u_n) / dt (SI:
    /// kg/m, m, s). Where the load is slow against the rock's own periods (ms) it gives the
    /// equilibrium; where there is none (a block held only by joints sliding past the Coulomb
    /// limit) the block accelerates at its true rate instead of leaving the Newton matrix
    /// singular, and a shorter step always makes the solve easier (the mass term M / dt^2
    /// dominates), so the adaptive step's cutbacks get through. Needs `end: Time`.
    #[serde(default)]
    pub inertia: Inertia,
    /// Quasi-static scheme: the linear algebra of the Newton direction (default `Auto`; see
    /// [`LinearSolver`]). The converged answers agree to the solver's tolerance.
    #[serde(default)]
    pub linear_solver: LinearSolver,
    /// Adaptive quasi-static step: the longest step, s (default: the end time / 100).
    #[serde(default)]
    pub dt_max: Option<f64>,
    /// Adaptive quasi-static step: the shortest step a failing step may be halved to, s
    /// (default: the end time x 1e-9).
    #[serde(default)]
    pub dt_min: Option<f64>,
    /// Adaptive quasi-static step: a step whose Newton solve took at most this many iterations
    /// is followed by one 1.5 times longer; above three times this many the next is halved;
    /// between, it is kept (default 4; 1 to 20). Where many joints slide every step takes
    /// several iterations whatever its length (contact states settle, the coupled line
    /// search), so a larger value lets the step grow there; the pressure-change and
    /// new-cell limits still bound each step.
    #[serde(default = "default_newton_easy")]
    pub newton_easy: u64,
    /// Quasi-static scheme: a step is in equilibrium when the free degrees of freedom's
    /// unbalanced force is below this times the reactions and loads (or the step's first
    /// unbalanced force), N/m over N/m (default 1e-10; 1e-14 to 1e-3). On a network where
    /// hundreds of joints slide the iteration can stall at round-off near 1e-9.
    #[serde(default = "default_newton_tol")]
    pub newton_tol: f64,
    /// Quasi-static scheme: the most re-solves at the same time after splits in one step
    /// (default 200); reaching it is counted in `summary.json` (`resolve_cap_hits`).
    #[serde(default = "default_max_resolves")]
    pub max_resolves: u64,
    /// Hard cap on the number of steps.
    #[serde(default = "default_max_steps")]
    pub max_steps: u64,
    /// Coupled runs: the most explicit flow sub-steps allowed in one solid step. The flow step
    /// shrinks with the square of the largest aperture; past this cap the run stops with a
    /// message instead of crawling.
    #[serde(default = "default_max_substeps")]
    pub max_substeps: u64,
    /// Nodal mass scaling for static relaxation (only with `end: Static`; default off): each
    /// node's mass becomes R_i dt_crit^2 / 4 with R_i its Gershgorin row sum of the stiffness
    /// (elements and joints), Underwood's fictitious masses for dynamic relaxation, so every
    /// node relaxes at about the rate of the stiffest and the large elements of a graded mesh
    /// stop slowing the relaxation. The step is unchanged and stays stable. The dynamics
    /// change; the static answer (K u = f) does not, since body forces use the true density.
    #[serde(default)]
    pub mass_scaling: bool,
    /// Selective mass scaling for the explicit rock (default off): `Some(f)` lengthens the
    /// critical step f times (f >= 1) by raising the mass of each node whose own Gershgorin
    /// bound 2 sqrt(m_i / g_i) is shorter, to m_i = g_i T^2 / 4 (T the new critical step, s;
    /// g_i the node's row sum of |K|: its elements, and per joint face max(K_n, K_t) plus, in
    /// coupled runs, the fluid's K L / a_r of a full cell at the residual aperture;
    /// `systems::solid::raise_masses`). Other nodes keep their masses. The joints' and the
    /// fluid's springs set the step of a coupled run (on Example II 6x below the elements'),
    /// so up to a factor of about 16 there only the nodes on fracture faces get heavier. The rock's response
    /// to pumping is quasi-static, so added inertia changes it little; how little is measured
    /// on Example II in the README. Body forces keep the true density. `summary.json`
    /// `mass_scaling` reports the nodes raised and the mass added.
    #[serde(default)]
    pub selective_mass_scaling: Option<f64>,
}

/// Default of `time.newton_tol` (the quasi-static solver's `DEFAULT_TOL`).
pub const DEFAULT_NEWTON_TOL: f64 = 1e-10;
/// Default of `time.newton_easy` (the adaptive step's `NEWTON_EASY`).
pub const DEFAULT_NEWTON_EASY: u64 = 4;

fn default_newton_tol() -> f64 {
    DEFAULT_NEWTON_TOL
}
fn default_newton_easy() -> u64 {
    DEFAULT_NEWTON_EASY
}
fn default_max_resolves() -> u64 {
    200
}

fn default_max_substeps() -> u64 {
    100_000
}

/// Time integration of the network flow (see [`TimeControl::flow_scheme`]).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum FlowScheme {
    /// Forward Euler sub-steps below the explicit stability bound.
    #[default]
    Explicit,
    /// One backward-Euler step per step (unconditionally stable, first order in time).
    Implicit,
}

/// The quasi-static Newton direction's linear algebra (`time.linear_solver`).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum LinearSolver {
    /// `Lu` when more than 32 joints slide or more than 200 fracture cells load the rock
    /// (`systems::quasi_static::LU_MIN_SLIDING`, `LU_MIN_CELLS`), else `Cholesky`.
    #[default]
    Auto,
    /// The symmetric tangent by sparse Cholesky (kept while the contact states are), the
    /// sliding joints' Coulomb term by Sherman-Morrison-Woodbury (one solve per sliding
    /// joint), coupled steps reduced to the cells through W = K_T^-1 G (one solve per cell
    /// and factor, a dense cells x cells LU).
    Cholesky,
    /// The full unsymmetric Newton matrix, rock and cells together, with the exact joint
    /// tangent, by sparse LU every iteration (`systems::quasi_static_lu`).
    Lu,
}

/// The rock's inertia in a quasi-static step (see [`TimeControl::inertia`]).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum Inertia {
    /// Equilibrium at the end of every step.
    #[default]
    Off,
    /// Implicit dynamics with the true lumped mass, backward Euler (first order, damps the
    /// rock's fast vibration).
    BackwardEuler,
}

/// Time integration of the rock (see [`TimeControl::solid_scheme`]).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub enum SolidScheme {
    /// Central difference, damped for pseudo-static response (the seed's).
    #[default]
    Explicit,
    /// Static equilibrium per step.
    QuasiStatic,
}

fn default_safety() -> f64 {
    0.9
}
fn default_max_steps() -> u64 {
    10_000_000
}

/// When a run ends.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum End {
    /// After this simulated time, s.
    Time(f64),
    /// When the static residual ||unbalanced force on free dofs|| / ||internal force|| drops
    /// below `tol` (checked after at least `min_steps` steps).
    Static {
        tol: f64,
        #[serde(default = "default_min_steps")]
        min_steps: u64,
    },
    /// Flow-only scenes: solve the incompressible steady state of the network directly (sparse
    /// Cholesky), no time stepping. Pressure and rate boundaries only.
    SteadyDirect,
}

fn default_min_steps() -> u64 {
    10
}

impl TimeControl {
    /// The steps, the Newton settings, the schemes (`mesh`, `network`: whether the scene has a
    /// rock mesh and a rigid network, which decide the schemes it can take), mass scaling and
    /// the end (a `SteadyDirect` end's needs are `Scenario::check_steady_direct`'s); errors name
    /// `time.<field>`.
    pub(super) fn validate(&self, mesh: bool, network: bool) -> Result<(), SetupError> {
        self.validate_steps()?;
        self.validate_newton()?;
        if let Some(dt) = self.flow_dt {
            positive("time.flow_dt", dt, "the flow step")?;
            if self.flow_scheme == FlowScheme::Implicit && mesh {
                return Err(SetupError::invalid(
                    "time.flow_dt",
                    "the implicit flow scheme takes one flow step per solid step; \
                     set time.dt instead",
                ));
            }
        }
        if self.max_steps == 0 {
            return Err(SetupError::invalid("time.max_steps", "must be at least 1"));
        }
        if self.solid_scheme == SolidScheme::QuasiStatic {
            let why = if !mesh {
                Some("needs a rock mesh")
            } else if network {
                Some("couples with the rock's own fractures, not with a separate network")
            } else {
                None
            };
            if let Some(why) = why {
                return Err(SetupError::invalid(
                    "time.solid_scheme",
                    format!("QuasiStatic {why}"),
                ));
            }
        }
        if self.inertia == Inertia::BackwardEuler {
            if self.solid_scheme != SolidScheme::QuasiStatic {
                return Err(SetupError::invalid(
                    "time.inertia",
                    "BackwardEuler is the quasi-static scheme's inertia; the explicit rock \
                     has its own (set time.solid_scheme: QuasiStatic)",
                ));
            }
            if !matches!(self.end, End::Time(_)) {
                return Err(SetupError::invalid(
                    "time.inertia",
                    "BackwardEuler follows the rock in time: it needs end: Time(..)",
                ));
            }
        }
        self.validate_mass_scaling()?;
        self.end.validate(self.max_steps)
    }

    /// The safety factor and the given steps.
    fn validate_steps(&self) -> Result<(), SetupError> {
        finite("time.safety", self.safety)?;
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return Err(SetupError::invalid(
                "time.safety",
                format!("the safety factor must be in (0, 1], got {}", self.safety),
            ));
        }
        if let Some(dt) = self.dt {
            positive("time.dt", dt, "the time step")?;
        }
        if let Some(dt) = self.dt_max {
            positive("time.dt_max", dt, "the longest adaptive step")?;
        }
        if let Some(dt) = self.dt_min {
            positive("time.dt_min", dt, "the shortest adaptive step")?;
            if self.dt_max.is_some_and(|m| m < dt) {
                return Err(SetupError::invalid(
                    "time.dt_min",
                    "must not exceed time.dt_max",
                ));
            }
        }
        // The defaults of the adaptive step's bounds follow the end time (`RunParams`): a
        // `dt_max` alone must not fall below the default `dt_min`.
        if let (Some(m), None, End::Time(te)) = (self.dt_max, self.dt_min, &self.end) {
            let default_min = te * 1e-9;
            if m < default_min {
                return Err(SetupError::invalid(
                    "time.dt_max",
                    format!(
                        "{m:e} s is below the shortest adaptive step, {default_min:e} s \
                         (the end time x 1e-9, the default of time.dt_min); raise it or set \
                         time.dt_min below it"
                    ),
                ));
            }
        }
        if let (None, Some(m), End::Time(te)) = (self.dt_max, self.dt_min, &self.end) {
            let default_max = te / 100.0;
            if m > default_max {
                return Err(SetupError::invalid(
                    "time.dt_min",
                    format!(
                        "{m:e} s is above the longest adaptive step, {default_max:e} s \
                         (the end time / 100, the default of time.dt_max); lower it or set \
                         time.dt_max above it"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The quasi-static scheme's re-solves, tolerance and easy-step count.
    fn validate_newton(&self) -> Result<(), SetupError> {
        if self.max_resolves == 0 {
            return Err(SetupError::invalid("time.max_resolves", "must be >= 1"));
        }
        if !(self.newton_tol >= 1e-14 && self.newton_tol <= 1e-3) {
            return Err(SetupError::invalid(
                "time.newton_tol",
                format!(
                    "{} is not in [1e-14, 1e-3] (a relative residual: below 1e-14 round-off \
                     cannot reach it, above 1e-3 the rock is not in equilibrium)",
                    self.newton_tol
                ),
            ));
        }
        if !(1..=20).contains(&self.newton_easy) {
            return Err(SetupError::invalid(
                "time.newton_easy",
                format!(
                    "{} is not in 1..=20 (three times it must stay below the cap on Newton \
                     iterations of a step)",
                    self.newton_easy
                ),
            ));
        }
        Ok(())
    }

    /// Selective mass scaling (a factor >= 1, not with `mass_scaling` nor the quasi-static
    /// scheme), then `mass_scaling` (static relaxation only).
    fn validate_mass_scaling(&self) -> Result<(), SetupError> {
        if let Some(f) = self.selective_mass_scaling {
            if !(f.is_finite() && f >= 1.0) {
                return Err(SetupError::invalid(
                    "time.selective_mass_scaling",
                    format!("{f} is not a factor of at least 1 on the critical step"),
                ));
            }
            let why = if self.mass_scaling {
                Some("and time.mass_scaling both set the masses: choose one")
            } else if self.solid_scheme == SolidScheme::QuasiStatic {
                Some("lengthens the explicit step: the quasi-static scheme has no masses")
            } else {
                None
            };
            if let Some(why) = why {
                return Err(SetupError::invalid("time.selective_mass_scaling", why));
            }
        }
        if self.mass_scaling && !matches!(self.end, End::Static { .. }) {
            return Err(SetupError::invalid(
                "time.mass_scaling",
                "changes the dynamics: only for static relaxation (end: Static)",
            ));
        }
        Ok(())
    }

    /// `max_substeps` at least 1 (checked after the fluid, where it always was).
    pub(super) fn validate_max_substeps(&self) -> Result<(), SetupError> {
        if self.max_substeps == 0 {
            return Err(SetupError::invalid("time.max_substeps", "must be >= 1"));
        }
        Ok(())
    }
}

impl End {
    /// A positive end time, or a positive tolerance checked within `max_steps`; errors name
    /// `time.end...`. `SteadyDirect` has nothing of its own to check.
    fn validate(&self, max_steps: u64) -> Result<(), SetupError> {
        match *self {
            End::Time(te) => positive("time.end", te, "the end time"),
            End::Static { tol, min_steps } => {
                positive("time.end.tol", tol, "the residual tolerance")?;
                if min_steps > max_steps {
                    return Err(SetupError::invalid(
                        "time.end.min_steps",
                        format!(
                            "{min_steps} steps before the residual is checked (default 10) is \
                             more than time.max_steps = {max_steps}: the run could never \
                             converge; lower time.end.min_steps or raise time.max_steps"
                        ),
                    ));
                }
                Ok(())
            }
            End::SteadyDirect => Ok(()),
        }
    }
}
