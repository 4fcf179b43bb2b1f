//! The rock's part of the simulation state (the flow's is [`super::flow::FlowPart`], the
//! fracture counters [`super::fracture::FractureState`], the clock [`super::monitor::Clock`]).

use crate::quasi_static::QuasiStatic;
use crate::solid::StepStats;
use hydrofrac_core::dim::{Cst, Element};
use hydrofrac_core::view::SolidView;

/// The rock's part of the state: the dense view, the last step's statistics and the critical
/// step of the current topology. `E` is the element kind (2D CST by default, or TET4).
pub struct SolidPart<E: Element = Cst> {
    pub view: SolidView<E>,
    /// Statistics of the last `integrate`.
    pub stats: StepStats,
    /// Critical solid step (elements, joints, fluid stiffness; [`hydrofrac_core::stability::solid`]), s;
    /// infinite without a solid.
    pub dt_crit: f64,
    /// 3D, explicit rock: the elements' own part of `dt_crit` (the smallest tetrahedron's exact
    /// critical step), s, kept across splits, which change joints and nodal masses but no
    /// tetrahedron; infinite where unused (2D, the quasi-static rock).
    pub dt_elements: f64,
    /// `time.solid_scheme: QuasiStatic` in 2D: the equilibrium solver with joint contact and
    /// coupled flow.
    pub quasi_static: Option<QuasiStatic>,
    /// `time.solid_scheme: QuasiStatic` in 3D (a rock without joints): the factorised linear
    /// stiffness ([`crate::linear_static`]).
    pub linear: Option<crate::linear_static::LinearStatic>,
}
