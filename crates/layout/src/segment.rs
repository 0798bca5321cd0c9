//! The segmentation pipeline (paper §6.1–§6.2): trace, cut to disks, merge, split, remove tiny
//! patches, straighten and remesh, report.
//!
//! 1. **Trace** the separatrices of every singularity on a per-vertex cross field
//!    ([`crate::trace`]); a singularity left without any seam is joined to the nearest seam or
//!    boundary by a field-aligned shortest path (it must end up on a seam).
//! 2. **Disks**: extra field-aligned cuts until every patch is a topological disk
//!    ([`crate::cutgraph`]).
//! 3. **Merge** (§6.2.2): adjacent patches whose union is a disk with exactly four corners, with
//!    no singularity left inside and a developability score within `max_developability`, are
//!    merged, flattest union first; dangling seams (a slit inside a patch, both sides the same
//!    patch) are removed under the same conditions. The union's boundary is a subset of the
//!    existing, field-traced seams, so it stays field-aligned.
//! 4. **Split** (§6.2.3): a patch whose score exceeds `max_developability` is split in two disks
//!    by spectral clustering, the seam traced along the field ([`crate::split`]), recursively.
//!    Then non-quad patches with a concave corner (an L shape) are split from that corner along
//!    the field, as Pietroni et al. 2016 complete their layouts.
//! 5. **Tiny patches** (< `min_patch_fraction` of the area) are merged into the neighbour they
//!    share the longest seam with (if the union is a disk and no singularity ends up inside).
//! 6. **Smooth seams** (§6.2.1): split the seam network into chains between nodes
//!    ([`crate::network`]), pin long chains every `pin_spacing` edge lengths, straighten them
//!    together into geodesics with FlipOut ([`crate::flipout`]), and remesh the surface along
//!    them ([`crate::remesh`]). Chains that touch after straightening (which FlipOut allows,
//!    and which would pinch a patch) are pinned more and straightened again; if the patch
//!    topology still changed, the traced seams are kept and the report says so.
//! 7. **Late repairs**, on the final seams where corners are counted as reported (up to
//!    three rounds): a patch that is not a quad merges with a neighbour when the union is a
//!    quad within `max_developability` and the patches at the removed seam have as many quads
//!    and no more Σ |corners − 4| in total;
//!    then non-quads are split along the field from a concave corner or a corner, traced on
//!    the final mesh, the new seams straightened with every old seam vertex pinned, kept when
//!    the share of quads (after the tiny pass) rises; then cusps (`State::zip_cusps`: a
//!    non-quad's thin spike between two seams that leave a junction along one field arm is
//!    cut off across and handed to a neighbour), kept on the same terms. A last tiny pass
//!    follows.
//! 8. **Verify and report**: every patch must be a disk (else [`LayoutError::NotADisk`]); corners
//!    per patch (counted in the field's quarter turns, see [`crate::patches::CornerRule`]),
//!    quad fraction, singularities inside patches, seam length, seam–field deviation,
//!    developability, smallest angles.
//!
//! Steps 3–5 run on the traced (jagged) seams, with corner angles measured between chords a few
//! edges long, as the straightened seams will run. Straightening and remeshing run on the
//! input mesh for the whole network in step 6 (for both networks, re-routed and not, when
//! `follow_streamlines` is on), and in step 7 once per tried batch of late splits or cusp
//! repairs, on the
//! final mesh: the pinned old seams are already mesh edges there, so only the new seams' faces
//! are cut.
//!
//! Complexity: tracing O(S · V log V) for S separatrices in the worst case; cutting, chains,
//! remeshing O(F log F); FlipOut O(flips); merging O(merges · F_local log F); splitting one sparse
//! factorization per split patch.

use crate::LayoutError;
use crate::cutgraph::{self, make_disks};
use crate::developability::vertex_scores;
use crate::flipout::{FlipOutOptions, straighten_network};
use crate::network;
use crate::patches::{
    CornerRule, RegionInfo, edge_between, faces_by_label, patch_labels, patches, patches_with, region_info, seam_edges,
};
use crate::remesh::{RemeshOptions, insert_polylines};
use crate::split::{dart_path, field_aligned_split, spectral_split, split_through, two_sides};
use crate::trace::{SeparatrixEnd, TraceOptions, field_path, trace_separatrices};
use crate::vertex_field::VertexField;
use clothcast_field::{CrossField, Singularity};
use clothcast_mesh::geometry::shortest_edge_path;
use clothcast_mesh::{EdgeData, EdgeId, FaceData, FaceId, HalfedgeId, Mesh, Vec3, VertexData, VertexId};
use serde::Serialize;
use std::cell::OnceCell;
use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

/// Options of the segmentation (`[layout]` in the configuration).
#[derive(Clone, Debug)]
pub struct LayoutOptions {
    /// D of the tracing cost `ℓ (1 + D (φ/φ_max)²)`.
    pub drift_penalty: f64,
    /// φ_max: largest deviation (degrees) of a traced step from the field.
    pub max_deviation_deg: f64,
    /// Capture radius of singularities during tracing, in mean edge lengths.
    pub capture_radius: f64,
    /// Straighten seams into geodesics and remesh along them.
    pub smooth_seams: bool,
    /// Straightened seams are geodesic between pins placed about this many mean edge lengths
    /// apart along the traced seams (0: geodesic from node to node).
    pub pin_spacing: f64,
    /// Before straightening, move every field-following chain onto the streamlines of the
    /// field through its ends ([`crate::reroute`]).
    pub follow_streamlines: bool,
    /// Merge adjacent patches into quads.
    pub merge: bool,
    /// Step 7 (module doc): merges, corner splits and cusp repairs on the final (straightened)
    /// seams.
    pub late_repairs: bool,
    /// Largest patch developability score `∫ min(κ₁², κ₂²) dA` before a patch is split
    /// (infinite: never split).
    pub max_developability: f64,
    /// Patches smaller than this share of the total area are merged into a neighbour.
    pub min_patch_fraction: f64,
    /// Remeshing snap distance (share of an edge).
    pub snap: f64,
    /// Upper bound on developability splits (size splits have their own, 512 of each kind).
    pub max_splits: usize,
    /// Largest patch extent (metres, [`patch_extent`]: a long shortest path through the patch,
    /// usually above its flattened piece's width in any direction) before a patch is split, and
    /// that no merge may exceed; the CLI sets it from the fabric roll's width. Infinite (the
    /// default): no limit.
    pub max_patch_extent: f64,
    /// Patches to split further (what a first layout left too wide for the roll).
    pub split_hints: Vec<SplitHint>,
    /// Vertices of the input mesh that a seam must reach: cone-like tips (concentrated Gaussian
    /// curvature) that an earlier layout left inside a piece, where the flattening shrank the
    /// fabric around them (the CLI finds them). Each gets its seam last, on the final seams: a
    /// dart, a seam along the field from its patch's boundary ending at the tip
    /// ([`dart_path`]), or where that fails a cut through it both ways ([`split_through`]).
    pub cone_cuts: Vec<VertexId>,
    /// Seed of the tracing order and the spectral start vectors.
    pub seed: u64,
}

impl Default for LayoutOptions {
    fn default() -> Self {
        Self {
            drift_penalty: 10.0,
            max_deviation_deg: 45.0,
            capture_radius: 4.0,
            smooth_seams: true,
            pin_spacing: 12.0,
            follow_streamlines: true,
            merge: true,
            late_repairs: true,
            max_developability: 2.5,
            min_patch_fraction: 0.005,
            snap: 0.2,
            max_splits: 64,
            max_patch_extent: f64::INFINITY,
            split_hints: Vec::new(),
            cone_cuts: Vec::new(),
            seed: 1,
        }
    }
}

/// A patch of an earlier layout to split further: the input mesh's faces it held and the
/// largest extent ([`patch_extent`]) its pieces may have. Patches are laid out the same way up
/// to the splits (the same input and options), so a patch holding at least half of these
/// faces, or made at least half of them, is (part of) it: it is split until within the
/// extent, and no merge makes such a patch wider (the smallest extent where hints overlap).
#[derive(Clone, Debug, PartialEq)]
pub struct SplitHint {
    /// Faces of the input mesh.
    pub faces: Vec<FaceId>,
    /// Largest extent of the pieces (metres).
    pub max_extent: f64,
}

/// One seam: a chain of mesh edges between two nodes, and the patches on its two sides.
#[derive(Clone, Debug)]
pub struct Seam {
    /// Vertices of the chain on the segmented mesh.
    pub vertices: Vec<VertexId>,
    /// Patches on the left and right of the chain (equal for a self-seam, e.g. a dart).
    pub patches: [u32; 2],
}

/// One patch.
#[derive(Clone, Debug)]
pub struct PatchInfo {
    /// Euler characteristic (1 for a disk).
    pub euler: i64,
    /// Boundary loops (1 for a disk).
    pub loops: usize,
    /// Corner vertices in boundary order.
    pub corners: Vec<VertexId>,
    /// Every corner candidate (junction, singularity, mesh-boundary vertex) on the boundary and
    /// the patch's angle there in field quarter turns (a corner below 1.5).
    pub candidates: Vec<(VertexId, f64)>,
    /// Area (m²).
    pub area: f64,
    /// Developability score `∫ min(κ₁², κ₂²) dA` over the patch interior.
    pub developability: f64,
}

/// Figures of a segmentation (`segmentation` in `summary.json`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SegmentationStats {
    /// Number of patches.
    pub patches: usize,
    /// Patches that are topological disks (all of them, or the run fails).
    pub disks: usize,
    /// Patches below the tiny-area threshold that could not be merged away.
    pub tiny_patches: usize,
    /// Corners of every patch.
    pub corners: Vec<usize>,
    /// Share of patches with exactly four corners.
    pub quad_fraction: f64,
    /// Singularities not on a seam or boundary.
    pub singularities_inside_patches: usize,
    /// Total seam length (m), each seam counted once.
    pub seam_length_m: f64,
    /// Length-weighted median angle between the seams and the nearest cross direction (degrees).
    pub seam_field_deviation_median_deg: f64,
    /// Largest patch developability score.
    pub developability_max: f64,
    /// Merges of adjacent patches (and dangling seams removed).
    pub merges: usize,
    /// Developability splits.
    pub splits: usize,
    /// Splits of patches wider than `max_patch_extent` (pieces that would not fit the roll).
    pub size_splits: usize,
    /// Cusps repaired on the final seams (a patch's thin spike between two seams leaving a
    /// junction along one field arm, given to a neighbour; see `late_repairs`).
    pub cusp_repairs: usize,
    /// Separatrices traced (T-junctions among them) and failed.
    pub separatrices: usize,
    /// Separatrices ending in a T-junction.
    pub t_junctions: usize,
    /// Separatrices that found no target.
    pub separatrices_failed: usize,
    /// Extra cuts made to obtain disks.
    pub extra_cuts: usize,
    /// Seams run to or through cone-like tips ([`LayoutOptions::cone_cuts`]).
    pub cone_cuts: usize,
    /// Whether those seams are darts (each a seam from its patch's boundary ending at the tip,
    /// the patch kept whole) rather than cuts through the tip into two patches.
    pub darts: bool,
    /// Chains moved onto streamlines of the field before straightening.
    pub rerouted: usize,
    /// Whether the seams are straightened geodesics (false when straightening had to be skipped).
    pub straightened: bool,
    /// Smallest triangle angle of the segmented mesh (degrees).
    pub min_angle_deg: f64,
    /// Smallest angle of the triangles remeshing created (degrees; 180 when none).
    pub min_angle_new_deg: f64,
    /// Smallest triangle angle of the input mesh (degrees), for comparison.
    pub min_angle_input_deg: f64,
    /// Faces of the segmented mesh.
    pub faces: usize,
    /// Seconds spent.
    pub seconds: f64,
}

/// The segmented target.
#[derive(Clone, Debug)]
pub struct Segmentation {
    /// The remeshed target: every seam is an edge path.
    pub mesh: Mesh,
    /// Input-mesh face containing every face.
    pub face_parent: FaceData<FaceId>,
    /// Input vertex of every vertex that is one (inserted vertices: `None`).
    pub vertex_input: VertexData<Option<VertexId>>,
    /// Patch of every face.
    pub patch_of_face: FaceData<u32>,
    /// Every patch.
    pub patches: Vec<PatchInfo>,
    /// Every seam.
    pub seams: Vec<Seam>,
    /// The singularities on the segmented mesh.
    pub singularities: Vec<Singularity>,
    /// Cross field direction (one arm, unit, in the face plane) of every face.
    pub field_directions: FaceData<Vec3>,
    /// Figures.
    pub stats: SegmentationStats,
}

/// A mesh with seams, tied to the input mesh.
#[derive(Clone)]
struct Stage {
    mesh: Mesh,
    face_parent: FaceData<FaceId>,
    seam: EdgeData<bool>,
    singular: VertexData<bool>,
    /// Singularity index (quarter turns) of every vertex, 0 for regular ones.
    index: VertexData<i32>,
    /// What no merge may exceed: the largest extent and the split hints' extents.
    limits: Limits,
}

/// The size limits of a layout ([`LayoutOptions::max_patch_extent`], [`SplitHint`]).
#[derive(Clone, Debug)]
struct Limits {
    max_extent: f64,
    hints: Vec<SplitHint>,
    input_faces: usize,
}

impl Stage {
    /// The stage on a remeshing of its mesh, with the given seams: faces keep their input parent,
    /// inserted vertices are regular.
    fn remeshed(&self, r: &crate::remesh::Remeshed, seam: EdgeData<bool>) -> Stage {
        let face_parent = r.face_parent.map(|&f| self.face_parent[f]);
        let (singular, index) = (r.carry(&self.singular, false), r.carry(&self.index, 0));
        Stage { mesh: r.mesh.clone(), face_parent, seam, singular, index, limits: self.limits.clone() }
    }
}

/// Segment `mesh` given its cross field and singularities.
pub fn segment(
    mesh: &Mesh,
    field: &CrossField,
    singularities: &[Singularity],
    opts: &LayoutOptions,
) -> Result<Segmentation, LayoutError> {
    let start = Instant::now();
    let mut stats = SegmentationStats::default();
    let dirs = field.directions(mesh);
    let phi_max = opts.max_deviation_deg.to_radians();

    // 1. Trace.
    let vf = VertexField::from_face_field(mesh, field);
    let trace_opts = TraceOptions {
        drift_penalty: opts.drift_penalty,
        max_deviation_deg: opts.max_deviation_deg,
        seed: opts.seed,
        capture_radius: opts.capture_radius,
    };
    let seps = trace_separatrices(mesh, &vf, &dirs, singularities, &trace_opts);
    stats.separatrices = seps.iter().filter(|s| s.end != SeparatrixEnd::Failed).count();
    stats.t_junctions = seps.iter().filter(|s| matches!(s.end, SeparatrixEnd::TJunction(_))).count();
    stats.separatrices_failed = seps.len() - stats.separatrices;
    let paths: Vec<Vec<VertexId>> = seps.iter().filter(|s| s.vertices.len() >= 2).map(|s| s.vertices.clone()).collect();
    let mut seam = seam_edges(mesh, &paths);
    let mut singular = VertexData::filled(mesh.n_vertices(), false);
    let mut index = VertexData::filled(mesh.n_vertices(), 0i32);
    for s in singularities {
        singular[s.vertex] = true;
        index[s.vertex] = s.index;
    }
    // A one-edge stub of a separatrix is no seam; its singularity is then joined as any other.
    let mut lone = cutgraph::drop_lone_seam_edges(mesh, &mut seam);
    let attached = cutgraph::attach_isolated(mesh, &dirs, &mut seam, &singular, opts.drift_penalty, phi_max);
    tracing::debug!(separatrices = stats.separatrices, attached, "traced");

    // 2. Disks.
    let (cuts, _) = make_disks(mesh, &dirs, &mut seam, opts.drift_penalty, phi_max)?;
    stats.extra_cuts = cuts.len() + attached;

    let limits =
        Limits { max_extent: opts.max_patch_extent, hints: opts.split_hints.clone(), input_faces: mesh.n_faces() };
    let mut stage = Stage { mesh: mesh.clone(), face_parent: mesh.face_ids().collect(), seam, singular, index, limits };

    // 3.–5. Merge, split, tiny patches, on the traced (jagged) seams: corners are measured
    // between chords a few edges long, as the straightened seams will run.
    let (seam, merges, splits, tiny_merges) = {
        let scores = vertex_scores(&stage.mesh);
        let mut state =
            State::new(&stage.mesh, &stage.seam, &stage.singular, &stage.index, &scores, &dirs, CHORD_STEPS);
        state.limit(&stage);
        let merges = if opts.merge { state.merge_quads(opts.max_developability, false) } else { 0 };
        let splits = state.split_non_developable(opts.max_developability, opts.max_splits, &vf, &trace_opts)?;
        let size_splits = state.split_oversized(MAX_SIZE_SPLITS, &vf, &trace_opts)?
            + state.split_hinted(MAX_SIZE_SPLITS, &vf, &trace_opts)?;
        let concave = state.split_concave(&vf, &trace_opts, opts.max_splits);
        let to_quads = state.split_to_quads(&vf, &trace_opts, opts.max_splits);
        let tiny = state.merge_tiny(opts.min_patch_fraction * mesh.total_area(), &dirs, opts.drift_penalty, phi_max);
        (state.seam, merges, (splits + concave + to_quads, size_splits), tiny)
    };
    stage.seam = seam;
    stats.merges = merges + tiny_merges;
    (stats.splits, stats.size_splits) = splits;

    // 6. Smooth seams: straighten and remesh once.
    stats.straightened = opts.smooth_seams;
    if opts.smooth_seams {
        let no_pins = VertexData::filled(stage.mesh.n_vertices(), false);
        let traced = opts.follow_streamlines.then(|| stage.clone());
        let (plain, plain_ok) = smooth(stage, &no_pins, opts)?;
        stage = plain;
        stats.straightened &= plain_ok;
        if let Some(base) = &traced {
            // Re-route along streamlines; keep the result when, straightened, it has at least as
            // many quads (corners depend on the final geometry, so both are straightened and
            // compared). Chains next to patches that lost their quad are then left alone and
            // the re-route is tried once more.
            let (labels, n_patches) = patch_labels(&base.mesh, &base.seam);
            let sides = |chain: &[VertexId]| -> [u32; 2] {
                let e = edge_between(&base.mesh, chain[0], chain[1]).expect("chains are edge paths");
                let (a, b) = base.mesh.edge_faces(e);
                [labels[a], labels[b.unwrap_or(a)]]
            };
            let quality = |s: &Stage| {
                let fd = final_field(s, &dirs);
                let rule = CornerRule::new(&s.mesh, &s.index).with_chords(FINAL_CHORD_STEPS).with_field(fd.clone());
                let p = patches_with(&s.mesh, &s.seam, &rule);
                // Corner count per patch of `base` (by majority of its faces' children).
                let mut votes: Vec<BTreeMap<usize, usize>> = vec![BTreeMap::new(); n_patches];
                for f in s.mesh.face_ids() {
                    *votes[labels[s.face_parent[f]] as usize].entry(p.patch_of_face[f] as usize).or_default() += 1;
                }
                let per_base: Vec<usize> = votes
                    .iter()
                    .map(|v| v.iter().max_by_key(|(_, c)| **c).map(|(q, _)| p.corners[*q].len()).unwrap_or(0))
                    .collect();
                let quads = p.corners.iter().filter(|c| c.len() == 4).count();
                (quads, per_base)
            };
            let (best_q, plain_corners) = quality(&stage);
            let mut lost: BTreeSet<u32> = BTreeSet::new();
            for round in 0..2 {
                let skip = |chain: &[VertexId]| sides(chain).iter().any(|p| lost.contains(p));
                let r = crate::reroute::reroute(
                    &base.mesh,
                    &base.seam,
                    &base.singular,
                    &base.index,
                    &dirs,
                    CHORD_STEPS,
                    REROUTE_PIN_EDGES * base.mesh.mean_edge_length(),
                    REROUTE_PIN_SNAP,
                    &skip,
                );
                if r.chains == 0 {
                    break;
                }
                let alt = match &r.refined {
                    Some(refined) => base.remeshed(refined, r.seam),
                    None => Stage { seam: r.seam, ..base.clone() },
                };
                let (alt, alt_ok) = smooth(alt, &r.pins, opts)?;
                let (q, corners) = quality(&alt);
                tracing::debug!(round, rerouted = r.chains, quads = q, quads_plain = best_q, "re-route");
                if (alt_ok || !stats.straightened) && q >= best_q {
                    stage = alt;
                    stats.straightened = alt_ok;
                    stats.rerouted = r.chains;
                    break;
                }
                let newly: Vec<u32> = (0..n_patches)
                    .filter(|&i| plain_corners[i] == 4 && corners[i] != 4)
                    .map(|i| i as u32)
                    .filter(|i| !lost.contains(i))
                    .collect();
                if newly.is_empty() {
                    break;
                }
                lost.extend(newly);
            }
        }
    }
    let final_chords = if stats.straightened { FINAL_CHORD_STEPS } else { CHORD_STEPS };
    // On the final seams, where corners are counted as reported (the corners before
    // straightening were measured on the traced seams and can differ): merge a patch that is
    // not a quad with a neighbour when the union is one, split non-quads from a corner, repair
    // cusps.
    for _ in 0..if opts.late_repairs { LATE_ROUNDS } else { 0 } {
        let mut merged = 0;
        if opts.merge {
            let (seam, m) =
                on_stage(&stage, &dirs, final_chords, |state, _| state.merge_quads(opts.max_developability, true));
            stage.seam = seam;
            merged = m;
            stats.merges += merged;
        }
        let (mut split, mut zipped) = (0, 0);
        if stats.straightened {
            // The stage after its tiny pass, measured once for the repairs tried on it.
            let mut passed = OnceCell::new();
            if let Some((late_stage, n, m)) = late_splits(&stage, &dirs, &trace_opts, final_chords, opts, &passed) {
                stage = late_stage;
                passed = OnceCell::new();
                split = n;
                stats.splits += n;
                stats.merges += m;
            }
            // Cusp repairs: cuts along the field first, then the smallest spikes.
            let zips = [true, false].into_iter().find_map(|aligned| {
                late_repair(&stage, &dirs, final_chords, opts, "cusps", true, &passed, |state, budget| {
                    state.zip_cusps(budget, aligned)
                })
            });
            if let Some((late_stage, n, m)) = zips {
                stage = late_stage;
                zipped = n;
                stats.cusp_repairs += n;
                stats.merges += m;
            }
        }
        if merged + split + zipped == 0 {
            break;
        }
    }
    // Straightening can shrink a patch below the tiny threshold: one more tiny pass.
    stats.merges += tiny_pass(&mut stage, &dirs, final_chords, opts);
    // Last, the seams through the cone-like tips asked for (no tiny pass after them: it could
    // merge the two sides of such a seam back).
    if !opts.cone_cuts.is_empty()
        && let Some((cut_stage, n, darts)) = cut_cones(&stage, &dirs, &trace_opts, final_chords, opts)
    {
        stage = cut_stage;
        stats.cone_cuts = n;
        stats.darts = darts;
    }
    let total_area = stage.mesh.total_area();
    let field_directions = final_field(&stage, &dirs);

    // 8. Verify and report (the passes above may have left a one-edge slit too).
    lone += cutgraph::drop_lone_seam_edges(&stage.mesh, &mut stage.seam);
    if lone > 0 {
        tracing::debug!(lone, "one-edge slits removed from the seams");
    }
    let rule =
        CornerRule::new(&stage.mesh, &stage.index).with_chords(final_chords).with_field(field_directions.clone());
    let p = patches_with(&stage.mesh, &stage.seam, &rule);
    if let Some(bad) = (0..p.n).find(|&i| !p.is_disk(i)) {
        return Err(LayoutError::NotADisk { patch: bad, euler: p.euler[bad], boundary_loops: p.loops[bad] });
    }
    let scores = vertex_scores(&stage.mesh);
    let faces = p.faces();
    let label = |f: FaceId| p.patch_of_face[f];
    let cut = |e: EdgeId| stage.seam[e];
    let patch_infos: Vec<PatchInfo> = (0..p.n)
        .map(|i| PatchInfo {
            euler: p.euler[i],
            loops: p.loops[i],
            corners: p.corners[i].clone(),
            candidates: p.candidates[i].clone(),
            area: p.area[i],
            developability: region_score(&stage.mesh, &faces[i], &label, &cut, &scores),
        })
        .collect();
    if tracing::enabled!(tracing::Level::DEBUG) {
        for (i, info) in patch_infos.iter().enumerate().filter(|(_, info)| info.corners.len() != 4) {
            let candidates: Vec<String> = info.candidates.iter().map(|(v, q)| format!("{}:{q:.2}", v.idx())).collect();
            tracing::debug!(patch = i, corners = info.corners.len(), candidates = candidates.join(" "), "not a quad");
        }
    }
    let chains = network::chains(&stage.mesh, &stage.seam, &stage.singular);
    let seams: Vec<Seam> = chains
        .into_iter()
        .map(|c| {
            let e = edge_between(&stage.mesh, c[0], c[1]).expect("chains are edge paths");
            let h = stage.mesh.edge_halfedge(e);
            // Left: the face of the halfedge running along the chain.
            let (left, right) = if stage.mesh.tail(h) == c[0] {
                (stage.mesh.face(h), stage.mesh.twin(h).map(|t| stage.mesh.face(t)))
            } else {
                (stage.mesh.twin(h).map(|t| stage.mesh.face(t)).unwrap_or(stage.mesh.face(h)), Some(stage.mesh.face(h)))
            };
            let pl = p.patch_of_face[left];
            let pr = right.map(|f| p.patch_of_face[f]).unwrap_or(pl);
            Seam { vertices: c, patches: [pl, pr] }
        })
        .collect();
    let on_cut = {
        let mut on = VertexData::filled(stage.mesh.n_vertices(), false);
        for e in stage.mesh.edges() {
            if stage.seam[e] || stage.mesh.is_boundary_edge(e) {
                for v in stage.mesh.edge_vertices(e) {
                    on[v] = true;
                }
            }
        }
        on
    };
    // Input vertices keep their ids through remeshing.
    let final_singularities: Vec<Singularity> = singularities.to_vec();
    stats.singularities_inside_patches = final_singularities.iter().filter(|s| !on_cut[s.vertex]).count();
    stats.patches = p.n;
    stats.disks = (0..p.n).filter(|&i| p.is_disk(i)).count();
    stats.corners = patch_infos.iter().map(|i| i.corners.len()).collect();
    stats.quad_fraction =
        if p.n > 0 { stats.corners.iter().filter(|&&c| c == 4).count() as f64 / p.n as f64 } else { 0.0 };
    stats.tiny_patches = patch_infos.iter().filter(|i| i.area < opts.min_patch_fraction * total_area).count();
    stats.developability_max = patch_infos.iter().map(|i| i.developability).fold(0.0, f64::max);
    let (len, dev) = seam_deviation(&stage.mesh, &stage.seam, &field_directions);
    stats.seam_length_m = len;
    stats.seam_field_deviation_median_deg = dev;
    stats.min_angle_deg = stage.mesh.min_angle().to_degrees();
    stats.min_angle_input_deg = mesh.min_angle().to_degrees();
    stats.min_angle_new_deg = {
        let mut children = vec![0u32; mesh.n_faces()];
        for &f in stage.face_parent.iter() {
            children[f.idx()] += 1;
        }
        let angles = stage.mesh.corner_angles();
        stage
            .mesh
            .face_ids()
            .filter(|&f| children[stage.face_parent[f].idx()] > 1)
            .flat_map(|f| (0..3).map(move |k| (f, k)))
            .map(|(f, k)| angles[stage.mesh.face_halfedge(f, k)])
            .fold(std::f64::consts::PI, f64::min)
            .to_degrees()
    };
    stats.faces = stage.mesh.n_faces();
    stats.seconds = start.elapsed().as_secs_f64();
    let vertex_input = stage.mesh.vertices().map(|v| (v.idx() < mesh.n_vertices()).then_some(v)).collect();
    Ok(Segmentation {
        face_parent: stage.face_parent,
        vertex_input,
        patch_of_face: p.patch_of_face,
        patches: patch_infos,
        seams,
        singularities: final_singularities,
        field_directions,
        mesh: stage.mesh,
        stats,
    })
}

/// Concave and corner splits ([`State::split_concave`], [`State::split_to_quads`]) on the
/// final, straightened seams, where corners are counted as reported: the new seams are traced
/// on the final mesh ([`late_repair`]). Returns the new stage, the splits kept and the tiny
/// merges they brought, or None when no split is kept.
fn late_splits(
    stage: &Stage,
    dirs: &FaceData<Vec3>,
    trace: &TraceOptions,
    chords: usize,
    opts: &LayoutOptions,
    passed: &OnceCell<Passed>,
) -> Option<(Stage, usize, usize)> {
    let vf = stage_vertex_field(stage, dirs);
    late_repair(stage, dirs, chords, opts, "late splits", false, passed, |state, budget| {
        let n = state.split_concave(&vf, trace, budget);
        if n < budget { n + state.split_to_quads(&vf, trace, budget - n) } else { n }
    })
}

/// The field of a (remeshed) stage as a vertex field, for traces on its own mesh.
fn stage_vertex_field(stage: &Stage, dirs: &FaceData<Vec3>) -> VertexField {
    let mesh = &stage.mesh;
    let field_directions = final_field(stage, dirs);
    let theta: FaceData<f64> = mesh.face_ids().map(|f| mesh.face_frame(f).angle_of(&field_directions[f])).collect();
    let cross = CrossField::from_angles(mesh, &clothcast_field::cross::connection(mesh), theta);
    VertexField::from_face_field(mesh, &cross)
}

/// Seams through the cone-like tips of [`LayoutOptions::cone_cuts`] that lie inside a patch of
/// the final layout: a dart first (a seam from the patch's boundary to the tip, the patch kept
/// whole, [`dart_path`]), else a cut through the tip into two patches ([`split_through`], each
/// side at least [`CONE_MIN_SIDE`] of its patch); straightened with every existing seam vertex
/// and the tips pinned, so that the new seams run to each tip as geodesics. Kept when
/// straightening succeeds and every patch is a disk; returns the new stage, the seams made and
/// whether they are darts, or None.
fn cut_cones(
    stage: &Stage,
    dirs: &FaceData<Vec3>,
    trace: &TraceOptions,
    chords: usize,
    opts: &LayoutOptions,
) -> Option<(Stage, usize, bool)> {
    let mesh = &stage.mesh;
    let vf = stage_vertex_field(stage, dirs);
    // The input mesh's vertices keep their ids in every remeshed stage.
    let tips: Vec<VertexId> = opts.cone_cuts.iter().copied().filter(|v| v.idx() < mesh.n_vertices()).collect();
    let mut pins = network::seam_degree(mesh, &stage.seam).map(|&d| d > 0);
    for &v in &tips {
        pins[v] = true;
    }
    [true, false].into_iter().find_map(|darts| {
        let (seam, n) = on_stage(stage, dirs, chords, |state, _| state.cone_seams(&tips, darts, &vf, trace));
        if n == 0 {
            return None;
        }
        let alt = Stage { seam, ..stage.clone() };
        match smooth_quiet(alt, &pins, opts) {
            Ok((alt, true)) => {
                let p = patches_with(&alt.mesh, &alt.seam, &CornerRule::new(&alt.mesh, &alt.index).with_chords(chords));
                let disks = (0..p.n).all(|i| p.is_disk(i));
                tracing::debug!(seams = n, darts, disks, "cone cuts");
                disks.then_some((alt, n, darts))
            }
            Ok((_, false)) => {
                tracing::debug!(seams = n, darts, "cone cuts dropped: straightening would change the patches");
                None
            }
            Err(e) => {
                tracing::debug!(seams = n, darts, error = %e, "cone cuts dropped: straightening failed");
                None
            }
        }
    })
}

/// Smallest share of its patch's area on either side of a seam cut through a cone-like tip.
const CONE_MIN_SIDE: f64 = 0.05;

/// A stage after the tiny pass that follows a late repair (a repair may cut off a sliver that
/// then merges into another neighbour), measured: its share of quads, whether every patch is a
/// disk, the tiny patches left, and the merges the pass made.
struct Passed {
    stage: Stage,
    merges: usize,
    share: f64,
    disks: bool,
    tiny: usize,
}

/// [`Passed`]: `stage`'s tiny pass, then its measures.
fn after_tiny_pass(stage: &Stage, dirs: &FaceData<Vec3>, chords: usize, opts: &LayoutOptions) -> Passed {
    let mut s = stage.clone();
    let merges = tiny_pass(&mut s, dirs, chords, opts);
    let fd = final_field(&s, dirs);
    let rule = CornerRule::new(&s.mesh, &s.index).with_chords(chords).with_field(fd);
    let p = patches_with(&s.mesh, &s.seam, &rule);
    let quads = p.corners.iter().filter(|c| c.len() == 4).count();
    let min_area = opts.min_patch_fraction * s.mesh.total_area();
    let tiny = (0..p.n).filter(|&i| p.area[i] < min_area).count();
    let disks = (0..p.n).all(|i| p.is_disk(i));
    Passed { stage: s, merges, share: quads as f64 / p.n.max(1) as f64, disks, tiny }
}

/// A repair of the final, straightened seams: `propose` changes the seams of the merge/split
/// state (at most `budget` changes; returns how many), the new seams are straightened with
/// every existing seam vertex pinned (the other seams stay as they are), and the result is kept
/// when, after the tiny pass, it has a larger share of quads, only disks and no more tiny
/// patches than before; all the changes found are tried together, then (if that is not kept)
/// a single one. With `tiny_first`, `propose` works on the stage after the tiny pass (the
/// neighbours a repair hands faces to are then those of the final layout). `passed` holds
/// `stage` after its tiny pass ([`after_tiny_pass`]), filled on first use and shared by the
/// repairs tried on the same stage. Returns the new stage, the changes kept and the tiny
/// merges they brought, or None when nothing is kept.
#[allow(clippy::too_many_arguments)]
fn late_repair(
    stage: &Stage,
    dirs: &FaceData<Vec3>,
    chords: usize,
    opts: &LayoutOptions,
    what: &str,
    tiny_first: bool,
    passed: &OnceCell<Passed>,
    propose: impl Fn(&mut State<'_>, usize) -> usize,
) -> Option<(Stage, usize, usize)> {
    let orig = || passed.get_or_init(|| after_tiny_pass(stage, dirs, chords, opts));
    let (stage, first_merges) = if tiny_first { (&orig().stage, orig().merges) } else { (stage, 0) };
    let pins = network::seam_degree(&stage.mesh, &stage.seam).map(|&d| d > 0);
    for budget in [opts.max_splits, 1] {
        let (seam, n) = on_stage(stage, dirs, chords, |state, _| propose(state, budget));
        if n == 0 {
            break;
        }
        // The layout as it is, measured the same way (when there is a change to compare).
        let (before, tiny_before) = (orig().share, orig().tiny);
        let mut alt = stage.clone();
        alt.seam = seam;
        // The repair is optional: if straightening the new seams fails, they are dropped.
        match smooth_quiet(alt, &pins, opts) {
            Ok((alt, ok)) => {
                let Passed { stage: alt, merges, share: after, disks, tiny } =
                    after_tiny_pass(&alt, dirs, chords, opts);
                tracing::debug!(what, changes = n, merges, ok, before, after, disks, tiny, "late repair");
                if ok && disks && tiny <= tiny_before && after > before {
                    return Some((alt, n, first_merges + merges));
                }
            }
            Err(e) => tracing::debug!(what, changes = n, error = %e, "late repair dropped: straightening failed"),
        }
        if n == 1 {
            break;
        }
    }
    None
}

/// Merge patches below `min_patch_fraction` of the area into a neighbour, on a stage's own
/// field and corners ([`State::merge_tiny`]); returns the merges.
fn tiny_pass(stage: &mut Stage, dirs: &FaceData<Vec3>, chords: usize, opts: &LayoutOptions) -> usize {
    let min_area = opts.min_patch_fraction * stage.mesh.total_area();
    let (seam, m) = on_stage(stage, dirs, chords, |state, field| {
        state.merge_tiny(min_area, field, opts.drift_penalty, opts.max_deviation_deg.to_radians())
    });
    stage.seam = seam;
    m
}

/// Run `f` on the merge/split state of a (remeshed) stage, with the stage's own field
/// ([`final_field`]) and corners counted between chords of `chords` edges; returns the seams
/// `f` leaves and its result.
fn on_stage<R>(
    stage: &Stage,
    dirs: &FaceData<Vec3>,
    chords: usize,
    f: impl FnOnce(&mut State<'_>, &FaceData<Vec3>) -> R,
) -> (EdgeData<bool>, R) {
    let field = final_field(stage, dirs);
    let scores = vertex_scores(&stage.mesh);
    let mut state = State::new(&stage.mesh, &stage.seam, &stage.singular, &stage.index, &scores, &field, chords);
    state.limit(stage);
    let r = f(&mut state, &field);
    (state.seam, r)
}

/// The field's arm on every face of a (remeshed) stage: its input face's, in its own plane.
fn final_field(stage: &Stage, dirs: &FaceData<Vec3>) -> FaceData<Vec3> {
    stage
        .mesh
        .face_ids()
        .map(|f| {
            let n = stage.mesh.face_normal(f);
            let d = dirs[stage.face_parent[f]];
            let t = d - n * n.dot(&d);
            if t.norm() > 1e-12 { t.normalize() } else { stage.mesh.face_frame(f).b1 }
        })
        .collect()
}

/// Straighten the seam network and remesh along it. Returns the new stage and whether the
/// straightened seams were kept (false: the patch topology could not be kept, the stage is
/// unchanged).
///
/// FlipOut lets geodesics touch (a geodesic wrapping around another chain's end passes through
/// it; two geodesics may share a vertex or an edge point). A touch pinches the patch between the
/// two seams and changes the layout, so touching chains get their middle vertex as an extra
/// fixed node and the network is straightened again; in the last two of [`SMOOTH_ATTEMPTS`]
/// rounds every vertex of a chain that still touches is pinned (it keeps its traced course).
fn smooth(stage: Stage, pins: &VertexData<bool>, opts: &LayoutOptions) -> Result<(Stage, bool), LayoutError> {
    let (stage, ok) = smooth_quiet(stage, pins, opts)?;
    if !ok {
        tracing::warn!("straightened seams would change the patches; keeping the traced seams");
    }
    Ok((stage, ok))
}

/// [`smooth`] without the warning (for the late repairs, where a failure only drops them).
fn smooth_quiet(stage: Stage, pins: &VertexData<bool>, opts: &LayoutOptions) -> Result<(Stage, bool), LayoutError> {
    let (_, n_before) = patch_labels(&stage.mesh, &stage.seam);
    let deg = network::seam_degree(&stage.mesh, &stage.seam);
    let mut nodes: VertexData<bool> =
        stage.mesh.vertices().map(|v| stage.singular[v] || (pins[v] && deg[v] > 0)).collect();
    // Pins along long chains: each piece between pins becomes a geodesic, so the seam keeps
    // the course of the traced (field-aligned) curve instead of cutting across to its far end.
    if opts.pin_spacing > 0.0 {
        let spacing = opts.pin_spacing * stage.mesh.mean_edge_length();
        for chain in network::chains(&stage.mesh, &stage.seam, &nodes) {
            let len: Vec<f64> =
                chain.windows(2).map(|w| (stage.mesh.position(w[1]) - stage.mesh.position(w[0])).norm()).collect();
            let total: f64 = len.iter().sum();
            let pieces = (total / spacing).round().max(1.0);
            let step = total / pieces;
            let mut acc = 0.0;
            let mut next = step;
            for (i, l) in len.iter().enumerate().take(chain.len().saturating_sub(2)) {
                acc += l;
                if acc >= next - 1e-12 {
                    nodes[chain[i + 1]] = true;
                    next += step;
                }
            }
        }
    }
    for attempt in 0..SMOOTH_ATTEMPTS {
        let chains = network::chains(&stage.mesh, &stage.seam, &nodes);
        if chains.is_empty() {
            return Ok((stage, true));
        }
        let polylines = straighten_network(&stage.mesh, &chains, &FlipOutOptions::default())?;
        let mut touching = touching_chains(&polylines);
        let mut remeshed = None;
        if touching.is_empty() {
            // Remeshing snaps crossings near a vertex onto it, which can make two seams touch too.
            let r = insert_polylines(&stage.mesh, &polylines, &RemeshOptions { snap: opts.snap })?;
            let as_points: Vec<Vec<crate::SurfacePoint>> =
                r.paths.iter().map(|p| p.iter().map(|&v| crate::SurfacePoint::Vertex(v)).collect()).collect();
            touching = touching_chains(&as_points);
            remeshed = Some(r);
        }
        if !touching.is_empty() {
            tracing::debug!(attempt, touching = touching.len(), "straightened seams touch; pinning them");
            // First pin the middles; in the last rounds pin every vertex (a chain of single
            // edges cannot move, so the network then straightens without touching).
            let mut progressed = false;
            for &c in &touching {
                let chain = &chains[c];
                if chain.len() < 3 {
                    continue;
                }
                if attempt + 2 >= SMOOTH_ATTEMPTS {
                    chain.iter().for_each(|&v| nodes[v] = true);
                } else {
                    nodes[chain[chain.len() / 2]] = true;
                }
                progressed = true;
            }
            if progressed {
                continue;
            }
            break;
        }
        let r = remeshed.expect("remeshed when nothing touches");
        let seam = seam_edges(&r.mesh, &r.paths);
        let after = patches(&r.mesh, &seam);
        if after.n != n_before || (0..after.n).any(|i| !after.is_disk(i)) {
            break;
        }
        return Ok((stage.remeshed(&r, seam), true));
    }
    tracing::debug!(patches = n_before, "straightened seams would change the patches");
    Ok((stage, false))
}

/// A patch angle below this many quarter turns is a cusp ([`State::zip_cusps`]).
const CUSP_QUARTERS: f64 = 0.5;

/// Cut positions tried along each side of a cusp ([`State::zip_cusps`]).
const ZIP_SAMPLES: usize = 12;

/// Narrowest cut across a cusp's spike, in mean edge lengths ([`State::zip_cusps`]).
const ZIP_MIN_WIDTH: f64 = 2.0;

/// A patch angle of at least this many quarter turns is a concave corner.
const CONCAVE_QUARTERS: f64 = 2.5;

/// Corners of traced (jagged) seams are measured between chords this many edges long.
const CHORD_STEPS: usize = 8;
/// Corners of the final (straightened) seams: chords a few edges long (they are geodesics; this
/// only smooths the remeshing's small kinks).
const FINAL_CHORD_STEPS: usize = 3;

/// Pins of chains re-routed along streamlines, in mean edge lengths (measured on fertility,
/// bunny, spot, torus: 5 gave the lowest seam–field deviation; 3 and 8 were worse).
const REROUTE_PIN_EDGES: f64 = 5.0;

/// A re-route pin is the streamline's own crossing of an edge unless that lies within this share
/// of the edge from an end (then the nearest vertex). Measured at seed 1–3 on the six models:
/// 0.2 (the remeshing snap) gave the lowest deviations but new angles down to 3.6° on the bunny
/// (6.0° before); 0.3 keeps the new angles where they were and fertility's deviation below 10°.
const REROUTE_PIN_SNAP: f64 = 0.3;

/// Rounds of straightening in [`smooth`].
const SMOOTH_ATTEMPTS: usize = 8;

/// Rounds of late repairs (merges, corner splits, cusp repairs) on the final seams.
const LATE_ROUNDS: usize = 3;

/// Polylines whose interior shares a point (vertex or edge point) with another polyline.
fn touching_chains(polylines: &[Vec<crate::SurfacePoint>]) -> Vec<usize> {
    use crate::SurfacePoint;
    let key = |p: &SurfacePoint| -> (u8, u32, i64) {
        match *p {
            SurfacePoint::Vertex(v) => (0, v.0, 0),
            SurfacePoint::Edge { edge, t } => (1, edge.0, (t * 1e6).round() as i64),
        }
    };
    // Every point → the polylines using it (ends count, interiors are what gets pinched).
    let mut users: BTreeMap<(u8, u32, i64), Vec<(usize, bool)>> = BTreeMap::new();
    for (i, pl) in polylines.iter().enumerate() {
        for (j, p) in pl.iter().enumerate() {
            let interior = j > 0 && j + 1 < pl.len();
            users.entry(key(p)).or_default().push((i, interior));
        }
    }
    let mut out: BTreeSet<usize> = BTreeSet::new();
    for list in users.values() {
        if list.len() < 2 || !list.iter().any(|&(_, interior)| interior) {
            continue;
        }
        for &(i, interior) in list {
            if interior {
                out.insert(i);
            }
        }
    }
    out.into_iter().collect()
}

/// Σ of vertex scores over the interior vertices of a region (no incident cut edge). `faces`
/// are all the faces `label` gives the region's label (its first face's).
fn region_score(
    mesh: &Mesh,
    faces: &[FaceId],
    label: &impl Fn(FaceId) -> u32,
    seam: &impl Fn(EdgeId) -> bool,
    scores: &VertexData<f64>,
) -> f64 {
    let own = match faces.first() {
        Some(&f) => label(f),
        None => return 0.0,
    };
    // Each vertex taken at one face, the face of its first outgoing halfedge: a vertex whose
    // faces all lie in the region is met there once (no sort and dedup of every corner).
    let mut vs: Vec<VertexId> = faces
        .iter()
        .flat_map(|&f| mesh.face_vertices(f).into_iter().map(move |v| (f, v)))
        .filter(|&(f, v)| {
            !mesh.is_boundary_vertex(v)
                && mesh.face(mesh.vertex_halfedge(v)) == f
                && mesh.outgoing(v).all(|h| label(mesh.face(h)) == own && !seam(mesh.edge(h)))
        })
        .map(|(_, v)| v)
        .collect();
    // Summed in vertex order, as ever.
    vs.sort_unstable();
    vs.into_iter().map(|v| scores[v]).sum()
}

/// The connected pieces (through shared vertices) of a set of edges.
fn edge_components(mesh: &Mesh, edges: &[EdgeId]) -> Vec<Vec<EdgeId>> {
    let mut uf = clothcast_mesh::util::UnionFind::new(edges.len());
    let mut at: BTreeMap<VertexId, usize> = BTreeMap::new();
    for (i, &e) in edges.iter().enumerate() {
        for v in mesh.edge_vertices(e) {
            if let Some(&j) = at.get(&v) {
                uf.union(i as u32, j as u32);
            } else {
                at.insert(v, i);
            }
        }
    }
    let (labels, n) = uf.labels();
    let mut out = vec![Vec::new(); n];
    for (i, &e) in edges.iter().enumerate() {
        out[labels[i] as usize].push(e);
    }
    out
}

/// Length-weighted median deviation (degrees) of seam edges from the field, and total length.
fn seam_deviation(mesh: &Mesh, seam: &EdgeData<bool>, dirs: &FaceData<Vec3>) -> (f64, f64) {
    let mut samples: Vec<(f64, f64)> = Vec::new();
    for e in mesh.edges() {
        if !seam[e] || mesh.is_boundary_edge(e) {
            continue;
        }
        let len = mesh.edge_length(e);
        if len <= 0.0 {
            continue;
        }
        let phi = crate::reroute::edge_deviation(mesh, e, dirs);
        samples.push((phi.to_degrees(), len));
    }
    let total: f64 = samples.iter().map(|s| s.1).sum();
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut acc = 0.0;
    let mut median = 0.0;
    for (phi, w) in &samples {
        acc += w;
        median = *phi;
        if acc >= 0.5 * total {
            break;
        }
    }
    (total, median)
}

/// Patches as labelled face sets over a fixed mesh, with the seam set; merges and splits.
struct State<'a> {
    mesh: &'a Mesh,
    seam: EdgeData<bool>,
    label: FaceData<u32>,
    /// Faces of each label (sorted; empty once merged away).
    faces: Vec<Vec<FaceId>>,
    singular: &'a VertexData<bool>,
    scores: &'a VertexData<f64>,
    density: VertexData<f64>,
    vertex_areas: VertexData<f64>,
    rule: CornerRule,
    degree: VertexData<u32>,
    mean_edge: f64,
    /// No merge may make a patch wider than this ([`LayoutOptions::max_patch_extent`]).
    max_extent: f64,
    /// [`patch_extent`] of each patch, once computed (forgotten when its faces change).
    extents: std::cell::RefCell<Vec<Option<f64>>>,
    /// The size limit and [`patch_extent`] of the union of two patches (smaller id first),
    /// kept while neither changes: the merge of a tiny patch the roll's width refuses is asked
    /// again after every other merge (a 3 m mold on a 300 mm roll: 460 such patches, about half
    /// of the layout's time spent in these searches and in building the unions).
    union_extents: std::cell::RefCell<BTreeMap<(u32, u32), (f64, f64)>>,
    /// Split hints: no merge may make a hinted patch wider than its target.
    hints: Option<HintMap>,
}

/// A cusp repair ([`State::zip_cusps`]): the spike's faces, the patch that receives them and
/// the cut edges.
type Zip = (Vec<FaceId>, u32, BTreeSet<EdgeId>);

/// The least drop in Σ |corners − 4| that makes a repair candidate the best so far, given the
/// best's drop and whether the candidate wins a tie with it (none yet: any drop).
fn least_to_beat(best: Option<(usize, bool)>) -> usize {
    best.map_or(1, |(gain, wins_tie)| if wins_tie { gain } else { gain + 1 }).max(1)
}

/// Patch measures ([`State::info_of`]) once computed, kept until the caller forgets a patch a
/// change may have touched.
#[derive(Default)]
struct InfoCache(Vec<Option<RegionInfo>>);

impl InfoCache {
    /// The measure of patch `p`.
    fn get(&mut self, state: &State<'_>, p: u32) -> &RegionInfo {
        if self.0.len() <= p as usize {
            self.0.resize(p as usize + 1, None);
        }
        self.0[p as usize].get_or_insert_with(|| state.info_of(p))
    }

    /// Forget the measures of `patches`.
    fn forget(&mut self, patches: &BTreeSet<u32>) {
        for &q in patches {
            if let Some(slot) = self.0.get_mut(q as usize) {
                *slot = None;
            }
        }
    }
}

/// A candidate merge: patches `a` and `b` (equal for removing a dangling seam) and the edges
/// to remove.
struct Candidate {
    a: u32,
    b: u32,
    edges: Vec<EdgeId>,
    score: f64,
    length: f64,
}

impl<'a> State<'a> {
    fn new(
        mesh: &'a Mesh,
        seam: &EdgeData<bool>,
        singular: &'a VertexData<bool>,
        index: &VertexData<i32>,
        scores: &'a VertexData<f64>,
        field: &FaceData<Vec3>,
        chords: usize,
    ) -> Self {
        let (label, n) = patch_labels(mesh, seam);
        let faces = faces_by_label(&label, n);
        let vertex_areas = mesh.vertex_areas();
        let density =
            mesh.vertices().map(|v| if vertex_areas[v] > 0.0 { scores[v] / vertex_areas[v] } else { 0.0 }).collect();
        Self {
            mesh,
            seam: seam.clone(),
            label,
            faces,
            singular,
            scores,
            density,
            vertex_areas,
            rule: CornerRule::new(mesh, index).with_chords(chords).with_field(field.clone()),
            degree: network::seam_degree(mesh, seam),
            mean_edge: mesh.mean_edge_length(),
            max_extent: f64::INFINITY,
            extents: Default::default(),
            union_extents: Default::default(),
            hints: None,
        }
    }

    /// [`patch_extent`] of patch `p` (cached).
    fn extent(&self, p: u32) -> f64 {
        let mut cache = self.extents.borrow_mut();
        if cache.len() <= p as usize {
            cache.resize(p as usize + 1, None);
        }
        *cache[p as usize].get_or_insert_with(|| patch_extent(self.mesh, &self.faces[p as usize]))
    }

    fn forget_extent(&self, p: u32) {
        if let Some(e) = self.extents.borrow_mut().get_mut(p as usize) {
            *e = None;
        }
        self.union_extents.borrow_mut().retain(|&(a, b), _| a != p && b != p);
    }

    /// The stage's size limits ([`Limits`]) on this state.
    fn limit(&mut self, stage: &Stage) {
        let l = &stage.limits;
        self.max_extent = l.max_extent;
        self.hints = HintMap::new(&l.hints, &stage.face_parent, l.input_faces);
    }

    /// Seam edges grouped by the (sorted) pair of labels on their sides.
    fn interfaces(&self) -> BTreeMap<(u32, u32), Vec<EdgeId>> {
        let mut out: BTreeMap<(u32, u32), Vec<EdgeId>> = BTreeMap::new();
        for e in self.mesh.edges() {
            if !self.seam[e] {
                continue;
            }
            if let (a, Some(b)) = self.mesh.edge_faces(e) {
                let (la, lb) = (self.label[a], self.label[b]);
                out.entry((la.min(lb), la.max(lb))).or_default().push(e);
            }
        }
        out
    }

    /// The faces of patches `a` and `b` (sorted).
    fn union_faces(&self, a: u32, b: u32) -> Vec<FaceId> {
        let mut union: Vec<FaceId> = self.faces[a as usize].clone();
        if a != b {
            union.extend_from_slice(&self.faces[b as usize]);
            union.sort_unstable();
        }
        union
    }

    /// The patches whose merge candidates a merge with union `union` (its faces, before the
    /// merge) can change: those with a face at one of its vertices (their corners, seams and
    /// neighbours there), the union's own two among them.
    fn touched_by(&self, union: &[FaceId]) -> BTreeSet<u32> {
        let mut touched = BTreeSet::new();
        for &f in union {
            for k in 0..3 {
                if let Some(g) = self.mesh.face_neighbor(f, k) {
                    touched.insert(self.label[g]);
                }
            }
            for v in self.mesh.face_vertices(f) {
                for g in self.mesh.vertex_faces(v) {
                    touched.insert(self.label[g]);
                }
            }
        }
        touched
    }

    /// Evaluate removing `edges` between `a` and `b`: the union's topology, its developability
    /// score ([`region_score`]) when `scored` asks for it given the topology (the tiny merges
    /// never use it, the quad merges only for a quad disk), and its faces; None if a
    /// singularity would end up inside (unless `allow_exposing`: the caller then joins it to the
    /// seams again) or the union would be too wide.
    fn evaluate_with(
        &self,
        a: u32,
        b: u32,
        edges: &[EdgeId],
        allow_exposing: bool,
        scored: impl Fn(&RegionInfo) -> bool,
    ) -> Option<(RegionInfo, Option<f64>, Vec<FaceId>)> {
        // Singularities exposed by the removal.
        let mut removed_at: BTreeMap<VertexId, u32> = BTreeMap::new();
        for &e in edges {
            for v in self.mesh.edge_vertices(e) {
                *removed_at.entry(v).or_default() += 1;
            }
        }
        for (&v, &k) in &removed_at {
            if !allow_exposing && self.singular[v] && self.degree[v] <= k && !self.mesh.is_boundary_vertex(v) {
                return None;
            }
        }
        // The two patches measured together before, and unchanged since: too wide, or how wide.
        let pair = (a.min(b), a.max(b));
        let known = self.union_extents.borrow().get(&pair).copied();
        if known.is_some_and(|(limit, extent)| extent > limit) {
            return None;
        }
        let union = self.union_faces(a, b);
        let removed: BTreeSet<EdgeId> = edges.iter().copied().collect();
        let label = |f: FaceId| if self.label[f] == b { a } else { self.label[f] };
        let seam = |e: EdgeId| self.seam[e] && !removed.contains(&e);
        let limit = self.hints.as_ref().and_then(|m| m.target(&union)).unwrap_or(f64::INFINITY).min(self.max_extent);
        // Within the limit without a search when the two extents add up to it (a path between
        // the two runs through a shared vertex); a slit's removal keeps the patch's faces.
        if limit.is_finite() {
            let extent = if a == b {
                self.extent(a)
            } else if self.extent(a) + self.extent(b) <= limit {
                0.0
            } else {
                known.map(|(_, extent)| extent).unwrap_or_else(|| {
                    let extent = patch_extent(self.mesh, &union);
                    self.union_extents.borrow_mut().insert(pair, (limit, extent));
                    extent
                })
            };
            if extent > limit {
                return None;
            }
        }
        let info = region_info(self.mesh, &union, &label, &seam, &self.rule);
        let score = scored(&info).then(|| region_score(self.mesh, &union, &label, &seam, self.scores));
        Some((info, score, union))
    }

    fn apply(&mut self, a: u32, b: u32, edges: &[EdgeId], union: Vec<FaceId>) {
        for &e in edges {
            self.seam[e] = false;
            for v in self.mesh.edge_vertices(e) {
                self.degree[v] -= 1;
            }
        }
        if a != b {
            for &f in &self.faces[b as usize] {
                self.label[f] = a;
            }
            self.faces[b as usize].clear();
            self.forget_extent(b);
        }
        self.faces[a as usize] = union;
        self.forget_extent(a);
    }

    /// Dangling seam edges inside patch `a`: seam edges with the same patch on both sides
    /// forming chains that end at a seam-degree-1 vertex (slits), as groups of edges.
    fn slits(&self) -> Vec<(u32, Vec<EdgeId>)> {
        let mut out = Vec::new();
        let none = VertexData::filled(self.mesh.n_vertices(), false);
        let chains = network::chains(self.mesh, &self.seam, &none);
        for c in chains {
            let (first, last) = (c[0], *c.last().expect("chains have two vertices"));
            let dangling = |v: VertexId| self.degree[v] == 1 && !self.mesh.is_boundary_vertex(v);
            if !dangling(first) && !dangling(last) {
                continue;
            }
            let edges: Vec<EdgeId> = c.windows(2).filter_map(|w| edge_between(self.mesh, w[0], w[1])).collect();
            let (fa, fb) = self.mesh.edge_faces(edges[0]);
            let Some(fb) = fb else { continue };
            if self.label[fa] == self.label[fb] {
                out.push((self.label[fa], edges));
            }
        }
        out
    }

    /// Greedy merges into quads; returns the number of merges. With `fix_only`, only merges that
    /// do not lower the number of quads (at least one of the two patches is not a quad).
    fn merge_quads(&mut self, max_dev: f64, fix_only: bool) -> usize {
        let mut merges = 0;
        // Cache of evaluated pairs: (a, b) → candidate if acceptable.
        let mut cache: BTreeMap<(u32, u32), Option<Candidate>> = BTreeMap::new();
        // The patches' measures, forgotten with the pairs a merge touches.
        let mut infos = InfoCache::default();
        loop {
            let interfaces = self.interfaces();
            let mut pairs: Vec<((u32, u32), Vec<EdgeId>)> = interfaces.into_iter().collect();
            for (a, edges) in self.slits() {
                pairs.push(((a, a), edges));
            }
            let mut best: Option<Candidate> = None;
            for ((a, b), edges) in pairs {
                let key = (a, b);
                let cand = match cache.get(&key) {
                    Some(c) if c.as_ref().is_none_or(|c| c.edges == edges) => {
                        c.as_ref().map(|c| Candidate { a, b, edges: c.edges.clone(), score: c.score, length: c.length })
                    }
                    // Merging two quads fixes no corners: not worth measuring the union.
                    _ if fix_only && self.all_quads(a, b, &mut infos) => {
                        cache.insert(key, None);
                        None
                    }
                    _ => {
                        // Scored only when the union is a quad disk: the score's absence says it is not.
                        let quad_disk = |info: &RegionInfo| info.is_disk() && info.corners.len() == 4;
                        let c = self.evaluate_with(a, b, &edges, false, quad_disk).and_then(|(_, score, _)| {
                            let score = score?;
                            (score <= max_dev && (!fix_only || self.merge_fixes_corners(a, b, &edges, &mut infos)))
                                .then(|| Candidate {
                                    a,
                                    b,
                                    length: edges.iter().map(|&e| self.mesh.edge_length(e)).sum(),
                                    edges: edges.clone(),
                                    score,
                                })
                        });
                        cache.insert(
                            key,
                            c.as_ref().map(|c| Candidate {
                                a,
                                b,
                                edges: c.edges.clone(),
                                score: c.score,
                                length: c.length,
                            }),
                        );
                        c
                    }
                };
                if let Some(c) = cand {
                    let better = match &best {
                        None => true,
                        Some(bst) => c.score < bst.score || (c.score == bst.score && c.length > bst.length),
                    };
                    if better {
                        best = Some(c);
                    }
                }
            }
            let Some(c) = best else { break };
            // The patches beside the removed seam may have changed since the candidate was
            // cached (their own neighbours merged): check again.
            if fix_only && !self.merge_fixes_corners(c.a, c.b, &c.edges, &mut infos) {
                cache.insert((c.a, c.b), None);
                continue;
            }
            let union = self.union_faces(c.a, c.b);
            // Invalidate pairs touching the merged patches and their neighbours.
            let touched = self.touched_by(&union);
            self.apply(c.a, c.b, &c.edges, union);
            cache.retain(|&(x, y), _| !touched.contains(&x) && !touched.contains(&y));
            infos.forget(&touched);
            merges += 1;
        }
        merges
    }

    /// Whether merging `b` into `a` across `edges` (the union a quad) helps the layout: the
    /// patches at the removed seam (the two, and the others whose corners the removal changes)
    /// keep at least as many quads and get no further from four corners in total, and at least
    /// one of the two was not a quad. `infos` keeps the patches' measures.
    fn merge_fixes_corners(&self, a: u32, b: u32, edges: &[EdgeId], infos: &mut InfoCache) -> bool {
        let mesh = self.mesh;
        let removed: BTreeSet<EdgeId> = edges.iter().copied().collect();
        let others: BTreeSet<u32> = edges
            .iter()
            .flat_map(|&e| mesh.edge_vertices(e))
            .flat_map(|v| mesh.vertex_faces(v))
            .map(|f| self.label[f])
            .filter(|&q| q != a && q != b)
            .collect();
        let label = |f: FaceId| if self.label[f] == b { a } else { self.label[f] };
        let seam = |e: EdgeId| self.seam[e] && !removed.contains(&e);
        if self.all_quads(a, b, infos) {
            return false;
        }
        let mut counts_before: Vec<usize> = vec![infos.get(self, a).corners.len()];
        if a != b {
            counts_before.push(infos.get(self, b).corners.len());
        }
        let mut counts_after: Vec<usize> = vec![4];
        for &q in &others {
            counts_before.push(infos.get(self, q).corners.len());
            counts_after.push(region_info(mesh, &self.faces[q as usize], &label, &seam, &self.rule).corners.len());
        }
        let quads = |c: &[usize]| c.iter().filter(|&&k| k == 4).count();
        let bad = |c: &[usize]| c.iter().map(|&k| k.abs_diff(4)).sum::<usize>();
        quads(&counts_after) >= quads(&counts_before) && bad(&counts_after) <= bad(&counts_before)
    }

    /// The patches whose [`Self::info_of`] can differ from what it was under `label` and `seam`
    /// (this state's earlier labels and seams): those that gained or lost a face, and those with
    /// a face at a vertex of a relabelled face or of an edge whose seam flag changed (a region's
    /// measure reads only the labels and seams at its own vertices).
    fn touched_since(&self, label: &FaceData<u32>, seam: &EdgeData<bool>) -> BTreeSet<u32> {
        let mesh = self.mesh;
        let mut out = BTreeSet::new();
        let mut at: Vec<VertexId> = Vec::new();
        for f in mesh.face_ids() {
            if label[f] != self.label[f] {
                out.insert(label[f]);
                out.insert(self.label[f]);
                at.extend(mesh.face_vertices(f));
            }
        }
        for e in mesh.edges() {
            if seam[e] != self.seam[e] {
                at.extend(mesh.edge_vertices(e));
            }
        }
        for v in at {
            out.extend(mesh.vertex_faces(v).map(|g| self.label[g]));
        }
        out
    }

    /// Whether patches `a` and `b` (equal for a dangling seam) are both quads.
    fn all_quads(&self, a: u32, b: u32, infos: &mut InfoCache) -> bool {
        infos.get(self, a).corners.len() == 4 && (a == b || infos.get(self, b).corners.len() == 4)
    }

    /// Split non-quad patches at their concave corners (an angle of three quarter turns, an
    /// L-shaped patch): trace from the corner along a field arm pointing into the patch until the
    /// patch boundary (Pietroni et al. 2016 complete their layouts the same way). Returns the
    /// number of splits; see [`Self::split_from`] for when a split is kept.
    fn split_concave(&mut self, vf: &VertexField, trace: &TraceOptions, max_splits: usize) -> usize {
        self.split_from(vf, trace, max_splits, |info| {
            info.candidates.iter().filter(|&&(_, q)| q >= CONCAVE_QUARTERS).map(|&(v, _)| v).collect()
        })
    }

    /// Seams to the `tips` that lie inside a patch, in the order listed: with `darts`, a seam
    /// from the patch's boundary ending at the tip ([`dart_path`]), the patch kept whole;
    /// otherwise a cut through the tip into two patches ([`split_through`]; a side may come out
    /// tiny, a tip near its patch's boundary: a small piece to sew is better than fabric cut far
    /// too small). Returns the seams made.
    fn cone_seams(&mut self, tips: &[VertexId], darts: bool, vf: &VertexField, trace: &TraceOptions) -> usize {
        let mut made = 0;
        for &tip in tips {
            let Some(h) = self.mesh.outgoing(tip).next() else { continue };
            let p = self.label[self.mesh.face(h)];
            let label = |f: FaceId| self.label[f];
            let seam = |e: EdgeId| self.seam[e];
            let faces = &self.faces[p as usize];
            if darts {
                let Some(path) = dart_path(self.mesh, faces, &label, &seam, tip, vf, trace) else {
                    tracing::debug!(tip = tip.idx(), patch = p, "no dart to the tip");
                    continue;
                };
                for w in path.windows(2) {
                    if let Some(e) = edge_between(self.mesh, w[0], w[1]) {
                        self.seam[e] = true;
                    }
                }
            } else {
                let Some(split) =
                    split_through(self.mesh, faces, &label, &seam, tip, vf, trace, &self.rule, CONE_MIN_SIDE)
                else {
                    tracing::debug!(tip = tip.idx(), patch = p, "no cut through the tip");
                    continue;
                };
                self.apply_split(p, split.a, split.b);
            }
            made += 1;
        }
        made
    }

    /// Split non-quad patches from their corners (convex ones too, where
    /// [`Self::split_concave`] only starts at concave ones): a field-aligned trace from a
    /// corner into the patch until its boundary, where the new seam ends in a T-junction.
    /// Returns the number of splits.
    fn split_to_quads(&mut self, vf: &VertexField, trace: &TraceOptions, max_splits: usize) -> usize {
        self.split_from(vf, trace, max_splits, |info| info.corners.clone())
    }

    /// Split non-quad patches by field-aligned traces from the boundary vertices `starts` picks
    /// out of each patch's [`RegionInfo`], one split at a time, until none is accepted or
    /// `max_splits` is reached. A split is kept when both sides are disks and the total distance
    /// from four corners, Σ |corners − 4| over the split patch and the patches at the new seam's
    /// ends (counted again: a T-junction gives the patch across it a corner only where its side
    /// bends, see [`crate::patches`]), decreases. Returns the number of splits.
    fn split_from(
        &mut self,
        vf: &VertexField,
        trace: &TraceOptions,
        max_splits: usize,
        starts: impl Fn(&RegionInfo) -> Vec<VertexId>,
    ) -> usize {
        self.repair_non_quads(max_splits, starts, |state, p, v, info| {
            match state.best_corner_split(p, v, info.corners.len().abs_diff(4), vf, trace) {
                Some((a, b)) => {
                    state.apply_split(p, a, b);
                    true
                }
                None => false,
            }
        })
    }

    /// Repairs of non-quad patches, one at a time until none is found or `max` are made: for
    /// each patch that is not a quad and each boundary vertex `starts` picks from its
    /// [`RegionInfo`], `repair(self, p, v, info)` makes one (true) or not (false: that patch
    /// and vertex are not tried again). Returns the repairs made.
    fn repair_non_quads(
        &mut self,
        max: usize,
        starts: impl Fn(&RegionInfo) -> Vec<VertexId>,
        mut repair: impl FnMut(&mut Self, u32, VertexId, &RegionInfo) -> bool,
    ) -> usize {
        let mut done = 0;
        let mut failed: BTreeSet<(u32, VertexId)> = BTreeSet::new();
        // Each patch's measure, kept until a repair changes the labels or seams at its vertices.
        let mut infos = InfoCache::default();
        'outer: while done < max {
            let (label, seam) = (self.label.clone(), self.seam.clone());
            for p in 0..self.faces.len() as u32 {
                if self.faces[p as usize].is_empty() {
                    continue;
                }
                let info = infos.get(self, p).clone();
                if info.corners.len() == 4 {
                    continue;
                }
                for v in starts(&info) {
                    if failed.contains(&(p, v)) {
                        continue;
                    }
                    if repair(self, p, v, &info) {
                        done += 1;
                        infos.forget(&self.touched_since(&label, &seam));
                        continue 'outer;
                    }
                    failed.insert((p, v));
                }
            }
            break;
        }
        done
    }

    /// Repair cusps: where a non-quad patch `p` has a wedge of (almost) zero quarter turns at an
    /// interior junction — two seams leaving along the same field arm, a thin spike of `p`
    /// between them — cut the spike off across, from a vertex of one of the two seams to a
    /// vertex of the other (up to and including their next nodes), and give it to the patch
    /// across one of them, so that those two seams become one. A repair is kept when
    /// Σ |corners − 4| over the patches around drops, all stay disks, no singularity loses its
    /// last seam and the spike is at most half of `p`; the cut is a shortest path through `p`'s
    /// interior (the straightening then makes it a geodesic). Of the cuts with the largest
    /// drop, `aligned` takes the one closest to the field (its ends at least [`ZIP_MIN_WIDTH`]
    /// mean edge lengths apart), else the one with the smallest spike. Returns the repairs, at most
    /// `max`.
    fn zip_cusps(&mut self, max: usize, aligned: bool) -> usize {
        let mesh = self.mesh;
        let cusps = |info: &RegionInfo| {
            let cusp = |&&(v, q): &&(VertexId, f64)| q < CUSP_QUARTERS && !mesh.is_boundary_vertex(v);
            info.candidates.iter().filter(cusp).map(|&(v, _)| v).collect()
        };
        self.repair_non_quads(max, cusps, |state, p, v, info| match state.best_zip(p, v, info, aligned) {
            Some((spike, to, cut)) => {
                state.apply_zip(p, to, &spike, &cut);
                true
            }
            None => false,
        })
    }

    /// Whether edge `e` is a seam once the faces are relabelled by `after` and the `cut` edges
    /// added: where the two labels differ (a mesh-boundary edge always); a slit (a seam between
    /// faces of one patch, before and after) stays as it is.
    fn seam_after(&self, e: EdgeId, after: &impl Fn(FaceId) -> u32, cut: &BTreeSet<EdgeId>) -> bool {
        match self.mesh.edge_faces(e) {
            (_, None) => true,
            (f0, Some(f1)) => {
                let slit = self.label[f0] == self.label[f1] && after(f0) == after(f1) && !cut.contains(&e);
                if slit { self.seam[e] } else { after(f0) != after(f1) }
            }
        }
    }

    /// Is edge `e` a cut under the current labels and seams?
    fn is_cut(&self, e: EdgeId) -> bool {
        crate::patches::is_cut_edge(self.mesh, e, &|f| self.label[f], &|e| self.seam[e])
    }

    /// The best cusp repair of patch `p` (topology and corners `info`) at `v`
    /// ([`Self::zip_cusps`]): the spike's faces, the patch that receives them and the cut edges.
    fn best_zip(&self, p: u32, v: VertexId, info: &RegionInfo, aligned: bool) -> Option<Zip> {
        let mesh = self.mesh;
        let angles = &self.rule.angles;
        let in_p = |f: FaceId| self.label[f] == p;
        // The wedge of p at v with the smallest angle: incoming boundary halfedge h (p on its
        // left), outgoing g.
        let mut wedge: Option<(f64, HalfedgeId, HalfedgeId)> = None;
        for h0 in mesh.outgoing(v) {
            let Some(h) = mesh.twin(h0).filter(|&h| in_p(mesh.face(h))) else { continue };
            if !self.is_cut(mesh.edge(h)) {
                continue;
            }
            let mut g = mesh.next(h);
            let mut angle = angles[g];
            while !self.is_cut(mesh.edge(g)) {
                g = mesh.next(mesh.twin(g)?);
                angle += angles[g];
            }
            if wedge.is_none_or(|(a, _, _)| angle < a) {
                wedge = Some((angle, h, g));
            }
        }
        let (_, h, g) = wedge?;
        // The two arms as vertex lists from v to the next corner candidate of p: along p's
        // boundary backwards from h, forwards from g.
        let nodes: BTreeSet<VertexId> = info.candidates.iter().map(|&(u, _)| u).collect();
        let arm = |start: HalfedgeId, forward: bool| -> Option<Vec<VertexId>> {
            let mut out = vec![v];
            let mut k = start;
            loop {
                let u = if forward { mesh.head(k) } else { mesh.tail(k) };
                out.push(u);
                if u == v {
                    // Around the whole patch without meeting a node.
                    return None;
                }
                if nodes.contains(&u) {
                    return Some(out);
                }
                let step = |x: HalfedgeId| if forward { mesh.next(x) } else { mesh.prev(x) };
                k = step(k);
                while !self.is_cut(mesh.edge(k)) {
                    k = step(mesh.twin(k)?);
                }
            }
        };
        let (arm_a, arm_b) = (arm(h, false)?, arm(g, true)?);
        let across = |k: HalfedgeId| mesh.twin(k).map(|t| self.label[mesh.face(t)]);
        let (qa, qb) = (across(h), across(g));
        let spike_face = mesh.face(g);
        // Vertices a cut may pass: all faces in p, on no cut edge.
        let interior = |u: VertexId| mesh.outgoing(u).all(|k| in_p(mesh.face(k)) && !self.is_cut(mesh.edge(k)));
        let pos = |u: VertexId| mesh.position(u);
        let nearest = |u: VertexId, arm: &[VertexId]| {
            arm[1..].iter().copied().min_by(|x, y| (pos(*x) - pos(u)).norm().total_cmp(&(pos(*y) - pos(u)).norm()))
        };
        let mut pairs: BTreeSet<(VertexId, VertexId)> = BTreeSet::new();
        let sample =
            |n: usize| -> Vec<usize> { (1..n).step_by(((n - 1) / ZIP_SAMPLES).max(1)).chain([n - 1]).collect() };
        for i in sample(arm_a.len()) {
            pairs.extend(nearest(arm_a[i], &arm_b).map(|b| (arm_a[i], b)));
        }
        for j in sample(arm_b.len()) {
            pairs.extend(nearest(arm_b[j], &arm_a).map(|a| (a, arm_b[j])));
        }
        pairs.insert((*arm_a.last()?, *arm_b.last()?));
        let faces = &self.faces[p as usize];
        let mut bad_now: BTreeMap<u32, usize> = BTreeMap::new();
        // (drop of Σ |corners − 4|, tie-break key, the repair)
        let mut best: Option<(usize, f64, Zip)> = None;
        let min_width = if aligned { ZIP_MIN_WIDTH * self.mean_edge } else { 0.0 };
        let p_area: f64 = faces.iter().map(|&f| mesh.face_area(f)).sum();
        let field = self.rule.field.as_ref()?;
        for (a, b) in pairs {
            if a == b || (pos(a) - pos(b)).norm() < min_width {
                continue;
            }
            let Some(path) = shortest_edge_path(mesh, a, b, &interior) else { continue };
            let cut: BTreeSet<EdgeId> = path.windows(2).filter_map(|w| edge_between(mesh, w[0], w[1])).collect();
            let Some((s1, s2)) = self.two_sides(faces, &cut) else { continue };
            let (spike, rest) = if s1.binary_search(&spike_face).is_ok() { (s1, s2) } else { (s2, s1) };
            let spike_area: f64 = spike.iter().map(|&f| mesh.face_area(f)).sum();
            if spike_area > 0.5 * p_area {
                continue;
            }
            // The tie-break: the cut's deviation from the field (its chord against the arms of
            // the faces along it, mean), else the spike's area.
            let key = if aligned {
                let chord = pos(b) - pos(a);
                let along: BTreeSet<FaceId> =
                    path.iter().flat_map(|&u| mesh.vertex_faces(u)).filter(|&f| in_p(f)).collect();
                let angles: Vec<f64> = along
                    .iter()
                    .filter_map(|&f| {
                        let n = mesh.face_normal(f);
                        let t = chord - n * n.dot(&chord);
                        let t = (t.norm() > 1e-12 * chord.norm()).then(|| t.normalize())?;
                        let (x, y) = (field[f], n.cross(&field[f]));
                        Some(x.dot(&t).abs().max(y.dot(&t).abs()).clamp(0.0, 1.0).acos())
                    })
                    .collect();
                angles.iter().sum::<f64>() / angles.len().max(1) as f64
            } else {
                spike_area
            };
            for to in [qa, qb].into_iter().flatten() {
                if to == p {
                    continue;
                }
                let label = |f: FaceId| if spike.binary_search(&f).is_ok() { to } else { self.label[f] };
                let seam_after = |e: EdgeId| self.seam_after(e, &label, &cut);
                // No singularity may lose its last seam edge (the seams between the spike and
                // `to` go away, the cut comes in).
                let mut degree: BTreeMap<VertexId, i64> = BTreeMap::new();
                for (e, now) in self.zip_changes(&spike, to, &cut) {
                    for u in mesh.edge_vertices(e).into_iter().filter(|&u| self.singular[u]) {
                        *degree.entry(u).or_insert(i64::from(self.degree[u])) += if now { 1 } else { -1 };
                    }
                }
                if degree.iter().any(|(&u, &d)| d <= 0 && !mesh.is_boundary_vertex(u)) {
                    continue;
                }
                let mut grown = self.faces[to as usize].clone();
                grown.extend_from_slice(&spike);
                grown.sort_unstable();
                let around: BTreeSet<u32> = [v, a, b]
                    .iter()
                    .flat_map(|&u| mesh.vertex_faces(u))
                    .map(|f| self.label[f])
                    .chain([p, to])
                    .collect();
                let changed = [(p, &rest[..]), (to, &grown[..])];
                // Ties go to the smaller key.
                let least = least_to_beat(best.as_ref().map(|(bg, bk, _)| (*bg, key < *bk)));
                let Some(gain) =
                    self.corner_gain(&around, &changed, &label, &seam_after, &mut bad_now, (0, 0), least, true)
                else {
                    continue;
                };
                best = Some((gain, key, (spike.clone(), to, cut.clone())));
            }
        }
        best.map(|(_, _, zip)| zip)
    }

    /// The seam changes of handing `spike` (sorted faces of one patch) to patch `to` with the
    /// `cut` edges added ([`Self::seam_after`]): every interior edge whose state changes, and
    /// whether it is a seam then.
    fn zip_changes(&self, spike: &[FaceId], to: u32, cut: &BTreeSet<EdgeId>) -> Vec<(EdgeId, bool)> {
        let mesh = self.mesh;
        let after = |f: FaceId| if spike.binary_search(&f).is_ok() { to } else { self.label[f] };
        let mut touched: BTreeSet<EdgeId> = cut.clone();
        touched.extend(spike.iter().flat_map(|&f| (0..3).map(move |k| mesh.edge(mesh.face_halfedge(f, k)))));
        touched
            .into_iter()
            .filter(|&e| !mesh.is_boundary_edge(e))
            .filter_map(|e| {
                let want = self.seam_after(e, &after, cut);
                (want != self.seam[e]).then_some((e, want))
            })
            .collect()
    }

    /// The drop in Σ |corners − 4| over the patches `ids` from as they are (cached in `now`) to
    /// under the labelling `label` with seams `seam`, the faces of the patches in `changed`
    /// replaced, `extra` = (before, after) added to the two sums; None when the drop is below
    /// `least` or, with `disks`, a patch would not be a disk. The patches of `changed` are
    /// measured first, and the measuring stops once the drop cannot reach `least` (the sums
    /// only grow), so a candidate that cannot win costs fewer measurements.
    #[allow(clippy::too_many_arguments)]
    fn corner_gain(
        &self,
        ids: &BTreeSet<u32>,
        changed: &[(u32, &[FaceId])],
        label: &impl Fn(FaceId) -> u32,
        seam: &impl Fn(EdgeId) -> bool,
        now: &mut BTreeMap<u32, usize>,
        extra: (usize, usize),
        least: usize,
        disks: bool,
    ) -> Option<usize> {
        let (mut before, mut after) = extra;
        for &r in ids {
            before += *now.entry(r).or_insert_with(|| self.info_of(r).corners.len().abs_diff(4));
        }
        let is_changed = |r: &u32| changed.iter().any(|(q, _)| q == r);
        for &r in ids.iter().filter(|r| is_changed(r)).chain(ids.iter().filter(|r| !is_changed(r))) {
            if after + least > before {
                return None;
            }
            let faces = changed.iter().find(|(q, _)| *q == r).map_or(&self.faces[r as usize][..], |&(_, f)| f);
            let info = region_info(self.mesh, faces, label, seam, &self.rule);
            if disks && !info.is_disk() {
                return None;
            }
            after += info.corners.len().abs_diff(4);
        }
        (after + least <= before).then(|| before - after)
    }

    /// Give the `spike` faces of `p` to patch `to`, the `cut` edges becoming seams and the
    /// seams between the spike and `to` going away.
    fn apply_zip(&mut self, p: u32, to: u32, spike: &[FaceId], cut: &BTreeSet<EdgeId>) {
        let mesh = self.mesh;
        for (e, want) in self.zip_changes(spike, to, cut) {
            self.seam[e] = want;
            for u in mesh.edge_vertices(e) {
                if want {
                    self.degree[u] += 1;
                } else {
                    self.degree[u] -= 1;
                }
            }
        }
        for &f in spike {
            self.label[f] = to;
        }
        self.faces[p as usize].retain(|f| spike.binary_search(f).is_err());
        self.faces[to as usize].extend_from_slice(spike);
        self.faces[to as usize].sort_unstable();
        self.forget_extent(p);
        self.forget_extent(to);
    }

    /// Topology and corners of patch `p` under the current labels and seams.
    fn info_of(&self, p: u32) -> RegionInfo {
        let label = |f: FaceId| self.label[f];
        let seam = |e: EdgeId| self.seam[e];
        region_info(self.mesh, &self.faces[p as usize], &label, &seam, &self.rule)
    }

    /// The best field-aligned split of patch `p` from its corner or concave point `v`, as the
    /// two sides: traced into the patch along a field arm until the patch boundary. `bad` is the
    /// patch's Σ |corners − 4|; a split must lower that sum over both sides and the patches that
    /// meet the new seam's ends (counted again with the new seam).
    fn best_corner_split(
        &self,
        p: u32,
        v: VertexId,
        bad: usize,
        vf: &VertexField,
        trace: &TraceOptions,
    ) -> Option<(Vec<FaceId>, Vec<FaceId>)> {
        let mesh = self.mesh;
        let faces = &self.faces[p as usize];
        let field = self.rule.field.as_ref()?;
        let in_p = |f: FaceId| self.label[f] == p;
        let on_boundary = |u: VertexId| {
            mesh.is_boundary_vertex(u) || mesh.outgoing(u).any(|h| self.seam[mesh.edge(h)] || !in_p(mesh.face(h)))
        };
        // Arms of the faces at v that point into the patch, away from its boundary edges at v.
        let boundary_dirs: Vec<Vec3> = mesh
            .outgoing(v)
            .filter(|&h| {
                let e = mesh.edge(h);
                self.seam[e]
                    || mesh.is_boundary_edge(e)
                    || mesh.edge_faces(e).1.is_some_and(|g| in_p(g) != in_p(mesh.edge_faces(e).0))
            })
            .map(|h| mesh.vector(h).normalize())
            .collect();
        let mut dirs: Vec<Vec3> = Vec::new();
        for h in mesh.outgoing(v) {
            let f = mesh.face(h);
            if !in_p(f) {
                continue;
            }
            let n = mesh.face_normal(f);
            let e1 = mesh.vector(h);
            let e2 = mesh.position(mesh.opposite_vertex(h)) - mesh.position(v);
            let corner = e1.angle(&e2);
            let a = field[f] - n * n.dot(&field[f]);
            if a.norm() <= 0.0 {
                continue;
            }
            let a = a.normalize();
            let b = n.cross(&a);
            for d in [a, b, -a, -b] {
                let inside = (e1.angle(&d) + d.angle(&e2) - corner).abs() < 1e-9;
                let clear = boundary_dirs.iter().all(|bd| bd.angle(&d) > 30f64.to_radians());
                if inside && clear && dirs.iter().all(|x| x.angle(&d) > 20f64.to_radians()) {
                    dirs.push(d);
                }
            }
        }
        let neighbours: BTreeSet<VertexId> = mesh.vertex_neighbors(v).into_iter().collect();
        // Σ |corners − 4| of the other patches as they are, computed once per patch.
        let mut bad_now: BTreeMap<u32, usize> = BTreeMap::new();
        let mut best: Option<(usize, f64, Vec<FaceId>, Vec<FaceId>)> = None;
        for d in dirs {
            let (k, _) = vf.best_arm(v, &d);
            let target = |u: VertexId| on_boundary(u) && !neighbours.contains(&u);
            // The patch's interior, and of its boundary only targets (not the start's
            // neighbours). The search may still pass through a target it reached at a shallow
            // angle; such a path is refused below. (Not passing through them at all, in
            // `field_path`, was measured as a wash: camelhead 0.68 → 0.65 and fertility 0.70 →
            // 0.67 at seeds 1 and 2, fertility 0.76 → 0.79 and camelhead 0.79 → 0.86 at seed 3.)
            let allowed = |u: VertexId| {
                let touches = mesh.vertex_faces(u).any(&in_p);
                touches && (if on_boundary(u) { target(u) } else { !self.singular[u] })
            };
            let seam_at = |u: VertexId, w: VertexId| {
                edge_between(mesh, u, w).is_some_and(|e| self.seam[e] || mesh.is_boundary_edge(e))
            };
            let Some(path) = field_path(mesh, vf, v, k, Some(d), trace, &allowed, &target, &seam_at) else { continue };
            // The first step must enter the patch through its interior.
            let Some(e0) = edge_between(mesh, path[0], path[1]) else { continue };
            let interior_first = !self.seam[e0] && matches!(mesh.edge_faces(e0), (f, Some(g)) if in_p(f) && in_p(g));
            if !interior_first || path[1..path.len() - 1].iter().any(|&u| on_boundary(u)) {
                continue;
            }
            let cut: BTreeSet<EdgeId> = path.windows(2).filter_map(|w| edge_between(mesh, w[0], w[1])).collect();
            let Some((a, b)) = self.two_sides(faces, &cut) else { continue };
            let label = |f: FaceId| {
                if self.label[f] != p {
                    self.label[f]
                } else if a.binary_search(&f).is_ok() {
                    u32::MAX
                } else {
                    u32::MAX - 1
                }
            };
            let seam = |e: EdgeId| self.seam[e] || cut.contains(&e);
            let ia = region_info(mesh, &a, &label, &seam, &self.rule);
            let ib = region_info(mesh, &b, &label, &seam, &self.rule);
            if !ia.is_disk() || !ib.is_disk() {
                continue;
            }
            // The other patches at the new seam's ends, counted again with the new seam.
            let ends = [path[0], *path.last().expect("paths have two vertices")];
            let others: BTreeSet<u32> =
                ends.iter().flat_map(|&u| mesh.vertex_faces(u)).map(|f| self.label[f]).filter(|&q| q != p).collect();
            let len: f64 = path.windows(2).map(|w| (mesh.position(w[1]) - mesh.position(w[0])).norm()).sum();
            // Ties go to the shorter seam.
            let least = least_to_beat(best.as_ref().map(|(bg, bl, _, _)| (*bg, len < *bl)));
            let sides = ia.corners.len().abs_diff(4) + ib.corners.len().abs_diff(4);
            let Some(gain) = self.corner_gain(&others, &[], &label, &seam, &mut bad_now, (bad, sides), least, false)
            else {
                continue;
            };
            best = Some((gain, len, a, b));
        }
        best.map(|(_, _, a, b)| (a, b))
    }

    /// The faces of a patch split by extra cut edges, if they fall in exactly two parts.
    fn two_sides(&self, faces: &[FaceId], cut: &BTreeSet<EdgeId>) -> Option<(Vec<FaceId>, Vec<FaceId>)> {
        two_sides(self.mesh, faces, &|e| self.seam[e] || cut.contains(&e))
    }

    /// Split patch `p` into sides `a` (keeps the label) and `b` (a new label), making the edges
    /// between them seams.
    fn apply_split(&mut self, p: u32, a: Vec<FaceId>, b: Vec<FaceId>) {
        let new = self.faces.len() as u32;
        for &f in &b {
            self.label[f] = new;
        }
        for &f in &a {
            for k in 0..3 {
                let h = self.mesh.face_halfedge(f, k);
                if let Some(t) = self.mesh.twin(h)
                    && self.label[self.mesh.face(t)] == new
                {
                    let e = self.mesh.edge(h);
                    if !self.seam[e] {
                        self.seam[e] = true;
                        for v in self.mesh.edge_vertices(e) {
                            self.degree[v] += 1;
                        }
                    }
                }
            }
        }
        self.faces[p as usize] = a;
        self.faces.push(b);
        self.forget_extent(p);
    }

    /// Merge patches smaller than `min_area` into their neighbours; returns the merges.
    /// Merge patches below `min_area` into a neighbour. A merge that would leave a singularity
    /// inside the union is tried last, and the singularity is then joined to the seams by a
    /// field-aligned cut (a slit into the merged patch, which stays a disk).
    fn merge_tiny(&mut self, min_area: f64, dirs: &FaceData<Vec3>, drift: f64, phi_max: f64) -> usize {
        let merges = self.merge_tiny_with(min_area, false);
        let exposing = self.merge_tiny_with(min_area, true);
        if exposing > 0 {
            let mut seam = self.seam.clone();
            cutgraph::attach_isolated(self.mesh, dirs, &mut seam, self.singular, drift, phi_max);
            for e in self.mesh.edges() {
                if seam[e] && !self.seam[e] {
                    self.seam[e] = true;
                    for v in self.mesh.edge_vertices(e) {
                        self.degree[v] += 1;
                    }
                }
            }
        }
        merges + exposing
    }

    fn merge_tiny_with(&mut self, min_area: f64, allow_exposing: bool) -> usize {
        let mut merges = 0;
        // Merges refused (keep, gone, edges), until a merge touches one of the two patches
        // ([`Self::touched_by`]): each merge restarts the search, which would otherwise ask
        // again about every tiny patch that could not merge.
        let mut refused: BTreeSet<(u32, u32, Vec<EdgeId>)> = BTreeSet::new();
        loop {
            let area = |fs: &[FaceId]| fs.iter().map(|&f| self.mesh.face_area(f)).sum::<f64>();
            let interfaces = self.interfaces();
            let mut done = false;
            let mut tiny: Vec<(f64, u32)> = (0..self.faces.len() as u32)
                .filter(|&p| !self.faces[p as usize].is_empty())
                .map(|p| (area(&self.faces[p as usize]), p))
                .filter(|&(a, _)| a < min_area)
                .collect();
            tiny.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            for (_, t) in tiny {
                // Each neighbour across all shared seams, then across each connected piece of
                // them alone (the others stay as seams inside the union).
                let length = |edges: &[EdgeId]| edges.iter().map(|&e| self.mesh.edge_length(e)).sum::<f64>();
                let mut options: Vec<(u8, f64, u32, u32, Vec<EdgeId>)> = Vec::new();
                for (&(a, b), edges) in &interfaces {
                    if a == b || (a != t && b != t) {
                        continue;
                    }
                    options.push((0, length(edges), a, b, edges.clone()));
                    let pieces = edge_components(self.mesh, edges);
                    if pieces.len() > 1 {
                        for piece in pieces {
                            options.push((1, length(&piece), a, b, piece));
                        }
                    }
                }
                options.sort_by(|x, y| x.0.cmp(&y.0).then(y.1.total_cmp(&x.1)).then(x.2.cmp(&y.2)).then(x.3.cmp(&y.3)));
                for (_, _, a, b, edges) in options {
                    // Keep the neighbour's label.
                    let (keep, gone) = if a == t { (b, a) } else { (a, b) };
                    let key = (keep, gone, edges);
                    if refused.contains(&key) {
                        continue;
                    }
                    let edges = &key.2;
                    if let Some((info, _, union)) = self.evaluate_with(keep, gone, edges, allow_exposing, |_| false)
                        && info.is_disk()
                    {
                        let touched = self.touched_by(&union);
                        refused.retain(|(x, y, _)| !touched.contains(x) && !touched.contains(y));
                        self.apply(keep, gone, edges, union);
                        merges += 1;
                        done = true;
                        break;
                    }
                    refused.insert(key);
                }
                if done {
                    break;
                }
            }
            if !done {
                break;
            }
        }
        merges
    }

    /// Split patches above `max_dev` in two, recursively; returns the number of splits.
    fn split_non_developable(
        &mut self,
        max_dev: f64,
        max_splits: usize,
        vf: &VertexField,
        trace: &TraceOptions,
    ) -> Result<usize, LayoutError> {
        if !max_dev.is_finite() {
            return Ok(0);
        }
        self.split_worst(max_dev, max_splits, vf, trace, |state, p| {
            let label = |f: FaceId| state.label[f];
            let seam = |e: EdgeId| state.seam[e];
            region_score(state.mesh, &state.faces[p as usize], &label, &seam, state.scores)
        })
    }

    /// Split patches wider than the state's `max_extent` ([`patch_extent`]), widest first, so
    /// that every piece fits the fabric roll; returns the splits.
    fn split_oversized(
        &mut self,
        max_splits: usize,
        vf: &VertexField,
        trace: &TraceOptions,
    ) -> Result<usize, LayoutError> {
        if !self.max_extent.is_finite() {
            return Ok(0);
        }
        self.split_worst(self.max_extent, max_splits, vf, trace, |state, p| state.extent(p))
    }

    /// Split the patches a hint applies to ([`SplitHint`]) until each is within its extent;
    /// returns the splits.
    fn split_hinted(
        &mut self,
        max_splits: usize,
        vf: &VertexField,
        trace: &TraceOptions,
    ) -> Result<usize, LayoutError> {
        if self.hints.is_none() {
            return Ok(0);
        }
        self.split_worst(0.0, max_splits, vf, trace, |state, p| {
            let fs = &state.faces[p as usize];
            match state.hints.as_ref().and_then(|m| m.target(fs)) {
                Some(t) => state.extent(p) / t.max(f64::MIN_POSITIVE) - 1.0,
                None => f64::NEG_INFINITY,
            }
        })
    }

    /// Split the patch with the largest `measure` above `threshold` in two disks (spectral
    /// clustering, the seam traced along the field), until none is above it, up to
    /// `max_splits`; a patch that cannot be split is left. `measure` may depend on a patch's
    /// faces and on the labels and seams at them, not on other patches': a split changes only
    /// its own patch's, so the others keep their measure from one split to the next.
    fn split_worst(
        &mut self,
        threshold: f64,
        max_splits: usize,
        vf: &VertexField,
        trace: &TraceOptions,
        measure: impl Fn(&Self, u32) -> f64,
    ) -> Result<usize, LayoutError> {
        let seed = trace.seed;
        let mut splits = 0;
        let mut failed: BTreeSet<u32> = BTreeSet::new();
        let mut measured: Vec<Option<f64>> = Vec::new();
        while splits < max_splits {
            // The worst patch above the threshold that has not failed to split.
            let mut worst: Option<(f64, u32)> = None;
            measured.resize(self.faces.len(), None);
            for p in 0..self.faces.len() as u32 {
                if self.faces[p as usize].is_empty() || failed.contains(&p) {
                    continue;
                }
                let s = *measured[p as usize].get_or_insert_with(|| measure(self, p));
                if s > threshold && worst.is_none_or(|(w, _)| s > w) {
                    worst = Some((s, p));
                }
            }
            let Some((measure, p)) = worst else { break };
            tracing::debug!(patch = p, faces = self.faces[p as usize].len(), measure, "splitting");
            let label = |f: FaceId| self.label[f];
            let seam = |e: EdgeId| self.seam[e];
            let split = spectral_split(
                self.mesh,
                &self.faces[p as usize],
                &label,
                &seam,
                &self.density,
                &self.vertex_areas,
                &self.rule,
                seed.wrapping_add(splits as u64),
            )?;
            let Some(split) = split else {
                tracing::debug!(patch = p, "no cut into two disks");
                failed.insert(p);
                continue;
            };
            let split =
                field_aligned_split(self.mesh, &self.faces[p as usize], &label, &seam, &split, vf, trace, &self.rule)
                    .unwrap_or(split);
            self.apply_split(p, split.a, split.b);
            measured[p as usize] = None;
            splits += 1;
        }
        Ok(splits)
    }
}

/// The split hints on a state's mesh: each face's hint (through its input face; the one with
/// the smallest extent where hints overlap) and each hint's face count here.
#[derive(Clone, Debug)]
struct HintMap {
    of_face: FaceData<u32>,
    sizes: Vec<usize>,
    extents: Vec<f64>,
}

impl HintMap {
    /// `parent`: the input face of each of the mesh's faces.
    fn new(hints: &[SplitHint], parent: &FaceData<FaceId>, input_faces: usize) -> Option<Self> {
        if hints.is_empty() {
            return None;
        }
        let mut of_input = vec![u32::MAX; input_faces];
        for (i, h) in hints.iter().enumerate() {
            for &f in &h.faces {
                let slot = of_input.get_mut(f.idx());
                if let Some(slot) = slot
                    && (*slot == u32::MAX || h.max_extent < hints[*slot as usize].max_extent)
                {
                    *slot = i as u32;
                }
            }
        }
        let of_face: FaceData<u32> = parent.map(|&f| of_input[f.idx()]);
        let mut sizes = vec![0; hints.len()];
        for &h in of_face.iter() {
            if h != u32::MAX {
                sizes[h as usize] += 1;
            }
        }
        Some(Self { of_face, sizes, extents: hints.iter().map(|h| h.max_extent).collect() })
    }

    /// The extent these faces must keep within: the smallest of the hints of which they hold at
    /// least half, or which make at least half of them.
    fn target(&self, faces: &[FaceId]) -> Option<f64> {
        let mut count: BTreeMap<u32, usize> = BTreeMap::new();
        for &f in faces {
            if self.of_face[f] != u32::MAX {
                *count.entry(self.of_face[f]).or_default() += 1;
            }
        }
        count
            .iter()
            .filter(|&(&h, &n)| 2 * n >= faces.len() || 2 * n >= self.sizes[h as usize])
            .map(|(&h, _)| self.extents[h as usize])
            .reduce(f64::min)
    }
}

/// Upper bound on size splits ([`LayoutOptions::max_patch_extent`], [`SplitHint`]), each kind.
const MAX_SIZE_SPLITS: usize = 512;

/// The extent of a region: the length of a long shortest path along its edges, from the vertex
/// farthest from its first vertex to the vertex farthest from that (a double sweep of Dijkstra:
/// the longest shortest path on a tree, a close lower bound of it on a surface patch).
/// Edge paths run a little longer than straight lines; a piece's flattened width is usually
/// below it, but not always (the flattening stretches, and the sweep is a lower bound), which
/// is why the CLI checks the flattened pieces too.
pub fn patch_extent(mesh: &Mesh, faces: &[FaceId]) -> f64 {
    use clothcast_mesh::util::MinCost;
    use std::collections::BinaryHeap;
    // The patch's vertices, numbered locally, and its edges (each face's three, both ways).
    let mut verts: Vec<VertexId> = faces.iter().flat_map(|&f| mesh.face_vertices(f)).collect();
    verts.sort_unstable();
    verts.dedup();
    if verts.is_empty() {
        return 0.0;
    }
    let local = |v: VertexId| verts.binary_search(&v).expect("a vertex of the patch");
    let mut arcs: Vec<(usize, usize, f64)> = Vec::with_capacity(6 * faces.len());
    for &f in faces {
        let vs = mesh.face_vertices(f);
        for k in 0..3 {
            let (u, w) = (vs[k], vs[(k + 1) % 3]);
            let len = (mesh.position(w) - mesh.position(u)).norm();
            let (i, j) = (local(u), local(w));
            arcs.push((i, j, len));
            arcs.push((j, i, len));
        }
    }
    // An inner edge comes from both its faces: once per direction is enough.
    arcs.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.cmp(&y.1)));
    arcs.dedup_by_key(|a| (a.0, a.1));
    let n = verts.len();
    let mut start = vec![0usize; n + 1];
    for &(i, _, _) in &arcs {
        start[i + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let sweep = |from: usize| -> (usize, f64) {
        let mut dist = vec![f64::INFINITY; n];
        let mut heap = BinaryHeap::new();
        dist[from] = 0.0;
        heap.push(MinCost(0.0, from as u32));
        let mut far = (from, 0.0);
        while let Some(MinCost(d, v)) = heap.pop() {
            let v = v as usize;
            if d > dist[v] {
                continue;
            }
            if d > far.1 {
                far = (v, d);
            }
            for &(_, w, len) in &arcs[start[v]..start[v + 1]] {
                let nd = d + len;
                if nd < dist[w] {
                    dist[w] = nd;
                    heap.push(MinCost(nd, w as u32));
                }
            }
        }
        far
    };
    let (far, _) = sweep(0);
    sweep(far).1
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;

    /// A 3 × 2 flat grid (cells of 0.25) cut into patches by `region` of the face centroids,
    /// with the field along x. The states below count corners as the late passes do (short
    /// chords: these seams are the final ones, their bends are meant).
    fn flat_layout(region: impl Fn(f64, f64) -> u32) -> (Mesh, EdgeData<bool>, FaceData<Vec3>) {
        let mesh = shapes::grid(12, 8, 3.0, 2.0);
        let region_of: FaceData<u32> = mesh
            .face_ids()
            .map(|f| {
                let c = mesh.face_centroid(f);
                region(c.x, c.y)
            })
            .collect();
        let seam: EdgeData<bool> =
            mesh.edges().map(|e| matches!(mesh.edge_faces(e), (a, Some(b)) if region_of[a] != region_of[b])).collect();
        let dirs: FaceData<Vec3> = mesh.face_ids().map(|_| Vec3::new(1.0, 0.0, 0.0)).collect();
        (mesh, seam, dirs)
    }

    /// The label of the face at (x, y) and the corner count of its patch.
    fn corners_at(state: &State<'_>, x: f64, y: f64) -> (u32, usize) {
        let f = state
            .mesh
            .face_ids()
            .min_by(|&a, &b| {
                let d = |f: FaceId| (state.mesh.face_centroid(f) - Vec3::new(x, y, 0.0)).norm();
                d(a).total_cmp(&d(b))
            })
            .expect("faces");
        let p = state.label[f];
        (p, state.info_of(p).corners.len())
    }

    #[test]
    fn late_merge_joins_a_pentagon_and_a_triangle_into_a_quad() {
        // A: an L (five corners: its concave corner is none, its 90° corner at the T-junction
        // (2, 1) is one); C: the square in the L's notch (three corners: (1, 1) joins only two
        // patches); D: a rectangle with a T-junction on its straight side (four).
        let (mesh, seam, dirs) = flat_layout(|x, y| {
            if x > 2.0 {
                2
            } else if x > 1.0 && y > 1.0 {
                1
            } else {
                0
            }
        });
        let n = mesh.n_vertices();
        let (singular, index) = (VertexData::filled(n, false), VertexData::filled(n, 0));
        let scores = vertex_scores(&mesh);
        let mut state = State::new(&mesh, &seam, &singular, &index, &scores, &dirs, FINAL_CHORD_STEPS);
        let (a, ca) = corners_at(&state, 0.5, 0.5);
        let (c, cc) = corners_at(&state, 1.5, 1.5);
        let (d, cd) = corners_at(&state, 2.5, 1.0);
        assert_eq!((ca, cc, cd), (5, 3, 4));
        assert!(a != c && c != d && a != d);
        assert_eq!(state.merge_quads(f64::INFINITY, true), 1);
        let (a2, ca2) = corners_at(&state, 0.5, 0.5);
        assert_eq!(corners_at(&state, 1.5, 1.5).0, a2, "A and C merged");
        assert_eq!(ca2, 4);
        assert_eq!(corners_at(&state, 2.5, 1.0), (d, 4), "D keeps its four corners");
    }

    #[test]
    fn cusp_repair_hands_a_thin_spike_to_a_neighbour() {
        // P: a block on the right (x > 2.25) with a spike one cell thin (1 < y < 1.25) reaching
        // left to (1, 1), its tip a cusp between Q (below) and R (above): P has five corners.
        let (mesh, seam, dirs) = flat_layout(|x, y| {
            if x > 2.25 || (y > 1.0 && y < 1.25 && x > 1.0 && y - 1.0 < x - 1.0) {
                0
            } else if y < 1.0 {
                1
            } else {
                2
            }
        });
        let n = mesh.n_vertices();
        let (singular, index) = (VertexData::filled(n, false), VertexData::filled(n, 0));
        let scores = vertex_scores(&mesh);
        let live =
            |s: &State<'_>| (0..s.faces.len() as u32).filter(|&l| !s.faces[l as usize].is_empty()).collect::<Vec<_>>();
        let quads = |s: &State<'_>| live(s).into_iter().filter(|&l| s.info_of(l).corners.len() == 4).count();
        for aligned in [true, false] {
            let mut state = State::new(&mesh, &seam, &singular, &index, &scores, &dirs, FINAL_CHORD_STEPS);
            let (p, cp) = corners_at(&state, 2.6, 1.0);
            assert_eq!(cp, 5);
            assert!(state.info_of(p).candidates.iter().any(|&(_, q)| q < CUSP_QUARTERS), "the tip is a cusp");
            let before = quads(&state);
            assert_eq!(state.zip_cusps(4, aligned), 1);
            assert!(quads(&state) > before);
            assert_eq!(corners_at(&state, 2.6, 1.0), (p, 4), "P is a quad");
            assert!(corners_at(&state, 1.2, 1.1).0 != p, "the spike's tip went to a neighbour");
            // Labels and seams agree: the same patches, all disks.
            let cut = patches(&mesh, &state.seam);
            assert_eq!(cut.n, live(&state).len());
            assert!((0..cut.n).all(|i| cut.is_disk(i)));
            assert!(live(&state).iter().all(|&l| state.info_of(l).is_disk()));
        }
    }

    #[test]
    fn late_merge_leaves_quads_alone() {
        // Three rectangles side by side: every union of two is a quad, but only the plain merge
        // takes it (the late merge is for patches that are not quads).
        let (mesh, seam, dirs) = flat_layout(|x, _| {
            if x > 2.0 {
                2
            } else if x > 1.0 {
                1
            } else {
                0
            }
        });
        let n = mesh.n_vertices();
        let (singular, index) = (VertexData::filled(n, false), VertexData::filled(n, 0));
        let scores = vertex_scores(&mesh);
        let mut state = State::new(&mesh, &seam, &singular, &index, &scores, &dirs, FINAL_CHORD_STEPS);
        assert_eq!([0.5, 1.5, 2.5].map(|x| corners_at(&state, x, 1.0).1), [4, 4, 4]);
        assert_eq!(state.merge_quads(f64::INFINITY, true), 0);
        assert!(state.merge_quads(f64::INFINITY, false) >= 1);
    }
}
