//! The subcommands.

pub mod bench;
pub mod check;
pub mod run;

use crate::args::{Cli, Command, MeshArgs, RunArgs};
use crate::config::{Config, TEMPLATE, Up};
use crate::failure::{Blame, Failure};
use crate::progress::Progress;
use anyhow::{Context, anyhow};
use clothcast_mesh::io::{PlyFormat, write_atomic, write_obj, write_ply};
use clothcast_mesh::repair::RepairOptions;
use std::path::Path;

/// Run the parsed command line.
pub fn dispatch(cli: &Cli) -> Result<(), Failure> {
    let progress = Progress::new(cli.quiet);
    match &cli.command {
        Command::Run(a) => run::run(a, &progress, run::Until::All),
        Command::Simulate(a) => run::run(a, &progress, run::Until::Simulation),
        Command::Field(a) => run::run(a, &progress, run::Until::Field),
        Command::Segment(a) => run::run(a, &progress, run::Until::Segmentation),
        Command::Flatten(a) => run::run(a, &progress, run::Until::Patterns),
        Command::Check(a) => check::check(a, &progress),
        Command::Bench(a) => bench::bench(a, &progress),
        Command::Example(a) => write_example(&a.out, &progress),
        Command::Config(a) => match &a.out {
            Some(p) => {
                check_output_file(p)?;
                write_atomic(p, |w| std::io::Write::write_all(w, TEMPLATE.as_bytes()))
                    .with_context(|| format!("cannot write {}", p.display()))
                    .internal()
            }
            None => {
                print!("{TEMPLATE}");
                Ok(())
            }
        },
    }
}

/// The scenario of a run: the config file (if any), then INPUT, then flags.
pub fn resolve_scenario(args: &RunArgs) -> Result<(Config, RepairOptions), Failure> {
    let mut cfg = match &args.config {
        Some(p) => Config::from_file(p).input()?,
        None => Config::default(),
    };
    if let Some(input) = &args.input {
        let is_toml = input.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        if is_toml {
            if args.config.is_some() {
                return Err(Failure::Input(anyhow!("give the scenario either as INPUT or with --config, not both")));
            }
            cfg = Config::from_file(input).input()?;
        } else {
            cfg.mesh.path = Some(input.clone());
        }
    }
    apply_mesh_flags(&mut cfg, &args.mesh)?;
    if let Some(s) = args.seed {
        cfg.seed = s;
    }
    if args.allow_unconverged {
        cfg.solver.allow_unconverged = true;
    }
    cfg.check(None, "command line").input()?;
    Ok((cfg, repair_options(&args.mesh)))
}

fn apply_mesh_flags(cfg: &mut Config, m: &MeshArgs) -> Result<(), Failure> {
    if let Some(u) = m.units {
        cfg.mesh.units = u;
    }
    if let Some(h) = m.height {
        cfg.mesh.height = Some(h);
    }
    if let Some(up) = &m.up {
        cfg.mesh.up = Up::parse(up).map_err(|e| Failure::Input(anyhow!("--up: {e}")))?;
    }
    if let Some(n) = m.min_faces {
        cfg.mesh.min_faces = n;
    }
    if m.no_refine {
        cfg.mesh.refine = false;
    }
    Ok(())
}

/// Repair policy from the flags.
pub fn repair_options(m: &MeshArgs) -> RepairOptions {
    RepairOptions { repair: m.repair, largest_component: m.largest_component, ..Default::default() }
}

/// An output file's path is the user's to fix (exit 2) when it names a directory or a
/// directory that does not exist; a write that fails there is the machine's (exit 1).
fn check_output_file(p: &Path) -> Result<(), Failure> {
    if p.is_dir() {
        return Err(Failure::Input(anyhow!("the output path {} is a directory; name a file", p.display())));
    }
    match p.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(d) if !d.is_dir() => Err(Failure::Input(anyhow!(
            "cannot write {}: {} {}",
            p.display(),
            d.display(),
            if d.exists() { "is not a directory" } else { "does not exist" }
        ))),
        _ => Ok(()),
    }
}

fn write_example(out: &Path, progress: &Progress) -> Result<(), Failure> {
    let mesh = clothcast_mesh::shapes::rounded_tetrahedron(crate::input::EXAMPLE_HEIGHT);
    let soup = mesh.to_soup();
    let ext = out.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
    if matches!(ext.as_deref(), Some("obj" | "ply")) {
        check_output_file(out)?;
    }
    let header = "clothcast built-in example: rounded tetrahedron, 0.5 m tall along +z, units m";
    let result = match ext.as_deref() {
        Some("obj") => write_atomic(out, |w| write_obj(w, header, &soup.positions, &soup.triangles, None, None)),
        Some("ply") => write_atomic(out, |w| {
            write_ply(w, PlyFormat::BinaryLittleEndian, header, &soup.positions, &soup.triangles, &[], &[])
        }),
        _ => return Err(Failure::Input(anyhow!("{}: the example can be written as .obj or .ply", out.display()))),
    };
    result.with_context(|| format!("cannot write {}", out.display())).internal()?;
    progress.say(format!("wrote {} ({} vertices, {} faces)", out.display(), mesh.n_vertices(), mesh.n_faces()));
    Ok(())
}
