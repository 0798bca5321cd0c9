//! Stage 3: segmentation into patches (`segmentation.ply`, `seams.obj`, summary `segmentation`).

use crate::config::Config;
use crate::failure::{Blame, Failure};
use crate::input::Input;
use crate::progress::Progress;
use anyhow::Context;
use clothcast_field::FieldResult;
use clothcast_layout::{LayoutOptions, Segmentation, SplitHint, segment};
use clothcast_mesh::io::{Attribute, PlyFormat, write_atomic, write_ply};
use clothcast_mesh::{Vec3, VertexId};
use std::io::Write;
use std::path::Path;

/// How much longer than the roll's usable width a patch's extent may be before the layout
/// splits it (a first guess, see [`options`]).
const EXTENT_ALLOWANCE: f64 = 1.25;

/// The most pieces a roll may take before its width is refused as too narrow.
const MAX_PIECES: usize = 250;

/// True when the roll is so narrow that a mold of this area would take hundreds of pieces
/// (every piece at most about a disk as wide as the roll): a mistake in the scenario, refused
/// by [`run`].
pub fn roll_too_narrow(cfg: &Config, area_m2: f64) -> bool {
    let usable = cfg.pattern.usable_width_m();
    let least = area_m2 / (std::f64::consts::FRAC_PI_4 * (EXTENT_ALLOWANCE * usable).powi(2));
    !(usable > 0.0) || least > MAX_PIECES as f64
}

/// The library options from the scenario, with the patches to split further (`hints`, from
/// earlier layouts whose pieces did not fit the roll) and the tips to cut through (`cones`, from
/// an earlier layout's pieces shrunk around them).
pub fn options(cfg: &Config, hints: &[SplitHint], cones: &[VertexId]) -> LayoutOptions {
    let l = &cfg.layout;
    LayoutOptions {
        drift_penalty: l.drift_penalty,
        max_deviation_deg: l.max_deviation,
        capture_radius: l.capture_radius,
        smooth_seams: l.smooth_seams,
        pin_spacing: l.pin_spacing,
        follow_streamlines: l.follow_streamlines,
        merge: l.merge,
        late_repairs: l.late_repairs,
        max_developability: l.max_developability,
        min_patch_fraction: l.min_patch_fraction,
        snap: l.snap,
        max_splits: l.max_splits,
        // The layout's first guess at pieces that fit the roll with their seam allowance: a
        // patch's extent (its longest path) bounds its piece's width across the roll from
        // above, by more the less round it is; pieces that still do not fit once flattened are
        // split in a new layout (the `run` command).
        max_patch_extent: (cfg.pattern.usable_width_m() * EXTENT_ALLOWANCE).max(0.0),
        split_hints: hints.to_vec(),
        cone_cuts: cones.to_vec(),
        seed: cfg.seed,
    }
}

/// Segment the target along the field.
pub fn run(
    cfg: &Config,
    input: &Input,
    field: &FieldResult,
    hints: &[SplitHint],
    cones: &[VertexId],
    progress: &Progress,
) -> Result<Segmentation, Failure> {
    let (w, a) = (cfg.pattern.fabric_width_mm, cfg.pattern.seam_allowance_mm);
    let usable = cfg.pattern.usable_width_m();
    let area = input.mesh.total_area();
    if roll_too_narrow(cfg, area) {
        return Err(Failure::Input(anyhow::anyhow!(
            "the roll is too narrow for this mold: [pattern] fabric_width_mm = {w} mm less twice seam_allowance_mm \
             = {a} mm leaves {:.0} mm, and the target's {area:.3} m² would take over {MAX_PIECES} pieces; set \
             fabric_width_mm wider",
            1000.0 * usable
        )));
    }
    let stage = progress.stage("segmenting into patches");
    let seg = segment(&input.mesh, &field.field, &field.singularities, &options(cfg, hints, cones)).internal()?;
    drop(stage);
    let s = &seg.stats;
    progress.say(format!(
        "segmentation: {} patches ({:.0}% quads, {} tiny), {} seams {:.2} m, seam-field deviation median {:.1}°, developability max {:.2}, {} merges, {} splits, {:.2} s",
        s.patches,
        100.0 * s.quad_fraction,
        s.tiny_patches,
        seg.seams.len(),
        s.seam_length_m,
        s.seam_field_deviation_median_deg,
        s.developability_max,
        s.merges,
        s.splits,
        s.seconds
    ));
    if s.singularities_inside_patches > 0 {
        progress.say(format!("warning: {} singularities lie inside patches", s.singularities_inside_patches));
    }
    Ok(seg)
}

/// The files this stage writes in the output directory.
pub const FILES: [&str; 2] = ["segmentation.ply", "seams.obj"];

/// Write `segmentation.ply` (remeshed target, per-face `patch`) and `seams.obj` (one `o`
/// object per seam with `l` records).
pub fn write_outputs(out: &Path, input: &Input, seg: &Segmentation) -> Result<(), Failure> {
    let m = &seg.mesh;
    let pos: Vec<Vec3> = m.positions().iter().map(|p| p / input.to_metres).collect();
    let tris: Vec<[u32; 3]> = m.faces().iter().map(|t| t.map(|v| v.0)).collect();
    let patch: Vec<i32> = seg.patch_of_face.iter().map(|&p| p as i32).collect();
    let parent: Vec<i32> = seg.face_parent.iter().map(|f| input.face_to_input[f.idx()] as i32).collect();
    let fattr = [Attribute::i32("patch", patch), Attribute::i32("parent_face", parent)];
    let comment = "clothcast segmentation: the target remeshed along the seams; patch = patch id per face, parent_face = face of the input mesh containing it";
    let path = out.join(FILES[0]);
    write_atomic(&path, |w| write_ply(w, PlyFormat::BinaryLittleEndian, comment, &pos, &tris, &[], &fattr))
        .with_context(|| format!("cannot write {}", path.display()))
        .internal()?;

    let path = out.join(FILES[1]);
    write_atomic(&path, |w| {
        writeln!(w, "# clothcast seams: one object per seam, named seam_<id>_<patch a>_<patch b>,")?;
        writeln!(w, "# a polyline of the segmentation.ply vertices (same numbering, same units).")?;
        for p in &pos {
            writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
        }
        for (i, s) in seg.seams.iter().enumerate() {
            writeln!(w, "o seam_{}_{}_{}", i, s.patches[0], s.patches[1])?;
            write!(w, "l")?;
            for v in &s.vertices {
                write!(w, " {}", v.0 + 1)?;
            }
            writeln!(w)?;
        }
        Ok(())
    })
    .with_context(|| format!("cannot write {}", path.display()))
    .internal()
}
