//! The pattern: notches pair up, nesting stays on the roll without overlaps and keeps the
//! grain, every typed validation error is reached, statistics add up.

mod common;

use clothcast_pattern::geom::{BBox, P2, dist, dist_point_boundary, point_in_polygon, segments_intersect};
use clothcast_pattern::{
    MarkKind, PatternError, PatternOptions, PieceInput, PointMark, build_pattern, seam_length_mismatch,
};
use common::{check_offset, ring, side, star, two_panels};

#[test]
fn notches_pair_up_by_normalised_arc_length() {
    // Sides of 250 and 262 mm: mean 256 → 2 interior notches (100, 200) plus both ends.
    let pieces = two_panels(250.0, 262.0);
    let opts = PatternOptions::default();
    let pat = build_pattern(&pieces, &opts).unwrap();
    let (a, b) = (&pat.pieces[0], &pat.pieces[1]);
    assert_eq!(a.notches.len(), 4);
    assert_eq!(b.notches.len(), 4);
    let mean = 256.0;
    for (k, (na, nb)) in a.notches.iter().zip(&b.notches).enumerate() {
        assert_eq!(na.index, k);
        assert_eq!(nb.index, k);
        assert_eq!(na.t, nb.t);
        // Seam direction: upwards on both pieces (piece 1 walks its left side backwards).
        let expect_t = [0.0, 100.0 / mean, 200.0 / mean, 1.0][k];
        assert!((na.t - expect_t).abs() < 1e-12);
        assert!(dist(na.position, [300.0, expect_t * 250.0]) < 1e-9, "{:?}", na.position);
        assert!(dist(nb.position, [0.0, expect_t * 262.0]) < 1e-9, "{:?}", nb.position);
        assert_eq!(na.normal, [1.0, 0.0]);
        assert_eq!(nb.normal, [-1.0, 0.0]);
        // The slit starts on the cut line and points inwards, notch_length long.
        assert!((na.tick[0][0] - 315.0).abs() < 1e-9 && (na.tick[1][0] - 309.0).abs() < 1e-9, "{:?}", na.tick);
        assert!((nb.tick[0][0] + 15.0).abs() < 1e-9 && (nb.tick[1][0] + 9.0).abs() < 1e-9, "{:?}", nb.tick);
    }
    let mismatch = seam_length_mismatch(&pieces);
    assert!((mismatch - 12.0 / 256.0).abs() < 1e-12);
    assert_eq!(pat.stats.seam_length_mismatch_max_rel, mismatch);
    assert_eq!(pat.stats.notches, 8);
    assert_eq!(pat.stats.seams, 1);
    // Seam labels: one per side, inside the piece.
    assert_eq!(a.seam_labels.len(), 1);
    assert_eq!(a.seam_labels[0].text, "S7");
    assert!(point_in_polygon(a.seam_labels[0].position, &a.sew));
    assert!(point_in_polygon(b.seam_labels[0].position, &b.sew));
}

#[test]
fn notch_count_is_shared_and_exact_multiples_do_not_double_the_end() {
    // 300.25 mm: no notch at 300, a quarter millimetre before the end's (a double mark).
    for (h0, h1, interior) in
        [(200.0, 200.0, 1), (199.0, 201.0, 1), (99.0, 99.0, 0), (300.0, 300.5, 2), (315.0, 315.0, 3)]
    {
        let pat = build_pattern(&two_panels(h0, h1), &PatternOptions::default()).unwrap();
        assert_eq!(pat.pieces[0].notches.len(), interior + 2, "{h0} {h1}");
        assert_eq!(pat.pieces[1].notches.len(), interior + 2, "{h0} {h1}");
    }
}

#[test]
fn self_seam_and_ring_pattern() {
    let pieces = ring(5);
    let pat = build_pattern(&pieces, &PatternOptions::default()).unwrap();
    assert_eq!(pat.stats.pieces, 6);
    assert_eq!(pat.stats.seams, 6);
    // The L piece's self seam: both sides on the same piece, 120 mm → 1 interior notch.
    let l = pat.pieces.iter().find(|p| p.name == "L").unwrap();
    assert_eq!(l.notches.len(), 6);
    assert_eq!(l.seam_labels.len(), 2);
    // Each seam's two sides have the same notch parameters.
    let mut by_seam: std::collections::BTreeMap<usize, Vec<Vec<f64>>> = Default::default();
    for p in &pat.pieces {
        for s in p.notches.iter().map(|n| n.seam).collect::<std::collections::BTreeSet<_>>() {
            by_seam.entry(s).or_default();
        }
    }
    for p in &pat.pieces {
        let mut groups: std::collections::BTreeMap<usize, Vec<f64>> = Default::default();
        for n in &p.notches {
            groups.entry(n.seam).or_default().push(n.t);
        }
        for (s, ts) in groups {
            // A self seam contributes its two sides one after the other.
            let half = if p.name == "L" { ts.len() / 2 } else { ts.len() };
            by_seam.get_mut(&s).unwrap().push(ts[..half].to_vec());
            if half < ts.len() {
                by_seam.get_mut(&s).unwrap().push(ts[half..].to_vec());
            }
        }
    }
    for (s, sides) in by_seam {
        assert_eq!(sides.len(), 2, "seam {s}");
        assert_eq!(sides[0], sides[1], "seam {s}");
    }
    // Every piece: cut line valid, labels and grain inside the piece.
    for p in &pat.pieces {
        check_offset(&p.sew, &p.cut, 15.0).unwrap();
        for t in p.labels.iter().chain(&p.seam_labels) {
            assert!(point_in_polygon(t.position, &p.sew), "{} {:?}", p.name, t);
        }
        assert!(point_in_polygon(p.grain.start, &p.sew) && point_in_polygon(p.grain.end, &p.sew));
        assert!(p.grain.end[0] > p.grain.start[0] && p.grain.end[1] == p.grain.start[1]);
        assert!(p.labels[1].text.ends_with(" m²"));
    }
    let area: f64 = pat.pieces.iter().map(|p| p.sew_area_mm2).sum();
    assert!((pat.stats.area_mm2_total - area).abs() < 1e-6);
    let json = serde_json::to_value(&pat.stats).unwrap();
    assert_eq!(json["pieces"], 6);
    assert!(json["seam_length_mismatch_max_rel"].as_f64().unwrap() > 0.0);
}

/// Cut polygons on the roll, pairwise: no crossing, no containment, at least the gap
/// apart; all within the roll.
fn assert_nested(pat: &clothcast_pattern::Pattern, gap: f64) {
    let placed: Vec<Vec<P2>> = pat.pieces.iter().map(|p| p.placed_cut()).collect();
    let boxes: Vec<BBox> = placed.iter().map(|c| BBox::of(c)).collect();
    for (i, b) in boxes.iter().enumerate() {
        assert!(b.min[1] >= -1e-9 && b.max[1] <= pat.fabric_width_mm + 1e-9, "piece {i} off the roll: {b:?}");
        assert!(b.min[0] >= -1e-9 && b.max[0] <= pat.fabric_length_mm + 1e-9, "piece {i} beyond the length");
        for j in i + 1..boxes.len() {
            let (p, q) = (&placed[i], &placed[j]);
            assert!(!point_in_polygon(q[0], p) && !point_in_polygon(p[0], q), "pieces {i} and {j} nested");
            if gap == 0.0 {
                // May touch: check interiors through the vertices only.
                assert!(q.iter().all(|&v| !point_in_polygon(v, p) || dist_point_boundary(v, p) < 1e-9));
                continue;
            }
            for a in 0..p.len() {
                for k in 0..q.len() {
                    assert!(!segments_intersect(p[a], p[(a + 1) % p.len()], q[k], q[(k + 1) % q.len()]));
                }
            }
            // Between disjoint polygons the distance is attained at a vertex of one of them.
            let d = p
                .iter()
                .map(|&v| dist_point_boundary(v, q))
                .chain(q.iter().map(|&v| dist_point_boundary(v, p)))
                .fold(f64::INFINITY, f64::min);
            assert!(d >= gap * (1.0 - 1e-9), "pieces {i} and {j} only {d} mm apart");
        }
    }
    let cut: f64 = pat.pieces.iter().map(|p| p.cut_area_mm2).sum();
    assert!((pat.utilisation - cut / (pat.fabric_width_mm * pat.fabric_length_mm)).abs() < 1e-12);
    assert!(pat.utilisation > 0.0 && pat.utilisation <= 1.0);
}

fn many_stars(n: usize) -> Vec<PieceInput> {
    (0..n)
        .map(|i| {
            let k = 5 + i % 7;
            let angles: Vec<f64> = (0..k).map(|j| j as f64 / k as f64 * std::f64::consts::TAU).collect();
            let radii: Vec<f64> = (0..k)
                .map(|j| 60.0 + ((i * 37 + j * 71) % 230) as f64 * (if j % 2 == 0 { 1.0 } else { 0.4 }))
                .collect();
            PieceInput {
                id: i,
                name: format!("S{i}"),
                outline: star([0.0, 0.0], &angles, &radii),
                seams: vec![],
                marks: vec![],
            }
        })
        .collect()
}

#[test]
fn nesting_keeps_pieces_apart_on_the_roll_and_respects_the_grain() {
    let pieces = many_stars(40);
    for swap in [false, true] {
        let opts = PatternOptions { fabric_width_mm: 1200.0, allow_weft_swap: swap, ..Default::default() };
        let pat = build_pattern(&pieces, &opts).unwrap();
        assert_nested(&pat, opts.piece_gap_mm);
        for p in &pat.pieces {
            let r = p.placement.rotation_deg;
            assert!(if swap { [0, 90, 180, 270].contains(&r) } else { [0, 180].contains(&r) }, "{r}");
        }
        println!("swap {swap}: length {:.0} mm, utilisation {:.3}", pat.fabric_length_mm, pat.utilisation);
    }
}

#[test]
fn weft_swap_turns_a_piece_too_tall_for_the_roll() {
    let tall = common::rect_piece(3, 300.0, 1600.0);
    let opts = PatternOptions::default();
    match build_pattern(std::slice::from_ref(&tall), &opts) {
        Err(PatternError::PieceTooWide { piece: 3, height_mm, weft_swap: false, .. }) => {
            assert!((height_mm - 1630.0).abs() < 1e-9)
        }
        other => panic!("{other:?}"),
    }
    let opts = PatternOptions { allow_weft_swap: true, ..Default::default() };
    let pat = build_pattern(&[tall], &opts).unwrap();
    assert_eq!(pat.pieces[0].placement.rotation_deg, 90);
    assert!((pat.fabric_length_mm - 1630.0).abs() < 1e-9);
    assert_nested(&pat, 10.0);
    // The placed coordinates are the rotation then the offset.
    let p = &pat.pieces[0];
    assert_eq!(p.to_roll([0.0, 0.0]), p.placement.offset);
    assert_eq!(p.to_roll([1.0, 0.0]), [p.placement.offset[0], p.placement.offset[1] + 1.0]);
    let wide = common::rect_piece(4, 1600.0, 1600.0);
    assert!(matches!(build_pattern(&[wide], &opts), Err(PatternError::PieceTooWide { piece: 4, weft_swap: true, .. })));
    // Every piece too wide is listed, the first in the error first, with its width over the roll's.
    let opts = PatternOptions::default();
    let pieces = [
        common::rect_piece(5, 300.0, 1600.0),
        common::rect_piece(6, 300.0, 300.0),
        common::rect_piece(7, 300.0, 2000.0),
    ];
    match build_pattern(&pieces, &opts) {
        Err(PatternError::PieceTooWide { piece: 5, too_wide, .. }) => {
            assert_eq!(too_wide.iter().map(|t| t.0).collect::<Vec<_>>(), [5, 7]);
            assert!(
                (too_wide[0].1 - 1630.0 / 1500.0).abs() < 1e-9 && (too_wide[1].1 - 2030.0 / 1500.0).abs() < 1e-9,
                "{too_wide:?}"
            );
        }
        other => panic!("{other:?}"),
    }
}

fn sq(id: usize) -> PieceInput {
    common::rect_piece(id, 100.0, 100.0)
}

#[test]
fn every_validation_error_is_reached() {
    let o = PatternOptions::default();
    let err = |pieces: &[PieceInput], o: &PatternOptions| build_pattern(pieces, o).unwrap_err();
    assert!(matches!(err(&[], &o), PatternError::NoPieces));
    assert!(matches!(err(&[sq(1), sq(1)], &o), PatternError::DuplicatePieceId { piece: 1 }));
    let mut p = sq(2);
    p.outline[2][1] = f64::NAN;
    assert!(matches!(err(&[p], &o), PatternError::NonFiniteCoordinate { piece: 2, vertex: 2, .. }));
    let mut p = sq(2);
    p.outline[1][0] = 1e12;
    assert!(matches!(err(&[p], &o), PatternError::CoordinateOutOfRange { piece: 2, vertex: 1, .. }));
    let mut p = sq(2);
    p.marks.push(PointMark { kind: MarkKind::Pour, position: [f64::INFINITY, 0.0], label: String::new() });
    assert!(matches!(err(&[p], &o), PatternError::NonFiniteMark { piece: 2, mark: 0, .. }));
    let mut p = sq(3);
    p.outline.truncate(2);
    assert!(matches!(err(&[p], &o), PatternError::TooFewPoints { piece: 3, points: 2 }));
    let mut p = sq(3);
    p.outline.push([0.0, 0.0]);
    assert!(matches!(err(&[p], &o), PatternError::RepeatedPoint { piece: 3, vertex: 4, next: 0 }));
    let mut p = sq(4);
    p.outline.reverse();
    assert!(matches!(err(&[p], &o), PatternError::Clockwise { piece: 4, .. }));
    let mut p = sq(5);
    p.outline = vec![[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [50.0, -20.0], [0.0, 100.0]];
    assert!(matches!(err(&[p], &o), PatternError::SelfIntersecting { piece: 5, .. }));
    let mut p = sq(6);
    p.seams = vec![side(1, 0, 4, true)];
    assert!(matches!(err(&[p], &o), PatternError::SeamIndexOutOfRange { piece: 6, seam: 1, index: 4, points: 4 }));
    // A side from index 2 back to it is round the whole outline: another side overlaps it.
    let mut p = sq(6);
    p.seams = vec![side(1, 2, 2, true), side(2, 0, 1, true)];
    assert!(matches!(err(&[p], &o), PatternError::OverlappingSeamSides { piece: 6, seam_a: 1, seam_b: 2, edge: 0 }));
    let mut p = sq(6);
    p.seams = vec![side(1, 0, 2, true), side(2, 1, 3, true)];
    assert!(matches!(err(&[p], &o), PatternError::OverlappingSeamSides { piece: 6, seam_a: 1, seam_b: 2, edge: 1 }));
    let mut p = sq(7);
    p.seams = vec![side(9, 0, 1, true)];
    assert!(matches!(err(&[p], &o), PatternError::SeamOneSide { seam: 9, piece: 7 }));
    let (mut a, mut b) = (sq(7), sq(8));
    a.seams = vec![side(9, 0, 1, true), side(9, 2, 3, true)];
    b.seams = vec![side(9, 0, 1, true)];
    assert!(matches!(err(&[a, b], &o), PatternError::SeamTooManySides { seam: 9, sides: 3 }));
    for (opts, name) in [
        (PatternOptions { seam_allowance_mm: -1.0, ..Default::default() }, "seam_allowance_mm"),
        (PatternOptions { seam_allowance_mm: f64::NAN, ..Default::default() }, "seam_allowance_mm"),
        (PatternOptions { notch_spacing_mm: 0.0, ..Default::default() }, "notch_spacing_mm"),
        (PatternOptions { notch_length_mm: -1.0, ..Default::default() }, "notch_length_mm"),
        (PatternOptions { fabric_width_mm: 0.0, ..Default::default() }, "fabric_width_mm"),
        (PatternOptions { fabric_width_mm: f64::INFINITY, ..Default::default() }, "fabric_width_mm"),
        (PatternOptions { piece_gap_mm: -0.5, ..Default::default() }, "piece_gap_mm"),
        (PatternOptions { text_height_mm: 0.0, ..Default::default() }, "text_height_mm"),
    ] {
        match err(&[sq(1)], &opts) {
            PatternError::InvalidOption { name: n, .. } => assert_eq!(n, name),
            other => panic!("{other:?}"),
        }
    }
    let opts = PatternOptions { notch_spacing_mm: 1e-3, ..Default::default() };
    let e = err(&two_panels(250.0, 250.0), &opts);
    assert!(matches!(e, PatternError::TooManyNotches { seam: 7, .. }), "{e}");
    // Messages name the piece and its size.
    let e = err(&[common::rect_piece(3, 300.0, 1600.0)], &o);
    let msg = e.to_string();
    assert!(msg.contains("piece 3 (P3)") && msg.contains("1630.0 mm across"), "{msg}");
    // Tolerated: seam_length_mismatch on broken input does not panic.
    let mut p = sq(6);
    p.seams = vec![side(1, 0, 40, true), side(1, 1, 2, true)];
    assert_eq!(seam_length_mismatch(&[p]), 0.0);
}

#[test]
fn large_outline() {
    // A 4000-point wavy disc with one self seam over two long arcs.
    let n = 4000;
    let outline: Vec<P2> = (0..n)
        .map(|k| {
            let a = k as f64 / n as f64 * std::f64::consts::TAU;
            let r = 600.0 + 40.0 * (25.0 * a).sin();
            [r * a.cos(), r * a.sin()]
        })
        .collect();
    let p = PieceInput {
        id: 1,
        name: "big".into(),
        outline,
        seams: vec![side(1, 100, 1000, true), side(1, 2000, 2900, false)],
        marks: vec![],
    };
    let t = std::time::Instant::now();
    let pat = build_pattern(&[p], &PatternOptions::default()).unwrap();
    println!("4000-point piece: {:.3} s, cut line {} points", t.elapsed().as_secs_f64(), pat.pieces[0].cut.len());
    check_offset(&pat.pieces[0].sew, &pat.pieces[0].cut, 15.0).unwrap();
    assert_eq!(pat.pieces[0].notches.len() % 2, 0);
}

#[test]
fn zero_allowance_and_gap() {
    let opts = PatternOptions { seam_allowance_mm: 0.0, piece_gap_mm: 0.0, ..Default::default() };
    let pat = build_pattern(&two_panels(250.0, 250.0), &opts).unwrap();
    assert_eq!(pat.pieces[0].cut, pat.pieces[0].sew);
    // Notch slits are empty at zero allowance but still located on the sew line.
    assert_eq!(pat.pieces[0].notches[1].tick[0], pat.pieces[0].notches[1].position);
    assert_nested(&pat, 0.0);
}

mod never_panics {
    use super::*;
    use clothcast_pattern::{SeamSide, all_writers};
    use proptest::prelude::*;

    /// A star polygon (valid, CCW), then maybe corrupted.
    fn outline() -> impl Strategy<Value = Vec<P2>> {
        (prop::collection::vec(20.0f64..400.0, 3..10), 0u8..12, 0usize..10).prop_map(|(radii, corrupt, at)| {
            let n = radii.len();
            let mut v: Vec<P2> = radii
                .iter()
                .enumerate()
                .map(|(k, r)| {
                    let a = k as f64 / n as f64 * std::f64::consts::TAU;
                    [r * a.cos(), r * a.sin()]
                })
                .collect();
            let at = at % n;
            match corrupt {
                0 => v.swap(at, (at + 1) % n),
                1 => v.reverse(),
                2 => v.insert(at, v[at]),
                3 => v[at][0] = f64::NAN,
                4 => v.truncate(2),
                5 => v[at] = v[(at + 2) % n],
                _ => {}
            }
            v
        })
    }

    fn piece(id: usize) -> impl Strategy<Value = PieceInput> {
        (
            outline(),
            prop_oneof![Just(vec![]), prop::collection::vec((0usize..3, 0usize..10, 0usize..10, any::<bool>()), 1..3),],
        )
            .prop_map(move |(outline, seams)| PieceInput {
                id,
                name: format!("R{id}"),
                outline,
                seams: seams
                    .into_iter()
                    .map(|(seam, start, end, forward)| SeamSide {
                        seam,
                        label: format!("X{seam}"),
                        start,
                        end,
                        forward,
                    })
                    .collect(),
                marks: vec![PointMark { kind: MarkKind::Clamp, position: [0.0, 0.0], label: "c".into() }],
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Arbitrary (mostly invalid) input: an error or a pattern whose files all write.
        #[test]
        fn build_pattern_never_panics(a in piece(0), b in piece(1), width in prop_oneof![3 => Just(1500.0), 1 => -1.0f64..3000.0],
                                      swap in any::<bool>(), allowance in prop_oneof![3 => Just(15.0), 1 => 0.0f64..40.0]) {
            let opts = PatternOptions { fabric_width_mm: width, allow_weft_swap: swap, seam_allowance_mm: allowance,
                                        ..Default::default() };
            let pieces = [a, b];
            let _ = seam_length_mismatch(&pieces);
            if let Ok(pat) = build_pattern(&pieces, &opts) {
                for p in &pat.pieces {
                    prop_assert!(check_offset(&p.sew, &p.cut, allowance).is_ok());
                }
                for w in all_writers() {
                    let mut out = Vec::new();
                    prop_assert!(w.write(&pat, &mut out).is_ok());
                }
            }
        }
    }
}

/// A piece too small for the text keeps its labels inside: a 30 mm square's name and area
/// shrink below `text_height_mm` (to its depth, 15 mm, over 4), a 100 mm one's do not, and no
/// piece's text goes below 3 mm.
#[test]
fn labels_shrink_on_small_pieces() {
    let small = common::rect_piece(1, 30.0, 30.0);
    let tiny = common::rect_piece(2, 6.0, 6.0);
    let pat = build_pattern(&[small, sq(3), tiny], &PatternOptions::default()).unwrap();
    let name_height = |i: usize| pat.pieces[i].labels[0].height;
    assert!((name_height(0) - 15.0 / 4.0).abs() < 0.1, "{}", name_height(0));
    assert_eq!(name_height(1), PatternOptions::default().text_height_mm);
    assert_eq!(name_height(2), 3.0);
    // The name stays inside the small piece's sewing line.
    let p = &pat.pieces[0];
    assert!(point_in_polygon(p.labels[0].position, &p.sew), "{:?}", p.labels[0].position);
}

/// A seam that is a closed loop (two pieces each bounded by it alone, as the two halves of a
/// sphere cut along its equator): each side runs from its start round the whole outline back to
/// it; the notches of the two sides match, one at the start and none doubled at the end.
#[test]
fn a_closed_seam_runs_round_the_whole_outline() {
    let o = PatternOptions { notch_spacing_mm: 90.0, ..Default::default() };
    // The same loop on both pieces, started at different outline indices (the seam's start is
    // outline index 1 of one, 3 of the other), walked the other way round on the second.
    let (mut a, mut b) = (sq(1), sq(2));
    a.seams = vec![side(5, 1, 1, true)];
    b.seams = vec![side(5, 3, 3, false)];
    let pat = build_pattern(&[a.clone(), b.clone()], &o).expect("a closed seam is valid");
    let notches = |k: usize| -> Vec<(usize, f64)> {
        pat.pieces[k].notches.iter().map(|n| (n.index, (n.t * 1e9).round() / 1e9)).collect()
    };
    // 400 mm of seam at 90 mm: the start and four interior notches, no end notch.
    assert_eq!(notches(0).len(), 5, "{:?}", notches(0));
    assert_eq!(notches(0), notches(1));
    assert_eq!(pat.pieces[0].notches[0].position, a.outline[1]);
    assert_eq!(pat.pieces[1].notches[0].position, b.outline[3]);
    assert_eq!(pat.pieces[0].seam_labels.len(), 1);
}
