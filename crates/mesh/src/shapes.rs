//! Generated shapes: the built-in example (a smooth rounded tetrahedron, like the paper's
//! Fig. 3), icospheres, tori, cylinders and flat grids for tests and benchmarks. All are
//! deterministic and consistently oriented with outward normals.

use crate::Vec3;
use crate::mesh::Mesh;
use std::collections::HashMap;
use std::f64::consts::PI;

/// Icosphere of the given radius: an icosahedron subdivided `level` times (20·4^level faces),
/// vertices projected on the sphere.
pub fn icosphere(level: u32, radius: f64) -> Mesh {
    let (p, t) = icosphere_soup(level);
    Mesh::try_new(p.into_iter().map(|x| x * radius).collect(), t).expect("icosphere is valid")
}

fn icosphere_soup(level: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut p: Vec<Vec3> = [
        [-1., g, 0.],
        [1., g, 0.],
        [-1., -g, 0.],
        [1., -g, 0.],
        [0., -1., g],
        [0., 1., g],
        [0., -1., -g],
        [0., 1., -g],
        [g, 0., -1.],
        [g, 0., 1.],
        [-g, 0., -1.],
        [-g, 0., 1.],
    ]
    .iter()
    .map(|c| Vec3::new(c[0], c[1], c[2]).normalize())
    .collect();
    let mut t: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut nt = Vec::with_capacity(t.len() * 4);
        let mut midpoint = |a: u32, b: u32, p: &mut Vec<Vec3>| -> u32 {
            let k = (a.min(b), a.max(b));
            *mid.entry(k).or_insert_with(|| {
                p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                (p.len() - 1) as u32
            })
        };
        for &[a, b, c] in &t {
            let ab = midpoint(a, b, &mut p);
            let bc = midpoint(b, c, &mut p);
            let ca = midpoint(c, a, &mut p);
            nt.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        t = nt;
    }
    (p, t)
}

/// Outward unit normals of a regular tetrahedron with one face on top (normal +z) and the
/// opposite vertex pointing down.
fn tetrahedron_normals() -> [Vec3; 4] {
    let s = 8f64.sqrt() / 3.0;
    let mut n = [Vec3::z(); 4];
    for k in 0..3 {
        let phi = 2.0 * PI * k as f64 / 3.0 + PI / 2.0;
        n[k + 1] = Vec3::new(s * phi.cos(), s * phi.sin(), -1.0 / 3.0);
    }
    n
}

/// Distance along the unit direction `u` to the rounded tetrahedron
/// {x : (Σ_i max(0, n_i·x)^p)^(1/p) = 1} (a p-norm blend of the four face planes).
fn rounded_tet_radius(u: &Vec3, normals: &[Vec3; 4], p: f64) -> f64 {
    let f: f64 = normals.iter().map(|n| n.dot(u).max(0.0).powf(p)).sum::<f64>().powf(1.0 / p);
    1.0 / f
}

/// The built-in example: a smooth rounded tetrahedron standing on a vertex with a face on top,
/// `height` tall along +z (bottom at z = 0, centred on the z axis), 5120 faces, closed,
/// genus 0, with evenly spread vertices (tangential relaxation on the exact surface).
pub fn rounded_tetrahedron(height: f64) -> Mesh {
    const P: f64 = 6.0;
    let normals = tetrahedron_normals();
    let (mut p, t) = icosphere_soup(4);
    let project = |x: &Vec3| {
        let u = x.normalize();
        u * rounded_tet_radius(&u, &normals, P)
    };
    for x in p.iter_mut() {
        *x = project(x);
    }
    // Neighbours for relaxation.
    let mut nbr: Vec<Vec<u32>> = vec![Vec::new(); p.len()];
    for tri in &t {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            if !nbr[a as usize].contains(&b) {
                nbr[a as usize].push(b);
                nbr[b as usize].push(a);
            }
        }
    }
    for _ in 0..40 {
        let mut normal = vec![Vec3::zeros(); p.len()];
        for tri in &t {
            let a = (p[tri[1] as usize] - p[tri[0] as usize]).cross(&(p[tri[2] as usize] - p[tri[0] as usize]));
            for &v in tri {
                normal[v as usize] += a;
            }
        }
        let next: Vec<Vec3> = (0..p.len())
            .map(|i| {
                let c = nbr[i].iter().map(|&j| p[j as usize]).sum::<Vec3>() / nbr[i].len() as f64;
                let n = normal[i].normalize();
                let d = c - p[i];
                project(&(p[i] + 0.5 * (d - n * n.dot(&d))))
            })
            .collect();
        p = next;
    }
    let zmin = p.iter().map(|x| x.z).fold(f64::INFINITY, f64::min);
    let zmax = p.iter().map(|x| x.z).fold(f64::NEG_INFINITY, f64::max);
    let s = height / (zmax - zmin);
    let p = p.into_iter().map(|x| Vec3::new(x.x * s, x.y * s, (x.z - zmin) * s)).collect();
    Mesh::try_new(p, t).expect("rounded tetrahedron is valid")
}

/// Torus around the z axis with major radius `big_r`, tube radius `small_r`, `n_major × n_minor`
/// quads split into triangles.
pub fn torus(big_r: f64, small_r: f64, n_major: usize, n_minor: usize) -> Mesh {
    let mut p = Vec::with_capacity(n_major * n_minor);
    for i in 0..n_major {
        let u = 2.0 * PI * i as f64 / n_major as f64;
        for j in 0..n_minor {
            let v = 2.0 * PI * j as f64 / n_minor as f64;
            let r = big_r + small_r * v.cos();
            p.push(Vec3::new(r * u.cos(), r * u.sin(), small_r * v.sin()));
        }
    }
    let id = |i: usize, j: usize| ((i % n_major) * n_minor + j % n_minor) as u32;
    let mut t = Vec::with_capacity(2 * n_major * n_minor);
    for i in 0..n_major {
        for j in 0..n_minor {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            t.push([a, b, c]);
            t.push([a, c, d]);
        }
    }
    Mesh::try_new(p, t).expect("torus is valid")
}

/// The unit square [0, 1]² in the z = 0 plane as two triangles, (0, 1, 2) and (0, 2, 3), its
/// vertices counter-clockwise from the origin (normal +z; the diagonal joins 0 and 2).
pub fn unit_square() -> Mesh {
    let p = vec![Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)];
    Mesh::try_new(p, vec![[0, 1, 2], [0, 2, 3]]).expect("the square is valid")
}

/// Flat `nx × ny` grid of squares (each split in two) over [0, sx] × [0, sy] in the z = 0
/// plane, normal +z.
pub fn grid(nx: usize, ny: usize, sx: f64, sy: f64) -> Mesh {
    let mut p = Vec::with_capacity((nx + 1) * (ny + 1));
    for j in 0..=ny {
        for i in 0..=nx {
            p.push(Vec3::new(sx * i as f64 / nx as f64, sy * j as f64 / ny as f64, 0.0));
        }
    }
    let id = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let mut t = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            // Alternate the diagonal for a symmetric mesh.
            if (i + j) % 2 == 0 {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            } else {
                t.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
                t.push([id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }
    Mesh::try_new(p, t).expect("grid is valid")
}

/// Cylinder of radius `r` along z from 0 to `h`, `n_around × n_up` quads split into triangles,
/// open at both ends unless capped: `cap_bottom`/`cap_top` close an end with a fan from a
/// centre vertex. Outward normals.
pub fn cylinder(r: f64, h: f64, n_around: usize, n_up: usize, cap_bottom: bool, cap_top: bool) -> Mesh {
    let mut p = Vec::new();
    for j in 0..=n_up {
        for i in 0..n_around {
            let a = 2.0 * PI * i as f64 / n_around as f64;
            p.push(Vec3::new(r * a.cos(), r * a.sin(), h * j as f64 / n_up as f64));
        }
    }
    let id = |i: usize, j: usize| (j * n_around + i % n_around) as u32;
    let mut t = Vec::new();
    for j in 0..n_up {
        for i in 0..n_around {
            t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    if cap_bottom {
        p.push(Vec3::new(0.0, 0.0, 0.0));
        let c = (p.len() - 1) as u32;
        for i in 0..n_around {
            t.push([c, id(i + 1, 0), id(i, 0)]);
        }
    }
    if cap_top {
        p.push(Vec3::new(0.0, 0.0, h));
        let c = (p.len() - 1) as u32;
        for i in 0..n_around {
            t.push([c, id(i, n_up), id(i + 1, n_up)]);
        }
    }
    Mesh::try_new(p, t).expect("cylinder is valid")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_have_expected_topology() {
        let s = icosphere(2, 1.0);
        assert_eq!((s.n_faces(), s.euler_characteristic(), s.genus()), (320, 2, 0));
        assert!(s.signed_volume() > 0.0);
        let t = torus(2.0, 0.5, 24, 12);
        assert_eq!((t.euler_characteristic(), t.genus()), (0, 1));
        assert!(t.signed_volume() > 0.0);
        let g = grid(4, 3, 1.0, 1.0);
        assert_eq!((g.n_faces(), g.boundary_loops().len()), (24, 1));
        let c = cylinder(1.0, 2.0, 16, 4, true, false);
        assert_eq!((c.boundary_loops().len(), c.genus()), (1, 0));
        assert!(c.signed_volume() > 0.0);
        let c2 = cylinder(1.0, 2.0, 16, 4, true, true);
        assert_eq!(c2.euler_characteristic(), 2);
        assert!(c2.signed_volume() > 0.0);
    }

    #[test]
    fn example_is_a_smooth_closed_tetrahedron() {
        let m = rounded_tetrahedron(0.5);
        assert_eq!(m.n_faces(), 5120);
        assert_eq!((m.euler_characteristic(), m.genus()), (2, 0));
        let b = m.bbox();
        assert!((b.extent().z - 0.5).abs() < 1e-12);
        assert!(m.signed_volume() > 0.0);
        // Reasonable triangle quality after relaxation.
        assert!(m.min_angle().to_degrees() > 15.0, "min angle {}", m.min_angle().to_degrees());
    }
}

/// A sphere meshed from a cube: each cube face an `n × n` grid of quads, each quad split into
/// four triangles around its centre (so the mesh has the cube's full symmetry), every vertex
/// projected on the sphere of radius `r` (24·n² faces). Its 8 cube-corner vertices are where a
/// smoothest cross field puts its 8 valence-3 singularities.
pub fn cube_sphere(n: usize, r: f64) -> Mesh {
    let n = n.max(1);
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut p: Vec<Vec3> = Vec::new();
    let mut t: Vec<[u32; 3]> = Vec::new();
    // Integer lattice coordinates in units of 1/(2n) of the half-edge, so quad centres are exact.
    let mut vid = |key: [i64; 3], p: &mut Vec<Vec3>| -> u32 {
        *index.entry(key).or_insert_with(|| {
            let v = Vec3::new(key[0] as f64, key[1] as f64, key[2] as f64);
            p.push(v.normalize() * r);
            (p.len() - 1) as u32
        })
    };
    let m = n as i64; // a face spans -m..=m in lattice units, 2 per quad
    // (normal axis, sign, u axis, v axis) with u × v = sign · normal for outward orientation.
    let faces: [(usize, i64, usize, usize); 6] =
        [(0, 1, 1, 2), (0, -1, 2, 1), (1, 1, 2, 0), (1, -1, 0, 2), (2, 1, 0, 1), (2, -1, 1, 0)];
    for (axis, sign, ua, va) in faces {
        let at = |u: i64, v: i64| -> [i64; 3] {
            let mut k = [0i64; 3];
            k[axis] = sign * m;
            k[ua] = u;
            k[va] = v;
            k
        };
        for i in 0..n as i64 {
            for j in 0..n as i64 {
                let (u0, v0) = (-m + 2 * i, -m + 2 * j);
                let a = vid(at(u0, v0), &mut p);
                let b = vid(at(u0 + 2, v0), &mut p);
                let c = vid(at(u0 + 2, v0 + 2), &mut p);
                let d = vid(at(u0, v0 + 2), &mut p);
                let o = vid(at(u0 + 1, v0 + 1), &mut p);
                t.extend([[a, b, o], [b, c, o], [c, d, o], [d, a, o]]);
            }
        }
    }
    Mesh::try_new(p, t).expect("cube sphere is valid")
}

#[cfg(test)]
mod cube_sphere_tests {
    use super::*;

    #[test]
    fn cube_sphere_is_a_closed_outward_sphere() {
        let m = cube_sphere(4, 2.0);
        assert_eq!(m.n_faces(), 24 * 16);
        assert_eq!(m.euler_characteristic(), 2);
        assert!(m.boundary_loops().is_empty());
        assert!(m.signed_volume() > 0.0);
        assert!(m.positions().iter().all(|p| (p.norm() - 2.0).abs() < 1e-12));
    }
}
