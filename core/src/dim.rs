//! Where the dimension enters: the solid element kind of a run, CST (2D, plane strain) or TET4
//! (3D). The dense solid view ([`crate::view::SolidView`]) and the solid systems
//! (`hydrofrac_systems::solid`: internal force, external load, damping, central-difference
//! integration, strain energy) are written once, generic over [`Element`]; the element formulas
//! stay in their homes ([`crate::element`] for the CST, [`crate::tet4`] for the TET4) and this
//! module only names them.
//!
//! The 2D kind is the default type parameter everywhere, so 2D code reads `SolidView` and its
//! fields are the concrete arrays they always were; the generic kernels do the same operations
//! in the same order as the 2D ones did, so 2D results are unchanged to the bit.
//!
//! Units: SI. Measures are per unit thickness in 2D (area m^2, forces N/m, masses kg/m) and
//! absolute in 3D (volume m^3, forces N, masses kg).

use crate::element::{SolidParams, cst_forces, cst_strain, cst_stress, hooke};
use crate::tet4;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt::Debug;
use std::ops::{Index, IndexMut};

/// Plain per-item data a view holds in arrays and checkpoints save: copyable, comparable,
/// thread-safe, serialisable.
pub trait Plain:
    Copy + Default + Debug + PartialEq + Send + Sync + 'static + Serialize + DeserializeOwned
{
}

impl<T> Plain for T where
    T: Copy + Default + Debug + PartialEq + Send + Sync + 'static + Serialize + DeserializeOwned
{
}

/// A small fixed array of numbers (a node vector, an element's stress or nodal forces).
pub trait Numbers:
    Plain + Index<usize, Output = f64> + IndexMut<usize> + AsRef<[f64]> + AsMut<[f64]>
{
}

impl<T> Numbers for T where
    T: Plain + Index<usize, Output = f64> + IndexMut<usize> + AsRef<[f64]> + AsMut<[f64]>
{
}

/// A solid element kind: its space dimension, the shapes of its per-node and per-element data,
/// and the kernels of the explicit step (strain, stress and nodal forces of one element).
pub trait Element: Plain {
    /// Space dimension (2 or 3).
    const D: usize;
    /// Nodes per element.
    const NODES: usize;
    /// A node vector (position, displacement, velocity, force): `[f64; D]`.
    type Vector: Numbers;
    /// The dense node indices of one element: `[u32; NODES]`.
    type Conn: Plain + AsRef<[u32]>;
    /// The element's reference geometry (measure and shape-function gradients).
    type Geom: Plain;
    /// Stress (Pa) in Voigt order: `[xx, yy, xy]` in 2D, `[xx, yy, zz, xy, yz, zx]` in 3D.
    type Stress: Numbers;
    /// Nodal forces of one element, node by node: `[f64; D * NODES]`.
    type Forces: Numbers;

    /// Area (2D, m^2) or volume (3D, m^3) of the element.
    fn measure(g: &Self::Geom) -> f64;
    /// Stress of the element `c` from the displacements `u` of every node (m), Pa.
    fn stress(g: &Self::Geom, c: &Self::Conn, u: &[Self::Vector], p: &SolidParams) -> Self::Stress;
    /// Nodal internal forces f_a = -measure B_a^T sigma (N/m in 2D, N in 3D).
    fn forces(g: &Self::Geom, s: &Self::Stress) -> Self::Forces;
    /// Strain energy of the element, 1/2 measure sigma:epsilon (J/m in 2D, J in 3D).
    fn strain_energy(g: &Self::Geom, c: &Self::Conn, u: &[Self::Vector], p: &SolidParams) -> f64;
    /// The element stiffness K_e = measure B^T D B (D * NODES square, dofs node by node), N/m
    /// per m in 2D, N/m in 3D: the internal force is f = -K_e u.
    fn stiffness(g: &Self::Geom, p: &SolidParams) -> Self::Stiffness;
    /// The type of [`Element::stiffness`].
    type Stiffness: Index<(usize, usize), Output = f64>;
    /// A joint's dense nodes, face p's then face q's: `[u32; 4]` (two edges) in 2D, `[u32; 6]`
    /// (two triangles) in 3D.
    type JointNodes: Plain + AsRef<[u32]>;
    /// A joint's tangential force and offset: one component in 2D, two in 3D.
    type Shear: Plain;
}

/// The plane-strain constant-strain triangle (2D). Geometry `[A, dN/dx (3), dN/dy (3)]`.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct Cst;

impl Element for Cst {
    const D: usize = 2;
    const NODES: usize = 3;
    type Vector = [f64; 2];
    type Conn = [u32; 3];
    type Geom = [f64; 7];
    type Stress = [f64; 3];
    type Forces = [f64; 6];
    type Stiffness = nalgebra::SMatrix<f64, 6, 6>;
    type JointNodes = [u32; 4];
    type Shear = f64;

    #[inline(always)]
    fn measure(g: &[f64; 7]) -> f64 {
        g[0]
    }
    #[inline(always)]
    fn stress(g: &[f64; 7], c: &[u32; 3], u: &[[f64; 2]], p: &SolidParams) -> [f64; 3] {
        cst_stress(g, [u[c[0] as usize], u[c[1] as usize], u[c[2] as usize]], p)
    }
    #[inline(always)]
    fn forces(g: &[f64; 7], s: &[f64; 3]) -> [f64; 6] {
        cst_forces(g, *s)
    }
    #[inline(always)]
    fn strain_energy(g: &[f64; 7], c: &[u32; 3], u: &[[f64; 2]], p: &SolidParams) -> f64 {
        // Plane strain: the zz term vanishes because eps_zz = 0.
        let eps = cst_strain(g, [u[c[0] as usize], u[c[1] as usize], u[c[2] as usize]]);
        let s = hooke(eps, p);
        0.5 * g[0] * (s[0] * eps[0] + s[1] * eps[1] + s[2] * eps[2])
    }
    fn stiffness(g: &[f64; 7], p: &SolidParams) -> Self::Stiffness {
        crate::element::element_stiffness(g, p)
    }
}

/// The linear tetrahedron (3D). Geometry: [`tet4::TetGeometry`], the volume (m^3) and the
/// shape-function gradients of nodes 1 to 3 (1/m; node 0's is minus their sum); the component
/// packs it (`TetGeom`).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct Tet4;

/// A TET4's packed geometry: volume, then the shape-function gradients of nodes 1 to 3.
#[inline(always)]
pub fn tet_geometry(g: &[f64; 10]) -> tet4::TetGeometry {
    tet4::TetGeometry {
        volume: g[0],
        grad: [0, 1, 2].map(|k| [g[1 + 3 * k], g[2 + 3 * k], g[3 + 3 * k]]),
    }
}

/// Pack a TET4's geometry as the view holds it.
pub fn pack_tet_geometry(g: &tet4::TetGeometry) -> [f64; 10] {
    let mut p = [0.0; 10];
    p[0] = g.volume;
    for k in 0..3 {
        p[1 + 3 * k..4 + 3 * k].copy_from_slice(&g.grad[k]);
    }
    p
}

impl Element for Tet4 {
    const D: usize = 3;
    const NODES: usize = 4;
    type Vector = [f64; 3];
    type Conn = [u32; 4];
    type Geom = tet4::TetGeometry;
    type Stress = [f64; 6];
    type Forces = [f64; 12];
    type Stiffness = nalgebra::SMatrix<f64, 12, 12>;
    type JointNodes = [u32; 6];
    type Shear = hydrofrac_components::CornerShear;

    #[inline(always)]
    fn measure(g: &tet4::TetGeometry) -> f64 {
        g.volume
    }
    #[inline(always)]
    fn stress(g: &tet4::TetGeometry, c: &[u32; 4], u: &[[f64; 3]], p: &SolidParams) -> [f64; 6] {
        let ue = c.map(|a| u[a as usize]);
        tet4::hooke(tet4::strain(g, ue), p)
    }
    #[inline(always)]
    fn forces(g: &tet4::TetGeometry, s: &[f64; 6]) -> [f64; 12] {
        tet4::forces_flat(g, *s)
    }
    #[inline(always)]
    fn strain_energy(g: &tet4::TetGeometry, c: &[u32; 4], u: &[[f64; 3]], p: &SolidParams) -> f64 {
        let eps = tet4::strain(g, c.map(|a| u[a as usize]));
        let s = tet4::hooke(eps, p);
        // Voigt with engineering shear: sigma:epsilon = sum_k s_k e_k.
        0.5 * g.volume * (0..6).map(|k| s[k] * eps[k]).sum::<f64>()
    }
    fn stiffness(g: &tet4::TetGeometry, p: &SolidParams) -> Self::Stiffness {
        tet4::stiffness(g, p)
    }
}
