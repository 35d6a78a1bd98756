//! Ray-query acceleration: an 8-wide BVH over all primitives of the scene.
//!
//! API: [`Accel::intersect`] (closest hit) and [`Accel::occluded`] (any hit).
//! `build` makes the tree, `tri4` tests four triangles at once, `bvh` holds
//! the nodes and the traversal.

pub mod build;
pub mod bvh;
pub mod lanes8;
pub mod memory;
pub mod tri4;

pub use bvh::{Accel, Hit, Prim};
