//! The rock's part of the simulation state (the flow's is [`super::flow::FlowPart`], the
//! fracture counters [`super::fracture::FractureState`], the clock [`super::monitor::Clock`]).

use crate::quasi_static::QuasiStatic;
use crate::solid::StepStats;
use hydrofrac_core::view::SolidView;

/// The rock's part of the state: the dense view, the last step's statistics and the critical
/// step of the current topology.
pub struct SolidPart {
    pub view: SolidView,
    /// Statistics of the last `integrate`.
    pub stats: StepStats,
    /// Critical solid step (elements, joints, fluid stiffness; [`hydrofrac_core::stability::solid`]), s;
    /// infinite without a solid.
    pub dt_crit: f64,
    /// `time.solid_scheme: QuasiStatic`: the equilibrium solver.
    pub quasi_static: Option<QuasiStatic>,
}
