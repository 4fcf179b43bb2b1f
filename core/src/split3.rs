//! Node splitting in 3D at run time: the seed's splitting condition on tetrahedra, applied to
//! the entities of a [`Model`] built by [`Model::from_tet_mesh`]. The run-time counterpart of
//! [`crate::tetmesh::TetMesh::split_along`] (which splits the mesh of a pre-existing fracture
//! before it becomes entities) and the 3D counterpart of [`crate::split::open_edges`]: all the
//! faces of a batch open together by entity creation and relinking, then the topology
//! generation is bumped once.
//!
//! - **Which nodes split.** At every node of a ready face, the tetrahedra around the node are
//!   grouped across the faces they share that stay closed (solid faces that are neither ready
//!   nor already a fracture face). A node whose tetrahedra fall into two or more groups splits:
//!   the group holding the tetrahedron of smallest stable id keeps the node (as `split_along`
//!   does), every other group gets a daughter (same reference position, state and prescribed
//!   values; the mother's mass and loads shared in proportion to the groups' volumes), linked
//!   to the node's root mother. A node on a fracture's front inside the rock keeps one group,
//!   so the fracture closes there; where it reaches the domain's surface it opens.
//! - **Which faces open.** A ready face whose two tetrahedra take different nodes at one of its
//!   corners opens: the face entity becomes face p (its first tetrahedron's side), a sister
//!   face q is spawned for the other tetrahedron, sister nodes in the same places, turned so
//!   that face p's (x1 - x0) x (x2 - x0) points out of p's tetrahedron (the convention of
//!   [`FaceJoint`] and `TetMesh::orient_sisters`). Each opened face gets a joint
//!   ([`FaceJoint`]) and a flow cell ([`FaceCell`]) of the given initial aperture, created at
//!   the given time, empty. A ready face that no split separates waits, as in 2D. A
//!   pre-existing fracture's face whose three nodes all lay on its front (`split_along` gives
//!   it a joint on the one face, closed) keeps its joint and cell when it opens: the joint
//!   takes the new sister.
//!
//! Deterministic: candidates, groups, daughters and opened faces follow stable ids.

use crate::dim::tet_geometry;
use crate::model::Model;
use crate::model3::{NodeBc3, NodeRef3, NodeState3, TetNodes};
use crate::split::{SplitReport, root, stable};
use crate::union_find::UnionFind;
use hecs::Entity;
use hydrofrac_components::*;
use std::collections::{BTreeMap, BTreeSet, HashMap};

/// The tetrahedra of a face, `[Some, Some]` when internal.
fn face_tets(world: &hecs::World, f: Entity) -> [Option<Entity>; 2] {
    world.get::<&EdgeElems>(f).expect("face").0
}

/// A split node: its tetrahedra's groups (tetrahedron -> group, group 0 keeps the node) and
/// its nodes per group (the node itself for group 0, daughters after).
struct SplitNode {
    group_of: BTreeMap<Entity, usize>,
    nodes: Vec<Entity>,
}

/// The node that tetrahedron `t` uses in place of `n`.
fn node_for(split: &HashMap<Entity, SplitNode>, n: Entity, t: Entity) -> Entity {
    match split.get(&n) {
        Some(s) => s.nodes[s.group_of[&t]],
        None => n,
    }
}

/// Open the given internal faces of a 3D model by node splitting (module docs). `aperture` is
/// the new cells' initial hydraulic aperture (m), `t` the time they are created (s). Faces that
/// are not internal solid faces are ignored. The report lists the split nodes with their
/// nodes after the split (the kept node first) and their shares of its mass and loads.
pub fn open_faces(model: &mut Model, ready: &[Entity], aperture: f64, t: f64) -> SplitReport {
    let world = &model.world;
    let ready: BTreeSet<(u64, Entity)> = ready
        .iter()
        .filter(|&&f| {
            world.get::<&FaceNodes>(f).is_ok()
                && matches!(
                    world.get::<&EdgeElems>(f).map(|e| e.0),
                    Ok([Some(_), Some(_)])
                )
        })
        .map(|&f| (stable(world, f), f))
        .collect();
    if ready.is_empty() {
        return SplitReport::default();
    }
    let is_ready: BTreeSet<Entity> = ready.iter().map(|r| r.1).collect();
    // The solid faces around every node of a ready face.
    let candidates: BTreeMap<u64, Entity> = ready
        .iter()
        .flat_map(|&(_, f)| world.get::<&FaceNodes>(f).expect("face").0)
        .map(|n| (stable(world, n), n))
        .collect();
    let wanted: BTreeSet<Entity> = candidates.values().copied().collect();
    let mut node_faces: HashMap<Entity, Vec<(u64, Entity)>> = HashMap::new();
    for (f, id, fnodes) in world.query::<(Entity, &StableId, &FaceNodes)>().iter() {
        for n in fnodes.0 {
            if wanted.contains(&n) {
                node_faces.entry(n).or_default().push((id.0, f));
            }
        }
    }
    for faces in node_faces.values_mut() {
        faces.sort_unstable();
    }
    // Groups at every candidate node.
    let mut groups: Vec<(Entity, BTreeMap<Entity, usize>, usize)> = Vec::new();
    for &n in candidates.values() {
        let (group_of, count) = tet_groups(world, &node_faces[&n], &is_ready);
        if count >= 2 {
            groups.push((n, group_of, count));
        }
    }
    if groups.is_empty() {
        return SplitReport::default();
    }
    let mut report = SplitReport::default();
    let split = spawn_daughters(model, groups, &mut report);
    // Relink the tetrahedra at split nodes.
    let touched: BTreeSet<Entity> = split
        .values()
        .flat_map(|s| s.group_of.keys().copied())
        .collect();
    for &el in &touched {
        let nodes = model.world.get::<&TetNodes>(el).expect("tetrahedron").0;
        let new = nodes.map(|n| node_for(&split, n, el));
        model.world.get::<&mut TetNodes>(el).expect("tetrahedron").0 = new;
    }
    // Relink the faces at split nodes; collect the ready faces a split separates.
    let faces_at: BTreeSet<(u64, Entity)> = split
        .keys()
        .flat_map(|n| node_faces[n].iter().copied())
        .collect();
    let mut opened = Vec::new();
    for &(_, f) in &faces_at {
        let nodes = model.world.get::<&FaceNodes>(f).expect("face").0;
        let [a, b] = face_tets(&model.world, f);
        let a = a.expect("a face has a tetrahedron");
        if is_ready.contains(&f) {
            let b = b.expect("ready faces are internal");
            if nodes
                .iter()
                .any(|&n| node_for(&split, n, a) != node_for(&split, n, b))
            {
                opened.push(f);
                continue;
            }
        }
        let new = nodes.map(|n| node_for(&split, n, a));
        model.world.get::<&mut FaceNodes>(f).expect("face").0 = new;
    }
    // A pre-existing fracture's face whose nodes all lay on its front has a joint on that one
    // face (and a flow cell in coupled runs): opened now, the joint takes the new sister.
    let closed_joint: HashMap<Entity, Entity> = model
        .world
        .query::<(Entity, &FaceJoint)>()
        .iter()
        .filter(|(_, j)| j.faces[0] == j.faces[1])
        .map(|(e, j)| (j.faces[0], e))
        .collect();
    // `faces_at` is in stable-id order, so `opened` is too.
    for f in opened {
        let joint = closed_joint.get(&f).copied();
        open_face(model, &split, f, (aperture, t), joint, &mut report);
    }
    model.topology_generation += 1;
    report
}

/// The tetrahedra around a node (its solid `faces`) grouped across the faces that stay closed:
/// tetrahedron -> group index (numbered in order of the smallest tetrahedron stable id), and
/// the number of groups.
fn tet_groups(
    world: &hecs::World,
    faces: &[(u64, Entity)],
    is_ready: &BTreeSet<Entity>,
) -> (BTreeMap<Entity, usize>, usize) {
    let mut tets: Vec<(u64, Entity)> = faces
        .iter()
        .flat_map(|&(_, f)| face_tets(world, f).into_iter().flatten())
        .map(|t| (stable(world, t), t))
        .collect();
    tets.sort_unstable();
    tets.dedup();
    let index: HashMap<Entity, usize> = tets.iter().enumerate().map(|(i, t)| (t.1, i)).collect();
    let mut sets = UnionFind::new(tets.len());
    for &(_, f) in faces {
        if is_ready.contains(&f) {
            continue;
        }
        if let [Some(a), Some(b)] = face_tets(world, f) {
            sets.union(index[&a], index[&b]);
        }
    }
    let mut number: HashMap<usize, usize> = HashMap::new();
    let mut group_of = BTreeMap::new();
    for (i, &(_, t)) in tets.iter().enumerate() {
        let r = sets.find(i);
        let next = number.len();
        group_of.insert(t, *number.entry(r).or_insert(next));
    }
    (group_of, number.len())
}

/// Shares the mother's mass and loads among its groups in proportion to their volumes (group
/// 0 keeps the node), and spawns a daughter for every further group.
fn spawn_daughters(
    model: &mut Model,
    groups: Vec<(Entity, BTreeMap<Entity, usize>, usize)>,
    report: &mut SplitReport,
) -> HashMap<Entity, SplitNode> {
    let mut split = HashMap::new();
    for (n, group_of, count) in groups {
        let mut volume = vec![0.0; count];
        for (&el, &g) in &group_of {
            volume[g] += tet_geometry(&model.world.get::<&TetGeom>(el).expect("tet").0).volume;
        }
        let total: f64 = volume.iter().sum();
        let shares: Vec<f64> = volume.iter().map(|v| v / total).collect();
        let (x, state, bc, mass) = {
            let w = &model.world;
            (
                *w.get::<&NodeRef3>(n).expect("node"),
                *w.get::<&NodeState3>(n).expect("node"),
                *w.get::<&NodeBc3>(n).expect("node"),
                w.get::<&NodeMass>(n).expect("node").0,
            )
        };
        let share_bc = |s: f64| NodeBc3 {
            prescribed: bc.prescribed,
            load: bc.load.map(|l| l * s),
        };
        let mother = root(&model.world, n);
        let mut nodes = vec![n];
        for &s in &shares[1..] {
            let id = model.next_node_id;
            model.next_node_id += 1;
            let bundle: Node3Bundle = (
                StableId(id),
                x,
                state,
                NodeMass(mass * s),
                share_bc(s),
                NodeLink {
                    in_solid: true,
                    mother: Some(mother),
                },
            );
            nodes.push(model.world.spawn(bundle));
        }
        model.world.get::<&mut NodeMass>(n).expect("node").0 = mass * shares[0];
        *model.world.get::<&mut NodeBc3>(n).expect("node") = share_bc(shares[0]);
        report.split_nodes += 1;
        report.daughters += count - 1;
        report
            .daughters_of
            .push((n, nodes.iter().copied().zip(shares).collect()));
        split.insert(n, SplitNode { group_of, nodes });
    }
    split
}

/// Opens the ready face `f`: it becomes face p (its first tetrahedron's side), a sister face q
/// is spawned for the second, both turned so that p's normal points towards q; then the joint
/// of the pair and its flow cell, or, where `f` already had a closed joint (`joint`), that
/// joint takes the pair (its cell stays).
fn open_face(
    model: &mut Model,
    split: &HashMap<Entity, SplitNode>,
    f: Entity,
    (aperture, t): (f64, f64),
    joint: Option<Entity>,
    report: &mut SplitReport,
) {
    let nodes = model.world.get::<&FaceNodes>(f).expect("face").0;
    let [Some(tp), Some(tq)] = face_tets(&model.world, f) else {
        unreachable!("ready faces are internal")
    };
    let mut p = nodes.map(|n| node_for(split, n, tp));
    let mut q = nodes.map(|n| node_for(split, n, tq));
    // (x1 - x0) x (x2 - x0) must point away from p's fourth node.
    let tet = model.world.get::<&TetNodes>(tp).expect("tetrahedron").0;
    let opp = *tet
        .iter()
        .find(|n| !p.contains(n))
        .expect("a tetrahedron has a node off each face");
    let pos = |n: Entity| model.world.get::<&NodeRef3>(n).expect("node").0;
    let x = p.map(pos);
    if crate::tet4::signed_volume(x[0], x[1], x[2], pos(opp)) > 0.0 {
        p.swap(1, 2);
        q.swap(1, 2);
    }
    {
        let w = &mut model.world;
        w.get::<&mut FaceNodes>(f).expect("face").0 = p;
        w.get::<&mut EdgeElems>(f).expect("face").0 = [Some(tp), None];
        w.get::<&mut EdgeState>(f).expect("face").fracture_ready = true;
    }
    let id = model.next_edge_id;
    model.next_edge_id += 1;
    let sister: FaceBundle = (
        StableId(id),
        FaceNodes(q),
        EdgeElems([Some(tq), None]),
        EdgeState {
            fracture_ready: true,
            ..Default::default()
        },
    );
    let fq = model.world.spawn(sister);
    report.opened_edges += 1;
    if let Some(je) = joint {
        model.world.get::<&mut FaceJoint>(je).expect("joint").faces = [f, fq];
        return;
    }
    let jid = model.next_joint_id;
    model.next_joint_id += 1;
    let joint: FaceJointBundle = (
        StableId(jid),
        FaceJoint { faces: [f, fq] },
        JointState::default(),
    );
    let je = model.world.spawn(joint);
    let cid = model.next_cell_id;
    model.next_cell_id += 1;
    let (fluid, origin) = crate::split::new_cell_state(aperture, t);
    let cell: FaceCellBundle = (StableId(cid), FaceCell(je), fluid, origin);
    report.cells.push(model.world.spawn(cell));
    report.joints.push(je);
}

/// Topology invariants of a 3D model; returns the first violation found:
/// - every tetrahedron uses four distinct live in-solid nodes and has a positive reference
///   volume;
/// - every solid face lists one or two tetrahedra, each of which has the face's three nodes;
/// - every side of every tetrahedron is exactly one solid face;
/// - every joint's two faces have one tetrahedron each and sister nodes at the same reference
///   places, face p's normal pointing out of its tetrahedron (except a pre-existing fracture's
///   face with all three nodes on its front, one face entity on both sides of its joint);
/// - every node's mother link names a root (a node without a mother).
pub fn check_invariants_3d(model: &Model) -> Result<(), String> {
    let w = &model.world;
    let in_solid = |n: Entity| w.get::<&NodeLink>(n).map(|l| l.in_solid).unwrap_or(false);
    let pos = |n: Entity| w.get::<&NodeRef3>(n).map(|x| x.0);
    let mut sides: BTreeMap<[Entity; 3], usize> = BTreeMap::new();
    for (id, tn) in w.query::<(&StableId, &TetNodes)>().iter() {
        let nodes = tn.0;
        if nodes.iter().any(|&n| !w.contains(n) || !in_solid(n)) {
            return Err(format!(
                "tetrahedron {} uses a node outside the solid",
                id.0
            ));
        }
        let x: Vec<[f64; 3]> = nodes.iter().map(|&n| pos(n).expect("node")).collect();
        if crate::tet4::signed_volume(x[0], x[1], x[2], x[3]) <= 0.0 {
            return Err(format!("tetrahedron {} is not positive", id.0));
        }
        for k in crate::tet4::sorted_sides(nodes) {
            sides.insert(k, 0);
        }
    }
    for (id, fnodes, tets) in w.query::<(&StableId, &FaceNodes, &EdgeElems)>().iter() {
        let mut k = fnodes.0;
        k.sort_unstable();
        match sides.get_mut(&k) {
            Some(c) => *c += 1,
            None => return Err(format!("face {} is no tetrahedron's side", id.0)),
        }
        if tets.0[0].is_none() {
            return Err(format!("face {} lists no tetrahedron", id.0));
        }
        for t in tets.0.into_iter().flatten() {
            let tn = w
                .get::<&TetNodes>(t)
                .map_err(|_| format!("face {}", id.0))?
                .0;
            if !fnodes.0.iter().all(|n| tn.contains(n)) {
                return Err(format!("face {} is not a side of its tetrahedron", id.0));
            }
        }
    }
    if let Some((k, _)) = sides.iter().find(|(_, c)| **c != 1) {
        let ids: Vec<u64> = k.iter().map(|&n| stable(w, n)).collect();
        return Err(format!(
            "the tetrahedron side on nodes {ids:?} is {} solid faces",
            sides[k]
        ));
    }
    for (id, j) in w.query::<(&StableId, &FaceJoint)>().iter() {
        if j.faces[0] == j.faces[1] {
            // A pre-existing fracture's face whose three nodes all lie on its front: one
            // face entity on both sides, a joint that stays closed.
            continue;
        }
        let f = j.faces.map(|f| w.get::<&FaceNodes>(f).expect("face").0);
        let t = j.faces.map(|f| face_tets(w, f));
        if t.iter().any(|t| t[0].is_none() || t[1].is_some()) {
            return Err(format!(
                "joint {}: a face with other than one tetrahedron",
                id.0
            ));
        }
        for a in 0..3 {
            if pos(f[0][a]).ok() != pos(f[1][a]).ok() {
                return Err(format!("joint {}: sister nodes {a} apart", id.0));
            }
        }
        let tp = w.get::<&TetNodes>(t[0][0].expect("tet")).expect("tet").0;
        let opp = *tp.iter().find(|n| !f[0].contains(n)).expect("fourth node");
        let x = f[0].map(|n| pos(n).expect("node"));
        if crate::tet4::signed_volume(x[0], x[1], x[2], pos(opp).expect("node")) > 0.0 {
            return Err(format!(
                "joint {}: face p turned towards its tetrahedron",
                id.0
            ));
        }
    }
    for (id, l) in w.query::<(&StableId, &NodeLink)>().iter() {
        if let Some(m) = l.mother
            && w.get::<&NodeLink>(m)
                .map(|ml| ml.mother.is_some())
                .unwrap_or(true)
        {
            return Err(format!("node {}'s mother is not a root", id.0));
        }
    }
    Ok(())
}
