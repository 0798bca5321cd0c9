//! Flattening a whole segmentation (issue 6): no flips on any patch of the test meshes, the two
//! sides of every seam equal in length, orientation rules, area matching.

use clothcast_field::cross::connection;
use clothcast_field::synthesis::FieldSource;
use clothcast_field::{CrossField, FieldOptions, compute_field};
use clothcast_flatten::{FlattenOptions, Orientation, WarpAlong, flatten_segmentation};
use clothcast_layout::{LayoutOptions, Segmentation, segment};
use clothcast_mesh::io::read_mesh_file;
use clothcast_mesh::{FaceData, Mesh, Vec3, shapes};
use std::path::PathBuf;

fn data(rel: &str) -> Mesh {
    let p = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/meshes")).join(rel);
    Mesh::try_from_soup(&read_mesh_file(&p).unwrap()).unwrap()
}

fn segmented(m: &Mesh) -> Segmentation {
    let opts = FieldOptions { source: FieldSource::Curvature, ..Default::default() };
    let r = compute_field(m, None, &opts).unwrap();
    segment(m, &r.field, &r.singularities, &LayoutOptions::default()).unwrap()
}

#[test]
fn every_patch_flattens_without_flips_and_seams_match() {
    for (name, m) in [
        ("example", shapes::rounded_tetrahedron(0.5)),
        ("bunny", data("closed/bunny.obj")),
        ("fertility", data("closed/fertility.off")),
        ("camelhead", data("open/camelhead.ply")),
    ] {
        let seg = segmented(&m);
        let ones = FaceData::filled(seg.mesh.n_faces(), 1.0);
        let flat = flatten_segmentation(&seg, &ones, &seg.field_directions, &FlattenOptions::default()).unwrap();
        let r = &flat.report;
        eprintln!(
            "{name}: {} pieces, flips {}, bff area {:.4} scale {:.4}, qc {:.4}/{:.3}, mismatch {:.3}%, fibre {:.1}° (other {:.1}°)",
            flat.patches.len(),
            r.flipped_triangles,
            r.area_ratio_bff,
            r.area_scale,
            r.qc_mean,
            r.qc_max,
            100.0 * r.seam_length_mismatch_max_rel,
            r.fiber_alignment_median_deg,
            r.fiber_alignment_other_rule_deg
        );
        assert_eq!(flat.patches.len(), seg.patches.len());
        assert_eq!(r.flipped_triangles, 0, "{name}");
        assert!(flat.patches.iter().all(|p| p.stats.flipped_triangles == 0));
        // Every outline can be cut: simple (fertility's curvature-field layout has one piece whose
        // outline looped over itself and was uncurled, which costs its seams a little length).
        assert_eq!(r.outlines_not_simple, 0, "{name}");
        assert!(
            flat.patches.iter().all(|p| clothcast_flatten::outline_crossing(&p.uv, &p.outline).is_none()),
            "{name}"
        );
        // The outline closed by turning: both sides of a seam are its 3D edges' lengths (an
        // untangling that moves the outline may change them by up to 0.5%).
        let limit = if r.repaired_vertices > 0 { 0.005 } else { 1e-9 };
        assert!(
            r.seam_length_mismatch_max_rel <= limit,
            "{name}: seam sides differ by {} ({} outlines repaired)",
            r.seam_length_mismatch_max_rel,
            r.outlines_repaired
        );
        assert!(r.qc_mean < 1.05, "{name}: qc {}", r.qc_mean);
        // Every seam has exactly two sides among the pieces.
        let mut sides = vec![0; seg.seams.len()];
        for run in flat.runs.iter().flatten() {
            sides[run.seam] += 1;
        }
        assert!(sides.iter().all(|&k| k == 2), "{name}: seam sides {sides:?}");
        // Area matching: the pieces' total 2D area is the target's.
        let a2: f64 = flat.patches.iter().map(|p| p.stats.area_ratio * p.mesh.total_area()).sum();
        assert!((a2 / m.total_area() - 1.0).abs() < 1e-9, "{name}: area {a2} vs {}", m.total_area());
        // Every face of the target is on exactly one piece.
        let faces: usize = flat.patches.iter().map(|p| p.mesh.n_faces()).sum();
        assert_eq!(faces, seg.mesh.n_faces());
    }
}

/// Without area matching the seams keep their 3D lengths exactly (up to BFF's discretisation).
#[test]
fn without_area_matching_boundary_lengths_are_kept() {
    let m = shapes::rounded_tetrahedron(0.5);
    let seg = segmented(&m);
    let ones = FaceData::filled(seg.mesh.n_faces(), 1.0);
    let none = FaceData::filled(seg.mesh.n_faces(), Vec3::zeros());
    let flat =
        flatten_segmentation(&seg, &ones, &none, &FlattenOptions { match_area: false, ..Default::default() }).unwrap();
    assert_eq!(flat.report.area_scale, 1.0);
    assert!(flat.report.area_ratio_bff < 1.0, "a closed convex target flattens smaller");
    for p in &flat.patches {
        assert!(
            p.stats.boundary_length_error_max_rel < 2e-3,
            "patch {}: {}",
            p.patch,
            p.stats.boundary_length_error_max_rel
        );
    }
}

/// A flat 4 × 1 strip with a constant cross field at 30° to its long side, laid out as one patch.
fn strip_at_30_degrees() -> Segmentation {
    let m = shapes::grid(40, 10, 4.0, 1.0);
    let rho = connection(&m);
    let world = Vec3::new(30f64.to_radians().cos(), 30f64.to_radians().sin(), 0.0);
    let theta: FaceData<f64> = m.face_ids().map(|f| m.face_frame(f).angle_of(&world)).collect();
    let field = CrossField::from_angles(&m, &rho, theta);
    let seg = segment(&m, &field, &[], &LayoutOptions::default()).unwrap();
    assert_eq!(seg.patches.len(), 1);
    seg
}

/// On a flat patch with a constant field at 30°, the field rule turns the piece so that the
/// fibres follow the field exactly; the side rule aligns the longest side of a long rectangle.
#[test]
fn orientation_rules() {
    let seg = strip_at_30_degrees();
    let ones = FaceData::filled(seg.mesh.n_faces(), 1.0);
    let major = &seg.field_directions;
    let by_field = flatten_segmentation(&seg, &ones, major, &FlattenOptions::default()).unwrap();
    assert!(by_field.report.fiber_alignment_median_deg < 1e-6, "{}", by_field.report.fiber_alignment_median_deg);
    let by_side = flatten_segmentation(
        &seg,
        &ones,
        major,
        &FlattenOptions { orientation: Orientation::LongestSide, ..Default::default() },
    )
    .unwrap();
    // The 4 × 1 rectangle's long side lies along a fibre, so the field (at 30°) is 30° off.
    let p = &by_side.patches[0];
    let (mut lo, mut hi) =
        (clothcast_mesh::Vec2::repeat(f64::INFINITY), clothcast_mesh::Vec2::repeat(f64::NEG_INFINITY));
    for v in p.mesh.vertices() {
        lo = lo.inf(&p.uv[v]);
        hi = hi.sup(&p.uv[v]);
    }
    let ext = hi - lo;
    assert!((ext.x.max(ext.y) - 4.0).abs() < 1e-6 && (ext.x.min(ext.y) - 1.0).abs() < 1e-6, "extent {ext}");
    assert!((by_side.report.fiber_alignment_median_deg - 30.0).abs() < 1e-6);
}

/// Which fibre runs along the major direction: on a flat strip with a constant cross field at
/// 30°, whose major direction is the arm at 120°, the warp follows that arm with "major" (a
/// quarter turn more than the orientation rule alone gives), the weft with "minor"; "either"
/// keeps the rule's turn, which here puts the 30° arm on the warp. Without a major direction
/// the share is 0.5 and the turn is the rule's.
#[test]
fn warp_runs_along_the_major_direction() {
    let seg = strip_at_30_degrees();
    let b = 120f64.to_radians();
    let n = seg.mesh.n_faces();
    let ones = FaceData::filled(n, 1.0);
    // Either sign of the direction means the same.
    let major: FaceData<Vec3> =
        (0..n).map(|i| Vec3::new(b.cos(), b.sin(), 0.0) * if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
    let run = |rule: WarpAlong, major: &FaceData<Vec3>| {
        let flat = flatten_segmentation(&seg, &ones, major, &FlattenOptions { warp_along: rule, ..Default::default() })
            .unwrap();
        assert!(flat.report.fiber_alignment_median_deg < 1e-6, "the fibres follow the field");
        assert_eq!(flat.report.warp_along, Some(rule));
        let p = &flat.patches[0];
        // The grid's x axis in the piece: from its lowest-left vertex to the farthest one on
        // the same row (the flat strip flattens isometrically, up to the common scale).
        let at = |v: clothcast_mesh::VertexId| p.mesh.position(v);
        let v0 = p.mesh.vertices().min_by(|&u, &w| (at(u).y, at(u).x).partial_cmp(&(at(w).y, at(w).x)).unwrap());
        let v0 = v0.unwrap();
        let v1 = p.mesh.vertices().filter(|&v| (at(v).y - at(v0).y).abs() < 1e-12);
        let v1 = v1.max_by(|&u, &w| at(u).x.total_cmp(&at(w).x)).unwrap();
        let x_axis = (p.uv[v1] - p.uv[v0]).normalize();
        let turn = x_axis.y.atan2(x_axis.x);
        let on_piece = (turn + b).cos().abs();
        (flat.report.major_on_warp_share, p.rotation, on_piece)
    };
    let (share, rot_major, cos_major) = run(WarpAlong::Major, &major);
    assert!((share - 1.0).abs() < 1e-12, "{share}");
    assert!((cos_major - 1.0).abs() < 1e-6, "the major direction on the warp: |cos| {cos_major}");
    let (share, rot_minor, cos_minor) = run(WarpAlong::Minor, &major);
    assert!(share.abs() < 1e-12, "{share}");
    assert!(cos_minor < 1e-3, "the major direction on the weft: |cos| {cos_minor}");
    let (share, rot_either, _) = run(WarpAlong::Either, &major);
    assert_eq!(share, 0.0, "the rule's own turn puts the 30° arm on the warp");
    assert_eq!(rot_either, rot_minor);
    assert!(((rot_major - rot_either).abs() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    // No major direction anywhere: the rule's turn, share 0.5.
    let none = FaceData::filled(n, Vec3::zeros());
    let (share, rot, _) = run(WarpAlong::Major, &none);
    assert_eq!((share, rot), (0.5, rot_either));
}

/// A patch whose BFF outline loops over itself (one piece of the built-in segmentation of
/// bob_small at 0.5 m: three sharp boundary corners in a row; every triangle positive) is
/// flattened with a simple outline by uncurling the looping stretch of its boundary, with no
/// flipped triangle and its boundary lengths within a few percent.
#[test]
fn a_self_crossing_outline_is_made_simple() {
    let m = data("derived/bob_pinched_patch.obj");
    let plain = clothcast_flatten::bff_flatten(&m, &clothcast_flatten::BffOptions::default()).unwrap();
    let outline: Vec<_> = m.boundary_loops()[0].iter().map(|&h| m.tail(h)).collect();
    assert_eq!(plain.stats.flipped_triangles, 0);
    assert!(
        clothcast_flatten::outline_crossing(&plain.uv, &outline).is_some(),
        "the patch's plain BFF outline crosses itself (what this test is about)"
    );
    let piece =
        clothcast_flatten::flatten_piece(&m, &clothcast_flatten::BffOptions::default(), &Default::default()).unwrap();
    let s = &piece.flattening.stats;
    println!("{:?}: {s:?}", piece.outline_repair);
    assert!(piece.outline_simple);
    assert!(
        matches!(piece.outline_repair, Some(clothcast_flatten::OutlineRepair::Uncurled(_))),
        "{:?}",
        piece.outline_repair
    );
    assert_eq!(piece.outline, outline);
    assert!(clothcast_flatten::outline_crossing(&piece.flattening.uv, &outline).is_none());
    assert_eq!(s.flipped_triangles, 0);
    assert!(s.boundary_length_error_max_rel < 0.05, "{s:?}");
    // A piece that needs nothing is left as BFF made it.
    let grid = shapes::grid(8, 6, 0.4, 0.3);
    let fine = clothcast_flatten::flatten_piece(&grid, &Default::default(), &Default::default()).unwrap();
    let direct = clothcast_flatten::bff_flatten(&grid, &Default::default()).unwrap();
    assert!(fine.outline_simple && fine.outline_repair.is_none() && !fine.retried);
    assert_eq!(fine.flattening.uv, direct.uv);
}

/// The last-resort flattening of a piece whose outline no re-flattening makes simple: on a
/// sheared, curved open cylinder (a disk once cut), every triangle positive, the outline simple
/// with the margin, its perimeter kept to the chord-against-arc error.
#[test]
fn the_convex_fallback_is_simple_and_unfolded() {
    let cyl = shapes::cylinder(0.2, 0.3, 24, 8, false, false);
    // Cut the cylinder open along the faces of one column: keep a disk (the faces away from
    // angle 0).
    let keep: Vec<clothcast_mesh::FaceId> = cyl
        .face_ids()
        .filter(|&f| {
            let c = cyl.face_vertices(f).map(|v| cyl.position(v)).iter().fold(Vec3::zeros(), |a, p| a + p) / 3.0;
            c.y.atan2(c.x).abs() > 0.2
        })
        .collect();
    let pm = clothcast_mesh::submesh::extract_submesh(&cyl, &keep).unwrap().mesh;
    assert_eq!(pm.boundary_loops().len(), 1);
    let outline: Vec<clothcast_mesh::VertexId> = pm.boundary_loops()[0].iter().map(|&h| pm.tail(h)).collect();
    let flat = clothcast_flatten::convex_flattening(&pm, &outline).expect("a disk flattens");
    assert_eq!(flat.stats.flipped_triangles, 0, "{:?}", flat.stats);
    assert!(flat.stats.area_ratio_min > 0.0);
    assert!(clothcast_flatten::outline_crossing(&flat.uv, &outline).is_none());
    let n = outline.len();
    let len3: f64 = (0..n).map(|k| (pm.position(outline[(k + 1) % n]) - pm.position(outline[k])).norm()).sum();
    let len2: f64 = (0..n).map(|k| (flat.uv[outline[(k + 1) % n]] - flat.uv[outline[k]]).norm()).sum();
    assert!((len2 / len3 - 1.0).abs() < 0.01, "{len2} vs {len3}");
}

/// The pieces are flattened in parallel: the result must not depend on the number of threads
/// (the untangling's own parallel tries are tested in `untangle.rs`).
#[test]
fn the_result_does_not_depend_on_the_thread_count() {
    let seg = segmented(&data("closed/fertility.off"));
    let ones = FaceData::filled(seg.mesh.n_faces(), 1.0);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut flat = pool
            .install(|| flatten_segmentation(&seg, &ones, &seg.field_directions, &FlattenOptions::default()))
            .unwrap();
        flat.report.seconds = 0.0;
        let pieces: Vec<String> =
            flat.patches.iter().map(|p| format!("{:?} {:?} {} {:?}", p.uv, p.outline, p.rotation, p.stats)).collect();
        (pieces, format!("{:?} {:?}", flat.runs, flat.report))
    };
    assert_eq!(run(1), run(4));
}
