//! End-to-end tests of the field stage through the binary.

mod common;
use common::*;

use clothcast_mesh::io::read_ply_properties;

#[test]
fn field_writes_raw_and_cross_fields() {
    let out = tmpdir("basic");
    expect_exit(&run_stage("field", &out, None, &[]), 0);
    let s = summary(&out);
    let f = &s["field"];
    assert_keys(
        f,
        "field",
        &[
            "source",
            "anisotropic_fraction",
            "energy_raw",
            "energy_pass1",
            "energy_pass2",
            "singularities_raw",
            "singularities_smoothed",
            "singularities_final",
            "merged",
            "cancelled",
            "index_sum",
            "singularities",
            "seconds",
        ],
    );
    assert_eq!(f["source"], "strain");
    assert_eq!(f["index_sum"], 8, "4χ of the rounded tetrahedron");
    assert!(f["singularities_final"].as_u64().unwrap() < f["singularities_raw"].as_u64().unwrap());
    assert!(s["stages"]["field"]["seconds"].as_f64().unwrap() < s["stages"]["simulation"]["seconds"].as_f64().unwrap());

    // strain_raw.ply: unit d1 per face, λ1 ≥ λ2, a 0/1 anisotropic flag.
    let raw = read_ply_properties(&std::fs::read(out.join("strain_raw.ply")).unwrap(), "strain_raw.ply").unwrap();
    let rf = &raw["face"];
    let n = rf["lambda1"].len();
    assert_eq!(n, 5120);
    for i in 0..n {
        let d = (rf["d1_x"][i].powi(2) + rf["d1_y"][i].powi(2) + rf["d1_z"][i].powi(2)).sqrt();
        assert!((d - 1.0).abs() < 1e-9);
        assert!(rf["lambda1"][i] >= rf["lambda2"][i]);
        assert!(rf["anisotropic"][i] == 0.0 || rf["anisotropic"][i] == 1.0);
    }
    // cross_field.ply: the singular vertices are the listed singularities.
    let cf = read_ply_properties(&std::fs::read(out.join("cross_field.ply")).unwrap(), "cross_field.ply").unwrap();
    let sing: Vec<(u64, i64)> = cf["vertex"]["singularity"]
        .iter()
        .enumerate()
        .filter(|(_, v)| **v != 0.0)
        .map(|(i, v)| (i as u64, *v as i64))
        .collect();
    let listed: Vec<(u64, i64)> = f["singularities"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["vertex"].as_u64().unwrap(), s["index"].as_i64().unwrap()))
        .collect();
    assert_eq!(sing, listed);
    assert_eq!(sing.iter().map(|s| s.1).sum::<i64>(), 8);
}

#[test]
fn curvature_source_and_config_errors() {
    let out = tmpdir("curv");
    run_configured("field", &out, "[field]\nsource = \"curvature\"\n", &[], 0);
    assert_eq!(summary(&out)["field"]["source"], "curvature");
    let t = run_configured("field", &out, "[field]\nsource = \"stress\"\n", &[], 2);
    assert_mentions(&t, "stress");
    let t = run_configured("field", &out, "[field]\nanisotropy_threshold = 1.5\n", &[], 2);
    assert_mentions(&t, "field.anisotropy_threshold");
}
