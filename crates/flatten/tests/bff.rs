//! BFF on flat, developable, spherical and real patches (issue: flattening core).
//!
//! Closed-form expectations: a flat patch is reproduced up to a rigid motion; a developable
//! (cylinder) patch is flattened isometrically; a spherical cap of angular radius α flattened
//! with zero boundary scale factors is the disk of radius sin α, so its area ratio is
//! (1 + cos α)/2 = cos²(α/2) (the conformal map is a scaled stereographic projection).

use clothcast_flatten::{BffOptions, FlattenError, Flattening, bff_flatten, distortion};
use clothcast_mesh::io::read_mesh_file;
use clothcast_mesh::submesh::extract_submesh;
use clothcast_mesh::util::SplitMix64;
use clothcast_mesh::{FaceId, Mesh, Vec2, Vec3, VertexData, shapes};
use nalgebra::Rotation3;
use proptest::prelude::*;
use std::collections::VecDeque;
use std::path::PathBuf;

fn data(rel: &str) -> Mesh {
    let p = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/meshes")).join(rel);
    Mesh::try_from_soup(&read_mesh_file(&p).unwrap()).unwrap()
}

fn flatten(m: &Mesh) -> Flattening {
    bff_flatten(m, &BffOptions::default()).unwrap()
}

/// The patch of the given faces if it is a disk.
fn disk(m: &Mesh, faces: &[FaceId]) -> Option<Mesh> {
    let s = extract_submesh(m, faces).ok()?;
    (s.mesh.euler_characteristic() == 1 && s.mesh.boundary_loops().len() == 1 && s.mesh.n_components() == 1)
        .then_some(s.mesh)
}

/// Breadth-first growth of `size` faces from a seed face.
fn bfs_patch(m: &Mesh, seed: FaceId, size: usize) -> Vec<FaceId> {
    let mut inside = vec![false; m.n_faces()];
    let mut queue = VecDeque::from([seed]);
    inside[seed.idx()] = true;
    let mut out = Vec::new();
    while let Some(f) = queue.pop_front() {
        if out.len() == size {
            break;
        }
        out.push(f);
        for k in 0..3 {
            if let Some(g) = m.face_neighbor(f, k)
                && !inside[g.idx()]
            {
                inside[g.idx()] = true;
                queue.push_back(g);
            }
        }
    }
    out
}

/// Random growth that keeps the patch a disk: a frontier face is added only if it shares one
/// edge with the patch and brings a new vertex (a new ear), or shares two edges (fills a
/// notch); both keep χ = 1 and a single boundary. Boundaries come out jagged.
fn random_disk(m: &Mesh, size: usize, rng: &mut SplitMix64) -> Vec<FaceId> {
    let start = FaceId::new(rng.below(m.n_faces()));
    let mut in_face = vec![false; m.n_faces()];
    let mut in_vertex = vec![false; m.n_vertices()];
    let mut out = vec![start];
    in_face[start.idx()] = true;
    m.face_vertices(start).iter().for_each(|v| in_vertex[v.idx()] = true);
    let mut stalled = 0;
    while out.len() < size && stalled < 200 {
        // A random face of the patch, a random neighbour of it.
        let f = out[rng.below(out.len())];
        let Some(g) = m.face_neighbor(f, rng.below(3)) else {
            stalled += 1;
            continue;
        };
        if in_face[g.idx()] {
            stalled += 1;
            continue;
        }
        let shared = (0..3).filter(|&k| m.face_neighbor(g, k).is_some_and(|n| in_face[n.idx()])).count();
        let new_vertex = m.face_vertices(g).iter().any(|v| !in_vertex[v.idx()]);
        if (shared == 1 && new_vertex) || shared == 2 {
            in_face[g.idx()] = true;
            m.face_vertices(g).iter().for_each(|v| in_vertex[v.idx()] = true);
            out.push(g);
            stalled = 0;
        } else {
            stalled += 1;
        }
    }
    out
}

/// Max distance between `uv` and the xy of `target` after the best rigid (proper) 2D motion.
fn rigid_error(uv: &VertexData<Vec2>, target: &[Vec2]) -> f64 {
    let n = target.len() as f64;
    let ca = uv.iter().sum::<Vec2>() / n;
    let cb = target.iter().sum::<Vec2>() / n;
    let (mut s, mut c) = (0.0, 0.0);
    for (a, b) in uv.iter().zip(target) {
        let (a, b) = (a - ca, b - cb);
        s += a.x * b.y - a.y * b.x;
        c += a.x * b.x + a.y * b.y;
    }
    let t = s.atan2(c);
    let rot = nalgebra::Rotation2::new(t);
    uv.iter().zip(target).map(|(a, b)| (rot * (a - ca) - (b - cb)).norm()).fold(0.0, f64::max)
}

fn max_edge_error_rel(m: &Mesh, uv: &VertexData<Vec2>) -> f64 {
    m.edges()
        .map(|e| {
            let [a, b] = m.edge_vertices(e);
            let l = m.edge_length(e);
            ((uv[a] - uv[b]).norm() - l).abs() / l
        })
        .fold(0.0, f64::max)
}

fn signed_area(m: &Mesh, uv: &VertexData<Vec2>) -> f64 {
    m.face_ids()
        .map(|f| {
            let q = m.face_vertices(f).map(|v| uv[v]);
            let (d1, d2) = (q[1] - q[0], q[2] - q[0]);
            0.5 * (d1.x * d2.y - d1.y * d2.x)
        })
        .sum()
}

/// Flat patches (a regular grid, the same jittered in its plane, a round sub-disk of it, all
/// rigidly moved into 3D) are reproduced up to a rigid motion.
#[test]
fn flat_disk_is_reproduced() {
    let grid = shapes::grid(24, 18, 2.0, 1.5);
    let mut rng = SplitMix64::new(7);
    let mut jittered = grid.clone();
    let h = grid.mean_edge_length();
    let p = grid.positions().map(|x| {
        let on_boundary = x.x == 0.0 || x.y == 0.0 || (x.x - 2.0).abs() < 1e-12 || (x.y - 1.5).abs() < 1e-12;
        if on_boundary { *x } else { x + Vec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, 0.0) * (0.5 * h) }
    });
    jittered.set_positions(p);
    let round: Vec<FaceId> =
        grid.face_ids().filter(|&f| (grid.face_centroid(f) - Vec3::new(1.0, 0.75, 0.0)).norm() < 0.7).collect();
    let round = disk(&grid, &round).expect("round sub-disk");
    let motion = Rotation3::from_euler_angles(0.3, -1.1, 2.0);
    for (name, flat) in [("grid", grid), ("jittered", jittered), ("round", round)] {
        let target: Vec<Vec2> = flat.positions().iter().map(|x| Vec2::new(x.x, x.y)).collect();
        let mut m = flat.clone();
        m.set_positions(flat.positions().map(|x| motion * x + Vec3::new(0.1, 0.2, -0.3)));
        let fl = flatten(&m);
        let size = m.bbox().extent().norm();
        let err = rigid_error(&fl.uv, &target) / size;
        let s = &fl.stats;
        println!("{name}: rigid error {err:.2e}, {s:?}");
        assert!(err < 1e-6, "{name}: {err}");
        assert_eq!(s.flipped_triangles, 0, "{name}");
        assert!((s.qc_mean - 1.0).abs() < 1e-6 && (s.qc_max - 1.0).abs() < 1e-5, "{name}: {s:?}");
        assert!((s.area_ratio - 1.0).abs() < 1e-6, "{name}: {s:?}");
        assert!(s.boundary_length_error_max_rel < 1e-6, "{name}: {s:?}");
    }
}

/// A sector of an open cylinder (developable) is flattened isometrically.
#[test]
fn cylinder_patch_is_isometric() {
    let (n_around, n_up) = (32, 12);
    let cyl = shapes::cylinder(0.5, 1.5, n_around, n_up, false, false);
    // Faces are 2 per quad, quads ordered row by row; keep the columns 0..20 (a 225° sector).
    let faces: Vec<FaceId> = cyl.face_ids().filter(|f| (f.idx() / 2) % n_around < 20).collect();
    let m = disk(&cyl, &faces).expect("sector is a disk");
    let fl = flatten(&m);
    let s = &fl.stats;
    let edge_err = max_edge_error_rel(&m, &fl.uv);
    println!("cylinder sector: edge error {edge_err:.2e}, {s:?}");
    assert!(edge_err < 1e-6, "{edge_err}");
    assert_eq!(s.flipped_triangles, 0);
    assert!((s.area_ratio - 1.0).abs() < 1e-6 && (s.area_ratio_min - 1.0).abs() < 1e-5, "{s:?}");
    assert!((s.qc_mean - 1.0).abs() < 1e-6 && (s.qc_max - 1.0).abs() < 1e-5, "{s:?}");
    // Unrolled: the rectangle of width 20 chords and height 1.5.
    let ext = |k: usize| {
        fl.uv.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max)
            - fl.uv.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min)
    };
    let chord = 2.0 * 0.5 * (std::f64::consts::PI / n_around as f64).sin();
    let (w, h) = (ext(0).max(ext(1)), ext(0).min(ext(1)));
    assert!((w - 20.0 * chord).abs() < 1e-6 && (h - 1.5).abs() < 1e-6, "{w} × {h}");
}

/// Spherical caps (faces with centroid z > 0.5 of unit icospheres, α ≈ 60°): no flips, boundary
/// lengths kept, and the area ratio converging to the closed form (1 + cos α)/2 (first order in
/// the edge length: the jagged boundary is longer than the circle), the centre's ratio to
/// cos⁴(α/2), the quasi-conformal ratio to 1.
#[test]
fn spherical_cap() {
    let mut prev_err = f64::INFINITY;
    for level in [4, 5, 6] {
        let sphere = shapes::icosphere(level, 1.0);
        let faces: Vec<FaceId> = sphere.face_ids().filter(|&f| sphere.face_centroid(f).z > 0.5).collect();
        let m = disk(&sphere, &faces).expect("cap is a disk");
        let fl = flatten(&m);
        let s = &fl.stats;
        // Equivalent angular radius from the mean height of the boundary vertices.
        let lp = &m.boundary_loops()[0];
        let cos_a = lp.iter().map(|&h| m.position(m.tail(h)).z).sum::<f64>() / lp.len() as f64;
        let expected = (1.0 + cos_a) / 2.0;
        let err = (s.area_ratio / expected - 1.0).abs();
        let centre_err = (s.area_ratio_min / (expected * expected) - 1.0).abs();
        println!(
            "cap level {level}: {} faces, area ratio {:.5} (closed form {expected:.5}, rel. error {err:.2e}), \
             centre {:.5} (closed form {:.5}), {s:?}",
            m.n_faces(),
            s.area_ratio,
            s.area_ratio_min,
            expected * expected
        );
        assert_eq!(s.flipped_triangles, 0);
        assert!(signed_area(&m, &fl.uv) > 0.0);
        assert!(err < 0.03 && err < 0.7 * prev_err, "level {level}: {err} (previous {prev_err})");
        assert!(centre_err < 0.03, "level {level}: {centre_err}");
        assert!(s.qc_mean < 1.02 && s.qc_max < 1.05, "{s:?}");
        assert!(s.boundary_length_error_max_rel < 1e-6, "{s:?}");
        // Every boundary edge is within the reported error (the statistic is the max).
        for e in m.edges().filter(|&e| m.is_boundary_edge(e)) {
            let [a, b] = m.edge_vertices(e);
            let rel = ((fl.uv[a] - fl.uv[b]).norm() - m.edge_length(e)).abs() / m.edge_length(e);
            assert!(rel <= s.boundary_length_error_max_rel + 1e-15);
        }
        // The statistics of the returned layout are those of `distortion`.
        let again = distortion(&m, &fl.uv);
        assert_eq!(again.flipped_triangles, s.flipped_triangles);
        assert_eq!(again.qc_mean, s.qc_mean);
        prev_err = err;
    }
    assert!(prev_err < 0.006, "{prev_err}");
}

/// Breadth-first disks of a few hundred faces on scanned meshes: no flips, positive
/// orientation.
#[test]
fn real_patches() {
    for (name, file) in [("bunny", "closed/bunny.obj"), ("fertility", "closed/fertility.off")] {
        let m = data(file);
        let mut accepted = 0;
        let (mut worst_qc, mut worst_len) = (0.0f64, 0.0f64);
        for k in 0..12 {
            let seed = FaceId::new(k * m.n_faces() / 12 + 5);
            let size = 150 + 50 * (k % 6);
            let Some(p) = disk(&m, &bfs_patch(&m, seed, size)) else { continue };
            let fl = flatten(&p);
            let s = &fl.stats;
            assert_eq!(s.flipped_triangles, 0, "{name} seed {seed:?}: {s:?}");
            assert!(signed_area(&p, &fl.uv) > 0.0);
            assert!(s.area_ratio_min > 0.0 && s.qc_max.is_finite(), "{name} seed {seed:?}: {s:?}");
            println!(
                "{name} seed {seed:?}: {} faces, flips {}, area ratio {:.4} [{:.3}, {:.3}], qc mean {:.4} max {:.3}, \
                 boundary length error {:.2e}",
                p.n_faces(),
                s.flipped_triangles,
                s.area_ratio,
                s.area_ratio_min,
                s.area_ratio_max,
                s.qc_mean,
                s.qc_max,
                s.boundary_length_error_max_rel
            );
            worst_qc = worst_qc.max(s.qc_mean);
            worst_len = worst_len.max(s.boundary_length_error_max_rel);
            accepted += 1;
        }
        println!(
            "{name}: {accepted} patches, worst qc_mean {worst_qc:.4}, worst boundary length error {worst_len:.2e}"
        );
        assert!(accepted >= 6, "{name}: only {accepted} disk candidates");
    }
}

#[test]
fn non_disks_are_refused() {
    let sphere = shapes::icosphere(3, 1.0);
    let e = bff_flatten(&sphere, &BffOptions::default()).unwrap_err();
    assert!(matches!(e, FlattenError::NotADisk { euler: 2, boundary_loops: 0 }), "{e}");
    let annulus = shapes::cylinder(1.0, 2.0, 16, 4, false, false);
    let e = bff_flatten(&annulus, &BffOptions::default()).unwrap_err();
    assert!(matches!(e, FlattenError::NotADisk { euler: 0, boundary_loops: 2 }), "{e}");
    // A planar annulus: a square grid with its centre quads removed.
    let grid = shapes::grid(6, 6, 1.0, 1.0);
    let faces: Vec<FaceId> = grid
        .face_ids()
        .filter(|&f| {
            let c = grid.face_centroid(f);
            !((0.34..0.66).contains(&c.x) && (0.34..0.66).contains(&c.y))
        })
        .collect();
    let ring = extract_submesh(&grid, &faces).unwrap().mesh;
    let e = bff_flatten(&ring, &BffOptions::default()).unwrap_err();
    assert!(matches!(e, FlattenError::NotADisk { euler: 0, boundary_loops: 2 }), "{e}");
}

/// A flat grid whose vertex (3, 2) is moved to within `delta` of the opposite edge of one of
/// its triangles (a cap triangle with an angle ≈ π and two ≈ 0), still a valid flat mesh.
fn grid_with_cap(delta: f64) -> Mesh {
    let mut m = shapes::grid(6, 6, 1.0, 1.0);
    let mut p = m.positions().clone();
    // Quad (3, 2) is split along (4, 2)–(3, 3); its triangle (3,2), (4,2), (3,3) becomes the cap.
    let mid = (p[clothcast_mesh::VertexId::new(2 * 7 + 4)] + p[clothcast_mesh::VertexId::new(3 * 7 + 3)]) / 2.0;
    p[clothcast_mesh::VertexId::new(2 * 7 + 3)] = mid - Vec3::new(1.0, 1.0, 0.0) * (delta / 2f64.sqrt());
    m.set_positions(p);
    let m = Mesh::try_from_soup(&m.to_soup()).expect("still a valid mesh");
    assert!(m.min_angle() < 1e3 * delta);
    m
}

/// Nearly degenerate (cap) triangles, down to a height of 1e-12 × their base: finite
/// positions, no flips, the flat patch still reproduced (the solve stays well conditioned
/// because each face's cotangents share one area, so its stiffness is a Gram matrix).
#[test]
fn cap_triangles_are_handled() {
    for delta in [1e-4, 1e-7, 1e-10, 1e-12] {
        let m = grid_with_cap(delta);
        let target: Vec<Vec2> = m.positions().iter().map(|x| Vec2::new(x.x, x.y)).collect();
        for floor in [0.0, BffOptions::default().cotan_area_floor, 1e-8] {
            let opts = BffOptions { cotan_area_floor: floor, ..Default::default() };
            let fl = bff_flatten(&m, &opts).unwrap();
            assert!(fl.uv.iter().all(|x| x.x.is_finite() && x.y.is_finite()));
            let err = rigid_error(&fl.uv, &target);
            let s = &fl.stats;
            println!("cap δ = {delta:e}, floor {floor:e}: rigid error {err:.2e}, qc_max {:.3e}", s.qc_max);
            assert_eq!(s.flipped_triangles, 0, "δ = {delta}, floor {floor}");
            assert!(err < 1e-5, "δ = {delta}, floor {floor}: {err}");
            assert!((s.area_ratio - 1.0).abs() < 1e-9 && s.qc_mean < 1.0 + 1e-4, "{s:?}");
        }
    }
}

/// The same input gives bit-identical output.
#[test]
fn deterministic() {
    let sphere = shapes::icosphere(3, 1.0);
    let faces: Vec<FaceId> = sphere.face_ids().filter(|&f| sphere.face_centroid(f).y > 0.2).collect();
    let m = disk(&sphere, &faces).unwrap();
    let a = flatten(&m);
    let b = flatten(&m);
    assert!(a.uv.iter().zip(b.uv.iter()).all(|(x, y)| x == y));
}

/// Generated surfaces (icosphere, torus, bumpy grid, cylinder) with jitter.
fn generated(kind: u8, jitter: f64, seed: u64) -> Mesh {
    let mut m = match kind % 4 {
        0 => shapes::icosphere(3, 1.0),
        1 => shapes::torus(2.0, 0.7, 40, 20),
        2 => {
            let mut g = shapes::grid(30, 30, 1.0, 1.0);
            let p = g.positions().map(|x| x + Vec3::z() * (0.15 * (6.0 * x.x).sin() * (5.0 * x.y).cos()));
            g.set_positions(p);
            g
        }
        _ => shapes::cylinder(1.0, 2.0, 30, 15, true, true),
    };
    let h = m.mean_edge_length();
    let mut rng = SplitMix64::new(seed);
    let p = m
        .positions()
        .map(|x| x + Vec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5) * (jitter * h));
    m.set_positions(p);
    m
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Random disk patches (random growth kept a disk, so with jagged boundaries) of jittered
    /// generated meshes: no flips, finite distortion, boundary lengths nearly kept.
    #[test]
    fn random_disk_patches(kind in 0u8..4, size in 20usize..600, jitter in 0.0f64..0.3, seed in any::<u64>()) {
        let m = generated(kind, jitter, seed);
        let mut rng = SplitMix64::new(seed ^ 0x5eed);
        let faces = random_disk(&m, size, &mut rng);
        let p = disk(&m, &faces).expect("grown as a disk");
        let fl = flatten(&p);
        let s = &fl.stats;
        prop_assert_eq!(s.flipped_triangles, 0, "{:?}", s);
        prop_assert!(s.qc_mean.is_finite() && s.qc_max.is_finite(), "{:?}", s);
        // Over 3000 cases: qc_mean ≤ 1.17, qc_max ≤ 2.3, boundary length error ≤ 0.95 %.
        prop_assert!(s.qc_mean < 1.5 && s.boundary_length_error_max_rel < 0.03, "{:?}", s);
        prop_assert!(signed_area(&p, &fl.uv) > 0.0);
    }
}

/// Boundary smoothing keeps the boundary closed and its lengths, and tends to a circle: a
/// 2:1 rectangle, whose corners hold all the turning, comes out nearly round at s = 10, and
/// a little smoothing moves it only a little.
#[test]
fn boundary_smoothing_tends_to_a_circle() {
    let rect = shapes::grid(24, 12, 2.0, 1.0);
    let spread = |fl: &Flattening| {
        let boundary: Vec<Vec2> = rect.boundary_loops()[0].iter().map(|&h| fl.uv[rect.tail(h)]).collect();
        let c = boundary.iter().sum::<Vec2>() / boundary.len() as f64;
        let r: Vec<f64> = boundary.iter().map(|p| (p - c).norm()).collect();
        r.iter().copied().fold(0.0, f64::max) / r.iter().copied().fold(f64::INFINITY, f64::min)
    };
    let plain = flatten(&rect);
    // The rectangle itself: corner distance √(1 + 0.25) against 0.5 at the long sides' middles.
    assert!((spread(&plain) - 1.25f64.sqrt() / 0.5).abs() < 1e-6, "{}", spread(&plain));
    let mut last = spread(&plain);
    for s in [1e-3, 1e-2, 1e-1, 10.0] {
        let fl = bff_flatten(&rect, &BffOptions { boundary_smoothing: s, ..Default::default() }).unwrap();
        let st = &fl.stats;
        println!("s = {s}: radius spread {:.4}, {st:?}", spread(&fl));
        assert_eq!(st.flipped_triangles, 0, "s = {s}");
        assert!(spread(&fl) < last, "s = {s}: the outline rounds off monotonically");
        last = spread(&fl);
        assert!(st.boundary_length_error_max_rel < 0.05, "s = {s}: {st:?}");
    }
    assert!(last < 1.05, "nearly a circle at s = 10: radius spread {last}");
}

/// Boundary relief: a stretch's turning is scaled by 1 − fraction and the rest of the outline
/// takes what it lost as a uniform density. Relieving one corner of a rectangle fully makes
/// it straight in the layout; the other corners keep their right angles plus a small share.
#[test]
fn boundary_relief_straightens_its_stretch() {
    use clothcast_flatten::BoundaryRelief;
    let rect = shapes::grid(24, 12, 2.0, 1.0);
    let lp: Vec<_> = rect.boundary_loops()[0].iter().map(|&h| rect.tail(h)).collect();
    let n = lp.len();
    let is_corner = |v: clothcast_mesh::VertexId| {
        let p = rect.position(v);
        (p.x == 0.0 || p.x == 2.0) && (p.y == 0.0 || p.y == 1.0)
    };
    let corners: Vec<usize> = (0..n).filter(|&j| is_corner(lp[j])).collect();
    assert_eq!(corners.len(), 4);
    let c = corners[1];
    // (The curve closed by length: closing it by turning would give the corner a little back.)
    let fl = bff_flatten(
        &rect,
        &BffOptions {
            boundary_relief: Some(BoundaryRelief { first: c, last: c, fraction: 1.0 }),
            exact_lengths: false,
            ..Default::default()
        },
    )
    .unwrap();
    let turning = |j: usize| {
        let (a, b, d) = (fl.uv[lp[(j + n - 1) % n]], fl.uv[lp[j]], fl.uv[lp[(j + 1) % n]]);
        let (u, w) = (b - a, d - b);
        u.perp(&w).atan2(u.dot(&w))
    };
    let total: f64 = (0..n).map(turning).sum();
    assert!((total - std::f64::consts::TAU).abs() < 1e-9, "{total}");
    assert!(turning(c).abs() < 1e-9, "the relieved corner is straight: {}", turning(c));
    for &k in corners.iter().filter(|&&k| k != c) {
        let t = turning(k);
        assert!(t > std::f64::consts::FRAC_PI_2 && t < std::f64::consts::FRAC_PI_2 + 0.1, "corner {k}: {t}");
    }
    assert_eq!(fl.stats.flipped_triangles, 0);
}

/// The boundary curve closed by turning keeps every boundary edge at its 3D length (so both
/// sides of a seam match), where the paper's best-fit curve changes them; the interior stays
/// as conformal. An asymmetric piece of a coarse sphere (the best-fit curve's change grows with
/// the discretisation error): a cap cut by a plane through its side.
#[test]
fn closing_by_turning_keeps_the_boundary_lengths() {
    let sphere = shapes::icosphere(2, 1.0);
    let faces: Vec<FaceId> = sphere
        .face_ids()
        .filter(|&f| {
            let c = sphere.face_centroid(f);
            c.z > 0.3 && c.x + 0.5 * c.y > -0.4
        })
        .collect();
    let m = disk(&sphere, &faces).expect("a disk");
    let exact = bff_flatten(&m, &BffOptions::default()).unwrap();
    let fitted = bff_flatten(&m, &BffOptions { exact_lengths: false, ..Default::default() }).unwrap();
    let (e, f) = (&exact.stats, &fitted.stats);
    println!("closed by turning: {e:?}\nclosed by length: {f:?}");
    assert!(e.boundary_length_error_max_rel < 1e-9, "{e:?}");
    assert!(f.boundary_length_error_max_rel > 1e-5, "the best-fit curve changes the lengths: {f:?}");
    assert_eq!(e.flipped_triangles, 0);
    assert!(e.qc_mean < f.qc_mean + 0.01 && e.qc_max < 1.2, "{e:?} against {f:?}");
    assert!(signed_area(&m, &exact.uv) > 0.0);
}

/// A prepared problem (one factorization) gives exactly the flattenings of `bff_flatten` with
/// the same boundary options, for any number of them.
#[test]
fn a_prepared_problem_reuses_its_factor_for_every_boundary_treatment() {
    use clothcast_flatten::{BffProblem, BoundaryRelief};
    let m = shapes::grid(16, 9, 1.5, 0.8);
    let opts = BffOptions::default();
    let problem = BffProblem::new(&m, &opts).unwrap();
    // A stretch of outline around a corner of the rectangle (the sides have no turning).
    let lp: Vec<_> = m.boundary_loops()[0].iter().map(|&h| m.tail(h)).collect();
    let corner = (0..lp.len()).find(|&j| m.position(lp[j]) == clothcast_mesh::Vec3::new(1.5, 0.8, 0.0)).unwrap();
    let n = lp.len();
    let relief = Some(BoundaryRelief { first: (corner + n - 2) % n, last: (corner + 2) % n, fraction: 0.4 });
    for (relief, smoothing) in [(None, 0.0), (relief, 0.0), (None, 1e-3), (relief, 1e-2)] {
        let once = problem.flatten(relief, smoothing).unwrap();
        let fresh =
            bff_flatten(&m, &BffOptions { boundary_relief: relief, boundary_smoothing: smoothing, ..opts.clone() })
                .unwrap();
        assert!(once.uv == fresh.uv, "{relief:?} {smoothing}");
    }
    assert!(problem.flatten(None, 0.0).unwrap().uv != problem.flatten(relief, 0.0).unwrap().uv);
}
