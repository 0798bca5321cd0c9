//! Where a piece's texts go: every label's box (its Helvetica advance width by its height) kept
//! on the piece's fabric (inside the sewing line, or in the seam allowance) and clear of the
//! piece's other texts, its marks, its notches and its grain arrow.
//!
//! The piece's name stays at its interior anchor (the deepest point, see
//! [`crate::pattern::interior_anchor`]); around it, the area, each mark's label and then each
//! seam side's label take the first of their candidate places that is free: the area below,
//! beside the name, then anywhere inside, then in the allowance; a mark's label around the mark,
//! inside then in the allowance; a seam side's label at a few points along the side (from its
//! middle out) and depths inside it at half the text height or more, then in the allowance,
//! then inside at smaller heights down to [`crate::pattern::MIN_TEXT_MM`]. A label with no free
//! place takes the candidate in its region that overlaps the others least and is counted
//! ([`crate::PatternStats::labels_crowded`]).
//!
//! Hand-written: a greedy placement over oriented rectangles (separating-axis overlap tests,
//! O(candidates · (n + labels)) per label for a sewing line of n vertices, a few hundred
//! candidates per label); no crate places labels inside a polygon.

use crate::geom::{P2, add, axpy, dot, normalize, point_in_polygon, segment_inside, segments_intersect, sub};
use crate::output::{HELVETICA_CAP_HEIGHT, helvetica_width};
use crate::pattern::Text;

/// Margin around a text's box, in text heights.
const PAD: f64 = 0.15;

/// Overlaps up to this depth (mm; a nanometre, far above the rounding of pattern coordinates
/// and far below anything a plotter draws) count as touching.
const TOUCH_MM: f64 = 1e-6;

/// Half the height of a text's box, in text heights (a cap height centred on the position, with
/// room for descenders).
const HALF_HEIGHT: f64 = 0.65;

/// An oriented rectangle: centre, unit direction of its first axis, half extents along it and
/// across it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LabelBox {
    centre: P2,
    axis: P2,
    half: [f64; 2],
}

impl LabelBox {
    /// The box a text covers, with a margin.
    pub(crate) fn of_text(t: &Text) -> Self {
        let a = t.angle_deg.to_radians();
        let width = helvetica_width(&t.text) * t.height / HELVETICA_CAP_HEIGHT;
        let pad = PAD * t.height;
        Self { centre: t.position, axis: [a.cos(), a.sin()], half: [0.5 * width + pad, HALF_HEIGHT * t.height + pad] }
    }

    /// A band of half width `half_width` around the segment `a b` (a grain arrow, a mark's cross).
    pub(crate) fn of_segment(a: P2, b: P2, half_width: f64) -> Self {
        let d = sub(b, a);
        let len = dot(d, d).sqrt();
        let axis = if len > 0.0 { normalize(d) } else { [1.0, 0.0] };
        Self { centre: axpy(a, 0.5, d), axis, half: [0.5 * len + half_width, half_width] }
    }

    /// A square of half side `half` centred on `c`.
    pub(crate) fn square(c: P2, half: f64) -> Self {
        Self::rect(c, [half, half])
    }

    /// An axis-aligned rectangle of half extents `half` centred on `c`.
    pub(crate) fn rect(c: P2, half: [f64; 2]) -> Self {
        Self { centre: c, axis: [1.0, 0.0], half }
    }

    /// Half extents along and across its axis.
    pub(crate) fn half(&self) -> [f64; 2] {
        self.half
    }

    fn across(&self) -> P2 {
        [-self.axis[1], self.axis[0]]
    }

    fn corners(&self) -> [P2; 4] {
        let (u, v) = (self.axis, self.across());
        let at = |su: f64, sv: f64| axpy(axpy(self.centre, su * self.half[0], u), sv * self.half[1], v);
        [at(-1.0, -1.0), at(1.0, -1.0), at(1.0, 1.0), at(-1.0, 1.0)]
    }

    /// Half the box's extent along the unit direction `d`.
    fn reach(&self, d: P2) -> f64 {
        self.half[0] * dot(self.axis, d).abs() + self.half[1] * dot(self.across(), d).abs()
    }

    /// How deep the two boxes overlap: the least of their overlaps along the four edge
    /// directions (separating axis theorem), 0 when they do not.
    pub(crate) fn penetration(&self, o: &LabelBox) -> f64 {
        let gap = sub(o.centre, self.centre);
        [self.axis, self.across(), o.axis, o.across()]
            .iter()
            .map(|&d| self.reach(d) + o.reach(d) - dot(gap, d).abs())
            .fold(f64::INFINITY, f64::min)
            .max(0.0)
    }

    /// Whether the two boxes overlap by more than [`TOUCH_MM`]: boxes that only touch do not
    /// (a mark's label is offset to touch the mark's box exactly, margins included, and the
    /// rounding of that sum must not decide whether it is free).
    pub(crate) fn overlaps(&self, o: &LabelBox) -> bool {
        self.penetration(o) > TOUCH_MM
    }

    /// Whether the box lies inside the simple polygon `poly` (its four sides inside: no corner
    /// outside, no crossing of the boundary, which could otherwise only enter the box through
    /// a side).
    pub(crate) fn inside(&self, poly: &[P2]) -> bool {
        let c = self.corners();
        (0..4).all(|i| segment_inside(c[i], c[(i + 1) % 4], poly))
    }

    /// Whether the box and the simple polygon `poly` are disjoint: no corner inside it, no
    /// crossing, and the polygon not inside the box.
    pub(crate) fn outside(&self, poly: &[P2]) -> bool {
        let c = self.corners();
        let n = poly.len();
        let contains = |p: P2| {
            let d = sub(p, self.centre);
            dot(d, self.axis).abs() <= self.half[0] && dot(d, self.across()).abs() <= self.half[1]
        };
        !c.iter().any(|&p| point_in_polygon(p, poly))
            && !poly.first().is_some_and(|&p| contains(p))
            && (0..4).all(|i| (0..n).all(|j| !segments_intersect(c[i], c[(i + 1) % 4], poly[j], poly[(j + 1) % n])))
    }
}

/// Where a label may go on its piece.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Region {
    /// Inside the sewing line.
    Piece,
    /// In the seam allowance: inside the cut line, clear of the sewing line (the fabric cut
    /// and sewn into the seam, where a tiny piece has room that its inside lacks).
    Allowance,
}

/// The boxes already taken on one piece, and the piece's sewing and cut lines.
pub(crate) struct Placer<'a> {
    sew: &'a [P2],
    cut: &'a [P2],
    taken: Vec<LabelBox>,
    /// Labels that found no free place.
    pub(crate) crowded: usize,
}

impl<'a> Placer<'a> {
    pub(crate) fn new(sew: &'a [P2], cut: &'a [P2]) -> Self {
        Self { sew, cut, taken: Vec::new(), crowded: 0 }
    }

    /// Whether the box lies in its region.
    fn within(&self, b: &LabelBox, region: Region) -> bool {
        match region {
            Region::Piece => b.inside(self.sew),
            Region::Allowance => b.inside(self.cut) && b.outside(self.sew),
        }
    }

    /// Reserve a box (a fixed text, a mark, the grain arrow).
    pub(crate) fn reserve(&mut self, b: LabelBox) {
        self.taken.push(b);
    }

    /// Whether the box is free: in its region and clear of everything placed.
    fn free(&self, b: &LabelBox, region: Region) -> bool {
        !self.taken.iter().any(|t| t.overlaps(b)) && self.within(b, region)
    }

    /// The first free text of `candidates` (in order), reserved; or, if none is free, the one
    /// in its region that overlaps the placed boxes least (the sum of its overlaps' depths
    /// over its own height; the earliest on a tie), or if none is in its region, the least
    /// overlapping of all; reserved and counted as crowded. `None` without candidates.
    pub(crate) fn place(&mut self, candidates: Vec<(Text, Region)>) -> Option<Text> {
        let boxes: Vec<LabelBox> = candidates.iter().map(|(t, _)| LabelBox::of_text(t)).collect();
        let pick = match (0..boxes.len()).find(|&i| self.free(&boxes[i], candidates[i].1)) {
            Some(i) => i,
            None => {
                self.crowded += 1;
                let cost = |i: usize| {
                    let b = &boxes[i];
                    let depth: f64 = self.taken.iter().map(|t| t.penetration(b)).sum();
                    (!self.within(b, candidates[i].1), depth / b.half[1].max(f64::MIN_POSITIVE))
                };
                let costs: Vec<(bool, f64)> = (0..boxes.len()).map(cost).collect();
                (0..boxes.len()).min_by(|&i, &j| {
                    let (a, b) = (costs[i], costs[j]);
                    a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(i.cmp(&j))
                })?
            }
        };
        self.taken.push(boxes[pick]);
        candidates.into_iter().nth(pick).map(|(t, _)| t)
    }
}

/// Text heights to try for a label of height `h`: h, then 0.8 times smaller each, down to
/// `floor` (included; only h when h is at or below it).
pub(crate) fn heights(h: f64, floor: f64) -> Vec<f64> {
    let mut out = vec![h];
    let mut x = h;
    while x > floor {
        x = (0.8 * x).max(floor);
        out.push(x);
    }
    out
}

/// Candidate places of a mark's label of height `h`, the mark's symbol reaching `s` from `c`:
/// below, above, right, left, then the four diagonals, then all eight twice as far.
pub(crate) fn mark_candidates(text: &str, c: P2, s: f64, h: f64) -> Vec<Text> {
    let w = helvetica_width(text) * h / HELVETICA_CAP_HEIGHT;
    // Offsets that clear the symbol: vertically by the box's half height, sideways by its half
    // width.
    let dy = s + (HALF_HEIGHT + PAD) * h;
    let dx = s + 0.5 * w + PAD * h;
    let dirs = [[0.0, -1.0], [0.0, 1.0], [1.0, 0.0], [-1.0, 0.0], [1.0, -1.0], [-1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    [1.0, 2.0]
        .iter()
        .flat_map(|&k| dirs.iter().map(move |d| [k * d[0] * dx, k * d[1] * dy]))
        .map(|o| Text { text: text.to_string(), position: add(c, o), height: h, angle_deg: 0.0 })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{MarkKind, PatternOptions, PieceInput, PointMark, SeamSide};
    use crate::pattern::build_pattern;

    fn text(s: &str, p: P2, h: f64, a: f64) -> Text {
        Text { text: s.into(), position: p, height: h, angle_deg: a }
    }

    #[test]
    fn boxes_overlap_by_separating_axes() {
        let a = LabelBox::of_text(&text("A12", [0.0, 0.0], 10.0, 0.0));
        // "A12" at 10 mm: about 23 mm wide with its margins, 16 mm tall.
        assert!(a.overlaps(&LabelBox::of_text(&text("B1", [15.0, 0.0], 10.0, 0.0))));
        assert!(!a.overlaps(&LabelBox::of_text(&text("B1", [40.0, 0.0], 10.0, 0.0))));
        assert!(!a.overlaps(&LabelBox::of_text(&text("B1", [0.0, 20.0], 10.0, 0.0))));
        // Turned by 90° beside it: clear; turned by 45° into its corner: overlapping.
        assert!(!a.overlaps(&LabelBox::of_text(&text("B1", [25.0, 0.0], 10.0, 90.0))));
        assert!(a.overlaps(&LabelBox::of_text(&text("B1", [20.0, 12.0], 10.0, 45.0))));
        // A mark's label candidate touches the mark's box exactly: free, whatever the rounding.
        for (c, s) in [([0.1, 0.2], 1.5), ([123.456, -78.9], 2.25), ([1e3 / 3.0, 7.0 / 3.0], 0.7)] {
            let mark = LabelBox::square(c, s);
            for t in mark_candidates("C12", c, s, 3.5).iter().take(4) {
                assert!(!mark.overlaps(&LabelBox::of_text(t)), "{t:?} against the mark at {c:?}");
                assert!(mark.penetration(&LabelBox::of_text(t)) < 1e-9);
            }
        }
    }

    #[test]
    fn a_box_is_inside_only_clear_of_the_boundary() {
        let square = [[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]];
        assert!(LabelBox::square([50.0, 50.0], 10.0).inside(&square));
        assert!(!LabelBox::square([95.0, 50.0], 10.0).inside(&square));
        // A notch of the boundary reaching into the box from below, its corners all inside.
        let notched = [[0.0, 0.0], [49.0, 0.0], [50.0, 55.0], [51.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]];
        assert!(!LabelBox::square([50.0, 60.0], 10.0).inside(&notched));
        assert!(LabelBox::square([50.0, 80.0], 10.0).inside(&notched));
    }

    #[test]
    fn the_placer_takes_the_first_free_candidate_and_counts_the_crowded() {
        let square = [[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]];
        let cut = [[-20.0, -20.0], [120.0, -20.0], [120.0, 120.0], [-20.0, 120.0]];
        let mut p = Placer::new(&square, &cut);
        p.reserve(LabelBox::square([50.0, 50.0], 10.0));
        let inside = |s: &str, y: f64| (text(s, [50.0, y], 8.0, 0.0), Region::Piece);
        let t = p.place(vec![inside("S1", 50.0), inside("S1", 80.0)]).unwrap();
        assert_eq!(t.position, [50.0, 80.0]);
        assert_eq!(p.crowded, 0);
        // In the allowance only clear of the sewing line.
        let band = |y: f64| (text("S3", [50.0, y], 8.0, 0.0), Region::Allowance);
        assert_eq!(p.place(vec![band(-2.0), band(108.0)]).unwrap().position, [50.0, 108.0]);
        // Nothing free: the least overlapping candidate inside the piece, not the one crossing
        // its side.
        let t = p.place(vec![inside("S2", 78.0), inside("S2", 98.0), inside("S2", 61.0), inside("S2", 58.0)]);
        assert_eq!(t.unwrap().position, [50.0, 61.0]);
        assert_eq!(p.crowded, 1);
        assert!(p.place(Vec::new()).is_none());
    }

    /// A piece of `outline` with one seam side per edge (seams `first..`, labelled by them),
    /// and the given marks.
    fn piece(id: usize, outline: Vec<P2>, first: usize, marks: Vec<PointMark>) -> PieceInput {
        let n = outline.len();
        let seams = (0..n)
            .map(|k| SeamSide {
                seam: first + k,
                label: format!("A{}", first + k),
                start: k,
                end: (k + 1) % n,
                forward: true,
            })
            .collect();
        PieceInput { id, name: format!("P{id}"), outline, seams, marks }
    }

    fn mirrored(p: &PieceInput, id: usize) -> PieceInput {
        let mut q = p.clone();
        q.id = id;
        q.name = format!("P{id}");
        for s in &mut q.seams {
            s.forward = false;
        }
        q
    }

    #[test]
    fn every_text_of_a_piece_is_clear_of_the_others_and_on_its_fabric() {
        // A strip too narrow for any label inside (4 mm), with a short seam on every edge of
        // its long sides; an octagon with eight seams and a pour and a clamp mark on one point
        // (the pour opening is also clamped). Each sewn to a copy of itself.
        let mut strip = vec![[0.0, 0.0]];
        strip.extend((1..=6).map(|k| [50.0 * k as f64, 0.0]));
        strip.extend((0..=6).rev().map(|k| [50.0 * k as f64, 4.0]));
        let octagon: Vec<P2> = (0..8)
            .map(|k| {
                let a = std::f64::consts::FRAC_PI_4 * k as f64;
                [120.0 * a.cos(), 120.0 * a.sin()]
            })
            .collect();
        let marks = vec![
            PointMark { kind: MarkKind::Pour, position: [110.0, 0.0], label: "pour".into() },
            PointMark { kind: MarkKind::Clamp, position: [110.0, 0.0], label: "clamp".into() },
        ];
        let a = piece(0, strip, 0, Vec::new());
        let b = piece(2, octagon, 100, marks);
        let pieces = vec![mirrored(&a, 1), a, mirrored(&b, 3), b];
        let pat = build_pattern(&pieces, &PatternOptions::default()).unwrap();
        assert_eq!(pat.stats.labels_crowded, 0);
        for p in &pat.pieces {
            let texts: Vec<&Text> = p.labels.iter().chain(&p.seam_labels).chain(&p.mark_labels).collect();
            // Every labelled mark has its label, every seam side its own.
            assert_eq!(p.mark_labels.len(), p.marks.iter().filter(|m| !m.label.is_empty()).count());
            assert_eq!(p.seam_labels.len(), pieces.iter().find(|q| q.id == p.id).unwrap().seams.len());
            let boxes: Vec<LabelBox> = texts.iter().map(|t| LabelBox::of_text(t)).collect();
            for (i, b) in boxes.iter().enumerate() {
                assert!(b.inside(&p.cut), "piece {}: {:?} off the fabric", p.name, texts[i]);
                for (j, c) in boxes.iter().enumerate().skip(i + 1) {
                    assert!(!b.overlaps(c), "piece {}: {:?} over {:?}", p.name, texts[i], texts[j]);
                }
            }
            // Seam labels inside the sewing line or in the allowance, never across it.
            for t in &p.seam_labels {
                let b = LabelBox::of_text(t);
                assert!(b.inside(&p.sew) || b.outside(&p.sew), "piece {}: {t:?} across its sewing line", p.name);
            }
        }
        // The strip's seam labels went into its allowance, the octagon's stayed inside.
        let strip = &pat.pieces[1];
        assert_eq!(strip.seam_labels.len(), 14);
        assert!(strip.seam_labels.iter().all(|t| LabelBox::of_text(t).outside(&strip.sew)));
        let oct = &pat.pieces[3];
        assert!(oct.seam_labels.iter().all(|t| LabelBox::of_text(t).inside(&oct.sew)));
        assert_eq!(oct.mark_labels.len(), 2);
    }

    #[test]
    fn heights_shrink_to_the_floor() {
        assert_eq!(heights(12.0, 3.0).len(), 8);
        assert_eq!(*heights(12.0, 3.0).last().unwrap(), 3.0);
        assert_eq!(heights(3.0, 3.0), vec![3.0]);
        assert_eq!(heights(2.0, 3.0), vec![2.0]);
    }
}
