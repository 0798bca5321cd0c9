//! Raw triangle soups as read from files, before validation, and axis-aligned boxes.

use crate::Vec3;

/// Coordinates beyond this magnitude (in the file's units) are refused like NaN: no model is
/// 10⁹ km wide in metres (10⁶ km in millimetres), and squared lengths and areas of such points
/// overflow (a tetrahedron at 1e300 had been refused for "zero area (inf)").
pub const MAX_COORDINATE: f64 = 1e12;

/// Whether every coordinate of `p` is finite and within ±[`MAX_COORDINATE`].
pub fn usable_point(p: &Vec3) -> bool {
    p.iter().all(|c| c.is_finite() && c.abs() <= MAX_COORDINATE)
}

/// Raw input: positions and triangles exactly as read (polygons fan-triangulated), with no
/// guarantee beyond "every index is in range". Turn it into a [`crate::Mesh`] with
/// [`crate::Mesh::try_from_soup`] (strict) or [`crate::repair::repair_soup`] (opt-in fixes).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriSoup {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles as vertex indices (all `< positions.len()`).
    pub triangles: Vec<[u32; 3]>,
    /// For each triangle, the index of the source polygon it came from.
    pub source_face: Vec<u32>,
    /// Number of polygons in the source file (before fan triangulation).
    pub source_polygons: usize,
}

impl TriSoup {
    /// A soup from triangles (each triangle is its own source polygon).
    pub fn from_triangles(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Self {
        let n = triangles.len();
        Self { positions, triangles, source_face: (0..n as u32).collect(), source_polygons: n }
    }

    /// Append a polygon, fan-triangulated from its first corner: (c0, ci, ci+1).
    /// Polygons with fewer than 3 corners are the caller's error to report.
    pub fn push_polygon(&mut self, corners: &[u32]) {
        let src = self.source_polygons as u32;
        for i in 1..corners.len().saturating_sub(1) {
            self.triangles.push([corners[0], corners[i], corners[i + 1]]);
            self.source_face.push(src);
        }
        self.source_polygons += 1;
    }

    /// Bounding box of all positions (finite ones only).
    pub fn bbox(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }
}

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (min = +inf, max = −inf).
    pub fn empty() -> Self {
        Self { min: Vec3::repeat(f64::INFINITY), max: Vec3::repeat(f64::NEG_INFINITY) }
    }

    /// Box around the usable points of an iterator ([`usable_point`]).
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        let mut b = Self::empty();
        for p in points {
            if usable_point(&p) {
                b.min = b.min.inf(&p);
                b.max = b.max.sup(&p);
            }
        }
        b
    }

    /// True if no point was added.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }

    /// Length of the diagonal (0 for an empty box).
    pub fn diagonal(&self) -> f64 {
        if self.is_empty() { 0.0 } else { (self.max - self.min).norm() }
    }

    /// Extent along each axis.
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() { Vec3::zeros() } else { self.max - self.min }
    }

    /// Centre of the box.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fan_triangulation() {
        let mut s = TriSoup { positions: vec![Vec3::zeros(); 5], ..Default::default() };
        s.push_polygon(&[0, 1, 2, 3, 4]);
        s.push_polygon(&[0, 2, 4]);
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 2, 4]]);
        assert_eq!(s.source_face, vec![0, 0, 0, 1]);
        assert_eq!(s.source_polygons, 2);
    }

    #[test]
    fn bbox_ignores_nan() {
        let b = Aabb::from_points([Vec3::new(0., 0., 0.), Vec3::new(f64::NAN, 1., 1.), Vec3::new(3., 4., 0.)]);
        assert_eq!(b.diagonal(), 5.0);
    }
}
