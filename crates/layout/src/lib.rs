//! # clothcast-layout
//!
//! Segmentation: field-traced seams into quad-like, near-developable patches (paper §6.1, §6.2).
//!
//! Input: the target mesh and the cross field. Output: the remeshed target, the patch of every face and the seams as polylines.
//!
//! This stage is not built yet: the crate holds its place in the pipeline (see
//! `docs/ARCHITECTURE.md`) and will carry its types and algorithms when its issue lands.
//! It deliberately exports nothing rather than a placeholder.
