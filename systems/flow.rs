//! Flow systems: explicit (forward Euler) finite-volume sub-steps of the fracture network with
//! pump, rate and pressure boundaries. Pair fluxes are computed per pair and gathered per cell
//! through a CSR incidence list (no atomics), so results are the same bits for any thread count.

use crate::error::SetupError;
pub use crate::flow::boundary::{
    FlowStats, MASS_ROUNDOFF, accumulate_boundary_volumes, boundary_flows, pump_operating_point,
};
use crate::flow::implicit::{ImplicitSolver, implicit_step};
use crate::flow::{FlowParams, FlowView, kahan_add, pressure_of};
use crate::network::CellNetwork;
use crate::params::RunParams;
use crate::scenario::{FlowBoundary, FlowScheme};
use crate::systems::RunError;
use crate::systems::coupling::Coupling;
use crate::view::SolidView;
use rayon::prelude::*;

/// Cells per rayon task / reduction chunk.
pub const CELL_CHUNK: usize = 4096;

/// One explicit flow step of length dt at time t: pressures, pair fluxes, boundary flows, mass
/// update (excess mass += dt rho_r sum of inflows), throughput, and the boundaries' cumulative
/// volumes.
pub fn flow_step(
    v: &mut FlowView,
    p: &FlowParams,
    specs: &[FlowBoundary],
    dt: f64,
    t: f64,
) -> FlowStats {
    if v.n_cells() <= CELL_CHUNK && v.pairs.len() <= CELL_CHUNK {
        return flow_step_serial(v, p, specs, dt, t);
    }
    // Pressures from mass.
    v.pressure
        .par_iter_mut()
        .zip(v.excess.par_iter().zip(v.volume.par_iter()))
        .with_min_len(CELL_CHUNK)
        .for_each(|(pr, (m, vol))| *pr = pressure_of(*m, *vol, p));
    // Pair fluxes, first -> second.
    let (pairs, pres) = (&v.pairs, &v.pressure);
    v.pair_q
        .par_iter_mut()
        .zip(pairs.par_iter().zip(v.kappa.par_iter()))
        .with_min_len(CELL_CHUNK)
        .for_each(|(q, (pr, k))| *q = k * (pres[pr[0] as usize] - pres[pr[1] as usize]));
    boundary_flows(v, specs, t);
    // Gather and update, reducing in fixed chunks.
    let (ptr, inc, pq, bc_in, vol) = (&v.inc_ptr, &v.inc, &v.pair_q, &v.bc_in, &v.volume);
    let rho_dt = p.rho_r * dt;
    let partial: Vec<FlowStats> = v
        .excess
        .par_chunks_mut(CELL_CHUNK)
        .zip(v.excess_comp.par_chunks_mut(CELL_CHUNK))
        .zip(v.flow_rate.par_chunks_mut(CELL_CHUNK))
        .enumerate()
        .map(|(ch, ((mc, cc), fc))| {
            let mut st = FlowStats::default();
            for (k, ((m, comp), fr)) in mc
                .iter_mut()
                .zip(cc.iter_mut())
                .zip(fc.iter_mut())
                .enumerate()
            {
                let i = ch * CELL_CHUNK + k;
                let (mut net, mut through) = (bc_in[i], bc_in[i].abs());
                for &e in &inc[ptr[i] as usize..ptr[i + 1] as usize] {
                    let q = pq[(e >> 1) as usize];
                    net += if e & 1 == 0 { -q } else { q };
                    through += q.abs();
                }
                kahan_add(m, comp, rho_dt * net);
                *fr = 0.5 * through;
                st.net2 += net * net;
                if !(*m >= -p.rho_r * vol[i] * (1.0 + MASS_ROUNDOFF) && m.is_finite())
                    && st.bad_cell.is_none()
                {
                    st.bad_cell = Some(i);
                }
            }
            st
        })
        .collect();
    accumulate_boundary_volumes(v, dt);
    partial
        .into_iter()
        .fold(FlowStats::default(), |a, b| FlowStats {
            net2: a.net2 + b.net2,
            bad_cell: a.bad_cell.or(b.bad_cell),
        })
}

/// [`flow_step`] for small networks (one reduction chunk), without rayon or allocation: the
/// same operations in the same order, so the same bits. Coupled runs take thousands of
/// sub-steps per solid step on networks of tens of cells, where dispatch would dominate.
fn flow_step_serial(
    v: &mut FlowView,
    p: &FlowParams,
    specs: &[FlowBoundary],
    dt: f64,
    t: f64,
) -> FlowStats {
    for c in 0..v.n_cells() {
        v.pressure[c] = pressure_of(v.excess[c], v.volume[c], p);
    }
    for (k, pr) in v.pairs.iter().enumerate() {
        v.pair_q[k] = v.kappa[k] * (v.pressure[pr[0] as usize] - v.pressure[pr[1] as usize]);
    }
    boundary_flows(v, specs, t);
    let rho_dt = p.rho_r * dt;
    let mut st = FlowStats::default();
    for i in 0..v.n_cells() {
        let (mut net, mut through) = (v.bc_in[i], v.bc_in[i].abs());
        for &e in &v.inc[v.inc_ptr[i] as usize..v.inc_ptr[i + 1] as usize] {
            let q = v.pair_q[(e >> 1) as usize];
            net += if e & 1 == 0 { -q } else { q };
            through += q.abs();
        }
        kahan_add(&mut v.excess[i], &mut v.excess_comp[i], rho_dt * net);
        v.flow_rate[i] = 0.5 * through;
        st.net2 += net * net;
        let m = v.excess[i];
        if !(m >= -p.rho_r * v.volume[i] * (1.0 + MASS_ROUNDOFF) && m.is_finite())
            && st.bad_cell.is_none()
        {
            st.bad_cell = Some(i);
        }
    }
    accumulate_boundary_volumes(v, dt);
    // The parallel path folds its chunk statistics into a default: one chunk gives the same.
    FlowStats {
        net2: 0.0 + st.net2,
        bad_cell: st.bad_cell,
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

/// The fracture-network flow part of the state.
pub struct FlowPart {
    pub view: FlowView,
    /// Flow sub-step, s, and sub-steps per step.
    pub dt: f64,
    pub substeps: u64,
    /// Explicit critical flow step, s.
    pub dt_crit: f64,
    pub stats: FlowStats,
    /// Fluid excess mass (above rho_r V) summed at the start, kg/m.
    pub initial_excess: f64,
    /// Steady residual ||net inflow per cell|| / sum |boundary rates| (infinite before the first
    /// step).
    pub residual: f64,
    /// Network volume sum a L at the start, m^2 (volumes change in coupled runs).
    pub initial_volume: f64,
    /// The fractures the network was cut from (written to the output; empty in coupled runs).
    pub network: CellNetwork,
    /// Coupled runs (the network is the rock's fractures): maps and exchange state.
    pub coupling: Option<Coupling>,
    /// `time.flow_scheme: Implicit`: the backward-Euler solver (one flow step per step).
    pub implicit: Option<ImplicitSolver>,
}

impl FlowPart {
    /// The flow part over a freshly built view: pressures at the initial masses, the initial
    /// state recorded for the mass balance.
    pub fn new(mut view: FlowView, p: &RunParams, network: CellNetwork, coupled: bool) -> Self {
        view.set_bc_kinds(&p.flow_boundaries);
        for c in 0..view.n_cells() {
            view.pressure[c] = pressure_of(view.excess[c], view.volume[c], &p.fluid);
        }
        FlowPart {
            dt_crit: view.critical_step(&p.fluid),
            initial_excess: view.excess.iter().sum(),
            initial_volume: view.volume.iter().sum(),
            view,
            dt: 0.0,
            substeps: 1,
            stats: FlowStats::default(),
            residual: f64::INFINITY,
            network,
            coupling: coupled.then(Coupling::default),
            implicit: (p.time.flow_scheme == FlowScheme::Implicit).then(ImplicitSolver::new),
        }
    }

    /// Flow volumes (m^2 at reference density): injected, produced, stored change, and the
    /// relative mass-balance error |stored change - (injected - produced)| / max(injected,
    /// produced, |stored change|, network volume). The network volume (sum of a L) is in the
    /// scale because the cell masses carry round-off of eps times the mass they can hold.
    pub fn balance(&self, p: &FlowParams) -> (f64, f64, f64, f64) {
        let v = &self.view;
        let inj: f64 = v.bcs.iter().map(|b| b.volume_in).sum();
        let prod: f64 = v.bcs.iter().map(|b| b.volume_out).sum();
        // Mass = excess + rho_r V: the stored volume is the change of both (volumes change in
        // coupled runs, and cells created by splits arrive empty: e = -rho_r V).
        let stored = (v.excess.iter().sum::<f64>() - self.initial_excess) / p.rho_r
            + (v.volume.iter().sum::<f64>() - self.initial_volume);
        let scale = inj
            .max(prod)
            .max(stored.abs())
            .max(v.volume.iter().sum::<f64>());
        let err = if scale > 0.0 {
            (stored - (inj - prod)).abs() / scale
        } else {
            0.0
        };
        (inj, prod, stored, err)
    }
}

/// `flow_substeps`: the network's flow over the solid step [t0, t0 + dt]. Explicit: N
/// sub-steps, stopping at the first cell with negative or non-finite mass (reported by
/// `monitor`); implicit: one backward-Euler step. Coupled runs exchange apertures and face
/// pressures with the rock ([`Coupling`]). `step` is the number of the step being taken (for
/// error messages). Errors: a coupled explicit step that needs more than `time.max_substeps`
/// sub-steps, an implicit step whose Newton iteration fails.
pub fn flow_substeps(
    f: &mut FlowPart,
    solid: &SolidView,
    p: &RunParams,
    t0: f64,
    step: u64,
) -> Result<(), RunError> {
    let (specs, fp, dt) = (&p.flow_boundaries, &p.fluid, p.solid.dt);
    let implicit_error = |e| RunError::ImplicitFlow {
        step,
        time: t0 + dt,
        source: Box::new(e),
    };
    if let Some(c) = f.coupling.as_mut() {
        let r = match f.implicit.as_mut() {
            Some(solver) => c
                .step_implicit(solid, &mut f.view, fp, specs, t0, dt, solver)
                .map_err(implicit_error)?,
            None => c
                .step(
                    solid,
                    &mut f.view,
                    fp,
                    specs,
                    t0,
                    dt,
                    p.time.safety,
                    p.time.max_substeps,
                )
                .map_err(|e| RunError::BlowUp {
                    step,
                    time: t0 + dt,
                    entity: f.view.cell_label(e.cell),
                    quantity: "flow sub-steps per solid step",
                    value: e.needed as f64,
                    why: format!(
                        "above time.max_substeps = {}: the apertures make the explicit flow step \
                         {:.3e} s against a solid step of {dt:.3e} s (use time.flow_scheme: \
                         Implicit, or raise time.max_substeps)",
                        p.time.max_substeps, e.dt_crit
                    ),
                    dt,
                })?,
        };
        f.stats = r.stats;
        f.substeps = r.substeps;
        f.dt = r.dt;
        f.dt_crit = r.dt_crit;
    } else if let Some(solver) = f.implicit.as_mut() {
        f.dt = dt;
        f.stats = implicit_step(&mut f.view, fp, specs, dt, t0, solver).map_err(implicit_error)?;
    } else {
        for k in 0..f.substeps {
            f.stats = flow_step(&mut f.view, fp, specs, f.dt, t0 + k as f64 * f.dt);
            if f.stats.bad_cell.is_some() {
                break;
            }
        }
    }
    let bc: f64 = f.view.bcs.iter().map(|b| b.rate.abs()).sum();
    let net = f.stats.net2.sqrt();
    f.residual = if bc > 0.0 {
        net / bc
    } else if net == 0.0 {
        0.0
    } else {
        f64::INFINITY
    };
    Ok(())
}

/// `time.end: SteadyDirect`: solve the network's incompressible steady state directly and
/// store it as the current state (cell pressures, masses at those pressures, throughputs,
/// boundary pressures and rates). No time passes: the solved state is the mass balance's
/// reference.
pub fn steady_direct(f: &mut FlowPart, p: &RunParams, t: f64) -> Result<(), SetupError> {
    let mut solver = crate::flow::steady::SteadySolver::new();
    let sol = f
        .view
        .solve_steady(
            &mut solver,
            &p.flow_boundaries,
            |i| p.bc_names[i].clone(),
            t,
        )
        .map_err(|e| SetupError::invalid("flow", e.to_string()))?;
    let v = &mut f.view;
    for c in 0..v.n_cells() {
        v.pressure[c] = sol.pressure[c];
        v.excess[c] = p.fluid.rho_r * sol.pressure[c] / p.fluid.k * v.volume[c];
    }
    // Throughput per cell from the pair flows and the boundary flows of the solution.
    for (k, pr) in v.pairs.iter().enumerate() {
        v.pair_q[k] = v.kappa[k] * (sol.pressure[pr[0] as usize] - sol.pressure[pr[1] as usize]);
    }
    v.bc_in.iter_mut().for_each(|q| *q = 0.0);
    for (b, &(pb, rate)) in v.bcs.iter_mut().zip(&sol.boundaries) {
        for (k, &c) in b.cells.iter().enumerate() {
            b.q_cells[k] = b.kappa[k] * (pb - sol.pressure[c as usize]);
            v.bc_in[c as usize] += b.q_cells[k];
        }
        b.pressure = pb;
        b.rate = rate;
    }
    for c in 0..v.n_cells() {
        let through: f64 = v.inc[v.inc_ptr[c] as usize..v.inc_ptr[c + 1] as usize]
            .iter()
            .map(|&e| v.pair_q[(e >> 1) as usize].abs())
            .sum();
        v.flow_rate[c] = 0.5 * (through + v.bc_in[c].abs());
    }
    f.residual = sol.residual;
    f.initial_excess = v.excess.iter().sum();
    Ok(())
}
