//! The flat-array reference kernel used by the benchmark computes the same physics as the ECS
//! systems: after 200 steps of the in-situ problem both give identical bits.

use hydrofrac::mesh::TriMesh;
use hydrofrac::reference::FlatSolid;
use hydrofrac::scenario::{Boundary, Damping, End, Material, MeshSpec};
use hydrofrac::sim::Simulation;
use hydrofrac::verify::solid_cases::scenario;

#[test]
fn reference_kernel_matches_the_engine_bit_for_bit() {
    let mat = Material {
        young: 20e9,
        poisson: 0.2,
        density: 2700.0,
    };
    let sc = scenario(
        "ref",
        MeshSpec::Perturbed {
            width: 100.0,
            height: 100.0,
            h: 1.0,
            origin: [0.0, 0.0],
            fraction: 0.2,
            seed: 9,
        },
        mat,
        Boundary::InSitu {
            sxx: -20e6,
            syy: -10e6,
        },
        End::Time(1.0),
        Damping::Local(0.8),
    );
    let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
    let mesh = TriMesh::perturbed(100.0, 100.0, 1.0, [0.0, 0.0], 0.2, 9).unwrap();
    let bcs: Vec<[Option<f64>; 2]> = (0..sim.solid().n_nodes())
        .map(|i| {
            [0, 1]
                .map(|d| (sim.solid().fixed[i] & (1 << d) != 0).then_some(sim.solid().presc[i][d]))
        })
        .collect();
    assert_eq!(
        sim.solid().x0,
        mesh.nodes,
        "view order must follow stable ids"
    );
    let lookup = |x: [f64; 2]| bcs[mesh.nodes.iter().position(|&y| y == x).unwrap()];
    let mut serial = FlatSolid::new(&mesh, &mat, sim.params().solid, sim.dt(), 0.8, lookup);
    let mut parallel = FlatSolid::new(&mesh, &mat, sim.params().solid, sim.dt(), 0.8, lookup);
    for _ in 0..200 {
        sim.step_once().unwrap();
        serial.step_serial();
        parallel.step_parallel();
    }
    let engine: Vec<f64> = sim.solid().u.as_flattened().to_vec();
    assert!(engine.iter().any(|&u| u != 0.0));
    assert!(
        engine == serial.u,
        "serial reference differs from the engine"
    );
    assert!(
        engine == parallel.u,
        "parallel reference differs from the engine"
    );
}
