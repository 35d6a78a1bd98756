//! pbrt-v4 parameter lists: `"type name" value` or `"type name" [values]`,
//! typed when parsed, read by typed getters that mark them used, so that a
//! parameter nobody read is an error naming its position (as Penumbra's
//! Mitsuba reader treats unused properties).

use crate::error::{FileLoc, LoadError, Result};
use std::cell::Cell;

/// A parameter's declared type (pbrt-v4's names; `point`, `vector`,
/// `normal` and `color`, from pbrt-v3 files, read as `point3`, `vector3`,
/// `normal3` and `rgb`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamType {
    /// `integer`
    Integer,
    /// `float`
    Float,
    /// `point2`
    Point2,
    /// `vector2`
    Vector2,
    /// `point3`
    Point3,
    /// `vector3`
    Vector3,
    /// `normal3` (or `normal`)
    Normal3,
    /// `bool`
    Bool,
    /// `string`
    String,
    /// `texture`: the name of a texture
    Texture,
    /// `rgb`
    Rgb,
    /// `spectrum`: (wavelength, value) pairs, a constant, a named spectrum or an `.spd` file
    Spectrum,
    /// `blackbody`: a temperature in kelvin
    Blackbody,
}

impl ParamType {
    fn parse(s: &str) -> Option<ParamType> {
        Some(match s {
            "integer" => ParamType::Integer,
            "float" => ParamType::Float,
            "point2" => ParamType::Point2,
            "vector2" => ParamType::Vector2,
            "point3" | "point" => ParamType::Point3,
            "vector3" | "vector" => ParamType::Vector3,
            "normal3" | "normal" => ParamType::Normal3,
            "bool" => ParamType::Bool,
            "string" => ParamType::String,
            "texture" => ParamType::Texture,
            "rgb" | "color" => ParamType::Rgb,
            "spectrum" => ParamType::Spectrum,
            "blackbody" => ParamType::Blackbody,
            _ => return None,
        })
    }

    /// The name pbrt-v4 files use.
    pub fn name(self) -> &'static str {
        match self {
            ParamType::Integer => "integer",
            ParamType::Float => "float",
            ParamType::Point2 => "point2",
            ParamType::Vector2 => "vector2",
            ParamType::Point3 => "point3",
            ParamType::Vector3 => "vector3",
            ParamType::Normal3 => "normal3",
            ParamType::Bool => "bool",
            ParamType::String => "string",
            ParamType::Texture => "texture",
            ParamType::Rgb => "rgb",
            ParamType::Spectrum => "spectrum",
            ParamType::Blackbody => "blackbody",
        }
    }

    /// Numbers per element (0: not numeric).
    fn arity(self) -> usize {
        match self {
            ParamType::Integer | ParamType::Float | ParamType::Blackbody => 1,
            ParamType::Point2 | ParamType::Vector2 => 2,
            ParamType::Point3 | ParamType::Vector3 | ParamType::Normal3 | ParamType::Rgb => 3,
            ParamType::Spectrum => 1,
            ParamType::Bool | ParamType::String | ParamType::Texture => 0,
        }
    }
}

/// A parameter's values as written.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// Numbers (integers are whole numbers here).
    Nums(Vec<f64>),
    /// Strings (`string`, `texture`, a named `spectrum`).
    Strs(Vec<String>),
    /// Booleans.
    Bools(Vec<bool>),
}

/// One parameter.
#[derive(Debug, Clone)]
pub struct Param {
    /// Its declared type.
    pub ty: ParamType,
    /// Its name.
    pub name: String,
    /// Its values.
    pub values: Values,
    /// Where its `"type name"` string starts.
    pub loc: FileLoc,
    used: Cell<bool>,
}

/// A directive's parameters, in the order written.
#[derive(Debug, Clone, Default)]
pub struct ParamList {
    /// The parameters.
    pub params: Vec<Param>,
}

/// A spectrum-valued parameter as written (`rgb`, `blackbody` or `spectrum`).
#[derive(Debug, Clone, PartialEq)]
pub enum SpectrumValue {
    /// `"rgb name" [r g b]`
    Rgb([f64; 3]),
    /// `"blackbody name" T`
    Blackbody(f64),
    /// `"spectrum name" v`: a constant
    Constant(f64),
    /// `"spectrum name" [λ0 v0 λ1 v1 ...]`
    Samples(Vec<(f64, f64)>),
    /// `"spectrum name" "metal-Cu-eta"` or a file name
    Named(String),
}

impl Param {
    /// A parameter from its `"type name"` declaration and the values that
    /// followed it, each value token with its position (`Ok(word)` bare,
    /// `Err(string)` quoted).
    pub fn new(decl: &str, loc: FileLoc, vals: Vec<(std::result::Result<String, String>, FileLoc)>) -> Result<Param> {
        let mut it = decl.split_whitespace();
        let (Some(ty), Some(name), None) = (it.next(), it.next(), it.next()) else {
            return Err(LoadError::at(
                &loc,
                format!("parameter declaration \"{decl}\" must be \"type name\", e.g. \"float radius\""),
            ));
        };
        let Some(ty) = ParamType::parse(ty) else {
            return Err(LoadError::at(
                &loc,
                format!(
                    "unknown parameter type '{ty}' in \"{decl}\": pbrt-v4's types are integer, float, point2, vector2, \
                     point3, vector3, normal3, bool, string, texture, rgb, spectrum, blackbody"
                ),
            ));
        };
        let values = match ty {
            ParamType::Bool => {
                let mut b = Vec::new();
                for (v, vloc) in vals {
                    match v.as_ref().map_or_else(|s| s.as_str(), |s| s.as_str()) {
                        "true" => b.push(true),
                        "false" => b.push(false),
                        other => {
                            return Err(LoadError::at(&vloc, format!("\"{decl}\": '{other}' is not true or false")))
                        }
                    }
                }
                Values::Bools(b)
            }
            ParamType::String | ParamType::Texture => {
                let mut s = Vec::new();
                for (v, vloc) in vals {
                    match v {
                        Err(q) => s.push(q),
                        Ok(w) => {
                            return Err(LoadError::at(
                                &vloc,
                                format!("\"{decl}\": expected a quoted string, found '{w}'"),
                            ))
                        }
                    }
                }
                Values::Strs(s)
            }
            ParamType::Spectrum if vals.iter().any(|(v, _)| v.is_err()) => {
                let mut s = Vec::new();
                for (v, vloc) in vals {
                    match v {
                        Err(q) => s.push(q),
                        Ok(w) => {
                            return Err(LoadError::at(
                                &vloc,
                                format!("\"{decl}\": a spectrum is either numbers or one name, not both ('{w}')"),
                            ))
                        }
                    }
                }
                Values::Strs(s)
            }
            _ => {
                let mut n = Vec::with_capacity(vals.len());
                for (v, vloc) in vals {
                    let w = match v {
                        Ok(w) => w,
                        Err(q) => {
                            return Err(LoadError::at(&vloc, format!("\"{decl}\": expected a number, found \"{q}\"")))
                        }
                    };
                    let x: f64 =
                        w.parse().map_err(|_| LoadError::at(&vloc, format!("\"{decl}\": '{w}' is not a number")))?;
                    if !x.is_finite() {
                        return Err(LoadError::at(&vloc, format!("\"{decl}\": '{w}' is not a finite number")));
                    }
                    if ty == ParamType::Integer && x.fract() != 0.0 {
                        return Err(LoadError::at(&vloc, format!("\"{decl}\": '{w}' is not an integer")));
                    }
                    n.push(x);
                }
                let arity = ty.arity();
                if n.len() % arity != 0 || (ty == ParamType::Spectrum && n.len() > 1 && n.len() % 2 != 0) {
                    return Err(LoadError::at(
                        &loc,
                        format!(
                            "\"{decl}\" has {} numbers, not a multiple of {}",
                            n.len(),
                            if ty == ParamType::Spectrum { 2 } else { arity }
                        ),
                    ));
                }
                Values::Nums(n)
            }
        };
        let empty = match &values {
            Values::Nums(v) => v.is_empty(),
            Values::Strs(v) => v.is_empty(),
            Values::Bools(v) => v.is_empty(),
        };
        if empty {
            return Err(LoadError::at(&loc, format!("\"{decl}\" has no values")));
        }
        Ok(Param { ty, name: name.to_string(), values, loc, used: Cell::new(false) })
    }

    /// Whether a getter has read it.
    pub fn is_used(&self) -> bool {
        self.used.get()
    }

    fn decl(&self) -> String {
        format!("\"{} {}\"", self.ty.name(), self.name)
    }
}

impl ParamList {
    /// The parameter `name`, marked used; an error if it is declared with
    /// a type other than those in `types`.
    fn find(&self, name: &str, types: &[ParamType]) -> Result<Option<&Param>> {
        let Some(p) = self.params.iter().find(|p| p.name == name) else { return Ok(None) };
        if !types.contains(&p.ty) {
            let want: Vec<_> = types.iter().map(|t| t.name()).collect();
            return Err(LoadError::at(
                &p.loc,
                format!("{} should have type {}, not {}", p.decl(), want.join(" or "), p.ty.name()),
            ));
        }
        p.used.set(true);
        Ok(Some(p))
    }

    fn nums(&self, name: &str, ty: ParamType) -> Result<Option<(&[f64], &FileLoc)>> {
        Ok(self.find(name, &[ty])?.map(|p| match &p.values {
            Values::Nums(v) => (v.as_slice(), &p.loc),
            _ => unreachable!("numeric types hold numbers"),
        }))
    }

    fn one(&self, name: &str, ty: ParamType) -> Result<Option<f64>> {
        match self.nums(name, ty)? {
            None => Ok(None),
            Some(([x], _)) => Ok(Some(*x)),
            Some((v, loc)) => {
                Err(LoadError::at(loc, format!("\"{} {name}\" takes one value, not {}", ty.name(), v.len())))
            }
        }
    }

    /// A `float`, or `default`.
    pub fn float(&self, name: &str, default: f64) -> Result<f64> {
        Ok(self.one(name, ParamType::Float)?.unwrap_or(default))
    }

    /// An `integer`, or `default`.
    pub fn int(&self, name: &str, default: i64) -> Result<i64> {
        Ok(self.one(name, ParamType::Integer)?.map_or(default, |x| x as i64))
    }

    /// A `bool`, or `default`.
    pub fn bool(&self, name: &str, default: bool) -> Result<bool> {
        match self.find(name, &[ParamType::Bool])? {
            None => Ok(default),
            Some(p) => match &p.values {
                Values::Bools(b) if b.len() == 1 => Ok(b[0]),
                _ => Err(LoadError::at(&p.loc, format!("{} takes one value", p.decl()))),
            },
        }
    }

    /// A `string`, or `None`.
    pub fn string(&self, name: &str) -> Result<Option<String>> {
        self.one_string(name, ParamType::String)
    }

    /// A `texture` reference (a texture's name), or `None`.
    pub fn texture(&self, name: &str) -> Result<Option<String>> {
        self.one_string(name, ParamType::Texture)
    }

    fn one_string(&self, name: &str, ty: ParamType) -> Result<Option<String>> {
        match self.find(name, &[ty])? {
            None => Ok(None),
            Some(p) => match &p.values {
                Values::Strs(s) if s.len() == 1 => Ok(Some(s[0].clone())),
                _ => Err(LoadError::at(&p.loc, format!("{} takes one string", p.decl()))),
            },
        }
    }

    /// All strings of a `string` array (or `None`).
    pub fn strings(&self, name: &str) -> Result<Option<Vec<String>>> {
        Ok(self.find(name, &[ParamType::String])?.map(|p| match &p.values {
            Values::Strs(s) => s.clone(),
            _ => unreachable!("strings hold strings"),
        }))
    }

    /// The declared type of the parameter `name`, if given (not marked used).
    pub fn type_of(&self, name: &str) -> Option<ParamType> {
        self.params.iter().find(|p| p.name == name).map(|p| p.ty)
    }

    /// All numbers of a `float` array (or `None`).
    pub fn floats(&self, name: &str) -> Result<Option<Vec<f64>>> {
        Ok(self.nums(name, ParamType::Float)?.map(|(v, _)| v.to_vec()))
    }

    /// All numbers of an `integer` array (or `None`).
    pub fn ints(&self, name: &str) -> Result<Option<Vec<i64>>> {
        Ok(self.nums(name, ParamType::Integer)?.map(|(v, _)| v.iter().map(|&x| x as i64).collect()))
    }

    /// Triples of a `point3`, `vector3` or `normal3` array (`ty`), or `None`.
    pub fn triples(&self, name: &str, ty: ParamType) -> Result<Option<Vec<[f64; 3]>>> {
        Ok(self.nums(name, ty)?.map(|(v, _)| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()))
    }

    /// Pairs of a `point2` or `vector2` array (`ty`), or `None`.
    pub fn pairs(&self, name: &str, ty: ParamType) -> Result<Option<Vec<[f64; 2]>>> {
        Ok(self.nums(name, ty)?.map(|(v, _)| v.chunks_exact(2).map(|c| [c[0], c[1]]).collect()))
    }

    /// A spectrum given as `rgb`, `blackbody` or `spectrum` (or `None`);
    /// the parameter's position comes with it.
    pub fn spectrum(&self, name: &str) -> Result<Option<(SpectrumValue, FileLoc)>> {
        let Some(p) = self.find(name, &[ParamType::Rgb, ParamType::Blackbody, ParamType::Spectrum])? else {
            return Ok(None);
        };
        let bad = |what: &str| LoadError::at(&p.loc, format!("{} {what}", p.decl()));
        let v = match (&p.values, p.ty) {
            (Values::Nums(n), ParamType::Rgb) if n.len() == 3 => SpectrumValue::Rgb([n[0], n[1], n[2]]),
            (Values::Nums(_), ParamType::Rgb) => return Err(bad("takes three values (r g b)")),
            (Values::Nums(n), ParamType::Blackbody) if n.len() == 1 => SpectrumValue::Blackbody(n[0]),
            (Values::Nums(_), ParamType::Blackbody) => return Err(bad("takes one temperature in kelvin")),
            (Values::Nums(n), ParamType::Spectrum) if n.len() == 1 => SpectrumValue::Constant(n[0]),
            (Values::Nums(n), ParamType::Spectrum) => {
                let s: Vec<(f64, f64)> = n.chunks_exact(2).map(|c| (c[0], c[1])).collect();
                if s.windows(2).any(|w| w[1].0 <= w[0].0) {
                    return Err(bad("must list wavelengths in increasing order"));
                }
                SpectrumValue::Samples(s)
            }
            (Values::Strs(s), ParamType::Spectrum) if s.len() == 1 => SpectrumValue::Named(s[0].clone()),
            (Values::Strs(_), _) => return Err(bad("takes one name")),
            _ => return Err(bad("has values of the wrong kind")),
        };
        Ok(Some((v, p.loc.clone())))
    }

    /// Marks every parameter not read yet as used and returns their
    /// declarations (`"float radius"`): for a directive whose parameters are
    /// knowingly set aside, with a note naming them.
    pub fn take_unused(&self) -> Vec<String> {
        self.params
            .iter()
            .filter(|p| !p.is_used())
            .map(|p| {
                p.used.set(true);
                format!("{} {}", p.ty.name(), p.name)
            })
            .collect()
    }

    /// An error for the first parameter no getter read: `what` names the
    /// directive (e.g. `Shape "sphere"`).
    pub fn check_unused(&self, what: &str) -> Result<()> {
        match self.params.iter().find(|p| !p.is_used()) {
            None => Ok(()),
            Some(p) => Err(LoadError::at(
                &p.loc,
                format!(
                    "parameter {} of {what} is not used by Penumbra (misspelt, or not supported): remove it",
                    p.decl()
                ),
            )),
        }
    }
}
