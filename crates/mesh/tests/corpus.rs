//! Corpus tests: real meshes copied into `data/meshes` (credits in `data/meshes/CREDITS.md`)
//! give the topology figures of the shared collection's SOURCES.md, and every broken file gives
//! its typed error naming the elements.

use clothcast_mesh::io::read_mesh_file;
use clothcast_mesh::repair::{RepairOptions, prepare};
use clothcast_mesh::{Mesh, MeshError, Problem, analyze};
use std::f64::consts::PI;
use std::path::PathBuf;

fn data(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/meshes")).join(rel)
}

/// (file, V, F, components, boundary loops, χ, genus)
const GOOD: &[(&str, usize, usize, usize, usize, i64, i64)] = &[
    ("closed/fertility.off", 4494, 9000, 1, 0, -6, 4),
    ("closed/bunny.obj", 3301, 6598, 1, 0, 2, 0),
    ("closed/spot.ply", 11533, 23062, 1, 0, 2, 0),
    ("closed/spot_low_resolution.obj", 829, 1654, 1, 0, 2, 0),
    ("closed/sphere.obj", 642, 1280, 1, 0, 2, 0),
    ("closed/torus.obj", 2304, 4608, 1, 0, 0, 1),
    ("closed/cube.obj", 26, 48, 1, 0, 2, 0),
    ("closed/cylinder.obj", 220, 436, 1, 0, 2, 0),
    ("closed/xcylinder.obj", 42, 80, 1, 0, 2, 0),
    ("closed/tet.obj", 4, 4, 1, 0, 2, 0),
    ("closed/bob_small.ply", 250, 500, 1, 0, 0, 1),
    ("open/camelhead.ply", 11381, 22704, 1, 1, 1, 0),
    ("open/cube_no_bottom.obj", 25, 40, 1, 1, 1, 0),
    ("open/hemisphere.off", 1861, 3600, 1, 1, 1, 0),
    ("open/dome.off", 5000, 9635, 1, 1, 1, 0),
    ("multi/wooden_table_02.obj", 120, 196, 5, 4, 6, 0),
    ("multi/painted_wooden_stool.obj", 384, 676, 13, 20, 6, 0),
    ("multi/platonic_shelf.obj", 50, 80, 5, 0, 10, 0),
    ("handmade/cube_binary.stl", 26, 48, 1, 0, 2, 0),
    ("handmade/tet_ascii.stl", 4, 4, 1, 0, 2, 0),
];

#[test]
fn topology_figures_match_sources() {
    for &(file, v, f, c, b, chi, g) in GOOD {
        let soup = read_mesh_file(&data(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        let a = analyze(&soup);
        assert_eq!(
            (a.referenced_vertices, a.faces, a.components, a.boundary_loops, a.euler_characteristic, a.genus),
            (v, f, c, Some(b), chi, Some(g)),
            "{file}"
        );
        let blocking: Vec<_> = a.blocking_problems().collect();
        assert!(blocking.is_empty(), "{file}: {blocking:?}");
        // The halfedge mesh agrees with the soup analysis.
        let m = Mesh::try_from_soup(&soup).unwrap();
        assert_eq!((m.n_vertices(), m.n_faces(), m.n_components()), (v, f, c), "{file}");
        assert_eq!((m.euler_characteristic(), m.genus(), m.boundary_loops().len()), (chi, g, b), "{file}");
    }
}

#[test]
fn gauss_bonnet_on_real_meshes() {
    for &(file, ..) in GOOD {
        let m = Mesh::try_from_soup(&read_mesh_file(&data(file)).unwrap()).unwrap();
        let total: f64 = m.angle_defects().iter().sum::<f64>() + m.boundary_turning().iter().sum::<f64>();
        let expect = 2.0 * PI * m.euler_characteristic() as f64;
        assert!((total - expect).abs() < 1e-8 * m.n_vertices() as f64, "{file}: {total} vs {expect}");
    }
}

#[test]
fn cotan_laplacian_invariants_on_real_meshes() {
    for file in ["closed/fertility.off", "open/camelhead.ply", "closed/bob_small.ply"] {
        let m = Mesh::try_from_soup(&read_mesh_file(&data(file)).unwrap()).unwrap();
        let l = m.cotan_laplacian();
        let lt = l.as_ref().transpose().to_col_major().unwrap();
        let ones = faer::Col::<f64>::ones(m.n_vertices());
        let l1 = l.as_ref() * &ones;
        let scale = m.cotan_weights().iter().map(|w| w.abs()).fold(0.0, f64::max);
        assert!(l1.norm_max() < 1e-12 * scale, "{file}: |L·1| = {}", l1.norm_max());
        let diff = (&l - &lt).val().iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert_eq!(diff, 0.0, "{file}: L not symmetric");
    }
}

fn expect_invalid(file: &str, pred: impl Fn(&Problem) -> bool, what: &str) {
    let soup = read_mesh_file(&data(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
    match Mesh::try_from_soup(&soup) {
        Err(MeshError::Invalid { problems }) => {
            assert!(problems.iter().any(&pred), "{file}: no {what} among {problems:?}");
            let msg = MeshError::Invalid { problems }.to_string();
            assert!(msg.contains("invalid mesh"), "{msg}");
        }
        other => panic!("{file}: expected an invalid-mesh error, got {other:?}"),
    }
}

#[test]
fn broken_corpus_gives_typed_errors() {
    expect_invalid(
        "broken/fan3.obj",
        |p| matches!(p, Problem::NonManifoldEdge { faces, .. } if faces.len() == 3),
        "non-manifold edge with 3 faces",
    );
    expect_invalid(
        "broken/hourglass_ico.obj",
        |p| matches!(p, Problem::NonManifoldVertex { fans: 2, .. }),
        "non-manifold vertex",
    );
    expect_invalid("broken/moebius.obj", |p| matches!(p, Problem::NonOrientable { .. }), "non-orientable");
    expect_invalid("broken/triple_vierbein.obj", |p| matches!(p, Problem::NonManifoldEdge { .. }), "non-manifold edge");
    expect_invalid("broken/truck.obj", |p| matches!(p, Problem::NonManifoldEdge { .. }), "non-manifold edge");
    expect_invalid("broken/teapot.obj", |p| matches!(p, Problem::NonManifoldVertex { .. }), "non-manifold vertex");
    expect_invalid("broken/suzanne.obj", |p| matches!(p, Problem::DuplicateFace { .. }), "duplicate face");
    expect_invalid("broken/sofa_03.obj", |p| matches!(p, Problem::DuplicateFace { .. }), "duplicate face");
    expect_invalid(
        "handmade/nan_coordinate.obj",
        |p| matches!(p, Problem::NonFiniteCoordinate { vertex } if vertex.0 == 2),
        "NaN at vertex 2",
    );

    // Counts of the shared SOURCES.md for the broken files.
    let count = |file: &str, kind: &str| {
        analyze(&read_mesh_file(&data(file)).unwrap()).problems.iter().filter(|p| p.kind() == kind).count()
    };
    assert_eq!(count("broken/triple_vierbein.obj", "non_manifold_edge"), 20);
    assert_eq!(count("broken/truck.obj", "non_manifold_edge"), 54);
    assert_eq!(count("broken/teapot.obj", "non_manifold_vertex"), 38);
    assert_eq!(count("broken/hourglass_ico.obj", "non_manifold_vertex"), 1);
    assert_eq!(count("broken/fan3.obj", "non_manifold_vertex"), 0);
    assert_eq!(count("broken/suzanne.obj", "duplicate_face"), 1);
    assert_eq!(count("broken/sofa_03.obj", "duplicate_face"), 1);
}

#[test]
fn read_errors_name_file_line_and_element() {
    let err = |f: &str| read_mesh_file(&data(f)).unwrap_err();
    assert!(matches!(err("handmade/empty.obj"), MeshError::EmptyFile { .. }));
    assert!(matches!(err("handmade/blank.off"), MeshError::EmptyFile { .. }));
    let e = err("handmade/index_out_of_range.obj");
    assert!(matches!(e, MeshError::IndexOutOfRange { index: 9, vertices: 3, face: 1, line: Some(5), .. }), "{e:?}");
    assert!(e.to_string().contains("index_out_of_range.obj:5"), "{e}");
    let e = err("handmade/negative_index.off");
    assert!(matches!(e, MeshError::IndexOutOfRange { index: -1, .. }), "{e:?}");
    let e = err("handmade/garbage.obj");
    assert!(matches!(e, MeshError::Malformed { line: Some(1), .. }), "{e:?}");
    let e = err("handmade/garbage.ply");
    assert!(matches!(e, MeshError::Malformed { line: Some(5), .. }), "{e:?}");
    // The offending header line quoted, not the parser's grammar.
    assert!(e.to_string().contains("`property flot y`") && !e.to_string().contains("ExpectedSet"), "{e}");
    assert!(matches!(err("handmade/truncated_binary.ply"), MeshError::Truncated { .. }));
    assert!(matches!(err("handmade/truncated_binary.stl"), MeshError::Truncated { .. }));
    assert!(matches!(err("broken/sofa_03_1k.gltf"), MeshError::UnknownFormat { .. }));
    assert!(matches!(err("handmade/does_not_exist.obj"), MeshError::Io { .. }));
}

#[test]
fn repair_fixes_what_it_can_and_refuses_the_rest() {
    let opts = RepairOptions { repair: true, ..Default::default() };
    let prep = |f: &str, o: &RepairOptions| prepare(&read_mesh_file(&data(f)).unwrap(), o);

    // Flipped closed tetrahedron: reoriented outward.
    let p = prep("handmade/tet_inward.obj", &opts).unwrap();
    assert_eq!(p.report.faces_flipped, 4);
    assert!(p.mesh.signed_volume() > 0.0);

    // Hourglass: split into two spheres, then refused as two components unless asked.
    assert!(matches!(prep("broken/hourglass_ico.obj", &opts), Err(MeshError::Invalid { .. })));
    let both = RepairOptions { repair: true, largest_component: true, ..Default::default() };
    let p = prep("broken/hourglass_ico.obj", &both).unwrap();
    assert_eq!(p.report.non_manifold_vertices_split, 1);
    assert_eq!(p.report.components_removed, 1);
    assert_eq!(p.mesh.euler_characteristic(), 2);

    // NaN vertex: its faces dropped (an open tet remains), then usable.
    let p = prep("handmade/nan_coordinate.obj", &opts).unwrap();
    assert_eq!(p.report.faces_with_non_finite_vertices_removed, 3);
    assert_eq!(p.mesh.n_faces(), 1);

    // Non-manifold edges and non-orientable surfaces stay refused.
    for f in ["broken/fan3.obj", "broken/moebius.obj", "broken/triple_vierbein.obj"] {
        assert!(prep(f, &both).is_err(), "{f}");
    }

    // What remains after repair is named in the input file's numbering: suzanne's duplicate
    // face goes and its seams are welded (renumbering faces and vertices), and the
    // non-manifold edge left is the one the unrepaired analysis names.
    let soup = read_mesh_file(&data("broken/suzanne.obj")).unwrap();
    let before = analyze(&soup).problems;
    let nm = |ps: &[Problem]| ps.iter().find(|p| p.kind() == "non_manifold_edge").cloned();
    let Err(MeshError::Invalid { problems }) = prepare(&soup, &opts) else { panic!("suzanne was accepted") };
    let (a, b) = (nm(&before).expect("before"), nm(&problems).expect("after"));
    assert_eq!(a.to_string(), b.to_string());

    // Multi-component meshes: refused by default, the largest kept when asked.
    assert!(prep("multi/platonic_shelf.obj", &RepairOptions::default()).is_err());
    let p = prep("multi/platonic_shelf.obj", &RepairOptions { largest_component: true, ..Default::default() }).unwrap();
    assert_eq!(p.mesh.n_components(), 1);
    assert_eq!(p.report.components_removed, 4);

    // A clean mesh is untouched by --repair (same vertex and face order).
    let soup = read_mesh_file(&data("closed/bunny.obj")).unwrap();
    let p = prepare(&soup, &opts).unwrap();
    assert!(p.report.is_empty(), "{:?}", p.report);
    assert_eq!(p.mesh.positions().as_slice(), soup.positions.as_slice());
}
