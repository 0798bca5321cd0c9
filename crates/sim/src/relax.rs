//! Local relaxation: nonlinear block Gauss–Seidel on a set of vertices, the rest held.
//!
//! Newton's step is right for the mold as a whole, but not for every vertex: a vertex among
//! wrinkled or slack faces has next to no stiffness across the wrinkles, so the step moves it a
//! long way, and where its faces tighten again the energy rises far beyond the quadratic
//! model. On camelhead, a step that would have lowered Π by 0.04 J raised it by 13 572 J, 90%
//! of it in a single face; backtracking then shortened the whole step to 1/64 for the sake of
//! that face's vertices, and the solve crawled (97 iterations). Relaxing the few
//! vertices that overshoot, each to the minimum of its own energy with its neighbours held,
//! repairs such a step where it went wrong and keeps it everywhere else (see
//! [`crate::newton`]: camelhead 97 → 72 iterations, kitten's fine solve 71 → 29 with the
//! coarse start of the time).
//!
//! Each vertex takes a Newton step on its local energy (its faces, its weight, its contacts):
//! the 3×3 block of the Hessian, its eigenvalues floored to keep it positive definite, the
//! constrained axes of its frame held, and a backtracking line search on the local energy, so
//! that the total energy never rises. Vertices are coloured so that no two of one colour share
//! a face; the vertices of a colour are independent and move in parallel, colour after colour.
//! The colouring and the order are fixed by the vertex ids, so the result does not depend on
//! the number of threads. A sweep visits the vertices that are still moving (or next to one
//! that is), until none moves by more than the tolerance or the sweeps run out.

use crate::system::System;
use clothcast_mesh::Vec3;
use nalgebra::Matrix3;
use rayon::prelude::*;

/// Backtracking halvings of a vertex's step before it is left where it is.
const VERTEX_HALVINGS: usize = 6;
/// Eigenvalues of a vertex's Hessian block are floored at this fraction of the largest.
const EIGEN_FLOOR: f64 = 1e-6;
/// Parallel work items of fewer vertices than this are not split further.
const MIN_PARALLEL: usize = 64;

/// What one relaxation did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RelaxReport {
    /// Vertices in the set (free ones).
    pub vertices: usize,
    /// Sweeps run.
    pub sweeps: usize,
    /// Vertex moves made.
    pub moves: usize,
}

impl System<'_> {
    /// Relax the free vertices among `seeds` by at most `sweeps` sweeps of nonlinear block
    /// Gauss–Seidel on Π at load factor `s` (see the module documentation); a vertex that moves
    /// by no more than `tolerance` (m), and none of whose neighbours does, is settled. Π never
    /// rises.
    pub fn relax(&self, x: &mut [Vec3], s: f64, seeds: &[usize], sweeps: usize, tolerance: f64) -> RelaxReport {
        let mut set: Vec<usize> = seeds.iter().copied().filter(|&v| self.frame(v).1 < 3).collect();
        set.sort_unstable();
        set.dedup();
        let mut report = RelaxReport { vertices: set.len(), ..Default::default() };
        // Scratch per vertex: colour (u32::MAX: not in the current sweep), moved flag.
        let mut colour = vec![u32::MAX; x.len()];
        let mut moved = vec![false; x.len()];
        let mut active = set.clone();
        while report.sweeps < sweeps && !active.is_empty() {
            report.sweeps += 1;
            let classes = self.colour_classes(&active, &mut colour);
            for class in &classes {
                let xr: &[Vec3] = x;
                let steps: Vec<Option<Vec3>> =
                    class.par_iter().with_min_len(MIN_PARALLEL).map(|&v| self.vertex_step(xr, v, s)).collect();
                for (&v, y) in class.iter().zip(steps) {
                    if let Some(y) = y {
                        report.moves += 1;
                        moved[v] = (y - x[v]).norm() > tolerance;
                        x[v] = y;
                    }
                }
            }
            for &v in &active {
                colour[v] = u32::MAX;
            }
            // Next sweep: the vertices of the set that moved or are next to one that did.
            let next: Vec<usize> =
                set.iter().copied().filter(|&v| moved[v] || self.vertex_neighbours(v).any(|w| moved[w])).collect();
            for &v in &active {
                moved[v] = false;
            }
            active = next;
        }
        report
    }

    /// Greedy colouring of `vertices` (ascending ids): no two vertices of one class share a
    /// face. `colour` is scratch, u32::MAX on entry for every vertex; the caller resets it.
    fn colour_classes(&self, vertices: &[usize], colour: &mut [u32]) -> Vec<Vec<usize>> {
        let mut classes: Vec<Vec<usize>> = Vec::new();
        let mut used: Vec<bool> = Vec::new();
        for &v in vertices {
            used.iter_mut().for_each(|u| *u = false);
            for w in self.vertex_neighbours(v) {
                let c = colour[w];
                if c != u32::MAX {
                    used[c as usize] = true;
                }
            }
            let c = used.iter().position(|&u| !u).unwrap_or(used.len());
            if c == classes.len() {
                classes.push(Vec::new());
                used.push(false);
            }
            colour[v] = c as u32;
            classes[c].push(v);
        }
        classes
    }

    /// The new position of vertex `v` after one Newton step on its local energy with the other
    /// vertices at `x` (None if no step lowers it).
    fn vertex_step(&self, x: &[Vec3], v: usize, s: f64) -> Option<Vec3> {
        let (e0, g, h) = self.vertex_terms(x, v, &x[v], s, true);
        // In the vertex's frame: constrained axes first, held (zero gradient, decoupled).
        let (frame, k) = self.frame(v);
        let r = frame.unwrap_or_else(Matrix3::identity);
        let (mut gf, mut hf) = (r.transpose() * g, r.transpose() * h * r);
        let free_scale = (k..3).map(|i| hf[(i, i)].abs()).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
        for i in 0..k {
            gf[i] = 0.0;
            for j in 0..3 {
                hf[(i, j)] = 0.0;
                hf[(j, i)] = 0.0;
            }
            hf[(i, i)] = free_scale;
        }
        // Where no eigenvalue can be below the floor, the floored eigen-decomposition's step is
        // the plain Newton step: a Cholesky solve (most vertices). For a positive definite 3×3
        // block λ_min = det/(λ_a λ_b) ≥ det/(tr/2)² and λ_max ≤ tr, so det > floor · tr³/4
        // keeps λ_min above floor · λ_max.
        let tr = hf.trace();
        let safe = tr > 0.0 && hf.determinant() > EIGEN_FLOOR * tr * tr * tr / 4.0;
        let df = match hf.cholesky().filter(|_| safe) {
            Some(c) => -c.solve(&gf),
            None => {
                let eig = hf.symmetric_eigen();
                let lmax = eig.eigenvalues.max();
                if !(lmax > 0.0) {
                    return None;
                }
                let mut df = Vec3::zeros();
                for i in 0..3 {
                    let q = eig.eigenvectors.column(i);
                    df -= q * (q.dot(&gf) / eig.eigenvalues[i].max(EIGEN_FLOOR * lmax));
                }
                df
            }
        };
        let d = r * df;
        let slope = g.dot(&d);
        if !(slope < 0.0) {
            return None;
        }
        let mut alpha = 1.0;
        for _ in 0..=VERTEX_HALVINGS {
            let y = x[v] + d * alpha;
            if self.vertex_terms(x, v, &y, s, false).0 <= e0 + 1e-4 * alpha * slope {
                return Some(y);
            }
            alpha *= 0.5;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::constraints::Constraints;
    use crate::hydrostatic::Hydrostatic;
    use crate::material::WrinklingStVenantKirchhoff;
    use crate::system::Loads;
    use clothcast_mesh::VertexId;

    fn sphere_problem() -> (clothcast_mesh::Mesh, WrinklingStVenantKirchhoff, Loads, Constraints) {
        let mesh = clothcast_mesh::shapes::icosphere(3, 0.2);
        let mat = WrinklingStVenantKirchhoff::from_young_poisson(5e4, 0.3);
        let loads = Loads {
            hydrostatic: Some(Hydrostatic { rho_g: 1460.0 * 9.81, up: Vec3::z(), fill_height: 0.2 }),
            head_pressure: 200.0,
            self_weight: Some((2.0, Vec3::z())),
        };
        let mut c = Constraints::free(mesh.n_vertices());
        for v in mesh.vertices() {
            if mesh.position(v).z > 0.17 {
                c.fix_vertex(v);
            }
        }
        c.fix_direction(VertexId(5), Vec3::new(1.0, 0.0, 0.0));
        (mesh, mat, loads, c)
    }

    /// Vertices pushed off their places go back towards them, the energy falls, constrained
    /// axes stay put, and the result does not depend on the number of threads.
    #[test]
    fn relaxation_lowers_the_energy_and_is_deterministic() {
        let (mesh, mat, loads, c) = sphere_problem();
        let sys = System::new(&mesh, &mat, loads, &c, vec![], None);
        let target: Vec<Vec3> = mesh.positions().as_slice().to_vec();
        let mut x = target.clone();
        let seeds: Vec<usize> = (0..mesh.n_vertices()).step_by(7).collect();
        for &v in &seeds {
            if c.n_fixed(VertexId(v as u32)) == 0 {
                x[v] += Vec3::new(0.004, -0.003, 0.002) * (1.0 + (v % 3) as f64);
            }
        }
        x[5] += Vec3::new(0.003, 0.002, 0.0);
        let before = x.clone();
        let e0 = sys.energy(&x, 1.0);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut y = before.clone();
            let mut seeds5 = seeds.clone();
            seeds5.push(5);
            let r = pool.install(|| sys.relax(&mut y, 1.0, &seeds5, 20, 1e-9));
            (y, r)
        };
        let (x1, r1) = run(1);
        let (x2, r2) = run(2);
        assert_eq!(r1, r2);
        assert!(x1.iter().zip(&x2).all(|(a, b)| a == b), "thread count changed the result");
        let e1 = sys.energy(&x1, 1.0);
        assert!(e1 < e0 - 1.0, "energy {e0} → {e1}");
        assert!(r1.sweeps > 1 && r1.moves > 0);
        // Clamped vertices and vertex 5's fixed axis do not move; vertices outside the set neither.
        for v in 0..x1.len() {
            let fixed = c.n_fixed(VertexId(v as u32));
            if fixed == 3 || !(seeds.contains(&v) || v == 5) {
                assert_eq!(x1[v], before[v], "vertex {v} moved");
            }
        }
        assert!((x1[5] - before[5]).x.abs() < 1e-15, "vertex 5 moved along its fixed axis");
        // The displaced vertices went most of the way back.
        let off = |y: &[Vec3]| seeds.iter().map(|&v| (y[v] - target[v]).norm()).sum::<f64>();
        assert!(off(&x1) < 0.2 * off(&before), "{} vs {}", off(&x1), off(&before));
    }

    /// At an equilibrium nothing moves (beyond round-off), and one sweep settles it.
    #[test]
    fn relaxation_keeps_an_equilibrium() {
        let mesh = clothcast_mesh::shapes::icosphere(2, 0.2);
        let mat = WrinklingStVenantKirchhoff::from_young_poisson(5e4, 0.3);
        let c = Constraints::free(mesh.n_vertices());
        let sys = System::new(&mesh, &mat, Loads::default(), &c, vec![], None);
        let mut x: Vec<Vec3> = mesh.positions().as_slice().to_vec();
        let all: Vec<usize> = (0..x.len()).collect();
        let r = sys.relax(&mut x, 1.0, &all, 5, 1e-9);
        assert_eq!(r.sweeps, 1);
        let moved = x.iter().zip(mesh.positions().iter()).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
        assert!(moved < 1e-12, "{moved}");
    }
}
