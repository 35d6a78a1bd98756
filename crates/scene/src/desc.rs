//! Format-neutral scene description: a tree of plugin nodes with typed
//! properties, each carrying its file position. The Mitsuba XML reader
//! produces it; `builder/` turns it into a render scene.

use crate::error::FileLoc;
use glam::{DMat4, DVec3};
use std::cell::Cell;
use std::rc::Rc;

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
}
