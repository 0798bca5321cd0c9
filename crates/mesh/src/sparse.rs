//! Sparse symmetric systems: a fixed pattern with value slots (assemble by index, no triplet
//! sorting per Newton step) and a sparse Cholesky whose symbolic analysis (AMD or a given
//! ordering such as [`crate::ordering::nested_dissection`], supernodes) is computed once and
//! reused for every numeric factorization, in double or single precision ([`FactorScalar`]),
//! optionally split over two threads along a nested dissection's top separator
//! ([`CholeskySolver::with_split_ordering`]).
//!
//! Backed by `faer`'s supernodal LLᵀ. The split (two sparse factorizations joined by a dense
//! Schur complement) is written here because faer's numeric factorization parallelizes only
//! inside its dense kernels, which was slower than one thread on these systems. So is the
//! forward triangular solve with a supernodal factor (`supernodal_forward`): faer's calls a
//! dense triangular solve and a matrix product per supernode, built for many right-hand
//! sides; a Newton step (or a conjugate-gradient iteration) has one, and streaming each
//! column of the factor once, in ascending memory order, took kitten's two-thread
//! single-precision forward sweep from 7–9 ms to 3.3–5.4 ms. The backward sweep stays faer's
//! (`supernodal_backward`).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::{
    LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Mat, MatMut, MatRef, Par, Side};
use rayon::slice::ParallelSliceMut;
use std::sync::Arc;

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
    /// A matrix value is not representable in the factor's precision.
    #[error("matrix value {value:e} at slot {slot} is out of the factor's range")]
    OutOfRange {
        /// Slot in the caller's pattern.
        slot: usize,
        /// The value.
        value: f64,
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
        // (In parallel: a mesh's face-by-face entries are millions, kitten's 4.8M.)
        keys.par_sort_unstable();
        keys.dedup();
        Self::from_sorted_keys(n, &keys)
    }

    /// The pattern of sorted, distinct `column << 32 | row` keys (row ≥ column).
    fn from_sorted_keys(n: usize, keys: &[u64]) -> Self {
        let mut col_ptr = vec![0usize; n + 1];
        let mut row_idx = Vec::with_capacity(keys.len());
        for &k in keys {
            col_ptr[(k >> 32) as usize + 1] += 1;
            row_idx.push((k & 0xFFFF_FFFF) as usize);
        }
        for c in 0..n {
            col_ptr[c + 1] += col_ptr[c];
        }
        Self { n, col_ptr, row_idx }
    }

    /// Every stored entry `(row, column, slot)` of the matrix permuted by `inv` (the old
    /// index i moves to position `inv[i]`), as a lower-triangle entry (row ≥ column).
    fn permuted_entries<'p>(&'p self, inv: &'p [usize]) -> impl Iterator<Item = (usize, usize, usize)> + 'p {
        (0..self.n).flat_map(move |c| {
            (self.col_ptr[c]..self.col_ptr[c + 1]).map(move |k| {
                let (i, j) = (inv[self.row_idx[k]], inv[c]);
                if i >= j { (i, j, k) } else { (j, i, k) }
            })
        })
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
        self.mul_vec_columns(values, x, y, 0..self.n);
    }

    /// y = A x on two threads for large matrices: each multiplies half of the stored entries
    /// (whole columns) into its own vector, and the two are added in a fixed order, so the
    /// result does not depend on scheduling.
    pub fn mul_vec_parallel(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        if self.nnz() < PARALLEL_MUL_MIN_NNZ {
            return self.mul_vec(values, x, y);
        }
        self.mul_vec_halves(values, x, y);
    }

    fn mul_vec_halves(&self, values: &[f64], x: &[f64], y: &mut [f64]) {
        let half = self.col_ptr.partition_point(|&p| p < self.nnz() / 2).min(self.n);
        let mut other = vec![0.0; self.n];
        y.iter_mut().for_each(|v| *v = 0.0);
        rayon::join(
            || self.mul_vec_columns(values, x, y, 0..half),
            || self.mul_vec_columns(values, x, &mut other, half..self.n),
        );
        y.iter_mut().zip(&other).for_each(|(a, b)| *a += b);
    }

    fn mul_vec_columns(&self, values: &[f64], x: &[f64], y: &mut [f64], cols: std::ops::Range<usize>) {
        for c in cols {
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

/// Sparse Cholesky with a reusable symbolic analysis (faer's supernodal LLᵀ, low-level API so
/// that the symbolic structure is shared by every numeric factorization).
///
/// The fill-reducing permutation is applied once, to the pattern: the analysis is done on the
/// permuted pattern with faer's identity ordering, and every numeric factorization gathers the
/// values into the permuted order through a precomputed slot map (converting them to the
/// factor's precision on the way). Faer would otherwise re-permute the matrix, indices
/// included, in every factorization (about 13 ms of kitten's 155 ms single-precision one).
///
/// With [`CholeskySolver::with_split_ordering`] (a nested-dissection order whose top separator
/// is known) the factorization runs on two threads: faer's numeric factorization is
/// sequential per matrix (its own parallel mode was slower here), so the two halves are
/// factored as two matrices at once, each with the separator appended,
///
/// ```text
/// F0 = chol [A00 B0; B0ᵀ c·I],   F1 = chol [A11 B1; B1ᵀ c·I],
/// ```
///
/// whose trailing separator blocks `L_h` (`L_h L_hᵀ = c·I − B_hᵀA_hh⁻¹B_h`) give the
/// separator's Schur complement `S = C − B0ᵀA00⁻¹B0 − B1ᵀA11⁻¹B1 = C + Σ_h (L_h L_hᵀ − c·I)`,
/// factored densely in double precision. `c` is a power of two ≥ 1.5·λmax(C) (Gershgorin):
/// when the matrix is positive definite, `B_hᵀA_hh⁻¹B_h ≺ C`, so both appended blocks are
/// positive definite with condition numbers below 3. A solve is a forward solve with both halves (in parallel), a dense separator
/// solve, and a backward solve with both halves (in parallel).
#[derive(Clone, Debug)]
pub struct CholeskySolver {
    analysis: Arc<Analysis>,
    par: Par,
}

#[derive(Debug)]
struct Analysis {
    /// `perm[k]`: the original index placed at position k.
    perm: Vec<usize>,
    kind: Kind,
}

// One per solver: the size of the variants does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
enum Kind {
    Whole(Part),
    Split(Split),
}

/// One matrix handed to faer: its lower triangle in elimination order, where each of its
/// slots takes its value from (a slot of the caller's pattern, or [`SEP_SHIFT`]).
#[derive(Debug)]
struct Part {
    symbolic: SymbolicCholesky<usize>,
    lower: SymmetricPattern,
    src: Vec<usize>,
}

/// Stored entries from which [`SymmetricPattern::mul_vec_parallel`] uses two threads.
const PARALLEL_MUL_MIN_NNZ: usize = 200_000;

/// Source marker of the `c·I` diagonal of the halves' separator blocks.
const SEP_SHIFT: usize = usize::MAX;

#[derive(Debug)]
struct Split {
    halves: [Part; 2],
    /// Unknowns of the two halves (without the separator) and of the separator.
    n: [usize; 2],
    ns: usize,
    /// The separator block's entries (row, column in the separator, caller's slot).
    c_entries: Vec<(usize, usize, usize)>,
}

impl CholeskySolver {
    /// Symbolic analysis of the pattern with faer's AMD ordering (done once).
    pub fn new(pattern: &SymmetricPattern) -> Result<Self, SolveError> {
        Self::with_ordering(pattern, None)
    }

    /// Symbolic analysis with a given fill-reducing permutation (`perm[i]` is the original
    /// index placed at position i), or AMD when `None`.
    pub fn with_ordering(pattern: &SymmetricPattern, perm: Option<&[usize]>) -> Result<Self, SolveError> {
        let fwd = match perm {
            Some(p) => p.to_vec(),
            None => {
                let sym = factorize_symbolic_cholesky(
                    pattern.symbolic(),
                    Side::Lower,
                    SymmetricOrdering::Amd,
                    Default::default(),
                )
                .map_err(|e| SolveError::Internal(format!("{e:?}")))?;
                match sym.perm() {
                    Some(p) => p.arrays().0.to_vec(),
                    None => (0..pattern.n).collect(),
                }
            }
        };
        let inv = inverse(&fwd, pattern.n)?;
        let (lower, src) = permute_pattern(pattern, &inv);
        let symbolic = analyse(&lower)?;
        Ok(Self {
            analysis: Arc::new(Analysis { perm: fwd, kind: Kind::Whole(Part { symbolic, lower, src }) }),
            par: Par::Seq,
        })
    }

    /// Symbolic analysis for the two-thread factorization (see [`CholeskySolver`]): `perm`
    /// eliminates a first part of `parts[0]` unknowns, then a second of `parts[1]` unknowns
    /// with no entry coupling it to the first, then their separator. An error if the parts
    /// are coupled, or if either half is too small for faer's supernodal kernel.
    pub fn with_split_ordering(
        pattern: &SymmetricPattern,
        perm: &[usize],
        parts: [usize; 2],
    ) -> Result<Self, SolveError> {
        let n = pattern.n;
        let inv = inverse(perm, n)?;
        let [n0, n1] = parts;
        if n0 + n1 > n {
            return Err(SolveError::Internal(format!("parts of {n0} + {n1} unknowns exceed {n}")));
        }
        let ns = n - n0 - n1;
        // Position → (half, local index); the separator belongs to both.
        let half_of = |p: usize| {
            if p < n0 {
                0
            } else if p < n0 + n1 {
                1
            } else {
                2
            }
        };
        let local = |h: usize, p: usize| match half_of(p) {
            2 => [n0, n1][h] + (p - n0 - n1),
            0 => p,
            _ => p - n0,
        };
        let mut entries: [Vec<(u64, usize)>; 2] = [Vec::new(), Vec::new()];
        let mut c_entries = Vec::new();
        for (r, cc, k) in pattern.permuted_entries(&inv) {
            let key = |h: usize| ((local(h, cc) as u64) << 32) | local(h, r) as u64;
            match (half_of(r), half_of(cc)) {
                (2, 2) => c_entries.push((r - n0 - n1, cc - n0 - n1, k)),
                (a, b) if a == b => entries[a].push((key(a), k)),
                (2, h) => entries[h].push((key(h), k)),
                _ => return Err(SolveError::Internal(format!("entry ({r}, {cc}) couples the two parts"))),
            }
        }
        // Both halves' separator blocks: c·I (C itself enters the dense Schur complement).
        for (h, e) in entries.iter_mut().enumerate() {
            for s in 0..ns {
                let d = ([n0, n1][h] + s) as u64;
                e.push(((d << 32) | d, SEP_SHIFT));
            }
        }
        let mut halves = Vec::with_capacity(2);
        for (h, e) in entries.into_iter().enumerate() {
            let (lower, src) = pattern_from_keyed([n0, n1][h] + ns, e);
            let symbolic = analyse(&lower)?;
            if !matches!(symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)) {
                return Err(SolveError::Internal("a half is too small for the supernodal kernel".into()));
            }
            halves.push(Part { symbolic, lower, src });
        }
        let halves: [Part; 2] = halves.try_into().expect("two halves");
        Ok(Self {
            analysis: Arc::new(Analysis {
                perm: perm.to_vec(),
                kind: Kind::Split(Split { halves, n: [n0, n1], ns, c_entries }),
            }),
            par: Par::Seq,
        })
    }

    /// True if factorizations run on two threads ([`CholeskySolver::with_split_ordering`]).
    pub fn is_split(&self) -> bool {
        matches!(self.analysis.kind, Kind::Split(_))
    }

    /// AMD order (`order[k]` is the k-th node eliminated) of the `n_nodes`-node graph with the
    /// given edges (either direction; duplicates and loops allowed).
    pub fn amd_order(
        n_nodes: usize,
        node_entries: impl IntoIterator<Item = (usize, usize)>,
    ) -> Result<Vec<usize>, SolveError> {
        let graph = SymmetricPattern::from_entries(n_nodes, node_entries);
        let sym =
            factorize_symbolic_cholesky(graph.symbolic(), Side::Lower, SymmetricOrdering::Amd, Default::default())
                .map_err(|e| SolveError::Internal(format!("{e:?}")))?;
        Ok(match sym.perm() {
            Some(p) => p.arrays().0.to_vec(),
            None => (0..n_nodes).collect(),
        })
    }

    /// Entries of the Cholesky factor's lower triangle (diagonal included) of the
    /// `n_nodes`-node graph with the given edges, eliminated in `order` (`order[k]` is the
    /// k-th node): a cheap measure of the fill an ordering of the nodes gives, to compare
    /// orderings before the (much larger) dof-level analysis. With b dofs per node, the dof
    /// factor has about b² times as many entries.
    pub fn node_fill(
        n_nodes: usize,
        node_entries: impl IntoIterator<Item = (usize, usize)>,
        order: &[usize],
    ) -> Result<usize, SolveError> {
        let graph = SymmetricPattern::from_entries(n_nodes, node_entries);
        let inv = inverse(order, n_nodes)?;
        let (lower, _) = permute_pattern(&graph, &inv);
        let params = faer::sparse::linalg::cholesky::CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: faer::sparse::linalg::SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        };
        Ok(analyse_with(&lower, params)?.len_val())
    }

    /// Stored length of the factor (supernodal storage, including padding; with the split
    /// factorization both halves and the dense separator).
    pub fn factor_len(&self) -> usize {
        match &self.analysis.kind {
            Kind::Whole(p) => p.symbolic.len_val(),
            Kind::Split(s) => s.halves.iter().map(|p| p.symbolic.len_val()).sum::<usize>() + s.ns * s.ns,
        }
    }

    /// Numeric factorization (double precision) of the matrix with the given values (same
    /// pattern).
    pub fn factor(&self, pattern: &SymmetricPattern, values: &[f64]) -> Result<CholeskyFactor, SolveError> {
        self.factor_in(pattern, values)
    }

    /// Numeric factorization in precision `T` of the matrix with the given values.
    pub fn factor_in<T: FactorScalar>(
        &self,
        pattern: &SymmetricPattern,
        values: &[f64],
    ) -> Result<CholeskyFactor<T>, SolveError> {
        let n_parts = match &self.analysis.kind {
            Kind::Whole(_) => 1,
            Kind::Split(_) => 2,
        };
        let mut f = CholeskyFactor {
            analysis: self.analysis.clone(),
            parts: (0..n_parts)
                .map(|_| PartFactor { values: Vec::new(), a_values: Vec::new(), scratch: None })
                .collect(),
            sep: None,
            par: self.par,
            valid: false,
        };
        self.refactor(pattern, values, &mut f)?;
        Ok(f)
    }

    /// Numeric factorization into an existing factor, reusing its buffers (the factor of a
    /// large mesh is hundreds of megabytes: allocating and faulting it in every Newton step
    /// costs as much as the factorization). On error the factor is left invalid. A value
    /// outside `T`'s range is refused as [`SolveError::OutOfRange`].
    pub fn refactor<T: FactorScalar>(
        &self,
        pattern: &SymmetricPattern,
        values: &[f64],
        f: &mut CholeskyFactor<T>,
    ) -> Result<(), SolveError> {
        assert_eq!(values.len(), pattern.nnz(), "value count must match the pattern");
        assert_eq!(pattern.n(), self.analysis.perm.len(), "the pattern must be the analysed one");
        assert!(Arc::ptr_eq(&f.analysis, &self.analysis), "factor belongs to another solver");
        f.valid = false;
        let par = self.par;
        match &self.analysis.kind {
            Kind::Whole(p) => factor_part(p, values, 0.0, &mut f.parts[0], par)?,
            Kind::Split(s) => {
                // c ≥ 1.5 λmax(C) (Gershgorin), a power of two (exact in either precision):
                // c·I − B_hᵀA_hh⁻¹B_h ≻ (c − λmax(C))·I, so both halves stay positive definite
                // and well conditioned whenever the matrix is positive definite.
                let mut row = vec![0.0f64; s.ns];
                for &(r, c, k) in &s.c_entries {
                    row[r] += values[k].abs();
                    if r != c {
                        row[c] += values[k].abs();
                    }
                }
                let bound = 1.5 * row.iter().fold(0.0f64, |m, &v| m.max(v));
                let shift = if bound > 0.0 && bound.is_finite() { 2f64.powi(bound.log2().ceil() as i32) } else { 1.0 };
                let (p0, p1) = f.parts.split_at_mut(1);
                let (r0, r1) = rayon::join(
                    || factor_part(&s.halves[0], values, shift, &mut p0[0], par),
                    || factor_part(&s.halves[1], values, shift, &mut p1[0], par),
                );
                // Pivot indices in the elimination order of the whole matrix.
                let global = |h: usize, r: Result<(), SolveError>| {
                    r.map_err(|e| match e {
                        SolveError::NotPositiveDefinite { index } => SolveError::NotPositiveDefinite {
                            index: if index < s.n[h] {
                                [0, s.n[0]][h] + index
                            } else {
                                s.n[0] + s.n[1] + index - s.n[h]
                            },
                        },
                        e => e,
                    })
                };
                global(0, r0)?;
                global(1, r1)?;
                // The separator's Schur complement C − Σ B_hᵀA_hh⁻¹B_h = C + Σ (L_h L_hᵀ − c·I),
                // L_h the halves' trailing blocks; lower triangle only.
                // The dense blocks of an earlier factorization are reused.
                let sep = f.sep.get_or_insert_with(|| SepFactor {
                    l: [Mat::zeros(s.ns, s.ns), Mat::zeros(s.ns, s.ns)],
                    schur: Mat::zeros(s.ns, s.ns),
                });
                for (h, l) in sep.l.iter_mut().enumerate() {
                    trailing_block(&s.halves[h], &f.parts[h], s.n[h], l);
                }
                let schur = &mut sep.schur;
                schur.fill(0.0);
                for &(r, c, k) in &s.c_entries {
                    schur[(r, c)] += values[k];
                }
                for i in 0..s.ns {
                    schur[(i, i)] -= 2.0 * shift;
                }
                for lh in &sep.l {
                    use faer::linalg::matmul::triangular::{BlockStructure, matmul};
                    matmul(
                        schur.as_mut(),
                        BlockStructure::TriangularLower,
                        faer::Accum::Add,
                        lh.as_ref(),
                        BlockStructure::TriangularLower,
                        lh.transpose(),
                        BlockStructure::TriangularUpper,
                        1.0,
                        Par::Seq,
                    );
                }
                // Dense Cholesky, sequential (no dependence on the thread count).
                let mut mem = MemBuffer::new(faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                    s.ns,
                    Par::Seq,
                    Default::default(),
                ));
                faer::linalg::cholesky::llt::factor::cholesky_in_place(
                    schur.as_mut(),
                    Default::default(),
                    Par::Seq,
                    MemStack::new(&mut mem),
                    Default::default(),
                )
                .map_err(|e| match e {
                    faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => {
                        SolveError::NotPositiveDefinite { index: s.n[0] + s.n[1] + index }
                    }
                })?;
            }
        }
        f.valid = true;
        Ok(())
    }
}

/// `inv` of a permutation of 0..n, or an error naming the offending index.
fn inverse(fwd: &[usize], n: usize) -> Result<Vec<usize>, SolveError> {
    if fwd.len() != n {
        return Err(SolveError::Internal(format!("ordering of {} indices for {n} unknowns", fwd.len())));
    }
    let mut inv = vec![usize::MAX; n];
    for (i, &p) in fwd.iter().enumerate() {
        if p >= n || inv[p] != usize::MAX {
            return Err(SolveError::Internal(format!("ordering is not a permutation (index {p})")));
        }
        inv[p] = i;
    }
    Ok(inv)
}

/// The permuted matrix's lower triangle, with the source slot of every entry.
fn permute_pattern(pattern: &SymmetricPattern, inv: &[usize]) -> (SymmetricPattern, Vec<usize>) {
    let keyed = pattern.permuted_entries(inv).map(|(r, c, k)| (((c as u64) << 32) | r as u64, k)).collect();
    pattern_from_keyed(pattern.n, keyed)
}

/// Lower pattern from `(column << 32 | row, source)` entries (distinct keys), with the
/// source of each of its slots.
fn pattern_from_keyed(n: usize, mut keyed: Vec<(u64, usize)>) -> (SymmetricPattern, Vec<usize>) {
    keyed.sort_unstable_by_key(|e| e.0);
    let keys: Vec<u64> = keyed.iter().map(|e| e.0).collect();
    (SymmetricPattern::from_sorted_keys(n, &keys), keyed.into_iter().map(|e| e.1).collect())
}

/// Faer's identity-ordered analysis, which reads the upper triangle: the transpose.
fn analyse(lower: &SymmetricPattern) -> Result<SymbolicCholesky<usize>, SolveError> {
    analyse_with(lower, Default::default())
}

fn analyse_with(
    lower: &SymmetricPattern,
    params: faer::sparse::linalg::cholesky::CholeskySymbolicParams<'_>,
) -> Result<SymbolicCholesky<usize>, SolveError> {
    let n = lower.n;
    let (up_ptr, up_rows) = crate::util::group_by_key(n, || {
        (0..n).flat_map(move |c| lower.row_idx[lower.col_ptr[c]..lower.col_ptr[c + 1]].iter().map(move |&r| (r, c)))
    });
    let upper = SymbolicSparseColMatRef::new_checked(n, n, &up_ptr, None, &up_rows);
    factorize_symbolic_cholesky(upper, Side::Upper, SymmetricOrdering::Identity, params)
        .map_err(|e| SolveError::Internal(format!("{e:?}")))
}

/// Gather one matrix's values (the separator shift where marked) and factor it.
fn factor_part<T: FactorScalar>(
    p: &Part,
    values: &[f64],
    shift: f64,
    f: &mut PartFactor<T>,
    par: Par,
) -> Result<(), SolveError> {
    f.a_values.clear();
    f.a_values.extend(p.src.iter().map(|&k| T::from_f64(if k == SEP_SHIFT { shift } else { values[k] })));
    if let Some(k) = f.a_values.iter().position(|v| !v.is_finite()) {
        let (slot, value) = match p.src[k] {
            SEP_SHIFT => (p.src.iter().position(|&k| k != SEP_SHIFT).map_or(0, |i| p.src[i]), shift),
            slot => (slot, values[slot]),
        };
        // A value that is not a number at all fails like a lost pivot (as faer would report
        // it); a finite one beyond T's range is out of range.
        return Err(if value.is_finite() {
            SolveError::OutOfRange { slot, value }
        } else {
            SolveError::NotPositiveDefinite { index: p.lower.col_ptr.partition_point(|&c| c <= k) - 1 }
        });
    }
    f.values.resize(p.symbolic.len_val(), T::default());
    // The supernodal kernel zeroes its storage itself; the simplicial one is given a zeroed
    // buffer, as faer's own high-level API does.
    if matches!(p.symbolic.raw(), SymbolicCholeskyRaw::Simplicial(_)) {
        f.values.fill(T::default());
    }
    // The workspace's size is computed once (it walks every supernode).
    let mem = match &mut f.scratch {
        Some(m) => m,
        None => {
            let req = p.symbolic.factorize_numeric_llt_scratch::<T>(par, Default::default());
            f.scratch.insert(MemBuffer::try_new(req).map_err(|_| SolveError::Internal("out of memory".into()))?)
        }
    };
    let mat = SparseColMatRef::new(p.lower.symbolic(), &f.a_values);
    match p.symbolic.factorize_numeric_llt(
        &mut f.values,
        mat,
        Side::Lower,
        Default::default(),
        par,
        MemStack::new(mem),
        Default::default(),
    ) {
        Ok(_) => Ok(()),
        Err(faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index }) => {
            Err(SolveError::NotPositiveDefinite { index })
        }
    }
}

/// The trailing `ns × ns` block (columns and rows from `start`) of a supernodal factor, in
/// double precision.
fn trailing_block<T: FactorScalar>(p: &Part, f: &PartFactor<T>, start: usize, out: &mut Mat<f64>) {
    let SymbolicCholeskyRaw::Supernodal(sym) = p.symbolic.raw() else {
        unreachable!("split halves are supernodal (checked in the analysis)")
    };
    let llt = SupernodalLltRef::new(sym, &f.values);
    out.fill(0.0);
    for s in 0..sym.n_supernodes() {
        let node = llt.supernode(s);
        let (first, val) = (node.start(), node.val());
        let ncols = val.ncols();
        if first + ncols <= start {
            continue;
        }
        for j in 0..ncols {
            let col = first + j;
            if col < start {
                continue;
            }
            for i in j..ncols {
                out[(first + i - start, col - start)] = val[(i, j)].to_f64();
            }
            for (k, &row) in node.pattern().iter().enumerate() {
                out[(row - start, col - start)] = val[(ncols + k, j)].to_f64();
            }
        }
    }
}

/// Scalars a factor can be computed in: f64, or f32 for a preconditioner (half the memory
/// traffic and twice the SIMD width of f64).
pub trait FactorScalar:
    faer::traits::RealField
    + Copy
    + Default
    + Send
    + Sync
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::AddAssign
    + std::ops::SubAssign
{
    /// Rounded from f64 (infinite when out of range).
    fn from_f64(v: f64) -> Self;
    /// Widened to f64.
    fn to_f64(self) -> f64;
    /// Neither infinite nor NaN.
    fn is_finite(&self) -> bool;
}
impl FactorScalar for f64 {
    fn from_f64(v: f64) -> Self {
        v
    }
    fn to_f64(self) -> f64 {
        self
    }
    fn is_finite(&self) -> bool {
        f64::is_finite(*self)
    }
}
impl FactorScalar for f32 {
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    fn to_f64(self) -> f64 {
        self as f64
    }
    fn is_finite(&self) -> bool {
        f32::is_finite(*self)
    }
}

/// Buffers of one factored matrix.
struct PartFactor<T> {
    values: Vec<T>,
    /// The permuted matrix handed to the factorization (kept to reuse its buffer).
    a_values: Vec<T>,
    scratch: Option<MemBuffer>,
}

/// The separator of a split factor: the halves' trailing blocks and the Schur complement's
/// dense Cholesky factor.
struct SepFactor {
    /// The halves' trailing blocks.
    l: [Mat<f64>; 2],
    /// Lower Cholesky factor of the Schur complement (its strict upper part is unused).
    schur: Mat<f64>,
}

/// A numeric Cholesky factor.
pub struct CholeskyFactor<T = f64> {
    analysis: Arc<Analysis>,
    parts: Vec<PartFactor<T>>,
    sep: Option<SepFactor>,
    par: Par,
    valid: bool,
}

impl<T> std::fmt::Debug for CholeskyFactor<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CholeskyFactor")
            .field("n", &self.analysis.perm.len())
            .field("parts", &self.parts.len())
            .field("valid", &self.valid)
            .finish()
    }
}

impl<T: FactorScalar> CholeskyFactor<T> {
    /// True if the last factorization into this factor succeeded.
    pub fn is_valid(&self) -> bool {
        self.valid
    }

    /// Solve A x = b in place (`rhs` holds b on entry, x on exit), in the factor's precision
    /// (b rounded to it, x widened back; the split factor's separator in double precision).
    ///
    /// # Panics
    /// If the factor is invalid (its last factorization failed).
    pub fn solve_in_place(&self, rhs: &mut [f64]) {
        assert!(self.valid, "solve with a failed factorization");
        let perm = &self.analysis.perm;
        assert_eq!(rhs.len(), perm.len());
        // Scaled by a power of two (exact) to order one, so that a single-precision solve
        // neither underflows nor overflows on very small or large right-hand sides.
        let big = rhs.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let scale = if big > 0.0 && big.is_finite() { 2f64.powi(-(big.log2().round() as i32)) } else { 1.0 };
        if scale != 1.0 {
            rhs.iter_mut().for_each(|v| *v *= scale);
        }
        self.solve_scaled(rhs);
        if scale != 1.0 {
            rhs.iter_mut().for_each(|v| *v /= scale);
        }
    }

    fn solve_scaled(&self, rhs: &mut [f64]) {
        let perm = &self.analysis.perm;
        match &self.analysis.kind {
            Kind::Whole(p) => {
                let n = perm.len();
                let mut x: Vec<T> = perm.iter().map(|&i| T::from_f64(rhs[i])).collect();
                if let SymbolicCholeskyRaw::Supernodal(sym) = p.symbolic.raw() {
                    let llt = SupernodalLltRef::new(sym, &self.parts[0].values);
                    supernodal_forward(&llt, &mut x);
                    supernodal_backward(&llt, &mut x, self.par);
                } else {
                    let m = MatMut::from_column_major_slice_mut(&mut x, n, 1);
                    let mut mem = MemBuffer::new(p.symbolic.solve_in_place_scratch::<T>(1, self.par));
                    LltRef::new(&p.symbolic, &self.parts[0].values).solve_in_place_with_conj(
                        faer::Conj::No,
                        m,
                        self.par,
                        MemStack::new(&mut mem),
                    );
                }
                for (&i, v) in perm.iter().zip(&x) {
                    rhs[i] = v.to_f64();
                }
            }
            Kind::Split(s) => self.solve_split(s, rhs),
        }
    }

    fn solve_split(&self, s: &Split, rhs: &mut [f64]) {
        let perm = &self.analysis.perm;
        let sep = self.sep.as_ref().expect("a valid split factor has its separator");
        let [n0, n1] = s.n;
        let ns = s.ns;
        let offset = [0, n0];
        // Forward: [z_h; t_h] = F_h⁻¹ [b_h; 0], so that W_hᵀ z_h = −L_h t_h.
        let mut u: Vec<Vec<T>> = (0..2)
            .map(|h| {
                let mut v: Vec<T> = (0..s.n[h]).map(|k| T::from_f64(rhs[perm[offset[h] + k]])).collect();
                v.resize(s.n[h] + ns, T::default());
                v
            })
            .collect();
        let (u0, u1) = u.split_at_mut(1);
        rayon::join(|| self.half_solve(s, 0, &mut u0[0], false), || self.half_solve(s, 1, &mut u1[0], false));
        // Separator: S xs = b_s − W0ᵀz0 − W1ᵀz1 = b_s + L0 t0 + L1 t1.
        let mut xs = Mat::<f64>::zeros(ns, 1);
        for i in 0..ns {
            xs[(i, 0)] = rhs[perm[n0 + n1 + i]];
        }
        for (h, l) in sep.l.iter().enumerate() {
            let t: Vec<f64> = u[h][s.n[h]..].iter().map(|v| v.to_f64()).collect();
            for j in 0..ns {
                let tj = t[j];
                if tj != 0.0 {
                    for i in j..ns {
                        xs[(i, 0)] += l[(i, j)] * tj;
                    }
                }
            }
        }
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(sep.schur.as_ref(), xs.as_mut(), Par::Seq);
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(sep.schur.transpose(), xs.as_mut(), Par::Seq);
        // Backward: [x_h; xs] = F_h⁻ᵀ [z_h; L_hᵀ xs].
        for (h, l) in sep.l.iter().enumerate() {
            for j in 0..ns {
                let mut acc = 0.0;
                for i in j..ns {
                    acc += l[(i, j)] * xs[(i, 0)];
                }
                u[h][s.n[h] + j] = T::from_f64(acc);
            }
        }
        let (u0, u1) = u.split_at_mut(1);
        rayon::join(|| self.half_solve(s, 0, &mut u0[0], true), || self.half_solve(s, 1, &mut u1[0], true));
        for h in 0..2 {
            for k in 0..s.n[h] {
                rhs[perm[offset[h] + k]] = u[h][k].to_f64();
            }
        }
        for i in 0..ns {
            rhs[perm[n0 + n1 + i]] = xs[(i, 0)];
        }
    }

    /// Forward (L) or backward (Lᵀ) triangular solve with half `h`.
    fn half_solve(&self, s: &Split, h: usize, v: &mut [T], transpose: bool) {
        let SymbolicCholeskyRaw::Supernodal(sym) = s.halves[h].symbolic.raw() else {
            unreachable!("split halves are supernodal (checked in the analysis)")
        };
        let llt = SupernodalLltRef::new(sym, &self.parts[h].values);
        if transpose {
            supernodal_backward(&llt, v, self.par);
        } else {
            supernodal_forward(&llt, v);
        }
    }
}

/// The columns of supernode `s` of a supernodal factor: its first column, its width, the rows
/// below its diagonal block, and the column-major values (diagonal block, then those rows).
fn supernode_columns<'a, T: FactorScalar>(
    llt: &SupernodalLltRef<'a, usize, T>,
    s: usize,
) -> (usize, usize, &'a [usize], MatRef<'a, T>) {
    let sn = llt.supernode(s);
    let val = sn.val();
    (sn.start(), val.ncols(), sn.pattern(), val)
}

/// Column `j` of a supernode's values as a slice (faer stores them column-major, contiguous).
fn column<'a, T: FactorScalar>(val: MatRef<'a, T>, j: usize) -> &'a [T] {
    val.col(j).try_as_col_major().expect("supernodal values are column-major").as_slice()
}

/// x ← L⁻¹ x for a supernodal factor L and one right-hand side: each column read once, its
/// diagonal-block part and its below-block part in the same pass.
pub(crate) fn supernodal_forward<T: FactorScalar>(llt: &SupernodalLltRef<'_, usize, T>, x: &mut [T]) {
    assert_eq!(x.len(), llt.symbolic().nrows(), "right-hand side of the factor's size");
    let mut below: Vec<T> = Vec::new();
    for s in 0..llt.symbolic().n_supernodes() {
        let (start, size, pattern, val) = supernode_columns(llt, s);
        below.clear();
        below.resize(pattern.len(), T::default());
        let xs = &mut x[start..start + size];
        for j in 0..size {
            let col = column(val, j);
            let xj = xs[j] / col[j];
            xs[j] = xj;
            for (xi, &l) in xs[j + 1..].iter_mut().zip(&col[j + 1..size]) {
                *xi -= l * xj;
            }
            for (b, &l) in below.iter_mut().zip(&col[size..]) {
                *b += l * xj;
            }
        }
        for (&i, &b) in pattern.iter().zip(&below) {
            x[i] -= b;
        }
    }
}

/// x ← L⁻ᵀ x for a supernodal factor L and one right-hand side: faer's (its transposed
/// products, in its wider SIMD kernels, were faster than one pass over the columns here: the
/// backward sweep visits the supernodes in descending memory order, which the hardware does
/// not prefetch, and is bound by the products rather than by the stream).
pub(crate) fn supernodal_backward<T: FactorScalar>(llt: &SupernodalLltRef<'_, usize, T>, x: &mut [T], par: Par) {
    let n = x.len();
    let m = MatMut::from_column_major_slice_mut(x, n, 1);
    let mut mem = MemBuffer::new(llt.symbolic().solve_in_place_scratch::<T>(1, par));
    llt.l_transpose_solve_with_conj(faer::Conj::No, m, par, MemStack::new(&mut mem));
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The edges of an nx × ny grid graph (node `j·nx + i` at column i, row j), with the
    /// diagonals (i, j)–(i+1, j+1) if asked.
    pub(crate) fn grid_edges(nx: usize, ny: usize, diagonals: bool) -> Vec<(usize, usize)> {
        let id = |i: usize, j: usize| j * nx + i;
        let mut edges = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                if i + 1 < nx {
                    edges.push((id(i, j), id(i + 1, j)));
                }
                if j + 1 < ny {
                    edges.push((id(i, j), id(i, j + 1)));
                }
                if diagonals && i + 1 < nx && j + 1 < ny {
                    edges.push((id(i, j), id(i + 1, j + 1)));
                }
            }
        }
        edges
    }

    /// An SPD matrix on these edges over `n` unknowns: −1 per edge, `diag + (i mod 5)/10` on
    /// the diagonal.
    fn laplacian(n: usize, edges: &[(usize, usize)], diag: f64) -> (SymmetricPattern, Vec<f64>) {
        let p = SymmetricPattern::from_entries(n, edges.iter().copied());
        let mut v = vec![0.0; p.nnz()];
        for i in 0..n {
            v[p.slot(i, i)] = diag + (i % 5) as f64 * 0.1;
        }
        for &(a, b) in edges {
            v[p.slot(a, b)] = -1.0;
        }
        (p, v)
    }

    fn max_dev(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
    }

    /// max |A x − b|.
    fn residual(p: &SymmetricPattern, v: &[f64], x: &[f64], b: &[f64]) -> f64 {
        let mut ax = vec![0.0; b.len()];
        p.mul_vec(v, x, &mut ax);
        max_dev(&ax, b)
    }

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
        // Single precision: the same solution to single-precision accuracy.
        let f32 = solver.factor_in::<f32>(&p, &v).unwrap();
        let mut x32 = b.clone();
        f32.solve_in_place(&mut x32);
        let dev = x.iter().zip(&x32).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let scale = x.iter().fold(0.0f64, |m, a| m.max(a.abs()));
        assert!(dev < 1e-5 * scale && dev > 0.0, "{dev} against {scale}");
        // Beyond single precision's range: refused, naming the slot.
        let mut big = v.clone();
        big[p.slot(3, 3)] = 1e300;
        match solver.factor_in::<f32>(&p, &big) {
            Err(SolveError::OutOfRange { slot, .. }) => assert_eq!(slot, p.slot(3, 3)),
            other => panic!("{other:?}"),
        }
        // Same pattern, indefinite values: refused.
        for i in 0..n {
            v[p.slot(i, i)] = -1.0;
        }
        assert!(matches!(solver.factor(&p, &v), Err(SolveError::NotPositiveDefinite { .. })));
        assert!(matches!(solver.factor_in::<f32>(&p, &v), Err(SolveError::NotPositiveDefinite { .. })));
    }

    /// A 2D grid Laplacian (large enough for the supernodal kernel) under a scrambled
    /// ordering: the pre-permuted pattern solves the original system, in both precisions.
    #[test]
    fn custom_ordering_solves_the_original_system() {
        let m = 60;
        let n = m * m;
        let (p, v) = laplacian(n, &grid_edges(m, m, false), 4.01);
        // A scrambled order (a multiplicative walk) and AMD.
        let order: Vec<usize> = (0..n).map(|k| (k * 1237) % n).collect();
        let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
        for solver in [CholeskySolver::with_ordering(&p, Some(&order)).unwrap(), CholeskySolver::new(&p).unwrap()] {
            let mut x = b.clone();
            solver.factor(&p, &v).unwrap().solve_in_place(&mut x);
            let err = residual(&p, &v, &x, &b);
            assert!(err < 1e-10, "{err}");
            let mut x32 = b.clone();
            solver.factor_in::<f32>(&p, &v).unwrap().solve_in_place(&mut x32);
            let err = residual(&p, &v, &x32, &b);
            assert!(err < 1e-4 && err > 1e-12, "{err}");
        }
        // Not a permutation: an error, not a panic.
        let mut bad = order.clone();
        bad[1] = bad[0];
        assert!(matches!(CholeskySolver::with_ordering(&p, Some(&bad)), Err(SolveError::Internal(_))));
    }

    /// The vertex-graph fill equals the entries of L counted by eliminating the graph node
    /// by node (each eliminated node's later neighbours become a clique), for a good and a
    /// bad order of a grid; the good order has less fill.
    #[test]
    fn node_fill_counts_the_factor_entries() {
        let (nx, ny) = (9, 7);
        let n = nx * ny;
        let edges = grid_edges(nx, ny, true);
        let brute = |order: &[usize]| -> usize {
            let mut pos = vec![0; n];
            for (k, &v) in order.iter().enumerate() {
                pos[v] = k;
            }
            let mut adj: Vec<std::collections::BTreeSet<usize>> = vec![Default::default(); n];
            for &(a, b) in &edges {
                adj[pos[a]].insert(pos[b]);
                adj[pos[b]].insert(pos[a]);
            }
            let mut count = 0;
            for k in 0..n {
                let later: Vec<usize> = adj[k].iter().copied().filter(|&j| j > k).collect();
                count += 1 + later.len();
                for &i in &later {
                    for &j in &later {
                        if i != j {
                            adj[i].insert(j);
                        }
                    }
                }
            }
            count
        };
        let natural: Vec<usize> = (0..n).collect();
        let amd = CholeskySolver::amd_order(n, edges.iter().copied()).unwrap();
        let fill_natural = CholeskySolver::node_fill(n, edges.iter().copied(), &natural).unwrap();
        let fill_amd = CholeskySolver::node_fill(n, edges.iter().copied(), &amd).unwrap();
        assert_eq!(fill_natural, brute(&natural));
        assert_eq!(fill_amd, brute(&amd));
        // A scrambled order (k ↦ 37k mod 63): more fill.
        let bad: Vec<usize> = (0..n).map(|k| (37 * k) % n).collect();
        let fill_bad = CholeskySolver::node_fill(n, edges.iter().copied(), &bad).unwrap();
        assert_eq!(fill_bad, brute(&bad));
        assert!(fill_amd < fill_natural && fill_natural < fill_bad, "{fill_amd} {fill_natural} {fill_bad}");
        // Not a permutation: refused.
        assert!(CholeskySolver::node_fill(n, edges.iter().copied(), &vec![0; n]).is_err());
    }

    /// The hand-written forward sweep equals faer's (to round-off), in both precisions.
    #[test]
    fn supernodal_forward_sweep_matches_faer() {
        // A half of a split factor (always supernodal: the separator block is dense).
        let m = 80;
        let n = m * m;
        let (p, v) = laplacian(n, &grid_edges(m, m, true), 6.01);
        let mid = m / 2;
        let left: Vec<usize> = (0..m).flat_map(|i| (0..mid).map(move |j| i * m + j)).collect();
        let right: Vec<usize> = (0..m).flat_map(|i| (mid + 1..m).map(move |j| i * m + j)).collect();
        let sep: Vec<usize> = (0..m).map(|i| i * m + mid).collect();
        let order: Vec<usize> = left.iter().chain(&right).chain(&sep).copied().collect();
        let solver = CholeskySolver::with_split_ordering(&p, &order, [left.len(), right.len()]).unwrap();
        let Kind::Split(split) = &solver.analysis.kind else { panic!("split analysis") };
        let SymbolicCholeskyRaw::Supernodal(sym) = split.halves[0].symbolic.raw() else { panic!("supernodal") };
        let n = split.n[0] + split.ns;
        fn check<T: FactorScalar>(
            sym: &faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
            f: &CholeskyFactor<T>,
            n: usize,
            tol: f64,
        ) {
            let llt = SupernodalLltRef::new(sym, &f.parts[0].values);
            let b: Vec<T> = (0..n).map(|i| T::from_f64(((i * 13) % 17) as f64 - 8.0)).collect();
            let mut ours = b.clone();
            supernodal_forward(&llt, &mut ours);
            let mut theirs = b;
            let mut mem = MemBuffer::new(sym.solve_in_place_scratch::<T>(1, Par::Seq));
            llt.l_solve_with_conj(
                faer::Conj::No,
                MatMut::from_column_major_slice_mut(&mut theirs, n, 1),
                Par::Seq,
                MemStack::new(&mut mem),
            );
            let dev = ours.iter().zip(&theirs).map(|(a, b)| (a.to_f64() - b.to_f64()).abs()).fold(0.0, f64::max);
            let big = theirs.iter().map(|v| v.to_f64().abs()).fold(0.0, f64::max);
            assert!(big > 1.0 && dev <= tol * big, "{dev} of {big}");
        }
        check(sym, &solver.factor_in::<f64>(&p, &v).unwrap(), n, 1e-12);
        check(sym, &solver.factor_in::<f32>(&p, &v).unwrap(), n, 1e-5);
    }

    /// The two-thread factorization: a grid split by its middle column solves the original
    /// system, in both precisions, like the single factorization; coupled parts are refused.
    #[test]
    fn split_factorization_solves_the_original_system() {
        let m = 80;
        let n = m * m;
        let id = |i: usize, j: usize| i * m + j;
        // Diagonals, so that the separator couples its neighbours both ways.
        let edges = grid_edges(m, m, true);
        let (p, v) = laplacian(n, &edges, 6.01);
        let mid = m / 2;
        let left: Vec<usize> = (0..m).flat_map(|i| (0..mid).map(move |j| i * m + j)).collect();
        let right: Vec<usize> = (0..m).flat_map(|i| (mid + 1..m).map(move |j| i * m + j)).collect();
        let sep: Vec<usize> = (0..m).map(|i| id(i, mid)).collect();
        let order: Vec<usize> = left.iter().chain(&right).chain(&sep).copied().collect();
        let split = CholeskySolver::with_split_ordering(&p, &order, [left.len(), right.len()]).unwrap();
        assert!(split.is_split());
        let whole = CholeskySolver::with_ordering(&p, Some(&order)).unwrap();
        assert!(!whole.is_split());
        let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
        let mut xs = b.clone();
        split.factor(&p, &v).unwrap().solve_in_place(&mut xs);
        let mut xw = b.clone();
        whole.factor(&p, &v).unwrap().solve_in_place(&mut xw);
        let err = residual(&p, &v, &xs, &b);
        assert!(err < 1e-10, "{err}");
        let dev = max_dev(&xs, &xw);
        assert!(dev < 1e-10, "{dev}");
        let mut x32 = b.clone();
        split.factor_in::<f32>(&p, &v).unwrap().solve_in_place(&mut x32);
        let err = residual(&p, &v, &x32, &b);
        assert!(err < 1e-3 && err > 1e-12, "{err}");
        // The two-thread product equals the sequential one up to the order of two sums.
        let (mut y1, mut y2) = (vec![0.0; n], vec![0.0; n]);
        p.mul_vec(&v, &b, &mut y1);
        p.mul_vec_halves(&v, &b, &mut y2);
        assert!(y1.iter().zip(&y2).all(|(a, c)| (a - c).abs() <= 1e-12 * a.abs().max(1.0)));
        // Refactoring reuses the buffers and gives the same solution.
        let mut f = split.factor(&p, &v).unwrap();
        split.refactor(&p, &v, &mut f).unwrap();
        let mut xr = b.clone();
        f.solve_in_place(&mut xr);
        assert_eq!(xr, xs);
        // Indefinite: refused.
        let mut bad = v.clone();
        bad[p.slot(sep[3], sep[3])] = -50.0;
        assert!(matches!(split.factor(&p, &bad), Err(SolveError::NotPositiveDefinite { .. })));
        // Two disconnected halves (no separator): the same solution as one factorization.
        let cut_edges: Vec<(usize, usize)> =
            edges.iter().copied().filter(|&(a, c)| a % m != mid && c % m != mid).collect();
        let (p2, v2) = laplacian(n, &cut_edges, 6.01);
        // Column by column (a wider band than row by row: faer's supernodal kernel).
        let by_col =
            |js: std::ops::Range<usize>| -> Vec<usize> { js.flat_map(|j| (0..m).map(move |i| id(i, j))).collect() };
        let zero_sep: Vec<usize> = by_col(0..mid).into_iter().chain(by_col(mid..m)).collect();
        let split0 = CholeskySolver::with_split_ordering(&p2, &zero_sep, [left.len(), n - left.len()]).unwrap();
        let mut x0 = b.clone();
        split0.factor(&p2, &v2).unwrap().solve_in_place(&mut x0);
        let mut xw = b.clone();
        CholeskySolver::with_ordering(&p2, Some(&zero_sep)).unwrap().factor(&p2, &v2).unwrap().solve_in_place(&mut xw);
        let dev = max_dev(&x0, &xw);
        assert!(dev < 1e-10, "{dev}");
        // Parts that touch each other: refused at the analysis.
        let wrong: Vec<usize> = left.iter().chain(&sep).chain(&right).copied().collect();
        assert!(CholeskySolver::with_split_ordering(&p, &wrong, [left.len(), sep.len()]).is_err());
    }
}
