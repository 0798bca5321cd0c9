//! Stage 6: the check (paper §7.4). The mold as it will be sewn: the segmented target's faces
//! with each one's rest shape its triangle on the cut pattern (at its size there, the piece
//! turned as it lies on the roll, so +u is the warp), of a woven fabric
//! ([`clothcast_sim::WovenFabric`]), filled and hung as in stage 1. Then how far the cast
//! deviates from the target (the paper's D_avg: each cast vertex's distance to the closest
//! point of the target) and how much the weave shears (`cast.ply`, summary `validation`).

use crate::config::{Config, SuspensionMode, WOR11_FABRICS};
use crate::failure::{Blame, Failure};
use crate::input::Input;
use crate::progress::Progress;
use crate::stages::patterns::{PatternsResult, on_roll_mm};
use anyhow::{Context, anyhow};
use clothcast_field::FieldResult;
use clothcast_flatten::WarpAlong;
use clothcast_layout::Segmentation;
use clothcast_layout::patches::edge_between;
use clothcast_mesh::Vec2 as Vector2;
use clothcast_mesh::io::{Attribute, PlyFormat, write_atomic, write_ply};
use clothcast_mesh::simplify::{ClosestHit, ClosestPoint};
use clothcast_mesh::{FaceData, FaceId, Mesh, Vec3, VertexData, VertexId};
use clothcast_sim::element::{Element, sym2_angle};
use clothcast_sim::{SimResult, Suspension, WovenFabric, simulate_sewn};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// A face shears "visibly" beyond this angle between its yarns' right angle (degrees).
const VISIBLE_SHEAR_DEG: f64 = 5.0;

/// A yarn stretched beyond this, or a cast deviating by more than this share of the target's
/// size on average, is warned about: the fabric is too soft for the mold (the default fabric
/// stays below 1.18 and 0.02 on the built-in example, 2.1 and 0.17 on the 2 m cube).
const TOO_SOFT_STRETCH: f64 = 2.5;
const TOO_SOFT_DEVIATION: f64 = 0.25;

/// Where the fabric stretches beyond [`TOO_SOFT_STRETCH`] on a face whose pattern triangle has
/// less than this share of the target's area, the pattern is blamed, not the fabric: the
/// flattening shrank the piece there (spot at 0.3 m with `[layout] cone_cuts = false`: a horn
/// tip of 60° angle defect inside a piece, cut at 5% of its area, stretched 4.9× by the default
/// fabric).
const SHRUNK_PATTERN: f64 = 0.5;

/// The woven fabric the check used (N/m).
#[derive(Clone, Debug, Serialize)]
pub struct FabricSummary {
    /// "constants" (`[validation]` stiffnesses) or the measured fabric's name or path.
    pub source: String,
    /// Tensile stiffness along the warp, at small strain.
    pub warp_stiffness: f64,
    /// Tensile stiffness along the weft, at small strain.
    pub weft_stiffness: f64,
    /// The warp's stiffness from a stretch of 7/6 on.
    pub warp_stiffness_stretched: f64,
    /// The weft's stiffness from a stretch of 7/6 on.
    pub weft_stiffness_stretched: f64,
    /// In-plane shear modulus.
    pub shear_modulus: f64,
    /// A yarn's stiffness in compression over its tensile stiffness.
    pub compression_ratio: f64,
    /// Axial stiffness of every seam (N); 0: seams no stiffer than the fabric.
    pub seam_stiffness: f64,
}

/// The `validation` section of `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ValidationSummary {
    /// The sewn mold's solve converged (when not, the figures below are of its last iterate).
    pub converged: bool,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// The iteration limit the check's solve had (`[solver] max_iterations`, or its default
    /// for the sewn mold's size).
    pub max_iterations: usize,
    /// Relative residual force at the end.
    pub residual_rel: f64,
    /// The fabric.
    pub fabric: FabricSummary,
    /// Pattern triangles folded over on their pieces, sewn mirrored.
    pub folded_triangles: usize,
    /// Faces and vertices of the sewn mold (the segmented target).
    pub faces: usize,
    /// Vertices.
    pub vertices: usize,
    /// Mean distance of the cast's vertices from the target surface (m): the paper's D_avg.
    pub deviation_mean_m: f64,
    /// Root mean square of that distance (m).
    pub deviation_rms_m: f64,
    /// Largest distance (m).
    pub deviation_max_m: f64,
    /// The mean signed distance (m), outward positive: how much the cast bulges on average.
    pub deviation_signed_mean_m: f64,
    /// The same mean for stage 1's mold (each target triangle its own panel, the isotropic
    /// model), measured at the same points (its equilibrium carried onto the segmented mesh):
    /// what the infill's stretch alone gives, for comparison.
    pub design_deviation_mean_m: f64,
    /// Largest distance of stage 1's mold from the target (m).
    pub design_deviation_max_m: f64,
    /// The cast's deviation over the target's bounding-box diagonal.
    pub deviation_mean_rel: f64,
    /// Area-weighted mean shear of the weave: the warp and weft's departure from a right angle
    /// (degrees).
    pub shear_mean_deg: f64,
    /// Largest shear (degrees).
    pub shear_max_deg: f64,
    /// Share of the fabric's area sheared by more than 5°.
    pub shear_over_5deg_share: f64,
    /// Median over the faces of the angle between the cast's largest principal stretch and
    /// stage 1's (the isotropic simulation's, which the field and the seams follow), in
    /// degrees: the paper's Table 2 measure of how far the woven fabric moves the strain
    /// directions.
    pub strain_direction_change_median_deg: f64,
    /// The same median over the faces stage 1 found anisotropic (whose directions the field
    /// keeps), or null when there are none.
    pub strain_direction_change_anisotropic_median_deg: Option<f64>,
    /// Largest stretch along the warp (1: unstretched).
    pub warp_stretch_max: f64,
    /// Largest stretch along the weft.
    pub weft_stretch_max: f64,
    /// Where a yarn stretches most: the face of `segmentation.ply` (and `cast.ply`), its piece,
    /// and the area of its triangle on the pattern against the target's (1: cut at the
    /// target's size; far below 1, the flattening shrank the piece there and the fabric must
    /// stretch to cover it).
    pub stretch_max_at: StretchSite,
    /// The Newton solver's details (as `simulation.solver`).
    pub solver: clothcast_sim::newton::SolveStats,
    /// Seconds.
    pub seconds: f64,
}

/// Where the check's yarns stretch most.
#[derive(Clone, Debug, Serialize)]
pub struct StretchSite {
    /// Face of `segmentation.ply`.
    pub face: usize,
    /// The face of the input mesh it lies in (numbered as in the input file).
    pub input_face: usize,
    /// Its piece (`P<piece>` on the patterns).
    pub piece: usize,
    /// The larger of its warp and weft stretches.
    pub stretch: f64,
    /// Its triangle's area on the pattern over its area on the target.
    pub pattern_area_ratio: f64,
}

/// The `validation` section of `summary.json`: the check's figures, or why it could not be
/// made (the run still succeeds: its patterns are written).
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum ValidationOutcome {
    /// The check ran (converged or not: see `converged`).
    Done(Box<ValidationSummary>),
    /// It failed before an equilibrium could be sought.
    Failed {
        /// What went wrong.
        error: String,
    },
}

/// What the stage produces.
pub struct ValidationResult {
    /// The cast (the sewn mold's equilibrium), on the segmented mesh.
    pub positions: VertexData<Vec3>,
    /// Per vertex: signed distance from the target (m, outward positive).
    pub deviation: Vec<f64>,
    /// Per face: the weave's shear (degrees).
    pub shear_deg: Vec<f64>,
    /// Per face: stretch along the warp.
    pub warp_stretch: Vec<f64>,
    /// Per face: stretch along the weft.
    pub weft_stretch: Vec<f64>,
    /// Per face: the angle between the cast's and stage 1's largest principal stretch
    /// (degrees).
    pub direction_change_deg: Vec<f64>,
    /// Summary section.
    pub summary: ValidationSummary,
}

/// A measured fabric in Wang et al. 2011's JSON layout (as ARCSim reads it).
#[derive(serde::Deserialize)]
struct Wor11 {
    stretching: Vec<Vec<f64>>,
}

/// The woven fabric of a measured WOR11 table, as ARCSim reads it (every stiffness doubled,
/// negative ones clamped to zero): the warp's small-strain stiffness k0 and the weft's k2 from
/// the rest row (0), their stretched ones from the rows along each yarn (1: 0°, 5: 90°), the
/// shear modulus k3/4 from the rest row. `Err` names what is wrong.
fn wor11_fabric(text: &str) -> Result<WovenFabric, String> {
    // A JSON object: serde would also take a bare array as the struct's fields in order.
    if !text.trim_start().starts_with('{') {
        return Err("not a WOR11 fabric file: expected a JSON object with a \"stretching\" table".into());
    }
    let t: Wor11 = serde_json::from_str(text).map_err(|e| format!("not a WOR11 fabric file: {e}"))?;
    if t.stretching.len() != 6 {
        return Err(format!(
            "\"stretching\" must be 6 rows of 4 stiffnesses (k0 k1 k2 k3), got {} rows",
            t.stretching.len()
        ));
    }
    if let Some((i, r)) = t.stretching.iter().enumerate().find(|(_, r)| r.len() != 4) {
        return Err(format!(
            "\"stretching\" must be 6 rows of 4 stiffnesses (k0 k1 k2 k3), row {i} has {} values",
            r.len()
        ));
    }
    let k = |row: usize, col: usize| 2.0 * t.stretching[row][col].max(0.0);
    WovenFabric::stiffening(k(0, 0), k(0, 2), k(1, 0), k(5, 2), k(0, 3) / 4.0)
}

/// The fabric of a configuration and where it came from, or the input error naming what is
/// wrong with it.
pub fn fabric(cfg: &Config) -> Result<(WovenFabric, String), Failure> {
    let v = &cfg.validation;
    if let Some(name) = &v.fabric {
        let text = match WOR11_FABRICS.iter().find(|(n, _)| n == name) {
            Some((_, t)) => (*t).to_string(),
            None => std::fs::read_to_string(name).map_err(|e| {
                Failure::Input(anyhow!(
                    "[validation] fabric = {name:?}: not a built-in fabric ({}) and not a readable file: {e}",
                    WOR11_FABRICS.map(|(n, _)| n).join(", ")
                ))
            })?,
        };
        let named = |e: String| Failure::Input(anyhow!("[validation] fabric = {name:?}: {e}"));
        let measured = wor11_fabric(&text).map_err(named)?;
        let scale =
            v.fabric_scale.unwrap_or_else(|| cfg.material.youngs_modulus / (measured.warp * measured.weft).sqrt());
        if !(scale.is_finite() && scale > 0.0) {
            return Err(named(format!(
                "its warp and weft stiffnesses ({:e}, {:e} N/m) cannot be scaled to [material] youngs_modulus = {} N/m \
                 (scale {scale:e}); is it a measured fabric?",
                measured.warp, measured.weft, cfg.material.youngs_modulus
            )));
        }
        let fabric = measured.scaled(scale).map_err(named)?;
        in_range(&fabric).map_err(named)?;
        return Ok((fabric, name.clone()));
    }
    let warp = v.warp_stiffness.unwrap_or(cfg.material.youngs_modulus);
    let weft = v.weft_stiffness.unwrap_or(cfg.material.youngs_modulus);
    let mean = (warp * weft).sqrt();
    let f =
        WovenFabric::new(warp, weft, v.shear_ratio * mean).map_err(|e| Failure::Input(anyhow!("[validation]: {e}")))?;
    in_range(&f)
        .map_err(|e| Failure::Input(anyhow!("[validation] (warp_stiffness, weft_stiffness, shear_ratio): {e}")))?;
    Ok((f, "constants".into()))
}

/// The check's fabric refused where a stiffness (small-strain, stretched, or shear) lies
/// outside the moduli accepted for `[material] youngs_modulus` (a scale or a file of 1e300
/// made the check's residual NaN, one of 1e-300 let the yarns stretch by 1100%).
fn in_range(f: &WovenFabric) -> Result<(), String> {
    let (lo, hi) = crate::config::MODULUS_RANGE;
    for (what, k) in [
        ("warp stiffness", f.warp),
        ("weft stiffness", f.weft),
        ("stretched warp stiffness", f.warp_stretched),
        ("stretched weft stiffness", f.weft_stretched),
    ] {
        if !(lo..=hi).contains(&k) {
            return Err(format!("the fabric's {what} is {k:e} N/m: it must lie in [{lo:e}, {hi:e}] N/m"));
        }
    }
    if !(f.shear <= hi && f.shear > 0.0) {
        return Err(format!(
            "the fabric's shear modulus is {:e} N/m: it must be positive, at most {hi:e} N/m",
            f.shear
        ));
    }
    Ok(())
}

/// Each segmented face's triangle on its pattern piece as the piece lies on the roll (metres,
/// corners in the face's vertex order), and how many were folded over on their piece (a
/// flipped triangle the flattening could not undo, warned about there): those are mirrored
/// across the warp (v → −v), which keeps their metric, C = FᵀF, and their yarn directions.
fn pattern_triangles(seg: &Segmentation, p: &PatternsResult) -> Result<(FaceData<[Vector2; 3]>, usize), Failure> {
    let mut folded = 0;
    let mut rest: FaceData<Option<[Vector2; 3]>> = FaceData::from_vec(vec![None; seg.mesh.n_faces()]);
    for fp in &p.flat.patches {
        let piece = p.piece(fp.patch)?;
        for f in fp.mesh.face_ids() {
            let sf = fp.seg_face[f];
            let corners = fp.mesh.face_vertices(f);
            let mut tri = [Vector2::zeros(); 3];
            for (k, sv) in seg.mesh.face_vertices(sf).into_iter().enumerate() {
                let c = corners.iter().find(|&&c| fp.seg_vertex[c] == sv).ok_or_else(|| {
                    Failure::Internal(anyhow!("face {} of piece {} misses a corner of its face", f.idx(), fp.patch))
                })?;
                let q = on_roll_mm(piece, &fp.uv[*c]);
                tri[k] = Vector2::new(q[0] / 1000.0, q[1] / 1000.0);
            }
            if (tri[1] - tri[0]).perp(&(tri[2] - tri[0])) < 0.0 {
                folded += 1;
                for q in &mut tri {
                    q.y = -q.y;
                }
            }
            rest[sf] = Some(tri);
        }
    }
    let missing = rest.iter().position(Option::is_none);
    if let Some(f) = missing {
        return Err(Failure::Internal(anyhow!("segmented face {f} lies on no pattern piece")));
    }
    Ok((rest.map(|t| t.expect("checked")), folded))
}

/// Signed distances of `points` from the surface of `target` (outward positive: the side of
/// the vertex normals interpolated at the closest point, which, unlike the closest face's
/// normal, is right where that point lies on an edge or a vertex).
fn distances(target: &Mesh, cp: &ClosestPoint<'_>, normals: &VertexData<Vec3>, points: &[Vec3]) -> Vec<f64> {
    points
        .iter()
        .map(|p| {
            let hit = cp.query(p);
            let vs = target.face_vertices(hit.face);
            let (mut on, mut n) = (Vec3::zeros(), Vec3::zeros());
            for k in 0..3 {
                on += target.position(vs[k]) * hit.weights[k];
                n += normals[vs[k]] * hit.weights[k];
            }
            if (p - on).dot(&n) < 0.0 { -hit.distance } else { hit.distance }
        })
        .collect()
}

/// Sew, fill and measure.
#[allow(clippy::too_many_arguments)] // the stage reads every earlier stage's result
pub fn run(
    cfg: &Config,
    (fabric, source): &(WovenFabric, String),
    input: &Input,
    sim: &SimResult,
    field: &FieldResult,
    seg: &Segmentation,
    patterns: &PatternsResult,
    progress: &Progress,
) -> Result<ValidationResult, Failure> {
    let t0 = Instant::now();
    // The stiffer yarn belongs along the largest stretch (README, The check).
    let (warp, weft) = (fabric.warp, fabric.weft);
    let against = match cfg.pattern.warp_along {
        WarpAlong::Major => weft > 1.2 * warp,
        WarpAlong::Minor => warp > 1.2 * weft,
        WarpAlong::Either => false,
    };
    if against {
        let (stiff, soft) = if weft > warp { ("weft", "warp") } else { ("warp", "weft") };
        tracing::warn!(
            "the fabric's {stiff} is {:.1} times as stiff as its {soft}, but [pattern] warp_along = \"{}\" puts the \
             {soft} along the mold's largest stretch: \"{}\" would put the stiffer yarn there",
            weft.max(warp) / weft.min(warp),
            if weft > warp { "major" } else { "minor" },
            if weft > warp { "minor" } else { "major" },
        );
    }
    let (rest, folded) = pattern_triangles(seg, patterns)?;
    if folded > 0 {
        tracing::warn!(
            "{folded} pattern triangles are folded over on their pieces (flattening.flipped_triangles): the check \
             sews them mirrored"
        );
    }
    let cp = ClosestPoint::new(&input.mesh);
    // Where each segmented vertex lies on the target (they all lie on it).
    let on_target: Vec<ClosestHit> = seg.mesh.positions().iter().map(|p| cp.query(p)).collect();
    // The iteration limit for the sewn mold's own size (its seams add vertices).
    let mut sc = crate::stages::simulation::scenario(cfg, input, seg.mesh.n_vertices())?;
    // Its steps solved less exactly than stage 1's (see the constant).
    sc.newton.single_step_tolerance = clothcast_sim::newton::SEWN_STEP_TOLERANCE;
    if cfg.suspension.mode == SuspensionMode::Vertices {
        // The clamped target vertices, on the segmented mesh (every target vertex is one of
        // its), and the vertices the segmentation inserted on an edge between two of them (a
        // seam ending on a clamped rim).
        let Suspension::Vertices(held) = &sc.suspension else { unreachable!("mode vertices") };
        let held: std::collections::HashSet<VertexId> = held.iter().copied().collect();
        let holds = |v: VertexId| match seg.vertex_input[v] {
            Some(t) => held.contains(&t),
            None => {
                let hit = &on_target[v.idx()];
                let on: Vec<VertexId> = input
                    .mesh
                    .face_vertices(hit.face)
                    .into_iter()
                    .zip(hit.weights)
                    .filter(|&(_, w)| w > 1e-9)
                    .map(|(t, _)| t)
                    .collect();
                on.len() <= 2 && on.iter().all(|t| held.contains(t))
            }
        };
        sc.suspension = Suspension::Vertices(seg.mesh.vertices().filter(|&v| holds(v)).collect());
    }
    // Started from stage 1's equilibrium, carried to the segmented mesh (its vertices lie on
    // the target: each takes the displacement of its point there).
    let start: Vec<Vec3> = seg
        .mesh
        .positions()
        .iter()
        .zip(&on_target)
        .map(|(p, hit)| {
            let t = input.mesh.face_vertices(hit.face);
            (0..3).map(|k| (sim.positions[t[k]] - input.mesh.position(t[k])) * hit.weights[k]).sum::<Vec3>() + p
        })
        .collect();
    // The seams: every edge of every seam chain, with the seam allowances' stiffness.
    let seam_stiffness = cfg
        .validation
        .seam_stiffness
        .unwrap_or_else(|| 2.0 * cfg.pattern.seam_allowance_mm / 1000.0 * (fabric.warp * fabric.weft).sqrt());
    let mut seams = Vec::new();
    for chain in &seg.seams {
        for w in chain.vertices.windows(2) {
            let e = edge_between(&seg.mesh, w[0], w[1]).ok_or_else(|| {
                Failure::Internal(anyhow!("seam vertices {} and {} share no edge", w[0].idx(), w[1].idx()))
            })?;
            seams.push((e, seam_stiffness));
        }
    }
    // Stage 1's mold measured like the cast: at the segmented mesh's vertices.
    let normals = input.mesh.vertex_normals();
    let design = distances(&input.mesh, &cp, &normals, &start);
    let stage = progress.stage("checking: the sewn mold, filled");
    let result = simulate_sewn(&seg.mesh, &rest, &seams, Some(start), fabric, &sc, &mut |it| {
        stage.set_message(format!("checking: Newton iteration {}, residual {:.1e}", it.iteration, it.residual_rel));
    })
    .map_err(|e| {
        let input_error = e.is_input_error();
        let e = anyhow!("{e} (vertices and faces numbered as in segmentation.ply)");
        if input_error { Failure::Input(e) } else { Failure::Internal(e) }
    })?;
    drop(stage);
    let s = &result.stats;
    if !s.converged {
        let why = format!(
            "the check (the sewn mold, filled) did not converge ({:?} after {} Newton iterations of {} allowed, \
             relative residual {:.2e}): its figures in summary.json (validation) are of the last iterate; the patterns \
             stand",
            s.termination, s.newton_iterations, s.max_iterations, s.residual_rel
        );
        tracing::warn!("{why}");
    }

    // Deviation from the target, of the cast and of stage 1's mold.
    let deviation = distances(&input.mesh, &cp, &normals, result.positions.as_slice());
    let n = deviation.len().max(1) as f64;
    let mean_abs = |d: &[f64]| d.iter().map(|x| x.abs()).sum::<f64>() / d.len().max(1) as f64;
    let max_abs = |d: &[f64]| d.iter().fold(0.0f64, |m, x| m.max(x.abs()));

    // The weave: per face, the warp and weft directions carried by the deformation.
    let (mut shear_deg, mut warp_stretch, mut weft_stretch) = (Vec::new(), Vec::new(), Vec::new());
    let mut turn = Vec::with_capacity(seg.mesh.n_faces());
    let (mut area, mut shear_area, mut visible) = (0.0, 0.0, 0.0);
    for f in seg.mesh.face_ids() {
        let e = Element::from_plane(&rest[f]).expect("checked by the solve");
        let k = e.kinematics(&seg.mesh.face_vertices(f).map(|v| result.positions[v]));
        let (lu, lv) = (k.f[0].norm(), k.f[1].norm());
        let g = (k.f[0].dot(&k.f[1]) / (lu * lv)).clamp(-1.0, 1.0).asin().to_degrees().abs();
        area += e.area;
        shear_area += e.area * g;
        if g > VISIBLE_SHEAR_DEG {
            visible += e.area;
        }
        shear_deg.push(g);
        warp_stretch.push(lu);
        weft_stretch.push(lv);
        // The cast's largest principal stretch, in the pattern's frame, carried onto the
        // target (the map from the face's pattern triangle to its place on the target), against
        // stage 1's on the target face the segmented face lies in: an angle between lines.
        let c = k.strain;
        let theta = sym2_angle(1.0 + 2.0 * c[0], c[2], 1.0 + 2.0 * c[1]);
        let u = Vector2::new(theta.cos(), theta.sin());
        let (tri, uv) = (seg.mesh.face_positions(f), &rest[f]);
        let (a, b) = (uv[1] - uv[0], uv[2] - uv[0]);
        let det = a.perp(&b);
        // Pattern coordinates of u in the triangle's edge basis, then the same edges in 3D.
        let (s1, s2) = (u.perp(&b) / det, a.perp(&u) / det);
        let cast = ((tri[1] - tri[0]) * s1 + (tri[2] - tri[0]) * s2).normalize();
        let parent = seg.face_parent[f];
        let iso = input.mesh.face_frame(parent).direction(field.raw.angle[parent]);
        turn.push((cast.dot(&iso).abs().min(1.0).acos().to_degrees(), field.anisotropic[parent]));
    }
    let median = |mut v: Vec<f64>| -> Option<f64> {
        v.sort_by(f64::total_cmp);
        (!v.is_empty()).then(|| v[v.len() / 2])
    };
    // Where a yarn stretches most (the first such face).
    let stretch_of = |i: usize| warp_stretch[i].max(weft_stretch[i]);
    let w = (0..warp_stretch.len()).fold(0, |w, i| if stretch_of(i) > stretch_of(w) { i } else { w });
    let wf = FaceId::new(w);
    let stretch_max_at = StretchSite {
        face: w,
        input_face: input.face_to_input[seg.face_parent[wf].idx()] as usize,
        piece: seg.patch_of_face[wf] as usize,
        stretch: stretch_of(w),
        pattern_area_ratio: Element::from_plane(&rest[wf]).expect("checked by the solve").area / seg.mesh.face_area(wf),
    };
    let diagonal = input.mesh.bbox().diagonal();
    let summary = ValidationSummary {
        converged: s.converged,
        newton_iterations: s.newton_iterations,
        max_iterations: s.max_iterations,
        residual_rel: s.residual_rel,
        fabric: FabricSummary {
            source: source.clone(),
            warp_stiffness: fabric.warp,
            weft_stiffness: fabric.weft,
            warp_stiffness_stretched: fabric.warp_stretched,
            weft_stiffness_stretched: fabric.weft_stretched,
            shear_modulus: fabric.shear,
            compression_ratio: fabric.compression,
            seam_stiffness,
        },
        folded_triangles: folded,
        faces: seg.mesh.n_faces(),
        vertices: seg.mesh.n_vertices(),
        deviation_mean_m: mean_abs(&deviation),
        deviation_rms_m: (deviation.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
        deviation_max_m: max_abs(&deviation),
        deviation_signed_mean_m: deviation.iter().sum::<f64>() / n,
        design_deviation_mean_m: mean_abs(&design),
        design_deviation_max_m: max_abs(&design),
        deviation_mean_rel: mean_abs(&deviation) / diagonal,
        shear_mean_deg: shear_area / area,
        shear_max_deg: shear_deg.iter().copied().fold(0.0, f64::max),
        shear_over_5deg_share: visible / area,
        strain_direction_change_median_deg: median(turn.iter().map(|t| t.0).collect()).unwrap_or(0.0),
        strain_direction_change_anisotropic_median_deg: median(turn.iter().filter(|t| t.1).map(|t| t.0).collect()),
        warp_stretch_max: warp_stretch.iter().copied().fold(0.0, f64::max),
        weft_stretch_max: weft_stretch.iter().copied().fold(0.0, f64::max),
        stretch_max_at,
        solver: s.solver.clone(),
        seconds: t0.elapsed().as_secs_f64(),
    };
    // A fabric far too soft for the load: the mold balloons (with the level held at the top,
    // the deeper it hangs the higher the pressure: there may be no equilibrium at all).
    let site = &summary.stretch_max_at;
    let stretch = site.stretch;
    if stretch > TOO_SOFT_STRETCH && site.pattern_area_ratio < SHRUNK_PATTERN {
        // Not the fabric: the pattern is too small there.
        tracing::warn!(
            "piece {p} (P{p}) is cut far smaller than the target around face {} of segmentation.ply (face {} of the \
             input): its pattern there has {:.0}% of the target's area, and the sewn fabric stretches up to {:.0}% to \
             cover it. The flattening shrank a strongly curved region inside the piece (flattening.per_piece \
             area_ratio_min), usually a cone-like tip, which only a seam ending at it flattens well: [layout] \
             cone_cuts (now {}) gives such a tip a dart where the flattening cut a triangle at under {} of its \
             area; otherwise round or blunt the target there, or lower [pattern] max_area_spread (now {}) to have \
             the layout split the piece",
            site.face,
            site.input_face,
            100.0 * site.pattern_area_ratio,
            100.0 * (stretch - 1.0),
            cfg.layout.cone_cuts,
            crate::stages::patterns::SHRUNK_PIECE,
            cfg.pattern.max_area_spread,
            p = site.piece
        );
    } else if stretch > TOO_SOFT_STRETCH || summary.deviation_mean_rel > TOO_SOFT_DEVIATION {
        tracing::warn!(
            "the check's fabric is too soft for this mold: it stretches up to {:.0}% and the cast deviates by {:.0}% of \
             the target's size on average; a stiffer fabric ([validation], or fabric_scale for a measured one), a lower \
             fill or supports",
            100.0 * (stretch - 1.0),
            100.0 * summary.deviation_mean_rel
        );
    }
    progress.say(format!(
        "check: the sewn mold {} in {} Newton iterations; the cast deviates from the target by {:.2} mm on average \
         (max {:.2} mm; stage 1's mold: {:.2} mm), weave shear {:.1}° on average (max {:.1}°, {:.0}% of the fabric \
         over 5°), {:.2} s",
        if s.converged { "converged" } else { "did NOT converge" },
        s.newton_iterations,
        summary.deviation_mean_m * 1e3,
        summary.deviation_max_m * 1e3,
        summary.design_deviation_mean_m * 1e3,
        summary.shear_mean_deg,
        summary.shear_max_deg,
        100.0 * summary.shear_over_5deg_share,
        summary.seconds
    ));
    let direction_change_deg = turn.iter().map(|t| t.0).collect();
    Ok(ValidationResult {
        positions: result.positions,
        deviation,
        shear_deg,
        warp_stretch,
        weft_stretch,
        direction_change_deg,
        summary,
    })
}

/// The files this stage writes in the output directory.
pub const FILES: [&str; 1] = ["cast.ply"];

/// Write `cast.ply`: the cast on the segmented mesh (input units), per vertex the signed
/// deviation from the target (m), per face the patch, the weave's shear (degrees) and the
/// stretch along warp and weft.
pub fn write_outputs(out: &Path, input: &Input, seg: &Segmentation, r: &ValidationResult) -> Result<(), Failure> {
    let pos: Vec<Vec3> = r.positions.iter().map(|p| p / input.to_metres).collect();
    let tris: Vec<[u32; 3]> = seg.mesh.faces().iter().map(|t| t.map(|v| v.0)).collect();
    let vattr = [Attribute::f64("deviation", r.deviation.clone())];
    let fattr = [
        Attribute::i32("patch", seg.patch_of_face.iter().map(|&p| p as i32).collect()),
        Attribute::f64("shear_deg", r.shear_deg.clone()),
        Attribute::f64("warp_stretch", r.warp_stretch.clone()),
        Attribute::f64("weft_stretch", r.weft_stretch.clone()),
        Attribute::f64("direction_change_deg", r.direction_change_deg.clone()),
    ];
    let comment = format!(
        "clothcast cast: the mold sewn from the patterns, filled (stage 6)\ncoordinates in input units ({} m per \
         unit); deviation: signed distance from the target in metres, outward positive\nshear_deg: warp-weft angle's \
         departure from 90 degrees; warp_stretch, weft_stretch: stretch along each yarn",
        input.to_metres
    );
    let path = out.join(FILES[0]);
    write_atomic(&path, |w| write_ply(w, PlyFormat::BinaryLittleEndian, &comment, &pos, &tris, &vattr, &fattr))
        .with_context(|| format!("cannot write {}", path.display()))
        .internal()
}

#[cfg(test)]
mod tests {
    use super::wor11_fabric;

    #[test]
    fn wor11_files_of_the_wrong_shape_are_named() {
        let row4 = "[1, 2, 3, 4]";
        let rows = |r: &str| format!("{{\"stretching\": [{}]}}", [r; 6].join(", "));
        assert!(wor11_fabric(&rows(row4)).is_ok());
        let e = wor11_fabric(&rows("[1, 2, 3, 4, 5]")).err().unwrap();
        assert!(e.contains("row 0 has 5 values"), "{e}");
        let e = wor11_fabric(&format!("[[{}]]", [row4; 6].join(", "))).err().unwrap();
        assert!(e.contains("JSON object"), "{e}");
    }
}
