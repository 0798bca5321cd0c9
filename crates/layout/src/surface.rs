//! Points on a mesh's surface: vertices and points on edges. Polylines of surface points are
//! how straightened seams travel from the geodesic solver to the remesher.

use clothcast_mesh::{EdgeId, Mesh, Vec3, VertexId};

/// A point on the surface of a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfacePoint {
    /// A vertex.
    Vertex(VertexId),
    /// A point on an edge, at parameter `t` ∈ (0, 1) from `mesh.edge_vertices(edge)[0]`
    /// towards `mesh.edge_vertices(edge)[1]`.
    Edge {
        /// The edge.
        edge: EdgeId,
        /// Parameter along the edge.
        t: f64,
    },
}

impl SurfacePoint {
    /// 3D position.
    pub fn position(&self, mesh: &Mesh) -> Vec3 {
        match *self {
            SurfacePoint::Vertex(v) => mesh.position(v),
            SurfacePoint::Edge { edge, t } => {
                let [a, b] = mesh.edge_vertices(edge);
                mesh.position(a) * (1.0 - t) + mesh.position(b) * t
            }
        }
    }
}

/// Length of a polyline of surface points.
pub fn polyline_length(mesh: &Mesh, points: &[SurfacePoint]) -> f64 {
    points.windows(2).map(|w| (w[1].position(mesh) - w[0].position(mesh)).norm()).sum()
}
