//! A signpost intrinsic triangulation (Sharp, Soliman & Crane 2019, "Navigating Intrinsic
//! Triangulations", ACM TOG 38(4)), restricted to what FlipOut needs: edge flips.
//!
//! The triangulation starts as a copy of the input [`Mesh`] (same vertices, same halfedge and
//! edge numbering for the interior halfedges) and then evolves by intrinsic edge flips. It stores
//! explicit mutable connectivity (next, twin, tail, edge of every halfedge), an edge length per
//! edge and a *signpost* per halfedge: the angle φ ∈ [0, Θ_v) of the halfedge's direction at its
//! tail v, measured counter-clockwise from the first halfedge of the input mesh's vertex fan
//! ([`Mesh::outgoing`]; for a boundary vertex the boundary halfedge, so that φ ∈ [0, Θ_v]),
//! where Θ_v is the vertex's angle sum. Since the input triangulation is the initial one, a
//! signpost is directly a direction in the input mesh's fan, which is how the flip-out paths are
//! traced back onto the input (see `flipout.rs`).
//!
//! Deviations from the paper: no vertex insertion (FlipOut only flips), signposts are kept in
//! raw angle units (not rescaled to 2π), and every boundary edge gets an explicit *exterior*
//! halfedge (no face, numbered after the `3F` interior ones) so that paths may run along the
//! boundary in either direction. The signpost of an exterior halfedge is Θ_v: it points along
//! the incoming boundary edge, the end of the fan. Angles come from edge lengths by the
//! law of cosines in a cancellation-free form (Kahan's Heron area and `atan2`), so nearly flat
//! triangles keep accurate angles.
//!
//! Preconditions: a valid [`Mesh`] (any genus, boundaries allowed). Boundary edges are never
//! flipped; the triangulation may become a Δ-complex (several edges between two vertices).
//!
//! Complexity: construction O(F); a flip O(1).

use clothcast_mesh::Mesh;
use std::f64::consts::PI;

/// The "no such element" index.
pub const NONE: usize = usize::MAX;

/// Area of a triangle with side lengths `a`, `b`, `c` (Kahan's stable Heron formula); 0 for
/// lengths violating the triangle inequality (round-off on degenerate triangles).
pub fn triangle_area(a: f64, b: f64, c: f64) -> f64 {
    let mut s = [a, b, c];
    s.sort_by(|x, y| y.total_cmp(x));
    let [x, y, z] = s;
    let p = (x + (y + z)) * (z - (x - y)) * (z + (x - y)) * (x + (y - z));
    0.25 * p.max(0.0).sqrt()
}

/// The angle between sides `a` and `b` of a triangle whose third side is `c`.
///
/// `atan2(4A, a² + b² − c²)`: both arguments are accurate for needle and flat triangles, where
/// `acos` of the law of cosines loses half the digits.
pub fn corner_angle(a: f64, b: f64, c: f64) -> f64 {
    (4.0 * triangle_area(a, b, c)).atan2(a * a + b * b - c * c)
}

/// Signposts of the input mesh: for every input halfedge, the angle of its direction at its
/// tail counter-clockwise from the start of the vertex fan, and every vertex's angle sum. The
/// intrinsic triangulation and the tracer both use this one function, so that their angles agree
/// to the last bit.
pub fn input_signposts(mesh: &Mesh) -> (Vec<f64>, Vec<f64>) {
    let len: Vec<f64> = mesh.edges().map(|e| mesh.edge_length(e)).collect();
    let corner = |h| {
        corner_angle(len[mesh.edge(h).idx()], len[mesh.edge(mesh.prev(h)).idx()], len[mesh.edge(mesh.next(h)).idx()])
    };
    let mut signpost = vec![0.0; mesh.n_halfedges()];
    let mut sums = vec![0.0; mesh.n_vertices()];
    for v in mesh.vertices() {
        let mut acc = 0.0;
        for h in mesh.outgoing(v) {
            signpost[h.idx()] = acc;
            acc += corner(h);
        }
        sums[v.idx()] = acc;
    }
    (signpost, sums)
}

/// A signpost intrinsic triangulation of a mesh's surface (see the module docs).
///
/// Indices are plain `usize`: vertices are those of the input mesh; halfedges `0..3F` are the
/// input's interior halfedges (same ids as long as nothing was flipped), `3F..` the exterior
/// halfedges of boundary edges; edges keep the input's edge ids.
#[derive(Clone, Debug)]
pub struct IntrinsicTriangulation {
    next: Vec<usize>,
    twin: Vec<usize>,
    tail: Vec<usize>,
    edge: Vec<usize>,
    edge_he: Vec<usize>,
    vertex_he: Vec<usize>,
    length: Vec<f64>,
    signpost: Vec<f64>,
    angle_sum: Vec<f64>,
    boundary_vertex: Vec<bool>,
    original: Vec<bool>,
    n_interior: usize,
}

impl IntrinsicTriangulation {
    /// The input mesh as an intrinsic triangulation.
    pub fn from_mesh(mesh: &Mesh) -> Self {
        let n_interior = mesh.n_halfedges();
        let n_boundary = mesh.edges().filter(|&e| mesh.is_boundary_edge(e)).count();
        let nh = n_interior + n_boundary;
        let mut next = vec![NONE; nh];
        let mut twin = vec![NONE; nh];
        let mut tail = vec![NONE; nh];
        let mut edge = vec![NONE; nh];
        for h in (0..n_interior).map(clothcast_mesh::HalfedgeId::new) {
            next[h.idx()] = mesh.next(h).idx();
            tail[h.idx()] = mesh.tail(h).idx();
            edge[h.idx()] = mesh.edge(h).idx();
            if let Some(t) = mesh.twin(h) {
                twin[h.idx()] = t.idx();
            }
        }
        // Exterior halfedges, in edge order (deterministic).
        for (k, e) in mesh.edges().filter(|&e| mesh.is_boundary_edge(e)).enumerate() {
            let (h, ext) = (mesh.edge_halfedge(e), n_interior + k);
            twin[h.idx()] = ext;
            twin[ext] = h.idx();
            tail[ext] = mesh.head(h).idx();
            edge[ext] = e.idx();
        }
        let (mut signpost, angle_sum) = input_signposts(mesh);
        signpost.resize(nh, 0.0);
        for h in n_interior..nh {
            signpost[h] = angle_sum[tail[h]];
        }
        Self {
            next,
            twin,
            tail,
            edge,
            edge_he: mesh.edges().map(|e| mesh.edge_halfedge(e).idx()).collect(),
            vertex_he: mesh.vertices().map(|v| mesh.vertex_halfedge(v).idx()).collect(),
            length: mesh.edges().map(|e| mesh.edge_length(e)).collect(),
            signpost,
            angle_sum,
            boundary_vertex: mesh.vertices().map(|v| mesh.is_boundary_vertex(v)).collect(),
            original: vec![true; mesh.n_edges()],
            n_interior,
        }
    }

    // ---- sizes and connectivity -------------------------------------------------------------

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.vertex_he.len()
    }
    /// Number of edges.
    pub fn n_edges(&self) -> usize {
        self.edge_he.len()
    }
    /// Number of halfedges, interior and exterior.
    pub fn n_halfedges(&self) -> usize {
        self.next.len()
    }
    /// True if the halfedge has a face (false for exterior halfedges of boundary edges).
    #[inline]
    pub fn is_interior(&self, h: usize) -> bool {
        h < self.n_interior
    }
    /// Next halfedge in the face.
    ///
    /// # Panics
    /// For an exterior halfedge (a caller's bug).
    #[inline]
    #[track_caller]
    pub fn next(&self, h: usize) -> usize {
        assert!(self.is_interior(h), "exterior halfedge {h} has no face");
        self.next[h]
    }
    /// Previous halfedge in the face (see [`Self::next`]).
    #[inline]
    #[track_caller]
    pub fn prev(&self, h: usize) -> usize {
        self.next(self.next(h))
    }
    /// Opposite halfedge (always exists: boundary edges have an exterior halfedge).
    #[inline]
    pub fn twin(&self, h: usize) -> usize {
        self.twin[h]
    }
    /// Tail vertex.
    #[inline]
    pub fn tail(&self, h: usize) -> usize {
        self.tail[h]
    }
    /// Head vertex.
    #[inline]
    pub fn head(&self, h: usize) -> usize {
        self.tail[self.twin[h]]
    }
    /// Edge of a halfedge.
    #[inline]
    pub fn edge(&self, h: usize) -> usize {
        self.edge[h]
    }
    /// The representative halfedge of an edge (interior for boundary edges).
    #[inline]
    pub fn edge_halfedge(&self, e: usize) -> usize {
        self.edge_he[e]
    }
    /// The next outgoing halfedge counter-clockwise around the tail of `h` (`h` interior); the
    /// exterior halfedge after the last interior one of a boundary vertex.
    #[inline]
    #[track_caller]
    pub fn ccw_next(&self, h: usize) -> usize {
        self.twin[self.prev(h)]
    }
    /// True for boundary edges (never flipped).
    #[inline]
    pub fn is_boundary_edge(&self, e: usize) -> bool {
        let h = self.edge_he[e];
        !self.is_interior(h) || !self.is_interior(self.twin[h])
    }
    /// True for boundary vertices.
    #[inline]
    pub fn is_boundary_vertex(&self, v: usize) -> bool {
        self.boundary_vertex[v]
    }
    /// True if the edge was never flipped: it is still the input mesh's edge of the same id.
    #[inline]
    pub fn is_original_edge(&self, e: usize) -> bool {
        self.original[e]
    }
    /// The halfedge from `u` to `w`, if an edge joins them (the first one counter-clockwise
    /// from the fan's start when several do).
    pub fn halfedge_between(&self, u: usize, w: usize) -> Option<usize> {
        let start = self.vertex_he[u];
        let mut h = start;
        for _ in 0..self.n_halfedges() {
            if self.head(h) == w {
                return Some(h);
            }
            if !self.is_interior(h) {
                return None;
            }
            h = self.ccw_next(h);
            if h == start {
                return None;
            }
        }
        None
    }

    // ---- geometry ---------------------------------------------------------------------------

    /// Length of an edge.
    #[inline]
    pub fn length(&self, e: usize) -> f64 {
        self.length[e]
    }
    /// Length of a halfedge's edge.
    #[inline]
    pub fn halfedge_length(&self, h: usize) -> f64 {
        self.length[self.edge[h]]
    }
    /// Signpost angle of a halfedge at its tail (see the module docs).
    #[inline]
    pub fn signpost(&self, h: usize) -> f64 {
        self.signpost[h]
    }
    /// Angle sum Θ_v of a vertex.
    #[inline]
    pub fn angle_sum(&self, v: usize) -> f64 {
        self.angle_sum[v]
    }
    /// Interior angle of the face of `h` at the tail of `h`.
    #[inline]
    #[track_caller]
    pub fn corner_angle(&self, h: usize) -> f64 {
        let (n, p) = (self.next(h), self.prev(h));
        corner_angle(self.halfedge_length(h), self.halfedge_length(p), self.halfedge_length(n))
    }

    /// An angle at `v` reduced to the signpost range: modulo Θ_v at interior vertices, clamped
    /// to [0, Θ_v] at boundary vertices (whose fan does not wrap).
    fn wrap_angle(&self, v: usize, x: f64) -> f64 {
        let t = self.angle_sum[v];
        if self.boundary_vertex[v] {
            x.clamp(0.0, t)
        } else {
            let r = x.rem_euclid(t);
            if r >= t { 0.0 } else { r }
        }
    }

    // ---- flips ------------------------------------------------------------------------------

    /// Flip edge `e` if it is interior and its quad is strictly convex (both angles at the
    /// edge's endpoints below π − `eps`, and both new triangles non-degenerate in floating point;
    /// `eps` should be ≳ 1e-7 for that); returns whether it was flipped. The halfedge ids of `e`
    /// are reused for the new diagonal; its signposts are set from the neighbouring halfedges'.
    pub fn flip_edge(&mut self, e: usize, eps: f64) -> bool {
        let h = self.edge_he[e];
        let t = self.twin[h];
        if !self.is_interior(h) || !self.is_interior(t) {
            return false;
        }
        // Before: face (h: i→j, ha: j→k, hb: k→i) and (t: j→i, tc: i→l, td: l→j).
        let (ha, tc) = (self.next[h], self.next[t]);
        let (hb, td) = (self.next[ha], self.next[tc]);
        let (i, j, k, l) = (self.tail[h], self.tail[t], self.tail[hb], self.tail[td]);
        let (a_i0, a_i1) = (self.corner_angle(h), self.corner_angle(tc));
        let (a_j0, a_j1) = (self.corner_angle(ha), self.corner_angle(t));
        if !(a_i0 + a_i1 < PI - eps && a_j0 + a_j1 < PI - eps) {
            return false;
        }
        // Lay the quad out with i at the origin and j on +x: k above, l below.
        let (d_ik, d_il) = (self.halfedge_length(hb), self.halfedge_length(tc));
        let (kx, ky) = (d_ik * a_i0.cos(), d_ik * a_i0.sin());
        let (lx, ly) = (d_il * a_i1.cos(), -d_il * a_i1.sin());
        let new_len = (kx - lx).hypot(ky - ly);
        // Both new triangles must be representable by their lengths: a quad angle within ~1e-8
        // of π gives a triangle-inequality slack below round-off, i.e. a degenerate triangle.
        let area_ok = |a: f64, b: f64| {
            let s = new_len + a + b;
            triangle_area(new_len, a, b) > 1e-14 * s * s
        };
        let (d_jk, d_jl) = (self.halfedge_length(ha), self.halfedge_length(td));
        if !(new_len > 0.0 && new_len.is_finite() && area_ok(d_ik, d_il) && area_ok(d_jk, d_jl)) {
            return false;
        }
        // After: face (h: l→k, hb: k→i, tc: i→l) and (t: k→l, td: l→j, ha: j→k).
        self.tail[h] = l;
        self.tail[t] = k;
        self.next[h] = hb;
        self.next[hb] = tc;
        self.next[tc] = h;
        self.next[t] = td;
        self.next[td] = ha;
        self.next[ha] = t;
        // i and j lose h and t; their stored fan start moves to an unchanged halfedge. Boundary
        // vertices store their boundary halfedge, which is never flipped.
        if self.vertex_he[i] == h {
            self.vertex_he[i] = tc;
        }
        if self.vertex_he[j] == t {
            self.vertex_he[j] = ha;
        }
        self.length[e] = new_len;
        self.original[e] = false;
        // h follows td counter-clockwise around l; t follows hb around k.
        self.signpost[h] = self.wrap_angle(l, self.signpost[td] + self.corner_angle(td));
        self.signpost[t] = self.wrap_angle(k, self.signpost[hb] + self.corner_angle(hb));
        true
    }

    /// Check the invariants (connectivity, positive triangles, consistent signposts up to
    /// `tol` radians); the first violation found, for tests and debugging.
    pub fn check(&self, tol: f64) -> Result<(), String> {
        for h in 0..self.n_halfedges() {
            if self.twin[self.twin[h]] != h || self.edge[self.twin[h]] != self.edge[h] {
                return Err(format!("twin of {h} inconsistent"));
            }
            if self.tail[self.twin[h]] == NONE || self.tail[h] == NONE {
                return Err(format!("halfedge {h} has no tail"));
            }
            if !self.is_interior(h) {
                continue;
            }
            let (n, p) = (self.next[h], self.prev(h));
            if self.next[p] != h || self.tail[n] != self.head(h) {
                return Err(format!("face of {h} is not a triangle"));
            }
            let (a, b, c) = (self.halfedge_length(h), self.halfedge_length(n), self.halfedge_length(p));
            if !(triangle_area(a, b, c) > 0.0) {
                return Err(format!("face of {h} is degenerate ({a}, {b}, {c})"));
            }
            let v = self.tail[h];
            let succ = self.ccw_next(h);
            let expected = self.signpost[h] + self.corner_angle(h);
            let mut diff = (self.signpost[succ] - expected).abs();
            if !self.boundary_vertex[v] {
                diff = diff.min((diff - self.angle_sum[v]).abs());
            }
            if diff > tol {
                return Err(format!("signposts of {h} and {succ} at vertex {v} disagree by {diff}"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;

    #[test]
    fn angles_are_accurate() {
        assert!((corner_angle(1.0, 1.0, 2f64.sqrt()) - PI / 2.0).abs() < 1e-15);
        assert!((corner_angle(3.0, 4.0, 5.0) - PI / 2.0).abs() < 1e-15);
        // A needle: the angle between the two long sides.
        let (a, eps) = (1.0, 1e-9);
        assert!((corner_angle(a, a, eps) - eps).abs() < 1e-20);
        // A flat triangle: angle π (not NaN).
        assert!((corner_angle(1.0, 2.0, 3.0) - PI).abs() < 1e-12);
        assert_eq!(triangle_area(1.0, 1.0, 3.0), 0.0);
    }

    #[test]
    fn square_flip() {
        let m = shapes::unit_square();
        let mut tri = IntrinsicTriangulation::from_mesh(&m);
        tri.check(1e-12).unwrap();
        assert_eq!(tri.n_halfedges(), 6 + 4);
        let e = tri.edge(tri.halfedge_between(0, 2).unwrap());
        assert!(!tri.is_boundary_edge(e));
        assert!(tri.flip_edge(e, 1e-10));
        assert!(!tri.is_original_edge(e));
        assert!((tri.length(e) - 2f64.sqrt()).abs() < 1e-15);
        let h = tri.halfedge_between(1, 3).unwrap();
        assert_eq!(tri.edge(h), e);
        assert!(tri.halfedge_between(0, 2).is_none());
        tri.check(1e-12).unwrap();
        // Vertex 1's fan starts at its boundary halfedge 1→2; 1→3 bisects its right angle.
        assert!((tri.signpost(h) - PI / 4.0).abs() < 1e-15);
        // Boundary edges never flip; flipping back restores the diagonal.
        let b = tri.edge(tri.halfedge_between(0, 1).unwrap());
        assert!(!tri.flip_edge(b, 1e-10));
        assert!(tri.flip_edge(e, 1e-10));
        assert!(tri.halfedge_between(0, 2).is_some());
        tri.check(1e-12).unwrap();
        // Exterior halfedges point along the incoming boundary edge: signpost Θ.
        let x = tri.halfedge_between(0, 3).unwrap();
        assert!(!tri.is_interior(x));
        assert!((tri.signpost(x) - PI / 2.0).abs() < 1e-15);
    }

    #[test]
    fn random_flips_keep_invariants() {
        let m = shapes::icosphere(2, 1.0);
        let mut tri = IntrinsicTriangulation::from_mesh(&m);
        let sums = tri.angle_sum.clone();
        let mut rng = clothcast_mesh::util::SplitMix64::new(7);
        let mut flips = 0;
        for _ in 0..2000 {
            let e = rng.below(tri.n_edges());
            flips += tri.flip_edge(e, 1e-6) as usize;
        }
        assert!(flips > 500, "{flips}");
        tri.check(1e-9).unwrap();
        // Corner angles around every vertex still sum to Θ (intrinsic flips preserve curvature).
        let mut s = vec![0.0; tri.n_vertices()];
        for h in (0..tri.n_halfedges()).filter(|&h| tri.is_interior(h)) {
            s[tri.tail(h)] += tri.corner_angle(h);
        }
        for v in 0..s.len() {
            assert!((s[v] - sums[v]).abs() < 1e-9);
        }
    }

    #[test]
    fn boundary_fans() {
        let m = shapes::grid(3, 3, 1.0, 1.0);
        let mut tri = IntrinsicTriangulation::from_mesh(&m);
        let mut rng = clothcast_mesh::util::SplitMix64::new(3);
        for _ in 0..300 {
            let e = rng.below(tri.n_edges());
            tri.flip_edge(e, 1e-6);
        }
        tri.check(1e-9).unwrap();
        // Flat grid: interior angle sums 2π, boundary sides π, corners π/2.
        assert!((tri.angle_sum(5) - 2.0 * PI).abs() < 1e-12);
        assert!((tri.angle_sum(1) - PI).abs() < 1e-12);
        assert!((tri.angle_sum(0) - PI / 2.0).abs() < 1e-12);
    }
}
