//! Texture parameters: a BSDF parameter given as a constant (`<rgb>`,
//! `<float>`, `<spectrum>`) or as a nested / referenced `<texture>`.

use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use glam::Vec3;
use penumbra_render::math::Spectrum;
use penumbra_render::texture::Texture;
use std::collections::HashMap;

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
        let t = build_texture(node)?;
        self.cache.insert(key, t.clone());
        Ok(t)
    }
}

fn build_texture(node: &Node) -> Result<Texture> {
    Err(LoadError::at(&node.loc, format!("texture '{}' is not supported yet", node.plugin)))
}
