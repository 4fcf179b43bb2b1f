//! The network's rows of a coupled quasi-static step: the backward-Euler flow step and the
//! rock's equilibrium solved together by one Newton iteration (`systems::quasi_static`), and
//! the flow system's commit of the converged step (`flow_substeps` with the quasi-static
//! scheme).
//!
//! Unknowns per cell: the pseudo-pressure y (Pa) of [`hydrofrac_core::flow::implicit`], so the cell
//! pressure is P = max(y, 0) and the fluid mass m = rho_r V (1 + y/K) (kg/m). The cell's volume
//! follows its joint: V(u) = L max(delta_n(u), a_r) (m^2, L the cell's length). The step's
//! mass balance per cell, scaled by K / V^n (V^n the volume at the start of the step),
//!
//! ```text
//! r_c = (V_c(u) / V_c^n) (K + y_c) - (K + y_c^n) - (dt K / V_c^n) N_c(P) = 0,
//! ```
//!
//! N_c the net volumetric inflow (pairs and boundaries, m^2/s) at the end-of-step pressures and
//! the start-of-step transmissibilities. With V = V^n it is the implicit flow step's residual.
//! The rock's residual gains the face pressures: F(u, y) = F_rock(u) + G P(y), G the
//! `fluid_pressure` map (P L n to each face, half to each node).
//!
//! Newton: with K_T the rock's tangent, W = K_T^-1 G (one column per cell with a joint, kept
//! while the factor is), H = diag(dP/dy), A = dr/du (per cell (K + y)/V^n L d(delta_n)/du on
//! its joint's 8 dofs when delta_n > a_r) and J = dr/dy (the implicit step's Jacobian plus
//! V/V^n - 1 on the diagonal), the coupled linear system is reduced to the cells:
//!
//! ```text
//! du0 = K_T^-1 F,   (J + A W H) dy = -(r + A du0),   du = du0 + W H dy.
//! ```
//!
//! The reduced matrix is dense (cells x cells) and solved by LU with partial pivoting: the
//! cells are few against the rock's dofs (Example I: tens to a hundred against 20,000). Why
//! monolithic: the fluid is a spring K L / a on the faces, 100 times the joint penalty at the
//! residual aperture, so a staggered (fixed-point) iteration between flow and rock multiplies
//! its error by about that ratio each pass and diverges (measured: a factor ~2,000 on Example
//! I); here the fluid's stiffness is in the Newton matrix.
//!
//! Transmissibilities are those of the start-of-step apertures (lagged): the Newton matrix is
//! then exact and the step first order in time, like backward Euler itself; the adaptive step
//! (see `sim::Simulation`) bounds the pressure change a step may make. Mass is conserved
//! exactly whatever the residual: the commit moves each cell's volume to V(u) with its mass
//! kept and adds dt rho_r N_c with the converged fluxes, as the implicit flow step does.

use crate::flow::FlowPart;
use crate::fracture::joint_frame;
use hydrofrac_core::flow::FlowParams;
use hydrofrac_core::flow::boundary::FlowStats;
use hydrofrac_core::flow::implicit::{
    apply_net_inflow, assemble, first_kink, kink_landing, measure, residual, residual_scale,
};
use hydrofrac_core::scenario::FlowBoundary;
use hydrofrac_core::view::SolidView;

/// Relative mass residual |R_c| / (rho_r V_c^n) the coupled step converges to (the rock's
/// positions carry round-off of about 64 eps |x|, which is added per cell).
pub const FLOW_TOL: f64 = 1e-10;
/// Face coefficients of a joint's 4 nodes in delta = c_q - c_p (c the mean of a face's nodes).
pub const FACE: [f64; 4] = [-0.5, -0.5, 0.5, 0.5];
/// The most cells x rock dofs the dense K_T^-1 G may hold (2 GB of f64).
pub const MAX_W_ENTRIES: usize = 250_000_000;

/// Per-cell state and work arrays of the coupled step (no allocation per step while the
/// network is unchanged).
#[derive(Default)]
pub struct FlowRows {
    /// Pseudo-pressure at the iterate and at the start of the step, Pa.
    pub y: Vec<f64>,
    y0: Vec<f64>,
    /// With `Filling::FrontInCell` (else empty): each cell's face pressure while it fills, at
    /// the start of the step (`flow::filling_face_pressure`; 0 for a cell full then), Pa, and
    /// the face pressures at the iterate.
    fill_load: Vec<f64>,
    face_p: Vec<f64>,
    /// dt K / V^n, Pa s / m^2; V^n, m^2.
    w: Vec<f64>,
    v0: Vec<f64>,
    /// The cell's volume L a(u) at the iterate, m^2, and whether it follows the joint
    /// (delta_n > a_r).
    pub vol: Vec<f64>,
    active: Vec<bool>,
    /// Net inflow (m^2/s), residual and allowed residual (Pa) at the iterate.
    pub net: Vec<f64>,
    r: Vec<f64>,
    scale: Vec<f64>,
    /// Flow Jacobian values in the implicit solver's pattern, and the reduced dense matrix
    /// (column-major) with its right-hand side.
    values: Vec<f64>,
    s: Vec<f64>,
    pub b: Vec<f64>,
    /// W = K_T^-1 G, rock dofs x columns (column-major); `w_col[c]` is cell c's column
    /// (`u32::MAX`: none); valid while the factor numbered `w_factor` is.
    wmat: Vec<f64>,
    w_col: Vec<u32>,
    w_factor: Option<u64>,
    /// Round-off allowance of the positions, m (64 eps max |x|).
    dx: f64,
    /// The worst cell's residual over its allowance (converged at <= 1) at the last iterate.
    pub worst: f64,
    pub worst_cell: usize,
    /// Sum of (r_c / allowed_c)^2 at the last iterate (the line search's merit).
    pub phi: f64,
    /// The iterate and the Newton update of the line search (y, dy).
    y_base: Vec<f64>,
    /// Rows of A = dr/du: (rock dof, value) per cell.
    a_rows: Vec<Vec<(usize, f64)>>,
}

/// What the coupled step needs of the flow: the flow part, the boundary specs, the fluid, and
/// the step [t0, t0 + dt] (dt = 0 for a re-solve at the same time after a split).
pub struct FlowStep<'a> {
    pub part: &'a mut FlowPart,
    pub specs: &'a [FlowBoundary],
    pub fluid: &'a FlowParams,
    /// Whether the face pressures load the rock (`fluid_pressure` not switched off).
    pub faces: bool,
    pub t0: f64,
    pub dt: f64,
}

impl FlowRows {
    /// Start a step: y^n from the cells' masses, the weights, y = y^n.
    pub fn begin(&mut self, s: &mut FlowStep, solid: &SolidView) {
        let fv = &s.part.view;
        let nc = fv.n_cells();
        let k = s.fluid.k;
        for buf in [
            &mut self.y,
            &mut self.y0,
            &mut self.w,
            &mut self.v0,
            &mut self.vol,
            &mut self.net,
            &mut self.r,
            &mut self.scale,
            &mut self.b,
        ] {
            buf.clear();
            buf.resize(nc, 0.0);
        }
        self.active.clear();
        self.active.resize(nc, false);
        for c in 0..nc {
            let v0 = fv.volume[c];
            self.v0[c] = v0;
            self.w[c] = s.dt * k / v0;
            self.y0[c] = k * fv.excess[c] / (s.fluid.rho_r * v0);
        }
        self.y.copy_from_slice(&self.y0);
        self.fill_load.clear();
        if s.fluid.filling != hydrofrac_core::scenario::Filling::Dry {
            self.fill_load.extend((0..nc).map(|c| {
                hydrofrac_core::flow::filling_face_pressure(fv, s.fluid, c).unwrap_or(0.0)
            }));
        }
        // Boundary transmissibilities at the start-of-step apertures, for the whole step (a
        // failed attempt may have left the view's at a trial's apertures).
        let fv = &mut s.part.view;
        for c in 0..nc {
            fv.aperture[c] = self.v0[c] / fv.length[c];
        }
        fv.update_bc_kappa(s.fluid);
        let xmax = solid
            .x0
            .iter()
            .fold(0.0f64, |m, x| m.max(x[0].abs()).max(x[1].abs()));
        self.dx = 64.0 * f64::EPSILON * xmax.max(1.0);
    }

    /// The flow rows at the rock's iterate: volumes, pressures (into the view), fluxes,
    /// residual and the allowed residual per cell. Returns whether they are converged.
    pub fn evaluate(&mut self, s: &mut FlowStep, solid: &SolidView) -> bool {
        let c_map = s.part.coupling.as_ref().expect("coupled flow");
        let fv = &mut s.part.view;
        let k = s.fluid.k;
        for c in 0..fv.n_cells() {
            let j = c_map.cell_joint[c];
            if j == u32::MAX {
                self.vol[c] = self.v0[c];
                self.active[c] = false;
            } else {
                let dn = joint_frame(solid, j as usize).dn;
                self.vol[c] =
                    fv.length[c] * hydrofrac_core::fractures::hydraulic_aperture(dn, c_map.a_r);
                self.active[c] = dn > c_map.a_r;
            }
        }
        // Transmissibilities at the mid-step apertures (a^n + a(u)) / 2.
        for c in 0..fv.n_cells() {
            fv.aperture[c] = 0.5 * (self.v0[c] + self.vol[c]) / fv.length[c];
        }
        // Boundary transmissibilities stay at the start-of-step apertures (the pump's
        // operating point has no derivative in the Newton matrix with respect to them).
        fv.update_pair_kappa(s.fluid);
        let t1 = s.t0 + s.dt;
        residual(
            fv,
            s.specs,
            t1,
            &self.y,
            &self.y0,
            &self.w,
            &mut self.net,
            &mut self.r,
        );
        residual_scale(fv, k, FLOW_TOL, &self.w, &mut self.scale);
        for c in 0..fv.n_cells() {
            let ratio = self.vol[c] / self.v0[c];
            self.r[c] += (ratio - 1.0) * (k + self.y[c]);
            // Round-off of delta_n from the positions moves V by L dx.
            self.scale[c] += (k + self.y[c].abs()) * fv.length[c] * self.dx / self.v0[c];
        }
        let (worst, cell, phi) = measure(&self.r, &self.scale);
        self.phi = phi;
        self.worst = worst;
        self.worst_cell = cell;
        worst <= 1.0
    }

    /// Whether W = K_T^-1 G must be recomputed for the factor numbered `factor`.
    pub fn needs_w(&self, factor: u64) -> bool {
        self.w_factor != Some(factor)
    }

    /// The columns of G (face pressure to nodal force, per unit pressure) of every cell with a
    /// joint, into the W buffer (to be solved in place by the caller); returns the number of
    /// columns. `dof[2 i + d]` is node i's free dof (`usize::MAX`: prescribed), `n` their count.
    /// `normal` and `len` are each joint's normal and length as the rock's tangent takes them
    /// (kept along a chain of low-rank updates of K_T, so W = K_T^-1 G stays exact under
    /// them; the residual uses the current geometry).
    pub fn load_g(
        &mut self,
        s: &FlowStep,
        solid: &SolidView,
        dof: &[usize],
        n: usize,
        normal: &[[f64; 2]],
        len: &[f64],
    ) -> Result<usize, String> {
        let c_map = s.part.coupling.as_ref().expect("coupled flow");
        let nc = s.part.view.n_cells();
        self.w_col.clear();
        self.w_col.resize(nc, u32::MAX);
        let mut m = 0u32;
        if s.faces {
            for c in 0..nc {
                if c_map.cell_joint[c] != u32::MAX {
                    self.w_col[c] = m;
                    m += 1;
                }
            }
        }
        let m = m as usize;
        if m.saturating_mul(n) > MAX_W_ENTRIES {
            return Err(format!(
                "the coupled step holds K^-1 G densely: {m} fracture cells x {n} rock dofs is \
                 above {MAX_W_ENTRIES} entries (use time.solid_scheme: Explicit)"
            ));
        }
        self.wmat.clear();
        self.wmat.resize(m * n, 0.0);
        let w = &mut self.wmat;
        g_entries(
            &self.w_col,
            &c_map.cell_joint,
            solid,
            dof,
            normal,
            len,
            |col, k, a| w[col * n + k] += a,
        );
        Ok(m)
    }

    /// Weight of W's column `col` in the combinations [`FlowRows::g_combination`] and
    /// [`FlowRows::w_combination`] (distinct weights, so no two columns' errors cancel).
    fn weight(col: usize) -> f64 {
        1.0 + (col % 7) as f64 / 7.0
    }

    /// G x for the weights x of `FlowRows::weight`, over the columns of the last
    /// [`FlowRows::load_g`] (same arguments), into `out` (length `n`).
    #[allow(clippy::too_many_arguments)]
    pub fn g_combination(
        &self,
        s: &FlowStep,
        solid: &SolidView,
        dof: &[usize],
        n: usize,
        normal: &[[f64; 2]],
        len: &[f64],
        out: &mut Vec<f64>,
    ) {
        let c_map = s.part.coupling.as_ref().expect("coupled flow");
        out.clear();
        out.resize(n, 0.0);
        g_entries(
            &self.w_col,
            &c_map.cell_joint,
            solid,
            dof,
            normal,
            len,
            |col, k, a| out[k] += Self::weight(col) * a,
        );
    }

    /// W x for the weights of `FlowRows::weight`, into `out` (length `n`).
    pub fn w_combination(&self, n: usize, out: &mut Vec<f64>) {
        out.clear();
        out.resize(n, 0.0);
        for (col, wc) in self.wmat.chunks_exact(n.max(1)).enumerate() {
            let x = Self::weight(col);
            for (o, w) in out.iter_mut().zip(wc) {
                *o += x * w;
            }
        }
    }

    /// The W buffer (G before the caller's solve, K_T^-1 G after) and its column count.
    pub fn w_buffer(&mut self) -> &mut [f64] {
        &mut self.wmat
    }

    /// Whether W is K_T^-1 G for the factor numbered `factor`.
    pub fn w_is_for(&self, factor: u64) -> bool {
        self.w_factor == Some(factor)
    }

    /// The number of columns of W for `n` rock dofs.
    pub fn w_columns(&self, n: usize) -> usize {
        self.wmat.len().checked_div(n).unwrap_or(0)
    }

    /// Mark W as solved for the factor numbered `factor`.
    pub fn set_w_factor(&mut self, factor: u64) {
        self.w_factor = Some(factor);
    }

    /// Forget W (the network or the rock's dofs changed).
    pub fn forget_w(&mut self) {
        self.w_factor = None;
    }

    /// The flow rows' linearisation at the iterate: J = dr/dy into `values` (the implicit
    /// solver's pattern, returned with the diagonal slots, V/V^n - 1 added on the diagonal),
    /// the rows of A = dr/du into `a_rows` and -r into `b`.
    pub(crate) fn linearise<'p>(
        &mut self,
        s: &'p mut FlowStep,
        solid: &SolidView,
        dof: &[usize],
    ) -> Result<&'p hydrofrac_core::flow::implicit::Pattern, String> {
        let c_map = s.part.coupling.as_ref().expect("coupled flow");
        let fv = &s.part.view;
        let nc = fv.n_cells();
        let k = s.fluid.k;
        let solver = s.part.implicit.as_mut().expect("backward-Euler flow");
        let pat = solver.pattern(fv).map_err(|e| e.to_string())?;
        let t1 = s.t0 + s.dt;
        assemble(fv, s.specs, t1, &self.y, &self.w, pat, &mut self.values);
        // A = dr/du, row by row: the volume term on the cell's own joint, and the mid-step
        // transmissibilities' term on both cells' joints of each pair it belongs to.
        self.a_rows.resize_with(nc, Vec::new);
        self.a_rows.iter_mut().for_each(|r| r.clear());
        let joint_dn = |c: usize, scale: f64, row: &mut Vec<(usize, f64)>| {
            let kj = c_map.cell_joint[c] as usize;
            let normal = joint_frame(solid, kj).n;
            opening_gradient(solid, kj, normal, dof, |q, a| row.push((q, scale * a)));
        };
        for c in 0..nc {
            self.values[pat.diag[c]] += self.vol[c] / self.v0[c] - 1.0;
            self.b[c] = -self.r[c];
            if self.active[c] {
                // (K + y_c) / V^n L d(delta_n)/du.
                let coef = (k + self.y[c]) / self.v0[c] * fv.length[c];
                joint_dn(c, coef, &mut self.a_rows[c]);
            }
        }
        for (pk, pr) in fv.pairs.iter().enumerate() {
            let (i, j) = (pr[0] as usize, pr[1] as usize);
            let dp = fv.pressure[i] - fv.pressure[j];
            if dp == 0.0 || s.dt == 0.0 {
                continue;
            }
            // kappa at the mid-step apertures: d a_s / du = d(delta_n)/du / 2.
            let kap = fv.kappa[pk];
            let slopes = s.fluid.pair_kappa_slopes(
                kap,
                fv.length[i],
                fv.aperture[i],
                fv.length[j],
                fv.aperture[j],
            );
            for (side, slope) in [(i, slopes[0]), (j, slopes[1])] {
                if !self.active[side] {
                    continue;
                }
                let dk = 0.5 * slope;
                // r_i = ... - w_i N_i with N_i = -q, N_j = +q, q = kappa (P_i - P_j).
                joint_dn(side, self.w[i] * dp * dk, &mut self.a_rows[i]);
                joint_dn(side, -self.w[j] * dp * dk, &mut self.a_rows[j]);
            }
        }
        Ok(pat)
    }

    /// The linearisation's values of J, in the pattern [`FlowRows::linearise`] returned.
    pub(crate) fn jacobian_values(&self) -> &[f64] {
        &self.values
    }

    /// The linearisation's rows of A = dr/du: (rock dof, value) per cell.
    pub(crate) fn a_rows(&self) -> &[Vec<(usize, f64)>] {
        &self.a_rows
    }

    /// The rock's face pressure per cell at the iterate (Pa): the cell's pressure (set by
    /// [`FlowRows::evaluate`]), or while it fills (y < 0), with `Filling::FrontInCell`, its
    /// filling load at the start of the step (constant over the step, so dP/dy stays 0).
    pub fn face_pressure<'a>(&'a mut self, fv: &'a hydrofrac_core::flow::FlowView) -> &'a [f64] {
        if self.fill_load.is_empty() {
            return &fv.pressure;
        }
        self.face_p.clear();
        self.face_p.extend((0..fv.n_cells()).map(|c| {
            if self.y[c] < 0.0 {
                self.fill_load[c]
            } else {
                fv.pressure[c]
            }
        }));
        &self.face_p
    }

    /// dP/dy of cell `c` at the iterate: 1 when full, 0 when filling.
    pub(crate) fn dp_dy(&self, c: usize) -> f64 {
        if self.y[c] >= 0.0 { 1.0 } else { 0.0 }
    }

    /// Set the Newton update of the pseudo-pressures (the line search's dy).
    pub(crate) fn set_dy(&mut self, dy: &[f64]) {
        self.b.copy_from_slice(dy);
    }

    /// The cells' W columns after [`FlowRows::load_g`]: whether cell c loads the faces.
    pub(crate) fn has_faces(s: &FlowStep, c: usize) -> bool {
        s.faces && s.part.coupling.as_ref().expect("coupled flow").cell_joint[c] != u32::MAX
    }

    /// The reduced Newton system: given du0 = K_T^-1 F on the rock's free dofs, solve
    /// (J + A W H) dy = -(r + A du0) for dy (into `self.b`) and add W H dy to du0 (making it
    /// du). Errors: a singular reduced matrix.
    pub fn reduce_and_solve(
        &mut self,
        s: &mut FlowStep,
        solid: &SolidView,
        dof: &[usize],
        n: usize,
        du: &mut [f64],
    ) -> Result<(), String> {
        let nc = s.part.view.n_cells();
        let pat = self.linearise(s, solid, dof)?;
        self.s.clear();
        self.s.resize(nc * nc, 0.0);
        let (cp, ri) = (pat.sparse.col_ptr(), pat.sparse.row_idx());
        for col in 0..nc {
            for slot in cp[col]..cp[col + 1] {
                self.s[col * nc + ri[slot]] += self.values[slot];
            }
        }
        let h = |y: f64| if y >= 0.0 { 1.0 } else { 0.0 };
        let fv = &s.part.view;
        for c in 0..nc {
            let row = &self.a_rows[c];
            if row.is_empty() {
                continue;
            }
            for &(q, a) in row {
                self.b[c] -= a * du[q];
            }
            for c2 in 0..nc {
                let col = self.w_col[c2];
                if col == u32::MAX || h(self.y[c2]) == 0.0 {
                    continue;
                }
                let wc = &self.wmat[col as usize * n..(col as usize + 1) * n];
                let sum: f64 = row.iter().map(|&(q, a)| a * wc[q]).sum();
                self.s[c2 * nc + c] += sum;
            }
        }
        let lu = nalgebra::DMatrix::from_column_slice(nc, nc, &self.s).lu();
        let rhs = nalgebra::DVector::from_column_slice(&self.b);
        let dy = lu.solve(&rhs).ok_or_else(|| {
            "the reduced flow-rock matrix is singular (a cell with no volume change, no flow \
             and no compressibility)"
                .to_string()
        })?;
        if let Some(c) = dy.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "the Newton update of {} is not finite",
                fv.cell_label(c)
            ));
        }
        for c in 0..nc {
            self.b[c] = dy[c];
            let col = self.w_col[c];
            if col == u32::MAX || h(self.y[c]) == 0.0 {
                continue;
            }
            let wc = &self.wmat[col as usize * n..(col as usize + 1) * n];
            for (d, w) in du.iter_mut().zip(wc) {
                *d += w * dy[c];
            }
        }
        Ok(())
    }

    /// Largest change of a cell's pressure max(y, 0) over the step, relative to the largest
    /// pressure at its start or end (0 when all are zero).
    pub fn pressure_change(&self) -> f64 {
        let (mut dp, mut pmax) = (0.0f64, 0.0f64);
        for (y, y0) in self.y.iter().zip(&self.y0) {
            let (p, p0) = (y.max(0.0), y0.max(0.0));
            dp = dp.max((p - p0).abs());
            pmax = pmax.max(p).max(p0);
        }
        if pmax > 0.0 { dp / pmax } else { 0.0 }
    }

    /// Keep the iterate y as the line search's base (after [`FlowRows::reduce_and_solve`],
    /// which left dy in `b`).
    pub fn save_base(&mut self) {
        self.y_base.clear();
        self.y_base.extend_from_slice(&self.y);
    }

    /// The first kink of the pressure law on the way, if before the full step
    /// ([`hydrofrac_core::flow::implicit::first_kink`]).
    pub fn first_kink(&self) -> Option<(f64, usize)> {
        first_kink(&self.y_base, &self.b).filter(|&(a, _)| a < 1.0)
    }

    /// y = base + alpha dy; at a kink step the kink's cell lands on its new branch (y = 0
    /// when it fills, just below when it drains).
    pub fn set_trial(&mut self, alpha: f64, kink: Option<usize>) {
        for ((y, b), d) in self.y.iter_mut().zip(&self.y_base).zip(&self.b) {
            *y = b + alpha * d;
        }
        if let Some(c) = kink {
            self.y[c] = kink_landing(self.b[c]);
        }
    }
}

/// The entries of G: `push(col, dof, value)` for each cell with a W column `w_col[c]` (its
/// joint `cell_joint[c]`): the face pressure's force per unit pressure, len d(delta_n)/du.
fn g_entries(
    w_col: &[u32],
    cell_joint: &[u32],
    solid: &SolidView,
    dof: &[usize],
    normal: &[[f64; 2]],
    len: &[f64],
    mut push: impl FnMut(usize, usize, f64),
) {
    for (c, &col) in w_col.iter().enumerate() {
        if col == u32::MAX {
            continue;
        }
        let kj = cell_joint[c] as usize;
        let l = len[kj];
        opening_gradient(solid, kj, normal[kj], dof, |k, a| {
            push(col as usize, k, l * a)
        });
    }
}

/// d(delta_n)/du of joint `kj` on its free dofs along the normal `n`: `push(dof, FACE[j] n[d])`
/// for node j's component d (the normal's own change is neglected).
fn opening_gradient(
    solid: &SolidView,
    kj: usize,
    n: [f64; 2],
    dof: &[usize],
    mut push: impl FnMut(usize, f64),
) {
    for (j, &node) in solid.joint_nodes[kj].iter().enumerate() {
        for d in 0..2 {
            let q = dof[2 * node as usize + d];
            if q != usize::MAX {
                push(q, FACE[j] * n[d]);
            }
        }
    }
}

/// `flow_substeps` with the quasi-static scheme: commit the converged coupled step of length
/// `dt` (s): each cell's volume moves to V(u) with its mass kept, the converged fluxes add
/// dt rho_r N_c (Kahan-compensated), the boundaries' volumes advance by dt times their rates,
/// the apertures become the end-of-step ones (transmissibilities of the next step) and the
/// converged pressures the face load. Returns the step's statistics.
pub fn commit(rows: &FlowRows, f: &mut FlowPart, fp: &FlowParams, dt: f64) -> FlowStats {
    let v = &mut f.view;
    for c in 0..v.n_cells() {
        v.set_volume_keep_mass(c, rows.vol[c], fp);
        v.aperture[c] = rows.vol[c] / v.length[c];
    }
    let st = apply_net_inflow(v, fp, &rows.net, dt);
    v.update_kappa(fp);
    if let Some(c) = f.coupling.as_mut() {
        c.p_mean.copy_from_slice(&v.pressure);
        // The face load the converged step carried (`FlowRows::face_pressure`).
        for (c, (p, &l)) in c.p_mean.iter_mut().zip(&rows.fill_load).enumerate() {
            if rows.y[c] < 0.0 {
                *p = l;
            }
        }
    }
    st
}
