//! # clothcast-field
//!
//! The cross field every seam and fibre direction follows (paper §4 and §6.2.2):
//!
//! 1. [`synthesis`]: the raw field — principal stretch directions of the simulated mold on the
//!    target (or principal curvature directions, for comparison with garment tools) and the
//!    anisotropy of every face;
//! 2. [`smoothing`], pass 1 (denoise): Eq. 7 with the alignment term weighted by α and the
//!    face's anisotropy;
//! 3. pass 2 (simplicity): anisotropic faces fixed exactly to their pass-1 directions, the rest
//!    solved for the smoothest field (α = 0);
//! 4. [`relax`]: nearby singularities combined (valence 5 + 5 → 6) or cancelled (3 + 5).
//!
//! The field is face-based: an angle per face, connection angles and integer period jumps per
//! edge, singularity indices per vertex in quarter turns ([`cross`]). On a closed surface the
//! indices always sum to 4χ.
//!
//! ```
//! use clothcast_field::{FieldOptions, compute_field, synthesis::FieldSource};
//! let mesh = clothcast_mesh::shapes::torus(2.0, 0.7, 32, 16);
//! let opts = FieldOptions { source: FieldSource::Curvature, ..Default::default() };
//! let r = compute_field(&mesh, None, &opts).unwrap();
//! assert_eq!(r.stats.index_sum, 0); // 4χ of a torus
//! ```

pub mod cross;
pub mod error;
pub mod relax;
pub mod smoothing;
pub mod synthesis;

pub use cross::{CrossField, Singularity};
pub use error::FieldError;

use clothcast_mesh::{EdgeData, FaceData, Mesh, Vec3, VertexData};
use serde::Serialize;
use smoothing::Smoother;
use std::time::Instant;
use synthesis::{FieldSource, RawField};

/// Options of the field stage.
#[derive(Clone, Debug)]
pub struct FieldOptions {
    /// Strain (the paper) or curvature (garment tools).
    pub source: FieldSource,
    /// A face is anisotropic when its anisotropy exceeds this (see [`synthesis`]).
    pub anisotropy_threshold: f64,
    /// Weight α of the alignment term in pass 1 (paper Eq. 7).
    pub alpha: f64,
    /// Combine singularities closer than this fraction of the bounding-box diagonal (0: no
    /// relaxation).
    pub relax_radius: f64,
    /// Largest rise of the pass-2 energy accepted for one merge (two valence-5 into a valence-6)
    /// or cancellation (a valence-3/valence-5 pair).
    pub relax_merge_energy: f64,
}

impl Default for FieldOptions {
    fn default() -> Self {
        Self {
            source: FieldSource::Strain,
            anisotropy_threshold: 0.6,
            alpha: 0.5,
            relax_radius: 0.15,
            relax_merge_energy: 3.0,
        }
    }
}

/// A singularity as reported.
#[derive(Clone, Debug, Serialize)]
pub struct SingularityReport {
    /// Vertex id.
    pub vertex: u32,
    /// Index in quarter turns (+1 valence 3, −1 valence 5, −2 valence 6).
    pub index: i32,
    /// Position (metres, the mesh as simulated).
    pub position: [f64; 3],
}

/// Statistics (the `field` section of summary.json).
#[derive(Clone, Debug, Serialize)]
pub struct FieldStats {
    /// "strain" or "curvature".
    pub source: FieldSource,
    /// Share of faces above the anisotropy threshold.
    pub anisotropic_fraction: f64,
    /// Eq. 7 (pass-1 weights) of the raw field: the energy before pass 1.
    pub energy_raw: f64,
    /// Eq. 7 (pass-1 weights) after pass 1.
    pub energy_pass1: f64,
    /// Eq. 7 (α = 0, the pass-2 objective) of the pass-1 field: the energy before pass 2.
    pub energy_before_pass2: f64,
    /// Eq. 7 (α = 0) after pass 2.
    pub energy_pass2: f64,
    /// Eq. 7 (α = 0) after relaxation.
    pub energy_final: f64,
    /// Singularities of the raw field.
    pub singularities_raw: usize,
    /// After the two smoothing passes.
    pub singularities_smoothed: usize,
    /// After relaxation.
    pub singularities_final: usize,
    /// Valence-5 pairs merged into valence 6.
    pub merged: usize,
    /// Valence-3/valence-5 pairs cancelled.
    pub cancelled: usize,
    /// Sum of the final indices (quarter turns; 4χ on a closed surface).
    pub index_sum: i64,
    /// Sum of the raw field's indices.
    pub index_sum_raw: i64,
    /// Sum of the smoothed field's indices (before relaxation).
    pub index_sum_smoothed: i64,
    /// The final singularities.
    pub singularities: Vec<SingularityReport>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Everything the field stage produces.
pub struct FieldResult {
    /// The raw field.
    pub raw: RawField,
    /// Faces treated as anisotropic.
    pub anisotropic: FaceData<bool>,
    /// Connection angles per edge.
    pub connection: EdgeData<f64>,
    /// The field after pass 1 (denoised).
    pub pass1: CrossField,
    /// The final (smoothed, relaxed) cross field.
    pub field: CrossField,
    /// Its singularities.
    pub singularities: Vec<Singularity>,
    /// Statistics.
    pub stats: FieldStats,
}

/// Run the whole field stage. `deformed` (the simulated positions, same vertex order) is
/// required for the strain source.
pub fn compute_field(
    mesh: &Mesh,
    deformed: Option<&VertexData<Vec3>>,
    opts: &FieldOptions,
) -> Result<FieldResult, FieldError> {
    let t0 = Instant::now();
    let raw = match (opts.source, deformed) {
        (FieldSource::Strain, Some(d)) => {
            if d.len() != mesh.n_vertices() {
                return Err(FieldError::VertexCountMismatch { expected: mesh.n_vertices(), got: d.len() });
            }
            synthesis::strain_field(mesh, d)
        }
        (FieldSource::Strain, None) => return Err(FieldError::MissingDeformation),
        (FieldSource::Curvature, _) => synthesis::curvature_field(mesh),
    };
    let anisotropic = raw.anisotropic(opts.anisotropy_threshold);
    let rho = cross::connection(mesh);
    let n_f = mesh.n_faces();

    // Raw field and pass 1 (soft, anisotropy-weighted alignment).
    let raw_field = CrossField::from_angles(mesh, &rho, raw.angle.clone());
    let pass1 = Smoother::new(mesh, &rho, raw.anisotropy.map(|a| opts.alpha * a), FaceData::filled(n_f, None));
    let (field1, _) = pass1.solve(&raw.angle)?;
    let sum = |(s, a): (f64, f64)| s + a;
    let energy_raw = sum(pass1.energy(&raw_field, &raw.angle));
    let energy_pass1 = sum(pass1.energy(&field1, &raw.angle));

    // Pass 2: anisotropic faces fixed to their pass-1 directions, smoothest elsewhere.
    let fixed: FaceData<Option<f64>> = mesh.face_ids().map(|f| anisotropic[f].then_some(field1.theta[f])).collect();
    let pass2 = Smoother::new(mesh, &rho, FaceData::filled(n_f, 0.0), fixed);
    let energy_before_pass2 = sum(pass2.energy(&field1, &raw.angle));
    let (mut field, solver2) = pass2.solve(&raw.angle)?;
    let energy_pass2 = sum(pass2.energy(&field, &raw.angle));
    let smoothed = field.singularities(mesh, &rho);
    let raw_sing = raw_field.singularities(mesh, &rho);
    let sum_of = |s: &[Singularity]| s.iter().map(|x| x.index as i64).sum::<i64>();

    // Relaxation.
    let report = if opts.relax_radius > 0.0 {
        let ro = relax::RelaxOptions {
            radius: opts.relax_radius * mesh.bbox().diagonal(),
            merge_tolerance: opts.relax_merge_energy,
        };
        relax::relax(mesh, &rho, &pass2, &solver2, &raw.angle, &mut field, &ro)
    } else {
        relax::RelaxReport::default()
    };
    let energy_final = sum(pass2.energy(&field, &raw.angle));
    let singularities = field.singularities(mesh, &rho);
    let stats = FieldStats {
        source: opts.source,
        anisotropic_fraction: anisotropic.iter().filter(|&&a| a).count() as f64 / n_f.max(1) as f64,
        energy_raw,
        energy_pass1,
        energy_before_pass2,
        energy_pass2,
        energy_final,
        singularities_raw: raw_sing.len(),
        singularities_smoothed: smoothed.len(),
        singularities_final: singularities.len(),
        merged: report.merged,
        cancelled: report.cancelled,
        index_sum: sum_of(&singularities),
        index_sum_raw: sum_of(&raw_sing),
        index_sum_smoothed: sum_of(&smoothed),
        singularities: singularities
            .iter()
            .map(|s| SingularityReport { vertex: s.vertex.0, index: s.index, position: mesh.position(s.vertex).into() })
            .collect(),
        seconds: t0.elapsed().as_secs_f64(),
    };
    Ok(FieldResult { raw, anisotropic, connection: rho, pass1: field1, field, singularities, stats })
}
