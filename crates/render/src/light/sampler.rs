//! Light selection: which light [`crate::scene::Scene::sample_light`]
//! samples for a receiver, and with what probability.

use super::bvh::LightBvh;
use super::Light;
use crate::geometry::Shape;
use crate::math::{fast, luminance};
use crate::sampling::Distribution1D;
use glam::Vec3;

/// The selection strategy a scene asks for: the integrators'
/// `light_selection` parameter (`uniform`, `power`, `bvh`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightSelection {
    /// Every light with the same probability (Mitsuba's choice).
    #[default]
    Uniform,
    /// Proportional to each light's emitted power (luminance of its flux).
    Power,
    /// Proportional to each light's estimated contribution at the receiver,
    /// through a light BVH (pbrt-v4's BVH light sampler).
    Bvh,
}

impl LightSelection {
    /// Its name as the `light_selection` parameter spells it.
    pub fn name(self) -> &'static str {
        match self {
            LightSelection::Uniform => "uniform",
            LightSelection::Power => "power",
            LightSelection::Bvh => "bvh",
        }
    }
}

/// A [`LightSelection`] with the tables it needs, built for one scene's lights.
#[derive(Debug, Clone)]
pub enum LightSampler {
    /// Each of `count` lights with probability 1 / `count`.
    Uniform {
        /// Number of lights.
        count: usize,
    },
    /// By power: an alias table over the lights' flux luminances.
    Power(Distribution1D),
    /// By importance at the receiver.
    Bvh(LightBvh),
}

impl LightSampler {
    /// Precomputes `kind` for `lights` (on `shapes`, in a scene of bounding
    /// radius `scene_radius`, which sets the power of lights at infinity).
    /// Selection by power falls back to uniform when no light has positive
    /// power.
    pub fn build(kind: LightSelection, lights: &[Light], shapes: &[Shape], scene_radius: f32) -> LightSampler {
        let uniform = LightSampler::Uniform { count: lights.len() };
        match kind {
            LightSelection::Uniform => uniform,
            LightSelection::Power => {
                let w: Vec<f32> = lights.iter().map(|l| luminance(l.power(shapes, scene_radius)).max(0.0)).collect();
                Distribution1D::new(&w).map_or(uniform, LightSampler::Power)
            }
            LightSelection::Bvh => LightSampler::Bvh(LightBvh::build(lights, shapes)),
        }
    }

    /// The strategy in use (`Uniform` where selection by power fell back to it).
    pub fn kind(&self) -> LightSelection {
        match self {
            LightSampler::Uniform { .. } => LightSelection::Uniform,
            LightSampler::Power(_) => LightSelection::Power,
            LightSampler::Bvh(_) => LightSelection::Bvh,
        }
    }

    /// Picks a light for a receiver at `p` with normal `n` (`Vec3::ZERO` when
    /// there is none, e.g. the camera) with `u` in [0, 1): (index,
    /// probability). None when there is no light, or when the BVH finds no
    /// importance at the receiver (retrying would bias the estimate).
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32)> {
        match self {
            LightSampler::Uniform { count: 0 } => None,
            &LightSampler::Uniform { count } => {
                // fast::index is `as usize` for u * count in [0, 2^31) and NaN.
                Some((fast::index(u * count as f32).min(count - 1), 1.0 / count as f32))
            }
            LightSampler::Power(d) => {
                let (i, pmf, _) = d.sample_discrete(u);
                Some((i, pmf))
            }
            LightSampler::Bvh(bvh) => bvh.sample(p, n, u),
        }
    }

    /// Whether [`Self::sample`]'s pick does not depend on its number: there
    /// is at most one light to pick (the light BVH aside), so a caller may
    /// skip drawing it.
    #[inline]
    pub fn picks_without_number(&self) -> bool {
        match self {
            LightSampler::Uniform { count } => *count <= 1,
            LightSampler::Power(d) => d.len() <= 1,
            LightSampler::Bvh(_) => false,
        }
    }

    /// Probability that `sample` picks light `i` for a receiver at (`p`, `n`),
    /// bit-identical to the probability `sample` returns with it.
    #[inline]
    pub fn pmf(&self, p: Vec3, n: Vec3, i: usize) -> f32 {
        match self {
            LightSampler::Uniform { count } => 1.0 / *count as f32,
            LightSampler::Power(d) => d.pmf(i),
            LightSampler::Bvh(bvh) => bvh.pmf(p, n, i),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::PointLight;
    use crate::math::Spectrum;

    fn point(intensity: f32) -> Light {
        Light::Point(PointLight { position: Vec3::Y, intensity: Spectrum::splat(intensity) })
    }

    #[test]
    fn no_lights_no_sample() {
        for kind in [LightSelection::Uniform, LightSelection::Power, LightSelection::Bvh] {
            let sampler = LightSampler::build(kind, &[], &[], 1.0);
            assert_eq!(sampler.sample(Vec3::ZERO, Vec3::Z, 0.5), None, "{kind:?}");
        }
    }

    #[test]
    fn power_without_power_is_uniform() {
        let lights = [point(0.0), point(0.0)];
        let sampler = LightSampler::build(LightSelection::Power, &lights, &[], 1.0);
        assert_eq!(sampler.kind(), LightSelection::Uniform);
        assert_eq!(sampler.sample(Vec3::ZERO, Vec3::ZERO, 0.75), Some((1, 0.5)));
        let sampler = LightSampler::build(LightSelection::Power, &[point(1.0), point(3.0)], &[], 1.0);
        assert_eq!(sampler.kind(), LightSelection::Power);
        assert_eq!(sampler.pmf(Vec3::ZERO, Vec3::ZERO, 1), 0.75);
    }
}
