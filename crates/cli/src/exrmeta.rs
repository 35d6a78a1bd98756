//! EXR files with Penumbra's metadata: the beauty image as R, G, B (f32,
//! single part, readable by any EXR reader), optionally the per-pixel weight
//! sum as channel `penumbra.weight` (what `merge` needs to add parts exactly:
//! Σ w·L = RGB·weight), and text attributes `penumbra:*` in the header.
//! A crop window is written as EXR means it: the data window is the crop,
//! the display window the full frame. Writes are atomic
//! ([`penumbra_scene::atomic`]).

use anyhow::{anyhow, bail, Context, Result};
use exr::prelude::*;
use penumbra_scene::atomic;
use std::collections::BTreeMap;
use std::path::Path;

pub const WEIGHT_CHANNEL: &str = "penumbra.weight";
pub const PREFIX: &str = "penumbra:";
/// The largest width or height [`read()`] accepts (that of the largest film).
pub const MAX_SIZE: usize = 1 << 16;

/// An image with its placement in the full frame and its metadata.
#[derive(Debug, Clone)]
pub struct ExrImage {
    pub width: u32,
    pub height: u32,
    /// Position of this image in the full frame (the crop window's corner).
    pub offset: (u32, u32),
    pub full_size: (u32, u32),
    pub rgb: Vec<[f32; 3]>,
    pub weight: Option<Vec<f32>>,
    /// Further channels by full name (`albedo.R`, `depth.Z`, ...), one value
    /// per pixel each: AOV layers beside the beauty image.
    pub layers: Vec<(String, Vec<f32>)>,
    /// `penumbra:*` attributes, without the prefix.
    pub meta: BTreeMap<String, String>,
}

/// EXR text attributes hold bytes 0..=255: other characters become '?'.
fn text(s: &str) -> Text {
    let bytes: Vec<u8> = s.chars().map(|c| u8::try_from(c as u32).unwrap_or(b'?')).collect();
    Text::from_slice_unchecked(&bytes)
}

/// Writes `img` atomically.
pub fn write(path: &Path, img: &ExrImage) -> Result<()> {
    let n = (img.width * img.height) as usize;
    assert_eq!(img.rgb.len(), n);
    let ch = |c: usize| FlatSamples::F32(img.rgb.iter().map(|p| p[c]).collect());
    let mut channels = vec![AnyChannel::new("R", ch(0)), AnyChannel::new("G", ch(1)), AnyChannel::new("B", ch(2))];
    if let Some(w) = &img.weight {
        assert_eq!(w.len(), n);
        channels.push(AnyChannel::new(WEIGHT_CHANNEL, FlatSamples::F32(w.clone())));
    }
    for (name, v) in &img.layers {
        assert_eq!(v.len(), n, "{name}");
        channels.push(AnyChannel::new(name.as_str(), FlatSamples::F32(v.clone())));
    }
    let mut attrs = LayerAttributes {
        layer_position: Vec2(img.offset.0 as i32, img.offset.1 as i32),
        software_name: Some(text(&format!("penumbra {}", crate::settings::VERSION))),
        ..LayerAttributes::default()
    };
    for (k, v) in &img.meta {
        attrs.other.insert(text(&format!("{PREFIX}{k}")), AttributeValue::Text(text(v)));
    }
    let layer = Layer::new(
        (img.width as usize, img.height as usize),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into_iter().collect()),
    );
    let display = IntegerBounds::from_dimensions((img.full_size.0 as usize, img.full_size.1 as usize));
    let image = Image::new(ImageAttributes::new(display), layer);
    // The encoder's message alone: its I/O errors carry the cause in it.
    atomic::write_file(path, |w| image.write().to_buffered(w).map_err(|e| std::io::Error::other(e.to_string())))
        .with_context(|| format!("cannot write '{}'", path.display()))
}

/// Reads an EXR written by [`write()`] (or any RGB EXR: then `meta` is empty).
pub fn read(path: &Path) -> Result<ExrImage> {
    // Sizes from the header are checked before the pixels are allocated:
    // no film is larger than 65536 x 65536.
    let header = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| anyhow!("cannot read '{}': {e}", path.display()))?;
    for h in &header.headers {
        let (data, display) = (h.layer_size, h.shared_attributes.display_window.size);
        if [data.0, data.1, display.0, display.1].iter().any(|&s| s > MAX_SIZE) {
            bail!(
                "'{}': its header claims a {} x {} image in a {} x {} frame; Penumbra's images are at most \
                 {MAX_SIZE} x {MAX_SIZE} (the file is damaged, or not a Penumbra render)",
                path.display(),
                data.0,
                data.1,
                display.0,
                display.1
            );
        }
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| anyhow!("cannot read '{}': {e}", path.display()))?;
    let layer = &image.layer_data;
    let (w, h) = (layer.size.0, layer.size.1);
    let find = |name: &str| layer.channel_data.list.iter().find(|c| c.name.eq(name));
    let values = |name: &str| -> Option<Vec<f32>> { find(name).map(|c| c.sample_data.values_as_f32().collect()) };
    let (r, g, b) = match (values("R"), values("G"), values("B")) {
        (Some(r), Some(g), Some(b)) => (r, g, b),
        _ => bail!("'{}' has no R, G and B channels", path.display()),
    };
    let rgb = (0..w * h).map(|i| [r[i], g[i], b[i]]).collect();
    let mut meta = BTreeMap::new();
    for (k, v) in layer.attributes.other.iter().chain(image.attributes.other.iter()) {
        let key = String::from_utf8_lossy(k.as_slice()).to_string();
        if let (Some(key), AttributeValue::Text(t)) = (key.strip_prefix(PREFIX), v) {
            meta.insert(key.to_string(), t.as_slice().iter().map(|&b| b as char).collect());
        }
    }
    let pos = layer.attributes.layer_position;
    let disp = image.attributes.display_window;
    if pos.0 < 0 || pos.1 < 0 || disp.position.0 != 0 || disp.position.1 != 0 {
        bail!(
            "'{}': a data window at a negative position or a display window not at 0,0 is not supported",
            path.display()
        );
    }
    Ok(ExrImage {
        width: w as u32,
        height: h as u32,
        offset: (pos.0 as u32, pos.1 as u32),
        full_size: (disp.size.0 as u32, disp.size.1 as u32),
        rgb,
        weight: values(WEIGHT_CHANNEL),
        layers: layer
            .channel_data
            .list
            .iter()
            .filter(|c| !["R", "G", "B", WEIGHT_CHANNEL].iter().any(|n| c.name.eq(n)))
            .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
            .collect(),
        meta,
    })
}

impl ExrImage {
    /// The channel named `name` (a layer; not R, G, B or the weight).
    pub fn layer(&self, name: &str) -> Option<&[f32]> {
        self.layers.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }
}
