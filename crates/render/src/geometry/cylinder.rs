//! Mitsuba's `cylinder`: an open tube (no caps) around the segment p0 → p1.
//!
//! As in Mitsuba 3.9.1 (`src/shapes/cylinder.cpp`) the shape is the unit
//! cylinder x² + y² = 1, 0 ≤ z ≤ 1 placed by
//! `to_world · translate(p0) · to_frame(Frame(d/|d|)) · scale(r, r, |d|)`,
//! with uv = (φ/2π, z), dp/du = to_world·2π(−y, x, 0), dp/dv = to_world·(0, 0, 1)
//! and the normal dp/du × dp/dv (outwards unless flipped). Rays are
//! intersected in object space in double precision; both roots count, so a
//! ray from inside hits the far wall.

use super::{Aabb, Ray};
use crate::math::PI;
use glam::{DMat4, DVec3, Mat4, Vec2, Vec3};

/// An open tube placed by a transform (Mitsuba's `cylinder`), see the module docs.
#[derive(Debug, Clone)]
pub struct Cylinder {
    world_from_object: DMat4,
    object_from_world: DMat4,
    to_world: Mat4,
    /// Radius in world units (after `to_world`'s scale).
    pub radius: f32,
    /// Length of the axis in world units.
    pub length: f32,
    /// Normals point inwards (Mitsuba's `flip_normals`).
    pub flip: bool,
}

/// Mitsuba's `coordinate_system` (Duff et al. 2017) in double precision.
fn frame_from_normal(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

impl Cylinder {
    /// Mitsuba's parameters: `to_world`, `p0`, `p1`, `radius`, `flip_normals`.
    /// Errors when the placement shears or scales x and y unequally (Mitsuba
    /// only warns there, and its sampling density is then wrong).
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn new(to_world: DMat4, p0: DVec3, p1: DVec3, radius: f64, flip: bool) -> Result<Cylinder, String> {
        let d = p1 - p0;
        let len = d.length();
        if !(len > 0.0) {
            return Err("cylinder: p0 and p1 must differ".into());
        }
        if !(radius != 0.0 && radius.is_finite()) {
            return Err("cylinder: the radius must be non-zero".into());
        }
        let n = d / len;
        let (s, t) = frame_from_normal(n);
        let to_frame = DMat4::from_cols(s.extend(0.0), t.extend(0.0), n.extend(0.0), glam::DVec4::W);
        let m = to_world * DMat4::from_translation(p0) * to_frame * DMat4::from_scale(DVec3::new(radius, radius, len));
        let (ax, ay, az) =
            (m.transform_vector3(DVec3::X), m.transform_vector3(DVec3::Y), m.transform_vector3(DVec3::Z));
        let (rx, ry) = (ax.length(), ay.length());
        let tol = 1e-5 * rx.max(ry).max(az.length());
        if (rx - ry).abs() > tol
            || ax.dot(ay).abs() > tol * rx
            || ax.dot(az).abs() > tol * rx
            || ay.dot(az).abs() > tol * ry
        {
            return Err("cylinder: to_world must not shear or scale the cross-section unevenly (use a mesh)".into());
        }
        let inv = m.inverse();
        if !inv.is_finite() {
            return Err("cylinder: to_world is singular".into());
        }
        Ok(Cylinder {
            world_from_object: m,
            object_from_world: inv,
            to_world: m.as_mat4(),
            radius: rx as f32,
            length: az.length() as f32,
            flip,
        })
    }

    /// World-space surface area of the tube, 2πr·length (no caps).
    pub fn area(&self) -> f32 {
        2.0 * PI * self.radius * self.length
    }

    /// Mitsuba's bound: the box around the two end circles.
    pub fn bounds(&self) -> Aabb {
        let m = &self.world_from_object;
        let (x1, x2) = (m.transform_vector3(DVec3::X), m.transform_vector3(DVec3::Y));
        let x = (x1 * x1 + x2 * x2).map(f64::sqrt);
        let (p0, p1) = (m.transform_point3(DVec3::ZERO), m.transform_point3(DVec3::Z));
        // Widen by a few ulps so the f32 box surely contains the surface.
        let pad = 1e-6 * (p0.abs().max(p1.abs()).max_element() + x.max_element());
        Aabb {
            min: (p0.min(p1) - x - DVec3::splat(pad)).as_vec3(),
            max: (p0.max(p1) + x + DVec3::splat(pad)).as_vec3(),
        }
    }

    /// Closest hit with 0 < t < ray.t_max: the near root if it lies on the
    /// tube, else the far one (a hit on the inside).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<f32> {
        let o = self.object_from_world.transform_point3(ray.o.as_dvec3());
        let d = self.object_from_world.transform_vector3(ray.d.as_dvec3());
        let a = d.x * d.x + d.y * d.y;
        let b = 2.0 * (d.x * o.x + d.y * o.y);
        let c = o.x * o.x + o.y * o.y - 1.0;
        if a == 0.0 {
            return None; // parallel to the axis: never on the tube
        }
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let q = -0.5 * (b + disc.sqrt().copysign(b));
        let (mut t0, mut t1) = (q / a, c / q);
        if q == 0.0 {
            (t0, t1) = (0.0, 0.0);
        }
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t_max = ray.t_max as f64;
        for t in [t0, t1] {
            let z = o.z + d.z * t;
            if t > 0.0 && t < t_max && (0.0..=1.0).contains(&z) && (t as f32) > 0.0 && (t as f32) < ray.t_max {
                return Some(t as f32);
            }
        }
        None
    }

    /// (p, geometric normal = shading normal, uv, dp/du, dp/dv) at the hit `t`.
    pub fn interaction(&self, ray: &Ray, t: f32) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        let p = ray.o.as_dvec3() + ray.d.as_dvec3() * t as f64;
        let mut l = self.object_from_world.transform_point3(p);
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += 2.0 * std::f64::consts::PI;
        }
        let uv = Vec2::new((phi / (2.0 * std::f64::consts::PI)) as f32, l.z as f32);
        let dpdu = self.to_world.transform_vector3(Vec3::new(-l.y as f32, l.x as f32, 0.0) * (2.0 * PI));
        let dpdv = self.to_world.transform_vector3(Vec3::Z);
        let mut n = dpdu.cross(dpdv).normalize();
        // Re-project onto the surface to limit floating-point drift.
        let r = (l.x * l.x + l.y * l.y).sqrt();
        if r > 0.0 {
            l.x /= r;
            l.y /= r;
        }
        let p = self.world_from_object.transform_point3(l).as_vec3();
        if self.flip {
            n = -n;
        }
        (p, n, uv, dpdu, dpdv)
    }

    /// Uniform point on the tube: (point, front normal, density per unit area),
    /// with Mitsuba's mapping (φ = 2π u.y, z = u.x).
    pub fn sample_area(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        let (s, c) = crate::simd::sin_cos(2.0 * PI * u.y);
        let p = self.to_world.transform_point3(Vec3::new(c, s, u.x));
        let dpdu = self.to_world.transform_vector3(Vec3::new(-s, c, 0.0));
        let dpdv = self.to_world.transform_vector3(Vec3::Z);
        let n = dpdu.cross(dpdv).normalize();
        (p, if self.flip { -n } else { n }, 1.0 / self.area())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Shape, SurfaceInteraction};
    use crate::sampling::rng::{hash_words, to_unit_f32};
    use crate::testing::chi2::{alpha, chi2_test, integrate_over_sphere};

    fn rnd(i: u64, k: u64) -> f32 {
        to_unit_f32(hash_words(&[i, 77, k]))
    }

    fn cyl(to_world: DMat4, p0: [f64; 3], p1: [f64; 3], r: f64, flip: bool) -> Shape {
        Shape::Cylinder(Cylinder::new(to_world, DVec3::from_array(p0), DVec3::from_array(p1), r, flip).unwrap())
    }

    fn hit(s: &Shape, o: [f32; 3], d: [f32; 3]) -> SurfaceInteraction {
        let ray = Ray::new(Vec3::from_array(o), Vec3::from_array(d), f32::INFINITY);
        let (t, uv) = s.intersect_analytic(&ray).expect("missed");
        s.interaction(0, 0, &ray, t, uv)
    }

    fn close(a: Vec3, b: [f32; 3], tol: f32, what: &str) {
        assert!((a - Vec3::from_array(b)).abs().max_element() < tol, "{what}: {a} vs {b:?}");
    }

    /// Values printed by Mitsuba 3.9.1 (scalar_rgb):
    ///   s = mi.load_dict({'type': 'scene', 's': {'type': 'cylinder', ...}})
    ///   si = s.ray_intersect(mi.Ray3f(o, d)); si.t, si.uv, si.dp_du, si.dp_dv, si.sh_frame.s, si.n
    #[allow(clippy::type_complexity)]
    fn check(si: &SurfaceInteraction, t: f32, uv: [f32; 2], dpdu: [f32; 3], dpdv: [f32; 3], s: [f32; 3], n: [f32; 3]) {
        assert!((si.t - t).abs() < 1e-4 * t.max(1.0), "t {} vs {t}", si.t);
        assert!((si.uv - Vec2::from_array(uv)).abs().max_element() < 1e-5, "uv {} vs {uv:?}", si.uv);
        close(si.dpdu, dpdu, 1e-4 * (1.0 + Vec3::from_array(dpdu).length()), "dp_du");
        close(si.dpdv, dpdv, 1e-5 * (1.0 + Vec3::from_array(dpdv).length()), "dp_dv");
        close(si.sh_frame.s, s, 1e-5, "s");
        close(si.n, n, 1e-5, "n");
        close(si.sh_frame.n, n, 1e-5, "sh n");
    }

    // Shapes: {'type': 'cylinder'}; the same with p0, p1, radius and flip_normals;
    // and to_world = T().translate([1,0,0]).rotate([0,0,1],30).scale(1.5). The second
    // ray starts inside the tube.
    #[test]
    fn uv_and_frame_match_mitsuba() {
        let unit = cyl(DMat4::IDENTITY, [0.0; 3], [0.0, 0.0, 1.0], 1.0, false);
        let si = hit(&unit, [3.0, 0.5, 0.3], [-1.0, 0.0, 0.0]);
        check(
            &si,
            2.133974552154541,
            [0.08333337306976318, 0.29999998211860657],
            [-3.141592502593994, 5.4413981437683105, 0.0],
            [0.0, 0.0, 1.0],
            [-0.5, 0.866025447845459, 0.0],
            [0.866025447845459, 0.5, -0.0],
        );
        let si = hit(&unit, [0.2, 0.1, 0.5], [0.6, 0.8, 0.0]);
        check(
            &si,
            0.7949874997138977,
            [0.13164140284061432, 0.4999999701976776],
            [-4.624361038208008, 4.253669261932373, 0.0],
            [0.0, 0.0, 1.0],
            [-0.7359899282455444, 0.6769925355911255, 0.0],
            [0.6769925355911255, 0.7359899282455444, -0.0],
        );
        let s = cyl(DMat4::IDENTITY, [0.1, 0.2, -0.5], [0.4, -0.3, 1.2], 0.6, true);
        let si = hit(&s, [3.0, 0.1, 0.4], [-1.0, 0.0, 0.0]);
        check(
            &si,
            2.1619889736175537,
            [0.0462673045694828, 0.5577100515365601],
            [-0.9788962006568909, 3.442284345626831, 1.1851829290390015],
            [0.30000001192092896, -0.5, 1.7000001668930054],
            [-0.25966042280197144, 0.9130947589874268, 0.3143796920776367],
            [-0.9511638283729553, -0.2980917990207672, 0.0801783949136734],
        );
        let to_world = DMat4::from_translation(DVec3::X)
            * DMat4::from_rotation_z(30f64.to_radians())
            * DMat4::from_scale(DVec3::splat(1.5));
        let s = cyl(to_world, [0.0; 3], [1.0, 1.0, 1.0], 0.5, false);
        let si = hit(&s, [1.5, 0.8, -5.0], [0.0, 0.0, 1.0]);
        check(
            &si,
            4.7837724685668945,
            [0.06504233181476593, 0.23546786606311798],
            [-3.9735708236694336, 2.100904703140259, -1.4154611825942993],
            [0.5490379929542542, 2.0490379333496094, 1.5],
            [-0.843218207359314, 0.4458259642124176, -0.3003702759742737],
            [0.494292289018631, 0.4233565628528595, -0.7592393159866333],
        );
        // s.surface_area(), s.bbox()
        assert!((s.area() - 12.243144989013672).abs() < 1e-4);
        let b = s.prim_bounds(0);
        close(b.min, [0.266938, -0.461108, -0.612372], 1e-5, "bbox min");
        close(b.max, [2.2821, 2.51015, 2.11237], 1e-5, "bbox max");
    }

    /// Intersection against a brute-force march along the ray, from outside and inside.
    #[test]
    fn intersection_agrees_with_brute_force() {
        let to_world = DMat4::from_translation(DVec3::new(0.3, -0.2, 0.1)) * DMat4::from_rotation_x(0.7);
        let s = cyl(to_world, [0.1, 0.2, -0.5], [0.4, -0.3, 1.2], 0.6, false);
        let Shape::Cylinder(c) = &s else { unreachable!() };
        let m = c.object_from_world;
        let on_tube = |p: Vec3| {
            let l = m.transform_point3(p.as_dvec3());
            (l.x * l.x + l.y * l.y - 1.0, (0.0..=1.0).contains(&l.z))
        };
        let (mut hits, mut inside_hits) = (0, 0);
        for i in 0..3000u64 {
            let o = Vec3::new(rnd(i, 0), rnd(i, 1), rnd(i, 2)) * 4.0 - 2.0;
            let d = (Vec3::new(rnd(i, 3), rnd(i, 4), rnd(i, 5)) - 0.5).normalize();
            let ray = Ray::new(o, d, if i % 4 == 0 { 1.5 } else { f32::INFINITY });
            // March in small steps and bisect sign changes of the implicit function.
            let (steps, t_end) = (4000, ray.t_max.min(8.0));
            let f = |t: f32| on_tube(o + d * t);
            let mut expected = None;
            let mut prev = f(0.0).0;
            for k in 1..=steps {
                let t = t_end * k as f32 / steps as f32;
                let cur = f(t).0;
                if (prev < 0.0) != (cur < 0.0) {
                    let (mut lo, mut hi) = (t - t_end / steps as f32, t);
                    for _ in 0..40 {
                        let mid = 0.5 * (lo + hi);
                        if (f(mid).0 < 0.0) == (prev < 0.0) {
                            lo = mid
                        } else {
                            hi = mid
                        }
                    }
                    if f(0.5 * (lo + hi)).1 {
                        expected = Some(0.5 * (lo + hi));
                        break;
                    }
                }
                prev = cur;
            }
            let got = s.intersect_analytic(&ray).map(|h| h.0);
            match (got, expected) {
                (Some(g), Some(e)) => {
                    assert!((g - e).abs() < 1e-3, "ray {i}: {g} vs {e}");
                    hits += 1;
                    if f(0.0).0 < 0.0 {
                        inside_hits += 1;
                    }
                }
                (None, None) => {}
                // Grazing rays may differ right at the rims or tangents.
                (g, e) => {
                    let t = g.or(e).unwrap();
                    let l = m.transform_point3((o + d * t).as_dvec3());
                    let near_rim = l.z.abs() < 1e-3 || (l.z - 1.0).abs() < 1e-3;
                    assert!(near_rim || (t - ray.t_max).abs() < 1e-3, "ray {i}: {g:?} vs {e:?}");
                }
            }
        }
        assert!(hits > 200 && inside_hits > 50, "{hits} hits, {inside_hits} from inside");
    }

    /// Density of area sampling seen from `p_ref` along `w`, summed over the
    /// crossings of the ray with the tube; also returns how many there are.
    fn crossings(s: &Shape, p_ref: Vec3, w: Vec3) -> (f64, usize) {
        let (mut total, mut count, mut t0) = (0.0, 0, 0.0);
        loop {
            let ray = Ray::new(p_ref + w * t0, w, f32::INFINITY);
            let Some((t, uv)) = s.intersect_analytic(&ray) else { return (total, count) };
            let si = s.interaction(0, 0, &ray, t, uv);
            total += s.pdf_direction(p_ref, si.p, si.n) as f64;
            count += 1;
            t0 += t + 1e-4;
        }
    }

    #[test]
    fn area_sampling_matches_its_pdf() {
        let to_world = DMat4::from_rotation_y(0.4);
        let outside = (cyl(to_world, [0.2, -0.1, 1.0], [-0.3, 0.4, 2.2], 0.5, false), Vec3::ZERO);
        let inside = (cyl(to_world, [0.0, 0.0, -1.0], [0.0, 0.0, 1.5], 0.7, true), Vec3::new(0.1, 0.0, 0.2));
        for (s, p_ref) in [&outside, &inside] {
            // Every sample lands on the tube, with the radial normal (outwards
            // unless flipped) and the pdf that pdf_direction reports.
            let Shape::Cylinder(c) = s else { unreachable!() };
            for i in 0..200 {
                let x = s.sample_direction(*p_ref, Vec2::new(rnd(i, 10), rnd(i, 11))).unwrap();
                let l = c.object_from_world.transform_point3(x.p.as_dvec3());
                assert!((l.x * l.x + l.y * l.y - 1.0).abs() < 1e-5 && (-1e-6..=1.0 + 1e-6).contains(&l.z));
                let axis_p = c.world_from_object.transform_point3(DVec3::new(0.0, 0.0, l.z)).as_vec3();
                let radial = (x.p - axis_p).normalize();
                let want = if c.flip { -radial } else { radial };
                assert!((x.n - want).length() < 1e-4, "{} vs {want}", x.n);
                assert!((s.pdf_direction(*p_ref, x.p, x.n) - x.pdf).abs() < 1e-4 * x.pdf);
            }
        }
        // Seen from inside, the density is smooth: chi-square, and a wrong pdf must fail.
        let (s, p_ref) = &inside;
        let sample = |_: f32, u: Vec2| s.sample_direction(*p_ref, u).map(|x| (x.p - *p_ref).normalize());
        let p = chi2_test(200_000, 90, sample, |w| crossings(s, *p_ref, w).0);
        assert!(p > alpha(1), "inside: p = {p}");
        let p = chi2_test(200_000, 91, sample, |w| crossings(s, *p_ref, w).0 * if w.x > 0.0 { 1.1 } else { 0.9 });
        assert!(p < 1e-6, "a wrong pdf passed: p = {p}");
        // From outside the density has an integrable 1/cos singularity at the
        // silhouette, too sharp for the chi-square grid. Check instead that
        // E[1/pdf] equals the solid angle of the tube counted once per crossing
        // (a step function, which the grid integrates well).
        let (s, p_ref) = &outside;
        let n = 400_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let x = s.sample_direction(*p_ref, Vec2::new(rnd(i, 20), rnd(i, 21))).unwrap();
            let v = 1.0 / x.pdf as f64;
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        let want = integrate_over_sphere(|w| crossings(s, *p_ref, w).1 as f64);
        assert!((mean - want).abs() < 4.0 * se + 2e-3 * want, "E[1/pdf] = {mean} ± {se}, solid angle {want}");
        // The closed-form area: 2π r |p1 − p0| (here r = 1, length 10).
        let s = cyl(DMat4::from_scale(DVec3::splat(2.0)), [0.0; 3], [0.0, 3.0, 4.0], 0.5, false);
        assert!((s.area() - 2.0 * PI * 1.0 * 10.0).abs() < 1e-4);
    }
}
