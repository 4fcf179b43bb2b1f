//! The flow system: `flow_substeps` advances the fracture network over a solid step with the
//! explicit scheme ([`hydrofrac_core::flow::explicit`]: N forward-Euler sub-steps) or the implicit one
//! ([`hydrofrac_core::flow::implicit`]: one backward-Euler step), coupled to the rock when the network
//! is the rock's fractures ([`crate::coupling`]). Also the flow part of the state and
//! the direct steady solve of `time.end: SteadyDirect`.

use crate::RunError;
use crate::coupling::Coupling;
use hydrofrac_core::error::SetupError;
pub use hydrofrac_core::flow::boundary::{
    FlowStats, MASS_ROUNDOFF, accumulate_boundary_volumes, boundary_flows, pump_operating_point,
};
pub use hydrofrac_core::flow::explicit::{CELL_CHUNK, flow_step};
use hydrofrac_core::flow::implicit::{ImplicitSolver, implicit_step};
use hydrofrac_core::flow::{FlowParams, FlowView, pressure_of};
use hydrofrac_core::network::CellNetwork;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::scenario::FlowScheme;

/// The fracture-network flow part of the state. A checkpoint saves it as it is (serde), less
/// the network table, which setup rebuilds from the scenario.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct FlowPart {
    pub view: FlowView,
    /// Flow sub-step, s, and sub-steps per step.
    pub dt: f64,
    pub substeps: u64,
    /// Explicit critical flow step, s (at the current network: a split rebuilds the view and
    /// this bound with it).
    pub dt_crit: f64,
    /// The explicit stability bound the last flow step's sub-step was chosen under and checked
    /// against, s: computed at that step's state, before any split of the same step changed the
    /// network (infinite for the implicit scheme).
    pub substep_bound: f64,
    pub stats: FlowStats,
    /// Fluid excess mass (above rho_r V) summed at the start, kg/m.
    pub initial_excess: f64,
    /// Steady residual of the last flow step ([`steady_residual`]); 1 before the first step
    /// (nothing measured yet: no balance claimed, so a static run cannot end on it).
    pub residual: f64,
    /// Network volume sum a L at the start, m^2 (volumes change in coupled runs).
    pub initial_volume: f64,
    /// The fractures the network was cut from (written to the output; empty in coupled runs;
    /// not saved: rebuilt by setup).
    #[serde(skip)]
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
            substep_bound: f64::INFINITY,
            substeps: 1,
            stats: FlowStats::default(),
            residual: 1.0,
            network,
            coupling: coupled.then(Coupling::default),
            // The quasi-static scheme's coupled step is backward Euler too (its pattern).
            implicit: (p.time.flow_scheme == FlowScheme::Implicit
                || p.time.solid_scheme == hydrofrac_core::scenario::SolidScheme::QuasiStatic)
                .then(ImplicitSolver::new),
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

/// `flow_substeps`: the network's flow over the solid step [t0, t0 + dt]. `opening(k)` is
/// solid joint k's normal opening, m (coupled runs; [`crate::coupling::opening_2d`] in 2D). Explicit: N
/// sub-steps, stopping at the first cell with negative or non-finite mass (reported by
/// `monitor`); implicit: one backward-Euler step. Coupled runs exchange apertures and face
/// pressures with the rock ([`Coupling`]). `step` is the number of the step being taken (for
/// error messages). Errors: a coupled explicit step that needs more than `time.max_substeps`
/// sub-steps, an explicit sub-step above the stability bound it was chosen under
/// ([`check_substep`]: a forced `time.flow_dt`), an implicit step whose Newton iteration fails.
pub fn flow_substeps(
    f: &mut FlowPart,
    opening: impl Fn(usize) -> f64,
    p: &RunParams,
    t0: f64,
    dt: f64,
    step: u64,
) -> Result<(), RunError> {
    let (specs, fp) = (&p.flow_boundaries, &p.fluid);
    let implicit_error = |e| RunError::ImplicitFlow {
        step,
        time: t0 + dt,
        source: Box::new(e),
    };
    if let Some(c) = f.coupling.as_mut() {
        let r = match f.implicit.as_mut() {
            Some(solver) => c
                .step_implicit(opening, &mut f.view, fp, specs, t0, dt, solver)
                .map_err(implicit_error)?,
            None => c
                .step(
                    opening,
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
        f.substep_bound = r.dt_crit;
        if f.implicit.is_none() {
            check_substep(f, fp, Some(r.critical_cell), step, t0 + dt)?;
        }
    } else if let Some(solver) = f.implicit.as_mut() {
        f.dt = dt;
        f.stats = implicit_step(&mut f.view, fp, specs, dt, t0, solver).map_err(implicit_error)?;
    } else {
        // Fixed apertures: the bound of the network as it is, the one the sub-step was chosen
        // from at setup (or a forced `time.flow_dt` that may exceed it).
        f.substep_bound = f.dt_crit;
        check_substep(f, fp, None, step, t0 + dt)?;
        for k in 0..f.substeps {
            f.stats = flow_step(&mut f.view, fp, specs, f.dt, t0 + k as f64 * f.dt);
            if f.stats.bad_cell.is_some() {
                break;
            }
        }
    }
    steady_residual(f);
    Ok(())
}

/// The one check of an explicit flow sub-step: `f.dt` must not exceed `f.substep_bound`, the
/// bound it was chosen under at the same state (relative slack 1e-9 for the rounding of
/// dt / N). Above it the scheme oscillates, and the P = 0 floor of unfilled cells can hold the
/// oscillation bounded, so it would not show up as a blow-up by itself. `cell` is the cell
/// that set the bound when known (else the network's critical cell now); `time` is the end of
/// the step, s.
pub fn check_substep(
    f: &FlowPart,
    fp: &FlowParams,
    cell: Option<usize>,
    step: u64,
    time: f64,
) -> Result<(), RunError> {
    if f.dt <= f.substep_bound * (1.0 + 1e-9) {
        return Ok(());
    }
    let c = cell
        .or_else(|| f.view.critical_cell(fp).map(|c| c.0))
        .unwrap_or(0);
    Err(RunError::BlowUp {
        step,
        time,
        entity: f.view.cell_label(c),
        quantity: "flow step",
        value: f.dt,
        why: format!(
            "above the cell's stability bound V/(K sum kappa) = {:.4e} s: unstable",
            f.substep_bound
        ),
        dt: f.dt,
    })
}

/// The steady residual of the last step: ||net inflow per cell|| / sum |boundary rates|. With
/// no boundary flow (a closed network, or rates that reached zero) the scale is the network's
/// throughput sum of the cells' flow rates instead (m^2/s), and 0 when nothing flows at all;
/// 1 when cells gain or lose fluid but neither scale is positive. Always finite for a finite
/// state.
pub fn steady_residual(f: &mut FlowPart) {
    let bc: f64 = f.view.bcs.iter().map(|b| b.rate.abs()).sum();
    let net = f.stats.net2.sqrt();
    let through: f64 = f.view.flow_rate.iter().sum();
    f.residual = if bc > 0.0 {
        net / bc
    } else if net == 0.0 {
        0.0
    } else if through > 0.0 {
        net / through
    } else {
        1.0
    };
}

/// `time.end: SteadyDirect`: solve the network's incompressible steady state directly and
/// store it as the current state (cell pressures, masses at those pressures, throughputs,
/// boundary pressures and rates). No time passes: the solved state is the mass balance's
/// reference.
pub fn steady_direct(f: &mut FlowPart, p: &RunParams, t: f64) -> Result<(), SetupError> {
    let mut solver = hydrofrac_core::flow::steady::SteadySolver::new();
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
