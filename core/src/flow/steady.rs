//! Steady incompressible flow in a fracture network by a sparse direct solve.
//!
//! The network is a set of finite-volume cells (fracture segments). Cells exchange
//! fluid in pairs with volumetric flow `q_ij = kappa_ij (P_j - P_i)` (cubic-law
//! transmissibility per unit thickness, m^2/(Pa s)). Boundary conditions are
//! "Dirichlet" connections of a cell to a reservoir at fixed pressure `P_b` through a
//! transmissibility `kappa_b` (flow into the cell `kappa_b (P_b - P_i)`) and volumetric
//! sources (m^2/s into a cell). The steady balance of cell `i`,
//!
//! ```text
//! sum_j kappa_ij (P_j - P_i) + sum_b kappa_b (P_b - P_i) + s_i = 0,
//! ```
//!
//! is a symmetric positive (semi-)definite graph-Laplacian system. It is solved with
//! faer's sparse supernodal/simplicial Cholesky (`L L^T`) factorisation with an AMD
//! fill-reducing ordering, run sequentially (`Par::Seq`) so that the result is
//! bit-for-bit reproducible whatever the rayon configuration.
//!
//! Connected components (over `pairs`) without any Dirichlet connection are removed
//! from the factorised system: with zero net source they get pressure 0, with a
//! non-zero net source the problem has no steady solution and
//! [`SteadyError::UngroundedSource`] is returned.
//!
//! Numerical details:
//! * Each grounded component is solved for `u = P - c`, where `c` is the midpoint of
//!   the reservoir pressures connected to that component. This is exact (the Laplacian
//!   annihilates constants) and avoids cancellation when pressure differences are
//!   small compared with the absolute pressure level.
//! * One step of iterative refinement is applied after the direct solve.
//! * [`SteadySolution::residual`] is `||A u - b|| / ||b||` for that (shifted) system,
//!   with `||.||` the Euclidean norm (or `||A u - b||` itself when `b = 0`).

use crate::sparse::SparsePattern;
use crate::union_find::UnionFind;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{Conj, MatMut, Par, Side};

/// Marker for "no reduced index" / "no matrix slot".
const NONE_U32: u32 = u32::MAX;
const NONE_USIZE: usize = usize::MAX;

/// A steady-flow problem on a cell network.
#[derive(Debug, Clone, Copy)]
pub struct SteadyProblem<'a> {
    pub n_cells: usize,
    /// (i, j, kappa_ij): each unordered pair once, i != j, kappa > 0. Duplicates must be summed, not rejected.
    pub pairs: &'a [(u32, u32, f64)],
    /// (cell, kappa_b, reservoir pressure P_b in Pa).
    pub dirichlet: &'a [(u32, f64, f64)],
    /// (cell, volumetric rate into the cell, m^2/s).
    pub sources: &'a [(u32, f64)],
}

/// Result of a steady solve.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadySolution {
    /// Cell pressures, Pa.
    pub pressure: Vec<f64>,
    /// Flow from each reservoir into its cell, kappa_b (P_b - P_i), same order as `dirichlet`.
    pub dirichlet_flow: Vec<f64>,
    /// Relative residual ||A p - b|| / ||b|| of the solved system (for reporting).
    pub residual: f64,
}

/// Which input list an erroneous entry belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputList {
    Pairs,
    Dirichlet,
    Sources,
}

impl std::fmt::Display for InputList {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            InputList::Pairs => "pairs",
            InputList::Dirichlet => "dirichlet",
            InputList::Sources => "sources",
        })
    }
}

/// Errors of [`SteadySolver::solve`] / [`solve_steady`].
#[derive(Debug, thiserror::Error)]
pub enum SteadyError {
    #[error("{list} entry {entry}: cell index {cell} out of range (n_cells = {n_cells})")]
    IndexOutOfRange {
        list: InputList,
        entry: usize,
        cell: u32,
        n_cells: usize,
    },
    #[error("pairs entry {entry}: cell {cell} is paired with itself")]
    SelfPair { entry: usize, cell: u32 },
    #[error("{list} entry {entry}: transmissibility {kappa} is not finite and positive")]
    InvalidKappa {
        list: InputList,
        entry: usize,
        kappa: f64,
    },
    #[error("{list} entry {entry}: {quantity} {value} is not finite")]
    NonFiniteValue {
        list: InputList,
        entry: usize,
        quantity: &'static str,
        value: f64,
    },
    #[error(
        "connected component containing cell {cell} ({component_cells} cells) has net source {net_source:e} m^2/s but no Dirichlet connection"
    )]
    UngroundedSource {
        /// Smallest cell index of the offending component.
        cell: u32,
        component_cells: usize,
        net_source: f64,
    },
    #[error("n_cells = {n_cells} exceeds the u32 cell-index range")]
    TooManyCells { n_cells: usize },
    #[error("sparse Cholesky factorisation failed: {detail}")]
    Factorisation { detail: String },
}

/// Everything that depends only on the sparsity pattern.
struct Structure {
    n_cells: usize,
    pair_pattern: Vec<(u32, u32)>,
    dirichlet_cells: Vec<u32>,
    /// Component root (smallest cell index of the component) of each cell.
    root: Vec<u32>,
    /// Per root cell: the component has at least one Dirichlet connection.
    grounded: Vec<bool>,
    /// Reduced (matrix) index of each cell, `NONE_U32` for ungrounded cells.
    reduced: Vec<u32>,
    /// Cell of each reduced index.
    cell_of: Vec<u32>,
    /// Lower-triangular CSC pattern of the reduced matrix (diagonal first in each column).
    pattern: SparsePattern,
    /// Value slot of the off-diagonal entry of each pair (`NONE_USIZE` if ungrounded).
    pair_slot: Vec<usize>,
    symbolic: Option<SymbolicCholesky<usize>>,
    /// Workspace for numeric factorisation and solves.
    mem: Option<MemBuffer>,
}

impl Structure {
    fn matches(&self, p: &SteadyProblem) -> bool {
        self.n_cells == p.n_cells
            && self.pair_pattern.len() == p.pairs.len()
            && self.dirichlet_cells.len() == p.dirichlet.len()
            && self
                .pair_pattern
                .iter()
                .zip(p.pairs)
                .all(|(&(a, b), &(i, j, _))| a == i && b == j)
            && self
                .dirichlet_cells
                .iter()
                .zip(p.dirichlet)
                .all(|(&a, &(c, _, _))| a == c)
    }

    fn n_reduced(&self) -> usize {
        self.cell_of.len()
    }

    /// Builds components, the reduced numbering and the matrix pattern (no factorisation).
    fn build(p: &SteadyProblem) -> Result<Self, SteadyError> {
        let n = p.n_cells;
        // The root of a component is always its smallest cell index.
        let mut sets = UnionFind::new(n);
        for &(i, j, _) in p.pairs {
            sets.union(i as usize, j as usize);
        }
        let root: Vec<u32> = (0..n).map(|c| sets.find(c) as u32).collect();
        drop(sets);
        let mut grounded = vec![false; n];
        for &(c, _, _) in p.dirichlet {
            grounded[root[c as usize] as usize] = true;
        }
        let mut reduced = vec![NONE_U32; n];
        let mut cell_of = Vec::new();
        for c in 0..n {
            if grounded[root[c] as usize] {
                reduced[c] = cell_of.len() as u32;
                cell_of.push(c as u32);
            }
        }
        let m = cell_of.len();

        // Lower triangle: the diagonal and, per grounded pair, (row = max, col = min). The
        // diagonal is the smallest row of its column, so it comes first.
        let reduced_pair = |&(i, j, _): &(u32, u32, f64)| {
            let (ri, rj) = (reduced[i as usize], reduced[j as usize]);
            (ri != NONE_U32).then(|| (ri.max(rj) as usize, ri.min(rj) as usize))
        };
        let pattern = SparsePattern::from_entries(
            m,
            (0..m)
                .map(|c| (c, c))
                .chain(p.pairs.iter().filter_map(reduced_pair)),
        )
        .map_err(|detail| SteadyError::Factorisation { detail })?;
        debug_assert!((0..m).all(|c| pattern.slot(c, c) == Some(pattern.col_ptr()[c])));
        let pair_slot = p
            .pairs
            .iter()
            .map(|pr| {
                reduced_pair(pr).map_or(NONE_USIZE, |(row, col)| {
                    pattern
                        .slot(row, col)
                        .expect("pair entry is in the pattern")
                })
            })
            .collect();

        Ok(Structure {
            n_cells: n,
            pair_pattern: p.pairs.iter().map(|&(i, j, _)| (i, j)).collect(),
            dirichlet_cells: p.dirichlet.iter().map(|&(c, _, _)| c).collect(),
            root,
            grounded,
            reduced,
            cell_of,
            pattern,
            pair_slot,
            symbolic: None,
            mem: None,
        })
    }

    /// Symbolic Cholesky analysis (AMD ordering) and workspace allocation.
    fn analyse(&mut self) -> Result<(), SteadyError> {
        let symbolic = factorize_symbolic_cholesky(
            self.pattern.as_ref(),
            Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| SteadyError::Factorisation {
            detail: format!("symbolic analysis: {e:?}"),
        })?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let mem = MemBuffer::try_new(req).map_err(|_| SteadyError::Factorisation {
            detail: "out of memory allocating the workspace".into(),
        })?;
        self.symbolic = Some(symbolic);
        self.mem = Some(mem);
        Ok(())
    }
}

/// Reusable solver: keeps the symbolic factorisation and reuses it while the sparsity pattern
/// (n_cells, pairs' (i,j) sequence, dirichlet cells) is unchanged; values may change freely.
pub struct SteadySolver {
    structure: Option<Structure>,
    symbolic_count: usize,
    values: Vec<f64>,
    l_values: Vec<f64>,
}

impl Default for SteadySolver {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for SteadySolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SteadySolver")
            .field("symbolic_count", &self.symbolic_count)
            .field(
                "n_reduced",
                &self.structure.as_ref().map(Structure::n_reduced),
            )
            .finish_non_exhaustive()
    }
}

fn validate(p: &SteadyProblem) -> Result<(), SteadyError> {
    let n = p.n_cells;
    if n > u32::MAX as usize {
        return Err(SteadyError::TooManyCells { n_cells: n });
    }
    let check_cell = |list, entry, cell: u32| {
        if (cell as usize) < n {
            Ok(())
        } else {
            Err(SteadyError::IndexOutOfRange {
                list,
                entry,
                cell,
                n_cells: n,
            })
        }
    };
    let check_kappa = |list, entry, kappa: f64| {
        if kappa.is_finite() && kappa > 0.0 {
            Ok(())
        } else {
            Err(SteadyError::InvalidKappa { list, entry, kappa })
        }
    };
    for (entry, &(i, j, kappa)) in p.pairs.iter().enumerate() {
        check_cell(InputList::Pairs, entry, i)?;
        check_cell(InputList::Pairs, entry, j)?;
        if i == j {
            return Err(SteadyError::SelfPair { entry, cell: i });
        }
        check_kappa(InputList::Pairs, entry, kappa)?;
    }
    for (entry, &(c, kappa, pb)) in p.dirichlet.iter().enumerate() {
        check_cell(InputList::Dirichlet, entry, c)?;
        check_kappa(InputList::Dirichlet, entry, kappa)?;
        if !pb.is_finite() {
            return Err(SteadyError::NonFiniteValue {
                list: InputList::Dirichlet,
                entry,
                quantity: "reservoir pressure",
                value: pb,
            });
        }
    }
    for (entry, &(c, rate)) in p.sources.iter().enumerate() {
        check_cell(InputList::Sources, entry, c)?;
        if !rate.is_finite() {
            return Err(SteadyError::NonFiniteValue {
                list: InputList::Sources,
                entry,
                quantity: "source rate",
                value: rate,
            });
        }
    }
    Ok(())
}

/// y = A x for the symmetric matrix stored as its lower triangle (diagonal first in
/// each column) in `pattern` and `values`.
fn sym_matvec(pattern: &SparsePattern, values: &[f64], x: &[f64], y: &mut [f64]) {
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    y.fill(0.0);
    for col in 0..col_ptr.len() - 1 {
        let (start, end) = (col_ptr[col], col_ptr[col + 1]);
        let xc = x[col];
        let mut acc = values[start] * xc;
        for s in start + 1..end {
            let row = row_idx[s];
            acc += values[s] * x[row];
            y[row] += values[s] * xc;
        }
        y[col] += acc;
    }
}

fn norm2(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl SteadySolver {
    pub fn new() -> Self {
        SteadySolver {
            structure: None,
            symbolic_count: 0,
            values: Vec::new(),
            l_values: Vec::new(),
        }
    }

    /// How many symbolic factorisations were done so far (tests check reuse).
    pub fn symbolic_count(&self) -> usize {
        self.symbolic_count
    }

    pub fn solve(&mut self, p: &SteadyProblem) -> Result<SteadySolution, SteadyError> {
        validate(p)?;

        let reuse = self.structure.as_ref().is_some_and(|s| s.matches(p));
        if !reuse {
            self.structure = None;
            let mut s = Structure::build(p)?;
            if s.n_reduced() > 0 {
                s.analyse()?;
                self.symbolic_count += 1;
            }
            self.structure = Some(s);
        }
        let s = self.structure.as_mut().expect("structure was just built");
        let n = p.n_cells;
        let m = s.n_reduced();

        // Ungrounded components: the net source must vanish.
        check_ungrounded_sources(s, p)?;

        // Per-component reference pressure: midpoint of its reservoir pressures.
        let mut p_lo = vec![f64::INFINITY; n];
        let mut p_hi = vec![f64::NEG_INFINITY; n];
        for &(c, _, pb) in p.dirichlet {
            let r = s.root[c as usize] as usize;
            p_lo[r] = p_lo[r].min(pb);
            p_hi[r] = p_hi[r].max(pb);
        }
        let shift = |c: usize| {
            let r = s.root[c] as usize;
            0.5 * p_lo[r] + 0.5 * p_hi[r]
        };

        // Numeric assembly (lower triangle, deterministic summation order) and rhs.
        let nnz = s.pattern.nnz();
        self.values.clear();
        self.values.resize(nnz, 0.0);
        let values = &mut self.values;
        // Diagonal slots: first in each column.
        let col_ptr = s.pattern.col_ptr();
        let mut rhs = vec![0.0; m];
        for (k, &(i, j, kappa)) in p.pairs.iter().enumerate() {
            let slot = s.pair_slot[k];
            if slot != NONE_USIZE {
                let ri = s.reduced[i as usize] as usize;
                let rj = s.reduced[j as usize] as usize;
                values[col_ptr[ri]] += kappa;
                values[col_ptr[rj]] += kappa;
                values[slot] -= kappa;
            }
        }
        for &(c, kappa, pb) in p.dirichlet {
            let r = s.reduced[c as usize] as usize;
            values[col_ptr[r]] += kappa;
            rhs[r] += kappa * (pb - shift(c as usize));
        }
        for &(c, rate) in p.sources {
            let r = s.reduced[c as usize];
            if r != NONE_U32 {
                rhs[r as usize] += rate;
            }
        }

        let mut u = rhs.clone();
        let mut residual = 0.0;
        if m > 0 {
            let symbolic = s.symbolic.as_ref().expect("analysed");
            let mem = s.mem.as_mut().expect("analysed");
            self.l_values.clear();
            self.l_values.resize(symbolic.len_val(), 0.0);
            let a = SparseColMatRef::new(s.pattern.as_ref(), values);
            symbolic
                .factorize_numeric_llt::<f64>(
                    &mut self.l_values,
                    a,
                    Side::Lower,
                    LltRegularization::default(),
                    Par::Seq,
                    MemStack::new(mem),
                    Default::default(),
                )
                .map_err(|e| SteadyError::Factorisation {
                    detail: format!("{e:?}"),
                })?;
            let llt = LltRef::<usize, f64>::new(symbolic, &self.l_values);
            let mut solve = |x: &mut [f64]| {
                let len = x.len();
                llt.solve_in_place_with_conj(
                    Conj::No,
                    MatMut::from_column_major_slice_mut(x, len, 1),
                    Par::Seq,
                    MemStack::new(mem),
                );
            };
            solve(&mut u);

            // One step of iterative refinement.
            let mut r = vec![0.0; m];
            sym_matvec(&s.pattern, values, &u, &mut r);
            for (ri, bi) in r.iter_mut().zip(&rhs) {
                *ri = bi - *ri;
            }
            solve(&mut r);
            for (ui, di) in u.iter_mut().zip(&r) {
                *ui += di;
            }

            sym_matvec(&s.pattern, values, &u, &mut r);
            for (ri, bi) in r.iter_mut().zip(&rhs) {
                *ri -= bi;
            }
            let b_norm = norm2(&rhs);
            let r_norm = norm2(&r);
            if !(r_norm.is_finite() && u.iter().all(|x| x.is_finite())) {
                return Err(SteadyError::Factorisation {
                    detail: "non-finite solution (transmissibilities out of floating-point range?)"
                        .into(),
                });
            }
            residual = if b_norm > 0.0 {
                r_norm / b_norm
            } else {
                r_norm
            };
        }

        let mut pressure = vec![0.0; n];
        for (r, &c) in s.cell_of.iter().enumerate() {
            pressure[c as usize] = u[r] + shift(c as usize);
        }
        let dirichlet_flow = p
            .dirichlet
            .iter()
            .map(|&(c, kappa, pb)| {
                let r = s.reduced[c as usize] as usize;
                kappa * ((pb - shift(c as usize)) - u[r])
            })
            .collect();
        Ok(SteadySolution {
            pressure,
            dirichlet_flow,
            residual,
        })
    }
}

/// Errors if an ungrounded component has a non-zero net source
/// (|sum| > 1e-12 max|source| within the component). Reports the component with the
/// smallest cell index.
fn check_ungrounded_sources(s: &Structure, p: &SteadyProblem) -> Result<(), SteadyError> {
    if p.sources
        .iter()
        .all(|&(c, _)| s.grounded[s.root[c as usize] as usize])
    {
        return Ok(());
    }
    let n = p.n_cells;
    let mut net = vec![0.0; n];
    let mut max_abs = vec![0.0f64; n];
    for &(c, rate) in p.sources {
        let r = s.root[c as usize] as usize;
        if !s.grounded[r] {
            net[r] += rate;
            max_abs[r] = max_abs[r].max(rate.abs());
        }
    }
    // Roots are the smallest cells of their components, so scanning roots in order
    // reports the component with the smallest cell index.
    for r in 0..n {
        if s.root[r] as usize == r && !s.grounded[r] && net[r].abs() > 1e-12 * max_abs[r] {
            let component_cells = s.root.iter().filter(|&&x| x as usize == r).count();
            return Err(SteadyError::UngroundedSource {
                cell: r as u32,
                component_cells,
                net_source: net[r],
            });
        }
    }
    Ok(())
}

/// One-shot convenience: a fresh [`SteadySolver`] and one solve.
pub fn solve_steady(p: &SteadyProblem) -> Result<SteadySolution, SteadyError> {
    SteadySolver::new().solve(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const MU: f64 = 1e-3; // Pa s

    /// Cubic-law transmissibility of a cell-to-cell connection over length `l`.
    fn kappa_cubic(a: f64, l: f64) -> f64 {
        a * a * a / (12.0 * MU * l)
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// Owned problem data.
    #[derive(Clone, Default)]
    struct Net {
        n: usize,
        pairs: Vec<(u32, u32, f64)>,
        dirichlet: Vec<(u32, f64, f64)>,
        sources: Vec<(u32, f64)>,
    }

    impl Net {
        fn problem(&self) -> SteadyProblem<'_> {
            SteadyProblem {
                n_cells: self.n,
                pairs: &self.pairs,
                dirichlet: &self.dirichlet,
                sources: &self.sources,
            }
        }
    }

    /// `|sum dirichlet_flow + sum sources| / (sum |dirichlet_flow| + sum |sources|)`.
    fn mass_imbalance(net: &Net, sol: &SteadySolution) -> f64 {
        let total: f64 =
            sol.dirichlet_flow.iter().sum::<f64>() + net.sources.iter().map(|s| s.1).sum::<f64>();
        let scale: f64 = sol.dirichlet_flow.iter().map(|q| q.abs()).sum::<f64>()
            + net.sources.iter().map(|s| s.1.abs()).sum::<f64>();
        total.abs() / scale
    }

    /// Random-aperture 2D lattice `nx * ny`, reservoirs on the left (P_in) and right (P_out)
    /// columns, a fraction `drop` of the bonds removed (creates isolated clusters).
    fn lattice(nx: usize, ny: usize, seed: u64, drop: f64) -> Net {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = nx * ny;
        let lc = 1.0;
        // log-uniform aperture over one decade around 1e-4 m
        let k: Vec<f64> = (0..n)
            .map(|_| kappa_cubic(1e-4 * 10f64.powf(rng.random::<f64>() - 0.5), lc))
            .collect();
        let id = |x: usize, y: usize| (y * nx + x) as u32;
        let mut net = Net {
            n,
            ..Default::default()
        };
        for y in 0..ny {
            for x in 0..nx {
                let c = id(x, y);
                let mut bond = |d: u32| {
                    if rng.random::<f64>() >= drop {
                        let (ki, kj) = (k[c as usize], k[d as usize]);
                        net.pairs.push((c, d, 2.0 * ki * kj / (ki + kj)));
                    }
                };
                if x + 1 < nx {
                    bond(id(x + 1, y));
                }
                if y + 1 < ny {
                    bond(id(x, y + 1));
                }
            }
        }
        for y in 0..ny {
            let (l, r) = (id(0, y), id(nx - 1, y));
            net.dirichlet.push((l, 2.0 * k[l as usize], 2.0e7));
            net.dirichlet.push((r, 2.0 * k[r as usize], 1.0e7));
        }
        net
    }

    /// Single fracture of `n` equal cells between two reservoirs.
    fn chain(n: usize, a: f64, len: f64, p_in: f64, p_out: f64) -> Net {
        let lc = len / n as f64;
        let k = kappa_cubic(a, lc);
        Net {
            n,
            pairs: (0..n as u32 - 1).map(|i| (i, i + 1, k)).collect(),
            dirichlet: vec![(0, 2.0 * k, p_in), (n as u32 - 1, 2.0 * k, p_out)],
            sources: vec![],
        }
    }

    /// Test 1: single fracture; flow = a^3 dP / (12 mu L) and linear pressure, to 1e-12 rel.
    #[test]
    fn single_fracture_chain() {
        for &(n, a, len, p_in, p_out) in &[
            (1usize, 1e-4, 3.0, 2.0e7, 1.0e7),
            (2, 1e-4, 3.0, 2.0e7, 1.0e7),
            (50, 2e-4, 10.0, 3.0e7, 2.9e7),
            (400, 5e-5, 100.0, 1.0e5, 0.0),
        ] {
            let net = chain(n, a, len, p_in, p_out);
            let sol = solve_steady(&net.problem()).unwrap();
            let q = a * a * a * (p_in - p_out) / (12.0 * MU * len);
            assert!(
                rel(sol.dirichlet_flow[0], q) <= 1e-12,
                "n={n}: {:?} vs {q}",
                sol.dirichlet_flow
            );
            assert!(rel(-sol.dirichlet_flow[1], q) <= 1e-12, "n={n}");
            for (i, &p) in sol.pressure.iter().enumerate() {
                let exact = p_in - (p_in - p_out) * (i as f64 + 0.5) / n as f64;
                assert!(
                    (p - exact).abs() <= 1e-12 * (p_in - p_out),
                    "n={n} cell {i}: {p} vs {exact}"
                );
            }
            assert!(sol.residual < 1e-14, "residual {}", sol.residual);
        }
    }

    /// Star of branches meeting in junction cell 0; branch k is a chain of `cells` cells
    /// of aperture `a` and cell length `lc` ending in a reservoir at `p_res`.
    /// Returns the network and the series resistance of each branch.
    fn star(branches: &[(usize, f64, f64, f64)], junction_source: f64) -> (Net, Vec<f64>) {
        let mut net = Net {
            n: 1,
            sources: vec![(0, junction_source)],
            ..Default::default()
        };
        let mut resistance = Vec::new();
        for &(cells, a, lc, p_res) in branches {
            let k = kappa_cubic(a, lc);
            let first = net.n as u32;
            net.pairs.push((0, first, k));
            for c in 1..cells as u32 {
                net.pairs.push((first + c - 1, first + c, k));
            }
            net.n += cells;
            net.dirichlet.push((net.n as u32 - 1, 2.0 * k, p_res));
            resistance.push(cells as f64 / k + 0.5 / k);
        }
        (net, resistance)
    }

    /// Test 2: T (3-branch) and X (4-branch) junctions; closed-form split, 1e-12 rel.
    #[test]
    fn t_and_x_junctions() {
        let t = [
            (10, 1e-4, 0.5, 2.0e7),
            (25, 2e-4, 0.2, 1.0e7),
            (7, 5e-5, 1.0, 1.2e7),
        ];
        let x = [
            (10, 1e-4, 0.5, 2.0e7),
            (25, 2e-4, 0.2, 1.0e7),
            (7, 5e-5, 1.0, 1.2e7),
            (13, 3e-4, 0.3, 1.5e7),
        ];
        for (branches, s0) in [
            (&t[..], 0.0),
            (&t[..], 1e-6),
            (&x[..], 0.0),
            (&x[..], -2e-6),
        ] {
            let (net, res) = star(branches, s0);
            let sol = solve_steady(&net.problem()).unwrap();
            // Junction pressure: sum_k (P_k - P_c)/R_k + s = 0.
            let g: f64 = res.iter().map(|r| 1.0 / r).sum();
            let pc = (s0 + branches.iter().zip(&res).map(|(b, r)| b.3 / r).sum::<f64>()) / g;
            assert!(rel(sol.pressure[0], pc) <= 1e-12);
            for (k, (b, r)) in branches.iter().zip(&res).enumerate() {
                let q = (b.3 - pc) / r;
                assert!(
                    rel(sol.dirichlet_flow[k], q) <= 1e-12,
                    "branch {k}: {} vs {q}",
                    sol.dirichlet_flow[k]
                );
            }
            assert!(mass_imbalance(&net, &sol) <= 1e-12);
        }
    }

    /// Test 3: isolated clusters.
    #[test]
    fn isolated_clusters() {
        let base = chain(6, 1e-4, 3.0, 2.0e7, 1.0e7);
        let reference = solve_steady(&base.problem()).unwrap();
        let mut net = base.clone();
        // cluster {6, 7, 8} (a triangle) and the lone cell 9, no reservoir.
        net.n = 10;
        net.pairs.insert(2, (7, 6, 1e-9));
        net.pairs.push((8, 7, 2e-9));
        net.pairs.push((6, 8, 3e-9));
        // zero net source on the cluster: allowed
        net.sources = vec![(7, 1e-6), (8, -1e-6)];
        let sol = solve_steady(&net.problem()).unwrap();
        assert_eq!(&sol.pressure[6..], &[0.0; 4]);
        for i in 0..6 {
            assert!(rel(sol.pressure[i], reference.pressure[i]) <= 1e-14);
        }
        for (q, q0) in sol.dirichlet_flow.iter().zip(&reference.dirichlet_flow) {
            assert!(rel(*q, *q0) <= 1e-12);
        }
        assert!(sol.residual < 1e-14);

        // non-zero net source: error naming the smallest cell of the cluster
        net.sources = vec![(7, 1e-6), (8, -0.5e-6)];
        let err = solve_steady(&net.problem()).unwrap_err();
        match err {
            SteadyError::UngroundedSource {
                cell,
                component_cells,
                net_source,
            } => {
                assert_eq!(cell, 6);
                assert_eq!(component_cells, 3);
                assert!(rel(net_source, 0.5e-6) <= 1e-12);
            }
            e => panic!("wrong error {e:?}"),
        }
        let msg = solve_steady(&net.problem()).unwrap_err().to_string();
        assert!(msg.contains("cell 6"), "{msg}");
        // a source on the lone cell 9 is an error too
        net.sources = vec![(9, 1e-6)];
        assert!(matches!(
            solve_steady(&net.problem()),
            Err(SteadyError::UngroundedSource { cell: 9, .. })
        ));

        // no reservoir at all, no source: everything zero, nothing factorised
        let mut solver = SteadySolver::new();
        let free = Net {
            n: 3,
            pairs: vec![(0, 1, 1.0), (1, 2, 1.0)],
            ..Default::default()
        };
        let sol = solver.solve(&free.problem()).unwrap();
        assert_eq!(sol.pressure, vec![0.0; 3]);
        assert_eq!(solver.symbolic_count(), 0);
    }

    /// Test 4: global mass balance, 1e-12 relative.
    #[test]
    fn mass_balance() {
        let mut net = lattice(60, 40, 7, 0.15);
        net.sources = vec![(1234, 3e-9), (77, -1e-9), (2000, 5e-10), (1234, 1e-9)];
        let sol = solve_steady(&net.problem()).unwrap();
        let imb = mass_imbalance(&net, &sol);
        assert!(imb <= 1e-12, "imbalance {imb}");
        let (net, _) = star(&[(10, 1e-4, 0.5, 2e7), (3, 2e-4, 0.1, 1e7)], 1e-7);
        let sol = solve_steady(&net.problem()).unwrap();
        assert!(mass_imbalance(&net, &sol) <= 1e-12);
    }

    /// Test 5: symbolic reuse; results bit-identical to a fresh solver's.
    #[test]
    fn symbolic_reuse() {
        let net_a = lattice(30, 20, 1, 0.1);
        let mut net_b = net_a.clone();
        let mut rng = ChaCha8Rng::seed_from_u64(99);
        for p in &mut net_b.pairs {
            p.2 *= 0.5 + rng.random::<f64>();
        }
        for d in &mut net_b.dirichlet {
            d.1 *= 2.0;
            d.2 += 1.0e6;
        }
        net_b.sources.push((100, 1e-9));

        let mut solver = SteadySolver::new();
        let sol_a = solver.solve(&net_a.problem()).unwrap();
        let sol_b = solver.solve(&net_b.problem()).unwrap();
        assert_eq!(solver.symbolic_count(), 1);
        assert_eq!(sol_a, solve_steady(&net_a.problem()).unwrap());
        assert_eq!(sol_b, solve_steady(&net_b.problem()).unwrap());
        assert_ne!(sol_a.pressure, sol_b.pressure);

        // changed pattern: one more pair
        let mut net_c = net_b.clone();
        net_c.pairs.push((0, 599, 1e-9));
        let sol_c = solver.solve(&net_c.problem()).unwrap();
        assert_eq!(solver.symbolic_count(), 2);
        assert_eq!(sol_c, solve_steady(&net_c.problem()).unwrap());
        // changed pattern: a Dirichlet connection moved
        let mut net_d = net_c.clone();
        net_d.dirichlet[3].0 = 300;
        let sol_d = solver.solve(&net_d.problem()).unwrap();
        assert_eq!(solver.symbolic_count(), 3);
        assert_eq!(sol_d, solve_steady(&net_d.problem()).unwrap());
        // back to the first problem: same bits as the very first solve
        assert_eq!(solver.solve(&net_a.problem()).unwrap(), sol_a);
        assert_eq!(solver.symbolic_count(), 4);
        // a failed solve (bad input) leaves the cached structure intact
        let mut bad = net_a.clone();
        bad.pairs[5].2 = -1.0;
        assert!(solver.solve(&bad.problem()).is_err());
        assert_eq!(solver.solve(&net_a.problem()).unwrap(), sol_a);
        assert_eq!(solver.symbolic_count(), 4);
    }

    /// Duplicated pairs (either orientation) are summed.
    #[test]
    fn duplicate_pairs_are_summed() {
        let single = chain(5, 1e-4, 2.0, 2e7, 1e7);
        let mut split = single.clone();
        split.pairs = Vec::new();
        for &(i, j, k) in &single.pairs {
            split.pairs.push((i, j, 0.25 * k));
            split.pairs.push((j, i, 0.75 * k));
        }
        let a = solve_steady(&single.problem()).unwrap();
        let b = solve_steady(&split.problem()).unwrap();
        for (x, y) in a.pressure.iter().zip(&b.pressure) {
            assert!(rel(*x, *y) <= 1e-14);
        }
        // two Dirichlet entries on the same cell are also summed
        let mut twice = single.clone();
        let (c, k, pb) = twice.dirichlet[0];
        twice.dirichlet[0].1 = 0.5 * k;
        twice.dirichlet.push((c, 0.5 * k, pb));
        let c_sol = solve_steady(&twice.problem()).unwrap();
        assert!(
            rel(
                c_sol.dirichlet_flow[0] + c_sol.dirichlet_flow[2],
                a.dirichlet_flow[0]
            ) <= 1e-12
        );
    }

    /// Test 6: bad inputs give the right error variants.
    #[test]
    fn bad_inputs() {
        let good = chain(4, 1e-4, 1.0, 2e7, 1e7);
        let solve = |f: &dyn Fn(&mut Net)| {
            let mut net = good.clone();
            f(&mut net);
            solve_steady(&net.problem()).unwrap_err()
        };
        let e = solve(&|n| n.pairs[2].1 = 4);
        assert!(
            matches!(
                e,
                SteadyError::IndexOutOfRange {
                    list: InputList::Pairs,
                    entry: 2,
                    cell: 4,
                    n_cells: 4
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("pairs entry 2"), "{e}");
        let e = solve(&|n| n.dirichlet[1].0 = 99);
        assert!(matches!(
            e,
            SteadyError::IndexOutOfRange {
                list: InputList::Dirichlet,
                entry: 1,
                cell: 99,
                ..
            }
        ));
        let e = solve(&|n| n.sources = vec![(0, 1.0), (u32::MAX, 1.0)]);
        assert!(matches!(
            e,
            SteadyError::IndexOutOfRange {
                list: InputList::Sources,
                entry: 1,
                ..
            }
        ));
        let e = solve(&|n| n.pairs[1].0 = n.pairs[1].1);
        assert!(matches!(e, SteadyError::SelfPair { entry: 1, cell: 2 }));
        for bad in [0.0, -1e-9, f64::NAN, f64::INFINITY] {
            let e = solve(&|n| n.pairs[0].2 = bad);
            assert!(
                matches!(
                    e,
                    SteadyError::InvalidKappa {
                        list: InputList::Pairs,
                        entry: 0,
                        ..
                    }
                ),
                "{e:?}"
            );
            let e = solve(&|n| n.dirichlet[1].1 = bad);
            assert!(matches!(
                e,
                SteadyError::InvalidKappa {
                    list: InputList::Dirichlet,
                    entry: 1,
                    ..
                }
            ));
        }
        let e = solve(&|n| n.dirichlet[0].2 = f64::NAN);
        assert!(matches!(
            e,
            SteadyError::NonFiniteValue {
                list: InputList::Dirichlet,
                entry: 0,
                ..
            }
        ));
        let e = solve(&|n| n.sources = vec![(1, f64::INFINITY)]);
        assert!(matches!(
            e,
            SteadyError::NonFiniteValue {
                list: InputList::Sources,
                entry: 0,
                ..
            }
        ));
        // finite but overflowing transmissibilities: a factorisation error, never NaNs
        let e = solve(&|n| {
            n.pairs[0].2 = f64::MAX;
            n.pairs.push((0, 1, f64::MAX));
        });
        assert!(matches!(e, SteadyError::Factorisation { .. }), "{e:?}");
        for e in [
            solve(&|n| n.pairs[0].2 = f64::NAN),
            solve(&|n| n.sources = vec![(1, f64::NAN)]),
        ] {
            let msg = e.to_string();
            assert!(!msg.contains('\n') && msg.contains("entry 0"), "{msg}");
        }
    }

    /// Same input, same bits: repeated solves and concurrent solves on several threads.
    #[test]
    fn deterministic_across_threads() {
        let net = lattice(80, 60, 5, 0.1);
        let reference = solve_steady(&net.problem()).unwrap();
        let results: Vec<SteadySolution> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..4)
                .map(|_| scope.spawn(|| solve_steady(&net.problem()).unwrap()))
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for r in results {
            assert_eq!(r, reference);
        }
    }

    /// Test 7: random 2D lattice of 1e5 cells: residual < 1e-10, mass balance 1e-12,
    /// per-cell balance, maximum principle.
    #[test]
    fn lattice_1e5_cells() {
        let net = lattice(400, 250, 2024, 0.1);
        assert_eq!(net.n, 100_000);
        let mut solver = SteadySolver::new();
        let sol = solver.solve(&net.problem()).unwrap();
        assert!(sol.residual < 1e-10, "residual {}", sol.residual);
        let imb = mass_imbalance(&net, &sol);
        assert!(imb <= 1e-12, "imbalance {imb}");
        // per-cell balance from the raw input, relative to the largest bond flow
        let mut net_q = vec![0.0; net.n];
        let mut touched = vec![false; net.n];
        let mut q_max = 0.0f64;
        for &(i, j, k) in &net.pairs {
            let q = k * (sol.pressure[j as usize] - sol.pressure[i as usize]);
            net_q[i as usize] += q;
            net_q[j as usize] -= q;
            q_max = q_max.max(q.abs());
            touched[i as usize] |= q != 0.0;
            touched[j as usize] |= q != 0.0;
        }
        for (&(c, _, _), &q) in net.dirichlet.iter().zip(&sol.dirichlet_flow) {
            net_q[c as usize] += q;
        }
        let worst = net_q.iter().fold(0.0f64, |w, q| w.max(q.abs())) / q_max;
        assert!(
            worst <= 1e-10,
            "worst cell imbalance {worst} of the largest bond flow"
        );
        let isolated = (0..net.n)
            .filter(|&c| !touched[c] && sol.pressure[c] == 0.0)
            .count();
        assert!(
            isolated > 0,
            "the test network should contain isolated cells"
        );
        // no sources: pressures within the reservoir range (isolated cells excepted)
        for c in 0..net.n {
            let p = sol.pressure[c];
            assert!(p == 0.0 || (1.0e7 * (1.0 - 1e-12)..=2.0e7 * (1.0 + 1e-12)).contains(&p));
        }
        eprintln!(
            "1e5 lattice: residual {:.2e}, imbalance {imb:.2e}, worst cell {worst:.2e}, isolated {isolated}",
            sol.residual
        );
    }
}
