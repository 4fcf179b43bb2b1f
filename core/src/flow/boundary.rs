//! Boundary flows of the fracture network, shared by the explicit step
//! (`systems/flow.rs`) and the backward-Euler step ([`crate::flow::implicit`]): pressure, rate
//! and pump boundaries (seed (5)-(6): the pump's characteristic curve with a check valve), and
//! the boundaries' cumulative volumes. SI units: pressures Pa, rates m^2/s per unit thickness.

use crate::flow::{FlowView, kahan_add};
use crate::scenario::{FlowBcKind, FlowBoundary};

/// A cell's mass may dip below zero by this fraction of the mass it holds when full,
/// rho_r V (round-off of an emptying cell, or of a converged implicit step at tolerance
/// 1e-12); below that it is a failure (more fluid withdrawn than the cell holds).
pub const MASS_ROUNDOFF: f64 = 1e-12;

/// Reductions of one flow step.
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct FlowStats {
    /// Sum of squared net volumetric inflow per cell, (m^2/s)^2.
    pub net2: f64,
    /// First cell (dense index) with negative or non-finite mass.
    pub bad_cell: Option<usize>,
}

/// Pump operating point against cells at pressures `p` through transmissibilities `kappa`:
/// the rate q >= 0 solving q = sum kappa_k (P_pump(q) - p_k) with
/// P_pump = p_max (1 - (2/pi) atan(q/q_half)). Returns (q, P_pump). With a closed check valve
/// (the network pressure above the pump's) q = 0 and the pressure is the no-flow average.
pub fn pump_operating_point(
    p_max: f64,
    q_half: f64,
    kappa: &[f64],
    p: &[f64],
    q_guess: f64,
) -> (f64, f64) {
    let s: f64 = kappa.iter().sum();
    let sp: f64 = kappa.iter().zip(p).map(|(k, p)| k * p).sum();
    let curve = |q: f64| p_max * (1.0 - std::f64::consts::FRAC_2_PI * (q / q_half).atan());
    let g = |q: f64| q - s * curve(q) + sp;
    if s <= 0.0 || g(0.0) >= 0.0 {
        return (0.0, if s > 0.0 { sp / s } else { p_max });
    }
    // g is increasing; bracket [0, s p_max] and Newton with bisection safeguard.
    let (mut lo, mut hi) = (0.0, s * p_max);
    let mut q = q_guess.clamp(lo, hi);
    for _ in 0..200 {
        let gq = g(q);
        if gq > 0.0 {
            hi = q;
        } else {
            lo = q;
        }
        let dg =
            1.0 + s * p_max * std::f64::consts::FRAC_2_PI / q_half / (1.0 + (q / q_half).powi(2));
        let mut next = q - gq / dg;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - q).abs() <= 1e-15 * q.abs().max(1e-300) || hi - lo <= 1e-15 * hi {
            q = next;
            break;
        }
        q = next;
    }
    (q, curve(q))
}

/// Boundary flows for the current cell pressures: fills `bc_in` and each boundary's state.
pub fn boundary_flows(v: &mut FlowView, specs: &[FlowBoundary], t: f64) {
    for b in &v.bcs {
        for &c in &b.cells {
            v.bc_in[c as usize] = 0.0;
        }
    }
    for b in &mut v.bcs {
        let f = specs[b.index].factor(t);
        for (p, &c) in b.p_cells.iter_mut().zip(&b.cells) {
            *p = v.pressure[c as usize];
        }
        let pc = &b.p_cells;
        let s: f64 = b.kappa.iter().sum();
        let sp: f64 = b.kappa.iter().zip(pc.iter()).map(|(k, p)| k * p).sum();
        let pb = match b.kind {
            FlowBcKind::Pressure(p) => f * p,
            FlowBcKind::Rate(q) => {
                if s > 0.0 {
                    (f * q + sp) / s
                } else {
                    0.0
                }
            }
            FlowBcKind::Pump { p_max, q_half } => {
                pump_operating_point(f * p_max, q_half, &b.kappa, pc, b.rate).1
            }
        };
        let mut total = 0.0;
        for (k, &c) in b.cells.iter().enumerate() {
            let q = b.kappa[k] * (pb - pc[k]);
            b.q_cells[k] = q;
            v.bc_in[c as usize] += q;
            total += q;
        }
        b.pressure = pb;
        b.rate = total;
    }
}

/// Add dt times each boundary's rate to its cumulative volume in (or out), m^2.
pub fn accumulate_boundary_volumes(v: &mut FlowView, dt: f64) {
    for b in &mut v.bcs {
        if b.rate >= 0.0 {
            kahan_add(&mut b.volume_in, &mut b.comp_in, dt * b.rate);
        } else {
            kahan_add(&mut b.volume_out, &mut b.comp_out, -dt * b.rate);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pump_point_solves_both_curves() {
        // One cell at 2 MPa behind kappa = 1e-9: q = kappa (P(q) - 2e6).
        let (q, pp) = pump_operating_point(18e6, 2.0, &[1e-9], &[2e6], 0.0);
        assert!((q - 1e-9 * (pp - 2e6)).abs() < 1e-12 * q);
        let curve = 18e6 * (1.0 - std::f64::consts::FRAC_2_PI * (q / 2.0).atan());
        assert!((pp - curve).abs() < 1e-6, "{pp} vs {curve}");
        // Check valve: network above p_max gives no backflow.
        let (q, _) = pump_operating_point(18e6, 2.0, &[1e-9], &[20e6], 0.0);
        assert_eq!(q, 0.0);
    }
}
