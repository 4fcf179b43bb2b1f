//! `solve` (`time.solid_scheme: QuasiStatic`): the rock's equilibrium at the end of the step,
//! instead of the explicit scheme's central-difference step. The same physics: the residual is
//! the sum of the forces the explicit systems compute (`internal_force`, `external_load`,
//! `contact`), evaluated by the same kernels, so both schemes have the same static answers.
//!
//! Newton on the free degrees of freedom: K_T du = f(u), u += du, with prescribed components
//! held at `load_factor * value`. K_T is the CST stiffness (`element::element_stiffness`) plus,
//! per joint, the penalty springs of its contact state: K_n n n^T on the faces' relative
//! displacement when closed, K_t t t^T when sticking; sliding joints carry mu F_n s and add
//! no tangential spring, but their Coulomb term mu K_n s a_t a_n^T (unsymmetric) is added to
//! every solve by Sherman-Morrison-Woodbury over the symmetric factor (`SlipTerm`). The shear force's return map
//! starts from the step-start state at every iteration, so iterates do not accumulate slip.
//! Converged when the free-dof residual is below `tol` times the larger of the reactions-and-
//! loads norm and the step's first residual, and the contact states did not change in the
//! last iteration; stopped as diverged when it passes [`DIVERGED`] times that scale (the
//! step then fails as one that does not converge); after `freeze_after` iterations the
//! states are frozen in the tangent (the residual keeps the true return map). From
//! [`SOLID_LINE_SEARCH_AFTER`] iterations on, a step without flow damps each update by a
//! line search on |F|^2 (coupled steps search from the first iteration): on the interlocked
//! zigzag of `verify slip_inclined` (snapped mesh, b/h = 10 and 80) a joint opened and closed
//! at every iteration, and freezing the tangent's states did not stop the residual's, so
//! Newton stalled at a relative residual of 1e-3 until the cap; with the line search it
//! converges in 19-20 iterations.
//!
//! Linear algebra ([`Linear`], `time.linear_solver`): faer's sparse Cholesky (AMD ordering).
//! The symbolic analysis is kept while the topology is unchanged (the pattern holds every
//! joint's springs, open or not); the numeric factor is kept while the contact states are
//! unchanged, so a step whose states do not change costs solves only. With many sliding
//! joints or many coupled fracture cells (the Sherman-Morrison-Woodbury term and W = K_T^-1 G
//! then cost a solve per sliding joint and per cell), the full unsymmetric Newton matrix with
//! the exact joint tangent is factored by sparse LU instead, every iteration
//! (`systems::quasi_static_lu`). SI units: forces N/m, displacements m.

use crate::RunError;
use crate::fracture::{contact, fluid_pressure, joint_frame};
use crate::quasi_static_flow::{FlowRows, FlowStep};
use crate::quasi_static_lu::{Direction, FullTangent, JointTangent, LuOptions};
use crate::solid::{StepStats, external_load, internal_force, strain_energy};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky};
use faer::{Conj, MatMut, Par, Side};
use hydrofrac_core::element::element_stiffness;
use hydrofrac_core::params::RunParams;
use hydrofrac_core::sparse::SparsePattern;
use hydrofrac_core::view::SolidView;

/// Default relative residual tolerance of the equilibrium iteration.
pub const DEFAULT_TOL: f64 = hydrofrac_core::scenario::DEFAULT_NEWTON_TOL;
/// Newton iterations before the run stops with an error.
pub const MAX_ITER: usize = 60;
/// Halvings the coupled line search tries after the full step and the first kink (when none
/// of them meets the Armijo condition, the trial of lowest merit is taken).
pub const LINE_SEARCH_HALVINGS: i32 = 10;
/// Newton iterations of a step without flow after which each update is damped by the line
/// search (coupled steps search from the first): cycling between contact states (a joint
/// opening and closing at every iteration on the interlocked zigzag of `verify slip_inclined`)
/// is broken, while the steps that converge sooner keep their full Newton updates.
pub const SOLID_LINE_SEARCH_AFTER: usize = 8;
/// Relative residual (against the larger of the reactions and the step's first residual)
/// past which the iteration has diverged and stops: on a conforming Example II mesh under a
/// sudden 9 MPa, 1,690 joints switched to slip and the updates grew to 1e9 m within three
/// iterations and to non-finite values after 33 (each a sparse LU).
pub const DIVERGED: f64 = 1e4;
/// Iterations after which the contact states are frozen.
pub const FREEZE_AFTER: usize = 30;
/// Low-rank updates of W in a row before it is solved again in full (bounds round-off drift).
pub const MAX_W_UPDATES: usize = 16;
/// Largest backward error |K_T W x - G x| / |G x| an updated W may have; above it, W is solved
/// again in full. A full solve gives 1e-14; updates give 1e-15 to 4e-8 when K_T is well
/// conditioned and 1e-7 to 4 where a soft mode (sliding or open joints around a block) makes
/// the update cancel (measured on `kgd.ron` and `example1_cross.ron`). W only enters the
/// Newton matrix, so 1e-7 costs no iterations.
pub const W_UPDATE_TOL: f64 = 1e-7;
/// Columns per block of a multi-column solve: fixed, so the bits do not depend on the number
/// of threads that share the blocks.
const SOLVE_BLOCK: usize = 8;

const NONE: usize = usize::MAX;

/// Contact state of a joint in the tangent: open, closed and sticking, closed and sliding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Open,
    Stick,
    Slip,
}

/// What the solver did, summed over the run (reported in `summary.json`).
#[derive(Clone, Copy, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct QsCounts {
    pub steps: u64,
    pub newton_iterations: u64,
    pub symbolic_factorisations: u64,
    pub numeric_factorisations: u64,
    pub solves: u64,
    /// Newton iterations of the last step.
    pub last_iterations: u64,
    /// Coupled runs: columns of K^-1 G solved (one per fracture cell and full rebuild of W,
    /// one per changed joint spring and low-rank update of W).
    pub coupling_solves: u64,
    /// Coupled runs: refactorisations after which W = K_T^-1 G was updated for the changed
    /// joint springs instead of solved again column by column.
    pub w_updates: u64,
    /// Updates refused for their backward error (above [`W_UPDATE_TOL`]), W then solved in
    /// full.
    pub w_updates_refused: u64,
    /// Newton iterations whose direction came from the full matrix's sparse LU
    /// ([`Linear::Lu`]), and the symbolic analyses of its pattern.
    pub lu_factorisations: u64,
    pub lu_symbolic: u64,
    /// Of `lu_factorisations`, those that needed partial pivoting: the factor without
    /// pivoting ([`hydrofrac_core::static_lu`]) refused a pivot or left a residual above
    /// [`crate::quasi_static_lu::STATIC_TOL`].
    pub lu_pivoted: u64,
    /// Newton iterations whose direction came from BiCGSTAB preconditioned by an earlier
    /// iteration's LU factor of the same pattern instead of a new factorisation
    /// (`systems::quasi_static_lu`), and their BiCGSTAB iterations.
    pub lu_reused: u64,
    pub krylov_iterations: u64,
    /// Steps retried with half the step after Newton failed.
    pub cutbacks: u64,
    /// Re-solves at the same time after a split opened faces, their most in one step, and
    /// the steps that reached the cap `time.max_resolves`.
    pub resolves: u64,
    pub max_resolves_in_step: u64,
    pub resolve_cap_hits: u64,
    /// [`Linear::Auto`]: solves (steps and re-solves) whose Newton iteration failed with the
    /// Cholesky tangent and were solved again with the LU, which then holds for a while
    /// ([`QuasiStatic::lu_left`]).
    pub lu_retries: u64,
}

/// Everything that depends on the topology (dof numbering, pattern, elastic values, symbolic
/// factorisation), plus the numeric factor of the last contact states.
struct Structure {
    generation: u64,
    /// Free dof index of node i's component d at `2 i + d` (`NONE`: prescribed).
    dof: Vec<usize>,
    n: usize,
    pattern: SparsePattern,
    /// Elastic values in pattern order.
    k_el: Vec<f64>,
    /// Per joint, the slot of each (a, b) entry of its 8 x 8 block (dofs of its 4 nodes).
    joint_slots: Vec<[usize; 64]>,
    /// Per joint, the unit normal and tangent its springs act along in K_T, its normal and its
    /// length (m) in G: the geometry at the last refactorisation that was not followed by a
    /// low-rank update of W (so along a chain of updates K_T changes only in the joints whose
    /// states changed, and each update is exact).
    joint_axes: Vec<[[f64; 2]; 2]>,
    joint_normal: Vec<[f64; 2]>,
    joint_len: Vec<f64>,
    /// Per joint, the free dof of each of its 8 components (`NONE`: prescribed).
    joint_dofs: Vec<[usize; 8]>,
    /// The mass term's slots ([`mass_slots`]).
    mass_slots: Vec<(u32, usize)>,
    symbolic: SymbolicCholesky<usize>,
    mem: MemBuffer,
}

impl Structure {
    /// Each joint's axes, normal and length from the current positions.
    fn set_joint_geometry(&mut self, v: &SolidView) {
        let frames = (0..v.joint_nodes.len()).map(|k| joint_frame(v, k));
        (self.joint_axes, self.joint_normal, self.joint_len) = (
            Vec::with_capacity(v.joint_nodes.len()),
            Vec::with_capacity(v.joint_nodes.len()),
            Vec::with_capacity(v.joint_nodes.len()),
        );
        for (k, f) in frames.enumerate() {
            self.joint_axes.push([f.n, f.t]);
            self.joint_normal.push(f.n);
            // The face pressure's length (`fracture::fluid_pressure`).
            self.joint_len.push(hydrofrac_core::view::joint_len0(v, k));
        }
    }
}

/// The quasi-static solver of a run (see the module documentation).
pub struct QuasiStatic {
    /// The force systems in the residual.
    pub on: Systems,
    structure: Option<Structure>,
    /// Contact states and Cholesky values of the current numeric factor.
    factored: Option<Vec<State>>,
    l_values: Vec<f64>,
    values: Vec<f64>,
    /// Low-rank updates of W since it was last solved in full, and how many are allowed in a
    /// row (0: W solved in full after every refactorisation, for comparison).
    w_updates: usize,
    pub max_w_updates: usize,
    pub tol: f64,
    /// The most Newton iterations of one solve ([`MAX_ITER`]; the production stage's settling
    /// steps allow fewer, since a shorter step is cheaper than a long failed solve).
    pub max_iter: usize,
    pub counts: QsCounts,
    /// The network's rows of a coupled step.
    pub rows: FlowRows,
    /// Which linear solver makes the Newton direction (see [`Linear`]).
    pub linear: Linear,
    /// The full Newton matrix's pattern and LU factors ([`Linear::Lu`]).
    full: Option<FullTangent>,
    /// Whether a Newton direction on the LU path may come from BiCGSTAB preconditioned by
    /// an earlier factor of the same pattern (default on; off for comparison).
    pub reuse_lu: bool,
    /// The LU path factors without pivoting first, on the pattern's symmetric fill
    /// ([`hydrofrac_core::static_lu`]), refusing pivots below this times the largest
    /// diagonal entry (default [`hydrofrac_core::static_lu::PIVOT_TOL`]; tests raise it to
    /// take the fallback). `None`, for comparison: faer's LU with partial pivoting at every
    /// factorisation.
    pub static_pivots: Option<f64>,
    lu_rhs: Vec<f64>,
    /// `time.inertia: BackwardEuler`: the state at the start of the step being solved.
    pub step_start: Option<StepStart>,
    /// The mass shift 1/dt^2 (1/s^2) of the numeric factor (0: none).
    factored_shift: f64,
    /// Re-solves after splits in the step being taken (0 until it splits; the time series'
    /// `resolves` column). Not in checkpoints: a restart starts between steps, where it is 0.
    pub step_resolves: u64,
    /// [`Linear::Auto`]: while above 0, every Newton direction comes from the full matrix's
    /// LU; set by the retry of a solve that failed with the Cholesky tangent
    /// (`quasi_static_step::solve_step`, `resolve_at`) to [`QuasiStatic::lu_hold`] steps, one
    /// less after each step solved, then the Cholesky tangent again.
    /// Not in checkpoints: a restarted run starts with the Cholesky tangent again (its steps
    /// agree to the solver's tolerance, as every quasi-static restart's).
    pub lu_left: u64,
    /// The LU's hold after the last retry: [`LU_HOLD_FIRST`] steps, doubled at every retry
    /// after the first (a scene where the Cholesky tangent keeps failing pays one failed
    /// Cholesky solve per doubling; one where it failed once goes back to it).
    pub lu_hold: u64,
    /// A stop request checked between Newton iterations (non-zero: stop): a solve it
    /// interrupts fails with "interrupted". Set by the production stage, whose failed solve is
    /// rolled back and which then ends between two solves (a solve of Example II's network
    /// from scratch takes tens of iterations); the step loop of a run stops between steps.
    pub interrupt: Option<crate::StopFlag>,
}

/// The state at the start of an implicit-dynamics step (`time.inertia: BackwardEuler`): its
/// length (s), and per node the displacement (m) and velocity (m/s), in the order of the view
/// of topology `generation`, whose nodes' stable ids are `id`. A re-solve at the same time
/// after a split solves the same step again on the rebuilt view: each node keeps its start
/// state by stable id (the rebuilt view may order the nodes differently), and a node the
/// split added takes the start state that gives its own end state, u_n = u - dt v, v_n = v
/// (its origin's, less the step's acceleration).
#[derive(Clone, Debug, Default)]
pub struct StepStart {
    pub dt: f64,
    pub u: Vec<[f64; 2]>,
    pub v: Vec<[f64; 2]>,
    pub id: Vec<u64>,
    pub generation: u64,
}

impl StepStart {
    /// The mass shift 1/dt^2 of the tangent, 1/s^2.
    pub fn shift(&self) -> f64 {
        1.0 / (self.dt * self.dt)
    }

    /// The inertia force of node i at displacement `u`: -m (u - u_n - dt v_n) / dt^2, N/m.
    fn force(&self, mass: f64, i: usize, u: [f64; 2]) -> [f64; 2] {
        let s = mass * self.shift();
        std::array::from_fn(|d| -s * (u[d] - self.u[i][d] - self.dt * self.v[i][d]))
    }

    /// The squared norm of the inertia force over the free dofs of `v` at its displacements:
    /// after a converged step the inertia force balances F(u), so this is the squared static
    /// residual of the step's end state (the production stage's settling reads it).
    pub fn force_norm2(&self, v: &SolidView) -> f64 {
        let mut r2 = 0.0;
        for i in 0..v.n_nodes() {
            let f = self.force(v.mass[i], i, v.u[i]);
            for (d, fd) in f.iter().enumerate() {
                if v.fixed[i] & (1 << d) == 0 {
                    r2 += fd * fd;
                }
            }
        }
        r2
    }

    /// Carry the start state over to the view's topology after a split: by stable id for the
    /// nodes that were there, and for the nodes added since the step started the start state
    /// that gives their current end state.
    fn extend(&mut self, v: &SolidView) {
        if self.generation == v.generation {
            return;
        }
        let by_id: std::collections::HashMap<u64, ([f64; 2], [f64; 2])> = self
            .id
            .iter()
            .zip(self.u.iter().zip(&self.v))
            .map(|(&id, (&u, &w))| (id, (u, w)))
            .collect();
        let dt = self.dt;
        let (u, w): (Vec<_>, Vec<_>) = (0..v.n_nodes())
            .map(|i| {
                by_id.get(&v.node_id[i]).copied().unwrap_or_else(|| {
                    let (u, w) = (v.u[i], v.v[i]);
                    ([u[0] - dt * w[0], u[1] - dt * w[1]], w)
                })
            })
            .unzip();
        self.u = u;
        self.v = w;
        self.id.clone_from(&v.node_id);
        self.generation = v.generation;
    }
}

/// Per free dof, its node and its diagonal slot in a tangent's pattern, for the mass term
/// M / dt^2 of implicit dynamics (one home for the Cholesky and the LU tangent).
pub(crate) fn mass_slots(dof: &[usize], slot: impl Fn(usize, usize) -> usize) -> Vec<(u32, usize)> {
    dof.iter()
        .enumerate()
        .filter(|(_, k)| **k != NONE)
        .map(|(j, &k)| ((j / 2) as u32, slot(k, k)))
        .collect()
}

/// values += shift M on the diagonal slots `slots` ([`mass_slots`]).
pub(crate) fn add_mass(values: &mut [f64], slots: &[(u32, usize)], mass: &[f64], shift: f64) {
    if shift > 0.0 {
        for &(i, s) in slots {
            values[s] += shift * mass[i as usize];
        }
    }
}

/// The linear algebra of the Newton direction (`time.linear_solver`).
pub use hydrofrac_core::scenario::LinearSolver as Linear;

/// [`Linear::Auto`] takes the LU when more joints than this slide.
pub const LU_MIN_SLIDING: usize = 32;
/// [`Linear::Auto`] takes the LU when more fracture cells than this load the rock.
pub const LU_MIN_CELLS: usize = 200;

/// Steps the LU keeps the Newton directions after the first retry of a failed Cholesky step
/// ([`QuasiStatic::lu_hold`]).
pub const LU_HOLD_FIRST: u64 = 8;

impl QuasiStatic {
    /// A solver whose residual includes the force systems `on`.
    pub fn new(on: Systems) -> Self {
        QuasiStatic {
            on,
            structure: None,
            factored: None,
            l_values: Vec::new(),
            values: Vec::new(),
            w_updates: 0,
            max_w_updates: MAX_W_UPDATES,
            tol: DEFAULT_TOL,
            max_iter: MAX_ITER,
            counts: QsCounts::default(),
            rows: FlowRows::default(),
            linear: Linear::Auto,
            full: None,
            reuse_lu: true,
            static_pivots: Some(hydrofrac_core::static_lu::PIVOT_TOL),
            lu_rhs: Vec::new(),
            step_start: None,
            factored_shift: 0.0,
            step_resolves: 0,
            lu_left: 0,
            lu_hold: 0,
            interrupt: None,
        }
    }
}

fn fail(step: u64, time: f64, why: String) -> RunError {
    RunError::QuasiStatic { step, time, why }
}

impl QuasiStatic {
    fn structure(&mut self, v: &SolidView, p: &RunParams) -> Result<(), String> {
        if self
            .structure
            .as_ref()
            .is_some_and(|s| s.generation == v.generation)
        {
            return Ok(());
        }
        let mut dof = vec![NONE; 2 * v.n_nodes()];
        let mut n = 0;
        for i in 0..v.n_nodes() {
            for d in 0..2 {
                if v.fixed[i] & (1 << d) == 0 {
                    dof[2 * i + d] = n;
                    n += 1;
                }
            }
        }
        let dofs_of = |nodes: &[u32]| dofs_of(&dof, nodes);
        // Lower triangle (row >= col) of every element and joint block.
        let mut entries = Vec::new();
        let blocks = v
            .conn
            .iter()
            .map(|c| dofs_of(c))
            .chain(v.joint_nodes.iter().map(|j| dofs_of(j)));
        for d in blocks.clone() {
            for &a in &d {
                for &b in &d {
                    if a != NONE && b != NONE && a >= b {
                        entries.push((a, b));
                    }
                }
            }
        }
        let pattern = SparsePattern::from_entries(n, entries)?;
        let slot = |a: usize, b: usize| -> usize {
            if a == NONE || b == NONE || a < b {
                NONE
            } else {
                pattern.slot(a, b).expect("in pattern")
            }
        };
        let (k_el, joint_slots) = rock_stiffness(v, p, &dof, pattern.nnz(), slot);
        let mass_slots = mass_slots(&dof, slot);
        let (symbolic, mem) = pattern.symbolic_cholesky()?;
        let joint_dofs = v
            .joint_nodes
            .iter()
            .map(|j| std::array::from_fn(|i| dof[2 * j[i / 2] as usize + i % 2]))
            .collect();
        self.counts.symbolic_factorisations += 1;
        self.factored = None;
        self.rows.forget_w();
        self.structure = Some(Structure {
            generation: v.generation,
            dof,
            n,
            pattern,
            k_el,
            joint_slots,
            joint_axes: Vec::new(),
            joint_normal: Vec::new(),
            joint_len: Vec::new(),
            joint_dofs,
            mass_slots,
            symbolic,
            mem,
        });
        Ok(())
    }

    /// Numeric factor of K_T for the contact `states` (kept while they are unchanged), with
    /// the joints' geometry taken afresh from the current positions when `refresh`.
    /// Returns the states of the factor it replaced, if it made a new one.
    fn factor(
        &mut self,
        v: &SolidView,
        p: &RunParams,
        states: &[State],
        refresh: bool,
    ) -> Result<Option<Vec<State>>, String> {
        let shift = self.shift();
        if shift != self.factored_shift {
            // The step length changed: W = K_T^-1 G is solved again, not updated.
            self.factored = None;
            self.rows.forget_w();
        }
        if self.factored.as_deref() == Some(states) {
            return Ok(None);
        }
        self.factored_shift = shift;
        let s = self.structure.as_mut().expect("structure");
        if refresh {
            s.set_joint_geometry(v);
        }
        self.values.clear();
        self.values.extend_from_slice(&s.k_el);
        for (k, st) in states.iter().enumerate() {
            for (kk, a) in joint_springs(p, &s.joint_axes[k], *st) {
                for i in 0..8 {
                    for j in 0..8 {
                        let slot = s.joint_slots[k][8 * i + j];
                        if slot != NONE {
                            self.values[slot] += kk * a[i] * a[j];
                        }
                    }
                }
            }
        }
        add_mass(&mut self.values, &s.mass_slots, &v.mass, shift);
        self.l_values.clear();
        self.l_values.resize(s.symbolic.len_val(), 0.0);
        let a = SparseColMatRef::new(s.pattern.as_ref(), &self.values);
        s.symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                a,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut s.mem),
                Default::default(),
            )
            .map_err(|e| {
                let sliding = states.iter().filter(|s| **s == State::Slip).count();
                if sliding > 0 {
                    format!(
                        "the stiffness is not positive definite ({e:?}) with {sliding} joints \
                         in slip: the joints slide past the Coulomb limit and hold a block by \
                         friction alone, which has no static equilibrium (use \
                         time.solid_scheme: Explicit to follow the sliding)"
                    )
                } else {
                    format!(
                        "the stiffness is not positive definite ({e:?}): the rock can move as \
                         a rigid body (too few supports) or a block is held by open joints only"
                    )
                }
            })?;
        self.counts.numeric_factorisations += 1;
        Ok(self.factored.replace(states.to_vec()))
    }

    /// How well W solves K_T W = G: |K_T W x - G x| / |G x| for the fixed weights x of
    /// [`FlowRows::w_combination`], given `gx` = G x. A full solve gives round-off (1e-14); a
    /// low-rank update loses digits when K_T has a soft mode (a block held by sliding or open
    /// joints), which this catches.
    fn w_backward_error(&self, gx: &[f64], wx: &mut Vec<f64>) -> f64 {
        let s = self.structure.as_ref().expect("structure");
        self.rows.w_combination(s.n, wx);
        let (ptr, idx) = (s.pattern.col_ptr(), s.pattern.row_idx());
        let mut r: Vec<f64> = gx.iter().map(|g| -g).collect();
        for j in 0..s.n {
            for k in ptr[j]..ptr[j + 1] {
                let (i, a) = (idx[k], self.values[k]);
                r[i] += a * wx[j];
                if i != j {
                    r[j] += a * wx[i];
                }
            }
        }
        let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        norm(&r) / norm(gx).max(f64::MIN_POSITIVE)
    }

    /// After a refactorisation from the contact states `before` (factor number `before_id`)
    /// to `now`, bring W = K_T^-1 G up to date without solving every column again:
    /// K_new = K_old + sum_s dk_s a_s a_s^T over the joint springs that changed, so
    /// K_new W_new = G = K_old W_old gives W_new = W_old - K_new^-1 (sum_s dk_s a_s a_s^T) W_old,
    /// one solve per changed spring. Returns false (W left for a full solve) when W was not
    /// that of the factor replaced, the change is not small against the columns, or
    /// `max_w_updates` updates were made in a row.
    fn update_w(
        &mut self,
        p: &RunParams,
        before: &[State],
        before_id: u64,
        now: &[State],
    ) -> Result<bool, String> {
        if !self.rows.w_is_for(before_id) || self.w_updates >= self.max_w_updates {
            return Ok(false);
        }
        let s = self.structure.as_ref().expect("structure");
        let n = s.n;
        let m = self.rows.w_columns(n);
        // The changed springs (dk_s, a_s) and their dofs.
        let mut springs: Vec<(f64, [f64; 8])> = Vec::new();
        let mut at_dofs = Vec::new();
        for (k, (b, a)) in before.iter().zip(now).enumerate() {
            if b == a {
                continue;
            }
            let old = joint_springs(p, &s.joint_axes[k], *b);
            let new = joint_springs(p, &s.joint_axes[k], *a);
            for (o, w) in old.iter().zip(&new) {
                if o.0 != w.0 {
                    springs.push((w.0 - o.0, w.1));
                    at_dofs.push(s.joint_dofs[k]);
                }
            }
        }
        if 4 * springs.len() > m {
            return Ok(false);
        }
        let ns = springs.len();
        let mut z = vec![0.0; n * ns];
        for (j, ((_, a), d)) in springs.iter().zip(&at_dofs).enumerate() {
            for i in 0..8 {
                if d[i] != NONE {
                    z[j * n + d[i]] += a[i];
                }
            }
        }
        solve_columns(s, &self.l_values, &mut z, ns)?;
        update_columns(self.rows.w_buffer(), n, m, &springs, &at_dofs, &z);
        self.counts.coupling_solves += ns as u64;
        self.w_updates += 1;
        Ok(true)
    }

    /// Whether a failed solve may be solved again by LU: `Auto`, not already on the LU.
    pub fn may_retry_lu(&self) -> bool {
        self.linear == Linear::Auto && self.lu_left == 0
    }

    /// Whether this iteration's direction comes from the full matrix's LU ([`Linear`]).
    fn use_lu(&self, states: &[State], flow: Option<&FlowStep>) -> bool {
        match self.linear {
            Linear::Cholesky => false,
            Linear::Lu => true,
            Linear::Auto if self.lu_left > 0 => true,
            Linear::Auto => {
                let sliding = states.iter().filter(|s| **s == State::Slip).count();
                let cells = flow.map_or(0, |f| {
                    let c = f.part.coupling.as_ref().expect("coupled flow");
                    let with_joint = c.cell_joint.iter().filter(|j| **j != u32::MAX).count();
                    if f.faces { with_joint } else { 0 }
                });
                sliding > LU_MIN_SLIDING || cells > LU_MIN_CELLS
            }
        }
    }

    /// The Newton direction from the full matrix ([`FullTangent`]): du into `rhs` (which
    /// holds F on entry), and dy into the flow rows.
    fn lu_direction(
        &mut self,
        v: &SolidView,
        p: &RunParams,
        states: &[State],
        flow: &mut Option<FlowStep>,
        rhs: &mut [f64],
    ) -> Result<(), String> {
        let s = self.structure.as_ref().expect("structure");
        let n = s.n;
        if !self
            .full
            .as_ref()
            .is_some_and(|t| t.matches(v, flow.as_mut()))
        {
            self.full = None;
            self.full = Some(FullTangent::build(v, p, &s.dof, n, flow.as_mut())?);
            self.counts.lu_symbolic += 1;
        }
        let tangent: Vec<JointTangent> = states
            .iter()
            .map(|st| match st {
                State::Open => JointTangent::Open,
                State::Stick => JointTangent::Stick,
                State::Slip => JointTangent::Slip,
            })
            .collect();
        let tangent = if self.on.contact {
            tangent
        } else {
            vec![JointTangent::Open; states.len()]
        };
        let shift = self.shift();
        self.lu_rhs.clear();
        self.lu_rhs.extend_from_slice(rhs);
        if let Some(f) = flow.as_mut() {
            let dof = &self.structure.as_ref().expect("structure").dof;
            self.rows.linearise(f, v, dof)?;
            let nc = f.part.view.n_cells();
            self.lu_rhs.extend_from_slice(&self.rows.b[..nc]);
        }
        let full = self.full.as_mut().expect("built above");
        let direction = full.factor_and_solve(
            v,
            p,
            shift,
            &tangent,
            flow.as_ref().map(|f| (f, &self.rows)),
            &mut self.lu_rhs,
            LuOptions {
                reuse: self.reuse_lu,
                static_pivots: self.static_pivots,
            },
        )?;
        match direction {
            Direction::Factored { pivoted } => {
                self.counts.lu_factorisations += 1;
                self.counts.lu_pivoted += u64::from(pivoted);
            }
            Direction::Reused { iterations } => {
                self.counts.lu_reused += 1;
                self.counts.krylov_iterations += iterations as u64;
            }
        }
        rhs.copy_from_slice(&self.lu_rhs[..n]);
        if flow.is_some() {
            let dy = self.lu_rhs[n..].to_vec();
            self.rows.set_dy(&dy);
        }
        Ok(())
    }

    /// Drop the numeric factor, so the next iteration refactorises with the joints' geometry
    /// taken afresh (benchmarks; the production stage after restoring a failed solve's start).
    /// The mass shift 1/dt^2 of the step being solved (0: equilibrium), 1/s^2.
    fn shift(&self) -> f64 {
        self.step_start.as_ref().map_or(0.0, StepStart::shift)
    }

    pub fn forget_factor(&mut self) {
        self.factored = None;
    }

    /// The Newton direction by the Cholesky factor of the symmetric tangent: the coupled
    /// rows' W kept up to date (a low-rank update of the factor's W when accurate, else
    /// solved again), and the sliding joints' Coulomb term (unsymmetric) as a low-rank
    /// correction. `rhs` holds the residual on entry and the direction on return.
    fn cholesky_direction(
        &mut self,
        v: &SolidView,
        p: &RunParams,
        states: &[State],
        flow: &mut Option<FlowStep>,
        rhs: &mut [f64],
        work: &mut Work,
    ) -> Result<(), String> {
        let on = self.on;
        let before_id = self.counts.numeric_factorisations;
        // The joints' geometry stays that of the factor W was solved with while W may be
        // updated (an exact low-rank change); otherwise it is taken afresh.
        let may_update = flow.is_some()
            && self.factored.is_some()
            && self.rows.w_is_for(before_id)
            && self.w_updates < self.max_w_updates;
        let before = self.factor(v, p, states, !may_update)?;
        if let Some(f) = flow.as_ref() {
            let id = self.counts.numeric_factorisations;
            let updated = match before {
                Some(b) if id != before_id => {
                    let ok = self.update_w(p, &b, before_id, states)?;
                    let s = self.structure.as_ref().expect("structure");
                    let accurate = ok && {
                        self.rows.g_combination(
                            f,
                            v,
                            &s.dof,
                            s.n,
                            &s.joint_normal,
                            &s.joint_len,
                            &mut work.gx,
                        );
                        self.w_backward_error(&work.gx, &mut work.wx) <= W_UPDATE_TOL
                    };
                    if ok && !accurate {
                        self.counts.w_updates_refused += 1;
                    }
                    if accurate {
                        self.counts.w_updates += 1;
                        self.rows.set_w_factor(id);
                    }
                    accurate
                }
                _ => false,
            };
            if !updated && self.rows.needs_w(id) {
                let s = self.structure.as_ref().expect("structure");
                let m = self
                    .rows
                    .load_g(f, v, &s.dof, s.n, &s.joint_normal, &s.joint_len)?;
                self.solve_w(m)?;
                self.rows.set_w_factor(id);
            }
        }
        self.solve_in_place(rhs);
        // The sliding joints' Coulomb term (unsymmetric, left out of the Cholesky tangent)
        // as a low-rank correction of the solves.
        let slip = if on.contact {
            SlipTerm::new(self, v, p, states)?
        } else {
            None
        };
        if let Some(c) = &slip {
            c.apply(rhs);
        }
        if let Some(f) = flow.as_mut() {
            let s = self.structure.as_ref().expect("structure");
            // W of the full tangent for this iteration only: the kept W is the Cholesky
            // tangent's.
            if let Some(c) = &slip {
                work.w_keep.clear();
                work.w_keep.extend_from_slice(self.rows.w_buffer());
                for col in self.rows.w_buffer().chunks_exact_mut(s.n.max(1)) {
                    c.apply(col);
                }
            }
            let reduced = self.rows.reduce_and_solve(f, v, &s.dof, s.n, rhs);
            if slip.is_some() {
                self.rows.w_buffer().copy_from_slice(&work.w_keep);
            }
            reduced?;
        }
        Ok(())
    }

    fn solve_in_place(&mut self, x: &mut [f64]) {
        let s = self.structure.as_mut().expect("structure");
        let llt = LltRef::<usize, f64>::new(&s.symbolic, &self.l_values);
        let len = x.len();
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, len, 1),
            Par::Seq,
            MemStack::new(&mut s.mem),
        );
        self.counts.solves += 1;
    }

    /// Solve K_T X = B in place for the column-major `m` columns in the flow rows' W buffer.
    fn solve_w(&mut self, m: usize) -> Result<(), String> {
        let s = self.structure.as_ref().expect("structure");
        solve_columns(s, &self.l_values, self.rows.w_buffer(), m)?;
        self.counts.coupling_solves += m as u64;
        self.w_updates = 0;
        Ok(())
    }
}

/// W_new = W_old - Z C A^T W_old for the `m` column-major columns of `w` (n rows): the
/// changed springs `changes` (dk_s, a_s) on the dofs `dofs` (`NONE` where fixed), with
/// Z = K_new^-1 A (column s of `z`) and C = diag(dk_s), so that K_new W_new = G when
/// K_old W_old = G and K_new = K_old + A C A^T ([`QuasiStatic::update_w`]). Every a_s^T W is
/// taken on the old column: applying the springs one after the other to the updated column is
/// exact only for a single change.
fn update_columns(
    w: &mut [f64],
    n: usize,
    m: usize,
    changes: &[(f64, [f64; 8])],
    dofs: &[[usize; 8]],
    z: &[f64],
) {
    let mut coef = vec![0.0; changes.len()];
    for wc in w[..n * m].chunks_exact_mut(n.max(1)) {
        for ((c, (dk, a)), d) in coef.iter_mut().zip(changes).zip(dofs) {
            let mut b = 0.0;
            for i in 0..8 {
                if d[i] != NONE {
                    b += a[i] * wc[d[i]];
                }
            }
            *c = dk * b;
        }
        for (j, &cj) in coef.iter().enumerate() {
            if cj != 0.0 {
                for (x, zj) in wc.iter_mut().zip(&z[j * n..(j + 1) * n]) {
                    *x -= cj * zj;
                }
            }
        }
    }
}

/// Solve K_T X = B in place for the `m` column-major columns of `buf` with the factor
/// `l_values`, in blocks of [`SOLVE_BLOCK`] columns shared among the threads.
fn solve_columns(s: &Structure, l_values: &[f64], buf: &mut [f64], m: usize) -> Result<(), String> {
    use rayon::prelude::*;
    let n = s.n;
    if m == 0 || n == 0 {
        return Ok(());
    }
    let req = s
        .symbolic
        .solve_in_place_scratch::<f64>(SOLVE_BLOCK, Par::Seq);
    let llt = LltRef::<usize, f64>::new(&s.symbolic, l_values);
    buf[..n * m]
        .par_chunks_mut(n * SOLVE_BLOCK)
        .try_for_each(|block| {
            let mut mem = MemBuffer::try_new(req).map_err(|_| "out of memory for the workspace")?;
            let cols = block.len() / n;
            llt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(block, n, cols),
                Par::Seq,
                MemStack::new(&mut mem),
            );
            Ok::<(), String>(())
        })
}

/// The sliding joints' Coulomb term of the tangent: a sliding joint carries F_t = mu F_n s
/// (s the sign of its shear force), so dF_t/d(delta_n) = -mu K_n s and the tangent gains
/// mu K_n s a_t a_n^T (a_n, a_t: the joint's normal and tangential coefficients on its 8 dofs,
/// [`joint_springs`]). That term is unsymmetric, so the Cholesky factor holds the symmetric
/// rest K_s, and solves with K_s + U V^T (U = [mu K_n s a_t], V = [a_n], one column per
/// sliding joint) use Sherman-Morrison-Woodbury: x = y - Z (I + V^T Z)^-1 V^T y with
/// y = K_s^-1 b and Z = K_s^-1 U. Without it the Newton direction turns wherever joints slide
/// around a soft block (README, "Choosing the solid scheme").
struct SlipTerm {
    n: usize,
    /// Z, column-major n x r.
    z: Vec<f64>,
    /// The 8 (dof, coefficient) entries of each column of V.
    v: Vec<[(usize, f64); 8]>,
    /// LU of the r x r capacitance I + V^T Z.
    lu: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
}

impl SlipTerm {
    /// The correction for the contact `states` at the current iterate; `None` when no joint
    /// slides (or `mu` is zero).
    fn new(
        qs: &mut QuasiStatic,
        sv: &SolidView,
        p: &RunParams,
        states: &[State],
    ) -> Result<Option<Self>, String> {
        let s = qs.structure.as_ref().expect("structure");
        let n = s.n;
        let mut cols = Vec::new();
        for (k, st) in states.iter().enumerate() {
            let sign = sv.joint_state[k].shear_force.signum();
            if *st != State::Slip || p.joint.mu == 0.0 || sv.joint_state[k].shear_force == 0.0 {
                continue;
            }
            let [(_, an), (_, at)] = joint_springs(p, &s.joint_axes[k], State::Stick);
            let d = s.joint_dofs[k];
            let mut u = [(NONE, 0.0); 8];
            let mut vv = [(NONE, 0.0); 8];
            for i in 0..8 {
                if d[i] != NONE {
                    u[i] = (d[i], p.joint.mu * p.joint.kn * sign * at[i]);
                    vv[i] = (d[i], an[i]);
                }
            }
            cols.push((u, vv));
        }
        if cols.is_empty() {
            return Ok(None);
        }
        let r = cols.len();
        let mut z = vec![0.0; n * r];
        for (j, (u, _)) in cols.iter().enumerate() {
            for &(d, a) in u {
                if d != NONE {
                    z[j * n + d] += a;
                }
            }
        }
        solve_columns(s, &qs.l_values, &mut z, r)?;
        qs.counts.solves += r as u64;
        let mut cap = nalgebra::DMatrix::<f64>::identity(r, r);
        for (i, (_, vv)) in cols.iter().enumerate() {
            for j in 0..r {
                let zj = &z[j * n..(j + 1) * n];
                cap[(i, j)] += vv
                    .iter()
                    .filter(|e| e.0 != NONE)
                    .map(|&(d, a)| a * zj[d])
                    .sum::<f64>();
            }
        }
        Ok(Some(SlipTerm {
            n,
            z,
            v: cols.into_iter().map(|c| c.1).collect(),
            lu: cap.lu(),
        }))
    }

    /// x <- (K_s + U V^T)^-1 b given x = K_s^-1 b.
    fn apply(&self, x: &mut [f64]) {
        let r = self.v.len();
        let t = nalgebra::DVector::from_iterator(
            r,
            self.v.iter().map(|vv| {
                vv.iter()
                    .filter(|e| e.0 != NONE)
                    .map(|&(d, a)| a * x[d])
                    .sum::<f64>()
            }),
        );
        let Some(y) = self.lu.solve(&t) else {
            return;
        };
        for j in 0..r {
            let zj = &self.z[j * self.n..(j + 1) * self.n];
            for (xi, zi) in x.iter_mut().zip(zj) {
                *xi -= y[j] * zi;
            }
        }
    }
}

/// The penalty springs of a joint in contact state `st` along its `axes` (normal, tangent):
/// (stiffness N/m^2, coefficients on its 8 dofs). The springs act on the faces' relative
/// displacement delta = c_q - c_p, c the mean of a face's two nodes: coefficient -1/2, -1/2,
/// 1/2, 1/2 per node times the axis. Open: none; closed: K_n along n, and K_t along t when
/// sticking (a sliding joint's shear is bounded, not a spring).
fn joint_springs(p: &RunParams, axes: &[[f64; 2]; 2], st: State) -> [(f64, [f64; 8]); 2] {
    const C: [f64; 4] = [-0.5, -0.5, 0.5, 0.5];
    let along = |e: [f64; 2]| std::array::from_fn(|i| C[i / 2] * e[i % 2]);
    let (kn, kt) = match st {
        State::Open => (0.0, 0.0),
        State::Stick => (p.joint.kn, p.joint.kt),
        State::Slip => (p.joint.kn, 0.0),
    };
    [(kn, along(axes[0])), (kt, along(axes[1]))]
}

/// The forces at the current iterate, with the joints' return map restarted from `joint0`.
fn forces(
    v: &mut SolidView,
    p: &RunParams,
    lf: f64,
    on: Systems,
    joint0: &[hydrofrac_components::JointState],
) {
    v.joint_state.copy_from_slice(joint0);
    internal_force(v, &p.solid);
    if on.load {
        external_load(v, lf);
    }
    if on.contact {
        contact(v, &p.joint);
    }
}

/// Which force systems the residual includes (those the user did not switch off: without
/// `contact` the joints carry nothing in the equilibrium either, without `fluid_pressure` the
/// fluid does not load the faces).
#[derive(Clone, Copy, Debug)]
pub struct Systems {
    pub load: bool,
    pub contact: bool,
    pub fluid: bool,
}

/// Fluid pressures held fixed on the fracture faces (a coupled run whose `flow_substeps` is
/// switched off, as the explicit scheme's `fluid_pressure` holds them; the production stage's
/// equilibria): joint k's faces carry `pressure[joint_cell[k]]` (Pa) as a load.
#[derive(Clone, Copy, Debug)]
pub struct Held<'a> {
    pub joint_cell: &'a [u32],
    pub pressure: &'a [f64],
}

/// The end of the step a solve is for: the step's number and time (s), which name it in
/// errors, and the boundary schedule's load factor there.
#[derive(Clone, Copy, Debug)]
pub struct StepEnd {
    pub step: u64,
    pub time: f64,
    pub lf: f64,
    /// The step's length, s (0: a re-solve at the same time).
    pub dt: f64,
}

/// `solve`: equilibrium at the end of the step `at` under its load factor; with `flow`, the
/// network's backward-Euler step over the same step in the same Newton iteration
/// ([`crate::quasi_static_flow`]), the converged state left for the flow system's
/// commit; without it, `held` face pressures as a fixed load. Velocities are set to zero (no
/// inertia).
pub fn solve(
    v: &mut SolidView,
    qs: &mut QuasiStatic,
    mut flow: Option<FlowStep>,
    held: Option<Held>,
    p: &RunParams,
    at: StepEnd,
) -> Result<StepStats, RunError> {
    let StepEnd { step, time, lf, dt } = at;
    qs.structure(v, p).map_err(|e| fail(step, time, e))?;
    let on = qs.on;
    start_step(qs, v, p, dt);
    for i in 0..v.n_nodes() {
        for d in 0..2 {
            if v.fixed[i] & (1 << d) != 0 {
                v.u[i][d] = lf * v.presc[i][d];
            }
        }
        if qs.step_start.is_none() {
            v.v[i] = [0.0; 2];
        }
    }
    let joint0 = v.joint_state.clone();
    let n = qs.structure.as_ref().expect("structure").n;
    let mut rhs = vec![0.0; n];
    let mut states: Vec<State> = vec![State::Open; v.joint_nodes.len()];
    let mut prev: Option<Vec<State>> = None;
    let mut iterations = 0;
    if let Some(f) = flow.as_mut() {
        qs.rows.begin(f, v);
    }
    // The residual's scale: the reactions and loads, or the step's first unbalanced force when
    // that is larger (a prescribed displacement into a stress-free state, e.g. a lifted block
    // on an opening joint, ends with no reaction at all).
    let mut first2 = None;
    // The most joints in slip at any iterate of this step (for the failure's hint).
    let mut max_slip = 0;
    let mut work = Work::default();
    // The coupled line search leaves the residual of the point it accepted.
    let mut evaluated = None;
    let (res2, ref2) = loop {
        let (res2, ref2, flow_ok) = match evaluated.take() {
            Some(e) => e,
            None => evaluate(v, qs, &mut flow, held, p, lf, &joint0, &mut rhs),
        };
        if on.contact {
            for (st, js) in states.iter_mut().zip(&v.joint_state) {
                if iterations <= FREEZE_AFTER {
                    // Touching faces (delta_n = 0, e.g. a closed fracture at the start) carry
                    // the normal spring in the tangent, so a block resting on a joint is held.
                    *st = match (js.opening <= 0.0, js.sliding) {
                        (false, _) => State::Open,
                        (true, false) => State::Stick,
                        (true, true) => State::Slip,
                    };
                }
            }
        }
        max_slip = max_slip.max(states.iter().filter(|s| **s == State::Slip).count());
        let ref2 = ref2.max(*first2.get_or_insert(res2));
        let settled = prev.as_deref() == Some(&states[..]);
        if !res2.is_finite() {
            return Err(fail(step, time, "the residual is not finite".into()));
        }
        if res2 > DIVERGED * DIVERGED * ref2 {
            return Err(fail(
                step,
                time,
                format!(
                    "the Newton iteration diverged: relative residual {:.1e} after {iterations} \
                     iterations{}",
                    (res2 / ref2).sqrt(),
                    slip_hint(v, max_slip, qs.step_start.is_some())
                ),
            ));
        }
        let tol2 = qs.tol * qs.tol * ref2.max(f64::MIN_POSITIVE);
        if res2 <= tol2 && flow_ok && (settled || !on.contact) {
            break (res2, ref2);
        }
        if iterations >= qs.max_iter {
            return Err(fail(
                step,
                time,
                not_converged(v, qs, &flow, res2, ref2, max_slip),
            ));
        }
        if qs
            .interrupt
            .as_ref()
            .is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed) != 0)
        {
            return Err(fail(step, time, "interrupted by a stop request".into()));
        }
        if qs.use_lu(&states, flow.as_ref()) {
            qs.lu_direction(v, p, &states, &mut flow, &mut rhs)
                .map_err(|e| fail(step, time, e))?;
        } else {
            qs.cholesky_direction(v, p, &states, &mut flow, &mut rhs, &mut work)
                .map_err(|e| fail(step, time, e))?;
        }
        let dof = &qs.structure.as_ref().expect("structure").dof;
        if flow.is_none() && iterations < SOLID_LINE_SEARCH_AFTER {
            add_update(v, dof, &rhs, 1.0);
        } else {
            let e = line_search(
                v, qs, &mut flow, held, p, lf, &joint0, &mut rhs, &mut work, res2, tol2,
            );
            evaluated = Some(e);
        }
        prev = Some(states.clone());
        iterations += 1;
    };
    if let Some(s) = &qs.step_start {
        for i in 0..v.n_nodes() {
            v.v[i] = std::array::from_fn(|d| (v.u[i][d] - s.u[i][d]) / s.dt);
        }
    }
    qs.counts.steps += 1;
    qs.counts.newton_iterations += iterations as u64;
    qs.counts.last_iterations = iterations as u64;
    let non_finite =
        v.u.iter()
            .position(|u| !(u[0].is_finite() && u[1].is_finite()));
    Ok(StepStats {
        strain: strain_energy(v, &p.solid),
        res2,
        ref2,
        non_finite,
        ..StepStats::default()
    })
}

/// The state at the start of the step (`time.inertia: BackwardEuler`, [`StepStart`]): taken
/// for a step of length `dt` > 0 (s), kept for a re-solve at the same time (dt = 0); none
/// without inertia.
fn start_step(qs: &mut QuasiStatic, v: &SolidView, p: &RunParams, dt: f64) {
    use hydrofrac_core::scenario::Inertia;
    if p.time.inertia == Inertia::Off {
        qs.step_start = None;
    } else if dt > 0.0 {
        // The last step's buffers are reused: no allocation per step.
        let s = qs.step_start.get_or_insert_with(StepStart::default);
        s.dt = dt;
        s.u.clear();
        s.u.extend_from_slice(&v.u);
        s.v.clear();
        s.v.extend_from_slice(&v.v);
        s.id.clone_from(&v.node_id);
        s.generation = v.generation;
    } else if let Some(s) = qs.step_start.as_mut() {
        s.extend(v);
    }
}

/// Scratch arrays of a quasi-static solve, kept across its Newton iterations.
#[derive(Default)]
struct Work {
    /// The line search's base displacements and trial residual.
    u_base: Vec<[f64; 2]>,
    rhs_try: Vec<f64>,
    /// The W update's check (G x, W x) and the kept W while the slip term corrects it.
    gx: Vec<f64>,
    wx: Vec<f64>,
    w_keep: Vec<f64>,
}

/// A line search on the merit phi = |F|^2 / (tol^2 ref) (+ sum (r_c / allowed_c)^2
/// when coupled) (Armijo, c = 1e-4): the full step, else (coupled) the first kink
/// of the pressure law on the way, else halving. The kinks (a cell filling or
/// draining, a joint opening or closing, sliding or sticking) would otherwise make
/// Newton cycle.
/// When no trial meets the condition, the one of lowest merit is taken (evaluated again
/// unless it was the last): taking the smallest halving whatever its merit made Newton
/// two-cycle to its cap (`docs/schemes.md`, the coupled step's line search).
/// Returns the residual of the accepted trial (the iterate), whose forces are left in `rhs`.
#[allow(clippy::too_many_arguments)]
fn line_search(
    v: &mut SolidView,
    qs: &mut QuasiStatic,
    flow: &mut Option<FlowStep>,
    held: Option<Held>,
    p: &RunParams,
    lf: f64,
    joint0: &[hydrofrac_components::JointState],
    rhs: &mut Vec<f64>,
    work: &mut Work,
    res2: f64,
    tol2: f64,
) -> (f64, f64, bool) {
    let mut evaluated = None;
    let coupled = flow.is_some();
    let phi_of = |rows: &FlowRows| if coupled { rows.phi } else { 0.0 };
    let phi0 = res2 / tol2 + phi_of(&qs.rows);
    if coupled {
        qs.rows.save_base();
    }
    work.u_base.clear();
    work.u_base.extend_from_slice(&v.u);
    let kink = if coupled { qs.rows.first_kink() } else { None };
    let candidates = std::iter::once((1.0, None))
        .chain(kink.map(|(a, c)| (a, Some(c))))
        .chain((1..=LINE_SEARCH_HALVINGS).map(|k| (0.5f64.powi(k), None)));
    work.rhs_try.resize(rhs.len(), 0.0);
    let (u_base, rhs_try) = (&work.u_base, &mut work.rhs_try);
    // One trial: u = base + alpha du (and the cells' y), evaluated into `rhs_try`.
    let mut trial = |v: &mut SolidView,
                     qs: &mut QuasiStatic,
                     flow: &mut Option<FlowStep>,
                     alpha: f64,
                     at: Option<usize>| {
        v.u.copy_from_slice(u_base);
        let dof = &qs.structure.as_ref().expect("structure").dof;
        add_update(v, dof, rhs, alpha);
        if coupled {
            qs.rows.set_trial(alpha, at);
        }
        let e = evaluate(v, qs, flow, held, p, lf, joint0, rhs_try);
        (e, e.0 / tol2 + phi_of(&qs.rows))
    };
    // The lowest merit seen and its trial; the last trial.
    let mut best: Option<(f64, f64, Option<usize>)> = None;
    let mut last = (f64::NAN, None);
    for (alpha, at) in candidates {
        let (e, merit) = trial(v, qs, flow, alpha, at);
        evaluated = Some(e);
        last = (alpha, at);
        if merit <= (1.0 - 1e-4 * alpha) * phi0 {
            best = None;
            break;
        }
        if best.is_none_or(|b| merit < b.0) {
            best = Some((merit, alpha, at));
        }
    }
    // No trial met the condition: take the one of lowest merit.
    if let Some((_, alpha, at)) = best.filter(|b| (b.1, b.2) != last) {
        evaluated = Some(trial(v, qs, flow, alpha, at).0);
    }
    // The iterate is the last trial: its residual is the next iteration's.
    std::mem::swap(rhs, &mut work.rhs_try);
    evaluated.expect("the full step is always tried")
}

/// The dofs of a list of nodes (`NONE`: prescribed), from the node-and-direction dof map.
pub(crate) fn dofs_of(dof: &[usize], nodes: &[u32]) -> Vec<usize> {
    nodes
        .iter()
        .flat_map(|&i| [dof[2 * i as usize], dof[2 * i as usize + 1]])
        .collect()
}

/// The rock's part of a tangent on a sparse pattern of `nnz` entries, where `slot(a, b)` is
/// the entry of dofs (a, b) (`NONE`: not stored): every element's CST stiffness summed into
/// its slots (N/m per m), and per joint the slots of its 8 x 8 block (row-major), where the
/// joints' springs go at each iterate. One home for the Cholesky tangent and the full LU
/// tangent.
pub(crate) fn rock_stiffness(
    v: &SolidView,
    p: &RunParams,
    dof: &[usize],
    nnz: usize,
    slot: impl Fn(usize, usize) -> usize,
) -> (Vec<f64>, Vec<[usize; 64]>) {
    let mut k_el = vec![0.0; nnz];
    for (c, g) in v.conn.iter().zip(&v.geom) {
        let d = dofs_of(dof, c);
        let ke = element_stiffness(g, &p.solid);
        for a in 0..6 {
            for b in 0..6 {
                let s = slot(d[a], d[b]);
                if s != NONE {
                    k_el[s] += ke[(a, b)];
                }
            }
        }
    }
    let joint_slots = v
        .joint_nodes
        .iter()
        .map(|j| {
            let d = dofs_of(dof, j);
            std::array::from_fn(|i| slot(d[i / 8], d[i % 8]))
        })
        .collect();
    (k_el, joint_slots)
}

/// u += alpha du on the free dofs.
fn add_update(v: &mut SolidView, dof: &[usize], du: &[f64], alpha: f64) {
    for i in 0..v.n_nodes() {
        for d in 0..2 {
            let k = dof[2 * i + d];
            if k != NONE {
                v.u[i][d] += alpha * du[k];
            }
        }
    }
}

/// The residual at the current iterate: the forces (rock, and the face pressures of the
/// flow rows' pressures), the flow rows, the free dofs' forces into `rhs`; returns the sum of
/// squared free-dof forces, of squared reactions and loads, and whether the flow rows are
/// converged.
#[allow(clippy::too_many_arguments)]
fn evaluate(
    v: &mut SolidView,
    qs: &mut QuasiStatic,
    flow: &mut Option<FlowStep>,
    held: Option<Held>,
    p: &RunParams,
    lf: f64,
    joint0: &[hydrofrac_components::JointState],
    rhs: &mut [f64],
) -> (f64, f64, bool) {
    let on = qs.on;
    forces(v, p, lf, on, joint0);
    let flow_ok = match flow.as_mut() {
        Some(f) => {
            let ok = qs.rows.evaluate(f, v);
            if on.fluid {
                let c = f.part.coupling.as_ref().expect("coupled flow");
                let load = qs.rows.face_pressure(&f.part.view);
                fluid_pressure(v, &c.joint_cell, load);
            }
            ok
        }
        None => {
            if let (true, Some(h)) = (on.fluid, held) {
                fluid_pressure(v, h.joint_cell, h.pressure);
            }
            true
        }
    };
    if let Some(s) = &qs.step_start {
        for i in 0..v.n_nodes() {
            let f = s.force(v.mass[i], i, v.u[i]);
            v.force[i][0] += f[0];
            v.force[i][1] += f[1];
        }
    }
    let dof = &qs.structure.as_ref().expect("structure").dof;
    let (mut res2, mut ref2) = (0.0, 0.0);
    for i in 0..v.n_nodes() {
        for d in 0..2 {
            let f = v.force[i][d];
            let l = lf * v.load[i][d];
            ref2 += l * l;
            match dof[2 * i + d] {
                NONE => ref2 += f * f,
                k => {
                    rhs[k] = f;
                    res2 += f * f;
                }
            }
        }
    }
    (res2, ref2, flow_ok)
}

/// A hint for a failed iteration when joints slide (empty when none does): the larger of the
/// joints sliding at the iterate and `seen`, the most that slid at an iterate of the step.
/// With inertia (`dynamic`) a block held by sliding joints has its own motion, so the hint
/// names the contact iteration instead of a missing equilibrium.
fn slip_hint(v: &SolidView, seen: usize, dynamic: bool) -> String {
    let slip = v.joint_state.iter().filter(|s| s.sliding).count().max(seen);
    let n = v.joint_nodes.len();
    match (slip > 0, dynamic) {
        (false, _) => String::new(),
        (true, false) => format!(
            "; {slip} of {n} joints slide: past the friction limit there may be no static \
             equilibrium (the explicit scheme follows the sliding)"
        ),
        (true, true) => {
            format!("; {slip} of {n} joints slide and the contact states did not settle")
        }
    }
}

/// The message of a step that did not converge: the rock's residual, the worst cell's, and a
/// hint when joints slide.
fn not_converged(
    v: &SolidView,
    qs: &QuasiStatic,
    flow: &Option<FlowStep>,
    res2: f64,
    ref2: f64,
    seen: usize,
) -> String {
    let hint = slip_hint(v, seen, qs.step_start.is_some());
    let cell = match flow {
        Some(f) if qs.rows.worst > 1.0 => format!(
            "; {} has mass residual {:.3e} times its tolerance",
            f.part.view.cell_label(qs.rows.worst_cell),
            qs.rows.worst
        ),
        _ => String::new(),
    };
    format!(
        "no equilibrium after {} Newton iterations: relative residual {:.3e} \
         (tolerance {:.1e}){cell}{hint}",
        qs.max_iter,
        (res2 / ref2.max(f64::MIN_POSITIVE)).sqrt(),
        qs.tol
    )
}

#[cfg(test)]
mod tests {
    use super::{NONE, update_columns};
    use nalgebra::DMatrix;

    /// The low-rank update of W after several springs change at once is K_new^-1 G to
    /// round-off (1e-12 relative on a well-conditioned 10 x 10 system). Applying the springs
    /// one after the other to the updated column (the defect before 2026-12-07, which the
    /// backward-error check then refused, so W was solved again in full) is off by O(1) here.
    #[test]
    fn several_spring_changes_update_w_exactly() {
        let (n, m) = (10, 3);
        let val = |i: usize, j: usize| ((7 * i + 3 * j + 1) as f64).sin();
        let b = DMatrix::from_fn(n, n, val);
        let k_old = &b * b.transpose() + DMatrix::identity(n, n) * n as f64;
        let g = DMatrix::from_fn(n, m, |i, j| val(i + 20, j));
        let w_old = k_old.clone().lu().solve(&g).unwrap();
        // Three springs on overlapping dofs, one entry of each on a fixed dof.
        let dofs: Vec<[usize; 8]> = vec![
            [0, 1, 2, 3, 4, 5, 6, NONE],
            [2, 3, 4, 5, 6, 7, 8, 9],
            [NONE, 9, 8, 1, 0, 5, 3, 7],
        ];
        let changes: Vec<(f64, [f64; 8])> = (0..3)
            .map(|s| {
                let dk = [2.0, -1.5, 3.0][s];
                (dk, std::array::from_fn(|i| val(s + 40, i)))
            })
            .collect();
        let mut k_new = k_old.clone();
        let mut a_mat = DMatrix::zeros(n, changes.len());
        for (s, ((dk, a), d)) in changes.iter().zip(&dofs).enumerate() {
            for i in 0..8 {
                if d[i] == NONE {
                    continue;
                }
                a_mat[(d[i], s)] += a[i];
                for j in 0..8 {
                    if d[j] != NONE {
                        k_new[(d[i], d[j])] += dk * a[i] * a[j];
                    }
                }
            }
        }
        let lu = k_new.clone().lu();
        let z = lu.solve(&a_mat).unwrap();
        let want = lu.solve(&g).unwrap();
        let mut w: Vec<f64> = w_old.as_slice().to_vec();
        update_columns(&mut w, n, m, &changes, &dofs, z.as_slice());
        let err = (DMatrix::from_column_slice(n, m, &w) - &want).norm() / want.norm();
        assert!(err < 1e-12, "relative error {err:e}");
    }
}
