//! The format-neutral scene builder: every scene reader translates its
//! format into calls of [`SceneBuilder`], which assembles the render job.
//!
//! Inputs are plain values: meshes as arrays ([`MeshData`]), images as pixel
//! buffers ([`RgbImage`], made textures by [`image_texture`]), the render
//! crate's materials, textures, lights, camera, filter, sampler and
//! integrator. The builder owns the assembly every format needs: shape and
//! material ids, area lights on shapes, instancing (one group of shapes
//! placed by many transforms), media on shapes, the BVH, the lights that
//! depend on the scene's size, the camera's scene bounds, and the reuse of
//! unchanged geometry across rebuilds ([`GeometryCache`]).
//!
//! Every call that can fail takes the [`Location`] of what it is given (file
//! and line for text formats, a JSON pointer for glTF, a byte offset for
//! binary files), and its error names it.
//!
//! ```
//! use penumbra_render::bsdf::DiffuseParams;
//! use penumbra_render::camera::{Camera, FovAxis};
//! use penumbra_render::film::{Filter, FilterKind};
//! use penumbra_render::material::Material;
//! use penumbra_render::math::look_at;
//! use penumbra_render::texture::{FilterType, WrapMode};
//! use penumbra_scene::image_io::RgbImage;
//! use penumbra_scene::scene_builder::{image_texture, Emission, Film, Location, MeshData, SceneBuilder, ShapeDesc};
//! use glam::{Affine2, Mat4, Vec2, Vec3};
//!
//! let at = Location::new(std::sync::Arc::new("memory".into()), 0, 0);
//! let mut scene = SceneBuilder::new(at.clone());
//! // A 2x2 checker image as the quad's reflectance.
//! let image = RgbImage { width: 2, height: 2, pixels: vec![[0.8; 3], [0.2; 3], [0.2; 3], [0.8; 3]] };
//! let texture = image_texture(image, FilterType::Nearest, WrapMode::Repeat, Affine2::IDENTITY, &at)?;
//! let material = scene.add_material(Material::Diffuse(DiffuseParams { reflectance: texture }));
//! let quad = MeshData {
//!     positions: [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]].map(|[x, y]| Vec3::new(x, y, 0.0)).to_vec(),
//!     uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
//!     indices: vec![[0, 1, 2], [0, 2, 3]],
//!     ..MeshData::default()
//! };
//! let geometry = quad.clone().into_geometry(&Mat4::IDENTITY, false, false, &at)?;
//! let id = scene.add_shape(ShapeDesc::new(geometry, material), &at)?;
//! scene.place_shape(id);
//! // A small emitting quad above it, placed by a transform.
//! // Facing down: the winding reversed.
//! let lamp = MeshData { indices: vec![[0, 2, 1], [0, 3, 2]], uvs: Vec::new(), ..quad.clone() };
//! let black = scene.add_material(Material::Diffuse(DiffuseParams { reflectance: Vec3::ZERO.into() }));
//! let to_world = Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0)) * Mat4::from_scale(Vec3::splat(0.2));
//! let lamp = lamp.into_geometry(&to_world, false, false, &at)?;
//! let emission = Some(Emission::Diffuse(Vec3::splat(10.0).into()));
//! let id = scene.add_shape(ShapeDesc { emission, ..ShapeDesc::new(lamp, black) }, &at)?;
//! scene.place_shape(id);
//! let (w, h) = (32, 24);
//! let to_world = look_at(Vec3::new(0.0, -3.0, 3.0), Vec3::ZERO, Vec3::Z);
//! scene.set_camera(Camera::new(to_world, 45.0, FovAxis::X, w, h, 0.01, 100.0), None);
//! scene.set_film(Film::new(w, h), Filter::new(FilterKind::Gaussian { stddev: 0.5 }));
//! let job = scene.finish()?;
//! assert_eq!((job.width, job.height), (32, 24));
//! # Ok::<(), penumbra_scene::LoadError>(())
//! ```

use crate::error::{FileLoc, LoadError, Result};
use crate::image_io::RgbImage;
use glam::{Affine2, Mat4, Vec2, Vec3};
use penumbra_render::accel::{Accel, Instance, Primitive, ShapeGroup};
use penumbra_render::camera::{Camera, Projection};
use penumbra_render::film::Filter;
use penumbra_render::geometry::{Mesh, Shape, TriangleMesh};
use penumbra_render::integrator::{Integrator, ParticleTracer, PathIntegrator, DEFAULT_CAUSTICS};
use penumbra_render::light::{AreaLight, DirectionalAreaLight, Light, LightSelection};
use penumbra_render::material::Material;
use penumbra_render::math::Spectrum;
use penumbra_render::medium::Medium;
use penumbra_render::render::RenderJob;
use penumbra_render::sampling::{Sampler, SamplerKind};
use penumbra_render::scene::{Scene, ShapeInfo, ShapeMedia};
use penumbra_render::texture::{Bitmap, FilterType, MeshAttributeData, Texture, WrapMode};
use std::collections::HashMap;
use std::sync::Arc;

/// Where something was given: file and line for text formats; a position
/// of another kind (a glTF JSON pointer, a byte offset) through
/// [`FileLoc::with_place`].
pub type Location = FileLoc;

/// Index of a shape among the scene's shapes (group members included).
pub type ShapeId = u32;
/// Index of a material.
pub type MaterialId = u32;
/// Index of a shape group.
pub type GroupId = u32;
/// Index of a participating medium.
pub type MediumId = u32;

/// A shape's geometry with its mesh attributes (vertex colours and other
/// per-vertex or per-face values, which `mesh_attribute` textures read).
pub type Geometry = (Shape, Vec<MeshAttributeData>);

/// A light made once the scene's bounding radius is known (a directional
/// light's flux is that through the scene's bounding disk).
pub type PendingLight = Box<dyn FnOnce(f32) -> Result<Light>>;

/// A triangle mesh as arrays, in object space. Optional arrays are empty
/// or hold one value per vertex.
#[derive(Debug, Clone, Default)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex indices of each triangle, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals (else the face normal shades).
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates.
    pub uvs: Vec<Vec2>,
    /// Per-vertex linear RGB colours, read as the mesh attribute `vertex_color`.
    pub colors: Vec<Vec3>,
    /// Further attributes (`vertex_NAME` per vertex, `face_NAME` per triangle).
    pub attributes: Vec<MeshAttributeData>,
}

impl MeshData {
    /// The mesh placed by `to_world`, its orientation reversed if
    /// `flip_normals`, shaded by face normals if `face_normals`. Errors
    /// (an index out of range, an array of the wrong length, a position that
    /// is not finite) name `at`.
    pub fn into_geometry(
        self,
        to_world: &Mat4,
        flip_normals: bool,
        face_normals: bool,
        at: &Location,
    ) -> Result<Geometry> {
        let MeshData { positions, indices, normals, uvs, colors, mut attributes } = self;
        let (vertices, faces) = (positions.len(), indices.len());
        if !colors.is_empty() {
            if colors.len() != vertices {
                return Err(LoadError::at(at, format!("{} vertex colours for {vertices} vertices", colors.len())));
            }
            let data = colors.iter().flat_map(|c| c.to_array()).collect();
            attributes.push(MeshAttributeData { name: "vertex_color".into(), per_vertex: true, dim: 3, data });
        }
        for a in &attributes {
            let count = if a.per_vertex { vertices } else { faces };
            if a.dim == 0 || a.data.len() != a.dim * count {
                return Err(LoadError::at(
                    at,
                    format!(
                        "mesh attribute '{}' has {} values; {count} {} of {} components need {}",
                        a.name,
                        a.data.len(),
                        if a.per_vertex { "vertices" } else { "faces" },
                        a.dim,
                        a.dim * count
                    ),
                ));
            }
        }
        let mut m = TriangleMesh { positions, normals, uvs, indices };
        m.transform(to_world);
        if flip_normals {
            m.flip();
        }
        m.validate().map_err(|e| LoadError::at(at, e))?;
        Ok((Shape::Mesh(Mesh::new(m, face_normals)), attributes))
    }
}

/// An image as a texture: linear RGB texels (top row first), looked up with
/// `filter` and `wrap` at `to_uv` applied to the surface's uv.
pub fn image_texture(
    image: RgbImage,
    filter: FilterType,
    wrap: WrapMode,
    to_uv: Affine2,
    at: &Location,
) -> Result<Texture> {
    let data = image.pixels.iter().map(|p| Vec3::from_array(*p)).collect();
    let bitmap = Bitmap::new(image.width as usize, image.height as usize, data, filter, wrap, to_uv)
        .map_err(|e| LoadError::at(at, e))?;
    Ok(Texture::Bitmap(Arc::new(bitmap)))
}

/// Light a shape emits.
pub enum Emission {
    /// Diffuse: `radiance` (a colour or a texture over the surface) into
    /// the hemisphere of the shape's normal.
    Diffuse(Texture),
    /// Diffuse from both sides of the surface (pbrt-v4's `twosided`).
    DiffuseTwoSided(Texture),
    /// Along the shape's normal only (Mitsuba's `directionalarea`).
    Directional(Spectrum),
}

/// A shape as the builder takes it.
pub struct ShapeDesc {
    /// Its geometry, in world space (object space for group members).
    pub geometry: Geometry,
    /// Its material.
    pub material: MaterialId,
    /// The light it emits, if any.
    pub emission: Option<Emission>,
    /// The media inside and outside it.
    pub media: ShapeMedia,
    /// The key its geometry is cached under ([`SceneBuilder::cached_geometry`]);
    /// `None` for geometry that a rebuild makes anew.
    pub cache_key: Option<String>,
}

impl ShapeDesc {
    /// `geometry` with `material`: no emission, no media, not cached.
    pub fn new(geometry: Geometry, material: MaterialId) -> Self {
        ShapeDesc { geometry, material, emission: None, media: ShapeMedia::default(), cache_key: None }
    }
}

/// The film's geometry: its full size and the crop window rendered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Film {
    /// Full width and height in pixels.
    pub size: (u32, u32),
    /// The crop window's top-left pixel.
    pub crop_offset: (u32, u32),
    /// The crop window's width and height.
    pub crop_size: (u32, u32),
}

impl Film {
    /// A `width` × `height` film, rendered whole.
    pub fn new(width: u32, height: u32) -> Self {
        Film { size: (width, height), crop_offset: (0, 0), crop_size: (width, height) }
    }
}

/// What rebuilding the same scene with other parameters (Python's
/// `scene.set`) can reuse: each shape's geometry, keyed by what the reader
/// built it from (so a changed radius or transform rebuilds that shape),
/// and the top-level BVH when every shape it holds was reused. Reused
/// geometry is bitwise the geometry a fresh build makes from the same
/// description; mesh files are not read again, so a file changed on disk
/// needs a fresh load.
#[derive(Default)]
pub struct GeometryCache {
    /// Geometry by key, with the reader's note on it.
    shapes: HashMap<String, (Geometry, Vec<String>)>,
    /// The last top-level BVH and the shape keys it was built over.
    accel: Option<(Vec<String>, Accel)>,
    /// Shapes built (not reused) over the cache's life.
    pub shapes_built: u64,
    /// Top-level BVHs built over the cache's life.
    pub accels_built: u64,
}

/// Assembles a render job from shapes, materials, lights, media and the
/// camera; see the module documentation.
pub struct SceneBuilder {
    /// Where the scene comes from: errors about the whole scene name it.
    at: Location,
    shapes: Vec<Shape>,
    infos: Vec<ShapeInfo>,
    shape_media: Vec<ShapeMedia>,
    /// The cache key of each shape, by id (`None`: not cached).
    shape_keys: Vec<Option<String>>,
    groups: Vec<Arc<ShapeGroup>>,
    instances: Vec<Instance>,
    /// What the scene's BVH holds, in the order placed.
    placed: Vec<Primitive>,
    materials: Vec<Material>,
    material_names: HashMap<String, MaterialId>,
    /// In the order added: area lights with their shapes, the others.
    lights: Vec<PendingLight>,
    media: Vec<Medium>,
    camera: Option<(Camera, Option<MediumId>)>,
    film: Option<(Film, Filter)>,
    sampler: Option<Sampler>,
    integrator: Option<(Integrator, LightSelection, Location)>,
    /// [`GeometryCache::shapes`], taken for the build.
    cache: HashMap<String, (Geometry, Vec<String>)>,
    /// Shapes whose geometry was built, not reused.
    shapes_built: u64,
}

impl SceneBuilder {
    /// An empty scene; `at` is where it comes from (its file), named by
    /// errors about the scene as a whole.
    pub fn new(at: Location) -> Self {
        SceneBuilder {
            at,
            shapes: Vec::new(),
            infos: Vec::new(),
            shape_media: Vec::new(),
            shape_keys: Vec::new(),
            groups: Vec::new(),
            instances: Vec::new(),
            placed: Vec::new(),
            materials: Vec::new(),
            material_names: HashMap::new(),
            lights: Vec::new(),
            media: Vec::new(),
            camera: None,
            film: None,
            sampler: None,
            integrator: None,
            cache: HashMap::new(),
            shapes_built: 0,
        }
    }

    /// An empty scene that reuses the geometry `cache` holds; finish it
    /// with [`SceneBuilder::finish_cached`] and the same cache.
    pub fn with_cache(at: Location, cache: &mut GeometryCache) -> Self {
        SceneBuilder { cache: std::mem::take(&mut cache.shapes), ..SceneBuilder::new(at) }
    }

    /// The geometry cached under `key`, else the geometry `build` makes
    /// (cached under `key`), each with the note stored beside it: whatever
    /// the reader must replay when the geometry is reused (Mitsuba's reader:
    /// the properties building read). Give `key` to the shape as
    /// [`ShapeDesc::cache_key`].
    pub fn cached_geometry(
        &mut self,
        key: &str,
        build: impl FnOnce() -> Result<(Geometry, Vec<String>)>,
    ) -> Result<(Geometry, Vec<String>)> {
        if let Some(entry) = self.cache.get(key) {
            return Ok(entry.clone());
        }
        let entry = build()?;
        self.shapes_built += 1;
        self.cache.insert(key.to_string(), entry.clone());
        Ok(entry)
    }

    /// Adds a material; returns its id.
    pub fn add_material(&mut self, material: Material) -> MaterialId {
        self.materials.push(material);
        (self.materials.len() - 1) as MaterialId
    }

    /// Names the material `id` (a later name replaces an earlier one).
    pub fn name_material(&mut self, name: &str, id: MaterialId) {
        self.material_names.insert(name.to_string(), id);
    }

    /// The material named `name`, if any.
    pub fn material(&self, name: &str) -> Option<MaterialId> {
        self.material_names.get(name).copied()
    }

    /// Adds a participating medium; returns its id.
    pub fn add_medium(&mut self, medium: Medium) -> MediumId {
        self.media.push(medium);
        (self.media.len() - 1) as MediumId
    }

    /// Adds a shape (with its area light, if it emits) without placing it:
    /// [`SceneBuilder::place_shape`] places it in the scene,
    /// [`SceneBuilder::add_group`] makes it a member of a group. Returns its id.
    pub fn add_shape(&mut self, desc: ShapeDesc, at: &Location) -> Result<ShapeId> {
        let ShapeDesc { geometry: (shape, _), material, emission, media, cache_key } = desc;
        if shape.prim_count() == 0 {
            return Err(LoadError::at(at, "the shape has no triangles"));
        }
        // Finite inputs can still overflow once transformed (3e38 scaled by 2).
        if let Some(i) = (0..shape.prim_count()).find(|&i| {
            let b = shape.prim_bounds(i);
            !(b.min.is_finite() && b.max.is_finite())
        }) {
            return Err(LoadError::at(
                at,
                format!(
                    "primitive {i} of the shape lies beyond single precision in world space                      (its coordinates times its transform overflow 3.4e38); scale the scene down"
                ),
            ));
        }
        if material as usize >= self.materials.len() {
            return Err(LoadError::at(at, format!("material {material} does not exist")));
        }
        for m in [media.interior, media.exterior].into_iter().flatten() {
            if m as usize >= self.media.len() {
                return Err(LoadError::at(at, format!("medium {m} does not exist")));
            }
        }
        let id = self.shapes.len() as ShapeId;
        let light = match emission {
            None => None,
            Some(_) if !shape.can_emit() => {
                return Err(LoadError::at(at, "the shape cannot carry an area light (points on it cannot be sampled)"))
            }
            Some(_) if shape.area() <= 0.0 => return Err(LoadError::at(at, "an area light's shape has zero area")),
            Some(Emission::Diffuse(Texture::MeshAttribute(_)))
            | Some(Emission::DiffuseTwoSided(Texture::MeshAttribute(_))) => {
                return Err(LoadError::at(at, "an area light's radiance cannot be a mesh attribute"))
            }
            Some(Emission::Diffuse(Texture::Constant(c)))
            | Some(Emission::DiffuseTwoSided(Texture::Constant(c)))
            | Some(Emission::Directional(c))
                if c.min_element() < 0.0 =>
            {
                return Err(LoadError::at(at, "an area light's radiance must not be negative"))
            }
            Some(Emission::Diffuse(radiance)) => Some(Light::Area(AreaLight { shape: id, radiance, two_sided: false })),
            Some(Emission::DiffuseTwoSided(radiance)) => {
                Some(Light::Area(AreaLight { shape: id, radiance, two_sided: true }))
            }
            Some(Emission::Directional(radiance)) => {
                Some(Light::DirectionalArea(DirectionalAreaLight { shape: id, radiance }))
            }
        };
        let light = light.map(|l| {
            self.lights.push(Box::new(move |_| Ok(l)));
            (self.lights.len() - 1) as u32
        });
        self.shapes.push(shape);
        self.infos.push(ShapeInfo { material, light });
        self.shape_media.push(media);
        self.shape_keys.push(cache_key);
        Ok(id)
    }

    /// The shape `id`, as added (`None` if there is no such shape).
    pub fn shape(&self, id: ShapeId) -> Option<&Shape> {
        self.shapes.get(id as usize)
    }

    /// How many shapes have been added.
    pub fn shape_count(&self) -> usize {
        self.shapes.len()
    }

    /// Places the shape `id` in the scene as it is (world space).
    pub fn place_shape(&mut self, id: ShapeId) {
        self.placed.push(Primitive::Shape(id));
    }

    /// A group of shapes (object space, none emitting), placed only by
    /// [`SceneBuilder::add_instance`]. Returns its id.
    pub fn add_group(&mut self, members: Vec<ShapeId>, at: &Location) -> Result<GroupId> {
        if members.is_empty() {
            return Err(LoadError::at(at, "the group holds no shapes"));
        }
        if let Some(&m) = members.iter().find(|&&m| m as usize >= self.shapes.len()) {
            return Err(LoadError::at(at, format!("shape {m} does not exist")));
        }
        if members.iter().any(|&m| self.infos[m as usize].light.is_some()) {
            return Err(LoadError::at(at, "a shape in a group cannot emit light; place emitting shapes alone"));
        }
        self.groups.push(Arc::new(ShapeGroup::new(members, &self.shapes)));
        Ok((self.groups.len() - 1) as GroupId)
    }

    /// Places the group `group` by `to_world` (which must be invertible).
    pub fn add_instance(&mut self, group: GroupId, to_world: Mat4, at: &Location) -> Result<()> {
        let Some(g) = self.groups.get(group as usize) else {
            return Err(LoadError::at(at, format!("group {group} does not exist")));
        };
        if to_world.determinant() == 0.0 || !to_world.is_finite() {
            return Err(LoadError::at(at, "the instance's transform is singular"));
        }
        let instance = Instance::new(g.clone(), to_world);
        let b = instance.bounds();
        if !(b.min.is_finite() && b.max.is_finite()) {
            return Err(LoadError::at(
                at,
                "the instance lies beyond single precision in world space (its group's bounds times \
                 its transform overflow 3.4e38); scale the scene down",
            ));
        }
        self.placed.push(Primitive::Instance(self.instances.len() as u32));
        self.instances.push(instance);
        Ok(())
    }

    /// Adds a light that is not on a shape (point, spot, directional,
    /// environment, ...): a directional light's `scene_radius` is set to
    /// the scene's bounding radius when the scene is finished. Area lights
    /// come with their shape ([`ShapeDesc::emission`]).
    pub fn add_light(&mut self, light: Light, at: &Location) -> Result<()> {
        if matches!(light, Light::Area(_) | Light::DirectionalArea(_)) {
            return Err(LoadError::at(at, "an area light is given with its shape (ShapeDesc::emission)"));
        }
        self.lights.push(Box::new(move |radius| {
            Ok(match light {
                Light::Directional(mut d) => {
                    d.scene_radius = radius;
                    Light::Directional(d)
                }
                l => l,
            })
        }));
        Ok(())
    }

    /// Adds a light made from the scene's bounding radius once it is known.
    pub fn add_light_deferred(&mut self, light: PendingLight) {
        self.lights.push(light);
    }

    /// The camera, and the medium it sits in (if any). Required.
    pub fn set_camera(&mut self, camera: Camera, medium: Option<MediumId>) {
        self.camera = Some((camera, medium));
    }

    /// The film and its reconstruction filter (Mitsuba's default filter:
    /// `FilterKind::Gaussian { stddev: 0.5 }`). Required.
    pub fn set_film(&mut self, film: Film, filter: Filter) {
        self.film = Some((film, filter));
    }

    /// The sampler (default: independent, 4 samples per pixel, seed 0).
    pub fn set_sampler(&mut self, sampler: Sampler) {
        self.sampler = Some(sampler);
    }

    /// The integrator and the light selection it uses (default: `path` with
    /// uniform selection); `at` is where it is given.
    pub fn set_integrator(&mut self, integrator: Integrator, selection: LightSelection, at: &Location) {
        self.integrator = Some((integrator, selection, at.clone()));
    }

    /// The render job.
    pub fn finish(self) -> Result<RenderJob> {
        self.finish_cached(&mut GeometryCache::default())
    }

    /// The render job, refilling `cache` with this scene's geometry and
    /// reusing its BVH when the same shapes were reused: the job is bitwise
    /// the one [`SceneBuilder::finish`] makes.
    pub fn finish_cached(mut self, cache: &mut GeometryCache) -> Result<RenderJob> {
        let Some((mut camera, camera_medium)) = self.camera.take() else {
            return Err(LoadError::at(&self.at, "the scene has no camera"));
        };
        let Some((film, filter)) = self.film.take() else {
            return Err(LoadError::at(&self.at, "the scene has no film size"));
        };
        let sampler = self.sampler.take().unwrap_or_else(|| Sampler::new(SamplerKind::Independent, 0, 4));
        let (mut integrator, selection, integrator_at) = self.integrator.take().unwrap_or_else(|| {
            let path = PathIntegrator { caustics: DEFAULT_CAUSTICS, ..PathIntegrator::default() };
            (Integrator::Path(path), LightSelection::Uniform, self.at.clone())
        });
        if let Some(m) = camera_medium.filter(|&m| m as usize >= self.media.len()) {
            return Err(LoadError::at(&self.at, format!("the camera's medium {m} does not exist")));
        }
        // Reused only when every shape was cached, and without instances,
        // whose groups have BVHs of their own.
        let keys: Option<Vec<String>> =
            if self.instances.is_empty() { self.shape_keys.iter().cloned().collect() } else { None };
        let accel = match (cache.accel.take(), &keys) {
            (Some((old, accel)), Some(keys)) if old == *keys => accel,
            _ => {
                cache.accels_built += 1;
                Accel::build(&self.placed, &self.shapes, &self.instances)
            }
        };
        if let Some(keys) = keys {
            cache.accel = Some((keys, accel.clone()));
        }
        cache.shapes_built += self.shapes_built;
        cache.shapes = std::mem::take(&mut self.cache);
        let radius = accel.bounds.bounding_radius();
        camera.set_scene_bounds(accel.bounds.min, accel.bounds.max);
        let lights = self.lights.into_iter().map(|light| light(radius)).collect::<Result<Vec<_>>>()?;
        let mut scene =
            Scene::with_accel(accel, self.shapes, self.infos, self.instances, self.placed, self.materials, lights);
        if let Integrator::PTracer(pt) = &integrator {
            check_ptracer(pt, &camera, sampler.spp, &integrator_at)?;
        }
        // Light paths reach perspective and thin-lens cameras only, and are
        // not let through hidden emitters; otherwise the camera paths keep
        // the caustics.
        if let Integrator::Path(p) = &mut integrator {
            p.caustics &=
                !p.hide_emitters && matches!(camera.projection, Projection::Pinhole | Projection::ThinLens { .. });
        }
        scene.set_light_selection(selection);
        if !self.media.is_empty() {
            let shape_media =
                if self.shape_media.iter().any(ShapeMedia::is_transition) { self.shape_media } else { Vec::new() };
            scene.set_media(self.media, shape_media, camera_medium);
        }
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
            stream: true,
            packet_lanes: 0,
        })
    }
}

/// What Penumbra's `ptracer` needs: a perspective or thin-lens camera and (as Mitsuba)
/// a sample count that is a multiple of `samples_per_pass`.
fn check_ptracer(pt: &ParticleTracer, camera: &Camera, spp: u32, at: &Location) -> Result<()> {
    if !matches!(camera.projection, Projection::Pinhole | Projection::ThinLens { .. }) {
        return Err(LoadError::at(at, "ptracer connects light paths to perspective and thinlens sensors only"));
    }
    if let Some(n) = pt.samples_per_pass {
        if !spp.is_multiple_of(n) {
            return Err(LoadError::at(
                at,
                format!("ptracer: sample_count ({spp}) must be a multiple of samples_per_pass ({n}), as in Mitsuba"),
            ));
        }
    }
    Ok(())
}
