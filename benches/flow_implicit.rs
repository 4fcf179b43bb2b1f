//! Cost of one implicit (backward-Euler) flow step per cell against one explicit sub-step per
//! cell, on the square lattice networks of `flow_step` (four cells per interior node, six
//! pairs), 1 thread (the implicit step is sequential: faer sparse LU with `Par::Seq`).
//!
//! Every implicit step must do real work: the inlet pressure follows a schedule (1 at t = 0,
//! 2 at t = 1 s) and the bench alternates steps ending at t = 0 and t = 1 s, so each step
//! moves the network between two states (one Newton iteration: the system is linear once every
//! cell is full; the symbolic LU is reused, as in a run). The step is 100x the explicit bound.
//!
//! Run: `cargo bench --bench flow_implicit`. HYDROFRAC_BENCH_FLOW=10,32 picks lattice sizes.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use hydrofrac::flow::implicit::{ImplicitSolver, implicit_step};
use hydrofrac::network;
use hydrofrac::scenario::{End, FlowBcKind, FlowTarget, InitialFluid};
use hydrofrac::sim::Simulation;
use hydrofrac::systems::flow::flow_step;
use hydrofrac::verify::flow_cases::{WATER, bc, flow_scenario, net};
use std::time::Duration;

fn lattice(n: usize) -> Simulation {
    let len = (n - 1) as f64;
    let fr = network::lattice(n, |k| 1e-4 * (1.0 + 0.5 * ((k * 7919) % 13) as f64 / 13.0));
    let mut inlet = bc(
        "in",
        FlowTarget::Node([0.0, 0.0]),
        FlowBcKind::Pressure(2e6),
    );
    inlet.schedule = vec![(0.0, 1.0), (1.0, 2.0)];
    let sc = flow_scenario(
        "bench",
        net(fr, None, 1.0),
        vec![
            inlet,
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
    let mut group = c.benchmark_group("flow_per_cell");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(3));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    for n in sizes() {
        let mut sim = lattice(n);
        let specs = sim.scenario().flow_boundaries.clone();
        let params = sim.params().fluid;
        let f = sim.flow_mut().unwrap();
        let cells = f.view.n_cells();
        let crit = f.dt_crit;
        group.throughput(Throughput::Elements(cells as u64));
        group.bench_function(BenchmarkId::new("explicit_substep/1t", cells), |b| {
            pool.install(|| b.iter(|| flow_step(&mut f.view, &params, &specs, 0.9 * crit, 0.0)))
        });
        let dt = 100.0 * crit;
        let mut solver = ImplicitSolver::new();
        // A Newton iteration with its factorisation each time (the chord would reuse the
        // kept factor and time a solve instead).
        solver.chord = false;
        let mut flip = false;
        group.bench_function(BenchmarkId::new("implicit_step/1t", cells), |b| {
            pool.install(|| {
                b.iter(|| {
                    flip = !flip;
                    let t = if flip { 1.0 - dt } else { -dt };
                    implicit_step(&mut f.view, &params, &specs, dt, t, &mut solver).unwrap()
                })
            })
        });
        eprintln!(
            "lattice {n}: {cells} cells, {} pairs; implicit: {} steps, {:.2} Newton iterations per step, {} symbolic LU",
            f.view.pairs.len(),
            solver.steps,
            solver.total_iterations as f64 / solver.steps.max(1) as f64,
            solver.symbolic_count()
        );
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = bench
}
criterion_main!(benches);
