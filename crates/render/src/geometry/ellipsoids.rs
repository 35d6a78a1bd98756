//! Mitsuba's `ellipsoids` and `ellipsoidsmesh`: clouds of anisotropic
//! ellipsoids, each a centre, three radii and a rotation.
//!
//! As in Mitsuba 3.9.1 (`src/shapes/ellipsoids.cpp`, `ellipsoidsmesh.cpp`):
//!
//! - `ellipsoids` intersects each ellipsoid in closed form and culls back
//!   faces: a ray hits an ellipsoid only where it enters it (the near root,
//!   0 < t < t_max), so a ray from inside sees nothing of it. The normal is
//!   the gradient of the implicit function, R (l / s²) for the local point
//!   l = Rᵀ (p − c); there is no uv parameterisation (uv = 0, dp/du = 0, and
//!   the shading frame is Mitsuba's arbitrary frame about the normal).
//! - `ellipsoidsmesh` replaces each ellipsoid by a shell of flat triangles
//!   (an icosahedron by default) scaled to enclose it, and also culls back
//!   faces (Mitsuba's Embree filter drops hits with d · N_g > 0). Its hits
//!   are those of a mesh without normals or uvs (barycentric uv, face normal).

use super::{Aabb, Ray, TriangleMesh};
use glam::{DMat3, DVec3, Mat3, Vec3};

/// One ellipsoid: centre, radii (its `extent` folded in) and the rotation
/// from its local frame to world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ellipsoid {
    /// Centre in world space.
    pub center: Vec3,
    /// Radii along the local axes (positive).
    pub scale: Vec3,
    /// Local-to-world rotation.
    pub rot: Mat3,
}

/// The rotation matrix of the unit quaternion (x, y, z, w) (Dr.Jit's `quat_to_matrix`).
pub fn quat_to_matrix(q: [f64; 4]) -> DMat3 {
    let [x, y, z, w] = q;
    let (xx, yy, zz, xy, xz, yz, xw, yw, zw) = (x * x, y * y, z * z, x * y, x * z, y * z, x * w, y * w, z * w);
    DMat3::from_cols(
        DVec3::new(1.0 - 2.0 * (yy + zz), 2.0 * (xy + zw), 2.0 * (xz - yw)),
        DVec3::new(2.0 * (xy - zw), 1.0 - 2.0 * (xx + zz), 2.0 * (yz + xw)),
        DVec3::new(2.0 * (xz + yw), 2.0 * (yz - xw), 1.0 - 2.0 * (xx + yy)),
    )
}

impl Ellipsoid {
    /// The ellipsoid's axis-aligned box: half-extent along world axis k is
    /// sqrt(Σ_j (R_kj s_j)²), widened by a few ulps.
    pub fn bounds(&self) -> Aabb {
        let r = self.rot.as_dmat3();
        let s = self.scale.as_dvec3();
        let half = DVec3::new((r.row(0) * s).length(), (r.row(1) * s).length(), (r.row(2) * s).length());
        let c = self.center.as_dvec3();
        let pad = 1e-6 * (c.abs().max_element() + half.max_element());
        Aabb { min: (c - half - DVec3::splat(pad)).as_vec3(), max: (c + half + DVec3::splat(pad)).as_vec3() }
    }

    /// The entry hit 0 < t < ray.t_max, or None (a miss, or a ray starting
    /// inside: Mitsuba culls the back face). Double precision, in the
    /// ellipsoid's unit-sphere space, from the foot of the perpendicular
    /// from the centre (Mitsuba's plane trick).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<f32> {
        let rt = self.rot.as_dmat3().transpose();
        let inv_s = self.scale.as_dvec3().recip();
        let o = rt * (ray.o.as_dvec3() - self.center.as_dvec3()) * inv_s;
        let d = rt * ray.d.as_dvec3() * inv_s;
        let a = d.length_squared();
        if a == 0.0 || !a.is_finite() {
            return None;
        }
        let t_foot = -o.dot(d) / a;
        let f = o + d * t_foot;
        let c = f.length_squared() - 1.0;
        if c > 0.0 {
            return None; // the line passes outside
        }
        // |f + d u|² = 1 with f ⟂ d: u = ±sqrt(-c / a).
        let t_near = t_foot - (-c / a).sqrt();
        let t = t_near as f32;
        (t_near > 0.0 && t > 0.0 && t < ray.t_max).then_some(t)
    }

    /// (p, normal) of the hit at `t`: p = o + t d (as Mitsuba), the normal
    /// R (l / s²) normalised.
    pub fn interaction(&self, ray: &Ray, t: f32) -> (Vec3, Vec3) {
        let p = ray.o + ray.d * t;
        let l = self.rot.transpose() * (p - self.center);
        let n = (self.rot * (l / (self.scale * self.scale))).normalize();
        (p, n)
    }
}

/// Mitsuba's `ellipsoids`: a cloud of analytic ellipsoids, one BVH
/// primitive each.
#[derive(Debug, Clone)]
pub struct Ellipsoids {
    /// The ellipsoids, in file order.
    pub items: Vec<Ellipsoid>,
}

/// The shells `ellipsoidsmesh` can wrap each ellipsoid in (Mitsuba's `shell`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shell {
    /// 20 triangles (Mitsuba's default, `ico_sphere`).
    IcoSphere,
    /// 12 triangles (`box`).
    Box,
    /// 72 triangles (`uv_sphere`).
    UvSphere,
}

impl Shell {
    /// The template's vertices and faces (Mitsuba 3.9.1's tables).
    fn template(self) -> (&'static [[f32; 3]], &'static [[u32; 3]]) {
        match self {
            Shell::IcoSphere => (&ICO_VERTICES, &ICO_FACES),
            Shell::Box => (&BOX_VERTICES, &BOX_FACES),
            Shell::UvSphere => (&UV_VERTICES, &UV_FACES),
        }
    }

    /// The shell mesh of `items`: the template, scaled so that every vertex
    /// and every face centre lies on or outside the unit sphere (so the
    /// shell encloses it, as Mitsuba scales it), placed by each ellipsoid's
    /// translate · rotate · scale. Vertices are rounded to f32 as Mitsuba stores them.
    pub fn mesh(self, items: &[Ellipsoid]) -> TriangleMesh {
        let (verts, faces) = self.template();
        let v: Vec<Vec3> = verts.iter().map(|p| Vec3::from_array(*p)).collect();
        let mut scaling = f32::MAX;
        for f in faces {
            let [a, b, c] = f.map(|i| v[i as usize]);
            scaling = scaling.min(a.length()).min(b.length()).min(c.length()).min(((a + b + c) / 3.0).length());
        }
        let v: Vec<Vec3> = v.iter().map(|p| *p / scaling).collect();
        let mut m = TriangleMesh::default();
        for e in items {
            let base = m.positions.len() as u32;
            let (r, s, c) = (e.rot.as_dmat3(), e.scale.as_dvec3(), e.center.as_dvec3());
            m.positions.extend(v.iter().map(|p| (c + r * (s * p.as_dvec3())).as_vec3()));
            m.indices.extend(faces.iter().map(|f| f.map(|i| i + base)));
        }
        m
    }
}

// Mitsuba 3.9.1's shell templates (src/shapes/ellipsoidsmesh.cpp).
#[rustfmt::skip]
const ICO_VERTICES: [[f32; 3]; 12] = [
    [0.0, -1.0, 0.0], [0.7236, -0.447215, 0.52572], [-0.276385, -0.447215, 0.85064],
    [-0.894425, -0.447215, 0.0], [-0.276385, -0.447215, -0.85064], [0.7236, -0.447215, -0.52572],
    [0.276385, 0.447215, 0.85064], [-0.7236, 0.447215, 0.52572], [-0.7236, 0.447215, -0.52572],
    [0.276385, 0.447215, -0.85064], [0.894425, 0.447215, 0.0], [0.0, 1.0, 0.0],
];
#[rustfmt::skip]
const ICO_FACES: [[u32; 3]; 20] = [
    [0, 1, 2], [1, 0, 5], [0, 2, 3], [0, 3, 4], [0, 4, 5], [1, 5, 10], [2, 1, 6], [3, 2, 7], [4, 3, 8], [5, 4, 9],
    [1, 10, 6], [2, 6, 7], [3, 7, 8], [4, 8, 9], [5, 9, 10], [6, 10, 11], [7, 6, 11], [8, 7, 11], [9, 8, 11], [10, 9, 11],
];
#[rustfmt::skip]
const BOX_VERTICES: [[f32; 3]; 24] = [
    [1.0, -1.0, -1.0], [1.0, -1.0, 1.0], [-1.0, -1.0, 1.0], [-1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, 1.0],
    [1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [1.0, 1.0, 1.0], [1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, -1.0, 1.0],
    [-1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0], [1.0, -1.0, -1.0], [-1.0, -1.0, -1.0], [-1.0, 1.0, -1.0],
];
#[rustfmt::skip]
const BOX_FACES: [[u32; 3]; 12] = [
    [0, 1, 2], [3, 0, 2], [4, 5, 6], [7, 4, 6], [8, 9, 10], [11, 8, 10],
    [12, 13, 14], [15, 12, 14], [16, 17, 18], [19, 16, 18], [20, 21, 22], [23, 20, 22],
];
#[rustfmt::skip]
const UV_VERTICES: [[f32; 3]; 38] = [
    [0.377821, 0.809017, -0.450270], [0.611327, 0.309017, -0.728552], [0.611327, -0.309017, -0.728552],
    [0.377821, -0.809017, -0.450270], [0.578855, 0.809017, -0.102068], [0.936608, 0.309017, -0.165149],
    [0.936608, -0.309017, -0.165149], [0.578855, -0.809017, -0.102068], [0.509037, 0.809017, 0.293893],
    [0.823639, 0.309017, 0.475528], [0.823639, -0.309017, 0.475528], [0.509037, -0.809017, 0.293893],
    [0.201034, 0.809017, 0.552337], [0.325280, 0.309017, 0.893701], [0.325280, -0.309017, 0.893701],
    [0.201034, -0.809017, 0.552337], [-0.201034, 0.809017, 0.552337], [-0.325280, 0.309017, 0.893701],
    [-0.325280, -0.309017, 0.893701], [-0.201034, -0.809017, 0.552337], [0.000000, 1.000000, 0.000000],
    [-0.509037, 0.809017, 0.293893], [-0.823639, 0.309017, 0.475528], [-0.823639, -0.309017, 0.475528],
    [-0.509037, -0.809017, 0.293893], [-0.578855, 0.809017, -0.102068], [-0.936608, 0.309017, -0.165149],
    [-0.936608, -0.309017, -0.165149], [-0.578855, -0.809017, -0.102068], [-0.377821, 0.809017, -0.450269],
    [-0.611327, 0.309017, -0.728551], [-0.611327, -0.309017, -0.728551], [-0.377821, -0.809017, -0.450269],
    [-0.000000, 0.809017, -0.587785], [-0.000000, 0.309017, -0.951056], [-0.000000, -0.309017, -0.951056],
    [-0.000000, -0.809017, -0.587785], [0.000000, -1.000000, 0.000000],
];
#[rustfmt::skip]
const UV_FACES: [[u32; 3]; 72] = [
    [35, 3, 36], [34, 0, 1], [37, 36, 3], [34, 2, 35], [33, 20, 0], [37, 3, 7],
    [1, 6, 2], [0, 20, 4], [2, 7, 3], [1, 4, 5], [37, 7, 11], [5, 10, 6],
    [4, 20, 8], [6, 11, 7], [4, 9, 5], [37, 11, 15], [9, 14, 10], [8, 20, 12],
    [11, 14, 15], [8, 13, 9], [37, 15, 19], [13, 18, 14], [12, 20, 16], [14, 19, 15],
    [13, 16, 17], [37, 19, 24], [17, 23, 18], [16, 20, 21], [18, 24, 19], [17, 21, 22],
    [37, 24, 28], [22, 27, 23], [21, 20, 25], [23, 28, 24], [22, 25, 26], [37, 28, 32],
    [26, 31, 27], [25, 20, 29], [27, 32, 28], [26, 29, 30], [37, 32, 36], [30, 35, 31],
    [29, 20, 33], [32, 35, 36], [29, 34, 30], [35, 2, 3], [34, 33, 0], [34, 1, 2],
    [1, 5, 6], [2, 6, 7], [1, 0, 4], [5, 9, 10], [6, 10, 11], [4, 8, 9],
    [9, 13, 14], [11, 10, 14], [8, 12, 13], [13, 17, 18], [14, 18, 19], [13, 12, 16],
    [17, 22, 23], [18, 23, 24], [17, 16, 21], [22, 26, 27], [23, 27, 28], [22, 21, 25],
    [26, 30, 31], [27, 31, 32], [26, 25, 29], [30, 34, 35], [32, 31, 35], [29, 33, 34],
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use crate::sampling::rng::{hash_words, to_unit_f32};
    use glam::{Quat, Vec2};

    fn rnd(i: u64, k: u64) -> f32 {
        to_unit_f32(hash_words(&[i, 91, k]))
    }

    fn ellipsoid(center: [f32; 3], scale: [f32; 3], q: Quat) -> Ellipsoid {
        let q = q.normalize();
        let rot = quat_to_matrix([q.x as f64, q.y as f64, q.z as f64, q.w as f64]).as_mat3();
        Ellipsoid { center: Vec3::from_array(center), scale: Vec3::from_array(scale), rot }
    }

    fn random_ellipsoid(i: u64) -> Ellipsoid {
        let q = Quat::from_xyzw(rnd(i, 0) - 0.5, rnd(i, 1) - 0.5, rnd(i, 2) - 0.5, rnd(i, 3) - 0.5);
        let s = [0.1 + rnd(i, 4), 0.1 + rnd(i, 5), 0.1 + rnd(i, 6)];
        ellipsoid([rnd(i, 7) * 4.0 - 2.0, rnd(i, 8) * 4.0 - 2.0, rnd(i, 9) * 4.0 - 2.0], s, q)
    }

    /// A point on the surface with its outward unit normal, from a unit vector u.
    fn surface_point(e: &Ellipsoid, u: Vec3) -> (Vec3, Vec3) {
        let p = e.center + e.rot * (e.scale * u);
        let n = (e.rot * (u / e.scale)).normalize();
        (p, n)
    }

    // Values printed by Mitsuba 3.9.1 (llvm_ad_rgb):
    //   q = 30 degrees about (1,1,1); data = [[0.2,0.1,-0.3, 0.5,0.3,0.2, qx,qy,qz,qw]]
    //   s = mi.load_dict({'type':'scene','e':{'type':'ellipsoids','data':data,'extent':2.0}})
    //   si = s.ray_intersect(mi.Ray3f(o, d)); si.t, si.p, si.n; s.bbox()
    #[test]
    fn hits_and_bounds_match_mitsuba() {
        let axis = Vec3::ONE.normalize();
        let e = ellipsoid([0.2, 0.1, -0.3], [1.0, 0.6, 0.4], Quat::from_axis_angle(axis, 30f32.to_radians()));
        let s = Shape::Ellipsoids(Ellipsoids { items: vec![e] });
        for (o, d, t, n) in [
            ([0.3, 0.2, 5.0], [0.0, 0.0, -1.0], 4.89618, [0.27765, -0.0234325, 0.960396]),
            ([3.0, 0.5, -0.1], [-1.0, 0.0, 0.0], 2.27047, [0.44561, 0.288615, 0.847427]),
        ] {
            let ray = Ray::new(Vec3::from_array(o), Vec3::from_array(d), f32::INFINITY);
            let (th, uv) = s.intersect_prim(0, &ray).expect("missed");
            assert!((th - t).abs() < 2e-5, "t {th} vs {t}");
            let si = s.interaction(0, 0, &ray, th, uv);
            assert!((si.n - Vec3::from_array(n)).abs().max_element() < 2e-5, "n {} vs {n:?}", si.n);
            assert_eq!(si.sh_frame.n, si.n);
            assert_eq!((si.uv, si.dpdu, si.dpdv), (Vec2::ZERO, Vec3::ZERO, Vec3::ZERO));
        }
        // From the centre (inside): the back face is culled, as in Mitsuba (t = inf).
        let inside = Ray::new(Vec3::new(0.2, 0.1, -0.3), Vec3::Y, f32::INFINITY);
        assert!(s.intersect_prim(0, &inside).is_none());
        let b = s.prim_bounds(0);
        assert!((b.min - Vec3::new(-0.731965, -0.547458, -0.781912)).abs().max_element() < 1e-5, "{b:?}");
        assert!((b.max - Vec3::new(1.13196, 0.747458, 0.181912)).abs().max_element() < 1e-5, "{b:?}");
    }

    /// Rays aimed along the normal at a known surface point hit it at the
    /// known distance with that normal; rays from inside, rays ending short
    /// of the surface and rays passing just outside miss; just inside hit.
    #[test]
    fn hits_match_closed_form() {
        let mut grazing_hits = 0;
        for i in 0..2000u64 {
            let e = random_ellipsoid(i);
            let u = Vec3::new(rnd(i, 10) - 0.5, rnd(i, 11) - 0.5, rnd(i, 12) - 0.5).normalize();
            let (p, n) = surface_point(&e, u);
            let dist = 0.5 + 3.0 * rnd(i, 13);
            let ray = Ray::new(p + n * dist, -n, f32::INFINITY);
            let t = e.intersect(&ray).expect("missed a head-on ray");
            assert!((t - dist).abs() < 1e-4 * (1.0 + dist), "{i}: t {t} vs {dist}");
            let (q, m) = e.interaction(&ray, t);
            assert!((q - p).length() < 1e-4 && (m - n).length() < 1e-4, "{i}: {q} {m} vs {p} {n}");
            // The same ray ending before the surface misses.
            assert!(e.intersect(&Ray::new(ray.o, ray.d, dist * 0.99)).is_none());
            // From just inside (and from the centre), culled.
            assert!(e.intersect(&Ray::new(p - n * 1e-3, -n, f32::INFINITY)).is_none(), "{i}: inside hit");
            assert!(e.intersect(&Ray::new(e.center, n, f32::INFINITY)).is_none(), "{i}: centre hit");
            // Grazing: along a tangent through p moved out by a little
            // (misses) or in by a little (hits; the chord is short).
            let tangent = n.cross(if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y }).normalize();
            let out = Ray::new(p + n * 1e-3 - tangent * 5.0, tangent, f32::INFINITY);
            assert!(e.intersect(&out).is_none(), "{i}: a ray passing outside hit");
            let min_r = e.scale.min_element();
            let inn = Ray::new(p - n * 1e-3 * min_r - tangent * 5.0, tangent, f32::INFINITY);
            if let Some(t) = e.intersect(&inn) {
                assert!((t - 5.0).abs() < 0.2, "{i}: grazing hit at {t}");
                grazing_hits += 1;
            }
        }
        // Moving in by 1e-3 of the smallest radius keeps a chord unless the
        // curvature along the tangent is far larger; nearly all hit.
        assert!(grazing_hits > 1900, "{grazing_hits}");
    }

    /// Every surface point lies in the box, and the box touches the surface
    /// on every side (the support function along each axis).
    #[test]
    fn bounds_are_tight() {
        for i in 0..200u64 {
            let e = random_ellipsoid(i);
            let b = e.bounds();
            let mut lo = Vec3::splat(f32::INFINITY);
            let mut hi = Vec3::splat(f32::NEG_INFINITY);
            for k in 0..4000u64 {
                let u = Vec3::new(rnd(k, 20 + i) - 0.5, rnd(k, 21 + i) - 0.5, rnd(k, 22 + i) - 0.5).normalize();
                let (p, _) = surface_point(&e, u);
                assert!(p.cmpge(b.min).all() && p.cmple(b.max).all(), "{i}: {p} outside {b:?}");
                lo = lo.min(p);
                hi = hi.max(p);
            }
            let size = (b.max - b.min).max_element();
            assert!((lo - b.min).max_element() < 0.02 * size && (b.max - hi).max_element() < 0.02 * size, "{i}");
        }
    }

    /// The shells' vertices and face centres lie outside their ellipsoid
    /// (Mitsuba's scaling; the icosahedron then encloses it: each face's
    /// plane has the whole ellipsoid behind it, by the support function,
    /// while the box's faces cut it), face outwards, and cull back faces:
    /// from outside a ray hits the front face, from inside nothing.
    #[test]
    fn shells_enclose_and_cull() {
        for shell in [Shell::IcoSphere, Shell::Box, Shell::UvSphere] {
            let items: Vec<Ellipsoid> = (0..20).map(random_ellipsoid).collect();
            let m = shell.mesh(&items);
            let faces = m.indices.len() / items.len();
            let s = Shape::CulledMesh(crate::geometry::Mesh::new(m.clone(), true));
            for (k, t) in m.indices.iter().enumerate() {
                let e = &items[k / faces];
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                let n = (b - a).cross(c - a).normalize();
                // max over the ellipsoid of n·x = n·c + |S Rᵀ n|.
                let support = n.dot(e.center) + (e.scale * (e.rot.transpose() * n)).length();
                if shell == Shell::IcoSphere {
                    assert!(support <= n.dot(a) + 1e-5, "{shell:?} face {k}: {support} > {}", n.dot(a));
                }
                let unit = |p: Vec3| (e.rot.transpose() * (p - e.center) / e.scale).length();
                for p in [a, b, c, (a + b + c) / 3.0] {
                    assert!(unit(p) >= 1.0 - 1e-5, "{shell:?} face {k}: a point inside the ellipsoid");
                }
                assert!(n.dot((a + b + c) / 3.0 - e.center) > 0.0, "{shell:?} face {k} faces inwards");
                let centroid = (a + b + c) / 3.0;
                let front = Ray::new(centroid + n, -n, f32::INFINITY);
                let hit = s.intersect_prim(k, &front).map(|h| h.0);
                assert!(hit.is_some_and(|t| (t - 1.0).abs() < 1e-4), "{shell:?} face {k}: {hit:?}");
                let back = Ray::new(e.center, centroid - e.center, f32::INFINITY);
                assert!(s.intersect_prim(k, &back).is_none(), "{shell:?} face {k}: a back face was hit");
            }
        }
    }
}
