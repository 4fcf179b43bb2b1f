//! `split`: opens the fracture-ready edges by node splitting, all in one batch
//! ([`hydrofrac_core::split::open_edges`], the only topology change of a step). The step loop rebuilds
//! the views right after; [`shorten_step`] then lowers the step when the new joints (and the
//! fluid that will fill them) lower the stability bound.

use crate::flow::FlowPart;
use crate::fracture::FractureState;
use crate::monitor::Clock;
use crate::state::SolidPart;
use crate::sync;
use hydrofrac_core::model::Model;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::scenario::End;
use hydrofrac_core::view::SolidView;

/// Open the ready edges at time `t` (the end of the step). Returns whether any node split (the
/// topology changed). The state is synced into the components first.
pub fn split(
    model: &mut Model,
    solid: &SolidView,
    flow: Option<&FlowPart>,
    frac: &mut FractureState,
    p: &RunParams,
    t: f64,
) -> bool {
    let ready: Vec<hecs::Entity> = (0..solid.edge_entity.len())
        .filter(|&k| solid.edge_ready[k])
        .map(|k| solid.edge_entity[k])
        .collect();
    let key = (ready.len(), model.topology_generation);
    if ready.is_empty() || frac.last_idle_split == Some(key) {
        return false;
    }
    sync::write_back(model, solid, flow, p);
    // A uniform face pressure (`fracture.pressure`) acts on the faces opened now too.
    let face = p.face_pressure.map(|fp| {
        (
            fp,
            hydrofrac_core::fractures::face_pressure_loads(model, fp),
        )
    });
    let r = hydrofrac_core::split::open_edges(model, &ready, p.residual_aperture, t);
    if let Some((fp, before)) = &face {
        hydrofrac_core::fractures::reload_face_pressure(model, *fp, before, &r.daughters_of);
    }
    frac.splits += r.split_nodes;
    frac.opened_edges += r.opened_edges;
    if r.split_nodes == 0 {
        frac.last_idle_split = Some(key);
        return false;
    }
    true
}

/// After a split at time `t`: the critical step of the new topology, and a shorter step when
/// the bound requires it (unless the user forced `time.dt`); a timed run then takes the steps
/// it needs to reach its end.
pub fn shorten_step(
    model: &Model,
    solid: &mut SolidPart,
    clock: &mut Clock,
    p: &RunParams,
    t: f64,
) {
    // With `time.selective_mass_scaling` the view rebuilt for the new topology raises the new
    // joints' nodes to the scaling's step, so that stays the bound.
    let bound = match &p.time.selective {
        Some(s) => s.dt_crit,
        None => hydrofrac_core::stability::solid(
            model,
            p.c_p,
            p.joint.k_max(),
            p.k_fluid(),
            p.residual_aperture,
        ),
    };
    solid.dt_crit = bound;
    shorten_to(clock, p, bound, t);
}

/// Lower the step to `safety` times the critical step `bound` (s) when it is longer (unless
/// the user forced `time.dt`), and recount a timed run's steps to its end from time `t`.
pub fn shorten_to(clock: &mut Clock, p: &RunParams, bound: f64, t: f64) {
    let safe = p.time.safety * bound;
    if !clock.forced(p) && safe < clock.dt {
        clock.dt = safe;
        if let End::Time(te) = p.time.end {
            let left = ((te - t) / safe - 1e-9).ceil().max(0.0) as u64;
            clock.steps_to_end = Some(clock.step + 1 + left);
        }
    }
}
