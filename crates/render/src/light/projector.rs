//! Mitsuba `projector`: a pinhole projecting `irradiance` (a colour or a
//! bitmap) into the scene along its local +z, the reciprocal of the
//! `perspective` sensor (the same fov conventions and film-to-direction map).
//! A Dirac delta in position: only light sampling reaches it.
//!
//! | parameter    | type              | default |
//! |--------------|-------------------|---------|
//! | irradiance   | rgb or bitmap     | 1 (irradiance on the image plane z = 1) |
//! | scale        | float             | 1 |
//! | to_world     | transform         | identity (position and orientation) |
//! | fov          | float             | (degrees, full angle; or `focal_length`) |
//! | focal_length | string            | 50mm |
//! | fov_axis     | string            | x (y, diagonal, smaller, larger) |
//!
//! The image's aspect ratio is the bitmap's (1 for a colour). A point p at local (x, y, z), z > 0, maps to the uv of the
//! perspective sensor, uv = (½ − ½ x / (z t_x), ½ − ½ y / (z t_y)), and
//! receives nothing outside uv ∈ [0, 1]². Its incident radiance, as a delta,
//! is Mitsuba's (projector.cpp, `sample_direction`):
//!
//! L = π · scale · E(uv) / (z² · cos θ),
//!
//! cos θ = ⟨a, ω⟩ for the local +z axis a (through `to_world`) and the unit
//! direction ω from the projector to p: with d² cos³θ = z² cos θ this is
//! E / d² times the perspective camera's 1 / cos³θ importance factor, so a
//! constant image lights a plane facing it uniformly.

use super::bvh::{DirectionCone, LightBounds};
use super::LightSample;
use crate::geometry::{Aabb, SurfaceInteraction};
use crate::math::{luminance, Mat4, Spectrum, PI};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Mitsuba's `projector` emitter.
#[derive(Debug, Clone)]
pub struct ProjectorLight {
    /// Position in world space (the translation of `to_world`).
    pub position: Vec3,
    light_from_world: Mat4,
    world_from_light: Mat4,
    /// The local +z axis in world space, through `to_world` (scaled as it).
    axis: Vec3,
    /// The projected image E (irradiance on the plane z = 1).
    pub irradiance: Texture,
    /// Mitsuba's `scale`.
    pub scale: f32,
    /// tan of the half field of view along x and y.
    tan_half: Vec2,
}

impl ProjectorLight {
    /// A projector placed by `world_from_light` whose image spans
    /// tan_half.x (tan_half.y) on either side of its axis at z = 1.
    pub fn new(world_from_light: Mat4, irradiance: Texture, scale: f32, tan_half: Vec2) -> ProjectorLight {
        ProjectorLight {
            position: world_from_light.transform_point3(Vec3::ZERO),
            light_from_world: world_from_light.inverse(),
            world_from_light,
            axis: world_from_light.transform_vector3(Vec3::Z),
            irradiance,
            scale,
            tan_half,
        }
    }

    /// The image's uv of a point at light-local `local` (the perspective
    /// sensor's map), None behind the projector or outside the image.
    #[inline]
    pub fn uv(&self, local: Vec3) -> Option<Vec2> {
        if local.z <= 0.0 {
            return None;
        }
        let uv = Vec2::new(
            0.5 - 0.5 * local.x / (local.z * self.tan_half.x),
            0.5 - 0.5 * local.y / (local.z * self.tan_half.y),
        );
        (uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()).then_some(uv)
    }

    /// The direction to the projector as a delta: pdf 1, `li` as in the
    /// module's equation; None outside the image.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn sample_li(&self, p_ref: Vec3) -> Option<LightSample> {
        let local = self.light_from_world.transform_point3(p_ref);
        let uv = self.uv(local)?;
        let (wi, dist) = super::point::towards(p_ref, self.position)?;
        let e = match self.irradiance.constant() {
            Some(c) => c,
            None => self.irradiance.eval(&SurfaceInteraction::at_uv(uv)),
        };
        let cos = self.axis.dot(-wi);
        if !(cos > 0.0) || e == Spectrum::ZERO {
            return None;
        }
        let li = e * (PI * self.scale / (local.z * local.z * cos));
        Some(LightSample { wi, dist, pdf: 1.0, li, delta: true })
    }

    /// Flux through the image plane: the plane z = 1 receives π · scale ·
    /// E(uv) (the module's L times cos θ at distance 1 / cos θ), over its
    /// area 4 t_x t_y; a texture's mean stands in for E (selection only).
    pub fn power(&self) -> Spectrum {
        let e = match &self.irradiance {
            Texture::Constant(c) => *c,
            t => Spectrum::splat(t.mean()),
        };
        e * (PI * self.scale * 4.0 * self.tan_half.x * self.tan_half.y)
    }

    /// Its position and the pyramid of its image: the cone around the
    /// world axis that holds the four corner rays holds the whole (convex)
    /// pyramid, also through a `to_world` that scales unevenly.
    pub fn bounds(&self) -> LightBounds {
        let at = Aabb { min: self.position, max: self.position };
        let w = self.axis.normalize();
        let cos_e = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
            .iter()
            .map(|&(sx, sy)| {
                let c = Vec3::new(sx * self.tan_half.x, sy * self.tan_half.y, 1.0);
                w.dot(self.world_from_light.transform_vector3(c).normalize())
            })
            .fold(1.0f32, f32::min);
        let (cone, cos_e) = if w.is_finite() && cos_e > 0.0 {
            (DirectionCone { w, cos_theta: 1.0 }, cos_e)
        } else {
            (DirectionCone::ENTIRE_SPHERE, 0.0)
        };
        LightBounds::new(at, cone, cos_e, luminance(self.power()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A constant image on a plane facing the projector at distance h gives
    /// the same irradiance π · scale · E / h² at every lit point (L cos θ_i
    /// with L = π · scale · E / (h² cos θ) and θ_i = θ); nothing outside the
    /// image or behind.
    #[test]
    fn a_constant_image_lights_a_facing_plane_evenly() {
        let to_world = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)) * Mat4::from_rotation_x(0.4);
        let p = ProjectorLight::new(to_world, Spectrum::new(1.0, 2.0, 3.0).into(), 0.5, Vec2::new(0.5, 0.25));
        let h = 2.5;
        for &(x, y) in &[(0.0, 0.0), (1.0, 0.3), (-1.2, -0.6), (0.4, 0.6)] {
            let q = to_world.transform_point3(Vec3::new(x, y, h));
            let s = p.sample_li(q).expect("inside the image");
            let cos_i = s.wi.dot(-to_world.transform_vector3(Vec3::Z));
            let e = s.li * cos_i;
            let want = Spectrum::new(1.0, 2.0, 3.0) * (PI * 0.5 / (h * h));
            assert!((e - want).abs().max_element() < 1e-5 * want.max_element(), "{e} vs {want}");
            assert!(s.delta && s.pdf == 1.0);
        }
        // Outside the image (|x| > t_x h) and behind the projector.
        assert!(p.sample_li(to_world.transform_point3(Vec3::new(1.3, 0.0, h))).is_none());
        assert!(p.sample_li(to_world.transform_point3(Vec3::new(0.0, 0.0, -h))).is_none());
    }

    /// uv follows the perspective sensor: local +x is the image's left
    /// (u = 0), +y its top (v = 0).
    #[test]
    fn uv_is_the_perspective_sensors() {
        let p = ProjectorLight::new(Mat4::IDENTITY, Spectrum::ONE.into(), 1.0, Vec2::new(1.0, 0.5));
        assert_eq!(p.uv(Vec3::new(0.0, 0.0, 2.0)), Some(Vec2::splat(0.5)));
        assert_eq!(p.uv(Vec3::new(2.0, 1.0, 2.0)), Some(Vec2::ZERO));
        assert_eq!(p.uv(Vec3::new(-1.0, -0.5, 2.0)), Some(Vec2::new(0.75, 0.75)));
    }
}
