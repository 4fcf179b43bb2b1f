//! Hydro-mechanical coupling by sub-stepping (`docs/seed-method.md`, time stepping and flow
//! sub-stepping; D8 says where we differ from the seed).
//!
//! The solid takes one central-difference step of dt; the fracture network's flow takes N
//! explicit sub-steps of dt/N inside it, N chosen every solid step from the flow's critical step
//! at the step's apertures. Exchange per solid step:
//! - solid -> flow: every fracture cell's hydraulic aperture a = max(delta_n, a_r) (seed (12),
//!   [`hydrofrac_core::fractures::hydraulic_aperture`])
//!   from its joint's opening at the start and at the end of the step (the flow runs after
//!   `integrate`, so both are known); the sub-steps use the linear interpolation between them
//!   (the seed extrapolates from the previous step: the same scheme shifted by one step, with
//!   the end value measured rather than predicted). Volumes a L follow each sub-step with the
//!   fluid mass kept (the excess mass is rebased), so mass is conserved exactly as faces move;
//!   transmissibilities use the mid-step apertures.
//! - flow -> solid: the pressure averaged over the N sub-steps is the traction the
//!   `fluid_pressure` system applies to both faces of the cell in the next solid step.
//!
//! Cells created by a split join the network in the same step, empty (pressure zero until full,
//! seed (4)); the flow view is rebuilt from the components with the masses carried over.
//!
//! The fluid is a stiff spring on the fracture faces: an opening change d(delta) changes a full
//! cell's pressure by K d(delta)/a, a force K L/a d(delta) per face, stiffer than the joint
//! penalty for a = a_r. The solid's critical step includes it (see [`hydrofrac_core::stability::solid`]).

use crate::fracture::joint_frame;
use hecs::Entity;
use hydrofrac_core::flow::boundary::FlowStats;
use hydrofrac_core::flow::explicit::flow_step;
use hydrofrac_core::flow::{FlowParams, FlowView, pressure_of};
use hydrofrac_core::model::Model;
use hydrofrac_core::scenario::FlowBoundary;
use hydrofrac_core::view::SolidView;
use std::collections::HashMap;

/// Coupling maps and per-step state between the solid's joints and the flow's cells.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Coupling {
    /// Flow cell -> solid joint (dense indices; u32::MAX: the cell has no joint).
    pub cell_joint: Vec<u32>,
    /// Solid joint -> flow cell (u32::MAX: none).
    pub joint_cell: Vec<u32>,
    /// Mean pressure of each cell over the last step's sub-steps, Pa: the load of the next
    /// step's `fluid_pressure`.
    pub p_mean: Vec<f64>,
    /// Residual hydraulic aperture a_r, m.
    pub a_r: f64,
    /// Scratch: apertures at the start and end of the step (m), pressure sums (Pa).
    a_start: Vec<f64>,
    a_end: Vec<f64>,
    p_sum: Vec<f64>,
    kappa_sum: Vec<f64>,
}

/// Joint k's normal opening delta_n in a 2D view, m (the `opening` of [`Coupling::step`]).
pub fn opening_2d(solid: &SolidView) -> impl Fn(usize) -> f64 + '_ {
    move |k| joint_frame(solid, k).dn
}

/// What a coupled flow step did.
#[derive(Clone, Copy, Debug, Default)]
pub struct CoupledStep {
    pub stats: FlowStats,
    /// Sub-steps taken, their length (s) and the critical flow step at this step's apertures (s).
    pub substeps: u64,
    pub dt: f64,
    pub dt_crit: f64,
    /// The cell that set the critical step.
    pub critical_cell: usize,
}

/// The flow needs more sub-steps in one solid step than allowed.
#[derive(Clone, Copy, Debug)]
pub struct TooManySubsteps {
    pub needed: u64,
    pub dt_crit: f64,
    pub cell: usize,
}

impl Coupling {
    /// Maps for freshly built views; the mean pressures restart from the cells' pressures.
    pub fn build(
        model: &Model,
        solid: &SolidView,
        flow: &FlowView,
        p: &FlowParams,
        a_r: f64,
    ) -> Self {
        let cell_index: HashMap<Entity, u32> = flow
            .cell_entity
            .iter()
            .enumerate()
            .map(|(i, &e)| (e, i as u32))
            .collect();
        let mut cell_joint = vec![u32::MAX; flow.n_cells()];
        let mut joint_cell = vec![u32::MAX; solid.joint_entity.len()];
        for (k, &je) in solid.joint_entity.iter().enumerate() {
            let Ok(j) = model.world.get::<&hydrofrac_components::Joint>(je) else {
                continue;
            };
            if let Some(&c) = cell_index.get(&j.cell) {
                joint_cell[k] = c;
                cell_joint[c as usize] = k as u32;
            }
        }
        Self::from_map(cell_joint, joint_cell, flow, p, a_r)
    }

    /// Maps for freshly built 3D views: each cell's [`FaceCell`](hydrofrac_components::FaceCell)
    /// joint, as a dense joint index of the TET4 view.
    pub fn build_3d(
        model: &Model,
        joint_entity: &[Entity],
        flow: &FlowView,
        p: &FlowParams,
        a_r: f64,
    ) -> Self {
        let joint_index: HashMap<Entity, u32> = joint_entity
            .iter()
            .enumerate()
            .map(|(k, &e)| (e, k as u32))
            .collect();
        let mut cell_joint = vec![u32::MAX; flow.n_cells()];
        let mut joint_cell = vec![u32::MAX; joint_entity.len()];
        for (c, &ce) in flow.cell_entity.iter().enumerate() {
            let Ok(fc) = model.world.get::<&hydrofrac_components::FaceCell>(ce) else {
                continue;
            };
            if let Some(&k) = joint_index.get(&fc.0) {
                cell_joint[c] = k;
                joint_cell[k as usize] = c as u32;
            }
        }
        Self::from_map(cell_joint, joint_cell, flow, p, a_r)
    }

    /// The coupling of given maps: the mean pressures start from the cells' pressures.
    fn from_map(
        cell_joint: Vec<u32>,
        joint_cell: Vec<u32>,
        flow: &FlowView,
        p: &FlowParams,
        a_r: f64,
    ) -> Self {
        let nc = flow.n_cells();
        let mut p_mean: Vec<f64> = (0..nc)
            .map(|c| pressure_of(flow.excess[c], flow.volume[c], p))
            .collect();
        hydrofrac_core::flow::apply_filling_load(flow, p, &mut p_mean);
        Coupling {
            cell_joint,
            joint_cell,
            p_mean,
            a_r,
            a_start: vec![0.0; nc],
            a_end: vec![0.0; nc],
            p_sum: vec![0.0; nc],
            kappa_sum: vec![0.0; nc],
        }
    }

    /// Hydraulic apertures max(delta_n, a_r) of every cell from the solid's current positions
    /// (cells without a joint keep theirs), m. `opening(k)` is joint k's normal opening
    /// delta_n, m ([`opening_2d`] in 2D, `joint_frame_3d(..).dn` in 3D).
    pub fn apertures_now(&mut self, opening: impl Fn(usize) -> f64, flow: &FlowView) {
        for c in 0..flow.n_cells() {
            let k = self.cell_joint[c];
            self.a_end[c] = if k == u32::MAX {
                flow.aperture[c]
            } else {
                hydrofrac_core::fractures::hydraulic_aperture(opening(k as usize), self.a_r)
            };
        }
    }

    /// Transmissibilities at the mid-step apertures (a_start + a_end)/2, used through the step.
    fn mid_step_kappa(&self, flow: &mut FlowView, p: &FlowParams) {
        for c in 0..flow.n_cells() {
            flow.aperture[c] = 0.5 * (self.a_start[c] + self.a_end[c]);
        }
        flow.update_kappa(p);
    }

    /// One solid step of flow: N explicit sub-steps over [t0, t0 + dt] with apertures
    /// interpolated from the start (the flow view's) to the end (the solid's now). Leaves the
    /// view at the end apertures and the mean pressures in `p_mean`.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        opening: impl Fn(usize) -> f64,
        flow: &mut FlowView,
        p: &FlowParams,
        specs: &[FlowBoundary],
        t0: f64,
        dt: f64,
        safety: f64,
        max_substeps: u64,
    ) -> Result<CoupledStep, TooManySubsteps> {
        let nc = flow.n_cells();
        self.apertures_now(opening, flow);
        self.a_start.copy_from_slice(&flow.aperture);
        // Critical step over the step: transmissibilities at the larger aperture of the two,
        // volumes at the smaller (kappa grows and V shrinks monotonically along the path).
        for c in 0..nc {
            flow.aperture[c] = self.a_start[c].max(self.a_end[c]);
        }
        flow.update_kappa(p);
        flow.kappa_sums(&mut self.kappa_sum);
        let (mut dt_crit, mut critical_cell) = (f64::INFINITY, 0);
        for c in 0..nc {
            if self.kappa_sum[c] > 0.0 {
                let v = flow.length[c] * self.a_start[c].min(self.a_end[c]);
                let b = hydrofrac_core::stability::flow_cell(v, p.k, self.kappa_sum[c]);
                if b < dt_crit {
                    (dt_crit, critical_cell) = (b, c);
                }
            }
        }
        let n = if dt_crit.is_finite() {
            ((dt / (safety * dt_crit)) * (1.0 - 1e-12)).ceil().max(1.0)
        } else {
            1.0
        };
        if n > max_substeps as f64 {
            for c in 0..nc {
                flow.aperture[c] = self.a_start[c];
            }
            flow.update_kappa(p);
            return Err(TooManySubsteps {
                needed: n.min(u64::MAX as f64) as u64,
                dt_crit,
                cell: critical_cell,
            });
        }
        let n = n as u64;
        let dtf = dt / n as f64;
        self.mid_step_kappa(flow, p);
        self.p_sum.iter_mut().for_each(|s| *s = 0.0);
        let mut stats = FlowStats::default();
        for k in 0..n {
            if k > 0 {
                let s = k as f64 / n as f64;
                for c in 0..nc {
                    let a = self.a_start[c] + s * (self.a_end[c] - self.a_start[c]);
                    flow.set_volume_keep_mass(c, flow.length[c] * a, p);
                }
            }
            stats = flow_step(flow, p, specs, dtf, t0 + k as f64 * dtf);
            for c in 0..nc {
                self.p_sum[c] += flow.pressure[c];
            }
            if stats.bad_cell.is_some() {
                break;
            }
        }
        for c in 0..nc {
            flow.aperture[c] = self.a_end[c];
            flow.set_volume_keep_mass(c, flow.length[c] * self.a_end[c], p);
            self.p_mean[c] = self.p_sum[c] / n as f64;
        }
        hydrofrac_core::flow::apply_filling_load(flow, p, &mut self.p_mean);
        Ok(CoupledStep {
            stats,
            substeps: n,
            dt: dtf,
            dt_crit,
            critical_cell,
        })
    }
}

impl Coupling {
    /// One solid step of flow with the implicit scheme (`time.flow_scheme: Implicit`): the
    /// volumes move to the end-of-step apertures with the fluid mass kept, the
    /// transmissibilities take the mid-step apertures, and one backward-Euler step of dt
    /// follows. The end-of-step pressures are the next step's face load.
    #[allow(clippy::too_many_arguments)]
    pub fn step_implicit(
        &mut self,
        opening: impl Fn(usize) -> f64,
        flow: &mut FlowView,
        p: &FlowParams,
        specs: &[FlowBoundary],
        t0: f64,
        dt: f64,
        solver: &mut hydrofrac_core::flow::implicit::ImplicitSolver,
    ) -> Result<CoupledStep, hydrofrac_core::flow::implicit::ImplicitError> {
        let nc = flow.n_cells();
        self.apertures_now(opening, flow);
        self.a_start.copy_from_slice(&flow.aperture);
        self.mid_step_kappa(flow, p);
        for c in 0..nc {
            flow.aperture[c] = self.a_end[c];
            flow.set_volume_keep_mass(c, flow.length[c] * self.a_end[c], p);
        }
        let stats = hydrofrac_core::flow::implicit::implicit_step(flow, p, specs, dt, t0, solver)?;
        self.p_mean.copy_from_slice(&flow.pressure);
        hydrofrac_core::flow::apply_filling_load(flow, p, &mut self.p_mean);
        Ok(CoupledStep {
            stats,
            substeps: 1,
            dt,
            dt_crit: f64::INFINITY,
            critical_cell: 0,
        })
    }
}
