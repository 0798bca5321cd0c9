//! Stage 4: flattening, orientation and sewing patterns (`patterns/pattern.svg`, `.dxf`,
//! `.pdf`, `pattern_a4.pdf`, `flattened.obj`; summary `flattening` and `patterns`).

use crate::config::Config;
use crate::failure::{Blame, Failure};
use crate::input::Input;
use crate::progress::Progress;
use anyhow::Context;
use clothcast_field::FieldResult;
use clothcast_flatten::{DistortionLimits, FlatPieces, FlattenOptions, WarpAlong, flatten_segmentation};
use clothcast_layout::Segmentation;
use clothcast_mesh::io::{ObjUvs, write_atomic, write_obj};
use clothcast_mesh::{FaceData, Vec2, Vec3, VertexData, VertexId};
use clothcast_pattern::{
    MarkKind, Pattern, PatternOptions, Piece, PieceInput, PointMark, SeamSide, all_writers, build_pattern,
};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// The `patterns` section of `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct PatternsSummary {
    /// Pieces to cut.
    pub pieces: usize,
    /// Seams (each with two sides).
    pub seams: usize,
    /// Match marks over all pieces.
    pub notches: usize,
    /// Roll width (mm).
    pub fabric_width_mm: f64,
    /// Roll length used (mm).
    pub fabric_length_mm: f64,
    /// Piece (cut) area / used roll area.
    pub utilisation: f64,
    /// Sum of the pieces' sew-line areas (mm²), to compare with the target's area.
    pub pieces_area_mm2: f64,
    /// Labels (areas, marks' and seams' labels) that found no place clear of the piece's other
    /// texts and marks, inside its sewing line or in its seam allowance (on tiny pieces).
    pub labels_crowded: usize,
    /// The files written (relative to the output directory).
    pub files: Vec<String>,
    /// Times the patches were laid out again, smaller, because a piece did not fit the roll.
    pub layout_retries: usize,
    /// Layouts made again to split pieces that came out badly distorted
    /// (`flattening.distorted_pieces`), at most two.
    pub distortion_retries: usize,
    /// Layouts made again with a seam through the cone-like tips of pieces shrunk around them
    /// (`[layout] cone_cuts`; 0 or 1; `segmentation.cone_cuts` says whether it was kept).
    pub cone_retries: usize,
    /// Seconds.
    pub seconds: f64,
}

/// What the stage produces.
pub struct PatternsResult {
    /// The flattened pieces.
    pub flat: FlatPieces,
    /// The patterns.
    pub pattern: Pattern,
    /// Summary section.
    pub summary: PatternsSummary,
}

impl PatternsResult {
    /// The pattern piece of a flattened patch.
    pub fn piece(&self, patch: u32) -> Result<&Piece, Failure> {
        self.pattern
            .pieces
            .iter()
            .find(|q| q.id == patch as usize)
            .ok_or_else(|| Failure::Internal(anyhow::anyhow!("patch {patch} has no pattern piece")))
    }
}

/// A point of a flattened piece (metres, piece coordinates) where it lies on the roll (mm).
pub fn on_roll_mm(piece: &Piece, uv: &Vec2) -> [f64; 2] {
    piece.to_roll([uv.x * 1000.0, uv.y * 1000.0])
}

/// Warn about every badly distorted piece of a flattening (`flattening.distorted_pieces`).
pub fn warn_distorted(r: &clothcast_flatten::FlattenReport, cfg: &Config) {
    for p in r.per_piece.iter().filter(|p| r.distorted_pieces.contains(&p.patch)) {
        tracing::warn!(
            "piece {id} (P{id}) is badly distorted once flattened (area ratio {:.3}–{:.1}, mean quasi-conformal ratio \
             {:.2}; limits [pattern] max_area_spread = {}, max_qc_mean = {}): the fabric cannot follow the target \
             there; a sharp corner or sliver triangles inside the piece are the usual cause (round or remesh the \
             target there)",
            p.area_ratio_min,
            p.area_ratio_max,
            p.qc_mean,
            cfg.pattern.max_area_spread,
            cfg.pattern.max_qc_mean,
            id = p.patch
        );
    }
}

/// Label of a seam: a letter and a number (A1…A99, B1…).
pub fn seam_label(id: usize) -> String {
    let letter = (b'A' + ((id / 99) % 26) as u8) as char;
    format!("{letter}{}", id % 99 + 1)
}

/// Pieces wider than the roll (the pattern stage's `PieceTooWide`), with how much too wide:
/// the `run` command lays the patches out again, those split, when it sees this.
#[derive(Debug)]
pub struct TooWide {
    /// The message for the user.
    pub message: String,
    /// Each piece (patch id) too wide, with its width across the roll over the roll's (> 1).
    pub pieces: Vec<(u32, f64)>,
}

impl std::fmt::Display for TooWide {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for TooWide {}

/// A setting's value as the configuration spells it (serde's kebab-case).
fn config_name(value: impl Serialize) -> String {
    serde_json::to_value(value).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_default()
}

/// Flatten, orient, build the patterns.
pub fn run(
    cfg: &Config,
    input: &Input,
    field: &FieldResult,
    seg: &Segmentation,
    progress: &Progress,
) -> Result<PatternsResult, Failure> {
    let t0 = Instant::now();
    let stage = progress.stage("flattening the patches");
    let anisotropy: FaceData<f64> = seg.face_parent.map(|&f| field.raw.anisotropy[f]);
    // The raw field's major direction (the largest principal stretch) of each target face, in
    // 3D: a segmented face lies in the plane of the target face it came from.
    let major: FaceData<Vec3> = seg.face_parent.map(|&f| input.mesh.face_frame(f).direction(field.raw.angle[f]));
    let opts = FlattenOptions {
        orientation: cfg.pattern.orientation,
        warp_along: cfg.pattern.warp_along,
        match_area: cfg.pattern.match_area,
        limits: DistortionLimits { qc_mean: cfg.pattern.max_qc_mean, area_spread: cfg.pattern.max_area_spread },
        ..Default::default()
    };
    let flat = flatten_segmentation(seg, &anisotropy, &major, &opts).internal()?;
    drop(stage);
    let r = &flat.report;
    progress.say(format!(
        "flattening: {} pieces, {} flipped triangles, area {:.1}% of the target before scaling by {:.4}, area ratio {:.3}–{:.3}, qc mean {:.4} max {:.3}, seam length mismatch {:.2}%, fibre alignment median {:.1}° (orientation \"{}\"; the other rule: {:.1}°), major stretch nearer the warp on {:.0}% (warp_along \"{}\"), {:.2} s",
        flat.patches.len(),
        r.flipped_triangles,
        100.0 * r.area_ratio_bff,
        r.area_scale,
        r.area_ratio_min,
        r.area_ratio_max,
        r.qc_mean,
        r.qc_max,
        100.0 * r.seam_length_mismatch_max_rel,
        r.fiber_alignment_median_deg,
        config_name(cfg.pattern.orientation),
        r.fiber_alignment_other_rule_deg,
        100.0 * r.major_on_warp_share,
        config_name(cfg.pattern.warp_along),
        r.seconds
    ));

    let stage = progress.stage("building the patterns");
    let t1 = Instant::now();
    let marks = marks_per_piece(cfg, input, seg, &flat)?;
    let mm = 1000.0;
    let pieces: Vec<PieceInput> = flat
        .patches
        .iter()
        .zip(&flat.runs)
        .zip(marks)
        .map(|((p, runs), marks)| PieceInput {
            id: p.patch as usize,
            name: format!("P{}", p.patch),
            outline: p.outline.iter().map(|&v| [p.uv[v].x * mm, p.uv[v].y * mm]).collect(),
            seams: runs
                .iter()
                .map(|r| SeamSide {
                    seam: r.seam,
                    label: seam_label(r.seam),
                    start: r.start,
                    end: r.end,
                    forward: r.forward,
                })
                .collect(),
            marks,
        })
        .collect();
    let popts = PatternOptions {
        seam_allowance_mm: cfg.pattern.seam_allowance_mm,
        notch_spacing_mm: cfg.pattern.notch_spacing_mm,
        notch_length_mm: cfg.pattern.notch_length_mm,
        fabric_width_mm: cfg.pattern.fabric_width_mm,
        allow_weft_swap: cfg.pattern.allow_weft_swap,
        piece_gap_mm: cfg.pattern.piece_gap_mm,
        text_height_mm: cfg.pattern.text_height_mm,
    };
    let pattern = build_pattern(&pieces, &popts).map_err(|e| {
        // A piece wider than the roll is the user's choice of roll; anything else is ours.
        if let clothcast_pattern::PatternError::PieceTooWide { too_wide, .. } = &e {
            let more = match too_wide.len() {
                0 | 1 => String::new(),
                n => format!(" ({n} pieces too wide in all)"),
            };
            Failure::Input(anyhow::Error::new(TooWide {
                message: format!("{e}{more}; set [pattern] fabric_width_mm wider or allow_weft_swap = true"),
                pieces: too_wide.iter().map(|&(piece, ratio)| (piece as u32, ratio)).collect(),
            }))
        } else {
            pattern_failure("building the patterns", &e)
        }
    })?;
    drop(stage);
    let turned = pattern.pieces.iter().filter(|p| p.placement.rotation_deg % 180 == 90).count();
    if turned > 0 && cfg.pattern.warp_along != WarpAlong::Either {
        tracing::warn!(
            "{turned} of {} pieces lie turned by a quarter on the roll (allow_weft_swap = true), their warp and weft \
             exchanged: [pattern] warp_along = \"{}\" holds on the others only",
            pattern.pieces.len(),
            config_name(cfg.pattern.warp_along)
        );
    }
    let summary = PatternsSummary {
        pieces: pattern.pieces.len(),
        seams: pattern.stats.seams,
        notches: pattern.stats.notches,
        fabric_width_mm: pattern.fabric_width_mm,
        fabric_length_mm: pattern.fabric_length_mm,
        utilisation: pattern.utilisation,
        pieces_area_mm2: pattern.stats.area_mm2_total,
        labels_crowded: pattern.stats.labels_crowded,
        files: Vec::new(),
        layout_retries: 0,
        distortion_retries: 0,
        cone_retries: 0,
        seconds: t1.elapsed().as_secs_f64(),
    };
    progress.say(format!(
        "patterns: {} pieces, {} seams, {} notches, roll {:.0} × {:.0} mm, utilisation {:.0}%, {:.2} s (stage {:.2} s)",
        summary.pieces,
        summary.seams,
        summary.notches,
        summary.fabric_width_mm,
        summary.fabric_length_mm,
        100.0 * summary.utilisation,
        summary.seconds,
        t0.elapsed().as_secs_f64()
    ));
    Ok(PatternsResult { flat, pattern, summary })
}

/// Suspension/clamp points and the pour opening, on the pieces where they fall (a few per
/// piece: clamped vertices at least a notch spacing apart, at most 12).
fn marks_per_piece(
    cfg: &Config,
    input: &Input,
    seg: &Segmentation,
    flat: &FlatPieces,
) -> Result<Vec<Vec<PointMark>>, Failure> {
    let scenario = crate::stages::simulation::scenario(cfg, input, input.mesh.n_vertices())?;
    let constraints = clothcast_sim::scenario::suspension_constraints(&input.mesh, &scenario.suspension, &input.up)
        .map_err(|e| Failure::Input(anyhow::anyhow!("{e}")))?;
    // Segmented vertices that are clamped input vertices.
    let clamped: VertexData<bool> = seg.vertex_input.map(|v| v.is_some_and(|v| constraints.n_fixed(v) >= 3));
    // The pour opening: the highest point (of the mesh boundary for an open mold).
    let up: Vec3 = input.up;
    let height = |v: VertexId| seg.mesh.position(v).dot(&up);
    let boundary: Vec<VertexId> = seg.mesh.vertices().filter(|&v| seg.mesh.is_boundary_vertex(v)).collect();
    let pool: Vec<VertexId> = if boundary.is_empty() { seg.mesh.vertices().collect() } else { boundary };
    let pour = pool.into_iter().max_by(|a, b| height(*a).total_cmp(&height(*b)).then(b.cmp(a)));
    let spacing = cfg.pattern.notch_spacing_mm;
    let mut pour_placed = false;
    let mut out = Vec::with_capacity(flat.patches.len());
    for p in &flat.patches {
        let mut marks: Vec<PointMark> = Vec::new();
        let at = |v: VertexId| [p.uv[v].x * 1000.0, p.uv[v].y * 1000.0];
        // The pour mark first (on one piece only, where the seams split that vertex).
        if !pour_placed && let Some(v) = p.mesh.vertices().find(|&v| Some(p.seg_vertex[v]) == pour) {
            marks.push(PointMark { kind: MarkKind::Pour, position: at(v), label: "pour".into() });
            pour_placed = true;
        }
        for v in p.mesh.vertices() {
            let sv = p.seg_vertex[v];
            let pos = at(v);
            if clamped[sv] && marks.iter().filter(|m| m.kind == MarkKind::Clamp).count() < 12 {
                // Apart from the other clamps and from the pour mark (the pour opening at the top
                // is held too: its mark would be drawn over).
                let far = marks.iter().all(|m| {
                    let d = [m.position[0] - pos[0], m.position[1] - pos[1]];
                    (d[0] * d[0] + d[1] * d[1]).sqrt() >= spacing
                });
                if far {
                    marks.push(PointMark { kind: MarkKind::Clamp, position: pos, label: "clamp".into() });
                }
            }
        }
        out.push(marks);
    }
    Ok(out)
}

/// A pattern error as the run's failure: the user's, pointing to `[pattern]`, where the options
/// are to blame ([`clothcast_pattern::PatternError::is_option_error`]), else internal.
fn pattern_failure(doing: &str, e: &clothcast_pattern::PatternError) -> Failure {
    if e.is_option_error() {
        Failure::Input(anyhow::anyhow!("{doing}: {e} (see the [pattern] section)"))
    } else {
        Failure::Internal(anyhow::anyhow!("{doing}: {e}"))
    }
}

/// The directory of the pattern files, in the output directory.
const DIR: &str = "patterns";

/// The flattened pieces as a mesh, in [`DIR`].
const FLATTENED: &str = "flattened.obj";

/// The files this stage writes (relative to the output directory): the writers' and
/// `flattened.obj`, in `patterns/`.
pub fn files() -> Vec<String> {
    let mut files: Vec<String> = all_writers().iter().map(|w| format!("{DIR}/{}", w.file_name())).collect();
    files.push(format!("{DIR}/{FLATTENED}"));
    files
}

/// Write the pattern files into `out/patterns/` and `flattened.obj`; returns the file names
/// (relative to `out`, [`files`]).
pub fn write_outputs(
    out: &Path,
    input: &Input,
    seg: &Segmentation,
    r: &PatternsResult,
) -> Result<Vec<String>, Failure> {
    let dir = out.join(DIR);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display())).internal()?;
    for w in all_writers() {
        let path = dir.join(w.file_name());
        let mut buf: Vec<u8> = Vec::new();
        w.write(&r.pattern, &mut buf).map_err(|e| pattern_failure(&format!("writing {}", w.name()), &e))?;
        write_atomic(&path, |f| std::io::Write::write_all(f, &buf))
            .with_context(|| format!("cannot write {}", path.display()))
            .internal()?;
    }
    // flattened.obj: the segmented mesh (input units) with per-corner UVs in millimetres as laid
    // out on the roll, one group per patch.
    let positions: Vec<Vec3> = seg.mesh.positions().iter().map(|p| p / input.to_metres).collect();
    let mut uvs: Vec<[f64; 2]> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut face_uvs: Vec<[u32; 3]> = Vec::new();
    let mut groups: Vec<(String, Vec<u32>)> = Vec::new();
    for p in &r.flat.patches {
        let piece = r.piece(p.patch)?;
        let base = uvs.len() as u32;
        for v in p.mesh.vertices() {
            uvs.push(on_roll_mm(piece, &p.uv[v]));
        }
        let mut ids = Vec::with_capacity(p.mesh.n_faces());
        for f in p.mesh.face_ids() {
            let vs = p.mesh.face_vertices(f);
            ids.push(faces.len() as u32);
            faces.push(vs.map(|v| p.seg_vertex[v].0));
            face_uvs.push(vs.map(|v| base + v.0));
        }
        groups.push((format!("patch_{}", p.patch), ids));
    }
    let path = dir.join(FLATTENED);
    let header = "clothcast flattened patches: v = segmented target (input units), vt = piece coordinates in millimetres as laid out on the fabric roll (x along the roll = warp), one group per patch";
    write_atomic(&path, |w| {
        write_obj(w, header, &positions, &faces, Some(ObjUvs { uvs: &uvs, face_uvs: &face_uvs }), Some(&groups))
    })
    .with_context(|| format!("cannot write {}", path.display()))
    .internal()?;
    Ok(files())
}

/// A piece whose flattening shrank some triangle below this share of its area on the target
/// is searched for a cone-like tip to cut through ([`shrunk_tips`]). The README models at 0.5 m
/// stay above 0.17; spot at 0.3 m has a horn tip inside a piece at 0.047.
pub const SHRUNK_PIECE: f64 = 0.1;

/// Least angle defect of a tip worth a seam through it (radians; 20°).
const TIP_DEFECT: f64 = std::f64::consts::PI / 9.0;

/// The cone-like tips inside the pieces the flattening shrank (a triangle at under
/// [`SHRUNK_PIECE`] of its area): per such piece, of the corners of its most shrunk triangle
/// and their neighbours inside the piece, the input vertex with the largest angle defect (at
/// least 20°); a flattening shrinks the fabric most at such a tip. Vertices of the input mesh,
/// largest defect first.
pub fn shrunk_tips(seg: &Segmentation, p: &PatternsResult) -> Vec<VertexId> {
    let mesh = &seg.mesh;
    let defects = mesh.angle_defects();
    let mut tips: Vec<(f64, VertexId)> = Vec::new();
    for fp in p.flat.patches.iter().filter(|fp| fp.stats.area_ratio_min < SHRUNK_PIECE) {
        let ratio = |f| {
            let [a, b, c] = fp.mesh.face_vertices(f).map(|v| fp.uv[v]);
            0.5 * (b - a).perp(&(c - a)) / fp.mesh.face_area(f).max(f64::MIN_POSITIVE)
        };
        let Some(worst) = fp.mesh.face_ids().min_by(|&x, &y| ratio(x).total_cmp(&ratio(y))) else { continue };
        // Inside the piece: every face around it on this piece, off the mesh's boundary.
        let inside = |v: VertexId| {
            !mesh.is_boundary_vertex(v) && mesh.outgoing(v).all(|h| seg.patch_of_face[mesh.face(h)] == fp.patch)
        };
        let mut near: Vec<VertexId> = Vec::new();
        for c in fp.mesh.face_vertices(worst) {
            let v = fp.seg_vertex[c];
            near.push(v);
            near.extend(mesh.outgoing(v).map(|h| mesh.head(h)));
        }
        let best = near
            .into_iter()
            .filter(|&v| seg.vertex_input[v].is_some() && inside(v))
            .map(|v| (defects[v], v))
            .filter(|&(d, _)| d >= TIP_DEFECT)
            .max_by(|x, y| x.0.total_cmp(&y.0).then(y.1.cmp(&x.1)));
        if let Some(t) = best {
            tips.push(t);
        }
    }
    tips.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
    tips.dedup_by_key(|t| t.1);
    tips.into_iter().map(|t| t.1).collect()
}
