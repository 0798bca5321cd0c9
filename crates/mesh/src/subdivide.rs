//! Refining a coarse target without changing its shape: longest-edge bisection.
//!
//! A target from CAD is often coarse (a box of 12 or 48 triangles, a cylinder of 80 needles).
//! The simulation's membrane and the layout's patches live on the faces, so such a mesh gives
//! a strain field of a few values and patches that cannot be cut finer (to fit the roll).
//! [`refine`] splits the longest edge of the mesh at its midpoint, again and again, until the
//! mesh has enough faces and no edge is too long:
//!
//! - the surface does not move: every new vertex is an edge midpoint, so flat faces stay flat
//!   and sharp edges sharp (a smoothing subdivision such as Loop's would round the box);
//! - the globally longest edge is the longest edge of both its triangles, so each split is a
//!   longest-edge bisection (Rivara): the mesh stays conforming, its smallest angle never drops
//!   below half the input's, and needles are cut across until their sides are comparable;
//! - refinement goes where the edges are long: a table's large top is refined, its fine legs
//!   are not (a uniform subdivision would keep their disparity);
//! - the input's vertices keep their ids (new vertices are appended) and every face remembers
//!   the input face it lies in.
//!
//! Written here because it is a short loop on a priority queue of edges; the mesh crates of the
//! ecosystem subdivide uniformly with smoothing (Loop) or remesh isotropically, which moves the
//! vertices off the input's faces.

use crate::{FaceData, FaceId, Mesh, Vec3};
use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

/// A refined mesh and, for each of its faces, the face of the mesh it was made from.
#[derive(Clone, Debug)]
pub struct Refined {
    /// The refined mesh: the original vertices first, with their ids, then the new ones.
    pub mesh: Mesh,
    /// For each refined face, its face in the original mesh.
    pub parent: FaceData<FaceId>,
    /// Edges split.
    pub splits: usize,
    /// True when `max_faces` stopped the refinement with an edge still longer than `max_edge`
    /// (or fewer faces than `min_faces`).
    pub capped: bool,
}

/// Split longest edges until the mesh has at least `min_faces` faces and no edge longer than
/// `max_edge` (`f64::INFINITY`, or anything not positive: no length limit), or until it has
/// `max_faces` faces (a cap against a limit far below the mesh's scale; never more than
/// [`MAX_FACES`]). `None` when both hold already, or the mesh is at the cap: nothing to split.
///
/// The result is a valid mesh by construction (each split replaces two triangles, or one on the
/// boundary, by their halves, with the same orientation), so it is not validated again: its
/// halved faces may fall below the validator's degenerate-area threshold (relative to the
/// bounding box) that the input's passed.
pub fn refine(mesh: &Mesh, min_faces: usize, max_edge: f64, max_faces: usize) -> Option<Refined> {
    let max_edge = if max_edge > 0.0 { max_edge } else { f64::INFINITY };
    let max_faces = max_faces.min(MAX_FACES);
    let longest = mesh.edge_lengths().iter().copied().fold(0.0, f64::max);
    let n = mesh.n_faces();
    if (n >= min_faces && longest <= max_edge) || n >= max_faces {
        return None;
    }
    let soup = mesh.to_soup();
    let (mut pos, mut tris) = (soup.positions, soup.triangles);
    let mut parent: Vec<FaceId> = mesh.face_ids().collect();
    // Directed edge (tail, head) → the triangle holding it.
    let mut owner: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * tris.len());
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            owner.insert((tri[k], tri[(k + 1) % 3]), t as u32);
        }
    }
    // Undirected edges by length, longest first; ties by the smaller vertex ids (determinism).
    // Lengths are positive, so their bit patterns order as the numbers do.
    type Key = (u64, Reverse<u32>, Reverse<u32>);
    let key = |pos: &[Vec3], a: u32, b: u32| -> Key {
        let (a, b) = (a.min(b), a.max(b));
        ((pos[a as usize] - pos[b as usize]).norm().to_bits(), Reverse(a), Reverse(b))
    };
    let mut heap: BinaryHeap<Key> =
        mesh.edges().map(|e| mesh.edge_vertices(e)).map(|[a, b]| key(&pos, a.0, b.0)).collect();
    let mut splits = 0;
    let mut capped = false;
    while let Some(&(len, Reverse(a), Reverse(b))) = heap.peek() {
        let wanted = f64::from_bits(len) > max_edge || tris.len() < min_faces;
        if !wanted || tris.len() >= max_faces {
            capped = wanted;
            break;
        }
        heap.pop();
        // Each edge has one entry, popped when it is split; new edges all end at the new
        // vertex, so a split edge never comes back.
        debug_assert!(owner.contains_key(&(a, b)) || owner.contains_key(&(b, a)));
        let m = pos.len() as u32;
        pos.push(0.5 * (pos[a as usize] + pos[b as usize]));
        let mut opposite = Vec::with_capacity(2);
        for (p, q) in [(a, b), (b, a)] {
            let Some(t) = owner.remove(&(p, q)) else { continue };
            let tri = tris[t as usize];
            let k = (0..3).find(|&k| tri[k] == p).expect("the edge's tail is in its triangle");
            let c = tri[(k + 2) % 3];
            // (p, q, c) → (p, m, c) in place and (m, q, c) appended.
            let u = tris.len() as u32;
            tris[t as usize] = [p, m, c];
            tris.push([m, q, c]);
            parent.push(parent[t as usize]);
            owner.insert((p, m), t);
            owner.insert((m, c), t);
            owner.insert((m, q), u);
            owner.insert((q, c), u);
            owner.insert((c, m), u);
            opposite.push(c);
        }
        for v in [a, b].into_iter().chain(opposite) {
            heap.push(key(&pos, v, m));
        }
        splits += 1;
    }
    let mesh = Mesh::build_unchecked(pos, &tris);
    Some(Refined { mesh, parent: FaceData::from_vec(parent), splits, capped })
}

/// Most faces [`refine`] makes (vertex ids stay well inside `u32`).
pub const MAX_FACES: usize = 100_000_000;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes;

    fn check_refinement(m: &Mesh, r: &Refined) {
        let s = &r.mesh;
        assert_eq!(s.euler_characteristic(), m.euler_characteristic());
        assert_eq!(s.boundary_loops().len(), m.boundary_loops().len());
        assert!((s.total_area() - m.total_area()).abs() < 1e-12 * m.total_area());
        for v in m.vertices() {
            assert_eq!(s.position(v), m.position(v));
        }
        // Each child lies in its parent's plane, with the parent's orientation, and the
        // children of a face cover its area.
        let (ns, nm) = (s.face_normals(), m.face_normals());
        let mut area = vec![0.0; m.n_faces()];
        for f in s.face_ids() {
            let p = r.parent[f];
            assert!((ns[f] - nm[p]).norm() < 1e-9, "face {f:?}");
            area[p.idx()] += s.face_area(f);
        }
        for f in m.face_ids() {
            assert!((area[f.idx()] - m.face_area(f)).abs() < 1e-12, "face {f:?}");
        }
    }

    #[test]
    fn refines_to_a_face_count_keeping_shape_ids_and_angles() {
        let m = shapes::cylinder(0.3, 1.0, 12, 3, true, false);
        let r = refine(&m, 1000, f64::INFINITY, usize::MAX).unwrap();
        assert!(r.mesh.n_faces() >= 1000 && r.mesh.n_faces() < 1004, "{}", r.mesh.n_faces());
        assert_eq!(r.mesh.n_vertices(), m.n_vertices() + r.splits);
        check_refinement(&m, &r);
        // Longest-edge bisection keeps the smallest angle at least half the input's.
        let min_angle = |m: &Mesh| m.corner_angles().iter().copied().fold(f64::INFINITY, f64::min);
        assert!(min_angle(&r.mesh) >= 0.5 * min_angle(&m) - 1e-12);
        // Nothing to do.
        assert!(refine(&m, 10, f64::INFINITY, usize::MAX).is_none());
        assert!(refine(&m, 1000, f64::INFINITY, 10).is_none());
    }

    #[test]
    fn refines_needles_to_a_length_limit_where_they_are_long() {
        // A 4 m by 0.2 m strip of two needles: cut across until every edge is at most 0.5 m.
        let mut m = shapes::grid(1, 1, 4.0, 0.2);
        let r = refine(&m, 0, 0.5, usize::MAX).unwrap();
        assert!(r.mesh.edges().all(|e| r.mesh.edge_length(e) <= 0.5 + 1e-12));
        check_refinement(&m, &r);
        // The cap stops it.
        let capped = refine(&m, 0, 1e-3, 100).unwrap();
        assert!(capped.mesh.n_faces() >= 100 && capped.mesh.n_faces() < 104);
        // Deterministic.
        let again = refine(&m, 0, 0.5, usize::MAX).unwrap();
        assert_eq!(again.mesh.faces(), r.mesh.faces());
        assert_eq!(again.parent, r.parent);
        m = shapes::icosphere(0, 1.0);
        let r = refine(&m, 0, 0.3, usize::MAX).unwrap();
        assert!(r.mesh.edges().all(|e| r.mesh.edge_length(e) <= 0.3));
        assert_eq!(r.mesh.genus(), 0);
        check_refinement(&m, &r);
    }
}
