//! Fracture-network flow: the dense flow view (cells, pairs, boundaries) and its parameters.
//!
//! Finite volumes, one per cell (fracture segment), per unit thickness. Equations (seed (1)-(4),
//! with the corrections D1-D5 of `docs/seed-method.md`):
//! - transmissibility between cells i and j sharing a node:
//!   kappa_ij = 1 / (6 mu (L_i / a_i^3 + L_j / a_j^3))   (m^2/(Pa s)), the harmonic form of (1)+(2);
//! - volumetric flow from i to j: q_ij = kappa_ij (P_i - P_j)   (m^2/s);
//! - pressure: P = K (rho/rho_r - 1) for rho > rho_r, else 0 (a cell is pressurised once full);
//! - mass: dm_i/dt = rho_r * (sum of volumetric inflows). Fluid is carried at the reference
//!   density, so the steady state is exactly the incompressible network solution and mass is
//!   conserved to round-off; the error against carrying rho_upwind is O(P/K) (< 1 % below 20 MPa).
//! - a boundary at a node connects to every cell there, at a cell to that cell, through half
//!   the cell's length: kappa_b = a^3 / (6 mu L).

pub mod boundary;
pub mod explicit;
pub mod faces;
pub mod implicit;
pub mod steady;

use crate::model::Model;
use crate::scenario::{Filling, FlowBcKind, FlowBoundary, Fluid, Transmissibility};
use hecs::Entity;
use hydrofrac_components::*;

/// Fluid constants used by the flow kernels.
#[derive(Clone, Copy, Debug)]
pub struct FlowParams {
    /// Viscosity mu, Pa s.
    pub mu: f64,
    /// Bulk modulus K, Pa.
    pub k: f64,
    /// Reference density rho_r, kg/m^3.
    pub rho_r: f64,
    /// How two cells' apertures give their transmissibility.
    pub transmissibility: Transmissibility,
    /// The face load of a filling cell.
    pub filling: Filling,
}

impl From<Fluid> for FlowParams {
    fn from(f: Fluid) -> Self {
        FlowParams {
            mu: f.viscosity,
            k: f.bulk_modulus,
            rho_r: f.density,
            transmissibility: f.transmissibility,
            filling: f.filling,
        }
    }
}

impl FlowParams {
    /// The transmissibility of two cells (lengths m, apertures m) by `self.transmissibility`:
    /// [`pair_kappa`] or [`pair_kappa_linear`], m^2/(Pa s).
    #[inline(always)]
    pub fn pair_kappa(&self, li: f64, ai: f64, lj: f64, aj: f64) -> f64 {
        match self.transmissibility {
            Transmissibility::CellMean => pair_kappa(li, ai, lj, aj, self.mu),
            Transmissibility::LinearOpening => pair_kappa_linear(li, ai, lj, aj, self.mu),
        }
    }

    /// d kappa / d a_i and d kappa / d a_j of [`FlowParams::pair_kappa`] at `kappa`, its value,
    /// m^2/(Pa s) per m (the Newton matrix of the coupled quasi-static step).
    pub fn pair_kappa_slopes(&self, kappa: f64, li: f64, ai: f64, lj: f64, aj: f64) -> [f64; 2] {
        match self.transmissibility {
            Transmissibility::CellMean => [
                pair_kappa_slope(kappa, li, ai, self.mu),
                pair_kappa_slope(kappa, lj, aj, self.mu),
            ],
            Transmissibility::LinearOpening => {
                pair_kappa_linear_slopes(kappa, li, ai, lj, aj, self.mu)
            }
        }
    }
}

impl FlowParams {
    /// The density of the fluid at pressure p (Pa), kg/m^3: rho_r (1 + p / K), the inverse of
    /// [`pressure_of`] for a full cell (a cell filled at p holds this density times its volume).
    pub fn density_at(&self, p: f64) -> f64 {
        self.rho_r * (1.0 + p / self.k)
    }
}

/// Pressure of a cell from its excess mass e = m - rho_r V (kg/m) and volume V (m^2), Pa:
/// equation (4) corrected, P = K (rho/rho_r - 1) = K e / (rho_r V) when the cell is full (e > 0),
/// else 0. Working with the excess keeps full relative precision in P; with the total mass the
/// subtraction of 1 limits P to steps of K * 2.2e-16 = 5e-7 Pa, which floors steady residuals.
#[inline(always)]
pub fn pressure_of(excess: f64, volume: f64, p: &FlowParams) -> f64 {
    if excess > 0.0 {
        p.k * excess / (p.rho_r * volume)
    } else {
        0.0
    }
}

/// The face pressure of cell `c` with [`Filling::FrontInCell`] while the fluid fills it (its
/// excess mass below zero), Pa: the filled fraction f = 1 + e / (rho_r V) carries a pressure
/// falling linearly from its highest neighbouring pressure P_u to zero at the front, the rest
/// none, so the face's mean is f P_u / 2. `None` for a full cell (its face carries its
/// pressure) and with [`Filling::Dry`].
pub fn filling_face_pressure(v: &FlowView, p: &FlowParams, c: usize) -> Option<f64> {
    if p.filling == Filling::Dry || v.excess[c] >= 0.0 {
        return None;
    }
    let filled = (1.0 + v.excess[c] / (p.rho_r * v.volume[c])).clamp(0.0, 1.0);
    let p_u = v.inc[v.inc_ptr[c] as usize..v.inc_ptr[c + 1] as usize]
        .iter()
        .map(|&e| {
            let pr = v.pairs[(e >> 1) as usize];
            v.pressure[pr[1 - (e & 1) as usize] as usize]
        })
        .fold(0.0, f64::max);
    Some(0.5 * filled * p_u)
}

/// Overwrite the face pressures `out` (per cell, Pa) of the filling cells with
/// [`filling_face_pressure`] (nothing with [`Filling::Dry`]).
pub fn apply_filling_load(v: &FlowView, p: &FlowParams, out: &mut [f64]) {
    if p.filling == Filling::Dry {
        return;
    }
    for (c, o) in out.iter_mut().enumerate() {
        if let Some(f) = filling_face_pressure(v, p, c) {
            *o = f;
        }
    }
}

/// Transmissibility between two cells, m^2/(Pa s).
#[inline(always)]
pub fn pair_kappa(li: f64, ai: f64, lj: f64, aj: f64, mu: f64) -> f64 {
    1.0 / (6.0 * mu * (li / (ai * ai * ai) + lj / (aj * aj * aj)))
}

/// d kappa / d a_s of a pair's [`pair_kappa`] for one of its cells s (length l, aperture a):
/// 18 mu kappa^2 l / a^4, m^2/(Pa s) per m (the Newton matrix of the coupled quasi-static step).
pub fn pair_kappa_slope(kappa: f64, l: f64, a: f64, mu: f64) -> f64 {
    18.0 * mu * kappa * kappa * l / (a * a * a * a)
}

/// Transmissibility between two cells whose opening varies linearly from each centre to the
/// shared node, where it is a_n = (a_i L_j + a_j L_i) / (L_i + L_j), m^2/(Pa s): the cubic law
/// dP/ds = 12 mu q / a(s)^3 integrated over a half-cell (length L/2) from a to a_n gives the
/// resistance 3 mu L (a + a_n) / (a^2 a_n^2), and kappa = 1 / (R_i + R_j)
/// ([`crate::scenario::Transmissibility::LinearOpening`]). Equal apertures give [`pair_kappa`].
#[inline(always)]
pub fn pair_kappa_linear(li: f64, ai: f64, lj: f64, aj: f64, mu: f64) -> f64 {
    let an = (ai * lj + aj * li) / (li + lj);
    let half = |l: f64, a: f64| l * (a + an) / (a * a * an * an);
    1.0 / (3.0 * mu * (half(li, ai) + half(lj, aj)))
}

/// d kappa / d a_i and d kappa / d a_j of [`pair_kappa_linear`] at its value `kappa`:
/// -kappa^2 dR/da_s, with R_s = 3 mu L_s (a_s + a_n) / (a_s^2 a_n^2),
/// dR_s/da_s = -3 mu L_s (a_s + 2 a_n) / (a_s^3 a_n^2) at fixed a_n,
/// dR_s/da_n = -3 mu L_s (2 a_s + a_n) / (a_s^2 a_n^3), da_n/da_i = L_j / (L_i + L_j) and
/// da_n/da_j = L_i / (L_i + L_j).
pub fn pair_kappa_linear_slopes(
    kappa: f64,
    li: f64,
    ai: f64,
    lj: f64,
    aj: f64,
    mu: f64,
) -> [f64; 2] {
    let an = (ai * lj + aj * li) / (li + lj);
    let d_self = |l: f64, a: f64| -3.0 * mu * l * (a + 2.0 * an) / (a * a * a * an * an);
    let d_node = |l: f64, a: f64| -3.0 * mu * l * (2.0 * a + an) / (a * a * an * an * an);
    let dn = d_node(li, ai) + d_node(lj, aj);
    let (wi, wj) = (lj / (li + lj), li / (li + lj));
    [
        -kappa * kappa * (d_self(li, ai) + dn * wi),
        -kappa * kappa * (d_self(lj, aj) + dn * wj),
    ]
}

/// Transmissibility from a boundary to a cell through half its length, m^2/(Pa s).
#[inline(always)]
pub fn half_cell_kappa(l: f64, a: f64, mu: f64) -> f64 {
    a * a * a / (6.0 * mu * l)
}

/// A flow boundary in dense form.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct BcView {
    pub entity: Entity,
    /// Index into the scenario's `flow_boundaries`.
    pub index: usize,
    pub kind: FlowBcKind,
    /// Cells it connects to, their transmissibilities and the flow into each at the last step.
    pub cells: Vec<u32>,
    pub kappa: Vec<f64>,
    pub q_cells: Vec<f64>,
    /// 3D only (empty in 2D): per connected cell its half-cell length l and width w, m
    /// (`faces::node_connection`, `faces::cell_connection`); the connection is w times the 2D
    /// half-cell form at l.
    pub geom: Vec<[f64; 2]>,
    /// Scratch: the connected cells' pressures at the current step (no allocation per step).
    pub p_cells: Vec<f64>,
    /// Boundary pressure (Pa), total rate into the network (m^2/s), cumulative volumes (m^2).
    pub pressure: f64,
    pub rate: f64,
    pub volume_in: f64,
    pub volume_out: f64,
    /// Kahan compensations of the two volumes.
    pub comp_in: f64,
    pub comp_out: f64,
}

impl BcView {
    /// The dense form of boundary entity `entity` with state `b`, joined to `cells` (with their
    /// 3D connection geometry `geom`, empty in 2D); its kind is set by
    /// [`FlowView::set_bc_kinds`].
    pub fn new(entity: Entity, b: &FlowBc, cells: Vec<u32>, geom: Vec<[f64; 2]>) -> Self {
        let n = cells.len();
        BcView {
            entity,
            index: b.index,
            kind: FlowBcKind::Pressure(0.0),
            q_cells: vec![0.0; n],
            p_cells: vec![0.0; n],
            kappa: vec![0.0; n],
            geom,
            cells,
            pressure: b.pressure,
            rate: b.rate,
            volume_in: b.volume_in,
            volume_out: b.volume_out,
            comp_in: 0.0,
            comp_out: 0.0,
        }
    }
}

/// The model's flow boundaries in stable-id order, with their entities.
pub(crate) fn boundaries(model: &Model) -> Vec<(Entity, FlowBc)> {
    let mut bcs: Vec<(u64, Entity, FlowBc)> = model
        .world
        .query::<(Entity, &StableId, &FlowBc)>()
        .iter()
        .map(|(e, id, b)| (id.0, e, *b))
        .collect();
    bcs.sort_unstable_by_key(|b| b.0);
    bcs.into_iter().map(|(_, e, b)| (e, b)).collect()
}

/// Kahan-compensated `*sum += x` with compensation `c`.
#[inline(always)]
pub fn kahan_add(sum: &mut f64, c: &mut f64, x: f64) {
    let y = x - *c;
    let t = *sum + y;
    *c = (t - *sum) - y;
    *sum = t;
}

/// The network as flat arrays, cells ordered by stable id.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct FlowView {
    pub generation: u64,
    pub cell_entity: Vec<Entity>,
    pub cell_id: Vec<u64>,
    /// Dense node indices of each cell's ends (2D; empty in 3D).
    pub cell_nodes: Vec<[u32; 2]>,
    /// 3D only (empty in 2D): each cell's triangle corners in the reference geometry, m.
    pub corners: Vec<[[f64; 3]; 3]>,
    pub node_entity: Vec<Entity>,
    /// Current node positions, m (for output).
    pub node_pos: Vec<[f64; 2]>,
    /// Reference node positions, m: cell lengths come from these, so a cell's volume changes
    /// only with its aperture (with K = 2.2 GPa, a length strain of 1e-3 would move the
    /// pressure of a full cell by 2 MPa).
    pub node_ref: Vec<[f64; 2]>,
    /// Length L (m), aperture a (m), volume a L (m^2), pressure (Pa), throughput (m^2/s).
    /// In 3D a cell is a triangle and everything is per cell rather than per metre: `length`
    /// holds its area A (m^2), the volume is a A (m^3), masses are kg and rates m^3/s.
    pub length: Vec<f64>,
    pub aperture: Vec<f64>,
    pub volume: Vec<f64>,
    /// Fluid mass above the reference mass rho_r V, kg/m (negative while the cell fills); the
    /// cell's mass is `excess + rho_r * volume`.
    pub excess: Vec<f64>,
    /// Kahan compensation of `excess` (the low-order bits lost by the running sum): it is
    /// accumulated over millions of sub-steps and the balance is checked to 1e-12.
    pub excess_comp: Vec<f64>,
    pub pressure: Vec<f64>,
    pub flow_rate: Vec<f64>,
    pub kind: Vec<CellKind>,
    pub created_t: Vec<f64>,
    /// Cell pairs that exchange fluid (every two cells meeting at a node), their
    /// transmissibility and the flow from the first to the second at the last step.
    pub pairs: Vec<[u32; 2]>,
    pub kappa: Vec<f64>,
    pub pair_q: Vec<f64>,
    /// 3D only (empty in 2D): per pair the half-cell lengths l_i, l_j (twice each triangle's
    /// distance to the shared edge, `faces::triangle_cells`, m) and the edge's length w (m). The pair's
    /// transmissibility is w times the 2D form at l_i, l_j (for `CellMean`
    /// w / (12 mu (d_i / a_i^3 + d_j / a_j^3)), the cubic law over the two half-cells, m^3/(Pa s)).
    pub pair_geom: Vec<[f64; 3]>,
    /// Cell -> (pair * 2 + side) incidence, CSR; side 0: the cell is the pair's first.
    pub inc_ptr: Vec<u32>,
    pub inc: Vec<u32>,
    /// Boundary inflow per cell at the last step, m^2/s.
    pub bc_in: Vec<f64>,
    pub bcs: Vec<BcView>,
    /// For output, per cell (empty until [`FlowView::attach_joints`]): the joint's normal
    /// stress F_n/L (Pa, tension positive: contact compression is negative), shear stress
    /// F_t/L (Pa) and sliding flag (1 sliding, 0 not; NaN for a cell without a joint).
    pub joint_stress: Vec<[f64; 3]>,
    /// Output only, from [`FlowView::attach_joints`]: per cell the joint's mechanical opening
    /// delta_n and shear slip delta_t (m); a cell without a joint has its aperture and 0.
    pub kinematics: Vec<[f64; 2]>,
}

impl FlowView {
    /// Build from the model's cells, nodes and flow boundaries.
    pub fn build(model: &Model, p: &FlowParams) -> Self {
        let world = &model.world;
        let mut cells: Vec<(u64, Entity, CellNodes, CellFluid, CellOrigin)> = world
            .query::<(Entity, &StableId, &CellNodes, &CellFluid, &CellOrigin)>()
            .iter()
            .map(|(e, id, n, f, o)| (id.0, e, *n, *f, *o))
            .collect();
        cells.sort_unstable_by_key(|c| c.0);
        // Nodes used by cells, ordered by stable id.
        let mut nodes: Vec<(u64, Entity, [f64; 2], [f64; 2])> = cells
            .iter()
            .flat_map(|c| c.2.0)
            .map(|n| {
                let id = world.get::<&StableId>(n).expect("node").0;
                let x = world.get::<&NodeRef>(n).expect("node").0;
                let u = world.get::<&NodeState>(n).expect("node").u;
                (id, n, [x[0] + u[0], x[1] + u[1]], x)
            })
            .collect();
        nodes.sort_unstable_by_key(|n| n.0);
        nodes.dedup_by_key(|n| n.0);
        let max_index = world
            .iter()
            .map(|e| e.entity().id())
            .max()
            .map_or(0, |m| m as usize + 1);
        let mut dense = vec![u32::MAX; max_index];
        let mut v = FlowView {
            generation: model.topology_generation,
            ..Default::default()
        };
        for (i, (_, e, x, r)) in nodes.iter().enumerate() {
            dense[e.id() as usize] = i as u32;
            v.node_entity.push(*e);
            v.node_pos.push(*x);
            v.node_ref.push(*r);
        }
        let mut cell_dense = vec![u32::MAX; max_index];
        for (i, (id, e, n, f, o)) in cells.iter().enumerate() {
            cell_dense[e.id() as usize] = i as u32;
            v.cell_entity.push(*e);
            v.cell_id.push(*id);
            v.cell_nodes.push(n.0.map(|x| dense[x.id() as usize]));
            v.push_cell_state(f, o);
        }
        let nc = v.cell_entity.len();
        v.length = vec![0.0; nc];
        v.finish_cells(p);
        // Pairs: at every node, every two cells that meet there.
        let mut at_node: Vec<Vec<u32>> = vec![Vec::new(); v.node_pos.len()];
        for (c, n) in v.cell_nodes.iter().enumerate() {
            at_node[n[0] as usize].push(c as u32);
            if n[1] != n[0] {
                at_node[n[1] as usize].push(c as u32);
            }
        }
        let mut pairs = Vec::new();
        for cs in &at_node {
            for a in 0..cs.len() {
                for b in a + 1..cs.len() {
                    pairs.push([cs[a], cs[b]]);
                }
            }
        }
        v.set_pairs(pairs);
        for (e, b) in boundaries(model) {
            let cells: Vec<u32> = match b.target {
                FlowBcTarget::Node(n) => {
                    let d = dense.get(n.id() as usize).copied().unwrap_or(u32::MAX);
                    if d == u32::MAX {
                        Vec::new()
                    } else {
                        at_node[d as usize].clone()
                    }
                }
                FlowBcTarget::Cell(c) => vec![cell_dense[c.id() as usize]],
            };
            v.bcs.push(BcView::new(e, &b, cells, Vec::new()));
        }
        v.update_kappa(p);
        v
    }

    /// Append a cell's fluid state and origin (its geometry is set apart).
    pub(crate) fn push_cell_state(&mut self, f: &CellFluid, o: &CellOrigin) {
        self.aperture.push(f.aperture);
        self.excess.push(f.mass);
        self.pressure.push(f.pressure);
        self.flow_rate.push(f.flow_rate);
        self.kind.push(o.kind);
        self.created_t.push(o.created_t);
    }

    /// With every cell pushed and `length` set: the volumes, the zeroed per-cell scratch, and
    /// the masses as excess over rho_r V.
    pub(crate) fn finish_cells(&mut self, p: &FlowParams) {
        let nc = self.cell_entity.len();
        self.volume = vec![0.0; nc];
        self.bc_in = vec![0.0; nc];
        self.excess_comp = vec![0.0; nc];
        self.update_geometry();
        for c in 0..nc {
            self.excess[c] -= p.rho_r * self.volume[c];
        }
    }

    /// Set the pairs, their incidence per cell and their zeroed flows.
    pub(crate) fn set_pairs(&mut self, pairs: Vec<[u32; 2]>) {
        let nc = self.cell_entity.len();
        self.pairs = pairs;
        (self.inc_ptr, self.inc) =
            crate::view::incidence(nc, &self.pairs, |k, side| (2 * k + side) as u32);
        self.pair_q = vec![0.0; self.pairs.len()];
    }

    /// Attach the scenario's boundary kinds (kept out of the ECS: they are inputs).
    pub fn set_bc_kinds(&mut self, specs: &[FlowBoundary]) {
        for b in &mut self.bcs {
            b.kind = specs[b.index].kind;
        }
    }

    pub fn n_cells(&self) -> usize {
        self.cell_entity.len()
    }

    /// Lengths (reference positions) and volumes from the apertures. A 3D view's areas are set
    /// once when it is built.
    pub fn update_geometry(&mut self) {
        for c in 0..self.cell_nodes.len() {
            let [a, b] = self.cell_nodes[c].map(|n| self.node_ref[n as usize]);
            self.length[c] = (b[0] - a[0]).hypot(b[1] - a[1]);
        }
        for c in 0..self.length.len() {
            self.volume[c] = self.aperture[c] * self.length[c];
        }
    }

    /// Transmissibilities of pairs and boundary connections from the current apertures.
    pub fn update_kappa(&mut self, p: &FlowParams) {
        self.update_pair_kappa(p);
        self.update_bc_kappa(p);
    }

    /// The pairs' transmissibilities at the current apertures (see [`FlowView::update_kappa`]).
    pub fn update_pair_kappa(&mut self, p: &FlowParams) {
        self.kappa.resize(self.pairs.len(), 0.0);
        if !self.pair_geom.is_empty() {
            for (k, pr) in self.pairs.iter().enumerate() {
                let (i, j) = (pr[0] as usize, pr[1] as usize);
                let [li, lj, w] = self.pair_geom[k];
                self.kappa[k] = w * p.pair_kappa(li, self.aperture[i], lj, self.aperture[j]);
            }
            return;
        }
        for (k, pr) in self.pairs.iter().enumerate() {
            let (i, j) = (pr[0] as usize, pr[1] as usize);
            self.kappa[k] = p.pair_kappa(
                self.length[i],
                self.aperture[i],
                self.length[j],
                self.aperture[j],
            );
        }
    }

    /// The boundaries' half-cell transmissibilities at the current apertures.
    pub fn update_bc_kappa(&mut self, p: &FlowParams) {
        for b in &mut self.bcs {
            for (k, &c) in b.cells.iter().enumerate() {
                let a = self.aperture[c as usize];
                b.kappa[k] = match b.geom.get(k) {
                    Some(&[l, w]) => w * half_cell_kappa(l, a, p.mu),
                    None => half_cell_kappa(self.length[c as usize], a, p.mu),
                };
            }
        }
    }

    /// Explicit critical step, s: min over cells of [`crate::stability::flow_cell`], the
    /// Gershgorin bound V_i / (K sum of the cell's transmissibilities, pairs and boundaries).
    /// For a chain of equal cells it equals the seed's 6 mu/K (L/a)^2
    /// (`docs/seed-method.md` (6)); 2 V_i/(K sum kappa) would be twice the chain limit (D5).
    pub fn critical_step(&self, p: &FlowParams) -> f64 {
        self.critical_cell(p).map_or(f64::INFINITY, |c| c.1)
    }

    /// Sum of each cell's transmissibilities (pairs and boundaries) into `sum`, m^2/(Pa s).
    pub fn kappa_sums(&self, sum: &mut [f64]) {
        sum.iter_mut().for_each(|s| *s = 0.0);
        for (k, pr) in self.pairs.iter().enumerate() {
            sum[pr[0] as usize] += self.kappa[k];
            sum[pr[1] as usize] += self.kappa[k];
        }
        for b in &self.bcs {
            for (k, &c) in b.cells.iter().enumerate() {
                sum[c as usize] += b.kappa[k];
            }
        }
    }

    /// The cell with the smallest stability bound and that bound, s.
    pub fn critical_cell(&self, p: &FlowParams) -> Option<(usize, f64)> {
        let mut sum = vec![0.0; self.n_cells()];
        self.kappa_sums(&mut sum);
        (0..self.n_cells())
            .filter(|&c| sum[c] > 0.0)
            .map(|c| (c, crate::stability::flow_cell(self.volume[c], p.k, sum[c])))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// 3D: cell c's triangle centroid in the reference geometry, m (`None` in 2D).
    pub fn centroid(&self, c: usize) -> Option<[f64; 3]> {
        let x = self.corners.get(c)?;
        Some(std::array::from_fn(|d| (x[0][d] + x[1][d] + x[2][d]) / 3.0))
    }

    /// "cell ID at (x, y) m" (3D: (x, y, z)) for messages.
    pub fn cell_label(&self, c: usize) -> String {
        if let Some(x) = self.centroid(c) {
            return format!(
                "cell {} at ({:.4}, {:.4}, {:.4}) m",
                self.cell_id[c], x[0], x[1], x[2]
            );
        }
        let [a, b] = self.cell_nodes[c].map(|n| self.node_pos[n as usize]);
        format!(
            "cell {} at ({:.4}, {:.4}) m",
            self.cell_id[c],
            0.5 * (a[0] + b[0]),
            0.5 * (a[1] + b[1])
        )
    }

    /// Cells connected through pairs to any of `seeds`.
    pub fn grounded_cells(&self, seeds: &[u32]) -> Vec<bool> {
        let mut seen = vec![false; self.n_cells()];
        let mut stack: Vec<u32> = seeds.to_vec();
        while let Some(c) = stack.pop() {
            if std::mem::replace(&mut seen[c as usize], true) {
                continue;
            }
            for &e in
                &self.inc[self.inc_ptr[c as usize] as usize..self.inc_ptr[c as usize + 1] as usize]
            {
                let pr = self.pairs[(e >> 1) as usize];
                let other = pr[1 - (e & 1) as usize];
                if !seen[other as usize] {
                    stack.push(other);
                }
            }
        }
        seen
    }

    /// Fill `joint_stress` (normal stress, tension positive, and shear stress, Pa; 1 if the
    /// joint slid since the last frame) and `kinematics` from the joints' components (state as
    /// of the last sync).
    pub fn attach_joints(&mut self, model: &Model) {
        let index: std::collections::HashMap<Entity, usize> = self
            .cell_entity
            .iter()
            .enumerate()
            .map(|(i, &e)| (e, i))
            .collect();
        self.joint_stress = vec![[f64::NAN; 3]; self.n_cells()];
        self.kinematics = self.aperture.iter().map(|&a| [a, 0.0]).collect();
        for (j, st) in model.world.query::<(&Joint, &JointState)>().iter() {
            if let Some(&c) = index.get(&j.cell) {
                let len = self.length[c].max(f64::MIN_POSITIVE);
                self.joint_stress[c] = [
                    -st.normal_force / len,
                    st.shear_force / len,
                    if st.slid { 1.0 } else { 0.0 },
                ];
                self.kinematics[c] = [st.opening, st.last_shear_offset];
            }
        }
    }

    /// Current node positions (reference + displacement) from the components, m.
    pub fn refresh_positions(&mut self, model: &Model) {
        for (i, &n) in self.node_entity.iter().enumerate() {
            if let (Ok(x), Ok(st)) = (
                model.world.get::<&NodeRef>(n),
                model.world.get::<&NodeState>(n),
            ) {
                self.node_pos[i] = [x.0[0] + st.u[0], x.0[1] + st.u[1]];
            }
        }
    }

    /// Set cell c's volume to `volume` (m^2) keeping its fluid mass: the excess mass
    /// e = m - rho_r V moves by rho_r (V_old - V_new) (Kahan-compensated).
    #[inline]
    pub fn set_volume_keep_mass(&mut self, c: usize, volume: f64, p: &FlowParams) {
        let d = p.rho_r * (self.volume[c] - volume);
        kahan_add(&mut self.excess[c], &mut self.excess_comp[c], d);
        self.volume[c] = volume;
    }

    /// Fluid volume at reference density, m^2.
    pub fn stored_volume(&self, p: &FlowParams) -> f64 {
        self.excess.iter().sum::<f64>() / p.rho_r + self.volume.iter().sum::<f64>()
    }

    /// Copy the cell and boundary state back into the components.
    pub fn write_back(&self, model: &mut Model, p: &FlowParams) {
        let mut view = model.world.view_mut::<&mut CellFluid>();
        for (i, &e) in self.cell_entity.iter().enumerate() {
            if let Some(f) = view.get_mut(e) {
                f.aperture = self.aperture[i];
                f.mass = self.excess[i] + p.rho_r * self.volume[i];
                f.pressure = self.pressure[i];
                f.flow_rate = self.flow_rate[i];
            }
        }
        let mut view = model.world.view_mut::<&mut FlowBc>();
        for b in &self.bcs {
            if let Some(s) = view.get_mut(b.entity) {
                s.pressure = b.pressure;
                s.rate = b.rate;
                s.volume_in = b.volume_in;
                s.volume_out = b.volume_out;
            }
        }
    }
}

/// Result of a direct steady solve of the network.
#[derive(Clone, Debug)]
pub struct SteadyNetwork {
    /// Cell pressures, Pa.
    pub pressure: Vec<f64>,
    /// Per boundary (view order): boundary pressure (Pa) and rate into the network (m^2/s).
    pub boundaries: Vec<(f64, f64)>,
    /// Relative residual of the linear solve.
    pub residual: f64,
}

/// Errors of the direct steady solve.
#[derive(Debug, thiserror::Error)]
pub enum SteadyNetworkError {
    #[error(
        "the steady solver takes pressure and rate boundaries; boundary {0} is a pump (run the explicit solver to steady state instead)"
    )]
    Pump(String),
    #[error(transparent)]
    Solve(#[from] steady::SteadyError),
}

impl FlowView {
    /// Incompressible steady state of the network with its pressure and rate boundaries at time
    /// t (schedules applied), by a sparse direct solve (faer Cholesky). A rate boundary becomes
    /// one extra unknown (its boundary pressure) joined to its cells by their half-cell
    /// transmissibilities and fed by the rate. The explicit solver's steady state satisfies the
    /// same linear equations, so the two agree to the explicit run's convergence.
    pub fn solve_steady(
        &self,
        solver: &mut steady::SteadySolver,
        specs: &[FlowBoundary],
        names: impl Fn(usize) -> String,
        t: f64,
    ) -> Result<SteadyNetwork, SteadyNetworkError> {
        let nc = self.n_cells();
        let mut pairs: Vec<(u32, u32, f64)> = self
            .pairs
            .iter()
            .zip(&self.kappa)
            .map(|(p, &k)| (p[0], p[1], k))
            .collect();
        let mut dirichlet = Vec::new();
        let mut sources = Vec::new();
        let mut extra = nc as u32;
        let mut rate_unknown = vec![None; self.bcs.len()];
        for (bi, b) in self.bcs.iter().enumerate() {
            let f = specs[b.index].factor(t);
            match b.kind {
                FlowBcKind::Pressure(p) => {
                    for (k, &c) in b.cells.iter().enumerate() {
                        dirichlet.push((c, b.kappa[k], f * p));
                    }
                }
                FlowBcKind::Rate(q) => {
                    for (k, &c) in b.cells.iter().enumerate() {
                        pairs.push((extra, c, b.kappa[k]));
                    }
                    sources.push((extra, f * q));
                    rate_unknown[bi] = Some(extra);
                    extra += 1;
                }
                FlowBcKind::Pump { .. } => return Err(SteadyNetworkError::Pump(names(b.index))),
            }
        }
        let sol = solver.solve(&steady::SteadyProblem {
            n_cells: extra as usize,
            pairs: &pairs,
            dirichlet: &dirichlet,
            sources: &sources,
        })?;
        let mut boundaries = Vec::with_capacity(self.bcs.len());
        let mut d = 0;
        for (bi, b) in self.bcs.iter().enumerate() {
            let f = specs[b.index].factor(t);
            match (b.kind, rate_unknown[bi]) {
                (FlowBcKind::Rate(q), Some(u)) => {
                    boundaries.push((sol.pressure[u as usize], f * q))
                }
                (FlowBcKind::Pressure(p), _) => {
                    let rate: f64 = sol.dirichlet_flow[d..d + b.cells.len()].iter().sum();
                    d += b.cells.len();
                    boundaries.push((f * p, rate));
                }
                _ => unreachable!("pumps rejected above"),
            }
        }
        let mut pressure = sol.pressure;
        pressure.truncate(nc);
        // Cells in a cluster no pressure boundary reaches keep their pressure: the steady
        // problem leaves it undetermined, and a closed cluster keeps its fluid.
        let grounded = self.grounded_cells(&dirichlet.iter().map(|d| d.0).collect::<Vec<_>>());
        for c in 0..nc {
            if !grounded[c] {
                pressure[c] = self.pressure[c];
            }
        }
        Ok(SteadyNetwork {
            pressure,
            boundaries,
            residual: sol.residual,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::{pair_kappa, pair_kappa_linear, pair_kappa_linear_slopes, pair_kappa_slope};

    /// `FrontInCell`: a cell filled to 40 % beside a full cell at 5 MPa carries 0.4 x 5 / 2 =
    /// 1 MPa; a cell whose only neighbour is filling (pressure 0) carries nothing, and a full
    /// cell its own pressure (`None`). With `Dry` no cell has a filling load.
    #[test]
    fn filling_face_pressure_of_a_front_in_the_cell() {
        use super::{FlowParams, FlowView, apply_filling_load, filling_face_pressure};
        use crate::scenario::{Filling, Fluid};
        let mut p = FlowParams::from(Fluid::default());
        p.filling = Filling::FrontInCell;
        let mut v = FlowView {
            volume: vec![1e-3; 3],
            excess: vec![1e-3, -0.6 * p.rho_r * 1e-3, -p.rho_r * 1e-3],
            pressure: vec![5e6, 0.0, 0.0],
            pairs: vec![[0, 1], [1, 2]],
            ..Default::default()
        };
        (v.inc_ptr, v.inc) = crate::view::incidence(3, &v.pairs, |k, side| (2 * k + side) as u32);
        assert_eq!(filling_face_pressure(&v, &p, 0), None);
        let f1 = filling_face_pressure(&v, &p, 1).unwrap();
        assert!((f1 - 1e6).abs() < 1e-6, "{f1}");
        assert_eq!(filling_face_pressure(&v, &p, 2), Some(0.0));
        let mut out = v.pressure.clone();
        apply_filling_load(&v, &p, &mut out);
        assert_eq!(out, vec![5e6, f1, 0.0]);
        p.filling = Filling::Dry;
        assert!((0..3).all(|c| filling_face_pressure(&v, &p, c).is_none()));
    }

    /// `LinearOpening`: equal apertures give the seed's value; a tip cell (half the aperture of
    /// its neighbour) conducts more than the harmonic mean of cell means lets it; the slopes
    /// match central differences to 1e-7 relative (as for the seed's form below).
    #[test]
    fn linear_opening_transmissibility_and_its_slopes() {
        let (li, lj, mu) = (1.0, 0.7, 8.9e-4);
        let k_eq = pair_kappa_linear(li, 5e-4, lj, 5e-4, mu);
        let k_seed = pair_kappa(li, 5e-4, lj, 5e-4, mu);
        assert!(
            (k_eq / k_seed - 1.0).abs() < 1e-14,
            "{k_eq:e} vs {k_seed:e}"
        );
        // A tip cell at w/2 behind a cell at 1.3 w: the linear profile's resistance is 1.98x
        // lower (25.6 against 50.7 mu / w^3 per metre).
        let (w, l) = (2e-3, 1.0);
        let ratio =
            pair_kappa_linear(l, 1.3 * w, l, 0.5 * w, mu) / pair_kappa(l, 1.3 * w, l, 0.5 * w, mu);
        assert!((ratio - 1.98).abs() < 0.01, "{ratio}");
        for (ai, aj) in [(5e-4, 5e-4), (2e-3, 5e-4), (3e-4, 1.5e-3)] {
            let k = pair_kappa_linear(li, ai, lj, aj, mu);
            let s = pair_kappa_linear_slopes(k, li, ai, lj, aj, mu);
            let h = 1e-5 * ai;
            let fd_i = (pair_kappa_linear(li, ai + h, lj, aj, mu)
                - pair_kappa_linear(li, ai - h, lj, aj, mu))
                / (2.0 * h);
            let h = 1e-5 * aj;
            let fd_j = (pair_kappa_linear(li, ai, lj, aj + h, mu)
                - pair_kappa_linear(li, ai, lj, aj - h, mu))
                / (2.0 * h);
            for (fd, s) in [(fd_i, s[0]), (fd_j, s[1])] {
                assert!((fd - s).abs() < 1e-7 * fd.abs(), "slope {s:e} vs {fd:e}");
            }
        }
    }

    /// The slope of the pair transmissibility equals its central difference in either cell's
    /// aperture, to 1e-7 relative (truncation O(h^2) with h = 1e-5 a; a wrong power of a or a
    /// missing factor shows at order 1).
    #[test]
    fn pair_kappa_slope_matches_finite_differences() {
        let (li, lj, mu) = (1.0, 0.7, 8.9e-4);
        for (ai, aj) in [(5e-4, 5e-4), (2e-3, 5e-4), (3e-4, 1.5e-3)] {
            let k = pair_kappa(li, ai, lj, aj, mu);
            let h = 1e-5 * ai;
            let fd_i = (pair_kappa(li, ai + h, lj, aj, mu) - pair_kappa(li, ai - h, lj, aj, mu))
                / (2.0 * h);
            let h = 1e-5 * aj;
            let fd_j = (pair_kappa(li, ai, lj, aj + h, mu) - pair_kappa(li, ai, lj, aj - h, mu))
                / (2.0 * h);
            for (fd, s) in [
                (fd_i, pair_kappa_slope(k, li, ai, mu)),
                (fd_j, pair_kappa_slope(k, lj, aj, mu)),
            ] {
                assert!((fd - s).abs() < 1e-7 * fd.abs(), "slope {s:e} vs {fd:e}");
            }
        }
    }
}
