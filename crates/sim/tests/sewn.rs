//! A sewn mold: every face's rest shape given as a triangle on a pattern (its +u the warp),
//! simulated with the woven fabric (`simulate_sewn`, `WovenFabric`).

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

fn centroid(p: &[Vec3]) -> Vec3 {
    p.iter().sum::<Vec3>() / p.len() as f64
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
        let kc = 0.0;
        let (mut lt, mut lz) = (1.05f64, 1.01f64);
        for _ in 0..60 {
            let (et, ez) = (0.5 * (lt * lt - 1.0), 0.5 * (lz * lz - 1.0));
            let (st, sz) = (kt * et + kc * ez, kc * et + kz * ez);
            let f = [st - p * r_poly * lz, sz - p * r_poly * lt * lt / (2.0 * lz)];
            let j = [
                [kt * lt, kc * lz - p * r_poly],
                [kc * lt - p * r_poly * lt / lz, kz * lz + p * r_poly * lt * lt / (2.0 * lz * lz)],
            ];
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            lt -= (f[0] * j[1][1] - f[1] * j[0][1]) / det;
            lz -= (j[0][0] * f[1] - j[1][0] * f[0]) / det;
        }
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
        let ring = |j: usize| -> Vec<Vec3> { (0..n).map(|i| r.positions[VertexId::new(j * n + i)]).collect() };
        let (a, b) = (ring(24), ring(36));
        let (ca, cb) = (centroid(&a), centroid(&b));
        let axis = (cb - ca).normalize();
        let measured_lz = (cb - ca).norm() / (len * 12.0 / 60.0);
        let radius = |pts: &[Vec3], c: Vec3| {
            pts.iter().map(|x| ((x - c) - axis * axis.dot(&(x - c))).norm()).sum::<f64>() / pts.len() as f64
        };
        let measured_lt = 0.5 * (radius(&a, ca) + radius(&b, cb)) / rad;
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
    let x: Vec<Vec3> =
        mesh.positions().iter().map(|p| Vec3::new(p.x * 1.1, p.y * 0.95 + 0.02 * p.z, p.z * 1.05)).collect();
    let ev = sys.evaluate(&x, 0.8, true);
    let mut shares = Vec::new();
    let total = sys.energy_faces(&x, 0.8, Some(&mut shares));
    assert!((total - ev.energy).abs() < 1e-9 * ev.energy_magnitude, "{total} vs {}", ev.energy);
    let h = ev.hessian.clone().unwrap();
    let n = sys.n_dofs();
    let eps = 1e-6;
    let mut xp = vec![Vec3::zeros(); x.len()];
    for i in (0..n).step_by(5) {
        let mut d = vec![0.0; n];
        d[i] = 1.0;
        sys.apply_step(&x, &d, eps, &mut xp);
        let ep = sys.evaluate(&xp, 0.8, false);
        sys.apply_step(&x, &d, -eps, &mut xp);
        let em = sys.evaluate(&xp, 0.8, false);
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

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
    /// For any fabric (stiffening or softening yarns) and any strain away from the kinks (a yarn
    /// at zero strain, or at the stretch 7/6 where its stiffness stops rising): the stress is
    /// the energy's gradient, the tangent the stress's, the tangent is PSD, and the energy is
    /// never negative.
    #[test]
    fn woven_fabric_stress_and_tangent_are_the_energy_derivatives(
        warp in 1.0e2f64..1.0e5,
        weft in 1.0e2f64..1.0e5,
        rise in 0.5f64..2.0,
        shear in 1.0f64..1.0e4,
        e0 in -0.2f64..0.5,
        e1 in -0.2f64..0.5,
        g in -0.5f64..0.5,
    ) {
        use clothcast_sim::Material;
        let kink = 0.5 * ((7.0f64 / 6.0).powi(2) - 1.0);
        proptest::prop_assume!(e0.abs() > 1e-4 && e1.abs() > 1e-4 && (e0 - kink).abs() > 1e-4 && (e1 - kink).abs() > 1e-4);
        let m = WovenFabric::stiffening(warp, weft, warp * rise, weft * rise, shear).unwrap();
        let f = clothcast_mesh::FaceId::new(0);
        let e = nalgebra::Vector3::new(e0, e1, g);
        let r = m.response(f, &e);
        proptest::prop_assert!(r.energy >= 0.0);
        proptest::prop_assert!(r.tangent.symmetric_eigenvalues().min() >= 0.0);
        let h = 1e-7;
        for j in 0..3 {
            let (mut ep, mut em) = (e, e);
            ep[j] += h;
            em[j] -= h;
            let ds = (m.energy(f, &ep) - m.energy(f, &em)) / (2.0 * h);
            proptest::prop_assert!((ds - r.stress[j]).abs() < 1e-5 * (1.0 + r.stress[j].abs()), "dW/dE{}: {} vs {}", j, ds, r.stress[j]);
            // A softening yarn's tangent is floored at zero: compare where it is not.
            if r.tangent[(j, j)] > 0.0 {
                let dc = (m.response(f, &ep).stress[j] - m.response(f, &em).stress[j]) / (2.0 * h);
                proptest::prop_assert!((dc - r.tangent[(j, j)]).abs() < 1e-4 * (1.0 + dc.abs()), "C{}{}: {} vs {}", j, j, dc, r.tangent[(j, j)]);
            }
        }
    }
}
