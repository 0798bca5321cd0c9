//! Constant-strain membrane triangles (ALGORITHMS.md §1.1).
//!
//! Each target triangle, flattened isometrically into its own face frame, is the rest shape of
//! its element (paper §3: the panels are not known yet, so every triangle is its own panel);
//! a sewn mold's element has its triangle on the cut pattern instead ([`Element::from_plane`]).
//! With shape-function gradients `∇N_a` (rows of `Dm⁻¹`, `∇N0 = −∇N1 − ∇N2`), the
//! deformation gradient is `F = Σ_a x_a ⊗ ∇N_a` (3×2), `C = FᵀF`, `E = ½(C − I)`.
//!
//! For node a, `B_a` maps `δx_a` to the Voigt strain variation:
//! rows `∇N_a[0] F0ᵀ`, `∇N_a[1] F1ᵀ`, `∇N_a[1] F0ᵀ + ∇N_a[0] F1ᵀ` (F0, F1 the columns of F).
//! Then `∂Ψ/∂x_a = A0 B_aᵀ S` and
//! `∂²Ψ/∂x_a∂x_b = A0 (B_aᵀ C B_b + (∇N_aᵀ S ∇N_b) I₃)`.
//!
//! The first (material) term is PSD whenever the material tangent is; the second (geometric)
//! term is indefinite under compression. [`Element::evaluate`] (with `project`) replaces S by its
//! positive part S⁺ in the geometric term, which gives a PSD Hessian that equals the exact one
//! wherever the membrane is in tension (the common case under infill pressure), at the cost of
//! two 2×2 eigen-decompositions instead of a 9×9 one. Near the equilibrium Newton takes the
//! exact term ([`crate::newton::EXACT_TAIL`], or the material's).

use crate::material::{Material, MaterialResponse};
use clothcast_mesh::{FaceId, Mesh, Vec3};
use nalgebra::{Matrix2, Matrix3, SMatrix, Vector2, Vector3};

/// 9×9 element matrix (vertex-major: rows 3a..3a+3 belong to corner a).
pub type Mat9 = SMatrix<f64, 9, 9>;
/// 9-vector.
pub type Vec9 = SMatrix<f64, 9, 1>;

/// Rest data of one triangle.
#[derive(Clone, Copy, Debug)]
pub struct Element {
    /// Shape-function gradients of the three corners in the rest (face) frame.
    pub grad_n: [Vector2<f64>; 3],
    /// Rest area.
    pub area: f64,
}

/// Deformation of one element.
#[derive(Clone, Copy, Debug)]
pub struct Kinematics {
    /// Columns of F.
    pub f: [Vec3; 2],
    /// Green strain, Voigt (E11, E22, 2E12).
    pub strain: Vector3<f64>,
}

impl Element {
    /// Rest data from the three corners of a (non-degenerate) triangle.
    pub fn from_corners(p: &[Vec3; 3]) -> Self {
        let e01 = p[1] - p[0];
        let e02 = p[2] - p[0];
        let n = e01.cross(&e02);
        let b1 = e01.normalize();
        let b2 = n.normalize().cross(&b1);
        // Dm = [[l, a], [0, b]]
        let l = e01.norm();
        let (a, b) = (e02.dot(&b1), e02.dot(&b2));
        let dm_inv = Matrix2::new(1.0 / l, -a / (l * b), 0.0, 1.0 / b);
        Self::from_inverse(&dm_inv, 0.5 * l * b)
    }

    /// Rest data from `Dm⁻¹` (its rows are `∇N1`, `∇N2`) and the rest area.
    fn from_inverse(dm_inv: &Matrix2<f64>, area: f64) -> Self {
        let g1 = Vector2::new(dm_inv[(0, 0)], dm_inv[(0, 1)]);
        let g2 = Vector2::new(dm_inv[(1, 0)], dm_inv[(1, 1)]);
        Self { grad_n: [-(g1 + g2), g1, g2], area }
    }

    /// Rest data from a triangle given in the plane, e.g. on a cut pattern: the material frame
    /// is the plane's (its first axis along +u, the warp of a pattern piece). `None` when the
    /// triangle is degenerate or clockwise (a folded pattern triangle).
    pub fn from_plane(uv: &[Vector2<f64>; 3]) -> Option<Self> {
        let dm = Matrix2::from_columns(&[uv[1] - uv[0], uv[2] - uv[0]]);
        let det = dm.determinant();
        let scale = (uv[1] - uv[0]).norm_squared().max((uv[2] - uv[0]).norm_squared());
        if !(det > 1e-12 * scale) {
            return None;
        }
        Some(Self::from_inverse(&dm.try_inverse()?, 0.5 * det))
    }

    /// Rest data of every face of a mesh (the target is the rest shape).
    pub fn for_mesh(mesh: &Mesh) -> Vec<Self> {
        mesh.face_ids().map(|f| Self::from_corners(&mesh.face_positions(f))).collect()
    }

    /// F and the Green strain at deformed corners `x`.
    #[inline]
    pub fn kinematics(&self, x: &[Vec3; 3]) -> Kinematics {
        let mut f = [Vec3::zeros(); 2];
        for a in 0..3 {
            f[0] += x[a] * self.grad_n[a][0];
            f[1] += x[a] * self.grad_n[a][1];
        }
        let c00 = f[0].dot(&f[0]);
        let c11 = f[1].dot(&f[1]);
        let c01 = f[0].dot(&f[1]);
        Kinematics { f, strain: Vector3::new(0.5 * (c00 - 1.0), 0.5 * (c11 - 1.0), c01) }
    }

    /// Elastic energy.
    #[inline]
    pub fn energy(&self, mat: &dyn Material, face: FaceId, x: &[Vec3; 3]) -> f64 {
        self.area * mat.energy(face, &self.kinematics(x).strain)
    }

    fn b_matrix(&self, k: &Kinematics, a: usize) -> Matrix3<f64> {
        let g = self.grad_n[a];
        let (f0, f1) = (k.f[0], k.f[1]);
        let r2 = f0 * g[1] + f1 * g[0];
        Matrix3::from_rows(&[(f0 * g[0]).transpose(), (f1 * g[1]).transpose(), r2.transpose()])
    }

    /// Energy, gradient and the Hessian (exact, or with the geometric term's stress replaced
    /// by its positive part when `project` is set).
    pub fn evaluate(&self, mat: &dyn Material, face: FaceId, x: &[Vec3; 3], project: bool) -> (f64, Vec9, Mat9) {
        let k = self.kinematics(x);
        let MaterialResponse { energy, stress, tangent } = mat.response(face, &k.strain);
        let b = [self.b_matrix(&k, 0), self.b_matrix(&k, 1), self.b_matrix(&k, 2)];
        let mut g = Vec9::zeros();
        for a in 0..3 {
            g.fixed_rows_mut::<3>(3 * a).copy_from(&(b[a].transpose() * stress * self.area));
        }
        let s = Matrix2::new(stress[0], stress[2], stress[2], stress[1]);
        let s_geo = if project { positive_part(&s) } else { s };
        let mut h = Mat9::zeros();
        let cb: [Matrix3<f64>; 3] = [tangent * b[0], tangent * b[1], tangent * b[2]];
        for a in 0..3 {
            for c in a..3 {
                let geo = (self.grad_n[a].transpose() * s_geo * self.grad_n[c])[0];
                let blk = (b[a].transpose() * cb[c] + Matrix3::identity() * geo) * self.area;
                h.fixed_view_mut::<3, 3>(3 * a, 3 * c).copy_from(&blk);
                if c != a {
                    h.fixed_view_mut::<3, 3>(3 * c, 3 * a).copy_from(&blk.transpose());
                }
            }
        }
        (self.area * energy, g, h)
    }

    /// Energy, and the gradient and Hessian block of corner `a` alone (the corner's 3×3
    /// diagonal block of [`Element::evaluate`]'s projected Hessian): what a vertex-by-vertex
    /// relaxation needs, without the other eight blocks. The energy is [`Element::energy`]'s,
    /// to the bit (the material's energy formula, which may round differently from its
    /// response's), so that a relaxation compares its trial points with the same formula.
    pub fn corner(&self, mat: &dyn Material, face: FaceId, x: &[Vec3; 3], a: usize) -> (f64, Vec3, Matrix3<f64>) {
        let k = self.kinematics(x);
        let MaterialResponse { stress, tangent, .. } = mat.response(face, &k.strain);
        let energy = mat.energy(face, &k.strain);
        let b = self.b_matrix(&k, a);
        let g = b.transpose() * stress * self.area;
        let s = positive_part(&Matrix2::new(stress[0], stress[2], stress[2], stress[1]));
        let geo = (self.grad_n[a].transpose() * s * self.grad_n[a])[0];
        let h = (b.transpose() * tangent * b + Matrix3::identity() * geo) * self.area;
        (self.area * energy, g, h)
    }

    /// The largest principal Green strain e1 at corners `x` and its gradient with respect to
    /// each corner: with p the unit eigenvector of e1 in the rest frame, `δe1 = pᵀ δE p =
    /// (F p)·(δF p)` and `δF p = Σ_a δx_a (∇N_a·p)`, so `∂e1/∂x_a = (∇N_a·p) F p` (where e1 is
    /// a simple eigenvalue; at a double one, that of the direction the eigen-solver picks).
    pub fn largest_strain_gradient(&self, x: &[Vec3; 3]) -> (f64, [Vec3; 3]) {
        let k = self.kinematics(x);
        let e = k.strain;
        let (e1, _, th) = sym2_eigen(e[0], 0.5 * e[2], e[1]);
        let p = Vector2::new(th.cos(), th.sin());
        let fp = k.f[0] * p[0] + k.f[1] * p[1];
        (e1, [0, 1, 2].map(|a| fp * self.grad_n[a].dot(&p)))
    }

    /// Eigenvalues λ1 ≥ λ2 of C = FᵀF (squared principal stretches) and the unit direction
    /// of λ1 in the rest (face) frame.
    pub fn principal_stretches(&self, x: &[Vec3; 3]) -> (f64, f64, Vector2<f64>) {
        let k = self.kinematics(x);
        let (a, c, b) = (1.0 + 2.0 * k.strain[0], 1.0 + 2.0 * k.strain[1], k.strain[2]);
        let (l1, l2, angle) = sym2_eigen(a, b, c);
        (l1, l2, Vector2::new(angle.cos(), angle.sin()))
    }
}

/// A seam of a sewn mold along one edge of a face: a bar (the seam allowances' folded layers
/// and the stitching) that carries tension along the edge, from corner `k` to corner `k + 1`
/// of its face, with Green strain `ε = (l² − L²)/(2L²)` and energy `½ k L ε²`, where `k` is
/// its axial stiffness (N) in tension and `compression · k` in compression (it buckles).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Bar {
    /// Axial stiffness in tension (N); 0: no bar.
    pub stiffness: f64,
    /// Rest length L (m).
    pub rest: f64,
    /// Its stiffness in compression as a fraction of `stiffness`.
    pub compression: f64,
}

impl Bar {
    /// Energy, the gradient with respect to the far end (the near end's is its negative), and
    /// the Hessian block of the far end with itself (the near end's is the same; their
    /// coupling its negative), for the edge vector `d` (far − near). With `project`, the
    /// geometric term's strain is taken at its positive part (a PSD block).
    #[inline]
    pub fn evaluate(&self, d: &Vec3, project: bool) -> (f64, Vec3, Matrix3<f64>) {
        let (eps, k) = self.strain(d);
        let energy = 0.5 * k * self.rest * eps * eps;
        let g = d * (k * eps / self.rest);
        let geo = if project { eps.max(0.0) } else { eps };
        let h = (d * d.transpose() / (self.rest * self.rest) + Matrix3::identity() * geo) * (k / self.rest);
        (energy, g, h)
    }

    /// Energy alone.
    #[inline]
    pub fn energy(&self, d: &Vec3) -> f64 {
        let (eps, k) = self.strain(d);
        0.5 * k * self.rest * eps * eps
    }

    /// The Green strain at edge vector `d`, and the stiffness there (tension or compression).
    #[inline]
    fn strain(&self, d: &Vec3) -> (f64, f64) {
        let l2 = self.rest * self.rest;
        let eps = 0.5 * (d.norm_squared() - l2) / l2;
        (eps, if eps > 0.0 { self.stiffness } else { self.compression * self.stiffness })
    }
}

/// The bars of a face that exist, each with its near and far corner (edge k: corner k to
/// k + 1; a bar of zero stiffness is none).
#[inline]
fn face_bars(bars: &[Bar; 3]) -> impl Iterator<Item = (usize, usize, &Bar)> {
    bars.iter().enumerate().filter(|(_, b)| b.stiffness > 0.0).map(|(k, b)| (k, (k + 1) % 3, b))
}

/// `e` plus the energy of a face's bars at corners `p`, added bar by bar (as [`add_bars`]
/// adds them: the same sum to the bit).
#[inline]
pub fn add_bars_energy(bars: &[Bar; 3], p: &[Vec3; 3], e: f64) -> f64 {
    face_bars(bars).fold(e, |e, (i, j, b)| e + b.energy(&(p[j] - p[i])))
}

/// A face's bars added to a vertex's terms: their energy to `e` (added as
/// [`add_bars_energy`] does), and to `g`, `h` the gradient and (projected) Hessian block of
/// corner `a` alone: what a vertex-by-vertex relaxation needs ([`Element::corner`]'s
/// counterpart).
#[inline]
pub fn add_bars_corner(bars: &[Bar; 3], p: &[Vec3; 3], a: usize, e: &mut f64, g: &mut Vec3, h: &mut Matrix3<f64>) {
    for (i, j, b) in face_bars(bars) {
        let (be, bg, bh) = b.evaluate(&(p[j] - p[i]), true);
        *e += be;
        if a == i {
            *g -= bg;
            *h += bh;
        } else if a == j {
            *g += bg;
            *h += bh;
        }
    }
}

/// The bars of a face added to its element's energy, gradient and Hessian.
#[inline]
pub fn add_bars(bars: &[Bar; 3], p: &[Vec3; 3], project: bool, e: &mut f64, g: &mut Vec9, h: &mut Mat9) {
    for (i, j, b) in face_bars(bars) {
        let (be, bg, bh) = b.evaluate(&(p[j] - p[i]), project);
        *e += be;
        let mut gi = g.fixed_rows_mut::<3>(3 * i);
        gi -= bg;
        let mut gj = g.fixed_rows_mut::<3>(3 * j);
        gj += bg;
        for (r, c, sign) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
            let mut blk = h.fixed_view_mut::<3, 3>(3 * r, 3 * c);
            blk += bh * sign;
        }
    }
}

/// Closed-form eigen-decomposition of [[a, b], [b, c]]: (λ1 ≥ λ2, angle of λ1's eigenvector).
#[inline]
pub fn sym2_eigen(a: f64, b: f64, c: f64) -> (f64, f64, f64) {
    let (l1, l2) = sym2_eigenvalues(a, b, c);
    (l1, l2, sym2_angle(a, b, c))
}

/// The eigenvalues λ1 ≥ λ2 of [[a, b], [b, c]] alone (no arctangent).
#[inline]
pub fn sym2_eigenvalues(a: f64, b: f64, c: f64) -> (f64, f64) {
    let m = 0.5 * (a + c);
    let r = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    (m + r, m - r)
}

/// The angle of λ1's eigenvector of [[a, b], [b, c]].
#[inline]
pub fn sym2_angle(a: f64, b: f64, c: f64) -> f64 {
    0.5 * (2.0 * b).atan2(a - c)
}

/// Positive semi-definite part of a symmetric 2×2 matrix (negative eigenvalues set to 0).
#[inline]
pub fn positive_part(s: &Matrix2<f64>) -> Matrix2<f64> {
    // The eigenvector (an arctangent) only when one eigenvalue is dropped: the tension-field
    // model's stress is always positive semi-definite.
    let (a, b, c) = (s[(0, 0)], s[(0, 1)], s[(1, 1)]);
    let (l1, l2) = sym2_eigenvalues(a, b, c);
    if l2 >= 0.0 {
        return *s;
    }
    if l1 <= 0.0 {
        return Matrix2::zeros();
    }
    let th = sym2_angle(a, b, c);
    let v = Vector2::new(th.cos(), th.sin());
    v * v.transpose() * l1
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::material::StVenantKirchhoff;
    use nalgebra::Rotation3;

    #[test]
    fn the_largest_strain_gradient_matches_finite_differences() {
        let rest = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.03, 0.0, 0.0), Vec3::new(0.01, 0.025, 0.0)];
        let el = Element::from_corners(&rest);
        let rot = Rotation3::from_euler_angles(0.3, -0.7, 1.1);
        // Slack (compressed both ways), wrinkled (stretched one way) and taut, rotated in space.
        for (sx, sy, shear) in [(0.97, 0.95, 0.01), (1.02, 0.9, -0.03), (1.05, 1.03, 0.02)] {
            let x = rest.map(|p| rot * Vec3::new(sx * p[0] + shear * p[1], sy * p[1], 0.002 * p[0]));
            let (e1, g) = el.largest_strain_gradient(&x);
            let e1_at = |q: &[Vec3; 3]| {
                let e = el.kinematics(q).strain;
                sym2_eigenvalues(e[0], 0.5 * e[2], e[1]).0
            };
            assert!((e1 - e1_at(&x)).abs() < 1e-15);
            let h = 1e-7;
            for c in 0..9 {
                let (mut xp, mut xm) = (x, x);
                xp[c / 3][c % 3] += h;
                xm[c / 3][c % 3] -= h;
                let fd = (e1_at(&xp) - e1_at(&xm)) / (2.0 * h);
                assert!((fd - g[c / 3][c % 3]).abs() < 1e-6, "({sx}, {sy}) dof {c}: {fd} vs {}", g[c / 3][c % 3]);
            }
        }
    }

    #[test]
    fn seam_bar_derivatives() {
        let b = Bar { stiffness: 1500.0, rest: 0.02, compression: 0.01 };
        let p = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.021, 0.003, -0.001), Vec3::new(0.01, 0.02, 0.0)];
        for q in [p, [p[0], p[0] + (p[1] - p[0]) * 0.9, p[2]]] {
            let bars = [b, Bar::default(), Bar::default()];
            let (mut e, mut g, mut h) = (0.0, Vec9::zeros(), Mat9::zeros());
            add_bars(&bars, &q, false, &mut e, &mut g, &mut h);
            assert!((e - b.energy(&(q[1] - q[0]))).abs() < 1e-15);
            let flat = |q: &[Vec3; 3]| {
                let (mut e, mut g, mut h) = (0.0, Vec9::zeros(), Mat9::zeros());
                add_bars(&bars, q, false, &mut e, &mut g, &mut h);
                (e, g)
            };
            let step = 1e-8;
            for c in 0..9 {
                let (mut qp, mut qm) = (q, q);
                qp[c / 3][c % 3] += step;
                qm[c / 3][c % 3] -= step;
                let ((ep, gp), (em, gm)) = (flat(&qp), flat(&qm));
                assert!(((ep - em) / (2.0 * step) - g[c]).abs() < 1e-6 * (1.0 + g[c].abs()), "g{c}");
                for r in 0..9 {
                    let fd = (gp[r] - gm[r]) / (2.0 * step);
                    assert!((fd - h[(r, c)]).abs() < 1e-4 * (1.0 + h[(r, c)].abs()), "h{r}{c}: {fd} vs {}", h[(r, c)]);
                }
            }
            // The third corner takes no part.
            assert!(g.fixed_rows::<3>(6).norm() == 0.0);
        }
    }

    fn tri() -> [Vec3; 3] {
        [Vec3::new(0.1, 0.2, 0.0), Vec3::new(1.3, 0.1, 0.2), Vec3::new(0.4, 0.9, -0.1)]
    }

    #[test]
    fn rest_state_is_stress_free_and_rigid_motions_give_no_force() {
        let mat = StVenantKirchhoff::from_young_poisson(1000.0, 0.3);
        let p = tri();
        let e = Element::from_corners(&p);
        let rot = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let t = Vec3::new(3.0, -2.0, 0.5);
        let moved = p.map(|x| rot * x + t);
        for x in [p, moved] {
            let (w, g, _) = e.evaluate(&mat, FaceId(0), &x, false);
            assert!(w.abs() < 1e-20, "{w}");
            assert!(g.norm() < 1e-10, "{}", g.norm());
        }
        assert!((e.area - 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm()).abs() < 1e-14);
    }

    #[test]
    fn corner_terms_are_the_blocks_of_the_full_evaluation() {
        let wrinkling = crate::material::WrinklingStVenantKirchhoff::from_young_poisson(1000.0, 0.3);
        let plain = StVenantKirchhoff::from_young_poisson(1000.0, 0.3);
        let p = tri();
        let e = Element::from_corners(&p);
        // Taut, and compressed along one side: wrinkled, and plain StVK in compression (whose
        // stress is indefinite, so the geometric term's S⁺ differs from S).
        let compressed = [p[0], p[1] * 0.8, p[2] * 1.1];
        let stress = plain.response(FaceId(0), &e.kinematics(&compressed).strain).stress;
        let s2 = nalgebra::Matrix2::new(stress[0], stress[2], stress[2], stress[1]).symmetric_eigenvalues();
        assert!(s2.min() < 0.0 && s2.max() > 0.0, "the plain case is indefinite: {s2:?}");
        let cases: [(&dyn Material, [Vec3; 3]); 3] =
            [(&wrinkling, p.map(|v| v * 1.05)), (&wrinkling, compressed), (&plain, compressed)];
        for (mat, x) in cases {
            let (w, g, h) = e.evaluate(mat, FaceId(0), &x, true);
            for a in 0..3 {
                let (wa, ga, ha) = e.corner(mat, FaceId(0), &x, a);
                assert!((wa - w).abs() <= 1e-15 * w.abs().max(1e-300));
                assert_eq!(wa, e.energy(mat, FaceId(0), &x), "the energy formula's value, to the bit");
                assert!((ga - g.fixed_rows::<3>(3 * a)).norm() <= 1e-12 * g.norm());
                assert!((ha - h.fixed_view::<3, 3>(3 * a, 3 * a)).norm() <= 1e-12 * h.norm());
            }
        }
    }

    #[test]
    fn uniaxial_stretch_closed_form() {
        // Stretch a right triangle by s along x: E11 = (s²−1)/2, S11 = (λ+2μ)E11, S22 = λE11.
        let mat = StVenantKirchhoff::from_young_poisson(2000.0, 0.25);
        let p = [Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let e = Element::from_corners(&p);
        let s = 1.2;
        let x = p.map(|v| Vec3::new(v.x * s, v.y, v.z));
        let (w, _, _) = e.evaluate(&mat, FaceId(0), &x, false);
        let e11 = 0.5 * (s * s - 1.0);
        let expect = 0.5 * (mat.lambda + 2.0 * mat.mu) * e11 * e11 * 0.5;
        assert!((w - expect).abs() < 1e-12 * expect, "{w} vs {expect}");
        let (l1, l2, d) = e.principal_stretches(&x);
        assert!((l1 - s * s).abs() < 1e-12 && (l2 - 1.0).abs() < 1e-12);
        assert!((d.x.abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn gradient_and_hessian_match_finite_differences() {
        let mat = StVenantKirchhoff::from_young_poisson(1000.0, 0.3);
        let p = tri();
        let e = Element::from_corners(&p);
        // A deformed state with both tension and compression.
        let x = [p[0] + Vec3::new(0.05, -0.02, 0.1), p[1] * 1.1, p[2] + Vec3::new(-0.1, -0.2, 0.3)];
        let flat = |x: &[Vec3; 3]| Vec9::from_iterator(x.iter().flat_map(|v| [v.x, v.y, v.z]));
        let unflat = |v: &Vec9| [0, 1, 2].map(|a| Vec3::new(v[3 * a], v[3 * a + 1], v[3 * a + 2]));
        let (_, g, h) = e.evaluate(&mat, FaceId(0), &x, false);
        let x0 = flat(&x);
        let eps = 1e-6;
        for i in 0..9 {
            let mut xp = x0;
            let mut xm = x0;
            xp[i] += eps;
            xm[i] -= eps;
            let (wp, gp, _) = e.evaluate(&mat, FaceId(0), &unflat(&xp), false);
            let (wm, gm, _) = e.evaluate(&mat, FaceId(0), &unflat(&xm), false);
            let fd = (wp - wm) / (2.0 * eps);
            assert!((fd - g[i]).abs() < 1e-6 * (1.0 + g[i].abs()), "grad {i}: {fd} vs {}", g[i]);
            let fdh = (gp - gm) / (2.0 * eps);
            for j in 0..9 {
                assert!(
                    (fdh[j] - h[(j, i)]).abs() < 1e-5 * (1.0 + h[(j, i)].abs()),
                    "hess ({j},{i}): {} vs {}",
                    fdh[j],
                    h[(j, i)]
                );
            }
        }
        // The projected Hessian is PSD.
        let (_, _, hp) = e.evaluate(&mat, FaceId(0), &x, true);
        let ev = hp.symmetric_eigenvalues();
        assert!(ev.min() > -1e-9 * ev.max(), "{ev}");
    }

    #[test]
    fn positive_part_of_2x2() {
        let s = Matrix2::new(2.0, 1.0, 1.0, -3.0);
        let p = positive_part(&s);
        let ev = p.symmetric_eigenvalues();
        assert!(ev.min().abs() < 1e-12 && ev.max() > 0.0);
        assert_eq!(positive_part(&Matrix2::new(1.0, 0.0, 0.0, 2.0)), Matrix2::new(1.0, 0.0, 0.0, 2.0));
    }
}
