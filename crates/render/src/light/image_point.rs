//! pbrt-v4's `goniometric` and `projection` lights: point lights whose
//! radiant intensity over directions is an image, looked up at the nearest
//! texel (pbrt-v4's `LookupNearest`, clamped at the edges). Dirac deltas in
//! position: only light sampling reaches them.
//!
//! For a light-space unit direction w (world directions reach light space
//! through the inverse of the light's frame):
//!
//! - **goniometric**: I(w) = I · image(u, v), (u, v) = the equal-area
//!   octahedral square of w ([`warp::equal_area_sphere_to_square`]), the
//!   image a square grey map (pbrt-v4 averages R, G and B);
//! - **projection**: I(w) = image(u, v) for w.z ≥ 10⁻³, with (u, v) =
//!   (½ + ½ w.x / (w.z t_x), ½ + ½ w.y / (w.z t_y)) inside [0, 1]², and 0
//!   elsewhere: a pinhole of half-widths t_x, t_y on the plane z = 1. Unlike
//!   Mitsuba's `projector` there is no cos³ factor: the image is intensity.
//!
//! Incident radiance at p is the delta I(w) / |p − x|² towards the light.
//! The translator composes pbrt-v4's own changes of frame (the y-z swap of
//! `goniometric`, the y flip of `projection`) into the light's frame.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x >= y)` is also true for NaN, on purpose

use super::bvh::{DirectionCone, LightBounds};
use super::LightSample;
use crate::geometry::Aabb;
use crate::math::{luminance, Spectrum, PI};
use crate::sampling::warp;
use glam::{Mat3, Vec2, Vec3};

/// How a light-space direction finds its texel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DirectionMap {
    /// The equal-area octahedral square (`goniometric`).
    EqualArea,
    /// A pinhole projection onto the plane z = 1 (`projection`), spanning
    /// ±`tan_half.x` and ±`tan_half.y` there.
    Perspective {
        /// Half-widths of the image on the plane z = 1.
        tan_half: Vec2,
    },
}

/// pbrt-v4's `hither` of the projection light: directions closer to its
/// plane than this get nothing.
const HITHER: f32 = 1e-3;

/// A point light with an image of intensities (see the module docs).
#[derive(Debug, Clone)]
pub struct ImagePointLight {
    /// Position in world space.
    pub position: Vec3,
    light_from_world: Mat3,
    map: DirectionMap,
    width: usize,
    height: usize,
    /// Row-major, row 0 the image's top row (v = 0).
    texels: Vec<Spectrum>,
    /// Flux, for selection by power.
    power: Spectrum,
}

impl ImagePointLight {
    /// A light at `position` whose light space is `light_from_world` applied
    /// to world directions, with the `width` × `height` image `texels`
    /// (row-major, scale and colour already applied).
    pub fn new(
        position: Vec3,
        light_from_world: Mat3,
        map: DirectionMap,
        width: usize,
        height: usize,
        texels: Vec<Spectrum>,
    ) -> Result<ImagePointLight, String> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return Err(format!("an image of {width}x{height} pixels with {} values", texels.len()));
        }
        if let Some(t) = texels.iter().find(|t| !t.is_finite() || t.min_element() < 0.0) {
            return Err(format!("intensity {t} is not finite and non-negative"));
        }
        if map == DirectionMap::EqualArea && width != height {
            return Err(format!("an equal-area image is square, not {width}x{height}"));
        }
        if !(position.is_finite() && light_from_world.is_finite() && light_from_world.determinant() != 0.0) {
            return Err("the light's transform is singular or not finite".into());
        }
        let power = flux(map, width, height, &texels);
        Ok(ImagePointLight { position, light_from_world, map, width, height, texels, power })
    }

    /// How directions find their texel.
    pub fn map(&self) -> DirectionMap {
        self.map
    }

    /// I(w) for the light-space unit direction `w`.
    pub fn intensity(&self, w: Vec3) -> Spectrum {
        let uv = match self.map {
            DirectionMap::EqualArea => warp::equal_area_sphere_to_square(w),
            DirectionMap::Perspective { tan_half } => {
                if !(w.z >= HITHER) {
                    return Spectrum::ZERO;
                }
                let uv = Vec2::new(0.5 + 0.5 * w.x / (w.z * tan_half.x), 0.5 + 0.5 * w.y / (w.z * tan_half.y));
                if !(uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()) {
                    return Spectrum::ZERO;
                }
                uv
            }
        };
        self.nearest(uv)
    }

    /// The texel under `uv`, clamped to the image.
    fn nearest(&self, uv: Vec2) -> Spectrum {
        // `as usize` saturates: negative values and NaN give 0.
        let x = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        self.texels[y * self.width + x]
    }

    /// The direction to the light as a delta: pdf 1, `li` = I(w) / d².
    pub fn sample_li(&self, p_ref: Vec3) -> Option<LightSample> {
        let (wi, dist) = super::point::towards(p_ref, self.position)?;
        let w = (self.light_from_world * -wi).normalize();
        let i = self.intensity(w);
        if i == Spectrum::ZERO {
            return None;
        }
        Some(LightSample { wi, dist, pdf: 1.0, li: i / (dist * dist), delta: true })
    }

    /// Radiant flux Φ = ∫ I dω (for selection by power).
    pub fn power(&self) -> Spectrum {
        self.power
    }

    /// Its position, emitting in any direction (a cone over the projection's
    /// pyramid would be tighter; the whole sphere is never wrong).
    pub fn bounds(&self) -> LightBounds {
        let at = Aabb { min: self.position, max: self.position };
        LightBounds::new(at, DirectionCone::ENTIRE_SPHERE, 0.0, luminance(self.power))
    }
}

/// ∫ I dω: each equal-area texel covers 4π / (W H) exactly; a projection
/// texel covers the solid angle of its rectangle on the plane z = 1, in
/// closed form: Ω = Σ ± atan(x y / √(1 + x² + y²)) over its corners.
fn flux(map: DirectionMap, width: usize, height: usize, texels: &[Spectrum]) -> Spectrum {
    match map {
        DirectionMap::EqualArea => texels.iter().copied().sum::<Spectrum>() * (4.0 * PI / (width * height) as f32),
        DirectionMap::Perspective { tan_half } => {
            let f = |x: f64, y: f64| (x * y / (1.0 + x * x + y * y).sqrt()).atan();
            let edge = |k: usize, n: usize, t: f32| (2.0 * k as f64 / n as f64 - 1.0) * t as f64;
            let mut sum = glam::DVec3::ZERO;
            for (k, t) in texels.iter().enumerate() {
                let (x, y) = (k % width, k / width);
                let (x0, x1) = (edge(x, width, tan_half.x), edge(x + 1, width, tan_half.x));
                let (y0, y1) = (edge(y, height, tan_half.y), edge(y + 1, height, tan_half.y));
                sum += t.as_dvec3() * (f(x1, y1) - f(x0, y1) - f(x1, y0) + f(x0, y0));
            }
            sum.as_vec3()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4x2 image of distinct texels, so a wrong texel shows.
    fn texels(w: usize, h: usize) -> Vec<Spectrum> {
        (0..w * h).map(|k| Spectrum::new(1.0 + k as f32, 2.0, 0.5 + 0.25 * k as f32)).collect()
    }

    /// The projection's texels land where pbrt-v4's screen bounds put them:
    /// +x of light space to the right (u grows), +y to v = 1 (pbrt's image
    /// rows; its y flip is the translator's), nothing behind or outside.
    #[test]
    fn projection_texels_sit_where_pbrt_puts_them() {
        let tan_half = Vec2::new(2.0, 1.0); // aspect 2, fov 90
        let l = ImagePointLight::new(
            Vec3::ZERO,
            Mat3::IDENTITY,
            DirectionMap::Perspective { tan_half },
            4,
            2,
            texels(4, 2),
        )
        .unwrap();
        let t = texels(4, 2);
        // Centre of texel (x, y) at screen ((2 (x + ½) / 4 - 1) · 2, (2 (y + ½) / 2 - 1) · 1).
        for y in 0..2 {
            for x in 0..4 {
                let s =
                    Vec2::new((2.0 * (x as f32 + 0.5) / 4.0 - 1.0) * 2.0, (2.0 * (y as f32 + 0.5) / 2.0 - 1.0) * 1.0);
                let w = Vec3::new(s.x, s.y, 1.0).normalize();
                assert_eq!(l.intensity(w), t[y * 4 + x], "texel ({x}, {y})");
            }
        }
        assert_eq!(l.intensity(Vec3::new(0.0, 0.0, -1.0)), Spectrum::ZERO);
        assert_eq!(l.intensity(Vec3::new(2.5, 0.0, 1.0).normalize()), Spectrum::ZERO);
        assert_eq!(l.intensity(Vec3::new(0.0, 1.2, 1.0).normalize()), Spectrum::ZERO);
    }

    /// li = I(w) / d², towards the light, through the light's frame.
    #[test]
    fn sample_is_intensity_over_distance_squared() {
        let frame = Mat3::from_rotation_y(0.3);
        let pos = Vec3::new(1.0, 2.0, 3.0);
        let l = ImagePointLight::new(pos, frame.transpose(), DirectionMap::EqualArea, 8, 8, texels(8, 8)).unwrap();
        let p = Vec3::new(-1.0, 0.5, 1.0);
        let s = l.sample_li(p).unwrap();
        let d = pos - p;
        assert!((s.wi - d.normalize()).length() < 1e-6 && (s.dist - d.length()).abs() < 1e-5);
        let w = (frame.transpose() * -s.wi).normalize();
        let i = l.intensity(w);
        assert!(((s.li - i / d.length_squared()).abs().max_element()) < 1e-6);
        assert!(s.delta && s.pdf == 1.0);
    }

    /// The flux is ∫ I dω: against a Monte Carlo integral over the sphere
    /// (uniform directions, fixed seed, 5 standard errors).
    #[test]
    fn power_is_the_integral_of_intensity() {
        let cases = [
            ImagePointLight::new(Vec3::ZERO, Mat3::IDENTITY, DirectionMap::EqualArea, 8, 8, texels(8, 8)).unwrap(),
            ImagePointLight::new(
                Vec3::ZERO,
                Mat3::IDENTITY,
                DirectionMap::Perspective { tan_half: Vec2::new(0.8, 0.5) },
                16,
                10,
                texels(16, 10),
            )
            .unwrap(),
        ];
        for l in &cases {
            // xorshift64*, fixed seed.
            let mut state = 0x9e37_79b9_7f4a_7c15u64;
            let mut next = || {
                state ^= state >> 12;
                state ^= state << 25;
                state ^= state >> 27;
                (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32 / (1u64 << 24) as f32
            };
            let n = 400_000;
            let (mut s, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let w = warp::sample_uniform_sphere(Vec2::new(next(), next()));
                let f = luminance(l.intensity(w)) as f64 * 4.0 * std::f64::consts::PI;
                s += f;
                s2 += f * f;
            }
            let mean = s / n as f64;
            let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
            let want = luminance(l.power()) as f64;
            assert!((mean - want).abs() < 5.0 * se, "{:?}: {mean} ± {se} against {want}", l.map);
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let eq = DirectionMap::EqualArea;
        assert!(ImagePointLight::new(Vec3::ZERO, Mat3::IDENTITY, eq, 4, 2, texels(4, 2)).is_err());
        assert!(ImagePointLight::new(Vec3::ZERO, Mat3::IDENTITY, eq, 2, 2, texels(3, 1)).is_err());
        let mut t = texels(2, 2);
        t[1].x = f32::NAN;
        assert!(ImagePointLight::new(Vec3::ZERO, Mat3::IDENTITY, eq, 2, 2, t).is_err());
        assert!(ImagePointLight::new(Vec3::ZERO, Mat3::ZERO, eq, 2, 2, texels(2, 2)).is_err());
    }
}
