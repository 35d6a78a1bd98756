//! Phase functions: Mitsuba 3's `isotropic`, `hg` and `blendphase`.
//!
//! Directions follow Mitsuba's convention: `wi` points back along the
//! incoming ray (towards where the light goes), `wo` is the scattered
//! direction. Every phase function here is sampled exactly, so a sample's
//! weight (value over density) is 1 and [`PhaseFunction::sample`] returns
//! only the direction and its density.

use crate::math::{safe_sqrt, Frame, INV_4PI, PI};
use crate::sampling::warp::sample_uniform_sphere;
use glam::{Vec2, Vec3};

/// A phase function: the angular distribution of light scattered in a medium.
#[derive(Debug, Clone, PartialEq)]
pub enum PhaseFunction {
    /// Mitsuba `isotropic`: 1 / (4π) in every direction.
    Isotropic,
    /// Mitsuba `hg` (Henyey and Greenstein 1941) with asymmetry `g` in
    /// (−1, 1): forward scattering for g > 0.
    HenyeyGreenstein {
        /// Mean cosine of the scattering angle.
        g: f32,
    },
    /// Mitsuba `blendphase`: (1 − weight) · `first` + weight · `second`.
    Blend {
        /// Weight of `second`, in [0, 1].
        weight: f32,
        /// Weighted by 1 − `weight`.
        first: Box<PhaseFunction>,
        /// Weighted by `weight`.
        second: Box<PhaseFunction>,
    },
}

/// Henyey–Greenstein density for `cos` = dot(wo, wi) (so forward
/// scattering is cos = −1): (1 − g²) / (4π (1 + g² + 2g cos)^{3/2}).
#[inline]
fn hg(g: f32, cos: f32) -> f32 {
    let temp = 1.0 + g * g + 2.0 * g * cos;
    INV_4PI * (1.0 - g * g) / (temp * temp.sqrt())
}

impl PhaseFunction {
    /// The phase function's value for scattering from `wi` into `wo`,
    /// which is also the density of [`PhaseFunction::sample`] there.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self {
            PhaseFunction::Isotropic => INV_4PI,
            PhaseFunction::HenyeyGreenstein { g } => hg(*g, wo.dot(wi)),
            PhaseFunction::Blend { weight, first, second } => {
                let mut v = 0.0;
                if *weight < 1.0 {
                    v += (1.0 - weight) * first.eval(wi, wo);
                }
                if *weight > 0.0 {
                    v += weight * second.eval(wi, wo);
                }
                v
            }
        }
    }

    /// Samples `wo` given `wi`: the direction and its density (equal to the
    /// value, so the weight is 1). `u` chooses a component of a blend.
    pub fn sample(&self, wi: Vec3, u: f32, u2: Vec2) -> (Vec3, f32) {
        let wo = self.sample_direction(wi, u, u2);
        (wo, self.eval(wi, wo))
    }

    fn sample_direction(&self, wi: Vec3, u: f32, u2: Vec2) -> Vec3 {
        match self {
            PhaseFunction::Isotropic => sample_uniform_sphere(u2),
            PhaseFunction::HenyeyGreenstein { g } => {
                let g = *g;
                // Inverse of the CDF in cos θ of the scattering angle
                // (Mitsuba's hg.cpp; θ measured from the forward direction −wi).
                let cos = if g.abs() < f32::EPSILON {
                    1.0 - 2.0 * u2.x
                } else {
                    let sqr = (1.0 - g * g) / (1.0 - g + 2.0 * g * u2.x);
                    ((1.0 + g * g - sqr * sqr) / (2.0 * g)).clamp(-1.0, 1.0)
                };
                let sin = safe_sqrt(1.0 - cos * cos);
                let (sin_phi, cos_phi) = crate::simd::sin_cos(2.0 * PI * u2.y);
                Frame::from_normal(wi).to_world(Vec3::new(sin * cos_phi, sin * sin_phi, -cos))
            }
            PhaseFunction::Blend { weight, first, second } => {
                // The second component when u < weight, its number rescaled.
                if u < *weight {
                    second.sample_direction(wi, u / weight, u2)
                } else {
                    first.sample_direction(wi, (u - weight) / (1.0 - weight), u2)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{chi2_cases, chi2_test, integrate_over_sphere};

    fn cases() -> Vec<(PhaseFunction, Vec3)> {
        let wi = Vec3::new(0.3, -0.5, 0.8).normalize();
        let blend = PhaseFunction::Blend {
            weight: 0.3,
            first: Box::new(PhaseFunction::HenyeyGreenstein { g: 0.7 }),
            second: Box::new(PhaseFunction::HenyeyGreenstein { g: -0.5 }),
        };
        vec![
            (PhaseFunction::Isotropic, Vec3::Z),
            (PhaseFunction::HenyeyGreenstein { g: 0.0 }, wi),
            (PhaseFunction::HenyeyGreenstein { g: 0.8 }, Vec3::Z),
            (PhaseFunction::HenyeyGreenstein { g: 0.5 }, wi),
            (PhaseFunction::HenyeyGreenstein { g: -0.3 }, wi),
            (PhaseFunction::HenyeyGreenstein { g: 0.95 }, -Vec3::X),
            (blend, wi),
        ]
    }

    /// Sampled directions follow the density `eval` claims (chi-square),
    /// and a density off by a lobe is rejected (the test's power).
    #[test]
    fn sampling_matches_the_density_chi2() {
        let a = chi2_cases(
            "phase",
            200_000,
            7000,
            &cases(),
            |p, wi, u1, u| Some(p.sample(wi, u1, u).0),
            |p, wi, wo| p.eval(wi, wo) as f64,
        );
        // Power: HG g = 0.5 sampled, g = 0.4 claimed.
        let wi = Vec3::Z;
        let p = chi2_test(
            200_000,
            1,
            |u1, u| Some(PhaseFunction::HenyeyGreenstein { g: 0.5 }.sample(wi, u1, u).0),
            |wo| PhaseFunction::HenyeyGreenstein { g: 0.4 }.eval(wi, wo) as f64,
        );
        assert!(p < a, "a wrong g was not detected: p = {p}");
    }

    /// Each phase function integrates to 1 over the sphere, its sample's
    /// density is its value, and g is the mean cosine (forward = −wi).
    #[test]
    fn normalised_with_mean_cosine_g() {
        for (p, wi) in cases() {
            let total = integrate_over_sphere(|wo| p.eval(wi, wo) as f64);
            assert!((total - 1.0).abs() < 2e-3, "{p:?}: integral {total}");
            let mean_cos = integrate_over_sphere(|wo| (p.eval(wi, wo) * wo.dot(-wi)) as f64);
            let g = match &p {
                PhaseFunction::Isotropic => 0.0,
                PhaseFunction::HenyeyGreenstein { g } => *g as f64,
                PhaseFunction::Blend { .. } => 0.7 * 0.7 + 0.3 * -0.5,
            };
            assert!((mean_cos - g).abs() < 5e-3, "{p:?}: mean cosine {mean_cos}, g {g}");
            let (wo, pdf) = p.sample(wi, 0.4, Vec2::new(0.3, 0.7));
            assert!((wo.length() - 1.0).abs() < 1e-5);
            assert_eq!(pdf, p.eval(wi, wo));
        }
    }
}
