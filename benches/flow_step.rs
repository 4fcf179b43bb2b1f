//! One explicit flow sub-step in ns per cell pair: the engine's `flow_step` on the flow view
//! built from the ECS, beside a flat-array reference (`FlatFlow`: serial scatter, no boundary
//! handling, no throughput or Kahan compensation), on lattice networks of about 1e3, 1e4 and 1e5
//! cells (four cells per interior node: six pairs), with 1 and 2 threads.
//!
//! Run: `cargo bench --bench flow_step`. HYDROFRAC_BENCH_FLOW=10,32 picks lattice sizes.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hydrofrac::network;
use hydrofrac::reference::FlatFlow;
use hydrofrac::scenario::{End, FlowBcKind, FlowTarget, InitialFluid};
use hydrofrac::sim::Simulation;
use hydrofrac::systems::flow::flow_step;
use hydrofrac::verify::flow_cases::{WATER, bc, flow_scenario, net};
use std::time::Duration;

/// A square lattice of n x n fracture lines, 1 m apart: about 2 n^2 cells.
fn lattice(n: usize) -> Simulation {
    let len = (n - 1) as f64;
    let fr = network::lattice(n, |k| 1e-4 * (1.0 + 0.5 * ((k * 7919) % 13) as f64 / 13.0));
    let sc = flow_scenario(
        "bench",
        net(fr, None, 1.0),
        vec![
            bc(
                "in",
                FlowTarget::Node([0.0, 0.0]),
                FlowBcKind::Pressure(2e6),
            ),
            bc(
                "out",
                FlowTarget::Node([len, len]),
                FlowBcKind::Pressure(1e6),
            ),
        ],
        InitialFluid::Full(1e6),
        End::Time(1.0),
        WATER,
    );
    Simulation::new(sc.validate().unwrap(), &[]).unwrap()
}

fn sizes() -> Vec<usize> {
    std::env::var("HYDROFRAC_BENCH_FLOW")
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| vec![23, 71, 224])
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("flow_substep");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    for n in sizes() {
        let mut sim = lattice(n);
        let specs = sim.scenario().flow_boundaries.clone();
        let params = sim.params().fluid;
        let f = sim.flow_mut().unwrap();
        let (cells, pairs) = (f.view.n_cells(), f.view.pairs.len());
        let dt = f.dt_crit * 0.9;
        let mut flat = FlatFlow::from_view(&f.view, &params);
        eprintln!("lattice {n}: {cells} cells, {pairs} pairs");
        group.throughput(Throughput::Elements(pairs as u64));
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
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

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
