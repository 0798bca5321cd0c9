//! The validated triangle mesh with implicit halfedge connectivity.
//!
//! Halfedge `3f + k` runs from corner `k` to corner `k + 1 (mod 3)` of face `f`, so `next`,
//! `prev`, `face` and `tail` are arithmetic; only `twin` and the edge map are stored. A
//! boundary halfedge has no twin. Every vertex stores one outgoing halfedge, the boundary one
//! for boundary vertices, so that [`Mesh::outgoing`] visits its whole fan counter-clockwise.
//!
//! A [`Mesh`] is always a manifold, consistently oriented surface without degenerate or
//! duplicate faces or unreferenced vertices (it may have several components and boundaries):
//! the only constructor, [`Mesh::try_from_soup`], checks all of that.

use crate::Vec3;
use crate::error::MeshError;
use crate::ids::*;
use crate::soup::{Aabb, TriSoup};
use crate::validate::{analyze, group_edges};

/// A manifold, oriented triangle mesh (see the module docs for the invariants).
#[derive(Clone, Debug)]
pub struct Mesh {
    positions: VertexData<Vec3>,
    faces: FaceData<[VertexId; 3]>,
    twin: Vec<HalfedgeId>,
    he_edge: Vec<EdgeId>,
    edge_he: EdgeData<HalfedgeId>,
    vertex_he: VertexData<HalfedgeId>,
    boundary_loops: Vec<Vec<HalfedgeId>>,
    component_of_face: FaceData<u32>,
    n_components: usize,
}

impl Mesh {
    /// Build a mesh from a soup, refusing it (with every problem named) unless it is a valid
    /// manifold, oriented surface. Several components are accepted here; whether they are
    /// acceptable is the caller's policy.
    pub fn try_from_soup(soup: &TriSoup) -> Result<Self, MeshError> {
        let analysis = analyze(soup);
        let problems: Vec<_> = analysis.blocking_problems().cloned().collect();
        if !problems.is_empty() {
            return Err(MeshError::Invalid { problems });
        }
        Ok(Self::build_unchecked(soup.positions.clone(), &soup.triangles))
    }

    /// Build from positions and triangles; same checks as [`Mesh::try_from_soup`].
    pub fn try_new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        Self::try_from_soup(&TriSoup::from_triangles(positions, triangles))
    }

    /// Connectivity construction; the soup must already be valid (used directly where validity
    /// holds by construction, such as [`crate::subdivide`]'s bisections of a valid mesh).
    pub(crate) fn build_unchecked(positions: Vec<Vec3>, triangles: &[[u32; 3]]) -> Self {
        let nf = triangles.len();
        let nv = positions.len();
        let groups = group_edges(triangles, |_| true);
        let ne = groups.n_edges();
        let mut twin = vec![HalfedgeId::INVALID; 3 * nf];
        let mut he_edge = vec![EdgeId::INVALID; 3 * nf];
        let mut edge_he = Vec::with_capacity(ne);
        for e in 0..ne {
            let hs = groups.halfedges(e);
            debug_assert!(hs.len() <= 2);
            for &h in hs {
                he_edge[h as usize] = EdgeId::new(e);
            }
            if hs.len() == 2 {
                twin[hs[0] as usize] = HalfedgeId(hs[1]);
                twin[hs[1] as usize] = HalfedgeId(hs[0]);
            }
            edge_he.push(HalfedgeId(*hs.iter().min().expect("edge has a halfedge")));
        }
        let mut vertex_he = vec![HalfedgeId::INVALID; nv];
        for h in 0..3 * nf {
            let v = triangles[h / 3][h % 3] as usize;
            if !vertex_he[v].is_valid() || !twin[h].is_valid() {
                vertex_he[v] = HalfedgeId::new(h);
            }
        }
        let faces: FaceData<[VertexId; 3]> = triangles.iter().map(|t| t.map(VertexId)).collect();
        let mut uf = crate::util::UnionFind::new(nf);
        for h in 0..3 * nf {
            if twin[h].is_valid() {
                uf.union((h / 3) as u32, twin[h].0 / 3);
            }
        }
        let (labels, n_components) = uf.labels();
        let mut mesh = Self {
            positions: VertexData::from_vec(positions),
            faces,
            twin,
            he_edge,
            edge_he: EdgeData::from_vec(edge_he),
            vertex_he: VertexData::from_vec(vertex_he),
            boundary_loops: Vec::new(),
            component_of_face: FaceData::from_vec(labels),
            n_components,
        };
        mesh.boundary_loops = mesh.trace_boundary_loops();
        mesh
    }

    fn trace_boundary_loops(&self) -> Vec<Vec<HalfedgeId>> {
        let mut seen = vec![false; self.n_halfedges()];
        let mut loops = Vec::new();
        for h in 0..self.n_halfedges() {
            if seen[h] || self.twin[h].is_valid() {
                continue;
            }
            let mut lp = Vec::new();
            let mut cur = HalfedgeId::new(h);
            while !seen[cur.idx()] {
                seen[cur.idx()] = true;
                lp.push(cur);
                cur = self.vertex_he[self.head(cur)];
            }
            loops.push(lp);
        }
        loops
    }

    // ---- sizes --------------------------------------------------------------------------

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }
    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }
    /// Number of undirected edges.
    pub fn n_edges(&self) -> usize {
        self.edge_he.len()
    }
    /// Number of halfedges (3 per face; boundary edges have one).
    pub fn n_halfedges(&self) -> usize {
        self.twin.len()
    }
    /// Vertex ids.
    pub fn vertices(&self) -> impl ExactSizeIterator<Item = VertexId> + use<> {
        (0..self.n_vertices() as u32).map(VertexId)
    }
    /// Face ids.
    pub fn face_ids(&self) -> impl ExactSizeIterator<Item = FaceId> + use<> {
        (0..self.n_faces() as u32).map(FaceId)
    }
    /// Edge ids.
    pub fn edges(&self) -> impl ExactSizeIterator<Item = EdgeId> + use<> {
        (0..self.n_edges() as u32).map(EdgeId)
    }

    // ---- geometry access ----------------------------------------------------------------

    /// All vertex positions.
    pub fn positions(&self) -> &VertexData<Vec3> {
        &self.positions
    }
    /// Position of a vertex.
    #[inline]
    pub fn position(&self, v: VertexId) -> Vec3 {
        self.positions[v]
    }
    /// Replace all positions (same count).
    ///
    /// # Panics
    /// If the count differs.
    #[track_caller]
    pub fn set_positions(&mut self, positions: VertexData<Vec3>) {
        assert_eq!(positions.len(), self.n_vertices(), "position count must not change");
        self.positions = positions;
    }
    /// Mutable positions (connectivity is unaffected).
    pub fn positions_mut(&mut self) -> &mut VertexData<Vec3> {
        &mut self.positions
    }
    /// All faces as vertex triples.
    pub fn faces(&self) -> &FaceData<[VertexId; 3]> {
        &self.faces
    }
    /// Vertices of a face (counter-clockwise seen from the outside/normal).
    #[inline]
    pub fn face_vertices(&self, f: FaceId) -> [VertexId; 3] {
        self.faces[f]
    }
    /// Corner positions of a face.
    #[inline]
    pub fn face_positions(&self, f: FaceId) -> [Vec3; 3] {
        self.faces[f].map(|v| self.positions[v])
    }
    /// Bounding box.
    pub fn bbox(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }

    // ---- halfedges ----------------------------------------------------------------------

    /// Halfedge `k` (0..3) of face `f`, from corner `k` to corner `k+1`.
    #[inline]
    pub fn face_halfedge(&self, f: FaceId, k: usize) -> HalfedgeId {
        HalfedgeId(3 * f.0 + k as u32)
    }
    /// Face of a halfedge.
    #[inline]
    pub fn face(&self, h: HalfedgeId) -> FaceId {
        FaceId(h.0 / 3)
    }
    /// Corner index (0..3) of a halfedge's tail in its face.
    #[inline]
    pub fn corner(&self, h: HalfedgeId) -> usize {
        (h.0 % 3) as usize
    }
    /// Next halfedge in the face.
    #[inline]
    pub fn next(&self, h: HalfedgeId) -> HalfedgeId {
        HalfedgeId(h.0 - h.0 % 3 + (h.0 % 3 + 1) % 3)
    }
    /// Previous halfedge in the face.
    #[inline]
    pub fn prev(&self, h: HalfedgeId) -> HalfedgeId {
        HalfedgeId(h.0 - h.0 % 3 + (h.0 % 3 + 2) % 3)
    }
    /// Opposite halfedge across the edge, if the edge is interior.
    #[inline]
    pub fn twin(&self, h: HalfedgeId) -> Option<HalfedgeId> {
        let t = self.twin[h.idx()];
        t.is_valid().then_some(t)
    }
    /// Tail vertex.
    #[inline]
    pub fn tail(&self, h: HalfedgeId) -> VertexId {
        self.faces[self.face(h)][self.corner(h)]
    }
    /// Head vertex.
    #[inline]
    pub fn head(&self, h: HalfedgeId) -> VertexId {
        self.faces[self.face(h)][(self.corner(h) + 1) % 3]
    }
    /// The vertex of the face opposite to the halfedge.
    #[inline]
    pub fn opposite_vertex(&self, h: HalfedgeId) -> VertexId {
        self.faces[self.face(h)][(self.corner(h) + 2) % 3]
    }
    /// Edge of a halfedge.
    #[inline]
    pub fn edge(&self, h: HalfedgeId) -> EdgeId {
        self.he_edge[h.idx()]
    }
    /// Vector from tail to head.
    #[inline]
    pub fn vector(&self, h: HalfedgeId) -> Vec3 {
        self.positions[self.head(h)] - self.positions[self.tail(h)]
    }
    /// True if the halfedge has no twin (its edge is on the boundary).
    #[inline]
    pub fn is_boundary_halfedge(&self, h: HalfedgeId) -> bool {
        !self.twin[h.idx()].is_valid()
    }

    // ---- edges --------------------------------------------------------------------------

    /// A halfedge of the edge (the boundary one for boundary edges; the lower id otherwise).
    #[inline]
    pub fn edge_halfedge(&self, e: EdgeId) -> HalfedgeId {
        self.edge_he[e]
    }
    /// Endpoints of an edge (tail and head of [`Mesh::edge_halfedge`]).
    #[inline]
    pub fn edge_vertices(&self, e: EdgeId) -> [VertexId; 2] {
        let h = self.edge_he[e];
        [self.tail(h), self.head(h)]
    }
    /// The one or two faces of an edge.
    #[inline]
    pub fn edge_faces(&self, e: EdgeId) -> (FaceId, Option<FaceId>) {
        let h = self.edge_he[e];
        (self.face(h), self.twin(h).map(|t| self.face(t)))
    }
    /// True for boundary edges.
    #[inline]
    pub fn is_boundary_edge(&self, e: EdgeId) -> bool {
        self.is_boundary_halfedge(self.edge_he[e])
    }
    /// Length of an edge.
    #[inline]
    pub fn edge_length(&self, e: EdgeId) -> f64 {
        self.vector(self.edge_he[e]).norm()
    }

    // ---- vertices -----------------------------------------------------------------------

    /// An outgoing halfedge of a vertex (the boundary one for boundary vertices).
    #[inline]
    pub fn vertex_halfedge(&self, v: VertexId) -> HalfedgeId {
        self.vertex_he[v]
    }
    /// True if the vertex lies on the boundary.
    #[inline]
    pub fn is_boundary_vertex(&self, v: VertexId) -> bool {
        self.is_boundary_halfedge(self.vertex_he[v])
    }
    /// Outgoing halfedges of a vertex, counter-clockwise (seen from the normal side). For a
    /// boundary vertex the first one is the boundary halfedge leaving it.
    pub fn outgoing(&self, v: VertexId) -> Outgoing<'_> {
        let start = self.vertex_he[v];
        Outgoing { mesh: self, start, cur: Some(start) }
    }
    /// Faces around a vertex, counter-clockwise.
    pub fn vertex_faces(&self, v: VertexId) -> impl Iterator<Item = FaceId> + '_ {
        self.outgoing(v).map(move |h| self.face(h))
    }
    /// Neighbouring vertices, counter-clockwise (for a boundary vertex including the last
    /// neighbour along the incoming boundary edge).
    pub fn vertex_neighbors(&self, v: VertexId) -> Vec<VertexId> {
        let mut out: Vec<VertexId> = self.outgoing(v).map(|h| self.head(h)).collect();
        if self.is_boundary_vertex(v) {
            let last = self.outgoing(v).last().expect("vertex has a face");
            out.push(self.opposite_vertex(last));
        }
        out
    }
    /// Number of edges at a vertex.
    pub fn valence(&self, v: VertexId) -> usize {
        self.outgoing(v).count() + self.is_boundary_vertex(v) as usize
    }

    // ---- faces --------------------------------------------------------------------------

    /// The face across edge `k` of `f`, if any.
    #[inline]
    pub fn face_neighbor(&self, f: FaceId, k: usize) -> Option<FaceId> {
        self.twin(self.face_halfedge(f, k)).map(|t| self.face(t))
    }

    // ---- global topology ----------------------------------------------------------------

    /// Boundary loops; each is a cycle of boundary halfedges with the surface on their left.
    pub fn boundary_loops(&self) -> &[Vec<HalfedgeId>] {
        &self.boundary_loops
    }
    /// Number of (edge-connected) components.
    pub fn n_components(&self) -> usize {
        self.n_components
    }
    /// Component label of every face (`0..n_components`, numbered by first face).
    pub fn component_of_face(&self) -> &FaceData<u32> {
        &self.component_of_face
    }
    /// χ = V − E + F.
    pub fn euler_characteristic(&self) -> i64 {
        self.n_vertices() as i64 - self.n_edges() as i64 + self.n_faces() as i64
    }
    /// Total genus: Σ over components of (2 − χ_c − b_c)/2.
    pub fn genus(&self) -> i64 {
        let nc = self.n_components;
        let mut chi = vec![0i64; nc];
        for f in self.face_ids() {
            chi[self.component_of_face[f] as usize] += 1;
        }
        for e in self.edges() {
            chi[self.component_of_face[self.face(self.edge_he[e])] as usize] -= 1;
        }
        for v in self.vertices() {
            chi[self.component_of_face[self.face(self.vertex_he[v])] as usize] += 1;
        }
        // χ_c + b_c = 2 − 2g_c.
        for lp in &self.boundary_loops {
            chi[self.component_of_face[self.face(lp[0])] as usize] += 1;
        }
        chi.iter().map(|c| (2 - c) / 2).sum()
    }

    /// Back to a soup (positions and triangles).
    pub fn to_soup(&self) -> TriSoup {
        TriSoup::from_triangles(self.positions.as_slice().to_vec(), self.faces.iter().map(|t| t.map(|v| v.0)).collect())
    }
}

/// Iterator over the outgoing halfedges of a vertex (see [`Mesh::outgoing`]).
pub struct Outgoing<'a> {
    mesh: &'a Mesh,
    start: HalfedgeId,
    cur: Option<HalfedgeId>,
}

impl Iterator for Outgoing<'_> {
    type Item = HalfedgeId;
    fn next(&mut self) -> Option<HalfedgeId> {
        let h = self.cur?;
        self.cur = self.mesh.twin(self.mesh.prev(h)).filter(|&n| n != self.start);
        Some(h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_connectivity() {
        let m = crate::shapes::unit_square();
        assert_eq!((m.n_vertices(), m.n_edges(), m.n_faces()), (4, 5, 2));
        assert_eq!(m.euler_characteristic(), 1);
        assert_eq!(m.boundary_loops().len(), 1);
        assert_eq!(m.boundary_loops()[0].len(), 4);
        assert_eq!(m.genus(), 0);
        // Vertex 0 is on the boundary with 2 faces, 3 neighbours, CCW: 1, 2, 3.
        assert!(m.is_boundary_vertex(VertexId(0)));
        assert_eq!(m.vertex_faces(VertexId(0)).count(), 2);
        assert_eq!(m.vertex_neighbors(VertexId(0)), vec![VertexId(1), VertexId(2), VertexId(3)]);
        // Boundary loop walks with the surface on its left: 0→1→2→3.
        let lp: Vec<_> = m.boundary_loops()[0].iter().map(|&h| m.tail(h).0).collect();
        let start = lp.iter().position(|&v| v == 0).unwrap();
        let rot: Vec<_> = (0..4).map(|i| lp[(start + i) % 4]).collect();
        assert_eq!(rot, vec![0, 1, 2, 3]);
    }

    #[test]
    fn closed_octahedron() {
        let p = vec![
            Vec3::new(1., 0., 0.),
            Vec3::new(-1., 0., 0.),
            Vec3::new(0., 1., 0.),
            Vec3::new(0., -1., 0.),
            Vec3::new(0., 0., 1.),
            Vec3::new(0., 0., -1.),
        ];
        let t = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        let m = Mesh::try_new(p, t).unwrap();
        assert_eq!(m.euler_characteristic(), 2);
        assert!(m.boundary_loops().is_empty());
        for v in m.vertices() {
            assert_eq!(m.valence(v), 4);
            assert!(!m.is_boundary_vertex(v));
        }
        for h in (0..m.n_halfedges() as u32).map(HalfedgeId) {
            let t = m.twin(h).unwrap();
            assert_eq!(m.tail(t), m.head(h));
            assert_eq!(m.edge(t), m.edge(h));
        }
    }

    #[test]
    fn refuses_invalid() {
        let err = Mesh::try_new(vec![Vec3::zeros(); 3], vec![[0, 1, 2]]).unwrap_err();
        assert!(err.to_string().contains("zero area"), "{err}");
    }
}
