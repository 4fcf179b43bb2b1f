//! Fracture systems. `fracture_criterion` (seed equation (7)): an internal edge is
//! fracture-ready when the normal stress across it, from the mean stress of its two elements,
//! reaches lambda*T0 (tension positive). It only marks edges; topology changes belong to the
//! split system. `contact` (joint penalty forces with Coulomb friction) and `fluid_pressure`
//! (the fracture fluid's pressure on the faces) add to the nodal forces.

pub use crate::params::JointParams;
use crate::view::SolidView;
use rayon::prelude::*;

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

/// Largest principal stress of `s` = [sxx, syy, sxy], Pa, raised by 1e-9 of the components'
/// size so that it bounds n.s.n and any weighted mean of such values under rounding.
#[inline]
fn principal_bound(s: [f64; 3]) -> f64 {
    let c = 0.5 * (s[0] + s[1]);
    let r = (0.5 * (s[0] - s[1])).hypot(s[2]);
    c + r + 1e-9 * (s[0].abs() + s[1].abs() + 2.0 * s[2].abs())
}

/// Work counts of the strength test.
#[derive(Clone, Copy, Debug, Default)]
pub struct StrengthCounts {
    /// Faces whose stress was evaluated, and faces screened out by the bound, summed over
    /// passes.
    pub evaluated: u64,
    pub screened: u64,
}

/// `fracture_criterion`'s strength test: sigma_n of every internal edge, marking edges with
/// sigma_n >= `strength` (lambda*T0, Pa; seed (7)). Marks stay once set. Returns the number of
/// fracture-ready edges.
///
/// **Screening** (`screen`: scratch per node): no face stress can exceed the largest principal
/// stress of the elements it averages, and those all touch one of the edge's two nodes. So each
/// element's largest principal stress is computed once, each node keeps the largest of its
/// elements', and an edge whose two nodes' bounds are below the strength cannot be marked: its
/// face stress is not evaluated and `edge_sigma_n` holds that bound instead. The marks are
/// exactly those of the full evaluation (`screen = None`; `tests/fracture_criterion.rs`).
/// `skip_node`: faces touching a node marked there are not tested (the toughness criterion's
/// tip neighbourhoods).
pub fn fracture_criterion(
    v: &mut SolidView,
    strength: f64,
    by_elements: bool,
    screen: Option<&mut Vec<f64>>,
    skip_node: Option<&[bool]>,
    counts: &mut StrengthCounts,
) -> usize {
    let bound: Option<&[f64]> = match screen {
        Some(node_max) => {
            let (stress, ptr, inc) = (&v.stress, &v.inc_ptr, &v.inc);
            node_max.resize(v.x0.len(), 0.0);
            node_max
                .par_iter_mut()
                .enumerate()
                .with_min_len(4096)
                .for_each(|(i, m)| {
                    *m = inc[ptr[i] as usize..ptr[i + 1] as usize]
                        .iter()
                        .map(|&c| principal_bound(stress[(c / 6) as usize]))
                        .fold(f64::NEG_INFINITY, f64::max);
                });
            Some(node_max)
        }
        None => None,
    };
    let (evaluated, screened): (u64, u64) = {
        let mut sn = std::mem::take(&mut v.edge_sigma_n);
        let mut ready = std::mem::take(&mut v.edge_ready);
        let view = &*v;
        let r = sn
            .par_iter_mut()
            .zip(ready.par_iter_mut())
            .enumerate()
            .with_min_len(4096)
            .map(|(k, (sn, ready))| {
                let [a, b] = view.edge_nodes[k];
                if let Some(skip) = skip_node
                    && (skip[a as usize] || skip[b as usize])
                {
                    return (0, 0);
                }
                if let Some(m) = bound {
                    let ub = m[a as usize].max(m[b as usize]);
                    if ub < strength {
                        *sn = ub;
                        return (0, 1);
                    }
                }
                *sn = normal_stress(face_stress(view, k, by_elements), view.edge_normal[k]);
                *ready |= *sn >= strength;
                (1, 0)
            })
            .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1));
        v.edge_sigma_n = sn;
        v.edge_ready = ready;
        r
    };
    counts.evaluated += evaluated;
    counts.screened += screened;
    v.edge_ready.iter().filter(|r| **r).count()
}

/// Current geometry of joint `k`: face p's unit tangent t (from its first node to its second),
/// its outward unit normal n (towards face q), its length (m), and the offsets of face q's centre
/// from face p's along n (opening delta_n, m, positive when the faces separate) and along t
/// (delta_t, m) (seed (8)).
#[derive(Clone, Copy, Debug)]
pub struct JointFrame {
    pub n: [f64; 2],
    pub t: [f64; 2],
    pub len: f64,
    pub dn: f64,
    pub dt: f64,
}

#[inline]
pub fn joint_frame(v: &SolidView, k: usize) -> JointFrame {
    let nodes = v.joint_nodes[k];
    let x = nodes.map(|i| v.position(i as usize));
    let t = [x[1][0] - x[0][0], x[1][1] - x[0][1]];
    let len = t[0].hypot(t[1]);
    let t = [t[0] / len, t[1] / len];
    let s = v.joint_sign[k];
    let n = [s * t[1], -s * t[0]];
    let cp = [0.5 * (x[0][0] + x[1][0]), 0.5 * (x[0][1] + x[1][1])];
    let cq = [0.5 * (x[2][0] + x[3][0]), 0.5 * (x[2][1] + x[3][1])];
    let d = [cq[0] - cp[0], cq[1] - cp[1]];
    JointFrame {
        n,
        t,
        len,
        dn: d[0] * n[0] + d[1] * n[1],
        dt: d[0] * t[0] + d[1] * t[1],
    }
}

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
    /// Scratch of the strength test's screening (one bound per node) and its counts.
    pub screen: Vec<f64>,
    pub strength_counts: StrengthCounts,
}
