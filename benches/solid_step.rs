//! Whole solid step (internal force, boundary conditions, damping, integration) in ns per
//! element per step: the ECS engine (`Simulation::step_once`, with its schedule, spans and
//! monitoring) beside the flat-array reference kernel of the same physics, on 20,000, 320,000
//! and 1,280,000-element meshes, with 1 and 2 threads.
//!
//! Run: `cargo bench --bench solid_step` (criterion reports Melem/s; ns/element = 1000 / that).
//! Set HYDROFRAC_BENCH_SIZES=100,400 to pick meshes (cells per side of the 100 m square).

#[macro_use]
mod common;

use common::ROCK;
use criterion::{BenchmarkId, Criterion, Throughput};
use hydrofrac::mesh::TriMesh;
use hydrofrac::reference::FlatSolid;
use hydrofrac::scenario::{Damping, End};
use hydrofrac::sim::Simulation;
use hydrofrac::verify::solid_cases::seed_block;

fn solid_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("solid_step");
    common::ten_samples(&mut group, 500, 2);
    for n in common::sizes("HYDROFRAC_BENCH_SIZES", &[100, 400, 800]) {
        let h = 100.0 / n as f64;
        let elems = 2 * n * n;
        group.throughput(Throughput::Elements(elems as u64));
        let sc = seed_block(h, End::Time(1e9), Damping::Local(0.8));
        let mut sim = Simulation::new(sc.validate().unwrap(), &[]).unwrap();
        let mesh = TriMesh::regular(100.0, 100.0, h, [0.0, 0.0]).unwrap();
        let bcs: Vec<[Option<f64>; 2]> = (0..sim.solid().n_nodes())
            .map(|i| {
                [0, 1].map(|d| {
                    (sim.solid().fixed[i] & (1 << d) != 0).then_some(sim.solid().presc[i][d])
                })
            })
            .collect();
        let w = n + 1;
        let mut flat = FlatSolid::new(&mesh, &ROCK, sim.params().solid, sim.dt(), 0.8, |x| {
            let (i, j) = ((x[0] / h).round() as usize, (x[1] / h).round() as usize);
            bcs[j * w + i]
        });
        for threads in [1usize, 2] {
            let pool = common::pool(threads);
            group.bench_function(BenchmarkId::new(format!("ecs/{threads}t"), elems), |b| {
                pool.install(|| b.iter(|| sim.step_once().unwrap()))
            });
            group.bench_function(
                BenchmarkId::new(format!("flat_parallel/{threads}t"), elems),
                |b| pool.install(|| b.iter(|| flat.step_parallel())),
            );
            if threads == 1 {
                group.bench_function(BenchmarkId::new("flat_serial/1t", elems), |b| {
                    b.iter(|| flat.step_serial())
                });
            }
        }
    }
    group.finish();
}

bench_main!(solid_step);
