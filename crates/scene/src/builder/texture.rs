//! Texture parameters: a BSDF parameter given as a constant (`<rgb>`,
//! `<float>`, `<spectrum>`) or as a nested / referenced `<texture>`
//! (Mitsuba's `bitmap`, `checkerboard`, `mesh_attribute` and `volume`).
//!
//! | plugin   | parameters (defaults) |
//! |----------|-----------------------|
//! | `volume` | `volume` (required): a nested `<volume>` (constvolume, or a gridvolume of 1 or 3 channels) looked up at the world-space surface point; as a scalar, a constant's channel mean, a grid's value or luminance. Mitsuba refuses a float or colour there, and textures needing a mean (blendbsdf weights, …) or a gradient (bumpmap) cannot use it |

use super::{find_plugin, listed, Plugins};
use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use crate::image_io;
use crate::scene_builder::image_texture;
use glam::{Affine2, DMat4, Mat2, Vec2, Vec3};
use penumbra_render::math::Spectrum;
use penumbra_render::texture::{
    AttributeTable, Checkerboard, FilterType, MeshAttribute, MeshAttributeData, Texture, WrapMode,
};
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::Arc;

/// A builder of a texture from its `<texture>` node.
type BuildTexture = fn(&mut Textures, &Node) -> Result<Texture>;

pub(super) const TEXTURES: &Plugins<BuildTexture> = &[
    ("bitmap", |_, node| build_bitmap(node)),
    ("checkerboard", Textures::checkerboard),
    ("mesh_attribute", |_, node| mesh_attribute(node)),
    ("volume", |_, node| volume(node)),
];

/// Textures already built, by node identity (shared through `<ref>`).
#[derive(Default)]
pub(crate) struct Textures {
    cache: HashMap<*const Node, Texture>,
    /// `mesh_attribute` nodes read as a scalar (`eval_1`) and/or as a colour (`eval`).
    attr_uses: HashMap<*const Node, (bool, bool)>,
    /// Per-shape tables of `mesh_attribute` textures, installed by
    /// [`Textures::finish_mesh_attributes`].
    attr_tables: Vec<(Arc<MeshAttribute>, u32, AttributeTable)>,
}

impl Textures {
    /// The colour parameter `name` of `node`: a constant or a texture.
    pub fn spectrum(&mut self, node: &Node, name: &str, default: Spectrum) -> Result<Texture> {
        if let Some(child) = node.children_of(Kind::Texture).find(|c| c.name.as_deref() == Some(name)) {
            self.attr_uses.entry(Rc::as_ptr(&child.node)).or_default().1 = true;
            return self.build(&child.node);
        }
        Ok(Texture::Constant(
            node.get_rgb(name)?.map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)).unwrap_or(default),
        ))
    }

    /// A scalar parameter (roughness, opacity): a float or a texture read
    /// through `eval_1`.
    pub fn float(&mut self, node: &Node, name: &str, default: f32) -> Result<Texture> {
        if let Some(child) = node.children_of(Kind::Texture).find(|c| c.name.as_deref() == Some(name)) {
            self.attr_uses.entry(Rc::as_ptr(&child.node)).or_default().0 = true;
            return self.build(&child.node);
        }
        Ok(Texture::Constant(Spectrum::splat(node.float(name, default as f64)? as f32)))
    }

    /// A top-level or nested `<texture>`.
    pub fn build(&mut self, node: &Rc<Node>) -> Result<Texture> {
        let key = Rc::as_ptr(node);
        if let Some(t) = self.cache.get(&key) {
            return Ok(t.clone());
        }
        let t = self.build_texture(node)?;
        self.cache.insert(key, t.clone());
        Ok(t)
    }

    fn build_texture(&mut self, node: &Node) -> Result<Texture> {
        let Some(build) = find_plugin(TEXTURES, &node.plugin) else {
            return Err(node.error(format!(
                "texture type '{}' is not supported; Penumbra supports {}",
                node.plugin,
                listed(TEXTURES).iter().map(|t| format!("'{t}'")).collect::<Vec<_>>().join(" and ")
            )));
        };
        let t = build(self, node)?;
        node.check_all_used(if node.plugin == "volume" { &[Kind::Volume] } else { &[Kind::Texture] })?;
        Ok(t)
    }

    fn checkerboard(&mut self, node: &Node) -> Result<Texture> {
        if let Some(c) =
            node.children_of(Kind::Texture).find(|c| !matches!(c.name.as_deref(), Some("color0") | Some("color1")))
        {
            return Err(LoadError::at(&c.loc, "a texture nested in a checkerboard must be named 'color0' or 'color1'"));
        }
        let color0 = self.spectrum(node, "color0", Spectrum::splat(0.4))?;
        let color1 = self.spectrum(node, "color1", Spectrum::splat(0.2))?;
        let to_uv = to_uv(node)?;
        Ok(Texture::Checkerboard(Arc::new(Checkerboard { color0, color1, to_uv })))
    }
}

/// Mitsuba's `volume` texture: its nested volume named `volume`.
fn volume(node: &Node) -> Result<Texture> {
    let Some(child) = node.children_of(Kind::Volume).find(|c| c.name.as_deref() == Some("volume")) else {
        let loc = if node.props.iter().any(|p| p.name == "volume") { node.loc_of("volume") } else { &node.loc };
        return Err(LoadError::at(
            loc,
            "the volume texture needs a nested <volume name=\"volume\"> (constvolume or gridvolume); \
             Mitsuba refuses a float or colour here",
        ));
    };
    Ok(Texture::Volume(Arc::new(super::medium::colour_volume(child, "volume")?)))
}

fn mesh_attribute(node: &Node) -> Result<Texture> {
    let (name, loc) =
        node.get_string("name")?.ok_or_else(|| node.error("mesh_attribute needs a 'name', e.g. \"vertex_color\""))?;
    if !name.contains("vertex_") && !name.contains("face_") {
        return Err(LoadError::at(
            &loc,
            format!("invalid mesh attribute name \"{name}\": it must start with \"vertex_\" or \"face_\""),
        ));
    }
    let scale = node.float("scale", 1.0)? as f32;
    Ok(Texture::MeshAttribute(Arc::new(MeshAttribute::new(name, scale))))
}

impl Textures {
    /// Connects the `mesh_attribute` textures that the BSDF `bsdf` (already
    /// built) uses to shape `shape_id`, whose mesh has `attributes` over the
    /// triangles `indices` (`None` for analytic shapes). Fails, at the
    /// texture's line, where Mitsuba would fail when rendering: the shape
    /// lacks the attribute, or its size does not fit (a colour parameter
    /// takes 1 or 3 components, a scalar one 1).
    pub fn bind_mesh_attributes(
        &mut self,
        bsdf: &Rc<Node>,
        shape_id: u32,
        shape: &Node,
        attributes: &[MeshAttributeData],
        indices: Option<&[[u32; 3]]>,
    ) -> Result<()> {
        let mut stack = vec![bsdf.clone()];
        while let Some(n) = stack.pop() {
            for c in &n.children {
                if matches!(c.node.kind, Kind::Bsdf | Kind::Texture) {
                    stack.push(c.node.clone());
                }
            }
            let key = Rc::as_ptr(&n);
            let Some(Texture::MeshAttribute(tex)) = self.cache.get(&key) else { continue };
            let tex = tex.clone();
            let have = || {
                if attributes.is_empty() {
                    "it has no attributes".to_string()
                } else {
                    let list: Vec<String> =
                        attributes.iter().map(|a| format!("{} ({} components)", a.name, a.dim)).collect();
                    format!("it has {}", list.join(", "))
                }
            };
            let (Some(indices), Some(attr)) = (indices, attributes.iter().find(|a| a.name == tex.name)) else {
                return Err(n.error(format!(
                    "mesh_attribute: the {} at {} has no attribute \"{}\"; {}",
                    shape.describe(),
                    shape.loc,
                    tex.name,
                    if indices.is_some() { have() } else { "only meshes carry attributes".to_string() }
                )));
            };
            let (as_float, as_color) = self.attr_uses.get(&key).copied().unwrap_or((false, true));
            if (as_float && attr.dim != 1) || (as_color && attr.dim != 1 && attr.dim != 3) {
                return Err(n.error(format!(
                    "mesh_attribute \"{}\" has {} components; Mitsuba evaluates 1 or 3 for a colour and 1 for a scalar parameter",
                    tex.name, attr.dim
                )));
            }
            self.attr_tables.push((tex, shape_id, AttributeTable::new(attr, indices)));
        }
        Ok(())
    }

    /// Installs every `mesh_attribute` texture's per-shape tables once all
    /// `shape_count` shapes exist.
    pub fn finish_mesh_attributes(&mut self, shape_count: usize) {
        let mut by_texture: HashMap<*const MeshAttribute, (Arc<MeshAttribute>, Vec<Option<AttributeTable>>)> =
            HashMap::new();
        for (tex, shape, table) in self.attr_tables.drain(..) {
            let entry = by_texture.entry(Arc::as_ptr(&tex)).or_insert_with(|| (tex, vec![None; shape_count]));
            entry.1[shape as usize] = Some(table);
        }
        for (tex, tables) in by_texture.into_values() {
            tex.set_tables(tables);
        }
    }
}

/// Mitsuba's `to_uv`: a 3×3 affine map of uv; from a 4×4 transform the
/// third row and column (z) are dropped, keeping the translation.
fn to_uv(node: &Node) -> Result<Affine2> {
    let m: DMat4 = node.transform("to_uv")?;
    let c = m.to_cols_array_2d();
    let a = Affine2::from_mat2_translation(
        Mat2::from_cols(Vec2::new(c[0][0] as f32, c[0][1] as f32), Vec2::new(c[1][0] as f32, c[1][1] as f32)),
        Vec2::new(c[3][0] as f32, c[3][1] as f32),
    );
    if !a.is_finite() {
        return Err(LoadError::at(node.loc_of("to_uv"), "to_uv must be finite"));
    }
    Ok(a)
}

/// A `bitmap` node's texture, or an error naming the plugin for any other.
pub(super) fn build_bitmap_texture(node: &Node) -> Result<Texture> {
    if node.plugin != "bitmap" {
        return Err(node.error(format!("a {} texture cannot be used here; give a bitmap", node.plugin)));
    }
    build_bitmap(node)
}

fn build_bitmap(node: &Node) -> Result<Texture> {
    let source = image_source(node, "bitmap")?;
    let filter = match node.string("filter_type", "bilinear")?.as_str() {
        "bilinear" => FilterType::Bilinear,
        "nearest" => FilterType::Nearest,
        other => {
            return Err(LoadError::at(
                node.loc_of("filter_type"),
                format!("invalid filter_type '{other}': must be 'nearest' or 'bilinear'"),
            ))
        }
    };
    let wrap = match node.string("wrap_mode", "repeat")?.as_str() {
        "repeat" => WrapMode::Repeat,
        "mirror" => WrapMode::Mirror,
        "clamp" => WrapMode::Clamp,
        other => {
            return Err(LoadError::at(
                node.loc_of("wrap_mode"),
                format!("invalid wrap_mode '{other}': must be 'repeat', 'mirror' or 'clamp'"),
            ))
        }
    };
    // Storage precision: Penumbra always stores f32, which matches 'variant'
    // (8-bit sources differ from Mitsuba's 'auto' only by rounding).
    let format = node.string("format", "auto")?;
    if !["auto", "variant", "float16", "fp16", "uint8"].contains(&format.as_str()) {
        return Err(LoadError::at(
            node.loc_of("format"),
            format!("invalid format '{format}': must be 'auto', 'variant', 'float16' or 'uint8'"),
        ));
    }
    // Hardware interpolation on CUDA only.
    node.accept(&["accel"]);
    let raw = node.bool("raw", false)?;
    let to_uv = to_uv(node)?;
    let (img, loc, name) = match source {
        ImageSource::File(path, loc) => (
            image_io::read_image_with(&path, raw).map_err(|e| LoadError::at(&loc, e))?,
            loc,
            path.display().to_string(),
        ),
        // Given as linear values: `raw` has nothing to undo.
        ImageSource::Data(img, loc) => (img.as_ref().clone(), loc, "data".to_string()),
    };
    image_texture(img, filter, wrap, to_uv, &loc)
        .map_err(|e| LoadError::at(&loc, format!("bitmap texture '{name}': {}", e.message)))
}

/// Where a bitmap's or an environment map's pixels come from.
pub(super) enum ImageSource {
    /// An image file, resolved.
    File(std::path::PathBuf, crate::error::FileLoc),
    /// An image in memory, given from Python as `data` (linear RGB).
    Data(std::sync::Arc<image_io::RgbImage>, crate::error::FileLoc),
}

/// `data` (from Python) or else `filename`. `data` set on a texture read
/// from a file replaces the file's image, as Mitsuba's `params['id.data']`.
pub(super) fn image_source(node: &Node, what: &str) -> Result<ImageSource> {
    match (node.get_string("filename")?, node.get_image("data")?) {
        (_, Some((img, loc))) => Ok(ImageSource::Data(img, loc)),
        (Some((file, loc)), None) => {
            let path = super::resolve(&loc, &file, &format!("{what} image"))?;
            Ok(ImageSource::File(path, loc))
        }
        (None, None) => Err(node
            .error(format!("{what} needs a 'filename' (.exr, .hdr, .png or .jpg), or from Python an array as 'data'"))),
    }
}
