//! Mitsuba `path`: unidirectional path tracing with next-event estimation
//! and multiple importance sampling (power heuristic) of light and BSDF
//! samples, and Russian roulette. Its sampling decisions follow Mitsuba 3's
//! `path.cpp`, so the same scene converges to the same image.
//!
//! | parameter     | type    | default |
//! |---------------|---------|---------|
//! | max_depth     | integer | -1 (unbounded); 1 = emitters seen directly, 2 = direct light |
//! | rr_depth      | integer | 5 (depth at which Russian roulette starts) |
//! | hide_emitters | boolean | false (camera rays pass through emitters; environment black) |

use super::RayStats;
use crate::geometry::{Ray, SurfaceInteraction};
use crate::math::Spectrum;
use crate::sampling::mis::power_heuristic;
use crate::sampling::SampleStream;
use crate::scene::Scene;

#[derive(Debug, Clone)]
pub struct PathIntegrator {
    /// Longest path in segments; `u32::MAX` for unbounded.
    pub max_depth: u32,
    pub rr_depth: u32,
    pub hide_emitters: bool,
}

impl Default for PathIntegrator {
    fn default() -> Self {
        PathIntegrator { max_depth: u32::MAX, rr_depth: 5, hide_emitters: false }
    }
}

impl PathIntegrator {
    /// Estimates L(x, -d) = Le + ∫ f Li cos dω (the rendering equation,
    /// Kajiya 1986) with one light sample and one BSDF sample per vertex,
    /// each MIS-weighted against the other (Veach 1997, eq. 9.13).
    pub fn li(&self, scene: &Scene, camera_ray: &Ray, rng: &mut SampleStream, stats: &mut RayStats) -> Spectrum {
        if self.max_depth == 0 {
            return Spectrum::ZERO;
        }
        let mut l = Spectrum::ZERO;
        let mut beta = Spectrum::ONE;
        let mut eta = 1.0f32;
        let mut ray = *camera_ray;
        let mut depth = 0u32;
        // The previous vertex, for MIS of emitters hit by BSDF sampling.
        let mut prev_p = ray.o;
        let mut prev_bsdf_pdf = 1.0f32;
        let mut prev_delta = true;

        loop {
            stats.rays += 1;
            let mut hit = scene.intersect(&ray);
            if depth == 0 && self.hide_emitters {
                hit = self.skip_emitters(scene, &ray, hit, stats);
            }

            let Some(si) = hit else {
                // Escaped: environment emission, MIS-weighted against light sampling.
                if !(depth == 0 && self.hide_emitters) {
                    let (le, env_pdf) = scene.environment(ray.d);
                    if le != Spectrum::ZERO {
                        let w = if prev_delta { 1.0 } else { power_heuristic(prev_bsdf_pdf, env_pdf) };
                        l += beta * le * w;
                    }
                }
                break;
            };

            // Emission at the hit, MIS-weighted against light sampling at the previous vertex.
            let le = scene.emitted(&si);
            if le != Spectrum::ZERO {
                let w = if prev_delta { 1.0 } else { power_heuristic(prev_bsdf_pdf, scene.light_pdf(prev_p, &si)) };
                l += beta * le * w;
            }

            if depth + 1 >= self.max_depth {
                break;
            }
            let bsdf = scene.bsdf(&si);
            let wo = si.to_local(si.wo);

            // Light sampling (next-event estimation).
            let u_light = rng.next_2d();
            if bsdf.has_smooth() {
                if let Some(ls) = scene.sample_light(si.p, u_light) {
                    let wi = si.to_local(ls.wi);
                    let f = bsdf.eval(wo, wi) * wi.z.abs();
                    if f != Spectrum::ZERO {
                        stats.shadow_rays += 1;
                        if !scene.occluded(&si, ls.wi, ls.dist) {
                            let w = if ls.delta { 1.0 } else { power_heuristic(ls.pdf, bsdf.pdf(wo, wi)) };
                            l += beta * f * ls.li * (w / ls.pdf);
                        }
                    }
                }
            }

            // BSDF sampling for the next segment.
            let u = rng.next_1d();
            let u2 = rng.next_2d();
            let Some(bs) = bsdf.sample(wo, u, u2) else { break };
            beta *= bs.weight;
            eta *= bs.eta;
            let wi = si.to_world(bs.wi);
            prev_p = si.p;
            prev_bsdf_pdf = bs.pdf;
            prev_delta = bs.delta;
            ray = scene.spawn_ray(&si, wi);
            depth += 1;

            // Russian roulette (Mitsuba: survival min(0.95, max(β) η²)).
            let beta_max = beta.max_element();
            if beta_max <= 0.0 {
                break;
            }
            if depth >= self.rr_depth {
                let q = (beta_max * eta * eta).min(0.95);
                if rng.next_1d() >= q {
                    break;
                }
                beta /= q;
            }
        }
        l
    }

    /// With `hide_emitters`, camera rays pass through area emitters (as
    /// Mitsuba 3 does), revealing what lies behind them.
    fn skip_emitters(
        &self,
        scene: &Scene,
        ray: &Ray,
        mut hit: Option<SurfaceInteraction>,
        stats: &mut RayStats,
    ) -> Option<SurfaceInteraction> {
        while let Some(si) = hit {
            if scene.shape_info[si.shape as usize].light.is_none() {
                return Some(si);
            }
            stats.rays += 1;
            let next = scene.spawn_ray(&si, ray.d);
            hit = scene.intersect(&next);
        }
        None
    }
}
