//! The linear tetrahedron (TET4), the seed's 3D solid element: geometry, strain, 3D Hooke's law,
//! nodal forces, the element stiffness, the lumped mass and the element's exact critical step.
//! Each is a pure function of one element's nodes and displacements, the 3D counterpart of the
//! CST in [`crate::element`] (which keeps the 2D formulas; the Lame constants are shared through
//! [`SolidParams`]).
//!
//! Conventions: SI units (m, Pa, kg/m^3, s), tension positive. Strain and stress in Voigt order
//! `[xx, yy, zz, xy, yz, zx]` with engineering shear strains (gamma = 2 eps). A tetrahedron
//! `[a, b, c, d]` is positively oriented when (b - a) x (c - a) . (d - a) > 0; its volume is a
//! sixth of that.
//!
//! In the engine through [`crate::dim::Tet4`] (the 3D element kind of the generic solid
//! systems); also used by [`crate::tetmesh`] and the 3D tests (`tests/tet_solid.rs`,
//! `tests/three_d.rs`).

use crate::element::SolidParams;
use nalgebra::{Matrix3, SMatrix, SVector, SymmetricEigen};

/// Geometry of one tetrahedron: its volume (m^3) and the gradients of the shape functions of
/// nodes 1 to 3 (1/m), `grad[k] = [dN_{k+1}/dx, dN_{k+1}/dy, dN_{k+1}/dz]`. Node 0's is minus
/// their sum (the shape functions sum to one), so it is not stored ([`TetGeometry::grads`]
/// gives all four): the explicit step reads 80 bytes per element instead of 104.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TetGeometry {
    pub volume: f64,
    pub grad: [[f64; 3]; 3],
}

impl TetGeometry {
    /// The four shape-function gradients, node 0's first: grad N_0 = -(grad N_1 + grad N_2 +
    /// grad N_3), 1/m.
    #[inline(always)]
    pub fn grads(&self) -> [[f64; 3]; 4] {
        let g = &self.grad;
        let g0 = std::array::from_fn(|d| -(g[0][d] + g[1][d] + g[2][d]));
        [g0, g[0], g[1], g[2]]
    }
}

/// The four sides of a tetrahedron given by its nodes, each as the sorted triple of the nodes
/// off one corner (corner 0's side first).
pub fn sorted_sides<T: Copy + Ord>(t: [T; 4]) -> [[T; 3]; 4] {
    std::array::from_fn(|skip| {
        let mut f = [t[0]; 3];
        let mut m = 0;
        for (a, &n) in t.iter().enumerate() {
            if a != skip {
                f[m] = n;
                m += 1;
            }
        }
        f.sort_unstable();
        f
    })
}

/// Signed volume of the tetrahedron (a, b, c, d), positive when positively oriented, m^3.
pub fn signed_volume(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    let e = |p: [f64; 3]| [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let (u, v, w) = (e(b), e(c), e(d));
    (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0]))
        / 6.0
}

/// Volume and shape-function gradients of a tetrahedron. `None` when it is degenerate or
/// inverted (signed volume not above 1e-12 of its edges' bounding cube).
///
/// With J = [x1 - x0, x2 - x0, x3 - x0] (columns), N_k = xi_k for k = 1..3 and
/// N_0 = 1 - xi_1 - xi_2 - xi_3, the gradient of N_k is row k - 1 of J^-1 (stored), and
/// grad N_0 = -(grad N_1 + grad N_2 + grad N_3).
pub fn geometry(x: [[f64; 3]; 4]) -> Option<TetGeometry> {
    let volume = signed_volume(x[0], x[1], x[2], x[3]);
    let scale = (1..4)
        .flat_map(|k| (0..3).map(move |d| (k, d)))
        .fold(0.0f64, |m, (k, d)| m.max((x[k][d] - x[0][d]).abs()));
    if volume.is_nan() || volume <= 1e-12 * scale * scale * scale {
        return None;
    }
    let j = Matrix3::from_fn(|r, c| x[c + 1][r] - x[0][r]);
    let inv = j.try_inverse()?;
    let grad = std::array::from_fn(|k| std::array::from_fn(|d| inv[(k, d)]));
    Some(TetGeometry { volume, grad })
}

/// Strain of one element from its nodal displacements (m): Voigt, engineering shear.
#[inline(always)]
pub fn strain(g: &TetGeometry, u: [[f64; 3]; 4]) -> [f64; 6] {
    // H = grad u, H[i][j] = du_i / dx_j = sum_a u_a,i dN_a/dx_j; with grad N_0 = -(sum of
    // the others), H = sum_{k=1..3} (u_k - u_0)_i dN_k/dx_j: 27 products instead of 36.
    // Column j of H is sum_k (u_k - u_0) dN_k/dx_j: written over four lanes (the fourth
    // unused) so that the compiler can use whole vector registers; each entry is the same
    // sum in the same order as written out by component.
    let g = &g.grad;
    let u0 = lanes(u[0]);
    let du: [Lanes; 3] = std::array::from_fn(|k| lane_sub(lanes(u[k + 1]), u0));
    let h: [Lanes; 3] = std::array::from_fn(|j| {
        lane_add(
            lane_add(lane_scale(du[0], g[0][j]), lane_scale(du[1], g[1][j])),
            lane_scale(du[2], g[2][j]),
        )
    });
    // h[j][i] = H[i][j].
    [
        h[0][0],
        h[1][1],
        h[2][2],
        h[1][0] + h[0][1],
        h[2][1] + h[1][2],
        h[0][2] + h[2][0],
    ]
}

/// Four f64 lanes: a 3-vector and an unused fourth lane (see [`strain`]).
type Lanes = [f64; 4];

#[inline(always)]
fn lanes(v: [f64; 3]) -> Lanes {
    [v[0], v[1], v[2], 0.0]
}

#[inline(always)]
fn lane_add(a: Lanes, b: Lanes) -> Lanes {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]]
}

#[inline(always)]
fn lane_sub(a: Lanes, b: Lanes) -> Lanes {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3]]
}

#[inline(always)]
fn lane_scale(a: Lanes, s: f64) -> Lanes {
    [a[0] * s, a[1] * s, a[2] * s, a[3] * s]
}

/// Isotropic Hooke's law in 3D: stress (Pa, Voigt) from strain (Voigt, engineering shear).
#[inline(always)]
pub fn hooke(e: [f64; 6], p: &SolidParams) -> [f64; 6] {
    let tr = e[0] + e[1] + e[2];
    [
        p.lam * tr + 2.0 * p.g * e[0],
        p.lam * tr + 2.0 * p.g * e[1],
        p.lam * tr + 2.0 * p.g * e[2],
        p.g * e[3],
        p.g * e[4],
        p.g * e[5],
    ]
}

/// Nodal internal forces of one element, f_a = -V B_a^T sigma, N.
#[inline(always)]
pub fn forces(g: &TetGeometry, s: [f64; 6]) -> [[f64; 3]; 4] {
    let f = forces_flat(g, s);
    std::array::from_fn(|a| [f[3 * a], f[3 * a + 1], f[3 * a + 2]])
}

/// [`forces`] node by node in one array `[f0x, f0y, f0z, f1x, ..]` (the engine's layout).
/// Node 0's force is minus the other three's (grad N_0 = -(sum of the others)), so the
/// element's forces sum to zero to round-off.
#[inline(always)]
pub fn forces_flat(g: &TetGeometry, s: [f64; 6]) -> [f64; 12] {
    // f_k = -V sigma grad N_k = sum_j (-V sigma)_{:, j} dN_k/dx_j, over the columns of the
    // symmetric stress in four lanes (as in [`strain`]).
    let sv = s.map(|x| -g.volume * x);
    let col = [
        [sv[0], sv[3], sv[5], 0.0],
        [sv[3], sv[1], sv[4], 0.0],
        [sv[5], sv[4], sv[2], 0.0],
    ];
    let fk: [Lanes; 3] = std::array::from_fn(|k| {
        let b = &g.grad[k];
        lane_add(
            lane_add(lane_scale(col[0], b[0]), lane_scale(col[1], b[1])),
            lane_scale(col[2], b[2]),
        )
    });
    let f0 = lane_add(lane_add(fk[0], fk[1]), fk[2]);
    [
        -f0[0], -f0[1], -f0[2], fk[0][0], fk[0][1], fk[0][2], fk[1][0], fk[1][1], fk[1][2],
        fk[2][0], fk[2][1], fk[2][2],
    ]
}

/// Strain-displacement matrix B (6 x 12): eps = B u with u = [u0x, u0y, u0z, u1x, ...].
pub fn b_matrix(g: &TetGeometry) -> SMatrix<f64, 6, 12> {
    let mut b = SMatrix::<f64, 6, 12>::zeros();
    for (a, d) in g.grads().iter().enumerate() {
        let c = 3 * a;
        b[(0, c)] = d[0];
        b[(1, c + 1)] = d[1];
        b[(2, c + 2)] = d[2];
        b[(3, c)] = d[1];
        b[(3, c + 1)] = d[0];
        b[(4, c + 1)] = d[2];
        b[(4, c + 2)] = d[1];
        b[(5, c)] = d[2];
        b[(5, c + 2)] = d[0];
    }
    b
}

/// Elasticity matrix D (6 x 6) of [`hooke`].
pub fn d_matrix(p: &SolidParams) -> SMatrix<f64, 6, 6> {
    let mut d = SMatrix::<f64, 6, 6>::zeros();
    for i in 0..3 {
        for j in 0..3 {
            d[(i, j)] = if i == j { p.lam2g } else { p.lam };
        }
        d[(3 + i, 3 + i)] = p.g;
    }
    d
}

/// Element stiffness K_e = V B^T D B (12 x 12), N/m.
pub fn stiffness(g: &TetGeometry, p: &SolidParams) -> SMatrix<f64, 12, 12> {
    let b = b_matrix(g);
    (b.transpose() * d_matrix(p) * b) * g.volume
}

/// Lumped mass of each of the element's nodes, rho V / 4, kg.
pub fn lumped_mass(g: &TetGeometry, density: f64) -> f64 {
    density * g.volume / 4.0
}

/// The element's exact critical step of the central-difference scheme with the lumped mass,
/// s: 2 / omega_max with omega_max^2 the largest eigenvalue of K_e / (rho V / 4). By the
/// element eigenvalue theorem (Irons) the smallest over the elements bounds the mesh's step
/// from below.
pub fn critical_step(g: &TetGeometry, p: &SolidParams, density: f64) -> f64 {
    let k = stiffness(g, p);
    let lmax = SymmetricEigen::new(k)
        .eigenvalues
        .iter()
        .fold(0.0f64, |m, &l| m.max(l));
    2.0 / (lmax / lumped_mass(g, density)).sqrt()
}

/// The element's displacements as one vector [u0x, u0y, u0z, u1x, ...].
pub fn element_vector(u: [[f64; 3]; 4]) -> SVector<f64, 12> {
    SVector::<f64, 12>::from_fn(|i, _| u[i / 3][i % 3])
}

/// The six dihedral angles of a tetrahedron, degrees: along the edge (i, j) the angle between
/// the faces opposite the other two vertices k, l, acos(-g_k . g_l / (|g_k| |g_l|)) with g the
/// shape-function gradients (each normal to the face opposite its vertex, pointing at it).
/// A regular tetrahedron has 70.5 degrees everywhere; a Kuhn cube's six have 45, 60 and 90.
pub fn dihedral_angles(g: &TetGeometry) -> [f64; 6] {
    const PAIRS: [(usize, usize); 6] = [(2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1)];
    let gr = g.grads();
    PAIRS.map(|(k, l)| {
        let (a, b) = (gr[k], gr[l]);
        (-dot(a, b) / (norm(a) * norm(b)))
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees()
    })
}

/// a - b.
pub fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// a . b.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a x b.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// |a|.
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// Area of a triangle in space, m^2.
pub fn triangle_area(p: [[f64; 3]; 3]) -> f64 {
    0.5 * norm(cross(sub(p[1], p[0]), sub(p[2], p[0])))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Damping;

    fn params() -> SolidParams {
        let rock = crate::scenario::Material {
            young: 30e9,
            poisson: 0.25,
            density: 2700.0,
        };
        SolidParams::of(&rock, Damping::default())
    }

    fn skew() -> [[f64; 3]; 4] {
        [
            [0.1, -0.2, 0.05],
            [1.3, 0.1, -0.1],
            [0.2, 0.9, 0.3],
            [0.4, 0.3, 1.1],
        ]
    }

    #[test]
    fn lane_form_gives_the_bits_of_the_component_form() {
        // The strain and forces written over four lanes sum the same products in the same
        // order as written out by component (the form before the lanes), so the bits agree.
        let p = params();
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..2000 {
            let x0 = skew();
            let x: [[f64; 3]; 4] = std::array::from_fn(|a| x0[a].map(|c| c + 0.2 * next()));
            let Some(g) = geometry(x) else { continue };
            let u: [[f64; 3]; 4] =
                std::array::from_fn(|_| [next(), next(), next()].map(|c| 1e-3 * c));
            // The component form.
            let gr = &g.grad;
            let du: [[f64; 3]; 3] =
                std::array::from_fn(|k| std::array::from_fn(|i| u[k + 1][i] - u[0][i]));
            let h: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    du[0][i] * gr[0][j] + du[1][i] * gr[1][j] + du[2][i] * gr[2][j]
                })
            });
            let e = [
                h[0][0],
                h[1][1],
                h[2][2],
                h[0][1] + h[1][0],
                h[1][2] + h[2][1],
                h[2][0] + h[0][2],
            ];
            assert_eq!(strain(&g, u).map(f64::to_bits), e.map(f64::to_bits));
            let s = hooke(e, &p);
            let sv = s.map(|x| -g.volume * x);
            let mut f = [0.0; 12];
            for (k, b) in gr.iter().enumerate() {
                let a = 3 * (k + 1);
                f[a] = b[0] * sv[0] + b[1] * sv[3] + b[2] * sv[5];
                f[a + 1] = b[0] * sv[3] + b[1] * sv[1] + b[2] * sv[4];
                f[a + 2] = b[0] * sv[5] + b[1] * sv[4] + b[2] * sv[2];
            }
            for d in 0..3 {
                f[d] = -(f[3 + d] + f[6 + d] + f[9 + d]);
            }
            assert_eq!(forces_flat(&g, s).map(f64::to_bits), f.map(f64::to_bits));
        }
    }

    #[test]
    fn shape_gradients_reproduce_linear_fields() {
        // sum_a N_a = 1 and sum_a x_a grad N_a = I: exact for any tetrahedron, to round-off.
        let x = skew();
        let g = geometry(x).expect("valid");
        let gr = g.grads();
        for d in 0..3 {
            let s: f64 = gr.iter().map(|b| b[d]).sum();
            assert!(s.abs() < 1e-13, "sum of dN/dx_{d} = {s}");
            for e in 0..3 {
                let m: f64 = (0..4).map(|a| x[a][e] * gr[a][d]).sum();
                let want = if d == e { 1.0 } else { 0.0 };
                assert!((m - want).abs() < 1e-13, "x_{e} gradient along {d}: {m}");
            }
        }
        assert!(
            geometry([x[1], x[0], x[2], x[3]]).is_none(),
            "inverted accepted"
        );
    }

    #[test]
    fn rigid_motions_carry_no_force_and_a_uniform_strain_is_exact() {
        let x = skew();
        let g = geometry(x).expect("valid");
        let p = params();
        // A rigid translation and a small rotation about z: zero strain to round-off.
        let w = 1e-3;
        let u = x.map(|q| [0.3 - w * q[1], 0.1 + w * q[0], -0.2]);
        let e = strain(&g, u);
        assert!(e.iter().all(|v| v.abs() < 1e-15), "rigid strain {e:?}");
        let k = stiffness(&g, &p);
        let f = k * element_vector(u);
        assert!(
            f.amax() < 1e-3 * 1e-4 * k.amax(),
            "rigid force {}",
            f.amax()
        );
        // The six rigid modes: K_e has exactly six zero eigenvalues and six positive ones.
        let ev = SymmetricEigen::new(k).eigenvalues;
        let small = ev.iter().filter(|l| l.abs() < 1e-9 * k.amax()).count();
        assert_eq!(small, 6, "zero eigenvalues {ev:?}");
        assert!(ev.iter().all(|&l| l > -1e-9 * k.amax()));
        // A linear field u = E x: the strain is E's symmetric part, exactly.
        let m = [[1e-4, 2e-5, -3e-5], [4e-5, -2e-4, 1e-5], [0.0, 5e-5, 3e-4]];
        let u = x.map(|q| {
            let mut r = [0.0; 3];
            for i in 0..3 {
                r[i] = (0..3).map(|j| m[i][j] * q[j]).sum();
            }
            r
        });
        let e = strain(&g, u);
        let want = [
            m[0][0],
            m[1][1],
            m[2][2],
            m[0][1] + m[1][0],
            m[1][2] + m[2][1],
            m[2][0] + m[0][2],
        ];
        for (a, b) in e.iter().zip(want) {
            assert!((a - b).abs() < 1e-16, "strain {e:?} against {want:?}");
        }
        // Forces from the kernel equal K_e u, and they balance.
        let f = forces(&g, hooke(e, &p));
        let ku = k * element_vector(u);
        for a in 0..4 {
            for d in 0..3 {
                assert!((f[a][d] + ku[3 * a + d]).abs() < 1e-9 * ku.amax());
            }
        }
        for d in 0..3 {
            assert!((0..4).map(|a| f[a][d]).sum::<f64>().abs() < 1e-9 * ku.amax());
        }
    }

    #[test]
    fn hooke_gives_the_uniaxial_strain_modulus() {
        // Uniaxial strain: sigma_xx = (lambda + 2G) e, sigma_yy = sigma_zz = lambda e.
        let p = params();
        let s = hooke([1e-4, 0.0, 0.0, 0.0, 0.0, 0.0], &p);
        assert!((s[0] - p.lam2g * 1e-4).abs() < 1e-6);
        assert!((s[1] - p.lam * 1e-4).abs() < 1e-6 && (s[2] - s[1]).abs() < 1e-9);
        // Uniaxial stress: E = G (3 lambda + 2 G) / (lambda + G) and nu from the lateral strain.
        let (lam, g) = (p.lam, p.g);
        let young = g * (3.0 * lam + 2.0 * g) / (lam + g);
        let nu = lam / (2.0 * (lam + g));
        let e = [1e-4, -nu * 1e-4, -nu * 1e-4, 0.0, 0.0, 0.0];
        let s = hooke(e, &p);
        assert!((s[0] - young * 1e-4).abs() < 1e-9 * young);
        assert!(s[1].abs() < 1e-9 * young && s[2].abs() < 1e-9 * young);
        assert!((young - 30e9).abs() < 1e-3 && (nu - 0.25).abs() < 1e-15);
    }
}
