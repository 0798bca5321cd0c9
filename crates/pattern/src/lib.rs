//! # clothcast-pattern
//!
//! Sewing patterns: pieces with seam allowances, seam pairs, match marks, nesting on the roll, SVG/DXF/PDF output (paper §7.1).
//!
//! Input: the flattened patches and the seams. Output: pattern pieces in millimetres and the pattern files.
//!
//! This stage is not built yet: the crate holds its place in the pipeline (see
//! `docs/ARCHITECTURE.md`) and will carry its types and algorithms when its issue lands.
//! It deliberately exports nothing rather than a placeholder.
