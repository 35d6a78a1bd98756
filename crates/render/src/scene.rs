//! The scene as integrators see it: ray queries, the BSDF at a hit, and
//! light sampling (selection included). Nothing else is exposed to them.

use crate::accel::{Accel, Hit, Instance, Primitive};
use crate::bsdf::roughplastic::TRANSMITTANCE_RES;
use crate::bsdf::Bsdf;
use crate::geometry::{offset_origin, Ray, Shape, SurfaceInteraction};
use crate::light::lane_table::LaneLightTable;
use crate::light::{Light, LightSample, LightSampler, LightSelection};
use crate::material::{LaneMaterial, LaneSurface, Material, Scratch};
use crate::math::{Spectrum, SHADOW_EPSILON};
use crate::medium::Medium;
use glam::{Vec2, Vec3};
use std::sync::{Arc, Mutex};

/// Every ray query a scene answers, in order, while attached to it
/// (`Scene::ray_log`): `penumbra bench` replays a render's rays through
/// the BVH alone, and through Embree, to time traversal without shading.
pub type RayLog = Arc<Mutex<Vec<LoggedRay>>>;

/// One recorded query: the ray as handed to the BVH, and whether it was a
/// shadow (any-hit) query.
#[derive(Debug, Clone, Copy)]
pub struct LoggedRay {
    /// The ray in world space; for shadow rays already offset and shortened.
    pub ray: Ray,
    /// An any-hit (`occluded`) query rather than a closest-hit one.
    pub shadow: bool,
}

/// Per-shape attributes beside its geometry.
#[derive(Debug, Clone, Copy)]
pub struct ShapeInfo {
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Index into [`Scene::lights`] when the shape is an area emitter.
    pub light: Option<u32>,
}

/// A shape whose hits lane vertices shade ([`Scene::lane_site`]): what the
/// vertex needs of it before its hit, found once per scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaneSite {
    /// Its material.
    pub surface: LaneSurface,
    /// Its geometry as the lane kernels read it: 0 a flat-shaded mesh, 1 a
    /// sphere, 2 a disk, 3 a flat-shaded mesh whose frame follows its
    /// texture coordinates (a textured material), 4 a sphere whose frame
    /// follows its uv parameterisation (an anisotropic material), 5 and 6: 0
    /// and 3 on a mesh with vertex normals (the shading normal interpolated).
    pub geometry: u8,
    /// [`LaneMaterial::kernel`] of its material.
    pub kernel: u8,
    /// Whether it is an area emitter.
    pub emitter: bool,
    /// [`Scene::carries_caustics`].
    pub carries_caustics: bool,
}

/// An area light as lane vertices sample it ([`Scene::lane_light`]), its
/// constants found once.
#[derive(Debug, Clone, Copy)]
pub enum LaneLight {
    /// On a mesh.
    Mesh {
        /// Its triangles: `Scene::lane_light_tris()[first..first + count]`.
        first: u32,
        /// How many.
        count: u32,
        /// Its density per unit area (`Mesh::area_pdf`).
        area_pdf: f32,
        /// The radiance.
        li: Spectrum,
        /// Whether it emits from both sides.
        two_sided: bool,
    },
    /// On a sphere.
    Sphere {
        /// Its centre.
        center: Vec3,
        /// (radius, 1 / area, 1 if its normals are flipped).
        params: Vec3,
        /// The radiance.
        li: Spectrum,
        /// Whether it emits from both sides.
        two_sided: bool,
    },
}

/// A triangle of a mesh light as lane vertices pick it
/// ([`Scene::lane_light_tris`]): bucket `b` of the mesh's alias table
/// (`Mesh::pick_triangle`'s) and the corners of triangle `b`, in one
/// record, so that a pick follows no pointer through the shape.
#[derive(Debug, Clone, Copy)]
pub struct LaneLightTri {
    /// The share of the bucket kept by triangle `b`.
    pub keep: f32,
    /// The triangle taking the rest (an index among the light's own).
    pub other: u32,
    /// Triangle `b`'s corners.
    pub p: [Vec3; 3],
}

/// The most triangles a mesh light may have to be sampled in lanes
/// ([`LaneLightTri`] copies each: 2.9 MB at most per light).
const MAX_LANE_LIGHT_TRIANGLES: usize = 1 << 16;

/// Shapes, materials, lights and the BVH, with the queries integrators use.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Every shape, by id: those placed directly, in world space, and the
    /// members of shape groups, in object space (placed by `instances`).
    pub shapes: Vec<Shape>,
    /// Per shape id.
    pub shape_info: Vec<ShapeInfo>,
    /// Shape groups placed by transforms.
    pub instances: Vec<Instance>,
    /// What `accel` is built over, in scene order: the shapes placed
    /// directly and the instances.
    pub placed: Vec<Primitive>,
    /// Materials, indexed by [`ShapeInfo::material`].
    pub materials: Vec<Material>,
    /// Every emitter; area lights refer to their shape by id.
    pub lights: Vec<Light>,
    /// Indices of lights at infinity (hit by escaping rays).
    pub env_lights: Vec<u32>,
    /// The top-level BVH over `placed`.
    pub accel: Accel,
    /// How `sample_light` picks a light (see [`Scene::set_light_selection`]).
    light_sampler: LightSampler,
    /// Per shape: whether its hits need the surface parameterisation
    /// ([`Material::reads_uv`] of its material, or an area light with a
    /// textured radiance); hits on the others skip it.
    reads_uv: Vec<bool>,
    /// Per shape: [`Scene::carries_caustics`], looked up once a bounce.
    carries_caustics: Vec<bool>,
    /// Per shape: [`Scene::lane_site`].
    lane_sites: Vec<Option<LaneSite>>,
    /// Per light: [`Scene::lane_light`].
    lane_lights: Vec<Option<LaneLight>>,
    /// The triangles of the mesh lights among `lane_lights`.
    lane_light_tris: Vec<LaneLightTri>,
    /// `lane_lights` as one table, where every light has a lane kernel.
    lane_light_table: Option<LaneLightTable>,
    /// The transmittance tables of the `roughplastic`s among `lane_sites`.
    lane_tables: Vec<[f32; TRANSMITTANCE_RES]>,
    /// When set, every `intersect` and `occluded` query is appended here
    /// (benchmarking only; one predictable branch per ray otherwise).
    pub ray_log: Option<RayLog>,
    /// Participating media (see [`Scene::set_media`]); the `path`,
    /// `direct` and `bruteforce` integrators ignore them, as Mitsuba's do.
    pub media: Vec<Medium>,
    /// Per shape id, its interior and exterior medium; empty when no shape
    /// bounds a medium.
    pub shape_media: Vec<ShapeMedia>,
    /// The medium the camera sits in.
    pub camera_medium: Option<u32>,
}

/// The media on the two sides of a shape (Mitsuba's `interior` and
/// `exterior`). A shape with either is a medium transition: a ray crossing
/// it enters the medium on the side its direction points to.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ShapeMedia {
    /// Inside: behind the geometric normal.
    pub interior: Option<u32>,
    /// Outside: in front of the geometric normal.
    pub exterior: Option<u32>,
}

impl ShapeMedia {
    /// Whether crossing the shape changes the medium (Mitsuba's
    /// `is_medium_transition`: either side has one).
    #[inline]
    pub fn is_transition(&self) -> bool {
        self.interior.is_some() || self.exterior.is_some()
    }

    /// The medium a ray leaving the surface along `d` enters, for the
    /// geometric normal `n` (Mitsuba's `target_medium`).
    #[inline]
    pub fn target(&self, n: Vec3, d: Vec3) -> Option<u32> {
        if d.dot(n) > 0.0 {
            self.exterior
        } else {
            self.interior
        }
    }
}

#[cold]
fn log_ray(log: &RayLog, ray: Ray, shadow: bool) {
    log.lock().unwrap_or_else(|e| e.into_inner()).push(LoggedRay { ray, shadow });
}

impl Scene {
    /// Assembles a scene of `shapes`, each placed as it is, and builds its
    /// acceleration structure. Lights are selected uniformly until
    /// [`Scene::set_light_selection`].
    pub fn new(shapes: Vec<Shape>, shape_info: Vec<ShapeInfo>, materials: Vec<Material>, lights: Vec<Light>) -> Scene {
        let placed: Vec<Primitive> = (0..shapes.len() as u32).map(Primitive::Shape).collect();
        let accel = Accel::build(&placed, &shapes, &[]);
        Scene::with_accel(accel, shapes, shape_info, Vec::new(), placed, materials, lights)
    }

    /// A scene whose BVH `accel` was built by `Accel::build(&placed, &shapes,
    /// &instances)`: shapes placed directly and instances of shape groups
    /// (whose members are the other shapes). The scene builder builds the
    /// BVH first, for the bounding radius its directional lights need.
    pub fn with_accel(
        accel: Accel,
        shapes: Vec<Shape>,
        shape_info: Vec<ShapeInfo>,
        instances: Vec<Instance>,
        placed: Vec<Primitive>,
        materials: Vec<Material>,
        lights: Vec<Light>,
    ) -> Scene {
        assert_eq!(shapes.len(), shape_info.len());
        let env_lights = lights.iter().enumerate().filter(|(_, l)| l.is_environment()).map(|(i, _)| i as u32).collect();
        let reads_uv: Vec<bool> = shape_info
            .iter()
            .map(|info| {
                let textured =
                    matches!(info.light.map(|l| &lights[l as usize]), Some(Light::Area(a)) if a.is_textured());
                materials.get(info.material as usize).is_none_or(Material::reads_uv) || textured
            })
            .collect();
        let light_sampler = LightSampler::Uniform { count: lights.len() };
        let carries_caustics: Vec<bool> = shape_info
            .iter()
            .map(|info| materials.get(info.material as usize).is_some_and(Material::carries_caustics))
            .collect();
        // Per material first, so that a table is copied once per material.
        let mut lane_tables = Vec::new();
        let per_material: Vec<Option<LaneSurface>> =
            materials.iter().map(|m| m.lane_material(&mut lane_tables)).collect();
        let lane_sites = shapes
            .iter()
            .zip(&shape_info)
            .zip(&reads_uv)
            .zip(&carries_caustics)
            .map(|(((shape, info), &uv), &carries_caustics)| {
                let (known, mesh) = match shape {
                    Shape::Mesh(_) | Shape::CulledMesh(_) => (true, true),
                    Shape::Sphere(_) | Shape::Disk(_) => (true, false),
                    _ => (false, false),
                };
                let m = per_material.get(info.material as usize).copied().flatten().filter(|_| known);
                // Textures read the uv parameterisation, which lanes find on
                // meshes only; anisotropic roughness its dp/du, which lanes
                // find on spheres only.
                let surface = m.filter(|s| match &s.material {
                    LaneMaterial::TexturedDiffuse => mesh,
                    m if m.anisotropic() => matches!(shape, Shape::Sphere(_)),
                    _ => !uv,
                })?;
                let geometry = match shape {
                    Shape::Mesh(m) | Shape::CulledMesh(m) => {
                        let textured =
                            matches!(surface.material, LaneMaterial::TexturedDiffuse) && !m.mesh.uvs.is_empty();
                        let smooth = !m.face_normals && !m.mesh.normals.is_empty();
                        match (textured, smooth) {
                            (false, false) => 0,
                            (true, false) => 3,
                            (false, true) => 5,
                            (true, true) => 6,
                        }
                    }
                    Shape::Sphere(_) if surface.material.anisotropic() => 4,
                    Shape::Sphere(_) => 1,
                    _ => 2,
                };
                Some(LaneSite {
                    surface,
                    geometry,
                    kernel: surface.material.kernel(),
                    emitter: info.light.is_some(),
                    carries_caustics,
                })
            })
            .collect();
        let mut lane_light_tris = Vec::new();
        let lane_lights = lights
            .iter()
            .map(|l| {
                let Light::Area(a) = l else { return None };
                let li = a.radiance.constant().filter(|&li| li != Spectrum::ZERO)?;
                let two_sided = a.two_sided;
                match &shapes[a.shape as usize] {
                    Shape::Mesh(m) | Shape::CulledMesh(m) => {
                        // The table copies the corners (44 bytes a triangle):
                        // a huge emissive mesh stays with the scalar vertex
                        // rather than doubling its memory.
                        let alias = m.area_alias().filter(|a| a.len() <= MAX_LANE_LIGHT_TRIANGLES)?;
                        let (first, count) = (u32::try_from(lane_light_tris.len()).ok()?, alias.len() as u32);
                        lane_light_tris.extend(alias.iter().enumerate().map(|(b, &(keep, other))| LaneLightTri {
                            keep,
                            other,
                            p: m.vertices(b),
                        }));
                        Some(LaneLight::Mesh { first, count, area_pdf: m.area_pdf(), li, two_sided })
                    }
                    Shape::Sphere(s) => {
                        let flip = if s.flip { 1.0 } else { 0.0 };
                        let params = Vec3::new(s.radius, 1.0 / s.area(), flip);
                        Some(LaneLight::Sphere { center: s.center, params, li, two_sided })
                    }
                    _ => None,
                }
            })
            .collect::<Vec<_>>();
        let lane_light_table = (!lane_lights.is_empty()).then(|| {
            let mut table = LaneLightTable::default();
            for l in &lane_lights {
                match *l.as_ref()? {
                    LaneLight::Mesh { first, count, area_pdf, li, two_sided } => {
                        let tris = &lane_light_tris[first as usize..][..count as usize];
                        let tris: Vec<_> = tris.iter().map(|t| (t.keep, t.other, t.p)).collect();
                        table.push_mesh(&tris, area_pdf, li, two_sided);
                    }
                    LaneLight::Sphere { center, params, li, two_sided } => {
                        table.push_sphere(center, params, li, two_sided)
                    }
                }
            }
            // Its float indices fit an i32 (for gathers).
            table.gathers().then_some(table)
        });
        Scene {
            shapes,
            shape_info,
            instances,
            placed,
            materials,
            lights,
            env_lights,
            accel,
            light_sampler,
            reads_uv,
            carries_caustics,
            lane_sites,
            lane_lights,
            lane_light_tris,
            lane_light_table: lane_light_table.flatten(),
            lane_tables,
            ray_log: None,
            media: Vec::new(),
            shape_media: Vec::new(),
            camera_medium: None,
        }
    }

    /// Adds participating media: `shape_media` per shape id (or empty when
    /// no shape bounds one) and the camera's medium.
    pub fn set_media(&mut self, media: Vec<Medium>, shape_media: Vec<ShapeMedia>, camera_medium: Option<u32>) {
        assert!(shape_media.is_empty() || shape_media.len() == self.shapes.len());
        self.media = media;
        self.shape_media = shape_media;
        self.camera_medium = camera_medium;
    }

    /// The media around shape `shape` (none for scenes without media).
    #[inline]
    pub fn shape_media(&self, shape: u32) -> ShapeMedia {
        self.shape_media.get(shape as usize).copied().unwrap_or_default()
    }

    /// Chooses the light-selection strategy (precomputing what it needs).
    pub fn set_light_selection(&mut self, selection: LightSelection) {
        let radius = self.accel.bounds.bounding_radius().max(1e-3);
        self.light_sampler = LightSampler::build(selection, &self.lights, &self.shapes, radius);
    }

    /// The light-selection strategy with its tables.
    pub fn light_sampler(&self) -> &LightSampler {
        &self.light_sampler
    }

    /// Closest surface hit.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceInteraction> {
        if let Some(log) = &self.ray_log {
            log_ray(log, *ray, false);
        }
        let hit = self.accel.intersect(ray, &self.shapes, &self.instances)?;
        Some(self.interaction(ray, &hit))
    }

    /// Closest surface hit with its full surface parameterisation (`uv`,
    /// `dpdu`, `dpdv`) whatever the material reads (the `aov` integrator's).
    pub fn intersect_full(&self, ray: &Ray) -> Option<SurfaceInteraction> {
        if let Some(log) = &self.ray_log {
            log_ray(log, *ray, false);
        }
        let hit = self.accel.intersect(ray, &self.shapes, &self.instances)?;
        let (id, i, t, uv) = (hit.shape, hit.index as usize, hit.t, hit.uv);
        let shape = &self.shapes[id as usize];
        Some(if hit.instance == Hit::NOT_INSTANCED {
            shape.interaction_with(id, i, ray, t, uv, true)
        } else {
            self.instances[hit.instance as usize].interaction_with(shape, id, i, ray, t, uv, true)
        })
    }

    /// The surface interaction of `ray`'s closest hit `hit` (from
    /// [`Scene::intersect`] or a packet traversal of [`Scene::accel`]).
    #[inline]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let (id, i, t, uv) = (hit.shape, hit.index as usize, hit.t, hit.uv);
        let param = self.reads_uv[id as usize];
        let shape = &self.shapes[id as usize];
        // Instances and their flattened geometry take the same path (the same frames).
        if hit.instance == Hit::NOT_INSTANCED {
            shape.interaction_with(id, i, ray, t, uv, param)
        } else {
            self.instances[hit.instance as usize].interaction_with(shape, id, i, ray, t, uv, param)
        }
    }

    /// Shape `shape` when its hits can be shaded in lanes (the `path`
    /// integrator's lane vertex): a mesh (flat or with vertex normals), a
    /// sphere or a disk, an emitter or not, whose material is a
    /// [`Material::lane_material`] (a textured one on meshes only).
    #[inline(always)]
    pub fn lane_site(&self, shape: u32) -> Option<&LaneSite> {
        self.lane_sites[shape as usize].as_ref()
    }

    /// Whether light paths carry the caustics of shape `shape`'s delta
    /// lobes ([`Material::carries_caustics`] of its material).
    #[inline]
    pub fn carries_caustics(&self, shape: u32) -> bool {
        self.carries_caustics[shape as usize]
    }

    /// Light `i` when its samples can be drawn in lanes: an area light of
    /// constant, non-zero radiance on a mesh or a sphere.
    #[inline(always)]
    pub fn lane_light(&self, i: usize) -> Option<&LaneLight> {
        self.lane_lights[i].as_ref()
    }

    /// The transmittance tables that [`LaneMaterial::RoughPlastic`]'s `table` indexes.
    #[inline(always)]
    pub fn lane_tables(&self) -> &[[f32; TRANSMITTANCE_RES]] {
        &self.lane_tables
    }

    /// Every light as one table for lane kernels to pick from, where every
    /// light has a lane kernel ([`Self::lane_light`]) and lights are
    /// selected uniformly.
    #[inline(always)]
    pub fn lane_light_table(&self) -> Option<&LaneLightTable> {
        match self.light_sampler {
            LightSampler::Uniform { count } => self.lane_light_table.as_ref().filter(|t| t.len() == count),
            _ => None,
        }
    }

    /// The triangles of a [`LaneLight::Mesh`] (its `first..first + count`).
    #[inline(always)]
    pub fn lane_light_tris(&self, first: u32, count: u32) -> &[LaneLightTri] {
        &self.lane_light_tris[first as usize..][..count as usize]
    }

    /// Whether the segment from `si` along `wi` is blocked before `dist`.
    ///
    /// The ray starts at the offset origin and is aimed from there at the
    /// light's point `si.p + wi * dist`: keeping `wi` from the unoffset
    /// point would shift the whole segment by the offset, and at grazing
    /// angles its end would pierce the light's own surface (Mitsuba's
    /// `spawn_ray_to` aims the same way).
    #[inline]
    pub fn occluded(&self, si: &SurfaceInteraction, wi: Vec3, dist: f32) -> bool {
        self.occluded_ray(&self.shadow_ray(si, wi, dist))
    }

    /// The shadow ray of [`Scene::occluded`].
    #[inline]
    pub fn shadow_ray(&self, si: &SurfaceInteraction, wi: Vec3, dist: f32) -> Ray {
        let o = offset_origin(si.p, si.n, wi);
        if dist.is_finite() {
            let d = si.p + wi * dist - o;
            let len = d.length();
            Ray::new(o, d / len, len * (1.0 - SHADOW_EPSILON))
        } else {
            Ray::new(o, wi, f32::INFINITY)
        }
    }

    /// Whether `ray` (a [`Scene::shadow_ray`]) is blocked before its `t_max`.
    #[inline]
    pub fn occluded_ray(&self, ray: &Ray) -> bool {
        if let Some(log) = &self.ray_log {
            log_ray(log, *ray, true);
        }
        self.accel.occluded(ray, &self.shapes, &self.instances)
    }

    /// A ray leaving `si` in direction `wi`.
    #[inline]
    pub fn spawn_ray(&self, si: &SurfaceInteraction, wi: Vec3) -> Ray {
        Ray::new(offset_origin(si.p, si.n, wi), wi, f32::INFINITY)
    }

    /// The BSDF at a hit, with textures evaluated. May replace
    /// `si.sh_frame` (see [`Material::bsdf`]); nested BSDFs go to `scratch`.
    #[inline]
    pub fn bsdf<'a>(&'a self, si: &mut SurfaceInteraction, scratch: &'a Scratch) -> Bsdf<'a> {
        self.materials[self.shape_info[si.shape as usize].material as usize].bsdf(si, scratch)
    }

    /// Probability that `sample_light` picks light `i` for a receiver at
    /// `p` with normal `n` (`Vec3::ZERO` when there is none, e.g. the camera).
    #[inline]
    pub fn light_pmf(&self, p: Vec3, n: Vec3, i: usize) -> f32 {
        self.light_sampler.pmf(p, n, i)
    }

    /// Picks a light for a receiver at (`p`, `n`) with `u` in [0, 1):
    /// (index, probability); see [`LightSampler::sample`].
    #[inline]
    pub fn select_light(&self, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32)> {
        self.light_sampler.sample(p, n, u)
    }

    /// Picks a light with `u` and samples a direction towards it with `u2`,
    /// for a receiver at `p_ref` with normal `n_ref`. The returned pdf
    /// includes the selection probability (delta lights: pdf 1 times it).
    /// No visibility test.
    #[inline]
    pub fn sample_light(&self, p_ref: Vec3, n_ref: Vec3, u: f32, u2: Vec2) -> Option<LightSample> {
        let (i, pmf) = self.select_light(p_ref, n_ref, u)?;
        let mut s = self.lights[i].sample_li(p_ref, u2, &self.shapes)?;
        s.pdf *= pmf;
        Some(s)
    }

    /// Radiance emitted by the surface at `si` towards `si.wo` (zero if the
    /// shape is not an emitter or is seen from behind).
    #[inline]
    pub fn emitted(&self, si: &SurfaceInteraction) -> Spectrum {
        match self.shape_info[si.shape as usize].light {
            Some(l) => match &self.lights[l as usize] {
                Light::Area(a) => a.emitted(si),
                _ => Spectrum::ZERO,
            },
            None => Spectrum::ZERO,
        }
    }

    /// Solid-angle density (selection included) with which `sample_light`
    /// from `p_ref` would have produced the emitter point `si`.
    #[inline]
    pub fn light_pdf(&self, p_ref: Vec3, n_ref: Vec3, si: &SurfaceInteraction) -> f32 {
        match self.shape_info[si.shape as usize].light {
            Some(l) => {
                self.lights[l as usize].pdf_li(p_ref, -si.wo, Some(si), &self.shapes)
                    * self.light_pmf(p_ref, n_ref, l as usize)
            }
            None => 0.0,
        }
    }

    /// Radiance from lights at infinity along direction `d`.
    #[inline]
    pub fn environment_radiance(&self, d: Vec3) -> Spectrum {
        self.env_lights.iter().map(|&i| self.lights[i as usize].environment_radiance(d)).sum()
    }

    /// The part of [`Self::environment_radiance`] along `d` whose caustics
    /// camera paths carry: the lights at infinity that are not concentrated
    /// there ([`Light::environment_left_to_camera`]).
    pub fn environment_radiance_left_to_camera(&self, d: Vec3) -> Spectrum {
        self.env_lights.iter().map(|&i| self.lights[i as usize].environment_left_to_camera(d)).sum()
    }

    /// The scene's environment, with its light index, when it is one
    /// `envmap` and nothing else: then [`Self::environment_radiance`] of a
    /// direction d is `Spectrum::ZERO + e.eval(d)` (the sum above), which
    /// [`crate::light::EnvMapLight::eval_lanes`] computes for many directions at once
    /// (`None` for a map too large to be gathered in lanes).
    pub fn single_envmap(&self) -> Option<(usize, &crate::light::EnvMapLight)> {
        match self.env_lights[..] {
            [i] => match &self.lights[i as usize] {
                Light::EnvMap(e) if e.gathers() => Some((i as usize, e)),
                _ => None,
            },
            _ => None,
        }
    }

    /// Radiance from lights at infinity along direction `d`, and the
    /// solid-angle density (selection included) with which `sample_light`
    /// for a receiver at (`p_ref`, `n_ref`) samples that direction.
    #[inline]
    pub fn environment(&self, p_ref: Vec3, n_ref: Vec3, d: Vec3) -> (Spectrum, f32) {
        let mut sum = (Spectrum::ZERO, 0.0);
        for &i in &self.env_lights {
            self.add_environment(&mut sum, p_ref, n_ref, i as usize, self.lights[i as usize].environment(d));
        }
        sum
    }

    /// Adds environment light `i`'s (radiance, solid-angle density) of a
    /// direction to `sum` as [`Self::environment`] does, the density times
    /// the light's selection probability for (`p_ref`, `n_ref`).
    #[inline]
    pub fn add_environment(
        &self,
        sum: &mut (Spectrum, f32),
        p_ref: Vec3,
        n_ref: Vec3,
        i: usize,
        (l, p): (Spectrum, f32),
    ) {
        sum.0 += l;
        sum.1 += p * self.light_pmf(p_ref, n_ref, i);
    }

    /// Bounds of all geometry.
    pub fn bounds(&self) -> crate::geometry::Aabb {
        self.accel.bounds
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::{AreaLight, PointLight};

    fn three_lights() -> Scene {
        let shapes = vec![Shape::sphere(Vec3::new(0.0, 3.0, 0.0), 0.5, false)];
        let info = vec![ShapeInfo { material: 0, light: Some(2) }];
        let materials = vec![Material::Diffuse(crate::bsdf::DiffuseParams { reflectance: Vec3::splat(0.5).into() })];
        let lights = vec![
            Light::Point(PointLight { position: Vec3::X, intensity: Vec3::splat(1.0) }),
            Light::Point(PointLight { position: Vec3::Y, intensity: Vec3::splat(5.0) }),
            Light::Area(AreaLight { shape: 0, radiance: Vec3::splat(2.0).into(), two_sided: false }),
        ];
        Scene::new(shapes, info, materials, lights)
    }

    /// Selection frequencies equal `light_pmf`, and the pmfs sum to one.
    #[test]
    fn light_selection_frequencies_match_the_pmf() {
        for sel in [LightSelection::Uniform, LightSelection::Power, LightSelection::Bvh] {
            let mut scene = three_lights();
            scene.set_light_selection(sel);
            let n = 100_000;
            let mut counts = [0usize; 3];
            for k in 0..n {
                let (i, pmf) = scene.select_light(Vec3::ZERO, Vec3::Y, (k as f32 + 0.5) / n as f32).unwrap();
                assert_eq!(pmf, scene.light_pmf(Vec3::ZERO, Vec3::Y, i));
                counts[i] += 1;
            }
            let total: f32 = (0..3).map(|i| scene.light_pmf(Vec3::ZERO, Vec3::Y, i)).sum();
            // (The BVH may pick no light at some receivers; not at this one.)
            assert!((total - 1.0).abs() < 1e-6);
            for (i, &c) in counts.iter().enumerate() {
                assert!(
                    (c as f32 / n as f32 - scene.light_pmf(Vec3::ZERO, Vec3::Y, i)).abs() < 1e-3,
                    "{sel:?} light {i}"
                );
            }
        }
        // Power: 4π·1, 4π·5 and π·(4π 0.25)·2 = 2π² → proportional to 4, 20, 2π.
        let mut scene = three_lights();
        scene.set_light_selection(LightSelection::Power);
        let w = [4.0, 20.0, 2.0 * std::f32::consts::PI];
        let sum: f32 = w.iter().sum();
        for i in 0..3 {
            assert!((scene.light_pmf(Vec3::ZERO, Vec3::Y, i) - w[i] / sum).abs() < 1e-5);
        }
    }
    /// A receiver far out on a floor sees the edge of a ceiling light at a
    /// grazing angle to the light's plane. Shifting the segment by the
    /// receiver's offset (instead of aiming from the offset origin) lifted
    /// its end above that plane, through the light: occluded wrongly.
    #[test]
    fn shadow_rays_reach_an_area_light_at_a_grazing_angle() {
        use glam::Mat4;
        let light = Mat4::from_translation(Vec3::Y) * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
        let floor = Mat4::from_scale(Vec3::splat(100.0)) * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
        let shapes = vec![Shape::disk(light, false), Shape::disk(floor, false)];
        let info = vec![ShapeInfo { material: 0, light: Some(0) }, ShapeInfo { material: 0, light: None }];
        let materials = vec![Material::Diffuse(crate::bsdf::DiffuseParams { reflectance: Vec3::splat(0.5).into() })];
        let lights = vec![Light::Area(AreaLight { shape: 0, radiance: Vec3::ONE.into(), two_sided: false })];
        let scene = Scene::new(shapes, info, materials, lights);
        for x in [5.0f32, 20.0, 40.0] {
            let si = scene.intersect(&Ray::new(Vec3::new(x, 5.0, 0.0), -Vec3::Y, f32::INFINITY)).unwrap();
            assert_eq!(si.shape, 1);
            assert!(si.n.y > 0.99, "floor normal {:?}", si.n);
            // A point on the light near the receiver's side of its edge.
            let target = Vec3::new(0.9, 1.0, 0.0);
            let (wi, dist) = ((target - si.p).normalize(), (target - si.p).length());
            assert!(!scene.occluded(&si, wi, dist), "x = {x}: the light's own point occludes it");
            // Unbounded, a ray aimed at the light's centre does hit it.
            let wc = (Vec3::Y - si.p).normalize();
            assert!(scene.occluded(&si, wc, f32::INFINITY), "x = {x}: the ray misses the light");
        }
    }
}
