//! BSDFs. All methods work in the local shading frame (normal = +z).
//!
//! Contract (see CONVENTIONS.md):
//! - `wo` points towards the camera side, `wi` is the light / sampled direction.
//! - [`Bsdf::eval`] returns f(wo, wi) *without* the cosine; integrators
//!   multiply by |cos θ_i|. Delta lobes evaluate to zero.
//! - [`Bsdf::pdf`] is a density per unit solid angle of `wi`; 0 for delta lobes.
//! - [`BsdfSample::weight`] is f · |cos θ_i| / pdf (the discrete probability
//!   for delta lobes), ready to multiply into the path throughput.
//! - BSDFs are one-sided like Mitsuba's (black when `wo.z <= 0`) except
//!   dielectrics, unless wrapped in [`Bsdf::TwoSided`].

pub mod conductor;
pub mod dielectric;
pub mod diffuse;
pub mod fresnel;
pub mod presets;

pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;

use crate::math::Spectrum;
use glam::{Vec2, Vec3};

/// A sampled direction with its weight.
#[derive(Debug, Clone, Copy)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// Solid-angle density, or the lobe's discrete probability when `delta`.
    pub pdf: f32,
    /// f · |cos θ_i| / pdf.
    pub weight: Spectrum,
    /// Sampled from a Dirac delta lobe (MIS does not apply).
    pub delta: bool,
    /// Relative IOR crossed (1 for reflection), for Russian roulette.
    pub eta: f32,
}

#[derive(Debug, Clone)]
pub enum Bsdf {
    Diffuse(Diffuse),
    Dielectric(Dielectric),
    Conductor(Conductor),
    /// Mitsuba `twosided`: the back side mirrors `back` (usually the same BSDF).
    TwoSided(Box<Bsdf>, Box<Bsdf>),
}

impl Bsdf {
    /// Whether any lobe is non-delta, i.e. light sampling can help.
    pub fn has_smooth(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) => true,
            Bsdf::Dielectric(_) | Bsdf::Conductor(_) => false,
            Bsdf::TwoSided(a, b) => a.has_smooth() || b.has_smooth(),
        }
    }

    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        match self {
            Bsdf::Diffuse(d) => d.eval(wo, wi),
            Bsdf::Dielectric(_) | Bsdf::Conductor(_) => Spectrum::ZERO,
            Bsdf::TwoSided(front, back) => {
                if wo.z >= 0.0 {
                    front.eval(wo, wi)
                } else {
                    back.eval(flip(wo), flip(wi))
                }
            }
        }
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse(d) => d.pdf(wo, wi),
            Bsdf::Dielectric(_) | Bsdf::Conductor(_) => 0.0,
            Bsdf::TwoSided(front, back) => {
                if wo.z >= 0.0 {
                    front.pdf(wo, wi)
                } else {
                    back.pdf(flip(wo), flip(wi))
                }
            }
        }
    }

    /// Samples `wi` given `wo`; `u` picks a lobe, `u2` the direction.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(d) => d.sample(wo, u2),
            Bsdf::Dielectric(d) => d.sample(wo, u, u2),
            Bsdf::Conductor(c) => c.sample(wo),
            Bsdf::TwoSided(front, back) => {
                if wo.z >= 0.0 {
                    front.sample(wo, u, u2)
                } else {
                    back.sample(flip(wo), u, u2).map(|mut s| {
                        s.wi = flip(s.wi);
                        s
                    })
                }
            }
        }
    }
}

#[inline]
fn flip(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}
