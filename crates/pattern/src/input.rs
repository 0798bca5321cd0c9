//! What the pattern stage takes: flattened pieces with their seams and marks, and the options.
//!
//! Conventions: millimetres; piece coordinates with the fabric's warp along +x and y up
//! (mathematical orientation), as the flattening stage orients them (paper §6.4).

use crate::geom::P2;

/// One flattened patch, in mm, warp along +x.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PieceInput {
    /// Patch id (unique among the pieces; names the piece in errors and outputs).
    pub id: usize,
    /// Display name, e.g. "P3".
    pub name: String,
    /// Sew line: closed polygon, counter-clockwise, no repeated last point, simple.
    pub outline: Vec<P2>,
    /// The parts of the outline that are sewn to another side.
    pub seams: Vec<SeamSide>,
    /// Points to mark (suspension, clamp, pour), in piece coordinates.
    pub marks: Vec<PointMark>,
}

/// A contiguous run of outline edges that is one side of a seam.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct SeamSide {
    /// Seam id: the two sides of a seam share it.
    pub seam: usize,
    /// Printed on both sides, e.g. "A7".
    pub label: String,
    /// Outline index where the run starts (walking counter-clockwise, i.e. by increasing
    /// index, wrapping).
    pub start: usize,
    /// Outline index where the run ends (inclusive vertex). `start == end` is a seam round the
    /// whole outline (a closed loop: a piece bounded by one seam), from `start` back to it.
    pub end: usize,
    /// True if walking counter-clockwise from `start` to `end` follows the seam's own
    /// direction (its 3D start → end); false if opposite.
    pub forward: bool,
}

/// A point to mark on a piece.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PointMark {
    /// What the point is for.
    pub kind: MarkKind,
    /// Position in piece coordinates (mm).
    pub position: P2,
    /// Printed next to the mark.
    pub label: String,
}

/// The purpose of a marked point (each is drawn with its own symbol).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MarkKind {
    /// Where the formwork hangs from the frame: drawn as a circle with a cross.
    Suspension,
    /// Where the fabric is clamped to the frame: drawn as a square with a cross.
    Clamp,
    /// An opening for pouring the infill: drawn as a triangle with a cross.
    Pour,
}

/// Options of [`crate::build_pattern`]. Every length is in millimetres.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PatternOptions {
    /// Seam allowance: distance from the sew line to the cut line (≥ 0). Default 15.
    pub seam_allowance_mm: f64,
    /// Spacing of the match marks (notches) along a seam (> 0). Default 100.
    pub notch_spacing_mm: f64,
    /// Length of a notch: a slit from the cut line inwards (≥ 0). Default 6.
    pub notch_length_mm: f64,
    /// Usable width of the fabric roll (> 0). Default 1500.
    pub fabric_width_mm: f64,
    /// Allow quarter turns on the roll (warp and weft swapped). Default false: only 0° and
    /// 180°, which keep the warp along the roll.
    pub allow_weft_swap: bool,
    /// Minimum spacing between the cut lines of nested pieces (≥ 0). Default 10.
    pub piece_gap_mm: f64,
    /// Height of the printed labels (> 0). Default 12.
    pub text_height_mm: f64,
}

impl Default for PatternOptions {
    fn default() -> Self {
        Self {
            seam_allowance_mm: 15.0,
            notch_spacing_mm: 100.0,
            notch_length_mm: 6.0,
            fabric_width_mm: 1500.0,
            allow_weft_swap: false,
            piece_gap_mm: 10.0,
            text_height_mm: 12.0,
        }
    }
}
