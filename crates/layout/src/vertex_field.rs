//! A per-vertex cross field for tracing (ALGORITHMS.md §6, after `xfield_tracer`'s
//! vertex-field graph): the face field's 4-RoSy power `e^{4iθ}` of the faces around a vertex,
//! each projected into the vertex's tangent plane and weighted by its corner angle, averaged;
//! one arm is `cos θ e1 + sin θ e2`, the others follow by quarter turns about the normal. The
//! magnitude of the average (1 where the faces agree, near 0 at singularities) is kept as
//! `strength`.
//!
//! Complexity: O(F).

use clothcast_field::CrossField;
use clothcast_mesh::{Mesh, Vec3, VertexData, VertexId};

/// A cross per vertex.
#[derive(Clone, Debug)]
pub struct VertexField {
    /// Unit vertex normals (area-weighted).
    pub normal: VertexData<Vec3>,
    /// One unit arm of the cross, tangent to the vertex.
    pub arm0: VertexData<Vec3>,
    /// Agreement of the faces around the vertex in [0, 1].
    pub strength: VertexData<f64>,
}

impl VertexField {
    /// Average a face cross field onto the vertices.
    pub fn from_face_field(mesh: &Mesh, field: &CrossField) -> Self {
        let normal = mesh.vertex_normals();
        let dirs = field.directions(mesh);
        let angles = mesh.corner_angles();
        let mut arm0 = Vec::with_capacity(mesh.n_vertices());
        let mut strength = Vec::with_capacity(mesh.n_vertices());
        for v in mesh.vertices() {
            let n = normal[v];
            let (e1, e2) = tangent_frame(mesh, v, &n);
            let (mut re, mut im, mut wsum) = (0.0, 0.0, 0.0);
            for h in mesh.outgoing(v) {
                let w = angles[h];
                let d = dirs[mesh.face(h)];
                let a = d.dot(&e2).atan2(d.dot(&e1));
                re += w * (4.0 * a).cos();
                im += w * (4.0 * a).sin();
                wsum += w;
            }
            let theta = im.atan2(re) / 4.0;
            arm0.push(e1 * theta.cos() + e2 * theta.sin());
            strength.push(if wsum > 0.0 { (re * re + im * im).sqrt() / wsum } else { 0.0 });
        }
        Self { normal, arm0: VertexData::from_vec(arm0), strength: VertexData::from_vec(strength) }
    }

    /// Arm `k` (0..4) of the cross at `v`.
    #[inline]
    pub fn arm(&self, v: VertexId, k: usize) -> Vec3 {
        let (a, n) = (self.arm0[v], self.normal[v]);
        match k % 4 {
            0 => a,
            1 => n.cross(&a),
            2 => -a,
            _ => -n.cross(&a),
        }
    }

    /// The arm of `v` closest to the direction `d` (projected on the tangent plane) and the angle
    /// between them.
    pub fn best_arm(&self, v: VertexId, d: &Vec3) -> (usize, f64) {
        let n = self.normal[v];
        let t = d - n * n.dot(d);
        let norm = t.norm();
        if norm < 1e-300 {
            return (0, std::f64::consts::FRAC_PI_2);
        }
        let t = t / norm;
        let (mut best, mut best_cos) = (0, f64::NEG_INFINITY);
        for k in 0..4 {
            let c = self.arm(v, k).dot(&t);
            if c > best_cos {
                best = k;
                best_cos = c;
            }
        }
        (best, best_cos.clamp(-1.0, 1.0).acos())
    }
}

/// An orthonormal tangent frame at `v`: e1 along the projection of the first outgoing edge.
fn tangent_frame(mesh: &Mesh, v: VertexId, n: &Vec3) -> (Vec3, Vec3) {
    let h = mesh.vertex_halfedge(v);
    let e = mesh.vector(h);
    let mut e1 = e - n * n.dot(&e);
    if e1.norm() < 1e-300 {
        e1 = n.cross(&Vec3::x());
        if e1.norm() < 1e-6 {
            e1 = n.cross(&Vec3::y());
        }
    }
    let e1 = e1.normalize();
    (e1, n.cross(&e1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_field::cross::connection;
    use clothcast_mesh::{FaceData, shapes};

    #[test]
    fn constant_field_on_a_plane() {
        let m = shapes::grid(6, 6, 1.0, 1.0);
        let rho = connection(&m);
        // Each face's frame: a field at world angle 0.3 expressed in the face frame.
        let world = Vec3::new(0.3f64.cos(), 0.3f64.sin(), 0.0);
        let theta: FaceData<f64> = m.face_ids().map(|f| m.face_frame(f).angle_of(&world)).collect();
        let field = CrossField::from_angles(&m, &rho, theta);
        let vf = VertexField::from_face_field(&m, &field);
        for v in m.vertices() {
            let (k, ang) = vf.best_arm(v, &world);
            assert!(ang < 1e-6, "vertex {v}: {ang}");
            assert!((vf.arm(v, k) - world).norm() < 1e-9);
            assert!((vf.strength[v] - 1.0).abs() < 1e-9);
        }
    }
}
