//! The layout crate's error type.

use clothcast_mesh::MeshError;
use clothcast_mesh::sparse::SolveError;

/// What can go wrong segmenting a mesh.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LayoutError {
    /// A path given to a layout routine is not a valid edge path (a bug of the caller).
    #[error("invalid path {path}: {reason}")]
    InvalidPath {
        /// Index of the path.
        path: usize,
        /// What is wrong.
        reason: String,
    },
    /// A patch is not a topological disk after all cuts (should never happen; reported loudly).
    #[error("patch {patch} is not a disk (Euler characteristic {euler}, {boundary_loops} boundary loops)")]
    NotADisk {
        /// The patch.
        patch: usize,
        /// Its Euler characteristic.
        euler: i64,
        /// Its boundary loops.
        boundary_loops: usize,
    },
    /// Tracing a geodesic across the surface failed (numerical trouble).
    #[error("geodesic tracing failed: {0}")]
    Trace(String),
    /// Remeshing produced an invalid mesh (internal).
    #[error("remeshing produced an invalid mesh: {0}")]
    Remesh(MeshError),
    /// A sparse solve failed (internal).
    #[error("layout solver failure: {0}")]
    Solver(SolveError),
}

clothcast_mesh::wrap_error!(LayoutError::Solver(SolveError));
clothcast_mesh::wrap_error!(LayoutError::Remesh(MeshError));
