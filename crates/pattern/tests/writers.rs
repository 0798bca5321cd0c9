//! The writers: every file parses back, the three formats agree on the coordinates of the
//! pattern, the PDFs have the expected pages and sizes, and output is deterministic.

mod common;

use clothcast_pattern::geom::P2;
use clothcast_pattern::output::pdf::{A4_MM, PT_PER_MM, a4_tile_grid, a4_tiles_used, piece_page_size_mm};
use clothcast_pattern::{
    DxfWriter, Pattern, PatternOptions, PatternWriter, PdfMode, PdfWriter, SvgWriter, all_writers, build_pattern,
};

fn pattern() -> Pattern {
    let mut pieces = common::ring(4);
    pieces.extend(common::two_panels(250.0, 255.0).into_iter().map(|mut p| {
        p.id += 1000;
        p.name = format!("{} & <\"quoted\">", p.name);
        p
    }));
    build_pattern(&pieces, &PatternOptions { fabric_width_mm: 900.0, ..Default::default() }).unwrap()
}

fn bytes(w: &dyn PatternWriter, p: &Pattern) -> Vec<u8> {
    let mut out = Vec::new();
    w.write(p, &mut out).unwrap();
    out
}

fn close(a: &[P2], b: &[P2], tol: f64) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(p, q)| (p[0] - q[0]).abs() <= tol && (p[1] - q[1]).abs() <= tol)
}

/// The cut paths of the SVG, by piece id, y un-flipped.
fn svg_cut_paths(svg: &str, height: f64) -> Vec<(usize, Vec<P2>)> {
    let start = svg.find("<g id=\"cut\"").expect("cut layer");
    let end = start + svg[start..].find("</g>").unwrap();
    let mut out = Vec::new();
    for line in svg[start..end].lines().filter(|l| l.trim_start().starts_with("<path")) {
        let attr = |name: &str| {
            let k = line.find(&format!(" {name}=\"")).unwrap() + name.len() + 3;
            line[k..k + line[k..].find('"').unwrap()].to_string()
        };
        let id: usize = attr("data-piece").parse().unwrap();
        let d = attr("d");
        let nums: Vec<f64> =
            d.split([' ', 'M', 'L', 'Z']).filter(|s| !s.is_empty()).map(|s| s.parse().unwrap()).collect();
        let pts = nums.chunks(2).map(|c| [c[0], height - c[1]]).collect();
        out.push((id, pts));
    }
    out
}

#[test]
fn svg_has_one_cut_and_sew_path_per_piece_at_the_placed_coordinates() {
    let pat = pattern();
    let svg = String::from_utf8(bytes(&SvgWriter, &pat)).unwrap();
    assert!(svg.starts_with("<?xml"));
    // True scale: width/height in mm, the viewBox in the same numbers.
    let attr = |name: &str| -> f64 {
        let k = svg.find(&format!(" {name}=\"")).unwrap() + name.len() + 3;
        svg[k..k + svg[k..].find("mm\"").unwrap()].parse().unwrap()
    };
    assert!((attr("width") - pat.fabric_length_mm).abs() < 1e-3);
    assert!((attr("height") - pat.fabric_width_mm).abs() < 1e-3);
    assert!(svg.contains("viewBox=\"0 0 "));
    let cuts = svg_cut_paths(&svg, pat.fabric_width_mm);
    assert_eq!(cuts.len(), pat.pieces.len());
    for ((id, pts), piece) in cuts.iter().zip(&pat.pieces) {
        assert_eq!(*id, piece.id);
        assert!(close(pts, &piece.placed_cut(), 1e-3), "piece {id}");
    }
    // Every layer is present, once; names are escaped.
    for id in ["cut", "sew", "notches", "grain", "labels", "marks"] {
        assert_eq!(svg.matches(&format!("<g id=\"{id}\"")).count(), 1, "{id}");
    }
    assert!(svg.matches("<g data-piece=").count() >= 2 * pat.pieces.len());
    assert!(svg.contains("P0 &amp; &lt;&quot;quoted&quot;&gt;"));
    assert!(!svg.contains("<\"quoted\">"));
    let notch_paths = {
        let s = svg.find("<g id=\"notches\"").unwrap();
        let e = s + svg[s..].find("</g>\n</g>").unwrap();
        svg[s..e].matches("<path").count()
    };
    assert_eq!(notch_paths, pat.stats.notches);
}

#[test]
fn dxf_reads_back_with_the_dxf_crate() {
    let pat = pattern();
    let data = bytes(&DxfWriter, &pat);
    let text = String::from_utf8(data.clone()).unwrap();
    assert!(text.contains("$INSUNITS\r\n 70\r\n4\r\n"));
    let drawing = dxf::Drawing::load(&mut data.as_slice()).expect("dxf parses");
    let mut layers: Vec<String> = drawing.layers().map(|l| l.name.clone()).collect();
    layers.sort();
    for l in ["CUT", "GRAIN", "MARK", "NOTCH", "SEW", "TEXT"] {
        assert!(layers.iter().any(|x| x == l), "layer {l} missing: {layers:?}");
    }
    let mut polys: std::collections::BTreeMap<String, Vec<Vec<P2>>> = Default::default();
    let (mut notch_lines, mut texts) = (0, 0);
    for e in drawing.entities() {
        match &e.specific {
            dxf::entities::EntityType::Polyline(p) => {
                assert!(p.is_closed());
                let v: Vec<P2> = p.vertices().map(|v| [v.location.x, v.location.y]).collect();
                polys.entry(e.common.layer.clone()).or_default().push(v);
            }
            dxf::entities::EntityType::Line(_) if e.common.layer == "NOTCH" => notch_lines += 1,
            dxf::entities::EntityType::Text(t) if e.common.layer == "TEXT" => {
                assert!(t.text_height > 0.0);
                texts += 1;
            }
            _ => {}
        }
    }
    assert_eq!(notch_lines, pat.stats.notches);
    let seam_sides: usize = pat.pieces.iter().map(|p| p.seam_labels.len()).sum();
    assert_eq!(texts, 2 * pat.pieces.len() + seam_sides);
    let cut = &polys["CUT"];
    let sew = &polys["SEW"];
    assert_eq!(cut.len(), pat.pieces.len());
    assert_eq!(sew.len(), pat.pieces.len());
    for (i, piece) in pat.pieces.iter().enumerate() {
        assert!(close(&cut[i], &piece.placed_cut(), 1e-6), "cut {i}");
        assert!(close(&sew[i], &piece.placed_sew(), 1e-6), "sew {i}");
    }
    // Clamp squares are closed polylines on MARK.
    assert_eq!(polys["MARK"].len(), 4 + 1); // 4 clamp squares, 1 pour triangle
}

#[test]
fn svg_dxf_and_pattern_agree_on_the_first_cut_polygon() {
    let pat = pattern();
    let expect = pat.pieces[0].placed_cut();
    let svg = String::from_utf8(bytes(&SvgWriter, &pat)).unwrap();
    let from_svg = &svg_cut_paths(&svg, pat.fabric_width_mm)[0].1;
    let data = bytes(&DxfWriter, &pat);
    let drawing = dxf::Drawing::load(&mut data.as_slice()).unwrap();
    let from_dxf: Vec<P2> = drawing
        .entities()
        .find_map(|e| match &e.specific {
            dxf::entities::EntityType::Polyline(p) if e.common.layer == "CUT" => {
                Some(p.vertices().map(|v| [v.location.x, v.location.y]).collect())
            }
            _ => None,
        })
        .unwrap();
    assert!(close(from_svg, &expect, 1e-3));
    assert!(close(&from_dxf, &expect, 1e-3));
    assert!(close(from_svg, &from_dxf, 1e-3));
}

/// Page objects (not the page tree) and their MediaBoxes.
fn pdf_pages(pdf: &[u8]) -> Vec<[f64; 4]> {
    let s = String::from_utf8_lossy(pdf);
    assert!(s.starts_with("%PDF-1."));
    assert!(s.trim_end().ends_with("%%EOF"));
    let mut boxes = Vec::new();
    let mut rest = &s[..];
    while let Some(k) = rest.find("/Type /Page") {
        let after = &rest[k + "/Type /Page".len()..];
        if !after.starts_with('s') {
            let mb = after.find("/MediaBox [").expect("page has a MediaBox") + "/MediaBox [".len();
            let nums: Vec<f64> =
                after[mb..mb + after[mb..].find(']').unwrap()].split_whitespace().map(|x| x.parse().unwrap()).collect();
            boxes.push([nums[0], nums[1], nums[2], nums[3]]);
        }
        rest = after;
    }
    boxes
}

#[test]
fn pdf_pieces_one_true_scale_page_per_piece() {
    let pat = pattern();
    let pdf = bytes(&PdfWriter { mode: PdfMode::Pieces }, &pat);
    let pages = pdf_pages(&pdf);
    assert_eq!(pages.len(), pat.pieces.len());
    for (mb, piece) in pages.iter().zip(&pat.pieces) {
        let size = piece_page_size_mm(&piece.cut);
        assert_eq!([mb[0], mb[1]], [0.0, 0.0]);
        assert!((mb[2] - size[0] * 72.0 / 25.4).abs() < 0.01, "{mb:?} {size:?}");
        assert!((mb[3] - size[1] * 72.0 / 25.4).abs() < 0.01);
    }
    let s = String::from_utf8_lossy(&pdf);
    assert!(s.contains("/BaseFont /Helvetica"));
    assert!(!s.contains("/UserUnit"));
}

#[test]
fn pdf_pieces_larger_than_the_pdf_limit_use_user_unit() {
    let long = common::rect_piece(1, 6000.0, 400.0);
    let pat = build_pattern(&[long], &PatternOptions::default()).unwrap();
    let pdf = bytes(&PdfWriter { mode: PdfMode::Pieces }, &pat);
    let s = String::from_utf8_lossy(&pdf);
    assert!(s.contains("/UserUnit 2"), "{}", &s[..s.len().min(600)]);
    let pages = pdf_pages(&pdf);
    let size = piece_page_size_mm(&pat.pieces[0].cut);
    assert!((pages[0][2] * 2.0 - size[0] * PT_PER_MM).abs() < 0.01);
}

#[test]
fn pdf_a4_tiles_cover_the_roll() {
    let pat = pattern();
    let pdf = bytes(&PdfWriter { mode: PdfMode::TiledA4 }, &pat);
    let pages = pdf_pages(&pdf);
    let (rows, cols) = a4_tile_grid(pat.fabric_length_mm, pat.fabric_width_mm);
    let used = a4_tiles_used(&pat);
    assert_eq!(pages.len(), used.len());
    assert!(used.len() <= rows * cols && used.contains(&(rows - 1, cols - 1)), "{used:?}");
    assert!(rows >= 4 && cols >= 2, "{rows} x {cols}");
    for mb in &pages {
        assert!((mb[2] - A4_MM[0] * 72.0 / 25.4).abs() < 0.01 && (mb[3] - A4_MM[1] * 72.0 / 25.4).abs() < 0.01);
    }
    let s = String::from_utf8_lossy(&pdf);
    assert!(s.contains(&format!("(row {rows} / col {cols})")));
    assert!(s.contains("(100 mm)"));
    assert_eq!(s.matches("/Subtype /Form").count(), 1);
}

/// A small piece on a wide roll: only the tile that shows it is printed (the roll's other
/// rows are empty fabric), with its own row and column.
#[test]
fn pdf_a4_tiles_without_a_piece_are_not_printed() {
    let pat = build_pattern(&[common::rect_piece(1, 100.0, 100.0)], &PatternOptions::default()).unwrap();
    let (rows, cols) = a4_tile_grid(pat.fabric_length_mm, pat.fabric_width_mm);
    assert_eq!((rows, cols), (6, 1));
    let used = a4_tiles_used(&pat);
    assert_eq!(used.len(), 1, "{used:?}");
    let pdf = bytes(&PdfWriter { mode: PdfMode::TiledA4 }, &pat);
    assert_eq!(pdf_pages(&pdf).len(), 1);
    let (r, c) = used[0];
    assert!(String::from_utf8_lossy(&pdf).contains(&format!("(row {} / col {})", r + 1, c + 1)));
}

#[test]
fn outputs_are_deterministic() {
    let (a, b) = (pattern(), pattern());
    assert_eq!(a, b);
    let writers = all_writers();
    let names: Vec<&str> = writers.iter().map(|w| w.file_name()).collect();
    assert_eq!(names, ["pattern.svg", "pattern.dxf", "pattern.pdf", "pattern_a4.pdf"]);
    for w in &writers {
        assert_eq!(bytes(w.as_ref(), &a), bytes(w.as_ref(), &b), "{}", w.name());
    }
}

#[test]
fn absurd_layouts_are_errors_not_hangs() {
    let long = common::rect_piece(5, 9e8, 100.0);
    let pat = build_pattern(&[long], &PatternOptions::default()).unwrap();
    let mut sink = Vec::new();
    let e = PdfWriter { mode: PdfMode::Pieces }.write(&pat, &mut sink).unwrap_err();
    assert!(matches!(e, clothcast_pattern::PatternError::PageTooLarge { piece: 5, .. }), "{e}");
    let e = PdfWriter { mode: PdfMode::TiledA4 }.write(&pat, &mut sink).unwrap_err();
    assert!(matches!(e, clothcast_pattern::PatternError::TooManyPages { .. }), "{e}");
}
