//! Straightening seams into locally shortest geodesics by edge flips: FlipOut (Sharp & Crane
//! 2020, "You Can Find Geodesic Paths in Triangle Meshes by Just Flipping Edges", ACM TOG
//! 39(6)) on a network of paths in a signpost intrinsic triangulation ([`crate::intrinsic`]),
//! and the tracing of the result back onto the input mesh as polylines of [`SurfacePoint`]s.
//!
//! Algorithm. Each path is a doubly linked list of intrinsic halfedges. At a joint a→b→c the two
//! wedge angles at b come from the signposts: left = CCW angle from b→c to b→a, right = Θ_b −
//! left (at a boundary vertex the side crossing the boundary is infinite). If the smaller one β
//! is below π − tolerance, every flippable edge strictly inside that wedge is flipped until none
//! is (the vertex degree drops with every flip, so this ends), and a→b→c is replaced by the
//! wedge's outer chain a, v1, …, vk, c, which is strictly shorter. Joints are taken from a
//! priority queue, smallest β first, until every joint is straight or blocked.
//!
//! Network rules (as in the paper's §5 and geometry-central's `FlipEdgeNetwork`): edges used by
//! any path are frozen (never flipped); a joint whose wedge contains a path edge is blocked, so
//! paths never cross; several paths may come to share an edge (e.g. geodesics from a common
//! endpoint through a saddle vertex), and each edge keeps its paths ordered across it, a joint
//! being blocked unless its two segments are the outermost on the wedge's side. Endpoints never
//! move. Deviations: after the queue empties, all joints are rescanned and blocked ones retried
//! once something moved (the reference only re-queues paths on the same edges), and a
//! replacement that is not numerically shorter is refused (as in the reference).
//!
//! Tracing: an intrinsic edge that was never flipped is an input edge and is emitted as its two
//! vertices. Any other is traced from its tail in its signpost direction for its length: the
//! input face whose wedge at the tail contains the direction is laid out in 2D, and neighbour
//! faces are unfolded across each crossed edge; crossings become [`SurfacePoint::Edge`] (snapped
//! to [`SurfacePoint::Vertex`] within 1e-9 of an end) and the trace must arrive at the head
//! vertex within 1e-6 of the edge length, or [`LayoutError::Trace`] is returned.
//!
//! Tolerances: flips require both quad angles below π − ε, ε = the angle tolerance clamped to
//! [1e-7, 1e-6]: nearly flat quads (e.g. collinear vertices on flat regions) would give
//! triangles whose lengths cannot represent them (their triangle-inequality slack ℓε²/8 falls
//! below round-off), and a spoke left unflipped for this reason bends the new path by less than
//! ε ≤ tolerance, which counts as straight. A tolerance below 1e-7 therefore buys nothing.
//!
//! Preconditions (checked, [`LayoutError::InvalidPath`]): see [`straighten_network`]. A path
//! whose ends coincide is a loop pinned at that vertex (no joint there); a contractible loop may
//! shrink to a path doubling back on one edge, which is then left alone (the reference's
//! special cases for loops are not reproduced).
//!
//! Termination: every flip lowers the degree of the joint's vertex and every replacement
//! shortens the network; as a safety net, FlipOut stops (with a `tracing` warning, output still
//! valid and no longer than the input) after 1000 + 50·(edges + segments) joint visits.
//!
//! Complexity: O(flips · valence) for FlipOut (flips are typically a small multiple of the
//! path length in edges), plus O(faces crossed) per traced edge.

use crate::intrinsic::{IntrinsicTriangulation, NONE, corner_angle, input_signposts};
use crate::{LayoutError, SurfacePoint};
use clothcast_mesh::{HalfedgeId, Mesh, Vec2, VertexId};
use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;
use std::f64::consts::PI;

/// Options of FlipOut.
#[derive(Clone, Debug)]
pub struct FlipOutOptions {
    /// Joints with both wedge angles ≥ π − angle_tolerance are straight (radians, in [0, π)).
    pub angle_tolerance: f64,
    /// Safety cap on flips per path (0 = unlimited).
    pub max_flips_per_path: usize,
}

impl Default for FlipOutOptions {
    fn default() -> Self {
        Self { angle_tolerance: 1e-6, max_flips_per_path: 0 }
    }
}

/// Quads whose angle at either end of the diagonal is above π − ε are not flipped, with ε the
/// angle tolerance clamped to this range: below ~1e-7 the new triangle would be degenerate in
/// floating point (slack ℓε²/8 under round-off); at most the tolerance, so that a spoke left
/// unflipped bends the new path by less than the tolerance (it counts as straight).
const FLIP_EPS_RANGE: (f64, f64) = (1e-7, 1e-6);
/// Edge crossings within this fraction of an edge's end are emitted as that vertex.
const SNAP: f64 = 1e-9;
/// A traced edge must end within this fraction of its length from its head vertex.
const ARRIVAL_TOL: f64 = 1e-6;

/// Straighten a network of edge paths into locally shortest geodesics and return each as a
/// polyline of surface points on the input mesh.
///
/// Preconditions (else [`LayoutError::InvalidPath`] naming the path): each path has ≥ 2
/// vertices; consecutive vertices are joined by a mesh edge; an interior vertex of a path
/// appears once in it, belongs to no other path (neither interior nor endpoint: split a path
/// where another one meets it) and is not on the mesh boundary; no edge is used twice. Endpoints
/// may be shared and may lie on the boundary.
///
/// Output: per path, points from `Vertex(first)` to `Vertex(last)`, each consecutive pair in a
/// common input face (or on a common input edge). Paths touch but never cross; none gets longer.
///
/// # Panics
/// If `options.angle_tolerance` is not in [0, π) (a caller's bug).
#[track_caller]
pub fn straighten_network(
    mesh: &Mesh,
    paths: &[Vec<VertexId>],
    options: &FlipOutOptions,
) -> Result<Vec<Vec<SurfacePoint>>, LayoutError> {
    assert!(
        options.angle_tolerance >= 0.0 && options.angle_tolerance < PI,
        "FlipOut angle tolerance must be in [0, π), got {}",
        options.angle_tolerance
    );
    let tri = IntrinsicTriangulation::from_mesh(mesh);
    let halfedge_paths = validate_paths(mesh, &tri, paths)?;
    let mut net = Network::new(tri, &halfedge_paths, options);
    let stats = net.straighten();
    tracing::debug!(paths = paths.len(), flips = stats.flips, shortenings = stats.shortenings, "FlipOut done");
    let tracer = Tracer::new(mesh);
    let mut out = Vec::with_capacity(paths.len());
    for p in 0..paths.len() {
        let mut points: Vec<SurfacePoint> = Vec::new();
        for h in net.path_halfedges(p) {
            for pt in tracer.trace(&net.tri, h)? {
                if points.last() != Some(&pt) {
                    points.push(pt);
                }
            }
        }
        out.push(points);
    }
    Ok(out)
}

/// Check the preconditions and convert each path to intrinsic halfedges.
fn validate_paths(
    mesh: &Mesh,
    tri: &IntrinsicTriangulation,
    paths: &[Vec<VertexId>],
) -> Result<Vec<Vec<usize>>, LayoutError> {
    let invalid = |path: usize, reason: String| LayoutError::InvalidPath { path, reason };
    let nv = mesh.n_vertices();
    let mut is_endpoint = vec![false; nv];
    for (pi, p) in paths.iter().enumerate() {
        if p.len() < 2 {
            return Err(invalid(pi, format!("{} vertices; a path needs at least 2", p.len())));
        }
        if let Some(v) = p.iter().find(|v| v.idx() >= nv) {
            return Err(invalid(pi, format!("vertex {v} out of range ({nv} vertices)")));
        }
        is_endpoint[p[0].idx()] = true;
        is_endpoint[p[p.len() - 1].idx()] = true;
    }
    let mut interior_owner = vec![NONE; nv];
    let mut edge_owner = vec![NONE; tri.n_edges()];
    let mut out = Vec::with_capacity(paths.len());
    for (pi, p) in paths.iter().enumerate() {
        for &v in &p[1..p.len() - 1] {
            if mesh.is_boundary_vertex(v) {
                return Err(invalid(pi, format!("interior vertex {v} lies on the mesh boundary")));
            }
            if is_endpoint[v.idx()] {
                return Err(invalid(pi, format!("interior vertex {v} is a path endpoint (split the path there)")));
            }
            match interior_owner[v.idx()] {
                NONE => interior_owner[v.idx()] = pi,
                q if q == pi => return Err(invalid(pi, format!("vertex {v} appears twice"))),
                q => return Err(invalid(pi, format!("interior vertex {v} is also inside path {q}"))),
            }
        }
        let mut hes = Vec::with_capacity(p.len() - 1);
        for w in p.windows(2) {
            let h = (w[0] != w[1])
                .then(|| tri.halfedge_between(w[0].idx(), w[1].idx()))
                .flatten()
                .ok_or_else(|| invalid(pi, format!("vertices {} and {} are not joined by a mesh edge", w[0], w[1])))?;
            let e = tri.edge(h);
            match edge_owner[e] {
                NONE => edge_owner[e] = pi,
                q if q == pi => return Err(invalid(pi, format!("edge {}–{} is used twice", w[0], w[1]))),
                q => return Err(invalid(pi, format!("edge {}–{} is also used by path {q}", w[0], w[1]))),
            }
            hes.push(h);
        }
        out.push(hes);
    }
    Ok(out)
}

// ---- FlipOut on a network ---------------------------------------------------------------------

/// Which wedge of a joint is too sharp.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Turn {
    Straight,
    /// The left wedge (CCW from the outgoing to the incoming direction) is below π.
    Left,
    /// The right wedge is below π.
    Right,
}

/// One intrinsic halfedge of a path; the joint "at" a segment is at its tail.
#[derive(Clone, Debug)]
struct Segment {
    he: usize,
    prev: usize,
    next: usize,
    path: usize,
    alive: bool,
}

/// A total order on angles for the priority queue (ties broken by segment id: deterministic).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Key(f64);
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Key {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// Counters of a FlipOut run.
#[derive(Clone, Copy, Debug, Default)]
struct Stats {
    flips: usize,
    shortenings: usize,
}

/// Paths on an intrinsic triangulation, with the bookkeeping of FlipOut.
struct Network {
    tri: IntrinsicTriangulation,
    segs: Vec<Segment>,
    /// First segment of every path.
    first: Vec<usize>,
    /// Per edge, the segments lying on it ordered across it: from the side of the twin of the
    /// edge's representative halfedge (front) to the representative's side (back).
    layers: Vec<Vec<usize>>,
    flips: Vec<usize>,
    /// Per segment, the `version` at which its joint last failed to shorten (u64::MAX: never).
    failed_at: Vec<u64>,
    /// Number of successful shortenings so far: the state changes only when it does.
    version: u64,
    heap: BinaryHeap<Reverse<(Key, usize)>>,
    tol: f64,
    flip_eps: f64,
    cap: usize,
    stats: Stats,
}

impl Network {
    fn new(tri: IntrinsicTriangulation, paths: &[Vec<usize>], options: &FlipOutOptions) -> Self {
        let mut layers = vec![Vec::new(); tri.n_edges()];
        let mut segs = Vec::new();
        let mut first = Vec::with_capacity(paths.len());
        for (pi, hes) in paths.iter().enumerate() {
            let mut prev = NONE;
            for &h in hes {
                let id = segs.len();
                segs.push(Segment { he: h, prev, next: NONE, path: pi, alive: true });
                if prev == NONE {
                    first.push(id);
                } else {
                    segs[prev].next = id;
                }
                layers[tri.edge(h)].push(id);
                prev = id;
            }
        }
        let n = segs.len();
        Self {
            tri,
            segs,
            first,
            layers,
            flips: vec![0; paths.len()],
            failed_at: vec![u64::MAX; n],
            version: 0,
            heap: BinaryHeap::new(),
            tol: options.angle_tolerance,
            flip_eps: options.angle_tolerance.clamp(FLIP_EPS_RANGE.0, FLIP_EPS_RANGE.1),
            cap: options.max_flips_per_path,
            stats: Stats::default(),
        }
    }

    /// The intrinsic halfedges of a path, in order.
    fn path_halfedges(&self, p: usize) -> Vec<usize> {
        let mut out = Vec::new();
        let mut s = self.first[p];
        while s != NONE {
            out.push(self.segs[s].he);
            s = self.segs[s].next;
        }
        out
    }

    /// Left and right wedge angles at the joint hp → hn.
    fn side_angles(&self, hp: usize, hn: usize) -> (f64, f64) {
        let tri = &self.tri;
        let b = tri.head(hp);
        let theta = tri.angle_sum(b);
        let (a_in, a_out) = (tri.signpost(tri.twin(hp)), tri.signpost(hn));
        // At a boundary vertex the fan does not wrap: a wedge through the gap is outside the
        // surface and cannot be shortened.
        let boundary = tri.is_boundary_vertex(b);
        let left = if a_in > a_out {
            a_in - a_out
        } else if boundary {
            f64::INFINITY
        } else {
            theta - a_out + a_in
        };
        let right = if a_out > a_in {
            a_out - a_in
        } else if boundary {
            f64::INFINITY
        } else {
            theta - a_in + a_out
        };
        (left, right)
    }

    /// The smaller wedge angle at the joint at the tail of segment `s` and its classification.
    fn joint(&self, s: usize) -> Option<(f64, Turn)> {
        let p = self.segs[s].prev;
        if p == NONE {
            return None;
        }
        let (left, right) = self.side_angles(self.segs[p].he, self.segs[s].he);
        let min = left.min(right);
        let turn = if min >= PI - self.tol {
            Turn::Straight
        } else if left <= right {
            Turn::Left
        } else {
            Turn::Right
        };
        Some((min, turn))
    }

    fn push_joint(&mut self, s: usize) {
        if s == NONE || !self.segs[s].alive {
            return;
        }
        if let Some((angle, turn)) = self.joint(s)
            && turn != Turn::Straight
        {
            self.heap.push(Reverse((Key(angle), s)));
        }
    }

    /// True if `x` is its edge's representative halfedge (its side is the back of the layers).
    fn is_rep(&self, x: usize) -> bool {
        self.tri.edge_halfedge(self.tri.edge(x)) == x
    }
    /// The segment on `x`'s edge closest to the face of `x`.
    fn outermost(&self, x: usize) -> Option<usize> {
        let l = &self.layers[self.tri.edge(x)];
        if self.is_rep(x) { l.last() } else { l.first() }.copied()
    }
    fn push_side(&mut self, x: usize, seg: usize) {
        let rep = self.is_rep(x);
        let l = &mut self.layers[self.tri.edge(x)];
        if rep { l.push(seg) } else { l.insert(0, seg) }
    }
    fn pop_side(&mut self, x: usize) -> Option<usize> {
        let rep = self.is_rep(x);
        let l = &mut self.layers[self.tri.edge(x)];
        if rep {
            l.pop()
        } else if l.is_empty() {
            None
        } else {
            Some(l.remove(0))
        }
    }

    /// Outgoing halfedges strictly between `start` and `end`, counter-clockwise around their
    /// common tail; `None` if the walk leaves the surface (a bug or a wedge through the boundary).
    fn wedge_spokes(&self, start: usize, end: usize) -> Option<Vec<usize>> {
        let mut out = Vec::new();
        let mut x = start;
        for _ in 0..self.tri.n_halfedges() {
            if !self.tri.is_interior(x) {
                return None;
            }
            x = self.tri.ccw_next(x);
            if x == end {
                return Some(out);
            }
            out.push(x);
        }
        None
    }

    /// Run FlipOut until every joint is straight or blocked.
    fn straighten(&mut self) -> Stats {
        for s in 0..self.segs.len() {
            self.push_joint(s);
        }
        // A safety net only: FlipOut terminates long before on real inputs.
        let limit = 1000 + 50 * (self.tri.n_edges() + self.segs.len());
        let mut processed = 0usize;
        loop {
            while let Some(Reverse((Key(angle), s))) = self.heap.pop() {
                if !self.segs[s].alive || self.failed_at[s] == self.version {
                    continue;
                }
                // Stale entry: the joint changed since (a fresh entry was queued then).
                match self.joint(s) {
                    Some((a, turn)) if a == angle && turn != Turn::Straight => {}
                    _ => continue,
                }
                processed += 1;
                if processed > limit {
                    tracing::warn!(
                        processed,
                        "FlipOut stopped at its iteration limit; paths are shorter but not all straight"
                    );
                    return self.stats;
                }
                if !self.shorten_at(s) {
                    self.failed_at[s] = self.version;
                }
            }
            // Retry every bent joint that has not failed in the current state: a blocking path
            // may have moved away.
            let mut any = false;
            for s in 0..self.segs.len() {
                if self.segs[s].alive && self.failed_at[s] != self.version {
                    let before = self.heap.len();
                    self.push_joint(s);
                    any |= self.heap.len() > before;
                }
            }
            if !any {
                return self.stats;
            }
        }
    }

    /// Try to shorten the path at the joint at the tail of segment `s`; true if it did.
    fn shorten_at(&mut self, s: usize) -> bool {
        let p = self.segs[s].prev;
        let (hp, hn) = (self.segs[p].he, self.segs[s].he);
        let path = self.segs[s].path;
        if hn == self.tri.twin(hp) {
            // The path doubles back on one edge (a degenerate loop): nothing sensible to do.
            return false;
        }
        let Some((_, turn)) = self.joint(s) else { return false };
        // `side_*`: the halfedges of the two segments whose faces are in the wedge; `start`,
        // `end`: the wedge's bounding outgoing halfedges at b in CCW order.
        let (side_p, side_n, start, end) = match turn {
            Turn::Straight => return false,
            Turn::Left => (hp, hn, hn, self.tri.twin(hp)),
            Turn::Right => (self.tri.twin(hp), self.tri.twin(hn), self.tri.twin(hp), hn),
        };
        // Blocked by another path lying between us and the wedge on the same edge ...
        if self.outermost(side_p) != Some(p) || self.outermost(side_n) != Some(s) {
            return false;
        }
        // ... or by a path edge inside the wedge (a path through or ending at b).
        let Some(spokes) = self.wedge_spokes(start, end) else { return false };
        if spokes.iter().any(|&x| !self.layers[self.tri.edge(x)].is_empty()) {
            return false;
        }
        // Flip until no spoke is flippable. Each flip removes a spoke, so this ends; the
        // spokes are re-collected after each flip since the fan changed.
        'flips: loop {
            let Some(spokes) = self.wedge_spokes(start, end) else { return false };
            for x in spokes {
                if self.cap > 0 && self.flips[path] >= self.cap {
                    break 'flips;
                }
                if self.tri.flip_edge(self.tri.edge(x), self.flip_eps) {
                    self.flips[path] += 1;
                    self.stats.flips += 1;
                    continue 'flips;
                }
            }
            break;
        }
        // The outer chain: the edges opposite b in the wedge's faces, oriented from a to c.
        let Some(spokes) = self.wedge_spokes(start, end) else { return false };
        let fan: Vec<usize> = std::iter::once(start).chain(spokes).collect();
        let chain: Vec<usize> = match turn {
            Turn::Left => fan.iter().rev().map(|&x| self.tri.twin(self.tri.next(x))).collect(),
            _ => fan.iter().map(|&y| self.tri.next(y)).collect(),
        };
        let old_len = self.tri.halfedge_length(hp) + self.tri.halfedge_length(hn);
        let new_len: f64 = chain.iter().map(|&h| self.tri.halfedge_length(h)).sum();
        // In exact arithmetic the chain is shorter; refuse it if round-off says otherwise.
        if !(new_len < old_len) {
            return false;
        }
        debug_assert_eq!(self.tri.tail(chain[0]), self.tri.tail(hp));
        debug_assert_eq!(self.tri.head(chain[chain.len() - 1]), self.tri.head(hn));
        self.replace(p, s, side_p, side_n, turn, &chain);
        true
    }

    /// Replace segments `p`, `s` (outermost on the sides `side_p`, `side_n`) by `chain`.
    fn replace(&mut self, p: usize, s: usize, side_p: usize, side_n: usize, turn: Turn, chain: &[usize]) {
        let popped = (self.pop_side(side_p), self.pop_side(side_n));
        debug_assert_eq!(popped, (Some(p), Some(s)));
        self.segs[p].alive = false;
        self.segs[s].alive = false;
        let (before, after, path) = (self.segs[p].prev, self.segs[s].next, self.segs[s].path);
        let mut prev = before;
        let mut new_ids = Vec::with_capacity(chain.len());
        for &h in chain {
            let id = self.segs.len();
            self.segs.push(Segment { he: h, prev, next: NONE, path, alive: true });
            self.failed_at.push(u64::MAX);
            if prev == NONE {
                self.first[path] = id;
            } else {
                self.segs[prev].next = id;
            }
            // The new segment hugs the edge from the wedge's side, inside any path already there.
            let wedge_side = if turn == Turn::Left { self.tri.twin(h) } else { h };
            self.push_side(wedge_side, id);
            new_ids.push(id);
            prev = id;
        }
        self.segs[prev].next = after;
        if after != NONE {
            self.segs[after].prev = prev;
        }
        self.version += 1;
        self.stats.shortenings += 1;
        for id in new_ids {
            self.push_joint(id);
        }
        self.push_joint(after);
        // Paths that were behind the removed segments may now be free to move.
        for x in [side_p, side_n] {
            if let Some(o) = self.outermost(x) {
                self.push_joint(o);
                self.push_joint(self.segs[o].next);
            }
        }
    }
}

// ---- tracing back onto the input mesh ------------------------------------------------------

#[inline]
fn cross(a: Vec2, b: Vec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// The point left of `p0 → p1` at distance `d0` from `p0` and `d1` from `p1`.
fn layout_left(p0: Vec2, p1: Vec2, d0: f64, d1: f64) -> Vec2 {
    let base = p1 - p0;
    let l = base.norm();
    let u = base / l;
    let n = Vec2::new(-u.y, u.x);
    let a = corner_angle(l, d0, d1);
    p0 + (u * a.cos() + n * a.sin()) * d0
}

/// Traces intrinsic edges over the input mesh.
struct Tracer<'m> {
    mesh: &'m Mesh,
    len: Vec<f64>,
    corner: Vec<f64>,
    signpost: Vec<f64>,
}

impl<'m> Tracer<'m> {
    fn new(mesh: &'m Mesh) -> Self {
        let len: Vec<f64> = mesh.edges().map(|e| mesh.edge_length(e)).collect();
        let l = |h: HalfedgeId| len[mesh.edge(h).idx()];
        let corner = (0..mesh.n_halfedges())
            .map(HalfedgeId::new)
            .map(|h| corner_angle(l(h), l(mesh.prev(h)), l(mesh.next(h))))
            .collect();
        let (signpost, _) = input_signposts(mesh);
        Self { mesh, len, corner, signpost }
    }

    fn hlen(&self, h: HalfedgeId) -> f64 {
        self.len[self.mesh.edge(h).idx()]
    }

    /// The input halfedge whose face's corner at `v` contains direction `phi`, and the angle
    /// of `phi` from it (clamped into the corner).
    fn start_wedge(&self, v: VertexId, phi: f64) -> (HalfedgeId, f64) {
        let mut best = (f64::INFINITY, self.mesh.vertex_halfedge(v));
        for g in self.mesh.outgoing(v) {
            let (a0, a) = (self.signpost[g.idx()], self.corner[g.idx()]);
            let miss = (a0 - phi).max(phi - a0 - a).max(0.0);
            if miss < best.0 {
                best = (miss, g);
            }
            if miss == 0.0 {
                break;
            }
        }
        let g = best.1;
        (g, (phi - self.signpost[g.idx()]).clamp(0.0, self.corner[g.idx()]))
    }

    /// The polyline of intrinsic halfedge `h`.
    fn trace(&self, tri: &IntrinsicTriangulation, h: usize) -> Result<Vec<SurfacePoint>, LayoutError> {
        let (v, w) = (VertexId::new(tri.tail(h)), VertexId::new(tri.head(h)));
        if tri.is_original_edge(tri.edge(h)) {
            return Ok(vec![SurfacePoint::Vertex(v), SurfacePoint::Vertex(w)]);
        }
        self.trace_geodesic(v, w, tri.signpost(h), tri.halfedge_length(h))
    }

    /// Walk the straight line leaving `v` at signpost `phi` for `length` across the input mesh;
    /// it must end at `target`.
    fn trace_geodesic(
        &self,
        v: VertexId,
        target: VertexId,
        phi: f64,
        length: f64,
    ) -> Result<Vec<SurfacePoint>, LayoutError> {
        let mesh = self.mesh;
        let tol = ARRIVAL_TOL * length;
        let (g, theta) = self.start_wedge(v, phi);
        // The first face with v at the origin and g along +x; the ray starts at the origin.
        let a = self.corner[g.idx()];
        let (b, c) = (mesh.head(g), mesh.opposite_vertex(g));
        let pb = Vec2::new(self.hlen(g), 0.0);
        let pc = Vec2::new(a.cos(), a.sin()) * self.hlen(mesh.prev(g));
        let d = Vec2::new(theta.cos(), theta.sin());
        let end = d * length;
        let mut points = vec![SurfacePoint::Vertex(v)];
        let arrived = |x: VertexId, px: Vec2| x == target && (end - px).norm() <= tol;
        if arrived(b, pb) || arrived(c, pc) {
            points.push(SurfacePoint::Vertex(target));
            return Ok(points);
        }
        // Invariant: the ray leaves the current face through `exit`, running p → q with p on
        // the ray's right and q on its left.
        let (mut exit, mut p, mut q, mut pp, mut pq) = (mesh.next(g), b, c, pb, pc);
        for _ in 0..2 * mesh.n_faces() + 8 {
            let e = pq - pp;
            let denom = cross(e, d);
            let s = if denom != 0.0 { (-cross(pp, d) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let tau = (pp + e * s).dot(&d);
            if tau > length + tol {
                return Err(LayoutError::Trace(format!(
                    "geodesic from vertex {v} towards {target} (length {length}) ends inside a face"
                )));
            }
            let pt = if s <= SNAP {
                SurfacePoint::Vertex(p)
            } else if s >= 1.0 - SNAP {
                SurfacePoint::Vertex(q)
            } else {
                let edge = mesh.edge(exit);
                let t = if mesh.edge_vertices(edge)[0] == p { s } else { 1.0 - s };
                SurfacePoint::Edge { edge, t }
            };
            if points.last() != Some(&pt) {
                points.push(pt);
            }
            let Some(tw) = mesh.twin(exit) else {
                return Err(LayoutError::Trace(format!(
                    "geodesic from vertex {v} towards {target} leaves the surface across a boundary edge"
                )));
            };
            // Unfold the next face: tw runs q → p, its third vertex r is on tw's left.
            let r = mesh.opposite_vertex(tw);
            let pr = layout_left(pq, pp, self.hlen(mesh.prev(tw)), self.hlen(mesh.next(tw)));
            if arrived(p, pp) || arrived(q, pq) || arrived(r, pr) {
                if points.last() != Some(&SurfacePoint::Vertex(target)) {
                    points.push(SurfacePoint::Vertex(target));
                }
                return Ok(points);
            }
            if cross(d, pr) > 0.0 {
                (exit, q, pq) = (mesh.next(tw), r, pr);
            } else {
                (exit, p, pp) = (mesh.prev(tw), r, pr);
            }
        }
        Err(LayoutError::Trace(format!("geodesic from vertex {v} towards {target} did not arrive")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::polyline_length;
    use clothcast_mesh::shapes;

    fn vid(i: usize) -> VertexId {
        VertexId::new(i)
    }

    /// Grid vertex (i, j) of `shapes::grid(nx, ..)`.
    fn g(nx: usize, i: usize, j: usize) -> VertexId {
        vid(j * (nx + 1) + i)
    }

    #[test]
    fn single_bend_on_a_grid() {
        // (1,1) → (2,1) → (2,2) is a right-angle staircase step: it becomes the diagonal.
        let m = shapes::grid(4, 4, 4.0, 4.0);
        let path = vec![g(4, 1, 1), g(4, 2, 1), g(4, 2, 2)];
        let out = straighten_network(&m, &[path], &FlipOutOptions::default()).unwrap();
        assert_eq!(out[0].first(), Some(&SurfacePoint::Vertex(g(4, 1, 1))));
        assert_eq!(out[0].last(), Some(&SurfacePoint::Vertex(g(4, 2, 2))));
        assert!((polyline_length(&m, &out[0]) - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn network_keeps_invariants() {
        let m = shapes::grid(8, 8, 1.0, 1.0);
        let tri = IntrinsicTriangulation::from_mesh(&m);
        let paths = vec![
            vec![g(8, 1, 1), g(8, 2, 1), g(8, 3, 1), g(8, 3, 2), g(8, 4, 2), g(8, 4, 3), g(8, 5, 3)],
            vec![g(8, 1, 1), g(8, 1, 2), g(8, 1, 3), g(8, 2, 3), g(8, 2, 4), g(8, 3, 4), g(8, 3, 5)],
        ];
        let hes = validate_paths(&m, &tri, &paths).unwrap();
        let mut net = Network::new(tri, &hes, &FlipOutOptions::default());
        let stats = net.straighten();
        assert!(stats.flips > 0 && stats.shortenings > 0);
        net.tri.check(1e-9).unwrap();
        for p in 0..2 {
            let hs = net.path_halfedges(p);
            for w in hs.windows(2) {
                assert_eq!(net.tri.head(w[0]), net.tri.tail(w[1]));
            }
            assert_eq!(net.tri.tail(hs[0]), paths[p][0].idx());
            assert_eq!(net.tri.head(hs[hs.len() - 1]), paths[p].last().unwrap().idx());
            for s in 1..net.segs.len() {
                if net.segs[s].alive && net.segs[s].path == p {
                    assert_eq!(net.joint(s).map(|j| j.1).unwrap_or(Turn::Straight), Turn::Straight);
                }
            }
        }
        // Every live segment is on exactly its edge's layer.
        for (e, l) in net.layers.iter().enumerate() {
            for &s in l {
                assert!(net.segs[s].alive);
                assert_eq!(net.tri.edge(net.segs[s].he), e);
            }
        }
    }
}
