//! The XML reader proper.
//!
//! Parsing runs in two passes, as in Mitsuba: the first walks the document
//! (and its includes) in order, substituting `$parameters`, checking tags and
//! attributes and collecting objects in an arena with `<ref>`s left as ids;
//! the second resolves the references and freezes the arena into shared
//! [`Node`]s. Resolving after the whole document is read is what lets a
//! `<ref>` name an object declared further down, as Mitsuba allows.

use super::transform;
use crate::desc::{Child, Kind, Node, Property, Rename, SceneDesc, UpgradedFile, Value};
use crate::error::{FileLoc, LoadError, Result};
use glam::{DMat4, DVec3};
use std::cell::Cell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

/// Reads a Mitsuba 3 scene file. `defines` are the `-D name=value`
/// parameters; they take precedence over the scene's `<default>`s.
pub fn parse_file(path: &Path, defines: &[(String, String)]) -> Result<SceneDesc> {
    let text = read_text(path).map_err(|m| LoadError::in_file(path, m))?;
    parse_str(&text, path, defines)
}

/// Parses scene text as if it were the contents of `path`, which names the
/// file in messages and is the base for relative `<include>`s.
///
/// File names in the scene are looked up as Mitsuba's file resolver does
/// when it loads a scene: in the directories of the main file's `<path>`
/// elements (latest first; they apply to every file name of the scene,
/// before or after them, since Mitsuba resolves names only when it builds
/// the objects), then the main file's directory, then the working
/// directory. Mitsuba does not search an included file's directory for
/// the names inside it; Penumbra does, after all of the above, so that
/// every scene Mitsuba loads finds the same files here.
pub fn parse_str(text: &str, path: &Path, defines: &[(String, String)]) -> Result<SceneDesc> {
    let mut parser = Parser::new(defines);
    parser.include_stack.push(canonical(path));
    let cwd = std::env::current_dir().unwrap_or_default();
    parser.resolver.push(cwd.join(path.parent().unwrap_or(Path::new(""))));
    parser.resolver.push(cwd);
    let version = parser.parse_root(text, Arc::new(path.to_path_buf()))?;
    parser.attach_search_dirs(path);
    let mut upgraded = std::mem::take(&mut parser.upgraded);
    for u in &mut upgraded {
        u.renames.sort_by_key(|r| (r.loc.line, r.loc.col));
    }
    let root = parser.resolve()?;
    Ok(SceneDesc { root, version, upgraded })
}

fn read_text(path: &Path) -> std::result::Result<String, String> {
    let bytes = std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => "file not found".to_string(),
        _ => format!("cannot read file: {e}"),
    })?;
    crate::error::utf8_text(bytes).map_err(|e| format!("file is {e}"))
}

/// Removes repeated directories, keeping the first of each.
fn dedup(dirs: Vec<PathBuf>) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = Vec::with_capacity(dirs.len());
    for d in dirs {
        if !out.contains(&d) {
            out.push(d);
        }
    }
    out
}

/// " (searched 'a', 'b')" for messages about files not found.
fn searched(dirs: &[PathBuf]) -> String {
    let list: Vec<String> = dedup(dirs.to_vec()).iter().map(|d| format!("'{}'", d.display())).collect();
    format!(" (searched {})", list.join(", "))
}

fn canonical(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// Every tag the reader knows, for the message about an unknown one.
const SUPPORTED_TAGS: &str = "objects (scene, shape, bsdf, emitter, sensor, film, sampler, \
     rfilter, integrator, texture, medium, phase, volume), properties (float, integer, boolean, \
     string, rgb, spectrum, point, vector, transform), ref, include, default and alias";

/// A `$name` parameter, stored as Mitsuba does: with its `$` prefix.
struct Param {
    key: String,
    value: String,
}

/// An object while the document is being read.
struct RawNode {
    kind: Kind,
    plugin: String,
    id: Option<String>,
    name: Option<String>,
    props: Vec<Property>,
    children: Vec<RawChild>,
    loc: FileLoc,
    /// The node's file, when it is older than version 2.0.0: an index
    /// into `Parser::upgraded`.
    old: Option<usize>,
}

struct RawChild {
    name: Option<String>,
    target: Target,
    loc: FileLoc,
}

enum Target {
    Node(usize),
    /// `<ref id=..>`, resolved once the whole document is read.
    Ref(String),
}

struct Parser {
    /// Sorted by decreasing key length, so that `$ab` is substituted before
    /// `$a` gets a chance to match its prefix (Mitsuba's rule).
    params: Vec<Param>,
    nodes: Vec<RawNode>,
    ids: HashMap<String, usize>,
    /// Canonical paths of the files being read, outermost first.
    include_stack: Vec<PathBuf>,
    /// Mitsuba's file resolver while the document is read: the directories
    /// searched for relative names, first match wins. `<path>` prepends to
    /// it; an `<include>` reads its file with a copy (plus the including
    /// file's directory) and restores it afterwards.
    resolver: Vec<PathBuf>,
    /// For each included file, the extra directories searched after the
    /// main file's (its resolver when it was read, and its own directory).
    include_dirs: HashMap<PathBuf, Vec<PathBuf>>,
    /// Files older than version 2.0.0 read so far, and what was renamed.
    upgraded: Vec<UpgradedFile>,
    /// The file being read, when it is one of `upgraded`.
    old: Option<usize>,
}

/// The document an element belongs to, for positions.
struct Src<'a, 'input> {
    doc: &'a roxmltree::Document<'input>,
    file: Arc<PathBuf>,
    /// The byte offset where each line starts, the first at 0.
    line_starts: Vec<usize>,
}

impl<'a, 'input> Src<'a, 'input> {
    fn new(doc: &'a roxmltree::Document<'input>, file: Arc<PathBuf>) -> Self {
        let text = doc.input_text();
        let line_starts = std::iter::once(0).chain(text.match_indices('\n').map(|(i, _)| i + 1)).collect();
        Src { doc, file, line_starts }
    }

    /// Where `node` starts: row and column as `roxmltree`'s `text_pos_at`
    /// counts them (1-based; the column in characters), found in the line
    /// table. `text_pos_at` scans the text from its start, which made
    /// reading a file quadratic in its size: 7 s for 20,000 shapes.
    fn loc(&self, node: roxmltree::Node) -> FileLoc {
        let text = self.doc.input_text();
        let pos = node.range().start.min(text.len());
        let row = self.line_starts.partition_point(|&s| s <= pos);
        let col = 1 + text[self.line_starts[row - 1]..pos].chars().count();
        FileLoc::new(self.file.clone(), row as u32, col as u32)
    }
}

/// An element with its attributes after `$parameter` substitution.
struct Elem<'a, 'input> {
    xml: roxmltree::Node<'a, 'input>,
    tag: &'a str,
    attrs: Vec<(&'a str, String)>,
    loc: FileLoc,
}

impl Elem<'_, '_> {
    fn get(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(n, _)| *n == name).map(|(_, v)| v.as_str())
    }

    /// The value of an attribute that [`Elem::check`] made sure is present.
    fn req(&self, name: &str) -> &str {
        self.get(name).unwrap_or_default()
    }

    fn err(&self, message: impl Into<String>) -> LoadError {
        LoadError::at(&self.loc, message)
    }

    /// Rejects attributes outside `required` and `optional`, and missing
    /// required ones (Mitsuba's `check_attributes`).
    fn check(&self, required: &[&str], optional: &[&str]) -> Result<()> {
        for (name, _) in &self.attrs {
            if !required.contains(name) && !optional.contains(name) {
                let allowed: Vec<&str> = required.iter().chain(optional).copied().collect();
                return Err(self.err(format!(
                    "unexpected attribute \"{name}\" in <{}> (allowed: {})",
                    self.tag,
                    allowed.join(", ")
                )));
            }
        }
        for name in required {
            if self.get(name).is_none() {
                return Err(self.err(format!("missing required attribute \"{name}\" in <{}>", self.tag)));
            }
        }
        Ok(())
    }

    /// `<float name="radius">`, to name a property in messages.
    fn describe(&self) -> String {
        match self.get("name") {
            Some(n) => format!("<{} name=\"{n}\">", self.tag),
            None => format!("<{}>", self.tag),
        }
    }

    fn float(&self, text: &str, what: &str) -> Result<f64> {
        parse_float(text).ok_or_else(|| {
            self.err(format!(
                "could not parse {what} \"{text}\" of {} as a finite number (at most {:e} in magnitude)",
                self.describe(),
                f32::MAX
            ))
        })
    }
}

/// Splits a list of numbers on commas and whitespace.
fn tokenize(text: &str) -> Vec<&str> {
    text.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).collect()
}

/// A finite floating point number that must make up the whole string:
/// "nan" and "inf", which Rust's parser accepts, would render silently
/// wrong images (a NaN colour, an infinite radius), so they are refused,
/// and so are numbers past the single-precision range (`1e39`), which
/// become infinite when the scene is built.
fn parse_float(text: &str) -> Option<f64> {
    text.trim().parse().ok().filter(|v: &f64| v.abs() <= f32::MAX as f64)
}

/// `major.minor.patch`, all three required (Mitsuba's `util::Version`).
fn parse_version(text: &str) -> Option<[u32; 3]> {
    let parts: Vec<&str> = text.split(['.', ' ']).filter(|s| !s.is_empty()).collect();
    match parts[..] {
        [a, b, c] => Some([a.parse().ok()?, b.parse().ok()?, c.parse().ok()?]),
        _ => None,
    }
}

/// Mitsuba 3's `camel_to_underscore_case`: an upper-case letter after a
/// lower-case one starts a new word, and the upper-case letters right after
/// it stay in that word (`maxDepth` -> `max_depth`, `intIOR` -> `int_ior`,
/// `toWorld` -> `to_world`); everything else is kept as written.
fn camel_to_underscore(name: &str) -> String {
    let b = name.as_bytes();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if i > 0 && b[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase() as char);
            while i + 1 < b.len() && b[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(b[i].to_ascii_lowercase() as char);
            }
            i += 1;
        } else {
            // Not ASCII-only: copy the whole character.
            let ch = name[i..].chars().next().unwrap_or_default();
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

fn xml_document<'input>(text: &'input str, file: &Path) -> Result<roxmltree::Document<'input>> {
    let options = roxmltree::ParsingOptions { allow_dtd: true, ..Default::default() };
    roxmltree::Document::parse_with_options(text, options).map_err(|e| {
        let pos = e.pos();
        // roxmltree appends " at row:col" itself; the location goes in front.
        let message = e.to_string().replace(&format!(" at {pos}"), "");
        LoadError {
            loc: Some(FileLoc::new(Arc::new(file.to_path_buf()), pos.row, pos.col)),
            message: format!("malformed XML: {message}"),
        }
    })
}

impl Parser {
    fn new(defines: &[(String, String)]) -> Self {
        let mut params: Vec<Param> = Vec::new();
        for (name, value) in defines {
            let key = format!("${name}");
            // A later -D of the same name wins.
            params.retain(|p| p.key != key);
            params.push(Param { key, value: value.clone() });
        }
        params.sort_by_key(|p| std::cmp::Reverse(p.key.len()));
        Parser {
            params,
            nodes: Vec::new(),
            ids: HashMap::new(),
            include_stack: Vec::new(),
            resolver: Vec::new(),
            include_dirs: HashMap::new(),
            upgraded: Vec::new(),
            old: None,
        }
    }

    /// Replaces `$name` occurrences by parameter values; `\$` escapes a
    /// dollar sign. Mirrors Mitsuba's `substitute_parameters`, including its
    /// plain (not identifier-bounded) matching, longest name first.
    fn substitute(&self, value: &str, loc: &FileLoc) -> Result<String> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut value = value.to_string();
        for param in &self.params {
            let mut pos = 0;
            while let Some(found) = value[pos..].find(&param.key) {
                let at = pos + found;
                if at > 0 && value.as_bytes()[at - 1] == b'\\' {
                    pos = at + param.key.len();
                } else {
                    value.replace_range(at..at + param.key.len(), &param.value);
                    pos = at + param.value.len();
                }
            }
        }
        let bytes = value.as_bytes();
        for (at, _) in value.match_indices('$') {
            if at > 0 && bytes[at - 1] == b'\\' {
                continue;
            }
            let name: String = value[at + 1..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            if name.is_empty() {
                return Err(LoadError::at(
                    loc,
                    format!("stray '$' in \"{value}\" (write \\$ for a literal dollar sign)"),
                ));
            }
            return Err(LoadError::at(
                loc,
                format!(
                    "undefined parameter ${name}: pass -D {name}=<value> on the command line \
                     or add <default name=\"{name}\" value=\"...\"/> to the scene"
                ),
            ));
        }
        Ok(value.replace("\\$", "$"))
    }

    fn elem<'a, 'input>(&self, src: &Src, xml: roxmltree::Node<'a, 'input>) -> Result<Elem<'a, 'input>> {
        let loc = src.loc(xml);
        let mut attrs = Vec::new();
        for a in xml.attributes() {
            attrs.push((a.name(), self.substitute(a.value(), &loc)?));
        }
        Ok(Elem { xml, tag: xml.tag_name().name(), attrs, loc })
    }

    /// Reads the main file, whose root must be `<scene>`; returns its version.
    fn parse_root(&mut self, text: &str, file: Arc<PathBuf>) -> Result<String> {
        let doc = xml_document(text, &file)?;
        let src = Src::new(&doc, file);
        let root = self.elem(&src, doc.root_element())?;
        if root.tag != "scene" {
            return Err(root.err(format!(
                "the root element is <{}>, but a scene file must start with \
                 <scene version=\"3.0.0\">",
                root.tag
            )));
        }
        root.check(&["version"], &["type", "id", "name"])?;
        let version = check_version(&root)?;
        self.old = self.old_file(&version, &src.file);
        let idx = self.push_node(RawNode {
            kind: Kind::Scene,
            plugin: root.get("type").unwrap_or_default().to_string(),
            id: root.get("id").map(str::to_string),
            name: None,
            props: Vec::new(),
            children: Vec::new(),
            loc: root.loc.clone(),
            old: None,
        })?;
        self.elements(&src, root.xml, idx, true)?;
        Ok(version)
    }

    /// Reads the element children of `xml` into the object `parent`.
    /// `in_scene` says `xml` is a `<scene>` element, where properties are
    /// not allowed.
    fn elements(&mut self, src: &Src, xml: roxmltree::Node, parent: usize, in_scene: bool) -> Result<()> {
        for child in xml.children().filter(|c| c.is_element()) {
            self.element(src, child, parent, in_scene)?;
        }
        Ok(())
    }

    fn element(&mut self, src: &Src, xml: roxmltree::Node, parent: usize, in_scene: bool) -> Result<()> {
        let e = self.elem(src, xml)?;
        // `<spectrum type="...">` is a spectrum plugin, which Mitsuba treats as a texture.
        let kind = match e.tag {
            "spectrum" if e.get("type").is_some() => Some(Kind::Texture),
            tag => Kind::from_tag(tag),
        };
        if let Some(kind) = kind {
            if kind == Kind::Scene {
                return Err(e.err("<scene> can only be the root element of a file"));
            }
            let idx = self.object(src, &e, kind)?;
            let name = e.get("name").map(str::to_string);
            return self.add_child(parent, RawChild { name, target: Target::Node(idx), loc: e.loc });
        }
        match e.tag {
            "float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" | "point" | "vector" | "transform" => {
                if in_scene {
                    return Err(e.err(format!(
                        "{} cannot appear directly inside <scene>: properties belong \
                         inside an object such as <shape> or <integrator>",
                        e.describe()
                    )));
                }
                let prop = property(&e, |x| self.elem(src, x), &self.resolver)?;
                self.add_prop(parent, prop)
            }
            "ref" => {
                e.check(&["id"], &["name"])?;
                let child = RawChild {
                    name: e.get("name").map(str::to_string),
                    target: Target::Ref(e.req("id").to_string()),
                    loc: e.loc.clone(),
                };
                self.add_child(parent, child)
            }
            "include" => self.include(&e, parent),
            "default" => {
                e.check(&["name", "value"], &[])?;
                let name = e.req("name");
                if name.is_empty() {
                    return Err(e.err("<default> needs a non-empty name"));
                }
                let key = format!("${name}");
                if !self.params.iter().any(|p| p.key == key) {
                    let at = self.params.partition_point(|p| p.key.len() >= key.len());
                    self.params.insert(at, Param { key, value: e.req("value").to_string() });
                }
                Ok(())
            }
            "alias" => {
                e.check(&["id", "as"], &[])?;
                let (id, alias) = (e.req("id"), e.req("as"));
                if self.ids.contains_key(alias) {
                    return Err(e.err(format!("alias destination id \"{alias}\" already exists")));
                }
                let Some(&target) = self.ids.get(id) else {
                    return Err(e.err(format!("alias source id \"{id}\" not found")));
                };
                self.ids.insert(alias.to_string(), target);
                Ok(())
            }
            "path" => self.search_path(&e, in_scene),
            "translate" | "rotate" | "scale" | "matrix" | "lookat" => {
                Err(e.err(format!("<{}> can only appear inside a <transform>", e.tag)))
            }
            tag => Err(e.err(format!("unsupported element <{tag}>; supported are {SUPPORTED_TAGS}"))),
        }
    }

    /// Reads an object element and its contents; returns its arena index.
    fn object(&mut self, src: &Src, e: &Elem, kind: Kind) -> Result<usize> {
        e.check(&["type"], &["id", "name"])?;
        let idx = self.push_node(RawNode {
            kind,
            plugin: e.req("type").to_string(),
            id: e.get("id").map(str::to_string),
            name: e.get("name").map(str::to_string),
            props: Vec::new(),
            children: Vec::new(),
            loc: e.loc.clone(),
            old: None,
        })?;
        self.elements(src, e.xml, idx, false)?;
        self.upgrade(idx)?;
        Ok(idx)
    }

    fn push_node(&mut self, mut node: RawNode) -> Result<usize> {
        node.old = self.old;
        let idx = self.nodes.len();
        if let Some(id) = &node.id {
            if let Some(&prev) = self.ids.get(id) {
                return Err(LoadError::at(
                    &node.loc,
                    format!("duplicate id \"{id}\" (first declared at {})", self.nodes[prev].loc),
                ));
            }
            self.ids.insert(id.clone(), idx);
        }
        self.nodes.push(node);
        Ok(idx)
    }

    /// Where a name is already taken in an object, by a property or a
    /// named nested object.
    fn name_taken(&self, parent: usize, name: &str) -> Option<&FileLoc> {
        let node = &self.nodes[parent];
        let prop = node.props.iter().find(|p| p.name == name).map(|p| &p.loc);
        prop.or_else(|| node.children.iter().find(|c| c.name.as_deref() == Some(name)).map(|c| &c.loc))
    }

    fn duplicate(&self, parent: usize, name: &str, loc: &FileLoc, first: &FileLoc) -> LoadError {
        let node = &self.nodes[parent];
        let owner = match node.kind {
            Kind::Scene => "<scene>".to_string(),
            k => format!("<{} type=\"{}\">", k.tag(), node.plugin),
        };
        LoadError::at(loc, format!("\"{name}\" is specified more than once in {owner} (first at {first})"))
    }

    fn add_prop(&mut self, parent: usize, prop: Property) -> Result<()> {
        if let Some(first) = self.name_taken(parent, &prop.name) {
            return Err(self.duplicate(parent, &prop.name, &prop.loc, first));
        }
        self.nodes[parent].props.push(prop);
        Ok(())
    }

    fn add_child(&mut self, parent: usize, child: RawChild) -> Result<()> {
        if let Some(name) = &child.name {
            if let Some(first) = self.name_taken(parent, name) {
                return Err(self.duplicate(parent, name, &child.loc, first));
            }
        }
        self.nodes[parent].children.push(child);
        Ok(())
    }

    /// `<include filename=".."/>`: the file's `<scene>` children are spliced
    /// into `parent`; a file whose root is another object adds that object.
    fn include(&mut self, e: &Elem, parent: usize) -> Result<()> {
        e.check(&["filename"], &["name"])?;
        let filename = Path::new(e.req("filename"));
        // As Mitsuba: the including file's directory first, then the resolver.
        let mut resolver = self.resolver.clone();
        resolver.insert(0, e.loc.file.parent().unwrap_or(Path::new("")).to_path_buf());
        let path = if filename.is_absolute() {
            filename.to_path_buf()
        } else {
            let candidates = resolver.iter().map(|d| d.join(filename));
            candidates.clone().find(|c| c.is_file()).unwrap_or_else(|| resolver[0].join(filename))
        };
        if !path.is_file() {
            let searched = if filename.is_absolute() { String::new() } else { searched(&resolver) };
            return Err(e.err(format!("included file \"{}\" not found{searched}", path.display())));
        }
        let key = canonical(&path);
        if self.include_stack.contains(&key) {
            let chain: Vec<String> = self.include_stack.iter().chain([&key]).map(|p| p.display().to_string()).collect();
            return Err(e.err(format!("include cycle: {}", chain.join(" -> "))));
        }
        let text = read_text(&path).map_err(|m| LoadError::in_file(&path, m))?;
        self.include_stack.push(key);
        let outer = std::mem::replace(&mut self.resolver, resolver);
        let outer_old = self.old;
        let result = self.parse_included(&text, Arc::new(path.clone()), parent, e);
        self.old = outer_old;
        let mut extra = std::mem::replace(&mut self.resolver, outer);
        extra.push(path.parent().unwrap_or(Path::new("")).to_path_buf());
        self.include_dirs.entry(path).or_insert(extra);
        self.include_stack.pop();
        result.map_err(|mut err| {
            err.message.push_str(&format!("\n  (in a file included at {})", e.loc));
            err
        })
    }

    fn parse_included(&mut self, text: &str, file: Arc<PathBuf>, parent: usize, include: &Elem) -> Result<()> {
        let doc = xml_document(text, &file)?;
        let src = Src::new(&doc, file);
        let root = self.elem(&src, doc.root_element())?;
        if root.tag == "scene" {
            root.check(&["version"], &["type", "id", "name"])?;
            let version = check_version(&root)?;
            self.old = self.old_file(&version, &src.file);
            return self.elements(&src, root.xml, parent, true);
        }
        let kind = match root.tag {
            "spectrum" if root.get("type").is_some() => Some(Kind::Texture),
            tag => Kind::from_tag(tag),
        };
        let Some(kind) = kind else {
            return Err(root.err(format!(
                "the root element of an included file must be <scene> or an object, not <{}>",
                root.tag
            )));
        };
        root.check(&["version", "type"], &["id", "name"])?;
        let version = check_version(&root)?;
        self.old = self.old_file(&version, &src.file);
        let idx = self.push_node(RawNode {
            kind,
            plugin: root.req("type").to_string(),
            id: root.get("id").map(str::to_string),
            name: root.get("name").map(str::to_string),
            props: Vec::new(),
            children: Vec::new(),
            loc: root.loc.clone(),
            old: None,
        })?;
        self.elements(&src, root.xml, idx, false)?;
        self.upgrade(idx)?;
        let name = include.get("name").map(str::to_string);
        self.add_child(parent, RawChild { name, target: Target::Node(idx), loc: include.loc.clone() })
    }

    /// Registers `file` as an upgraded one when its `version` is older
    /// than 2.0.0; returns its index in `upgraded`.
    fn old_file(&mut self, version: &str, file: &Arc<PathBuf>) -> Option<usize> {
        if parse_version(version)?[0] >= 2 {
            return None;
        }
        self.upgraded.push(UpgradedFile { file: file.clone(), version: version.to_string(), renames: Vec::new() });
        Some(self.upgraded.len() - 1)
    }

    /// Mitsuba 3's `upgrade_from_v1` on one object of a file older than
    /// 2.0.0, after its contents are read: every parameter and nested
    /// object name from camelCase to snake_case, diffuse's
    /// `diffuse_reflectance` to `reflectance`, and `uoffset`/`voffset`/
    /// `uscale`/`vscale` folded into `to_uv` = scale(uscale, vscale) ·
    /// translate(uoffset, voffset).
    fn upgrade(&mut self, idx: usize) -> Result<()> {
        let Some(file) = self.node_old(idx) else { return Ok(()) };
        let mut renames = Vec::new();
        let node = &mut self.nodes[idx];
        let names = node
            .props
            .iter_mut()
            .map(|p| (&mut p.name, &p.loc))
            .chain(node.children.iter_mut().filter_map(|c| Some((c.name.as_mut()?, &c.loc))));
        for (name, loc) in names {
            let mut new = camel_to_underscore(name);
            if node.plugin == "diffuse" && new == "diffuse_reflectance" {
                new = "reflectance".to_string();
            }
            if new != *name {
                renames.push(Rename { loc: loc.clone(), from: std::mem::replace(name, new.clone()), to: new });
            }
        }
        let offsets = ["uoffset", "voffset", "uscale", "vscale"];
        let mut uv = [0.0, 0.0, 1.0, 1.0];
        let mut first: Option<FileLoc> = None;
        for (k, key) in offsets.iter().enumerate() {
            let Some(at) = node.props.iter().position(|p| p.name == *key) else { continue };
            let p = node.props.remove(at);
            uv[k] = match p.value {
                Value::Float(v) => v,
                Value::Integer(v) => v as f64,
                _ => return Err(LoadError::at(&p.loc, format!("\"{key}\" must be a number (<float>)"))),
            };
            renames.push(Rename { loc: p.loc.clone(), from: key.to_string(), to: "to_uv".to_string() });
            first = first.or(Some(p.loc));
        }
        self.upgraded[file].renames.extend(renames);
        let Some(loc) = first else { return self.check_unique(idx) };
        let m =
            DMat4::from_scale(DVec3::new(uv[2], uv[3], 1.0)) * DMat4::from_translation(DVec3::new(uv[0], uv[1], 0.0));
        self.check_unique(idx)?;
        self.add_prop(
            idx,
            Property { name: "to_uv".to_string(), value: Value::Transform(m), loc, used: Cell::new(false) },
        )
    }

    fn node_old(&self, idx: usize) -> Option<usize> {
        self.nodes[idx].old
    }

    /// After renaming, two parameters of one object may share a name
    /// (`toWorld` and `to_world`): an error, as any repeated name.
    fn check_unique(&self, idx: usize) -> Result<()> {
        let node = &self.nodes[idx];
        let names = node
            .props
            .iter()
            .map(|p| (p.name.as_str(), &p.loc))
            .chain(node.children.iter().filter_map(|c| Some((c.name.as_deref()?, &c.loc))));
        let mut seen: HashMap<&str, &FileLoc> = HashMap::new();
        for (name, loc) in names {
            if let Some(first) = seen.insert(name, loc) {
                return Err(self.duplicate(idx, name, loc, first));
            }
        }
        Ok(())
    }

    /// `<path value="dir"/>`: a directory searched for relative file names
    /// (Mitsuba's `TagType::Resource`): relative to the file that states
    /// it, else through the directories already searched; prepended, so
    /// the latest `<path>` is searched first.
    fn search_path(&mut self, e: &Elem, in_scene: bool) -> Result<()> {
        e.check(&["value"], &[])?;
        if !in_scene {
            return Err(e.err("<path> can only appear directly inside <scene>"));
        }
        let value = Path::new(e.req("value"));
        let mut dir = e.loc.file.parent().unwrap_or(Path::new("")).join(value);
        if !dir.exists() {
            if let Some(found) = self.resolver.iter().map(|d| d.join(value)).find(|d| d.exists()) {
                dir = found;
            }
        }
        if !dir.is_dir() {
            let searched = if value.is_absolute() { String::new() } else { searched(&self.resolver) };
            return Err(e.err(format!(
                "<path>: folder \"{}\" not found (relative to {}){searched}",
                value.display(),
                e.loc.file.parent().map(|p| p.display().to_string()).unwrap_or_default()
            )));
        }
        self.resolver.insert(0, dir);
        Ok(())
    }

    /// Gives every property the directories its file names are searched
    /// in: the main file's final resolver, and for properties of included
    /// files the extra directories of that file (see [`parse_str`]).
    fn attach_search_dirs(&mut self, main: &Path) {
        let main_dirs = dedup(self.resolver.clone());
        let main_arc = Arc::new(main_dirs.clone());
        let mut per_file: HashMap<PathBuf, Arc<Vec<PathBuf>>> = HashMap::new();
        per_file.insert(main.to_path_buf(), main_arc.clone());
        for node in &mut self.nodes {
            for prop in &mut node.props {
                let file = prop.loc.file.as_path();
                let dirs = per_file
                    .entry(file.to_path_buf())
                    .or_insert_with(|| {
                        let mut dirs = main_dirs.clone();
                        dirs.extend(self.include_dirs.get(file).cloned().unwrap_or_default());
                        Arc::new(dedup(dirs))
                    })
                    .clone();
                prop.loc.search = Some(dirs);
            }
        }
    }

    /// Second pass: resolves references and builds the shared node tree.
    fn resolve(mut self) -> Result<Rc<Node>> {
        let mut built = vec![None; self.nodes.len()];
        let mut in_progress = vec![false; self.nodes.len()];
        self.build(0, &mut built, &mut in_progress)
    }

    fn build(&mut self, idx: usize, built: &mut [Option<Rc<Node>>], in_progress: &mut [bool]) -> Result<Rc<Node>> {
        if let Some(node) = &built[idx] {
            return Ok(node.clone());
        }
        in_progress[idx] = true;
        let raw_children = std::mem::take(&mut self.nodes[idx].children);
        let mut children = Vec::with_capacity(raw_children.len());
        let mut spectra = Vec::new();
        for c in raw_children {
            let target = match &c.target {
                Target::Node(i) => *i,
                Target::Ref(id) => {
                    let Some(&i) = self.ids.get(id) else {
                        return Err(LoadError::at(
                            &c.loc,
                            format!(
                                "<ref id=\"{id}\">: no object with id=\"{id}\" is declared \
                                 in the scene or its includes"
                            ),
                        ));
                    };
                    if in_progress[i] {
                        return Err(LoadError::at(
                            &c.loc,
                            format!(
                                "<ref id=\"{id}\"> refers to an object that contains this \
                                 reference (a cycle)"
                            ),
                        ));
                    }
                    i
                }
            };
            let node = self.build(target, built, in_progress)?;
            // A spectrum plugin (`<spectrum type="blackbody" name="radiance">`)
            // is a value of its parent, not an object of its own.
            if node.kind == Kind::Texture && crate::spectrum::SPECTRUM_PLUGINS.contains(&node.plugin.as_str()) {
                let Some(name) = c.name else {
                    return Err(LoadError::at(&c.loc, format!("a <spectrum type=\"{}\"> needs a name", node.plugin)));
                };
                let value = crate::spectrum::plugin_value(&node)?;
                spectra.push(Property { name, value, loc: c.loc, used: Cell::new(false) });
                continue;
            }
            children.push(Child { name: c.name, node, loc: c.loc });
        }
        let raw = &mut self.nodes[idx];
        raw.props.extend(spectra);
        let node = Rc::new(Node {
            kind: raw.kind,
            plugin: std::mem::take(&mut raw.plugin),
            id: raw.id.take(),
            name: raw.name.take(),
            props: std::mem::take(&mut raw.props),
            children,
            loc: raw.loc.clone(),
        });
        in_progress[idx] = false;
        built[idx] = Some(node.clone());
        Ok(node)
    }
}

/// Checks a root element's `version` (Mitsuba's `util::Version`:
/// major.minor.patch). Versions 2.x and 3.x share one syntax; older files
/// are read too, upgraded object by object as Mitsuba 3 upgrades them
/// ([`Parser::upgrade`]).
fn check_version(root: &Elem) -> Result<String> {
    let text = root.req("version");
    if parse_version(text).is_none() {
        return Err(root.err(format!("invalid version \"{text}\": expected major.minor.patch, e.g. \"3.0.0\"")));
    }
    Ok(text.to_string())
}

/// Reads a property element. `elem` substitutes parameters in the
/// attributes of nested elements (the operations of a `<transform>`).
fn property<'a, 'input>(
    e: &Elem<'a, 'input>,
    elem: impl Fn(roxmltree::Node<'a, 'input>) -> Result<Elem<'a, 'input>>,
    resolver: &[PathBuf],
) -> Result<Property> {
    let value = match e.tag {
        "transform" => {
            e.check(&["name"], &[])?;
            let mut m = DMat4::IDENTITY;
            for op in e.xml.children().filter(|c| c.is_element()) {
                m = transform_op(&elem(op)?)? * m;
            }
            Value::Transform(m)
        }
        tag => {
            if let Some(child) = e.xml.children().find(|c| c.is_element()) {
                return Err(e.err(format!(
                    "<{}> cannot appear inside the property {}",
                    child.tag_name().name(),
                    e.describe()
                )));
            }
            match tag {
                "float" => {
                    e.check(&["name", "value"], &[])?;
                    Value::Float(e.float(e.req("value"), "the value")?)
                }
                "integer" => {
                    e.check(&["name", "value"], &[])?;
                    let text = e.req("value");
                    Value::Integer(text.trim().parse().map_err(|_| {
                        e.err(format!("could not parse the value \"{text}\" of {} as an integer", e.describe()))
                    })?)
                }
                "boolean" => {
                    e.check(&["name", "value"], &[])?;
                    let text = e.req("value");
                    Value::Boolean(match text.trim().to_ascii_lowercase().as_str() {
                        "true" => true,
                        "false" => false,
                        _ => {
                            return Err(e.err(format!(
                                "could not parse the value \"{text}\" of {}: expected \
                                 \"true\" or \"false\"",
                                e.describe()
                            )))
                        }
                    })
                }
                "string" => {
                    e.check(&["name", "value"], &[])?;
                    Value::String(e.req("value").to_string())
                }
                "rgb" => {
                    e.check(&["name", "value"], &[])?;
                    let text = e.req("value");
                    let v = match tokenize(text)[..] {
                        [g] => [e.float(g, "the value")?; 3],
                        [r, g, b] => [e.float(r, "the value")?, e.float(g, "the value")?, e.float(b, "the value")?],
                        ref t => {
                            return Err(e.err(format!("{} needs one or three values, got {}", e.describe(), t.len())))
                        }
                    };
                    Value::Rgb(v)
                }
                "spectrum" => spectrum(e, resolver)?,
                "point" | "vector" => {
                    e.check(&["name"], &["value", "x", "y", "z"])?;
                    let v = xyz(e, 0.0, true)?;
                    if tag == "point" {
                        Value::Point(v)
                    } else {
                        Value::Vector(v)
                    }
                }
                _ => unreachable!("property() called for <{tag}>"),
            }
        }
    };
    Ok(Property { name: e.req("name").to_string(), value, loc: e.loc.clone(), used: Cell::new(false) })
}

/// `<spectrum>`: a constant (`value="0.5"`), wavelength:value pairs
/// (`value="400:0.1, 700:0.5"`), or an `.spd` file (`filename`), read now
/// as Mitsuba does, through the directories searched so far.
fn spectrum(e: &Elem, resolver: &[PathBuf]) -> Result<Value> {
    e.check(&["name"], &["value", "filename"])?;
    let value = e.get("value").unwrap_or_default();
    let filename = e.get("filename").unwrap_or_default();
    if value.is_empty() == filename.is_empty() {
        return Err(
            e.err(format!("{} needs either a \"value\" or a \"filename\" attribute (but not both)", e.describe()))
        );
    }
    if !filename.is_empty() {
        let name = Path::new(filename);
        let path = if name.is_absolute() {
            name.to_path_buf()
        } else {
            let found = resolver.iter().map(|d| d.join(name)).find(|p| p.is_file());
            found.ok_or_else(|| {
                e.err(format!("spectrum file \"{filename}\" of {} not found{}", e.describe(), searched(resolver)))
            })?
        };
        let pairs = crate::spectrum::read_spd(&path)
            .map_err(|m| e.err(format!("{}: spectrum file \"{}\": {m}", e.describe(), path.display())))?;
        return Ok(Value::SpectrumSampled(pairs));
    }
    let tokens = tokenize(value);
    if let [single] = tokens[..] {
        if !single.contains(':') {
            return Ok(Value::SpectrumConstant(e.float(single, "the value")?));
        }
    }
    let mut pairs = Vec::with_capacity(tokens.len());
    for token in tokens {
        let bad = || {
            e.err(format!(
                "could not parse \"{token}\" in {}: expected wavelength:value pairs such as \
                 \"400:0.1, 700:0.5\"",
                e.describe()
            ))
        };
        let (wl, v) = token.split_once(':').ok_or_else(bad)?;
        pairs.push((parse_float(wl).ok_or_else(bad)?, parse_float(v).ok_or_else(bad)?));
    }
    crate::spectrum::check_sampled(&pairs).map_err(|m| e.err(format!("{}: {m}", e.describe())))?;
    Ok(Value::SpectrumSampled(pairs))
}

/// Three components from `value` (one number is broadcast, as Mitsuba's
/// `expand_value_to_xyz`) or from `x`/`y`/`z` attributes, which are all
/// required for points and vectors and default to `default` otherwise.
fn xyz(e: &Elem, default: f64, require_all: bool) -> Result<DVec3> {
    let has_xyz = ["x", "y", "z"].iter().any(|a| e.get(a).is_some());
    if let Some(value) = e.get("value") {
        if has_xyz {
            return Err(e.err(format!("{}: cannot mix \"value\" and \"x\"/\"y\"/\"z\"", e.describe())));
        }
        return match tokenize(value)[..] {
            [v] => Ok(DVec3::splat(e.float(v, "the value")?)),
            [x, y, z] => Ok(DVec3::new(e.float(x, "the value")?, e.float(y, "the value")?, e.float(z, "the value")?)),
            ref t => Err(e.err(format!("the \"value\" of {} must have 1 or 3 numbers, got {}", e.describe(), t.len()))),
        };
    }
    let mut v = [default; 3];
    for (i, axis) in ["x", "y", "z"].into_iter().enumerate() {
        match e.get(axis) {
            Some(text) => v[i] = e.float(text, &format!("\"{axis}\""))?,
            None if require_all => {
                return Err(
                    e.err(format!("missing attribute \"{axis}\" in {} (give x, y and z, or value)", e.describe()))
                )
            }
            None => {}
        }
    }
    Ok(DVec3::from_array(v))
}

/// Three numbers from an attribute of `<lookat>`.
fn vec3_attr(e: &Elem, attr: &str) -> Result<DVec3> {
    let text = e.req(attr);
    match tokenize(text)[..] {
        [x, y, z] => {
            let what = format!("\"{attr}\"");
            Ok(DVec3::new(e.float(x, &what)?, e.float(y, &what)?, e.float(z, &what)?))
        }
        ref t => Err(e.err(format!("\"{attr}\" of <lookat> needs 3 numbers, got {}", t.len()))),
    }
}

/// The matrix of one operation inside `<transform>`.
fn transform_op(e: &Elem) -> Result<DMat4> {
    match e.tag {
        "translate" => {
            e.check(&[], &["value", "x", "y", "z"])?;
            Ok(transform::translate(xyz(e, 0.0, false)?))
        }
        "scale" => {
            e.check(&[], &["value", "x", "y", "z"])?;
            Ok(transform::scale(xyz(e, 1.0, false)?))
        }
        "rotate" => {
            e.check(&["angle"], &["value", "x", "y", "z"])?;
            let axis = xyz(e, 0.0, false)?;
            if axis == DVec3::ZERO {
                return Err(e.err("the rotation axis of <rotate> cannot be zero"));
            }
            Ok(transform::rotate(axis, e.float(e.req("angle"), "the angle")?))
        }
        "matrix" => {
            e.check(&["value"], &[])?;
            let values =
                tokenize(e.req("value")).into_iter().map(|t| e.float(t, "a value")).collect::<Result<Vec<f64>>>()?;
            transform::matrix(&values)
                .ok_or_else(|| e.err(format!("<matrix> needs 16 (or 9) values, got {}", values.len())))
        }
        "lookat" => {
            e.check(&["origin", "target"], &["up"])?;
            let origin = vec3_attr(e, "origin")?;
            let target = vec3_attr(e, "target")?;
            let mut up = match e.get("up") {
                Some(_) => vec3_attr(e, "up")?,
                None => DVec3::ZERO,
            };
            if up == DVec3::ZERO {
                up = transform::coordinate_system((target - origin).normalize()).0;
            }
            let m = transform::look_at(origin, target, up);
            if m.is_nan() {
                return Err(e.err(
                    "invalid <lookat>: the origin equals the target, or the up vector is \
                     parallel to the viewing direction",
                ));
            }
            Ok(m)
        }
        tag => Err(e.err(format!(
            "unexpected <{tag}> inside <transform>; expected translate, rotate, scale, \
             matrix or lookat"
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The line table gives every element's position as `text_pos_at`
    /// does: multi-byte characters before an element on its line, CRLF
    /// line ends, tabs, elements after the last newline and on line 1.
    #[test]
    fn element_positions_are_roxmltree_s() {
        let text = "<scene version=\"3.0.0\"><a/>\r\n\t<b x=\"é\"/><c/>\n\n  <!-- ünïcödé --> <d>\r\n<e/></d>\n<f/><g/></scene>";
        let doc = xml_document(text, Path::new("t.xml")).unwrap();
        let src = Src::new(&doc, Arc::new(PathBuf::from("t.xml")));
        let mut seen = 0;
        for node in doc.descendants().filter(|n| n.is_element()) {
            let expect = doc.text_pos_at(node.range().start);
            let loc = src.loc(node);
            assert_eq!((loc.line, loc.col), (expect.row, expect.col), "<{}>", node.tag_name().name());
            seen += 1;
        }
        assert_eq!(seen, 8);
    }
}
