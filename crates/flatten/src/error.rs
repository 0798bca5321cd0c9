//! The flatten crate's error type.
//!
//! Every variant names the value that made the input unusable: a patch that is not a disk
//! (its Euler characteristic and boundary count), a sparse-solver failure, or geometry for
//! which no finite flattening can be computed.

use clothcast_mesh::sparse::SolveError;

/// What can go wrong flattening a patch.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FlattenError {
    /// BFF needs a disk: exactly one boundary loop and χ = V − E + F = 1.
    #[error("the patch is not a disk: χ = {euler}, {boundary_loops} boundary loop(s) (expected χ = 1 and one loop)")]
    NotADisk {
        /// Euler characteristic of the patch.
        euler: i64,
        /// Number of boundary loops.
        boundary_loops: usize,
    },
    /// χ = 1 and one boundary loop, but several components (a disk plus closed surfaces of
    /// total χ = 0, e.g. a torus).
    #[error("the patch has {components} components (expected one disk)")]
    Disconnected {
        /// Number of edge-connected components.
        components: usize,
    },
    /// The sparse solver failed, even with the largest allowed regularisation.
    #[error("flattening solver failure: {0}")]
    Solver(SolveError),
    /// The geometry is numerically impossible to flatten (non-finite values, a boundary curve
    /// whose tangents cannot be closed).
    #[error("degenerate patch: {reason}")]
    Degenerate {
        /// What went wrong.
        reason: String,
    },
    /// Flattening one patch of a segmentation failed.
    #[error("patch {patch}: {error}")]
    Patch {
        /// The patch.
        patch: u32,
        /// What went wrong (in the message, so not named `source`, which would make it the
        /// error's source as well and print it twice with the chain).
        error: Box<FlattenError>,
    },
}

clothcast_mesh::wrap_error!(FlattenError::Solver(SolveError));
