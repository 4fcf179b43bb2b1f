//! One explicit flow sub-step in ns per cell pair: the engine's `flow_step` on the flow view
//! built from the ECS, beside a flat-array reference (`FlatFlow`: serial scatter, no boundary
//! handling, no throughput or Kahan compensation), on lattice networks of about 1e3, 1e4 and 1e5
//! cells (four cells per interior node: six pairs), with 1 and 2 threads.
//!
//! Run: `cargo bench --bench flow_step`. HYDROFRAC_BENCH_FLOW=10,32 picks lattice sizes.

#[macro_use]
mod common;

use criterion::{BenchmarkId, Criterion, Throughput};
use hydrofrac::reference::FlatFlow;
use hydrofrac::systems::flow::flow_step;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("flow_substep");
    common::ten_samples(&mut group, 300, 2);
    for n in common::flow_sizes() {
        let mut sim = common::lattice(n, Vec::new());
        let specs = sim.scenario().flow_boundaries.clone();
        let params = sim.params().fluid;
        let f = sim.flow_mut().unwrap();
        let (cells, pairs) = (f.view.n_cells(), f.view.pairs.len());
        let dt = f.dt_crit * 0.9;
        let mut flat = FlatFlow::from_view(&f.view, &params);
        eprintln!("lattice {n}: {cells} cells, {pairs} pairs");
        group.throughput(Throughput::Elements(pairs as u64));
        for threads in [1usize, 2] {
            let pool = common::pool(threads);
            group.bench_function(BenchmarkId::new(format!("ecs/{threads}t"), cells), |b| {
                pool.install(|| b.iter(|| flow_step(&mut f.view, &params, &specs, dt, 0.0)))
            });
        }
        group.bench_function(BenchmarkId::new("flat_serial/1t", cells), |b| {
            b.iter(|| flat.step(dt))
        });
    }
    group.finish();
}

bench_main!(bench);
