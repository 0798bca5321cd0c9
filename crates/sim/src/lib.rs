//! # clothcast-sim
//!
//! Simulation: the equilibrium shape of the fabric mold under the liquid infill (paper §3).
//!
//! Input: the target mesh, material, loads and boundary conditions. Output: the deformed positions, per-face principal stretches and solver statistics.
//!
//! This stage is not built yet: the crate holds its place in the pipeline (see
//! `docs/ARCHITECTURE.md`) and will carry its types and algorithms when its issue lands.
//! It deliberately exports nothing rather than a placeholder.
