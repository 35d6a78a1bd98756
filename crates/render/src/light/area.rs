//! Mitsuba `area`: a diffuse emitter attached to a shape, emitting
//! `radiance` from the shape's front side only (the side its shading normal
//! points to). Sampled by the shape's `sample_direction` (the subtended cone
//! for spheres seen from outside, the area otherwise). `two_sided` (pbrt-v4's
//! `twosided`, not a Mitsuba parameter) emits the same radiance from the back.
//!
//! | parameter | type                 | default |
//! |-----------|----------------------|---------|
//! | radiance  | rgb or texture       | (required) |
//!
//! A textured `radiance` (`bitmap`, `checkerboard`) varies with the
//! surface's uv, L(x, ω) = T(uv(x)). Mitsuba 3.9.1 then samples the
//! texture's own distribution and maps it onto the shape through the uv
//! parameterisation (meshes with texture coordinates only); here the shape
//! is still sampled by area (or by its cone) and the texture evaluated at
//! the sampled point: the same estimator expectation, ∫ T(uv(x)) G dA, with
//! a variance that grows with the texture's contrast, and on every shape.
//!
//! Declared inside a `<shape>`; the shape must have positive area and may
//! not belong to a `shapegroup`.

use super::bvh::{DirectionCone, LightBounds};
use super::LightSample;
use crate::geometry::{Aabb, AreaSample, Mesh, Ray, Shape, SurfaceInteraction};
use crate::math::{luminance, Spectrum, PI};
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Mitsuba's `area` emitter on one shape.
#[derive(Debug, Clone)]
pub struct AreaLight {
    /// Index of the emitting shape in the scene's shapes.
    pub shape: u32,
    /// Emitted radiance (W/(m² sr)), the same in every front-facing
    /// direction; a texture makes it vary with the surface's uv.
    pub radiance: Texture,
    /// Emits from both sides (pbrt-v4's `twosided`); Mitsuba's area
    /// emitters emit from the front only.
    pub two_sided: bool,
}

impl AreaLight {
    /// Radiance leaving the surface point `si` (a hit on this light's
    /// shape) towards `si.wo`: zero behind the shading normal.
    #[inline]
    pub fn emitted(&self, si: &SurfaceInteraction) -> Spectrum {
        if self.two_sided || si.sh_frame.n.dot(si.wo) > 0.0 {
            self.radiance.eval(si)
        } else {
            Spectrum::ZERO
        }
    }

    /// Whether the radiance varies over the surface: hits on the shape then
    /// need their uv (see [`crate::scene::Scene`]'s `interaction`).
    pub fn is_textured(&self) -> bool {
        self.radiance.constant().is_none()
    }

    /// `shape`: this light's shape.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn sample_li(&self, p_ref: Vec3, u2: Vec2, shape: &Shape) -> Option<LightSample> {
        let s = shape.sample_direction(p_ref, u2)?;
        let d = s.p - p_ref;
        let dist = d.length();
        if dist == 0.0 || !(s.pdf > 0.0) || !s.pdf.is_finite() {
            return None;
        }
        let wi = d / dist;
        if s.n.dot(wi) >= 0.0 && !(self.two_sided && s.n.dot(wi) > 0.0) {
            return None;
        }
        let li = match self.radiance.constant() {
            Some(c) => c,
            // The texture at the sampled point: its interaction as a ray from
            // p_ref would find it.
            None => {
                let ray = Ray::new(p_ref, wi, f32::INFINITY);
                let si = shape.interaction(self.shape, s.prim as usize, &ray, dist, s.param);
                self.radiance.eval(&si)
            }
        };
        if li == Spectrum::ZERO {
            return None;
        }
        Some(LightSample { wi, dist, pdf: s.pdf, li, delta: false })
    }

    /// The radiance leaving the point `s`, sampled on `shape` (this light's
    /// shape) by area: the texture there, found as a ray along the normal
    /// finds it.
    pub fn radiance_at(&self, shape: &Shape, s: &AreaSample) -> Spectrum {
        match self.radiance.constant() {
            Some(c) => c,
            None => {
                let ray = Ray::new(s.p + s.n, -s.n, f32::INFINITY);
                let si = shape.interaction(self.shape, s.prim as usize, &ray, 1.0, s.param);
                self.radiance.eval(&si)
            }
        }
    }

    /// Solid-angle density at `p_ref` with which `sample_li` reaches the
    /// point `hit` of `shape` (this light's shape).
    #[inline]
    pub fn pdf_li(&self, p_ref: Vec3, hit: &SurfaceInteraction, shape: &Shape) -> f32 {
        shape.pdf_direction(p_ref, hit.p, hit.n)
    }

    /// Φ = π A L for a one-sided diffuse emitter (twice that for a
    /// two-sided one); a texture's mean value over its uv domain stands in
    /// for L (it only weights light selection).
    pub fn power(&self, shape: &Shape) -> Spectrum {
        let l = match &self.radiance {
            Texture::Constant(c) => *c,
            t => Spectrum::splat(t.mean()),
        };
        PI * shape.area() * l * if self.two_sided { 2.0 } else { 1.0 }
    }

    /// The shape's box and the cone of its front-facing normals; diffuse
    /// emission spreads θ_e = π/2 around each normal.
    pub fn bounds(&self, shape: &Shape) -> LightBounds {
        let cone = if self.two_sided { DirectionCone::ENTIRE_SPHERE } else { normal_cone(shape) };
        LightBounds::new(shape_bounds(shape), cone, 0.0, luminance(self.power(shape)))
    }
}

/// Bounding box of all of a shape's primitives.
fn shape_bounds(shape: &Shape) -> Aabb {
    (0..shape.prim_count()).fold(Aabb::EMPTY, |b, i| b.union(shape.prim_bounds(i)))
}

/// Cone bounding a shape's front-facing normals: the normal for a disk, the
/// whole sphere for a sphere, and for a mesh the cone around its
/// area-weighted mean normal that holds every face normal (and the vertex
/// normals when they shade, since emission follows the shading normal).
fn normal_cone(shape: &Shape) -> DirectionCone {
    match shape {
        // The shapes that cannot emit (the builder refuses them) get the
        // whole sphere too.
        Shape::Sphere(_) | Shape::Cylinder(_) | Shape::Ellipsoids(_) | Shape::SdfGrid(_) | Shape::Curves(_) => {
            DirectionCone::ENTIRE_SPHERE
        }
        Shape::Disk(d) => DirectionCone { w: d.n, cos_theta: 1.0 },
        Shape::Mesh(m) | Shape::CulledMesh(m) => mesh_normal_cone(m),
    }
}

fn mesh_normal_cone(m: &Mesh) -> DirectionCone {
    let faces: Vec<Vec3> = (0..m.mesh.indices.len())
        .filter_map(|i| {
            let [p0, p1, p2] = m.vertices(i);
            let c = (p1 - p0).cross(p2 - p0);
            (c.length_squared() > 0.0 && c.is_finite()).then_some(c)
        })
        .collect();
    // Area-weighted mean normal (cross products have length 2 × area).
    let sum: Vec3 = faces.iter().sum();
    let total: f32 = faces.iter().map(|c| c.length()).sum();
    if !sum.is_finite() || sum.length() <= 1e-4 * total {
        return DirectionCone::ENTIRE_SPHERE;
    }
    let w = sum.normalize();
    let shading: &[Vec3] = if m.face_normals { &[] } else { &m.mesh.normals };
    let cos_theta = faces
        .iter()
        .map(|c| c.normalize())
        .chain(shading.iter().filter(|n| n.length_squared() > 0.0).map(|n| n.normalize()))
        .map(|n| w.dot(n))
        .fold(1.0f32, f32::min);
    DirectionCone { w, cos_theta: cos_theta.max(-1.0) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::TriangleMesh;
    use crate::math::Mat4;
    use glam::Quat;

    fn mesh_shape(mut m: TriangleMesh, world_from_object: Mat4) -> Shape {
        m.transform(&world_from_object);
        Shape::Mesh(Mesh::new(m, false))
    }

    /// A two-sided emitter is reached, sampled and powered from its back
    /// as from its front; a one-sided one is black from behind.
    #[test]
    fn two_sided_emits_from_the_back() {
        let quad = mesh_shape(TriangleMesh::rectangle(), Mat4::IDENTITY);
        let one = AreaLight { shape: 0, radiance: Spectrum::splat(2.0).into(), two_sided: false };
        let two = AreaLight { two_sided: true, ..one.clone() };
        let (front, back) = (Vec3::new(0.2, 0.1, 3.0), Vec3::new(0.2, 0.1, -3.0));
        let u = Vec2::new(0.3, 0.7);
        assert!(one.sample_li(back, u, &quad).is_none());
        let (f, b) = (two.sample_li(front, u, &quad).unwrap(), two.sample_li(back, u, &quad).unwrap());
        assert_eq!((f.li, f.pdf), (b.li, b.pdf));
        assert_eq!(one.sample_li(front, u, &quad).unwrap().li, f.li);
        assert_eq!(two.power(&quad), 2.0 * one.power(&quad));
        assert_eq!(two.bounds(&quad).cos_theta_o, DirectionCone::ENTIRE_SPHERE.cos_theta);
    }

    /// A textured emitter's sampled radiance is the texture where a ray
    /// along the sampled direction hits the shape (what `emitted` gives
    /// there), on a mesh, a disk and a sphere, so light sampling and hits
    /// weigh the same radiance; and the squares of the checkerboard are
    /// both reached.
    #[test]
    fn textured_radiance_agrees_between_samples_and_hits() {
        use crate::material::Material;
        use crate::scene::{Scene, ShapeInfo};
        use crate::texture::Checkerboard;
        let checker = Texture::Checkerboard(std::sync::Arc::new(Checkerboard {
            color0: Spectrum::new(1.0, 0.5, 0.25).into(),
            color1: Spectrum::new(0.1, 0.2, 0.9).into(),
            to_uv: glam::Affine2::from_scale(Vec2::new(3.0, 2.0)),
        }));
        let rect = Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0)) * Mat4::from_scale(Vec3::new(1.5, 1.0, 1.0));
        let shapes = vec![
            mesh_shape(TriangleMesh::rectangle(), rect),
            Shape::disk(Mat4::from_translation(Vec3::new(3.0, 0.0, -2.0)), false),
            Shape::sphere(Vec3::new(-3.0, 0.0, -2.0), 0.7, false),
        ];
        let info = (0..3).map(|i| ShapeInfo { material: 0, light: Some(i) }).collect();
        let lights = (0..3)
            .map(|i| super::super::Light::Area(AreaLight { shape: i, radiance: checker.clone(), two_sided: false }))
            .collect();
        let material = Material::Diffuse(crate::bsdf::DiffuseParams { reflectance: Spectrum::ZERO.into() });
        let scene = Scene::new(shapes, info, vec![material], lights);
        let p_ref = Vec3::new(0.2, 0.1, 1.0);
        for (i, light) in scene.lights.iter().enumerate() {
            let super::super::Light::Area(a) = light else { unreachable!() };
            let mut seen = [false; 2];
            for k in 0..400 {
                let u = Vec2::new((k % 20) as f32 + 0.5, (k / 20) as f32 + 0.5) / 20.0;
                let Some(s) = a.sample_li(p_ref, u, &scene.shapes[i]) else { continue };
                let si = scene.intersect(&Ray::new(p_ref, s.wi, f32::INFINITY)).expect("sampled point is hit");
                assert_eq!(si.shape, i as u32);
                assert_eq!(s.li, scene.emitted(&si), "shape {i}, sample {k}");
                seen[(s.li.z > 0.5) as usize] = true;
            }
            assert_eq!(seen, [true, true], "shape {i}");
        }
    }

    #[test]
    fn normal_cones_bound_the_emitters() {
        // A tilted planar mesh: its normal, θ_o ≈ 0.
        let n = Vec3::new(1.0, 2.0, -0.5).normalize();
        let m = Mat4::from_translation(Vec3::ONE)
            * Mat4::from_quat(Quat::from_rotation_arc(Vec3::Z, n))
            * Mat4::from_scale(Vec3::new(2.0, 0.3, 1.0));
        let c = normal_cone(&mesh_shape(TriangleMesh::rectangle(), m));
        assert!((c.w - n).length() < 1e-5 && c.cos_theta > 0.99999, "{c:?}");
        // Two faces at a right angle: θ_o = 45°.
        let bent = TriangleMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.0, 0.0, 1.0)],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        };
        let c = normal_cone(&Shape::Mesh(Mesh::new(bent, false)));
        assert!(
            (c.cos_theta - 0.5f32.sqrt()).abs() < 1e-5 && (c.w - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-5
        );
        // Closed shapes: every direction.
        assert_eq!(normal_cone(&mesh_shape(TriangleMesh::cube(), Mat4::IDENTITY)).cos_theta, -1.0);
        assert_eq!(normal_cone(&Shape::sphere(Vec3::ZERO, 1.0, false)).cos_theta, -1.0);
        // A flipped disk faces -z.
        let c = normal_cone(&Shape::disk(Mat4::IDENTITY, true));
        assert_eq!((c.w, c.cos_theta), (-Vec3::Z, 1.0));
        // Vertex normals that shade widen the cone.
        let mut m = TriangleMesh::rectangle();
        m.normals[0] = Vec3::new(1.0, 0.0, 1.0).normalize();
        let c = normal_cone(&Shape::Mesh(Mesh::new(m.clone(), false)));
        assert!((c.cos_theta - 0.5f32.sqrt()).abs() < 1e-5);
        assert_eq!(normal_cone(&Shape::Mesh(Mesh::new(m, true))).cos_theta, 1.0);
    }
}
