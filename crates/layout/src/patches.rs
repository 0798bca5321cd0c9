//! Patches: the mesh cut open along its seam edges.
//!
//! Every vertex is split into one copy per *wedge* — the faces around it between two seam (or
//! boundary) edges — so the cut mesh is what the fabric pieces are: each connected component
//! is a patch, and its χ and boundary loops are those of the piece (a seam that ends inside a
//! patch is a slit in the fabric; an interior seam loop would make it an annulus).
//!
//! **Corners** ([`CornerRule`]). The candidates are the vertices where the seam network is not a
//! plain curve — three or more patches meet, a seam meets the mesh boundary, a singularity — and
//! the vertices of the mesh boundary. A candidate is a corner of a patch when the patch's angle
//! there, measured in the field's quarter turns, is below 1.5 (a 135° angle on a flat
//! surface): the patch angle α is scaled by `(4 − index) / Θ`, Θ the vertex's total angle and
//! index the field's singularity index (quarter turns), so the three 120° wedges at a valence-3
//! singularity and the five 72° wedges at a valence-5 one are each one quarter turn — one corner
//! — like the 90° wedges at a regular cross junction. This refines the plain "three or more
//! patches meet" rule the way the quad-layout literature does: at a T-junction the patch whose
//! side runs straight through (two quarter turns) gets no corner, the two others get one each.
//! Mesh-boundary vertices use the plain geometric scale (2/π per radian).
//!
//! Complexity: O(F log F).

use clothcast_mesh::util::UnionFind;
use clothcast_mesh::{EdgeData, EdgeId, FaceData, FaceId, HalfedgeData, HalfedgeId, Mesh, Vec3, VertexData, VertexId};
use std::f64::consts::PI;

/// A patch angle below this many quarter turns of the field is a corner.
pub const CORNER_QUARTERS: f64 = 1.5;

/// What makes a corner (see the module documentation): corner angles and the field's
/// quarter turns per radian at every vertex.
#[derive(Clone, Debug)]
pub struct CornerRule {
    /// Corner angle of every halfedge (at its tail... as [`Mesh::corner_angles`]).
    pub angles: HalfedgeData<f64>,
    /// Quarter turns per radian at every vertex.
    pub scale: VertexData<f64>,
    /// Singular vertices (always corner candidates).
    pub singular: VertexData<bool>,
    /// Total angle around every vertex.
    pub angle_sum: VertexData<f64>,
    /// Angles at candidates are measured between chords this many boundary edges long (1:
    /// the local angle); see [`CornerRule::with_chords`].
    pub chord_steps: usize,
    /// One arm of the cross field per face: angles are then counted from arm to arm (see
    /// [`CornerRule::with_field`]).
    pub field: Option<FaceData<Vec3>>,
}

impl CornerRule {
    /// The rule for a field with the given singularity index (quarter turns) per vertex.
    pub fn new(mesh: &Mesh, index: &VertexData<i32>) -> Self {
        let angles = mesh.corner_angles();
        let sums = mesh.angle_sums_of(&angles);
        let scale = mesh
            .vertices()
            .map(|v| {
                if mesh.is_boundary_vertex(v) || sums[v] <= 0.0 { 2.0 / PI } else { f64::from(4 - index[v]) / sums[v] }
            })
            .collect();
        Self { angles, scale, singular: index.map(|&i| i != 0), angle_sum: sums, chord_steps: 1, field: None }
    }
    /// Measure angles between chords `steps` edges long: for jagged (not yet straightened)
    /// seams, whose local angles zig-zag.
    pub fn with_chords(mut self, steps: usize) -> Self {
        self.chord_steps = steps;
        self
    }
    /// Count angles from field arm to field arm: each seam's deviation from the field (one arm
    /// per face, in the face plane) is taken out of the angle between two seams.
    pub fn with_field(mut self, field: FaceData<Vec3>) -> Self {
        self.field = Some(field);
        self
    }
    /// The rule without a field (no singularities; interior vertices scaled by 4/Θ).
    pub fn plain(mesh: &Mesh) -> Self {
        Self::new(mesh, &VertexData::filled(mesh.n_vertices(), 0))
    }
}

/// The patches of a mesh cut along seams.
#[derive(Clone, Debug, PartialEq)]
pub struct Patches {
    /// Patch of every face (`0..n`, numbered by first face).
    pub patch_of_face: FaceData<u32>,
    /// Number of patches.
    pub n: usize,
    /// Euler characteristic of each cut patch.
    pub euler: Vec<i64>,
    /// Boundary loops of each cut patch.
    pub loops: Vec<usize>,
    /// Area of each patch.
    pub area: Vec<f64>,
    /// Corner vertices of each patch (original mesh vertices, in boundary order per loop).
    pub corners: Vec<Vec<VertexId>>,
    /// Corner candidates of each patch and its angle there in field quarter turns.
    pub candidates: Vec<Vec<(VertexId, f64)>>,
}

impl Patches {
    /// True if patch `p` is a topological disk.
    pub fn is_disk(&self, p: usize) -> bool {
        self.euler[p] == 1 && self.loops[p] == 1
    }
    /// Faces of every patch.
    pub fn faces(&self) -> Vec<Vec<FaceId>> {
        faces_by_label(&self.patch_of_face, self.n)
    }

    /// The patches of a labelling (`0..infos.len()`) with each one's measure, in label order.
    fn from_infos(patch_of_face: FaceData<u32>, infos: Vec<RegionInfo>) -> Patches {
        let n = infos.len();
        let mut out = Patches {
            patch_of_face,
            n,
            euler: Vec::with_capacity(n),
            loops: Vec::with_capacity(n),
            area: Vec::with_capacity(n),
            corners: Vec::with_capacity(n),
            candidates: Vec::with_capacity(n),
        };
        for i in infos {
            out.euler.push(i.euler);
            out.loops.push(i.loops);
            out.area.push(i.area);
            out.corners.push(i.corners);
            out.candidates.push(i.candidates);
        }
        out
    }

    /// The measure of patch `p`.
    fn info(&self, p: usize) -> RegionInfo {
        RegionInfo {
            euler: self.euler[p],
            loops: self.loops[p],
            corners: self.corners[p].clone(),
            area: self.area[p],
            candidates: self.candidates[p].clone(),
        }
    }

    /// The patches once the seams are `seam`, where these are `patches_with(mesh, old_seam,
    /// rule)`: equal to `patches_with(mesh, seam, rule)`, but only the patches around the
    /// change are measured again. The faces of the patches at the changed edges' ends are
    /// regrouped; a patch away from them keeps its faces, its cut edges (between two of its
    /// faces, or to another patch before and after) and its measure, unless a vertex of its
    /// sees the patches around it regrouped (its corners count the patches meeting there).
    /// Costs O(E) in plain passes, plus the measure of those patches (the full measure is the
    /// cost of a seam change otherwise: the re-routing of a chain between two patches measured
    /// every patch of the mesh).
    pub fn reseamed(
        &self,
        mesh: &Mesh,
        old_seam: &EdgeData<bool>,
        seam: &EdgeData<bool>,
        rule: &CornerRule,
    ) -> Patches {
        let touched: Vec<VertexId> =
            mesh.edges().filter(|&e| old_seam[e] != seam[e]).map(|e| mesh.edge_vertices(e)[0]).collect();
        if touched.is_empty() {
            return self.clone();
        }
        let old = &self.patch_of_face;
        // The patches at the touched vertices, and their faces (ascending).
        let mut affected = vec![false; self.n];
        for &v in &touched {
            for f in mesh.vertex_faces(v) {
                affected[old[f] as usize] = true;
            }
        }
        let region: Vec<FaceId> = mesh.face_ids().filter(|&f| affected[old[f] as usize]).collect();
        let mut local_of = vec![u32::MAX; mesh.n_faces()];
        for (i, &f) in region.iter().enumerate() {
            local_of[f.idx()] = i as u32;
        }
        let local = |f: FaceId| Some(local_of[f.idx()] as usize).filter(|_| local_of[f.idx()] != u32::MAX);
        let mut uf = UnionFind::new(region.len());
        for (i, &f) in region.iter().enumerate() {
            for k in 0..3 {
                let h = mesh.face_halfedge(f, k);
                let Some(t) = mesh.twin(h) else { continue };
                if seam[mesh.edge(h)] {
                    continue;
                }
                match local(mesh.face(t)) {
                    Some(j) => {
                        uf.union(i as u32, j as u32);
                    }
                    // An uncut edge out of the region: `self` was not measured on `old_seam`
                    // (or the mesh is not manifold). Measured from scratch instead.
                    None => return patches_with(mesh, seam, rule),
                }
            }
        }
        let (component, k) = uf.labels();
        // Provisional ids (kept patches as they were, the region's components after them),
        // then numbered by first face, as `patches_with` numbers them.
        let provisional = |f: FaceId| match local(f) {
            Some(i) => self.n as u32 + component[i],
            None => old[f],
        };
        let mut number = vec![u32::MAX; self.n + k];
        let mut n = 0u32;
        let mut new = FaceData::filled(mesh.n_faces(), 0u32);
        for f in mesh.face_ids() {
            let q = provisional(f) as usize;
            if number[q] == u32::MAX {
                number[q] = n;
                n += 1;
            }
            new[f] = number[q];
        }
        let n = n as usize;
        // Measured again: the region's patches, and those with a vertex of a region face where
        // the faces around it are grouped differently (is_cut and distinct labels there).
        let mut remeasure = vec![false; n];
        for &f in &region {
            remeasure[new[f] as usize] = true;
        }
        let mut verts: Vec<VertexId> = region.iter().flat_map(|&f| mesh.face_vertices(f)).collect();
        verts.sort_unstable();
        verts.dedup();
        for v in verts {
            let around: Vec<FaceId> = mesh.vertex_faces(v).collect();
            let regrouped = around
                .iter()
                .enumerate()
                .any(|(i, &a)| around[i + 1..].iter().any(|&b| (old[a] == old[b]) != (new[a] == new[b])));
            if regrouped {
                for &f in &around {
                    remeasure[new[f] as usize] = true;
                }
            }
        }
        let mut faces: Vec<Vec<FaceId>> = vec![Vec::new(); n];
        let mut was = vec![u32::MAX; n];
        for f in mesh.face_ids() {
            let q = new[f] as usize;
            if remeasure[q] {
                faces[q].push(f);
            } else {
                was[q] = old[f];
            }
        }
        let (label, cut) = (|f: FaceId| new[f], |e: EdgeId| seam[e]);
        let infos = (0..n)
            .map(|q| {
                if remeasure[q] { region_info(mesh, &faces[q], &label, &cut, rule) } else { self.info(was[q] as usize) }
            })
            .collect();
        Patches::from_infos(new, infos)
    }
}

/// The cut mesh's vertex (wedge) of every face corner: `wedge[3f + k]`, and the wedge count.
pub fn wedges(mesh: &Mesh, seam: &EdgeData<bool>) -> (Vec<u32>, usize) {
    let nf = mesh.n_faces();
    let mut uf = UnionFind::new(3 * nf);
    for e in mesh.edges() {
        if seam[e] {
            continue;
        }
        let h = mesh.edge_halfedge(e);
        let Some(t) = mesh.twin(h) else { continue };
        // h: a→b in face f at corners (k, k+1); t: b→a in g.
        let (fh, ft) = (mesh.face(h).0, mesh.face(t).0);
        let (ka, kb) = (mesh.corner(h) as u32, (mesh.corner(h) as u32 + 1) % 3);
        let (tb, ta) = (mesh.corner(t) as u32, (mesh.corner(t) as u32 + 1) % 3);
        uf.union(3 * fh + ka, 3 * ft + ta);
        uf.union(3 * fh + kb, 3 * ft + tb);
    }
    let (labels, n) = uf.labels();
    (labels, n)
}

/// Topology and corners of one region (a set of faces carrying the same label).
#[derive(Clone, Debug, PartialEq)]
pub struct RegionInfo {
    /// Euler characteristic of the region cut open along its cut edges.
    pub euler: i64,
    /// Boundary loops of the cut region.
    pub loops: usize,
    /// Corner vertices (in boundary order per loop).
    pub corners: Vec<VertexId>,
    /// Area.
    pub area: f64,
    /// Every corner candidate on the boundary and the region's angle there in field quarter
    /// turns (a corner when below [`CORNER_QUARTERS`]).
    pub candidates: Vec<(VertexId, f64)>,
}

impl RegionInfo {
    /// True for a topological disk.
    pub fn is_disk(&self) -> bool {
        self.euler == 1 && self.loops == 1
    }
}

/// Whether edge `e` separates regions under a labelling: a mesh-boundary edge, a `seam`, or an
/// edge whose two faces have different labels.
pub fn is_cut_edge(mesh: &Mesh, e: EdgeId, label: &impl Fn(FaceId) -> u32, seam: &impl Fn(EdgeId) -> bool) -> bool {
    match mesh.edge_faces(e) {
        (_, None) => true,
        (a, Some(b)) => seam(e) || label(a) != label(b),
    }
}

thread_local! {
    /// [`LocalIndex`]'s table: `u32::MAX` everywhere between uses.
    static LOCAL_INDEX: std::cell::Cell<Vec<u32>> = const { std::cell::Cell::new(Vec::new()) };
}

/// The place of each face of a region in its sorted face list, in O(1): a table the size of
/// the mesh, kept per thread, set for the region's faces and cleared when dropped (also on
/// unwinding). A nested use finds the table taken and makes its own.
struct LocalIndex<'a> {
    table: Vec<u32>,
    faces: &'a [FaceId],
}

impl<'a> LocalIndex<'a> {
    fn new(mesh: &Mesh, faces: &'a [FaceId]) -> Self {
        let mut table = LOCAL_INDEX.take();
        if table.len() < mesh.n_faces() {
            table.resize(mesh.n_faces(), u32::MAX);
        }
        for (i, f) in faces.iter().enumerate() {
            table[f.idx()] = i as u32;
        }
        Self { table, faces }
    }

    fn of(&self, f: FaceId) -> Option<usize> {
        self.table.get(f.idx()).filter(|&&i| i != u32::MAX).map(|&i| i as usize)
    }
}

impl Drop for LocalIndex<'_> {
    fn drop(&mut self) {
        for f in self.faces {
            self.table[f.idx()] = u32::MAX;
        }
        LOCAL_INDEX.set(std::mem::take(&mut self.table));
    }
}

/// Topology of the region `faces` (sorted, all with the same label) under a labelling of the
/// whole mesh: an edge is a cut when it is a mesh boundary, a `seam`, or its two faces have
/// different labels. O(|faces|) (the first call on a thread sizes a table to the mesh,
/// [`LocalIndex`]).
pub fn region_info(
    mesh: &Mesh,
    faces: &[FaceId],
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    rule: &CornerRule,
) -> RegionInfo {
    let angles = &rule.angles;
    debug_assert!(faces.windows(2).all(|w| w[0] < w[1]), "faces must be sorted");
    // Each face's place in `faces`, from a per-thread table the size of the mesh (set for
    // these faces and cleared again on the way out): region_info runs thousands of times on
    // regions of a large mesh, and a binary search per halfedge was a large part of it.
    let index = LocalIndex::new(mesh, faces);
    let local = |f: FaceId| index.of(f);
    let is_cut = |h: HalfedgeId| is_cut_edge(mesh, mesh.edge(h), label, seam);
    // Whether each face corner's halfedge (3i + k) is a cut: asked once per edge, its twin's
    // entry set with it.
    let mut cut: Vec<Option<bool>> = vec![None; 3 * faces.len()];
    // Wedges: corners joined across non-cut edges; their count is the corners less the
    // unions that joined two sets.
    let mut uf = UnionFind::new(3 * faces.len());
    let mut joined = 0i64;
    let mut edges_inner = 0i64;
    let mut edges_cut = 0i64;
    for (i, &f) in faces.iter().enumerate() {
        for k in 0..3 {
            let h = mesh.face_halfedge(f, k);
            let here = 3 * i + k;
            let twin = mesh.twin(h);
            let is = *cut[here].get_or_insert_with(|| is_cut(h));
            if let Some(t) = twin
                && let Some(j) = local(mesh.face(t))
            {
                cut[3 * j + mesh.corner(t)] = Some(is);
            }
            if is {
                edges_cut += 1;
                continue;
            }
            let t = twin.expect("non-cut edges are interior");
            let j = local(mesh.face(t)).expect("non-cut edges stay in the region");
            if (f, k) < (mesh.face(t), mesh.corner(t)) {
                edges_inner += 1;
            }
            let (ka, kb) = (k as u32, (k as u32 + 1) % 3);
            let (tb, ta) = (mesh.corner(t) as u32, (mesh.corner(t) as u32 + 1) % 3);
            joined += i64::from(uf.union(3 * i as u32 + ka, 3 * j as u32 + ta));
            joined += i64::from(uf.union(3 * i as u32 + kb, 3 * j as u32 + tb));
        }
    }
    let n_wedges = 3 * faces.len() as i64 - joined;
    let euler = n_wedges - edges_inner - edges_cut + faces.len() as i64;
    // A halfedge of a region face: its cut flag as found above.
    let is_cut_inside = |h: HalfedgeId| {
        let i = local(mesh.face(h)).expect("a region face");
        cut[3 * i + mesh.corner(h)] == Some(true)
    };
    // Whether at least three labels meet at v.
    let three_labels = |v: VertexId| -> bool {
        let mut seen: [Option<u32>; 2] = [None, None];
        for l in mesh.vertex_faces(v).map(label) {
            match seen {
                [None, _] => seen[0] = Some(l),
                [Some(a), None] if a != l => seen[1] = Some(l),
                [Some(a), Some(b)] if a != l && b != l => return true,
                _ => {}
            }
        }
        false
    };
    let cut_meets_boundary = |v: VertexId| -> bool {
        mesh.is_boundary_vertex(v) && mesh.outgoing(v).any(|h| !mesh.is_boundary_halfedge(h) && is_cut(h))
    };
    let mut seen: Vec<bool> = vec![false; 3 * faces.len()];
    let mut loops = 0;
    let mut corners = Vec::new();
    let mut candidates = Vec::new();
    for (i, &f) in faces.iter().enumerate() {
        for k in 0..3 {
            let h0 = mesh.face_halfedge(f, k);
            if seen[3 * i + k] || cut[3 * i + k] != Some(true) {
                continue;
            }
            loops += 1;
            // The loop: each vertex with the region's angle there (local wedge sum).
            let mut lp: Vec<LoopVertex> = Vec::new();
            let mut h = h0;
            loop {
                let li = local(mesh.face(h)).expect("loop stays in the region");
                seen[3 * li + mesh.corner(h)] = true;
                // The next cut halfedge leaves v = head(h) at the far side of the wedge: rotate
                // from next(h) across non-cut edges, summing the region's angles at v.
                let v = mesh.head(h);
                let mut g = mesh.next(h);
                let mut angle_sum = angles[g];
                let mut wedge = vec![WedgeFace {
                    face: mesh.face(g),
                    a: mesh.position(mesh.tail(h)) - mesh.position(v),
                    b: mesh.vector(g),
                    angle: angles[g],
                }];
                while !is_cut_inside(g) {
                    let a = mesh.vector(g);
                    g = mesh.next(mesh.twin(g).expect("non-cut edges are interior"));
                    angle_sum += angles[g];
                    wedge.push(WedgeFace { face: mesh.face(g), a, b: mesh.vector(g), angle: angles[g] });
                }
                lp.push(LoopVertex {
                    v,
                    angle: angle_sum,
                    wedge,
                    seam_in: !mesh.is_boundary_halfedge(h),
                    seam_out: !mesh.is_boundary_halfedge(g),
                });
                h = g;
                let lg = local(mesh.face(h)).expect("loop stays in the region");
                if h == h0 || seen[3 * lg + mesh.corner(h)] {
                    break;
                }
            }
            let candidate: Vec<bool> = lp
                .iter()
                .map(|l| {
                    let v = l.v;
                    rule.singular[v] || mesh.is_boundary_vertex(v) || three_labels(v) || cut_meets_boundary(v)
                })
                .collect();
            let n = lp.len();
            for j in 0..n {
                if !candidate[j] {
                    continue;
                }
                let v = lp[j].v;
                let quarters = corner_quarters(mesh, rule, &lp, &candidate, j);
                candidates.push((v, quarters));
                if quarters < CORNER_QUARTERS {
                    corners.push(v);
                }
            }
        }
    }
    let area = faces.iter().map(|&f| mesh.face_area(f)).sum();
    RegionInfo { euler, loops, corners, area, candidates }
}

/// A face of the wedge of a region at one of its boundary vertices v: its edge directions at v
/// on the side of the incoming boundary edge (`a`) and of the outgoing one (`b`), and its angle.
struct WedgeFace {
    face: FaceId,
    a: Vec3,
    b: Vec3,
    angle: f64,
}

/// A vertex of a region's boundary loop: the region's (local) angle there and the faces of its
/// wedge, from the incoming boundary edge's face to the outgoing one's.
struct LoopVertex {
    v: VertexId,
    angle: f64,
    wedge: Vec<WedgeFace>,
    /// The incoming (outgoing) boundary edge is a seam, not the mesh boundary.
    seam_in: bool,
    seam_out: bool,
}

/// Angle of `d` in the plane of a wedge face, measured from its `a` edge towards its `b` edge.
fn wedge_angle(w: &WedgeFace, d: &Vec3) -> f64 {
    let n = w.a.cross(&w.b);
    if n.norm() <= 0.0 {
        return 0.0;
    }
    let n = n.normalize();
    let a = w.a.normalize();
    d.dot(&n.cross(&a)).atan2(d.dot(&a))
}

/// Quarter turns of the field between the two boundary chords at a loop vertex, counted through
/// the wedge: the field's arms are followed face by face across the wedge (in the vertex's
/// polar angle, each face's arm taken nearest to the previous face's), each seam chord is
/// snapped to its nearest arm, and the count is the number of arms between the two. A chord
/// along the mesh boundary (which need not follow the field) is not snapped: its angle from the
/// arms counts fractionally.
fn field_quarters(l: &LoopVertex, field: &FaceData<Vec3>, ca: &Vec3, cb: &Vec3) -> f64 {
    let q = std::f64::consts::FRAC_PI_2;
    let mut polar = 0.0;
    let mut psi_prev: Option<f64> = None;
    let (mut psi_first, mut psi_last) = (0.0, 0.0);
    let mut p_b = 0.0;
    for (i, w) in l.wedge.iter().enumerate() {
        let psi = polar + wedge_angle(w, &field[w.face]).rem_euclid(q);
        let psi = match psi_prev {
            Some(prev) => psi + ((prev - psi) / q).round() * q,
            None => psi,
        };
        if i == 0 {
            psi_first = psi;
        }
        psi_last = psi;
        psi_prev = Some(psi);
        if i + 1 == l.wedge.len() {
            p_b = polar + wedge_angle(w, cb);
        }
        polar += w.angle;
    }
    let p_a = wedge_angle(&l.wedge[0], ca);
    let t_a = (p_a - psi_first) / q;
    let t_b = (p_b - psi_last) / q;
    let t_a = if l.seam_in { t_a.round() } else { t_a };
    let t_b = if l.seam_out { t_b.round() } else { t_b };
    t_b - t_a
}

/// The region's angle at loop vertex `j` in field quarter turns.
///
/// Geometric part: the angle between chords to the loop vertices up to `rule.chord_steps` edges
/// before and after (stopping at the next candidate), so that jagged edge paths read like the
/// straight seams they will become — the chord angle θ in the tangent plane or its complement
/// Θ − θ, whichever is closer to the local wedge angle. Field part (when the rule has a field):
/// the angle is taken from the arm nearest to one chord to the arm nearest to the other, i.e.
/// corrected by each chord's deviation from the field in its face, so that two seams each a few
/// degrees off the field still meet at a whole number of quarter turns. Chords along the mesh
/// boundary, which need not follow the field, are not corrected.
fn corner_quarters(mesh: &Mesh, rule: &CornerRule, lp: &[LoopVertex], candidate: &[bool], j: usize) -> f64 {
    let n = lp.len();
    let v = lp[j].v;
    let local_angle = lp[j].angle;
    if n < 3 {
        return local_angle * rule.scale[v];
    }
    let steps = rule.chord_steps.max(1);
    let mut a = j;
    let mut b = j;
    for s in 1..=steps {
        a = (j + n - s) % n;
        if candidate[a] || a == (j + 1) % n {
            break;
        }
    }
    for s in 1..=steps {
        b = (j + s) % n;
        if candidate[b] || b == a {
            break;
        }
    }
    let p = mesh.position(v);
    let (ca, cb) = (mesh.position(lp[a].v) - p, mesh.position(lp[b].v) - p);
    let mut angle = local_angle;
    if steps > 1 {
        // The vertex normal from its faces (area weighted).
        let nrm = mesh.vertex_faces(v).fold(Vec3::zeros(), |acc, f| acc + mesh.face_normal(f) * mesh.face_area(f));
        if nrm.norm() > 0.0 {
            let nrm = nrm.normalize();
            let proj = |d: Vec3| d - nrm * nrm.dot(&d);
            let (pa, pb) = (proj(ca), proj(cb));
            if pa.norm() > 0.0 && pb.norm() > 0.0 {
                let theta = pa.angle(&pb);
                // A boundary vertex has no full fan: take 2π as the complement's reference.
                let total = if mesh.is_boundary_vertex(v) { 2.0 * PI } else { rule.angle_sum[v] };
                let other = total - theta;
                angle = if (theta - local_angle).abs() <= (other - local_angle).abs() { theta } else { other };
            }
        }
    }
    if let Some(field) = &rule.field {
        return field_quarters(&lp[j], field, &ca, &cb);
    }
    angle * rule.scale[v]
}

/// Patches of `mesh` cut along `seam` edges (boundary edges are always cuts), corners by the
/// plain rule (no field singularities).
pub fn patches(mesh: &Mesh, seam: &EdgeData<bool>) -> Patches {
    patches_with(mesh, seam, &CornerRule::plain(mesh))
}

/// Patches of `mesh` cut along `seam` edges, corners by `rule`.
pub fn patches_with(mesh: &Mesh, seam: &EdgeData<bool>, rule: &CornerRule) -> Patches {
    let (labels, n) = patch_labels(mesh, seam);
    patches_from_labels(mesh, labels, n, seam, rule)
}

/// The patch of every face of `mesh` cut along `seam` edges (faces connected across non-seam
/// interior edges, numbered by first face, as in [`Patches::patch_of_face`]) and their count,
/// without measuring the patches.
pub fn patch_labels(mesh: &Mesh, seam: &EdgeData<bool>) -> (FaceData<u32>, usize) {
    let mut uf = UnionFind::new(mesh.n_faces());
    for e in mesh.edges() {
        if let (a, Some(b)) = mesh.edge_faces(e)
            && !seam[e]
        {
            uf.union(a.0, b.0);
        }
    }
    let (labels, n) = uf.labels();
    (FaceData::from_vec(labels), n)
}

/// Patches for a given face labelling (`0..n`, every label used; an edge is cut when it is a
/// seam or its faces differ in label).
pub fn patches_from_labels(
    mesh: &Mesh,
    patch_of_face: FaceData<u32>,
    n: usize,
    seam: &EdgeData<bool>,
    rule: &CornerRule,
) -> Patches {
    let label = |f: FaceId| patch_of_face[f];
    let cut = |e: EdgeId| seam[e];
    let infos: Vec<RegionInfo> =
        faces_by_label(&patch_of_face, n).iter().map(|fs| region_info(mesh, fs, &label, &cut, rule)).collect();
    Patches::from_infos(patch_of_face, infos)
}

/// The faces carrying each of the labels `0..n`, ascending.
pub fn faces_by_label(patch_of_face: &FaceData<u32>, n: usize) -> Vec<Vec<FaceId>> {
    let mut faces: Vec<Vec<FaceId>> = vec![Vec::new(); n];
    for (f, &p) in patch_of_face.enumerate() {
        faces[p as usize].push(f);
    }
    faces
}

/// Seam edges from a list of vertex paths.
pub fn seam_edges(mesh: &Mesh, paths: &[Vec<VertexId>]) -> EdgeData<bool> {
    let mut seam = EdgeData::filled(mesh.n_edges(), false);
    for p in paths {
        for w in p.windows(2) {
            if let Some(e) = edge_between(mesh, w[0], w[1]) {
                seam[e] = true;
            }
        }
    }
    seam
}

/// The edge joining two vertices, if any.
pub fn edge_between(mesh: &Mesh, a: VertexId, b: VertexId) -> Option<EdgeId> {
    for h in mesh.outgoing(a) {
        if mesh.head(h) == b {
            return Some(mesh.edge(h));
        }
        if mesh.opposite_vertex(h) == b {
            return Some(mesh.edge(mesh.prev(h)));
        }
    }
    None
}

/// Vertices on a seam or on the boundary.
pub fn on_seam(mesh: &Mesh, seam: &EdgeData<bool>) -> VertexData<bool> {
    let mut on = VertexData::filled(mesh.n_vertices(), false);
    for e in mesh.edges() {
        if seam[e] {
            for v in mesh.edge_vertices(e) {
                on[v] = true;
            }
        }
    }
    on
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;
    use clothcast_mesh::util::SplitMix64;

    /// Seams flipped at random around random vertices (slits, loops, cuts to the boundary and
    /// all), one change after another: measuring only the patches around each change gives the
    /// patches measured from scratch, numbering included, also with chord angles and a field.
    /// (Without re-measuring the patches whose vertices see the grouping change, this fails.)
    #[test]
    fn reseamed_patches_equal_the_patches_measured_from_scratch() {
        for (mesh, chords) in [(shapes::icosphere(3, 1.0), 1), (shapes::grid(14, 11, 1.0, 0.8), 3)] {
            let normals = mesh.face_normals();
            let field = normals.map(|n| {
                let t = Vec3::x() - n * n.x;
                if t.norm() > 1e-9 { t.normalize() } else { Vec3::y() }
            });
            let mut index = VertexData::filled(mesh.n_vertices(), 0);
            index[VertexId(7)] = 1;
            let rule = CornerRule::new(&mesh, &index).with_chords(chords).with_field(field);
            // Three plane cuts to start from.
            let centroid = |f: FaceId| mesh.face_positions(f).iter().sum::<Vec3>() / 3.0;
            let side = |f: FaceId| {
                let c = centroid(f);
                (c.x > 0.1, c.y > 0.3, c.z > -0.2)
            };
            let mut seam = EdgeData::filled(mesh.n_edges(), false);
            for e in mesh.edges() {
                if let (a, Some(b)) = mesh.edge_faces(e) {
                    seam[e] = side(a) != side(b);
                }
            }
            let mut current = patches_with(&mesh, &seam, &rule);
            assert_eq!(current.reseamed(&mesh, &seam, &seam, &rule), current);
            let mut rng = SplitMix64::new(3);
            let mut count_changes = 0;
            for _ in 0..150 {
                let old_seam = seam.clone();
                let v = VertexId(rng.below(mesh.n_vertices()) as u32);
                for h in mesh.outgoing(v).collect::<Vec<_>>() {
                    if rng.below(3) == 0 {
                        let e = mesh.edge(h);
                        seam[e] = !seam[e];
                    }
                }
                let next = current.reseamed(&mesh, &old_seam, &seam, &rule);
                assert_eq!(next, patches_with(&mesh, &seam, &rule));
                count_changes += usize::from(next.n != current.n);
                current = next;
            }
            assert!(count_changes > 5, "the changes split and join patches ({count_changes})");
        }
    }
}
