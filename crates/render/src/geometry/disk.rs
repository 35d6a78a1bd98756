//! Mitsuba's `disk`: the unit disk in the local z = 0 plane, normal +z
//! (unless flipped), placed by `to_world`. Rays are intersected in object
//! space; uv is Mitsuba's polar parameterisation (r, φ/2π).

use super::{Aabb, Ray};
use crate::math::{fast, PI};
use crate::sampling::warp;
use glam::{Mat4, Vec2, Vec3};

/// The unit disk placed by a transform (Mitsuba's `disk`).
#[derive(Debug, Clone)]
pub struct Disk {
    /// Mitsuba's `to_world`: places the unit disk in z = 0.
    pub world_from_object: Mat4,
    object_from_world: Mat4,
    /// The front normal, in world space.
    pub n: Vec3,
    area: f32,
}

impl Disk {
    /// The disk placed by `world_from_object`; `flip` reverses the normal
    /// (Mitsuba's `flip_normals`). The area follows the transform's scale.
    pub fn new(world_from_object: Mat4, flip: bool) -> Disk {
        let ax = world_from_object.transform_vector3(Vec3::X);
        let ay = world_from_object.transform_vector3(Vec3::Y);
        let c = ax.cross(ay);
        let n = if flip { -c.normalize() } else { c.normalize() };
        Disk { world_from_object, object_from_world: world_from_object.inverse(), n, area: PI * c.length() }
    }

    /// The inverse of `to_world`, into which [`Self::intersect`] takes rays
    /// (the packet traversal repeats its operations per lane).
    pub fn object_from_world(&self) -> &Mat4 {
        &self.object_from_world
    }

    /// World-space area: π·|X × Y|, X and Y the transformed local axes.
    pub fn area(&self) -> f32 {
        self.area
    }

    /// The box around the placed square [-1, 1]².
    pub fn bounds(&self) -> Aabb {
        let pts: Vec<Vec3> = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
            .iter()
            .map(|&(x, y)| self.world_from_object.transform_point3(Vec3::new(x, y, 0.0)))
            .collect();
        Aabb::from_points(&pts)
    }

    /// Closest hit with 0 < t < ray.t_max: (t, the hit's local (x, y)).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, Vec2)> {
        let o = self.object_from_world.transform_point3(ray.o);
        let d = self.object_from_world.transform_vector3(ray.d);
        let t = -o.z / d.z;
        if !(t > 0.0 && t < ray.t_max) {
            return None;
        }
        let p = o + t * d;
        (p.x * p.x + p.y * p.y <= 1.0).then_some((t, Vec2::new(p.x, p.y)))
    }

    /// (p, normal, uv, dp/du, dp/dv) at the local point `local` of a hit.
    /// With `param` false (see [`Shape::interaction_with`](super::Shape::interaction_with))
    /// uv and dp/dv are zero and dp/du is the radial direction only.
    #[inline]
    pub fn interaction(&self, local: Vec2, param: bool) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        let (m, n) = (&self.world_from_object, self.n);
        let p = m.transform_point3(Vec3::new(local.x, local.y, 0.0));
        if !param {
            // dp/du is radial: the direction of the hit from the centre.
            let dpdu = m.transform_vector3(Vec3::new(local.x, local.y, 0.0));
            return (p, n, Vec2::ZERO, dpdu, Vec3::ZERO);
        }
        let r2 = local.length_squared();
        let inv_r = if r2 != 0.0 { 1.0 / r2.sqrt() } else { 0.0 };
        let r = r2 * inv_r;
        let mut v = fast::atan2(local.y, local.x) * (0.5 / PI);
        if v < 0.0 {
            v += 1.0;
        }
        let (c, s) = (local.x * inv_r, local.y * inv_r);
        let dpdu = m.transform_vector3(Vec3::new(c, s, 0.0));
        let dpdv = m.transform_vector3(Vec3::new(-s, c, 0.0)) * (2.0 * PI * r);
        (p, n, Vec2::new(r, v), dpdu, dpdv)
    }

    /// Uniform point on the disk: (point, front normal, density per unit area).
    pub fn sample_area(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        let q = warp::sample_concentric_disk(u);
        (self.world_from_object.transform_point3(Vec3::new(q.x, q.y, 0.0)), self.n, 1.0 / self.area)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shape::tests::{check, hit};
    use crate::geometry::Shape;

    #[test]
    fn disk_area_follows_its_transform() {
        let m = Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0));
        assert!((Disk::new(m, false).area() - 6.0 * PI).abs() < 1e-4);
    }

    // {'type': 'disk', 'to_world': T.translate([0,0,1]).scale([2,2,1])}; {'type': 'disk', 'flip_normals': True}
    #[test]
    fn disk_uv_and_frame_match_mitsuba() {
        let to_world = Mat4::from_translation(Vec3::Z) * Mat4::from_scale(Vec3::new(2.0, 2.0, 1.0));
        let s = Shape::disk(to_world, false);
        let si = hit(&s, [0.6, -0.8, 5.0], [0.0, 0.0, -1.0]);
        check(&si, [0.5, 0.8524163], [1.2, -1.6, 0.0], [5.026549, 3.7699115, 0.0], [0.6, -0.8, 0.0], [0.0, 0.0, 1.0]);
        let si = hit(&s, [-1.0, 0.5, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.559017, 0.4262082],
            [-1.7888545, 0.89442724, 0.0],
            [-3.141593, -6.283186, 0.0],
            [-0.89442724, 0.44721362, 0.0],
            [0.0, 0.0, 1.0],
        );
        let si = hit(&Shape::disk(Mat4::IDENTITY, true), [0.3, 0.4, 5.0], [0.0, 0.0, -1.0]);
        check(&si, [0.5, 0.14758368], [0.6, 0.8, 0.0], [-2.5132744, 1.8849558, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, -1.0]);
        assert!((si.sh_frame.t - Vec3::new(0.8, -0.6, 0.0)).length() < 1e-5);
    }
}
