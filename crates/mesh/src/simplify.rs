//! Coarse versions of a mesh and the map from a mesh onto its coarse version.
//!
//! [`simplify`] collapses edges with meshoptimizer's quadric-error simplifier (the `meshopt`
//! crate): it keeps a subset of the original vertices in place, preserves the topology and,
//! with the border locked, every boundary loop. The result is validated like any input mesh,
//! so a collapse that would leave a non-manifold surface is refused as an error, never
//! passed on.
//!
//! [`ClosestPoint`] finds the closest point of a mesh's surface to a query point (a uniform
//! grid of face boxes searched ring by ring), to carry a field from a coarse mesh to the fine
//! one by barycentric interpolation. Written here because it is a hundred lines over the mesh
//! types; a BVH crate would need its own triangle representation and gain little at these
//! sizes (one query per fine vertex, a few cells each).

use crate::Vec3;
use crate::error::MeshError;
use crate::geometry::triangle_area_vector2;
use crate::ids::{FaceId, VertexId};
use crate::mesh::Mesh;
use crate::soup::{Aabb, TriSoup};

/// A simplified mesh and where its vertices come from.
#[derive(Clone, Debug)]
pub struct Simplified {
    /// The coarse mesh.
    pub mesh: Mesh,
    /// For each coarse vertex, the original vertex it is (same position).
    pub parent: Vec<VertexId>,
}

/// Simplify `mesh` towards `target_faces` faces, never moving or removing a vertex marked in
/// `locked` (one flag per vertex) nor any boundary vertex.
///
/// The simplifier may stop above the target (locked vertices, topology); the result has the
/// original vertices it kept in their original order.
///
/// # Errors
/// If the simplified surface is not a valid manifold mesh ([`MeshError::Invalid`]).
///
/// # Panics
/// If `locked` does not have one flag per vertex.
pub fn simplify(mesh: &Mesh, target_faces: usize, locked: &[bool]) -> Result<Simplified, MeshError> {
    assert_eq!(locked.len(), mesh.n_vertices(), "one lock flag per vertex");
    // Single precision about the centre (meshoptimizer reads f32 positions).
    let center = mesh.bbox().center();
    let positions: Vec<[f32; 3]> =
        mesh.positions().iter().map(|p| p - center).map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
    let indices: Vec<u32> = mesh.faces().iter().flat_map(|f| f.map(|v| v.0)).collect();
    // No error bound: the face count is the target (the error is relative to the extent).
    let out = meshopt::simplify_with_locks_decoder(
        &indices,
        &positions,
        locked,
        3 * target_faces,
        1.0,
        meshopt::SimplifyOptions::LockBorder,
        None,
    );
    let triangles = out.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let (soup, kept) =
        crate::repair::compact(&TriSoup::from_triangles(mesh.positions().as_slice().to_vec(), triangles));
    let coarse = Mesh::try_from_soup(&soup)?;
    let parent = kept.into_iter().map(VertexId).collect();
    Ok(Simplified { mesh: coarse, parent })
}

/// Closest-point queries on a mesh's faces.
pub struct ClosestPoint<'m> {
    mesh: &'m Mesh,
    origin: Vec3,
    cell: f64,
    dims: [usize; 3],
    /// Faces overlapping cell c: `faces[start[c]..start[c + 1]]`.
    start: Vec<usize>,
    faces: Vec<u32>,
}

/// Where a query point lands on the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestHit {
    /// The face.
    pub face: FaceId,
    /// Barycentric coordinates on its corners (non-negative, summing to 1).
    pub weights: [f64; 3],
    /// Distance from the query point.
    pub distance: f64,
}

impl<'m> ClosestPoint<'m> {
    /// Index the faces of `mesh` (a non-empty mesh).
    pub fn new(mesh: &'m Mesh) -> Self {
        let bbox = mesh.bbox();
        let extent = bbox.max - bbox.min;
        // About one face per cell on a surface: cells of twice the mean edge, made larger
        // until there are at most 4 cells per face (a long or sparse mesh, several far apart
        // components), so the grid always covers the box and its size is linear in the faces.
        let mut cell = (2.0 * mesh.mean_edge_length()).max(1e-9 * extent.norm()).max(f64::MIN_POSITIVE);
        let dims_of = |cell: f64| extent.map(|e| (e / cell).floor() + 1.0);
        let max_cells = 4.0 * mesh.n_faces() as f64 + 64.0;
        while dims_of(cell).product() > max_cells {
            cell *= 1.25;
        }
        let d = dims_of(cell);
        let dims = [d.x as usize, d.y as usize, d.z as usize];
        let mut this = Self { mesh, origin: bbox.min, cell, dims, start: Vec::new(), faces: Vec::new() };
        let n_cells = dims[0] * dims[1] * dims[2];
        let (start, faces) = crate::util::group_by_key(n_cells, || {
            let this = &this;
            mesh.face_ids().flat_map(move |f| {
                let b = Aabb::from_points(mesh.face_positions(f));
                let (lo, hi) = (this.cell_of(&b.min), this.cell_of(&b.max));
                (lo[2]..=hi[2]).flat_map(move |k| {
                    (lo[1]..=hi[1]).flat_map(move |j| (lo[0]..=hi[0]).map(move |i| (this.cell_index([i, j, k]), f.0)))
                })
            })
        });
        this.start = start;
        this.faces = faces;
        this
    }

    fn cell_of(&self, p: &Vec3) -> [usize; 3] {
        [0, 1, 2].map(|k| (((p[k] - self.origin[k]) / self.cell).floor().max(0.0) as usize).min(self.dims[k] - 1))
    }

    fn cell_index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// The closest point of the surface to `p` (among faces at equal distance, one chosen
    /// deterministically).
    ///
    /// Searches the cells in rings of growing Chebyshev radius around `p`'s cell, skipping
    /// cells farther than the best point found, until no cell of the next ring can be closer.
    pub fn query(&self, p: &Vec3) -> ClosestHit {
        self.query_among(p, |_| true)
    }

    /// The closest point of `p` on the faces that face the same way as `normal` (positive dot
    /// product with their normal), or on all faces if none does: what carries a field from one
    /// side of a thin wall to the same side of its coarse version, not to the opposite one.
    pub fn query_facing(&self, p: &Vec3, normal: &Vec3) -> ClosestHit {
        let hit = self.query_among(p, |f| triangle_area_vector2(&self.mesh.face_positions(f)).dot(normal) > 0.0);
        if hit.distance.is_finite() { hit } else { self.query(p) }
    }

    /// The closest point of `p` on the faces `accept` takes (distance ∞ if it takes none).
    fn query_among(&self, p: &Vec3, accept: impl Fn(FaceId) -> bool) -> ClosestHit {
        let c = self.cell_of(p);
        let mut best = ClosestHit { face: FaceId(0), weights: [1.0, 0.0, 0.0], distance: f64::INFINITY };
        for r in 0.. {
            let lo = c.map(|x| x.saturating_sub(r));
            let hi = [0, 1, 2].map(|k| (c[k] + r).min(self.dims[k] - 1));
            for k in lo[2]..=hi[2] {
                for j in lo[1]..=hi[1] {
                    // Only the shell of the ring (the inside was searched before): the whole
                    // row where j or k is on it, else its two ends.
                    let inner = k.abs_diff(c[2]) < r && j.abs_diff(c[1]) < r;
                    let mut visit = |i: usize| {
                        if self.box_distance(p, [i, j, k]) >= best.distance {
                            return;
                        }
                        let cell = self.cell_index([i, j, k]);
                        for &f in &self.faces[self.start[cell]..self.start[cell + 1]] {
                            let face = FaceId(f);
                            if !accept(face) {
                                continue;
                            }
                            let (w, q) = closest_on_triangle(p, &self.mesh.face_positions(face));
                            let d = (q - p).norm();
                            if d < best.distance || (d == best.distance && face.0 < best.face.0) {
                                best = ClosestHit { face, weights: w, distance: d };
                            }
                        }
                    };
                    if inner {
                        if c[0] >= r {
                            visit(c[0] - r);
                        }
                        if r > 0 && c[0] + r < self.dims[0] {
                            visit(c[0] + r);
                        }
                    } else {
                        (lo[0]..=hi[0]).for_each(&mut visit);
                    }
                }
            }
            // The next ring lies beyond the cube's faces that are not the grid's border.
            let mut reach = f64::INFINITY;
            for k in 0..3 {
                if c[k] > r {
                    reach = reach.min(p[k] - (self.origin[k] + (c[k] - r) as f64 * self.cell));
                }
                if c[k] + r + 1 < self.dims[k] {
                    reach = reach.min(self.origin[k] + (c[k] + r + 1) as f64 * self.cell - p[k]);
                }
            }
            if best.distance <= reach || reach == f64::INFINITY {
                break;
            }
        }
        best
    }

    /// Distance from `p` to the box of a cell.
    fn box_distance(&self, p: &Vec3, cell: [usize; 3]) -> f64 {
        let mut d2 = 0.0;
        for k in 0..3 {
            let lo = self.origin[k] + cell[k] as f64 * self.cell;
            let gap = (lo - p[k]).max(p[k] - (lo + self.cell)).max(0.0);
            d2 += gap * gap;
        }
        d2.sqrt()
    }
}

/// Barycentric weights and position of the point of triangle `t` closest to `p` (by the
/// Voronoi regions of its vertices, edges and face).
pub fn closest_on_triangle(p: &Vec3, t: &[Vec3; 3]) -> ([f64; 3], Vec3) {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ([1.0, 0.0, 0.0], a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return ([0.0, 1.0, 0.0], b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        // (d1 − d3 = |ab|² > 0 unless a = b: then the corner.)
        let v = if d1 - d3 > 0.0 { d1 / (d1 - d3) } else { 0.0 };
        return ([1.0 - v, v, 0.0], a + ab * v);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return ([0.0, 0.0, 1.0], c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = if d2 - d6 > 0.0 { d2 / (d2 - d6) } else { 0.0 };
        return ([1.0 - w, 0.0, w], a + ac * w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let den = (d4 - d3) + (d5 - d6);
        let w = if den > 0.0 { (d4 - d3) / den } else { 0.0 };
        return ([0.0, 1.0 - w, w], b + (c - b) * w);
    }
    let denom = va + vb + vc;
    if !(denom > 0.0) {
        // A degenerate triangle: its first corner.
        return ([1.0, 0.0, 0.0], a);
    }
    let (v, w) = (vb / denom, vc / denom);
    ([1.0 - v - w, v, w], a + ab * v + ac * w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    #[test]
    fn closest_point_on_a_triangle_matches_brute_force_sampling() {
        let t = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.2, 0.0), Vec3::new(0.3, 0.9, 0.4)];
        // One point in each Voronoi region: the face, the three corners, the three edges.
        let points = [
            (0.3, 0.3, 0.5),
            (-1.0, -1.0, 0.0),
            (2.0, 0.0, 0.0),
            (0.5, -0.5, 0.1),
            (0.0, 2.0, 1.0),
            (1.0, 1.0, 0.0),
            (-0.5, 0.6, 0.2),
        ];
        for &(x, y, z) in &points {
            let p = Vec3::new(x, y, z);
            let (w, q) = closest_on_triangle(&p, &t);
            assert!(w.iter().all(|&a| a >= 0.0) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            assert!((t[0] * w[0] + t[1] * w[1] + t[2] * w[2] - q).norm() < 1e-12);
            let mut best = f64::INFINITY;
            for i in 0..=200 {
                for j in 0..=(200 - i) {
                    let (u, v) = (i as f64 / 200.0, j as f64 / 200.0);
                    let s = t[0] * (1.0 - u - v) + t[1] * u + t[2] * v;
                    best = best.min((s - p).norm());
                }
            }
            let d = (q - p).norm();
            assert!(d <= best + 1e-12 && d >= best - 1e-2, "{p:?}: {d} vs sampled {best}");
        }
    }

    #[test]
    fn grid_query_equals_the_scan_over_all_faces() {
        // A uniform sphere, its non-uniform simplification (slivers, a locked fine cap), and two
        // far-apart spheres (a sparse box: the grid is coarsened to stay linear in the faces).
        let m = shapes::icosphere(3, 1.0);
        let locked: Vec<bool> = m.vertices().map(|v| m.position(v).z > 0.7).collect();
        let coarse = simplify(&m, 100, &locked).unwrap().mesh;
        let soup = m.to_soup();
        let n = soup.positions.len() as u32;
        let mut positions = soup.positions.clone();
        positions.extend(soup.positions.iter().map(|p| p + Vec3::new(1e4, 0.0, 0.0)));
        let mut triangles = soup.triangles.clone();
        triangles.extend(soup.triangles.iter().map(|t| t.map(|i| i + n)));
        let two = Mesh::try_new(positions, triangles).unwrap();
        for mesh in [&m, &coarse, &two] {
            let cp = ClosestPoint::new(mesh);
            assert!(cp.dims.iter().product::<usize>() <= 4 * mesh.n_faces() + 64, "{:?}", cp.dims);
            for k in 0..60 {
                let a = k as f64 * 0.7;
                let r = 0.3 + 0.05 * k as f64;
                let p = Vec3::new(r * a.cos() * (0.3 * a).sin(), r * a.sin(), r * (0.3 * a).cos());
                let got = cp.query(&p);
                let scan = mesh
                    .face_ids()
                    .map(|f| (closest_on_triangle(&p, &mesh.face_positions(f)).1 - p).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!((got.distance - scan).abs() < 1e-12, "{p:?}: {} vs {scan}", got.distance);
            }
        }
    }

    #[test]
    fn simplify_keeps_topology_locked_vertices_and_original_positions() {
        let m = shapes::icosphere(4, 1.0);
        let mut locked = vec![false; m.n_vertices()];
        for v in m.vertices() {
            if m.position(v).z > 0.9 {
                locked[v.idx()] = true;
            }
        }
        let s = simplify(&m, 500, &locked).unwrap();
        assert!(s.mesh.n_faces() < m.n_faces() / 4, "{} faces", s.mesh.n_faces());
        assert_eq!(s.mesh.euler_characteristic(), 2);
        assert_eq!(s.mesh.n_components(), 1);
        assert!(s.mesh.signed_volume() > 0.0);
        for (c, &p) in s.parent.iter().enumerate() {
            assert_eq!(s.mesh.position(VertexId(c as u32)), m.position(p));
        }
        assert!(s.parent.windows(2).all(|w| w[0] < w[1]));
        let kept: std::collections::HashSet<_> = s.parent.iter().copied().collect();
        for v in m.vertices() {
            if locked[v.idx()] {
                assert!(kept.contains(&v), "locked vertex {v:?} removed");
            }
        }
    }

    #[test]
    fn simplify_keeps_boundary_loops_of_an_open_mesh() {
        let m = shapes::icosphere(4, 1.0);
        // Cut a cap off: the faces below z = 0.6.
        let faces: Vec<FaceId> = m.face_ids().filter(|&f| m.face_centroid(f).z < 0.6).collect();
        let open = crate::submesh::extract_submesh(&m, &faces).unwrap().mesh;
        let boundary: Vec<VertexId> = open.vertices().filter(|&v| open.is_boundary_vertex(v)).collect();
        let s = simplify(&open, 300, &vec![false; open.n_vertices()]).unwrap();
        assert_eq!(s.mesh.boundary_loops().len(), 1);
        let kept: std::collections::HashSet<_> = s.parent.iter().copied().collect();
        assert!(boundary.iter().all(|v| kept.contains(v)));
        assert!(s.mesh.n_faces() < open.n_faces() / 2);
    }
}
