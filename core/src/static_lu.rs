//! LU without pivoting on the fill of a symmetric pattern (`StaticLu`): the factor of an
//! unsymmetric matrix whose pattern is structurally symmetric (or is made so by explicit
//! zeros), with the pivots taken in the order of a fill-reducing symmetric ordering (AMD) and
//! never exchanged. L and U then have the structure of the pattern's Cholesky factor (L's
//! columns and U's rows), so the factor costs about twice a sparse Cholesky, where a sparse
//! LU with partial pivoting (faer's, COLAMD ordering) must allow for any row exchange and
//! fills the structure of A^T A: on the quasi-static Newton matrix of Example II (28,000
//! unknowns) its numeric factor took 116 ms against 19 ms for a Cholesky of the same pattern.
//!
//! When it is safe: the matrix is a stiffness (symmetric positive definite) with unsymmetric
//! terms that are not large against it (the joints' Coulomb term, the fluid coupling), so the
//! diagonal pivots stay away from zero. A pivot below [`PIVOT_TOL`] times the largest
//! diagonal entry is refused (`Err`); the caller falls back to a pivoting LU and should check
//! the residual of what it solves.
//!
//! Layout: faer's supernodal symbolic Cholesky of the pattern (AMD, supernodal forced) gives
//! the supernodes (consecutive columns of the permuted matrix with the same structure below
//! their diagonal block) and the rows below each. Per supernode of width w with b rows below,
//! a column-major panel of (w + b) x w holds the diagonal block (L's strict lower part, unit
//! diagonal implied, and U's upper part with the pivots) and L below it; a second panel of
//! b x w holds U's rows to the right of the block, transposed. The numeric factor is
//! left-looking: each supernode gathers the updates of the earlier supernodes whose rows reach
//! it (two dense products per pair), then factors its diagonal block and solves its panels.

use crate::sparse::SparsePattern;
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_unit_lower_triangular_in_place,
    solve_upper_triangular_in_place,
};
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::{Accum, MatMut, MatRef, Par, Side};

/// Smallest pivot accepted, relative to the largest diagonal entry of the matrix.
pub const PIVOT_TOL: f64 = 1e-13;

/// Diagonal blocks up to this size are factored by the unblocked loop.
const UNBLOCKED: usize = 32;

/// The symbolic structure and the numeric factor (see the module doc).
pub struct StaticLu {
    n: usize,
    /// perm[k]: the unknown eliminated k-th.
    perm: Vec<usize>,
    /// Supernode s holds permuted columns begin[s]..begin[s + 1].
    begin: Vec<usize>,
    /// Rows below supernode s: rows[row_ptr[s]..row_ptr[s + 1]] (permuted, ascending).
    row_ptr: Vec<usize>,
    rows: Vec<usize>,
    /// Start of supernode s's L panel and U panel in `val`.
    l_ptr: Vec<usize>,
    u_ptr: Vec<usize>,
    val: Vec<f64>,
    /// Per entry of the original pattern, its slot in `val`.
    slot: Vec<usize>,
    /// Supernodes whose rows reach supernode s: desc[desc_ptr[s]..desc_ptr[s + 1]], each with
    /// the index (into its own rows) of its first row at or after begin[s].
    desc_ptr: Vec<usize>,
    desc: Vec<(usize, usize)>,
    /// The most rows below one supernode (the solve's scratch beside the permuted vector).
    max_below: usize,
    /// Local row of each permuted row in the supernode being assembled (scratch).
    pos: Vec<usize>,
    tmp: Vec<f64>,
    /// Whether `val` holds a factor.
    factored: bool,
    /// Smallest pivot accepted, relative to the largest diagonal entry ([`PIVOT_TOL`] unless
    /// set; 1 refuses every pivot, which tests use to take the caller's fallback).
    pub pivot_tol: f64,
}

impl std::fmt::Debug for StaticLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "StaticLu(n = {}, supernodes = {}, values = {})",
            self.n,
            self.begin.len() - 1,
            self.val.len()
        )
    }
}

impl StaticLu {
    /// The symbolic factor of `pattern` (square; its transpose's entries are added as
    /// explicit zeros where missing).
    pub fn new(pattern: &SparsePattern) -> Result<Self, String> {
        let n = pattern.col_ptr().len() - 1;
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        let mut entries = Vec::with_capacity(2 * ri.len());
        for c in 0..n {
            for &r in &ri[cp[c]..cp[c + 1]] {
                entries.push((r, c));
                entries.push((c, r));
            }
        }
        let sym = SparsePattern::from_entries(n, entries)?;
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let symbolic =
            factorize_symbolic_cholesky(sym.as_ref(), Side::Lower, SymmetricOrdering::Amd, params)
                .map_err(|e| format!("symbolic analysis: {e:?}"))?;
        let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
            return Err("symbolic analysis: not supernodal".into());
        };
        let (perm, inv) = match symbolic.perm() {
            Some(p) => {
                let (f, i) = p.arrays();
                (f.to_vec(), i.to_vec())
            }
            None => ((0..n).collect(), (0..n).collect()),
        };
        let ns = sn.n_supernodes();
        let mut begin: Vec<usize> = sn.supernode_begin().to_vec();
        begin.push(n);
        let row_ptr: Vec<usize> = sn.col_ptr_for_row_idx().to_vec();
        let rows: Vec<usize> = sn.row_idx().to_vec();
        let mut sn_of = vec![0usize; n];
        let (mut l_ptr, mut u_ptr) = (Vec::with_capacity(ns + 1), Vec::with_capacity(ns + 1));
        let mut len = 0;
        for s in 0..ns {
            sn_of[begin[s]..begin[s + 1]].fill(s);
            let (w, b) = (begin[s + 1] - begin[s], row_ptr[s + 1] - row_ptr[s]);
            l_ptr.push(len);
            len += (w + b) * w;
            u_ptr.push(len);
            len += b * w;
        }
        l_ptr.push(len);
        u_ptr.push(len);
        // Where each entry of the original pattern goes.
        let local_row = |s: usize, r: usize| -> Result<usize, String> {
            let w = begin[s + 1] - begin[s];
            if r < begin[s + 1] {
                return Ok(r - begin[s]);
            }
            rows[row_ptr[s]..row_ptr[s + 1]]
                .binary_search(&r)
                .map(|i| w + i)
                .map_err(|_| "symbolic analysis: an entry outside the fill".to_string())
        };
        let mut slot = Vec::with_capacity(ri.len());
        for c in 0..n {
            for &r in &ri[cp[c]..cp[c + 1]] {
                let (pr, pc) = (inv[r], inv[c]);
                let s = sn_of[pr.min(pc)];
                let w = begin[s + 1] - begin[s];
                let ld = w + row_ptr[s + 1] - row_ptr[s];
                let k = if pr.max(pc) < begin[s + 1] {
                    l_ptr[s] + (pc - begin[s]) * ld + (pr - begin[s])
                } else if pr > pc {
                    l_ptr[s] + (pc - begin[s]) * ld + local_row(s, pr)?
                } else {
                    let b = ld - w;
                    u_ptr[s] + (pr - begin[s]) * b + (local_row(s, pc)? - w)
                };
                slot.push(k);
            }
        }
        // Descendants: d reaches s where one of d's rows falls in s's columns.
        let mut pairs: Vec<(usize, usize, usize)> = Vec::new();
        for d in 0..ns {
            let r = &rows[row_ptr[d]..row_ptr[d + 1]];
            let mut i = 0;
            while i < r.len() {
                let s = sn_of[r[i]];
                pairs.push((s, d, i));
                while i < r.len() && r[i] < begin[s + 1] {
                    i += 1;
                }
            }
        }
        pairs.sort_unstable();
        let mut desc_ptr = vec![0usize; ns + 1];
        for &(s, _, _) in &pairs {
            desc_ptr[s + 1] += 1;
        }
        for s in 0..ns {
            desc_ptr[s + 1] += desc_ptr[s];
        }
        let desc = pairs.into_iter().map(|(_, d, i)| (d, i)).collect();
        let max_below = row_ptr.windows(2).map(|w| w[1] - w[0]).max().unwrap_or(0);
        Ok(StaticLu {
            n,
            perm,
            begin,
            row_ptr,
            rows,
            l_ptr,
            u_ptr,
            val: vec![0.0; len],
            slot,
            desc_ptr,
            desc,
            max_below,
            pos: vec![0; n],
            tmp: Vec::new(),
            factored: false,
            pivot_tol: PIVOT_TOL,
        })
    }

    /// Whether the last [`StaticLu::factor`] succeeded.
    pub fn is_factored(&self) -> bool {
        self.factored
    }

    /// Factor the matrix with the pattern given to [`StaticLu::new`] and these values (one per
    /// entry, in the pattern's order). `Err` names the pivot that fell below `pivot_tol` times
    /// the largest diagonal entry (or was not finite).
    pub fn factor(&mut self, values: &[f64]) -> Result<(), String> {
        self.factored = false;
        assert_eq!(values.len(), self.slot.len(), "values of another pattern");
        self.val.fill(0.0);
        for (&k, &a) in self.slot.iter().zip(values) {
            self.val[k] += a;
        }
        let mut dmax = 0.0f64;
        for s in 0..self.begin.len() - 1 {
            let (w, ld) = self.dims(s);
            for j in 0..w {
                dmax = dmax.max(self.val[self.l_ptr[s] + j * ld + j].abs());
            }
        }
        let tiny = self.pivot_tol * dmax;
        for s in 0..self.begin.len() - 1 {
            self.gather_updates(s);
            self.factor_supernode(s, tiny)?;
        }
        self.factored = true;
        Ok(())
    }

    /// Width and L panel's leading dimension (width + rows below) of supernode s.
    fn dims(&self, s: usize) -> (usize, usize) {
        let w = self.begin[s + 1] - self.begin[s];
        (w, w + self.row_ptr[s + 1] - self.row_ptr[s])
    }

    /// Subtract from supernode s's panels the products of the earlier supernodes that reach it.
    fn gather_updates(&mut self, s: usize) {
        let (bs, es) = (self.begin[s], self.begin[s + 1]);
        let (ws, lds) = self.dims(s);
        for (j, r) in (bs..es).enumerate() {
            self.pos[r] = j;
        }
        for (i, &r) in self.rows[self.row_ptr[s]..self.row_ptr[s + 1]]
            .iter()
            .enumerate()
        {
            self.pos[r] = ws + i;
        }
        for k in self.desc_ptr[s]..self.desc_ptr[s + 1] {
            let (d, i0) = self.desc[k];
            let (wd, ldd) = self.dims(d);
            let bd = ldd - wd;
            let drows = &self.rows[self.row_ptr[d]..self.row_ptr[d + 1]];
            let i1 = i0 + drows[i0..].partition_point(|&r| r < es);
            let (nr, nh) = (bd - i0, i1 - i0);
            let (head, tail) = self.val.split_at_mut(self.l_ptr[s]);
            let ld_panel = MatRef::from_column_major_slice_with_stride(
                &head[self.l_ptr[d]..self.u_ptr[d]],
                ldd,
                wd,
                ldd,
            );
            let ud_panel = MatRef::from_column_major_slice_with_stride(
                &head[self.u_ptr[d]..self.l_ptr[d + 1]],
                bd,
                wd,
                bd.max(1),
            );
            self.tmp.clear();
            self.tmp.resize(nr * nh, 0.0);
            // L rows: L_d[R, :] U_d[:, hit], U_d[:, hit] = (U^T_d[hit, :])^T.
            let mut t = MatMut::from_column_major_slice_mut(&mut self.tmp, nr, nh);
            matmul(
                t.rb_mut(),
                Accum::Replace,
                ld_panel.subrows(wd + i0, nr),
                ud_panel.subrows(i0, nh).transpose(),
                1.0,
                Par::Seq,
            );
            let (ls, us) = tail.split_at_mut(self.u_ptr[s] - self.l_ptr[s]);
            for jj in 0..nh {
                let col = drows[i0 + jj] - bs;
                let dst = &mut ls[col * lds..(col + 1) * lds];
                let src = &self.tmp[jj * nr..(jj + 1) * nr];
                for (ii, &x) in src.iter().enumerate() {
                    dst[self.pos[drows[i0 + ii]]] -= x;
                }
            }
            // U rows right of s's block: U^T_d[R below, :] (L_d[hit, :])^T.
            let nb = nr - nh;
            if nb == 0 {
                continue;
            }
            let bsz = lds - ws;
            self.tmp.clear();
            self.tmp.resize(nb * nh, 0.0);
            let mut t = MatMut::from_column_major_slice_mut(&mut self.tmp, nb, nh);
            matmul(
                t.rb_mut(),
                Accum::Replace,
                ud_panel.subrows(i1, nb),
                ld_panel.subrows(wd + i0, nh).transpose(),
                1.0,
                Par::Seq,
            );
            for jj in 0..nh {
                let col = drows[i0 + jj] - bs;
                let dst = &mut us[col * bsz..(col + 1) * bsz];
                let src = &self.tmp[jj * nb..(jj + 1) * nb];
                for (ii, &x) in src.iter().enumerate() {
                    dst[self.pos[drows[i1 + ii]] - ws] -= x;
                }
            }
        }
    }

    /// Factor supernode s's diagonal block and solve its two panels.
    fn factor_supernode(&mut self, s: usize, tiny: f64) -> Result<(), String> {
        let (w, ld) = self.dims(s);
        let b = ld - w;
        let (l, u) = self.val[self.l_ptr[s]..self.l_ptr[s + 1]].split_at_mut(ld * w);
        let mut lp = MatMut::from_column_major_slice_with_stride_mut(l, ld, w, ld);
        let (mut diag, mut below) = lp.rb_mut().split_at_row_mut(w);
        lu_no_pivot(diag.rb_mut(), tiny).map_err(|k| {
            let col = self.perm[self.begin[s] + k];
            format!("LU without pivoting: the pivot of unknown {col} is below the tolerance")
        })?;
        if b == 0 {
            return Ok(());
        }
        let diag = diag.rb();
        // L below: X U_ss = S  <=>  U_ss^T X^T = S^T.
        solve_lower_triangular_in_place(diag.transpose(), below.rb_mut().transpose_mut(), Par::Seq);
        // U right: L_ss U = S^T's transpose  <=>  L_ss (U^T)^T = panel^T.
        let mut up = MatMut::from_column_major_slice_with_stride_mut(u, b, w, b);
        solve_unit_lower_triangular_in_place(diag, up.rb_mut().transpose_mut(), Par::Seq);
        Ok(())
    }

    /// Solve A x = b in place with the factor (`x` holds b on entry); `work` is scratch
    /// (kept by the caller, so a solve allocates nothing once it has grown).
    pub fn solve_in_place(&self, x: &mut [f64], work: &mut Vec<f64>) {
        assert!(self.factored, "solve with a factor that failed");
        let n = self.n;
        work.clear();
        work.extend(self.perm.iter().map(|&i| x[i]));
        work.resize(n + self.max_below, 0.0);
        let (y, g) = work.split_at_mut(n);
        for s in 0..self.begin.len() - 1 {
            let (w, ld) = self.dims(s);
            let b = ld - w;
            let bs = self.begin[s];
            let lp = MatRef::from_column_major_slice_with_stride(
                &self.val[self.l_ptr[s]..self.u_ptr[s]],
                ld,
                w,
                ld,
            );
            let (diag, below) = lp.split_at_row(w);
            let mut xs = MatMut::from_column_major_slice_mut(&mut y[bs..bs + w], w, 1);
            solve_unit_lower_triangular_in_place(diag, xs.rb_mut(), Par::Seq);
            if b > 0 {
                let gm = MatMut::from_column_major_slice_mut(&mut g[..b], b, 1);
                matmul(gm, Accum::Replace, below, xs.rb(), 1.0, Par::Seq);
                for (&r, &v) in self.rows[self.row_ptr[s]..self.row_ptr[s + 1]]
                    .iter()
                    .zip(&g[..b])
                {
                    y[r] -= v;
                }
            }
        }
        for s in (0..self.begin.len() - 1).rev() {
            let (w, ld) = self.dims(s);
            let b = ld - w;
            let bs = self.begin[s];
            if b > 0 {
                for (gi, &r) in g
                    .iter_mut()
                    .zip(&self.rows[self.row_ptr[s]..self.row_ptr[s + 1]])
                {
                    *gi = y[r];
                }
                let up = MatRef::from_column_major_slice_with_stride(
                    &self.val[self.u_ptr[s]..self.l_ptr[s + 1]],
                    b,
                    w,
                    b,
                );
                let xs = MatMut::from_column_major_slice_mut(&mut y[bs..bs + w], w, 1);
                matmul(
                    xs,
                    Accum::Add,
                    up.transpose(),
                    MatRef::from_column_major_slice(&g[..b], b, 1),
                    -1.0,
                    Par::Seq,
                );
            }
            let lp = MatRef::from_column_major_slice_with_stride(
                &self.val[self.l_ptr[s]..self.u_ptr[s]],
                ld,
                w,
                ld,
            );
            let xs = MatMut::from_column_major_slice_mut(&mut y[bs..bs + w], w, 1);
            solve_upper_triangular_in_place(lp.split_at_row(w).0, xs, Par::Seq);
        }
        for k in 0..n {
            x[self.perm[k]] = y[k];
        }
    }
}

/// Dense LU without pivoting in place (L strictly below the diagonal, unit diagonal implied;
/// U on and above it). `Err(k)`: pivot k is below `tiny` in magnitude or not finite.
fn lu_no_pivot(mut a: MatMut<'_, f64>, tiny: f64) -> Result<(), usize> {
    let n = a.nrows();
    if n <= UNBLOCKED {
        for k in 0..n {
            let p = a[(k, k)];
            if !p.is_finite() || p.abs() <= tiny {
                return Err(k);
            }
            let r = 1.0 / p;
            for i in k + 1..n {
                a[(i, k)] *= r;
            }
            for j in k + 1..n {
                let ukj = a[(k, j)];
                if ukj != 0.0 {
                    for i in k + 1..n {
                        let lik = a[(i, k)];
                        a[(i, j)] -= lik * ukj;
                    }
                }
            }
        }
        return Ok(());
    }
    let h = n / 2;
    let (mut a11, mut a12, mut a21, mut a22) = a.rb_mut().split_at_mut(h, h);
    lu_no_pivot(a11.rb_mut(), tiny)?;
    let a11 = a11.rb();
    solve_unit_lower_triangular_in_place(a11, a12.rb_mut(), Par::Seq);
    solve_lower_triangular_in_place(a11.transpose(), a21.rb_mut().transpose_mut(), Par::Seq);
    matmul(a22.rb_mut(), Accum::Add, a21.rb(), a12.rb(), -1.0, Par::Seq);
    lu_no_pivot(a22, tiny).map_err(|k| k + h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A 2D grid Laplacian (5-point, n x n nodes, 2 unknowns per node coupled) made
    /// unsymmetric by a random perturbation of its off-diagonal entries, and a few entries
    /// only on one side (the pattern is not symmetric).
    fn grid(m: usize, seed: u64) -> (SparsePattern, Vec<f64>, usize) {
        let n = 2 * m * m;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let id = |i: usize, j: usize, d: usize| 2 * (i * m + j) + d;
        let mut entries = Vec::new();
        for i in 0..m {
            for j in 0..m {
                for d in 0..2 {
                    for e in 0..2 {
                        entries.push((id(i, j, d), id(i, j, e)));
                        if i + 1 < m {
                            entries.push((id(i + 1, j, d), id(i, j, e)));
                            entries.push((id(i, j, d), id(i + 1, j, e)));
                        }
                        if j + 1 < m {
                            entries.push((id(i, j + 1, d), id(i, j, e)));
                            entries.push((id(i, j, d), id(i, j + 1, e)));
                        }
                    }
                }
                // A one-sided entry (row far from the column).
                if (i + j) % 7 == 0 && i + 2 < m {
                    entries.push((id(i + 2, j, 0), id(i, j, 1)));
                }
            }
        }
        let pat = SparsePattern::from_entries(n, entries).unwrap();
        let (cp, ri) = (pat.col_ptr(), pat.row_idx());
        let mut vals = vec![0.0; pat.nnz()];
        for c in 0..n {
            for k in cp[c]..cp[c + 1] {
                vals[k] = if ri[k] == c {
                    9.0 + rng.random_range(0.0..1.0)
                } else {
                    -1.0 + 0.6 * (rng.random_range(0.0..1.0) - 0.5)
                };
            }
        }
        (pat, vals, n)
    }

    fn residual(pat: &SparsePattern, vals: &[f64], x: &[f64], b: &[f64]) -> f64 {
        let (cp, ri) = (pat.col_ptr(), pat.row_idx());
        let mut r = b.to_vec();
        for c in 0..x.len() {
            for k in cp[c]..cp[c + 1] {
                r[ri[k]] -= vals[k] * x[c];
            }
        }
        let nr: f64 = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        let nb: f64 = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        nr / nb
    }

    /// Against the definition: A x = b to round-off on unsymmetric matrices of several sizes
    /// (supernodes from 1 to tens of columns; the blocked diagonal LU at the larger ones).
    #[test]
    fn solves_unsymmetric_grid_matrices_to_round_off() {
        for (m, seed) in [(3, 1), (10, 2), (40, 3), (90, 4)] {
            let (pat, vals, n) = grid(m, seed);
            let mut lu = StaticLu::new(&pat).unwrap();
            lu.factor(&vals).unwrap();
            let b: Vec<f64> = (0..n).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
            let mut x = b.clone();
            let mut work = Vec::new();
            lu.solve_in_place(&mut x, &mut work);
            let rel = residual(&pat, &vals, &x, &b);
            // Round-off: the matrix is diagonally dominant (condition number ~ 10), so a
            // backward-stable solve leaves about 1e-15; 1e-12 allows for the accumulation.
            assert!(rel < 1e-12, "m = {m}: relative residual {rel:e}");
            // Refactoring new values in the same structure works the same.
            let vals2: Vec<f64> = vals.iter().map(|v| 1.5 * v).collect();
            lu.factor(&vals2).unwrap();
            let mut x2 = b.clone();
            lu.solve_in_place(&mut x2, &mut work);
            for (a, c) in x.iter().zip(&x2) {
                assert!((a - 1.5 * c).abs() <= 1e-12 * a.abs().max(1.0));
            }
        }
    }

    /// A zero pivot is refused with an error naming the unknown, not a non-finite factor.
    #[test]
    fn a_zero_pivot_is_refused() {
        let (pat, mut vals, _) = grid(5, 7);
        let (cp, ri) = (pat.col_ptr(), pat.row_idx());
        // Unknown 0 decoupled and zero on its diagonal.
        for k in cp[0]..cp[1] {
            vals[k] = 0.0;
        }
        for c in 0..pat.col_ptr().len() - 1 {
            for k in cp[c]..cp[c + 1] {
                if ri[k] == 0 {
                    vals[k] = 0.0;
                }
            }
        }
        let mut lu = StaticLu::new(&pat).unwrap();
        let e = lu.factor(&vals).unwrap_err();
        assert!(e.contains("unknown 0"), "{e}");
        assert!(!lu.is_factored());
    }
}
