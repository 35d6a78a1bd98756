//! Statistics shared by the image-comparison tests.
//!
//! An [`Estimate`] is an image with the variance of each pixel's mean,
//! estimated from independent batches. [`compare`] tests the hypothesis
//! that two estimates have the same expectation with four statistics, each
//! at a false-alarm rate of `FALSE_ALARM / 3` (Bonferroni), so a comparison
//! of two unbiased renders fails with probability at most [`FALSE_ALARM`]:
//! - each channel's image mean (a z-test, whose resolution must reach the
//!   caller's relative tolerance: a comparison too noisy to see a 1 % energy
//!   error fails as such);
//! - 8x8-pixel block means, where noise averages out but a local error does
//!   not: Σ z² over block channels against χ²(n), for errors spread over
//!   the image, and the largest |z| of any block, for a local one.
//!
//! Each block's t statistic is its difference over its standard error, with
//! Welch–Satterthwaite degrees of freedom from the two sides' batch counts,
//! mapped to a standard normal z by its own distribution's CDF, so the χ²
//! sum is exact for normal batch means whatever the batch counts.
//!
//! Normal batch means need enough samples behind each: single pixels of a
//! caustic are far from it at the sample counts tests afford (rare paths
//! make a batch's mean and its spread low together, so z is skewed
//! negative: glass_caustic at 16 batches of 32 spp gave Σ z² = 4.3 n over
//! pixels), which is why pixels are tested only through their blocks, and
//! why a scene's batches must hold enough samples for its blocks (glass_caustic:
//! Σ z² = 1.05 n over blocks with 8 batches of 512 spp).
#![allow(dead_code)]

use penumbra_render::film::Film;
use penumbra_render::sampling::Sampler;
use penumbra_scene::{load_scene, Overrides};
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal, StudentsT};
use std::path::{Path, PathBuf};

#[path = "../../../../tests/support/skip.rs"]
mod skip;
#[allow(unused_imports)]
pub use skip::{in_ci, skip};

/// Why the Hosek-Wilkie tables of `sunsky` cannot be read (None when they
/// can): they come with an installed Mitsuba, not with Penumbra.
pub fn sunsky_data_missing() -> Option<String> {
    penumbra_scene::sunsky_data::load().err()
}

/// Probability that [`compare`] rejects two unbiased estimates of one image.
pub const FALSE_ALARM: f64 = 1e-4;
/// Side of the square pixel blocks of the block statistics.
pub const BLOCK: u32 = 8;
/// Relative differences of a block below this are not tested: constant
/// pixels (a background seen directly) have no variance, yet renderers'
/// colour conversions and f32 sums differ there in the fifth digit.
const ROUNDING: f64 = 1e-4;

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A rendered image: per-pixel mean and the variance of that mean, from
/// `batches` independent batches.
#[derive(Clone)]
pub struct Estimate {
    pub width: u32,
    pub height: u32,
    pub mean: Vec<[f64; 3]>,
    pub var: Vec<[f64; 3]>,
    /// Number of independent batches behind `var` (its degrees of freedom
    /// are `batches - 1`).
    pub batches: u32,
    /// Per block and channel, the variance of the block's mean estimated
    /// from the batches' block means; `None` for a reference read from disk.
    /// Pixel filters wider than a pixel correlate neighbours, which the sum
    /// of pixel variances misses; this measures it (see [`compare`]).
    pub block_var: Option<Vec<[f64; 3]>>,
}

/// Seed of batch `b` of an estimate seeded `seed`: distinct for every
/// (seed, batch) pair the tests use (fewer than 1000 batches).
fn batch_seed(seed: u64, b: u32) -> u64 {
    seed * 1000 + b as u64
}

/// Renders `batches` independent batches of `spp / batches` samples, each
/// with its own seed and the scene's own sampler (or `sampler`), and
/// estimates each pixel's variance from the spread of the batch means.
/// Batches that were index ranges of one stratified or low-discrepancy
/// pattern would be correlated; independently seeded ones are not.
/// Estimates to be compared with each other must use different seeds.
pub fn render_batches(
    scene: &Path,
    spp: u32,
    batches: u32,
    integrator: Option<&str>,
    sampler: Option<&str>,
    seed: u64,
) -> Estimate {
    assert!(batches >= 2 && spp >= batches, "{}: need at least 2 batches of 1 sample", scene.display());
    let per = spp / batches;
    let ov = Overrides {
        spp: Some(per),
        integrator: integrator.map(str::to_string),
        sampler: sampler.map(str::to_string),
        ..Default::default()
    };
    let mut job = load_scene(scene, &[], &ov).unwrap_or_else(|e| panic!("{e}"));
    let imgs: Vec<Vec<[f32; 3]>> = (0..batches)
        .map(|b| {
            // The sampler as loaded, re-seeded: stratified kinds keep the
            // sample count they rounded `per` to, and every batch renders all of it.
            job.sampler = Sampler::new(job.sampler.kind, batch_seed(seed, b), job.sampler.spp);
            let mut film = Film::new(job.width, job.height);
            job.render_into(&mut film, 0..job.sampler.spp, &|_| {});
            film.develop()
        })
        .collect();
    estimate(job.width, job.height, &imgs)
}

/// [`render_batches`] with the scene's sampler.
pub fn render_with_variance(scene: &Path, spp: u32, batches: u32, integrator: Option<&str>, seed: u64) -> Estimate {
    render_batches(scene, spp, batches, integrator, None, seed)
}

/// [`render_batches`] with another sampler (`--sampler NAME`).
pub fn render_with_sampler(scene: &Path, spp: u32, batches: u32, sampler: &str, seed: u64) -> Estimate {
    render_batches(scene, spp, batches, None, Some(sampler), seed)
}

/// Pixel indices of each `BLOCK`x`BLOCK` block (partial at the right and
/// bottom edges), row by row.
fn blocks(width: u32, height: u32) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    for by in (0..height).step_by(BLOCK as usize) {
        for bx in (0..width).step_by(BLOCK as usize) {
            let mut px = Vec::new();
            for y in by..(by + BLOCK).min(height) {
                for x in bx..(bx + BLOCK).min(width) {
                    px.push((y * width + x) as usize);
                }
            }
            out.push(px);
        }
    }
    out
}

/// Per-pixel mean of equally weighted, independent images, the variance of
/// that mean, and the variance of each block's mean.
pub fn estimate(width: u32, height: u32, imgs: &[Vec<[f32; 3]>]) -> Estimate {
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
    let block_var = blocks(width, height)
        .iter()
        .map(|px| {
            let bm = |im: &Vec<[f32; 3]>, c: usize| px.iter().map(|&i| im[i][c] as f64).sum::<f64>() / px.len() as f64;
            std::array::from_fn(|c| {
                let m = imgs.iter().map(|im| bm(im, c)).sum::<f64>() / k;
                imgs.iter().map(|im| (bm(im, c) - m).powi(2)).sum::<f64>() / (k - 1.0) / k
            })
        })
        .collect();
    Estimate { width, height, mean, var, batches: imgs.len() as u32, block_var: Some(block_var) }
}

/// z² of a difference `d` whose two independent parts have estimated
/// variances `va` and `vb` with `dfa` and `dfb` degrees of freedom: the
/// standard normal deviate with the same tail probability as the Welch t
/// statistic d / √(va + vb) under Welch–Satterthwaite's degrees of freedom.
pub fn welch_z2(d: f64, va: f64, dfa: f64, vb: f64, dfb: f64) -> f64 {
    let v = va + vb;
    let df = (v * v / (va * va / dfa + vb * vb / dfb)).clamp(1.0, 1e6);
    let tail = StudentsT::new(0.0, 1.0, df).unwrap().sf(d.abs() / v.sqrt());
    let z = if tail > 0.0 { Normal::standard().inverse_cdf(tail) } else { f64::NEG_INFINITY };
    z * z
}

/// What [`compare`] found: each statistic and the tests that failed.
#[derive(Debug, Default)]
pub struct Verdict {
    pub failures: Vec<String>,
    /// Σ z² over block channels, its degrees of freedom and critical value.
    pub block_chi2: (f64, usize, f64),
    /// Largest block |z| and its critical value.
    pub block_max: (f64, f64),
    /// Per-channel ratio of block variance to the sum of pixel variances.
    pub kappa: [f64; 3],
}

/// Tests that `a` and `b` estimate the same image (see the module's
/// comment): the per-channel mean z-test, resolving `rel_tol` of the mean,
/// the block χ² and the largest block deviation. Never panics.
pub fn compare(name: &str, a: &Estimate, b: &Estimate, rel_tol: f64) -> Verdict {
    assert_eq!((a.width, a.height), (b.width, b.height), "{name}: resolution");
    let alpha = FALSE_ALARM / 3.0;
    let normal = Normal::standard();
    let mut v = Verdict::default();
    let n = a.mean.len() as f64;

    // Image means: the variance of a mean of pixels is Σ var / n² times the
    // filter's correlation factor κ, measured below on the blocks.
    let blocks = blocks(a.width, a.height);
    for c in 0..3 {
        // κ: how much more the block means vary than independent pixels
        // would (1 for a box filter); the filters are the same on both
        // sides, so it applies to both.
        let (mut measured, mut pixel_sum) = (0.0, 0.0);
        for (bi, px) in blocks.iter().enumerate() {
            let m = px.len() as f64;
            if let Some(bv) = a.block_var.as_ref().or(b.block_var.as_ref()) {
                measured += bv[bi][c];
                let own = if a.block_var.is_some() { a } else { b };
                pixel_sum += px.iter().map(|&i| own.var[i][c]).sum::<f64>() / (m * m);
            }
        }
        v.kappa[c] = if pixel_sum > 0.0 { (measured / pixel_sum).max(1.0) } else { 1.0 };
    }
    let z_mean = -normal.inverse_cdf(alpha / 6.0);
    for c in 0..3 {
        let ma = a.mean.iter().map(|p| p[c]).sum::<f64>() / n;
        let mb = b.mean.iter().map(|p| p[c]).sum::<f64>() / n;
        let se = (v.kappa[c] * (a.var.iter().map(|p| p[c]).sum::<f64>() + b.var.iter().map(|p| p[c]).sum::<f64>()))
            .sqrt()
            / n;
        eprintln!("{name} channel {c}: mean {ma:.5} vs {mb:.5} (se {se:.5}, kappa {:.2})", v.kappa[c]);
        if (ma - mb).abs() > z_mean * se + ROUNDING * mb.abs() {
            v.failures.push(format!(
                "channel {c} mean {ma:.5} vs {mb:.5}: {:.1} se apart (limit {z_mean:.1})",
                (ma - mb).abs() / se
            ));
        }
        // Power: the test must resolve an energy error of `rel_tol`.
        if z_mean * se > rel_tol * mb.abs() {
            v.failures.push(format!(
                "channel {c}: too noisy to resolve a {rel_tol} error in the image mean (se {se:.5} of {mb:.5}): render more samples"
            ));
        }
    }

    // A pixel with no variance on either side (a constant background)
    // must agree to rounding; other pixels enter through their blocks.
    for i in 0..a.mean.len() {
        for c in 0..3 {
            let (ma, mb) = (a.mean[i][c], b.mean[i][c]);
            if a.var[i][c] + b.var[i][c] <= 0.0 && (ma - mb).abs() > 4.0 * ROUNDING * (ma.abs() + mb.abs()) {
                v.failures.push(format!("pixel {i} channel {c}: {ma} vs {mb} with zero variance"));
            }
        }
    }

    // Blocks.
    let (mut sum, mut dof) = (0.0, 0usize);
    let mut all = Vec::new();
    for (bi, px) in blocks.iter().enumerate() {
        let m = px.len() as f64;
        for c in 0..3 {
            let mean_b = px.iter().map(|&i| b.mean[i][c]).sum::<f64>() / m;
            let d = px.iter().map(|&i| a.mean[i][c] - b.mean[i][c]).sum::<f64>() / m;
            // Either side's block variance: measured from its batches when it
            // has them (B - 1 degrees of freedom, correlations included),
            // else κ Σ pixel variances / m² with Satterthwaite's degrees of
            // freedom for a sum of independent pixel estimates.
            let side = |e: &Estimate| -> (f64, f64) {
                match &e.block_var {
                    Some(bv) => (bv[bi][c], (e.batches - 1) as f64),
                    None => {
                        let k = v.kappa[c] / (m * m);
                        let (sum, sq) =
                            px.iter().fold((0.0, 0.0), |(s, q), &i| (s + e.var[i][c], q + e.var[i][c].powi(2)));
                        let df = if sq > 0.0 { sum * sum / sq * (e.batches - 1) as f64 } else { 1e6 };
                        (k * sum, df)
                    }
                }
            };
            let ((va, dfa), (vb, dfb)) = (side(a), side(b));
            // Differences below ROUNDING of the value are not tested.
            let d = d.signum() * (d.abs() - ROUNDING * mean_b.abs()).max(0.0);
            if va + vb <= 0.0 {
                if d != 0.0 {
                    v.failures.push(format!("block {bi} channel {c}: {} vs {mean_b} with zero variance", mean_b + d));
                }
                continue;
            }
            let z2 = welch_z2(d, va, dfa, vb, dfb);
            sum += z2;
            dof += 1;
            all.push((z2, bi, c, mean_b + d, mean_b, va.sqrt(), vb.sqrt()));
        }
    }
    all.sort_by(|x, y| y.0.total_cmp(&x.0));
    let bw = a.width.div_ceil(BLOCK) as usize;
    let describe = |&(z2, bi, c, ma, mb, sa, sb): &(f64, usize, usize, f64, f64, f64, f64)| {
        format!(
            "block at pixel ({}, {}) channel {c}: {ma:.5} vs {mb:.5} (se {sa:.5} and {sb:.5}), z {:.1}",
            (bi % bw) as u32 * BLOCK,
            (bi / bw) as u32 * BLOCK,
            z2.sqrt()
        )
    };
    for worst in all.iter().take(3) {
        eprintln!("{name}: {}", describe(worst));
    }
    let worst = all.first().map_or(0.0, |w| w.0);
    let crit = if dof > 0 { ChiSquared::new(dof as f64).unwrap().inverse_cdf(1.0 - alpha) } else { 0.0 };
    v.block_chi2 = (sum, dof, crit);
    if sum > crit {
        v.failures.push(format!("blocks: chi2 {sum:.0} over {dof} block channels, above {crit:.0}"));
    }
    // Largest block deviation, Bonferroni over the blocks.
    let zmax = -normal.inverse_cdf(alpha / (2.0 * dof.max(1) as f64));
    v.block_max = (worst.sqrt(), zmax);
    if worst.sqrt() > zmax {
        v.failures.push(format!("{}, above {zmax:.1}", describe(&all[0])));
    }
    eprintln!(
        "{name}: block chi2 {:.0}/{} (limit {:.0}), worst block {:.2} (limit {:.2})",
        v.block_chi2.0, v.block_chi2.1, v.block_chi2.2, v.block_max.0, v.block_max.1
    );
    v
}

/// [`compare`], panicking with every failed test.
pub fn assert_agree(name: &str, a: &Estimate, b: &Estimate, rel_tol: f64) -> Verdict {
    let v = compare(name, a, b, rel_tol);
    assert!(v.failures.is_empty(), "{name}: the estimates disagree:\n  {}", v.failures.join("\n  "));
    v
}

/// The three local errors a comparison must catch where they are visible
/// (a lobe a little too wide, a mirrored texture or environment map, 10 %
/// too bright over a fifth of the image), applied to an image.
pub fn injected_errors(e: &Estimate) -> Vec<(&'static str, Estimate)> {
    let (w, h) = (e.width as usize, e.height as usize);
    let at = |x: usize, y: usize| y * w + x;
    // Too wide: a 3x3 box blur over the image (a wider lobe spreads every highlight and edge).
    let mut blur = e.clone();
    for y in 0..h {
        for x in 0..w {
            let mut s = [0.0; 3];
            let mut k = 0.0;
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    for (c, sc) in s.iter_mut().enumerate() {
                        *sc += e.mean[at(xx, yy)][c];
                    }
                    k += 1.0;
                }
            }
            blur.mean[at(x, y)] = s.map(|v| v / k);
        }
    }
    // Mirrored: the image flipped left to right.
    let mut mirror = e.clone();
    for y in 0..h {
        for x in 0..w {
            mirror.mean[at(x, y)] = e.mean[at(w - 1 - x, y)];
            mirror.var[at(x, y)] = e.var[at(w - 1 - x, y)];
        }
    }
    // 10 % too bright in the middle fifth of the rows.
    let mut bright = e.clone();
    for y in 2 * h / 5..3 * h / 5 {
        for x in 0..w {
            bright.mean[at(x, y)] = e.mean[at(x, y)].map(|v| v * 1.1);
        }
    }
    vec![("lobe too wide (3x3 blur)", blur), ("mirrored", mirror), ("10 % too bright over a fifth", bright)]
}

/// `path` with `max_depth` and `options` (`key=value,...`) on
/// tests/scenes/`name`.xml at `spp` (8 batches, seed 3) against its
/// Mitsuba reference, to 2 % of the image mean.
pub fn compare_path(name: &str, max_depth: u32, spp: u32, options: &str) {
    let scene = root().join("tests/scenes").join(format!("{name}.xml"));
    let integrator = format!("path:max_depth={max_depth},{options}");
    let ours = render_with_variance(&scene, spp, 8, Some(&integrator), 3);
    assert_agree(&format!("{name} ({options})"), &ours, &reference(name), 0.02);
}

/// The Mitsuba reference of tests/scenes/`name`.xml (tests/refs/, with its variance image).
pub fn reference(name: &str) -> Estimate {
    let img = penumbra_scene::image_io::read_exr(&root().join("tests/refs").join(format!("{name}.exr"))).unwrap();
    let var = penumbra_scene::image_io::read_exr(&root().join("tests/refs").join(format!("{name}_var.exr"))).unwrap();
    let f = |v: &Vec<[f32; 3]>| v.iter().map(|p| p.map(|c| c as f64)).collect();
    Estimate {
        width: img.width,
        height: img.height,
        mean: f(&img.pixels),
        var: f(&var.pixels),
        batches: manifest_batches(name),
        block_var: None,
    }
}

/// The batch count tools/make_refs.py recorded for `name` in tests/refs/manifest.json.
fn manifest_batches(name: &str) -> u32 {
    let text = std::fs::read_to_string(root().join("tests/refs/manifest.json")).unwrap();
    let entry = &text[text.find(&format!("\"{name}\": {{")).unwrap_or_else(|| panic!("{name} not in manifest.json"))..];
    let field = &entry[entry.find("\"batches\":").unwrap() + 10..];
    field.trim_start().split(|c: char| !c.is_ascii_digit()).next().unwrap().parse().unwrap()
}
