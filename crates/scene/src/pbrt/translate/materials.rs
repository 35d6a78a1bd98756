//! pbrt-v4's materials as Penumbra's.
//!
//! pbrt-v4's reflective BSDFs answer on both sides of a surface; Mitsuba's
//! (and Penumbra's) are black from behind, so `diffuse` and `conductor` are
//! wrapped in `twosided`. Microfacet models are pbrt-v4's Trowbridge-Reitz
//! (GGX) with α = √roughness when `remaproughness` is true (its default);
//! α below 10⁻³ is a smooth surface, as pbrt-v4's `EffectivelySmooth`.
//!
//! | material            | parameters read                                                   |
//! |---------------------|-------------------------------------------------------------------|
//! | diffuse             | reflectance (0.5)                                                 |
//! | conductor           | eta (metal-Cu-eta), k (metal-Cu-k) or reflectance; roughness, uroughness, vroughness (0), remaproughness (true) |
//! | dielectric          | eta (1.5; a float or a spectrum, its value at 550 nm), roughness, uroughness, vroughness (0), remaproughness |
//! | thindielectric      | eta (1.5)                                                         |
//! | diffusetransmission | reflectance (0.25), transmittance (0.25), scale (1)               |
//! | coateddiffuse       | reflectance (0.5), roughness, uroughness, vroughness (0), eta (1.5), thickness (0.01), g (0), albedo (0), maxdepth (10), nsamples (1), remaproughness (true): pbrt-v4's stochastic layered BSDF (`bsdf::layered`) |
//! | coatedconductor     | interface.roughness/uroughness/vroughness (0), interface.eta (1.5), conductor.eta/conductor.k (metal-Cu) or reflectance, conductor.roughness/uroughness/vroughness (0), thickness, g, albedo, maxdepth, nsamples, remaproughness |
//! | mix                 | materials (two names), amount (0.5): Penumbra blends the two BSDFs, pbrt-v4 picks one per hit with the same probabilities |
//! | interface, none     | (none): the surface only bounds media                             |

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose

use super::super::params::ParamList;
use super::super::parser::Entity;
use super::spectra::{eta as spectrum_eta, SpectrumUse};
use super::textures::{PTex, Textures};
use crate::error::{FileLoc, LoadError, Result};
use penumbra_render::bsdf::{
    ConductorParams, DielectricParams, DiffuseParams, DiffuseTransmissionParams, MicrofacetType, RoughConductorParams,
    RoughDielectricParams, Roughness, ThinDielectricParams,
};
use penumbra_render::material::Material;
use penumbra_render::texture::Texture;
use std::collections::HashMap;

/// Materials Penumbra translates, for error messages.
pub const MATERIALS: &[&str] = &[
    "diffuse",
    "conductor",
    "dielectric",
    "thindielectric",
    "diffusetransmission",
    "coateddiffuse",
    "coatedconductor",
    "mix",
    "interface",
];

/// Whether a translated material must be made two-sided.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sides {
    /// Black from behind (Mitsuba's convention): wrap in `twosided`.
    Front,
    /// Both sides by its nature (transmissive, or null).
    Both,
}

/// `eta`, `k` of a conductor from `reflectance` r: η = 1, k = 2√r / √(1 − r)
/// (pbrt-v4's `ConductorMaterial::GetBxDF`).
fn k_from_reflectance(r: f32) -> f32 {
    let r = r.clamp(0.0, 0.9999);
    2.0 * r.sqrt() / (1.0 - r).sqrt()
}

/// The roughness (α_u, α_v) of a microfacet material, or `None` when smooth.
fn roughness(p: &ParamList, tex: &Textures, prefix: &str, at: &FileLoc) -> Result<Option<Roughness>> {
    let name = |n: &str| format!("{prefix}{n}");
    let u = tex.optional(p, &name("uroughness"), None)?;
    let v = tex.optional(p, &name("vroughness"), None)?;
    let r = tex.value(p, &name("roughness"), None, [0.0; 3])?;
    let (u, v) = (u.unwrap_or_else(|| r.clone()), v.unwrap_or(r));
    let remap = p.bool("remaproughness", true)?;
    let to_alpha = |t: PTex| if remap { t.map(&|x| x.max(0.0).sqrt()) } else { t };
    let (u, v) = (to_alpha(u), to_alpha(v));
    if let (Some(a), Some(b)) = (u.constant(), v.constant()) {
        if a[0].max(b[0]) < 1e-3 {
            return Ok(None);
        }
    }
    Ok(Some(Roughness { kind: MicrofacetType::Ggx, alpha_u: u.build(at)?, alpha_v: v.build(at)? }))
}

/// The materials of a scene, built once each.
pub struct Materials<'a> {
    named: &'a HashMap<String, Entity>,
}

impl<'a> Materials<'a> {
    /// Over the scene's named materials.
    pub fn new(named: &'a HashMap<String, Entity>) -> Self {
        Materials { named }
    }

    /// A material directive's translation, two-sided where pbrt's is.
    pub fn entity(&self, e: &Entity, tex: &Textures, depth: usize) -> Result<Material> {
        let (m, sides) = self.build(e, tex, depth)?;
        Ok(match sides {
            Sides::Front => Material::TwoSided(Box::new(m.clone()), Box::new(m)),
            Sides::Both => m,
        })
    }

    fn build(&self, e: &Entity, tex: &Textures, depth: usize) -> Result<(Material, Sides)> {
        let p = &e.params;
        let at = &e.loc;
        let kind = e.kind.as_str();
        // MakeNamedMaterial's type.
        p.string("type")?;
        let tex_of = |t: PTex| t.build(at);
        let out = match kind {
            "diffuse" => {
                let r = tex.value(p, "reflectance", Some(SpectrumUse::Albedo), [0.5; 3])?;
                (Material::Diffuse(DiffuseParams { reflectance: tex_of(r)? }), Sides::Front)
            }
            "conductor" => {
                let refl = tex.optional(p, "reflectance", Some(SpectrumUse::Albedo))?;
                let (eta, k) = match refl {
                    Some(r) => {
                        if p.type_of("eta").is_some() || p.type_of("k").is_some() {
                            return Err(LoadError::at(
                                at,
                                "conductor: give either \"reflectance\" or \"eta\" and \"k\", not both",
                            ));
                        }
                        (PTex::Const([1.0; 3]), r.map(&k_from_reflectance))
                    }
                    None => {
                        let eta = tex.optional(p, "eta", Some(SpectrumUse::Unbounded))?;
                        let k = tex.optional(p, "k", Some(SpectrumUse::Unbounded))?;
                        let cu = |n: &str| {
                            super::spectra::to_rgb(
                                &super::super::params::SpectrumValue::Named(n.into()),
                                SpectrumUse::Unbounded,
                                at,
                            )
                        };
                        (
                            eta.map_or_else(|| cu("metal-Cu-eta").map(PTex::Const), Ok)?,
                            k.map_or_else(|| cu("metal-Cu-k").map(PTex::Const), Ok)?,
                        )
                    }
                };
                let (eta, k) = (tex_of(eta)?, tex_of(k)?);
                let one = Texture::Constant(glam::Vec3::ONE);
                let m = match roughness(p, tex, "", at)? {
                    None => Material::Conductor(ConductorParams { eta, k, specular_reflectance: one }),
                    Some(roughness) => {
                        Material::RoughConductor(RoughConductorParams { roughness, eta, k, specular_reflectance: one })
                    }
                };
                (m, Sides::Front)
            }
            "dielectric" | "thindielectric" => {
                let eta = match p.type_of("eta") {
                    None => 1.5,
                    Some(super::super::params::ParamType::Float) => p.float("eta", 1.5)? as f32,
                    Some(_) => {
                        let (v, vloc) = p.spectrum("eta")?.expect("present");
                        spectrum_eta(&v, &vloc)?
                    }
                };
                if !(eta > 0.0) {
                    return Err(LoadError::at(at, format!("{kind}: eta {eta} must be positive")));
                }
                let one = || Texture::Constant(glam::Vec3::ONE);
                let m = if kind == "thindielectric" {
                    Material::ThinDielectric(ThinDielectricParams {
                        eta,
                        specular_reflectance: one(),
                        specular_transmittance: one(),
                    })
                } else {
                    match roughness(p, tex, "", at)? {
                        // An index of 1: no interface at all, rough or not.
                        _ if eta == 1.0 => Material::Null,
                        None => Material::Dielectric(DielectricParams {
                            eta,
                            specular_reflectance: one(),
                            specular_transmittance: one(),
                        }),
                        Some(roughness) => Material::RoughDielectric(RoughDielectricParams {
                            roughness,
                            eta,
                            specular_reflectance: one(),
                            specular_transmittance: one(),
                        }),
                    }
                };
                (m, Sides::Both)
            }
            "diffusetransmission" => {
                let r = tex.value(p, "reflectance", Some(SpectrumUse::Albedo), [0.25; 3])?;
                let t = tex.value(p, "transmittance", Some(SpectrumUse::Albedo), [0.25; 3])?;
                let scale = p.float("scale", 1.0)? as f32;
                let m = DiffuseTransmissionParams { reflectance: tex_of(r)?, transmittance: tex_of(t)?, scale };
                (Material::DiffuseTransmission(m), Sides::Both)
            }
            "interface" | "none" | "" => (Material::Null, Sides::Both),
            "mix" => {
                if depth > 16 {
                    return Err(LoadError::at(at, "mix materials nest more than 16 deep (a cycle?)"));
                }
                let names = p.strings("materials")?.unwrap_or_default();
                let [a, b] = names.as_slice() else {
                    return Err(LoadError::at(at, "mix needs \"string materials\" with two material names"));
                };
                let amount = tex.value(p, "amount", None, [0.5; 3])?;
                let side = |n: &str| -> Result<(Material, Sides)> {
                    let e = self.named.get(n).ok_or_else(|| {
                        LoadError::at(at, format!("mix: no material named \"{n}\" (MakeNamedMaterial) is defined"))
                    })?;
                    self.build(e, tex, depth + 1)
                };
                let ((ma, sa), (mb, sb)) = (side(a)?, side(b)?);
                if sa != sb {
                    return Err(LoadError::at(
                        at,
                        "mix of a reflective material (diffuse, conductor) with a transmissive one is not supported",
                    ));
                }
                (Material::Blend { weight: tex_of(amount)?, first: Box::new(ma), second: Box::new(mb) }, sa)
            }
            "coateddiffuse" | "coatedconductor" => {
                use penumbra_render::bsdf::layered::{
                    CoatedConductorParams, CoatedDiffuseParams, ConductorSpec, LayerParams,
                };
                // Raw roughness textures: the model applies `remaproughness` itself.
                let rough = |prefix: &str| -> Result<(Texture, Texture)> {
                    let r = tex.value(p, &format!("{prefix}roughness"), None, [0.0; 3])?;
                    let u = tex.optional(p, &format!("{prefix}uroughness"), None)?.unwrap_or_else(|| r.clone());
                    let v = tex.optional(p, &format!("{prefix}vroughness"), None)?.unwrap_or(r);
                    Ok((tex_of(u)?, tex_of(v)?))
                };
                let float_eta = |name: &str| -> Result<f32> {
                    let eta = match p.type_of(name) {
                        None => 1.5,
                        Some(super::super::params::ParamType::Float) => p.float(name, 1.5)? as f32,
                        Some(_) => {
                            let (v, vloc) = p.spectrum(name)?.expect("present");
                            spectrum_eta(&v, &vloc)?
                        }
                    };
                    if !(eta >= 0.0 && eta.is_finite()) {
                        return Err(LoadError::at(at, format!("{kind}: {name} {eta} must be finite and not negative")));
                    }
                    Ok(eta)
                };
                let max_depth = p.int("maxdepth", 10)?;
                let n_samples = p.int("nsamples", 1)?;
                if !(1..=10_000).contains(&max_depth) || !(1..=1000).contains(&n_samples) {
                    return Err(LoadError::at(
                        at,
                        format!(
                            "{kind}: maxdepth {max_depth} must lie in 1..=10000 and nsamples {n_samples} in 1..=1000"
                        ),
                    ));
                }
                let layer = LayerParams {
                    thickness: tex_of(tex.value(p, "thickness", None, [0.01; 3])?)?,
                    g: tex_of(tex.value(p, "g", None, [0.0; 3])?)?,
                    albedo: tex_of(tex.value(p, "albedo", Some(SpectrumUse::Albedo), [0.0; 3])?)?,
                    max_depth: max_depth as u32,
                    n_samples: n_samples as u32,
                    remap_roughness: p.bool("remaproughness", true)?,
                };
                let m = if kind == "coateddiffuse" {
                    let reflectance = tex_of(tex.value(p, "reflectance", Some(SpectrumUse::Albedo), [0.5; 3])?)?;
                    let (u_roughness, v_roughness) = rough("")?;
                    let eta = float_eta("eta")?;
                    Material::CoatedDiffuse(Box::new(CoatedDiffuseParams {
                        reflectance,
                        u_roughness,
                        v_roughness,
                        eta,
                        layer,
                    }))
                } else {
                    let (interface_u_roughness, interface_v_roughness) = rough("interface.")?;
                    let (conductor_u_roughness, conductor_v_roughness) = rough("conductor.")?;
                    let interface_eta = float_eta("interface.eta")?;
                    let conductor = match tex.optional(p, "reflectance", Some(SpectrumUse::Albedo))? {
                        Some(r) => {
                            if p.type_of("conductor.eta").is_some() || p.type_of("conductor.k").is_some() {
                                return Err(LoadError::at(
                                    at,
                                    "coatedconductor: give either \"reflectance\" or \"conductor.eta\" and \"conductor.k\", not both",
                                ));
                            }
                            ConductorSpec::Reflectance(tex_of(r)?)
                        }
                        None => {
                            let cu = |n: &str| {
                                super::spectra::to_rgb(
                                    &super::super::params::SpectrumValue::Named(n.into()),
                                    SpectrumUse::Unbounded,
                                    at,
                                )
                                .map(PTex::Const)
                            };
                            let eta = tex.optional(p, "conductor.eta", Some(SpectrumUse::Unbounded))?;
                            let k = tex.optional(p, "conductor.k", Some(SpectrumUse::Unbounded))?;
                            ConductorSpec::EtaK {
                                eta: tex_of(eta.map_or_else(|| cu("metal-Cu-eta"), Ok)?)?,
                                k: tex_of(k.map_or_else(|| cu("metal-Cu-k"), Ok)?)?,
                            }
                        }
                    };
                    Material::CoatedConductor(Box::new(CoatedConductorParams {
                        interface_u_roughness,
                        interface_v_roughness,
                        interface_eta,
                        conductor,
                        conductor_u_roughness,
                        conductor_v_roughness,
                        layer,
                    }))
                };
                // pbrt-v4's layered BxDFs are two-sided.
                (m, Sides::Both)
            }
            other => {
                return Err(LoadError::at(
                    at,
                    format!("material \"{other}\" is not supported; supported: {}", MATERIALS.join(", ")),
                ))
            }
        };
        p.check_unused(&format!("material \"{kind}\""))?;
        Ok(out)
    }
}
