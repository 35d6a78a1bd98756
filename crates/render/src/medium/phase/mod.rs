//! Phase functions: Mitsuba 3's `isotropic`, `hg`, `rayleigh`,
//! `blendphase`, `tabphase` (tabulated.rs) and `sggx` (sggx.rs).
//!
//! Directions follow Mitsuba's convention: `wi` points back along the
//! incoming ray (towards where the light goes), `wo` is the scattered
//! direction. Every phase function here is sampled exactly, so a sample's
//! weight (value over density) is 1 and [`PhaseFunction::sample`] returns
//! only the direction and its density. `p`, the scattering point, matters
//! only to `sggx`, whose parameters are a volume.

pub mod sggx;
pub mod tabulated;

pub use sggx::Sggx;
pub use tabulated::TabulatedPhase;

use crate::math::{safe_sqrt, Frame, INV_4PI, INV_PI, PI};
use crate::sampling::warp::sample_uniform_sphere;
use glam::{Vec2, Vec3};
use std::sync::Arc;

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
    /// Mitsuba `rayleigh`: 3 / (16π) · (1 + cos²θ), unpolarised.
    Rayleigh,
    /// Mitsuba `tabphase`: a table over the cosine of the scattering angle.
    Tabulated(Arc<TabulatedPhase>),
    /// Mitsuba `sggx`: the specular SGGX microflake phase function, its
    /// matrix S a 6-channel volume.
    Sggx(Arc<Sggx>),
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

/// Rayleigh density for `cos` = dot(wo, wi) (symmetric in cos).
#[inline]
fn rayleigh(cos: f32) -> f32 {
    (3.0 / 16.0) * INV_PI * (1.0 + cos * cos)
}

impl PhaseFunction {
    /// The phase function's value at `p` for scattering from `wi` into
    /// `wo`, which is also the density of [`PhaseFunction::sample`] there.
    pub fn eval(&self, p: Vec3, wi: Vec3, wo: Vec3) -> f32 {
        match self {
            PhaseFunction::Isotropic => INV_4PI,
            PhaseFunction::HenyeyGreenstein { g } => hg(*g, wo.dot(wi)),
            PhaseFunction::Rayleigh => rayleigh(wo.dot(wi)),
            PhaseFunction::Tabulated(t) => t.eval(wi, wo),
            PhaseFunction::Sggx(s) => s.eval(p, wi, wo),
            PhaseFunction::Blend { weight, first, second } => {
                let mut v = 0.0;
                if *weight < 1.0 {
                    v += (1.0 - weight) * first.eval(p, wi, wo);
                }
                if *weight > 0.0 {
                    v += weight * second.eval(p, wi, wo);
                }
                v
            }
        }
    }

    /// The microflakes' projected area σ(w) at `p` (Mitsuba's
    /// `projected_area`): `sggx`'s sqrt(wᵀ S w), 1 for every other phase
    /// function (a blend included, as in Mitsuba). Media multiply their
    /// extinction by it.
    #[inline]
    pub fn projected_area(&self, p: Vec3, w: Vec3) -> f32 {
        match self {
            PhaseFunction::Sggx(s) => sggx::projected_area(w, &s.s.eval6(p)),
            _ => 1.0,
        }
    }

    /// An upper bound of [`PhaseFunction::projected_area`] over all points
    /// and directions (1 where that is 1).
    pub fn projected_area_bound(&self) -> f32 {
        match self {
            PhaseFunction::Sggx(s) => s.projected_area_bound(),
            _ => 1.0,
        }
    }

    /// Samples `wo` given `wi`: the direction and its density (equal to the
    /// value, so the weight is 1). `u` chooses a component of a blend.
    pub fn sample(&self, p: Vec3, wi: Vec3, u: f32, u2: Vec2) -> (Vec3, f32) {
        let wo = self.sample_direction(p, wi, u, u2);
        (wo, self.eval(p, wi, wo))
    }

    fn sample_direction(&self, p: Vec3, wi: Vec3, u: f32, u2: Vec2) -> Vec3 {
        match self {
            PhaseFunction::Isotropic => sample_uniform_sphere(u2),
            PhaseFunction::Rayleigh => {
                // The CDF in μ = cos θ, (3/8)(μ + μ³/3) + ½ = u, is a
                // depressed cubic μ³ + 3μ − 2z = 0 with z = 2(2u − 1);
                // Cardano's root (Mitsuba's rayleigh.cpp).
                let z = 2.0 * (2.0 * u2.x - 1.0);
                let tmp = (z * z + 1.0).sqrt();
                let cos = ((z + tmp).cbrt() + (z - tmp).cbrt()).clamp(-1.0, 1.0);
                let sin = safe_sqrt(1.0 - cos * cos);
                let (sin_phi, cos_phi) = crate::simd::sin_cos(2.0 * PI * u2.y);
                Frame::from_normal(wi).to_world(Vec3::new(sin * cos_phi, sin * sin_phi, cos))
            }
            PhaseFunction::Tabulated(t) => t.sample(wi, u2),
            PhaseFunction::Sggx(s) => s.sample(p, wi, u2),
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
                    second.sample_direction(p, wi, u / weight, u2)
                } else {
                    first.sample_direction(p, wi, (u - weight) / (1.0 - weight), u2)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{chi2_cases, chi2_test, integrate_over_sphere};

    /// A forward-peaked table with a backward bump and a zero stretch.
    const TABLE: [f32; 9] = [0.6, 0.2, 0.0, 0.0, 0.1, 0.3, 0.8, 2.5, 6.0];

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
            (PhaseFunction::Rayleigh, wi),
            (PhaseFunction::Rayleigh, -Vec3::Y),
            (PhaseFunction::Tabulated(Arc::new(TabulatedPhase::new(&TABLE).unwrap())), wi),
            (PhaseFunction::Tabulated(Arc::new(TabulatedPhase::new(&[1.0, 1.0]).unwrap())), Vec3::Z),
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
            |p, wi, u1, u| Some(p.sample(Vec3::ZERO, wi, u1, u).0),
            |p, wi, wo| p.eval(Vec3::ZERO, wi, wo) as f64,
        );
        // Power: HG g = 0.5 sampled, g = 0.4 claimed; a table sampled with
        // the sign of cos θ flipped; Rayleigh against isotropic.
        let wi = Vec3::Z;
        let o = Vec3::ZERO;
        let p = chi2_test(
            200_000,
            1,
            |u1, u| Some(PhaseFunction::HenyeyGreenstein { g: 0.5 }.sample(o, wi, u1, u).0),
            |wo| PhaseFunction::HenyeyGreenstein { g: 0.4 }.eval(o, wi, wo) as f64,
        );
        assert!(p < a, "a wrong g was not detected: p = {p}");
        let positive = [0.5, 0.3, 0.2, 0.2, 0.4, 0.8, 1.5, 3.0, 5.0];
        let tab = PhaseFunction::Tabulated(Arc::new(TabulatedPhase::new(&positive).unwrap()));
        let p = chi2_test(200_000, 2, |u1, u| Some(-tab.sample(o, wi, u1, u).0), |wo| tab.eval(o, wi, wo) as f64);
        assert!(p < a, "a flipped table was not detected: p = {p}");
        let p = chi2_test(
            200_000,
            3,
            |u1, u| Some(PhaseFunction::Rayleigh.sample(o, wi, u1, u).0),
            |wo| PhaseFunction::Isotropic.eval(o, wi, wo) as f64,
        );
        assert!(p < a, "Rayleigh samples passed as isotropic: p = {p}");
    }

    /// Each phase function integrates to 1 over the sphere, its sample's
    /// density is its value, and g is the mean cosine (forward = −wi).
    #[test]
    fn normalised_with_mean_cosine_g() {
        for (p, wi) in cases() {
            let o = Vec3::ZERO;
            let total = integrate_over_sphere(|wo| p.eval(o, wi, wo) as f64);
            assert!((total - 1.0).abs() < 2e-3, "{p:?}: integral {total}");
            let mean_cos = integrate_over_sphere(|wo| (p.eval(o, wi, wo) * wo.dot(-wi)) as f64);
            let g = match &p {
                PhaseFunction::Isotropic | PhaseFunction::Rayleigh => 0.0,
                PhaseFunction::HenyeyGreenstein { g } => *g as f64,
                PhaseFunction::Blend { .. } => 0.7 * 0.7 + 0.3 * -0.5,
                // ∫ μ p(μ) dμ of the normalised linear interpolant, by a fine midpoint rule.
                PhaseFunction::Tabulated(t) => {
                    let n = 200_000;
                    (0..n)
                        .map(|i| {
                            let mu = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                            mu * t.distr.eval_pdf_normalized(mu as f32) as f64 * 2.0 / n as f64
                        })
                        .sum()
                }
                PhaseFunction::Sggx(_) => unreachable!("not among the cases"),
            };
            assert!((mean_cos - g).abs() < 5e-3, "{p:?}: mean cosine {mean_cos}, g {g}");
            let (wo, pdf) = p.sample(o, wi, 0.4, Vec2::new(0.3, 0.7));
            assert!((wo.length() - 1.0).abs() < 1e-5);
            assert_eq!(pdf, p.eval(o, wi, wo));
        }
    }

    /// Values against Mitsuba 3.9.1's eval_pdf, printed by
    /// tools/mitsuba_phase_values.py (same wi, wo, table and S; Mitsuba's
    /// exact forward direction of sggx is NaN there, 0 here, and left out).
    #[test]
    fn matches_mitsuba() {
        let wi = Vec3::new(0.3, -0.5, 0.8).normalize();
        let wos = [
            Vec3::new(0.3, -0.5, 0.8),
            Vec3::new(-0.3, 0.5, -0.8),
            Vec3::new(0.9, 0.1, -0.2),
            Vec3::new(-0.4, -0.4, 0.3),
            Vec3::new(0.0, 1.0, 0.1),
        ];
        let rayleigh = [0.1193662, 0.1193662, 0.05993804, 0.07489353, 0.07031969];
        let tab = [0.05305165, 0.5305165, 0.006530426, 0.000341636, 0.05697013];
        let sggx_cases: [([f32; 6], [f32; 5]); 3] = [
            ([1.0, 1.0, 1.0, 0.0, 0.0, 0.0], [0.07957747, f32::NAN, 0.07957745, 0.07957747, 0.07957748]),
            ([0.05, 0.05, 1.0, 0.0, 0.0, 0.0], [0.03372538, f32::NAN, 0.006829975, 0.02061234, 0.04662794]),
            ([1.0, 0.5, 0.3, 0.2, -0.1, 0.05], [0.02917544, f32::NAN, 0.08010015, 0.04196861, 0.05568379]),
        ];
        let table = PhaseFunction::Tabulated(Arc::new(TabulatedPhase::new(&TABLE).unwrap()));
        let close = |ours: f32, theirs: f32, what: &str| {
            println!("{what}: {ours} vs Mitsuba {theirs}");
            assert!((ours / theirs - 1.0).abs() < 2e-5, "{what}: {ours} vs Mitsuba {theirs}");
        };
        for (k, wo) in wos.iter().map(|w| w.normalize()).enumerate() {
            close(PhaseFunction::Rayleigh.eval(Vec3::ZERO, wi, wo), rayleigh[k], "rayleigh");
            close(table.eval(Vec3::ZERO, wi, wo), tab[k], "tabphase");
            for (s, values) in &sggx_cases {
                if !values[k].is_nan() {
                    close(sggx::eval(s, wi, wo), values[k], "sggx");
                }
            }
        }
    }
}
