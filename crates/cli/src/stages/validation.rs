//! Stage 6: the check (paper §7.4). The mold as it will be sewn: the segmented target's faces
//! with each one's rest shape its triangle on the cut pattern (at its size there, the piece
//! turned as it lies on the roll, so +u is the warp), of a woven fabric
//! ([`clothcast_sim::WovenFabric`]), filled and hung as in stage 1. Then how far the cast
//! deviates from the target (the paper's D_avg: each cast vertex's distance to the closest
//! point of the target) and how much the weave shears (`cast.ply`, summary `validation`).

use crate::config::{Config, SuspensionMode};
use crate::failure::{Blame, Failure};
use crate::input::Input;
use crate::progress::Progress;
use crate::stages::patterns::PatternsResult;
use anyhow::{Context, anyhow};
use clothcast_layout::Segmentation;
use clothcast_mesh::Vec2 as Vector2;
use clothcast_mesh::io::{Attribute, PlyFormat, write_atomic, write_ply};
use clothcast_mesh::simplify::ClosestPoint;
use clothcast_mesh::{FaceData, Mesh, Vec3, VertexData, VertexId};
use clothcast_sim::element::Element;
use clothcast_sim::{SimResult, Suspension, WovenFabric, simulate_sewn};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// A face shears "visibly" beyond this angle between its yarns' right angle (degrees).
const VISIBLE_SHEAR_DEG: f64 = 5.0;

/// The woven fabric the check used (N/m).
#[derive(Clone, Debug, Serialize)]
pub struct FabricSummary {
    /// Tensile stiffness along the warp.
    pub warp_stiffness: f64,
    /// Tensile stiffness along the weft.
    pub weft_stiffness: f64,
    /// In-plane shear modulus.
    pub shear_modulus: f64,
    /// A yarn's stiffness in compression over its tensile stiffness.
    pub compression_ratio: f64,
}

/// The `validation` section of `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ValidationSummary {
    /// The sewn mold's solve converged (when not, the figures below are of its last iterate).
    pub converged: bool,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Relative residual force at the end.
    pub residual_rel: f64,
    /// The fabric.
    pub fabric: FabricSummary,
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
    /// model): what the infill's stretch alone gives, for comparison.
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
    /// Largest stretch along the warp (1: unstretched).
    pub warp_stretch_max: f64,
    /// Largest stretch along the weft.
    pub weft_stretch_max: f64,
    /// The Newton solver's details (as `simulation.solver`).
    pub solver: clothcast_sim::newton::SolveStats,
    /// Seconds.
    pub seconds: f64,
}

/// What the stage produces.
pub struct ValidationResult {
    /// The cast (the sewn mold's equilibrium), on the segmented mesh.
    pub positions: VertexData<Vec3>,
    /// Per vertex: signed distance from the target (m, outward positive).
    pub deviation: Vec<f64>,
    /// Per face: shear (degrees), warp and weft stretch.
    pub shear_deg: Vec<f64>,
    /// Per face: stretch along the warp.
    pub warp_stretch: Vec<f64>,
    /// Per face: stretch along the weft.
    pub weft_stretch: Vec<f64>,
    /// Summary section.
    pub summary: ValidationSummary,
}

/// The fabric of a configuration, or the input error naming what is wrong with it.
pub fn fabric(cfg: &Config) -> Result<WovenFabric, Failure> {
    let v = &cfg.validation;
    let warp = v.warp_stiffness.unwrap_or(cfg.material.youngs_modulus);
    let weft = v.weft_stiffness.unwrap_or(cfg.material.youngs_modulus);
    let mean = (warp * weft).sqrt();
    WovenFabric::new(warp, weft, v.shear_ratio * mean).map_err(|e| Failure::Input(anyhow!("[validation]: {e}")))
}

/// Each segmented face's triangle on its pattern piece as the piece lies on the roll (metres,
/// corners in the face's vertex order).
fn pattern_triangles(seg: &Segmentation, p: &PatternsResult) -> Result<FaceData<[Vector2; 3]>, Failure> {
    let mut rest: FaceData<Option<[Vector2; 3]>> = FaceData::from_vec(vec![None; seg.mesh.n_faces()]);
    for fp in &p.flat.patches {
        let piece = p
            .pattern
            .pieces
            .iter()
            .find(|q| q.id == fp.patch as usize)
            .ok_or_else(|| Failure::Internal(anyhow!("patch {} has no pattern piece", fp.patch)))?;
        for f in fp.mesh.face_ids() {
            let sf = fp.seg_face[f];
            let corners = fp.mesh.face_vertices(f);
            let mut tri = [Vector2::zeros(); 3];
            for (k, sv) in seg.mesh.face_vertices(sf).into_iter().enumerate() {
                let c = corners.iter().find(|&&c| fp.seg_vertex[c] == sv).ok_or_else(|| {
                    Failure::Internal(anyhow!("face {} of piece {} misses a corner of its face", f.idx(), fp.patch))
                })?;
                let q = piece.to_roll([fp.uv[*c].x * 1000.0, fp.uv[*c].y * 1000.0]);
                tri[k] = Vector2::new(q[0] / 1000.0, q[1] / 1000.0);
            }
            rest[sf] = Some(tri);
        }
    }
    let missing = rest.iter().position(Option::is_none);
    if let Some(f) = missing {
        return Err(Failure::Internal(anyhow!("segmented face {f} lies on no pattern piece")));
    }
    Ok(rest.map(|t| t.expect("checked")))
}

/// Signed distances of `points` from the surface of `target` (outward positive).
fn distances(target: &Mesh, cp: &ClosestPoint<'_>, points: &[Vec3]) -> Vec<f64> {
    let normals = target.face_normals();
    points
        .iter()
        .map(|p| {
            let hit = cp.query(p);
            let t = target.face_positions(hit.face);
            let on = t[0] * hit.weights[0] + t[1] * hit.weights[1] + t[2] * hit.weights[2];
            if (p - on).dot(&normals[hit.face]) < 0.0 { -hit.distance } else { hit.distance }
        })
        .collect()
}

/// Sew, fill and measure.
pub fn run(
    cfg: &Config,
    input: &Input,
    sim: &SimResult,
    seg: &Segmentation,
    patterns: &PatternsResult,
    progress: &Progress,
) -> Result<ValidationResult, Failure> {
    let t0 = Instant::now();
    let fabric = fabric(cfg)?;
    let rest = pattern_triangles(seg, patterns)?;
    let mut sc = crate::stages::simulation::scenario(cfg, input)?;
    if cfg.suspension.mode == SuspensionMode::Vertices {
        // The clamped target vertices, on the segmented mesh (every target vertex is one of its).
        let Suspension::Vertices(held) = &sc.suspension else { unreachable!("mode vertices") };
        let held: std::collections::HashSet<VertexId> = held.iter().copied().collect();
        sc.suspension = Suspension::Vertices(
            seg.mesh.vertices().filter(|&v| seg.vertex_input[v].is_some_and(|t| held.contains(&t))).collect(),
        );
    }
    // Started from stage 1's equilibrium, carried to the segmented mesh (its vertices lie on
    // the target: each takes the displacement of its point there).
    let cp = ClosestPoint::new(&input.mesh);
    let start: Vec<Vec3> = seg
        .mesh
        .positions()
        .iter()
        .map(|p| {
            let hit = cp.query(p);
            let t = input.mesh.face_vertices(hit.face);
            (0..3).map(|k| (sim.positions[t[k]] - input.mesh.position(t[k])) * hit.weights[k]).sum::<Vec3>() + p
        })
        .collect();
    let stage = progress.stage("checking: the sewn mold, filled");
    let result = simulate_sewn(&seg.mesh, &rest, Some(start), &fabric, &sc, &mut |it| {
        stage.set_message(format!("checking: Newton iteration {}, residual {:.1e}", it.iteration, it.residual_rel));
    })
    .map_err(|e| Failure::Internal(anyhow!("the check of the sewn mold: {e}")))?;
    drop(stage);
    let s = &result.stats;
    if !s.converged {
        let why = format!(
            "the check (the sewn mold, filled) did not converge ({:?} after {} Newton iterations, relative residual \
             {:.2e}): its figures in summary.json (validation) are of the last iterate; the patterns stand",
            s.termination, s.newton_iterations, s.residual_rel
        );
        tracing::warn!("{why}");
    }

    // Deviation from the target, of the cast and of stage 1's mold.
    let deviation = distances(&input.mesh, &cp, result.positions.as_slice());
    let design = distances(&input.mesh, &cp, sim.positions.as_slice());
    let n = deviation.len().max(1) as f64;
    let mean_abs = |d: &[f64]| d.iter().map(|x| x.abs()).sum::<f64>() / d.len().max(1) as f64;
    let max_abs = |d: &[f64]| d.iter().fold(0.0f64, |m, x| m.max(x.abs()));

    // The weave: per face, the warp and weft directions carried by the deformation.
    let (mut shear_deg, mut warp_stretch, mut weft_stretch) = (Vec::new(), Vec::new(), Vec::new());
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
    }
    let diagonal = input.mesh.bbox().diagonal();
    let summary = ValidationSummary {
        converged: s.converged,
        newton_iterations: s.newton_iterations,
        residual_rel: s.residual_rel,
        fabric: FabricSummary {
            warp_stiffness: fabric.warp,
            weft_stiffness: fabric.weft,
            shear_modulus: fabric.shear,
            compression_ratio: fabric.compression,
        },
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
        warp_stretch_max: warp_stretch.iter().copied().fold(0.0, f64::max),
        weft_stretch_max: weft_stretch.iter().copied().fold(0.0, f64::max),
        solver: s.solver.clone(),
        seconds: t0.elapsed().as_secs_f64(),
    };
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
    Ok(ValidationResult { positions: result.positions, deviation, shear_deg, warp_stretch, weft_stretch, summary })
}

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
    ];
    let comment = format!(
        "clothcast cast: the mold sewn from the patterns, filled (stage 6)\ncoordinates in input units ({} m per \
         unit); deviation: signed distance from the target in metres, outward positive\nshear_deg: warp-weft angle's \
         departure from 90 degrees; warp_stretch, weft_stretch: stretch along each yarn",
        input.to_metres
    );
    let path = out.join("cast.ply");
    write_atomic(&path, |w| write_ply(w, PlyFormat::BinaryLittleEndian, &comment, &pos, &tris, &vattr, &fattr))
        .with_context(|| format!("cannot write {}", path.display()))
        .internal()
}
