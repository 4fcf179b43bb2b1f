//! Sparsity pattern shared by the sparse solvers (flow: `flow::steady`, `flow::implicit`;
//! solid: `systems::quasi_static`): faer builds the compressed-column pattern from the (row, col) entries a matrix will have
//! ([`SymbolicSparseColMat::try_new_from_indices`]: rows sorted within each column, repeats
//! merged), and each solver looks up, once per pattern, the value slot every contribution of its
//! assembly goes to. The solvers then assemble in place, in their own (fixed) order, so the
//! values are summed in the same order at every assembly and no allocation is needed per step.

use faer::Par;
use faer::dyn_stack::{MemBuffer, StackReq};
use faer::sparse::linalg::cholesky::{
    SymbolicCholesky, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::linalg::lu::{SymbolicLu, factorize_symbolic_lu};
use faer::sparse::{Pair, SymbolicSparseColMat, SymbolicSparseColMatRef};

/// An `n x n` compressed-column pattern.
#[derive(Debug, Clone)]
pub struct SparsePattern {
    symbolic: SymbolicSparseColMat<usize>,
}

impl SparsePattern {
    /// The pattern with an entry at each `(row, col)` of `entries` (repeats allowed; every index
    /// must be below `n`).
    pub fn from_entries(
        n: usize,
        entries: impl IntoIterator<Item = (usize, usize)>,
    ) -> Result<Self, String> {
        let idx: Vec<Pair<usize, usize>> = entries
            .into_iter()
            .map(|(row, col)| Pair { row, col })
            .collect();
        let (symbolic, _order) = SymbolicSparseColMat::try_new_from_indices(n, n, &idx)
            .map_err(|e| format!("sparsity pattern: {e:?}"))?;
        Ok(SparsePattern { symbolic })
    }

    pub fn as_ref(&self) -> SymbolicSparseColMatRef<'_, usize> {
        self.symbolic.as_ref()
    }

    /// Column `c`'s entries are `row_idx()[col_ptr()[c]..col_ptr()[c + 1]]`, rows ascending.
    pub fn col_ptr(&self) -> &[usize] {
        self.symbolic.col_ptr()
    }

    pub fn row_idx(&self) -> &[usize] {
        self.symbolic.row_idx()
    }

    /// Number of stored entries (value slots).
    pub fn nnz(&self) -> usize {
        self.row_idx().len()
    }

    /// The pattern's symbolic LU (faer's default ordering, COLAMD) and a workspace for one
    /// sequential numeric factorisation and one-column solves: the set-up of every sparse LU
    /// solver (the implicit flow, the heat models, the quasi-static full tangent).
    pub fn symbolic_lu(&self) -> Result<(SymbolicLu<usize>, MemBuffer), String> {
        let symbolic = factorize_symbolic_lu(self.as_ref(), Default::default())
            .map_err(|e| format!("symbolic LU: {e:?}"))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let mem = MemBuffer::try_new(req).map_err(|_| "out of memory for the LU workspace")?;
        Ok((symbolic, mem))
    }

    /// The symbolic Cholesky factorisation of the pattern's lower triangle (AMD ordering) and a
    /// workspace for one sequential numeric factorisation and one-column solves: the set-up of
    /// both solid solvers (`systems::quasi_static`, `systems::linear_static`).
    pub fn symbolic_cholesky(&self) -> Result<(SymbolicCholesky<usize>, MemBuffer), String> {
        let symbolic = factorize_symbolic_cholesky(
            self.as_ref(),
            faer::Side::Lower,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| format!("symbolic analysis: {e:?}"))?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::rayon(0), Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        let mem = MemBuffer::try_new(req).map_err(|_| "out of memory for the workspace")?;
        Ok((symbolic, mem))
    }

    /// Value slot of entry (row, col); `None` if it is not in the pattern.
    pub fn slot(&self, row: usize, col: usize) -> Option<usize> {
        let (a, b) = (self.col_ptr()[col], self.col_ptr()[col + 1]);
        self.row_idx()[a..b].binary_search(&row).ok().map(|k| a + k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pattern_is_sorted_and_merged() {
        let p = SparsePattern::from_entries(3, [(2, 0), (0, 0), (2, 0), (1, 1), (0, 2), (2, 2)])
            .unwrap();
        assert_eq!(p.col_ptr(), [0, 2, 3, 5]);
        assert_eq!(p.row_idx(), [0, 2, 1, 0, 2]);
        assert_eq!(p.nnz(), 5);
        assert_eq!(p.slot(2, 0), Some(1));
        assert_eq!(p.slot(2, 2), Some(4));
        assert_eq!(p.slot(1, 0), None);
        let empty = SparsePattern::from_entries(0, []).unwrap();
        assert_eq!((empty.col_ptr(), empty.nnz()), (&[0usize][..], 0));
        assert!(SparsePattern::from_entries(2, [(2, 0)]).is_err());
    }
}
