//! One home for the stability bounds of the explicit schemes, s.
//!
//! - Solid: the smallest triangle altitude over the P-wave speed (lumped-mass CST; the seed's
//!   edge length over c_p is about 44 % too large, `docs/seed-method.md` D6).
//! - Joints: the penalty springs between sister faces, combined with the elements' bound by a
//!   Gershgorin estimate ([`with_joint_stiffness`]).
//! - Fluid: a full fracture cell pushes back on an opening change with K_f L / a per face, a
//!   stiffer spring than the joint penalty at the residual aperture ([`solid`]).
//! - Flow: the per-cell Gershgorin bound V_i / (K sum_j kappa_ij) of the explicit finite-volume
//!   step ([`flow_cell`]; the seed's 6 mu/K (L/a)^2 for a chain of equal cells, seed (6)).

use crate::model::Model;
use hecs::Entity;
use hydrofrac_components::{EdgeNodes, Joint, NodeMass, NodeRef};
use std::collections::HashMap;

/// Critical step of the elements alone, s: min altitude / c_p.
pub fn elements(min_altitude: f64, c_p: f64) -> f64 {
    min_altitude / c_p
}

/// Critical solid step of a scene, s: the elements' bound with every joint's stiffness
/// `k_joint` (max(K_n, K_t), Pa) raised by the fluid's, `k_fluid` L / a_r (the stiffest a full
/// cell of length L at the residual aperture a_r pushes back on an opening change; `k_fluid`
/// is 0 when no fluid fills the fractures).
pub fn solid(model: &Model, c_p: f64, k_joint: f64, k_fluid: f64, a_r: f64) -> f64 {
    with_joint_stiffness(
        model,
        elements(model.min_altitude, c_p),
        joint_spring(k_joint, k_fluid, a_r),
    )
}

/// The stiffness a joint of reference length L (m) adds to its nodes' rows, Pa:
/// `k_joint` + `k_fluid` L / a_r (see [`solid`]).
pub fn joint_spring(k_joint: f64, k_fluid: f64, a_r: f64) -> impl Fn(f64) -> f64 {
    move |len| k_joint + k_fluid * len / a_r
}

/// Stability bound of one flow cell, s: V / (K sum of its transmissibilities), with V its
/// volume (m^2), K the fluid's bulk modulus (Pa) and `kappa_sum` in m^2/(Pa s). Infinite for
/// a cell with no connection.
#[inline]
pub fn flow_cell(volume: f64, k: f64, kappa_sum: f64) -> f64 {
    if kappa_sum > 0.0 {
        volume / (k * kappa_sum)
    } else {
        f64::INFINITY
    }
}

/// Critical solid step with joint contact, s: the elements' `dt_crit` combined with the
/// Gershgorin bound of the contact stiffness. Each joint couples its four nodes with
/// coefficients +-K/2, a row sum of K per joint at a node, so
/// dt = 2 / sqrt((2/dt_crit)^2 + max_i (sum of K over the joints at node i) / m_i), with
/// K = max(K_n, K_t), here `k` of each joint's reference length (m), Pa.
pub fn with_joint_stiffness(model: &Model, dt_crit: f64, k: impl Fn(f64) -> f64) -> f64 {
    let mut sum: HashMap<Entity, f64> = HashMap::new();
    for j in model.world.query::<&Joint>().iter() {
        let en = model.world.get::<&EdgeNodes>(j.edges[0]).expect("edge").0;
        let [a, b] = en.map(|n| model.world.get::<&NodeRef>(n).expect("node").0);
        let kj = k((b[0] - a[0]).hypot(b[1] - a[1]));
        for e in j.edges {
            for n in model.world.get::<&EdgeNodes>(e).expect("edge").0 {
                *sum.entry(n).or_default() += kj;
            }
        }
    }
    let worst = sum
        .iter()
        .map(|(&n, &ks)| {
            let m = model.world.get::<&NodeMass>(n).map(|m| m.0).unwrap_or(0.0);
            if m > 0.0 { ks / m } else { 0.0 }
        })
        .fold(0.0, f64::max);
    if worst == 0.0 {
        return dt_crit;
    }
    2.0 / ((2.0 / dt_crit).powi(2) + worst).sqrt()
}
