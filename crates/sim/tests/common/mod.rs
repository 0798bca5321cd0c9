//! Helpers shared by the simulation's integration tests.

use clothcast_sim::newton::IterationReport;

/// Newton never raised the energy from one iteration to the next.
pub fn assert_energy_never_rises(history: &[IterationReport]) {
    for w in history.windows(2) {
        assert!(
            w[1].energy <= w[0].energy + 1e-12 * w[0].energy.abs(),
            "energy rose: {} -> {}",
            w[0].energy,
            w[1].energy
        );
    }
}
