//! Opt-in repair of triangle soups (`--repair`), reporting every change.
//!
//! In order: drop faces touching non-finite vertices; weld positions closer than
//! `weld_tolerance` × bounding-box diagonal (spatial hashing, deterministic: the lowest index
//! wins); drop faces that became degenerate (repeated vertex or zero area); drop duplicate
//! faces (same three vertices, first kept); orient each orientable component consistently
//! (breadth-first from its first face); split non-manifold vertices (one copy per fan); orient
//! each component so that its (capped) volume is positive, i.e. normals point outward;
//! optionally keep only the largest component; remove unreferenced vertices.
//!
//! Not repairable: non-manifold edges and non-orientable surfaces (the result is still refused
//! with their [`Problem`]s).

use crate::Vec3;
use crate::error::MeshError;
use crate::ids::{FaceId, VertexId};
use crate::mesh::Mesh;
use crate::soup::TriSoup;
use crate::util::{UnionFind, edge_key};
use crate::validate::{Problem, ZERO_AREA_REL, analyze, group_edges};
use serde::Serialize;
use std::collections::HashMap;

/// Options for [`repair_soup`] and [`prepare`].
#[derive(Clone, Debug)]
pub struct RepairOptions {
    /// Run the repairs (otherwise only the component policy applies).
    pub repair: bool,
    /// Weld tolerance relative to the bounding-box diagonal.
    pub weld_tolerance: f64,
    /// Keep only the largest component (by face count) instead of refusing several.
    pub largest_component: bool,
}

impl Default for RepairOptions {
    fn default() -> Self {
        Self { repair: false, weld_tolerance: 1e-7, largest_component: false }
    }
}

/// What a repair changed (all counts; zero means untouched).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RepairReport {
    /// Faces dropped because a vertex had a NaN/infinite coordinate.
    pub faces_with_non_finite_vertices_removed: usize,
    /// Vertices welded into an earlier vertex at the same position.
    pub vertices_welded: usize,
    /// Zero-area faces (a vertex on the opposite edge) mended by flipping that edge with the
    /// face across it, which splits that face in two at the vertex (as dropping them would open
    /// a slit in the surface).
    pub zero_area_faces_flipped: usize,
    /// Faces dropped for a repeated vertex or zero area.
    pub degenerate_faces_removed: usize,
    /// Boundary edges the dropping of degenerate faces left (holes, or slits, the input did
    /// not have: a mold open there may spill).
    pub boundary_edges_opened: usize,
    /// Faces dropped as duplicates.
    pub duplicate_faces_removed: usize,
    /// Faces flipped to make orientation consistent or outward.
    pub faces_flipped: usize,
    /// Extra vertex copies created to split non-manifold vertices.
    pub non_manifold_vertices_split: usize,
    /// Components dropped by `--largest-component`.
    pub components_removed: usize,
    /// Faces dropped with those components.
    pub component_faces_removed: usize,
    /// Vertices removed because no remaining face used them (unreferenced in the input, or
    /// left over by the removals above, welded duplicates excluded).
    pub unreferenced_vertices_removed: usize,
}

impl RepairReport {
    /// True if nothing changed.
    pub fn is_empty(&self) -> bool {
        *self == Self::default()
    }
    /// One human-readable line per change.
    pub fn lines(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut push = |n: usize, what: &str| {
            if n > 0 {
                out.push(format!("{n} {what}"));
            }
        };
        push(self.faces_with_non_finite_vertices_removed, "face(s) with non-finite vertices removed");
        push(self.vertices_welded, "duplicate vertex position(s) welded");
        push(self.zero_area_faces_flipped, "zero-area face(s) mended by an edge flip");
        push(self.degenerate_faces_removed, "degenerate face(s) removed");
        push(self.boundary_edges_opened, "boundary edge(s) left by those removals (the surface is open there now)");
        push(self.duplicate_faces_removed, "duplicate face(s) removed");
        push(self.faces_flipped, "face(s) flipped to a consistent outward orientation");
        push(self.non_manifold_vertices_split, "vertex copy(ies) added to split non-manifold vertices");
        push(self.components_removed, "smaller component(s) removed");
        push(self.unreferenced_vertices_removed, "unreferenced vertex(ices) removed");
        out
    }
}

/// A mesh ready for the pipeline, with what was changed to get it and maps back to the input.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The mesh.
    pub mesh: Mesh,
    /// What was repaired.
    pub report: RepairReport,
    /// For each mesh vertex, the input vertex it came from.
    pub vertex_to_input: Vec<u32>,
    /// For each mesh face, the input triangle it came from.
    pub face_to_input: Vec<u32>,
}

/// Apply the repairs of the module docs to a soup. Returns the repaired soup, the report and
/// the maps of the output vertices/triangles to the input ones.
pub fn repair_soup(soup: &TriSoup, opts: &RepairOptions) -> (TriSoup, RepairReport, Vec<u32>, Vec<u32>) {
    let mut rep = RepairReport::default();
    let mut tris: Vec<[u32; 3]> = soup.triangles.clone();
    let mut face_src: Vec<u32> = (0..tris.len() as u32).collect();
    let mut positions = soup.positions.clone();
    let mut vert_src: Vec<u32> = (0..positions.len() as u32).collect();

    // 1. Faces touching non-finite vertices.
    let finite: Vec<bool> = positions.iter().map(crate::soup::usable_point).collect();
    retain_faces(&mut tris, &mut face_src, |t| {
        let ok = t.iter().all(|&v| finite[v as usize]);
        if !ok {
            rep.faces_with_non_finite_vertices_removed += 1;
        }
        ok
    });

    // 2. Weld.
    let diag = soup.bbox().diagonal();
    let tol = opts.weld_tolerance * diag;
    if tol > 0.0 {
        let remap = weld(&positions, &finite, tol);
        rep.vertices_welded = remap.iter().enumerate().filter(|(i, r)| **r as usize != *i).count();
        for t in tris.iter_mut() {
            *t = t.map(|v| remap[v as usize]);
        }
    }

    // 3. Degenerate faces: caps mended by flipping their longest edge where that leaves two
    // faces with area, the rest (and faces with a repeated vertex) dropped.
    let area_eps = ZERO_AREA_REL * diag * diag;
    rep.zero_area_faces_flipped = flip_caps(&mut tris, &positions, area_eps);
    let degenerate = |t: &[u32; 3]| has_repeated_vertex(t) || face_area(&positions, t) <= area_eps;
    if tris.iter().any(degenerate) {
        let boundary_edges = |tris: &[[u32; 3]]| {
            let g = group_edges(tris, |_| true);
            (0..g.n_edges()).filter(|&e| g.halfedges(e).len() == 1).count()
        };
        let open_before = boundary_edges(&tris);
        let n = tris.len();
        retain_faces(&mut tris, &mut face_src, |t| !degenerate(t));
        rep.degenerate_faces_removed = n - tris.len();
        rep.boundary_edges_opened = boundary_edges(&tris).saturating_sub(open_before);
    }

    // 4. Duplicate faces (first kept).
    {
        let mut seen: HashMap<[u32; 3], ()> = HashMap::with_capacity(tris.len());
        retain_faces(&mut tris, &mut face_src, |t| {
            let mut k = *t;
            k.sort_unstable();
            let fresh = seen.insert(k, ()).is_none();
            if !fresh {
                rep.duplicate_faces_removed += 1;
            }
            fresh
        });
    }

    // 5. Consistent orientation per component (where orientable).
    let mut flipped = vec![false; tris.len()];
    orient_consistently(&tris, &mut flipped);

    // 6. Split non-manifold vertices.
    for (t, &fl) in tris.iter_mut().zip(&flipped) {
        if fl {
            t.swap(1, 2);
        }
    }
    rep.non_manifold_vertices_split = split_nonmanifold_vertices(&mut tris, &mut positions, &mut vert_src);

    // 7. Outward orientation: flip components whose capped volume is negative.
    let tmp = TriSoup::from_triangles(positions.clone(), tris.clone());
    if let Ok(mesh) = Mesh::try_from_soup(&compact(&tmp).0) {
        // Components in `mesh` follow face order, so labels map one-to-one onto `tris`.
        let labels = mesh.component_of_face();
        let mut vol = vec![0.0; mesh.n_components()];
        for c in 0..mesh.n_components() {
            let faces: Vec<_> = mesh.face_ids().filter(|&f| labels[f] as usize == c).collect();
            if let Ok(sub) = crate::submesh::extract_submesh(&mesh, &faces) {
                vol[c] = sub.mesh.signed_volume();
            }
        }
        for (f, t) in tris.iter_mut().enumerate() {
            if vol[labels[crate::ids::FaceId::new(f)] as usize] < 0.0 {
                t.swap(1, 2);
                flipped[f] = !flipped[f];
            }
        }
    }
    rep.faces_flipped = flipped.iter().filter(|&&f| f).count();

    // 8. Largest component.
    if opts.largest_component {
        let (kept, removed_comps, removed_faces) = largest_component_faces(&tris, positions.len());
        rep.components_removed = removed_comps;
        rep.component_faces_removed = removed_faces;
        let mut i = 0;
        retain_faces(&mut tris, &mut face_src, |_| {
            let k = kept[i];
            i += 1;
            k
        });
    }

    // 9. Unreferenced vertices.
    let out = TriSoup::from_triangles(positions, tris);
    let (out, new_to_old) = compact(&out);
    rep.unreferenced_vertices_removed =
        soup.positions.len() + rep.non_manifold_vertices_split - out.positions.len() - rep.vertices_welded;
    let vertex_map = new_to_old.iter().map(|&v| vert_src[v as usize]).collect();
    (out, rep, vertex_map, face_src)
}

/// Load policy in one call: strict unless `opts.repair`; several components refused unless
/// `opts.largest_component`.
pub fn prepare(soup: &TriSoup, opts: &RepairOptions) -> Result<Prepared, MeshError> {
    let (soup2, report, vertex_to_input, face_to_input) = if opts.repair {
        repair_soup(soup, opts)
    } else if opts.largest_component {
        let (kept, removed_comps, removed_faces) = largest_component_faces(&soup.triangles, soup.positions.len());
        let faces: Vec<u32> = (0..soup.triangles.len() as u32).filter(|&f| kept[f as usize]).collect();
        let tris: Vec<[u32; 3]> = faces.iter().map(|&f| soup.triangles[f as usize]).collect();
        let (s, map) = compact(&TriSoup::from_triangles(soup.positions.clone(), tris));
        let report = RepairReport {
            components_removed: removed_comps,
            component_faces_removed: removed_faces,
            ..Default::default()
        };
        (s, report, map, faces)
    } else {
        (
            soup.clone(),
            RepairReport::default(),
            (0..soup.positions.len() as u32).collect(),
            (0..soup.triangles.len() as u32).collect(),
        )
    };
    if opts.repair && soup2.triangles.is_empty() && !soup.triangles.is_empty() {
        return Err(MeshError::Invalid {
            problems: vec![Problem::NothingLeftAfterRepair {
                faces: soup.triangles.len(),
                non_finite: report.faces_with_non_finite_vertices_removed,
                degenerate: report.degenerate_faces_removed,
                duplicate: report.duplicate_faces_removed,
            }],
        });
    }
    let problems: Vec<Problem> = analyze(&soup2).problems;
    if !problems.is_empty() {
        // Named in the input file's numbering (welding, removals and splits renumber).
        let problems = problems
            .into_iter()
            .map(|p| {
                p.renumbered(
                    |v| VertexId::new(vertex_to_input[v.idx()] as usize),
                    |f| FaceId::new(face_to_input[f.idx()] as usize),
                )
            })
            .collect();
        return Err(MeshError::Invalid { problems });
    }
    let mesh = Mesh::try_from_soup(&soup2)?;
    Ok(Prepared { mesh, report, vertex_to_input, face_to_input })
}

/// Mend caps, faces of (nearly) zero area whose three vertices are distinct, so that one lies on
/// the opposite edge: flipping that edge with the face across it makes two faces, each a part
/// of that face cut at the vertex. Done only where both parts have area, the edge is shared by
/// exactly the two faces in opposite directions and the new edge is not already in the mesh; a
/// cap whose neighbour is a cap itself is tried again after the others (a fan of caps along a
/// straight line unzips from its end). Returns the number of flips.
fn flip_caps(tris: &mut [[u32; 3]], positions: &[Vec3], area_eps: f64) -> usize {
    let area = |t: &[u32; 3]| face_area(positions, t);
    let is_cap = |t: &[u32; 3]| !has_repeated_vertex(t) && area(t) <= area_eps;
    let mut caps: Vec<usize> = (0..tris.len()).filter(|&f| is_cap(&tris[f])).collect();
    if caps.is_empty() {
        return 0;
    }
    let mut edges: HashMap<u64, Vec<usize>> = HashMap::with_capacity(3 * tris.len() / 2);
    for (f, t) in tris.iter().enumerate() {
        for k in 0..3 {
            edges.entry(edge_key(t[k], t[(k + 1) % 3])).or_default().push(f);
        }
    }
    let mut flips = 0;
    loop {
        let before = flips;
        let mut left = Vec::new();
        for &f in &caps {
            let t = tris[f];
            if !is_cap(&t) {
                continue; // mended as the face across another cap's edge
            }
            // The longest edge a→b (directed as in f) and the vertex m on it.
            let k = (0..3)
                .max_by(|&i, &j| {
                    let len = |i: usize| (positions[t[i] as usize] - positions[t[(i + 1) % 3] as usize]).norm_squared();
                    len(i).total_cmp(&len(j))
                })
                .unwrap_or(0);
            let (a, b, m) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let (pa, pb, pm) = (positions[a as usize], positions[b as usize], positions[m as usize]);
            let ab = pb - pa;
            let s = (pm - pa).dot(&ab) / ab.norm_squared().max(f64::MIN_POSITIVE);
            let across = edges
                .get(&edge_key(a, b))
                .filter(|fs| fs.len() == 2)
                .and_then(|fs| fs.iter().copied().find(|&g| g != f));
            let Some(g) = across else {
                continue; // a boundary or non-manifold edge: nothing to flip with
            };
            let u = tris[g];
            let Some(j) = (0..3).find(|&j| u[j] == b && u[(j + 1) % 3] == a) else {
                continue; // oriented against f: left to the removal
            };
            let c = u[(j + 2) % 3];
            let (nf, ng) = ([a, c, m], [c, b, m]);
            let ok = s > 0.0
                && s < 1.0
                && c != m
                && !edges.contains_key(&edge_key(c, m))
                && area(&nf) > area_eps
                && area(&ng) > area_eps;
            if !ok {
                left.push(f);
                continue;
            }
            tris[f] = nf;
            tris[g] = ng;
            edges.remove(&edge_key(a, b));
            edges.insert(edge_key(c, m), vec![f, g]);
            for (e, from, to) in [(edge_key(a, c), g, f), (edge_key(b, m), f, g)] {
                if let Some(fs) = edges.get_mut(&e) {
                    fs.iter_mut().filter(|h| **h == from).for_each(|h| *h = to);
                }
            }
            flips += 1;
        }
        if flips == before || left.is_empty() {
            return flips;
        }
        caps = left;
    }
}

/// The area of the triangle `t` of `positions`.
fn face_area(positions: &[Vec3], t: &[u32; 3]) -> f64 {
    let p = t.map(|v| positions[v as usize]);
    0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm()
}

fn has_repeated_vertex(t: &[u32; 3]) -> bool {
    t[0] == t[1] || t[1] == t[2] || t[0] == t[2]
}

fn retain_faces(tris: &mut Vec<[u32; 3]>, src: &mut Vec<u32>, mut keep: impl FnMut(&[u32; 3]) -> bool) {
    let mut w = 0;
    for r in 0..tris.len() {
        if keep(&tris[r]) {
            tris[w] = tris[r];
            src[w] = src[r];
            w += 1;
        }
    }
    tris.truncate(w);
    src.truncate(w);
}

/// Weld map: every vertex to the lowest-index vertex within `tol` (grid hashing with cells of
/// size `tol`, so only the 27 neighbouring cells need checking).
fn weld(p: &[Vec3], finite: &[bool], tol: f64) -> Vec<u32> {
    let key = |x: &Vec3| -> [i64; 3] { [0, 1, 2].map(|i| (x[i] / tol).floor() as i64) };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut remap: Vec<u32> = (0..p.len() as u32).collect();
    for (i, x) in p.iter().enumerate() {
        if !finite[i] {
            continue;
        }
        let k = key(x);
        let mut found: Option<u32> = None;
        for d in 0..27i64 {
            let cell = [k[0] + d % 3 - 1, k[1] + (d / 3) % 3 - 1, k[2] + d / 9 - 1];
            for &j in grid.get(&cell).map(Vec::as_slice).unwrap_or(&[]) {
                if (p[j as usize] - x).norm() <= tol && found.is_none_or(|f| j < f) {
                    found = Some(j);
                }
            }
        }
        match found {
            Some(j) => remap[i] = j,
            None => grid.entry(k).or_default().push(i as u32),
        }
    }
    remap
}

/// Flip faces so that each edge-connected, orientable component is consistent with its first
/// face. Non-orientable components are left as they are.
fn orient_consistently(tris: &[[u32; 3]], flipped: &mut [bool]) {
    let groups = group_edges(tris, |_| true);
    let nf = tris.len();
    let mut adj: Vec<Vec<(u32, bool)>> = vec![Vec::new(); nf];
    for e in 0..groups.n_edges() {
        let hs = groups.halfedges(e);
        if hs.len() != 2 {
            continue;
        }
        let tail = |h: u32| tris[(h / 3) as usize][(h % 3) as usize];
        let same = tail(hs[0]) == tail(hs[1]);
        adj[(hs[0] / 3) as usize].push((hs[1] / 3, same));
        adj[(hs[1] / 3) as usize].push((hs[0] / 3, same));
    }
    let mut state = vec![u8::MAX; nf];
    for seed in 0..nf {
        if state[seed] != u8::MAX {
            continue;
        }
        let mut comp = vec![seed as u32];
        state[seed] = 0;
        let mut i = 0;
        let mut ok = true;
        while i < comp.len() {
            let f = comp[i] as usize;
            i += 1;
            for &(g, same) in &adj[f] {
                let want = state[f] ^ same as u8;
                if state[g as usize] == u8::MAX {
                    state[g as usize] = want;
                    comp.push(g);
                } else if state[g as usize] != want {
                    ok = false;
                }
            }
        }
        if ok {
            for &f in &comp {
                flipped[f as usize] = state[f as usize] == 1;
            }
        }
    }
}

/// Give each extra fan of a vertex its own copy of the vertex. Returns the number of copies.
fn split_nonmanifold_vertices(tris: &mut [[u32; 3]], positions: &mut Vec<Vec3>, vert_src: &mut Vec<u32>) -> usize {
    let nf = tris.len();
    let groups = group_edges(tris, |_| true);
    let mut uf = UnionFind::new(3 * nf);
    let mut nm_edge_vertex = vec![false; positions.len()];
    for e in 0..groups.n_edges() {
        let hs = groups.halfedges(e);
        let verts = |h: u32| {
            let t = tris[(h / 3) as usize];
            (t[(h % 3) as usize], t[((h % 3 + 1) % 3) as usize])
        };
        if hs.len() > 2 {
            let (a, b) = verts(hs[0]);
            nm_edge_vertex[a as usize] = true;
            nm_edge_vertex[b as usize] = true;
        }
        if hs.len() != 2 {
            continue;
        }
        let (a, b) = verts(hs[0]);
        for x in [a, b] {
            let c = |h: u32| {
                let f = h / 3;
                3 * f + (0..3).find(|&k| tris[f as usize][k as usize] == x).unwrap_or(0)
            };
            uf.union(c(hs[0]), c(hs[1]));
        }
    }
    let mut root_vertex: HashMap<u32, u32> = HashMap::new();
    let mut first_root: Vec<u32> = vec![u32::MAX; positions.len()];
    let mut added = 0;
    for f in 0..nf {
        for k in 0..3 {
            let v = tris[f][k];
            if nm_edge_vertex[v as usize] {
                continue;
            }
            let r = uf.find((3 * f + k) as u32);
            if first_root[v as usize] == u32::MAX {
                first_root[v as usize] = r;
            } else if first_root[v as usize] != r {
                let nv = *root_vertex.entry(r).or_insert_with(|| {
                    positions.push(positions[v as usize]);
                    vert_src.push(vert_src[v as usize]);
                    added += 1;
                    (positions.len() - 1) as u32
                });
                tris[f][k] = nv;
            }
        }
    }
    added
}

/// Faces of the largest vertex-connected component (ties: the one containing the lowest face),
/// number of other components and their face count.
fn largest_component_faces(tris: &[[u32; 3]], nv: usize) -> (Vec<bool>, usize, usize) {
    let mut uf = UnionFind::new(nv);
    for t in tris {
        uf.union(t[0], t[1]);
        uf.union(t[1], t[2]);
    }
    let mut count: HashMap<u32, (usize, usize)> = HashMap::new(); // root -> (faces, first face)
    for (f, t) in tris.iter().enumerate() {
        let e = count.entry(uf.find(t[0])).or_insert((0, f));
        e.0 += 1;
    }
    let best = count.iter().max_by_key(|(_, (n, first))| (*n, std::cmp::Reverse(*first))).map(|(r, _)| *r);
    let kept: Vec<bool> = tris.iter().map(|t| Some(uf.find(t[0])) == best).collect();
    let removed_faces = kept.iter().filter(|&&k| !k).count();
    (kept, count.len().saturating_sub(1), removed_faces)
}

/// Drop unreferenced vertices, keeping the order of the others; returns the compacted soup
/// and the new→old vertex map.
pub(crate) fn compact(soup: &TriSoup) -> (TriSoup, Vec<u32>) {
    let mut used = vec![false; soup.positions.len()];
    for t in &soup.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    let mut new_of_old = vec![u32::MAX; soup.positions.len()];
    let mut new_to_old = Vec::new();
    for (v, &u) in used.iter().enumerate() {
        if u {
            new_of_old[v] = new_to_old.len() as u32;
            new_to_old.push(v as u32);
        }
    }
    let tris = soup.triangles.iter().map(|t| t.map(|v| new_of_old[v as usize])).collect();
    let positions = new_to_old.iter().map(|&v| soup.positions[v as usize]).collect();
    (TriSoup::from_triangles(positions, tris), new_to_old)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_repair_that_drops_every_face_says_so() {
        // A tetrahedron flattened onto a line: every face degenerate.
        let soup = TriSoup::from_triangles(
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(3.0, 0.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]],
        );
        let opts = RepairOptions { repair: true, ..Default::default() };
        let Err(e) = prepare(&soup, &opts) else { panic!("a mesh with no area left was accepted") };
        let e = e.to_string();
        assert!(e.contains("dropped all 4 faces") && e.contains("4 degenerate"), "{e}");
    }

    /// A tetrahedron with `m` on edge ab: one side of ab split at m (two faces), the other
    /// side a face over ab and, between them, the cap (a, m, b) of zero area.
    fn tetra_with_a_cap(second_cap: bool) -> TriSoup {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0), // a
            Vec3::new(2.0, 0.0, 0.0), // b
            Vec3::new(1.0, 2.0, 0.0), // c
            Vec3::new(1.0, 0.7, 1.5), // d
            Vec3::new(0.6, 0.0, 0.0), // m, on ab
            Vec3::new(1.3, 0.0, 0.0), // m', on ab too
        ];
        let (a, b, c, d, m, m2) = (0, 1, 2, 3, 4, 5);
        let mut t = vec![[a, c, d], [b, d, c], [a, d, m], [m, d, b], [a, m, b]];
        if second_cap {
            // Split the face over ab at m' too: the cap's neighbour is a cap itself.
            t.extend([[b, m2, a], [a, m2, c], [m2, b, c]]);
        } else {
            t.push([a, b, c]);
        }
        TriSoup::from_triangles(p, t)
    }

    /// [`tetra_with_a_cap`] repaired, and its report's flips, drops and opened boundary edges.
    fn repaired_tetra(second_cap: bool) -> (Prepared, [usize; 3]) {
        let opts = RepairOptions { repair: true, ..Default::default() };
        let prepared = prepare(&tetra_with_a_cap(second_cap), &opts).unwrap();
        let r = &prepared.report;
        let counts = [r.zero_area_faces_flipped, r.degenerate_faces_removed, r.boundary_edges_opened];
        (prepared, counts)
    }

    /// A cap is mended by an edge flip, so the surface stays closed (dropping it opened a hole
    /// that made a closed mold spill).
    #[test]
    fn a_cap_is_flipped_away_not_dropped() {
        let (prepared, counts) = repaired_tetra(false);
        assert_eq!(counts, [1, 0, 0], "{:?}", prepared.report);
        let mesh = &prepared.mesh;
        assert_eq!((mesh.n_faces(), mesh.boundary_loops().len()), (6, 0));
        let eps = 1e-9;
        assert!(mesh.face_ids().all(|f| mesh.face_area(f) > eps), "a face of zero area is left");
        assert!(mesh.signed_volume() > 0.0, "orientation kept outward");
    }

    /// Two caps back to back over one edge cannot be flipped into area: they are dropped, and
    /// the report says that the surface is open there now.
    #[test]
    fn caps_that_cannot_be_flipped_are_dropped_and_the_opening_is_reported() {
        let (prepared, counts) = repaired_tetra(true);
        let r = &prepared.report;
        assert_eq!(counts, [0, 2, 4], "{r:?}");
        assert_eq!(prepared.mesh.boundary_loops().len(), 1);
        assert!(r.lines().iter().any(|l| l.contains("4 boundary edge(s) left")), "{:?}", r.lines());
    }
}
