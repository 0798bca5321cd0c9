//! Stage 2: the cross field (`strain_raw.ply`, `cross_field.ply`, summary `field`).

use crate::config::Config;
use crate::failure::{Blame, Failure};
use crate::input::Input;
use crate::progress::Progress;
use anyhow::Context;
use clothcast_field::{FieldOptions, FieldResult, compute_field};
use clothcast_mesh::Vec3;
use clothcast_mesh::io::{Attribute, PlyFormat, write_atomic, write_ply};
use clothcast_sim::SimResult;
use std::path::Path;

/// Compute the field from the simulation.
pub fn run(cfg: &Config, input: &Input, sim: &SimResult, progress: &Progress) -> Result<FieldResult, Failure> {
    let f = &cfg.field;
    let opts = FieldOptions {
        source: f.source,
        anisotropy_threshold: f.anisotropy_threshold,
        alpha: f.alpha,
        relax_radius: f.relax_radius,
        relax_merge_energy: f.relax_merge_energy,
    };
    let stage = progress.stage("computing the cross field");
    let r = compute_field(&input.mesh, Some(&sim.positions), &opts).internal()?;
    drop(stage);
    let s = &r.stats;
    progress.say(format!(
        "field ({:?}): {:.0}% anisotropic, singularities raw {} → smoothed {} → final {} ({} merged, {} cancelled), index sum {}, {:.2} s",
        s.source,
        100.0 * s.anisotropic_fraction,
        s.singularities_raw,
        s.singularities_smoothed,
        s.singularities_final,
        s.merged,
        s.cancelled,
        s.index_sum,
        s.seconds
    ));
    Ok(r)
}

/// The files this stage writes in the output directory.
pub const FILES: [&str; 2] = ["strain_raw.ply", "cross_field.ply"];

/// Write `strain_raw.ply` (raw directions) and `cross_field.ply` (final field, singularities).
pub fn write_outputs(out: &Path, input: &Input, r: &FieldResult) -> Result<(), Failure> {
    let m = &input.mesh;
    let pos: Vec<Vec3> = m.positions().iter().map(|p| p / input.to_metres).collect();
    let tris: Vec<[u32; 3]> = m.faces().iter().map(|t| t.map(|v| v.0)).collect();
    let raw_dirs: Vec<Vec3> = m.face_ids().map(|f| m.face_frame(f).direction(r.raw.angle[f])).collect();
    let mut fattr = Attribute::vec3("d1", &raw_dirs).to_vec();
    fattr.push(Attribute::f64("lambda1", r.raw.principal.iter().map(|p| p[0]).collect()));
    fattr.push(Attribute::f64("lambda2", r.raw.principal.iter().map(|p| p[1]).collect()));
    fattr.push(Attribute::f64("anisotropy", r.raw.anisotropy.as_slice().to_vec()));
    fattr.push(Attribute::u8("anisotropic", r.anisotropic.iter().map(|&a| a as u8).collect()));
    let comment = "clothcast raw field on the target: d1 = unit major direction per face; lambda1 >= lambda2 (squared principal stretches for source strain, principal curvatures for source curvature); anisotropy in [0, 1]";
    let path = out.join(FILES[0]);
    write_atomic(&path, |w| write_ply(w, PlyFormat::BinaryLittleEndian, comment, &pos, &tris, &[], &fattr))
        .with_context(|| format!("cannot write {}", path.display()))
        .internal()?;

    let dirs = r.field.directions(m);
    let fattr = Attribute::vec3("d1", dirs.as_slice()).to_vec();
    let index = r.field.indices(m, &r.connection);
    let vattr = [Attribute::i32("singularity", index.as_slice().to_vec())];
    let comment = "clothcast cross field (smoothed and relaxed): d1 = one unit arm of the cross per face (the others: -d1, n x d1, -n x d1); singularity = vertex index in quarter turns (+1 valence 3, -1 valence 5, -2 valence 6)";
    let path = out.join(FILES[1]);
    write_atomic(&path, |w| write_ply(w, PlyFormat::BinaryLittleEndian, comment, &pos, &tris, &vattr, &fattr))
        .with_context(|| format!("cannot write {}", path.display()))
        .internal()
}
