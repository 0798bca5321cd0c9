//! Seam allowance: the cut line as the outward offset of the sew line.
//!
//! # Method
//!
//! The offset region of a simple counter-clockwise polygon P by the allowance r is built as
//! a union of simple convex pieces, so that it is right by construction, however concave or
//! narrow P is:
//!
//! - P itself;
//! - for every edge `v_i v_{i+1}` with outward normal `n_i`, the rectangle
//!   `v_i, v_i + r n_i, v_{i+1} + r n_i, v_{i+1}`;
//! - at every convex vertex (left turn by θ), a mitred wedge `v, v + r n_a, tip, v + r n_b`
//!   with the miter tip at `r / cos(θ/2)`; when that exceeds [`MITER_LIMIT`]` · r` (θ >
//!   120° for the limit 2) the miter is clipped by a line perpendicular to the bisector, at
//!   the points of the two offset lines that are exactly `MITER_LIMIT · r` from `v`, which
//!   is still at least `r` from `v` (a "clipped miter": unlike a bevel it never cuts into
//!   the allowance).
//!
//! Concave vertices need nothing: there the two neighbouring rectangles already cover every
//! point within r of the corner. The union therefore contains the Minkowski sum P ⊕ disc(r)
//! (every sew-line point is ≥ r from the cut line) and lies within `MITER_LIMIT · r` of P
//! (every cut vertex is ≤ `MITER_LIMIT · r` from the sew line). Its outer boundary is the cut
//! line; holes of the union (a nearly closed C shape) are fabric inside the cut line and are
//! dropped. Loops of the naive offset curve never arise: there is no offset curve to untangle.
//!
//! The union is computed by [`i_overlay`] (non-zero fill over all the pieces). Reasons for the
//! crate rather than a hand-written arrangement: the pieces overlap along shared and collinear
//! edges by construction (rectangle sides, wedge sides, comb teeth whose mitres meet), exactly
//! the degenerate cases where floating-point sweep code breaks; i_overlay snaps to an integer
//! grid and is exact there. It is pure Rust, maintained, MIT/Apache, with no default
//! features (no rayon), and costs ~5 s of clean release build (5 small crates). We use its
//! `i64` engine: the grid step is then ~1e-15 of the piece size, far below the 1e-6·r
//! tolerance the tests demand (the default `i32` engine's ~4e-6 mm step on a 2 m piece is
//! not).
//!
//! Complexity: O(n log n) for n outline points (at most 2n + 1 input contours to the sweep).
//!
//! The pieces' cut lines are [`cut_line`]: this offset with the small dents a zigzagging
//! seam leaves in it closed (a morphological closing by a large disc, with i_overlay's round
//! outline offsets and boolean operations, bounded by the miter limit). It costs more than the
//! exact offset: the pattern of the 4000-point test piece took 0.14 → 0.92 s, kitten's whole
//! pattern stage (50 pieces) 0.32 → 0.65 s.

use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay_rule::OverlayRule;
use i_overlay::float::simplify::SimplifyShape;
use i_overlay::float::single::SingleFloatOverlay;
use i_overlay::mesh::float::outline::offset::OutlineOffset;
use i_overlay::mesh::float::style::{LineJoin, OutlineStyle};

use crate::geom::{BBox, P2, add, axpy, cross, dot, normalize, right_normal, scale, signed_area, sub};

/// Largest distance of a cut-line corner from its sew-line corner, in allowances.
pub const MITER_LIMIT: f64 = 2.0;

/// The convex pieces whose union is the offset region (all counter-clockwise).
fn offset_pieces(poly: &[P2], r: f64) -> Vec<Vec<P2>> {
    let n = poly.len();
    let mut out = Vec::with_capacity(2 * n + 1);
    out.push(poly.to_vec());
    let dirs: Vec<P2> = (0..n).map(|i| normalize(sub(poly[(i + 1) % n], poly[i]))).collect();
    let normals: Vec<P2> = dirs.iter().map(|&d| right_normal(d)).collect();
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        let off = scale(normals[i], r);
        out.push(vec![a, add(a, off), add(b, off), b]);
    }
    let k = (MITER_LIMIT * MITER_LIMIT - 1.0).sqrt();
    for i in 0..n {
        let v = poly[i];
        let (da, db) = (dirs[(i + n - 1) % n], dirs[i]);
        let (na, nb) = (normals[(i + n - 1) % n], normals[i]);
        let s = cross(da, db);
        if !(s > 0.0) {
            continue; // concave or straight: covered by the rectangles
        }
        let c = dot(da, db); // cos θ
        let pa = axpy(v, r, na);
        let pb = axpy(v, r, nb);
        // Miter length r / cos(θ/2), cos(θ/2) = sqrt((1 + cos θ) / 2).
        let half_cos = ((1.0 + c) * 0.5).max(0.0).sqrt();
        if half_cos * MITER_LIMIT >= 1.0 {
            let m = normalize(add(na, nb));
            out.push(vec![v, pa, axpy(v, r / half_cos, m), pb]);
        } else {
            // Clipped miter: the points of the offset lines at MITER_LIMIT·r from v.
            let qa = axpy(pa, r * k, da);
            let qb = axpy(pb, -r * k, db);
            out.push(vec![v, pa, qa, qb, pb]);
        }
    }
    for c in &mut out {
        if signed_area(c) < 0.0 {
            c.reverse();
        }
    }
    out
}

/// The cut line: `poly` (simple; a clockwise one is taken in reverse) offset outwards by
/// `r ≥ 0`, as a simple counter-clockwise polygon starting at its lowest-then-leftmost
/// vertex. `None` if the union came back empty (not expected for a valid polygon). `r = 0`
/// returns the polygon itself.
pub fn offset_polygon(poly: &[P2], r: f64) -> Option<Vec<P2>> {
    if r == 0.0 {
        return Some(poly.to_vec());
    }
    let pieces = offset_pieces(&counter_clockwise(poly), r);
    // The outer contour of the largest shape (a valid union is one shape). The integer grid
    // leaves the mitre joins' nearly collinear points (pa, tip, pb lie on the two offset
    // lines): they are dropped.
    let contour = largest_outer(pieces.simplify_shape_as::<i64>(FillRule::NonZero))?;
    Some(normalized_contour(contour, r))
}

/// Radius of the disc that closes the cut line's dents ([`cut_line`]), in allowances.
pub const DENT_RADIUS: f64 = 8.0;

/// Angle (radians) of the segments approximating the arcs of [`cut_line`]'s round offsets.
const ARC_STEP: f64 = 0.2;

/// The cut line of a piece: [`offset_polygon`] with its dents closed. A sew line that zigzags
/// on the scale of a mesh edge (seams follow the remeshed target's edges) leaves the exact
/// offset with the same small dents, drawn as teeth on the cut line. Here the offset region is
/// closed by a disc of radius [`DENT_RADIUS`]` · r` (dilated by it, then eroded by it, both
/// with round joins: the morphological closing), which fills every dent narrower than about
/// `r` and leaves the rest; the fabric it adds is kept within [`MITER_LIMIT`]` · r` of the sew
/// line (intersected with the sew line's round offset by that much) and joined to the exact
/// offset, so every sew-line point stays at least `r` inside the cut line (where the arcs'
/// chords, which fall inside the true arcs, leave the closing a little short of the offset,
/// the offset stands) and a piece without dents keeps its exact offset. `None` as for
/// [`offset_polygon`].
pub fn cut_line(sew: &[P2], r: f64) -> Option<Vec<P2>> {
    let cut = offset_polygon(sew, r)?;
    if !(r > 0.0) {
        return Some(cut);
    }
    let c = DENT_RADIUS * r;
    let round = |offset: f64| OutlineStyle::new(offset).line_join(LineJoin::Round(ARC_STEP));
    let closed = (|| {
        let dilated = largest_outer(vec![cut.clone()].outline_as::<i64>(&round(c)))?;
        let closed = largest_outer(vec![dilated].outline_as::<i64>(&round(-c)))?;
        let reach = largest_outer(vec![counter_clockwise(sew)].outline_as::<i64>(&round(MITER_LIMIT * r)))?;
        let added = vec![closed].overlay_as::<i64>(&vec![reach], OverlayRule::Intersect, FillRule::NonZero);
        let added = largest_outer(added)?;
        largest_outer(vec![cut.clone()].overlay_as::<i64>(&vec![added], OverlayRule::Union, FillRule::NonZero))
    })();
    match closed {
        // Closing only adds fabric: anything else is the boolean operations' failure, and the
        // exact offset stands.
        Some(c) if c.len() >= 3 && signed_area(&c).abs() >= signed_area(&cut) * (1.0 - 1e-9) => {
            Some(normalized_contour(c, r))
        }
        _ => Some(cut),
    }
}

/// A copy of `poly` running counter-clockwise.
fn counter_clockwise(poly: &[P2]) -> Vec<P2> {
    let mut ccw = poly.to_vec();
    if signed_area(&ccw) < 0.0 {
        ccw.reverse();
    }
    ccw
}

/// The outer contour of the largest of `shapes` (holes dropped), if any.
fn largest_outer(shapes: Vec<Vec<Vec<P2>>>) -> Option<Vec<P2>> {
    let mut best: Option<(f64, Vec<P2>)> = None;
    for shape in shapes {
        let Some(outer) = shape.into_iter().next() else { continue };
        let a = signed_area(&outer).abs();
        if outer.len() >= 3 && best.as_ref().is_none_or(|(ba, _)| a > *ba) {
            best = Some((a, outer));
        }
    }
    best.map(|(_, c)| c)
}

/// A contour made counter-clockwise, started at its lowest-then-leftmost vertex, with the
/// nearly collinear points the integer grid leaves dropped (within 1e-9·r of their chord).
fn normalized_contour(mut contour: Vec<P2>, r: f64) -> Vec<P2> {
    if signed_area(&contour) < 0.0 {
        contour.reverse();
    }
    // Deterministic start: lowest y, then lowest x (an extreme, strictly convex vertex).
    let contour = lowest_first(contour);
    // Vertices the boolean operations left within 1e-9·r of the one before (a random star
    // polygon at r = 41.5 ended its cut line with two 3·10⁻¹⁴ mm apart, which made it cross
    // itself there).
    let tol = 1e-9 * r;
    let mut deduped: Vec<P2> = Vec::with_capacity(contour.len());
    for p in contour {
        if deduped.last().is_none_or(|&q| dot(sub(p, q), sub(p, q)) > tol * tol) {
            deduped.push(p);
        }
    }
    while deduped.len() > 3 && {
        let (a, b) = (deduped[deduped.len() - 1], deduped[0]);
        dot(sub(a, b), sub(a, b)) <= tol * tol
    } {
        deduped.pop();
    }
    let simple = cut_small_loops(drop_collinear(deduped, tol), 100.0 * tol);
    lowest_first(simple)
}

/// `poly` rotated to start at its lowest-then-leftmost vertex (an extreme, strictly convex
/// one): a deterministic start.
fn lowest_first(mut poly: Vec<P2>) -> Vec<P2> {
    let start = (0..poly.len())
        .min_by(|&i, &j| {
            let (p, q) = (poly[i], poly[j]);
            p[1].total_cmp(&q[1]).then(p[0].total_cmp(&q[0]))
        })
        .unwrap_or(0);
    poly.rotate_left(start);
    poly
}

/// Cuts out the loops, none wider than `limit`, that rounding the boolean operations' integer
/// grid back to floating point can leave in a contour: a random star polygon at r = 40.1 came
/// back with two vertices 5·10⁻⁸ mm apart (just over the 1e-9·r that [`normalized_contour`]
/// merges) and its neighbouring edges crossing 3·10⁻⁹ mm from them. A crossing of edges `i`
/// and `j` closes two loops, the vertices between them either way round; the smaller (by its
/// bounding box) is replaced by the crossing point. A fold-back at a vertex loses the vertex.
/// A loop wider than `limit` is no rounding artefact: the contour is returned with it, for the
/// caller's validation to report.
fn cut_small_loops(mut poly: Vec<P2>, limit: f64) -> Vec<P2> {
    let width = |pts: &[P2]| {
        let b = BBox::of(pts);
        b.width().max(b.height())
    };
    // Each pass removes at least one vertex.
    while poly.len() > 3 {
        let Some((i, j)) = crate::geom::find_self_intersection(&poly) else { break };
        let n = poly.len();
        // Vertices i+1..=j lie between the edges one way round, j+1..=i (wrapping) the other.
        let inner = width(&poly[i + 1..=j]);
        let outer = width(&[&poly[j + 1..], &poly[..=i]].concat());
        let (a, b, c, d) = (poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]);
        let den = cross(sub(b, a), sub(d, c));
        let crossing = if j == i + 1 || (i == 0 && j == n - 1) || den == 0.0 {
            None // a fold-back or collinear touch: the shared stretch's vertices go
        } else {
            Some(axpy(a, cross(sub(c, a), sub(d, c)) / den, sub(b, a)))
        };
        let mut next: Vec<P2> = Vec::with_capacity(n);
        if inner <= outer {
            if inner > limit {
                break;
            }
            next.extend_from_slice(&poly[..=i]);
            next.extend(crossing);
            next.extend_from_slice(&poly[j + 1..]);
        } else {
            if outer > limit {
                break;
            }
            next.extend(crossing);
            next.extend_from_slice(&poly[i + 1..=j]);
        }
        if next.len() < 3 {
            break;
        }
        poly = next;
    }
    poly
}

/// Removes vertices closer than `tol` to the chord that replaces them: a vertex is dropped
/// when it and every vertex dropped since the last kept one lie within `tol` of the segment
/// from the last kept vertex to the next one (runs capped at 64). `poly[0]` is always kept:
/// the caller starts the polygon at an extreme (strictly convex) vertex.
fn drop_collinear(poly: Vec<P2>, tol: f64) -> Vec<P2> {
    let n = poly.len();
    if n <= 3 {
        return poly;
    }
    let near = |a: P2, v: P2, b: P2| {
        let ab = sub(b, a);
        let l2 = dot(ab, ab);
        let t = if l2 > 0.0 { dot(sub(v, a), ab) / l2 } else { -1.0 };
        (0.0..=1.0).contains(&t) && cross(ab, sub(v, a)).abs() <= tol * l2.sqrt()
    };
    let mut kept: Vec<P2> = vec![poly[0]];
    let mut pending: Vec<P2> = Vec::new();
    for i in 1..n {
        let (v, next) = (poly[i], poly[(i + 1) % n]);
        let prev = kept[kept.len() - 1];
        if pending.len() < 64 && near(prev, v, next) && pending.iter().all(|&p| near(prev, p, next)) {
            pending.push(v);
        } else {
            kept.push(v);
            pending.clear();
        }
    }
    if kept.len() < 3 { poly } else { kept }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{dist_point_boundary, find_self_intersection, point_in_polygon};

    #[test]
    fn square_offset_is_mitred_square() {
        let sq = [[0.0, 0.0], [100.0, 0.0], [100.0, 50.0], [0.0, 50.0]];
        let cut = offset_polygon(&sq, 10.0).unwrap();
        assert_eq!(cut.len(), 4);
        assert!((signed_area(&cut) - 120.0 * 70.0).abs() < 1e-6);
        assert!((cut[0][0] + 10.0).abs() < 1e-9 && (cut[0][1] + 10.0).abs() < 1e-9);
    }

    #[test]
    fn tiny_loops_are_cut_and_wide_ones_left() {
        // The stretch of a cut line where a random star polygon's crossed itself (r = 40.1):
        // two vertices 5e-8 mm apart, the edges either side crossing 3e-9 mm from them.
        let poly = vec![
            [0.0, -200.0],
            [100.0, -200.0],
            [100.0, 100.0],
            [-127.85974836282112, 19.41308585830639],
            [-134.42059898846333, -81.10229865007541],
            [-134.4205989416946, -81.10229863859657],
            [-135.15628834972864, -81.0542786576162],
            [-137.75591669801554, -120.88183334362368],
        ];
        assert!(find_self_intersection(&poly).is_some());
        let r = 40.107853712255384;
        let cut = cut_small_loops(poly.clone(), 1e-7 * r);
        assert!(find_self_intersection(&cut).is_none(), "{cut:?}");
        assert_eq!(cut.len(), poly.len() - 1);
        assert!((signed_area(&cut) - signed_area(&poly)).abs() < 1e-9);
        // A bow tie is no rounding artefact: left for the caller to report.
        let bow = vec![[0.0, 0.0], [10.0, 10.0], [10.0, 0.0], [0.0, 10.0]];
        assert_eq!(cut_small_loops(bow.clone(), 1e-7 * r), bow);
    }

    #[test]
    fn sharp_corner_is_clipped_not_bevelled() {
        // A needle triangle: its tip turns by almost 180°.
        let tri = [[0.0, 0.0], [200.0, 5.0], [0.0, 10.0]];
        let r = 10.0;
        let cut = offset_polygon(&tri, r).unwrap();
        assert!(find_self_intersection(&cut).is_none());
        for &p in &tri {
            assert!(point_in_polygon(p, &cut));
            assert!(dist_point_boundary(p, &cut) >= r * (1.0 - 1e-9));
        }
        for &q in &cut {
            assert!(dist_point_boundary(q, &tri) <= MITER_LIMIT * r * (1.0 + 1e-9));
        }
    }
}
