//! Multichannel outputs against Mitsuba 3.9.1: the `aov` integrator's
//! channels (tests/scenes/aov_channels.xml) and the `moment` integrator's
//! (tests/scenes/moment_cbox.xml), read by name from references that
//! tools/make_channel_refs.py writes (batches of single `mi.render` calls of
//! the same sample count as ours, since `duv_dx` scales with it).
//!
//! Each channel is compared by the z statistic of its image mean and of
//! every 8x8 block's mean (Welch's t with the two sides' batch counts,
//! mapped to a normal deviate, as `common::compare`), at a family-wise
//! false-alarm rate of `common::FALSE_ALARM` (Bonferroni over every channel
//! and block: valid however the channels correlate). Differences below
//! 1e-4 of the value are rounding (flat surfaces give every sample the same
//! normal, with no variance to compare against). Each test also shows its
//! power: a 2 % error injected into one channel must fail it.

use crate::common::{root, welch_z2, FALSE_ALARM};
use penumbra_render::film::{Film, FilmLayers};
use penumbra_render::sampling::Sampler;
use penumbra_scene::image_io::read_exr_channels;
use penumbra_scene::{load_scene, Overrides};
use statrs::distribution::{ContinuousCDF, Normal};
use std::collections::HashMap;

/// Per-pixel means and variances of the mean, by channel name.
struct Channels {
    width: u32,
    height: u32,
    mean: HashMap<String, Vec<f64>>,
    var: HashMap<String, Vec<f64>>,
    batches: u32,
}

fn manifest_field(name: &str, field: &str) -> u32 {
    let text = std::fs::read_to_string(root().join("tests/refs/manifest.json")).unwrap();
    let entry = &text[text.find(&format!("\"{name}\": {{")).unwrap_or_else(|| panic!("{name} not in manifest.json"))..];
    let f = &entry[entry.find(&format!("\"{field}\":")).unwrap() + field.len() + 3..];
    f.trim_start().split(|c: char| !c.is_ascii_digit()).next().unwrap().parse().unwrap()
}

fn reference(name: &str) -> Channels {
    let read = |suffix: &str| {
        let (w, h, ch) = read_exr_channels(&root().join("tests/refs").join(format!("{name}{suffix}.exr"))).unwrap();
        (w, h, ch.into_iter().map(|(n, v)| (n, v.into_iter().map(f64::from).collect())).collect::<HashMap<_, _>>())
    };
    let (width, height, mean) = read("");
    let (_, _, var) = read("_var");
    Channels { width, height, mean, var, batches: manifest_field(name, "batches") }
}

/// Renders `batches` batches of `batch_spp` samples (seeds apart from the
/// reference's), the beauty as channels R, G, B beside the integrator's.
fn render(name: &str, batch_spp: u32, batches: u32, seed: u64) -> Channels {
    render_films(name, batch_spp, batches, seed).0
}

/// [`render`], with the batches' films.
fn render_films(name: &str, batch_spp: u32, batches: u32, seed: u64) -> (Channels, Vec<Film>) {
    let scene = root().join("tests/scenes").join(format!("{name}.xml"));
    let ov = Overrides { spp: Some(batch_spp), ..Default::default() };
    let mut job = load_scene(&scene, &[], &ov).unwrap_or_else(|e| panic!("{e}"));
    let names = job.integrator.channel_names();
    let layers = FilmLayers { channels: names.clone(), ..Default::default() };
    let mut all: HashMap<String, Vec<Vec<f64>>> = HashMap::new();
    let mut films = Vec::new();
    for b in 0..batches {
        job.sampler = Sampler::new(job.sampler.kind, seed * 1000 + b as u64, job.sampler.spp);
        let mut film = Film::with_layers(job.width, job.height, &layers);
        job.render_into(&mut film, 0..job.sampler.spp, &|_| {});
        let rgb = film.develop();
        for (c, n) in ["R", "G", "B"].iter().enumerate() {
            all.entry(n.to_string()).or_default().push(rgb.iter().map(|p| p[c] as f64).collect());
        }
        for (c, n) in names.iter().enumerate() {
            all.entry(n.clone()).or_default().push(film.develop_channel(c).into_iter().map(f64::from).collect());
        }
        films.push(film);
    }
    let (mut mean, mut var) = (HashMap::new(), HashMap::new());
    let k = batches as f64;
    for (n, imgs) in all {
        let m: Vec<f64> = (0..imgs[0].len()).map(|i| imgs.iter().map(|im| im[i]).sum::<f64>() / k).collect();
        let v =
            (0..m.len()).map(|i| imgs.iter().map(|im| (im[i] - m[i]).powi(2)).sum::<f64>() / (k * (k - 1.0))).collect();
        mean.insert(n.clone(), m);
        var.insert(n, v);
    }
    (Channels { width: job.width, height: job.height, mean, var, batches }, films)
}

/// Channel names compared, and the z statistics beyond the Bonferroni bound.
fn compare(ours: &Channels, reference: &Channels, channels: &[String]) -> Vec<String> {
    assert_eq!((ours.width, ours.height), (reference.width, reference.height));
    let (w, h) = (ours.width as usize, ours.height as usize);
    let mut regions: Vec<Vec<usize>> = vec![(0..w * h).collect()];
    for by in (0..h).step_by(8) {
        for bx in (0..w).step_by(8) {
            regions.push((by..(by + 8).min(h)).flat_map(|y| (bx..(bx + 8).min(w)).map(move |x| y * w + x)).collect());
        }
    }
    let tests = (channels.len() * regions.len()) as f64;
    let z_max = -Normal::standard().inverse_cdf(FALSE_ALARM / (2.0 * tests));
    let (dfa, dfb) = ((ours.batches - 1) as f64, (reference.batches - 1) as f64);
    let mut failures = Vec::new();
    for c in channels {
        let (ma, va) = (&ours.mean[c], &ours.var[c]);
        let (Some(mb), Some(vb)) = (reference.mean.get(c), reference.var.get(c)) else {
            failures.push(format!("{c}: not in the reference"));
            continue;
        };
        for (r, region) in regions.iter().enumerate() {
            // Pixels Mitsuba leaves NaN (uv partials where the ray escapes) are skipped.
            let px: Vec<usize> = region.iter().copied().filter(|&i| mb[i].is_finite() && ma[i].is_finite()).collect();
            if px.is_empty() {
                continue;
            }
            let n = px.len() as f64;
            let (a, b) = (px.iter().map(|&i| ma[i]).sum::<f64>() / n, px.iter().map(|&i| mb[i]).sum::<f64>() / n);
            let (sa, sb) =
                (px.iter().map(|&i| va[i]).sum::<f64>() / (n * n), px.iter().map(|&i| vb[i]).sum::<f64>() / (n * n));
            let d = a - b;
            if d.abs() <= 1e-4 * (1.0 + a.abs().max(b.abs())) {
                continue;
            }
            let z = if sa + sb > 0.0 { welch_z2(d, sa, dfa, sb, dfb).sqrt() } else { f64::INFINITY };
            if z > z_max {
                let what = if r == 0 { "image mean".to_string() } else { format!("block {}", r - 1) };
                failures.push(format!("{c} {what}: ours {a:.5} Mitsuba {b:.5}, z {z:.1} > {z_max:.1}"));
            }
        }
    }
    failures
}

/// Prints each channel's image-mean deviation and z (the agreement figures).
fn report(ours: &Channels, reference: &Channels, channels: &[String]) {
    for c in channels {
        let (ma, mb) = (&ours.mean[c], &reference.mean[c]);
        let px: Vec<usize> = (0..ma.len()).filter(|&i| mb[i].is_finite()).collect();
        let n = px.len() as f64;
        let a = px.iter().map(|&i| ma[i]).sum::<f64>() / n;
        let b = px.iter().map(|&i| mb[i]).sum::<f64>() / n;
        let s = (px.iter().map(|&i| ours.var[c][i] + reference.var[c][i]).sum::<f64>()).sqrt() / n;
        eprintln!("{c:14} ours {a:10.5} Mitsuba {b:10.5} diff {:+.2e} z {:+.2}", a - b, (a - b) / s);
    }
}

fn aov_channel_names() -> Vec<String> {
    let scene = root().join("tests/scenes/aov_channels.xml");
    load_scene(&scene, &[], &Overrides::default()).unwrap().integrator.channel_names()
}

/// Every AOV type against Mitsuba, channels found by name; the nested
/// path tracer's image is the beauty; shape indices partition the image
/// as Mitsuba's do (its numbering is its own).
#[test]
fn aov_channels_match_mitsuba() {
    let reference = reference("aov_channels");
    let spp = manifest_field("aov_channels", "spp_per_batch");
    let ours = render("aov_channels", spp, 16, 7);
    let names = aov_channel_names();
    // Mitsuba's order: the nested image, then the AOVs in the string's order.
    let expect = "my_image.R my_image.G my_image.B my_image.A alb.R alb.G alb.B dd.y.T pos.X pos.Y pos.Z tex.U tex.V \
                  gn.X gn.Y gn.Z nn.X nn.Y nn.Z su.X su.Y su.Z sv.X sv.Y sv.Z dx.U dx.V dy.U dy.V prim.I shape.I";
    assert_eq!(names, expect.split_whitespace().collect::<Vec<_>>());
    let mut theirs: Vec<&String> = reference.mean.keys().filter(|k| !["R", "G", "B"].contains(&k.as_str())).collect();
    theirs.sort();
    let mut ours_sorted: Vec<&String> = names.iter().collect();
    ours_sorted.sort();
    assert_eq!(ours_sorted, theirs, "the same channel names as Mitsuba's EXR");
    for c in ["R", "G", "B"] {
        assert_eq!(ours.mean[c], ours.mean[&format!("my_image.{c}")], "the beauty is the nested image");
    }
    let compared: Vec<String> = names.iter().filter(|n| *n != "shape.I").cloned().collect();
    report(&ours, &reference, &compared);
    let failures = compare(&ours, &reference, &compared);
    assert!(failures.is_empty(), "aov_channels differs from Mitsuba:\n{}", failures.join("\n"));

    // shape.I: on pixels that saw one shape only, ours determines Mitsuba's and back.
    let (a, b) = (&ours.mean["shape.I"], &reference.mean["shape.I"]);
    let mut map: HashMap<i64, i64> = HashMap::new();
    let mut back: HashMap<i64, i64> = HashMap::new();
    for i in 0..a.len() {
        if a[i].fract() == 0.0 && b[i].fract() == 0.0 && ours.var["shape.I"][i] == 0.0 {
            assert_eq!(*map.entry(a[i] as i64).or_insert(b[i] as i64), b[i] as i64, "pixel {i}");
            assert_eq!(*back.entry(b[i] as i64).or_insert(a[i] as i64), a[i] as i64, "pixel {i}");
        }
    }
    assert!(map.len() >= 6, "the scene shows 5 shapes and the background: {map:?}");

    // Power: 2 % more albedo, or uv partials not scaled by 1/√spp, must fail.
    for (c, f) in [("alb.G", 1.02), ("dx.V", (spp as f64).sqrt())] {
        let mut mean = ours.mean.clone();
        mean.get_mut(c).unwrap().iter_mut().for_each(|v| *v *= f);
        let bad = Channels { mean, var: ours.var.clone(), ..ours };
        assert!(!compare(&bad, &reference, &compared).is_empty(), "{c} × {f} was not caught");
    }
}

/// Builds `integrator` in a minimal scene: the error, if any.
fn integrator_error(integrator: &str) -> Option<String> {
    let xml = format!(
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n{integrator}\n</scene>"
    );
    let desc = penumbra_scene::mitsuba::parse_str(&xml, std::path::Path::new("int.xml"), &[]).unwrap();
    penumbra_scene::builder::build(&desc, &Overrides::default()).err().map(|e| e.to_string())
}

#[test]
fn bad_aov_and_moment_parameters_are_errors_at_their_line() {
    let cases: &[(&str, &[&str])] = &[
        (r#"<integrator type="aov"/>"#, &["int.xml:3", "'aovs' is required"]),
        (
            r#"<integrator type="aov"><string name="aovs" value="dd:dpeth"/></integrator>"#,
            &["int.xml:3", "dpeth", "sh_normal"],
        ),
        (r#"<integrator type="aov"><string name="aovs" value="depth"/></integrator>"#, &["int.xml:3", "<name>:<type>"]),
        (
            r#"<integrator type="aov"><string name="aovs" value="a:b:depth"/></integrator>"#,
            &["int.xml:3", "<name>:<type>"],
        ),
        (
            r#"<integrator type="aov"><string name="aovs" value="d:depth"/><integer name="max_depth" value="3"/></integrator>"#,
            &["int.xml:3", "max_depth"],
        ),
        (
            r#"<integrator type="aov"><string name="aovs" value="d:depth"/><integrator type="path"><float name="rr" value="1"/></integrator></integrator>"#,
            &["int.xml:3", "'rr'"],
        ),
        (
            r#"<integrator type="aov"><string name="aovs" value="d:depth"/><bsdf type="diffuse"/></integrator>"#,
            &["int.xml:3", "bsdf"],
        ),
        (r#"<integrator type="moment"/>"#, &["int.xml:3", "nested integrator"]),
        (
            r#"<integrator type="moment"><integrator type="path"><integer name="max_depth" value="-2"/></integrator></integrator>"#,
            &["int.xml:3", "max_depth"],
        ),
    ];
    for (xml, want) in cases {
        let e = integrator_error(xml).unwrap_or_else(|| panic!("{xml} was accepted"));
        for w in *want {
            assert!(e.contains(w), "{xml}: '{e}' lacks '{w}'");
        }
    }
    assert!(integrator_error(r#"<integrator type="aov"><string name="aovs" value=""/></integrator>"#).is_none());
}

/// Unnamed nested integrators are `_arg_0`, `_arg_1`, ... as Mitsuba names them.
#[test]
fn unnamed_nested_integrators_get_mitsubas_names() {
    let xml = r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"/></sensor>
        <integrator type="moment"><integrator type="path"/><integrator type="depth" name="d"/><integrator type="direct"/></integrator></scene>"#;
    let desc = penumbra_scene::mitsuba::parse_str(xml, std::path::Path::new("m.xml"), &[]).unwrap();
    let job = penumbra_scene::builder::build(&desc, &Overrides::default()).unwrap();
    let names = job.integrator.channel_names();
    let first: Vec<&str> = names[..9].iter().map(String::as_str).collect();
    assert_eq!(first, ["_arg_0.X", "_arg_0.Y", "_arg_0.Z", "d.X", "d.Y", "d.Z", "_arg_1.X", "_arg_1.Y", "_arg_1.Z"]);
    assert_eq!(names[9], "m2__arg_0.X");
    assert_eq!(names.len(), 18);
}

/// `moment` around `path` and `direct` against Mitsuba, every channel by
/// name; and its second moments against the relation m2 = mean² + σ²: with
/// the box filter a pixel's n samples weigh alike, so (m2 − mean²)/(n − 1)
/// estimates σ²/n, the variance of the pixel mean, which the spread of the
/// independent batches' means measures too. Summed over pixels the two must
/// agree within 4.5 standard errors (from the per-pixel differences; pixels
/// are independent under the box filter); m2 − mean² 10 % too large must not.
#[test]
fn moment_channels_match_mitsuba_and_second_moments_hold() {
    let name = "moment_cbox";
    let reference = reference(name);
    let spp = manifest_field(name, "spp_per_batch");
    let batches = 64;
    let (ours, films) = render_films(name, spp, batches, 11);
    let scene = root().join("tests/scenes").join(format!("{name}.xml"));
    let names = load_scene(&scene, &[], &Overrides::default()).unwrap().integrator.channel_names();
    let expect = "p.X p.Y p.Z d.X d.Y d.Z m2_p.X m2_p.Y m2_p.Z m2_d.X m2_d.Y m2_d.Z";
    assert_eq!(names, expect.split_whitespace().collect::<Vec<_>>());
    let mut compared = names.clone();
    compared.extend(["R", "G", "B"].map(String::from));
    report(&ours, &reference, &compared);
    let failures = compare(&ours, &reference, &compared);
    assert!(failures.is_empty(), "{name} differs from Mitsuba:\n{}", failures.join("\n"));
    // Power: a second moment 5 % off must fail.
    let mut mean = ours.mean.clone();
    mean.get_mut("m2_d.Y").unwrap().iter_mut().for_each(|v| *v *= 1.05);
    let bad = Channels { mean, var: ours.var.clone(), ..ours };
    assert!(!compare(&bad, &reference, &compared).is_empty(), "m2_d.Y × 1.05 was not caught");

    // The relation, from the batches themselves.
    let relation = |scale: f64| -> Vec<(String, f64)> {
        let mut out = Vec::new();
        for c in ["p.X", "p.Y", "p.Z", "d.X", "d.Y", "d.Z"] {
            let (i, j) = (
                names.iter().position(|n| n == c).unwrap(),
                names.iter().position(|n| *n == format!("m2_{c}")).unwrap(),
            );
            let mean: Vec<Vec<f64>> =
                films.iter().map(|f| f.develop_channel(i).into_iter().map(f64::from).collect()).collect();
            let m2: Vec<Vec<f64>> =
                films.iter().map(|f| f.develop_channel(j).into_iter().map(f64::from).collect()).collect();
            let (k, n) = (batches as f64, spp as f64);
            // Per pixel: from the moments, and from the batch spread.
            let d: Vec<f64> = (0..mean[0].len())
                .map(|p| {
                    let from_moments =
                        (0..batches as usize).map(|b| scale * (m2[b][p] - mean[b][p].powi(2)) / (n - 1.0)).sum::<f64>()
                            / k;
                    let mu = (0..batches as usize).map(|b| mean[b][p]).sum::<f64>() / k;
                    let spread = (0..batches as usize).map(|b| (mean[b][p] - mu).powi(2)).sum::<f64>() / (k - 1.0);
                    from_moments - spread
                })
                .collect();
            let np = d.len() as f64;
            let md = d.iter().sum::<f64>() / np;
            let se = (d.iter().map(|x| (x - md).powi(2)).sum::<f64>() / (np - 1.0) / np).sqrt();
            out.push((c.to_string(), md / se));
        }
        out
    };
    for (c, z) in relation(1.0) {
        eprintln!("{c}: (m2 − mean²)/(n − 1) against the batch variance of the mean: z {z:+.2}");
        assert!(z.abs() < 4.5, "{c}: second moment and batch spread disagree, z {z}");
    }
    for (c, z) in relation(1.1) {
        eprintln!("{c} with m2 − mean² 10 % too large: z {z:+.2}");
        assert!(z.abs() >= 4.5, "{c}: a 10 % error in the second moment's variance went unnoticed");
    }
}
