//! Submeshes: a subset of faces as a mesh of its own, with index maps back to the parent.

use crate::error::MeshError;
use crate::ids::*;
use crate::mesh::Mesh;

/// A mesh made of some faces of a parent mesh.
#[derive(Clone, Debug)]
pub struct Submesh {
    /// The extracted mesh (vertices in order of first use by the faces, faces in given order).
    pub mesh: Mesh,
    /// Parent vertex of each submesh vertex.
    pub vertex_to_parent: VertexData<VertexId>,
    /// Parent face of each submesh face.
    pub face_to_parent: FaceData<FaceId>,
}

impl Submesh {
    /// Submesh vertex of a parent vertex, if it is in the submesh (O(V_sub) lookup table built
    /// by the caller is cheaper for many queries; see [`Submesh::parent_to_vertex`]).
    pub fn parent_to_vertex(&self, n_parent_vertices: usize) -> Vec<Option<VertexId>> {
        let mut m = vec![None; n_parent_vertices];
        for (v, &p) in self.vertex_to_parent.enumerate() {
            m[p.idx()] = Some(v);
        }
        m
    }
}

/// Extract the given faces (in the given order). Fails with the problem named if the faces do
/// not form a manifold surface on their own (e.g. two patches touching at a single vertex).
pub fn extract_submesh(parent: &Mesh, faces: &[FaceId]) -> Result<Submesh, MeshError> {
    let mut local = vec![u32::MAX; parent.n_vertices()];
    let mut vertex_to_parent = Vec::new();
    let mut tris = Vec::with_capacity(faces.len());
    for &f in faces {
        tris.push(parent.face_vertices(f).map(|v| {
            if local[v.idx()] == u32::MAX {
                local[v.idx()] = vertex_to_parent.len() as u32;
                vertex_to_parent.push(v);
            }
            local[v.idx()]
        }));
    }
    let positions = vertex_to_parent.iter().map(|&v| parent.position(v)).collect();
    let mesh = Mesh::try_new(positions, tris)?;
    Ok(Submesh {
        mesh,
        vertex_to_parent: VertexData::from_vec(vertex_to_parent),
        face_to_parent: FaceData::from_vec(faces.to_vec()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec3;

    #[test]
    fn strip_halves() {
        // 2×1 strip of four triangles.
        let p = (0..6).map(|i| Vec3::new((i % 3) as f64, (i / 3) as f64, 0.0)).collect();
        let m = Mesh::try_new(p, vec![[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]).unwrap();
        let s = extract_submesh(&m, &[FaceId(2), FaceId(3)]).unwrap();
        assert_eq!(s.mesh.n_faces(), 2);
        assert_eq!(s.mesh.n_vertices(), 4);
        for v in s.mesh.vertices() {
            assert_eq!(s.mesh.position(v), m.position(s.vertex_to_parent[v]));
        }
        assert_eq!(s.face_to_parent[FaceId(1)], FaceId(3));
        // Faces touching only at vertex 4 are refused: non-manifold vertex.
        let m2 = extract_submesh(&m, &[FaceId(1), FaceId(3)]);
        assert!(m2.is_err());
    }
}
