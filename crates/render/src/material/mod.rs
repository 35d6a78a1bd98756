//! Materials: the BSDF plugins as the scene stores them, and the wrappers
//! that combine them. Each plugin's parameters live beside its model in
//! `bsdf/<plugin>.rs`; a `Material` holds them and adds what needs whole
//! materials: `twosided`, `mask`, `normalmap`, `bumpmap`, `blendbsdf` and
//! `null`. At a hit, [`Material::bsdf`] evaluates the textures, resolves the
//! wrappers and returns a plain [`Bsdf`] (pbrt-v4's Material → BSDF split);
//! a blend's nested BSDFs are resolved at the same time into the sample's
//! [`Scratch`] memory, so `Bsdf` never sees a `Material`.

pub mod blend;
pub mod bumpmap;
pub mod normalmap;

use crate::bsdf::roughplastic::TRANSMITTANCE_RES;
use crate::bsdf::{
    Blend, Bsdf, BsdfKind, BsdfParams, CoatedConductorParams, CoatedDiffuseParams, ConductorParams, DielectricParams,
    DiffuseParams, DiffuseTransmissionParams, GltfPbrParams, HairParams, MeasuredParams, MicrofacetType, Nested,
    PPlasticParams, Perturbation, PlasticParams, PrincipledParams, PrincipledThinParams, RoughConductorParams,
    RoughDielectricParams, RoughPlasticParams, ThinDielectricParams,
};
use crate::geometry::SurfaceInteraction;
use crate::math::{Frame, Spectrum};
use crate::texture::Texture;
use glam::Vec3;

/// Scratch memory for the BSDFs of one sample's hits (pbrt-v4's
/// `ScratchBuffer`): a blend's nested BSDFs are allocated here when its
/// hit is resolved. One per thread; reset between samples, once no `Bsdf`
/// of the previous sample is alive. Nothing is allocated for scenes
/// without `blendbsdf`.
#[derive(Debug, Default)]
pub struct Scratch(bumpalo::Bump);

impl Scratch {
    /// An empty scratch buffer.
    pub fn new() -> Scratch {
        Scratch::default()
    }

    /// Frees everything allocated since the last reset (keeping the memory).
    #[inline]
    pub fn reset(&mut self) {
        self.0.reset();
    }
}

/// A surface material: a Mitsuba BSDF plugin with its parameters, possibly wrapped.
#[derive(Debug, Clone)]
pub enum Material {
    /// Mitsuba `diffuse`.
    Diffuse(DiffuseParams),
    /// pbrt-v4 `diffusetransmission`.
    DiffuseTransmission(DiffuseTransmissionParams),
    /// pbrt-v4 `coateddiffuse`.
    CoatedDiffuse(Box<CoatedDiffuseParams>),
    /// pbrt-v4 `coatedconductor`.
    CoatedConductor(Box<CoatedConductorParams>),
    /// Mitsuba `dielectric`.
    Dielectric(DielectricParams),
    /// Mitsuba `thindielectric`.
    ThinDielectric(ThinDielectricParams),
    /// Mitsuba `conductor`.
    Conductor(ConductorParams),
    /// Mitsuba `roughconductor`.
    RoughConductor(RoughConductorParams),
    /// Mitsuba `roughdielectric`.
    RoughDielectric(RoughDielectricParams),
    /// Mitsuba `plastic`.
    Plastic(PlasticParams),
    /// Mitsuba `roughplastic`.
    RoughPlastic(RoughPlasticParams),
    /// Mitsuba `pplastic` (as its RGB variants render it).
    PPlastic(PPlasticParams),
    /// Mitsuba `hair`.
    Hair(Box<HairParams>),
    /// Mitsuba `measured` (RGL `.bsdf` files, RGB).
    Measured(MeasuredParams),
    /// Mitsuba `principled` (the Disney BSDF).
    Principled(Box<PrincipledParams>),
    /// Mitsuba `principledthin` (the thin-sheet Disney BSDF).
    PrincipledThin(Box<PrincipledThinParams>),
    /// glTF 2.0's metallic-roughness material.
    GltfPbr(Box<GltfPbrParams>),
    /// Mitsuba `null`: invisible to every ray (a shape that only emits).
    Null,
    /// The front material, and the one seen from the back side.
    TwoSided(Box<Material>, Box<Material>),
    /// Mitsuba `mask`: cut-out by an opacity texture.
    Mask {
        /// Opacity in [0, 1]; rays pass through the rest.
        opacity: Texture,
        /// The material where opaque.
        inner: Box<Material>,
    },
    /// Mitsuba `normalmap`: shading normals from a texture.
    NormalMap {
        /// Tangent-space normal texture.
        normals: Texture,
        /// The wrapped material.
        inner: Box<Material>,
    },
    /// Mitsuba `bumpmap`: shading normals from a height texture's gradient.
    BumpMap {
        /// Height texture.
        height: Texture,
        /// Multiplier of the height.
        scale: f32,
        /// The wrapped material.
        inner: Box<Material>,
    },
    /// Mitsuba `blendbsdf`: (1 − weight) · first + weight · second.
    Blend {
        /// Blend weight in [0, 1] of `second`.
        weight: Texture,
        /// Material weighted by 1 − weight.
        first: Box<Material>,
        /// Material weighted by weight.
        second: Box<Material>,
    },
}

/// Mitsuba's `twosided`: seen from below, the back material is shaded in a
/// frame whose normal is negated (local z ↦ −z). Flips `si.sh_frame` so and
/// returns true where wo is below it.
pub fn two_sided_frame(si: &mut SurfaceInteraction) -> bool {
    let below = si.to_local(si.wo).z < 0.0;
    if below {
        let f = si.sh_frame;
        si.sh_frame = Frame { s: f.s, t: f.t, n: -f.n };
    }
    below
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

/// A material of [`Material::lane_material`], with its constant parameters
/// (those of [`crate::bsdf::Diffuse`], [`crate::bsdf::Conductor`],
/// [`crate::bsdf::RoughConductor`] and [`crate::bsdf::Dielectric`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LaneMaterial {
    /// Lambertian: the reflectance.
    Diffuse(Spectrum),
    /// Lambertian with a reflectance texture that reads only the hit's uv
    /// ([`Texture::reads_only_uv`]).
    TexturedDiffuse,
    /// A smooth conductor.
    Conductor {
        /// Real part of the relative complex IOR.
        eta: Spectrum,
        /// Its imaginary part.
        k: Spectrum,
        /// Multiplier of the Fresnel reflectance.
        specular_reflectance: Spectrum,
    },
    /// A GGX or Beckmann rough conductor.
    RoughConductor {
        /// Roughness α along u and v (before `Microfacet`'s floor of 1e-4).
        alpha_u: f32,
        /// Along v.
        alpha_v: f32,
        /// Beckmann (else GGX).
        beckmann: bool,
        /// Real part of the relative complex IOR.
        eta: Spectrum,
        /// Its imaginary part.
        k: Spectrum,
        /// Multiplier of the Fresnel reflectance.
        specular_reflectance: Spectrum,
    },
    /// A smooth dielectric.
    Dielectric {
        /// Relative IOR.
        eta: f32,
        /// Multiplier of the Fresnel reflectance.
        specular_reflectance: Spectrum,
        /// Multiplier of the Fresnel transmittance.
        specular_transmittance: Spectrum,
    },
    /// A GGX or Beckmann rough dielectric.
    RoughDielectric {
        /// Roughness α along u and v (before `Microfacet`'s floor of 1e-4).
        alpha_u: f32,
        /// Along v.
        alpha_v: f32,
        /// Beckmann (else GGX).
        beckmann: bool,
        /// Relative IOR.
        eta: f32,
        /// Multiplier of the Fresnel reflectance.
        specular_reflectance: Spectrum,
        /// Multiplier of the Fresnel transmittance.
        specular_transmittance: Spectrum,
    },
    /// A GGX or Beckmann `roughplastic`.
    RoughPlastic {
        /// Roughness α along u and v (before `Microfacet`'s floor of 1e-4).
        alpha_u: f32,
        /// Along v.
        alpha_v: f32,
        /// Beckmann (else GGX).
        beckmann: bool,
        /// Relative IOR.
        eta: f32,
        /// The diffuse lobe's albedo after internal reflections, as
        /// `RoughPlastic::eval` finds it from the reflectance.
        diffuse: Spectrum,
        /// Tint of the specular reflection.
        specular_reflectance: Spectrum,
        /// The probability weight of the specular lobe.
        specular_sampling_weight: f32,
        /// Its transmittance table: the index of a copy of
        /// `RoughPlasticTables::external_transmittance` in the tables
        /// [`Material::lane_material`] was given.
        table: u32,
    },
    /// Smooth `plastic`.
    Plastic {
        /// Relative IOR.
        eta: f32,
        /// The diffuse albedo after internal reflections (`Plastic::diffuse`).
        diffuse: Spectrum,
        /// Tint of the specular reflection.
        specular_reflectance: Spectrum,
        /// The probability weight of the specular lobe.
        specular_sampling_weight: f32,
    },
}

/// A [`LaneMaterial`] and whether it is wrapped in `twosided` (the same
/// material on both sides: seen from below, it is shaded in a frame whose
/// normal is negated, as [`Material::bsdf`] does).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneSurface {
    /// The material on either side.
    pub material: LaneMaterial,
    /// Whether it is two-sided.
    pub two_sided: bool,
}

/// Constant roughnesses (α_u, α_v), as `Texture::eval_1` of a constant gives them.
fn constant_alphas(r: &crate::bsdf::microfacet::Roughness) -> Option<(f32, f32)> {
    let one = |t: &Texture| t.constant().map(|c| (c.x + c.y + c.z) / 3.0);
    Some((one(&r.alpha_u)?, one(&r.alpha_v)?))
}

impl LaneMaterial {
    /// The lane kernel that shades it: 0 diffuse (textured too), 1 and 6
    /// the GGX and Beckmann rough conductors, 2 the smooth conductor, 3 the
    /// smooth dielectric, 4 plastic, 5 and 7 the GGX and Beckmann rough
    /// dielectrics, 8 and 9 the GGX and Beckmann rough plastics.
    pub fn kernel(&self) -> u8 {
        match self {
            LaneMaterial::Diffuse(_) | LaneMaterial::TexturedDiffuse => 0,
            LaneMaterial::RoughConductor { beckmann: false, .. } => 1,
            LaneMaterial::Conductor { .. } => 2,
            LaneMaterial::Dielectric { .. } => 3,
            LaneMaterial::Plastic { .. } => 4,
            LaneMaterial::RoughDielectric { beckmann: false, .. } => 5,
            LaneMaterial::RoughConductor { beckmann: true, .. } => 6,
            LaneMaterial::RoughDielectric { beckmann: true, .. } => 7,
            LaneMaterial::RoughPlastic { beckmann: false, .. } => 8,
            LaneMaterial::RoughPlastic { beckmann: true, .. } => 9,
        }
    }

    /// Whether no lobe transmits (as [`crate::bsdf::Bsdf::reflects_only`]
    /// of its BSDF): all but the dielectrics.
    pub fn reflects_only(&self) -> bool {
        !matches!(self, LaneMaterial::Dielectric { .. } | LaneMaterial::RoughDielectric { .. })
    }

    /// [`crate::bsdf::Bsdf::narrower_than`] of its BSDF: a rough conductor's
    /// or dielectric's lesser roughness below `roughness`.
    pub fn narrower_than(&self, roughness: f32) -> bool {
        match *self {
            LaneMaterial::RoughConductor { alpha_u, alpha_v, .. }
            | LaneMaterial::RoughDielectric { alpha_u, alpha_v, .. } => alpha_u.min(alpha_v) < roughness,
            _ => false,
        }
    }

    /// Whether its roughness differs along u and v: its frame must follow
    /// the surface's uv parameterisation.
    pub fn anisotropic(&self) -> bool {
        match *self {
            LaneMaterial::RoughConductor { alpha_u, alpha_v, .. }
            | LaneMaterial::RoughDielectric { alpha_u, alpha_v, .. }
            | LaneMaterial::RoughPlastic { alpha_u, alpha_v, .. } => alpha_u != alpha_v,
            _ => false,
        }
    }
}

impl Material {
    /// The BSDF at a hit. Wrappers may replace `si.sh_frame` (a flipped
    /// frame on the back of `twosided`, a perturbed one for normal and
    /// bump maps); integrators must use the frame after this call. A
    /// blend's nested BSDFs are allocated in `scratch`.
    pub fn bsdf<'a>(&'a self, si: &mut SurfaceInteraction, scratch: &'a Scratch) -> Bsdf<'a> {
        let mut m = self;
        let mut opacity = 1.0f32;
        let mut perturbation = None;
        loop {
            let kind = match m {
                Material::TwoSided(front, back) => {
                    m = if two_sided_frame(si) { back } else { front };
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
                Material::Diffuse(p) => BsdfKind::Diffuse(p.at(si)),
                Material::DiffuseTransmission(p) => BsdfKind::DiffuseTransmission(p.at(si)),
                Material::CoatedDiffuse(p) => BsdfKind::CoatedDiffuse(p.at(si)),
                Material::CoatedConductor(p) => BsdfKind::CoatedConductor(p.at(si)),
                Material::Dielectric(p) => BsdfKind::Dielectric(p.at(si)),
                Material::ThinDielectric(p) => BsdfKind::ThinDielectric(p.at(si)),
                Material::Conductor(p) => BsdfKind::Conductor(p.at(si)),
                Material::RoughConductor(p) => BsdfKind::RoughConductor(p.at(si)),
                Material::RoughDielectric(p) => BsdfKind::RoughDielectric(p.at(si)),
                Material::Plastic(p) => BsdfKind::Plastic(p.at(si)),
                Material::RoughPlastic(p) => BsdfKind::RoughPlastic(p.at(si)),
                Material::PPlastic(p) => BsdfKind::PPlastic(p.at(si)),
                Material::Hair(p) => BsdfKind::Hair(p.at(si)),
                Material::Measured(p) => BsdfKind::Measured(p.at(si)),
                Material::Principled(p) => BsdfKind::Principled(p.at(si)),
                Material::PrincipledThin(p) => BsdfKind::PrincipledThin(p.at(si)),
                Material::GltfPbr(p) => BsdfKind::GltfPbr(p.at(si)),
                Material::Null => BsdfKind::Null,
                Material::Blend { weight, first, second } => {
                    let weight = weight.eval_1(si).clamp(0.0, 1.0);
                    // Each nested material resolved at a copy of the hit,
                    // in the frame it chooses.
                    let nested = |m: &'a Material| -> &'a Nested<'a> {
                        let mut nsi = *si;
                        let bsdf = m.bsdf(&mut nsi, scratch);
                        scratch.0.alloc(Nested::new(bsdf, si.sh_frame, nsi.sh_frame))
                    };
                    BsdfKind::Blend(Blend { weight, first: nested(first), second: nested(second) })
                }
            };
            return Bsdf { kind, opacity, perturbation };
        }
    }

    /// The material as the `path` integrator's lane vertex shades it: a
    /// plain `diffuse` (its reflectance constant or read from uv alone), `conductor`, `roughconductor`,
    /// `dielectric`, `roughdielectric`, `plastic` or `roughplastic` whose parameters are constants (no
    /// texture, mask, bump or normal map), or `twosided` around one such
    /// material of constant parameters on both sides. A
    /// `roughplastic`'s transmittance table is appended to `tables`.
    pub fn lane_material(&self, tables: &mut Vec<[f32; TRANSMITTANCE_RES]>) -> Option<LaneSurface> {
        if let Material::TwoSided(front, back) = self {
            let n = tables.len();
            let (f, m) = (front.lane_material(tables), tables.len());
            let b = back.lane_material(tables);
            // A rough plastic's table is appended once per side: the sides
            // are the same when their tables are.
            let same = match (f, b) {
                (Some(f), Some(b)) => {
                    let untabled = |mut m: LaneMaterial| {
                        if let LaneMaterial::RoughPlastic { table, .. } = &mut m {
                            *table = 0;
                        }
                        m
                    };
                    !f.two_sided
                        && !b.two_sided
                        && f.material != LaneMaterial::TexturedDiffuse
                        && untabled(f.material) == untabled(b.material)
                        && tables[n..m] == tables[m..]
                }
                _ => false,
            };
            tables.truncate(if same { m } else { n });
            return f.filter(|_| same).map(|f| LaneSurface { two_sided: true, ..f });
        }
        let material = self.lane_material_one_sided(tables)?;
        Some(LaneSurface { material, two_sided: false })
    }

    /// [`Self::lane_material`] of a material that is not `twosided`.
    fn lane_material_one_sided(&self, tables: &mut Vec<[f32; TRANSMITTANCE_RES]>) -> Option<LaneMaterial> {
        match self {
            Material::Diffuse(d) => match d.reflectance.constant() {
                Some(c) => Some(LaneMaterial::Diffuse(c)),
                None => d.reflectance.reads_only_uv().then_some(LaneMaterial::TexturedDiffuse),
            },
            Material::Conductor(c) => Some(LaneMaterial::Conductor {
                eta: c.eta.constant()?,
                k: c.k.constant()?,
                specular_reflectance: c.specular_reflectance.constant()?,
            }),
            Material::RoughConductor(c) => {
                let (alpha_u, alpha_v) = constant_alphas(&c.roughness)?;
                Some(LaneMaterial::RoughConductor {
                    alpha_u,
                    alpha_v,
                    beckmann: matches!(c.roughness.kind, MicrofacetType::Beckmann),
                    eta: c.eta.constant()?,
                    k: c.k.constant()?,
                    specular_reflectance: c.specular_reflectance.constant()?,
                })
            }
            Material::RoughDielectric(d) => {
                let (alpha_u, alpha_v) = constant_alphas(&d.roughness)?;
                Some(LaneMaterial::RoughDielectric {
                    alpha_u,
                    alpha_v,
                    beckmann: matches!(d.roughness.kind, MicrofacetType::Beckmann),
                    eta: d.eta,
                    specular_reflectance: d.specular_reflectance.constant()?,
                    specular_transmittance: d.specular_transmittance.constant()?,
                })
            }
            Material::Plastic(p) => {
                let model = crate::bsdf::plastic::Plastic {
                    eta: p.eta,
                    diffuse_reflectance: p.diffuse_reflectance.constant()?,
                    specular_reflectance: p.specular_reflectance.constant()?,
                    nonlinear: p.nonlinear,
                    fdr_int: p.fdr_int,
                    specular_sampling_weight: p.specular_sampling_weight,
                };
                Some(LaneMaterial::Plastic {
                    eta: model.eta,
                    diffuse: model.diffuse(),
                    specular_reflectance: model.specular_reflectance,
                    specular_sampling_weight: model.specular_sampling_weight,
                })
            }
            Material::RoughPlastic(p) => {
                let rho = p.diffuse_reflectance.constant()?;
                let f_int = p.tables.internal_reflectance;
                // RoughPlastic::eval's diffuse albedo, the same operations.
                let diffuse = if p.nonlinear { rho / (Spectrum::ONE - rho * f_int) } else { rho / (1.0 - f_int) };
                let lane = LaneMaterial::RoughPlastic {
                    alpha_u: p.distr.alpha_u,
                    alpha_v: p.distr.alpha_v,
                    beckmann: matches!(p.distr.kind, MicrofacetType::Beckmann),
                    eta: p.eta,
                    diffuse,
                    specular_reflectance: p.specular_reflectance.constant()?,
                    specular_sampling_weight: p.specular_sampling_weight,
                    table: u32::try_from(tables.len()).ok()?,
                };
                tables.push(p.tables.external_transmittance[..].try_into().ok()?);
                Some(lane)
            }
            Material::Dielectric(d) => Some(LaneMaterial::Dielectric {
                eta: d.eta,
                specular_reflectance: d.specular_reflectance.constant()?,
                specular_transmittance: d.specular_transmittance.constant()?,
            }),
            _ => None,
        }
    }

    /// Whether the BSDF reads the hit's surface parameterisation: `uv`,
    /// `dpdu`, `dpdv`, or the orientation of `sh_frame` about the normal
    /// (textures, normal and bump maps, anisotropy). When false, hits skip
    /// computing them (see [`crate::geometry::Shape::interaction_with`]).
    /// Conservative: unknown cases answer true.
    pub fn reads_uv(&self) -> bool {
        match self {
            Material::Diffuse(p) => p.reads_uv(),
            Material::DiffuseTransmission(p) => p.reads_uv(),
            Material::CoatedDiffuse(p) => p.reads_uv(),
            Material::CoatedConductor(p) => p.reads_uv(),
            Material::Dielectric(p) => p.reads_uv(),
            Material::ThinDielectric(p) => p.reads_uv(),
            Material::Conductor(p) => p.reads_uv(),
            Material::RoughConductor(p) => p.reads_uv(),
            Material::RoughDielectric(p) => p.reads_uv(),
            Material::Plastic(p) => p.reads_uv(),
            Material::RoughPlastic(p) => p.reads_uv(),
            Material::PPlastic(p) => p.reads_uv(),
            Material::Hair(p) => p.reads_uv(),
            Material::Measured(p) => p.reads_uv(),
            Material::Principled(p) => p.reads_uv(),
            Material::PrincipledThin(p) => p.reads_uv(),
            Material::GltfPbr(p) => p.reads_uv(),
            Material::Null => false,
            Material::TwoSided(front, back) => front.reads_uv() || back.reads_uv(),
            Material::Mask { opacity, inner } => opacity.constant().is_none() || inner.reads_uv(),
            Material::Blend { weight, first, second } => {
                weight.constant().is_none() || first.reads_uv() || second.reads_uv()
            }
            Material::NormalMap { .. } | Material::BumpMap { .. } => true,
        }
    }

    /// Mitsuba's `eval_diffuse_reflectance` (what its `aov` integrator's
    /// `albedo` reports): the diffuse reflectance texture of `diffuse`,
    /// `plastic`, `roughplastic`, the base colour of `principled` and
    /// `principledthin`; the side's material of `twosided`; the wrapped
    /// material of `mask`, `normalmap`, `bumpmap` (unperturbed); the blend of
    /// `blendbsdf`'s two; for every other BSDF π f(wo, n), the BSDF evaluated
    /// towards the shading normal (0 for smooth conductors and dielectrics).
    pub fn diffuse_reflectance(&self, si: &SurfaceInteraction, scratch: &Scratch) -> crate::math::Spectrum {
        match self {
            Material::Diffuse(p) => p.reflectance.eval(si),
            Material::Plastic(p) => p.diffuse_reflectance.eval(si),
            Material::RoughPlastic(p) => p.diffuse_reflectance.eval(si),
            Material::Principled(p) => p.base_color.eval(si),
            Material::PrincipledThin(p) => p.base_color.eval(si),
            Material::GltfPbr(p) => p.at(si).base_color,
            Material::TwoSided(front, back) => {
                if si.to_local(si.wo).z >= 0.0 {
                    front.diffuse_reflectance(si, scratch)
                } else {
                    let mut b = *si;
                    b.sh_frame = Frame { s: si.sh_frame.s, t: si.sh_frame.t, n: -si.sh_frame.n };
                    back.diffuse_reflectance(&b, scratch)
                }
            }
            Material::Mask { inner, .. } | Material::NormalMap { inner, .. } | Material::BumpMap { inner, .. } => {
                inner.diffuse_reflectance(si, scratch)
            }
            Material::Blend { weight, first, second } => {
                let w = weight.eval_1(si).clamp(0.0, 1.0);
                first.diffuse_reflectance(si, scratch) * (1.0 - w) + second.diffuse_reflectance(si, scratch) * w
            }
            _ => {
                let mut s = *si;
                let bsdf = self.bsdf(&mut s, scratch);
                bsdf.eval(s.to_local(s.wo), Vec3::Z) * crate::math::PI
            }
        }
    }

    /// The shading frame Mitsuba's `BSDF::sh_frame` reports (its `aov`
    /// integrator's `sh_normal`): perturbed by a `normalmap` or `bumpmap`
    /// at the top of the material, else the hit's own (no `twosided` flip).
    pub fn sh_frame(&self, si: &SurfaceInteraction) -> Frame {
        let mut s = *si;
        match self {
            Material::NormalMap { normals, .. } => {
                let rel = normalmap::relative_frame(si, normals.eval(si));
                perturb(&mut s, rel);
            }
            Material::BumpMap { height, scale, .. } => {
                if let Some(rel) = bumpmap::relative_frame(si, height, *scale) {
                    perturb(&mut s, rel);
                }
            }
            _ => {}
        }
        s.sh_frame
    }

    /// Whether `leaf` holds for any of the materials this one is made of:
    /// itself, or those inside a two-sided, normal- or bump-mapped material
    /// or a blend (which have no lobes of their own).
    fn any_part(&self, leaf: &impl Fn(&Material) -> bool) -> bool {
        match self {
            Material::TwoSided(front, back) => front.any_part(leaf) || back.any_part(leaf),
            Material::NormalMap { inner, .. } | Material::BumpMap { inner, .. } => inner.any_part(leaf),
            Material::Blend { first, second, .. } => first.any_part(leaf) || second.any_part(leaf),
            m => leaf(m),
        }
    }

    /// Whether the BSDF has a pass-through lobe (Mitsuba's `BSDFFlags::Null`):
    /// `null`, `mask`, `thindielectric`, or a wrapper or blend of one.
    pub fn has_null_lobe(&self) -> bool {
        self.any_part(&|m| matches!(m, Material::Null | Material::Mask { .. } | Material::ThinDielectric(_)))
    }

    /// Whether its BSDF may have a delta lobe (a smooth interface or
    /// mirror, a specular coat, a mask's pass-through): false only for
    /// the materials whose lobes are all non-delta. Light paths for the
    /// caustics aim at the shapes for which this holds.
    pub fn may_be_delta(&self) -> bool {
        self.any_part(&|m| {
            !matches!(
                m,
                Material::Diffuse(_)
                    | Material::DiffuseTransmission(_)
                    | Material::RoughConductor(_)
                    | Material::RoughDielectric(_)
                    | Material::RoughPlastic(_)
                    | Material::PPlastic(_)
                    | Material::Hair(_)
                    | Material::Measured(_)
                    | Material::Principled(_)
                    | Material::PrincipledThin(_)
                    | Material::GltfPbr(_)
            )
        })
    }

    /// Whether light paths carry the caustics of its delta lobes (see
    /// `integrator::path::caustics`): those that [`Self::may_be_delta`] finds,
    /// but a specular coat over a diffuse base (`plastic`, `coateddiffuse`),
    /// whose faint caustics camera paths find well enough: light paths aimed
    /// at them cost time and bought nothing (rough_spheres, see the README).
    pub fn carries_caustics(&self) -> bool {
        self.any_part(&|m| !matches!(m, Material::Plastic(_) | Material::CoatedDiffuse(_)) && m.may_be_delta())
    }

    /// Whether a hit on this material can scatter light at all (false for
    /// `null`, which rays pass through).
    pub fn is_null(&self) -> bool {
        matches!(self, Material::Null)
    }
}
