//! Mitsuba `principled` and `principledthin` as the scene stores them:
//! textured parameters that [`PrincipledMaterial::eval`] and
//! [`PrincipledThinMaterial::eval`] turn into a per-hit [`Principled`] or
//! [`PrincipledThin`].

use crate::bsdf::{Principled, PrincipledThin};
use crate::geometry::SurfaceInteraction;
use crate::texture::Texture;

/// Parameters absent from the scene (or given as the float 0, Mitsuba's
/// `get_flag`) are `None` and evaluate to 0.
#[derive(Debug, Clone)]
pub struct PrincipledMaterial {
    pub base_color: Texture,
    pub roughness: Texture,
    pub anisotropic: Option<Texture>,
    pub spec_trans: Option<Texture>,
    pub metallic: Option<Texture>,
    pub spec_tint: Option<Texture>,
    pub sheen: Option<Texture>,
    pub sheen_tint: Option<Texture>,
    pub clearcoat: Option<Texture>,
    pub clearcoat_gloss: Texture,
    pub flatness: Option<Texture>,
    /// Relative IOR (Mitsuba's adjustments for η = 1 already applied).
    pub eta: f32,
    pub spec_srate: f32,
    pub clearcoat_srate: f32,
    pub diffuse_srate: f32,
}

impl PrincipledMaterial {
    pub fn eval(&self, si: &SurfaceInteraction) -> Principled {
        let opt = |t: &Option<Texture>| t.as_ref().map_or(0.0, |t| t.eval_1(si));
        Principled {
            base_color: self.base_color.eval(si),
            roughness: self.roughness.eval_1(si),
            anisotropic: opt(&self.anisotropic),
            spec_trans: opt(&self.spec_trans),
            metallic: opt(&self.metallic),
            spec_tint: opt(&self.spec_tint),
            sheen: opt(&self.sheen),
            sheen_tint: opt(&self.sheen_tint),
            clearcoat: opt(&self.clearcoat),
            clearcoat_gloss: if self.clearcoat.is_some() { self.clearcoat_gloss.eval_1(si) } else { 0.0 },
            flatness: opt(&self.flatness),
            eta: self.eta,
            has_spec_trans: self.spec_trans.is_some(),
            has_flatness: self.flatness.is_some(),
            spec_srate: self.spec_srate,
            clearcoat_srate: self.clearcoat_srate,
            diffuse_srate: self.diffuse_srate,
        }
    }
}

/// Mitsuba `principledthin`; absent parameters (or the float 0, Mitsuba's
/// `get_flag`) are `None`.
#[derive(Debug, Clone)]
pub struct PrincipledThinMaterial {
    pub base_color: Texture,
    pub roughness: Texture,
    pub anisotropic: Option<Texture>,
    pub spec_trans: Option<Texture>,
    pub spec_tint: Option<Texture>,
    pub sheen: Option<Texture>,
    pub sheen_tint: Option<Texture>,
    pub flatness: Option<Texture>,
    /// Mitsuba's 0..2 `diff_trans`, halved at evaluation as there.
    pub diff_trans: Option<Texture>,
    pub eta: Texture,
    pub spec_refl_srate: f32,
    pub spec_trans_srate: f32,
    pub diff_trans_srate: f32,
    pub diff_refl_srate: f32,
}

impl PrincipledThinMaterial {
    pub fn eval(&self, si: &SurfaceInteraction) -> PrincipledThin {
        let opt = |t: &Option<Texture>| t.as_ref().map_or(0.0, |t| t.eval_1(si));
        PrincipledThin {
            base_color: self.base_color.eval(si),
            roughness: self.roughness.eval_1(si),
            anisotropic: opt(&self.anisotropic),
            spec_trans: opt(&self.spec_trans),
            spec_tint: opt(&self.spec_tint),
            sheen: opt(&self.sheen),
            sheen_tint: opt(&self.sheen_tint),
            flatness: opt(&self.flatness),
            diff_trans: opt(&self.diff_trans) / 2.0,
            eta: self.eta.eval_1(si),
            has_anisotropic: self.anisotropic.is_some(),
            has_spec_trans: self.spec_trans.is_some(),
            has_spec_tint: self.spec_tint.is_some(),
            has_sheen: self.sheen.is_some(),
            has_sheen_tint: self.sheen_tint.is_some(),
            has_flatness: self.flatness.is_some(),
            has_diff_trans: self.diff_trans.is_some(),
            spec_refl_srate: self.spec_refl_srate,
            spec_trans_srate: self.spec_trans_srate,
            diff_trans_srate: self.diff_trans_srate,
            diff_refl_srate: self.diff_refl_srate,
        }
    }
}
