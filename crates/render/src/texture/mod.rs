//! Textures: spatially varying parameters, evaluated at a surface point.
//!
//! Every BSDF parameter Mitsuba lets a texture drive is a [`Texture`]; a
//! plain `<rgb>` or `<float>` becomes [`Texture::Constant`].

use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;

#[derive(Debug, Clone)]
pub enum Texture {
    Constant(Spectrum),
}

impl Texture {
    /// The colour at a surface point (linear RGB).
    #[inline]
    pub fn eval(&self, _si: &SurfaceInteraction) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
        }
    }

    /// A scalar at a surface point (Mitsuba's `eval_1`): the mean of the
    /// channels for colour data.
    #[inline]
    pub fn eval_1(&self, si: &SurfaceInteraction) -> f32 {
        let c = self.eval(si);
        (c.x + c.y + c.z) / 3.0
    }

    /// Mean value over the texture's domain, averaged over channels (Mitsuba's
    /// `Texture::mean`, used to set sampling weights).
    pub fn mean(&self) -> f32 {
        match self {
            Texture::Constant(c) => (c.x + c.y + c.z) / 3.0,
        }
    }

    /// The value when the texture is constant.
    pub fn constant(&self) -> Option<Spectrum> {
        match self {
            Texture::Constant(c) => Some(*c),
        }
    }
}

impl From<Spectrum> for Texture {
    fn from(c: Spectrum) -> Texture {
        Texture::Constant(c)
    }
}
