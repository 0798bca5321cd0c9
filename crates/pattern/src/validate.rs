//! Input validation: everything [`crate::build_pattern`] checks before any geometry.
//!
//! Strict, no repair: the first problem found is returned as a typed [`PatternError`] naming
//! the piece, seam, vertex or option. Pieces are checked in input order, and within a piece
//! coordinates, point count, repeated points, orientation, simplicity, then seams.
//!
//! Complexity: O(Σ n log n) for the simplicity sweeps (n = outline points).

use std::collections::BTreeMap;

use crate::error::PatternError;
use crate::geom::{find_self_intersection, signed_area};
use crate::input::{PatternOptions, PieceInput, SeamSide};

/// Largest accepted |coordinate| (mm): keeps every derived quantity (areas, the polygon
/// union's integer grid, PDF sizes) finite and meaningful.
pub const MAX_COORDINATE_MM: f64 = 1e9;

/// Checks the options' ranges.
pub fn validate_options(o: &PatternOptions) -> Result<(), PatternError> {
    let checks: [(&'static str, f64, bool, &'static str); 6] = [
        ("seam_allowance_mm", o.seam_allowance_mm, o.seam_allowance_mm >= 0.0, "a finite value ≥ 0"),
        ("notch_spacing_mm", o.notch_spacing_mm, o.notch_spacing_mm > 0.0, "a finite value > 0"),
        ("notch_length_mm", o.notch_length_mm, o.notch_length_mm >= 0.0, "a finite value ≥ 0"),
        ("fabric_width_mm", o.fabric_width_mm, o.fabric_width_mm > 0.0, "a finite value > 0"),
        ("piece_gap_mm", o.piece_gap_mm, o.piece_gap_mm >= 0.0, "a finite value ≥ 0"),
        ("text_height_mm", o.text_height_mm, o.text_height_mm > 0.0, "a finite value > 0"),
    ];
    for (name, value, ok, expected) in checks {
        if !(ok && value.is_finite()) {
            return Err(PatternError::InvalidOption { name, value, expected });
        }
    }
    Ok(())
}

/// The number of outline edges of a seam side (walking counter-clockwise from start to end).
pub fn side_edge_count(side: &SeamSide, n: usize) -> usize {
    match (side.end + n - side.start) % n {
        0 => n, // round the whole outline
        k => k,
    }
}

/// Checks one piece: coordinates, size, orientation, simplicity, seam indices and overlaps.
pub fn validate_piece(p: &PieceInput) -> Result<(), PatternError> {
    let piece = p.id;
    for (vertex, q) in p.outline.iter().enumerate() {
        if !(q[0].is_finite() && q[1].is_finite()) {
            return Err(PatternError::NonFiniteCoordinate { piece, vertex, x: q[0], y: q[1] });
        }
        if q[0].abs() > MAX_COORDINATE_MM || q[1].abs() > MAX_COORDINATE_MM {
            return Err(PatternError::CoordinateOutOfRange {
                piece,
                vertex,
                x: q[0],
                y: q[1],
                limit: MAX_COORDINATE_MM,
            });
        }
    }
    for (mark, m) in p.marks.iter().enumerate() {
        if !(m.position[0].is_finite() && m.position[1].is_finite()) {
            return Err(PatternError::NonFiniteMark { piece, mark, x: m.position[0], y: m.position[1] });
        }
    }
    let n = p.outline.len();
    if n < 3 {
        return Err(PatternError::TooFewPoints { piece, points: n });
    }
    for vertex in 0..n {
        let next = (vertex + 1) % n;
        if p.outline[vertex] == p.outline[next] {
            return Err(PatternError::RepeatedPoint { piece, vertex, next });
        }
    }
    let area = signed_area(&p.outline);
    if !(area > 0.0) {
        return Err(PatternError::Clockwise { piece, signed_area_mm2: area });
    }
    if let Some((edge_a, edge_b)) = find_self_intersection(&p.outline) {
        return Err(PatternError::SelfIntersecting { piece, edge_a, edge_b });
    }
    let mut owner: Vec<Option<usize>> = vec![None; n];
    for s in &p.seams {
        for index in [s.start, s.end] {
            if index >= n {
                return Err(PatternError::SeamIndexOutOfRange { piece, seam: s.seam, index, points: n });
            }
        }
        for k in 0..side_edge_count(s, n) {
            let edge = (s.start + k) % n;
            if let Some(seam_a) = owner[edge] {
                return Err(PatternError::OverlappingSeamSides { piece, seam_a, seam_b: s.seam, edge });
            }
            owner[edge] = Some(s.seam);
        }
    }
    Ok(())
}

/// Where each seam's sides are: seam id → list of (piece index, side index), in input order.
pub type SeamSides = BTreeMap<usize, Vec<(usize, usize)>>;

/// Groups the seam sides of all pieces by seam id (no validation).
pub fn group_seams(pieces: &[PieceInput]) -> SeamSides {
    let mut seams: SeamSides = BTreeMap::new();
    for (pi, p) in pieces.iter().enumerate() {
        for (si, s) in p.seams.iter().enumerate() {
            seams.entry(s.seam).or_default().push((pi, si));
        }
    }
    seams
}

/// Checks that every seam has exactly two sides.
pub fn validate_seams(pieces: &[PieceInput], seams: &SeamSides) -> Result<(), PatternError> {
    for (&seam, sides) in seams {
        match sides.len() {
            2 => {}
            1 => return Err(PatternError::SeamOneSide { seam, piece: pieces[sides[0].0].id }),
            k => return Err(PatternError::SeamTooManySides { seam, sides: k }),
        }
    }
    Ok(())
}

/// Checks the whole input: options, then every piece, unique ids, then the seams.
pub fn validate(pieces: &[PieceInput], opts: &PatternOptions) -> Result<SeamSides, PatternError> {
    validate_options(opts)?;
    if pieces.is_empty() {
        return Err(PatternError::NoPieces);
    }
    let mut ids = std::collections::BTreeSet::new();
    for p in pieces {
        validate_piece(p)?;
        if !ids.insert(p.id) {
            return Err(PatternError::DuplicatePieceId { piece: p.id });
        }
    }
    let seams = group_seams(pieces);
    validate_seams(pieces, &seams)?;
    Ok(seams)
}
