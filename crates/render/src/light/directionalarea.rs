//! Mitsuba `directionalarea`: a shape that emits `radiance` only along its
//! normal, a Dirac delta in direction at every point of the surface.
//!
//! | parameter | type | default |
//! |-----------|------|---------|
//! | radiance  | rgb  | 1 |
//!
//! Declared inside a `<shape>` like `area`. As Mitsuba 3.9.1 notes, only a
//! particle tracer can render it: a camera path meets the surface from the
//! one emitted direction with probability zero, and a connection from a
//! surface point would have to land on the point whose normal points back at
//! it. Its `sample_direction` and `eval` return zero (directionalarea.cpp),
//! so under `path`, `direct` and `volpath` it lights nothing and is seen as
//! its shape's BSDF alone; the same holds here. Its flux, Φ = L A (all of it
//! along the normals), is kept for reference; selection by power gives it
//! no weight, since no sample it drew could contribute.

use super::bvh::{DirectionCone, LightBounds};
use super::LightSample;
use crate::geometry::{Aabb, Shape};
use crate::math::Spectrum;

/// Mitsuba's `directionalarea` emitter on one shape.
#[derive(Debug, Clone)]
pub struct DirectionalAreaLight {
    /// Index of the emitting shape in the scene's shapes.
    pub shape: u32,
    /// Radiance along the normal (W/(m² sr), as a delta in direction).
    pub radiance: Spectrum,
}

impl DirectionalAreaLight {
    /// No direction from a reference point reaches the emission (see the
    /// module's note): always None, as Mitsuba's `sample_direction`.
    pub fn sample_li(&self) -> Option<LightSample> {
        None
    }

    /// Φ = L A: radiance L along the normal of each point of the area A.
    pub fn flux(&self, shape: &Shape) -> Spectrum {
        self.radiance * shape.area()
    }

    /// Its shape's box with zero power: the light BVH never picks it.
    pub fn bounds(&self, shape: &Shape) -> LightBounds {
        let b = (0..shape.prim_count()).fold(Aabb::EMPTY, |b, i| b.union(shape.prim_bounds(i)));
        LightBounds::new(b, DirectionCone::ENTIRE_SPHERE, 1.0, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::light::Light;
    use crate::material::Material;
    use crate::scene::{Scene, ShapeInfo};
    use glam::{Vec2, Vec3};

    /// Neither light sampling nor a hit on the shape finds any radiance,
    /// from in front of the surface along its normal too; the flux is L A.
    #[test]
    fn nothing_reaches_it_from_a_reference_point() {
        let shape = Shape::disk(crate::math::Mat4::IDENTITY, false);
        let light = DirectionalAreaLight { shape: 0, radiance: Spectrum::new(3.0, 2.0, 1.0) };
        assert!((light.flux(&shape) - Spectrum::new(3.0, 2.0, 1.0) * crate::math::PI).abs().max_element() < 1e-5);
        let material = Material::Diffuse(crate::bsdf::DiffuseParams { reflectance: Spectrum::ZERO.into() });
        let info = vec![ShapeInfo { material: 0, light: Some(0) }];
        let scene = Scene::new(vec![shape], info, vec![material], vec![Light::DirectionalArea(light)]);
        let l = &scene.lights[0];
        let p_ref = Vec3::new(0.0, 0.0, 2.0);
        assert!(l.is_delta() && !l.is_environment() && l.name() == "directionalarea");
        for k in 0..16 {
            let u = Vec2::new((k % 4) as f32 + 0.5, (k / 4) as f32 + 0.5) / 4.0;
            assert!(scene.sample_light(p_ref, -Vec3::Z, 0.5, u).is_none());
        }
        let si = scene.intersect(&Ray::new(p_ref, -Vec3::Z, f32::INFINITY)).unwrap();
        assert_eq!(scene.emitted(&si), Spectrum::ZERO);
        assert_eq!(l.pdf_li(p_ref, -Vec3::Z, Some(&si), &scene.shapes), 0.0);
        assert_eq!(l.power(&scene.shapes, 1.0), Spectrum::ZERO);
        assert!(!l.bounds(&scene.shapes).unwrap().emits());
    }
}
