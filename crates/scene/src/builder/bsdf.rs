//! `<bsdf>` nodes → [`Material`]s: one function per Mitsuba plugin family,
//! with Mitsuba 3.9's defaults. Parameters Mitsuba accepts as textures are
//! read through [`Textures`].

use super::texture::Textures;
use super::{plugin, resolve, Plugins};
use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use glam::Vec3;
use penumbra_render::bsdf::plastic::fresnel_diffuse_reflectance;
use penumbra_render::bsdf::{
    presets, ConductorParams, DielectricParams, DiffuseParams, HairAbsorption, HairLobes, HairParams, Measured,
    MeasuredParams, Microfacet, MicrofacetType, PPlasticParams, PlasticParams, PrincipledParams, PrincipledThinParams,
    RoughConductorParams, RoughDielectricParams, RoughPlasticParams, RoughPlasticTables, Roughness,
    ThinDielectricParams,
};
use penumbra_render::material::Material;
use penumbra_render::math::Spectrum;
use penumbra_render::texture::Texture;

/// A builder of a material from its `<bsdf>` node.
type BuildBsdf = fn(&Node, &mut Textures) -> Result<Material>;

pub(crate) const BSDFS: &Plugins<BuildBsdf> = &[
    ("diffuse", diffuse),
    ("dielectric", dielectric),
    ("thindielectric", dielectric),
    ("roughdielectric", roughdielectric),
    ("conductor", conductor),
    ("roughconductor", roughconductor),
    ("plastic", plastic),
    ("roughplastic", plastic),
    ("pplastic", pplastic),
    ("hair", hair),
    ("measured", measured),
    ("twosided", twosided),
    ("mask", mask),
    ("normalmap", normalmap),
    ("bumpmap", bumpmap),
    ("null", |_, _| Ok(Material::Null)),
    ("blendbsdf", blendbsdf),
    ("principled", principled),
    ("principledthin", principledthin),
];

/// An IOR given as a number or one of Mitsuba's named materials.
pub(crate) fn ior(node: &Node, name: &str, default: &str) -> Result<f32> {
    let (s, loc) = match node.get_string(name).ok().flatten() {
        Some(v) => v,
        None => match node.get_float(name)? {
            Some(v) => return Ok(v as f32),
            None => (default.to_string(), node.loc.clone()),
        },
    };
    presets::named_ior(&s).ok_or_else(|| {
        LoadError::at(&loc, format!("unknown IOR name '{s}'; known names: {}", presets::IOR_NAMES.join(", ")))
    })
}

/// int_ior / ext_ior, both positive (and different, where Mitsuba requires it).
fn relative_ior(node: &Node, int_default: &str, must_differ: bool) -> Result<f32> {
    let int = ior(node, "int_ior", int_default)?;
    let ext = ior(node, "ext_ior", "air")?;
    if !(int > 0.0 && ext > 0.0) || (must_differ && int == ext) {
        return Err(node.error(format!(
            "{}: int_ior and ext_ior must be positive{}",
            node.describe(),
            if must_differ { " and differ" } else { "" }
        )));
    }
    Ok(int / ext)
}

fn distribution(node: &Node) -> Result<MicrofacetType> {
    match node.get_string("distribution")? {
        None => Ok(MicrofacetType::Beckmann),
        Some((s, loc)) => match s.to_lowercase().as_str() {
            "beckmann" => Ok(MicrofacetType::Beckmann),
            "ggx" => Ok(MicrofacetType::Ggx),
            _ => Err(LoadError::at(&loc, format!("distribution '{s}' is not one of beckmann, ggx"))),
        },
    }
}

/// `alpha`, or `alpha_u` and `alpha_v` (both), as Mitsuba's microfacet plugins.
fn roughness(node: &Node, tex: &mut Textures) -> Result<Roughness> {
    let kind = distribution(node)?;
    // Visible-normal sampling is always used; `sample_visible = false`
    // selects Mitsuba's older sampler of the same distribution, whose
    // variance is never lower.
    node.bool("sample_visible", true)?;
    let has = |n: &str| node.has(n) || node.children_of(Kind::Texture).any(|c| c.name.as_deref() == Some(n));
    if has("alpha_u") || has("alpha_v") {
        if !(has("alpha_u") && has("alpha_v")) {
            return Err(node.error(format!("{}: give both 'alpha_u' and 'alpha_v'", node.describe())));
        }
        if has("alpha") {
            return Err(node.error(format!("{}: give either 'alpha' or 'alpha_u'/'alpha_v'", node.describe())));
        }
        Ok(Roughness { kind, alpha_u: tex.float(node, "alpha_u", 0.1)?, alpha_v: tex.float(node, "alpha_v", 0.1)? })
    } else {
        let a = tex.float(node, "alpha", 0.1)?;
        Ok(Roughness { kind, alpha_u: a.clone(), alpha_v: a })
    }
}

/// Complex IOR of a conductor: `material` (a name) or `eta`/`k`; Mitsuba's
/// default "none" is eta 0, k 1, a perfect mirror.
fn complex_ior(node: &Node, tex: &mut Textures) -> Result<(Texture, Texture)> {
    let material = node.get_string("material")?;
    let explicit = node.has("eta")
        || node.has("k")
        || node.children_of(Kind::Texture).any(|c| matches!(c.name.as_deref(), Some("eta") | Some("k")));
    match material {
        Some((name, loc)) if name != "none" => {
            if explicit {
                return Err(LoadError::at(
                    &loc,
                    format!("{}: give either 'material' or 'eta'/'k', not both", node.describe()),
                ));
            }
            match presets::named_conductor(&name) {
                Some((e, k)) => Ok((Texture::Constant(Vec3::from(e)), Texture::Constant(Vec3::from(k)))),
                None => Err(LoadError::at(
                    &loc,
                    format!("unknown conductor material '{name}'; known: {}", presets::CONDUCTOR_NAMES.join(", ")),
                )),
            }
        }
        _ => Ok((tex.spectrum(node, "eta", Spectrum::ZERO)?, tex.spectrum(node, "k", Spectrum::ONE)?)),
    }
}

/// The single nested BSDF of a wrapper.
fn nested(node: &Node, tex: &mut Textures) -> Result<Box<Material>> {
    let inner: Vec<_> = node.children_of(Kind::Bsdf).collect();
    match inner.as_slice() {
        [one] => Ok(Box::new(build_material(&one.node, tex)?)),
        _ => Err(node.error(format!("{} needs exactly one nested BSDF", node.describe()))),
    }
}

/// `flip_invalid_normals` and `use_shadowing_function` of the normal- and
/// bump-map wrappers: only Mitsuba's defaults (true) are implemented.
fn wrapper_defaults(node: &Node) -> Result<()> {
    for name in ["flip_invalid_normals", "use_shadowing_function"] {
        if !node.bool(name, true)? {
            return Err(LoadError::at(
                node.loc_of(name),
                format!("{}: '{name}' = false is not supported (only Mitsuba's default, true)", node.describe()),
            ));
        }
    }
    Ok(())
}

/// Mitsuba `principled`. A parameter given as the float 0 counts as absent
/// (Mitsuba's `get_flag`), which matters for `spec_trans`: present, it also
/// enables transmission from the back side.
/// Mitsuba's `get_flag`: a parameter absent or given as the float 0 is `None`.
fn flagged_param(node: &Node, tex: &mut Textures, name: &str) -> Result<Option<Texture>> {
    let is_tex = node.children_of(Kind::Texture).any(|c| c.name.as_deref() == Some(name));
    if !is_tex && (!node.has(name) || node.get_float(name)? == Some(0.0)) {
        // Mark a zero float as used.
        node.float(name, 0.0)?;
        return Ok(None);
    }
    Ok(Some(tex.float(node, name, 0.0)?))
}

/// Mitsuba `principledthin`, with its parameters and defaults
/// (src/bsdfs/principledthin.cpp); every parameter but the sampling rates
/// may be a texture.
fn principledthin(node: &Node, tex: &mut Textures) -> Result<Material> {
    let flagged = |tex: &mut Textures, name: &str| flagged_param(node, tex, name);
    let p = PrincipledThinParams {
        base_color: tex.spectrum(node, "base_color", Spectrum::splat(0.5))?,
        roughness: tex.float(node, "roughness", 0.5)?,
        anisotropic: flagged(tex, "anisotropic")?,
        spec_trans: flagged(tex, "spec_trans")?,
        spec_tint: flagged(tex, "spec_tint")?,
        sheen: flagged(tex, "sheen")?,
        sheen_tint: flagged(tex, "sheen_tint")?,
        flatness: flagged(tex, "flatness")?,
        diff_trans: flagged(tex, "diff_trans")?,
        eta: tex.float(node, "eta", 1.5)?,
        spec_refl_srate: node.float("specular_reflectance_sampling_rate", 1.0)? as f32,
        spec_trans_srate: node.float("specular_transmittance_sampling_rate", 1.0)? as f32,
        diff_trans_srate: node.float("diffuse_transmittance_sampling_rate", 1.0)? as f32,
        diff_refl_srate: node.float("diffuse_reflectance_sampling_rate", 1.0)? as f32,
    };
    Ok(Material::PrincipledThin(Box::new(p)))
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn principled(node: &Node, tex: &mut Textures) -> Result<Material> {
    let flagged = |tex: &mut Textures, name: &str| flagged_param(node, tex, name);
    let spec_trans = flagged(tex, "spec_trans")?;
    let has_spec_trans = spec_trans.is_some();
    let eta = if node.has("eta") {
        if node.has("specular") {
            return Err(LoadError::at(
                node.loc_of("specular"),
                "principled: give either 'eta' or 'specular', not both (as in Mitsuba)",
            ));
        }
        let eta = node.float("eta", 1.5)? as f32;
        if has_spec_trans && eta == 1.0 {
            1.001
        } else {
            eta
        }
    } else {
        let mut specular = node.float("specular", 0.5)? as f32;
        if has_spec_trans && specular == 0.0 {
            specular = 1e-3;
        }
        2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
    };
    if !(eta > 0.0) {
        return Err(node.error(format!("principled: eta must be positive (got {eta})")));
    }
    let p = PrincipledParams {
        base_color: tex.spectrum(node, "base_color", Spectrum::splat(0.5))?,
        roughness: tex.float(node, "roughness", 0.5)?,
        anisotropic: flagged(tex, "anisotropic")?,
        spec_trans,
        metallic: flagged(tex, "metallic")?,
        spec_tint: flagged(tex, "spec_tint")?,
        sheen: flagged(tex, "sheen")?,
        sheen_tint: flagged(tex, "sheen_tint")?,
        clearcoat: flagged(tex, "clearcoat")?,
        clearcoat_gloss: tex.float(node, "clearcoat_gloss", 0.0)?,
        flatness: flagged(tex, "flatness")?,
        eta,
        spec_srate: node.float("main_specular_sampling_rate", 1.0)? as f32,
        clearcoat_srate: node.float("clearcoat_sampling_rate", 1.0)? as f32,
        diffuse_srate: node.float("diffuse_reflectance_sampling_rate", 1.0)? as f32,
    };
    Ok(Material::Principled(Box::new(p)))
}

pub(crate) fn build_material(node: &Node, tex: &mut Textures) -> Result<Material> {
    let m = plugin(BSDFS, node)?(node, tex)?;
    node.check_all_used(&[Kind::Bsdf, Kind::Texture])?;
    Ok(m)
}

fn diffuse(node: &Node, tex: &mut Textures) -> Result<Material> {
    Ok(Material::Diffuse(DiffuseParams { reflectance: tex.spectrum(node, "reflectance", Spectrum::splat(0.5))? }))
}

/// Mitsuba's `dielectric` and `thindielectric`.
fn dielectric(node: &Node, tex: &mut Textures) -> Result<Material> {
    let one = Spectrum::ONE;
    let eta = relative_ior(node, "bk7", false)?;
    let specular_reflectance = tex.spectrum(node, "specular_reflectance", one)?;
    let specular_transmittance = tex.spectrum(node, "specular_transmittance", one)?;
    Ok(if node.plugin == "dielectric" {
        Material::Dielectric(DielectricParams { eta, specular_reflectance, specular_transmittance })
    } else {
        Material::ThinDielectric(ThinDielectricParams { eta, specular_reflectance, specular_transmittance })
    })
}

fn roughdielectric(node: &Node, tex: &mut Textures) -> Result<Material> {
    let one = Spectrum::ONE;
    Ok(Material::RoughDielectric(RoughDielectricParams {
        eta: relative_ior(node, "bk7", true)?,
        roughness: roughness(node, tex)?,
        specular_reflectance: tex.spectrum(node, "specular_reflectance", one)?,
        specular_transmittance: tex.spectrum(node, "specular_transmittance", one)?,
    }))
}

fn conductor(node: &Node, tex: &mut Textures) -> Result<Material> {
    let (eta, k) = complex_ior(node, tex)?;
    Ok(Material::Conductor(ConductorParams {
        eta,
        k,
        specular_reflectance: tex.spectrum(node, "specular_reflectance", Spectrum::ONE)?,
    }))
}

fn roughconductor(node: &Node, tex: &mut Textures) -> Result<Material> {
    let (eta, k) = complex_ior(node, tex)?;
    Ok(Material::RoughConductor(RoughConductorParams {
        roughness: roughness(node, tex)?,
        eta,
        k,
        specular_reflectance: tex.spectrum(node, "specular_reflectance", Spectrum::ONE)?,
    }))
}

/// Mitsuba's `plastic` and `roughplastic`.
fn plastic(node: &Node, tex: &mut Textures) -> Result<Material> {
    let eta = relative_ior(node, "polypropylene", node.plugin == "roughplastic")?;
    let diffuse_reflectance = tex.spectrum(node, "diffuse_reflectance", Spectrum::splat(0.5))?;
    let specular_reflectance = tex.spectrum(node, "specular_reflectance", Spectrum::ONE)?;
    let nonlinear = node.bool("nonlinear", false)?;
    // Mitsuba steers lobe selection by the textures' mean values.
    let specular_sampling_weight = specular_sampling_weight(node, &diffuse_reflectance, &specular_reflectance)?;
    if node.plugin == "plastic" {
        return Ok(Material::Plastic(PlasticParams {
            eta,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
            specular_sampling_weight,
        }));
    }
    let r = roughness(node, tex)?;
    let (Some(au), Some(av)) = (r.alpha_u.constant(), r.alpha_v.constant()) else {
        return Err(node.error("roughplastic: alpha must be a number, not a texture (as in Mitsuba)"));
    };
    if au != av {
        return Err(node.error("roughplastic does not support anisotropic roughness (as in Mitsuba)"));
    }
    let distr = Microfacet { kind: r.kind, alpha_u: au.x, alpha_v: av.x };
    Ok(Material::RoughPlastic(RoughPlasticParams {
        distr,
        eta,
        diffuse_reflectance,
        specular_reflectance,
        nonlinear,
        specular_sampling_weight,
        tables: RoughPlasticTables::new(distr, eta),
    }))
}

/// The textures' means that steer lobe selection (Mitsuba's
/// `m_specular_sampling_weight` = s̄ / (ρ̄ + s̄)).
fn specular_sampling_weight(node: &Node, diffuse: &Texture, specular: &Texture) -> Result<f32> {
    if !diffuse.has_mean() || !specular.has_mean() {
        return Err(node.error(format!(
            "{}: a mesh_attribute reflectance is not supported (Mitsuba needs the texture's mean \
             for lobe selection and fails the same way)",
            node.plugin
        )));
    }
    let (d_mean, s_mean) = (diffuse.mean(), specular.mean());
    Ok(s_mean / (d_mean + s_mean))
}

/// Mitsuba's `pplastic` (its RGB variants' non-polarised form): `eta` (a
/// float or texture) or `int_ior`/`ext_ior`, textured roughness as the rough
/// conductor's.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn pplastic(node: &Node, tex: &mut Textures) -> Result<Material> {
    let has = |n: &str| node.has(n) || node.children_of(Kind::Texture).any(|c| c.name.as_deref() == Some(n));
    let eta = if has("eta") {
        if has("int_ior") || has("ext_ior") {
            return Err(node.error("pplastic: give either 'eta' or 'int_ior'/'ext_ior', not both (as in Mitsuba)"));
        }
        let eta = tex.float(node, "eta", 0.0)?;
        if let Some(e) = eta.constant() {
            if !(e.x > 0.0) {
                return Err(LoadError::at(node.loc_of("eta"), format!("pplastic: eta must be positive (got {})", e.x)));
            }
        }
        eta
    } else {
        Texture::Constant(Spectrum::splat(relative_ior(node, "polypropylene", true)?))
    };
    let diffuse_reflectance = tex.spectrum(node, "diffuse_reflectance", Spectrum::splat(0.5))?;
    let specular_reflectance = tex.spectrum(node, "specular_reflectance", Spectrum::ONE)?;
    let specular_sampling_weight = specular_sampling_weight(node, &diffuse_reflectance, &specular_reflectance)?;
    Ok(Material::PPlastic(PPlasticParams {
        roughness: roughness(node, tex)?,
        eta,
        diffuse_reflectance,
        specular_reflectance,
        specular_sampling_weight,
    }))
}

/// Mitsuba's `hair`: roughnesses in [0, 1], the scale tilt, the fibre's IOR,
/// and its absorption from pigments or `sigma_a` (not both).
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn hair(node: &Node, tex: &mut Textures) -> Result<Material> {
    use penumbra_render::bsdf::hair::{EUMELANIN_SIGMA_A, PHEOMELANIN_SIGMA_A};
    let rough = |name: &str| -> Result<f32> {
        let r = node.float(name, 0.3)? as f32;
        if !(0.0..=1.0).contains(&r) {
            return Err(LoadError::at(node.loc_of(name), format!("hair: {name} must be in [0, 1] (got {r})")));
        }
        Ok(r)
    };
    let (longitudinal, azimuthal) = (rough("longitudinal_roughness")?, rough("azimuthal_roughness")?);
    let tilt = node.float("scale_tilt", 2.0)? as f32;
    let int = ior(node, "int_ior", "amber")?;
    let ext = ior(node, "ext_ior", "air")?;
    if !(int > 0.0 && ext > 0.0) || int == ext {
        return Err(node.error("hair: int_ior and ext_ior must be positive and differ"));
    }
    let has_sigma =
        node.has("sigma_a") || node.children_of(Kind::Texture).any(|c| c.name.as_deref() == Some("sigma_a"));
    let absorption = if has_sigma {
        for name in ["eumelanin", "pheomelanin"] {
            if node.has(name) {
                return Err(LoadError::at(
                    node.loc_of(name),
                    "hair: give either the pigments (eumelanin, pheomelanin) or sigma_a, not both (as in Mitsuba)",
                ));
            }
        }
        let sigma_a = tex.spectrum(node, "sigma_a", Spectrum::ZERO)?;
        HairAbsorption::SigmaA { sigma_a, scale: node.float("scale", 1.0)? as f32 }
    } else {
        let eu = node.float("eumelanin", 1.3)? as f32;
        let pheo = node.float("pheomelanin", 0.2)? as f32;
        // Mitsuba reads `scale` always, and uses it with sigma_a only.
        node.float("scale", 1.0)?;
        HairAbsorption::Pigments(EUMELANIN_SIGMA_A * eu + PHEOMELANIN_SIGMA_A * pheo)
    };
    Ok(Material::Hair(Box::new(HairParams {
        lobes: HairLobes::new(longitudinal, azimuthal, tilt, int / ext),
        absorption,
    })))
}

/// Mitsuba's `measured`: an RGL `.bsdf` file (RGB) by `filename`, read
/// through [`crate::tensor`]; whatever is wrong with the file is an error
/// at the `filename` property naming the file (and the byte, where the
/// format is at fault).
fn measured(node: &Node, _tex: &mut Textures) -> Result<Material> {
    let (file, loc) =
        node.get_string("filename")?.ok_or_else(|| node.error("measured needs a 'filename' (an RGL .bsdf file)"))?;
    let path = resolve(&loc, &file, "measured BSDF file")?;
    let bsdf = std::fs::read(&path)
        .map_err(|e| format!("cannot read it: {e}"))
        .and_then(crate::tensor::TensorFile::parse)
        .and_then(|t| crate::tensor::measured_tables(&t))
        .and_then(Measured::new)
        .map_err(|e| LoadError::at(&loc, format!("measured BSDF file '{}': {e}", path.display())))?;
    Ok(Material::Measured(MeasuredParams(std::sync::Arc::new(bsdf))))
}

fn twosided(node: &Node, tex: &mut Textures) -> Result<Material> {
    let inner: Vec<_> = node.children_of(Kind::Bsdf).collect();
    let (front, back) = match inner.as_slice() {
        [one] => (build_material(&one.node, tex)?, build_material(&one.node, tex)?),
        [a, b] => (build_material(&a.node, tex)?, build_material(&b.node, tex)?),
        _ => return Err(node.error("twosided needs one or two nested BSDFs")),
    };
    if matches!(front, Material::TwoSided(..)) || matches!(back, Material::TwoSided(..)) {
        return Err(node.error("twosided cannot wrap another twosided BSDF"));
    }
    Ok(Material::TwoSided(Box::new(front), Box::new(back)))
}

fn mask(node: &Node, tex: &mut Textures) -> Result<Material> {
    Ok(Material::Mask { opacity: tex.float(node, "opacity", 0.5)?, inner: nested(node, tex)? })
}

fn normalmap(node: &Node, tex: &mut Textures) -> Result<Material> {
    let child = node
        .children_of(Kind::Texture)
        .find(|c| c.name.as_deref() == Some("normalmap"))
        .ok_or_else(|| node.error("normalmap needs a texture named 'normalmap'"))?;
    let normals = tex.build(&child.node)?;
    wrapper_defaults(node)?;
    Ok(Material::NormalMap { normals, inner: nested(node, tex)? })
}

fn bumpmap(node: &Node, tex: &mut Textures) -> Result<Material> {
    let textures: Vec<_> = node.children_of(Kind::Texture).collect();
    let [t] = textures.as_slice() else {
        return Err(node.error("bumpmap needs exactly one nested texture (the height field)"));
    };
    let height = tex.build(&t.node)?;
    if !height.has_gradient() {
        return Err(LoadError::at(
            &t.loc,
            "bumpmap: this texture has no gradient (Mitsuba rejects it too); use a bitmap height map",
        ));
    }
    wrapper_defaults(node)?;
    Ok(Material::BumpMap { height, scale: node.float("scale", 1.0)? as f32, inner: nested(node, tex)? })
}

fn blendbsdf(node: &Node, tex: &mut Textures) -> Result<Material> {
    let has_weight = node.has("weight") || node.children_of(Kind::Texture).any(|c| c.name.as_deref() == Some("weight"));
    if !has_weight {
        return Err(node.error("blendbsdf needs a 'weight' (a float or a texture)"));
    }
    let weight = tex.float(node, "weight", 0.5)?;
    let inner: Vec<_> = node.children_of(Kind::Bsdf).collect();
    let [a, b] = inner.as_slice() else {
        return Err(node.error("blendbsdf needs exactly two nested BSDFs"));
    };
    Ok(Material::Blend {
        weight,
        first: Box::new(build_material(&a.node, tex)?),
        second: Box::new(build_material(&b.node, tex)?),
    })
}
