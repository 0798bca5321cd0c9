//! # clothcast-layout
//!
//! Segmentation of the target into field-traced, quad-like, near-developable patches (paper
//! §6.1–§6.2): the fabric pieces of the mold.
//!
//! Input: the target mesh, its cross field and singularities (`clothcast-field`). Output: a
//! [`Segmentation`] — the target remeshed so that every seam is an edge path, the patch of
//! every face, the seams with the patches on their sides, corners, and figures.
//!
//! Data flow ([`segment()`]): [`vertex_field`] → [`trace`] (separatrices as shortest paths on a
//! direction-aware graph) → [`cutgraph`] (extra cuts until every patch is a disk) →
//! merge / [`split`] ([`developability`] with the hinge energy) → [`network`] (chains between
//! nodes) → [`reroute`] (chains moved onto streamlines of the field) → [`flipout`] on an [`intrinsic`] triangulation (geodesic seams) → [`remesh`] (seams
//! become edges) → [`patches`] (topology and corners) → report.
//!
//! Written by hand because no crate does it: FlipOut and the signpost intrinsic triangulation
//! exist only in geometry-central (C++); the tracing, merging and splitting are the paper's.

pub mod cutgraph;
pub mod developability;
pub mod error;
pub mod flipout;
pub mod intrinsic;
pub mod network;
pub mod patches;
pub mod remesh;
pub mod reroute;
pub mod segment;
pub mod split;
pub mod surface;
pub mod trace;
pub mod vertex_field;

pub use error::LayoutError;
pub use segment::{LayoutOptions, PatchInfo, Seam, Segmentation, SegmentationStats, SplitHint, patch_extent, segment};
pub use surface::SurfacePoint;
