//! Scene description → render job. The only module that knows both the
//! format-neutral description and the render types: one function per
//! object kind. Every property a plugin reads is marked; whatever is left
//! unread is reported as unsupported (see `props.rs`).

mod bsdf;
mod texture;

use bsdf::build_material;
use texture::Textures;

use crate::desc::{Kind, Node, Property, SceneDesc, Value};
use crate::error::FileLoc;
use crate::error::{LoadError, Result};
use crate::{image_io, obj, ply};
use glam::{DMat4, DVec3, Vec3};
use penumbra_render::accel::{Accel, Instance, Primitive, ShapeGroup};
use penumbra_render::bsdf::DiffuseParams;
use penumbra_render::camera::{Camera, FovAxis};
use penumbra_render::film::{Filter, FilterKind, MAX_MARGIN};
use penumbra_render::geometry::{Mesh, Shape, TriangleMesh};
use penumbra_render::integrator::{
    BruteForceIntegrator, DirectIntegrator, HemisphereSampling, Integrator, PathIntegrator, Termination,
};
use penumbra_render::light::{
    AreaLight, ConstantLight, DirectionalLight, EnvMapLight, Light, LightSelection, PointLight, SpotLight,
};
use penumbra_render::material::Material;
use penumbra_render::math::Spectrum;
use penumbra_render::render::RenderJob;
use penumbra_render::sampling::{Sampler, SamplerKind};
use penumbra_render::scene::{Scene, ShapeInfo};
use std::cell::Cell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

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
}

/// Sampler names `--sampler` accepts.
pub const SAMPLER_OVERRIDES: &[&str] =
    &["independent", "stratified", "multijitter", "orthogonal", "ldsampler", "sobol"];

const SHAPES: &[&str] =
    &["rectangle", "cube", "sphere", "disk", "cylinder", "obj", "ply", "serialized", "shapegroup", "instance"];
const EMITTERS: &[&str] = &["area (inside a shape)", "constant", "envmap", "point", "spot", "directional"];

fn unsupported(node: &Node, supported: &[&str]) -> LoadError {
    node.error(format!(
        "{} plugin '{}' is not supported by Penumbra; supported {} plugins: {}",
        node.kind.tag(),
        node.plugin,
        node.kind.tag(),
        supported.join(", ")
    ))
}

fn rgb(v: [f64; 3]) -> Spectrum {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// Builds the render job for a parsed scene.
pub fn build(desc: &SceneDesc, ov: &Overrides) -> Result<RenderJob> {
    let root = &desc.root;
    let mut b = Builder::default();
    let mut sensor = None;
    let mut integrator = None;
    for child in &root.children {
        let node = &child.node;
        match node.kind {
            // A declaration that a `<ref>` uses elsewhere (Mitsuba allows
            // an area emitter or a sampler at the top level, referenced from
            // a shape or the sensor): built where it is used.
            Kind::Emitter | Kind::Sampler | Kind::Film | Kind::Rfilter
                if Rc::strong_count(node) > 1 && (node.kind != Kind::Emitter || node.plugin == "area") => {}
            Kind::Shape => b.shape(node)?,
            Kind::Emitter => {
                let light = b.top_level_emitter(node)?;
                b.lights.push(light);
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
                b.bsdf(node)?;
            }
            Kind::Texture => {
                b.textures.build(node)?;
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
    ])?;
    let sensor = sensor.ok_or_else(|| root.error("the scene has no <sensor>; add a perspective sensor"))?;
    let (camera, filter, film, sampler) = build_sensor(&sensor, ov)?;
    let (integrator, selection) = match (&ov.integrator, &integrator) {
        (Some(spec), scene_node) => build_integrator(&integrator_from_spec(spec, scene_node.as_deref())?)?,
        (None, Some(node)) => build_integrator(node)?,
        (None, None) => (Integrator::Path(PathIntegrator::default()), LightSelection::Uniform),
    };
    b.textures.finish_mesh_attributes(b.shapes.len());
    // Lights are made once the geometry's bounds are known.
    let accel = Accel::build(&b.placed, &b.shapes, &b.instances);
    let radius = accel.bounds.bounding_radius();
    let lights = b.lights.into_iter().map(|light| light(radius)).collect();
    let mut scene = Scene::with_accel(accel, b.shapes, b.infos, b.instances, b.placed, b.materials, lights);
    scene.set_light_selection(selection);
    Ok(RenderJob {
        scene,
        camera,
        integrator,
        sampler,
        filter,
        width: film.crop_size.0,
        height: film.crop_size.1,
        crop_offset: film.crop_offset,
        full_size: film.size,
    })
}

/// A light as declared (parsed and checked where the scene declares it),
/// made once the geometry's bounding radius is known: a directional light's
/// flux is that through the scene's bounding disk.
type PendingLight = Box<dyn FnOnce(f32) -> Light>;

/// A light that needs nothing from the rest of the scene.
fn ready(light: Light) -> PendingLight {
    Box::new(move |_| light)
}

#[derive(Default)]
struct Builder {
    /// Every shape by id, shape-group members included.
    shapes: Vec<Shape>,
    infos: Vec<ShapeInfo>,
    instances: Vec<Instance>,
    /// What the scene's BVH holds, in file order: the shapes placed
    /// directly and the instances.
    placed: Vec<Primitive>,
    materials: Vec<Material>,
    textures: Textures,
    /// In scene order: area lights with their shapes, top-level emitters as declared.
    lights: Vec<PendingLight>,
    /// BSDF nodes already built, by node identity (shared through `<ref>`).
    bsdf_index: HashMap<*const Node, u32>,
    default_bsdf: Option<u32>,
    default_emitter_bsdf: Option<u32>,
    /// Shape groups already built, by node identity (instanced through `<ref>`).
    groups: HashMap<*const Node, Arc<ShapeGroup>>,
}

impl Builder {
    fn bsdf(&mut self, node: &Rc<Node>) -> Result<u32> {
        let key = Rc::as_ptr(node);
        if let Some(&i) = self.bsdf_index.get(&key) {
            return Ok(i);
        }
        let m = build_material(node, &mut self.textures)?;
        let i = self.materials.len() as u32;
        self.materials.push(m);
        self.bsdf_index.insert(key, i);
        Ok(i)
    }

    /// A top-level shape: placed directly, placed by an instance, or a
    /// shape group (placed only by instances).
    fn shape(&mut self, node: &Rc<Node>) -> Result<()> {
        match node.plugin.as_str() {
            "shapegroup" => {
                self.shape_group(node)?;
            }
            "instance" => {
                let instance = self.instance(node)?;
                self.placed.push(Primitive::Instance(self.instances.len() as u32));
                self.instances.push(instance);
            }
            _ => {
                let id = self.plain_shape(node)?;
                self.placed.push(Primitive::Shape(id));
            }
        }
        Ok(())
    }

    /// Mitsuba's `shapegroup`: its shapes are built once, as shapes of the
    /// scene (with ids, materials and object-space geometry), into a group
    /// that instances place.
    fn shape_group(&mut self, node: &Rc<Node>) -> Result<Arc<ShapeGroup>> {
        let key = Rc::as_ptr(node);
        if let Some(g) = self.groups.get(&key) {
            return Ok(g.clone());
        }
        let mut members = Vec::new();
        for child in &node.children {
            let c = &child.node;
            if c.kind != Kind::Shape {
                continue; // reported by check_all_used below
            }
            if c.plugin == "shapegroup" || c.plugin == "instance" {
                return Err(LoadError::at(
                    &child.loc,
                    format!("a {} inside a shapegroup is not supported (nested instancing)", c.plugin),
                ));
            }
            if c.single_child(Kind::Emitter)?.is_some() {
                return Err(LoadError::at(
                    &child.loc,
                    "emitters inside a shapegroup are not allowed (Mitsuba 3 forbids them too)",
                ));
            }
            members.push(self.plain_shape(c)?);
        }
        node.check_all_used(&[Kind::Shape])?;
        if members.is_empty() {
            return Err(node.error("the shapegroup holds no shapes"));
        }
        let group = Arc::new(ShapeGroup::new(members, &self.shapes));
        self.groups.insert(key, group.clone());
        Ok(group)
    }

    /// Mitsuba's `instance`: a shapegroup (by reference) placed by `to_world`.
    fn instance(&mut self, node: &Rc<Node>) -> Result<Instance> {
        let to_world = node.transform("to_world")?;
        if node.single_child(Kind::Emitter)?.is_some() || node.single_child(Kind::Bsdf)?.is_some() {
            return Err(node.error("an instance takes no emitter or bsdf; its shapegroup's shapes carry their own"));
        }
        let group_node = node
            .single_child(Kind::Shape)?
            .filter(|g| g.plugin == "shapegroup")
            .ok_or_else(|| node.error("an instance needs one shapegroup, e.g. <ref id=\"my_group\"/>"))?;
        let group = self.shape_group(&group_node)?;
        if to_world.as_mat4().determinant() == 0.0 {
            return Err(LoadError::at(node.loc_of("to_world"), "the instance's to_world is singular"));
        }
        node.check_all_used(&[Kind::Shape])?;
        Ok(Instance::new(group, to_world.as_mat4()))
    }

    /// Every other shape: geometry, BSDF and an optional area emitter.
    /// Adds it to the scene's shapes; returns its id.
    fn plain_shape(&mut self, node: &Rc<Node>) -> Result<u32> {
        let to_world = node.transform("to_world")?;
        let flip = node.bool("flip_normals", false)?;
        // Mitsuba's mesh attributes (PLY vertex colours and other properties).
        let mut attributes = Vec::new();
        let shape = match node.plugin.as_str() {
            "rectangle" | "cube" => {
                let mut m = if node.plugin == "rectangle" { TriangleMesh::rectangle() } else { TriangleMesh::cube() };
                m.transform(&to_world.as_mat4());
                if flip {
                    m.flip();
                }
                Shape::Mesh(Mesh::new(m, false))
            }
            "obj" | "ply" => {
                let (file, loc) = node
                    .get_string("filename")?
                    .ok_or_else(|| node.error(format!("{} needs a 'filename'", node.describe())))?;
                let path = resolve(&loc, &file, "mesh file")?;
                // Mitsuba flips v for OBJ by default, not for PLY.
                let flip_uv = node.bool("flip_tex_coords", node.plugin == "obj")?;
                let mut m = if node.plugin == "obj" {
                    obj::load_obj_with(&path, flip_uv)?
                } else {
                    let (m, a) = ply::load_ply_with_attributes(&path, flip_uv)?;
                    attributes = a;
                    m
                };
                let face_normals = node.bool("face_normals", false)?;
                m.transform(&to_world.as_mat4());
                if flip {
                    m.flip();
                }
                m.validate().map_err(|e| LoadError::at(&loc, format!("mesh '{}': {e}", path.display())))?;
                Shape::Mesh(Mesh::new(m, face_normals))
            }
            "serialized" => serialized_shape(node, &to_world, flip)?,
            "sphere" => {
                let c = node.get_point("center")?.unwrap_or(DVec3::ZERO);
                let r = node.float("radius", 1.0)?;
                // The sphere's own parameters compose with to_world, as in Mitsuba.
                let m = to_world * DMat4::from_translation(c) * DMat4::from_scale(DVec3::splat(r));
                let center = m.transform_point3(DVec3::ZERO);
                let axes = [DVec3::X, DVec3::Y, DVec3::Z].map(|a| m.transform_vector3(a).length());
                if (axes[0] - axes[1]).abs() > 1e-6 * axes[0] || (axes[0] - axes[2]).abs() > 1e-6 * axes[0] {
                    return Err(node.error("sphere: to_world must not scale non-uniformly (use a mesh for ellipsoids)"));
                }
                let rot = glam::DMat3::from_mat4(m) * (1.0 / axes[0]);
                Shape::sphere_rotated(center.as_vec3(), axes[0] as f32, rot.as_mat3(), flip)
            }
            "disk" => Shape::disk(to_world.as_mat4(), flip),
            "cylinder" => {
                let p0 = node.get_point("p0")?.unwrap_or(DVec3::ZERO);
                let p1 = node.get_point("p1")?.unwrap_or(DVec3::Z);
                let r = node.float("radius", 1.0)?;
                let c =
                    penumbra_render::geometry::Cylinder::new(to_world, p0, p1, r, flip).map_err(|e| node.error(e))?;
                Shape::Cylinder(c)
            }
            _ => return Err(unsupported(node, SHAPES)),
        };
        if shape.prim_count() == 0 {
            return Err(node.error(format!("{} has no triangles", node.describe())));
        }

        let emitter = node.single_child(Kind::Emitter)?;
        let bsdf_node = node.single_child(Kind::Bsdf)?;
        let bsdf = match &bsdf_node {
            Some(bn) => self.bsdf(bn)?,
            // Mitsuba's default: diffuse with reflectance 0.5, but black for
            // emitters (checked against Mitsuba 3.9: an emitter without a BSDF
            // reflects nothing).
            None if emitter.is_some() => *self.default_emitter_bsdf.get_or_insert_with(|| {
                self.materials.push(Material::Diffuse(DiffuseParams { reflectance: Spectrum::ZERO.into() }));
                (self.materials.len() - 1) as u32
            }),
            None => *self.default_bsdf.get_or_insert_with(|| {
                self.materials.push(Material::Diffuse(DiffuseParams { reflectance: Spectrum::splat(0.5).into() }));
                (self.materials.len() - 1) as u32
            }),
        };
        let shape_id = self.shapes.len() as u32;
        if let Some(bn) = &bsdf_node {
            let indices = if let Shape::Mesh(m) = &shape { Some(&m.mesh.indices[..]) } else { None };
            self.textures.bind_mesh_attributes(bn, shape_id, node, &attributes, indices)?;
        }
        let light = match emitter {
            Some(en) => {
                if en.plugin != "area" {
                    return Err(
                        en.error(format!("emitter '{}' cannot be attached to a shape; only 'area' can", en.plugin))
                    );
                }
                let radiance =
                    en.get_rgb("radiance")?.ok_or_else(|| en.error("area emitter needs a 'radiance' value"))?;
                en.check_all_used(&[])?;
                if shape.area() <= 0.0 {
                    return Err(node.error("an area emitter's shape has zero area"));
                }
                self.lights.push(ready(Light::Area(AreaLight { shape: shape_id, radiance: rgb(radiance) })));
                Some((self.lights.len() - 1) as u32)
            }
            None => None,
        };
        node.check_all_used(&[Kind::Bsdf, Kind::Emitter])?;
        self.shapes.push(shape);
        self.infos.push(ShapeInfo { material: bsdf, light });
        Ok(shape_id)
    }

    /// Emitters declared at the top level (not attached to a shape).
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    fn top_level_emitter(&mut self, node: &Node) -> Result<PendingLight> {
        let light: PendingLight = match node.plugin.as_str() {
            "constant" => {
                let radiance = node.get_rgb("radiance")?.unwrap_or([1.0; 3]);
                ready(Light::Constant(ConstantLight { radiance: rgb(radiance) }))
            }
            "point" => {
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
                ready(Light::Point(PointLight { position: position.as_vec3(), intensity }))
            }
            "spot" => {
                let to_world = node.transform("to_world")?;
                let intensity = rgb(node.get_rgb("intensity")?.unwrap_or([1.0; 3]));
                let cutoff = node.float("cutoff_angle", 20.0)?;
                let beam = node.float("beam_width", cutoff * 0.75)?;
                if !(cutoff > 0.0 && cutoff <= 180.0 && beam >= 0.0 && beam < cutoff) {
                    return Err(node.error("spot light: need 0 <= beam_width < cutoff_angle <= 180 (degrees)"));
                }
                ready(Light::Spot(SpotLight::new(to_world.as_mat4(), intensity, cutoff as f32, beam as f32)))
            }
            "directional" => {
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
                Box::new(move |scene_radius| {
                    Light::Directional(DirectionalLight { direction, irradiance, scene_radius })
                })
            }
            "envmap" => {
                let (file, loc) = node
                    .get_string("filename")?
                    .ok_or_else(|| node.error("envmap needs a 'filename' (.exr, .hdr, .png or .jpg)"))?;
                let path = resolve(&loc, &file, "environment map")?;
                let img = image_io::read_image(&path).map_err(|e| LoadError::at(&loc, e))?;
                let scale = node.float("scale", 1.0)?;
                let to_world = node.transform("to_world")?;
                let light = EnvMapLight::new(
                    img.width as usize,
                    img.height as usize,
                    img.pixels,
                    to_world.as_mat4(),
                    scale as f32,
                )
                .map_err(|e| LoadError::at(&loc, format!("'{}': {e}", path.display())))?;
                ready(Light::EnvMap(light))
            }
            "area" => return Err(node.error("an 'area' emitter must be nested inside a shape")),
            _ => return Err(unsupported(node, EMITTERS)),
        };
        node.check_all_used(&[])?;
        Ok(light)
    }
}

/// Mitsuba's `serialized` shape: one mesh (`shape_index`) of a `.serialized` file.
fn serialized_shape(node: &Node, to_world: &DMat4, flip: bool) -> Result<Shape> {
    let (file, loc) =
        node.get_string("filename")?.ok_or_else(|| node.error("serialized needs a 'filename'".to_string()))?;
    let path = resolve(&loc, &file, "mesh file")?;
    let index = node.int("shape_index", 0)?;
    if index < 0 {
        return Err(LoadError::at(node.loc_of("shape_index"), "shape_index must be nonnegative"));
    }
    let s = crate::serialized::load_serialized(&path, index as usize)
        .map_err(|e| LoadError::at(&loc, format!("'{}': {}", path.display(), e.message)))?;
    // Mitsuba 3.9.1 ignores the file's face-normals flag (0x0010); so do we.
    let face_normals = node.bool("face_normals", false)?;
    let mut m = s.mesh;
    m.transform(&to_world.as_mat4());
    if !face_normals && m.normals.is_empty() {
        // As Mitsuba: smooth normals from the (world-space) faces.
        m.recompute_vertex_normals();
    }
    if flip {
        m.flip();
    }
    Ok(Shape::Mesh(Mesh::new(m, face_normals)))
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

const INTEGRATORS: &[&str] = &["path", "direct", "bruteforce"];

/// Termination parameters shared by `path` and `bruteforce`.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn termination(node: &Node) -> Result<Termination> {
    let max_depth = node.int("max_depth", -1)?;
    let rr_depth = node.int("rr_depth", 5)?;
    if max_depth < -1 {
        return Err(LoadError::at(node.loc_of("max_depth"), "max_depth must be -1 (unbounded) or >= 0"));
    }
    if rr_depth <= 0 {
        return Err(LoadError::at(node.loc_of("rr_depth"), "rr_depth must be positive"));
    }
    let threshold = node.float("throughput_threshold", 0.0)?;
    if !(threshold >= 0.0) {
        return Err(LoadError::at(node.loc_of("throughput_threshold"), "throughput_threshold must be >= 0"));
    }
    Ok(Termination {
        max_depth: if max_depth < 0 { u32::MAX } else { max_depth.min(u32::MAX as i64 - 1) as u32 },
        rr_depth: rr_depth.min(u32::MAX as i64) as u32,
        throughput_threshold: threshold as f32,
    })
}

fn light_selection(node: &Node) -> Result<LightSelection> {
    match node.string("light_selection", "uniform")?.as_str() {
        "uniform" => Ok(LightSelection::Uniform),
        "power" => Ok(LightSelection::Power),
        "bvh" => Ok(LightSelection::Bvh),
        other => Err(LoadError::at(
            node.loc_of("light_selection"),
            format!("light_selection '{other}' is not one of uniform, power, bvh"),
        )),
    }
}

fn count(node: &Node, name: &str, default: i64) -> Result<u32> {
    let v = node.int(name, default)?;
    if !(0..=1 << 20).contains(&v) {
        return Err(LoadError::at(node.loc_of(name), format!("{name} must be between 0 and 2^20")));
    }
    Ok(v as u32)
}

/// Builds an integrator and the light-selection strategy it asks for.
fn build_integrator(node: &Node) -> Result<(Integrator, LightSelection)> {
    let result = match node.plugin.as_str() {
        "path" => (
            Integrator::Path(PathIntegrator {
                term: termination(node)?,
                hide_emitters: node.bool("hide_emitters", false)?,
                mis: node.bool("mis", true)?,
            }),
            light_selection(node)?,
        ),
        "direct" => {
            let shading = node.get_int("shading_samples")?;
            let default = shading.unwrap_or(1);
            (
                Integrator::Direct(DirectIntegrator {
                    emitter_samples: count(node, "emitter_samples", default)?,
                    bsdf_samples: count(node, "bsdf_samples", default)?,
                    hide_emitters: node.bool("hide_emitters", false)?,
                }),
                light_selection(node)?,
            )
        }
        "bruteforce" => {
            let sampling = match node.string("sampling", "cosine")?.as_str() {
                "uniform" => HemisphereSampling::Uniform,
                "cosine" => HemisphereSampling::Cosine,
                "bsdf" => HemisphereSampling::Bsdf,
                other => {
                    return Err(LoadError::at(
                        node.loc_of("sampling"),
                        format!("sampling '{other}' is not one of uniform, cosine, bsdf"),
                    ))
                }
            };
            (
                Integrator::BruteForce(BruteForceIntegrator {
                    term: termination(node)?,
                    hide_emitters: node.bool("hide_emitters", false)?,
                    sampling,
                }),
                LightSelection::Uniform,
            )
        }
        _ => return Err(unsupported(node, INTEGRATORS)),
    };
    node.check_all_used(&[])?;
    Ok(result)
}

/// Parameters that carry over from the scene's integrator to one chosen on
/// the command line, so estimators compare on equal terms.
const SHARED_INTEGRATOR_PARAMS: &[&str] = &["max_depth", "rr_depth", "hide_emitters"];

/// Turns `--integrator NAME[:key=value,...]` into an integrator node, typing
/// each value as Mitsuba's XML would (boolean, integer, float, else string)
/// and filling unset shared parameters from the scene's integrator.
pub fn integrator_from_spec(spec: &str, scene_integrator: Option<&Node>) -> Result<Node> {
    let loc = FileLoc::new(std::sync::Arc::new(PathBuf::from("--integrator")), 0, 0);
    let (name, rest) = spec.split_once(':').unwrap_or((spec, ""));
    let mut props = Vec::new();
    for kv in rest.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (k, v) = kv.split_once('=').ok_or_else(|| {
            LoadError::new(None, format!("--integrator: '{kv}' is not of the form key=value (in '{spec}')"))
        })?;
        let value = match v {
            "true" => Value::Boolean(true),
            "false" => Value::Boolean(false),
            _ => match (v.parse::<i64>(), v.parse::<f64>()) {
                (Ok(i), _) => Value::Integer(i),
                (_, Ok(f)) => Value::Float(f),
                _ => Value::String(v.to_string()),
            },
        };
        props.push(Property { name: k.to_string(), value, loc: loc.clone(), used: Cell::new(false) });
    }
    let accepts = |param: &str| match name {
        "direct" => param == "hide_emitters",
        _ => true,
    };
    if let Some(scene) = scene_integrator {
        for p in &scene.props {
            if SHARED_INTEGRATOR_PARAMS.contains(&p.name.as_str())
                && accepts(&p.name)
                && !props.iter().any(|q: &Property| q.name == p.name)
            {
                props.push(Property { used: Cell::new(false), ..p.clone() });
            }
        }
    }
    Ok(Node {
        kind: Kind::Integrator,
        plugin: name.to_string(),
        id: None,
        name: None,
        props,
        children: Vec::new(),
        loc,
    })
}

/// Film geometry: full size and the crop window rendered.
struct FilmRect {
    size: (u32, u32),
    crop_offset: (u32, u32),
    crop_size: (u32, u32),
}

type SensorParts = (Camera, Filter, FilmRect, Sampler);

/// Field of view in degrees along `fov_axis`: `fov`, or Mitsuba's
/// `focal_length` ("50mm" by default), a 35 mm-equivalent focal length that
/// fixes the diagonal field of view (the 36x24 mm frame's diagonal is 43.27 mm).
fn field_of_view(node: &Node) -> Result<(f64, Option<FovAxis>)> {
    let fov = node.get_float("fov")?;
    let focal = node.get_string("focal_length")?;
    match (fov, focal) {
        (Some(_), Some((_, loc))) => Err(LoadError::at(&loc, "give either 'fov' or 'focal_length', not both")),
        (Some(f), None) => {
            if !(f > 0.0 && f < 180.0) {
                return Err(LoadError::at(node.loc_of("fov"), "fov must lie in (0, 180) degrees"));
            }
            Ok((f, None))
        }
        (None, focal) => {
            let (text, loc) = focal.unwrap_or_else(|| ("50mm".to_string(), node.loc.clone()));
            let mm: f64 = text
                .trim()
                .strip_suffix("mm")
                .and_then(|v| v.trim().parse().ok())
                .filter(|v: &f64| *v > 0.0)
                .ok_or_else(|| LoadError::at(&loc, format!("focal_length '{text}' is not of the form '50mm'")))?;
            let diagonal = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
            Ok((2.0 * (diagonal / (2.0 * mm)).atan().to_degrees(), Some(FovAxis::Diagonal)))
        }
    }
}

/// The sensor's projection parameters, read as Mitsuba 3.9.1's
/// `perspective`, `thinlens` and `orthographic` read them.
enum SensorModel {
    Perspective { fov: f64, axis: FovAxis },
    ThinLens { fov: f64, axis: FovAxis, aperture_radius: f64, focus_distance: f64 },
    Orthographic,
}

fn fov_and_axis(node: &Node) -> Result<(f64, FovAxis)> {
    let (fov, forced_axis) = field_of_view(node)?;
    let axis = match node.string("fov_axis", "x")?.as_str() {
        _ if forced_axis.is_some() => forced_axis.unwrap_or(FovAxis::X),
        "x" => FovAxis::X,
        "y" => FovAxis::Y,
        "diagonal" => FovAxis::Diagonal,
        "smaller" => FovAxis::Smaller,
        "larger" => FovAxis::Larger,
        other => {
            return Err(LoadError::at(
                node.loc_of("fov_axis"),
                format!("fov_axis '{other}' is not one of x, y, diagonal, smaller, larger"),
            ))
        }
    };
    Ok((fov, axis))
}

/// Whether a camera-to-world matrix scales (Mitsuba's `has_scale`: some
/// column of the linear part is not of unit length).
fn has_scale(m: &glam::DMat4) -> bool {
    [m.x_axis, m.y_axis, m.z_axis].iter().any(|c| (c.truncate().length_squared() - 1.0).abs() > 1e-3)
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn sensor_model(node: &Node, to_world: &glam::DMat4, far: f64) -> Result<SensorModel> {
    match node.plugin.as_str() {
        "perspective" => {
            let (fov, axis) = fov_and_axis(node)?;
            Ok(SensorModel::Perspective { fov, axis })
        }
        "thinlens" => {
            let (fov, axis) = fov_and_axis(node)?;
            let aperture_radius = node
                .get_float("aperture_radius")?
                .ok_or_else(|| node.error("thinlens: 'aperture_radius' is required"))?;
            if !(aperture_radius >= 0.0) {
                return Err(LoadError::at(node.loc_of("aperture_radius"), "aperture_radius must not be negative"));
            }
            // Mitsuba replaces a zero radius by machine epsilon (with a warning).
            let aperture_radius = if aperture_radius == 0.0 { f32::EPSILON as f64 } else { aperture_radius };
            let focus_distance = node.float("focus_distance", far)?;
            if !(focus_distance > 0.0) {
                return Err(LoadError::at(node.loc_of("focus_distance"), "focus_distance must be positive"));
            }
            if has_scale(to_world) {
                return Err(node.error(
                    "thinlens: scale factors in the camera-to-world transformation are not allowed (as in Mitsuba)",
                ));
            }
            Ok(SensorModel::ThinLens { fov, axis, aperture_radius, focus_distance })
        }
        "orthographic" => Ok(SensorModel::Orthographic),
        _ => Err(unsupported(node, &["perspective", "thinlens", "orthographic"])),
    }
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn build_sensor(node: &Node, ov: &Overrides) -> Result<SensorParts> {
    if !matches!(node.plugin.as_str(), "perspective" | "thinlens" | "orthographic") {
        return Err(unsupported(node, &["perspective", "thinlens", "orthographic"]));
    }
    let to_world = node.transform("to_world")?;
    let near = node.float("near_clip", 0.01)?;
    let far = node.float("far_clip", 10000.0)?;
    if !(near > 0.0 && far > near) {
        return Err(node.error("near_clip must be positive and smaller than far_clip"));
    }
    let model = sensor_model(node, &to_world, far)?;
    if !matches!(model, SensorModel::Orthographic) {
        for p in ["principal_point_offset_x", "principal_point_offset_y"] {
            if node.float(p, 0.0)? != 0.0 {
                return Err(LoadError::at(node.loc_of(p), format!("{p} is not supported yet")));
            }
        }
    }
    node.accept(&["shutter_open", "shutter_close"]);
    // Every projective camera of Mitsuba reads it; only thinlens uses it.
    node.accept(&["focus_distance"]);

    // Film.
    let film =
        node.single_child(Kind::Film)?.ok_or_else(|| node.error("the sensor needs a <film type=\"hdrfilm\">"))?;
    if film.plugin != "hdrfilm" {
        return Err(unsupported(&film, &["hdrfilm"]));
    }
    let width = film.int("width", 768)?;
    let height = film.int("height", 576)?;
    if !(1..=1 << 16).contains(&width) || !(1..=1 << 16).contains(&height) {
        return Err(film.error("film width and height must be between 1 and 65536"));
    }
    let (w, h) = (width as u32, height as u32);
    let cx = film.int("crop_offset_x", 0)?;
    let cy = film.int("crop_offset_y", 0)?;
    let cw = film.int("crop_width", width)?;
    let ch = film.int("crop_height", height)?;
    if cx < 0 || cy < 0 || cw < 1 || ch < 1 || cx + cw > width || cy + ch > height {
        return Err(film.error(format!(
            "the crop window ({cx}, {cy}) + ({cw} x {ch}) does not lie inside the {width} x {height} film"
        )));
    }
    let rect = FilmRect { size: (w, h), crop_offset: (cx as u32, cy as u32), crop_size: (cw as u32, ch as u32) };
    // Output-format settings that cannot change the rendered values.
    film.accept(&["pixel_format", "component_format", "file_format", "sample_border", "compensate"]);
    let filter = match film.single_child(Kind::Rfilter)? {
        None => Filter::new(FilterKind::Gaussian { stddev: 0.5 }),
        Some(f) => {
            let kind = match f.plugin.as_str() {
                "box" => FilterKind::Box,
                "tent" => FilterKind::Tent { radius: f.float("radius", 1.0)? as f32 },
                "gaussian" => FilterKind::Gaussian { stddev: f.float("stddev", 0.5)? as f32 },
                _ => return Err(unsupported(&f, &["box", "tent", "gaussian"])),
            };
            f.check_all_used(&[])?;
            let filter = Filter::new(kind);
            if filter.margin() > MAX_MARGIN || !(filter.radius > 0.0) {
                return Err(f.error(format!(
                    "the {} filter's radius {} is not supported: it must be positive and reach at most {MAX_MARGIN} pixels",
                    f.plugin, filter.radius
                )));
            }
            filter
        }
    };
    film.check_all_used(&[Kind::Rfilter])?;

    // Sampler.
    let (kind, mut spp, mut seed) = match node.single_child(Kind::Sampler)? {
        None => (SamplerKind::Independent, 4, 0),
        Some(s) => {
            let kind = match s.plugin.as_str() {
                "independent" => SamplerKind::Independent,
                "stratified" => {
                    if !s.bool("jitter", true)? {
                        return Err(LoadError::at(s.loc_of("jitter"), "stratified: jitter=false is not supported"));
                    }
                    SamplerKind::Stratified
                }
                "multijitter" => SamplerKind::Multijitter { jitter: s.bool("jitter", true)? },
                "orthogonal" => {
                    if s.int("strength", 2)? != 2 {
                        return Err(LoadError::at(
                            s.loc_of("strength"),
                            "orthogonal: only strength 2 (Bose construction, the default) is supported",
                        ));
                    }
                    SamplerKind::Orthogonal { jitter: s.bool("jitter", true)? }
                }
                "ldsampler" => SamplerKind::LowDiscrepancy,
                _ => {
                    return Err(unsupported(
                        &s,
                        &["independent", "stratified", "multijitter", "orthogonal", "ldsampler"],
                    ))
                }
            };
            let spp = s.int("sample_count", 4)?;
            let seed = s.int("seed", 0)?;
            if spp < 1 || spp > u32::MAX as i64 {
                return Err(LoadError::at(s.loc_of("sample_count"), "sample_count must be a positive integer"));
            }
            s.check_all_used(&[])?;
            (kind, spp as u32, seed as u64)
        }
    };
    let kind = match ov.sampler.as_deref() {
        None => kind,
        Some("independent") => SamplerKind::Independent,
        Some("stratified") => SamplerKind::Stratified,
        Some("multijitter") => SamplerKind::Multijitter { jitter: true },
        Some("orthogonal") => SamplerKind::Orthogonal { jitter: true },
        Some("ldsampler") => SamplerKind::LowDiscrepancy,
        Some("sobol") => SamplerKind::Sobol,
        Some(other) => {
            return Err(LoadError::new(
                None,
                format!("--sampler {other}: unknown sampler; use one of {}", SAMPLER_OVERRIDES.join(", ")),
            ))
        }
    };
    if let Some(o) = ov.spp {
        spp = o;
    }
    // Mitsuba's stratified samplers round the count up to what their
    // construction needs (checked with 3.9.1, e.g. stratified 10 -> 16,
    // multijitter 10 -> 12, orthogonal 16 -> 25, ldsampler 17 -> 64).
    spp = kind.round_sample_count(spp);
    if let Some(o) = ov.seed {
        seed = o;
    }
    node.check_all_used(&[Kind::Film, Kind::Sampler])?;
    let (m, w, h) = (to_world.as_mat4(), width as u32, height as u32);
    let camera = match model {
        SensorModel::Perspective { fov, axis } => Camera::new(m, fov as f32, axis, w, h, near as f32, far as f32),
        SensorModel::ThinLens { fov, axis, aperture_radius, focus_distance } => Camera::thin_lens(
            m,
            fov as f32,
            axis,
            w,
            h,
            near as f32,
            far as f32,
            aperture_radius as f32,
            focus_distance as f32,
        ),
        SensorModel::Orthographic => Camera::orthographic(m, w, h, near as f32, far as f32),
    };
    Ok((camera, filter, rect, Sampler::new(kind, seed, spp)))
}
