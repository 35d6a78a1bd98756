//! Mitsuba `direct`: direct illumination only (the area form of the
//! rendering equation at the first hit), with `emitter_samples` light samples
//! (shadow rays) and `bsdf_samples` BSDF samples combined by the power
//! heuristic in its multi-sample form (Veach 1997, eq. 9.13): a sample of
//! strategy s with n_s samples gets w = (n_s p_s)² / Σ_k (n_k p_k)².
//!
//! | parameter       | type    | default |
//! |-----------------|---------|---------|
//! | emitter_samples | integer | 1 (N_s; with `bsdf_samples` 0, pure light sampling) |
//! | bsdf_samples    | integer | 1 |
//! | shading_samples | integer | sets both |
//! | hide_emitters   | boolean | false (camera rays pass through emitters; environment black) |

use super::{camera_hit, RayStats};
use crate::material::Scratch;
use crate::math::Spectrum;
use crate::sampling::mis::power_heuristic;
use crate::sampling::SampleStream;
use crate::scene::Scene;

/// The `direct` integrator's parameters.
#[derive(Debug, Clone)]
pub struct DirectIntegrator {
    /// Light samples (shadow rays) per hit, N_s.
    pub emitter_samples: u32,
    /// BSDF samples per hit.
    pub bsdf_samples: u32,
    /// Mitsuba's `hide_emitters`: camera rays pass through area emitters
    /// and see a black environment.
    pub hide_emitters: bool,
}

impl DirectIntegrator {
    /// Radiance along the camera ray `ray`: emission at the first hit plus its
    /// direct illumination, the two sample kinds MIS-weighted (Veach 1997, eq. 9.13).
    pub fn li(
        &self,
        scene: &Scene,
        ray: &crate::geometry::Ray,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
    ) -> Spectrum {
        let Some(mut si) = camera_hit(scene, ray, self.hide_emitters, stats) else {
            return if self.hide_emitters {
                Spectrum::ZERO
            } else {
                scene.environment(ray.o, glam::Vec3::ZERO, ray.d).0
            };
        };
        // With hide_emitters the camera ray has passed through any emitter.
        let mut l = scene.emitted(&si);
        let total = (self.emitter_samples + self.bsdf_samples) as f32;
        if total == 0.0 {
            return l;
        }
        let (frac_lum, frac_bsdf) = (self.emitter_samples as f32 / total, self.bsdf_samples as f32 / total);
        let bsdf = scene.bsdf(&mut si, scratch);
        let wo = si.to_local(si.wo);

        // Light sampling: N_s shadow rays, each averaged with weight 1/N_s.
        if bsdf.has_smooth() {
            for _ in 0..self.emitter_samples {
                let (u, u2) = (rng.next_1d(), rng.next_2d());
                let Some(ls) = scene.sample_light(si.p, si.n, u, u2) else { continue };
                let wi = si.to_local(ls.wi);
                let f = bsdf.eval(wo, wi) * wi.z.abs();
                if f == Spectrum::ZERO {
                    continue;
                }
                stats.shadow_rays += 1;
                if scene.occluded(&si, ls.wi, ls.dist) {
                    continue;
                }
                let w = if ls.delta { 1.0 } else { power_heuristic(ls.pdf * frac_lum, bsdf.pdf(wo, wi) * frac_bsdf) };
                l += f * ls.li * (w / (ls.pdf * self.emitter_samples as f32));
            }
        }

        // BSDF sampling: emission found along M sampled directions.
        for _ in 0..self.bsdf_samples {
            let u = rng.next_1d();
            let Some(bs) = bsdf.sample(wo, u, rng.next_2d()) else { continue };
            let wi = si.to_world(bs.wi);
            let ray = scene.spawn_ray(&si, wi);
            stats.rays += 1;
            let (le, light_pdf) = match scene.intersect(&ray) {
                Some(hit) => (scene.emitted(&hit), scene.light_pdf(si.p, si.n, &hit)),
                None => scene.environment(si.p, si.n, wi),
            };
            if le == Spectrum::ZERO {
                continue;
            }
            let w = if bs.delta { 1.0 } else { power_heuristic(bs.pdf * frac_bsdf, light_pdf * frac_lum) };
            l += bs.weight * le * (w / self.bsdf_samples as f32);
        }
        l
    }
}
