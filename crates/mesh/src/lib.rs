//! # clothcast-mesh
//!
//! The ground every clothcast stage stands on: an indexed triangle mesh with implicit halfedge
//! connectivity and typed ids ([`Mesh`], [`VertexId`], [`FaceData`], ...), strict validation
//! that names every problem ([`validate`]), opt-in repair ([`repair`]), mesh files
//! ([`io`]: OBJ, PLY, STL, OFF in; OBJ and PLY with custom properties out; atomic writes),
//! discrete geometry ([`geometry`]: areas, normals, angles, curvature, cotan Laplacian, mass,
//! frames), submeshes ([`submesh`]), refinement by longest-edge bisection ([`subdivide`]), coarse versions and closest points ([`simplify`]), sparse
//! Cholesky with symbolic reuse ([`sparse`]) and generated shapes including the built-in
//! example ([`shapes`]).
//!
//! ```
//! use clothcast_mesh::{shapes, Mesh};
//! let m: Mesh = shapes::icosphere(2, 1.0);
//! assert_eq!(m.euler_characteristic(), 2);
//! // Gauss–Bonnet: the angle defects sum to 2πχ.
//! let total: f64 = m.angle_defects().iter().sum();
//! assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-9);
//! ```

pub mod error;
pub mod geometry;
pub mod ids;
pub mod io;
pub mod mesh;
pub mod ordering;
pub mod polygon;
pub mod repair;
pub mod shapes;
pub mod simplify;
pub mod soup;
pub mod sparse;
pub mod subdivide;
pub mod submesh;
pub mod util;
pub mod validate;

pub use error::MeshError;
pub use geometry::FaceFrame;
pub use ids::{EdgeData, EdgeId, FaceData, FaceId, HalfedgeData, HalfedgeId, VertexData, VertexId};
pub use mesh::Mesh;
pub use soup::{Aabb, TriSoup};
pub use validate::{Problem, SoupAnalysis, analyze};

/// The linear-algebra crate behind [`sparse`], re-exported so every stage uses the same version.
pub use faer;

/// 3D vector (f64).
pub type Vec3 = nalgebra::Vector3<f64>;
/// 2D vector (f64).
pub type Vec2 = nalgebra::Vector2<f64>;
