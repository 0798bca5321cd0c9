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

/// The closed form of a long closed cylinder (polygonal radius `r`) under pressure `p`: the
/// hoop and axial stretches (λθ, λz) where the membrane stresses S_θ = k_θθ E_θ + k_θz E_z and
/// S_z = k_θz E_θ + k_zz E_z balance S_θ = p r λz and S_z = p r λθ²/(2 λz), by Newton from
/// `start` (`iterations` steps).
pub fn pressurised_cylinder_stretches(
    (k_tt, k_tz, k_zz): (f64, f64, f64),
    p: f64,
    r: f64,
    start: (f64, f64),
    iterations: usize,
) -> (f64, f64) {
    let (mut lt, mut lz) = start;
    for _ in 0..iterations {
        let (et, ez) = (0.5 * (lt * lt - 1.0), 0.5 * (lz * lz - 1.0));
        let (st, sz) = (k_tt * et + k_tz * ez, k_tz * et + k_zz * ez);
        let f = [st - p * r * lz, sz - p * r * lt * lt / (2.0 * lz)];
        let j = [
            [k_tt * lt, k_tz * lz - p * r],
            [k_tz * lt - p * r * lt / lz, k_zz * lz + p * r * lt * lt / (2.0 * lz * lz)],
        ];
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        lt -= (f[0] * j[1][1] - f[1] * j[0][1]) / det;
        lz -= (j[0][0] * f[1] - j[1][0] * f[0]) / det;
    }
    (lt, lz)
}

/// Mean of points.
pub fn centroid(p: &[Vec3]) -> Vec3 {
    p.iter().sum::<Vec3>() / p.len() as f64
}

/// The stretches (λθ, λz) of a deformed `shapes::cylinder(rad, len, around, 60, ..)` measured
/// between its rings 24 and 36 (at 40% and 60% of the length, away from the caps): the mean
/// perimeter-based radius of the two rings about their axis over `rad`, and their distance over
/// its rest value.
pub fn measured_cylinder_stretches(positions: &[Vec3], around: usize, rad: f64, len: f64) -> (f64, f64) {
    let ring = |j: usize| -> Vec<Vec3> { (0..around).map(|i| positions[j * around + i]).collect() };
    let (a, b) = (ring(24), ring(36));
    let (ca, cb) = (centroid(&a), centroid(&b));
    let axis = (cb - ca).normalize();
    let radius = |pts: &[Vec3], c: Vec3| {
        pts.iter().map(|x| ((x - c) - axis * axis.dot(&(x - c))).norm()).sum::<f64>() / pts.len() as f64
    };
    (0.5 * (radius(&a, ca) + radius(&b, cb)) / rad, (cb - ca).norm() / (len * 12.0 / 60.0))
}

/// A material as `inner`, with its reference stiffness or the residual below which Newton
/// takes the geometric term exactly set by the test (None: the inner material's).
pub struct Tweaked<M> {
    pub inner: M,
    pub reference_stiffness: Option<f64>,
    pub exact_geometric_below: Option<f64>,
}

impl<M: clothcast_sim::material::Material> clothcast_sim::material::Material for Tweaked<M> {
    fn response(
        &self,
        face: clothcast_mesh::FaceId,
        e: &nalgebra::Vector3<f64>,
    ) -> clothcast_sim::material::MaterialResponse {
        self.inner.response(face, e)
    }
    fn energy(&self, face: clothcast_mesh::FaceId, e: &nalgebra::Vector3<f64>) -> f64 {
        self.inner.energy(face, e)
    }
    fn reference_stiffness(&self) -> f64 {
        self.reference_stiffness.unwrap_or_else(|| self.inner.reference_stiffness())
    }
    fn is_uniform(&self) -> bool {
        self.inner.is_uniform()
    }
    fn exact_geometric_below(&self) -> f64 {
        self.exact_geometric_below.unwrap_or_else(|| self.inner.exact_geometric_below())
    }
    fn slack_wall_stiffness(&self) -> Option<f64> {
        self.inner.slack_wall_stiffness()
    }
}

/// A generated torus (tube radius 0.08 m about a circle of 0.17 m, `around` × `tube`
/// segments) stood up about x (a rotation: the orientation stays outward), 0.5 m tall, its
/// lowest point at 0: the partial fills' test mold.
pub fn upright_torus(around: usize, tube: usize) -> clothcast_mesh::Mesh {
    let mut mesh = clothcast_mesh::shapes::torus(0.17, 0.08, around, tube);
    mesh.set_positions(mesh.positions().map(|q| Vec3::new(q.x, -q.z, q.y + 0.25)));
    mesh
}

/// `mesh` filled to `level` (m) in scenario `sc` (its fill level and iteration limit replaced:
/// 3000), asserted converged.
pub fn partial_fill(
    mesh: &clothcast_mesh::Mesh,
    mat: &dyn clothcast_sim::material::Material,
    level: f64,
    mut sc: clothcast_sim::Scenario,
) -> clothcast_sim::SimResult {
    sc.fill_level = clothcast_sim::FillLevel::Height(level);
    sc.newton.max_iterations = 3000;
    let r = clothcast_sim::simulate(mesh, mat, &sc, &mut |_| {}).unwrap();
    assert!(r.stats.converged, "{:?}: {:?} {:?}", sc.newton, r.stats.termination, r.stats.solver);
    r
}

/// A closed mesh of the test data (`data/meshes/closed/NAME`), scaled to `height` metres along z.
pub fn closed_test_mesh(name: &str, height: f64) -> clothcast_mesh::Mesh {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/closed").join(name);
    let soup = clothcast_mesh::io::read_mesh_file(&path).unwrap();
    let mut mesh = clothcast_mesh::Mesh::try_from_soup(&soup).unwrap();
    let scale = height / mesh.bbox().extent().z;
    mesh.set_positions(mesh.positions().map(|x| x * scale));
    mesh
}
