//! FlipOut end to end: straightened seams against closed-form geodesics (flat grid, unrolled
//! cylinder, sphere), networks that must not cross, validity of the traced polylines on a real
//! mesh, and the documented input errors.

use clothcast_layout::flipout::{FlipOutOptions, straighten_network};
use clothcast_layout::surface::polyline_length;
use clothcast_layout::{LayoutError, SurfacePoint};
use clothcast_mesh::geometry::shortest_edge_path;
use clothcast_mesh::util::SplitMix64;
use clothcast_mesh::{FaceId, Mesh, Vec3, VertexId, shapes};
use std::f64::consts::PI;

fn vid(i: usize) -> VertexId {
    VertexId::new(i)
}

/// Vertex (i, j) of `shapes::grid(nx, ..)`.
fn gv(nx: usize, i: usize, j: usize) -> VertexId {
    vid(j * (nx + 1) + i)
}

/// A monotone staircase of unit lattice steps from (i0, j0) to (i1, j1), alternating so as to
/// stay near the straight line (as jagged as an edge path along a grid can be).
fn staircase(i0: i64, j0: i64, i1: i64, j1: i64) -> Vec<(i64, i64)> {
    let (di, dj) = ((i1 - i0).signum(), (j1 - j0).signum());
    let (ni, nj) = ((i1 - i0).abs(), (j1 - j0).abs());
    let (mut i, mut j) = (0, 0);
    let mut out = vec![(i0, j0)];
    while i < ni || j < nj {
        // Step in x while its progress fraction is behind y's.
        if j == nj || (i < ni && i * nj <= j * ni) {
            i += 1;
        } else {
            j += 1;
        }
        out.push((i0 + di * i, j0 + dj * j));
    }
    out
}

fn grid_path(nx: usize, steps: &[(i64, i64)]) -> Vec<VertexId> {
    steps.iter().map(|&(i, j)| gv(nx, i as usize, j as usize)).collect()
}

fn vertex_path_length(m: &Mesh, p: &[VertexId]) -> f64 {
    p.windows(2).map(|w| (m.position(w[1]) - m.position(w[0])).norm()).sum()
}

fn faces_of(m: &Mesh, p: &SurfacePoint) -> Vec<FaceId> {
    match *p {
        SurfacePoint::Vertex(v) => m.vertex_faces(v).collect(),
        SurfacePoint::Edge { edge, .. } => {
            let (f, g) = m.edge_faces(edge);
            std::iter::once(f).chain(g).collect()
        }
    }
}

/// The output contract: ends at the path's ends, edge points strictly inside their edge, each
/// consecutive pair in a common input face, never longer than the input.
fn check_polyline(m: &Mesh, input: &[VertexId], out: &[SurfacePoint]) {
    assert_eq!(out.first(), Some(&SurfacePoint::Vertex(input[0])));
    assert_eq!(out.last(), Some(&SurfacePoint::Vertex(*input.last().unwrap())));
    for p in out {
        if let SurfacePoint::Edge { t, .. } = *p {
            assert!(t > 1e-9 && t < 1.0 - 1e-9, "edge point too close to a vertex: t = {t}");
        }
    }
    for w in out.windows(2) {
        assert_ne!(w[0], w[1], "repeated point");
        let fa = faces_of(m, &w[0]);
        assert!(faces_of(m, &w[1]).iter().any(|f| fa.contains(f)), "{:?} and {:?} share no face", w[0], w[1]);
    }
    let (before, after) = (vertex_path_length(m, input), polyline_length(m, out));
    assert!(after <= before * (1.0 + 1e-12), "length grew: {before} → {after}");
}

/// Distance from `p` to the segment a–b.
fn dist_to_segment(p: Vec3, a: Vec3, b: Vec3) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
    (a + ab * t - p).norm()
}

/// Check that a path came out as the straight segment between its ends.
fn assert_straight(m: &Mesh, out: &[SurfacePoint]) {
    let (a, b) = (out[0].position(m), out.last().unwrap().position(m));
    for p in out {
        let d = dist_to_segment(p.position(m), a, b);
        assert!(d < 1e-9, "point {p:?} is {d} off the straight line");
    }
    let (len, dist) = (polyline_length(m, out), (b - a).norm());
    assert!((len - dist).abs() <= 1e-9 * dist, "length {len} vs distance {dist}");
}

/// True if two planar (z = 0) polylines cross properly (touching at points is allowed).
fn planar_crossing(m: &Mesh, p: &[SurfacePoint], q: &[SurfacePoint]) -> bool {
    let xy = |s: &SurfacePoint| {
        let x = s.position(m);
        [x.x, x.y]
    };
    let orient = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        let o = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if o.abs() < 1e-12 { 0.0 } else { o.signum() }
    };
    for u in p.windows(2) {
        for v in q.windows(2) {
            let (a, b, c, d) = (xy(&u[0]), xy(&u[1]), xy(&v[0]), xy(&v[1]));
            if orient(a, b, c) * orient(a, b, d) < 0.0 && orient(c, d, a) * orient(c, d, b) < 0.0 {
                return true;
            }
        }
    }
    false
}

/// Shortest edge path by Dijkstra, avoiding the `blocked` vertices.
fn dijkstra(m: &Mesh, s: VertexId, t: VertexId, blocked: &[bool]) -> Option<Vec<VertexId>> {
    shortest_edge_path(m, s, t, &|v| !blocked[v.idx()])
}

fn straighten(m: &Mesh, paths: &[Vec<VertexId>]) -> Vec<Vec<SurfacePoint>> {
    let out = straighten_network(m, paths, &FlipOutOptions::default()).unwrap();
    assert_eq!(out.len(), paths.len());
    for (p, o) in paths.iter().zip(&out) {
        check_polyline(m, p, o);
    }
    out
}

#[test]
fn grid_staircase_becomes_straight() {
    // Non-square cells, so that nothing is accidentally symmetric.
    let (nx, ny) = (12, 9);
    let m = shapes::grid(nx, ny, 12.0, 7.2);
    for (i0, j0, i1, j1) in [(1, 1, 10, 6), (2, 7, 11, 2), (10, 8, 1, 1), (1, 4, 11, 5)] {
        let input = grid_path(nx, &staircase(i0, j0, i1, j1));
        let out = straighten(&m, std::slice::from_ref(&input));
        assert_straight(&m, &out[0]);
        assert!(out[0].iter().any(|p| matches!(p, SurfacePoint::Edge { .. })));
    }
    // An L-shaped path, the most jagged one.
    let mut l: Vec<(i64, i64)> = (1..=9).map(|i| (i, 1)).collect();
    l.extend((2..=7).map(|j| (9, j)));
    let out = straighten(&m, &[grid_path(nx, &l)]);
    assert_straight(&m, &out[0]);
}

#[test]
fn grid_path_through_collinear_vertices() {
    // (1,1) → (9,5) passes exactly through the vertices (3,2), (5,3), (7,4): they are flat,
    // so the geodesic goes straight through them and they are emitted as vertices.
    let nx = 10;
    let m = shapes::grid(nx, 6, 10.0, 6.0);
    let out = straighten(&m, &[grid_path(nx, &staircase(1, 1, 9, 5))]);
    assert_straight(&m, &out[0]);
    for (i, j) in [(3, 2), (5, 3), (7, 4)] {
        assert!(out[0].contains(&SurfacePoint::Vertex(gv(nx, i, j))), "({i}, {j}) missing");
    }
}

#[test]
fn cylinder_staircase_matches_the_unrolled_line() {
    let (r, h, n, m_up) = (1.0, 2.0, 24usize, 8usize);
    let m = shapes::cylinder(r, h, n, m_up, false, false);
    let chord = 2.0 * r * (PI / n as f64).sin();
    let dz = h / m_up as f64;
    let id = |i: i64, j: i64| vid(j as usize * n + i.rem_euclid(n as i64) as usize);
    // The second one crosses the i = 0 seam of the vertex numbering.
    for (i0, j0, i1, j1) in [(0, 1, 5, 7), (21, 1, 27, 6), (3, 7, -4, 1)] {
        let input: Vec<VertexId> = staircase(i0, j0, i1, j1).into_iter().map(|(i, j)| id(i, j)).collect();
        let out = straighten(&m, std::slice::from_ref(&input));
        let expected = (((i1 - i0) as f64 * chord).powi(2) + ((j1 - j0) as f64 * dz).powi(2)).sqrt();
        let len = polyline_length(&m, &out[0]);
        assert!((len - expected).abs() <= 1e-9 * expected, "length {len}, unrolled line {expected}");
    }
}

#[test]
fn icosphere_path_approaches_a_great_circle() {
    let m = shapes::icosphere(4, 1.0);
    let no_block = vec![false; m.n_vertices()];
    // From an icosahedron vertex (a cone of valence 5) and from an ordinary vertex.
    for start in [vid(0), vid(1000)] {
        let a = m.position(start);
        let target = m
            .vertices()
            .min_by(|&u, &w| {
                let f = |x: VertexId| (a.dot(&m.position(x)).acos() - PI / 2.0).abs();
                f(u).total_cmp(&f(w))
            })
            .unwrap();
        let angle = a.dot(&m.position(target)).acos();
        let input = dijkstra(&m, start, target, &no_block).unwrap();
        let out = straighten(&m, std::slice::from_ref(&input));
        let len = polyline_length(&m, &out[0]);
        assert!((len - angle).abs() < 0.01 * angle, "length {len} vs great circle {angle}");
        assert!(len < vertex_path_length(&m, &input));
    }
}

#[test]
fn network_with_a_shared_endpoint_does_not_cross() {
    let nx = 14;
    let m = shapes::grid(nx, 10, 14.0, 10.0);
    let row = |j: i64, i0: i64, i1: i64| -> Vec<(i64, i64)> { (i0..=i1).map(|i| (i, j)).collect() };
    let col = |i: i64, j0: i64, j1: i64| -> Vec<(i64, i64)> {
        if j0 <= j1 { (j0..=j1).map(|j| (i, j)).collect() } else { (j1..=j0).rev().map(|j| (i, j)).collect() }
    };
    // Two paths fanning out of (2,2): a staircase and an L.
    let p0 = staircase(2, 2, 12, 6);
    let p1 = [col(2, 2, 5), row(5, 3, 6)].concat();
    // Two paths out of (1,9) whose geodesics overlap: (1,9) → (5,8) → (9,7) is on the line to
    // (13,6). P2 comes from above, P3 from below; they end up sharing two intrinsic edges.
    let p2 = [row(9, 1, 13), col(13, 8, 6)].concat();
    let p3 = [col(1, 9, 7), row(7, 2, 9)].concat();
    let paths: Vec<Vec<VertexId>> = [p0, p1, p2, p3].iter().map(|p| grid_path(nx, p)).collect();
    let out = straighten(&m, &paths);
    for o in &out {
        assert_straight(&m, o);
    }
    for a in 0..out.len() {
        for b in a + 1..out.len() {
            assert!(!planar_crossing(&m, &out[a], &out[b]), "paths {a} and {b} cross");
        }
    }
    for (i, j) in [(5, 8), (9, 7)] {
        assert!(out[2].contains(&SurfacePoint::Vertex(gv(nx, i, j))));
    }
    assert!(out[3].contains(&SurfacePoint::Vertex(gv(nx, 5, 8))));
}

#[test]
fn three_paths_meeting_at_a_vertex_stay_there() {
    let nx = 12;
    let m = shapes::grid(nx, 12, 12.0, 12.0);
    let v = gv(nx, 6, 6);
    // A staircase through v, split at v, and a third path leaving v up and left.
    let (a1, a2) = (staircase(1, 2, 6, 6), staircase(6, 6, 11, 9));
    let b = [(6, 6), (6, 7), (5, 7), (5, 8), (4, 8), (4, 9), (3, 9), (3, 10)];
    let paths = vec![grid_path(nx, &a1), grid_path(nx, &a2), grid_path(nx, &b)];
    let out = straighten(&m, &paths);
    assert_eq!(out[0].last(), Some(&SurfacePoint::Vertex(v)));
    assert_eq!(out[1].first(), Some(&SurfacePoint::Vertex(v)));
    assert_eq!(out[2].first(), Some(&SurfacePoint::Vertex(v)));
    for o in &out {
        assert_straight(&m, o);
    }
    for i in 0..3 {
        for j in i + 1..3 {
            assert!(!planar_crossing(&m, &out[i], &out[j]), "paths {i} and {j} cross");
        }
    }
    // The same configuration without splitting A at v is refused.
    let whole: Vec<VertexId> = a1.iter().chain(&a2[1..]).map(|&(i, j)| gv(nx, i as usize, j as usize)).collect();
    let err = straighten_network(&m, &[whole, paths[2].clone()], &FlipOutOptions::default()).unwrap_err();
    assert!(matches!(err, LayoutError::InvalidPath { path: 0, .. }), "{err}");
}

#[test]
fn a_path_wraps_around_another_instead_of_crossing_it() {
    // A runs horizontally from (3,6) to (11,6). B goes from (5,3) to (5,9) around A's left end;
    // it cannot cross A, so it becomes the taut string (5,3) → (3,6) → (5,9).
    let nx = 14;
    let m = shapes::grid(nx, 12, 14.0, 12.0);
    let a: Vec<(i64, i64)> = (3..=11).map(|i| (i, 6)).collect();
    let mut b: Vec<(i64, i64)> = (2..=5).rev().map(|i| (i, 3)).collect();
    b.extend((4..=9).map(|j| (2, j)));
    b.extend((3..=5).map(|i| (i, 9)));
    let out = straighten(&m, &[grid_path(nx, &a), grid_path(nx, &b)]);
    assert_straight(&m, &out[0]);
    let corner = gv(nx, 3, 6);
    assert!(out[1].contains(&SurfacePoint::Vertex(corner)), "B does not wrap around A's end");
    let expected = 2.0 * 13f64.sqrt();
    let len = polyline_length(&m, &out[1]);
    assert!((len - expected).abs() < 1e-9 * expected, "length {len} vs {expected}");
    assert!(!planar_crossing(&m, &out[0], &out[1]));
}

#[test]
fn geodesic_bends_around_a_reflex_boundary_corner() {
    // An L-shaped domain: the 8×8 grid without its top-right 4×4 block. From (7,2) to (2,7) the
    // shortest path bends at the reflex corner (4,4), a boundary vertex.
    let full = shapes::grid(8, 8, 8.0, 8.0);
    let keep: Vec<[u32; 3]> = full
        .face_ids()
        .filter(|&f| {
            let c = full.face_centroid(f);
            !(c.x > 4.0 && c.y > 4.0)
        })
        .map(|f| full.face_vertices(f).map(|v| v.0))
        .collect();
    let mut used = vec![u32::MAX; full.n_vertices()];
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    for t in keep {
        tris.push(t.map(|v| {
            if used[v as usize] == u32::MAX {
                used[v as usize] = positions.len() as u32;
                positions.push(full.position(VertexId(v)));
            }
            used[v as usize]
        }));
    }
    let m = Mesh::try_new(positions, tris).unwrap();
    let at = |i: i64, j: i64| VertexId(used[gv(8, i as usize, j as usize).idx()]);
    let mut p: Vec<(i64, i64)> = (2..=7).rev().map(|i| (i, 2)).collect();
    p.extend((3..=7).map(|j| (2, j)));
    let input: Vec<VertexId> = p.iter().map(|&(i, j)| at(i, j)).collect();
    let out = straighten(&m, std::slice::from_ref(&input));
    let expected = 2.0 * (9.0f64 + 4.0).sqrt();
    let len = polyline_length(&m, &out[0]);
    assert!((len - expected).abs() < 1e-9 * expected, "length {len} vs {expected}");
    assert!(out[0].contains(&SurfacePoint::Vertex(at(4, 4))));
    // Between two points of the notch's sides the geodesic runs along the boundary itself, in
    // either direction (the surface on its left or on its right).
    let mut p: Vec<(i64, i64)> = vec![(7, 4)];
    p.extend((3..=7).rev().map(|i| (i, 3)));
    p.extend((4..=7).map(|j| (3, j)));
    p.push((4, 7));
    let notch: Vec<(i64, i64)> = vec![(7, 4), (6, 4), (5, 4), (4, 4), (4, 5), (4, 6), (4, 7)];
    for reverse in [false, true] {
        let (mut input, mut expected): (Vec<VertexId>, Vec<SurfacePoint>) = (
            p.iter().map(|&(i, j)| at(i, j)).collect(),
            notch.iter().map(|&(i, j)| SurfacePoint::Vertex(at(i, j))).collect(),
        );
        if reverse {
            input.reverse();
            expected.reverse();
        }
        let out = straighten(&m, &[input]);
        assert_eq!(out[0], expected);
    }
}

#[test]
fn bunny_paths_are_valid() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/closed/bunny.obj");
    let soup = clothcast_mesh::io::read_mesh_file(&path).unwrap();
    let m = Mesh::try_from_soup(&soup).unwrap();
    let n = m.n_vertices();
    let mut rng = SplitMix64::new(2024);
    // A network of disjoint paths (each avoids the vertices of the previous ones) ...
    let mut blocked = vec![false; n];
    let mut network = Vec::new();
    while network.len() < 6 {
        let (s, t) = (vid(rng.below(n)), vid(rng.below(n)));
        if s == t || blocked[s.idx()] || blocked[t.idx()] {
            continue;
        }
        if let Some(p) = dijkstra(&m, s, t, &blocked)
            && p.len() > 3
        {
            p.iter().for_each(|v| blocked[v.idx()] = true);
            network.push(p);
        }
    }
    let out = straighten(&m, &network);
    let (before, after): (f64, f64) = network
        .iter()
        .zip(&out)
        .fold((0.0, 0.0), |(b, a), (p, o)| (b + vertex_path_length(&m, p), a + polyline_length(&m, o)));
    assert!(after < 0.99 * before, "network barely shortened: {before} → {after}");
    // ... random self-avoiding walks (far more winding than shortest edge paths) ...
    for _ in 0..8 {
        let mut walk = vec![vid(rng.below(n))];
        let mut near = vec![false; n];
        near[walk[0].idx()] = true;
        for _ in 0..80 {
            let last = *walk.last().unwrap();
            let next: Vec<VertexId> = m.vertex_neighbors(last).into_iter().filter(|w| !near[w.idx()]).collect();
            if next.is_empty() {
                break;
            }
            // Mark the whole neighbourhood of the walk so that it never touches itself.
            m.vertex_neighbors(last).iter().for_each(|w| near[w.idx()] = true);
            walk.push(next[rng.below(next.len())]);
        }
        if walk.len() > 2 {
            straighten(&m, &[walk]);
        }
    }
    // ... and single long paths, each on its own.
    let free = vec![false; n];
    for _ in 0..6 {
        let (s, t) = (vid(rng.below(n)), vid(rng.below(n)));
        if let Some(p) = dijkstra(&m, s, t, &free).filter(|p| p.len() > 2) {
            straighten(&m, &[p]);
        }
    }
}

#[test]
fn bunny_star_networks_are_valid() {
    // Stars of paths from one centre: geodesics with a common endpoint may merge through saddle
    // vertices and share edges; they must still touch without crossing and come out valid.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/closed/bunny.obj");
    let m = Mesh::try_from_soup(&clothcast_mesh::io::read_mesh_file(&path).unwrap()).unwrap();
    let n = m.n_vertices();
    let mut rng = SplitMix64::new(77);
    for _ in 0..4 {
        let centre = vid(rng.below(n));
        let mut blocked = vec![false; n];
        blocked[centre.idx()] = true;
        let mut star = Vec::new();
        for _ in 0..40 {
            if star.len() == 8 {
                break;
            }
            let t = vid(rng.below(n));
            if blocked[t.idx()] {
                continue;
            }
            // Paths leave the centre through distinct neighbours (no edge used twice).
            if let Some(p) = dijkstra(&m, centre, t, &blocked).filter(|p| p.len() > 3) {
                p.iter().for_each(|v| blocked[v.idx()] = true);
                star.push(p);
            }
        }
        assert!(star.len() >= 4);
        let out = straighten(&m, &star);
        let before: f64 = star.iter().map(|p| vertex_path_length(&m, p)).sum();
        let after: f64 = out.iter().map(|o| polyline_length(&m, o)).sum();
        assert!(after < 0.99 * before, "star barely shortened: {before} → {after}");
    }
}

#[test]
fn torus_paths_are_valid() {
    let m = shapes::torus(2.0, 0.7, 40, 16);
    let free = vec![false; m.n_vertices()];
    let mut rng = SplitMix64::new(5);
    for _ in 0..5 {
        let (s, t) = (vid(rng.below(m.n_vertices())), vid(rng.below(m.n_vertices())));
        if let Some(p) = dijkstra(&m, s, t, &free).filter(|p| p.len() > 2) {
            straighten(&m, &[p]);
        }
    }
}

#[test]
fn closed_loops_pinned_at_a_vertex() {
    // A jagged loop around the torus's hole, closed at one vertex: it straightens to a geodesic
    // loop with a corner only at its pinned vertex. Loops are paths whose ends coincide.
    let (nu, nv) = (40usize, 16usize);
    let m = shapes::torus(2.0, 0.7, nu, nv);
    let id = |i: usize, j: usize| vid((i % nu) * nv + j % nv);
    let mut lp = vec![id(0, 0)];
    for i in 0..nu {
        // Wiggle up and down the tube while going around.
        let j = if (i / 3) % 2 == 0 { 1 } else { 0 };
        if lp.last() != Some(&id(i, j)) {
            lp.push(id(i, j));
        }
        lp.push(id(i + 1, j));
    }
    if lp.last() != Some(&id(0, 0)) {
        lp.push(id(0, 0));
    }
    lp.dedup();
    let out = straighten(&m, &[lp]);
    assert_eq!(out[0].first(), out[0].last());
    // Shorter than the outer equator it started near, longer than the shortest loop around the
    // hole (the inner equator polygon).
    let len = polyline_length(&m, &out[0]);
    let inner = 2.0 * nu as f64 * (2.0 - 0.7) * (PI / nu as f64).sin();
    let outer = 2.0 * nu as f64 * (2.0 + 0.7) * (PI / nu as f64).sin();
    assert!(len > inner && len < 0.75 * outer, "loop length {len} (inner {inner}, outer {outer})");
}

#[test]
fn flip_cap_and_determinism() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/closed/bunny.obj");
    let m = Mesh::try_from_soup(&clothcast_mesh::io::read_mesh_file(&path).unwrap()).unwrap();
    let free = vec![false; m.n_vertices()];
    let p = dijkstra(&m, vid(10), vid(2000), &free).unwrap();
    let full = straighten(&m, std::slice::from_ref(&p));
    // Same input, same output, to the bit.
    assert_eq!(straighten(&m, std::slice::from_ref(&p)), full);
    // A tight flip cap stops early: still a valid polyline, between the input and the geodesic.
    let capped = straighten_network(
        &m,
        std::slice::from_ref(&p),
        &FlipOutOptions { max_flips_per_path: 3, ..Default::default() },
    )
    .unwrap();
    check_polyline(&m, &p, &capped[0]);
    let (l_full, l_capped) = (polyline_length(&m, &full[0]), polyline_length(&m, &capped[0]));
    assert!(l_full < l_capped, "{l_full} vs {l_capped}");
}

#[test]
fn invalid_paths_are_refused() {
    let nx = 6;
    let m = shapes::grid(nx, 6, 1.0, 1.0);
    let opts = FlipOutOptions::default();
    let invalid = |paths: &[Vec<VertexId>], which: usize| {
        let err = straighten_network(&m, paths, &opts).unwrap_err();
        assert!(matches!(err, LayoutError::InvalidPath { path, .. } if path == which), "{err}");
    };
    let a = grid_path(nx, &[(1, 3), (2, 3), (3, 3), (4, 3), (5, 3)]);
    // Non-adjacent consecutive vertices.
    invalid(&[grid_path(nx, &[(1, 1), (3, 1)])], 0);
    // Too short, repeated vertex, out of range.
    invalid(&[vec![gv(nx, 1, 1)]], 0);
    invalid(&[grid_path(nx, &[(1, 1), (1, 1)])], 0);
    invalid(&[vec![gv(nx, 1, 1), vid(10_000)]], 0);
    // A vertex inside two paths.
    invalid(&[a.clone(), grid_path(nx, &[(3, 1), (3, 2), (3, 3), (3, 4), (3, 5)])], 1);
    // A path ending at another's interior vertex (a T-junction not split): the path whose
    // interior is touched is named.
    invalid(&[a.clone(), grid_path(nx, &[(3, 1), (3, 2), (3, 3)])], 0);
    // An edge used twice.
    invalid(&[grid_path(nx, &[(1, 1), (2, 1)]), grid_path(nx, &[(2, 1), (1, 1)])], 1);
    // An interior vertex on the boundary.
    invalid(&[grid_path(nx, &[(1, 1), (1, 0), (2, 0)])], 0);
    // A vertex twice in one path.
    invalid(&[grid_path(nx, &[(1, 1), (2, 1), (2, 2), (1, 2), (1, 1), (0, 1)])], 0);
    // Valid: shared endpoints, boundary endpoints, a lone edge along the boundary.
    let ok = vec![
        grid_path(nx, &[(0, 0), (1, 0)]),
        grid_path(nx, &[(1, 0), (1, 1), (2, 1)]),
        grid_path(nx, &[(2, 1), (2, 2), (3, 2)]),
    ];
    let out = straighten(&m, &ok);
    assert_eq!(out[0], vec![SurfacePoint::Vertex(gv(nx, 0, 0)), SurfacePoint::Vertex(gv(nx, 1, 0))]);
}
