//! PDF output with `pdf-writer`: one true-scale page per piece, or the roll tiled on A4.
//!
//! Both modes draw the shared layers (`piece_items`) in millimetres under a
//! `72/25.4` scale (1 mm = 2.8346 pt): cut line solid black 0.35 mm, sew line dashed blue
//! (4 mm / 2 mm), notches red, grain arrow green, texts in the builtin Helvetica (no font
//! file; WinAnsi encoding, characters outside it print as `?`), marks purple.
//!
//! - [`PdfMode::Pieces`] → `pattern.pdf`: page i = piece i (pattern order), unrotated (warp
//!   along +x of the page), MediaBox = cut-line box + [`PIECE_MARGIN_MM`] on each side +
//!   [`PIECE_HEADER_MM`] above for the title and a scale-check bar. PDF viewers limit pages to
//!   14 400 pt (≈ 5.08 m): a larger page gets a `/UserUnit` u = ⌈size / 14 400 pt⌉ (PDF 1.6)
//!   and its MediaBox and content are divided by u, so it still prints at true size in
//!   readers that honour UserUnit (Acrobat, pdf.js, MuPDF); beyond u = 75 000 it is a
//!   [`PatternError::PageTooLarge`].
//! - [`PdfMode::TiledA4`] → `pattern_a4.pdf`: the roll layout (x along the roll) on A4 portrait
//!   pages, each showing a 190 × 277 mm window (10 mm margins) of the roll, neighbouring
//!   windows overlapping by [`TILE_OVERLAP_MM`]: columns step 180 mm along the roll, rows step
//!   267 mm across it, row 1 at the roll's top edge (largest y), column 1 at x = 0; pages go
//!   row by row. The layout is one Form XObject drawn clipped on every page. Each page has the
//!   window frame, corner crop marks, the overlap bands' edges dashed, the label
//!   "row r / col c" and a 100 mm scale-check bar in the bottom margin.
//!
//! Deterministic: no dates, no file ids, fixed object numbering (catalog 1, page tree 2,
//! font 3, layout form 4, then page/content pairs).

use pdf_writer::{Content, Finish, Name, Pdf, Rect, Ref, Str};

use super::{HELVETICA_CAP_HEIGHT, Item, Layer, PatternWriter, Prim, helvetica_width, piece_items};
use crate::error::PatternError;
use crate::geom::{BBox, P2};
use crate::labels::LabelBox;
use crate::pattern::{Pattern, Text};

/// Points per millimetre.
pub const PT_PER_MM: f64 = 72.0 / 25.4;
/// Margin around a piece on its page (mm).
pub const PIECE_MARGIN_MM: f64 = 10.0;
/// Extra space above a piece for its title and scale bar (mm).
pub const PIECE_HEADER_MM: f64 = 20.0;
/// The largest page side PDF readers accept (pt), before UserUnit.
pub const PDF_MAX_PAGE_PT: f64 = 14_400.0;
/// A4 portrait (mm).
pub const A4_MM: [f64; 2] = [210.0, 297.0];
/// Margin of an A4 tile (mm).
pub const TILE_MARGIN_MM: f64 = 10.0;
/// Overlap of neighbouring tiles (mm).
pub const TILE_OVERLAP_MM: f64 = 10.0;

/// Most pages of an A4 tiling (a 100 m roll 1.5 m wide needs ~3300).
pub const MAX_TILES: usize = 20_000;

/// Which PDF to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PdfMode {
    /// One true-scale page per piece → `pattern.pdf`.
    Pieces,
    /// The roll layout tiled on A4 portrait pages → `pattern_a4.pdf`.
    TiledA4,
}

/// Writes a PDF in the given mode (see the module docs).
#[derive(Debug, Clone, Copy)]
pub struct PdfWriter {
    /// Per-piece pages or A4 tiles.
    pub mode: PdfMode,
}

/// Rows and columns of the A4 tiling of a roll layout `length × width` mm.
pub fn a4_tile_grid(length_mm: f64, width_mm: f64) -> (usize, usize) {
    let (win, _) = tile_window_and_step();
    let count = |extent: f64, w: f64| {
        // `as usize` saturates: absurd layouts give huge counts, never a panic.
        if extent <= w { 1 } else { 1 + ((extent - w) / (w - TILE_OVERLAP_MM) - 1e-9).ceil() as usize }
    };
    (count(width_mm, win[1]), count(length_mm, win[0]))
}

/// The tiles of the A4 tiling (row, column; row 0 at the roll's top edge) that show some
/// piece: those whose window meets a piece's cut line or lies inside one. The others show only
/// empty roll and are not printed.
pub fn a4_tiles_used(pattern: &Pattern) -> Vec<(usize, usize)> {
    let (len, wid) = (pattern.fabric_length_mm, pattern.fabric_width_mm);
    let (rows, cols) = a4_tile_grid(len, wid);
    if rows.saturating_mul(cols) > MAX_TILES {
        return Vec::new(); // refused by the writer (PatternError::TooManyPages)
    }
    let (win, _) = tile_window_and_step();
    let cuts: Vec<(Vec<P2>, BBox)> = pattern
        .pieces
        .iter()
        .map(|p| {
            let c = p.placed_cut();
            let b = BBox::of(&c);
            (c, b)
        })
        .collect();
    let mut used = Vec::new();
    for r in 0..rows {
        for col in 0..cols {
            let lo = tile_origin(r, col, wid);
            let window = BBox { min: lo, max: [lo[0] + win[0], lo[1] + win[1]] };
            let frame = LabelBox::rect([lo[0] + 0.5 * win[0], lo[1] + 0.5 * win[1]], [0.5 * win[0], 0.5 * win[1]]);
            if cuts.iter().any(|(c, b)| b.intersects(&window) && !frame.outside(c)) {
                used.push((r, col));
            }
        }
    }
    used
}

/// An A4 tile's window on the roll (mm) and the step between neighbouring windows.
fn tile_window_and_step() -> ([f64; 2], [f64; 2]) {
    let win = [A4_MM[0] - 2.0 * TILE_MARGIN_MM, A4_MM[1] - 2.0 * TILE_MARGIN_MM];
    (win, [win[0] - TILE_OVERLAP_MM, win[1] - TILE_OVERLAP_MM])
}

/// The roll coordinates of the lower-left corner of the window of tile (`row`, `col`), on a
/// roll `width` mm wide (row 0 at its top edge).
fn tile_origin(row: usize, col: usize, width: f64) -> P2 {
    let (win, step) = tile_window_and_step();
    [col as f64 * step[0], width - row as f64 * step[1] - win[1]]
}

/// Page size (mm) of a piece in [`PdfMode::Pieces`].
pub fn piece_page_size_mm(cut: &[P2]) -> [f64; 2] {
    let b = BBox::of(cut);
    [b.width() + 2.0 * PIECE_MARGIN_MM, b.height() + 2.0 * PIECE_MARGIN_MM + PIECE_HEADER_MM]
}

const FONT: Name<'static> = Name(b"F1");
const LAYOUT: Name<'static> = Name(b"L1");

fn f(x: f64) -> f32 {
    x as f32
}

/// WinAnsi bytes of a string (Latin-1 range kept, others → '?').
fn win_ansi(s: &str) -> Vec<u8> {
    s.chars()
        .map(|c| match c as u32 {
            k @ 0x20..=0x7E | k @ 0xA0..=0xFF => k as u8,
            _ => b'?',
        })
        .collect()
}

fn set_style(c: &mut Content, layer: Layer) {
    let (rgb, width, dashed) = match layer {
        Layer::Cut => ([0.0, 0.0, 0.0], 0.35, false),
        Layer::Sew => ([0.12, 0.37, 0.75], 0.25, true),
        Layer::Notch => ([0.75, 0.0, 0.0], 0.35, false),
        Layer::Grain => ([0.13, 0.44, 0.13], 0.35, false),
        Layer::Text => ([0.0, 0.0, 0.0], 0.25, false),
        Layer::Mark => ([0.5, 0.0, 0.63], 0.3, false),
    };
    c.set_stroke_rgb(rgb[0], rgb[1], rgb[2]);
    c.set_line_width(width);
    if dashed {
        c.set_dash_pattern([4.0, 2.0], 0.0);
    } else {
        c.set_dash_pattern([], 0.0);
    }
}

/// Centred text of cap height `t.height`, in the current (mm) user space.
fn text(c: &mut Content, t: &Text) {
    let size = t.height / HELVETICA_CAP_HEIGHT;
    let (s, co) = t.angle_deg.to_radians().sin_cos();
    let w = helvetica_width(&t.text) * size;
    c.set_fill_rgb(0.0, 0.0, 0.0);
    c.begin_text();
    c.set_font(FONT, f(size));
    c.set_text_matrix([f(co), f(s), f(-s), f(co), f(t.position[0]), f(t.position[1])]);
    c.next_line(f(-0.5 * w), f(-0.5 * t.height));
    c.show(Str(&win_ansi(&t.text)));
    c.end_text();
}

fn circle(c: &mut Content, ctr: P2, r: f64) {
    const K: f64 = 0.552_284_749_8;
    let (x, y) = (ctr[0], ctr[1]);
    c.move_to(f(x + r), f(y));
    c.cubic_to(f(x + r), f(y + K * r), f(x + K * r), f(y + r), f(x), f(y + r));
    c.cubic_to(f(x - K * r), f(y + r), f(x - r), f(y + K * r), f(x - r), f(y));
    c.cubic_to(f(x - r), f(y - K * r), f(x - K * r), f(y - r), f(x), f(y - r));
    c.cubic_to(f(x + K * r), f(y - r), f(x + r), f(y - K * r), f(x + r), f(y));
    c.close_path();
    c.stroke();
}

fn polyline(c: &mut Content, v: &[P2], closed: bool) {
    for (i, p) in v.iter().enumerate() {
        if i == 0 {
            c.move_to(f(p[0]), f(p[1]));
        } else {
            c.line_to(f(p[0]), f(p[1]));
        }
    }
    if closed {
        c.close_path();
    }
    c.stroke();
}

/// Draws items (mm user space), switching style at each layer change.
fn draw_items(c: &mut Content, items: &[Item]) {
    let mut current: Option<Layer> = None;
    for it in items {
        if current != Some(it.layer) {
            set_style(c, it.layer);
            current = Some(it.layer);
        }
        match &it.prim {
            Prim::Polygon(v) => polyline(c, v, true),
            Prim::Line(a, b) => polyline(c, &[*a, *b], false),
            Prim::Circle(ctr, r) => circle(c, *ctr, *r),
            Prim::Text(t) => text(c, t),
        }
    }
}

/// A scale-check bar of `len` mm at `origin` (mm), with 10 mm ticks and its label.
fn scale_bar(c: &mut Content, origin: P2, len: f64) {
    set_style(c, Layer::Cut);
    c.set_line_width(0.3);
    let [x, y] = origin;
    polyline(c, &[[x, y], [x + len, y]], false);
    let ticks = (len / 10.0).round() as usize;
    for k in 0..=ticks {
        let h = if k == 0 || k == ticks { 3.0 } else { 1.5 };
        let xi = x + len * k as f64 / ticks.max(1) as f64;
        polyline(c, &[[xi, y], [xi, y + h]], false);
    }
    let label = format!("{} mm", super::fmt_num(len, 0));
    let w = helvetica_width(&label) * 2.5 / HELVETICA_CAP_HEIGHT;
    text(c, &Text { text: label, position: [x + len + 3.0 + 0.5 * w, y + 1.25], height: 2.5, angle_deg: 0.0 });
}

fn write_font(pdf: &mut Pdf, id: Ref) {
    pdf.type1_font(id).base_font(Name(b"Helvetica")).encoding_predefined(Name(b"WinAnsiEncoding"));
}

fn finish_pages(pdf: &mut Pdf, catalog: Ref, tree: Ref, kids: &[Ref]) {
    pdf.catalog(catalog).pages(tree);
    pdf.pages(tree).kids(kids.iter().copied()).count(kids.len() as i32);
}

impl PdfWriter {
    /// The PDF file's bytes.
    pub fn render(&self, pattern: &Pattern) -> Result<Vec<u8>, PatternError> {
        match self.mode {
            PdfMode::Pieces => render_pieces(pattern),
            PdfMode::TiledA4 => render_tiles(pattern),
        }
    }
}

fn render_pieces(pattern: &Pattern) -> Result<Vec<u8>, PatternError> {
    let (catalog, tree, font) = (Ref::new(1), Ref::new(2), Ref::new(3));
    let mut pdf = Pdf::new();
    write_font(&mut pdf, font);
    let mut kids = Vec::with_capacity(pattern.pieces.len());
    for (i, piece) in pattern.pieces.iter().enumerate() {
        let (page_id, content_id) = (Ref::new(5 + 2 * i as i32), Ref::new(6 + 2 * i as i32));
        let size = piece_page_size_mm(&piece.cut);
        let size_pt = [size[0] * PT_PER_MM, size[1] * PT_PER_MM];
        let longest = size_pt[0].max(size_pt[1]);
        let unit = if longest > PDF_MAX_PAGE_PT { (longest / PDF_MAX_PAGE_PT).ceil() } else { 1.0 };
        if unit > 75_000.0 {
            return Err(PatternError::PageTooLarge { piece: piece.id, width_mm: size[0], height_mm: size[1] });
        }
        let b = BBox::of(&piece.cut);
        let k = PT_PER_MM / unit;
        let mut c = Content::new();
        c.save_state();
        // mm → page units, piece box lower-left at the margin.
        c.transform([f(k), 0.0, 0.0, f(k), f(k * (PIECE_MARGIN_MM - b.min[0])), f(k * (PIECE_MARGIN_MM - b.min[1]))]);
        draw_items(&mut c, &piece_items(piece, false));
        c.restore_state();
        // Header: title and scale bar, in page mm.
        c.save_state();
        c.transform([f(k), 0.0, 0.0, f(k), 0.0, 0.0]);
        let top = size[1];
        let title = format!(
            "{} (piece {}): cut {} x {} mm, 1:1, warp along the arrow",
            piece.name,
            piece.id,
            super::fmt_num(b.width(), 0),
            super::fmt_num(b.height(), 0)
        );
        let tw = helvetica_width(&title) * 3.0 / HELVETICA_CAP_HEIGHT;
        text(
            &mut c,
            &Text { text: title, position: [PIECE_MARGIN_MM + 0.5 * tw, top - 6.0], height: 3.0, angle_deg: 0.0 },
        );
        let bar = [100.0, 50.0, 20.0, 10.0].into_iter().find(|&l| l <= size[0] - 2.0 * PIECE_MARGIN_MM - 15.0);
        if let Some(len) = bar {
            scale_bar(&mut c, [PIECE_MARGIN_MM, top - 15.0], len);
        }
        c.restore_state();
        let data = c.finish();
        pdf.stream(content_id, &data);
        let mut page = pdf.page(page_id);
        page.parent(tree)
            .media_box(Rect::new(0.0, 0.0, f(size_pt[0] / unit), f(size_pt[1] / unit)))
            .contents(content_id);
        if unit > 1.0 {
            page.user_unit(f(unit));
        }
        page.resources().fonts().pair(FONT, font);
        page.finish();
        kids.push(page_id);
    }
    finish_pages(&mut pdf, catalog, tree, &kids);
    Ok(pdf.finish())
}

fn render_tiles(pattern: &Pattern) -> Result<Vec<u8>, PatternError> {
    let (catalog, tree, font, form) = (Ref::new(1), Ref::new(2), Ref::new(3), Ref::new(4));
    let (len, wid) = (pattern.fabric_length_mm, pattern.fabric_width_mm);
    let (rows, cols) = a4_tile_grid(len, wid);
    if rows.saturating_mul(cols) > MAX_TILES {
        return Err(PatternError::TooManyPages {
            length_mm: len,
            width_mm: wid,
            pages: rows.saturating_mul(cols),
            limit: MAX_TILES,
        });
    }
    let mut pdf = Pdf::new();
    write_font(&mut pdf, font);

    // The whole layout once, in roll mm, as a Form XObject.
    let mut c = Content::new();
    c.set_stroke_rgb(0.7, 0.7, 0.7);
    c.set_line_width(0.3);
    c.rect(0.0, 0.0, f(len), f(wid));
    c.stroke();
    for piece in &pattern.pieces {
        draw_items(&mut c, &piece_items(piece, true));
    }
    let data = c.finish();
    let mut xo = pdf.form_xobject(form, &data);
    xo.bbox(Rect::new(-100.0, -100.0, f(len + 100.0), f(wid + 100.0)));
    xo.resources().fonts().pair(FONT, font);
    xo.finish();

    let m = TILE_MARGIN_MM;
    let (win, _) = tile_window_and_step();
    let k = PT_PER_MM;
    // Only the tiles that show a piece are printed; each keeps its row and column label.
    let used = a4_tiles_used(pattern);
    let mut kids = Vec::with_capacity(used.len());
    for (i, &(r, col)) in used.iter().enumerate() {
        let (page_id, content_id) = (Ref::new(5 + 2 * i as i32), Ref::new(6 + 2 * i as i32));
        let origin = tile_origin(r, col, wid);
        let mut c = Content::new();
        c.save_state();
        c.rect(f(k * m), f(k * m), f(k * win[0]), f(k * win[1]));
        c.clip_nonzero();
        c.end_path();
        c.transform([f(k), 0.0, 0.0, f(k), f(k * (m - origin[0])), f(k * (m - origin[1]))]);
        c.x_object(LAYOUT);
        c.restore_state();

        // Page furniture, in page mm.
        c.save_state();
        c.transform([f(k), 0.0, 0.0, f(k), 0.0, 0.0]);
        c.set_stroke_rgb(0.0, 0.0, 0.0);
        c.set_line_width(0.2);
        c.rect(f(m), f(m), f(win[0]), f(win[1]));
        c.stroke();
        let (x0, y0, x1, y1) = (m, m, A4_MM[0] - m, A4_MM[1] - m);
        for (cx, cy, sx, sy) in [(x0, y0, -1.0, -1.0), (x1, y0, 1.0, -1.0), (x0, y1, -1.0, 1.0), (x1, y1, 1.0, 1.0)] {
            polyline(&mut c, &[[cx, cy + sy * 2.0], [cx, cy + sy * 8.0]], false);
            polyline(&mut c, &[[cx + sx * 2.0, cy], [cx + sx * 8.0, cy]], false);
        }
        c.set_dash_pattern([2.0, 2.0], 0.0);
        let o = TILE_OVERLAP_MM;
        if col > 0 {
            polyline(&mut c, &[[x0 + o, y0], [x0 + o, y1]], false);
        }
        if col + 1 < cols {
            polyline(&mut c, &[[x1 - o, y0], [x1 - o, y1]], false);
        }
        if r > 0 {
            polyline(&mut c, &[[x0, y1 - o], [x1, y1 - o]], false);
        }
        if r + 1 < rows {
            polyline(&mut c, &[[x0, y0 + o], [x1, y0 + o]], false);
        }
        c.set_dash_pattern([], 0.0);
        scale_bar(&mut c, [m, 4.0], 100.0);
        let label = format!("row {} / col {}", r + 1, col + 1);
        let w = helvetica_width(&label) * 3.0 / HELVETICA_CAP_HEIGHT;
        text(&mut c, &Text { text: label, position: [x1 - 0.5 * w, 4.0], height: 3.0, angle_deg: 0.0 });
        let info = format!(
            "clothcast pattern, A4 tile {} of {} ({} of the {rows} x {cols} grid show no piece), overlap {} mm",
            i + 1,
            used.len(),
            rows * cols - used.len(),
            o
        );
        let w = helvetica_width(&info) * 2.5 / HELVETICA_CAP_HEIGHT;
        text(&mut c, &Text { text: info, position: [x0 + 0.5 * w, y1 + 4.0], height: 2.5, angle_deg: 0.0 });
        c.restore_state();
        let data = c.finish();
        pdf.stream(content_id, &data);
        let mut page = pdf.page(page_id);
        page.parent(tree).media_box(Rect::new(0.0, 0.0, f(A4_MM[0] * k), f(A4_MM[1] * k))).contents(content_id);
        let mut res = page.resources();
        res.fonts().pair(FONT, font);
        res.x_objects().pair(LAYOUT, form);
        res.finish();
        page.finish();
        kids.push(page_id);
    }
    finish_pages(&mut pdf, catalog, tree, &kids);
    Ok(pdf.finish())
}

impl PatternWriter for PdfWriter {
    fn name(&self) -> &'static str {
        match self.mode {
            PdfMode::Pieces => "pdf",
            PdfMode::TiledA4 => "pdf-a4",
        }
    }

    fn file_name(&self) -> &'static str {
        match self.mode {
            PdfMode::Pieces => "pattern.pdf",
            PdfMode::TiledA4 => "pattern_a4.pdf",
        }
    }

    fn write(&self, pattern: &Pattern, out: &mut dyn std::io::Write) -> Result<(), PatternError> {
        out.write_all(&self.render(pattern)?)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_grid() {
        assert_eq!(a4_tile_grid(190.0, 277.0), (1, 1));
        assert_eq!(a4_tile_grid(370.0, 277.0), (1, 2));
        assert_eq!(a4_tile_grid(371.0, 544.0), (2, 3));
        assert_eq!(a4_tile_grid(100.0, 545.0), (3, 1));
    }
}
