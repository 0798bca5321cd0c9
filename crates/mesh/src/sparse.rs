//! Sparse symmetric systems: a fixed pattern with value slots (assemble by index, no triplet
//! sorting per Newton step) and a sparse Cholesky whose symbolic analysis (AMD ordering,
//! supernodes) is computed once and reused for every numeric factorization.
//!
//! Backed by `faer`'s supernodal LLᵀ.

use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{MatMut, Side};

/// Errors of the sparse solver.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SolveError {
    /// The matrix is not (numerically) positive definite.
    #[error("matrix is not positive definite (pivot {index} is not positive)")]
    NotPositiveDefinite {
        /// Index of the failing pivot (in the permuted order).
        index: usize,
    },
    /// The solver failed otherwise (out of memory, index overflow).
    #[error("sparse solver failure: {0}")]
    Internal(String),
}

/// The lower triangle (row ≥ column) of a symmetric n × n sparsity pattern, in compressed
/// columns with sorted rows; every diagonal entry is present.
#[derive(Clone, Debug)]
pub struct SymmetricPattern {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
}

impl SymmetricPattern {
    /// Pattern holding the diagonal and the given entries (either triangle; duplicates merge).
    pub fn from_entries(n: usize, entries: impl IntoIterator<Item = (usize, usize)>) -> Self {
        let mut keys: Vec<u64> = (0..n as u64).map(|i| (i << 32) | i).collect();
        for (i, j) in entries {
            assert!(i < n && j < n, "pattern entry ({i}, {j}) outside {n}×{n}");
            let (r, c) = if i >= j { (i, j) } else { (j, i) };
            keys.push(((c as u64) << 32) | r as u64);
        }
        keys.sort_unstable();
        keys.dedup();
        let mut col_ptr = vec![0usize; n + 1];
        let mut row_idx = Vec::with_capacity(keys.len());
        for k in keys {
            col_ptr[(k >> 32) as usize + 1] += 1;
            row_idx.push((k & 0xFFFF_FFFF) as usize);
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        Self { n, col_ptr, row_idx }
    }

    /// Dimension.
    pub fn n(&self) -> usize {
        self.n
    }
    /// Stored entries (lower triangle).
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }
    /// Slot of entry (i, j) (either triangle) in the value array, if stored.
    pub fn find(&self, i: usize, j: usize) -> Option<usize> {
        let (r, c) = if i >= j { (i, j) } else { (j, i) };
        let (a, b) = (self.col_ptr[c], self.col_ptr[c + 1]);
        self.row_idx[a..b].binary_search(&r).ok().map(|k| a + k)
    }
    /// Slot of entry (i, j).
    ///
    /// # Panics
    /// If the entry is not in the pattern (a programming error).
    #[track_caller]
    pub fn slot(&self, i: usize, j: usize) -> usize {
        self.find(i, j).unwrap_or_else(|| panic!("entry ({i}, {j}) is not in the pattern"))
    }
    /// Slots of the diagonal entries.
    pub fn diagonal_slots(&self) -> Vec<usize> {
        (0..self.n).map(|i| self.col_ptr[i]).collect()
    }
    fn symbolic(&self) -> SymbolicSparseColMatRef<'_, usize> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
    /// y = A x for the symmetric matrix with these values.
    pub fn mul_vec(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for c in 0..self.n {
            for k in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[k];
                y[r] += values[k] * x[c];
                if r != c {
                    y[c] += values[k] * x[r];
                }
            }
        }
    }
}

/// Sparse Cholesky with a reusable symbolic analysis.
#[derive(Clone, Debug)]
pub struct CholeskySolver {
    symbolic: SymbolicLlt<usize>,
}

impl CholeskySolver {
    /// Symbolic analysis of the pattern (done once).
    pub fn new(pattern: &SymmetricPattern) -> Result<Self, SolveError> {
        let symbolic = SymbolicLlt::try_new(pattern.symbolic(), Side::Lower)
            .map_err(|e| SolveError::Internal(format!("{e:?}")))?;
        Ok(Self { symbolic })
    }

    /// Numeric factorization of the matrix with the given values (same pattern).
    pub fn factor(&self, pattern: &SymmetricPattern, values: &[f64]) -> Result<CholeskyFactor, SolveError> {
        assert_eq!(values.len(), pattern.nnz(), "value count must match the pattern");
        let mat = SparseColMatRef::new(pattern.symbolic(), values);
        match Llt::try_new_with_symbolic(self.symbolic.clone(), mat, Side::Lower) {
            Ok(llt) => Ok(CholeskyFactor { llt, n: pattern.n() }),
            Err(faer::sparse::linalg::LltError::Numeric(
                faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index },
            )) => Err(SolveError::NotPositiveDefinite { index }),
            Err(e) => Err(SolveError::Internal(format!("{e:?}"))),
        }
    }
}

/// A numeric Cholesky factor.
#[derive(Clone, Debug)]
pub struct CholeskyFactor {
    llt: Llt<usize, f64>,
    n: usize,
}

impl CholeskyFactor {
    /// Solve A x = b in place (`rhs` holds b on entry, x on exit).
    pub fn solve_in_place(&self, rhs: &mut [f64]) {
        use faer::prelude::Solve;
        assert_eq!(rhs.len(), self.n);
        let m = MatMut::from_column_major_slice_mut(rhs, self.n, 1);
        self.llt.solve_in_place(m);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_path_laplacian() {
        // Tridiagonal SPD: 2 on the diagonal, −1 off it, plus 0.1·I.
        let n = 50;
        let p = SymmetricPattern::from_entries(n, (1..n).map(|i| (i, i - 1)));
        let mut v = vec![0.0; p.nnz()];
        for i in 0..n {
            v[p.slot(i, i)] = 2.1;
            if i > 0 {
                v[p.slot(i - 1, i)] = -1.0;
            }
        }
        let solver = CholeskySolver::new(&p).unwrap();
        let f = solver.factor(&p, &v).unwrap();
        let b: Vec<f64> = (0..n).map(|i| (i % 7) as f64 - 3.0).collect();
        let mut x = b.clone();
        f.solve_in_place(&mut x);
        let mut ax = vec![0.0; n];
        p.mul_vec(&v, &x, &mut ax);
        let err: f64 = ax.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 1e-12, "{err}");
        // Same pattern, indefinite values: refused.
        for i in 0..n {
            v[p.slot(i, i)] = -1.0;
        }
        assert!(matches!(solver.factor(&p, &v), Err(SolveError::NotPositiveDefinite { .. })));
    }
}
