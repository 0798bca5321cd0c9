//! `clothcast check MESH [--json]`: topology figures and every validation problem.

use crate::args::CheckArgs;
use crate::failure::{Blame, Failure};
use crate::progress::Progress;
use clothcast_mesh::io::read_mesh_file;
use clothcast_mesh::repair::{RepairOptions, prepare};
use clothcast_mesh::util::edge_key;
use clothcast_mesh::{MeshError, Problem, SoupAnalysis, TriSoup, analyze};
use serde_json::{Value, json};

/// Mean length of the distinct edges and smallest corner angle (degrees) of a soup, over
/// triangles with finite coordinates and three distinct vertices.
fn edge_and_angle_figures(soup: &TriSoup) -> (f64, f64) {
    let finite = |v: u32| soup.positions[v as usize].iter().all(|c| c.is_finite());
    let mut keys = Vec::with_capacity(3 * soup.triangles.len());
    let mut min_angle = f64::INFINITY;
    for t in &soup.triangles {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || !t.iter().all(|&v| finite(v)) {
            continue;
        }
        let p = t.map(|v| soup.positions[v as usize]);
        for k in 0..3 {
            keys.push(edge_key(t[k], t[(k + 1) % 3]));
            min_angle = min_angle.min(clothcast_mesh::geometry::angle_at(&p[k], &p[(k + 1) % 3], &p[(k + 2) % 3]));
        }
    }
    keys.sort_unstable();
    keys.dedup();
    let total: f64 = keys
        .iter()
        .map(|k| (soup.positions[(k >> 32) as usize] - soup.positions[(k & 0xFFFF_FFFF) as usize]).norm())
        .sum();
    let mean = if keys.is_empty() { 0.0 } else { total / keys.len() as f64 };
    (mean, if min_angle.is_finite() { min_angle.to_degrees() } else { 0.0 })
}

fn problem_json(p: &Problem) -> Value {
    let mut v = serde_json::to_value(p).unwrap_or_else(|_| json!({ "kind": p.kind() }));
    if let Value::Object(m) = &mut v {
        m.insert("message".into(), Value::String(p.to_string()));
        m.insert("remedy".into(), Value::String(p.remedy().into()));
    }
    v
}

fn report_json(path: &str, soup: &TriSoup, a: &SoupAnalysis) -> Value {
    let (mean_edge, min_angle) = edge_and_angle_figures(soup);
    json!({
        "file": path,
        "vertices": a.vertices,
        "faces": a.faces,
        "edges": a.edges,
        "components": a.components,
        "boundary_loops": a.boundary_loops,
        "euler_characteristic": a.euler_characteristic,
        "genus": a.genus,
        "bbox_min": a.bbox.min.as_slice(),
        "bbox_max": a.bbox.max.as_slice(),
        "bbox_diagonal": a.bbox.diagonal(),
        "mean_edge_length": mean_edge,
        "min_angle_deg": min_angle,
        "source_polygons": soup.source_polygons,
        "problems": a.problems.iter().map(problem_json).collect::<Vec<_>>(),
    })
}

fn print_human(v: &Value, a: &SoupAnalysis) {
    let show = |k: &str| match &v[k] {
        Value::Null => "n/a (not a manifold, orientable surface)".to_string(),
        Value::Number(n) if n.is_f64() => format!("{:.6}", n.as_f64().unwrap_or(0.0)),
        x => x.to_string(),
    };
    println!("{}", v["file"].as_str().unwrap_or(""));
    for (label, key) in [
        ("vertices", "vertices"),
        ("faces", "faces"),
        ("edges", "edges"),
        ("components", "components"),
        ("boundary loops", "boundary_loops"),
        ("Euler characteristic", "euler_characteristic"),
        ("genus", "genus"),
        ("bounding-box diagonal", "bbox_diagonal"),
        ("mean edge length", "mean_edge_length"),
        ("min angle (deg)", "min_angle_deg"),
    ] {
        println!("  {label:<22} {}", show(key));
    }
    println!("  {:<22} {:?} – {:?}", "bounding box", a.bbox.min.as_slice(), a.bbox.max.as_slice());
    if a.problems.is_empty() {
        println!("  problems               none");
        return;
    }
    println!("  problems               {}", a.problems.len());
    // Up to 10 per kind, then a count.
    let mut shown: Vec<(&str, usize)> = Vec::new();
    for p in &a.problems {
        let entry = match shown.iter_mut().find(|(k, _)| *k == p.kind()) {
            Some(e) => e,
            None => {
                shown.push((p.kind(), 0));
                shown.last_mut().expect("just pushed")
            }
        };
        entry.1 += 1;
        if entry.1 <= 10 {
            println!("    - {p}");
        }
    }
    for (kind, n) in shown {
        if n > 10 {
            println!("    ... {} more {kind}", n - 10);
        }
        let example = a.problems.iter().find(|p| p.kind() == kind).expect("kind seen");
        println!("    {kind}: {}", example.remedy());
    }
}

/// Run `check`.
pub fn check(args: &CheckArgs, progress: &Progress) -> Result<(), Failure> {
    let path = args.mesh.display().to_string();
    let stage = progress.stage("reading mesh");
    let soup = match read_mesh_file(&args.mesh) {
        Ok(s) => s,
        Err(e) => {
            drop(stage);
            if args.json {
                println!("{}", json!({ "file": path, "usable": false, "error": e.to_string() }));
            }
            return Err(Failure::Input(e.into()));
        }
    };
    stage.set_message("validating");
    let analysis = analyze(&soup);
    let mut report = report_json(&path, &soup, &analysis);
    let opts = RepairOptions { repair: args.repair, largest_component: args.largest_component, ..Default::default() };
    let prepared = prepare(&soup, &opts);
    drop(stage);
    // An inward-oriented mesh is read and repaired like any other, but the simulation refuses
    // it (the infill would pull the fabric in) unless --repair flips it.
    let inward = prepared.as_ref().ok().map(|p| p.mesh.signed_volume()).filter(|&v| v < 0.0).map(|v| {
        format!(
            "the mesh is oriented inward (its enclosed volume is {v:.4e}, negative): run and simulate refuse it; \
             --repair flips it"
        )
    });
    let usable = prepared.is_ok() && inward.is_none();
    report["usable"] = Value::Bool(usable);
    if let Some(why) = &inward {
        report["error"] = Value::String(why.clone());
    }
    if let Ok(p) = &prepared
        && (args.repair || args.largest_component)
    {
        report["repairs"] = serde_json::to_value(&p.report).internal()?;
        report["repair_summary"] = json!(p.report.lines());
        let m = &p.mesh;
        report["after_repair"] = json!({
            "vertices": m.n_vertices(), "faces": m.n_faces(), "edges": m.n_edges(),
            "components": m.n_components(), "boundary_loops": m.boundary_loops().len(),
            "euler_characteristic": m.euler_characteristic(), "genus": m.genus(),
        });
    }
    if let Err(MeshError::Invalid { problems }) = &prepared
        && (args.repair || args.largest_component)
    {
        report["remaining_problems"] = Value::Array(problems.iter().map(problem_json).collect());
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report).internal()?);
    } else {
        print_human(&report, &analysis);
        if let Some(lines) = report.get("repair_summary").and_then(|l| l.as_array()) {
            println!("  with --repair/--largest-component:");
            if lines.is_empty() {
                println!("    nothing to change");
            }
            for l in lines {
                println!("    {}", l.as_str().unwrap_or(""));
            }
        }
        match &prepared {
            Ok(_) => match &inward {
                Some(why) => println!("  usable: no ({why})"),
                None => println!("  usable: yes"),
            },
            Err(e) => {
                let first = match e {
                    MeshError::Invalid { problems } => {
                        problems.first().map(|p| format!("{p} [{}]", p.remedy())).unwrap_or_default()
                    }
                    other => other.to_string(),
                };
                println!("  usable: no ({first})");
            }
        }
    }
    if usable {
        Ok(())
    } else {
        if !args.json {
            let first = match &prepared {
                Err(MeshError::Invalid { problems }) => problems.first().map(|p| p.to_string()).unwrap_or_default(),
                Err(e) => e.to_string(),
                Ok(_) => inward.clone().unwrap_or_default(),
            };
            eprintln!("error: {}", crate::failure::printable(&format!("{path} is not usable: {first}")));
        }
        Err(Failure::Reported(2))
    }
}
