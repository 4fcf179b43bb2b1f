//! Steady fracture-network flow: sparse Cholesky solve of a 1e5-cell random-aperture
//! lattice with reservoirs on two opposite sides.
//!
//! `solve_fresh`: new solver each time (symbolic analysis + numeric factorisation + solve).
//! `solve_reused`: symbolic analysis reused, only numeric factorisation + solve.

#[macro_use]
mod common;

use std::hint::black_box;

use criterion::Criterion;
use hydrofrac::flow::steady::{SteadyProblem, SteadySolver};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

struct Net {
    n: usize,
    pairs: Vec<(u32, u32, f64)>,
    dirichlet: Vec<(u32, f64, f64)>,
}

/// `nx * ny` lattice, log-uniform apertures (one decade around 0.1 mm), 10 % of the
/// bonds removed, reservoirs at 20 MPa (x = 0) and 10 MPa (x = nx - 1).
fn lattice(nx: usize, ny: usize, seed: u64) -> Net {
    let mu = 1e-3;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = nx * ny;
    let k: Vec<f64> = (0..n)
        .map(|_| {
            let a = 1e-4 * 10f64.powf(rng.random::<f64>() - 0.5);
            a * a * a / (12.0 * mu)
        })
        .collect();
    let id = |x: usize, y: usize| (y * nx + x) as u32;
    let mut pairs = Vec::with_capacity(2 * n);
    for y in 0..ny {
        for x in 0..nx {
            let c = id(x, y);
            let mut neighbours = [None, None];
            if x + 1 < nx {
                neighbours[0] = Some(id(x + 1, y));
            }
            if y + 1 < ny {
                neighbours[1] = Some(id(x, y + 1));
            }
            for d in neighbours.into_iter().flatten() {
                if rng.random::<f64>() >= 0.1 {
                    let (ki, kj) = (k[c as usize], k[d as usize]);
                    pairs.push((c, d, 2.0 * ki * kj / (ki + kj)));
                }
            }
        }
    }
    let mut dirichlet = Vec::with_capacity(2 * ny);
    for y in 0..ny {
        let (l, r) = (id(0, y), id(nx - 1, y));
        dirichlet.push((l, 2.0 * k[l as usize], 2.0e7));
        dirichlet.push((r, 2.0 * k[r as usize], 1.0e7));
    }
    Net {
        n,
        pairs,
        dirichlet,
    }
}

fn bench_steady(c: &mut Criterion) {
    let net = lattice(400, 250, 2024);
    let problem = SteadyProblem {
        n_cells: net.n,
        pairs: &net.pairs,
        dirichlet: &net.dirichlet,
        sources: &[],
    };
    let mut group = c.benchmark_group("flow_steady_1e5");
    group.bench_function("solve_fresh", |b| {
        b.iter(|| {
            let mut solver = SteadySolver::new();
            black_box(solver.solve(black_box(&problem)).unwrap())
        })
    });
    let mut solver = SteadySolver::new();
    solver.solve(&problem).unwrap();
    group.bench_function("solve_reused", |b| {
        b.iter(|| black_box(solver.solve(black_box(&problem)).unwrap()))
    });
    group.finish();
    assert_eq!(solver.symbolic_count(), 1);
}

bench_main!(common::criterion_10_samples(); bench_steady);
