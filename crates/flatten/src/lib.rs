//! # clothcast-flatten
//!
//! Flattening of every patch with Boundary First Flattening and orientation on the fabric's warp/weft (paper §6.3, §6.4).
//!
//! Input: the segmented mesh. Output: per-patch 2D coordinates in metres and distortion statistics.
//!
//! This stage is not built yet: the crate holds its place in the pipeline (see
//! `docs/ARCHITECTURE.md`) and will carry its types and algorithms when its issue lands.
//! It deliberately exports nothing rather than a placeholder.
