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

/// Clarberg's equal-area octahedral map from the unit square to the unit
/// sphere, as pbrt-v4 defines it (`EqualAreaSquareToSphere`): every region
/// of the square maps to a region of the sphere with 4π times its area, so
/// a uniform point gives a uniform direction (density 1/(4π)).
#[inline]
pub fn equal_area_square_to_sphere(p: Vec2) -> Vec3 {
    let (u, v) = (2.0 * p.x - 1.0, 2.0 * p.y - 1.0);
    let (up, vp) = (u.abs(), v.abs());
    // Signed distance from the square's diagonal |u| + |v| = 1: positive
    // inside (the upper hemisphere), negative in the folded corners.
    let signed_distance = 1.0 - (up + vp);
    let r = 1.0 - signed_distance.abs();
    let phi = (if r == 0.0 { 1.0 } else { (vp - up) / r + 1.0 }) * (PI / 4.0);
    let z = (1.0 - r * r).copysign(signed_distance);
    let (s, c) = sin_cos(phi);
    let k = r * safe_sqrt(2.0 - r * r);
    Vec3::new(c.copysign(u) * k, s.copysign(v) * k, z)
}

/// The inverse of [`equal_area_square_to_sphere`] for a unit vector `d`
/// (pbrt-v4's `EqualAreaSphereToSquare`).
#[inline]
pub fn equal_area_sphere_to_square(d: Vec3) -> Vec2 {
    let (x, y, z) = (d.x.abs(), d.y.abs(), d.z.abs());
    let r = safe_sqrt(1.0 - z);
    let (a, b) = (x.max(y), x.min(y));
    let b = if a == 0.0 { 0.0 } else { b / a };
    let mut phi = crate::simd::atan(b) * (2.0 / PI);
    if x < y {
        phi = 1.0 - phi;
    }
    let mut v = phi * r;
    let mut u = r - v;
    if d.z < 0.0 {
        (u, v) = (1.0 - v, 1.0 - u);
    }
    Vec2::new((u.copysign(d.x) + 1.0) * 0.5, (v.copysign(d.y) + 1.0) * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_area_maps_invert_each_other_and_keep_area() {
        let n = 200;
        for i in 0..=n {
            for j in 0..=n {
                let p = Vec2::new(i as f32 / n as f32, j as f32 / n as f32);
                let d = equal_area_square_to_sphere(p);
                assert!((d.length() - 1.0).abs() < 2e-6, "{p} -> {d}");
                let q = equal_area_sphere_to_square(d);
                // The square's boundary is folded (opposite edge halves meet), so
                // compare directions there.
                let back = equal_area_square_to_sphere(q);
                assert!((back - d).length() < 2e-5, "{p} -> {d} -> {q} -> {back}");
                if i > 0 && i < n && j > 0 && j < n {
                    assert!((q - p).length() < 2e-5, "{p} -> {d} -> {q}");
                }
            }
        }
        // Known points: the centre is +z, the corners are -z, edge midpoints lie on the equator.
        assert!((equal_area_square_to_sphere(Vec2::splat(0.5)) - Vec3::Z).length() < 1e-6);
        assert!((equal_area_square_to_sphere(Vec2::ZERO) + Vec3::Z).length() < 1e-6);
        assert!((equal_area_square_to_sphere(Vec2::new(1.0, 0.5)) - Vec3::X).length() < 1e-6);
        assert!((equal_area_square_to_sphere(Vec2::new(0.5, 1.0)) - Vec3::Y).length() < 1e-6);
    }

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
