//! Image output by file extension: `.exr` (linear float RGB), `.png`
//! (sRGB-encoded 8-bit, clamped), `.pfm` (linear float, bottom row first),
//! `.hdr` (Radiance RGBE). Files are written atomically ([`crate::atomic`]),
//! so a reader never sees a half-written image and a failure leaves nothing.

use crate::atomic;
use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// A linear RGB image, row-major, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width · height` pixels; pixel (x, y) at `y * width + x`.
    pub pixels: Vec<[f32; 3]>,
}

/// The output formats, chosen by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// OpenEXR, 32-bit float RGB, linear.
    Exr,
    /// 8-bit sRGB-encoded RGB, clamped to [0, 1] (non-finite values → 0).
    Png,
    /// Portable float map, little-endian, rows bottom to top, linear.
    Pfm,
    /// Radiance RGBE, linear (negative and non-finite values → 0).
    Hdr,
}

impl Format {
    /// The format named by the extension of `path` (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Format, String> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "exr" => Ok(Format::Exr),
            "png" => Ok(Format::Png),
            "pfm" => Ok(Format::Pfm),
            "hdr" => Ok(Format::Hdr),
            _ => Err(format!(
                "cannot tell the image format of '{}': use the extension .exr, .png, .pfm or .hdr",
                path.display()
            )),
        }
    }
}

/// sRGB transfer function (IEC 61966-2-1).
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes `img` to `path` in the format its extension names.
pub fn write_image(path: &Path, img: &RgbImage) -> Result<(), String> {
    let format = Format::from_path(path)?;
    atomic::write_file(path, |w| encode(w, format, img)).map_err(|e| format!("cannot write '{}': {e}", path.display()))
}

fn encode(out: &mut BufWriter<File>, format: Format, img: &RgbImage) -> io::Result<()> {
    let (w, h) = (img.width as usize, img.height as usize);
    match format {
        Format::Exr => {
            use exr::prelude::*;
            let px = &img.pixels;
            let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
                let p = px[y * w + x];
                (p[0], p[1], p[2])
            });
            Image::from_channels((w, h), channels).write().to_buffered(out).map_err(io::Error::other)
        }
        Format::Png => {
            let mut buf = Vec::with_capacity(w * h * 3);
            for p in &img.pixels {
                for c in p {
                    let v = if c.is_finite() { linear_to_srgb(c.clamp(0.0, 1.0)) } else { 0.0 };
                    buf.push((v * 255.0 + 0.5) as u8);
                }
            }
            image::write_buffer_with_format(
                out,
                &buf,
                img.width,
                img.height,
                image::ColorType::Rgb8,
                image::ImageFormat::Png,
            )
            .map_err(io::Error::other)
        }
        Format::Pfm => {
            // Negative scale: little-endian floats; rows run bottom to top.
            write!(out, "PF\n{w} {h}\n-1.0\n")?;
            for y in (0..h).rev() {
                for p in &img.pixels[y * w..(y + 1) * w] {
                    for c in p {
                        out.write_all(&c.to_le_bytes())?;
                    }
                }
            }
            Ok(())
        }
        Format::Hdr => {
            let pixels: Vec<image::Rgb<f32>> = img
                .pixels
                .iter()
                .map(|p| image::Rgb(p.map(|c| if c.is_finite() { c.max(0.0) } else { 0.0 })))
                .collect();
            image::codecs::hdr::HdrEncoder::new(out).encode(&pixels, w, h).map_err(io::Error::other)
        }
    }
}

/// The most pixels an image read may hold: 2²⁸ (16384 x 16384, 3 GiB as
/// f32 RGB). A header claiming more is refused before anything is
/// allocated: a damaged or hostile file must not exhaust memory.
pub const MAX_PIXELS: u64 = 1 << 28;

/// Refuses an image whose header claims more than [`MAX_PIXELS`].
fn check_size(path: &Path, width: u64, height: u64) -> Result<(), String> {
    if width.saturating_mul(height) > MAX_PIXELS {
        return Err(format!(
            "cannot read '{}': its header claims {width} x {height} pixels, more than the {MAX_PIXELS} \
             (16384 x 16384) Penumbra reads; the file is damaged, or must be downscaled",
            path.display()
        ));
    }
    Ok(())
}

/// Reads a linear RGB EXR (references, tests).
pub fn read_exr(path: &Path) -> Result<RgbImage, String> {
    use exr::prelude::*;
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    for header in &meta.headers {
        check_size(path, header.layer_size.width() as u64, header.layer_size.height() as u64)?;
    }
    let img = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), res.height(), vec![[0f32; 3]; res.width() * res.height()]),
        |(w, _, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| px[pos.y() * *w + pos.x()] = [r, g, b],
    )
    .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let (w, h, pixels) = img.layer_data.channel_data.pixels;
    Ok(RgbImage { width: w as u32, height: h as u32, pixels })
}

/// An EXR's channels by name, each row-major.
pub type Channels = Vec<(String, Vec<f32>)>;

/// Every channel of an EXR's first layer, by name, row-major (a multichannel
/// image such as the `aov` integrator's): width, height, channels.
pub fn read_exr_channels(path: &Path) -> Result<(u32, u32, Channels), String> {
    use exr::prelude::*;
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    for header in &meta.headers {
        check_size(path, header.layer_size.width() as u64, header.layer_size.height() as u64)?;
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let layer = &image.layer_data;
    let channels =
        layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect();
    Ok((layer.size.0 as u32, layer.size.1 as u32, channels))
}

/// Inverse of [`linear_to_srgb`] (IEC 61966-2-1).
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Reads an image as linear RGB by extension: `.exr` (linear float), `.hdr`
/// (Radiance RGBE, linear), `.png` / `.jpg` / `.jpeg` (8 or 16 bit, sRGB
/// encoded, decoded to linear as Mitsuba does). Alpha is dropped; grey
/// images are expanded to RGB.
pub fn read_image(path: &Path) -> Result<RgbImage, String> {
    read_image_with(path, false)
}

/// [`read_image`], optionally without the sRGB decoding of 8/16-bit
/// formats (Mitsuba's `raw`: the stored values divided by 255 or 65535).
/// Linear formats (EXR, HDR) are returned as stored either way.
pub fn read_image_with(path: &Path, raw: bool) -> Result<RgbImage, String> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let (format, srgb) = match ext.as_str() {
        "exr" => return read_exr(path),
        "pfm" => return read_pfm(path),
        "hdr" => (image::ImageFormat::Hdr, false),
        "png" => (image::ImageFormat::Png, true),
        "jpg" | "jpeg" => (image::ImageFormat::Jpeg, true),
        "tga" => (image::ImageFormat::Tga, true),
        _ => {
            return Err(format!(
                "cannot read '{}': unsupported image format; use .exr, .hdr, .pfm, .png, .jpg or .tga",
                path.display()
            ))
        }
    };
    let fail = |e: &dyn std::fmt::Display| format!("cannot read '{}': {e}", path.display());
    let mut bytes = fs::read(path).map_err(|e| fail(&e))?;
    if format == image::ImageFormat::Hdr && bytes.starts_with(b"#?") && !bytes.starts_with(b"#?RADIANCE") {
        // The decoder accepts only the "#?RADIANCE" signature; Mitsuba and others write "#?RGBE".
        let eol = bytes.iter().position(|&b| b == b'\n').unwrap_or(bytes.len());
        bytes.splice(0..eol, b"#?RADIANCE".iter().copied());
    }
    let (w, h) = image::ImageReader::with_format(std::io::Cursor::new(&bytes[..]), format)
        .into_dimensions()
        .map_err(|e| fail(&e))?;
    check_size(path, w as u64, h as u64)?;
    // Environment maps can exceed the decoder's default 512 MiB allocation
    // limit; the size was checked above instead.
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    reader.no_limits();
    let img = reader.decode().map_err(|e| fail(&e))?.to_rgb32f();
    let srgb = srgb && !raw;
    let decode = |c: f32| if srgb { srgb_to_linear(c) } else { c };
    Ok(RgbImage { width: img.width(), height: img.height(), pixels: img.pixels().map(|p| p.0.map(decode)).collect() })
}

/// Reads a PFM file (`PF` colour or `Pf` grey, expanded to RGB; the scale's
/// sign gives the byte order; rows bottom to top), as linear RGB. A header
/// that is not PFM, or data shorter than the header claims, is an error
/// naming the byte where it goes wrong.
pub fn read_pfm(path: &Path) -> Result<RgbImage, String> {
    let fail = |m: String| format!("cannot read '{}': {m}", path.display());
    let bytes = fs::read(path).map_err(|e| fail(e.to_string()))?;
    // Three whitespace-separated header fields after the magic, then one
    // whitespace byte before the data.
    let mut at = 0usize;
    let mut field = |what: &str| -> Result<String, String> {
        while at < bytes.len() && bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while at < bytes.len() && !bytes[at].is_ascii_whitespace() && at - start < 32 {
            at += 1;
        }
        if start == at || at >= bytes.len() {
            return Err(fail(format!("not a PFM file: no {what} at byte {start}")));
        }
        Ok(String::from_utf8_lossy(&bytes[start..at]).into_owned())
    };
    let magic = field("PF/Pf signature")?;
    let channels = match magic.as_str() {
        "PF" => 3,
        "Pf" => 1,
        _ => return Err(fail(format!("not a PFM file: it starts with '{magic}', not PF or Pf"))),
    };
    let dim = |s: String, what: &str| -> Result<u64, String> {
        s.parse::<u64>()
            .ok()
            .filter(|&v| v > 0)
            .ok_or_else(|| fail(format!("PFM {what} '{s}' is not a positive integer")))
    };
    let w = dim(field("width")?, "width")?;
    let h = dim(field("height")?, "height")?;
    let scale_text = field("scale")?;
    let scale: f32 = scale_text
        .parse()
        .ok()
        .filter(|s: &f32| s.is_finite() && *s != 0.0)
        .ok_or_else(|| fail(format!("PFM scale '{scale_text}' is not a non-zero number")))?;
    let data = at + 1;
    check_size(path, w, h)?;
    let need = w * h * channels as u64 * 4;
    let have = bytes.len().saturating_sub(data) as u64;
    if have < need {
        return Err(fail(format!(
            "the PFM data ends at byte {} of {} ({w} x {h} pixels need {need} bytes from byte {data})",
            bytes.len(),
            data as u64 + need
        )));
    }
    let (w, h) = (w as usize, h as usize);
    let value = |i: usize| {
        let b: [u8; 4] = bytes[data + 4 * i..data + 4 * i + 4].try_into().unwrap();
        if scale < 0.0 {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let mut pixels = vec![[0f32; 3]; w * h];
    for y in 0..h {
        // File row y is image row h − 1 − y.
        for x in 0..w {
            let i = (y * w + x) * channels;
            let p = if channels == 3 { [value(i), value(i + 1), value(i + 2)] } else { [value(i); 3] };
            pixels[(h - 1 - y) * w + x] = p;
        }
    }
    Ok(RgbImage { width: w as u32, height: h as u32, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Written PFM files read back bit for bit; big-endian and grey files
    /// read; a short or foreign file is an error naming where.
    #[test]
    fn pfm_reads_back_and_refuses_damage() {
        let dir = std::env::temp_dir().join(format!("penumbra-pfm-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let img = RgbImage { width: 3, height: 2, pixels: (0..6).map(|i| [i as f32 * 0.25, -0.5, 1e30]).collect() };
        let p = dir.join("a.pfm");
        write_image(&p, &img).unwrap();
        assert_eq!(read_image(&p).unwrap().pixels, img.pixels);
        // Big-endian grey, 2 x 1: bottom row first (one row here).
        let mut be = b"Pf\n2 1\n1.0\n".to_vec();
        for v in [1.5f32, 2.0] {
            be.extend_from_slice(&v.to_be_bytes());
        }
        fs::write(&p, &be).unwrap();
        assert_eq!(read_image(&p).unwrap().pixels, vec![[1.5; 3], [2.0; 3]]);
        fs::write(&p, &be[..be.len() - 1]).unwrap();
        let e = read_image(&p).unwrap_err();
        assert!(e.contains("ends at byte 18 of 19"), "{e}");
        fs::write(&p, b"P6\n2 1\n255\n").unwrap();
        assert!(read_image(&p).unwrap_err().contains("starts with 'P6'"));
        fs::write(&p, b"PF\n2 -1\n-1.0\n").unwrap();
        assert!(read_image(&p).unwrap_err().contains("height '-1'"));
        fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn formats_round_trip_or_exist() {
        let dir = std::env::temp_dir().join(format!("penumbra-io-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let img = RgbImage { width: 3, height: 2, pixels: (0..6).map(|i| [i as f32 * 0.25, 0.5, 2.0]).collect() };
        let exr_path = dir.join("a.exr");
        write_image(&exr_path, &img).unwrap();
        let back = read_exr(&exr_path).unwrap();
        assert_eq!(back.pixels, img.pixels);
        for ext in ["png", "pfm", "hdr"] {
            let p = dir.join(format!("a.{ext}"));
            write_image(&p, &img).unwrap();
            assert!(fs::metadata(&p).unwrap().len() > 0);
        }
        let pfm = fs::read(dir.join("a.pfm")).unwrap();
        assert_eq!(pfm.len(), "PF\n3 2\n-1.0\n".len() + 6 * 12);
        assert!(write_image(&dir.join("a.jpg"), &img).is_err());
        assert!(fs::read_dir(&dir).unwrap().all(|e| !e.unwrap().file_name().to_string_lossy().contains(".tmp")));
        fs::remove_dir_all(&dir).ok();
    }

    /// A PNG whose header claims 100000 x 100000 pixels (valid chunks, no
    /// pixel data) is refused by its size, before anything is allocated.
    #[test]
    fn huge_image_headers_are_refused() {
        let dir = std::env::temp_dir().join(format!("penumbra-huge-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let mut ihdr = b"IHDR".to_vec();
        ihdr.extend_from_slice(&100_000u32.to_be_bytes());
        ihdr.extend_from_slice(&100_000u32.to_be_bytes());
        ihdr.extend_from_slice(&[8, 2, 0, 0, 0]); // 8-bit RGB
        let mut crc = flate2::Crc::new();
        crc.update(&ihdr);
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        png.extend_from_slice(&13u32.to_be_bytes());
        png.extend_from_slice(&ihdr);
        png.extend_from_slice(&crc.sum().to_be_bytes());
        for name in [b"IDAT", b"IEND"] {
            let mut crc = flate2::Crc::new();
            crc.update(name);
            png.extend_from_slice(&0u32.to_be_bytes());
            png.extend_from_slice(name);
            png.extend_from_slice(&crc.sum().to_be_bytes());
        }
        let path = dir.join("huge.png");
        fs::write(&path, &png).unwrap();
        let e = read_image(&path).unwrap_err();
        assert!(e.contains("huge.png") && e.contains("100000 x 100000"), "{e}");
        // The limit itself.
        assert!(check_size(&path, 16384, 16384).is_ok());
        assert!(check_size(&path, 16385, 16384).unwrap_err().contains("16385 x 16384"));
        fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn srgb_curve_endpoints() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        assert!((linear_to_srgb(0.18) - 0.4613).abs() < 1e-3);
    }

    #[test]
    fn read_image_decodes_every_input_format() {
        let dir = std::env::temp_dir().join(format!("penumbra-read-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let img = RgbImage {
            width: 3,
            height: 2,
            pixels: vec![
                [0.0, 0.5, 1.0],
                [0.18, 0.02, 0.9],
                [1.0, 0.0, 0.25],
                [0.7, 0.7, 0.7],
                [0.001, 0.3, 0.6],
                [0.05, 1.0, 0.4],
            ],
        };
        let close = |path: &Path, tol: f32| {
            let back = read_image(path).unwrap();
            assert_eq!((back.width, back.height), (3, 2), "{}", path.display());
            // RGBE and 8-bit quantisation errors scale with the pixel's largest channel.
            for (a, b) in back.pixels.iter().zip(&img.pixels) {
                let m = b.iter().fold(0.05f32, |m, &c| m.max(c));
                assert!((0..3).all(|k| (a[k] - b[k]).abs() <= tol * m), "{}: {a:?} vs {b:?}", path.display());
            }
        };
        for (ext, tol) in [("exr", 0.0), ("hdr", 0.02), ("png", 0.02)] {
            let p = dir.join(format!("in.{ext}"));
            write_image(&p, &img).unwrap();
            close(&p, tol);
        }
        // Mitsuba writes RGBE files with the signature "#?RGBE" rather than "#?RADIANCE".
        let hdr = fs::read(dir.join("in.hdr")).unwrap();
        assert!(hdr.starts_with(b"#?RADIANCE\n"));
        fs::write(dir.join("rgbe.hdr"), [b"#?RGBE".as_slice(), &hdr[10..]].concat()).unwrap();
        close(&dir.join("rgbe.hdr"), 0.02);
        // An 8-bit sRGB JPEG of a flat colour: mid grey 188 is linear 0.5029.
        let jpg = dir.join("in.JPG");
        image::save_buffer(&jpg, &[188u8; 8 * 8 * 3], 8, 8, image::ColorType::Rgb8).unwrap();
        let back = read_image(&jpg).unwrap();
        assert!(back.pixels.iter().flatten().all(|c| (c - 0.5029).abs() < 0.01), "{:?}", back.pixels[0]);
        // 8-bit sRGB TGA (pbrt-v4 scenes use them), the same grey.
        let tga = dir.join("in.tga");
        image::save_buffer(&tga, &[188u8; 8 * 8 * 3], 8, 8, image::ColorType::Rgb8).unwrap();
        let back = read_image(&tga).unwrap();
        assert!(back.pixels.iter().flatten().all(|c| (c - 0.5029).abs() < 1e-4), "{:?}", back.pixels[0]);
        let err = read_image(&dir.join("in.bmp")).unwrap_err();
        assert!(err.contains("in.bmp") && err.contains(".exr, .hdr, .pfm, .png, .jpg or .tga"), "{err}");
        let err = read_image(&dir.join("missing.hdr")).unwrap_err();
        assert!(err.contains("missing.hdr"), "{err}");
        fs::remove_dir_all(&dir).ok();
    }
}
