//! Helpers shared by the simulation's integration tests.
#![allow(dead_code)] // each test file uses its own subset

use clothcast_mesh::Vec3;
use clothcast_sim::newton::IterationReport;
use clothcast_sim::system::System;

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

/// The assembled gradient and Hessian of `sys` at `x` (load factor `s`) against central
/// differences of its energy and gradient (step 10⁻⁶), along every `stride`-th free dof.
pub fn assert_assembled_derivatives(sys: &mut System<'_>, x: &[Vec3], s: f64, stride: usize) {
    let ev = sys.evaluate(x, s, true);
    let h = ev.hessian.clone().unwrap();
    let n = sys.n_dofs();
    let eps = 1e-6;
    let mut xp = vec![Vec3::zeros(); x.len()];
    for i in (0..n).step_by(stride) {
        let mut d = vec![0.0; n];
        d[i] = 1.0;
        sys.apply_step(x, &d, eps, &mut xp);
        let ep = sys.evaluate(&xp, s, false);
        sys.apply_step(x, &d, -eps, &mut xp);
        let em = sys.evaluate(&xp, s, false);
        let fd = (ep.energy - em.energy) / (2.0 * eps);
        assert!(
            (fd - ev.gradient[i]).abs() < 1e-5 * (1.0 + ev.gradient[i].abs()),
            "grad {i}: {fd} vs {}",
            ev.gradient[i]
        );
        let mut col = vec![0.0; n];
        sys.pattern().mul_vec(&h, &d, &mut col);
        for j in 0..n {
            let fdh = (ep.gradient[j] - em.gradient[j]) / (2.0 * eps);
            assert!((fdh - col[j]).abs() < 1e-4 * (1.0 + col[j].abs()), "hess ({j},{i}): {fdh} vs {}", col[j]);
        }
    }
}
