//! Hydrostatic infill pressure as a conservative load (ALGORITHMS.md §1.2).
//!
//! The liquid surface is a fixed level (`fill_height` along `up`); depth `d(x) = h_fill − x·up`
//! and pressure `p = ρ g max(d, 0)`. The work of the pressure is `∫_Ω p dV` over the liquid
//! region; with `Φ = ½ ρ g max(d,0)² ĝ` (ĝ = −up, `div Φ = p`) the divergence theorem turns it
//! into a sum over the wetted fabric only (the free surface has d = 0):
//!
//! `W = Σ_f (ρg/4) · s_f · J(d0, d1, d2)`,  `s_f = ĝ · ((x1−x0) × (x2−x0))`,
//!
//! where `J = (1/A)∫_f max(d,0)² dA` is the mean of `d⁺²` over the triangle (d linear). It is
//! a polynomial for fully wetted faces, `d0⁴ / (6 (d0−d1)(d0−d2))` with one wetted corner, and
//! the full polynomial minus that term (with the dry corner) with two: exact for faces that
//! cross the level, and numerically stable (every denominator is at least the largest depth
//! gap). The total potential is `U − W`, so `−∇(−W)` is exactly the pressure force and the
//! Hessian is symmetric. Derivatives of J come from tiny second-order dual numbers ([`D3`]).
//!
//! Precondition: the surface is oriented outward (normals point away from the liquid); for an
//! open surface, boundary vertices below the level must be fixed (else liquid spills, and the
//! missing cap is not constant).

use crate::element::{Mat9, Vec9};
use clothcast_mesh::Vec3;
use nalgebra::Matrix3;

/// Value, gradient and Hessian of a function of three variables.
#[derive(Clone, Copy, Debug)]
pub struct D3 {
    /// Value.
    pub v: f64,
    /// Gradient.
    pub g: [f64; 3],
    /// Hessian.
    pub h: [[f64; 3]; 3],
}

impl D3 {
    /// A constant.
    pub fn cst(v: f64) -> Self {
        Self { v, g: [0.0; 3], h: [[0.0; 3]; 3] }
    }
    /// Variable number `i` with value `v`.
    pub fn var(v: f64, i: usize) -> Self {
        let mut g = [0.0; 3];
        g[i] = 1.0;
        Self { v, g, h: [[0.0; 3]; 3] }
    }
    fn map(self, f: f64, df: f64, ddf: f64) -> Self {
        // Chain rule for a scalar function applied to self.
        let mut out = Self::cst(f);
        for i in 0..3 {
            out.g[i] = df * self.g[i];
            for j in 0..3 {
                out.h[i][j] = df * self.h[i][j] + ddf * self.g[i] * self.g[j];
            }
        }
        out
    }
    /// 1 / self.
    pub fn recip(self) -> Self {
        let v = self.v;
        self.map(1.0 / v, -1.0 / (v * v), 2.0 / (v * v * v))
    }
    /// self^n for a small integer n ≥ 2.
    pub fn powi(self, n: i32) -> Self {
        let v = self.v;
        let nf = n as f64;
        self.map(v.powi(n), nf * v.powi(n - 1), nf * (nf - 1.0) * v.powi(n - 2))
    }
}

impl std::ops::Add for D3 {
    type Output = D3;
    fn add(self, o: D3) -> D3 {
        let mut r = self;
        r.v += o.v;
        for i in 0..3 {
            r.g[i] += o.g[i];
            for j in 0..3 {
                r.h[i][j] += o.h[i][j];
            }
        }
        r
    }
}
impl std::ops::Sub for D3 {
    type Output = D3;
    fn sub(self, o: D3) -> D3 {
        self + o * D3::cst(-1.0)
    }
}
impl std::ops::Mul for D3 {
    type Output = D3;
    fn mul(self, o: D3) -> D3 {
        let mut r = D3::cst(self.v * o.v);
        for i in 0..3 {
            r.g[i] = self.g[i] * o.v + self.v * o.g[i];
            for j in 0..3 {
                r.h[i][j] = self.h[i][j] * o.v + self.g[i] * o.g[j] + o.g[i] * self.g[j] + self.v * o.h[i][j];
            }
        }
        r
    }
}
impl std::ops::Div for D3 {
    type Output = D3;
    #[allow(clippy::suspicious_arithmetic_impl)] // a / b = a · (1/b), with the chain rule in recip
    fn div(self, o: D3) -> D3 {
        self * o.recip()
    }
}

/// Mean of `max(d,0)²` over a triangle with linear d taking values `d` at the corners, with
/// derivatives in the three corner depths.
pub fn mean_sq_positive_depth(d: [f64; 3]) -> D3 {
    let v = [D3::var(d[0], 0), D3::var(d[1], 1), D3::var(d[2], 2)];
    // One corner i on one side, j and k on the other: ∫ of (sign·d)⁺² = (sign·d_i)⁴/(6 Δij Δik).
    let corner = |v: &[D3; 3], i: usize| {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        v[i].powi(4) / ((v[i] - v[j]) * (v[i] - v[k]) * D3::cst(6.0))
    };
    match d.iter().filter(|&&x| x > 0.0).count() {
        0 => D3::cst(0.0),
        3 => full_wet(d),
        1 => corner(&v, (0..3).find(|&i| d[i] > 0.0).expect("one wet corner")),
        _ => {
            let dry = (0..3).find(|&i| d[i] <= 0.0).expect("one dry corner");
            full(&v) - corner(&v, dry)
        }
    }
}

/// `(Σ dᵢ² + Σ dᵢdⱼ)/6` in dual numbers: the mean of d² over a wetted triangle.
fn full(v: &[D3; 3]) -> D3 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[0] * v[1] + v[1] * v[2] + v[2] * v[0]) * D3::cst(1.0 / 6.0)
}

/// [`mean_sq_positive_depth`] of a fully wetted face, `(Σ dᵢ² + Σ dᵢdⱼ)/6`, in closed form:
/// the same non-trivial operations, in the same order, as the dual-number evaluation [`full`]
/// (which also adds and multiplies zeros), so the same bits (a test checks it), without its 3×3 Hessian products. Nearly every face is fully wetted.
fn full_wet(d: [f64; 3]) -> D3 {
    let sixth = 1.0 / 6.0;
    let [a, b, c] = d;
    let v = (a * a + b * b + c * c + a * b + b * c + c * a) * sixth;
    let g = [(a + a + b + c) * sixth, (b + b + a + c) * sixth, (c + c + b + a) * sixth];
    let (two, one) = (2.0 * sixth, sixth);
    D3 { v, g, h: [[two, one, one], [one, two, one], [one, one, two]] }
}

/// Mean of `max(d,0)` over the triangle (value only; for the liquid volume).
pub fn mean_positive_depth(d: [f64; 3]) -> f64 {
    let one = |i: usize| {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        d[i].powi(3) / (3.0 * (d[i] - d[j]) * (d[i] - d[k]))
    };
    match d.iter().filter(|&&x| x > 0.0).count() {
        0 => 0.0,
        3 => (d[0] + d[1] + d[2]) / 3.0,
        1 => one((0..3).find(|&i| d[i] > 0.0).expect("one wet corner")),
        _ => {
            let dry = (0..3).find(|&i| d[i] <= 0.0).expect("one dry corner");
            (d[0] + d[1] + d[2]) / 3.0 - one(dry)
        }
    }
}

/// `w · ((x1−x0) × (x2−x0))` with its gradient and (constant) Hessian.
pub fn triple(w: &Vec3, x: &[Vec3; 3]) -> (f64, Vec9, Mat9) {
    let s = w.dot(&(x[1] - x[0]).cross(&(x[2] - x[0])));
    let mut g = Vec9::zeros();
    g.fixed_rows_mut::<3>(0).copy_from(&(x[1] - x[2]).cross(w));
    g.fixed_rows_mut::<3>(3).copy_from(&(x[2] - x[0]).cross(w));
    g.fixed_rows_mut::<3>(6).copy_from(&(x[0] - x[1]).cross(w));
    // w·(xi × xj) = xiᵀ(−[w]×)xj for the cyclic pairs (0,1), (1,2), (2,0).
    let wx = w.cross_matrix();
    let mut h = Mat9::zeros();
    for (i, j) in [(0, 1), (1, 2), (2, 0)] {
        h.fixed_view_mut::<3, 3>(3 * i, 3 * j).copy_from(&(-wx));
        h.fixed_view_mut::<3, 3>(3 * j, 3 * i).copy_from(&wx);
    }
    (s, g, h)
}

/// The hydrostatic load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hydrostatic {
    /// ρ g (N/m³).
    pub rho_g: f64,
    /// Unit up direction.
    pub up: Vec3,
    /// Height of the liquid surface along `up` (same origin as positions).
    pub fill_height: f64,
}

impl Hydrostatic {
    /// Depth of a point below the surface (negative above it).
    #[inline]
    pub fn depth(&self, x: &Vec3) -> f64 {
        self.fill_height - x.dot(&self.up)
    }

    /// Pressure work `W_f` of a face (value only).
    pub fn work(&self, x: &[Vec3; 3]) -> f64 {
        let d = x.map(|p| self.depth(&p));
        if d.iter().all(|&v| v <= 0.0) {
            return 0.0;
        }
        let s = (-self.up).dot(&(x[1] - x[0]).cross(&(x[2] - x[0])));
        0.25 * self.rho_g * s * mean_sq_positive_depth(d).v
    }

    /// Pressure work `W_f` of a face with gradient and Hessian (None if the face is dry).
    pub fn work_derivatives(&self, x: &[Vec3; 3]) -> Option<(f64, Vec9, Mat9)> {
        let mut h = Mat9::zeros();
        self.work_derivatives_into(x, Some((&mut h, -1.0))).map(|(w, g)| (w, g, h))
    }

    /// Pressure work `W_f` of a face and its gradient (None if the face is dry); with
    /// `hessian = Some((h, s))`, also `h ← h − s·∇²W_f`, in place, entry by entry: the
    /// assembly's hot loop, without the 9×9 temporaries of the matrix expression
    /// `(S_h J + s_g J_gᵀ + J_g s_gᵀ + J_h s) ρg/4` (whose rounding it reproduces).
    pub fn work_derivatives_into(&self, x: &[Vec3; 3], hessian: Option<(&mut Mat9, f64)>) -> Option<(f64, Vec9)> {
        let d = x.map(|p| self.depth(&p));
        if d.iter().all(|&v| v <= 0.0) {
            return None;
        }
        let j = mean_sq_positive_depth(d);
        let (s, sg, sh) = triple(&(-self.up), x);
        let c = 0.25 * self.rho_g;
        // ∂d_a/∂x_a = −up, so ∂J/∂x_a = −J_a up and ∂²J/∂x_a∂x_b = J_ab up upᵀ.
        let mut jg = Vec9::zeros();
        for a in 0..3 {
            jg.fixed_rows_mut::<3>(3 * a).copy_from(&(-self.up * j.g[a]));
        }
        let w = c * s * j.v;
        let g = (sg * j.v + jg * s) * c;
        if let Some((h, scale)) = hessian {
            let up = &self.up;
            for col in 0..9 {
                for row in 0..9 {
                    let jh = (up[row % 3] * up[col % 3]) * j.h[row / 3][col / 3];
                    let wh = (sh[(row, col)] * j.v + sg[row] * jg[col] + jg[row] * sg[col] + jh * s) * c;
                    h[(row, col)] -= wh * scale;
                }
            }
        }
        Some((w, g))
    }

    /// Pressure work `W_f` of a face with its gradient and Hessian block with respect to
    /// corner `a` alone (the corner's 3×3 diagonal block of [`Hydrostatic::work_derivatives`];
    /// None if the face is dry): what a vertex-by-vertex relaxation needs.
    pub fn work_corner(&self, x: &[Vec3; 3], a: usize) -> Option<(f64, Vec3, Matrix3<f64>)> {
        let d = x.map(|p| self.depth(&p));
        if d.iter().all(|&v| v <= 0.0) {
            return None;
        }
        let j = mean_sq_positive_depth(d);
        let w = -self.up;
        let s = w.dot(&(x[1] - x[0]).cross(&(x[2] - x[0])));
        // ∂s/∂x_a as in `triple`; ∂²s/∂x_a² = 0; ∂J/∂x_a = −J_a up, ∂²J/∂x_a² = J_aa up upᵀ.
        let sg = (x[(a + 1) % 3] - x[(a + 2) % 3]).cross(&w);
        let jg = -self.up * j.g[a];
        let c = 0.25 * self.rho_g;
        let h = (sg * jg.transpose() + jg * sg.transpose() + self.up * self.up.transpose() * (j.h[a][a] * s)) * c;
        Some((c * s * j.v, (sg * j.v + jg * s) * c, h))
    }

    /// Liquid volume enclosed below the level by an outward-oriented face (its contribution).
    pub fn face_liquid_volume(&self, x: &[Vec3; 3]) -> f64 {
        let d = x.map(|p| self.depth(&p));
        let s = (-self.up).dot(&(x[1] - x[0]).cross(&(x[2] - x[0])));
        0.5 * s * mean_positive_depth(d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_check(h: &Hydrostatic, x: [Vec3; 3]) {
        let (_, g, hh) = h.work_derivatives(&x).expect("wet");
        let eps = 1e-6;
        for i in 0..9 {
            let mut xp = x;
            let mut xm = x;
            xp[i / 3][i % 3] += eps;
            xm[i / 3][i % 3] -= eps;
            let fd = (h.work(&xp) - h.work(&xm)) / (2.0 * eps);
            assert!((fd - g[i]).abs() < 1e-6 * (1.0 + g[i].abs()), "grad {i}: {fd} vs {}", g[i]);
            let gp = h.work_derivatives(&xp).map(|t| t.1).unwrap_or_else(Vec9::zeros);
            let gm = h.work_derivatives(&xm).map(|t| t.1).unwrap_or_else(Vec9::zeros);
            for j in 0..9 {
                let fdh = (gp[j] - gm[j]) / (2.0 * eps);
                assert!(
                    (fdh - hh[(j, i)]).abs() < 1e-5 * (1.0 + hh[(j, i)].abs()),
                    "hess ({j},{i}): {fdh} vs {}",
                    hh[(j, i)]
                );
            }
        }
    }

    /// The corner blocks are those of the full derivatives, wet, crossing and partial faces.
    #[test]
    fn corner_blocks_match_the_full_derivatives() {
        let h = Hydrostatic { rho_g: 1460.0 * 9.81, up: Vec3::new(0.1, 0.2, 0.97).normalize(), fill_height: 0.5 };
        for x in [
            [Vec3::new(0.0, 0.0, 0.1), Vec3::new(0.3, 0.05, 0.2), Vec3::new(0.1, 0.4, 0.15)],
            [Vec3::new(0.0, 0.0, 0.3), Vec3::new(0.3, 0.05, 0.8), Vec3::new(0.1, 0.4, 0.9)],
            [Vec3::new(0.0, 0.0, 0.2), Vec3::new(0.3, 0.05, 0.3), Vec3::new(0.1, 0.4, 0.9)],
        ] {
            let (w, g, hh) = h.work_derivatives(&x).expect("wet");
            for a in 0..3 {
                let (wa, ga, ha) = h.work_corner(&x, a).expect("wet");
                assert!((wa - w).abs() <= 1e-15 * w.abs());
                assert!((ga - g.fixed_rows::<3>(3 * a)).norm() <= 1e-12 * g.norm());
                assert!((ha - hh.fixed_view::<3, 3>(3 * a, 3 * a)).norm() <= 1e-12 * hh.norm(), "{a}");
            }
        }
        let dry = [Vec3::new(0.0, 0.0, 0.6), Vec3::new(0.3, 0.05, 0.7), Vec3::new(0.1, 0.4, 0.9)];
        assert!(h.work_corner(&dry, 1).is_none());
    }

    #[test]
    fn derivatives_for_wet_crossing_and_partial_faces() {
        let h = Hydrostatic { rho_g: 1460.0 * 9.81, up: Vec3::new(0.1, 0.2, 0.97).normalize(), fill_height: 0.5 };
        // Fully wetted, one corner wet, two corners wet.
        fd_check(&h, [Vec3::new(0.0, 0.0, 0.1), Vec3::new(0.3, 0.05, 0.2), Vec3::new(0.1, 0.4, 0.15)]);
        fd_check(&h, [Vec3::new(0.0, 0.0, 0.3), Vec3::new(0.3, 0.05, 0.8), Vec3::new(0.1, 0.4, 0.9)]);
        fd_check(&h, [Vec3::new(0.0, 0.0, 0.2), Vec3::new(0.3, 0.05, 0.3), Vec3::new(0.1, 0.4, 0.9)]);
    }

    #[test]
    fn closed_form_of_the_wet_face_is_the_dual_number_evaluation() {
        // Same bits as the generic dual-number sum, which it replaces.
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..1000 {
            let d = [rnd() * 0.7, rnd() * 1e-3, rnd() * 50.0];
            let v = [D3::var(d[0], 0), D3::var(d[1], 1), D3::var(d[2], 2)];
            let dual = full(&v);
            let closed = full_wet(d);
            assert_eq!(closed.v.to_bits(), dual.v.to_bits());
            for i in 0..3 {
                assert_eq!(closed.g[i].to_bits(), dual.g[i].to_bits());
                for j in 0..3 {
                    assert_eq!(closed.h[i][j].to_bits(), dual.h[i][j].to_bits());
                }
            }
        }
    }

    #[test]
    fn mean_depth_formulas_match_quadrature() {
        // Subdivide the reference triangle finely and average.
        let cases = [[0.3, 0.1, 0.2], [0.5, -0.2, -0.4], [0.4, 0.3, -0.5], [-0.1, -0.2, -0.3], [0.2, 0.2000001, -0.1]];
        let n = 400;
        for d in cases {
            let (mut s1, mut s2, mut cnt) = (0.0, 0.0, 0.0);
            for i in 0..n {
                for j in 0..n - i {
                    // Centroid of the small triangle (upward ones only, and the downward ones).
                    for (u, v) in [
                        ((i as f64 + 1.0 / 3.0) / n as f64, (j as f64 + 1.0 / 3.0) / n as f64),
                        ((i as f64 + 2.0 / 3.0) / n as f64, (j as f64 + 2.0 / 3.0) / n as f64),
                    ] {
                        if u + v > 1.0 {
                            continue;
                        }
                        let dd: f64 = d[0] * (1.0 - u - v) + d[1] * u + d[2] * v;
                        s1 += dd.max(0.0);
                        s2 += dd.max(0.0).powi(2);
                        cnt += 1.0;
                    }
                }
            }
            assert!((mean_positive_depth(d) - s1 / cnt).abs() < 2e-4, "{d:?}");
            assert!((mean_sq_positive_depth(d).v - s2 / cnt).abs() < 2e-4, "{d:?}");
        }
    }
}
