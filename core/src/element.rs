//! The plane-strain constant-strain triangle (CST): strain, Hooke's law, nodal forces and the
//! element stiffness matrix, each a pure function of one element's geometry and displacements.
//! One home for these formulas: the explicit kernels (`systems/solid.rs`), the frame writer and
//! the reference kernel call them.
//!
//! Geometry `g` is `[A, b1, b2, b3, c1, c2, c3]`: the area (m^2) and the shape-function
//! gradients dN_a/dx = b_a, dN_a/dy = c_a (1/m) (see `model::element_geometry`).

use crate::scenario::Damping;
use nalgebra::{SMatrix, SVector};

/// Material constants and damping of the solid kernels (the step length and the load factor
/// are state: `hydrofrac_systems::monitor::Clock`).
#[derive(Clone, Copy, Debug)]
pub struct SolidParams {
    /// lambda + 2G, Pa.
    pub lam2g: f64,
    /// Lame's lambda, Pa.
    pub lam: f64,
    /// Shear modulus G, Pa.
    pub g: f64,
    pub damping: Damping,
}

impl SolidParams {
    /// The Lame constants of an isotropic material (`Material::lambda`, `Material::shear`),
    /// Pa, with the given damping.
    pub fn of(material: &crate::scenario::Material, damping: Damping) -> Self {
        SolidParams {
            lam2g: material.lambda() + 2.0 * material.shear(),
            lam: material.lambda(),
            g: material.shear(),
            damping,
        }
    }
}

/// Strain of one element from its nodal displacements: [exx, eyy, gamma_xy] (engineering shear).
#[inline(always)]
pub fn cst_strain(g: &[f64; 7], u: [[f64; 2]; 3]) -> [f64; 3] {
    [
        g[1] * u[0][0] + g[2] * u[1][0] + g[3] * u[2][0],
        g[4] * u[0][1] + g[5] * u[1][1] + g[6] * u[2][1],
        g[4] * u[0][0]
            + g[5] * u[1][0]
            + g[6] * u[2][0]
            + g[1] * u[0][1]
            + g[2] * u[1][1]
            + g[3] * u[2][1],
    ]
}

/// Plane-strain Hooke's law: [sxx, syy, sxy], Pa, from [exx, eyy, gamma_xy].
#[inline(always)]
pub fn hooke(e: [f64; 3], p: &SolidParams) -> [f64; 3] {
    [
        p.lam2g * e[0] + p.lam * e[1],
        p.lam * e[0] + p.lam2g * e[1],
        p.g * e[2],
    ]
}

/// Stress of one element from its nodal displacements: [sxx, syy, sxy], Pa.
#[inline(always)]
pub fn cst_stress(g: &[f64; 7], u: [[f64; 2]; 3], p: &SolidParams) -> [f64; 3] {
    hooke(cst_strain(g, u), p)
}

/// Nodal internal forces of one element, f_a = -A B_a^T sigma, N/m.
#[inline(always)]
pub fn cst_forces(g: &[f64; 7], s: [f64; 3]) -> [f64; 6] {
    let a = g[0];
    let mut f = [0.0; 6];
    for k in 0..3 {
        let (bx, by) = (g[1 + k], g[4 + k]);
        f[2 * k] = -a * (bx * s[0] + by * s[2]);
        f[2 * k + 1] = -a * (bx * s[2] + by * s[1]);
    }
    f
}

/// Strain-displacement matrix B (3 x 6) of one element: eps = B u with
/// u = [ux1, uy1, ux2, uy2, ux3, uy3] and eps = [exx, eyy, gamma_xy].
pub fn b_matrix(g: &[f64; 7]) -> SMatrix<f64, 3, 6> {
    let mut b = SMatrix::<f64, 3, 6>::zeros();
    for k in 0..3 {
        let (bx, by) = (g[1 + k], g[4 + k]);
        b[(0, 2 * k)] = bx;
        b[(1, 2 * k + 1)] = by;
        b[(2, 2 * k)] = by;
        b[(2, 2 * k + 1)] = bx;
    }
    b
}

/// Plane-strain elasticity matrix D (Pa): sigma = D eps.
pub fn d_matrix(p: &SolidParams) -> SMatrix<f64, 3, 3> {
    SMatrix::<f64, 3, 3>::new(
        p.lam2g, p.lam, 0.0, //
        p.lam, p.lam2g, 0.0, //
        0.0, 0.0, p.g,
    )
}

/// Element stiffness matrix K_e = A B^T D B (N/m per m of displacement, per unit thickness):
/// the internal force is f = -K_e u (see [`cst_forces`]).
pub fn element_stiffness(g: &[f64; 7], p: &SolidParams) -> SMatrix<f64, 6, 6> {
    let b = b_matrix(g);
    (b.transpose() * d_matrix(p) * b) * g[0]
}

/// Nodal displacements of one element as the 6-vector [ux1, uy1, ux2, uy2, ux3, uy3].
pub fn element_vector(u: [[f64; 2]; 3]) -> SVector<f64, 6> {
    SVector::<f64, 6>::from_iterator(u.iter().flatten().copied())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> SolidParams {
        let (e, nu) = (30e9, 0.25);
        let lam = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let g = e / (2.0 * (1.0 + nu));
        SolidParams {
            lam2g: lam + 2.0 * g,
            lam,
            g,
            damping: Damping::None,
        }
    }

    /// The stiffness matrix reproduces the explicit kernel's forces, is symmetric, and has the
    /// three rigid-body modes in its null space.
    #[test]
    fn stiffness_matches_the_kernel_and_has_rigid_modes() {
        let e = crate::model::element_geometry([[0.0, 0.0], [1.3, 0.2], [0.4, 0.9]]);
        let g = [
            e.area, e.dndx[0], e.dndx[1], e.dndx[2], e.dndy[0], e.dndy[1], e.dndy[2],
        ];
        let p = params();
        let k = element_stiffness(&g, &p);
        let u = [[1e-3, -2e-4], [3e-4, 5e-4], [-7e-4, 2e-4]];
        let f = cst_forces(&g, cst_stress(&g, u, &p));
        let fk = -(k * element_vector(u));
        let scale = f.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        for i in 0..6 {
            assert!(
                (f[i] - fk[i]).abs() <= 1e-12 * scale,
                "{i}: {} vs {}",
                f[i],
                fk[i]
            );
        }
        assert!((k - k.transpose()).abs().max() <= 1e-12 * k.abs().max());
        let x = [[0.0, 0.0], [1.3, 0.2], [0.4, 0.9]];
        for rigid in [[[1.0, 0.0]; 3], [[0.0, 1.0]; 3], x.map(|p| [-p[1], p[0]])] {
            let r = k * element_vector(rigid);
            assert!(r.abs().max() <= 1e-9 * k.abs().max(), "{r}");
        }
    }
}
