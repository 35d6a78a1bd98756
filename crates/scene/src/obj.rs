//! Wavefront OBJ reader.
//!
//! Hand-written rather than `tobj`, to control what Mitsuba controls:
//! every object and group is merged into one mesh (as Mitsuba's `obj`
//! shape does), polygons are fan-triangulated around their first corner,
//! and corners are split into one output vertex per distinct
//! (position, uv, normal) triple.
//!
//! Texture coordinates: Mitsuba 3's OBJ loader flips them vertically
//! (`v → 1 − v`) unless the shape sets `flip_tex_coords` to false
//! (`src/shapes/obj.cpp`); [`load_obj`] applies that default.

use crate::error::{FileLoc, LoadError, Result};
use glam::{Vec2, Vec3};
use penumbra_render::geometry::TriangleMesh;
use std::path::Path;
use std::sync::Arc;

/// Loads an OBJ file with Mitsuba's default of flipping texture
/// coordinates vertically.
pub fn load_obj(path: &Path) -> Result<TriangleMesh> {
    load_obj_with(path, true)
}

/// Loads an OBJ file; `flip_tex_coords` is the Mitsuba shape parameter of
/// that name (true replaces each `v` by `1 - v`).
pub fn load_obj_with(path: &Path, flip_tex_coords: bool) -> Result<TriangleMesh> {
    let bytes = std::fs::read(path).map_err(|e| {
        let msg = match e.kind() {
            std::io::ErrorKind::NotFound => "OBJ file not found".to_string(),
            _ => format!("cannot read OBJ file: {e}"),
        };
        LoadError::in_file(path, msg)
    })?;
    check_text(&bytes).map_err(|e| LoadError::at(&FileLoc::new(Arc::new(path.to_path_buf()), e.0, e.1), e.2))?;
    parse_obj(&String::from_utf8_lossy(&bytes), path, flip_tex_coords)
}

/// Refuses data that is not text (a binary file given as OBJ): the first
/// NUL or other control byte (tab, line feed, carriage return and form feed
/// aside) as (line, column, message naming its offset). Bytes that are not
/// UTF-8 are let through: names and comments in other encodings are
/// common, and a number spelt with them is refused where it is parsed.
pub fn check_text(bytes: &[u8]) -> std::result::Result<(), (u32, u32, String)> {
    let Some(bad) = bytes.iter().position(|&b| b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0c) || b == 0x7f)
    else {
        return Ok(());
    };
    let good = &bytes[..bad];
    let line = 1 + good.iter().filter(|&&b| b == b'\n').count();
    let col = 1 + String::from_utf8_lossy(&good[good.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1)..])
        .chars()
        .count();
    Err((
        line as u32,
        col as u32,
        format!("not an OBJ text file: byte {bad} is the control character 0x{:02x} (is the file binary?)", bytes[bad]),
    ))
}

/// Marks an absent texture coordinate or normal index in a corner key.
const NONE: u32 = u32::MAX;

/// Parses OBJ text; `path` names the file in messages.
pub fn parse_obj(text: &str, path: &Path, flip_tex_coords: bool) -> Result<TriangleMesh> {
    let file = Arc::new(path.to_path_buf());
    let mut positions: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut uvs: Vec<Vec2> = Vec::new();
    let mut corners = Corners::default();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut face: Vec<u32> = Vec::new();
    // Whether some corner lacks a uv / a normal: then the whole mesh goes
    // without, rather than mixing real and made-up values.
    let (mut missing_uv, mut missing_normal) = (false, false);

    for (line_no, line) in text.lines().enumerate() {
        // The column (in characters) where `word`, a slice of `line`, starts.
        let col = |word: &str| 1 + line[..word.as_ptr() as usize - line.as_ptr() as usize].chars().count();
        let err_at = |word: &str, message: String| {
            LoadError::at(&FileLoc::new(file.clone(), line_no as u32 + 1, col(word) as u32), message)
        };
        let mut words = line.split_ascii_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        match keyword {
            "v" => {
                let p = floats::<3>(&mut words, 3, "vertex", line, &err_at)?;
                positions.push(Vec3::from_array(p));
            }
            "vn" => {
                let n = floats::<3>(&mut words, 3, "normal", line, &err_at)?;
                normals.push(Vec3::from_array(n));
            }
            "vt" => {
                let [u, v] = floats::<2>(&mut words, 1, "texture coordinate", line, &err_at)?;
                uvs.push(Vec2::new(u, if flip_tex_coords { 1.0 - v } else { v }));
            }
            "f" => {
                face.clear();
                for word in words {
                    let err = |message: String| err_at(word, message);
                    let mut parts = word.split('/');
                    let mut index = |count: usize, what: &str| -> Result<u32> {
                        match parts.next() {
                            None | Some("") => Ok(NONE),
                            Some(s) => resolve_index(s, count).ok_or_else(|| {
                                err(format!("invalid {what} index \"{s}\" in face \"{word}\" ({count} defined so far)"))
                            }),
                        }
                    };
                    let v = index(positions.len(), "vertex")?;
                    let vt = index(uvs.len(), "texture coordinate")?;
                    let vn = index(normals.len(), "normal")?;
                    if v == NONE || parts.next().is_some() {
                        return Err(err(format!("malformed face vertex \"{word}\"")));
                    }
                    missing_uv |= vt == NONE;
                    missing_normal |= vn == NONE;
                    face.push(corners.insert([v, vt, vn]));
                }
                // Mitsuba skips faces with fewer than three corners.
                for i in 1..face.len().saturating_sub(1) {
                    triangles.push([face[0], face[i], face[i + 1]]);
                }
            }
            _ => {} // groups, objects, materials, smoothing groups, lines, comments
        }
    }

    if missing_uv || missing_normal {
        let mut reduced = Corners::default();
        let remap: Vec<u32> = corners
            .keys
            .iter()
            .map(|&[v, vt, vn]| {
                reduced.insert([v, if missing_uv { NONE } else { vt }, if missing_normal { NONE } else { vn }])
            })
            .collect();
        for t in &mut triangles {
            *t = t.map(|i| remap[i as usize]);
        }
        corners = reduced;
    }

    let keys = &corners.keys;
    let has = |i: usize| !keys.is_empty() && keys.iter().all(|k| k[i] != NONE);
    Ok(TriangleMesh {
        positions: keys.iter().map(|k| positions[k[0] as usize]).collect(),
        normals: if has(2) { keys.iter().map(|k| normals[k[2] as usize]).collect() } else { Vec::new() },
        uvs: if has(1) { keys.iter().map(|k| uvs[k[1] as usize]).collect() } else { Vec::new() },
        indices: triangles,
    })
}

/// Reads `N` numbers, at least `min` present (the rest are 0); extra
/// numbers (a `w`, vertex colours) are ignored. A missing number is an
/// error at the keyword, a bad or non-finite one at its column.
fn floats<'a, const N: usize>(
    words: &mut impl Iterator<Item = &'a str>,
    min: usize,
    what: &str,
    line: &'a str,
    err_at: &impl Fn(&str, String) -> LoadError,
) -> Result<[f32; N]> {
    let mut out = [0.0f32; N];
    for (i, slot) in out.iter_mut().enumerate() {
        match words.next() {
            Some(w) => {
                *slot = w.parse().map_err(|_| {
                    err_at(w, format!("could not parse \"{w}\" as a number in the {what} line \"{}\"", line.trim()))
                })?;
                if !slot.is_finite() {
                    return Err(err_at(w, format!("{what} component \"{w}\" is not a finite single-precision number")));
                }
            }
            None if i >= min => break,
            None => {
                return Err(err_at(
                    line.trim_start(),
                    format!("the {what} line \"{}\" has {i} numbers, it needs {min}", line.trim()),
                ))
            }
        }
    }
    Ok(out)
}

/// A 1-based OBJ index, or a negative one counting back from the last
/// element defined so far, to a 0-based index.
fn resolve_index(s: &str, count: usize) -> Option<u32> {
    let i: i64 = s.parse().ok()?;
    let zero_based = match i {
        0 => return None,
        i if i > 0 => i - 1,
        i => count as i64 + i,
    };
    (0..count as i64).contains(&zero_based).then_some(zero_based as u32)
}

/// Output vertices, one per distinct (position, uv, normal) index triple.
///
/// Looked up through a chain per position index instead of a hash map: a
/// position rarely has more than a few distinct corners.
#[derive(Default)]
struct Corners {
    keys: Vec<[u32; 3]>,
    /// Per position index, the first output vertex using it.
    first: Vec<u32>,
    /// Per output vertex, the next one with the same position.
    next: Vec<u32>,
}

impl Corners {
    fn insert(&mut self, key: [u32; 3]) -> u32 {
        let p = key[0] as usize;
        if p >= self.first.len() {
            self.first.resize(p + 1, NONE);
        }
        let mut cur = self.first[p];
        let mut last = NONE;
        while cur != NONE {
            if self.keys[cur as usize] == key {
                return cur;
            }
            last = cur;
            cur = self.next[cur as usize];
        }
        let id = self.keys.len() as u32;
        self.keys.push(key);
        self.next.push(NONE);
        if last == NONE {
            self.first[p] = id;
        } else {
            self.next[last as usize] = id;
        }
        id
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<TriangleMesh> {
        parse_obj(text, Path::new("/virtual/mesh.obj"), false)
    }

    #[test]
    fn triangle_with_all_attributes() {
        let m = parse(
            "# comment\nv 0 0 0\nv 1 0 0\nv 0 1 0 1.0\nvt 0 0\nvt 1 0\nvt 0 1 0\nvn 0 0 1\n\
             o thing\ng group\nusemtl m\ns 1\nf 1/1/1 2/2/1 3/3/1\n",
        )
        .unwrap();
        assert_eq!(m.positions, [Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(m.uvs, [Vec2::ZERO, Vec2::X, Vec2::Y]);
        assert_eq!(m.normals, [Vec3::Z; 3]);
        assert_eq!(m.indices, [[0, 1, 2]]);
        m.validate().unwrap();
    }

    #[test]
    fn flips_v_by_default_like_mitsuba() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.75\nf 1/1 2/1 3/1\n";
        let flipped = parse_obj(text, Path::new("m.obj"), true).unwrap();
        assert_eq!(flipped.uvs[0], Vec2::new(0.25, 0.25));
        let kept = parse(text).unwrap();
        assert_eq!(kept.uvs[0], Vec2::new(0.25, 0.75));
    }

    #[test]
    fn polygons_are_fans_and_groups_merge() {
        let m = parse(
            "o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\n\
             o b\nf 1 2 3 4 5\nf 1 2\n",
        )
        .unwrap();
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.indices, [[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        assert!(m.normals.is_empty() && m.uvs.is_empty());
    }

    #[test]
    fn negative_indices_are_relative() {
        let m =
            parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//-1 -2//-1 -1//-1\nv 5 5 5\nf 1//1 2//1 -1//1\n").unwrap();
        assert_eq!(m.indices, [[0, 1, 2], [0, 1, 3]]);
        assert_eq!(m.positions[3], Vec3::splat(5.0));
    }

    #[test]
    fn corners_are_split_where_attributes_differ() {
        // Two triangles share an edge (positions 1 and 3) but not the uvs there.
        let m = parse(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0.5\nvn 0 0 1\n\
             f 1/1/1 2/2/1 3/3/1\nf 2/2/1 4/4/1 3/5/1\n",
        )
        .unwrap();
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.indices, [[0, 1, 2], [1, 3, 4]]);
        assert_eq!(m.positions[4], Vec3::Y);
        assert_eq!(m.uvs[4], Vec2::splat(0.5));
        assert_eq!(m.uvs[2], Vec2::Y);
        m.validate().unwrap();
    }

    #[test]
    fn attributes_missing_on_some_faces_are_dropped() {
        let m = parse(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\nvn 0 0 -1\n\
             f 1/1/1 2/2/1 3/1/2\nf 2//1 4//1 3//2\n",
        )
        .unwrap();
        assert!(m.uvs.is_empty());
        // Normals are on every corner, so they stay.
        assert_eq!(m.normals.len(), m.positions.len());
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, [[0, 1, 2], [1, 3, 2]]);

        let m = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 2 3\n").unwrap();
        assert!(m.normals.is_empty());
        assert_eq!(m.positions.len(), 3);
        assert_eq!(m.indices, [[0, 1, 2], [0, 1, 2]]);
        m.validate().unwrap();
    }

    #[test]
    fn crlf_and_tabs() {
        let m = parse("v\t0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf\t1 2 3\r\n").unwrap();
        assert_eq!(m.indices, [[0, 1, 2]]);
    }

    #[test]
    fn errors_name_file_and_line() {
        let check = |text: &str, line: u32, word: &str| {
            let e = parse(text).unwrap_err();
            let loc = e.loc.clone().unwrap();
            assert_eq!((loc.file.as_path(), loc.line), (Path::new("/virtual/mesh.obj"), line), "{e}");
            assert!(e.to_string().contains("/virtual/mesh.obj:"), "{e}");
            assert!(e.to_string().contains(word), "{e} lacks {word}");
        };
        check("v 0 0 0\nv 1 0 x\n", 2, "vertex");
        check("v 0 0 0\nv 1 0\n", 2, "vertex");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n", 5, "\"4\"");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n", 4, "\"0\"");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", 4, "\"-4\"");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2 3\n", 4, "texture coordinate");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2 3\n", 4, "normal");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/a 2 3\n", 4, "\"a\"");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1/1 2 3\n", 6, "malformed");
        check("v 0 inf 0\n", 1, "finite");
    }

    /// Errors name the column of the offending number or face corner, and
    /// non-finite normals and texture coordinates are refused like positions.
    #[test]
    fn errors_name_the_column_and_refuse_non_finite_numbers() {
        let check = |text: &str, line: u32, col: u32, word: &str| {
            let e = parse(text).unwrap_err();
            let loc = e.loc.clone().unwrap();
            assert_eq!((loc.line, loc.col), (line, col), "{e}");
            assert!(e.to_string().starts_with(&format!("/virtual/mesh.obj:{line}:{col}: ")), "{e}");
            assert!(e.to_string().contains(word), "{e} lacks {word}");
        };
        check("v 0 0 0\nv  1 0 x\n", 2, 8, "\"x\"");
        check("v 0 0 0\n  v 1 0\n", 2, 3, "has 2 numbers");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2  4\n", 4, 8, "\"4\"");
        check("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2 3/x\n", 5, 10, "\"x\"");
        check("v 0 nan 0\n", 1, 5, "not a finite");
        check("v 0 0 1e39\n", 1, 7, "\"1e39\" is not a finite");
        check("vn 0 0 NaN\n", 1, 8, "normal component \"NaN\"");
        check("vt 0.5 -inf\n", 1, 8, "texture coordinate component \"-inf\"");
        check("# caf\u{e9}\nv \u{e9}1 0 0\n", 2, 3, "\"\u{e9}1\"");
    }

    /// A binary file given as OBJ is refused at its first control byte,
    /// with its offset; other encodings in names and comments are read.
    #[test]
    fn binary_data_is_refused_with_its_offset() {
        assert_eq!(check_text(b"v 0 0 0\r\n\tf 1 2 3\x0c\n"), Ok(()));
        assert_eq!(check_text(b"# caf\xe9\nv 0 0 0\n"), Ok(()));
        let (line, col, m) = check_text(b"v 0 0 0\nv 1\x00\x00").unwrap_err();
        assert_eq!((line, col), (2, 4));
        assert!(m.contains("byte 11") && m.contains("0x00") && m.contains("binary"), "{m}");
        let dir = std::env::temp_dir().join(format!("penumbra-obj-binary-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("mesh.obj");
        std::fs::write(&path, b"\x89PNG\r\n\x1a\n\x00\x00").unwrap();
        let e = load_obj(&path).unwrap_err().to_string();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(e.contains("mesh.obj:2:1: not an OBJ text file: byte 6 is the control character 0x1a"), "{e}");
    }

    #[test]
    fn missing_file() {
        let e = load_obj(Path::new("/nonexistent/bunny.obj")).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("/nonexistent/bunny.obj") && s.contains("not found"), "{s}");
    }

    #[test]
    fn loads_from_disk() {
        let dir = std::env::temp_dir().join(format!("penumbra-obj-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("quad.obj");
        std::fs::write(
            &path,
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n",
        )
        .unwrap();
        let m = load_obj(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(m.indices, [[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.uvs[2], Vec2::new(1.0, 0.0));
    }
}
