//! Uniform head pressure, self weight and rigid support planes.
//!
//! - Head pressure p_h is conservative with work `p_h · V(x)`, V the volume enclosed by the
//!   surface, `V = Σ_f (1/6) y0·(y1 × y2)` with `y = x − c` for a fixed reference point c. For
//!   a closed surface V does not depend on c; for an open one the missing caps are constant
//!   only if the boundary is fixed (checked by the caller).
//! - Self weight: `m_v g (x_v · up)` with lumped masses.
//! - Supports: planes the fabric cannot pass, enforced by the smooth log barrier of
//!   Incremental Potential Contact (Li et al. 2020), `b(d) = −κ (d − d̂)² ln(d/d̂)` for
//!   `0 < d < d̂`, where d is the signed distance to the plane; the line search never lets d
//!   reach 0, so the fabric cannot pass. The contact force on a support is `Σ −b'(d) n`.

use crate::element::{Mat9, Vec9};
use clothcast_mesh::Vec3;
use nalgebra::Matrix3;

/// Enclosed-volume contribution of a face relative to `c`, with gradient and Hessian.
pub fn face_volume(x: &[Vec3; 3], c: &Vec3) -> (f64, Vec9, Mat9) {
    let y = x.map(|p| p - c);
    let v = y[0].dot(&y[1].cross(&y[2])) / 6.0;
    let mut g = Vec9::zeros();
    g.fixed_rows_mut::<3>(0).copy_from(&(y[1].cross(&y[2]) / 6.0));
    g.fixed_rows_mut::<3>(3).copy_from(&(y[2].cross(&y[0]) / 6.0));
    g.fixed_rows_mut::<3>(6).copy_from(&(y[0].cross(&y[1]) / 6.0));
    // ∂²/∂yi∂yj of y0·(y1×y2) for cyclic (i, j, k): −[y_k]×.
    let mut h = Mat9::zeros();
    for (i, j, k) in [(0, 1, 2), (1, 2, 0), (2, 0, 1)] {
        let m: Matrix3<f64> = -y[k].cross_matrix() / 6.0;
        h.fixed_view_mut::<3, 3>(3 * i, 3 * j).copy_from(&m);
        h.fixed_view_mut::<3, 3>(3 * j, 3 * i).copy_from(&m.transpose());
    }
    (v, g, h)
}

/// A rigid plane: the fabric stays on the side `normal` points to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point of the plane.
    pub point: Vec3,
    /// Unit normal towards the allowed side.
    pub normal: Vec3,
}

impl Plane {
    /// Plane through `point` with normal `normal` (normalized here).
    pub fn new(point: Vec3, normal: Vec3) -> Self {
        Self { point, normal: normal.normalize() }
    }
    /// Signed distance (positive on the allowed side).
    #[inline]
    pub fn distance(&self, x: &Vec3) -> f64 {
        (x - self.point).dot(&self.normal)
    }
}

/// The IPC log barrier with activation distance `dhat` and stiffness `kappa`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Barrier {
    /// Activation distance.
    pub dhat: f64,
    /// Stiffness (N/m).
    pub kappa: f64,
}

impl Barrier {
    /// b(d), b'(d), b''(d); zero beyond `dhat`, +∞ at or behind the plane.
    #[inline]
    pub fn eval(&self, d: f64) -> (f64, f64, f64) {
        if d >= self.dhat {
            return (0.0, 0.0, 0.0);
        }
        if d <= 0.0 {
            return (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
        }
        let (k, h) = (self.kappa, self.dhat);
        let t = d - h;
        let l = (d / h).ln();
        (-k * t * t * l, -k * (2.0 * t * l + t * t / d), -k * (2.0 * l + 4.0 * t / d - t * t / (d * d)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn volume_derivatives_match_finite_differences() {
        let x = [Vec3::new(0.3, 0.1, 0.2), Vec3::new(1.0, 0.2, -0.1), Vec3::new(0.2, 0.9, 0.4)];
        let c = Vec3::new(0.1, -0.2, 0.05);
        let (_, g, h) = face_volume(&x, &c);
        let eps = 1e-6;
        for i in 0..9 {
            let (mut xp, mut xm) = (x, x);
            xp[i / 3][i % 3] += eps;
            xm[i / 3][i % 3] -= eps;
            let (vp, gp, _) = face_volume(&xp, &c);
            let (vm, gm, _) = face_volume(&xm, &c);
            assert!(((vp - vm) / (2.0 * eps) - g[i]).abs() < 1e-8);
            for j in 0..9 {
                assert!(((gp[j] - gm[j]) / (2.0 * eps) - h[(j, i)]).abs() < 1e-8, "({j},{i})");
            }
        }
    }

    #[test]
    fn barrier_derivatives() {
        let b = Barrier { dhat: 0.01, kappa: 3.0 };
        for d in [0.001, 0.004, 0.0099] {
            let (e, g, h) = b.eval(d);
            assert!(e > 0.0 && g < 0.0 && h > 0.0);
            let eps = 1e-9;
            assert!(((b.eval(d + eps).0 - b.eval(d - eps).0) / (2.0 * eps) - g).abs() < 1e-5 * g.abs());
            assert!(((b.eval(d + eps).1 - b.eval(d - eps).1) / (2.0 * eps) - h).abs() < 1e-4 * h.abs());
        }
        assert_eq!(b.eval(0.02), (0.0, 0.0, 0.0));
        assert_eq!(b.eval(0.0).0, f64::INFINITY);
    }
}
