//! pbrt-v4's `Texture` directives (`imagemap`, `checkerboard`, `scale`,
//! `mix`, `constant`) and the texture-or-value parameters of materials.
//!
//! Penumbra's textures are a constant, an image or a checkerboard of two
//! textures; pbrt's `scale` and `mix` are folded into those when one side is
//! a constant (an image's texels scaled, a checkerboard's colours scaled),
//! and are an error otherwise.
//!
//! | texture      | parameters read                                                   |
//! |--------------|-------------------------------------------------------------------|
//! | imagemap     | filename, filter (bilinear; point = nearest; trilinear, ewa: bilinear, no MIP-map), wrap (repeat, clamp), encoding (sRGB, linear), scale, invert, maxanisotropy, mapping uv with uscale vscale udelta vdelta |
//! | checkerboard | dimension 2, tex1 (1), tex2 (0), mapping uv with uscale vscale udelta vdelta: point sampled (pbrt-v4 box-filters it over the ray footprint) |
//! | scale        | tex (1), scale (1)                                                |
//! | mix          | tex1 (0), tex2 (1), amount (0.5, a number)                        |
//! | constant     | value (1)                                                         |

use super::super::params::{ParamList, ParamType};
use super::super::parser::TextureEntity;
use super::spectra::{to_rgb, SpectrumUse};
use crate::error::{FileLoc, LoadError, Result};
use crate::image_io::RgbImage;
use crate::scene_builder::image_texture;
use glam::{Affine2, Mat2, Vec2, Vec3};
use penumbra_render::texture::{Checkerboard, FilterType, Texture, WrapMode};
use std::collections::HashMap;
use std::sync::{Arc, OnceLock};

/// A texture before it becomes Penumbra's: what `scale` and `mix` fold over.
#[derive(Clone)]
pub enum PTex {
    /// The same value everywhere (a float texture in all three channels).
    Const([f32; 3]),
    /// An image (linear RGB, top row first) looked up at `to_uv`(uv).
    Image {
        image: Arc<RgbImage>,
        filter: FilterType,
        wrap: WrapMode,
        to_uv: Affine2,
        scale: [f32; 3],
        /// Penumbra's texture, once built: materials sharing this texture
        /// share one bitmap.
        built: Arc<OnceLock<Texture>>,
    },
    /// pbrt's 2D checkerboard: `tex1` where ⌊s⌋ + ⌊t⌋ is even.
    Checker { tex1: Box<PTex>, tex2: Box<PTex>, to_st: Affine2 },
}

impl PTex {
    /// Multiplied by the colour `k`.
    pub fn scaled(self, k: [f32; 3]) -> PTex {
        let mul = |a: [f32; 3]| [a[0] * k[0], a[1] * k[1], a[2] * k[2]];
        match self {
            PTex::Const(c) => PTex::Const(mul(c)),
            PTex::Image { image, filter, wrap, to_uv, scale, .. } => {
                PTex::Image { image, filter, wrap, to_uv, scale: mul(scale), built: Default::default() }
            }
            PTex::Checker { tex1, tex2, to_st } => {
                PTex::Checker { tex1: Box::new(tex1.scaled(k)), tex2: Box::new(tex2.scaled(k)), to_st }
            }
        }
    }

    /// With each value mapped by `f` (a float texture's roughness remapping).
    pub fn map(self, f: &dyn Fn(f32) -> f32) -> PTex {
        match self {
            PTex::Const(c) => PTex::Const(c.map(f)),
            PTex::Image { image, filter, wrap, to_uv, scale, .. } => {
                let pixels = image.pixels.iter().map(|p| [0, 1, 2].map(|c| f(p[c] * scale[c]))).collect();
                let image = Arc::new(RgbImage { width: image.width, height: image.height, pixels });
                PTex::Image { image, filter, wrap, to_uv, scale: [1.0; 3], built: Default::default() }
            }
            PTex::Checker { tex1, tex2, to_st } => {
                PTex::Checker { tex1: Box::new(tex1.map(f)), tex2: Box::new(tex2.map(f)), to_st }
            }
        }
    }

    /// The constant value, if it is one.
    pub fn constant(&self) -> Option<[f32; 3]> {
        match self {
            PTex::Const(c) => Some(*c),
            _ => None,
        }
    }

    /// Penumbra's texture.
    pub fn build(&self, at: &FileLoc) -> Result<Texture> {
        Ok(match self {
            PTex::Const(c) => Texture::Constant(Vec3::from_array(*c)),
            PTex::Image { image, filter, wrap, to_uv, scale, built } => {
                if let Some(t) = built.get() {
                    return Ok(t.clone());
                }
                let pixels = image.pixels.iter().map(|p| [p[0] * scale[0], p[1] * scale[1], p[2] * scale[2]]).collect();
                let img = RgbImage { width: image.width, height: image.height, pixels };
                let t = image_texture(img, *filter, *wrap, *to_uv, at)?;
                let _ = built.set(t.clone());
                t
            }
            // Mitsuba's checkerboard alternates on squares of side ½ in its
            // uv: colour 0 where the fractional parts of u and v lie on the
            // same side of ½, that is where ⌊2u⌋ + ⌊2v⌋ is even; so u = s / 2.
            PTex::Checker { tex1, tex2, to_st } => Texture::Checkerboard(Arc::new(Checkerboard {
                color0: tex1.build(at)?,
                color1: tex2.build(at)?,
                to_uv: Affine2::from_scale(Vec2::splat(0.5)) * *to_st,
            })),
        })
    }
}

/// The textures a scene defines, by name, float and spectrum apart (pbrt
/// keeps two namespaces).
#[derive(Default)]
pub struct Textures {
    float: HashMap<String, PTex>,
    spectrum: HashMap<String, PTex>,
}

/// pbrt's (u, v) → (s, t) of the `uv` mapping.
fn uv_mapping(p: &ParamList, at: &FileLoc) -> Result<Affine2> {
    if let Some(m) = p.string("mapping")? {
        if m != "uv" {
            return Err(LoadError::at(at, format!("texture mapping \"{m}\" is not supported; only \"uv\"")));
        }
    }
    let (su, sv) = (p.float("uscale", 1.0)? as f32, p.float("vscale", 1.0)? as f32);
    let (du, dv) = (p.float("udelta", 0.0)? as f32, p.float("vdelta", 0.0)? as f32);
    Ok(Affine2::from_mat2_translation(Mat2::from_diagonal(Vec2::new(su, sv)), Vec2::new(du, dv)))
}

impl Textures {
    /// Defines the textures in file order (a texture may use earlier ones).
    pub fn new(defs: &[TextureEntity]) -> Result<Textures> {
        let mut t = Textures::default();
        for def in defs {
            let spectrum = def.value_kind == "spectrum";
            let e = &def.entity;
            let usage = if spectrum { Some(SpectrumUse::Albedo) } else { None };
            let p = &e.params;
            let tex = match e.kind.as_str() {
                "constant" => t.value(p, "value", usage, [1.0; 3])?,
                "scale" => {
                    let a = t.value(p, "tex", usage, [1.0; 3])?;
                    let b = t.value(p, "scale", None, [1.0; 3])?;
                    match (a.constant(), b.constant()) {
                        (_, Some(k)) => a.scaled(k),
                        (Some(k), None) => b.scaled(k),
                        _ => {
                            return Err(LoadError::at(
                                &e.loc,
                                "a \"scale\" texture of two textures is not supported; one of tex and scale must be a value",
                            ))
                        }
                    }
                }
                "mix" => {
                    let a = t.value(p, "tex1", usage, [0.0; 3])?;
                    let b = t.value(p, "tex2", usage, [1.0; 3])?;
                    let amount = t.value(p, "amount", None, [0.5; 3])?;
                    match (a.constant(), b.constant(), amount.constant()) {
                        (Some(a), Some(b), Some(m)) => {
                            PTex::Const([0, 1, 2].map(|c| (1.0 - m[c]) * a[c] + m[c] * b[c]))
                        }
                        (_, _, Some([m, ..])) if m <= 0.0 => a,
                        (_, _, Some([m, ..])) if m >= 1.0 => b,
                        _ => {
                            return Err(LoadError::at(
                                &e.loc,
                                "a \"mix\" texture is supported only between two values with a constant amount",
                            ))
                        }
                    }
                }
                "checkerboard" => {
                    if p.int("dimension", 2)? != 2 {
                        return Err(LoadError::at(&e.loc, "checkerboard: only \"dimension\" 2 is supported"));
                    }
                    let tex1 = t.value(p, "tex1", usage, [1.0; 3])?;
                    let tex2 = t.value(p, "tex2", usage, [0.0; 3])?;
                    PTex::Checker { tex1: Box::new(tex1), tex2: Box::new(tex2), to_st: uv_mapping(p, &e.loc)? }
                }
                "imagemap" => imagemap(p, spectrum, &e.loc)?,
                other => {
                    return Err(LoadError::at(
                        &e.loc,
                        format!(
                        "texture \"{other}\" is not supported; supported: imagemap, checkerboard, scale, mix, constant"
                    ),
                    ))
                }
            };
            p.check_unused(&format!("Texture \"{}\" \"{}\"", def.name, e.kind))?;
            let map = if spectrum { &mut t.spectrum } else { &mut t.float };
            map.insert(def.name.clone(), tex);
        }
        Ok(t)
    }

    /// A texture-or-value parameter: `texture name` (a spectrum texture
    /// when `usage` is set, else a float texture), a spectrum (`rgb`,
    /// `spectrum`, `blackbody`) for spectra, or a `float`; `default` if absent.
    pub fn value(&self, p: &ParamList, name: &str, usage: Option<SpectrumUse>, default: [f32; 3]) -> Result<PTex> {
        Ok(self.optional(p, name, usage)?.unwrap_or(PTex::Const(default)))
    }

    /// [`Textures::value`] without a default.
    pub fn optional(&self, p: &ParamList, name: &str, usage: Option<SpectrumUse>) -> Result<Option<PTex>> {
        let Some(param) = p.params.iter().find(|x| x.name == name) else { return Ok(None) };
        let loc = param.loc.clone();
        Ok(Some(match param.ty {
            ParamType::Texture => {
                let n = p.texture(name)?.unwrap_or_default();
                let map = if usage.is_some() { &self.spectrum } else { &self.float };
                match map.get(&n) {
                    Some(t) => t.clone(),
                    None => {
                        let kind = if usage.is_some() { "spectrum" } else { "float" };
                        return Err(LoadError::at(
                            &loc,
                            format!("no {kind} texture named \"{n}\" is defined before this"),
                        ));
                    }
                }
            }
            ParamType::Float => PTex::Const([p.float(name, 0.0)? as f32; 3]),
            _ if usage.is_some() => {
                let (v, vloc) = p.spectrum(name)?.expect("present");
                PTex::Const(to_rgb(&v, usage.unwrap_or(SpectrumUse::Albedo), &vloc)?)
            }
            other => {
                return Err(LoadError::at(
                    &loc,
                    format!("\"{} {name}\" should be a float or a texture, not {}", other.name(), other.name()),
                ))
            }
        }))
    }
}

/// pbrt-v4's `imagemap`.
fn imagemap(p: &ParamList, spectrum: bool, at: &FileLoc) -> Result<PTex> {
    let file = p.string("filename")?.ok_or_else(|| LoadError::at(at, "imagemap needs a \"string filename\""))?;
    let path = at.file.parent().map(|d| d.join(&file)).unwrap_or_else(|| file.clone().into());
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let eight_bit = matches!(ext.as_str(), "png" | "jpg" | "jpeg");
    let raw = match p.string("encoding")?.as_deref() {
        None | Some("sRGB") => false,
        Some("linear") => true,
        Some(other) => {
            return Err(LoadError::at(
                at,
                format!("imagemap encoding \"{other}\" is not supported; use sRGB or linear"),
            ))
        }
    };
    let mut image = crate::image_io::read_image_with(&path, raw || !eight_bit)
        .map_err(|e| LoadError::at(at, format!("imagemap \"{file}\": {e}")))?;
    let filter = match p.string("filter")?.as_deref() {
        None | Some("bilinear") | Some("trilinear") | Some("ewa") | Some("EWA") => FilterType::Bilinear,
        Some("point") => FilterType::Nearest,
        Some(other) => {
            return Err(LoadError::at(
                at,
                format!("imagemap filter \"{other}\" is not one of point, bilinear, trilinear, ewa"),
            ))
        }
    };
    p.float("maxanisotropy", 8.0)?;
    let wrap = match p.string("wrap")?.as_deref() {
        None | Some("repeat") => WrapMode::Repeat,
        Some("clamp") => WrapMode::Clamp,
        Some(other) => {
            return Err(LoadError::at(at, format!("imagemap wrap \"{other}\" is not supported; use repeat or clamp")))
        }
    };
    let scale = p.float("scale", 1.0)? as f32;
    let invert = p.bool("invert", false)?;
    if !spectrum {
        // A float texture reads the channels' average (pbrt-v4's `GetChannels(..).Average()`).
        for px in &mut image.pixels {
            *px = [(px[0] + px[1] + px[2]) / 3.0; 3];
        }
    }
    // pbrt-v4: scale, then invert (1 - v, clamped at 0).
    let scale = if invert {
        for px in &mut image.pixels {
            *px = px.map(|c| (1.0 - scale * c).max(0.0));
        }
        1.0
    } else {
        scale
    };
    // pbrt-v4 looks images up at (s, 1 - t), its first row at t = 1;
    // Penumbra's bitmaps put the first row at v = 0.
    let flip = Affine2::from_mat2_translation(Mat2::from_diagonal(Vec2::new(1.0, -1.0)), Vec2::new(0.0, 1.0));
    let to_uv = flip * uv_mapping(p, at)?;
    Ok(PTex::Image { image: Arc::new(image), filter, wrap, to_uv, scale: [scale; 3], built: Default::default() })
}
