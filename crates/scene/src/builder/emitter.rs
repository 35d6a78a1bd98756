//! `<emitter>` nodes → [`Light`]s: area emitters inside shapes and the
//! emitters declared at the top level.

use super::texture::Textures;
use super::{plugin, Plugins};
use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use crate::image_io;
use crate::scene_builder::Emission;
use glam::{DVec3, Vec3};
use penumbra_render::camera::tan_half_x;
use penumbra_render::geometry::Shape;
use penumbra_render::light::sunsky::{
    dir_to_sph, sun_coordinates, DateTime, Location, SunskyParams, SunskyTables, TimedRange,
};
use penumbra_render::light::{
    ConstantLight, DirectionalLight, EnvMapLight, Light, PointLight, ProjectorLight, SpotLight, SunskyLight,
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
    ("sunsky", sunsky),
    ("timed_sunsky", timed_sunsky),
];

fn rgb(v: [f64; 3]) -> Spectrum {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// What a light may need from the rest of the scene, known once the
/// geometry and the sensor are built.
pub(super) struct LightContext {
    /// The geometry's bounding radius: a directional light's flux is that
    /// through the scene's bounding disk.
    pub scene_radius: f32,
    /// The sensor's `shutter_open` and `shutter_close` (Mitsuba's defaults 0, 0).
    pub shutter: (f64, f64),
    /// Where the sensor is declared.
    pub sensor_loc: crate::error::FileLoc,
}

/// A light as declared (parsed and checked where the scene declares it),
/// made once the [`LightContext`] is known (the builder's
/// [`crate::scene_builder::PendingLight`] gets the scene radius; `mod.rs`
/// adds the sensor's part).
pub(super) type PendingLight = Box<dyn FnOnce(&LightContext) -> Result<Light>>;

/// A light that needs nothing from the rest of the scene.
fn ready(light: Light) -> PendingLight {
    Box::new(move |_| Ok(light))
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
        // Mitsuba samples a spatially varying radiance by the texture's
        // sample_position, which a volume texture lacks.
        Texture::Volume(_) => {
            let loc = &en.children_of(Kind::Texture).next().map_or(en.loc.clone(), |c| c.loc.clone());
            return Err(LoadError::at(loc, "an area emitter's radiance cannot be a volume texture"));
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
    Ok(Box::new(move |cx| {
        Ok(Light::Directional(DirectionalLight { direction, irradiance, scene_radius: cx.scene_radius }))
    }))
}

/// An `envmap` light of the image file `path` with the defaults (scale 1, identity transform).
pub(super) fn envmap_file(path: &std::path::Path) -> Result<Light> {
    let img = image_io::read_image(path).map_err(|e| LoadError::new(None, format!("--envmap: {e}")))?;
    let light = EnvMapLight::new(img.width as usize, img.height as usize, img.pixels, glam::Mat4::IDENTITY, 1.0)
        .map_err(|e| LoadError::new(None, format!("--envmap '{}': {e}", path.display())))?;
    Ok(Light::EnvMap(light))
}

fn envmap(node: &Node) -> Result<PendingLight> {
    use super::texture::{image_source, ImageSource};
    let (img, loc, name) = match image_source(node, "envmap")? {
        ImageSource::File(path, loc) => {
            (image_io::read_image(&path).map_err(|e| LoadError::at(&loc, e))?, loc, path.display().to_string())
        }
        ImageSource::Data(img, loc) => (img.as_ref().clone(), loc, "data".to_string()),
    };
    let scale = node.float("scale", 1.0)?;
    let to_world = node.transform("to_world")?;
    let light = EnvMapLight::new(img.width as usize, img.height as usize, img.pixels, to_world.as_mat4(), scale as f32)
        .map_err(|e| LoadError::at(&loc, format!("'{name}': {e}")))?;
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

/// The Hosek–Wilkie tables, read at run time (see `sunsky_data.rs`); a
/// missing or bad file is an error at the emitter.
fn sunsky_tables(node: &Node) -> Result<SunskyTables> {
    crate::sunsky_data::load().map_err(|e| node.error(format!("{}: {e}", node.plugin)))
}

/// What `sunsky` and `timed_sunsky` share (Mitsuba's `BaseSunskyEmitter`),
/// checked as Mitsuba checks it.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn sunsky_params(node: &Node) -> Result<SunskyParams> {
    let name = node.plugin.as_str();
    let sun_scale = node.float("sun_scale", 1.0)?;
    if !(sun_scale >= 0.0) {
        return Err(LoadError::at(node.loc_of("sun_scale"), format!("{name}: sun_scale must not be negative")));
    }
    let sky_scale = node.float("sky_scale", 1.0)?;
    if !(sky_scale >= 0.0) {
        return Err(LoadError::at(node.loc_of("sky_scale"), format!("{name}: sky_scale must not be negative")));
    }
    let turbidity = node.float("turbidity", 3.0)?;
    if !(1.0..=10.0).contains(&turbidity) {
        return Err(LoadError::at(
            node.loc_of("turbidity"),
            format!("{name}: turbidity {turbidity} is outside [1, 10]"),
        ));
    }
    let aperture = node.float("sun_aperture", 0.5358)?;
    if !(aperture > 0.0 && aperture < 180.0) {
        return Err(LoadError::at(
            node.loc_of("sun_aperture"),
            format!("{name}: sun_aperture {aperture} must be in ]0, 180[ degrees"),
        ));
    }
    if let Some(c) = node.children_of(Kind::Texture).next() {
        return Err(LoadError::at(
            &c.loc,
            format!("{name}: the albedo cannot be a texture (it must not vary spatially); give a colour"),
        ));
    }
    let albedo = node.get_rgb("albedo")?.unwrap_or([0.3; 3]);
    if albedo.iter().any(|a| !(0.0..=1.0).contains(a)) {
        return Err(LoadError::at(
            node.loc_of("albedo"),
            format!("{name}: albedo values must be in [0, 1], got {albedo:?}"),
        ));
    }
    let to_world = node.transform("to_world")?;
    let m = glam::DMat3::from_mat4(to_world);
    if !((m.transpose() * m).abs_diff_eq(glam::DMat3::IDENTITY, 1e-5)) {
        return Err(LoadError::at(
            node.loc_of("to_world"),
            format!("{name}: to_world must be a rotation (its directions are not rescaled)"),
        ));
    }
    Ok(SunskyParams {
        turbidity: turbidity as f32,
        albedo: albedo.map(|a| a as f32),
        sun_scale: sun_scale as f32,
        sky_scale: sky_scale as f32,
        sun_aperture: aperture as f32,
        complex_sun: node.bool("complex_sun", false)?,
        world_from_light: glam::Mat3::from_mat4(to_world.as_mat4()),
    })
}

fn location(node: &Node) -> Result<Location> {
    Ok(Location {
        latitude: node.float("latitude", 35.6894)? as f32,
        longitude: node.float("longitude", 139.6917)? as f32,
        timezone: node.float("timezone", 9.0)? as f32,
    })
}

/// Mitsuba's `sunsky`: the sun from `sun_direction` (world space) or from
/// the date, time and place (defaults: Tokyo, 10 July 2010, 15:00).
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn sunsky(node: &Node) -> Result<PendingLight> {
    let params = sunsky_params(node)?;
    const TIME_PLACE: [&str; 9] =
        ["latitude", "longitude", "timezone", "year", "month", "day", "hour", "minute", "second"];
    let (theta, phi) = match node.get_point("sun_direction")? {
        Some(d) => {
            if let Some(p) = TIME_PLACE.iter().find(|p| node.has(p)) {
                return Err(LoadError::at(
                    node.loc_of(p),
                    "sunsky: give either 'sun_direction' or the time and place, not both",
                ));
            }
            if !(d.length() > 0.0) {
                return Err(LoadError::at(node.loc_of("sun_direction"), "sunsky: sun_direction must not be zero"));
            }
            let local = params.world_from_light.transpose() * d.normalize().as_vec3();
            dir_to_sph(local.normalize())
        }
        None => {
            let t = DateTime {
                year: node.int("year", 2010)? as i32,
                month: node.int("month", 7)? as i32,
                day: node.int("day", 10)? as i32,
                hour: node.float("hour", 15.0)? as f32,
                minute: node.float("minute", 0.0)? as f32,
                second: node.float("second", 0.0)? as f32,
            };
            sun_coordinates(&t, &location(node)?)
        }
    };
    let tables = sunsky_tables(node)?;
    let light = SunskyLight::sunsky(&params, &tables, theta, phi);
    Ok(ready(Light::Sunsky { light: Box::new(light), timed: false }))
}

/// Mitsuba's `timed_sunsky`, at the sensor's instant (`shutter_open`): the
/// sensor's shutter must not be open over an interval, since Penumbra does
/// not sample ray times.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn timed_sunsky(node: &Node) -> Result<PendingLight> {
    let params = sunsky_params(node)?;
    let date = |prefix: &str, default: [i64; 3]| -> Result<DateTime> {
        Ok(DateTime {
            year: node.int(&format!("{prefix}_year"), default[0])? as i32,
            month: node.int(&format!("{prefix}_month"), default[1])? as i32,
            day: node.int(&format!("{prefix}_day"), default[2])? as i32,
            hour: 0.0,
            minute: 0.0,
            second: 0.0,
        })
    };
    let start = date("start", [2025, 1, 1])?;
    let end = date("end", [start.year as i64 + 1, start.month as i64, start.day as i64])?;
    let window_start = node.float("window_start_time", 7.0)?;
    let window_end = node.float("window_end_time", 19.0)?;
    for (p, v) in [("window_start_time", window_start), ("window_end_time", window_end)] {
        if !(0.0..=24.0).contains(&v) {
            return Err(LoadError::at(node.loc_of(p), format!("timed_sunsky: {p} {v} is outside [0, 24] hours")));
        }
    }
    if window_start > window_end {
        return Err(node.error("timed_sunsky: window_start_time is after window_end_time"));
    }
    let shutter_open = node.float("shutter_open", 0.0)?;
    let shutter_close = node.float("shutter_close", 1.0)?;
    // (Mitsuba accepts equal times, then divides by zero: every time maps to NaN.)
    if !(shutter_close > shutter_open) {
        return Err(node.error("timed_sunsky: shutter_close must be after shutter_open"));
    }
    let range = TimedRange {
        location: location(node)?,
        start,
        end,
        window_start: window_start as f32,
        window_end: window_end as f32,
        shutter_open: shutter_open as f32,
        shutter_close: shutter_close as f32,
    };
    if range.days().is_none() {
        return Err(node.error("timed_sunsky: the start date is after the end date"));
    }
    let tables = sunsky_tables(node)?;
    let loc = node.loc.clone();
    Ok(Box::new(move |cx: &LightContext| {
        let (open, close) = cx.shutter;
        if close > open {
            return Err(LoadError::at(
                &loc,
                format!(
                    "timed_sunsky: the sensor ({}) keeps its shutter open from {open} to {close}; Penumbra renders one \
                     instant (it does not sample ray times), so give the sensor no shutter interval \
                     (shutter_close = shutter_open) and choose the instant with the sensor's shutter_open and this \
                     emitter's shutter_open / shutter_close",
                    cx.sensor_loc
                ),
            ));
        }
        let (theta, phi) = range.sun_angles(open as f32);
        let light = SunskyLight::timed(&params, &tables, theta, phi);
        Ok(Light::Sunsky { light: Box::new(light), timed: true })
    }))
}
