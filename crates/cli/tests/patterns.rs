//! End-to-end tests of the whole pipeline through the binary (issue 6): `clothcast run` writes
//! every file, the pieces add up to the target's area, the pattern files agree.

mod common;
use common::*;

use serde_json::Value;
use std::path::Path;

/// `clothcast run MESH --height H` into a fresh directory, which it returns; it must succeed.
fn run_scaled(tag: &str, mesh: &str, height: &str, extra: &[&str]) -> TmpDir {
    let out = tmpdir(tag);
    let mesh = data(mesh);
    let mut args = vec![mesh.to_str().unwrap(), "--height", height];
    args.extend_from_slice(extra);
    expect_exit(&run_stage("run", &out, None, &args), 0);
    out
}

/// The pieces cut in `pattern.svg` (the `data-piece` paths of its `cut` group).
fn cut_pieces(out: &Path) -> usize {
    let svg = std::fs::read_to_string(out.join("patterns/pattern.svg")).unwrap();
    let cut = svg.split("<g id=\"cut\"").nth(1).unwrap().split("</g>").next().unwrap();
    cut.matches("data-piece=").count()
}

/// Every file present and consistent; returns the summary.
fn check_run(out: &Path) -> Value {
    for f in [
        "summary.json",
        "deformed.ply",
        "cross_field.ply",
        "segmentation.ply",
        "seams.obj",
        "patterns/pattern.svg",
        "patterns/pattern.dxf",
        "patterns/pattern.pdf",
        "patterns/pattern_a4.pdf",
        "patterns/flattened.obj",
        "cast.ply",
    ] {
        let p = out.join(f);
        assert!(p.is_file() && std::fs::metadata(&p).unwrap().len() > 0, "{f} missing");
    }
    let s = summary(out);
    let fl = &s["flattening"];
    assert_keys(
        fl,
        "flattening",
        &[
            "flipped_triangles",
            "area_ratio_min",
            "area_ratio_max",
            "qc_mean",
            "qc_max",
            "seam_length_mismatch_max_rel",
            "fiber_alignment_median_deg",
            "orientation",
            "warp_along",
            "major_on_warp_share",
            "outlines_repaired",
            "outlines_not_simple",
            "distorted_pieces",
            "seconds",
        ],
    );
    assert!(fl["distorted_pieces"].as_array().unwrap().is_empty(), "{fl}");
    assert_eq!(fl["outlines_not_simple"], 0);
    let pt = &s["patterns"];
    assert_keys(
        pt,
        "patterns",
        &[
            "pieces",
            "seams",
            "notches",
            "fabric_width_mm",
            "fabric_length_mm",
            "utilisation",
            "files",
            "seconds",
            "distortion_retries",
        ],
    );
    assert_eq!(fl["flipped_triangles"], 0);
    assert_eq!(fl["orientation"], "field");
    assert_eq!(fl["warp_along"], "major");
    assert!(fl["qc_mean"].as_f64().unwrap() <= 1.05);
    let limit = if fl["repaired_vertices"].as_u64().unwrap() > 0 { 0.005 } else { 1e-9 };
    assert!(fl["seam_length_mismatch_max_rel"].as_f64().unwrap() <= limit, "{fl}");
    let pieces = pt["pieces"].as_u64().unwrap() as usize;
    assert_eq!(pieces as u64, s["segmentation"]["patches"].as_u64().unwrap());
    let per_piece = fl["per_piece"].as_array().unwrap();
    assert_eq!(per_piece.len(), pieces);
    for q in per_piece {
        assert_eq!(q["flipped_triangles"], 0);
        let qc = q["qc_mean"].as_f64().unwrap();
        assert!((1.0..=q["qc_max"].as_f64().unwrap()).contains(&qc), "{q}");
        // A strongly curved piece keeps its boundary and shrinks inside (fertility has one at
        // 0.72, a cap of ~64°); the common scale then brings the total back.
        let r = q["area_ratio"].as_f64().unwrap();
        assert!(r > 0.5 && r < 1.5, "{q}");
    }
    assert_eq!(pt["files"].as_array().unwrap().len(), 5);
    // The pieces' areas add up to the target's.
    let target = s["input"]["area_m2"].as_f64().unwrap();
    let pieces_area = pt["pieces_area_mm2"].as_f64().unwrap() * 1e-6;
    assert!((pieces_area / target - 1.0).abs() < 0.01, "pieces {pieces_area} m² vs target {target} m²");
    let util = pt["utilisation"].as_f64().unwrap();
    assert!(util > 0.2 && util <= 1.0);

    // SVG: one cut path per piece.
    assert_eq!(cut_pieces(out), pieces);
    // PDF: one page per piece.
    let pdf = std::fs::read(out.join("patterns/pattern.pdf")).unwrap();
    assert!(pdf.starts_with(b"%PDF"));
    let pages = String::from_utf8_lossy(&pdf).matches("/Type /Page\n").count()
        + String::from_utf8_lossy(&pdf).matches("/Type /Page ").count()
        + String::from_utf8_lossy(&pdf).matches("/Type /Page/").count();
    assert!(pages >= pieces, "{pages} pages for {pieces} pieces");
    // DXF: closed polylines on CUT and SEW, one each per piece.
    let dxf = std::fs::read_to_string(out.join("patterns/pattern.dxf")).unwrap();
    assert!(dxf.contains("EOF"));
    // flattened.obj: a group per patch, every face with v/vt, as many faces as the segmentation.
    let obj = std::fs::read_to_string(out.join("patterns/flattened.obj")).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("g patch_")).count(), pieces);
    let faces: Vec<&str> = obj.lines().filter(|l| l.starts_with("f ")).collect();
    assert!(faces.iter().all(|f| f.split_whitespace().skip(1).all(|c| c.contains('/'))));
    assert_eq!(faces.len() as u64, s["segmentation"]["faces"].as_u64().unwrap());
    // The check: the sewn mold converged, deviating from the target by about what stage 1's
    // mold does (the infill stretches both; within 4×), by less than a quarter of the model's
    // size (the 2 m cube, 28.6 kPa at its floor on 50 kN/m fabric, balloons by 0.17).
    let v = &s["validation"];
    assert_keys(
        v,
        "validation",
        &[
            "converged",
            "newton_iterations",
            "residual_rel",
            "fabric",
            "deviation_mean_m",
            "deviation_rms_m",
            "deviation_max_m",
            "deviation_signed_mean_m",
            "design_deviation_mean_m",
            "design_deviation_max_m",
            "deviation_mean_rel",
            "shear_mean_deg",
            "shear_max_deg",
            "shear_over_5deg_share",
            "warp_stretch_max",
            "weft_stretch_max",
            "strain_direction_change_median_deg",
            "seconds",
        ],
    );
    // An angle between lines; a NaN (a degenerate direction) would fail here.
    let turn = v["strain_direction_change_median_deg"].as_f64().unwrap();
    assert!((0.0..=90.0).contains(&turn), "{v}");
    assert_eq!(v["converged"], true, "{v}");
    assert_eq!(v["faces"], s["segmentation"]["faces"]);
    // The check's own iteration limit, "auto" resolved for the sewn mesh (its seams split
    // vertices, so it has more than the target).
    let sewn = v["vertices"].as_u64().unwrap() as usize;
    assert!(sewn > s["input"]["vertices"].as_u64().unwrap() as usize, "{v}");
    assert_eq!(v["max_iterations"].as_u64().unwrap() as usize, clothcast_sim::newton::auto_max_iterations(3 * sewn));
    let (dev, design) = (v["deviation_mean_m"].as_f64().unwrap(), v["design_deviation_mean_m"].as_f64().unwrap());
    assert!(dev > 0.0 && design > 0.0 && dev < 4.0 * design, "{v}");
    assert!(v["deviation_mean_rel"].as_f64().unwrap() < 0.25, "{v}");
    // The infill pushes the fabric out.
    assert!(v["deviation_signed_mean_m"].as_f64().unwrap() > 0.0, "{v}");
    let shear = v["shear_mean_deg"].as_f64().unwrap();
    assert!(shear > 0.0 && shear < 10.0, "{v}");
    assert!(v["warp_stretch_max"].as_f64().unwrap() > 1.0 && v["weft_stretch_max"].as_f64().unwrap() > 1.0);
    assert!(s["stages"]["validation"]["seconds"].as_f64().is_some());
    s
}

#[test]
fn run_on_the_example_writes_everything() {
    let out = tmpdir("example");
    // Not quiet (no `run_stage`): the closing message is part of what is checked.
    let t = expect_exit(&run(&["run", "-o", out.to_str().unwrap()]), 0);
    assert_mentions(&t, "patterns to cut");
    check_run(&out);
}

#[test]
fn run_on_fertility_writes_everything() {
    let out = run_scaled("fertility", "closed/fertility.off", "0.5", &[]);
    let s = check_run(&out);
    assert_eq!(s["input"]["genus"], 4);
}

/// bob_small (genus 1, 500 faces, not refined) at 0.5 m has a patch whose flattened outline looped over
/// itself, and the pattern stage refused it (exit 1): the looping stretch of its boundary is
/// now uncurled until the outline is simple, and every piece is cut.
#[test]
fn a_self_crossing_outline_is_repaired_and_cut() {
    let out = run_scaled("bob_small", "closed/bob_small.ply", "0.5", &["--no-refine"]);
    let s = summary(&out);
    let fl = &s["flattening"];
    assert_eq!(fl["outlines_not_simple"], 0);
    assert_eq!(fl["flipped_triangles"], 0);
    assert!(fl["outlines_repaired"].as_u64().unwrap() >= 1, "{fl}");
    // Uncurled by turning, the outline keeps its lengths: the seams still match.
    assert!(fl["seam_length_mismatch_max_rel"].as_f64().unwrap() < 1e-9, "{fl}");
    assert_eq!(s["patterns"]["pieces"], s["segmentation"]["patches"]);
    assert_eq!(cut_pieces(&out) as u64, s["patterns"]["pieces"].as_u64().unwrap());
}

/// A 2 m sphere does not fit a 1.5 m roll in the default layout's pieces (it used to stop with
/// exit 2 asking for a wider roll): its patches are split until every piece fits.
#[test]
fn pieces_are_split_to_fit_the_roll() {
    let out = run_scaled("sphere2m", "closed/sphere.obj", "2.0", &[]);
    let s = summary(&out);
    let (seg, pt) = (&s["segmentation"], &s["patterns"]);
    assert!(seg["size_splits"].as_u64().unwrap() + pt["layout_retries"].as_u64().unwrap() > 0, "{seg} {pt}");
    assert_eq!(pt["fabric_width_mm"], 1500.0);
    assert_eq!(pt["pieces"], seg["patches"]);
    // The pieces' areas still add up to the sphere's.
    let target = s["input"]["area_m2"].as_f64().unwrap();
    let pieces_area = pt["pieces_area_mm2"].as_f64().unwrap() * 1e-6;
    assert!((pieces_area / target - 1.0).abs() < 0.02, "{pieces_area} against {target}");
}

/// A CAD-style box of 48 triangles, 2 m wide: unrefined, its sides cannot be cut to fit the
/// 1.5 m roll (exit 2); refined (longest edges split until none is longer than a tenth of the
/// roll's usable width) it is cut in flat pieces, and the outputs are on the refined mesh,
/// whose first vertices are the input's.
#[test]
fn a_coarse_box_is_refined_and_cut() {
    let out = tmpdir("coarse-box");
    let cube = data("closed/cube.obj");
    let t = expect_exit(&run_stage("run", &out, None, &[cube.to_str().unwrap(), "--no-refine"]), 2);
    assert_mentions(&t, "does not fit");

    let out = run_scaled("coarse-box", "closed/cube.obj", "2.0", &[]);
    let s = check_run(&out);
    let inp = &s["input"];
    let faces = inp["faces"].as_u64().unwrap();
    assert_eq!(inp["unrefined_faces"], 48);
    // Each split of an interior edge adds two faces.
    assert_eq!(faces, 48 + 2 * inp["refinement_splits"].as_u64().unwrap(), "{inp}");
    assert!(faces >= 1000, "{inp}");
    assert_eq!(s["patterns"]["pieces"], s["segmentation"]["patches"]);
    // The sides are flat: every piece is developable, flattened without distortion.
    assert!(s["flattening"]["qc_max"].as_f64().unwrap() < 1.01, "{}", s["flattening"]);
    let deformed = std::fs::read(out.join("deformed.ply")).unwrap();
    let header = String::from_utf8_lossy(&deformed[..deformed.len().min(600)]).to_string();
    assert!(header.contains(&format!("element face {faces}\n")), "{header}");
    // The input's vertices keep their ids: explicit suspension vertices still name them.
    let cfg = write_config(&out, "corners.toml", "[suspension]\nmode = \"vertices\"\nvertices = [0, 26]\n");
    let t = expect_exit(&run_stage("simulate", &out, Some(&cfg), &[cube.to_str().unwrap()]), 2);
    assert_mentions(&t, "vertex 26 is not in the (repaired) mesh, which has 26 vertices");
}

/// The capped cylinder at 1 m, refined to 1920 faces: a patch too wide for the roll bends over
/// the rim, where every sweep cut of its spectral split leaves a side in two parts; the split
/// takes a side's largest part against the rest, and every piece fits (checked: with that
/// fallback disabled, this run stops with exit 2).
#[test]
fn a_patch_over_a_crease_is_split_to_fit_the_roll() {
    let out = run_scaled("cylinder1m", "closed/cylinder.obj", "1.0", &[]);
    let s = summary(&out);
    assert!(s["input"]["refinement_splits"].as_u64().unwrap() > 0);
    assert_eq!(s["patterns"]["pieces"], s["segmentation"]["patches"]);
    assert_eq!(cut_pieces(&out) as u64, s["patterns"]["pieces"].as_u64().unwrap());
}

/// The table top of a CAD model (0.16° input slivers, box corners). At 0.5 m two of its
/// pieces flattened with a mean quasi-conformal ratio of 36 and 79 (obtuse slivers, negative
/// cotan weights): they are flattened again on their intrinsic Delaunay triangulation and come
/// out near conformal. At 0.3 m BFF flips slivers in two pieces; unfolded where they are, no
/// piece is badly distorted (the former Tutte untangling sheared one to a mean of 13.6, and two
/// new layouts left it so). With stricter limits (`[pattern] max_qc_mean`, `max_area_spread`)
/// the pieces over them are named in warnings and in `flattening.distorted_pieces`, and the
/// patches are laid out again with them split. Smooth models have none (checked by `check_run`).
#[test]
fn distorted_pieces_are_reflattened_or_reported() {
    let table = data("multi/wooden_table_02.obj");
    let table_run = |tag: &str, height: &str, config: Option<&str>| {
        let out = tmpdir(tag);
        let cfg = config.map(|c| write_config(&out, "limits.toml", c));
        let args = [table.to_str().unwrap(), "--largest-component", "--height", height];
        let log = expect_exit(&run_stage("run", &out, cfg.as_deref(), &args), 0);
        (summary(&out), log)
    };
    let (s, _) = table_run("table-05", "0.5", None);
    let fl = &s["flattening"];
    assert!(fl["intrinsic_delaunay"].as_u64().unwrap() >= 1, "{fl}");
    assert!(fl["distorted_pieces"].as_array().unwrap().is_empty(), "{fl}");
    assert!(fl["qc_mean"].as_f64().unwrap() < 1.1, "{fl}");

    let (s, _) = table_run("table-03", "0.3", None);
    let fl = &s["flattening"];
    assert!(fl["repaired_vertices"].as_u64().unwrap() > 0, "{fl}");
    assert!(fl["distorted_pieces"].as_array().unwrap().is_empty(), "{fl}");
    assert!(fl["qc_mean"].as_f64().unwrap() < 1.1 && fl["qc_max"].as_f64().unwrap() < 20.0, "{fl}");
    assert_eq!(s["patterns"]["distortion_retries"], 0);

    let (s, log) = table_run("table-03-strict", "0.3", Some("[pattern]\nmax_qc_mean = 1.05\nmax_area_spread = 8\n"));
    assert!(s["patterns"]["distortion_retries"].as_u64().unwrap() >= 1, "{}", s["patterns"]);
    let distorted = s["flattening"]["distorted_pieces"].as_array().unwrap().clone();
    assert!(!distorted.is_empty(), "{}", s["flattening"]);
    for p in s["flattening"]["per_piece"].as_array().unwrap() {
        let over = p["qc_mean"].as_f64().unwrap() > 1.05
            || p["area_ratio_max"].as_f64().unwrap() > 8.0 * p["area_ratio_min"].as_f64().unwrap();
        assert_eq!(over, distorted.contains(&p["patch"]), "{p}");
    }
    let warning = format!("piece {} (P{}) is badly distorted", distorted[0], distorted[0]);
    assert_mentions(&log, &warning);
    assert_mentions(&log, "max_qc_mean = 1.05");
}

#[test]
fn flatten_command_and_determinism() {
    let files = ["patterns/pattern.svg", "patterns/pattern.dxf", "patterns/pattern.pdf", "patterns/flattened.obj"];
    assert_reproducible("flatten", "3", &files);
}

/// A run that fails leaves the output directory as the last complete run left it, and what
/// it wrote before failing in `failed-run/` (the layout that could not be made into patterns).
#[test]
fn a_failed_run_leaves_the_last_complete_run_whole() {
    let out = tmpdir("failed-run");
    run_configured("segment", &out, "", &["--height", "0.3"], 0);
    let before: Vec<Vec<u8>> =
        ["summary.json", "segmentation.ply"].iter().map(|f| std::fs::read(out.join(f)).unwrap()).collect();
    let t = run_configured(
        "flatten",
        &out,
        "[pattern]\nnotch_spacing_mm = 0.001\n",
        &["--height", "0.3", "--seed", "2"],
        2,
    );
    assert_mentions(&t, "failed-run");
    for (f, b) in ["summary.json", "segmentation.ply"].iter().zip(&before) {
        assert_eq!(&std::fs::read(out.join(f)).unwrap(), b, "{f} changed");
    }
    assert!(out.join("failed-run/segmentation.ply").exists());
    assert!(!out.join("patterns").exists() && !out.join(".clothcast-partial").exists());
    // A complete run supersedes the failed one's files.
    run_configured("segment", &out, "", &["--height", "0.3"], 0);
    assert!(!out.join("failed-run").exists());
}

/// A complete run replaces the files of its stages that it did not write: the check's
/// `cast.ply` of an earlier run does not stay beside patterns it was not made from.
#[test]
fn a_run_removes_its_stages_files_it_did_not_write() {
    let out = tmpdir("stale");
    run_configured("run", &out, "", &["--height", "0.3"], 0);
    assert!(out.join("cast.ply").exists());
    run_configured("run", &out, "[validation]\nenabled = false\n", &["--height", "0.3", "--seed", "2"], 0);
    assert!(!out.join("cast.ply").exists());
    assert!(summary(&out)["validation"].is_null());
    assert!(out.join("patterns/pattern.dxf").exists() && !out.join(".clothcast-partial").exists());
}

#[test]
fn a_roll_too_narrow_is_an_input_error() {
    let out = tmpdir("narrow");
    let t = run_configured("run", &out, "[pattern]\nfabric_width_mm = 50.0\n", &[], 2);
    assert_mentions(&t, "fabric_width_mm");
}

/// `[pattern] warp_along` decides which yarn runs along the mold's largest stretch on every
/// piece. On the cylinder (hoop stretch about twice the axial) the warp follows it on most of
/// the weight with "major", the weft with "minor"; "either" keeps the orientation rule's own
/// quarter turns, which mix the two. A value that is none of these is an input error.
#[test]
fn warp_along_puts_the_chosen_yarn_on_the_largest_stretch() {
    let share = |rule: &str| {
        let out = tmpdir(&format!("warp_{rule}"));
        let toml = format!("[pattern]\nwarp_along = \"{rule}\"\n");
        let cyl = data("closed/cylinder.obj");
        run_configured("run", &out, &toml, &[cyl.to_str().unwrap(), "--height", "1"], 0);
        let fl = summary(&out)["flattening"].clone();
        assert_eq!(fl["warp_along"], rule);
        for q in fl["per_piece"].as_array().unwrap() {
            let s = q["major_on_warp_share"].as_f64().unwrap();
            assert!((0.0..=1.0).contains(&s), "{q}");
        }
        fl["major_on_warp_share"].as_f64().unwrap()
    };
    let (major, minor, either) = (share("major"), share("minor"), share("either"));
    assert!(major > 0.8, "{major}");
    assert!(minor < 0.2, "{minor}");
    assert!(either > minor && either < major, "{either}");
    let out = tmpdir("warp_bad");
    let t = run_configured("run", &out, "[pattern]\nwarp_along = \"bias\"\n", &[], 2);
    assert_mentions(&t, "warp_along");
}

/// A patch bounded by one seam alone, a closed loop (the torus 2 m across, hung along +x from a
/// 109 mm band, seed 41, makes one in a layout it tries): its seam runs round the whole outline
/// from the seam's start. The pattern stage took that for an empty seam side and stopped the
/// run with an internal error (exit 1); found by fuzzing random scenarios.
#[test]
fn a_patch_bounded_by_a_closed_seam_is_cut() {
    let out = tmpdir("closed-seam");
    let toml = "seed = 41\n[mesh]\nup = \"+x\"\n[suspension]\nmode = \"top-band\"\nband = 0.109\n";
    let mesh = data("closed/torus.obj");
    run_configured("run", &out, toml, &[mesh.to_str().unwrap(), "--height", "2.0"], 0);
    let s = summary(&out);
    assert_eq!(s["patterns"]["pieces"], s["segmentation"]["patches"]);
    assert_eq!(cut_pieces(&out) as u64, s["patterns"]["pieces"].as_u64().unwrap());
}
