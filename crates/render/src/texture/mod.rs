//! Textures: spatially varying parameters, evaluated at a surface point.
//!
//! Every BSDF parameter Mitsuba lets a texture drive is a [`Texture`]; a
//! plain `<rgb>` or `<float>` becomes [`Texture::Constant`], Mitsuba's
//! `bitmap` a [`Texture::Bitmap`], `checkerboard` a
//! [`Texture::Checkerboard`], `mesh_attribute` a [`Texture::MeshAttribute`]
//! and `volume` a [`Texture::Volume`] (volume data, volume.rs, looked up at
//! the surface point in world space).

pub mod bitmap;
pub mod checkerboard;
pub mod mesh_attribute;
pub mod volume;

pub use bitmap::{Bitmap, FilterType, WrapMode};
pub use checkerboard::Checkerboard;
pub use mesh_attribute::{AttributeTable, MeshAttribute, MeshAttributeData};

use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use glam::Vec2;
use std::sync::Arc;

/// A texturable parameter: a constant or a shared texture object.
#[derive(Debug, Clone)]
pub enum Texture {
    /// The same value everywhere (linear RGB; scalars in all three channels).
    Constant(Spectrum),
    /// Mitsuba's `bitmap`: an image looked up at the surface uv.
    Bitmap(Arc<Bitmap>),
    /// Mitsuba's `checkerboard`.
    Checkerboard(Arc<Checkerboard>),
    /// Mitsuba's `mesh_attribute`: per-vertex or per-face data of the hit mesh.
    MeshAttribute(Arc<MeshAttribute>),
    /// Mitsuba's `volume`: a volume (`constvolume`, `gridvolume` of 1 or 3
    /// channels) looked up at the world-space surface point.
    Volume(Arc<volume::Volume>),
}

impl Texture {
    /// The colour at a surface point (linear RGB).
    #[inline]
    pub fn eval(&self, si: &SurfaceInteraction) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(b) => b.eval(si.uv),
            Texture::Checkerboard(c) => c.eval(si),
            Texture::MeshAttribute(m) => m.eval(si),
            Texture::Volume(v) => v.eval(si.p),
        }
    }

    /// Whether the value depends on the hit's `uv` alone (constants,
    /// bitmaps, checkerboards of those): then a hit with only `uv` set
    /// evaluates it.
    pub fn reads_only_uv(&self) -> bool {
        match self {
            Texture::Constant(_) | Texture::Bitmap(_) => true,
            Texture::Checkerboard(c) => c.color0.reads_only_uv() && c.color1.reads_only_uv(),
            Texture::MeshAttribute(_) | Texture::Volume(_) => false,
        }
    }

    /// A scalar at a surface point (Mitsuba's `eval_1`): the mean of the
    /// channels for a constant colour, the luminance of a colour bitmap, and
    /// for the checkerboard Mitsuba 3.9.1's `eval_1`, whose squares are
    /// swapped with respect to `eval` (see [`Checkerboard::eval_1`]).
    #[inline]
    pub fn eval_1(&self, si: &SurfaceInteraction) -> f32 {
        match self {
            Texture::Constant(c) => (c.x + c.y + c.z) / 3.0,
            Texture::Bitmap(b) => b.eval_1(si.uv),
            Texture::Checkerboard(c) => c.eval_1(si),
            Texture::MeshAttribute(m) => m.eval_1(si),
            Texture::Volume(v) => v.eval_1(si.p),
        }
    }

    /// The scalar value and its gradient with respect to (u, v) (Mitsuba's
    /// `eval_1` and `eval_1_grad`, as `bumpmap` uses them). Constants have a
    /// zero gradient; Mitsuba implements the gradient only for bitmaps, so a
    /// checkerboard reports zero (its derivative vanishes almost everywhere).
    #[inline]
    pub fn eval_1_grad(&self, si: &SurfaceInteraction) -> (f32, Vec2) {
        match self {
            Texture::Bitmap(b) => b.eval_1_grad(si.uv),
            _ => (self.eval_1(si), Vec2::ZERO),
        }
    }

    /// Whether Mitsuba implements `eval_1_grad` for this texture (bump maps
    /// need it).
    pub fn has_gradient(&self) -> bool {
        !matches!(self, Texture::Checkerboard(_) | Texture::MeshAttribute(_) | Texture::Volume(_))
    }

    /// Whether Mitsuba implements `mean` for this texture (not for
    /// `mesh_attribute` and `volume`: plugins that need it fail to load there).
    pub fn has_mean(&self) -> bool {
        match self {
            Texture::MeshAttribute(_) | Texture::Volume(_) => false,
            Texture::Checkerboard(c) => c.color0.has_mean() && c.color1.has_mean(),
            _ => true,
        }
    }

    /// Mean value over the texture's domain (Mitsuba's `Texture::mean`, used
    /// to set sampling weights): the channel mean of a constant colour, the
    /// mean luminance of a bitmap, the mean of a checkerboard's two colours.
    pub fn mean(&self) -> f32 {
        match self {
            Texture::Constant(c) => (c.x + c.y + c.z) / 3.0,
            Texture::Bitmap(b) => b.mean(),
            Texture::Checkerboard(c) => 0.5 * (c.color0.mean() + c.color1.mean()),
            // Never asked for: the builder checks `has_mean` first.
            Texture::MeshAttribute(_) | Texture::Volume(_) => 0.0,
        }
    }

    /// The value when the texture is constant.
    pub fn constant(&self) -> Option<Spectrum> {
        match self {
            Texture::Constant(c) => Some(*c),
            _ => None,
        }
    }
}

impl From<Spectrum> for Texture {
    fn from(c: Spectrum) -> Texture {
        Texture::Constant(c)
    }
}
