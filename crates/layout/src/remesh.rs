//! Remeshing along seams: insert polylines of surface points into a mesh so that every polyline
//! becomes a path of mesh edges (ALGORITHMS.md §7 "Remeshing along seams").
//!
//! The construction is a common subdivision of the input mesh and the polylines, the idea of
//! geometry-central's `CommonSubdivision` (no code copied), specialised to extrinsic polylines
//! whose points lie on input vertices or edges:
//!
//! 1. Edge points within `snap` × edge length of an edge end (at least [`MIN_SNAP`]) become that
//!    vertex (no sliver next to a vertex); points on the same edge at nearly the same parameter (two polylines meeting,
//!    round-off) become one new vertex; consecutive duplicates collapse.
//! 2. Consecutive points on a common input edge are joined along that edge (through every new
//!    vertex between them); otherwise they are the ends of a straight chord across their common
//!    input face.
//! 3. Every input face with new vertices on its sides is a convex polygon (the triangle with
//!    its side points); its chords, which may not cross, split it into convex pieces. The split
//!    is combinatorial (a chord goes into the piece holding both its ends), and so is the
//!    collinearity test: points are collinear exactly when they share a side of the input face,
//!    since a chord line meets the triangle's boundary only at its two ends.
//! 4. Each piece is triangulated by clipping ears (best minimum angle first, never a collinear
//!    ear), then the face's non-chord interior edges are flipped until locally Delaunay (Lawson),
//!    which maximises the minimum angle within each piece. Edges on input edges or chords are
//!    never flipped, so every new triangle lies in one input face and the surface is unchanged.
//!
//! Preconditions (checked where cheap, else [`LayoutError::InvalidPath`]): every polyline has at
//! least two points, ids are in range, edge parameters lie in (0, 1), consecutive points lie in a
//! common input face, and polylines do not cross (crossings inside a face are detected) and
//! touch only at vertices.
//!
//! Complexity: O(V + F + E + N log N) for N polyline points, plus O(m²) per touched face with m
//! new points on its boundary (m is a handful for seams).
//!
//! Quality: each piece gets its Delaunay (max-min angle) triangulation, so the minimum new angle is
//! set by where the points fall. The worst case with the default snap of 0.1 is a side point at
//! 0.1 × the side from a corner, seen from the opposite corner: ≈ 5.2° in an equilateral face,
//! ≈ 3.0° in a right isosceles (grid) face, less in faces that are already thin. Seams running
//! nearly parallel to an input edge or to each other at a small distance leave thin strips that
//! no triangulation with vertices on input edges only can fix. Measured (tests/remesh.rs): 3.1°
//! on grids, 4.4° on icospheres, 3.1° on the bunny.

use std::collections::{BTreeMap, BTreeSet};
use std::f64::consts::PI;

use clothcast_mesh::geometry::angle_at;
use clothcast_mesh::{EdgeId, FaceData, FaceId, Mesh, Vec3, VertexData, VertexId};

use crate::{LayoutError, SurfacePoint};

/// Edge points of the same edge whose parameters differ by less than this are one vertex.
const MERGE_T: f64 = 1e-6;

/// The least snap, whatever the options ask: a point this close to an edge end (share of the
/// edge) is that vertex. Without it, `snap = 0` kept crossings 10⁻¹² of an edge from its end
/// and made faces of zero area (the 436-face cylinder: "remeshing produced an invalid mesh").
/// A piece's worst triangle is then about 10⁻⁸ of its input face (two points this close to
/// one corner), well above the mesh's zero-area threshold.
pub const MIN_SNAP: f64 = 1e-4;

/// Options of the remeshing.
#[derive(Clone, Debug)]
pub struct RemeshOptions {
    /// A polyline point closer than this fraction of its edge's length to an edge end is snapped
    /// to that vertex (clamped to [[`MIN_SNAP`], 0.5]; a non-finite value means the least
    /// snap, [`MIN_SNAP`]).
    pub snap: f64,
}

impl Default for RemeshOptions {
    fn default() -> Self {
        Self { snap: 0.1 }
    }
}

/// The remeshed surface.
pub struct Remeshed {
    /// The new mesh: same surface, every polyline an edge path.
    pub mesh: Mesh,
    /// For each new face, the input face it lies in.
    pub face_parent: FaceData<FaceId>,
    /// For each new vertex, where it lies on the input mesh (`Vertex` for input vertices, `Edge`
    /// for inserted points).
    pub vertex_parent: VertexData<SurfacePoint>,
    /// For each new vertex that is an input vertex, its input id (None for inserted vertices).
    pub vertex_input: VertexData<Option<VertexId>>,
    /// Each input polyline as a vertex path of the new mesh (consecutive vertices joined by a
    /// new-mesh edge).
    pub paths: Vec<Vec<VertexId>>,
}

impl Remeshed {
    /// Per-vertex data carried over to the new mesh: input vertices keep theirs, inserted ones
    /// get `fill`.
    pub fn carry<T: Clone>(&self, data: &VertexData<T>, fill: T) -> VertexData<T> {
        self.vertex_input.map(|v| v.map_or_else(|| fill.clone(), |v| data[v].clone()))
    }
}

fn invalid(path: usize, reason: impl Into<String>) -> LayoutError {
    LayoutError::InvalidPath { path, reason: reason.into() }
}

/// Insert the polylines into the mesh.
///
/// New vertices `0..mesh.n_vertices()` are the input vertices; inserted vertices follow, by
/// edge id and then parameter. New faces follow the input faces' order (untouched faces keep
/// their corners, touched faces are replaced by their pieces).
pub fn insert_polylines(
    mesh: &Mesh,
    polylines: &[Vec<SurfacePoint>],
    options: &RemeshOptions,
) -> Result<Remeshed, LayoutError> {
    let snap = if options.snap.is_finite() { options.snap.clamp(MIN_SNAP, 0.5) } else { MIN_SNAP };
    let n_in = mesh.n_vertices();

    // 1. Validate, snap, collect edge points.
    let mut snapped: Vec<Vec<SurfacePoint>> = Vec::with_capacity(polylines.len());
    let mut edge_points: Vec<(EdgeId, f64, usize, usize)> = Vec::new();
    for (k, line) in polylines.iter().enumerate() {
        if line.len() < 2 {
            return Err(invalid(k, format!("a polyline needs at least 2 points, got {}", line.len())));
        }
        for (i, p) in line.iter().enumerate() {
            check_point(mesh, k, i, p)?;
        }
        for (i, w) in line.windows(2).enumerate() {
            if common_face(mesh, &w[0], &w[1]).is_none() {
                return Err(invalid(
                    k,
                    format!("points {i} and {} ({:?}, {:?}) lie in no common face", i + 1, w[0], w[1]),
                ));
            }
        }
        let s: Vec<SurfacePoint> = line.iter().map(|p| snap_point(mesh, *p, snap)).collect();
        for (i, p) in s.iter().enumerate() {
            if let SurfacePoint::Edge { edge, t } = *p {
                edge_points.push((edge, t, k, i));
            }
        }
        snapped.push(s);
    }

    // 2. Merge edge points into new vertices, numbered by edge, then parameter.
    edge_points.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)).then(a.3.cmp(&b.3)));
    let mut vertex_parent: Vec<SurfacePoint> = mesh.vertices().map(SurfacePoint::Vertex).collect();
    let mut edge_verts: Vec<Vec<(f64, u32)>> = vec![Vec::new(); mesh.n_edges()];
    let mut ids: Vec<Vec<u32>> = snapped
        .iter()
        .map(|s| s.iter().map(|p| if let SurfacePoint::Vertex(v) = p { v.0 } else { 0 }).collect())
        .collect();
    let mut run: Option<(EdgeId, f64)> = None;
    for &(edge, t, k, i) in &edge_points {
        let same = run.is_some_and(|(e0, t0)| e0 == edge && t - t0 < MERGE_T);
        if !same {
            run = Some((edge, t));
            let id = u32::try_from(vertex_parent.len()).map_err(|_| invalid(k, "too many vertices"))?;
            vertex_parent.push(SurfacePoint::Edge { edge, t });
            edge_verts[edge.idx()].push((t, id));
        }
        ids[k][i] = (vertex_parent.len() - 1) as u32;
    }
    let positions: Vec<Vec3> = vertex_parent.iter().map(|p| p.position(mesh)).collect();

    // 3. Paths, and chords grouped by face.
    let mut paths = Vec::with_capacity(polylines.len());
    let mut chords: Vec<(FaceId, u32, u32, usize)> = Vec::new();
    for (k, line) in ids.iter().enumerate() {
        let mut seq = line.clone();
        seq.dedup();
        let mut path = vec![VertexId(seq[0])];
        for w in seq.windows(2) {
            let (a, b) = (w[0], w[1]);
            let (pa, pb) = (vertex_parent[a as usize], vertex_parent[b as usize]);
            if let Some(e) = common_edge(mesh, &pa, &pb) {
                let (ta, tb) = (param_on(mesh, e, &pa), param_on(mesh, e, &pb));
                let (lo, hi) = (ta.min(tb), ta.max(tb));
                let inner = edge_verts[e.idx()].iter().filter(|&&(t, id)| t > lo && t < hi && id != a && id != b);
                if ta < tb {
                    path.extend(inner.map(|&(_, id)| VertexId(id)));
                } else {
                    path.extend(inner.rev().map(|&(_, id)| VertexId(id)));
                }
            } else if let Some(f) = common_face(mesh, &pa, &pb) {
                chords.push((f, a.min(b), a.max(b), k));
            } else {
                return Err(invalid(k, format!("snapped points {pa:?} and {pb:?} lie in no common face")));
            }
            path.push(VertexId(b));
        }
        paths.push(path);
    }
    chords.sort_by_key(|&(f, a, b, k)| (f, a, b, k));
    chords.dedup_by_key(|c| (c.0, c.1, c.2));

    // 4. Split and triangulate the touched faces.
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(mesh.n_faces() + 4 * chords.len());
    let mut face_parent: Vec<FaceId> = Vec::with_capacity(triangles.capacity());
    let mut ci = 0;
    for f in mesh.face_ids() {
        let start = ci;
        while ci < chords.len() && chords[ci].0 == f {
            ci += 1;
        }
        let touched = (0..3).any(|k| !edge_verts[mesh.edge(mesh.face_halfedge(f, k)).idx()].is_empty());
        if !touched {
            triangles.push(mesh.face_vertices(f).map(|v| v.0));
            face_parent.push(f);
            continue;
        }
        let before = triangles.len();
        split_face(mesh, f, &edge_verts, &chords[start..ci], &positions, &mut triangles)?;
        face_parent.resize(face_parent.len() + triangles.len() - before, f);
    }

    let new_mesh = Mesh::try_new(positions, triangles)?;
    let vertex_input = (0..vertex_parent.len()).map(|i| (i < n_in).then_some(VertexId(i as u32))).collect();
    Ok(Remeshed {
        mesh: new_mesh,
        face_parent: FaceData::from_vec(face_parent),
        vertex_parent: VertexData::from_vec(vertex_parent),
        vertex_input,
        paths,
    })
}

/// Ids in range and edge parameters in (0, 1).
fn check_point(mesh: &Mesh, k: usize, i: usize, p: &SurfacePoint) -> Result<(), LayoutError> {
    match *p {
        SurfacePoint::Vertex(v) if v.idx() >= mesh.n_vertices() => {
            Err(invalid(k, format!("point {i}: vertex {v} out of range ({} vertices)", mesh.n_vertices())))
        }
        SurfacePoint::Edge { edge, .. } if edge.idx() >= mesh.n_edges() => {
            Err(invalid(k, format!("point {i}: edge {edge} out of range ({} edges)", mesh.n_edges())))
        }
        SurfacePoint::Edge { t, .. } if !(t > 0.0 && t < 1.0) => {
            Err(invalid(k, format!("point {i}: edge parameter {t} not in (0, 1)")))
        }
        _ => Ok(()),
    }
}

/// An edge point within `snap` of an end becomes that end.
fn snap_point(mesh: &Mesh, p: SurfacePoint, snap: f64) -> SurfacePoint {
    match p {
        SurfacePoint::Edge { edge, t } if t < snap => SurfacePoint::Vertex(mesh.edge_vertices(edge)[0]),
        SurfacePoint::Edge { edge, t } if t > 1.0 - snap => SurfacePoint::Vertex(mesh.edge_vertices(edge)[1]),
        _ => p,
    }
}

/// Parameter of a point lying on edge `e` (0 or 1 for its endpoints).
fn param_on(mesh: &Mesh, e: EdgeId, p: &SurfacePoint) -> f64 {
    match *p {
        SurfacePoint::Vertex(v) => {
            if mesh.edge_vertices(e)[0] == v {
                0.0
            } else {
                1.0
            }
        }
        SurfacePoint::Edge { t, .. } => t,
    }
}

/// The edge joining two vertices, if any.
fn edge_between(mesh: &Mesh, u: VertexId, w: VertexId) -> Option<EdgeId> {
    for h in mesh.outgoing(u) {
        if mesh.head(h) == w {
            return Some(mesh.edge(h));
        }
        let p = mesh.prev(h);
        if mesh.tail(p) == w {
            return Some(mesh.edge(p));
        }
    }
    None
}

/// The input edge both points lie on, if any (two distinct vertices: the edge joining them).
fn common_edge(mesh: &Mesh, a: &SurfacePoint, b: &SurfacePoint) -> Option<EdgeId> {
    use SurfacePoint::{Edge, Vertex};
    match (*a, *b) {
        (Vertex(u), Vertex(w)) => edge_between(mesh, u, w),
        (Vertex(u), Edge { edge, .. }) | (Edge { edge, .. }, Vertex(u)) => {
            mesh.edge_vertices(edge).contains(&u).then_some(edge)
        }
        (Edge { edge: e1, .. }, Edge { edge: e2, .. }) => (e1 == e2).then_some(e1),
    }
}

/// The faces whose closure holds a point.
fn point_faces(mesh: &Mesh, p: &SurfacePoint) -> Vec<FaceId> {
    match *p {
        SurfacePoint::Vertex(v) => mesh.vertex_faces(v).collect(),
        SurfacePoint::Edge { edge, .. } => {
            let (f, g) = mesh.edge_faces(edge);
            std::iter::once(f).chain(g).collect()
        }
    }
}

/// The lowest-id input face holding both points, if any.
fn common_face(mesh: &Mesh, a: &SurfacePoint, b: &SurfacePoint) -> Option<FaceId> {
    let fb = point_faces(mesh, b);
    point_faces(mesh, a).into_iter().filter(|f| fb.contains(f)).min()
}

/// Split input face `f` along its chords and triangulate the pieces, appending to `out`.
fn split_face(
    mesh: &Mesh,
    f: FaceId,
    edge_verts: &[Vec<(f64, u32)>],
    chords: &[(FaceId, u32, u32, usize)],
    positions: &[Vec3],
    out: &mut Vec<[u32; 3]>,
) -> Result<(), LayoutError> {
    // Boundary cycle, counter-clockwise, with the sides (bit k: halfedge k) each point lies on.
    let fv = mesh.face_vertices(f);
    let mut ids: Vec<u32> = Vec::new();
    let mut side: Vec<u8> = Vec::new();
    for (k, v) in fv.iter().enumerate() {
        ids.push(v.0);
        side.push(1 << k | 1 << ((k + 2) % 3));
        let h = mesh.face_halfedge(f, k);
        let e = mesh.edge(h);
        let list = &edge_verts[e.idx()];
        let along: Vec<u32> = if mesh.edge_halfedge(e) == h {
            list.iter().map(|&(_, id)| id).collect()
        } else {
            list.iter().rev().map(|&(_, id)| id).collect()
        };
        side.extend(std::iter::repeat_n(1u8 << k, along.len()));
        ids.extend(along);
    }
    let p: Vec<Vec3> = ids.iter().map(|&i| positions[i as usize]).collect();
    let fp = mesh.face_positions(f);
    let normal = (fp[1] - fp[0]).cross(&(fp[2] - fp[0]));

    // Split into convex pieces, one chord at a time.
    let mut pieces: Vec<Vec<usize>> = vec![(0..ids.len()).collect()];
    let mut constrained = BTreeSet::new();
    for &(_, a, b, k) in chords {
        let (Some(la), Some(lb)) = (ids.iter().position(|&x| x == a), ids.iter().position(|&x| x == b)) else {
            return Err(invalid(k, format!("segment {a}-{b} does not end on the boundary of face {f}")));
        };
        if side[la] & side[lb] != 0 {
            continue; // along a side: already edges
        }
        let found = pieces.iter().enumerate().find_map(|(pi, piece)| {
            let ia = piece.iter().position(|&x| x == la)?;
            let ib = piece.iter().position(|&x| x == lb)?;
            Some((pi, ia.min(ib), ia.max(ib)))
        });
        let Some((pi, i, j)) = found else {
            return Err(invalid(k, format!("polylines cross inside input face {f}")));
        };
        let piece = std::mem::take(&mut pieces[pi]);
        if j == i + 1 || (i == 0 && j == piece.len() - 1) {
            pieces[pi] = piece; // already a side of the piece
            continue;
        }
        pieces[pi] = piece[i..=j].to_vec();
        pieces.push(piece[j..].iter().chain(&piece[..=i]).copied().collect());
        constrained.insert((la.min(lb), la.max(lb)));
    }

    let mut tris: Vec<[usize; 3]> = Vec::new();
    for piece in &pieces {
        if !triangulate_convex(piece, &side, &p, &mut tris) {
            let k = chords.first().map_or(0, |c| c.3);
            return Err(invalid(k, format!("a piece of input face {f} could not be triangulated")));
        }
    }
    delaunay_flips(&mut tris, &constrained, &side, &p, &normal);
    out.extend(tris.iter().map(|t| t.map(|i| ids[i])));
    Ok(())
}

/// Smallest angle of a triangle.
fn min_angle(a: &Vec3, b: &Vec3, c: &Vec3) -> f64 {
    angle_at(a, b, c).min(angle_at(b, c, a)).min(angle_at(c, a, b))
}

/// Triangulate a convex polygon (local indices, counter-clockwise) by clipping the ear of
/// largest minimum angle among those that are not collinear and leave a non-collinear rest.
/// Returns false if stuck (impossible for a piece with three non-collinear points).
fn triangulate_convex(piece: &[usize], side: &[u8], p: &[Vec3], tris: &mut Vec<[usize; 3]>) -> bool {
    let mut poly = piece.to_vec();
    while poly.len() > 3 {
        let n = poly.len();
        let mut pre = vec![u8::MAX; n + 1];
        let mut suf = vec![u8::MAX; n + 1];
        for i in 0..n {
            pre[i + 1] = pre[i] & side[poly[i]];
            suf[n - 1 - i] = suf[n - i] & side[poly[n - 1 - i]];
        }
        let mut best: Option<(f64, usize)> = None;
        for i in 0..n {
            let (u, v, w) = (poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n]);
            if side[u] & side[v] & side[w] != 0 || pre[i] & suf[i + 1] != 0 {
                continue;
            }
            let q = min_angle(&p[u], &p[v], &p[w]);
            if best.is_none_or(|(bq, _)| q > bq) {
                best = Some((q, i));
            }
        }
        let Some((_, i)) = best else { return false };
        tris.push([poly[(i + n - 1) % n], poly[i], poly[(i + 1) % n]]);
        poly.remove(i);
    }
    if poly.len() < 3 || side[poly[0]] & side[poly[1]] & side[poly[2]] != 0 {
        return false;
    }
    tris.push([poly[0], poly[1], poly[2]]);
    true
}

/// Lawson flips of the unconstrained interior edges of one input face until every one is
/// locally Delaunay (opposite angles sum to at most π). Flips that would make a collinear or
/// inverted triangle are skipped.
fn delaunay_flips(
    tris: &mut [[usize; 3]],
    constrained: &BTreeSet<(usize, usize)>,
    side: &[u8],
    p: &[Vec3],
    normal: &Vec3,
) {
    let mut map: BTreeMap<(usize, usize), (usize, usize)> = BTreeMap::new();
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            map.insert((tri[k], tri[(k + 1) % 3]), (t, k));
        }
    }
    let mut stack: Vec<(usize, usize)> =
        map.keys().filter(|&&(a, b)| a < b && map.contains_key(&(b, a))).copied().collect();
    stack.reverse();
    let tol = 1e-12 * normal.norm_squared();
    let orient = |x: usize, y: usize, z: usize| (p[y] - p[x]).cross(&(p[z] - p[x])).dot(normal);
    let mut budget = 16 * tris.len() * tris.len() + 64;
    while let Some((a, b)) = stack.pop() {
        if constrained.contains(&(a, b)) {
            continue;
        }
        let (Some(&(t1, k1)), Some(&(t2, k2))) = (map.get(&(a, b)), map.get(&(b, a))) else { continue };
        let c = tris[t1][(k1 + 2) % 3];
        let d = tris[t2][(k2 + 2) % 3];
        if side[c] & side[d] & side[b] != 0 || side[c] & side[a] & side[d] != 0 {
            continue;
        }
        if orient(d, b, c) <= tol || orient(c, a, d) <= tol {
            continue;
        }
        if angle_at(&p[c], &p[a], &p[b]) + angle_at(&p[d], &p[b], &p[a]) <= PI + 1e-12 {
            continue;
        }
        if budget == 0 {
            break;
        }
        budget -= 1;
        for key in [(a, b), (b, c), (c, a), (b, a), (a, d), (d, b)] {
            map.remove(&key);
        }
        tris[t1] = [d, b, c];
        tris[t2] = [c, a, d];
        for t in [t1, t2] {
            for k in 0..3 {
                map.insert((tris[t][k], tris[t][(k + 1) % 3]), (t, k));
            }
        }
        for (x, y) in [(b, c), (c, a), (a, d), (d, b)] {
            stack.push((x.min(y), x.max(y)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The point at fraction `s` from `a` to `b` on their edge.
    fn on(m: &Mesh, a: u32, b: u32, s: f64) -> SurfacePoint {
        let edge = edge_between(m, VertexId(a), VertexId(b)).unwrap();
        let t = if m.edge_vertices(edge)[0] == VertexId(a) { s } else { 1.0 - s };
        SurfacePoint::Edge { edge, t }
    }

    fn is_edge(m: &Mesh, a: VertexId, b: VertexId) -> bool {
        edge_between(m, a, b).is_some()
    }

    #[test]
    fn chord_across_square() {
        let m = clothcast_mesh::shapes::unit_square();
        let line = vec![on(&m, 0, 1, 0.5), on(&m, 0, 2, 0.5), on(&m, 2, 3, 0.5)];
        let r = insert_polylines(&m, &[line], &RemeshOptions::default()).unwrap();
        assert_eq!(r.mesh.n_vertices(), 7);
        assert_eq!(r.mesh.n_faces(), 6);
        assert_eq!(r.mesh.euler_characteristic(), 1);
        assert_eq!(r.face_parent.as_slice(), &[FaceId(0), FaceId(0), FaceId(0), FaceId(1), FaceId(1), FaceId(1)]);
        let path = &r.paths[0];
        assert_eq!(path.len(), 3);
        let pos: Vec<Vec3> = path.iter().map(|&v| r.mesh.position(v)).collect();
        assert_eq!(pos, vec![Vec3::new(0.5, 0., 0.), Vec3::new(0.5, 0.5, 0.), Vec3::new(0.5, 1., 0.)]);
        assert!(path.windows(2).all(|w| is_edge(&r.mesh, w[0], w[1])));
        assert!((r.mesh.total_area() - 1.0).abs() < 1e-15);
        // Inserted vertices by edge id, then parameter.
        let keys: Vec<(EdgeId, f64)> = (4..7)
            .map(|i| match r.vertex_parent[VertexId(i)] {
                SurfacePoint::Edge { edge, t } => (edge, t),
                SurfacePoint::Vertex(_) => panic!("inserted vertex {i} has a vertex parent"),
            })
            .collect();
        assert!(keys.windows(2).all(|w| w[0].0 < w[1].0));
        assert_eq!(r.vertex_input.as_slice()[..4], [0, 1, 2, 3].map(|i| Some(VertexId(i))));
        assert!(r.vertex_input.as_slice()[4..].iter().all(Option::is_none));
        // Every piece is cut into right isosceles triangles.
        assert!((r.mesh.min_angle().to_degrees() - 45.0).abs() < 1e-9, "{}", r.mesh.min_angle().to_degrees());
    }

    #[test]
    fn snapping_and_merging() {
        let m = clothcast_mesh::shapes::unit_square();
        // Near vertex 1 on edge 0-1: snapped; the chord from vertex 1 to the diagonal point stays.
        let line = vec![on(&m, 0, 1, 0.95), on(&m, 0, 2, 0.5), on(&m, 2, 3, 0.5)];
        let r = insert_polylines(&m, std::slice::from_ref(&line), &RemeshOptions::default()).unwrap();
        assert_eq!(r.paths[0][0], VertexId(1));
        assert_eq!(r.mesh.n_vertices(), 6);
        // Without snapping the point is inserted.
        let r = insert_polylines(&m, std::slice::from_ref(&line), &RemeshOptions { snap: 0.0 }).unwrap();
        assert_eq!(r.mesh.n_vertices(), 7);
        assert!(r.paths[0][0].idx() >= 4);
        // Not even without snapping is a point next to a vertex inserted: it would make a face
        // of (numerically) zero area.
        for t in [1e-12, 0.5 * MIN_SNAP, 1.0 - 1e-12] {
            let line = vec![on(&m, 0, 1, t), on(&m, 0, 2, 0.5), on(&m, 2, 3, 0.5)];
            let r = insert_polylines(&m, std::slice::from_ref(&line), &RemeshOptions { snap: 0.0 }).unwrap();
            assert_eq!(r.mesh.n_vertices(), 6, "{t}");
            assert!(r.paths[0][0].idx() < 4, "{t}");
        }
        // Two polylines meeting at (nearly) the same edge point share its vertex.
        let a = vec![on(&m, 0, 1, 0.5), on(&m, 0, 2, 0.5)];
        let mut b = vec![on(&m, 0, 2, 0.5), on(&m, 2, 3, 0.5)];
        if let SurfacePoint::Edge { t, .. } = &mut b[0] {
            *t += 1e-12;
        }
        let r = insert_polylines(&m, &[a, b], &RemeshOptions::default()).unwrap();
        assert_eq!(r.paths[0][1], r.paths[1][0]);
        assert_eq!(r.mesh.n_vertices(), 7);
        // Consecutive points that snap to the same vertex collapse.
        let line = vec![on(&m, 0, 1, 0.97), on(&m, 1, 2, 0.02), on(&m, 0, 2, 0.5)];
        let r = insert_polylines(&m, &[line], &RemeshOptions::default()).unwrap();
        assert_eq!(r.paths[0].len(), 2);
        assert_eq!(r.paths[0][0], VertexId(1));
    }

    #[test]
    fn paths_along_edges() {
        let m = clothcast_mesh::shapes::unit_square();
        // One seam along the boundary 0-1-2, another ending on edge 1-2 (a touch at an edge point),
        // a third along edge 1-2: the first passes through all three inserted points.
        let a = vec![
            SurfacePoint::Vertex(VertexId(0)),
            SurfacePoint::Vertex(VertexId(1)),
            SurfacePoint::Vertex(VertexId(2)),
        ];
        let b = vec![SurfacePoint::Vertex(VertexId(0)), on(&m, 1, 2, 0.5)];
        let c = vec![on(&m, 1, 2, 0.3), on(&m, 1, 2, 0.7)];
        let r = insert_polylines(&m, &[a, b, c], &RemeshOptions::default()).unwrap();
        let p = &r.paths[0];
        assert_eq!(p.len(), 6, "{p:?}");
        assert_eq!((p[0], p[1], p[5]), (VertexId(0), VertexId(1), VertexId(2)));
        assert_eq!(p[3], r.paths[1][1]);
        assert_eq!(r.paths[2].len(), 3);
        for path in &r.paths {
            assert!(path.windows(2).all(|w| is_edge(&r.mesh, w[0], w[1])));
        }
        // Untouched corners keep their order: face 1 (0,2,3) was not split.
        assert_eq!(r.mesh.face_vertices(FaceId(r.mesh.n_faces() as u32 - 1)), [0, 2, 3].map(VertexId));
    }

    #[test]
    fn crossing_and_invalid_polylines_are_refused() {
        let m = clothcast_mesh::shapes::unit_square();
        let opts = RemeshOptions::default();
        let a = vec![on(&m, 0, 1, 0.5), on(&m, 0, 2, 0.5)];
        let b = vec![on(&m, 0, 1, 0.3), SurfacePoint::Vertex(VertexId(2))];
        match insert_polylines(&m, &[a, b], &opts) {
            Err(LayoutError::InvalidPath { path, reason }) => {
                assert!(path <= 1);
                assert!(reason.contains("cross"), "{reason}");
            }
            other => panic!("expected a crossing error, got {:?}", other.err()),
        }
        // Points in no common face: an edge point of face 0 only and vertex 3 (face 1 only).
        let c = vec![on(&m, 0, 1, 0.5), SurfacePoint::Vertex(VertexId(3))];
        assert!(matches!(insert_polylines(&m, &[c], &opts), Err(LayoutError::InvalidPath { path: 0, .. })));
        let d = vec![on(&m, 0, 1, 0.5)];
        assert!(matches!(insert_polylines(&m, &[d], &opts), Err(LayoutError::InvalidPath { path: 0, .. })));
    }

    #[test]
    fn convex_pieces_with_collinear_runs() {
        // A triangle with two points on every side: 9 vertices, 7 triangles, none collinear.
        let corners = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(0.5, 0.9, 0.)];
        let mut p = Vec::new();
        let mut side = Vec::new();
        for k in 0..3 {
            let (a, b) = (corners[k], corners[(k + 1) % 3]);
            p.push(a);
            side.push(1u8 << k | 1 << ((k + 2) % 3));
            for s in [0.3, 0.6] {
                p.push(a * (1.0 - s) + b * s);
                side.push(1 << k);
            }
        }
        let piece: Vec<usize> = (0..9).collect();
        let mut tris = Vec::new();
        assert!(triangulate_convex(&piece, &side, &p, &mut tris));
        assert_eq!(tris.len(), 7);
        let normal = Vec3::z();
        delaunay_flips(&mut tris, &BTreeSet::new(), &side, &p, &normal);
        let mut area = 0.0;
        for t in &tris {
            assert_eq!(side[t[0]] & side[t[1]] & side[t[2]], 0);
            let a = (p[t[1]] - p[t[0]]).cross(&(p[t[2]] - p[t[0]])).dot(&normal);
            assert!(a > 0.0);
            area += a / 2.0;
        }
        assert!((area - 0.45).abs() < 1e-15);
        // Every interior edge is locally Delaunay.
        for (i, s) in tris.iter().enumerate() {
            for (j, t) in tris.iter().enumerate().skip(i + 1) {
                let shared: Vec<usize> = s.iter().copied().filter(|x| t.contains(x)).collect();
                if shared.len() == 2 {
                    let c = *s.iter().find(|x| !shared.contains(x)).unwrap();
                    let d = *t.iter().find(|x| !shared.contains(x)).unwrap();
                    let (a, b) = (shared[0], shared[1]);
                    let sum = angle_at(&p[c], &p[a], &p[b]) + angle_at(&p[d], &p[a], &p[b]);
                    assert!(sum <= PI + 1e-9, "edge {a}-{b} of {i}, {j} not Delaunay");
                }
            }
        }
    }
}
