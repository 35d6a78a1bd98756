//! `read` and `write`: image files as numpy float32 arrays of shape
//! (height, width, channels), through the command line's own readers and
//! writers. EXR keeps every channel and the `penumbra:*` metadata; PNG, PFM
//! and HDR hold RGB (PNG 8-bit sRGB, clamped, as the command line writes it).

use crate::{anyhow_error, error};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray3, PyUntypedArrayMethods};
use penumbra::exrmeta::{self, ExrImage};
use penumbra_scene::image_io::{self, Format, RgbImage};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Reads an image: `{"image": (h, w, 3) array, <layer>: ..., "metadata":
/// {key: text}}`; EXR layers (`albedo.R`, ...) are grouped by name as the
/// render's AOVs are (`albedo`: (h, w, 3)).
#[pyfunction]
pub fn read<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let arr = |v: Vec<f32>, h: u32, w: u32, c: usize| -> PyResult<Bound<'py, PyAny>> {
        Ok(PyArray1::from_vec(py, v).reshape([h as usize, w as usize, c])?.into_any())
    };
    if Format::from_path(&path).map_err(error)? != Format::Exr {
        let img = image_io::read_image(&path).map_err(error)?;
        out.set_item("image", arr(img.pixels.into_iter().flatten().collect(), img.height, img.width, 3)?)?;
        out.set_item("metadata", PyDict::new(py))?;
        return Ok(out);
    }
    let img = exrmeta::read(&path).map_err(anyhow_error)?;
    let (w, h) = (img.width, img.height);
    out.set_item("image", arr(img.rgb.iter().flatten().copied().collect(), h, w, 3)?)?;
    // Layers "name.C": one array per name. EXR files list channels sorted by
    // name, so R, G, B, A and X, Y, Z are put back in that order.
    let rank = |c: &str| ["R", "G", "B", "A", "X", "Y", "Z"].iter().position(|&n| n == c).unwrap_or(7);
    type Channels<'a> = Vec<(&'a str, &'a Vec<f32>)>;
    let mut groups: Vec<(String, Channels)> = Vec::new();
    for (name, v) in &img.layers {
        let (layer, suffix) = name.rsplit_once('.').unwrap_or((name.as_str(), ""));
        match groups.iter_mut().find(|(l, _)| l == layer) {
            Some((_, list)) => list.push((suffix, v)),
            None => groups.push((layer.to_string(), vec![(suffix, v)])),
        }
    }
    for (layer, mut channels) in groups {
        channels.sort_by_key(|&(suffix, _)| rank(suffix));
        let channels: Vec<&Vec<f32>> = channels.into_iter().map(|(_, v)| v).collect();
        let n = (w * h) as usize;
        let c = channels.len();
        let mut v = vec![0f32; n * c];
        for (j, ch) in channels.iter().enumerate() {
            for i in 0..n {
                v[i * c + j] = ch[i];
            }
        }
        out.set_item(layer, arr(v, h, w, c)?)?;
    }
    let meta = PyDict::new(py);
    for (k, v) in &img.meta {
        meta.set_item(k, v)?;
    }
    out.set_item("metadata", meta)?;
    Ok(out)
}

/// Writes `image` ((h, w, 3) float32, linear RGB) to `path` by extension
/// (atomically, as every output); for EXR, `layers` (name → (h, w, c)
/// array, channels named R, G, B, A or X, Y, Z by count as the render's
/// AOVs are) and `metadata` (text attributes `penumbra:KEY`) go with it.
#[pyfunction]
#[pyo3(signature = (path, image, layers=None, metadata=None))]
pub fn write(
    path: PathBuf,
    image: PyReadonlyArray3<'_, f32>,
    layers: Option<Vec<(String, PyReadonlyArray3<'_, f32>)>>,
    metadata: Option<BTreeMap<String, String>>,
) -> PyResult<()> {
    let shape = image.shape();
    if shape[2] != 3 {
        return Err(error(format!("write: the image must have shape (height, width, 3), not {shape:?}")));
    }
    let (h, w) = (shape[0] as u32, shape[1] as u32);
    let a = image.as_array();
    let rgb: Vec<[f32; 3]> =
        a.outer_iter().flat_map(|row| row.outer_iter().map(|p| [p[0], p[1], p[2]]).collect::<Vec<_>>()).collect();
    let format = Format::from_path(&path).map_err(error)?;
    let layers = layers.unwrap_or_default();
    if format != Format::Exr {
        if !layers.is_empty() || metadata.as_ref().is_some_and(|m| !m.is_empty()) {
            return Err(error(format!("write: layers and metadata need an EXR file, not '{}'", path.display())));
        }
        return image_io::write_image(&path, &RgbImage { width: w, height: h, pixels: rgb }).map_err(error);
    }
    let mut channels = Vec::new();
    for (name, arr) in &layers {
        let s = arr.shape();
        if s[0] != h as usize || s[1] != w as usize {
            return Err(error(format!("write: layer '{name}' is {}x{}, the image {w}x{h}", s[1], s[0])));
        }
        let names: &[&str] = match s[2] {
            1 => &["Z"],
            2 => &["X", "Y"],
            3 if matches!(name.as_str(), "normal" | "position") => &["X", "Y", "Z"],
            3 => &["R", "G", "B"],
            4 => &["R", "G", "B", "A"],
            c => return Err(error(format!("write: layer '{name}' has {c} channels; at most 4"))),
        };
        let v = arr.as_array();
        for (c, suffix) in names.iter().enumerate() {
            channels.push((
                format!("{name}.{suffix}"),
                v.outer_iter().flat_map(|r| r.outer_iter().map(|p| p[c]).collect::<Vec<_>>()).collect(),
            ));
        }
    }
    let img = ExrImage {
        width: w,
        height: h,
        offset: (0, 0),
        full_size: (w, h),
        rgb,
        weight: None,
        layers: channels,
        meta: metadata.unwrap_or_default(),
    };
    exrmeta::write(&path, &img).map_err(anyhow_error)
}
