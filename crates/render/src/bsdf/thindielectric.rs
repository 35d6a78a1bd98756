//! Mitsuba `thindielectric`: a thin pane (window glass, a soap film) that
//! reflects or passes light straight through, summing all internal bounces.
//!
//! | parameter              | type          | default |
//! |------------------------|---------------|---------|
//! | int_ior                | float or name | bk7     |
//! | ext_ior                | float or name | air     |
//! | specular_reflectance   | rgb/texture   | 1       |
//! | specular_transmittance | rgb/texture   | 1       |

use super::fresnel::{fresnel_dielectric, reflect};
use super::BsdfSample;
use super::{BsdfModel, BsdfParams};
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// Mitsuba `thindielectric` with its textures evaluated at a hit.
#[derive(Debug, Clone, Copy)]
pub struct ThinDielectric {
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Spectrum,
    /// Multiplier of the Fresnel transmittance 1 − F.
    pub specular_transmittance: Spectrum,
}

/// Mitsuba `thindielectric` as the scene stores it.
#[derive(Debug, Clone)]
pub struct ThinDielectricParams {
    /// Relative IOR (interior / exterior).
    pub eta: f32,
    /// Multiplier of the Fresnel reflectance.
    pub specular_reflectance: Texture,
    /// Multiplier of the Fresnel transmittance 1 − F.
    pub specular_transmittance: Texture,
}

impl BsdfParams for ThinDielectricParams {
    type Model<'a> = ThinDielectric;

    #[inline]
    fn at(&self, si: &SurfaceInteraction) -> ThinDielectric {
        ThinDielectric {
            eta: self.eta,
            specular_reflectance: self.specular_reflectance.eval(si),
            specular_transmittance: self.specular_transmittance.eval(si),
        }
    }

    fn textures(&self) -> Vec<&Texture> {
        vec![&self.specular_reflectance, &self.specular_transmittance]
    }
}

impl ThinDielectric {
    /// Reflectance of the slab including the internal bounces,
    /// R' = R + T²R/(1 − R²) = 2R/(1 + R) (a geometric series).
    #[inline]
    pub fn reflectance(&self, cos_i: f32) -> f32 {
        let r = fresnel_dielectric(cos_i.abs(), self.eta).0;
        2.0 * r / (1.0 + r)
    }
}

impl BsdfModel for ThinDielectric {
    #[inline]
    fn has_smooth(&self) -> bool {
        false
    }

    /// Chooses reflection with probability R', straight transmission
    /// otherwise, so the weight is the tint alone. Works from both sides.
    #[inline]
    fn sample(&self, wo: Vec3, u: f32, _u2: Vec2) -> Option<BsdfSample> {
        let r = self.reflectance(wo.z);
        if u <= r {
            Some(BsdfSample {
                wi: reflect(wo),
                pdf: r,
                weight: self.specular_reflectance,
                delta: true,
                null: false,
                eta: 1.0,
            })
        } else {
            Some(BsdfSample {
                wi: -wo,
                pdf: 1.0 - r,
                weight: self.specular_transmittance,
                delta: true,
                null: true,
                eta: 1.0,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_reflectance_sums_the_series() {
        let b = ThinDielectric { eta: 1.5, specular_reflectance: Spectrum::ONE, specular_transmittance: Spectrum::ONE };
        for c in [1.0f32, 0.5, 0.1] {
            let r = fresnel_dielectric(c, 1.5).0;
            let t = 1.0 - r;
            // Explicit sum of R + T R T + T R³ T + ...
            let series: f32 = r + (0..50).map(|k| t * t * r.powi(2 * k + 1)).sum::<f32>();
            assert!((b.reflectance(c) - series).abs() < 1e-6);
            assert_eq!(b.reflectance(c), b.reflectance(-c), "same from both sides");
        }
        // Normal incidence on glass: 2·0.04/1.04.
        assert!((b.reflectance(1.0) - 0.08 / 1.04).abs() < 1e-6);
    }

    #[test]
    fn lobe_frequencies_match_the_reflectance() {
        let b = ThinDielectric { eta: 1.5, specular_reflectance: Spectrum::ONE, specular_transmittance: Spectrum::ONE };
        let wo = Vec3::new(0.8, 0.0, 0.6);
        let n = 100_000;
        let mut refl = 0;
        for i in 0..n {
            let s = b.sample(wo, (i as f32 + 0.5) / n as f32, Vec2::ZERO).unwrap();
            if s.wi.z > 0.0 {
                refl += 1;
                assert!((s.wi - Vec3::new(-0.8, 0.0, 0.6)).length() < 1e-6);
            } else {
                assert!((s.wi + wo).length() < 1e-6);
            }
        }
        assert!((refl as f32 / n as f32 - b.reflectance(0.6)).abs() < 1e-4);
    }
}
