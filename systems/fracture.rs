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
