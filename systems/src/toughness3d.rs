//! The toughness criterion on 3D fronts (`fracture.criterion: Some(Toughness(k_ic: ...))` with
//! `fracture.grow_in: DiscPlanes`): part of the `fracture_criterion` system in 3D.
//!
//! **Front nodes.** A front node is a node of a fracture face that did not split: the same node
//! on both faces of a joint (every other corner of a joint is a sister pair, a node and its
//! daughter). The front runs through the front nodes.
//!
//! **Stress intensity by displacement correlation.** Near a front, the opening at a distance s
//! behind it is w = (8 / E') K_I sqrt(s / (2 pi)) (E' = E / (1 - nu^2)). At front node F, each
//! sister pair P that shares a fracture face with F gives K_P = C (E' / 8) sqrt(2 pi / s_P) w_P,
//! with w_P the pair's offset along the face normal and s_P its distance behind the front:
//! s_P = (x_F - x_P) . m, m the unit vector from the mean of those pairs to F (the front's
//! outward normal, reference positions). K(F) is the mean of the K_P with s_P > 0, then
//! averaged over the front nodes within [`SMOOTH_CELLS`] cells of F (a staircase front's
//! corners and straight runs see the square root at different distances). The linear
//! elements do not hold the square root one element behind the front; C = [`DC_CALIBRATION`]
//! corrects that on average (measured on Sneddon's penny, below).
//!
//! **Growth.** When K(F) >= K_Ic, the candidate faces (those of the discs' planes) that touch
//! F are marked ready. With every face round it cut, F splits (`split`), the faces round it
//! open, and their far corners are the new front nodes: the front moves one element forward
//! there.
//!
//! SI units: m, Pa, Pa sqrt(m); tension positive.

use hydrofrac_core::dim::Tet4;
use hydrofrac_core::model3::{corner_offsets_3d, joint_frame_3d};
use hydrofrac_core::tet4::{dot, norm, sub};
use hydrofrac_core::view::SolidView;
use std::collections::BTreeMap;

/// The displacement-correlation factor C of K_P (see the module doc). Measured on Sneddon's
/// penny under a uniform pressure (a quarter, the staircase front of a `GradedBox` without
/// `round`, the quasi-static rock; R from the faces' area): the uncorrected estimate, averaged
/// over the front, was 0.564 / 0.602 / 0.644 of 2 p sqrt(R / pi) at R/h = 4 / 8 / 16; C is
/// 1 / 0.644, set at 16 elements per radius, the resolution of the radial benchmark
/// (`tests/split3d.rs` `front_stress_intensity_matches_sneddons_penny`).
pub const DC_CALIBRATION: f64 = 1.55;

/// K_I at one front node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontNode {
    /// The node (view index).
    pub node: u32,
    /// K_I, Pa sqrt(m).
    pub k: f64,
}

/// K_I at every front node of the view's fractures ([`FrontNode`], in node order).
pub fn front_sif_nodes(v: &SolidView<Tet4>, e_prime: f64) -> Vec<FrontNode> {
    // A pair's opening (keyed by its node on face p) and each front node's pairs.
    let mut opening: BTreeMap<u32, f64> = BTreeMap::new();
    let mut behind: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for k in 0..v.joint_nodes.len() {
        let nodes = v.joint_nodes[k];
        let n = joint_frame_3d(v, k).n;
        let off = corner_offsets_3d(v, k);
        for a in 0..3 {
            if nodes[a] != nodes[a + 3] {
                opening.entry(nodes[a]).or_insert(dot(off[a], n));
            }
        }
        for a in (0..3).filter(|&a| nodes[a] == nodes[a + 3]) {
            let list = behind.entry(nodes[a]).or_default();
            for b in (0..3).filter(|&b| nodes[b] != nodes[b + 3]) {
                if !list.contains(&nodes[b]) {
                    list.push(nodes[b]);
                }
            }
        }
    }
    let x = |i: u32| v.x0[i as usize];
    let raw: Vec<(FrontNode, f64)> = behind
        .into_iter()
        .filter(|(_, ps)| !ps.is_empty())
        .filter_map(|(f, ps)| {
            let m = ps.len() as f64;
            let mean: [f64; 3] =
                std::array::from_fn(|d| ps.iter().map(|&p| x(p)[d]).sum::<f64>() / m);
            let out = sub(x(f), mean);
            let l = norm(out);
            if l == 0.0 {
                return None;
            }
            let out = out.map(|c| c / l);
            let ks: Vec<f64> = ps
                .iter()
                .filter_map(|&p| {
                    let s = dot(sub(x(f), x(p)), out);
                    (s > 0.0).then(|| {
                        DC_CALIBRATION
                            * 0.125
                            * e_prime
                            * (2.0 * std::f64::consts::PI / s).sqrt()
                            * opening[&p]
                    })
                })
                .collect();
            let h = ps.iter().map(|&p| norm(sub(x(f), x(p)))).sum::<f64>() / m;
            (!ks.is_empty()).then(|| {
                (
                    FrontNode {
                        node: f,
                        k: ks.iter().sum::<f64>() / ks.len() as f64,
                    },
                    h,
                )
            })
        })
        .collect();
    // The mean over the front nodes within SMOOTH_CELLS cells of each: a staircase front's
    // corners and straight runs see the square root at different distances.
    raw.iter()
        .map(|&(f, h)| {
            let near: Vec<f64> = raw
                .iter()
                .filter(|(g, _)| norm(sub(x(f.node), x(g.node))) <= SMOOTH_CELLS * h)
                .map(|(g, _)| g.k)
                .collect();
            FrontNode {
                k: near.iter().sum::<f64>() / near.len() as f64,
                ..f
            }
        })
        .collect()
}

/// The radius, in cells, over which the front nodes' K_I are averaged.
pub const SMOOTH_CELLS: f64 = 2.0;

/// `fracture_criterion` in 3D under `Toughness`: marks ready the candidate faces round the
/// front nodes whose K_I reaches `k_ic` (Pa sqrt(m)) (module doc). The candidate faces are the
/// view's `edge_*` rows (the discs' planes' faces). Returns the number of ready faces.
pub fn toughness_criterion_3d(v: &mut SolidView<Tet4>, e_prime: f64, k_ic: f64) -> usize {
    let growing: std::collections::BTreeSet<u32> = front_sif_nodes(v, e_prime)
        .iter()
        .filter(|f| f.k >= k_ic)
        .map(|f| f.node)
        .collect();
    let mut ready = 0;
    for k in 0..v.edge_elems.len() {
        // A corner of the face: a node of both its tetrahedra.
        let [a, b] = v.edge_elems[k].map(|e| v.conn[e as usize]);
        let r = !growing.is_empty() && a.iter().any(|n| b.contains(n) && growing.contains(n));
        v.edge_ready[k] = r;
        ready += r as usize;
    }
    ready
}
