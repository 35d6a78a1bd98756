//! `<emitter>` nodes → [`Light`]s: area emitters inside shapes and the
//! emitters declared at the top level.

use super::texture::Textures;
use super::{plugin, resolve, Plugins};
use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use crate::image_io;
use crate::scene_builder::Emission;
pub(super) use crate::scene_builder::PendingLight;
use glam::{DVec3, Vec3};
use penumbra_render::camera::tan_half_x;
use penumbra_render::geometry::Shape;
use penumbra_render::light::{
    ConstantLight, DirectionalLight, EnvMapLight, Light, PointLight, ProjectorLight, SpotLight,
};
use penumbra_render::math::Spectrum;
use penumbra_render::texture::Texture;

/// A builder of a top-level emitter.
type BuildEmitter = fn(&Node) -> Result<PendingLight>;

pub(super) const EMITTERS: &Plugins<BuildEmitter> = &[
    ("area (inside a shape)", area_at_top_level),
    ("directionalarea (inside a shape)", area_at_top_level),
    ("constant", constant),
    ("envmap", envmap),
    ("point", point),
    ("spot", spot),
    ("directional", directional),
    ("projector", projector),
];

fn rgb(v: [f64; 3]) -> Spectrum {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// A light that needs nothing from the rest of the scene.
fn ready(light: Light) -> PendingLight {
    Box::new(move |_| light)
}

/// The light the area emitter `en` attached to the shape `shape_node`
/// (built as `shape`) emits. Its `radiance` (Mitsuba's default 1) is a
/// colour or a nested `bitmap` / `checkerboard` texture.
pub(super) fn area(en: &Node, shape_node: &Node, shape: &Shape, textures: &mut Textures) -> Result<Emission> {
    if en.plugin == "directionalarea" {
        return directional_area(en, shape_node, shape);
    }
    if en.plugin != "area" {
        return Err(en.error(format!(
            "emitter '{}' cannot be attached to a shape; only 'area' and 'directionalarea' can",
            en.plugin
        )));
    }
    if let Some(c) = en.children_of(Kind::Texture).find(|c| c.name.as_deref() != Some("radiance")) {
        return Err(LoadError::at(&c.loc, "an area emitter takes one nested texture, named 'radiance'"));
    }
    if en.has("to_world") {
        return Err(LoadError::at(
            en.loc_of("to_world"),
            "an area emitter takes no 'to_world': it inherits its shape's transformation (as in Mitsuba)",
        ));
    }
    let radiance = textures.spectrum(en, "radiance", Spectrum::ONE)?;
    match &radiance {
        Texture::MeshAttribute(_) => {
            let loc = &en.children_of(Kind::Texture).next().map_or(en.loc.clone(), |c| c.loc.clone());
            return Err(LoadError::at(loc, "an area emitter's radiance cannot be a mesh_attribute texture"));
        }
        Texture::Constant(c) if c.min_element() < 0.0 => {
            return Err(LoadError::at(en.loc_of("radiance"), "an area emitter's radiance must not be negative"));
        }
        _ => {}
    }
    en.check_all_used(&[Kind::Texture])?;
    if shape.area() <= 0.0 {
        return Err(shape_node.error("an area emitter's shape has zero area"));
    }
    Ok(Emission::Diffuse(radiance))
}

/// An emitter declared at the top level (not attached to a shape).
pub(super) fn top_level(node: &Node) -> Result<PendingLight> {
    let light = plugin(EMITTERS, node)?(node)?;
    // Only spot and projector lights take a nested texture (checked there).
    node.check_all_used(if matches!(node.plugin.as_str(), "spot" | "projector") { &[Kind::Texture] } else { &[] })?;
    Ok(light)
}

fn area_at_top_level(node: &Node) -> Result<PendingLight> {
    Err(node.error(format!("the '{}' emitter must be nested inside a shape", node.plugin)))
}

/// Mitsuba's `directionalarea` on the shape `shape_node`: `radiance` (a
/// colour, default 1) along the shape's normals.
fn directional_area(en: &Node, shape_node: &Node, shape: &Shape) -> Result<Emission> {
    if let Some(c) = en.children_of(Kind::Texture).next() {
        return Err(LoadError::at(&c.loc, "directionalarea: a textured radiance is not supported; give a colour"));
    }
    if en.has("to_world") {
        return Err(LoadError::at(
            en.loc_of("to_world"),
            "a directionalarea emitter takes no 'to_world': it inherits its shape's transformation (as in Mitsuba)",
        ));
    }
    let radiance = rgb(en.get_rgb("radiance")?.unwrap_or([1.0; 3]));
    if radiance.min_element() < 0.0 {
        return Err(LoadError::at(en.loc_of("radiance"), "directionalarea: radiance must not be negative"));
    }
    en.check_all_used(&[])?;
    if shape.area() <= 0.0 {
        return Err(shape_node.error("a directionalarea emitter's shape has zero area"));
    }
    Ok(Emission::Directional(radiance))
}

fn constant(node: &Node) -> Result<PendingLight> {
    let radiance = node.get_rgb("radiance")?.unwrap_or([1.0; 3]);
    Ok(ready(Light::Constant(ConstantLight { radiance: rgb(radiance) })))
}

fn point(node: &Node) -> Result<PendingLight> {
    let to_world = node.transform("to_world")?;
    let position = match node.get_point("position")? {
        Some(p) if node.has("to_world") => {
            return Err(LoadError::at(
                node.loc_of("position"),
                format!("point light: give either 'position' ({p}) or 'to_world', not both"),
            ))
        }
        Some(p) => p,
        None => to_world.transform_point3(DVec3::ZERO),
    };
    let intensity = rgb(node.get_rgb("intensity")?.unwrap_or([1.0; 3]));
    Ok(ready(Light::Point(PointLight { position: position.as_vec3(), intensity })))
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn spot(node: &Node) -> Result<PendingLight> {
    let to_world = node.transform("to_world")?;
    let intensity = rgb(node.get_rgb("intensity")?.unwrap_or([1.0; 3]));
    let cutoff = node.float("cutoff_angle", 20.0)?;
    let beam = node.float("beam_width", cutoff * 0.75)?;
    if !(cutoff > 0.0 && cutoff <= 180.0 && beam >= 0.0 && beam < cutoff) {
        return Err(node.error("spot light: need 0 <= beam_width < cutoff_angle <= 180 (degrees)"));
    }
    let mut light = SpotLight::new(to_world.as_mat4(), intensity, cutoff as f32, beam as f32);
    if let Some(c) = node.children_of(Kind::Texture).find(|c| c.name.as_deref() != Some("texture")) {
        return Err(LoadError::at(&c.loc, "a spot light takes one nested texture, named 'texture'"));
    }
    if let Some(child) = node.children_of(Kind::Texture).find(|c| c.name.as_deref() == Some("texture")) {
        // Mitsuba requires a spatially varying texture here.
        match super::texture::build_bitmap_texture(&child.node)? {
            Texture::Bitmap(b) if child.node.plugin == "bitmap" => light.texture = Some(b),
            _ => return Err(LoadError::at(&child.loc, "the spot light's 'texture' must be a bitmap")),
        }
        child.node.check_all_used(&[])?;
    }
    Ok(ready(Light::Spot(light)))
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn directional(node: &Node) -> Result<PendingLight> {
    let to_world = node.transform("to_world")?;
    let dir = match node.get_point("direction")? {
        Some(_) if node.has("to_world") => {
            return Err(node.error("directional light: give either 'direction' or 'to_world', not both"))
        }
        Some(d) => d,
        None => to_world.transform_vector3(DVec3::Z),
    };
    if !(dir.length() > 0.0) {
        return Err(node.error("directional light: the direction must not be zero"));
    }
    let irradiance = rgb(node.get_rgb("irradiance")?.unwrap_or([1.0; 3]));
    let direction = dir.normalize().as_vec3();
    Ok(Box::new(move |scene_radius| Light::Directional(DirectionalLight { direction, irradiance, scene_radius })))
}

fn envmap(node: &Node) -> Result<PendingLight> {
    let (file, loc) = node
        .get_string("filename")?
        .ok_or_else(|| node.error("envmap needs a 'filename' (.exr, .hdr, .png or .jpg)"))?;
    let path = resolve(&loc, &file, "environment map")?;
    let img = image_io::read_image(&path).map_err(|e| LoadError::at(&loc, e))?;
    let scale = node.float("scale", 1.0)?;
    let to_world = node.transform("to_world")?;
    let light = EnvMapLight::new(img.width as usize, img.height as usize, img.pixels, to_world.as_mat4(), scale as f32)
        .map_err(|e| LoadError::at(&loc, format!("'{}': {e}", path.display())))?;
    Ok(ready(Light::EnvMap(light)))
}

/// Mitsuba's `projector`: `irradiance` (a colour or a nested bitmap named
/// `irradiance`, default 1), `scale`, `to_world` and the perspective
/// sensor's `fov` / `focal_length` / `fov_axis` over the image's aspect ratio.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn projector(node: &Node) -> Result<PendingLight> {
    let to_world = node.transform("to_world")?;
    if let Some(c) = node.children_of(Kind::Texture).find(|c| c.name.as_deref() != Some("irradiance")) {
        return Err(LoadError::at(&c.loc, "a projector takes one nested texture, named 'irradiance'"));
    }
    let irradiance = match node.children_of(Kind::Texture).next() {
        Some(child) => {
            let t = super::texture::build_bitmap_texture(&child.node)?;
            child.node.check_all_used(&[])?;
            t
        }
        None => {
            let c = rgb(node.get_rgb("irradiance")?.unwrap_or([1.0; 3]));
            if c.min_element() < 0.0 {
                return Err(LoadError::at(node.loc_of("irradiance"), "projector: irradiance must not be negative"));
            }
            Texture::Constant(c)
        }
    };
    let scale = node.float("scale", 1.0)?;
    if !(scale >= 0.0) {
        return Err(LoadError::at(node.loc_of("scale"), "projector: scale must not be negative"));
    }
    let (w, h) = match &irradiance {
        Texture::Bitmap(b) => b.resolution(),
        _ => (1, 1),
    };
    let aspect = w as f32 / h as f32;
    let (fov, axis) = super::fov::fov_and_axis(node)?;
    let tan_x = tan_half_x(fov as f32, axis, aspect);
    let tan_half = glam::Vec2::new(tan_x, tan_x / aspect);
    let light = ProjectorLight::new(to_world.as_mat4(), irradiance, scale as f32, tan_half);
    Ok(ready(Light::Projector(light)))
}
