//! Shapes: triangle meshes and the analytic sphere and disk. A shape answers
//! the geometric questions (bounds of its primitives, the interaction at a
//! hit, area and direction sampling); the BVH intersects its primitives.

use super::{Aabb, Ray, SurfaceInteraction, TriangleMesh};
use crate::math::{safe_sqrt, Frame, Mat4, PI};
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
    /// Ignore vertex normals and shade with the flat face normal.
    pub face_normals: bool,
    area_distrib: Option<Distribution1D>,
}

impl Mesh {
    pub fn new(mesh: TriangleMesh, face_normals: bool) -> Mesh {
        let areas: Vec<f32> = (0..mesh.indices.len()).map(|i| tri_area(&mesh, i)).collect();
        Mesh { area_distrib: Distribution1D::new(&areas), mesh, face_normals }
    }
    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        let t = self.mesh.indices[i];
        [self.mesh.positions[t[0] as usize], self.mesh.positions[t[1] as usize], self.mesh.positions[t[2] as usize]]
    }
}

fn tri_area(m: &TriangleMesh, i: usize) -> f32 {
    let t = m.indices[i];
    let (a, b, c) = (m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]);
    0.5 * (b - a).cross(c - a).length()
}

#[derive(Debug, Clone)]
pub enum Shape {
    Mesh(Mesh),
    /// Mitsuba `sphere`: normals point outwards unless flipped.
    Sphere {
        center: Vec3,
        radius: f32,
        flip: bool,
    },
    /// Mitsuba `disk`: the unit disk in the local z = 0 plane, normal +z.
    Disk {
        world_from_object: Mat4,
        object_from_world: Mat4,
        n: Vec3,
        area: f32,
    },
}

impl Shape {
    pub fn sphere(center: Vec3, radius: f32, flip: bool) -> Shape {
        Shape::Sphere { center, radius: radius.abs(), flip }
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
        }
    }

    pub fn area(&self) -> f32 {
        match self {
            Shape::Mesh(m) => m.area_distrib.as_ref().map_or(0.0, |d| d.total as f32),
            Shape::Sphere { radius, .. } => 4.0 * PI * radius * radius,
            Shape::Disk { area, .. } => *area,
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
            Shape::Mesh(_) => None,
        }
    }

    /// Completes a hit on primitive `prim` at distance `t`; `uv` holds the
    /// triangle barycentrics (b1, b2), or the disk's local (x, y).
    pub fn interaction(&self, shape_id: u32, prim: usize, ray: &Ray, t: f32, uv: Vec2) -> SurfaceInteraction {
        let wo = -ray.d.normalize();
        match self {
            Shape::Mesh(m) => {
                let t_idx = m.mesh.indices[prim];
                let [p0, p1, p2] = m.vertices(prim);
                let (b1, b2) = (uv.x, uv.y);
                let b0 = 1.0 - b1 - b2;
                let p = b0 * p0 + b1 * p1 + b2 * p2;
                let n = (p1 - p0).cross(p2 - p0).normalize();
                let mut sh_n = n;
                if !m.face_normals && !m.mesh.normals.is_empty() {
                    let ns = &m.mesh.normals;
                    let s = b0 * ns[t_idx[0] as usize] + b1 * ns[t_idx[1] as usize] + b2 * ns[t_idx[2] as usize];
                    if s.length_squared() > 0.0 {
                        sh_n = s.normalize();
                    }
                }
                let tex = if m.mesh.uvs.is_empty() {
                    Vec2::new(b1, b2)
                } else {
                    let u = &m.mesh.uvs;
                    b0 * u[t_idx[0] as usize] + b1 * u[t_idx[1] as usize] + b2 * u[t_idx[2] as usize]
                };
                SurfaceInteraction { p, t, n, sh_frame: Frame::from_normal(sh_n), uv: tex, shape: shape_id, wo }
            }
            Shape::Sphere { center, radius, flip } => {
                let mut n = (ray.at(t) - *center).normalize();
                // Re-project onto the surface to limit floating-point drift.
                let p = *center + n * *radius;
                // Texture coordinates are not needed until textures exist;
                // computing them here (atan2, acos) would cost every hit.
                let uv = Vec2::ZERO;
                if *flip {
                    n = -n;
                }
                SurfaceInteraction { p, t, n, sh_frame: Frame::from_normal(n), uv, shape: shape_id, wo }
            }
            Shape::Disk { world_from_object, n, .. } => {
                let p = world_from_object.transform_point3(Vec3::new(uv.x, uv.y, 0.0));
                SurfaceInteraction { p, t, n: *n, sh_frame: Frame::from_normal(*n), uv, shape: shape_id, wo }
            }
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
            Shape::Sphere { center, radius, flip } => {
                let d = warp::sample_uniform_sphere(u);
                let n = if *flip { -d } else { d };
                (*center + d * *radius, n, 1.0 / self.area())
            }
            Shape::Disk { world_from_object, n, area, .. } => {
                let q = warp::sample_concentric_disk(u);
                (world_from_object.transform_point3(Vec3::new(q.x, q.y, 0.0)), *n, 1.0 / area)
            }
        }
    }

    /// Samples a point of the shape as seen from `p_ref`, with the density per
    /// unit solid angle at `p_ref`. Spheres seen from outside sample the cone
    /// they subtend (pbrt-v4 §6.2.4); other shapes sample their area.
    pub fn sample_direction(&self, p_ref: Vec3, u: Vec2) -> Option<ShapeSample> {
        if let Shape::Sphere { center, radius, flip } = self {
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
}
