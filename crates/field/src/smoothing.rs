//! The two smoothing passes of paper §4.2 as one solver: minimise Eq. 7,
//!
//! `E = Σ_e ω_e (θ_a − θ_b + ρ_e + (π/2) p_e)² + Σ_f α w_f m_f (θ_f − ψ_f)²`,
//!
//! over angles θ and integer period jumps p, with some faces optionally fixed (pass 2 fixes the
//! anisotropic faces and sets α = 0 elsewhere).
//!
//! The mixed-integer problem is solved by a **convex power-field initialisation refined with
//! Eq. 7** (the second option): first the 4-RoSy power field `u = e^{4iθ}` minimising
//! `Σ_e |u_a e^{4iρ_e} − u_b|² + Σ_f α w_f |u_f − e^{4iψ_f}|²` (Knöppel et al. 2013; convex, one
//! sparse solve, singularities emerge where |u| vanishes, no period jumps needed); then the
//! jumps are rounded from its angles and Eq. 7 is minimised exactly over θ with those jumps
//! fixed (a linear least-squares problem), alternating rounding and solving until the jumps no
//! longer change. The Eq. 7 matrix does not depend on the jumps or targets, so it is factored
//! once ([`AngleSolver`]) and every re-solve (also in singularity relaxation) is a pair of
//! triangular solves.
//!
//! Discretisation: ω_e is the primal/dual edge-length ratio and m_f the face area, both
//! normalised to 1 on an equilateral mesh of uniform size, where this is exactly the paper's
//! uniform-weight Eq. 7; on irregular meshes the weights keep the energy a discretisation of
//! the Dirichlet energy (with uniform weights the smoothest field of an icosphere had a
//! spurious singularity pair).
//!
//! ψ_f is defined modulo π/2; the soft term uses the representative closest to the current θ_f
//! (so the cross symmetry is respected). With neither fixed faces nor alignment weight, the
//! smoothest field is the smallest eigenvector of the connection Laplacian, found by inverse
//! iteration.

use crate::cross::{CrossField, round_jumps};
use crate::error::FieldError;
use clothcast_mesh::sparse::{CholeskyFactor, CholeskySolver, SymmetricPattern};
use clothcast_mesh::{EdgeData, FaceData, Mesh};
use std::f64::consts::FRAC_PI_2;

const NONE: u32 = u32::MAX;
/// Relative regularisation that fixes null spaces (global rotation of an unanchored field).
const EPS: f64 = 1e-10;

/// The closest representative of ψ (mod π/2) to θ.
#[inline]
pub fn nearest_rep(psi: f64, theta: f64) -> f64 {
    psi + FRAC_PI_2 * ((theta - psi) / FRAC_PI_2).round()
}

/// Geometric weight of each interior edge in the smoothness term: primal over dual edge length
/// (the discrete Dirichlet energy of a face-based field), divided by √3 so that it is 1 on an
/// equilateral mesh, where Eq. 7's uniform weights are recovered.
pub fn edge_weights(mesh: &Mesh) -> EdgeData<f64> {
    mesh.edges()
        .map(|e| match mesh.edge_faces(e) {
            (a, Some(b)) => {
                let d = (mesh.face_centroid(a) - mesh.face_centroid(b)).norm();
                mesh.edge_length(e) / (d.max(1e-300) * 3f64.sqrt())
            }
            _ => 0.0,
        })
        .collect()
}

/// One smoothing problem: weights α·w_f of the alignment term and optionally fixed angles.
pub struct Smoother<'a> {
    mesh: &'a Mesh,
    rho: &'a EdgeData<f64>,
    edge_w: EdgeData<f64>,
    mass: FaceData<f64>,
    weight: FaceData<f64>,
    fixed: FaceData<Option<f64>>,
    free_index: Vec<u32>,
    n_free: usize,
}

impl<'a> Smoother<'a> {
    /// A smoothing problem. `weight[f]` is α·w_f; `fixed[f]` pins θ_f.
    pub fn new(mesh: &'a Mesh, rho: &'a EdgeData<f64>, weight: FaceData<f64>, fixed: FaceData<Option<f64>>) -> Self {
        let mut free_index = vec![NONE; mesh.n_faces()];
        let mut n_free = 0;
        for (f, fx) in fixed.enumerate() {
            if fx.is_none() {
                free_index[f.idx()] = n_free as u32;
                n_free += 1;
            }
        }
        let mean_area = mesh.total_area() / mesh.n_faces().max(1) as f64;
        let mass = mesh.face_areas().map(|a| a / mean_area);
        Self { mesh, rho, edge_w: edge_weights(mesh), weight, fixed, free_index, n_free, mass }
    }

    fn anchored(&self) -> bool {
        self.fixed.iter().any(|f| f.is_some()) || self.weight.iter().any(|&w| w > 0.0)
    }

    /// Eq. 7 energy of a field: (smoothness, alignment).
    pub fn energy(&self, field: &CrossField, targets: &FaceData<f64>) -> (f64, f64) {
        let smooth =
            self.mesh.edges().map(|e| self.edge_w[e] * field.edge_residual(self.mesh, self.rho, e).powi(2)).sum();
        let align = self
            .mesh
            .face_ids()
            .map(|f| self.weight[f] * (field.theta[f] - nearest_rep(targets[f], field.theta[f])).powi(2))
            .sum();
        (smooth, align)
    }

    /// The full pass: power-field initialisation, then alternate jump rounding and the exact
    /// Eq. 7 solve until the jumps are stable.
    pub fn solve(&self, targets: &FaceData<f64>) -> Result<(CrossField, AngleSolver), FieldError> {
        let theta0 = self.power_field(targets)?;
        let solver = self.angle_solver()?;
        let mut field = CrossField::from_angles(self.mesh, self.rho, theta0);
        for _ in 0..8 {
            let theta = solver.solve(self, &field.jumps, targets, &field.theta);
            let jumps = round_jumps(self.mesh, self.rho, &theta);
            let stable = jumps == field.jumps;
            field = CrossField { theta, jumps: field.jumps };
            if stable {
                break;
            }
            field.jumps = jumps;
        }
        Ok((field, solver))
    }

    /// Angles of the power field (one sparse solve, or inverse iteration when unanchored).
    pub fn power_field(&self, targets: &FaceData<f64>) -> Result<FaceData<f64>, FieldError> {
        let mesh = self.mesh;
        let n = 2 * self.n_free;
        let fi = |f: clothcast_mesh::FaceId| self.free_index[f.idx()];
        let unit = |a: f64| [(4.0 * a).cos(), (4.0 * a).sin()];
        let mut entries: Vec<(usize, usize)> = Vec::new();
        for e in mesh.edges() {
            if let (a, Some(b)) = mesh.edge_faces(e) {
                let (ia, ib) = (fi(a), fi(b));
                if ia != NONE && ib != NONE {
                    for r in 0..2 {
                        for c in 0..2 {
                            entries.push((2 * ia as usize + r, 2 * ib as usize + c));
                        }
                    }
                }
            }
        }
        for i in 0..self.n_free {
            entries.push((2 * i + 1, 2 * i));
        }
        let pattern = SymmetricPattern::from_entries(n, entries);
        let mut vals = vec![0.0; pattern.nnz()];
        let mut rhs = vec![0.0; n];
        let add = |vals: &mut Vec<f64>, i: usize, j: usize, v: f64| {
            if i >= j {
                vals[pattern.slot(i, j)] += v;
            }
        };
        for e in mesh.edges() {
            let (a, Some(b)) = mesh.edge_faces(e) else { continue };
            let w = self.edge_w[e];
            let (c, s) = ((4.0 * self.rho[e]).cos(), (4.0 * self.rho[e]).sin());
            // R = [[c, −s], [s, c]]; term w |R u_a − u_b|².
            let rot = [[w * c, -w * s], [w * s, w * c]];
            match (fi(a), fi(b)) {
                (ia, ib) if ia != NONE && ib != NONE => {
                    let (ia, ib) = (2 * ia as usize, 2 * ib as usize);
                    for k in 0..2 {
                        add(&mut vals, ia + k, ia + k, w);
                        add(&mut vals, ib + k, ib + k, w);
                    }
                    // A_ab = −Rᵀ, A_ba = −R (store the lower triangle only).
                    for r in 0..2 {
                        for col in 0..2 {
                            add(&mut vals, ia + r, ib + col, -rot[col][r]);
                            add(&mut vals, ib + r, ia + col, -rot[r][col]);
                        }
                    }
                }
                (ia, ib) if ia == NONE && ib != NONE => {
                    let ca = unit(self.fixed[a].expect("fixed"));
                    let ib = 2 * ib as usize;
                    for k in 0..2 {
                        add(&mut vals, ib + k, ib + k, w);
                        rhs[ib + k] += rot[k][0] * ca[0] + rot[k][1] * ca[1];
                    }
                }
                (ia, ib) if ia != NONE && ib == NONE => {
                    let cb = unit(self.fixed[b].expect("fixed"));
                    let ia = 2 * ia as usize;
                    for k in 0..2 {
                        add(&mut vals, ia + k, ia + k, w);
                        rhs[ia + k] += rot[0][k] * cb[0] + rot[1][k] * cb[1];
                    }
                }
                _ => {}
            }
        }
        for f in mesh.face_ids() {
            let i = fi(f);
            if i == NONE {
                continue;
            }
            let w = self.weight[f] * self.mass[f];
            let c = unit(targets[f]);
            for k in 0..2 {
                add(&mut vals, 2 * i as usize + k, 2 * i as usize + k, w);
                rhs[2 * i as usize + k] += w * c[k];
            }
        }
        let diag_mean = pattern.diagonal_slots().iter().map(|&s| vals[s]).sum::<f64>() / n.max(1) as f64;
        let eps = EPS * diag_mean.max(1e-300);
        for f in mesh.face_ids() {
            let i = fi(f);
            if i != NONE {
                for k in 0..2 {
                    vals[pattern.slot(2 * i as usize + k, 2 * i as usize + k)] += eps * self.mass[f];
                }
            }
        }
        let mut u = vec![0.0; n];
        if n > 0 {
            let factor = CholeskySolver::new(&pattern)?.factor(&pattern, &vals)?;
            if self.anchored() {
                u.copy_from_slice(&rhs);
                factor.solve_in_place(&mut u);
            } else {
                // Smoothest field: the smallest eigenvector of L u = λ M u (M = face areas), by
                // inverse iteration from a seeded random vector. The lowest eigenspace can be
                // degenerate (9-dimensional for a round sphere); a symmetric start on a
                // symmetric mesh lands on special members with multiple zeros (two order-4
                // zeros on an icosphere), a generic start on one with simple zeros.
                let mut rng = clothcast_mesh::util::SplitMix64::new(0x5EED);
                u.iter_mut().for_each(|x| *x = rng.next_f64() - 0.5);
                for _ in 0..200 {
                    for f in mesh.face_ids() {
                        let i = 2 * fi(f) as usize;
                        u[i] *= self.mass[f];
                        u[i + 1] *= self.mass[f];
                    }
                    factor.solve_in_place(&mut u);
                    let norm = u.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
                    u.iter_mut().for_each(|x| *x /= norm);
                }
            }
        }
        Ok(mesh
            .face_ids()
            .map(|f| match self.fixed[f] {
                Some(t) => t,
                None => {
                    let i = 2 * fi(f) as usize;
                    u[i + 1].atan2(u[i]) / 4.0
                }
            })
            .collect())
    }

    /// The factored Eq. 7 system (independent of jumps and targets).
    pub fn angle_solver(&self) -> Result<AngleSolver, FieldError> {
        let mesh = self.mesh;
        let fi = |f: clothcast_mesh::FaceId| self.free_index[f.idx()];
        let mut entries = Vec::new();
        for e in mesh.edges() {
            if let (a, Some(b)) = mesh.edge_faces(e)
                && fi(a) != NONE
                && fi(b) != NONE
            {
                entries.push((fi(a) as usize, fi(b) as usize));
            }
        }
        let n = self.n_free;
        let pattern = SymmetricPattern::from_entries(n, entries);
        let mut vals = vec![0.0; pattern.nnz()];
        for e in mesh.edges() {
            let (a, Some(b)) = mesh.edge_faces(e) else { continue };
            let (ia, ib) = (fi(a), fi(b));
            let w = self.edge_w[e];
            if ia != NONE {
                vals[pattern.slot(ia as usize, ia as usize)] += w;
            }
            if ib != NONE {
                vals[pattern.slot(ib as usize, ib as usize)] += w;
            }
            if ia != NONE && ib != NONE {
                vals[pattern.slot(ia as usize, ib as usize)] -= w;
            }
        }
        for f in mesh.face_ids() {
            if fi(f) != NONE {
                vals[pattern.slot(fi(f) as usize, fi(f) as usize)] += self.weight[f] * self.mass[f];
            }
        }
        let diag_mean = pattern.diagonal_slots().iter().map(|&s| vals[s]).sum::<f64>() / n.max(1) as f64;
        let eps = EPS * diag_mean.max(1e-300);
        for &s in &pattern.diagonal_slots() {
            vals[s] += eps;
        }
        let factor = if n > 0 { Some(CholeskySolver::new(&pattern)?.factor(&pattern, &vals)?) } else { None };
        Ok(AngleSolver { factor, eps, n })
    }
}

/// The factored Eq. 7 system of a [`Smoother`].
pub struct AngleSolver {
    factor: Option<CholeskyFactor>,
    eps: f64,
    n: usize,
}

impl AngleSolver {
    /// θ minimising Eq. 7 for the given jumps; `guess` provides the representatives of the
    /// targets (nearest to it) and the tiny regularisation's anchor.
    pub fn solve(
        &self,
        sm: &Smoother<'_>,
        jumps: &EdgeData<i32>,
        targets: &FaceData<f64>,
        guess: &FaceData<f64>,
    ) -> FaceData<f64> {
        let mesh = sm.mesh;
        let fi = |f: clothcast_mesh::FaceId| sm.free_index[f.idx()];
        let mut rhs = vec![0.0; self.n];
        for e in mesh.edges() {
            let (a, Some(b)) = mesh.edge_faces(e) else { continue };
            let t = sm.rho[e] + FRAC_PI_2 * jumps[e] as f64;
            let w = sm.edge_w[e];
            // Term w (θ_a − θ_b + t)².
            match (fi(a), fi(b)) {
                (ia, ib) if ia != NONE && ib != NONE => {
                    rhs[ia as usize] -= w * t;
                    rhs[ib as usize] += w * t;
                }
                (ia, ib) if ia == NONE && ib != NONE => rhs[ib as usize] += w * (sm.fixed[a].expect("fixed") + t),
                (ia, ib) if ia != NONE && ib == NONE => rhs[ia as usize] += w * (sm.fixed[b].expect("fixed") - t),
                _ => {}
            }
        }
        for f in mesh.face_ids() {
            let i = fi(f);
            if i != NONE {
                rhs[i as usize] += sm.weight[f] * sm.mass[f] * nearest_rep(targets[f], guess[f]) + self.eps * guess[f];
            }
        }
        if let Some(factor) = &self.factor {
            factor.solve_in_place(&mut rhs);
        }
        mesh.face_ids().map(|f| sm.fixed[f].unwrap_or_else(|| rhs[fi(f) as usize])).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cross::connection;
    use clothcast_mesh::shapes;

    #[test]
    fn fully_constrained_field_reproduces_its_input() {
        let m = shapes::torus(2.0, 0.7, 24, 12);
        let rho = connection(&m);
        let mut rng = clothcast_mesh::util::SplitMix64::new(7);
        let input: FaceData<f64> = m.face_ids().map(|_| rng.next_f64() * 3.0).collect();
        let sm = Smoother::new(&m, &rho, FaceData::filled(m.n_faces(), 0.0), input.map(|&t| Some(t)));
        let (field, _) = sm.solve(&input).unwrap();
        assert_eq!(field.theta, input);
    }

    /// The smoothest field (no constraint, no alignment), after relaxation: a sphere has eight
    /// valence-3 singularities, a torus none.
    #[test]
    fn smoothest_fields_sphere_and_torus() {
        for (m, expect) in [(shapes::icosphere(3, 1.0), vec![1; 8]), (shapes::torus(2.0, 0.7, 48, 24), vec![])] {
            let rho = connection(&m);
            let targets = FaceData::filled(m.n_faces(), 0.0);
            let sm = Smoother::new(&m, &rho, FaceData::filled(m.n_faces(), 0.0), FaceData::filled(m.n_faces(), None));
            let (mut field, solver) = sm.solve(&targets).unwrap();
            // The convex relaxation may leave dipoles that the exact energy does not want.
            let opts = crate::relax::RelaxOptions { radius: m.bbox().diagonal(), merge_tolerance: 0.0 };
            crate::relax::relax(&m, &rho, &sm, &solver, &targets, &mut field, &opts);
            let idx: Vec<i32> = field.singularities(&m, &rho).iter().map(|s| s.index).collect();
            assert_eq!(idx, expect);
        }
    }
}
