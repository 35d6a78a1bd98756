//! pbrt-v4's directives, read into a [`PbrtScene`]: the graphics state
//! (current transformation matrix, material, area light, orientation,
//! media) kept as pbrt-v4's `BasicSceneBuilder` keeps it, and every entity
//! recorded with its parameters, its transform and its position.

use super::lexer::{Lexer, Tok, Token};
use super::params::{Param, ParamList};
use crate::error::{FileLoc, LoadError, Result};
use glam::{DMat4, DVec3, DVec4};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Most nested `Include`/`Import` files (a file that includes itself
/// reaches it at once).
pub const MAX_INCLUDE_DEPTH: usize = 32;

/// A directive's type and parameters: `Shape "sphere" "float radius" 2`.
#[derive(Debug, Clone)]
pub struct Entity {
    /// The type string (`"sphere"`).
    pub kind: String,
    /// The parameters.
    pub params: ParamList,
    /// Where the directive starts.
    pub loc: FileLoc,
}

/// A shape's material: the n-th anonymous `Material`, or a named one.
#[derive(Debug, Clone, PartialEq)]
pub enum MaterialRef {
    /// Index into [`PbrtScene::materials`]; `None` before any `Material`
    /// (pbrt-v4's default, a `diffuse` of reflectance 0.5).
    Anonymous(Option<usize>),
    /// A name given to `MakeNamedMaterial`, as written at `NamedMaterial`.
    Named(String, FileLoc),
}

/// A `Shape` with what the graphics state held when it was given.
#[derive(Debug, Clone)]
pub struct ShapeEntity {
    /// Type and parameters.
    pub entity: Entity,
    /// The current transformation matrix.
    pub world_from_object: DMat4,
    /// `ReverseOrientation` in effect.
    pub reverse_orientation: bool,
    /// The current material.
    pub material: MaterialRef,
    /// The current `AreaLightSource`, if any.
    pub area_light: Option<Entity>,
    /// `MediumInterface` names (inside, outside); "" is none.
    pub media: (String, String),
}

/// A `LightSource` placed by the current transformation matrix.
#[derive(Debug, Clone)]
pub struct LightEntity {
    /// Type and parameters.
    pub entity: Entity,
    /// The current transformation matrix.
    pub world_from_light: DMat4,
    /// The outside medium ("" is none).
    pub medium: String,
}

/// A `Texture "name" "float"|"spectrum" "class" ...`.
#[derive(Debug, Clone)]
pub struct TextureEntity {
    /// Its name.
    pub name: String,
    /// `"float"` or `"spectrum"`.
    pub value_kind: String,
    /// Class (`imagemap`, `checkerboard`, ...) and parameters.
    pub entity: Entity,
    /// The current transformation matrix.
    pub world_from_texture: DMat4,
}

/// An `ObjectBegin "name"` ... `ObjectEnd` block.
#[derive(Debug, Clone)]
pub struct InstanceDefinition {
    /// Its shapes, with transforms relative to the world (pbrt-v4 places
    /// them by the transform current inside the block).
    pub shapes: Vec<ShapeEntity>,
    /// Where `ObjectBegin` is.
    pub loc: FileLoc,
}

/// An `ObjectInstance "name"`.
#[derive(Debug, Clone)]
pub struct InstanceUse {
    /// The definition's name.
    pub name: String,
    /// The current transformation matrix.
    pub world_from_instance: DMat4,
    /// Where it is.
    pub loc: FileLoc,
}

/// A camera and the transform current at its `Camera` directive.
#[derive(Debug, Clone)]
pub struct CameraEntity {
    /// Type and parameters.
    pub entity: Entity,
    /// The current transformation matrix at `Camera` (pbrt's world to camera).
    pub camera_from_world: DMat4,
    /// The outside medium ("" is none).
    pub medium: String,
}

/// A pbrt-v4 scene as its files describe it, not yet interpreted.
#[derive(Debug, Clone, Default)]
pub struct PbrtScene {
    /// `Camera` (`None`: pbrt-v4's default perspective camera).
    pub camera: Option<CameraEntity>,
    /// `Film`, `Sampler`, `Integrator`, `PixelFilter`, `Accelerator`, when given.
    pub film: Option<Entity>,
    /// `Sampler`.
    pub sampler: Option<Entity>,
    /// `Integrator`.
    pub integrator: Option<Entity>,
    /// `PixelFilter`.
    pub filter: Option<Entity>,
    /// `Accelerator`.
    pub accelerator: Option<Entity>,
    /// `Option` parameters, in order.
    pub options: ParamList,
    /// The `ColorSpace` last given (pbrt-v4's default: `srgb`).
    pub color_space: Option<(String, FileLoc)>,
    /// Anonymous `Material`s, in order.
    pub materials: Vec<Entity>,
    /// `MakeNamedMaterial`s by name (type in the `"string type"` parameter).
    pub named_materials: HashMap<String, Entity>,
    /// `Texture`s, in order.
    pub textures: Vec<TextureEntity>,
    /// `MakeNamedMedium`s by name, with the transform current there.
    pub media: HashMap<String, (Entity, DMat4)>,
    /// Shapes outside object definitions.
    pub shapes: Vec<ShapeEntity>,
    /// `LightSource`s.
    pub lights: Vec<LightEntity>,
    /// `ObjectBegin` blocks by name.
    pub instance_definitions: HashMap<String, InstanceDefinition>,
    /// `ObjectInstance`s, in order.
    pub instances: Vec<InstanceUse>,
}

#[derive(Debug, Clone)]
struct GraphicsState {
    /// The transform at the start and end of the shutter interval
    /// (`ActiveTransform` chooses which the transform directives change).
    ctm: [DMat4; 2],
    active: [bool; 2],
    reverse_orientation: bool,
    material: MaterialRef,
    area_light: Option<Entity>,
    media: (String, String),
}

/// What a push saved, to check pairs (`AttributeBegin` with `AttributeEnd`).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Push {
    Attribute,
    Transform,
    Object,
}

/// Reads a pbrt-v4 scene file and the files it includes.
pub fn parse_file(path: &Path) -> Result<PbrtScene> {
    let text = read_text(path, None)?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut p = Parser::new(base);
    p.run(path, &text)?;
    Ok(p.scene)
}

/// Reads a pbrt-v4 scene from a string; `Include`d files are looked up
/// relative to `base` (`name` appears in errors).
pub fn parse_str(text: &str, name: &Path, base: &Path) -> Result<PbrtScene> {
    let mut p = Parser::new(base.to_path_buf());
    p.run(name, text)?;
    Ok(p.scene)
}

/// A file's text: UTF-8 (an error names the first bad byte), gzip
/// decompressed when the name ends in `.gz`.
fn read_text(path: &Path, from: Option<&FileLoc>) -> Result<String> {
    let err = |m: String| match from {
        Some(l) => LoadError::at(l, m),
        None => LoadError::in_file(path, m),
    };
    let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read {}: {e}", path.display())))?;
    let bytes = if path.extension().is_some_and(|e| e == "gz") {
        let mut out = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(&bytes[..]), &mut out)
            .map_err(|e| err(format!("{}: not a valid gzip file: {e}", path.display())))?;
        out
    } else {
        bytes
    };
    String::from_utf8(bytes).map_err(|e| {
        LoadError::in_file(
            path,
            format!(
                "not a pbrt-v4 text file: invalid UTF-8 at byte {} (a binary file, or text in another encoding)",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

struct Parser {
    /// Relative `Include` names resolve against the first file's directory, as in pbrt-v4.
    base: PathBuf,
    scene: PbrtScene,
    gs: GraphicsState,
    stack: Vec<(Push, GraphicsState, FileLoc)>,
    named_coords: HashMap<String, [DMat4; 2]>,
    in_world: bool,
    /// The object definition being read: its name and shapes.
    object: Option<(String, InstanceDefinition)>,
    /// Open files, innermost last (for the include depth and cycles).
    files: Vec<PathBuf>,
    /// A token read ahead.
    peeked: Option<Token>,
}

impl Parser {
    fn new(base: PathBuf) -> Parser {
        Parser {
            base,
            scene: PbrtScene::default(),
            gs: GraphicsState {
                ctm: [DMat4::IDENTITY; 2],
                active: [true, true],
                reverse_orientation: false,
                material: MaterialRef::Anonymous(None),
                area_light: None,
                media: (String::new(), String::new()),
            },
            stack: Vec::new(),
            named_coords: HashMap::new(),
            in_world: false,
            object: None,
            files: Vec::new(),
            peeked: None,
        }
    }

    fn run(&mut self, path: &Path, text: &str) -> Result<()> {
        self.files.push(path.to_path_buf());
        let mut lex = Lexer::new(text, Arc::new(path.to_path_buf()));
        while let Some(t) = self.next(&mut lex)? {
            self.directive(t, &mut lex)?;
        }
        self.files.pop();
        Ok(())
    }

    fn next(&mut self, lex: &mut Lexer) -> Result<Option<Token>> {
        match self.peeked.take() {
            Some(t) => Ok(Some(t)),
            None => lex.next_token(),
        }
    }

    fn peek<'a>(&'a mut self, lex: &mut Lexer) -> Result<Option<&'a Token>> {
        if self.peeked.is_none() {
            self.peeked = lex.next_token()?;
        }
        Ok(self.peeked.as_ref())
    }

    /// A quoted string argument of `what`.
    fn string(&mut self, lex: &mut Lexer, what: &str, at: &FileLoc) -> Result<(String, FileLoc)> {
        match self.next(lex)? {
            Some(Token { tok: Tok::Str(s), loc }) => Ok((s, loc)),
            Some(t) => Err(LoadError::at(&t.loc, format!("{what}: expected a quoted string, found {}", show(&t.tok)))),
            None => Err(LoadError::at(at, format!("{what}: expected a quoted string, found the end of the file"))),
        }
    }

    /// `n` numbers, optionally in brackets.
    fn numbers(&mut self, lex: &mut Lexer, n: usize, what: &str, at: &FileLoc) -> Result<Vec<f64>> {
        let bracketed = matches!(self.peek(lex)?, Some(Token { tok: Tok::Open, .. }));
        if bracketed {
            self.next(lex)?;
        }
        let mut v = Vec::with_capacity(n);
        for _ in 0..n {
            match self.next(lex)? {
                Some(Token { tok: Tok::Word(w), loc }) => {
                    let x: f64 =
                        w.parse().map_err(|_| LoadError::at(&loc, format!("{what}: '{w}' is not a number")))?;
                    if !x.is_finite() {
                        return Err(LoadError::at(&loc, format!("{what}: '{w}' is not a finite number")));
                    }
                    v.push(x);
                }
                Some(t) => {
                    return Err(LoadError::at(
                        &t.loc,
                        format!("{what} takes {n} numbers; found {} after {}", show(&t.tok), v.len()),
                    ))
                }
                None => {
                    return Err(LoadError::at(at, format!("{what} takes {n} numbers; the file ends after {}", v.len())))
                }
            }
        }
        if bracketed {
            match self.next(lex)? {
                Some(Token { tok: Tok::Close, .. }) => {}
                Some(t) => return Err(LoadError::at(&t.loc, format!("{what} takes {n} numbers; expected ']' here"))),
                None => return Err(LoadError::at(at, format!("{what}: missing ']'"))),
            }
        }
        Ok(v)
    }

    /// The parameter list that follows a directive's own arguments.
    fn params(&mut self, lex: &mut Lexer) -> Result<ParamList> {
        let mut list = ParamList::default();
        while let Some(Token { tok: Tok::Str(_), .. }) = self.peek(lex)? {
            let Some(Token { tok: Tok::Str(decl), loc }) = self.next(lex)? else { unreachable!() };
            let mut vals = Vec::new();
            match self.next(lex)? {
                Some(Token { tok: Tok::Open, loc: open }) => loop {
                    match self.next(lex)? {
                        Some(Token { tok: Tok::Close, .. }) => break,
                        Some(Token { tok: Tok::Word(w), loc }) => vals.push((Ok(w), loc)),
                        Some(Token { tok: Tok::Str(s), loc }) => vals.push((Err(s), loc)),
                        Some(Token { tok: Tok::Open, loc }) => {
                            return Err(LoadError::at(&loc, format!("\"{decl}\": '[' inside its values")))
                        }
                        None => return Err(LoadError::at(&open, format!("\"{decl}\": '[' without its ']'"))),
                    }
                },
                Some(Token { tok: Tok::Word(w), loc }) => vals.push((Ok(w), loc)),
                Some(Token { tok: Tok::Str(s), loc }) => vals.push((Err(s), loc)),
                Some(t) => return Err(LoadError::at(&t.loc, format!("\"{decl}\": expected a value, found ']'"))),
                None => return Err(LoadError::at(&loc, format!("\"{decl}\" has no value"))),
            }
            if let Some(old) = list.params.iter().find(|p| decl.split_whitespace().nth(1) == Some(p.name.as_str())) {
                return Err(LoadError::at(
                    &loc,
                    format!("parameter \"{decl}\" given twice (first at line {})", old.loc.line),
                ));
            }
            list.params.push(Param::new(&decl, loc, vals)?);
        }
        Ok(list)
    }

    /// A directive's type string and parameters.
    fn entity(&mut self, lex: &mut Lexer, name: &str, loc: &FileLoc) -> Result<Entity> {
        let (kind, _) = self.string(lex, &format!("{name}'s type"), loc)?;
        let params = self.params(lex)?;
        Ok(Entity { kind, params, loc: loc.clone() })
    }

    fn apply(&mut self, t: DMat4) {
        for (c, a) in self.gs.ctm.iter_mut().zip(self.gs.active) {
            if a {
                *c *= t;
            }
        }
    }

    fn set(&mut self, t: [DMat4; 2]) {
        for ((c, a), t) in self.gs.ctm.iter_mut().zip(self.gs.active).zip(t) {
            if a {
                *c = t;
            }
        }
    }

    /// The current transform; an error where start and end differ
    /// (motion blur, which Penumbra does not render).
    fn ctm(&self, loc: &FileLoc, what: &str) -> Result<DMat4> {
        let [a, b] = self.gs.ctm;
        if a != b {
            return Err(LoadError::at(
                loc,
                format!(
                    "{what} moves during the shutter interval (ActiveTransform set different start and end \
                     transforms): motion blur is not supported; give one transform (ActiveTransform All)"
                ),
            ));
        }
        Ok(a)
    }

    fn need_world(&self, name: &str, loc: &FileLoc, world: bool) -> Result<()> {
        match (world, self.in_world) {
            (true, false) => Err(LoadError::at(loc, format!("{name} is only allowed after WorldBegin"))),
            (false, true) => Err(LoadError::at(loc, format!("{name} is only allowed before WorldBegin"))),
            _ => Ok(()),
        }
    }

    fn push(&mut self, kind: Push, loc: &FileLoc) {
        self.stack.push((kind, self.gs.clone(), loc.clone()));
    }

    fn pop(&mut self, kind: Push, name: &str, loc: &FileLoc) -> Result<()> {
        let Some((k, gs, open)) = self.stack.pop() else {
            return Err(LoadError::at(loc, format!("{name} without a matching begin")));
        };
        if k != kind {
            let begin = match k {
                Push::Attribute => "AttributeBegin",
                Push::Transform => "TransformBegin",
                Push::Object => "ObjectBegin",
            };
            return Err(LoadError::at(
                loc,
                format!("{name} closes the {begin} at line {} of {}", open.line, open.file.display()),
            ));
        }
        if kind == Push::Transform {
            self.gs.ctm = gs.ctm;
            self.gs.active = gs.active;
        } else {
            self.gs = gs;
        }
        Ok(())
    }

    fn directive(&mut self, t: Token, lex: &mut Lexer) -> Result<()> {
        let Token { tok, loc } = t;
        let name = match tok {
            Tok::Word(w) => w,
            other => {
                return Err(LoadError::at(
                    &loc,
                    format!("expected a directive (Shape, Material, ...), found {}", show(&other)),
                ))
            }
        };
        match name.as_str() {
            // Transforms.
            "Identity" => self.set([DMat4::IDENTITY; 2]),
            "Translate" => {
                let v = self.numbers(lex, 3, "Translate", &loc)?;
                self.apply(DMat4::from_translation(DVec3::new(v[0], v[1], v[2])));
            }
            "Scale" => {
                let v = self.numbers(lex, 3, "Scale", &loc)?;
                self.apply(DMat4::from_scale(DVec3::new(v[0], v[1], v[2])));
            }
            "Rotate" => {
                let v = self.numbers(lex, 4, "Rotate", &loc)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                if axis.length_squared() == 0.0 {
                    return Err(LoadError::at(&loc, "Rotate about a zero axis"));
                }
                self.apply(DMat4::from_axis_angle(axis.normalize(), v[0].to_radians()));
            }
            "LookAt" => {
                let v = self.numbers(lex, 9, "LookAt", &loc)?;
                let m = look_at(
                    DVec3::new(v[0], v[1], v[2]),
                    DVec3::new(v[3], v[4], v[5]),
                    DVec3::new(v[6], v[7], v[8]),
                )
                .ok_or_else(|| {
                    LoadError::at(&loc, "LookAt: the eye equals the target, or 'up' is parallel to the view direction")
                })?;
                self.apply(m);
            }
            "Transform" | "ConcatTransform" => {
                let v = self.numbers(lex, 16, &name, &loc)?;
                // Sixteen numbers column by column (pbrt transposes the row-major read).
                let m = DMat4::from_cols_array(&v.try_into().expect("16 numbers"));
                if name == "Transform" {
                    self.set([m; 2]);
                } else {
                    self.apply(m);
                }
            }
            "CoordinateSystem" => {
                let (n, _) = self.string(lex, "CoordinateSystem", &loc)?;
                self.named_coords.insert(n, self.gs.ctm);
            }
            "CoordSysTransform" => {
                let (n, nloc) = self.string(lex, "CoordSysTransform", &loc)?;
                match self.named_coords.get(&n) {
                    Some(&m) => self.set(m),
                    None => {
                        return Err(LoadError::at(
                            &nloc,
                            format!("no coordinate system named \"{n}\" (define it with CoordinateSystem first)"),
                        ))
                    }
                }
            }
            "ActiveTransform" => {
                let which = match self.next(lex)? {
                    Some(Token { tok: Tok::Word(w), .. }) => w,
                    Some(t) => return Err(LoadError::at(&t.loc, "ActiveTransform takes StartTime, EndTime or All")),
                    None => return Err(LoadError::at(&loc, "ActiveTransform takes StartTime, EndTime or All")),
                };
                self.gs.active = match which.as_str() {
                    "StartTime" => [true, false],
                    "EndTime" => [false, true],
                    "All" => [true, true],
                    other => {
                        return Err(LoadError::at(
                            &loc,
                            format!("ActiveTransform {other}: expected StartTime, EndTime or All"),
                        ))
                    }
                };
            }
            "TransformTimes" => {
                self.numbers(lex, 2, "TransformTimes", &loc)?;
            }
            "ReverseOrientation" => self.gs.reverse_orientation = !self.gs.reverse_orientation,

            // Blocks.
            "WorldBegin" => {
                if self.in_world {
                    return Err(LoadError::at(&loc, "WorldBegin given twice"));
                }
                self.in_world = true;
                self.gs.ctm = [DMat4::IDENTITY; 2];
                self.named_coords.insert("world".into(), self.gs.ctm);
            }
            // pbrt-v3's end marker: nothing follows it in a pbrt-v4 scene.
            "WorldEnd" => {}
            "AttributeBegin" | "TransformBegin" => {
                let kind = if name == "AttributeBegin" { Push::Attribute } else { Push::Transform };
                self.push(kind, &loc);
            }
            "AttributeEnd" => self.pop(Push::Attribute, &name, &loc)?,
            "TransformEnd" => self.pop(Push::Transform, &name, &loc)?,
            "ObjectBegin" => {
                self.need_world(&name, &loc, true)?;
                let (n, _) = self.string(lex, "ObjectBegin", &loc)?;
                if let Some((open, def)) = &self.object {
                    return Err(LoadError::at(
                        &loc,
                        format!("ObjectBegin inside the definition of \"{open}\" (line {}): close it with ObjectEnd first", def.loc.line),
                    ));
                }
                if let Some(old) = self.scene.instance_definitions.get(&n) {
                    return Err(LoadError::at(&loc, format!("object \"{n}\" defined twice (first at line {})", old.loc.line)));
                }
                self.push(Push::Object, &loc);
                self.object = Some((n, InstanceDefinition { shapes: Vec::new(), loc: loc.clone() }));
            }
            "ObjectEnd" => {
                let Some((n, def)) = self.object.take() else {
                    return Err(LoadError::at(&loc, "ObjectEnd without ObjectBegin"));
                };
                self.pop(Push::Object, &name, &loc)?;
                self.scene.instance_definitions.insert(n, def);
            }
            "ObjectInstance" => {
                self.need_world(&name, &loc, true)?;
                let (n, _) = self.string(lex, "ObjectInstance", &loc)?;
                if self.object.is_some() {
                    return Err(LoadError::at(&loc, "ObjectInstance inside an object definition (pbrt-v4 does not nest instances)"));
                }
                let world_from_instance = self.ctm(&loc, "ObjectInstance")?;
                self.scene.instances.push(InstanceUse { name: n, world_from_instance, loc });
            }

            // Files.
            "Include" | "Import" => {
                let (f, floc) = self.string(lex, &name, &loc)?;
                let path = if Path::new(&f).is_absolute() { PathBuf::from(&f) } else { self.base.join(&f) };
                if self.files.len() >= MAX_INCLUDE_DEPTH || self.files.contains(&path) {
                    return Err(LoadError::at(
                        &floc,
                        format!("{name} \"{f}\": includes nest deeper than {MAX_INCLUDE_DEPTH} files, or a file includes itself"),
                    ));
                }
                let text = read_text(&path, Some(&floc))?;
                let peeked = self.peeked.take();
                self.run(&path, &text)?;
                self.peeked = peeked;
            }

            // Options block.
            "Camera" => {
                self.need_world(&name, &loc, false)?;
                let entity = self.entity(lex, &name, &loc)?;
                let camera_from_world = self.ctm(&loc, "the camera")?;
                self.named_coords.insert("camera".into(), [camera_from_world.inverse(); 2]);
                self.scene.camera = Some(CameraEntity { entity, camera_from_world, medium: self.gs.media.1.clone() });
            }
            "Film" | "Sampler" | "Integrator" | "PixelFilter" | "Accelerator" => {
                self.need_world(&name, &loc, false)?;
                let e = self.entity(lex, &name, &loc)?;
                let slot = match name.as_str() {
                    "Film" => &mut self.scene.film,
                    "Sampler" => &mut self.scene.sampler,
                    "Integrator" => &mut self.scene.integrator,
                    "PixelFilter" => &mut self.scene.filter,
                    _ => &mut self.scene.accelerator,
                };
                if let Some(old) = slot {
                    return Err(LoadError::at(&loc, format!("{name} given twice (first at line {})", old.loc.line)));
                }
                *slot = Some(e);
            }
            "Option" => {
                let p = self.params(lex)?;
                self.scene.options.params.extend(p.params);
            }
            "ColorSpace" => {
                let (n, nloc) = self.string(lex, "ColorSpace", &loc)?;
                self.scene.color_space = Some((n, nloc));
            }

            // World block.
            "Material" => {
                self.need_world(&name, &loc, true)?;
                let e = self.entity(lex, &name, &loc)?;
                self.scene.materials.push(e);
                self.gs.material = MaterialRef::Anonymous(Some(self.scene.materials.len() - 1));
            }
            "MakeNamedMaterial" => {
                self.need_world(&name, &loc, true)?;
                let (n, _) = self.string(lex, "MakeNamedMaterial", &loc)?;
                let params = self.params(lex)?;
                let kind = params.string("type")?.ok_or_else(|| {
                    LoadError::at(&loc, format!("MakeNamedMaterial \"{n}\" needs a \"string type\" parameter"))
                })?;
                if let Some(old) = self.scene.named_materials.get(&n) {
                    return Err(LoadError::at(&loc, format!("material \"{n}\" defined twice (first at line {})", old.loc.line)));
                }
                self.scene.named_materials.insert(n, Entity { kind, params, loc });
            }
            "NamedMaterial" => {
                self.need_world(&name, &loc, true)?;
                let (n, nloc) = self.string(lex, "NamedMaterial", &loc)?;
                self.gs.material = MaterialRef::Named(n, nloc);
            }
            "Texture" => {
                self.need_world(&name, &loc, true)?;
                let (n, _) = self.string(lex, "Texture's name", &loc)?;
                let (value_kind, vloc) = self.string(lex, "Texture's value type", &loc)?;
                if value_kind != "float" && value_kind != "spectrum" {
                    return Err(LoadError::at(
                        &vloc,
                        format!("Texture \"{n}\": value type \"{value_kind}\" is neither \"float\" nor \"spectrum\""),
                    ));
                }
                let entity = self.entity(lex, "Texture", &loc)?;
                if self.scene.textures.iter().any(|t| t.name == n && t.value_kind == value_kind) {
                    return Err(LoadError::at(&loc, format!("{value_kind} texture \"{n}\" defined twice")));
                }
                let world_from_texture = self.ctm(&loc, "a texture")?;
                self.scene.textures.push(TextureEntity { name: n, value_kind, entity, world_from_texture });
            }
            "LightSource" => {
                self.need_world(&name, &loc, true)?;
                let entity = self.entity(lex, &name, &loc)?;
                let world_from_light = self.ctm(&loc, "a light")?;
                self.scene.lights.push(LightEntity { entity, world_from_light, medium: self.gs.media.1.clone() });
            }
            "AreaLightSource" => {
                self.need_world(&name, &loc, true)?;
                self.gs.area_light = Some(self.entity(lex, &name, &loc)?);
            }
            "Shape" => {
                self.need_world(&name, &loc, true)?;
                let entity = self.entity(lex, &name, &loc)?;
                let shape = ShapeEntity {
                    world_from_object: self.ctm(&loc, "a shape")?,
                    reverse_orientation: self.gs.reverse_orientation,
                    material: self.gs.material.clone(),
                    area_light: self.gs.area_light.clone(),
                    media: self.gs.media.clone(),
                    entity,
                };
                match &mut self.object {
                    Some((n, def)) => {
                        if shape.area_light.is_some() {
                            return Err(LoadError::at(
                                &loc,
                                format!("an area light in object \"{n}\": pbrt-v4 does not instance area lights; give the shape outside ObjectBegin/ObjectEnd"),
                            ));
                        }
                        def.shapes.push(shape);
                    }
                    None => self.scene.shapes.push(shape),
                }
            }
            "MakeNamedMedium" => {
                let (n, _) = self.string(lex, "MakeNamedMedium", &loc)?;
                let params = self.params(lex)?;
                let kind = params.string("type")?.ok_or_else(|| {
                    LoadError::at(&loc, format!("MakeNamedMedium \"{n}\" needs a \"string type\" parameter"))
                })?;
                let m = self.ctm(&loc, "a medium")?;
                self.scene.media.insert(n, (Entity { kind, params, loc }, m));
            }
            "MediumInterface" => {
                let (inside, _) = self.string(lex, "MediumInterface", &loc)?;
                // One name: the same medium on both sides.
                let outside = match self.peek(lex)? {
                    Some(Token { tok: Tok::Str(_), .. }) => self.string(lex, "MediumInterface", &loc)?.0,
                    _ => inside.clone(),
                };
                self.gs.media = (inside, outside);
            }
            "Attribute" => {
                let (target, tloc) = self.string(lex, "Attribute's target", &loc)?;
                let p = self.params(lex)?;
                return Err(LoadError::at(
                    &tloc,
                    format!(
                        "Attribute \"{target}\" ({} parameter(s)) is not supported yet: give the parameters on each {target} directly",
                        p.params.len()
                    ),
                ));
            }
            other => {
                return Err(LoadError::at(
                    &loc,
                    format!("unknown directive '{other}' (pbrt-v4's directives are Shape, Material, LightSource, AttributeBegin, Translate, ...)"),
                ))
            }
        }
        Ok(())
    }
}

/// pbrt's `LookAt`: the camera-from-world transform of an eye at `pos`
/// looking at `look` with `up` (left-handed: right = up × dir).
pub fn look_at(pos: DVec3, look: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (look - pos).try_normalize()?;
    let right = up.try_normalize()?.cross(dir).try_normalize()?;
    let new_up = dir.cross(right);
    let world_from_camera =
        DMat4::from_cols(right.extend(0.0), new_up.extend(0.0), dir.extend(0.0), DVec4::new(pos.x, pos.y, pos.z, 1.0));
    Some(world_from_camera.inverse())
}

fn show(t: &Tok) -> String {
    match t {
        Tok::Str(s) => format!("\"{s}\""),
        Tok::Open => "'['".into(),
        Tok::Close => "']'".into(),
        Tok::Word(w) => format!("'{w}'"),
    }
}
