//! Set-up the benches share (each pulls it in with `mod common;` and uses what it needs): the
//! criterion configurations, thread pools, sizes picked by an environment variable, the rock,
//! and the lattice networks of the flow benches.
#![allow(dead_code)]

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion};
use hydrofrac::network;
use hydrofrac::scenario::{Coords, End, FlowBcKind, FlowTarget, InitialFluid, Material};
use hydrofrac::sim::Simulation;
use hydrofrac::verify::flow_cases::{WATER, bc, flow_scenario, net};
use std::time::Duration;

/// Criterion without plots (every bench's configuration).
pub fn criterion() -> Criterion {
    Criterion::default().without_plots()
}

/// [`criterion`] with 10 samples measured for 3 s each (the solver benches).
pub fn criterion_10_samples() -> Criterion {
    criterion()
        .sample_size(10)
        .measurement_time(Duration::from_secs(3))
}

/// A group of 10 samples, warmed up for `warm_up_ms` ms and measured for `measure_s` s.
pub fn ten_samples(group: &mut BenchmarkGroup<'_, WallTime>, warm_up_ms: u64, measure_s: u64) {
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(warm_up_ms))
        .measurement_time(Duration::from_secs(measure_s));
}

/// A thread pool of `threads` threads.
pub fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

/// The sizes listed in the environment variable `var` (comma-separated), else `default`.
pub fn sizes(var: &str, default: &[usize]) -> Vec<usize> {
    std::env::var(var)
        .ok()
        .map(|s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect())
        .unwrap_or_else(|| default.to_vec())
}

/// The flow benches' lattice sizes: `HYDROFRAC_BENCH_FLOW`, else about 1e3, 1e4 and 1e5 cells.
pub fn flow_sizes() -> Vec<usize> {
    sizes("HYDROFRAC_BENCH_FLOW", &[23, 71, 224])
}

/// Granite as the solid benches take it (SI).
pub const ROCK: Material = Material {
    young: 20e9,
    poisson: 0.2,
    density: 2700.0,
};

/// A square lattice of n x n fracture lines, 1 m apart (about 2 n^2 cells, apertures about
/// 0.1 mm), full of water at 1 MPa, between an inlet at 2 MPa (times `inlet_schedule`, pairs
/// of time s and factor; empty: constant) at one corner and an outlet at 1 MPa at the other.
pub fn lattice(n: usize, inlet_schedule: Vec<(f64, f64)>) -> Simulation {
    let len = (n - 1) as f64;
    let fr = network::lattice(n, |k| 1e-4 * (1.0 + 0.5 * ((k * 7919) % 13) as f64 / 13.0));
    let mut inlet = bc(
        "in",
        FlowTarget::Node(Coords::two([0.0, 0.0])),
        FlowBcKind::Pressure(2e6),
    );
    inlet.schedule = inlet_schedule;
    let outlet = bc(
        "out",
        FlowTarget::Node(Coords::two([len, len])),
        FlowBcKind::Pressure(1e6),
    );
    let sc = flow_scenario(
        "bench",
        net(fr, None, 1.0),
        vec![inlet, outlet],
        InitialFluid::Full(1e6),
        End::Time(1.0),
        WATER,
    );
    Simulation::new(sc.validate().unwrap(), &[]).unwrap()
}

/// The bench's `main`: a criterion group of `targets` with `config` (default [`criterion`]).
/// The bench pulls this module in with `#[macro_use] mod common;`.
macro_rules! bench_main {
    ($config:expr; $($target:path),+ $(,)?) => {
        criterion::criterion_group! {
            name = benches;
            config = $config;
            targets = $($target),+
        }
        criterion::criterion_main!(benches);
    };
    ($($target:path),+ $(,)?) => {
        bench_main!(common::criterion(); $($target),+);
    };
}
