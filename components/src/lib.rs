//! Plain-data components of the hydrofrac ECS (hecs).
//!
//! Every kind of entity (node, element, edge) is spawned with one fixed bundle, so it lives in a
//! single archetype for the whole run: state flags are fields, never marker components.
//! Relations between entities are `hecs::Entity` fields. Units are SI; in 2D the model is plane
//! strain per unit thickness (forces in N/m, masses in kg/m, stresses in Pa, tension positive),
//! in 3D forces are in N and masses in kg.
//!
//! Where the dimension enters a component its shape is a type parameter whose default is the 2D
//! one (`NodeRef` is `NodeRef<[f64; 2]>`; a 3D node is a `NodeRef<[f64; 3]>`), so 2D code
//! names the components as it always did ([`Node3Bundle`] and [`Tet4Bundle`] name the 3D
//! bundles). A 3D face (a triangle) is an entity like a 2D edge: [`FaceNodes`] with the same
//! [`EdgeElems`] and [`EdgeState`].

use hecs::Entity;
use serde::{Deserialize, Serialize};

/// Stable identifier of an entity within its kind (nodes, elements and edges count separately).
/// Dense views and every output are ordered by it, so results never depend on hecs' storage
/// order or on the number of threads.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct StableId(pub u64);

/// Which side of the box-shaped domain a boundary node or external edge (face) lies on. The
/// vertical axis is the last one: y in 2D, z in 3D. `Front` and `Back` (y = min and max) exist in
/// 3D only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Side {
    Left,
    Right,
    Bottom,
    Top,
    Front,
    Back,
}

impl Side {
    /// The sides of a 2D domain.
    pub const ALL: [Side; 4] = [Side::Left, Side::Right, Side::Bottom, Side::Top];
    /// The sides of a 3D domain.
    pub const ALL3: [Side; 6] = [
        Side::Left,
        Side::Right,
        Side::Front,
        Side::Back,
        Side::Bottom,
        Side::Top,
    ];

    /// Outward unit normal of the side in 2D (`Front` and `Back` have none: zero).
    pub fn normal(self) -> [f64; 2] {
        match self {
            Side::Left => [-1.0, 0.0],
            Side::Right => [1.0, 0.0],
            Side::Bottom => [0.0, -1.0],
            Side::Top => [0.0, 1.0],
            Side::Front | Side::Back => [0.0, 0.0],
        }
    }

    /// The axis the side is normal to in `dim` dimensions (the vertical one is the last) and
    /// the sign of its outward normal along it.
    pub fn axis(self, dim: usize) -> (usize, f64) {
        match self {
            Side::Left => (0, -1.0),
            Side::Right => (0, 1.0),
            Side::Front => (1, -1.0),
            Side::Back => (1, 1.0),
            Side::Bottom => (dim - 1, -1.0),
            Side::Top => (dim - 1, 1.0),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Side::Left => "left",
            Side::Right => "right",
            Side::Bottom => "bottom",
            Side::Top => "top",
            Side::Front => "front",
            Side::Back => "back",
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Nodes
// ---------------------------------------------------------------------------------------------

/// Reference (undeformed) position of a node, m.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NodeRef<V = [f64; 2]>(pub V);

/// Kinematic state of a node: displacement u (m) and velocity v (m/s, at the last half step).
/// The dense solid view holds the hot copy during stepping; it is written back here at every
/// sync point (output frame, topology change, end of run).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NodeState<V = [f64; 2]> {
    pub u: V,
    pub v: V,
}

/// Lumped nodal mass: per unit thickness in 2D, kg/m (one third of rho*A of each element around
/// it); kg in 3D (a quarter of rho*V of each tetrahedron around it).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NodeMass(pub f64);

/// Boundary condition of a node: a prescribed displacement per direction (m) where `Some`,
/// and a constant external force (N/m in 2D, N in 3D, from tractions and body forces) added
/// every step.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NodeBc<V = [f64; 2], P = [Option<f64>; 2]> {
    pub prescribed: P,
    pub load: V,
}

/// Topological role of a node. `in_solid` is false for a mother node that has left the solid
/// mesh after a split; `mother` links a daughter to the node it was split from.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NodeLink {
    pub in_solid: bool,
    pub mother: Option<Entity>,
}

/// Node bundle: the one archetype of every node entity.
pub type NodeBundle = (StableId, NodeRef, NodeState, NodeMass, NodeBc, NodeLink);

/// A 3D node's bundle.
pub type Node3Bundle = (
    StableId,
    NodeRef<[f64; 3]>,
    NodeState<[f64; 3]>,
    NodeMass,
    NodeBc<[f64; 3], [Option<f64>; 3]>,
    NodeLink,
);

// ---------------------------------------------------------------------------------------------
// Elements
// ---------------------------------------------------------------------------------------------

/// The nodes of an element: a constant-strain triangle's three, counter-clockwise (2D), or a
/// tetrahedron's four, positively oriented (3D).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ElemNodes<C = [Entity; 3]>(pub C);

/// Precomputed geometry of a constant-strain triangle in the reference configuration:
/// area A (m^2) and the constant shape-function gradients dN_a/dx, dN_a/dy (1/m).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ElemGeom {
    pub area: f64,
    pub dndx: [f64; 3],
    pub dndy: [f64; 3],
}

/// Precomputed geometry of a linear tetrahedron in the reference configuration: volume V (m^3)
/// and the constant shape-function gradients of nodes 1 to 3 (1/m; node 0's is minus their
/// sum), packed as `[V, dN1/dx, dN1/dy, dN1/dz, dN2/dx, ..]` (`hydrofrac_core::dim::Tet4`'s
/// view geometry).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TetGeom(pub [f64; 10]);

/// Cauchy stress of the element, Pa, tension positive: [sigma_xx, sigma_yy, sigma_xy] in 2D
/// (sigma_zz = nu (sigma_xx + sigma_yy) in plane strain), [xx, yy, zz, xy, yz, zx] in 3D.
/// Written back from the view at sync points.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ElemStress<S = [f64; 3]>(pub S);

/// Element bundle: the one archetype of every element entity.
pub type ElemBundle = (StableId, ElemNodes, ElemGeom, ElemStress);

/// A tetrahedron's bundle.
pub type Tet4Bundle = (
    StableId,
    ElemNodes<[Entity; 4]>,
    TetGeom,
    ElemStress<[f64; 6]>,
);

// ---------------------------------------------------------------------------------------------
// Edges (faces)
// ---------------------------------------------------------------------------------------------

/// The two end nodes of an edge.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EdgeNodes(pub [Entity; 2]);

/// The elements on either side of an edge: two for an internal edge, one (`[Some, None]`) for
/// an external edge (domain boundary or fracture face).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EdgeElems(pub [Option<Entity>; 2]);

impl EdgeElems {
    pub fn is_external(&self) -> bool {
        self.0[1].is_none()
    }
}

/// Per-edge state: the domain side for external boundary edges, the normal stress across the
/// edge (Pa, tension positive), the fracture-ready mark set by the fracture criterion, and
/// `opened`: the edge has been split into two daughter edges and left the solid (it is then a
/// mother edge, the geometry of a flow cell).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EdgeState {
    pub side: Option<Side>,
    pub sigma_n: f64,
    pub fracture_ready: bool,
    pub opened: bool,
}

/// Edge bundle: the one archetype of every edge entity.
pub type EdgeBundle = (StableId, EdgeNodes, EdgeElems, EdgeState);

/// The three nodes of a 3D face (a triangle between two tetrahedra, or on the boundary).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FaceNodes(pub [Entity; 3]);

/// A 3D face's bundle: the 2D edge's, with three nodes.
pub type FaceBundle = (StableId, FaceNodes, EdgeElems, EdgeState);

// ---------------------------------------------------------------------------------------------
// Flow cells and flow boundaries
// ---------------------------------------------------------------------------------------------

/// The two nodes a flow cell runs between. Cells exchange fluid with every other cell that shares
/// one of these nodes (the seed's pairs), so junction connectivity is held by the nodes: a split
/// that creates cells only has to point them at the right (mother) nodes.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CellNodes(pub [Entity; 2]);

/// Fluid state of a cell (per unit thickness): hydraulic aperture a (m), fluid mass m (kg/m),
/// pressure P (Pa) and the throughput |flow| through the cell (m^2/s) at the last flow step.
/// Volume V = a L (m^2), density rho = m / V.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CellFluid {
    pub aperture: f64,
    pub mass: f64,
    pub pressure: f64,
    pub flow_rate: f64,
}

/// Whether a cell was there at the start or created by fracturing, and when (s).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CellKind {
    Preexisting,
    New,
}

#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CellOrigin {
    pub kind: CellKind,
    pub created_t: f64,
}

/// Flow cell bundle: the one archetype of every cell entity.
pub type CellBundle = (StableId, CellNodes, CellFluid, CellOrigin);

/// Where a flow boundary condition acts: every cell at a node, or one cell.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum FlowBcTarget {
    Node(Entity),
    Cell(Entity),
}

/// A flow boundary condition: `index` into the scenario's `flow_boundaries`, its target, and its
/// state at the last flow step: boundary pressure (Pa), rate into the network (m^2/s) and the
/// cumulative volumes in and out (m^2, at reference density).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FlowBc {
    pub index: usize,
    pub target: FlowBcTarget,
    pub pressure: f64,
    pub rate: f64,
    pub volume_in: f64,
    pub volume_out: f64,
}

/// A joint: the two sister daughter edges of an opened mother edge, the mother edge and the flow
/// cell made from it.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Joint {
    pub edges: [Entity; 2],
    pub mother_edge: Entity,
    pub cell: Entity,
}

/// Contact state of a joint (seed (8)-(11)): normal force F_n (N/m in 2D, N in 3D,
/// compression positive), tangential force F_t (on face q along face p's tangent: a number in
/// 2D, `T = f64`; in 3D its two components along face p's tangents t1, t2 for each of the
/// three sister node pairs, `T = [CornerShear]`), the last tangential offset (m, for the
/// incremental update; the same shape), whether it slid at the last step (in 3D: one of its
/// pairs), and the opening (m).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointState<T = f64> {
    pub normal_force: f64,
    pub shear_force: T,
    pub last_shear_offset: T,
    pub sliding: bool,
    pub opening: f64,
    /// Slid at some step since the last frame (output: "slid during the output interval";
    /// cleared after each frame; the physics never reads it).
    pub slid: bool,
    /// Accumulated frictional (plastic) slip, m: the sum over sliding steps of the return
    /// map's excess |F_t trial| - cap over K_t. Slip-weakening friction reads it.
    pub slip: f64,
}

/// Joint bundle.
pub type JointBundle = (StableId, Joint, JointState);

/// A 3D joint: the two sister faces of a planar fracture opened by node splitting, face p
/// (`faces[0]`) and face q, each listing its nodes in the same order (sister nodes at the same
/// places), ordered so that (x1 - x0) x (x2 - x0) of face p points out of p's tetrahedron
/// towards q.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FaceJoint {
    pub faces: [Entity; 2],
}

/// A 3D joint's tangential state, per sister node pair (face p's node a and face q's node a,
/// a = 0, 1, 2): the components along face p's tangents t1, t2 (N for forces, m for offsets).
/// The 3D joint takes its contact pair by pair (`contact_3d`).
pub type CornerShear = [[f64; 2]; 3];

/// 3D joint bundle.
pub type FaceJointBundle = (StableId, FaceJoint, JointState<CornerShear>);

/// A 3D flow cell: the fracture face pair of its joint (a [`FaceJoint`] entity). The cell is the
/// joint's triangle; it exchanges fluid with every cell whose face p shares an edge with its
/// own (two fractures meeting along a line share that line's edges).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FaceCell(pub Entity);

/// 3D flow cell bundle: a [`CellBundle`] with the joint in place of the two nodes. Its fluid
/// state is per cell, not per metre: mass kg, volume a A m^3, flow rate m^3/s.
pub type FaceCellBundle = (StableId, FaceCell, CellFluid, CellOrigin);

/// Flow boundary bundle.
pub type FlowBcBundle = (StableId, FlowBc);
