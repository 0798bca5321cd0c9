//! Coarse start: the equilibrium of a simplified mold as the starting point of the fine solve.
//!
//! Newton's iterations on a large mesh go mostly to carrying the mold from the stress-free
//! target to its tensioned shape: the sag, the bulging walls and the wrinkled bridges over
//! concave regions travel a few element sizes per iteration, so their count grows with the
//! resolution (kitten under the default scenario: 41 iterations at 6.6k faces, 58 at 27k, 106
//! at 106k). Solved first on a mesh simplified to a few thousand faces (a fraction of one fine
//! iteration's time) and carried over, that motion is done before the fine solve starts, which
//! then only settles the fine-scale detail (kitten: 106 → about 65 iterations).
//!
//! The coarse mesh keeps every constrained vertex and every boundary vertex of the fine one
//! (locked in the simplification), so its clamps are the same; loads and supports are the
//! same objects. Each free fine vertex starts displaced like the closest point of the coarse
//! target surface (barycentric interpolation of the coarse displacements); constrained ones
//! stay put. The fine equilibrium is solved to the full tolerance from there, so the start
//! changes where Newton begins, not the convergence criterion. Anything that fails along the
//! way (simplification, coarse convergence) only means the fine solve starts from the target,
//! as without a coarse start.

use crate::constraints::Constraints;
use crate::loads::{Barrier, Plane};
use crate::material::Material;
use crate::newton::{NewtonOptions, Termination, solve};
use crate::system::{Loads, System};
use clothcast_mesh::simplify::{ClosestPoint, simplify};
use clothcast_mesh::{Mesh, Vec3};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// When and how coarse the coarse start is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CoarseOptions {
    /// Meshes with fewer faces are solved from the target directly: their solves are short,
    /// and measured with a coarse start they were not reliably shorter (camelhead, 23k faces:
    /// 77 iterations from the target, 85–107 from coarse starts of 1k–5k faces; spot, 23k
    /// faces: 23 against 16–20).
    pub min_faces: usize,
    /// The simplified mesh has this many times fewer faces (at least 2).
    pub ratio: usize,
}

impl Default for CoarseOptions {
    fn default() -> Self {
        Self { min_faces: 50_000, ratio: 8 }
    }
}

/// The coarse solve needs no more accuracy than this relative residual: the fine solve starts
/// from it and converges to its own tolerance.
pub const COARSE_TOLERANCE: f64 = 1e-6;

/// What the coarse start did (the `simulation.coarse_start` section of summary.json).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CoarseStats {
    /// Faces of the simplified mesh (0 if the simplification failed).
    pub faces: usize,
    /// Its vertices.
    pub vertices: usize,
    /// Newton iterations of the coarse solve.
    pub newton_iterations: usize,
    /// Whether the coarse solve converged.
    pub converged: bool,
    /// Whether the fine solve's result is the one that started from the coarse equilibrium
    /// (false: it was not usable, or the fine solve from it failed and was redone from the
    /// target; `note` says which).
    pub used: bool,
    /// Why the coarse start was not used, if it was not.
    pub note: Option<String>,
    /// Seconds: simplification, coarse solve and the transfer to the fine mesh.
    pub seconds: f64,
}

/// The starting positions for `mesh` from the equilibrium of a simplified copy of it with
/// about `target_faces` faces, or why there are none (the statistics say how far it got).
#[allow(clippy::too_many_arguments)]
pub(crate) fn coarse_start(
    mesh: &Mesh,
    material: &dyn Material,
    loads: &Loads,
    constraints: &Constraints,
    supports: &[Plane],
    barrier: Option<Barrier>,
    opts: &NewtonOptions,
    target_faces: usize,
) -> (Option<Vec<Vec3>>, CoarseStats) {
    let t0 = Instant::now();
    let mut stats = CoarseStats {
        faces: 0,
        vertices: 0,
        newton_iterations: 0,
        converged: false,
        used: false,
        note: None,
        seconds: 0.0,
    };
    let x = run(mesh, material, loads, constraints, supports, barrier, opts, target_faces, &mut stats);
    if let Err(why) = &x {
        stats.note = Some(why.clone());
    }
    stats.seconds = t0.elapsed().as_secs_f64();
    (x.ok(), stats)
}

#[allow(clippy::too_many_arguments)]
fn run(
    mesh: &Mesh,
    material: &dyn Material,
    loads: &Loads,
    constraints: &Constraints,
    supports: &[Plane],
    barrier: Option<Barrier>,
    opts: &NewtonOptions,
    target_faces: usize,
    stats: &mut CoarseStats,
) -> Result<Vec<Vec3>, String> {
    let t = Instant::now();
    let locked: Vec<bool> = mesh.vertices().map(|v| constraints.n_fixed(v) > 0).collect();
    let coarse = simplify(mesh, target_faces, &locked).map_err(|e| format!("simplification failed: {e}"))?;
    tracing::debug!(seconds = t.elapsed().as_secs_f64(), faces = coarse.mesh.n_faces(), "coarse mesh");
    stats.faces = coarse.mesh.n_faces();
    stats.vertices = coarse.mesh.n_vertices();
    if 2 * coarse.mesh.n_faces() > mesh.n_faces() {
        return Err(format!("the simplified mesh keeps {} of {} faces", coarse.mesh.n_faces(), mesh.n_faces()));
    }
    let cons = constraints.restrict(&coarse.parent);
    let mut sys = System::new(&coarse.mesh, material, loads.clone(), &cons, supports.to_vec(), barrier);
    let opts = NewtonOptions { tolerance: opts.tolerance.max(COARSE_TOLERANCE), ..opts.clone() };
    let res = solve(&mut sys, coarse.mesh.positions().as_slice().to_vec(), &opts, &mut |_| {})
        .map_err(|e| format!("coarse solve failed: {e}"))?;
    stats.newton_iterations = res.stats.iterations;
    stats.converged = res.termination == Termination::Converged;
    if !stats.converged {
        return Err(format!("the coarse solve did not converge ({:?})", res.termination));
    }
    tracing::debug!(seconds = t.elapsed().as_secs_f64(), iterations = res.stats.iterations, "coarse solve");
    let disp: Vec<Vec3> = res.positions.iter().zip(coarse.mesh.positions().iter()).map(|(x, p)| x - p).collect();
    let closest = ClosestPoint::new(&coarse.mesh);
    let target = mesh.positions().as_slice();
    let mut x: Vec<Vec3> = target
        .par_iter()
        .enumerate()
        .map(|(v, p)| {
            if constraints.n_fixed(clothcast_mesh::VertexId(v as u32)) > 0 {
                return *p;
            }
            let q = closest.query(p);
            let c = coarse.mesh.face_vertices(q.face);
            p + disp[c[0].idx()] * q.weights[0] + disp[c[1].idx()] * q.weights[1] + disp[c[2].idx()] * q.weights[2]
        })
        .collect();
    tracing::debug!(seconds = t.elapsed().as_secs_f64(), "coarse start transferred");
    // Keep every vertex at least a fifth of its starting distance in front of each support
    // (the contact barrier is infinite behind it): shorten the whole displacement if needed.
    let mut t: f64 = 1.0;
    for pl in supports {
        for (p, q) in target.iter().zip(&x) {
            let (d0, d1) = (pl.distance(p), pl.distance(q));
            if d1 < 0.2 * d0 {
                t = t.min(0.8 * d0 / (d0 - d1));
            }
        }
    }
    if t < 1.0 {
        for (q, p) in x.iter_mut().zip(target) {
            *q = p + (*q - p) * t;
        }
    }
    Ok(x)
}
