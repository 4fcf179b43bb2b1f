//! Sync points: the dense views' hot state copied into the ECS components (before a topology
//! change, for frames, at the end). A sync reads the views and writes only the components, so
//! writing outputs never changes the physics: the views are the state the systems step, and
//! the components are read back only when a view is rebuilt, which every topology change
//! precedes with its own sync.

use crate::flow::FlowPart;
use hydrofrac_core::model::Model;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::view::SolidView;

/// Copy the solid's state (displacements, velocities, stresses at the current displacements,
/// joint and edge state), the flow's (cells and boundaries) and the fracture geometry (mother
/// nodes follow their daughters; without a flow network, joint cells take the hydraulic
/// aperture of their joint) into the components.
pub fn write_back(model: &mut Model, solid: &SolidView, flow: Option<&FlowPart>, p: &RunParams) {
    solid.write_back(model, &p.solid);
    if let Some(f) = flow {
        f.view.write_back(model, &p.fluid);
    }
    if !solid.joint_entity.is_empty() {
        let coupled = flow.is_some_and(|f| f.coupling.is_some());
        hydrofrac_core::fractures::sync_fracture_geometry(
            model,
            (!coupled).then_some(p.residual_aperture),
        );
    }
}
