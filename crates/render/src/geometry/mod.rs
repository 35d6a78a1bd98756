//! Geometric primitives: rays, boxes, triangles, meshes, spheres, disks,
//! cylinders, ellipsoids, signed distance grids and curves.

pub mod bounds;
pub mod curves;
pub mod cylinder;
pub mod disk;
pub mod ellipsoids;
pub mod interaction;
pub mod loop_subdiv;
pub mod mesh;
pub mod ray;
pub mod sdfgrid;
pub mod shape;
pub mod sphere;
pub mod triangle;

pub use bounds::Aabb;
pub use curves::Curves;
pub use cylinder::Cylinder;
pub use disk::Disk;
pub use ellipsoids::{Ellipsoid, Ellipsoids, Shell};
pub use interaction::SurfaceInteraction;
pub use mesh::TriangleMesh;
pub use ray::{offset_origin, Ray, RayLanes};
pub use sdfgrid::SdfGrid;
pub use shape::{AreaSample, Mesh, Shape, ShapeSample};
pub use sphere::Sphere;
