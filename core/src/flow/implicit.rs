//! Backward-Euler (implicit) step of the fracture-network flow: one step of length dt over the
//! whole network, solved by Newton's method with a sparse LU (faer), as an alternative to the
//! explicit sub-steps whose stable length shrinks with the aperture squared.
//!
//! Unknowns: per cell the "pseudo-pressure" y_i = K e_i / (rho_r V_i) (Pa), a scaled excess mass
//! e = m - rho_r V (kg/m), so that the cell pressure of equation (4) is P_i = max(y_i, 0): zero
//! while the cell fills (e <= 0), K e/(rho_r V) once it is full. The step solves, with the
//! current (end-of-step) volumes V_i and the boundary schedules evaluated at t + dt,
//!
//! ```text
//! R_i = e_i - e_i^n - dt rho_r (sum_j kappa_ij (P_j - P_i) + q_bc,i(P)) = 0,
//! r_i = K R_i / (rho_r V_i) = y_i - y_i^n - (dt K / V_i) (net volumetric inflow of cell i)
//! ```
//!
//! (Pa). Boundaries: a pressure boundary gives kappa_b (P_b - P_i); a rate boundary spreads its
//! rate over its cells through their half-cell transmissibilities at the common boundary
//! pressure P_b = (q + sum kappa_k P_k) / sum kappa_k; a pump solves its characteristic curve
//! with the network (check valve: no backflow), exactly as the explicit step does
//! ([`crate::flow::boundary::boundary_flows`] is called on the Newton iterate). The Jacobian has
//! the exact derivatives: dP/dy = 1 for y >= 0 and 0 otherwise (so it is not symmetric when some
//! cells are unfilled), and for a pump the implicit-function derivative of its operating point,
//! dP_b/dP_l = -P'(q) kappa_l / (1 - s P'(q)), s = sum kappa_k, P'(q) < 0 the curve's slope
//! (with the valve closed the pump is a rate boundary of zero rate, dP_b/dP_l = kappa_l / s).
//!
//! Newton: the linear system is factorised by faer's sparse LU (COLAMD ordering, partial
//! pivoting, sequential, so the result is the same bits for any thread count); the symbolic
//! factorisation is kept while the sparsity pattern (cells, pairs, boundary cells) is unchanged,
//! i.e. until a split adds cells. The numeric factor is kept too: a step first takes chord
//! iterations with it (the direction from an earlier iterate's Jacobian, full steps), as long
//! as each shrinks the residual's norm by [`CHORD_CONTRACTION`], and only then refactorises
//! and goes on with Newton; the converged answer is the same to the tolerance. The kept
//! Jacobian's values travel in checkpoints, so a restart continues bit for bit. A line search
//! on the scaled residual norm (full step, else the first kink at e = 0 on the way, else
//! Armijo backtracking) keeps the kink from making Newton cycle or creep towards it.
//! Convergence: for every cell
//! |R_i| <= tol rho_r V_i + 64 eps F_i, a relative mass residual of `tol` (default 1e-12) of
//! the cell's reference mass, or the round-off floor of the flux sum when that is larger:
//! F_i = dt rho_r (sum_j kappa_ij (P_i + P_j) + sum_b kappa_b (|P_b| + P_i)) (kg/m) is the
//! mass the step's pressures could move through the cell, and a change of one ulp in the
//! pressures changes R_i by about eps F_i, so below that no iterate can be told from the
//! solution (it matters only for steps thousands of times the diffusion time).
//!
//! Mass balance: after convergence the state is updated exactly as the explicit step does it,
//! e_i += dt rho_r (net inflow), Kahan-compensated, with the pair fluxes and boundary flows of
//! the converged pressures, and the boundaries' cumulative volumes are advanced by dt times the
//! same boundary rates: injected - produced = stored change to round-off, whatever the Newton
//! residual (which only measures how far the stored pressures are from the stored masses).
//!
//! Known limit: a filling front advances by about one cell per Newton iteration (an unfilled
//! cell has dP/de = 0, so the linear model does not see it fill), so a step over which the front
//! crosses many cells needs many iterations; `max_iter` (default 100) bounds them and the error
//! names the cell with the largest residual.

use crate::flow::boundary::{FlowStats, boundary_flows};
use crate::flow::{FlowParams, FlowView, kahan_add};
use crate::scenario::{FlowBcKind, FlowBoundary};
use crate::sparse::SparsePattern;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::lu::{LuRef, NumericLu, SymbolicLu};
use faer::{Conj, MatMut, Par};

/// Default convergence tolerance on |R_i| / (rho_r V_i) (see the module documentation).
pub const DEFAULT_TOL: f64 = 1e-12;
/// Default cap on Newton iterations per step.
pub const DEFAULT_MAX_ITER: usize = 100;
/// Smallest line-search step fraction before Newton is declared stalled.
const MIN_ALPHA: f64 = 1.0 / (1u64 << 30) as f64;
/// Chord iterations: the factor of an earlier Newton iterate's Jacobian (kept across steps
/// while the pattern is unchanged) gives the direction as long as each iteration shrinks the
/// scaled residual norm by at least this factor (its full step, no line search); otherwise
/// the step goes on with Newton and a fresh factorisation. On Example II the numeric LU was
/// 39 % of the whole run with a factorisation at every iteration.
pub const CHORD_CONTRACTION: f64 = 0.1;

/// Errors of [`implicit_step`]. Every message names the time, the step length and the cell.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ImplicitError {
    #[error(
        "implicit flow step to t = {t:.6e} s (dt = {dt:.3e} s): Newton {why} after {iterations} \
         iterations; {cell} has relative mass residual |R|/(rho_r V) = {residual:.3e} \
         (allowed {allowed:.3e})"
    )]
    NotConverged {
        /// End time of the step, s.
        t: f64,
        dt: f64,
        iterations: usize,
        /// Dense index and label of the cell with the largest scaled residual.
        cell_index: usize,
        cell: String,
        /// |R_i| / (rho_r V_i) of that cell and the value accepted as converged there.
        residual: f64,
        allowed: f64,
        why: &'static str,
    },
    #[error(
        "implicit flow step to t = {t:.6e} s (dt = {dt:.3e} s): {cell} has a non-finite {quantity} \
         at Newton iteration {iteration}"
    )]
    NonFinite {
        t: f64,
        dt: f64,
        iteration: usize,
        cell_index: usize,
        cell: String,
        quantity: &'static str,
    },
    #[error("implicit flow step: {cell} has volume {volume:e} m^2 (must be finite and > 0)")]
    BadVolume {
        cell_index: usize,
        cell: String,
        volume: f64,
    },
    #[error("implicit flow step: the time step {dt:e} s must be finite and > 0")]
    BadStep { dt: f64 },
    #[error("implicit flow step: sparse LU failed: {detail}")]
    Factorisation { detail: String },
}

impl ImplicitError {
    /// Dense index of the cell the error is about, if any.
    pub fn cell_index(&self) -> Option<usize> {
        match self {
            ImplicitError::NotConverged { cell_index, .. }
            | ImplicitError::NonFinite { cell_index, .. }
            | ImplicitError::BadVolume { cell_index, .. } => Some(*cell_index),
            _ => None,
        }
    }
}

/// Everything that depends only on the sparsity pattern of the Jacobian.
pub struct Pattern {
    generation: u64,
    pairs: Vec<[u32; 2]>,
    bc_cells: Vec<Vec<u32>>,
    pub sparse: SparsePattern,
    /// Value slot of the diagonal of each cell.
    pub diag: Vec<usize>,
    /// Value slots of each pair (i, j): entry (row i, col j) and (row j, col i).
    pair_slots: Vec<[usize; 2]>,
    /// Per boundary with m cells, m x m slots: (row cell k, col cell l) at k * m + l.
    bc_slots: Vec<Vec<usize>>,
    symbolic: SymbolicLu<usize>,
    mem: MemBuffer,
}

impl Pattern {
    fn matches(&self, v: &FlowView) -> bool {
        self.generation == v.generation
            && self.diag.len() == v.n_cells()
            && self.pairs == v.pairs
            && self.bc_cells.len() == v.bcs.len()
            && self.bc_cells.iter().zip(&v.bcs).all(|(a, b)| *a == b.cells)
    }

    pub fn build(v: &FlowView) -> Result<Self, ImplicitError> {
        let n = v.n_cells();
        // (row, col) entries: diagonal, both directions of every pair, and every two cells of a
        // boundary (a rate or pump boundary couples its cells through the common pressure).
        let mut e: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
        for p in &v.pairs {
            let (i, j) = (p[0] as usize, p[1] as usize);
            e.push((i, j));
            e.push((j, i));
        }
        for b in &v.bcs {
            for &k in &b.cells {
                for &l in &b.cells {
                    e.push((k as usize, l as usize));
                }
            }
        }
        let sparse = SparsePattern::from_entries(n, e)
            .map_err(|detail| ImplicitError::Factorisation { detail })?;
        let slot = |row: usize, col: usize| -> usize {
            sparse.slot(row, col).expect("entry is in the pattern")
        };
        let diag = (0..n).map(|i| slot(i, i)).collect();
        let pair_slots = v
            .pairs
            .iter()
            .map(|p| {
                let (i, j) = (p[0] as usize, p[1] as usize);
                [slot(i, j), slot(j, i)]
            })
            .collect();
        let bc_slots = v
            .bcs
            .iter()
            .map(|b| {
                let mut s = Vec::with_capacity(b.cells.len() * b.cells.len());
                for &k in &b.cells {
                    for &l in &b.cells {
                        s.push(slot(k as usize, l as usize));
                    }
                }
                s
            })
            .collect();
        let (symbolic, mem) = sparse
            .symbolic_lu()
            .map_err(|detail| ImplicitError::Factorisation { detail })?;
        Ok(Pattern {
            generation: v.generation,
            pairs: v.pairs.clone(),
            bc_cells: v.bcs.iter().map(|b| b.cells.clone()).collect(),
            sparse,
            diag,
            pair_slots,
            bc_slots,
            symbolic,
            mem,
        })
    }
}

/// Reusable backward-Euler solver: the symbolic LU of the Jacobian's pattern, the numeric
/// factors and the work arrays (no allocation per step while the topology is unchanged).
/// Saved (serde) and cloned as its [`ImplicitCounters`]: the caches are rebuilt at the next
/// step for the same pattern and Jacobian, which gives the same numbers.
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(into = "ImplicitCounters", from = "ImplicitCounters")]
pub struct ImplicitSolver {
    /// Convergence tolerance on the relative mass residual |R_i| / (rho_r V_i) (see the module
    /// documentation for the round-off allowance), default [`DEFAULT_TOL`].
    pub tol: f64,
    /// Newton iteration cap per step, default [`DEFAULT_MAX_ITER`].
    pub max_iter: usize,
    /// Chord iterations with the kept factor before Newton (default on; off: a fresh
    /// factorisation at every iteration, for comparison).
    pub chord: bool,
    pattern: Option<Pattern>,
    numeric: NumericLu<usize, f64>,
    values: Vec<f64>,
    y0: Vec<f64>,
    y: Vec<f64>,
    y_try: Vec<f64>,
    r: Vec<f64>,
    delta: Vec<f64>,
    w: Vec<f64>,
    scale: Vec<f64>,
    net: Vec<f64>,
    r_try: Vec<f64>,
    symbolic_count: usize,
    /// The pattern (its `symbolic_count`) whose numeric factor `numeric` holds, of the
    /// Jacobian values in `values`: kept across steps for the chord iterations.
    kept: Option<usize>,
    /// Jacobian values from a checkpoint, factorised at the next step (so a restart
    /// continues with the factor the interrupted run had).
    pending: Vec<f64>,
    /// Newton iterations (linear solves) of the last step.
    pub last_iterations: usize,
    /// Newton iterations and steps so far.
    pub total_iterations: u64,
    pub steps: u64,
    /// Relative mass residual max_i |R_i| / (rho_r V_i) at which the last step stopped.
    pub last_residual: f64,
    /// Numeric LU factorisations, and iterations taken with the kept factor (chord).
    pub factorisations: u64,
    pub chord_iterations: u64,
}

impl Default for ImplicitSolver {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for ImplicitSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ImplicitSolver")
            .field("tol", &self.tol)
            .field("max_iter", &self.max_iter)
            .field("symbolic_count", &self.symbolic_count)
            .field("total_iterations", &self.total_iterations)
            .field("steps", &self.steps)
            .finish_non_exhaustive()
    }
}

impl ImplicitSolver {
    pub fn new() -> Self {
        ImplicitSolver {
            tol: DEFAULT_TOL,
            max_iter: DEFAULT_MAX_ITER,
            chord: true,
            pattern: None,
            numeric: NumericLu::new(),
            values: Vec::new(),
            y0: Vec::new(),
            y: Vec::new(),
            y_try: Vec::new(),
            r: Vec::new(),
            delta: Vec::new(),
            w: Vec::new(),
            scale: Vec::new(),
            net: Vec::new(),
            r_try: Vec::new(),
            symbolic_count: 0,
            kept: None,
            pending: Vec::new(),
            last_iterations: 0,
            total_iterations: 0,
            steps: 0,
            last_residual: 0.0,
            factorisations: 0,
            chord_iterations: 0,
        }
    }

    /// The Jacobian's pattern for the view's network (rebuilt when the network changed): the
    /// coupled quasi-static step assembles the flow rows with it.
    pub fn pattern(&mut self, v: &FlowView) -> Result<&Pattern, ImplicitError> {
        if !self.pattern.as_ref().is_some_and(|p| p.matches(v)) {
            self.pattern = None;
            self.pattern = Some(Pattern::build(v)?);
            self.symbolic_count += 1;
        }
        Ok(self.pattern.as_ref().expect("built above"))
    }

    /// How many symbolic factorisations were done so far (tests check reuse).
    pub fn symbolic_count(&self) -> usize {
        self.symbolic_count
    }

    /// The settings, counters and kept Jacobian (a restart checkpoint's part of the solver:
    /// the symbolic factorisation is rebuilt for the same pattern, and the kept Jacobian is
    /// factorised again, which gives the same numbers).
    pub fn counters(&self) -> ImplicitCounters {
        ImplicitCounters {
            tol: self.tol,
            max_iter: self.max_iter,
            chord: self.chord,
            last_iterations: self.last_iterations,
            total_iterations: self.total_iterations,
            steps: self.steps,
            last_residual: self.last_residual,
            factorisations: self.factorisations,
            chord_iterations: self.chord_iterations,
            // The kept factor's values, or those a restored solver has yet to factorise.
            jacobian: if self.kept == Some(self.symbolic_count) {
                self.values.clone()
            } else {
                self.pending.clone()
            },
        }
    }

    /// Set what [`ImplicitSolver::counters`] returned.
    pub fn set_counters(&mut self, c: ImplicitCounters) {
        self.tol = c.tol;
        self.max_iter = c.max_iter;
        self.chord = c.chord;
        self.last_iterations = c.last_iterations;
        self.total_iterations = c.total_iterations;
        self.steps = c.steps;
        self.last_residual = c.last_residual;
        self.factorisations = c.factorisations;
        self.chord_iterations = c.chord_iterations;
        self.kept = None;
        self.pending = c.jacobian;
    }
}

impl Clone for ImplicitSolver {
    fn clone(&self) -> Self {
        self.counters().into()
    }
}

impl From<ImplicitCounters> for ImplicitSolver {
    fn from(c: ImplicitCounters) -> Self {
        let mut s = ImplicitSolver::default();
        s.set_counters(c);
        s
    }
}

impl From<ImplicitSolver> for ImplicitCounters {
    fn from(s: ImplicitSolver) -> Self {
        s.counters()
    }
}

/// [`ImplicitSolver`]'s settings and counters, and the Jacobian values of its kept factor
/// (empty: none).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct ImplicitCounters {
    pub tol: f64,
    pub max_iter: usize,
    pub chord: bool,
    pub last_iterations: usize,
    pub total_iterations: u64,
    pub steps: u64,
    pub last_residual: f64,
    pub factorisations: u64,
    pub chord_iterations: u64,
    pub jacobian: Vec<f64>,
}

/// Pressures P = max(y, 0) into the view, pair fluxes, boundary flows at `t1`, net inflow per
/// cell (m^2/s) into `net`, and the scaled residual r = y - y0 - w net (Pa) into `r`.
#[allow(clippy::too_many_arguments)]
pub fn residual(
    v: &mut FlowView,
    specs: &[FlowBoundary],
    t1: f64,
    y: &[f64],
    y0: &[f64],
    w: &[f64],
    net: &mut [f64],
    r: &mut [f64],
) {
    for (p, &yi) in v.pressure.iter_mut().zip(y) {
        *p = if yi > 0.0 { yi } else { 0.0 };
    }
    for ((q, pr), k) in v.pair_q.iter_mut().zip(&v.pairs).zip(&v.kappa) {
        *q = k * (v.pressure[pr[0] as usize] - v.pressure[pr[1] as usize]);
    }
    boundary_flows(v, specs, t1);
    for i in 0..y.len() {
        let mut s = v.bc_in[i];
        for &e in &v.inc[v.inc_ptr[i] as usize..v.inc_ptr[i + 1] as usize] {
            let q = v.pair_q[(e >> 1) as usize];
            s += if e & 1 == 0 { -q } else { q };
        }
        net[i] = s;
        r[i] = y[i] - y0[i] - w[i] * s;
    }
}

/// Round-off multiple of the flux-sum scale accepted as converged (see the module doc).
const ROUND_OFF: f64 = 64.0 * f64::EPSILON;

/// Per-cell allowed residual (Pa): tol K + 64 eps F_i K / (rho_r V_i) at the view's current
/// pressures (see the module documentation).
pub fn residual_scale(v: &FlowView, k: f64, tol: f64, w: &[f64], scale: &mut [f64]) {
    for i in 0..scale.len() {
        let pi = v.pressure[i];
        let mut s = 0.0;
        for &e in &v.inc[v.inc_ptr[i] as usize..v.inc_ptr[i + 1] as usize] {
            let pair = (e >> 1) as usize;
            let pr = v.pairs[pair];
            let j = pr[1 - (e & 1) as usize] as usize;
            s += v.kappa[pair] * (pi + v.pressure[j]);
        }
        scale[i] = s;
    }
    for b in &v.bcs {
        for (kk, &c) in b.cells.iter().enumerate() {
            let c = c as usize;
            scale[c] += b.kappa[kk] * (b.pressure.abs() + v.pressure[c]);
        }
    }
    for (s, wi) in scale.iter_mut().zip(w) {
        *s = tol * k + ROUND_OFF * wi * *s;
    }
}

/// Largest |r_i| / scale_i (converged when <= 1), its cell, and sum (r_i / scale_i)^2.
pub fn measure(r: &[f64], scale: &[f64]) -> (f64, usize, f64) {
    let (mut worst, mut cell, mut sum) = (0.0f64, 0usize, 0.0f64);
    for (i, (ri, si)) in r.iter().zip(scale).enumerate() {
        let x = ri / si;
        if x.abs() > worst || x.is_nan() {
            worst = x.abs();
            cell = i;
        }
        sum += x * x;
    }
    (worst, cell, sum)
}

/// The end of a backward-Euler step whose pressures, pair fluxes and boundary flows are in
/// the view and whose net inflows (m^2/s) are `net`: each cell's excess mass gains
/// dt rho_r net (Kahan-compensated), its throughput is half the sum of |fluxes|, the
/// boundaries' volumes advance by dt times their rates. Returns the step's statistics (the
/// first cell with negative or non-finite mass). Shared by the implicit step and the coupled
/// quasi-static step's commit.
pub fn apply_net_inflow(v: &mut FlowView, p: &FlowParams, net: &[f64], dt: f64) -> FlowStats {
    let rho_dt = p.rho_r * dt;
    let mut st = FlowStats::default();
    for (i, &q) in net.iter().enumerate() {
        let mut through = v.bc_in[i].abs();
        for &e in &v.inc[v.inc_ptr[i] as usize..v.inc_ptr[i + 1] as usize] {
            through += v.pair_q[(e >> 1) as usize].abs();
        }
        kahan_add(&mut v.excess[i], &mut v.excess_comp[i], rho_dt * q);
        v.flow_rate[i] = 0.5 * through;
        st.net2 += q * q;
        let m = v.excess[i];
        if !(m >= -p.rho_r * v.volume[i] * (1.0 + crate::flow::boundary::MASS_ROUNDOFF)
            && m.is_finite())
            && st.bad_cell.is_none()
        {
            st.bad_cell = Some(i);
        }
    }
    crate::flow::boundary::accumulate_boundary_volumes(v, dt);
    st
}

/// The smallest positive step fraction along `d` at which some y changes branch of the
/// pressure law P = max(y, 0) (y < 0 reaching 0: the cell fills; y > 0 going below: it
/// drains), and that cell.
pub fn first_kink(y: &[f64], d: &[f64]) -> Option<(f64, usize)> {
    let mut best: Option<(f64, usize)> = None;
    for (i, (&yi, &di)) in y.iter().zip(d).enumerate() {
        if (yi < 0.0 && yi + di >= 0.0) || (yi > 0.0 && yi + di < 0.0) {
            let a = -yi / di;
            if a > 0.0 && best.is_none_or(|(b, _)| a < b) {
                best = Some((a, i));
            }
        }
    }
    best
}

/// Where a kink step puts its cell: on the branch the step was heading for (y = 0 when it
/// fills, just below when it drains), so the next Jacobian takes that branch.
pub fn kink_landing(d: f64) -> f64 {
    if d > 0.0 { 0.0 } else { -f64::MIN_POSITIVE }
}

/// Jacobian dr/dy at the current iterate (the view holds its pressures and boundary state).
pub fn assemble(
    v: &FlowView,
    specs: &[FlowBoundary],
    t1: f64,
    y: &[f64],
    w: &[f64],
    pat: &Pattern,
    values: &mut Vec<f64>,
) {
    values.clear();
    values.resize(pat.sparse.nnz(), 0.0);
    // dP/dy: 1 for a full cell, 0 for a filling one. At the kink y = 0 (a cell exactly full at
    // zero pressure, e.g. `Full(0)` at the start) the right derivative is taken: the cell is
    // about to be pressurised, and with 0 every such cell would need its own Newton iteration.
    let h = |c: usize| if y[c] >= 0.0 { 1.0 } else { 0.0 };
    for &d in &pat.diag {
        values[d] = 1.0;
    }
    for (k, pr) in v.pairs.iter().enumerate() {
        let (i, j) = (pr[0] as usize, pr[1] as usize);
        let kap = v.kappa[k];
        let (hi, hj) = (h(i), h(j));
        values[pat.diag[i]] += w[i] * kap * hi;
        values[pat.diag[j]] += w[j] * kap * hj;
        values[pat.pair_slots[k][0]] -= w[i] * kap * hj;
        values[pat.pair_slots[k][1]] -= w[j] * kap * hi;
    }
    for (bi, b) in v.bcs.iter().enumerate() {
        let m = b.cells.len();
        let slots = &pat.bc_slots[bi];
        let s: f64 = b.kappa.iter().sum();
        if s <= 0.0 {
            continue;
        }
        // g_l = dP_b / dP_l for the boundaries whose pressure follows the cells.
        let g_factor = match b.kind {
            FlowBcKind::Pressure(_) => None,
            FlowBcKind::Rate(_) => Some(1.0 / s),
            FlowBcKind::Pump { p_max, q_half } => {
                let pm = specs[b.index].factor(t1) * p_max;
                let sp: f64 = b
                    .kappa
                    .iter()
                    .zip(&b.cells)
                    .map(|(k, &c)| k * v.pressure[c as usize])
                    .sum();
                if s * pm > sp {
                    // Open: q = s P_pump(q) - sp, P' the curve's slope at the operating point.
                    let q = b.rate.max(0.0);
                    let dpdq = -pm * std::f64::consts::FRAC_2_PI
                        / (q_half * (1.0 + (q / q_half) * (q / q_half)));
                    Some(-dpdq / (1.0 - s * dpdq))
                } else {
                    Some(1.0 / s)
                }
            }
        };
        for (kk, &ck) in b.cells.iter().enumerate() {
            let ck = ck as usize;
            // flux_k = kappa_k (P_b - P_k): d/dP_l = kappa_k (g_l - delta_kl).
            for (l, &cl) in b.cells.iter().enumerate() {
                let cl = cl as usize;
                let mut d = if kk == l { -b.kappa[kk] } else { 0.0 };
                if let Some(g) = g_factor {
                    d += b.kappa[kk] * g * b.kappa[l];
                }
                if d != 0.0 {
                    values[slots[kk * m + l]] -= w[ck] * d * h(cl);
                }
            }
        }
    }
}

impl ImplicitSolver {
    /// Sizes the work vectors for the view's `n` cells and sets the step's weights
    /// `w_i = dt K / V_i` (s/m^2 times the pressure modulus K, Pa) and start values
    /// `y0_i = K m_i / (rho_r V_i)` (Pa) from the excess masses; `y` starts at `y0`. Errors on
    /// a cell whose volume is not finite and positive.
    fn load_step(
        &mut self,
        v: &FlowView,
        params: &FlowParams,
        dt: f64,
    ) -> Result<(), ImplicitError> {
        let n = v.n_cells();
        let k = params.k;
        for buf in [
            &mut self.y0,
            &mut self.y,
            &mut self.y_try,
            &mut self.r,
            &mut self.delta,
            &mut self.w,
            &mut self.scale,
            &mut self.net,
            &mut self.r_try,
        ] {
            buf.clear();
            buf.resize(n, 0.0);
        }
        for i in 0..n {
            let vol = v.volume[i];
            if !(vol.is_finite() && vol > 0.0) {
                return Err(ImplicitError::BadVolume {
                    cell_index: i,
                    cell: v.cell_label(i),
                    volume: vol,
                });
            }
            self.w[i] = dt * k / vol;
            self.y0[i] = k * v.excess[i] / (params.rho_r * vol);
        }
        self.y.copy_from_slice(&self.y0);
        Ok(())
    }

    /// Rebuilds the sparsity pattern (and its symbolic analysis) when the view's network
    /// changed, then, after a restart, factorises the checkpoint's pending Jacobian values again
    /// so that the kept factor is the interrupted run's.
    fn refresh_pattern(&mut self, v: &FlowView) -> Result<(), ImplicitError> {
        if v.n_cells() > 0 && !self.pattern.as_ref().is_some_and(|p| p.matches(v)) {
            self.pattern = None;
            self.pattern = Some(Pattern::build(v)?);
            self.symbolic_count += 1;
        }
        if !self.pending.is_empty() {
            // A restart: the interrupted run's kept factor, factorised again from its values.
            let values = std::mem::take(&mut self.pending);
            if let Some(pat) = self.pattern.as_mut()
                && values.len() == pat.sparse.nnz()
            {
                self.values = values;
                if factorise(pat, &mut self.numeric, &self.values).is_ok() {
                    self.kept = Some(self.symbolic_count);
                }
            }
        }
        Ok(())
    }

    /// One chord iteration: the kept factor's direction from `y`, taken when it is finite and
    /// contracts the residual (`phi` by CHORD_CONTRACTION^2 of `phi0`, or converges). Returns
    /// whether it was taken (`y` then holds the new iterate).
    fn chord_iteration(
        &mut self,
        v: &mut FlowView,
        specs: &[FlowBoundary],
        t1: f64,
        phi0: f64,
    ) -> bool {
        let pat = self.pattern.as_mut().expect("built above");
        direction(pat, &self.numeric, &self.r, &mut self.delta);
        if !self.delta.iter().all(|d| d.is_finite()) {
            return false;
        }
        let (w_try, phi) = self.trial(v, specs, t1, 1.0, None);
        if w_try <= 1.0 || phi <= CHORD_CONTRACTION * CHORD_CONTRACTION * phi0 {
            std::mem::swap(&mut self.y, &mut self.y_try);
            self.chord_iterations += 1;
            return true;
        }
        false
    }

    /// The trial iterate y + alpha delta into `y_try` (with `landing`, that cell put on the
    /// kink it reaches, [`kink_landing`]) and its residual into `r_try`; returns the worst
    /// scaled residual and phi = sum (r_i / scale_i)^2 there.
    fn trial(
        &mut self,
        v: &mut FlowView,
        specs: &[FlowBoundary],
        t1: f64,
        alpha: f64,
        landing: Option<usize>,
    ) -> (f64, f64) {
        for i in 0..self.y.len() {
            self.y_try[i] = self.y[i] + alpha * self.delta[i];
        }
        if let Some(c) = landing {
            self.y_try[c] = kink_landing(self.delta[c]);
        }
        residual(
            v,
            specs,
            t1,
            &self.y_try,
            &self.y0,
            &self.w,
            &mut self.net,
            &mut self.r_try,
        );
        let (w_try, _, phi) = measure(&self.r_try, &self.scale);
        (w_try, phi)
    }

    /// The Newton direction at `y`: assembles the Jacobian, factorises it (kept for the chord
    /// iterations) and solves `J delta = -r` into `delta`.
    fn newton_direction(
        &mut self,
        v: &FlowView,
        specs: &[FlowBoundary],
        t1: f64,
    ) -> Result<(), ImplicitError> {
        let pat = self.pattern.as_mut().expect("built above");
        assemble(v, specs, t1, &self.y, &self.w, pat, &mut self.values);
        self.kept = None;
        factorise(pat, &mut self.numeric, &self.values).map_err(|e| {
            ImplicitError::Factorisation {
                detail: format!("{e:?}"),
            }
        })?;
        self.kept = Some(self.symbolic_count);
        self.factorisations += 1;
        direction(pat, &self.numeric, &self.r, &mut self.delta);
        Ok(())
    }

    /// Line search along `delta` from `y` on phi = sum (r_i / scale_i)^2 with the scales of
    /// this iterate (Armijo with c = 1e-4: the Newton direction's slope is -2 phi, `phi0` at
    /// `y`). Candidates: the full step; then the first kink on the way, the smallest fraction
    /// at which a cell changes branch of the pressure law (landing on y = 0 when it fills,
    /// just below when it drains, so that the next Jacobian takes the branch the step was
    /// heading for): up to there the residual is smooth and the Newton model exact for the
    /// linear boundaries, so it decreases, where halving alone would creep towards the kink;
    /// then halving from 1/2. Takes the accepted step into `y` and returns true, or false when
    /// the halving fell below MIN_ALPHA (stalled; `y` unchanged).
    fn line_search(
        &mut self,
        v: &mut FlowView,
        specs: &[FlowBoundary],
        t1: f64,
        phi0: f64,
    ) -> bool {
        let (kink, kink_cell) =
            first_kink(&self.y, &self.delta).unwrap_or((f64::INFINITY, usize::MAX));
        let mut alpha = 1.0;
        let mut halving = 1.0;
        let mut tried_kink = false;
        loop {
            let landing = (alpha == kink).then_some(kink_cell);
            let (w_try, phi) = self.trial(v, specs, t1, alpha, landing);
            if phi <= (1.0 - 1e-4 * alpha) * phi0 || w_try <= 1.0 {
                break;
            }
            if !tried_kink && kink < 1.0 {
                tried_kink = true;
                alpha = kink;
            } else {
                halving *= 0.5;
                alpha = halving;
            }
            if halving < MIN_ALPHA {
                return false;
            }
        }
        std::mem::swap(&mut self.y, &mut self.y_try);
        true
    }
}

/// One backward-Euler step of length `dt` (s) from time `t` (s) to `t + dt` over the whole
/// network, with the view's current volumes (m^2) as the end-of-step volumes and the boundary
/// schedules evaluated at `t + dt`. Updates everything the explicit [`flow_step`] updates: the
/// excess masses (Kahan-compensated), `pressure` (the converged end-of-step pressures used for
/// the fluxes, Pa), `pair_q` and `bc_in` (m^2/s), `flow_rate` (throughput, m^2/s), each
/// boundary's pressure, rate and cumulative volumes in and out (m^2). Returns the same
/// statistics as the explicit step (`net2` of the step's net inflows, the first cell with
/// negative or non-finite mass), or an error naming the cell and its residual if Newton does
/// not converge within `solver.max_iter` iterations. On error the view's masses and boundary
/// volumes are unchanged (its pressures and fluxes hold the last iterate).
///
/// [`flow_step`]: crate::flow::explicit::flow_step
pub fn implicit_step(
    v: &mut FlowView,
    params: &FlowParams,
    specs: &[FlowBoundary],
    dt: f64,
    t: f64,
    solver: &mut ImplicitSolver,
) -> Result<FlowStats, ImplicitError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(ImplicitError::BadStep { dt });
    }
    let n = v.n_cells();
    let t1 = t + dt;
    let k = params.k;
    let s = solver;
    s.load_step(v, params, dt)?;
    s.refresh_pattern(v)?;
    // The chord: while the kept factor (of an earlier iterate's Jacobian, on this pattern)
    // shrinks the residual by CHORD_CONTRACTION an iteration, no new factorisation.
    let mut chord = s.chord && n > 0 && s.kept == Some(s.symbolic_count);
    let not_finite = |v: &FlowView, it: usize, c: usize, quantity| ImplicitError::NonFinite {
        t: t1,
        dt,
        iteration: it,
        cell_index: c,
        cell: v.cell_label(c),
        quantity,
    };
    let mut it = 0;
    loop {
        residual(v, specs, t1, &s.y, &s.y0, &s.w, &mut s.net, &mut s.r);
        residual_scale(v, k, s.tol, &s.w, &mut s.scale);
        let (worst, cell, phi0) = measure(&s.r, &s.scale);
        if !worst.is_finite() {
            return Err(not_finite(v, it, cell, "residual"));
        }
        // Relative mass residual |R_i| / (rho_r V_i) = |r_i| / K of the worst cell.
        let rel = s.r[cell].abs() / k;
        if worst <= 1.0 {
            s.last_residual = s.r.iter().fold(0.0f64, |a, r| a.max(r.abs())) / k;
            break;
        }
        let not_converged =
            |v: &FlowView, s: &ImplicitSolver, it, why| ImplicitError::NotConverged {
                t: t1,
                dt,
                iterations: it,
                cell_index: cell,
                cell: v.cell_label(cell),
                residual: rel,
                allowed: s.scale[cell] / k,
                why,
            };
        if it >= s.max_iter {
            return Err(not_converged(v, s, it, "reached the iteration cap"));
        }
        it += 1;
        if chord {
            // Not taken (not contracting: a cell filled or drained, the step changed): Newton
            // from y, whose residual the next pass evaluates again.
            chord = s.chord_iteration(v, specs, t1, phi0);
            continue;
        }
        s.newton_direction(v, specs, t1)?;
        if let Some(c) = s.delta.iter().position(|d| !d.is_finite()) {
            return Err(not_finite(v, it, c, "Newton update"));
        }
        if !s.line_search(v, specs, t1, phi0) {
            let why = "stalled (the line search found no decrease)";
            return Err(not_converged(v, s, it, why));
        }
    }
    // The view now holds the converged pressures, pair fluxes and boundary flows; update the
    // masses with exactly those fluxes and the boundary volumes with the same rates.
    let st = apply_net_inflow(v, params, &s.net, dt);
    s.last_iterations = it;
    s.total_iterations += it as u64;
    s.steps += 1;
    Ok(st)
}

/// The numeric LU of the Jacobian `values` (in `pat`'s pattern) into `numeric`.
fn factorise(
    pat: &mut Pattern,
    numeric: &mut NumericLu<usize, f64>,
    values: &[f64],
) -> Result<(), LuError> {
    let a = SparseColMatRef::new(pat.sparse.as_ref(), values);
    pat.symbolic
        .factorize_numeric_lu(
            numeric,
            a,
            Par::Seq,
            MemStack::new(&mut pat.mem),
            Default::default(),
        )
        .map(|_| ())
}

/// delta = -J^-1 r with the factor `numeric` of `pat`'s pattern (Newton's freshly made, or
/// the chord's kept one).
fn direction(pat: &mut Pattern, numeric: &NumericLu<usize, f64>, r: &[f64], delta: &mut [f64]) {
    for (d, r) in delta.iter_mut().zip(r) {
        *d = -r;
    }
    let n = delta.len();
    LuRef::new_unchecked(&pat.symbolic, numeric).solve_in_place_with_conj(
        Conj::No,
        MatMut::from_column_major_slice_mut(delta, n, 1),
        Par::Seq,
        MemStack::new(&mut pat.mem),
    );
}
