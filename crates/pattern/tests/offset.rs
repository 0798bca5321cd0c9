//! The seam allowance offset: contains the sew line, keeps the allowance everywhere, stays
//! within the miter limit, and is a simple polygon — on random star-shaped (concave)
//! polygons, combs with narrow gaps, and hand-picked hard cases.

mod common;

use clothcast_pattern::geom::{P2, signed_area};
use clothcast_pattern::{cut_line, offset_polygon};
use common::{check_offset, comb, star};
use proptest::prelude::*;

fn checked(sew: &[P2], r: f64) -> Vec<P2> {
    let cut = offset_polygon(sew, r).expect("offset");
    if let Err(e) = check_offset(sew, &cut, r) {
        panic!("{e}\nsew = {sew:?}\ncut = {cut:?}");
    }
    cut
}

#[test]
fn combs_with_narrow_and_wide_gaps() {
    for &(gap, r) in &[(2.0, 15.0), (29.0, 15.0), (30.0, 15.0), (31.0, 15.0), (30.5, 15.0), (80.0, 15.0), (5.0, 1.0)] {
        let sew = comb(6, 20.0, gap, 100.0, 40.0);
        assert!(signed_area(&sew) > 0.0);
        let cut = checked(&sew, r);
        if gap <= 2.0 * r {
            // The gaps close up (at 2r exactly the offsets touch): the cut line runs straight
            // over the teeth.
            assert!(cut.len() <= 8, "{} vertices", cut.len());
        } else {
            assert!(cut.len() > 8);
        }
    }
}

#[test]
fn nearly_closed_c_drops_the_hole() {
    // A C whose mouth (4 mm) is narrower than 2r: the union has a hole; the cut line is the
    // outer boundary only.
    let sew = vec![
        [0.0, 0.0],
        [300.0, 0.0],
        [300.0, 148.0],
        [60.0, 148.0],
        [60.0, 152.0],
        [300.0, 152.0],
        [300.0, 300.0],
        [0.0, 300.0],
    ];
    let sew: Vec<P2> = sew;
    let cut = checked(&sew, 15.0);
    assert!((signed_area(&cut) - 330.0 * 330.0).abs() < 1e-6, "{cut:?}");
}

#[test]
fn needle_spikes_and_zero_allowance() {
    let sew = vec![[0.0, 0.0], [100.0, 0.0], [100.0, 40.0], [500.0, 41.0], [100.0, 42.0], [100.0, 80.0], [0.0, 80.0]];
    checked(&sew, 10.0);
    assert_eq!(offset_polygon(&sew, 0.0).unwrap(), sew);
    // A clockwise input is taken in reverse.
    let cw: Vec<P2> = sew.iter().rev().copied().collect();
    assert_eq!(offset_polygon(&cw, 10.0), offset_polygon(&sew, 10.0));
}

#[test]
fn scale_robustness() {
    // The same shape at 1e-3 and 1e4 times the size, allowance scaled along.
    let base = comb(3, 20.0, 7.0, 50.0, 20.0);
    for s in [1e-3, 1.0, 1e4] {
        let sew: Vec<P2> = base.iter().map(|p| [p[0] * s, p[1] * s]).collect();
        checked(&sew, 15.0 * s);
    }
}

/// How far the bottom side of a cut line (its vertices below the panel, away from the corners)
/// rises above its lowest point: the depth of its teeth.
fn teeth_depth(cut: &[P2]) -> f64 {
    let bottom: Vec<f64> = cut.iter().filter(|p| p[1] < 0.0 && p[0] > 30.0 && p[0] < 570.0).map(|p| p[1]).collect();
    let lo = bottom.iter().copied().fold(f64::INFINITY, f64::min);
    bottom.iter().map(|y| y - lo).fold(0.0, f64::max)
}

/// A sew line that zigzags on the scale of a mesh edge (a 600 × 300 mm panel whose bottom
/// side has V dents 24 mm wide and 4 mm deep) leaves the exact offset with a tooth over every
/// dent, as deep as the dent; the cut line's closing (a 120 mm disc for the 15 mm allowance)
/// leaves under a quarter of that, the allowance kept everywhere, within the miter limit, never inside
/// the exact offset. A panel without dents keeps its exact offset.
#[test]
fn the_cut_line_closes_small_dents() {
    let r = 15.0;
    let mut sew: Vec<P2> = Vec::new();
    for k in 0..25 {
        let x = 24.0 * k as f64;
        sew.push([x, 0.0]);
        sew.push([x + 12.0, 4.0]);
    }
    sew.extend([[600.0, 0.0], [600.0, 300.0], [0.0, 300.0]]);
    assert!(signed_area(&sew) > 0.0);
    let exact = checked(&sew, r);
    let cut = cut_line(&sew, r).expect("cut line");
    if let Err(e) = check_offset(&sew, &cut, r) {
        panic!("{e}\ncut = {cut:?}");
    }
    let (before, after) = (teeth_depth(&exact), teeth_depth(&cut));
    println!("teeth: {before:.2} mm in the exact offset, {after:.2} mm in the cut line");
    assert!(before > 3.5, "the exact offset's teeth: {before} mm");
    assert!(after < before / 4.0, "teeth of {after} mm left of {before} mm");
    assert!(signed_area(&cut) >= signed_area(&exact));
    for &p in &exact {
        assert!(
            clothcast_pattern::geom::point_in_polygon(p, &cut)
                || clothcast_pattern::geom::dist_point_boundary(p, &cut) < 1e-9 * r,
            "exact offset vertex {p:?} outside the cut line"
        );
    }
    // Without dents: the exact offset, to the bit.
    let panel = vec![[0.0, 0.0], [600.0, 0.0], [600.0, 300.0], [0.0, 300.0]];
    assert_eq!(cut_line(&panel, r), offset_polygon(&panel, r));
    assert_eq!(cut_line(&panel, 0.0).unwrap(), panel);
}

fn star_strategy() -> impl Strategy<Value = Vec<P2>> {
    (3usize..40).prop_flat_map(|n| {
        (prop::collection::vec(0.2f64..1.0, n), prop::collection::vec(5.0f64..400.0, n), -1e3f64..1e3).prop_map(
            |(steps, radii, cx)| {
                let total: f64 = steps.iter().sum();
                let mut a = 0.0;
                let angles: Vec<f64> = steps
                    .iter()
                    .map(|s| {
                        let here = a;
                        a += s / total * std::f64::consts::TAU;
                        here
                    })
                    .collect();
                star([cx, 0.5 * cx], &angles, &radii)
            },
        )
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// The exact offset and the cut line with its dents closed, both checked; the cut line
    /// never holds less fabric than the exact offset.
    #[test]
    fn random_star_polygons(sew in star_strategy(), r in 0.5f64..60.0) {
        // Star polygons whose centre falls outside (an angular gap > π) may run clockwise.
        prop_assume!(signed_area(&sew) > 0.0);
        prop_assume!(clothcast_pattern::geom::find_self_intersection(&sew).is_none());
        let exact = offset_polygon(&sew, r).expect("offset");
        let closed = cut_line(&sew, r).expect("cut line");
        for cut in [&exact, &closed] {
            let res = check_offset(&sew, cut, r);
            prop_assert!(res.is_ok(), "{:?}\nsew = {:?}\ncut = {:?}", res, sew, cut);
        }
        prop_assert!(signed_area(&closed) >= signed_area(&exact) * (1.0 - 1e-12));
    }

    #[test]
    fn random_combs(teeth in 1usize..8, tooth in 1.0f64..60.0, gap in 0.5f64..80.0, height in 1.0f64..150.0,
                    base in 1.0f64..50.0, r in 0.5f64..40.0) {
        let sew = comb(teeth, tooth, gap, height, base);
        let cut = offset_polygon(&sew, r).expect("offset");
        let res = check_offset(&sew, &cut, r);
        prop_assert!(res.is_ok(), "{:?}\nsew = {:?}\ncut = {:?}", res, sew, cut);
    }
}
