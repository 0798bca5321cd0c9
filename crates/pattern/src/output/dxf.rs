//! `pattern.dxf`: the roll layout for CAD and cutting software.
//!
//! AutoCAD R12 DXF (`$ACADVER AC1009`), ASCII, millimetres (`$INSUNITS 4`, `$MEASUREMENT 1`),
//! y up like the [`crate::Pattern`] (no flip). Sections: HEADER; TABLES with LTYPE
//! (CONTINUOUS, DASHED), LAYER and STYLE (STANDARD); ENTITIES. Layers and entities:
//!
//! | layer | colour | entities |
//! |---|---|---|
//! | CUT | 7 | one closed `POLYLINE` (+ `VERTEX`…`SEQEND`) per piece |
//! | SEW | 5, DASHED | one closed `POLYLINE` per piece |
//! | NOTCH | 1 | one `LINE` per notch slit |
//! | GRAIN | 3 | `LINE`s: shaft and the two arrowhead barbs |
//! | TEXT | 7 | `TEXT` (centred: 72 = 1, 73 = 2): piece name, area, seam labels |
//! | MARK | 6 | `CIRCLE`/closed `POLYLINE` symbols, `LINE` crosses, `TEXT` labels |
//!
//! Entities come piece by piece in pattern order, layers in the order above within a piece.
//! Coordinates are written with Rust's shortest round-trip `f64` formatting, so a reader gets
//! the pattern's exact values back.
//!
//! Hand-written rather than the `dxf` crate: R12 with `POLYLINE` is the most widely read
//! flavour (AAMA/ASTM-style cutting software, every CAD program), needs no entity handles or
//! object sections, and fits in this file; the crate always pulls in the `image` crate (~30 s
//! of extra build) and writes `LWPOLYLINE` only at R14+. The crate is still used, as a
//! dev-dependency, to read the file back in the tests.

use std::fmt::Write as _;

use super::{Item, Layer, PatternWriter, Prim, piece_items};
use crate::error::PatternError;
use crate::geom::P2;
use crate::pattern::Pattern;

/// Writes `pattern.dxf` (see the module docs for the structure).
#[derive(Debug, Clone, Copy, Default)]
pub struct DxfWriter;

/// A DXF real: shortest round-trip representation, always with a decimal point.
fn real(x: f64) -> String {
    let x = if x == 0.0 { 0.0 } else { x }; // no "-0"
    let s = format!("{x}");
    if s.contains('.') || s.contains("inf") || s.contains("NaN") { s } else { s + ".0" }
}

/// DXF text: ASCII, other characters as `\U+XXXX`, control characters dropped.
fn dxf_text(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            c if (c as u32) < 0x20 => {}
            c if c.is_ascii() => out.push(c),
            c if (c as u32) <= 0xFFFF => {
                let _ = write!(out, "\\U+{:04X}", c as u32);
            }
            _ => out.push('?'),
        }
    }
    out
}

struct Dxf {
    s: String,
}

impl Dxf {
    fn pair(&mut self, code: i32, value: &str) {
        let _ = write!(self.s, "{code:>3}\r\n{value}\r\n");
    }

    fn point(&mut self, base: i32, p: P2) {
        self.pair(base, &real(p[0]));
        self.pair(base + 10, &real(p[1]));
        self.pair(base + 20, "0.0");
    }

    fn polyline(&mut self, layer: &str, v: &[P2], closed: bool) {
        self.pair(0, "POLYLINE");
        self.pair(8, layer);
        self.pair(66, "1");
        self.point(10, [0.0, 0.0]);
        self.pair(70, if closed { "1" } else { "0" });
        for &p in v {
            self.pair(0, "VERTEX");
            self.pair(8, layer);
            self.point(10, p);
        }
        self.pair(0, "SEQEND");
        self.pair(8, layer);
    }

    fn item(&mut self, it: &Item) {
        let layer = it.layer.dxf_name();
        match &it.prim {
            Prim::Polygon(v) => self.polyline(layer, v, true),
            Prim::Line(a, b) => {
                self.pair(0, "LINE");
                self.pair(8, layer);
                self.point(10, *a);
                self.point(11, *b);
            }
            Prim::Circle(c, r) => {
                self.pair(0, "CIRCLE");
                self.pair(8, layer);
                self.point(10, *c);
                self.pair(40, &real(*r));
            }
            Prim::Text(t) => {
                self.pair(0, "TEXT");
                self.pair(8, layer);
                self.point(10, t.position);
                self.pair(40, &real(t.height));
                self.pair(1, &dxf_text(&t.text));
                self.pair(50, &real(t.angle_deg));
                self.pair(72, "1");
                self.point(11, t.position);
                self.pair(73, "2");
            }
        }
    }
}

fn layer_style(layer: Layer) -> (&'static str, &'static str) {
    match layer {
        Layer::Cut => ("7", "CONTINUOUS"),
        Layer::Sew => ("5", "DASHED"),
        Layer::Notch => ("1", "CONTINUOUS"),
        Layer::Grain => ("3", "CONTINUOUS"),
        Layer::Text => ("7", "CONTINUOUS"),
        Layer::Mark => ("6", "CONTINUOUS"),
    }
}

impl DxfWriter {
    /// The DXF file as a string.
    pub fn render(&self, pattern: &Pattern) -> String {
        let mut d = Dxf { s: String::new() };
        let (len, wid) = (pattern.fabric_length_mm, pattern.fabric_width_mm);
        d.pair(0, "SECTION");
        d.pair(2, "HEADER");
        d.pair(9, "$ACADVER");
        d.pair(1, "AC1009");
        d.pair(9, "$INSBASE");
        d.point(10, [0.0, 0.0]);
        d.pair(9, "$EXTMIN");
        d.point(10, [0.0, 0.0]);
        d.pair(9, "$EXTMAX");
        d.point(10, [len, wid]);
        d.pair(9, "$LIMMIN");
        d.pair(10, "0.0");
        d.pair(20, "0.0");
        d.pair(9, "$LIMMAX");
        d.pair(10, &real(len));
        d.pair(20, &real(wid));
        d.pair(9, "$LUNITS");
        d.pair(70, "2");
        d.pair(9, "$MEASUREMENT");
        d.pair(70, "1");
        d.pair(9, "$DWGCODEPAGE");
        d.pair(3, "ANSI_1252");
        d.pair(9, "$INSUNITS");
        d.pair(70, "4");
        d.pair(0, "ENDSEC");

        d.pair(0, "SECTION");
        d.pair(2, "TABLES");
        d.pair(0, "TABLE");
        d.pair(2, "LTYPE");
        d.pair(70, "2");
        for (name, desc, pattern_len, dashes) in
            [("CONTINUOUS", "Solid line", 0.0, &[][..]), ("DASHED", "Dashed __ __ __", 9.0, &[6.0, -3.0][..])]
        {
            d.pair(0, "LTYPE");
            d.pair(2, name);
            d.pair(70, "0");
            d.pair(3, desc);
            d.pair(72, "65");
            d.pair(73, &dashes.len().to_string());
            d.pair(40, &real(pattern_len));
            for &x in dashes {
                d.pair(49, &real(x));
            }
        }
        d.pair(0, "ENDTAB");
        d.pair(0, "TABLE");
        d.pair(2, "LAYER");
        d.pair(70, &(Layer::ALL.len() + 1).to_string());
        // Layer 0 always exists in CAD programs; some readers expect it in the table.
        d.pair(0, "LAYER");
        d.pair(2, "0");
        d.pair(70, "0");
        d.pair(62, "7");
        d.pair(6, "CONTINUOUS");
        for layer in Layer::ALL {
            let (colour, ltype) = layer_style(layer);
            d.pair(0, "LAYER");
            d.pair(2, layer.dxf_name());
            d.pair(70, "0");
            d.pair(62, colour);
            d.pair(6, ltype);
        }
        d.pair(0, "ENDTAB");
        d.pair(0, "TABLE");
        d.pair(2, "STYLE");
        d.pair(70, "1");
        d.pair(0, "STYLE");
        d.pair(2, "STANDARD");
        d.pair(70, "0");
        d.pair(40, "0.0");
        d.pair(41, "1.0");
        d.pair(50, "0.0");
        d.pair(71, "0");
        d.pair(42, "2.5");
        d.pair(3, "txt");
        d.pair(4, "");
        d.pair(0, "ENDTAB");
        d.pair(0, "ENDSEC");

        d.pair(0, "SECTION");
        d.pair(2, "ENTITIES");
        for piece in &pattern.pieces {
            for it in piece_items(piece, true) {
                d.item(&it);
            }
        }
        d.pair(0, "ENDSEC");
        d.pair(0, "EOF");
        d.s
    }
}

impl PatternWriter for DxfWriter {
    fn name(&self) -> &'static str {
        "dxf"
    }

    fn file_name(&self) -> &'static str {
        "pattern.dxf"
    }

    fn write(&self, pattern: &Pattern, out: &mut dyn std::io::Write) -> Result<(), PatternError> {
        out.write_all(self.render(pattern).as_bytes())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_and_text() {
        assert_eq!(real(1.0), "1.0");
        assert_eq!(real(-0.0), "0.0");
        assert_eq!(real(0.1), "0.1");
        assert_eq!(real(1e-7), "0.0000001");
        assert_eq!(dxf_text("0.123 m²"), "0.123 m\\U+00B2");
    }
}
