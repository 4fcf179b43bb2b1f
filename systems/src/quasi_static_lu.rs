//! The quasi-static Newton matrix in full, factored by faer's sparse LU (`systems::quasi_static`
//! takes this path when many joints slide or many fracture cells are coupled, see
//! [`crate::quasi_static::Linear`]).
//!
//! Unknowns: the rock's free dofs, then (coupled steps) each flow cell's pseudo-pressure y. The
//! matrix is the exact derivative of the residual the Cholesky path solves with (`solve`):
//!
//! ```text
//! [ K_T    -G H ] [du]   [ F ]
//! [ A       J   ] [dy] = [-r ]
//! ```
//!
//! K_T the CST stiffness plus each closed joint's exact contact tangent (below), G the face
//! pressures' map, H = diag(dP/dy), A = dr/du and J = dr/dy of the flow rows
//! ([`crate::quasi_static_flow`]). The Cholesky path reduces the same system to the
//! cells through W = K_T^-1 G (one solve per cell, a dense cells x cells LU) and adds the
//! sliding joints' Coulomb term by Sherman-Morrison-Woodbury (one solve per sliding joint);
//! here each Newton iteration costs one sparse LU of the whole system instead, whatever the
//! number of cells and sliding joints.
//!
//! **The exact joint tangent.** A joint's frame is that of its face p in the current
//! geometry (`view::joint_frame`): t = e / L along the face (e = x_1 - x_0), n normal to it,
//! delta = c_q - c_p the offset of the faces' centres, delta_n = n . delta, delta_t = t . delta.
//! With a_n, a_t the coefficients of n . d(delta) and t . d(delta) on the joint's 8 dofs (-1/2,
//! -1/2, 1/2, 1/2 per node times the axis) and b the face's rotation, omega = n . de / L
//! (b = (-n, n, 0, 0) / L), the frame turns as dt = n omega, dn = -t omega, so
//!
//! ```text
//! d(delta_n) = (a_n - delta_t b) . du,   d(delta_t) = (a_t + delta_n b) . du,
//! ```
//!
//! and the contact force a_n F_n + a_t F_t (F_n = -K_n delta_n, F_t = F_t^0 - K_t (delta_t -
//! delta_t^0) when sticking, mu F_n s when sliding) has the tangent
//!
//! ```text
//! K_n a_n (a_n - delta_t b)^T + [stick] K_t a_t (a_t + delta_n b)^T
//!   + [slip] mu s K_n a_t (a_n - delta_t b)^T - (F_t a_n - F_n a_t) b^T.
//! ```
//!
//! The Cholesky path keeps only K_n a_n a_n^T, K_t a_t a_t^T and the Coulomb term: the
//! frame's rotation times the slip, K_n delta_t b, is of relative size 2 delta_t / L against
//! K_n a_n, which a penalty of 100 E makes matter (0.14 on `verify slip_inclined` at b/h = 80,
//! where the Cholesky path converges linearly), and the force's turning (F / L against the
//! rock's E / h) is small.

use crate::fracture::joint_frame;
use crate::quasi_static::{add_mass, dofs_of, mass_slots, rock_stiffness};
use crate::quasi_static_flow::{FACE, FlowRows, FlowStep};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::matrix_free::bicgstab::{BicgParams, bicgstab, bicgstab_scratch};
use faer::matrix_free::{IdentityPrecond, InitialGuessStatus, LinOp, Precond};
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::lu::{LuRef, NumericLu, SymbolicLu};
use faer::{Conj, MatMut, MatRef, Par};
use hydrofrac_core::params::RunParams;
use hydrofrac_core::sparse::SparsePattern;
use hydrofrac_core::static_lu::StaticLu;
use hydrofrac_core::view::SolidView;

const NONE: usize = usize::MAX;

/// A joint's contact state in the tangent (the solver's own states, which may be frozen).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum JointTangent {
    Open,
    Stick,
    Slip,
}

/// The pattern, the constant elastic values, the value slots and the LU factors of the full
/// Newton matrix for one topology and network.
pub(crate) struct FullTangent {
    /// (topology generation, cells, nonzeros of the flow pattern, faces loaded).
    key: (u64, usize, usize, bool),
    n: usize,
    nc: usize,
    pattern: SparsePattern,
    k_el: Vec<f64>,
    joint_slots: Vec<[usize; 64]>,
    /// The mass term's slots (`quasi_static::mass_slots`).
    mass_slots: Vec<(u32, usize)>,
    /// Per cell: the slots of G's column (its joint's 8 dofs in the cell's column).
    g_slots: Vec<[usize; 8]>,
    /// Per slot of the flow pattern, its slot in the full pattern.
    j_slots: Vec<usize>,
    /// The LU without pivoting on the pattern's symmetric fill, tried first at every
    /// factorisation ([`hydrofrac_core::static_lu`]), and its solve's scratch.
    static_lu: StaticLu,
    static_work: Vec<f64>,
    /// faer's LU with partial pivoting (COLAMD): its symbolic analysis and workspace, made at
    /// the first factorisation the static pivots refuse or do not solve accurately.
    pivoted: Option<(SymbolicLu<usize>, MemBuffer)>,
    numeric: NumericLu<usize, f64>,
    /// Whether `numeric` holds a pivoting factor of this pattern (of an earlier iterate),
    /// which BiCGSTAB may reuse.
    pivoted_held: bool,
    /// Whether the last reuse of the factor took more than [`REUSE_REFACTOR_AFTER`]
    /// iterations or failed: the next iteration factors afresh.
    stale: bool,
    values: Vec<f64>,
    /// The right-hand side kept for the residual check of a factor without pivoting.
    rhs_keep: Vec<f64>,
    /// BiCGSTAB's workspace (allocated at the first reuse), its solution and A x for the
    /// residual check (kept, so a reuse allocates nothing).
    krylov_mem: Option<MemBuffer>,
    krylov_x: Vec<f64>,
    krylov_ax: Vec<f64>,
}

/// How a Newton direction was found: a fresh factor (without pivoting, or with partial
/// pivoting where the static pivots failed), or BiCGSTAB preconditioned by an older factor in
/// that many iterations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Direction {
    Factored { pivoted: bool },
    Reused { iterations: usize },
}

/// How [`FullTangent::factor_and_solve`] may find a direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LuOptions {
    /// Try BiCGSTAB on an earlier factor with partial pivoting first (not on a factor without
    /// pivoting: that one costs about eight of its solves, and a reuse takes two a
    /// BiCGSTAB iteration).
    pub reuse: bool,
    /// Factor without pivoting first ([`StaticLu`]), refusing pivots below this times the
    /// largest diagonal entry (`None`: not at all).
    pub static_pivots: Option<f64>,
}

/// Relative residual |b - A x| / |b| a direction from the factor without pivoting must reach
/// (after at most [`STATIC_REFINE`] steps of iterative refinement), else the matrix is factored
/// again with partial pivoting. The Newton iteration's own tolerance is 1e-10 of the forces'
/// scale, and [`REUSE_TOL`] is what an inexact direction may leave.
pub const STATIC_TOL: f64 = REUSE_TOL;

/// Iterative refinement steps (one residual and one solve each) a direction from the factor
/// without pivoting may take to reach [`STATIC_TOL`].
pub const STATIC_REFINE: usize = 2;

/// The most BiCGSTAB iterations on an older factor before the matrix is factored afresh
/// (each costs two solves with the factor and two products with the matrix; on Example II
/// a reuse of about 5 iterations costs about two thirds of a factorisation,
/// `benches/quasi_static.rs`).
pub const REUSE_MAX_ITERS: usize = 12;

/// A reuse that needed more iterations than this marks the factor stale: the next Newton
/// iteration factors afresh.
pub const REUSE_REFACTOR_AFTER: usize = 4;

/// Relative residual |b - A x| / |b| of a direction from the older factor. The Newton
/// iteration stops at a relative residual of 1e-10 of the forces' scale and each of its
/// updates reduces the residual by about this factor, so an inexact direction costs at most
/// one more iteration.
pub const REUSE_TOL: f64 = 1e-9;

/// An LU factor of an earlier Newton matrix of the same pattern as a preconditioner
/// (faer's `Precond`: x = (L U)^-1 b).
struct OldFactor<'a> {
    lu: LuRef<'a, usize, f64>,
    n: usize,
}

impl std::fmt::Debug for OldFactor<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "OldFactor({})", self.n)
    }
}

impl LinOp<f64> for OldFactor<'_> {
    fn apply_scratch(&self, rhs_ncols: usize, par: Par) -> StackReq {
        self.lu
            .symbolic()
            .solve_in_place_scratch::<f64>(rhs_ncols, par)
    }
    fn nrows(&self) -> usize {
        self.n
    }
    fn ncols(&self) -> usize {
        self.n
    }
    fn apply(
        &self,
        mut out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        out.copy_from(rhs);
        self.lu.solve_in_place_with_conj(Conj::No, out, par, stack);
    }
    fn conj_apply(
        &self,
        out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        self.apply(out, rhs, par, stack);
    }
}

impl Precond<f64> for OldFactor<'_> {}

fn joint_dofs(dof: &[usize], nodes: &[u32; 4]) -> [usize; 8] {
    std::array::from_fn(|i| dof[2 * nodes[i / 2] as usize + i % 2])
}

impl FullTangent {
    /// Whether the pattern was built for this topology and network.
    pub(crate) fn matches(&self, v: &SolidView, flow: Option<&mut FlowStep>) -> bool {
        self.key == key(v, flow)
    }

    /// The pattern of the rock's free dofs `dof` (`n` of them) and, with `flow`, its cells:
    /// element and joint blocks, G's columns, the rows of A (a cell's own joint and those of
    /// its pairs' cells), J; its symbolic LU (COLAMD ordering) and the elastic values.
    pub(crate) fn build(
        v: &SolidView,
        p: &RunParams,
        dof: &[usize],
        n: usize,
        mut flow: Option<&mut FlowStep>,
    ) -> Result<Self, String> {
        let key = key(v, flow.as_deref_mut());
        let nc = key.1;
        let mut entries = Vec::new();
        for d in v
            .conn
            .iter()
            .map(|c| dofs_of(dof, c))
            .chain(v.joint_nodes.iter().map(|j| dofs_of(dof, j)))
        {
            for &a in &d {
                for &b in &d {
                    if a != NONE && b != NONE {
                        entries.push((a, b));
                    }
                }
            }
        }
        let mut flow_pattern: Option<(Vec<usize>, Vec<usize>)> = None;
        if let Some(f) = flow.as_deref_mut() {
            let c_map = f.part.coupling.as_ref().expect("coupled flow");
            let cell_dofs = |c: usize| -> Option<[usize; 8]> {
                let kj = c_map.cell_joint[c];
                (kj != u32::MAX).then(|| joint_dofs(dof, &v.joint_nodes[kj as usize]))
            };
            for c in 0..nc {
                if let Some(d) = cell_dofs(c) {
                    for q in d.into_iter().filter(|&q| q != NONE) {
                        // G's column and the volume term of A's row.
                        entries.push((q, n + c));
                        entries.push((n + c, q));
                    }
                }
            }
            for pr in &f.part.view.pairs {
                let (i, j) = (pr[0] as usize, pr[1] as usize);
                for (row, side) in [(i, j), (j, i)] {
                    if let Some(d) = cell_dofs(side) {
                        for q in d.into_iter().filter(|&q| q != NONE) {
                            entries.push((n + row, q));
                        }
                    }
                }
            }
            let fv = &f.part.view;
            let solver = f.part.implicit.as_mut().expect("backward-Euler flow");
            let pat = solver.pattern(fv).map_err(|e| e.to_string())?;
            let (cp, ri) = (pat.sparse.col_ptr(), pat.sparse.row_idx());
            let mut rows = Vec::with_capacity(ri.len());
            let mut cols = Vec::with_capacity(ri.len());
            for col in 0..nc {
                for &row in &ri[cp[col]..cp[col + 1]] {
                    entries.push((n + row, n + col));
                    rows.push(row);
                    cols.push(col);
                }
            }
            flow_pattern = Some((rows, cols));
        }
        let pattern = SparsePattern::from_entries(n + nc, entries)?;
        let slot = |a: usize, b: usize| -> usize {
            if a == NONE || b == NONE {
                NONE
            } else {
                pattern.slot(a, b).expect("in pattern")
            }
        };
        let (k_el, joint_slots) = rock_stiffness(v, p, dof, pattern.nnz(), slot);
        let mass_slots = mass_slots(dof, slot);
        let mut g_slots = Vec::new();
        let mut j_slots = Vec::new();
        if let (Some(f), Some((rows, cols))) = (flow.as_deref(), flow_pattern) {
            let c_map = f.part.coupling.as_ref().expect("coupled flow");
            g_slots = (0..nc)
                .map(|c| match c_map.cell_joint[c] {
                    u32::MAX => [NONE; 8],
                    kj => joint_dofs(dof, &v.joint_nodes[kj as usize]).map(|q| slot(q, n + c)),
                })
                .collect();
            j_slots = rows
                .iter()
                .zip(&cols)
                .map(|(&r, &c)| slot(n + r, n + c))
                .collect();
        }
        let static_lu = StaticLu::new(&pattern)?;
        Ok(FullTangent {
            key,
            n,
            nc,
            pattern,
            k_el,
            joint_slots,
            mass_slots,
            g_slots,
            j_slots,
            static_lu,
            static_work: Vec::new(),
            pivoted: None,
            numeric: NumericLu::new(),
            pivoted_held: false,
            stale: false,
            values: Vec::new(),
            rhs_keep: Vec::new(),
            krylov_mem: None,
            krylov_x: Vec::new(),
            krylov_ax: Vec::new(),
        })
    }

    /// Assemble the full Newton matrix at the current iterate for the joints' tangent
    /// `states` (and, with `flow`, the flow rows linearised by [`FlowRows::linearise`]) plus
    /// `shift` M (implicit dynamics; 1/s^2, 0 for equilibrium), and factor it; then solve it
    /// for `rhs` = [F; -r] in place (length n + cells).
    ///
    /// With `reuse`, a factor of an earlier iterate of the same pattern is tried first as the
    /// preconditioner of BiCGSTAB on the new matrix (at most [`REUSE_MAX_ITERS`] iterations
    /// to a relative residual of [`REUSE_TOL`]); the matrix is factored when that fails, when
    /// the last reuse was slow, or when there is no factor yet.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn factor_and_solve(
        &mut self,
        v: &SolidView,
        p: &RunParams,
        shift: f64,
        states: &[JointTangent],
        flow: Option<(&FlowStep, &FlowRows)>,
        rhs: &mut [f64],
        options: LuOptions,
    ) -> Result<Direction, String> {
        self.assemble(v, p, shift, states, flow);
        if options.reuse
            && self.pivoted_held
            && !self.stale
            && let Some(iterations) = self.reuse_solve(rhs)
        {
            self.stale = iterations > REUSE_REFACTOR_AFTER;
            return Ok(Direction::Reused { iterations });
        }
        let pivoted = self.factor_solve(states, rhs, options.static_pivots)?;
        Ok(Direction::Factored { pivoted })
    }

    /// BiCGSTAB on the assembled matrix with the older factor as right preconditioner:
    /// `rhs` replaced by the solution and its iterations returned, or `None` (and `rhs`
    /// unchanged) when it does not reach [`REUSE_TOL`] in [`REUSE_MAX_ITERS`] iterations.
    fn reuse_solve(&mut self, rhs: &mut [f64]) -> Option<usize> {
        let len = rhs.len();
        let a = SparseColMatRef::new(self.pattern.as_ref(), &self.values);
        let (symbolic, _) = self.pivoted.as_ref()?;
        let pre = OldFactor {
            lu: LuRef::new_unchecked(symbolic, &self.numeric),
            n: len,
        };
        let ident = IdentityPrecond { dim: len };
        let mem = match &mut self.krylov_mem {
            Some(m) => m,
            None => {
                let req = bicgstab_scratch(ident, &pre, a, 1, Par::Seq);
                self.krylov_mem.insert(MemBuffer::try_new(req).ok()?)
            }
        };
        let x = &mut self.krylov_x;
        x.clear();
        x.resize(len, 0.0);
        let params = BicgParams {
            initial_guess: InitialGuessStatus::MaybeNonZero,
            abs_tolerance: 0.0,
            rel_tolerance: REUSE_TOL,
            max_iters: REUSE_MAX_ITERS,
            ..Default::default()
        };
        let info = bicgstab(
            MatMut::from_column_major_slice_mut(x, len, 1),
            ident,
            &pre,
            a,
            MatRef::from_column_major_slice(rhs, len, 1),
            params,
            |_| {},
            Par::Seq,
            MemStack::new(mem),
        )
        .ok()?;
        if !x.iter().all(|v| v.is_finite()) {
            return None;
        }
        // The true residual, checked (faer 0.24's BiCGSTAB leaves its residual
        // uninitialised when told the initial guess is zero, so the guess is passed as
        // "maybe non-zero"; this check keeps any such surprise out of the Newton direction).
        let x = std::mem::take(&mut self.krylov_x);
        let (r2, b2) = self.residual2(&x, rhs);
        self.krylov_x = x;
        if r2.is_nan() || r2 > 100.0 * REUSE_TOL * REUSE_TOL * b2 {
            return None;
        }
        rhs.copy_from_slice(&self.krylov_x);
        Some(info.iter_count)
    }

    /// |b - A x|^2 and |b|^2 for the assembled matrix A; `krylov_ax` holds b - A x after.
    fn residual2(&mut self, x: &[f64], b: &[f64]) -> (f64, f64) {
        let ax = &mut self.krylov_ax;
        ax.clear();
        ax.extend_from_slice(b);
        let (cp, ri) = (
            self.pattern.as_ref().col_ptr(),
            self.pattern.as_ref().row_idx(),
        );
        for c in 0..x.len() {
            for k in cp[c]..cp[c + 1] {
                ax[ri[k]] -= self.values[k] * x[c];
            }
        }
        let r2 = ax.iter().map(|r| r * r).sum();
        let b2 = b.iter().map(|v| v * v).sum();
        (r2, b2)
    }

    /// Factor the assembled matrix and solve it for `rhs` in place: without pivoting first
    /// ([`StaticLu`], its direction refined to [`STATIC_TOL`]), else with partial pivoting.
    /// Returns whether the pivoting LU was needed.
    fn factor_solve(
        &mut self,
        states: &[JointTangent],
        rhs: &mut [f64],
        static_pivots: Option<f64>,
    ) -> Result<bool, String> {
        self.pivoted_held = false;
        self.stale = false;
        if let Some(tol) = static_pivots
            && self.static_solve(rhs, tol)
        {
            return Ok(false);
        }
        if self.pivoted.is_none() {
            self.pivoted = Some(self.pattern.symbolic_lu()?);
        }
        let (symbolic, mem) = self.pivoted.as_mut().expect("made above");
        let a = SparseColMatRef::new(self.pattern.as_ref(), &self.values);
        let lu = symbolic
            .factorize_numeric_lu::<f64>(
                &mut self.numeric,
                a,
                Par::Seq,
                MemStack::new(mem),
                Default::default(),
            )
            .map_err(|e| singular(&format!("{e:?}"), states))?;
        let len = rhs.len();
        lu.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, len, 1),
            Par::Seq,
            MemStack::new(mem),
        );
        if let Some(i) = rhs.iter().position(|x| !x.is_finite()) {
            return Err(singular(
                &format!("the update of unknown {i} of {len} is not finite"),
                states,
            ));
        }
        self.pivoted_held = true;
        Ok(true)
    }

    /// The direction from [`StaticLu`] with up to [`STATIC_REFINE`] refinement steps: `true`
    /// with `rhs` replaced by it, or `false` with `rhs` unchanged (a pivot refused, or the
    /// residual above [`STATIC_TOL`]).
    fn static_solve(&mut self, rhs: &mut [f64], pivot_tol: f64) -> bool {
        self.static_lu.pivot_tol = pivot_tol;
        if self.static_lu.factor(&self.values).is_err() {
            return false;
        }
        // b kept aside (no allocation per iteration); x is solved in `rhs` itself.
        let mut b = std::mem::take(&mut self.rhs_keep);
        b.clear();
        b.extend_from_slice(rhs);
        self.static_lu.solve_in_place(rhs, &mut self.static_work);
        let mut ok = false;
        for refine in 0..=STATIC_REFINE {
            let (r2, b2) = self.residual2(rhs, &b);
            if !r2.is_finite() {
                break;
            }
            if r2 <= STATIC_TOL * STATIC_TOL * b2 {
                ok = true;
                break;
            }
            if refine == STATIC_REFINE {
                break;
            }
            // residual2 left b - A x in krylov_ax: solve it for the correction.
            let mut dx = std::mem::take(&mut self.krylov_ax);
            self.static_lu
                .solve_in_place(&mut dx, &mut self.static_work);
            for (xi, d) in rhs.iter_mut().zip(&dx) {
                *xi += d;
            }
            self.krylov_ax = dx;
        }
        if !ok {
            rhs.copy_from_slice(&b);
        }
        self.rhs_keep = b;
        ok
    }

    /// The full Newton matrix's values at the current iterate (`factor_and_solve`).
    fn assemble(
        &mut self,
        v: &SolidView,
        p: &RunParams,
        shift: f64,
        states: &[JointTangent],
        flow: Option<(&FlowStep, &FlowRows)>,
    ) {
        self.values.clear();
        self.values.extend_from_slice(&self.k_el);
        add_mass(&mut self.values, &self.mass_slots, &v.mass, shift);
        for (k, st) in states.iter().enumerate() {
            let kt = joint_tangent(v, p, k, *st);
            let slots = &self.joint_slots[k];
            for i in 0..64 {
                if slots[i] != NONE {
                    self.values[slots[i]] += kt[i];
                }
            }
        }
        if let Some((f, rows)) = flow {
            let c_map = f.part.coupling.as_ref().expect("coupled flow");
            let n = self.n;
            let a_rows = rows.a_rows();
            for (slot, val) in self.j_slots.iter().zip(rows.jacobian_values()) {
                self.values[*slot] += val;
            }
            for c in 0..self.nc {
                for &(q, a) in &a_rows[c] {
                    let s = self.pattern.slot(n + c, q).expect("A in pattern");
                    self.values[s] += a;
                }
                let kj = c_map.cell_joint[c];
                if kj == u32::MAX || !FlowRows::has_faces(f, c) || rows.dp_dy(c) == 0.0 {
                    continue;
                }
                // -G H: the face pressure's force per unit pressure, len d(delta_n)/du.
                let n = joint_frame(v, kj as usize).n;
                let len0 = hydrofrac_core::view::joint_len0(v, kj as usize);
                for (i, s) in self.g_slots[c].iter().enumerate() {
                    if *s != NONE {
                        self.values[*s] -= len0 * FACE[i / 2] * n[i % 2];
                    }
                }
            }
        }
    }
}

/// The error of a singular Newton matrix, with a hint when joints slide.
fn singular(why: &str, states: &[JointTangent]) -> String {
    let sliding = states.iter().filter(|s| **s == JointTangent::Slip).count();
    if sliding > 0 {
        format!(
            "the Newton matrix is singular ({why}) with {sliding} joints in slip: the joints \
             slide past the Coulomb limit and hold a block by friction alone, which has no \
             static equilibrium (use time.solid_scheme: Explicit to follow the sliding)"
        )
    } else {
        format!(
            "the Newton matrix is singular ({why}): the rock can move as a rigid body (too few \
             supports) or a block is held by open joints only"
        )
    }
}

fn key(v: &SolidView, flow: Option<&mut FlowStep>) -> (u64, usize, usize, bool) {
    match flow {
        Some(f) => {
            let nc = f.part.view.n_cells();
            let fv = &f.part.view;
            let nnz = f
                .part
                .implicit
                .as_mut()
                .and_then(|s| s.pattern(fv).ok().map(|p| p.sparse.nnz()))
                .unwrap_or(0);
            (v.generation, nc, nnz, f.faces)
        }
        None => (v.generation, 0, 0, false),
    }
}

/// The exact contact tangent of joint `k` in state `st` at the current iterate (module
/// documentation), row-major 8 x 8 over its dofs (node-major, x then y).
pub(crate) fn joint_tangent(v: &SolidView, p: &RunParams, k: usize, st: JointTangent) -> [f64; 64] {
    let mut out = [0.0; 64];
    if st == JointTangent::Open {
        return out;
    }
    let fr = joint_frame(v, k);
    let js = &v.joint_state[k];
    let along = |e: [f64; 2]| -> [f64; 8] { std::array::from_fn(|i| FACE[i / 2] * e[i % 2]) };
    let (an, at) = (along(fr.n), along(fr.t));
    let mut b = [0.0; 8];
    for d in 0..2 {
        b[d] = -fr.n[d] / fr.len;
        b[2 + d] = fr.n[d] / fr.len;
    }
    let kn = p.joint.kn;
    // d(delta_n) and d(delta_t) along the turning frame.
    let ddn: [f64; 8] = std::array::from_fn(|i| an[i] - fr.dt * b[i]);
    let ddt: [f64; 8] = std::array::from_fn(|i| at[i] + fr.dn * b[i]);
    // Rows: -dF_n/du, -dF_t/du.
    let dfn = ddn.map(|x| kn * x);
    let dft: [f64; 8] = match st {
        JointTangent::Stick => ddt.map(|x| p.joint.kt * x),
        _ => {
            let s = if js.shear_force == 0.0 {
                0.0
            } else {
                js.shear_force.signum()
            };
            dfn.map(|x| p.joint.mu * s * x)
        }
    };
    let (f_n, f_t) = (js.normal_force, js.shear_force);
    for i in 0..8 {
        for j in 0..8 {
            out[8 * i + j] = an[i] * dfn[j] + at[i] * dft[j] - (f_t * an[i] - f_n * at[i]) * b[j];
        }
    }
    out
}
