//! Face-based 4-direction (cross) fields: an angle per face in its frame, connection angles
//! across edges, integer period jumps, and vertex singularity indices (ALGORITHMS.md §3–4;
//! Bommes, Zimmer & Kobbelt 2009, the vocabulary of Directional).
//!
//! Conventions:
//! - Face frame: `b1` along the face's first edge, `b2 = n × b1` ([`Mesh::face_frame`]).
//! - Every edge `e` has a first face `a` (of `edge_halfedge(e)`) and, if interior, a second face
//!   `b`. The connection `ρ_e` maps angles of frame `a` to frame `b`: unfolding about the shared
//!   edge keeps its direction ê, so `ρ_e = angle_b(ê) − angle_a(ê)` (wrapped to (−π, π]).
//! - The period jump `p_e` (from `a` to `b`) makes `θ_a + ρ_e + (π/2) p_e ≈ θ_b`; crossing the
//!   edge from `b` to `a` uses `−ρ_e`, `−p_e`.
//! - Vertex index in quarter turns (+1 = valence 3, −1 = valence 5, −2 = valence 6), from the
//!   faces around v counter-clockwise: `4·I(v) = 4·round((K(v) − Σρ)/2π) − Σp`, with K the angle
//!   defect. Because every edge's ρ and p enter its two endpoints with opposite signs, the
//!   indices of a closed surface always sum to 4χ.

use clothcast_mesh::{EdgeData, EdgeId, FaceData, FaceId, HalfedgeId, Mesh, Vec3, VertexData, VertexId};
use serde::Serialize;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Wrap an angle to (−π, π].
#[inline]
pub fn wrap(a: f64) -> f64 {
    let mut x = a % TAU;
    if x > PI {
        x -= TAU;
    } else if x <= -PI {
        x += TAU;
    }
    x
}

/// Connection angles of every interior edge (0 on boundary edges).
pub fn connection(mesh: &Mesh) -> EdgeData<f64> {
    let frames = mesh.face_frames();
    mesh.edges()
        .map(|e| {
            let h = mesh.edge_halfedge(e);
            let Some(t) = mesh.twin(h) else { return 0.0 };
            let (fa, fb) = (frames[mesh.face(h)], frames[mesh.face(t)]);
            let ev = mesh.vector(h);
            wrap(fb.angle_of(&ev) - fa.angle_of(&ev))
        })
        .collect()
}

/// A cross field on a mesh.
#[derive(Clone, Debug)]
pub struct CrossField {
    /// Angle of one arm per face, in the face frame.
    pub theta: FaceData<f64>,
    /// Period jump per edge, from its first face to its second (0 on boundary edges).
    pub jumps: EdgeData<i32>,
}

/// A singular vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Singularity {
    /// The vertex.
    pub vertex: VertexId,
    /// Index in quarter turns (+1 valence 3, −1 valence 5, −2 valence 6, ...).
    pub index: i32,
}

impl Singularity {
    /// Number of separatrices leaving it: 4 − index.
    pub fn separatrices(&self) -> i32 {
        4 - self.index
    }
}

impl CrossField {
    /// The field with the given angles and the period jumps that best match them.
    pub fn from_angles(mesh: &Mesh, rho: &EdgeData<f64>, theta: FaceData<f64>) -> Self {
        let jumps = round_jumps(mesh, rho, &theta);
        Self { theta, jumps }
    }

    /// 3D unit vector of the representative arm of face `f`.
    pub fn direction(&self, mesh: &Mesh, f: FaceId) -> Vec3 {
        mesh.face_frame(f).direction(self.theta[f])
    }

    /// Representative arms of all faces.
    pub fn directions(&self, mesh: &Mesh) -> FaceData<Vec3> {
        let frames = mesh.face_frames();
        mesh.face_ids().map(|f| frames[f].direction(self.theta[f])).collect()
    }

    /// Residual of edge `e`: θ_a + ρ + (π/2)p − θ_b (0 on boundary edges).
    #[inline]
    pub fn edge_residual(&self, mesh: &Mesh, rho: &EdgeData<f64>, e: EdgeId) -> f64 {
        let (a, b) = mesh.edge_faces(e);
        match b {
            Some(b) => self.theta[a] + rho[e] + FRAC_PI_2 * self.jumps[e] as f64 - self.theta[b],
            None => 0.0,
        }
    }

    /// Smoothness energy Σ_e (θ_a + ρ + (π/2)p − θ_b)², the first term of the paper's Eq. 7.
    pub fn smoothness_energy(&self, mesh: &Mesh, rho: &EdgeData<f64>) -> f64 {
        mesh.edges().map(|e| self.edge_residual(mesh, rho, e).powi(2)).sum()
    }

    /// Singularity index (quarter turns) of every vertex; 0 on boundary vertices.
    pub fn indices(&self, mesh: &Mesh, rho: &EdgeData<f64>) -> VertexData<i32> {
        let defects = mesh.angle_defects();
        mesh.vertices()
            .map(|v| {
                if mesh.is_boundary_vertex(v) {
                    return 0;
                }
                let (mut sum_rho, mut sum_p) = (0.0, 0i32);
                for h in mesh.outgoing(v) {
                    // Crossing prev(h) from face(h) to the next face counter-clockwise.
                    let (r, p) = crossing(mesh, rho, &self.jumps, mesh.prev(h));
                    sum_rho += r;
                    sum_p += p;
                }
                4 * ((defects[v] - sum_rho) / TAU).round() as i32 - sum_p
            })
            .collect()
    }

    /// All singular vertices (index ≠ 0), in vertex order.
    pub fn singularities(&self, mesh: &Mesh, rho: &EdgeData<f64>) -> Vec<Singularity> {
        self.indices(mesh, rho)
            .enumerate()
            .filter(|(_, i)| **i != 0)
            .map(|(vertex, index)| Singularity { vertex, index: *index })
            .collect()
    }
}

/// (ρ, p) for crossing the edge of halfedge `h` from `face(h)` to the face across.
#[inline]
pub fn crossing(mesh: &Mesh, rho: &EdgeData<f64>, jumps: &EdgeData<i32>, h: HalfedgeId) -> (f64, i32) {
    let e = mesh.edge(h);
    if mesh.face(mesh.edge_halfedge(e)) == mesh.face(h) { (rho[e], jumps[e]) } else { (-rho[e], -jumps[e]) }
}

/// Period jumps rounded to make θ_a + ρ + (π/2)p closest to θ_b.
pub fn round_jumps(mesh: &Mesh, rho: &EdgeData<f64>, theta: &FaceData<f64>) -> EdgeData<i32> {
    mesh.edges()
        .map(|e| match mesh.edge_faces(e) {
            (a, Some(b)) => ((theta[b] - theta[a] - rho[e]) / FRAC_PI_2).round() as i32,
            _ => 0,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;

    #[test]
    fn connection_is_antisymmetric_and_consistent() {
        let m = shapes::icosphere(2, 1.0);
        let rho = connection(&m);
        let frames = m.face_frames();
        for e in m.edges() {
            let h = m.edge_halfedge(e);
            let t = m.twin(h).unwrap();
            // A tangent vector of face a along the edge maps to the same vector in face b.
            let ev = m.vector(h).normalize();
            let (fa, fb) = (frames[m.face(h)], frames[m.face(t)]);
            let th_a = fa.angle_of(&ev);
            assert!((wrap(th_a + rho[e] - fb.angle_of(&ev))).abs() < 1e-12);
        }
    }

    #[test]
    fn any_field_has_index_sum_4chi() {
        for m in [shapes::icosphere(2, 1.0), shapes::torus(2.0, 0.6, 20, 12), shapes::rounded_tetrahedron(0.5)] {
            let rho = connection(&m);
            // A deliberately rough field.
            let mut rng = clothcast_mesh::util::SplitMix64::new(3);
            let theta: FaceData<f64> = m.face_ids().map(|_| rng.next_f64() * 6.0).collect();
            let f = CrossField::from_angles(&m, &rho, theta);
            let sum: i32 = f.indices(&m, &rho).iter().sum();
            assert_eq!(sum as i64, 4 * m.euler_characteristic());
        }
    }

    #[test]
    fn wrap_range() {
        for a in [-7.0, -PI, -1.0, 0.0, PI, 4.0, 20.0] {
            let w = wrap(a);
            assert!(w > -PI - 1e-15 && w <= PI + 1e-15);
            assert!(((a - w) / TAU - ((a - w) / TAU).round()).abs() < 1e-12);
        }
    }
}
