//! Emitters. Integrators reach them through [`crate::scene::Scene`]'s
//! `sample_light` / `light_pdf` / `emitted` / `environment` calls, which add
//! light selection ([`LightSampler`]).
//!
//! The contract every light fulfils, through [`Light`]:
//! - [`Light::sample_li`] picks a direction towards the light from a
//!   reference point; [`Light::pdf_li`] is the solid-angle density with which
//!   it picks a given one. `li` is the radiance arriving along `-wi`,
//!   unoccluded. For delta lights ([`Light::is_delta`]) the sample's `pdf` is
//!   1 and `li` is the delta's weight (I/d² for point and spot lights, E for
//!   directional ones), so `f · li · cos / pdf` is the contribution in every
//!   case, and `pdf_li` is 0 (no other direction finds them).
//! - [`Light::power`] (flux, for selection by power) and [`Light::bounds`]
//!   (where and in which directions it emits, for the light BVH).
//! - Lights at infinity that escaping rays see ([`Light::is_environment`])
//!   give their radiance through [`Light::environment`].
//! - [`Light::name`]: the Mitsuba plugin.
//!
//! Adding a light: its own file with its parameters documented, a variant
//! here and its arm in each `match` below (the compiler lists them), and its
//! plugin in the scene builder (`crates/scene/src/builder`).

pub mod area;
pub mod bvh;
pub mod constant;
pub mod directional;
pub mod directionalarea;
pub mod envmap;
pub mod equal_area;
pub mod image_point;
pub mod lane_table;
pub mod point;
pub mod projector;
pub mod sampler;
pub mod spot;
pub mod sunsky;

pub use area::AreaLight;
pub use bvh::LightBounds;
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use directionalarea::DirectionalAreaLight;
pub use envmap::EnvMapLight;
pub use equal_area::EqualAreaEnvLight;
pub use image_point::{DirectionMap, ImagePointLight};
pub use point::PointLight;
pub use projector::ProjectorLight;
pub use sampler::{LightSampler, LightSelection};
pub use spot::SpotLight;
pub use sunsky::SunskyLight;

use crate::geometry::{Shape, SurfaceInteraction};
use crate::math::Spectrum;
use glam::{Vec2, Vec3};

/// A direction sampled towards a light from a reference point.
#[derive(Debug, Clone, Copy)]
pub struct LightSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (infinite for lights at infinity).
    pub dist: f32,
    /// Density per unit solid angle (not including light selection).
    pub pdf: f32,
    /// Emitted radiance towards the reference point.
    pub li: Spectrum,
    /// Dirac-delta light (point, spot, directional): MIS does not apply.
    pub delta: bool,
}

/// The solid-angle sampling density (per steradian) above which a light
/// at infinity is concentrated in a direction, so that light paths carry
/// its caustics there ([`Light::caustics_by_light_paths`]): 25 times a
/// uniform sky's 1/(4π). A sky, overcast or clear, stays below it (at most
/// 0.06 in `tests/scenes/textures/sunsky.exr`) and a sun is far above it
/// (10 to 41 in that 128x64 map's sun texels; a sun in a finer map or
/// `sunsky`'s, thousands). Window rooms at 4 s (`tests/scenes/window*.xml`
/// at 96x72, relative variance) chose it: with a uniform sky, 6.4e-4 at
/// 1, 2 and 10 against 1.2e-2 with every environment on light paths; with
/// the sun and sky, 5.2e-3 / 5.9e-3 / 5.6e-3 against 6.9e-3, and 5.0e-2 at
/// 100 (above that map's sun).
pub const CONCENTRATED_PDF: f32 = 2.0;

/// An emitter: one variant per Mitsuba plugin, dispatched by `match`.
#[derive(Debug, Clone)]
pub enum Light {
    /// `area`: diffuse emission from the front side of a shape.
    Area(AreaLight),
    /// `constant`: uniform radiance from every direction at infinity.
    Constant(ConstantLight),
    /// `point`: isotropic point light (delta in position).
    Point(PointLight),
    /// `spot`: point light restricted to a cone (delta in position).
    Spot(SpotLight),
    /// `directional`: light from one direction at infinity (delta in direction).
    Directional(DirectionalLight),
    /// `envmap`: radiance at infinity from a latitude-longitude image.
    EnvMap(EnvMapLight),
    /// pbrt-v4 `infinite` with an image: radiance at infinity from a square
    /// equal-area octahedral image.
    EqualAreaEnv(EqualAreaEnvLight),
    /// `projector`: an image projected from a point (delta in position).
    Projector(ProjectorLight),
    /// pbrt-v4 `goniometric` / `projection`: a point light whose intensity
    /// is an image over directions (delta in position).
    ImagePoint(ImagePointLight),
    /// `directionalarea`: emission along a shape's normals (delta in
    /// direction), reached by no path this renderer traces.
    DirectionalArea(DirectionalAreaLight),
    /// `sunsky` / `timed_sunsky`: the Hosek–Wilkie sky and sun at infinity
    /// (`timed` tells which plugin, for [`Light::name`]).
    Sunsky {
        /// The model at the rendered instant.
        light: Box<SunskyLight>,
        /// Built from `timed_sunsky`.
        timed: bool,
    },
}

impl Light {
    /// The Mitsuba plugin this light implements.
    pub fn name(&self) -> &'static str {
        match self {
            Light::Area(_) => "area",
            Light::Constant(_) => "constant",
            Light::Point(_) => "point",
            Light::Spot(_) => "spot",
            Light::Directional(_) => "directional",
            Light::EnvMap(_) => "envmap",
            Light::EqualAreaEnv(_) => "infinite",
            Light::Projector(_) => "projector",
            Light::ImagePoint(l) => match l.map() {
                DirectionMap::EqualArea => "goniometric",
                DirectionMap::Perspective { .. } => "projection",
            },
            Light::DirectionalArea(_) => "directionalarea",
            Light::Sunsky { timed: false, .. } => "sunsky",
            Light::Sunsky { timed: true, .. } => "timed_sunsky",
        }
    }

    /// Samples a direction towards the light from `p_ref` with `u2` in
    /// [0, 1)² (the pdf excludes selection). No visibility test.
    pub fn sample_li(&self, p_ref: Vec3, u2: Vec2, shapes: &[Shape]) -> Option<LightSample> {
        match self {
            Light::Area(a) => a.sample_li(p_ref, u2, &shapes[a.shape as usize]),
            Light::Constant(c) => c.sample_li(u2),
            Light::Point(p) => p.sample_li(p_ref),
            Light::Spot(s) => s.sample_li(p_ref),
            Light::Directional(d) => d.sample_li(),
            Light::EnvMap(e) => e.sample_li(u2),
            Light::EqualAreaEnv(e) => e.sample_li(u2),
            Light::Projector(p) => p.sample_li(p_ref),
            Light::ImagePoint(l) => l.sample_li(p_ref),
            Light::DirectionalArea(d) => d.sample_li(),
            Light::Sunsky { light, .. } => light.sample_li(u2),
        }
    }

    /// Solid-angle density at `p_ref` with which [`Self::sample_li`] picks
    /// the unit direction `wi` (selection excluded). `hit` is where `wi`
    /// meets the light's surface, for lights on shapes (an area light's pdf
    /// is 0 without it); lights at infinity need only `wi`. 0 for delta lights.
    #[inline]
    pub fn pdf_li(&self, p_ref: Vec3, wi: Vec3, hit: Option<&SurfaceInteraction>, shapes: &[Shape]) -> f32 {
        match self {
            Light::Area(a) => hit.map_or(0.0, |hit| a.pdf_li(p_ref, hit, &shapes[a.shape as usize])),
            Light::Constant(c) => c.pdf(),
            Light::EnvMap(e) => e.pdf(wi),
            Light::EqualAreaEnv(e) => e.pdf(wi),
            Light::Sunsky { light, .. } => light.pdf(wi),
            Light::Point(_)
            | Light::Spot(_)
            | Light::Directional(_)
            | Light::Projector(_)
            | Light::ImagePoint(_)
            | Light::DirectionalArea(_) => 0.0,
        }
    }

    /// Whether this light is at infinity and seen by rays that escape the
    /// scene (constant, envmap; a directional light is at infinity too, but
    /// a delta that no ray hits).
    pub fn is_environment(&self) -> bool {
        match self {
            Light::Constant(_) | Light::EnvMap(_) | Light::EqualAreaEnv(_) | Light::Sunsky { .. } => true,
            Light::Area(_)
            | Light::Point(_)
            | Light::Spot(_)
            | Light::Directional(_)
            | Light::Projector(_)
            | Light::ImagePoint(_)
            | Light::DirectionalArea(_) => false,
        }
    }

    /// Whether light paths carry the caustics of this light's emission
    /// arriving from direction `wi` (`integrator/path/caustics.rs`), rather
    /// than camera paths: always for an area light; for a light at infinity
    /// only where its sampling density exceeds [`CONCENTRATED_PDF`] (a sun,
    /// not a sky); never for delta lights (no camera path reaches them).
    /// A camera path finds a wide source through glass easily, while light
    /// paths, a few per pixel and spread over everything the glass lights,
    /// find it no better: a room lit by a uniform sky through a window had
    /// 18x the variance with the sky's caustics on light paths.
    #[inline]
    pub fn caustics_by_light_paths(&self, wi: Vec3) -> bool {
        match self {
            Light::Area(_) => true,
            l if l.is_environment() => l.environment(wi).1 > CONCENTRATED_PDF,
            _ => false,
        }
    }

    /// The radiance from direction `wi` of a light at infinity whose
    /// caustics camera paths carry there (not
    /// [`Self::caustics_by_light_paths`]), else zero: its radiance and
    /// density found at once.
    #[inline]
    pub fn environment_left_to_camera(&self, wi: Vec3) -> Spectrum {
        match self.environment(wi) {
            (_, pdf) if pdf > CONCENTRATED_PDF => Spectrum::ZERO,
            (le, _) => le,
        }
    }

    /// Radiance from direction `wi` for lights at infinity (zero otherwise),
    /// and the solid-angle density with which `sample_li` picks `wi`: the
    /// `pdf_li` of environment lights, sharing their work with the radiance.
    #[inline]
    pub fn environment(&self, wi: Vec3) -> (Spectrum, f32) {
        match self {
            Light::Constant(c) => (c.radiance, c.pdf()),
            Light::EnvMap(e) => e.eval_pdf(wi),
            Light::EqualAreaEnv(e) => e.eval_pdf(wi),
            Light::Sunsky { light, .. } => light.eval_pdf(wi),
            Light::Area(_)
            | Light::Point(_)
            | Light::Spot(_)
            | Light::Directional(_)
            | Light::Projector(_)
            | Light::ImagePoint(_)
            | Light::DirectionalArea(_) => (Spectrum::ZERO, 0.0),
        }
    }

    /// [`Self::environment`] without the density, for paths whose last
    /// vertex was the camera or a specular bounce (no MIS weight to form).
    #[inline]
    pub fn environment_radiance(&self, wi: Vec3) -> Spectrum {
        match self {
            Light::Constant(c) => c.radiance,
            Light::EnvMap(e) => e.eval(wi),
            Light::EqualAreaEnv(e) => e.eval(wi),
            Light::Sunsky { light, .. } => light.eval(wi),
            Light::Area(_)
            | Light::Point(_)
            | Light::Spot(_)
            | Light::Directional(_)
            | Light::Projector(_)
            | Light::ImagePoint(_)
            | Light::DirectionalArea(_) => Spectrum::ZERO,
        }
    }

    /// Dirac-delta lights (point, spot, directional, projector,
    /// directionalarea): reachable only by light sampling.
    pub fn is_delta(&self) -> bool {
        match self {
            Light::Point(_)
            | Light::Spot(_)
            | Light::Directional(_)
            | Light::Projector(_)
            | Light::ImagePoint(_)
            | Light::DirectionalArea(_) => true,
            Light::Area(_) | Light::Constant(_) | Light::EnvMap(_) | Light::EqualAreaEnv(_) | Light::Sunsky { .. } => {
                false
            }
        }
    }

    /// Emitted flux (its luminance weights selection by power).
    /// `scene_radius` bounds the scene, for the environment lights' flux
    /// through it (a directional light holds the radius it was built with).
    pub fn power(&self, shapes: &[Shape], scene_radius: f32) -> Spectrum {
        match self {
            Light::Area(a) => a.power(&shapes[a.shape as usize]),
            Light::Constant(c) => c.power(scene_radius),
            Light::Point(p) => p.power(),
            Light::Spot(s) => s.power(),
            Light::Directional(d) => d.power(),
            Light::EnvMap(e) => e.power(scene_radius),
            Light::EqualAreaEnv(e) => e.power(scene_radius),
            Light::Sunsky { light, .. } => light.power(scene_radius),
            Light::Projector(p) => p.power(),
            Light::ImagePoint(l) => l.power(),
            // No weight for a light no sample can reach (see directionalarea.rs).
            Light::DirectionalArea(_) => Spectrum::ZERO,
        }
    }

    /// Where and in which directions the light emits, for the light BVH;
    /// None for lights at infinity (constant, envmap, directional), which
    /// stay outside the tree. Bounds with φ = 0 mark a light that emits
    /// nothing.
    pub fn bounds(&self, shapes: &[Shape]) -> Option<LightBounds> {
        match self {
            Light::Area(a) => Some(a.bounds(&shapes[a.shape as usize])),
            Light::Point(p) => Some(p.bounds()),
            Light::Spot(s) => Some(s.bounds()),
            Light::Projector(p) => Some(p.bounds()),
            Light::ImagePoint(l) => Some(l.bounds()),
            Light::DirectionalArea(d) => Some(d.bounds(&shapes[d.shape as usize])),
            Light::Constant(_)
            | Light::EnvMap(_)
            | Light::EqualAreaEnv(_)
            | Light::Sunsky { .. }
            | Light::Directional(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::material::Material;
    use crate::math::Mat4;
    use crate::scene::{Scene, ShapeInfo};

    /// One light of each kind; the area lights on a sphere and a disk.
    fn every_light() -> Scene {
        let disk =
            Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0)) * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
        let shapes = vec![Shape::sphere(Vec3::new(2.0, 1.0, -1.0), 0.5, false), Shape::disk(disk, false)];
        let info = vec![ShapeInfo { material: 0, light: Some(0) }, ShapeInfo { material: 0, light: Some(1) }];
        let texels: Vec<[f32; 3]> = (0..8 * 5).map(|k| [1.0 + (k % 7) as f32, 0.5, 0.2 * (k / 8) as f32]).collect();
        let lights = vec![
            Light::Area(AreaLight { shape: 0, radiance: Spectrum::splat(2.0).into(), two_sided: false }),
            Light::Area(AreaLight { shape: 1, radiance: Spectrum::ONE.into(), two_sided: false }),
            Light::Constant(ConstantLight { radiance: Spectrum::splat(0.5) }),
            Light::EnvMap(EnvMapLight::new(8, 5, texels, Mat4::from_rotation_y(0.3), 1.0).unwrap()),
            Light::EqualAreaEnv(
                EqualAreaEnvLight::new(
                    4,
                    (0..16).map(|k| [0.2 + k as f32, 1.0, 0.1]).collect(),
                    Mat4::from_rotation_x(0.4),
                    0.5,
                )
                .unwrap(),
            ),
            Light::Point(PointLight { position: Vec3::new(0.0, 2.0, 1.0), intensity: Spectrum::ONE }),
            Light::Spot(SpotLight::new(Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0)), Spectrum::ONE, 60.0, 30.0)),
            Light::Directional(DirectionalLight { direction: -Vec3::Y, irradiance: Spectrum::ONE, scene_radius: 3.0 }),
            Light::Projector(ProjectorLight::new(
                crate::math::look_at(Vec3::new(0.0, 2.0, 2.0), Vec3::ZERO, Vec3::Y),
                Spectrum::new(1.0, 0.5, 0.2).into(),
                2.0,
                Vec2::new(0.6, 0.4),
            )),
        ];
        Scene::new(
            shapes,
            info,
            vec![Material::Diffuse(crate::bsdf::DiffuseParams { reflectance: Spectrum::splat(0.5).into() })],
            lights,
        )
    }

    #[test]
    fn names_are_mitsubas_plugins() {
        let names: Vec<&str> = every_light().lights.iter().map(Light::name).collect();
        assert_eq!(
            names,
            ["area", "area", "constant", "envmap", "infinite", "point", "spot", "directional", "projector"]
        );
    }

    /// `pdf_li` is the density `sample_li` reports (at the emitter point the
    /// sampled direction hits, for area lights), 0 for delta lights, and
    /// `environment` gives the same density bit for bit.
    #[test]
    fn pdf_li_is_the_sampled_density() {
        let scene = every_light();
        let p_ref = Vec3::new(0.1, 0.2, 0.3);
        let mut checked = [0usize; 9];
        for (i, light) in scene.lights.iter().enumerate() {
            for k in 0..256 {
                let u = Vec2::new((k % 16) as f32 + 0.5, (k / 16) as f32 + 0.5) / 16.0;
                let Some(s) = light.sample_li(p_ref, u, &scene.shapes) else { continue };
                assert_eq!(s.delta, light.is_delta());
                let pdf = if light.is_delta() {
                    light.pdf_li(p_ref, s.wi, None, &scene.shapes)
                } else if light.is_environment() {
                    let pdf = light.pdf_li(p_ref, s.wi, None, &scene.shapes);
                    assert_eq!(light.environment(s.wi).1.to_bits(), pdf.to_bits());
                    pdf
                } else {
                    let si = scene.intersect(&Ray::new(p_ref, s.wi, f32::INFINITY)).expect("sampled point is hit");
                    assert_eq!(scene.shape_info[si.shape as usize].light, Some(i as u32));
                    assert_eq!(light.pdf_li(p_ref, s.wi, None, &scene.shapes), 0.0);
                    light.pdf_li(p_ref, s.wi, Some(&si), &scene.shapes)
                };
                if light.is_delta() {
                    assert_eq!(pdf, 0.0, "{}", light.name());
                } else {
                    assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{}: pdf_li {pdf} vs sampled {}", light.name(), s.pdf);
                }
                checked[i] += 1;
            }
        }
        assert!(checked.iter().all(|&n| n > 0), "{checked:?}");
    }

    /// Lights at infinity have no bounds; the others are bounded with their
    /// power (4π I for a spot light, as pbrt).
    #[test]
    fn bounds_hold_the_finite_lights() {
        let scene = every_light();
        for light in &scene.lights {
            let b = light.bounds(&scene.shapes);
            let at_infinity =
                matches!(light, Light::Constant(_) | Light::EnvMap(_) | Light::EqualAreaEnv(_) | Light::Directional(_));
            assert_eq!(b.is_none(), at_infinity, "{}", light.name());
            if let Some(b) = b {
                assert!(b.emits(), "{}", light.name());
                let phi = match light {
                    Light::Spot(s) => 4.0 * crate::math::PI * crate::math::luminance(s.intensity),
                    _ => crate::math::luminance(light.power(&scene.shapes, 1.0)),
                };
                assert_eq!(b.phi, phi, "{}", light.name());
            }
        }
        let Light::Area(sphere) = &scene.lights[0] else { unreachable!() };
        let b = scene.lights[0].bounds(&scene.shapes).unwrap();
        assert_eq!(b.bounds, scene.shapes[sphere.shape as usize].prim_bounds(0));
    }
}
