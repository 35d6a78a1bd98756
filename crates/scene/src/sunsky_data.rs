//! The Hosek–Wilkie tables of Mitsuba's `sunsky` and `timed_sunsky`
//! (`sunsky_datasets.bin`, `sampling_data.bin`). They are third-party data
//! and not part of Penumbra: they are read at run time from the directory
//! named by `PENUMBRA_SUNSKY_DATA`, or else from an installed Mitsuba Python
//! package (`mitsuba/data/sunsky` under the `sys.path` entries of `python3`,
//! and of `$VIRTUAL_ENV`'s).
//!
//! File format (Mitsuba's `TensorFile`, little-endian): the 12 bytes
//! `tensor_file\0`, a version (2 bytes), the field count (u32), then per
//! field its name length (u16), name, dimension count (u16), type (u8: 10 =
//! float32, 11 = float64), data offset (u64) and shape (u64 each).

use crate::spectrum::cie1931_xyz;
use penumbra_render::light::sunsky::{SunskyTables, WAVELENGTHS};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The environment variable naming the tables' directory.
pub const ENV_VAR: &str = "PENUMBRA_SUNSKY_DATA";

/// A tensor read from a file: its shape and values as f32 (Mitsuba casts
/// the float64 tables to its float type).
#[derive(Debug)]
pub struct Field {
    /// Name in the file.
    pub name: String,
    /// Dimensions.
    pub shape: Vec<usize>,
    /// Row-major values.
    pub data: Vec<f32>,
}

/// Parses a `TensorFile`; errors name the byte offset and what was wrong.
pub fn parse_tensor_file(bytes: &[u8]) -> Result<Vec<Field>, String> {
    let take = |at: usize, n: usize, what: &str| -> Result<&[u8], String> {
        bytes.get(at..at.checked_add(n).ok_or("size overflow")?).ok_or_else(|| {
            format!("byte {at}: the file ends ({} bytes) inside {what} ({n} bytes); truncated?", bytes.len())
        })
    };
    if take(0, 12, "the header")? != b"tensor_file\0" {
        return Err("byte 0: not a tensor file (it does not start with 'tensor_file')".into());
    }
    let n_fields = u32::from_le_bytes(take(14, 4, "the field count")?.try_into().expect("4 bytes"));
    let mut at = 18;
    let mut fields = Vec::new();
    for _ in 0..n_fields {
        let name_len = u16::from_le_bytes(take(at, 2, "a field's name length")?.try_into().expect("2")) as usize;
        let name = String::from_utf8_lossy(take(at + 2, name_len, "a field's name")?).into_owned();
        at += 2 + name_len;
        let ndim = u16::from_le_bytes(take(at, 2, "a field's rank")?.try_into().expect("2")) as usize;
        let dtype = take(at + 2, 1, "a field's type")?[0];
        let offset = u64::from_le_bytes(take(at + 3, 8, "a field's offset")?.try_into().expect("8"));
        at += 11;
        let mut shape = Vec::with_capacity(ndim);
        for _ in 0..ndim {
            shape.push(u64::from_le_bytes(take(at, 8, "a field's shape")?.try_into().expect("8")) as usize);
            at += 8;
        }
        let count = shape.iter().try_fold(1usize, |a, &d| a.checked_mul(d)).ok_or("shape overflow")?;
        let size = match dtype {
            10 => 4,
            11 => 8,
            t => return Err(format!("field '{name}': type {t} is not float32 (10) or float64 (11)")),
        };
        let offset = usize::try_from(offset).map_err(|_| format!("field '{name}': offset {offset} too large"))?;
        let raw = take(offset, count.checked_mul(size).ok_or("size overflow")?, &format!("field '{name}''s data"))?;
        let data = if size == 4 {
            raw.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4"))).collect()
        } else {
            raw.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8")) as f32).collect()
        };
        fields.push(Field { name, shape, data });
    }
    Ok(fields)
}

/// Directories that may hold the tables, in the order tried.
pub fn candidate_dirs() -> Vec<PathBuf> {
    if let Some(dir) = std::env::var_os(ENV_VAR) {
        return vec![PathBuf::from(dir)];
    }
    static FOUND: OnceLock<Vec<PathBuf>> = OnceLock::new();
    FOUND
        .get_or_init(|| {
            let mut pythons = vec![PathBuf::from("python3")];
            if let Some(venv) = std::env::var_os("VIRTUAL_ENV") {
                pythons.insert(0, Path::new(&venv).join("bin").join("python3"));
            }
            let mut dirs = Vec::new();
            for py in pythons {
                let Ok(out) = std::process::Command::new(&py)
                    .args(["-c", "import sys; print('\\n'.join(sys.path))"])
                    .stderr(std::process::Stdio::null())
                    .output()
                else {
                    continue;
                };
                for line in String::from_utf8_lossy(&out.stdout).lines().filter(|l| !l.is_empty()) {
                    let d = Path::new(line).join("mitsuba").join("data").join("sunsky");
                    if !dirs.contains(&d) {
                        dirs.push(d);
                    }
                }
            }
            dirs
        })
        .clone()
}

/// Reads the tables from the first candidate directory that has both
/// files. The error says which directories were tried, or which file is
/// bad, and how to provide the data.
pub fn load() -> Result<SunskyTables, String> {
    let dirs = candidate_dirs();
    let help = format!(
        "the Hosek-Wilkie tables (sunsky_datasets.bin, sampling_data.bin) come with Mitsuba 3: \
         `pip install mitsuba==3.9.1`, or set {ENV_VAR} to a directory holding them"
    );
    let Some(dir) =
        dirs.iter().find(|d| d.join("sunsky_datasets.bin").is_file() && d.join("sampling_data.bin").is_file())
    else {
        let tried: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
        let tried = if tried.is_empty() { "none (no python3 found)".to_string() } else { tried.join(", ") };
        return Err(format!("no sunsky data found (tried: {tried}); {help}"));
    };
    let mut files = Vec::new();
    for name in ["sunsky_datasets.bin", "sampling_data.bin"] {
        let path = dir.join(name);
        let bytes = std::fs::read(&path).map_err(|e| format!("'{}': {e}; {help}", path.display()))?;
        let fields = parse_tensor_file(&bytes).map_err(|e| format!("'{}': {e}; {help}", path.display()))?;
        files.push((name, path, fields));
    }
    let mut get = |file: &str, field: &str, shape: &[usize]| -> Result<Vec<f32>, String> {
        let (_, path, fields) = files.iter_mut().find(|(n, _, _)| *n == file).expect("both files read");
        let f = fields
            .iter_mut()
            .find(|f| f.name == field)
            .ok_or_else(|| format!("'{}': no field '{field}'; {help}", path.display()))?;
        if f.shape != shape {
            return Err(format!(
                "'{}': field '{field}' has shape {:?}, expected {shape:?}; {help}",
                path.display(),
                f.shape
            ));
        }
        Ok(std::mem::take(&mut f.data))
    };
    let [sky_params, sky_rad, sun_rad, sun_irradiance, sky_irradiance, sampling_weights] =
        SunskyTables::FIELDS.map(|(file, field, shape)| get(file, field, shape));
    let cie_xyz = WAVELENGTHS.map(|w| cie1931_xyz(w as f64).map(|v| v as f32));
    Ok(SunskyTables {
        sky_params: sky_params?,
        sky_rad: sky_rad?,
        sun_rad: sun_rad?,
        sun_irradiance: sun_irradiance?,
        sky_irradiance: sky_irradiance?,
        sampling_weights: sampling_weights?,
        cie_xyz,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(fields: &[(&str, u8, &[u64], &[u8])]) -> Vec<u8> {
        let mut head = b"tensor_file\0\x01\x00".to_vec();
        head.extend((fields.len() as u32).to_le_bytes());
        let header_len: usize =
            head.len() + fields.iter().map(|(n, _, s, _)| 2 + n.len() + 11 + 8 * s.len()).sum::<usize>();
        let mut data: Vec<u8> = Vec::new();
        for (name, dtype, shape, bytes) in fields {
            head.extend((name.len() as u16).to_le_bytes());
            head.extend(name.as_bytes());
            head.extend((shape.len() as u16).to_le_bytes());
            head.push(*dtype);
            head.extend(((header_len + data.len()) as u64).to_le_bytes());
            for d in *shape {
                head.extend(d.to_le_bytes());
            }
            data.extend(*bytes);
        }
        head.extend(data);
        head
    }

    #[test]
    fn reads_float32_and_float64_fields() {
        let a: Vec<u8> = [1.0f32, 2.5, -3.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        let b: Vec<u8> = [0.25f64, 7.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        let bytes = file(&[("a", 10, &[3], &a), ("bb", 11, &[1, 2], &b)]);
        let f = parse_tensor_file(&bytes).unwrap();
        assert_eq!(
            (f[0].name.as_str(), f[0].shape.as_slice(), f[0].data.as_slice()),
            ("a", &[3][..], &[1.0, 2.5, -3.0][..])
        );
        assert_eq!(
            (f[1].name.as_str(), f[1].shape.as_slice(), f[1].data.as_slice()),
            ("bb", &[1, 2][..], &[0.25, 7.0][..])
        );
    }

    #[test]
    fn every_truncation_is_an_error_with_its_offset() {
        let a: Vec<u8> = [1.0f32, 2.5, -3.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        let bytes = file(&[("abc", 10, &[3], &a)]);
        for n in 0..bytes.len() {
            let e = parse_tensor_file(&bytes[..n]).expect_err("truncated");
            assert!(e.starts_with("byte "), "{n}: {e}");
        }
        let mut bad = bytes.clone();
        bad[0] = b'x';
        assert!(parse_tensor_file(&bad).unwrap_err().contains("not a tensor file"));
        let mut bad = bytes;
        bad[18 + 2 + 3 + 2] = 3; // the type byte
        assert!(parse_tensor_file(&bad).unwrap_err().contains("type 3"));
    }
}
