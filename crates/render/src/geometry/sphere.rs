//! Mitsuba's `sphere`: a centre and radius (its `to_world` folded in, the
//! rotation kept to orient the uv parameterisation), normals outwards
//! unless flipped. Rays are intersected with the careful discriminant of
//! Haines et al. 2019; points seen from outside are sampled in the cone the
//! sphere subtends (pbrt-v4 §6.2.4).

use super::{Aabb, Ray, ShapeSample};
use crate::math::{fast, safe_sqrt, Frame, Mat3, PI};
use crate::sampling::warp;
use glam::{Vec2, Vec3};

/// A sphere in world space (Mitsuba's `sphere` with its `to_world` applied).
#[derive(Debug, Clone)]
pub struct Sphere {
    /// Centre, in world space.
    pub center: Vec3,
    /// Radius in world units (non-negative).
    pub radius: f32,
    /// The rotation part of `to_world`, which orients the uv parameterisation.
    pub rot: Mat3,
    /// Normals point inwards (Mitsuba's `flip_normals`).
    pub flip: bool,
}

impl Sphere {
    /// A sphere whose local frame is rotated by `rot` (the orthonormal part
    /// of Mitsuba's `to_world`; it orients the uv parameterisation only).
    pub fn new(center: Vec3, radius: f32, rot: Mat3, flip: bool) -> Sphere {
        Sphere { center, radius: radius.abs(), rot, flip }
    }

    /// World-space bounding box.
    pub fn bounds(&self) -> Aabb {
        Aabb { min: self.center - Vec3::splat(self.radius), max: self.center + Vec3::splat(self.radius) }
    }

    /// Surface area, 4πr².
    pub fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    /// Closest hit with 0 < t < ray.t_max (from inside, the far side), with
    /// the numerically careful discriminant of "Precision Improvements for
    /// Ray/Sphere Intersection" (Haines et al. 2019).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<f32> {
        let f = ray.o - self.center;
        let a = ray.d.length_squared();
        let b = -f.dot(ray.d);
        let l = f + (b / a) * ray.d;
        let disc = a * (self.radius * self.radius - l.length_squared());
        if disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let q = if b > 0.0 { b + sq } else { b - sq };
        let (mut t0, mut t1) = (q / a, f.length_squared().mul_add(1.0, -self.radius * self.radius) / q);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t = if t0 > 0.0 { t0 } else { t1 };
        (t > 0.0 && t < ray.t_max).then_some(t)
    }

    /// (p, normal, uv, dp/du, dp/dv) at the hit `t` of `ray`: Mitsuba's
    /// spherical coordinates in the sphere's local frame. With `param`
    /// false (see [`Shape::interaction_with`](super::Shape::interaction_with))
    /// uv and dp/dv are zero and dp/du is only a tangent.
    #[inline]
    pub fn interaction(&self, ray: &Ray, t: f32, param: bool) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        let (center, radius, rot) = (self.center, self.radius, self.rot);
        let mut n = (ray.at(t) - center).normalize();
        // Re-project onto the surface to limit floating-point drift.
        let p = center + n * radius;
        let (tex, dpdu, dpdv) = if param {
            let l = rot.transpose() * n;
            let theta = fast::acos(l.z);
            let mut phi = fast::atan2(l.y, l.x);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            let tex = Vec2::new(phi * (0.5 / PI), theta * (1.0 / PI));
            let rd = (l.x * l.x + l.y * l.y).sqrt();
            let dpdv_l = if rd == 0.0 { Vec3::X } else { Vec3::new(l.z * l.x / rd, l.z * l.y / rd, -rd) };
            let dpdu = rot * Vec3::new(-l.y, l.x, 0.0) * (radius * 2.0 * PI);
            (tex, dpdu, rot * dpdv_l * (radius * PI))
        } else {
            // dp/du ∝ rot·(z × l) = (rot·z) × n, without the angles.
            (Vec2::ZERO, rot.z_axis.cross(n), Vec3::ZERO)
        };
        if self.flip {
            n = -n;
        }
        (p, n, tex, dpdu, dpdv)
    }

    /// Uniform point on the surface: (point, front normal, density per unit area).
    pub fn sample_area(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        let d = warp::sample_uniform_sphere(u);
        let n = if self.flip { -d } else { d };
        (self.center + d * self.radius, n, 1.0 / self.area())
    }

    /// A point of the cone the sphere subtends at `p_ref`, with its density
    /// per unit solid angle; `None` when `p_ref` is inside the sphere (or on
    /// it), where the area is sampled instead.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn sample_cone(&self, p_ref: Vec3, u: Vec2) -> Option<ShapeSample> {
        let (center, radius) = (self.center, self.radius);
        let dc2 = p_ref.distance_squared(center);
        let r2 = radius * radius;
        if !(dc2 > r2 * 1.0001) {
            return None;
        }
        let sin2_max = r2 / dc2;
        let sin_max = sin2_max.sqrt();
        let cos_max = safe_sqrt(1.0 - sin2_max);
        let mut one_minus_cos_max = 1.0 - cos_max;
        let mut cos_t = (cos_max - 1.0) * u.x + 1.0;
        let mut sin2_t = 1.0 - cos_t * cos_t;
        if sin2_max < 0.000_685_23 {
            // Small cones: Taylor expansion avoids cancellation in 1 - cos.
            sin2_t = sin2_max * u.x;
            cos_t = (1.0 - sin2_t).sqrt();
            one_minus_cos_max = sin2_max / 2.0;
        }
        // Angle alpha at the sphere centre between -wc and the sampled point.
        let cos_alpha = sin2_t / sin_max + cos_t * safe_sqrt(1.0 - sin2_t / sin2_max);
        let sin_alpha = safe_sqrt(1.0 - cos_alpha * cos_alpha);
        let (sin_phi, cos_phi) = crate::simd::sin_cos(u.y * 2.0 * PI);
        let w = Vec3::new(sin_alpha * cos_phi, sin_alpha * sin_phi, cos_alpha);
        let frame = Frame::from_normal((center - p_ref).normalize());
        let nd = frame.to_world(-w);
        let p = center + nd * radius;
        let n = if self.flip { -nd } else { nd };
        Some(ShapeSample { p, n, pdf: 1.0 / (2.0 * PI * one_minus_cos_max), prim: 0, param: Vec2::ZERO })
    }

    /// The density of [`Sphere::sample_cone`] from `p_ref` (uniform over
    /// the cone); `None` where it does not sample.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn pdf_cone(&self, p_ref: Vec3) -> Option<f32> {
        let dc2 = p_ref.distance_squared(self.center);
        let r2 = self.radius * self.radius;
        if !(dc2 > r2 * 1.0001) {
            return None;
        }
        let sin2_max = r2 / dc2;
        let one_minus_cos_max = if sin2_max < 0.000_685_23 { sin2_max / 2.0 } else { 1.0 - safe_sqrt(1.0 - sin2_max) };
        Some(1.0 / (2.0 * PI * one_minus_cos_max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::shape::tests::{check, hit};
    use crate::geometry::Shape;

    #[test]
    fn sphere_hits_front_and_back() {
        let s = |r: f32| Sphere::new(Vec3::ZERO, r, Mat3::IDENTITY, false);
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, f32::INFINITY);
        let t = s(1.0).intersect(&r).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        let inside = Ray::new(Vec3::ZERO, Vec3::X, f32::INFINITY);
        assert!((s(2.0).intersect(&inside).unwrap() - 2.0).abs() < 1e-5);
        let miss = Ray::new(Vec3::new(0.0, 1.5, -5.0), Vec3::Z, f32::INFINITY);
        assert!(s(1.0).intersect(&miss).is_none());
    }

    #[test]
    fn sphere_cone_sample_pdf_matches_pdf_direction() {
        let s = Shape::sphere(Vec3::new(0.0, 0.0, 3.0), 0.5, false);
        let p_ref = Vec3::ZERO;
        let smp = s.sample_direction(p_ref, Vec2::new(0.3, 0.7)).unwrap();
        assert!((smp.p.distance(Vec3::new(0.0, 0.0, 3.0)) - 0.5).abs() < 1e-4);
        assert!(smp.n.dot(p_ref - smp.p) > 0.0, "sampled points face the reference");
        assert!((s.pdf_direction(p_ref, smp.p, smp.n) - smp.pdf).abs() < 1e-3 * smp.pdf);
    }

    // {'type': 'sphere', 'center': [1, 2, 3], 'radius': 2}; flip_normals; and
    // to_world = T.translate([1,0,0]).rotate([0,0,1],30).rotate([1,0,0],50).scale(1.5)
    #[test]
    fn sphere_uv_and_frame_match_mitsuba() {
        let s = Shape::sphere(Vec3::new(1.0, 2.0, 3.0), 2.0, false);
        let si = hit(&s, [1.5, 2.5, 10.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.12500007, 0.11502672],
            [-3.1415925, 3.1415925, 0.0],
            [4.155936, 4.155936, -2.2214413],
            [-0.70710683, 0.70710683, 0.0],
            [0.25, 0.25, 0.93541443],
        );
        let si = hit(&s, [10.0, 2.3, 2.5], [-1.0, 0.0, 0.0]);
        check(
            &si,
            [0.02475589, 0.58043057],
            [-1.8849552, 12.020441, 0.0],
            [-1.5518318, -0.24334662, -6.083668],
            [-0.15491933, 0.9879272, 0.0],
            [0.9565563, 0.15, -0.25],
        );
        let si = hit(&Shape::sphere(Vec3::ZERO, 1.0, true), [0.3, -0.4, 10.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.8524163, 0.16666672],
            [2.513275, 1.8849565, 0.0],
            [1.6324195, -2.176559, -1.570797],
            [0.8, 0.6, 0.0],
            [-0.3, 0.4, -0.8660254],
        );
        assert!((si.n - si.sh_frame.n).length() < 1e-6);
        let rot = Mat3::from_rotation_z(30f32.to_radians()) * Mat3::from_rotation_x(50f32.to_radians());
        let s = Shape::sphere_rotated(Vec3::X, 1.5, rot, false);
        let si = hit(&s, [1.3, 0.2, 10.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.20095031, 0.29032847],
            [-6.8769627, -2.2924361, 1.7318254],
            [-1.5529681, 4.4396925, -0.2898639],
            [-0.92271155, -0.30758598, 0.23236638],
            [0.2, 0.13333331, 0.97068137],
        );
    }
}
