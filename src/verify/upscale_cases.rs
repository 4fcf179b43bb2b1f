//! Upscaling a fracture network to block permeabilities (`docs/upscaling.md`).
//!
//! `oda`: Oda's tensor and the flow-based permeameter on parallel fractures, where both equal
//! b^3 / (12 s); then both on seeded sparse random networks at four block sizes, where Oda must
//! bound the flow-based value from above in every block (the linear pressure field is a trial
//! field of the permeameter's minimum-dissipation principle) and the ratio says how much of
//! the fracture length is connected across the blocks.

use super::{CaseResult, Row};
use crate::network::{NetworkSpec, RandomNetwork};
use crate::reservoir::doublet::network_of;
use crate::reservoir::upscale::{flow_based, oda};
use crate::reservoir::{Grid2, NetworkFlow};
use std::time::Instant;

/// Two orthogonal families of fractures of aperture `b` at spacing `s` across a square of side
/// `m s`, cells of `cell` m: k = b^3 / (12 s) in x and in y.
fn two_families(m: usize, s: f64, b: f64, cell: f64) -> NetworkFlow {
    let side = m as f64 * s;
    let mut fractures = Vec::new();
    for f in 0..m {
        let c = (f as f64 + 0.5) * s;
        fractures.push(crate::network::Fracture {
            from: [0.0, c],
            to: [side, c],
            aperture: b,
        });
        fractures.push(crate::network::Fracture {
            from: [c, 0.0],
            to: [c, side],
            aperture: b,
        });
    }
    let spec = NetworkSpec {
        fractures,
        random: None,
        cell_length: cell,
    };
    network_of(&spec.discretise())
}

/// A random network of `count` fractures: two families (30 and 120 degrees, +-15), 10-40 m long, apertures
/// 0.1-0.5 mm log-uniform, in a 100 m square.
fn random(seed: u64, count: usize) -> NetworkFlow {
    let spec = NetworkSpec {
        fractures: Vec::new(),
        random: Some(RandomNetwork {
            seed,
            count,
            origin: [0.0; 2],
            size: [100.0; 2],
            angles_deg: vec![30.0, 120.0],
            jitter_deg: 15.0,
            length: [10.0, 40.0],
            aperture: [1e-4, 5e-4],
        }),
        cell_length: 1.0,
    };
    network_of(&spec.discretise())
}

pub fn oda_case(quick: bool) -> anyhow::Result<CaseResult> {
    let mut res = CaseResult::default();
    let (s, b, m) = (2.0, 3e-4_f64, 16);
    let exact = b.powi(3) / (12.0 * s);
    let net = two_families(m, s, b, 0.5);
    let side = m as f64 * s;
    let levels: &[usize] = if quick { &[1, 2, 4] } else { &[1, 2, 4, 8] };
    let (mut worst_oda, mut worst_flow) = (0.0f64, 0.0f64);
    for (level, &n) in levels.iter().enumerate() {
        let grid = Grid2 {
            origin: [0.0; 2],
            size: [side; 2],
            n: [n, n],
        };
        let t0 = Instant::now();
        let ko = oda(&grid, &net);
        let t_oda = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let kf = flow_based(&grid, &net, 1e-3)?;
        let t_flow = t0.elapsed().as_secs_f64();
        let e_oda = ko
            .iter()
            .map(|k| {
                ((k[0] - exact).abs().max((k[1] - exact).abs()) / exact).max(k[2].abs() / exact)
            })
            .fold(0.0, f64::max);
        let e_flow = kf
            .iter()
            .map(|k| (k[0] - exact).abs().max((k[1] - exact).abs()) / exact)
            .fold(0.0, f64::max);
        worst_oda = worst_oda.max(e_oda);
        worst_flow = worst_flow.max(e_flow);
        for (metric, e, t) in [
            ("parallel: Oda", e_oda, t_oda),
            ("parallel: flow-based", e_flow, t_flow),
        ] {
            res.rows.push(Row {
                case: "oda",
                level,
                h: side / n as f64,
                unknowns: net.cells.len(),
                metric: metric.into(),
                error: e,
                wall_s: t,
            });
        }
    }
    // Round-off: sums of O(100) equal terms; the flow-based value goes through a Cholesky
    // solve of a well-conditioned Kirchhoff system.
    res.check_max("parallel fractures: Oda, max rel. error", worst_oda, 1e-12);
    res.check_max(
        "parallel fractures: flow-based, max rel. error",
        worst_flow,
        1e-9,
    );

    // Sparse random networks.
    let seeds: &[u64] = if quick { &[7] } else { &[7, 8, 9] };
    let mut worst_bound: f64 = 0.0;
    for (&seed, count) in seeds.iter().flat_map(|s| [(s, 60), (s, 150)]) {
        let net = random(seed, count);
        for (level, &n) in [1usize, 2, 4, 10].iter().enumerate() {
            let grid = Grid2 {
                origin: [0.0; 2],
                size: [100.0; 2],
                n: [n, n],
            };
            let t0 = Instant::now();
            let ko = oda(&grid, &net);
            let kf = flow_based(&grid, &net, 1e-3)?;
            let wall = t0.elapsed().as_secs_f64();
            // Oda >= flow-based on the diagonal, to round-off.
            for (a, f) in ko.iter().zip(&kf) {
                for d in 0..2 {
                    let excess = (f[d] - a[d]) / a[d].max(1e-300);
                    worst_bound = worst_bound.max(excess);
                }
            }
            let (sum_o, sum_f): (f64, f64) = ko
                .iter()
                .zip(&kf)
                .map(|(a, f)| (a[0] + a[1], f[0] + f[1]))
                .fold((0.0, 0.0), |s, x| (s.0 + x.0, s.1 + x.1));
            let flowing = kf.iter().filter(|f| f[0] + f[1] > 0.0).count();
            let ratio = if sum_f > 0.0 {
                format!("{:.3}", sum_o / sum_f)
            } else {
                "- (no block connected across)".into()
            };
            res.notes.push(format!(
                "{count} fractures, seed {seed}, {n}x{n} blocks of {:.0} m: sum Oda / sum flow-based = {ratio}; {flowing} of {} blocks carry flow",
                100.0 / n as f64,
                grid.len()
            ));
            if seed == seeds[0] {
                res.rows.push(Row {
                    case: "oda",
                    level,
                    h: 100.0 / n as f64,
                    unknowns: net.cells.len(),
                    metric: format!("random {count}: 1 - flow/Oda (sum)"),
                    error: 1.0 - sum_f / sum_o.max(1e-300),
                    wall_s: wall,
                });
            }
        }
    }
    res.check_max(
        "random networks: (flow-based - Oda)/Oda, max over blocks (Oda is an upper bound)",
        worst_bound,
        1e-9,
    );
    Ok(res)
}
