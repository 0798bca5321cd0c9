//! # clothcast-sim
//!
//! The first stage of the pipeline (paper §3): the equilibrium shape of the fabric mold when it
//! hangs from its clamps and is filled with liquid, solved **statically** by Newton's method on
//! the total potential (the paper used a dynamic backward-Euler solver and names a static one as
//! future work).
//!
//! - [`material`]: the `Material` trait and the isotropic St. Venant–Kirchhoff membrane
//!   (Young's modulus Y in N/m, Poisson ratio ν; the paper's Eq. 2), its tension-field
//!   relaxation, and the woven fabric of the check (warp, weft, shear; paper §7.4).
//! - [`element`]: constant-strain triangles; each target triangle flattened isometrically is its
//!   own rest shape, or a sewn mold's triangle on its pattern piece; PSD-projected Hessians.
//! - [`hydrostatic`]: the infill pressure as a conservative potential, exact for faces crossing
//!   the fill level.
//! - [`loads`]: head pressure, self weight, support planes (log-barrier contact).
//! - [`constraints`]: clamps and sliding constraints as per-vertex frames.
//! - [`system`], [`newton`]: assembly with a fixed sparse pattern and the Newton solver with a
//!   reused symbolic Cholesky factorization.
//! - [`walls`]: the slack faces a creeping Newton step runs into, in the next step's model.
//! - [`relax`]: nonlinear block Gauss–Seidel on the vertices a Newton step sent too far.
//! - [`coarse`]: the coarse start (the equilibrium of a simplified mold as the fine solve's
//!   starting point).
//! - [`scenario`]: the one-shot [`simulate`] with suspension modes and precondition checks, and
//!   [`simulate_sewn`] for a mold sewn from patterns.
//!
//! ```
//! use clothcast_mesh::shapes;
//! use clothcast_sim::{material::StVenantKirchhoff, scenario::*};
//! let mesh = shapes::icosphere(2, 0.2);
//! let sc = Scenario { infill_density: 0.0, head_pressure: 500.0, suspension: Suspension::None, ..Default::default() };
//! let mat = StVenantKirchhoff::from_young_poisson(5.0e4, 0.3);
//! let r = simulate(&mesh, &mat, &sc, &mut |_| {}).unwrap();
//! assert!(r.stats.converged && r.stats.residual_rel <= 1e-8);
//! ```

pub mod coarse;
pub mod constraints;
pub mod element;
pub mod hydrostatic;
pub mod loads;
pub mod material;
pub mod newton;
mod precision;
pub mod relax;
pub mod scenario;
pub mod system;
pub mod walls;

pub use material::{Material, StVenantKirchhoff, WovenFabric};
pub use scenario::{
    BehindWhy, CONTINUATION_RATIO, CONTINUATION_START, FillLevel, ResidualSite, Scenario, SimError, SimResult,
    SimStats, StiffnessStage, Suspension, simulate, simulate_sewn, stiffness_stages,
};
