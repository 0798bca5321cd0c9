//! Remeshing along seams on a flat grid, an icosphere and the bunny: validity, topology, exact
//! surface (vertices on the input, children inside their parents, area), edge paths, snapping and
//! the minimum angle of the new triangles.
//!
//! Seams are plane sections walked face by face (a straight chord in every face, like a
//! straightened geodesic): great circles on the sphere, a straight line on the grid.
//!
//! Asserted minimum angles of the new triangles (children of split faces): ≥ 3° on the grid
//! and the icospheres, ≥ min(3°, half the smallest angle of the split input faces) on the bunny.
//! Measured (printed with `--nocapture`): grid line 4.67°, grid fan 3.09°, icosphere 4.44°,
//! icosphere slices 5.09°, bunny 5.15°, bunny slices 3.76°, random bunny seams 3.06°.

use clothcast_layout::remesh::{RemeshOptions, Remeshed, insert_polylines};
use clothcast_layout::{LayoutError, SurfacePoint};
use clothcast_mesh::geometry::angle_at;
use clothcast_mesh::io::read_mesh_file;
use clothcast_mesh::{EdgeId, FaceId, Mesh, Vec3, VertexId, shapes};
use std::collections::BTreeSet;
use std::path::PathBuf;

fn data(rel: &str) -> Mesh {
    let p = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/meshes")).join(rel);
    Mesh::try_from_soup(&read_mesh_file(&p).unwrap()).unwrap()
}

/// Walk the section of the mesh by the plane through `start` with normal `n`, entering `face`,
/// for at most `max_faces` faces (stops at the boundary).
fn walk_plane(mesh: &Mesh, start: SurfacePoint, face: FaceId, n: Vec3, max_faces: usize) -> Vec<SurfacePoint> {
    let origin = start.position(mesh);
    let d = |v: VertexId| (mesh.position(v) - origin).dot(&n);
    let mut out = vec![start];
    let (mut cur, mut f) = (start, face);
    for _ in 0..max_faces {
        let mut exit = None;
        for k in 0..3 {
            let h = mesh.face_halfedge(f, k);
            let e = mesh.edge(h);
            let skip = match cur {
                SurfacePoint::Vertex(v) => mesh.edge_vertices(e).contains(&v),
                SurfacePoint::Edge { edge, .. } => edge == e,
            };
            let (da, db) = (d(mesh.tail(h)), d(mesh.head(h)));
            if !skip && da * db < 0.0 {
                let s = da / (da - db);
                let t = if mesh.edge_halfedge(e) == h { s } else { 1.0 - s };
                exit = Some((h, SurfacePoint::Edge { edge: e, t }));
            }
        }
        let Some((h, p)) = exit else { break };
        out.push(p);
        cur = p;
        match mesh.twin(h) {
            Some(t) => f = mesh.face(t),
            None => break,
        }
    }
    out
}

/// The plane section leaving vertex `v` (plane through `v` with normal `n`) on the side of `dir`.
fn walk_from_vertex(mesh: &Mesh, v: VertexId, n: Vec3, dir: Vec3, max_faces: usize) -> Vec<SurfacePoint> {
    let o = mesh.position(v);
    for h in mesh.outgoing(v) {
        let f = mesh.face(h);
        let g = mesh.next(h); // the edge opposite to v
        let (a, b) = (mesh.position(mesh.tail(g)) - o, mesh.position(mesh.head(g)) - o);
        let (da, db) = (a.dot(&n), b.dot(&n));
        if da * db < 0.0 {
            let s = da / (da - db);
            if (a * (1.0 - s) + b * s).dot(&dir) > 0.0 {
                return walk_plane(mesh, SurfacePoint::Vertex(v), f, n, max_faces);
            }
        }
    }
    panic!("no face of vertex {v} in direction {dir:?}");
}

/// The plane section through vertex `v`, both ways: `v` is an interior point of the polyline.
fn walk_through_vertex(mesh: &Mesh, v: VertexId, n: Vec3, dir: Vec3, max_faces: usize) -> Vec<SurfacePoint> {
    let mut a = walk_from_vertex(mesh, v, n, -dir, max_faces);
    a.reverse();
    a.extend(walk_from_vertex(mesh, v, n, dir, max_faces).into_iter().skip(1));
    a
}

/// Tangent unit vectors at a point of a surface with normal `nrm`: (u, w).
fn tangents(nrm: Vec3) -> (Vec3, Vec3) {
    let a = if nrm.x.abs() < 0.8 { Vec3::x() } else { Vec3::y() };
    let u = nrm.cross(&a).normalize();
    (u, nrm.cross(&u))
}

/// Closest distance from `p` to triangle `t` (Ericson, Real-Time Collision Detection §5.1.5).
fn point_triangle_distance(p: Vec3, t: [Vec3; 3]) -> f64 {
    (clothcast_mesh::simplify::closest_on_triangle(&p, &t).1 - p).norm()
}

/// Minimum angle (degrees) of the given faces of a mesh.
fn min_angle_deg(m: &Mesh, faces: impl Iterator<Item = FaceId>) -> f64 {
    let mut min = f64::INFINITY;
    for f in faces {
        let [a, b, c] = m.face_positions(f);
        min = min.min(angle_at(&a, &b, &c)).min(angle_at(&b, &c, &a)).min(angle_at(&c, &a, &b));
    }
    min.to_degrees()
}

/// What a remeshing achieved.
struct Quality {
    /// Smallest angle of the triangles of touched input faces (degrees).
    min_new: f64,
    /// Smallest angle of the touched input faces themselves (degrees).
    min_touched_input: f64,
    /// Largest distance of a new vertex to the input face its triangles lie in.
    hausdorff: f64,
}

/// Every property of a remeshing that does not depend on the polylines' shape.
fn check(input: &Mesh, polylines: &[Vec<SurfacePoint>], r: &Remeshed, snap: f64) -> Quality {
    let m = &r.mesh;
    let scale = input.bbox().diagonal();
    let n_in = input.n_vertices();
    // Topology.
    assert_eq!(m.euler_characteristic(), input.euler_characteristic());
    assert_eq!(m.boundary_loops().len(), input.boundary_loops().len());
    assert_eq!(m.n_components(), input.n_components());
    assert_eq!(m.genus(), input.genus());
    assert_eq!(r.face_parent.len(), m.n_faces());
    assert_eq!(r.vertex_parent.len(), m.n_vertices());
    assert_eq!(r.vertex_input.len(), m.n_vertices());
    assert_eq!(r.paths.len(), polylines.len());
    // Vertices: input ones first, every vertex exactly at its parent point.
    for v in m.vertices() {
        let parent = r.vertex_parent[v];
        assert_eq!(parent.position(input), m.position(v), "vertex {v}");
        if v.idx() < n_in {
            assert_eq!(parent, SurfacePoint::Vertex(v));
            assert_eq!(r.vertex_input[v], Some(v));
        } else {
            assert!(matches!(parent, SurfacePoint::Edge { t, .. } if t > 0.0 && t < 1.0));
            assert_eq!(r.vertex_input[v], None);
        }
    }
    // Faces: inside their parents, same orientation, area per parent preserved.
    let mut child_area = vec![0.0; input.n_faces()];
    let mut n_children = vec![0usize; input.n_faces()];
    let mut hausdorff: f64 = 0.0;
    for f in m.face_ids() {
        let g = r.face_parent[f];
        let pp = input.face_positions(g);
        let pn = input.face_normal(g);
        let c = m.face_centroid(f);
        assert!((c - pp[0]).dot(&pn).abs() <= 1e-12 * scale, "child {f} off the plane of {g}");
        let area2 = (pp[1] - pp[0]).cross(&(pp[2] - pp[0])).norm();
        for k in 0..3 {
            let (a, b) = (pp[(k + 1) % 3], pp[(k + 2) % 3]);
            let bary = (b - a).cross(&(c - a)).dot(&pn) / area2;
            assert!(bary >= -1e-12, "child {f} centroid outside parent {g}");
        }
        for v in m.face_vertices(f) {
            hausdorff = hausdorff.max(point_triangle_distance(m.position(v), pp));
        }
        assert!(m.face_normal(f).dot(&pn) > 0.0, "child {f} flipped");
        child_area[g.idx()] += m.face_area(f);
        n_children[g.idx()] += 1;
    }
    assert!(hausdorff <= 1e-12 * scale, "Hausdorff {hausdorff}");
    for g in input.face_ids() {
        let a = input.face_area(g);
        assert!((child_area[g.idx()] - a).abs() <= 1e-12 * a, "area of {g}: {} vs {a}", child_area[g.idx()]);
    }
    let (a_in, a_out) = (input.total_area(), m.total_area());
    assert!((a_in - a_out).abs() <= 1e-12 * a_in, "total area {a_out} vs {a_in}");
    // Untouched faces keep their corners.
    for f in m.face_ids() {
        let g = r.face_parent[f];
        if n_children[g.idx()] == 1 {
            assert_eq!(m.face_vertices(f), input.face_vertices(g));
        }
    }
    // Paths: edge paths from the first to the last (snapped) point.
    let edges: BTreeSet<(VertexId, VertexId)> = m
        .edges()
        .map(|e| {
            let [a, b] = m.edge_vertices(e);
            (a.min(b), a.max(b))
        })
        .collect();
    for (k, (path, line)) in r.paths.iter().zip(polylines).enumerate() {
        for w in path.windows(2) {
            assert!(edges.contains(&(w[0].min(w[1]), w[0].max(w[1]))), "path {k}: {}-{} is not an edge", w[0], w[1]);
        }
        for (end, p) in [(path[0], line[0]), (*path.last().unwrap(), *line.last().unwrap())] {
            let tol = match p {
                SurfacePoint::Edge { edge, .. } => snap * input.edge_length(edge) * (1.0 + 1e-9),
                SurfacePoint::Vertex(_) => 0.0,
            };
            assert!((m.position(end) - p.position(input)).norm() <= tol, "path {k} ends away from its polyline");
        }
    }
    let touched: Vec<FaceId> = m.face_ids().filter(|&f| n_children[r.face_parent[f].idx()] > 1).collect();
    let touched_in: BTreeSet<FaceId> = touched.iter().map(|&f| r.face_parent[f]).collect();
    Quality {
        min_new: min_angle_deg(m, touched.into_iter()),
        min_touched_input: min_angle_deg(input, touched_in.into_iter()),
        hausdorff,
    }
}

/// Path vertices lie on their polyline (within the snap distance of some segment).
fn check_on_polyline(input: &Mesh, line: &[SurfacePoint], path: &[VertexId], r: &Remeshed, tol: f64) {
    for &v in path {
        let p = r.mesh.position(v);
        let dist = line
            .windows(2)
            .map(|w| {
                let (a, b) = (w[0].position(input), w[1].position(input));
                let s = ((p - a).dot(&(b - a)) / (b - a).norm_squared().max(1e-300)).clamp(0.0, 1.0);
                (p - (a + (b - a) * s)).norm()
            })
            .fold(f64::INFINITY, f64::min);
        assert!(dist <= tol, "path vertex {v} is {dist} from its polyline");
    }
}

fn max_edge(m: &Mesh) -> f64 {
    m.edges().map(|e| m.edge_length(e)).fold(0.0, f64::max)
}

#[test]
fn straight_line_across_grid() {
    let grid = shapes::grid(10, 10, 1.0, 1.0);
    // Start on the left boundary at y = 0.137 and head along (1, 0.53).
    let e0 = grid
        .edges()
        .find(|&e| {
            let [a, b] = grid.edge_vertices(e).map(|v| grid.position(v));
            a.x == 0.0 && b.x == 0.0 && a.y.min(b.y) < 0.137 && a.y.max(b.y) > 0.137
        })
        .unwrap();
    let [a, b] = grid.edge_vertices(e0).map(|v| grid.position(v));
    let start = SurfacePoint::Edge { edge: e0, t: (0.137 - a.y) / (b.y - a.y) };
    let n = Vec3::new(-0.53, 1.0, 0.0).normalize();
    let line = walk_plane(&grid, start, grid.edge_faces(e0).0, n, 1000);
    assert!(line.len() > 10);
    let end = line.last().unwrap().position(&grid);
    assert!((end.x - 1.0).abs() < 1e-12 || (end.y - 1.0).abs() < 1e-12);
    let r = insert_polylines(&grid, std::slice::from_ref(&line), &RemeshOptions::default()).unwrap();
    let q = check(&grid, std::slice::from_ref(&line), &r, 0.1);
    // Every path vertex is on the straight line; the path is monotone in x.
    for w in r.paths[0].windows(2) {
        assert!(r.mesh.position(w[1]).x > r.mesh.position(w[0]).x);
    }
    check_on_polyline(&grid, &line, &r.paths[0], &r, 0.1 * max_edge(&grid) + 1e-12);
    println!(
        "grid: {} points, {} -> {} faces, min angle new {:.2}° (input {:.2}°), hausdorff {:.1e}",
        line.len(),
        grid.n_faces(),
        r.mesh.n_faces(),
        q.min_new,
        q.min_touched_input,
        q.hausdorff
    );
    assert!(q.min_new >= 3.0, "min angle {}", q.min_new);
}

#[test]
fn lines_across_grid_at_many_angles() {
    // A fan of straight lines from one boundary point, one remeshing each: the worst angle.
    let grid = shapes::grid(8, 8, 1.0, 1.0);
    let e0 = grid.edges().find(|&e| grid.edge_vertices(e).iter().all(|&v| grid.position(v).y == 0.0)).unwrap();
    let mut worst = f64::INFINITY;
    for i in 1..60 {
        let t = 0.05 + 0.9 * ((i as f64 * 0.618_033_988_75) % 1.0);
        let start = SurfacePoint::Edge { edge: e0, t };
        let ang = 0.1 + (std::f64::consts::PI - 0.2) * i as f64 / 60.0;
        let n = Vec3::new(-ang.sin(), ang.cos(), 0.0);
        let line = walk_plane(&grid, start, grid.edge_faces(e0).0, n, 1000);
        let r = insert_polylines(&grid, std::slice::from_ref(&line), &RemeshOptions::default()).unwrap();
        let q = check(&grid, std::slice::from_ref(&line), &r, 0.1);
        worst = worst.min(q.min_new);
    }
    println!("grid fan: worst min angle {worst:.2}°");
    assert!(worst >= 3.0, "min angle {worst}");
}

/// Seams on a curved closed mesh: two sharing their start vertex `v`, one through vertex `w`,
/// and one walked from a vertex about three edges from `y` along a plane that misses `y` by
/// 0.03 × the mean edge length, so that its edge points around `y` must snap onto `y`.
fn seams_on(mesh: &Mesh, v: VertexId, w: VertexId, y: VertexId, steps: usize) -> Vec<Vec<SurfacePoint>> {
    let nv = mesh.vertex_normals();
    let (u1, u2) = tangents(nv[v]);
    let d1 = u1 * 0.8 + u2 * 0.6;
    let d2 = u1 * (-0.3) + u2 * 0.95;
    let a = walk_from_vertex(mesh, v, nv[v].cross(&d1).normalize(), d1, steps);
    let b = walk_from_vertex(mesh, v, nv[v].cross(&d2).normalize(), d2, steps);
    let (t1, t2) = tangents(nv[w]);
    let t1 = t1 * 0.37f64.cos() + t2 * 0.37f64.sin();
    let c = walk_through_vertex(mesh, w, nv[w].cross(&t1).normalize(), t1, steps / 2);
    let h = mesh.mean_edge_length();
    let py = mesh.position(y);
    let s = mesh
        .vertices()
        .min_by(|&p, &q| {
            let f = |x: VertexId| ((mesh.position(x) - py).norm() - 3.0 * h).abs();
            f(p).total_cmp(&f(q))
        })
        .unwrap();
    let sy = py - mesh.position(s);
    let n0 = nv[y].cross(&sy).normalize();
    let n = (n0 + sy * (0.03 * h / sy.norm_squared())).normalize();
    let d = walk_from_vertex(mesh, s, n, sy, steps);
    vec![a, b, c, d]
}

/// Remesh seams on a curved mesh and check them; returns the quality.
fn curved_case(name: &str, mesh: &Mesh, v: VertexId, w: VertexId, y: VertexId, steps: usize) -> Quality {
    let lines = seams_on(mesh, v, w, y, steps);
    for (k, l) in lines.iter().enumerate() {
        assert!(l.len() >= 4, "{name}: seam {k} has only {} points", l.len());
    }
    assert!(lines[2].contains(&SurfacePoint::Vertex(w)));
    // Some edge point of the grazing seam is within the snap distance of y.
    let near_y = lines[3]
        .iter()
        .filter(|p| {
            matches!(p, SurfacePoint::Edge { edge, t } if {
                let [a, b] = mesh.edge_vertices(*edge);
                (a == y && *t < 0.1) || (b == y && *t > 0.9)
            })
        })
        .count();
    assert!(near_y >= 1, "{name}: the grazing seam does not come near y");
    let opts = RemeshOptions::default();
    let r = insert_polylines(mesh, &lines, &opts).unwrap();
    let q = check(mesh, &lines, &r, opts.snap);
    // Shared start, snapped graze, vertex in the middle.
    assert_eq!(r.paths[0][0], v);
    assert_eq!(r.paths[1][0], v);
    assert!(r.paths[2].contains(&w));
    assert!(r.paths[3].contains(&y), "{name}: grazing seam not snapped onto {y}");
    let tol = 0.1 * max_edge(mesh) + 1e-12;
    for (line, path) in lines.iter().zip(&r.paths) {
        check_on_polyline(mesh, line, path, &r, tol);
    }
    // Inserted vertices are never within the snap distance of an edge end.
    for v in r.mesh.vertices().skip(mesh.n_vertices()) {
        if let SurfacePoint::Edge { t, .. } = r.vertex_parent[v] {
            assert!((0.1..=0.9).contains(&t));
        }
    }
    // Deterministic.
    let r2 = insert_polylines(mesh, &lines, &opts).unwrap();
    assert_eq!(r.mesh.faces().as_slice(), r2.mesh.faces().as_slice());
    assert_eq!(r.paths, r2.paths);
    let inserted = r.mesh.n_vertices() - mesh.n_vertices();
    println!(
        "{name}: {} points, {inserted} inserted vertices, {} -> {} faces, min angle new {:.2}° \
         (touched input faces {:.2}°, whole input {:.2}°), hausdorff {:.1e}",
        lines.iter().map(Vec::len).sum::<usize>(),
        mesh.n_faces(),
        r.mesh.n_faces(),
        q.min_new,
        q.min_touched_input,
        mesh.min_angle().to_degrees(),
        q.hausdorff
    );
    q
}

fn extreme(mesh: &Mesh, key: impl Fn(Vec3) -> f64) -> VertexId {
    mesh.vertices().max_by(|&a, &b| key(mesh.position(a)).total_cmp(&key(mesh.position(b)))).unwrap()
}

#[test]
fn seams_on_icosphere() {
    let m = shapes::icosphere(3, 1.0);
    let v = extreme(&m, |p| p.z);
    let w = extreme(&m, |p| -p.z);
    let y = extreme(&m, |p| p.x + 0.1 * p.y);
    let q = curved_case("icosphere", &m, v, w, y, 10);
    assert!(q.min_new >= 3.0, "min angle {}", q.min_new);
}

#[test]
fn seams_on_bunny() {
    let m = data("closed/bunny.obj");
    let c = m.bbox().center();
    // Three vertices in different regions of the body.
    let v = extreme(&m, |p| -(p - (c + Vec3::new(0.0, 0.0, 0.3) * m.bbox().extent().z)).norm());
    let w = extreme(&m, |p| -(p - (c - Vec3::new(0.3, 0.0, 0.0) * m.bbox().extent().x)).norm());
    let y = extreme(&m, |p| -(p - (c + Vec3::new(0.3, 0.0, 0.0) * m.bbox().extent().x)).norm());
    let q = curved_case("bunny", &m, v, w, y, 20);
    // Bound: 3° or half the smallest angle of the input faces the seams cross.
    assert!(
        q.min_new >= 3f64.min(0.5 * q.min_touched_input),
        "min angle {} (input {})",
        q.min_new,
        q.min_touched_input
    );
}

#[test]
fn invalid_inputs_are_reported() {
    let m = shapes::icosphere(2, 1.0);
    let opts = RemeshOptions::default();
    let far = extreme(&m, |p| -p.z);
    let near = extreme(&m, |p| p.z);
    // Two vertices in no common face.
    let lines = vec![
        vec![SurfacePoint::Vertex(near), SurfacePoint::Vertex(m.vertex_neighbors(near)[0])],
        vec![SurfacePoint::Vertex(near), SurfacePoint::Vertex(far)],
    ];
    match insert_polylines(&m, &lines, &opts) {
        Err(LayoutError::InvalidPath { path, reason }) => {
            assert_eq!(path, 1);
            assert!(reason.contains("no common face"), "{reason}");
        }
        other => panic!("expected InvalidPath, got {:?}", other.err()),
    }
    // An edge point and a far edge.
    let e_far = m.edge(m.vertex_halfedge(far));
    let e_near = m.edge(m.vertex_halfedge(near));
    let lines = vec![vec![SurfacePoint::Edge { edge: e_near, t: 0.5 }, SurfacePoint::Edge { edge: e_far, t: 0.5 }]];
    assert!(matches!(insert_polylines(&m, &lines, &opts), Err(LayoutError::InvalidPath { path: 0, .. })));
    // Out of range, bad parameter, too short.
    let bad = [
        vec![SurfacePoint::Vertex(VertexId(u32::MAX - 1)), SurfacePoint::Vertex(near)],
        vec![SurfacePoint::Edge { edge: EdgeId(1 << 30), t: 0.5 }, SurfacePoint::Vertex(near)],
        vec![SurfacePoint::Edge { edge: e_near, t: 1.0 }, SurfacePoint::Vertex(near)],
        vec![SurfacePoint::Edge { edge: e_near, t: f64::NAN }, SurfacePoint::Vertex(near)],
        vec![SurfacePoint::Vertex(near)],
    ];
    for line in bad {
        assert!(matches!(insert_polylines(&m, &[line], &opts), Err(LayoutError::InvalidPath { path: 0, .. })));
    }
}

/// Plane sections through vertices spread along a generic direction: parallel planes, so the
/// seams never cross; each is walked until it comes back next to its start (or `max` faces).
fn parallel_slices(mesh: &Mesh, dir: Vec3, count: usize, max: usize) -> Vec<Vec<SurfacePoint>> {
    let dir = dir.normalize();
    let heights: Vec<f64> = mesh.vertices().map(|v| mesh.position(v).dot(&dir)).collect();
    let (lo, hi) = heights.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &h| (a.min(h), b.max(h)));
    let (u, _) = tangents(dir);
    (1..=count)
        .map(|i| {
            let target = lo + (hi - lo) * i as f64 / (count + 1) as f64;
            let v = mesh
                .vertices()
                .min_by(|&a, &b| (heights[a.idx()] - target).abs().total_cmp(&(heights[b.idx()] - target).abs()))
                .unwrap();
            let along = mesh.vertex_normals()[v].cross(&dir);
            let d = if along.norm() > 1e-3 { along } else { u };
            walk_from_vertex(mesh, v, dir, d, max)
        })
        .collect()
}

#[test]
fn parallel_slices_on_bunny_and_sphere() {
    for (name, mesh) in [("bunny", data("closed/bunny.obj")), ("icosphere", shapes::icosphere(4, 1.0))] {
        let lines = parallel_slices(&mesh, Vec3::new(0.31, 0.87, 0.38), 7, 2000);
        let opts = RemeshOptions::default();
        let r = insert_polylines(&mesh, &lines, &opts).unwrap();
        let q = check(&mesh, &lines, &r, opts.snap);
        let tol = 0.1 * max_edge(&mesh) + 1e-12;
        for (line, path) in lines.iter().zip(&r.paths) {
            check_on_polyline(&mesh, line, path, &r, tol);
        }
        println!(
            "{name} slices: {} points, {} -> {} faces, min angle new {:.2}° (touched input {:.2}°)",
            lines.iter().map(Vec::len).sum::<usize>(),
            mesh.n_faces(),
            r.mesh.n_faces(),
            q.min_new,
            q.min_touched_input
        );
        assert!(q.min_new >= 3f64.min(0.5 * q.min_touched_input), "{name}: min angle {}", q.min_new);
    }
}

#[test]
fn random_seams_one_at_a_time() {
    // Seeded random seams (vertex, direction), each remeshed alone: the worst angle over all.
    for (name, mesh) in [("bunny", data("closed/bunny.obj")), ("icosphere", shapes::icosphere(3, 1.0))] {
        let mut rng = clothcast_mesh::util::SplitMix64::new(7);
        let nv = mesh.vertex_normals();
        let (mut worst, mut worst_input) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..40 {
            let v = VertexId(rng.below(mesh.n_vertices()) as u32);
            let (u1, u2) = tangents(nv[v]);
            let a = rng.next_f64() * std::f64::consts::TAU;
            let d = u1 * a.cos() + u2 * a.sin();
            let line = walk_from_vertex(&mesh, v, nv[v].cross(&d).normalize(), d, 30);
            let opts = RemeshOptions::default();
            let r = insert_polylines(&mesh, std::slice::from_ref(&line), &opts).unwrap();
            let q = check(&mesh, std::slice::from_ref(&line), &r, opts.snap);
            worst = worst.min(q.min_new);
            worst_input = worst_input.min(q.min_touched_input);
        }
        println!("{name} random seams: worst min angle new {worst:.2}° (touched input {worst_input:.2}°)");
        assert!(worst >= 3f64.min(0.5 * worst_input), "{name}: min angle {worst}");
    }
}
