//! Statistics shared by the image-comparison tests.
#![allow(dead_code)]

use penumbra_render::film::Film;
use penumbra_scene::{load_scene, Overrides};
use std::path::{Path, PathBuf};

#[path = "../../../../tests/support/skip.rs"]
mod skip;
#[allow(unused_imports)]
pub use skip::{in_ci, skip};

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A rendered image: per-pixel mean and the variance of that mean.
#[derive(Clone)]
pub struct Estimate {
    pub width: u32,
    pub height: u32,
    pub mean: Vec<[f64; 3]>,
    pub var: Vec<[f64; 3]>,
}

/// Renders `batches` independent batches of `spp / batches` samples and
/// estimates each pixel's variance from the spread of the batch means.
/// Estimates to be compared with each other must use different seeds, or
/// their errors are correlated and the comparison proves little.
pub fn render_with_variance(scene: &Path, spp: u32, batches: u32, integrator: Option<&str>, seed: u64) -> Estimate {
    let ov = Overrides {
        spp: Some(spp),
        seed: Some(seed),
        integrator: integrator.map(str::to_string),
        ..Default::default()
    };
    let job = load_scene(scene, &[], &ov).unwrap_or_else(|e| panic!("{e}"));
    let per = spp / batches;
    let imgs: Vec<Vec<[f32; 3]>> = (0..batches)
        .map(|b| {
            let mut film = Film::new(job.width, job.height);
            job.render_into(&mut film, b * per..(b + 1) * per, &|_| {});
            film.develop()
        })
        .collect();
    estimate(job.width, job.height, &imgs)
}

/// As [`render_with_variance`] with another sampler (`--sampler NAME`):
/// each batch is its own seed's first `spp / batches` samples. Batches of one
/// low-discrepancy sequence are correlated, so their spread would misjudge
/// the variance; independently scrambled batches are independent.
pub fn render_with_sampler(scene: &Path, spp: u32, batches: u32, sampler: &str, seed: u64) -> Estimate {
    let per = spp / batches;
    let imgs: Vec<Vec<[f32; 3]>> = (0..batches as u64)
        .map(|b| {
            let ov = Overrides {
                spp: Some(per),
                seed: Some(seed + b),
                sampler: Some(sampler.to_string()),
                ..Default::default()
            };
            let job = load_scene(scene, &[], &ov).unwrap_or_else(|e| panic!("{e}"));
            let mut film = Film::new(job.width, job.height);
            job.render_into(&mut film, 0..per, &|_| {});
            film.develop()
        })
        .collect();
    let job = load_scene(scene, &[], &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    estimate(job.width, job.height, &imgs)
}

/// Per-pixel mean of equally weighted, independent images and the variance of that mean.
fn estimate(width: u32, height: u32, imgs: &[Vec<[f32; 3]>]) -> Estimate {
    let n = imgs[0].len();
    let k = imgs.len() as f64;
    let mut mean = vec![[0.0; 3]; n];
    let mut var = vec![[0.0; 3]; n];
    for i in 0..n {
        for c in 0..3 {
            let m = imgs.iter().map(|im| im[i][c] as f64).sum::<f64>() / k;
            let v = imgs.iter().map(|im| (im[i][c] as f64 - m).powi(2)).sum::<f64>() / (k - 1.0);
            mean[i][c] = m;
            var[i][c] = v / k;
        }
    }
    Estimate { width, height, mean, var }
}

/// Checks that two estimates of the same image agree: per-channel image
/// means within `rel_tol` and 5 standard errors, and a squared difference
/// that the two variances explain (Σ d² / Σ (var_a + var_b) < 1.3, relative
/// weighting 1 / (ref² + 0.01) as in relMSE). Returns that ratio.
pub fn assert_agree(name: &str, a: &Estimate, b: &Estimate, rel_tol: f64) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height), "{name}: resolution");
    let n = a.mean.len() as f64;
    for c in 0..3 {
        let ma = a.mean.iter().map(|p| p[c]).sum::<f64>() / n;
        let mb = b.mean.iter().map(|p| p[c]).sum::<f64>() / n;
        let se = (a.var.iter().map(|v| v[c]).sum::<f64>() + b.var.iter().map(|v| v[c]).sum::<f64>()).sqrt() / n;
        eprintln!("{name} channel {c}: {ma:.5} vs {mb:.5} (se {se:.5})");
        assert!((ma - mb).abs() <= rel_tol * mb.abs() + 1e-4, "{name}: channel {c} mean {ma} vs {mb}");
        assert!((ma - mb).abs() <= 5.0 * se + 1e-4, "{name}: channel {c} mean {ma} vs {mb}, se {se}");
    }
    let (mut err, mut expl) = (0.0, 0.0);
    for i in 0..a.mean.len() {
        for c in 0..3 {
            let d = b.mean[i][c] * b.mean[i][c] + 1e-2;
            err += (a.mean[i][c] - b.mean[i][c]).powi(2) / d;
            expl += (a.var[i][c] + b.var[i][c]) / d;
        }
    }
    let ratio = err / expl;
    eprintln!(
        "{name}: relMSE {:.3e}, explained by variance {:.3e}, ratio {ratio:.3}",
        err / (3.0 * n),
        expl / (3.0 * n)
    );
    // For unbiased estimators the ratio's expectation is 1; over ~10k pixel
    // channels its spread is a few percent, the batch variance estimates add
    // more; 1.3 leaves room for that but not for a systematic difference.
    assert!(ratio < 1.3, "{name}: squared difference {ratio:.2}x what the variances explain");
    ratio
}
