//! Developability split: cut a non-developable patch in two by spectral clustering (paper
//! §6.2.3 and its supplement §8; von Luxburg 2007; Shi & Malik's normalized cut; ALGORITHMS.md §8).
//!
//! **Affinity.** The dual graph of the patch (faces joined across its non-cut edges) with weights
//! `w_fg = ℓ_e · exp(−ρ_e / ρ̄)`: ℓ_e the shared edge's length, ρ_e the mean of the hinge-energy
//! densities (≈ min κ², see `developability`) at its two vertices and ρ̄ their area-weighted mean
//! over the patch. Cheap to cut where the surface is least developable, so the cut runs through
//! high-energy regions "with high probability", as the paper asks. (ALGORITHMS.md suggests
//! normal differences; those also penalise cutting across creases of developable bends, which
//! need no cut.)
//!
//! **Fiedler vector** of `L y = λ D y` (L = D − W) by inverse iteration on `(L + σD)` with the
//! constant vector deflated (D-orthogonal projection), one sparse Cholesky factorization. The
//! start vector is seeded, so the split is deterministic.
//!
//! **Sweep.** Faces sorted by the Fiedler value; every prefix with 15–85% of the area is a
//! candidate, scored by its normalized cut `cut(S, S̄) (1/vol S + 1/vol S̄)`, computed
//! incrementally. Candidates are tried best first; the first whose two sides are both
//! topological disks wins (so the new seam is one boundary-to-boundary path). When none does
//! because a side falls in several parts (the level sets of a patch bent over a crease, or
//! U-shaped), the candidates are tried again with a side's largest part against the rest of
//! the patch.
//!
//! **Field-aligned cut.** The sweep decides *where* to cut; the seam itself is then traced along
//! the field from the middle of the sweep's interface to the patch boundary in both directions
//! ([`field_aligned_split`]), so a quad splits into two quads and the new seam follows the fibres
//! like the others. The sweep's own interface is kept when that trace does not give two disks.
//!
//! Complexity: O(F_p log F_p) for the ordering and sweep plus one sparse factorization and
//! `ITERATIONS` solves on the patch.

use crate::LayoutError;
use crate::patches::{CornerRule, RegionInfo, edge_between, region_info};
use crate::trace::{TraceOptions, field_path};
use crate::vertex_field::VertexField;
use clothcast_mesh::sparse::{CholeskySolver, SymmetricPattern};
use clothcast_mesh::util::SplitMix64;
use clothcast_mesh::util::UnionFind;
use clothcast_mesh::{EdgeId, FaceId, Mesh, VertexData, VertexId};
use std::collections::{BTreeMap, BTreeSet};

/// Inverse iterations for the Fiedler vector.
const ITERATIONS: usize = 60;
/// Sweep candidates tried (best normalized cut first).
const MAX_CANDIDATES: usize = 40;
/// Smallest share of the patch area on either side of a split.
const MIN_SIDE: f64 = 0.15;

/// A split of a patch: the faces of the two sides (sorted) and their topology.
#[derive(Clone, Debug)]
pub struct Split {
    /// First side.
    pub a: Vec<FaceId>,
    /// Second side.
    pub b: Vec<FaceId>,
    /// Topology of the first side.
    pub info_a: RegionInfo,
    /// Topology of the second side.
    pub info_b: RegionInfo,
    /// Normalized cut value.
    pub ncut: f64,
}

/// Split the patch `faces` (sorted; the region of label `label(faces[0])`) in two disks.
/// `density` is the per-vertex hinge density ρ_v (1/m²). Returns `None` when no sweep cut, nor
/// a side's largest part against the rest, gives two disks.
#[allow(clippy::too_many_arguments)]
pub fn spectral_split(
    mesh: &Mesh,
    faces: &[FaceId],
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    density: &VertexData<f64>,
    areas: &VertexData<f64>,
    rule: &CornerRule,
    seed: u64,
) -> Result<Option<Split>, LayoutError> {
    let n = faces.len();
    if n < 8 {
        return Ok(None);
    }
    let own = label(faces[0]);
    let local = |f: FaceId| faces.binary_search(&f).ok();
    // Mean density over the patch.
    let (mut rs, mut ws) = (0.0, 0.0);
    for &f in faces {
        for v in mesh.face_vertices(f) {
            rs += density[v] * areas[v];
            ws += areas[v];
        }
    }
    let rho_bar = if ws > 0.0 { rs / ws } else { 0.0 } + 1e-300;
    // Dual graph.
    let mut arcs: Vec<(usize, usize, f64)> = Vec::new();
    for (i, &f) in faces.iter().enumerate() {
        for k in 0..3 {
            let h = mesh.face_halfedge(f, k);
            let Some(t) = mesh.twin(h) else { continue };
            let g = mesh.face(t);
            if seam(mesh.edge(h)) || label(g) != own {
                continue;
            }
            let j = local(g).expect("same label faces are in the patch");
            if i < j {
                let [a, b] = [mesh.tail(h), mesh.head(h)];
                let rho = 0.5 * (density[a] + density[b]);
                let w = mesh.vector(h).norm() * (-rho / rho_bar).exp();
                arcs.push((i, j, w.max(1e-300)));
            }
        }
    }
    let mut degree = vec![0.0; n];
    for &(i, j, w) in &arcs {
        degree[i] += w;
        degree[j] += w;
    }
    if degree.iter().any(|&d| d <= 0.0) {
        // An isolated face (the patch is not connected through edges): no spectral split.
        return Ok(None);
    }
    let pattern = SymmetricPattern::from_entries(n, arcs.iter().map(|&(i, j, _)| (i, j)));
    let mut values = vec![0.0; pattern.nnz()];
    let sigma = 1e-6;
    for &(i, j, w) in &arcs {
        values[pattern.slot(i, j)] -= w;
    }
    for i in 0..n {
        values[pattern.slot(i, i)] += degree[i] * (1.0 + sigma);
    }
    let solver = CholeskySolver::new(&pattern)?;
    let factor = solver.factor(&pattern, &values)?;
    let vol: f64 = degree.iter().sum();
    let deflate = |y: &mut [f64]| {
        let c = y.iter().zip(&degree).map(|(a, d)| a * d).sum::<f64>() / vol;
        y.iter_mut().for_each(|a| *a -= c);
        let norm = y.iter().zip(&degree).map(|(a, d)| a * a * d).sum::<f64>().sqrt();
        if norm > 0.0 {
            y.iter_mut().for_each(|a| *a /= norm);
        }
    };
    let mut rng = SplitMix64::new(seed);
    let mut y: Vec<f64> = (0..n).map(|_| rng.next_f64() - 0.5).collect();
    deflate(&mut y);
    for _ in 0..ITERATIONS {
        let mut rhs: Vec<f64> = y.iter().zip(&degree).map(|(a, d)| a * d).collect();
        factor.solve_in_place(&mut rhs);
        y = rhs;
        deflate(&mut y);
    }
    // Sweep.
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| y[a].total_cmp(&y[b]).then(a.cmp(&b)));
    let mut adj: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for &(i, j, w) in &arcs {
        adj[i].push((j, w));
        adj[j].push((i, w));
    }
    let face_area: Vec<f64> = faces.iter().map(|&f| mesh.face_area(f)).collect();
    let total_area: f64 = face_area.iter().sum();
    let mut in_s = vec![false; n];
    let (mut cut, mut vol_s, mut area_s) = (0.0, 0.0, 0.0);
    let mut cands: Vec<(f64, usize)> = Vec::new();
    for (k, &i) in order.iter().enumerate().take(n - 1) {
        in_s[i] = true;
        vol_s += degree[i];
        area_s += face_area[i];
        for &(j, w) in &adj[i] {
            if in_s[j] {
                cut -= w;
            } else {
                cut += w;
            }
        }
        let frac = area_s / total_area;
        if (MIN_SIDE..=1.0 - MIN_SIDE).contains(&frac) {
            let ncut = cut.max(0.0) * (1.0 / vol_s + 1.0 / (vol - vol_s));
            cands.push((ncut, k));
        }
    }
    cands.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    // Keep candidates distinct enough: skip positions within 2% of the faces of a tried one.
    let mut tried: Vec<(f64, usize)> = Vec::new();
    let spacing = (n / 50).max(1);
    for &(ncut, k) in &cands {
        if tried.len() >= MAX_CANDIDATES {
            break;
        }
        if tried.iter().all(|&(_, t)| t.abs_diff(k) >= spacing) {
            tried.push((ncut, k));
        }
    }
    let sides = |k: usize| {
        let mut a: Vec<FaceId> = order[..=k].iter().map(|&i| faces[i]).collect();
        let mut b: Vec<FaceId> = order[k + 1..].iter().map(|&i| faces[i]).collect();
        a.sort_unstable();
        b.sort_unstable();
        (a, b)
    };
    let two_disks = |a: Vec<FaceId>, b: Vec<FaceId>, ncut: f64| {
        let side_label = |f: FaceId| side_label(label(f), own, &a, f);
        let info_a = region_info(mesh, &a, &side_label, seam, rule);
        if !info_a.is_disk() {
            return None;
        }
        let info_b = region_info(mesh, &b, &side_label, seam, rule);
        info_b.is_disk().then_some(Split { a, b, info_a, info_b, ncut })
    };
    for &(ncut, k) in &tried {
        let (a, b) = sides(k);
        if let Some(split) = two_disks(a, b, ncut) {
            return Ok(Some(split));
        }
    }
    // No sweep cut gives two disks: where a side falls in several parts (the Fiedler vector's
    // level sets break up on a patch bent over a crease, or U-shaped), its largest part against
    // the rest of the patch. Tried last, so that patches split before keep their cut.
    for &(_, k) in &tried {
        let (a, b) = sides(k);
        for side in [&a, &b] {
            let parts = connected_parts(mesh, side, seam);
            if parts.len() < 2 {
                continue;
            }
            let area = |p: &Vec<FaceId>| p.iter().map(|&f| mesh.face_area(f)).sum::<f64>();
            let largest =
                parts.into_iter().map(|p| (area(&p), p)).max_by(|x, y| x.0.total_cmp(&y.0)).expect("two parts");
            if !(MIN_SIDE..=1.0 - MIN_SIDE).contains(&(largest.0 / total_area)) {
                continue;
            }
            let in_part: Vec<bool> = faces.iter().map(|f| largest.1.binary_search(f).is_ok()).collect();
            let rest: Vec<FaceId> = faces.iter().zip(&in_part).filter(|&(_, &p)| !p).map(|(&f, _)| f).collect();
            let cut: f64 = arcs.iter().filter(|&&(i, j, _)| in_part[i] != in_part[j]).map(|&(_, _, w)| w).sum();
            let vol_part: f64 = degree.iter().zip(&in_part).filter(|&(_, &p)| p).map(|(d, _)| d).sum();
            let ncut = cut * (1.0 / vol_part + 1.0 / (vol - vol_part));
            if let Some(split) = two_disks(largest.1, rest, ncut) {
                return Ok(Some(split));
            }
        }
    }
    Ok(None)
}

/// The parts of a face set (sorted) connected across edges where not `cut`; each sorted, in
/// the order of their first face.
fn connected_parts(mesh: &Mesh, faces: &[FaceId], cut: &impl Fn(EdgeId) -> bool) -> Vec<Vec<FaceId>> {
    let mut uf = UnionFind::new(faces.len());
    for (i, &f) in faces.iter().enumerate() {
        for k in 0..3 {
            let h = mesh.face_halfedge(f, k);
            let Some(t) = mesh.twin(h) else { continue };
            if cut(mesh.edge(h)) {
                continue;
            }
            if let Ok(j) = faces.binary_search(&mesh.face(t)) {
                uf.union(i as u32, j as u32);
            }
        }
    }
    let (labels, n) = uf.labels();
    let mut parts = vec![Vec::new(); n];
    for (&f, &l) in faces.iter().zip(&labels) {
        parts[l as usize].push(f);
    }
    parts
}

/// The label of face `f` while patch `own` is being split into `a` (sorted) and the rest: its
/// own label outside the patch, `u32::MAX` on side `a`, `u32::MAX − 1` on the other side.
fn side_label(label: u32, own: u32, a: &[FaceId], f: FaceId) -> u32 {
    if label != own {
        label
    } else if a.binary_search(&f).is_ok() {
        u32::MAX
    } else {
        u32::MAX - 1
    }
}

/// The faces of a patch (`faces`, sorted) separated across the edges where `cut(e)`, if they
/// fall in exactly two connected parts.
pub(crate) fn two_sides(
    mesh: &Mesh,
    faces: &[FaceId],
    cut: &impl Fn(EdgeId) -> bool,
) -> Option<(Vec<FaceId>, Vec<FaceId>)> {
    let mut parts = connected_parts(mesh, faces, cut);
    if parts.len() != 2 {
        return None;
    }
    let b = parts.pop()?;
    let a = parts.pop()?;
    Some((a, b))
}

/// Replace the interface of a spectral split by a field-aligned cut: from the interface's
/// middle vertex, trace along the field arm closest to the interface's chord in both directions
/// until the patch boundary (T-junctions on the patch's sides). A quad split this way gives two
/// quads, and the new seam follows the field like the traced ones. `None` when the cut does not
/// give two disks with at least 10% of the area each.
#[allow(clippy::too_many_arguments)]
pub fn field_aligned_split(
    mesh: &Mesh,
    faces: &[FaceId],
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    split: &Split,
    vf: &VertexField,
    trace: &TraceOptions,
    rule: &CornerRule,
) -> Option<Split> {
    let own = label(faces[0]);
    let in_patch = |f: FaceId| faces.binary_search(&f).is_ok();
    let in_a = |f: FaceId| split.a.binary_search(&f).is_ok();
    // Interface edges between the two sides, as a vertex path.
    let mut adj: BTreeMap<VertexId, Vec<VertexId>> = BTreeMap::new();
    for &f in &split.a {
        for k in 0..3 {
            let h = mesh.face_halfedge(f, k);
            let Some(t) = mesh.twin(h) else { continue };
            let g = mesh.face(t);
            if in_patch(g) && !in_a(g) && !seam(mesh.edge(h)) {
                let (u, v) = (mesh.tail(h), mesh.head(h));
                adj.entry(u).or_default().push(v);
                adj.entry(v).or_default().push(u);
            }
        }
    }
    let start = adj.iter().find(|(_, n)| n.len() == 1).map(|(&v, _)| v)?;
    let mut path = vec![start];
    let mut prev = start;
    let mut cur = adj[&start][0];
    loop {
        path.push(cur);
        let next: Vec<VertexId> = adj[&cur].iter().copied().filter(|&w| w != prev).collect();
        match next.as_slice() {
            [] => break,
            [w] if !path.contains(w) => {
                prev = cur;
                cur = *w;
            }
            _ => return None,
        }
    }
    let on_boundary = |v: VertexId| on_patch_boundary(mesh, label, seam, own, v);
    // The middle interior vertex of the interface.
    let interior: Vec<VertexId> = path.iter().copied().filter(|&v| !on_boundary(v)).collect();
    let m = *interior.get(interior.len() / 2)?;
    let chord = mesh.position(*path.last()?) - mesh.position(path[0]);
    let (k, _) = vf.best_arm(m, &chord);
    let cut = cut_through(mesh, faces, label, seam, m, k, vf, trace, rule, (2.0 / 3.0) * MIN_SIDE)?;
    Some(Split { ncut: split.ncut, ..cut })
}

/// A field-aligned path inside patch `own` ([`field_path`]) from `start` along arm `k` to the
/// patch's boundary (its seams, the mesh's boundary or another patch), through vertices of the
/// patch for which `allowed` also holds.
#[allow(clippy::too_many_arguments)]
fn path_to_boundary(
    mesh: &Mesh,
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    own: u32,
    start: VertexId,
    k: usize,
    vf: &VertexField,
    trace: &TraceOptions,
    allowed: &dyn Fn(VertexId) -> bool,
) -> Option<Vec<VertexId>> {
    let on_boundary = |v: VertexId| on_patch_boundary(mesh, label, seam, own, v);
    let touches = |v: VertexId| mesh.vertex_faces(v).any(|f| label(f) == own);
    let seam_at =
        |u: VertexId, w: VertexId| edge_between(mesh, u, w).is_some_and(|e| seam(e) || mesh.is_boundary_edge(e));
    field_path(mesh, vf, start, k, None, trace, &|v| touches(v) && allowed(v), &on_boundary, &seam_at)
}

/// On the boundary of patch `own`: on the mesh's boundary, a seam, or a face of another patch.
fn on_patch_boundary(
    mesh: &Mesh,
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    own: u32,
    v: VertexId,
) -> bool {
    mesh.is_boundary_vertex(v) || mesh.outgoing(v).any(|h| seam(mesh.edge(h)) || label(mesh.face(h)) != own)
}

/// Cut the patch of `faces` through its interior vertex `m`: trace along the field's arm `k`
/// and the opposite one until the patch boundary. `None` unless that gives two disks with at
/// least `min_side` of the area each (`ncut` is left 0).
#[allow(clippy::too_many_arguments)]
fn cut_through(
    mesh: &Mesh,
    faces: &[FaceId],
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    m: VertexId,
    k: usize,
    vf: &VertexField,
    trace: &TraceOptions,
    rule: &CornerRule,
    min_side: f64,
) -> Option<Split> {
    let own = label(faces[0]);
    let half1 = path_to_boundary(mesh, label, seam, own, m, k, vf, trace, &|_| true)?;
    let used: BTreeSet<VertexId> = half1.iter().copied().collect();
    let half2 = path_to_boundary(mesh, label, seam, own, m, (k + 2) % 4, vf, trace, &|v| !used.contains(&v))?;
    let mut cut: Vec<VertexId> = half1.into_iter().rev().collect();
    cut.extend_from_slice(&half2[1..]);
    // The two sides: patch faces connected across edges that are neither cuts nor the new seam.
    let cut_edges: BTreeSet<EdgeId> = cut.windows(2).filter_map(|w| edge_between(mesh, w[0], w[1])).collect();
    let (a, b) = two_sides(mesh, faces, &|e| seam(e) || cut_edges.contains(&e))?;
    let area = |fs: &[FaceId]| fs.iter().map(|&f| mesh.face_area(f)).sum::<f64>();
    let (aa, ab) = (area(&a), area(&b));
    if aa.min(ab) < min_side * (aa + ab) {
        return None;
    }
    let side_label = |f: FaceId| side_label(label(f), own, &a, f);
    let info_a = region_info(mesh, &a, &side_label, seam, rule);
    let info_b = region_info(mesh, &b, &side_label, seam, rule);
    (info_a.is_disk() && info_b.is_disk()).then_some(Split { a, b, info_a, info_b, ncut: 0.0 })
}

/// A dart's seam: from the patch's interior vertex `tip` along the field to the patch's
/// boundary, on whichever of the four arms gives the shortest path (the tip's vertices from
/// `tip` on). The patch stays one piece, slit from its boundary to the tip, where a flattening
/// opens the slit into a wedge as wide as the tip's angle defect. `None` when `tip` lies on
/// the patch boundary or no arm reaches it.
pub fn dart_path(
    mesh: &Mesh,
    faces: &[FaceId],
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    tip: VertexId,
    vf: &VertexField,
    trace: &TraceOptions,
) -> Option<Vec<VertexId>> {
    let own = label(*faces.first()?);
    if on_patch_boundary(mesh, label, seam, own, tip) {
        return None;
    }
    let length = |p: &[VertexId]| p.windows(2).map(|w| (mesh.position(w[1]) - mesh.position(w[0])).norm()).sum::<f64>();
    (0..4)
        .filter_map(|k| path_to_boundary(mesh, label, seam, own, tip, k, vf, trace, &|_| true))
        .min_by(|a, b| length(a).total_cmp(&length(b)))
}

/// Cut a patch through its interior vertex `tip` (a cone-like tip, which a flattening can only
/// lay flat without shrinking the fabric around it when a seam runs through it): along the field
/// both ways from the tip to the patch boundary, on whichever of the field's two lines through
/// it gives two disks with the larger smaller side (each at least `min_side` of the area).
/// `None` when `tip` lies on the patch boundary or neither line gives two such disks.
#[allow(clippy::too_many_arguments)]
pub fn split_through(
    mesh: &Mesh,
    faces: &[FaceId],
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    tip: VertexId,
    vf: &VertexField,
    trace: &TraceOptions,
    rule: &CornerRule,
    min_side: f64,
) -> Option<Split> {
    let own = label(*faces.first()?);
    if on_patch_boundary(mesh, label, seam, own, tip) {
        return None;
    }
    let smaller = |s: &Split| s.info_a.area.min(s.info_b.area);
    (0..2)
        .filter_map(|k| cut_through(mesh, faces, label, seam, tip, k, vf, trace, rule, min_side))
        .max_by(|x, y| smaller(x).total_cmp(&smaller(y)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;

    /// Parts connected across edges that are not cut, in the order of their first face.
    #[test]
    fn connected_parts_follow_the_cut() {
        // A 6 × 2 grid strip: 24 faces, columns of 4 faces.
        let m = shapes::grid(6, 2, 6.0, 2.0);
        let column = |f: FaceId| {
            let c = m.face_positions(f).iter().map(|p| p.x).sum::<f64>() / 3.0;
            c.floor() as usize
        };
        let all: Vec<FaceId> = m.face_ids().collect();
        assert_eq!(connected_parts(&m, &all, &|_| false).len(), 1);
        // Columns 0–1 and 4–5 without the middle: two parts.
        let ends: Vec<FaceId> = all.iter().copied().filter(|&f| !(2..4).contains(&column(f))).collect();
        let parts = connected_parts(&m, &ends, &|_| false);
        assert_eq!(parts.len(), 2);
        assert!(parts[0].iter().all(|&f| column(f) < 2) && parts[1].iter().all(|&f| column(f) >= 4));
        assert_eq!(parts[0].len() + parts[1].len(), ends.len());
        // Cutting along x = 3 splits the whole strip in two halves.
        let cut = |e: EdgeId| {
            let [a, b] = m.edge_vertices(e);
            m.position(a).x == 3.0 && m.position(b).x == 3.0
        };
        let halves = connected_parts(&m, &all, &cut);
        assert_eq!(halves.iter().map(Vec::len).collect::<Vec<_>>(), vec![12, 12]);
        assert_eq!(two_sides(&m, &all, &cut).map(|(a, b)| (a.len(), b.len())), Some((12, 12)));
        assert!(two_sides(&m, &all, &|_| false).is_none());
    }
}
