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

#[macro_use]
mod common;

use criterion::{BenchmarkId, Criterion, Throughput};
use hydrofrac::flow::implicit::{ImplicitSolver, implicit_step};
use hydrofrac::systems::flow::flow_step;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("flow_per_cell");
    common::ten_samples(&mut group, 300, 3);
    let pool = common::pool(1);
    for n in common::flow_sizes() {
        // The inlet at 1 x its pressure at t = 0, 2 x at t = 1 s.
        let mut sim = common::lattice(n, vec![(0.0, 1.0), (1.0, 2.0)]);
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

bench_main!(bench);
