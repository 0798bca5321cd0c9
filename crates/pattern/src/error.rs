//! The pattern crate's error type.
//!
//! Every input error names the piece (by its [`crate::PieceInput::id`]), the seam (by its
//! seam id), the vertex or edge and the offending value, so that the caller can point at it.
//! Validation runs before any geometry, so these are returned instead of a panic for any
//! input.

/// What can go wrong building or writing a pattern.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PatternError {
    /// No pieces were given.
    #[error("no pieces to lay out")]
    NoPieces,
    /// Two pieces share an id (ids name the pieces in the outputs).
    #[error("piece id {piece} is used by more than one piece")]
    DuplicatePieceId {
        /// The repeated id.
        piece: usize,
    },
    /// A coordinate of a piece's outline is NaN or infinite.
    #[error("piece {piece}: vertex {vertex} has a non-finite coordinate ({x}, {y})")]
    NonFiniteCoordinate {
        /// Piece id.
        piece: usize,
        /// Outline index.
        vertex: usize,
        /// x coordinate.
        x: f64,
        /// y coordinate.
        y: f64,
    },
    /// A coordinate of a piece's outline is larger in magnitude than
    /// [`crate::validate::MAX_COORDINATE_MM`] (1000 km: certainly a unit error).
    #[error("piece {piece}: vertex {vertex} at ({x}, {y}) is beyond ±{limit} mm (wrong units?)")]
    CoordinateOutOfRange {
        /// Piece id.
        piece: usize,
        /// Outline index.
        vertex: usize,
        /// x coordinate.
        x: f64,
        /// y coordinate.
        y: f64,
        /// The limit (mm).
        limit: f64,
    },
    /// A marked point is NaN or infinite.
    #[error("piece {piece}: mark {mark} has a non-finite position ({x}, {y})")]
    NonFiniteMark {
        /// Piece id.
        piece: usize,
        /// Index in the piece's marks.
        mark: usize,
        /// x coordinate.
        x: f64,
        /// y coordinate.
        y: f64,
    },
    /// The outline has fewer than 3 points.
    #[error("piece {piece}: the outline has {points} point(s), at least 3 are needed")]
    TooFewPoints {
        /// Piece id.
        piece: usize,
        /// Number of outline points.
        points: usize,
    },
    /// Two consecutive outline points coincide (a zero-length edge).
    #[error("piece {piece}: outline points {vertex} and {next} coincide")]
    RepeatedPoint {
        /// Piece id.
        piece: usize,
        /// Outline index of the first point.
        vertex: usize,
        /// Outline index of the next point (0 when the last point repeats the first).
        next: usize,
    },
    /// Two outline edges cross or touch (edge `i` joins vertices `i` and `i + 1`).
    #[error("piece {piece}: the outline is not simple, edges {edge_a} and {edge_b} intersect")]
    SelfIntersecting {
        /// Piece id.
        piece: usize,
        /// First edge.
        edge_a: usize,
        /// Second edge.
        edge_b: usize,
    },
    /// The outline runs clockwise (or has zero area).
    #[error("piece {piece}: the outline must run counter-clockwise, its signed area is {signed_area_mm2} mm²")]
    Clockwise {
        /// Piece id.
        piece: usize,
        /// Signed area (≤ 0).
        signed_area_mm2: f64,
    },
    /// A seam side's start or end index is not an outline index.
    #[error("piece {piece}: seam {seam} refers to outline index {index}, but the outline has {points} points")]
    SeamIndexOutOfRange {
        /// Piece id.
        piece: usize,
        /// Seam id.
        seam: usize,
        /// The bad index.
        index: usize,
        /// Number of outline points.
        points: usize,
    },
    /// A seam side whose path along the outline cannot be built. Not produced since
    /// `start == end` became a seam round the whole outline (a closed loop); kept so that code
    /// matching on it still compiles.
    #[error("piece {piece}: seam {seam} starts and ends at outline index {index}")]
    EmptySeamSide {
        /// Piece id.
        piece: usize,
        /// Seam id.
        seam: usize,
        /// The index.
        index: usize,
    },
    /// Two seam sides of a piece share an outline edge.
    #[error("piece {piece}: seams {seam_a} and {seam_b} both claim outline edge {edge}")]
    OverlappingSeamSides {
        /// Piece id.
        piece: usize,
        /// Seam claiming the edge first.
        seam_a: usize,
        /// Seam claiming it again.
        seam_b: usize,
        /// Outline edge.
        edge: usize,
    },
    /// A seam with only one side among all pieces.
    #[error("seam {seam} has a single side (on piece {piece}); every seam needs two")]
    SeamOneSide {
        /// Seam id.
        seam: usize,
        /// Piece holding the side.
        piece: usize,
    },
    /// A seam with more than two sides.
    #[error("seam {seam} has {sides} sides; a seam joins exactly two")]
    SeamTooManySides {
        /// Seam id.
        seam: usize,
        /// Number of sides found.
        sides: usize,
    },
    /// An option is out of its range (or not finite).
    #[error("option {name} = {value} is invalid: expected {expected}")]
    InvalidOption {
        /// Option name (a field of [`crate::PatternOptions`]).
        name: &'static str,
        /// Given value.
        value: f64,
        /// The valid range.
        expected: &'static str,
    },
    /// A seam would get an unreasonable number of notches (spacing too small for its length).
    #[error(
        "seam {seam}: {} notches at the given spacing (the limit is {limit}); increase notch_spacing_mm",
        if *.count < 1e9 { format!("{:.0}", .count) } else { format!("{:.2e}", .count) }
    )]
    TooManyNotches {
        /// Seam id.
        seam: usize,
        /// Notches the seam would get.
        count: f64,
        /// The limit.
        limit: usize,
    },
    /// A piece (with its seam allowance) is wider than the roll in every allowed rotation.
    #[error(
        "piece {piece} ({name}) is {width_mm:.1} mm along the warp by {height_mm:.1} mm across (with seam allowance) \
         and does not fit the {fabric_width_mm} mm roll{}",
        if *weft_swap { " in any rotation" } else { " with the warp along the roll (allow_weft_swap is off)" }
    )]
    PieceTooWide {
        /// Piece id.
        piece: usize,
        /// Piece name.
        name: String,
        /// Cut-line extent along the warp (piece x).
        width_mm: f64,
        /// Cut-line extent across the warp (piece y).
        height_mm: f64,
        /// Roll width.
        fabric_width_mm: f64,
        /// Whether quarter turns were allowed.
        weft_swap: bool,
        /// Every piece too wide, this one first: its id and its cut line's width across the
        /// roll (the narrower side with quarter turns) over the roll's width.
        too_wide: Vec<(usize, f64)>,
    },
    /// The seam allowance could not be computed (the polygon union returned nothing); not
    /// expected for validated input.
    #[error("piece {piece}: the seam allowance offset failed")]
    OffsetFailed {
        /// Piece id.
        piece: usize,
    },
    /// A PDF page would exceed what PDF can describe even with `UserUnit` scaling.
    #[error("piece {piece}: a {width_mm:.0} × {height_mm:.0} mm page is too large for PDF")]
    PageTooLarge {
        /// Piece id.
        piece: usize,
        /// Page width.
        width_mm: f64,
        /// Page height.
        height_mm: f64,
    },
    /// The A4 tiling of the roll would need more pages than [`crate::output::pdf::MAX_TILES`].
    #[error("the A4 tiling of a {length_mm:.0} × {width_mm:.0} mm layout needs {pages} pages (the limit is {limit})")]
    TooManyPages {
        /// Roll length used.
        length_mm: f64,
        /// Roll width.
        width_mm: f64,
        /// Pages needed.
        pages: usize,
        /// The limit.
        limit: usize,
    },
    /// Writing an output failed.
    #[error("write error: {0}")]
    Io(std::io::Error),
}

clothcast_mesh::wrap_error!(PatternError::Io(std::io::Error));

impl PatternError {
    /// Whether the options are to blame (an option out of range, or options that ask for more
    /// notches, a larger page or more pages than the writers make, or a roll too narrow for a
    /// piece), rather than the pieces given.
    pub fn is_option_error(&self) -> bool {
        matches!(
            self,
            Self::InvalidOption { .. }
                | Self::TooManyNotches { .. }
                | Self::PieceTooWide { .. }
                | Self::PageTooLarge { .. }
                | Self::TooManyPages { .. }
        )
    }
}
