//! Ray-query acceleration: a binned-SAH BVH over all primitives of the scene.
//!
//! API: [`Accel::intersect`] (closest hit) and [`Accel::occluded`] (any hit).

pub mod bvh;

pub use bvh::{Accel, Hit, Prim};
