//! Mitsuba's object model: a tree of plugin nodes with typed properties,
//! each carrying its file position. The Mitsuba XML reader produces it;
//! `builder/` translates it into calls of the format-neutral
//! [`crate::scene_builder::SceneBuilder`]. Other formats' readers call the
//! builder directly.

use crate::error::{FileLoc, LoadError};
use glam::{DMat4, DVec3};
use std::cell::Cell;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::Arc;

/// A typed property value, after `$name` substitution.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// `<float value="..."/>`.
    Float(f64),
    /// `<integer value="..."/>`.
    Integer(i64),
    /// `<boolean value="..."/>`.
    Boolean(bool),
    /// `<string value="..."/>`.
    String(String),
    /// `<rgb value="r, g, b"/>` (a single value is broadcast to all three).
    Rgb([f64; 3]),
    /// `<spectrum value="v"/>` with a single constant value.
    SpectrumConstant(f64),
    /// `<spectrum value="400:0.1, 500:0.8"/>`: (wavelength nm, value) pairs.
    SpectrumSampled(Vec<(f64, f64)>),
    /// `<point x=".." y=".." z=".."/>`.
    Point(DVec3),
    /// `<vector x=".." y=".." z=".."/>`.
    Vector(DVec3),
    /// `<transform>` composed in the order written (later operations apply after earlier ones).
    Transform(DMat4),
    /// An image in memory (linear RGB), given from Python as a bitmap
    /// texture's or an environment map's `data`; no XML form.
    Image(Arc<crate::image_io::RgbImage>),
}

impl Value {
    /// The XML tag name of the value's type, for error messages.
    pub fn type_name(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::SpectrumConstant(_) | Value::SpectrumSampled(_) => "spectrum",
            Value::Point(_) => "point",
            Value::Vector(_) => "vector",
            Value::Transform(_) => "transform",
            Value::Image(_) => "image",
        }
    }
}

/// A named property of a node.
#[derive(Debug, Clone)]
pub struct Property {
    /// Property name (the `name` attribute).
    pub name: String,
    /// The parsed value.
    pub value: Value,
    /// Where the property appears in the file.
    pub loc: FileLoc,
    /// Set when the builder reads the property; unread ones are errors.
    pub used: Cell<bool>,
}

/// The object kinds of the format (Mitsuba's tag names).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `<scene>`, the root.
    Scene,
    /// `<shape>`.
    Shape,
    /// `<bsdf>`.
    Bsdf,
    /// `<emitter>`.
    Emitter,
    /// `<sensor>`.
    Sensor,
    /// `<film>`.
    Film,
    /// `<sampler>`.
    Sampler,
    /// `<rfilter>`, the reconstruction filter.
    Rfilter,
    /// `<integrator>`.
    Integrator,
    /// `<texture>`.
    Texture,
    /// `<medium>`.
    Medium,
    /// `<phase>`, a phase function.
    Phase,
    /// `<volume>`.
    Volume,
}

impl Kind {
    /// Maps an XML tag to a kind, `None` for tags that are not objects.
    pub fn from_tag(tag: &str) -> Option<Kind> {
        Some(match tag {
            "scene" => Kind::Scene,
            "shape" => Kind::Shape,
            "bsdf" => Kind::Bsdf,
            "emitter" => Kind::Emitter,
            "sensor" => Kind::Sensor,
            "film" => Kind::Film,
            "sampler" => Kind::Sampler,
            "rfilter" => Kind::Rfilter,
            "integrator" => Kind::Integrator,
            "texture" => Kind::Texture,
            "medium" => Kind::Medium,
            "phase" => Kind::Phase,
            "volume" => Kind::Volume,
            _ => return None,
        })
    }
    /// The XML tag name of the kind.
    pub fn tag(self) -> &'static str {
        match self {
            Kind::Scene => "scene",
            Kind::Shape => "shape",
            Kind::Bsdf => "bsdf",
            Kind::Emitter => "emitter",
            Kind::Sensor => "sensor",
            Kind::Film => "film",
            Kind::Sampler => "sampler",
            Kind::Rfilter => "rfilter",
            Kind::Integrator => "integrator",
            Kind::Texture => "texture",
            Kind::Medium => "medium",
            Kind::Phase => "phase",
            Kind::Volume => "volume",
        }
    }
}

/// One plugin instance: `<shape type="sphere" id="s">...</shape>`.
///
/// Nodes reached through `<ref id=.../>` are shared (`Rc`), so a BSDF
/// referenced by two shapes is one node, and the builder can build it once.
#[derive(Debug)]
pub struct Node {
    /// Object kind (the tag).
    pub kind: Kind,
    /// The `type` attribute (empty for the scene root).
    pub plugin: String,
    /// The `id` attribute, if given.
    pub id: Option<String>,
    /// The `name` attribute of a nested object (e.g. `<texture name="reflectance">`).
    pub name: Option<String>,
    /// Properties in document order.
    pub props: Vec<Property>,
    /// Nested objects in document order, references already resolved.
    pub children: Vec<Child>,
    /// Where the opening tag appears.
    pub loc: FileLoc,
}

/// A nested object with the name it was given in its parent (if any).
#[derive(Debug, Clone)]
pub struct Child {
    /// `name` attribute of the nested tag, or of the `<ref name=.. id=..>`.
    pub name: Option<String>,
    /// The referenced or nested node.
    pub node: Rc<Node>,
    /// Where the nesting (or the `<ref>`) appears in the parent.
    pub loc: FileLoc,
}

/// A parsed scene file: the root `<scene>` node.
#[derive(Debug)]
pub struct SceneDesc {
    /// The root `<scene>` node.
    pub root: Rc<Node>,
    /// The scene's `version` attribute.
    pub version: String,
    /// The files older than version 2.0.0, upgraded in memory as Mitsuba 3
    /// upgrades them, in the order read (empty for a current scene).
    pub upgraded: Vec<UpgradedFile>,
}

/// A file older than version 2.0.0 (Mitsuba 0.x/1.x), read as Mitsuba 3's
/// `upgrade_from_v1` reads it.
#[derive(Debug, Clone)]
pub struct UpgradedFile {
    /// The file.
    pub file: Arc<PathBuf>,
    /// Its `version` attribute.
    pub version: String,
    /// The parameters renamed, in document order.
    pub renames: Vec<Rename>,
}

/// One parameter renamed by the upgrade: `maxDepth` -> `max_depth`,
/// diffuse's `diffuseReflectance` -> `reflectance`, or `uoffset`/`voffset`/
/// `uscale`/`vscale` -> `to_uv`.
#[derive(Debug, Clone)]
pub struct Rename {
    /// Where the old parameter is written.
    pub loc: FileLoc,
    /// The name written in the file.
    pub from: String,
    /// The name it now has.
    pub to: String,
}

/// A new value for property `name` of the object with id `id`
/// (`"red.reflectance"`), as Python's `scene.set` gives it.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// The object's `id`; `sensor` also names the scene's sensor when no
    /// object has that id.
    pub id: String,
    /// The property's name.
    pub name: String,
    /// The new value.
    pub value: Value,
}

impl SceneDesc {
    /// One line per upgraded file, for a note on stderr: `old.xml has scene
    /// version 0.5.0, upgraded in memory as Mitsuba 3 upgrades it: maxDepth
    /// -> max_depth (line 3), ...`.
    pub fn upgrade_notes(&self) -> Vec<String> {
        self.upgraded
            .iter()
            .map(|u| {
                let items: Vec<String> =
                    u.renames.iter().map(|r| format!("{} -> {} (line {})", r.from, r.to, r.loc.line)).collect();
                format!(
                    "{} has scene version {}, upgraded in memory as Mitsuba 3 upgrades it: {}",
                    u.file.display(),
                    u.version,
                    if items.is_empty() { "nothing renamed".to_string() } else { items.join(", ") }
                )
            })
            .collect()
    }

    /// `e` with a hint when it is about an upgraded file: the name as
    /// written there, or what the upgrade does and does not do.
    pub fn explain(&self, mut e: LoadError) -> LoadError {
        let Some(loc) = &e.loc else { return e };
        let Some(u) = self.upgraded.iter().find(|u| u.file == loc.file) else { return e };
        let hint = match u.renames.iter().find(|r| r.loc == *loc) {
            Some(r) => format!(
                "written \"{}\" in this scene version {} file, and renamed \"{}\" as Mitsuba 3 \
                 renames the parameters of old files",
                r.from, u.version, r.to
            ),
            None => format!(
                "this file has scene version {}, read as Mitsuba 3 reads it: parameter names \
                 upgraded to snake_case; plugins and parameters that Mitsuba 3 no longer has are \
                 errors there too",
                u.version
            ),
        };
        e.message.push_str(&format!("\n  ({hint})"));
        e
    }

    /// A copy of the scene with `overrides` applied in order (later ones
    /// win). A property the object has is replaced by a value of a
    /// compatible type; one it lacks is added (and, as every property, is
    /// an error at build time if its plugin does not read it). Objects
    /// shared through `<ref>` stay shared.
    pub fn with_overrides(&self, overrides: &[Override]) -> std::result::Result<SceneDesc, String> {
        let mut copies = std::collections::HashMap::new();
        let root = copy_node(&self.root, overrides, &mut copies)?;
        let applied: std::collections::HashSet<usize> = copies.values().flat_map(|(_, a)| a.iter().copied()).collect();
        for (i, o) in overrides.iter().enumerate() {
            if !applied.contains(&i) {
                let ids = ids(&self.root);
                return Err(format!(
                    "no object with id '{}' (objects with an id: {})",
                    o.id,
                    if ids.is_empty() { "none".to_string() } else { ids.join(", ") }
                ));
            }
        }
        Ok(SceneDesc { root, version: self.version.clone(), upgraded: self.upgraded.clone() })
    }
}

/// The ids of every object under `node`, in document order (for messages).
pub fn ids(node: &Node) -> Vec<String> {
    let mut out: Vec<String> = node.id.iter().cloned().collect();
    for c in &node.children {
        for id in ids(&c.node) {
            if !out.contains(&id) {
                out.push(id);
            }
        }
    }
    out
}

/// Whether `o` addresses `node`.
fn addresses(node: &Node, o: &Override) -> bool {
    node.id.as_deref() == Some(o.id.as_str()) || (o.id == "sensor" && node.kind == Kind::Sensor && node.id.is_none())
}

/// Whether a property of type `old` may take the value `new`.
fn compatible(old: &Value, new: &Value) -> bool {
    use Value::*;
    let colour = |v: &Value| matches!(v, Rgb(_) | SpectrumConstant(_) | SpectrumSampled(_) | Float(_) | Integer(_));
    match (old, new) {
        (Float(_) | Integer(_), Float(_) | Integer(_)) => true,
        (Rgb(_) | SpectrumConstant(_) | SpectrumSampled(_), n) => colour(n),
        (Point(_) | Vector(_), Point(_) | Vector(_)) => true,
        (o, n) => o.type_name() == n.type_name(),
    }
}

/// A deep copy of `node` with the overrides that address it applied;
/// `copies` maps each original node to its copy and the overrides applied.
fn copy_node(
    node: &Rc<Node>,
    overrides: &[Override],
    copies: &mut std::collections::HashMap<*const Node, (Rc<Node>, Vec<usize>)>,
) -> std::result::Result<Rc<Node>, String> {
    if let Some((copy, _)) = copies.get(&Rc::as_ptr(node)) {
        return Ok(copy.clone());
    }
    let mut props = node.props.clone();
    let mut applied = Vec::new();
    for (i, o) in overrides.iter().enumerate().filter(|(_, o)| addresses(node, o)) {
        let what = format!("{}.{}", o.id, o.name);
        match props.iter_mut().find(|p| p.name == o.name) {
            Some(p) if compatible(&p.value, &o.value) => {
                // A value given as a float where the file has an integer (or
                // the reverse) keeps the file's type.
                p.value = match (&p.value, &o.value) {
                    (Value::Integer(_), Value::Float(f)) if f.fract() == 0.0 => Value::Integer(*f as i64),
                    (Value::Float(_), Value::Integer(k)) => Value::Float(*k as f64),
                    _ => o.value.clone(),
                };
            }
            Some(p) => {
                return Err(format!("{what} is a {} ({}), not a {}", p.value.type_name(), p.loc, o.value.type_name()))
            }
            None if node.children.iter().any(|c| c.name.as_deref() == Some(o.name.as_str())) => {
                return Err(format!("{what} is a nested object (a texture?), not a value: set its own parameters"))
            }
            None => props.push(Property {
                name: o.name.clone(),
                value: o.value.clone(),
                loc: node.loc.clone(),
                used: Cell::new(false),
            }),
        }
        applied.push(i);
    }
    for p in &props {
        p.used.set(false);
    }
    let mut children = Vec::with_capacity(node.children.len());
    for c in &node.children {
        children.push(Child { name: c.name.clone(), node: copy_node(&c.node, overrides, copies)?, loc: c.loc.clone() });
    }
    let copy = Rc::new(Node {
        kind: node.kind,
        plugin: node.plugin.clone(),
        id: node.id.clone(),
        name: node.name.clone(),
        props,
        children,
        loc: node.loc.clone(),
    });
    copies.insert(Rc::as_ptr(node), (copy.clone(), applied));
    Ok(copy)
}
