//! glTF 2.0 scenes (`.gltf` with embedded data-URI or external buffers,
//! `.glb`) → [`SceneBuilder`] calls. The `gltf` crate parses and validates
//! the JSON; this module checks every buffer, view and accessor range before
//! reading, so that bad input is an error naming its JSON pointer
//! (`/meshes/0/primitives/1`), never a panic.
//!
//! What is read, and how:
//! - The default scene's node hierarchy (TRS or matrix transforms), meshes
//!   of triangles (other primitive modes are errors) with POSITION, NORMAL,
//!   TEXCOORD_0 and COLOR_0, baked into world space (a mirroring transform
//!   reverses the winding, as the specification requires); a mesh that
//!   several nodes use, none of them mirroring and no primitive emitting,
//!   is stored once as a group placed by instances.
//! - Materials: the metallic-roughness model as [`GltfPbrParams`] (base
//!   colour factor × sRGB texture × vertex colour; metallic and roughness
//!   factors × the texture's B and G channels; `KHR_materials_ior` gives the
//!   dielectric f0, `KHR_materials_specular`'s `specularFactor` scales its
//!   Fresnel term), `normalTexture` as a normal map (its `scale` applied to
//!   x and y), `doubleSided` as `twosided`, alpha MASK (cut-off) and BLEND
//!   (stochastic opacity) as a mask, `KHR_materials_transmission` as a blend
//!   with a rough dielectric of the same roughness and IOR tinted by the base
//!   colour, `KHR_texture_transform` as the textures' uv transform.
//!   `KHR_materials_volume` on a transmitting material with a thickness
//!   (not thin-walled) fills the mesh with an absorbing homogeneous medium,
//!   σ_a = −ln(attenuationColor) / attenuationDistance, σ_s = 0 (the
//!   specification's Beer–Lambert law), and the scene renders with `volpath`
//!   unless `--integrator` says otherwise; `thicknessTexture` is not used
//!   (it serves rasterisers, a path tracer measures the thickness).
//!   `occlusionTexture` is not used: a path tracer computes occlusion.
//! - Emission: `emissiveFactor` × `emissiveTexture` × `KHR_materials_emissive_strength`
//!   as area lights on the triangles (front side).
//! - Cameras: the first node with a camera, perspective (`yfov` vertical,
//!   `aspectRatio` sets the film) or orthographic; glTF cameras look down
//!   their −z with +y up, Penumbra's (Mitsuba's) down +z with +x to the image's
//!   left: the two differ by a half turn about y. Without a camera: the
//!   scene's bounding sphere framed from +z, 40° vertical field of view.
//! - `KHR_lights_punctual`: point, spot (outer cone = cut-off, inner = beam
//!   width of Mitsuba's linear fall-off, an approximation of the
//!   specification's recommended smooth fall-off), directional. Intensities
//!   are used as given, as radiometric values (candela as W/sr, lux as
//!   W/m²), as glTF viewers (the Khronos sample viewer, three.js) use them;
//!   `range` is ignored (the specification allows physical inverse-square
//!   fall-off).
//! - Without a punctual light: a uniform white environment (radiance 1), so
//!   the scene is not black (emissive materials alone light it only where
//!   they glow). Film 512 pixels on the long side, 64 samples per
//!   pixel, Mitsuba's `path` integrator, Gaussian filter.

use crate::builder::Overrides;
use crate::error::{FileLoc, LoadError, Result};
use crate::image_io::{srgb_to_linear, RgbImage};
use crate::scene_builder::{image_texture, Emission, Film, GroupId, MaterialId, MeshData, SceneBuilder, ShapeDesc};
use glam::{Affine2, Mat4, Quat, Vec2, Vec3};
use gltf::camera::Projection as GltfProjection;
use gltf::khr_lights_punctual::Kind as LightKind;
use gltf::material::AlphaMode;
use gltf::texture::{MagFilter, WrappingMode};
use penumbra_render::bsdf::{GltfPbrParams, MicrofacetType, RoughDielectricParams, Roughness};
use penumbra_render::camera::{Camera, FovAxis};
use penumbra_render::film::{Filter, FilterKind};
use penumbra_render::light::{ConstantLight, DirectionalLight, Light, PointLight, SpotLight};
use penumbra_render::material::Material;
use penumbra_render::math::look_at;
use penumbra_render::render::RenderJob;
use penumbra_render::sampling::Sampler;
use penumbra_render::texture::{AttributeTable, FilterType, MeshAttribute, Texture, WrapMode};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The film's longer side without a camera aspect ratio to follow (pixels).
pub const DEFAULT_FILM_SIZE: u32 = 512;
/// Samples per pixel unless `--spp` says otherwise.
pub const DEFAULT_SPP: u32 = 64;
/// The vertical field of view of the default camera (degrees).
pub const DEFAULT_FOV_DEG: f32 = 40.0;

/// The extensions read (others listed in `extensionsRequired` are refused by
/// the `gltf` crate's validation, in `extensionsUsed` noted).
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// Whether `path` names a glTF file (`.gltf` or `.glb`).
pub fn is_gltf(path: &Path) -> bool {
    matches!(path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).as_deref(), Some("gltf" | "glb"))
}

/// Loads a glTF 2.0 file as a render job, with notes for the user (what
/// was approximated or left out).
pub fn load(path: &Path, ov: &Overrides) -> Result<(RenderJob, Vec<String>)> {
    let bytes = std::fs::read(path).map_err(|e| LoadError::in_file(path, format!("cannot read the file: {e}")))?;
    load_bytes(path, &bytes, ov)
}

/// [`load`] of a file's contents (`path` names it in errors and resolves
/// external buffers and images).
pub fn load_bytes(path: &Path, bytes: &[u8], ov: &Overrides) -> Result<(RenderJob, Vec<String>)> {
    let file = Arc::new(path.to_path_buf());
    let at = |place: &str| FileLoc::with_place(file.clone(), place.to_string());
    if bytes.starts_with(b"glTF") && bytes.len() >= 12 {
        // The gltf crate subtracts the header's size from this unchecked (1.4.1).
        let length = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if length < 12 {
            return Err(LoadError::at(
                &at("byte 8"),
                format!("not a valid binary glTF (.glb): its total length {length} is shorter than its 12-byte header"),
            ));
        }
    }
    let gltf = parse(bytes).map_err(|e| parse_error(&file, e))?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let buffers = read_buffers(&gltf, &dir, &at)?;
    let mut r = Reader {
        file: file.clone(),
        doc: &gltf.document,
        dir,
        buffers,
        scene: SceneBuilder::new(FileLoc::new(file.clone(), 0, 0)),
        materials: HashMap::new(),
        volumes: HashMap::new(),
        has_volumes: false,
        images: HashMap::new(),
        vertex_color: Arc::new(MeshAttribute::new("vertex_color".into(), 1.0)),
        color_tables: Vec::new(),
        bounds: (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        mesh_uses: {
            let mut uses = vec![0; gltf.meshes().len()];
            gltf.nodes().filter_map(|n| n.mesh()).for_each(|m| uses[m.index()] += 1);
            uses
        },
        groups: HashMap::new(),
        camera: None,
        lights: 0,
        notes: Vec::new(),
    };
    for ext in gltf.extensions_used() {
        if !SUPPORTED_EXTENSIONS.contains(&ext) {
            r.notes.push(format!("/extensionsUsed: {ext} is not supported; the file renders without it"));
        }
    }
    for view in gltf.views() {
        let len = r.buffers[view.buffer().index()].len();
        if view.offset().checked_add(view.length()).is_none_or(|end| end > len) {
            return Err(LoadError::at(
                &at(&format!("/bufferViews/{}", view.index())),
                format!(
                    "the view's bytes {}..{} lie outside buffer {} ({len} bytes)",
                    view.offset(),
                    view.offset().saturating_add(view.length()),
                    view.buffer().index()
                ),
            ));
        }
    }
    let roots: Vec<gltf::Node> = match gltf.default_scene().or_else(|| gltf.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            // No scene: the nodes that are nobody's child.
            let mut child = vec![false; gltf.nodes().len()];
            for n in gltf.nodes() {
                for c in n.children() {
                    child[c.index()] = true;
                }
            }
            gltf.nodes().filter(|n| !child[n.index()]).collect()
        }
    };
    for n in roots {
        r.node(&n, Mat4::IDENTITY, 0)?;
    }
    r.finish(ov)
}

/// The document, validated. The `gltf` crate's validation indexes the
/// accessors by each primitive's POSITION without a bounds check (1.4.1), so
/// that index is checked first.
fn parse(bytes: &[u8]) -> std::result::Result<gltf::Gltf, gltf::Error> {
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes)?;
    let json = document.into_json();
    let mut errors = Vec::new();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let pos = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(i) = prim.attributes.get(&pos) {
                if i.value() >= json.accessors.len() {
                    let path = gltf::json::Path(format!("meshes[{m}].primitives[{p}].attributes.POSITION"));
                    errors.push((path, gltf::json::validation::Error::IndexOutOfBounds));
                }
            }
        }
    }
    // Cameras and spot lights whose parameters object is missing (the
    // crate's accessors unwrap it; its validation does not check it).
    use gltf::json::validation::{Checked::Valid, Error as E};
    for (i, c) in json.cameras.iter().enumerate() {
        let missing = match c.type_ {
            Valid(gltf::json::camera::Type::Perspective) => c.perspective.is_none().then_some("perspective"),
            Valid(gltf::json::camera::Type::Orthographic) => c.orthographic.is_none().then_some("orthographic"),
            _ => None,
        };
        if let Some(field) = missing {
            errors.push((gltf::json::Path(format!("cameras[{i}].{field}")), E::Missing));
        }
    }
    let lights = json.extensions.as_ref().and_then(|e| e.khr_lights_punctual.as_ref());
    for (i, l) in lights.map_or(&[][..], |l| &l.lights[..]).iter().enumerate() {
        if l.type_ == Valid(gltf::json::extensions::scene::khr_lights_punctual::Type::Spot) && l.spot.is_none() {
            let path = format!("extensions.KHR_lights_punctual.lights[{i}].spot");
            errors.push((gltf::json::Path(path), E::Missing));
        }
    }
    if !errors.is_empty() {
        return Err(gltf::Error::Validation(errors));
    }
    Ok(gltf::Gltf { document: gltf::Document::from_json(json)?, blob })
}

/// The `gltf` crate's error as a load error: validation errors with the
/// JSON pointers of what they concern, JSON syntax errors with their line.
fn parse_error(file: &Arc<PathBuf>, e: gltf::Error) -> LoadError {
    match e {
        gltf::Error::Validation(errors) => {
            let pointer = |p: &gltf::json::Path| {
                let s = p.as_str().replace('[', "/").replace(']', "").replace('.', "/");
                format!("/{s}")
            };
            let place = errors.first().map_or_else(|| "/".to_string(), |(p, _)| pointer(p));
            let list: Vec<String> = errors.iter().map(|(p, e)| format!("{}: {e}", pointer(p))).collect();
            LoadError::at(&FileLoc::with_place(file.clone(), place), format!("invalid glTF: {}", list.join("; ")))
        }
        gltf::Error::Deserialize(j) => LoadError::at(
            &FileLoc::new(file.clone(), j.line() as u32, j.column() as u32),
            format!("invalid glTF JSON: {j}"),
        ),
        gltf::Error::Binary(b) => LoadError::at(
            &FileLoc::with_place(file.clone(), "the GLB container"),
            format!("not a valid binary glTF (.glb): {b}; the file may be truncated"),
        ),
        other => LoadError::in_file(file, format!("invalid glTF: {other}")),
    }
}

/// The bytes of every buffer: the GLB's BIN chunk, a base64 data URI or a
/// file beside the scene; each at least as long as its `byteLength`.
fn read_buffers(gltf: &gltf::Gltf, dir: &Path, at: &dyn Fn(&str) -> FileLoc) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for b in gltf.buffers() {
        let place = at(&format!("/buffers/{}", b.index()));
        let data = match b.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                LoadError::at(&place, "the buffer refers to the GLB's binary chunk, which the file lacks")
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(uri, dir, &place)?,
        };
        if data.len() < b.length() {
            return Err(LoadError::at(
                &place,
                format!("the buffer holds {} bytes; its byteLength says {}", data.len(), b.length()),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes a URI names: `data:...;base64,...` or a relative file path
/// (percent-encoded characters decoded).
fn read_uri(uri: &str, dir: &Path, place: &FileLoc) -> Result<Vec<u8>> {
    use base64::Engine;
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, data)) = rest.split_once(";base64,") else {
            return Err(LoadError::at(place, "a data URI must be base64-encoded (data:...;base64,...)"));
        };
        return base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| LoadError::at(place, format!("bad base64 in the data URI: {e}")));
    }
    if uri.contains("://") {
        return Err(LoadError::at(place, format!("'{uri}': only data URIs and relative file paths can be read")));
    }
    let path = dir.join(percent_decode(uri));
    std::fs::read(&path).map_err(|e| LoadError::at(place, format!("cannot read '{}': {e}", path.display())))
}

/// `%XX` escapes decoded (URIs of external files are URI-encoded).
fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() && s.is_char_boundary(i + 3) {
            if let Ok(v) = u8::from_str_radix(&s[i + 1..i + 3], 16) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Checks that an attribute the reader uses has a type the specification
/// allows (the `gltf` crate's readers assume it).
fn check_type(acc: &gltf::Accessor, sem: &gltf::Semantic, prim: &str, loc: &FileLoc) -> Result<()> {
    use gltf::accessor::{DataType as T, Dimensions as D};
    use gltf::Semantic as S;
    let (t, d, norm) = (acc.data_type(), acc.dimensions(), acc.normalized());
    let ok = match sem {
        S::Positions | S::Normals => (t, d) == (T::F32, D::Vec3),
        S::TexCoords(0) => d == D::Vec2 && (t == T::F32 || (norm && matches!(t, T::U8 | T::U16))),
        S::Colors(0) => matches!(d, D::Vec3 | D::Vec4) && (t == T::F32 || (norm && matches!(t, T::U8 | T::U16))),
        _ => true, // not read
    };
    if ok {
        Ok(())
    } else {
        Err(LoadError::at(
            loc,
            format!(
                "{} of {prim}: {d:?} of {t:?}{} is not a type the specification allows for it",
                sem.to_string(),
                if norm { " (normalized)" } else { "" }
            ),
        ))
    }
}

/// Whether a primitive of `mesh` emits light (its shapes cannot join a group).
fn emissive(mesh: &gltf::Mesh) -> bool {
    mesh.primitives().any(|p| p.material().emissive_factor().iter().any(|&e| e > 0.0))
}

/// Whether a primitive's material has `KHR_materials_volume`.
fn has_volume(mesh: &gltf::Mesh) -> bool {
    mesh.primitives().any(|p| p.material().volume().is_some())
}

/// A decoded image: RGBA texels as stored (not yet sRGB-decoded), top row first.
struct Image {
    width: u32,
    height: u32,
    rgba: Vec<[f32; 4]>,
}

/// What the material cache holds: the material and the emission of its triangles.
type BuiltMaterial = (MaterialId, Option<Texture>);

struct Reader<'a> {
    file: Arc<PathBuf>,
    doc: &'a gltf::Document,
    dir: PathBuf,
    buffers: Vec<Vec<u8>>,
    scene: SceneBuilder,
    /// By (material index, with vertex colours).
    materials: HashMap<(Option<usize>, bool), BuiltMaterial>,
    /// Whether a material added a medium (the scene then renders with `volpath`).
    has_volumes: bool,
    /// The interior medium of each material with `KHR_materials_volume`.
    volumes: HashMap<Option<usize>, Option<penumbra_render::scene::ShapeMedia>>,
    images: HashMap<usize, Arc<Image>>,
    /// The one `vertex_color` attribute texture of every material used with COLOR_0.
    vertex_color: Arc<MeshAttribute>,
    /// Its table for each shape with vertex colours.
    color_tables: Vec<(u32, AttributeTable)>,
    /// World-space bounds of every vertex.
    bounds: (Vec3, Vec3),
    /// How many nodes use each mesh: meshes used by several are instanced.
    mesh_uses: Vec<usize>,
    /// The group of each instanced mesh, with its object-space bounds.
    groups: HashMap<usize, (GroupId, Vec3, Vec3)>,
    /// The first camera met, with its node's world transform.
    camera: Option<(Mat4, gltf::Camera<'a>, String)>,
    /// `KHR_lights_punctual` lights added (emissive materials do not count:
    /// glTF viewers light such models by an environment too, e.g. the
    /// sample `DamagedHelmet`, whose emission is its small displays).
    lights: usize,
    notes: Vec<String>,
}

impl<'a> Reader<'a> {
    fn at(&self, place: impl Into<String>) -> FileLoc {
        FileLoc::with_place(self.file.clone(), place.into())
    }

    fn node(&mut self, n: &gltf::Node<'a>, parent: Mat4, depth: usize) -> Result<()> {
        let place = format!("/nodes/{}", n.index());
        if depth > self.doc.nodes().len() {
            return Err(LoadError::at(&self.at(place), "the node hierarchy has a cycle (a node is its own ancestor)"));
        }
        let local = Mat4::from_cols_array_2d(&n.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(LoadError::at(&self.at(place), "the node's transform is not finite"));
        }
        if let Some(mesh) = n.mesh() {
            // Emitting and volume-filled meshes are baked per node: lights and
            // media are per shape, not per instance.
            let shared = self.mesh_uses[mesh.index()] > 1 && !emissive(&mesh) && !has_volume(&mesh);
            if shared && world.determinant() > 0.0 {
                self.instance(&mesh, &world, &place)?;
            } else {
                let (ids, lo, hi) = self.mesh(&mesh, &world)?;
                ids.into_iter().for_each(|id| self.scene.place_shape(id));
                self.bounds = (self.bounds.0.min(lo), self.bounds.1.max(hi));
            }
        }
        if let Some(cam) = n.camera() {
            if self.camera.is_none() {
                self.camera = Some((world, cam, place.clone()));
            } else {
                self.notes.push(format!("{place}: a further camera is ignored (the first one met renders)"));
            }
        }
        if let Some(light) = n.light() {
            self.light(&light, &world, &place)?;
        }
        for c in n.children() {
            self.node(&c, world, depth + 1)?;
        }
        Ok(())
    }

    /// Checks that `acc`'s elements lie inside its view and returns its pointer.
    fn check_accessor(&self, acc: &gltf::Accessor, what: &str, prim: &str) -> Result<()> {
        let place = format!("/accessors/{}", acc.index());
        let fail = |m: String| Err(LoadError::at(&self.at(place.clone()), format!("{m} (the {what} of {prim})")));
        if acc.sparse().is_some() {
            return fail("sparse accessors are not supported".into());
        }
        let Some(view) = acc.view() else {
            return fail("the accessor has no bufferView".into());
        };
        let elem = acc.size();
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return fail(format!(
                "bufferView {}'s byteStride {stride} is less than the element size {elem}",
                view.index()
            ));
        }
        if acc.count() == 0 {
            return fail("the accessor's count must be at least 1".into());
        }
        let end = (acc.count() - 1).checked_mul(stride).and_then(|x| x.checked_add(acc.offset() + elem));
        if end.is_none_or(|e| e > view.length()) {
            return fail(format!(
                "{} elements of {elem} bytes (stride {stride}) from byte {} run past the end of bufferView {} ({} bytes)",
                acc.count(),
                acc.offset(),
                view.index(),
                view.length()
            ));
        }
        Ok(())
    }

    /// `mesh` placed by `world` (which must not mirror) through a group
    /// shared by every node of the mesh: its geometry is stored once.
    fn instance(&mut self, mesh: &gltf::Mesh<'a>, world: &Mat4, place: &str) -> Result<()> {
        let (group, lo, hi) = match self.groups.get(&mesh.index()) {
            Some(g) => *g,
            None => {
                let (ids, lo, hi) = self.mesh(mesh, &Mat4::IDENTITY)?;
                if ids.is_empty() {
                    return Ok(());
                }
                let g = self.scene.add_group(ids, &self.at(format!("/meshes/{}", mesh.index())))?;
                self.groups.insert(mesh.index(), (g, lo, hi));
                (g, lo, hi)
            }
        };
        for i in 0..8 {
            let corner = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let w = world.transform_point3(corner);
            self.bounds = (self.bounds.0.min(w), self.bounds.1.max(w));
        }
        self.scene.add_instance(group, *world, &self.at(place))
    }

    /// The shapes of `mesh`'s primitives placed by `to_world` (not yet in the
    /// scene), with their bounds.
    fn mesh(&mut self, mesh: &gltf::Mesh<'a>, to_world: &Mat4) -> Result<(Vec<u32>, Vec3, Vec3)> {
        let world = to_world;
        let mut ids = Vec::new();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for prim in mesh.primitives() {
            let place = format!("/meshes/{}/primitives/{}", mesh.index(), prim.index());
            let loc = self.at(place.clone());
            if prim.mode() != gltf::mesh::Mode::Triangles {
                return Err(LoadError::at(
                    &loc,
                    format!("primitive mode {:?} is not supported; Penumbra renders triangles (mode 4)", prim.mode()),
                ));
            }
            for (sem, acc) in prim.attributes() {
                self.check_accessor(&acc, &sem.to_string(), &place)?;
                check_type(&acc, &sem, &place, &self.at(format!("/accessors/{}", acc.index())))?;
            }
            if let Some(acc) = prim.indices() {
                self.check_accessor(&acc, "indices", &place)?;
                use gltf::accessor::{DataType as T, Dimensions as D};
                if !matches!((acc.data_type(), acc.dimensions()), (T::U8 | T::U16 | T::U32, D::Scalar)) {
                    return Err(LoadError::at(
                        &self.at(format!("/accessors/{}", acc.index())),
                        format!("the indices of {place} must be unsigned byte, short or int scalars"),
                    ));
                }
            }
            let buffers = &self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
            let bad = |what: &str| LoadError::at(&loc, format!("cannot read the {what}"));
            let positions: Vec<Vec3> =
                reader.read_positions().ok_or_else(|| bad("POSITION attribute (required)"))?.map(Vec3::from).collect();
            let n = positions.len();
            let per_vertex = |len: usize, what: &str| -> Result<()> {
                if len != n {
                    return Err(LoadError::at(&loc, format!("{len} {what} for {n} positions")));
                }
                Ok(())
            };
            let normals: Vec<Vec3> = reader.read_normals().map(|i| i.map(Vec3::from).collect()).unwrap_or_default();
            if !normals.is_empty() {
                per_vertex(normals.len(), "normals")?;
            }
            let uvs: Vec<Vec2> =
                reader.read_tex_coords(0).map(|i| i.into_f32().map(Vec2::from).collect()).unwrap_or_default();
            if !uvs.is_empty() {
                per_vertex(uvs.len(), "texture coordinates")?;
            }
            let colors: Vec<Vec3> =
                reader.read_colors(0).map(|i| i.into_rgb_f32().map(Vec3::from).collect()).unwrap_or_default();
            if !colors.is_empty() {
                per_vertex(colors.len(), "vertex colours")?;
            }
            let flat: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..n as u32).collect(),
            };
            if !flat.len().is_multiple_of(3) {
                return Err(LoadError::at(&loc, format!("{} indices: not a whole number of triangles", flat.len())));
            }
            if let Some(i) = flat.iter().find(|&&i| i as usize >= n) {
                return Err(LoadError::at(&loc, format!("index {i} is out of range ({n} vertices)")));
            }
            let indices: Vec<[u32; 3]> = flat.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
            if indices.is_empty() {
                continue;
            }
            for p in &positions {
                let w = world.transform_point3(*p);
                (lo, hi) = (lo.min(w), hi.max(w));
            }
            let with_colors = !colors.is_empty();
            let (material, emission) = self.material(prim.material(), with_colors)?;
            let media = self.volume(&prim.material())?;
            let kept_indices = indices.clone();
            let data = MeshData { positions, indices, normals, uvs, colors, attributes: Vec::new() };
            let mirror = world.determinant() < 0.0;
            let geometry = data.into_geometry(world, mirror, false, &loc)?;
            let attrs = geometry.1.clone();
            let id = self.scene.add_shape(
                ShapeDesc {
                    emission: emission.map(Emission::Diffuse),
                    media: media.unwrap_or_default(),
                    ..ShapeDesc::new(geometry, material)
                },
                &loc,
            )?;
            ids.push(id);
            if let Some(a) = attrs.iter().find(|a| a.name == "vertex_color") {
                self.color_tables.push((id, AttributeTable::new(a, &kept_indices)));
            }
        }
        Ok((ids, lo, hi))
    }

    fn image(&mut self, index: usize) -> Result<Arc<Image>> {
        if let Some(i) = self.images.get(&index) {
            return Ok(i.clone());
        }
        let place = self.at(format!("/images/{index}"));
        let img = self.doc.images().nth(index).ok_or_else(|| LoadError::at(&place, "no such image"))?;
        // `source()` unwraps these (gltf 1.4.1); its validation does not check them.
        let json = &self.doc.as_json().images[index];
        match (&json.buffer_view, &json.uri, &json.mime_type) {
            (Some(_), _, None) => return Err(LoadError::at(&place, "an image in a bufferView needs a mimeType")),
            (None, None, _) => return Err(LoadError::at(&place, "the image has neither a uri nor a bufferView")),
            _ => {}
        }
        let bytes = match img.source() {
            gltf::image::Source::View { view, .. } => {
                self.buffers[view.buffer().index()][view.offset()..view.offset() + view.length()].to_vec()
            }
            gltf::image::Source::Uri { uri, .. } => read_uri(uri, &self.dir, &place)?,
        };
        let decoded = image::load_from_memory(&bytes)
            .map_err(|e| LoadError::at(&place, format!("cannot decode the image (PNG or JPEG expected): {e}")))?
            .to_rgba32f();
        let image = Arc::new(Image {
            width: decoded.width(),
            height: decoded.height(),
            rgba: decoded.pixels().map(|p| p.0).collect(),
        });
        self.images.insert(index, image.clone());
        Ok(image)
    }

    /// A texture from `info`'s image, each texel made by `texel` from the
    /// stored RGBA, with the sampler's filter and wrap mode and
    /// `KHR_texture_transform`.
    fn texture(
        &mut self,
        info: &gltf::texture::Texture<'a>,
        tex_coord: u32,
        transform: Option<gltf::texture::TextureTransform>,
        place: &str,
        texel: impl Fn([f32; 4]) -> [f32; 3],
    ) -> Result<Texture> {
        let loc = self.at(place);
        if tex_coord != 0 || transform.as_ref().and_then(|t| t.tex_coord()).is_some_and(|t| t != 0) {
            return Err(LoadError::at(&loc, "only TEXCOORD_0 is supported (texCoord must be 0)"));
        }
        let image = self.image(info.source().index())?;
        let sampler = info.sampler();
        let wrap = |w: WrappingMode| match w {
            WrappingMode::ClampToEdge => WrapMode::Clamp,
            WrappingMode::MirroredRepeat => WrapMode::Mirror,
            WrappingMode::Repeat => WrapMode::Repeat,
        };
        if sampler.wrap_s() != sampler.wrap_t() {
            self.notes.push(format!(
                "/samplers/{}: wrapS and wrapT differ; wrapS is used for both",
                sampler.index().unwrap_or(0)
            ));
        }
        let filter =
            if sampler.mag_filter() == Some(MagFilter::Nearest) { FilterType::Nearest } else { FilterType::Bilinear };
        let to_uv = match &transform {
            None => Affine2::IDENTITY,
            Some(t) => {
                // The extension's uv' = T R S uv, with its GLSL (column-major)
                // R = mat3(cos, sin, 0, −sin, cos, 0, 0, 0, 1): u' = cos u − sin v.
                let (s, c) = t.rotation().sin_cos();
                let r = Affine2::from_cols(Vec2::new(c, s), Vec2::new(-s, c), Vec2::ZERO);
                Affine2::from_translation(Vec2::from(t.offset())) * r * Affine2::from_scale(Vec2::from(t.scale()))
            }
        };
        let rgb = RgbImage {
            width: image.width,
            height: image.height,
            pixels: image.rgba.iter().map(|p| texel(*p)).collect(),
        };
        image_texture(rgb, filter, wrap(sampler.wrap_s()), to_uv, &loc)
    }

    /// The media of a material with `KHR_materials_volume` (see the module
    /// docs): an absorbing interior, `None` where there is nothing to absorb.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    fn volume(&mut self, mat: &gltf::Material<'a>) -> Result<Option<penumbra_render::scene::ShapeMedia>> {
        use penumbra_render::medium::{Medium, MediumKind, PhaseFunction};
        if let Some(v) = self.volumes.get(&mat.index()) {
            return Ok(*v);
        }
        let place = mat.index().map_or_else(|| "/materials".to_string(), |i| format!("/materials/{i}"));
        let at = self.at(format!("{place}/extensions/KHR_materials_volume"));
        let transmits = mat.transmission().is_some_and(|t| t.transmission_factor() > 0.0);
        let media = match mat.volume() {
            Some(v) if transmits && v.thickness_factor() > 0.0 => {
                if v.thickness_texture().is_some() {
                    self.notes.push(format!("{place}: KHR_materials_volume's thicknessTexture is not used"));
                }
                let (d, c) = (v.attenuation_distance(), Vec3::from(v.attenuation_color()));
                if !(d > 0.0 && c.is_finite() && c.min_element() >= 0.0) {
                    return Err(LoadError::at(&at, "attenuationDistance must be > 0 and attenuationColor in [0, 1]"));
                }
                if d.is_infinite() || c == Vec3::ONE {
                    None
                } else {
                    // Beer–Lambert: transmittance c after distance d; c = 0 absorbs all but a trace.
                    let sigma_a = c.max(Vec3::splat(1e-6)).min(Vec3::ONE).map(|x| -x.ln()) / d;
                    let id = self.scene.add_medium(Medium {
                        kind: MediumKind::Homogeneous { sigma_t: sigma_a, albedo: Vec3::ZERO },
                        phase: PhaseFunction::Isotropic,
                        sample_emitters: true,
                    });
                    self.has_volumes = true;
                    Some(penumbra_render::scene::ShapeMedia { interior: Some(id), exterior: None })
                }
            }
            _ => None,
        };
        self.volumes.insert(mat.index(), media);
        Ok(media)
    }

    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    fn material(&mut self, mat: gltf::Material<'a>, colors: bool) -> Result<BuiltMaterial> {
        let key = (mat.index(), colors);
        if let Some(m) = self.materials.get(&key) {
            return Ok(m.clone());
        }
        let place =
            mat.index().map_or_else(|| "/materials (default material)".to_string(), |i| format!("/materials/{i}"));
        let pbr = mat.pbr_metallic_roughness();
        let [fr, fg, fb, fa] = pbr.base_color_factor();
        let factor = Vec3::new(fr, fg, fb);
        let (base_color, alpha) = match pbr.base_color_texture() {
            Some(info) => {
                let p = format!("{place}/pbrMetallicRoughness/baseColorTexture");
                let t = info.texture();
                let base = self.texture(&t, info.tex_coord(), info.texture_transform(), &p, |c| {
                    [srgb_to_linear(c[0]) * fr, srgb_to_linear(c[1]) * fg, srgb_to_linear(c[2]) * fb]
                })?;
                let alpha = if mat.alpha_mode() == AlphaMode::Opaque {
                    Texture::Constant(Vec3::ONE)
                } else {
                    let cutoff = mat.alpha_cutoff().unwrap_or(0.5);
                    let mask = mat.alpha_mode() == AlphaMode::Mask;
                    self.texture(&t, info.tex_coord(), info.texture_transform(), &p, move |c| {
                        let a = c[3] * fa;
                        let a = if mask { f32::from(a >= cutoff) } else { a };
                        [a; 3]
                    })?
                };
                (base, alpha)
            }
            None => {
                let a = match mat.alpha_mode() {
                    AlphaMode::Opaque => 1.0,
                    AlphaMode::Mask => f32::from(fa >= mat.alpha_cutoff().unwrap_or(0.5)),
                    AlphaMode::Blend => fa,
                };
                (Texture::Constant(factor), Texture::Constant(Vec3::splat(a)))
            }
        };
        let (m, r) = (pbr.metallic_factor(), pbr.roughness_factor());
        let metallic_roughness = match pbr.metallic_roughness_texture() {
            Some(info) => {
                let p = format!("{place}/pbrMetallicRoughness/metallicRoughnessTexture");
                self.texture(&info.texture(), info.tex_coord(), info.texture_transform(), &p, |c| {
                    [0.0, c[1] * r, c[2] * m]
                })?
            }
            None => Texture::Constant(Vec3::new(0.0, r, m)),
        };
        let ior = mat.ior().unwrap_or(1.5);
        if !(ior >= 1.0 && ior.is_finite()) {
            return Err(LoadError::at(&self.at(format!("{place}/extensions/KHR_materials_ior")), "ior must be >= 1"));
        }
        let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
        let specular = match mat.specular() {
            Some(sp) => {
                if sp.specular_texture().is_some()
                    || sp.specular_color_texture().is_some()
                    || sp.specular_color_factor() != [1.0; 3]
                {
                    self.notes.push(format!(
                        "{place}: KHR_materials_specular: only specularFactor is used (not its colour or textures)"
                    ));
                }
                sp.specular_factor()
            }
            None => 1.0,
        };
        let vertex_color = colors.then(|| Texture::MeshAttribute(self.vertex_color.clone()));
        let mut material = Material::GltfPbr(Box::new(GltfPbrParams {
            base_color: base_color.clone(),
            vertex_color,
            metallic_roughness,
            f0,
            specular,
        }));
        if let Some(nt) = mat.normal_texture() {
            let p = format!("{place}/normalTexture");
            let s = nt.scale();
            let normals = self.texture(&nt.texture(), nt.tex_coord(), None, &p, |c| {
                // n = normalize((2c − 1) · (scale, scale, 1)), stored back in [0, 1].
                let v = Vec3::new((2.0 * c[0] - 1.0) * s, (2.0 * c[1] - 1.0) * s, 2.0 * c[2] - 1.0);
                (v.normalize_or(Vec3::Z) * 0.5 + 0.5).to_array()
            })?;
            material = Material::NormalMap { normals, inner: Box::new(material) };
        }
        // Two-sided around the normal map, so that the back side's flipped
        // frame is the one perturbed (as Mitsuba's twosided(normalmap(...))).
        if mat.double_sided() {
            material = Material::TwoSided(Box::new(material.clone()), Box::new(material));
        }
        if let Some(t) = mat.transmission() {
            let w = t.transmission_factor();
            if t.transmission_texture().is_some() {
                self.notes.push(format!(
                    "{place}: KHR_materials_transmission's transmissionTexture is not used (its factor is)"
                ));
            }
            if w > 0.0 {
                // A rough dielectric of the same roughness (α = r²) and IOR,
                // transmission tinted by the base colour: the specification's
                // microfacet BTDF, without the thin-walled / volume distinction.
                let alpha = Texture::Constant(Vec3::splat((r * r).max(1e-3)));
                let glass = Material::RoughDielectric(RoughDielectricParams {
                    roughness: Roughness { kind: MicrofacetType::Ggx, alpha_u: alpha.clone(), alpha_v: alpha },
                    eta: ior.max(1.0 + 1e-4),
                    specular_reflectance: Texture::Constant(Vec3::ONE),
                    specular_transmittance: base_color,
                });
                material = Material::Blend {
                    weight: Texture::Constant(Vec3::splat((w * (1.0 - m)).clamp(0.0, 1.0))),
                    first: Box::new(material),
                    second: Box::new(glass),
                };
            }
        }
        if alpha.constant() != Some(Vec3::ONE) {
            material = Material::Mask { opacity: alpha, inner: Box::new(material) };
        }
        let id = self.scene.add_material(material);
        // Emission.
        let strength = mat.emissive_strength().unwrap_or(1.0);
        let e = Vec3::from(mat.emissive_factor()) * strength;
        let emission = if e.max_element() <= 0.0 {
            None
        } else if let Some(info) = mat.emissive_texture() {
            let p = format!("{place}/emissiveTexture");
            Some(self.texture(&info.texture(), info.tex_coord(), info.texture_transform(), &p, |c| {
                [srgb_to_linear(c[0]) * e.x, srgb_to_linear(c[1]) * e.y, srgb_to_linear(c[2]) * e.z]
            })?)
        } else {
            Some(Texture::Constant(e))
        };
        self.materials.insert(key, (id, emission.clone()));
        Ok((id, emission))
    }

    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    fn light(&mut self, light: &gltf::khr_lights_punctual::Light, world: &Mat4, node: &str) -> Result<()> {
        let loc = self.at(format!("/extensions/KHR_lights_punctual/lights/{}", light.index()));
        let power = Vec3::from(light.color()) * light.intensity();
        if !(power.is_finite() && power.min_element() >= 0.0) {
            return Err(LoadError::at(&loc, "color × intensity must be finite and not negative"));
        }
        let (_, rot, pos) = world.to_scale_rotation_translation();
        let light = match light.kind() {
            LightKind::Point => Light::Point(PointLight { position: pos, intensity: power }),
            LightKind::Directional => {
                let direction = (rot * Vec3::NEG_Z).normalize();
                Light::Directional(DirectionalLight { direction, irradiance: power, scene_radius: 0.0 })
            }
            LightKind::Spot { inner_cone_angle, outer_cone_angle } => {
                let (inner, outer) = (inner_cone_angle.to_degrees(), outer_cone_angle.to_degrees());
                if !(inner >= 0.0 && inner < outer && outer <= 90.0) {
                    return Err(LoadError::at(
                        &loc,
                        format!("spot: need 0 <= innerConeAngle < outerConeAngle <= π/2 (got {inner}°, {outer}°)"),
                    ));
                }
                // Mitsuba's spot shines along its +z; glTF's along −z.
                let m = Mat4::from_rotation_translation(rot * Quat::from_rotation_y(std::f32::consts::PI), pos);
                Light::Spot(SpotLight::new(m, power, outer, inner))
            }
        };
        let _ = node;
        self.lights += 1;
        self.scene.add_light(light, &loc)
    }

    fn finish(mut self, ov: &Overrides) -> Result<(RenderJob, Vec<String>)> {
        let whole = self.at("/");
        if self.scene.shape_count() == 0 {
            return Err(LoadError::at(&whole, "the scene has no triangles to render"));
        }
        if let Some(path) = &ov.envmap {
            self.scene.add_light(crate::builder::envmap_light(path)?, &whole)?;
        } else if self.lights == 0 {
            self.notes.push("the scene has no punctual lights: lit by a uniform white environment (radiance 1)".into());
            self.scene.add_light(Light::Constant(ConstantLight { radiance: Vec3::ONE }), &whole)?;
        }
        let (lo, hi) = self.bounds;
        let (camera, (w, h)) = match self.camera.take() {
            Some((world, cam, place)) => camera(&world, &cam, &self.at(place))?,
            None => {
                let (centre, radius) = ((lo + hi) * 0.5, ((hi - lo) * 0.5).length().max(1e-3));
                let d = radius / (DEFAULT_FOV_DEG.to_radians() * 0.5).sin();
                let to_world = look_at(centre + Vec3::new(0.0, 0.0, d), centre, Vec3::Y);
                let s = DEFAULT_FILM_SIZE;
                (Camera::new(to_world, DEFAULT_FOV_DEG, FovAxis::Y, s, s, 1e-3 * d, 10.0 * (d + radius)), (s, s))
            }
        };
        self.scene.set_camera(camera, None);
        self.scene.set_film(Film::new(w, h), Filter::new(FilterKind::Gaussian { stddev: 0.5 }));
        let kind =
            crate::builder::sampler_kind(ov.sampler.as_deref(), penumbra_render::sampling::SamplerKind::Independent)?;
        self.scene.set_sampler(Sampler::new(kind, ov.seed.unwrap_or(0), ov.spp.unwrap_or(DEFAULT_SPP)));
        if let Some(spec) = &ov.integrator {
            let (integrator, selection) = crate::builder::integrator_override(spec)?;
            self.scene.set_integrator(integrator, selection, &whole);
        } else if self.has_volumes {
            // `path` ignores media: the volumes need the volumetric path tracer.
            self.notes.push("KHR_materials_volume: rendered by volpath, which absorbs inside the volumes".into());
            let (integrator, selection) = crate::builder::integrator_override("volpath")?;
            self.scene.set_integrator(integrator, selection, &whole);
        }
        let mut tables = vec![None; self.scene.shape_count()];
        for (id, t) in self.color_tables.drain(..) {
            tables[id as usize] = Some(t);
        }
        self.vertex_color.set_tables(tables);
        let job = self.scene.finish()?;
        Ok((job, self.notes))
    }
}

/// The Penumbra camera of a glTF camera at `world`, with its film size.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn camera(world: &Mat4, cam: &gltf::Camera, loc: &FileLoc) -> Result<(Camera, (u32, u32))> {
    // Rotation and position only (the specification forbids scale on cameras'
    // nodes; a stray one must not skew the rays); a half turn about y maps
    // Penumbra's +z view direction and +x image-left onto glTF's −z and −x.
    let (_, rot, pos) = world.to_scale_rotation_translation();
    let to_world = Mat4::from_rotation_translation(rot * Quat::from_rotation_y(std::f32::consts::PI), pos);
    let size = |aspect: f32| {
        let s = DEFAULT_FILM_SIZE as f32;
        if aspect >= 1.0 {
            (DEFAULT_FILM_SIZE, (s / aspect).round().max(1.0) as u32)
        } else {
            ((s * aspect).round().max(1.0) as u32, DEFAULT_FILM_SIZE)
        }
    };
    match cam.projection() {
        GltfProjection::Perspective(p) => {
            let aspect = p.aspect_ratio().unwrap_or(1.0);
            let (yfov, near) = (p.yfov().to_degrees(), p.znear());
            if !(aspect > 0.0 && aspect.is_finite() && yfov > 0.0 && yfov < 180.0 && near > 0.0) {
                return Err(LoadError::at(loc, "camera: need aspectRatio > 0, 0 < yfov < π and znear > 0"));
            }
            let far = p.zfar().unwrap_or(1e9);
            let (w, h) = size(aspect);
            Ok((Camera::new(to_world, yfov, FovAxis::Y, w, h, near, far), (w, h)))
        }
        GltfProjection::Orthographic(o) => {
            let (xmag, ymag) = (o.xmag().abs(), o.ymag().abs());
            if !(xmag > 0.0 && ymag > 0.0 && o.zfar() > o.znear()) {
                return Err(LoadError::at(loc, "orthographic camera: need xmag, ymag != 0 and zfar > znear"));
            }
            let (w, h) = size(xmag / ymag);
            // Mitsuba's orthographic film spans [−1, 1] in x: scaled to ±xmag.
            let m = to_world * Mat4::from_scale(Vec3::new(xmag, xmag, 1.0));
            Ok((Camera::orthographic(m, w, h, o.znear().max(0.0), o.zfar()), (w, h)))
        }
    }
}
