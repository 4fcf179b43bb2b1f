//! Fracture systems. `fracture_criterion` (seed equation (7)): an internal edge is
//! fracture-ready when the normal stress across it, from the mean stress of its two elements,
//! reaches lambda*T0 (tension positive). It only marks edges; topology changes belong to the
//! split system. `contact` (joint penalty forces with Coulomb friction) and `fluid_pressure`
//! (the fracture fluid's pressure on the faces) add to the nodal forces.

pub use crate::params::JointParams;
use crate::view::SolidView;
use rayon::prelude::*;
use std::collections::BinaryHeap;

/// Normal stress n.sigma.n across a face with unit normal n, Pa, for sigma = [sxx, syy, sxy].
#[inline(always)]
pub fn normal_stress(s: [f64; 3], n: [f64; 2]) -> f64 {
    s[0] * n[0] * n[0] + s[1] * n[1] * n[1] + 2.0 * s[2] * n[0] * n[1]
}

/// The face stress of internal edge `k` that the criterion reads, [sxx, syy, sxy], Pa.
///
/// The face stress (`by_elements = false`, the default) is the area-weighted mean stress of the
/// edge's patch: the elements touching either end of the edge whose centroid lies alongside it
/// (projects onto the edge). In a uniform field it is exact, like any mean. At a crack tip it
/// also sees the tip's fan: on the seed's regular mesh the two elements beside the edge straight
/// ahead of a pressurised crack stay in compression while the element below/above the tip (where
/// the singular sigma_yy peaks, about 60 degrees off the crack line) turns tensile, so with the
/// mean of only the two elements beside the edge (`by_elements = true`) fractures branch off one
/// row beside the crack instead of running ahead (seen on Example I).
#[inline]
fn face_stress(v: &SolidView, k: usize, by_elements: bool) -> [f64; 3] {
    if by_elements {
        let [a, b] = v.edge_elems[k].map(|e| v.stress[e as usize]);
        [
            0.5 * (a[0] + b[0]),
            0.5 * (a[1] + b[1]),
            0.5 * (a[2] + b[2]),
        ]
    } else {
        let mut m = [0.0; 3];
        for &(e, w) in &v.patch[v.patch_ptr[k] as usize..v.patch_ptr[k + 1] as usize] {
            let s = v.stress[e as usize];
            m[0] += w * s[0];
            m[1] += w * s[1];
            m[2] += w * s[2];
        }
        m
    }
}

/// The normal stress n.sigma.n the strength test reads on internal edge `k`, Pa.
pub fn face_normal_stress(v: &SolidView, k: usize, by_elements: bool) -> f64 {
    normal_stress(face_stress(v, k, by_elements), v.edge_normal[k])
}

/// Work counts of the strength test.
#[derive(Clone, Copy, Debug, Default)]
pub struct StrengthCounts {
    /// Face stresses evaluated, and faces passed over by the screen, summed over passes.
    pub evaluated: u64,
    pub screened: u64,
}

/// A face's due point: evaluate it again once the accumulated displacement bound reaches
/// `at` (m).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Due {
    at: f64,
    edge: u32,
}
impl Eq for Due {}
impl Ord for Due {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        // Reversed: the standard max-heap then pops the earliest due point first.
        o.at.total_cmp(&self.at).then(o.edge.cmp(&self.edge))
    }
}
impl PartialOrd for Due {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

/// The strength test's screen: which faces can have reached the strength since they were last
/// evaluated.
///
/// A CST's stress is D B u, so between two passes every stress component of element e changes
/// by at most (lambda + 2G, lambda, G combined) (2 lambda + 3 G) S_e du, with
/// S_e = sum over its nodes of |dN/dx| + |dN/dy| and du the largest nodal displacement change
/// (either component); a face's normal stress, a convex combination of such stresses
/// projected on a unit normal, by the same bound with S = max S_e. So a face evaluated with
/// margin m = strength - sigma_n cannot reach the strength before the accumulated
/// (2 lambda + 3 G) S du reaches m: it is due then, and only due faces are evaluated
/// (a binary heap by due point). A topology change (split) evaluates every face again. The
/// marks are exactly those of the full evaluation (`tests/fracture_criterion.rs`).
#[derive(Clone, Debug, Default)]
pub struct StrengthScreen {
    generation: Option<u64>,
    /// Displacements at the last pass, m.
    u_ref: Vec<[f64; 2]>,
    /// Accumulated largest displacement change, m: after the last pass and before it.
    acc: f64,
    acc_before: f64,
    /// Stress change per metre of displacement change, Pa/m: (2 lambda + 3 G) max S_e.
    rate: f64,
    due: BinaryHeap<Due>,
    /// Faces evaluated at every pass (due soon).
    hot: Vec<u32>,
}

impl StrengthScreen {
    /// Evaluate face `k` again at the next pass (a mark that was taken back).
    pub fn recheck(&mut self, k: u32) {
        self.hot.push(k);
    }
}

/// `fracture_criterion`'s strength test: sigma_n of internal edges, marking edges with
/// sigma_n >= `strength` (lambda*T0, Pa; seed (7)). Marks stay once set. Returns the number of
/// fracture-ready edges.
///
/// `screen = None` evaluates every face (`edge_sigma_n` then holds every face's stress);
/// with a screen only the faces that can have reached the strength are evaluated
/// ([`StrengthScreen`]; `edge_sigma_n` holds each face's value at its last evaluation).
/// `stress_lags`: the element stresses were computed from the displacements of the previous
/// pass (the explicit scheme's `internal_force` runs before `integrate`), so the bound is the
/// one accumulated up to that pass. `skip_node`: faces touching a node marked there are not
/// tested (the toughness criterion's tip neighbourhoods).
#[allow(clippy::too_many_arguments)]
pub fn fracture_criterion(
    v: &mut SolidView,
    strength: f64,
    by_elements: bool,
    screen: Option<(&mut StrengthScreen, &crate::element::SolidParams, bool)>,
    skip_node: Option<&[bool]>,
    counts: &mut StrengthCounts,
) -> usize {
    let skipped = |v: &SolidView, k: usize| {
        let [a, b] = v.edge_nodes[k];
        skip_node.is_some_and(|s| s[a as usize] || s[b as usize])
    };
    let Some((sc, p, stress_lags)) = screen else {
        let (evaluated, _) = evaluate_all(v, strength, by_elements, &skipped);
        counts.evaluated += evaluated;
        return v.edge_ready.iter().filter(|r| **r).count();
    };
    // The displacement change since the last pass.
    let du = if sc.u_ref.len() == v.u.len() {
        v.u.iter()
            .zip(&sc.u_ref)
            .map(|(a, b)| (a[0] - b[0]).abs().max((a[1] - b[1]).abs()))
            .fold(0.0, f64::max)
    } else {
        f64::INFINITY
    };
    sc.u_ref.clone_from(&v.u);
    sc.acc_before = sc.acc;
    sc.acc += du;
    let now = if stress_lags { sc.acc_before } else { sc.acc };
    if sc.generation != Some(v.generation) || !now.is_finite() {
        // Every face again (new topology, or the first pass).
        sc.generation = Some(v.generation);
        (sc.acc, sc.acc_before) = (0.0, 0.0);
        let s_max = v
            .geom
            .iter()
            .map(|g| g[1..].iter().map(|x| x.abs()).sum::<f64>())
            .fold(0.0, f64::max);
        sc.rate = (2.0 * p.lam + 3.0 * p.g) * s_max;
        let (evaluated, _) = evaluate_all(v, strength, by_elements, &skipped);
        counts.evaluated += evaluated;
        sc.hot.clear();
        sc.due = (0..v.edge_nodes.len())
            .filter(|&k| !v.edge_ready[k] && !skipped(v, k))
            .map(|k| Due {
                at: (strength - v.edge_sigma_n[k]) / sc.rate,
                edge: k as u32,
            })
            .collect();
        return v.edge_ready.iter().filter(|r| **r).count();
    }
    // Faces due within HOT_PASSES passes of this pass's displacement change are kept in a
    // plain list and evaluated every pass (cheaper than a heap round trip each time).
    let hot_span = HOT_PASSES * du;
    let mut evaluated = 0;
    let mut eval = |v: &mut SolidView, k: u32, hot: &mut Vec<u32>, due: &mut BinaryHeap<Due>| {
        let ku = k as usize;
        let sn = normal_stress(face_stress(v, ku, by_elements), v.edge_normal[ku]);
        v.edge_sigma_n[ku] = sn;
        evaluated += 1;
        let wait = (strength - sn) / sc.rate;
        if sn >= strength {
            v.edge_ready[ku] = true;
        } else if wait <= hot_span {
            hot.push(k);
        } else {
            due.push(Due {
                at: now + wait,
                edge: k,
            });
        }
    };
    let mut hot = Vec::with_capacity(sc.hot.len());
    for k in std::mem::take(&mut sc.hot) {
        eval(v, k, &mut hot, &mut sc.due);
    }
    while let Some(d) = sc.due.peek().copied() {
        if d.at > now {
            break;
        }
        sc.due.pop();
        eval(v, d.edge, &mut hot, &mut sc.due);
    }
    sc.hot = hot;
    counts.evaluated += evaluated;
    counts.screened += sc.due.len() as u64;
    v.edge_ready.iter().filter(|r| **r).count()
}

/// See `fracture_criterion`'s screen: faces due within this many passes' worth of the
/// current displacement change are evaluated every pass instead of through the heap.
const HOT_PASSES: f64 = 8.0;

/// Evaluate every face not skipped, in parallel; returns (evaluated, skipped).
fn evaluate_all(
    v: &mut SolidView,
    strength: f64,
    by_elements: bool,
    skipped: &(dyn Fn(&SolidView, usize) -> bool + Sync),
) -> (u64, u64) {
    let mut sn = std::mem::take(&mut v.edge_sigma_n);
    let mut ready = std::mem::take(&mut v.edge_ready);
    let view = &*v;
    let r = sn
        .par_iter_mut()
        .zip(ready.par_iter_mut())
        .enumerate()
        .with_min_len(4096)
        .map(|(k, (sn, ready))| {
            if skipped(view, k) {
                return (0, 1);
            }
            *sn = normal_stress(face_stress(view, k, by_elements), view.edge_normal[k]);
            *ready |= *sn >= strength;
            (1, 0)
        })
        .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1));
    v.edge_sigma_n = sn;
    v.edge_ready = ready;
    r
}

pub use crate::view::{JointFrame, joint_frame};

/// `fluid_pressure`: the fluid in each fracture cell pushes its two faces apart. Joint k carries
/// cell `joint_cell[k]` (u32::MAX: none) at pressure `pressure[cell]` (Pa, the mean over the last
/// step's flow sub-steps): face q gets p L n (N/m, current normal and length of face p), face p
/// the opposite, half to each node. Adds to `force`. Serial, fixed scatter order.
pub fn fluid_pressure(v: &mut SolidView, joint_cell: &[u32], pressure: &[f64]) {
    for k in 0..v.joint_nodes.len() {
        let c = joint_cell[k];
        if c == u32::MAX {
            continue;
        }
        let p = pressure[c as usize];
        if p == 0.0 {
            continue;
        }
        let JointFrame { n, len, .. } = joint_frame(v, k);
        let fq = [p * len * n[0], p * len * n[1]];
        let nodes = v.joint_nodes[k];
        for (j, sgn) in [(0, -0.5), (1, -0.5), (2, 0.5), (3, 0.5)] {
            let i = nodes[j] as usize;
            v.force[i][0] += sgn * fq[0];
            v.force[i][1] += sgn * fq[1];
        }
    }
}

/// `contact` (seed (8)-(11)): for each joint, the offsets of face q's centre from face p's in
/// p's outward normal and tangent, delta_n and delta_t (current geometry). In contact
/// (delta_n < 0): F_n = -K_n delta_n; F_t += -K_t (change of delta_t), capped at mu F_n
/// (sliding). Open: both zero. Face q gets F_n n + F_t t, face p the opposite, half to each
/// node. Adds to `force` (after `internal_force` and `external_load`). Serial: joints are few
/// against elements and the scatter order is then fixed.
pub fn contact(v: &mut SolidView, p: &JointParams) {
    for k in 0..v.joint_nodes.len() {
        let nodes = v.joint_nodes[k];
        let JointFrame { n, t, dn, dt, .. } = joint_frame(v, k);
        let st = &mut v.joint_state[k];
        st.opening = dn;
        if dn < 0.0 {
            st.normal_force = -p.kn * dn;
            let mut ft = st.shear_force - p.kt * (dt - st.last_shear_offset);
            let cap = p.mu * st.normal_force;
            st.sliding = ft.abs() > cap;
            st.slid |= st.sliding;
            if st.sliding {
                ft = cap.copysign(ft);
            }
            st.shear_force = ft;
        } else {
            st.normal_force = 0.0;
            st.shear_force = 0.0;
            st.sliding = false;
        }
        st.last_shear_offset = dt;
        let fq = [
            st.normal_force * n[0] + st.shear_force * t[0],
            st.normal_force * n[1] + st.shear_force * t[1],
        ];
        for (j, sgn) in [(0, -0.5), (1, -0.5), (2, 0.5), (3, 0.5)] {
            let i = nodes[j] as usize;
            v.force[i][0] += sgn * fq[0];
            v.force[i][1] += sgn * fq[1];
        }
    }
}

/// Counters of the fracture systems.
#[derive(Clone, Debug, Default)]
pub struct FractureState {
    /// Internal edges marked fracture-ready so far (`fracture_criterion`).
    pub ready_edges: usize,
    /// Nodes split and edges opened so far (`split`).
    pub splits: usize,
    pub opened_edges: usize,
    /// (ready edges, topology generation) of the last split attempt that split nothing: a
    /// ready edge with both ends interior waits for the fracture to reach it, so `split` retries
    /// only when the ready set or the topology changed.
    pub last_idle_split: Option<(usize, u64)>,
    /// The toughness criterion's tips (`systems::toughness`).
    pub tips: crate::systems::toughness::Tips,
    /// The strength test's screen and its counts.
    pub screen: StrengthScreen,
    pub strength_counts: StrengthCounts,
}
