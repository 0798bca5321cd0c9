//! # clothcast-field
//!
//! Strain cross field: synthesis from the simulated stretch, two smoothing passes, singularities and their relaxation (paper §4, §6.2.2).
//!
//! Input: the target mesh and the deformed positions. Output: a per-face 4-direction field with period jumps and its singularities.
//!
//! This stage is not built yet: the crate holds its place in the pipeline (see
//! `docs/ARCHITECTURE.md`) and will carry its types and algorithms when its issue lands.
//! It deliberately exports nothing rather than a placeholder.
