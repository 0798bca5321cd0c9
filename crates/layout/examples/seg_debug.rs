//! Development tool: segment a `cross_field.ply` written by `clothcast field` and print
//! diagnostics of every stage. `cargo run --release -p clothcast-layout --example seg_debug -- DIR`

use clothcast_field::cross::connection;
use clothcast_field::{CrossField, Singularity};
use clothcast_layout::reroute::edge_deviation;
use clothcast_layout::trace::{SeparatrixEnd, TraceOptions, trace_separatrices};
use clothcast_layout::vertex_field::VertexField;
use clothcast_layout::{LayoutOptions, segment};
use clothcast_mesh::io::{read_ply, read_ply_properties};
use clothcast_mesh::{FaceData, Mesh, Vec3, VertexId};

fn main() {
    let dir = std::env::args().nth(1).expect("directory with cross_field.ply");
    let bytes = std::fs::read(format!("{dir}/cross_field.ply")).unwrap();
    let soup = read_ply(&bytes, "cross_field.ply").unwrap();
    let mesh = Mesh::try_from_soup(&soup).unwrap();
    let props = read_ply_properties(&bytes, "cross_field.ply").unwrap();
    let f = &props["face"];
    let d: Vec<Vec3> = (0..mesh.n_faces()).map(|i| Vec3::new(f["d1_x"][i], f["d1_y"][i], f["d1_z"][i])).collect();
    let rho = connection(&mesh);
    let theta: FaceData<f64> = mesh.face_ids().map(|fi| mesh.face_frame(fi).angle_of(&d[fi.idx()])).collect();
    let field = CrossField::from_angles(&mesh, &rho, theta);
    let sing: Vec<Singularity> = props["vertex"]["singularity"]
        .iter()
        .enumerate()
        .filter(|(_, s)| **s != 0.0)
        .map(|(v, s)| Singularity { vertex: VertexId(v as u32), index: *s as i32 })
        .collect();
    let mut hist = std::collections::BTreeMap::new();
    for s in &sing {
        *hist.entry(s.index).or_insert(0) += 1;
    }
    println!("{} faces, {} singularities {:?}", mesh.n_faces(), sing.len(), hist);
    let vf = VertexField::from_face_field(&mesh, &field);
    let dirs = field.directions(&mesh);
    let mut topts = TraceOptions::default();
    if let Ok(d) = std::env::var("DRIFT") {
        topts.drift_penalty = d.parse().unwrap();
    }
    let seps = trace_separatrices(&mesh, &vf, &dirs, &sing, &topts);
    let expected: i32 = sing.iter().map(|s| 4 - s.index).sum();
    let mut ends = std::collections::BTreeMap::new();
    for s in &seps {
        let k = match s.end {
            SeparatrixEnd::Singularity => "singularity",
            SeparatrixEnd::Boundary => "boundary",
            SeparatrixEnd::TJunction(_) => "t-junction",
            SeparatrixEnd::Failed => "failed",
        };
        *ends.entry(k).or_insert(0) += 1;
    }
    if let Ok(w) = std::env::var("WATCH") {
        let watch: Vec<u32> = w.split(',').map(|x| x.parse().unwrap()).collect();
        for (i, sp) in seps.iter().enumerate() {
            let (a, b) = (sp.vertices[0].0, sp.vertices.last().unwrap().0);
            if watch.contains(&a) || watch.contains(&b) {
                println!("sep {i}: {:?} end {:?}", sp.vertices.iter().map(|v| v.0).collect::<Vec<_>>(), sp.end);
            }
        }
    }
    {
        let mut devs: Vec<f64> = Vec::new();
        let mut start_devs: Vec<f64> = Vec::new();
        for sp in &seps {
            let v = &sp.vertices;
            if v.len() < 9 {
                continue;
            }
            for i in 4..v.len() - 4 {
                let d = mesh.position(v[i + 4]) - mesh.position(v[i - 4]);
                devs.push(vf.best_arm(v[i], &d).1.to_degrees());
            }
            // Departure: chord from the singularity to vertex 4, against the face field at vertex 2.
            let d = mesh.position(v[4]) - mesh.position(v[0]);
            start_devs.push(vf.best_arm(v[2], &d).1.to_degrees());
        }
        devs.sort_by(|a, b| a.total_cmp(b));
        start_devs.sort_by(|a, b| a.total_cmp(b));
        let q = |x: &Vec<f64>, f: f64| x[((x.len() as f64 - 1.0) * f) as usize];
        println!(
            "traced chord deviation: median {:.1} p90 {:.1}; departure median {:.1} p90 {:.1}",
            q(&devs, 0.5),
            q(&devs, 0.9),
            q(&start_devs, 0.5),
            q(&start_devs, 0.9)
        );
    }
    println!("emissions expected {expected}, traced records {} {:?}", seps.len(), ends);
    let env = |k: &str| std::env::var(k).ok();
    let mut opts = LayoutOptions::default();
    if env("NOMERGE").is_some() {
        opts.merge = false;
    }
    if env("NORR").is_some() {
        opts.follow_streamlines = false;
    }
    if env("NOSMOOTH").is_some() {
        opts.smooth_seams = false;
    }
    opts.drift_penalty = topts.drift_penalty;
    if let Some(d) = env("TINY") {
        opts.min_patch_fraction = d.parse().unwrap();
    }
    if let Some(d) = env("PIN") {
        opts.pin_spacing = d.parse().unwrap();
    }
    if let Some(d) = env("MAXDEV") {
        opts.max_developability = d.parse().unwrap();
    }
    let seg = segment(&mesh, &field, &sing, &opts).unwrap();
    if env("PATCHES").is_some() {
        for (i, p) in seg.patches.iter().enumerate() {
            if p.corners.len() != 4 {
                let c: Vec<String> = p
                    .candidates
                    .iter()
                    .map(|(v, q)| {
                        format!(
                            "{}{}:{:.2}",
                            v.0,
                            if seg.singularities.iter().any(|s| s.vertex == *v) { "*" } else { "" },
                            q
                        )
                    })
                    .collect();
                println!(
                    "patch {i} corners {} area {:.4} dev {:.2}: {}",
                    p.corners.len(),
                    p.area,
                    p.developability,
                    c.join(" ")
                );
            }
        }
    }
    if env("HIST").is_some() {
        let mut h = [0usize; 16];
        for p in &seg.patches {
            for &(_, q) in &p.candidates {
                h[((q * 4.0) as usize).min(15)] += 1;
            }
        }
        println!("candidate angle histogram (quarter-turn bins of 0.25): {h:?}");
    }
    if env("DEVHIST").is_some() {
        // Length per 5° bin of the final seams' deviation from the field.
        let m = &seg.mesh;
        let mut h = [0.0f64; 10];
        let mut per_seam: Vec<(f64, f64, usize)> = Vec::new();
        for (si, sm) in seg.seams.iter().enumerate() {
            let (mut len, mut acc) = (0.0, 0.0);
            for w in sm.vertices.windows(2) {
                let h0 = m.outgoing(w[0]).find(|&hh| m.head(hh) == w[1]);
                let Some(hh) = h0 else { continue };
                let d = m.vector(hh);
                let phi = edge_deviation(m, m.edge(hh), &seg.field_directions).to_degrees();
                h[((phi / 5.0) as usize).min(9)] += d.norm();
                len += d.norm();
                acc += phi * d.norm();
            }
            per_seam.push((acc / len.max(1e-12), len, si));
        }
        // Deviation by position along the seam (share of its length from the nearer end).
        let mut pos = [(0.0f64, 0.0f64); 5];
        for sm in &seg.seams {
            let lens: Vec<f64> = sm.vertices.windows(2).map(|w| (m.position(w[1]) - m.position(w[0])).norm()).collect();
            let total: f64 = lens.iter().sum();
            let mut acc = 0.0;
            for (i, w) in sm.vertices.windows(2).enumerate() {
                let mid = acc + 0.5 * lens[i];
                acc += lens[i];
                let frac = mid.min(total - mid) / total.max(1e-12);
                let Some(hh) = m.outgoing(w[0]).find(|&hh| m.head(hh) == w[1]) else { continue };
                let phi = edge_deviation(m, m.edge(hh), &seg.field_directions).to_degrees();
                let k = ((frac / 0.1) as usize).min(4);
                pos[k].0 += phi * lens[i];
                pos[k].1 += lens[i];
            }
        }
        println!(
            "mean deviation by distance from the nearer end (0-10%, 10-20%, .., 40-50%): {:?}",
            pos.iter()
                .map(|(a, l)| format!("{:.1}° ({:.0}%)", a / l, 100.0 * l / pos.iter().map(|x| x.1).sum::<f64>()))
                .collect::<Vec<_>>()
        );
        let tot: f64 = h.iter().sum();
        println!(
            "deviation histogram (share of length per 5° bin): {:?}",
            h.iter().map(|x| (100.0 * x / tot).round()).collect::<Vec<_>>()
        );
        per_seam.sort_by(|a, b| b.0.total_cmp(&a.0));
        for (d, l, si) in per_seam.iter().take(12) {
            println!("  seam {si}: mean dev {d:.1}° length {l:.3} patches {:?}", seg.seams[*si].patches);
        }
    }
    let s = &seg.stats;
    let mut ch = std::collections::BTreeMap::new();
    for c in &s.corners {
        *ch.entry(c).or_insert(0) += 1;
    }
    println!(
        "rerouted {} patches {} corners {:?} quad {:.2} merges {} splits {} straightened {} dev {:.1} dmax {:.2} min angle {:.1}",
        s.rerouted,
        s.patches,
        ch,
        s.quad_fraction,
        s.merges,
        s.splits,
        s.straightened,
        s.seam_field_deviation_median_deg,
        s.developability_max,
        s.min_angle_deg
    );
}
