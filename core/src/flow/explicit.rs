//! Explicit (forward Euler) finite-volume step of the fracture network with pump, rate and
//! pressure boundaries (seed (1)-(6), `docs/seed-method.md`). Pair fluxes are computed per pair
//! and gathered per cell through a CSR incidence list (no atomics), so results are the same
//! bits for any thread count. Stable below [`crate::stability::flow_cell`] per cell.

use crate::flow::boundary::{
    FlowStats, MASS_ROUNDOFF, accumulate_boundary_volumes, boundary_flows,
};
use crate::flow::{FlowParams, FlowView, kahan_add, pressure_of};
use crate::scenario::FlowBoundary;
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
