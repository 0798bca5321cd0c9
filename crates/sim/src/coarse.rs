//! Coarse start: the equilibrium of a simplified mold as the starting point of the fine solve.
//!
//! Newton's iterations on a large mesh go mostly to carrying the mold from the stress-free
//! target to its tensioned shape (the sag, the bulging walls, the wrinkled bridges over concave
//! regions), and their count grows with the resolution (kitten under the default scenario,
//! simplified to 6.6k faces: 41 iterations, to 27k: 58, the full 106k: 106, before the
//! relaxed line search). Solved first on a copy with a quarter of the faces and carried over,
//! that motion is done before the fine solve starts, which then settles the fine-scale detail.
//! The copy's own solve starts the same way from a copy of it with a quarter of its faces, as
//! long as that keeps [`CASCADE_MIN_FACES`] (a cascade: kitten 106k → 26.5k → 6.6k faces).
//! Measured with the relaxed line search on kitten and bunny_hr (60k faces) at heights 0.4,
//! 0.5, 0.7 m and lying along +y and −x (ten solves): 112.5 s in all with one level at 1/8,
//! 96.7 s with one level at 1/4, 91.7 s with the cascade; bunny_hr lying along +y, the
//! hardest, 189 → 84 fine iterations (84–150 in later builds, whose rounding differs: the
//! count is that sensitive).
//!
//! The coarse mesh keeps every boundary vertex of the fine one and every constrained vertex
//! but those of a clamp's interior (fully fixed among fully fixed: they hold nothing its
//! frontier does not), locked in the simplification, so its clamps hold the same lines;
//! loads and supports are the same objects (the contact barrier is the fine mesh's). A fine
//! vertex kept by the simplification starts where the coarse solve put it (which respects its
//! constraints); every other one, free, is displaced like the closest point of the coarse
//! target surface among the faces that face its way (barycentric interpolation of the coarse
//! displacements; the facing filter keeps a vertex on one side of a thin ear or tail from
//! taking the displacement of the other side). The fine
//! equilibrium is solved to the full tolerance from there, so the start changes where Newton
//! begins, not the convergence criterion. Where the energy has several minima (contact,
//! wrinkling) the two starts could end in different ones; on the meshes measured they reached
//! the same equilibrium (kitten: displacements equal to 1e-11). Anything that fails along the
//! way (simplification, a topology change, coarse convergence) only means the fine solve starts
//! from the target, as without a coarse start.

use crate::constraints::Constraints;
use crate::loads::{Barrier, Plane};
use crate::material::Material;
use crate::newton::{NewtonOptions, Termination, solve};
use crate::system::{Loads, System};
use clothcast_mesh::simplify::{ClosestPoint, simplify};
use clothcast_mesh::{Mesh, Vec3, VertexId};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// When and how coarse the coarse start is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CoarseOptions {
    /// Meshes with fewer faces are solved from the target directly. 20k: filled to 0.05–0.45 m
    /// of 0.5 m, spot and camelhead (23k faces) took 538 → 481 s and 198 → 97 s from the
    /// coarse start (2026-12-08), filled to the top about as fast; below 10k faces (torus,
    /// bunny, fertility) it did not pay; between 12k and 25k faces (six meshes simplified from
    /// spot, kitten and bunny_hr) it was 7% slower than the target on the partial fills (639
    /// against 598 s over 18, the 25k ones 339 against 287 s) and gained filled to the top at
    /// 25k. The figures are in docs/SIMULATION_LOG.md (thirty-sixth and thirty-seventh
    /// sessions).
    pub min_faces: usize,
    /// The simplified mesh has this many times fewer faces (at least 2); so has each further
    /// level of the cascade.
    pub ratio: usize,
}

impl Default for CoarseOptions {
    fn default() -> Self {
        Self { min_faces: 20_000, ratio: 4 }
    }
}

/// Coarse meshes below this many faces are not worth a solve (a ratio too large for the mesh).
pub const COARSE_MIN_FACES: usize = 500;

/// Coarse meshes with fewer free (unconstrained) vertices are not worth a solve.
pub const COARSE_MIN_FREE_VERTICES: usize = 100;

/// A coarse level gets a coarse start of its own (a cascade) when the next level down would
/// still have this many faces (kitten: 106k → 26.5k → 6.6k faces).
pub const CASCADE_MIN_FACES: usize = 2000;

/// Face counts tried for a simplification (the target, then 1.25 and 1.5 times it) before the
/// coarse start is given up.
pub const SIMPLIFY_TRIES: usize = 3;

/// Newton iterations a coarse level may take (fewer if the whole solve is allowed fewer; also
/// when it starts the first of a stiff mold's stages, which itself gets at most
/// [`crate::newton::START_MAX_ITERATIONS`]): it is
/// only a start, but on a mold filled well below its top a level that has not converged is
/// thrown away, and the fine solve then starts from the target. Measured on 2026-12-07, kitten
/// at 0.5 m filled to 0.1 m (8000 allowed): with 200 (`NewtonOptions::for_start`, until then)
/// both levels stopped unconverged and the fine solve took 5678 iterations, 1736 s; with up
/// to 1000 the 6.6k-face level converged in 525 (5 s), the 26.6k-face one in 535 (22 s in
/// all), and the fine solve in 3514, 1032 s in all (its equilibrium 3·10⁻⁴ J lower, of 38.18 J, the
/// largest displacement and liquid volume equal to 4 digits). Levels that converge within 200,
/// as on the full fills (kitten's 27 and 29), are unchanged; one that never converges costs
/// up to this many of its cheaper iterations (kitten's levels take about a quarter and a
/// twentieth of a fine iteration's time).
pub const COARSE_MAX_ITERATIONS: usize = 1000;

/// Same components, Euler characteristic and boundary loops.
fn same_topology(m: &Mesh, c: &Mesh) -> bool {
    (c.n_components(), c.euler_characteristic(), c.boundary_loops().len())
        == (m.n_components(), m.euler_characteristic(), m.boundary_loops().len())
}

/// The coarse solve needs no more accuracy than this relative residual: the fine solve starts
/// from it and converges to its own tolerance.
pub const COARSE_TOLERANCE: f64 = 1e-6;

/// What the coarse start did (the `simulation.coarse_start` section of summary.json).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct CoarseStats {
    /// Faces of the simplified mesh (0 if the simplification failed).
    pub faces: usize,
    /// Its vertices.
    pub vertices: usize,
    /// Its vertices without constraints (the clamps' interiors are simplified, their
    /// frontiers kept).
    pub free_vertices: usize,
    /// Newton iterations of the coarse solve.
    pub newton_iterations: usize,
    /// Whether the coarse solve converged.
    pub converged: bool,
    /// Newton steps of the coarse solve taken with slack walls ([`crate::walls`]); the
    /// levels are solved without them, so 0 (reported so that a test can see it).
    pub wall_steps: usize,
    /// Whether the fine solve's result is the one that started from the coarse equilibrium
    /// (false: it was not usable, or the fine solve from it failed and was redone from the
    /// target; `note` says which). In a nested level (`coarser`): whether the solve of the
    /// level above it started from it and converged.
    pub used: bool,
    /// Why the coarse start was not used, if it was not; or, when it was, why the fine solve
    /// from it stopped unconverged (at its limit, none left: kept).
    pub note: Option<String>,
    /// Seconds: simplification (every try), the coarser levels, the coarse solve and the
    /// transfer to the finer mesh.
    pub seconds: f64,
    /// Fine vertices moved back in front of a support (to a fifth of their starting distance)
    /// after the transfer.
    pub support_adjusted_vertices: usize,
    /// Newton iterations of a fine solve from the coarse start that failed and was redone
    /// from the target (0 otherwise; they count against `max_iterations`).
    pub fine_iterations_discarded: usize,
    /// Its seconds.
    pub fine_seconds_discarded: f64,
    /// The coarse start of this coarse level (the next level of the cascade), if it was
    /// tried; `used` says whether the coarse solve started from it.
    pub coarser: Option<Box<CoarseStats>>,
}

impl CoarseStats {
    /// The levels of the cascade, finest first.
    pub fn levels(&self) -> impl Iterator<Item = &CoarseStats> {
        std::iter::successors(Some(self), |s| s.coarser.as_deref())
    }
}

/// The fine problem a coarse start is made for.
#[derive(Clone, Copy)]
pub(crate) struct Problem<'a> {
    pub mesh: &'a Mesh,
    pub material: &'a dyn Material,
    pub loads: &'a Loads,
    pub constraints: &'a Constraints,
    pub supports: &'a [Plane],
    /// The fine solve's start: the target, lifted clear of the supports.
    pub start: &'a [Vec3],
    /// The fine mesh's contact barrier, which every level keeps: each coarse mold then rests
    /// at the fine one's contact distance, which its start inherits (sized for the coarse mesh,
    /// the barrier's wider zone left the bag on a floor of the tests 48 fine iterations from
    /// the start, against 14).
    pub barrier: Option<Barrier>,
    pub opts: &'a NewtonOptions,
}

/// The starting positions for the problem's mesh from the equilibrium of a simplified copy of
/// it with `ratio` times fewer faces, or why there are none (the statistics say how far it
/// got). The copy's own solve starts from a coarser copy again while that would keep at
/// least [`CASCADE_MIN_FACES`] faces.
pub(crate) fn coarse_start(pb: &Problem<'_>, ratio: usize) -> (Option<Vec<Vec3>>, CoarseStats) {
    let t0 = Instant::now();
    let mut stats = CoarseStats::default();
    let x = transfer(pb, ratio, &mut stats);
    if let Err(why) = &x {
        stats.note = Some(why.clone());
    }
    stats.seconds = t0.elapsed().as_secs_f64();
    (x.ok(), stats)
}

/// The body of [`coarse_start`]: the positions, or why there are none.
fn transfer(pb: &Problem<'_>, ratio: usize, stats: &mut CoarseStats) -> Result<Vec<Vec3>, String> {
    let Problem { mesh, material, loads, constraints, supports, start, barrier, opts } = *pb;
    let target_faces = mesh.n_faces() / ratio.max(2);
    if target_faces < COARSE_MIN_FACES {
        return Err(format!("a coarse mesh of {target_faces} faces is too small (at least {COARSE_MIN_FACES})"));
    }
    let clock = Instant::now();
    // Locked in the simplification: every partially constrained vertex, and every fully fixed
    // one next to a vertex that is not (the clamp's frontier). Fully fixed vertices among
    // fully fixed ones may be simplified away: they hold nothing the frontier does not, and a
    // wide clamped band kept whole would leave little of the face budget to the free part
    // (bunny_hr at 0.5 m: 2.5k clamped vertices; its second level kept 10 free vertices).
    let fixed = |v: VertexId| constraints.n_fixed(v) == 3;
    let locked: Vec<bool> = mesh
        .vertices()
        .map(|v| match constraints.n_fixed(v) {
            0 => false,
            3 => mesh.vertex_neighbors(v).into_iter().any(|w| !fixed(w)),
            _ => true,
        })
        .collect();
    // The simplifier may return an invalid mesh (a non-manifold edge) or change the topology
    // at one face count and not at another: the target is tried, then 1.25 and 1.5 times it
    // (while that stays under half the faces).
    let mut tries = Vec::new();
    let mut coarse = None;
    for k in 0..SIMPLIFY_TRIES {
        let target = target_faces * (4 + k) / 4;
        if k > 0 && 2 * target > mesh.n_faces() {
            break;
        }
        match simplify(mesh, target, &locked) {
            Err(e) => tries.push(format!("simplification to {target} faces failed: {e}")),
            Ok(c) if 2 * c.mesh.n_faces() > mesh.n_faces() => {
                stats.faces = c.mesh.n_faces();
                return Err(format!("the simplified mesh keeps {} of {} faces", c.mesh.n_faces(), mesh.n_faces()));
            }
            Ok(c) if !same_topology(mesh, &c.mesh) => {
                tries.push(format!("the simplification to {target} faces changed the topology"))
            }
            Ok(c) => {
                coarse = Some(c);
                break;
            }
        }
    }
    let Some(coarse) = coarse else { return Err(tries.join("; ")) };
    tracing::debug!(
        seconds = clock.elapsed().as_secs_f64(),
        faces = coarse.mesh.n_faces(),
        tries = tries.len() + 1,
        "coarse mesh"
    );
    stats.faces = coarse.mesh.n_faces();
    stats.vertices = coarse.mesh.n_vertices();
    // A level with next to nothing free is not worth a solve.
    let free = coarse.parent.iter().filter(|&&p| constraints.n_fixed(p) == 0).count();
    stats.free_vertices = free;
    if free < COARSE_MIN_FREE_VERTICES {
        return Err(format!(
            "the simplified mesh keeps only {free} free vertices (at least {COARSE_MIN_FREE_VERTICES})"
        ));
    }
    let cons = constraints.restrict(&coarse.parent);
    let coarse_start_x: Vec<Vec3> = coarse.parent.iter().map(|p| start[p.idx()]).collect();
    let mut sys = System::new(&coarse.mesh, material, loads.clone(), &cons, supports.to_vec(), barrier);
    // Without slack walls (crate::walls): with walls on its levels, bunny_hr filled to 0.1 m of
    // 0.5 m took 429 and 890 iterations there (542 and 906 without), but 6356 on the fine mesh
    // against 5548 (2026-12-07, thirty-first session).
    let opts = NewtonOptions {
        tolerance: opts.tolerance.max(COARSE_TOLERANCE),
        slack_walls: false,
        ..opts.at_most(COARSE_MAX_ITERATIONS)
    };
    // The next level of the cascade, if it is still large enough; if it gives no start, or the
    // solve from its start fails, this level is solved from its own start (its target, lifted
    // clear of the supports as the fine one's).
    let mut res = None;
    if coarse.mesh.n_faces() / ratio.max(2) >= CASCADE_MIN_FACES {
        let pb = Problem { mesh: &coarse.mesh, constraints: &cons, start: &coarse_start_x, opts: &opts, ..*pb };
        let (x, mut st) = coarse_start(&pb, ratio);
        if let Some(x) = x {
            match solve(&mut sys, x, &opts, &mut |_| {}) {
                Ok(r) if r.termination == Termination::Converged => {
                    st.used = true;
                    res = Some(r);
                }
                Ok(r) => {
                    st.note = Some(format!("the solve from it failed ({:?}); solved from the target", r.termination))
                }
                Err(e) => st.note = Some(format!("the solve from it failed ({e}); solved from the target")),
            }
        }
        tracing::debug!(faces = st.faces, iterations = st.newton_iterations, used = st.used, "coarser level");
        stats.coarser = Some(Box::new(st));
    }
    let res = match res {
        Some(r) => r,
        None => solve(&mut sys, coarse_start_x.clone(), &opts, &mut |_| {})
            .map_err(|e| format!("coarse solve failed: {e}"))?,
    };
    stats.newton_iterations = res.stats.iterations;
    stats.wall_steps = res.stats.wall_steps;
    stats.converged = res.termination == Termination::Converged;
    if !stats.converged {
        return Err(format!("the coarse solve did not converge ({:?})", res.termination));
    }
    tracing::debug!(seconds = clock.elapsed().as_secs_f64(), iterations = res.stats.iterations, "coarse solve");
    let disp: Vec<Vec3> = res.positions.iter().zip(coarse_start_x.iter()).map(|(x, p)| x - p).collect();
    let closest = ClosestPoint::new(&coarse.mesh);
    let normals = mesh.vertex_normals();
    // Kept vertices (every partially constrained one among them) start where the coarse
    // solve put them; fully fixed ones that were simplified away, where they are held.
    let mut kept = vec![u32::MAX; mesh.n_vertices()];
    for (i, p) in coarse.parent.iter().enumerate() {
        kept[p.idx()] = i as u32;
    }
    let mut x: Vec<Vec3> = start
        .par_iter()
        .enumerate()
        .map(|(v, p)| {
            if kept[v] != u32::MAX {
                return res.positions[kept[v] as usize];
            }
            match constraints.n_fixed(VertexId(v as u32)) {
                0 => {}
                3 => return *p,
                _ => debug_assert!(false, "partially constrained vertices are locked, hence kept"),
            }
            let q = closest.query_facing(p, &normals[VertexId(v as u32)]);
            let c = coarse.mesh.face_vertices(q.face);
            p + disp[c[0].idx()] * q.weights[0] + disp[c[1].idx()] * q.weights[1] + disp[c[2].idx()] * q.weights[2]
        })
        .collect();
    tracing::debug!(seconds = clock.elapsed().as_secs_f64(), "coarse start transferred");
    // Keep every vertex at least a fifth of its starting distance in front of each support (the
    // contact barrier is infinite behind it): an interpolated vertex may land behind a support
    // the coarse surface rested on. Each such vertex is moved back along the support's normal.
    for pl in supports {
        for (v, (p, q)) in start.iter().zip(x.iter_mut()).enumerate() {
            let (d0, d1) = (pl.distance(p), pl.distance(q));
            if d1 < 0.2 * d0 && constraints.n_fixed(VertexId(v as u32)) == 0 {
                *q += pl.normal * (0.2 * d0 - d1);
                stats.support_adjusted_vertices += 1;
            }
        }
    }
    Ok(x)
}
