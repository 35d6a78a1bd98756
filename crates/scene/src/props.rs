//! Typed property access on scene nodes. Every read marks the property as
//! used; [`Node::check_all_used`] then turns any property the builder never
//! read into an error naming its file and line, so a parameter Penumbra does
//! not implement can never be silently ignored.

use crate::desc::{Child, Kind, Node, Property, Value};
use crate::error::{LoadError, Result};
use crate::spectrum::{self, ColorUse};
use glam::{DMat4, DVec3};
use std::rc::Rc;

impl Node {
    /// Human-readable name for messages: `shape 'sphere'`.
    pub fn describe(&self) -> String {
        format!("{} '{}'", self.kind.tag(), self.plugin)
    }

    fn find(&self, name: &str) -> Option<&Property> {
        let p = self.props.iter().rev().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    fn type_error(&self, p: &Property, want: &str) -> LoadError {
        LoadError::at(
            &p.loc,
            format!("parameter '{}' of {} must be {want}, found a {}", p.name, self.describe(), p.value.type_name()),
        )
    }

    /// Whether a property `name` is given.
    pub fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
    }

    /// A float (an integer is accepted and converted, as Mitsuba does);
    /// NaN and infinities are errors, whatever gave the value.
    pub fn get_float(&self, name: &str) -> Result<Option<f64>> {
        match self.find(name) {
            None => Ok(None),
            Some(p) => match p.value {
                Value::Float(v) if !v.is_finite() => Err(LoadError::at(
                    &p.loc,
                    format!("parameter '{}' of {} is {v}, which is not a finite number", p.name, self.describe()),
                )),
                Value::Float(v) => Ok(Some(v)),
                Value::Integer(v) => Ok(Some(v as f64)),
                _ => Err(self.type_error(p, "a float")),
            },
        }
    }
    /// Float property `name`, or `default` when absent.
    pub fn float(&self, name: &str, default: f64) -> Result<f64> {
        Ok(self.get_float(name)?.unwrap_or(default))
    }

    /// Integer property `name`, `None` when absent.
    pub fn get_int(&self, name: &str) -> Result<Option<i64>> {
        match self.find(name) {
            None => Ok(None),
            Some(p) => match p.value {
                Value::Integer(v) => Ok(Some(v)),
                Value::Float(v) if v.fract() == 0.0 => Ok(Some(v as i64)),
                _ => Err(self.type_error(p, "an integer")),
            },
        }
    }
    /// Integer property `name`, or `default` when absent.
    pub fn int(&self, name: &str, default: i64) -> Result<i64> {
        Ok(self.get_int(name)?.unwrap_or(default))
    }

    /// Boolean property `name`, or `default` when absent.
    pub fn bool(&self, name: &str, default: bool) -> Result<bool> {
        match self.find(name) {
            None => Ok(default),
            Some(p) => match p.value {
                Value::Boolean(v) => Ok(v),
                _ => Err(self.type_error(p, "a boolean")),
            },
        }
    }

    /// String property `name` with its file position, `None` when absent.
    pub fn get_string(&self, name: &str) -> Result<Option<(String, crate::error::FileLoc)>> {
        match self.find(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::String(v) => Ok(Some((v.clone(), p.loc.clone()))),
                _ => Err(self.type_error(p, "a string")),
            },
        }
    }
    /// An in-memory image property `name` (see [`Value::Image`]) with its
    /// position, `None` when absent.
    pub fn get_image(
        &self,
        name: &str,
    ) -> Result<Option<(std::sync::Arc<crate::image_io::RgbImage>, crate::error::FileLoc)>> {
        match self.find(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                Value::Image(v) => Ok(Some((v.clone(), p.loc.clone()))),
                _ => Err(self.type_error(p, "an image (an array given from Python)")),
            },
        }
    }

    /// String property `name`, or `default` when absent.
    pub fn string(&self, name: &str, default: &str) -> Result<String> {
        Ok(self.get_string(name)?.map(|s| s.0).unwrap_or_else(|| default.to_string()))
    }

    /// A colour: `<rgb>`, a `<float>` (grey) or a `<spectrum>` (constant,
    /// sampled or read from a file), converted to linear sRGB as Mitsuba's
    /// RGB variants do for this parameter: emitter colours as emission,
    /// the parameters Mitsuba reads unbounded (`eta`, `k`, ...) unclamped,
    /// all others as reflectances (see [`crate::spectrum`]).
    pub fn get_rgb(&self, name: &str) -> Result<Option<[f64; 3]>> {
        let usage = ColorUse::of(self.kind, name);
        let Some(p) = self.find(name) else {
            return Ok(None);
        };
        let rgb = match &p.value {
            Value::Rgb(v) => *v,
            Value::Float(v) => [*v; 3],
            Value::Integer(v) => [*v as f64; 3],
            Value::SpectrumConstant(v) => spectrum::constant_to_srgb(*v, usage),
            Value::SpectrumSampled(pairs) => spectrum::sampled_to_srgb(pairs, usage),
            _ => return Err(self.type_error(p, "an rgb colour, a spectrum or a float")),
        };
        // Rendering is in single precision: a colour past its range would
        // become infinite there, and then NaN.
        if rgb.iter().any(|c| !c.is_finite() || c.abs() > f32::MAX as f64) {
            return Err(LoadError::at(
                &p.loc,
                format!(
                    "parameter '{}' of {} is the colour ({}, {}, {}), which is not finite in single precision",
                    p.name,
                    self.describe(),
                    rgb[0],
                    rgb[1],
                    rgb[2]
                ),
            ));
        }
        Ok(Some(rgb))
    }

    /// A point (`<point>`; a `<vector>` is accepted too).
    pub fn get_point(&self, name: &str) -> Result<Option<DVec3>> {
        match self.find(name) {
            None => Ok(None),
            Some(p) => match p.value {
                Value::Point(v) | Value::Vector(v) => Ok(Some(v)),
                _ => Err(self.type_error(p, "a point")),
            },
        }
    }

    /// Transform property `name`, `None` when absent.
    pub fn get_transform(&self, name: &str) -> Result<Option<DMat4>> {
        match self.find(name) {
            None => Ok(None),
            Some(p) => match p.value {
                Value::Transform(m) => Ok(Some(m)),
                _ => Err(self.type_error(p, "a transform")),
            },
        }
    }
    /// Transform property `name`, or the identity when absent.
    pub fn transform(&self, name: &str) -> Result<DMat4> {
        Ok(self.get_transform(name)?.unwrap_or(DMat4::IDENTITY))
    }

    /// Marks parameters as read that are valid but cannot change the image.
    pub fn accept(&self, names: &[&str]) {
        for n in names {
            self.find(n);
        }
    }

    /// Location of a property, for errors about its value.
    pub fn loc_of(&self, name: &str) -> &crate::error::FileLoc {
        self.props.iter().rev().find(|p| p.name == name).map(|p| &p.loc).unwrap_or(&self.loc)
    }

    /// An error at this node.
    pub fn error(&self, message: impl Into<String>) -> LoadError {
        LoadError::at(&self.loc, message)
    }

    /// Nested objects of one kind.
    pub fn children_of(&self, kind: Kind) -> impl Iterator<Item = &Child> {
        self.children.iter().filter(move |c| c.node.kind == kind)
    }

    /// At most one nested object of a kind; two are an error.
    pub fn single_child(&self, kind: Kind) -> Result<Option<Rc<Node>>> {
        let mut it = self.children_of(kind);
        let first = it.next();
        if let Some(second) = it.next() {
            return Err(LoadError::at(
                &second.loc,
                format!("{} has more than one nested {}", self.describe(), kind.tag()),
            ));
        }
        Ok(first.map(|c| c.node.clone()))
    }

    /// Fails on any property that was never read, and on nested objects of
    /// kinds outside `allowed_children`.
    pub fn check_all_used(&self, allowed_children: &[Kind]) -> Result<()> {
        if let Some(p) = self.props.iter().find(|p| !p.used.get()) {
            return Err(LoadError::at(
                &p.loc,
                format!(
                    "parameter '{}' of {} is not supported by Penumbra (or unknown to Mitsuba 3); \
                     remove it or check its spelling",
                    p.name,
                    self.describe()
                ),
            ));
        }
        if let Some(c) = self.children.iter().find(|c| !allowed_children.contains(&c.node.kind)) {
            return Err(LoadError::at(
                &c.loc,
                format!("a nested {} is not supported inside {}", c.node.kind.tag(), self.describe()),
            ));
        }
        Ok(())
    }
}
