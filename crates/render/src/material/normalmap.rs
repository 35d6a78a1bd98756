//! Mitsuba `normalmap`: the shading frame from a tangent-space normal map.
//! Placeholder: implemented in the textures change.

use crate::geometry::SurfaceInteraction;
use crate::math::{Frame, Spectrum};

/// The perturbed shading frame for a normal-map texel `rgb` (in [0, 1]³).
pub fn perturbed_frame(si: &SurfaceInteraction, _rgb: Spectrum) -> Frame {
    si.sh_frame
}
