//! Four triangles intersected at once: the watertight test of Woop, Benthin
//! and Wald 2013 (see [`crate::geometry::triangle`]) evaluated on SIMD lanes.
//! Every lane performs exactly the scalar test's floating-point operations
//! in the same order, so a lane's hit distance is bitwise the scalar one.

use crate::geometry::triangle::RayShear;
use crate::geometry::Ray;
use glam::{BVec4A, Vec3, Vec4};

/// Vertices of four triangles, structure of arrays: `v[k][c]` holds
/// coordinate `c` (x, y, z) of vertex `k` for each lane. Unused lanes hold
/// NaN, which fails every comparison and so never hits.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
pub struct Tri4 {
    /// `v[vertex][coordinate]`, one lane per triangle.
    pub v: [[Vec4; 3]; 3],
}

impl Tri4 {
    /// Packs up to four triangles.
    pub fn new(tris: &[[Vec3; 3]]) -> Tri4 {
        debug_assert!(!tris.is_empty() && tris.len() <= 4);
        let mut a = [[[f32::NAN; 4]; 3]; 3];
        for (lane, t) in tris.iter().enumerate() {
            for k in 0..3 {
                for c in 0..3 {
                    a[k][c][lane] = t[k][c];
                }
            }
        }
        Tri4 { v: a.map(|k| k.map(Vec4::from_array)) }
    }

    /// Number of real (non-padding) triangles (a block is never empty).
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> usize {
        (0..4).filter(|&l| !self.v[0][0].to_array()[l].is_nan()).count()
    }

    /// The vertices of one lane.
    pub fn lane(&self, l: usize) -> [Vec3; 3] {
        self.v.map(|k| Vec3::new(k[0].to_array()[l], k[1].to_array()[l], k[2].to_array()[l]))
    }
}

/// Per-ray constants of the lane test, built once per traversal.
pub struct RayLanes {
    o: [Vec4; 3],
    sx: Vec4,
    sy: Vec4,
    sz: Vec4,
}

impl RayLanes {
    /// Splats the ray origin and the shear constants `sh` of `ray.d` over four lanes.
    #[inline(always)]
    pub fn new(ray: &Ray, sh: &RayShear) -> RayLanes {
        RayLanes {
            o: [Vec4::splat(ray.o.x), Vec4::splat(ray.o.y), Vec4::splat(ray.o.z)],
            sx: Vec4::splat(sh.sx),
            sy: Vec4::splat(sh.sy),
            sz: Vec4::splat(sh.sz),
        }
    }
}

/// Hits of the four lanes with 0 < t < `t_max`: a bit mask of the lanes
/// hit, their distances and barycentrics (b1, b2).
#[inline(always)]
pub fn intersect4<const KZ: usize>(r: &RayLanes, t_max: f32, tri: &Tri4) -> (u32, Vec4, Vec4, Vec4) {
    let kx = if KZ == 2 { 0 } else { KZ + 1 };
    let ky = if kx == 2 { 0 } else { kx + 1 };
    // Translate to the origin, permute so z is dominant, shear (per lane,
    // the scalar test's operations in its order).
    let p = |k: usize| {
        let (x, y, z) = (tri.v[k][kx] - r.o[kx], tri.v[k][ky] - r.o[ky], tri.v[k][KZ] - r.o[KZ]);
        (x + r.sx * z, y + r.sy * z, z)
    };
    let (p0x, p0y, p0z) = p(0);
    let (p1x, p1y, p1z) = p(1);
    let (p2x, p2y, p2z) = p(2);
    let mut e0 = p1x * p2y - p1y * p2x;
    let mut e1 = p2x * p0y - p2y * p0x;
    let mut e2 = p0x * p1y - p0y * p1x;
    let zero = Vec4::ZERO;
    let exact = (e0.cmpeq(zero) | e1.cmpeq(zero) | e2.cmpeq(zero)).bitmask();
    if exact != 0 {
        // Rare: an edge function is exactly zero; redo those lanes in f64.
        let (mut a0, mut a1, mut a2) = (e0.to_array(), e1.to_array(), e2.to_array());
        let (x0, y0, x1, y1, x2, y2) =
            (p0x.to_array(), p0y.to_array(), p1x.to_array(), p1y.to_array(), p2x.to_array(), p2y.to_array());
        for l in 0..4 {
            if exact & (1 << l) != 0 {
                a0[l] = (x1[l] as f64 * y2[l] as f64 - y1[l] as f64 * x2[l] as f64) as f32;
                a1[l] = (x2[l] as f64 * y0[l] as f64 - y2[l] as f64 * x0[l] as f64) as f32;
                a2[l] = (x0[l] as f64 * y1[l] as f64 - y0[l] as f64 * x1[l] as f64) as f32;
            }
        }
        (e0, e1, e2) = (Vec4::from_array(a0), Vec4::from_array(a1), Vec4::from_array(a2));
    }
    let any_neg = e0.cmplt(zero) | e1.cmplt(zero) | e2.cmplt(zero);
    let any_pos = e0.cmpgt(zero) | e1.cmpgt(zero) | e2.cmpgt(zero);
    let det = e0 + e1 + e2;
    let t_scaled = (e0 * p0z + e1 * p1z + e2 * p2z) * r.sz;
    let tmax_det = Vec4::splat(t_max) * det;
    let neg_ok = det.cmplt(zero) & !(t_scaled.cmpge(zero) | t_scaled.cmplt(tmax_det));
    let pos_ok = det.cmpgt(zero) & !(t_scaled.cmple(zero) | t_scaled.cmpgt(tmax_det));
    let mut valid: BVec4A = !(any_neg & any_pos) & (neg_ok | pos_ok);
    if !valid.any() {
        return (0, zero, zero, zero);
    }
    let inv_det = Vec4::ONE / det;
    let t = t_scaled * inv_det;
    valid &= t.cmpgt(zero) & t.cmplt(Vec4::splat(t_max));
    (valid.bitmask(), t, e1 * inv_det, e2 * inv_det)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle::intersect_triangle;
    use crate::sampling::rng::{hash_words, to_unit_f32};

    fn rnd(i: u64, k: u64) -> f32 {
        to_unit_f32(hash_words(&[i, 4, k]))
    }

    /// Each lane gives bitwise the scalar test's answer, for rays of every
    /// dominant axis, partial blocks, and rays through shared edges.
    #[test]
    fn lanes_match_the_scalar_test() {
        let mut hits = 0;
        for i in 0..4000u64 {
            let n = 1 + (i % 4) as usize;
            let mut tris: Vec<[Vec3; 3]> = (0..n as u64)
                .map(|k| {
                    let c = Vec3::new(rnd(i * 8 + k, 0), rnd(i * 8 + k, 1), rnd(i * 8 + k, 2));
                    [0, 1, 2].map(|v| c + Vec3::new(rnd(i * 8 + k, 3 + v), rnd(i * 8 + k, 6 + v), rnd(i, 9 + v)) - 0.5)
                })
                .collect();
            if i % 5 == 0 && n >= 2 {
                // Two triangles sharing an edge, the ray aimed at the edge.
                tris[1] = [tris[0][0], tris[0][1], tris[0][0] + Vec3::new(0.1, -0.7, 0.4)];
            }
            let o = Vec3::new(rnd(i, 20), rnd(i, 21), rnd(i, 22)) * 3.0 - 1.5;
            let target = if i % 5 == 0 { tris[0][0].lerp(tris[0][1], rnd(i, 23)) } else { tris[0][0] };
            let d = (target - o).normalize();
            let ray = Ray::new(o, d, if i % 3 == 0 { 1.0 } else { f32::INFINITY });
            let sh = RayShear::new(d);
            let block = Tri4::new(&tris);
            assert_eq!(block.len(), n);
            let lanes = RayLanes::new(&ray, &sh);
            let (mask, t, b1, b2) = match sh.kz {
                0 => intersect4::<0>(&lanes, ray.t_max, &block),
                1 => intersect4::<1>(&lanes, ray.t_max, &block),
                _ => intersect4::<2>(&lanes, ray.t_max, &block),
            };
            for (l, tri) in tris.iter().enumerate() {
                let scalar = intersect_triangle(&ray, &sh, tri);
                assert_eq!(mask & (1 << l) != 0, scalar.is_some(), "ray {i} lane {l}");
                if let Some((ts, s1, s2)) = scalar {
                    hits += 1;
                    assert_eq!(t.to_array()[l].to_bits(), ts.to_bits(), "ray {i} lane {l}");
                    assert_eq!(b1.to_array()[l].to_bits(), s1.to_bits());
                    assert_eq!(b2.to_array()[l].to_bits(), s2.to_bits());
                }
            }
            assert_eq!(mask >> n, 0, "padding lanes never hit");
        }
        assert!(hits > 1000, "{hits}");
    }
}
