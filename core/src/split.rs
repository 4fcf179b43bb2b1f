//! Adaptive remeshing by node splitting (the seed's "Adaptive Remeshing", Fig. 5): the only
//! place where topology changes. All splits of a batch are applied together by entity creation
//! and relinking, then the topology generation is bumped once.
//!
//! A node is split when two of its edges are fracture-ready, or one is and two are external
//! (seed conditions 1 and 2). The elements around it fall into groups separated by the cut
//! edges (ready edges and edges that are already external); each group gets a daughter node
//! (same reference position and state, the lumped mass of its elements) and the mother node
//! leaves the solid. Each ready edge separated at one or both ends becomes a mother edge: it
//! leaves the solid, its two elements get one daughter edge each (the sister edges of a joint),
//! and a flow cell is created between the root mother nodes of its ends, so that cells of
//! intersecting fractures meet at the original mother node (the seed's node 5 / node 12 case).

use crate::model::Model;
use crate::union_find::UnionFind;
use hecs::Entity;
use hydrofrac_components::*;
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// What a batch of splits did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SplitReport {
    /// Nodes split (mothers) and daughters created.
    pub split_nodes: usize,
    pub daughters: usize,
    /// Mother edges opened, and the flow cells and joints made from them.
    pub opened_edges: usize,
    pub cells: Vec<Entity>,
    pub joints: Vec<Entity>,
    /// Each split node (mother) and its daughters with their share of its mass (and loads),
    /// in the mothers' stable order.
    pub daughters_of: Vec<(Entity, Vec<(Entity, f64)>)>,
}

pub(crate) fn stable(world: &hecs::World, e: Entity) -> u64 {
    world.get::<&StableId>(e).map(|s| s.0).unwrap_or(u64::MAX)
}

/// The root mother of a node: its mother if it is a daughter, else itself.
pub fn root(world: &hecs::World, n: Entity) -> Entity {
    world
        .get::<&NodeLink>(n)
        .ok()
        .and_then(|l| l.mother)
        .unwrap_or(n)
}

/// The split nodes by stable id: (node, element -> group index, number of groups).
type NodeGroups = BTreeMap<u64, (Entity, BTreeMap<Entity, usize>, usize)>;

/// The daughters of the split nodes and, per split node, the group of each of its elements.
struct Daughters<'a> {
    of: HashMap<Entity, Vec<Entity>>,
    group_of: HashMap<Entity, &'a BTreeMap<Entity, usize>>,
}

impl Daughters<'_> {
    /// The node that element `el` uses in place of `n`: the daughter of its group where `n` was
    /// split, else `n`.
    fn daughter_of(&self, n: Entity, el: Entity) -> Entity {
        match self.group_of.get(&n) {
            Some(of_elem) => self.of[&n][of_elem[&el]],
            None => n,
        }
    }
}

/// The edges of `ready` that are internal solid edges not yet opened, by stable id.
fn ready_edges(world: &hecs::World, ready: &[Entity]) -> BTreeSet<(u64, Entity)> {
    ready
        .iter()
        .filter(|&&e| {
            let st = world.get::<&EdgeState>(e);
            let el = world.get::<&EdgeElems>(e);
            matches!((st, el), (Ok(s), Ok(l)) if !s.opened && !l.is_external())
        })
        .map(|&e| (stable(world, e), e))
        .collect()
}

/// The solid (not opened) edges around every node.
fn solid_edges_at_nodes(world: &hecs::World) -> HashMap<Entity, Vec<Entity>> {
    let mut node_edges: HashMap<Entity, Vec<Entity>> = HashMap::new();
    for (e, en, st) in world.query::<(Entity, &EdgeNodes, &EdgeState)>().iter() {
        if !st.opened {
            for n in en.0 {
                node_edges.entry(n).or_default().push(e);
            }
        }
    }
    node_edges
}

/// The nodes of the ready edges that split (two ready edges, or one and two external), each
/// with the groups of its elements.
fn split_groups(
    world: &hecs::World,
    ready: &BTreeSet<(u64, Entity)>,
    is_ready: &HashMap<Entity, ()>,
    node_edges: &HashMap<Entity, Vec<Entity>>,
) -> NodeGroups {
    // Candidate nodes in stable order and the conditions.
    let candidates: BTreeMap<u64, Entity> = ready
        .iter()
        .flat_map(|&(_, e)| world.get::<&EdgeNodes>(e).expect("edge").0)
        .map(|n| (stable(world, n), n))
        .collect();
    let mut groups = NodeGroups::new();
    for (&nid, &n) in &candidates {
        let edges = &node_edges[&n];
        let r = edges.iter().filter(|e| is_ready.contains_key(e)).count();
        let x = edges
            .iter()
            .filter(|&&e| world.get::<&EdgeElems>(e).expect("edge").is_external())
            .count();
        if !(r >= 2 || (r >= 1 && x >= 2)) {
            continue;
        }
        let (of_elem, count) = element_groups(world, edges, is_ready);
        if count >= 2 {
            groups.insert(nid, (n, of_elem, count));
        }
    }
    groups
}

/// The elements around a node (its solid `edges`) grouped across the edges that stay closed:
/// element -> group index (numbered in order of the smallest element stable id), and the
/// number of groups.
fn element_groups(
    world: &hecs::World,
    edges: &[Entity],
    is_ready: &HashMap<Entity, ()>,
) -> (BTreeMap<Entity, usize>, usize) {
    // Union the elements around n across edges that stay closed.
    let mut elems: Vec<Entity> = Vec::new();
    for &e in edges {
        for el in world
            .get::<&EdgeElems>(e)
            .expect("edge")
            .0
            .into_iter()
            .flatten()
        {
            if !elems.contains(&el) {
                elems.push(el);
            }
        }
    }
    elems.sort_by_key(|&el| stable(world, el));
    let mut sets = UnionFind::new(elems.len());
    for &e in edges {
        if is_ready.contains_key(&e) {
            continue;
        }
        if let [Some(a), Some(b)] = world.get::<&EdgeElems>(e).expect("edge").0 {
            let ia = elems.iter().position(|&x| x == a).expect("element at node");
            let ib = elems.iter().position(|&x| x == b).expect("element at node");
            sets.union(ia, ib);
        }
    }
    // Group numbers in order of the smallest element stable id. `of_elem` is ordered so
    // that the daughters' masses below are summed in the same order in every process (a
    // HashMap's iteration order changes from run to run, and so would the masses' last
    // bits on a mesh of unequal elements).
    let mut number: HashMap<usize, usize> = HashMap::new();
    let mut of_elem = BTreeMap::new();
    for (i, &el) in elems.iter().enumerate() {
        let r = sets.find(i);
        let next = number.len();
        let g = *number.entry(r).or_insert(next);
        of_elem.insert(el, g);
    }
    (of_elem, number.len())
}

/// Spawns the daughters of every split node (same reference position, state and boundary
/// condition, the lumped mass `rho A / 3` of its group's elements in kg per metre, the loads
/// shared in proportion to mass) and takes the mother out of the solid.
fn spawn_daughters(
    model: &mut Model,
    groups: &NodeGroups,
    report: &mut SplitReport,
) -> HashMap<Entity, Vec<Entity>> {
    let rho = model.material.density;
    let mut daughters: HashMap<Entity, Vec<Entity>> = HashMap::new();
    for (n, of_elem, ng) in groups.values() {
        let (x, state, bc, link) = {
            let w = &model.world;
            (
                *w.get::<&NodeRef>(*n).expect("node"),
                *w.get::<&NodeState>(*n).expect("node"),
                *w.get::<&NodeBc>(*n).expect("node"),
                *w.get::<&NodeLink>(*n).expect("node"),
            )
        };
        let mother_mass = model.world.get::<&NodeMass>(*n).expect("node").0;
        let mut mass = vec![0.0; *ng];
        for (&el, &g) in of_elem {
            mass[g] += rho * model.world.get::<&ElemGeom>(el).expect("element").area / 3.0;
        }
        let mother = link.mother.unwrap_or(*n);
        let mut ds = Vec::with_capacity(*ng);
        let mut shares = Vec::with_capacity(*ng);
        for &m in &mass {
            let id = model.next_node_id;
            model.next_node_id += 1;
            // External loads (tractions, body forces) are shared in proportion to mass.
            let share = if mother_mass > 0.0 {
                m / mother_mass
            } else {
                0.0
            };
            let bundle: NodeBundle = (
                StableId(id),
                x,
                state,
                NodeMass(m),
                NodeBc {
                    prescribed: bc.prescribed,
                    load: [bc.load[0] * share, bc.load[1] * share],
                },
                NodeLink {
                    in_solid: true,
                    mother: Some(mother),
                },
            );
            ds.push(model.world.spawn(bundle));
            shares.push(share);
        }
        model.world.get::<&mut NodeLink>(*n).expect("node").in_solid = false;
        report.split_nodes += 1;
        report.daughters += ds.len();
        report
            .daughters_of
            .push((*n, ds.iter().copied().zip(shares).collect()));
        daughters.insert(*n, ds);
    }
    daughters
}

/// Relinks every element at a split node to the daughter of its group.
fn relink_elements(model: &mut Model, split: &Daughters) {
    let elems_at: Vec<(Entity, [Entity; 3])> = model
        .world
        .query::<(Entity, &ElemNodes)>()
        .iter()
        .filter(|(_, en)| en.0.iter().any(|n| split.of.contains_key(n)))
        .map(|(e, en)| (e, en.0))
        .collect();
    for (el, nodes) in elems_at {
        let new = nodes.map(|n| split.daughter_of(n, el));
        model.world.get::<&mut ElemNodes>(el).expect("element").0 = new;
    }
}

/// Relinks the split ends of the edges at split nodes that stay closed or were already
/// external; returns the ready edges that a split end separates (to open), unsorted.
fn relink_edges(
    model: &mut Model,
    split: &Daughters,
    node_edges: &HashMap<Entity, Vec<Entity>>,
    is_ready: &HashMap<Entity, ()>,
) -> Vec<Entity> {
    let mut opened: Vec<Entity> = Vec::new();
    let touched: BTreeSet<(u64, Entity)> = split
        .of
        .keys()
        .flat_map(|n| node_edges[n].iter().copied())
        .map(|e| (stable(&model.world, e), e))
        .collect();
    for &(_, e) in &touched {
        let (en, ee) = {
            let w = &model.world;
            (
                w.get::<&EdgeNodes>(e).expect("edge").0,
                w.get::<&EdgeElems>(e).expect("edge").0,
            )
        };
        if is_ready.contains_key(&e) {
            let [Some(a), Some(b)] = ee else { continue };
            // Opened where some split end separates the two elements.
            if en.iter().any(|&n| {
                split.of.contains_key(&n) && split.daughter_of(n, a) != split.daughter_of(n, b)
            }) {
                opened.push(e);
            } else {
                let new = en.map(|n| split.daughter_of(n, a));
                model.world.get::<&mut EdgeNodes>(e).expect("edge").0 = new;
            }
            continue;
        }
        let el = ee[0].expect("edge has an element");
        let new = en.map(|n| split.daughter_of(n, el));
        model.world.get::<&mut EdgeNodes>(e).expect("edge").0 = new;
    }
    opened
}

/// Opens the mother edge `e`: one daughter edge per element (the sisters), the edge out of the
/// solid, a flow cell of initial aperture `aperture` (m) created at `t` (s) between the root
/// mothers of its ends, and the joint of the three.
fn open_mother_edge(
    model: &mut Model,
    split: &Daughters,
    e: Entity,
    (aperture, t): (f64, f64),
    report: &mut SplitReport,
) {
    let (en, ee) = {
        let w = &model.world;
        (
            w.get::<&EdgeNodes>(e).expect("edge").0,
            w.get::<&EdgeElems>(e).expect("edge").0,
        )
    };
    let mut sisters = [e; 2];
    for (s, el) in ee.into_iter().enumerate() {
        let el = el.expect("internal edge");
        let id = model.next_edge_id;
        model.next_edge_id += 1;
        let bundle: EdgeBundle = (
            StableId(id),
            EdgeNodes(en.map(|n| split.daughter_of(n, el))),
            EdgeElems([Some(el), None]),
            EdgeState::default(),
        );
        sisters[s] = model.world.spawn(bundle);
    }
    {
        let mut st = model.world.get::<&mut EdgeState>(e).expect("edge");
        st.opened = true;
        st.fracture_ready = true;
    }
    let ends = en.map(|n| root(&model.world, n));
    let cid = model.next_cell_id;
    model.next_cell_id += 1;
    let (fluid, origin) = new_cell_state(aperture, t);
    let cell_bundle: CellBundle = (StableId(cid), CellNodes(ends), fluid, origin);
    let cell = model.world.spawn(cell_bundle);
    let jid = model.next_joint_id;
    model.next_joint_id += 1;
    let joint_bundle: JointBundle = (
        StableId(jid),
        Joint {
            edges: sisters,
            mother_edge: e,
            cell,
        },
        JointState::default(),
    );
    report.joints.push(model.world.spawn(joint_bundle));
    report.cells.push(cell);
    report.opened_edges += 1;
}

/// The fluid state and origin of a flow cell a split creates at time `t` (s): empty, of
/// hydraulic aperture `aperture` (m); the same in 2D and 3D.
pub fn new_cell_state(aperture: f64, t: f64) -> (CellFluid, CellOrigin) {
    (
        CellFluid {
            aperture,
            ..Default::default()
        },
        CellOrigin {
            kind: CellKind::New,
            created_t: t,
        },
    )
}

/// Open the given internal solid edges by node splitting. `aperture` is the initial hydraulic
/// aperture of the new cells (m), `t` the time they are created (s). Edges that are not internal
/// solid edges are ignored; edges that no split separates stay as they are (a ready edge with
/// both ends interior waits until the fracture reaches it).
pub fn open_edges(model: &mut Model, ready: &[Entity], aperture: f64, t: f64) -> SplitReport {
    let world = &model.world;
    // Solid edges around every node, and the ready set.
    let ready = ready_edges(world, ready);
    if ready.is_empty() {
        return SplitReport::default();
    }
    let is_ready: HashMap<Entity, ()> = ready.iter().map(|&(_, e)| (e, ())).collect();
    let node_edges = solid_edges_at_nodes(world);
    let groups = split_groups(world, &ready, &is_ready, &node_edges);
    if groups.is_empty() {
        return SplitReport::default();
    }
    let mut report = SplitReport::default();
    let of = spawn_daughters(model, &groups, &mut report);
    let split = Daughters {
        of,
        group_of: groups.values().map(|(n, g, _)| (*n, g)).collect(),
    };
    relink_elements(model, &split);
    let mut opened = relink_edges(model, &split, &node_edges, &is_ready);
    // Opened mother edges: two daughter edges, a flow cell between root mothers, a joint.
    opened.sort_by_key(|&e| stable(&model.world, e));
    for e in opened {
        open_mother_edge(model, &split, e, (aperture, t), &mut report);
    }
    model.topology_generation += 1;
    report
}

/// Topology invariants of the solid and the network; returns the first violation found.
/// - every entity reference is live;
/// - every element has positive area and three in-solid nodes;
/// - every solid edge joins two in-solid nodes, lists one element (external) or two (internal),
///   and each listed element has both edge nodes;
/// - every element side is exactly one solid edge;
/// - every flow cell's nodes are root mothers (no mother link).
pub fn check_invariants(model: &Model) -> Result<(), String> {
    let w = &model.world;
    let live = |e: Entity| w.contains(e);
    let in_solid = |n: Entity| w.get::<&NodeLink>(n).map(|l| l.in_solid).unwrap_or(false);
    let mut sides: BTreeMap<(Entity, Entity), usize> = BTreeMap::new();
    for (el, en) in w.query::<(Entity, &ElemNodes)>().iter() {
        for &n in &en.0 {
            if !live(n) || !in_solid(n) {
                return Err(format!(
                    "element {} uses a node outside the solid",
                    stable(w, el)
                ));
            }
        }
        let p = en.0.map(|n| w.get::<&NodeRef>(n).expect("node").0);
        if crate::mesh::signed_area(p[0], p[1], p[2]) <= 0.0 {
            return Err(format!("element {} is inverted", stable(w, el)));
        }
        for k in 0..3 {
            let (a, b) = (en.0[k], en.0[(k + 1) % 3]);
            let key = if a.id() < b.id() { (a, b) } else { (b, a) };
            *sides.entry(key).or_default() += 0;
        }
    }
    for (e, en, ee, st) in w
        .query::<(Entity, &EdgeNodes, &EdgeElems, &EdgeState)>()
        .iter()
    {
        if st.opened {
            continue;
        }
        let id = stable(w, e);
        for &n in &en.0 {
            if !live(n) || !in_solid(n) {
                return Err(format!("solid edge {id} uses a node outside the solid"));
            }
        }
        let n_el = ee.0.iter().flatten().count();
        if ee.0[0].is_none() || n_el == 0 {
            return Err(format!("solid edge {id} has no first element"));
        }
        for el in ee.0.iter().flatten() {
            let nodes = w
                .get::<&ElemNodes>(*el)
                .map_err(|_| format!("solid edge {id} lists a dead element"))?
                .0;
            if !en.0.iter().all(|n| nodes.contains(n)) {
                return Err(format!(
                    "solid edge {id} lists element {} that does not have its nodes",
                    stable(w, *el)
                ));
            }
        }
        let (a, b) = (en.0[0], en.0[1]);
        let key = if a.id() < b.id() { (a, b) } else { (b, a) };
        match sides.get_mut(&key) {
            Some(c) => *c += 1,
            None => return Err(format!("solid edge {id} is not a side of any element")),
        }
    }
    if let Some(((a, b), c)) = sides.iter().find(|(_, c)| **c != 1) {
        return Err(format!(
            "element side ({}, {}) is covered by {c} solid edges",
            stable(w, *a),
            stable(w, *b)
        ));
    }
    for (c, cn) in w.query::<(Entity, &CellNodes)>().iter() {
        for &n in &cn.0 {
            if !live(n) {
                return Err(format!("cell {} uses a dead node", stable(w, c)));
            }
            if w.get::<&NodeLink>(n)
                .map(|l| l.mother.is_some())
                .unwrap_or(true)
            {
                return Err(format!(
                    "cell {} attaches to a daughter node, not a root mother",
                    stable(w, c)
                ));
            }
        }
    }
    Ok(())
}
