//! Fill-reducing orderings for the sparse Cholesky of mesh systems: geometric nested
//! dissection with minimum-degree (AMD) leaves.
//!
//! Written here because `faer` (the factorization used) only ships AMD and no Rust crate
//! offers nested dissection without a C dependency (METIS). On large surface meshes nested
//! dissection gives less fill and fewer flops than AMD alone (CHOLMOD with METIS, measured when
//! the dependencies were chosen: about 28% less fill on a 90k-node system; this module on
//! kitten's 53k vertices: a 22% smaller factor than AMD's).
//!
//! The graph is split recursively by a plane normal to x, y or z, placed (among positions that
//! leave at least 30% of the nodes on each side) where the one-sided vertex separator is
//! smallest (ties: the most balanced); that separator is then refined by Fiduccia–Mattheyses
//! node moves (as METIS refines its separators), which shortens the jagged line a plane cuts
//! through a triangulation (kitten: factor 23.3M → 21.7M entries, one factorization about 9%
//! faster, medians of 7 alternating runs each, first version); the two halves are ordered
//! first, the separator last.
//! Below `leaf` nodes a part is ordered by AMD on its own subgraph. On a surface a plane meets
//! the mesh in curves, so separators have O(√n) vertices and the factor's fill is O(n log n).
//! Deterministic: sorts break ties by index.
//!
//! Complexity: O(n log² n) for the splits (a sort per axis per level; every cut position's
//! separator size from one sweep), the refinement's heap moves around each separator, plus the
//! leaves' AMD.

use crate::Vec3;
use crate::sparse::CholeskySolver;

/// Node order (a permutation: `order[k]` is the k-th node eliminated) for the graph with the
/// given undirected `edges` over nodes at `positions`.
pub fn nested_dissection(positions: &[Vec3], edges: &[(usize, usize)], leaf: usize) -> Vec<usize> {
    nested_dissection_with_top(positions, edges, leaf).0
}

/// [`nested_dissection`], and the sizes of the two halves of the top split (`order` is the
/// first half, then the second, then their separator), or None if the graph was not split.
pub fn nested_dissection_with_top(
    positions: &[Vec3],
    edges: &[(usize, usize)],
    leaf: usize,
) -> (Vec<usize>, Option<[usize; 2]>) {
    let n = positions.len();
    let graph = Graph::from_edges(n, edges);
    let mut scratch = Scratch::new(n);
    let nodes: Vec<usize> = (0..n).collect();
    let leaf = leaf.max(1);
    if n <= leaf {
        return (scratch.amd_order(&graph, &nodes), None);
    }
    let Some((a, b, sep)) = scratch.bisect(&graph, positions, &nodes) else {
        return (scratch.amd_order(&graph, &nodes), None);
    };
    let top = Some([a.len(), b.len()]);
    let order = dissect_halves(&graph, positions, leaf, &mut scratch, 0, a, b, sep);
    debug_assert_eq!(order.len(), n);
    (order, top)
}

/// Levels of the dissection whose two halves are ordered in parallel (each forked half gets
/// its own scratch; the order is the same for any thread count: A's, then B's, then the
/// separator). Kitten's 53k vertices: 0.20 → 0.11 s on two threads.
const PARALLEL_LEVELS: usize = 3;

/// Parts smaller than this are not forked (the fork's scratch would cost more than it saves).
const PARALLEL_MIN_NODES: usize = 4096;

/// The order of `nodes`: split, each half ordered recursively, the separator last.
fn dissect(g: &Graph, pos: &[Vec3], nodes: Vec<usize>, leaf: usize, sc: &mut Scratch, level: usize) -> Vec<usize> {
    if nodes.len() <= leaf {
        return sc.amd_order(g, &nodes);
    }
    match sc.bisect(g, pos, &nodes) {
        Some((a, b, sep)) => dissect_halves(g, pos, leaf, sc, level + 1, a, b, sep),
        None => sc.amd_order(g, &nodes),
    }
}

/// A's order, then B's, then the separator; the halves in parallel near the top.
#[allow(clippy::too_many_arguments)]
fn dissect_halves(
    g: &Graph,
    pos: &[Vec3],
    leaf: usize,
    sc: &mut Scratch,
    level: usize,
    a: Vec<usize>,
    b: Vec<usize>,
    sep: Vec<usize>,
) -> Vec<usize> {
    let (mut order, ob) = if level < PARALLEL_LEVELS && a.len().min(b.len()) >= PARALLEL_MIN_NODES {
        rayon::join(
            || dissect(g, pos, a, leaf, sc, level),
            || dissect(g, pos, b, leaf, &mut Scratch::new(pos.len()), level),
        )
    } else {
        let oa = dissect(g, pos, a, leaf, sc, level);
        (oa, dissect(g, pos, b, leaf, sc, level))
    };
    order.extend(ob);
    order.extend(sep);
    order
}

/// Per-node scratch of a dissection: which part a node is in (by a stamp, to avoid clearing)
/// and its rank or side. Only nodes of the part at hand are read, so a forked half can work
/// on its own copy.
struct Scratch {
    mark: Vec<usize>,
    rank: Vec<usize>,
    stamp: usize,
}

impl Scratch {
    fn new(n: usize) -> Self {
        Self { mark: vec![usize::MAX; n], rank: vec![0; n], stamp: 0 }
    }
    fn amd_order(&mut self, g: &Graph, nodes: &[usize]) -> Vec<usize> {
        amd_order(g, nodes, &mut self.mark, &mut self.rank, &mut self.stamp)
    }
    fn bisect(&mut self, g: &Graph, pos: &[Vec3], nodes: &[usize]) -> Option<(Vec<usize>, Vec<usize>, Vec<usize>)> {
        bisect(g, pos, nodes, &mut self.mark, &mut self.rank, &mut self.stamp)
    }
}

struct Graph {
    ptr: Vec<usize>,
    adj: Vec<usize>,
}

impl Graph {
    /// Compressed rows of the undirected graph on `n` nodes with the given edges (either
    /// direction), rows sorted; loops and repeated edges are dropped (the separator refinement
    /// counts neighbours).
    fn from_edges(n: usize, edges: &[(usize, usize)]) -> Self {
        let mut pairs: Vec<(usize, usize)> =
            edges.iter().filter(|(a, b)| a != b).flat_map(|&(a, b)| [(a, b), (b, a)]).collect();
        pairs.sort_unstable();
        pairs.dedup();
        let mut ptr = vec![0usize; n + 1];
        for &(a, _) in &pairs {
            ptr[a + 1] += 1;
        }
        for i in 0..n {
            ptr[i + 1] += ptr[i];
        }
        Self { ptr, adj: pairs.into_iter().map(|(_, b)| b).collect() }
    }

    fn neighbors(&self, v: usize) -> &[usize] {
        &self.adj[self.ptr[v]..self.ptr[v + 1]]
    }
}

/// Split `nodes` by a plane normal to x, y or z: (A, B, S) with no edge between A and B; the
/// plane's separator S is the nodes of B with a neighbour in A. Over the three axes and every
/// plane position that leaves at least [`BALANCE`] of the nodes on each side, the one with the
/// smallest separator (ties: the most balanced), refined by [`refine_separator`]. None when no
/// plane separates.
fn bisect(
    g: &Graph,
    pos: &[Vec3],
    nodes: &[usize],
    mark: &mut [usize],
    rank: &mut [usize],
    stamp: &mut usize,
) -> Option<(Vec<usize>, Vec<usize>, Vec<usize>)> {
    let m = nodes.len();
    let (k_lo, k_hi) = (((m as f64) * BALANCE).ceil() as usize, ((m as f64) * (1.0 - BALANCE)).floor() as usize);
    if k_lo == 0 || k_lo > k_hi {
        return None;
    }
    // The nodes of this part (stamped in `mark`), ranked along each axis in turn in `rank`.
    *stamp += 1;
    let s = *stamp;
    for &v in nodes {
        mark[v] = s;
    }
    // Per axis, the best cut: (separator size, imbalance |2k − m|, k) and the nodes sorted
    // along the axis.
    let mut cuts: Vec<((usize, usize, usize), Vec<usize>)> = Vec::new();
    // (Oblique planes, the cube's face and body diagonals, were tried too: no smaller factor
    // on kitten, at three times the cost.)
    for axis in 0..3 {
        let mut sorted = nodes.to_vec();
        sorted.sort_unstable_by(|&x, &y| pos[x][axis].total_cmp(&pos[y][axis]).then(x.cmp(&y)));
        for (r, &v) in sorted.iter().enumerate() {
            rank[v] = r;
        }
        // Node v of rank r is in the separator of cut k (A = ranks < k) iff its lowest-ranked
        // neighbour is below k ≤ r: a difference array over k gives every cut's size at once.
        let mut diff = vec![0i64; m + 2];
        for (r, &v) in sorted.iter().enumerate() {
            let low = g.neighbors(v).iter().filter(|&&u| mark[u] == s).map(|&u| rank[u]).min();
            if let Some(low) = low
                && low < r
            {
                diff[low + 1] += 1;
                diff[r + 1] -= 1;
            }
        }
        let mut size = 0i64;
        let mut best: Option<(usize, usize, usize)> = None;
        for (k, d) in diff.iter().enumerate().take(k_hi + 1) {
            size += d;
            let cut = (size as usize, (2 * k).abs_diff(m), k);
            if k >= k_lo && best.is_none_or(|b| (cut.0, cut.1) < (b.0, b.1)) {
                best = Some(cut);
            }
        }
        if let Some(b) = best {
            cuts.push((b, sorted));
        }
    }
    // The smallest cut (ties: the most balanced, then the first axis), refined.
    let ((_, _, k), sorted) = cuts.into_iter().min_by_key(|(c, _)| (c.0, c.1))?;
    let (lo, hi) = sorted.split_at(k);
    *stamp += 1;
    let sa = *stamp;
    for &v in lo {
        mark[v] = sa;
    }
    let (mut b, mut sep) = (Vec::new(), Vec::new());
    for &v in hi {
        if g.neighbors(v).iter().any(|&u| mark[u] == sa) {
            sep.push(v);
        } else {
            b.push(v);
        }
    }
    let mut a = lo.to_vec();
    refine_separator(g, &mut a, &mut b, &mut sep, mark, rank, stamp);
    if a.is_empty() || b.is_empty() {
        return None;
    }
    a.sort_unstable();
    b.sort_unstable();
    sep.sort_unstable();
    Some((a, b, sep))
}

/// Fiduccia–Mattheyses refinement of a vertex separator (Ashcraft & Liu 1998; the node
/// refinement METIS does on every level): moving a separator node `v` into A pulls its
/// neighbours in B into the separator, a gain of 1 − |N(v) ∩ B| (and symmetrically into B).
/// Each pass makes the best move (ties: into the side that was smaller when the move was
/// queued, then the lowest index) while no move takes a side below [`REFINE_BALANCE`] of the
/// nodes, also through non-improving moves (up to [`REFINE_STALL`] in a row), then rolls back
/// to the smallest separator seen; passes repeat while they shrink it. Keeps the invariant: no
/// edge between A and B.
fn refine_separator(
    g: &Graph,
    a: &mut Vec<usize>,
    b: &mut Vec<usize>,
    sep: &mut Vec<usize>,
    mark: &mut [usize],
    side: &mut [usize],
    stamp: &mut usize,
) {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;
    const A: usize = 0;
    const B: usize = 1;
    const S: usize = 2;
    let m = a.len() + b.len() + sep.len();
    let min_side = ((m as f64) * REFINE_BALANCE).ceil() as usize;
    *stamp += 1;
    let st = *stamp;
    for (list, k) in [(&*a, A), (&*b, B), (&*sep, S)] {
        for &v in list {
            mark[v] = st;
            side[v] = k;
        }
    }
    let count =
        |side: &[usize], v: usize, k: usize| g.neighbors(v).iter().filter(|&&u| mark[u] == st && side[u] == k).count();
    let mut sizes = [a.len(), b.len(), sep.len()];
    for _pass in 0..REFINE_PASSES {
        // Heap of (gain, into the smaller side when pushed, lowest index, target side); entries
        // are checked against the current gain when popped (stale ones skipped).
        let mut heap: BinaryHeap<(i64, bool, Reverse<usize>, usize)> = BinaryHeap::new();
        let push = |heap: &mut BinaryHeap<(i64, bool, Reverse<usize>, usize)>,
                    side: &[usize],
                    sizes: &[usize; 3],
                    v: usize| {
            for to in [A, B] {
                let other = 1 - to;
                let gain = 1 - count(side, v, other) as i64;
                heap.push((gain, sizes[to] < sizes[other], Reverse(v), to));
            }
        };
        let start_sep = sizes[S];
        let imbalance = |sz: &[usize; 3]| sz[A].abs_diff(sz[B]);
        let mut best = (sizes[S], imbalance(&sizes), 0usize);
        // Move log: (node, side it went to, nodes it pulled into the separator).
        let mut log: Vec<(usize, usize, Vec<usize>)> = Vec::new();
        let mut moved = std::collections::HashSet::new();
        // Seeds: the current separator (it changes from pass to pass).
        for &v in a.iter().chain(b.iter()).chain(sep.iter()) {
            if side[v] == S {
                push(&mut heap, side, &sizes, v);
            }
        }
        let mut stall = 0usize;
        while let Some((gain, _, Reverse(v), to)) = heap.pop() {
            if side[v] != S || moved.contains(&v) {
                continue;
            }
            let other = 1 - to;
            let pulled: Vec<usize> =
                g.neighbors(v).iter().copied().filter(|&u| mark[u] == st && side[u] == other).collect();
            if 1 - pulled.len() as i64 != gain {
                continue; // stale
            }
            if sizes[other] < pulled.len() + min_side {
                continue;
            }
            side[v] = to;
            for &u in &pulled {
                side[u] = S;
            }
            sizes[to] += 1;
            sizes[other] -= pulled.len();
            sizes[S] = sizes[S] + pulled.len() - 1;
            moved.insert(v);
            // Gains change for the separator nodes around v and the pulled nodes.
            for &u in pulled.iter().chain(std::iter::once(&v)) {
                for &w in g.neighbors(u) {
                    if mark[w] == st && side[w] == S && !moved.contains(&w) {
                        push(&mut heap, side, &sizes, w);
                    }
                }
            }
            for &u in &pulled {
                push(&mut heap, side, &sizes, u);
            }
            log.push((v, to, pulled));
            if (sizes[S], imbalance(&sizes)) < (best.0, best.1) {
                best = (sizes[S], imbalance(&sizes), log.len());
                stall = 0;
            } else {
                stall += 1;
                if stall > REFINE_STALL {
                    break;
                }
            }
        }
        // Roll back past the best point.
        while log.len() > best.2 {
            let (v, to, pulled) = log.pop().expect("nonempty");
            let other = 1 - to;
            for &u in &pulled {
                side[u] = other;
            }
            side[v] = S;
            sizes[to] -= 1;
            sizes[other] += pulled.len();
            sizes[S] = sizes[S] + 1 - pulled.len();
        }
        if sizes[S] >= start_sep {
            break;
        }
    }
    let all: Vec<usize> = a.iter().chain(b.iter()).chain(sep.iter()).copied().collect();
    a.clear();
    b.clear();
    sep.clear();
    for v in all {
        match side[v] {
            A => a.push(v),
            B => b.push(v),
            _ => sep.push(v),
        }
    }
}

/// Smallest share of a part's nodes on either side after separator refinement.
const REFINE_BALANCE: f64 = 0.25;
/// Refinement passes at most.
const REFINE_PASSES: usize = 8;
/// Non-improving moves in a row before a refinement pass stops.
const REFINE_STALL: usize = 64;

/// Smallest share of a part's nodes on either side of a dissecting plane.
const BALANCE: f64 = 0.3;

/// AMD order of the subgraph induced by `nodes` (their own order if AMD fails).
fn amd_order(g: &Graph, nodes: &[usize], mark: &mut [usize], local: &mut [usize], stamp: &mut usize) -> Vec<usize> {
    let m = nodes.len();
    if m <= 2 {
        return nodes.to_vec();
    }
    *stamp += 1;
    let s = *stamp;
    // Local index of each node (valid where `mark` has this stamp).
    for (i, &v) in nodes.iter().enumerate() {
        mark[v] = s;
        local[v] = i;
    }
    let (mark, local) = (&*mark, &*local);
    let edges = nodes
        .iter()
        .enumerate()
        .flat_map(|(i, &v)| g.neighbors(v).iter().filter(move |&&u| mark[u] == s).map(move |&u| (i, local[u])));
    match CholeskySolver::amd_order(m, edges) {
        Ok(order) => order.iter().map(|&k| nodes[k]).collect(),
        Err(_) => nodes.to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An nx × ny grid graph, rows `dy` apart, columns 1 apart: positions and edges.
    fn grid_graph(nx: usize, ny: usize, dy: f64) -> (Vec<Vec3>, Vec<(usize, usize)>) {
        let positions = (0..ny).flat_map(|j| (0..nx).map(move |i| Vec3::new(i as f64, dy * j as f64, 0.0))).collect();
        (positions, crate::sparse::tests::grid_edges(nx, ny, false))
    }

    #[test]
    fn orders_every_node_once_and_separates() {
        let (nx, ny) = (30, 30);
        let (positions, edges) = grid_graph(nx, ny, 1.0);
        let order = nested_dissection(&positions, &edges, 50);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..nx * ny).collect::<Vec<_>>());
        // The top-level separator, eliminated last, is as small as a grid line (30 nodes) and
        // splits the grid into two parts of at least a quarter each.
        let last: std::collections::HashSet<usize> = order[order.len() - nx..].iter().copied().collect();
        let g = Graph::from_edges(nx * ny, &edges);
        let mut comp = vec![usize::MAX; nx * ny];
        let mut sizes = Vec::new();
        for s in 0..nx * ny {
            if last.contains(&s) || comp[s] != usize::MAX {
                continue;
            }
            let (mut stack, mut size) = (vec![s], 0);
            comp[s] = sizes.len();
            while let Some(v) = stack.pop() {
                size += 1;
                for &u in g.neighbors(v) {
                    if !last.contains(&u) && comp[u] == usize::MAX {
                        comp[u] = sizes.len();
                        stack.push(u);
                    }
                }
            }
            sizes.push(size);
        }
        assert_eq!(sizes.len(), 2, "{sizes:?}");
        assert!(sizes.iter().all(|&k| 4 * k >= nx * ny - nx), "{sizes:?}");
        // Deterministic.
        assert_eq!(order, nested_dissection(&positions, &edges, 50));
    }

    /// The halves forked to two threads near the top give the order of one thread (each
    /// fork has its own scratch; the order is A's, B's, then the separator either way).
    #[test]
    fn parallel_dissection_is_the_order_of_one_thread() {
        // Large enough for the top halves to be forked (PARALLEL_MIN_NODES each).
        let (nx, ny) = (130, 100);
        let (positions, edges) = grid_graph(nx, ny, 0.9);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| nested_dissection_with_top(&positions, &edges, 64))
        };
        let (one, top) = run(1);
        let top = top.expect("split");
        assert!(top.iter().all(|&k| k >= PARALLEL_MIN_NODES), "{top:?}");
        for threads in [2, 3] {
            assert_eq!(run(threads), (one.clone(), Some(top)));
        }
        let mut seen = one;
        seen.sort_unstable();
        assert_eq!(seen, (0..nx * ny).collect::<Vec<_>>());
    }

    #[test]
    fn separator_refinement_straightens_a_jagged_separator() {
        let (nx, ny) = (30, 30);
        let (positions, edges) = grid_graph(nx, ny, 1.0);
        let n = positions.len();
        let g = Graph::from_edges(n, &edges);
        // A: the left part with a zigzag edge; S: the nodes of the rest next to A.
        let in_a = |v: usize| (v % nx) < 12 + 3 * ((v / nx) % 3);
        let mut a: Vec<usize> = (0..n).filter(|&v| in_a(v)).collect();
        let (mut b, mut sep): (Vec<usize>, Vec<usize>) =
            (0..n).filter(|&v| !in_a(v)).partition(|&v| !g.neighbors(v).iter().any(|&u| in_a(u)));
        let before = sep.len();
        assert!(before > ny, "{before}");
        let (mut mark, mut side, mut stamp) = (vec![usize::MAX; n], vec![0usize; n], 0usize);
        refine_separator(&g, &mut a, &mut b, &mut sep, &mut mark, &mut side, &mut stamp);
        // Smaller, down to a grid line's ny nodes, and still a separator of the same nodes.
        assert!(sep.len() < before && sep.len() >= ny, "{before} -> {}", sep.len());
        assert_eq!(sep.len(), ny);
        let mut all: Vec<usize> = a.iter().chain(&b).chain(&sep).copied().collect();
        all.sort_unstable();
        assert_eq!(all, (0..n).collect::<Vec<_>>());
        let side_of = |v: usize| {
            if a.contains(&v) {
                0
            } else if b.contains(&v) {
                1
            } else {
                2
            }
        };
        for &(x, y) in &edges {
            assert!(!matches!((side_of(x), side_of(y)), (0, 1) | (1, 0)), "edge {x}-{y} joins A and B");
        }
        assert!(a.len() >= n / 4 && b.len() >= n / 4);
    }

    #[test]
    fn factors_and_solves_a_block_system_in_its_order() {
        use crate::sparse::SymmetricPattern;
        // A 60 × 60 grid, 3 dofs per node: (graph Laplacian + 0.1 I) ⊗ I₃, through the
        // nested-dissection order expanded to the dofs, as the Newton solver uses it.
        let (nx, ny) = (60, 60);
        let (positions, edges) = grid_graph(nx, ny, 0.3);
        let n = 3 * nx * ny;
        let dof_edges: Vec<(usize, usize)> =
            edges.iter().flat_map(|&(a, b)| (0..3).map(move |c| (3 * a + c, 3 * b + c))).collect();
        let p = SymmetricPattern::from_entries(n, dof_edges.iter().copied());
        let mut v = vec![0.0; p.nnz()];
        for &(a, b) in &dof_edges {
            v[p.slot(a, b)] = -1.0;
            v[p.slot(a, a)] += 1.0;
            v[p.slot(b, b)] += 1.0;
        }
        for i in 0..n {
            v[p.slot(i, i)] += 0.1;
        }
        let order: Vec<usize> =
            nested_dissection(&positions, &edges, 64).iter().flat_map(|&k| (0..3).map(move |c| 3 * k + c)).collect();
        let nd = CholeskySolver::with_ordering(&p, Some(&order)).unwrap();
        let amd = CholeskySolver::new(&p).unwrap();
        assert!(
            nd.factor_len() < amd.factor_len() * 3 / 2,
            "nested dissection's factor {} against AMD's {}",
            nd.factor_len(),
            amd.factor_len()
        );
        let f = nd.factor(&p, &v).unwrap();
        let b: Vec<f64> = (0..n).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
        let mut x = b.clone();
        f.solve_in_place(&mut x);
        let mut ax = vec![0.0; n];
        p.mul_vec(&v, &x, &mut ax);
        let err = ax.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 1e-9, "residual {err}");
    }
}
