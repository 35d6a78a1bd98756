//! Shapes: triangle meshes and the analytic sphere and disk. A shape answers
//! the geometric questions (bounds of its primitives, the interaction at a
//! hit, area and direction sampling); the BVH intersects its primitives.

use super::{Aabb, Cylinder, Ray, SurfaceInteraction, TriangleMesh};
use crate::math::{fast, safe_sqrt, Frame, Mat3, Mat4, PI};
use crate::sampling::{warp, Distribution1D};
use glam::{Vec2, Vec3};

/// A point sampled on a shape, as seen from a reference point.
#[derive(Debug, Clone, Copy)]
pub struct ShapeSample {
    pub p: Vec3,
    /// Front-side geometric normal at `p`.
    pub n: Vec3,
    /// Density per unit solid angle at the reference point.
    pub pdf: f32,
}

#[derive(Debug, Clone)]
pub struct Mesh {
    pub mesh: TriangleMesh,
    /// Ignore vertex normals and shade with the flat face normal (also set
    /// when the vertex normals are the face normals, e.g. `rectangle` and
    /// `cube`: the same shading without interpolating them per hit).
    pub face_normals: bool,
    area_distrib: Option<Distribution1D>,
}

impl Mesh {
    pub fn new(mesh: TriangleMesh, face_normals: bool) -> Mesh {
        let areas: Vec<f32> = (0..mesh.indices.len()).map(|i| tri_area(&mesh, i)).collect();
        let face_normals = face_normals || normals_are_flat(&mesh);
        Mesh { area_distrib: Distribution1D::new(&areas), mesh, face_normals }
    }
    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        let t = self.mesh.indices[i];
        [self.mesh.positions[t[0] as usize], self.mesh.positions[t[1] as usize], self.mesh.positions[t[2] as usize]]
    }
}

/// Whether every triangle's vertex normals equal its face normal (to well
/// below a shading difference: 1e-5 rad); false without normals.
fn normals_are_flat(m: &TriangleMesh) -> bool {
    !m.normals.is_empty()
        && m.indices.iter().all(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            t.iter().all(|&i| (m.normals[i as usize] - n).length_squared() < 1e-10)
        })
}

fn tri_area(m: &TriangleMesh, i: usize) -> f32 {
    let t = m.indices[i];
    let (a, b, c) = (m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]);
    0.5 * (b - a).cross(c - a).length()
}

#[derive(Debug, Clone)]
pub enum Shape {
    Mesh(Mesh),
    /// Mitsuba `sphere`: normals point outwards unless flipped. `rot` is the
    /// rotation part of `to_world`, which orients the uv parameterisation.
    Sphere {
        center: Vec3,
        radius: f32,
        rot: Mat3,
        flip: bool,
    },
    /// Mitsuba `disk`: the unit disk in the local z = 0 plane, normal +z.
    Disk {
        world_from_object: Mat4,
        object_from_world: Mat4,
        n: Vec3,
        area: f32,
    },
    /// Mitsuba `cylinder`: an open tube (see [`Cylinder`]).
    Cylinder(Cylinder),
}

impl Shape {
    pub fn sphere(center: Vec3, radius: f32, flip: bool) -> Shape {
        Shape::Sphere { center, radius: radius.abs(), rot: Mat3::IDENTITY, flip }
    }

    /// A sphere whose local frame is rotated by `rot` (the orthonormal part
    /// of Mitsuba's `to_world`; it orients the uv parameterisation only).
    pub fn sphere_rotated(center: Vec3, radius: f32, rot: Mat3, flip: bool) -> Shape {
        Shape::Sphere { center, radius: radius.abs(), rot, flip }
    }

    pub fn disk(world_from_object: Mat4, flip: bool) -> Shape {
        let ax = world_from_object.transform_vector3(Vec3::X);
        let ay = world_from_object.transform_vector3(Vec3::Y);
        let c = ax.cross(ay);
        let n = if flip { -c.normalize() } else { c.normalize() };
        Shape::Disk { world_from_object, object_from_world: world_from_object.inverse(), n, area: PI * c.length() }
    }

    /// Number of primitives the BVH sees.
    pub fn prim_count(&self) -> usize {
        match self {
            Shape::Mesh(m) => m.mesh.indices.len(),
            _ => 1,
        }
    }

    pub fn prim_bounds(&self, i: usize) -> Aabb {
        match self {
            Shape::Mesh(m) => Aabb::from_points(&m.vertices(i)),
            Shape::Sphere { center, radius, .. } => {
                Aabb { min: *center - Vec3::splat(*radius), max: *center + Vec3::splat(*radius) }
            }
            Shape::Disk { world_from_object, .. } => {
                let pts: Vec<Vec3> = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
                    .iter()
                    .map(|&(x, y)| world_from_object.transform_point3(Vec3::new(x, y, 0.0)))
                    .collect();
                Aabb::from_points(&pts)
            }
            Shape::Cylinder(c) => c.bounds(),
        }
    }

    pub fn area(&self) -> f32 {
        match self {
            Shape::Mesh(m) => m.area_distrib.as_ref().map_or(0.0, |d| d.total as f32),
            Shape::Sphere { radius, .. } => 4.0 * PI * radius * radius,
            Shape::Disk { area, .. } => *area,
            Shape::Cylinder(c) => c.area(),
        }
    }

    /// Intersects an analytic shape (meshes are intersected per triangle by the BVH).
    #[inline]
    pub fn intersect_analytic(&self, ray: &Ray) -> Option<(f32, Vec2)> {
        match self {
            Shape::Sphere { center, radius, .. } => intersect_sphere(ray, *center, *radius),
            Shape::Disk { object_from_world, .. } => {
                let o = object_from_world.transform_point3(ray.o);
                let d = object_from_world.transform_vector3(ray.d);
                let t = -o.z / d.z;
                if !(t > 0.0 && t < ray.t_max) {
                    return None;
                }
                let p = o + t * d;
                (p.x * p.x + p.y * p.y <= 1.0).then_some((t, Vec2::new(p.x, p.y)))
            }
            Shape::Cylinder(c) => c.intersect(ray).map(|t| (t, Vec2::ZERO)),
            Shape::Mesh(_) => None,
        }
    }

    /// Completes a hit on primitive `prim` at distance `t`; `uv` holds the
    /// triangle barycentrics (b1, b2), or the disk's local (x, y). Fills in
    /// Mitsuba's uv, dp/du, dp/dv and a shading frame aligned with dp/du;
    /// `shape_id` becomes the result's `shape`.
    pub fn interaction(&self, shape_id: u32, prim: usize, ray: &Ray, t: f32, uv: Vec2) -> SurfaceInteraction {
        self.interaction_with(shape_id, prim, ray, t, uv, true)
    }

    /// [`Shape::interaction`]; with `param` false (for materials where
    /// [`Material::reads_uv`](crate::material::Material::reads_uv) is false)
    /// it skips Mitsuba's uv and dp/dv: `uv` and `dpdv` are then meaningless,
    /// and `dpdu` is a cheap tangent that only orients `sh_frame` about the
    /// normal, which such materials do not see.
    #[inline]
    pub fn interaction_with(
        &self,
        shape_id: u32,
        prim: usize,
        ray: &Ray,
        t: f32,
        uv: Vec2,
        param: bool,
    ) -> SurfaceInteraction {
        let wo = -ray.d.normalize();
        let (p, n, sh_n, tex, dpdu, dpdv) = match self {
            Shape::Mesh(m) => {
                let t_idx = m.mesh.indices[prim];
                let [p0, p1, p2] = m.vertices(prim);
                let (b1, b2) = (uv.x, uv.y);
                let b0 = 1.0 - b1 - b2;
                let p = b0 * p0 + b1 * p1 + b2 * p2;
                let (dp0, dp1) = (p1 - p0, p2 - p0);
                let n = dp0.cross(dp1).normalize();
                let mut sh_n = n;
                if !m.face_normals && !m.mesh.normals.is_empty() {
                    let ns = &m.mesh.normals;
                    let s = b0 * ns[t_idx[0] as usize] + b1 * ns[t_idx[1] as usize] + b2 * ns[t_idx[2] as usize];
                    if s.length_squared() > 0.0 {
                        sh_n = s.normalize();
                    }
                }
                // Without texture coordinates the parameterisation is barycentric.
                let (mut tex, mut dpdu, mut dpdv) = (Vec2::new(b1, b2), dp0, dp1);
                if param && !m.mesh.uvs.is_empty() {
                    let u = &m.mesh.uvs;
                    let (uv0, uv1, uv2) = (u[t_idx[0] as usize], u[t_idx[1] as usize], u[t_idx[2] as usize]);
                    tex = b0 * uv0 + b1 * uv1 + b2 * uv2;
                    let (duv0, duv1) = (uv1 - uv0, uv2 - uv0);
                    let det = duv0.x * duv1.y - duv0.y * duv1.x;
                    if det != 0.0 {
                        let inv = 1.0 / det;
                        dpdu = (duv1.y * dp0 - duv0.y * dp1) * inv;
                        dpdv = (duv0.x * dp1 - duv1.x * dp0) * inv;
                    } else {
                        // Degenerate uvs: Mitsuba falls back to an arbitrary basis.
                        let f = Frame::from_normal(n);
                        (dpdu, dpdv) = (f.s, f.t);
                    }
                }
                (p, n, sh_n, tex, dpdu, dpdv)
            }
            Shape::Sphere { center, radius, rot, flip } => {
                let mut n = (ray.at(t) - *center).normalize();
                // Re-project onto the surface to limit floating-point drift.
                let p = *center + n * *radius;
                let (tex, dpdu, dpdv) = if param {
                    // Mitsuba's spherical coordinates in the sphere's local frame.
                    let l = rot.transpose() * n;
                    let theta = fast::acos(l.z);
                    let mut phi = fast::atan2(l.y, l.x);
                    if phi < 0.0 {
                        phi += 2.0 * PI;
                    }
                    let tex = Vec2::new(phi * (0.5 / PI), theta * (1.0 / PI));
                    let rd = (l.x * l.x + l.y * l.y).sqrt();
                    let dpdv_l = if rd == 0.0 { Vec3::X } else { Vec3::new(l.z * l.x / rd, l.z * l.y / rd, -rd) };
                    let dpdu = *rot * Vec3::new(-l.y, l.x, 0.0) * (*radius * 2.0 * PI);
                    (tex, dpdu, *rot * dpdv_l * (*radius * PI))
                } else {
                    // dp/du ∝ rot·(z × l) = (rot·z) × n, without the angles.
                    (Vec2::ZERO, rot.z_axis.cross(n), Vec3::ZERO)
                };
                if *flip {
                    n = -n;
                }
                (p, n, n, tex, dpdu, dpdv)
            }
            Shape::Disk { world_from_object, n, .. } => {
                let p = world_from_object.transform_point3(Vec3::new(uv.x, uv.y, 0.0));
                if !param {
                    // dp/du is radial: the direction of the hit from the centre.
                    let dpdu = world_from_object.transform_vector3(Vec3::new(uv.x, uv.y, 0.0));
                    (p, *n, *n, Vec2::ZERO, dpdu, Vec3::ZERO)
                } else {
                    // Mitsuba's polar parameterisation (r, φ/2π).
                    let r2 = uv.length_squared();
                    let inv_r = if r2 != 0.0 { 1.0 / r2.sqrt() } else { 0.0 };
                    let r = r2 * inv_r;
                    let mut v = fast::atan2(uv.y, uv.x) * (0.5 / PI);
                    if v < 0.0 {
                        v += 1.0;
                    }
                    let (c, s) = (uv.x * inv_r, uv.y * inv_r);
                    let dpdu = world_from_object.transform_vector3(Vec3::new(c, s, 0.0));
                    let dpdv = world_from_object.transform_vector3(Vec3::new(-s, c, 0.0)) * (2.0 * PI * r);
                    (p, *n, *n, Vec2::new(r, v), dpdu, dpdv)
                }
            }
            Shape::Cylinder(c) => {
                let (p, n, tex, dpdu, dpdv) = c.interaction(ray, t);
                (p, n, n, tex, dpdu, dpdv)
            }
        };
        SurfaceInteraction {
            p,
            t,
            n,
            sh_frame: SurfaceInteraction::frame_from_dpdu(sh_n, dpdu),
            uv: tex,
            dpdu,
            dpdv,
            shape: shape_id,
            prim: prim as u32,
            bary: if matches!(self, Shape::Mesh(_)) { uv } else { Vec2::ZERO },
            wo,
        }
    }

    /// Uniform point on the surface: (point, front normal, density per unit area).
    pub fn sample_area(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        match self {
            Shape::Mesh(m) => {
                let d = m.area_distrib.as_ref().expect("sampling a mesh without area");
                let (i, _, ux) = d.sample_discrete(u.x);
                let b = warp::sample_uniform_triangle(Vec2::new(ux, u.y));
                let [p0, p1, p2] = m.vertices(i);
                let p = (1.0 - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
                let n = (p1 - p0).cross(p2 - p0).normalize();
                (p, n, 1.0 / d.total as f32)
            }
            Shape::Sphere { center, radius, flip, .. } => {
                let d = warp::sample_uniform_sphere(u);
                let n = if *flip { -d } else { d };
                (*center + d * *radius, n, 1.0 / self.area())
            }
            Shape::Disk { world_from_object, n, area, .. } => {
                let q = warp::sample_concentric_disk(u);
                (world_from_object.transform_point3(Vec3::new(q.x, q.y, 0.0)), *n, 1.0 / area)
            }
            Shape::Cylinder(c) => c.sample_area(u),
        }
    }

    /// Samples a point of the shape as seen from `p_ref`, with the density per
    /// unit solid angle at `p_ref`. Spheres seen from outside sample the cone
    /// they subtend (pbrt-v4 §6.2.4); other shapes sample their area.
    pub fn sample_direction(&self, p_ref: Vec3, u: Vec2) -> Option<ShapeSample> {
        if let Shape::Sphere { center, radius, flip, .. } = self {
            let dc2 = p_ref.distance_squared(*center);
            let r2 = radius * radius;
            if dc2 > r2 * 1.0001 {
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
                let phi = u.y * 2.0 * PI;
                let w = Vec3::new(sin_alpha * phi.cos(), sin_alpha * phi.sin(), cos_alpha);
                let frame = Frame::from_normal((*center - p_ref).normalize());
                let nd = frame.to_world(-w);
                let p = *center + nd * *radius;
                let n = if *flip { -nd } else { nd };
                return Some(ShapeSample { p, n, pdf: 1.0 / (2.0 * PI * one_minus_cos_max) });
            }
        }
        let (p, n, pdf_area) = self.sample_area(u);
        let pdf = area_to_solid_angle(pdf_area, p_ref, p, n)?;
        Some(ShapeSample { p, n, pdf })
    }

    /// Density per unit solid angle with which [`Shape::sample_direction`]
    /// from `p_ref` yields the point `p` (normal `n`) of this shape.
    pub fn pdf_direction(&self, p_ref: Vec3, p: Vec3, n: Vec3) -> f32 {
        if let Shape::Sphere { center, radius, .. } = self {
            let dc2 = p_ref.distance_squared(*center);
            let r2 = radius * radius;
            if dc2 > r2 * 1.0001 {
                let sin2_max = r2 / dc2;
                let one_minus_cos_max =
                    if sin2_max < 0.000_685_23 { sin2_max / 2.0 } else { 1.0 - safe_sqrt(1.0 - sin2_max) };
                return 1.0 / (2.0 * PI * one_minus_cos_max);
            }
        }
        area_to_solid_angle(1.0 / self.area(), p_ref, p, n).unwrap_or(0.0)
    }
}

/// Converts an area density at `p` to a solid-angle density at `p_ref`:
/// p_ω = p_A · d² / |cos θ_light| (pbrt-v4 eq. 4.11).
#[inline]
fn area_to_solid_angle(pdf_area: f32, p_ref: Vec3, p: Vec3, n: Vec3) -> Option<f32> {
    let d = p - p_ref;
    let dist2 = d.length_squared();
    if dist2 == 0.0 {
        return None;
    }
    let cos = (n.dot(d) / dist2.sqrt()).abs();
    if cos == 0.0 {
        return None;
    }
    Some(pdf_area * dist2 / cos)
}

/// Ray/sphere intersection with the numerically careful discriminant of
/// "Precision Improvements for Ray/Sphere Intersection" (Haines et al. 2019).
#[inline]
fn intersect_sphere(ray: &Ray, center: Vec3, radius: f32) -> Option<(f32, Vec2)> {
    let f = ray.o - center;
    let a = ray.d.length_squared();
    let b = -f.dot(ray.d);
    let l = f + (b / a) * ray.d;
    let disc = a * (radius * radius - l.length_squared());
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let q = if b > 0.0 { b + sq } else { b - sq };
    let (mut t0, mut t1) = (q / a, f.length_squared().mul_add(1.0, -radius * radius) / q);
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    let t = if t0 > 0.0 { t0 } else { t1 };
    (t > 0.0 && t < ray.t_max).then_some((t, Vec2::ZERO))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_hits_front_and_back() {
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z, f32::INFINITY);
        let (t, _) = intersect_sphere(&r, Vec3::ZERO, 1.0).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        let inside = Ray::new(Vec3::ZERO, Vec3::X, f32::INFINITY);
        assert!((intersect_sphere(&inside, Vec3::ZERO, 2.0).unwrap().0 - 2.0).abs() < 1e-5);
        let miss = Ray::new(Vec3::new(0.0, 1.5, -5.0), Vec3::Z, f32::INFINITY);
        assert!(intersect_sphere(&miss, Vec3::ZERO, 1.0).is_none());
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

    #[test]
    fn disk_area_follows_its_transform() {
        let m = Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0));
        assert!((Shape::disk(m, false).area() - 6.0 * PI).abs() < 1e-4);
    }
    /// The interaction for the closest hit of a ray (analytic shapes and meshes).
    fn hit(s: &Shape, o: [f32; 3], d: [f32; 3]) -> SurfaceInteraction {
        let ray = Ray::new(Vec3::from_array(o), Vec3::from_array(d), f32::INFINITY);
        if let Some((t, uv)) = s.intersect_analytic(&ray) {
            return s.interaction(0, 0, &ray, t, uv);
        }
        let Shape::Mesh(m) = s else { panic!("missed") };
        let sh = super::super::triangle::RayShear::new(ray.d);
        let best = (0..m.mesh.indices.len())
            .filter_map(|i| super::super::triangle::intersect_triangle(&ray, &sh, &m.vertices(i)).map(|h| (i, h)))
            .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
            .expect("missed");
        let (i, (t, b1, b2)) = best;
        s.interaction(0, i, &ray, t, Vec2::new(b1, b2))
    }

    fn close(a: Vec3, b: [f32; 3], tol: f32, what: &str) {
        assert!((a - Vec3::from_array(b)).abs().max_element() < tol, "{what}: {a} vs {b:?}");
    }

    /// Checks uv, dp/du, dp/dv, the frame's tangent s and normal against
    /// values printed by Mitsuba 3.9.1 (scalar_rgb):
    ///   s = mi.load_dict({'type': 'scene', 's': shape})
    ///   si = s.ray_intersect(mi.Ray3f(o, d)); si.uv, si.dp_du, si.dp_dv, si.sh_frame
    fn check(si: &SurfaceInteraction, uv: [f32; 2], dpdu: [f32; 3], dpdv: [f32; 3], s: [f32; 3], n: [f32; 3]) {
        let tol = 1e-4 * (1.0 + Vec3::from_array(dpdu).length().max(Vec3::from_array(dpdv).length()));
        assert!((si.uv - Vec2::from_array(uv)).abs().max_element() < 1e-5, "uv {} vs {uv:?}", si.uv);
        close(si.dpdu, dpdu, tol, "dp_du");
        close(si.dpdv, dpdv, tol, "dp_dv");
        close(si.sh_frame.s, s, 1e-5, "s");
        close(si.sh_frame.n, n, 1e-5, "n");
        close(si.sh_frame.t, si.sh_frame.n.cross(si.sh_frame.s).to_array(), 1e-6, "t = n x s");
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

    // {'type': 'rectangle', 'to_world': T.translate([0,0,1]).rotate([0,0,1],30).scale([2,3,1])}
    #[test]
    fn rectangle_uv_and_frame_match_mitsuba() {
        let mut m = TriangleMesh::rectangle();
        let to_world = Mat4::from_translation(Vec3::Z)
            * Mat4::from_rotation_z(30f32.to_radians())
            * Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0));
        m.transform(&to_world);
        let s = Shape::Mesh(Mesh::new(m, false));
        let si = hit(&s, [0.5, 0.7, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.6957532, 0.5593697],
            [3.4641018, 2.0, 0.0],
            [-3.0, 5.196152, 0.0],
            [0.86602545, 0.5, 0.0],
            [0.0, 0.0, 1.0],
        );
        let si = hit(&s, [-1.0, 0.2, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.30849367, 0.61220086],
            [3.4641018, 2.0, 0.0],
            [-3.0, 5.196152, 0.0],
            [0.86602545, 0.5, 0.0],
            [0.0, 0.0, 1.0],
        );
    }

    // {'type': 'cube'}, one ray per face
    #[test]
    fn cube_uv_and_frame_match_mitsuba() {
        let s = Shape::Mesh(Mesh::new(TriangleMesh::cube(), false));
        let cases: [([f32; 3], [f32; 3], [f32; 2], [f32; 3], [f32; 3], [f32; 3]); 6] = [
            ([0.3, -0.6, 5.0], [0.0, 0.0, -1.0], [0.2, 0.65], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            ([0.3, -0.6, -5.0], [0.0, 0.0, 1.0], [0.8, 0.65], [0.0, -2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
            ([5.0, 0.2, 0.7], [-1.0, 0.0, 0.0], [0.6, 0.15], [0.0, 2.0, 0.0], [0.0, 0.0, -2.0], [1.0, 0.0, 0.0]),
            ([-5.0, 0.2, 0.7], [1.0, 0.0, 0.0], [0.6, 0.85], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0], [-1.0, 0.0, 0.0]),
            ([0.2, 5.0, 0.7], [0.0, -1.0, 0.0], [0.4, 0.15], [-2.0, 0.0, 0.0], [0.0, 0.0, -2.0], [0.0, 1.0, 0.0]),
            ([0.2, -5.0, 0.7], [0.0, 1.0, 0.0], [0.85, 0.6], [0.0, 0.0, 2.0], [2.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
        ];
        for (o, d, uv, dpdu, dpdv, n) in cases {
            let si = hit(&s, o, d);
            check(&si, uv, dpdu, dpdv, (Vec3::from_array(dpdu) / 2.0).to_array(), n);
        }
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

    // mi.Mesh with vertex_positions [0,0,0, 2,0,0.5, 0,1,0], faces [0,1,2], with and
    // without vertex_texcoords [0.1,0.2, 0.9,0.4, 0.3,0.8]; ray from (0.5,0.25,5) along -z
    #[test]
    fn mesh_uv_and_frame_match_mitsuba() {
        let mut m = TriangleMesh {
            positions: vec![Vec3::ZERO, Vec3::new(2.0, 0.0, 0.5), Vec3::Y],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        };
        let si = hit(&Shape::Mesh(Mesh::new(m.clone(), false)), [0.5, 0.25, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.25, 0.25],
            [2.0, 0.0, 0.5],
            [0.0, 1.0, 0.0],
            [0.97014254, 0.0, 0.24253564],
            [-0.24253564, 0.0, 0.97014254],
        );
        m.uvs = vec![Vec2::new(0.1, 0.2), Vec2::new(0.9, 0.4), Vec2::new(0.3, 0.8)];
        let si = hit(&Shape::Mesh(Mesh::new(m, false)), [0.5, 0.25, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.35, 0.4],
            [2.7272727, -0.45454547, 0.6818182],
            [-0.909091, 1.8181816, -0.22727275],
            [0.95770437, -0.1596174, 0.2394261],
            [-0.24253564, 0.0, 0.97014254],
        );
    }
}
