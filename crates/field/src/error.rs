//! The field crate's error type.

use clothcast_mesh::sparse::SolveError;

/// What can go wrong computing a field.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FieldError {
    /// The deformed positions do not match the mesh.
    #[error("the deformed mesh has {got} vertices, the target {expected}")]
    VertexCountMismatch {
        /// Target vertices.
        expected: usize,
        /// Deformed vertices.
        got: usize,
    },
    /// The strain source needs the simulated positions.
    #[error("the strain field needs the simulated (deformed) positions")]
    MissingDeformation,
    /// The sparse solver failed (internal).
    #[error("field solver failure: {0}")]
    Solver(SolveError),
}

clothcast_mesh::wrap_error!(FieldError::Solver(SolveError));
