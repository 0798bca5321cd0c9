//! Untangling the flipped triangles of a flattening with as little change as possible.
//!
//! BFF is linear, and around needle triangles of the input its map can flip a few of them: a
//! sliver's height is below the map's discretization error. The former fix (still the last
//! resort, [`untangle_tutte`]) moved the flipped triangles' vertices and rings around them to
//! their neighbours' mean, which unflips but shears the whole neighbourhood: on camelhead at
//! 1 m, 6 flipped slivers cost a piece of 1101 faces its conformality (area-weighted mean
//! quasi-conformal ratio 1.03 → 1.57, 92 vertices moved).
//!
//! [`untangle`] instead minimises, over the flipped triangles' vertices and a ring around them
//! (the rest held), the foldover-free conformal energy of Garanzha et al. 2021 ("Foldover-free
//! maps in 50 lines of code"):
//!
//! `E = Σ_f A_f |J_f|² / χ(det J_f, ε)`,  `χ(D, ε) = (D + √(ε² + D²)) / 2`,
//!
//! J_f the map of face f from its own 3D shape (area A_f) to the plane. For ε > 0 the energy is
//! finite and smooth also for flipped faces, and its minimisation pushes every determinant up;
//! ε is lowered until nothing in the region is flipped. |J|²/det J is twice the MIPS energy,
//! scale invariant, so the BFF map's conformal scale around the region is kept and every
//! triangle tends to the shape of its 3D triangle (a sliver to a similar sliver). The
//! minimisation is nonlinear Gauss–Seidel: a damped 2×2 Newton step per vertex with an
//! analytic gradient and Hessian (det J is linear in one vertex's position), the energy never
//! rising. Five regions are tried (rings 1, 2, 3 around, then 2 and 4 with the
//! piece's boundary vertices); of those that leave nothing flipped, scored by the mean
//! quasi-conformal ratio over all five regions' faces, the smallest within 0.02 of the best is
//! taken (a region held by a fixed boundary can unfold around a thrown boundary vertex only by
//! following it); if none unfolds, the Tutte step.
//!
//! Written here: the regions are a few dozen vertices, and no crate minimises this energy.

use clothcast_mesh::{FaceId, Mesh, Vec2, VertexData, VertexId};
use std::collections::BTreeSet;

/// The tries: rings grown around the flipped triangles' vertices, and whether the piece's
/// boundary vertices may move.
const TRIES: [(usize, bool); 5] = [(1, false), (2, false), (3, false), (2, true), (4, true)];
/// Rounds of lowering ε per try, Gauss–Seidel sweeps per round.
const ROUNDS: usize = 16;
const SWEEPS: usize = 8;
/// How much worse (in area-weighted mean quasi-conformal ratio) a smaller region's result may
/// score than the best try's and still be taken.
const SCORE_SLACK: f64 = 0.02;
/// Sweeps once the region is unfolded.
const POLISH_SWEEPS: usize = 24;

/// Each face's map from its 3D shape: J = Σ_k u_k g_kᵀ over its corners k (u_k the 2D
/// positions); the rest area weighs it. Faces without a 3D area have no map and weight 0.
struct FaceMaps {
    g: Vec<[Vec2; 3]>,
    area: Vec<f64>,
}

impl FaceMaps {
    fn new(mesh: &Mesh) -> Self {
        let mut g = Vec::with_capacity(mesh.n_faces());
        let mut area = Vec::with_capacity(mesh.n_faces());
        for f in mesh.face_ids() {
            let p = mesh.face_positions(f);
            let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
            let l1 = e1.norm();
            let a2 = e1.cross(&e2).norm();
            let (c, h) = (e1.dot(&e2) / l1, a2 / l1);
            // The 3D triangle in its own frame: Dm = [[l1, c], [0, h]]; its inverse's rows r0, r1.
            let r0 = Vec2::new(1.0 / l1, -c / (l1 * h));
            let r1 = Vec2::new(0.0, 1.0 / h);
            if a2 > 0.0 && r0.iter().chain(r1.iter()).all(|x| x.is_finite()) {
                g.push([-(r0 + r1), r0, r1]);
                area.push(0.5 * a2);
            } else {
                g.push([Vec2::zeros(); 3]);
                area.push(0.0);
            }
        }
        FaceMaps { g, area }
    }

    /// J of face f as [[j00, j01], [j10, j11]] (column j = ∂/∂ rest axis j).
    fn jacobian(&self, mesh: &Mesh, uv: &VertexData<Vec2>, f: FaceId) -> [[f64; 2]; 2] {
        let mut j = [[0.0; 2]; 2];
        for (k, v) in mesh.face_vertices(f).into_iter().enumerate() {
            let (u, g) = (uv[v], self.g[f.idx()][k]);
            for (r, ur) in [u.x, u.y].into_iter().enumerate() {
                j[r][0] += ur * g.x;
                j[r][1] += ur * g.y;
            }
        }
        j
    }
}

fn det(j: &[[f64; 2]; 2]) -> f64 {
    j[0][0] * j[1][1] - j[0][1] * j[1][0]
}

/// One vertex's energy over its faces, with gradient and Hessian in its position when asked.
fn vertex_energy(
    mesh: &Mesh,
    maps: &FaceMaps,
    uv: &VertexData<Vec2>,
    faces: &[(FaceId, usize)],
    eps: f64,
    derivatives: bool,
) -> (f64, Vec2, [[f64; 2]; 2]) {
    let (mut e, mut grad, mut hess) = (0.0, Vec2::zeros(), [[0.0; 2]; 2]);
    for &(f, k) in faces {
        let a = maps.area[f.idx()];
        if a == 0.0 {
            continue;
        }
        let j = maps.jacobian(mesh, uv, f);
        let t = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
        let d = det(&j);
        let root = (eps * eps + d * d).sqrt();
        let x = 0.5 * (d + root);
        e += a * t / x;
        if !derivatives {
            continue;
        }
        let g = maps.g[f.idx()][k];
        // J = C + u gᵀ: ∂t/∂u = 2 J g, ∂²t/∂u² = 2|g|² I; det J is linear in u with
        // ∂D/∂u = cof(J) g (cof = ∂ det/∂J).
        let jg = Vec2::new(j[0][0] * g.x + j[0][1] * g.y, j[1][0] * g.x + j[1][1] * g.y);
        let dt = 2.0 * jg;
        let dd = Vec2::new(j[1][1] * g.x - j[1][0] * g.y, -j[0][1] * g.x + j[0][0] * g.y);
        let x1 = 0.5 * (1.0 + d / root);
        let x2 = 0.5 * eps * eps / root.powi(3);
        // f = t/χ: ∇f = ∇t/χ − t χ′ ∇D/χ²;
        // ∇²f = ∇²t/χ − χ′(∇t ∇Dᵀ + ∇D ∇tᵀ)/χ² + t(2χ′²/χ³ − χ″/χ²) ∇D ∇Dᵀ.
        grad += a * (dt / x - t * x1 / (x * x) * dd);
        let s = t * (2.0 * x1 * x1 / x.powi(3) - x2 / (x * x));
        let (dtv, ddv) = ([dt.x, dt.y], [dd.x, dd.y]);
        for r in 0..2 {
            for c in 0..2 {
                let id = if r == c { 2.0 * g.norm_squared() / x } else { 0.0 };
                hess[r][c] += a * (id - x1 * (dtv[r] * ddv[c] + ddv[r] * dtv[c]) / (x * x) + s * ddv[r] * ddv[c]);
            }
        }
    }
    (e, grad, hess)
}

/// One damped Newton step on vertex v's position, kept only if its energy falls.
fn relax_vertex(
    mesh: &Mesh,
    maps: &FaceMaps,
    uv: &mut VertexData<Vec2>,
    v: VertexId,
    faces: &[(FaceId, usize)],
    eps: f64,
) {
    let (e0, g, h) = vertex_energy(mesh, maps, uv, faces, eps, true);
    if !(e0.is_finite() && g.norm() > 0.0) {
        return;
    }
    // The Hessian made positive definite: shifted past its smallest eigenvalue.
    let (tr, dt) = (h[0][0] + h[1][1], h[0][0] * h[1][1] - h[0][1] * h[1][0]);
    let disc = (0.25 * tr * tr - dt).max(0.0).sqrt();
    let lmin = 0.5 * tr - disc;
    let lmax = 0.5 * tr + disc;
    let shift = if lmin > 1e-9 * lmax.abs() { 0.0 } else { 1e-6 * lmax.abs().max(1e-300) - lmin };
    let (a, b, c) = (h[0][0] + shift, h[0][1], h[1][1] + shift);
    let m = a * c - b * b;
    let mut step = if m > 0.0 && m.is_finite() {
        -Vec2::new((c * g.x - b * g.y) / m, (a * g.y - b * g.x) / m)
    } else {
        -g / g.norm() * 1e-3
    };
    let start = uv[v];
    for _ in 0..30 {
        uv[v] = start + step;
        let (e1, _, _) = vertex_energy(mesh, maps, uv, faces, eps, false);
        if e1 < e0 {
            return;
        }
        step *= 0.5;
    }
    uv[v] = start;
}

/// The flipped faces (non-positive signed area in `uv`).
fn flipped_faces(mesh: &Mesh, uv: &VertexData<Vec2>) -> Vec<FaceId> {
    mesh.face_ids()
        .filter(|&f| {
            let [a, b, c] = mesh.face_vertices(f).map(|v| uv[v]);
            !((b - a).perp(&(c - a)) > 0.0)
        })
        .collect()
}

/// Unflip every flipped triangle of `uv` (a layout of `mesh`) with as little change as
/// possible (see the module's text); falls back to [`untangle_tutte`]. Returns the number of
/// vertices moved.
pub(crate) fn untangle(mesh: &Mesh, uv: &mut VertexData<Vec2>) -> usize {
    let bad = flipped_faces(mesh, uv);
    if bad.is_empty() {
        return 0;
    }
    let maps = FaceMaps::new(mesh);
    let original = uv.clone();
    let seeds: BTreeSet<VertexId> = bad.iter().flat_map(|&f| mesh.face_vertices(f)).collect();
    let regions: Vec<BTreeSet<VertexId>> = TRIES
        .iter()
        .map(|&(rings, with_boundary)| {
            let mut region = seeds.clone();
            for _ in 0..rings {
                let grown: Vec<VertexId> = region.iter().flat_map(|&v| mesh.vertex_neighbors(v)).collect();
                region.extend(grown);
            }
            region.retain(|&v| with_boundary || !mesh.is_boundary_vertex(v));
            region
        })
        .collect();
    // Every try that unfolds the layout is scored on the same faces (those of all the
    // regions): a region held by a fixed boundary can unfold only by following a thrown
    // boundary vertex, at a cost in shape that a larger region avoids.
    let scored: BTreeSet<FaceId> = regions.iter().flatten().flat_map(|&v| mesh.vertex_faces(v)).collect();
    let score = |uv: &VertexData<Vec2>| -> f64 {
        let (mut sum, mut area) = (0.0, 0.0);
        for &f in &scored {
            let a = maps.area[f.idx()];
            sum += a * quasi_conformal(&maps.jacobian(mesh, uv, f));
            area += a;
        }
        if area > 0.0 { sum / area } else { 0.0 }
    };
    let candidates: Vec<(f64, VertexData<Vec2>)> = regions
        .iter()
        .filter(|r| !r.is_empty())
        .filter_map(|region| {
            let mut candidate = original.clone();
            unfold(mesh, &maps, &mut candidate, region);
            flipped_faces(mesh, &candidate).is_empty().then(|| (score(&candidate), candidate))
        })
        .collect();
    // The smallest region within SCORE_SLACK of the best score: a larger region always
    // settles a little better, but moves more of BFF's map.
    let best = candidates.iter().map(|(s, _)| *s).fold(f64::INFINITY, f64::min);
    eprintln!(
        "DBG untangle n={} flipped={} regions={:?} scores={:?} orig={}",
        mesh.n_faces(),
        bad.len(),
        regions.iter().map(|r| r.len()).collect::<Vec<_>>(),
        candidates.iter().map(|c| c.0).collect::<Vec<_>>(),
        score(&original)
    );
    match candidates.into_iter().find(|(s, _)| *s <= best + SCORE_SLACK) {
        Some((_, found)) => {
            *uv = found;
            mesh.vertices().filter(|&v| uv[v] != original[v]).count()
        }
        None => untangle_tutte(mesh, uv),
    }
}

/// The ratio of J's singular values (infinite for a flipped or collapsed J).
fn quasi_conformal(j: &[[f64; 2]; 2]) -> f64 {
    let t = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
    let d = det(j);
    if !(d > 0.0) {
        return f64::INFINITY;
    }
    // s1² + s2² = t, s1 s2 = d: s1/s2 = (t + √(t² − 4d²)) / (2d).
    (t + (t * t - 4.0 * d * d).max(0.0).sqrt()) / (2.0 * d)
}

/// Minimise the region's foldover-free energy, ε lowered until the region's faces are unfolded,
/// then a few sweeps near the plain MIPS energy.
fn unfold(mesh: &Mesh, maps: &FaceMaps, uv: &mut VertexData<Vec2>, region: &BTreeSet<VertexId>) {
    // Each region vertex's faces, with its corner in each.
    let corners: Vec<(VertexId, Vec<(FaceId, usize)>)> = region
        .iter()
        .map(|&v| {
            let fs = mesh
                .vertex_faces(v)
                .map(|f| (f, mesh.face_vertices(f).iter().position(|&w| w == v).unwrap_or(0)))
                .collect();
            (v, fs)
        })
        .collect();
    let faces: BTreeSet<FaceId> = corners.iter().flat_map(|(_, fs)| fs.iter().map(|&(f, _)| f)).collect();
    let dets = |uv: &VertexData<Vec2>| -> Vec<f64> {
        faces.iter().filter(|f| maps.area[f.idx()] > 0.0).map(|&f| det(&maps.jacobian(mesh, uv, f))).collect()
    };
    let sweep = |uv: &mut VertexData<Vec2>, eps: f64| {
        for (v, fs) in &corners {
            relax_vertex(mesh, maps, uv, *v, fs, eps);
        }
    };
    let mut abs: Vec<f64> = dets(uv).iter().map(|d| d.abs()).collect();
    abs.sort_by(f64::total_cmp);
    let median = abs.get(abs.len() / 2).copied().unwrap_or(1.0).max(1e-12);
    let mut eps = median;
    for _ in 0..ROUNDS {
        for _ in 0..SWEEPS {
            sweep(uv, eps);
        }
        if dets(uv).iter().all(|&d| d > 0.0) {
            // Unfolded: more sweeps with a small ε (the energy then nearly the plain MIPS
            // energy, its barrier keeping every triangle unflipped) let the region settle
            // into the shapes of its 3D triangles.
            for _ in 0..POLISH_SWEEPS {
                sweep(uv, eps.min(1e-3 * median));
            }
            return;
        }
        eps *= 0.25;
    }
}

/// Untangle flipped triangles of a flattening by local Tutte relaxation: the interior vertices of
/// flipped faces (then their 1-ring, 2-ring, …) move to the mean of their neighbours, a few
/// sweeps per round; boundary vertices join only when interior moves are not enough. Returns the
/// number of vertices moved.
pub(crate) fn untangle_tutte(mesh: &Mesh, uv: &mut VertexData<Vec2>) -> usize {
    let neighbours: Vec<Vec<VertexId>> = mesh.vertices().map(|v| mesh.vertex_neighbors(v)).collect();
    let mut moved = BTreeSet::new();
    for round in 0..12 {
        let bad = flipped_faces(mesh, uv);
        if bad.is_empty() {
            break;
        }
        let with_boundary = round >= 6;
        // The vertices of flipped faces grown by a few rings.
        let mut set: BTreeSet<VertexId> = bad.iter().flat_map(|&f| mesh.face_vertices(f)).collect();
        for _ in 0..(round % 6) / 2 + 1 {
            let grown: Vec<VertexId> = set.iter().flat_map(|&v| neighbours[v.idx()].iter().copied()).collect();
            set.extend(grown);
        }
        set.retain(|&v| with_boundary || !mesh.is_boundary_vertex(v));
        for _ in 0..20 {
            for &v in &set {
                let ns = &neighbours[v.idx()];
                if ns.is_empty() {
                    continue;
                }
                let mean = ns.iter().fold(Vec2::zeros(), |acc, &w| acc + uv[w]) / ns.len() as f64;
                // Boundary vertices go only half way, to stay near their boundary.
                uv[v] = if mesh.is_boundary_vertex(v) { 0.5 * (uv[v] + mean) } else { mean };
                moved.insert(v);
            }
        }
    }
    moved.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bff::distortion;
    use clothcast_mesh::{Vec3, shapes};

    /// A grid laid out by the conformal map w = (z + 1)² (its scale varies fourfold over the
    /// piece), with one vertex thrown across its neighbours.
    fn tangled(thrown: VertexId, by: Vec2) -> (Mesh, VertexData<Vec2>, VertexData<Vec2>) {
        // A grid with its interior vertices moved by up to a third of the spacing, so that its
        // triangles are irregular (where the Tutte step's uniform weights are not conformal).
        let mut m = shapes::grid(10, 8, 1.0, 0.8);
        let mut p = m.positions().clone();
        for v in m.vertices().filter(|&v| !m.is_boundary_vertex(v)) {
            let k = v.idx() as f64;
            p[v] += Vec3::new(0.033 * (k * 1.7).sin(), 0.033 * (k * 2.3).cos(), 0.0);
        }
        m.set_positions(p);
        let exact: VertexData<Vec2> = VertexData::from_vec(
            m.vertices()
                .map(|v| {
                    let p = m.position(v);
                    let (x, y) = (p.x + 1.0, p.y);
                    Vec2::new(x * x - y * y, 2.0 * x * y)
                })
                .collect(),
        );
        let mut uv = exact.clone();
        uv[thrown] += by;
        assert!(distortion(&m, &uv).flipped_triangles > 0);
        (m, exact, uv)
    }

    /// The flips are undone near where they were, and the conformal map around is kept:
    /// the result is as conformal as the exact map, and better than the Tutte step's.
    #[test]
    fn unflips_locally_and_keeps_the_map_conformal() {
        let thrown = VertexId::new(4 * 11 + 5);
        let (m, exact, tangled) = tangled(thrown, Vec2::new(0.9, -0.6));
        let mut uv = tangled.clone();
        let moved = untangle(&m, &mut uv);
        let s = distortion(&m, &uv);
        let e = distortion(&m, &exact);
        assert_eq!(s.flipped_triangles, 0);
        // Only the thrown vertex's neighbourhood (two rings) moved.
        let mut near: BTreeSet<VertexId> = BTreeSet::from([thrown]);
        for _ in 0..3 {
            let grown: Vec<VertexId> = near.iter().flat_map(|&v| m.vertex_neighbors(v)).collect();
            near.extend(grown);
        }
        assert!(m.vertices().filter(|v| !near.contains(v)).all(|v| uv[v] == tangled[v]));
        assert!(s.qc_max < e.qc_max + 0.02, "qc max {} against the exact map's {}", s.qc_max, e.qc_max);
        assert!((uv[thrown] - exact[thrown]).norm() < 0.02, "{:?} against {:?}", uv[thrown], exact[thrown]);
        let mut tutte = tangled;
        let tutte_moved = untangle_tutte(&m, &mut tutte);
        assert!(moved > 0 && moved <= tutte_moved, "{moved} vertices moved against Tutte's {tutte_moved}");
        let t = distortion(&m, &tutte);
        assert_eq!(t.flipped_triangles, 0);
        assert!(s.qc_mean < t.qc_mean && s.qc_max < t.qc_max, "{s:?} against Tutte's {t:?}");
    }

    /// A thrown boundary vertex is brought back by the tries that move the boundary.
    #[test]
    fn unflips_at_the_boundary() {
        let thrown = VertexId::new(5);
        let (m, _, mut uv) = tangled(thrown, Vec2::new(0.2, 0.9));
        untangle(&m, &mut uv);
        let s = distortion(&m, &uv);
        assert_eq!(s.flipped_triangles, 0);
        assert!(s.qc_max < 2.0, "{s:?}");
    }

    /// Nothing flipped: nothing moves.
    #[test]
    fn leaves_an_untangled_layout_alone() {
        let (m, exact, _) = tangled(VertexId::new(60), Vec2::new(0.9, -0.6));
        let mut uv = exact.clone();
        assert_eq!(untangle(&m, &mut uv), 0);
        assert!(m.vertices().all(|v| uv[v] == exact[v]));
    }
}
