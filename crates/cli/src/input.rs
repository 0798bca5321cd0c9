//! Loading the target mesh: file or built-in example, strict validation or opt-in repair,
//! units and height scaling to metres.

use crate::config::Config;
use crate::failure::{Blame, Failure};
use anyhow::anyhow;
use clothcast_mesh::io::read_mesh_file;
use clothcast_mesh::repair::{RepairOptions, RepairReport, prepare};
use clothcast_mesh::{Mesh, Vec3, shapes};
use serde::Serialize;

/// Height of the built-in example (metres).
pub const EXAMPLE_HEIGHT: f64 = 0.5;

/// The target mesh, in metres, ready for the pipeline.
pub struct Input {
    /// Where it came from ("built-in example" or the file path).
    pub label: String,
    /// The mesh in metres (input coordinates × `to_metres`).
    pub mesh: Mesh,
    /// Metres per input unit (outputs in 3D are written back in input units).
    pub to_metres: f64,
    /// Unit up direction.
    pub up: Vec3,
    /// What `--repair` / `--largest-component` changed.
    pub repairs: RepairReport,
    /// For each mesh vertex, the input file's vertex.
    #[allow(dead_code)] // read by the simulation stage (explicit suspension vertices)
    pub vertex_to_input: Vec<u32>,
    /// For each mesh face, the input file's triangle.
    #[allow(dead_code)] // kept for outputs that refer back to input faces
    pub face_to_input: Vec<u32>,
}

/// The `input` section of summary.json.
#[derive(Serialize, Clone, Debug)]
pub struct InputSummary {
    /// File path or "built-in example".
    pub path: String,
    /// Vertices (after repairs).
    pub vertices: usize,
    /// Faces (after repairs).
    pub faces: usize,
    /// Connected components.
    pub components: usize,
    /// Boundary loops.
    pub boundary_loops: usize,
    /// χ = V − E + F.
    pub euler_characteristic: i64,
    /// Genus.
    pub genus: i64,
    /// Surface area (m²).
    pub area_m2: f64,
    /// Bounding-box diagonal (m).
    pub bbox_diagonal_m: f64,
    /// Metres per input unit.
    pub metres_per_unit: f64,
    /// What was repaired (all zero without `--repair`).
    pub repairs: RepairReport,
}

impl Input {
    /// Summary figures.
    pub fn summary(&self) -> InputSummary {
        let m = &self.mesh;
        InputSummary {
            path: self.label.clone(),
            vertices: m.n_vertices(),
            faces: m.n_faces(),
            components: m.n_components(),
            boundary_loops: m.boundary_loops().len(),
            euler_characteristic: m.euler_characteristic(),
            genus: m.genus(),
            area_m2: m.total_area(),
            bbox_diagonal_m: m.bbox().diagonal(),
            metres_per_unit: self.to_metres,
            repairs: self.repairs.clone(),
        }
    }
}

/// Load the scenario's mesh (or the built-in example) and scale it to metres.
pub fn load(cfg: &Config, repair: &RepairOptions) -> Result<Input, Failure> {
    let up = Vec3::from(cfg.mesh.up.unit());
    let (label, prepared) = match &cfg.mesh.path {
        None => {
            let mesh = shapes::rounded_tetrahedron(EXAMPLE_HEIGHT);
            let n = (mesh.n_vertices() as u32, mesh.n_faces() as u32);
            let prepared = clothcast_mesh::repair::Prepared {
                mesh,
                report: RepairReport::default(),
                vertex_to_input: (0..n.0).collect(),
                face_to_input: (0..n.1).collect(),
            };
            ("built-in example".to_string(), prepared)
        }
        Some(path) => {
            let soup = read_mesh_file(path).input()?;
            let prepared = prepare(&soup, repair).map_err(|e| Failure::Input(anyhow!("{}: {e}", path.display())))?;
            (path.display().to_string(), prepared)
        }
    };
    let mut mesh = prepared.mesh;
    let to_metres = match cfg.mesh.height {
        Some(h) => {
            let (lo, hi) = mesh.positions().iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                let d = p.dot(&up);
                (lo.min(d), hi.max(d))
            });
            if !(hi > lo) {
                return Err(Failure::Input(anyhow!(
                    "{label}: the mesh has no extent along the up direction, cannot rescale to height {h} m"
                )));
            }
            h / (hi - lo)
        }
        None if cfg.mesh.path.is_none() => 1.0,
        None => cfg.mesh.units.to_metres(),
    };
    if to_metres != 1.0 {
        let p = mesh.positions().map(|x| x * to_metres);
        mesh.set_positions(p);
    }
    Ok(Input {
        label,
        mesh,
        to_metres,
        up,
        repairs: prepared.report,
        vertex_to_input: prepared.vertex_to_input,
        face_to_input: prepared.face_to_input,
    })
}
