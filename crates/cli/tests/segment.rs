//! End-to-end tests of the segmentation stage through the binary.

mod common;
use common::*;

use clothcast_mesh::io::{read_ply, read_ply_properties};
use std::collections::BTreeSet;

#[test]
fn segment_writes_patches_seams_and_summary() {
    let out = tmpdir("basic");
    expect_exit(&run_stage("segment", &out, None, &[]), 0);
    let s = summary(&out);
    let g = &s["segmentation"];
    assert_keys(
        g,
        "segmentation",
        &[
            "patches",
            "disks",
            "tiny_patches",
            "corners",
            "quad_fraction",
            "singularities_inside_patches",
            "seam_length_m",
            "seam_field_deviation_median_deg",
            "developability_max",
            "merges",
            "splits",
            "seconds",
        ],
    );
    let patches = g["patches"].as_u64().unwrap() as usize;
    assert!(patches >= 2);
    assert_eq!(g["disks"].as_u64().unwrap() as usize, patches);
    assert_eq!(g["corners"].as_array().unwrap().len(), patches);
    assert_eq!(g["singularities_inside_patches"], 0);
    assert!(s["stages"]["segmentation"]["seconds"].as_f64().is_some());

    // segmentation.ply: a per-face patch id covering 0..patches.
    let bytes = std::fs::read(out.join("segmentation.ply")).unwrap();
    let soup = read_ply(&bytes, "segmentation.ply").unwrap();
    let props = read_ply_properties(&bytes, "segmentation.ply").unwrap();
    let ids: BTreeSet<i64> = props["face"]["patch"].iter().map(|&p| p as i64).collect();
    assert_eq!(ids, (0..patches as i64).collect());
    assert_eq!(props["face"]["patch"].len(), soup.triangles.len());

    // seams.obj: one object per seam named seam_<id>_<a>_<b>, each with an `l` record of at
    // least two vertices, referring to the segmentation's vertices.
    let obj = std::fs::read_to_string(out.join("seams.obj")).unwrap();
    let n_v = obj.lines().filter(|l| l.starts_with("v ")).count();
    assert_eq!(n_v, soup.positions.len());
    let objects: Vec<&str> = obj.lines().filter(|l| l.starts_with("o ")).collect();
    let lines: Vec<&str> = obj.lines().filter(|l| l.starts_with("l ")).collect();
    assert_eq!(objects.len(), lines.len());
    assert!(!objects.is_empty());
    for (i, (o, l)) in objects.iter().zip(&lines).enumerate() {
        let parts: Vec<&str> = o[2..].split('_').collect();
        assert_eq!(parts.len(), 4, "{o}");
        assert_eq!(parts[0], "seam");
        assert_eq!(parts[1].parse::<usize>().unwrap(), i);
        for p in &parts[2..] {
            assert!(p.parse::<usize>().unwrap() < patches);
        }
        let idx: Vec<usize> = l[2..].split_whitespace().map(|x| x.parse().unwrap()).collect();
        assert!(idx.len() >= 2);
        assert!(idx.iter().all(|&k| k >= 1 && k <= n_v));
    }
}

#[test]
fn same_seed_same_outputs() {
    assert_reproducible("segment", "7", &["segmentation.ply", "seams.obj"]);
}

#[test]
fn bad_layout_config_is_an_input_error() {
    let out = tmpdir("badcfg");
    let t = run_configured("segment", &out, "[layout]\nmax_deviation = 120.0\n", &[], 2);
    assert_mentions(&t, "layout.max_deviation");
}

/// Spot (23k faces): every patch a disk with no singularity inside and none tiny (its last
/// tiny patch can only merge by exposing a singularity, which is then joined to the seams
/// again), and the seams, moved onto streamlines, within the 10° deviation target.
#[test]
fn spot_has_no_tiny_patches_and_field_aligned_seams() {
    let out = tmpdir("spot");
    let mesh = data("closed/spot.ply");
    expect_exit(&run_stage("segment", &out, None, &[mesh.to_str().unwrap(), "--height", "0.5"]), 0);
    let s = summary(&out);
    let g = &s["segmentation"];
    assert_eq!(g["disks"], g["patches"]);
    assert_eq!(g["singularities_inside_patches"], 0);
    assert_eq!(g["tiny_patches"], 0, "{g}");
    assert!(g["rerouted"].as_u64().unwrap() > 0);
    assert!(g["seam_field_deviation_median_deg"].as_f64().unwrap() <= 10.0, "{g}");
}
