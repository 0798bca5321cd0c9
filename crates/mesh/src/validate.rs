//! Strict validation of triangle soups: every problem named with the offending elements.
//!
//! [`analyze`] never fails: it measures a soup (counts, components, χ, genus where defined)
//! and lists every [`Problem`]. [`crate::Mesh::try_from_soup`] refuses a soup with any
//! problem; [`crate::repair::repair_soup`] fixes the repairable ones when asked.
//!
//! Conventions (the same as `shared/meshes/SOURCES.md`): counts are taken on the triangulated
//! soup; V counts referenced vertices; components are vertex-connected; a non-manifold vertex
//! is one whose faces form several edge-connected fans (vertices on non-manifold edges are
//! reported through the edge instead); ids are 0-based.
//!
//! Complexity: O(F log F) (one sort of the 3F halfedges).

use crate::ids::{FaceId, VertexId};
use crate::soup::{Aabb, TriSoup};
use crate::util::{UnionFind, edge_key};
use serde::Serialize;
use std::fmt;

/// A face whose area is below this fraction of the squared bounding-box diagonal is degenerate.
pub const ZERO_AREA_REL: f64 = 1e-14;

/// One thing wrong with an input mesh, naming the elements involved (0-based ids).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum Problem {
    /// The mesh has no faces.
    Empty,
    /// The file held faces, but the repair dropped every one of them.
    NothingLeftAfterRepair {
        /// Faces in the file.
        faces: usize,
        /// Of them, dropped for a vertex with a non-finite coordinate.
        non_finite: usize,
        /// Dropped as degenerate (a repeated vertex, or zero area once welded).
        degenerate: usize,
        /// Dropped as duplicates.
        duplicate: usize,
    },
    /// A coordinate is NaN, infinite, or beyond ±[`crate::soup::MAX_COORDINATE`].
    NonFiniteCoordinate {
        /// The vertex.
        vertex: VertexId,
    },
    /// A face uses the same vertex twice.
    RepeatedVertexInFace {
        /// The face.
        face: FaceId,
        /// Its vertices.
        vertices: [VertexId; 3],
    },
    /// A face has (numerically) zero area.
    ZeroAreaFace {
        /// The face.
        face: FaceId,
        /// Its vertices.
        vertices: [VertexId; 3],
        /// Its area.
        area: f64,
        /// The area a face must exceed: `ZERO_AREA_REL` times the squared bounding-box diagonal.
        limit: f64,
    },
    /// A face uses the same three vertices as an earlier face.
    DuplicateFace {
        /// The later face.
        face: FaceId,
        /// The earlier face it duplicates.
        duplicate_of: FaceId,
        /// Its vertices.
        vertices: [VertexId; 3],
    },
    /// A vertex is used by no face.
    UnreferencedVertex {
        /// The vertex.
        vertex: VertexId,
    },
    /// An edge is shared by more than two faces.
    NonManifoldEdge {
        /// The edge's vertices.
        edge: [VertexId; 2],
        /// All faces on it.
        faces: Vec<FaceId>,
    },
    /// A vertex's faces form several separate fans (e.g. two cones touching at a tip).
    NonManifoldVertex {
        /// The vertex.
        vertex: VertexId,
        /// Number of fans.
        fans: usize,
    },
    /// Two faces traverse their shared edge in the same direction (fixable by flipping).
    InconsistentOrientation {
        /// The edge, in the direction both faces traverse it.
        edge: [VertexId; 2],
        /// The two faces.
        faces: [FaceId; 2],
    },
    /// No consistent orientation exists (a Möbius strip, a Klein bottle, ...).
    NonOrientable {
        /// Edge where the orientation conflict closes.
        edge: [VertexId; 2],
        /// The two faces meeting there.
        faces: [FaceId; 2],
    },
    /// The mesh has several connected components.
    MultipleComponents {
        /// Number of components.
        components: usize,
        /// Faces in the largest one.
        largest_faces: usize,
    },
}

impl Problem {
    /// The same problem with its vertices and faces renumbered by `vertex` and `face` (e.g.
    /// from a repaired mesh back to the input file's numbering, so that a message names the
    /// elements the user can find).
    pub fn renumbered(self, vertex: impl Fn(VertexId) -> VertexId, face: impl Fn(FaceId) -> FaceId) -> Problem {
        use Problem as P;
        match self {
            P::Empty | P::NothingLeftAfterRepair { .. } | P::MultipleComponents { .. } => self,
            P::NonFiniteCoordinate { vertex: v } => P::NonFiniteCoordinate { vertex: vertex(v) },
            P::RepeatedVertexInFace { face: f, vertices } => {
                P::RepeatedVertexInFace { face: face(f), vertices: vertices.map(&vertex) }
            }
            P::ZeroAreaFace { face: f, vertices, area, limit } => {
                P::ZeroAreaFace { face: face(f), vertices: vertices.map(&vertex), area, limit }
            }
            P::DuplicateFace { face: f, duplicate_of, vertices } => {
                P::DuplicateFace { face: face(f), duplicate_of: face(duplicate_of), vertices: vertices.map(&vertex) }
            }
            P::UnreferencedVertex { vertex: v } => P::UnreferencedVertex { vertex: vertex(v) },
            P::NonManifoldEdge { edge, faces } => {
                P::NonManifoldEdge { edge: edge.map(&vertex), faces: faces.into_iter().map(&face).collect() }
            }
            P::NonManifoldVertex { vertex: v, fans } => P::NonManifoldVertex { vertex: vertex(v), fans },
            P::InconsistentOrientation { edge, faces } => {
                P::InconsistentOrientation { edge: edge.map(&vertex), faces: faces.map(&face) }
            }
            P::NonOrientable { edge, faces } => P::NonOrientable { edge: edge.map(&vertex), faces: faces.map(&face) },
        }
    }

    /// Short machine-readable kind (the JSON `kind` tag).
    pub fn kind(&self) -> &'static str {
        match self {
            Problem::Empty => "empty",
            Problem::NothingLeftAfterRepair { .. } => "nothing_left_after_repair",
            Problem::NonFiniteCoordinate { .. } => "non_finite_coordinate",
            Problem::RepeatedVertexInFace { .. } => "repeated_vertex_in_face",
            Problem::ZeroAreaFace { .. } => "zero_area_face",
            Problem::DuplicateFace { .. } => "duplicate_face",
            Problem::UnreferencedVertex { .. } => "unreferenced_vertex",
            Problem::NonManifoldEdge { .. } => "non_manifold_edge",
            Problem::NonManifoldVertex { .. } => "non_manifold_vertex",
            Problem::InconsistentOrientation { .. } => "inconsistent_orientation",
            Problem::NonOrientable { .. } => "non_orientable",
            Problem::MultipleComponents { .. } => "multiple_components",
        }
    }

    /// How the user can get past this problem, if at all.
    pub fn remedy(&self) -> &'static str {
        match self {
            Problem::Empty => "the file holds no triangles",
            Problem::NothingLeftAfterRepair { .. } => {
                "not repairable: no face of the file spans an area (check the coordinates and the file's units)"
            }
            Problem::NonManifoldEdge { .. } => {
                "not repairable automatically: fix the model so every edge has at most two faces"
            }
            Problem::NonOrientable { .. } => {
                "not repairable: a fabric mold needs an orientable surface (an inside and an outside)"
            }
            Problem::MultipleComponents { .. } => "pass --largest-component to keep only the largest component",
            _ => "pass --repair to fix it",
        }
    }
}

fn vs(v: &[VertexId]) -> String {
    v.iter().map(|x| x.0.to_string()).collect::<Vec<_>>().join(", ")
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Problem::Empty => write!(f, "the mesh has no faces"),
            Problem::NothingLeftAfterRepair { faces, non_finite, degenerate, duplicate } => write!(
                f,
                "the repair dropped all {faces} faces of the file ({non_finite} with a non-finite coordinate, \
                 {degenerate} degenerate, {duplicate} duplicates)"
            ),
            Problem::NonFiniteCoordinate { vertex } => {
                write!(
                    f,
                    "vertex {vertex} has a non-finite coordinate (NaN or infinity, or beyond ±{:e})",
                    crate::soup::MAX_COORDINATE
                )
            }
            Problem::RepeatedVertexInFace { face, vertices } => {
                write!(f, "face {face} (vertices {}) uses a vertex twice", vs(vertices))
            }
            Problem::ZeroAreaFace { face, vertices, area, limit } => {
                write!(
                    f,
                    "face {face} (vertices {}) has (numerically) zero area: {area:.3e}, not above {limit:.3e} \
                     (10⁻¹⁴ of the squared bounding-box diagonal)",
                    vs(vertices)
                )
            }
            Problem::DuplicateFace { face, duplicate_of, vertices } => {
                write!(f, "face {face} duplicates face {duplicate_of} (vertices {})", vs(vertices))
            }
            Problem::UnreferencedVertex { vertex } => {
                write!(f, "vertex {vertex} is not used by any face")
            }
            Problem::NonManifoldEdge { edge, faces } => write!(
                f,
                "non-manifold edge ({}) is shared by {} faces ({})",
                vs(edge),
                faces.len(),
                faces.iter().map(|x| x.0.to_string()).collect::<Vec<_>>().join(", ")
            ),
            Problem::NonManifoldVertex { vertex, fans } => {
                write!(f, "non-manifold vertex {vertex}: its faces form {fans} separate fans")
            }
            Problem::InconsistentOrientation { edge, faces } => write!(
                f,
                "inconsistent orientation: faces {} and {} both traverse edge {}→{}",
                faces[0], faces[1], edge[0], edge[1]
            ),
            Problem::NonOrientable { edge, faces } => write!(
                f,
                "non-orientable surface: no consistent orientation exists (conflict at edge ({}) between faces {} and {})",
                vs(edge),
                faces[0],
                faces[1]
            ),
            Problem::MultipleComponents { components, largest_faces } => {
                write!(f, "{components} connected components (the largest has {largest_faces} faces)")
            }
        }
    }
}

/// Measurements and problems of a soup.
#[derive(Clone, Debug, Serialize)]
pub struct SoupAnalysis {
    /// Positions in the file.
    pub vertices: usize,
    /// Vertices used by at least one face.
    pub referenced_vertices: usize,
    /// Triangles (after fan triangulation).
    pub faces: usize,
    /// Undirected edges (of faces without repeated vertices).
    pub edges: usize,
    /// Edges with exactly one face.
    pub boundary_edges: usize,
    /// Vertex-connected components (of referenced vertices).
    pub components: usize,
    /// Faces per component.
    pub component_faces: Vec<usize>,
    /// Component of each face.
    #[serde(skip)]
    pub component_of_face: Vec<u32>,
    /// Boundary loops (None when a boundary vertex does not have exactly two boundary edges).
    pub boundary_loops: Option<usize>,
    /// V − E + F with V the referenced vertices.
    pub euler_characteristic: i64,
    /// Sum of component genera (None unless the soup is manifold and orientable).
    pub genus: Option<i64>,
    /// Bounding box.
    #[serde(skip)]
    pub bbox: Aabb,
    /// Every problem found, in a deterministic order.
    pub problems: Vec<Problem>,
}

impl SoupAnalysis {
    /// Problems that make the surface unusable (all of them except several components,
    /// which is a policy decision of the caller).
    pub fn blocking_problems(&self) -> impl Iterator<Item = &Problem> {
        self.problems.iter().filter(|p| !matches!(p, Problem::MultipleComponents { .. }))
    }
}

/// Halfedges of the soup grouped by undirected edge: `order[starts[e]..starts[e+1]]` are the
/// halfedges (`3f + k`, running corner k → k+1) of edge `e`, edges sorted by key.
pub(crate) struct EdgeGroups {
    pub order: Vec<u32>,
    pub starts: Vec<u32>,
}

pub(crate) fn group_edges(triangles: &[[u32; 3]], use_face: impl Fn(usize) -> bool) -> EdgeGroups {
    let mut keyed: Vec<(u64, u32)> = Vec::with_capacity(triangles.len() * 3);
    for (f, t) in triangles.iter().enumerate() {
        if !use_face(f) {
            continue;
        }
        for k in 0..3 {
            keyed.push((edge_key(t[k], t[(k + 1) % 3]), (3 * f + k) as u32));
        }
    }
    keyed.sort_unstable();
    let mut starts = Vec::with_capacity(keyed.len() / 2 + 1);
    for i in 0..keyed.len() {
        if i == 0 || keyed[i].0 != keyed[i - 1].0 {
            starts.push(i as u32);
        }
    }
    starts.push(keyed.len() as u32);
    EdgeGroups { order: keyed.into_iter().map(|(_, h)| h).collect(), starts }
}

impl EdgeGroups {
    pub fn n_edges(&self) -> usize {
        self.starts.len() - 1
    }
    pub fn halfedges(&self, e: usize) -> &[u32] {
        &self.order[self.starts[e] as usize..self.starts[e + 1] as usize]
    }
}

#[inline]
fn he_verts(tris: &[[u32; 3]], h: u32) -> (u32, u32) {
    let (f, k) = ((h / 3) as usize, (h % 3) as usize);
    (tris[f][k], tris[f][(k + 1) % 3])
}

/// Measure a soup and list every problem.
pub fn analyze(soup: &TriSoup) -> SoupAnalysis {
    let tris = &soup.triangles;
    let nv = soup.positions.len();
    let nf = tris.len();
    let bbox = soup.bbox();
    let diag = bbox.diagonal();
    let mut problems = Vec::new();
    if nf == 0 {
        problems.push(Problem::Empty);
    }

    let finite: Vec<bool> = soup.positions.iter().map(crate::soup::usable_point).collect();
    for (v, ok) in finite.iter().enumerate() {
        if !ok {
            problems.push(Problem::NonFiniteCoordinate { vertex: VertexId::new(v) });
        }
    }

    // Faces: repeated indices, zero area, duplicates. `topo[f]` marks faces that take part in
    // the topological analysis.
    let mut topo = vec![true; nf];
    let area_eps = ZERO_AREA_REL * diag * diag;
    for (f, t) in tris.iter().enumerate() {
        let vids = t.map(VertexId);
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            problems.push(Problem::RepeatedVertexInFace { face: FaceId::new(f), vertices: vids });
            topo[f] = false;
            continue;
        }
        if t.iter().all(|&v| finite[v as usize]) {
            let p = t.map(|v| soup.positions[v as usize]);
            let area = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
            if !(area > area_eps) {
                problems.push(Problem::ZeroAreaFace { face: FaceId::new(f), vertices: vids, area, limit: area_eps });
            }
        }
    }
    {
        let mut sorted: Vec<([u32; 3], u32)> = (0..nf)
            .filter(|&f| topo[f])
            .map(|f| {
                let mut k = tris[f];
                k.sort_unstable();
                (k, f as u32)
            })
            .collect();
        sorted.sort_unstable();
        let mut dups = Vec::new();
        for i in 1..sorted.len() {
            if sorted[i].0 == sorted[i - 1].0 {
                // The first of a run is the original.
                let mut j = i - 1;
                while j > 0 && sorted[j - 1].0 == sorted[i].0 {
                    j -= 1;
                }
                let (f, g) = (sorted[i].1 as usize, sorted[j].1 as usize);
                topo[f] = false;
                dups.push(Problem::DuplicateFace {
                    face: FaceId::new(f),
                    duplicate_of: FaceId::new(g),
                    vertices: tris[f].map(VertexId),
                });
            }
        }
        dups.sort_by_key(|p| match p {
            Problem::DuplicateFace { face, .. } => face.0,
            _ => 0,
        });
        problems.extend(dups);
    }

    let mut referenced = vec![false; nv];
    for t in tris {
        for &v in t {
            referenced[v as usize] = true;
        }
    }
    let n_ref = referenced.iter().filter(|&&r| r).count();
    for (v, r) in referenced.iter().enumerate() {
        if !r {
            problems.push(Problem::UnreferencedVertex { vertex: VertexId::new(v) });
        }
    }

    // Edges.
    let groups = group_edges(tris, |f| topo[f]);
    let ne = groups.n_edges();
    let mut boundary_edges = 0usize;
    let mut corner_uf = UnionFind::new(3 * nf);
    let mut on_nonmanifold_edge = vec![false; nv];
    // (face a, face b, same direction) for manifold interior edges
    let mut manifold_pairs: Vec<(u32, u32, bool, u32)> = Vec::new();
    for e in 0..ne {
        let hs = groups.halfedges(e);
        match hs.len() {
            1 => boundary_edges += 1,
            2 => {
                let (a0, a1) = he_verts(tris, hs[0]);
                let (b0, _b1) = he_verts(tris, hs[1]);
                let same = a0 == b0;
                let (fa, fb) = (hs[0] / 3, hs[1] / 3);
                manifold_pairs.push((fa, fb, same, hs[0]));
                // Join the fans at both endpoints: corner of face at vertex x.
                let corner_at = |h: u32, x: u32| -> u32 {
                    let f = h / 3;
                    let t = tris[f as usize];
                    3 * f + (0..3).find(|&k| t[k as usize] == x).unwrap_or(0)
                };
                for x in [a0, a1] {
                    corner_uf.union(corner_at(hs[0], x), corner_at(hs[1], x));
                }
            }
            _ => {
                let (a0, a1) = he_verts(tris, hs[0]);
                on_nonmanifold_edge[a0 as usize] = true;
                on_nonmanifold_edge[a1 as usize] = true;
                let mut faces: Vec<FaceId> = hs.iter().map(|&h| FaceId(h / 3)).collect();
                faces.sort_unstable();
                let (lo, hi) = if a0 < a1 { (a0, a1) } else { (a1, a0) };
                problems.push(Problem::NonManifoldEdge { edge: [VertexId(lo), VertexId(hi)], faces });
            }
        }
    }

    // Non-manifold vertices: count distinct fans among each vertex's corners.
    let mut has_nm_vertex = false;
    {
        let mut first_root = vec![u32::MAX; nv];
        let mut extra: Vec<(u32, u32)> = Vec::new(); // (vertex, root) beyond the first
        for f in 0..nf {
            if !topo[f] {
                continue;
            }
            for k in 0..3 {
                let v = tris[f][k];
                let r = corner_uf.find((3 * f + k) as u32);
                if first_root[v as usize] == u32::MAX {
                    first_root[v as usize] = r;
                } else if first_root[v as usize] != r {
                    extra.push((v, r));
                }
            }
        }
        extra.sort_unstable();
        extra.dedup();
        let mut i = 0;
        while i < extra.len() {
            let v = extra[i].0;
            let mut j = i;
            while j < extra.len() && extra[j].0 == v {
                j += 1;
            }
            if !on_nonmanifold_edge[v as usize] {
                problems.push(Problem::NonManifoldVertex { vertex: VertexId(v), fans: 1 + j - i });
            }
            has_nm_vertex |= !on_nonmanifold_edge[v as usize];
            i = j;
        }
    }
    let has_nm_edge = on_nonmanifold_edge.iter().any(|&b| b);

    // Orientation: 2-colour faces across manifold edges; colour = "flip this face".
    let mut orientable = true;
    {
        let mut adj_start = vec![0u32; nf + 1];
        for &(a, b, _, _) in &manifold_pairs {
            adj_start[a as usize + 1] += 1;
            adj_start[b as usize + 1] += 1;
        }
        for i in 0..nf {
            adj_start[i + 1] += adj_start[i];
        }
        let mut fill = adj_start.clone();
        let mut adj = vec![(0u32, false, 0u32); 2 * manifold_pairs.len()];
        for &(a, b, same, h) in &manifold_pairs {
            adj[fill[a as usize] as usize] = (b, same, h);
            fill[a as usize] += 1;
            adj[fill[b as usize] as usize] = (a, same, h);
            fill[b as usize] += 1;
        }
        let mut flip = vec![u8::MAX; nf];
        let mut stack = Vec::new();
        let mut comp_conflict: Vec<Problem> = Vec::new();
        let mut inconsistent: Vec<Problem> = Vec::new();
        for seed in 0..nf {
            if !topo[seed] || flip[seed] != u8::MAX {
                continue;
            }
            flip[seed] = 0;
            stack.push(seed as u32);
            let mut conflict: Option<Problem> = None;
            let mut comp_inconsistent = Vec::new();
            while let Some(f) = stack.pop() {
                let fl = flip[f as usize];
                for &(g, same, h) in &adj[adj_start[f as usize] as usize..adj_start[f as usize + 1] as usize] {
                    let want = fl ^ (same as u8);
                    if flip[g as usize] == u8::MAX {
                        flip[g as usize] = want;
                        stack.push(g);
                    } else if flip[g as usize] != want && conflict.is_none() {
                        let (x, y) = he_verts(tris, h);
                        let (lo, hi) = if x < y { (x, y) } else { (y, x) };
                        let (fa, fb) = if f < g { (f, g) } else { (g, f) };
                        conflict = Some(Problem::NonOrientable {
                            edge: [VertexId(lo), VertexId(hi)],
                            faces: [FaceId(fa), FaceId(fb)],
                        });
                    }
                    if same && f < g {
                        let (x, y) = he_verts(tris, h);
                        comp_inconsistent.push(Problem::InconsistentOrientation {
                            edge: [VertexId(x), VertexId(y)],
                            faces: [FaceId(f), FaceId(g)],
                        });
                    }
                }
            }
            match conflict {
                Some(p) => {
                    orientable = false;
                    comp_conflict.push(p);
                }
                None => inconsistent.extend(comp_inconsistent),
            }
        }
        inconsistent.sort_by_key(|p| match p {
            Problem::InconsistentOrientation { faces, .. } => (faces[0].0, faces[1].0),
            _ => (0, 0),
        });
        problems.extend(inconsistent);
        problems.extend(comp_conflict);
    }

    // Components (vertex-connected), counted over referenced vertices.
    let mut vuf = UnionFind::new(nv);
    for t in tris {
        vuf.union(t[0], t[1]);
        vuf.union(t[1], t[2]);
    }
    let mut comp_label = vec![u32::MAX; nv];
    let mut n_comp = 0u32;
    let mut component_of_face = vec![0u32; nf];
    for (f, t) in tris.iter().enumerate() {
        let r = vuf.find(t[0]) as usize;
        if comp_label[r] == u32::MAX {
            comp_label[r] = n_comp;
            n_comp += 1;
        }
        component_of_face[f] = comp_label[r];
    }
    let n_comp = n_comp as usize;
    let mut component_faces = vec![0usize; n_comp];
    for &c in &component_of_face {
        component_faces[c as usize] += 1;
    }
    if n_comp > 1 {
        problems.push(Problem::MultipleComponents {
            components: n_comp,
            largest_faces: component_faces.iter().copied().max().unwrap_or(0),
        });
    }

    // Boundary loops: components of the boundary-edge graph, defined when every boundary
    // vertex has exactly two boundary edges.
    let mut bdeg = vec![0u32; nv];
    let mut buf = UnionFind::new(nv);
    let mut comp_loops = vec![0i64; n_comp];
    for e in 0..ne {
        let hs = groups.halfedges(e);
        if hs.len() == 1 {
            let (a, b) = he_verts(tris, hs[0]);
            bdeg[a as usize] += 1;
            bdeg[b as usize] += 1;
            buf.union(a, b);
        }
    }
    let boundary_loops = if bdeg.iter().all(|&d| d == 0 || d == 2) {
        let mut seen = vec![false; nv];
        let mut loops = 0usize;
        for v in 0..nv {
            if bdeg[v] == 2 {
                let r = buf.find(v as u32) as usize;
                if !seen[r] {
                    seen[r] = true;
                    loops += 1;
                    let c = comp_label[vuf.find(v as u32) as usize];
                    comp_loops[c as usize] += 1;
                }
            }
        }
        Some(loops)
    } else {
        None
    };

    let euler = n_ref as i64 - ne as i64 + topo.iter().filter(|&&t| t).count() as i64;

    // Genus per component when the surface is a manifold, orientable one.
    let genus = if orientable && !has_nm_edge && !has_nm_vertex && boundary_loops.is_some() && nf > 0 {
        let mut cv = vec![0i64; n_comp];
        let mut ce = vec![0i64; n_comp];
        let mut cf = vec![0i64; n_comp];
        for v in 0..nv {
            if referenced[v] {
                cv[comp_label[vuf.find(v as u32) as usize] as usize] += 1;
            }
        }
        for e in 0..ne {
            let (a, _) = he_verts(tris, groups.halfedges(e)[0]);
            ce[comp_label[vuf.find(a) as usize] as usize] += 1;
        }
        for f in 0..nf {
            if topo[f] {
                cf[component_of_face[f] as usize] += 1;
            }
        }
        let mut g = 0i64;
        for c in 0..n_comp {
            let chi = cv[c] - ce[c] + cf[c];
            g += (2 - chi - comp_loops[c]) / 2;
        }
        Some(g)
    } else {
        None
    };

    SoupAnalysis {
        vertices: nv,
        referenced_vertices: n_ref,
        faces: nf,
        edges: ne,
        boundary_edges,
        components: n_comp,
        component_faces,
        component_of_face,
        boundary_loops,
        euler_characteristic: euler,
        genus,
        bbox,
        problems,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec3;

    fn tet() -> TriSoup {
        TriSoup::from_triangles(
            vec![Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(0., 1., 0.), Vec3::new(0., 0., 1.)],
            vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]],
        )
    }

    #[test]
    fn clean_tetrahedron() {
        let a = analyze(&tet());
        assert!(a.problems.is_empty(), "{:?}", a.problems);
        assert_eq!((a.referenced_vertices, a.edges, a.faces), (4, 6, 4));
        assert_eq!(a.euler_characteristic, 2);
        assert_eq!(a.genus, Some(0));
        assert_eq!(a.boundary_loops, Some(0));
    }

    #[test]
    fn flipped_face_is_inconsistent() {
        let mut s = tet();
        s.triangles[1] = [0, 3, 1];
        let a = analyze(&s);
        assert!(a.problems.iter().all(|p| matches!(p, Problem::InconsistentOrientation { .. })));
        assert_eq!(a.problems.len(), 3);
    }

    #[test]
    fn fan_of_three_is_nonmanifold_edge() {
        let s = TriSoup::from_triangles(
            vec![
                Vec3::new(0., 0., 0.),
                Vec3::new(1., 0., 0.),
                Vec3::new(0., 1., 0.),
                Vec3::new(0., -1., 0.),
                Vec3::new(0., 0., 1.),
            ],
            vec![[0, 1, 2], [0, 1, 3], [0, 1, 4]],
        );
        let a = analyze(&s);
        assert!(a.problems.contains(&Problem::NonManifoldEdge {
            edge: [VertexId(0), VertexId(1)],
            faces: vec![FaceId(0), FaceId(1), FaceId(2)]
        }));
        assert!(!a.problems.iter().any(|p| matches!(p, Problem::NonManifoldVertex { .. })));
    }

    #[test]
    fn bowtie_is_nonmanifold_vertex() {
        let s = TriSoup::from_triangles(
            vec![
                Vec3::new(0., 0., 0.),
                Vec3::new(1., 0., 0.),
                Vec3::new(1., 1., 0.),
                Vec3::new(-1., 0., 0.),
                Vec3::new(-1., -1., 0.),
            ],
            vec![[0, 1, 2], [0, 3, 4]],
        );
        let a = analyze(&s);
        assert_eq!(a.problems, vec![Problem::NonManifoldVertex { vertex: VertexId(0), fans: 2 }]);
        assert_eq!(a.components, 1);
        assert_eq!(a.boundary_loops, None);
    }

    #[test]
    fn degenerate_duplicate_unreferenced() {
        let mut s = tet();
        s.positions.push(Vec3::new(5., 5., 5.));
        s.positions.push(Vec3::new(f64::NAN, 0., 0.));
        s.triangles.push([1, 1, 2]);
        s.triangles.push([2, 1, 0]);
        let a = analyze(&s);
        let kinds: Vec<_> = a.problems.iter().map(|p| p.kind()).collect();
        assert!(kinds.contains(&"repeated_vertex_in_face"));
        assert!(kinds.contains(&"duplicate_face"));
        assert!(kinds.contains(&"unreferenced_vertex"));
        assert!(kinds.contains(&"non_finite_coordinate"));
    }

    /// A tetrahedron stretched to 1e300 (a corrupt file): its vertices are refused as out of
    /// range, not its faces as degenerate (their areas overflow to infinity); at 1e11 it is a
    /// valid, if absurd, mesh.
    #[test]
    fn coordinates_out_of_range_are_refused() {
        for (scale, bad) in [(1e300, 3), (1e11, 0)] {
            let mut s = tet();
            for p in &mut s.positions {
                *p *= scale;
            }
            let a = analyze(&s);
            let kinds: Vec<_> = a.problems.iter().map(|p| p.kind()).collect();
            assert_eq!(kinds.iter().filter(|&&k| k == "non_finite_coordinate").count(), bad, "{scale}: {kinds:?}");
            assert!(!kinds.contains(&"zero_area_face"), "{scale}: {kinds:?}");
        }
    }
}
