//! pbrt-v4's participating media (`MakeNamedMedium`, `MediumInterface`) as
//! Penumbra's. pbrt-v4's `path` integrator ignores media (rays pass the
//! `interface` surfaces that bound them), its `volpath` renders them; so
//! media are attached only when the scene's integrator is `volpath`, which
//! then becomes Penumbra's volumetric path tracer.
//!
//! | type        | parameters read                                                       |
//! |-------------|-----------------------------------------------------------------------|
//! | homogeneous | sigma_a (1), sigma_s (1), scale (1), g (0: isotropic; else Henyey–Greenstein), Le (0; emission is refused) and Lescale |
//!
//! σ_t = scale · (σ_a + σ_s) and the albedo σ_s / σ_t per RGB channel (the
//! spectra converted as unbounded spectra, see `spectra`). `preset` (pbrt's
//! measured media) and the grid media (`uniformgrid`, `rgbgrid`,
//! `nanovdb`, `cloud`) are errors at their position.

use super::spectra::{to_rgb, SpectrumUse};
use crate::error::{LoadError, Result};
use crate::pbrt::parser::PbrtScene;
use crate::scene_builder::{MediumId, SceneBuilder};
use penumbra_render::math::Spectrum;
use penumbra_render::medium::{Medium, MediumKind, PhaseFunction};
use penumbra_render::scene::ShapeMedia;
use std::collections::HashMap;

/// The scene's named media, added to the builder, by name.
pub struct Media {
    ids: HashMap<String, MediumId>,
}

impl Media {
    /// Adds every `MakeNamedMedium` of `scene` to `b` (all are checked,
    /// used or not).
    pub fn new(scene: &PbrtScene, b: &mut SceneBuilder) -> Result<Media> {
        let mut names: Vec<&String> = scene.media.keys().collect();
        names.sort();
        let mut ids = HashMap::new();
        for name in names {
            let (e, _) = &scene.media[name];
            let (p, at) = (&e.params, &e.loc);
            if e.kind != "homogeneous" {
                return Err(LoadError::at(
                    at,
                    format!(
                        "MakeNamedMedium \"{name}\": medium type \"{}\" is not supported; supported: homogeneous",
                        e.kind
                    ),
                ));
            }
            if let Some(preset) = p.string("preset")? {
                return Err(LoadError::at(
                    at,
                    format!(
                        "MakeNamedMedium \"{name}\": \"preset\" \"{preset}\" (pbrt-v4's measured media) is not \
                         supported; give sigma_a and sigma_s"
                    ),
                ));
            }
            let spectrum = |n: &str| -> Result<Spectrum> {
                Ok(match p.spectrum(n)? {
                    Some((v, loc)) => Spectrum::from_array(to_rgb(&v, SpectrumUse::Unbounded, &loc)?),
                    None => Spectrum::ONE,
                })
            };
            let (sigma_a, sigma_s) = (spectrum("sigma_a")?, spectrum("sigma_s")?);
            let scale = p.float("scale", 1.0)?;
            let g = p.float("g", 0.0)?;
            let le_scale = p.float("Lescale", 1.0)?;
            if let Some((v, loc)) = p.spectrum("Le")? {
                let le = to_rgb(&v, SpectrumUse::Illuminant, &loc)?;
                if le_scale != 0.0 && le.iter().any(|&c| c > 0.0) {
                    return Err(LoadError::at(&loc, "emitting media (\"Le\") are not supported"));
                }
            }
            p.check_unused(&format!("MakeNamedMedium \"{name}\""))?;
            if !(scale >= 0.0 && scale.is_finite()) {
                return Err(LoadError::at(at, format!("\"scale\" {scale} must be finite and not negative")));
            }
            if !(g > -1.0 && g < 1.0) {
                return Err(LoadError::at(at, format!("\"g\" {g} must lie in (-1, 1)")));
            }
            let sigma_t = (sigma_a + sigma_s) * scale as f32;
            let albedo = Spectrum::new(
                ratio(sigma_s.x, sigma_a.x + sigma_s.x),
                ratio(sigma_s.y, sigma_a.y + sigma_s.y),
                ratio(sigma_s.z, sigma_a.z + sigma_s.z),
            );
            let phase =
                if g == 0.0 { PhaseFunction::Isotropic } else { PhaseFunction::HenyeyGreenstein { g: g as f32 } };
            let medium = Medium { kind: MediumKind::Homogeneous { sigma_t, albedo }, phase, sample_emitters: true };
            ids.insert(name.clone(), b.add_medium(medium));
        }
        Ok(Media { ids })
    }

    /// The medium named `name` ("" is none); `at` places the error of an unknown name.
    pub fn get(&self, name: &str, at: &crate::error::FileLoc) -> Result<Option<MediumId>> {
        if name.is_empty() {
            return Ok(None);
        }
        self.ids.get(name).copied().map(Some).ok_or_else(|| {
            LoadError::at(at, format!("MediumInterface names \"{name}\", which no MakeNamedMedium defines"))
        })
    }

    /// A shape's media from its `MediumInterface` (inside, outside).
    pub fn interface(&self, names: &(String, String), at: &crate::error::FileLoc) -> Result<ShapeMedia> {
        Ok(ShapeMedia { interior: self.get(&names.0, at)?, exterior: self.get(&names.1, at)? })
    }
}

/// a / b, 0 where b is 0.
fn ratio(a: f32, b: f32) -> f32 {
    if b > 0.0 {
        a / b
    } else {
        0.0
    }
}
