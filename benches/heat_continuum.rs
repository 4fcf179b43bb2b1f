//! Continuum heat model: a 100 x 100 doublet (1 km square, wells 200 m apart, 1e-3 m^2/s)
//! for one year of monthly steps.
//!
//! `darcy_100x100`: the steady pressure solve alone (sparse Cholesky).
//! `run_100x100_1y`: pressure solve, heat matrix LU (once) and 12 implicit heat steps.

#[macro_use]
mod common;

use std::hint::black_box;

use criterion::Criterion;
use hydrofrac::reservoir::continuum::{darcy_flow, run_continuum};
use hydrofrac::verify::heat_continuum_cases::doublet_spec;

fn bench_continuum(c: &mut Criterion) {
    let spec = doublet_spec(100, 1e-3, 1.0);
    let mut group = c.benchmark_group("heat_continuum");
    group.bench_function("darcy_100x100", |b| {
        b.iter(|| black_box(darcy_flow(black_box(&spec)).unwrap()))
    });
    group.bench_function("run_100x100_1y", |b| {
        b.iter(|| black_box(run_continuum(black_box(&spec)).unwrap()))
    });
    group.finish();
}

bench_main!(common::criterion_10_samples(); bench_continuum);
