//! Loading the target mesh: file or built-in example, strict validation or opt-in repair,
//! units and height scaling to metres, refinement of a coarse mesh (`mesh.refine`).

use crate::config::Config;
use crate::failure::{Blame, Failure};
use crate::stages::segmentation::roll_too_narrow;
use anyhow::anyhow;
use clothcast_mesh::io::read_mesh_file;
use clothcast_mesh::repair::{RepairOptions, RepairReport, prepare};
use clothcast_mesh::{Mesh, Vec3, VertexId, shapes, subdivide};
use serde::Serialize;

/// A refined mesh's longest edge is at most the roll's usable width over this: a patch as
/// wide as the roll is then some ten edges across, enough to be cut in two.
const EDGES_ACROSS_ROLL: f64 = 10.0;

/// Smallest and largest accepted bounding-box diagonal of the target, in metres.
const MIN_SIZE_M: f64 = 1e-4;
const MAX_SIZE_M: f64 = 1e4;

/// The refinement's face cap for the edge length (a larger `mesh.min_faces` raises it).
const MAX_REFINED_FACES: usize = 200_000;

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
    /// For each of the mesh's first `vertex_to_input.len()` vertices, the input file's vertex
    /// (the vertices refinement added, after those, have none).
    pub vertex_to_input: Vec<u32>,
    /// Vertices of the input file (before repairs): the vertices refinement added are numbered
    /// after these in messages, so that none is mistaken for an input vertex.
    pub input_vertices: usize,
    /// For each mesh face, the input file's triangle containing it.
    pub face_to_input: Vec<u32>,
    /// Faces before refinement (after repairs).
    pub unrefined_faces: usize,
    /// Edges split by the refinement (`mesh.refine`).
    pub refinement_splits: usize,
}

impl Input {
    /// The input file's number of mesh vertex `v` (a repair renumbers). A vertex the refinement
    /// added has none: it is numbered after the input file's vertices, in the order added
    /// (its own number when a repair neither removed nor added vertices).
    pub fn input_vertex(&self, v: VertexId) -> VertexId {
        VertexId::new(input_vertex(&self.vertex_to_input, self.input_vertices, v.idx()))
    }
}

/// [`Input::input_vertex`] on its maps (also before the `Input` is built).
fn input_vertex(vertex_to_input: &[u32], input_vertices: usize, v: usize) -> usize {
    match vertex_to_input.get(v) {
        Some(&i) => i as usize,
        None => input_vertices + (v - vertex_to_input.len()),
    }
}

/// The `input` section of summary.json.
#[derive(Serialize, Clone, Debug)]
pub struct InputSummary {
    /// File path or "built-in example".
    pub path: String,
    /// Vertices (after repairs and refinement: those of the mesh every stage works on).
    pub vertices: usize,
    /// Vertices after repairs, before refinement: the first `unrefined_vertices` are the input's
    /// (the ids `suspension.vertices` names).
    pub unrefined_vertices: usize,
    /// Faces (after repairs and refinement: those of the mesh every stage works on).
    pub faces: usize,
    /// Faces after repairs, before refinement (equal to `faces` when not refined).
    pub unrefined_faces: usize,
    /// Edges split by the refinement of a coarse mesh (`mesh.refine`; 0 when not refined).
    pub refinement_splits: usize,
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
            unrefined_vertices: self.vertex_to_input.len(),
            faces: m.n_faces(),
            unrefined_faces: self.unrefined_faces,
            refinement_splits: self.refinement_splits,
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
    let (label, prepared, input_vertices) = match &cfg.mesh.path {
        None => {
            let mesh = shapes::rounded_tetrahedron(EXAMPLE_HEIGHT);
            let n = (mesh.n_vertices() as u32, mesh.n_faces() as u32);
            let prepared = clothcast_mesh::repair::Prepared {
                mesh,
                report: RepairReport::default(),
                vertex_to_input: (0..n.0).collect(),
                face_to_input: (0..n.1).collect(),
            };
            ("built-in example".to_string(), prepared, n.0 as usize)
        }
        Some(path) => {
            let soup = read_mesh_file(path).input()?;
            let prepared = prepare(&soup, repair).map_err(|e| Failure::Input(anyhow!("{}: {e}", path.display())))?;
            (path.display().to_string(), prepared, soup.positions.len())
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
        if let Some(v) = p.iter().position(|x| !x.iter().all(|c| c.is_finite())) {
            // Named in the input file's numbering, as every error is.
            let v = input_vertex(&prepared.vertex_to_input, input_vertices, v);
            return Err(Failure::Input(anyhow!(
                "{label}: vertex {v} is not finite once scaled by {to_metres:e} to metres (mesh.height or mesh.units)"
            )));
        }
        mesh.set_positions(p);
    }
    // A mold between 0.1 mm and 10 km across: beyond that the units or the height are wrong,
    // and the loads and energies would under- or overflow. (The bounding box skips non-finite
    // points, hence the check above.)
    let size = mesh.bbox().diagonal();
    if !(MIN_SIZE_M..=MAX_SIZE_M).contains(&size) {
        return Err(Failure::Input(anyhow!(
            "{label}: the mesh is {size:.3e} m across once in metres (scaled by {to_metres:e}); a mold between \
             {MIN_SIZE_M} m and {MAX_SIZE_M} m is expected: check mesh.units or mesh.height"
        )));
    }
    let unrefined_faces = mesh.n_faces();
    let (mut face_to_input, mut refinement_splits) = (prepared.face_to_input, 0);
    if cfg.mesh.refine {
        // Edges at most a tenth of the roll's usable width, so that patches can be split to
        // fit it (not when the roll is refused as too narrow: the layout says so).
        let max_edge = if roll_too_narrow(cfg, mesh.total_area()) {
            f64::INFINITY
        } else {
            cfg.pattern.usable_width_m() / EDGES_ACROSS_ROLL
        };
        let cap = cfg.mesh.min_faces.max(MAX_REFINED_FACES);
        if let Some(r) = subdivide::refine(&mesh, cfg.mesh.min_faces, max_edge, cap) {
            if r.capped {
                tracing::warn!(
                    faces = r.mesh.n_faces(),
                    max_edge,
                    "{label}: refinement stopped at {cap} faces with edges still longer than a tenth of the roll's usable width"
                );
            }
            face_to_input = r.parent.iter().map(|&f| face_to_input[f.idx()]).collect();
            refinement_splits = r.splits;
            mesh = r.mesh;
        }
    }
    Ok(Input {
        label,
        mesh,
        to_metres,
        up,
        repairs: prepared.report,
        vertex_to_input: prepared.vertex_to_input,
        input_vertices,
        face_to_input,
        unrefined_faces,
        refinement_splits,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clothcast_mesh::FaceId;

    fn cube(cfg_extra: impl FnOnce(&mut Config)) -> Input {
        let mut cfg = Config::default();
        cfg.mesh.path = Some(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/meshes/closed/cube.obj").into());
        cfg_extra(&mut cfg);
        load(&cfg, &RepairOptions::default()).unwrap()
    }

    /// The 2 m, 48-face cube refined: every face maps to the input triangle it lies in (same
    /// plane, same orientation), the input's vertices keep their ids and positions, and no
    /// edge is longer than a tenth of the roll's usable width.
    #[test]
    fn a_coarse_mesh_is_refined_with_its_maps() {
        let raw = cube(|c| c.mesh.refine = false);
        assert_eq!((raw.mesh.n_faces(), raw.refinement_splits), (48, 0));
        let r = cube(|_| {});
        assert_eq!(r.unrefined_faces, 48);
        assert_eq!(r.mesh.n_faces(), 48 + 2 * r.refinement_splits);
        assert_eq!(r.vertex_to_input.len(), raw.mesh.n_vertices());
        for v in raw.mesh.vertices() {
            assert_eq!(r.mesh.position(v), raw.mesh.position(v));
        }
        let (nr, nraw) = (r.mesh.face_normals(), raw.mesh.face_normals());
        for f in r.mesh.face_ids() {
            let p = FaceId::new(r.face_to_input[f.idx()] as usize);
            assert!((nr[f] - nraw[p]).norm() < 1e-9, "face {f:?} not in input face {p:?}");
            let c = r.mesh.face_positions(f).iter().sum::<Vec3>() / 3.0;
            assert!((c - raw.mesh.position(raw.mesh.face_vertices(p)[0])).dot(&nraw[p]).abs() < 1e-9);
        }
        let limit = Config::default().pattern.usable_width_m() / EDGES_ACROSS_ROLL;
        assert!(r.mesh.edge_lengths().iter().all(|&l| l <= limit));
        let s = r.summary();
        assert_eq!((s.unrefined_faces, s.unrefined_vertices), (48, 26));
        // A larger minimum is honoured.
        let more = cube(|c| c.mesh.min_faces = 20_000);
        assert!(more.mesh.n_faces() >= 20_000);
    }

    /// The cube with an unused 27th vertex, repaired (the vertex dropped) and refined: the
    /// vertices refinement added are named after the input file's 27, never as the dropped one.
    #[test]
    fn refined_vertices_are_numbered_after_the_input_files() {
        let dir = std::env::temp_dir().join(format!("clothcast-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("cube_unused.obj");
        let cube = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/meshes/closed/cube.obj"));
        std::fs::write(&path, cube.unwrap() + "v 9 9 9\n").unwrap();
        let mut cfg = Config::default();
        cfg.mesh.path = Some(path);
        let r = load(&cfg, &RepairOptions { repair: true, ..Default::default() }).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!((r.input_vertices, r.vertex_to_input.len()), (27, 26));
        assert!(r.mesh.n_vertices() > 26, "refined");
        assert_eq!(r.input_vertex(VertexId::new(25)), VertexId::new(25));
        assert_eq!(r.input_vertex(VertexId::new(26)), VertexId::new(27));
        let last = r.mesh.n_vertices() - 1;
        assert_eq!(r.input_vertex(VertexId::new(last)), VertexId::new(last + 1));
    }
}
