//! Small shared utilities: union–find, a seeded RNG, edge keys, a min-heap entry, grouping by
//! key into compressed rows.

/// Disjoint-set forest with path halving and union by size.
#[derive(Clone, Debug)]
pub struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    /// `n` singletons.
    pub fn new(n: usize) -> Self {
        Self { parent: (0..n as u32).collect(), size: vec![1; n] }
    }

    /// Representative of `x`'s set.
    pub fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = self.parent[x as usize];
        }
        x
    }

    /// Merge the sets of `a` and `b`; returns true if they were different.
    pub fn union(&mut self, a: u32, b: u32) -> bool {
        let (mut ra, mut rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        if self.size[ra as usize] < self.size[rb as usize] {
            std::mem::swap(&mut ra, &mut rb);
        }
        self.parent[rb as usize] = ra;
        self.size[ra as usize] += self.size[rb as usize];
        true
    }

    /// Dense labels `0..k` for the sets, numbered in order of first appearance of their
    /// members (deterministic), plus `k`.
    pub fn labels(&mut self) -> (Vec<u32>, usize) {
        let n = self.parent.len();
        let mut label_of_root = vec![u32::MAX; n];
        let mut labels = vec![0u32; n];
        let mut k = 0u32;
        for i in 0..n as u32 {
            let r = self.find(i) as usize;
            if label_of_root[r] == u32::MAX {
                label_of_root[r] = k;
                k += 1;
            }
            labels[i as usize] = label_of_root[r];
        }
        (labels, k as usize)
    }
}

/// A priority-queue entry that makes [`std::collections::BinaryHeap`] a min-heap on a cost:
/// the smallest cost pops first, ties by the smaller id, so that searches are deterministic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MinCost(pub f64, pub u32);

impl Eq for MinCost {}

impl PartialOrd for MinCost {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for MinCost {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}

/// Key of the undirected edge {a, b}.
#[inline]
pub fn edge_key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    ((lo as u64) << 32) | hi as u64
}

/// SplitMix64: a tiny, fully specified generator so that `--seed` reproduces results across
/// platforms and dependency versions (crate RNGs do not promise value stability).
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// Seeded generator.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Uniform integer in `0..n` (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }
    /// Fisher–Yates shuffle.
    pub fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.below(i + 1);
            v.swap(i, j);
        }
    }
}

/// Values grouped by key into compressed rows: `(start, values)` with the values of key `k` at
/// `values[start[k]..start[k + 1]]`, each group in the order `items` yields them (a counting
/// sort: two passes over `items`, which must yield the same sequence both times).
///
/// # Panics
/// If a key is `n_keys` or more.
pub fn group_by_key<V: Copy + Default, I: Iterator<Item = (usize, V)>>(
    n_keys: usize,
    items: impl Fn() -> I,
) -> (Vec<usize>, Vec<V>) {
    let mut start = vec![0usize; n_keys + 1];
    for (k, _) in items() {
        start[k + 1] += 1;
    }
    for k in 0..n_keys {
        start[k + 1] += start[k];
    }
    let mut next = start[..n_keys].to_vec();
    let mut values = vec![V::default(); start[n_keys]];
    for (k, v) in items() {
        values[next[k]] = v;
        next[k] += 1;
    }
    (start, values)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grouping_keeps_each_keys_order() {
        let items = [(2, 'a'), (0, 'b'), (2, 'c'), (3, 'd'), (0, 'e')];
        let (start, values) = group_by_key(4, || items.iter().copied());
        assert_eq!(start, vec![0, 2, 2, 4, 5]);
        assert_eq!(values, vec!['b', 'e', 'a', 'c', 'd']);
    }

    #[test]
    fn union_find_labels() {
        let mut uf = UnionFind::new(5);
        uf.union(3, 4);
        uf.union(0, 2);
        let (labels, k) = uf.labels();
        assert_eq!(k, 3);
        assert_eq!(labels, vec![0, 1, 0, 2, 2]);
    }

    #[test]
    fn rng_is_stable() {
        let mut r = SplitMix64::new(1);
        // Reference values of SplitMix64 with seed 1.
        assert_eq!(r.next_u64(), 0x910A_2DEC_8902_5CC1);
        let x = r.next_f64();
        assert!((0.0..1.0).contains(&x));
    }
}
