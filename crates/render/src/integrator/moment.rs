//! Mitsuba `moment`: each nested integrator's image and its second moment,
//! for estimating the variance of a render.
//!
//! | parameter | type       | default |
//! |-----------|------------|---------|
//! | (nested)  | integrator | one or more, named by the nested tag's `name` (`_arg_N` when unnamed) |
//!
//! Output channels, in Mitsuba 3.9.1's order: for each nested integrator
//! `NAME`, its own output channels as `NAME.<channel>`, then `NAME.X`,
//! `NAME.Y`, `NAME.Z` (its radiance as CIE XYZ, converted from linear sRGB);
//! then the same list again with each name prefixed by `m2_`, the per-sample
//! squares of those values. Like every channel they are filter-weighted
//! means over the pixel's samples, so `m2_NAME.X − NAME.X²` estimates the
//! variance of one sample (not of the pixel's mean).
//!
//! The beauty is the first nested integrator's. Unlike `aov`, the nested
//! integrators draw their random numbers one after the other from the
//! camera sample's stream, as Mitsuba's share one sampler: the first one's
//! image is bitwise the one it gives alone, the others' are not.

use super::{Integrator, RayDiff, RayStats};
use crate::geometry::Ray;
use crate::material::Scratch;
use crate::math::Spectrum;
use crate::sampling::SampleStream;
use crate::scene::Scene;

/// The `moment` integrator.
#[derive(Debug, Clone, Default)]
pub struct MomentIntegrator {
    /// Nested integrators with their names, in document order.
    pub integrators: Vec<(String, Integrator)>,
}

/// Linear sRGB → CIE XYZ, Mitsuba's `srgb_to_xyz` (rows X, Y, Z).
pub const SRGB_TO_XYZ: [[f32; 3]; 3] =
    [[0.412453, 0.357580, 0.180423], [0.212671, 0.715160, 0.072169], [0.019334, 0.119193, 0.950227]];

/// `rgb` as CIE XYZ.
#[inline]
pub fn srgb_to_xyz(rgb: Spectrum) -> [f32; 3] {
    let c = rgb.to_array();
    SRGB_TO_XYZ.map(|row| row[0] * c[0] + row[1] * c[1] + row[2] * c[2])
}

impl MomentIntegrator {
    /// The output channels (Mitsuba's `aov_names()`).
    pub fn channel_names(&self) -> Vec<String> {
        let mut first = Vec::new();
        for (name, integrator) in &self.integrators {
            first.extend(integrator.channel_names().into_iter().map(|c| format!("{name}.{c}")));
            for c in ["X", "Y", "Z"] {
                first.push(format!("{name}.{c}"));
            }
        }
        let second: Vec<String> = first.iter().map(|c| format!("m2_{c}")).collect();
        first.extend(second);
        first
    }

    /// The first nested integrator's radiance along `ray`; every nested
    /// one's channels, XYZ and their squares go to `out`.
    #[allow(clippy::too_many_arguments)]
    pub fn sample(
        &self,
        scene: &Scene,
        ray: &Ray,
        diff: Option<&RayDiff>,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
        out: &mut [f32],
    ) -> Spectrum {
        let half = out.len() / 2;
        let (means, squares) = out.split_at_mut(half);
        let mut beauty = Spectrum::ZERO;
        let mut at = 0;
        for (i, (_, integrator)) in self.integrators.iter().enumerate() {
            let n = integrator.channel_names().len();
            let l = integrator.sample(scene, ray, diff, rng, stats, scratch, &mut means[at..at + n]);
            means[at + n..at + n + 3].copy_from_slice(&srgb_to_xyz(l));
            if i == 0 {
                beauty = l;
            }
            at += n + 3;
        }
        for (s, m) in squares.iter_mut().zip(means.iter()) {
            *s = m * m;
        }
        beauty
    }
}
