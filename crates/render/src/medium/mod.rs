//! Participating media: Mitsuba 3's `homogeneous` and `heterogeneous`
//! media with their phase functions and volumes, and the two questions the
//! volumetric path tracer asks of them: where along a ray does light
//! scatter first (free-flight sampling), and how much gets through a
//! segment (transmittance).
//!
//! Both estimators are unbiased and agree in expectation with Mitsuba's
//! `volpath` (src/integrators/volpath.cpp, src/render/medium.cpp):
//! - homogeneous: distances from exp(−σ_h t) of the path's hero channel h;
//!   each flight also reports every channel's density relative to the
//!   hero's, so that the integrator weights the whole path by the balance
//!   heuristic over the three channels (spectral MIS, as Mitsuba's
//!   `volpathmis`), which keeps chromatic media free of the fireflies of a
//!   single hero channel; transmittance in closed form, exp(−σ_t d);
//! - heterogeneous: delta tracking against the majorant σ̄ = scale ·
//!   max(sigma_t) inside the volume's bounds, with Mitsuba's null-collision
//!   probability mean(σ_n) / σ̄ and weights for chromatic σ_t; transmittance
//!   by ratio tracking (Novák et al. 2014), Π σ_n / σ̄.

pub mod phase;
pub use crate::texture::volume;

pub use phase::PhaseFunction;
pub use volume::{Grid, GridVolume, Volume, VolumeFilter, WrapMode};

use crate::geometry::{Aabb, Ray};
use crate::math::Spectrum;
use crate::sampling::SampleStream;
use glam::Vec3;

/// What a medium is made of.
#[derive(Debug, Clone)]
pub enum MediumKind {
    /// Mitsuba `homogeneous`: constant coefficients everywhere.
    Homogeneous {
        /// Extinction σ_t per unit length (`sigma_t` · `scale`).
        sigma_t: Spectrum,
        /// Single-scattering albedo σ_s / σ_t.
        albedo: Spectrum,
    },
    /// Mitsuba `heterogeneous`: coefficients from volumes, inside the
    /// bounds of `sigma_t`'s volume; vacuum outside.
    Heterogeneous {
        /// Extinction (before `scale`).
        sigma_t: Box<Volume>,
        /// Single-scattering albedo.
        albedo: Box<Volume>,
        /// Multiplier of `sigma_t`.
        scale: f32,
        /// σ̄ = scale · max(sigma_t) (times the phase function's bound of its
        /// projected area, 1 unless it is `sggx`), an upper bound of σ_t in every channel.
        majorant: f32,
    },
}

/// A participating medium.
#[derive(Debug, Clone)]
pub struct Medium {
    /// Its coefficients.
    pub kind: MediumKind,
    /// The phase function of its scattering.
    pub phase: PhaseFunction,
    /// Mitsuba's `sample_emitters`: next-event estimation at scattering
    /// events in the medium (otherwise only phase sampling finds light).
    pub sample_emitters: bool,
}

/// Outcome of free-flight sampling along a ray segment. `weight` is the
/// value over the hero channel's density; `ratio` is each channel's
/// density over the hero's (all ones where the densities agree). A path's
/// spectral-MIS throughput is Π weight / mean(Π ratio).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Flight {
    /// Light scatters at distance `t`.
    Scatter {
        /// Distance along the ray.
        t: f32,
        /// σ_s · transmittance / the hero's density.
        weight: Spectrum,
        /// Densities relative to the hero's.
        ratio: Spectrum,
    },
    /// The segment is crossed.
    Pass {
        /// Transmittance (or the null-collision weights) over the hero's probability.
        weight: Spectrum,
        /// Probabilities relative to the hero's.
        ratio: Spectrum,
    },
}

/// The parametric interval of `ray` inside `b`, clipped to [0, t_end].
#[inline]
fn clip(b: &Aabb, o: Vec3, d: Vec3, t_end: f32) -> Option<(f32, f32)> {
    let inv = d.recip();
    let t0 = (b.min - o) * inv;
    let t1 = (b.max - o) * inv;
    let near = t0.min(t1);
    let far = t0.max(t1);
    // NaN (0 · ∞ on a face) compares false and is skipped by max/min.
    let lo = near.x.max(near.y).max(near.z).max(0.0);
    let hi = far.x.min(far.y).min(far.z).min(t_end);
    (lo < hi).then_some((lo, hi))
}

/// e^{−σ t}, with e^{−0 · ∞} = 1.
#[inline]
fn tr(sigma: Spectrum, t: f32) -> Spectrum {
    let f = |s: f32| if s == 0.0 { 1.0 } else { crate::simd::exp(-s * t) };
    Spectrum::new(f(sigma.x), f(sigma.y), f(sigma.z))
}

/// The channel mean.
#[inline]
pub fn mean(s: Spectrum) -> f32 {
    (s.x + s.y + s.z) / 3.0
}

/// Most tentative collisions one tracking walk takes. A majorant far above
/// the scene's scale (a hostile `scale` or `max_value`) takes steps too
/// small to move `t` in f32, which would otherwise never end; past this
/// many the walk stops as if absorbed.
pub const MAX_TRACKING_STEPS: u32 = 1 << 20;

/// A distance from density σ e^{−σ t} for `u` in [0, 1) (∞ for σ = 0).
#[inline]
fn exp_step(sigma: f32, u: f32) -> f32 {
    if sigma > 0.0 {
        -crate::simd::ln(1.0 - u) / sigma
    } else {
        f32::INFINITY
    }
}

impl Medium {
    /// Whether σ_t is constant (then transmittance is exact).
    pub fn is_homogeneous(&self) -> bool {
        matches!(self.kind, MediumKind::Homogeneous { .. })
    }

    /// σ_s and σ_t at `p` of a heterogeneous medium for light travelling
    /// along `d`: σ_t times the microflakes' projected area along `d`
    /// (1 unless the phase function is `sggx`; Mitsuba's heterogeneous.cpp).
    #[inline]
    fn coefficients(&self, p: Vec3, d: Vec3) -> (Spectrum, Spectrum) {
        match &self.kind {
            MediumKind::Homogeneous { sigma_t, albedo } => (*sigma_t * *albedo, *sigma_t),
            MediumKind::Heterogeneous { sigma_t, albedo, scale, .. } => {
                let st = sigma_t.eval(p) * *scale * self.phase.projected_area(p, -d);
                (st * albedo.eval(p), st)
            }
        }
    }

    /// A homogeneous medium's extinction along `d`: σ_t times the
    /// microflakes' projected area along `d` (1 unless the phase function
    /// is `sggx`). As in Mitsuba 3.9.1's homogeneous.cpp, S is read at the
    /// world origin: Mitsuba evaluates this majorant before the interaction
    /// has a position (medium.cpp's `sample_interaction`), and a
    /// homogeneous medium's extinction is this majorant everywhere.
    #[inline]
    fn homogeneous_sigma_t(&self, sigma_t: Spectrum, d: Vec3) -> Spectrum {
        sigma_t * self.phase.projected_area(Vec3::ZERO, -d)
    }

    /// Samples where along `ray` (unit direction), before `t_end` (the
    /// closest surface, possibly ∞), light first scatters, drawing
    /// distances with the extinction of channel `hero`.
    pub fn sample_flight(&self, ray: &Ray, t_end: f32, hero: usize, rng: &mut SampleStream) -> Flight {
        match &self.kind {
            MediumKind::Homogeneous { sigma_t, albedo } => {
                let sigma_t = &self.homogeneous_sigma_t(*sigma_t, ray.d);
                let t = exp_step(sigma_t[hero], rng.next_1d());
                if t < t_end {
                    let transmittance = tr(*sigma_t, t);
                    let pdf = *sigma_t * transmittance;
                    let sigma_s = *sigma_t * *albedo;
                    let ph = pdf[hero];
                    Flight::Scatter { t, weight: sigma_s * transmittance / ph, ratio: pdf / ph }
                } else {
                    let transmittance = tr(*sigma_t, t_end);
                    let ph = transmittance[hero];
                    if ph > 0.0 {
                        Flight::Pass { weight: transmittance / ph, ratio: transmittance / ph }
                    } else {
                        // Unreachable for the hero (an infinite segment in
                        // a medium it sees); no estimate.
                        Flight::Pass { weight: Spectrum::ZERO, ratio: Spectrum::ONE }
                    }
                }
            }
            MediumKind::Heterogeneous { sigma_t, majorant, .. } => {
                // One majorant for all channels, and null-collision
                // probabilities from the channel mean: the same densities
                // for every hero.
                let ratio = Spectrum::ONE;
                let m = *majorant;
                let Some((t0, t1)) = clip(&sigma_t.bounds(), ray.o, ray.d, t_end).filter(|_| m > 0.0) else {
                    return Flight::Pass { weight: Spectrum::ONE, ratio };
                };
                let mut weight = Spectrum::ONE;
                let mut t = t0;
                for _ in 0..MAX_TRACKING_STEPS {
                    let next = t + exp_step(m, rng.next_1d());
                    if next >= t1 {
                        return Flight::Pass { weight, ratio };
                    }
                    t = next;
                    let (sigma_s, st) = self.coefficients(ray.at(t), ray.d);
                    let sigma_n = Spectrum::splat(m) - st;
                    let p_null = mean(sigma_n) / m;
                    if rng.next_1d() < p_null {
                        weight *= sigma_n / (m * p_null);
                    } else {
                        return Flight::Scatter { t, weight: weight * sigma_s / mean(st), ratio };
                    }
                }
                Flight::Pass { weight: Spectrum::ZERO, ratio }
            }
        }
    }

    /// Transmittance along `ray` (unit direction) from its origin to `t_end`
    /// (possibly ∞): exact for homogeneous media, ratio tracking otherwise.
    pub fn transmittance(&self, ray: &Ray, t_end: f32, rng: &mut SampleStream) -> Spectrum {
        match &self.kind {
            MediumKind::Homogeneous { sigma_t, .. } => tr(self.homogeneous_sigma_t(*sigma_t, ray.d), t_end),
            MediumKind::Heterogeneous { sigma_t, majorant, .. } => {
                let m = *majorant;
                let Some((t0, t1)) = clip(&sigma_t.bounds(), ray.o, ray.d, t_end).filter(|_| m > 0.0) else {
                    return Spectrum::ONE;
                };
                let mut transmittance = Spectrum::ONE;
                let mut t = t0;
                for _ in 0..MAX_TRACKING_STEPS {
                    let next = t + exp_step(m, rng.next_1d());
                    if next >= t1 {
                        return transmittance;
                    }
                    t = next;
                    let (_, st) = self.coefficients(ray.at(t), ray.d);
                    transmittance *= (Spectrum::splat(m) - st) / m;
                    if transmittance == Spectrum::ZERO {
                        return transmittance;
                    }
                }
                Spectrum::ZERO
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::sampler::{Sampler, SamplerKind};
    use glam::Mat4;
    use std::sync::Arc;

    fn homogeneous(sigma_t: Spectrum, albedo: Spectrum) -> Medium {
        Medium {
            kind: MediumKind::Homogeneous { sigma_t, albedo },
            phase: PhaseFunction::Isotropic,
            sample_emitters: true,
        }
    }

    /// A 4³ grid of density `rho` filling [0, 1]³.
    fn grid_medium(rho: impl Fn(u32, u32, u32) -> f32, scale: f32) -> Medium {
        let mut data = Vec::new();
        for z in 0..4 {
            for y in 0..4 {
                for x in 0..4 {
                    data.push(rho(x, y, z));
                }
            }
        }
        let grid = Arc::new(Grid { res: [4, 4, 4], channels: 1, data });
        let max = grid.max();
        let gv =
            GridVolume { grid, to_local: Mat4::IDENTITY, filter: VolumeFilter::Nearest, wrap: WrapMode::Clamp, max };
        let bounds = volume::unit_cube_bounds(Mat4::IDENTITY);
        Medium {
            kind: MediumKind::Heterogeneous {
                sigma_t: Box::new(Volume::Grid { grid: gv, bounds }),
                albedo: Box::new(Volume::constant(Spectrum::splat(0.8))),
                scale,
                majorant: scale * max,
            },
            phase: PhaseFunction::Isotropic,
            sample_emitters: true,
        }
    }

    fn streams(n: u32) -> impl Iterator<Item = SampleStream> {
        let sampler = Sampler::new(SamplerKind::Independent, 11, n);
        (0..n).map(move |i| sampler.stream((i % 97, i / 97), i))
    }

    /// Mean and standard error of `f` over `n` streams.
    fn estimate(n: u32, mut f: impl FnMut(&mut SampleStream) -> Spectrum) -> (Spectrum, Spectrum) {
        let (mut s, mut s2) = (Spectrum::ZERO, Spectrum::ZERO);
        for mut rng in streams(n) {
            let v = f(&mut rng);
            s += v;
            s2 += v * v;
        }
        let m = s / n as f32;
        let var = (s2 / n as f32 - m * m).max(Spectrum::ZERO);
        (m, (var / n as f32).powf(0.5))
    }

    fn assert_close(what: &str, (m, se): (Spectrum, Spectrum), want: Spectrum) {
        for c in 0..3 {
            let tol = 5.0 * se[c] + 1e-6;
            assert!((m[c] - want[c]).abs() <= tol, "{what}: channel {c}: {} vs {} (5 se = {tol})", m[c], want[c]);
        }
    }

    /// A majorant far beyond f32's resolution of the ray's length (a hostile
    /// scale) ends the walk as absorbed instead of never ending.
    #[test]
    fn hostile_majorants_end_the_walk() {
        let m = grid_medium(|_, _, _| 1.0, 1e30);
        let ray = Ray::new(Vec3::new(-0.5, 0.5, 0.5), Vec3::X, f32::INFINITY);
        let mut rng = streams(1).next().unwrap();
        assert_eq!(m.transmittance(&ray, 10.0, &mut rng), Spectrum::ZERO);
        // Every tentative collision is real (σ_n = 0): the flight scatters at once.
        assert!(matches!(m.sample_flight(&ray, 10.0, 0, &mut rng), Flight::Scatter { .. }));
        let m = grid_medium(|x, _, _| if x == 0 { 1.0 } else { 1e-30 }, 1e30);
        let ray = Ray::new(Vec3::new(0.3, 0.5, 0.5), Vec3::X, f32::INFINITY);
        let t = std::time::Instant::now();
        let _ = m.transmittance(&ray, 10.0, &mut rng);
        let _ = m.sample_flight(&ray, 10.0, 0, &mut rng);
        assert!(t.elapsed().as_secs() < 5, "the walk took {:?}", t.elapsed());
    }

    /// Through a homogeneous slab of thickness d: P(pass) weighted equals
    /// e^{−σ_t d} per channel, and the scattered weight sums to the single-
    /// scattering albedo's share, ∫₀^d σ_s e^{−σ_t t} dt (chromatic σ_t).
    #[test]
    fn homogeneous_flights_match_the_closed_forms() {
        let sigma_t = Spectrum::new(0.5, 1.0, 3.0);
        let albedo = Spectrum::new(0.9, 0.5, 0.2);
        let m = homogeneous(sigma_t, albedo);
        let ray = Ray::new(Vec3::ZERO, Vec3::X, f32::INFINITY);
        let d = 1.3;
        // One flight with a uniformly drawn hero, weighted by the balance
        // heuristic (weight / mean(ratio)).
        let flight = |rng: &mut SampleStream| {
            let hero = ((rng.next_1d() * 3.0) as usize).min(2);
            m.sample_flight(&ray, d, hero, rng)
        };
        let pass = estimate(100_000, |rng| match flight(rng) {
            Flight::Pass { weight, ratio } => weight / mean(ratio),
            Flight::Scatter { .. } => Spectrum::ZERO,
        });
        let want = tr(sigma_t, d);
        assert_close("pass", pass, want);
        let scatter = estimate(100_000, |rng| match flight(rng) {
            Flight::Scatter { weight, ratio, .. } => weight / mean(ratio),
            Flight::Pass { .. } => Spectrum::ZERO,
        });
        assert_close("scatter", scatter, albedo * (Spectrum::ONE - want));
        assert_eq!(m.transmittance(&ray, d, &mut streams(1).next().unwrap()), want);
        // A scattering distance's density: E[t · weight / σ_s] = ∫ t e^{−σt} dt.
        let first_moment = estimate(100_000, |rng| match flight(rng) {
            Flight::Scatter { t, weight, ratio } => weight / mean(ratio) / (sigma_t * albedo) * t,
            Flight::Pass { .. } => Spectrum::ZERO,
        });
        let want = (Spectrum::ONE - tr(sigma_t, d) * (Spectrum::ONE + sigma_t * d)) / (sigma_t * sigma_t);
        assert_close("first moment", first_moment, want);
    }

    /// A heterogeneous grid: the ratio-tracking transmittance and the delta-
    /// tracking pass weight both average to e^{−∫σ_t}, computed exactly
    /// along a ray through piecewise-constant voxels.
    #[test]
    fn heterogeneous_tracking_matches_the_optical_depth() {
        let m = grid_medium(|x, y, _| 1.0 + x as f32 + 2.0 * y as f32, 0.7);
        // Along x at y = 0.6 (voxel row 2), z = 0.3, from outside the box.
        let ray = Ray::new(Vec3::new(-0.5, 0.6, 0.3), Vec3::X, f32::INFINITY);
        let tau: f32 = (0..4).map(|x| 0.7 * (1.0 + x as f32 + 4.0) * 0.25).sum();
        let want = Spectrum::splat((-tau).exp());
        assert_close("ratio tracking", estimate(100_000, |rng| m.transmittance(&ray, 10.0, rng)), want);
        let pass = estimate(100_000, |rng| match m.sample_flight(&ray, 10.0, 1, rng) {
            Flight::Pass { weight, .. } => weight,
            Flight::Scatter { .. } => Spectrum::ZERO,
        });
        assert_close("delta tracking", pass, want);
        // Scattered weight: albedo · (1 − T).
        let scatter = estimate(100_000, |rng| match m.sample_flight(&ray, 10.0, 2, rng) {
            Flight::Scatter { weight, .. } => weight,
            Flight::Pass { .. } => Spectrum::ZERO,
        });
        assert_close("scatter", scatter, Spectrum::splat(0.8) * (Spectrum::ONE - want));
        // Ending inside the box at x = 0.5 covers voxels 0 and 1 only.
        let tau2: f32 = (0..2).map(|x| 0.7 * (1.0 + x as f32 + 4.0) * 0.25).sum();
        assert_close(
            "half way",
            estimate(100_000, |rng| m.transmittance(&ray, 1.0, rng)),
            Spectrum::splat((-tau2).exp()),
        );
        // A ray missing the box sees vacuum.
        let miss = Ray::new(Vec3::new(-0.5, 2.0, 0.3), Vec3::X, f32::INFINITY);
        assert_eq!(m.transmittance(&miss, 10.0, &mut streams(1).next().unwrap()), Spectrum::ONE);
    }

    /// With `sggx`, extinction is σ_t times the flakes' projected area
    /// along the ray, sqrt(dᵀ S d) (Mitsuba's media): a homogeneous medium
    /// reads S at the world origin, a heterogeneous one at each point, and
    /// its majorant covers a projected area above 1.
    #[test]
    fn sggx_scales_extinction_by_the_projected_area() {
        // S = diag(4, 0.25, 1) in the voxel at x < 0.5, diag(0.25, 4, 1) beyond.
        let data = vec![4.0, 0.25, 1.0, 0.0, 0.0, 0.0, 0.25, 4.0, 1.0, 0.0, 0.0, 0.0];
        let grid = Arc::new(Grid { res: [2, 1, 1], channels: 6, data });
        let gv = GridVolume {
            grid,
            to_local: Mat4::IDENTITY,
            filter: VolumeFilter::Nearest,
            wrap: WrapMode::Clamp,
            max: 4.0,
        };
        let sggx = PhaseFunction::Sggx(Arc::new(phase::Sggx { s: gv }));
        assert_eq!(sggx.projected_area_bound(), 2.0);
        let mut m = homogeneous(Spectrum::new(0.5, 1.0, 3.0), Spectrum::splat(0.9));
        m.phase = sggx.clone();
        let mut rng = streams(1).next().unwrap();
        let d = 0.7;
        // Along x: σ = sqrt(S_xx) = 2 at the origin's voxel, wherever the ray is.
        let along_x = Ray::new(Vec3::new(0.9, 0.5, 0.5), Vec3::X, f32::INFINITY);
        assert_eq!(m.transmittance(&along_x, d, &mut rng), tr(Spectrum::new(1.0, 2.0, 6.0), d));
        let along_y = Ray::new(Vec3::new(0.9, 0.5, 0.5), -Vec3::Y, f32::INFINITY);
        assert_eq!(m.transmittance(&along_y, d, &mut rng), tr(Spectrum::new(0.25, 0.5, 1.5), d));
        // Heterogeneous, density 1 everywhere: along y through both voxels'
        // S_yy (0.25 then 4), σ = 0.5 then 2; the majorant is 2.
        let mut h = grid_medium(|_, _, _| 1.0, 1.0);
        h.phase = sggx;
        if let MediumKind::Heterogeneous { majorant, .. } = &mut h.kind {
            *majorant *= h.phase.projected_area_bound();
            assert_eq!(*majorant, 2.0);
        }
        for (x, sigma) in [(0.25, 0.5f32), (0.75, 2.0)] {
            let ray = Ray::new(Vec3::new(x, -0.5, 0.5), Vec3::Y, f32::INFINITY);
            let want = Spectrum::splat((-sigma).exp());
            assert_close("ratio tracking", estimate(100_000, |rng| h.transmittance(&ray, 10.0, rng)), want);
            let pass = estimate(100_000, |rng| match h.sample_flight(&ray, 10.0, 0, rng) {
                Flight::Pass { weight, .. } => weight,
                Flight::Scatter { .. } => Spectrum::ZERO,
            });
            assert_close("delta tracking", pass, want);
        }
    }
}
