//! Node splitting: the seed's conditions, mother/daughter links, cells between root mothers,
//! and topology invariants over random sequences of splits (regular and perturbed meshes): every
//! reference live, every solid edge with one or two elements consistent with them, every element
//! side covered by exactly one solid edge, no element inverted, mass and momentum of the solid
//! unchanged, the topology generation bumped once per batch.

use hecs::Entity;
use hydrofrac::components::*;
use hydrofrac::mesh::TriMesh;
use hydrofrac::model::Model;
use hydrofrac::scenario::Material;
use hydrofrac::snap::{adjacency, snap_segment};
use hydrofrac::split::{check_invariants, open_edges, root};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const ROCK: Material = Material {
    young: 20e9,
    poisson: 0.2,
    density: 2700.0,
};

/// Solid edges between consecutive path nodes (mesh node indices = node stable ids).
fn path_edges(model: &Model, nodes: &[u32]) -> Vec<Entity> {
    let w = &model.world;
    let by_id = |n: u32| -> Entity {
        w.query::<(Entity, &StableId, &NodeLink)>()
            .iter()
            .find(|(_, id, _)| id.0 == n as u64)
            .map(|(e, _, _)| e)
            .unwrap()
    };
    nodes
        .windows(2)
        .map(|p| {
            let (a, b) = (by_id(p[0]), by_id(p[1]));
            w.query::<(Entity, &EdgeNodes, &EdgeState)>()
                .iter()
                .find(|(_, en, st)| !st.opened && en.0.contains(&a) && en.0.contains(&b))
                .map(|(e, _, _)| e)
                .unwrap()
        })
        .collect()
}

fn totals(model: &Model) -> (f64, [f64; 2]) {
    let mut m = 0.0;
    let mut p = [0.0; 2];
    for (mass, st, link) in model
        .world
        .query::<(&NodeMass, &NodeState, &NodeLink)>()
        .iter()
    {
        if link.in_solid {
            m += mass.0;
            p[0] += mass.0 * st.v[0];
            p[1] += mass.0 * st.v[1];
        }
    }
    (m, p)
}

#[test]
fn interior_crack_splits_its_inner_nodes_only() {
    let mesh = TriMesh::regular(20.0, 20.0, 1.0, [0.0, 0.0]).unwrap();
    let mut model = Model::from_mesh(&mesh, ROCK).unwrap();
    let path = snap_segment(&mesh, &adjacency(&mesh), [2.0, 10.0], [12.0, 10.0]).unwrap();
    let edges = path_edges(&model, &path.nodes);
    let (m0, _) = totals(&model);
    let g0 = model.topology_generation;
    let r = open_edges(&mut model, &edges, 5e-4, 0.0);
    assert_eq!(model.topology_generation, g0 + 1);
    // 9 inner nodes split in two; the tips stay; every path edge is opened.
    assert_eq!((r.split_nodes, r.daughters, r.opened_edges), (9, 18, 10));
    check_invariants(&model).unwrap();
    assert!((totals(&model).0 - m0).abs() < 1e-9 * m0);
    // Cells chain through root mother nodes: consecutive cells share a node.
    let cells: Vec<[Entity; 2]> = r
        .cells
        .iter()
        .map(|&c| model.world.get::<&CellNodes>(c).unwrap().0)
        .collect();
    for w in cells.windows(2) {
        assert!(
            w[0].iter().any(|n| w[1].contains(n)),
            "cells do not connect"
        );
    }
    // Solid edges: 10 mother edges left, 20 daughter edges joined; external count grows by 20.
    let external = model
        .world
        .query::<(&EdgeElems, &EdgeState)>()
        .iter()
        .filter(|(e, s)| !s.opened && e.is_external())
        .count();
    assert_eq!(external, 80 + 20);
}

#[test]
fn crack_reaching_the_boundary_splits_the_boundary_node() {
    let mesh = TriMesh::regular(20.0, 20.0, 1.0, [0.0, 0.0]).unwrap();
    let mut model = Model::from_mesh(&mesh, ROCK).unwrap();
    let path = snap_segment(&mesh, &adjacency(&mesh), [0.0, 10.0], [8.0, 10.0]).unwrap();
    let edges = path_edges(&model, &path.nodes);
    let r = open_edges(&mut model, &edges, 5e-4, 0.0);
    // Condition 2 at (0, 10): one ready edge and two external edges.
    assert_eq!((r.split_nodes, r.opened_edges), (8, 8));
    check_invariants(&model).unwrap();
}

/// The seed's Fig. 5 case: a fracture crossing an earlier one. The crossing node was split by
/// the first fracture; its daughter splits again for the second, and the new cells attach to the
/// original mother node, so all four cells around the crossing meet there.
#[test]
fn crossing_fracture_connects_through_the_original_mother() {
    let mesh = TriMesh::regular(20.0, 20.0, 1.0, [0.0, 0.0]).unwrap();
    let adj = adjacency(&mesh);
    let mut model = Model::from_mesh(&mesh, ROCK).unwrap();
    let h = snap_segment(&mesh, &adj, [2.0, 10.0], [12.0, 10.0]).unwrap();
    let e = path_edges(&model, &h.nodes);
    open_edges(&mut model, &e, 5e-4, 0.0);
    let centre = model
        .world
        .query::<(Entity, &StableId)>()
        .iter()
        .find(|(_, id)| id.0 == 10 * 21 + 5)
        .map(|(e, _)| e)
        .unwrap();
    // The second fracture's edges now join daughters of the centre; find them by position.
    let vertical: Vec<Entity> = model
        .world
        .query::<(Entity, &EdgeNodes, &EdgeElems, &EdgeState)>()
        .iter()
        .filter(|(_, en, ee, st)| {
            let p = en.0.map(|n| model.world.get::<&NodeRef>(n).unwrap().0);
            !st.opened
                && !ee.is_external()
                && p[0][0] == 5.0
                && p[1][0] == 5.0
                && p.iter().all(|q| (q[1] - 10.0).abs() <= 3.0)
        })
        .map(|(e, _, _, _)| e)
        .collect();
    assert_eq!(vertical.len(), 6);
    let r = open_edges(&mut model, &vertical, 5e-4, 1.0);
    assert_eq!(r.opened_edges, 6);
    check_invariants(&model).unwrap();
    let at_centre = model
        .world
        .query::<&CellNodes>()
        .iter()
        .filter(|c| c.0.contains(&centre))
        .count();
    assert_eq!(
        at_centre, 4,
        "horizontal and vertical cells meet at the mother node"
    );
    // Daughters of daughters point at the root.
    for (link, x) in model.world.query::<(&NodeLink, &NodeRef)>().iter() {
        if x.0 == [5.0, 10.0] && link.in_solid {
            assert_eq!(link.mother, Some(centre));
        }
    }
    assert_eq!(root(&model.world, centre), centre);
}

/// Random crack walks on regular and perturbed meshes, several batches each; invariants, mass and
/// momentum after every batch.
#[test]
fn random_split_sequences_keep_the_invariants() {
    for (seed, perturbed) in [(1u64, false), (2, true), (3, false), (4, true)] {
        let mesh = if perturbed {
            TriMesh::perturbed(16.0, 12.0, 1.0, [0.0, 0.0], 0.25, seed).unwrap()
        } else {
            TriMesh::regular(16.0, 12.0, 1.0, [0.0, 0.0]).unwrap()
        };
        let adj = adjacency(&mesh);
        let mut model = Model::from_mesh(&mesh, ROCK).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        // Random velocities so momentum is a real check.
        for st in model.world.query_mut::<&mut NodeState>() {
            st.v = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
        }
        let (m0, p0) = totals(&model);
        let mut split_total = 0;
        for batch in 0..6 {
            let a = [rng.random_range(0.0..16.0), rng.random_range(0.0..12.0)];
            let b = [rng.random_range(0.0..16.0), rng.random_range(0.0..12.0)];
            let Some(path) = snap_segment(&mesh, &adj, a, b) else {
                continue;
            };
            // Ready edges: the still-closed solid edges between the path's current nodes.
            let ready: Vec<Entity> = {
                let w = &model.world;
                let ids: Vec<u64> = path.nodes.iter().map(|&n| n as u64).collect();
                w.query::<(Entity, &EdgeNodes, &EdgeElems, &EdgeState)>()
                    .iter()
                    .filter(|(_, en, ee, st)| {
                        if st.opened || ee.is_external() {
                            return false;
                        }
                        let r = en.0.map(|n| {
                            let root = w.get::<&NodeLink>(n).unwrap().mother.unwrap_or(n);
                            w.get::<&StableId>(root).unwrap().0
                        });
                        ids.windows(2).any(|p| {
                            (p[0] == r[0] && p[1] == r[1]) || (p[0] == r[1] && p[1] == r[0])
                        })
                    })
                    .map(|(e, _, _, _)| e)
                    .collect()
            };
            let g = model.topology_generation;
            let r = open_edges(&mut model, &ready, 5e-4, batch as f64);
            split_total += r.split_nodes;
            assert_eq!(model.topology_generation, g + 1);
            if let Err(e) = check_invariants(&model) {
                panic!("seed {seed} batch {batch}: {e}");
            }
            let (m, p) = totals(&model);
            assert!((m - m0).abs() < 1e-9 * m0, "mass changed");
            for d in 0..2 {
                assert!((p[d] - p0[d]).abs() < 1e-9 * m0, "momentum changed");
            }
        }
        assert!(
            split_total > 10,
            "seed {seed}: only {split_total} splits, the test exercises little"
        );
    }
}

/// The invariant check can fail: a corrupted model is reported.
#[test]
fn invariant_check_catches_corruption() {
    let mesh = TriMesh::regular(4.0, 4.0, 1.0, [0.0, 0.0]).unwrap();
    let model = Model::from_mesh(&mesh, ROCK).unwrap();
    check_invariants(&model).unwrap();
    let el = model
        .world
        .query::<(Entity, &ElemNodes)>()
        .iter()
        .next()
        .map(|(e, _)| e)
        .unwrap();
    let n = model.world.get::<&ElemNodes>(el).unwrap().0[0];
    model.world.get::<&mut NodeLink>(n).unwrap().in_solid = false;
    assert!(
        check_invariants(&model)
            .unwrap_err()
            .contains("outside the solid")
    );
    model.world.get::<&mut NodeLink>(n).unwrap().in_solid = true;
    // Swap two nodes of an element: inverted.
    {
        let mut en = model.world.get::<&mut ElemNodes>(el).unwrap();
        en.0.swap(1, 2);
    }
    assert!(check_invariants(&model).unwrap_err().contains("inverted"));
}
