//! Texture parameters: a BSDF parameter given as a constant (`<rgb>`,
//! `<float>`, `<spectrum>`) or as a nested / referenced `<texture>`
//! (Mitsuba's `bitmap` and `checkerboard`).

use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use crate::image_io;
use glam::{Affine2, DMat4, Mat2, Vec2, Vec3};
use penumbra_render::math::Spectrum;
use penumbra_render::texture::{Bitmap, Checkerboard, FilterType, Texture, WrapMode};
use std::collections::HashMap;
use std::sync::Arc;

const TEXTURES: &[&str] = &["bitmap", "checkerboard"];

/// Textures already built, by node identity (shared through `<ref>`).
#[derive(Default)]
pub(crate) struct Textures {
    cache: HashMap<*const Node, Texture>,
}

impl Textures {
    /// The colour parameter `name` of `node`: a constant or a texture.
    pub fn spectrum(&mut self, node: &Node, name: &str, default: Spectrum) -> Result<Texture> {
        if let Some(child) = node.children_of(Kind::Texture).find(|c| c.name.as_deref() == Some(name)) {
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
            return self.build(&child.node);
        }
        Ok(Texture::Constant(Spectrum::splat(node.float(name, default as f64)? as f32)))
    }

    /// A top-level or nested `<texture>`.
    pub fn build(&mut self, node: &std::rc::Rc<Node>) -> Result<Texture> {
        let key = std::rc::Rc::as_ptr(node);
        if let Some(t) = self.cache.get(&key) {
            return Ok(t.clone());
        }
        let t = self.build_texture(node)?;
        self.cache.insert(key, t.clone());
        Ok(t)
    }

    fn build_texture(&mut self, node: &Node) -> Result<Texture> {
        let t = match node.plugin.as_str() {
            "bitmap" => build_bitmap(node)?,
            "checkerboard" => {
                if let Some(c) = node
                    .children_of(Kind::Texture)
                    .find(|c| !matches!(c.name.as_deref(), Some("color0") | Some("color1")))
                {
                    return Err(LoadError::at(
                        &c.loc,
                        "a texture nested in a checkerboard must be named 'color0' or 'color1'",
                    ));
                }
                let color0 = self.spectrum(node, "color0", Spectrum::splat(0.4))?;
                let color1 = self.spectrum(node, "color1", Spectrum::splat(0.2))?;
                let to_uv = to_uv(node)?;
                Texture::Checkerboard(Arc::new(Checkerboard { color0, color1, to_uv }))
            }
            other => {
                return Err(node.error(format!(
                    "texture type '{other}' is not supported; Penumbra supports {}",
                    TEXTURES.iter().map(|t| format!("'{t}'")).collect::<Vec<_>>().join(" and ")
                )))
            }
        };
        node.check_all_used(&[Kind::Texture])?;
        Ok(t)
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

fn build_bitmap(node: &Node) -> Result<Texture> {
    let (file, loc) = node
        .get_string("filename")?
        .ok_or_else(|| node.error("bitmap needs a 'filename' (.exr, .hdr, .png or .jpg)"))?;
    let path = super::resolve(&loc, &file, "bitmap texture")?;
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
    let img = image_io::read_image_with(&path, raw).map_err(|e| LoadError::at(&loc, e))?;
    let data = img.pixels.iter().map(|p| Vec3::from_array(*p)).collect();
    let bitmap = Bitmap::new(img.width as usize, img.height as usize, data, filter, wrap, to_uv)
        .map_err(|e| LoadError::at(&loc, format!("bitmap texture '{}': {e}", path.display())))?;
    Ok(Texture::Bitmap(Arc::new(bitmap)))
}
