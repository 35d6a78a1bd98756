//! Warps from the unit square to disks, hemispheres, spheres, cones and
//! triangles, with their densities. Chi-square tests live in `testing::chi2`.
//! Angles go through [`crate::simd::sin_cos`], whose lanes are bitwise its
//! scalar value, so SIMD kernels built on these warps match them.

use crate::math::{safe_sqrt, INV_4PI, INV_PI, PI};
use crate::simd::sin_cos;
use glam::{Vec2, Vec3};

/// Shirley–Chiu concentric map onto the unit disk (uniform in area).
#[inline]
pub fn sample_concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, (PI / 4.0) * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    };
    let (s, c) = sin_cos(theta);
    r * Vec2::new(c, s)
}

/// Cosine-weighted hemisphere around +z (Malley's method); density cos θ / π
/// per unit solid angle.
#[inline]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_concentric_disk(u);
    Vec3::new(d.x, d.y, safe_sqrt(1.0 - d.length_squared()))
}

/// Solid-angle density of [`sample_cosine_hemisphere`] at local `w`: cos θ / π, 0 below the horizon.
#[inline]
pub fn cosine_hemisphere_pdf(w: Vec3) -> f32 {
    w.z.max(0.0) * INV_PI
}

/// Uniform direction on the +z hemisphere; density 1 / (2π).
#[inline]
pub fn sample_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = safe_sqrt(1.0 - z * z);
    let (s, c) = sin_cos(2.0 * PI * u.y);
    Vec3::new(r * c, r * s, z)
}

/// Uniform direction on the unit sphere; density 1 / (4π).
#[inline]
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = safe_sqrt(1.0 - z * z);
    let (s, c) = sin_cos(2.0 * PI * u.y);
    Vec3::new(r * c, r * s, z)
}

/// Solid-angle density of [`sample_uniform_sphere`]: 1 / (4π).
#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    INV_4PI
}

/// Uniform direction in the cone around +z with cos of the half-angle
/// `cos_max`; density 1 / (2π (1 - cos_max)).
#[inline]
pub fn sample_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_t = (1.0 - cos_max).mul_add(-u.x, 1.0);
    let sin_t = safe_sqrt(1.0 - cos_t * cos_t);
    let (s, c) = sin_cos(2.0 * PI * u.y);
    Vec3::new(sin_t * c, sin_t * s, cos_t)
}

/// Solid-angle density of [`sample_uniform_cone`] inside the cone: 1 / (2π (1 - cos_max)).
#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentrics (b1, b2) on a triangle (Heitz 2019's low-distortion
/// map would also do; this is the classic square-root form).
#[inline]
pub fn sample_uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(1.0 - su, u.y * su)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_and_hemisphere_stay_in_domain() {
        for i in 0..64 {
            for j in 0..64 {
                let u = Vec2::new(i as f32 / 63.0, j as f32 / 63.0);
                assert!(sample_concentric_disk(u).length() <= 1.0 + 1e-6);
                let w = sample_cosine_hemisphere(u);
                assert!(w.z >= 0.0 && (w.length() - 1.0).abs() < 1e-5);
                assert!((sample_uniform_sphere(u).length() - 1.0).abs() < 1e-5);
                let c = sample_uniform_cone(u, 0.8);
                assert!(c.z >= 0.8 - 1e-6);
                let b = sample_uniform_triangle(u);
                assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            }
        }
    }
}
