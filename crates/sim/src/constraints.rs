//! Boundary conditions as per-vertex constrained directions.
//!
//! Each vertex has an orthonormal frame whose first `k` axes span its constrained directions
//! (Gram–Schmidt of the directions added); those axes do not move, the others are the free
//! degrees of freedom. A fully clamped vertex has all three axes constrained. Frames let a
//! vertex slide on a plane or a line, which is what the statically determinate "3-2-1" support
//! of a free-floating mold needs (see [`Constraints::anchor_rigid_motions`]): it removes the
//! six rigid motions without any reaction force when the load is self-equilibrated.

use clothcast_mesh::{Mesh, Vec3, VertexId};
use nalgebra::Matrix3;

/// Constrained directions of every vertex.
#[derive(Clone, Debug)]
pub struct Constraints {
    dirs: Vec<Vec<Vec3>>,
}

impl Constraints {
    /// No constraints on `n` vertices.
    pub fn free(n: usize) -> Self {
        Self { dirs: vec![Vec::new(); n] }
    }
    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }
    /// True for zero vertices.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }
    /// Clamp a vertex completely.
    pub fn fix_vertex(&mut self, v: VertexId) {
        self.dirs[v.idx()] = vec![Vec3::x(), Vec3::y(), Vec3::z()];
    }
    /// Forbid motion of a vertex along `dir` (it may still move perpendicular to it).
    pub fn fix_direction(&mut self, v: VertexId, dir: Vec3) {
        let mut d = dir.normalize();
        for e in &self.dirs[v.idx()] {
            d -= e * e.dot(&d);
        }
        if d.norm() > 1e-9 {
            self.dirs[v.idx()].push(d.normalize());
        }
    }
    /// The constraints of the vertices `vertices`, as vertices 0, 1, … of another mesh (a
    /// coarse version whose vertex i is `vertices[i]` of this one).
    pub fn restrict(&self, vertices: &[VertexId]) -> Self {
        Self { dirs: vertices.iter().map(|v| self.dirs[v.idx()].clone()).collect() }
    }
    /// Number of constrained directions of a vertex (0..=3).
    pub fn n_fixed(&self, v: VertexId) -> usize {
        self.dirs[v.idx()].len()
    }
    /// `x` with its components along the vertex's constrained directions taken from `target`
    /// (a clamped vertex: `target` itself; a free one: `x`).
    pub fn hold(&self, v: VertexId, x: Vec3, target: Vec3) -> Vec3 {
        let d = &self.dirs[v.idx()];
        match d.len() {
            3 => target,
            _ => x + d.iter().map(|e| e * e.dot(&(target - x))).sum::<Vec3>(),
        }
    }
    /// Vertices with at least one constrained direction.
    pub fn constrained_vertices(&self) -> usize {
        self.dirs.iter().filter(|d| !d.is_empty()).count()
    }
    /// Fully clamped vertices.
    pub fn clamped_vertices(&self) -> usize {
        self.dirs.iter().filter(|d| d.len() == 3).count()
    }
    /// The vertex frame: columns are the constrained directions first, then free ones; and the
    /// number of constrained columns. `None` frame means the identity (no constraint).
    pub fn frame(&self, v: VertexId) -> (Option<Matrix3<f64>>, usize) {
        let d = &self.dirs[v.idx()];
        match d.len() {
            0 => (None, 0),
            3 => (None, 3),
            k => {
                let mut cols: Vec<Vec3> = d.clone();
                for cand in [Vec3::x(), Vec3::y(), Vec3::z()] {
                    if cols.len() == 3 {
                        break;
                    }
                    let mut c = cand;
                    for e in &cols {
                        c -= e * e.dot(&c);
                    }
                    if c.norm() > 0.5 {
                        cols.push(c.normalize());
                    }
                }
                (Some(Matrix3::from_columns(&cols)), k)
            }
        }
    }

    /// The "3-2-1" support of a free body: vertex a clamped, vertex b (farthest from a) held
    /// only perpendicular to a→b, vertex c (farthest from the line ab) held only along the
    /// normal of the plane (a, b, c). Statically determinate: rigid motions are removed and a
    /// self-equilibrated load produces no reaction.
    pub fn anchor_rigid_motions(&mut self, mesh: &Mesh) -> [VertexId; 3] {
        let p = mesh.positions();
        let a = VertexId(0);
        let b = mesh.vertices().max_by(|&u, &w| (p[u] - p[a]).norm().total_cmp(&(p[w] - p[a]).norm())).unwrap_or(a);
        let ab = (p[b] - p[a]).normalize();
        let off_line = |v: VertexId| {
            let r = p[v] - p[a];
            (r - ab * ab.dot(&r)).norm()
        };
        let c = mesh.vertices().max_by(|&u, &w| off_line(u).total_cmp(&off_line(w))).unwrap_or(a);
        self.fix_vertex(a);
        let n = ab.cross(&(p[c] - p[a])).normalize();
        let t = ab.cross(&n);
        self.fix_direction(b, n);
        self.fix_direction(b, t);
        self.fix_direction(c, n);
        [a, b, c]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_with_constrained_axes_first() {
        let mut c = Constraints::free(3);
        c.fix_direction(VertexId(1), Vec3::new(1.0, 1.0, 0.0));
        c.fix_direction(VertexId(1), Vec3::new(1.0, 0.0, 0.0));
        let (f, k) = c.frame(VertexId(1));
        let f = f.unwrap();
        assert_eq!(k, 2);
        assert!((f.transpose() * f - Matrix3::identity()).norm() < 1e-12);
        assert!((f.column(0) - Vec3::new(1.0, 1.0, 0.0).normalize()).norm() < 1e-12);
        // The free axis is z.
        assert!((f.column(2).abs() - Vec3::z()).norm() < 1e-12);
        c.fix_vertex(VertexId(2));
        assert_eq!(c.frame(VertexId(2)), (None, 3));
        assert_eq!(c.frame(VertexId(0)), (None, 0));
        assert_eq!((c.constrained_vertices(), c.clamped_vertices()), (2, 1));
    }

    #[test]
    fn hold_takes_only_the_constrained_components_from_the_target() {
        let mut c = Constraints::free(3);
        c.fix_direction(VertexId(1), Vec3::new(0.0, 0.0, 2.0));
        c.fix_vertex(VertexId(2));
        let (x, t) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 5.0, 7.0));
        assert_eq!(c.hold(VertexId(0), x, t), x);
        assert_eq!(c.hold(VertexId(1), x, t), Vec3::new(1.0, 2.0, 7.0));
        assert_eq!(c.hold(VertexId(2), x, t), t);
    }
}
