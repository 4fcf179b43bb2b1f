//! The 3D rock as entities: nodes, tetrahedra and faces spawned from a [`TetMesh`], its
//! boundary conditions, the in-situ initial state, and the dense TET4 view built from them.
//! The 3D counterparts of [`Model::from_mesh`], [`Model::apply_boundary`] and
//! [`SolidView::build`]; the view's node and element filling is shared with 2D
//! ([`SolidView::push_node_rows`], [`SolidView::push_elem_rows`]).
//!
//! Units: m, Pa, kg, N; tension positive. The vertical axis is z (`Bottom`, `Top`); y is
//! `Front` (min) and `Back` (max).

use crate::dim::{Tet4, pack_tet_geometry, tet_geometry};
use crate::error::SetupError;
use crate::model::Model;
use crate::scenario::{Boundary, Material, SideBc};
use crate::tet4::{self, cross, dot, norm, sub, triangle_area};
use crate::tetmesh::TetMesh;
use crate::view::{ElemRow, NONE, NodeRow, SolidView, fixed_mask};
use hecs::{Entity, World};
use hydrofrac_components::*;

/// 3D node components.
pub type NodeRef3 = NodeRef<[f64; 3]>;
pub type NodeState3 = NodeState<[f64; 3]>;
pub type NodeBc3 = NodeBc<[f64; 3], [Option<f64>; 3]>;
pub type TetNodes = ElemNodes<[Entity; 4]>;
pub type TetStress = ElemStress<[f64; 6]>;

impl Material {
    /// Strains (exx, eyy, ezz) that give the principal stresses (sxx, syy, szz) along the axes,
    /// Pa, by 3D Hooke's law: exx = (sxx - nu (syy + szz)) / E, and cyclically.
    pub fn strain_3d(&self, s: [f64; 3]) -> [f64; 3] {
        let (e, nu) = (self.young, self.poisson);
        [
            (s[0] - nu * (s[1] + s[2])) / e,
            (s[1] - nu * (s[2] + s[0])) / e,
            (s[2] - nu * (s[0] + s[1])) / e,
        ]
    }
}

impl Model {
    /// Spawn nodes (lumped mass rho V / 4 from every tetrahedron around them), tetrahedra and
    /// faces (each triangle once, with the one or two tetrahedra on its sides and, on the
    /// boundary, the side of the box it lies on). Stable ids follow the mesh's numbering; faces
    /// are numbered by sorted node triples. Errors name a degenerate or inverted tetrahedron.
    pub fn from_tet_mesh(mesh: &TetMesh, material: Material) -> Result<Self, SetupError> {
        let mut world = World::new();
        let mut geoms = Vec::with_capacity(mesh.tets.len());
        let mut min_edge = f64::INFINITY;
        for t in 0..mesh.tets.len() {
            let x = mesh.corners(t);
            let g = tet4::geometry(x).ok_or_else(|| {
                SetupError::invalid(
                    "mesh",
                    format!(
                        "tetrahedron {t} is degenerate or inverted (nodes {:?})",
                        mesh.tets[t]
                    ),
                )
            })?;
            for a in 0..4 {
                for b in a + 1..4 {
                    let d = (0..3).map(|k| (x[b][k] - x[a][k]).powi(2)).sum::<f64>();
                    min_edge = min_edge.min(d.sqrt());
                }
            }
            geoms.push(g);
        }
        let mut mass = vec![0.0; mesh.nodes.len()];
        for (t, g) in mesh.tets.iter().zip(&geoms) {
            for &n in t {
                mass[n as usize] += tet4::lumped_mass(g, material.density);
            }
        }
        let nodes: Vec<Entity> = mesh
            .nodes
            .iter()
            .zip(&mass)
            .enumerate()
            .map(|(i, (&x, &m))| {
                let bundle: Node3Bundle = (
                    StableId(i as u64),
                    NodeRef(x),
                    NodeState::default(),
                    NodeMass(m),
                    NodeBc::default(),
                    NodeLink {
                        in_solid: true,
                        mother: None,
                    },
                );
                world.spawn(bundle)
            })
            .collect();
        let elems: Vec<Entity> = mesh
            .tets
            .iter()
            .zip(&geoms)
            .enumerate()
            .map(|(i, (t, g))| {
                let bundle: Tet4Bundle = (
                    StableId(i as u64),
                    ElemNodes(t.map(|n| nodes[n as usize])),
                    TetGeom(pack_tet_geometry(g)),
                    ElemStress::default(),
                );
                world.spawn(bundle)
            })
            .collect();
        // Faces: sorted node triples with their tetrahedra, in triple order.
        let mut faces: Vec<([u32; 3], Vec<u32>)> = mesh.faces().into_iter().collect();
        faces.sort_unstable_by_key(|f| f.0);
        let [x0, y0, z0, x1, y1, z1] = mesh.bbox;
        let tol = 1e-9 * min_edge;
        let side_of = |f: [u32; 3]| -> Option<Side> {
            let p = f.map(|n| mesh.grid_coords(mesh.nodes[n as usize]));
            let on = |d: usize, c: f64| p.iter().all(|q| (q[d] - c).abs() < tol);
            [
                (0, x0, Side::Left),
                (0, x1, Side::Right),
                (1, y0, Side::Front),
                (1, y1, Side::Back),
                (2, z0, Side::Bottom),
                (2, z1, Side::Top),
            ]
            .into_iter()
            .find(|&(d, c, _)| on(d, c))
            .map(|s| s.2)
        };
        for (id, (f, ts)) in faces.iter().enumerate() {
            if ts.len() > 2 {
                return Err(SetupError::invalid(
                    "mesh",
                    format!("face {f:?} is shared by more than two tetrahedra"),
                ));
            }
            let second = ts.get(1).map(|&t| elems[t as usize]);
            let side = if second.is_none() { side_of(*f) } else { None };
            let bundle: FaceBundle = (
                StableId(id as u64),
                FaceNodes(f.map(|n| nodes[n as usize])),
                EdgeElems([Some(elems[ts[0] as usize]), second]),
                EdgeState {
                    side,
                    ..Default::default()
                },
            );
            world.spawn(bundle);
        }
        Ok(Model {
            world,
            material,
            bbox: [x0, y0, x1, y1],
            bbox3: Some(mesh.bbox),
            frame3: mesh.frame,
            h: min_edge,
            min_altitude: f64::INFINITY,
            topology_generation: 0,
            next_node_id: mesh.nodes.len() as u64,
            next_elem_id: mesh.tets.len() as u64,
            next_edge_id: faces.len() as u64,
            next_cell_id: 0,
            next_joint_id: 0,
        })
    }

    /// Whether this is a 3D model ([`Model::from_tet_mesh`]).
    pub fn is_3d(&self) -> bool {
        self.bbox3.is_some()
    }

    /// The 3D box, `[xmin, ymin, zmin, xmax, ymax, zmax]`, m.
    fn box3(&self) -> [f64; 6] {
        self.bbox3.expect("a 3D model")
    }

    /// Store a 3D scenario's boundary conditions on the nodes: prescribed normal displacements
    /// (`Normal`, and `InSitu3`'s Hooke displacements about the box's centre), `Fixed` sides
    /// and normal tractions (t A / 3 to each node of a boundary face of area A). Previous
    /// conditions are replaced. A 2D boundary, and a 3D side's shear traction, are refused by
    /// the scenario's checks (`Scenario::validate`): the sides are then free, the shear unused.
    ///
    /// On a turned grid (`frame3`) the sides are oblique: a traction acts along the side's
    /// normal in the scene, and `InSitu3` holds every boundary node at the homogeneous
    /// displacement of the in-situ stress about the box's centre, all three components
    /// ([`Model::set_insitu_displacement3`]'s). `Normal` (an oblique roller) is refused by the
    /// scenario's checks and left free here.
    pub fn apply_boundary3(&mut self, boundary: &Boundary) {
        let b = self.box3();
        let frame = self.frame3;
        let mut held: Option<[f64; 3]> = None;
        let bc_of: [SideBc; 6] = match *boundary {
            Boundary::InSitu3 { sxx, syy, szz } if frame.is_some() => {
                held = Some(self.material.strain_3d([sxx, syy, szz]));
                [SideBc::Free; 6]
            }
            Boundary::InSitu3 { sxx, syy, szz } => {
                let e = self.material.strain_3d([sxx, syy, szz]);
                let half = [0, 1, 2].map(|d| 0.5 * (b[d + 3] - b[d]));
                [0, 0, 1, 1, 2, 2].map(|d| SideBc::Normal(e[d] * half[d]))
            }
            Boundary::Sides3 { .. } => boundary.sides3().expect("3D sides").map(|s| s.1),
            Boundary::InSitu { .. } | Boundary::Sides { .. } => [SideBc::Free; 6],
        };
        let index = |s: Side| Side::ALL3.iter().position(|&t| t == s).expect("side");
        let mut node_sides: std::collections::HashMap<Entity, Vec<Side>> = Default::default();
        for (fnodes, st) in self.world.query::<(&FaceNodes, &EdgeState)>().iter() {
            if let (Some(side), false) = (st.side, st.opened) {
                for n in fnodes.0 {
                    let v = node_sides.entry(n).or_default();
                    if !v.contains(&side) {
                        v.push(side);
                    }
                }
            }
        }
        let c = self.centre3();
        let mut updates: Vec<(Entity, NodeBc3)> = Vec::new();
        for (e, link, x) in self.world.query::<(Entity, &NodeLink, &NodeRef3)>().iter() {
            if !link.in_solid {
                continue;
            }
            let mut bc = NodeBc3::default();
            let sides = node_sides.get(&e).map_or(&[][..], |v| &v[..]);
            if let (Some(strain), false) = (held, sides.is_empty()) {
                bc.prescribed = [0, 1, 2].map(|d| Some(strain[d] * (x.0[d] - c[d])));
            }
            for &s in sides {
                let (axis, sign) = s.axis(3);
                match bc_of[index(s)] {
                    SideBc::Normal(_) if frame.is_some() => {}
                    SideBc::Normal(d) => bc.prescribed[axis] = Some(d * sign),
                    SideBc::Fixed => bc.prescribed = [Some(0.0); 3],
                    SideBc::Free | SideBc::Traction { .. } => {}
                }
            }
            updates.push((e, bc));
        }
        for (e, bc) in updates {
            *self.world.get::<&mut NodeBc3>(e).expect("node") = bc;
        }
        let mut loads: Vec<(Entity, [f64; 3])> = Vec::new();
        for (fnodes, st) in self.world.query::<(&FaceNodes, &EdgeState)>().iter() {
            let Some(side) = st.side else { continue };
            if let SideBc::Traction { normal, .. } = bc_of[index(side)] {
                let p = fnodes
                    .0
                    .map(|e| self.world.get::<&NodeRef3>(e).expect("node").0);
                let area = triangle_area(p);
                let (axis, sign) = side.axis(3);
                let mut out = [0.0; 3];
                out[axis] = sign;
                let out = crate::tetmesh::scene_coords(frame.as_ref(), out);
                let f = out.map(|o| normal * o * area / 3.0);
                for &e in &fnodes.0 {
                    loads.push((e, f));
                }
            }
        }
        for (e, f) in loads {
            let mut bc = self.world.get::<&mut NodeBc3>(e).expect("node");
            for d in 0..3 {
                bc.load[d] += f[d];
            }
        }
        self.topology_generation += 1;
    }

    /// The box's centre in the scene, m (turned with the grid).
    fn centre3(&self) -> [f64; 3] {
        let b = self.box3();
        let c = [0, 1, 2].map(|d| 0.5 * (b[d] + b[d + 3]));
        crate::tetmesh::scene_coords(self.frame3.as_ref(), c)
    }

    /// Put every solid node at the homogeneous displacement of the principal in-situ stress
    /// (sxx, syy, szz), Pa, about the box's centre, at rest: with `Boundary::InSitu3` the
    /// unfractured body starts in equilibrium.
    pub fn set_insitu_displacement3(&mut self, s: [f64; 3]) {
        let e = self.material.strain_3d(s);
        let c = self.centre3();
        for (x, st) in self.world.query_mut::<(&NodeRef3, &mut NodeState3)>() {
            st.u = [0, 1, 2].map(|d| e[d] * (x.0[d] - c[d]));
            st.v = [0.0; 3];
        }
    }
}

impl Model {
    /// Record a split made on the mesh before it became entities ([`TetMesh::split_along`],
    /// oriented by [`TetMesh::orient_sisters`]): each daughter node's mother link, and one
    /// joint ([`FaceJoint`]) per sister face pair, numbered in the split's order.
    pub fn add_face_joints(&mut self, split: &crate::tetmesh::TetSplit) {
        let by_id: std::collections::HashMap<u64, Entity> = self
            .world
            .query::<(Entity, &StableId, &NodeRef3)>()
            .iter()
            .map(|(e, id, _)| (id.0, e))
            .collect();
        for &(m, d) in &split.daughters {
            let (me, de) = (by_id[&(m as u64)], by_id[&(d as u64)]);
            self.world.get::<&mut NodeLink>(de).expect("node").mother = Some(me);
        }
        let mut face_of: std::collections::HashMap<[Entity; 3], Entity> = Default::default();
        for (e, f) in self.world.query::<(Entity, &FaceNodes)>().iter() {
            let mut k = f.0;
            k.sort_unstable();
            face_of.insert(k, e);
        }
        for s in &split.sisters {
            let faces = s.map(|tri| {
                let mut k = tri.map(|n| by_id[&(n as u64)]);
                k.sort_unstable();
                face_of[&k]
            });
            // The face entities list their nodes sorted; the joint's order is the split's.
            for (side, &fe) in s.iter().zip(&faces) {
                self.world.get::<&mut FaceNodes>(fe).expect("face").0 =
                    side.map(|n| by_id[&(n as u64)]);
            }
            let bundle: FaceJointBundle = (
                StableId(self.next_joint_id),
                FaceJoint { faces },
                JointState::default(),
            );
            self.world.spawn(bundle);
            self.next_joint_id += 1;
        }
        self.topology_generation += 1;
    }

    /// One flow cell ([`FaceCell`]) per 3D joint, in the joints' stable-id order, pre-existing,
    /// of hydraulic aperture `aperture` (m) and fluid density `fill` (kg/m^3: full at that
    /// density) or empty (`None`: the cells fill first, seed (4)).
    pub fn add_face_cells(&mut self, aperture: f64, fill: Option<f64>) {
        let mut joints: Vec<(u64, Entity, FaceJoint)> = self
            .world
            .query::<(Entity, &StableId, &FaceJoint)>()
            .iter()
            .map(|(e, id, j)| (id.0, e, *j))
            .collect();
        joints.sort_unstable_by_key(|j| j.0);
        for (_, je, j) in joints {
            let nodes = self.world.get::<&FaceNodes>(j.faces[0]).expect("face").0;
            let x = nodes.map(|e| self.world.get::<&NodeRef3>(e).expect("node").0);
            let area = crate::tet4::triangle_area(x);
            let bundle: FaceCellBundle = (
                StableId(self.next_cell_id),
                FaceCell(je),
                CellFluid {
                    aperture,
                    mass: fill.map_or(0.0, |rho| rho * aperture * area),
                    ..Default::default()
                },
                CellOrigin {
                    kind: CellKind::Preexisting,
                    created_t: 0.0,
                },
            );
            self.world.spawn(bundle);
            self.next_cell_id += 1;
        }
        self.topology_generation += 1;
    }

    /// Attach the scenario's flow boundaries (`Node`, `Cell` at 3D points) to the nearest fracture node
    /// (a root of the cells' triangles) or triangle centroid. The point must lie within half
    /// the largest edge of the triangles there; two boundaries on one node or cell are refused.
    pub fn add_flow_boundaries3(
        &mut self,
        bcs: &[crate::scenario::FlowBoundary],
    ) -> Result<(), SetupError> {
        use crate::scenario::FlowTarget;
        let tc = crate::flow::faces::cell_triangles(self);
        let geo = crate::flow::faces::triangle_cells(&tc.nodes, &tc.tris);
        if tc.tris.is_empty() {
            return Err(SetupError::invalid(
                "flow_boundaries",
                "the fractures have no cells",
            ));
        }
        let dist = |a: [f64; 3], b: &[f64]| norm(sub(a, [b[0], b[1], b[2]]));
        let longest = |t: &[u32; 3]| {
            (0..3)
                .map(|k| {
                    norm(sub(
                        tc.nodes[t[k] as usize],
                        tc.nodes[t[(k + 1) % 3] as usize],
                    ))
                })
                .fold(0.0, f64::max)
        };
        let mut spawned: Vec<FlowBcTarget> = Vec::new();
        for (i, bc) in bcs.iter().enumerate() {
            let field = format!("flow_boundaries[{i}].at");
            let at = bc.at.point();
            let (target, d, size, what) = match bc.at {
                _ if !bc.at.is_3d() => {
                    return Err(SetupError::invalid(
                        &field,
                        "this mesh is 3D: give the point as (x, y, z), m",
                    ));
                }
                FlowTarget::Node(_) => {
                    let (k, d) = (0..tc.nodes.len())
                        .map(|k| (k, dist(tc.nodes[k], at)))
                        .min_by(|a, b| a.1.total_cmp(&b.1))
                        .expect("cells have nodes");
                    let size = tc
                        .tris
                        .iter()
                        .filter(|t| t.contains(&(k as u32)))
                        .map(longest)
                        .fold(0.0, f64::max);
                    (FlowBcTarget::Node(tc.node_entity[k]), d, size, "node")
                }
                FlowTarget::Cell(_) => {
                    let (c, d) = (0..tc.tris.len())
                        .map(|c| (c, dist(geo.centroid[c], at)))
                        .min_by(|a, b| a.1.total_cmp(&b.1))
                        .expect("cells");
                    let size = longest(&tc.tris[c]);
                    (
                        FlowBcTarget::Cell(tc.cell_entity[c]),
                        d,
                        size,
                        "cell centroid",
                    )
                }
            };
            if d > 0.5 * size + 1e-9 {
                return Err(SetupError::invalid(
                    &field,
                    format!(
                        "({}, {}, {}) is {d:.3} m from the nearest fracture {what}; put it on a \
                         fracture",
                        at[0], at[1], at[2]
                    ),
                ));
            }
            if let Some(k) = spawned.iter().position(|t| *t == target) {
                return Err(SetupError::invalid(
                    &field,
                    format!(
                        "it is at the fracture {what} of flow_boundaries[{k}] too: two \
                         boundaries on one {what} contradict each other"
                    ),
                ));
            }
            spawned.push(target);
        }
        self.spawn_flow_boundaries(spawned.into_iter());
        Ok(())
    }

    /// Prescribe the pins' displacements on the solid's nodes nearest their points, which must
    /// lie within half the longest edge at that node (`size`, by node stable id:
    /// [`crate::tetmesh::TetMesh::local_size`]); errors name `pins[i].at`.
    pub fn apply_pins3(
        &mut self,
        pins: &[crate::scenario::Pin],
        size: &[f64],
    ) -> Result<(), SetupError> {
        for (i, pin) in pins.iter().enumerate() {
            let nearest = self
                .world
                .query::<(Entity, &StableId, &NodeRef3, &NodeLink)>()
                .iter()
                .filter(|(_, _, _, l)| l.in_solid)
                .map(|(e, id, x, _)| (e, id.0, norm(sub(x.0, pin.at.v))))
                .min_by(|a, b| a.2.total_cmp(&b.2).then(a.1.cmp(&b.1)));
            let Some((e, id, dist)) = nearest else {
                return Err(SetupError::invalid("pins", "the mesh has no nodes"));
            };
            if dist > 0.5 * size.get(id as usize).copied().unwrap_or(0.0) + 1e-12 {
                let [x, y, z] = pin.at.v;
                return Err(SetupError::invalid(
                    &format!("pins[{i}].at"),
                    format!(
                        "({x}, {y}, {z}) is {dist:.3} m from the nearest node (more than half \
                         the longest edge there)"
                    ),
                ));
            }
            let mut bc = self.world.get::<&mut NodeBc3>(e).expect("node");
            for (d, u) in [pin.ux, pin.uy, pin.uz].into_iter().enumerate() {
                if let Some(u) = u {
                    bc.prescribed[d] = Some(u);
                }
            }
        }
        self.topology_generation += 1;
        Ok(())
    }

    /// The consistent nodal loads of a uniform body force `b` (N/m^3, e.g. rho g): a quarter
    /// of each tetrahedron's b V at each of its nodes (exact for a constant force).
    pub fn add_body_force3(&mut self, b: [f64; 3]) {
        let mut loads: Vec<(Entity, f64)> = Vec::new();
        for en in self.world.query::<&TetNodes>().iter() {
            let x =
                en.0.map(|e| self.world.get::<&NodeRef3>(e).expect("node").0);
            let v = crate::tet4::signed_volume(x[0], x[1], x[2], x[3]).abs();
            for &e in &en.0 {
                loads.push((e, 0.25 * v));
            }
        }
        for (e, w) in loads {
            let mut bc = self.world.get::<&mut NodeBc3>(e).expect("node");
            for d in 0..3 {
                bc.load[d] += w * b[d];
            }
        }
        self.topology_generation += 1;
    }

    /// A uniform pressure p (Pa) on both faces of every 3D joint, as constant nodal loads in
    /// the reference geometry: face p's nodes get -p A n / 3 each, face q's +p A n / 3 (n face
    /// p's unit normal towards q, A its area), N.
    pub fn apply_face_pressure3(&mut self, p: f64) {
        let loads = self.face_pressure_loads3(p);
        self.add_loads3(&loads, 1.0);
        self.topology_generation += 1;
    }

    /// The nodal forces of a uniform pressure `p` (Pa) on both faces of every 3D joint, N: on
    /// each face, p times its area along its outward normal, a third to each node (face p
    /// pushed against its normal, face q along it), joint by joint in stable-id order.
    pub fn face_pressure_loads3(&self, p: f64) -> Vec<(Entity, [f64; 3])> {
        let mut joints: Vec<(u64, FaceJoint)> = self
            .world
            .query::<(&StableId, &FaceJoint)>()
            .iter()
            .map(|(id, j)| (id.0, *j))
            .collect();
        joints.sort_unstable_by_key(|j| j.0);
        let mut loads: Vec<(Entity, [f64; 3])> = Vec::new();
        for (_, j) in joints {
            let nodes = j
                .faces
                .map(|f| self.world.get::<&FaceNodes>(f).expect("face").0);
            let x = nodes[0].map(|e| self.world.get::<&NodeRef3>(e).expect("node").0);
            let an = cross(sub(x[1], x[0]), sub(x[2], x[0])).map(|c| 0.5 * c);
            for (side, sign) in [(0, -1.0), (1, 1.0)] {
                for &e in &nodes[side] {
                    loads.push((e, an.map(|c| sign * p * c / 3.0)));
                }
            }
        }
        loads
    }

    /// Add `scale` times the given nodal forces (N) to the nodes' loads, in the list's order.
    pub fn add_loads3(&mut self, loads: &[(Entity, [f64; 3])], scale: f64) {
        for (e, f) in loads {
            let mut bc = self.world.get::<&mut NodeBc3>(*e).expect("node");
            for d in 0..3 {
                bc.load[d] += scale * f[d];
            }
        }
    }
}

impl SolidView<Tet4> {
    /// Build the TET4 view from a 3D model (nodes in the solid only), ordered by stable id.
    pub fn build_3d(model: &Model) -> Self {
        let world = &model.world;
        let max_index = world
            .iter()
            .map(|e| e.entity().id())
            .max()
            .map_or(0, |m| m as usize + 1);
        let mut dense = vec![NONE; max_index];
        let mut v = SolidView::<Tet4> {
            generation: model.topology_generation,
            ..Default::default()
        };
        let nodes: Vec<NodeRow<Tet4>> = world
            .query::<(
                Entity,
                &StableId,
                &NodeRef3,
                &NodeState3,
                &NodeMass,
                &NodeBc3,
                &NodeLink,
            )>()
            .iter()
            .filter(|r| r.6.in_solid)
            .map(|(e, id, x, s, m, bc, _)| NodeRow {
                id: id.0,
                entity: e,
                x: x.0,
                u: s.u,
                v: s.v,
                mass: m.0,
                load: bc.load,
                fixed: fixed_mask(&bc.prescribed),
                presc: bc.prescribed.map(|p| p.unwrap_or(0.0)),
            })
            .collect();
        v.push_node_rows(nodes, &mut dense);
        let elems: Vec<ElemRow<Tet4>> = world
            .query::<(Entity, &StableId, &TetNodes, &TetGeom, &TetStress)>()
            .iter()
            .map(|(e, id, en, g, s)| {
                let c = en.0.map(|n| dense[n.id() as usize]);
                (id.0, e, c, tet_geometry(&g.0), s.0)
            })
            .collect();
        v.push_elem_rows(elems);
        v.set_incidence();
        let mut joints: Vec<(u64, Entity, FaceJoint, JointState<CornerShear>)> = world
            .query::<(Entity, &StableId, &FaceJoint, &JointState<CornerShear>)>()
            .iter()
            .map(|(e, id, j, st)| (id.0, e, *j, *st))
            .collect();
        joints.sort_unstable_by_key(|j| j.0);
        for (_, e, j, st) in joints {
            let f = j.faces.map(|f| world.get::<&FaceNodes>(f).expect("face").0);
            let d = |e: Entity| dense[e.id() as usize];
            v.joint_entity.push(e);
            v.joint_nodes.push([
                d(f[0][0]),
                d(f[0][1]),
                d(f[0][2]),
                d(f[1][0]),
                d(f[1][1]),
                d(f[1][2]),
            ]);
            v.joint_state.push(st);
        }
        v
    }

    /// The internal faces that are still rock (two tetrahedra, not a fracture's), in stable-id
    /// order: the strength criterion's candidates ([`SolidView::face_normal`] and the `edge_*`
    /// rows). A run with a criterion adds them to the view it builds; without one the view
    /// has none (about 100 bytes per tetrahedron saved). `planes` (a point and a unit normal
    /// each, m; `fracture.grow_in: DiscPlanes`): when not empty, only the faces whose three
    /// nodes lie on one of them (within 1e-6 of the face's longest edge) are candidates.
    pub fn push_internal_faces(&mut self, world: &hecs::World, planes: &[([f64; 3], [f64; 3])]) {
        let dense: std::collections::HashMap<Entity, u32> = self
            .elem_entity
            .iter()
            .enumerate()
            .map(|(i, &e)| (e, i as u32))
            .collect();
        // (stable id, entity, nodes, tetrahedra, criterion state)
        type Row = (u64, Entity, [Entity; 3], [Entity; 2], EdgeState);
        let mut faces: Vec<Row> = world
            .query::<(Entity, &StableId, &FaceNodes, &EdgeElems, &EdgeState)>()
            .iter()
            .filter_map(|(e, id, f, el, st)| match el.0 {
                [Some(a), Some(b)] => Some((id.0, e, f.0, [a, b], *st)),
                _ => None,
            })
            .collect();
        faces.sort_unstable_by_key(|f| f.0);
        for (_, e, nodes, [a, b], st) in faces {
            let x = nodes.map(|n| world.get::<&NodeRef3>(n).expect("node").0);
            if !planes.is_empty() && !planes.iter().any(|pl| on_plane(&x, pl)) {
                continue;
            }
            let nn = cross(sub(x[1], x[0]), sub(x[2], x[0]));
            let mut n = nn.map(|c| c / norm(nn));
            // From a to b: away from a's fourth node.
            let ta = world.get::<&TetNodes>(a).expect("tetrahedron").0;
            if let Some(&o) = ta.iter().find(|m| !nodes.contains(m)) {
                let xo = world.get::<&NodeRef3>(o).expect("node").0;
                if dot(n, sub(xo, x[0])) > 0.0 {
                    n = n.map(|c| -c);
                }
            }
            self.edge_entity.push(e);
            self.edge_elems.push([dense[&a], dense[&b]]);
            self.face_normal.push(n);
            self.edge_sigma_n.push(st.sigma_n);
            self.edge_ready.push(st.fracture_ready);
        }
    }

    /// Copy the hot state back into the components: displacement, velocity and the element
    /// stresses at the current displacements.
    pub fn write_back_3d(&self, model: &mut Model, p: &crate::element::SolidParams) {
        use crate::dim::Element;
        let mut view = model.world.view_mut::<&mut NodeState3>();
        for (i, &e) in self.node_entity.iter().enumerate() {
            if let Some(s) = view.get_mut(e) {
                s.u = self.u[i];
                s.v = self.v[i];
            }
        }
        let mut view = model.world.view_mut::<&mut TetStress>();
        for (k, &e) in self.elem_entity.iter().enumerate() {
            if let Some(s) = view.get_mut(e) {
                s.0 = Tet4::stress(&self.geom[k], &self.conn[k], &self.u, p);
            }
        }
        let mut view = model.world.view_mut::<&mut JointState<CornerShear>>();
        for (k, &e) in self.joint_entity.iter().enumerate() {
            if let Some(s) = view.get_mut(e) {
                *s = self.joint_state[k];
            }
        }
    }
}

/// A 3D joint's frame in the current geometry: face p's unit normal n (towards face q) and
/// tangents t1 (along its first edge), t2 = n x t1; the offsets of face q's centroid from face
/// p's along n (opening delta_n, m, positive when the faces separate) and along t1, t2 (m).
#[derive(Clone, Copy, Debug)]
pub struct JointFrame3 {
    pub n: [f64; 3],
    pub t: [[f64; 3]; 2],
    pub dn: f64,
    pub dt: [f64; 2],
}

/// The frame of joint `k` ([`JointFrame3`]).
#[inline]
pub fn joint_frame_3d(v: &SolidView<Tet4>, k: usize) -> JointFrame3 {
    let nodes = v.joint_nodes[k];
    let x = nodes.map(|i| {
        let (a, b) = (v.x0[i as usize], v.u[i as usize]);
        [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
    });
    let e1 = sub(x[1], x[0]);
    let nn = cross(e1, sub(x[2], x[0]));
    let n = nn.map(|c| c / norm(nn));
    let t1 = e1.map(|c| c / norm(e1));
    let t2 = cross(n, t1);
    let c = |o: usize| [0, 1, 2].map(|d| (x[o][d] + x[o + 1][d] + x[o + 2][d]) / 3.0);
    let d = sub(c(3), c(0));
    JointFrame3 {
        n,
        t: [t1, t2],
        dn: dot(d, n),
        dt: [dot(d, t1), dot(d, t2)],
    }
}

/// The offsets of joint `k`'s sister node pairs, x_q,a - x_p,a for a = 0, 1, 2 (m, current
/// positions): their mean is the centroids' offset, whose components along the joint's frame
/// are [`JointFrame3::dn`] and `dt`. Taken as (x0_q - x0_p) + (u_q - u_p), so that a node the
/// two faces share (on the fracture's front) has exactly none.
#[inline]
pub fn corner_offsets_3d(v: &SolidView<Tet4>, k: usize) -> [[f64; 3]; 3] {
    let nodes = v.joint_nodes[k];
    [0, 1, 2].map(|a| {
        let (p, q) = (nodes[a] as usize, nodes[a + 3] as usize);
        [0, 1, 2].map(|d| (v.x0[q][d] - v.x0[p][d]) + (v.u[q][d] - v.u[p][d]))
    })
}

/// A 3D joint's tangential force, its pairs' summed (components along t1, t2, N).
pub fn face_shear(st: &JointState<CornerShear>) -> [f64; 2] {
    let f = &st.shear_force;
    [0, 1].map(|i| f[0][i] + f[1][i] + f[2][i])
}

/// Face p's area of joint `k` in the reference positions, m^2.
pub fn joint_area0_3d(v: &SolidView<Tet4>, k: usize) -> f64 {
    triangle_area([0, 1, 2].map(|a| v.x0[v.joint_nodes[k][a] as usize]))
}

/// The length a 3D joint's penalty force is taken over, m: l = A0 / h = sqrt(A0 / 2), with A0
/// face p's reference area and h = sqrt(2 A0) the leg of a right isosceles triangle of that
/// area (the cell size on a box's grid). The 2D joint carries K delta per unit thickness over
/// an edge of length L, an interface stiffness K / L (Pa/m); the 3D joint carries
/// F = K l delta (N), the interface stiffness K / h over the area A0.
pub fn joint_len0_3d(v: &SolidView<Tet4>, k: usize) -> f64 {
    (0.5 * joint_area0_3d(v, k)).sqrt()
}

/// What a 3D fracture's joints open, in the current geometry: face p's total reference area
/// (m^2), the opened volume sum A0 max(delta_n, 0) (m^3), and the largest and smallest opening
/// delta_n (m; negative where a closed joint's faces interpenetrate, the penalty's); and what
/// they slip: the potency sum A0 |delta_t| (m^3; times the shear modulus, the seismic
/// moment), the area-weighted slip vector sum A0 delta_t in the scene's axes (m^3), and the
/// largest slip |delta_t| (m).
#[derive(Clone, Copy, Debug, Default)]
pub struct Opening3 {
    pub area: f64,
    pub volume: f64,
    pub max: f64,
    pub min: f64,
    pub potency: f64,
    pub slip_vector: [f64; 3],
    pub max_slip: f64,
}

/// Mode I stress intensity along a stretch of a disc fracture's front ([`front_sif_3d`]): the
/// angles (degrees, in the disc's plane from its first in-plane axis) the stretch spans, its
/// K_I (Pa m^1/2), and the node pairs it was fitted on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontSif {
    pub from_deg: f64,
    pub to_deg: f64,
    pub k: f64,
    pub nodes: usize,
}

/// K_I along the front of `disc` by displacement correlation: near a crack's front the
/// opening is w = (8 / E') K_I sqrt(s / (2 pi)) at a distance s behind it (E' = E / (1 - nu^2),
/// Pa), so each sister node pair of the disc's joints at s gives K(s) = (E' / 8) sqrt(2 pi / s)
/// w. The linear elements hold the square root only some cells away from the front, so K(s)
/// is fitted by a straight line over the pairs with s in `window` (m) and taken at s = 0 (the
/// extrapolation of the displacement correlation method). The front is cut into equal
/// stretches of about `stretch_deg` degrees over the angles where the disc has pairs (at least
/// one); a stretch with fewer than two distances gives none. w is the pair's offset along the
/// disc's normal, s = R minus its distance from the centre in the disc's plane (reference
/// positions). The in-plane axes: e1 = the normal x z (x where the normal is along z),
/// e2 = n x e1.
pub fn front_sif_3d(
    v: &SolidView<Tet4>,
    disc: &crate::scenario::Disc,
    e_prime: f64,
    window: [f64; 2],
    stretch_deg: f64,
) -> Vec<FrontSif> {
    let n = disc.unit_normal();
    let e1 = {
        let c = cross(n, [0.0, 0.0, 1.0]);
        let l = norm(c);
        if l < 1e-9 {
            [1.0, 0.0, 0.0]
        } else {
            c.map(|x| x / l)
        }
    };
    let e2 = cross(n, e1);
    // (angle, s, w) of each pair on the disc, once per node of face p.
    let mut seen = std::collections::BTreeMap::new();
    for k in 0..v.joint_nodes.len() {
        let off = corner_offsets_3d(v, k);
        let f = joint_frame_3d(v, k);
        let sign = dot(f.n, n).signum();
        for (a, o) in off.iter().enumerate() {
            let p = v.joint_nodes[k][a];
            let d = sub(v.x0[p as usize], disc.center);
            if dot(d, n).abs() > 1e-6 * disc.radius {
                continue;
            }
            let (x, y) = (dot(d, e1), dot(d, e2));
            let s = disc.radius - x.hypot(y);
            seen.entry(p)
                .or_insert((y.atan2(x).to_degrees(), s, sign * dot(*o, n)));
        }
    }
    let pts: Vec<(f64, f64, f64)> = seen.into_values().collect();
    if pts.is_empty() {
        return Vec::new();
    }
    let lo = pts.iter().fold(f64::INFINITY, |m, p| m.min(p.0));
    let hi = pts.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.0));
    let bins = ((hi - lo) / stretch_deg).round().max(1.0) as usize;
    let width = (hi - lo) / bins as f64;
    (0..bins)
        .filter_map(|b| {
            let (a0, a1) = (lo + b as f64 * width, lo + (b + 1) as f64 * width);
            let q: Vec<(f64, f64)> = pts
                .iter()
                .filter(|p| {
                    p.0 >= a0 - 1e-9
                        && (p.0 < a1 || b + 1 == bins)
                        && p.1 >= window[0]
                        && p.1 <= window[1]
                })
                .map(|&(_, s, w)| {
                    (
                        s,
                        0.125 * e_prime * (2.0 * std::f64::consts::PI / s).sqrt() * w,
                    )
                })
                .collect();
            let m = q.len() as f64;
            let ms = q.iter().map(|p| p.0).sum::<f64>() / m;
            let mk = q.iter().map(|p| p.1).sum::<f64>() / m;
            let sxx: f64 = q.iter().map(|p| (p.0 - ms).powi(2)).sum();
            let sxy: f64 = q.iter().map(|p| (p.0 - ms) * (p.1 - mk)).sum();
            (q.len() >= 2 && sxx > 1e-18 * window[1] * window[1]).then(|| FrontSif {
                from_deg: a0,
                to_deg: a1,
                k: mk - sxy / sxx * ms,
                nodes: q.len(),
            })
        })
        .collect()
}

/// [`Opening3`] of the view's joints (zeros without joints).
pub fn opening_3d(v: &SolidView<Tet4>) -> Opening3 {
    let mut o = Opening3::default();
    for k in 0..v.joint_nodes.len() {
        let a = joint_area0_3d(v, k);
        let f = joint_frame_3d(v, k);
        let dn = f.dn;
        o.area += a;
        o.volume += a * dn.max(0.0);
        o.max = o.max.max(dn);
        o.min = o.min.min(dn);
        let slip = f.dt[0].hypot(f.dt[1]);
        o.potency += a * slip;
        o.max_slip = o.max_slip.max(slip);
        for d in 0..3 {
            o.slip_vector[d] += a * (f.dt[0] * f.t[0][d] + f.dt[1] * f.t[1][d]);
        }
    }
    o
}

/// Whether the triangle `x` lies on the plane `(point, unit normal)`: each corner within 1e-6 of
/// the triangle's longest edge of it (m).
fn on_plane(x: &[[f64; 3]; 3], plane: &([f64; 3], [f64; 3])) -> bool {
    let edge = (0..3)
        .map(|i| norm(sub(x[(i + 1) % 3], x[i])))
        .fold(0.0, f64::max);
    x.iter()
        .all(|&c| dot(plane.1, sub(c, plane.0)).abs() <= 1e-6 * edge)
}
