//! Membrane materials: energy density as a function of the Green strain.
//!
//! Strains and stresses use Voigt vectors in the element's material frame (the face frame of
//! the target triangle, `b1` along its first edge): `E = [E11, E22, 2·E12]` (engineering
//! shear), `S = [S11, S22, S12]` (second Piola–Kirchhoff), so that `δW = S · δE`. The tangent
//! is `C = ∂S/∂E` (3×3).
//!
//! The trait takes the face so that materials with directions (the orthotropic woven-fabric
//! model of Wang et al. 2011, which needs the warp angle of every face) fit behind it.

use clothcast_mesh::FaceId;
use nalgebra::{Matrix3, Vector3};

/// Energy density (per unit rest area) and its first two derivatives at a strain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialResponse {
    /// W (J/m²).
    pub energy: f64,
    /// S = ∂W/∂E in Voigt form (N/m).
    pub stress: Vector3<f64>,
    /// ∂²W/∂E² (N/m); must be symmetric positive semi-definite for Newton's projection.
    pub tangent: Matrix3<f64>,
}

/// A hyperelastic membrane material.
pub trait Material: Send + Sync {
    /// Response of face `face` at Green strain `e` (Voigt, material frame).
    fn response(&self, face: FaceId, e: &Vector3<f64>) -> MaterialResponse;
    /// Energy only (cheaper where it matters, e.g. line searches).
    fn energy(&self, face: FaceId, e: &Vector3<f64>) -> f64 {
        self.response(face, e).energy
    }
    /// A representative stiffness (N/m) used to scale regularization and tolerances.
    fn reference_stiffness(&self) -> f64;
    /// True if the response does not depend on the face (then a coarse version of the mesh,
    /// whose face ids are its own, may be simulated with the same material: see
    /// [`crate::coarse`]). Materials with per-face data (fiber directions) keep the default.
    fn is_uniform(&self) -> bool {
        false
    }
    /// The relative residual below which Newton's Hessian takes the stress of its geometric
    /// term exactly; above it, at its positive part, which keeps the Hessian positive
    /// semi-definite in any state (exact where the stress is: the tension-field model's always
    /// is). Far from the equilibrium the projection makes steps the line search takes; near it,
    /// where compressed faces stay (plain StVK, the woven fabric's buckled yarns), only the exact
    /// term gives Newton's fast tail, and the Levenberg–Marquardt damping handles an indefinite
    /// step. The default: [`crate::newton::EXACT_TAIL`]; `f64::INFINITY`: exact throughout.
    fn exact_geometric_below(&self) -> f64 {
        crate::newton::EXACT_TAIL
    }
    /// The stiffness Y (N/m) a slack face takes on along its largest principal strain once that
    /// turns positive (`W = ½ Y e1²` there), for the slack walls of Newton's step model
    /// ([`crate::walls`]); `None` (the default): the material has no slack state to wall.
    fn slack_wall_stiffness(&self) -> Option<f64> {
        None
    }
}

/// Isotropic St. Venant–Kirchhoff membrane in plane stress:
/// `W = μ tr(E²) + ½ λ (tr E)²` with the project's convention (ALGORITHMS.md §1.1): Young's
/// modulus Y (thickness-integrated, N/m) and Poisson ratio ν give
/// `λ = Yν/(1−ν²)`, `μ = G = Y/(2(1+ν))` — the paper's Eq. 2 with k_uu = k_vv ↔ Y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StVenantKirchhoff {
    /// λ (N/m).
    pub lambda: f64,
    /// μ (N/m).
    pub mu: f64,
}

impl StVenantKirchhoff {
    /// From Y (N/m) and ν.
    pub fn from_young_poisson(youngs_modulus: f64, poisson_ratio: f64) -> Self {
        let (y, nu) = (youngs_modulus, poisson_ratio);
        Self { lambda: y * nu / (1.0 - nu * nu), mu: y / (2.0 * (1.0 + nu)) }
    }
    /// Young's modulus Y = 4μ(λ+μ)/(λ+2μ).
    pub fn youngs_modulus(&self) -> f64 {
        4.0 * self.mu * (self.lambda + self.mu) / (self.lambda + 2.0 * self.mu)
    }
    /// Poisson ratio ν = λ/(λ+2μ).
    pub fn poisson_ratio(&self) -> f64 {
        self.lambda / (self.lambda + 2.0 * self.mu)
    }
    fn tangent(&self) -> Matrix3<f64> {
        let (l, m) = (self.lambda, self.mu);
        Matrix3::new(l + 2.0 * m, l, 0.0, l, l + 2.0 * m, 0.0, 0.0, 0.0, m)
    }
}

impl Material for StVenantKirchhoff {
    fn response(&self, _face: FaceId, e: &Vector3<f64>) -> MaterialResponse {
        let c = self.tangent();
        let stress = c * e;
        MaterialResponse { energy: 0.5 * e.dot(&stress), stress, tangent: c }
    }
    fn energy(&self, _face: FaceId, e: &Vector3<f64>) -> f64 {
        let tr = e[0] + e[1];
        // μ tr(E²) + ½ λ (tr E)² with E12 = e[2]/2.
        self.mu * (e[0] * e[0] + e[1] * e[1] + 0.5 * e[2] * e[2]) + 0.5 * self.lambda * tr * tr
    }
    fn reference_stiffness(&self) -> f64 {
        self.lambda + 2.0 * self.mu
    }
    fn is_uniform(&self) -> bool {
        true
    }
}

/// St. Venant–Kirchhoff with the tension-field (wrinkling) relaxation of membrane theory
/// (Pipkin 1986; the "material modification" wrinkling models of membrane structures, e.g.
/// Jarasjarungkiat, Wüchner & Bletzinger 2008): a fabric cannot carry compression, it wrinkles.
///
/// With principal Green strains e1 ≥ e2 (eigenvectors v1, v2) and the plain StVK principal
/// stress `S2 = λ e1 + (λ+2μ) e2`:
/// - taut (S2 ≥ 0): plain StVK;
/// - wrinkled (S2 < 0 < e1): uniaxial tension along v1, `W = ½ Y e1²`, `S = Y e1 v1v1ᵀ`
///   (the relaxed energy `min_{e ≥ e2} W(e1, e)`);
/// - slack (e1 ≤ 0): `W = 0`.
///
/// The energy is C¹ across the regions, the stress is always positive semi-definite, and the
/// tangent `Y P1⊗P1 + Y e1/(e1−e2) (P1 dE P2 + P2 dE P1)` (P_i the eigenprojectors) is PSD,
/// so Newton needs no projection and converges where plain StVK, whose compressed regions are
/// saddles (the membrane would buckle), crawls (over 24 solves of eight meshes at three
/// heights, 1409 iterations against 565).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WrinklingStVenantKirchhoff {
    /// The underlying StVK parameters.
    pub stvk: StVenantKirchhoff,
}

/// Region of the tension-field model a strain falls in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TensionState {
    /// Both principal stresses ≥ 0.
    Taut,
    /// Uniaxial tension; wrinkles across it.
    Wrinkled,
    /// No tension at all.
    Slack,
}

impl WrinklingStVenantKirchhoff {
    /// From Y (N/m) and ν.
    pub fn from_young_poisson(youngs_modulus: f64, poisson_ratio: f64) -> Self {
        Self { stvk: StVenantKirchhoff::from_young_poisson(youngs_modulus, poisson_ratio) }
    }

    /// Principal strains (e1 ≥ e2), angle of v1, and the region.
    pub fn state(&self, e: &Vector3<f64>) -> (f64, f64, f64, TensionState) {
        let (e1, e2, st) = self.principal_state(e);
        (e1, e2, crate::element::sym2_angle(e[0], 0.5 * e[2], e[1]), st)
    }

    /// Principal strains and the region, without the direction (the energy and the taut and
    /// slack responses need no arctangent).
    fn principal_state(&self, e: &Vector3<f64>) -> (f64, f64, TensionState) {
        let (e1, e2) = crate::element::sym2_eigenvalues(e[0], 0.5 * e[2], e[1]);
        let (l, m) = (self.stvk.lambda, self.stvk.mu);
        let s2 = l * e1 + (l + 2.0 * m) * e2;
        let st = if s2 >= 0.0 {
            TensionState::Taut
        } else if e1 > 0.0 {
            TensionState::Wrinkled
        } else {
            TensionState::Slack
        };
        (e1, e2, st)
    }
}

impl Material for WrinklingStVenantKirchhoff {
    fn response(&self, face: FaceId, e: &Vector3<f64>) -> MaterialResponse {
        let (e1, e2, st) = self.principal_state(e);
        match st {
            TensionState::Taut => self.stvk.response(face, e),
            TensionState::Slack => {
                MaterialResponse { energy: 0.0, stress: Vector3::zeros(), tangent: Matrix3::zeros() }
            }
            TensionState::Wrinkled => {
                let y = self.stvk.youngs_modulus();
                let th = crate::element::sym2_angle(e[0], 0.5 * e[2], e[1]);
                let (c, s) = (th.cos(), th.sin());
                // Eigenprojectors in Voigt-friendly components.
                let p1 = [c * c, s * s, c * s];
                let p2 = [s * s, c * c, -c * s];
                let stress = Vector3::new(p1[0], p1[1], p1[2]) * (y * e1);
                // Columns: response to the Voigt strain unit vectors (E11, E22, 2E12 = 1).
                let k = y * e1 / (e1 - e2);
                let mut tangent = Matrix3::zeros();
                let units: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.5]];
                let m = |a: [f64; 3]| nalgebra::Matrix2::new(a[0], a[2], a[2], a[1]);
                let (mp1, mp2) = (m(p1), m(p2));
                for (j, d) in units.iter().enumerate() {
                    let de = m(*d);
                    let dp1 = mp1.component_mul(&de).sum(); // P1 : dE
                    let cross = mp1 * de * mp2 + mp2 * de * mp1;
                    let ds = mp1 * (y * dp1) + cross * k;
                    tangent.set_column(j, &Vector3::new(ds[(0, 0)], ds[(1, 1)], ds[(0, 1)]));
                }
                MaterialResponse { energy: 0.5 * y * e1 * e1, stress, tangent }
            }
        }
    }
    fn energy(&self, face: FaceId, e: &Vector3<f64>) -> f64 {
        let (e1, _, st) = self.principal_state(e);
        match st {
            TensionState::Taut => self.stvk.energy(face, e),
            TensionState::Wrinkled => 0.5 * self.stvk.youngs_modulus() * e1 * e1,
            TensionState::Slack => 0.0,
        }
    }
    fn reference_stiffness(&self) -> f64 {
        self.stvk.reference_stiffness()
    }
    fn is_uniform(&self) -> bool {
        true
    }
    fn slack_wall_stiffness(&self) -> Option<f64> {
        Some(self.stvk.youngs_modulus())
    }
}

/// [`Material::exact_geometric_below`] of the woven fabric. With the projection throughout, the
/// buckled yarns made Newton's tail linear (the sewn fertility: 137 and over 200 iterations
/// against 54 and 40 with the exact term throughout); projected until the relative residual is
/// 3·10⁻², the check's solves on eight meshes (the example, fertility, bunny, spot, torus,
/// camelhead, sphere, cylinder) at 0.3 / 0.5 / 1 m took 414 / 312 / 179 iterations against
/// 470 / 369 / 189 with the exact term throughout (in the trial that chose it, 316 at 0.5 m;
/// 10⁻²: 414 / 322 / 178; 10⁻¹: 349 at 0.5 m; 10⁻³: 394), kitten's 93 against 105 (36.3
/// against 37.7 s).
pub const WOVEN_EXACT_TAIL: f64 = 3e-2;

/// A woven fabric as two families of yarns, warp along the material frame's first axis and
/// weft along its second, held together by a weave that resists shearing (the paper's §7.4
/// validation uses the orthotropic model of Wang et al. 2011, ALGORITHMS.md §11; this is its
/// orthotropic energy without the warp–weft coupling, with each yarn's stiffness depending on
/// its own stretch, and with the yarns' compression relaxed). With Green strains `E11` (warp),
/// `E22` (weft), `γ = 2 E12`:
///
/// `W = Φ_warp(E11) + Φ_weft(E22) + ½ G γ²`,
///
/// where a yarn's stress is WOR11's `σ = k(E) E`, its energy `Φ(E) = ∫₀^E k(e) e de`, and its
/// stiffness `k` rises linearly in the stretch `s = √(1 + 2E)` from its small-strain value at
/// s = 1 to its stretched value at s ≥ 7/6 (WOR11's strain coordinate `t = clamp(6(s − 1), 0,
/// 1)` between its rest row and its row along that yarn; read by the yarn's own stretch, where
/// ARCSim reads the whole table by the largest principal stretch and its direction). `k_warp`,
/// `k_weft` are the tensile stiffnesses (N/m) of a 1 m strip along each yarn and `G` the
/// in-plane shear modulus (WOR11's k0, k2 and k3/4). A yarn in compression buckles out of the weave and keeps only a
/// small fraction `c` of its small-strain stiffness (as the tension-field model lets an
/// isotropic membrane wrinkle; with `c = 0` a region slack in both yarns could crumple freely,
/// which a static solve cannot settle: a fan of thin triangles with one warp direction, a
/// cylinder's flat cap, stalled at a relative residual of 10⁻² without it). WOR11's coupling k1
/// is left out: it is below 3% of √(k0 k2) for three of its five woven fabrics, and a coupling
/// of buckling yarns (k1 max(E11, 0) max(E22, 0)) has a gradient that jumps where one yarn goes
/// slack, which stalled the sewn built-in example at a relative residual of 3·10⁻⁴. The energy
/// is C¹ and, for yarns that stiffen (or keep their stiffness) as they stretch, convex in E with
/// a diagonal PSD tangent (a softening yarn's tangent is floored at zero).
///
/// The material frame of a face is its rest element's: [`crate::element::Element::from_plane`]
/// on the pattern piece, whose +u is the warp. (With the target's own triangles as rest shapes,
/// as [`crate::scenario::simulate`] has them, the warp would run along each triangle's first
/// edge: the fabric only means something on pattern triangles.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WovenFabric {
    /// Small-strain tensile stiffness along the warp (N/m).
    pub warp: f64,
    /// Small-strain tensile stiffness along the weft (N/m).
    pub weft: f64,
    /// The warp's stiffness from a stretch of 7/6 on (N/m; `warp` for a linear yarn).
    pub warp_stretched: f64,
    /// The weft's stiffness from a stretch of 7/6 on (N/m).
    pub weft_stretched: f64,
    /// In-plane shear modulus (N/m).
    pub shear: f64,
    /// A yarn's stiffness in compression as a fraction of its small-strain stiffness
    /// ([`WovenFabric::COMPRESSION`]).
    pub compression: f64,
}

/// The stretch from which a yarn has its stretched stiffness (WOR11: t = 6(s − 1) reaches 1).
const STRETCHED_AT: f64 = 7.0 / 6.0;

impl WovenFabric {
    /// The default [`WovenFabric::compression`].
    pub const COMPRESSION: f64 = 0.01;

    /// A fabric of constant stiffnesses, or a message naming the value that is not a positive
    /// finite number.
    pub fn new(warp: f64, weft: f64, shear: f64) -> Result<Self, String> {
        Self::stiffening(warp, weft, warp, weft, shear)
    }

    /// A fabric whose yarns' stiffnesses go from `warp`, `weft` at rest to `warp_stretched`,
    /// `weft_stretched` at a stretch of 7/6, or a message naming a value that is not a positive
    /// finite number.
    pub fn stiffening(
        warp: f64,
        weft: f64,
        warp_stretched: f64,
        weft_stretched: f64,
        shear: f64,
    ) -> Result<Self, String> {
        for (name, v) in [
            ("warp stiffness", warp),
            ("weft stiffness", weft),
            ("stretched warp stiffness", warp_stretched),
            ("stretched weft stiffness", weft_stretched),
            ("shear modulus", shear),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be positive and finite (got {v})"));
            }
        }
        Ok(Self { warp, weft, warp_stretched, weft_stretched, shear, compression: Self::COMPRESSION })
    }

    /// The same fabric with every stiffness multiplied by `k`, or a message naming the value
    /// that is then not a positive finite number.
    pub fn scaled(&self, k: f64) -> Result<Self, String> {
        Self::stiffening(self.warp * k, self.weft * k, self.warp_stretched * k, self.weft_stretched * k, self.shear * k)
    }

    /// A yarn's energy density, stress and tangent at its Green strain `e`, for stiffness `k0`
    /// at rest and `k1` from a stretch of 7/6 on.
    #[inline]
    fn yarn(&self, k0: f64, k1: f64, e: f64) -> (f64, f64, f64) {
        if e <= 0.0 {
            let k = self.compression * k0;
            return (0.5 * k * e * e, k * e, k);
        }
        let d = k1 - k0;
        if d == 0.0 {
            return (0.5 * k0 * e * e, k0 * e, k0);
        }
        let e1 = 0.5 * (STRETCHED_AT * STRETCHED_AT - 1.0);
        // k(e) = k0 + 6d (s − 1) up to e1, so Φ(E) = ½ k0 E² + 6d ∫₀^E (s − 1) e de, and with
        // t = s − 1 (e = t(2 + t)/2, de = (1 + t) dt) the integral is T³ (1/3 + 3T/8 + T²/10):
        // no cancellation (T = 2E / (S + 1)).
        let phi = |e: f64| {
            let t = 2.0 * e / ((1.0 + 2.0 * e).sqrt() + 1.0);
            0.5 * k0 * e * e + 6.0 * d * t * t * t * (1.0 / 3.0 + t * (3.0 / 8.0 + t / 10.0))
        };
        if e >= e1 {
            return (phi(e1) + 0.5 * k1 * (e * e - e1 * e1), k1 * e, k1);
        }
        let s = (1.0 + 2.0 * e).sqrt();
        let k = k0 + 6.0 * d * (2.0 * e / (s + 1.0));
        (phi(e), k * e, (k + 6.0 * d * e / s).max(0.0))
    }
}

impl Material for WovenFabric {
    fn response(&self, _face: FaceId, e: &Vector3<f64>) -> MaterialResponse {
        let (ww, sw, kw) = self.yarn(self.warp, self.warp_stretched, e[0]);
        let (wf, sf, kf) = self.yarn(self.weft, self.weft_stretched, e[1]);
        let stress = Vector3::new(sw, sf, self.shear * e[2]);
        let tangent = Matrix3::from_diagonal(&Vector3::new(kw, kf, self.shear));
        MaterialResponse { energy: ww + wf + 0.5 * self.shear * e[2] * e[2], stress, tangent }
    }
    fn reference_stiffness(&self) -> f64 {
        self.warp.max(self.weft)
    }
    fn is_uniform(&self) -> bool {
        true
    }
    fn exact_geometric_below(&self) -> f64 {
        WOVEN_EXACT_TAIL
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of `m` at strain `e` with step `h`: the response's energy is
    /// `energy`'s, the stress is the energy's gradient (to 1e-5 relative), and every column `j`
    /// of the tangent that `tangent_checked(j)` admits is the stress's derivative (to 1e-4).
    fn check_derivatives(
        m: &dyn Material,
        e: &Vector3<f64>,
        h: f64,
        tangent_checked: impl Fn(usize) -> bool,
    ) -> Result<(), String> {
        let f = FaceId(0);
        let r = m.response(f, e);
        if (r.energy - m.energy(f, e)).abs() >= 1e-14 {
            return Err(format!("{e:?}: energy {} vs {}", r.energy, m.energy(f, e)));
        }
        for j in 0..3 {
            let (mut ep, mut em) = (*e, *e);
            ep[j] += h;
            em[j] -= h;
            let ds = (m.energy(f, &ep) - m.energy(f, &em)) / (2.0 * h);
            if (ds - r.stress[j]).abs() >= 1e-5 * (1.0 + r.stress[j].abs()) {
                return Err(format!("{e:?} dW/dE{j}: {ds} vs {}", r.stress[j]));
            }
            if !tangent_checked(j) {
                continue;
            }
            let dc = (m.response(f, &ep).stress - m.response(f, &em).stress) / (2.0 * h);
            for i in 0..3 {
                if (dc[i] - r.tangent[(i, j)]).abs() >= 1e-4 * (1.0 + r.tangent[(i, j)].abs()) {
                    return Err(format!("{e:?} C{i}{j}: {} vs {}", dc[i], r.tangent[(i, j)]));
                }
            }
        }
        Ok(())
    }

    #[test]
    fn wrinkling_model_is_c1_with_consistent_derivatives() {
        let m = WrinklingStVenantKirchhoff::from_young_poisson(1000.0, 0.3);
        let f = FaceId(0);
        // Taut, wrinkled and slack samples (Voigt strains), away from region boundaries.
        let samples = [
            Vector3::new(0.05, 0.04, 0.01),
            Vector3::new(0.08, -0.05, 0.03),
            Vector3::new(0.02, -0.06, -0.05),
            Vector3::new(-0.03, -0.02, 0.01),
        ];
        let expect = [TensionState::Taut, TensionState::Wrinkled, TensionState::Wrinkled, TensionState::Slack];
        for (e, st) in samples.iter().zip(expect) {
            assert_eq!(m.state(e).3, st, "{e:?}");
            let r = m.response(f, e);
            check_derivatives(&m, e, 1e-7, |_| true).unwrap_or_else(|why| panic!("{st:?} {why}"));
            // Stress and tangent positive semi-definite.
            let s = nalgebra::Matrix2::new(r.stress[0], r.stress[2], r.stress[2], r.stress[1]);
            assert!(s.symmetric_eigenvalues().min() > -1e-9);
            assert!(r.tangent.symmetric_eigenvalues().min() > -1e-9);
        }
        // Continuity across the taut/wrinkled boundary (S2 = 0): e2 = −ν' e1.
        let nu = m.stvk.lambda / (m.stvk.lambda + 2.0 * m.stvk.mu);
        for d in [1e-9, -1e-9] {
            let e = Vector3::new(0.05, -nu * 0.05 + d, 0.0);
            let r = m.response(f, &e);
            assert!((r.energy - 0.5 * m.stvk.youngs_modulus() * 0.05f64.powi(2)).abs() < 1e-6);
            assert!(r.stress[1].abs() < 1e-3);
        }
    }

    #[test]
    fn woven_fabric_derivatives_and_buckling_yarns() {
        let m = WovenFabric::new(5.0e4, 2.0e4, 1.5e3).unwrap();
        let f = FaceId(0);
        // Both yarns taut, warp only, weft only, both slack (shear alone).
        let samples = [
            Vector3::new(0.05, 0.04, 0.01),
            Vector3::new(0.08, -0.05, 0.03),
            Vector3::new(-0.02, 0.06, -0.05),
            Vector3::new(-0.03, -0.02, 0.01),
        ];
        for e in &samples {
            check_derivatives(&m, e, 1e-7, |_| true).unwrap();
            assert!(m.response(f, e).tangent.symmetric_eigenvalues().min() > -1e-9);
        }
        // Stiffening yarns (a WOR11 fabric): derivatives in every regime, the stress k(E)·E,
        // the stretched stiffness from a stretch of 7/6 on (E = 0.1806), continuity there.
        let st = WovenFabric::stiffening(400.0, 2000.0, 460.0, 2100.0, 30.0).unwrap();
        let e1 = 0.5 * ((7.0f64 / 6.0).powi(2) - 1.0);
        for e in [
            Vector3::new(1e-4, 2e-4, 0.0),
            Vector3::new(0.05, 0.12, 0.01),
            Vector3::new(0.3, -0.05, 0.03),
            Vector3::new(e1 - 1e-9, e1 + 1e-9, -0.2),
        ] {
            let h = 1e-7 * (1.0 + e[0].abs().max(e[1].abs()));
            check_derivatives(&st, &e, h, |j| (e[j] - e1).abs() > 1e-6).unwrap();
        }
        let r = st.response(f, &Vector3::new(0.3, 0.0, 0.0));
        assert!((r.stress[0] - 460.0 * 0.3).abs() < 1e-9 && r.tangent[(0, 0)] == 460.0);
        let r = st.response(f, &Vector3::new(0.05, 0.0, 0.0));
        let k = 400.0 + 60.0 * 6.0 * ((1.1f64).sqrt() - 1.0);
        assert!((r.stress[0] - k * 0.05).abs() < 1e-9, "{} vs {}", r.stress[0], k * 0.05);
        assert!(WovenFabric::stiffening(400.0, 2000.0, 0.0, 2100.0, 30.0).unwrap_err().contains("stretched warp"));

        // A compressed yarn carries a hundredth of what it would in tension; a stretched one k·E.
        let r = m.response(f, &Vector3::new(0.1, -0.1, 0.0));
        assert!((r.stress[1] - 0.01 * 2.0e4 * -0.1).abs() < 1e-9, "{}", r.stress[1]);
        assert!((r.stress[0] - 5.0e3).abs() < 1e-9);
        // Unphysical values are refused, naming them.
        assert!(WovenFabric::new(5.0e4, 2.0e4, f64::NAN).unwrap_err().contains("shear"));
        assert!(WovenFabric::new(5.0e4, 0.0, 1.0).unwrap_err().contains("weft"));
    }

    #[test]
    fn lame_conversion_round_trips() {
        let m = StVenantKirchhoff::from_young_poisson(50_000.0, 0.3);
        assert!((m.youngs_modulus() - 50_000.0).abs() < 1e-9);
        assert!((m.poisson_ratio() - 0.3).abs() < 1e-12);
        // G = Y / (2(1+ν)), λ+μ = Y / (2(1−ν)).
        assert!((m.mu - 50_000.0 / 2.6).abs() < 1e-9);
        assert!((m.lambda + m.mu - 50_000.0 / 1.4).abs() < 1e-9);
    }

    #[test]
    fn energy_matches_response_and_tensor_form() {
        let m = StVenantKirchhoff::from_young_poisson(1000.0, 0.25);
        let e = Vector3::new(0.1, -0.03, 0.08);
        let r = m.response(FaceId(0), &e);
        assert!((r.energy - m.energy(FaceId(0), &e)).abs() < 1e-12);
        // Tensor form: μ (E11² + E22² + 2 E12²) + λ/2 (E11 + E22)².
        let e12 = e[2] / 2.0;
        let w = m.mu * (e[0] * e[0] + e[1] * e[1] + 2.0 * e12 * e12) + 0.5 * m.lambda * (e[0] + e[1]).powi(2);
        assert!((r.energy - w).abs() < 1e-12);
        // S12 = 2 μ E12.
        assert!((r.stress[2] - 2.0 * m.mu * e12).abs() < 1e-12);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
        /// For any woven fabric (stiffening or softening yarns) and any strain away from the
        /// kinks (a yarn at zero strain, or at the stretch 7/6 where its stiffness stops
        /// rising): the stress is the energy's gradient, the tangent the stress's where it is
        /// not floored at zero (a softening yarn), the tangent is PSD, and the energy is never
        /// negative.
        #[test]
        fn woven_fabric_stress_and_tangent_are_the_energy_derivatives(
            warp in 1.0e2f64..1.0e5,
            weft in 1.0e2f64..1.0e5,
            rise in 0.5f64..2.0,
            shear in 1.0f64..1.0e4,
            e0 in -0.2f64..0.5,
            e1 in -0.2f64..0.5,
            g in -0.5f64..0.5,
        ) {
            let kink = 0.5 * (STRETCHED_AT * STRETCHED_AT - 1.0);
            proptest::prop_assume!(
                e0.abs() > 1e-4 && e1.abs() > 1e-4 && (e0 - kink).abs() > 1e-4 && (e1 - kink).abs() > 1e-4
            );
            let m = WovenFabric::stiffening(warp, weft, warp * rise, weft * rise, shear).unwrap();
            let e = Vector3::new(e0, e1, g);
            let r = m.response(FaceId(0), &e);
            proptest::prop_assert!(r.energy >= 0.0);
            proptest::prop_assert!(r.tangent.symmetric_eigenvalues().min() >= 0.0);
            let checked = check_derivatives(&m, &e, 1e-7, |j| r.tangent[(j, j)] > 0.0);
            proptest::prop_assert!(checked.is_ok(), "{}", checked.unwrap_err());
        }
    }
}
