//! Re-routing traced seams along streamlines of the cross field.
//!
//! Separatrices are traced as shortest paths over the mesh's edges ([`crate::trace`]). An edge
//! path can only step in the six-or-so directions of the edges around a vertex, and the
//! per-step cost lets it settle on the best-aligned edge direction instead of the field's:
//! measured on fertility, bunny and spot, 8-edge chords of the traced separatrices deviate
//! from the field by 8–9° (median) whatever the drift penalty, and the straightened seams by
//! 11–12°. But every chain of a field-traced seam lies, ideally, on a streamline (an integral
//! curve of the cross field) through its end nodes.
//!
//! So, once the topology is final (after merges and splits), every chain between two nodes is
//! re-routed: from each end a streamline is integrated exactly through the piecewise-constant
//! face field (in each face the arm closest to the travel direction, straight to the exit
//! edge), for half the chain's length, and stopped early where it leaves the two patches the
//! chain separates, comes close to another seam, or strays from the traced chain by more than
//! a corridor (a quarter of the chain's length, at least two edges). Every `spacing`, the
//! streamline's crossing of an edge is a pin: inserted into the mesh as a new vertex (one
//! remeshing for all chains, each pin a piece of its edge, so no seam is split and vertex ids
//! stay), so that it lies on the streamline itself; a crossing near an edge's end or on a seam
//! uses the face's nearest vertex instead, which is up to half an edge off the streamline
//! (measured on fertility: median deviation 10.5° with nearest-vertex pins, 9.7° with inserted
//! ones). Pins are joined by shortest edge paths that stay inside the two patches and touch no
//! other seam, so the patch structure cannot change; it is checked anyway (same number of
//! patches, all disks, no fewer quads). Chains are joined one after the other; where the
//! planned pins fail (a chain re-routed before is in the way), nearest-vertex pins of
//! streamlines traced on the current seams are tried, and a chain whose re-route fails keeps
//! its traced course. The pins are then kept fixed by the geodesic straightening ([`crate::flipout`]),
//! which makes every seam a geodesic between streamline points a few edges apart.
//!
//! A chain that does not follow the field (a developability split, a disk cut) is left alone:
//! re-routing applies to chains whose traced course is within [`MAX_CHAIN_DEVIATION_DEG`] of the
//! field. The mismatch between the two half-streamlines is absorbed by the middle leg.
//!
//! Complexity: per chain, the streamlines cost O(faces crossed × chain vertices) (distance to
//! the traced chain) and the legs one bounded Dijkstra each; the patch check is O(F) per chain.

use crate::SurfacePoint;
use crate::network;
use crate::patches::{CornerRule, Patches, edge_between, patches_with, seam_edges};
use crate::remesh::{RemeshOptions, Remeshed, insert_polylines};
use clothcast_mesh::geometry::shortest_edge_path;
use clothcast_mesh::{EdgeData, EdgeId, FaceData, FaceId, HalfedgeId, Mesh, Vec3, VertexData, VertexId};
use std::collections::BTreeSet;

/// Chains whose traced course deviates more than this from the field (length-weighted mean of
/// the edge deviations, degrees) are not re-routed.
pub const MAX_CHAIN_DEVIATION_DEG: f64 = 25.0;

/// What [`reroute`] did.
pub struct Rerouted {
    /// The new seam edges (on the refined mesh when there is one).
    pub seam: EdgeData<bool>,
    /// Pins on the new seams (to be kept fixed by the straightening).
    pub pins: VertexData<bool>,
    /// Chains re-routed.
    pub chains: usize,
    /// The input mesh with the pins that fall inside edges inserted as vertices, so that each
    /// lies exactly on its streamline (None: no pin fell inside an edge, or inserting them
    /// failed and nearest-vertex pins were used; `seam` and `pins` are then on the input mesh).
    /// Every planned pin is inserted, also those of chains whose re-route is then refused: a
    /// few split edges more than needed (four triangles for two each).
    pub refined: Option<Remeshed>,
}

/// Re-route the chains of `seam` (nodes: `fixed` plus the network's own nodes) along
/// streamlines of the face field `dirs` (one unit arm per face), except those `skip` refuses.
/// `spacing` is the pin spacing in metres; corners for the no-fewer-quads check are counted by
/// `CornerRule::new(mesh, index)` with `chords` and the field. A pin is where the streamline
/// crosses an edge: unless that crossing is within `snap` (share of the edge) of an end or on a
/// seam, the crossing itself becomes a new vertex (one remeshing for all chains), else the
/// nearest vertex, up to half an edge off the streamline, is the pin.
#[allow(clippy::too_many_arguments)]
pub fn reroute(
    mesh: &Mesh,
    seam: &EdgeData<bool>,
    fixed: &VertexData<bool>,
    index: &VertexData<i32>,
    dirs: &FaceData<Vec3>,
    chords: usize,
    spacing: f64,
    snap: f64,
    skip: &dyn Fn(&[VertexId]) -> bool,
) -> Rerouted {
    let unchanged = || Rerouted {
        seam: seam.clone(),
        pins: VertexData::filled(mesh.n_vertices(), false),
        chains: 0,
        refined: None,
    };
    let rule = CornerRule::new(mesh, index).with_chords(chords).with_field(dirs.clone());
    let before = patches_with(mesh, seam, &rule);
    if (0..before.n).any(|i| !before.is_disk(i)) || spacing <= 0.0 {
        return unchanged();
    }
    let mean_edge = mesh.mean_edge_length();
    let chains = network::chains(mesh, seam, fixed);
    let eligible = |c: &[VertexId]| {
        c.len() >= 4 && !skip(c) && chain_deviation(mesh, c, dirs) <= MAX_CHAIN_DEVIATION_DEG.to_radians()
    };
    // 1. Every chain's pins, planned on the input mesh (an edge carries one pin at most).
    let plan = |snap: f64| -> Vec<(usize, Vec<SurfacePoint>)> {
        let mut taken: BTreeSet<EdgeId> = BTreeSet::new();
        (0..chains.len())
            .filter(|&i| eligible(&chains[i]))
            .filter_map(|i| {
                let c = &chains[i];
                plan_chain(mesh, seam, &before.patch_of_face, c, dirs, spacing, mean_edge, snap, &mut taken)
                    .map(|p| (i, p))
            })
            .collect()
    };
    let mut plans = plan(snap);
    // 2. The edge pins inserted as vertices, each as a piece of its edge (seam edges carry no
    // pin, so no seam is split and every vertex keeps its id).
    let edge_pins: Vec<Vec<SurfacePoint>> = plans
        .iter()
        .flat_map(|(_, pins)| pins.iter())
        .filter_map(|p| match *p {
            SurfacePoint::Edge { edge, .. } => Some(vec![*p, SurfacePoint::Vertex(mesh.edge_vertices(edge)[0])]),
            SurfacePoint::Vertex(_) => None,
        })
        .collect();
    let mut refined = None;
    if !edge_pins.is_empty() {
        match insert_polylines(mesh, &edge_pins, &RemeshOptions { snap: 0.0 }) {
            Ok(r) => refined = Some(r),
            Err(e) => {
                tracing::debug!(error = %e, "exact pins not inserted; the nearest vertices are the pins");
                plans = plan(0.5);
            }
        }
    }
    if plans.is_empty() {
        return unchanged();
    }
    // 3. On the refined mesh: the pins as vertices, then the chains joined through them.
    let mut inserted = refined.iter().flat_map(|r| r.paths.iter().map(|p| p[0]));
    let waypoints: Vec<(usize, Vec<VertexId>)> = plans
        .iter()
        .map(|(i, pins)| {
            let vs = pins
                .iter()
                .map(|p| match *p {
                    SurfacePoint::Vertex(v) => v,
                    SurfacePoint::Edge { .. } => inserted.next().expect("one path per edge pin"),
                })
                .collect();
            (*i, vs)
        })
        .collect();
    let (m2, seam2, dirs2, rule2) = match &refined {
        None => (mesh, seam.clone(), dirs.clone(), rule),
        Some(r) => {
            let old: Vec<Vec<VertexId>> =
                mesh.edges().filter(|&e| seam[e]).map(|e| mesh.edge_vertices(e).to_vec()).collect();
            let dirs2 = r.face_parent.map(|&f| dirs[f]);
            let rule2 = CornerRule::new(&r.mesh, &r.carry(index, 0)).with_chords(chords).with_field(dirs2.clone());
            (&r.mesh, seam_edges(&r.mesh, &old), dirs2, rule2)
        }
    };
    let mut out = Rerouted { seam: seam2, pins: VertexData::filled(m2.n_vertices(), false), chains: 0, refined: None };
    let mut current = patches_with(m2, &out.seam, &rule2);
    for (i, exact) in &waypoints {
        let chain = &chains[*i];
        // The planned pins, else (when the chains re-routed before this one are in the way)
        // the nearest vertices of streamlines traced on the seams as they are now.
        let nearest = || {
            let mut none = BTreeSet::new();
            plan_chain(m2, &out.seam, &current.patch_of_face, chain, &dirs2, spacing, mean_edge, 0.5, &mut none).map(
                |pins| {
                    pins.iter().filter_map(|p| if let SurfacePoint::Vertex(v) = *p { Some(v) } else { None }).collect()
                },
            )
        };
        let attempt = |pins: &[VertexId]| {
            let path = join_pins(m2, &out.seam, &current.patch_of_face, chain, pins)?;
            let mut trial = out.seam.clone();
            for w in chain.windows(2) {
                if let Some(e) = edge_between(m2, w[0], w[1]) {
                    trial[e] = false;
                }
            }
            for w in path.windows(2) {
                if let Some(e) = edge_between(m2, w[0], w[1]) {
                    trial[e] = true;
                }
            }
            let after = current.reseamed(m2, &out.seam, &trial, &rule2);
            let valid =
                after.n == current.n && (0..after.n).all(|i| after.is_disk(i)) && quads(&after) >= quads(&current);
            valid.then_some((path, trial, after))
        };
        let Some((pins, (path, trial, after))) = attempt(exact)
            .map(|r| (exact.clone(), r))
            .or_else(|| nearest().and_then(|pins: Vec<VertexId>| attempt(&pins).map(|r| (pins, r))))
        else {
            continue;
        };
        out.seam = trial;
        current = after;
        let on_path: BTreeSet<VertexId> = path.into_iter().collect();
        for v in pins.into_iter().filter(|v| on_path.contains(v)) {
            out.pins[v] = true;
        }
        out.chains += 1;
    }
    out.refined = refined;
    out
}

/// Patches with four corners.
fn quads(p: &Patches) -> usize {
    p.corners.iter().filter(|c| c.len() == 4).count()
}

/// Length-weighted mean angle (radians) between a chain's edges and the nearest field arm of
/// their faces.
fn chain_deviation(mesh: &Mesh, chain: &[VertexId], dirs: &FaceData<Vec3>) -> f64 {
    let (mut acc, mut len) = (0.0, 0.0);
    for w in chain.windows(2) {
        let Some(e) = edge_between(mesh, w[0], w[1]) else { continue };
        let l = mesh.edge_length(e);
        acc += edge_deviation(mesh, e, dirs) * l;
        len += l;
    }
    if len > 0.0 { acc / len } else { 0.0 }
}

/// Angle (radians) between edge `e` and the nearest arm of the cross, the mean over the edge's
/// faces (the measure of `seam_field_deviation_median_deg`).
pub fn edge_deviation(mesh: &Mesh, e: EdgeId, dirs: &FaceData<Vec3>) -> f64 {
    let d = mesh.vector(mesh.edge_halfedge(e));
    match mesh.edge_faces(e) {
        (a, Some(b)) => 0.5 * (arm_deviation(mesh, a, &d, dirs) + arm_deviation(mesh, b, &d, dirs)),
        (a, None) => arm_deviation(mesh, a, &d, dirs),
    }
}

/// Angle between `d` (projected on face `f`) and the nearest arm of the cross there.
fn arm_deviation(mesh: &Mesh, f: FaceId, d: &Vec3, dirs: &FaceData<Vec3>) -> f64 {
    let n = mesh.face_normal(f);
    let t = d - n * n.dot(d);
    if t.norm() <= 1e-300 {
        return 0.0;
    }
    let t = t.normalize();
    let a = dirs[f];
    let b = n.cross(&a);
    a.dot(&t).abs().max(b.dot(&t).abs()).clamp(0.0, 1.0).acos()
}

/// The two patches a chain separates (None for a slit).
fn sides(mesh: &Mesh, patch_of_face: &FaceData<u32>, chain: &[VertexId]) -> Option<(u32, u32)> {
    let e0 = edge_between(mesh, chain[0], chain[1])?;
    let (f0, f1) = mesh.edge_faces(e0);
    let (pl, pr) = (patch_of_face[f0], patch_of_face[f1?]);
    (pl != pr).then_some((pl, pr))
}

/// Vertices a new course may use: not on another seam or the boundary (this chain's interior
/// is free), with all their faces in the two patches the chain separates.
fn free_vertices(
    mesh: &Mesh,
    seam: &EdgeData<bool>,
    patch_of_face: &FaceData<u32>,
    chain: &[VertexId],
    (pl, pr): (u32, u32),
) -> VertexData<bool> {
    let mut blocked = VertexData::filled(mesh.n_vertices(), false);
    for e in mesh.edges() {
        if seam[e] || mesh.is_boundary_edge(e) {
            for v in mesh.edge_vertices(e) {
                blocked[v] = true;
            }
        }
    }
    for &v in &chain[1..chain.len() - 1] {
        if !mesh.is_boundary_vertex(v) {
            blocked[v] = false;
        }
    }
    let in_region = |f: FaceId| patch_of_face[f] == pl || patch_of_face[f] == pr;
    mesh.vertices().map(|v| !blocked[v] && mesh.outgoing(v).all(|h| in_region(mesh.face(h)))).collect()
}

/// The pins of one chain's new course (its ends excluded, in order from the first end):
/// half-streamlines from both ends, a pin every `spacing` along them where the streamline
/// crosses an edge — that crossing itself when it lies inside an edge (not within `snap` of an
/// end) with both faces in the region, off the seams and not in `taken`, else the nearest free
/// vertex of the face. None when there is no pin.
#[allow(clippy::too_many_arguments)]
fn plan_chain(
    mesh: &Mesh,
    seam: &EdgeData<bool>,
    patch_of_face: &FaceData<u32>,
    chain: &[VertexId],
    dirs: &FaceData<Vec3>,
    spacing: f64,
    mean_edge: f64,
    snap: f64,
    taken: &mut BTreeSet<EdgeId>,
) -> Option<Vec<SurfacePoint>> {
    let (a, b) = (chain[0], *chain.last().expect("chain"));
    let (pl, pr) = sides(mesh, patch_of_face, chain)?;
    let in_region = |f: FaceId| patch_of_face[f] == pl || patch_of_face[f] == pr;
    let free = free_vertices(mesh, seam, patch_of_face, chain, (pl, pr));
    let length: f64 = chain.windows(2).map(|w| (mesh.position(w[1]) - mesh.position(w[0])).norm()).sum();
    let corridor = (0.25 * length).max(2.0 * mean_edge);
    // Short chains get closer pins (at least two per half when it is long enough).
    let spacing = spacing.min(length / 3.0).max(1.5 * mean_edge);
    let chain_pts: Vec<Vec3> = chain.iter().map(|&v| mesh.position(v)).collect();
    let dist_to_chain =
        |p: &Vec3| chain_pts.iter().map(|q| (q - p).norm_squared()).fold(f64::INFINITY, f64::min).sqrt();
    let mut half = |from: VertexId, toward: &[VertexId]| -> Vec<SurfacePoint> {
        let k = toward.len().min(5);
        let d0 = mesh.position(toward[k - 1]) - mesh.position(from);
        let pts = streamline(mesh, dirs, from, d0, 0.5 * (length - spacing), &in_region);
        let mut pins: Vec<SurfacePoint> = Vec::new();
        let (mut acc, mut next) = (0.0, spacing);
        let mut prev = mesh.position(from);
        for &(p, f, h) in &pts {
            if dist_to_chain(&p) > corridor {
                break;
            }
            acc += (p - prev).norm();
            prev = p;
            if acc < next {
                continue;
            }
            next += spacing;
            let e = mesh.edge(h);
            let x = mesh.edge_vertices(e)[0];
            let t = (p - mesh.position(x)).norm() / mesh.edge_length(e).max(f64::MIN_POSITIVE);
            let inside = matches!(mesh.edge_faces(e), (f0, Some(f1)) if in_region(f0) && in_region(f1));
            if inside && !seam[e] && t > snap && t < 1.0 - snap && taken.insert(e) {
                pins.push(SurfacePoint::Edge { edge: e, t });
                continue;
            }
            // The nearest free vertex of the face.
            let pin = mesh
                .face_vertices(f)
                .into_iter()
                .filter(|&v| free[v])
                .min_by(|x, y| (mesh.position(*x) - p).norm().total_cmp(&(mesh.position(*y) - p).norm()));
            match pin {
                Some(v) if !pins.contains(&SurfacePoint::Vertex(v)) => pins.push(SurfacePoint::Vertex(v)),
                Some(_) => {}
                None => break,
            }
        }
        pins
    };
    let from_a = half(a, &chain[1..]);
    let rev: Vec<VertexId> = chain.iter().rev().copied().collect();
    let from_b = half(b, &rev[1..]);
    let mut pins = from_a;
    pins.extend(from_b.into_iter().rev());
    pins.dedup();
    (!pins.is_empty()).then_some(pins)
}

/// The new course of a chain through its pins (vertices): shortest edge paths between
/// consecutive ones through free vertices ([`free_vertices`]), never visiting a vertex twice.
fn join_pins(
    mesh: &Mesh,
    seam: &EdgeData<bool>,
    patch_of_face: &FaceData<u32>,
    chain: &[VertexId],
    pins: &[VertexId],
) -> Option<Vec<VertexId>> {
    let (a, b) = (chain[0], *chain.last().expect("chain"));
    let region = sides(mesh, patch_of_face, chain)?;
    let free = free_vertices(mesh, seam, patch_of_face, chain, region);
    // Pins that another re-routed chain took are skipped.
    let mut waypoints = vec![a];
    waypoints.extend(pins.iter().copied().filter(|&v| free[v]));
    waypoints.push(b);
    waypoints.dedup();
    let mut used = VertexData::filled(mesh.n_vertices(), false);
    let mut path = vec![a];
    used[a] = true;
    for w in waypoints.windows(2) {
        let target = w[1];
        if used[target] {
            return None;
        }
        let leg = shortest_edge_path(mesh, w[0], target, &|v| free[v] && !used[v])?;
        for &v in &leg[1..] {
            used[v] = true;
            path.push(v);
        }
    }
    Some(path)
}

/// Points (with their face and the halfedge of the face they lie on) of the streamline of the cross field `dirs` from vertex `start`,
/// leaving in the direction closest to `d0`, for at most `max_len`, while `in_region`. The
/// field is constant per face: in each face the arm closest to the travel direction is
/// followed straight to the exit edge. Stops at the mesh boundary, when leaving the region, and
/// where the field turns back (two faces whose arms point into each other).
fn streamline(
    mesh: &Mesh,
    dirs: &FaceData<Vec3>,
    start: VertexId,
    d0: Vec3,
    max_len: f64,
    in_region: &impl Fn(FaceId) -> bool,
) -> Vec<(Vec3, FaceId, HalfedgeId)> {
    let mut out = Vec::new();
    let p0 = mesh.position(start);
    // The face of the fan whose field arm closest to d0 points into it (the departure); when
    // none does (at a singularity the arms of the fan disagree), the face containing d0, left
    // along d0 itself.
    let inside = |h: HalfedgeId, t: &Vec3| {
        let n = mesh.face_normal(mesh.face(h));
        let pb = mesh.position(mesh.head(h));
        let pc = mesh.position(mesh.opposite_vertex(h));
        (pb - p0).cross(t).dot(&n) >= 0.0 && t.cross(&(pc - p0)).dot(&n) >= 0.0
    };
    let mut first: Option<(FaceId, Vec3, bool)> = None;
    for h in mesh.outgoing(start) {
        let f = mesh.face(h);
        let arm = closest_arm(mesh, dirs, f, &d0);
        if arm.dot(&d0) > 0.0 && inside(h, &arm) {
            first = Some((f, arm, true));
            break;
        }
    }
    if first.is_none() {
        for h in mesh.outgoing(start) {
            let f = mesh.face(h);
            let n = mesh.face_normal(f);
            let t = d0 - n * n.dot(&d0);
            if t.norm() > 0.0 && inside(h, &t) {
                first = Some((f, t.normalize(), false));
                break;
            }
        }
    }
    let Some((mut f, t, _)) = first else { return out };
    if !in_region(f) {
        return out;
    }
    let mut p = p0;
    let mut travel = t.normalize();
    let mut entry: Option<HalfedgeId> = None;
    let mut len = 0.0;
    let mut first_face = true;
    for _ in 0..(4 * mesh.n_faces()).max(16) {
        let n = mesh.face_normal(f);
        // Arm closest to the travel direction (in the first face: the departure direction).
        let u = if first_face { travel } else { closest_arm(mesh, dirs, f, &travel) };
        first_face = false;
        // Exit point: the ray p + s u against the face's edges other than the entry edge.
        let mut exit: Option<(f64, HalfedgeId, Vec3)> = None;
        for k in 0..3 {
            let h = mesh.face_halfedge(f, k);
            if Some(h) == entry {
                continue;
            }
            let (x, y) = (mesh.position(mesh.tail(h)), mesh.position(mesh.head(h)));
            if let Some((s, q)) = ray_segment(&p, &u, &x, &y, &n)
                && s > 1e-12
                && exit.as_ref().is_none_or(|e| s < e.0)
            {
                exit = Some((s, h, q));
            }
        }
        let Some((s, h, q)) = exit else { break };
        len += s;
        out.push((q, f, h));
        if len >= max_len {
            break;
        }
        let Some(tw) = mesh.twin(h) else { break };
        let g = mesh.face(tw);
        if !in_region(g) {
            break;
        }
        // Does the next face's field turn back across the same edge?
        let ug = closest_arm(mesh, dirs, g, &u);
        // The inward side of the shared edge in g: towards g's third vertex.
        let third = mesh.position(mesh.opposite_vertex(tw));
        let (x, y) = (mesh.position(mesh.tail(tw)), mesh.position(mesh.head(tw)));
        let edge = (y - x).normalize();
        let inward = {
            let w = third - x;
            w - edge * edge.dot(&w)
        };
        if ug.dot(&inward) <= 0.0 {
            break;
        }
        p = q;
        travel = u;
        entry = Some(tw);
        f = g;
    }
    out
}

/// The arm of the cross on face `f` closest to direction `d`.
fn closest_arm(mesh: &Mesh, dirs: &FaceData<Vec3>, f: FaceId, d: &Vec3) -> Vec3 {
    let a = dirs[f];
    let b = mesh.face_normal(f).cross(&a);
    let mut best = a;
    for c in [-a, b, -b] {
        if c.dot(d) > best.dot(d) {
            best = c;
        }
    }
    best
}

/// Intersection of the ray `p + s u` with the segment `x y`, all in the plane of normal `n`:
/// `(s, point)` when it exists.
fn ray_segment(p: &Vec3, u: &Vec3, x: &Vec3, y: &Vec3, n: &Vec3) -> Option<(f64, Vec3)> {
    // Solve p + s u = x + r (y − x) in the plane: cross both sides with (y − x) and with u.
    let e = y - x;
    let denom = u.cross(&e).dot(n);
    if denom.abs() <= 1e-300 {
        return None;
    }
    let w = x - p;
    let s = w.cross(&e).dot(n) / denom;
    let r = w.cross(u).dot(n) / denom;
    if !(-1e-9..=1.0 + 1e-9).contains(&r) {
        return None;
    }
    let r = r.clamp(0.0, 1.0);
    Some((s, x + e * r))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes::grid;

    /// Vertex at grid position (i, j) of a `n × n` unit grid.
    fn at(n: usize, i: usize, j: usize) -> VertexId {
        VertexId((j * (n + 1) + i) as u32)
    }

    fn constant_field(mesh: &Mesh, angle: f64) -> FaceData<Vec3> {
        mesh.face_ids().map(|_| Vec3::new(angle.cos(), angle.sin(), 0.0)).collect()
    }

    fn distance_to_line(p: Vec3, o: Vec3, angle: f64) -> f64 {
        let d = p - o;
        (d.x * angle.sin() - d.y * angle.cos()).abs()
    }

    #[test]
    fn streamlines_of_a_constant_field_are_straight() {
        let n = 30;
        let m = grid(n, n, n as f64, n as f64);
        let angle = 20f64.to_radians();
        let dirs = constant_field(&m, angle);
        let start = at(n, 3, 4);
        let pts = streamline(&m, &dirs, start, Vec3::new(1.0, 0.3, 0.0), 20.0, &|_| true);
        assert!(pts.len() > 20);
        let o = m.position(start);
        for (p, _, _) in &pts {
            assert!(distance_to_line(*p, o, angle) < 1e-9, "{p:?}");
            assert!((p - o).dot(&Vec3::new(angle.cos(), angle.sin(), 0.0)) > 0.0);
        }
        let last = pts.last().unwrap().0;
        assert!((last - o).norm() >= 20.0 - 1e-9 && (last - o).norm() < 21.5);
        // Stops where the region ends.
        let half = streamline(&m, &dirs, start, Vec3::new(1.0, 0.3, 0.0), 100.0, &|f| m.face_positions(f)[0].x < 15.0);
        assert!(half.iter().all(|(p, _, _)| p.x <= 16.0 + 1e-9));
    }

    #[test]
    fn a_chain_off_the_field_is_moved_onto_it() {
        // A seam across a flat square: along the bottom rows first (20° off a constant field at
        // 20°), then a staircase along the field to the right side.
        let n = 40;
        let m = grid(n, n, n as f64, n as f64);
        let angle = 20f64.to_radians();
        let dirs = constant_field(&m, angle);
        let mut path: Vec<VertexId> = (0..=20).map(|i| at(n, i, 5)).collect();
        let (mut i, mut j) = (20usize, 5usize);
        while i < n {
            // Step right, or up when the staircase fell below the line at 20°.
            if (j as f64) < 5.0 + (i as f64 + 1.0 - 20.0) * angle.tan() {
                j += 1;
            } else {
                i += 1;
            }
            path.push(at(n, i, j));
        }
        let mut seam = EdgeData::filled(m.n_edges(), false);
        for w in path.windows(2) {
            seam[edge_between(&m, w[0], w[1]).unwrap()] = true;
        }
        let fixed = VertexData::filled(m.n_vertices(), false);
        let index = VertexData::filled(m.n_vertices(), 0);
        let (a, b) = (m.position(path[0]), m.position(*path.last().unwrap()));
        // Distance of the early part to the field line through the start, of the late part to
        // the one through the end.
        let off = |pts: &[Vec3]| {
            let early = pts.iter().filter(|q| q.x < 13.0);
            let late = pts.iter().filter(|q| q.x > 27.0);
            let e = early.map(|q| distance_to_line(*q, a, angle)).fold(0.0, f64::max);
            let l = late.map(|q| distance_to_line(*q, b, angle)).fold(0.0, f64::max);
            e.max(l)
        };
        let traced: Vec<Vec3> = path.iter().map(|&v| m.position(v)).collect();
        assert!(off(&traced) > 4.0);
        let r = reroute(&m, &seam, &fixed, &index, &dirs, 1, 5.0, 0.3, &|_| false);
        assert_eq!(r.chains, 1);
        // Pins inside edges were inserted as vertices: the new course lives on the refined mesh.
        let refined = r.refined.as_ref().expect("some pins fall inside edges");
        let m2 = &refined.mesh;
        let after = patches_with(m2, &r.seam, &CornerRule::plain(m2));
        assert_eq!(after.n, 2);
        assert!((0..2).all(|i| after.is_disk(i)));
        let new_course: Vec<Vec3> =
            m2.edges().filter(|&e| r.seam[e]).flat_map(|e| m2.edge_vertices(e)).map(|v| m2.position(v)).collect();
        assert!(off(&new_course) < 1.5, "{}", off(&new_course));
        let pins: Vec<VertexId> = m2.vertices().filter(|&v| r.pins[v]).collect();
        assert!(pins.len() >= 4);
        // The inserted pins lie on the streamlines themselves (those through the two ends).
        let exact: Vec<Vec3> = pins.iter().filter(|v| v.idx() >= m.n_vertices()).map(|&v| m2.position(v)).collect();
        assert!(exact.len() >= 2);
        assert!(off(&exact) < 1e-9, "{}", off(&exact));
        // Refused chains stay.
        let kept = reroute(&m, &seam, &fixed, &index, &dirs, 1, 5.0, 0.3, &|_| true);
        assert_eq!(kept.chains, 0);
        assert!(kept.refined.is_none());
        assert!(m.edges().all(|e| kept.seam[e] == seam[e]));
    }
}
