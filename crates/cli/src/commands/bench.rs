//! `clothcast bench`: simulation timings (the figures in the README).

use crate::args::BenchArgs;
use crate::config::Config;
use crate::failure::{Blame, Failure};
use crate::input;
use crate::progress::Progress;
use crate::stages;
use clothcast_mesh::repair::RepairOptions;
use serde_json::json;

/// Run the benchmark.
pub fn bench(args: &BenchArgs, progress: &Progress) -> Result<(), Failure> {
    let base = match &args.config {
        Some(p) => Config::from_file(p).input()?,
        None => Config::default(),
    };
    let meshes: Vec<Option<std::path::PathBuf>> =
        if args.meshes.is_empty() { vec![None] } else { args.meshes.iter().cloned().map(Some).collect() };
    let quiet = Progress::new(true);
    let mut rows = Vec::new();
    if !args.json {
        println!(
            "{:<28} {:>7} {:>7} {:>6} {:>6} {:>9} {:>9} {:>10} {:>6} {:>8} {:>9}  coarse start",
            "mesh",
            "faces",
            "dofs",
            "newton",
            "factor",
            "total s",
            "s/iter",
            "1 factor s",
            "prec",
            "ratio",
            "converged",
        );
    }
    if !(args.height > 0.0 && args.height.is_finite()) {
        return Err(Failure::Input(anyhow::anyhow!("--height {}: must be a positive number (metres)", args.height)));
    }
    for m in meshes {
        let mut cfg = base.clone();
        cfg.mesh.path = m.clone();
        cfg.mesh.height = Some(args.height);
        let input = input::load(&cfg, &RepairOptions::default())?;
        let stage = progress.stage(&format!("simulating {}", input.label));
        cfg.solver.allow_unconverged = true;
        let r = stages::simulation::run(&cfg, &input, &quiet)?;
        drop(stage);
        let s = &r.stats;
        let per_iter = s.seconds / s.newton_iterations.max(1) as f64;
        let one = s.solver.factorization_seconds_median;
        let name = m
            .as_ref()
            .and_then(|p| p.file_name())
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_else(|| "built-in example".into());
        let row = json!({
            "mesh": name, "faces": input.mesh.n_faces(), "dofs": s.solver.dofs,
            "newton_iterations": s.newton_iterations, "factorizations": s.solver.factorizations,
            "seconds": s.seconds, "seconds_per_iteration": per_iter, "factorization_seconds": one,
            "seconds_in_factorizations": s.solver.factorization_seconds,
            "ratio_to_one_factorization": if one > 0.0 { s.seconds / one } else { 0.0 },
            "converged": s.converged, "residual_rel": s.residual_rel,
            "factor_precision": if s.solver.single_precision { "single" } else { "double" },
            "pcg_iterations": s.solver.pcg_iterations,
            "coarse_start": s.coarse_start,
        });
        // The coarse start, if tried: the faces and iterations of each level used, finest
        // first ("-" if not tried, "unused" if tried but not used).
        let coarse = match &s.coarse_start {
            None => "-".to_string(),
            Some(c) if c.used => c
                .levels()
                .enumerate()
                .take_while(|(i, l)| *i == 0 || l.used)
                .map(|(_, l)| format!("{}f {}it", l.faces, l.newton_iterations))
                .collect::<Vec<_>>()
                .join(" < "),
            Some(_) => "unused".to_string(),
        };
        if !args.json {
            println!(
                "{:<28} {:>7} {:>7} {:>6} {:>6} {:>9.2} {:>9.3} {:>10.3} {:>6} {:>8.1} {:>9}  {}",
                name,
                input.mesh.n_faces(),
                s.solver.dofs,
                s.newton_iterations,
                s.solver.factorizations,
                s.seconds,
                per_iter,
                one,
                if s.solver.single_precision { "f32" } else { "f64" },
                row["ratio_to_one_factorization"].as_f64().unwrap_or(0.0),
                s.converged,
                coarse
            );
        }
        rows.push(row);
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows).internal()?);
    }
    Ok(())
}
