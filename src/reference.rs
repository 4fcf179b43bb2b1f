//! Flat-array reference kernel of the solid step: the same physics as the ECS systems
//! (`internal_force`, `external_load`, `damping` (local), `integrate`) written as one would
//! without an engine: plain `Vec<f64>`, fused loops, no schedule, spans or monitoring. The
//! benchmark runs it beside the engine so that the cost of the design is a number; a test checks
//! that both give the same bits.

use crate::mesh::TriMesh;
use crate::model::element_geometry;
use crate::scenario::Material;
use crate::systems::solid::{
    ELEM_GRAIN, NODE_CHUNK, SolidParams, cst_forces, cst_stress, flush_tiny, local_damping,
};
use rayon::prelude::*;

/// Flat solid state: interleaved x/y per node.
pub struct FlatSolid {
    pub conn: Vec<[u32; 3]>,
    pub geom: Vec<[f64; 7]>,
    pub u: Vec<f64>,
    pub v: Vec<f64>,
    pub f: Vec<f64>,
    pub load: Vec<f64>,
    pub inv_mass: Vec<f64>,
    /// 1 where the dof is prescribed.
    pub fixed: Vec<u8>,
    pub presc: Vec<f64>,
    pub elem_force: Vec<[f64; 6]>,
    pub inc_ptr: Vec<u32>,
    pub inc: Vec<u32>,
    pub params: SolidParams,
    /// Time step, s.
    pub dt: f64,
    /// Local damping coefficient.
    pub alpha: f64,
}

impl FlatSolid {
    /// Build from a mesh with lumped masses, stepping by `dt` (s); `presc(x)` gives prescribed
    /// displacements per dof.
    pub fn new(
        mesh: &TriMesh,
        mat: &Material,
        params: SolidParams,
        dt: f64,
        alpha: f64,
        presc: impl Fn([f64; 2]) -> [Option<f64>; 2],
    ) -> Self {
        let n = mesh.nodes.len();
        let geom: Vec<[f64; 7]> = mesh
            .triangles
            .iter()
            .map(|t| {
                let g = element_geometry([0, 1, 2].map(|k| mesh.nodes[t[k] as usize]));
                [
                    g.area, g.dndx[0], g.dndx[1], g.dndx[2], g.dndy[0], g.dndy[1], g.dndy[2],
                ]
            })
            .collect();
        let mut mass = vec![0.0; n];
        for (t, g) in mesh.triangles.iter().zip(&geom) {
            for &a in t {
                mass[a as usize] += mat.density * g[0] / 3.0;
            }
        }
        let mut fixed = vec![0u8; 2 * n];
        let mut pv = vec![0.0; 2 * n];
        for (i, &x) in mesh.nodes.iter().enumerate() {
            for (d, p) in presc(x).into_iter().enumerate() {
                if let Some(val) = p {
                    fixed[2 * i + d] = 1;
                    pv[2 * i + d] = val;
                }
            }
        }
        let (ptr, inc) = crate::view::incidence(n, &mesh.triangles, |e, k| (6 * e + 2 * k) as u32);
        FlatSolid {
            conn: mesh.triangles.clone(),
            elem_force: vec![[0.0; 6]; geom.len()],
            geom,
            u: vec![0.0; 2 * n],
            v: vec![0.0; 2 * n],
            f: vec![0.0; 2 * n],
            load: vec![0.0; 2 * n],
            inv_mass: mass.iter().map(|m| 1.0 / m).collect(),
            fixed,
            presc: pv,
            inc_ptr: ptr,
            inc,
            params,
            dt,
            alpha,
        }
    }

    /// One step, serial: element loop scattering straight into the force array, then one fused
    /// node loop (load, local damping, central difference, prescribed dofs).
    pub fn step_serial(&mut self) {
        self.f.iter_mut().for_each(|f| *f = 0.0);
        for (c, g) in self.conn.iter().zip(&self.geom) {
            let ue = c.map(|a| [self.u[2 * a as usize], self.u[2 * a as usize + 1]]);
            let fe = cst_forces(g, cst_stress(g, ue, &self.params));
            for k in 0..3 {
                self.f[2 * c[k] as usize] += fe[2 * k];
                self.f[2 * c[k] as usize + 1] += fe[2 * k + 1];
            }
        }
        let (dt, alpha) = (self.dt, self.alpha);
        for j in 0..self.u.len() {
            update_dof(
                j,
                dt,
                alpha,
                &self.f,
                &self.load,
                &self.inv_mass,
                &self.fixed,
                &self.presc,
                &mut self.u[j],
                &mut self.v[j],
            );
        }
    }

    /// One step, parallel and deterministic: element forces, then a fused node loop that gathers
    /// by node and integrates.
    pub fn step_parallel(&mut self) {
        let (u, p) = (&self.u, &self.params);
        self.elem_force
            .par_iter_mut()
            .zip(self.conn.par_iter().zip(self.geom.par_iter()))
            .with_min_len(ELEM_GRAIN)
            .for_each(|(fe, (c, g))| {
                let ue = c.map(|a| [u[2 * a as usize], u[2 * a as usize + 1]]);
                *fe = cst_forces(g, cst_stress(g, ue, p));
            });
        let ef = self.elem_force.as_flattened();
        let (ptr, inc, load, inv_m, fixed, presc) = (
            &self.inc_ptr,
            &self.inc,
            &self.load,
            &self.inv_mass,
            &self.fixed,
            &self.presc,
        );
        let (dt, alpha) = (self.dt, self.alpha);
        self.u
            .par_chunks_mut(2 * NODE_CHUNK)
            .zip(self.v.par_chunks_mut(2 * NODE_CHUNK))
            .zip(self.f.par_chunks_mut(2 * NODE_CHUNK))
            .enumerate()
            .for_each(|(c, ((uc, vc), fc))| {
                for k in 0..uc.len() / 2 {
                    let i = c * NODE_CHUNK + k;
                    let mut acc = [0.0; 2];
                    for &m in &inc[ptr[i] as usize..ptr[i + 1] as usize] {
                        acc[0] += ef[m as usize];
                        acc[1] += ef[m as usize + 1];
                    }
                    fc[2 * k] = acc[0];
                    fc[2 * k + 1] = acc[1];
                }
                let base = c * 2 * NODE_CHUNK;
                for j in 0..uc.len() {
                    let f = fc[j] + load[base + j];
                    let jj = base + j;
                    if fixed[jj] != 0 {
                        uc[j] = presc[jj];
                        vc[j] = 0.0;
                    } else {
                        let s = vc[j] + dt * f * inv_m[jj / 2];
                        let fd = local_damping(alpha, f, s);
                        vc[j] = flush_tiny(vc[j] + dt * (f + fd) * inv_m[jj / 2]);
                        uc[j] = flush_tiny(uc[j] + dt * vc[j]);
                    }
                }
            });
    }
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn update_dof(
    j: usize,
    dt: f64,
    alpha: f64,
    f: &[f64],
    load: &[f64],
    inv_m: &[f64],
    fixed: &[u8],
    presc: &[f64],
    u: &mut f64,
    v: &mut f64,
) {
    if fixed[j] != 0 {
        *u = presc[j];
        *v = 0.0;
        return;
    }
    let fj = f[j] + load[j];
    let s = *v + dt * fj * inv_m[j / 2];
    let fd = local_damping(alpha, fj, s);
    *v = flush_tiny(*v + dt * (fj + fd) * inv_m[j / 2]);
    *u = flush_tiny(*u + dt * *v);
}

/// Flat-array reference of one explicit flow sub-step (pressure from excess mass, pair fluxes,
/// serial scatter into the cells, mass update) without boundaries: the work per pair and per
/// cell that the engine's `flow_step` does, for the benchmark.
pub struct FlatFlow {
    pub excess: Vec<f64>,
    pub volume: Vec<f64>,
    pub pressure: Vec<f64>,
    pub net: Vec<f64>,
    pub pairs: Vec<[u32; 2]>,
    pub kappa: Vec<f64>,
    pub k: f64,
    pub rho_r: f64,
}

impl FlatFlow {
    /// Copy a network's cells and pairs out of a flow view.
    pub fn from_view(v: &crate::flow::FlowView, p: &crate::flow::FlowParams) -> Self {
        FlatFlow {
            excess: v.excess.clone(),
            volume: v.volume.clone(),
            pressure: vec![0.0; v.n_cells()],
            net: vec![0.0; v.n_cells()],
            pairs: v.pairs.clone(),
            kappa: v.kappa.clone(),
            k: p.k,
            rho_r: p.rho_r,
        }
    }

    pub fn step(&mut self, dt: f64) {
        for c in 0..self.excess.len() {
            let e = self.excess[c];
            self.pressure[c] = if e > 0.0 {
                self.k * e / (self.rho_r * self.volume[c])
            } else {
                0.0
            };
            self.net[c] = 0.0;
        }
        for (pr, k) in self.pairs.iter().zip(&self.kappa) {
            let (i, j) = (pr[0] as usize, pr[1] as usize);
            let q = k * (self.pressure[i] - self.pressure[j]);
            self.net[i] -= q;
            self.net[j] += q;
        }
        let rho_dt = self.rho_r * dt;
        for (e, n) in self.excess.iter_mut().zip(&self.net) {
            *e += rho_dt * n;
        }
    }
}
