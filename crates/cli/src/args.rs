//! Command-line interface definition.

use crate::config::Units;
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

/// clothcast designs fabric formwork: give it a 3D shape, get back the sewing patterns of a
/// fabric mold that, hung up and filled with plaster or concrete, casts that shape.
///
/// Quick start: `clothcast run` runs the whole pipeline on the built-in example and writes
/// everything to clothcast-out/. `clothcast check MODEL.obj` tells whether a mesh is usable.
#[derive(Parser, Debug)]
#[command(name = "clothcast", version, about, long_about, propagate_version = true)]
pub struct Cli {
    /// More log output on stderr (-v info, -vv debug, -vvv trace).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
    /// No progress display and no informational output (errors are still printed).
    #[arg(short, long, global = true)]
    pub quiet: bool,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run the whole pipeline: every stage, every output, summary.json.
    ///
    /// INPUT is a mesh file (.obj .ply .stl .off) or a scenario file (.toml). Without INPUT
    /// the built-in example (a rounded tetrahedron 0.5 m tall) is used.
    Run(RunArgs),
    /// Run only the simulation of the filled mold: writes deformed.ply and summary.json.
    Simulate(RunArgs),
    /// Run the simulation and the cross field: adds strain_raw.ply and cross_field.ply.
    Field(RunArgs),
    /// Run up to the segmentation into patches: adds segmentation.ply and seams.obj.
    Segment(RunArgs),
    /// Run up to the sewing patterns: adds patterns/ (pattern.svg, pattern.dxf, pattern.pdf,
    /// pattern_a4.pdf, flattened.obj).
    Flatten(RunArgs),
    /// Validate a mesh and print its topology and every problem found.
    ///
    /// Exit code 0 if the mesh is usable (with the given --repair/--largest-component), 2 if not.
    Check(CheckArgs),
    /// Write the built-in example mesh (a smooth rounded tetrahedron) to a file.
    Example(ExampleArgs),
    /// Print the default scenario file, every key commented.
    Config(ConfigArgs),
    /// Time the simulation on meshes (default scenario, rescaled to --height).
    ///
    /// Reports Newton iterations, time per iteration and the time of one sparse
    /// factorization of the same system (the floor a Newton solver cannot beat).
    Bench(BenchArgs),
}

/// `clothcast bench`
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Meshes to simulate (the built-in example when none is given).
    pub meshes: Vec<PathBuf>,
    /// Scenario file (TOML) applied to every mesh.
    #[arg(short, long)]
    pub config: Option<PathBuf>,
    /// Height along up (metres) every mesh is rescaled to.
    #[arg(long, default_value_t = 0.5)]
    pub height: f64,
    /// Print the results as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Options shared by the commands that load a mesh.
#[derive(Args, Debug, Clone, Default)]
pub struct MeshArgs {
    /// Fix what can be fixed (weld duplicate vertices, drop degenerate/duplicate faces,
    /// reorient, split non-manifold vertices) and report every change.
    #[arg(long)]
    pub repair: bool,
    /// Keep only the largest connected component instead of refusing several.
    #[arg(long)]
    pub largest_component: bool,
    /// Units of the mesh coordinates (overrides mesh.units in the config).
    #[arg(long, value_enum)]
    pub units: Option<Units>,
    /// Rescale so the extent along up is this many metres (overrides mesh.height).
    #[arg(long)]
    pub height: Option<f64>,
    /// Suspension direction: +x, -x, +y, -y, +z or -z (overrides mesh.up).
    #[arg(long, allow_hyphen_values = true)]
    pub up: Option<String>,
    /// Refine a coarse mesh to at least this many faces (overrides mesh.min_faces).
    #[arg(long)]
    pub min_faces: Option<usize>,
    /// Do not refine a coarse mesh (mesh.refine = false).
    #[arg(long)]
    pub no_refine: bool,
}

/// `clothcast run`
#[derive(Args, Debug, Clone)]
pub struct RunArgs {
    /// Mesh file or scenario (.toml); the built-in example when omitted.
    pub input: Option<PathBuf>,
    /// Scenario file (TOML); see `clothcast config`.
    #[arg(short, long)]
    pub config: Option<PathBuf>,
    /// Output directory.
    #[arg(short, long, default_value = "clothcast-out")]
    pub out: PathBuf,
    /// Seed for random choices (overrides the scenario's seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Continue even if the simulation does not converge (marked in summary.json).
    #[arg(long)]
    pub allow_unconverged: bool,
    /// Mesh options.
    #[command(flatten)]
    pub mesh: MeshArgs,
}

/// `clothcast check`
#[derive(Args, Debug, Clone)]
pub struct CheckArgs {
    /// The mesh file.
    pub mesh: PathBuf,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    pub json: bool,
    /// Also show what --repair would change and whether the result is usable.
    #[arg(long)]
    pub repair: bool,
    /// Accept several components by keeping the largest.
    #[arg(long)]
    pub largest_component: bool,
}

/// `clothcast example`
#[derive(Args, Debug, Clone)]
pub struct ExampleArgs {
    /// Output file (.obj or .ply).
    #[arg(short, long, default_value = "example.obj")]
    pub out: PathBuf,
}

/// `clothcast config`
#[derive(Args, Debug, Clone)]
pub struct ConfigArgs {
    /// Write to this file instead of stdout.
    #[arg(short, long)]
    pub out: Option<PathBuf>,
}
