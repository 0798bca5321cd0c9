//! # clothcast-pattern
//!
//! Sewing patterns you can cut (paper §7.1 (A)): the last stage of the pipeline turns the
//! flattened, oriented pieces into pattern pieces with seam allowances, match marks and
//! labels, nests them on the fabric roll, and writes SVG, DXF and PDF files.
//!
//! ## Data flow
//!
//! ```text
//! [PieceInput] (mm, warp = +x, CCW sew line, seam sides, marks) + PatternOptions
//!   -> validate          typed PatternError naming piece / seam / vertex / option
//!   -> offset            cut line = sew line ⊕ allowance (mitred, clipped at 2r)
//!   -> seams             notches paired by normalised arc length along each seam
//!   -> pattern           labels, grain arrow, seam labels, marks -> Piece
//!   -> nest              bottom-left fill of the cut lines on the roll -> Placement
//!   = Pattern            pieces + roll length + utilisation + PatternStats
//!   -> output            PatternWriter: SvgWriter, DxfWriter, PdfWriter{Pieces, TiledA4}
//! ```
//!
//! - [`input`]: [`PieceInput`], [`SeamSide`], [`PointMark`], [`MarkKind`], [`PatternOptions`].
//! - [`validate`](mod@validate): the input checks (strict, no repair).
//! - [`offset`]: the seam allowance as a union of convex pieces, computed with `i_overlay`
//!   (exact on the collinear overlaps the construction creates; why a crate: see there).
//! - [`seams`]: seam sides as arc-length paths, notch parameters, [`seam_length_mismatch`].
//! - [`nest`]: bottom-left fill against a banded profile of the placed cut lines (pieces
//!   interlock, not just their boxes), 0°/180° (and 90°/270° with weft swap).
//! - [`pattern`](mod@pattern): [`Pattern`], [`Piece`], [`build_pattern`].
//! - [`output`]: the writers over one shared y-up drawing model (SVG flips y once).
//! - [`geom`]: the small 2D kernel (areas, predicates, simplicity sweep, distances).
//!
//! ## Choices
//!
//! - Coordinates: millimetres, y up. On the roll, x runs along the roll (the warp, the long
//!   direction, growing from 0) and y across it, in `[0, fabric_width_mm]`.
//! - Cut line: mitred corners; a miter longer than [`MITER_LIMIT`]` · allowance` is clipped
//!   perpendicular to the bisector (not bevelled, which would eat into the allowance); dents
//!   closed by a disc of [`DENT_RADIUS`] allowances ([`cut_line`]), the fabric added kept
//!   within [`MITER_LIMIT`]` · allowance` of the sew line.
//! - Notches: at both ends of every seam and every `notch_spacing_mm` along the seam's own
//!   direction, at the same normalised arc length on both sides; drawn as a slit of
//!   `notch_length_mm` from the cut line inwards.
//! - Nesting keeps the grain: the warp stays along the roll unless `allow_weft_swap`.
//! - Outputs: hand-written SVG and R12 DXF (no dependency), `pdf-writer` for PDF; the PDF
//!   per piece is 1:1 with a scale-check bar, the A4 tiling overlaps by 10 mm.
//! - Strict input: any problem is a typed [`PatternError`] naming the piece, seam, vertex or
//!   option; nothing is repaired silently.
//!
//! ## Complexity
//!
//! Per piece with n outline points: O(n log n) validation and offset, O(n) per notch ray,
//! O((24² + 9²) · n) for the label anchor, O(candidates · n) per label placed (a few hundred
//! candidates); nesting O(N · B²) per fill for N pieces and B = 401 bands
//! across the roll (six fills at most). Everything is sequential and deterministic: the same
//! input gives byte-identical files. A 4000-point piece takes ~0.15 s in release.
//!
//! ```
//! use clothcast_pattern::{PieceInput, SeamSide, PatternOptions, build_pattern, SvgWriter, PatternWriter};
//! let rect = |id: usize, x0: f64| PieceInput {
//!     id,
//!     name: format!("P{id}"),
//!     outline: vec![[x0, 0.0], [x0 + 300.0, 0.0], [x0 + 300.0, 200.0], [x0, 200.0]],
//!     // The right side of piece 0 is sewn to the left side of piece 1, bottom to top.
//!     seams: vec![if id == 0 {
//!         SeamSide { seam: 7, label: "A7".into(), start: 1, end: 2, forward: true }
//!     } else {
//!         SeamSide { seam: 7, label: "A7".into(), start: 3, end: 0, forward: false }
//!     }],
//!     marks: vec![],
//! };
//! let pattern = build_pattern(&[rect(0, 0.0), rect(1, 0.0)], &PatternOptions::default()).unwrap();
//! assert_eq!(pattern.stats.notches, 2 * 3); // ends + one at 100 mm, on each side
//! let mut svg = Vec::new();
//! SvgWriter.write(&pattern, &mut svg).unwrap();
//! assert!(pattern.utilisation > 0.0 && pattern.utilisation <= 1.0);
//! ```

pub mod error;
pub use clothcast_mesh::polygon as geom;
pub mod input;
mod labels;
pub mod nest;
pub mod offset;
pub mod output;
pub mod pattern;
pub mod seams;
pub mod validate;

pub use error::PatternError;
pub use geom::P2;
pub use input::{MarkKind, PatternOptions, PieceInput, PointMark, SeamSide};
pub use offset::{DENT_RADIUS, MITER_LIMIT, cut_line, offset_polygon};
pub use output::{DxfWriter, PatternWriter, PdfMode, PdfWriter, SvgWriter, all_writers};
pub use pattern::{GrainArrow, Notch, Pattern, PatternStats, Piece, Placement, Text, build_pattern};
pub use seams::seam_length_mismatch;
