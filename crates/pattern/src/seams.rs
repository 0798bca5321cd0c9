//! Seam sides, their lengths, and the notches (match marks) that pair them up.
//!
//! # Notch placement
//!
//! For a seam with sides of lengths L₁, L₂ (mean L̄), the notches sit at the seam's ends and at
//! arc lengths `s_k = k · spacing`, `k = 1..m`, measured along the seam's own direction (from
//! its 3D start), with `m = ⌊L̄ / spacing − 0.1 − ε⌋` computed once per seam (ε = 1e-9): the
//! last interior notch keeps at least a tenth of the spacing from the far end's notch (a
//! notch 0.8 mm from the end one, as a review found on bunny, is a double mark to the sewer,
//! not a match mark). Each side places notch k at its
//! *normalised* arc length `s_k / L̄ · L_side`: notch k on one side meets notch k on the other
//! when the seam is sewn, even if the flattening left the two sides slightly different in
//! length (reported by [`seam_length_mismatch`]).
//!
//! A side's arc-length parameter runs along the outline from `start` to `end` when
//! `forward`, from `end` back to `start` otherwise. A notch's normal is the outward normal of
//! the outline edge it lies on (of the run's first/last edge at the seam's ends).
//!
//! Complexity: O(run length + notches) per side.

use crate::geom::{P2, axpy, dist, right_normal, sub};
use crate::input::{PieceInput, SeamSide};
use crate::validate::{group_seams, side_edge_count};

/// Relative slack of the interior-notch count (see the module docs).
pub const NOTCH_COUNT_EPS: f64 = 1e-9;

/// The last interior notch keeps this many spacings from the seam's far end.
pub const NOTCH_END_CLEARANCE: f64 = 0.1;

/// A seam side as a polyline in the seam's own direction.
#[derive(Debug, Clone)]
pub struct SidePath {
    /// Points from the seam's start to its end.
    pub points: Vec<P2>,
    /// Outward normal of each segment `points[i] → points[i+1]`.
    pub normals: Vec<P2>,
    /// Cumulative arc length at each point (`cum[0] = 0`).
    pub cum: Vec<f64>,
}

impl SidePath {
    /// Builds the path of `side` on `outline`; `None` if its indices are invalid.
    pub fn new(outline: &[P2], side: &SeamSide) -> Option<SidePath> {
        let n = outline.len();
        if side.start >= n || side.end >= n {
            return None;
        }
        let edges = side_edge_count(side, n);
        let mut points: Vec<P2> = (0..=edges).map(|k| outline[(side.start + k) % n]).collect();
        // Normals of the counter-clockwise edges: outward whatever the walking direction.
        let mut normals: Vec<P2> = points.windows(2).map(|w| right_normal(sub(w[1], w[0]))).collect();
        if !side.forward {
            points.reverse();
            normals.reverse();
        }
        let mut cum = Vec::with_capacity(points.len());
        let mut acc = 0.0;
        cum.push(0.0);
        for w in points.windows(2) {
            acc += dist(w[0], w[1]);
            cum.push(acc);
        }
        Some(SidePath { points, normals, cum })
    }

    /// Total length.
    pub fn length(&self) -> f64 {
        *self.cum.last().unwrap_or(&0.0)
    }

    /// Point and outward normal at arc length `s` (clamped to the path).
    pub fn at(&self, s: f64) -> (P2, P2) {
        let m = self.normals.len();
        let s = s.clamp(0.0, self.length());
        // First segment whose end reaches s.
        let i = self.cum[1..].partition_point(|&c| c < s).min(m - 1);
        let len = self.cum[i + 1] - self.cum[i];
        let t = if len > 0.0 { ((s - self.cum[i]) / len).clamp(0.0, 1.0) } else { 0.0 };
        let a = self.points[i];
        let b = self.points[i + 1];
        (axpy(a, t, sub(b, a)), self.normals[i])
    }
}

/// Normalised arc-length parameters `t ∈ [0, 1]` of a seam's notches: both ends and
/// `k · spacing / L̄` for `k = 1..m`, `m = ⌊L̄ / spacing − 0.1 − ε⌋`.
pub fn notch_params(mean_length: f64, spacing: f64) -> Vec<f64> {
    let m = interior_notch_count(mean_length, spacing);
    let mut t = Vec::with_capacity(m + 2);
    t.push(0.0);
    for k in 1..=m {
        t.push(k as f64 * spacing / mean_length);
    }
    t.push(1.0);
    t
}

/// `⌊L̄ / spacing − 0.1 − ε⌋`, at least 0 (as f64 so that absurd counts can be reported).
pub fn interior_notch_count_f64(mean_length: f64, spacing: f64) -> f64 {
    (mean_length / spacing - NOTCH_END_CLEARANCE - NOTCH_COUNT_EPS).floor().max(0.0)
}

/// `⌊L̄ / spacing − 0.1 − ε⌋`, at least 0.
pub fn interior_notch_count(mean_length: f64, spacing: f64) -> usize {
    interior_notch_count_f64(mean_length, spacing) as usize
}

/// Largest relative length difference `|L₁ − L₂| / mean` over the seams with two sides (0 if
/// none). Sides with invalid indices are skipped: this never panics.
pub fn seam_length_mismatch(pieces: &[PieceInput]) -> f64 {
    let mut worst: f64 = 0.0;
    for sides in group_seams(pieces).values() {
        if sides.len() != 2 {
            continue;
        }
        let len = |&(pi, si): &(usize, usize)| {
            let p: &PieceInput = &pieces[pi];
            SidePath::new(&p.outline, &p.seams[si]).map(|s| s.length())
        };
        if let (Some(l1), Some(l2)) = (len(&sides[0]), len(&sides[1])) {
            let mean = 0.5 * (l1 + l2);
            if mean > 0.0 {
                worst = worst.max((l1 - l2).abs() / mean);
            }
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notch_counts() {
        assert_eq!(interior_notch_count(250.0, 100.0), 2);
        assert_eq!(interior_notch_count(200.0, 100.0), 1);
        assert_eq!(interior_notch_count(99.0, 100.0), 0);
        assert_eq!(notch_params(200.0, 100.0), vec![0.0, 0.5, 1.0]);
        // An interior notch less than a tenth of the spacing from the far end is left out.
        assert_eq!(interior_notch_count(100.84, 100.0), 0);
        assert_eq!(interior_notch_count(110.0, 100.0), 0);
        assert_eq!(interior_notch_count(111.0, 100.0), 1);
    }

    #[test]
    fn reversed_side_runs_backwards() {
        let sq = [[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]];
        let side = SeamSide { seam: 0, label: "A".into(), start: 0, end: 2, forward: false };
        let p = SidePath::new(&sq, &side).unwrap();
        assert_eq!(p.points[0], [100.0, 100.0]);
        assert_eq!(p.length(), 200.0);
        let (q, n) = p.at(50.0);
        assert_eq!(q, [100.0, 50.0]);
        assert_eq!(n, [1.0, 0.0]);
        let (q, n) = p.at(150.0);
        assert_eq!(q, [50.0, 0.0]);
        assert_eq!(n, [0.0, -1.0]);
    }
}
