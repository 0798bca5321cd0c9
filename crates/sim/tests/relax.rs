//! The relaxed line search (crate::relax): the same equilibria as plain backtracking, in
//! fewer Newton iterations on a real mesh, with the energy never rising.

use clothcast_mesh::{Mesh, shapes};
use clothcast_sim::material::WrinklingStVenantKirchhoff;
use clothcast_sim::newton::NewtonOptions;
use clothcast_sim::*;

mod common;

fn solve(mesh: &Mesh, sc: &Scenario, relax_sweeps: usize) -> SimResult {
    let mat = WrinklingStVenantKirchhoff::from_young_poisson(5e4, 0.3);
    let sc = Scenario { newton: NewtonOptions { relax_sweeps, ..sc.newton.clone() }, ..sc.clone() };
    let r = simulate(mesh, &mat, &sc, &mut |_| {}).unwrap();
    assert!(r.stats.converged, "{:?}", r.stats.termination);
    common::assert_energy_never_rises(&r.history);
    r
}

/// The Stanford bunny hung from its top band and filled (wrinkled ears and flanks): the
/// relaxed line search repairs trial steps (most of the steps it relaxes are then accepted),
/// takes fewer Newton iterations than plain backtracking (measured 33 → 25; at 0.4 m 35 → 28,
/// at 0.7 m 27 → 20), and ends at an equilibrium of the same energy and shape.
#[test]
fn relaxed_line_search_on_the_bunny() {
    let mesh = common::closed_test_mesh("bunny.obj", 0.5);
    let sc = Scenario::default();
    let (plain, relaxed) = (solve(&mesh, &sc, 0), solve(&mesh, &sc, 10));
    let (p, r) = (&plain.stats.solver, &relaxed.stats.solver);
    assert_eq!(p.relaxations, 0);
    assert!(r.relaxations > 0 && 2 * r.relaxed_steps >= r.relaxations, "{r:?}");
    assert!(
        relaxed.stats.newton_iterations + 4 <= plain.stats.newton_iterations,
        "{} iterations relaxed, {} plain",
        relaxed.stats.newton_iterations,
        plain.stats.newton_iterations
    );
    let last = |s: &SimResult| s.history.last().expect("iterations").energy;
    assert!(
        (last(&plain) - last(&relaxed)).abs() <= 1e-6 * last(&plain).abs(),
        "{} vs {}",
        last(&plain),
        last(&relaxed)
    );
    let gap = plain.positions.iter().zip(relaxed.positions.iter()).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    assert!(gap <= 1e-3 * plain.stats.max_displacement_m, "equilibria {gap} m apart");
}

/// A taut mold (a free sphere inflated by a head pressure, whose equilibrium is unique): the
/// relaxed and the plain line search end at the same equilibrium, to round-off.
#[test]
fn taut_molds_reach_the_same_equilibrium() {
    let mesh = shapes::icosphere(3, 0.2);
    let sc =
        Scenario { infill_density: 0.0, head_pressure: 2000.0, suspension: Suspension::None, ..Default::default() };
    let (r, p) = (solve(&mesh, &sc, 10), solve(&mesh, &sc, 0));
    // The first steps from the stress-free sphere overshoot (it has no stiffness out of its
    // surface yet): relaxations happen even here.
    assert!(r.stats.solver.relaxations > 0, "{:?}", r.stats.solver);
    let gap = r.positions.iter().zip(p.positions.iter()).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    assert!(gap <= 1e-9 * p.stats.max_displacement_m, "equilibria {gap} m apart");
}
