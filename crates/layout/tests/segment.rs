//! Segmentation tests (issue 5): tracing follows the field, T-junctions, the cube layout of a
//! sphere, disks on genus 1 and 4, seams as edge paths closing into patch boundaries, remeshing
//! keeps the surface without slivers, determinism.

use clothcast_field::cross::connection;
use clothcast_field::synthesis::FieldSource;
use clothcast_field::{CrossField, FieldOptions, Singularity, compute_field};
use clothcast_layout::patches::edge_between;
use clothcast_layout::trace::{SeparatrixEnd, TraceOptions, trace_separatrices};
use clothcast_layout::vertex_field::VertexField;
use clothcast_layout::{LayoutOptions, Segmentation, segment};
use clothcast_mesh::io::read_mesh_file;
use clothcast_mesh::{FaceData, Mesh, Vec3, VertexId, shapes};
use std::collections::BTreeSet;
use std::path::PathBuf;

fn data(rel: &str) -> Mesh {
    let p = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/meshes")).join(rel);
    Mesh::try_from_soup(&read_mesh_file(&p).unwrap()).unwrap()
}

/// A constant world direction as a cross field (projected on every face).
fn constant_field(mesh: &Mesh, world: Vec3) -> CrossField {
    let rho = connection(mesh);
    let theta: FaceData<f64> = mesh.face_ids().map(|f| mesh.face_frame(f).angle_of(&world)).collect();
    CrossField::from_angles(mesh, &rho, theta)
}

/// The curvature cross field of a mesh (smoothed and relaxed like the strain field).
fn curvature_field(mesh: &Mesh) -> (CrossField, Vec<Singularity>) {
    let opts = FieldOptions { source: FieldSource::Curvature, ..Default::default() };
    let r = compute_field(mesh, None, &opts).unwrap();
    (r.field, r.singularities)
}

/// The cube's cross field on a sphere: on the region nearest to each cube face, the directions
/// of the cube face's grid lines projected on the tangent plane. It is the smoothest cross field
/// with the cube's symmetry; singular (valence 3) at the 8 cube corners.
fn cube_field(mesh: &Mesh) -> (CrossField, Vec<Singularity>) {
    let rho = connection(mesh);
    let theta: FaceData<f64> = mesh
        .face_ids()
        .map(|f| {
            let c = mesh.face_centroid(f);
            let a = (0..3).max_by(|&i, &j| c[i].abs().total_cmp(&c[j].abs())).unwrap();
            let mut e = Vec3::zeros();
            e[(a + 1) % 3] = 1.0;
            mesh.face_frame(f).angle_of(&e)
        })
        .collect();
    let field = CrossField::from_angles(mesh, &rho, theta);
    let sing = field.singularities(mesh, &rho);
    (field, sing)
}

/// Every patch a disk, every singularity on a seam, every seam an edge path, and the seams are
/// exactly the edges between different patches (plus self-seams).
fn check_valid(name: &str, seg: &Segmentation) {
    let s = &seg.stats;
    assert_eq!(s.disks, s.patches, "{name}: not all patches are disks");
    assert!(seg.patches.iter().all(|p| p.euler == 1 && p.loops == 1), "{name}");
    assert_eq!(s.singularities_inside_patches, 0, "{name}: singularity inside a patch");
    let m = &seg.mesh;
    let mut seam_edges = BTreeSet::new();
    for (i, sm) in seg.seams.iter().enumerate() {
        assert!(sm.vertices.len() >= 2, "{name}: seam {i} too short");
        for w in sm.vertices.windows(2) {
            let e = edge_between(m, w[0], w[1]).unwrap_or_else(|| panic!("{name}: seam {i} is not an edge path"));
            assert!(seam_edges.insert(e), "{name}: edge {e:?} in two seams");
            let (a, b) = m.edge_faces(e);
            let pa = seg.patch_of_face[a];
            let pb = b.map(|b| seg.patch_of_face[b]).unwrap_or(pa);
            let mut got = [pa, pb];
            let mut want = sm.patches;
            got.sort_unstable();
            want.sort_unstable();
            assert_eq!(got, want, "{name}: seam {i} names the wrong patches");
        }
    }
    for e in m.edges() {
        if let (a, Some(b)) = m.edge_faces(e)
            && seg.patch_of_face[a] != seg.patch_of_face[b]
        {
            assert!(seam_edges.contains(&e), "{name}: edge between patches {e:?} is on no seam");
        }
    }
}

fn report(name: &str, seg: &Segmentation) {
    let s = &seg.stats;
    eprintln!(
        "{name}: {} patches, quad {:.2}, corners {:?}, dev {:.1}°, dmax {:.2}, merges {}, splits {}, straightened {}, min angle new {:.1}° (input {:.1}°)",
        s.patches,
        s.quad_fraction,
        s.corners,
        s.seam_field_deviation_median_deg,
        s.developability_max,
        s.merges,
        s.splits,
        s.straightened,
        s.min_angle_new_deg,
        s.min_angle_input_deg
    );
}

/// On an open cylinder with the field along its axis, a separatrix runs straight along a
/// generator (or a circle) to the rim: every step is aligned with the field.
#[test]
fn tracing_follows_the_field_on_a_cylinder() {
    let m = shapes::cylinder(1.0, 3.0, 32, 30, false, false);
    let field = constant_field(&m, Vec3::z());
    let vf = VertexField::from_face_field(&m, &field);
    let dirs = field.directions(&m);
    // A fake index-3 "singularity" half-way up emits exactly one separatrix.
    let c =
        m.vertices().min_by(|a, b| (m.position(*a).z - 1.5).abs().total_cmp(&(m.position(*b).z - 1.5).abs())).unwrap();
    let seps = trace_separatrices(&m, &vf, &dirs, &[Singularity { vertex: c, index: 3 }], &TraceOptions::default());
    assert_eq!(seps.len(), 1);
    let p = &seps[0];
    assert_eq!(p.end, SeparatrixEnd::Boundary);
    for w in p.vertices.windows(2) {
        let d = m.position(w[1]) - m.position(w[0]);
        let along_axis = d.x.abs() < 1e-9 && d.y.abs() < 1e-9;
        let around = d.z.abs() < 1e-9;
        assert!(along_axis || around, "step {d} deviates from the field");
    }
}

/// A separatrix that meets an earlier one across it stops there (a T-junction), arriving at
/// about 90°.
#[test]
fn separatrices_stop_at_t_junctions() {
    let m = shapes::grid(30, 30, 1.0, 1.0);
    let field = constant_field(&m, Vec3::x());
    let vf = VertexField::from_face_field(&m, &field);
    let dirs = field.directions(&m);
    let id = |i: u32, j: u32| VertexId(j * 31 + i);
    // Two index-2 "singularities" (two opposite separatrices each) on different rows and
    // columns: whichever way they go, lines through both cross, so one must end in a T.
    let sing = [Singularity { vertex: id(10, 12), index: 2 }, Singularity { vertex: id(18, 20), index: 2 }];
    for seed in 1..6 {
        let seps = trace_separatrices(&m, &vf, &dirs, &sing, &TraceOptions { seed, ..Default::default() });
        let ts: Vec<_> = seps.iter().filter(|s| matches!(s.end, SeparatrixEnd::TJunction(_))).collect();
        let lines: BTreeSet<(bool, i64)> = seps
            .iter()
            .map(|s| {
                let d = m.position(s.vertices[1]) - m.position(s.vertices[0]);
                let p = m.position(s.vertices[0]);
                if d.x.abs() > d.y.abs() {
                    (true, (p.y * 30.0).round() as i64)
                } else {
                    (false, (p.x * 30.0).round() as i64)
                }
            })
            .collect();
        let horizontal = lines.iter().any(|l| l.0);
        let vertical = lines.iter().any(|l| !l.0);
        if horizontal && vertical {
            assert!(!ts.is_empty(), "seed {seed}: crossing lines without a T-junction");
        }
        for t in ts {
            let SeparatrixEnd::TJunction(k) = t.end else { unreachable!() };
            let end = *t.vertices.last().unwrap();
            let before = t.vertices[t.vertices.len() - 2];
            let other = &seps[k];
            let i = other.vertices.iter().position(|&v| v == end).expect("ends on the other separatrix");
            let tangent = m.position(other.vertices[i + 1]) - m.position(other.vertices[i - 1]);
            let arrive = m.position(end) - m.position(before);
            let cos = arrive.dot(&tangent).abs() / (arrive.norm() * tangent.norm());
            assert!(cos < 0.1, "seed {seed}: T-junction at {cos:.2}");
        }
    }
}

#[test]
fn sphere_cube_field_gives_a_cube() {
    let m = shapes::cube_sphere(12, 1.0);
    let (field, sing) = cube_field(&m);
    assert_eq!(sing.len(), 8);
    assert!(sing.iter().all(|s| s.index == 1), "valence-3 corners");
    // Each face of the cube layout scores 4π/6 ≈ 2.09 < 2.5 (the default): no split, and no
    // merge (two faces would score 4.2).
    let seg = segment(&m, &field, &sing, &LayoutOptions::default()).unwrap();
    report("sphere", &seg);
    check_valid("sphere", &seg);
    assert_eq!(seg.stats.patches, 6);
    assert!(seg.stats.corners.iter().all(|&c| c == 4), "{:?}", seg.stats.corners);
    // The corners are the 8 singularities.
    let corners: BTreeSet<VertexId> = seg.patches.iter().flat_map(|p| p.corners.iter().copied()).collect();
    let singular: BTreeSet<VertexId> = sing.iter().map(|s| s.vertex).collect();
    assert_eq!(corners, singular);
    assert!((seg.stats.quad_fraction - 1.0).abs() < 1e-12);
}

/// Genus 1 (a torus, no seams from singularities at all with a perfect field) and genus 4
/// (fertility): extra cuts make every patch a disk.
#[test]
fn every_patch_is_a_disk_on_genus_1_and_4() {
    let torus = shapes::torus(2.0, 0.7, 48, 24);
    let field = constant_field(&torus, Vec3::z());
    let sing = field.singularities(&torus, &connection(&torus));
    let seg = segment(&torus, &field, &sing, &LayoutOptions::default()).unwrap();
    report("torus (constant field)", &seg);
    check_valid("torus", &seg);
    assert!(seg.stats.extra_cuts > 0);

    let fert = data("closed/fertility.off");
    assert_eq!(fert.genus(), 4);
    let (field, sing) = curvature_field(&fert);
    let seg = segment(&fert, &field, &sing, &LayoutOptions::default()).unwrap();
    report("fertility (curvature field)", &seg);
    check_valid("fertility", &seg);
}

/// Remeshing keeps the surface: every vertex lies on its parent face (Hausdorff distance at
/// round-off), the area is unchanged, and new triangles keep reasonable angles.
#[test]
fn remeshing_keeps_the_surface_without_slivers() {
    for (name, m) in [("bunny", data("closed/bunny.obj")), ("camelhead", data("open/camelhead.ply"))] {
        let (field, sing) = curvature_field(&m);
        let seg = segment(&m, &field, &sing, &LayoutOptions::default()).unwrap();
        report(name, &seg);
        check_valid(name, &seg);
        assert!(seg.stats.straightened, "{name}: seams not straightened");
        let diag = m.bbox().extent().norm();
        let r = &seg.mesh;
        let mut worst: f64 = 0.0;
        for f in r.face_ids() {
            let parent = seg.face_parent[f];
            let [a, b, c] = m.face_positions(parent);
            let n = (b - a).cross(&(c - a)).normalize();
            for p in r.face_positions(f) {
                worst = worst.max((p - a).dot(&n).abs());
            }
        }
        assert!(worst < 1e-9 * diag, "{name}: vertex off its parent face by {worst:e}");
        assert!((r.total_area() - m.total_area()).abs() < 1e-9 * m.total_area(), "{name}: area changed");
        let floor = 2.0f64.min(0.5 * seg.stats.min_angle_input_deg);
        assert!(seg.stats.min_angle_new_deg >= floor, "{name}: new triangle angle {:.2}°", seg.stats.min_angle_new_deg);
    }
}

#[test]
fn same_seed_same_segmentation_other_seeds_valid() {
    let m = data("closed/bunny.obj");
    let (field, sing) = curvature_field(&m);
    let opts = LayoutOptions::default();
    let a = segment(&m, &field, &sing, &opts).unwrap();
    let b = segment(&m, &field, &sing, &opts).unwrap();
    assert_eq!(a.patch_of_face.as_slice(), b.patch_of_face.as_slice());
    assert_eq!(a.mesh.positions().as_slice(), b.mesh.positions().as_slice());
    assert_eq!(a.seams.len(), b.seams.len());
    for (x, y) in a.seams.iter().zip(&b.seams) {
        assert_eq!(x.vertices, y.vertices);
    }
    for seed in [2, 3] {
        let s = segment(&m, &field, &sing, &LayoutOptions { seed, ..opts.clone() }).unwrap();
        check_valid(&format!("bunny seed {seed}"), &s);
    }
}

#[test]
fn late_repairs_never_lose_quads_and_gain_some() {
    // On real meshes with their curvature fields: the repairs on the final seams keep every
    // patch valid, never lower the share of quads, and raise it somewhere.
    let mut gained = Vec::new();
    for name in ["closed/spot.ply", "closed/bunny.obj", "closed/fertility.off"] {
        let m = data(name);
        let (field, sing) = curvature_field(&m);
        let with = segment(&m, &field, &sing, &LayoutOptions::default()).unwrap();
        let without =
            segment(&m, &field, &sing, &LayoutOptions { late_repairs: false, ..LayoutOptions::default() }).unwrap();
        check_valid(name, &with);
        let (q_with, q_without) = (with.stats.quad_fraction, without.stats.quad_fraction);
        eprintln!(
            "{name}: quads {:.2} ({} patches) with the late repairs, {:.2} ({}) without",
            q_with, with.stats.patches, q_without, without.stats.patches
        );
        assert!(q_with >= q_without, "{name}: the late repairs lost quads");
        gained.push(q_with > q_without);
    }
    assert!(gained.iter().any(|&g| g), "the late repairs changed nothing on any mesh");
}

/// The largest distance between two vertices of each patch (a lower bound of its extent).
fn patch_chords(seg: &Segmentation) -> Vec<f64> {
    let mut verts: Vec<BTreeSet<VertexId>> = vec![BTreeSet::new(); seg.stats.patches];
    for (f, &p) in seg.patch_of_face.enumerate() {
        verts[p as usize].extend(seg.mesh.face_vertices(f));
    }
    verts
        .iter()
        .map(|vs| {
            let ps: Vec<Vec3> = vs.iter().map(|&v| seg.mesh.position(v)).collect();
            let mut best = 0.0f64;
            for (i, a) in ps.iter().enumerate() {
                for b in &ps[i + 1..] {
                    best = best.max((a - b).norm());
                }
            }
            best
        })
        .collect()
}

/// Size limits (what makes pieces fit the fabric roll): with `max_patch_extent` the cube layout
/// of a sphere of radius 1 m is split until every patch's extent is within it; a split hint
/// then splits the patch holding its faces further, to its share of its extent.
#[test]
fn patches_are_split_to_the_size_limit_and_the_hints() {
    let mesh = shapes::icosphere(4, 1.0);
    let (field, sing) = cube_field(&mesh);
    let plain = segment(&mesh, &field, &sing, &LayoutOptions::default()).unwrap();
    check_valid("plain", &plain);
    let widest = patch_chords(&plain).into_iter().fold(0.0, f64::max);
    assert_eq!(plain.stats.size_splits, 0);
    // The six cube faces: each about 1.6 m across (a corner-to-corner chord).
    assert!(widest > 1.2, "{widest}");
    let limit = 1.0;
    let opts = LayoutOptions { max_patch_extent: limit, ..Default::default() };
    let small = segment(&mesh, &field, &sing, &opts).unwrap();
    check_valid("limited", &small);
    let chords = patch_chords(&small);
    println!(
        "{} patches, {} size splits, widest chord {:.3} m",
        small.stats.patches,
        small.stats.size_splits,
        chords.iter().fold(0.0f64, |a, &b| a.max(b))
    );
    assert!(small.stats.size_splits > 0 && small.stats.patches > plain.stats.patches);
    assert!(chords.iter().all(|&c| c <= limit), "{chords:?}");
    // A hint on the widest patch of the limited layout, at half its extent.
    let (p, _) = chords.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
    let own: Vec<_> = small.patch_of_face.enumerate().filter(|&(_, &q)| q as usize == p).map(|(f, _)| f).collect();
    let extent = clothcast_layout::patch_extent(&small.mesh, &own);
    let faces: Vec<_> = own.iter().map(|&f| small.face_parent[f]).collect();
    let hinted = LayoutOptions {
        split_hints: vec![clothcast_layout::SplitHint { faces: faces.clone(), max_extent: 0.5 * extent }],
        ..opts.clone()
    };
    let split = segment(&mesh, &field, &sing, &hinted).unwrap();
    check_valid("hinted", &split);
    println!(
        "hinted: {} patches ({} before), {} size splits",
        split.stats.patches, small.stats.patches, split.stats.size_splits
    );
    // The hinted faces now lie in several patches, and each patch the hint applies to (made
    // mostly of those faces, or holding most of them) is within half the extent, up to what
    // straightening the seams moved.
    let mut count: std::collections::BTreeMap<u32, (usize, usize)> = Default::default();
    for (f, &q) in split.patch_of_face.enumerate() {
        let e = count.entry(q).or_default();
        e.1 += 1;
        if faces.contains(&split.face_parent[f]) {
            e.0 += 1;
        }
    }
    let total: usize = count.values().map(|&(h, _)| h).sum();
    assert!(count.values().filter(|&&(h, _)| h > 0).count() >= 2, "{count:?}");
    for (&q, &(h, n)) in &count {
        if h == 0 || (2 * h < n && 2 * h < total) {
            continue;
        }
        let fs: Vec<_> = split.patch_of_face.enumerate().filter(|&(_, &r)| r == q).map(|(f, _)| f).collect();
        let e = clothcast_layout::patch_extent(&split.mesh, &fs);
        println!("patch {q}: {h} of {n} faces hinted, extent {e:.3} (hint {:.3})", 0.5 * extent);
        assert!(e <= 0.5 * extent * 1.15, "patch {q}: extent {e} against {}", 0.5 * extent);
    }
}

/// A vertex asked for in `cone_cuts` that lies inside a patch gets a dart (the cube layout of a
/// sphere: the vertex nearest a cube face's centre, in the middle of its patch): a seam from the
/// patch's boundary ending at the tip, both its sides the same patch, the patch count and
/// every patch a disk kept; nothing changes without the request.
#[test]
fn a_cone_cut_gives_the_tip_a_dart() {
    let mesh = shapes::icosphere(3, 1.0);
    let (field, sing) = cube_field(&mesh);
    let plain = segment(&mesh, &field, &sing, &LayoutOptions::default()).unwrap();
    check_valid("plain", &plain);
    assert_eq!(plain.stats.cone_cuts, 0);
    let tip = mesh.vertices().max_by(|&a, &b| mesh.position(a).z.total_cmp(&mesh.position(b).z)).unwrap();
    let on_seam = |seg: &Segmentation| seg.seams.iter().any(|s| s.vertices.contains(&tip));
    assert!(!on_seam(&plain), "the tip lies inside a patch");
    let cut = segment(&mesh, &field, &sing, &LayoutOptions { cone_cuts: vec![tip], ..Default::default() }).unwrap();
    check_valid("dart", &cut);
    assert_eq!((cut.stats.cone_cuts, cut.stats.darts), (1, true));
    assert_eq!(cut.stats.patches, plain.stats.patches);
    let dart: Vec<_> = cut.seams.iter().filter(|s| s.vertices.contains(&tip)).collect();
    assert_eq!(dart.len(), 1, "one seam reaches the tip");
    assert_eq!(dart[0].patches[0], dart[0].patches[1], "a self-seam");
    assert!(dart[0].vertices.first() == Some(&tip) || dart[0].vertices.last() == Some(&tip), "ending at the tip");
}

/// The cut through a tip, where a dart cannot be made: on a flat 8 × 8 grid with the field
/// along x, through the centre vertex along the field both ways to the boundary, two disks of
/// half the area each; a vertex on the boundary gets none.
#[test]
fn split_through_cuts_along_the_field_through_the_tip() {
    use clothcast_layout::patches::CornerRule;
    use clothcast_layout::split::split_through;
    let mesh = shapes::grid(8, 8, 1.0, 1.0);
    let vf = VertexField::from_face_field(&mesh, &constant_field(&mesh, Vec3::x()));
    let index = clothcast_mesh::VertexData::filled(mesh.n_vertices(), 0i32);
    let rule = CornerRule::new(&mesh, &index);
    let faces: Vec<_> = mesh.face_ids().collect();
    let centre = mesh.vertices().min_by(|&a, &b| {
        let d = |v: VertexId| (mesh.position(v) - Vec3::new(0.5, 0.5, 0.0)).norm();
        d(a).total_cmp(&d(b))
    });
    let centre = centre.unwrap();
    let opts = TraceOptions::default();
    let s = split_through(&mesh, &faces, &|_| 0, &|_| false, centre, &vf, &opts, &rule, 0.05).expect("a cut");
    assert!(s.info_a.is_disk() && s.info_b.is_disk());
    let area = |fs: &[clothcast_mesh::FaceId]| fs.iter().map(|&f| mesh.face_area(f)).sum::<f64>();
    assert!((area(&s.a) - 0.5).abs() < 1e-9 && (area(&s.b) - 0.5).abs() < 1e-9, "{} {}", area(&s.a), area(&s.b));
    let corner = VertexId::new(0);
    assert!(split_through(&mesh, &faces, &|_| 0, &|_| false, corner, &vf, &opts, &rule, 0.05).is_none());
}
