//! Singularity relaxation (paper §6.2.2, inspired by Lyon, Campen & Kobbelt 2021): combine
//! nearby singularities — a valence-3/valence-5 pair (+1/−1 quarter turns) cancels, two
//! valence-5 (−1, −1) merge into one valence-6 (−2) — when the field stays smooth.
//!
//! Index is moved along a primal edge path u0 → um by adding +1 to the period jump of every dual
//! edge crossing the path, oriented from the path's left face to its right face (ALGORITHMS.md
//! §5): u0 gains +¼, um loses ¼, inner path vertices are unchanged. With the jumps fixed, the
//! angles are re-solved with the factored Eq. 7 system of the pass ([`crate::smoothing`]),
//! keeping its hard constraints (so anisotropic faces keep their directions exactly), and the
//! move is accepted when Eq. 7's energy does not rise by more than `merge_tolerance`: a merge
//! trades two singularities for one, a cancellation removes two, at some cost in smoothness.
//! (Cancellations used to be required to lower the energy; a close valence-3/valence-5 pair
//! that survived that rule cut the layout into slivers, so they now get the same allowance —
//! on the test models this halves the final singularities, e.g. bunny 52 → 31.)
//!
//! Candidates are pairs within `radius` (geodesic along edges, boundary avoided), tried
//! shortest first; rounds repeat until nothing changes. Deterministic.

use crate::cross::CrossField;
use crate::smoothing::{AngleSolver, Smoother};
use clothcast_mesh::util::MinCost;
use clothcast_mesh::{EdgeData, FaceData, HalfedgeId, Mesh, VertexId};
use std::collections::BinaryHeap;

/// Options of the relaxation.
#[derive(Clone, Copy, Debug)]
pub struct RelaxOptions {
    /// Largest geodesic distance (metres) between two singularities combined.
    pub radius: f64,
    /// Largest rise of Eq. 7's energy accepted for a merge or a cancellation.
    pub merge_tolerance: f64,
}

/// What the relaxation did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RelaxReport {
    /// Pairs of valence-5 singularities merged into one valence-6.
    pub merged: usize,
    /// Valence-3/valence-5 pairs cancelled.
    pub cancelled: usize,
}

/// Shortest edge paths from `src` to every interior vertex within `radius` (boundary vertices
/// excluded): for each reached vertex, (distance, halfedge by which it was reached).
fn dijkstra(mesh: &Mesh, src: VertexId, radius: f64) -> Vec<(VertexId, f64, Vec<HalfedgeId>)> {
    let n = mesh.n_vertices();
    let mut dist = vec![f64::INFINITY; n];
    let mut via: Vec<Option<HalfedgeId>> = vec![None; n];
    let mut heap = BinaryHeap::new();
    dist[src.idx()] = 0.0;
    heap.push(MinCost(0.0, src.0));
    let mut reached = Vec::new();
    while let Some(MinCost(d, v)) = heap.pop() {
        let v = VertexId(v);
        if d > dist[v.idx()] {
            continue;
        }
        reached.push(v);
        for h in mesh.outgoing(v) {
            if mesh.is_boundary_halfedge(h) {
                continue;
            }
            let w = mesh.head(h);
            if mesh.is_boundary_vertex(w) {
                continue;
            }
            let nd = d + mesh.vector(h).norm();
            if nd <= radius && nd < dist[w.idx()] {
                dist[w.idx()] = nd;
                via[w.idx()] = Some(h);
                heap.push(MinCost(nd, w.0));
            }
        }
    }
    reached
        .into_iter()
        .filter(|&v| v != src)
        .map(|v| {
            let mut path = Vec::new();
            let mut cur = v;
            while let Some(h) = via[cur.idx()] {
                path.push(h);
                cur = mesh.tail(h);
            }
            path.reverse();
            (v, dist[v.idx()], path)
        })
        .collect()
}

/// Add +1 to the jump of every dual edge crossing the path (left face → right face).
fn shift_along(mesh: &Mesh, jumps: &mut EdgeData<i32>, path: &[HalfedgeId]) {
    for &h in path {
        let e = mesh.edge(h);
        if mesh.face(mesh.edge_halfedge(e)) == mesh.face(h) {
            jumps[e] += 1;
        } else {
            jumps[e] -= 1;
        }
    }
}

/// Relax the singularities of `field` (the result of the pass set up in `smoother`).
pub fn relax(
    mesh: &Mesh,
    rho: &EdgeData<f64>,
    smoother: &Smoother<'_>,
    solver: &AngleSolver,
    targets: &FaceData<f64>,
    field: &mut CrossField,
    opts: &RelaxOptions,
) -> RelaxReport {
    let mut report = RelaxReport::default();
    let energy = |f: &CrossField| {
        let (s, a) = smoother.energy(f, targets);
        s + a
    };
    let mut e_cur = energy(field);
    for _round in 0..10 {
        let mut index = field.indices(mesh, rho);
        let sing: Vec<VertexId> = mesh.vertices().filter(|&v| index[v] == 1 || index[v] == -1).collect();
        // (length, from, to, path): cancellations go from the −1 to the +1.
        let mut cands: Vec<(f64, VertexId, VertexId, Vec<HalfedgeId>)> = Vec::new();
        for &s in &sing {
            if index[s] != -1 {
                continue;
            }
            for (t, d, path) in dijkstra(mesh, s, opts.radius) {
                let kind_ok = index[t] == 1 || (index[t] == -1 && s < t);
                if kind_ok {
                    cands.push((d, s, t, path));
                }
            }
        }
        cands.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut changed = false;
        for (_, s, t, path) in cands {
            let (is, it) = (index[s], index[t]);
            let cancel = is == -1 && it == 1;
            let merge = is == -1 && it == -1;
            if !(cancel || merge) {
                continue;
            }
            let mut trial = field.clone();
            shift_along(mesh, &mut trial.jumps, &path);
            trial.theta = solver.solve(smoother, &trial.jumps, targets, &field.theta);
            let e_new = energy(&trial);
            let tol = 1e-12 * e_cur.abs();
            let ok = if cancel {
                e_new <= e_cur + tol.max(opts.merge_tolerance)
            } else {
                e_new <= e_cur + opts.merge_tolerance
            };
            if ok {
                *field = trial;
                e_cur = e_new;
                index[s] += 1;
                index[t] -= 1;
                if cancel {
                    report.cancelled += 1;
                } else {
                    report.merged += 1;
                }
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cross::connection;
    use clothcast_mesh::shapes;

    #[test]
    fn shifting_jumps_moves_index_between_path_ends() {
        let m = shapes::icosphere(3, 1.0);
        let rho = connection(&m);
        let f = CrossField::from_angles(&m, &rho, FaceData::filled(m.n_faces(), 0.3));
        let before = f.indices(&m, &rho);
        let (u0, paths) = (VertexId(5), dijkstra(&m, VertexId(5), 0.8));
        let (um, _, path) = paths.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap().clone();
        let mut g = f.clone();
        shift_along(&m, &mut g.jumps, &path);
        let after = g.indices(&m, &rho);
        for v in m.vertices() {
            let d = after[v] - before[v];
            let expect = if v == u0 {
                1
            } else if v == um {
                -1
            } else {
                0
            };
            assert_eq!(d, expect, "vertex {v}");
        }
    }
}
