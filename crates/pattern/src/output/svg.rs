//! `pattern.svg`: the roll layout at true scale.
//!
//! Structure (a test counts the pieces through it):
//!
//! ```text
//! <svg width="{L}mm" height="{W}mm" viewBox="0 0 {L} {W}">      1 user unit = 1 mm, y down
//!   <g id="roll">     the fabric: a rectangle L × W
//!   <g id="cut">      one <path data-piece="{id}" data-name="{name}"> per piece (solid)
//!   <g id="sew">      one <path data-piece=…> per piece (dashed)
//!   <g id="notches">  one <g data-piece=…> per piece holding one <path> per notch slit
//!   <g id="grain">    one <g data-piece=…> per piece: shaft and arrowhead
//!   <g id="labels">   one <g data-piece=…> per piece: name, area, seam labels (<text>)
//!   <g id="marks">    one <g data-piece=…> per piece: symbols and labels
//! ```
//!
//! Each layer group is an Inkscape layer, so cutters/plotters driven from Inkscape can select
//! "cut" alone. Roll x (the warp) runs to the right; roll y is flipped once (SVG y runs
//! down, see `flip_y` in the parent module). Coordinates are written with 4 decimals (0.1 µm).
//!
//! Hand-written XML rather than the `svg` crate: the format is a few fixed element types,
//! the crate would add nothing but a dependency, and writing it here fixes the number format
//! (the crate prints full `f64` digits) and makes the escaping explicit.

use std::fmt::Write as _;

use super::{HELVETICA_CAP_HEIGHT, Item, Layer, PatternWriter, Prim, flip_y, fmt_num, piece_items};
use crate::error::PatternError;
use crate::geom::P2;
use crate::pattern::Pattern;

/// Writes `pattern.svg` (see the module docs for the structure).
#[derive(Debug, Clone, Copy, Default)]
pub struct SvgWriter;

const DECIMALS: usize = 4;

/// Escapes text for XML character data and attribute values.
pub(crate) fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Characters XML 1.0 cannot carry at all.
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => out.push('\u{FFFD}'),
            c => out.push(c),
        }
    }
    out
}

fn style(layer: Layer) -> &'static str {
    match layer {
        Layer::Cut => r##"fill="none" stroke="#000000" stroke-width="0.5""##,
        Layer::Sew => r##"fill="none" stroke="#1f5fbf" stroke-width="0.3" stroke-dasharray="6 3""##,
        Layer::Notch => r##"fill="none" stroke="#c00000" stroke-width="0.5""##,
        Layer::Grain => r##"fill="none" stroke="#207020" stroke-width="0.5""##,
        Layer::Text => r##"font-family="Helvetica, Arial, sans-serif""##,
        Layer::Mark => {
            r##"fill="none" stroke="#8000a0" stroke-width="0.4" font-family="Helvetica, Arial, sans-serif""##
        }
    }
}

impl SvgWriter {
    /// The SVG document as a string.
    pub fn render(&self, pattern: &Pattern) -> String {
        let (len, wid) = (pattern.fabric_length_mm, pattern.fabric_width_mm);
        let h = wid;
        let n = |x: f64| fmt_num(x, DECIMALS);
        let pt = |p: P2| {
            let q = flip_y(p, h);
            format!("{} {}", n(q[0]), n(q[1]))
        };
        let mut s = String::new();
        s.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"no\"?>\n");
        let _ = writeln!(
            s,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" \
             xmlns:inkscape=\"http://www.inkscape.org/namespaces/inkscape\" version=\"1.1\" \
             width=\"{0}mm\" height=\"{1}mm\" viewBox=\"0 0 {0} {1}\">",
            n(len),
            n(wid)
        );
        let _ = writeln!(s, "<title>clothcast sewing pattern</title>");
        let _ = writeln!(
            s,
            "<desc>{} pieces on a {} mm roll, {} mm used, utilisation {:.1}%. 1 unit = 1 mm; \
             x runs along the roll (warp).</desc>",
            pattern.pieces.len(),
            n(wid),
            n(len),
            100.0 * pattern.utilisation
        );
        let _ = writeln!(
            s,
            "<g id=\"roll\" inkscape:groupmode=\"layer\" inkscape:label=\"roll\">\
             <rect x=\"0\" y=\"0\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#b0b0b0\" \
             stroke-width=\"0.5\"/></g>",
            n(len),
            n(wid)
        );
        let drawings: Vec<Vec<Item>> = pattern.pieces.iter().map(|p| piece_items(p, true)).collect();
        for layer in Layer::ALL {
            let id = layer.svg_id();
            let _ =
                writeln!(s, "<g id=\"{id}\" inkscape:groupmode=\"layer\" inkscape:label=\"{id}\" {}>", style(layer));
            for (piece, items) in pattern.pieces.iter().zip(&drawings) {
                let attrs = format!("data-piece=\"{}\" data-name=\"{}\"", piece.id, xml_escape(&piece.name));
                let mine: Vec<&Item> = items.iter().filter(|it| it.layer == layer).collect();
                let single_path = matches!(layer, Layer::Cut | Layer::Sew);
                if single_path {
                    for it in mine {
                        if let Prim::Polygon(v) = &it.prim {
                            let _ = writeln!(s, "  <path {attrs} d=\"{}\"/>", path_data(v, true, &pt));
                        }
                    }
                    continue;
                }
                if mine.is_empty() {
                    continue;
                }
                let _ = writeln!(s, "  <g {attrs}>");
                for it in mine {
                    s.push_str("    ");
                    s.push_str(&prim_svg(&it.prim, h));
                    s.push('\n');
                }
                s.push_str("  </g>\n");
            }
            s.push_str("</g>\n");
        }
        s.push_str("</svg>\n");
        s
    }
}

fn path_data(v: &[P2], closed: bool, pt: &dyn Fn(P2) -> String) -> String {
    let mut d = String::new();
    for (i, &p) in v.iter().enumerate() {
        d.push_str(if i == 0 { "M" } else { " L" });
        d.push_str(&pt(p));
    }
    if closed {
        d.push_str(" Z");
    }
    d
}

fn prim_svg(prim: &Prim, h: f64) -> String {
    let n = |x: f64| fmt_num(x, DECIMALS);
    let pt = |p: P2| {
        let q = flip_y(p, h);
        format!("{} {}", n(q[0]), n(q[1]))
    };
    match prim {
        Prim::Polygon(v) => format!("<path d=\"{}\"/>", path_data(v, true, &pt)),
        Prim::Line(a, b) => format!("<path d=\"M{} L{}\"/>", pt(*a), pt(*b)),
        Prim::Circle(c, r) => {
            let q = flip_y(*c, h);
            format!("<circle cx=\"{}\" cy=\"{}\" r=\"{}\"/>", n(q[0]), n(q[1]), n(*r))
        }
        Prim::Text(t) => {
            let c = flip_y(t.position, h);
            // Baseline half a cap height below the centre (y down); rotation about the centre,
            // clockwise in SVG's y-down frame, hence the minus.
            let rot = if t.angle_deg == 0.0 {
                String::new()
            } else {
                format!(" transform=\"rotate({} {} {})\"", n(-t.angle_deg), n(c[0]), n(c[1]))
            };
            format!(
                "<text x=\"{}\" y=\"{}\" font-size=\"{}\" text-anchor=\"middle\" fill=\"#000000\" stroke=\"none\"{rot}>{}</text>",
                n(c[0]),
                n(c[1] + 0.5 * t.height),
                n(t.height / HELVETICA_CAP_HEIGHT),
                xml_escape(&t.text)
            )
        }
    }
}

impl PatternWriter for SvgWriter {
    fn name(&self) -> &'static str {
        "svg"
    }

    fn file_name(&self) -> &'static str {
        "pattern.svg"
    }

    fn write(&self, pattern: &Pattern, out: &mut dyn std::io::Write) -> Result<(), PatternError> {
        out.write_all(self.render(pattern).as_bytes())?;
        Ok(())
    }
}
