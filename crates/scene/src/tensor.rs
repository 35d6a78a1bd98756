//! Mitsuba's tensor file format (`TensorFile`, written by
//! `mitsuba.tensor_io.write`), used by the `measured` BSDF's RGL `.bsdf`
//! files. Little-endian throughout:
//!
//! - 12 bytes `tensor_file\0`, a version of two bytes (written as 1, 0;
//!   like Mitsuba 3.9.1, only a nonzero second byte is refused), the field
//!   count (u32);
//! - per field: the name length (u16) and the name's bytes, the number of
//!   dimensions (u16), the element type (u8: 1 u8, 2 i8, 3 u16, 4 i16,
//!   5 u32, 6 i32, 7 u64, 8 i64, 9 f16, 10 f32, 11 f64), the absolute byte
//!   offset of the data (u64), then one u64 size per dimension;
//! - the data of each field, C order (last index fastest).
//!
//! Unlike Mitsuba, which maps the file and trusts it, every read here is
//! checked: a truncated or malformed file is refused with the byte offset
//! of the problem, and a field whose data would not fit in the file is
//! refused before anything is allocated for it. As in Mitsuba, a later
//! field of the same name replaces an earlier one.
//!
//! Done: reading the header and field table, typed access to `u8` and
//! `f32` data. Remains: access to the other element types (no user of
//! them yet; `f16`/`f64` would be needed for tensors other plugins read).

use std::path::Path;

/// An element type of a tensor field (Mitsuba's `Struct` type codes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dtype {
    /// Unsigned 8-bit integer (code 1).
    U8,
    /// Signed 8-bit integer (code 2).
    I8,
    /// Unsigned 16-bit integer (code 3).
    U16,
    /// Signed 16-bit integer (code 4).
    I16,
    /// Unsigned 32-bit integer (code 5).
    U32,
    /// Signed 32-bit integer (code 6).
    I32,
    /// Unsigned 64-bit integer (code 7).
    U64,
    /// Signed 64-bit integer (code 8).
    I64,
    /// Half-precision float (code 9).
    F16,
    /// Single-precision float (code 10).
    F32,
    /// Double-precision float (code 11).
    F64,
}

impl Dtype {
    fn from_code(code: u8) -> Option<Dtype> {
        use Dtype::*;
        Some(match code {
            1 => U8,
            2 => I8,
            3 => U16,
            4 => I16,
            5 => U32,
            6 => I32,
            7 => U64,
            8 => I64,
            9 => F16,
            10 => F32,
            11 => F64,
            _ => return None,
        })
    }

    /// Bytes per element.
    pub fn size(self) -> u64 {
        use Dtype::*;
        match self {
            U8 | I8 => 1,
            U16 | I16 | F16 => 2,
            U32 | I32 | F32 => 4,
            U64 | I64 | F64 => 8,
        }
    }

    /// The name Mitsuba's documentation uses for the type.
    pub fn name(self) -> &'static str {
        use Dtype::*;
        match self {
            U8 => "uint8",
            I8 => "int8",
            U16 => "uint16",
            I16 => "int16",
            U32 => "uint32",
            I32 => "int32",
            U64 => "uint64",
            I64 => "int64",
            F16 => "float16",
            F32 => "float32",
            F64 => "float64",
        }
    }
}

/// One field of a tensor file: its element type, shape and where its data
/// lies in the file (checked to lie inside it).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    /// The field's name.
    pub name: String,
    /// The element type.
    pub dtype: Dtype,
    /// Absolute byte offset of the data.
    pub offset: u64,
    /// The sizes, slowest-varying first.
    pub shape: Vec<u64>,
}

impl Field {
    /// Number of elements (the product of the shape; 1 for no dimensions).
    pub fn len(&self) -> u64 {
        self.shape.iter().product()
    }

    /// Whether the field has no elements.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A parsed tensor file: the field table and the file's bytes.
#[derive(Debug)]
pub struct TensorFile {
    bytes: Vec<u8>,
    fields: Vec<Field>,
}

/// The smallest file Mitsuba accepts: magic, version and field count.
const HEADER: usize = 12 + 2 + 4;
/// The fixed part of a field entry: name length, ndim, dtype, offset.
const FIELD_FIXED: u64 = 2 + 2 + 1 + 8;

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: u64, what: &str) -> Result<&[u8], String> {
        let left = (self.bytes.len() - self.pos) as u64;
        if n > left {
            return Err(format!(
                "byte {}: the file ends while reading {what} ({n} bytes needed, {left} left; truncated?)",
                self.pos
            ));
        }
        let s = &self.bytes[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(s)
    }
    fn u8(&mut self, what: &str) -> Result<u8, String> {
        Ok(self.take(1, what)?[0])
    }
    fn u16(&mut self, what: &str) -> Result<u16, String> {
        Ok(u16::from_le_bytes(self.take(2, what)?.try_into().expect("2 bytes")))
    }
    fn u32(&mut self, what: &str) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }
    fn u64(&mut self, what: &str) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }
}

impl TensorFile {
    /// Reads and parses a tensor file; errors name the file.
    pub fn open(path: &Path) -> Result<TensorFile, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("cannot read tensor file {}: {e}", path.display()))?;
        TensorFile::parse(bytes).map_err(|e| format!("tensor file {}: {e}", path.display()))
    }

    /// Parses the bytes of a tensor file; errors name the byte offset and
    /// what was wrong there.
    pub fn parse(bytes: Vec<u8>) -> Result<TensorFile, String> {
        if bytes.len() < HEADER {
            return Err(format!(
                "the file has {} bytes, fewer than the {HEADER}-byte header of a tensor file (truncated?)",
                bytes.len()
            ));
        }
        if &bytes[..12] != b"tensor_file\0" {
            return Err("byte 0: not a tensor file (it does not start with 'tensor_file' and a zero byte)".into());
        }
        if bytes[13] != 0 {
            return Err(format!("byte 12: unknown tensor file version {}.{}", bytes[12], bytes[13]));
        }
        let mut r = Reader { bytes: &bytes, pos: 14 };
        let count = r.u32("the field count")?;
        let left = (bytes.len() - r.pos) as u64;
        if count as u64 * FIELD_FIXED > left {
            return Err(format!(
                "byte 14: {count} fields cannot fit in the {left} bytes that follow (each takes at least {FIELD_FIXED}; truncated?)"
            ));
        }
        let mut fields: Vec<Field> = Vec::with_capacity(count as usize);
        for i in 0..count {
            let at = r.pos;
            let name_len = r.u16(&format!("the name length of field {i}"))?;
            let name_at = r.pos;
            let name = std::str::from_utf8(r.take(name_len as u64, &format!("the name of field {i}"))?)
                .map_err(|_| format!("byte {name_at}: the name of field {i} is not UTF-8"))?
                .to_string();
            let ndim = r.u16(&format!("the dimension count of field '{name}'"))?;
            let dtype_at = r.pos;
            let code = r.u8(&format!("the element type of field '{name}'"))?;
            let dtype = Dtype::from_code(code)
                .ok_or_else(|| format!("byte {dtype_at}: field '{name}' has unknown element type {code}"))?;
            let offset = r.u64(&format!("the data offset of field '{name}'"))?;
            // Checked before the shape is allocated: `take` refuses sizes
            // beyond the file.
            let shape_bytes = r.take(8 * ndim as u64, &format!("the shape of field '{name}'"))?;
            let shape: Vec<u64> =
                shape_bytes.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes"))).collect();
            let size = shape
                .iter()
                .try_fold(dtype.size(), |acc, &s| acc.checked_mul(s))
                .filter(|&n| offset.checked_add(n).is_some_and(|end| end <= bytes.len() as u64));
            if size.is_none() {
                let dims: Vec<String> = shape.iter().map(|s| s.to_string()).collect();
                return Err(format!(
                    "byte {at}: field '{name}' ({} of shape [{}] at byte {offset}) does not fit in the file's {} bytes (truncated?)",
                    dtype.name(),
                    dims.join(", "),
                    bytes.len()
                ));
            }
            let field = Field { name, dtype, offset, shape };
            match fields.iter_mut().find(|f| f.name == field.name) {
                Some(old) => *old = field,
                None => fields.push(field),
            }
        }
        Ok(TensorFile { bytes, fields })
    }

    /// The fields, in file order.
    pub fn fields(&self) -> &[Field] {
        &self.fields
    }

    /// The field of this name, if any.
    pub fn field(&self, name: &str) -> Option<&Field> {
        self.fields.iter().find(|f| f.name == name)
    }

    fn raw(&self, field: &Field, want: Dtype) -> Result<&[u8], String> {
        if field.dtype != want {
            return Err(format!("field '{}' holds {} values, not {}", field.name, field.dtype.name(), want.name()));
        }
        // In range: checked by `parse`.
        let start = field.offset as usize;
        Ok(&self.bytes[start..start + (field.len() * want.size()) as usize])
    }

    /// The data of a `uint8` field.
    pub fn u8_data(&self, field: &Field) -> Result<&[u8], String> {
        self.raw(field, Dtype::U8)
    }

    /// The data of a `float32` field, C order.
    pub fn f32_data(&self, field: &Field) -> Result<Vec<f32>, String> {
        Ok(self
            .raw(field, Dtype::F32)?
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
            .collect())
    }
}

/// The tables of an RGB `.bsdf` file for the `measured` BSDF, with the
/// element types and dimension counts Mitsuba 3.9.1 requires (the shapes
/// are checked by `Measured::new`). Spectral files (a `wavelengths` field)
/// are refused, as Mitsuba's RGB variants refuse them.
pub fn measured_tables(t: &TensorFile) -> Result<penumbra_render::bsdf::measured::MeasuredTables, String> {
    if t.field("wavelengths").is_some() {
        return Err("the file holds spectral measurements ('wavelengths'); Mitsuba renders them only in spectral variants, Penumbra not at all".into());
    }
    let get = |name: &str| t.field(name).ok_or_else(|| format!("the file has no field '{name}'"));
    let f32s = |name: &str, ndim: usize| -> Result<(Vec<f32>, Vec<usize>), String> {
        let f = get(name)?;
        if f.shape.len() != ndim {
            return Err(format!("field '{name}' has {} dimensions, not {ndim}", f.shape.len()));
        }
        // Sizes fit in the file (checked by `parse`), hence in usize.
        Ok((t.f32_data(f)?, f.shape.iter().map(|&s| s as usize).collect()))
    };
    let desc = get("description")?;
    if desc.shape.len() != 1 {
        return Err("field 'description' must have one dimension".into());
    }
    t.u8_data(desc)?;
    let jac = get("jacobian")?;
    let jacobian = t.u8_data(jac)?;
    if jac.shape != [1] {
        return Err("field 'jacobian' must hold one value".into());
    }
    Ok(penumbra_render::bsdf::measured::MeasuredTables {
        theta_i: f32s("theta_i", 1)?.0,
        phi_i: f32s("phi_i", 1)?.0,
        ndf: f32s("ndf", 2)?,
        sigma: f32s("sigma", 2)?,
        vndf: f32s("vndf", 4)?,
        luminance: f32s("luminance", 4)?,
        rgb: f32s("rgb", 5)?,
        jacobian: jacobian[0] != 0,
    })
}

/// Writes a tensor file's bytes as `mitsuba.tensor_io.write` does (data
/// aligned to 8 bytes, in the order given); for tests and tools.
pub fn write(fields: &[(&str, Dtype, &[u64], &[u8])]) -> Vec<u8> {
    let code = |d: Dtype| (1..=11u8).find(|&c| Dtype::from_code(c) == Some(d)).expect("every type has a code");
    let mut out = b"tensor_file\0".to_vec();
    out.extend_from_slice(&[1, 0]);
    out.extend_from_slice(&(fields.len() as u32).to_le_bytes());
    let mut offset_at = Vec::new();
    for (name, dtype, shape, _) in fields {
        out.extend_from_slice(&(name.len() as u16).to_le_bytes());
        out.extend_from_slice(name.as_bytes());
        out.extend_from_slice(&(shape.len() as u16).to_le_bytes());
        out.push(code(*dtype));
        offset_at.push(out.len());
        out.extend_from_slice(&0u64.to_le_bytes());
        for s in *shape {
            out.extend_from_slice(&s.to_le_bytes());
        }
    }
    for ((_, _, _, data), at) in fields.iter().zip(offset_at) {
        out.resize(out.len().div_ceil(8) * 8, 0);
        let pos = out.len() as u64;
        out[at..at + 8].copy_from_slice(&pos.to_le_bytes());
        out.extend_from_slice(data);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<u8> {
        let vals: Vec<u8> = [0.5f32, -1.0, 2.0, 3.25, 4.0, 1e-3].iter().flat_map(|v| v.to_le_bytes()).collect();
        write(&[
            ("description", Dtype::U8, &[5], b"hello"),
            ("values", Dtype::F32, &[2, 3], &vals),
            ("flag", Dtype::U8, &[1], &[1]),
        ])
    }

    #[test]
    fn reads_fields_written_like_mitsuba() {
        let t = TensorFile::parse(sample()).unwrap();
        assert_eq!(t.fields().len(), 3);
        let v = t.field("values").unwrap();
        assert_eq!(v.shape, vec![2, 3]);
        assert_eq!(v.offset % 8, 0);
        assert_eq!(t.f32_data(v).unwrap(), vec![0.5, -1.0, 2.0, 3.25, 4.0, 1e-3]);
        assert_eq!(t.u8_data(t.field("description").unwrap()).unwrap(), b"hello");
        assert!(t.f32_data(t.field("flag").unwrap()).unwrap_err().contains("uint8"));
        assert!(t.field("missing").is_none());
    }

    #[test]
    fn every_truncation_is_refused() {
        let bytes = sample();
        for n in 0..bytes.len() {
            let err = TensorFile::parse(bytes[..n].to_vec()).unwrap_err();
            assert!(err.contains("truncated"), "{n} bytes: {err}");
        }
    }

    #[test]
    fn malformed_headers_are_refused_with_offsets() {
        let mut b = sample();
        b[3] = b'x';
        assert!(TensorFile::parse(b).unwrap_err().starts_with("byte 0:"));
        let mut b = sample();
        b[13] = 1;
        assert!(TensorFile::parse(b).unwrap_err().starts_with("byte 12:"));
        let mut b = sample();
        b[14..18].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(TensorFile::parse(b).unwrap_err().starts_with("byte 14:"));
        // Element type of the first field: after 4 + 11 + 2 bytes.
        let mut b = sample();
        let at = 18 + 2 + 11 + 2;
        b[at] = 12;
        assert_eq!(
            TensorFile::parse(b).unwrap_err(),
            format!("byte {at}: field 'description' has unknown element type 12")
        );
    }

    #[test]
    fn huge_or_misplaced_shapes_are_refused_before_allocating() {
        let huge = write(&[("x", Dtype::F64, &[u64::MAX / 2, 4], &[])]);
        assert!(TensorFile::parse(huge).unwrap_err().contains("does not fit"));
        let mut b = sample();
        // The offset of 'description' (after name length, name, ndim, type).
        let at = 18 + 2 + 11 + 2 + 1;
        b[at..at + 8].copy_from_slice(&(u64::MAX - 2).to_le_bytes());
        assert!(TensorFile::parse(b).unwrap_err().contains("does not fit"));
        let many_dims = write(&[("x", Dtype::U8, &[1; 3], &[0])]);
        let mut b = many_dims.clone();
        b[18 + 2 + 1..18 + 2 + 1 + 2].copy_from_slice(&u16::MAX.to_le_bytes());
        assert!(TensorFile::parse(b).unwrap_err().contains("shape of field 'x'"));
    }

    #[test]
    fn a_repeated_name_replaces_the_earlier_field() {
        let t = TensorFile::parse(write(&[("a", Dtype::U8, &[1], &[1]), ("a", Dtype::U8, &[2], &[7, 8])])).unwrap();
        assert_eq!(t.fields().len(), 1);
        assert_eq!(t.u8_data(t.field("a").unwrap()).unwrap(), &[7, 8]);
    }
}
