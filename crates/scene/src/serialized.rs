//! Mitsuba's `.serialized` mesh format (Mitsuba 3.9.1 `src/shapes/serialized.cpp`).
//!
//! Little endian. Each mesh: `u16` 0x041C, `u16` version (3 or 4), then a
//! zlib stream holding `u32` flags, (v4 only) a NUL-terminated name, `u64`
//! vertex and face counts, positions, optional normals, texture
//! coordinates and colours (f32, or f64 with flag 0x2000), and `u32`
//! triangle indices. Meshes are concatenated; the file ends with the byte
//! offset of every mesh (`u64` in v4, `u32` in v3) and a `u32` mesh count.

use crate::error::{LoadError, Result};
use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3};
use penumbra_render::geometry::TriangleMesh;
use std::io::Read;
use std::path::Path;

/// Magic number opening each mesh record.
pub const HEADER: u16 = 0x041C;
/// Flag: per-vertex normals are stored.
pub const HAS_NORMALS: u32 = 0x0001;
/// Flag: per-vertex texture coordinates are stored.
pub const HAS_TEXCOORDS: u32 = 0x0002;
/// Flag: per-vertex colours are stored.
pub const HAS_COLORS: u32 = 0x0008;
/// Flag: face normals (flat shading) are requested.
pub const FACE_NORMALS: u32 = 0x0010;
/// Flag: arrays are `f32`.
pub const SINGLE_PRECISION: u32 = 0x1000;
/// Flag: arrays are `f64`.
pub const DOUBLE_PRECISION: u32 = 0x2000;

/// One mesh as stored (object space). `face_normals` is the file's flag 0x0010.
#[derive(Debug, Clone, Default)]
pub struct SerializedMesh {
    /// The mesh's name in the file.
    pub name: String,
    /// Vertices, normals, UVs and indices in object space.
    pub mesh: TriangleMesh,
    /// Whether flag 0x0010 (flat shading) is set.
    pub face_normals: bool,
}

/// Reads mesh `shape_index` of a `.serialized` file.
pub fn load_serialized(path: &Path, shape_index: usize) -> Result<SerializedMesh> {
    let bytes = std::fs::read(path).map_err(|e| {
        let msg = match e.kind() {
            std::io::ErrorKind::NotFound => "serialized mesh file not found".to_string(),
            _ => format!("cannot read serialized mesh file: {e}"),
        };
        LoadError::in_file(path, msg)
    })?;
    parse_serialized(&bytes, shape_index).map_err(|e| LoadError::in_file(path, e))
}

fn u16_at(b: &[u8], at: usize) -> std::result::Result<u16, String> {
    b.get(at..at.saturating_add(2))
        .map(|s| u16::from_le_bytes([s[0], s[1]]))
        .ok_or_else(|| format!("file truncated: it has {} bytes, a 16-bit value at byte {at} was expected", b.len()))
}
fn u32_at(b: &[u8], at: usize) -> std::result::Result<u32, String> {
    b.get(at..at.saturating_add(4))
        .map(|s| u32::from_le_bytes(s.try_into().unwrap()))
        .ok_or_else(|| format!("file truncated: it has {} bytes, a 32-bit value at byte {at} was expected", b.len()))
}
fn u64_at(b: &[u8], at: usize) -> std::result::Result<u64, String> {
    b.get(at..at.saturating_add(8))
        .map(|s| u64::from_le_bytes(s.try_into().unwrap()))
        .ok_or_else(|| format!("file truncated: it has {} bytes, a 64-bit value at byte {at} was expected", b.len()))
}

/// Number of meshes a file holds, from its end-of-file dictionary.
pub fn mesh_count(b: &[u8]) -> std::result::Result<usize, String> {
    if b.len() < 8 {
        return Err("file too short for a serialized mesh".into());
    }
    Ok(u32_at(b, b.len() - 4)? as usize)
}

/// Parses mesh `shape_index` from the bytes of a `.serialized` file.
/// Errors name the mesh's byte offset in the file and, inside its
/// compressed record, the element and its offset in the uncompressed data
/// (`mesh 0 at byte 0: vertex 12 of 1000 at uncompressed byte 4711: ...`).
/// Counts are not trusted: memory grows with the data actually present.
pub fn parse_serialized(b: &[u8], shape_index: usize) -> std::result::Result<SerializedMesh, String> {
    let format = u16_at(b, 0)?;
    let version = u16_at(b, 2)?;
    if format != HEADER {
        return Err(format!("not a Mitsuba serialized mesh (header 0x{format:04X} at byte 0, expected 0x041C)"));
    }
    if version != 3 && version != 4 {
        return Err(format!("byte 2: serialized format version {version} is not supported (3 and 4 are)"));
    }
    let start = if shape_index == 0 {
        0
    } else {
        let count = mesh_count(b)?;
        if shape_index >= count {
            return Err(match count {
                0 => format!("shape_index {shape_index} is out of range: the file's dictionary lists no mesh"),
                _ => format!("shape_index {shape_index} is out of range: the file holds meshes 0..{}", count - 1),
            });
        }
        // The dictionary: one offset per mesh before the count.
        let entry = if version == 4 { 8 } else { 4 };
        let dict = (count as u64 * entry as u64 + 4) as usize;
        let Some(dict_start) = b.len().checked_sub(dict) else {
            return Err(format!(
                "the dictionary at the end of the file claims {count} meshes ({dict} bytes), but the file has {} bytes",
                b.len()
            ));
        };
        let at = dict_start + entry * shape_index;
        let offset = if version == 4 { u64_at(b, at)? } else { u32_at(b, at)? as u64 };
        let offset = usize::try_from(offset).unwrap_or(usize::MAX);
        let (f, v) = (u16_at(b, offset), u16_at(b, offset.saturating_add(2)));
        if f != Ok(HEADER) || v != Ok(version) {
            return Err(format!(
                "the offset dictionary (byte {at}) points mesh {shape_index} at byte {offset}, where no mesh starts"
            ));
        }
        offset
    };
    parse_record(b, start, version).map_err(|e| format!("mesh {shape_index} at byte {start}: {e}"))
}

/// The mesh whose record starts at byte `start`.
fn parse_record(b: &[u8], start: usize, version: u16) -> std::result::Result<SerializedMesh, String> {
    let data = b.get(start + 4..).ok_or("file truncated")?;
    let mut z = ZlibDecoder::new(data);
    let mut r = Reader { z: &mut z, at: 0 };
    let flags = r.u32("the flags")?;
    let mut name = String::new();
    if version == 4 {
        let mut raw = Vec::new();
        loop {
            match r.bytes(1, "the mesh name")?[0] {
                0 => break,
                c => raw.push(c),
            }
        }
        name = String::from_utf8_lossy(&raw).into_owned();
    }
    let nv = r.u64("the vertex count")?;
    let nf = r.u64("the face count")?;
    if nv > u32::MAX as u64 || nf > (u32::MAX / 3) as u64 {
        return Err(format!(
            "mesh too large: the header claims {nv} vertices and {nf} faces; a mesh holds at most {} vertices \
             and {} faces (32-bit indices)",
            u32::MAX,
            u32::MAX / 3
        ));
    }
    let (nv, nf) = (nv as usize, nf as usize);
    let double = flags & DOUBLE_PRECISION != 0;
    let size = if double { 8 } else { 4 };
    // `dim` floats per vertex; every value must be finite.
    let floats = |r: &mut Reader, dim: usize, what: &str| -> std::result::Result<Vec<f32>, String> {
        let base = r.at;
        let raw = r.bytes(size * dim * nv, &format!("{nv} vertex {what}"))?;
        let values: Vec<f32> = if double {
            raw.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap()) as f32).collect()
        } else {
            raw.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
        };
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "vertex {} of {nv} at uncompressed byte {}: its {what} holds {}, which is not a finite \
                 single-precision number",
                k / dim,
                base + k * size,
                if double { f64::from_le_bytes(raw[8 * k..8 * k + 8].try_into().unwrap()) } else { values[k] as f64 }
            ));
        }
        Ok(values)
    };
    let v3 = |v: Vec<f32>| v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect::<Vec<_>>();
    let positions = v3(floats(&mut r, 3, "position")?);
    let normals = if flags & HAS_NORMALS != 0 { v3(floats(&mut r, 3, "normal")?) } else { Vec::new() };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        floats(&mut r, 2, "texture coordinates")?.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect()
    } else {
        Vec::new()
    };
    if flags & HAS_COLORS != 0 {
        // Vertex colours are skipped, as Mitsuba 3.9.1 does.
        r.bytes(size * 3 * nv, &format!("{nv} vertex colours"))?;
    }
    let base = r.at;
    let indices: Vec<[u32; 3]> = r
        .bytes(12 * nf, &format!("{nf} faces"))?
        .chunks_exact(12)
        .map(|c| {
            let i = |k: usize| u32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap());
            [i(0), i(1), i(2)]
        })
        .collect();
    if let Some((f, t)) = indices.iter().enumerate().find(|(_, t)| t.iter().any(|&v| v as usize >= nv)) {
        return Err(format!(
            "face {f} of {nf} at uncompressed byte {}: it refers to vertices {t:?}, but there are {nv} vertices",
            base + 12 * f
        ));
    }
    let mesh = TriangleMesh { positions, normals, uvs, indices };
    mesh.validate()?;
    Ok(SerializedMesh { name, mesh, face_normals: flags & FACE_NORMALS != 0 })
}

/// Reads the uncompressed data of a record, counting its offset.
struct Reader<'a, 'b> {
    z: &'a mut ZlibDecoder<&'b [u8]>,
    /// Bytes read so far.
    at: usize,
}

impl Reader<'_, '_> {
    /// `n` bytes holding `what`. The buffer grows with the data read, so a
    /// count the data does not back allocates nothing near its claim.
    fn bytes(&mut self, n: usize, what: &str) -> std::result::Result<Vec<u8>, String> {
        let mut v = Vec::with_capacity(n.min(1 << 20));
        let got = (&mut *self.z).take(n as u64).read_to_end(&mut v);
        let start = self.at;
        self.at += v.len();
        match got {
            Ok(_) if v.len() == n => Ok(v),
            Ok(_) => Err(format!(
                "{what}: {n} bytes from uncompressed byte {start} were expected, the data ends after {}",
                v.len()
            )),
            Err(e) => Err(format!("{what}: the compressed data is corrupt at uncompressed byte {} ({e})", self.at)),
        }
    }
    fn u32(&mut self, what: &str) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(self.bytes(4, what)?.try_into().unwrap()))
    }
    fn u64(&mut self, what: &str) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(self.bytes(8, what)?.try_into().unwrap()))
    }
}

/// Options for [`write_serialized`] (used to make test files).
#[derive(Debug, Clone, Copy)]
pub struct WriteOptions {
    /// Format version written (3 or 4).
    pub version: u16,
    /// Store arrays as `f64` rather than `f32`.
    pub double: bool,
    /// Adds a (skipped) per-vertex colour array.
    pub colors: bool,
    /// Sets the face-normals flag 0x0010.
    pub face_normals: bool,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions { version: 4, double: false, colors: false, face_normals: false }
    }
}

/// Writes meshes in the `.serialized` format (the inverse of [`parse_serialized`]).
pub fn write_serialized(meshes: &[(&str, &TriangleMesh)], opt: WriteOptions) -> Vec<u8> {
    use flate2::write::ZlibEncoder;
    use std::io::Write;
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for (name, m) in meshes {
        offsets.push(out.len() as u64);
        out.extend_from_slice(&HEADER.to_le_bytes());
        out.extend_from_slice(&opt.version.to_le_bytes());
        let mut raw = Vec::new();
        let mut flags = if opt.double { DOUBLE_PRECISION } else { SINGLE_PRECISION };
        if !m.normals.is_empty() {
            flags |= HAS_NORMALS;
        }
        if !m.uvs.is_empty() {
            flags |= HAS_TEXCOORDS;
        }
        if opt.colors {
            flags |= HAS_COLORS;
        }
        if opt.face_normals {
            flags |= FACE_NORMALS;
        }
        raw.extend_from_slice(&flags.to_le_bytes());
        if opt.version == 4 {
            raw.extend_from_slice(name.as_bytes());
            raw.push(0);
        }
        raw.extend_from_slice(&(m.positions.len() as u64).to_le_bytes());
        raw.extend_from_slice(&(m.indices.len() as u64).to_le_bytes());
        let put = |raw: &mut Vec<u8>, vals: &mut dyn Iterator<Item = f32>| {
            for x in vals {
                if opt.double {
                    raw.extend_from_slice(&(x as f64).to_le_bytes());
                } else {
                    raw.extend_from_slice(&x.to_le_bytes());
                }
            }
        };
        put(&mut raw, &mut m.positions.iter().flat_map(|p| p.to_array()));
        put(&mut raw, &mut m.normals.iter().flat_map(|p| p.to_array()));
        put(&mut raw, &mut m.uvs.iter().flat_map(|p| p.to_array()));
        if opt.colors {
            put(&mut raw, &mut m.positions.iter().flat_map(|_| [0.25f32, 0.5, 0.75]));
        }
        for t in &m.indices {
            for i in t {
                raw.extend_from_slice(&i.to_le_bytes());
            }
        }
        let mut enc = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(&raw).unwrap();
        out.extend_from_slice(&enc.finish().unwrap());
    }
    for o in &offsets {
        if opt.version == 4 {
            out.extend_from_slice(&o.to_le_bytes());
        } else {
            out.extend_from_slice(&(*o as u32).to_le_bytes());
        }
    }
    out.extend_from_slice(&(meshes.len() as u32).to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(z: f32, normals: bool, uvs: bool) -> TriangleMesh {
        TriangleMesh {
            positions: vec![
                Vec3::new(0.0, 0.0, z),
                Vec3::new(1.0, 0.0, z),
                Vec3::new(0.0, 1.0, z),
                Vec3::new(1.0, 1.0, z),
            ],
            normals: if normals { vec![Vec3::Z; 4] } else { Vec::new() },
            uvs: if uvs { vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE] } else { Vec::new() },
            indices: vec![[0, 1, 2], [1, 3, 2]],
        }
    }

    #[test]
    fn round_trips_every_version_precision_and_index() {
        let (a, b, c) = (tri(0.0, true, true), tri(1.5, false, true), tri(-2.0, true, false));
        for version in [3, 4] {
            for double in [false, true] {
                for colors in [false, true] {
                    let opt = WriteOptions { version, double, colors, face_normals: false };
                    let bytes = write_serialized(&[("a", &a), ("b", &b), ("c", &c)], opt);
                    assert_eq!(mesh_count(&bytes).unwrap(), 3);
                    for (i, m) in [&a, &b, &c].iter().enumerate() {
                        let r = parse_serialized(&bytes, i).unwrap();
                        assert_eq!(r.mesh.positions, m.positions, "v{version} double {double} mesh {i}");
                        assert_eq!(r.mesh.normals, m.normals);
                        assert_eq!(r.mesh.uvs, m.uvs);
                        assert_eq!(r.mesh.indices, m.indices);
                        if version == 4 {
                            assert_eq!(r.name, ["a", "b", "c"][i]);
                        }
                    }
                    let e = parse_serialized(&bytes, 3).unwrap_err();
                    assert!(e.contains("out of range"), "{e}");
                }
            }
        }
    }

    #[test]
    fn bad_files_are_errors() {
        let a = tri(0.0, true, true);
        let mut bytes = write_serialized(&[("a", &a)], WriteOptions::default());
        assert!(parse_serialized(&bytes[..bytes.len() / 2], 0).is_err());
        bytes[2] = 5;
        assert!(parse_serialized(&bytes, 0).unwrap_err().contains("version 5"));
        bytes[0] = 0;
        assert!(parse_serialized(&bytes, 0).unwrap_err().contains("header"));
        let mut bad = tri(0.0, false, false);
        bad.indices[0][1] = 9;
        let bytes = write_serialized(&[("a", &bad)], WriteOptions::default());
        assert!(parse_serialized(&bytes, 0).unwrap_err().contains("face 0"));
        let bytes = write_serialized(&[("a", &a)], WriteOptions { face_normals: true, ..Default::default() });
        assert!(parse_serialized(&bytes, 0).unwrap().face_normals);
    }

    /// A version-4 record holding `raw` (flags onwards) compressed, with a
    /// dictionary claiming `count` meshes.
    fn record(raw: &[u8], count: u32) -> Vec<u8> {
        use flate2::write::ZlibEncoder;
        use std::io::Write;
        let mut out = vec![0x1C, 0x04, 4, 0];
        let mut enc = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(raw).unwrap();
        out.extend_from_slice(&enc.finish().unwrap());
        out.extend_from_slice(&0u64.to_le_bytes());
        out.extend_from_slice(&count.to_le_bytes());
        out
    }

    /// Flags, the name "m", and the counts.
    fn head(nv: u64, nf: u64) -> Vec<u8> {
        [&SINGLE_PRECISION.to_le_bytes()[..], b"m\0", &nv.to_le_bytes(), &nf.to_le_bytes()].concat()
    }

    /// Counts of billions are refused or read as far as the data goes,
    /// without allocating what they claim; errors name mesh, element and
    /// offset.
    #[test]
    fn hostile_counts_and_values_name_their_position() {
        // 4 billion vertices claimed, 2 present: an error once the data ends.
        let mut raw = head(u32::MAX as u64, 1);
        raw.extend(std::iter::repeat_n(0u8, 24));
        let e = parse_serialized(&record(&raw, 1), 0).unwrap_err();
        assert!(
            e.contains("mesh 0 at byte 0: 4294967295 vertex position: 51539607540 bytes from uncompressed byte 22")
                && e.contains("ends after 24"),
            "{e}"
        );
        let e = parse_serialized(&record(&head(1 << 40, 0), 1), 0).unwrap_err();
        assert!(e.contains("1099511627776 vertices") && e.contains("at most 4294967295"), "{e}");
        // A NaN position: the vertex and its offset (the data starts at byte 22).
        let mut raw = head(3, 1);
        for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, f32::NAN, 0.0] {
            raw.extend_from_slice(&v.to_le_bytes());
        }
        for i in [0u32, 1, 2] {
            raw.extend_from_slice(&i.to_le_bytes());
        }
        let e = parse_serialized(&record(&raw, 1), 0).unwrap_err();
        assert!(e.contains("vertex 2 of 3 at uncompressed byte 50: its position holds NaN"), "{e}");
        // A face out of range: its number and offset.
        let n = raw.len();
        raw[n - 4..].copy_from_slice(&7u32.to_le_bytes());
        raw[22 + 28..22 + 32].copy_from_slice(&0f32.to_le_bytes());
        let e = parse_serialized(&record(&raw, 1), 0).unwrap_err();
        assert!(e.contains("face 0 of 1 at uncompressed byte 58: it refers to vertices [0, 1, 7]"), "{e}");
        raw[n - 4..].copy_from_slice(&2u32.to_le_bytes());
        parse_serialized(&record(&raw, 1), 0).unwrap();
        // Dictionaries claiming no mesh, or more than the file can hold.
        let e = parse_serialized(&record(&raw, 0), 1).unwrap_err();
        assert!(e.contains("lists no mesh"), "{e}");
        let e = parse_serialized(&record(&raw, 1_000_000_000), 1).unwrap_err();
        assert!(e.contains("claims 1000000000 meshes"), "{e}");
        let mut bad_offset = record(&raw, 2);
        let len = bad_offset.len();
        bad_offset[len - 12..len - 4].copy_from_slice(&u64::MAX.to_le_bytes());
        let e = parse_serialized(&bad_offset, 1).unwrap_err();
        assert!(e.contains("where no mesh starts"), "{e}");
    }
}
