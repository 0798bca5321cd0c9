//! Static equilibrium by Newton's method on the total potential.
//!
//! Each iteration: assemble the gradient and the Hessian (elastic part projected to PSD, see
//! [`crate::element`], until the relative residual is below the material's
//! [`crate::material::Material::exact_geometric_below`], then exact;
//! pressure part exact), factor `H + μM` with the sparse Cholesky whose
//! symbolic analysis (node-level AMD or nested dissection, whichever factor is smaller) was
//! done once, solve for the step, and backtrack along it until the energy decreases enough
//! (Armijo). On large meshes the factor is computed in single precision and the step solved
//! in double precision by conjugate gradients preconditioned with it ([`FactorPrecision`]).
//! When the previous factor is a good preconditioner, conjugate gradients replace the
//! factorization (inexact Newton). `M` is the damping matrix ([`Damping`]: by default the
//! rest shape's cotan Laplacian, which damps a vertex's motion relative to its neighbours, not
//! the smooth motion of a region) and μ ≥ 0 an adaptive Levenberg–Marquardt damping: raised when
//! the matrix is not positive definite or the full step is rejected (×4 when the line search
//! shortened it to ½ or ¼, by 1/α when it shortened it further, to α), lowered (to exactly
//! zero, i.e. pure Newton with quadratic convergence) when full steps succeed. The raise by
//! 1/α, measured over 18 large solves (kitten and bunny_hr at three heights upright and at
//! 0.5, 0.4 and 0.7 m lying along +y and −x): 1088 → 876 fine iterations, and bunny_hr lying
//! along +y at 0.7 m, which crept without converging within 200 iterations (steps cut to
//! α = 2⁻¹⁰ every few iterations, each raising μ only ×4), converges in 100. This is what carries
//! the solve from the stress-free target, where a membrane has no stiffness against
//! out-of-plane motion, to the tensioned equilibrium.
//!
//! Before the line search shortens a step (the full step and the half step) it tries to
//! repair it ([`crate::relax`]): where a trial step raised Π, the rise is usually held by a few
//! faces around vertices that the step sent far too far (among wrinkled or slack faces, which
//! barely resist), and shortening the whole step for their sake makes the solve crawl. The
//! vertices of the faces holding 90% of the rise are relaxed by nonlinear block Gauss–Seidel,
//! the others keep the step, and the relaxed point is accepted on the same Armijo test.
//! Measured on the default scenario at three heights (0.4, 0.5, 0.7 m), before the coarse start
//! became a cascade: kitten 182 / 71 / 58 → 63 / 29 / 33 fine iterations, camelhead 104 / 97 /
//! 84 → 107 / 72 / 62, the geometric mean over those 24 solves of eight meshes 31.2 → 23.7.
//!
//! If the line search keeps failing at full load, the load factor is cut back (continuation)
//! from the last converged load step and raised again once that converges.
//!
//! Convergence: `‖∇Π‖ ≤ tolerance · max(‖f_ext‖, ‖f_int‖)` at full load, ∇Π and the load
//! f_ext on the free degrees of freedom, the internal forces f_int over all vertices
//! (reactions included, so that a displacement-driven problem without load has a scale).

use crate::precision::{Factored, Next, Precision};
use crate::system::System;
use clothcast_mesh::Vec3;
use clothcast_mesh::sparse::{CholeskyFactor, CholeskySolver, FactorScalar, SolveError, SymmetricPattern};
use serde::Serialize;
use std::time::Instant;

/// Newton iterations allowed by default (all load steps together) on large meshes, and at
/// least on any ([`auto_max_iterations`]). The README's default scenarios converge in 11–62,
/// but some full fills take longer: a fuzz of 60 random scenarios (2026-12-06) had two full
/// fills converge in 214 and 244, and partial fills filled to half their height or more
/// converged in 147–1166 (torus, bunny, fertility, spot at 0.25 and 0.35 m of 0.5 m; 7 of the
/// 8 within 1000).
pub const DEFAULT_MAX_ITERATIONS: usize = 1000;

/// The work the default iteration limit allows a solve, in Newton iterations times degrees of
/// freedom ([`auto_max_iterations`]; the CLI counts three per vertex, clamped ones included): a
/// Newton iteration costs about 1.0–1.3 µs per dof on the 2-core development machine below 35k
/// dofs (torus, bunny, spot: 7 / 12 / 42 ms), kitten's 2.1 µs, so a solve that does not
/// converge reports after one to two and a half minutes on small meshes (filled to a fifth and
/// run to the limit: spot 72 s; torus, bunny, fertility 120 / 155 / 141 s on a day the machine
/// ran 1.4–2.5× slow), and after the floor of
/// [`DEFAULT_MAX_ITERATIONS`] on meshes of 20k vertices and more (kitten filled to a fifth:
/// 214 s, measured on 2026-12-06, its coarse levels then allowed 200). Molds
/// filled to a fifth of their height converge, but in thousands of iterations (measured on
/// 2026-12-06 at 0.5 m filled to 0.1 m: torus 2994, 2304 vertices; bunny 2449, 3.3k;
/// fertility 1520, 4.5k; spot 4460, 11.5k vertices, more than its 1734; before
/// [`CREEP_AFTER`] 5603 / 4186 / 2433 / 7814; on 2026-12-07 kitten, 53k vertices, 3514 in 17
/// minutes, more than its 1000).
pub const AUTO_ITERATION_BUDGET: usize = 60_000_000;

/// The most iterations the default limit allows (tiny meshes).
pub const AUTO_MAX_ITERATIONS_CAP: usize = 20_000;

/// The default iteration limit of a solve with `dofs` free degrees of freedom:
/// [`AUTO_ITERATION_BUDGET`] / dofs, at least [`DEFAULT_MAX_ITERATIONS`], at most
/// [`AUTO_MAX_ITERATIONS_CAP`]. A solve that converges stops as soon as it does: the limit only
/// decides how long one that does not takes to say so.
pub fn auto_max_iterations(dofs: usize) -> usize {
    (AUTO_ITERATION_BUDGET / dofs.max(1)).clamp(DEFAULT_MAX_ITERATIONS, AUTO_MAX_ITERATIONS_CAP)
}

/// After this many Newton iterations a step the line search shortened raises the damping ×4,
/// not by 1/α. A solve that has taken this many is creeping: on a mold filled well below its
/// top, the slack and wrinkled fabric above the liquid slides a little per step (SIMULATION_LOG,
/// 2026-12-06), a step is cut short every four or so (to α down to 6·10⁻⁵ on the torus filled
/// to 0.1 m of 0.5 m), and a raise by 1/α then costs the next seven full steps' progress. Measured
/// on 2026-12-06 (torus, bunny, fertility, spot at 0.5 m): filled to 0.1 m 5603 / 4186 / 2433 /
/// 7814 → 2994 / 2449 / 1520 / 4460 iterations; filled to 0.25 and 0.35 m 4760 → 4421 in all
/// (torus and spot at 0.25 m slower: 723 → 804, 675 → 940). Below it the raise by 1/α stays,
/// which the large full fills need (it took 18 of them 1088 → 876 iterations; ×4 from a
/// relative residual of 10⁻² or 10⁻³ instead took 21 such solves 851 → 903 or 886).
pub const CREEP_AFTER: usize = 200;

/// A stiffness stage before the last, whose equilibrium only starts the next, gets at most
/// this many Newton iterations, fewer if fewer are left ([`NewtonOptions::for_start`]): one
/// that takes longer is no quick start, and the next stage goes on from where it stopped. (The
/// coarse-start levels had it too until 2026-12-07; they now have
/// [`crate::coarse::COARSE_MAX_ITERATIONS`].) Kitten's
/// coarse levels at 0.5 m take 27 and 29 (under plain StVK 184 and 110); stiffness stages of
/// spot, bunny and fertility 0.1 m tall of 300 kN/m, 10–34 (measured on 2026-12-06). This was
/// the whole solve's default limit until 2026-12-06; with 1000, a first stage that crept took
/// 999 of them and left the last one a single iteration (a torus 0.19 m tall of 283 kN/m filled
/// to 39%: relative residual 0.81; with this limit 4.8·10⁻⁴, still not converged, as most molds
/// filled below half their height).
pub const START_MAX_ITERATIONS: usize = 200;

/// Newton options.
#[derive(Clone, Debug)]
pub struct NewtonOptions {
    /// Relative residual at convergence.
    pub tolerance: f64,
    /// Iterations allowed (all load steps together).
    pub max_iterations: usize,
    /// Initial damping μ.
    pub initial_damping: f64,
    /// Factor applied to μ after a full step.
    pub damping_decrease: f64,
    /// Precision of the sparse factorization.
    pub factor_precision: FactorPrecision,
    /// Factor the two halves of the nested dissection's top split on two threads (large
    /// systems only, see [`SPLIT_MIN_FACTOR_LEN`]). It also lets nested dissection be chosen
    /// with a somewhat larger factor than AMD's for its split
    /// ([`crate::system::SPLIT_FILL_ALLOWANCE`]), so turning it off can change the ordering.
    pub split_factorization: bool,
    /// Sweeps of local relaxation ([`crate::relax`]) of the vertices a rejected trial step
    /// sent too far, before the step is shortened; 0: none (plain backtracking).
    pub relax_sweeps: usize,
    /// The relaxed vertices are those of the faces holding this fraction of the energy rise
    /// of the rejected trial step.
    pub relax_fraction: f64,
    /// The damping matrix M of the damped step `(H + μM) d = −g`.
    pub damping: Damping,
    /// Relative residual to which a step is solved with a single-precision factor (or the
    /// Newton residual, when smaller): [`SINGLE_STEP_TOLERANCE`], or the looser
    /// [`SEWN_STEP_TOLERANCE`] for the check's solve.
    pub single_step_tolerance: f64,
    /// After [`CREEP_AFTER`] iterations, the slack faces the last step ran into enter the next
    /// step's model as walls ([`crate::walls`]: the stiffness they take on past their rest
    /// length, within [`crate::walls::WALL_GAP`] of it; materials with a slack state only).
    pub slack_walls: bool,
}

impl NewtonOptions {
    /// These options with at most `n` iterations.
    pub fn at_most(&self, n: usize) -> Self {
        Self { max_iterations: self.max_iterations.min(n), ..self.clone() }
    }

    /// These options for a solve that only starts another ([`START_MAX_ITERATIONS`]).
    pub fn for_start(&self) -> Self {
        self.at_most(START_MAX_ITERATIONS)
    }
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            max_iterations: DEFAULT_MAX_ITERATIONS,
            initial_damping: 1e-2,
            damping_decrease: 0.25,
            factor_precision: FactorPrecision::Auto,
            split_factorization: true,
            relax_sweeps: 10,
            relax_fraction: 0.9,
            damping: Damping::Laplacian,
            single_step_tolerance: SINGLE_STEP_TOLERANCE,
            slack_walls: true,
        }
    }
}

/// The damping matrix M of the Levenberg–Marquardt step `(H + μM) d = −g`.
///
/// Measured on 2026-12-03 (the ninth session), fine Newton iterations of the diagonal against
/// the Laplacian: 588 → 487 over 18 solves (the example, fertility, bunny, spot, torus and
/// camelhead at 0.3, 0.5 and 1 m; camelhead at 0.3 m 156 → 112, fewer or as many in 16 of
/// the 18), 975 → 739 over 18 large ones (kitten and bunny_hr at 0.4, 0.5 and 0.7 m, upright
/// and lying along +y and −x; 201.6 → 161.8 s; bunny_hr lying along +y at 0.7 m 111 → 170,
/// kitten at 0.7 m lying along +y 157 → 68), every solve converging.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Damping {
    /// The rest shape's cotan Laplacian ⊗ I₃ ([`System::laplacian_values`]), scaled so that
    /// its median diagonal entry is [`LAPLACIAN_DAMPING_SCALE`] times the rest Hessian's: it
    /// damps the motion of a vertex relative to its neighbours (the pleats of wrinkled fabric,
    /// where single vertices overshoot) much more than the smooth motion of a region (the
    /// mold's sag and swing), which the diagonal damped alike.
    #[default]
    Laplacian,
    /// The rest Hessian's diagonal, floored at its median (dofs without stiffness at rest, the
    /// out-of-plane motion of a flat membrane, get the in-plane scale): the former default.
    Diagonal,
}

/// The Laplacian damping's median diagonal entry against the rest Hessian's (measured with a
/// first version: 0.25, 1, 4 and 16 gave 467, 484, 458 and 461 iterations over the 18 smaller
/// solves of [`Damping`]; the damping μ adapts, so the scale matters little, and camelhead's
/// path alone moves by tens of iterations with the rounding of the matrix).
pub const LAPLACIAN_DAMPING_SCALE: f64 = 4.0;

/// The damping matrix's stored entries (lower triangle, in the Hessian's pattern).
struct DampingMatrix {
    slots: Vec<usize>,
    values: Vec<f64>,
}

impl DampingMatrix {
    fn new(sys: &System<'_>, kind: Damping, rest_hessian: &[f64]) -> Self {
        // The rest Hessian's diagonal and its median (the floor of the diagonal damping, the
        // scale of the Laplacian).
        let diag: Vec<f64> = sys.diagonal_slots().iter().map(|&s| rest_hessian[s].abs()).collect();
        let median = |v: &[f64]| {
            let mut sorted = v.to_vec();
            sorted.sort_by(f64::total_cmp);
            sorted.get(sorted.len() / 2).map(|m| m.max(f64::MIN_POSITIVE))
        };
        let m = median(&diag).unwrap_or(1.0);
        let diagonal =
            || Self { slots: sys.diagonal_slots().to_vec(), values: diag.iter().map(|&d| d.max(m)).collect() };
        match kind {
            Damping::Diagonal => diagonal(),
            // Positive definite on the free dofs: the mesh is connected and at least one vertex
            // is held on every axis (a clamp, the boundary, or the 3-2-1 support of a free
            // body), so no displacement but zero has zero Dirichlet energy.
            Damping::Laplacian => {
                let dense = sys.laplacian_values();
                let ld: Vec<f64> = sys.diagonal_slots().iter().map(|&s| dense[s]).filter(|v| *v > 0.0).collect();
                let Some(lm) = median(&ld) else { return diagonal() };
                let k = LAPLACIAN_DAMPING_SCALE * m / lm;
                let (slots, values) =
                    dense.iter().enumerate().filter(|(_, v)| **v != 0.0).map(|(s, &v)| (s, k * v)).unzip();
                Self { slots, values }
            }
        }
    }

    /// vals += μ M.
    fn add(&self, vals: &mut [f64], mu: f64) {
        for (&s, &v) in self.slots.iter().zip(&self.values) {
            vals[s] += mu * v;
        }
    }

    /// The undamped values at M's slots.
    fn save(&self, vals: &[f64]) -> Vec<f64> {
        self.slots.iter().map(|&s| vals[s]).collect()
    }

    /// Put back the values `save` returned.
    fn restore(&self, vals: &mut [f64], base: &[f64]) {
        for (&s, &b) in self.slots.iter().zip(base) {
            vals[s] = b;
        }
    }

    /// dᵀ M d.
    fn quadratic(&self, pattern: &SymmetricPattern, d: &[f64]) -> f64 {
        let mut dense = vec![0.0; pattern.nnz()];
        self.add(&mut dense, 1.0);
        let mut y = vec![0.0; d.len()];
        pattern.mul_vec(&dense, d, &mut y);
        dot(&y, d)
    }
}

/// Precision of the Newton step's sparse factorization.
///
/// A single-precision factor moves half the bytes and does twice the arithmetic per SIMD
/// instruction; the step is then solved in double precision by conjugate gradients
/// preconditioned with it, to a relative residual of [`NewtonOptions::single_step_tolerance`] (or the Newton
/// residual, when smaller): each step solves the same system as the direct solve, to that
/// residual (on kitten the 111 iterations and their energies, to 7 digits, were those of the
/// direct solve). Where the single-precision factorization fails (a pivot lost to round-off,
/// or a matrix not positive definite at that damping) or does not precondition well enough,
/// that step falls back to double precision; after [`SINGLE_MAX_POOR`] poorly preconditioned
/// steps, or [`SINGLE_MAX_LOST_PIVOTS`] lost pivots, the whole solve goes on in double
/// precision. A failure is told from indefiniteness by
/// that double-precision factorization only until [`SINGLE_TRUST_AFTER`] have found the
/// matrix indefinite (and none a lost pivot); later failures raise the damping at once, but
/// for one in [`SINGLE_RECHECK_EVERY`], confirmed again.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FactorPrecision {
    /// Single precision when the factor holds at least [`SINGLE_MIN_FACTOR_LEN`] entries
    /// (where it pays: kitten's factorization 0.24 → 0.15 s), else double.
    #[default]
    Auto,
    /// Always double precision: the step is one direct solve.
    Double,
    /// A single-precision factor as the preconditioner whatever the size (with the fallbacks
    /// above).
    Single,
}

/// Factor size from which [`FactorPrecision::Auto`] factors in single precision. Measured:
/// spot (3.8M entries) gains 14% in the whole solve; fertility's and bunny's factors (AMD,
/// under 1M) gain nothing against the extra conjugate-gradient iterations.
pub const SINGLE_MIN_FACTOR_LEN: usize = 2_000_000;

/// Factor size from which the factorization is split over two threads (measured: spot, 3.8M
/// entries, 1.10 → 0.98 s; kitten, 21.7M, 33.6 → 25.6 s), judged before the dof-level
/// analysis as nine times the vertex graph's factor entries (three dofs per vertex; the
/// supernodal storage measured 10.4–10.8 times on spot, bunny_hr and kitten).
pub const SPLIT_MIN_FACTOR_LEN: usize = 2_000_000;

/// Relative residual to which a step is solved with a single-precision factor. Looser steps
/// change kitten's Newton path (1e-5: 144 iterations, 1e-3: 131, against 111 with exact
/// steps); at 1e-7 kitten's path and count were those of the direct solve.
pub const SINGLE_STEP_TOLERANCE: f64 = 1e-7;

/// [`NewtonOptions::single_step_tolerance`] of the check's solve (the sewn woven mold, stage 6,
/// set by the CLI), whose damping, raised wherever the compressed yarns make the Hessian
/// indefinite, shapes its path more than the steps' last digits do. Measured on 2026-12-04
/// (check iterations, conjugate-gradient iterations, seconds): kitten at its own size 93, 333,
/// 35.7–37.7 s with 10⁻⁷ (three runs; a fourth, in a slow minute, 42.8 s); 89, 239, 31.9–34.7
/// s with 10⁻⁵; 104, 168, 34.2–36.0 s with 10⁻³. At 0.5 m: kitten 92 → 79 iterations, 39.2 →
/// 31.6 s; bunny_hr 82 → 72, 13.5 → 14.2 s. The smaller meshes factor in double precision
/// (no change); spot and camelhead, in single, 43 and 103 → 43 and 107. Stage 1 stays at
/// 10⁻⁷: with 10⁻³ kitten took 19 iterations instead of 17 and was no faster.
pub const SEWN_STEP_TOLERANCE: f64 = 1e-5;

/// Conjugate-gradient iterations allowed with a single-precision factor before the step is
/// solved in double precision (kitten needs 2.8 on average).
const SINGLE_PCG_MAX_ITER: usize = 20;

/// Steps whose single-precision factor preconditioned too poorly, after which the solve goes
/// on in double precision.
pub const SINGLE_MAX_POOR: usize = 2;

/// Pivots lost in single precision (the double-precision factorization of the same matrix
/// succeeded) after which the solve goes on in double precision. Each costs a wasted
/// single-precision factorization, about two thirds of a double-precision one. The full fills
/// lose none (kitten, bunny_hr, spot, camelhead at 0.5 m), but a partial fill's creep loses one at
/// every other step or so, when the damping is low against the taut fabric's stiffness: spot
/// filled to 0.1 m of 0.5 m lost 1053 in 1961 iterations (3439 factorizations, 232.8 s), and with
/// this limit took 1986 iterations, 2003 factorizations and 197.0 s (2026-12-07, thirty-first
/// session, both runs beside the same other solve); bunny_hr filled to 0.1 m (walls on its
/// coarse levels, an experiment) lost 3678 in 6356 iterations, and with this limit took 5980
/// iterations and 5988 factorizations.
pub const SINGLE_MAX_LOST_PIVOTS: usize = 8;

/// Single-precision failures confirmed as indefiniteness by a double-precision factorization
/// (and none found to be a lost pivot) after which a single-precision failure is taken as
/// indefiniteness at once. The check's solve (woven fabric, exact geometric term: compressed
/// yarns make the Hessian indefinite until the damping covers them) met it at every other
/// step: kitten's check made 45 double-precision confirmations, each about twice a
/// single-precision factorization's time, none of them a lost pivot.
pub const SINGLE_TRUST_AFTER: usize = 2;

/// Once [`SINGLE_TRUST_AFTER`] confirmations have let single-precision failures be taken as
/// indefiniteness at once, one in this many is still confirmed by a double-precision
/// factorization, and a lost pivot found so ends the trust. Without it, kitten filled to 0.1 m
/// of 0.5 m (8000 allowed) met two indefinite matrices early and then took every later failure
/// as indefiniteness, raising the damping tenfold each time; confirmed one by one, 1308 of its
/// 1310 failures were lost pivots, and the solve took 3032 fine iterations instead of 3514.
/// With this recheck (and [`SINGLE_MAX_LOST_PIVOTS`]) it took 3082 and 3101 factorizations
/// (4591 before; 2026-12-07, thirty-first session).
pub const SINGLE_RECHECK_EVERY: usize = 8;

/// One iteration, for logs and tests.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct IterationReport {
    /// Iteration number (1-based).
    pub iteration: usize,
    /// Π before the step.
    pub energy: f64,
    /// ‖∇Π‖/‖f_ext‖ before the step.
    pub residual_rel: f64,
    /// Accepted step length (0 if rejected).
    pub step: f64,
    /// Damping used.
    pub damping: f64,
    /// Load factor.
    pub load_factor: f64,
}

/// Why the solver stopped.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Termination {
    /// Residual below tolerance at full load.
    Converged,
    /// Out of iterations.
    MaxIterations,
    /// No further progress possible.
    Stalled(String),
}

/// Solver statistics.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SolveStats {
    /// Newton iterations (steps attempted).
    pub iterations: usize,
    /// Numeric Cholesky factorizations (including ones refused as not positive definite).
    pub factorizations: usize,
    /// Of those, factorizations in double precision (all of them when `single_precision` is
    /// false; otherwise the fallbacks' factorizations).
    pub double_factorizations: usize,
    /// Seconds in numeric factorization.
    pub factorization_seconds: f64,
    /// Median time of a successful factorization: the floor of one Newton step.
    pub factorization_seconds_median: f64,
    /// Seconds in symbolic analysis.
    pub symbolic_seconds: f64,
    /// Seconds assembling gradients and Hessians.
    pub assembly_seconds: f64,
    /// Seconds in triangular solves.
    pub solve_seconds: f64,
    /// Seconds in line searches.
    pub line_search_seconds: f64,
    /// Load-step cutbacks.
    pub load_cutbacks: usize,
    /// Newton steps solved by conjugate gradients preconditioned with an earlier factor
    /// (no new factorization).
    pub reused_factor_steps: usize,
    /// Conjugate-gradient iterations: in those steps, and in steps solved with a
    /// single-precision factor.
    pub pcg_iterations: usize,
    /// Whether single precision was chosen for the factorizations ([`FactorPrecision`]; steps
    /// may still fall back to double, counted in `single_fallbacks`).
    pub single_precision: bool,
    /// Fallbacks from a single- to a double-precision factor (a step may fall back more than
    /// once): the sum of the four counts below.
    pub single_fallbacks: usize,
    /// Of those: a value out of single precision's range.
    pub single_fallbacks_range: usize,
    /// Of those: a pivot lost in single precision where the double-precision factorization of
    /// the same matrix succeeded (round-off). After [`SINGLE_MAX_LOST_PIVOTS`] the solve goes on
    /// in double precision.
    pub single_fallbacks_pivot: usize,
    /// Of those: a pivot lost in single precision where the double-precision factorization
    /// failed too (the matrix was not positive definite at that damping). The raised
    /// damping's factorizations are then single-precision again: normally one
    /// double-precision factorization per such fallback, and at most [`SINGLE_TRUST_AFTER`]
    /// in a solve without lost pivots (later failures are `single_indefinite_unconfirmed`).
    pub single_fallbacks_indefinite: usize,
    /// Of those: a single-precision factor that preconditioned the step too poorly.
    pub single_fallbacks_poor: usize,
    /// Single-precision factorizations that failed and were taken as the matrix's
    /// indefiniteness at that damping without a double-precision factorization (the damping
    /// raised at once): those after a confirmation in the same step, and, once
    /// [`SINGLE_TRUST_AFTER`] confirmations have been made in the solve and no failure was a
    /// lost pivot, all but one in [`SINGLE_RECHECK_EVERY`].
    pub single_indefinite_unconfirmed: usize,
    /// Whether a double-precision confirmation made once the trust was earned
    /// ([`SINGLE_TRUST_AFTER`] confirmations, no lost pivot) found a lost pivot, which ends the
    /// trust (from then on single-precision failures are confirmed as before the trust). That
    /// confirmation is mostly the recheck of one in [`SINGLE_RECHECK_EVERY`]; it may also come
    /// before a step started under the trust, when the step of the earning confirmation took
    /// the rest of the count in failures of its own.
    pub single_trust_ended: bool,
    /// Trial steps whose overshooting vertices were relaxed ([`crate::relax`]).
    pub relaxations: usize,
    /// Steps accepted after a relaxation.
    pub relaxed_steps: usize,
    /// Vertices relaxed, over all relaxations.
    pub relaxed_vertices: usize,
    /// Seconds in relaxations (included in `line_search_seconds`).
    pub relax_seconds: f64,
    /// Steps whose model had slack walls ([`crate::walls`]).
    pub wall_steps: usize,
    /// Slack walls over those steps.
    pub wall_faces: usize,
    /// Slack faces a step ran into that the next step's model left out, further than
    /// [`crate::walls::WALL_GAP`] from their wall, over all steps.
    pub wall_faces_beyond_gap: usize,
    /// Final relative residual.
    pub residual_rel: f64,
    /// Set when the solve stopped above the tolerance because the residual had reached its
    /// round-off floor ([`System::residual_floor`](crate::system::System::residual_floor)),
    /// relative to the load: the mesh's sliver triangles limit the precision.
    pub round_off_floor_rel: Option<f64>,
    /// Free degrees of freedom.
    pub dofs: usize,
    /// Stored entries of the Hessian (lower triangle).
    pub hessian_nnz: usize,
}

/// Result of a Newton solve.
pub struct NewtonResult {
    /// Final positions.
    pub positions: Vec<Vec3>,
    /// Why it stopped.
    pub termination: Termination,
    /// Statistics.
    pub stats: SolveStats,
    /// Every iteration.
    pub history: Vec<IterationReport>,
    /// World-space gradient at the final positions (for reactions).
    pub world_gradient: Vec<Vec3>,
}

/// A Newton solve that failed with an error of the sparse layer (a failed symbolic analysis
/// or factorization: not an input problem), with what the solve had spent until then. A
/// solve that merely stops short of the tolerance is no error: it returns its
/// [`Termination`].
#[derive(Debug)]
pub struct NewtonError {
    /// What failed.
    pub error: SolveError,
    /// The solve's statistics when it failed: `iterations` counts the iteration that failed
    /// (its factorization can fail before the iteration is reported to `progress`). Boxed, so
    /// that a `Result` holding it stays small.
    pub stats: Box<SolveStats>,
}

impl std::fmt::Display for NewtonError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.stats.iterations {
            0 => write!(f, "{} (before the first Newton iteration)", self.error),
            // The factorizations count the failing one.
            k => write!(f, "{} (Newton iteration {k}, factorization {})", self.error, self.stats.factorizations),
        }
    }
}

// The sparse error is part of the message, so it is not also given as the source.
impl std::error::Error for NewtonError {}

#[cfg(test)]
thread_local! {
    /// Test hook: when set, the factorizations of this Newton iteration fail (as an internal
    /// error of the sparse layer would).
    pub(crate) static FAIL_FACTORIZATION_IN: std::cell::Cell<Option<usize>> = const { std::cell::Cell::new(None) };
    /// Test hook: when set, the symbolic analysis of the one-thread factorization fails (as an
    /// internal error of the sparse layer would), before the first Newton iteration.
    pub(crate) static FAIL_SYMBOLIC: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// `res`, or the error a test hook injects when `fail` (an internal error of the sparse layer).
#[cfg(test)]
fn injected<T>(res: Result<T, SolveError>, fail: bool) -> Result<T, SolveError> {
    if fail { Err(SolveError::Internal("injected by the test".into())) } else { res }
}

/// Solve for equilibrium from `x0`. `progress` is called after every iteration.
pub fn solve(
    sys: &mut System<'_>,
    x0: Vec<Vec3>,
    opts: &NewtonOptions,
    progress: &mut dyn FnMut(&IterationReport),
) -> Result<NewtonResult, NewtonError> {
    let mut stats = SolveStats { dofs: sys.n_dofs(), hessian_nnz: sys.pattern().nnz(), ..Default::default() };
    let mut factor_times: Vec<f64> = Vec::new();
    let mut history = Vec::new();
    let mut x = x0;
    if sys.n_dofs() == 0 {
        let ev = sys.evaluate(&x, 1.0, false);
        return Ok(NewtonResult {
            positions: x,
            termination: Termination::Converged,
            stats,
            history,
            world_gradient: ev.world_gradient,
        });
    }
    let t = Instant::now();
    // The fill-reducing ordering: AMD or nested dissection, whichever gives the smaller factor
    // (nested dissection wins on large meshes: kitten's factorization 0.30 → 0.21 s), or
    // nested dissection with a somewhat larger one when it can be split over two threads.
    // Before the first iteration: the symbolic phase's time spent.
    let failed = |error, stats: &SolveStats| NewtonError {
        error,
        stats: Box::new(SolveStats { symbolic_seconds: t.elapsed().as_secs_f64(), ..stats.clone() }),
    };
    let ordering = sys.dof_ordering(opts.split_factorization).map_err(|e| failed(e, &stats))?;
    tracing::debug!(amd = ordering.amd_fill, nd = ?ordering.nd_fill, nested = ordering.nested, "vertex-graph factor sizes");
    let mut split = None;
    // Two threads for the factorization and the solves where the ordering offers its split
    // (asked for, and the factor large enough to pay for the separator's dense work). Not
    // conditioned on the thread count: with one thread the halves run one after the other,
    // same results.
    if let Some(parts) = ordering.split {
        match CholeskySolver::with_split_ordering(sys.pattern(), &ordering.dofs, parts) {
            Ok(s) => {
                tracing::debug!(parts = ?parts, len = s.factor_len(), "split factorization");
                split = Some(s);
            }
            Err(e) => tracing::debug!(error = %e, "split analysis failed; one thread"),
        }
    }
    let chol = match split {
        Some(s) => s,
        // Without its split, nested dissection chosen for it (with the larger factor) gives
        // way to AMD.
        None => {
            let res = CholeskySolver::with_ordering(
                sys.pattern(),
                Some(ordering.amd_dofs.as_ref().unwrap_or(&ordering.dofs)),
            );
            #[cfg(test)]
            let res = injected(res, FAIL_SYMBOLIC.get());
            res.map_err(|e| failed(e, &stats))?
        }
    };
    tracing::debug!(len = chol.factor_len(), "factor size");
    stats.symbolic_seconds = t.elapsed().as_secs_f64();

    // The damping matrix, scaled by the Hessian at the start.
    // (That evaluation, at full load where the solve starts, is also its first iteration's.)
    let ta = Instant::now();
    // The geometric term taken exactly (see Material::exact_geometric_below): from the start
    // for a material that asks for it throughout (a system solved before starts afresh).
    let exact_below = sys.material().exact_geometric_below();
    let mut exact = exact_below == f64::INFINITY;
    sys.set_exact_geometric(exact);
    let mut first_evaluation = Some(sys.evaluate(&x, 1.0, true));
    stats.assembly_seconds += ta.elapsed().as_secs_f64();
    let damping = DampingMatrix::new(
        sys,
        opts.damping,
        first_evaluation.as_ref().and_then(|ev| ev.hessian.as_ref()).expect("requested"),
    );

    let mut mu = opts.initial_damping;
    let (mut s, mut s_ok, mut ds) = (1.0f64, 0.0f64, 1.0f64);
    let mut x_ok = x.clone();
    let mut failures = 0usize;
    let mut trial = vec![Vec3::zeros(); x.len()];
    let mut factor = Factors::default();
    let use_single = match opts.factor_precision {
        FactorPrecision::Double => false,
        FactorPrecision::Single => true,
        FactorPrecision::Auto => chol.factor_len() >= SINGLE_MIN_FACTOR_LEN,
    };
    stats.single_precision = use_single;
    // Which precision each factorization takes (crate::precision).
    let mut precision = Precision::new(use_single);
    let mut pcg_promising = false;
    // Per-face energies at the iterate (from its evaluation, once per iteration, when a
    // relaxation needs them) and at a trial point.
    let (mut base_faces, mut trial_faces) = (Vec::new(), Vec::new());
    let relax_tolerance = RELAX_TOLERANCE * sys.mean_edge_length();
    // The faces that are walls of the next step's model, by face index.
    let mut wall_next = vec![false; sys.n_faces()];
    let residual_floor = sys.residual_floor();
    let termination;
    let mut last_world_gradient;
    loop {
        let ta = Instant::now();
        let ev = match first_evaluation.take() {
            Some(ev) => ev,
            None => sys.evaluate(&x, s, true),
        };
        stats.assembly_seconds += ta.elapsed().as_secs_f64();
        last_world_gradient = ev.world_gradient;
        let gnorm = norm(&ev.gradient);
        // Scale: the load, or the internal forces when they are larger (prescribed
        // displacements without load), so the criterion is meaningful either way.
        let fnorm = norm(&ev.external).max(ev.internal_norm).max(f64::MIN_POSITIVE);
        let r = gnorm / fnorm;
        stats.residual_rel = r;
        // At full load, a residual below its round-off floor is as converged as it can get
        // (sliver triangles: the floor can lie above the tolerance; said in the statistics).
        let at_floor = s >= 1.0 && gnorm <= residual_floor;
        if r <= opts.tolerance || gnorm == 0.0 || at_floor {
            if s >= 1.0 {
                if r > opts.tolerance {
                    stats.round_off_floor_rel = Some(residual_floor / fnorm);
                    tracing::debug!(residual = r, floor = residual_floor / fnorm, "converged at the round-off floor");
                }
                termination = Termination::Converged;
                break;
            }
            // Load step done: advance.
            s_ok = s;
            x_ok.copy_from_slice(&x);
            ds = (ds * 2.0).min(1.0 - s_ok);
            s = (s_ok + ds).min(1.0);
            continue;
        }
        if stats.iterations >= opts.max_iterations {
            termination = Termination::MaxIterations;
            break;
        }
        if r < exact_below && !exact {
            exact = true;
            sys.set_exact_geometric(true);
            tracing::debug!(iteration = stats.iterations + 1, residual = r, "geometric term exact from here");
        }
        stats.iterations += 1;
        let mut vals = ev.hessian.expect("requested");
        let mut rhs: Vec<f64> = ev.gradient.iter().map(|g| -g).collect();
        // A creeping solve: the slack faces the last step ran into are walls of this step's
        // model, those within WALL_GAP of their wall (see crate::walls).
        let walls = if opts.slack_walls && stats.iterations > CREEP_AFTER { sys.slack_walls(&x) } else { Vec::new() };
        let mut walled = 0;
        for w in walls.iter().filter(|w| wall_next[w.face as usize]) {
            if w.within_gap() {
                w.add_to(sys.pattern(), &mut vals, &mut rhs);
                walled += 1;
            } else {
                stats.wall_faces_beyond_gap += 1;
            }
        }
        if walled > 0 {
            stats.wall_steps += 1;
            stats.wall_faces += walled;
        }
        // The undamped values where the damping matrix adds, to re-damp from.
        let base = damping.save(&vals);
        if mu > 0.0 {
            damping.add(&mut vals, mu);
        }
        let mut step = vec![0.0; rhs.len()];
        // Inexact Newton: conjugate gradients preconditioned by the last factor (forcing term
        // min(0.1, √r)), worth it only when it converges in a few iterations, so tried only
        // undamped and right after a fresh factor or a successful reuse.
        let ts = Instant::now();
        let reused = match &factor {
            f if f.is_valid() && mu == 0.0 && pcg_promising => {
                let eta = r.sqrt().min(0.1);
                match pcg(sys.pattern(), &vals, &|z: &mut [f64]| f.apply(z), &rhs, eta * gnorm, PCG_MAX_ITER, &mut step)
                {
                    Ok(k) => {
                        stats.pcg_iterations += k;
                        stats.reused_factor_steps += 1;
                        true
                    }
                    Err(k) => {
                        stats.pcg_iterations += k;
                        pcg_promising = false;
                        false
                    }
                }
            }
            _ => false,
        };
        stats.solve_seconds += ts.elapsed().as_secs_f64();
        if !reused {
            let mut step_precision = precision.step(&stats);
            // Factor H + μM, raising μ until positive definite (reusing the factor's buffers).
            let ok = 'outer: loop {
                let ok = loop {
                    let single = step_precision.single;
                    let tf = Instant::now();
                    let res = factor.refactor(&chol, sys.pattern(), &vals, single);
                    #[cfg(test)]
                    let res = injected(res, FAIL_FACTORIZATION_IN.get() == Some(stats.iterations));
                    let dt = tf.elapsed().as_secs_f64();
                    stats.factorizations += 1;
                    stats.double_factorizations += usize::from(!single);
                    stats.factorization_seconds += dt;
                    let outcome = match &res {
                        Ok(()) => {
                            factor_times.push(dt);
                            Factored::Ok
                        }
                        Err(SolveError::NotPositiveDefinite { .. }) => Factored::NotPositiveDefinite,
                        Err(SolveError::OutOfRange { .. }) => Factored::OutOfRange,
                        Err(_) => Factored::Other,
                    };
                    match precision.factored(&mut step_precision, outcome, &mut stats) {
                        Next::Solve => break true,
                        Next::RaiseDamping => {
                            mu = if mu == 0.0 { 1e-8 } else { mu * 10.0 };
                            if mu > 1e12 {
                                break false;
                            }
                            damping.restore(&mut vals, &base);
                            damping.add(&mut vals, mu);
                        }
                        Next::Refactor => {}
                        Next::Fail => {
                            finish(&mut stats, &mut factor_times);
                            return Err(NewtonError {
                                error: res.expect_err("a failed factorization"),
                                stats: Box::new(stats),
                            });
                        }
                    }
                };
                if !ok {
                    break false;
                }
                let ts = Instant::now();
                let f = &factor;
                if step_precision.single {
                    let tol = opts.single_step_tolerance.min(r) * gnorm;
                    let res = pcg(
                        sys.pattern(),
                        &vals,
                        &|z: &mut [f64]| f.apply(z),
                        &rhs,
                        tol,
                        SINGLE_PCG_MAX_ITER,
                        &mut step,
                    );
                    stats.solve_seconds += ts.elapsed().as_secs_f64();
                    match res {
                        Ok(k) => {
                            stats.pcg_iterations += k;
                            break 'outer true;
                        }
                        Err(k) => {
                            stats.pcg_iterations += k;
                            precision.poorly_preconditioned(&mut step_precision, &mut stats);
                            continue 'outer;
                        }
                    }
                }
                step.copy_from_slice(&rhs);
                f.apply(&mut step);
                stats.solve_seconds += ts.elapsed().as_secs_f64();
                break true;
            };
            if !ok {
                termination =
                    Termination::Stalled("the stiffness matrix stays indefinite even with heavy damping".into());
                break;
            }
            pcg_promising = true;
        }

        // The next step's walls: the slack faces this one runs into, e1 linearized along it.
        wall_next.fill(false);
        for w in &walls {
            if w.strain_along(&step) > 0.0 {
                wall_next[w.face as usize] = true;
            }
        }

        // The step is solved (the factor holds its own copy of the values): the Hessian's
        // buffer goes back to the system for the next assembly.
        sys.recycle_hessian(vals);

        // Backtracking line search on Π.
        let tl = Instant::now();
        let slope: f64 = ev.gradient.iter().zip(&step).map(|(g, d)| g * d).sum();
        let mut alpha = sys.max_feasible_step(&x, &step);
        let mut accepted = 0.0;
        let mut accepted_energy = ev.energy;
        if slope < 0.0 {
            // Round-off of Π grows with the magnitude of the summed terms; once the predicted
            // decrease is below it, the step is accepted if Π does not rise beyond it.
            let noise = 1e-13 * ev.energy_magnitude.max(ev.energy.abs());
            let sufficient = |e: f64, alpha: f64| {
                e <= ev.energy + 1e-4 * alpha * slope || (-alpha * slope <= noise && e <= ev.energy + noise)
            };
            // The iterate's per-face energies, taken at the first relaxation of this search.
            base_faces.clear();
            let relaxing = opts.relax_sweeps > 0;
            let mut trials = 0;
            while alpha > 1e-10 {
                trials += 1;
                sys.apply_step(&x, &step, alpha, &mut trial);
                let relax_this = relaxing && trials <= RELAX_TRIALS;
                let mut e = sys.energy_faces(&trial, s, relax_this.then_some(&mut trial_faces));
                // Before shortening the step: relax the vertices it sent too far (none when no
                // face's energy rose: the step then fell short by the weight or contacts).
                let seeds = if !sufficient(e, alpha) && relax_this {
                    if base_faces.is_empty() {
                        sys.evaluated_face_energies(&mut base_faces);
                    }
                    sys.overshooting_vertices(&base_faces, &trial_faces, opts.relax_fraction)
                } else {
                    Vec::new()
                };
                if !seeds.is_empty() {
                    let tr = Instant::now();
                    let rep = sys.relax(&mut trial, s, &seeds, opts.relax_sweeps, relax_tolerance);
                    e = sys.energy(&trial, s);
                    stats.relaxations += 1;
                    stats.relaxed_vertices += rep.vertices;
                    stats.relax_seconds += tr.elapsed().as_secs_f64();
                    if sufficient(e, alpha) {
                        stats.relaxed_steps += 1;
                    }
                    tracing::trace!(
                        alpha,
                        vertices = rep.vertices,
                        sweeps = rep.sweeps,
                        rise = e - ev.energy,
                        "relaxed"
                    );
                }
                if sufficient(e, alpha) {
                    accepted = alpha;
                    accepted_energy = e;
                    break;
                }
                alpha *= 0.5;
            }
        }
        stats.line_search_seconds += tl.elapsed().as_secs_f64();
        let report = IterationReport {
            iteration: stats.iterations,
            energy: ev.energy,
            residual_rel: r,
            step: accepted,
            damping: mu,
            load_factor: s,
        };
        history.push(report);
        progress(&report);
        // For the log: the decrease achieved against the quadratic model's at the accepted
        // step length α (with (H + μM)d = −g, dᵀHd = −gᵀd − μdᵀMd, so the model's change is
        // αgᵀd − ½α²(gᵀd + μdᵀMd)): how well the model held along the step. (A step with slack
        // walls solves a system with their terms added, so there the ratio is approximate.)
        let model_ratio = if accepted > 0.0 && tracing::enabled!(tracing::Level::DEBUG) {
            let dd = damping.quadratic(sys.pattern(), &step);
            (accepted_energy - ev.energy) / (accepted * slope - 0.5 * accepted * accepted * (slope + mu * dd))
        } else {
            f64::NAN
        };
        tracing::debug!(
            iteration = report.iteration,
            energy = report.energy,
            residual = r,
            step = accepted,
            model_ratio,
            damping = mu,
            load = s,
            reused,
            "newton"
        );
        if accepted > 0.0 {
            std::mem::swap(&mut x, &mut trial);
            failures = 0;
            mu = if accepted == 1.0 {
                if mu < 1e-9 { 0.0 } else { mu * opts.damping_decrease }
            } else if stats.iterations > CREEP_AFTER {
                // A long creep (see CREEP_AFTER): ×4 only.
                (mu * 4.0).max(1e-8)
            } else {
                // Raised at least in proportion to how far the step had to be shortened: the
                // damping is what bounds the next step along the soft directions (there the
                // damped step is about −(μM)⁻¹g), so a step cut to α asks for a damping 1/α
                // times larger (×4 at least, as for α = ½ or ¼).
                (mu * (1.0 / accepted).max(4.0)).max(1e-8)
            };
        } else {
            tracing::debug!(slope, step_norm = norm(&step), grad_norm = gnorm, residual = r, "line search failed");
            failures += 1;
            mu = (mu * 10.0).max(1e-6);
            // Cut the load back only when even heavily damped steps fail.
            if failures >= 4 && mu >= 1e2 {
                if s - s_ok < 1e-4 {
                    termination = Termination::Stalled(format!("no descent step found at load factor {s:.4}"));
                    break;
                }
                stats.load_cutbacks += 1;
                ds = 0.5 * (s - s_ok);
                s = s_ok + ds;
                x.copy_from_slice(&x_ok);
                failures = 0;
                mu = opts.initial_damping;
            }
        }
    }
    tracing::debug!(?stats, "newton stats");
    finish(&mut stats, &mut factor_times);
    Ok(NewtonResult { positions: x, termination, stats, history, world_gradient: last_world_gradient })
}

/// The statistics' median factorization time, from the successful factorizations' times.
fn finish(stats: &mut SolveStats, factor_times: &mut [f64]) {
    factor_times.sort_by(f64::total_cmp);
    stats.factorization_seconds_median = factor_times.get(factor_times.len() / 2).copied().unwrap_or(0.0);
}

/// The numeric factors, in double and single precision, each kept once allocated (a switch
/// of precision for one step, and back, then reuses both buffers), and which one holds the
/// last successful factorization.
#[derive(Default)]
struct Factors {
    double: Option<CholeskyFactor<f64>>,
    single: Option<CholeskyFactor<f32>>,
    /// Some(true): the single-precision factor is current; Some(false): the double one.
    current: Option<bool>,
}

impl Factors {
    fn is_valid(&self) -> bool {
        match self.current {
            Some(true) => self.single.as_ref().is_some_and(|f| f.is_valid()),
            Some(false) => self.double.as_ref().is_some_and(|f| f.is_valid()),
            None => false,
        }
    }
    /// z ← A⁻¹ z with the current factor.
    ///
    /// # Panics
    /// Without a current factor (callers check [`Factors::is_valid`]).
    fn apply(&self, z: &mut [f64]) {
        match self.current {
            Some(true) => self.single.as_ref().expect("current").solve_in_place(z),
            Some(false) => self.double.as_ref().expect("current").solve_in_place(z),
            None => panic!("no current factor"),
        }
    }
    /// Factor `vals` in the given precision, reusing that precision's buffers.
    fn refactor(
        &mut self,
        chol: &CholeskySolver,
        pattern: &SymmetricPattern,
        vals: &[f64],
        single: bool,
    ) -> Result<(), SolveError> {
        fn into_slot<T: FactorScalar>(
            slot: &mut Option<CholeskyFactor<T>>,
            chol: &CholeskySolver,
            pattern: &SymmetricPattern,
            vals: &[f64],
        ) -> Result<(), SolveError> {
            match slot {
                Some(f) => chol.refactor(pattern, vals, f),
                None => chol.factor_in(pattern, vals).map(|f| *slot = Some(f)),
            }
        }
        self.current = None;
        let res = if single {
            into_slot(&mut self.single, chol, pattern, vals)
        } else {
            into_slot(&mut self.double, chol, pattern, vals)
        };
        if res.is_ok() {
            self.current = Some(single);
        }
        res
    }
}

/// Trial steps of one line search that are relaxed before they are shortened (the first, the
/// full step unless a support limits it, and the second, half as long): measured over 21
/// solves of seven meshes at three heights, relaxing only these took 566 iterations and 18.3 s
/// against 585 and 19.9 s when every trial was relaxed, and the same time on the large meshes.
pub const RELAX_TRIALS: usize = 2;

/// A relaxed vertex is settled once it moves by no more than this fraction of the mean edge
/// length in a sweep (and none of its neighbours does).
pub const RELAX_TOLERANCE: f64 = 1e-3;

/// Below this relative residual the Hessian's geometric term takes the stress exactly (the
/// default of [`crate::material::Material::exact_geometric_below`]); above it, its positive
/// part. Near the equilibrium the projection only slows Newton down. Plain StVK keeps compressed
/// faces at its equilibrium, where the projected term made the tail linear (the built-in example
/// at 0.5 m: relative residual 2·10⁻⁵ after 200 iterations; over 24 solves of eight meshes at
/// 0.3, 0.5 and 1 m, 9 did not converge within 200). With the exact term from 10⁻¹ all 24
/// converged (the example in 55; 10⁻² and 10⁻³ left camelhead at 0.3 m unconverged, and so
/// did the exact term throughout); an indefinite step raises the damping. The tension-field
/// model's stress is positive semi-definite, so its solves are unchanged.
pub const EXACT_TAIL: f64 = 1e-1;

/// Conjugate-gradient iterations allowed with a reused factor before refactoring.
const PCG_MAX_ITER: usize = 4;

/// Preconditioned conjugate gradients on `A x = b` (A in `pattern` with `vals`), preconditioned
/// by a Cholesky factor of a nearby matrix (an earlier Newton step's). Starts from x = 0.
/// Returns the iteration count, or, on negative curvature or no convergence, `Err` with the
/// iterations (matrix products) spent.
fn pcg(
    pattern: &SymmetricPattern,
    vals: &[f64],
    m: &dyn Fn(&mut [f64]),
    b: &[f64],
    tol: f64,
    max_iter: usize,
    x: &mut [f64],
) -> Result<usize, usize> {
    let n = b.len();
    x.iter_mut().for_each(|v| *v = 0.0);
    let mut r = b.to_vec();
    let mut z = r.clone();
    m(&mut z);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut ap = vec![0.0; n];
    for k in 0..max_iter {
        pattern.mul_vec_parallel(vals, &p, &mut ap);
        let pap = dot(&p, &ap);
        if !(pap > 0.0) {
            return Err(k + 1);
        }
        let alpha = rz / pap;
        for i in 0..n {
            x[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
        }
        if norm(&r) <= tol {
            return Ok(k + 1);
        }
        z.copy_from_slice(&r);
        m(&mut z);
        let rz_new = dot(&r, &z);
        let beta = rz_new / rz;
        rz = rz_new;
        for i in 0..n {
            p[i] = z[i] + beta * p[i];
        }
    }
    Err(max_iter)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}
