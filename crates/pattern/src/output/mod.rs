//! Pattern files: the [`PatternWriter`] trait and its SVG, DXF and PDF back ends.
//!
//! All writers draw from one shared 2D drawing model (`piece_items`): per piece, a list of
//! primitives (closed polygon, line, circle, text) on a `Layer`, in millimetres
//! with y up — the roll coordinates of [`crate::Pattern`] (or piece coordinates for the
//! per-piece PDF). Only SVG has y down; it flips once, through `flip_y`. So the three files
//! agree on every coordinate by construction, and a test checks it.
//!
//! | writer | file | content |
//! |---|---|---|
//! | [`SvgWriter`] | `pattern.svg` | roll layout at true scale (1 user unit = 1 mm) |
//! | [`DxfWriter`] | `pattern.dxf` | roll layout, R12, mm, layers CUT SEW NOTCH GRAIN TEXT MARK |
//! | [`PdfWriter`] + [`PdfMode::Pieces`] | `pattern.pdf` | one true-scale page per piece |
//! | [`PdfWriter`] + [`PdfMode::TiledA4`] | `pattern_a4.pdf` | roll layout tiled on A4 pages |
//!
//! Every writer is deterministic: the same pattern gives byte-identical files.

pub mod dxf;
pub mod pdf;
pub mod svg;

pub use dxf::DxfWriter;
pub use pdf::{PdfMode, PdfWriter};
pub use svg::SvgWriter;

use crate::error::PatternError;
use crate::geom::{P2, add, rotate_quarter};
use crate::input::MarkKind;
use crate::pattern::{Pattern, Piece, Text};

/// A back end that writes a [`Pattern`] to a file.
pub trait PatternWriter {
    /// Short name of the format, e.g. `"svg"`.
    fn name(&self) -> &'static str;
    /// The conventional output file name, e.g. `"pattern.svg"`.
    fn file_name(&self) -> &'static str;
    /// Writes the whole file to `out`.
    fn write(&self, pattern: &Pattern, out: &mut dyn std::io::Write) -> Result<(), PatternError>;
}

/// Every writer with its default settings: SVG, DXF, PDF per piece, PDF tiled on A4.
pub fn all_writers() -> Vec<Box<dyn PatternWriter>> {
    vec![
        Box::new(SvgWriter),
        Box::new(DxfWriter),
        Box::new(PdfWriter { mode: PdfMode::Pieces }),
        Box::new(PdfWriter { mode: PdfMode::TiledA4 }),
    ]
}

/// The layers of a pattern drawing, in drawing order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Layer {
    /// Cut line (solid).
    Cut,
    /// Sew line (dashed).
    Sew,
    /// Notches.
    Notch,
    /// Grain arrow.
    Grain,
    /// Piece and seam labels.
    Text,
    /// Marked points and their labels.
    Mark,
}

impl Layer {
    pub(crate) const ALL: [Layer; 6] = [Layer::Cut, Layer::Sew, Layer::Notch, Layer::Grain, Layer::Text, Layer::Mark];

    /// DXF layer name.
    pub(crate) fn dxf_name(self) -> &'static str {
        match self {
            Layer::Cut => "CUT",
            Layer::Sew => "SEW",
            Layer::Notch => "NOTCH",
            Layer::Grain => "GRAIN",
            Layer::Text => "TEXT",
            Layer::Mark => "MARK",
        }
    }

    /// SVG group id.
    pub(crate) fn svg_id(self) -> &'static str {
        match self {
            Layer::Cut => "cut",
            Layer::Sew => "sew",
            Layer::Notch => "notches",
            Layer::Grain => "grain",
            Layer::Text => "labels",
            Layer::Mark => "marks",
        }
    }
}

/// A drawing primitive, in mm, y up.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Prim {
    /// Closed polygon.
    Polygon(Vec<P2>),
    /// Segment.
    Line(P2, P2),
    /// Circle: centre, radius.
    Circle(P2, f64),
    /// Centred text.
    Text(Text),
}

/// One primitive on one layer.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Item {
    pub(crate) layer: Layer,
    pub(crate) prim: Prim,
}

/// A text baseline angle (degrees) that reads upright, in (−90°, 90°]: texts are centred on their
/// position, so one that would read upside down (e.g. on a piece placed at 180°) is turned by
/// 180° in place.
fn upright(angle_deg: f64) -> f64 {
    let a = angle_deg.rem_euclid(360.0);
    if a > 90.0 && a <= 270.0 {
        a - 180.0
    } else if a > 270.0 {
        a - 360.0
    } else {
        a
    }
}

/// The drawing of one piece, in roll coordinates (`placed`) or piece coordinates; items are
/// sorted by layer, in a fixed order within each layer.
pub(crate) fn piece_items(piece: &Piece, placed: bool) -> Vec<Item> {
    let (rot, off) = if placed { (piece.placement.rotation_deg, piece.placement.offset) } else { (0, [0.0, 0.0]) };
    let tf = |p: P2| add(rotate_quarter(p, rot), off);
    let tfv = |v: &[P2]| v.iter().map(|&p| tf(p)).collect::<Vec<_>>();
    let text = |t: &Text| {
        let a = upright(t.angle_deg + f64::from(rot));
        Prim::Text(Text { text: t.text.clone(), position: tf(t.position), height: t.height, angle_deg: a })
    };
    let th = piece.labels.first().map_or(12.0, |t| t.height);
    let mut items = vec![
        Item { layer: Layer::Cut, prim: Prim::Polygon(tfv(&piece.cut)) },
        Item { layer: Layer::Sew, prim: Prim::Polygon(tfv(&piece.sew)) },
    ];
    for n in &piece.notches {
        items.push(Item { layer: Layer::Notch, prim: Prim::Line(tf(n.tick[0]), tf(n.tick[1])) });
    }
    let g = &piece.grain;
    items.push(Item { layer: Layer::Grain, prim: Prim::Line(tf(g.start), tf(g.end)) });
    items.push(Item { layer: Layer::Grain, prim: Prim::Line(tf(g.head[0]), tf(g.head[1])) });
    items.push(Item { layer: Layer::Grain, prim: Prim::Line(tf(g.head[2]), tf(g.head[1])) });
    for t in piece.labels.iter().chain(&piece.seam_labels) {
        items.push(Item { layer: Layer::Text, prim: text(t) });
    }
    let s = crate::pattern::mark_size(th);
    for m in &piece.marks {
        let c = m.position;
        let at = |dx: f64, dy: f64| tf([c[0] + dx, c[1] + dy]);
        let symbol = match m.kind {
            MarkKind::Suspension => Prim::Circle(tf(c), 0.5 * s),
            MarkKind::Clamp => Prim::Polygon(vec![
                at(-0.5 * s, -0.5 * s),
                at(0.5 * s, -0.5 * s),
                at(0.5 * s, 0.5 * s),
                at(-0.5 * s, 0.5 * s),
            ]),
            MarkKind::Pour => Prim::Polygon(vec![at(-0.6 * s, -0.4 * s), at(0.6 * s, -0.4 * s), at(0.0, 0.65 * s)]),
        };
        items.push(Item { layer: Layer::Mark, prim: symbol });
        items.push(Item { layer: Layer::Mark, prim: Prim::Line(at(-s, 0.0), at(s, 0.0)) });
        items.push(Item { layer: Layer::Mark, prim: Prim::Line(at(0.0, -s), at(0.0, s)) });
    }
    for t in &piece.mark_labels {
        items.push(Item { layer: Layer::Mark, prim: text(t) });
    }
    items.sort_by_key(|it| it.layer); // stable: keeps the order within a layer
    items
}

/// The one y flip between the y-up drawing and a y-down output (SVG): `y ↦ height − y`.
pub(crate) fn flip_y(p: P2, height: f64) -> P2 {
    [p[0], height - p[1]]
}

/// A number with at most `decimals` decimals, trailing zeros removed, no `-0`.
pub(crate) fn fmt_num(x: f64, decimals: usize) -> String {
    let mut s = format!("{x:.decimals$}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

/// Helvetica advance widths (per 1000 em) of the printable ASCII characters 32..=126, from
/// the standard Adobe font metrics; other characters count as 556.
const HELVETICA_WIDTHS: [u16; 95] = [
    278, 278, 355, 556, 556, 889, 667, 191, 333, 333, 389, 584, 278, 333, 278, 278, // ' '..'/'
    556, 556, 556, 556, 556, 556, 556, 556, 556, 556, 278, 278, 584, 584, 584, 556, // '0'..'?'
    1015, 667, 667, 722, 722, 667, 611, 778, 722, 278, 500, 667, 556, 833, 722, 778, // '@'..'O'
    667, 778, 722, 667, 611, 722, 667, 944, 667, 667, 611, 278, 278, 278, 469, 556, // 'P'..'_'
    333, 556, 556, 500, 556, 556, 278, 556, 556, 222, 222, 500, 222, 833, 556, 556, // '`'..'o'
    556, 556, 333, 500, 278, 556, 500, 722, 500, 500, 500, 334, 260, 334, 584, // 'p'..'~'
];

/// Helvetica's cap height per em: a text of cap height h is set at font size h / this.
pub(crate) const HELVETICA_CAP_HEIGHT: f64 = 0.718;

/// Width of `text` in Helvetica at font size 1.
pub(crate) fn helvetica_width(text: &str) -> f64 {
    text.chars()
        .map(|c| {
            let k = c as u32;
            if (32..=126).contains(&k) { f64::from(HELVETICA_WIDTHS[(k - 32) as usize]) } else { 556.0 }
        })
        .sum::<f64>()
        / 1000.0
}

#[cfg(test)]
mod upright_tests {
    use super::upright;

    #[test]
    fn texts_stay_upright_on_turned_pieces() {
        for (angle, want) in
            [(180.0, 0.0), (0.0, 0.0), (210.0, 30.0), (90.0, 90.0), (270.0, 90.0), (170.0, -10.0), (-100.0, 80.0)]
        {
            assert!((upright(angle) - want).abs() < 1e-12, "{angle}: {}", upright(angle));
        }
    }
}
