//! End-to-end tests of the field stage through the binary.

mod common;
use common::*;

use clothcast_mesh::io::read_ply_properties;
use serde_json::Value;

#[test]
fn field_writes_raw_and_cross_fields() {
    let out = tmpdir("basic");
    let o = run(&["field", "-q", "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let s: Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let f = &s["field"];
    for k in [
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
    ] {
        assert!(!f[k].is_null(), "field.{k} missing");
    }
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
    let cfg = out.join("c.toml");
    std::fs::write(&cfg, "[field]\nsource = \"curvature\"\n").unwrap();
    let o = run(&["field", "-q", "-c", cfg.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let s: Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["field"]["source"], "curvature");
    std::fs::write(&cfg, "[field]\nsource = \"stress\"\n").unwrap();
    let o = run(&["field", "-q", "-c", cfg.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("stress"), "{}", text(&o));
    std::fs::write(&cfg, "[field]\nanisotropy_threshold = 1.5\n").unwrap();
    let o = run(&["field", "-q", "-c", cfg.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("field.anisotropy_threshold"), "{}", text(&o));
}
