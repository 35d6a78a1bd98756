//! Mitsuba `principled` as the scene stores it: textured parameters that
//! [`PrincipledMaterial::eval`] turns into a per-hit [`Principled`].

use crate::bsdf::Principled;
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
