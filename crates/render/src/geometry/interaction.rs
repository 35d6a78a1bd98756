//! Surface interactions: everything an integrator needs about a ray hit.

use crate::math::Frame;
use glam::{Vec2, Vec3};

/// A ray/surface hit in world space.
///
/// Direction convention (pbrt's): `wo` points from the hit back along the
/// incoming ray, towards the camera side; sampled directions are `wi`.
#[derive(Debug, Clone, Copy)]
pub struct SurfaceInteraction {
    pub p: Vec3,
    /// Ray distance to the hit.
    pub t: f32,
    /// Geometric normal on the shape's front side (after `flip_normals`).
    pub n: Vec3,
    /// Shading frame; `sh_frame.n` is the interpolated shading normal.
    pub sh_frame: Frame,
    /// Mesh texture coordinates (barycentrics without a uv attribute); the
    /// disk's local (x, y); zero on spheres.
    pub uv: Vec2,
    /// Index of the hit shape in the scene.
    pub shape: u32,
    /// Direction back towards the ray origin, in world space (unit length).
    pub wo: Vec3,
}

impl SurfaceInteraction {
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_local(v)
    }
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_world(v)
    }
}
