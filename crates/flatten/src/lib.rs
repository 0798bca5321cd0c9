//! # clothcast-flatten
//!
//! The flattening stage of the pipeline (paper §6.3): every patch of the segmented surface
//! becomes a flat sewing-pattern piece. Input: one disk-topology patch (a [`clothcast_mesh::Mesh`],
//! usually a [`clothcast_mesh::submesh::Submesh`] of the segmented target); output: a 2D
//! position per vertex in metres and distortion statistics.
//!
//! - [`bff`]: Boundary First Flattening (Sawhney & Crane 2017) in its minimal-area-distortion
//!   mode — zero boundary scale factors, so every boundary edge keeps its 3D length (up to the
//!   small correction that closes the boundary curve, reported in [`FlatteningStats`]) and the
//!   two sides of a seam stay the same length; [`distortion`] measures any 2D layout.
//! - [`pieces`]: the whole stage on a [`clothcast_layout::Segmentation`] — cut every patch
//!   out, flatten it by BFF (flips retried and untangled), scale all pieces by one common factor
//!   to the target's area, orient each on the fabric's warp/weft ([`Orientation::Field`], the
//!   closed-form best alignment with the cross field, or the paper's [`Orientation::LongestSide`]
//!   heuristics), and list every seam's side on every piece ([`SeamRun`]) for the sewing plan;
//!   [`FlattenReport`] (with a [`PieceReport`] per piece) is the summary's `flattening`.
//! - [`error`]: the error type, [`FlattenError`].
//!
//! ```
//! use clothcast_flatten::{bff_flatten, BffOptions};
//! let patch = clothcast_mesh::shapes::grid(8, 6, 0.4, 0.3);
//! let flat = bff_flatten(&patch, &BffOptions::default()).unwrap();
//! assert_eq!(flat.stats.flipped_triangles, 0);
//! assert!((flat.stats.area_ratio - 1.0).abs() < 1e-9);
//! ```

pub mod bff;
pub mod error;
pub mod pieces;
mod untangle;

pub use bff::{BffOptions, BffProblem, BoundaryRelief, Flattening, FlatteningStats, bff_flatten, distortion};
pub use error::FlattenError;
pub use pieces::{
    DistortionLimits, FlatPatch, FlatPieces, FlattenOptions, FlattenReport, Orientation, OutlineRepair,
    PieceFlattening, PieceReport, SeamRun, WarpAlong, convex_flattening, flatten_piece, flatten_segmentation,
    outline_crossing,
};
