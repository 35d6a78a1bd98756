//! Geometric primitives: rays, boxes, triangles, spheres and meshes.

pub mod mesh;
pub use mesh::TriangleMesh;
