//! Shared fixtures and checks of the pattern tests.
#![allow(dead_code)]

use clothcast_pattern::geom::{P2, dist_point_boundary, find_self_intersection, point_in_polygon};
use clothcast_pattern::{MITER_LIMIT, MarkKind, PieceInput, PointMark, SeamSide};

/// An axis-aligned rectangle piece (CCW from the lower-left corner) without seams.
pub fn rect_piece(id: usize, w: f64, h: f64) -> PieceInput {
    PieceInput {
        id,
        name: format!("P{id}"),
        outline: vec![[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]],
        seams: vec![],
        marks: vec![],
    }
}

pub fn side(seam: usize, start: usize, end: usize, forward: bool) -> SeamSide {
    SeamSide { seam, label: format!("S{seam}"), start, end, forward }
}

/// A star-shaped polygon around `c`: vertex k at angle `angles[k]` (increasing, in [0, 2π))
/// and radius `radii[k]`.
pub fn star(c: P2, angles: &[f64], radii: &[f64]) -> Vec<P2> {
    angles.iter().zip(radii).map(|(&a, &r)| [c[0] + r * a.cos(), c[1] + r * a.sin()]).collect()
}

/// A comb: a base `width × base` with `teeth` teeth of width `tooth` and height `height`,
/// separated by `gap` (counter-clockwise).
pub fn comb(teeth: usize, tooth: f64, gap: f64, height: f64, base: f64) -> Vec<P2> {
    let width = teeth as f64 * tooth + (teeth as f64 - 1.0) * gap;
    let mut v = vec![[0.0, 0.0], [width, 0.0]];
    // Walk the top from right to left.
    for k in (0..teeth).rev() {
        let x0 = k as f64 * (tooth + gap);
        let x1 = x0 + tooth;
        v.push([x1, base + height]);
        v.push([x0, base + height]);
        if k > 0 {
            v.push([x0, base]);
            v.push([x0 - gap, base]);
        }
    }
    v
}

/// The checks every cut line must pass; returns a description of the first failure.
pub fn check_offset(sew: &[P2], cut: &[P2], r: f64) -> Result<(), String> {
    if let Some(pair) = find_self_intersection(cut) {
        return Err(format!("cut line not simple: edges {pair:?}"));
    }
    if clothcast_pattern::geom::signed_area(cut) <= 0.0 {
        return Err("cut line not counter-clockwise".into());
    }
    for (i, &p) in sew.iter().enumerate() {
        if !point_in_polygon(p, cut) {
            return Err(format!("sew vertex {i} {p:?} outside the cut line"));
        }
        let d = dist_point_boundary(p, cut);
        if d < r * (1.0 - 1e-6) {
            return Err(format!("sew vertex {i} only {d} from the cut line (allowance {r})"));
        }
    }
    for (i, &q) in cut.iter().enumerate() {
        let d = dist_point_boundary(q, sew);
        // Together with the sew-vertex check: the two boundaries are ≥ r apart everywhere.
        if d < r * (1.0 - 1e-6) {
            return Err(format!("cut vertex {i} {q:?} only {d} from the sew line"));
        }
        if d > MITER_LIMIT * r * (1.0 + 1e-6) {
            return Err(format!("cut vertex {i} {q:?} is {d} from the sew line (> {MITER_LIMIT} r)"));
        }
        if point_in_polygon(q, sew) {
            return Err(format!("cut vertex {i} inside the sew line"));
        }
    }
    Ok(())
}

/// Two rectangles sewn along one side: piece 0's right side (CCW upwards, forward) to piece
/// 1's left side (CCW downwards, so backward), lengths `h0` and `h1`; both pieces carry a
/// mark.
pub fn two_panels(h0: f64, h1: f64) -> Vec<PieceInput> {
    let mut a = rect_piece(0, 300.0, h0);
    a.seams = vec![side(7, 1, 2, true)];
    a.marks = vec![PointMark { kind: MarkKind::Suspension, position: [150.0, h0 - 30.0], label: "S1".into() }];
    let mut b = rect_piece(1, 200.0, h1);
    b.seams = vec![side(7, 3, 0, false)];
    b.marks = vec![PointMark { kind: MarkKind::Pour, position: [100.0, 40.0], label: "pour".into() }];
    vec![a, b]
}

/// A small multi-piece pattern: a ring of `k` quads sewn side to side, the last to the first,
/// with a clamp mark on each, plus a concave L piece sewn to itself.
pub fn ring(k: usize) -> Vec<PieceInput> {
    let mut pieces = Vec::new();
    for i in 0..k {
        let w = 180.0 + 23.0 * i as f64;
        let h = 260.0 + 7.0 * (i % 3) as f64;
        let mut p = PieceInput {
            id: 10 + i,
            name: format!("Q{i}"),
            outline: vec![[0.0, 0.0], [w, 15.0], [w + 10.0, h], [-5.0, h - 10.0]],
            seams: vec![side(100 + i, 1, 2, true), side(100 + (i + k - 1) % k, 3, 0, false)],
            marks: vec![PointMark {
                kind: MarkKind::Clamp,
                position: [w / 2.0, h / 2.0 - 40.0],
                label: format!("C{i}"),
            }],
        };
        p.seams[0].label = format!("A{}", 100 + i);
        pieces.push(p);
    }
    // L shape with its two outer ends sewn together (a self seam).
    let l = vec![[0.0, 0.0], [400.0, 0.0], [400.0, 120.0], [120.0, 120.0], [120.0, 400.0], [0.0, 400.0]];
    pieces.push(PieceInput {
        id: 99,
        name: "L".into(),
        outline: l,
        seams: vec![side(500, 1, 2, true), side(500, 4, 5, false)],
        marks: vec![],
    });
    pieces
}
