//! Flattening every patch of a segmentation and orienting it on the fabric (paper §6.3, §6.4).
//!
//! **Pieces.** The segmented mesh is cut open along all seams (a seam inside a patch, a dart,
//! is opened too) and every patch becomes a disk mesh of its own, flattened by BFF in its
//! minimal-area-distortion mode ([`crate::bff`]): boundary lengths are kept (the outline is
//! closed by turning, [`BffOptions::exact_lengths`]), so the two sides of a seam keep the same
//! length. A flattening with flipped triangles (BFF is linear;
//! it happens around needle triangles of the input) is retried with a stronger cotangent floor,
//! then untangled (`untangle.rs`): the vertices of flipped triangles and a ring or a few
//! around them minimise a foldover-free conformal energy, the rest of the map held, so the
//! flips are undone where they are without shearing the piece (a local Tutte step is the last
//! resort). What remains is reported (`flipped_triangles`), never hidden.
//!
//! **Area.** BFF with zero boundary scale factors keeps every boundary length but shrinks the
//! interior of a positively curved patch (a spherical cap of half-angle α keeps (1 + cos α)/2 of
//! its area) and stretches a saddle: on our test models the pieces come out 1–4% smaller in
//! total than the target. With `match_area` (the default) all pieces are then scaled by one
//! common factor √(A₃D / A₂D), so the fabric has the target's area; every length — both sides
//! of every seam alike — grows by the same factor (≈ 1–2%), so the sides still match. The
//! factor and the area ratio before it are reported (`area_scale`, `area_ratio_bff`).
//!
//! **Orientation.** Warp runs along +x (u) of each piece. Two rules ([`Orientation`]):
//! - `Field` (the paper's future work, done here): map the cross field into the piece's plane
//!   (each face's direction through the face's own 3D → 2D map) and choose the rotation that
//!   best aligns warp/weft with it: maximise `Σ w_f cos 4(θ_f + φ)`, whose maximiser has the
//!   closed form `φ = −arg(Σ w_f e^{4iθ_f}) / 4`, with `w_f` = area × (anisotropy + 0.05) so that
//!   strongly anisotropic faces, where the fibre direction matters, count most.
//! - `LongestSide` (the paper's heuristics): the sides between consecutive corners; when the
//!   longest is clearly the longest (≥ 1.15 × the next), its chord is turned onto the nearest
//!   fibre axis; otherwise the angles of all sides to their nearest axis are minimised (the same
//!   4-fold closed form over the side chords, weighted by length).
//!
//! Either rule fixes the turn up to a quarter turn, warp and weft being both fibres. Which of
//! the two runs along the field's major direction (the largest principal stretch of the
//! simulated mold) is decided after it ([`WarpAlong`], the paper's "which principal stretch
//! goes on warp"): by default the warp, so that every piece of a mold carries its largest
//! stretch on the same yarn (the stiffer one, when the user sets the rule by the fabric). The
//! quarter turn is the one with `Σ w_f cos 2(θ_f + φ) > 0` over the major directions θ_f mapped
//! into the piece (same weights); `major_on_warp_share` reports the weight nearer the warp
//! than the weft.
//!
//! **Fibre alignment** of a piece: the area-weighted median over its faces of the angle between
//! the field's direction there and the nearest fibre (warp or weft).
//!
//! Complexity: one sparse factorization per patch (BFF), O(F) otherwise.

use crate::bff::{BffOptions, BffProblem, BoundaryRelief, Flattening, FlatteningStats, distortion};
use crate::error::FlattenError;
use crate::untangle::untangle;
use clothcast_layout::Segmentation;
use clothcast_layout::cutgraph::cut_open;
use clothcast_mesh::submesh::extract_submesh;
use clothcast_mesh::{EdgeData, FaceData, FaceId, Mesh, Vec2, Vec3, VertexData, VertexId};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::f64::consts::FRAC_PI_2;
use std::time::Instant;

/// How pieces are turned on the fabric.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Orientation {
    /// Best alignment of warp/weft with the cross field (closed form, area and anisotropy
    /// weighted).
    Field,
    /// The paper's heuristics: the longest side along a fibre, or all sides as close to a fibre
    /// as possible.
    LongestSide,
}

/// Which fibre the field's major direction (the largest principal stretch of the simulated
/// mold, or the largest principal curvature with the curvature field) runs along. Either
/// orientation rule fixes a piece's turn only up to a quarter turn (warp and weft are both
/// fibres); this decides the quarter turn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WarpAlong {
    /// The warp along the major direction (the default): set it, or `Minor`, by the fabric's
    /// stiffer yarn, which carries the largest stretch best (which yarn that is depends on the
    /// fabric: of the five woven fabrics measured by Wang et al. 2011, three are stiffer
    /// along one yarn, by 1.6–5 times, and two about alike).
    Major,
    /// The weft along the major direction.
    Minor,
    /// Whichever the orientation rule's turn gives (a piece's turn in (−45°, 45°]): warp and
    /// weft behave alike.
    Either,
}

/// Options of the flattening stage.
#[derive(Clone, Debug)]
pub struct FlattenOptions {
    /// Orientation rule.
    pub orientation: Orientation,
    /// Which fibre runs along the field's major direction.
    pub warp_along: WarpAlong,
    /// Scale all pieces by one common factor so that their total area equals the target's (see
    /// the module documentation).
    pub match_area: bool,
    /// BFF options.
    pub bff: BffOptions,
    /// When a piece is reported as badly distorted.
    pub limits: DistortionLimits,
}

impl Default for FlattenOptions {
    fn default() -> Self {
        Self {
            orientation: Orientation::Field,
            warp_along: WarpAlong::Major,
            match_area: true,
            bff: BffOptions::default(),
            limits: DistortionLimits::default(),
        }
    }
}

/// One flattened, oriented patch.
#[derive(Clone, Debug)]
pub struct FlatPatch {
    /// Patch id in the segmentation.
    pub patch: u32,
    /// The patch as a disk mesh (metres), cut open along every seam.
    pub mesh: Mesh,
    /// Segmented-mesh vertex of every piece vertex.
    pub seg_vertex: VertexData<VertexId>,
    /// Segmented-mesh face of every piece face.
    pub seg_face: FaceData<FaceId>,
    /// Oriented 2D positions (metres; warp along +x), centred on the origin.
    pub uv: VertexData<Vec2>,
    /// Rotation applied after BFF (radians, counter-clockwise).
    pub rotation: f64,
    /// Boundary loop (piece vertices, counter-clockwise in `uv`).
    pub outline: Vec<VertexId>,
    /// Distortion of the flattening.
    pub stats: FlatteningStats,
    /// Area-weighted median angle between the field and the nearest fibre (degrees).
    pub fiber_deviation_median_deg: f64,
    /// Share of the field's major direction nearer the warp than the weft ([`FlattenReport`]).
    pub major_on_warp_share: f64,
    /// Flattened by the last resort, [`convex_flattening`] ([`OutlineRepair::Convex`]): left
    /// out of the common area scale, whose BFF layouts it would shrink.
    pub convex_fallback: bool,
}

/// One side of a seam on a piece: a run of its outline.
#[derive(Clone, Debug, PartialEq)]
pub struct SeamRun {
    /// Seam id (index into `Segmentation::seams`).
    pub seam: usize,
    /// Outline index where the run starts (walking counter-clockwise).
    pub start: usize,
    /// Outline index where it ends (inclusive). Equal to `start` for a seam that is a closed
    /// loop round the whole outline: the run then starts and ends at the seam's first vertex,
    /// on both of its sides.
    pub end: usize,
    /// Whether walking counter-clockwise from start to end follows the seam's own direction.
    pub forward: bool,
    /// 2D length of the run (metres).
    pub length: f64,
}

/// The `flattening` section of `summary.json`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FlattenReport {
    /// Flipped 2D triangles over all pieces (after the retry).
    pub flipped_triangles: usize,
    /// Smallest per-face 2D/3D area ratio.
    pub area_ratio_min: f64,
    /// Largest per-face 2D/3D area ratio.
    pub area_ratio_max: f64,
    /// Area-weighted mean quasi-conformal ratio σ1/σ2 over all pieces.
    pub qc_mean: f64,
    /// Largest quasi-conformal ratio.
    pub qc_max: f64,
    /// Largest relative length difference between the two sides of a seam.
    pub seam_length_mismatch_max_rel: f64,
    /// Area-weighted median angle between the field and the nearest fibre, all pieces.
    pub fiber_alignment_median_deg: f64,
    /// The same with the other orientation rule, for comparison.
    pub fiber_alignment_other_rule_deg: f64,
    /// Orientation rule used.
    pub orientation: Option<Orientation>,
    /// Which fibre was put along the field's major direction.
    pub warp_along: Option<WarpAlong>,
    /// Share of the field's major direction (weighted by area × (anisotropy + 0.05), the
    /// orientation's weights) lying nearer the warp than the weft, over all pieces: near 1
    /// with `warp_along = "major"`, near 0 with `"minor"`; with `"either"`, what the turns
    /// happened to give. 0.5 when the field gives no major direction.
    pub major_on_warp_share: f64,
    /// Per piece: area ratio, quasi-conformal ratio, flips and fibre alignment (patch order).
    pub per_piece: Vec<PieceReport>,
    /// Pieces re-flattened because the first flattening had flipped triangles.
    pub retried: usize,
    /// Vertices moved by the untangling of flipped triangles.
    pub repaired_vertices: usize,
    /// Pieces flattened on their intrinsic Delaunay triangulation, their first flattening
    /// having come out with flipped triangles or badly distorted ([`flatten_piece`]).
    pub intrinsic_delaunay: usize,
    /// Pieces whose flattened outline crossed itself and was made simple ([`flatten_piece`]).
    pub outlines_repaired: usize,
    /// Pieces whose outline still crosses itself or nearly touches itself (within 10⁻⁹ of its
    /// perimeter; the pattern stage refuses those that cross).
    pub outlines_not_simple: usize,
    /// Patch ids of the pieces whose flattening is badly distorted: an area-weighted mean
    /// quasi-conformal ratio above [`DistortionLimits::qc_mean`] (default [`DISTORTED_QC_MEAN`]),
    /// or per-face area ratios further apart than [`DistortionLimits::area_spread`] (default
    /// [`DISTORTED_AREA_SPREAD`]) (the fabric cannot follow the target there; a sharp corner
    /// or sliver triangles inside the piece are the usual cause).
    pub distorted_pieces: Vec<u32>,
    /// Total 2D / 3D area straight out of BFF (before the common scale).
    pub area_ratio_bff: f64,
    /// The common scale applied to all pieces (1 when `match_area` is off).
    pub area_scale: f64,
    /// Seconds.
    pub seconds: f64,
}

/// A piece is reported as badly distorted above this area-weighted mean quasi-conformal ratio
/// by default (the six README models' pieces stay below 1.13).
pub const DISTORTED_QC_MEAN: f64 = 1.25;
/// … or when its largest per-face area ratio exceeds its smallest by this factor (the README
/// models at 0.5 m: at most 10.4, camelhead's).
pub const DISTORTED_AREA_SPREAD: f64 = 50.0;

/// When a flattened piece counts as badly distorted ([`FlattenReport::distorted_pieces`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistortionLimits {
    /// Largest area-weighted mean quasi-conformal ratio.
    pub qc_mean: f64,
    /// Largest ratio between a piece's largest and smallest per-face area ratios.
    pub area_spread: f64,
}

impl Default for DistortionLimits {
    fn default() -> Self {
        Self { qc_mean: DISTORTED_QC_MEAN, area_spread: DISTORTED_AREA_SPREAD }
    }
}

impl DistortionLimits {
    /// Whether a flattening exceeds these limits.
    pub fn exceeded_by(&self, stats: &FlatteningStats) -> bool {
        !(stats.qc_mean <= self.qc_mean && stats.area_ratio_max <= self.area_spread * stats.area_ratio_min.max(0.0))
    }
}

/// Flattening figures of one piece (an entry of `flattening.per_piece` in `summary.json`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct PieceReport {
    /// Patch id.
    pub patch: u32,
    /// Total 2D / 3D area of the piece (after the common scale).
    pub area_ratio: f64,
    /// Smallest per-face 2D/3D area ratio.
    pub area_ratio_min: f64,
    /// Largest per-face 2D/3D area ratio.
    pub area_ratio_max: f64,
    /// Area-weighted mean quasi-conformal ratio σ1/σ2.
    pub qc_mean: f64,
    /// Largest quasi-conformal ratio.
    pub qc_max: f64,
    /// Flipped triangles left.
    pub flipped_triangles: usize,
    /// Area-weighted median angle between the field and the nearest fibre (degrees).
    pub fiber_alignment_median_deg: f64,
    /// Share of the field's major direction nearer the warp than the weft.
    pub major_on_warp_share: f64,
}

/// Everything the stage produces.
#[derive(Clone, Debug)]
pub struct FlatPieces {
    /// One per patch, in patch order.
    pub patches: Vec<FlatPatch>,
    /// Seam sides on every piece (same order as `patches`).
    pub runs: Vec<Vec<SeamRun>>,
    /// Figures.
    pub report: FlattenReport,
}

/// Flatten and orient every patch. `anisotropy[f]` (segmented-mesh faces, in [0, 1]) weights
/// the field orientation; `major[f]` is the field's major direction on each face (a 3D vector
/// in the face's plane, either sign; zero where there is none), which decides which fibre runs
/// along it ([`WarpAlong`]).
pub fn flatten_segmentation(
    seg: &Segmentation,
    anisotropy: &FaceData<f64>,
    major: &FaceData<Vec3>,
    opts: &FlattenOptions,
) -> Result<FlatPieces, FlattenError> {
    let start = Instant::now();
    let m = &seg.mesh;
    // Cut along every seam: the cut mesh's faces are the segmented mesh's faces, in order.
    let mut seam = EdgeData::filled(m.n_edges(), false);
    for s in &seg.seams {
        for w in s.vertices.windows(2) {
            if let Some(e) = clothcast_layout::patches::edge_between(m, w[0], w[1]) {
                seam[e] = true;
            }
        }
    }
    let (cut, original) = cut_open(m, &seam);
    let n = seg.patches.len();
    let mut faces: Vec<Vec<FaceId>> = vec![Vec::new(); n];
    for (f, &p) in seg.patch_of_face.enumerate() {
        faces[p as usize].push(f);
    }
    // Seam edge (segmented vertices, in seam order) → (seam id, position along the seam).
    let mut seam_edge: HashMap<(VertexId, VertexId), usize> = HashMap::new();
    for (i, s) in seg.seams.iter().enumerate() {
        for w in s.vertices.windows(2) {
            seam_edge.insert((w[0], w[1]), i);
        }
    }
    let mut report =
        FlattenReport { orientation: Some(opts.orientation), warp_along: Some(opts.warp_along), ..Default::default() };
    let mut patches = Vec::with_capacity(n);
    let mut runs = Vec::with_capacity(n);
    // (fibre angle, area) of every face with the chosen rule and with the other one.
    let mut all_main: Vec<(f64, f64)> = Vec::new();
    let mut all_other: Vec<(f64, f64)> = Vec::new();
    // Weight of the major direction nearer the warp than the weft, and in all.
    let mut all_majors = (0.0, 0.0);
    // Every piece on its own (in parallel: they share nothing), then gathered in patch order,
    // so that the totals and the messages are the same however the work was shared out.
    let ctx = PieceContext { seg, cut: &cut, original: &original, seam_edge: &seam_edge, anisotropy, major, opts };
    let laid: Vec<Result<LaidPiece, FlattenError>> =
        faces.par_iter().enumerate().map(|(p, fs)| lay_piece(&ctx, p, fs)).collect();
    for (p, piece) in laid.into_iter().enumerate() {
        let piece = piece?;
        report.retried += usize::from(piece.retried);
        report.intrinsic_delaunay += usize::from(piece.intrinsic_delaunay);
        report.repaired_vertices += piece.repaired_vertices;
        if piece.flipped > 0 {
            tracing::warn!(patch = p, flipped = piece.flipped, "flattened patch has flipped triangles");
        }
        match (piece.outline_repair, piece.outline_simple) {
            (_, false) => {
                report.outlines_not_simple += 1;
                tracing::warn!(patch = p, "flattened outline crosses itself");
            }
            (Some(OutlineRepair::Convex), true) => {
                report.outlines_repaired += 1;
                tracing::warn!(
                    "patch {p}: no re-flattening gave a simple outline; the piece is mapped onto a disk instead \
                     (cuttable, but distorted: its seams keep their lengths, its inside does not)"
                );
            }
            (Some(how), true) => {
                report.outlines_repaired += 1;
                tracing::info!(patch = p, ?how, "flattened outline crossed itself: re-flattened with a simple one");
            }
            (None, true) => {}
        }
        all_majors.0 += piece.on_warp;
        all_majors.1 += piece.weight;
        all_main.extend_from_slice(&piece.samples);
        all_other.extend_from_slice(&piece.other_samples);
        runs.push(piece.runs);
        patches.push(piece.patch);
    }
    // Totals.
    let total_area: f64 = patches.iter().map(|q| q.mesh.total_area()).sum();
    // (A disk-mapped piece counts as its 3D area: its circle's area says nothing of BFF's shrink.)
    let flat_area: f64 =
        patches.iter().map(|q| if q.convex_fallback { 1.0 } else { q.stats.area_ratio } * q.mesh.total_area()).sum();
    report.area_ratio_bff = flat_area / total_area.max(1e-300);
    report.area_scale = 1.0;
    if opts.match_area && flat_area > 0.0 {
        let k = (total_area / flat_area).sqrt();
        report.area_scale = k;
        for q in &mut patches {
            q.uv.iter_mut().for_each(|x| *x *= k);
            q.stats = distortion(&q.mesh, &q.uv);
        }
        for r in runs.iter_mut().flatten() {
            r.length *= k;
        }
    }
    report.flipped_triangles = patches.iter().map(|q| q.stats.flipped_triangles).sum();
    report.area_ratio_min = patches.iter().map(|q| q.stats.area_ratio_min).fold(f64::INFINITY, f64::min);
    report.area_ratio_max = patches.iter().map(|q| q.stats.area_ratio_max).fold(f64::NEG_INFINITY, f64::max);
    report.qc_mean =
        patches.iter().map(|q| q.stats.qc_mean * q.mesh.total_area()).sum::<f64>() / total_area.max(1e-300);
    report.qc_max = patches.iter().map(|q| q.stats.qc_max).fold(0.0, f64::max);
    report.fiber_alignment_median_deg = weighted_median(all_main);
    report.per_piece = patches
        .iter()
        .map(|q| PieceReport {
            patch: q.patch,
            area_ratio: q.stats.area_ratio,
            area_ratio_min: q.stats.area_ratio_min,
            area_ratio_max: q.stats.area_ratio_max,
            qc_mean: q.stats.qc_mean,
            qc_max: q.stats.qc_max,
            flipped_triangles: q.stats.flipped_triangles,
            fiber_alignment_median_deg: q.fiber_deviation_median_deg,
            major_on_warp_share: q.major_on_warp_share,
        })
        .collect();
    report.distorted_pieces = patches.iter().filter(|q| opts.limits.exceeded_by(&q.stats)).map(|q| q.patch).collect();
    report.fiber_alignment_other_rule_deg = weighted_median(all_other);
    report.major_on_warp_share = share(all_majors.0, all_majors.1);
    report.seam_length_mismatch_max_rel = seam_mismatch(&runs, seg.seams.len());
    report.seconds = start.elapsed().as_secs_f64();
    Ok(FlatPieces { patches, runs, report })
}

/// What every piece of [`flatten_segmentation`] reads.
struct PieceContext<'a> {
    seg: &'a Segmentation,
    /// The segmented mesh cut open along every seam, and each of its vertices' original.
    cut: &'a Mesh,
    original: &'a [VertexId],
    /// Seam edge (segmented vertices, in seam order) → seam id.
    seam_edge: &'a HashMap<(VertexId, VertexId), usize>,
    anisotropy: &'a FaceData<f64>,
    major: &'a FaceData<Vec3>,
    opts: &'a FlattenOptions,
}

/// One piece flattened and oriented, with what the totals gather from it.
struct LaidPiece {
    patch: FlatPatch,
    runs: Vec<SeamRun>,
    /// (fibre angle, area) of every face with the chosen rule and with the other one.
    samples: Vec<(f64, f64)>,
    other_samples: Vec<(f64, f64)>,
    /// Weight of the major direction nearer the warp than the weft, and in all.
    on_warp: f64,
    weight: f64,
    retried: bool,
    intrinsic_delaunay: bool,
    repaired_vertices: usize,
    /// Flipped triangles of the flattening (before the common area scale).
    flipped: usize,
    outline_repair: Option<OutlineRepair>,
    outline_simple: bool,
}

/// Flatten patch `p` (faces `fs` of the segmented mesh) and orient it on the fabric.
fn lay_piece(ctx: &PieceContext<'_>, p: usize, fs: &[FaceId]) -> Result<LaidPiece, FlattenError> {
    let (seg, opts) = (ctx.seg, ctx.opts);
    let sub =
        extract_submesh(ctx.cut, fs).map_err(|e| FlattenError::Degenerate { reason: format!("patch {p}: {e}") })?;
    let seg_vertex: VertexData<VertexId> = sub.vertex_to_parent.map(|&v| ctx.original[v.idx()]);
    let seg_face = sub.face_to_parent.clone();
    let pm = sub.mesh;
    let piece = flatten_piece(&pm, &opts.bff, &opts.limits)
        .map_err(|e| FlattenError::Patch { patch: p as u32, error: Box::new(e) })?;
    let convex = piece.outline_repair == Some(OutlineRepair::Convex);
    let flat = piece.flattening;
    let outline = piece.outline;
    // Field directions mapped into the piece's plane, and their weights.
    let mapped: Vec<(f64, f64, f64)> = pm
        .face_ids()
        .map(|f| {
            let sf = seg_face[f];
            let theta = map_direction(&pm, &flat.uv, f, &seg.field_directions[sf]);
            let area = pm.face_area(f);
            (theta, area, area * (ctx.anisotropy[sf].clamp(0.0, 1.0) + 0.05))
        })
        .collect();
    let phi_field = field_rotation(&mapped);
    let phi_sides = side_rotation(&flat.uv, &outline, &seg_vertex, &seg.patches[p].corners);
    let (phi, phi_other) = match opts.orientation {
        Orientation::Field => (phi_field, phi_sides),
        Orientation::LongestSide => (phi_sides, phi_field),
    };
    // The major direction mapped into the piece's plane, with the same weights; the
    // quarter turn that puts it on the chosen fibre.
    let major = ctx.major;
    let majors: Vec<(f64, f64)> = pm
        .face_ids()
        .zip(&mapped)
        .filter(|&(f, _)| major[seg_face[f]].norm_squared() > 0.0)
        .map(|(f, &(_, _, w))| (map_direction(&pm, &flat.uv, f, &major[seg_face[f]]), w))
        .collect();
    let phi = phi + quarter_turn(&majors, phi, opts.warp_along);
    let (on_warp, weight) =
        majors.iter().fold((0.0, 0.0), |(a, b), &(t, w)| (if toward_warp(t, phi) > 0.0 { a + w } else { a }, b + w));
    let centroid = {
        let (mut c, mut a) = (Vec2::zeros(), 0.0);
        for f in pm.face_ids() {
            let [x, y, z] = pm.face_vertices(f).map(|v| flat.uv[v]);
            let area = 0.5 * ((y - x).perp(&(z - x))).abs();
            c += (x + y + z) / 3.0 * area;
            a += area;
        }
        if a > 0.0 { c / a } else { Vec2::zeros() }
    };
    let rot = nalgebra::Rotation2::new(phi);
    let uv: VertexData<Vec2> = flat.uv.map(|q| rot * (q - centroid));
    let samples: Vec<(f64, f64)> = mapped.iter().map(|&(t, a, _)| (fiber_angle(t + phi), a)).collect();
    let dev = weighted_median(samples.clone());
    let other_samples = mapped.iter().map(|&(t, a, _)| (fiber_angle(t + phi_other), a)).collect();
    let stats = distortion(&pm, &uv);
    let runs = seam_runs(&uv, &outline, &seg_vertex, ctx.seam_edge, |s| ctx.seg.seams[s].vertices.first().copied());
    Ok(LaidPiece {
        patch: FlatPatch {
            patch: p as u32,
            mesh: pm,
            seg_vertex,
            seg_face,
            uv,
            rotation: phi,
            outline,
            stats,
            fiber_deviation_median_deg: dev,
            major_on_warp_share: share(on_warp, weight),
            convex_fallback: convex,
        },
        runs,
        samples,
        other_samples,
        on_warp,
        weight,
        retried: piece.retried,
        intrinsic_delaunay: piece.intrinsic_delaunay,
        repaired_vertices: piece.repaired_vertices,
        flipped: flat.stats.flipped_triangles,
        outline_repair: piece.outline_repair,
        outline_simple: piece.outline_simple,
    })
}

/// Angle (radians) of a 3D direction of face `f` mapped into 2D by the face's affine map.
fn map_direction(mesh: &Mesh, uv: &VertexData<Vec2>, f: FaceId, d: &Vec3) -> f64 {
    let [a, b, c] = mesh.face_vertices(f);
    let (p0, p1, p2) = (mesh.position(a), mesh.position(b), mesh.position(c));
    let (e1, e2) = (p1 - p0, p2 - p0);
    // d = α e1 + β e2 in the face plane (least squares).
    let (g11, g12, g22) = (e1.dot(&e1), e1.dot(&e2), e2.dot(&e2));
    let det = g11 * g22 - g12 * g12;
    if det.abs() <= 1e-300 {
        return 0.0;
    }
    let (r1, r2) = (d.dot(&e1), d.dot(&e2));
    let alpha = (g22 * r1 - g12 * r2) / det;
    let beta = (g11 * r2 - g12 * r1) / det;
    let q = (uv[b] - uv[a]) * alpha + (uv[c] - uv[a]) * beta;
    q.y.atan2(q.x)
}

/// Angle (degrees, in [0, 45]) between a direction and the nearest fibre axis.
fn fiber_angle(theta: f64) -> f64 {
    let r = theta.rem_euclid(FRAC_PI_2);
    r.min(FRAC_PI_2 - r).to_degrees()
}

/// The rotation maximising `Σ w cos 4(θ + φ)`: φ = −arg(Σ w e^{4iθ}) / 4.
fn four_fold_rotation(samples: impl Iterator<Item = (f64, f64)>) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    for (theta, w) in samples {
        re += w * (4.0 * theta).cos();
        im += w * (4.0 * theta).sin();
    }
    if re == 0.0 && im == 0.0 { 0.0 } else { -im.atan2(re) / 4.0 }
}

/// The quarter turn (0 or π/2) to add to a piece's turn `phi` so that the major directions
/// `majors` (angle in the piece's plane, weight) lie, on the whole, along the fibre `rule`
/// asks for: the warp (+x) when `Σ w cos 2(θ + φ) > 0`. Ties keep `phi`.
fn quarter_turn(majors: &[(f64, f64)], phi: f64, rule: WarpAlong) -> f64 {
    let along_warp: f64 = majors.iter().map(|&(t, w)| w * toward_warp(t, phi)).sum();
    let turn = match rule {
        WarpAlong::Major => along_warp < 0.0,
        WarpAlong::Minor => along_warp > 0.0,
        WarpAlong::Either => false,
    };
    if turn { FRAC_PI_2 } else { 0.0 }
}

/// How much a direction at angle `theta`, once the piece is turned by `phi`, lies along the
/// warp rather than the weft: cos 2(θ + φ), 1 on the warp, −1 on the weft (either sign of the
/// direction alike).
fn toward_warp(theta: f64, phi: f64) -> f64 {
    (2.0 * (theta + phi)).cos()
}

/// `part / whole`, 0.5 when the whole is nothing.
fn share(part: f64, whole: f64) -> f64 {
    if whole > 0.0 { part / whole } else { 0.5 }
}

fn field_rotation(mapped: &[(f64, f64, f64)]) -> f64 {
    four_fold_rotation(mapped.iter().map(|&(t, _, w)| (t, w)))
}

/// The paper's side heuristics (see the module documentation).
fn side_rotation(
    uv: &VertexData<Vec2>,
    outline: &[VertexId],
    seg_vertex: &VertexData<VertexId>,
    corners: &[VertexId],
) -> f64 {
    let n = outline.len();
    let corner_at: Vec<usize> = (0..n).filter(|&i| corners.contains(&seg_vertex[outline[i]])).collect();
    // Sides: (chord angle, arc length).
    let mut sides: Vec<(f64, f64)> = Vec::new();
    if corner_at.len() >= 2 {
        for k in 0..corner_at.len() {
            let (a, b) = (corner_at[k], corner_at[(k + 1) % corner_at.len()]);
            let mut len = 0.0;
            let mut i = a;
            while i != b {
                let j = (i + 1) % n;
                len += (uv[outline[j]] - uv[outline[i]]).norm();
                i = j;
            }
            let d = uv[outline[b]] - uv[outline[a]];
            sides.push((d.y.atan2(d.x), len));
        }
    } else {
        for i in 0..n {
            let d = uv[outline[(i + 1) % n]] - uv[outline[i]];
            sides.push((d.y.atan2(d.x), d.norm()));
        }
    }
    let mut by_len = sides.clone();
    by_len.sort_by(|a, b| b.1.total_cmp(&a.1));
    if by_len.len() >= 2 && by_len[0].1 >= 1.15 * by_len[1].1 {
        // The longest side onto the nearest fibre axis.
        let t = by_len[0].0;
        let r = t.rem_euclid(FRAC_PI_2);
        if r < FRAC_PI_2 - r { -r } else { FRAC_PI_2 - r }
    } else {
        four_fold_rotation(sides.into_iter())
    }
}

/// Weighted median of (value, weight) samples.
fn weighted_median(mut samples: Vec<(f64, f64)>) -> f64 {
    samples.retain(|s| s.0.is_finite() && s.1 > 0.0);
    if samples.is_empty() {
        return 0.0;
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = samples.iter().map(|s| s.1).sum();
    let mut acc = 0.0;
    for (v, w) in &samples {
        acc += w;
        if acc >= 0.5 * total {
            return *v;
        }
    }
    samples.last().map(|s| s.0).unwrap_or(0.0)
}

/// The seam sides along a piece's outline: maximal runs of outline edges belonging to the same
/// seam in the same direction. A seam round the whole outline (a closed loop) is one run from
/// and back to the seam's first vertex (`seam_start`, on the segmented mesh), so that its two
/// sides start at the same point of the mold.
fn seam_runs(
    uv: &VertexData<Vec2>,
    outline: &[VertexId],
    seg_vertex: &VertexData<VertexId>,
    seam_edge: &HashMap<(VertexId, VertexId), usize>,
    seam_start: impl Fn(usize) -> Option<VertexId>,
) -> Vec<SeamRun> {
    let n = outline.len();
    // Per outline edge i (outline[i] → outline[i+1]): (seam, forward).
    let key: Vec<Option<(usize, bool)>> = (0..n)
        .map(|i| {
            let (a, b) = (seg_vertex[outline[i]], seg_vertex[outline[(i + 1) % n]]);
            seam_edge.get(&(a, b)).map(|&s| (s, true)).or_else(|| seam_edge.get(&(b, a)).map(|&s| (s, false)))
        })
        .collect();
    // Start at an edge whose key differs from its predecessor's, so no run wraps.
    let Some(first) = (0..n).find(|&i| key[i] != key[(i + n - 1) % n]) else {
        // One run around the whole outline (or none).
        return match key.first().copied().flatten() {
            Some((seam, forward)) => {
                let length = (0..n).map(|i| (uv[outline[(i + 1) % n]] - uv[outline[i]]).norm()).sum();
                let start =
                    seam_start(seam).and_then(|v| outline.iter().position(|&u| seg_vertex[u] == v)).unwrap_or(0);
                vec![SeamRun { seam, start, end: start, forward, length }]
            }
            None => Vec::new(),
        };
    };
    let mut out = Vec::new();
    let mut i = first;
    let mut visited = 0;
    while visited < n {
        let k = key[i];
        let start = i;
        let mut length = 0.0;
        while visited < n && key[i] == k {
            length += (uv[outline[(i + 1) % n]] - uv[outline[i]]).norm();
            i = (i + 1) % n;
            visited += 1;
        }
        if let Some((seam, forward)) = k {
            out.push(SeamRun { seam, start, end: i, forward, length });
        }
    }
    out
}

/// Largest relative length difference between the two sides of every seam.
fn seam_mismatch(runs: &[Vec<SeamRun>], n_seams: usize) -> f64 {
    let mut sides: Vec<Vec<f64>> = vec![Vec::new(); n_seams];
    for r in runs.iter().flatten() {
        sides[r.seam].push(r.length);
    }
    sides
        .iter()
        .filter(|s| s.len() == 2)
        .map(|s| (s[0] - s[1]).abs() / (0.5 * (s[0] + s[1])).max(1e-300))
        .fold(0.0, f64::max)
}

/// One flattened piece ([`flatten_piece`]).
#[derive(Clone, Debug)]
pub struct PieceFlattening {
    /// The layout and its distortion.
    pub flattening: Flattening,
    /// The boundary loop's vertices (counter-clockwise), the piece's outline.
    pub outline: Vec<VertexId>,
    /// Whether the first flattening had flipped triangles and was retried.
    pub retried: bool,
    /// Vertices moved by the untangling of flipped triangles.
    pub repaired_vertices: usize,
    /// How an outline that crossed itself was made simple, if one did.
    pub outline_repair: Option<OutlineRepair>,
    /// Whether the outline is simple (no two of its edges cross or touch).
    pub outline_simple: bool,
    /// Whether the piece came out with flipped triangles or badly distorted and is flattened on
    /// its intrinsic Delaunay triangulation instead ([`BffOptions::intrinsic_delaunay`]), which
    /// was less distorted.
    pub intrinsic_delaunay: bool,
}

/// How [`flatten_piece`] made a self-crossing outline simple.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OutlineRepair {
    /// The looping stretch's turning reduced ([`BffOptions::boundary_relief`]).
    Uncurled(BoundaryRelief),
    /// The whole boundary curvature smoothed ([`BffOptions::boundary_smoothing`]).
    Smoothed {
        /// The smoothing used.
        smoothing: f64,
    },
    /// Neither made it simple: the piece mapped onto a disk ([`convex_flattening`]), simple
    /// and unfolded by construction, but distorted.
    Convex,
}

/// Flattens one disk-shaped piece by BFF ([`bff_flatten`](crate::bff::bff_flatten)). Flipped
/// triangles: retried with a stronger cotangent floor, then untangled. Flipped triangles, or a
/// flattening over `limits`: flattened again on the intrinsic Delaunay triangulation, kept if
/// less distorted. An outline that crosses itself, which cannot be cut (BFF lays the boundary
/// out from its curvature, and where a patch nearly pinches, e.g. three sharp corners in a
/// row, the curve can loop over itself with every triangle positive): flattened again with the
/// looping stretch's turning reduced ([`BffOptions::boundary_relief`], the least fraction that
/// makes the outline simple without more flipped triangles), or failing that with the whole
/// boundary curvature smoothed ([`BffOptions::boundary_smoothing`]). The curve is closed by turning
/// ([`BffOptions::exact_lengths`]), so the boundary lengths are kept and the seams still match
/// (should that closing fail, the best-fit curve changes them by up to a few percent near the
/// loop); the triangles along the loop take the distortion. Should neither make it simple, the
/// piece is mapped onto a disk ([`convex_flattening`], [`OutlineRepair::Convex`]). Simple means
/// missing itself by 10⁻⁹ of the perimeter ([`outline_crossing`]).
///
/// # Errors
/// Those of [`bff_flatten`](crate::bff::bff_flatten) on the first flattening.
pub fn flatten_piece(pm: &Mesh, bff: &BffOptions, limits: &DistortionLimits) -> Result<PieceFlattening, FlattenError> {
    // The prepared problem an outline repair re-flattens from: its interior Laplacian is
    // factored once for the first flattening and every repair candidate.
    let mut problem = BffProblem::new(pm, bff)?;
    let mut flat = problem.flatten(bff.boundary_relief, bff.boundary_smoothing)?;
    let (mut retried, mut repaired_vertices) = (false, 0);
    if flat.stats.flipped_triangles > 0 {
        retried = true;
        let stronger = BffOptions { cotan_area_floor: bff.cotan_area_floor.max(1e-6), ..bff.clone() };
        // Kept with its prepared problem, so that an outline repair below starts from it.
        if let Ok(p2) = BffProblem::new(pm, &stronger)
            && let Ok(f2) = p2.flatten(stronger.boundary_relief, stronger.boundary_smoothing)
            && f2.stats.flipped_triangles < flat.stats.flipped_triangles
        {
            flat = f2;
            problem = p2;
        }
        repaired_vertices += untangle_flattening(pm, &mut flat);
    }
    // Flipped triangles or badly distorted (obtuse slivers make negative cotan weights, and the
    // map shears or folds): again on the intrinsic Delaunay triangulation, kept if less
    // distorted with no more flips.
    let mut intrinsic_delaunay = false;
    if (retried || limits.exceeded_by(&flat.stats)) && !bff.intrinsic_delaunay {
        let idt = BffOptions { intrinsic_delaunay: true, ..bff.clone() };
        if let Ok(p2) = BffProblem::new(pm, &idt)
            && let Ok(mut f2) = p2.flatten(idt.boundary_relief, idt.boundary_smoothing)
        {
            let moved = untangle_flattening(pm, &mut f2);
            if f2.stats.flipped_triangles <= flat.stats.flipped_triangles && f2.stats.qc_mean < flat.stats.qc_mean {
                flat = f2;
                repaired_vertices += moved;
                problem = p2;
                intrinsic_delaunay = true;
            }
        }
    }
    let outline: Vec<VertexId> = pm.boundary_loops()[0].iter().map(|&h| pm.tail(h)).collect();
    let mut outline_repair = None;
    let crossing = outline_crossing(&flat.uv, &outline);
    if let Some((i, j)) = crossing {
        // A candidate re-flattening is taken if its outline is simple with no more flipped
        // triangles (after untangling). The candidates change only the boundary curvature, so
        // they reuse the problem's factor.
        let try_with = |relief: Option<BoundaryRelief>, smoothing: f64| -> Option<(Flattening, usize)> {
            let mut f2 = problem.flatten(relief, smoothing).ok()?;
            let moved = untangle_flattening(pm, &mut f2);
            (f2.stats.flipped_triangles <= flat.stats.flipped_triangles && outline_crossing(&f2.uv, &outline).is_none())
                .then_some((f2, moved))
        };
        // First the stretch of outline between the two crossing edges, the shorter way round
        // (the loop), is uncurled: its turning reduced step by step, the rest of the outline
        // bending a little to close the curve. Edge i ends at vertex i + 1 and edge j starts
        // at vertex j: the stretch is vertices i + 1 ..= j, or the other way round j + 1 ..= i.
        let n = outline.len();
        let arc = |a: usize, b: usize| -> f64 {
            let (mut len, mut k) = (0.0, a);
            while k != b {
                len += (flat.uv[outline[(k + 1) % n]] - flat.uv[outline[k]]).norm();
                k = (k + 1) % n;
            }
            len
        };
        let (first, last) =
            if arc((i + 1) % n, j) <= arc((j + 1) % n, i) { ((i + 1) % n, j) } else { ((j + 1) % n, i) };
        let uncurled = RELIEF_FRACTIONS.iter().find_map(|&fraction| {
            let relief = BoundaryRelief { first, last, fraction };
            try_with(Some(relief), bff.boundary_smoothing).map(|r| (r, OutlineRepair::Uncurled(relief)))
        });
        // Then, if that does not do, the whole boundary curvature is smoothed.
        let repaired = uncurled.or_else(|| {
            OUTLINE_SMOOTHING.iter().find_map(|&smoothing| {
                try_with(bff.boundary_relief, smoothing).map(|r| (r, OutlineRepair::Smoothed { smoothing }))
            })
        });
        if let Some(((f2, moved), how)) = repaired {
            flat = f2;
            repaired_vertices += moved;
            outline_repair = Some(how);
        } else if let Some(f2) = convex_flattening(pm, &outline)
            && f2.stats.flipped_triangles == 0
            && outline_crossing(&f2.uv, &outline).is_none()
        {
            flat = f2;
            outline_repair = Some(OutlineRepair::Convex);
        }
    }
    let outline_simple = crossing.is_none() || outline_repair.is_some();
    Ok(PieceFlattening {
        flattening: flat,
        outline,
        retried,
        repaired_vertices,
        outline_repair,
        outline_simple,
        intrinsic_delaunay,
    })
}

/// [`untangle`] a flattening that has flipped triangles, its statistics updated; returns the
/// vertices moved (0 when nothing was flipped).
fn untangle_flattening(pm: &Mesh, flat: &mut Flattening) -> usize {
    if flat.stats.flipped_triangles == 0 {
        return 0;
    }
    let moved = untangle(pm, &mut flat.uv);
    flat.stats = distortion(pm, &flat.uv);
    moved
}

/// Fractions of a looping stretch's turning taken off, in order ([`BffOptions::boundary_relief`]).
const RELIEF_FRACTIONS: [f64; 20] =
    [0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 1.0];

/// Boundary smoothings tried, in order, on an outline that crosses itself (dimensionless, see
/// [`BffOptions::boundary_smoothing`]; the last ones are nearly a circle).
const OUTLINE_SMOOTHING: [f64; 12] = [1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 1.0];

/// The last resort for an outline that no re-flattening makes simple (a patch of a mold far
/// too soft for its load, where BFF's boundary curve loops over itself however its curvature is
/// relieved): Tutte's embedding, every interior vertex at the mean of its neighbours, with the
/// outline on a circle, each boundary edge taking the share of the circle its 3D length takes
/// of the boundary's, the radius such that the chords add up to the boundary's length. With a
/// convex outline and positive weights no triangle folds and the outline cannot cross itself
/// (Tutte 1963; Floater 2003), so the piece can be cut and its seams keep their total length
/// (each edge within the chord-to-arc spread of the others); its inside is distorted. `None` if the outline has no length or the solve fails.
pub fn convex_flattening(pm: &Mesh, outline: &[VertexId]) -> Option<Flattening> {
    use clothcast_mesh::sparse::{CholeskySolver, SymmetricPattern};
    use std::f64::consts::{PI, TAU};
    let n = outline.len();
    let lens: Vec<f64> = (0..n).map(|k| (pm.position(outline[(k + 1) % n]) - pm.position(outline[k])).norm()).collect();
    let total: f64 = lens.iter().sum();
    if n < 3 || !(total > 0.0 && total.is_finite()) {
        return None;
    }
    // The radius at which the chords, not the arcs, add up to the boundary's length.
    let chords = |r: f64| lens.iter().map(|l| 2.0 * r * (PI * l / total).sin()).sum::<f64>();
    let radius = total / chords(1.0);
    if !(radius.is_finite() && radius > 0.0) {
        return None;
    }
    let mut uv: VertexData<Vec2> = VertexData::from_vec(vec![Vec2::zeros(); pm.n_vertices()]);
    let mut on_outline = vec![false; pm.n_vertices()];
    let mut s = 0.0;
    for (k, &v) in outline.iter().enumerate() {
        let a = TAU * s / total;
        uv[v] = Vec2::new(radius * a.cos(), radius * a.sin());
        on_outline[v.idx()] = true;
        s += lens[k];
    }
    let interior: Vec<VertexId> = pm.vertices().filter(|v| !on_outline[v.idx()]).collect();
    if !interior.is_empty() {
        let mut index = vec![usize::MAX; pm.n_vertices()];
        for (i, v) in interior.iter().enumerate() {
            index[v.idx()] = i;
        }
        let rings: Vec<Vec<VertexId>> = interior.iter().map(|&v| pm.vertex_neighbors(v)).collect();
        let pattern = SymmetricPattern::from_entries(
            interior.len(),
            rings.iter().enumerate().flat_map(|(i, ring)| {
                let index = &index;
                ring.iter().filter(|u| index[u.idx()] != usize::MAX).map(move |u| (i, index[u.idx()]))
            }),
        );
        let mut values = vec![0.0; pattern.nnz()];
        let (mut bx, mut by) = (vec![0.0; interior.len()], vec![0.0; interior.len()]);
        for (i, ring) in rings.iter().enumerate() {
            values[pattern.slot(i, i)] = ring.len() as f64;
            for &u in ring {
                match index[u.idx()] {
                    usize::MAX => {
                        bx[i] += uv[u].x;
                        by[i] += uv[u].y;
                    }
                    j if j < i => values[pattern.slot(i, j)] = -1.0,
                    _ => {}
                }
            }
        }
        let factor = CholeskySolver::new(&pattern).ok()?.factor(&pattern, &values).ok()?;
        factor.solve_in_place(&mut bx);
        factor.solve_in_place(&mut by);
        for (i, &v) in interior.iter().enumerate() {
            uv[v] = Vec2::new(bx[i], by[i]);
        }
    }
    // The circle runs the way the outline does; the faces must keep their orientation.
    if distortion(pm, &uv).area_ratio < 0.0 {
        for v in pm.vertices() {
            uv[v].y = -uv[v].y;
        }
    }
    let stats = distortion(pm, &uv);
    Some(Flattening { uv, stats })
}

/// The first pair of outline edges that cross, touch or come within a hair of each other in the
/// layout `uv` (edge i joins outline vertices i and i + 1), `None` for a simple outline.
pub fn outline_crossing(uv: &VertexData<Vec2>, outline: &[VertexId]) -> Option<(usize, usize)> {
    let poly: Vec<[f64; 2]> = outline.iter().map(|&v| [uv[v].x, uv[v].y]).collect();
    // With a margin of 10⁻⁹ of the perimeter: an outline that only just misses itself here
    // could cross once the piece is turned onto the warp and written in millimetres.
    let eps = OUTLINE_MARGIN * clothcast_mesh::polygon::perimeter(&poly);
    clothcast_mesh::polygon::find_self_intersection_within(&poly, eps)
}

/// The margin by which a flattened outline must miss itself, relative to its perimeter
/// ([`outline_crossing`]).
const OUTLINE_MARGIN: f64 = 1e-9;

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// A piece bounded by one seam alone (a closed loop): one run round the whole outline,
    /// starting and ending where the seam starts, whichever outline vertex comes first; a seam
    /// met partly gives an ordinary run.
    #[test]
    fn a_closed_seam_is_one_run_from_its_start() {
        let n = 6;
        let outline: Vec<VertexId> = (0..n).map(VertexId::new).collect();
        let seg_vertex: VertexData<VertexId> = (0..n).map(|i| VertexId::new((i + 2) % n)).collect();
        let uv: VertexData<Vec2> = (0..n)
            .map(|i| {
                let a = i as f64 * TAU / n as f64;
                Vec2::new(a.cos(), a.sin())
            })
            .collect();
        // Seam 3 walks the loop of segmented vertices 4 → 3 → 2 → 1 → 0 → 5 → 4, against the
        // outline's order.
        let chain: Vec<VertexId> = [4, 3, 2, 1, 0, 5, 4].into_iter().map(VertexId::new).collect();
        let seam_edge: HashMap<(VertexId, VertexId), usize> = chain.windows(2).map(|w| ((w[0], w[1]), 3)).collect();
        let runs = seam_runs(&uv, &outline, &seg_vertex, &seam_edge, |_| Some(VertexId::new(4)));
        assert_eq!(runs.len(), 1, "{runs:?}");
        // Outline vertex 2 is segmented vertex 4, where the seam starts.
        assert_eq!((runs[0].seam, runs[0].start, runs[0].end, runs[0].forward), (3, 2, 2, false));
        assert!((runs[0].length - 6.0).abs() < 1e-12);
        // Half of the loop a seam: one run over outline edges 5, 0 and 1.
        let half: HashMap<(VertexId, VertexId), usize> = chain[..4].windows(2).map(|w| ((w[0], w[1]), 3)).collect();
        let runs = seam_runs(&uv, &outline, &seg_vertex, &half, |_| Some(VertexId::new(4)));
        assert_eq!(runs.iter().map(|r| (r.start, r.end)).collect::<Vec<_>>(), vec![(5, 2)], "{runs:?}");
    }
}
