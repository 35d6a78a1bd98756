//! Mitsuba 3.9.1's `tabphase` (src/phase/tabphase.cpp): a phase function
//! tabulated over the cosine of the scattering angle, values regularly
//! spaced on [−1, 1], linear in between, normalised automatically.
//!
//! The table is in the physics convention: cos θ = 1 is forward
//! scattering, i.e. cos θ = −dot(wo, wi) with Mitsuba's `wi` pointing back
//! along the incoming ray. The value is the normalised density in cos θ
//! over 2π (uniform in the azimuth).

use crate::math::{safe_sqrt, Frame, INV_2PI, PI};
use crate::sampling::ContinuousDistribution;
use glam::{Vec2, Vec3};

/// A tabulated phase function.
#[derive(Debug, Clone, PartialEq)]
pub struct TabulatedPhase {
    /// The density in cos θ (physics convention) on [−1, 1].
    pub distr: ContinuousDistribution,
}

impl TabulatedPhase {
    /// From the table's values (at least two, not negative, some positive).
    pub fn new(values: &[f32]) -> Result<TabulatedPhase, String> {
        Ok(TabulatedPhase { distr: ContinuousDistribution::new((-1.0, 1.0), values)? })
    }

    /// The value (and density) for scattering from `wi` into `wo`.
    #[inline]
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.distr.eval_pdf_normalized(-wo.dot(wi)) * INV_2PI
    }

    /// cos θ' from the table's CDF, a uniform azimuth, and the direction
    /// flipped into the graphics convention (as tabphase.cpp).
    pub fn sample(&self, wi: Vec3, u: Vec2) -> Vec3 {
        let cos = self.distr.sample(u.x);
        let sin = safe_sqrt(1.0 - cos * cos);
        let (sin_phi, cos_phi) = crate::simd::sin_cos(2.0 * PI * u.y);
        -Frame::from_normal(wi).to_world(Vec3::new(sin * cos_phi, sin * sin_phi, cos))
    }
}
