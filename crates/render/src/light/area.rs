//! Mitsuba `area`: a diffuse emitter attached to a shape, emitting
//! `radiance` from the shape's front side only (the side its shading normal
//! points to). Sampled by the shape's `sample_direction` (the subtended cone
//! for spheres seen from outside, the area otherwise).
//!
//! | parameter | type | default |
//! |-----------|------|---------|
//! | radiance  | rgb  | (required) |
//!
//! Declared inside a `<shape>`; the shape must have positive area and may
//! not belong to a `shapegroup`.

use super::bvh::{DirectionCone, LightBounds};
use super::LightSample;
use crate::geometry::{Aabb, Mesh, Shape, SurfaceInteraction};
use crate::math::{luminance, Spectrum, PI};
use glam::{Vec2, Vec3};

/// Mitsuba's `area` emitter on one shape.
#[derive(Debug, Clone)]
pub struct AreaLight {
    /// Index of the emitting shape in the scene's shapes.
    pub shape: u32,
    /// Emitted radiance (W/(m² sr)), the same in every front-facing direction.
    pub radiance: Spectrum,
}

impl AreaLight {
    /// Radiance leaving the surface with front normal `n` towards `w`.
    #[inline]
    pub fn emitted(&self, n: Vec3, w: Vec3) -> Spectrum {
        if n.dot(w) > 0.0 {
            self.radiance
        } else {
            Spectrum::ZERO
        }
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
        let li = self.emitted(s.n, -wi);
        if li == Spectrum::ZERO {
            return None;
        }
        Some(LightSample { wi, dist, pdf: s.pdf, li, delta: false })
    }

    /// Solid-angle density at `p_ref` with which `sample_li` reaches the
    /// point `hit` of `shape` (this light's shape).
    #[inline]
    pub fn pdf_li(&self, p_ref: Vec3, hit: &SurfaceInteraction, shape: &Shape) -> f32 {
        shape.pdf_direction(p_ref, hit.p, hit.n)
    }

    /// Φ = π A L for a one-sided diffuse emitter.
    pub fn power(&self, shape: &Shape) -> Spectrum {
        PI * shape.area() * self.radiance
    }

    /// The shape's box and the cone of its front-facing normals; diffuse
    /// emission spreads θ_e = π/2 around each normal.
    pub fn bounds(&self, shape: &Shape) -> LightBounds {
        LightBounds::new(shape_bounds(shape), normal_cone(shape), 0.0, luminance(self.power(shape)))
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
