//! Discrete differential geometry of a [`Mesh`]: areas, normals, corner angles, angle defect
//! (Gaussian curvature) and boundary turning (geodesic curvature), the cotan Laplacian and the
//! lumped mass matrix, local face frames, edge lengths, volumes.
//!
//! Conventions: the cotan Laplacian is the positive semi-definite one,
//! `L_ij = −½(cot α_ij + cot β_ij)`, `L_ii = −Σ_j L_ij`, so `L·1 = 0`; corner angles are stored
//! per halfedge (`angles[3f + k]` is the angle of face `f` at its corner `k`).

use crate::Vec3;
use crate::ids::*;
use crate::mesh::Mesh;
use faer::sparse::{SparseColMat, Triplet};
use std::f64::consts::PI;

/// An orthonormal frame attached to a face: `b1` along its first edge, `b2 = n × b1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceFrame {
    /// First tangent axis (unit vector along the edge from corner 0 to corner 1).
    pub b1: Vec3,
    /// Second tangent axis.
    pub b2: Vec3,
    /// Unit normal.
    pub n: Vec3,
}

impl FaceFrame {
    /// Coordinates of a 3D vector in the frame's tangent plane.
    #[inline]
    pub fn to_local(&self, v: &Vec3) -> [f64; 2] {
        [v.dot(&self.b1), v.dot(&self.b2)]
    }
    /// 3D vector from tangent-plane coordinates.
    #[inline]
    pub fn to_world(&self, x: [f64; 2]) -> Vec3 {
        self.b1 * x[0] + self.b2 * x[1]
    }
    /// The unit tangent vector at angle `theta` from `b1` towards `b2`.
    #[inline]
    pub fn direction(&self, theta: f64) -> Vec3 {
        self.b1 * theta.cos() + self.b2 * theta.sin()
    }
    /// Angle of a tangent vector, measured from `b1` towards `b2`.
    #[inline]
    pub fn angle_of(&self, v: &Vec3) -> f64 {
        v.dot(&self.b2).atan2(v.dot(&self.b1))
    }
}

/// Twice the area vector of a triangle: (p1 − p0) × (p2 − p0).
#[inline]
pub fn triangle_area_vector2(p: &[Vec3; 3]) -> Vec3 {
    (p[1] - p[0]).cross(&(p[2] - p[0]))
}

/// Interior angle at `a` of the triangle (a, b, c), robust for tiny angles.
#[inline]
pub fn angle_at(a: &Vec3, b: &Vec3, c: &Vec3) -> f64 {
    let (u, v) = (b - a, c - a);
    u.cross(&v).norm().atan2(u.dot(&v))
}

/// Cotangent of the angle at `a` of the triangle (a, b, c).
#[inline]
pub fn cot_at(a: &Vec3, b: &Vec3, c: &Vec3) -> f64 {
    let (u, v) = (b - a, c - a);
    u.dot(&v) / u.cross(&v).norm()
}

impl Mesh {
    /// Area of a face.
    pub fn face_area(&self, f: FaceId) -> f64 {
        0.5 * triangle_area_vector2(&self.face_positions(f)).norm()
    }
    /// Areas of all faces.
    pub fn face_areas(&self) -> FaceData<f64> {
        self.face_ids().map(|f| self.face_area(f)).collect()
    }
    /// Total surface area.
    pub fn total_area(&self) -> f64 {
        self.face_ids().map(|f| self.face_area(f)).sum()
    }
    /// Unit normal of a face (right-hand rule over its corners).
    pub fn face_normal(&self, f: FaceId) -> Vec3 {
        triangle_area_vector2(&self.face_positions(f)).normalize()
    }
    /// Unit normals of all faces.
    pub fn face_normals(&self) -> FaceData<Vec3> {
        self.face_ids().map(|f| self.face_normal(f)).collect()
    }
    /// Area-weighted vertex normals (unit).
    pub fn vertex_normals(&self) -> VertexData<Vec3> {
        let mut n = VertexData::filled(self.n_vertices(), Vec3::zeros());
        for f in self.face_ids() {
            let a = triangle_area_vector2(&self.face_positions(f));
            for v in self.face_vertices(f) {
                n[v] += a;
            }
        }
        n.iter_mut().for_each(|x| *x = x.normalize());
        n
    }
    /// Centroid of a face.
    pub fn face_centroid(&self, f: FaceId) -> Vec3 {
        let p = self.face_positions(f);
        (p[0] + p[1] + p[2]) / 3.0
    }
    /// Local frame of a face (b1 along corner 0 → 1).
    pub fn face_frame(&self, f: FaceId) -> FaceFrame {
        let p = self.face_positions(f);
        let n = triangle_area_vector2(&p).normalize();
        let b1 = (p[1] - p[0]).normalize();
        FaceFrame { b1, b2: n.cross(&b1), n }
    }
    /// Frames of all faces.
    pub fn face_frames(&self) -> FaceData<FaceFrame> {
        self.face_ids().map(|f| self.face_frame(f)).collect()
    }
    /// Corner angles, indexed by halfedge (`3f + k` is the angle at corner `k` of `f`).
    pub fn corner_angles(&self) -> HalfedgeData<f64> {
        use rayon::prelude::*;
        // Per face, in parallel (each angle is computed alone: the values do not depend on
        // the threads); the layout measures its patches' corners with these many times.
        let mut out = vec![0.0; 3 * self.n_faces()];
        out.par_chunks_mut(3).enumerate().for_each(|(f, a)| {
            let p = self.face_positions(FaceId::new(f));
            for k in 0..3 {
                a[k] = angle_at(&p[k], &p[(k + 1) % 3], &p[(k + 2) % 3]);
            }
        });
        HalfedgeData::from_vec(out)
    }
    /// Sum of corner angles at each vertex.
    pub fn angle_sums(&self) -> VertexData<f64> {
        self.angle_sums_of(&self.corner_angles())
    }
    /// Sum at each vertex of the given corner angles (those of [`Mesh::corner_angles`]), for
    /// callers that need both.
    pub fn angle_sums_of(&self, angles: &HalfedgeData<f64>) -> VertexData<f64> {
        debug_assert_eq!(angles.len(), 3 * self.n_faces(), "one angle per corner of this mesh");
        let mut s = VertexData::filled(self.n_vertices(), 0.0);
        for (h, a) in angles.enumerate() {
            s[self.tail(h)] += a;
        }
        s
    }
    /// Angle defect 2π − Σθ at interior vertices (the integrated Gaussian curvature); 0 at
    /// boundary vertices (see [`Mesh::boundary_turning`]).
    pub fn angle_defects(&self) -> VertexData<f64> {
        let sums = self.angle_sums();
        self.vertices().map(|v| if self.is_boundary_vertex(v) { 0.0 } else { 2.0 * PI - sums[v] }).collect()
    }
    /// Turning angle π − Σθ at boundary vertices (the integrated geodesic curvature of the
    /// boundary); 0 at interior vertices. Gauss–Bonnet: Σ defect + Σ turning = 2πχ.
    pub fn boundary_turning(&self) -> VertexData<f64> {
        let sums = self.angle_sums();
        self.vertices().map(|v| if self.is_boundary_vertex(v) { PI - sums[v] } else { 0.0 }).collect()
    }
    /// Edge lengths.
    pub fn edge_lengths(&self) -> EdgeData<f64> {
        self.edges().map(|e| self.edge_length(e)).collect()
    }
    /// Mean edge length (0 for an empty mesh).
    pub fn mean_edge_length(&self) -> f64 {
        if self.n_edges() == 0 {
            return 0.0;
        }
        self.edges().map(|e| self.edge_length(e)).sum::<f64>() / self.n_edges() as f64
    }
    /// Smallest corner angle over the mesh, in radians.
    pub fn min_angle(&self) -> f64 {
        self.corner_angles().iter().copied().fold(f64::INFINITY, f64::min)
    }
    /// Cotan weight of each edge: ½(cot α + cot β) over its one or two opposite angles.
    pub fn cotan_weights(&self) -> EdgeData<f64> {
        let mut w = EdgeData::filled(self.n_edges(), 0.0);
        for f in self.face_ids() {
            let p = self.face_positions(f);
            for k in 0..3 {
                // Angle at corner k+2 is opposite the halfedge k.
                let h = self.face_halfedge(f, k);
                let o = (k + 2) % 3;
                w[self.edge(h)] += 0.5 * cot_at(&p[o], &p[k], &p[(k + 1) % 3]);
            }
        }
        w
    }
    /// The PSD cotan Laplacian (n × n, `L·1 = 0`), see the module docs.
    pub fn cotan_laplacian(&self) -> SparseColMat<usize, f64> {
        let w = self.cotan_weights();
        let mut trip = Vec::with_capacity(4 * self.n_edges());
        for e in self.edges() {
            let [a, b] = self.edge_vertices(e);
            let x = w[e];
            trip.push(Triplet::new(a.idx(), b.idx(), -x));
            trip.push(Triplet::new(b.idx(), a.idx(), -x));
            trip.push(Triplet::new(a.idx(), a.idx(), x));
            trip.push(Triplet::new(b.idx(), b.idx(), x));
        }
        SparseColMat::try_new_from_triplets(self.n_vertices(), self.n_vertices(), &trip).expect("valid triplets")
    }
    /// Lumped (barycentric) mass: one third of the area of each incident face.
    pub fn vertex_areas(&self) -> VertexData<f64> {
        let mut m = VertexData::filled(self.n_vertices(), 0.0);
        for f in self.face_ids() {
            let a = self.face_area(f) / 3.0;
            for v in self.face_vertices(f) {
                m[v] += a;
            }
        }
        m
    }
    /// Signed volume enclosed by the surface (positive when normals point outward). For open
    /// surfaces each boundary loop is closed by a fan from its centroid first, so the value is
    /// the volume of the capped surface.
    pub fn signed_volume(&self) -> f64 {
        let c = self.bbox().center();
        let tet = |a: Vec3, b: Vec3, d: Vec3| (a - c).dot(&(b - c).cross(&(d - c))) / 6.0;
        let mut vol: f64 = self
            .face_ids()
            .map(|f| {
                let p = self.face_positions(f);
                tet(p[0], p[1], p[2])
            })
            .sum();
        for [head, tail, centroid] in self.boundary_caps(self.positions()) {
            vol += tet(centroid, head, tail);
        }
        vol
    }

    /// The triangles that close every boundary loop, at `positions` (the mesh's own, or a
    /// deformed copy): a fan from the mean of the loop's vertices, each triangle
    /// [head, tail, mean] of a loop halfedge, run against the loop so that the closed surface
    /// is oriented as the mesh.
    pub fn boundary_caps<'a>(&'a self, positions: &'a VertexData<Vec3>) -> impl Iterator<Item = [Vec3; 3]> + 'a {
        self.boundary_loops().iter().flat_map(move |lp| {
            let centroid = lp.iter().map(|&h| positions[self.tail(h)]).sum::<Vec3>() / lp.len() as f64;
            lp.iter().map(move |&h| [positions[self.head(h)], positions[self.tail(h)], centroid])
        })
    }
}

/// Shortest edge path from `a` to `b` (Dijkstra on edge lengths) through vertices with `ok(v)`;
/// `b` itself need not be `ok`. Ties go to the smaller vertex id. Distances are kept sparse, so a
/// short search on a large mesh costs only what it visits.
pub fn shortest_edge_path(
    mesh: &Mesh,
    a: VertexId,
    b: VertexId,
    ok: &impl Fn(VertexId) -> bool,
) -> Option<Vec<VertexId>> {
    use crate::util::MinCost;
    let mut dist: std::collections::HashMap<VertexId, (f64, VertexId)> = std::collections::HashMap::new();
    let mut heap = std::collections::BinaryHeap::new();
    dist.insert(a, (0.0, a));
    heap.push(MinCost(0.0, a.0));
    while let Some(MinCost(d, v)) = heap.pop() {
        let v = VertexId(v);
        if v == b {
            let mut path = vec![b];
            let mut c = b;
            while c != a {
                c = dist[&c].1;
                path.push(c);
            }
            path.reverse();
            return Some(path);
        }
        if d > dist[&v].0 {
            continue;
        }
        for w in mesh.vertex_neighbors(v) {
            if w != b && !ok(w) {
                continue;
            }
            let nd = d + (mesh.position(w) - mesh.position(v)).norm();
            if dist.get(&w).is_none_or(|x| nd < x.0) {
                dist.insert(w, (nd, v));
                heap.push(MinCost(nd, w.0));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_geometry() {
        let m = crate::shapes::unit_square();
        assert!((m.total_area() - 1.0).abs() < 1e-15);
        assert!((m.face_normal(FaceId(0)) - Vec3::z()).norm() < 1e-15);
        let w = m.cotan_weights();
        // The diagonal has two opposite right angles: weight 0; the sides 45°: ½·cot 45° = ½.
        let diag = m
            .edges()
            .find(|&e| m.edge_vertices(e).contains(&VertexId(0)) && m.edge_vertices(e).contains(&VertexId(2)))
            .unwrap();
        assert!(w[diag].abs() < 1e-15);
        for e in m.edges().filter(|&e| e != diag) {
            assert!((w[e] - 0.5).abs() < 1e-12);
        }
        let t = m.boundary_turning();
        let total: f64 = t.iter().sum();
        assert!((total - 2.0 * PI).abs() < 1e-12);
        assert!((m.signed_volume()).abs() < 1e-15);
    }

    #[test]
    fn frames_are_orthonormal() {
        let m = crate::shapes::unit_square();
        for fr in m.face_frames().iter() {
            assert!((fr.b1.norm() - 1.0).abs() < 1e-15);
            assert!(fr.b1.dot(&fr.b2).abs() < 1e-15);
            assert!(fr.b2.dot(&fr.n).abs() < 1e-15);
            let v = Vec3::new(0.3, -0.2, 0.0);
            assert!((fr.to_world(fr.to_local(&v)) - v).norm() < 1e-15);
        }
    }
}
