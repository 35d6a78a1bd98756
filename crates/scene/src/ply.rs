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
use std::path::Path;
use std::sync::Arc;

/// Loads a PLY file with Mitsuba's default of unflipped texture coordinates.
pub fn load_ply(path: &Path) -> Result<TriangleMesh> {
    load_ply_with(path, false)
}

/// Loads a PLY file; `flip_tex_coords` is the Mitsuba shape parameter of
/// that name (true replaces each `v` by `1 - v`).
pub fn load_ply_with(path: &Path, flip_tex_coords: bool) -> Result<TriangleMesh> {
    let bytes = std::fs::read(path).map_err(|e| {
        let msg = match e.kind() {
            std::io::ErrorKind::NotFound => "PLY file not found".to_string(),
            _ => format!("cannot read PLY file: {e}"),
        };
        LoadError::in_file(path, msg)
    })?;
    parse_ply(&bytes, path, flip_tex_coords)
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
        offset += len + 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| err("the PLY header is not ASCII text".into()))?
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

/// The data after the header.
enum Body<'a> {
    Ascii(std::str::SplitAsciiWhitespace<'a>),
    Binary { data: &'a [u8], pos: usize, big_endian: bool },
}

impl Body<'_> {
    /// One value; `None` at the end of the data or on an unparsable token.
    fn read(&mut self, ty: Scalar) -> Option<f64> {
        match self {
            Body::Ascii(tokens) => tokens.next()?.parse().ok(),
            Body::Binary { data, pos, big_endian } => {
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
    let file = Arc::new(path.to_path_buf());
    let header = parse_header(bytes, &file)?;
    let data = &bytes[header.body..];
    let mut body = match header.format {
        Format::Ascii => Body::Ascii(
            std::str::from_utf8(data)
                .map_err(|_| LoadError::in_file(path, "ASCII PLY data is not text"))?
                .split_ascii_whitespace(),
        ),
        f => Body::Binary { data, pos: 0, big_endian: f == Format::BinaryBe },
    };
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
    // Never trust a header count further than the data could go.
    let capacity = |count: usize| count.min(data.len());
    let mut mesh = TriangleMesh::default();
    let mut face = Vec::new();

    for el in &header.elements {
        let truncated = |i: usize| {
            LoadError::in_file(
                path,
                format!("{} {i} of {}: unexpected end of data or invalid number", el.name, el.count),
            )
        };
        match el.name.as_str() {
            "vertex" => {
                let slots = vertex_slots(el);
                let has = |f: fn(&Slot) -> bool, n: usize| slots.iter().filter(|s| f(s)).count() == n;
                if !has(|s| matches!(s, Slot::Pos(_)), 3) {
                    return Err(LoadError::in_file(path, "the PLY vertex element lacks x, y or z"));
                }
                let with_normals = has(|s| matches!(s, Slot::Normal(_)), 3);
                let with_uvs = has(|s| matches!(s, Slot::Uv(_)), 2);
                mesh.positions.reserve(capacity(el.count));
                for i in 0..el.count {
                    let (mut p, mut n, mut uv) = ([0f32; 3], [0f32; 3], [0f32; 2]);
                    for (prop, slot) in el.props.iter().zip(&slots) {
                        match (&prop.ty, *slot) {
                            (PropType::Scalar(ty), slot) => {
                                let v = body.read(*ty).ok_or_else(|| truncated(i))? as f32;
                                match slot {
                                    Slot::Pos(k) => p[k] = v,
                                    Slot::Normal(k) => n[k] = v,
                                    Slot::Uv(k) => uv[k] = v,
                                    Slot::Skip => {}
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
            "face" => {
                let index_prop = face_index_prop.unwrap_or_default();
                mesh.indices.reserve(capacity(el.count));
                for i in 0..el.count {
                    for (k, prop) in el.props.iter().enumerate() {
                        match &prop.ty {
                            PropType::Scalar(ty) => {
                                body.read(*ty).ok_or_else(|| truncated(i))?;
                            }
                            PropType::List { count, item } if k == index_prop => {
                                let n = read_count(&mut body, *count).ok_or_else(|| truncated(i))?;
                                face.clear();
                                for _ in 0..n {
                                    let v = body.read(*item).ok_or_else(|| truncated(i))?;
                                    if !(v >= 0.0 && v < vertex_count as f64 && v.fract() == 0.0) {
                                        return Err(LoadError::in_file(
                                            path,
                                            format!(
                                                "face {i} refers to vertex {v}, but there are \
                                                 {vertex_count} vertices"
                                            ),
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
                }
            }
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
    Ok(mesh)
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
        check(format!("{head}end_header\n0 0 0\n1 0\n").as_bytes(), &["vertex 1 of 3"]);
        check(format!("{head}end_header\n0 0 0\n1 0 0\n0 1 zero\n").as_bytes(), &["vertex 2 of 3"]);
        let faces = "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
        check(format!("{head}{faces}3 0 1 3\n").as_bytes(), &["face 0", "vertex 3"]);
        check(format!("{head}{faces}3 0 1 -1\n").as_bytes(), &["face 0", "vertex -1"]);
        check(format!("{head}{faces}3 0 1\n").as_bytes(), &["face 0 of 1"]);
        check(
            format!("{head}element face 1\nproperty list uchar int indices\nend_header\n").as_bytes(),
            &["vertex_indices"],
        );
        let noz = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n";
        check(noz.as_bytes(), &["x, y or z"]);
        // Truncated binary data.
        let mut b = binary(false);
        b.truncate(b.len() - 3);
        check(&b, &["face 1 of 2"]);
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
