//! Denoising with Intel Open Image Denoise (cargo feature `denoise`): the
//! `RT` filter on the CPU, HDR input, with the albedo and normal AOVs as
//! guides when the image has them (noisy guides: `cleanAux` off). `penumbra
//! render --denoise` denoises the final image; `penumbra denoise` an EXR.
//! The noisy beauty is kept as layer `noisy.R/G/B`.

use crate::args::DenoiseArgs;
use crate::exrmeta::{self, ExrImage};
use anyhow::{bail, Result};

/// What a build without the feature says.
pub const UNAVAILABLE: &str = "denoising needs Intel Open Image Denoise: build penumbra with `--features denoise` \
     (README, \"Denoising\", says how to get the library)";

/// Denoises `rgb` (`width`×`height`, row-major) with optional guides
/// (interleaved, 3 values per pixel).
#[cfg(feature = "denoise")]
pub fn denoise_rgb(
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    albedo: Option<&[f32]>,
    normal: Option<&[f32]>,
) -> Result<Vec<[f32; 3]>> {
    let device = oidn::Device::cpu().map_err(|e| anyhow::anyhow!("Open Image Denoise: no CPU device: {e:?}"))?;
    let color: Vec<f32> = rgb.iter().flatten().map(|v| v.max(0.0)).collect();
    let mut out = vec![0f32; color.len()];
    let albedo: Option<Vec<f32>> = albedo.map(|a| a.iter().map(|v| v.clamp(0.0, 1.0)).collect());
    let normal: Option<Vec<f32>> = normal.map(|n| n.iter().map(|v| v.clamp(-1.0, 1.0)).collect());
    let mut filter = oidn::RayTracing::try_new(&device)
        .map_err(|e| anyhow::anyhow!("Open Image Denoise: cannot create the RT filter: {e:?}"))?;
    filter.srgb(false).hdr(true).clean_aux(false).image_dimensions(width as usize, height as usize);
    match (&albedo, &normal) {
        (Some(a), Some(n)) => {
            filter.albedo_normal(a, n);
        }
        (Some(a), None) => {
            filter.albedo(a);
        }
        _ => {}
    }
    filter.filter(&color, &mut out).map_err(|e| anyhow::anyhow!("Open Image Denoise failed: {e:?}"))?;
    if let Err(e) = device.get_error() {
        bail!("Open Image Denoise failed: {e:?}");
    }
    Ok(out.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

#[cfg(not(feature = "denoise"))]
pub fn denoise_rgb(
    _width: u32,
    _height: u32,
    _rgb: &[[f32; 3]],
    _albedo: Option<&[f32]>,
    _normal: Option<&[f32]>,
) -> Result<Vec<[f32; 3]>> {
    bail!("{UNAVAILABLE}")
}

/// Interleaves the three channels `layer.X/Y/Z` (or R/G/B) of an image.
fn guide(img: &ExrImage, layer: &str, suffixes: [&str; 3]) -> Option<Vec<f32>> {
    let ch: Vec<&[f32]> = suffixes.iter().map(|s| img.layer(&format!("{layer}.{s}"))).collect::<Option<_>>()?;
    Some((0..ch[0].len()).flat_map(|i| [ch[0][i], ch[1][i], ch[2][i]]).collect())
}

/// Denoises `img` in place: the beauty becomes the denoised image and the
/// noisy one layer `noisy`; returns which guides were used.
pub fn denoise_image(img: &mut ExrImage) -> Result<&'static str> {
    let albedo = guide(img, "albedo", ["R", "G", "B"]);
    let normal = guide(img, "normal", ["X", "Y", "Z"]);
    let used = match (&albedo, &normal) {
        (Some(_), Some(_)) => "albedo+normal",
        (Some(_), None) => "albedo",
        _ => "none",
    };
    let normal = if albedo.is_some() { normal } else { None };
    let den = denoise_rgb(img.width, img.height, &img.rgb, albedo.as_deref(), normal.as_deref())?;
    img.layers.retain(|(n, _)| !n.starts_with("noisy."));
    for (c, s) in ["R", "G", "B"].iter().enumerate() {
        img.layers.push((format!("noisy.{s}"), img.rgb.iter().map(|p| p[c]).collect()));
    }
    img.rgb = den;
    img.meta.insert("denoised".into(), format!("Open Image Denoise RT filter, guides: {used}"));
    Ok(used)
}

/// `penumbra denoise IN.exr -o OUT.exr`.
pub fn run(a: &DenoiseArgs) -> Result<()> {
    if !a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        bail!("denoise writes EXR only: name the output '*.exr', not '{}'", a.output.display());
    }
    let mut img = exrmeta::read(&a.input)?;
    if img.weight.is_some() {
        bail!(
            "'{}' is one part of a render (it has a {} channel): merge the parts first, then denoise the result",
            a.input.display(),
            exrmeta::WEIGHT_CHANNEL
        );
    }
    let used = denoise_image(&mut img)?;
    if used != "albedo+normal" {
        eprintln!(
            "warning: '{}' has no {} layer: denoising with guides: {used} (render with --aov albedo,normal)",
            a.input.display(),
            if used == "none" { "albedo or normal" } else { "normal" }
        );
    }
    exrmeta::write(&a.output, &img)?;
    eprintln!(
        "denoised {} into {} ({}x{}, guides: {used})",
        a.input.display(),
        a.output.display(),
        img.width,
        img.height
    );
    Ok(())
}
