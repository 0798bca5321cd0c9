//! Raw direction fields (paper §4.1): principal stretch directions of the simulated mold, and,
//! for comparison, principal curvature directions of the target.
//!
//! **Strain.** Each target triangle, flattened isometrically into its face frame, maps to the
//! deformed triangle by the deformation gradient F (3×2); `C = FᵀF` (Eq. 3) has eigenvalues
//! λ1 ≥ λ2 (squared principal stretches) and eigenvectors s1, s2 (Eq. 4). Because the rest
//! triangle *is* the target triangle in its face frame, `F̂` is the frame itself and the
//! directions on the target (Eq. 5–6) are `d1 = cos ψ b1 + sin ψ b2` with
//! `ψ = ½ atan2(2C12, C11 − C22)`.
//!
//! **Anisotropy.** How well the direction is determined: the principal strain difference
//! relative to the strain of the face plus the typical strain of the mold,
//! `a = (e1 − e2) / (|e1| + |e2| + s)` with e_i = (λ_i − 1)/2 the principal Green strains and
//! `s` the median of `|e1| + |e2|` over the faces. In [0, 1): near 0 for an equibiaxial strain
//! or a face that barely strains, approaching 1 for a strongly uniaxial one. This deviates
//! from ALGORITHMS.md §2, which uses `(λ1−λ2)/(λ1+λ2)` on stretches: under infill the strains
//! are a few percent, so that measure is ~10⁻³ everywhere and a threshold on it would flip with
//! the fabric's stiffness; `a` is invariant to scaling all strains. The shape alone,
//! `(e1−e2)/(|e1|+|e2|)`, was tried first: it is 1 on every uniaxial or wrinkled face however
//! small its strain, which classed ~85% of the faces of real molds as anisotropic and froze
//! their noise (fertility kept 156 singularities after smoothing, against 49 with `a`).
//!
//! **Curvature.** Per-face second fundamental form fitted to the area-weighted vertex normals
//! along the three edges (Rusinkiewicz 2004), principal directions of it, anisotropy
//! `(k1 − k2) / (|k1| + |k2| + s)` with `s` the median of `|k1| + |k2|`.

use clothcast_mesh::{FaceData, Mesh, Vec3, VertexData};
use nalgebra::Matrix2;

/// Where the directions come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FieldSource {
    /// Principal stretch directions of the simulated mold (the paper's method).
    Strain,
    /// Principal curvature directions of the target (what garment tools such as CPM use).
    Curvature,
}

/// A raw per-face direction field.
#[derive(Clone, Debug)]
pub struct RawField {
    /// Angle of the major direction in the face frame.
    pub angle: FaceData<f64>,
    /// Principal values: (λ1, λ2) of C for strain, (k1, k2) for curvature.
    pub principal: FaceData<[f64; 2]>,
    /// Anisotropy in [0, 1].
    pub anisotropy: FaceData<f64>,
}

impl RawField {
    /// Faces whose anisotropy exceeds `threshold`.
    pub fn anisotropic(&self, threshold: f64) -> FaceData<bool> {
        self.anisotropy.map(|&a| a > threshold)
    }
}

/// Closed-form eigen-decomposition of [[a, b], [b, c]]: (λ1 ≥ λ2, angle of λ1's eigenvector).
#[inline]
pub fn sym2_eigen(a: f64, b: f64, c: f64) -> (f64, f64, f64) {
    let m = 0.5 * (a + c);
    let r = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    (m + r, m - r, 0.5 * (2.0 * b).atan2(a - c))
}

/// Raw strain field from the target mesh and the deformed positions (same vertex order).
///
/// # Panics
/// If `deformed` does not have one position per vertex.
pub fn strain_field(target: &Mesh, deformed: &VertexData<Vec3>) -> RawField {
    assert_eq!(deformed.len(), target.n_vertices(), "one deformed position per vertex");
    let n = target.n_faces();
    let (mut angle, mut principal, mut anisotropy) =
        (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    for f in target.face_ids() {
        let fr = target.face_frame(f);
        let p = target.face_positions(f);
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let dm = Matrix2::new(fr.to_local(&e1)[0], fr.to_local(&e2)[0], fr.to_local(&e1)[1], fr.to_local(&e2)[1]);
        let dm_inv = dm.try_inverse().unwrap_or_else(Matrix2::identity);
        let x = target.face_vertices(f).map(|v| deformed[v]);
        let (d1, d2) = (x[1] - x[0], x[2] - x[0]);
        // F = Ds Dm⁻¹ column by column.
        let f0 = d1 * dm_inv[(0, 0)] + d2 * dm_inv[(1, 0)];
        let f1 = d1 * dm_inv[(0, 1)] + d2 * dm_inv[(1, 1)];
        let (c00, c01, c11) = (f0.dot(&f0), f0.dot(&f1), f1.dot(&f1));
        let (l1, l2, psi) = sym2_eigen(c00, c01, c11);
        angle.push(psi);
        principal.push([l1, l2]);
        // Principal Green strains: gap and magnitude, normalised below.
        let (g1, g2) = (0.5 * (l1 - 1.0), 0.5 * (l2 - 1.0));
        anisotropy.push([g1 - g2, g1.abs() + g2.abs()]);
    }
    RawField {
        angle: FaceData::from_vec(angle),
        principal: FaceData::from_vec(principal),
        anisotropy: relative_anisotropy(&anisotropy),
    }
}

/// `gap / (magnitude + median magnitude)` for per-face (gap, magnitude) pairs.
fn relative_anisotropy(gm: &[[f64; 2]]) -> FaceData<f64> {
    let mut mags: Vec<f64> = gm.iter().map(|x| x[1]).collect();
    mags.sort_by(f64::total_cmp);
    let s = mags.get(mags.len() / 2).copied().unwrap_or(0.0);
    gm.iter().map(|&[gap, mag]| if mag + s > 1e-12 { (gap / (mag + s)).clamp(0.0, 1.0) } else { 0.0 }).collect()
}

/// Raw principal-curvature field of a mesh.
pub fn curvature_field(mesh: &Mesh) -> RawField {
    let normals = mesh.vertex_normals();
    let n = mesh.n_faces();
    let (mut angle, mut principal, mut anisotropy) =
        (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    for f in mesh.face_ids() {
        let fr = mesh.face_frame(f);
        let vs = mesh.face_vertices(f);
        // Least squares for II = [[a, b], [b, c]]: II·e = Δn along each edge (in the frame).
        let mut ata = nalgebra::Matrix3::<f64>::zeros();
        let mut atb = nalgebra::Vector3::<f64>::zeros();
        for k in 0..3 {
            let (i, j) = (vs[k], vs[(k + 1) % 3]);
            let e = fr.to_local(&(mesh.position(j) - mesh.position(i)));
            let dn = fr.to_local(&(normals[j] - normals[i]));
            for (row, rhs) in [([e[0], e[1], 0.0], dn[0]), ([0.0, e[0], e[1]], dn[1])] {
                let r = nalgebra::Vector3::from(row);
                ata += r * r.transpose();
                atb += r * rhs;
            }
        }
        let s = ata.try_inverse().map(|inv| inv * atb).unwrap_or_else(nalgebra::Vector3::zeros);
        let (k1, k2, psi) = sym2_eigen(s[0], s[1], s[2]);
        angle.push(psi);
        principal.push([k1, k2]);
        anisotropy.push([k1 - k2, k1.abs() + k2.abs()]);
    }
    RawField {
        angle: FaceData::from_vec(angle),
        principal: FaceData::from_vec(principal),
        anisotropy: relative_anisotropy(&anisotropy),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;

    #[test]
    fn uniaxial_stretch_is_found() {
        let m = shapes::grid(4, 4, 1.0, 1.0);
        // Stretch 10% along the diagonal direction (1, 1)/√2.
        let d = Vec3::new(1.0, 1.0, 0.0).normalize();
        let def = m.positions().map(|p| p + d * (0.1 * p.dot(&d)));
        let raw = strain_field(&m, &def);
        for f in m.face_ids() {
            let dir = m.face_frame(f).direction(raw.angle[f]);
            assert!((dir.dot(&d).abs() - 1.0).abs() < 1e-9, "face {f}: {dir}");
            assert!((raw.principal[f][0] - 1.21).abs() < 1e-9 && (raw.principal[f][1] - 1.0).abs() < 1e-9);
            // Every face has the median strain: a = gap / (2 · magnitude) = ½.
            assert!((raw.anisotropy[f] - 0.5).abs() < 1e-9);
        }
        // Equibiaxial: isotropic.
        let def = m.positions().map(|p| p * 1.05);
        assert!(strain_field(&m, &def).anisotropy.iter().all(|&a| a < 1e-9));
    }

    #[test]
    fn cylinder_curvature_directions() {
        let m = shapes::cylinder(1.0, 4.0, 48, 16, false, false);
        let raw = curvature_field(&m);
        for f in m.face_ids().filter(|&f| m.face_vertices(f).iter().all(|&v| !m.is_boundary_vertex(v))) {
            let dir = m.face_frame(f).direction(raw.angle[f]);
            // The cross is aligned with the hoop and axial directions (away from the rims,
            // where vertex normals are one-sided).
            assert!(dir.z.abs() < 0.05 || dir.z.abs() > 0.998, "face {f}: {dir}");
            assert!(raw.anisotropy[f] > 0.45);
        }
    }
}
