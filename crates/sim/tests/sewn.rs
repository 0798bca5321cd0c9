//! A sewn mold: every face's rest shape given as a triangle on a pattern (its +u the warp),
//! simulated with the woven fabric (`simulate_sewn`, `WovenFabric`).

mod common;
use common::centroid;

use clothcast_mesh::{FaceData, Mesh, Vec3, VertexId, shapes};
use clothcast_sim::material::{StVenantKirchhoff, WovenFabric};
use clothcast_sim::*;
use nalgebra::Vector2;

/// Each face flattened isometrically, its +u along `warp(face centre, normal)` projected into
/// the face's plane.
fn patterns(mesh: &Mesh, warp: impl Fn(Vec3, Vec3) -> Vec3) -> FaceData<[Vector2<f64>; 3]> {
    mesh.face_ids()
        .map(|f| {
            let p = mesh.face_positions(f);
            let n = (p[1] - p[0]).cross(&(p[2] - p[0])).normalize();
            let c = (p[0] + p[1] + p[2]) / 3.0;
            let w = warp(c, n);
            let u = (w - n * n.dot(&w)).normalize();
            let v = n.cross(&u);
            p.map(|x| Vector2::new((x - p[0]).dot(&u), (x - p[0]).dot(&v)))
        })
        .collect()
}

/// A woven fabric whose yarns and shear equal an isotropic StVK's with ν = 0 (k = Y, G = Y/2)
/// behaves like it wherever both yarns are stretched: an inflated sphere, its pattern triangles
/// turned every which way, comes out as the isotropic one.
#[test]
fn isotropic_equivalent_weave_matches_stvk_on_an_inflated_sphere() {
    let mesh = shapes::icosphere(3, 0.2);
    let iso = StVenantKirchhoff::from_young_poisson(5.0e4, 0.0);
    let woven = WovenFabric::new(5.0e4, 5.0e4, 2.5e4).unwrap();
    let sc = Scenario { infill_density: 0.0, head_pressure: 6.0e4, suspension: Suspension::None, ..Default::default() };
    let a = simulate(&mesh, &iso, &sc, &mut |_| {}).unwrap();
    // Warp directions that vary from face to face (a swirl about a tilted axis).
    let axis = Vec3::new(0.3, -0.5, 0.8).normalize();
    let rest = patterns(&mesh, |c, n| axis.cross(&c) + n.cross(&c) * 3.0 + Vec3::new(1.0, 0.2, 0.1));
    let b = simulate_sewn(&mesh, &rest, &[], None, &woven, &sc, &mut |_| {}).unwrap();
    assert!(a.stats.converged && b.stats.converged);
    let (ca, cb) = (centroid(a.positions.as_slice()), centroid(b.positions.as_slice()));
    let worst =
        a.positions.iter().zip(b.positions.iter()).map(|(x, y)| ((x - ca) - (y - cb)).norm()).fold(0.0, f64::max);
    assert!(worst < 1e-6 * 0.2, "largest difference {worst} m");
    // Stretched noticeably, so the comparison means something.
    assert!(a.stats.mean_displacement_m > 0.02, "{}", a.stats.mean_displacement_m);
}

/// A long closed cylinder of woven fabric under pressure, warp around it or along it: the
/// middle section's hoop and axial stretches against the closed form (S_θ = pRλ_z,
/// S_z = pRλ_θ²/(2λ_z), with S_θ = k_θ E_θ, S_z = k_z E_z).
#[test]
fn woven_cylinder_matches_closed_form_for_either_warp_direction() {
    let (rad, len, n) = (0.05, 0.6, 48);
    let mesh = shapes::cylinder(rad, len, n, 60, true, true);
    let r_poly = rad * (std::f64::consts::PI / n as f64).sin() / (std::f64::consts::PI / n as f64);
    let p = 2000.0;
    let fabric = WovenFabric::new(6.0e4, 2.0e4, 1.0e3).unwrap();
    let sc = Scenario { infill_density: 0.0, head_pressure: p, suspension: Suspension::None, ..Default::default() };
    let mut hoop = Vec::new();
    for warp_around in [true, false] {
        let (kt, kz) = if warp_around { (fabric.warp, fabric.weft) } else { (fabric.weft, fabric.warp) };
        // No warp–weft coupling.
        let (lt, lz) = common::pressurised_cylinder_stretches((kt, 0.0, kz), p, r_poly, (1.05, 1.01), 60);
        let rest = patterns(&mesh, |c, nrm| {
            let around = Vec3::z().cross(&Vec3::new(c.x, c.y, 0.0));
            // Cap faces (normal along the axis): one warp direction for the whole flat cap, as on
            // a cut piece; the side's warp around or along.
            if nrm.z.abs() > 0.9 {
                Vec3::x()
            } else if warp_around {
                around
            } else {
                Vec3::z()
            }
        });
        let r = simulate_sewn(&mesh, &rest, &[], None, &fabric, &sc, &mut |_| {}).unwrap();
        assert!(r.stats.converged, "{:?}", r.stats.termination);
        let (measured_lt, measured_lz) = common::measured_cylinder_stretches(r.positions.as_slice(), n, rad, len);
        assert!((measured_lt - lt).abs() / lt < 0.005, "warp around {warp_around}: hoop {measured_lt} vs {lt}");
        assert!((measured_lz - lz).abs() / lz < 0.005, "warp around {warp_around}: axial {measured_lz} vs {lz}");
        hoop.push(measured_lt);
    }
    // The stiff yarn around the cylinder holds it narrower (3× stiffer, about a third the strain).
    assert!(hoop[1] - 1.0 > 2.0 * (hoop[0] - 1.0), "{hoop:?}");
}

/// A folded pattern triangle is refused, naming the face.
#[test]
fn folded_pattern_triangle_is_refused() {
    let mesh = shapes::icosphere(1, 0.2);
    let mut rest = patterns(&mesh, |_, _| Vec3::x());
    rest[clothcast_mesh::FaceId::new(7)].swap(1, 2);
    let fabric = WovenFabric::new(5.0e4, 5.0e4, 1.0e3).unwrap();
    let sc = Scenario { infill_density: 0.0, head_pressure: 100.0, suspension: Suspension::None, ..Default::default() };
    let Err(e) = simulate_sewn(&mesh, &rest, &[], None, &fabric, &sc, &mut |_| {}) else {
        panic!("a folded triangle was accepted")
    };
    assert!(matches!(e, SimError::FoldedRest { face } if face.idx() == 7), "{e}");
    assert!(e.to_string().contains("face 7"));
}

/// The assembled system of a sewn mold (pattern triangles, woven fabric, seam bars, liquid)
/// against finite differences of its energy and gradient; the energy's per-face shares add up
/// to it.
#[test]
fn sewn_system_matches_finite_differences() {
    use clothcast_sim::constraints::Constraints;
    use clothcast_sim::element::{Bar, Element};
    use clothcast_sim::hydrostatic::Hydrostatic;
    use clothcast_sim::system::{Loads, System};
    let mesh = shapes::icosphere(1, 0.3);
    let rest = patterns(&mesh, |c, _| Vec3::new(1.0, 0.3, 0.0) + c);
    let elements: Vec<Element> = mesh.face_ids().map(|f| Element::from_plane(&rest[f]).unwrap()).collect();
    let fabric = WovenFabric::stiffening(5.0e4, 2.0e4, 6.0e4, 2.5e4, 1.0e3).unwrap();
    let loads = Loads {
        hydrostatic: Some(Hydrostatic { rho_g: 14000.0, up: Vec3::z(), fill_height: 0.05 }),
        head_pressure: 300.0,
        self_weight: None,
    };
    let mut c = Constraints::free(mesh.n_vertices());
    c.fix_vertex(VertexId(0));
    let mut sys = System::with_elements(&mesh, elements, &fabric, loads, &c, vec![], None);
    // Bars on the first edge of every third face, some stretched, some compressed below.
    let bars: Vec<[Bar; 3]> = mesh
        .face_ids()
        .map(|f| {
            let mut b = [Bar::default(); 3];
            if f.idx() % 3 == 0 {
                let l = (rest[f][1] - rest[f][0]).norm();
                b[0] = Bar { stiffness: 1500.0, rest: l * (0.97 + 0.01 * (f.idx() % 7) as f64), compression: 0.01 };
            }
            b
        })
        .collect();
    sys.set_bars(bars);
    // The exact Hessian (the one Newton takes near the equilibrium; far from it the geometric
    // term is at the stress's positive part).
    sys.set_exact_geometric(true);
    let x: Vec<Vec3> =
        mesh.positions().iter().map(|p| Vec3::new(p.x * 1.1, p.y * 0.95 + 0.02 * p.z, p.z * 1.05)).collect();
    // The per-face shares (what the line search sums) add up to the assembled energy.
    let ev = sys.evaluate(&x, 0.8, false);
    let total = sys.energy_faces(&x, 0.8, None);
    assert!((total - ev.energy).abs() < 1e-9 * ev.energy_magnitude, "{total} vs {}", ev.energy);
    common::assert_assembled_derivatives(&mut sys, &x, 0.8, 5);
}

/// The woven fabric's compressed yarns make the Hessian indefinite at many steps, as in the
/// check's solve; here a torus whose pattern triangles are 5% longer along the warp (excess
/// fabric that the yarns buckle under). A single-precision failure is confirmed by a
/// double-precision factorization of the same matrix only until
/// [`clothcast_sim::newton::SINGLE_TRUST_AFTER`] confirmations; later ones raise the damping at
/// once, but for one in [`clothcast_sim::newton::SINGLE_RECHECK_EVERY`], confirmed again. The
/// damping path is the double-precision solve's, with as many factorizations more as there
/// were confirmations. (The geometric term is taken exactly throughout, for the
/// indefinite steps: with the check's default, projected down to a relative residual of
/// 3·10⁻², this torus has one.)
#[test]
fn indefinite_woven_steps_trust_single_precision_after_confirmations() {
    use clothcast_sim::newton::{FactorPrecision, NewtonOptions, SINGLE_RECHECK_EVERY, SINGLE_TRUST_AFTER};
    let mesh = common::closed_test_mesh("torus.obj", 0.5);
    let fabric = common::Tweaked {
        inner: WovenFabric::new(6.0e4, 2.0e4, 1.0e3).unwrap(),
        reference_stiffness: None,
        exact_geometric_below: Some(f64::INFINITY),
    };
    let rest: FaceData<[Vector2<f64>; 3]> = patterns(&mesh, |c, _| Vec3::z() + Vec3::new(c.y, -c.x, 0.0) * 4.0)
        .iter()
        .map(|t| t.map(|q| Vector2::new(q.x * 1.05, q.y)))
        .collect();
    let run = |factor_precision| {
        let sc = Scenario { newton: NewtonOptions { factor_precision, ..Default::default() }, ..Default::default() };
        let r = simulate_sewn(&mesh, &rest, &[], None, &fabric, &sc, &mut |_| {}).unwrap();
        assert!(r.stats.converged, "{factor_precision:?}: {:?}", r.stats.termination);
        r
    };
    let (d, s) = (run(FactorPrecision::Double), run(FactorPrecision::Single));
    let st = &s.stats.solver;
    // Indefinite steps after the confirmations, taken as such at once but for one in
    // SINGLE_RECHECK_EVERY, confirmed again (indefinite: the trust stays).
    assert!(st.single_indefinite_unconfirmed >= SINGLE_RECHECK_EVERY, "{st:?}");
    let rechecks = st.single_fallbacks_indefinite - SINGLE_TRUST_AFTER;
    assert!(rechecks >= 1 && rechecks <= st.single_indefinite_unconfirmed / (SINGLE_RECHECK_EVERY - 1), "{st:?}");
    assert_eq!(st.single_fallbacks, st.single_fallbacks_indefinite, "{st:?}");
    assert_eq!(st.double_factorizations, st.single_fallbacks_indefinite, "{st:?}");
    assert_eq!(st.factorizations, d.stats.solver.factorizations + st.single_fallbacks_indefinite);
    assert_eq!(d.stats.newton_iterations, s.stats.newton_iterations);
    for (a, b) in d.history.iter().zip(&s.history) {
        assert_eq!((a.damping, a.step), (b.damping, b.step));
    }
}
