//! The quasi-static step of a rock with or without joints, for any element kind ([`Element`]:
//! the 2D CST or the 3D TET4): equilibrium K u = f of linear elasticity at the end of the step,
//! with the prescribed displacements and loads times the step's load factor. The stiffness of
//! the free dofs is assembled once per topology on a fixed pattern (which also holds every
//! joint's couplings), its symbolic analysis (nested dissection of the nodes in 3D,
//! [`hydrofrac_core::sparse::nested_dissection`]; AMD in 2D) and numeric Cholesky
//! factorisation (faer, parallel supernodal on the run's threads) are kept while the topology
//! stands, so a step without joints in contact is a
//! residual and two triangular solves, refined until the residual is at round-off.
//!
//! Joints (contact with Coulomb friction) enter by an active set: their forces are in every
//! residual ([`LinearStatic::solve_with`]'s `extra`), and each joint's stiffness as its state
//! gives it ([`JointTangent`]: per sister node pair, apart nothing, sticking normal and shear, sliding normal and the
//! shear across the slip) is in the factorised matrix. The matrix is factorised again, on the
//! kept analysis, only when a joint changes state; a step whose joints keep theirs costs no
//! factorisation.
//!
//! This is the `solve` system of the 3D rock (`engine/src/sim3.rs`). The 2D rock's `solve` is
//! [`crate::quasi_static`], the semi-smooth Newton with joint contact and coupled flow; the
//! element stiffness both assemble is [`Element::stiffness`].

use crate::solid::{StepStats, external_load, internal_force, strain_energy};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{LltRef, SymbolicCholesky};
use faer::{Conj, MatMut, Par, Side};
use hydrofrac_core::dim::Element;
use hydrofrac_core::element::SolidParams;
use hydrofrac_core::sparse::SparsePattern;
use hydrofrac_core::view::SolidView;

/// No dof (a prescribed component).
const NONE: usize = usize::MAX;

/// Refinement passes at most: the first solve is exact up to round-off for linear elasticity;
/// a second one takes the residual of the first to the factorisation's round-off.
const MAX_PASSES: usize = 3;

/// Passes at most with joints: each change of a joint's state costs one.
pub const MAX_CONTACT_PASSES: usize = 40;

/// A joint's stiffness in the quasi-static matrix: for each sister node pair a (face p's
/// node a and face q's node a) the 3 x 3 block `corner[a]` (N/m; 2 x 2 in 2D, the rest zero;
/// zero for a pair apart) between its two nodes, and `code` telling states apart (two bits a
/// pair, from bit 2a: 0 apart, 1 sticking, 2 sliding; 0 for an open joint).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointTangent {
    pub corner: [[[f64; 3]; 3]; 3],
    pub code: u8,
}

impl JointTangent {
    /// An open joint: no stiffness.
    pub const OPEN: JointTangent = JointTangent {
        corner: [[[0.0; 3]; 3]; 3],
        code: 0,
    };
}

/// The factorised stiffness of one topology.
pub struct LinearStatic {
    /// `dof[D * node + d]`: the free dof of component d, or `NONE`.
    dof: Vec<usize>,
    n: usize,
    symbolic: SymbolicCholesky<usize>,
    l_values: Vec<f64>,
    /// The pattern and the elastic stiffness on it (lower triangle), kept to factorise again
    /// with the joints' blocks.
    pattern: SparsePattern,
    elastic: Vec<f64>,
    /// The joints' states in the present factorisation ([`JointTangent::code`]).
    joint_codes: Vec<u8>,
    mem: MemBuffer,
    /// The residual and update on the free dofs (kept: no allocation per step).
    rhs: Vec<f64>,
    /// Numeric factorisations done (one per topology; `summary.json` `quasi_static`).
    pub factorisations: u64,
    /// Solves (passes) done (`summary.json` `quasi_static`).
    pub solves: u64,
    /// Relative residual a step refines to (`time.newton_tol`; default
    /// [`crate::quasi_static::DEFAULT_TOL`]).
    pub tol: f64,
}

impl LinearStatic {
    /// Number the free dofs of `v`, assemble the lower triangle of their stiffness, analyse
    /// and factorise it. Errors: a stiffness that is not positive definite (a body free to
    /// move: too few prescribed components to hold it).
    pub fn build<E: Element>(v: &SolidView<E>, p: &SolidParams) -> Result<Self, String> {
        let dn = E::D;
        let mut dof = vec![NONE; dn * v.n_nodes()];
        let mut n = 0;
        for i in 0..v.n_nodes() {
            for d in 0..dn {
                if v.fixed[i] & (1 << d) == 0 {
                    dof[dn * i + d] = n;
                    n += 1;
                }
            }
        }
        // The dofs of a list of nodes, node by node (`NONE` where prescribed).
        let dof_ref = &dof;
        let dofs_of = |nodes: &[u32]| -> Vec<usize> {
            nodes
                .iter()
                .flat_map(|&a| (0..dn).map(move |d| dof_ref[dn * a as usize + d]))
                .collect()
        };
        // Every element couples all its nodes; a joint couples the two nodes of each sister
        // pair (its blocks are zero while they are apart; `factorise`).
        let pairs: Vec<[u32; 2]> = v
            .joint_nodes
            .iter()
            .flat_map(|j| {
                let (j, m) = (j.as_ref(), j.as_ref().len() / 2);
                (0..m).map(move |s| [j[s], j[m + s]])
            })
            .collect();
        let mut entries = Vec::new();
        let items = v.conn.iter().map(|c| c.as_ref());
        for nodes in items.chain(pairs.iter().map(|p| &p[..])) {
            let d = dofs_of(nodes);
            for &a in &d {
                for &b in &d {
                    if a != NONE && b != NONE && a >= b {
                        entries.push((a, b));
                    }
                }
            }
        }
        let pattern = SparsePattern::from_entries(n, entries)?;
        let mut values = vec![0.0; pattern.nnz()];
        for (c, g) in v.conn.iter().zip(&v.geom) {
            let d = dofs_of(c.as_ref());
            let ke = E::stiffness(g, p);
            for (i, &a) in d.iter().enumerate() {
                for (j, &b) in d.iter().enumerate() {
                    if a != NONE && b != NONE && a >= b {
                        values[pattern.slot(a, b).expect("in pattern")] += ke[(i, j)];
                    }
                }
            }
        }
        // 3D: nested dissection of the nodes (less fill than AMD), the free dofs node by node.
        let order: Option<Vec<usize>> = (dn == 3).then(|| {
            let mut adjacency = vec![Vec::new(); v.n_nodes()];
            for c in &v.conn {
                for &a in c.as_ref() {
                    for &b in c.as_ref() {
                        if a != b {
                            adjacency[a as usize].push(b);
                        }
                    }
                }
            }
            for a in &mut adjacency {
                a.sort_unstable();
                a.dedup();
            }
            let pts: Vec<[f64; 3]> =
                v.x0.iter()
                    .map(|x| {
                        let x = x.as_ref();
                        [x[0], x[1], x[2]]
                    })
                    .collect();
            let nodes = hydrofrac_core::sparse::nested_dissection(&pts, &adjacency);
            dofs_of(&nodes).into_iter().filter(|&k| k != NONE).collect()
        });
        let (symbolic, mem) = pattern.symbolic_cholesky_ordered(order.as_deref())?;
        let mut l = LinearStatic {
            l_values: vec![0.0; symbolic.len_val()],
            elastic: values,
            pattern,
            joint_codes: vec![0; v.joint_nodes.len()],
            rhs: vec![0.0; n],
            dof,
            n,
            symbolic,
            mem,
            factorisations: 0,
            solves: 0,
            tol: crate::quasi_static::DEFAULT_TOL,
        };
        let open = vec![JointTangent::OPEN; v.joint_nodes.len()];
        l.factorise(v, &open).map_err(|e| {
            format!(
                "the stiffness is not positive definite ({e}): the body can move without \
                 straining (hold enough displacement components to stop every rigid motion)"
            )
        })?;
        Ok(l)
    }

    /// Equilibrium at load factor `lf`: the prescribed components at `lf` times their values,
    /// the free ones solved from K du = f_int(u) + lf f_ext, refined until the relative
    /// residual is below [`LinearStatic::tol`]; velocities zero. Returns the step's statistics
    /// (residual, reactions and loads, strain energy).
    pub fn solve<E: Element>(
        &mut self,
        v: &mut SolidView<E>,
        p: &SolidParams,
        lf: f64,
    ) -> StepStats {
        self.solve_with(v, p, lf, |_| {}, |_, _| JointTangent::OPEN)
            .expect("no joint blocks, no refactorisation")
    }

    /// [`LinearStatic::solve`] with joints: `extra` adds their forces to the unbalanced force
    /// at each residual (from the step's start state, so it can be called again), and
    /// `tangent(v, k)` gives joint k's stiffness in the state that residual left it in. The
    /// matrix is factorised again when a joint's [`JointTangent::code`] changes. Passes: at
    /// most [`MAX_PASSES`] without joints, [`MAX_CONTACT_PASSES`] with. Errors: a matrix that
    /// is not positive definite.
    pub fn solve_with<E: Element>(
        &mut self,
        v: &mut SolidView<E>,
        p: &SolidParams,
        lf: f64,
        mut extra: impl FnMut(&mut SolidView<E>),
        tangent: impl Fn(&SolidView<E>, usize) -> JointTangent,
    ) -> Result<StepStats, String> {
        let tol = self.tol;
        let dn = E::D;
        for i in 0..v.n_nodes() {
            for d in 0..dn {
                if v.fixed[i] & (1 << d) != 0 {
                    v.u[i][d] = lf * v.presc[i][d];
                }
                v.v[i][d] = 0.0;
            }
        }
        let mut rhs = std::mem::take(&mut self.rhs);
        let mut stats = self.residual(v, p, lf, &mut rhs, &mut extra);
        let passes = if v.joint_nodes.is_empty() {
            MAX_PASSES
        } else {
            MAX_CONTACT_PASSES
        };
        for _ in 0..passes {
            if stats.residual() <= tol || self.n == 0 {
                break;
            }
            let tangents: Vec<JointTangent> =
                (0..v.joint_nodes.len()).map(|k| tangent(v, k)).collect();
            if tangents
                .iter()
                .zip(&self.joint_codes)
                .any(|(t, &c)| t.code != c)
            {
                self.factorise(v, &tangents).map_err(|e| {
                    format!(
                        "the stiffness with the joints in contact is not positive definite ({e})"
                    )
                })?;
            }
            let llt = LltRef::<usize, f64>::new(&self.symbolic, &self.l_values);
            llt.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut rhs, self.n, 1),
                Par::Seq,
                MemStack::new(&mut self.mem),
            );
            self.solves += 1;
            for i in 0..v.n_nodes() {
                for d in 0..dn {
                    let k = self.dof[dn * i + d];
                    if k != NONE {
                        v.u[i][d] += rhs[k];
                    }
                }
            }
            stats = self.residual(v, p, lf, &mut rhs, &mut extra);
        }
        self.rhs = rhs;
        Ok(stats)
    }

    /// Factorise K + the joints' blocks on the kept analysis (parallel supernodal, on the
    /// run's threads; the same bits on any number). Joint k couples the two nodes of each
    /// sister pair by its D x D [`JointTangent`] block (N/m).
    fn factorise<E: Element>(
        &mut self,
        v: &SolidView<E>,
        tangents: &[JointTangent],
    ) -> Result<(), String> {
        let dn = E::D;
        let mut values = self.elastic.clone();
        for (k, t) in tangents.iter().enumerate() {
            if t.code == 0 {
                continue;
            }
            let corner = &t.corner;
            let nodes = v.joint_nodes[k];
            let nodes = nodes.as_ref();
            let m = nodes.len() / 2;
            let mut add = |a: u32, b: u32, w: f64, c: &[[f64; 3]; 3]| {
                for da in 0..dn {
                    for db in 0..dn {
                        let (ra, rb) = (
                            self.dof[dn * a as usize + da],
                            self.dof[dn * b as usize + db],
                        );
                        if ra != NONE && rb != NONE && ra >= rb {
                            let slot = self.pattern.slot(ra, rb).expect("joint in pattern");
                            values[slot] += w * c[da][db];
                        }
                    }
                }
            };
            // Each sister pair: +C on the diagonal blocks, -C between them.
            for (s, c) in corner.iter().enumerate().take(m) {
                let (a, b) = (nodes[s], nodes[m + s]);
                add(a, a, 1.0, c);
                add(b, b, 1.0, c);
                add(a, b, -1.0, c);
                add(b, a, -1.0, c);
            }
        }
        self.symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                SparseColMatRef::new(self.pattern.as_ref(), &values),
                Side::Lower,
                LltRegularization::default(),
                Par::rayon(0),
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| format!("{e:?}"))?;
        self.factorisations += 1;
        self.joint_codes = tangents.iter().map(|t| t.code).collect();
        Ok(())
    }

    /// The unbalanced force at the current displacements into `rhs` (free dofs) and the step
    /// statistics of that state.
    fn residual<E: Element>(
        &self,
        v: &mut SolidView<E>,
        p: &SolidParams,
        lf: f64,
        rhs: &mut [f64],
        extra: &mut impl FnMut(&mut SolidView<E>),
    ) -> StepStats {
        internal_force(v, p);
        external_load(v, lf);
        extra(v);
        let dn = E::D;
        let mut st = StepStats::default();
        for i in 0..v.n_nodes() {
            for d in 0..dn {
                let f = v.force[i][d];
                let l = lf * v.load[i][d];
                st.ref2 += l * l;
                match self.dof[dn * i + d] {
                    NONE => st.ref2 += f * f,
                    k => {
                        st.res2 += f * f;
                        rhs[k] = f;
                    }
                }
            }
        }
        st.strain = strain_energy(v, p);
        st.non_finite =
            v.u.iter()
                .position(|u| !u.as_ref().iter().all(|x| x.is_finite()));
        st
    }
}
