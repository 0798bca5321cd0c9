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
        // (The energy is the trial points' formula's, to the bit.)
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
        let mesh = clothcast_mesh::shapes::icosphere(4, 0.2);
        let mat = WrinklingStVenantKirchhoff::from_young_poisson(5e4, 0.3);
        let loads = Loads {
            hydrostatic: Some(Hydrostatic { rho_g: 1460.0 * 9.81, up: Vec3::z(), fill_height: 0.2 }),
            head_pressure: 200.0,
            self_weight: Some((2.0, Vec3::z())),
        };
        let mut c = Constraints::free(mesh.n_vertices());
        for v in mesh.vertices() {
            if mesh.position(v).z > 0.18 {
                c.fix_vertex(v);
            }
        }
        // Two vertices that slide: one on a plane, one along a line.
        c.fix_direction(VertexId(SLIDING[0] as u32), Vec3::new(1.0, 0.3, 0.0));
        c.fix_direction(VertexId(SLIDING[1] as u32), Vec3::new(0.0, 1.0, 1.0));
        c.fix_direction(VertexId(SLIDING[1] as u32), Vec3::new(1.0, 0.0, 0.0));
        (mesh, mat, loads, c)
    }

    /// Vertices of the test sphere below its clamped cap, given sliding constraints.
    const SLIDING: [usize; 2] = [40, 41];

    /// Vertices pushed off their places go back towards them, the energy falls, constrained
    /// axes stay put, and the result does not depend on the number of threads.
    #[test]
    fn relaxation_lowers_the_energy_and_is_deterministic() {
        let (mesh, mat, loads, c) = sphere_problem();
        let sys = System::new(&mesh, &mat, loads, &c, vec![], None);
        let target: Vec<Vec3> = mesh.positions().as_slice().to_vec();
        for v in SLIDING {
            assert_eq!(c.n_fixed(VertexId(v as u32)), v - 39, "vertex {v} is below the clamped cap");
        }
        // Every second vertex, pushed off its place (the sliding ones within their free axes):
        // colour classes of well over MIN_PARALLEL vertices, so two threads share them.
        let seeds: Vec<usize> = (0..mesh.n_vertices()).step_by(2).chain(SLIDING).collect();
        let free_part = |v: usize, d: Vec3| {
            let (frame, k) = c.frame(VertexId(v as u32));
            let r = frame.unwrap_or_else(Matrix3::identity);
            (k..3).map(|i| r.column(i) * r.column(i).dot(&d)).sum::<Vec3>()
        };
        let mut x = target.clone();
        for &v in &seeds {
            x[v] += free_part(v, Vec3::new(0.004, -0.003, 0.002) * (1.0 + (v % 3) as f64));
        }
        let before = x.clone();
        let e0 = sys.energy(&x, 1.0);
        let mut colour = vec![u32::MAX; x.len()];
        let free: Vec<usize> = seeds.iter().copied().filter(|&v| c.n_fixed(VertexId(v as u32)) < 3).collect();
        let largest = sys.colour_classes(&free, &mut colour).iter().map(Vec::len).max().unwrap_or(0);
        assert!(largest > 2 * MIN_PARALLEL, "colour classes of at most {largest} vertices run on one thread");
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut y = before.clone();
            let r = pool.install(|| sys.relax(&mut y, 1.0, &seeds, 20, 1e-9));
            (y, r)
        };
        let (x1, r1) = run(1);
        let (x2, r2) = run(2);
        assert_eq!(r1, r2);
        assert!(x1.iter().zip(&x2).all(|(a, b)| a == b), "thread count changed the result");
        let e1 = sys.energy(&x1, 1.0);
        assert!(e1 < e0 - 1.0, "energy {e0} → {e1}");
        assert!(r1.sweeps > 1 && r1.moves > 0);
        // Clamped vertices and vertices outside the set do not move; sliding ones only along
        // their free axes (and they do move).
        for v in 0..x1.len() {
            if c.n_fixed(VertexId(v as u32)) == 3 || !seeds.contains(&v) {
                assert_eq!(x1[v], before[v], "vertex {v} moved");
            }
        }
        for v in SLIDING {
            let d = x1[v] - before[v];
            assert!(d.norm() > 1e-5, "sliding vertex {v} did not move");
            assert!((d - free_part(v, d)).norm() < 1e-12 * d.norm().max(1e-3), "vertex {v} left its free axes");
        }
        // The displaced vertices went most of the way back.
        let off = |y: &[Vec3]| seeds.iter().map(|&v| (y[v] - target[v]).norm()).sum::<f64>();
        assert!(off(&x1) < 0.2 * off(&before), "{} vs {}", off(&x1), off(&before));
    }

    /// A vertex's local energy, gradient and Hessian block (faces, liquid, head pressure,
    /// weight, a support's barrier, seam bars) agree with finite differences, and with the
    /// total energy's change when the vertex alone moves.
    #[test]
    fn vertex_terms_match_finite_differences() {
        use crate::element::Bar;
        use crate::loads::{Barrier, Plane};
        let (mesh, mat, loads, c) = sphere_problem();
        let support = Plane::new(Vec3::new(0.0, 0.0, -0.2035), Vec3::new(0.05, 0.0, 1.0));
        let barrier = Barrier { dhat: 0.01, kappa: 1e4 };
        let mut sys = System::new(&mesh, &mat, loads, &c, vec![support], Some(barrier));
        // A stretched bar on every face's second edge.
        sys.set_bars(
            mesh.face_ids()
                .map(|f| {
                    let p = mesh.face_positions(f);
                    let bar = Bar { stiffness: 2000.0, rest: 0.9 * (p[2] - p[1]).norm(), compression: 0.01 };
                    [Bar::default(), bar, Bar::default()]
                })
                .collect(),
        );
        // A strained state, the lowest vertex within the barrier's reach.
        let x: Vec<Vec3> = mesh.positions().iter().map(|p| Vec3::new(p.x * 1.04, p.y * 0.97, p.z * 1.01)).collect();
        let v = (0..x.len()).min_by(|&a, &b| x[a].z.total_cmp(&x[b].z)).expect("vertices");
        assert!(support.distance(&x[v]) < 0.01, "vertex {v} is within the barrier's reach");
        let s = 0.9;
        let (e, g, h) = sys.vertex_terms(&x, v, &x[v], s, true);
        assert_eq!(e, sys.vertex_terms(&x, v, &x[v], s, false).0, "the same energy to the bit");
        let eps = 1e-6;
        for k in 0..3 {
            let (mut yp, mut ym) = (x[v], x[v]);
            yp[k] += eps;
            ym[k] -= eps;
            let fd =
                (sys.vertex_terms(&x, v, &yp, s, false).0 - sys.vertex_terms(&x, v, &ym, s, false).0) / (2.0 * eps);
            assert!((fd - g[k]).abs() < 1e-5 * (1.0 + g[k].abs()), "g{k}: {fd} vs {}", g[k]);
            let dg = (sys.vertex_terms(&x, v, &yp, s, true).1 - sys.vertex_terms(&x, v, &ym, s, true).1) / (2.0 * eps);
            for i in 0..3 {
                assert!(
                    (dg[i] - h[(i, k)]).abs() < 1e-4 * (1.0 + h[(i, k)].abs()),
                    "h{i}{k}: {} vs {}",
                    dg[i],
                    h[(i, k)]
                );
            }
            // The change of the total energy is the change of the vertex's own.
            let mut xp = x.clone();
            xp[v] = yp;
            let d_total = sys.energy(&xp, s) - sys.energy(&x, s);
            let d_local = sys.vertex_terms(&x, v, &yp, s, false).0 - e;
            assert!((d_total - d_local).abs() < 1e-9 * (1.0 + d_local.abs()), "{d_total} vs {d_local}");
        }
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
