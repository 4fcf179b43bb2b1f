//! The ECS model: a hecs `World` of node, element and edge entities built from a mesh, the
//! boundary conditions stored on them, and the topology generation counter.

use crate::error::SetupError;
use crate::mesh::TriMesh;
use crate::scenario::{Boundary, Material, SideBc};
use hecs::{Entity, World};
use hydrofrac_components::*;

/// The rock mass as entities. The world is the source of truth for identity, topology and
/// persistent state; hot loops run on [`crate::view::SolidView`], rebuilt when
/// `topology_generation` moves.
pub struct Model {
    pub world: World,
    pub material: Material,
    /// Domain bounding box `[xmin, ymin, xmax, ymax]`, m (in 3D, the box's x-y extent).
    pub bbox: [f64; 4],
    /// A 3D model's box `[xmin, ymin, zmin, xmax, ymax, zmax]`, m; `None` in 2D
    /// ([`Model::from_tet_mesh`], `model3.rs`).
    pub bbox3: Option<[f64; 6]>,
    /// A 3D model on a turned grid: the grid's rotation (`TetMesh::frame`); `bbox3` is then
    /// in the grid's frame.
    pub frame3: Option<[[f64; 3]; 3]>,
    /// Nominal mesh size, m.
    pub h: f64,
    /// Smallest triangle altitude, m.
    pub min_altitude: f64,
    /// Bumped once per batch of topology changes; views compare against it.
    pub topology_generation: u64,
    pub next_node_id: u64,
    pub next_elem_id: u64,
    pub next_edge_id: u64,
    pub next_cell_id: u64,
    pub next_joint_id: u64,
}

/// Geometry of a constant-strain triangle with nodes p (counter-clockwise).
pub fn element_geometry(p: [[f64; 2]; 3]) -> ElemGeom {
    let two_a =
        (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
    let inv = 1.0 / two_a;
    ElemGeom {
        area: 0.5 * two_a,
        dndx: [
            (p[1][1] - p[2][1]) * inv,
            (p[2][1] - p[0][1]) * inv,
            (p[0][1] - p[1][1]) * inv,
        ],
        dndy: [
            (p[2][0] - p[1][0]) * inv,
            (p[0][0] - p[2][0]) * inv,
            (p[1][0] - p[0][0]) * inv,
        ],
    }
}

impl Model {
    /// Spawn nodes (lumped mass rho*A/3 from every element around them), elements and edges.
    /// Stable ids follow the mesh's numbering; edges are numbered by sorted node pairs.
    pub fn from_mesh(mesh: &TriMesh, material: Material) -> Result<Self, SetupError> {
        let mut world = World::new();
        let geoms: Vec<ElemGeom> = mesh
            .triangles
            .iter()
            .map(|t| element_geometry([0, 1, 2].map(|k| mesh.nodes[t[k] as usize])))
            .collect();
        if let Some((e, g)) = geoms
            .iter()
            .enumerate()
            .find(|(_, g)| g.area.is_nan() || g.area <= 0.0)
        {
            return Err(SetupError::invalid(
                "mesh",
                format!("triangle {e} has non-positive area {:.3e} m^2", g.area),
            ));
        }
        let mut mass = vec![0.0; mesh.nodes.len()];
        for (t, g) in mesh.triangles.iter().zip(&geoms) {
            for &n in t {
                mass[n as usize] += material.density * g.area / 3.0;
            }
        }
        let nodes: Vec<Entity> = mesh
            .nodes
            .iter()
            .zip(&mass)
            .enumerate()
            .map(|(i, (&x, &m))| {
                let bundle: NodeBundle = (
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
            .triangles
            .iter()
            .zip(&geoms)
            .enumerate()
            .map(|(i, (t, g))| {
                let bundle: ElemBundle = (
                    StableId(i as u64),
                    ElemNodes(t.map(|n| nodes[n as usize])),
                    *g,
                    ElemStress::default(),
                );
                world.spawn(bundle)
            })
            .collect();
        // Edges: sort (min node, max node, element) and group.
        let mut keys: Vec<(u32, u32, u32)> = Vec::with_capacity(3 * mesh.triangles.len());
        for (e, t) in mesh.triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                keys.push((a.min(b), a.max(b), e as u32));
            }
        }
        keys.sort_unstable();
        let [x0, y0, x1, y1] = mesh.bbox;
        let tol = 1e-9 * mesh.h;
        let side_of = |p: [f64; 2], q: [f64; 2]| -> Option<Side> {
            let on = |a: f64, b: f64, c: f64| (a - c).abs() < tol && (b - c).abs() < tol;
            if on(p[0], q[0], x0) {
                Some(Side::Left)
            } else if on(p[0], q[0], x1) {
                Some(Side::Right)
            } else if on(p[1], q[1], y0) {
                Some(Side::Bottom)
            } else if on(p[1], q[1], y1) {
                Some(Side::Top)
            } else {
                None
            }
        };
        let mut edge_id = 0u64;
        let mut k = 0;
        while k < keys.len() {
            let (a, b, e0) = keys[k];
            let second = (k + 1 < keys.len() && keys[k + 1].0 == a && keys[k + 1].1 == b)
                .then(|| keys[k + 1].2);
            if k + 2 < keys.len() && second.is_some() && keys[k + 2].0 == a && keys[k + 2].1 == b {
                return Err(SetupError::invalid(
                    "mesh",
                    format!("edge ({a}, {b}) is shared by more than two triangles"),
                ));
            }
            let side = if second.is_none() {
                side_of(mesh.nodes[a as usize], mesh.nodes[b as usize])
            } else {
                None
            };
            let bundle: EdgeBundle = (
                StableId(edge_id),
                EdgeNodes([nodes[a as usize], nodes[b as usize]]),
                EdgeElems([Some(elems[e0 as usize]), second.map(|e| elems[e as usize])]),
                EdgeState {
                    side,
                    ..Default::default()
                },
            );
            world.spawn(bundle);
            edge_id += 1;
            k += if second.is_some() { 2 } else { 1 };
        }
        Ok(Model {
            world,
            material,
            bbox: mesh.bbox,
            bbox3: None,
            frame3: None,
            h: mesh.h,
            min_altitude: mesh.min_altitude(),
            topology_generation: 0,
            next_node_id: mesh.nodes.len() as u64,
            next_elem_id: mesh.triangles.len() as u64,
            next_edge_id: edge_id,
            next_cell_id: 0,
            next_joint_id: 0,
        })
    }

    /// A model with no solid (flow-only scenes).
    pub fn empty() -> Self {
        Model {
            world: World::new(),
            material: Material {
                young: 1.0,
                poisson: 0.0,
                density: 1.0,
            },
            bbox: [0.0; 4],
            bbox3: None,
            frame3: None,
            h: 1.0,
            min_altitude: f64::INFINITY,
            topology_generation: 0,
            next_node_id: 0,
            next_elem_id: 0,
            next_edge_id: 0,
            next_cell_id: 0,
            next_joint_id: 0,
        }
    }

    /// Spawn a rigid network's nodes (outside the solid) and its cells, each holding fluid per
    /// `initial` at reference density `rho_r` and bulk modulus `k`.
    pub fn add_network(
        &mut self,
        net: &crate::network::CellNetwork,
        initial: crate::scenario::InitialFluid,
        rho_r: f64,
        k: f64,
    ) {
        let nodes: Vec<Entity> = net
            .nodes
            .iter()
            .map(|&x| {
                let id = self.next_node_id;
                self.next_node_id += 1;
                let bundle: NodeBundle = (
                    StableId(id),
                    NodeRef(x),
                    NodeState::default(),
                    NodeMass(0.0),
                    NodeBc::default(),
                    NodeLink {
                        in_solid: false,
                        mother: None,
                    },
                );
                self.world.spawn(bundle)
            })
            .collect();
        for &(a, b, aperture, _) in &net.cells {
            let (pa, pb) = (net.nodes[a as usize], net.nodes[b as usize]);
            let len = ((pb[0] - pa[0]).powi(2) + (pb[1] - pa[1]).powi(2)).sqrt();
            let (mass, pressure) = match initial {
                crate::scenario::InitialFluid::Empty => (0.0, 0.0),
                crate::scenario::InitialFluid::Full(p) => {
                    (rho_r * (1.0 + p / k) * aperture * len, p)
                }
            };
            let id = self.next_cell_id;
            self.next_cell_id += 1;
            let bundle: CellBundle = (
                StableId(id),
                CellNodes([nodes[a as usize], nodes[b as usize]]),
                CellFluid {
                    aperture,
                    mass,
                    pressure,
                    flow_rate: 0.0,
                },
                CellOrigin {
                    kind: CellKind::Preexisting,
                    created_t: 0.0,
                },
            );
            self.world.spawn(bundle);
        }
        self.topology_generation += 1;
    }

    /// Attach the scenario's flow boundaries to the nearest network node or cell centre.
    pub fn add_flow_boundaries(
        &mut self,
        bcs: &[crate::scenario::FlowBoundary],
    ) -> Result<(), SetupError> {
        use crate::scenario::FlowTarget;
        let mut cell_ends: Vec<(Entity, [Entity; 2])> = self
            .world
            .query::<(Entity, &CellNodes)>()
            .iter()
            .map(|(e, c)| (e, c.0))
            .collect();
        cell_ends.sort_by_key(|(e, _)| self.world.get::<&StableId>(*e).map(|i| i.0).unwrap_or(0));
        let pos = |e: Entity| self.world.get::<&NodeRef>(e).expect("node").0;
        let mut spawned = Vec::new();
        for (i, bc) in bcs.iter().enumerate() {
            let (target, d_near, p) = match bc.at {
                FlowTarget::Node(_) | FlowTarget::Cell(_) if bc.at.is_3d() => {
                    return Err(SetupError::invalid(
                        &format!("flow_boundaries[{i}].at"),
                        "this mesh is 2D: give the point as (x, y), m",
                    ));
                }
                FlowTarget::Node(p) => {
                    let p = p.xy();
                    let best = cell_ends
                        .iter()
                        .flat_map(|(_, n)| n.iter().copied())
                        .map(|n| (n, dist(pos(n), p)))
                        .min_by(|a, b| a.1.total_cmp(&b.1));
                    let Some((n, d)) = best else {
                        return Err(SetupError::invalid(
                            "flow_boundaries",
                            "the network has no cells",
                        ));
                    };
                    (FlowBcTarget::Node(n), d, p)
                }
                FlowTarget::Cell(p) => {
                    let p = p.xy();
                    let best = cell_ends
                        .iter()
                        .map(|(c, n)| {
                            let (a, b) = (pos(n[0]), pos(n[1]));
                            (*c, dist([0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])], p))
                        })
                        .min_by(|a, b| a.1.total_cmp(&b.1));
                    let Some((c, d)) = best else {
                        return Err(SetupError::invalid(
                            "flow_boundaries",
                            "the network has no cells",
                        ));
                    };
                    (FlowBcTarget::Cell(c), d, p)
                }
            };
            // The nearest node or cell centre must be close compared with the cells around it.
            let near = match target {
                FlowBcTarget::Node(n) => cell_ends
                    .iter()
                    .filter(|(_, e)| e.contains(&n))
                    .map(|(_, e)| dist(pos(e[0]), pos(e[1])))
                    .fold(0.0, f64::max),
                FlowBcTarget::Cell(c) => cell_ends
                    .iter()
                    .find(|(e, _)| *e == c)
                    .map(|(_, e)| dist(pos(e[0]), pos(e[1])))
                    .unwrap_or(0.0),
            };
            if dist_ok(d_near, near).is_err() {
                return Err(SetupError::invalid(
                    &format!("flow_boundaries[{i}].at"),
                    format!(
                        "({}, {}) is {d_near:.3} m from the nearest network {}; put it on the network",
                        p[0],
                        p[1],
                        if matches!(target, FlowBcTarget::Node(_)) {
                            "node"
                        } else {
                            "cell centre"
                        }
                    ),
                ));
            }
            if let Some(other) = spawned.iter().find(|b: &&FlowBc| b.target == target) {
                let what = if matches!(target, FlowBcTarget::Node(_)) {
                    "node"
                } else {
                    "cell"
                };
                return Err(SetupError::invalid(
                    &format!("flow_boundaries[{i}].at"),
                    format!(
                        "({}, {}) is the network {what} of flow_boundaries[{}] too: two \
                         boundaries on one {what} contradict each other",
                        p[0], p[1], other.index
                    ),
                ));
            }
            spawned.push(FlowBc {
                index: i,
                target,
                pressure: 0.0,
                rate: 0.0,
                volume_in: 0.0,
                volume_out: 0.0,
            });
        }
        self.spawn_flow_boundaries(spawned.into_iter().map(|b| b.target));
        Ok(())
    }

    /// Spawn one flow boundary per target, boundary k for `flow_boundaries[k]` at rest (stable
    /// id k), in both dimensions.
    pub fn spawn_flow_boundaries(&mut self, targets: impl Iterator<Item = FlowBcTarget>) {
        for (k, target) in targets.enumerate() {
            let bundle: FlowBcBundle = (
                StableId(k as u64),
                FlowBc {
                    index: k,
                    target,
                    pressure: 0.0,
                    rate: 0.0,
                    volume_in: 0.0,
                    volume_out: 0.0,
                },
            );
            self.world.spawn(bundle);
        }
        self.topology_generation += 1;
    }

    /// Which sides of the domain a reference position lies on (corners are on two).
    pub fn sides_of(&self, p: [f64; 2]) -> impl Iterator<Item = Side> + '_ {
        let [x0, y0, x1, y1] = self.bbox;
        let tol = 1e-9 * self.h;
        Side::ALL.into_iter().filter(move |s| match s {
            Side::Left => (p[0] - x0).abs() < tol,
            Side::Right => (p[0] - x1).abs() < tol,
            Side::Bottom => (p[1] - y0).abs() < tol,
            Side::Top => (p[1] - y1).abs() < tol,
            Side::Front | Side::Back => false,
        })
    }

    /// Put every solid node at the homogeneous plane-strain displacement of the in-situ stress
    /// (sxx, syy), Pa: u = (exx (x - xc), eyy (y - yc)) about the domain centre, at rest. With
    /// `Boundary::InSitu` the unfractured body then starts in equilibrium.
    pub fn set_insitu_displacement(&mut self, sxx: f64, syy: f64) {
        let (exx, eyy) = self.material.plane_strain_strain(sxx, syy);
        let [x0, y0, x1, y1] = self.bbox;
        let (xc, yc) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        for (x, st) in self.world.query_mut::<(&NodeRef, &mut NodeState)>() {
            st.u = [exx * (x.0[0] - xc), eyy * (x.0[1] - yc)];
            st.v = [0.0; 2];
        }
    }

    /// Store the scenario's boundary conditions on the nodes (prescribed displacements and
    /// traction loads; previous conditions are replaced).
    pub fn apply_boundary(&mut self, boundary: &Boundary) {
        let bc_of_side: [SideBc; 4] = match *boundary {
            Boundary::InSitu { sxx, syy } => {
                let (exx, eyy) = self.material.plane_strain_strain(sxx, syy);
                let [x0, y0, x1, y1] = self.bbox;
                let (hw, hh) = (0.5 * (x1 - x0), 0.5 * (y1 - y0));
                // Outward normal displacement d: left/right move by exx*(+-hw), bottom/top by eyy*(+-hh).
                [
                    SideBc::Normal(exx * hw),
                    SideBc::Normal(exx * hw),
                    SideBc::Normal(eyy * hh),
                    SideBc::Normal(eyy * hh),
                ]
            }
            Boundary::Sides {
                left,
                right,
                bottom,
                top,
            } => [left, right, bottom, top],
            // A 2D mesh with a 3D box's boundary is refused by the scenario's checks
            // (`Scenario::validate`); nothing to hold here.
            Boundary::InSitu3 { .. } | Boundary::Sides3 { .. } => [SideBc::Free; 4],
        };
        let side_index = |s: Side| Side::ALL.iter().position(|&t| t == s).expect("side");
        // Prescribed displacements.
        let mut updates = Vec::new();
        // A node is on a side when one of its solid boundary edges is (after splitting, the
        // daughters of a corner node each keep only the sides of their own elements).
        let mut node_sides: std::collections::HashMap<Entity, Vec<Side>> =
            std::collections::HashMap::new();
        for (en, st) in self.world.query::<(&EdgeNodes, &EdgeState)>().iter() {
            if let (Some(side), false) = (st.side, st.opened) {
                for n in en.0 {
                    let v = node_sides.entry(n).or_default();
                    if !v.contains(&side) {
                        v.push(side);
                    }
                }
            }
        }
        for (e, link) in self.world.query::<(Entity, &NodeLink)>().iter() {
            if !link.in_solid {
                continue;
            }
            let mut bc: NodeBc = NodeBc::default();
            for &s in node_sides.get(&e).map_or(&[][..], |v| &v[..]) {
                let n = s.normal();
                match bc_of_side[side_index(s)] {
                    SideBc::Normal(d) => {
                        let dir = if n[0] != 0.0 { 0 } else { 1 };
                        bc.prescribed[dir] = Some(d * (n[0] + n[1]));
                    }
                    SideBc::Fixed => bc.prescribed = [Some(0.0), Some(0.0)],
                    SideBc::Free | SideBc::Traction { .. } => {}
                }
            }
            updates.push((e, bc));
        }
        for (e, bc) in updates {
            *self.world.get::<&mut NodeBc>(e).expect("node") = bc;
        }
        // Tractions on external boundary edges: t * L / 2 to each end node.
        let mut loads: Vec<(Entity, [f64; 2])> = Vec::new();
        for (en, st) in self.world.query::<(&EdgeNodes, &EdgeState)>().iter() {
            let Some(side) = st.side else { continue };
            if let SideBc::Traction { normal, shear } = bc_of_side[side_index(side)] {
                let n = side.normal();
                let t = [-n[1], n[0]];
                let tr = [normal * n[0] + shear * t[0], normal * n[1] + shear * t[1]];
                let p = en.0.map(|e| self.world.get::<&NodeRef>(e).expect("node").0);
                let len = ((p[1][0] - p[0][0]).powi(2) + (p[1][1] - p[0][1]).powi(2)).sqrt();
                for &e in &en.0 {
                    loads.push((e, [0.5 * len * tr[0], 0.5 * len * tr[1]]));
                }
            }
        }
        for (e, f) in loads {
            let mut bc = self.world.get::<&mut NodeBc>(e).expect("node");
            bc.load[0] += f[0];
            bc.load[1] += f[1];
        }
        self.topology_generation += 1;
    }

    /// Prescribe displacement components on the nodes nearest to each pin (which must be within
    /// half a cell diagonal of a node).
    pub fn apply_pins(&mut self, pins: &[crate::scenario::Pin]) -> Result<(), SetupError> {
        for (i, pin) in pins.iter().enumerate() {
            let nearest = self
                .world
                .query::<(Entity, &NodeRef, &NodeLink)>()
                .iter()
                .filter(|(_, _, l)| l.in_solid)
                .map(|(e, x, _)| (e, (x.0[0] - pin.at.v[0]).hypot(x.0[1] - pin.at.v[1])))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let Some((e, dist)) = nearest else {
                return Err(SetupError::invalid("pins", "the mesh has no nodes"));
            };
            if dist > 0.5 * std::f64::consts::SQRT_2 * self.h {
                return Err(SetupError::invalid(
                    &format!("pins[{i}].at"),
                    format!(
                        "({}, {}) is {dist:.3} m from the nearest node (more than half a cell diagonal)",
                        pin.at.v[0], pin.at.v[1]
                    ),
                ));
            }
            let mut bc = self.world.get::<&mut NodeBc>(e).expect("node");
            if let Some(ux) = pin.ux {
                bc.prescribed[0] = Some(ux);
            }
            if let Some(uy) = pin.uy {
                bc.prescribed[1] = Some(uy);
            }
        }
        self.topology_generation += 1;
        Ok(())
    }

    /// Prescribe displacements on every boundary node from a function of the reference position
    /// (for patch tests and manufactured solutions).
    pub fn prescribe_boundary_field(&mut self, f: impl Fn([f64; 2]) -> [f64; 2]) {
        let on_boundary: Vec<(Entity, [f64; 2])> = self
            .world
            .query::<(Entity, &NodeRef)>()
            .iter()
            .filter(|(_, x)| self.sides_of(x.0).next().is_some())
            .map(|(e, x)| (e, x.0))
            .collect();
        for (e, x) in on_boundary {
            let u = f(x);
            self.world.get::<&mut NodeBc>(e).expect("node").prescribed = [Some(u[0]), Some(u[1])];
        }
        self.topology_generation += 1;
    }

    /// Add the consistent nodal loads of a body force b(x), N/m^3, integrated over each element
    /// with the three-point edge-midpoint rule (exact for quadratic integrands).
    pub fn add_body_force(&mut self, b: impl Fn([f64; 2]) -> [f64; 2]) {
        let mut loads: Vec<(Entity, [f64; 2])> = Vec::new();
        for (en, g) in self.world.query::<(&ElemNodes, &ElemGeom)>().iter() {
            let p = en.0.map(|e| self.world.get::<&NodeRef>(e).expect("node").0);
            let mut f = [[0.0; 2]; 3];
            for k in 0..3 {
                let (i, j) = (k, (k + 1) % 3);
                let m = [0.5 * (p[i][0] + p[j][0]), 0.5 * (p[i][1] + p[j][1])];
                let bm = b(m);
                // Weight A/3; N_i = N_j = 1/2 at the midpoint of edge (i, j).
                for d in 0..2 {
                    f[i][d] += g.area / 3.0 * 0.5 * bm[d];
                    f[j][d] += g.area / 3.0 * 0.5 * bm[d];
                }
            }
            for k in 0..3 {
                loads.push((en.0[k], f[k]));
            }
        }
        for (e, f) in loads {
            let mut bc = self.world.get::<&mut NodeBc>(e).expect("node");
            bc.load[0] += f[0];
            bc.load[1] += f[1];
        }
        self.topology_generation += 1;
    }

    pub fn cell_count(&self) -> usize {
        self.world.query::<&CellNodes>().iter().count()
    }

    pub fn node_count(&self) -> usize {
        self.world
            .query::<&NodeLink>()
            .iter()
            .filter(|l| l.in_solid)
            .count()
    }
    pub fn element_count(&self) -> usize {
        self.world.query::<&ElemNodes>().iter().count()
    }
    /// Edges of the solid (opened mother edges excluded).
    pub fn edge_count(&self) -> usize {
        self.world
            .query::<&EdgeState>()
            .iter()
            .filter(|s| !s.opened)
            .count()
    }
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// A boundary point may sit at most half a cell length from its node or cell centre.
fn dist_ok(d: f64, cell_len: f64) -> Result<(), ()> {
    if d <= 0.5 * cell_len + 1e-9 {
        Ok(())
    } else {
        Err(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rock() -> Material {
        Material {
            young: 20e9,
            poisson: 0.2,
            density: 2700.0,
        }
    }

    #[test]
    fn edges_internal_and_external() {
        let mesh = TriMesh::regular(4.0, 3.0, 1.0, [0.0, 0.0]).unwrap();
        let m = Model::from_mesh(&mesh, rock()).unwrap();
        // Euler: E = V + F - 1 for a disc.
        assert_eq!(m.edge_count(), mesh.nodes.len() + mesh.triangles.len() - 1);
        let external: Vec<Option<Side>> = m
            .world
            .query::<(&EdgeElems, &EdgeState)>()
            .iter()
            .filter(|(e, _)| e.is_external())
            .map(|(_, s)| s.side)
            .collect();
        assert_eq!(external.len(), 2 * (4 + 3));
        assert!(external.iter().all(|s| s.is_some()));
        let total_mass: f64 = m.world.query::<&NodeMass>().iter().map(|m| m.0).sum();
        assert!((total_mass - 2700.0 * 12.0).abs() < 1e-9);
    }

    #[test]
    fn geometry_gradients_reproduce_linear_fields() {
        let p = [[0.1, 0.2], [1.3, 0.4], [0.5, 1.1]];
        let g = element_geometry(p);
        // sum_a dN_a/dx * x_a = 1, sum_a dN_a/dx * y_a = 0, etc.
        let sx: f64 = (0..3).map(|a| g.dndx[a] * p[a][0]).sum();
        let sy: f64 = (0..3).map(|a| g.dndx[a] * p[a][1]).sum();
        let ty: f64 = (0..3).map(|a| g.dndy[a] * p[a][1]).sum();
        assert!((sx - 1.0).abs() < 1e-14 && sy.abs() < 1e-14 && (ty - 1.0).abs() < 1e-14);
        assert!(g.area > 0.0);
    }
}
