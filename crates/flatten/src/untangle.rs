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
//! ε is lowered until nothing in the region is flipped. |J|²/det J = σ₁/σ₂ + σ₂/σ₁ (the MIPS
//! energy of Hormann & Greiner) is scale invariant, so the BFF map's conformal scale around the region is kept and every
//! triangle tends to the shape of its 3D triangle (a sliver to a similar sliver). The
//! minimisation is nonlinear Gauss–Seidel: a damped 2×2 Newton step per vertex with an
//! analytic gradient and Hessian (det J is linear in one vertex's position), the energy never
//! rising. Five regions are tried: rings 1, 2, 3 around, then 2 and 4 also moving the flipped
//! triangles' own boundary vertices (the energy is scale invariant: a free stretch of outline
//! would drift off its lengths), whose tries count only while every boundary edge keeps its length within 0.5% or
//! ends no further from its 3D length than it was (BFF lays the outline out at the seams' 3D
//! lengths). Of the tries that leave nothing
//! flipped, scored by the area-weighted mean quasi-conformal ratio over all five regions'
//! faces, the first in that order within 0.02 of the best is taken (a region held by a fixed
//! boundary can unfold around a flipped corner at the outline only by following it, at a cost
//! in shape); if none unfolds, or more than a tenth of the piece is flipped, the Tutte step.
//!
//! Written here: the regions are a few dozen vertices, and no crate minimises this energy.

use crate::bff::{rest_frame, singular_values};
use clothcast_mesh::{FaceId, Mesh, Vec2, VertexData, VertexId};
use rayon::prelude::*;
use std::collections::BTreeSet;

/// The tries: rings grown around the flipped triangles' vertices, and whether those of their
/// vertices on the piece's boundary may move.
const TRIES: [(usize, bool); 5] = [(1, false), (2, false), (3, false), (2, true), (4, true)];
/// Rounds of lowering ε per try, Gauss–Seidel sweeps per round.
const ROUNDS: usize = 16;
const SWEEPS: usize = 8;
/// How much worse (in area-weighted mean quasi-conformal ratio) a smaller region's result may
/// score than the best try's and still be taken.
const SCORE_SLACK: f64 = 0.02;
/// How much (relative) a try that moves the outline may change a boundary edge's length, unless
/// the edge ends no further from its 3D length than it was (or than this share of it).
const BOUNDARY_SLACK: f64 = 0.005;
/// Stiffness of the springs on a moving boundary vertex's boundary edges (see [`Star`]).
const SPRING: f64 = 1000.0;
/// The share of a piece's faces flipped above which the local minimisation is not tried: such a
/// map is broken as a whole, not around a few slivers. (A pinched dome's layouts: 2081 calls, of
/// which the 440 with more than 10% flipped all failed every try, 21 of the 55 s spent here;
/// the most flipped that one unfolded had 5.7%.)
const LOCAL_LIMIT: f64 = 0.1;
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
            let (l1, c, h, a2) = rest_frame(&mesh.face_positions(f));
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
        jacobian(&mesh.face_vertices(f), &self.g[f.idx()], uv)
    }
}

/// J = Σ_k u_k g_kᵀ of a face with corners `verts` and gradients `g`.
fn jacobian(verts: &[VertexId; 3], g: &[Vec2; 3], uv: &VertexData<Vec2>) -> [[f64; 2]; 2] {
    let mut j = [[0.0; 2]; 2];
    for (&v, g) in verts.iter().zip(g) {
        let u = uv[v];
        for (r, ur) in [u.x, u.y].into_iter().enumerate() {
            j[r][0] += ur * g.x;
            j[r][1] += ur * g.y;
        }
    }
    j
}

fn det(j: &[[f64; 2]; 2]) -> f64 {
    j[0][0] * j[1][1] - j[0][1] * j[1][0]
}

/// A region vertex: its faces with its corner in each, and, for a vertex on the piece's
/// boundary, a spring on each of its two boundary edges (the other end, the edge's 3D length,
/// the stiffness).
struct Star {
    v: VertexId,
    faces: Vec<StarFace>,
    springs: Vec<(VertexId, f64, f64)>,
}

/// A face of a [`Star`], with what its energy needs copied from the mesh and the [`FaceMaps`]
/// (the energy is evaluated tens of times per vertex and sweep).
struct StarFace {
    f: FaceId,
    /// The star vertex's corner.
    k: usize,
    verts: [VertexId; 3],
    g: [Vec2; 3],
    area: f64,
}

/// The faces around v as a [`Star`] holds them.
fn star_faces(mesh: &Mesh, maps: &FaceMaps, v: VertexId) -> Vec<StarFace> {
    mesh.vertex_faces(v)
        .map(|f| {
            let verts = mesh.face_vertices(f);
            let k = verts.iter().position(|&w| w == v).unwrap_or(0);
            StarFace { f, k, verts, g: maps.g[f.idx()], area: maps.area[f.idx()] }
        })
        .collect()
}

/// One vertex's energy over its faces (and springs), with gradient and Hessian in its position
/// when asked.
fn vertex_energy(uv: &VertexData<Vec2>, star: &Star, eps: f64, derivatives: bool) -> (f64, Vec2, [[f64; 2]; 2]) {
    let (mut e, mut grad, mut hess) = (0.0, Vec2::zeros(), [[0.0; 2]; 2]);
    // Springs k (l − L)²: ∇ = 2k (l − L) n, ∇² = 2k (n nᵀ + max(0, 1 − L/l) (I − n nᵀ)) (the
    // part that is negative under compression left out).
    for &(w, len, k) in &star.springs {
        let d = uv[star.v] - uv[w];
        let l = d.norm();
        e += k * (l - len).powi(2);
        if derivatives && l > 0.0 {
            let n = d / l;
            grad += 2.0 * k * (l - len) * n;
            let tangential = (1.0 - len / l).max(0.0);
            let nv = [n.x, n.y];
            for r in 0..2 {
                for c in 0..2 {
                    let id = if r == c { 1.0 } else { 0.0 };
                    hess[r][c] += 2.0 * k * (nv[r] * nv[c] + tangential * (id - nv[r] * nv[c]));
                }
            }
        }
    }
    for sf in &star.faces {
        let a = sf.area;
        if a == 0.0 {
            continue;
        }
        let j = jacobian(&sf.verts, &sf.g, uv);
        let t = j[0][0].powi(2) + j[0][1].powi(2) + j[1][0].powi(2) + j[1][1].powi(2);
        let d = det(&j);
        let root = (eps * eps + d * d).sqrt();
        // χ = (D + √(ε² + D²))/2, and χ′ = (1 + D/√(ε² + D²))/2, written without the
        // cancellation of D + √(ε² + D²) for D < 0 (which makes χ 0 once ε ≪ |D|).
        let (x, x1) = if d >= 0.0 {
            (0.5 * (d + root), 0.5 * (1.0 + d / root))
        } else {
            let gap = root - d;
            (0.5 * eps * eps / gap, 0.5 * eps * eps / (root * gap))
        };
        e += a * t / x;
        if !derivatives {
            continue;
        }
        let g = sf.g[sf.k];
        // J = C + u gᵀ: ∂t/∂u = 2 J g, ∂²t/∂u² = 2|g|² I; det J is linear in u with
        // ∂D/∂u = cof(J) g (cof = ∂ det/∂J).
        let jg = Vec2::new(j[0][0] * g.x + j[0][1] * g.y, j[1][0] * g.x + j[1][1] * g.y);
        let dt = 2.0 * jg;
        let dd = Vec2::new(j[1][1] * g.x - j[1][0] * g.y, -j[0][1] * g.x + j[0][0] * g.y);
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
fn relax_vertex(uv: &mut VertexData<Vec2>, star: &Star, eps: f64) {
    let v = star.v;
    let (e0, g, h) = vertex_energy(uv, star, eps, true);
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
        // A tenth of the smallest height among the vertex's triangles (1/|g| is the height
        // of the vertex over its opposite edge).
        let reach = star.faces.iter().map(|sf| sf.g[sf.k].norm()).fold(0.0, f64::max);
        -g / g.norm() * (0.1 / reach.max(1e-300))
    };
    let start = uv[v];
    for _ in 0..30 {
        uv[v] = start + step;
        let (e1, _, _) = vertex_energy(uv, star, eps, false);
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
    if bad.len() as f64 > LOCAL_LIMIT * mesh.n_faces() as f64 {
        return untangle_tutte(mesh, uv);
    }
    let maps = FaceMaps::new(mesh);
    let original = uv.clone();
    let seeds: BTreeSet<VertexId> = bad.iter().flat_map(|&f| mesh.face_vertices(f)).collect();
    // The seeds grown by 0, 1, … rings (each grown once, for all the tries).
    let most = TRIES.iter().map(|&(rings, _)| rings).max().unwrap_or(0);
    let mut ringed = vec![seeds.clone()];
    for k in 0..most {
        let mut next = ringed[k].clone();
        grow(mesh, &mut next, 1);
        ringed.push(next);
    }
    let regions: Vec<BTreeSet<VertexId>> = TRIES
        .iter()
        .map(|&(rings, with_boundary)| {
            let mut region = ringed[rings].clone();
            // The boundary vertices that may move are the flipped faces' own: the energy is
            // scale invariant and would let a free stretch of outline drift off its lengths.
            region.retain(|&v| !mesh.is_boundary_vertex(v) || (with_boundary && seeds.contains(&v)));
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
            if a == 0.0 {
                continue; // no 3D shape, no map (and 0 · ∞ would make the score NaN)
            }
            sum += a * quasi_conformal(&maps.jacobian(mesh, uv, f));
            area += a;
        }
        if area > 0.0 { sum / area } else { 0.0 }
    };
    // A try that moves boundary vertices changes the piece's outline, whose edges BFF laid out
    // at their 3D lengths (the seams' two sides must match): admissible only while every
    // boundary edge keeps its length within BOUNDARY_SLACK, or ends no further from its 3D
    // length than it was or than BOUNDARY_SLACK of it.
    let boundary: Vec<(VertexId, VertexId, f64, f64)> = mesh
        .edges()
        .filter(|&e| mesh.is_boundary_edge(e))
        .map(|e| {
            let [a, b] = mesh.edge_vertices(e);
            (a, b, (original[a] - original[b]).norm(), mesh.edge_length(e))
        })
        .collect();
    let outline_kept = |uv: &VertexData<Vec2>| {
        boundary.iter().all(|&(a, b, l0, l3)| {
            let l = (uv[a] - uv[b]).norm();
            (l - l0).abs() <= BOUNDARY_SLACK * l0 || (l - l3).abs() <= (l0 - l3).abs().max(BOUNDARY_SLACK * l3)
        })
    };
    // The tries run in parallel (a piece with a stubborn sliver can be untangled a hundred
    // times over the outline repairs of `flatten_piece`); collected in the order of TRIES.
    let candidates: Vec<(f64, VertexData<Vec2>)> = regions
        .par_iter()
        .filter(|r| !r.is_empty())
        .filter_map(|region| {
            let mut candidate = original.clone();
            unfold(mesh, &maps, &mut candidate, region);
            (flipped_faces(mesh, &candidate).is_empty() && outline_kept(&candidate))
                .then(|| (score(&candidate), candidate))
        })
        .collect();
    // The first try, in the order of TRIES, within SCORE_SLACK of the best score: the later
    // tries move more of BFF's map.
    let best = candidates.iter().map(|(s, _)| *s).fold(f64::INFINITY, f64::min);
    match candidates.into_iter().find(|(s, _)| *s <= best + SCORE_SLACK) {
        Some((_, found)) => {
            *uv = found;
            mesh.vertices().filter(|&v| uv[v] != original[v]).count()
        }
        None => untangle_tutte(mesh, uv),
    }
}

/// The ratio of J's singular values, as [`crate::bff::distortion`] measures it (infinite for a
/// flipped or collapsed J).
fn quasi_conformal(j: &[[f64; 2]; 2]) -> f64 {
    let (s1, s2) = singular_values(j[0][0], j[0][1], j[1][0], j[1][1]);
    if det(j) > 0.0 && s2 > 0.0 { s1 / s2 } else { f64::INFINITY }
}

/// `set` grown by `rings` rings of neighbours.
fn grow(mesh: &Mesh, set: &mut BTreeSet<VertexId>, rings: usize) {
    for _ in 0..rings {
        let grown: Vec<VertexId> = set.iter().flat_map(|&v| mesh.vertex_neighbors(v)).collect();
        set.extend(grown);
    }
}

/// Minimise the region's foldover-free energy, ε lowered until the region's faces are unfolded,
/// then a few sweeps near the plain MIPS energy.
fn unfold(mesh: &Mesh, maps: &FaceMaps, uv: &mut VertexData<Vec2>, region: &BTreeSet<VertexId>) {
    let stars: Vec<Star> = region
        .iter()
        .map(|&v| {
            let faces = star_faces(mesh, maps, v);
            // A boundary vertex's boundary edges held near their 3D lengths (the energy alone
            // is scale invariant), stiff against the faces: k L² = SPRING × the edge's face's
            // area, so a 1% change weighs SPRING · 10⁻⁴ of that face's area.
            // (Its face halfedges: the edge out of v and the one into it, each boundary edge
            // once.)
            let edges: BTreeSet<_> = mesh
                .outgoing(v)
                .flat_map(|h| [mesh.edge(h), mesh.edge(mesh.prev(h))])
                .filter(|&e| mesh.is_boundary_edge(e))
                .collect();
            let springs = edges
                .into_iter()
                .map(|e| {
                    let [a, b] = mesh.edge_vertices(e);
                    let len = mesh.edge_length(e);
                    let face = maps.area[mesh.edge_faces(e).0.idx()];
                    (if a == v { b } else { a }, len, SPRING * face / (len * len).max(1e-300))
                })
                .collect();
            Star { v, faces, springs }
        })
        .collect();
    let faces: BTreeSet<FaceId> = stars.iter().flat_map(|s| s.faces.iter().map(|sf| sf.f)).collect();
    let dets = |uv: &VertexData<Vec2>| -> Vec<f64> {
        faces.iter().filter(|f| maps.area[f.idx()] > 0.0).map(|&f| det(&maps.jacobian(mesh, uv, f))).collect()
    };
    let sweep = |uv: &mut VertexData<Vec2>, eps: f64| {
        for star in &stars {
            relax_vertex(uv, star, eps);
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
        grow(mesh, &mut set, (round % 6) / 2 + 1);
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
        tangled_by(thrown, by, |x, y| Vec2::new(x * x - y * y, 2.0 * x * y))
    }

    /// The same grid laid out by `map` of (x + 1, y).
    fn tangled_by(
        thrown: VertexId,
        by: Vec2,
        map: impl Fn(f64, f64) -> Vec2,
    ) -> (Mesh, VertexData<Vec2>, VertexData<Vec2>) {
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
                    map(p.x + 1.0, p.y)
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
        grow(&m, &mut near, 2);
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

    /// The tries run in parallel: the result is the same, bit for bit, on one thread and on
    /// several (inside and at the boundary).
    #[test]
    fn the_result_does_not_depend_on_the_thread_count() {
        for (thrown, by) in [(VertexId::new(4 * 11 + 5), Vec2::new(0.9, -0.6)), (VertexId::new(5), Vec2::new(0.0, 0.5))]
        {
            let (m, _, tangled) = tangled(thrown, by);
            let run = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let mut uv = tangled.clone();
                let moved = pool.install(|| untangle(&m, &mut uv));
                (moved, m.vertices().map(|v| [uv[v].x.to_bits(), uv[v].y.to_bits()]).collect::<Vec<_>>())
            };
            let one = run(1);
            assert!(one.0 > 0);
            assert_eq!(one, run(4));
        }
    }

    /// A thrown boundary vertex is brought back by the tries that move the boundary (laid out
    /// isometrically, as BFF lays the outline out: the tries keep the other boundary edges).
    #[test]
    fn unflips_at_the_boundary() {
        let thrown = VertexId::new(5);
        let (m, exact, mut uv) = tangled_by(thrown, Vec2::new(0.05, 0.25), Vec2::new);
        untangle(&m, &mut uv);
        let s = distortion(&m, &uv);
        assert_eq!(s.flipped_triangles, 0);
        assert!(s.qc_max < 2.0, "{s:?}");
        // Brought back by a try that moves the boundary (the thrown vertex itself).
        assert!((uv[thrown] - exact[thrown]).norm() < 0.05, "{:?} against {:?}", uv[thrown], exact[thrown]);
    }

    /// The analytic gradient and Hessian of a vertex's energy against central differences, at
    /// a boundary vertex (faces and springs, its edges stretched), unflipped and flipped.
    #[test]
    fn vertex_energy_derivatives_match_differences() {
        let (m, _, tangled) = tangled(VertexId::new(4 * 11 + 5), Vec2::new(0.9, -0.6));
        let maps = FaceMaps::new(&m);
        let mut uv = tangled.clone();
        for v in m.vertices() {
            uv[v] *= 1.3; // boundary edges longer than in 3D: the springs' exact Hessian
        }
        for (v, eps) in [(VertexId::new(5), 0.3), (VertexId::new(4 * 11 + 5), 0.3), (VertexId::new(4 * 11 + 5), 1e-3)] {
            let faces = star_faces(&m, &maps, v);
            let springs: Vec<(VertexId, f64, f64)> = m
                .vertex_neighbors(v)
                .into_iter()
                .filter(|&w| m.is_boundary_vertex(v) && m.is_boundary_vertex(w))
                .map(|w| (w, (m.position(v) - m.position(w)).norm(), 7.0))
                .collect();
            assert_eq!(springs.len(), if m.is_boundary_vertex(v) { 2 } else { 0 });
            let star = &Star { v, faces, springs };
            let (_, g, h) = vertex_energy(&uv, star, eps, true);
            let step = 1e-6;
            for axis in 0..2 {
                let mut du = Vec2::zeros();
                du[axis] = step;
                let at = |d: Vec2| {
                    let mut w = uv.clone();
                    w[v] += d;
                    vertex_energy(&w, star, eps, true)
                };
                let (ep, gp, _) = at(du);
                let (em, gm, _) = at(-du);
                let fd = (ep - em) / (2.0 * step);
                assert!(
                    (fd - g[axis]).abs() <= 1e-5 * (1.0 + g.norm()),
                    "{v:?} ε {eps}: ∂{axis} {fd} against {}",
                    g[axis]
                );
                for r in 0..2 {
                    let fdh = (gp[r] - gm[r]) / (2.0 * step);
                    let scale = 1.0 + h[0][0].abs() + h[1][1].abs();
                    assert!(
                        (fdh - h[r][axis]).abs() <= 1e-4 * scale,
                        "{v:?} ε {eps}: H[{r}][{axis}] {fdh} against {}",
                        h[r][axis]
                    );
                }
            }
        }
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
