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
//! | infinite    | L (uniform) or filename (a square equal-area octahedral image, as pbrt-v4; or a 2:1 latitude-longitude image, as pbrt-v3: +z up, u = φ / 2π from +x towards +y, v = θ / π, rendered by Mitsuba's `envmap`, whose rows sit at θ = π i / (H − 1) where pbrt-v3's sit half a texel in) , scale, illuminance (with L only) |
//! | goniometric | filename (a square equal-area image; R, G, B averaged as pbrt-v4 does), I, scale, power (`light::image_point`) |
//! | projection  | filename (an RGB image), fov (90, along the image's shorter side), scale, power (`light::image_point`) |
//! | area diffuse | L, scale, power, twosided                                       |

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose

use super::super::parser::{Entity, LightEntity};
use super::spectra::{to_rgb, SpectrumUse};
use crate::error::{FileLoc, LoadError, Result};
use glam::{DMat4, DVec3, Vec3};
use penumbra_render::light::{
    ConstantLight, DirectionMap, DirectionalLight, EnvMapLight, EqualAreaEnvLight, ImagePointLight, Light, PointLight,
    SpotLight,
};

/// Lights Penumbra translates, for error messages.
pub const LIGHTS: &[&str] = &["point", "spot", "distant", "infinite", "goniometric", "projection"];

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
        "goniometric" | "projection" => image_point(e, m)?,
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

/// `goniometric` and `projection`: pbrt-v4's point lights with an image
/// of intensities, their own changes of frame (`lights.cpp`: a y-z swap, a
/// y flip) composed into the light's frame.
fn image_point(e: &Entity, m: &DMat4) -> Result<Light> {
    let (p, at) = (&e.params, &e.loc);
    let f = p.string("filename")?.ok_or_else(|| LoadError::at(at, format!("{}: \"filename\" is required", e.kind)))?;
    let path = at.file.parent().map(|d| d.join(&f)).unwrap_or_else(|| f.clone().into());
    let img = crate::image_io::read_image(&path)
        .map_err(|err| LoadError::at(at, format!("{} light image \"{f}\": {err}", e.kind)))?;
    let (w, h) = (img.width as usize, img.height as usize);
    let mut scale = p.float("scale", 1.0)?;
    let lum = |c: &[f32; 3]| 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64;
    let (map, swap, texels) = if e.kind == "goniometric" {
        if w != h {
            return Err(LoadError::at(
                at,
                format!("goniometric light image \"{f}\" is {w}x{h}: pbrt-v4 takes square equal-area images only"),
            ));
        }
        let i = illuminant(e, "I")?;
        let grey: Vec<f64> = img.pixels.iter().map(|c| (c[0] as f64 + c[1] as f64 + c[2] as f64) / 3.0).collect();
        if let Some(phi) = positive_or_unset(e, "power")? {
            // k_e = 4π · mean(Y).
            let k_e = 4.0 * std::f64::consts::PI * grey.iter().sum::<f64>() / grey.len() as f64;
            if !(k_e > 0.0) {
                return Err(LoadError::at(at, "goniometric: \"power\" with a black image"));
            }
            scale *= phi / k_e;
        }
        // finalRenderFromLight = renderFromLight · swapYZ (its own inverse).
        let swap = glam::DMat3::from_cols(DVec3::X, DVec3::Z, DVec3::Y);
        let texels = grey.iter().map(|&g| i * (g * scale) as f32).collect();
        (DirectionMap::EqualArea, swap, texels)
    } else {
        let fov = p.float("fov", 90.0)?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(LoadError::at(at, format!("projection: fov {fov} must lie in (0, 180)")));
        }
        let t = (fov.to_radians() / 2.0).tan();
        let aspect = w as f64 / h as f64;
        let tan_half = if aspect > 1.0 { glam::DVec2::new(aspect * t, t) } else { glam::DVec2::new(t, t / aspect) };
        if let Some(phi) = positive_or_unset(e, "power")? {
            // pbrt-v4: Σ Y · cos³θ over texel centres, times the image's area A on z = 1.
            let mut sum = 0.0;
            for (k, c) in img.pixels.iter().enumerate() {
                let (x, y) = ((k % w) as f64 + 0.5, (k / w) as f64 + 0.5);
                let q =
                    glam::DVec2::new((2.0 * x / w as f64 - 1.0) * tan_half.x, (2.0 * y / h as f64 - 1.0) * tan_half.y);
                let cos = 1.0 / (1.0 + q.length_squared()).sqrt();
                sum += lum(c) * cos * cos * cos;
            }
            let area = 4.0 * tan_half.x * tan_half.y;
            if !(sum > 0.0) {
                return Err(LoadError::at(at, "projection: \"power\" with a black image"));
            }
            scale *= phi / (area * sum / (w * h) as f64);
        }
        // renderFromLight · Scale(1, -1, 1).
        let flip = glam::DMat3::from_diagonal(DVec3::new(1.0, -1.0, 1.0));
        let texels = img.pixels.iter().map(|c| Vec3::from_array(*c).max(Vec3::ZERO) * scale as f32).collect();
        (DirectionMap::Perspective { tan_half: tan_half.as_vec2() }, flip, texels)
    };
    let linear = glam::DMat3::from_mat4(*m);
    let light_from_world = (swap * linear.inverse()).as_mat3();
    let position = m.transform_point3(DVec3::ZERO).as_vec3();
    let light = ImagePointLight::new(position, light_from_world, map, w, h, texels)
        .map_err(|err| LoadError::at(at, format!("{} light \"{f}\": {err}", e.kind)))?;
    Ok(Light::ImagePoint(light))
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
            if img.width == 2 * img.height {
                // pbrt-v3's latitude-longitude map, as Mitsuba's envmap: light-space
                // d_p = P d_m with d_m = (d_p.y, d_p.z, -d_p.x) matches u and v (see the table).
                let p_m = DMat4::from_cols(
                    DVec3::Y.extend(0.0),
                    DVec3::Z.extend(0.0),
                    (-DVec3::X).extend(0.0),
                    glam::DVec4::W,
                );
                let light = EnvMapLight::new(
                    img.width as usize,
                    img.height as usize,
                    img.pixels,
                    (*m * p_m).as_mat4(),
                    scale as f32,
                )
                .map_err(|e| LoadError::at(at, e))?;
                return Ok(Light::EnvMap(light));
            }
            if img.width != img.height {
                return Err(LoadError::at(
                    at,
                    format!(
                        "infinite light image \"{f}\" is {}x{}: give a square equal-area octahedral image (pbrt-v4) or a \
                         2:1 latitude-longitude one (pbrt-v3)",
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
