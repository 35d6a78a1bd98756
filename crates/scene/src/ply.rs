//! PLY reader: ASCII, binary little- and big-endian.
//!
//! Hand-written (rather than `ply-rs-bw`) to read any scalar type into the
//! few fields a mesh needs without building a dictionary per vertex.
//! Vertices give `x y z`, optionally `nx ny nz` and a texture coordinate
//! pair (`u v`, `texture_u texture_v` or `s t`); faces give a
//! `vertex_indices` (or `vertex_index`) list, fan-triangulated. Other
//! properties and elements are skipped.
//!
//! Texture coordinates are kept as stored: Mitsuba 3's PLY loader flips
//! them only when the shape sets `flip_tex_coords` (default false,
//! `src/shapes/ply.cpp`), unlike its OBJ loader.

use crate::error::{FileLoc, LoadError, Result};
use glam::{Vec2, Vec3};
use penumbra_render::geometry::TriangleMesh;
use penumbra_render::texture::MeshAttributeData;
use std::cell::Cell;
use std::path::Path;
use std::sync::Arc;

/// Loads a PLY file with Mitsuba's default of unflipped texture coordinates.
pub fn load_ply(path: &Path) -> Result<TriangleMesh> {
    load_ply_with(path, false)
}

/// Loads a PLY file; `flip_tex_coords` is the Mitsuba shape parameter of
/// that name (true replaces each `v` by `1 - v`).
pub fn load_ply_with(path: &Path, flip_tex_coords: bool) -> Result<TriangleMesh> {
    Ok(load_ply_with_attributes(path, flip_tex_coords)?.0)
}

/// Loads a PLY file with its other vertex and face properties as Mitsuba's
/// mesh attributes (see [`parse_ply_with_attributes`]).
pub fn load_ply_with_attributes(path: &Path, flip_tex_coords: bool) -> Result<(TriangleMesh, Vec<MeshAttributeData>)> {
    let bytes = std::fs::read(path).map_err(|e| {
        let msg = match e.kind() {
            std::io::ErrorKind::NotFound => "PLY file not found".to_string(),
            _ => format!("cannot read PLY file: {e}"),
        };
        LoadError::in_file(path, msg)
    })?;
    parse_ply_with_attributes(&bytes, path, flip_tex_coords)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// Bytes per value in binary files.
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug)]
enum PropType {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
struct Prop {
    name: String,
    ty: PropType,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the data after `end_header`.
    body: usize,
}

fn parse_header(bytes: &[u8], file: &Arc<std::path::PathBuf>) -> Result<Header> {
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut offset = 0;
    let mut line_no = 0u32;
    loop {
        line_no += 1;
        let err = |message: String| LoadError::at(&FileLoc::new(file.clone(), line_no, 1), message);
        let Some(len) = bytes[offset..].iter().position(|&b| b == b'\n') else {
            return Err(err("unexpected end of file in the PLY header (no end_header)".into()));
        };
        let raw = &bytes[offset..offset + len];
        let start = offset;
        offset += len + 1;
        let line = std::str::from_utf8(raw)
            .map_err(|e| {
                err(format!(
                    "the PLY header is not text: byte {} (column {}) is not UTF-8",
                    start + e.valid_up_to(),
                    1 + e.valid_up_to()
                ))
            })?
            .trim_end_matches('\r');
        if line_no == 1 {
            if line.trim() != "ply" {
                return Err(err("not a PLY file (the first line must be \"ply\")".into()));
            }
            continue;
        }
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        match words[..] {
            [] => {}
            ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                format = Some(match f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLe,
                    "binary_big_endian" => Format::BinaryBe,
                    _ => return Err(err(format!("unknown PLY format \"{f}\""))),
                });
            }
            ["element", name, count] => {
                let count = count.parse().map_err(|_| err(format!("invalid element count \"{count}\"")))?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            ["property", "list", count, item, name] => {
                let ty = match (Scalar::from_name(count), Scalar::from_name(item)) {
                    (Some(count), Some(item)) => PropType::List { count, item },
                    _ => return Err(err(format!("unknown type in \"{}\"", line.trim()))),
                };
                push_prop(&mut elements, name, ty).map_err(err)?;
            }
            ["property", ty, name] => {
                let ty = Scalar::from_name(ty).ok_or_else(|| err(format!("unknown property type \"{ty}\"")))?;
                push_prop(&mut elements, name, PropType::Scalar(ty)).map_err(err)?;
            }
            ["end_header"] => break,
            _ => return Err(err(format!("unexpected PLY header line \"{}\"", line.trim()))),
        }
    }
    let format = format.ok_or_else(|| LoadError::in_file(file, "the PLY header has no format line"))?;
    Ok(Header { format, elements, body: offset })
}

fn push_prop(elements: &mut [Element], name: &str, ty: PropType) -> std::result::Result<(), String> {
    let el = elements.last_mut().ok_or("a property before any element")?;
    el.props.push(Prop { name: name.to_string(), ty });
    Ok(())
}

/// Where in the file the value being read starts, for messages.
#[derive(Clone, Copy)]
enum At {
    /// ASCII data: the line and column (1-based, header lines counted).
    Line(usize, usize),
    /// Binary data: the byte offset from the start of the file.
    Byte(usize),
    /// ASCII data: past its last value.
    End,
}

impl std::fmt::Display for At {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match self {
            At::Line(l, c) => write!(f, "line {l}, column {c}"),
            At::Byte(b) => write!(f, "byte {b}"),
            At::End => write!(f, "the end of the data"),
        }
    }
}

impl At {
    /// An error about the value at this position of `file`: ASCII positions
    /// go into the error's location (`file:line:column: ...`), binary ones
    /// into the message (`... at byte B`).
    fn error(self, file: &Arc<std::path::PathBuf>, what: &str, message: impl std::fmt::Display) -> LoadError {
        match self {
            At::Line(l, c) => {
                LoadError::at(&FileLoc::new(file.clone(), l as u32, c as u32), format!("{what}: {message}"))
            }
            at => LoadError::at(&FileLoc::new(file.clone(), 0, 0), format!("{what} at {at}: {message}")),
        }
    }
}

/// The data after the header; `at` follows the value being read.
enum Body<'a> {
    /// `pos`: byte offset in `text`; `line`: the file's line at `pos`;
    /// `line_start`: the offset in `text` where that line starts.
    Ascii { text: &'a str, pos: usize, line: usize, line_start: usize, at: &'a Cell<At> },
    /// `base`: the data's offset in the file.
    Binary { data: &'a [u8], pos: usize, base: usize, big_endian: bool, at: &'a Cell<At> },
}

impl Body<'_> {
    /// One value; `None` at the end of the data or on an unparsable token.
    fn read(&mut self, ty: Scalar) -> Option<f64> {
        match self {
            Body::Ascii { text, pos, line, line_start, at } => {
                let rest = &text.as_bytes()[*pos..];
                let skip = rest.iter().take_while(|b| b.is_ascii_whitespace()).count();
                if skip == rest.len() {
                    at.set(At::End);
                    return None;
                }
                for (k, &b) in rest[..skip].iter().enumerate() {
                    if b == b'\n' {
                        *line += 1;
                        *line_start = *pos + k + 1;
                    }
                }
                *pos += skip;
                at.set(At::Line(*line, 1 + text[*line_start..*pos].chars().count()));
                let len = text.as_bytes()[*pos..].iter().take_while(|b| !b.is_ascii_whitespace()).count();
                let token = &text[*pos..*pos + len];
                *pos += len;
                token.parse().ok()
            }
            Body::Binary { data, pos, base, big_endian, at } => {
                at.set(At::Byte(*base + *pos));
                macro_rules! num {
                    ($t:ty) => {{
                        const N: usize = std::mem::size_of::<$t>();
                        let b: [u8; N] = data.get(*pos..*pos + N)?.try_into().ok()?;
                        *pos += N;
                        let v = if *big_endian { <$t>::from_be_bytes(b) } else { <$t>::from_le_bytes(b) };
                        v as f64
                    }};
                }
                Some(match ty {
                    Scalar::I8 => num!(i8),
                    Scalar::U8 => num!(u8),
                    Scalar::I16 => num!(i16),
                    Scalar::U16 => num!(u16),
                    Scalar::I32 => num!(i32),
                    Scalar::U32 => num!(u32),
                    Scalar::F32 => num!(f32),
                    Scalar::F64 => num!(f64),
                })
            }
        }
    }
}

/// Refuses a header whose element counts the data cannot hold, before
/// anything is allocated: each property of each element takes at least one
/// byte (a digit in ASCII files; in binary ones the size of its scalar or of
/// its list's count). A shorter truncation is found where the data ends,
/// and named there.
fn check_counts(header: &Header, data_len: usize, path: &Path) -> Result<()> {
    let mut needed: u128 = 0;
    for el in &header.elements {
        let per_row: u128 = el
            .props
            .iter()
            .map(|p| match (header.format, &p.ty) {
                (Format::Ascii, _) => 1,
                (_, PropType::Scalar(t)) | (_, PropType::List { count: t, .. }) => t.size() as u128,
            })
            .sum();
        needed += per_row * el.count as u128;
        if needed > data_len as u128 + 1 {
            return Err(LoadError::in_file(
                path,
                format!(
                    "the PLY header claims {} '{}' elements, which need at least {needed} bytes of data with the \
                     elements before them, but the file has {data_len} bytes after the header (truncated or \
                     damaged); nothing was allocated",
                    el.count, el.name
                ),
            ));
        }
    }
    Ok(())
}

/// The reader of the data after the header. ASCII data must be text: the
/// first byte that is not UTF-8 is named by line, column and offset.
fn body<'a>(bytes: &'a [u8], header: &Header, file: &Arc<std::path::PathBuf>, at: &'a Cell<At>) -> Result<Body<'a>> {
    let data = &bytes[header.body..];
    let header_lines = 1 + bytes[..header.body].iter().filter(|&&b| b == b'\n').count();
    Ok(match header.format {
        Format::Ascii => Body::Ascii {
            text: std::str::from_utf8(data).map_err(|e| {
                let good = &data[..e.valid_up_to()];
                let line = header_lines + good.iter().filter(|&&b| b == b'\n').count();
                let col = 1 + good.iter().rev().take_while(|&&b| b != b'\n').count();
                LoadError::at(
                    &FileLoc::new(file.clone(), line as u32, col as u32),
                    format!(
                        "ASCII PLY data is not text: byte {} is not UTF-8 (is the file binary, \
                         with a wrong format line?)",
                        header.body + good.len()
                    ),
                )
            })?,
            pos: 0,
            line: header_lines,
            line_start: 0,
            at,
        },
        f => Body::Binary { data, pos: 0, base: header.body, big_endian: f == Format::BinaryBe, at },
    })
}

/// Where a vertex property goes.
#[derive(Clone, Copy, PartialEq)]
enum Slot {
    Pos(usize),
    Normal(usize),
    Uv(usize),
    Skip,
}

fn vertex_slots(el: &Element) -> Vec<Slot> {
    let has = |n: &str| el.props.iter().any(|p| p.name == n && matches!(p.ty, PropType::Scalar(_)));
    let has_normals = has("nx") && has("ny") && has("nz");
    let uv_names = [("u", "v"), ("texture_u", "texture_v"), ("s", "t")].into_iter().find(|(u, v)| has(u) && has(v));
    el.props
        .iter()
        .map(|p| match p.name.as_str() {
            _ if !matches!(p.ty, PropType::Scalar(_)) => Slot::Skip,
            "x" => Slot::Pos(0),
            "y" => Slot::Pos(1),
            "z" => Slot::Pos(2),
            "nx" if has_normals => Slot::Normal(0),
            "ny" if has_normals => Slot::Normal(1),
            "nz" if has_normals => Slot::Normal(2),
            n if uv_names.is_some_and(|(u, _)| u == n) => Slot::Uv(0),
            n if uv_names.is_some_and(|(_, v)| v == n) => Slot::Uv(1),
            _ => Slot::Skip,
        })
        .collect()
}

/// Parses PLY data; `path` names the file in messages.
pub fn parse_ply(bytes: &[u8], path: &Path, flip_tex_coords: bool) -> Result<TriangleMesh> {
    Ok(parse_ply_with_attributes(bytes, path, flip_tex_coords)?.0)
}

/// Parses PLY data and the vertex and face properties Mitsuba 3.9.1 keeps
/// as mesh attributes (`vertex_<name>`, `face_<name>`; see
/// `other_fields`). Face attributes are repeated for every triangle of a
/// fan-triangulated polygon, so they hold one entry per triangle.
pub fn parse_ply_with_attributes(
    bytes: &[u8],
    path: &Path,
    flip_tex_coords: bool,
) -> Result<(TriangleMesh, Vec<MeshAttributeData>)> {
    let file = Arc::new(path.to_path_buf());
    let header = parse_header(bytes, &file)?;
    let data = &bytes[header.body..];
    let at = Cell::new(At::Byte(header.body));
    let mut body = body(bytes, &header, &file, &at)?;
    let vertex_count = match header.elements.iter().find(|e| e.name == "vertex") {
        Some(el) => el.count,
        None => return Err(LoadError::in_file(path, "the PLY file has no vertex element")),
    };
    let face_index_prop = header.elements.iter().find(|e| e.name == "face").map(|el| {
        el.props
            .iter()
            .position(|p| {
                matches!(p.ty, PropType::List { .. }) && (p.name == "vertex_indices" || p.name == "vertex_index")
            })
            .ok_or_else(|| {
                LoadError::in_file(path, "the PLY face element has no vertex_indices (or vertex_index) list")
            })
    });
    let face_index_prop = face_index_prop.transpose()?;
    if vertex_count > u32::MAX as usize {
        return Err(LoadError::in_file(
            path,
            format!(
                "the PLY header claims {vertex_count} vertices; a mesh holds at most {} (32-bit indices)",
                u32::MAX
            ),
        ));
    }
    check_counts(&header, data.len(), path)?;
    // Never trust a header count further than the data could go.
    let capacity = |count: usize| count.min(data.len());
    let mut mesh = TriangleMesh::default();
    let mut face = Vec::new();
    let mut attributes = Vec::new();
    let mut face_values = Vec::new();

    for el in &header.elements {
        let what = |i: usize| format!("{} {i} of {}", el.name, el.count);
        let truncated = |i: usize| at.get().error(&file, &what(i), "unexpected end of data or invalid number");
        match el.name.as_str() {
            "vertex" => {
                let slots = vertex_slots(el);
                let has = |f: fn(&Slot) -> bool, n: usize| slots.iter().filter(|s| f(s)).count() == n;
                if !has(|s| matches!(s, Slot::Pos(_)), 3) {
                    return Err(LoadError::in_file(path, "the PLY vertex element lacks x, y or z"));
                }
                let with_normals = has(|s| matches!(s, Slot::Normal(_)), 3);
                let with_uvs = has(|s| matches!(s, Slot::Uv(_)), 2);
                let (specs, attr_slots) = other_fields("vertex_", el, &["x", "y", "z", "nx", "ny", "nz", "u", "v"]);
                let first = attributes.len();
                attributes.extend(specs);
                mesh.positions.reserve(capacity(el.count));
                for i in 0..el.count {
                    let (mut p, mut n, mut uv) = ([0f32; 3], [0f32; 3], [0f32; 2]);
                    for a in &mut attributes[first..] {
                        a.data.resize(a.data.len() + a.dim, 0.0);
                    }
                    for ((prop, slot), attr) in el.props.iter().zip(&slots).zip(&attr_slots) {
                        match (&prop.ty, *slot) {
                            (PropType::Scalar(ty), slot) => {
                                let raw = body.read(*ty).ok_or_else(|| truncated(i))?;
                                let v = raw as f32;
                                if slot != Slot::Skip && !v.is_finite() {
                                    return Err(at.get().error(
                                        &file,
                                        &what(i),
                                        format!(
                                            "property '{}' is {raw:e}, which is not a finite single-precision number",
                                            prop.name
                                        ),
                                    ));
                                }
                                match slot {
                                    Slot::Pos(k) => p[k] = v,
                                    Slot::Normal(k) => n[k] = v,
                                    Slot::Uv(k) => uv[k] = v,
                                    Slot::Skip => {}
                                }
                                if let Some((a, k)) = *attr {
                                    let a = &mut attributes[first + a];
                                    let at = i * a.dim + k;
                                    a.data[at] = attribute_value(*ty, raw);
                                }
                            }
                            (PropType::List { count, item }, _) => {
                                skip_list(&mut body, *count, *item).ok_or_else(|| truncated(i))?
                            }
                        }
                    }
                    mesh.positions.push(Vec3::from_array(p));
                    if with_normals {
                        mesh.normals.push(Vec3::from_array(n));
                    }
                    if with_uvs {
                        mesh.uvs.push(Vec2::new(uv[0], if flip_tex_coords { 1.0 - uv[1] } else { uv[1] }));
                    }
                }
            }
            // A face element without properties holds no faces, however many
            // it claims (looping over a claimed 10^19 of them would hang).
            "face" if el.props.is_empty() => {}
            "face" => {
                let index_prop = face_index_prop.unwrap_or_default();
                let (specs, attr_slots) = other_fields("face_", el, &[]);
                let first = attributes.len();
                attributes.extend(specs);
                let stride: usize = attributes[first..].iter().map(|a| a.dim).sum();
                let offsets: Vec<usize> = attributes[first..]
                    .iter()
                    .scan(0, |o, a| {
                        let at = *o;
                        *o += a.dim;
                        Some(at)
                    })
                    .collect();
                face_values.resize(stride, 0.0);
                mesh.indices.reserve(capacity(el.count));
                for i in 0..el.count {
                    let tris_before = mesh.indices.len();
                    for (k, prop) in el.props.iter().enumerate() {
                        match &prop.ty {
                            PropType::Scalar(ty) => {
                                let raw = body.read(*ty).ok_or_else(|| truncated(i))?;
                                if let Some((a, c)) = attr_slots[k] {
                                    face_values[offsets[a] + c] = attribute_value(*ty, raw);
                                }
                            }
                            PropType::List { count, item } if k == index_prop => {
                                let n = read_count(&mut body, *count).ok_or_else(|| truncated(i))?;
                                face.clear();
                                for _ in 0..n {
                                    let v = body.read(*item).ok_or_else(|| truncated(i))?;
                                    if !(v >= 0.0 && v < vertex_count as f64 && v.fract() == 0.0) {
                                        return Err(at.get().error(
                                            &file,
                                            &what(i),
                                            format!("refers to vertex {v}, but there are {vertex_count} vertices"),
                                        ));
                                    }
                                    face.push(v as u32);
                                }
                                for j in 1..face.len().saturating_sub(1) {
                                    mesh.indices.push([face[0], face[j], face[j + 1]]);
                                }
                            }
                            PropType::List { count, item } => {
                                skip_list(&mut body, *count, *item).ok_or_else(|| truncated(i))?
                            }
                        }
                    }
                    for _ in tris_before..mesh.indices.len() {
                        for (a, &o) in attributes[first..].iter_mut().zip(&offsets) {
                            a.data.extend_from_slice(&face_values[o..o + a.dim]);
                        }
                    }
                }
            }
            // An element without properties has nothing to read, however many it claims.
            _ if el.props.is_empty() => {}
            _ => {
                for i in 0..el.count {
                    for prop in &el.props {
                        match &prop.ty {
                            PropType::Scalar(ty) => {
                                body.read(*ty).ok_or_else(|| truncated(i))?;
                            }
                            PropType::List { count, item } => {
                                skip_list(&mut body, *count, *item).ok_or_else(|| truncated(i))?
                            }
                        }
                    }
                }
            }
        }
    }
    Ok((mesh, attributes))
}

/// A property value as Mitsuba 3.9.1 stores it in a mesh attribute: PLY
/// integer properties carry Mitsuba's `Normalized | Gamma` flags, so they
/// are divided by the type's maximum and decoded from sRGB, except `uchar`,
/// which Mitsuba's converter keeps as the raw 0..255 value (checked against
/// Mitsuba 3.9.1: `mi.traverse(mi.load_dict({'type': 'ply', ...}))` gives
/// `vertex_color [255, 128, 0, ...]` for uchar red/green/blue and
/// 1000/65535 decoded from sRGB = 0.00118104 for a ushort).
fn attribute_value(ty: Scalar, v: f64) -> f32 {
    let max = match ty {
        Scalar::F32 | Scalar::F64 | Scalar::U8 => return v as f32,
        Scalar::I8 => i8::MAX as f64,
        Scalar::I16 => i16::MAX as f64,
        Scalar::U16 => u16::MAX as f64,
        Scalar::I32 => i32::MAX as f64,
        Scalar::U32 => u32::MAX as f64,
    };
    let x = (v / max) as f32;
    if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

/// Mitsuba 3.9.1's `find_other_fields` (`src/shapes/ply.h`): which of an
/// element's scalar properties form mesh attributes. `r g b [a]` (or `red
/// green blue [alpha]`) become `<kind>color`; otherwise consecutive
/// properties `<prefix>_<c>` with postfixes from one of the sequences x y z w,
/// r g b a, 0 1 2 3 or 1 2 3 4 become `<kind><prefix>` (`<kind><prefix>_color`
/// for r g b), kept when they have one or three components. Mitsuba warns
/// about and skips the rest; so does this (silently). Returns the attributes
/// (empty data) and, per property, the (attribute, component) it feeds.
fn other_fields(kind: &str, el: &Element, reserved: &[&str]) -> (Vec<MeshAttributeData>, Vec<Option<(usize, usize)>>) {
    let mut names: Vec<Option<String>> =
        el.props.iter().map(|p| matches!(p.ty, PropType::Scalar(_)).then(|| p.name.clone())).collect();
    let find = |names: &[Option<String>], n: &str| names.iter().position(|x| x.as_deref() == Some(n));
    let mut specs = Vec::new();
    let mut slots = vec![None; el.props.len()];
    if !(find(&names, "r").is_some() && find(&names, "g").is_some() && find(&names, "b").is_some())
        && find(&names, "red").is_some()
        && find(&names, "green").is_some()
        && find(&names, "blue").is_some()
    {
        for (from, to) in [("red", "r"), ("green", "g"), ("blue", "b"), ("alpha", "a")] {
            if let Some(i) = find(&names, from) {
                names[i] = Some(to.to_string());
            }
        }
    }
    if let (Some(r), Some(g), Some(b)) = (find(&names, "r"), find(&names, "g"), find(&names, "b")) {
        let mut fields = vec![r, g, b];
        fields.extend(find(&names, "a"));
        for (c, &f) in fields.iter().enumerate() {
            slots[f] = Some((specs.len(), c));
        }
        specs.push(MeshAttributeData {
            name: format!("{kind}color"),
            per_vertex: kind == "vertex_",
            dim: fields.len(),
            data: Vec::new(),
        });
    }
    let reserved: Vec<&str> = reserved.iter().copied().chain(["r", "g", "b", "a"]).collect();
    const POSTFIXES: [&[u8; 4]; 4] = [b"xr01", b"yg12", b"zb23", b"wa34"];
    let mut encountered: Vec<String> = Vec::new();
    let (mut prefix, mut index, mut level, mut reading) = (String::new(), 0usize, 0usize, false);
    // Mitsuba's state machine, transcribed with its quirks (a skipped run of
    // properties also skips the property after it).
    let flush = |prefix: &mut String,
                 index: &mut usize,
                 level: &mut usize,
                 reading: &mut bool,
                 specs: &mut Vec<MeshAttributeData>,
                 slots: &mut Vec<Option<(usize, usize)>>,
                 encountered: &mut Vec<String>,
                 names: &[Option<String>]| {
        if *level == 1 || *level == 3 {
            let fields: Vec<Option<usize>> = (0..*level)
                .map(|c| {
                    let n = format!("{prefix}_{}", POSTFIXES[c][*index] as char);
                    names.iter().position(|x| x.as_deref() == Some(n.as_str()))
                })
                .collect();
            if fields.iter().all(|f| f.is_some()) {
                for (c, f) in fields.iter().enumerate() {
                    slots[f.unwrap()] = Some((specs.len(), c));
                }
                let color = if *index == 1 { "_color" } else { "" };
                specs.push(MeshAttributeData {
                    name: format!("{kind}{prefix}{color}"),
                    per_vertex: kind == "vertex_",
                    dim: *level,
                    data: Vec::new(),
                });
                encountered.push(prefix.clone());
            }
        }
        prefix.clear();
        *index = 0;
        *level = 0;
        *reading = false;
    };
    let count = names.len();
    let mut i = 0;
    while i < count {
        let Some(name) = names[i].clone() else {
            i += 1;
            continue;
        };
        if reserved.contains(&name.as_str()) {
            i += 1;
            continue;
        }
        // A run member is `<prefix>_<one character>`; anything else ends the run.
        let Some(pos) = name.rfind('_').filter(|&p| name[p + 1..].len() == 1) else {
            if reading {
                flush(
                    &mut prefix,
                    &mut index,
                    &mut level,
                    &mut reading,
                    &mut specs,
                    &mut slots,
                    &mut encountered,
                    &names,
                );
            }
            i += 1;
            continue;
        };
        let postfix = &name[pos + 1..];
        let this_prefix = &name[..pos];
        if reading && this_prefix != prefix {
            flush(&mut prefix, &mut index, &mut level, &mut reading, &mut specs, &mut slots, &mut encountered, &names);
        }
        let skip_run = |i: &mut usize| {
            while *i < count && names[*i].as_deref().is_some_and(|n| n.starts_with(this_prefix)) {
                *i += 1;
            }
        };
        if !reading && encountered.iter().any(|e| e == this_prefix) {
            skip_run(&mut i);
            i += 1;
            continue;
        }
        let ch = postfix.as_bytes()[0];
        if !reading {
            match POSTFIXES[0].iter().position(|&c| c == ch) {
                Some(j) => {
                    reading = true;
                    index = j;
                    prefix = this_prefix.to_string();
                }
                None => {
                    i += 1;
                    continue;
                }
            }
        } else if level >= 4 || ch != POSTFIXES[level][index] {
            prefix.clear();
            index = 0;
            level = 0;
            reading = false;
            skip_run(&mut i);
            if i >= count {
                break;
            }
        }
        level += 1;
        i += 1;
    }
    if reading {
        flush(&mut prefix, &mut index, &mut level, &mut reading, &mut specs, &mut slots, &mut encountered, &names);
    }
    (specs, slots)
}

/// The first element of a PLY file read as a table of float32 columns
/// (Mitsuba's `ellipsoids` reads its file so: every property a `float`).
#[derive(Debug, Clone)]
pub struct PlyTable {
    /// The column (property) names, in file order.
    pub names: Vec<String>,
    /// Row-major values, `names.len()` per row.
    pub values: Vec<f32>,
}

impl PlyTable {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.values.len().checked_div(self.names.len()).unwrap_or(0)
    }
}

/// Reads the first element of the PLY file at `path` as a [`PlyTable`]:
/// every property must be a scalar `float` (Mitsuba reads the rows as raw
/// float32). A count that the data cannot hold is refused before anything
/// is allocated; bad values name their line (ASCII) or byte (binary).
pub fn load_ply_table(path: &Path) -> Result<PlyTable> {
    let bytes = std::fs::read(path).map_err(|e| {
        let msg = match e.kind() {
            std::io::ErrorKind::NotFound => "PLY file not found".to_string(),
            _ => format!("cannot read PLY file: {e}"),
        };
        LoadError::in_file(path, msg)
    })?;
    parse_ply_table(&bytes, path)
}

/// [`load_ply_table`] of data in memory; `path` names the file in messages.
pub fn parse_ply_table(bytes: &[u8], path: &Path) -> Result<PlyTable> {
    let file = Arc::new(path.to_path_buf());
    let header = parse_header(bytes, &file)?;
    let el = header.elements.first().ok_or_else(|| LoadError::in_file(path, "the PLY file has no element"))?;
    for p in &el.props {
        if !matches!(p.ty, PropType::Scalar(Scalar::F32)) {
            return Err(LoadError::in_file(
                path,
                format!("property '{}' of element '{}' must be a float (float32)", p.name, el.name),
            ));
        }
    }
    let data = &bytes[header.body..];
    let columns = el.props.len();
    // A binary value takes 4 bytes, an ASCII one at least 2 (digit and separator).
    let min_bytes = if header.format == Format::Ascii { 2 } else { 4 };
    let needed = el.count.checked_mul(columns).and_then(|n| n.checked_mul(min_bytes));
    if needed.is_none_or(|n| n > data.len() + 1) {
        return Err(LoadError::in_file(
            path,
            format!(
                "truncated: element '{}' claims {} rows of {columns} floats, which need {}{} bytes; \
                 the data after the header (byte {}) has {}",
                el.name,
                el.count,
                if header.format == Format::Ascii { "at least " } else { "" },
                needed.map_or("more than 2^64".to_string(), |n| n.to_string()),
                header.body,
                data.len()
            ),
        ));
    }
    let at = Cell::new(At::Byte(header.body));
    let mut body = body(bytes, &header, &file, &at)?;
    let mut values = Vec::with_capacity(el.count * columns);
    // Without columns there is nothing to read, however many rows are claimed.
    let rows = if columns == 0 { 0 } else { el.count };
    for i in 0..rows {
        for p in &el.props {
            let what = || format!("{} {i} of {}, property '{}'", el.name, el.count, p.name);
            let v = body
                .read(Scalar::F32)
                .ok_or_else(|| at.get().error(&file, &what(), "unexpected end of data or invalid number"))?;
            values.push(v as f32);
        }
    }
    Ok(PlyTable { names: el.props.iter().map(|p| p.name.clone()).collect(), values })
}

fn read_count(body: &mut Body, ty: Scalar) -> Option<usize> {
    let n = body.read(ty)?;
    (n >= 0.0 && n.fract() == 0.0).then_some(n as usize)
}

fn skip_list(body: &mut Body, count: Scalar, item: Scalar) -> Option<()> {
    let n = read_count(body, count)?;
    for _ in 0..n {
        body.read(item)?;
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = "/virtual/mesh.ply";

    fn parse(bytes: &[u8]) -> Result<TriangleMesh> {
        parse_ply(bytes, Path::new(FILE), false)
    }

    const ASCII_QUAD: &str = "ply\nformat ascii 1.0\ncomment made by hand\n\
        element vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        property float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n";

    #[test]
    fn ascii_quad() {
        let m = parse(ASCII_QUAD.as_bytes()).unwrap();
        assert_eq!(m.positions, [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]);
        assert_eq!(m.normals, [Vec3::Z; 4]);
        assert_eq!(m.uvs[2], Vec2::ONE);
        assert_eq!(m.indices, [[0, 1, 2], [0, 2, 3]]);
        m.validate().unwrap();
        let flipped = parse_ply(ASCII_QUAD.as_bytes(), Path::new(FILE), true).unwrap();
        assert_eq!(flipped.uvs[1], Vec2::new(1.0, 1.0));
    }

    /// Found by fuzzing: a second face element without properties that
    /// claims 1.2·10^19 faces made the reader loop over them, reading nothing.
    #[test]
    fn face_element_without_properties_is_empty() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
            property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
            element face 12297829382473034404\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let m = parse(text.as_bytes()).unwrap();
        assert_eq!(m.indices, [[0, 1, 2]]);
    }

    #[test]
    fn crlf_header_and_missing_attributes() {
        let text = "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty double x\r\n\
            property double y\r\nproperty double z\r\nproperty float nx\r\n\
            element face 1\r\nproperty list uint8 uint32 vertex_index\r\nend_header\r\n\
            0 0 0 1\r\n1 0 0 1\r\n0 1 0 1\r\n3 0 1 2\r\n";
        let m = parse(text.as_bytes()).unwrap();
        // Only nx is present: no normals; no uvs either.
        assert!(m.normals.is_empty() && m.uvs.is_empty());
        assert_eq!(m.indices, [[0, 1, 2]]);
    }

    #[test]
    fn alternative_uv_names() {
        for (u, v) in [("s", "t"), ("texture_u", "texture_v")] {
            let text = format!(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                 property float z\nproperty float {u}\nproperty float {v}\nelement face 1\n\
                 property list uchar int vertex_indices\nend_header\n\
                 0 0 0 0.25 0.5\n1 0 0 0 0\n0 1 0 0 0\n3 0 1 2\n"
            );
            let m = parse(text.as_bytes()).unwrap();
            assert_eq!(m.uvs[0], Vec2::new(0.25, 0.5), "{u} {v}");
        }
    }

    /// Writes a binary PLY with mixed types, an extra element, extra
    /// properties (scalar and list) and a pentagon.
    fn binary(big_endian: bool) -> Vec<u8> {
        let format = if big_endian { "binary_big_endian" } else { "binary_little_endian" };
        let mut out = format!(
            "ply\nformat {format} 1.0\nelement material 1\nproperty uchar r\nproperty list uchar float weights\n\
             element vertex 5\nproperty float x\nproperty double y\nproperty short z\n\
             property uchar red\nproperty float s\nproperty float t\n\
             element face 2\nproperty uchar flags\nproperty list uchar ushort vertex_indices\n\
             property list int uchar extra\nend_header\n"
        )
        .into_bytes();
        fn put<const N: usize>(out: &mut Vec<u8>, le: [u8; N], big_endian: bool) {
            let mut b = le;
            if big_endian {
                b.reverse();
            }
            out.extend_from_slice(&b);
        }
        // material: r, weights [2 floats]
        out.push(7);
        out.push(2);
        put(&mut out, 1.5f32.to_le_bytes(), big_endian);
        put(&mut out, 2.5f32.to_le_bytes(), big_endian);
        for i in 0..5 {
            put(&mut out, (i as f32).to_le_bytes(), big_endian);
            put(&mut out, (i as f64 * 2.0).to_le_bytes(), big_endian);
            put(&mut out, (-(i as i16)).to_le_bytes(), big_endian);
            out.push(255);
            put(&mut out, (i as f32 / 4.0).to_le_bytes(), big_endian);
            put(&mut out, 0.5f32.to_le_bytes(), big_endian);
        }
        // face 0: a triangle; face 1: a pentagon; each with an extra list.
        out.push(0);
        out.push(3);
        for v in [0u16, 1, 2] {
            put(&mut out, v.to_le_bytes(), big_endian);
        }
        put(&mut out, 1i32.to_le_bytes(), big_endian);
        out.push(9);
        out.push(1);
        out.push(5);
        for v in [4u16, 3, 2, 1, 0] {
            put(&mut out, v.to_le_bytes(), big_endian);
        }
        put(&mut out, 0i32.to_le_bytes(), big_endian);
        out
    }

    #[test]
    fn binary_both_endiannesses() {
        for big_endian in [false, true] {
            let m = parse(&binary(big_endian)).unwrap();
            assert_eq!(m.positions.len(), 5);
            assert_eq!(m.positions[3], Vec3::new(3.0, 6.0, -3.0));
            assert_eq!(m.uvs[2], Vec2::new(0.5, 0.5));
            assert!(m.normals.is_empty());
            assert_eq!(m.indices, [[0, 1, 2], [4, 3, 2], [4, 2, 1], [4, 1, 0]]);
            m.validate().unwrap();
        }
    }

    #[test]
    fn errors() {
        let check = |bytes: &[u8], words: &[&str]| {
            let e = parse(bytes).unwrap_err();
            let s = e.to_string();
            assert!(s.contains(FILE), "{s}");
            for w in words {
                assert!(s.contains(w), "{s} lacks {w}");
            }
            e
        };
        check(b"obj\n", &["not a PLY file"]);
        let e = check(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\nend_header\n", &["flot"]);
        assert_eq!(e.loc.unwrap().line, 4);
        check(b"ply\nformat ascii 1.0\nproperty float x\nend_header\n", &["before any element"]);
        check(b"ply\nformat ascii 1.0\nelement vertex 1\n", &["end_header"]);
        check(b"ply\nformat ascii 1.0\nelement vertex x\nend_header\n", &["element count"]);
        check(b"ply\nformat binary_middle_endian 1.0\nend_header\n", &["binary_middle_endian"]);
        check(b"ply\nelement vertex 0\nend_header\n", &["format"]);
        check(b"ply\nformat ascii 1.0\nbogus line\nend_header\n", &["bogus line"]);
        check(b"ply\nformat ascii 1.0\nelement face 0\nend_header\n", &["no vertex element"]);
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
        // ASCII data: the line of the value (header lines counted; line 9 is the first after end_header).
        let at = |bytes: &[u8], line: u32, col: u32, words: &[&str]| {
            let e = check(bytes, words);
            let loc = e.loc.clone().unwrap();
            assert_eq!((loc.line, loc.col), (line, col), "{e}");
            assert!(e.to_string().starts_with(&format!("{FILE}:{line}:{col}: ")), "{e}");
        };
        check(format!("{head}end_header\n0 0 0\n1 0\n").as_bytes(), &["vertex 1 of 3 at the end of the data"]);
        at(format!("{head}end_header\n0 0 0\n1 0 0\n0 1 zero\n").as_bytes(), 10, 5, &["vertex 2 of 3: "]);
        at(format!("{head}end_header\n0 0 0\n\n\n1 0 0\n0 1 zero\n").as_bytes(), 12, 5, &["vertex 2 of 3: "]);
        at(
            &[format!("{head}end_header\n0 0 0\n1 ").as_bytes(), b"\xff 0\n"].concat(),
            9,
            3,
            &["byte 108 is not UTF-8"],
        );
        at(b"ply\nformat ascii 1.0\ncomment caf\xe9\n", 3, 1, &["byte 32 (column 12) is not UTF-8"]);
        let faces = "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
        at(format!("{head}{faces}3 0 1 3\n").as_bytes(), 13, 7, &["face 0 of 1: refers to vertex 3"]);
        at(format!("{head}{faces}3 0 1 -1\n").as_bytes(), 13, 7, &["face 0 of 1: refers to vertex -1"]);
        check(format!("{head}{faces}3 0 1\n").as_bytes(), &["face 0 of 1"]);
        // Non-finite positions, normals and texture coordinates, in ASCII
        // (nan, inf, a double past the float range) and binary data.
        at(format!("{head}end_header\n0 0 0\n1 nan 0\n0 1 0\n").as_bytes(), 9, 3, &["vertex 1 of 3: ", "'y' is NaN"]);
        at(format!("{head}end_header\n0 0 0\n1 0 -inf\n0 1 0\n").as_bytes(), 9, 5, &["'z' is -inf"]);
        let dhead = "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\n\
            property double z\nproperty float nx\nproperty float ny\nproperty float nz\n\
            property float u\nproperty float v\nend_header\n";
        at(format!("{dhead}1e39 0 0 0 0 1 0 0\n").as_bytes(), 13, 1, &["'x' is 1e39", "not a finite single"]);
        at(format!("{dhead}0 0 0 0 NaN 1 0 0\n").as_bytes(), 13, 9, &["'ny' is NaN"]);
        at(format!("{dhead}0 0 0 0 0 1 0 inf\n").as_bytes(), 13, 15, &["'v' is inf"]);
        let mut b = binary(false);
        let first_y = b.windows(10).position(|w| w == b"end_header").unwrap() + 11 + 1 + 1 + 8 + 4;
        b[first_y..first_y + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        check(&b, &[&format!("vertex 0 of 5 at byte {first_y}: property 'y' is NaN")]);
        check(
            format!("{head}element face 1\nproperty list uchar int indices\nend_header\n").as_bytes(),
            &["vertex_indices"],
        );
        // Billions of elements claimed: refused before allocating, with the size asked for.
        let huge = head.replace("vertex 3", "vertex 3000000000");
        check(
            format!("{huge}end_header\n0 0 0\n").as_bytes(),
            &["claims 3000000000 'vertex' elements, which need at least 9000000000 bytes", "has 6 bytes"],
        );
        let huge = head.replace("vertex 3", "vertex 5000000000");
        check(format!("{huge}end_header\n0 0 0\n").as_bytes(), &["5000000000 vertices", "32-bit"]);
        let binary_huge =
            "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
            property float z\nelement face 400000000\nproperty list uchar int vertex_indices\nend_header\n";
        let mut b = binary_huge.as_bytes().to_vec();
        b.extend_from_slice(&[0u8; 12]);
        check(&b, &["claims 400000000 'face' elements, which need at least 400000012 bytes", "has 12 bytes"]);
        // Elements without properties have nothing to read, however many are claimed.
        let empty = format!(
            "ply\nformat ascii 1.0\nelement junk 18000000000000000000\n{}end_header\n0 0 0\n1 0 0\n0 1 0\n",
            &head[21..]
        );
        assert_eq!(parse(empty.as_bytes()).unwrap().positions.len(), 3);
        let table = "ply\nformat ascii 1.0\nelement junk 18000000000000000000\nend_header\n";
        assert_eq!(parse_ply_table(table.as_bytes(), Path::new(FILE)).unwrap().rows(), 0);
        let noz = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n";
        check(noz.as_bytes(), &["x, y or z"]);
        // Truncated binary data.
        let mut b = binary(false);
        b.truncate(b.len() - 3);
        check(&b, &["face 1 of 2 at byte"]);
    }

    /// Mesh attributes as Mitsuba 3.9.1 groups and converts them; expected
    /// values from `mi.traverse(mi.load_dict({'type': 'ply', 'filename': f}))`
    /// on the same files (scalar_rgb).
    #[test]
    fn attributes_as_mitsuba() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
            property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
            property float rough_x\nproperty float temp_0\nproperty float temp_1\nproperty float temp_2\n\
            element face 1\nproperty list uchar int vertex_indices\nproperty float q_x\n\
            property uchar r\nproperty uchar g\nproperty uchar b\nend_header\n\
            0 0 0 255 128 0 0.5 1 2 3\n1 0 0 10 20 30 0.25 4 5 6\n0 1 0 0 0 255 0.75 7 8 9\n\
            3 0 1 2 0.3 64 128 192\n";
        let (_, attrs) = parse_ply_with_attributes(text.as_bytes(), Path::new(FILE), false).unwrap();
        let get = |n: &str| attrs.iter().find(|a| a.name == n).unwrap_or_else(|| panic!("{n} in {attrs:?}"));
        // uchar colours stay 0..255 in Mitsuba 3.9.1 (it warns about it).
        assert_eq!(get("vertex_color").data, [255., 128., 0., 10., 20., 30., 0., 0., 255.]);
        assert_eq!(get("vertex_rough").data, [0.5, 0.25, 0.75]);
        assert_eq!(get("vertex_temp").data, [1., 2., 3., 4., 5., 6., 7., 8., 9.]);
        assert_eq!(get("face_q").data, [0.3]);
        assert_eq!((get("face_color").data.as_slice(), get("face_color").per_vertex), (&[64., 128., 192.][..], false));
        assert_eq!(attrs.len(), 5);

        // Other integer types are normalised and decoded from sRGB; RGBA
        // colours have four components; a quad's face value repeats.
        let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
            property float z\nproperty ushort r\nproperty ushort g\nproperty ushort b\nproperty ushort a\n\
            property char k_x\nproperty int i_x\nproperty double d_x\n\
            element face 1\nproperty list uchar int vertex_indices\nproperty float w_y\nend_header\n\
            0 0 0 65535 1000 0 0 -128 7 0.5\n1 0 0 1000 0 0 0 127 -3 0.25\n0 1 0 0 0 0 0 0 0 1\n\
            1 1 0 0 0 0 0 0 0 1\n4 0 1 3 2 0.5\n";
        let (m, attrs) = parse_ply_with_attributes(text.as_bytes(), Path::new(FILE), false).unwrap();
        let get = |n: &str| attrs.iter().find(|a| a.name == n).unwrap_or_else(|| panic!("{n} in {attrs:?}"));
        let close = |a: &[f32], b: &[f32]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-6 * y.abs().max(1e-3))
        };
        let c = get("vertex_color");
        assert_eq!(c.dim, 4);
        assert!(close(&c.data[..8], &[1.0, 0.00118104, 0.0, 0.0, 0.00118104, 0.0, 0.0, 0.0]), "{:?}", c.data);
        assert!(close(&get("vertex_k").data[..3], &[-0.0780088, 1.0, 0.0]), "{:?}", get("vertex_k").data);
        assert!(close(&get("vertex_i").data[..3], &[2.52293e-10, -1.08126e-10, 0.0]), "{:?}", get("vertex_i").data);
        assert_eq!(get("vertex_d").data, [0.5, 0.25, 1.0, 1.0]);
        // 'w_y' does not start a postfix sequence (x, r, 0 or 1): ignored.
        assert!(attrs.iter().all(|a| !a.name.starts_with("face_")), "{attrs:?}");
        assert_eq!(m.indices.len(), 2);
    }

    #[test]
    fn load_from_disk_and_missing_file() {
        let dir = std::env::temp_dir().join(format!("penumbra-ply-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("quad.ply");
        std::fs::write(&path, binary(true)).unwrap();
        let m = load_ply(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(m.indices.len(), 4);
        let e = load_ply(Path::new("/nonexistent/bunny.ply")).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("/nonexistent/bunny.ply") && s.contains("not found"), "{s}");
    }
}
