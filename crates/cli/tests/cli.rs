//! End-to-end tests of the `clothcast` binary: exit codes, messages, outputs.

mod common;
use common::*;

use serde_json::Value;

#[test]
fn run_builtin_example_writes_summary() {
    let out = tmpdir("run");
    expect_exit(&run_stage("run", &out, None, &[]), 0);
    let s = summary(&out);
    assert_eq!(s["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(s["input"]["path"], "built-in example");
    assert_eq!(s["input"]["euler_characteristic"], 2);
    assert_eq!(s["input"]["genus"], 0);
    assert_keys(
        &s["input"],
        "input",
        &["vertices", "faces", "components", "boundary_loops", "area_m2", "bbox_diagonal_m", "repairs"],
    );
    assert_eq!(s["scenario"]["infill"]["density"], 1460.0);
    assert!(s["stages"]["input"]["seconds"].as_f64().unwrap() >= 0.0);
    assert!(s["seconds_total"].as_f64().unwrap() >= 0.0);
}

#[test]
fn check_reports_topology_as_json() {
    let o = run(&["check", "--json", data("closed/fertility.off").to_str().unwrap()]);
    expect_exit(&o, 0);
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
    expect_exit(&o, 2);
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
    expect_exit(&o, 0);
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["repairs"]["non_manifold_vertices_split"], 1);
    assert_eq!(v["after_repair"]["components"], 1);
    expect_exit(&run(&["check", "--repair", data("broken/moebius.obj").to_str().unwrap()]), 2);
}

#[test]
fn run_refuses_bad_input_without_touching_outputs() {
    let out = tmpdir("bad");
    let summary_file = out.join("summary.json");
    std::fs::write(&summary_file, b"{\"previous\": true}").unwrap();
    for (file, needle) in [
        ("broken/fan3.obj", "non-manifold edge"),
        ("handmade/nan_coordinate.obj", "non-finite"),
        ("handmade/does_not_exist.obj", "cannot read"),
    ] {
        let o = run_stage("run", &out, None, &[data(file).to_str().unwrap()]);
        assert_eq!(code(&o), 2, "{file}: {}", text(&o));
        assert!(text(&o).contains(needle), "{file}: {}", text(&o));
    }
    assert_eq!(std::fs::read(&summary_file).unwrap(), b"{\"previous\": true}");
    // With --repair the NaN mesh becomes usable: an open surface remains, held at its rim.
    let cfg = write_config(&out, "rim.toml", "[suspension]\nmode = \"boundary\"\n");
    let nan = data("handmade/nan_coordinate.obj");
    expect_exit(&run_stage("run", &out, Some(&cfg), &["--repair", nan.to_str().unwrap()]), 0);
    let s = summary(&out);
    assert_eq!(s["input"]["repairs"]["faces_with_non_finite_vertices_removed"], 3);
}

#[test]
fn config_errors_name_key_and_line() {
    let dir = tmpdir("cfg");
    let bad = write_config(&dir, "bad.toml", "[material]\nyoungs_modulus = 1e5\npoison_ratio = 0.3\n");
    let t = expect_exit(&run_stage("run", &dir, None, &[bad.to_str().unwrap()]), 2);
    assert_mentions(&t, "poison_ratio");
    assert_mentions(&t, "line 3");
    let bad = write_config(&dir, "bad.toml", "[infill]\ndensity = -3\n");
    let t = expect_exit(&run_stage("run", &dir, Some(&bad), &[]), 2);
    assert_mentions(&t, "bad.toml:2");
    assert_mentions(&t, "infill.density");
    // A mesh path relative to the config file, and CLI flags overriding the file.
    let good = write_config(
        &dir,
        "good.toml",
        &format!("seed = 5\n[mesh]\npath = \"{}\"\nheight = 0.4\n", data("closed/torus.obj").display()),
    );
    expect_exit(&run_stage("run", &dir, None, &[good.to_str().unwrap(), "--seed", "9"]), 0);
    let s = summary(&dir);
    assert_eq!(s["scenario"]["seed"], 9);
    assert_eq!(s["input"]["genus"], 1);
}

#[test]
fn config_and_example_commands() {
    let o = run(&["config"]);
    expect_exit(&o, 0);
    let t = String::from_utf8(o.stdout).unwrap();
    assert_mentions(&t, "[material]");
    assert_mentions(&t, "youngs_modulus");
    let dir = tmpdir("ex");
    let f = dir.join("example.obj");
    expect_exit(&run(&["example", "-q", "-o", f.to_str().unwrap()]), 0);
    let o = run(&["check", "--json", f.to_str().unwrap()]);
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((v["faces"].as_u64(), v["genus"].as_i64(), v["components"].as_u64()), (Some(5120), Some(0), Some(1)));
    expect_exit(&run(&["example", "-o", dir.join("x.fbx").to_str().unwrap()]), 2);
}

#[test]
fn usage_errors_exit_2() {
    assert_eq!(code(&run(&["frobnicate"])), 2);
    assert_eq!(code(&run(&["check"])), 2);
    assert_eq!(code(&run(&["run", "--up", "sideways"])), 2);
    let t = expect_exit(&run(&["--help"]), 0);
    assert_mentions(&t, "fabric");
}

#[test]
fn units_and_height_scale_the_mesh() {
    let dir = tmpdir("units");
    let sphere = data("closed/sphere.obj");
    // In centimetres the sphere is 2 cm across: the default 5 cm band would clamp all of it (a
    // scenario refused: nothing could move), so it hangs from a 5 mm band.
    let t = expect_exit(&run_stage("simulate", &dir, None, &[sphere.to_str().unwrap(), "--units", "cm"]), 2);
    assert_mentions(&t, "clamps all");
    let cfg = write_config(&dir, "band.toml", "[suspension]\nband = 0.005\n");
    expect_exit(&run_stage("run", &dir, Some(&cfg), &[sphere.to_str().unwrap(), "--units", "cm"]), 0);
    let s = summary(&dir);
    assert!((s["input"]["bbox_diagonal_m"].as_f64().unwrap() - 0.0346).abs() < 1e-3);
    expect_exit(&run_stage("run", &dir, None, &[sphere.to_str().unwrap(), "--height", "1.0", "--up", "+y"]), 0);
    let s = summary(&dir);
    assert!((s["input"]["metres_per_unit"].as_f64().unwrap() - 0.5).abs() < 1e-6, "{}", s["input"]);
}
