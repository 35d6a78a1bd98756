//! BSDFs: the scattering functions an integrator evaluates and samples at a
//! hit. Each plugin's file holds both of its forms: the parameters as the
//! scene stores them (constants or textures, `XxxParams`, see
//! [`BsdfParams`]) and the per-hit model they evaluate to with
//! [`BsdfParams::at`] (pbrt-v4's Material → BSDF split). A
//! [`crate::material::Material`] adds the wrappers (`twosided`, `mask`,
//! normal and bump maps, `blendbsdf`) and produces one [`Bsdf`] per hit.
//!
//! Contract (see CONVENTIONS.md), in the local shading frame (normal = +z):
//! - `wo` points towards the camera side, `wi` is the light / sampled direction.
//! - [`Bsdf::eval`] returns f(wo, wi) *without* the cosine; integrators
//!   multiply by |cos θ_i|. Delta lobes evaluate to zero.
//! - [`Bsdf::pdf`] is a density per unit solid angle of `wi`; 0 for delta lobes.
//! - [`BsdfSample::weight`] is f · |cos θ_i| / pdf (the discrete probability
//!   for delta lobes), ready to multiply into the path throughput.
//! - BSDFs are one-sided like Mitsuba's (black when `wo.z <= 0`) except
//!   dielectrics; `twosided` is resolved by the material (it flips the frame).

pub mod blend;
pub mod conductor;
pub mod dielectric;
pub mod difftrans;
pub mod diffuse;
pub mod fresnel;
pub mod gltf_pbr;
pub mod hair;
pub mod layered;
pub mod measured;
pub mod microfacet;
pub mod plastic;
pub mod pplastic;
pub mod presets;
pub mod principled;
pub mod principledthin;
pub mod roughconductor;
pub mod roughdielectric;
pub mod roughplastic;
pub mod thindielectric;

pub use blend::{Blend, Nested};
pub use conductor::{Conductor, ConductorParams};
pub use dielectric::{Dielectric, DielectricParams};
pub use difftrans::{DiffuseTransmission, DiffuseTransmissionParams};
pub use diffuse::{Diffuse, DiffuseParams};
pub use gltf_pbr::{GltfPbr, GltfPbrParams};
pub use hair::{Hair, HairAbsorption, HairLobes, HairParams};
pub use layered::{CoatedConductor, CoatedConductorParams, CoatedDiffuse, CoatedDiffuseParams};
pub use measured::{Measured, MeasuredParams};
pub use microfacet::{Microfacet, MicrofacetType, Roughness};
pub use plastic::{Plastic, PlasticParams};
pub use pplastic::{PPlastic, PPlasticParams};
pub use principled::{Principled, PrincipledParams};
pub use principledthin::{PrincipledThin, PrincipledThinParams};
pub use roughconductor::{RoughConductor, RoughConductorParams};
pub use roughdielectric::{RoughDielectric, RoughDielectricParams};
pub use roughplastic::{RoughPlastic, RoughPlasticParams, RoughPlasticTables};
pub use thindielectric::{ThinDielectric, ThinDielectricParams};

use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// The per-hit model of a BSDF plugin, in the local shading frame
/// (normal = +z), with the contract above. Delta-only models keep the
/// default `eval` and `pdf` (zero).
pub trait BsdfModel {
    /// Whether any lobe is non-delta, i.e. light sampling can help.
    fn has_smooth(&self) -> bool;

    /// f(wo, wi) without the cosine.
    #[inline]
    fn eval(&self, _wo: Vec3, _wi: Vec3) -> Spectrum {
        Spectrum::ZERO
    }

    /// The density of `sample` per unit solid angle of `wi`.
    #[inline]
    fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    /// Samples `wi` given `wo`: `u` picks a lobe, `u2` the direction.
    fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample>;
}

/// Runs `$e` with `$b` bound to the model of every plugin variant of a
/// [`BsdfKind`], and `$null` for `null`: the one list of models the
/// dispatch of [`Bsdf`] goes through.
macro_rules! with_model {
    ($kind:expr, $b:ident => $e:expr, null => $null:expr) => {
        match $kind {
            BsdfKind::Diffuse($b) => $e,
            BsdfKind::DiffuseTransmission($b) => $e,
            BsdfKind::CoatedDiffuse($b) => $e,
            BsdfKind::CoatedConductor($b) => $e,
            BsdfKind::Dielectric($b) => $e,
            BsdfKind::ThinDielectric($b) => $e,
            BsdfKind::Conductor($b) => $e,
            BsdfKind::RoughConductor($b) => $e,
            BsdfKind::RoughDielectric($b) => $e,
            BsdfKind::Plastic($b) => $e,
            BsdfKind::RoughPlastic($b) => $e,
            BsdfKind::PPlastic($b) => $e,
            BsdfKind::Hair($b) => $e,
            BsdfKind::Measured($b) => $e,
            BsdfKind::Principled($b) => $e,
            BsdfKind::PrincipledThin($b) => $e,
            BsdfKind::GltfPbr($b) => $e,
            BsdfKind::Blend($b) => $e,
            BsdfKind::Null => $null,
        }
    };
}

/// A BSDF plugin as the scene stores it: its parameters, any of which may
/// be a texture. Implemented by each plugin's `XxxParams` beside its model.
pub trait BsdfParams {
    /// The per-hit model, every parameter evaluated.
    type Model<'a>
    where
        Self: 'a;

    /// The model with every parameter evaluated at `si`.
    fn at<'a>(&'a self, si: &SurfaceInteraction) -> Self::Model<'a>;

    /// Every texture the plugin reads.
    fn textures(&self) -> Vec<&Texture>;

    /// Whether the model depends on the orientation of the shading frame
    /// about the normal with every texture constant (anisotropic roughness).
    fn anisotropic(&self) -> bool {
        false
    }

    /// Whether the model reads the hit's surface parameterisation (`uv`,
    /// `dpdu`, `dpdv`, or the orientation of the shading frame about the
    /// normal): when it is anisotropic or a texture varies.
    fn reads_uv(&self) -> bool {
        self.anisotropic() || self.textures().iter().any(|t| t.constant().is_none())
    }
}

/// A sampled direction with its weight.
/// `v` with the sign of `s` (+ for s = 0), as Dr.Jit's `mulsign`.
/// Written as a multiplication: with rustc 1.95 in release builds,
/// `if s < 0.0 { -v } else { v }` (or with `is_sign_negative`) came back
/// with the caller's vector negated in two BSDFs; each time the test
/// `weights_are_eval_cos_over_pdf` caught it. Keep this the one copy.
#[inline]
pub(crate) fn mulsign(v: Vec3, s: f32) -> Vec3 {
    let k = if s < 0.0 { -1.0 } else { 1.0 };
    Vec3::new(v.x * k, v.y * k, v.z * k)
}

/// A direction sampled from a BSDF, with its density and weight.
#[derive(Debug, Clone, Copy)]
pub struct BsdfSample {
    /// Sampled incident direction, local to the shading frame.
    pub wi: Vec3,
    /// Solid-angle density, or the lobe's discrete probability when `delta`.
    pub pdf: f32,
    /// f · |cos θ_i| / pdf.
    pub weight: Spectrum,
    /// Sampled from a Dirac delta lobe (MIS does not apply).
    pub delta: bool,
    /// Passed straight through, unchanged (Mitsuba's `BSDFFlags::Null`:
    /// `null`, a mask's cut-out, `thindielectric`'s transmission): not a
    /// scattering event for the volumetric path tracer, which crosses such
    /// surfaces without counting depth.
    pub null: bool,
    /// Relative IOR crossed (1 for reflection), for Russian roulette.
    pub eta: f32,
}

/// One scattering model with its parameters evaluated at a hit.
#[derive(Debug, Clone, Copy)]
pub enum BsdfKind<'a> {
    /// Mitsuba `diffuse`.
    Diffuse(Diffuse),
    /// pbrt-v4 `diffusetransmission`.
    DiffuseTransmission(DiffuseTransmission),
    /// pbrt-v4 `coateddiffuse`.
    CoatedDiffuse(CoatedDiffuse),
    /// pbrt-v4 `coatedconductor`.
    CoatedConductor(CoatedConductor),
    /// Mitsuba `dielectric`.
    Dielectric(Dielectric),
    /// Mitsuba `thindielectric`.
    ThinDielectric(ThinDielectric),
    /// Mitsuba `conductor`.
    Conductor(Conductor),
    /// Mitsuba `roughconductor`.
    RoughConductor(RoughConductor),
    /// Mitsuba `roughdielectric`.
    RoughDielectric(RoughDielectric),
    /// Mitsuba `plastic`.
    Plastic(Plastic),
    /// Mitsuba `roughplastic`.
    RoughPlastic(RoughPlastic<'a>),
    /// Mitsuba `pplastic` (as its RGB variants render it).
    PPlastic(PPlastic),
    /// Mitsuba `hair`.
    Hair(Hair<'a>),
    /// Mitsuba `measured` (RGL `.bsdf` files, RGB).
    Measured(&'a Measured),
    /// Mitsuba `principled`.
    Principled(Principled),
    /// Mitsuba `principledthin`.
    PrincipledThin(PrincipledThin),
    /// glTF 2.0's metallic-roughness material (its specification's Appendix B).
    GltfPbr(GltfPbr),
    /// Mitsuba `null`: light passes straight through.
    Null,
    /// Mitsuba `blendbsdf`: two nested BSDFs, resolved with the hit.
    Blend(Blend<'a>),
}

/// The BSDF at a hit: a model and Mitsuba `mask`'s opacity (1 when unmasked).
/// With probability 1 − opacity a ray passes straight through (a delta
/// "null" lobe); eval and pdf of the model scale by the opacity.
#[derive(Debug, Clone, Copy)]
pub struct Bsdf<'a> {
    /// The scattering model.
    pub kind: BsdfKind<'a>,
    /// Mitsuba `mask` opacity in [0, 1] (1 when unmasked).
    pub opacity: f32,
    /// Set by `normalmap` / `bumpmap`: the model is evaluated in the
    /// perturbed shading frame, and Mitsuba's wrappers add two terms.
    pub perturbation: Option<Perturbation>,
}

/// What Mitsuba 3.9.1's `normalmap` and `bumpmap` add to the nested BSDF:
/// a direction on different sides of the unperturbed and the perturbed
/// shading frames gets nothing, and values and sample weights are scaled by
/// the shadow-terminator term of Estevez et al. 2019
/// (`use_shadowing_function`, on by default).
#[derive(Debug, Clone, Copy)]
pub struct Perturbation {
    /// The unperturbed shading normal in the perturbed frame's local coordinates.
    pub n_orig: Vec3,
    /// The terminator's α² = min(tan²θ(perturbed normal) / 8, 1); 0 turns it off.
    pub alpha2: f32,
}

impl Perturbation {
    /// The factor for a direction `wi` (local to the perturbed frame): zero
    /// when it changes side between the two frames.
    #[inline]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn factor(&self, wi: Vec3) -> f32 {
        let c = self.n_orig.dot(wi);
        if !(c * wi.z > 0.0) {
            return 0.0;
        }
        let tan2 = (1.0 - c * c).max(0.0) / (c * c);
        2.0 / (1.0 + (1.0 + self.alpha2 * tan2).sqrt())
    }
}

impl<'a> From<BsdfKind<'a>> for Bsdf<'a> {
    fn from(kind: BsdfKind<'a>) -> Bsdf<'a> {
        Bsdf { kind, opacity: 1.0, perturbation: None }
    }
}

impl Bsdf<'_> {
    /// Whether any lobe is non-delta, i.e. light sampling can help.
    #[inline]
    pub fn has_smooth(&self) -> bool {
        self.opacity > 0.0 && with_model!(&self.kind, b => b.has_smooth(), null => false)
    }

    /// Whether no lobe transmits: f(wo, wi) is 0 unless wi is on wo's side
    /// of the surface (a mask's null lobe aside, which is delta). Path
    /// guiding folds its directions onto that side for such a BSDF. False
    /// where unsure (a blend), which only forgoes the fold.
    #[inline]
    pub fn reflects_only(&self) -> bool {
        use BsdfKind::*;
        matches!(
            self.kind,
            Diffuse(_)
                | Conductor(_)
                | RoughConductor(_)
                | Plastic(_)
                | RoughPlastic(_)
                | PPlastic(_)
                | CoatedDiffuse(_)
                | CoatedConductor(_)
                | Measured(_)
                | GltfPbr(_)
        )
    }

    /// Whether its non-delta lobe is a microfacet lobe of roughness below
    /// `roughness` (the lesser of α_u and α_v): path guiding leaves such a
    /// vertex to the BSDF, as [`crate::material::LaneMaterial::narrower_than`].
    #[inline]
    pub fn narrower_than(&self, roughness: f32) -> bool {
        match &self.kind {
            BsdfKind::RoughConductor(RoughConductor { distr, .. })
            | BsdfKind::RoughDielectric(RoughDielectric { distr, .. }) => distr.alpha_u.min(distr.alpha_v) < roughness,
            _ => false,
        }
    }

    /// f(wo, wi) without the cosine, scaled by the opacity; local directions.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        self.eval_and_pdf::<true, false>(wo, wi).0
    }

    /// Solid-angle density of sampling `wi` from `wo`, scaled by the opacity.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_and_pdf::<false, true>(wo, wi).1
    }

    /// `(eval, pdf)` with one dispatch, for MIS of a light sample.
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        self.eval_and_pdf::<true, true>(wo, wi)
    }

    /// The one dispatch behind `eval`, `pdf` and `eval_pdf`: the value when
    /// `F`, the pdf when `P` (the other is left zero).
    #[inline(always)]
    fn eval_and_pdf<const F: bool, const P: bool>(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        let (f, p) = with_model!(&self.kind, b => (
            if F { b.eval(wo, wi) } else { Spectrum::ZERO },
            if P { b.pdf(wo, wi) } else { 0.0 },
        ), null => (Spectrum::ZERO, 0.0));
        // Opacity scales both; a bump or normal map's factor scales the
        // value, and where it is zero the direction cannot be sampled either.
        let (scale, p) = match self.perturbation {
            Some(q) => {
                let k = q.factor(wi);
                (self.opacity * k, if k == 0.0 { 0.0 } else { p })
            }
            None => (self.opacity, p),
        };
        let (f, p) = (f * scale, p * self.opacity);
        debug_assert!(p >= 0.0 && !p.is_nan(), "BSDF pdf {p} is negative or NaN");
        // (Values are not checked: a NaN texture makes them NaN, and the
        // render drops such samples and counts them.)
        (f, p)
    }

    /// What passes straight through along `-wo` without scattering
    /// (Mitsuba's `eval_null_transmission`): 1 for `null`, 1 − R' times the
    /// tint for `thindielectric`, a mask's cut-out 1 − opacity · (1 − inner),
    /// 0 for every other model. Shadow rays of the volumetric path tracer
    /// cross surfaces by this factor.
    #[inline]
    pub fn null_transmission(&self, wo: Vec3) -> Spectrum {
        let inner = match &self.kind {
            BsdfKind::Null => Spectrum::ONE,
            BsdfKind::ThinDielectric(t) => t.specular_transmittance * (1.0 - t.reflectance(wo.z)),
            BsdfKind::Blend(b) => b.null_transmission(wo),
            _ => Spectrum::ZERO,
        };
        Spectrum::ONE - (Spectrum::ONE - inner) * self.opacity
    }

    /// Samples `wi` given `wo`; `u` picks a lobe, `u2` the direction.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample> {
        let mut u = u;
        if self.opacity < 1.0 {
            // Mask: pass through with probability 1 − opacity, weight 1;
            // otherwise reuse the rescaled number for the model.
            if u >= self.opacity || matches!(self.kind, BsdfKind::Null) {
                return Some(BsdfSample {
                    wi: -wo,
                    pdf: 1.0 - self.opacity,
                    weight: Spectrum::ONE,
                    delta: true,
                    null: true,
                    eta: 1.0,
                });
            }
            u /= self.opacity;
        }
        let mut s = with_model!(&self.kind, b => b.sample(wo, u, u2), null => {
            Some(BsdfSample { wi: -wo, pdf: 1.0, weight: Spectrum::ONE, delta: true, null: true, eta: 1.0 })
        })?;
        s.pdf *= self.opacity;
        if let Some(p) = self.perturbation {
            let g = p.factor(s.wi);
            if g == 0.0 {
                return None;
            }
            s.weight *= g;
        }
        debug_assert!(s.pdf >= 0.0 && s.pdf.is_finite(), "BSDF sample pdf {} is negative or not finite", s.pdf);
        debug_assert!((s.wi.length() - 1.0).abs() < 1e-3, "BSDF sample direction {} is not unit", s.wi);
        Some(s)
    }
}
