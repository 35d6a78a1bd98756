//! pbrt-v4's `LightSource`s and `AreaLightSource "diffuse"` as Penumbra's
//! lights. Spectra are normalised as pbrt-v4 normalises them (see
//! [`super::spectra`]); `power` and `illuminance` rescale as in pbrt-v4's
//! `lights.cpp`.
//!
//! | light       | parameters read                                                   |
//! |-------------|-------------------------------------------------------------------|
//! | point       | I (the colour space's illuminant), scale (1), power, from         |
//! | spot        | I, scale, power, from (0 0 0), to (0 0 1), coneangle (30), conedeltaangle (5): pbrt-v4's smoothstep falloff |
//! | distant     | L, scale, illuminance, from (0 0 0), to (0 0 1)                   |
//! | infinite    | L (uniform) or filename (a square equal-area octahedral image: .exr, .pfm, .hdr, .png), scale, illuminance (with L only) |
//! | area diffuse | L, scale, power, twosided                                       |

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose

use super::super::parser::{Entity, LightEntity};
use super::spectra::{to_rgb, SpectrumUse};
use crate::error::{FileLoc, LoadError, Result};
use glam::{DMat4, DVec3, Vec3};
use penumbra_render::light::{ConstantLight, DirectionalLight, EqualAreaEnvLight, Light, PointLight, SpotLight};

/// Lights Penumbra translates, for error messages.
pub const LIGHTS: &[&str] = &["point", "spot", "distant", "infinite"];

/// An illuminant parameter (default: the colour space's white, luminance 1).
fn illuminant(e: &Entity, name: &str) -> Result<Vec3> {
    Ok(match e.params.spectrum(name)? {
        None => Vec3::ONE,
        Some((v, at)) => Vec3::from_array(to_rgb(&v, SpectrumUse::Illuminant, &at)?),
    })
}

/// A `point3` parameter, or `default`.
fn point(e: &Entity, name: &str, default: DVec3) -> Result<DVec3> {
    Ok(e.params
        .triples(name, super::super::params::ParamType::Point3)?
        .and_then(|v| v.first().copied())
        .map_or(default, DVec3::from_array))
}

fn positive_or_unset(e: &Entity, name: &str) -> Result<Option<f64>> {
    let v = e.params.float(name, -1.0)?;
    Ok((v > 0.0).then_some(v))
}

/// A light that is not on a shape.
pub fn light(l: &LightEntity) -> Result<Light> {
    let e = &l.entity;
    let (p, at) = (&e.params, &e.loc);
    let m = &l.world_from_light;
    // A light's medium (`MediumInterface` before it) needs no attaching:
    // paths from the camera find media through the shapes that bound them.
    let light = match e.kind.as_str() {
        "point" => {
            let i = illuminant(e, "I")?;
            let mut scale = p.float("scale", 1.0)?;
            if let Some(phi) = positive_or_unset(e, "power")? {
                scale *= phi / (4.0 * std::f64::consts::PI);
            }
            let from = p.triples("from", super::super::params::ParamType::Point3)?.and_then(|v| v.first().copied());
            let from = from.map_or(DVec3::ZERO, DVec3::from_array);
            Light::Point(PointLight { position: m.transform_point3(from).as_vec3(), intensity: i * scale as f32 })
        }
        "distant" => {
            let l_rgb = illuminant(e, "L")?;
            let mut scale = p.float("scale", 1.0)?;
            let pt = |n: &str, d: DVec3| -> Result<DVec3> {
                Ok(p.triples(n, super::super::params::ParamType::Point3)?
                    .and_then(|v| v.first().copied())
                    .map_or(d, DVec3::from_array))
            };
            let (from, to) = (pt("from", DVec3::ZERO)?, pt("to", DVec3::Z)?);
            if let Some(e_v) = positive_or_unset(e, "illuminance")? {
                scale *= e_v;
            }
            let d = m.transform_vector3(to - from);
            if !(d.length() > 0.0) {
                return Err(LoadError::at(at, "distant: \"from\" and \"to\" must differ"));
            }
            Light::Directional(DirectionalLight {
                direction: d.normalize().as_vec3(),
                irradiance: l_rgb * scale as f32,
                scene_radius: 0.0,
            })
        }
        "infinite" => infinite(e, m)?,
        "spot" => {
            let i = illuminant(e, "I")?;
            let mut scale = p.float("scale", 1.0)?;
            let cone = p.float("coneangle", 30.0)?;
            let delta = p.float("conedeltaangle", 5.0)?;
            if !(cone > 0.0 && cone <= 180.0 && (0.0..=cone).contains(&delta)) {
                return Err(LoadError::at(at, format!("spot: coneangle {cone} and conedeltaangle {delta} must satisfy 0 <= conedeltaangle <= coneangle <= 180")));
            }
            let (from, to) = (point(e, "from", DVec3::ZERO)?, point(e, "to", DVec3::Z)?);
            let d = to - from;
            if !(d.length() > 0.0) {
                return Err(LoadError::at(at, "spot: \"from\" and \"to\" must differ"));
            }
            if let Some(phi) = positive_or_unset(e, "power")? {
                // pbrt-v4's k_e, the exact flux of the smoothstep falloff per unit I.
                let (a, b) = (cone.to_radians().cos(), (cone - delta).to_radians().cos());
                scale *= phi / (2.0 * std::f64::consts::PI * ((1.0 - b) + (b - a) / 2.0));
            }
            // Any frame whose +z is the beam (the light is symmetric about it).
            let w = d.normalize();
            let up = if w.z.abs() < 0.9 { DVec3::Z } else { DVec3::X };
            let x = up.cross(w).normalize();
            let y = w.cross(x);
            let frame = DMat4::from_cols(x.extend(0.0), y.extend(0.0), w.extend(0.0), from.extend(1.0));
            Light::Spot(SpotLight::pbrt((*m * frame).as_mat4(), i * scale as f32, cone as f32, delta as f32))
        }
        "goniometric" | "projection" => {
            return Err(LoadError::at(
                at,
                format!("light \"{}\" is not supported yet; supported: {}", e.kind, LIGHTS.join(", ")),
            ))
        }
        other => {
            return Err(LoadError::at(
                at,
                format!("light \"{other}\" is not supported; supported: {}", LIGHTS.join(", ")),
            ))
        }
    };
    p.check_unused(&format!("LightSource \"{}\"", e.kind))?;
    Ok(light)
}

fn infinite(e: &Entity, m: &DMat4) -> Result<Light> {
    let (p, at) = (&e.params, &e.loc);
    let mut scale = p.float("scale", 1.0)?;
    if p.type_of("portal").is_some() {
        return Err(LoadError::at(at, "infinite: \"portal\" lights are not supported"));
    }
    let file = p.string("filename")?;
    let has_l = p.type_of("L").is_some();
    match file {
        None => {
            let l_rgb = illuminant(e, "L")?;
            if let Some(e_v) = positive_or_unset(e, "illuminance")? {
                scale *= e_v / std::f64::consts::PI;
            }
            Ok(Light::Constant(ConstantLight { radiance: l_rgb * scale as f32 }))
        }
        Some(_) if has_l => Err(LoadError::at(at, "infinite: give either \"L\" or \"filename\", not both")),
        Some(f) => {
            if p.type_of("illuminance").is_some() {
                return Err(LoadError::at(at, "infinite: \"illuminance\" with an image is not supported"));
            }
            let path = at.file.parent().map(|d| d.join(&f)).unwrap_or_else(|| f.clone().into());
            let img = crate::image_io::read_image(&path)
                .map_err(|e| LoadError::at(at, format!("infinite light image \"{f}\": {e}")))?;
            if img.width != img.height {
                return Err(LoadError::at(
                    at,
                    format!(
                        "infinite light image \"{f}\" is {}x{}: pbrt-v4 takes square equal-area octahedral images only \
                         (convert a latitude-longitude map with pbrt-v4's imgtool makeequiarea)",
                        img.width, img.height
                    ),
                ));
            }
            let light = EqualAreaEnvLight::new(img.width as usize, img.pixels, m.as_mat4(), scale as f32)
                .map_err(|e| LoadError::at(at, e))?;
            Ok(Light::EqualAreaEnv(light))
        }
    }
}

/// An `AreaLightSource "diffuse"`'s radiance on a shape of world-space
/// `area`, and whether it emits from both sides.
pub fn area_radiance(e: &Entity, area: f32, at_shape: &FileLoc) -> Result<(Vec3, bool)> {
    let (p, at) = (&e.params, &e.loc);
    if e.kind != "diffuse" {
        return Err(LoadError::at(at, format!("area light \"{}\" is not supported; only \"diffuse\"", e.kind)));
    }
    if p.type_of("filename").is_some() {
        return Err(LoadError::at(at, "area light \"filename\" (an image) is not supported yet"));
    }
    let two_sided = p.bool("twosided", false)?;
    let l = illuminant(e, "L")?;
    let mut scale = p.float("scale", 1.0)?;
    if let Some(phi) = positive_or_unset(e, "power")? {
        if !(area > 0.0) {
            return Err(LoadError::at(at_shape, "an area light with \"power\" on a shape of zero area"));
        }
        scale *= phi / (if two_sided { 2.0 } else { 1.0 } * area as f64 * std::f64::consts::PI);
    }
    p.check_unused("AreaLightSource \"diffuse\"")?;
    Ok((l * scale as f32, two_sided))
}
