//! Fracture systems. `fracture_criterion` (seed equation (7)): an internal edge is
//! fracture-ready when the normal stress across it, from the mean stress of its two elements,
//! reaches lambda*T0 (tension positive). It only marks edges; topology changes belong to the
//! split system (issue "Fractures in the rock").

use crate::view::SolidView;
use rayon::prelude::*;

/// Normal stress n.sigma.n across a face with unit normal n, Pa, for sigma = [sxx, syy, sxy].
#[inline(always)]
pub fn normal_stress(s: [f64; 3], n: [f64; 2]) -> f64 {
    s[0] * n[0] * n[0] + s[1] * n[1] * n[1] + 2.0 * s[2] * n[0] * n[1]
}

/// `fracture_criterion`: sigma_n of every internal edge from the mean of its two elements'
/// stresses; mark edges with sigma_n >= `strength` (lambda*T0, Pa). Marks stay once set.
/// Returns the number of fracture-ready edges.
pub fn fracture_criterion(v: &mut SolidView, strength: f64) -> usize {
    let (stress, elems, normals) = (&v.stress, &v.edge_elems, &v.edge_normal);
    v.edge_sigma_n
        .par_iter_mut()
        .zip(v.edge_ready.par_iter_mut())
        .enumerate()
        .with_min_len(4096)
        .for_each(|(k, (sn, ready))| {
            let [a, b] = elems[k].map(|e| stress[e as usize]);
            let mean = [
                0.5 * (a[0] + b[0]),
                0.5 * (a[1] + b[1]),
                0.5 * (a[2] + b[2]),
            ];
            *sn = normal_stress(mean, normals[k]);
            *ready |= *sn >= strength;
        });
    v.edge_ready.iter().filter(|r| **r).count()
}

/// Joint constants: penalty stiffnesses K_n, K_t (Pa) and the friction coefficient tan(phi).
#[derive(Clone, Copy, Debug)]
pub struct JointParams {
    pub kn: f64,
    pub kt: f64,
    pub mu: f64,
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
        let x = nodes.map(|i| v.position(i as usize));
        let t = [x[1][0] - x[0][0], x[1][1] - x[0][1]];
        let len = t[0].hypot(t[1]);
        let t = [t[0] / len, t[1] / len];
        let s = v.joint_sign[k];
        let n = [s * t[1], -s * t[0]];
        let cp = [0.5 * (x[0][0] + x[1][0]), 0.5 * (x[0][1] + x[1][1])];
        let cq = [0.5 * (x[2][0] + x[3][0]), 0.5 * (x[2][1] + x[3][1])];
        let d = [cq[0] - cp[0], cq[1] - cp[1]];
        let (dn, dt) = (d[0] * n[0] + d[1] * n[1], d[0] * t[0] + d[1] * t[1]);
        let st = &mut v.joint_state[k];
        st.opening = dn;
        if dn < 0.0 {
            st.normal_force = -p.kn * dn;
            let mut ft = st.shear_force - p.kt * (dt - st.last_shear_offset);
            let cap = p.mu * st.normal_force;
            st.sliding = ft.abs() > cap;
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
