//! AOVs, variance, noise threshold, adaptive sampling and denoising, end to
//! end through the `penumbra` binary on tiny images.

use crate::common;

use crate::common::{bin, ok, read_exr, Exr};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn cornell() -> PathBuf {
    common::cornell()
}

fn tmpdir(name: &str) -> PathBuf {
    common::tmpdir("aov", name)
}

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = bin();
    c.arg("render").arg(scene).arg("-o").arg(out).arg("--quiet").args(extra);
    c
}

/// relMSE of R, G, B against a reference, as `penumbra diff` (ε = 0.01).
#[cfg(feature = "denoise")]
fn rel_mse(a: &Exr, b: &Exr) -> f64 {
    let mut s = 0.0;
    let mut n = 0;
    for c in ["R", "G", "B"] {
        for (x, y) in a.ch(c).iter().zip(b.ch(c)) {
            s += ((x - y) as f64).powi(2) / ((*y as f64).powi(2) + 0.01);
            n += 1;
        }
    }
    s / n as f64
}

/// A camera at the origin looking down +z (fov 10°, 8x8 box-filtered
/// pixels, 4 spp) at `body`, under a constant environment.
fn scene_file(d: &Path, name: &str, body: &str) -> PathBuf {
    scene_with(d, name, body, "box", 8, 4)
}

/// [`scene_file`] with a `res`² film, reconstruction filter `filter` and `spp` samples.
fn scene_with(d: &Path, name: &str, body: &str, filter: &str, res: u32, spp: u32) -> PathBuf {
    let xml = format!(
        r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="10"/>
        <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="{res}"/><integer name="height" value="{res}"/>
            <rfilter type="{filter}"/>
        </film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
    {body}
</scene>"#
    );
    let p = d.join(name);
    fs::write(&p, xml).unwrap();
    p
}

/// A 20x20 square at z = `z`, facing the camera (normal −z).
fn wall(z: f32, bsdf: &str) -> String {
    format!(
        r#"<shape type="rectangle">{bsdf}<transform name="to_world"><scale value="10"/>
        <rotate y="1" angle="180"/><translate z="{z}"/></transform></shape>"#
    )
}

#[test]
fn aov_layers_report_depth_normal_position_and_albedo_also_through_a_mirror() {
    let d = tmpdir("layers");
    let diffuse = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.8"/></bsdf>"#;
    let plane = scene_file(&d, "plane.xml", &wall(3.0, diffuse));
    let out = d.join("plane.exr");
    ok(render(&plane, &out, &["--aov", "albedo,normal,depth,position,variance"]).output().unwrap());
    let e = read_exr(&out);
    assert_eq!(e.size, (8, 8));
    for name in ["R", "albedo.R", "albedo.B", "normal.X", "normal.Z", "depth.Z", "position.Z", "variance.G"] {
        assert!(e.channels.contains_key(name), "{name}");
    }
    let tan = (5f32.to_radians()).tan();
    for i in 0..64 {
        // Box filter: the samples spread over the pixel; depth = 3 / cos θ,
        // between the pixel's nearest and farthest corners.
        let (px, py) = ((i % 8) as f32, (i / 8) as f32);
        let r = |x: f32, y: f32| ((x / 4.0 - 1.0) * tan).hypot((y / 4.0 - 1.0) * tan);
        let (mut lo, mut hi) = (f32::MAX, 0f32);
        for (x, y) in [(px, py), (px + 1.0, py), (px, py + 1.0), (px + 1.0, py + 1.0)] {
            let dz = 3.0 * (1.0 + r(x, y).powi(2)).sqrt();
            lo = lo.min(dz);
            hi = hi.max(dz);
        }
        if (px - 3.5).abs() < 1.0 && (py - 3.5).abs() < 1.0 {
            lo = 3.0; // the pixels around the axis contain the nearest point
        }
        let depth = e.ch("depth.Z")[i];
        assert!(depth >= lo - 1e-4 && depth <= hi + 1e-4, "pixel {i}: depth {depth} not in [{lo}, {hi}]");
        assert!((e.ch("position.Z")[i] - 3.0).abs() < 1e-5);
        let n = [e.ch("normal.X")[i], e.ch("normal.Y")[i], e.ch("normal.Z")[i]];
        assert!(n[0].abs() < 1e-6 && n[1].abs() < 1e-6 && (n[2] + 1.0).abs() < 1e-6, "{n:?}");
        let a = [e.ch("albedo.R")[i], e.ch("albedo.G")[i], e.ch("albedo.B")[i]];
        for (got, want) in a.iter().zip([0.2, 0.5, 0.8]) {
            assert!((got - want).abs() < 1e-5, "albedo {a:?}");
        }
    }

    // A perfect mirror at z = 3 shows a grey wall behind the camera (z = −1,
    // facing +z): albedo and normal are the wall's, depth and position the mirror's.
    let grey = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.3"/></bsdf>"#;
    let back = format!(
        r#"<shape type="rectangle">{grey}<transform name="to_world"><scale value="100"/>
        <translate z="-1"/></transform></shape>"#
    );
    let mirror = scene_file(&d, "mirror.xml", &format!("{}{back}", wall(3.0, r#"<bsdf type="conductor"/>"#)));
    let out = d.join("mirror.exr");
    ok(render(&mirror, &out, &["--aov", "albedo,normal,depth,position"]).output().unwrap());
    let e = read_exr(&out);
    for i in 0..64 {
        assert!((e.ch("albedo.G")[i] - 0.3).abs() < 1e-5, "albedo through the mirror {}", e.ch("albedo.G")[i]);
        assert!((e.ch("normal.Z")[i] - 1.0).abs() < 1e-6);
        assert!((e.ch("position.Z")[i] - 3.0).abs() < 1e-5);
        assert!(e.ch("depth.Z")[i] >= 3.0 - 1e-4 && e.ch("depth.Z")[i] < 3.03);
    }
    // AOVs do not change the beauty image.
    let plain = d.join("plain.exr");
    ok(render(&mirror, &plain, &[]).output().unwrap());
    assert_eq!(read_exr(&plain).ch("G"), e.ch("G"));
    // Unknown names are refused.
    let o = render(&mirror, &plain, &["--aov", "albedo,motion"]).output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("unknown AOV 'motion'"));
    fs::remove_dir_all(&d).ok();
}

/// A 20x20 diffuse wall (reflectance 0.2, 0.5, 0.8) filling a `res`² view
/// under a uniform sky, `spp` samples per pixel, reconstruction filter
/// `filter`: every pixel has the same light-tailed sample distribution (half
/// the sky's directions are behind the wall), independent of where in the
/// pixel a sample lands.
fn sky_wall(d: &Path, filter: &str, res: u32, spp: u32) -> PathBuf {
    let body = wall(3.0, r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.8"/></bsdf>"#);
    scene_with(d, &format!("wall-{filter}.xml"), &body, filter, res, spp)
}

/// Over K seeds: Σ over pixels (`border` pixels from the edges left out) of
/// the empirical variance of each pixel's value, divided by Σ of the variance
/// layer's estimates, per channel, with its standard error. Per seed,
/// a_k = Σ_p (x − x̄)² K/(K−1) and b_k = Σ_p estimate; the ratio Σa/Σb has,
/// by the delta method, the standard error sd(a_k − ratio·b_k) √K / Σb
/// (seeds are independent, so this holds however the filter correlates
/// neighbouring pixels).
///
/// `relative`: each pixel's terms weighted by 1 / (x̄² + 0.01), as the
/// noise threshold weighs them (`Film::pixel_rel_error`), so that dark
/// pixels count as much as they do there.
fn variance_ratio(d: &Path, scene: &Path, extra: &[&str], k: usize, border: usize, relative: bool) -> [(f64, f64); 3] {
    let imgs: Vec<Exr> = (0..k)
        .map(|s| {
            let out = d.join(format!("s{s}.exr"));
            let seed = s.to_string();
            ok(render(scene, &out, &[&["--aov", "variance", "--seed", &seed], extra].concat()).output().unwrap());
            read_exr(&out)
        })
        .collect();
    let (w, h) = imgs[0].size;
    let px: Vec<usize> = (border..h - border).flat_map(|y| (border..w - border).map(move |x| y * w + x)).collect();
    ["R", "G", "B"].map(|c| {
        let vname = format!("variance.{c}");
        let mean: Vec<f64> =
            px.iter().map(|&p| imgs.iter().map(|e| e.ch(c)[p] as f64).sum::<f64>() / k as f64).collect();
        let weight: Vec<f64> = mean.iter().map(|m| if relative { 1.0 / (m * m + 0.01) } else { 1.0 }).collect();
        let a: Vec<f64> = imgs
            .iter()
            .map(|e| {
                px.iter().zip(&mean).zip(&weight).map(|((&p, m), w)| (e.ch(c)[p] as f64 - m).powi(2) * w).sum::<f64>()
                    * k as f64
                    / (k - 1) as f64
            })
            .collect();
        let b: Vec<f64> =
            imgs.iter().map(|e| px.iter().zip(&weight).map(|(&p, w)| e.ch(&vname)[p] as f64 * w).sum()).collect();
        let (sa, sb): (f64, f64) = (a.iter().sum(), b.iter().sum());
        let ratio = sa / sb;
        let sd = (a.iter().zip(&b).map(|(x, y)| (x - ratio * y).powi(2)).sum::<f64>() / (k - 1) as f64).sqrt();
        (ratio, sd * (k as f64).sqrt() / sb)
    })
}

/// For an interior pixel under Mitsuba's default `gaussian` (σ = 0.5,
/// radius 2, g(x) = exp(−x²/2σ²) − exp(−r²/2σ²), applied in x and y) at
/// `spp` uniformly placed samples per pixel, with I_k = ∫ g^k:
/// b = Σw²/(Σw)² → I2²/(spp I1⁴), the inverse of Kish's effective count n,
/// and a = Σw³/(Σw Σw²) → I3²/(spp I1² I2²). Returns (n, a, b).
fn gaussian_weight_moments(spp: f64) -> (f64, f64, f64) {
    let g = |x: f64| ((-2.0 * x * x).exp() - (-8.0f64).exp()).max(0.0);
    let m = 100_000;
    let mut i = [0.0f64; 3];
    for j in 0..m {
        let x = -2.0 + 4.0 * (j as f64 + 0.5) / m as f64;
        for (k, ik) in i.iter_mut().enumerate() {
            *ik += g(x).powi(k as i32 + 1) * 4.0 / m as f64;
        }
    }
    let b = i[1].powi(2) / (spp * i[0].powi(4));
    let a = i[2].powi(2) / (spp * i[0].powi(2) * i[1].powi(2));
    (1.0 / b, a, b)
}

/// The variance layer estimates the variance of each pixel's mean: over K
/// seeds, the empirical variance of the pixel values must match the sum of
/// the estimates (`variance_ratio` R), on a wall where every pixel has the
/// same light-tailed distribution, at 8 spp, 96x96.
///
/// Expected R. The layer is the delta-method variance of the weighted mean
/// R̂ = Σ wL / Σ w, Σ w²(L − R̂)² / (Σ w)², times n/(n − 1) with Kish's
/// n = (Σw)²/Σw². Given the weights, with W = Σw, S_k = Σw^k and L of
/// variance σ² independent of them, E[Σ w²(L − R̂)²] = σ²(S2 − 2 S3/W +
/// S2²/W²), and the layer divides by 1 − 2a + b (a = S3/(W S2), b = S2/W²)
/// to make it unbiased: R = 1 for every filter. `box`: equal weights,
/// a = b = 1/n (n = spp = 8), the familiar n/(n − 1). `gaussian`:
/// a = 0.0531, b = 0.0399 (n = 25.07); the plain n/(n − 1) correction would
/// leave R = (1 − b)/(1 − 2a + b) = 1.0284 (measured 1.0283 ± 0.0031 before
/// the layer divided by 1 − 2a + b), which this test also rejects.
///
/// Threshold: |R − R_expected| < Z·se with Z = 4, a two-sided false-alarm
/// rate of 6.3e-5 per check (R is a sum over 8464 pixels and 40 seeds, near
/// normal); the three channels of this grey-lit wall are proportional, so
/// two independent checks, 1.3e-4 in all.
///
/// Power: the errors guarded against scale the layer by f: n/(n − 1) (the
/// factor applied twice), (n − 1)/n (dropped), 1.5 or 1/1.5, the plain
/// n/(n − 1) under the Gaussian (f = 1.0284), moving R to
/// R_expected/f. The closest is |R − R_expected| = R_expected·δ with
/// δ = 1/n (0.125 for the box, 0.040 for the Gaussian). With
/// se ≤ R_expected·δ/(Z + 3) the check misses such an error with
/// probability at most Φ(−3) = 1.3e-3, so se is asserted below that bound
/// (box: 0.018, measured 0.0023; Gaussian: 0.0059, measured 0.0031); and on
/// the data just measured every such f must fail: |R − R_expected/f| > Z·se/f.
#[test]
fn variance_layer_matches_the_empirical_variance_over_seeds() {
    const K: usize = 40;
    const Z: f64 = 4.0;
    const SPP: u32 = 8;
    let d = tmpdir("variance");
    let (n_gauss, a, b) = gaussian_weight_moments(SPP as f64);
    let configs = [("box", SPP as f64, 1.0), ("gaussian", n_gauss, 1.0)];
    // The n/(n − 1) correction alone, as under a box filter: must fail.
    let kish_only = (1.0 - b) / (1.0 - 2.0 * a + b);
    for (filter, n, expect) in configs {
        let scene = sky_wall(&d, filter, 96, SPP);
        let delta = 1.0 / n;
        let se_max = expect * delta / (Z + 3.0);
        for ((ratio, se), c) in variance_ratio(&d, &scene, &[], K, 2, false).into_iter().zip(["R", "G", "B"]) {
            eprintln!(
                "{filter} {c}: empirical / estimated variance = {ratio:.4} ± {se:.4}, expected {expect:.4} \
                 (n = {n:.2}, se must be <= {se_max:.4})"
            );
            assert!((ratio - expect).abs() < Z * se, "{filter} {c}: ratio {ratio} ± {se}, expected {expect}");
            assert!(se <= se_max, "{filter} {c}: standard error {se} too large to detect a factor 1 + 1/n");
            let plain = if filter == "gaussian" { vec![kish_only] } else { vec![] };
            for f in [n / (n - 1.0), (n - 1.0) / n, 1.5, 1.0 / 1.5].into_iter().chain(plain) {
                assert!(
                    (ratio / f - expect).abs() > Z * se / f,
                    "{filter} {c}: a layer off by {f} would pass ({ratio} / {f} vs {expect} ± {se})"
                );
            }
        }
    }
    fs::remove_dir_all(&d).ok();
}

/// The variance layer counts the light paths' share: in the Cornell box,
/// `path`'s light paths carry the glass sphere's caustic and the light it
/// sends on to the walls and ceiling, and the camera samples there are
/// smooth. Over K seeds (64x64, 32 spp), the empirical variance over the
/// layer's estimates, each pixel weighted as the noise threshold weighs it
/// (`variance_ratio` R, relative), is compared with the same ratio without
/// light paths (R₀, `caustics=false`: the camera samples' layer, whose
/// calibration the test above checks on a light-tailed scene; on this one
/// its fireflies leave R₀ a little below 1 at 32 spp).
///
/// The light paths' part, Σ s² / W², leaves in Σ (E s)² / W², so it may
/// only overestimate: R ≤ R₀ within Z·se (Z = 4, se of the difference of
/// two independent ratios), and it must not overestimate grossly:
/// R > R₀ / 1.5 within Z·se. Measured: R = 0.98, 0.99, 0.92 against R₀ =
/// 0.99, 0.99, 0.96 (se 0.007-0.016). Power: a layer that saw only the
/// camera samples (before the light paths' splats had moments of their
/// own) gave R = 1.22 ± 0.012 against R₀ = 0.99 ± 0.007 in red, and fails
/// the first check.
#[test]
fn variance_layer_counts_the_light_paths() {
    const K: usize = 40;
    const Z: f64 = 4.0;
    let d = tmpdir("variance-light-paths");
    let args = ["-D", "res=64", "-D", "spp=32"];
    let on = variance_ratio(&d, &cornell(), &args, K, 2, true);
    let off =
        variance_ratio(&d, &cornell(), &[&args[..], &["--integrator", "path:caustics=false"]].concat(), K, 2, true);
    for (((r, se), (r0, se0)), c) in on.into_iter().zip(off).zip(["R", "G", "B"]) {
        let se_diff = (se * se + se0 * se0).sqrt();
        eprintln!("Cornell box {c}: R = {r:.4} ± {se:.4} with light paths, R0 = {r0:.4} ± {se0:.4} without");
        assert!(r - r0 < Z * se_diff, "{c}: the layer misses light paths' variance: R {r} ± {se}, R0 {r0} ± {se0}");
        assert!(r - r0 / 1.5 > -Z * se_diff, "{c}: the layer overestimates 1.5-fold: R {r} ± {se}, R0 {r0} ± {se0}");
    }
    fs::remove_dir_all(&d).ok();
}

#[test]
fn noise_threshold_stops_earlier_on_an_easier_scene() {
    let d = tmpdir("threshold");
    // Easy: a diffuse wall under a uniform sky (only the bounce direction varies).
    let easy =
        scene_file(&d, "easy.xml", &wall(3.0, r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>"#));
    let spp_of = |scene: &Path, extra: &[&str]| {
        let out = d.join("t.exr");
        ok(render(scene, &out, &[&["--spp", "256", "--noise-threshold", "0.002"], extra].concat()).output().unwrap());
        let e = read_exr(&out);
        let est: f64 = e.meta["relErrorEstimate"].parse().unwrap();
        (e.meta["spp"].parse::<u32>().unwrap(), est, e.meta["complete"].clone())
    };
    let (spp_easy, est_easy, done) = spp_of(&easy, &[]);
    assert_eq!(done, "yes");
    assert!(est_easy <= 0.002);
    let (spp_hard, est_hard, _) = spp_of(&cornell(), &["-D", "res=16"]);
    eprintln!(
        "threshold 0.002: easy scene {spp_easy} spp ({est_easy:.2e}), Cornell box {spp_hard} spp ({est_hard:.2e})"
    );
    assert!(spp_easy >= 16 && spp_easy < spp_hard, "{spp_easy} vs {spp_hard}");
    fs::remove_dir_all(&d).ok();
}

fn signal(pid: u32, sig: &str) {
    let _ = Command::new("kill").arg(format!("-{sig}")).arg(pid.to_string()).status();
}

/// Adaptive decisions are a pure function of the film after the previous
/// pass, which a checkpoint holds: killed and resumed, the render is bitwise
/// the uninterrupted one, and it differs from the non-adaptive render.
#[test]
fn adaptive_render_killed_and_resumed_is_bitwise_the_uninterrupted_one() {
    let d = tmpdir("adaptive");
    let args = [
        "-D",
        "res=40",
        "--spp",
        "96",
        "--seed",
        "11",
        "--max-pass-spp",
        "2",
        "--noise-threshold",
        "0.01",
        "--adaptive",
        "--aov",
        "albedo,variance",
    ];
    let reference = d.join("ref.exr");
    let t0 = Instant::now();
    ok(render(&cornell(), &reference, &args).output().unwrap());
    let t_ref = t0.elapsed().as_secs_f64();
    let want = read_exr(&reference);
    let fixed = d.join("fixed.exr");
    ok(render(&cornell(), &fixed, &args[..8]).output().unwrap());
    assert_ne!(read_exr(&fixed).ch("G"), want.ch("G"), "adaptive sampling changed nothing");

    let (out, ck) = (d.join("out.exr"), d.join("render.ck"));
    let ck_args: Vec<&str> =
        [&args[..], &["--checkpoint", ck.to_str().unwrap(), "--checkpoint-every", "0.01", "--keep-checkpoint"]]
            .concat();
    let mut x: u64 = 77;
    let mut rnd = move || {
        x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut interrupted = 0;
    for round in 0..=12 {
        let mut child = render(&cornell(), &out, &ck_args).stderr(Stdio::piped()).spawn().unwrap();
        if round < 12 {
            // Early in a full render's time (as production.rs): later kills often
            // come after a run has already completed the render.
            std::thread::sleep(Duration::from_secs_f64(rnd() * 0.15 * t_ref));
            if rnd() < 0.5 {
                signal(child.id(), "TERM");
            } else {
                child.kill().unwrap();
            }
        }
        let o = child.wait_with_output().unwrap();
        let _ = fs::remove_file(d.join("render.ck.tmp"));
        interrupted += (!o.status.success()) as u32;
    }
    assert!(interrupted >= 4, "only {interrupted} runs interrupted");
    let got = read_exr(&out);
    for c in ["R", "G", "B", "albedo.R", "variance.G"] {
        let bits = |e: &Exr| e.ch(c).iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert!(bits(&got) == bits(&want), "{c} differs after {interrupted} interruptions");
    }
    fs::remove_dir_all(&d).ok();
}

/// What [`expectation_against_fixed_spp`] found.
struct ExpectationCheck {
    /// Per channel: (difference of the image means, its standard error).
    image_mean: [(f64, f64); 3],
    /// The largest per-pixel |difference| / standard error: (|z|, pixel, channel).
    worst_pixel: (f64, usize, usize),
    /// The spp each render with `extra` stopped at.
    stop_spp: Vec<u32>,
}

/// The Cornell box at 24x24 (default gaussian filter): K renders with
/// `--spp 128` and `extra` (seeds 0..K) against K fixed-spp renders at
/// `--spp fixed_spp` (seeds 1000..1000+K, independent of the first). Both image sets estimate the
/// same expectation when `extra` keeps the estimator unbiased; per pixel and
/// for the image mean, the difference of the two means over seeds is
/// compared with its standard error from the spread over seeds,
/// √(s_a²/K + s_f²/K).
fn expectation_against_fixed_spp(name: &str, extra: &[&str], fixed_spp: u32, k: u64) -> ExpectationCheck {
    let d = tmpdir(name);
    let images = |seed0: u64, spp: &str, extra: &[&str]| -> (Vec<[Vec<f32>; 3]>, Vec<u32>) {
        let base = ["-D", "res=24", "--spp", spp];
        (0..k)
            .map(|s| {
                let out = d.join(format!("s{}.exr", seed0 + s));
                let seed = (seed0 + s).to_string();
                let args = [&base[..], extra, &["--seed", &seed]].concat();
                ok(render(&cornell(), &out, &args).output().unwrap());
                let e = read_exr(&out);
                let spp: u32 = e.meta["samples"].split("..").nth(1).unwrap().parse().unwrap();
                (["R", "G", "B"].map(|c| e.ch(c).to_vec()), spp)
            })
            .unzip()
    };
    let (a, stop_spp) = images(0, "128", extra);
    let (f, _) = images(1000, &fixed_spp.to_string(), &[]);
    let kf = k as f64;
    let mean_var = |v: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = v.collect();
        let m = v.iter().sum::<f64>() / kf;
        (m, v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (kf - 1.0) / kf)
    };
    let n = a[0][0].len();
    let mut worst_pixel = (0.0f64, 0, 0);
    let image_mean = [0, 1, 2].map(|c| {
        for p in 0..n {
            let (ma, va) = mean_var(&mut a.iter().map(|img| img[c][p] as f64));
            let (mf, vf) = mean_var(&mut f.iter().map(|img| img[c][p] as f64));
            if va + vf > 0.0 {
                let z = (ma - mf).abs() / (va + vf).sqrt();
                if z > worst_pixel.0 {
                    worst_pixel = (z, p, c);
                }
            }
        }
        let img_mean = |img: &[Vec<f32>; 3]| img[c].iter().map(|&x| x as f64).sum::<f64>() / n as f64;
        let (ma, va) = mean_var(&mut a.iter().map(img_mean));
        let (mf, vf) = mean_var(&mut f.iter().map(img_mean));
        eprintln!(
            "{name} channel {c}: image mean {ma:.5} vs fixed spp {mf:.5}, z = {:+.2}",
            (ma - mf) / (va + vf).sqrt()
        );
        (ma - mf, (va + vf).sqrt())
    });
    let (z, p, c) = worst_pixel;
    eprintln!(
        "{name}: largest per-pixel |z| {z:.2} at pixel ({}, {}) channel {c}; stopped at {}..={} spp",
        p % 24,
        p / 24,
        stop_spp.iter().min().unwrap(),
        stop_spp.iter().max().unwrap()
    );
    fs::remove_dir_all(&d).ok();
    ExpectationCheck { image_mean, worst_pixel, stop_spp }
}

/// Thresholds for [`expectation_against_fixed_spp`] with K = 64 seeds per
/// side: each z is a Welch t statistic with at least 63 degrees of freedom.
/// Image means: |z| < 4.2, two-sided 8.6e-5 under t(63), 2.6e-4 for three
/// channels. Pixels: max |z| < 5.7, two-sided 3.4e-7 each, at most 5.9e-4
/// for the 1728 pixel channels (Bonferroni, which neighbouring pixels'
/// correlation under the filter only makes more conservative). Together a
/// false-alarm rate below 1e-3. A bias beyond (4.2 + 3)·se in the image
/// mean, or (5.7 + 3)·se in one pixel, fails with probability ≥ 0.9987.
const EXPECTATION_K: u64 = 64;
fn assert_same_expectation(name: &str, r: &ExpectationCheck) {
    for (c, (diff, se)) in r.image_mean.iter().enumerate() {
        assert!(diff.abs() < 4.2 * se, "{name}: channel {c} image mean differs by {diff:+.5} ({:+.2} se)", diff / se);
    }
    let (z, p, c) = r.worst_pixel;
    assert!(z < 5.7, "{name}: pixel ({}, {}) channel {c} differs by {z:.2} se", p % 24, p / 24);
}

/// `--noise-threshold` stops the whole render at the first pass whose
/// estimated error is at most X: a stopping time that depends on the
/// samples. The images must still have the fixed-spp render's expectation
/// (thresholds at [`EXPECTATION_K`]; against 64 fixed spp, cheaper, so the
/// image mean resolves a bias beyond 7.2 se ≈ 0.0045, 1.6 % of R). X = 0.01
/// stops the 64 seeds between 28 and 92 spp, so the rule is exercised
/// (asserted). Measured: image means within 0.3 se, worst pixel 3.5 se.
#[test]
fn noise_threshold_stop_keeps_the_expectation_of_the_fixed_spp_render() {
    let extra = ["--max-pass-spp", "4", "--noise-threshold", "0.01"];
    let r = expectation_against_fixed_spp("threshold-expectation", &extra, 64, EXPECTATION_K);
    let (lo, hi) = (*r.stop_spp.iter().min().unwrap(), *r.stop_spp.iter().max().unwrap());
    assert!(lo < hi && hi < 128, "the stopping rule is not exercised: {lo}..={hi} spp");
    assert_same_expectation("noise threshold", &r);
}

/// `--adaptive` renders, after 16 spp, only the pixels whose own estimated
/// error is above X (and their neighbours): the adaptive images must have
/// the fixed-spp render's expectation (thresholds at [`EXPECTATION_K`]).
/// X = 0.003 with a cap of 128 spp: the image never reaches X as a whole,
/// so every difference comes from the per-pixel decisions.
///
/// Fails with the adaptive sampling of this revision: image means 5.1, 4.3
/// and 3.0 se low (R, G, B; −1.3 % in R), a pixel 6.1 se off (100 seeds:
/// 7.6, 6.5, 5.0 se and 8.6 se; with a box filter still 5.1, 4.1, 3.1 se
/// low, but no pixel beyond 3.5 se). Two
/// causes: a pixel stops when its estimated variance is low, which for
/// skewed (caustic) samples correlates with a low mean; and under a filter
/// wider than a pixel a stopped pixel keeps receiving the samples of active
/// neighbours, which weights its value towards their side.
#[test]
#[ignore = "adaptive sampling is biased (Cornell box: image means 3-5 se low, a pixel 6 se off); see the doc comment"]
fn adaptive_render_has_the_expectation_of_the_fixed_spp_render() {
    let extra = ["--max-pass-spp", "4", "--noise-threshold", "0.003", "--adaptive"];
    let r = expectation_against_fixed_spp("adaptive-expectation", &extra, 128, EXPECTATION_K);
    assert!(r.stop_spp.iter().all(|&s| s == 128), "the image reached the threshold: {:?}", r.stop_spp);
    assert_same_expectation("adaptive", &r);
}

#[test]
fn parts_carry_aovs_and_variance_into_the_merge() {
    let d = tmpdir("parts");
    let args = ["-D", "res=24", "--spp", "12", "--seed", "5", "--aov", "albedo,depth,variance"];
    let single = d.join("single.exr");
    ok(render(&cornell(), &single, &args).output().unwrap());
    let parts: Vec<PathBuf> = (0..3)
        .map(|i| {
            let p = d.join(format!("p{i}.exr"));
            ok(render(&cornell(), &p, &[&args[..], &["--part", &format!("{i}/3")]].concat()).output().unwrap());
            p
        })
        .collect();
    let merged = d.join("merged.exr");
    ok(bin().arg("merge").args(&parts).arg("-o").arg(&merged).output().unwrap());
    let (m, s) = (read_exr(&merged), read_exr(&single));
    for c in ["R", "albedo.G", "depth.Z", "variance.R", "variance.B"] {
        let worst =
            m.ch(c).iter().zip(s.ch(c)).map(|(a, b)| ((a - b).abs() / b.abs().max(1e-6)) as f64).fold(0.0, f64::max);
        assert!(worst < 1e-4, "{c}: relative difference {worst}");
    }
    assert!(!m.channels.keys().any(|k| k.starts_with("penumbra.")), "merged image keeps part channels");
    // Adaptive or noise-stopped parts would not add up: refused.
    let o = render(&cornell(), &d.join("x.exr"), &[&args[..], &["--part", "0/2", "--noise-threshold", "0.1"]].concat())
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot be combined with --part"));
    fs::remove_dir_all(&d).ok();
}

#[cfg(not(feature = "denoise"))]
#[test]
fn denoise_without_the_feature_says_how_to_get_it() {
    let d = tmpdir("nodenoise");
    let o = render(&cornell(), &d.join("x.exr"), &["-D", "res=8", "--spp", "1", "--denoise"]).output().unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--features denoise"));
    fs::remove_dir_all(&d).ok();
}

/// Open Image Denoise with albedo and normal guides lowers the relMSE of a
/// noisy 4 spp Cornell box against a 512 spp reference; `penumbra denoise`
/// of a box-filtered render gives the same image as `render --denoise`
/// (which uses the box filter), and keeps the noisy one.
#[cfg(feature = "denoise")]
#[test]
fn denoising_lowers_the_error_of_a_noisy_cornell_box() {
    let d = tmpdir("denoise");
    let res = ["-D", "res=64", "--seed", "3"];
    let reference = d.join("ref.exr");
    ok(render(&cornell(), &reference, &[&res[..], &["--spp", "512"]].concat()).output().unwrap());
    // The same scene with the box filter (the bundled one has no rfilter,
    // i.e. Mitsuba's Gaussian; it refers to no other files, so it can move).
    let boxed = d.join("box.xml");
    let xml = fs::read_to_string(cornell()).unwrap();
    let with_box = xml.replace("<film type=\"hdrfilm\">", "<film type=\"hdrfilm\">\n<rfilter type=\"box\"/>");
    assert_ne!(xml, with_box);
    fs::write(&boxed, with_box).unwrap();
    let noisy = d.join("noisy.exr");
    ok(render(&boxed, &noisy, &[&res[..], &["--spp", "4", "--aov", "albedo,normal"]].concat()).output().unwrap());
    let den = d.join("den.exr");
    ok(bin().arg("denoise").arg(&noisy).arg("-o").arg(&den).output().unwrap());
    let direct = d.join("direct.exr");
    ok(render(&cornell(), &direct, &[&res[..], &["--spp", "4", "--denoise"]].concat()).output().unwrap());
    let (r, n, dn, dr) = (read_exr(&reference), read_exr(&noisy), read_exr(&den), read_exr(&direct));
    let (e_noisy, e_den) = (rel_mse(&n, &r), rel_mse(&dn, &r));
    eprintln!("relMSE 4 spp: noisy {e_noisy:.4}, denoised {e_den:.4}");
    assert!(e_den < 0.5 * e_noisy, "{e_den} vs {e_noisy}");
    assert_eq!(dn.ch("noisy.G"), n.ch("G"));
    let diff = dr.ch("G").iter().zip(dn.ch("G")).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
    assert!(diff < 1e-3, "render --denoise and penumbra denoise differ by {diff}");
    assert!(dr.meta["denoised"].contains("albedo+normal"));
    fs::remove_dir_all(&d).ok();
}
