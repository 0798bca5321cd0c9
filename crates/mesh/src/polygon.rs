//! Small 2D geometry kernel on plain point arrays: the pattern stage's (re-exported there as
//! `clothcast_pattern::geom`, in millimetres) and the flattening's outline check.
//!
//! Points are `[f64; 2]`, y up. Polygons are closed implicitly (no repeated last
//! vertex); counter-clockwise means positive [`signed_area`]. Predicates use plain `f64`
//! arithmetic: they are exact for the axis-aligned and well-separated inputs a pattern holds
//! and consistent (the same input always gives the same answer) otherwise.
//!
//! Complexity: every polygon function is O(n); [`find_self_intersection`] is O(n log n + k)
//! with a sweep over x-sorted edge boxes (k = edge pairs whose x-ranges overlap).

/// A point or vector in the plane (millimetres in the pattern stage).
pub type P2 = [f64; 2];

/// `a + b`.
#[inline]
pub fn add(a: P2, b: P2) -> P2 {
    [a[0] + b[0], a[1] + b[1]]
}

/// `a − b`.
#[inline]
pub fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}

/// `s · a`.
#[inline]
pub fn scale(a: P2, s: f64) -> P2 {
    [a[0] * s, a[1] * s]
}

/// `a + s · d`.
#[inline]
pub fn axpy(a: P2, s: f64, d: P2) -> P2 {
    [a[0] + s * d[0], a[1] + s * d[1]]
}

/// Dot product.
#[inline]
pub fn dot(a: P2, b: P2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// z-component of the cross product `a × b` (positive when b is counter-clockwise of a).
#[inline]
pub fn cross(a: P2, b: P2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Euclidean length.
#[inline]
pub fn norm(a: P2) -> f64 {
    a[0].hypot(a[1])
}

/// Distance between two points.
#[inline]
pub fn dist(a: P2, b: P2) -> f64 {
    norm(sub(a, b))
}

/// `a / |a|`, or `[0, 0]` for the zero vector.
#[inline]
pub fn normalize(a: P2) -> P2 {
    let n = norm(a);
    if n > 0.0 { [a[0] / n, a[1] / n] } else { [0.0, 0.0] }
}

/// The outward normal of an edge of a counter-clockwise polygon: the unit right-hand
/// perpendicular of its direction.
#[inline]
pub fn right_normal(dir: P2) -> P2 {
    normalize([dir[1], -dir[0]])
}

/// Orientation of `c` relative to the directed line `a → b`: > 0 left, < 0 right, 0 on it.
#[inline]
pub fn orient(a: P2, b: P2, c: P2) -> f64 {
    cross(sub(b, a), sub(c, a))
}

/// Rotates `p` counter-clockwise by `deg` degrees, one of 0, 90, 180, 270 (exact, no
/// trigonometry); any other value is taken modulo 360 and rounded down to a quarter turn.
#[inline]
pub fn rotate_quarter(p: P2, deg: u16) -> P2 {
    match (deg % 360) / 90 {
        0 => p,
        1 => [-p[1], p[0]],
        2 => [-p[0], -p[1]],
        _ => [p[1], -p[0]],
    }
}

/// Signed area (shoelace): positive for counter-clockwise polygons.
pub fn signed_area(poly: &[P2]) -> f64 {
    let n = poly.len();
    if n < 3 {
        return 0.0;
    }
    // Relative to the first vertex: less cancellation far from the origin.
    let o = poly[0];
    let mut s = 0.0;
    for i in 1..n - 1 {
        s += cross(sub(poly[i], o), sub(poly[i + 1], o));
    }
    0.5 * s
}

/// Area centroid of a simple polygon (the vertex mean for a degenerate one).
pub fn centroid(poly: &[P2]) -> P2 {
    let n = poly.len();
    if n == 0 {
        return [0.0, 0.0];
    }
    let o = poly[0];
    let (mut cx, mut cy, mut a2) = (0.0, 0.0, 0.0);
    for i in 1..n.saturating_sub(1) {
        let p = sub(poly[i], o);
        let q = sub(poly[i + 1], o);
        let c = cross(p, q);
        a2 += c;
        cx += (p[0] + q[0]) * c;
        cy += (p[1] + q[1]) * c;
    }
    if a2.abs() > 0.0 {
        [o[0] + cx / (3.0 * a2), o[1] + cy / (3.0 * a2)]
    } else {
        let s = poly.iter().fold([0.0, 0.0], |acc, &p| add(acc, p));
        scale(s, 1.0 / n as f64)
    }
}

/// Length of a closed polygon's boundary.
pub fn perimeter(poly: &[P2]) -> f64 {
    (0..poly.len()).map(|i| dist(poly[i], poly[(i + 1) % poly.len()])).sum()
}

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BBox {
    /// Lower-left corner.
    pub min: P2,
    /// Upper-right corner.
    pub max: P2,
}

impl BBox {
    /// The box of a point set (`min > max`, i.e. empty, for no points).
    pub fn of(points: &[P2]) -> BBox {
        let mut b = BBox { min: [f64::INFINITY; 2], max: [f64::NEG_INFINITY; 2] };
        for p in points {
            b.min = [b.min[0].min(p[0]), b.min[1].min(p[1])];
            b.max = [b.max[0].max(p[0]), b.max[1].max(p[1])];
        }
        b
    }

    /// Extent along x.
    pub fn width(&self) -> f64 {
        self.max[0] - self.min[0]
    }

    /// Extent along y.
    pub fn height(&self) -> f64 {
        self.max[1] - self.min[1]
    }

    /// Whether the two closed boxes overlap (touching counts).
    pub fn intersects(&self, o: &BBox) -> bool {
        self.min[0] <= o.max[0] && o.min[0] <= self.max[0] && self.min[1] <= o.max[1] && o.min[1] <= self.max[1]
    }
}

/// Point in polygon by winding number (points exactly on the boundary may go either way).
pub fn point_in_polygon(p: P2, poly: &[P2]) -> bool {
    let n = poly.len();
    let mut w = 0i32;
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        if a[1] <= p[1] {
            if b[1] > p[1] && orient(a, b, p) > 0.0 {
                w += 1;
            }
        } else if b[1] <= p[1] && orient(a, b, p) < 0.0 {
            w -= 1;
        }
    }
    w != 0
}

/// Distance from `p` to the segment `a b`.
pub fn dist_point_segment(p: P2, a: P2, b: P2) -> f64 {
    let d = sub(b, a);
    let l2 = dot(d, d);
    let t = if l2 > 0.0 { (dot(sub(p, a), d) / l2).clamp(0.0, 1.0) } else { 0.0 };
    dist(p, axpy(a, t, d))
}

/// Distance from `p` to the boundary of a closed polygon.
pub fn dist_point_boundary(p: P2, poly: &[P2]) -> f64 {
    let n = poly.len();
    (0..n).map(|i| dist_point_segment(p, poly[i], poly[(i + 1) % n])).fold(f64::INFINITY, f64::min)
}

/// Whether the closed segments `a b` and `c d` share a point (touching counts).
pub fn segments_intersect(a: P2, b: P2, c: P2, d: P2) -> bool {
    let o1 = orient(a, b, c);
    let o2 = orient(a, b, d);
    let o3 = orient(c, d, a);
    let o4 = orient(c, d, b);
    if ((o1 > 0.0 && o2 < 0.0) || (o1 < 0.0 && o2 > 0.0)) && ((o3 > 0.0 && o4 < 0.0) || (o3 < 0.0 && o4 > 0.0)) {
        return true;
    }
    let on = |p: P2, q: P2, r: P2| {
        // r on segment p q, given collinearity.
        r[0] >= p[0].min(q[0]) && r[0] <= p[0].max(q[0]) && r[1] >= p[1].min(q[1]) && r[1] <= p[1].max(q[1])
    };
    (o1 == 0.0 && on(a, b, c)) || (o2 == 0.0 && on(a, b, d)) || (o3 == 0.0 && on(c, d, a)) || (o4 == 0.0 && on(c, d, b))
}

/// The first pair of edges `(i, j)`, `i < j`, of a closed polygon that cross or touch, other
/// than consecutive edges meeting at their shared vertex; consecutive edges that fold back
/// onto each other (collinear, opposite directions) count as intersecting. `None` for a
/// simple polygon. Edge `i` runs from vertex `i` to vertex `i + 1`.
pub fn find_self_intersection(poly: &[P2]) -> Option<(usize, usize)> {
    find_self_intersection_within(poly, 0.0)
}

/// [`find_self_intersection`] with a margin: edges closer than `eps` count as touching, and
/// consecutive edges folding back to within a relative 10⁻¹² of collinear as a fold. A layout
/// that passes with a margin stays simple when it is rotated or scaled (an outline that only
/// just misses itself can cross once rounded in another frame).
pub fn find_self_intersection_within(poly: &[P2], eps: f64) -> Option<(usize, usize)> {
    let n = poly.len();
    if n < 3 {
        return None;
    }
    let seg = |i: usize| (poly[i], poly[(i + 1) % n]);
    // Consecutive edges: only a fold-back (or a zero-length edge) is a problem.
    for i in 0..n {
        let (a, b) = seg(i);
        let (_, c) = seg((i + 1) % n);
        let u = sub(b, a);
        let v = sub(c, b);
        let folded = cross(u, v).abs() <= if eps > 0.0 { 1e-12 * norm(u) * norm(v) } else { 0.0 };
        if (folded && dot(u, v) < 0.0) || a == b {
            let j = (i + 1) % n;
            return Some((i.min(j), i.max(j)));
        }
    }
    // With a margin, two edges count as near only if the outline between them, the shorter
    // way round, is longer than twice the margin: edges either side of a very short edge are
    // close, and that is no pinch.
    let cum: Vec<f64> = if eps > 0.0 {
        std::iter::once(0.0)
            .chain((0..n).scan(0.0, |acc, i| {
                let (a, b) = seg(i);
                *acc += dist(a, b);
                Some(*acc)
            }))
            .collect()
    } else {
        Vec::new()
    };
    let apart = |i: usize, j: usize| {
        // i < j: from the end of edge i to the start of edge j, or from the end of j round to
        // the start of i.
        let inner = cum[j] - cum[i + 1];
        let outer = cum[n] - cum[j + 1] + cum[i];
        inner.min(outer) > 2.0 * eps
    };
    let mut order: Vec<(f64, usize)> = (0..n)
        .map(|i| {
            let (a, b) = seg(i);
            (a[0].min(b[0]) - eps, i)
        })
        .collect();
    order.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let mut best: Option<(usize, usize)> = None;
    for (k, &(_, i)) in order.iter().enumerate() {
        let (a, b) = seg(i);
        let max_x = a[0].max(b[0]) + eps;
        let (min_y, max_y) = (a[1].min(b[1]) - eps, a[1].max(b[1]) + eps);
        for &(min_x_j, j) in &order[k + 1..] {
            if min_x_j > max_x {
                break;
            }
            let adjacent = (i + 1) % n == j || (j + 1) % n == i;
            if adjacent {
                continue;
            }
            let (c, d) = seg(j);
            if c[1].max(d[1]) < min_y || c[1].min(d[1]) > max_y {
                continue;
            }
            let near = || {
                eps > 0.0
                    && apart(i.min(j), i.max(j))
                    && dist_point_segment(a, c, d)
                        .min(dist_point_segment(b, c, d))
                        .min(dist_point_segment(c, a, b))
                        .min(dist_point_segment(d, a, b))
                        < eps
            };
            if segments_intersect(a, b, c, d) || near() {
                let pair = (i.min(j), i.max(j));
                // Report the lexicographically first pair: deterministic and readable.
                if best.is_none_or(|bp| pair < bp) {
                    best = Some(pair);
                }
            }
        }
    }
    best
}

/// Smallest `t > t_min` with `origin + t·dir` on the polygon boundary (`dir` need not be
/// unit; `t` is in units of `|dir|`).
pub fn ray_hit(origin: P2, dir: P2, poly: &[P2], t_min: f64) -> Option<f64> {
    let n = poly.len();
    let mut best: Option<f64> = None;
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        let e = sub(b, a);
        let den = cross(dir, e);
        if den == 0.0 {
            continue;
        }
        let w = sub(a, origin);
        let t = cross(w, e) / den;
        let s = cross(w, dir) / den;
        if t > t_min && (0.0..=1.0).contains(&s) && best.is_none_or(|bt| t < bt) {
            best = Some(t);
        }
    }
    best
}

/// Whether the closed segment `a b` lies inside the polygon (both ends inside, no boundary
/// crossing).
pub fn segment_inside(a: P2, b: P2, poly: &[P2]) -> bool {
    if !point_in_polygon(a, poly) || !point_in_polygon(b, poly) {
        return false;
    }
    let n = poly.len();
    (0..n).all(|i| !segments_intersect(a, b, poly[i], poly[(i + 1) % n]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_margin_catches_an_outline_that_only_just_misses_itself() {
        // A notch whose tip comes within 1e-12 of the opposite edge.
        let poly = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 1e-12], [0.9, 1.0], [0.0, 1.0]];
        assert_eq!(find_self_intersection(&poly), None);
        assert!(find_self_intersection_within(&poly, 1e-9).is_some());
        assert_eq!(find_self_intersection_within(&poly, 1e-13), None);
        // A very short edge is no pinch: its neighbours are close only along the outline.
        let short = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.5, 1.0], [0.5 - 1e-12, 1.0], [0.0, 1.0]];
        assert_eq!(find_self_intersection_within(&short, 1e-9), None);
    }

    #[test]
    fn area_centroid_square() {
        let sq = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        assert_eq!(signed_area(&sq), 4.0);
        assert_eq!(centroid(&sq), [1.0, 1.0]);
        assert!(point_in_polygon([1.0, 1.0], &sq));
        assert!(!point_in_polygon([3.0, 1.0], &sq));
        assert_eq!(find_self_intersection(&sq), None);
        let bow = [[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]];
        assert_eq!(find_self_intersection(&bow), Some((0, 2)));
        assert_eq!(ray_hit([1.0, 1.0], [1.0, 0.0], &sq, 0.0), Some(1.0));
    }

    #[test]
    fn quarter_rotations_are_exact() {
        let p = [3.0, 1.0];
        assert_eq!(rotate_quarter(p, 90), [-1.0, 3.0]);
        assert_eq!(rotate_quarter(p, 180), [-3.0, -1.0]);
        assert_eq!(rotate_quarter(p, 270), [1.0, -3.0]);
    }
}
