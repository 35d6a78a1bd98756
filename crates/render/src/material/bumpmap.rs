//! Mitsuba `bumpmap`: the shading frame from a height texture's gradient.
//! Placeholder: implemented in the textures change.

use crate::geometry::SurfaceInteraction;
use crate::math::Frame;
use crate::texture::Texture;

/// The perturbed shading frame for the height field `scale · height(uv)`.
pub fn perturbed_frame(si: &SurfaceInteraction, _height: &Texture, _scale: f32) -> Frame {
    si.sh_frame
}
