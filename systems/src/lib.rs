//! hydrofrac-systems: the systems of a step and their literal order.
//!
//! A step runs the enabled systems of [`SystemId::ORDER`] one after the other, each inside one
//! `tracing` span named after it (opened on the scheduler thread; rayon work inside a system is
//! counted in that system's span). Order is load-bearing:
//! - `internal_force` overwrites the force array, so it runs first;
//! - `external_load`, `contact` and `fluid_pressure` add to it, and `damping` reads the complete unbalanced force;
//! - `integrate` consumes forces and produces the step statistics that `monitor` checks;
//! - `flow_substeps` runs after `integrate`: it knows the apertures at both ends of the step and
//!   interpolates them over its sub-steps; the mean pressure it leaves is the load of the next
//!   step's `fluid_pressure` (the seed's staggered sub-stepping);
//! - `split` is the only system that changes topology; the step loop rebuilds the views right
//!   after it (`Simulation::rebuild_views_if_needed`);
//! - `monitor` must run before `output` so that no frame with non-finite values is written.
//!
//! Every system is a function in this folder that takes what it reads and writes as explicit
//! arguments; those that can fail return a [`RunError`]. A new system is one function here plus
//! one line in the `systems!` table below (its place in the order, name and doc line; the
//! enum, the order, the names and the spans come from it), one arm in the step loop
//! (`Simulation::step_once`, `src/sim.rs`: the arguments it takes) and one rule in
//! `schedule::SceneData::has` (when the scene has data for it).

#![allow(clippy::needless_range_loop)]

pub mod coupling;
pub mod criterion;
pub mod flow;
pub mod fracture;
pub mod linear_static;
pub mod monitor;
pub mod output;
pub mod quasi_static;
pub mod quasi_static_flow;
pub mod quasi_static_lu;
pub mod quasi_static_step;
pub mod seismicity;
pub mod solid;
pub mod split;
pub mod state;
pub mod sync;
pub mod toughness;
pub mod toughness3d;

use hydrofrac_core::error::SetupError;

/// The systems of the step, in order: one line each (variant, name, what it does). The macro
/// makes the enum, [`SystemId::ORDER`], the names, the doc lines and the spans from this table.
macro_rules! systems {
    ($($id:ident => $name:literal, $doc:literal;)+) => {
        /// A named system of the step.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum SystemId {
            $($id,)+
        }

        impl SystemId {
            /// The step, in order.
            pub const ORDER: [SystemId; [$($name),+].len()] = [$(SystemId::$id),+];

            pub fn name(self) -> &'static str {
                match self {
                    $(SystemId::$id => $name,)+
                }
            }

            /// One line on what the system does (shown by `hydrofrac systems` and in the
            /// README).
            pub fn doc(self) -> &'static str {
                match self {
                    $(SystemId::$id => $doc,)+
                }
            }

            /// The system's span. Names are literals so the timing layer and Perfetto see them
            /// as is.
            pub fn span(self) -> tracing::Span {
                match self {
                    $(SystemId::$id => tracing::info_span!(target: "hydrofrac::system", $name),)+
                }
            }
        }
    };
}

systems! {
    InternalForce => "internal_force", "CST (2D) or TET4 (3D) stresses and nodal internal forces, gathered by node";
    ExternalLoad => "external_load", "adds constant boundary tractions and body forces";
    Contact => "contact", "joint contact: penalty normal and shear forces between sister faces, Coulomb friction";
    FluidPressure => "fluid_pressure", "fluid pressure (mean of the last step's flow sub-steps) as traction on both faces of every fracture cell";
    Damping => "damping", "local (Cundall) or viscous damping force for pseudo-static response";
    Solve => "solve", "quasi-static scheme: equilibrium of internal force, loads and contact at the end of the step (Newton, sparse Cholesky)";
    Integrate => "integrate", "central-difference update of velocity and displacement; prescribed displacements";
    FlowSubsteps => "flow_substeps", "N explicit finite-volume steps of the fracture network (pairs, pump, rate, pressure), or one backward-Euler step";
    FractureCriterion => "fracture_criterion", "marks internal edges whose normal stress reaches lambda*T0 (never changes topology)";
    Split => "split", "node splitting at fracture-ready edges: daughters, sister edges, cells, joints (the only topology change)";
    Monitor => "monitor", "advances the clock; blow-up detection (solid speed, cell mass, flow step bound); residual and end";
    Seismicity => "seismicity", "slip rate of every joint; events from connected sets of fast-slipping joints (moment, magnitude, stress drop)";
    Output => "output", "ParaView frames and timeseries.csv rows at the scenario's intervals";
}

impl SystemId {
    /// Systems that cannot be switched off (the run would be unsafe or meaningless).
    pub fn required(self) -> bool {
        matches!(
            self,
            SystemId::Integrate | SystemId::Solve | SystemId::Monitor
        )
    }

    pub fn from_name(name: &str) -> Option<SystemId> {
        Self::ORDER.into_iter().find(|s| s.name() == name)
    }
}

/// A request to stop a run: 0 while none, else the number of the signal that asked (the
/// binary's SIGINT and SIGTERM handlers store 2 or 15 here). The step loop checks it between
/// steps (`Simulation::run`), the production stage's quasi-static solve between Newton
/// iterations (`quasi_static::QuasiStatic::interrupt`).
pub type StopFlag = std::sync::Arc<std::sync::atomic::AtomicUsize>;

/// A blow-up's value in words where it is not a number (messages are results too: no `inf` or
/// `NaN` token in them).
fn show_value(v: f64) -> String {
    if v.is_nan() {
        "not a number".into()
    } else if v.is_infinite() {
        if v > 0.0 {
            "infinite"
        } else {
            "minus infinite"
        }
        .into()
    } else {
        format!("{v:.6e}")
    }
}

/// A run that had to stop.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Numerical blow-up: the step, the entity and the quantity that went wrong.
    #[error(
        "blow-up at step {step} (t = {time:.6e} s): {entity} has {quantity} = {shown}, {why}; \
         stopped before writing non-finite output (dt = {dt:.3e} s)",
        shown = show_value(*.value)
    )]
    BlowUp {
        step: u64,
        time: f64,
        entity: String,
        quantity: &'static str,
        value: f64,
        why: String,
        dt: f64,
    },
    /// The implicit (backward-Euler) flow step failed: its Newton iteration did not converge.
    #[error("step {step} (t = {time:.6e} s): {source}")]
    ImplicitFlow {
        step: u64,
        time: f64,
        source: Box<hydrofrac_core::flow::implicit::ImplicitError>,
    },
    /// The quasi-static equilibrium iteration failed.
    #[error("step {step} (t = {time:.6e} s): quasi-static solve: {why}")]
    QuasiStatic { step: u64, time: f64, why: String },
    #[error("output: {0}")]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Setup(#[from] SetupError),
}
