//! Dense views: index arrays and struct-of-arrays state copied out of the ECS, ordered by stable
//! id, for the cross-entity hot loops (`docs/architecture.md`, dense views). A view is rebuilt only when the
//! model's topology generation moves; between rebuilds the view holds the hot node and element
//! state, which [`SolidView::write_back`] copies into the components at sync points.

use crate::dim::{Cst, Element};
use crate::element::{SolidParams, cst_stress};
use crate::model::Model;
use hecs::Entity;
use hydrofrac_components::*;

/// Marker for a dense index that does not exist.
pub const NONE: u32 = u32::MAX;

/// The solid mesh as flat arrays, for the element kind `E` ([`crate::dim`]: the CST in 2D, the
/// default, or the TET4 in 3D). Node vectors are `E::Vector`s (`[x, y]` or `[x, y, z]`);
/// `elem_force` holds every element's nodal force components from the last internal-force pass.
/// The edge, joint and motion arrays are the 2D fracture's; they stay empty in 3D.
#[derive(Clone, Default, serde::Serialize, serde::Deserialize)]
#[serde(bound = "")]
pub struct SolidView<E: Element = Cst> {
    /// Topology generation this view was built from.
    pub generation: u64,
    pub node_entity: Vec<Entity>,
    pub node_id: Vec<u64>,
    /// Reference positions, m.
    pub x0: Vec<E::Vector>,
    /// Displacements, m.
    pub u: Vec<E::Vector>,
    /// Velocities at the last half step, m/s.
    pub v: Vec<E::Vector>,
    /// Unbalanced force (internal + external), N/m in 2D, N in 3D.
    pub force: Vec<E::Vector>,
    /// Damping force (stays zero when the damping system is off).
    pub f_damp: Vec<E::Vector>,
    /// Constant external load (tractions, body forces).
    pub load: Vec<E::Vector>,
    /// Lumped mass (kg/m in 2D, kg in 3D) and its inverse.
    pub mass: Vec<f64>,
    pub inv_mass: Vec<f64>,
    /// Bit d set: displacement component d is prescribed to `presc[i][d]`.
    pub fixed: Vec<u8>,
    pub presc: Vec<E::Vector>,
    pub elem_entity: Vec<Entity>,
    pub elem_id: Vec<u64>,
    /// Dense node indices of each element.
    pub conn: Vec<E::Conn>,
    /// Element geometry: the measure, then the shape-function gradients (2D: [area,
    /// dN0/dx, dN1/dx, dN2/dx, dN0/dy, dN1/dy, dN2/dy]; 3D: [volume, grad N0, .., grad N3]).
    pub geom: Vec<E::Geom>,
    /// Element stress (Voigt), Pa.
    pub stress: Vec<E::Stress>,
    /// Element nodal forces, node by node ([f0x, f0y, f1x, ..]).
    pub elem_force: Vec<E::Forces>,
    /// Node -> (element * D * NODES + D * local node) incidence, CSR, ascending element order.
    pub inc_ptr: Vec<u32>,
    pub inc: Vec<u32>,
    /// Internal edges (two elements), ordered by stable id: entity, the dense indices of the two
    /// elements, the unit normal in the reference configuration, and the criterion state.
    pub edge_entity: Vec<Entity>,
    pub edge_elems: Vec<[u32; 2]>,
    /// Dense indices of the edge's two nodes.
    pub edge_nodes: Vec<[u32; 2]>,
    pub edge_normal: Vec<[f64; 2]>,
    /// Edge patches, CSR over edges: the elements touching either end of the edge whose
    /// centroid projects onto the edge (those alongside it), with their area weights
    /// normalised to 1 per edge. The fracture criterion's face stress is their weighted mean.
    pub patch_ptr: Vec<u32>,
    pub patch: Vec<(u32, f64)>,
    /// 3D with a fracture criterion: the unit normal of internal face k (the `edge_*` rows are
    /// then the internal faces, `edge_nodes` and the patches left empty), pointing from its
    /// first tetrahedron to its second, in the reference configuration
    /// (`SolidView::push_internal_faces`). Empty in 2D and in 3D runs without a criterion.
    pub face_normal: Vec<[f64; 3]>,
    /// Normal stress across the edge, Pa (tension positive), and the fracture-ready mark.
    pub edge_sigma_n: Vec<f64>,
    pub edge_ready: Vec<bool>,
    /// Joints, ordered by stable id: nodes [p_a, p_b, q_a, q_b] in 2D (dense; the sister edges
    /// list their ends in the same order), [p_0, p_1, p_2, q_0, q_1, q_2] in 3D (the sister
    /// faces likewise, face p's normal (x1 - x0) x (x2 - x0) pointing towards q); in 2D the
    /// sign that makes (t_y, -t_x) face p's outward normal (empty in 3D); the contact state.
    pub joint_entity: Vec<Entity>,
    pub joint_nodes: Vec<E::JointNodes>,
    pub joint_sign: Vec<f64>,
    pub joint_state: Vec<JointState<E::Shear>>,
    /// Motion regions, set by the strength test's screen
    /// (`systems::fracture::StrengthScreen`): runs of consecutive nodes in one region (first
    /// node, end, region; covering every node in order), and per region the sum
    /// over the `integrate` calls since the screen last read it of that call's largest change
    /// of a node's displacement component, m; `motion_steps` counts those calls. Empty: not
    /// tracked. Not in checkpoints (the screen installs them again on restore).
    #[serde(skip)]
    pub motion_runs: Vec<(u32, u32, u32)>,
    #[serde(skip)]
    pub motion_du: Vec<f64>,
    #[serde(skip)]
    pub motion_steps: u32,
    #[serde(skip)]
    pub motion_scratch: Vec<f64>,
    #[serde(skip)]
    pub motion_node: Vec<f64>,
}

/// CSR incidence of `n` targets from items that each name `K` targets: for target i,
/// `inc[ptr[i]..ptr[i + 1]]` lists `code(item, slot)` in ascending item order. Gathers over it
/// sum in a fixed order, so results do not depend on the number of threads.
pub fn incidence<const K: usize>(
    n: usize,
    items: &[[u32; K]],
    code: impl Fn(usize, usize) -> u32,
) -> (Vec<u32>, Vec<u32>) {
    incidence_of(n, items, code)
}

/// [`incidence`] for items of any fixed shape (an element kind's connectivity).
pub fn incidence_of<C: AsRef<[u32]>>(
    n: usize,
    items: &[C],
    code: impl Fn(usize, usize) -> u32,
) -> (Vec<u32>, Vec<u32>) {
    let mut ptr = vec![0u32; n + 1];
    for it in items {
        for &a in it.as_ref() {
            ptr[a as usize + 1] += 1;
        }
    }
    for i in 0..n {
        ptr[i + 1] += ptr[i];
    }
    let mut fill = ptr.clone();
    let mut inc = vec![0u32; ptr[n] as usize];
    for (e, it) in items.iter().enumerate() {
        for (k, &a) in it.as_ref().iter().enumerate() {
            inc[fill[a as usize] as usize] = code(e, k);
            fill[a as usize] += 1;
        }
    }
    (ptr, inc)
}

/// An internal solid edge: (stable id, entity, its two elements, its two nodes (dense), unit
/// normal, state).
type EdgeRow = (u64, Entity, [u32; 2], [u32; 2], [f64; 2], EdgeState);

/// The internal solid edges not opened (opened mother edges left the solid: their sister
/// daughters are joints), by stable id, with dense element and node indices and the unit
/// normal of the reference positions.
fn internal_edges(world: &hecs::World, dense: &[u32], elem_dense: &[u32]) -> Vec<EdgeRow> {
    let mut edges: Vec<EdgeRow> = world
        .query::<(Entity, &StableId, &EdgeNodes, &EdgeElems, &EdgeState)>()
        .iter()
        .filter_map(|(e, id, en, ee, st)| {
            // Opened (mother) edges left the solid: their sister daughters are joints.
            let ([Some(a), Some(b)], false) = (ee.0, st.opened) else {
                return None;
            };
            let [p, q] = en.0.map(|n| world.get::<&NodeRef>(n).expect("node").0);
            let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
            let len = dx.hypot(dy);
            Some((
                id.0,
                e,
                [elem_dense[a.id() as usize], elem_dense[b.id() as usize]],
                en.0.map(|x| dense[x.id() as usize]),
                [dy / len, -dx / len],
                *st,
            ))
        })
        .collect();
    edges.sort_unstable_by_key(|r| r.0);
    edges
}

impl<E: Element> SolidView<E> {
    pub fn n_nodes(&self) -> usize {
        self.node_entity.len()
    }
    pub fn n_elems(&self) -> usize {
        self.elem_entity.len()
    }

    /// Elements at node i: (element, local index), from the incidence.
    pub fn elements_at(&self, i: u32) -> impl Iterator<Item = (u32, u8)> + '_ {
        let (s, e) = (
            self.inc_ptr[i as usize] as usize,
            self.inc_ptr[i as usize + 1] as usize,
        );
        let per = (E::D * E::NODES) as u32;
        self.inc[s..e]
            .iter()
            .map(move |&c| (c / per, ((c % per) / E::D as u32) as u8))
    }

    /// Mean element stress (Voigt: [sxx, syy, sxy] in 2D, six components in 3D) at the
    /// current displacements, weighted by area or volume, Pa, with the element minimum and
    /// maximum (zeros without elements).
    pub fn stress_summary(&self, p: &SolidParams) -> (E::Stress, E::Stress, E::Stress) {
        let zero = E::Stress::default();
        let mut mean = zero;
        let mut min = zero;
        let mut max = zero;
        let n = zero.as_ref().len();
        for k in 0..n {
            min[k] = f64::INFINITY;
            max[k] = f64::NEG_INFINITY;
        }
        let mut measure = 0.0;
        for (e, g) in self.geom.iter().enumerate() {
            let s = E::stress(g, &self.conn[e], &self.u, p);
            let m = E::measure(g);
            for k in 0..n {
                mean[k] += m * s[k];
                min[k] = min[k].min(s[k]);
                max[k] = max[k].max(s[k]);
            }
            measure += m;
        }
        if measure == 0.0 {
            return (zero, zero, zero);
        }
        for k in 0..n {
            mean[k] /= measure;
        }
        (mean, min, max)
    }

    /// Whether any node carries an external load (tractions, body forces).
    pub fn has_load(&self) -> bool {
        self.load
            .iter()
            .any(|l| l.as_ref().iter().any(|&x| x != 0.0))
    }

    /// The node incidence of the elements (CSR, for the deterministic gather of element
    /// forces): codes `element * D * NODES + D * local node`.
    pub fn set_incidence(&mut self) {
        let per = E::D * E::NODES;
        (self.inc_ptr, self.inc) = incidence_of(self.n_nodes(), &self.conn, |e, k| {
            (per * e + E::D * k) as u32
        });
    }
}

/// The element kinds whose views a [`Model`] builds: the one place the engine chooses between
/// the 2D ([`SolidView::build`]) and 3D ([`SolidView::build_3d`]) entities.
pub trait ModelView: Element {
    /// The view of the model's solid, ordered by stable id.
    fn build_view(model: &Model) -> SolidView<Self>;
    /// Copy the view's hot state back into the model's components.
    fn write_back(v: &SolidView<Self>, model: &mut Model, p: &SolidParams);
}

impl ModelView for Cst {
    fn build_view(model: &Model) -> SolidView<Cst> {
        SolidView::<Cst>::build(model)
    }
    fn write_back(v: &SolidView<Cst>, model: &mut Model, p: &SolidParams) {
        v.write_back(model, p)
    }
}

impl ModelView for crate::dim::Tet4 {
    fn build_view(model: &Model) -> SolidView<Self> {
        SolidView::build_3d(model)
    }
    fn write_back(v: &SolidView<Self>, model: &mut Model, p: &SolidParams) {
        v.write_back_3d(model, p)
    }
}

/// One solid node as the view takes it: stable id, entity, reference position (m),
/// displacement (m), velocity (m/s), lumped mass, constant load, and the prescribed components
/// (bit d of `fixed`) with their values (m).
pub struct NodeRow<E: Element> {
    pub id: u64,
    pub entity: Entity,
    pub x: E::Vector,
    pub u: E::Vector,
    pub v: E::Vector,
    pub mass: f64,
    pub load: E::Vector,
    pub fixed: u8,
    pub presc: E::Vector,
}

/// One element as the view takes it: stable id, entity, dense connectivity, geometry, stress.
pub type ElemRow<E> = (
    u64,
    Entity,
    <E as Element>::Conn,
    <E as Element>::Geom,
    <E as Element>::Stress,
);

/// Bit d set where component d is prescribed.
pub fn fixed_mask(prescribed: &[Option<f64>]) -> u8 {
    let mut mask = 0u8;
    for (d, p) in prescribed.iter().enumerate() {
        if p.is_some() {
            mask |= 1 << d;
        }
    }
    mask
}

impl<E: Element> SolidView<E> {
    /// Fill the node arrays from `nodes` (any order; sorted here by stable id) and record
    /// each node entity's dense index in `dense` (by entity index).
    pub fn push_node_rows(&mut self, mut nodes: Vec<NodeRow<E>>, dense: &mut [u32]) {
        nodes.sort_unstable_by_key(|r| r.id);
        let n = nodes.len();
        self.node_entity.reserve(n);
        for (i, r) in nodes.into_iter().enumerate() {
            dense[r.entity.id() as usize] = i as u32;
            self.node_entity.push(r.entity);
            self.node_id.push(r.id);
            self.x0.push(r.x);
            self.u.push(r.u);
            self.v.push(r.v);
            self.mass.push(r.mass);
            self.inv_mass
                .push(if r.mass > 0.0 { 1.0 / r.mass } else { 0.0 });
            self.load.push(r.load);
            self.fixed.push(r.fixed);
            self.presc.push(r.presc);
        }
        self.force = vec![E::Vector::default(); n];
        self.f_damp = vec![E::Vector::default(); n];
    }

    /// Fill the element arrays from (stable id, entity, dense connectivity, geometry, stress)
    /// rows (any order; sorted here by stable id).
    pub fn push_elem_rows(&mut self, mut elems: Vec<ElemRow<E>>) {
        elems.sort_unstable_by_key(|r| r.0);
        let ne = elems.len();
        self.elem_entity.reserve(ne);
        for (id, e, c, g, s) in elems {
            self.elem_entity.push(e);
            self.elem_id.push(id);
            self.conn.push(c);
            self.geom.push(g);
            self.stress.push(s);
        }
        self.elem_force = vec![E::Forces::default(); ne];
    }
}

impl SolidView {
    /// Joints whose two faces share one end node, by node then joint: (that node, joint, the
    /// daughter pair at the joint's other end [face p's, face q's]). A node listed once is a
    /// fracture tip (intact rock ahead); a node listed by two joints joins two fracture pieces.
    pub fn joint_ends(&self) -> Vec<(u32, usize, [u32; 2])> {
        let mut ends: Vec<(u32, usize, [u32; 2])> = Vec::new();
        for (k, nodes) in self.joint_nodes.iter().enumerate() {
            let [pa, pb, qa, qb] = *nodes;
            if pa == qa && pb != qb {
                ends.push((pa, k, [pb, qb]));
            } else if pb == qb && pa != qa {
                ends.push((pb, k, [pa, qa]));
            }
        }
        ends.sort_by_key(|s| (s.0, s.1));
        ends
    }

    /// Build the view from the model (nodes in the solid only), ordered by stable id.
    pub fn build(model: &Model) -> Self {
        let world = &model.world;
        let max_index = world
            .iter()
            .map(|e| e.entity().id())
            .max()
            .map_or(0, |m| m as usize + 1);
        let mut dense = vec![NONE; max_index];
        let mut v = SolidView {
            generation: model.topology_generation,
            ..Default::default()
        };
        v.push_nodes(world, &mut dense);
        v.push_elements(world, &dense);
        // Node incidence (CSR) for the deterministic gather of element forces.
        v.set_incidence();
        // Internal edges for the fracture criterion.
        let mut elem_dense = vec![NONE; max_index];
        for (k, e) in v.elem_entity.iter().enumerate() {
            elem_dense[e.id() as usize] = k as u32;
        }
        let edges = internal_edges(world, &dense, &elem_dense);
        v.push_edge_patches(&edges);
        v.push_edges(edges);
        v.push_joints(model, &dense);
        v
    }

    /// The nodes in the solid, by stable id: reference position (m), displacement (m),
    /// velocity (m/s), mass and its inverse (kg per metre), load (N per metre) and the
    /// prescribed displacements (mask and values, m); `dense` maps each node entity's index to
    /// its dense index.
    fn push_nodes(&mut self, world: &hecs::World, dense: &mut [u32]) {
        let nodes: Vec<NodeRow<Cst>> = world
            .query::<(
                Entity,
                &StableId,
                &NodeRef,
                &NodeState,
                &NodeMass,
                &NodeBc,
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
        self.push_node_rows(nodes, dense);
    }

    /// The elements by stable id: connectivity (dense node indices), geometry (area m^2 and
    /// shape-function gradients 1/m) and stress (Pa).
    fn push_elements(&mut self, world: &hecs::World, dense: &[u32]) {
        let elems: Vec<ElemRow<Cst>> = world
            .query::<(Entity, &StableId, &ElemNodes, &ElemGeom, &ElemStress)>()
            .iter()
            .map(|(e, id, en, g, s)| {
                (
                    id.0,
                    e,
                    en.0.map(|n| dense[n.id() as usize]),
                    [
                        g.area, g.dndx[0], g.dndx[1], g.dndx[2], g.dndy[0], g.dndy[1], g.dndy[2],
                    ],
                    s.0,
                )
            })
            .collect();
        self.push_elem_rows(elems);
    }

    /// Per internal edge (in `edges`' order), the patch of elements around it whose centroids
    /// project strictly inside the edge, each with its share of the patch's area.
    fn push_edge_patches(&mut self, edges: &[EdgeRow]) {
        let v = self;
        v.patch_ptr.push(0);
        let mut cand: Vec<u32> = Vec::new();
        for &(_, _, _, nodes, _, _) in edges {
            let [a, b] = nodes.map(|x| v.x0[x as usize]);
            let t = [b[0] - a[0], b[1] - a[1]];
            let l2 = t[0] * t[0] + t[1] * t[1];
            cand.clear();
            for x in nodes {
                for &k in &v.inc[v.inc_ptr[x as usize] as usize..v.inc_ptr[x as usize + 1] as usize]
                {
                    cand.push(k / 6);
                }
            }
            cand.sort_unstable();
            cand.dedup();
            let start = v.patch.len();
            let mut w = 0.0;
            for &e in &cand {
                let c = v.conn[e as usize].map(|x| v.x0[x as usize]);
                let cx = (c[0][0] + c[1][0] + c[2][0]) / 3.0;
                let cy = (c[0][1] + c[1][1] + c[2][1]) / 3.0;
                let s = ((cx - a[0]) * t[0] + (cy - a[1]) * t[1]) / l2;
                if s > 1e-9 && s < 1.0 - 1e-9 {
                    let area = v.geom[e as usize][0];
                    v.patch.push((e, area));
                    w += area;
                }
            }
            for p in &mut v.patch[start..] {
                p.1 /= w;
            }
            v.patch_ptr.push(v.patch.len() as u32);
        }
    }

    /// The internal edges: entity, elements, nodes, unit normal, normal stress (Pa) and
    /// readiness.
    fn push_edges(&mut self, edges: Vec<EdgeRow>) {
        for (_, e, el, nodes, n, st) in edges {
            self.edge_entity.push(e);
            self.edge_elems.push(el);
            self.edge_nodes.push(nodes);
            self.edge_normal.push(n);
            self.edge_sigma_n.push(st.sigma_n);
            self.edge_ready.push(st.fracture_ready);
        }
    }

    /// The joints whose four face nodes are all in the solid, by stable id: dense nodes, the
    /// sign of face p's tangent against its outward normal, and state.
    fn push_joints(&mut self, model: &Model, dense: &[u32]) {
        let world = &model.world;
        let mut joints: Vec<(u64, Entity, Joint, JointState)> = world
            .query::<(Entity, &StableId, &Joint, &JointState)>()
            .iter()
            .map(|(e, id, j, s)| (id.0, e, *j, *s))
            .collect();
        joints.sort_unstable_by_key(|r| r.0);
        for (_, e, j, st) in joints {
            let [p, q] = j.edges.map(|x| world.get::<&EdgeNodes>(x).expect("edge").0);
            let nodes = [p[0], p[1], q[0], q[1]].map(|n| dense[n.id() as usize]);
            if nodes.contains(&NONE) {
                continue;
            }
            let [a, b] = p.map(|n| world.get::<&NodeRef>(n).expect("node").0);
            let t = [b[0] - a[0], b[1] - a[1]];
            let out = crate::fractures::outward_normal(model, j.edges[0]);
            let sign = if t[1] * out[0] - t[0] * out[1] >= 0.0 {
                1.0
            } else {
                -1.0
            };
            self.joint_entity.push(e);
            self.joint_nodes.push(nodes);
            self.joint_sign.push(sign);
            self.joint_state.push(st);
        }
    }

    /// Copy the hot state back into the components: displacement, velocity, the element
    /// stresses at the current displacements (computed here; the view's own `stress` lags by
    /// one step and is left alone), joint and edge state.
    pub fn write_back(&self, model: &mut Model, p: &SolidParams) {
        let mut view = model.world.view_mut::<&mut NodeState>();
        for (i, &e) in self.node_entity.iter().enumerate() {
            if let Some(s) = view.get_mut(e) {
                s.u = self.u[i];
                s.v = self.v[i];
            }
        }
        let mut view = model.world.view_mut::<&mut ElemStress>();
        for (k, &e) in self.elem_entity.iter().enumerate() {
            if let Some(s) = view.get_mut(e) {
                s.0 = self.current_stress(k, p);
            }
        }
        let mut view = model.world.view_mut::<&mut JointState>();
        for (k, &e) in self.joint_entity.iter().enumerate() {
            if let Some(s) = view.get_mut(e) {
                *s = self.joint_state[k];
            }
        }
        let mut view = model.world.view_mut::<&mut EdgeState>();
        for (k, &e) in self.edge_entity.iter().enumerate() {
            if let Some(s) = view.get_mut(e) {
                s.sigma_n = self.edge_sigma_n[k];
                s.fracture_ready = self.edge_ready[k];
            }
        }
    }

    /// Stress of element k at the current displacements, [sxx, syy, sxy], Pa.
    pub fn current_stress(&self, k: usize, p: &SolidParams) -> [f64; 3] {
        cst_stress(&self.geom[k], self.conn[k].map(|a| self.u[a as usize]), p)
    }

    /// Deformed position of node i, m.
    pub fn position(&self, i: usize) -> [f64; 2] {
        [self.x0[i][0] + self.u[i][0], self.x0[i][1] + self.u[i][1]]
    }
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

/// Face p's length of joint `k` in the reference positions x0, m: the length a fluid pressure
/// acts on (the rock's small-strain stresses are over the reference geometry too; over the
/// current length, an in-situ compression sigma_0 shortens the face by sigma_0 / E and the
/// pressure P loses P sigma_0 / E: 0.6 MPa of a 3 MPa net pressure under 120 MPa). Apart from
/// [`joint_frame`], which the contact kernel calls for every joint at every step.
#[inline]
pub fn joint_len0(v: &SolidView, k: usize) -> f64 {
    let [a, b] = [v.joint_nodes[k][0], v.joint_nodes[k][1]].map(|i| v.x0[i as usize]);
    (b[0] - a[0]).hypot(b[1] - a[1])
}

/// Midpoint of joint `k`'s face p in the reference positions x0, m (where the event catalogue
/// places a joint).
pub fn joint_mid0(v: &SolidView, k: usize) -> [f64; 2] {
    let [a, b] = [v.joint_nodes[k][0], v.joint_nodes[k][1]].map(|i| v.x0[i as usize]);
    [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]
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
