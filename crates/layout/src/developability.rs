//! Developability: the covariance (hinge) energy of Stein, Grinspun & Crane 2018, "Developability
//! of Triangle Meshes" (ALGORITHMS.md §8).
//!
//! Per vertex, `A_v = Σ_f θ_v^f n_f n_fᵀ` and `E_v = λ_min(A_v)`: zero exactly when the normals
//! of the star lie on a great circle (a discrete hinge, locally developable). On a smooth surface
//! sampled with edge length ℓ, `E_v ≈ (π/3) ℓ² min(κ₁², κ₂²)` (a star of six equilateral
//! triangles; verified on spheres by the tests), so `ρ_v = 3 E_v / (π ℓ̄_v²)` is a
//! resolution-independent estimate of `min(κ₁², κ₂²)` (1/m²; ℓ̄_v is the mean edge length at v).
//!
//! **Patch score** (`developability` in the reports): `D = Σ_{v interior} ρ_v A_v` ≈
//! `∫ min(κ₁², κ₂²) dA`, dimensionless and scale invariant: 0 for a developable patch,
//! `2π(1 − cos α)` for a spherical cap of half-angle α (a hemisphere: 2π ≈ 6.28; one face of
//! a cube-like layout of a sphere: 4π/6 ≈ 2.09). Boundary vertices of a patch count 0 (as in
//! Stein et al.): their star is cut by the seam. Deviation from the paper, which does not give
//! its normalisation: the score is this integral, so `[layout] max_developability` means the
//! same on any mesh size and scale.
//!
//! Complexity: O(F).

use clothcast_mesh::{Mesh, VertexData, VertexId};
use nalgebra::Matrix3;
use rayon::prelude::*;

/// `ρ_v A_v` for every vertex (0 on the mesh boundary): the contribution of each vertex to a
/// patch score.
pub fn vertex_scores(mesh: &Mesh) -> VertexData<f64> {
    let normals = mesh.face_normals();
    let angles = mesh.corner_angles();
    let areas = mesh.vertex_areas();
    // Per vertex, in parallel (a 3×3 eigenproblem each; the values do not depend on the
    // threads).
    let scores: Vec<f64> = (0..mesh.n_vertices())
        .into_par_iter()
        .map(VertexId::new)
        .map(|v| {
            if mesh.is_boundary_vertex(v) {
                return 0.0;
            }
            let mut a = Matrix3::zeros();
            let (mut len, mut n_len) = (0.0, 0.0);
            for h in mesh.outgoing(v) {
                let n = normals[mesh.face(h)];
                a += angles[h] * n * n.transpose();
                len += mesh.vector(h).norm();
                n_len += 1.0;
            }
            let lmin = a.symmetric_eigenvalues().min().max(0.0);
            let mean_len = len / n_len;
            if mean_len <= 0.0 {
                return 0.0;
            }
            3.0 * lmin / (std::f64::consts::PI * mean_len * mean_len) * areas[v]
        })
        .collect();
    VertexData::from_vec(scores)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;
    use std::f64::consts::PI;

    /// A sphere's score is ∫κ² dA = 4π at any radius and (fine enough) resolution; a cylinder's
    /// is 0 away from its rims.
    #[test]
    fn calibration_on_spheres_and_cylinders() {
        for (level, r) in [(3, 1.0), (4, 0.01), (5, 250.0)] {
            let m = shapes::icosphere(level, r);
            let d: f64 = vertex_scores(&m).iter().sum();
            assert!((d / (4.0 * PI) - 1.0).abs() < 0.15, "level {level} r {r}: {d}");
        }
        let c = shapes::cylinder(1.0, 3.0, 48, 30, false, false);
        let d: f64 = vertex_scores(&c).iter().sum();
        assert!(d < 1e-9, "cylinder {d}");
    }
}
