//! Fracture costs on the 20,000-element mesh (100 m x 100 m, h = 1 m): opening a 100-edge crack
//! by node splitting (per split node), rebuilding the dense view after it, and the whole solid
//! step with 1,000 joints in contact against the same mesh without fractures, and with the
//! event catalogue (`seismicity:`) on.
//!
//! Run: `cargo bench --bench fracture`.

#[macro_use]
mod common;

use common::ROCK;
use criterion::{BatchSize, Criterion};
use hydrofrac::mesh::TriMesh;
use hydrofrac::model::Model;
use hydrofrac::scenario::{Damping, End, FractureSpec, PreFracture};
use hydrofrac::sim::Simulation;
use hydrofrac::snap::{adjacency, snap_segment};
use hydrofrac::split::open_edges;
use hydrofrac::verify::solid_cases::seed_block;
use hydrofrac::view::SolidView;

fn crack_edges(model: &Model, mesh: &TriMesh) -> Vec<hecs::Entity> {
    use hydrofrac::components::{EdgeNodes, StableId};
    let path = snap_segment(mesh, &adjacency(mesh), [0.0, 50.0], [100.0, 50.0]).unwrap();
    let ids: Vec<u64> = path.nodes.iter().map(|&n| n as u64).collect();
    model
        .world
        .query::<(hecs::Entity, &EdgeNodes)>()
        .iter()
        .filter(|(_, en)| {
            let r = en.0.map(|n| model.world.get::<&StableId>(n).unwrap().0);
            ids.windows(2)
                .any(|p| (p[0] == r[0] && p[1] == r[1]) || (p[0] == r[1] && p[1] == r[0]))
        })
        .map(|(e, _)| e)
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("fracture");
    common::ten_samples(&mut g, 300, 3);
    let mesh = TriMesh::regular(100.0, 100.0, 1.0, [0.0, 0.0]).unwrap();
    // Split: a straight crack across the mesh, 100 edges, 101 nodes split.
    g.bench_function("open_100_edge_crack", |b| {
        b.iter_batched(
            || {
                let m = Model::from_mesh(&mesh, ROCK).unwrap();
                let e = crack_edges(&m, &mesh);
                (m, e)
            },
            |(mut m, e)| open_edges(&mut m, &e, 5e-4, 0.0),
            BatchSize::LargeInput,
        )
    });
    let mut cracked = Model::from_mesh(&mesh, ROCK).unwrap();
    let e = crack_edges(&cracked, &mesh);
    open_edges(&mut cracked, &e, 5e-4, 0.0);
    g.bench_function("view_rebuild_20k", |b| {
        b.iter(|| SolidView::build(&cracked))
    });
    // Step with and without 1,000 joints (10 horizontal fractures across the block, closed by
    // the in-situ compression).
    let mk = |fractures: bool, catalogue: bool| {
        let mut sc = seed_block(1.0, End::Time(1e9), Damping::Local(0.8));
        if catalogue {
            sc.seismicity = Some(Default::default());
        }
        if fractures {
            sc.fracture = Some(FractureSpec::joints(
                (1..=10)
                    .map(|k| PreFracture {
                        from: [0.0, 9.0 * k as f64],
                        to: [100.0, 9.0 * k as f64],
                    })
                    .collect(),
                30.0,
                5e-4,
                None,
            ));
        }
        Simulation::new(sc.validate().unwrap(), &[]).unwrap()
    };
    let pool = common::pool(1);
    for (name, with, catalogue) in [
        ("step_no_joints_1t", false, false),
        ("step_1000_joints_1t", true, false),
        ("step_1000_joints_catalogue_1t", true, true),
    ] {
        let mut sim = mk(with, catalogue);
        eprintln!("{name}: {} joints", sim.solid().joint_nodes.len());
        g.bench_function(name, |b| {
            pool.install(|| b.iter(|| sim.step_once().unwrap()))
        });
    }
    g.finish();
}

bench_main!(bench);
