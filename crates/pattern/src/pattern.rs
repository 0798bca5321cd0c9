//! The pattern: pieces with sew and cut lines, notches, labels, grain arrows and marks, nested
//! on the roll; [`build_pattern`] builds it from the flattened pieces (paper §7.1 (A)).
//!
//! Data flow per piece: validated outline → cut line ([`crate::offset`]) → notches on every
//! seam side ([`crate::seams`], ticks ending on the cut line) → an interior anchor point
//! (approximate pole of inaccessibility) carrying the grain arrow and the name → the area,
//! mark and seam labels placed clear of each other → marks copied. Then
//! all pieces are nested ([`crate::nest`]) and the statistics gathered.
//!
//! Complexity: O(n log n) per piece for the offset, O(G² · n) for the anchor search (G = 24
//! grid steps), O(candidates · n) per label (a few hundred candidates), plus nesting; all
//! sequential and deterministic.

use serde::Serialize;

use crate::error::PatternError;
use crate::geom::{
    BBox, P2, add, axpy, centroid, dist, dist_point_boundary, normalize, perimeter, point_in_polygon, ray_hit,
    right_normal, rotate_quarter, segment_inside, signed_area, sub,
};
use crate::input::{PatternOptions, PieceInput, PointMark};
use crate::labels::{LabelBox, Placer, Region, heights, mark_candidates};
use crate::nest::nest_polygons;
use crate::offset::cut_line;
use crate::seams::{SidePath, interior_notch_count_f64, notch_params, seam_length_mismatch};
use crate::validate::validate;

/// Most notches one seam may get before [`PatternError::TooManyNotches`].
pub const MAX_NOTCHES_PER_SEAM: usize = 10_000;

/// Longest grain arrow (mm).
pub const GRAIN_ARROW_MAX_MM: f64 = 200.0;

/// A text to print, centred on `position`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Text {
    /// The text (UTF-8; writers encode it for their format).
    pub text: String,
    /// Centre of the text box.
    pub position: P2,
    /// Capital letter height (mm).
    pub height: f64,
    /// Baseline direction, degrees counter-clockwise from +x.
    pub angle_deg: f64,
}

/// A match mark on a seam side.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Notch {
    /// Seam id.
    pub seam: usize,
    /// Index along the seam: 0 at its 3D start, `count − 1` at its end (a closed seam has no
    /// notch at its end, which is its start); notch k of one side meets notch k of the other.
    pub index: usize,
    /// Normalised arc length along the seam, in [0, 1].
    pub t: f64,
    /// The point on the sew line.
    pub position: P2,
    /// Outward unit normal of the sew line there.
    pub normal: P2,
    /// The slit as drawn: from the cut line inwards along `-normal`, `notch_length_mm` long
    /// (shorter if the allowance is).
    pub tick: [P2; 2],
}

/// The grain line: along +x (the warp) in piece coordinates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GrainArrow {
    /// Tail.
    pub start: P2,
    /// Head (tip).
    pub end: P2,
    /// Arrowhead polyline: barb, tip, barb.
    pub head: [P2; 3],
}

/// Where a piece lies on the roll: `roll = rotate(piece, rotation_deg) + offset`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Placement {
    /// Counter-clockwise quarter turn: 0, 90, 180 or 270.
    pub rotation_deg: u16,
    /// Translation after the rotation (mm).
    pub offset: P2,
}

impl Placement {
    /// The roll coordinates of a piece point.
    pub fn apply(&self, p: P2) -> P2 {
        add(rotate_quarter(p, self.rotation_deg), self.offset)
    }
}

/// One pattern piece, in piece coordinates (mm, warp along +x), and its place on the roll.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Piece {
    /// Patch id (from the input).
    pub id: usize,
    /// Name (from the input).
    pub name: String,
    /// Sew line (the input outline), counter-clockwise.
    pub sew: Vec<P2>,
    /// Cut line: the sew line offset by the seam allowance, counter-clockwise, simple.
    pub cut: Vec<P2>,
    /// Area inside the sew line (mm²): the finished piece.
    pub sew_area_mm2: f64,
    /// Area inside the cut line (mm²): the fabric used.
    pub cut_area_mm2: f64,
    /// Match marks of all seam sides, by side then along the seam.
    pub notches: Vec<Notch>,
    /// One label per seam side, along it: inside the piece, or in the seam allowance where the
    /// inside has no room.
    pub seam_labels: Vec<Text>,
    /// The grain line.
    pub grain: GrainArrow,
    /// Name (below the grain arrow), then area in m² (3 decimals; below the name where there
    /// is room).
    pub labels: Vec<Text>,
    /// Marked points (from the input).
    pub marks: Vec<PointMark>,
    /// The labels of the marks that have one, in the marks' order.
    pub mark_labels: Vec<Text>,
    /// Place on the roll.
    pub placement: Placement,
}

impl Piece {
    /// The roll coordinates of a point given in this piece's coordinates.
    pub fn to_roll(&self, p: P2) -> P2 {
        self.placement.apply(p)
    }

    /// The cut line on the roll.
    pub fn placed_cut(&self) -> Vec<P2> {
        self.cut.iter().map(|&p| self.to_roll(p)).collect()
    }

    /// The sew line on the roll.
    pub fn placed_sew(&self) -> Vec<P2> {
        self.sew.iter().map(|&p| self.to_roll(p)).collect()
    }
}

/// Summary figures of a pattern.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PatternStats {
    /// Number of pieces.
    pub pieces: usize,
    /// Number of seams (each with two sides).
    pub seams: usize,
    /// Number of notches over all sides.
    pub notches: usize,
    /// Largest `|L₁ − L₂| / mean` over the seams (see [`seam_length_mismatch`]).
    pub seam_length_mismatch_max_rel: f64,
    /// Total area inside the sew lines (mm²): the finished surface.
    pub area_mm2_total: f64,
    /// Total area inside the cut lines (mm²): the fabric in the pieces.
    pub cut_area_mm2_total: f64,
    /// Labels (areas, marks' and seams' labels) that found no place clear of their piece's other texts,
    /// marks, notches and grain arrow, inside its sewing line or in its seam allowance, at any
    /// height down to the smallest: on tiny pieces.
    pub labels_crowded: usize,
}

/// A nested sewing pattern.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Pattern {
    /// The pieces, in input order.
    pub pieces: Vec<Piece>,
    /// Roll width (roll y in `[0, width]`).
    pub fabric_width_mm: f64,
    /// Used roll length (roll x in `[0, length]`).
    pub fabric_length_mm: f64,
    /// Σ cut areas / (width × length).
    pub utilisation: f64,
    /// Summary figures.
    pub stats: PatternStats,
}

/// Builds the pattern: validates the input (see [`PatternError`]), offsets every sew line by
/// the seam allowance, places the notches, labels and grain arrows, and nests the pieces on
/// the roll. Never panics on bad input.
pub fn build_pattern(pieces: &[PieceInput], opts: &PatternOptions) -> Result<Pattern, PatternError> {
    let seams = validate(pieces, opts)?;
    let r = opts.seam_allowance_mm;
    let th = opts.text_height_mm;

    // Every piece's cut line; the pieces too wide for the roll are all reported at once (the
    // first in the error, all of them in its list), so that a caller can split them together.
    let mut cuts = Vec::with_capacity(pieces.len());
    let mut too_wide: Vec<(usize, f64)> = Vec::new();
    let mut first_too_wide: Option<(&PieceInput, f64, f64)> = None;
    let width = opts.fabric_width_mm;
    for p in pieces {
        let Some(cut) = cut_line(&p.outline, r) else {
            if first_too_wide.is_some() {
                break;
            }
            return Err(PatternError::OffsetFailed { piece: p.id });
        };
        let b = BBox::of(&cut);
        let (w, h) = (b.width(), b.height());
        if h > width && (!opts.allow_weft_swap || w > width) {
            let across = if opts.allow_weft_swap { w.min(h) } else { h };
            too_wide.push((p.id, across / width));
            first_too_wide.get_or_insert((p, w, h));
        }
        cuts.push(cut);
    }
    if let Some((p, w, h)) = first_too_wide {
        return Err(PatternError::PieceTooWide {
            piece: p.id,
            name: p.name.clone(),
            width_mm: w,
            height_mm: h,
            fabric_width_mm: width,
            weft_swap: opts.allow_weft_swap,
            too_wide,
        });
    }

    // Notches, seam by seam so that both sides share the parameters.
    let mut notches: Vec<Vec<(usize, Notch)>> = vec![Vec::new(); pieces.len()];
    for (&seam, sides) in &seams {
        let paths: Vec<SidePath> = sides
            .iter()
            .map(|&(pi, si)| SidePath::new(&pieces[pi].outline, &pieces[pi].seams[si]))
            .collect::<Option<_>>()
            .ok_or(PatternError::EmptySeamSide { piece: pieces[sides[0].0].id, seam, index: 0 })?;
        let mean = paths.iter().map(SidePath::length).sum::<f64>() / paths.len() as f64;
        let count = interior_notch_count_f64(mean, opts.notch_spacing_mm);
        if count > MAX_NOTCHES_PER_SEAM as f64 {
            return Err(PatternError::TooManyNotches { seam, count, limit: MAX_NOTCHES_PER_SEAM });
        }
        let mut params = notch_params(mean, opts.notch_spacing_mm);
        // Round a closed seam (a side from its start back to it) the end is the start again:
        // one notch there.
        if sides.iter().any(|&(pi, si)| pieces[pi].seams[si].start == pieces[pi].seams[si].end) {
            params.pop();
        }
        for (&(pi, si), path) in sides.iter().zip(&paths) {
            for (index, &t) in params.iter().enumerate() {
                let (position, normal) = path.at(t * path.length());
                let tick = notch_tick(position, normal, &cuts[pi], r, opts.notch_length_mm);
                notches[pi].push((si, Notch { seam, index, t, position, normal, tick }));
            }
        }
    }

    let mut out = Vec::with_capacity(pieces.len());
    let mut labels_crowded = 0;
    for ((p, cut), mut pn) in pieces.iter().zip(cuts).zip(notches) {
        pn.sort_by_key(|(si, n)| (*si, n.index));
        let sew_area = signed_area(&p.outline);
        let anchor = interior_anchor(&p.outline);
        // The text shrunk on a piece too small for it (the labels' stack is about 2.4 text
        // heights tall and wide: it then stays inside the sewing line), down to a legible floor.
        let th = th.min((dist_point_boundary(anchor, &p.outline) / TEXT_FIT).max(MIN_TEXT_MM.min(th)));
        // The smallest text on this piece; the smaller texts (area, marks) no smaller either.
        let floor = MIN_TEXT_MM.min(th);
        let small = |k: f64| (k * th).max(floor);
        let grain = grain_arrow(&p.outline, anchor, th);
        let name = Text { text: p.name.clone(), position: axpy(anchor, -0.9, [0.0, th]), height: th, angle_deg: 0.0 };
        // The name, the grain arrow, the marks' symbols and the notches hold their places; the
        // area, the marks' and the seams' labels are placed around them (`crate::labels`).
        let mut placer = Placer::new(&p.outline, &cut);
        placer.reserve(LabelBox::of_text(&name));
        placer.reserve(LabelBox::of_segment(grain.start, grain.end, 0.5 * th));
        let area = Text {
            text: format!("{:.3} m²", sew_area * 1e-6),
            position: name.position,
            height: small(0.8),
            angle_deg: 0.0,
        };
        let area = placer.place(text_candidates(&area, &name, &p.outline, r)).unwrap_or(area);
        let labels = vec![name, area];
        let s = mark_size(th);
        for m in &p.marks {
            placer.reserve(LabelBox::square(m.position, s));
        }
        for (_, n) in &pn {
            placer.reserve(LabelBox::of_segment(n.tick[0], n.tick[1], NOTCH_CLEARANCE_MM));
        }
        let mark_labels = p
            .marks
            .iter()
            .filter(|m| !m.label.is_empty())
            .filter_map(|m| {
                let here: Vec<Text> = heights(small(0.6), floor)
                    .into_iter()
                    .flat_map(|h| mark_candidates(&m.label, m.position, s, h))
                    .collect();
                let candidates = [Region::Piece, Region::Allowance]
                    .iter()
                    .flat_map(|&region| here.iter().map(move |t| (t.clone(), region)))
                    .collect();
                placer.place(candidates)
            })
            .collect();
        // A seam label inside the piece at a good height first, then in the seam allowance
        // (tiny pieces), then inside at the smallest heights.
        let sizes = heights(th, floor);
        let large = |h: &f64| *h >= 0.5 * th;
        // The allowance tier only where the allowance holds a text of the smallest height.
        let band =
            if ALLOWANCE_TEXT_FIT * r >= floor { heights(th.min(ALLOWANCE_TEXT_FIT * r), floor) } else { Vec::new() };
        let seam_labels = p
            .seams
            .iter()
            .filter_map(|s| SidePath::new(&p.outline, s).map(|path| (path, &s.label)))
            .filter_map(|(path, label)| {
                let inside = |h: f64| {
                    SEAM_LABEL_AT.iter().flat_map(move |&t| SEAM_LABEL_DEPTHS.iter().map(move |&d| (t, -d * h, h)))
                };
                let outside = |h: f64| {
                    SEAM_LABEL_AT.iter().flat_map(move |&t| ALLOWANCE_DEPTHS.iter().map(move |&d| (t, d * r, h)))
                };
                let tiers = sizes.iter().copied().filter(large).flat_map(|h| inside(h).map(|c| (c, Region::Piece)));
                let tiers = tiers.chain(band.iter().flat_map(|&h| outside(h).map(|c| (c, Region::Allowance))));
                let tiers = tiers.chain(
                    sizes.iter().copied().filter(|h| !large(h)).flat_map(|h| inside(h).map(|c| (c, Region::Piece))),
                );
                let candidates =
                    tiers.map(|((t, offset, h), region)| (seam_label(&path, label, t, offset, h), region)).collect();
                placer.place(candidates)
            })
            .collect();
        labels_crowded += placer.crowded;
        out.push(Piece {
            id: p.id,
            name: p.name.clone(),
            sew: p.outline.clone(),
            cut_area_mm2: signed_area(&cut),
            cut,
            sew_area_mm2: sew_area,
            notches: pn.into_iter().map(|(_, n)| n).collect(),
            seam_labels,
            grain,
            labels,
            marks: p.marks.clone(),
            mark_labels,
            placement: Placement { rotation_deg: 0, offset: [0.0, 0.0] },
        });
    }

    // Nest the cut lines.
    let cuts: Vec<Vec<P2>> = out.iter().map(|pc| pc.cut.clone()).collect();
    let (placements, length) = nest_polygons(&cuts, opts.fabric_width_mm, opts.piece_gap_mm, opts.allow_weft_swap);
    for (pc, pl) in out.iter_mut().zip(&placements) {
        pc.placement = Placement { rotation_deg: pl.rotation_deg, offset: pl.offset };
    }

    let cut_total: f64 = out.iter().map(|p| p.cut_area_mm2).sum();
    let stats = PatternStats {
        pieces: out.len(),
        seams: seams.len(),
        notches: out.iter().map(|p| p.notches.len()).sum(),
        seam_length_mismatch_max_rel: seam_length_mismatch(pieces),
        area_mm2_total: out.iter().map(|p| p.sew_area_mm2).sum(),
        cut_area_mm2_total: cut_total,
        labels_crowded,
    };
    let utilisation = if length > 0.0 { cut_total / (opts.fabric_width_mm * length) } else { 0.0 };
    Ok(Pattern { pieces: out, fabric_width_mm: opts.fabric_width_mm, fabric_length_mm: length, utilisation, stats })
}

/// A piece's text is at most its depth (the distance from the labels' anchor to the sewing
/// line) over this: spot at 0.3 m has a piece about 50 mm across whose 12 mm labels overran it.
const TEXT_FIT: f64 = 4.0;

/// Smallest text height a small piece's labels shrink to (mm).
pub(crate) const MIN_TEXT_MM: f64 = 3.0;

/// A mark's symbol reaches this far from its point (its cross's arms), for text height `th`.
pub(crate) fn mark_size(th: f64) -> f64 {
    0.6 * th
}

/// Where along a seam side its label is tried (arc-length fractions, the middle first).
const SEAM_LABEL_AT: [f64; 7] = [0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.8];

/// How deep inside the piece a seam label's centre is tried, in text heights (1.2, the
/// first, as before the labels were placed).
const SEAM_LABEL_DEPTHS: [f64; 4] = [1.2, 1.6, 2.2, 0.9];

/// How far out of the side a seam label in the seam allowance is tried, in allowances (the
/// middle of the band between the sewing and cut lines first).
const ALLOWANCE_DEPTHS: [f64; 3] = [0.5, 0.4, 0.6];

/// A label in the seam allowance is at most this many allowances high (its box, with its
/// margins, then takes 90% of the band).
const ALLOWANCE_TEXT_FIT: f64 = 0.56;

/// Labels keep this far from a notch's slit (mm).
const NOTCH_CLEARANCE_MM: f64 = 0.5;

/// The notch slit: from where the outward normal ray meets the cut line, inwards.
fn notch_tick(position: P2, normal: P2, cut: &[P2], r: f64, len: f64) -> [P2; 2] {
    if r == 0.0 {
        return [position, position]; // no allowance, no slit (the notch keeps its position)
    }
    // The ray leaves from inside the cut polygon, so its first boundary hit is the cut line.
    let reach = ray_hit(position, normal, cut, 1e-9 * r.max(1.0)).unwrap_or(r);
    let outer = axpy(position, reach, normal);
    [outer, axpy(outer, -len.min(reach), normal)]
}

/// An interior point far from the boundary (approximate pole of inaccessibility): the best
/// point of a G×G grid over the bounding box, refined on a finer grid around it; ties go to
/// the point nearer the centroid. Falls back to the centroid.
pub fn interior_anchor(poly: &[P2]) -> P2 {
    const G: usize = 24;
    let b = BBox::of(poly);
    let c = centroid(poly);
    let score = |q: P2| -> Option<(f64, f64)> {
        if !point_in_polygon(q, poly) {
            return None;
        }
        let d = dist_point_boundary(q, poly);
        let dc = (q[0] - c[0]).hypot(q[1] - c[1]);
        // Prefer central points among nearly equally deep ones (quantised depth).
        Some((d, -dc))
    };
    let better = |a: (f64, f64), bst: Option<(f64, f64)>| match bst {
        None => true,
        Some(bb) => a.0 > bb.0 * (1.0 + 1e-3) || (a.0 >= bb.0 * (1.0 - 1e-3) && a.1 > bb.1),
    };
    let mut best: Option<(f64, f64)> = None;
    let mut best_p = c;
    if let Some(s) = score(c) {
        best = Some(s);
    }
    let (dx, dy) = (b.width() / G as f64, b.height() / G as f64);
    for i in 0..G {
        for j in 0..G {
            let q = [b.min[0] + (i as f64 + 0.5) * dx, b.min[1] + (j as f64 + 0.5) * dy];
            if let Some(s) = score(q)
                && better(s, best)
            {
                best = Some(s);
                best_p = q;
            }
        }
    }
    let center = best_p;
    for i in 0..9 {
        for j in 0..9 {
            let q = [center[0] + (i as f64 - 4.0) * dx / 4.0, center[1] + (j as f64 - 4.0) * dy / 4.0];
            if let Some(s) = score(q)
                && better(s, best)
            {
                best = Some(s);
                best_p = q;
            }
        }
    }
    best_p
}

/// The grain arrow above the anchor: along +x, `min(200 mm, half the piece's x extent)` long,
/// shortened until it fits inside the piece.
fn grain_arrow(poly: &[P2], anchor: P2, th: f64) -> GrainArrow {
    let b = BBox::of(poly);
    let mut len = GRAIN_ARROW_MAX_MM.min(0.5 * b.width());
    let mut centre = axpy(anchor, 0.9, [0.0, th]);
    for attempt in 0..8 {
        let s = axpy(centre, -0.5 * len, [1.0, 0.0]);
        let e = axpy(centre, 0.5 * len, [1.0, 0.0]);
        if segment_inside(s, e, poly) {
            break;
        }
        if attempt == 3 {
            centre = anchor; // a narrow piece: try on the anchor itself
        } else {
            len *= 0.7;
        }
    }
    let start = axpy(centre, -0.5 * len, [1.0, 0.0]);
    let end = axpy(centre, 0.5 * len, [1.0, 0.0]);
    let hl = (0.15 * len).min(0.8 * th);
    let head = [add(end, [-hl, 0.4 * hl]), end, add(end, [-hl, -0.4 * hl])];
    GrainArrow { start, end, head }
}

/// Candidate places of a text `t` that goes with `next_to` (the area with the name): below
/// it (their boxes touching), right of it, left of it; then points inside the sewing line
/// (a grid over its box), then points in the seam allowance (along the sewing line, half an
/// allowance out), each nearest to `next_to` first.
fn text_candidates(t: &Text, next_to: &Text, sew: &[P2], r: f64) -> Vec<(Text, Region)> {
    let at = |position: P2| Text { position, ..t.clone() };
    let c = next_to.position;
    let (half, half_next) = (LabelBox::of_text(t).half(), LabelBox::of_text(next_to).half());
    let beside = 1.01 * (half[0] + half_next[0]);
    let below = 1.01 * (half[1] + half_next[1]);
    let mut out: Vec<(Text, Region)> =
        [[0.0, -below], [beside, 0.0], [-beside, 0.0]].iter().map(|&o| (at(add(c, o)), Region::Piece)).collect();
    let by_distance = |mut v: Vec<P2>| {
        v.sort_by(|a, b| dist(*a, c).total_cmp(&dist(*b, c)));
        v
    };
    const G: usize = 16;
    let b = BBox::of(sew);
    let grid: Vec<P2> = (0..G * G)
        .map(|k| {
            [
                b.min[0] + ((k % G) as f64 + 0.5) * b.width() / G as f64,
                b.min[1] + ((k / G) as f64 + 0.5) * b.height() / G as f64,
            ]
        })
        .filter(|&q| point_in_polygon(q, sew))
        .collect();
    out.extend(by_distance(grid).into_iter().map(|q| (at(q), Region::Piece)));
    if r > 0.0 {
        // Every two box heights along the sewing line by arc length, at most about
        // BAND_SAMPLES in all (one per edge would make a fine outline's search quadratic).
        let n = sew.len();
        let spacing = (4.0 * half[1]).max(perimeter(sew) / BAND_SAMPLES);
        let mut band = Vec::new();
        let mut next = 0.5 * spacing;
        let mut walked = 0.0;
        for i in 0..n {
            let (a, e) = (sew[i], sew[(i + 1) % n]);
            let len = dist(a, e);
            while len > 0.0 && next <= walked + len {
                let q = axpy(a, (next - walked) / len, sub(e, a));
                band.push(axpy(q, 0.5 * r, right_normal(sub(e, a))));
                next += spacing;
            }
            walked += len;
        }
        out.extend(by_distance(band).into_iter().map(|q| (at(q), Region::Allowance)));
    }
    out
}

/// About how many places along the sewing line a text is tried in the seam allowance.
const BAND_SAMPLES: f64 = 400.0;

/// The label of a seam side at the fraction `t` of its length, its centre `offset` (mm) out
/// of the side (negative: inside the piece), its baseline along the side (turned to read
/// upright).
fn seam_label(path: &SidePath, label: &str, t: f64, offset: f64, th: f64) -> Text {
    let (mid, n) = path.at(t * path.length());
    let position = axpy(mid, offset, n);
    // Edge direction: the outward normal turned a quarter counter-clockwise.
    let dir = normalize([-n[1], n[0]]);
    let mut angle = dir[1].atan2(dir[0]).to_degrees();
    if angle > 90.0 + 1e-9 {
        angle -= 180.0;
    } else if angle <= -90.0 + 1e-9 {
        angle += 180.0;
    }
    // Snap the -0.0 and rounding noise of axis-aligned sides.
    let angle = (angle * 1e9).round() / 1e9;
    Text { text: label.to_string(), position, height: th, angle_deg: angle + 0.0 }
}
