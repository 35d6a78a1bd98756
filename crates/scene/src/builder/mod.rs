//! Mitsuba scene description → calls of the format-neutral
//! [`SceneBuilder`], which assembles the render job: one file per object
//! kind (`shape`, `bsdf`, `texture`, `emitter`, `sensor`, `integrator`,
//! `medium`), each translating its plugins' parameters into render values,
//! orchestrated by [`build`]. Every property a plugin reads is marked;
//! whatever is left unread is reported as unsupported (see `props.rs`).

mod bsdf;
mod emitter;
mod fov;
mod integrator;
mod medium;
mod multipart;
mod sensor;
mod shape;
mod texture;

use bsdf::build_material;
pub(crate) use integrator::build_integrator;
pub use integrator::integrator_from_spec;
use sensor::build_sensor;
pub use sensor::{sampler_kind, SAMPLER_OVERRIDES};
use texture::Textures;

use crate::desc::{Kind, Node, SceneDesc};
use crate::error::FileLoc;
use crate::error::{LoadError, Result};
pub use crate::scene_builder::GeometryCache;
use crate::scene_builder::{Geometry, GroupId, SceneBuilder};
use penumbra_render::integrator::{Integrator, PathIntegrator};
use penumbra_render::light::LightSelection;
use penumbra_render::render::RenderJob;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Settings from the command line that override the scene file.
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    /// `--spp`, replacing the sampler's `sample_count`.
    pub spp: Option<u32>,
    /// `--seed`, replacing the sampler's `seed`.
    pub seed: Option<u64>,
    /// `--integrator NAME[:key=value,...]`, replacing the scene's integrator.
    pub integrator: Option<String>,
    /// `--sampler NAME`, replacing the scene's sampler type (its sample count
    /// and seed stay): a Mitsuba sampler or `sobol`.
    pub sampler: Option<String>,
    /// `--envmap FILE`: an environment map added to the scene's lights
    /// (a glTF file's default white environment is then left out).
    pub envmap: Option<PathBuf>,
}

/// The environment map `--envmap` names (Mitsuba's `envmap` with its
/// defaults: +y up, scale 1).
pub fn envmap_light(path: &Path) -> Result<penumbra_render::light::Light> {
    emitter::envmap_file(path)
}

/// The integrator `--integrator NAME[:key=value,...]` gives, for a scene
/// without one of its own.
pub fn integrator_override(spec: &str) -> Result<(Integrator, LightSelection)> {
    build_integrator(&integrator_from_spec(spec, None)?)
}

/// The plugins of one kind that Penumbra builds, in the order error messages
/// list them: each entry's name and its builder. Dispatch and the list in
/// [`unsupported`]'s message both come from the table, so no plugin is
/// built without being listed, or listed without being built. A name may
/// carry a note after a space (`"area (inside a shape)"`): listed with the
/// note, matched without it.
type Plugins<F> = [(&'static str, F)];

/// The `type` an entry of a [`Plugins`] table matches.
fn plugin_type(entry: &str) -> &str {
    entry.split_once(' ').map_or(entry, |(name, _)| name)
}

/// The builder `table` holds for the plugin `name`, if any.
fn find_plugin<F: Copy>(table: &Plugins<F>, name: &str) -> Option<F> {
    table.iter().find(|(entry, _)| plugin_type(entry) == name).map(|&(_, f)| f)
}

/// The builder of `node`'s plugin, or the error listing the plugins `table` supports.
fn plugin<F: Copy>(table: &Plugins<F>, node: &Node) -> Result<F> {
    find_plugin(table, &node.plugin).ok_or_else(|| unsupported(node, table))
}

/// The entries of `table`, as messages list them.
fn listed<F>(table: &Plugins<F>) -> Vec<&'static str> {
    table.iter().map(|&(name, _)| name).collect()
}

/// Mitsuba 3.9.1 plugins Penumbra does not build, with the reason (README,
/// "Every Mitsuba 3.9.1 plugin").
const UNSUPPORTED_WHY: &[(&[&str], &str)] = &[
    (
        &["measured_polarized", "polarizer", "retarder", "circular", "stokes"],
        "polarisation needs Stokes vectors, which an RGB renderer does not carry",
    ),
    (
        &["specfilm"],
        "it records spectral bands, and Mitsuba's own RGB variants refuse it too (spectral variants only)",
    ),
    (
        &["blender"],
        "it is the mesh Mitsuba's Blender add-on passes in memory, which no scene file can describe; export the mesh as ply or serialized",
    ),
];

fn unsupported<F>(node: &Node, table: &Plugins<F>) -> LoadError {
    let why = UNSUPPORTED_WHY
        .iter()
        .find(|(names, _)| names.contains(&node.plugin.as_str()))
        .map_or(String::new(), |(_, why)| format!(" ({why})"));
    node.error(format!(
        "{} plugin '{}' is not supported by Penumbra{why}; supported {} plugins: {}",
        node.kind.tag(),
        node.plugin,
        node.kind.tag(),
        listed(table).join(", ")
    ))
}

/// The plugins of `kind` that Penumbra builds, as its error messages list
/// them (an entry may carry a note: `"area (inside a shape)"`).
pub fn supported_plugins(kind: Kind) -> Vec<&'static str> {
    match kind {
        Kind::Shape => listed(shape::SHAPES),
        Kind::Bsdf => listed(bsdf::BSDFS),
        Kind::Texture => listed(texture::TEXTURES),
        Kind::Emitter => listed(emitter::EMITTERS),
        Kind::Sensor => listed(sensor::SENSORS),
        Kind::Film => listed(sensor::FILMS),
        Kind::Rfilter => listed(sensor::RFILTERS),
        Kind::Sampler => listed(sensor::SAMPLERS),
        Kind::Integrator => listed(integrator::INTEGRATORS),
        Kind::Medium => listed(medium::MEDIA),
        Kind::Phase => listed(medium::PHASES),
        Kind::Volume => listed(medium::VOLUMES),
        Kind::Scene => Vec::new(),
    }
}

/// Builds the render job for a parsed scene.
pub fn build(desc: &SceneDesc, ov: &Overrides) -> Result<RenderJob> {
    build_cached(desc, ov, &mut GeometryCache::default())
}

/// [`build`], reusing (and refilling) `cache`: the job is bitwise the one
/// [`build`] makes. A shape's geometry is cached under its node's position,
/// plugin and properties.
pub fn build_cached(desc: &SceneDesc, ov: &Overrides, cache: &mut GeometryCache) -> Result<RenderJob> {
    build_cached_with(desc, ov, cache, &mut |_| Ok(()))
}

/// [`build_cached`], with `extra` adding shapes (or lights) of its own to
/// the scene after those of the file, before the scene is finished: the
/// Python package's in-memory meshes. Top-level `<bsdf id="...">`
/// declarations are named in the builder, so `extra` can find them with
/// [`SceneBuilder::material`].
pub fn build_cached_with(
    desc: &SceneDesc,
    ov: &Overrides,
    cache: &mut GeometryCache,
    extra: &mut dyn FnMut(&mut SceneBuilder) -> Result<()>,
) -> Result<RenderJob> {
    let root = &desc.root;
    let mut b = Builder::new(SceneBuilder::with_cache(root.loc.clone(), cache));
    let mut sensor = None;
    let mut integrator = None;
    for child in &root.children {
        let node = &child.node;
        match node.kind {
            // A declaration that a `<ref>` uses elsewhere (Mitsuba allows
            // an area emitter or a sampler at the top level, referenced from
            // a shape or the sensor): built where it is used.
            Kind::Emitter | Kind::Sampler | Kind::Film | Kind::Rfilter
                if Rc::strong_count(node) > 1 && (node.kind != Kind::Emitter || matches!(node.plugin.as_str(), "area" | "directionalarea")) => {}
            Kind::Shape => b.shape(node)?,
            Kind::Emitter => {
                // Made once the scene radius (from the builder) and the sensor are known, in document order.
                let light = emitter::top_level(node)?;
                let sensor_cx = b.sensor_cx.clone();
                let loc = node.loc.clone();
                b.scene.add_light_deferred(Box::new(move |scene_radius| {
                    let s = sensor_cx.get().ok_or_else(|| LoadError::at(&loc, "an emitter in a scene without a sensor"))?;
                    light(&emitter::LightContext { scene_radius, shutter: s.shutter, sensor_loc: s.loc.clone() })
                }))
            }
            Kind::Sensor => {
                if sensor.is_some() {
                    return Err(LoadError::at(&child.loc, "the scene has more than one sensor; Penumbra renders one"));
                }
                sensor = Some(node.clone());
            }
            Kind::Integrator => {
                if integrator.is_some() {
                    return Err(LoadError::at(&child.loc, "the scene has more than one integrator"));
                }
                integrator = Some(node.clone());
            }
            // Declared for later reference; built (and checked) when used.
            Kind::Bsdf => {
                let i = b.bsdf(node)?;
                if let Some(id) = &node.id {
                    b.scene.name_material(id, i);
                }
            }
            Kind::Texture => {
                b.textures.build(node)?;
            }
            Kind::Medium => {
                b.media.get(node, &mut b.scene)?;
            }
            _ => {
                return Err(LoadError::at(
                    &child.loc,
                    format!(
                        "a top-level {} is not supported; the scene may contain shape, emitter, bsdf, sensor and integrator objects",
                        node.kind.tag()
                    ),
                ))
            }
        }
    }
    root.check_all_used(&[
        Kind::Shape,
        Kind::Emitter,
        Kind::Sensor,
        Kind::Integrator,
        Kind::Bsdf,
        Kind::Texture,
        Kind::Sampler,
        Kind::Film,
        Kind::Rfilter,
        Kind::Medium,
    ])?;
    // A sensor nested in a shape measures over that shape.
    let (sensor, on_shape) = match (sensor, b.shape_sensors.first()) {
        (_, Some((extra, _))) if b.shape_sensors.len() > 1 => {
            return Err(extra.error("the scene has more than one sensor; Penumbra renders one"))
        }
        (Some(top), Some((nested, _))) => {
            return Err(top.error(format!(
                "the scene has more than one sensor (another at {}); Penumbra renders one",
                nested.loc
            )))
        }
        (Some(top), None) => (top, None),
        (None, Some((nested, id))) => (nested.clone(), b.scene.shape(*id).cloned()),
        (None, None) => return Err(root.error("the scene has no <sensor>; add a perspective sensor")),
    };
    let (camera, filter, film, sampler) = build_sensor(&sensor, ov, on_shape)?;
    let camera_medium = match sensor.single_child(Kind::Medium)? {
        Some(m) => Some(b.media.get(&m, &mut b.scene)?),
        None => None,
    };
    let integrator_loc = integrator.as_ref().map_or_else(|| sensor.loc.clone(), |n| n.loc.clone());
    let (integrator, selection) = match (&ov.integrator, &integrator) {
        (Some(spec), scene_node) => build_integrator(&integrator_from_spec(spec, scene_node.as_deref())?)?,
        (None, Some(node)) => build_integrator(node)?,
        (None, None) => (Integrator::Path(PathIntegrator::default()), LightSelection::Uniform),
    };
    extra(&mut b.scene)?;
    b.textures.finish_mesh_attributes(b.scene.shape_count());
    // What the declared lights need of the sensor (timed_sunsky: its shutter).
    let _ = b.sensor_cx.set(SensorContext {
        shutter: (sensor.float("shutter_open", 0.0)?, sensor.float("shutter_close", 0.0)?),
        loc: sensor.loc.clone(),
    });
    let mut scene = b.scene;
    if let Some(path) = &ov.envmap {
        scene.add_light(envmap_light(path)?, &sensor.loc)?;
    }
    scene.set_camera(camera, camera_medium);
    scene.set_film(film, filter);
    scene.set_sampler(sampler);
    scene.set_integrator(integrator, selection, &integrator_loc);
    scene.finish_cached(cache)
}

/// What declared lights need of the sensor: its shutter interval and where it is declared.
struct SensorContext {
    shutter: (f64, f64),
    loc: crate::error::FileLoc,
}

/// The translation of one scene's nodes into [`SceneBuilder`] calls, with
/// what is shared through `<ref>` by node identity.
struct Builder {
    /// The scene assembled.
    scene: SceneBuilder,
    textures: Textures,
    /// BSDF nodes already built, by node identity (shared through `<ref>`).
    bsdf_index: HashMap<*const Node, u32>,
    default_bsdf: Option<u32>,
    default_emitter_bsdf: Option<u32>,
    /// Shape groups already built, by node identity (instanced through `<ref>`).
    groups: HashMap<*const Node, GroupId>,
    /// Media, built where first used.
    media: medium::Media,
    /// Sensors nested in shapes (`irradiancemeter`), with the shape's id.
    shape_sensors: Vec<(Rc<Node>, u32)>,
    /// The sensor's part of the declared lights' context, set once the sensor is built.
    sensor_cx: Rc<std::cell::OnceCell<SensorContext>>,
}

impl Builder {
    fn new(scene: SceneBuilder) -> Self {
        Builder {
            scene,
            textures: Textures::default(),
            bsdf_index: HashMap::new(),
            default_bsdf: None,
            default_emitter_bsdf: None,
            groups: HashMap::new(),
            media: medium::Media::default(),
            shape_sensors: Vec::new(),
            sensor_cx: Rc::default(),
        }
    }

    fn bsdf(&mut self, node: &Rc<Node>) -> Result<u32> {
        let key = Rc::as_ptr(node);
        if let Some(&i) = self.bsdf_index.get(&key) {
            return Ok(i);
        }
        let m = build_material(node, &mut self.textures)?;
        let i = self.scene.add_material(m);
        self.bsdf_index.insert(key, i);
        Ok(i)
    }
}

/// Finds the file `name` given at `loc`, as Mitsuba's file resolver does:
/// an absolute name is taken as is; a relative one is looked up in the
/// search directories of `loc` in order (the scene's `<path>` directories,
/// latest first, then the scene file's directory and the working
/// directory; see `mitsuba::xml`). `what` names the file in the error,
/// which lists every directory searched.
pub(crate) fn resolve(loc: &FileLoc, name: &str, what: &str) -> Result<PathBuf> {
    let p = Path::new(name);
    if p.is_absolute() {
        if p.exists() {
            return Ok(p.to_path_buf());
        }
        return Err(LoadError::at(loc, format!("{what} '{name}' not found")));
    }
    let dirs = loc.search_dirs();
    if let Some(found) = dirs.iter().map(|d| d.join(p)).find(|c| c.exists()) {
        return Ok(found);
    }
    let searched: Vec<String> = dirs.iter().map(|d| format!("'{}'", d.display())).collect();
    Err(LoadError::at(loc, format!("{what} '{name}' not found (searched {})", searched.join(", "))))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each table names each plugin once, so every entry is reachable.
    #[test]
    fn plugin_tables_name_each_plugin_once() {
        let kinds = [
            Kind::Shape,
            Kind::Bsdf,
            Kind::Texture,
            Kind::Emitter,
            Kind::Sensor,
            Kind::Film,
            Kind::Rfilter,
            Kind::Sampler,
            Kind::Integrator,
            Kind::Medium,
            Kind::Phase,
            Kind::Volume,
        ];
        for kind in kinds {
            let listed = supported_plugins(kind);
            assert!(!listed.is_empty(), "{}", kind.tag());
            let mut types: Vec<&str> = listed.iter().map(|e| plugin_type(e)).collect();
            types.sort_unstable();
            types.dedup();
            assert_eq!(types.len(), listed.len(), "{}: {listed:?}", kind.tag());
        }
        assert_eq!(plugin_type("area (inside a shape)"), "area");
        assert!(find_plugin(emitter::EMITTERS, "area").is_some());
        assert!(find_plugin(emitter::EMITTERS, "area (inside a shape)").is_none());
    }
}
