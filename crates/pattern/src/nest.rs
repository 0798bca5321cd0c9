//! Nesting: placing the pieces on the fabric roll.
//!
//! # Convention
//!
//! The roll runs along the warp, which is the pieces' x axis: roll x is the length (grows from
//! 0 as pieces are added), roll y is across the roll, in `[0, fabric_width]`. A piece keeps
//! its grain: it turns by 0° or 180° (warp along the roll), or also by 90°/270° when
//! `allow_weft_swap` (warp and weft exchanged).
//!
//! # Heuristic: bottom-left fill against a banded profile
//!
//! The roll is cut into horizontal bands of height `cell = width / 400` (3.75 mm on a 1.5 m
//! roll). For every band the *frontier* is the largest x reached so far by any placed piece in
//! that band. Each piece is first dilated by half the gap (with [`crate::offset_polygon`],
//! which contains the exact Minkowski dilation), and for each rotation its exact x-extent in
//! each band is computed (the extremes of the polygon ∩ band lie on its clipped edges). A
//! piece at band offset k then slides left until its left profile touches the frontier:
//! `x(k) = max(0, max_j frontier[k + j] − left_j)`. Over all allowed rotations and all k
//! (cut line within the roll width), the position with the smallest far end `x + w` wins
//! (ties: lower k, then rotation order 0°, 180°, 90°, 270°), and the frontier is raised to the
//! piece's right profile.
//!
//! Unlike boxes, profiles let a slanted or concave piece slide into the space its neighbour
//! leaves (trapezoid panels alternate 0°/180° and interlock). Guarantee: in every band the
//! dilated pieces are x-disjoint, so any two cut lines are at least `piece_gap_mm` apart, and
//! every cut line lies in `[0, width]` across the roll. Holes left behind the frontier are not
//! refilled (a skyline, not a full free-space search).
//!
//! The fill is run for three piece orders — decreasing extent across the roll, decreasing
//! box area, decreasing length along the roll (ties: input order) — and, with weft swap, also
//! with 0°/180° only; the shortest layout is kept (ties: the first tried). Deterministic (no
//! hashing, total orders on f64).
//!
//! Complexity: O(n · bands) per piece and rotation for the profiles (computed once), O(B²)
//! per piece and rotation for the placement (B ≤ 401 bands), so O(N · B²) per fill and six
//! fills at most.

use crate::geom::{BBox, P2, rotate_quarter, sub};
use crate::offset::offset_polygon;

/// Number of bands across the roll.
pub const BANDS: usize = 400;

/// Where a piece went: `roll = rotate(piece, rotation_deg) + offset`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NestPlacement {
    /// 0, 90, 180 or 270.
    pub rotation_deg: u16,
    /// Translation after the rotation.
    pub offset: P2,
}

/// One rotation of a piece, prepared for placement.
#[derive(Debug, Clone)]
struct Oriented {
    rotation: u16,
    /// Translation taking the rotated cut line's box corner to (0, 0).
    shift: P2,
    /// Cut-line box size.
    w: f64,
    h: f64,
    /// First band index of the dilated profile, relative to the cut line's bottom.
    j0: i64,
    /// Left and right x of the dilated shape per band (relative to the cut box corner);
    /// `left > right` for a band the shape does not reach.
    left: Vec<f64>,
    right: Vec<f64>,
}

fn orient(cut: &[P2], rotation: u16, half_gap: f64, cell: f64) -> Oriented {
    let rotated: Vec<P2> = cut.iter().map(|&p| rotate_quarter(p, rotation)).collect();
    let b = BBox::of(&rotated);
    let shift = [-b.min[0], -b.min[1]];
    let local: Vec<P2> = rotated.iter().map(|&p| sub(p, b.min)).collect();
    let dilated = if half_gap > 0.0 { offset_polygon(&local, half_gap).unwrap_or(local) } else { local };
    let db = BBox::of(&dilated);
    let j0 = (db.min[1] / cell).floor() as i64;
    let j1 = (db.max[1] / cell).floor() as i64;
    let nb = (j1 - j0 + 1).max(1) as usize;
    let mut left = vec![f64::INFINITY; nb];
    let mut right = vec![f64::NEG_INFINITY; nb];
    let n = dilated.len();
    for i in 0..n {
        let (p, q) = (dilated[i], dilated[(i + 1) % n]);
        let (ylo, yhi) = (p[1].min(q[1]), p[1].max(q[1]));
        let ja = ((ylo / cell).floor() as i64).max(j0);
        let jb = ((yhi / cell).floor() as i64).min(j1);
        for j in ja..=jb {
            // Clip the edge to the closed band [j·cell, (j+1)·cell].
            let (y0, y1) = (j as f64 * cell, (j + 1) as f64 * cell);
            let (lo, hi) = (ylo.max(y0), yhi.min(y1));
            if lo > hi {
                continue;
            }
            let x_at = |y: f64| {
                if q[1] == p[1] {
                    None
                } else {
                    Some(p[0] + (q[0] - p[0]) * ((y - p[1]) / (q[1] - p[1])).clamp(0.0, 1.0))
                }
            };
            let xs: [f64; 2] = match (x_at(lo), x_at(hi)) {
                (Some(a), Some(c)) => [a, c],
                _ => [p[0], q[0]], // horizontal edge inside the band
            };
            let k = (j - j0) as usize;
            for x in xs {
                left[k] = left[k].min(x);
                right[k] = right[k].max(x);
            }
        }
    }
    Oriented { rotation, shift, w: b.width(), h: b.height(), j0, left, right }
}

/// Piece orders tried by [`nest_polygons`].
#[derive(Debug, Clone, Copy)]
enum Order {
    /// Decreasing extent across the roll (the larger side when quarter turns are allowed).
    Across,
    /// Decreasing box area.
    Area,
    /// Decreasing extent along the roll.
    Along,
}

/// Places the cut lines on a roll of the given width (the caller has checked that each fits
/// in some allowed rotation). Returns the placements in input order and the used length.
///
/// Runs the bottom-left fill for three piece orders (and, with weft swap, also without quarter
/// turns) and keeps the shortest layout (ties: the first tried).
pub fn nest_polygons(cuts: &[Vec<P2>], width: f64, gap: f64, allow_swap: bool) -> (Vec<NestPlacement>, f64) {
    let cell = width / BANDS as f64;
    let rotations: &[u16] = if allow_swap { &[0, 180, 90, 270] } else { &[0, 180] };
    let orients: Vec<Vec<Oriented>> =
        cuts.iter().map(|c| rotations.iter().map(|&r| orient(c, r, 0.5 * gap, cell)).collect()).collect();
    let mut best: Option<(Vec<NestPlacement>, f64)> = None;
    let rotation_sets: &[usize] = if allow_swap { &[4, 2] } else { &[2] };
    for order in [Order::Across, Order::Area, Order::Along] {
        for &n_rot in rotation_sets {
            let (pl, len) = fill(&orients, n_rot, order, width, cell, allow_swap && n_rot == 4);
            if best.as_ref().is_none_or(|(_, bl)| len < *bl) {
                best = Some((pl, len));
            }
        }
    }
    best.unwrap_or_default()
}

/// One bottom-left fill with the first `n_rot` orientations of every piece.
fn fill(
    orients: &[Vec<Oriented>],
    n_rot: usize,
    order: Order,
    width: f64,
    cell: f64,
    swap: bool,
) -> (Vec<NestPlacement>, f64) {
    let nbands = BANDS + 1;
    let key = |i: usize| {
        let o = &orients[i][0];
        match order {
            Order::Across => {
                if swap {
                    o.w.max(o.h)
                } else {
                    o.h
                }
            }
            Order::Area => o.w * o.h,
            Order::Along => o.w,
        }
    };
    let mut sequence: Vec<usize> = (0..orients.len()).collect();
    sequence.sort_by(|&i, &j| key(j).total_cmp(&key(i)).then(i.cmp(&j)));
    let mut frontier = vec![f64::NEG_INFINITY; nbands];
    let mut out = vec![NestPlacement { rotation_deg: 0, offset: [0.0, 0.0] }; orients.len()];
    let mut length: f64 = 0.0;
    for i in sequence {
        // (far end, k, rotation rank, x)
        let mut best: Option<(f64, i64, usize, f64)> = None;
        for (rank, o) in orients[i].iter().take(n_rot).enumerate() {
            if o.h > width {
                continue;
            }
            let kmax = ((width - o.h) / cell).floor().max(0.0) as i64;
            for k in 0..=kmax {
                let mut x: f64 = 0.0;
                for (jj, &l) in o.left.iter().enumerate() {
                    let band = k + o.j0 + jj as i64;
                    if l > o.right[jj] || band < 0 || band >= nbands as i64 {
                        continue;
                    }
                    x = x.max(frontier[band as usize] - l);
                }
                let end = x + o.w;
                let better = match best {
                    None => true,
                    Some((be, bk, br, _)) => end < be || (end == be && (k < bk || (k == bk && rank < br))),
                };
                if better {
                    best = Some((end, k, rank, x));
                }
            }
        }
        let Some((end, k, rank, x)) = best else {
            // Fits in none of these rotations: this fill is void (the caller checked that every
            // piece fits some allowed rotation, so another fill succeeds).
            return (out, f64::INFINITY);
        };
        let o = &orients[i][rank];
        for (jj, (&l, &r)) in o.left.iter().zip(&o.right).enumerate() {
            let band = k + o.j0 + jj as i64;
            if l <= r && band >= 0 && band < nbands as i64 {
                let f = &mut frontier[band as usize];
                *f = f.max(x + r);
            }
        }
        let y = k as f64 * cell;
        out[i] = NestPlacement { rotation_deg: o.rotation, offset: [x + o.shift[0], y + o.shift[1]] };
        length = length.max(end);
    }
    (out, length)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trapezoids_interlock_by_turning_half_of_them() {
        // Trapezoids 400 wide at the bottom, 100 at the top, 300 high, on a 300 mm roll.
        let trap = vec![[0.0, 0.0], [400.0, 0.0], [250.0, 300.0], [150.0, 300.0]];
        let cuts = vec![trap.clone(), trap.clone(), trap.clone(), trap];
        let (pl, len) = nest_polygons(&cuts, 300.0, 0.0, false);
        let turned = pl.iter().filter(|p| p.rotation_deg == 180).count();
        assert!(turned >= 1, "{pl:?}");
        // Boxes side by side would need 1600 mm.
        assert!(len < 1200.0, "{len}");
    }
}
