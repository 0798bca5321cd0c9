//! Boundary First Flattening in its minimal-area-distortion mode.
//!
//! Reference: R. Sawhney and K. Crane, "Boundary First Flattening", ACM Transactions on
//! Graphics 37(1), 2017 (arXiv:1704.06873). Written from the paper's ideas and
//! `ALGORITHMS.md` §9; no code is taken from the reference implementation. The paper's parts
//! are cited by name below (its Cherrier problem, Dirichlet-to-Neumann map, best-fit curve,
//! extension, minimal area distortion), not by number: the numbering was not checked against
//! the published text.
//!
//! Notation: A is the positive semi-definite cotan Laplacian (`A_ij = −½(cot α + cot β)`),
//! split into interior (I) and boundary (B) blocks; K_I = 2π − Σθ is the angle defect of the
//! interior vertices and k_B = π − Σθ the turning angle (integrated geodesic curvature) of the
//! boundary vertices; u is the log conformal scale factor (new metric e^{2u}).
//!
//! Equations implemented (all with u_B = 0, the paper's minimal-area-distortion choice; the
//! `// Eq. n` comments in the code refer to this list):
//!
//! 1. Cherrier problem with target curvature K̃ = 0, Dirichlet data u_B = 0, discretised:
//!    `A_II u_I = −K_I` (the `− A_IB u_B` term vanishes).
//! 2. Dirichlet-to-Neumann map, target boundary curvature: `k̃_B = k_B + A_BI u_I (+ A_BB u_B)`.
//!    With u_B = 0 the sign pitfall of geometry-central (ALGORITHMS.md §9) does not arise; the
//!    sign used is the reference one. Gauss–Bonnet gives Σ k̃ = 2π; the round-off (or
//!    regularisation) residual is spread over the boundary vertices by dual edge length, as the
//!    reference does for user curvatures (a no-op for an exact solve).
//! 3. Best-fit curve: target lengths ℓ* = e^{(u_i+u_j)/2} ℓ = ℓ; tangent angles
//!    φ_j = Σ_{0 < m ≤ j} k̃_m along the loop, T_j = (cos φ_j, sin φ_j); closed lengths
//!    `ℓ̃ = ℓ* − N⁻¹Tᵀ(T N⁻¹ Tᵀ)⁻¹ T ℓ*` with N⁻¹ = diag(ℓ) (the closed polygon nearest to ℓ* in
//!    the 1/ℓ-weighted norm); boundary positions are the cumulative sums of ℓ̃_j T_j. This
//!    changes the boundary lengths slightly: the change is reported as
//!    [`FlatteningStats::boundary_length_error_max_rel`].
//!
//!    3′. By default ([`BffOptions::exact_lengths`]) the curve is closed by turning instead:
//!    the target curvature changes by the least dual-length-weighted amounts that close the
//!    polygon with every edge at ℓ* (Gauss–Newton on the gap, a 3×3 system per step), so both
//!    sides of every seam keep their 3D length (to ~10⁻¹² of the boundary's; the round-off gap
//!    is spread by the best-fit formula); the best-fit curve above is the fallback when that
//!    does not converge or would fold the outline. Not in the paper.
//! 4. Extension: harmonic `A_II x_I = −A_IB x_B`, same for y.
//!
//! One Cholesky factorization of A_II (symbolic analysis and numeric factor from
//! `clothcast_mesh::sparse`) serves the three solves.
//!
//! Deviations from the reference implementation:
//! - Both coordinates are harmonic extensions (as in geometry-central); the reference code can
//!   instead take y as the conjugate harmonic of x. Both are exact on flat and developable
//!   patches.
//! - Degenerate triangles: the three cotangents of a face share one area (computed once, from
//!   its two shortest edges), so each face's stiffness is a Gram matrix and A stays positive
//!   semi-definite up to round-off even for cap triangles (per-corner cross products made
//!   A_II indefinite for heights ~1e-11 × the base in tests). That area is floored at
//!   [`BffOptions::cotan_area_floor`] × (longest edge)²; non-finite cotangents become 0 as in
//!   the reference code. Instead of always adding 1e-8·I, A_II is factored unregularised first;
//!   only if that fails is a diagonal shift (relative to the mean diagonal) added, escalating
//!   up to [`BffOptions::max_regularization`].
//! - The layout is normalised: first boundary edge of `boundary_loops()[0]` along +x, vertex
//!   mean at the origin.
//!
//! Preconditions: a connected disk (one boundary loop, χ = 1), else [`FlattenError::NotADisk`]
//! or [`FlattenError::Disconnected`]. Boundary loops of a [`Mesh`] have the surface on their
//! left, so the boundary is traversed counter-clockwise and the layout is positively oriented.
//! Flips are not prevented (the method is linear), only counted: they can occur at triangles
//! with an angle within the discretisation error of π on curved patches.
//!
//! Complexity: O(V + F) assembly, one sparse Cholesky of the interior Laplacian (AMD ordering;
//! about O(V^1.5) for surface meshes) and three pairs of triangular solves; O(F) statistics.

use crate::error::FlattenError;
use clothcast_mesh::sparse::{CholeskyFactor, CholeskySolver, SolveError, SymmetricPattern};
use clothcast_mesh::{Mesh, Vec2, Vec3, VertexData};
use std::f64::consts::PI;

/// Options of BFF.
#[derive(Clone, Debug)]
pub struct BffOptions {
    /// Floor of a face's area, relative to its longest edge squared, in its cotangent weights
    /// (`cot = (u·v) / max(2A, 2·floor·ℓ_max²)`). Only cap/needle triangles whose height is below
    /// ~2·floor × their longest edge are affected: their stiffness is scaled down, which keeps
    /// the solve well conditioned but lets such a triangle open up to about that height in 2D
    /// (its own area ratio and qc become large; it does not flip). Default `1e-10`.
    pub cotan_area_floor: f64,
    /// Largest diagonal shift of A_II, relative to its mean diagonal, tried when the
    /// unregularised matrix is not numerically positive definite (shifts 1e-12, 1e-10, … up to
    /// this value). Default `1e-6`.
    pub max_regularization: f64,
    /// Smoothing of the target boundary curvature, dimensionless (0: none, the default). With
    /// s > 0 the curvature density κ = k̃ / (dual length) is diffused along the boundary loop,
    /// `(D + t L) κ' = D κ` with D the dual lengths, L the loop's Laplacian (weights 1/ℓ) and
    /// t = s × (boundary length)²: Σ k̃ = 2π is kept and the boundary lengths too, while the
    /// curve tends to a circle as s grows (about s ≥ 1). Used to make a self-overlapping
    /// outline simple ([`crate::pieces`]).
    pub boundary_smoothing: f64,
    /// Turning taken off a stretch of the boundary: the target boundary curvature of the loop
    /// vertices `first..=last` (positions along `boundary_loops()[0]`, cyclic) is scaled by
    /// 1 − `fraction`, and what it loses is spread over the other boundary vertices by dual
    /// length (a uniform curvature density: the rest of the outline bends a little, its
    /// corners stay as sharp; closed by turning, [`BffOptions::exact_lengths`], the stretch
    /// gets a little of it back). Used to uncurl a stretch of outline that loops over itself
    /// ([`crate::pieces`]). `None` (the default): the curvature as BFF gives it.
    pub boundary_relief: Option<BoundaryRelief>,
    /// Build the Laplacian on the intrinsic Delaunay triangulation of the patch (the same
    /// surface and vertices, its edges flipped in its own metric until every cotan weight is
    /// non-negative) instead of the mesh's own edges. Default `false`; [`crate::pieces`] uses
    /// it on a piece whose flattening came out badly distorted (sliver triangles).
    pub intrinsic_delaunay: bool,
    /// Close the boundary curve by turning, not by length: the target curvature is changed by
    /// the least (dual-length-weighted) amounts that close the polygon with every boundary
    /// edge at its 3D length, so the two sides of every seam come out the same length. When
    /// that does not converge, the lengths are changed instead (the paper's best-fit curve).
    /// Default `true`.
    pub exact_lengths: bool,
}

/// A stretch of boundary whose turning is reduced ([`BffOptions::boundary_relief`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundaryRelief {
    /// First loop vertex of the stretch.
    pub first: usize,
    /// Last loop vertex of the stretch (cyclic: may be below `first`).
    pub last: usize,
    /// Fraction of the stretch's turning taken off, in [0, 1].
    pub fraction: f64,
}

impl Default for BffOptions {
    fn default() -> Self {
        Self {
            cotan_area_floor: 1e-10,
            max_regularization: 1e-6,
            boundary_smoothing: 0.0,
            boundary_relief: None,
            intrinsic_delaunay: false,
            exact_lengths: true,
        }
    }
}

/// A flattened patch.
#[derive(Clone, Debug)]
pub struct Flattening {
    /// 2D position of every vertex (metres, same units as the mesh).
    pub uv: VertexData<Vec2>,
    /// Distortion statistics.
    pub stats: FlatteningStats,
}

/// Distortion of a flattening (per-face maps are the affine maps from each 3D triangle to its
/// 2D image).
#[derive(Clone, Debug, serde::Serialize)]
pub struct FlatteningStats {
    /// 2D triangles with non-positive signed area.
    pub flipped_triangles: usize,
    /// Total signed 2D area / total 3D area.
    pub area_ratio: f64,
    /// Smallest per-face signed area ratio (negative for flipped faces).
    pub area_ratio_min: f64,
    /// Largest per-face area ratio.
    pub area_ratio_max: f64,
    /// Area-weighted mean quasi-conformal ratio σ1/σ2 of the per-face 3D → 2D map (1 is
    /// conformal; infinite if a face collapses to a segment or a point).
    pub qc_mean: f64,
    /// Largest quasi-conformal ratio.
    pub qc_max: f64,
    /// Max over boundary edges of |ℓ2D − ℓ3D| / ℓ3D.
    pub boundary_length_error_max_rel: f64,
}

/// Cotan edge weights and angle sums of a mesh, with the degenerate-face safeguards of the
/// module docs.
struct Geometry {
    /// ½ Σ cot of the opposite angles, per edge.
    weight: Vec<f64>,
    /// Σθ per vertex.
    angle_sum: Vec<f64>,
}

fn geometry(mesh: &Mesh, area_floor: f64) -> Geometry {
    let mut weight = vec![0.0; mesh.n_edges()];
    let mut angle_sum = vec![0.0; mesh.n_vertices()];
    for f in mesh.face_ids() {
        let p = mesh.face_positions(f);
        // Edge k runs from corner k to corner k + 1.
        let e: [Vec3; 3] = std::array::from_fn(|k| p[(k + 1) % 3] - p[k]);
        let l2: [f64; 3] = e.map(|x| x.norm_squared());
        // Twice the area, once per face (so that the three cotangents share one scale and the
        // face's stiffness stays a Gram matrix, PSD), from the two shortest edges: the corner
        // opposite the longest edge k is k + 2, between edges k + 1 and k + 2.
        let k_long = (0..3).fold(0, |a, k| if l2[k] > l2[a] { k } else { a });
        let twice_area = e[(k_long + 1) % 3].cross(&e[(k_long + 2) % 3]).norm();
        let denom = twice_area.max(2.0 * area_floor * l2[k_long]);
        let vs = mesh.face_vertices(f);
        for k in 0..3 {
            // Corner k lies between the outgoing edge k and the incoming edge k + 2.
            let (u, v) = (e[k], -e[(k + 2) % 3]);
            let dot = u.dot(&v);
            angle_sum[vs[k].idx()] += u.cross(&v).norm().atan2(dot);
            let mut cot = dot / denom;
            if !cot.is_finite() {
                cot = 0.0;
            }
            // The angle at corner k is opposite edge k + 1 (from corner k + 1 to k + 2).
            let h = mesh.face_halfedge(f, (k + 1) % 3);
            weight[mesh.edge(h).idx()] += 0.5 * cot;
        }
    }
    Geometry { weight, angle_sum }
}

/// The interior block A_II (pattern, values), the coupling A_IB as (i, b, w) with
/// A_ib = −w, and the vertex numbering.
struct Blocks {
    /// Interior index of each vertex, or `NONE`.
    interior: Vec<usize>,
    /// Boundary index (position along the loop) of each vertex, or `NONE`.
    boundary: Vec<usize>,
    n_interior: usize,
    pattern: SymmetricPattern,
    values: Vec<f64>,
    coupling: Vec<(usize, usize, f64)>,
}

const NONE: usize = usize::MAX;

/// `edges`: the Laplacian's edges as (a, b, cotan weight), vertices by index.
fn blocks(nv: usize, loop_vertices: &[usize], edges: &[(usize, usize, f64)]) -> Result<Blocks, FlattenError> {
    let mut boundary = vec![NONE; nv];
    for (j, &v) in loop_vertices.iter().enumerate() {
        if boundary[v] != NONE {
            return Err(FlattenError::Degenerate { reason: format!("boundary vertex {v} is visited twice") });
        }
        boundary[v] = j;
    }
    let mut interior = vec![NONE; nv];
    let mut n_interior = 0;
    for v in 0..nv {
        if boundary[v] == NONE {
            interior[v] = n_interior;
            n_interior += 1;
        }
    }
    let mut entries = Vec::new();
    for &(a, b, _) in edges {
        let (ia, ib) = (interior[a], interior[b]);
        if ia != NONE && ib != NONE {
            entries.push((ia, ib));
        }
    }
    let pattern = SymmetricPattern::from_entries(n_interior, entries);
    let mut values = vec![0.0; pattern.nnz()];
    let mut coupling = Vec::new();
    for &(a, b, w) in edges {
        match (interior[a], interior[b]) {
            (NONE, NONE) => {}
            (ia, NONE) => {
                values[pattern.slot(ia, ia)] += w;
                coupling.push((ia, boundary[b], w));
            }
            (NONE, ib) => {
                values[pattern.slot(ib, ib)] += w;
                coupling.push((ib, boundary[a], w));
            }
            (ia, ib) => {
                values[pattern.slot(ia, ia)] += w;
                values[pattern.slot(ib, ib)] += w;
                values[pattern.slot(ia, ib)] -= w;
            }
        }
    }
    Ok(Blocks { interior, boundary, n_interior, pattern, values, coupling })
}

/// The cotan weights of the intrinsic Delaunay triangulation of the mesh (Bobenko &
/// Springborn 2007): interior edges flipped, in the mesh's own metric, until every one is
/// locally Delaunay (its two opposite angles sum to at most π), so that every weight is
/// non-negative and the harmonic maps of BFF keep the maximum principle, whatever the
/// triangle shapes (obtuse slivers make negative cotan weights, and the extrinsic Laplacian
/// then folds or shears the map). Same vertices, same boundary; the edges are (a, b, w), a
/// Δ-complex's parallel edges each listed (their weights add up in the matrix).
fn intrinsic_delaunay_weights(mesh: &Mesh) -> Vec<(usize, usize, f64)> {
    use clothcast_layout::intrinsic::IntrinsicTriangulation;
    let mut t = IntrinsicTriangulation::from_mesh(mesh);
    let opposite = |t: &IntrinsicTriangulation, h: usize| t.corner_angle(t.prev(h));
    let mut stack: Vec<usize> = (0..t.n_edges()).rev().collect();
    let mut queued = vec![true; t.n_edges()];
    // Each flip raises the triangulation's smallest angles (Lawson), so this ends; the cap is
    // a guard against round-off cycling on (near-)cocircular quads.
    let mut budget = 50 * t.n_edges() + 100;
    while let Some(e) = stack.pop() {
        queued[e] = false;
        if t.is_boundary_edge(e) || budget == 0 {
            continue;
        }
        let h = t.edge_halfedge(e);
        let w = t.twin(h);
        if opposite(&t, h) + opposite(&t, w) <= PI + 1e-12 || !t.flip_edge(e, 1e-7) {
            continue;
        }
        budget -= 1;
        let h = t.edge_halfedge(e);
        let w = t.twin(h);
        for x in [t.next(h), t.prev(h), t.next(w), t.prev(w)] {
            let f = t.edge(x);
            if !queued[f] {
                queued[f] = true;
                stack.push(f);
            }
        }
    }
    (0..t.n_edges())
        .filter_map(|e| {
            let h = t.edge_halfedge(e);
            let (a, b) = (t.tail(h), t.head(h));
            if a == b {
                return None; // a loop edge adds nothing to the Laplacian
            }
            let cot = |h: usize| {
                if !t.is_interior(h) {
                    return 0.0;
                }
                let c = 1.0 / opposite(&t, h).tan();
                if c.is_finite() { c } else { 0.0 }
            };
            Some((a, b, 0.5 * (cot(h) + cot(t.twin(h)))))
        })
        .collect()
}

/// Factor A_II, adding the smallest diagonal shift (relative to the mean |diagonal|) that
/// makes it numerically positive definite. Returns the factor and the shift used.
fn factor_interior(b: &Blocks, max_reg: f64) -> Result<(CholeskyFactor, f64), FlattenError> {
    let solver = CholeskySolver::new(&b.pattern)?;
    let diag = b.pattern.diagonal_slots();
    let mean_diag = diag.iter().map(|&s| b.values[s].abs()).sum::<f64>() / diag.len().max(1) as f64;
    let mean_diag = if mean_diag.is_finite() && mean_diag > 0.0 { mean_diag } else { 1.0 };
    let mut shifts = vec![0.0];
    let mut s = 1e-12;
    while s <= max_reg * (1.0 + 1e-9) {
        shifts.push(s);
        s *= 100.0;
    }
    let mut last = SolveError::NotPositiveDefinite { index: 0 };
    for shift in shifts {
        let mut values = b.values.clone();
        for &d in &diag {
            values[d] += shift * mean_diag;
        }
        match solver.factor(&b.pattern, &values) {
            Ok(f) => {
                if shift > 0.0 {
                    tracing::warn!(shift, "BFF: interior Laplacian regularised to factor it");
                }
                return Ok((f, shift));
            }
            Err(e @ SolveError::NotPositiveDefinite { .. }) => last = e,
            Err(e) => return Err(e.into()),
        }
    }
    Err(last.into())
}

/// The boundary curvature `kt` (per loop vertex; edge j of length `lengths[j]` joins vertices
/// j and j + 1, `dual` the vertices' dual lengths) with its density diffused along the loop for
/// a time `t` (length²): solves
/// `(D + t L) κ' = k̃` (D the dual lengths, L the loop Laplacian with weights 1/ℓ) and returns
/// D κ'. Since 1ᵀL = 0 the total curvature is unchanged; as t → ∞ the density becomes uniform
/// (a circle).
fn smooth_boundary_curvature(kt: &[f64], lengths: &[f64], dual: &[f64], t: f64) -> Result<Vec<f64>, FlattenError> {
    let nb = kt.len();
    let next = |j: usize| (j + 1) % nb;
    let entries = (0..nb).flat_map(|j| [(j, j), (j.max(next(j)), j.min(next(j)))]);
    let pattern = SymmetricPattern::from_entries(nb, entries);
    let mut values = vec![0.0; pattern.nnz()];
    for j in 0..nb {
        values[pattern.slot(j, j)] += dual[j];
        let k = next(j);
        let w = t / lengths[j].max(f64::MIN_POSITIVE);
        values[pattern.slot(j, j)] += w;
        values[pattern.slot(k, k)] += w;
        values[pattern.slot(j.max(k), j.min(k))] -= w;
    }
    let factor = CholeskySolver::new(&pattern)?.factor(&pattern, &values)?;
    let mut density = kt.to_vec();
    factor.solve_in_place(&mut density);
    let smoothed: Vec<f64> = density.iter().zip(dual).map(|(k, d)| k * d).collect();
    check_finite(&smoothed, "the smoothed boundary curvature")?;
    Ok(smoothed)
}

fn check_finite(values: &[f64], what: &str) -> Result<(), FlattenError> {
    match values.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(i) => Err(FlattenError::Degenerate { reason: format!("{what} is not finite at index {i}") }),
    }
}

/// Flatten a disk-topology mesh with BFF, minimal area distortion (u_B = 0). See the module
/// docs for the equations, deviations and preconditions.
///
/// # Errors
/// [`FlattenError::NotADisk`] / [`FlattenError::Disconnected`] unless the mesh is one disk;
/// [`FlattenError::Solver`] if the interior Laplacian cannot be factored even regularised;
/// [`FlattenError::Degenerate`] if non-finite values appear or the boundary cannot be closed.
pub fn bff_flatten(mesh: &Mesh, options: &BffOptions) -> Result<Flattening, FlattenError> {
    BffProblem::new(mesh, options)?.flatten(options.boundary_relief, options.boundary_smoothing)
}

/// BFF prepared on one disk: the interior Laplacian factored once and the target boundary
/// curvature (Eqs. 1–2, closed by Gauss–Bonnet). Flattenings with different treatments of that
/// curvature ([`BffOptions::boundary_relief`], [`BffOptions::boundary_smoothing`]) reuse the
/// factor: [`crate::pieces`] tries up to 32 of them on a piece whose outline crosses itself.
pub struct BffProblem<'m> {
    mesh: &'m Mesh,
    b: Blocks,
    /// The factor of A_II and the diagonal shift it needed (none without interior vertices).
    factor: Option<(CholeskyFactor, f64)>,
    /// The log conformal scale factor at the interior vertices.
    u: Vec<f64>,
    /// Target boundary curvature per loop vertex (Σ = 2π).
    kt: Vec<f64>,
    /// Boundary edge lengths (edge j from loop vertex j to j + 1).
    lengths: Vec<f64>,
    /// Each boundary vertex's dual length: half of its two boundary edges.
    dual: Vec<f64>,
    /// The boundary's length.
    total_len: f64,
    /// [`BffOptions::exact_lengths`].
    exact_lengths: bool,
}

impl<'m> BffProblem<'m> {
    /// Factor the interior Laplacian (`options.cotan_area_floor`, `options.max_regularization`)
    /// and compute the target boundary curvature; the boundary options are read by
    /// [`BffProblem::flatten`].
    ///
    /// # Errors
    /// As [`bff_flatten`].
    pub fn new(mesh: &'m Mesh, options: &BffOptions) -> Result<Self, FlattenError> {
        let euler = mesh.euler_characteristic();
        let loops = mesh.boundary_loops();
        if euler != 1 || loops.len() != 1 {
            return Err(FlattenError::NotADisk { euler, boundary_loops: loops.len() });
        }
        if mesh.n_components() != 1 {
            return Err(FlattenError::Disconnected { components: mesh.n_components() });
        }
        let lp = &loops[0];
        let nb = lp.len();
        // Boundary vertex j is the tail of loop halfedge j; boundary edge j runs from j to j + 1.
        let loop_vertices: Vec<usize> = lp.iter().map(|&h| mesh.tail(h).idx()).collect();
        let lengths: Vec<f64> = lp.iter().map(|&h| mesh.vector(h).norm()).collect();

        let geo = geometry(mesh, options.cotan_area_floor.max(0.0));
        let edges: Vec<(usize, usize, f64)> = if options.intrinsic_delaunay {
            intrinsic_delaunay_weights(mesh)
        } else {
            mesh.edges()
                .map(|e| {
                    let [a, b] = mesh.edge_vertices(e).map(|v| v.idx());
                    (a, b, geo.weight[e.idx()])
                })
                .collect()
        };
        let b = blocks(mesh.n_vertices(), &loop_vertices, &edges)?;
        let ni = b.n_interior;
        let factor = if ni > 0 { Some(factor_interior(&b, options.max_regularization)?) } else { None };

        // Eq. 1 (K̃ = 0, u_B = 0): A_II u_I = −K_I.
        let mut u = vec![0.0; ni];
        for v in 0..mesh.n_vertices() {
            if b.interior[v] != NONE {
                u[b.interior[v]] = -(2.0 * PI - geo.angle_sum[v]);
            }
        }
        if let Some((f, _)) = &factor {
            f.solve_in_place(&mut u);
        }
        check_finite(&u, "the conformal scale factor")?;

        // Eq. 2: k̃_B = k_B + A_BI u_I, with A_bi = −w.
        let mut kt: Vec<f64> = loop_vertices.iter().map(|&v| PI - geo.angle_sum[v]).collect();
        for &(i, j, w) in &b.coupling {
            kt[j] -= w * u[i];
        }
        check_finite(&kt, "the target boundary curvature")?;
        // Curvature closing: Σ k̃ = 2π exactly (Gauss–Bonnet), residual spread by dual length.
        let total_len: f64 = lengths.iter().sum();
        let dual: Vec<f64> = (0..nb).map(|j| 0.5 * (lengths[j] + lengths[(j + nb - 1) % nb])).collect();
        let residual = 2.0 * PI - kt.iter().sum::<f64>();
        for j in 0..nb {
            kt[j] += residual * dual[j] / total_len;
        }
        tracing::debug!(residual, "BFF: curvature closing residual");
        Ok(Self { mesh, b, factor, u, kt, lengths, dual, total_len, exact_lengths: options.exact_lengths })
    }

    /// The flattening with the target boundary curvature relieved and smoothed as
    /// [`BffOptions::boundary_relief`] and [`BffOptions::boundary_smoothing`] say (`None`, 0:
    /// as BFF gives it).
    ///
    /// # Errors
    /// [`FlattenError::Degenerate`] if non-finite values appear or the boundary cannot be
    /// closed.
    pub fn flatten(&self, relief: Option<BoundaryRelief>, smoothing: f64) -> Result<Flattening, FlattenError> {
        let (mesh, b, lengths, dual) = (self.mesh, &self.b, &self.lengths, &self.dual);
        let (nb, ni, total_len) = (lengths.len(), b.n_interior, self.total_len);
        let solve = |rhs: &mut [f64]| {
            if let Some((f, _)) = &self.factor {
                f.solve_in_place(rhs);
            }
        };
        let mut kt = self.kt.clone();
        if let Some(r) = relief
            && r.first < nb
            && r.last < nb
        {
            let in_stretch = |j: usize| {
                if r.first <= r.last { (r.first..=r.last).contains(&j) } else { j >= r.first || j <= r.last }
            };
            let f = r.fraction.clamp(0.0, 1.0);
            let removed: f64 = (0..nb).filter(|&j| in_stretch(j)).map(|j| f * kt[j]).sum();
            let rest: f64 = (0..nb).filter(|&j| !in_stretch(j)).map(|j| dual[j]).sum();
            if rest > 0.0 {
                for j in 0..nb {
                    kt[j] = if in_stretch(j) { (1.0 - f) * kt[j] } else { kt[j] + removed * dual[j] / rest };
                }
            }
        }
        if smoothing > 0.0 {
            kt = smooth_boundary_curvature(&kt, lengths, dual, smoothing * total_len * total_len)?;
        }

        // Eq. 3: tangents, closed lengths, boundary curve (or, Eq. 3′, the curvature closed
        // with the lengths kept).
        if self.exact_lengths {
            match close_by_turning(&kt, lengths, dual) {
                Some(k) => kt = k,
                None => tracing::debug!(boundary = nb, "BFF: not closed by turning; the best-fit curve instead"),
            }
        }
        let tangents = boundary_tangents(&kt);
        // M = T N⁻¹ Tᵀ = Σ ℓ_j T_j T_jᵀ, r = T ℓ*.
        let (mut m00, mut m01, mut m11, mut r) = (0.0, 0.0, 0.0, Vec2::zeros());
        for j in 0..nb {
            let (t, l) = (tangents[j], lengths[j]);
            m00 += l * t.x * t.x;
            m01 += l * t.x * t.y;
            m11 += l * t.y * t.y;
            r += l * t;
        }
        let det = m00 * m11 - m01 * m01;
        let trace = m00 + m11;
        if !(det > 1e-14 * trace * trace) {
            return Err(FlattenError::Degenerate {
                reason: format!("the boundary tangents cannot close a curve (det T N⁻¹ Tᵀ = {det:e})"),
            });
        }
        let lambda = Vec2::new(m11 * r.x - m01 * r.y, m00 * r.y - m01 * r.x) / det;
        // (Closed by turning, the gap is round-off, and so is this correction: it spreads the
        // gap over the edges instead of leaving it all to the last one.)
        let closed: Vec<f64> = (0..nb).map(|j| lengths[j] - lengths[j] * tangents[j].dot(&lambda)).collect();
        if let Some(j) = closed.iter().position(|&l| !(l > 0.0)) {
            // A debug note, not a warning: what it leads to (an outline that folds on itself,
            // a badly distorted piece) is checked on the result and told in the piece's terms,
            // and the pipeline mends it (another flattening, a split) more often than not.
            tracing::debug!(edge = j, length = closed[j], "BFF: a closed boundary length is not positive");
        }
        let mut xb = vec![Vec2::zeros(); nb];
        for j in 1..nb {
            xb[j] = xb[j - 1] + closed[j - 1] * tangents[j - 1];
        }

        // Eq. 4: harmonic extension A_II x_I = −A_IB x_B (A_ib = −w).
        let (mut xi, mut yi) = (vec![0.0; ni], vec![0.0; ni]);
        for &(i, j, w) in &b.coupling {
            xi[i] += w * xb[j].x;
            yi[i] += w * xb[j].y;
        }
        solve(&mut xi);
        solve(&mut yi);
        check_finite(&xi, "the interior x coordinate")?;
        check_finite(&yi, "the interior y coordinate")?;

        let mut uv: VertexData<Vec2> = mesh
            .vertices()
            .map(|v| {
                let (i, j) = (b.interior[v.idx()], b.boundary[v.idx()]);
                if i != NONE { Vec2::new(xi[i], yi[i]) } else { xb[j] }
            })
            .collect();
        let mean = uv.iter().sum::<Vec2>() / uv.len().max(1) as f64;
        uv.iter_mut().for_each(|p| *p -= mean);

        let stats = distortion(mesh, &uv);
        tracing::debug!(
            vertices = mesh.n_vertices(),
            interior = ni,
            boundary = nb,
            regularization = self.factor.as_ref().map_or(0.0, |f| f.1),
            u_min = self.u.iter().copied().fold(0.0, f64::min),
            ?stats,
            "BFF flattening"
        );
        Ok(Flattening { uv, stats })
    }
}

/// Unit tangents of the boundary edges: edge j turns by φ_j = Σ_{0 < m ≤ j} k_m from edge 0.
fn boundary_tangents(k: &[f64]) -> Vec<Vec2> {
    let mut phi = 0.0;
    (0..k.len())
        .map(|j| {
            if j > 0 {
                phi += k[j];
            }
            Vec2::new(phi.cos(), phi.sin())
        })
        .collect()
}

/// Eq. 3′: the boundary curvature `k` (Σ = 2π) changed by the least amounts δ, in the norm
/// Σ δ_j² / w_j (w the dual lengths: a change spread as a curvature density), that close the
/// polygon with edge lengths `len`, Σ δ = 0 keeping the total turning. Gauss–Newton on the
/// closing gap g = Σ ℓ_j T_j (∂g/∂k_i = Σ_{j ≥ i} ℓ_j T_j^⊥; k_0 only closes the turning):
/// each step is the point nearest to `k` (not to the last iterate) on the linearised
/// constraints, a 3×3 system, so the result does not depend on where the loop starts. None,
/// for the best-fit curve instead, if it does not close to 10⁻¹² of the boundary length within
/// 30 steps, or if a vertex's turning would change by more than 0.5 rad or reach ±π (a fold).
fn close_by_turning(k: &[f64], len: &[f64], w: &[f64]) -> Option<Vec<f64>> {
    let n = k.len();
    let total: f64 = len.iter().sum();
    if n < 3 || !(total > 0.0) {
        return None;
    }
    let w: Vec<f64> = w.iter().map(|&x| if x > 0.0 { x } else { 0.0 }).collect();
    let mut kk = k.to_vec();
    for _ in 0..=30 {
        let t = boundary_tangents(&kk);
        let gap: Vec2 = (0..n).map(|j| len[j] * t[j]).sum();
        if gap.norm() <= 1e-12 * total {
            let sound = (0..n).all(|j| (kk[j] - k[j]).abs() <= 0.5 && (kk[j].abs() < PI || k[j].abs() >= PI));
            return sound.then_some(kk);
        }
        // Constraint rows A: the gap's Jacobian (columns S_i = Σ_{j ≥ i} ℓ_j T_j^⊥ for i ≥ 1,
        // S_0 = 0) and the sum; the step x − k = W Aᵀ μ with A W Aᵀ μ = b + A (kk − k),
        // b = (−g, Σk − Σkk).
        let mut cols = vec![nalgebra::Vector3::new(0.0, 0.0, 1.0); n];
        let mut acc = Vec2::zeros();
        for j in (1..n).rev() {
            acc += len[j] * Vec2::new(-t[j].y, t[j].x);
            cols[j] = nalgebra::Vector3::new(acc.x, acc.y, 1.0);
        }
        let mut m = nalgebra::Matrix3::<f64>::zeros();
        let mut rhs = nalgebra::Vector3::new(-gap.x, -gap.y, 0.0);
        for i in 0..n {
            m += w[i] * cols[i] * cols[i].transpose();
            rhs += cols[i] * (kk[i] - k[i]);
        }
        rhs.z -= kk.iter().sum::<f64>() - k.iter().sum::<f64>();
        let mu = m.lu().solve(&rhs)?;
        if !mu.iter().all(|x| x.is_finite()) {
            return None;
        }
        for i in 0..n {
            kk[i] = k[i] + w[i] * cols[i].dot(&mu);
        }
    }
    None
}

/// A 3D triangle in its own frame, its edges from corner 0 e1 ↦ (l1, 0) and e2 ↦ (c, h):
/// (l1, c, h, twice its area). Not finite for a triangle without area.
pub(crate) fn rest_frame(p: &[Vec3; 3]) -> (f64, f64, f64, f64) {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let twice_area = e1.cross(&e2).norm();
    let l1 = e1.norm();
    (l1, e1.dot(&e2) / l1, twice_area / l1, twice_area)
}

/// Singular values σ1 ≥ σ2 ≥ 0 of a 2×2 matrix [[a, b], [c, d]] (closed form).
pub(crate) fn singular_values(a: f64, b: f64, c: f64, d: f64) -> (f64, f64) {
    let (e, f, g, h) = ((a + d) / 2.0, (a - d) / 2.0, (c + b) / 2.0, (c - b) / 2.0);
    let (q, r) = (e.hypot(h), f.hypot(g));
    (q + r, (q - r).abs())
}

/// Distortion statistics of any 2D layout of a mesh (one position per vertex).
///
/// # Panics
/// If `uv.len() != mesh.n_vertices()` (a programming error).
#[track_caller]
pub fn distortion(mesh: &Mesh, uv: &VertexData<Vec2>) -> FlatteningStats {
    assert_eq!(uv.len(), mesh.n_vertices(), "one 2D position per vertex");
    let mut flipped = 0;
    let (mut area2, mut area3) = (0.0, 0.0);
    let (mut rmin, mut rmax) = (f64::INFINITY, f64::NEG_INFINITY);
    let (mut qc_sum, mut qc_max) = (0.0, 1.0f64);
    for f in mesh.face_ids() {
        let (l1, c, h, a3x2) = rest_frame(&mesh.face_positions(f));
        let q = mesh.face_vertices(f).map(|v| uv[v]);
        let (d1, d2) = (q[1] - q[0], q[2] - q[0]);
        let a2x2 = d1.x * d2.y - d1.y * d2.x;
        if !(a2x2 > 0.0) {
            flipped += 1;
        }
        area3 += 0.5 * a3x2;
        area2 += 0.5 * a2x2;
        if !(a3x2 > 0.0) {
            // A zero-area 3D face (impossible for a validated mesh whose positions were not
            // edited) has no map; it weighs nothing in the means.
            continue;
        }
        let ratio = a2x2 / a3x2;
        rmin = rmin.min(ratio);
        rmax = rmax.max(ratio);
        // J = [d1 d2] E3⁻¹, E3 the 3D triangle in its own frame.
        let col1 = d1 / l1;
        let col2 = (d2 * l1 - d1 * c) / (l1 * h);
        let (s1, s2) = singular_values(col1.x, col2.x, col1.y, col2.y);
        let qc = if s2 > 0.0 && s1.is_finite() { s1 / s2 } else { f64::INFINITY };
        qc_sum += 0.5 * a3x2 * qc;
        qc_max = qc_max.max(qc);
    }
    let mut bmax = 0.0f64;
    for e in mesh.edges().filter(|&e| mesh.is_boundary_edge(e)) {
        let [a, b] = mesh.edge_vertices(e);
        let l3 = mesh.edge_length(e);
        let l2 = (uv[a] - uv[b]).norm();
        let err = (l2 - l3).abs() / l3;
        bmax = if err.is_nan() { err } else { bmax.max(err) };
    }
    FlatteningStats {
        flipped_triangles: flipped,
        area_ratio: area2 / area3,
        area_ratio_min: rmin,
        area_ratio_max: rmax,
        qc_mean: qc_sum / area3,
        qc_max,
        boundary_length_error_max_rel: bmax,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::shapes;

    /// On a Delaunay mesh the intrinsic weights are the mesh's own; where obtuse triangles make
    /// a weight negative, the flips leave none negative (same vertices).
    #[test]
    fn intrinsic_delaunay_weights_are_non_negative() {
        let extrinsic = |m: &Mesh| {
            let g = geometry(m, 0.0);
            m.edges().map(|e| (m.edge_vertices(e).map(|v| v.idx()), g.weight[e.idx()])).collect::<Vec<_>>()
        };
        let sphere = shapes::icosphere(2, 1.0);
        let idt = intrinsic_delaunay_weights(&sphere);
        for ([a, b], w) in extrinsic(&sphere) {
            let mine = idt.iter().find(|&&(x, y, _)| (x, y) == (a, b) || (x, y) == (b, a)).unwrap().2;
            assert!((mine - w).abs() < 1e-12 * w.abs().max(1.0), "{a}-{b}: {mine} against {w}");
        }
        // A bumpy grid whose middle row is pushed sideways: obtuse triangles.
        let mut m = shapes::grid(8, 8, 1.0, 1.0);
        let p: Vec<_> = m
            .positions()
            .iter()
            .map(|q| {
                let mut q = *q;
                if (q.y - 0.5).abs() < 1e-9 {
                    q.x += 0.06 * (q.x * 40.0).sin();
                    q.y += 0.05;
                }
                q.z = 0.3 * (3.0 * q.x).sin() * (2.0 * q.y).cos();
                q
            })
            .collect();
        *m.positions_mut() = clothcast_mesh::VertexData::from_vec(p);
        assert!(extrinsic(&m).iter().any(|&(_, w)| w < -1e-6), "the test mesh has no negative weight");
        let idt = intrinsic_delaunay_weights(&m);
        assert!(idt.iter().all(|&(a, b, w)| a != b && w > -1e-9), "{idt:?}");
    }

    fn tri(p: [[f64; 3]; 3]) -> Mesh {
        Mesh::try_new(p.iter().map(|x| Vec3::new(x[0], x[1], x[2])).collect(), vec![[0, 1, 2]]).unwrap()
    }

    #[test]
    fn singular_values_closed_form() {
        let (s1, s2) = singular_values(3.0, 0.0, 0.0, -2.0);
        assert!((s1 - 3.0).abs() < 1e-15 && (s2 - 2.0).abs() < 1e-15);
        // Rotation by 30° times diag(2, 0.5) has singular values 2 and 0.5.
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let (s1, s2) = singular_values(2.0 * c, -0.5 * s, 2.0 * s, 0.5 * c);
        assert!((s1 - 2.0).abs() < 1e-14 && (s2 - 0.5).abs() < 1e-14);
    }

    #[test]
    fn single_triangle_is_reproduced() {
        // No interior vertex: the boundary curve alone is the layout.
        let m = tri([[0.0, 0.0, 1.0], [2.0, 0.0, 0.0], [0.5, 1.5, 0.3]]);
        let fl = bff_flatten(&m, &BffOptions::default()).unwrap();
        let s = &fl.stats;
        assert_eq!(s.flipped_triangles, 0);
        assert!(s.boundary_length_error_max_rel < 1e-14, "{s:?}");
        assert!((s.area_ratio - 1.0).abs() < 1e-14 && (s.qc_max - 1.0).abs() < 1e-12, "{s:?}");
    }

    /// Closing by turning: a 12-gon whose turnings and lengths do not close comes out closed
    /// with its lengths, its total turning kept, the changes small; started from another
    /// vertex of the loop it changes the same vertices by the same amounts.
    #[test]
    fn closing_by_turning_is_the_least_change() {
        let n = 12;
        let len: Vec<f64> = (0..n).map(|j| 1.0 + 0.3 * (j as f64 * 1.3).sin()).collect();
        let mut k: Vec<f64> = (0..n).map(|j| 2.0 * PI / n as f64 + 0.05 * (j as f64 * 2.1).cos()).collect();
        let excess = k.iter().sum::<f64>() - 2.0 * PI;
        k.iter_mut().for_each(|x| *x -= excess / n as f64);
        let w: Vec<f64> = (0..n).map(|j| 0.5 * (len[j] + len[(j + n - 1) % n])).collect();
        let gap = |k: &[f64]| -> f64 {
            let t = boundary_tangents(k);
            (0..n).map(|j| len[j] * t[j]).sum::<Vec2>().norm()
        };
        assert!(gap(&k) > 0.05, "the test polygon does not close: {}", gap(&k));
        let kk = close_by_turning(&k, &len, &w).expect("closes");
        assert!(gap(&kk) < 1e-12 * len.iter().sum::<f64>(), "{}", gap(&kk));
        assert!((kk.iter().sum::<f64>() - k.iter().sum::<f64>()).abs() < 1e-12);
        let delta: Vec<f64> = (0..n).map(|j| kk[j] - k[j]).collect();
        assert!(delta.iter().all(|d| d.abs() < 0.1), "{delta:?}");
        // The same loop started at vertex 5.
        let rot = |v: &[f64]| -> Vec<f64> { (0..n).map(|j| v[(j + 5) % n]).collect() };
        let kk5 = close_by_turning(&rot(&k), &rot(&len), &rot(&w)).expect("closes");
        for j in 0..n {
            assert!((kk5[j] - rot(&k)[j] - delta[(j + 5) % n]).abs() < 1e-6, "vertex {j}");
        }
        // A curve that cannot close without folding (one edge longer than all the others
        // together) is left to the best-fit curve.
        let mut long = len.clone();
        long[0] = 100.0;
        assert!(close_by_turning(&k, &long, &w).is_none());
    }

    #[test]
    fn distortion_of_known_maps() {
        let m = tri([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        // Stretch x by 2: area ratio 2, qc 2.
        let uv = VertexData::from_vec(vec![Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0), Vec2::new(0.0, 1.0)]);
        let s = distortion(&m, &uv);
        assert_eq!(s.flipped_triangles, 0);
        assert!((s.area_ratio - 2.0).abs() < 1e-15 && (s.qc_mean - 2.0).abs() < 1e-14, "{s:?}");
        assert!((s.boundary_length_error_max_rel - 1.0).abs() < 1e-15);
        // Mirror: flipped, negative area ratio, finite qc 1.
        let uv = VertexData::from_vec(vec![Vec2::new(0.0, 0.0), Vec2::new(-1.0, 0.0), Vec2::new(0.0, 1.0)]);
        let s = distortion(&m, &uv);
        assert_eq!(s.flipped_triangles, 1);
        assert!((s.area_ratio + 1.0).abs() < 1e-15 && (s.qc_max - 1.0).abs() < 1e-14, "{s:?}");
        // Collapsed to a segment: flipped, qc infinite.
        let uv = VertexData::from_vec(vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(2.0, 0.0)]);
        let s = distortion(&m, &uv);
        assert_eq!(s.flipped_triangles, 1);
        assert!(s.qc_max.is_infinite());
    }

    #[test]
    fn refuses_non_disks() {
        let sphere = shapes::icosphere(1, 1.0);
        assert!(matches!(
            bff_flatten(&sphere, &BffOptions::default()),
            Err(FlattenError::NotADisk { euler: 2, boundary_loops: 0 })
        ));
        let annulus = shapes::cylinder(1.0, 1.0, 12, 3, false, false);
        assert!(matches!(
            bff_flatten(&annulus, &BffOptions::default()),
            Err(FlattenError::NotADisk { euler: 0, boundary_loops: 2 })
        ));
    }

    #[test]
    fn disk_plus_torus_is_disconnected() {
        let g = shapes::grid(2, 2, 1.0, 1.0);
        let t = shapes::torus(5.0, 1.0, 8, 6);
        let mut p: Vec<Vec3> = g.positions().iter().copied().collect();
        let mut tris: Vec<[u32; 3]> = g.faces().iter().map(|f| f.map(|v| v.0)).collect();
        let off = p.len() as u32;
        p.extend(t.positions().iter().copied());
        tris.extend(t.faces().iter().map(|f| f.map(|v| v.0 + off)));
        let m = Mesh::try_new(p, tris).unwrap();
        assert_eq!((m.euler_characteristic(), m.boundary_loops().len()), (1, 1));
        assert!(matches!(bff_flatten(&m, &BffOptions::default()), Err(FlattenError::Disconnected { components: 2 })));
    }
}
