//! Surface interactions: everything an integrator needs about a ray hit.

use crate::math::Frame;
use glam::{Vec2, Vec3};

/// A ray/surface hit in world space.
///
/// Direction convention (pbrt's): `wo` points from the hit back along the
/// incoming ray, towards the camera side; sampled directions are `wi`.
#[derive(Debug, Clone, Copy)]
pub struct SurfaceInteraction {
    /// The hit point.
    pub p: Vec3,
    /// Ray distance to the hit.
    pub t: f32,
    /// Geometric normal on the shape's front side (after `flip_normals`).
    pub n: Vec3,
    /// Shading frame; `sh_frame.n` is the interpolated shading normal and
    /// `sh_frame.s` the direction of `dpdu` projected onto the tangent plane
    /// (Mitsuba's `initialize_sh_frame`).
    pub sh_frame: Frame,
    /// Surface coordinates as Mitsuba defines them per shape: mesh texture
    /// coordinates (barycentrics (b1, b2) without), the sphere's
    /// (φ/2π, θ/π), the disk's (r, φ/2π), per-face uv on rectangle and cube.
    pub uv: Vec2,
    /// World-space derivatives of the position with respect to u and v.
    /// Hits on materials that read none of `uv`, `dpdu`, `dpdv` skip them
    /// (`Shape::interaction_with`): `dpdu` is then only a tangent.
    pub dpdu: Vec3,
    /// ∂p/∂v in world space (zero where skipped, see `dpdu`).
    pub dpdv: Vec3,
    /// Index of the hit shape in the scene.
    pub shape: u32,
    /// Index of the hit triangle within its mesh (0 for analytic shapes).
    pub prim: u32,
    /// Barycentric coordinates (b1, b2) of the hit on that triangle (what
    /// `mesh_attribute` interpolates with; zero for analytic shapes).
    pub bary: Vec2,
    /// Direction back towards the ray origin, in world space (unit length).
    pub wo: Vec3,
}

impl SurfaceInteraction {
    /// The shading frame around `n_s` whose tangent `s` is `dpdu` made
    /// orthogonal to `n_s` (Gram–Schmidt), as Mitsuba 3.9.1 builds it; an
    /// arbitrary frame where `dpdu` is zero or parallel to the normal.
    #[inline]
    pub fn frame_from_dpdu(n_s: Vec3, dpdu: Vec3) -> Frame {
        let s = dpdu - n_s * n_s.dot(dpdu);
        let len2 = s.length_squared();
        if len2 > 0.0 && len2.is_finite() {
            let s = s / len2.sqrt();
            Frame { s, t: n_s.cross(s), n: n_s }
        } else {
            Frame::from_normal(n_s)
        }
    }

    /// A hit that carries only `uv`: what a texture that reads nothing else
    /// needs (bitmaps, checkerboards: [`crate::texture::Texture::reads_only_uv`];
    /// Mitsuba queries a projector's texture the same way).
    pub fn at_uv(uv: Vec2) -> SurfaceInteraction {
        SurfaceInteraction {
            p: Vec3::ZERO,
            t: 0.0,
            n: Vec3::Z,
            sh_frame: Frame::from_normal(Vec3::Z),
            uv,
            dpdu: Vec3::X,
            dpdv: Vec3::Y,
            shape: 0,
            prim: 0,
            bary: Vec2::ZERO,
            wo: Vec3::Z,
        }
    }

    /// World direction → the shading frame (normal = +z), where BSDFs work.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_local(v)
    }
    /// Shading-frame direction → world space.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_world(v)
    }
}
