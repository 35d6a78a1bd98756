//! Ray-query acceleration: an 8-wide BVH over the scene's [`Primitive`]s
//! (shapes, and instances of shape groups, which hold BVHs of their own).
//!
//! API: [`Accel::intersect`] (closest hit) and [`Accel::occluded`] (any hit).
//! `build` makes the tree, `tri4` tests four triangles at once, `bvh` holds
//! the nodes and the traversal, `instance` the shape groups and instances.

pub mod build;
pub mod bvh;
pub mod instance;
pub mod lanes8;
pub mod memory;
pub mod packet;
pub mod tri4;

pub use bvh::{Accel, Hit, Primitive};
pub use instance::{Instance, ShapeGroup};
