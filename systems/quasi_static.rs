//! `solve` (`time.solid_scheme: QuasiStatic`): the rock's equilibrium at the end of the step,
//! instead of the explicit scheme's central-difference step. The same physics: the residual is
//! the sum of the forces the explicit systems compute (`internal_force`, `external_load`,
//! `contact`), evaluated by the same kernels, so both schemes have the same static answers.
//!
//! Newton on the free degrees of freedom: K_T du = f(u), u += du, with prescribed components
//! held at `load_factor * value`. K_T is the CST stiffness (`element::element_stiffness`) plus,
//! per joint, the penalty springs of its contact state: K_n n n^T on the faces' relative
//! displacement when closed, K_t t t^T when sticking (sliding joints carry mu F_n, bounded, and
//! add no tangential stiffness: a modified Newton step there). The shear force's return map
//! starts from the step-start state at every iteration, so iterates do not accumulate slip.
//! Converged when the free-dof residual is below `tol` times the larger of the reactions-and-
//! loads norm and the step's first residual, and the contact states did not change in the
//! last iteration; after `freeze_after` iterations the
//! states are frozen, so stick/slip cannot cycle.
//!
//! Linear algebra: faer's sparse Cholesky (AMD ordering). The symbolic analysis is kept while
//! the topology is unchanged (the pattern holds every joint's springs, open or not); the
//! numeric factor is kept while the contact states are unchanged, so a step whose states do
//! not change costs solves only. SI units: forces N/m, displacements m.

use crate::element::element_stiffness;
use crate::params::RunParams;
use crate::sparse::SparsePattern;
use crate::systems::RunError;
use crate::systems::fracture::{contact, fluid_pressure, joint_frame};
use crate::systems::quasi_static_flow::{FlowRows, FlowStep};
use crate::systems::solid::{StepStats, external_load, internal_force, strain_energy};
use crate::view::SolidView;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{Conj, MatMut, Par, Side};

/// Default relative residual tolerance of the equilibrium iteration.
pub const DEFAULT_TOL: f64 = 1e-10;
/// Newton iterations before the run stops with an error.
pub const MAX_ITER: usize = 60;
/// Halvings the coupled line search tries after the full step and the first kink (the last
/// is taken whatever its merit).
pub const LINE_SEARCH_HALVINGS: i32 = 10;
/// Iterations after which the contact states are frozen.
pub const FREEZE_AFTER: usize = 30;

const NONE: usize = usize::MAX;

/// Contact state of a joint in the tangent: open, closed and sticking, closed and sliding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Open,
    Stick,
    Slip,
}

/// What the solver did, summed over the run (reported in `summary.json`).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct QsCounts {
    pub steps: u64,
    pub newton_iterations: u64,
    pub symbolic_factorisations: u64,
    pub numeric_factorisations: u64,
    pub solves: u64,
    /// Newton iterations of the last step.
    pub last_iterations: u64,
    /// Coupled runs: columns of K^-1 G solved (one per fracture cell and factorisation).
    pub coupling_solves: u64,
    /// Steps retried with half the step after Newton failed.
    pub cutbacks: u64,
    /// Re-solves at the same time after a split opened faces, their most in one step, and
    /// the steps that reached the cap `time.max_resolves`.
    pub resolves: u64,
    pub max_resolves_in_step: u64,
    pub resolve_cap_hits: u64,
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
    symbolic: SymbolicCholesky<usize>,
    mem: MemBuffer,
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
    pub tol: f64,
    pub counts: QsCounts,
    /// The network's rows of a coupled step.
    pub rows: FlowRows,
}

impl QuasiStatic {
    /// A solver whose residual includes the force systems `on`.
    pub fn new(on: Systems) -> Self {
        QuasiStatic {
            on,
            structure: None,
            factored: None,
            l_values: Vec::new(),
            values: Vec::new(),
            tol: DEFAULT_TOL,
            counts: QsCounts::default(),
            rows: FlowRows::default(),
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
        let dofs_of = |nodes: &[u32]| -> Vec<usize> {
            nodes
                .iter()
                .flat_map(|&i| [dof[2 * i as usize], dof[2 * i as usize + 1]])
                .collect()
        };
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
        let mut k_el = vec![0.0; pattern.nnz()];
        for (c, g) in v.conn.iter().zip(&v.geom) {
            let d = dofs_of(c);
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
                let d = dofs_of(j);
                let mut s = [NONE; 64];
                for a in 0..8 {
                    for b in 0..8 {
                        s[8 * a + b] = slot(d[a], d[b]);
                    }
                }
                s
            })
            .collect();
        let symbolic = factorize_symbolic_cholesky(
            pattern.as_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| format!("symbolic analysis: {e:?}"))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let mem = MemBuffer::try_new(req).map_err(|_| "out of memory for the workspace")?;
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
            symbolic,
            mem,
        });
        Ok(())
    }

    /// Numeric factor of K_T for the contact `states` (kept while they are unchanged).
    fn factor(&mut self, v: &SolidView, p: &RunParams, states: &[State]) -> Result<(), String> {
        if self.factored.as_deref() == Some(states) {
            return Ok(());
        }
        let s = self.structure.as_mut().expect("structure");
        self.values.clear();
        self.values.extend_from_slice(&s.k_el);
        for (k, st) in states.iter().enumerate() {
            if *st == State::Open {
                continue;
            }
            let f = joint_frame(v, k);
            // Springs on the faces' relative displacement delta = c_q - c_p, with
            // c = mean of the face's two nodes: coefficient c_j = -1/2, -1/2, 1/2, 1/2.
            let tangent = if *st == State::Stick { p.joint.kt } else { 0.0 };
            const C: [f64; 4] = [-0.5, -0.5, 0.5, 0.5];
            for (kk, e) in [(p.joint.kn, f.n), (tangent, f.t)] {
                for a in 0..8 {
                    for b in 0..8 {
                        let slot = s.joint_slots[k][8 * a + b];
                        if slot != NONE {
                            let ka = C[a / 2] * C[b / 2] * kk * e[a % 2] * e[b % 2];
                            self.values[slot] += ka;
                        }
                    }
                }
            }
        }
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
                format!(
                    "the stiffness is not positive definite ({e:?}): the rock can move as a \
                     rigid body (too few supports) or a block is held by open joints only"
                )
            })?;
        self.counts.numeric_factorisations += 1;
        self.factored = Some(states.to_vec());
        Ok(())
    }

    /// Drop the numeric factor, so the next iteration refactorises (benchmarks).
    pub fn forget_factor(&mut self) {
        self.factored = None;
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
        let s = self.structure.as_mut().expect("structure");
        if m == 0 {
            return Ok(());
        }
        let req = s.symbolic.solve_in_place_scratch::<f64>(m, Par::Seq);
        let mut mem = MemBuffer::try_new(req).map_err(|_| "out of memory for the workspace")?;
        let llt = LltRef::<usize, f64>::new(&s.symbolic, &self.l_values);
        let n = s.n;
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(self.rows.w_buffer(), n, m),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        self.counts.coupling_solves += m as u64;
        Ok(())
    }
}

/// The forces at the current iterate, with the joints' return map restarted from `joint0`.
fn forces(v: &mut SolidView, p: &RunParams, on: Systems, joint0: &[crate::components::JointState]) {
    v.joint_state.copy_from_slice(joint0);
    internal_force(v, &p.solid);
    if on.load {
        external_load(v, &p.solid);
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

/// `solve`: equilibrium at the end of the step (load factor already set); with `flow`, the
/// network's backward-Euler step over the same step in the same Newton iteration
/// ([`crate::systems::quasi_static_flow`]), the converged state left for the flow system's
/// commit. `step` and `time` (the step's end) name the step in errors. Velocities are set to
/// zero (no inertia).
pub fn solve(
    v: &mut SolidView,
    qs: &mut QuasiStatic,
    mut flow: Option<FlowStep>,
    p: &RunParams,
    step: u64,
    time: f64,
) -> Result<StepStats, RunError> {
    qs.structure(v, p).map_err(|e| fail(step, time, e))?;
    let on = qs.on;
    let lf = p.solid.load_factor;
    for i in 0..v.n_nodes() {
        for d in 0..2 {
            if v.fixed[i] & (1 << d) != 0 {
                v.u[i][d] = lf * v.presc[i][d];
            }
        }
        v.v[i] = [0.0; 2];
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
    let (mut u_base, mut rhs_try) = (Vec::new(), Vec::new());
    // The coupled line search leaves the residual of the point it accepted.
    let mut evaluated = None;
    let (res2, ref2) = loop {
        let (res2, ref2, flow_ok) = match evaluated.take() {
            Some(e) => e,
            None => evaluate(v, qs, &mut flow, p, &joint0, &mut rhs),
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
        let ref2 = ref2.max(*first2.get_or_insert(res2));
        let settled = prev.as_deref() == Some(&states[..]);
        if !res2.is_finite() {
            return Err(fail(step, time, "the residual is not finite".into()));
        }
        let tol2 = qs.tol * qs.tol * ref2.max(f64::MIN_POSITIVE);
        if res2 <= tol2 && flow_ok && (settled || !on.contact) {
            break (res2, ref2);
        }
        if iterations >= MAX_ITER {
            return Err(fail(step, time, not_converged(v, qs, &flow, res2, ref2)));
        }
        qs.factor(v, p, &states).map_err(|e| fail(step, time, e))?;
        if let Some(f) = flow.as_ref() {
            let id = qs.counts.numeric_factorisations;
            if qs.rows.needs_w(id) {
                let s = qs.structure.as_ref().expect("structure");
                let m = qs
                    .rows
                    .load_g(f, v, &s.dof, s.n)
                    .map_err(|e| fail(step, time, e))?;
                qs.solve_w(m).map_err(|e| fail(step, time, e))?;
                qs.rows.set_w_factor(id);
            }
        }
        qs.solve_in_place(&mut rhs);
        let dof = &qs.structure.as_ref().expect("structure").dof;
        if flow.is_none() {
            add_update(v, dof, &rhs, 1.0);
        } else {
            // Coupled: the reduced system for dy, then a line search on the merit
            // phi = |F|^2 / (tol^2 ref) + sum (r_c / allowed_c)^2 (Armijo, c = 1e-4): the full
            // step, else the first kink of the pressure law on the way, else halving. The
            // kinks (a cell filling or draining) would otherwise make Newton cycle.
            let f = flow.as_mut().expect("coupled");
            let s = qs.structure.as_ref().expect("structure");
            qs.rows
                .reduce_and_solve(f, v, &s.dof, s.n, &mut rhs)
                .map_err(|e| fail(step, time, e))?;
            let phi0 = res2 / tol2 + qs.rows.phi;
            qs.rows.save_base();
            u_base.clear();
            u_base.extend_from_slice(&v.u);
            let kink = qs.rows.first_kink();
            let candidates = std::iter::once((1.0, None))
                .chain(kink.map(|(a, c)| (a, Some(c))))
                .chain((1..=LINE_SEARCH_HALVINGS).map(|k| (0.5f64.powi(k), None)));
            rhs_try.resize(n, 0.0);
            for (alpha, at) in candidates {
                v.u.copy_from_slice(&u_base);
                let dof = &qs.structure.as_ref().expect("structure").dof;
                add_update(v, dof, &rhs, alpha);
                qs.rows.set_trial(alpha, at);
                let e = evaluate(v, qs, &mut flow, p, &joint0, &mut rhs_try);
                evaluated = Some(e);
                if e.0 / tol2 + qs.rows.phi <= (1.0 - 1e-4 * alpha) * phi0 {
                    break;
                }
            }
            // The iterate is the last trial: its residual is the next iteration's.
            std::mem::swap(&mut rhs, &mut rhs_try);
        }
        prev = Some(states.clone());
        iterations += 1;
    };
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
fn evaluate(
    v: &mut SolidView,
    qs: &mut QuasiStatic,
    flow: &mut Option<FlowStep>,
    p: &RunParams,
    joint0: &[crate::components::JointState],
    rhs: &mut [f64],
) -> (f64, f64, bool) {
    let on = qs.on;
    forces(v, p, on, joint0);
    let flow_ok = match flow.as_mut() {
        Some(f) => {
            let ok = qs.rows.evaluate(f, v);
            if on.fluid {
                let c = f.part.coupling.as_ref().expect("coupled flow");
                fluid_pressure(v, &c.joint_cell, &f.part.view.pressure);
            }
            ok
        }
        None => true,
    };
    let lf = p.solid.load_factor;
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

/// The message of a step that did not converge: the rock's residual, the worst cell's, and a
/// hint when joints slide.
fn not_converged(
    v: &SolidView,
    qs: &QuasiStatic,
    flow: &Option<FlowStep>,
    res2: f64,
    ref2: f64,
) -> String {
    let slip = v.joint_state.iter().filter(|s| s.sliding).count();
    let hint = if slip > 0 {
        format!(
            "; {slip} of {} joints slide: past the friction limit there may be no static \
             equilibrium (the explicit scheme follows the sliding)",
            v.joint_nodes.len()
        )
    } else {
        String::new()
    };
    let cell = match flow {
        Some(f) if qs.rows.worst > 1.0 => format!(
            "; {} has mass residual {:.3e} times its tolerance",
            f.part.view.cell_label(qs.rows.worst_cell),
            qs.rows.worst
        ),
        _ => String::new(),
    };
    format!(
        "no equilibrium after {MAX_ITER} Newton iterations: relative residual {:.3e} \
         (tolerance {:.1e}){cell}{hint}",
        (res2 / ref2.max(f64::MIN_POSITIVE)).sqrt(),
        qs.tol
    )
}
