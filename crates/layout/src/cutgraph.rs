//! Extra field-aligned cuts until every patch is a topological disk.
//!
//! Separatrices alone do not cut handles (genus > 0) or join several boundary loops, and a
//! surface without singularities (a torus with a perfect field) has none at all. For every
//! patch that is not a disk, on the patch cut open along the seams:
//! - several boundary loops: the cheapest path joining one loop to another (an annulus becomes
//!   a disk);
//! - one boundary loop (or none) and genus g > 0: the 2g generator loops of a tree–cotree
//!   decomposition (Eppstein 2003; Erickson & Whittlesey 2005), rooted on the boundary so each
//!   loop is a boundary-to-boundary cut, with the primal tree a shortest-path tree in the
//!   field-aligned metric so the cuts follow the field;
//! - a closed sphere (no seam at all): a slit between two far-apart vertices.
//!
//! Costs are those of separatrix tracing, `ℓ (1 + D (φ/φ_max)²)` with φ the edge's deviation from
//! the nearest arm of the field of its faces (not capped: a cut must exist).
//! The process repeats until every patch is a disk.
//!
//! Complexity: O(k · F log F) for k non-disk patches.

use crate::LayoutError;
use crate::patches::{Patches, patches, wedges};
use clothcast_mesh::submesh::extract_submesh;
use clothcast_mesh::util::MinCost;
use clothcast_mesh::{EdgeData, FaceData, FaceId, Mesh, Vec3, VertexId};
use std::collections::{BinaryHeap, VecDeque};

/// The mesh cut open along `seam`, and the original vertex of every cut vertex.
pub fn cut_open(mesh: &Mesh, seam: &EdgeData<bool>) -> (Mesh, Vec<VertexId>) {
    let (wedge, n) = wedges(mesh, seam);
    let mut original = vec![VertexId(0); n];
    let mut tris = Vec::with_capacity(mesh.n_faces());
    for f in mesh.face_ids() {
        let vs = mesh.face_vertices(f);
        let t = [0, 1, 2].map(|k| wedge[3 * f.idx() + k]);
        for k in 0..3 {
            original[t[k] as usize] = vs[k];
        }
        tris.push(t);
    }
    let positions = original.iter().map(|&v| mesh.position(v)).collect();
    let cut = Mesh::try_new(positions, tris).expect("cutting a valid mesh along edges keeps it valid");
    (cut, original)
}

/// Field-aligned cost of every edge of `m` given its faces' field directions.
fn edge_costs(m: &Mesh, dirs: &FaceData<Vec3>, drift: f64, phi_max: f64) -> EdgeData<f64> {
    m.edges()
        .map(|e| {
            let h = m.edge_halfedge(e);
            let d = m.vector(h);
            let dev = |f: FaceId| {
                let n = m.face_normal(f);
                let t = (d - n * n.dot(&d)).normalize();
                let a = dirs[f];
                let b = n.cross(&a);
                a.dot(&t).abs().max(b.dot(&t).abs()).clamp(0.0, 1.0).acos()
            };
            let phi = match m.edge_faces(e) {
                (a, Some(b)) => 0.5 * (dev(a) + dev(b)),
                (a, None) => dev(a),
            };
            d.norm() * (1.0 + drift * (phi / phi_max).powi(2))
        })
        .collect()
}

/// Shortest-path tree from the sources over `m`'s edges (boundary edges cost 100× so paths
/// stay inside): distances and the predecessor vertex of every vertex.
fn dijkstra(m: &Mesh, cost: &EdgeData<f64>, sources: &[VertexId]) -> (Vec<f64>, Vec<Option<VertexId>>) {
    let n = m.n_vertices();
    let mut dist = vec![f64::INFINITY; n];
    let mut pred = vec![None; n];
    let mut heap = BinaryHeap::new();
    for &s in sources {
        dist[s.idx()] = 0.0;
        heap.push(MinCost(0.0, s.0));
    }
    while let Some(MinCost(d, v)) = heap.pop() {
        let v = VertexId(v);
        if d > dist[v.idx()] {
            continue;
        }
        for h in m.outgoing(v) {
            let w = m.head(h);
            let e = m.edge(h);
            let c = if m.is_boundary_edge(e) { 100.0 * cost[e] } else { cost[e] };
            if d + c < dist[w.idx()] {
                dist[w.idx()] = d + c;
                pred[w.idx()] = Some(v);
                heap.push(MinCost(d + c, w.0));
            }
        }
        if m.is_boundary_vertex(v) {
            // The incoming boundary neighbour is not an outgoing head.
            let last = m.outgoing(v).last().expect("vertex has faces");
            let w = m.opposite_vertex(last);
            let e = m.edge(m.prev(last));
            let c = 100.0 * cost[e];
            if d + c < dist[w.idx()] {
                dist[w.idx()] = d + c;
                pred[w.idx()] = Some(v);
                heap.push(MinCost(d + c, w.0));
            }
        }
    }
    (dist, pred)
}

fn path_to_root(pred: &[Option<VertexId>], mut v: VertexId) -> Vec<VertexId> {
    let mut p = vec![v];
    while let Some(u) = pred[v.idx()] {
        p.push(u);
        v = u;
    }
    p
}

/// Cuts that make one non-disk patch (a mesh of its own) a disk, as vertex paths on it.
fn patch_cuts(m: &Mesh, cost: &EdgeData<f64>) -> Vec<Vec<VertexId>> {
    let loops = m.boundary_loops();
    if loops.len() >= 2 {
        let src: Vec<VertexId> = loops[0].iter().map(|&h| m.tail(h)).collect();
        let (dist, pred) = dijkstra(m, cost, &src);
        let target = loops[1..]
            .iter()
            .flat_map(|lp| lp.iter().map(|&h| m.tail(h)))
            .min_by(|a, b| dist[a.idx()].total_cmp(&dist[b.idx()]).then(a.cmp(b)));
        return target.map(|t| vec![path_to_root(&pred, t)]).unwrap_or_default();
    }
    let chi = m.euler_characteristic();
    if loops.is_empty() && chi == 2 {
        // Closed sphere: a slit between two far-apart vertices.
        let (d0, _) = dijkstra(m, cost, &[VertexId(0)]);
        let far = m.vertices().max_by(|a, b| d0[a.idx()].total_cmp(&d0[b.idx()])).unwrap_or(VertexId(0));
        let (d1, pred) = dijkstra(m, cost, &[far]);
        let other = m.vertices().max_by(|a, b| d1[a.idx()].total_cmp(&d1[b.idx()])).unwrap_or(far);
        let mut slit = path_to_root(&pred, other);
        if slit.len() == 2 {
            // One edge is no slit the cut-open mesh can hold (a tetrahedron: every two vertices
            // are neighbours): two.
            if let Some(w) = m.outgoing(other).map(|h| m.head(h)).find(|&w| w != far) {
                slit.insert(0, w);
            }
        }
        return vec![slit];
    }
    // Genus > 0: tree–cotree generators, rooted on the boundary when there is one.
    let root = loops.first().map(|lp| m.tail(lp[0])).unwrap_or(VertexId(0));
    let (_, pred) = dijkstra(m, cost, &[root]);
    let mut in_tree = EdgeData::filled(m.n_edges(), false);
    for v in m.vertices() {
        if let Some(u) = pred[v.idx()]
            && let Some(e) = crate::patches::edge_between(m, u, v)
        {
            in_tree[e] = true;
        }
    }
    // Dual spanning tree over faces plus one virtual cap face (index nf) for the boundary.
    let nf = m.n_faces();
    let mut dual_seen = vec![false; nf + 1];
    let mut in_cotree = EdgeData::filled(m.n_edges(), false);
    let mut queue = VecDeque::new();
    let start = if loops.is_empty() { 0 } else { nf };
    dual_seen[start] = true;
    queue.push_back(start);
    // Boundary edges connect their face to the cap.
    let cap_edges: Vec<clothcast_mesh::EdgeId> = m.edges().filter(|&e| m.is_boundary_edge(e)).collect();
    while let Some(node) = queue.pop_front() {
        let neighbours: Vec<(usize, clothcast_mesh::EdgeId)> = if node == nf {
            cap_edges.iter().map(|&e| (m.edge_faces(e).0.idx(), e)).collect()
        } else {
            (0..3)
                .map(|k| {
                    let h = m.face_halfedge(FaceId::new(node), k);
                    let e = m.edge(h);
                    (m.twin(h).map(|t| m.face(t).idx()).unwrap_or(nf), e)
                })
                .collect()
        };
        for (g, e) in neighbours {
            if in_tree[e] || dual_seen[g] {
                continue;
            }
            dual_seen[g] = true;
            in_cotree[e] = true;
            queue.push_back(g);
        }
    }
    let mut cuts = Vec::new();
    for e in m.edges() {
        if in_tree[e] || in_cotree[e] || m.is_boundary_edge(e) {
            continue;
        }
        let [u, v] = m.edge_vertices(e);
        let mut lp = path_to_root(&pred, u);
        lp.reverse();
        lp.extend(path_to_root(&pred, v));
        cuts.push(lp);
    }
    cuts
}

/// Remove every seam edge that is a slit of its own: both its ends interior vertices with no
/// other seam edge. Such a one-edge slit opens the patch (it counts as a hole: an annulus), but
/// the cut-open mesh cannot hold it (its two sides share both end vertices, so they are one
/// edge again), and as a seam it is a buttonhole, not a piece boundary. A separatrix that found
/// nothing after one edge leaves one (a 436-face cylinder: "patch 0 is not a disk"). Returns how
/// many were removed.
pub fn drop_lone_seam_edges(mesh: &Mesh, seam: &mut EdgeData<bool>) -> usize {
    let mut cuts_at = vec![0u32; mesh.n_vertices()];
    for e in mesh.edges() {
        if seam[e] || mesh.is_boundary_edge(e) {
            for v in mesh.edge_vertices(e) {
                cuts_at[v.idx()] += 1;
            }
        }
    }
    let lone: Vec<_> = mesh
        .edges()
        .filter(|&e| {
            seam[e] && !mesh.is_boundary_edge(e) && mesh.edge_vertices(e).iter().all(|v| cuts_at[v.idx()] == 1)
        })
        .collect();
    for &e in &lone {
        seam[e] = false;
    }
    lone.len()
}

/// Join every `fixed` vertex (a singularity) that has no seam edge and is not on the boundary
/// to the nearest seam or boundary vertex by a field-aligned shortest path; returns how many
/// were joined.
pub fn attach_isolated(
    mesh: &Mesh,
    dirs: &FaceData<Vec3>,
    seam: &mut EdgeData<bool>,
    fixed: &clothcast_mesh::VertexData<bool>,
    drift: f64,
    phi_max: f64,
) -> usize {
    let cost = edge_costs(mesh, dirs, drift, phi_max);
    let mut joined = 0;
    for v in mesh.vertices() {
        if !fixed[v] || mesh.is_boundary_vertex(v) {
            continue;
        }
        // (A boundary vertex counts whatever its edges; for the others the outgoing halfedges
        // cover every edge.)
        let on_seam = |u: VertexId| mesh.is_boundary_vertex(u) || mesh.outgoing(u).any(|h| seam[mesh.edge(h)]);
        if on_seam(v) {
            continue;
        }
        let (dist, pred) = dijkstra(mesh, &cost, &[v]);
        let target = mesh
            .vertices()
            .filter(|&u| u != v && on_seam(u) && dist[u.idx()].is_finite())
            .min_by(|a, b| dist[a.idx()].total_cmp(&dist[b.idx()]).then(a.cmp(b)));
        let Some(t) = target else { continue };
        let path = path_to_root(&pred, t);
        for w in path.windows(2) {
            if let Some(e) = crate::patches::edge_between(mesh, w[0], w[1]) {
                seam[e] = true;
            }
        }
        joined += 1;
    }
    joined
}

/// Add cuts until every patch is a disk; returns the extra cut paths (vertex paths on `mesh`)
/// and the final patches.
pub fn make_disks(
    mesh: &Mesh,
    dirs: &FaceData<Vec3>,
    seam: &mut EdgeData<bool>,
    drift: f64,
    phi_max: f64,
) -> Result<(Vec<Vec<VertexId>>, Patches), LayoutError> {
    let mut added: Vec<Vec<VertexId>> = Vec::new();
    drop_lone_seam_edges(mesh, seam);
    for _ in 0..10_000 {
        let p = patches(mesh, seam);
        let Some(bad) = (0..p.n).find(|&i| !p.is_disk(i)) else {
            return Ok((added, p));
        };
        let (cut, original) = cut_open(mesh, seam);
        // The cut mesh's faces are the mesh's faces, in order.
        let faces: Vec<FaceId> = mesh.face_ids().filter(|&f| p.patch_of_face[f] as usize == bad).collect();
        let sub = extract_submesh(&cut, &faces)?;
        let sub_dirs: FaceData<Vec3> = sub.face_to_parent.map(|&f| dirs[f]);
        let cost = edge_costs(&sub.mesh, &sub_dirs, drift, phi_max);
        let cuts = patch_cuts(&sub.mesh, &cost);
        if cuts.is_empty() {
            return Err(LayoutError::NotADisk { patch: bad, euler: p.euler[bad], boundary_loops: p.loops[bad] });
        }
        let mut changed = false;
        for c in cuts {
            let path: Vec<VertexId> = c.iter().map(|&v| original[sub.vertex_to_parent[v].idx()]).collect();
            for w in path.windows(2) {
                if let Some(e) = crate::patches::edge_between(mesh, w[0], w[1]) {
                    changed |= !seam[e];
                    seam[e] = true;
                }
            }
            added.push(path);
        }
        if !changed {
            return Err(LayoutError::NotADisk { patch: bad, euler: p.euler[bad], boundary_loops: p.loops[bad] });
        }
    }
    let p = patches(mesh, seam);
    let bad = (0..p.n).find(|&i| !p.is_disk(i)).unwrap_or(0);
    Err(LayoutError::NotADisk { patch: bad, euler: p.euler[bad], boundary_loops: p.loops[bad] })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;

    fn constant_dirs(m: &Mesh) -> FaceData<Vec3> {
        m.face_ids().map(|f| m.face_frame(f).b1).collect()
    }

    #[test]
    fn torus_without_seams_becomes_a_disk() {
        let m = shapes::torus(2.0, 0.7, 24, 12);
        let mut seam = EdgeData::filled(m.n_edges(), false);
        let (cuts, p) = make_disks(&m, &constant_dirs(&m), &mut seam, 10.0, std::f64::consts::FRAC_PI_4).unwrap();
        assert!(!cuts.is_empty());
        assert_eq!(p.n, 1);
        assert!(p.is_disk(0), "χ {} loops {}", p.euler[0], p.loops[0]);
    }

    /// Every patch, cut open along the seams as the flattening cuts it, is a disk.
    fn assert_cut_open_disks(m: &Mesh, seam: &EdgeData<bool>) {
        let p = patches(m, seam);
        let (cut, _) = cut_open(m, seam);
        for i in 0..p.n {
            assert!(p.is_disk(i), "patch {i}: χ {} loops {}", p.euler[i], p.loops[i]);
            let faces: Vec<FaceId> = m.face_ids().filter(|&f| p.patch_of_face[f] as usize == i).collect();
            let sub = extract_submesh(&cut, &faces).unwrap();
            assert_eq!(sub.mesh.euler_characteristic(), 1, "patch {i}");
            assert_eq!(sub.mesh.boundary_loops().len(), 1, "patch {i}");
        }
    }

    #[test]
    fn a_one_edge_slit_is_no_seam() {
        // A lone seam edge and a three-edge slit far from it: the patch counts as an annulus,
        // but cut open the lone edge closes again (its sides share both ends), so no cut joining
        // the two was found ("patch 0 is not a disk"). The lone edge is dropped.
        let s = shapes::icosphere(2, 1.0);
        let mut seam = EdgeData::filled(s.n_edges(), false);
        let lone = clothcast_mesh::EdgeId::new(0);
        seam[lone] = true;
        let a = s.position(s.edge_vertices(lone)[0]);
        let mut v =
            s.vertices().max_by(|x, y| (s.position(*x) - a).norm().total_cmp(&(s.position(*y) - a).norm())).unwrap();
        let mut slit = vec![v];
        for _ in 0..3 {
            let w = s.outgoing(v).map(|h| s.head(h)).find(|w| !slit.contains(w)).unwrap();
            seam[crate::patches::edge_between(&s, v, w).unwrap()] = true;
            slit.push(w);
            v = w;
        }
        let before = patches(&s, &seam);
        assert_eq!((before.euler[0], before.loops[0]), (0, 2));
        make_disks(&s, &constant_dirs(&s), &mut seam, 10.0, 0.8).unwrap();
        assert!(!seam[lone]);
        assert_cut_open_disks(&s, &seam);
        // A tetrahedron without seams: its far-apart vertices are neighbours, and the slit
        // opening it takes two edges.
        let t = Mesh::try_new(
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
            ],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        )
        .unwrap();
        let mut seam = EdgeData::filled(t.n_edges(), false);
        make_disks(&t, &constant_dirs(&t), &mut seam, 0.0, 0.8).unwrap();
        assert_eq!(seam.iter().filter(|&&c| c).count(), 2);
        assert_cut_open_disks(&t, &seam);
    }

    #[test]
    fn sphere_and_annulus_become_disks() {
        let s = shapes::icosphere(2, 1.0);
        let mut seam = EdgeData::filled(s.n_edges(), false);
        let (_, p) = make_disks(&s, &constant_dirs(&s), &mut seam, 10.0, 0.8).unwrap();
        assert!((0..p.n).all(|i| p.is_disk(i)));
        let c = shapes::cylinder(1.0, 2.0, 16, 6, false, false);
        let mut seam = EdgeData::filled(c.n_edges(), false);
        let (_, p) = make_disks(&c, &constant_dirs(&c), &mut seam, 10.0, 0.8).unwrap();
        assert!((0..p.n).all(|i| p.is_disk(i)));
    }
}
