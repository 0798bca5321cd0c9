//! One-shot simulation of a filled mold: scenario → preconditions → Newton → outputs.

use crate::coarse::{CoarseOptions, CoarseStats, Problem, coarse_start};
use crate::constraints::Constraints;
use crate::element::{Bar, Element};
use crate::hydrostatic::Hydrostatic;
use crate::loads::{Barrier, Plane};
use crate::material::Material;
use crate::newton::{IterationReport, NewtonError, NewtonOptions, NewtonResult, SolveStats, Termination, solve};
use crate::system::{Loads, System};
use clothcast_mesh::{EdgeId, FaceData, FaceId, Mesh, Vec3, VertexData, VertexId};
use nalgebra::Vector2;
use serde::Serialize;
use std::time::Instant;

/// Standard gravity (m/s²).
pub const GRAVITY: f64 = 9.81;

/// How the mold is held.
#[derive(Clone, Debug, PartialEq)]
pub enum Suspension {
    /// Clamp every vertex within `band` metres of the top (along up).
    TopBand {
        /// Band height (m).
        band: f64,
    },
    /// Clamp these vertices.
    Vertices(Vec<VertexId>),
    /// Clamp every boundary vertex.
    Boundary,
    /// Nothing clamped; rigid motions removed by a statically determinate 3-2-1 support.
    None,
}

/// Fill level of the liquid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FillLevel {
    /// The highest point of the mold.
    Top,
    /// This many metres above the lowest point (along up).
    Height(f64),
}

/// The boundary vertices not fully clamped, each with its boundary loop's index, loop by loop.
fn free_rim<'a>(mesh: &'a Mesh, constraints: &'a Constraints) -> impl Iterator<Item = (usize, VertexId)> + 'a {
    mesh.boundary_loops()
        .iter()
        .enumerate()
        .flat_map(move |(li, lp)| lp.iter().map(move |&h| (li, mesh.tail(h))))
        .filter(move |&(_, v)| constraints.n_fixed(v) < 3)
}

/// A simulation scenario (SI units, positions in metres).
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Unit up direction (the suspension direction).
    pub up: Vec3,
    /// Liquid density (kg/m³); 0 for no infill.
    pub infill_density: f64,
    /// Fill level.
    pub fill_level: FillLevel,
    /// Uniform extra pressure (Pa).
    pub head_pressure: f64,
    /// Fabric areal density (kg/m²) when its weight counts.
    pub self_weight: Option<f64>,
    /// Boundary conditions.
    pub suspension: Suspension,
    /// Support planes.
    pub supports: Vec<Plane>,
    /// Gravity (m/s²).
    pub gravity: f64,
    /// Newton options.
    pub newton: NewtonOptions,
    /// The coarse start ([`crate::coarse`]); `None`: always solve from the target.
    pub coarse: Option<CoarseOptions>,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            up: Vec3::z(),
            infill_density: 1460.0,
            fill_level: FillLevel::Top,
            head_pressure: 0.0,
            self_weight: None,
            suspension: Suspension::TopBand { band: 0.05 },
            supports: Vec::new(),
            gravity: GRAVITY,
            newton: NewtonOptions::default(),
            coarse: Some(CoarseOptions::default()),
        }
    }
}

/// What can go wrong. Variants other than [`SimError::Solver`] are problems of the input or
/// the scenario (exit code 2 in the CLI).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// The surface's normals point into the liquid.
    #[error(
        "the mesh is oriented inward (its enclosed volume is {volume:.4e} m³, negative): the infill would pull the fabric in; pass --repair to flip it"
    )]
    InwardOrientation {
        /// The (negative) signed volume.
        volume: f64,
    },
    /// Nothing holds the mold although the load is not self-equilibrated.
    #[error(
        "suspension \"none\" needs a self-equilibrated load (head pressure only), but the {load} has a net weight; clamp the mold (e.g. mode \"top-band\")"
    )]
    NotSelfEquilibrated {
        /// Which load.
        load: &'static str,
    },
    /// A suspension vertex id is out of range.
    #[error("suspension vertex {vertex} does not exist (the mesh has {vertices} vertices)")]
    NoSuchVertex {
        /// The id.
        vertex: usize,
        /// Vertex count.
        vertices: usize,
    },
    /// Boundary suspension on a closed mesh.
    #[error("suspension \"boundary\" needs an open mesh, but this one has no boundary")]
    NoBoundary,
    /// An opening below the liquid level is not clamped.
    #[error(
        "boundary vertex {vertex} (boundary loop {boundary_loop}) lies {depth:.4} m below the fill level but is not clamped: the liquid would spill; clamp the boundary (mode \"boundary\") or lower the fill level"
    )]
    SpillingBoundary {
        /// Loop index.
        boundary_loop: usize,
        /// The deepest free rim vertex (of equally deep ones, the lowest-numbered).
        vertex: VertexId,
        /// Its depth below the level (m).
        depth: f64,
    },
    /// Head pressure on an open mesh whose boundary is not clamped.
    #[error("head pressure on an open mold needs its boundary clamped (boundary vertex {vertex} is free)")]
    HeadPressureOnFreeBoundary {
        /// A free boundary vertex.
        vertex: VertexId,
    },
    /// A vertex starts on the wrong side of a support, and cannot be started in front of it.
    #[error("vertex {vertex} starts {:.4e} m behind support {support}{why}; move the support or the mesh", .distance.abs())]
    BehindSupport {
        /// Support index.
        support: usize,
        /// The vertex.
        vertex: VertexId,
        /// Signed distance (≤ 0).
        distance: f64,
        /// Why it cannot start in front of the support.
        why: BehindWhy,
    },
    /// A rest triangle of a sewn mold is degenerate or folded.
    #[error("the pattern triangle of face {} is degenerate or folded (clockwise)", face.idx())]
    FoldedRest {
        /// The face.
        face: FaceId,
    },
    /// The suspension holds every vertex: nothing can move, and no strain is left to segment.
    #[error(
        "the suspension clamps all {vertices} vertices of the mold (e.g. a [suspension] band as tall as the mold): \
         nothing can move; hold it by less"
    )]
    AllClamped {
        /// Vertex count.
        vertices: usize,
    },
    /// Nothing loads the mold (no liquid, no head pressure, no self weight): its equilibrium
    /// is the target itself, and the solve's relative residual would have no scale.
    #[error(
        "the scenario puts no load on the mold (no liquid: [infill] density is 0 or fill_level at or below the \
         mold's lowest point; no head_pressure; no self weight): there is nothing to simulate"
    )]
    NoLoad,
    /// The linear solver failed (not an input problem), in the Newton solve whose statistics
    /// the error carries.
    #[error("linear solver failure: {0}")]
    Solver(NewtonError),
}

clothcast_mesh::wrap_error!(SimError::Solver(NewtonError));

/// Why a vertex on or behind a support cannot start in front of it ([`SimError::BehindSupport`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BehindWhy {
    /// It lies deeper than a support may reach into the mold ([`SUPPORT_REACH`] of the mold's
    /// extent along the support's normal; this many metres).
    TooDeep {
        /// The reach allowed (m).
        reach_m: f64,
    },
    /// The suspension holds it there.
    Held,
    /// Lifted off the other supports, it stays behind this one: the supports pinch the mold.
    Pinched,
}

impl std::fmt::Display for BehindWhy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BehindWhy::TooDeep { reach_m } => write!(
                f,
                ", deeper than the {reach_m:.4e} m (a tenth of the mold's extent along its normal) a support may reach \
                 into the mold"
            ),
            BehindWhy::Held => write!(
                f,
                " and the suspension holds it there: a support must leave every held (clamped) vertex strictly in \
                 front of it"
            ),
            BehindWhy::Pinched => {
                write!(f, ", and no lift brings it in front of every support: the supports pinch the mold")
            }
        }
    }
}

impl SimError {
    /// The same error with its vertex renumbered by `vertex` (e.g. back to the input file's
    /// numbering when the simulated mesh was repaired).
    pub fn renumbered(self, vertex: impl Fn(VertexId) -> VertexId) -> SimError {
        match self {
            SimError::SpillingBoundary { boundary_loop, vertex: v, depth } => {
                SimError::SpillingBoundary { boundary_loop, vertex: vertex(v), depth }
            }
            SimError::HeadPressureOnFreeBoundary { vertex: v } => {
                SimError::HeadPressureOnFreeBoundary { vertex: vertex(v) }
            }
            SimError::BehindSupport { support, vertex: v, distance, why } => {
                SimError::BehindSupport { support, vertex: vertex(v), distance, why }
            }
            other => other,
        }
    }

    /// True for problems of the input or scenario (as opposed to internal failures).
    pub fn is_input_error(&self) -> bool {
        !matches!(self, SimError::Solver(_))
    }
}

/// Machine-readable statistics (the `simulation` section of summary.json).
#[derive(Clone, Debug, Serialize)]
pub struct SimStats {
    /// Residual below tolerance at full load.
    pub converged: bool,
    /// Why the solver stopped.
    pub termination: Termination,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// The iteration limit the solve had (`[solver] max_iterations`, or its default for the
    /// mesh's size: [`crate::newton::auto_max_iterations`]).
    pub max_iterations: usize,
    /// Final ‖∇Π‖/‖f_ext‖.
    pub residual_rel: f64,
    /// Where the unbalanced force is largest at the end of the solve (`None` when it is zero
    /// everywhere): the place to look at when the solve did not converge.
    pub largest_residual: Option<ResidualSite>,
    /// The relative residual over the vertices below the fill level alone (the wetted part of
    /// the mold, which gives the cast its shape; the same scale as `residual_rel`); `None`
    /// without infill.
    pub residual_rel_below_level: Option<f64>,
    /// Largest vertex displacement (m).
    pub max_displacement_m: f64,
    /// Mean vertex displacement (m).
    pub mean_displacement_m: f64,
    /// Vertices with at least one constrained direction.
    pub fixed_vertices: usize,
    /// Liquid volume at equilibrium (m³): inside the mold and below the level, every opening
    /// closed by a lid across its rim (a fan from the mean of its vertices, flat when the rim is
    /// planar): openings below the level are clamped (else the run is refused), and a lid above
    /// the level adds nothing.
    pub liquid_volume_m3: f64,
    /// Largest pressure at equilibrium (Pa).
    pub pressure_max_pa: f64,
    /// Total force from the clamps (N).
    pub reaction_force_n: [f64; 3],
    /// Force on each support plane (N).
    pub support_forces_n: Vec<[f64; 3]>,
    /// Smallest and largest squared principal stretch over the faces.
    pub lambda_range: [f64; 2],
    /// Solver details (factorizations, timings, dofs) of the fine solve.
    pub solver: SolveStats,
    /// The coarse start, if it was tried.
    pub coarse_start: Option<CoarseStats>,
    /// Vertices of the start (the target, or a sewn mold's start) on or behind a support
    /// (within [`SUPPORT_REACH`] of the mold's extent), which the solve started in front of it.
    pub start_lifted_vertices: usize,
    /// The fabric's stiffness against its load: its reference stiffness over the largest
    /// pressure at the start times the mold's height (Y / (ρ g H²) when filled to the top; 0
    /// without pressure). Above [`CONTINUATION_RATIO`] the mold is solved in stages.
    pub stiffness_ratio: f64,
    /// The stiffness continuation of a fabric very stiff for its mold (empty without): each
    /// stage's share of the fabric's stiffness and its Newton iterations, the last at the full
    /// stiffness ([`CONTINUATION_RATIO`]). `newton_iterations` counts them all.
    pub stiffness_stages: Vec<StiffnessStage>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// A vertex where the solve left an unbalanced force.
#[derive(Clone, Debug, Serialize)]
pub struct ResidualSite {
    /// The vertex (the simulated mesh's numbering, that of `deformed.ply`).
    pub vertex: usize,
    /// Its unbalanced force along its free axes (N).
    pub force_n: f64,
    /// Its height above the fill level at the end of the solve (m; negative: below, wetted);
    /// `None` without infill.
    pub height_above_level_m: Option<f64>,
}

/// One stage of the stiffness continuation ([`SimStats::stiffness_stages`]).
#[derive(Clone, Debug, Serialize)]
pub struct StiffnessStage {
    /// The fabric's stiffness in this stage, as a share of its own.
    pub factor: f64,
    /// Newton iterations of the stage.
    pub newton_iterations: usize,
    /// Whether the stage converged (a stage that did not is still the next one's start).
    pub converged: bool,
}

/// A fabric stiffer than this against its load (its reference stiffness over the largest
/// pressure times the mold's height: Y / (ρ g H²) when filled to the top) is solved by a
/// continuation in stiffness: first at [`CONTINUATION_START`] of this ratio, then three times
/// stiffer each stage, each from the last one's equilibrium, the last at the fabric's own
/// stiffness. Such a fabric barely stretches, and from the target Newton took many short steps
/// while the wrinkles settled. Measured on 2026-12-04 at 0.1 m tall (ratio 350 / 700 / 2100 for
/// Y = 50 / 100 / 300 kN/m), Newton iterations in all, directly → by stages: spot 76 → 52 /
/// 127 → 79 / 408 (with 1000 allowed) → 148; bunny 44 → 38 (50 kN/m), 134 → 93 (300 kN/m);
/// fertility 28 → 26, 47 → 54. The default scenarios at 0.5 m have ratios near 14.
pub const CONTINUATION_RATIO: f64 = 300.0;

/// The ratio of the continuation's first stage ([`CONTINUATION_RATIO`]).
pub const CONTINUATION_START: f64 = 100.0;

/// The stiffness shares of the continuation's stages for a fabric `ratio` times as stiff as its
/// load (empty at or below [`CONTINUATION_RATIO`]): from [`CONTINUATION_START`] / ratio, ×3 a
/// stage, ending at 1 (a stage above 0.7 is skipped for the last).
pub fn stiffness_stages(ratio: f64) -> Vec<f64> {
    if !(ratio > CONTINUATION_RATIO) || !ratio.is_finite() {
        return Vec::new();
    }
    let mut stages = Vec::new();
    let mut f = CONTINUATION_START / ratio;
    while f < 0.7 {
        stages.push(f);
        f *= 3.0;
    }
    stages.push(1.0);
    stages
}

/// A material with its stiffness scaled: energy, stress and tangent times `factor`.
struct Scaled<'a> {
    inner: &'a dyn Material,
    factor: f64,
}

impl Material for Scaled<'_> {
    fn response(&self, face: FaceId, e: &nalgebra::Vector3<f64>) -> crate::material::MaterialResponse {
        let r = self.inner.response(face, e);
        crate::material::MaterialResponse {
            energy: r.energy * self.factor,
            stress: r.stress * self.factor,
            tangent: r.tangent * self.factor,
        }
    }
    fn energy(&self, face: FaceId, e: &nalgebra::Vector3<f64>) -> f64 {
        self.inner.energy(face, e) * self.factor
    }
    fn reference_stiffness(&self) -> f64 {
        self.inner.reference_stiffness() * self.factor
    }
    fn is_uniform(&self) -> bool {
        self.inner.is_uniform()
    }
    fn exact_geometric_below(&self) -> f64 {
        self.inner.exact_geometric_below()
    }
    fn slack_wall_stiffness(&self) -> Option<f64> {
        self.inner.slack_wall_stiffness().map(|y| y * self.factor)
    }
}

/// The equilibrium.
pub struct SimResult {
    /// Deformed positions (m).
    pub positions: VertexData<Vec3>,
    /// Squared principal stretches (λ1 ≥ λ2) per face.
    pub stretch: FaceData<[f64; 2]>,
    /// Statistics.
    pub stats: SimStats,
    /// Iteration history.
    pub history: Vec<IterationReport>,
}

/// How far a support may reach into the target, as a share of the mold's extent along the
/// support's normal: a floor laid at the mold's lowest point, or a chair pressed a little into
/// it, is taken; a plane across the mold (most likely wrong coordinates) is refused.
pub const SUPPORT_REACH: f64 = 0.1;

/// Passes of lifts off every support (see [`lift_onto_supports`]); a vertex still behind one
/// after them is refused ([`BehindWhy::Pinched`]).
const LIFT_PASSES: usize = 64;

/// Lifts the start `x` clear of the supports: every free vertex on or behind a support moves
/// along its normal to half the contact barrier's reach in front of it (the barrier is
/// infinite at the plane). The rest shape is the target's either way; only the solve's start
/// changes. Refused: a vertex behind a support by more than [`SUPPORT_REACH`] of the mold's
/// extent along its normal (the deepest is named), a constrained vertex on or behind one (the
/// suspension holds it there), and a vertex that no lift brings in front of every support
/// (supports pinching the mold). Returns how many vertices were lifted.
fn lift_onto_supports(
    mesh: &Mesh,
    x: &mut [Vec3],
    supports: &[Plane],
    constraints: &Constraints,
    barrier: Barrier,
) -> Result<usize, SimError> {
    let behind = |support, v: usize, distance, why| SimError::BehindSupport {
        support,
        vertex: VertexId(v as u32),
        distance,
        why,
    };
    for (si, pl) in supports.iter().enumerate() {
        let mut deepest = (0, f64::INFINITY);
        for (v, p) in x.iter().enumerate() {
            let d = pl.distance(p);
            if d <= 0.0 && constraints.n_fixed(VertexId(v as u32)) > 0 {
                return Err(behind(si, v, d, BehindWhy::Held));
            }
            if d < deepest.1 {
                deepest = (v, d);
            }
        }
        let (low, high) = extent(mesh, &pl.normal);
        let reach = SUPPORT_REACH * (high - low);
        if deepest.1 < -reach {
            return Err(behind(si, deepest.0, deepest.1, BehindWhy::TooDeep { reach_m: reach }));
        }
    }
    let clearance = 0.5 * barrier.dhat;
    let mut lifted = vec![false; x.len()];
    // A lift off one support may push a vertex behind another (two planes meeting at a corner):
    // alternating lifts settle it, slowly in a sharp wedge.
    for _ in 0..LIFT_PASSES {
        let mut moved = false;
        for pl in supports {
            for (v, p) in x.iter_mut().enumerate() {
                let d = pl.distance(p);
                if d <= 0.0 {
                    *p += pl.normal * (clearance - d);
                    lifted[v] = true;
                    moved = true;
                }
            }
        }
        if !moved {
            return Ok(lifted.iter().filter(|&&l| l).count());
        }
    }
    let (si, v, d) = supports
        .iter()
        .enumerate()
        .flat_map(|(si, pl)| x.iter().enumerate().map(move |(v, p)| (si, v, pl.distance(p))))
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .expect("a support was passed");
    Err(behind(si, v, d, BehindWhy::Pinched))
}

fn extent(mesh: &Mesh, up: &Vec3) -> (f64, f64) {
    mesh.positions()
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.dot(up)), hi.max(p.dot(up))))
}

/// Constraints of a suspension mode.
pub fn suspension_constraints(mesh: &Mesh, suspension: &Suspension, up: &Vec3) -> Result<Constraints, SimError> {
    let mut c = Constraints::free(mesh.n_vertices());
    match suspension {
        Suspension::TopBand { band } => {
            let (_, top) = extent(mesh, up);
            for v in mesh.vertices() {
                if mesh.position(v).dot(up) >= top - band {
                    c.fix_vertex(v);
                }
            }
        }
        Suspension::Vertices(vs) => {
            for &v in vs {
                if v.idx() >= mesh.n_vertices() {
                    return Err(SimError::NoSuchVertex { vertex: v.idx(), vertices: mesh.n_vertices() });
                }
                c.fix_vertex(v);
            }
        }
        Suspension::Boundary => {
            if mesh.boundary_loops().is_empty() {
                return Err(SimError::NoBoundary);
            }
            for lp in mesh.boundary_loops() {
                for &h in lp {
                    c.fix_vertex(mesh.tail(h));
                }
            }
        }
        Suspension::None => {
            c.anchor_rigid_motions(mesh);
        }
    }
    Ok(c)
}

/// The contact barrier of the supports on `mesh` under loads of at most `p_max` (Pa): its
/// scale is a tenth of a mean edge, its stiffness such that it holds the largest per-vertex
/// pressure load at half that distance.
pub(crate) fn contact_barrier(mesh: &Mesh, p_max: f64, material: &dyn Material) -> Barrier {
    let dhat = 0.1 * mesh.mean_edge_length();
    let a_v = mesh.total_area() / mesh.n_vertices() as f64;
    Barrier { dhat, kappa: (p_max * a_v).max(material.reference_stiffness() * dhat * 1e-6) / (1.19 * dhat) }
}

/// Solve from the coarse start's positions when it gave some, else from `start`.
fn solve_from(
    sys: &mut System<'_>,
    coarse: Option<&mut (Option<Vec<Vec3>>, CoarseStats)>,
    start: Vec<Vec3>,
    opts: &NewtonOptions,
    progress: &mut dyn FnMut(&IterationReport),
) -> Result<NewtonResult, NewtonError> {
    match coarse {
        Some((Some(x), st)) => solve_from_coarse(sys, std::mem::take(x), st, start, opts, progress),
        _ => solve(sys, start, opts, progress),
    }
}

/// The fine solve from the coarse start `x`; if it fails with iterations left, again from the
/// target with those; if none are left, its result is kept, or its error returned (the
/// allowance is this solve's: the whole solve's, or a stiffness stage's). `st` records which.
fn solve_from_coarse(
    sys: &mut System<'_>,
    x: Vec<Vec3>,
    st: &mut CoarseStats,
    target: Vec<Vec3>,
    opts: &NewtonOptions,
    progress: &mut dyn FnMut(&IterationReport),
) -> Result<NewtonResult, NewtonError> {
    let t = Instant::now();
    // With the slack walls as configured, as from the target (the coarse levels have none):
    // crate::walls gives the figures.
    #[cfg(not(test))]
    let res = solve(sys, x, opts, progress);
    #[cfg(test)]
    let res = tests::solve_or_fail(sys, x, opts, progress);
    let (why, spent) = match &res {
        Ok(r) if r.termination == Termination::Converged => {
            st.used = true;
            return res;
        }
        Ok(r) => (format!("{:?}", r.termination), r.stats.iterations),
        // Its error counts the iterations it began.
        Err(e) => (e.to_string(), e.stats.iterations),
    };
    let left = opts.max_iterations.saturating_sub(spent);
    if left == 0 {
        // None left to solve again with. Unconverged, it is kept, not discarded (as a
        // stiffness stage before the last is when it has not converged by its cap,
        // START_MAX_ITERATIONS); an error is the solve's.
        if res.is_ok() {
            st.used = true;
            st.note = Some(format!(
                "the fine solve from it stopped unconverged ({why}) at its limit of {} iterations, none left; kept",
                opts.max_iterations
            ));
        }
        return res;
    }
    tracing::debug!(reason = %why, left, "the fine solve from the coarse start failed");
    st.fine_iterations_discarded = spent;
    st.fine_seconds_discarded = t.elapsed().as_secs_f64();
    st.note = Some(format!(
        "the fine solve from it failed ({why}); solved again from the target with the {left} iterations left"
    ));
    solve(sys, target, &NewtonOptions { max_iterations: left.max(1), ..opts.clone() }, progress)
}

/// Simulate the filled mold: `mesh` is the target (and rest) shape in metres.
pub fn simulate(
    mesh: &Mesh,
    material: &dyn Material,
    sc: &Scenario,
    progress: &mut dyn FnMut(&IterationReport),
) -> Result<SimResult, SimError> {
    simulate_with_rest(mesh, None, material, sc, progress)
}

/// Simulate a sewn mold: `mesh` is the assembled mold in the target's place (metres: where it
/// is clamped, and what the scenario's fill level and supports refer to), `rest` the triangle
/// of each face on its cut pattern piece (metres, counter-clockwise, the piece's +u along the
/// warp: the material frame of [`crate::material::WovenFabric`]). The seams are the mesh's
/// shared edges; `seams` lists the edges sewn (each with its axial stiffness in N, 0 for a
/// seam no stiffer than the fabric), which become [`Bar`]s whose rest length is the mean of the
/// edge's lengths on its two pieces. Solved from `start` (e.g. an earlier equilibrium carried
/// over; a vertex's constrained directions start where the mesh has it, its free ones where
/// `start` has it) or from the mesh,
/// without the coarse start (a simplified copy has no pattern triangles).
pub fn simulate_sewn(
    mesh: &Mesh,
    rest: &FaceData<[Vector2<f64>; 3]>,
    seams: &[(EdgeId, f64)],
    start: Option<Vec<Vec3>>,
    material: &dyn Material,
    sc: &Scenario,
    progress: &mut dyn FnMut(&IterationReport),
) -> Result<SimResult, SimError> {
    let elements = mesh
        .face_ids()
        .map(|f| Element::from_plane(&rest[f]).ok_or(SimError::FoldedRest { face: f }))
        .collect::<Result<Vec<_>, _>>()?;
    assert!(start.as_ref().is_none_or(|s| s.len() == mesh.n_vertices()), "one start position per vertex");
    let mut bars = vec![[Bar::default(); 3]; if seams.iter().any(|s| s.1 > 0.0) { mesh.n_faces() } else { 0 }];
    for &(e, stiffness) in seams.iter().filter(|s| s.1 > 0.0) {
        // The edge's length on a face's piece, from the halfedge's corner (k to k + 1).
        let length = |h| {
            let (f, k) = (mesh.face(h), mesh.corner(h));
            (rest[f][(k + 1) % 3] - rest[f][k]).norm()
        };
        let h = mesh.edge_halfedge(e);
        let l0 = length(h);
        let l = mesh.twin(h).map_or(l0, |t| 0.5 * (l0 + length(t)));
        bars[mesh.face(h).idx()][mesh.corner(h)] = Bar { stiffness, rest: l, compression: SEAM_COMPRESSION };
    }
    simulate_with_rest(mesh, Some(Sewn { elements, start, bars }), material, sc, progress)
}

/// A seam bar's stiffness in compression over its tensile stiffness (it buckles, as the woven
/// fabric's yarns do: [`crate::material::WovenFabric::COMPRESSION`]).
const SEAM_COMPRESSION: f64 = crate::material::WovenFabric::COMPRESSION;

/// What a sewn mold brings to the solve: its rest elements, its start, its seam bars.
struct Sewn {
    elements: Vec<Element>,
    start: Option<Vec<Vec3>>,
    bars: Vec<[Bar; 3]>,
}

fn simulate_with_rest(
    mesh: &Mesh,
    mut rest: Option<Sewn>,
    material: &dyn Material,
    sc: &Scenario,
    progress: &mut dyn FnMut(&IterationReport),
) -> Result<SimResult, SimError> {
    let t0 = Instant::now();
    let up = sc.up.normalize();
    let (low, top) = extent(mesh, &up);
    let fill_height = match sc.fill_level {
        FillLevel::Top => top,
        FillLevel::Height(h) => low + h,
    };
    let hydro = (sc.infill_density > 0.0 && fill_height > low).then_some(Hydrostatic {
        rho_g: sc.infill_density * sc.gravity,
        up,
        fill_height,
    });
    let loads = Loads {
        hydrostatic: hydro,
        head_pressure: sc.head_pressure,
        self_weight: sc.self_weight.filter(|&a| a > 0.0).map(|a| (a * sc.gravity, up)),
    };

    // Preconditions. (A sewn mold is loaded by its own pattern too.)
    if hydro.is_none() && loads.head_pressure == 0.0 && loads.self_weight.is_none() && rest.is_none() {
        return Err(SimError::NoLoad);
    }
    if (hydro.is_some() || loads.head_pressure > 0.0) && mesh.signed_volume() < 0.0 {
        return Err(SimError::InwardOrientation { volume: mesh.signed_volume() });
    }
    if sc.suspension == Suspension::None {
        if hydro.is_some() {
            return Err(SimError::NotSelfEquilibrated { load: "liquid infill" });
        }
        if loads.self_weight.is_some() {
            return Err(SimError::NotSelfEquilibrated { load: "fabric's own weight" });
        }
    }
    let constraints = suspension_constraints(mesh, &sc.suspension, &up)?;
    if rest.is_none() && constraints.clamped_vertices() == mesh.n_vertices() {
        return Err(SimError::AllClamped { vertices: mesh.n_vertices() });
    }
    // A free rim below the level: the deepest of its vertices named (the lowest-numbered of
    // equally deep ones, so an input file's vertex before one the refinement added).
    if let Some(hy) = &hydro {
        let mut deepest: Option<(f64, usize, VertexId)> = None;
        for (li, v) in free_rim(mesh, &constraints) {
            let d = hy.depth(&mesh.position(v));
            if d > 1e-9 * (top - low) && deepest.is_none_or(|(dd, _, dv)| d > dd || (d == dd && v < dv)) {
                deepest = Some((d, li, v));
            }
        }
        if let Some((depth, boundary_loop, vertex)) = deepest {
            return Err(SimError::SpillingBoundary { boundary_loop, vertex, depth });
        }
    }
    if loads.head_pressure != 0.0
        && let Some((_, v)) = free_rim(mesh, &constraints).next()
    {
        return Err(SimError::HeadPressureOnFreeBoundary { vertex: v });
    }
    let p_max = hydro.map(|h| h.rho_g * (h.fill_height - low)).unwrap_or(0.0)
        + loads.head_pressure.abs()
        + loads.self_weight.map(|w| w.0).unwrap_or(0.0);
    let barrier = (!sc.supports.is_empty()).then(|| contact_barrier(mesh, p_max, material));

    let target: Vec<Vec3> = mesh.positions().as_slice().to_vec();
    // The start: a sewn mold's own (its held vertices where they are held), or the target;
    // lifted clear of the supports it touches or that reach into it.
    let mut start = match rest.as_mut().and_then(|r| r.start.take()) {
        Some(mut x) => {
            for v in mesh.vertices().filter(|&v| constraints.n_fixed(v) > 0) {
                x[v.idx()] = constraints.hold(v, x[v.idx()], target[v.idx()]);
            }
            x
        }
        None => target.clone(),
    };
    let start_lifted_vertices = match barrier {
        Some(b) => lift_onto_supports(mesh, &mut start, &sc.supports, &constraints, b)?,
        None => 0,
    };
    // A fabric very stiff for its mold: stages of growing stiffness (not for a sewn mold, which
    // starts from stage 1's equilibrium).
    let stiffness_ratio = if p_max > 0.0 { material.reference_stiffness() / (p_max * (top - low)) } else { 0.0 };
    let stages = if rest.is_none() { stiffness_stages(stiffness_ratio) } else { Vec::new() };
    let mut stiffness_stages = Vec::new();
    let mut history = Vec::new();
    let mut iterations = 0;
    // The coarse start (large meshes), for the first solve: the first stage's, or the fine one.
    let uses_coarse = sc
        .coarse
        .filter(|co| rest.is_none() && material.is_uniform() && mesh.n_faces() >= co.min_faces && co.ratio >= 2);
    let coarse_for = |mat: &dyn Material, start: &[Vec3]| {
        uses_coarse.map(|co| {
            let pb = Problem {
                mesh,
                material: mat,
                loads: &loads,
                constraints: &constraints,
                supports: &sc.supports,
                start,
                barrier,
                opts: &sc.newton,
            };
            coarse_start(&pb, co.ratio)
        })
    };
    // Each solve may take the iterations the ones before it left.
    let left = |used: usize| NewtonOptions {
        max_iterations: sc.newton.max_iterations.saturating_sub(used).max(1),
        ..sc.newton.clone()
    };
    let mut coarse = None;
    // Iterations of a first stage from the coarse start that failed and was redone from the
    // target: not in the count, but in the limit.
    let mut discarded = 0;
    for &factor in stages.iter().filter(|&&f| f < 1.0) {
        // The iteration limit counts every stage, the last one's at least one: once the rest
        // is spent, the last stage follows.
        if iterations + discarded + 1 >= sc.newton.max_iterations {
            break;
        }
        let soft = Scaled { inner: material, factor };
        let mut sys = System::new(mesh, &soft, loads.clone(), &constraints, sc.supports.clone(), barrier);
        let first = stiffness_stages.is_empty();
        if first {
            coarse = coarse_for(&soft, &start);
        }
        // (It only starts the next stage.)
        let opts = left(iterations + discarded + 1).for_start();
        let res = solve_from(&mut sys, coarse.as_mut().filter(|_| first), start, &opts, progress)?;
        if first {
            discarded = coarse.as_ref().map_or(0, |(_, st): &(_, CoarseStats)| st.fine_iterations_discarded);
        }
        let converged = res.termination == Termination::Converged;
        tracing::debug!(factor, iterations = res.stats.iterations, converged, "stiffness stage");
        stiffness_stages.push(StiffnessStage { factor, newton_iterations: res.stats.iterations, converged });
        iterations += res.stats.iterations;
        history.extend(res.history);
        start = res.positions;
    }
    let direct = stiffness_stages.is_empty();
    if direct {
        coarse = coarse_for(material, &start);
    }
    let Sewn { elements, bars, .. } =
        rest.unwrap_or_else(|| Sewn { elements: Element::for_mesh(mesh), start: None, bars: Vec::new() });
    let mut sys =
        System::with_elements(mesh, elements, material, loads.clone(), &constraints, sc.supports.clone(), barrier);
    if !bars.is_empty() {
        sys.set_bars(bars);
    }
    // (A sewn mold has no coarse start; after stiffness stages the last one's equilibrium is
    // the start.)
    let mut res =
        solve_from(&mut sys, coarse.as_mut().filter(|_| direct), start, &left(iterations + discarded), progress)?;
    if !direct {
        stiffness_stages.push(StiffnessStage {
            factor: 1.0,
            newton_iterations: res.stats.iterations,
            converged: res.termination == Termination::Converged,
        });
        res.stats.iterations += iterations;
        history.append(&mut res.history);
        res.history = history;
    }
    let coarse = coarse.map(|(_, st)| st);
    if let Some(st) = &coarse {
        tracing::debug!(?st, "coarse start");
    }

    // Outputs.
    let positions = VertexData::from_vec(res.positions);
    let stretch: FaceData<[f64; 2]> = mesh
        .face_ids()
        .map(|f| {
            let p = mesh.face_vertices(f).map(|v| positions[v]);
            let (l1, l2, _) = sys.element(f).principal_stretches(&p);
            [l1, l2]
        })
        .collect();
    let disp: Vec<f64> = mesh.vertices().map(|v| (positions[v] - mesh.position(v)).norm()).collect();
    let (mut liquid, mut pmax) = (0.0, loads.head_pressure.max(0.0));
    if let Some(hy) = &hydro {
        for f in mesh.face_ids() {
            liquid += hy.face_liquid_volume(&mesh.face_vertices(f).map(|v| positions[v]));
        }
        // A free stretch of rim above the level at rest may have sagged below it: its deepest
        // vertex per loop.
        let mut sag: Vec<Option<(VertexId, f64)>> = vec![None; mesh.boundary_loops().len()];
        for (li, v) in free_rim(mesh, &constraints) {
            let d = hy.depth(&positions[v]);
            if sag[li].is_none_or(|(_, deepest)| d.total_cmp(&deepest).is_ge()) {
                sag[li] = Some((v, d));
            }
        }
        for (li, s) in sag.into_iter().enumerate() {
            if let Some((v, d)) = s
                && d > 1e-3 * (top - low)
            {
                tracing::warn!(
                    "boundary loop {li}: free vertex {} sags {:.1} mm below the liquid level at equilibrium: the liquid \
                     would spill there (clamp that stretch of rim, or lower [infill] fill_level)",
                    v.idx(),
                    d * 1e3
                );
            }
        }
        // An opening below the level is clamped (or the run is refused: the liquid would spill),
        // its frame holding the liquid in: each boundary loop is closed by a lid (a fan from the
        // mean of its vertices, flat when the rim is planar; a lid above the level adds
        // nothing). Without it the sum is the volume between the surface and the level: a dome
        // held at its rim on the floor came out negative.
        for lid in mesh.boundary_caps(&positions) {
            liquid += hy.face_liquid_volume(&lid);
        }
        let deepest = positions.iter().map(|p| hy.depth(p)).fold(0.0, f64::max);
        pmax += hy.rho_g * deepest;
    }
    // Where the residual sits: per vertex, the unbalanced force along its free axes (their
    // squares sum to ‖∇Π‖², of which the relative residual is the share of the force scale).
    let unbalanced: Vec<f64> =
        res.world_gradient.iter().enumerate().map(|(v, g)| sys.residual_force(v, g).norm()).collect();
    let gnorm = unbalanced.iter().map(|f| f * f).sum::<f64>().sqrt();
    let largest_residual =
        unbalanced.iter().enumerate().filter(|&(_, &f)| f > 0.0).max_by(|a, b| a.1.total_cmp(b.1)).map(
            |(v, &force_n)| ResidualSite {
                vertex: v,
                force_n,
                height_above_level_m: hydro.as_ref().map(|hy| -hy.depth(&positions.as_slice()[v])),
            },
        );
    let residual_rel_below_level = hydro.as_ref().map(|hy| {
        if gnorm == 0.0 || res.stats.residual_rel == 0.0 {
            return 0.0;
        }
        let wet: f64 =
            unbalanced.iter().zip(positions.iter()).filter(|(_, p)| hy.depth(p) > 0.0).map(|(f, _)| f * f).sum();
        wet.sqrt() / gnorm * res.stats.residual_rel
    });
    let reaction = sys.reaction(&res.world_gradient);
    let support_forces = sys.contact_forces(positions.as_slice());
    let lmin = stretch.iter().map(|s| s[1]).fold(f64::INFINITY, f64::min);
    let lmax = stretch.iter().map(|s| s[0]).fold(f64::NEG_INFINITY, f64::max);
    let stats = SimStats {
        converged: res.termination == Termination::Converged,
        termination: res.termination,
        newton_iterations: res.stats.iterations,
        max_iterations: sc.newton.max_iterations,
        residual_rel: res.stats.residual_rel,
        largest_residual,
        residual_rel_below_level,
        max_displacement_m: disp.iter().copied().fold(0.0, f64::max),
        mean_displacement_m: disp.iter().sum::<f64>() / disp.len().max(1) as f64,
        fixed_vertices: constraints.constrained_vertices(),
        liquid_volume_m3: liquid,
        pressure_max_pa: pmax,
        reaction_force_n: reaction.into(),
        support_forces_n: support_forces.iter().map(|f| (*f).into()).collect(),
        lambda_range: [lmin, lmax],
        solver: res.stats,
        coarse_start: coarse,
        start_lifted_vertices,
        stiffness_ratio,
        stiffness_stages,
        seconds: t0.elapsed().as_secs_f64(),
    };
    Ok(SimResult { positions, stretch, stats, history: res.history })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::WrinklingStVenantKirchhoff;
    use clothcast_mesh::shapes;
    use clothcast_mesh::sparse::SolveError;
    use std::cell::Cell;

    /// How the test makes the fine solve from the coarse start fail (no mold found takes
    /// this path).
    #[derive(Clone, Copy)]
    enum Failure {
        /// Stalled (a result, unconverged).
        Stall,
        /// An error: its factorization failed.
        Error,
    }

    thread_local! {
        /// When set, the fine solve from the coarse start fails so in this iteration, when
        /// not converged by then.
        static FAIL_FROM_COARSE_AT: Cell<Option<(usize, Failure)>> = const { Cell::new(None) };
    }

    /// [`solve`], failed in its `k`th iteration when [`FAIL_FROM_COARSE_AT`] is set to
    /// `k` and the solve has not converged by then: stalled after it, or with the error of
    /// its factorization (injected by [`crate::newton::FAIL_FACTORIZATION_IN`], so the error
    /// and its statistics come from the solver's own path).
    pub(super) fn solve_or_fail(
        sys: &mut System<'_>,
        x: Vec<Vec3>,
        opts: &NewtonOptions,
        progress: &mut dyn FnMut(&IterationReport),
    ) -> Result<NewtonResult, NewtonError> {
        match FAIL_FROM_COARSE_AT.get() {
            None => solve(sys, x, opts, progress),
            Some((k, Failure::Stall)) => {
                let mut r = solve(sys, x, &opts.at_most(k), progress)?;
                if r.termination == Termination::MaxIterations {
                    r.termination = Termination::Stalled("injected by the test".into());
                }
                Ok(r)
            }
            Some((k, Failure::Error)) => {
                crate::newton::FAIL_FACTORIZATION_IN.set(Some(k));
                let res = solve(sys, x, opts, progress);
                crate::newton::FAIL_FACTORIZATION_IN.set(None);
                res
            }
        }
    }

    /// `mesh` simulated with the fine solve from the coarse start failed `how` in its `k`th
    /// iteration (the hook cleared after).
    fn simulate_failing(
        mesh: &Mesh,
        mat: &dyn Material,
        sc: &Scenario,
        k: usize,
        how: Failure,
    ) -> Result<SimResult, SimError> {
        FAIL_FROM_COARSE_AT.set(Some((k, how)));
        let res = simulate(mesh, mat, sc, &mut |_| {});
        FAIL_FROM_COARSE_AT.set(None);
        res
    }

    /// `mesh` simulated with the fine solve from the coarse start failed `how` in its 5th
    /// iteration: redone from the target (the coarse start not used, its 5 iterations
    /// discarded).
    fn failed_from_coarse(mesh: &Mesh, mat: &dyn Material, sc: &Scenario, how: Failure) -> SimResult {
        let r = simulate_failing(mesh, mat, sc, 5, how).unwrap();
        let st = r.stats.coarse_start.as_ref().expect("tried");
        assert!(!st.used && st.fine_iterations_discarded == 5, "{st:?}");
        r
    }

    /// The fine solve from the coarse start stalls or fails with an error (injected): it is
    /// solved again from the target, and the iterations the failed solve spent count against
    /// the whole solve's limit, though not in its iteration count; for a stiff fabric's first
    /// stage (the stages after it get fewer) and for a direct solve (which is then the plain
    /// one). With none left, a stalled solve is kept and an error is the simulation's.
    #[test]
    fn a_failed_solve_from_the_coarse_start_counts_in_the_limit() {
        let mesh = shapes::icosphere(4, 0.2);
        // Y / (ρ g H²) = 959: stages at 0.10, 0.31 and 1 of the stiffness.
        let mat = WrinklingStVenantKirchhoff::from_young_poisson(2e6, 0.3);
        // From the coarse start: 11 + 9 + 10 iterations. With the first stage failed after 5
        // and redone from the target, the stages need 10 + 9 + 10, and 27 are left for them.
        let limit = 32;
        let sc = Scenario {
            coarse: Some(CoarseOptions { min_faces: 1000, ratio: 8 }),
            newton: NewtonOptions { max_iterations: limit, ..Default::default() },
            ..Default::default()
        };
        let from_coarse = simulate(&mesh, &mat, &sc, &mut |_| {}).unwrap();
        let stages = &from_coarse.stats.stiffness_stages;
        assert!(from_coarse.stats.converged && stages.len() == 3, "{stages:?}");
        assert!(from_coarse.stats.coarse_start.as_ref().is_some_and(|c| c.used && c.fine_iterations_discarded == 0));
        let error = "failed (sparse solver failure: injected by the test (Newton iteration 5, factorization";
        for (how, why) in [(Failure::Stall, "failed (Stalled"), (Failure::Error, error)] {
            let r = failed_from_coarse(&mesh, &mat, &sc, how);
            let st = r.stats.coarse_start.as_ref().expect("tried");
            let note = st.note.as_deref().unwrap_or("");
            assert!(note.contains(why) && note.contains("with the 26 iterations left"), "{note}");
            let stages = &r.stats.stiffness_stages;
            assert_eq!(r.stats.newton_iterations + st.fine_iterations_discarded, limit, "{stages:?}");
            assert!(!r.stats.converged && stages.len() == 3, "{stages:?}");
        }
        // Failed at its limit itself: with a limit of 10 the first stage may take 9 (one is
        // kept for the last stage), and its coarse level converges within them. Stalled at
        // its 9th iteration, it is kept (the last stage then takes the one left); an error
        // there is the simulation's, and carries the 9 iterations.
        let at_limit = Scenario { newton: NewtonOptions { max_iterations: 10, ..Default::default() }, ..sc.clone() };
        let r = simulate_failing(&mesh, &mat, &at_limit, 9, Failure::Stall).unwrap();
        let st = r.stats.coarse_start.as_ref().expect("tried");
        assert!(st.used && st.note.as_deref().is_some_and(|n| n.contains("none left; kept")), "{st:?}");
        let stages: Vec<usize> = r.stats.stiffness_stages.iter().map(|s| s.newton_iterations).collect();
        assert!(!r.stats.converged && stages == [9, 1], "{stages:?}");
        let failed = simulate_failing(&mesh, &mat, &at_limit, 9, Failure::Error);
        let Err(SimError::Solver(NewtonError { error: SolveError::Internal(_), stats })) = failed else {
            panic!("{:?}", failed.err())
        };
        assert!(stats.iterations == 9 && stats.factorizations >= 9, "{stats:?}");
        assert!(stats.factorization_seconds_median > 0.0 && stats.symbolic_seconds > 0.0, "{stats:?}");
        // Without stages (the default fabric): from the coarse start 7 iterations, from the
        // target 9. Failed after 5, the solve from the target is the plain one, and within 12
        // it has the 7 left.
        let mat = WrinklingStVenantKirchhoff::from_young_poisson(5e4, 0.3);
        let direct = simulate(&mesh, &mat, &Scenario { coarse: None, ..sc.clone() }, &mut |_| {}).unwrap();
        for limit in [32, 12] {
            let sc = Scenario { newton: NewtonOptions { max_iterations: limit, ..Default::default() }, ..sc.clone() };
            assert!(simulate(&mesh, &mat, &sc, &mut |_| {}).unwrap().stats.converged);
            for how in [Failure::Stall, Failure::Error] {
                let r = failed_from_coarse(&mesh, &mat, &sc, how);
                assert!(r.stats.newton_iterations + 5 <= limit, "{limit}: {}", r.stats.newton_iterations);
                if limit == 32 {
                    assert!(r.stats.converged);
                    assert_eq!(r.positions.as_slice(), direct.positions.as_slice());
                } else {
                    assert!(!r.stats.converged && r.stats.newton_iterations == 7, "{}", r.stats.newton_iterations);
                }
            }
        }
    }

    /// The symbolic analysis fails (injected by [`crate::newton::FAIL_SYMBOLIC`]): the
    /// simulation's error says so, before the first Newton iteration, and carries the time
    /// the symbolic phase spent, with no iteration or factorization counted.
    #[test]
    fn a_failed_symbolic_analysis_is_an_error_before_the_first_iteration() {
        let mesh = shapes::icosphere(3, 0.2);
        let mat = WrinklingStVenantKirchhoff::from_young_poisson(5e4, 0.3);
        let sc = Scenario { coarse: None, ..Default::default() };
        crate::newton::FAIL_SYMBOLIC.set(true);
        let failed = simulate(&mesh, &mat, &sc, &mut |_| panic!("no iteration is reported"));
        crate::newton::FAIL_SYMBOLIC.set(false);
        let Err(e @ SimError::Solver(NewtonError { error: SolveError::Internal(_), .. })) = failed else {
            panic!("{:?}", failed.err())
        };
        let message = e.to_string();
        assert!(message.ends_with("injected by the test (before the first Newton iteration)"), "{message}");
        let SimError::Solver(NewtonError { stats, .. }) = e else { unreachable!() };
        assert!(stats.iterations == 0 && stats.factorizations == 0, "{stats:?}");
        assert!(stats.symbolic_seconds > 0.0 && stats.dofs > 0 && stats.hessian_nnz > 0, "{stats:?}");
        // Without the hook the same simulation converges.
        assert!(simulate(&mesh, &mat, &sc, &mut |_| {}).unwrap().stats.converged);
    }

    /// Two supports facing each other closer than the clearance a lifted vertex is given: each
    /// lift puts the vertex behind the other support, and after the passes it is refused as
    /// pinched, named with the support it is behind.
    #[test]
    fn a_vertex_pinched_between_supports_is_refused() {
        let mesh = shapes::icosphere(1, 1.0);
        let mut x: Vec<Vec3> = mesh.positions().iter().map(|p| Vec3::new(p.x, p.y, 0.0005)).collect();
        x[0].z = -0.001;
        let supports = vec![Plane::new(Vec3::zeros(), Vec3::z()), Plane::new(Vec3::new(0.0, 0.0, 0.002), -Vec3::z())];
        let barrier = Barrier { dhat: 0.01, kappa: 1.0 };
        let free = Constraints::free(mesh.n_vertices());
        match lift_onto_supports(&mesh, &mut x, &supports, &free, barrier) {
            Err(SimError::BehindSupport { vertex, distance, why: BehindWhy::Pinched, .. }) => {
                assert_eq!(vertex, VertexId(0));
                assert!(distance < 0.0, "{distance}");
            }
            other => panic!("expected a pinched vertex, got {other:?}"),
        }
        // With room between them the same vertex is lifted, in front of both.
        let mut x: Vec<Vec3> = mesh.positions().iter().map(|p| Vec3::new(p.x, p.y, 0.0005)).collect();
        x[0].z = -0.001;
        let supports = vec![supports[0], Plane::new(Vec3::new(0.0, 0.0, 0.02), -Vec3::z())];
        assert_eq!(lift_onto_supports(&mesh, &mut x, &supports, &free, barrier).unwrap(), 1);
        assert!(supports.iter().all(|pl| pl.distance(&x[0]) > 0.0));
    }
}
