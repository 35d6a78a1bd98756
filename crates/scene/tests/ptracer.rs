//! The particle tracer (`ptracer`): its image against `path`'s (the two
//! estimate the same one), bitwise independence of the thread count and of
//! crop windows, the pass split resume relies on, and its load errors.
//! Agreement with Mitsuba's `ptracer` is in references.rs.

use crate::common;

use crate::common::{assert_agree, compare, root};
use penumbra_render::film::Film;
use penumbra_render::sampling::Sampler;
use penumbra_scene::{load_scene, Overrides};

fn scene() -> std::path::PathBuf {
    named("ptracer_box")
}

fn named(name: &str) -> std::path::PathBuf {
    root().join("tests/scenes").join(format!("{name}.xml"))
}

/// 16 batches of `spp / 16` samples with `integrator` (None: the scene's
/// `ptracer`), the images cut to the pixels at least one pixel from the
/// border: there the two estimators converge to different images under a
/// filter wider than a pixel (`path` renormalises each pixel's weights over
/// the samples inside the film; the particle tracer, as Mitsuba's, splats
/// with weights normalised over the whole footprint and drops what falls
/// outside, so border pixels lose the filter's mass beyond the edge).
fn interior_estimate(spp: u32, integrator: Option<&str>, seed: u64) -> common::Estimate {
    estimate_inside(&scene(), 1, spp, integrator, seed)
}

/// [`interior_estimate`] of scene `path`, without `ring` pixels at each border.
fn estimate_inside(
    path: &std::path::Path,
    ring: u32,
    spp: u32,
    integrator: Option<&str>,
    seed: u64,
) -> common::Estimate {
    let batches = 16;
    let ov = Overrides { spp: Some(spp / batches), integrator: integrator.map(str::to_string), ..Default::default() };
    let mut job = load_scene(path, &[], &ov).unwrap();
    let (w, h) = (job.width, job.height);
    let imgs: Vec<Vec<[f32; 3]>> = (0..batches)
        .map(|b| {
            job.sampler = Sampler::new(job.sampler.kind, seed * 1000 + b as u64, job.sampler.spp);
            let mut film = Film::new(w, h);
            job.render_into(&mut film, 0..job.sampler.spp, &|_| {});
            let img = film.develop();
            (ring..h - ring)
                .flat_map(|y| (ring..w - ring).map(move |x| (x, y)))
                .map(|(x, y)| img[(y * w + x) as usize])
                .collect()
        })
        .collect();
    common::estimate(w - 2 * ring, h - 2 * ring, &imgs)
}

/// The thin-lens camera (sensors_samplers.xml: aperture 0.12, focused at
/// 5, under a constant sky and a directional sun): `ptracer`, which samples
/// the aperture per connection, against `path`, inside the Gaussian
/// filter's two-pixel ring.
#[test]
fn particle_tracer_through_a_thin_lens_matches_path() {
    let scene = named("sensors_samplers");
    let pt = estimate_inside(&scene, 2, 2048, Some("ptracer"), 7);
    let path = estimate_inside(&scene, 2, 2048, None, 8);
    let v = assert_agree("thin lens: ptracer against path", &pt, &path, 0.02);
    eprintln!("block χ² {:?}, largest block z {:?}", v.block_chi2, v.block_max);
}

/// Emitters at infinity and delta emitters: an envmap with a bright sun
/// (tests/scenes/ptracer_env.xml), spot_light.xml's spot and directional
/// lights, and area_texture.xml's textured area emitters, rendered by `ptracer` and by `path` (box filters:
/// the whole images agree). Mitsuba 3.9.1's own `ptracer` is about 17 %
/// brighter than its `path` on the envmap scene's ground, so the reference
/// here is the path tracer, which matches Mitsuba's (references.rs).
#[test]
fn particle_tracer_with_emitters_at_infinity_delta_and_textured_emitters_matches_path() {
    for (name, integrator) in
        [("ptracer_env", None), ("spot_light", Some("ptracer")), ("area_texture", Some("ptracer"))]
    {
        let path_spec = if integrator.is_some() { None } else { Some("path") };
        let pt = estimate_inside(&named(name), 0, 4096, integrator, 5);
        let path = estimate_inside(&named(name), 0, 4096, path_spec, 6);
        let v = assert_agree(&format!("{name}: ptracer against path"), &pt, &path, 0.02);
        eprintln!("{name}: block χ² {:?}, largest block z {:?}", v.block_chi2, v.block_max);
    }
}

/// `ptracer` and `path` converge to the same image (inside the border
/// ring, see [`interior_estimate`]), compared by `common::compare` (mean
/// z-test resolving 2 %, 8x8-block χ² and largest block z at 1e-4). Power:
/// the particle image 5 % too bright must fail.
#[test]
fn particle_tracer_converges_to_the_path_tracers_image() {
    let pt = interior_estimate(1024, None, 3);
    let path = interior_estimate(1024, Some("path"), 4);
    let v = assert_agree("ptracer against path", &pt, &path, 0.02);
    eprintln!("block χ² {:?}, largest block z {:?}", v.block_chi2, v.block_max);
    let mut bright = pt.clone();
    bright.mean.iter_mut().for_each(|p| *p = p.map(|c| c * 1.05));
    assert!(!compare("ptracer 5 % bright", &bright, &path, 0.02).failures.is_empty(), "a 5 % error went unnoticed");
}

fn render(threads: usize, crop: Option<(u32, u32, u32, u32)>, passes: &[std::ops::Range<u32>]) -> Film {
    let mut job = load_scene(&scene(), &[], &Overrides { spp: Some(8), ..Default::default() }).unwrap();
    if let Some((x, y, w, h)) = crop {
        job.crop_offset = (x, y);
        job.width = w;
        job.height = h;
    }
    let mut film = Film::new(job.width, job.height);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        for p in passes {
            job.render_into(&mut film, p.clone(), &|_| {});
        }
    });
    film
}

/// The film is bitwise the same for 1, 2 and 3 threads; a crop window is
/// bitwise its part of the full film (it traces the full film's particles).
#[test]
fn particle_image_is_bitwise_independent_of_threads_and_crops() {
    let passes = [0..1, 1..3, 3..8];
    let one = render(1, None, &passes);
    assert!(one.acc.iter().any(|a| a[0] > 0.0));
    for threads in [2, 3] {
        assert!(render(threads, None, &passes).acc == one.acc, "{threads} threads changed the image");
    }
    let (x0, y0, w, h) = (5, 9, 13, 11);
    let crop = render(2, Some((x0, y0, w, h)), &passes);
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (crop.acc[(y * w + x) as usize], one.acc[((y + y0) * one.width + x + x0) as usize]);
            assert!(a == b, "crop pixel ({x}, {y}): {a:?} vs {b:?}");
        }
    }
    // Each pass adds its sample count to every pixel's weight: the image is
    // Σ splats / spp whatever the passes, up to f64 rounding.
    let whole = render(2, None, &[0..8]);
    assert!(one.acc.iter().all(|a| a[3] == 8.0));
    let (a, b) = (one.develop(), whole.develop());
    for (p, q) in a.iter().zip(&b) {
        for c in 0..3 {
            assert!((p[c] - q[c]).abs() <= 1e-6 * q[c].abs() + 1e-12, "{p:?} vs {q:?}");
        }
    }
}

fn load_error(integrator: &str, extra: &str) -> String {
    let xml = format!(
        "<scene version=\"3.0.0\">\n{integrator}\n<sensor type=\"perspective\"><film type=\"hdrfilm\"/>\
         <sampler type=\"independent\"><integer name=\"sample_count\" value=\"6\"/></sampler></sensor>\n{extra}\n</scene>"
    );
    let desc = penumbra_scene::mitsuba::parse_str(&xml, std::path::Path::new("pt.xml"), &[]).unwrap();
    penumbra_scene::builder::build(&desc, &Overrides::default()).err().map(|e| e.to_string()).unwrap_or_default()
}

#[test]
fn bad_ptracer_scenes_are_errors_at_their_line() {
    let cases: &[(&str, &str, &[&str])] = &[
        (
            r#"<integrator type="ptracer"><integer name="max_depth" value="-3"/></integrator>"#,
            "",
            &["pt.xml:2", "max_depth"],
        ),
        (
            r#"<integrator type="ptracer"><integer name="rr_depth" value="0"/></integrator>"#,
            "",
            &["pt.xml:2", "rr_depth"],
        ),
        (
            r#"<integrator type="ptracer"><integer name="samples_per_pass" value="0"/></integrator>"#,
            "",
            &["pt.xml:2", "samples_per_pass"],
        ),
        (
            r#"<integrator type="ptracer"><integer name="samples_per_pass" value="4"/></integrator>"#,
            "",
            &["pt.xml:2", "multiple of samples_per_pass"],
        ),
        (r#"<integrator type="ptracer"><boolean name="mis" value="true"/></integrator>"#, "", &["pt.xml:2", "'mis'"]),
    ];
    for (integrator, extra, want) in cases {
        let e = load_error(integrator, extra);
        for w in *want {
            assert!(e.contains(w), "{integrator} {extra}: '{e}' lacks '{w}'");
        }
    }
    assert_eq!(
        load_error(r#"<integrator type="ptracer"><integer name="samples_per_pass" value="3"/></integrator>"#, ""),
        ""
    );
    let xml = r#"<scene version="3.0.0"><integrator type="ptracer"/>
        <sensor type="orthographic"><film type="hdrfilm"/></sensor></scene>"#;
    let desc = penumbra_scene::mitsuba::parse_str(xml, std::path::Path::new("o.xml"), &[]).unwrap();
    let e = penumbra_scene::builder::build(&desc, &Overrides::default()).err().unwrap().to_string();
    assert!(e.contains("o.xml:1") && e.contains("perspective"), "{e}");
}
