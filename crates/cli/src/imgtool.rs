//! `penumbra diff A B [--out ERR.png]`: compares an image with a reference.
//!
//! Prints the per-channel means of both images, the mean squared error and
//! the relative MSE, B being the reference:
//!
//! relMSE = mean over pixels and channels of (a - b)² / (b² + 0.01)
//!
//! (the 0.01 keeps dark reference pixels from dominating). With `--out` it
//! also writes a false-colour image of the per-pixel relMSE on a log scale.

use crate::args::DiffArgs;
use anyhow::{anyhow, bail, Result};
use penumbra_scene::image_io::{self, srgb_to_linear, RgbImage};

/// The ε of relMSE's denominator b² + ε.
pub const REL_EPS: f64 = 1e-2;
/// The false-colour scale: per-pixel relMSE from `LOG_MIN` to `LOG_MAX` (log10).
const LOG_MIN: f64 = -4.0;
const LOG_MAX: f64 = 0.0;

/// What `diff` measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffStats {
    pub mean_a: [f64; 3],
    pub mean_b: [f64; 3],
    pub mse: f64,
    pub rel_mse: f64,
    /// Largest |a - b| / |b| over pixels and channels (infinite where b is 0
    /// and a is not): how `merge` is compared with a single-machine render.
    pub max_rel: f64,
}

/// Compares `a` with the reference `b` (same size).
pub fn diff(a: &RgbImage, b: &RgbImage) -> Result<DiffStats> {
    if (a.width, a.height) != (b.width, b.height) {
        bail!("the images differ in size: {}x{} and {}x{}", a.width, a.height, b.width, b.height);
    }
    if a.pixels.is_empty() {
        bail!("the images are empty");
    }
    let (mut mean_a, mut mean_b) = ([0f64; 3], [0f64; 3]);
    let (mut se, mut rel, mut max_rel) = (0f64, 0f64, 0f64);
    for (pa, pb) in a.pixels.iter().zip(&b.pixels) {
        for k in 0..3 {
            let (x, y) = (pa[k] as f64, pb[k] as f64);
            mean_a[k] += x;
            mean_b[k] += y;
            let d2 = (x - y) * (x - y);
            se += d2;
            rel += d2 / (y * y + REL_EPS);
            let d = (x - y).abs();
            max_rel = max_rel.max(if d == 0.0 {
                0.0
            } else if y == 0.0 {
                f64::INFINITY
            } else {
                d / y.abs()
            });
        }
    }
    let n = a.pixels.len() as f64;
    Ok(DiffStats {
        mean_a: mean_a.map(|m| m / n),
        mean_b: mean_b.map(|m| m / n),
        mse: se / (3.0 * n),
        rel_mse: rel / (3.0 * n),
        max_rel,
    })
}

/// A perceptually ordered colour map (black, purple, red, orange, yellow,
/// close to matplotlib's "inferno"), sRGB-encoded control points.
const COLORMAP: [[f32; 3]; 6] = [
    [0.0, 0.0, 0.016],
    [0.259, 0.039, 0.408],
    [0.576, 0.149, 0.404],
    [0.867, 0.317, 0.227],
    [0.988, 0.647, 0.039],
    [0.988, 1.0, 0.643],
];

/// The colour map at t in [0, 1], as linear RGB (for `write_image`).
fn colormap(t: f64) -> [f32; 3] {
    let t = if t.is_nan() { 1.0 } else { t.clamp(0.0, 1.0) } as f32;
    let x = t * (COLORMAP.len() - 1) as f32;
    let i = (x as usize).min(COLORMAP.len() - 2);
    let f = x - i as f32;
    let (c0, c1) = (COLORMAP[i], COLORMAP[i + 1]);
    [0, 1, 2].map(|k| srgb_to_linear(c0[k] + (c1[k] - c0[k]) * f))
}

/// False-colour image of the per-pixel relMSE (mean over the channels),
/// log scale from 10^LOG_MIN (black) to 10^LOG_MAX (pale yellow).
pub fn error_image(a: &RgbImage, b: &RgbImage) -> RgbImage {
    let pixels = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(pa, pb)| {
            let e = (0..3)
                .map(|k| {
                    let (x, y) = (pa[k] as f64, pb[k] as f64);
                    (x - y) * (x - y) / (y * y + REL_EPS)
                })
                .sum::<f64>()
                / 3.0;
            colormap((e.max(1e-30).log10() - LOG_MIN) / (LOG_MAX - LOG_MIN))
        })
        .collect();
    RgbImage { width: a.width, height: a.height, pixels }
}

pub fn run(args: &DiffArgs) -> Result<()> {
    if let Some(out) = &args.out {
        // Check the output name before reading anything.
        image_io::Format::from_path(out).map_err(|e| anyhow!(e))?;
    }
    let a = image_io::read_image(&args.a).map_err(|e| anyhow!(e))?;
    let b = image_io::read_image(&args.b).map_err(|e| anyhow!(e))?;
    let s = diff(&a, &b).map_err(|e| anyhow!("{} vs {}: {e}", args.a.display(), args.b.display()))?;
    let fmt = |m: [f64; 3]| format!("{:.6} {:.6} {:.6}", m[0], m[1], m[2]);
    println!("image:     {} ({}x{})", args.a.display(), a.width, a.height);
    println!("reference: {}", args.b.display());
    println!("mean A:    {}", fmt(s.mean_a));
    println!("mean B:    {}", fmt(s.mean_b));
    println!("MSE:       {:.6e}", s.mse);
    println!("relMSE:    {:.6e}", s.rel_mse);
    println!("max rel:   {:.3e}", s.max_rel);
    if let Some(out) = &args.out {
        image_io::write_image(out, &error_image(&a, &b)).map_err(|e| anyhow!(e))?;
        println!(
            "error image: {} (per-pixel relMSE, log scale 1e{} black .. 1e{} yellow)",
            out.display(),
            LOG_MIN,
            LOG_MAX
        );
    }
    if let Some(limit) = args.max_rel {
        if s.max_rel.is_nan() || s.max_rel > limit {
            bail!("the largest relative difference {:.3e} is above --max-rel {limit:e}", s.max_rel);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(pixels: Vec<[f32; 3]>, width: u32) -> RgbImage {
        RgbImage { width, height: pixels.len() as u32 / width, pixels }
    }

    #[test]
    fn identical_images_have_zero_error() {
        let a = img(vec![[0.1, 0.2, 0.3], [4.0, 5.0, 6.0]], 2);
        let s = diff(&a, &a).unwrap();
        assert_eq!((s.mse, s.rel_mse, s.max_rel), (0.0, 0.0, 0.0));
        let b = img(vec![[0.1, 0.2, 0.3], [4.0, 5.0, 6.003]], 2);
        assert!((diff(&b, &a).unwrap().max_rel - 0.0005).abs() < 1e-6);
        assert!((s.mean_a[2] - 3.15).abs() < 1e-6 && s.mean_a == s.mean_b);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = img(vec![[0.0; 3]; 4], 2);
        let b = img(vec![[0.0; 3]; 4], 4);
        assert!(diff(&a, &b).unwrap_err().to_string().contains("2x2 and 4x1"));
    }

    #[test]
    fn colormap_ends_and_error_image_size() {
        assert!(colormap(0.0).iter().all(|&c| c < 0.01));
        assert!(colormap(1.0)[0] > 0.9 && colormap(1.0)[1] > 0.9);
        assert_eq!(colormap(f64::NAN), colormap(1.0));
        let a = img(vec![[0.0; 3]; 6], 3);
        let e = error_image(&a, &a);
        assert_eq!((e.width, e.height, e.pixels.len()), (3, 2, 6));
    }
}
