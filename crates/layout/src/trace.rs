//! Separatrix tracing as shortest-path planning (paper §6.1; Pietroni et al. 2016, "Tracing
//! Field-Coherent Quad Layouts"; the graph of `xfield_tracer`, ALGORITHMS.md §6).
//!
//! **Graph.** Four nodes per vertex, `(v, k)` = "travelling along arm k of the cross at v".
//! Node `(v, k)` has an arc to `(w, k')` for every neighbour w whose edge direction (projected on
//! v's tangent plane) is within `1.4 φ_max` (at most 80°) of arm k; k' is the arm of w closest to
//! arm k. The arc costs `ℓ · (1 + D (φ/φ_max)²)` with φ the mean of the deviations at both ends
//! and D the drift penalty (`[layout] drift_penalty`). (The graph of Pietroni et al. admits
//! φ ≤ φ_max only; on coarse meshes an arm often points between two edges ~50° off on either
//! side, and a hard 45° limit strands the separatrix, so the wider cone zig-zags at a high cost.)
//!
//! **Separatrices.** A singularity of index q (quarter turns) emits 4 − q of them. Its own
//! field is undefined, so the emission edges are chosen from the faces' field: the outgoing
//! edges best aligned with a cross arm of their adjacent faces, spread around the vertex (at
//! least 60% of the even spacing apart). Each separatrix is the cheapest path from its first
//! node to a target: another singularity, a boundary vertex, or a vertex of an earlier
//! separatrix reached across it (the arm of arrival perpendicular to that separatrix's axis there:
//! a T-junction). Reaching an earlier separatrix along its own axis is forbidden (no tangential
//! merge), and so is passing through any target, so separatrices never cross.
//!
//! **Order.** Emissions are traced in a random order from `seed` (the paper: the order changes
//! the topology of the layout, not its quality).
//!
//! Complexity: each separatrix is one Dijkstra search, O(V log V) in the worst case, usually
//! far less (it stops at the first target).

use crate::vertex_field::VertexField;
use clothcast_field::Singularity;
use clothcast_mesh::util::{MinCost, SplitMix64};
use clothcast_mesh::{FaceData, Mesh, Vec3, VertexData, VertexId};
use std::collections::BinaryHeap;

/// Tracing options.
#[derive(Clone, Debug)]
pub struct TraceOptions {
    /// D of the cost: how much drifting away from the field costs.
    pub drift_penalty: f64,
    /// Largest deviation φ_max (degrees) of an arc from the field.
    pub max_deviation_deg: f64,
    /// Seed of the tracing order.
    pub seed: u64,
    /// Radius (in mean edge lengths) of the capture zone of a singularity: a separatrix that
    /// reaches a free vertex this close to another singularity ends there (joined to it inside
    /// the zone). Discrete separatrices rarely hit a singular vertex exactly; without capture
    /// they pass it by and end in a T-junction, which breaks the quad structure. The radius is
    /// also capped at 0.4 × the distance to the nearest other singularity.
    pub capture_radius: f64,
}

impl Default for TraceOptions {
    fn default() -> Self {
        Self { drift_penalty: 10.0, max_deviation_deg: 45.0, seed: 1, capture_radius: 4.0 }
    }
}

/// How a separatrix ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeparatrixEnd {
    /// At another singularity.
    Singularity,
    /// On the mesh boundary.
    Boundary,
    /// Across an earlier separatrix (index of that separatrix).
    TJunction(usize),
    /// No target reachable (dropped).
    Failed,
}

/// A traced separatrix.
#[derive(Clone, Debug)]
pub struct Separatrix {
    /// Vertices from the source singularity to the end.
    pub vertices: Vec<VertexId>,
    /// The travel arm at each vertex (its axis, mod 2, tells T-junctions from tangential hits).
    pub arms: Vec<u8>,
    /// How it ended.
    pub end: SeparatrixEnd,
}

/// What a vertex is during tracing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mark {
    Free,
    Singular,
    Boundary,
    /// On separatrix `path` whose axis there is `axis` (0 or 1).
    Path {
        path: u32,
        axis: u8,
    },
}

/// Angle between a direction and the nearest arm of a face's cross (both in the face plane).
fn face_deviation(mesh: &Mesh, dirs: &FaceData<Vec3>, f: clothcast_mesh::FaceId, d: &Vec3) -> f64 {
    let n = mesh.face_normal(f);
    let t = d - n * n.dot(d);
    if t.norm() < 1e-300 {
        return std::f64::consts::FRAC_PI_2;
    }
    let t = t.normalize();
    let a = dirs[f];
    let b = n.cross(&a);
    let c = a.dot(&t).abs().max(b.dot(&t).abs()).clamp(0.0, 1.0);
    c.acos()
}

/// Polar angle of the edge `s → w` around `s` (sum of the corner angles before it in the fan)
/// and the total angle around `s`.
fn polar_angle(mesh: &Mesh, angles: &clothcast_mesh::HalfedgeData<f64>, s: VertexId, w: VertexId) -> (f64, f64) {
    let (mut polar, mut found) = (0.0, None);
    for h in mesh.outgoing(s) {
        if mesh.head(h) == w {
            found = Some(polar);
        }
        polar += angles[h];
    }
    (found.unwrap_or(polar), polar)
}

/// Emission edges of a singularity: the neighbours and their polar angles.
fn emissions(mesh: &Mesh, dirs: &FaceData<Vec3>, s: VertexId, count: usize) -> Vec<(VertexId, f64)> {
    // Angular position of each outgoing edge in the vertex's polar coordinate.
    let angles = mesh.corner_angles();
    let mut cands: Vec<(f64, f64, VertexId)> = Vec::new(); // (deviation, polar angle, neighbour)
    let mut polar = 0.0;
    for h in mesh.outgoing(s) {
        let w = mesh.head(h);
        let d = mesh.vector(h);
        let mut dev = face_deviation(mesh, dirs, mesh.face(h), &d);
        if let Some(t) = mesh.twin(h) {
            dev = 0.5 * (dev + face_deviation(mesh, dirs, mesh.face(t), &d));
        }
        cands.push((dev, polar, w));
        polar += angles[h];
    }
    let total = polar;
    cands.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
    let mut chosen: Vec<(f64, VertexId)> = Vec::new();
    for frac in [0.6, 0.3] {
        let min_sep = frac * total / count as f64;
        for &(_, p, w) in &cands {
            if chosen.len() == count {
                break;
            }
            if chosen.iter().any(|&(_, x)| x == w) {
                continue;
            }
            let far = chosen.iter().all(|&(q, _)| {
                let d = (p - q).abs();
                d.min(total - d) >= min_sep
            });
            if far {
                chosen.push((p, w));
            }
        }
        if chosen.len() == count {
            break;
        }
    }
    chosen.into_iter().map(|(p, w)| (w, p)).collect()
}

/// Capture zones: for every vertex within its singularity's capture radius, the singularity
/// (its vertex) and the next vertex on a shortest path to it.
fn capture_zones(
    mesh: &Mesh,
    singularities: &[Singularity],
    radius_edges: f64,
) -> (VertexData<Option<VertexId>>, VertexData<Option<VertexId>>) {
    let nv = mesh.n_vertices();
    let mut owner: VertexData<Option<VertexId>> = VertexData::filled(nv, None);
    let mut pred: VertexData<Option<VertexId>> = VertexData::filled(nv, None);
    if singularities.is_empty() || radius_edges <= 0.0 {
        return (owner, pred);
    }
    let h = mesh.mean_edge_length();
    let radius: Vec<f64> = singularities
        .iter()
        .map(|s| {
            let p = mesh.position(s.vertex);
            let nearest = singularities
                .iter()
                .filter(|t| t.vertex != s.vertex)
                .map(|t| (mesh.position(t.vertex) - p).norm())
                .fold(f64::INFINITY, f64::min);
            (radius_edges * h).min(0.4 * nearest)
        })
        .collect();
    let mut dist = vec![f64::INFINITY; nv];
    let mut heap = BinaryHeap::new();
    let mut which = vec![u32::MAX; nv];
    for (i, s) in singularities.iter().enumerate() {
        dist[s.vertex.idx()] = 0.0;
        which[s.vertex.idx()] = i as u32;
        heap.push(MinCost(0.0, s.vertex.0));
    }
    while let Some(MinCost(d, v)) = heap.pop() {
        let v = VertexId(v);
        if d > dist[v.idx()] {
            continue;
        }
        let i = which[v.idx()] as usize;
        owner[v] = Some(singularities[i].vertex);
        for u in mesh.vertex_neighbors(v) {
            let nd = d + (mesh.position(u) - mesh.position(v)).norm();
            if nd <= radius[i] && nd < dist[u.idx()] {
                dist[u.idx()] = nd;
                which[u.idx()] = i as u32;
                pred[u] = Some(v);
                heap.push(MinCost(nd, u.0));
            }
        }
    }
    (owner, pred)
}

/// Trace every separatrix of the given singularities.
pub fn trace_separatrices(
    mesh: &Mesh,
    vf: &VertexField,
    face_dirs: &FaceData<Vec3>,
    singularities: &[Singularity],
    opts: &TraceOptions,
) -> Vec<Separatrix> {
    let nv = mesh.n_vertices();
    let mut mark: VertexData<Mark> = VertexData::filled(nv, Mark::Free);
    for v in mesh.vertices() {
        if mesh.is_boundary_vertex(v) {
            mark[v] = Mark::Boundary;
        }
    }
    for s in singularities {
        mark[s.vertex] = Mark::Singular;
    }
    // All emissions, then a seeded shuffle of the order.
    // Emissions (singularity, first vertex, polar angle, half the even spacing).
    let mut jobs: Vec<(VertexId, VertexId, f64, f64)> = Vec::new();
    let angles = mesh.corner_angles();
    for s in singularities {
        let count = (4 - s.index).max(0) as usize;
        let total: f64 = mesh.outgoing(s.vertex).map(|h| angles[h]).sum();
        for (w, p) in emissions(mesh, face_dirs, s.vertex, count) {
            jobs.push((s.vertex, w, p, 0.5 * total / count as f64));
        }
    }
    // Emission directions of every singularity (polar angles, half spacing, total angle): a
    // separatrix may only arrive at a singularity along one of its free emission directions.
    let mut emission_dirs: std::collections::BTreeMap<VertexId, (Vec<f64>, f64, f64)> =
        std::collections::BTreeMap::new();
    for &(s, _, p, hs) in &jobs {
        let total: f64 = mesh.outgoing(s).map(|h| angles[h]).sum();
        let e = emission_dirs.entry(s).or_insert((Vec::new(), hs, total));
        e.0.push(p);
    }
    SplitMix64::new(opts.seed).shuffle(&mut jobs);
    // Directions at each singularity already taken by a separatrix (polar angles): an emission
    // close to one is the far end of a separatrix traced from the other side, and is skipped.
    let mut taken: std::collections::BTreeMap<VertexId, Vec<f64>> = std::collections::BTreeMap::new();

    let phi_max = opts.max_deviation_deg.to_radians();
    // Steps up to this deviation are admissible (at a high cost): on coarse meshes the arm often
    // points between two edges both ~50° off, and the path must zig-zag.
    let cutoff = (1.4 * phi_max).min(80f64.to_radians());
    let (zone, zone_pred) = capture_zones(mesh, singularities, opts.capture_radius);
    // The path from a zone vertex to its singularity, if every vertex on it is still free.
    // Whether a separatrix may arrive at singularity `t` from its neighbour `u`: the direction
    // must be near one of t's emission directions and not near one already taken.
    let arrival_ok = |taken: &std::collections::BTreeMap<VertexId, Vec<f64>>, t: VertexId, u: VertexId| -> bool {
        let Some((dirs, hs, total)) = emission_dirs.get(&t) else { return false };
        let (p, _) = polar_angle(mesh, &angles, t, u);
        let close = |q: f64| {
            let d = (p - q).abs();
            d.min(total - d) < *hs
        };
        dirs.iter().any(|&q| close(q)) && !taken.get(&t).is_some_and(|ts| ts.iter().any(|&q| close(q)))
    };
    let capture = |mark: &VertexData<Mark>,
                   taken: &std::collections::BTreeMap<VertexId, Vec<f64>>,
                   v: VertexId,
                   s: VertexId|
     -> Option<Vec<VertexId>> {
        let t = zone[v]?;
        if t == s || mark[v] != Mark::Free {
            return None;
        }
        let mut tail = Vec::new();
        let mut cur = v;
        while let Some(p) = zone_pred[cur] {
            if p == t {
                if !arrival_ok(taken, t, cur) {
                    return None;
                }
                tail.push(p);
                return Some(tail);
            }
            if mark[p] != Mark::Free {
                return None;
            }
            tail.push(p);
            cur = p;
        }
        None
    };
    let mut out: Vec<Separatrix> = Vec::new();
    // Pairs of singularities already joined by a separatrix (a second one would enclose a
    // sliver), and the unit tangent of the separatrix through every path vertex.
    let mut linked: std::collections::BTreeSet<(VertexId, VertexId)> = std::collections::BTreeSet::new();
    let mut path_tangent: VertexData<Vec3> = VertexData::filled(nv, Vec3::zeros());
    // Dijkstra scratch, reset per search through the touched list.
    let mut dist = vec![f64::INFINITY; 4 * nv];
    let mut prev = vec![u32::MAX; 4 * nv];
    let mut touched: Vec<u32> = Vec::new();
    for (s, w, polar, half_spacing) in jobs {
        let total: f64 = mesh.outgoing(s).map(|h| angles[h]).sum();
        let covered = taken.get(&s).is_some_and(|ps| {
            ps.iter().any(|&q| {
                let d = (polar - q).abs();
                d.min(total - d) < half_spacing
            })
        });
        if covered {
            continue;
        }
        let (k0, _) = vf.best_arm(w, &(mesh.position(w) - mesh.position(s)));
        // Whether the separatrix may step from `from` onto `v` along arm `k`: not back to its
        // singularity, onto another singularity only along a free emission direction and not
        // twice between the same two singularities, onto an earlier separatrix only across it
        // (perpendicular both by arm and geometrically: a T-junction).
        let enter_ok = |mark: &VertexData<Mark>,
                        taken: &std::collections::BTreeMap<VertexId, Vec<f64>>,
                        from: VertexId,
                        v: VertexId,
                        k: usize|
         -> bool {
            if v == s {
                return false;
            }
            match mark[v] {
                Mark::Free | Mark::Boundary => true,
                Mark::Singular => arrival_ok(taken, v, from) && !linked.contains(&(s.min(v), s.max(v))),
                Mark::Path { axis, .. } => {
                    let d = (mesh.position(v) - mesh.position(from)).normalize();
                    (k % 2) as u8 != axis && d.dot(&path_tangent[v]).abs() < std::f64::consts::FRAC_1_SQRT_2
                }
            }
        };
        // What reaching `v` (entered with `enter_ok`) means.
        let hit = |mark: &VertexData<Mark>, v: VertexId| -> Option<SeparatrixEnd> {
            match mark[v] {
                Mark::Free => None,
                Mark::Singular => Some(SeparatrixEnd::Singularity),
                Mark::Boundary => Some(SeparatrixEnd::Boundary),
                Mark::Path { path, .. } => Some(SeparatrixEnd::TJunction(path as usize)),
            }
        };
        if !enter_ok(&mark, &taken, s, w, k0) {
            continue;
        }
        let mut result: Option<(u32, SeparatrixEnd)> = None;
        let mut tail: Vec<VertexId> = Vec::new();
        if let Some(t) =
            capture(&mark, &taken, w, s).filter(|t| t.last().is_some_and(|&e| !linked.contains(&(s.min(e), s.max(e)))))
        {
            result = Some(((4 * w.0) + k0 as u32, SeparatrixEnd::Singularity));
            tail = t;
        } else if let Some(end) = hit(&mark, w) {
            result = Some(((4 * w.0) + k0 as u32, end));
        } else {
            for &t in &touched {
                dist[t as usize] = f64::INFINITY;
                prev[t as usize] = u32::MAX;
            }
            touched.clear();
            let start = 4 * w.0 + k0 as u32;
            dist[start as usize] = 0.0;
            touched.push(start);
            let mut heap = BinaryHeap::new();
            heap.push(MinCost(0.0, start));
            while let Some(MinCost(d, node)) = heap.pop() {
                if d > dist[node as usize] {
                    continue;
                }
                let (v, k) = (VertexId(node / 4), (node % 4) as usize);
                if node != start {
                    if let Some(t) = capture(&mark, &taken, v, s)
                        .filter(|t| t.last().is_some_and(|&e| !linked.contains(&(s.min(e), s.max(e)))))
                    {
                        result = Some((node, SeparatrixEnd::Singularity));
                        tail = t;
                        break;
                    }
                    if let Some(end) = hit(&mark, v) {
                        result = Some((node, end));
                        break;
                    }
                }
                let arm = vf.arm(v, k);
                for u in mesh.vertex_neighbors(v) {
                    let Some((k2, cost)) = arc(mesh, vf, v, &arm, u, cutoff, phi_max, opts.drift_penalty) else {
                        continue;
                    };
                    if !enter_ok(&mark, &taken, v, u, k2) {
                        continue;
                    }
                    let next = 4 * u.0 + k2 as u32;
                    let nd = d + cost;
                    if nd < dist[next as usize] {
                        if dist[next as usize] == f64::INFINITY {
                            touched.push(next);
                        }
                        dist[next as usize] = nd;
                        prev[next as usize] = node;
                        heap.push(MinCost(nd, next));
                    }
                }
            }
        }
        let Some((end_node, end)) = result else {
            tracing::debug!(singularity = s.0, "separatrix found no target");
            out.push(Separatrix { vertices: vec![s], arms: vec![], end: SeparatrixEnd::Failed });
            continue;
        };
        // Reconstruct; cut at the first repeated vertex (a path touching itself ends there).
        let mut nodes = vec![end_node];
        let mut cur = end_node;
        while prev[cur as usize] != u32::MAX && cur != 4 * w.0 + k0 as u32 {
            cur = prev[cur as usize];
            nodes.push(cur);
        }
        nodes.reverse();
        let mut vertices = vec![s];
        let mut arms = vec![k0 as u8];
        let mut end = end;
        for n in nodes {
            let v = VertexId(n / 4);
            if vertices.contains(&v) {
                end = SeparatrixEnd::Failed;
                break;
            }
            vertices.push(v);
            arms.push((n % 4) as u8);
        }
        if end != SeparatrixEnd::Failed {
            for &v in &tail {
                if vertices.contains(&v) {
                    end = SeparatrixEnd::Failed;
                    break;
                }
                let prev_v = *vertices.last().expect("non-empty");
                let (k, _) = vf.best_arm(prev_v, &(mesh.position(v) - mesh.position(prev_v)));
                *arms.last_mut().expect("non-empty") = k as u8;
                vertices.push(v);
                arms.push(k as u8);
            }
        }
        if end == SeparatrixEnd::Failed || vertices.len() < 2 {
            out.push(Separatrix { vertices: vec![s], arms: vec![], end: SeparatrixEnd::Failed });
            continue;
        }
        let id = out.len() as u32;
        taken.entry(s).or_default().push(polar);
        if end == SeparatrixEnd::Singularity {
            let (t, u) = (vertices[vertices.len() - 1], vertices[vertices.len() - 2]);
            taken.entry(t).or_default().push(polar_angle(mesh, &angles, t, u).0);
            linked.insert((s.min(t), s.max(t)));
        }
        for i in 1..vertices.len() - 1 {
            mark[vertices[i]] = Mark::Path { path: id, axis: arms[i] % 2 };
            let d = mesh.position(vertices[i + 1]) - mesh.position(vertices[i - 1]);
            path_tangent[vertices[i]] = if d.norm() > 0.0 { d.normalize() } else { Vec3::zeros() };
        }
        out.push(Separatrix { vertices, arms, end });
    }
    out
}

/// One field-aligned path on the direction-aware graph (the separatrix cost, the same cone):
/// from `start` along arm `k0` to the cheapest vertex for which `target` holds, never entering
/// a vertex for which `allowed` is false. Returns the vertices from `start` to the target.
/// A target is only reached across the seams there (`seam_at(u, w)`: the edge u–w is a seam):
/// the last step must make at least 45° with every seam edge at the target, so the new seam
/// ends in a T-junction, not tangentially (which would leave a cusp).
/// `first_dir` (if given) replaces the arm for the first step (for a start at a singular vertex,
/// whose own cross is undefined).
///
/// Used for the seams of developability splits. O(V log V) worst case (a search over the
/// allowed region).
#[allow(clippy::too_many_arguments)]
pub fn field_path(
    mesh: &Mesh,
    vf: &VertexField,
    start: VertexId,
    k0: usize,
    first_dir: Option<Vec3>,
    opts: &TraceOptions,
    allowed: &dyn Fn(VertexId) -> bool,
    target: &dyn Fn(VertexId) -> bool,
    seam_at: &dyn Fn(VertexId, VertexId) -> bool,
) -> Option<Vec<VertexId>> {
    let phi_max = opts.max_deviation_deg.to_radians();
    let cutoff = (1.4 * phi_max).min(80f64.to_radians());
    let mut dist: std::collections::HashMap<u32, (f64, u32)> = std::collections::HashMap::new();
    let s = 4 * start.0 + k0 as u32;
    dist.insert(s, (0.0, u32::MAX));
    let mut heap = BinaryHeap::new();
    heap.push(MinCost(0.0, s));
    while let Some(MinCost(d, node)) = heap.pop() {
        if dist.get(&node).is_some_and(|&(x, _)| d > x) {
            continue;
        }
        let (v, k) = (VertexId(node / 4), (node % 4) as usize);
        if node != s && target(v) && arrives_across(mesh, dist.get(&node).map(|&(_, p)| VertexId(p / 4)), v, seam_at) {
            let mut out = vec![v];
            let mut cur = node;
            while let Some(&(_, p)) = dist.get(&cur) {
                if p == u32::MAX {
                    break;
                }
                out.push(VertexId(p / 4));
                cur = p;
            }
            out.reverse();
            // A path through the same vertex twice is not simple: refuse it.
            let mut sorted = out.clone();
            sorted.sort_unstable();
            sorted.dedup();
            return (sorted.len() == out.len()).then_some(out);
        }
        let arm = match first_dir {
            Some(d) if node == s => {
                let n = vf.normal[v];
                let t = d - n * n.dot(&d);
                if t.norm() > 0.0 { t.normalize() } else { vf.arm(v, k) }
            }
            _ => vf.arm(v, k),
        };
        for u in mesh.vertex_neighbors(v) {
            if u == start || !allowed(u) {
                continue;
            }
            let Some((k2, cost)) = arc(mesh, vf, v, &arm, u, cutoff, phi_max, opts.drift_penalty) else {
                continue;
            };
            let nd = d + cost;
            let next = 4 * u.0 + k2 as u32;
            if dist.get(&next).is_none_or(|&(x, _)| nd < x) {
                dist.insert(next, (nd, node));
                heap.push(MinCost(nd, next));
            }
        }
    }
    None
}

/// The arc from `v` travelling along `arm` to its neighbour `u`: the arm `k2` of `u` it arrives
/// on and its cost `ℓ (1 + D (φ/φ_max)²)`, φ the mean deviation at both ends; `None` when the
/// edge is more than `cutoff` off the arm at `v` (or degenerate).
#[allow(clippy::too_many_arguments)]
fn arc(
    mesh: &Mesh,
    vf: &VertexField,
    v: VertexId,
    arm: &Vec3,
    u: VertexId,
    cutoff: f64,
    phi_max: f64,
    drift_penalty: f64,
) -> Option<(usize, f64)> {
    let e = mesh.position(u) - mesh.position(v);
    let n_v = vf.normal[v];
    let t_v = e - n_v * n_v.dot(&e);
    if t_v.norm() < 1e-300 {
        return None;
    }
    let phi_v = arm.dot(&t_v.normalize()).clamp(-1.0, 1.0).acos();
    if phi_v > cutoff {
        return None;
    }
    let (k2, _) = vf.best_arm(u, arm);
    let n_u = vf.normal[u];
    let t_u = e - n_u * n_u.dot(&e);
    let phi_u = if t_u.norm() > 1e-300 { vf.arm(u, k2).dot(&t_u.normalize()).clamp(-1.0, 1.0).acos() } else { phi_v };
    let phi = 0.5 * (phi_v + phi_u);
    Some((k2, e.norm() * (1.0 + drift_penalty * (phi / phi_max).powi(2))))
}

/// Whether the step `from → v` makes at least 45° with every seam edge at `v` (see
/// [`field_path`]).
fn arrives_across(
    mesh: &Mesh,
    from: Option<VertexId>,
    v: VertexId,
    seam_at: &dyn Fn(VertexId, VertexId) -> bool,
) -> bool {
    let Some(from) = from else { return true };
    let d = mesh.position(v) - mesh.position(from);
    mesh.vertex_neighbors(v).into_iter().filter(|&w| w != from && seam_at(v, w)).all(|w| {
        let e = mesh.position(w) - mesh.position(v);
        // The angle between the arriving direction and the seam edge, either way along it.
        let c = d.dot(&e) / (d.norm() * e.norm()).max(1e-300);
        c.abs() < std::f64::consts::FRAC_1_SQRT_2
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_field::cross::connection;
    use clothcast_mesh::shapes;

    /// A constant field on a flat grid: a separatrix forced from one vertex follows its arm.
    #[test]
    fn tracing_follows_a_constant_field() {
        let m = shapes::grid(20, 20, 1.0, 1.0);
        let rho = connection(&m);
        let x = Vec3::x();
        let theta: FaceData<f64> = m.face_ids().map(|f| m.face_frame(f).angle_of(&x)).collect();
        let field = clothcast_field::CrossField::from_angles(&m, &rho, theta);
        let vf = VertexField::from_face_field(&m, &field);
        let dirs = field.directions(&m);
        // A fake "singularity" of index 3 at the centre emits exactly one separatrix.
        let c = VertexId::new(10 * 21 + 10);
        let sep = trace_separatrices(&m, &vf, &dirs, &[Singularity { vertex: c, index: 3 }], &TraceOptions::default());
        assert_eq!(sep.len(), 1);
        let p = &sep[0];
        assert_eq!(p.end, SeparatrixEnd::Boundary);
        // Straight along an axis: every step is axis-aligned.
        for w in p.vertices.windows(2) {
            let d = m.position(w[1]) - m.position(w[0]);
            assert!(d.x.abs() < 1e-12 || d.y.abs() < 1e-12, "diagonal step {d}");
        }
        assert_eq!(p.vertices.len(), 11);
    }
}
