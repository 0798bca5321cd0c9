//! End-to-end tests of the `clothcast` binary: exit codes, messages, outputs.

mod common;
use common::*;

use serde_json::Value;

#[test]
fn run_builtin_example_writes_summary() {
    let out = tmpdir("run");
    let o = run(&["run", "-q", "-o", out.to_str().unwrap()]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let s: Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(s["input"]["path"], "built-in example");
    assert_eq!(s["input"]["euler_characteristic"], 2);
    assert_eq!(s["input"]["genus"], 0);
    for k in ["vertices", "faces", "components", "boundary_loops", "area_m2", "bbox_diagonal_m", "repairs"] {
        assert!(!s["input"][k].is_null(), "input.{k} missing");
    }
    assert_eq!(s["scenario"]["infill"]["density"], 1460.0);
    assert!(s["stages"]["input"]["seconds"].as_f64().unwrap() >= 0.0);
    assert!(s["seconds_total"].as_f64().unwrap() >= 0.0);
}

#[test]
fn check_reports_topology_as_json() {
    let o = run(&["check", "--json", data("closed/fertility.off").to_str().unwrap()]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    for k in [
        "vertices",
        "faces",
        "edges",
        "components",
        "boundary_loops",
        "euler_characteristic",
        "genus",
        "bbox_diagonal",
        "mean_edge_length",
        "min_angle_deg",
        "problems",
    ] {
        assert!(v.get(k).is_some(), "missing key {k}");
    }
    assert_eq!(
        (v["vertices"].as_u64(), v["faces"].as_u64(), v["edges"].as_u64()),
        (Some(4494), Some(9000), Some(13500))
    );
    assert_eq!((v["euler_characteristic"].as_i64(), v["genus"].as_i64()), (Some(-6), Some(4)));
    assert_eq!(v["problems"].as_array().unwrap().len(), 0);
    assert_eq!(v["usable"], true);
}

#[test]
fn check_broken_files_exit_2_naming_the_element() {
    let cases: &[(&str, &str)] = &[
        ("broken/fan3.obj", "non-manifold edge (2, 4) is shared by 3 faces (0, 1, 2)"),
        ("broken/hourglass_ico.obj", "non-manifold vertex 22"),
        ("broken/moebius.obj", "non-orientable surface"),
        ("broken/triple_vierbein.obj", "non-manifold edge"),
        ("broken/truck.obj", "non-manifold edge"),
        ("broken/teapot.obj", "non-manifold vertex"),
        ("broken/suzanne.obj", "face 270 duplicates face 269"),
        ("broken/sofa_03.obj", "duplicates face"),
        ("broken/sofa_03_1k.gltf", "unknown mesh format"),
        ("handmade/empty.obj", "the file is empty"),
        ("handmade/garbage.obj", "garbage.obj:1: unknown OBJ keyword"),
        (
            "handmade/index_out_of_range.obj",
            "index_out_of_range.obj:5: face 1 refers to vertex 9, but the file has 3 vertices",
        ),
        ("handmade/nan_coordinate.obj", "vertex 2 has a non-finite coordinate"),
        ("handmade/truncated_binary.ply", "truncated file"),
        ("handmade/truncated_binary.stl", "truncated file"),
        ("handmade/garbage.ply", "garbage.ply"),
        ("multi/platonic_shelf.obj", "5 connected components"),
    ];
    for (file, needle) in cases {
        let o = run(&["check", data(file).to_str().unwrap()]);
        assert_eq!(code(&o), 2, "{file}: {}", text(&o));
        assert!(text(&o).contains(needle), "{file}: expected {needle:?} in\n{}", text(&o));
        assert!(!text(&o).contains("panicked"), "{file}");
    }
    let o = run(&["check", "--json", data("broken/fan3.obj").to_str().unwrap()]);
    assert_eq!(code(&o), 2);
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["usable"], false);
    assert_eq!(v["problems"][0]["kind"], "non_manifold_edge");
    assert_eq!(v["problems"][0]["faces"], serde_json::json!([0, 1, 2]));
    assert!(v["boundary_loops"].is_null());
}

#[test]
fn check_with_repair_and_largest_component() {
    let o = run(&[
        "check",
        "--repair",
        "--largest-component",
        "--json",
        data("broken/hourglass_ico.obj").to_str().unwrap(),
    ]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["repairs"]["non_manifold_vertices_split"], 1);
    assert_eq!(v["after_repair"]["components"], 1);
    let o = run(&["check", "--repair", data("broken/moebius.obj").to_str().unwrap()]);
    assert_eq!(code(&o), 2, "{}", text(&o));
}

#[test]
fn run_refuses_bad_input_without_touching_outputs() {
    let out = tmpdir("bad");
    let summary = out.join("summary.json");
    std::fs::write(&summary, b"{\"previous\": true}").unwrap();
    for (file, needle) in [
        ("broken/fan3.obj", "non-manifold edge"),
        ("handmade/nan_coordinate.obj", "non-finite"),
        ("handmade/does_not_exist.obj", "cannot read"),
    ] {
        let o = run(&["run", "-q", data(file).to_str().unwrap(), "-o", out.to_str().unwrap()]);
        assert_eq!(code(&o), 2, "{file}: {}", text(&o));
        assert!(text(&o).contains(needle), "{file}: {}", text(&o));
    }
    assert_eq!(std::fs::read(&summary).unwrap(), b"{\"previous\": true}");
    // With --repair the NaN mesh becomes usable: an open surface remains, held at its rim.
    let cfg = out.join("rim.toml");
    std::fs::write(&cfg, "[suspension]\nmode = \"boundary\"\n").unwrap();
    let o = run(&[
        "run",
        "-q",
        "--repair",
        data("handmade/nan_coordinate.obj").to_str().unwrap(),
        "-c",
        cfg.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let s: Value = serde_json::from_slice(&std::fs::read(&summary).unwrap()).unwrap();
    assert_eq!(s["input"]["repairs"]["faces_with_non_finite_vertices_removed"], 3);
}

#[test]
fn config_errors_name_key_and_line() {
    let dir = tmpdir("cfg");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[material]\nyoungs_modulus = 1e5\npoison_ratio = 0.3\n").unwrap();
    let o = run(&["run", "-q", bad.to_str().unwrap(), "-o", dir.to_str().unwrap()]);
    assert_eq!(code(&o), 2);
    assert!(text(&o).contains("poison_ratio") && text(&o).contains("line 3"), "{}", text(&o));
    std::fs::write(&bad, "[infill]\ndensity = -3\n").unwrap();
    let o = run(&["run", "-q", "-c", bad.to_str().unwrap(), "-o", dir.to_str().unwrap()]);
    assert_eq!(code(&o), 2);
    assert!(text(&o).contains("bad.toml:2") && text(&o).contains("infill.density"), "{}", text(&o));
    // A mesh path relative to the config file, and CLI flags overriding the file.
    let good = dir.join("good.toml");
    std::fs::write(
        &good,
        format!("seed = 5\n[mesh]\npath = \"{}\"\nheight = 0.4\n", data("closed/torus.obj").display()),
    )
    .unwrap();
    let o = run(&["run", "-q", good.to_str().unwrap(), "--seed", "9", "-o", dir.to_str().unwrap()]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let s: Value = serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["scenario"]["seed"], 9);
    assert_eq!(s["input"]["genus"], 1);
}

#[test]
fn config_and_example_commands() {
    let o = run(&["config"]);
    assert_eq!(code(&o), 0);
    let t = String::from_utf8(o.stdout).unwrap();
    assert!(t.contains("[material]") && t.contains("youngs_modulus"));
    let dir = tmpdir("ex");
    let f = dir.join("example.obj");
    let o = run(&["example", "-q", "-o", f.to_str().unwrap()]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let o = run(&["check", "--json", f.to_str().unwrap()]);
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((v["faces"].as_u64(), v["genus"].as_i64(), v["components"].as_u64()), (Some(5120), Some(0), Some(1)));
    let o = run(&["example", "-o", dir.join("x.fbx").to_str().unwrap()]);
    assert_eq!(code(&o), 2);
}

#[test]
fn usage_errors_exit_2() {
    assert_eq!(code(&run(&["frobnicate"])), 2);
    assert_eq!(code(&run(&["check"])), 2);
    assert_eq!(code(&run(&["run", "--up", "sideways"])), 2);
    let o = run(&["--help"]);
    assert_eq!(code(&o), 0);
    assert!(text(&o).contains("fabric"));
}

#[test]
fn units_and_height_scale_the_mesh() {
    let dir = tmpdir("units");
    let o =
        run(&["run", "-q", data("closed/sphere.obj").to_str().unwrap(), "--units", "cm", "-o", dir.to_str().unwrap()]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let s: Value = serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    assert!((s["input"]["bbox_diagonal_m"].as_f64().unwrap() - 0.0346).abs() < 1e-3);
    let o = run(&[
        "run",
        "-q",
        data("closed/sphere.obj").to_str().unwrap(),
        "--height",
        "1.0",
        "--up",
        "+y",
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(code(&o), 0, "{}", text(&o));
    let s: Value = serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    assert!((s["input"]["metres_per_unit"].as_f64().unwrap() - 0.5).abs() < 1e-6, "{}", s["input"]);
}
