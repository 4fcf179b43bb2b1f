//! Discrete heat model: a ~2000-cell lattice network with a real steady flow
//! (`verify::heat_discrete_cases::lattice_network`, m = 32: 1984 cells, 10 kPa across) in a 100 m x 100 m
//! block of 1 m rock blocks (10^4), 30 years in monthly backward-Euler steps (360 steps, one
//! LU factorisation), yearly snapshots.
//!
//! `assemble`: validation, exchange geometry, pattern and symbolic LU.
//! `run_30_years`: assembly plus the whole run.

#[macro_use]
mod common;

use std::hint::black_box;

use criterion::Criterion;
use hydrofrac::reservoir::discrete::{DiscreteModel, run_discrete};
use hydrofrac::verify::heat_discrete_cases::{lattice_network, thirty_year_spec};

fn bench_discrete(c: &mut Criterion) {
    let flow = lattice_network(32, 100.0, 1e4, 2024).unwrap();
    let spec = thirty_year_spec();
    let run = run_discrete(&spec, &flow).unwrap();
    eprintln!(
        "heat_discrete: {} cells, {} unknowns, {} steps, {} factorisations, energy balance {:.2e}, production temperature after 30 years {:.2} K",
        flow.cells.len(),
        run.unknowns,
        run.times.len(),
        run.factorisations,
        run.energy_balance.relative_error,
        run.production_temperature.last().unwrap()
    );
    let q: f64 = flow
        .boundary
        .iter()
        .filter(|b| b.1 > 0.0)
        .map(|b| b.1)
        .sum();
    let year = |y: usize| run.production_temperature[12 * y - 1];
    eprintln!(
        "injected {q:.3e} m^2/s; production temperature after 1, 5, 10, 20, 30 years: {:.2}, {:.2}, {:.2}, {:.2}, {:.2} K; heat {:.3e} J/m",
        year(1),
        year(5),
        year(10),
        year(20),
        year(30),
        run.cumulative_heat.last().unwrap()
    );
    let mut group = c.benchmark_group("heat_discrete_2000_cells");
    group.bench_function("assemble", |b| {
        b.iter(|| black_box(DiscreteModel::new(black_box(&spec), black_box(&flow)).unwrap()))
    });
    group.bench_function("run_30_years", |b| {
        b.iter(|| black_box(run_discrete(black_box(&spec), black_box(&flow)).unwrap()))
    });
    group.finish();
}

bench_main!(common::criterion_10_samples(); bench_discrete);
