//! Materials: Mitsuba's BSDF plugins as the scene stores them, with
//! parameters that may be textures. At a hit, [`Material::bsdf`] evaluates
//! the textures, resolves the wrappers (`twosided`, `mask`, `normalmap`,
//! `bumpmap`) and returns a plain [`Bsdf`] (pbrt-v4's Material → BSDF split).

pub mod blend;
pub mod bumpmap;
pub mod normalmap;
pub mod principled;

use crate::bsdf::{
    Bsdf, BsdfKind, Conductor, Dielectric, Diffuse, Microfacet, MicrofacetType, Perturbation, Plastic, RoughConductor,
    RoughDielectric, RoughPlastic, RoughPlasticTables, ThinDielectric,
};
use crate::geometry::SurfaceInteraction;
use crate::math::Frame;
use crate::texture::Texture;
use glam::Vec3;

/// Parameters shared by `roughconductor` and `roughdielectric`: a
/// distribution with (possibly textured) roughness along s and t.
#[derive(Debug, Clone)]
pub struct Roughness {
    pub kind: MicrofacetType,
    pub alpha_u: Texture,
    pub alpha_v: Texture,
}

impl Roughness {
    #[inline]
    fn eval(&self, si: &SurfaceInteraction) -> Microfacet {
        // Microfacet keeps the roughness positive (its `alphas` clamp).
        Microfacet { kind: self.kind, alpha_u: self.alpha_u.eval_1(si), alpha_v: self.alpha_v.eval_1(si) }
    }
}

#[derive(Debug, Clone)]
pub enum Material {
    Diffuse {
        reflectance: Texture,
    },
    Dielectric {
        eta: f32,
        specular_reflectance: Texture,
        specular_transmittance: Texture,
    },
    ThinDielectric {
        eta: f32,
        specular_reflectance: Texture,
        specular_transmittance: Texture,
    },
    Conductor {
        eta: Texture,
        k: Texture,
        specular_reflectance: Texture,
    },
    RoughConductor {
        roughness: Roughness,
        eta: Texture,
        k: Texture,
        specular_reflectance: Texture,
    },
    RoughDielectric {
        roughness: Roughness,
        eta: f32,
        specular_reflectance: Texture,
        specular_transmittance: Texture,
    },
    Plastic {
        eta: f32,
        diffuse_reflectance: Texture,
        specular_reflectance: Texture,
        nonlinear: bool,
        fdr_int: f32,
        specular_sampling_weight: f32,
    },
    RoughPlastic {
        distr: Microfacet,
        eta: f32,
        diffuse_reflectance: Texture,
        specular_reflectance: Texture,
        nonlinear: bool,
        specular_sampling_weight: f32,
        tables: RoughPlasticTables,
    },
    /// Mitsuba `principled` (the Disney BSDF).
    Principled(Box<principled::PrincipledMaterial>),
    /// Mitsuba `principledthin` (the thin-sheet Disney BSDF).
    PrincipledThin(Box<principled::PrincipledThinMaterial>),
    /// Mitsuba `null`: invisible to every ray (a shape that only emits).
    Null,
    /// The front material, and the one seen from the back side.
    TwoSided(Box<Material>, Box<Material>),
    Mask {
        opacity: Texture,
        inner: Box<Material>,
    },
    NormalMap {
        normals: Texture,
        inner: Box<Material>,
    },
    BumpMap {
        height: Texture,
        scale: f32,
        inner: Box<Material>,
    },
    /// Mitsuba `blendbsdf`: (1 − weight) · first + weight · second.
    Blend {
        weight: Texture,
        first: Box<Material>,
        second: Box<Material>,
    },
}

/// Replaces `si.sh_frame` by the perturbed frame `rel` (given relative to
/// it) and returns the terms Mitsuba's normal/bump-map wrappers add; `None`
/// (frame unchanged) for a degenerate frame.
fn perturb(si: &mut SurfaceInteraction, rel: Frame) -> Option<Perturbation> {
    if !(rel.n.is_finite() && rel.s.is_finite() && rel.t.is_finite()) {
        return None;
    }
    let f = si.sh_frame;
    si.sh_frame = Frame { s: f.to_world(rel.s), t: f.to_world(rel.t), n: f.to_world(rel.n) };
    let c2 = rel.n.z * rel.n.z;
    let tan2 = (1.0 - c2).max(0.0) / c2;
    Some(Perturbation { n_orig: Vec3::new(rel.s.z, rel.t.z, rel.n.z), alpha2: (0.125 * tan2).min(1.0) })
}

impl Material {
    /// The BSDF at a hit. Wrappers may replace `si.sh_frame` (a flipped
    /// frame on the back of `twosided`, a perturbed one for normal and
    /// bump maps); integrators must use the frame after this call.
    pub fn bsdf<'a>(&'a self, si: &mut SurfaceInteraction) -> Bsdf<'a> {
        let mut m = self;
        let mut opacity = 1.0f32;
        let mut perturbation = None;
        loop {
            let kind = match m {
                Material::TwoSided(front, back) => {
                    // Mitsuba's twosided: seen from below, the back material in
                    // a frame whose normal is negated (local z ↦ −z).
                    if si.to_local(si.wo).z < 0.0 {
                        let f = si.sh_frame;
                        si.sh_frame = Frame { s: f.s, t: f.t, n: -f.n };
                        m = back;
                    } else {
                        m = front;
                    }
                    continue;
                }
                Material::Mask { opacity: o, inner } => {
                    opacity *= o.eval_1(si).clamp(0.0, 1.0);
                    m = inner;
                    continue;
                }
                Material::NormalMap { normals, inner } => {
                    let rel = normalmap::relative_frame(si, normals.eval(si));
                    perturbation = perturb(si, rel).or(perturbation);
                    m = inner;
                    continue;
                }
                Material::BumpMap { height, scale, inner } => {
                    if let Some(rel) = bumpmap::relative_frame(si, height, *scale) {
                        perturbation = perturb(si, rel).or(perturbation);
                    }
                    m = inner;
                    continue;
                }
                Material::Diffuse { reflectance } => BsdfKind::Diffuse(Diffuse { reflectance: reflectance.eval(si) }),
                Material::Dielectric { eta, specular_reflectance, specular_transmittance } => {
                    BsdfKind::Dielectric(Dielectric {
                        eta: *eta,
                        specular_reflectance: specular_reflectance.eval(si),
                        specular_transmittance: specular_transmittance.eval(si),
                    })
                }
                Material::ThinDielectric { eta, specular_reflectance, specular_transmittance } => {
                    BsdfKind::ThinDielectric(ThinDielectric {
                        eta: *eta,
                        specular_reflectance: specular_reflectance.eval(si),
                        specular_transmittance: specular_transmittance.eval(si),
                    })
                }
                Material::Conductor { eta, k, specular_reflectance } => BsdfKind::Conductor(Conductor {
                    eta: eta.eval(si),
                    k: k.eval(si),
                    specular_reflectance: specular_reflectance.eval(si),
                }),
                Material::RoughConductor { roughness, eta, k, specular_reflectance } => {
                    BsdfKind::RoughConductor(RoughConductor {
                        distr: roughness.eval(si),
                        eta: eta.eval(si),
                        k: k.eval(si),
                        specular_reflectance: specular_reflectance.eval(si),
                    })
                }
                Material::RoughDielectric { roughness, eta, specular_reflectance, specular_transmittance } => {
                    BsdfKind::RoughDielectric(RoughDielectric {
                        distr: roughness.eval(si),
                        eta: *eta,
                        specular_reflectance: specular_reflectance.eval(si),
                        specular_transmittance: specular_transmittance.eval(si),
                    })
                }
                Material::Plastic {
                    eta,
                    diffuse_reflectance,
                    specular_reflectance,
                    nonlinear,
                    fdr_int,
                    specular_sampling_weight,
                } => BsdfKind::Plastic(Plastic {
                    eta: *eta,
                    diffuse_reflectance: diffuse_reflectance.eval(si),
                    specular_reflectance: specular_reflectance.eval(si),
                    nonlinear: *nonlinear,
                    fdr_int: *fdr_int,
                    specular_sampling_weight: *specular_sampling_weight,
                }),
                Material::RoughPlastic {
                    distr,
                    eta,
                    diffuse_reflectance,
                    specular_reflectance,
                    nonlinear,
                    specular_sampling_weight,
                    tables,
                } => BsdfKind::RoughPlastic(RoughPlastic {
                    distr: *distr,
                    eta: *eta,
                    diffuse_reflectance: diffuse_reflectance.eval(si),
                    specular_reflectance: specular_reflectance.eval(si),
                    nonlinear: *nonlinear,
                    specular_sampling_weight: *specular_sampling_weight,
                    tables,
                }),
                Material::Principled(p) => BsdfKind::Principled(p.eval(si)),
                Material::PrincipledThin(p) => BsdfKind::PrincipledThin(p.eval(si)),
                Material::Null => BsdfKind::Null,
                Material::Blend { weight, first, second } => {
                    BsdfKind::Blend(blend::Blend { weight: weight.eval_1(si).clamp(0.0, 1.0), first, second, si: *si })
                }
            };
            return Bsdf { kind, opacity, perturbation };
        }
    }

    /// Whether the BSDF reads the hit's surface parameterisation: `uv`,
    /// `dpdu`, `dpdv`, or the orientation of `sh_frame` about the normal
    /// (textures, normal and bump maps, anisotropy). When false, hits skip
    /// computing them (see [`crate::geometry::Shape::interaction_with`]).
    /// Conservative: unknown cases answer true.
    pub fn reads_uv(&self) -> bool {
        let tex = |ts: &[&Texture]| ts.iter().any(|t| t.constant().is_none());
        let rough = |r: &Roughness| match (r.alpha_u.constant(), r.alpha_v.constant()) {
            (Some(u), Some(v)) => u != v,
            _ => true,
        };
        match self {
            Material::Diffuse { reflectance } => tex(&[reflectance]),
            Material::Dielectric { specular_reflectance, specular_transmittance, .. }
            | Material::ThinDielectric { specular_reflectance, specular_transmittance, .. } => {
                tex(&[specular_reflectance, specular_transmittance])
            }
            Material::Conductor { eta, k, specular_reflectance } => tex(&[eta, k, specular_reflectance]),
            Material::RoughConductor { roughness, eta, k, specular_reflectance } => {
                rough(roughness) || tex(&[eta, k, specular_reflectance])
            }
            Material::RoughDielectric { roughness, specular_reflectance, specular_transmittance, .. } => {
                rough(roughness) || tex(&[specular_reflectance, specular_transmittance])
            }
            Material::Plastic { diffuse_reflectance, specular_reflectance, .. } => {
                tex(&[diffuse_reflectance, specular_reflectance])
            }
            Material::RoughPlastic { distr, diffuse_reflectance, specular_reflectance, .. } => {
                distr.alpha_u != distr.alpha_v || tex(&[diffuse_reflectance, specular_reflectance])
            }
            Material::Null => false,
            Material::TwoSided(front, back) => front.reads_uv() || back.reads_uv(),
            Material::Mask { opacity, inner } => tex(&[opacity]) || inner.reads_uv(),
            Material::Blend { weight, first, second } => tex(&[weight]) || first.reads_uv() || second.reads_uv(),
            Material::Principled(_)
            | Material::PrincipledThin(_)
            | Material::NormalMap { .. }
            | Material::BumpMap { .. } => true,
        }
    }

    /// Whether a hit on this material can scatter light at all (false for
    /// `null`, which rays pass through).
    pub fn is_null(&self) -> bool {
        matches!(self, Material::Null)
    }
}
