//! Watertight ray/triangle intersection (Woop, Benthin and Wald 2013,
//! "Watertight Ray/Triangle Intersection"; pbrt-v4 §6.5.3): rays through an
//! edge or vertex shared by two triangles hit at least one of them.

use super::Ray;
use glam::Vec3;

/// Per-ray data for the shear transform, computed once per traversal.
#[derive(Debug, Clone, Copy)]
pub struct RayShear {
    /// The axis of the largest |d| component, which becomes z (kx, ky follow it cyclically).
    pub kz: usize,
    /// Shear of x: −d_kx / d_kz (Woop et al. 2013).
    pub sx: f32,
    /// Shear of y: −d_ky / d_kz.
    pub sy: f32,
    /// Scale of z: 1 / d_kz.
    pub sz: f32,
}

impl RayShear {
    /// The shear of ray direction `d` (need not be unit length).
    #[inline]
    pub fn new(d: Vec3) -> RayShear {
        let ad = d.abs();
        let kz = if ad.x > ad.y {
            if ad.x > ad.z {
                0
            } else {
                2
            }
        } else if ad.y > ad.z {
            1
        } else {
            2
        };
        let kx = if kz == 2 { 0 } else { kz + 1 };
        let ky = if kx == 2 { 0 } else { kx + 1 };
        let dz = d[kz];
        RayShear { kz, sx: -d[kx] / dz, sy: -d[ky] / dz, sz: 1.0 / dz }
    }
}

/// Returns (t, b1, b2) for a hit with 0 < t < ray.t_max; the barycentric
/// weights are those of vertices 1 and 2.
#[inline]
pub fn intersect_triangle(ray: &Ray, sh: &RayShear, v: &[Vec3; 3]) -> Option<(f32, f32, f32)> {
    match sh.kz {
        0 => intersect_triangle_k::<0>(ray, sh, v),
        1 => intersect_triangle_k::<1>(ray, sh, v),
        _ => intersect_triangle_k::<2>(ray, sh, v),
    }
}

/// [`intersect_triangle`] for a ray whose dominant axis `KZ` is known at
/// compile time, so the axis permutation costs nothing (traversal picks the
/// instance once per ray).
#[inline(always)]
pub fn intersect_triangle_k<const KZ: usize>(ray: &Ray, sh: &RayShear, v: &[Vec3; 3]) -> Option<(f32, f32, f32)> {
    debug_assert_eq!(KZ, sh.kz);
    let kx = if KZ == 2 { 0 } else { KZ + 1 };
    let ky = if kx == 2 { 0 } else { kx + 1 };
    // Translate to the ray origin, permute so z is the dominant direction, shear.
    let p0t = (v[0] - ray.o).to_array();
    let p1t = (v[1] - ray.o).to_array();
    let p2t = (v[2] - ray.o).to_array();
    let (p0z, p1z, p2z) = (p0t[KZ], p1t[KZ], p2t[KZ]);
    let p0x = p0t[kx] + sh.sx * p0z;
    let p0y = p0t[ky] + sh.sy * p0z;
    let p1x = p1t[kx] + sh.sx * p1z;
    let p1y = p1t[ky] + sh.sy * p1z;
    let p2x = p2t[kx] + sh.sx * p2z;
    let p2y = p2t[ky] + sh.sy * p2z;

    // Edge functions; fall back to f64 when a value is exactly zero.
    let mut e0 = p1x * p2y - p1y * p2x;
    let mut e1 = p2x * p0y - p2y * p0x;
    let mut e2 = p0x * p1y - p0y * p1x;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        e0 = (p1x as f64 * p2y as f64 - p1y as f64 * p2x as f64) as f32;
        e1 = (p2x as f64 * p0y as f64 - p2y as f64 * p0x as f64) as f32;
        e2 = (p0x as f64 * p1y as f64 - p0y as f64 * p1x as f64) as f32;
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return None;
    }
    // Scaled hit distance, compared against the range before dividing.
    let t_scaled = (e0 * p0z + e1 * p1z + e2 * p2z) * sh.sz;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < ray.t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > ray.t_max * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t > 0.0 && t < ray.t_max) {
        return None;
    }
    Some((t, e1 * inv_det, e2 * inv_det))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(o: Vec3, d: Vec3, v: &[Vec3; 3]) -> Option<(f32, f32, f32)> {
        let r = Ray::new(o, d, f32::INFINITY);
        intersect_triangle(&r, &RayShear::new(d), v)
    }

    #[test]
    fn hits_inside_and_misses_outside() {
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let (t, b1, b2) = hit(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, &v).unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (b1 - 0.25).abs() < 1e-6 && (b2 - 0.25).abs() < 1e-6);
        // Both faces are hit (culling is the BSDF's business).
        assert!(hit(Vec3::new(0.25, 0.25, -1.0), Vec3::Z, &v).is_some());
        assert!(hit(Vec3::new(0.75, 0.75, 1.0), -Vec3::Z, &v).is_none());
        assert!(hit(Vec3::new(0.25, 0.25, 1.0), Vec3::Z, &v).is_none(), "behind the origin");
    }

    #[test]
    fn shared_edges_are_watertight() {
        // Two triangles sharing the diagonal of the unit square; rays exactly
        // through the diagonal must hit at least one of them.
        let a = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)];
        let b = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        for i in 1..100 {
            let s = i as f32 / 100.0;
            let o = Vec3::new(s, s, 1.0);
            assert!(hit(o, -Vec3::Z, &a).is_some() || hit(o, -Vec3::Z, &b).is_some());
            // An oblique ray aimed at the same diagonal point.
            let d = Vec3::new(0.3, -0.2, -1.0);
            let p = Vec3::new(s, s, 0.0);
            assert!(hit(p - d, d, &a).is_some() || hit(p - d, d, &b).is_some());
        }
    }
}
