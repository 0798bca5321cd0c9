//! Property tests over generated meshes with random resolution, jitter and sub-patches.

use clothcast_mesh::repair::{RepairOptions, prepare};
use clothcast_mesh::submesh::extract_submesh;
use clothcast_mesh::util::SplitMix64;
use clothcast_mesh::{FaceId, HalfedgeId, Mesh, TriSoup, Vec3, analyze, shapes};
use proptest::prelude::*;
use std::f64::consts::PI;

/// A generated mesh: 0 icosphere, 1 torus, 2 grid, 3 open cylinder, 4 capped cylinder;
/// vertices jittered by `jitter` × mean edge length (seeded).
fn generated(kind: u8, res: usize, jitter: f64, seed: u64) -> Mesh {
    let mut m = match kind % 5 {
        0 => shapes::icosphere(1 + (res % 3) as u32, 1.0),
        1 => shapes::torus(2.0, 0.7, 8 + 2 * res, 6 + res),
        2 => shapes::grid(2 + res, 3 + res, 1.0, 1.5),
        3 => shapes::cylinder(1.0, 2.0, 6 + res, 2 + res, false, false),
        _ => shapes::cylinder(1.0, 2.0, 6 + res, 2 + res, true, true),
    };
    let h = m.mean_edge_length();
    let mut rng = SplitMix64::new(seed);
    let p = m
        .positions()
        .map(|x| x + Vec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5) * (jitter * h));
    m.set_positions(p);
    m
}

/// A random edge-connected sub-patch grown from a seed face.
fn random_patch(m: &Mesh, size: usize, seed: u64) -> Vec<FaceId> {
    let mut rng = SplitMix64::new(seed);
    let start = FaceId::new(rng.below(m.n_faces()));
    let mut inside = vec![false; m.n_faces()];
    let mut frontier = vec![start];
    let mut out = Vec::new();
    inside[start.idx()] = true;
    while out.len() < size && !frontier.is_empty() {
        let f = frontier.swap_remove(rng.below(frontier.len()));
        out.push(f);
        for k in 0..3 {
            if let Some(g) = m.face_neighbor(f, k)
                && !inside[g.idx()]
            {
                inside[g.idx()] = true;
                frontier.push(g);
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn euler_characteristic_from_halfedges(kind in 0u8..5, res in 0usize..4, jitter in 0.0f64..0.3, seed in any::<u64>()) {
        let m = generated(kind, res, jitter, seed);
        let h = m.n_halfedges();
        let boundary = (0..h as u32).filter(|&i| m.is_boundary_halfedge(HalfedgeId(i))).count();
        // Every interior edge has two halfedges, every boundary edge one.
        let e_from_halfedges = (h + boundary) / 2;
        prop_assert_eq!(e_from_halfedges, m.n_edges());
        let chi = m.n_vertices() as i64 - e_from_halfedges as i64 + m.n_faces() as i64;
        prop_assert_eq!(chi, m.euler_characteristic());
        prop_assert_eq!(chi, analyze(&m.to_soup()).euler_characteristic);
        // Vertex fans cover every halfedge exactly once.
        let fan_total: usize = m.vertices().map(|v| m.outgoing(v).count()).sum();
        prop_assert_eq!(fan_total, h);
    }

    #[test]
    fn cotan_laplacian_symmetric_with_constant_kernel(kind in 0u8..5, res in 0usize..4, jitter in 0.0f64..0.3, seed in any::<u64>()) {
        let m = generated(kind, res, jitter, seed);
        let l = m.cotan_laplacian();
        let lt = l.as_ref().transpose().to_col_major().unwrap();
        let asym = (&l - &lt).val().iter().fold(0.0f64, |a, x| a.max(x.abs()));
        prop_assert_eq!(asym, 0.0);
        let l1 = l.as_ref() * faer::Col::<f64>::ones(m.n_vertices());
        let scale = m.cotan_weights().iter().map(|w| w.abs()).fold(0.0, f64::max);
        prop_assert!(l1.norm_max() <= 1e-12 * scale);
        // Positive semi-definite on random vectors: xᵀ L x ≥ 0.
        let mut rng = SplitMix64::new(seed ^ 1);
        let x = faer::Col::<f64>::from_fn(m.n_vertices(), |_| rng.next_f64() - 0.5);
        let lx = l.as_ref() * &x;
        let q: f64 = (0..m.n_vertices()).map(|i| x[i] * lx[i]).sum();
        prop_assert!(q >= -1e-12 * scale);
    }

    #[test]
    fn gauss_bonnet_on_meshes_and_patches(kind in 0u8..5, res in 0usize..4, jitter in 0.0f64..0.3, seed in any::<u64>(), size in 1usize..200) {
        let m = generated(kind, res, jitter, seed);
        let gb = |m: &Mesh| m.angle_defects().iter().sum::<f64>() + m.boundary_turning().iter().sum::<f64>() - 2.0 * PI * m.euler_characteristic() as f64;
        prop_assert!(gb(&m).abs() < 1e-9);
        // A grown patch is usually a valid surface; when it pinches at a vertex it is refused.
        if let Ok(sub) = extract_submesh(&m, &random_patch(&m, size, seed)) {
            prop_assert!(gb(&sub.mesh).abs() < 1e-9);
            for v in sub.mesh.vertices() {
                prop_assert_eq!(sub.mesh.position(v), m.position(sub.vertex_to_parent[v]));
            }
        }
    }

    #[test]
    fn repair_recovers_a_scrambled_soup(kind in 0u8..5, res in 0usize..3, seed in any::<u64>()) {
        let m = generated(kind, res, 0.1, seed);
        let mut rng = SplitMix64::new(seed);
        let clean = m.to_soup();
        // Scramble: duplicate every position (faces use the copies at random), flip random
        // faces, add a duplicate face and an unreferenced vertex.
        let n = clean.positions.len() as u32;
        let mut positions = clean.positions.clone();
        positions.extend(clean.positions.iter().copied());
        let mut tris: Vec<[u32; 3]> = clean.triangles.iter().map(|t| {
            let mut t = t.map(|v| if rng.next_f64() < 0.5 { v } else { v + n });
            if rng.next_f64() < 0.3 { t.swap(1, 2); }
            t
        }).collect();
        tris.push(clean.triangles[0]);
        positions.push(Vec3::new(9.0, 9.0, 9.0));
        let soup = TriSoup::from_triangles(positions, tris);
        prop_assert!(Mesh::try_from_soup(&soup).is_err());
        let fixed = prepare(&soup, &RepairOptions { repair: true, ..Default::default() }).unwrap();
        prop_assert_eq!(fixed.mesh.n_faces(), m.n_faces());
        prop_assert_eq!(fixed.mesh.n_vertices(), m.n_vertices());
        prop_assert_eq!(fixed.mesh.euler_characteristic(), m.euler_characteristic());
        prop_assert_eq!(fixed.report.duplicate_faces_removed, 1);
        prop_assert!(fixed.mesh.signed_volume() > 0.0);
    }
}
