//! Sensors (`perspective`, `thinlens`, `orthographic`) and samplers
//! (`multijitter`, `orthogonal`, `ldsampler`) in scene files: parameters and
//! errors as Mitsuba 3.9.1 reads them, and the projections checked by rendering.

use penumbra_render::camera::Projection;
use penumbra_render::film::Film;
use penumbra_render::render::RenderJob;
use penumbra_render::sampling::SamplerKind;
use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::mitsuba::parse_str;
use std::path::Path;

fn job_of(xml: &str) -> Result<RenderJob, penumbra_scene::LoadError> {
    build(&parse_str(xml, Path::new("sensors.xml"), &[])?, &Overrides::default())
}

/// A sensor of type `sensor` with `params`, a 16x16 box-filtered film and
/// `sampler`, looking down -z from z = 4 at an emitting 2x2 square (the
/// rectangle [-1, 1]², radiance 1) at z = 0; emitters only (max_depth 1).
fn scene(sensor: &str, params: &str, sampler: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="1"/></integrator>
<sensor type="{sensor}">
  {params}
  {sampler}
  <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
</sensor>
<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"#
    )
}

const LOOK: &str = r#"<transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>"#;

fn render(job: &RenderJob, spp: u32) -> Vec<[f32; 3]> {
    let mut film = Film::new(job.width, job.height);
    job.render_into(&mut film, 0..spp, &|_| {});
    film.develop()
}

#[test]
fn orthographic_scale_sets_the_view() {
    // scale 2 then lookat: the 16x16 film spans [-2, 2]² at the square, so
    // the square covers exactly the central 8x8 pixels.
    let ortho = format!(
        r#"<transform name="to_world"><scale x="2" y="2"/><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>"#
    );
    let job = job_of(&scene("orthographic", &ortho, "")).unwrap();
    assert!(matches!(job.camera.projection, Projection::Orthographic { .. }));
    let img = render(&job, 4);
    for y in 0..16 {
        for x in 0..16 {
            let inside = (4..12).contains(&x) && (4..12).contains(&y);
            assert_eq!(img[y * 16 + x][0], if inside { 1.0 } else { 0.0 }, "pixel ({x}, {y})");
        }
    }
    // Orthographic cameras take no field of view.
    let e = job_of(&scene("orthographic", &format!("{ortho}<float name=\"fov\" value=\"30\"/>"), ""));
    assert!(e.unwrap_err().to_string().contains("fov"));
}

#[test]
fn thin_lens_in_focus_matches_the_pinhole_and_blurs_out_of_focus() {
    let fov = r#"<float name="fov" value="40"/>"#;
    let pin = render(&job_of(&scene("perspective", &format!("{fov}{LOOK}"), "")).unwrap(), 64);
    let lens = |focus: f32| {
        let p = format!(
            r#"{fov}{LOOK}<float name="aperture_radius" value="0.3"/><float name="focus_distance" value="{focus}"/>"#
        );
        let job = job_of(&scene("thinlens", &p, "")).unwrap();
        assert_eq!(job.camera.projection, Projection::ThinLens { aperture_radius: 0.3, focus_distance: focus });
        render(&job, 64)
    };
    // Focused on the square: every lens ray through a film point meets the
    // pinhole ray on the square, so pixels agree (same film samples).
    let sharp = lens(4.0);
    let max_diff = pin.iter().zip(&sharp).map(|(a, b)| (a[0] - b[0]).abs()).fold(0.0, f32::max);
    assert!(max_diff < 1e-6, "in focus: max difference {max_diff}");
    // Focused far behind it: the edges blur (partial pixels appear and the
    // sharp image's full pixels at the border lose some light), energy kept.
    let blurred = lens(40.0);
    let partial = |img: &[[f32; 3]]| img.iter().filter(|p| p[0] > 0.02 && p[0] < 0.98).count();
    assert!(partial(&blurred) > partial(&pin) + 16, "{} vs {}", partial(&blurred), partial(&pin));
    let sum = |img: &[[f32; 3]]| img.iter().map(|p| p[0] as f64).sum::<f64>();
    assert!((sum(&blurred) - sum(&pin)).abs() < 0.05 * sum(&pin), "{} vs {}", sum(&blurred), sum(&pin));
}

#[test]
fn thin_lens_parameters_follow_mitsuba() {
    let fov = r#"<float name="fov" value="40"/>"#;
    // focus_distance defaults to far_clip.
    let p = format!(r#"{fov}<float name="aperture_radius" value="0.1"/><float name="far_clip" value="50"/>"#);
    let job = job_of(&scene("thinlens", &p, "")).unwrap();
    assert_eq!(job.camera.projection, Projection::ThinLens { aperture_radius: 0.1, focus_distance: 50.0 });
    // aperture_radius is required; scaling transforms are refused (as Mitsuba).
    assert!(job_of(&scene("thinlens", fov, "")).unwrap_err().to_string().contains("aperture_radius"));
    let scaled = format!(
        r#"{fov}<float name="aperture_radius" value="0.1"/><transform name="to_world"><scale value="2"/></transform>"#
    );
    assert!(job_of(&scene("thinlens", &scaled, "")).unwrap_err().to_string().contains("scale"));
    // perspective accepts (and ignores) focus_distance, as every Mitsuba projective camera.
    assert!(job_of(&scene("perspective", &format!("{fov}<float name=\"focus_distance\" value=\"3\"/>"), "")).is_ok());
    let e = job_of(&scene("fisheye", fov, "")).unwrap_err().to_string();
    assert!(e.contains("sensors.xml:3") && e.contains("thinlens") && e.contains("orthographic"), "{e}");
}

#[test]
fn samplers_parse_with_mitsubas_parameters_and_counts() {
    let fov = r#"<float name="fov" value="40"/>"#;
    let with = |s: &str| job_of(&scene("perspective", fov, s));
    let j = with(r#"<sampler type="multijitter"><integer name="sample_count" value="10"/><boolean name="jitter" value="false"/><integer name="seed" value="3"/></sampler>"#).unwrap();
    assert_eq!((j.sampler.kind, j.sampler.spp, j.sampler.seed), (SamplerKind::Multijitter { jitter: false }, 12, 3));
    let j = with(r#"<sampler type="orthogonal"><integer name="sample_count" value="16"/></sampler>"#).unwrap();
    assert_eq!((j.sampler.kind, j.sampler.spp), (SamplerKind::Orthogonal { jitter: true }, 25));
    let j = with(r#"<sampler type="ldsampler"><integer name="sample_count" value="17"/></sampler>"#).unwrap();
    assert_eq!((j.sampler.kind, j.sampler.spp), (SamplerKind::LowDiscrepancy, 64));
    // Only the Bose construction (strength 2); ldsampler has no jitter.
    let e = with(r#"<sampler type="orthogonal"><integer name="strength" value="3"/></sampler>"#).unwrap_err();
    assert!(e.to_string().contains("strength"), "{e}");
    let e = with(r#"<sampler type="ldsampler"><boolean name="jitter" value="false"/></sampler>"#).unwrap_err();
    assert!(e.to_string().contains("jitter"), "{e}");
    let e = with(r#"<sampler type="halton"/>"#).unwrap_err().to_string();
    assert!(e.contains("ldsampler") && e.contains("multijitter"), "{e}");
}

/// Four linear statistics of a 16x16 image, Σ_p c_p x_p (red channel):
/// the total (normalisation), the first moments Σ u·x and Σ v·x (a shift,
/// e.g. pixel samples biased within their pixel) and the second moment
/// Σ (u² + v²)·x (the blur, set by the lens samples), with u, v ∈ (−1, 1) the
/// pixel centre.
const STATS: [&str; 4] = ["total", "Σ u·x", "Σ v·x", "Σ r²·x"];
fn weights(p: usize) -> [f64; 4] {
    let (u, v) = (((p % 16) as f64 + 0.5 - 8.0) / 8.0, ((p / 16) as f64 + 0.5 - 8.0) / 8.0);
    [1.0, u, v, u * u + v * v]
}
fn stats(img: &[[f32; 3]]) -> [f64; 4] {
    let mut s = [0.0; 4];
    for (p, x) in img.iter().enumerate() {
        for (sk, w) in s.iter_mut().zip(weights(p)) {
            *sk += w * x[0] as f64;
        }
    }
    s
}

/// Every sampler renders the blurred thin-lens view of the square (4
/// dimensions per sample) with the same expectation as the independent
/// sampler.
///
/// Each sampler renders K = 64 seeds at 16 spp (orthogonal rounds to 25);
/// the mean over seeds of each statistic has the variance s²/K from the
/// spread over seeds (renders with different seeds are independent, whatever
/// the stratification within one). The reference is one independent render
/// at 32768 spp: its samples are 0 or 1 and independent, so pixel p's mean
/// has the unbiased variance x(1 − x)/(n − 1), and a statistic's variance is
/// Σ c_p² x_p(1 − x_p)/(n − 1). A sampler passes when
/// |mean − reference| < T·√(s²/K + V_ref) for every statistic; T = 4.41 is
/// the two-sided 4.2e-5 quantile of Student's t with 63 degrees of freedom
/// (conservative, as the reference's part of the variance is known far
/// better), so the 24 checks (6 samplers × 4 statistics) raise a false alarm
/// with probability at most 1e-3. Any bias beyond (T + 3)·se, printed below,
/// fails with probability at least 1 − Φ(−3) = 0.9987.
#[test]
fn every_sampler_renders_the_same_image_in_expectation() {
    const K: u64 = 64;
    const T: f64 = 4.41;
    const REF_SPP: u32 = 32768;
    let p = format!(
        r#"<float name="fov" value="40"/>{LOOK}<float name="aperture_radius" value="0.5"/><float name="focus_distance" value="20"/>"#
    );
    let build_with = |sampler: &str, ov: Overrides| {
        build(&parse_str(&scene("thinlens", &p, sampler), Path::new("sensors.xml"), &[]).unwrap(), &ov).unwrap()
    };
    let ref_job = build_with("", Overrides { seed: Some(1 << 40), ..Default::default() });
    let ref_img = render(&ref_job, REF_SPP);
    let reference = stats(&ref_img);
    let mut ref_var = [0.0f64; 4];
    for (px, x) in ref_img.iter().enumerate() {
        let x = x[0] as f64;
        for (v, w) in ref_var.iter_mut().zip(weights(px)) {
            *v += w * w * x * (1.0 - x) / (REF_SPP - 1) as f64;
        }
    }
    let xml = |s: &str| format!(r#"<sampler type="{s}"><integer name="sample_count" value="16"/></sampler>"#);
    let samplers = ["multijitter", "orthogonal", "ldsampler", "stratified", "independent", "sobol"];
    for s in samplers {
        let (sampler, over) = if s == "sobol" { (xml("independent"), Some(s.to_string())) } else { (xml(s), None) };
        let per_seed: Vec<[f64; 4]> = (0..K)
            .map(|k| {
                let job =
                    build_with(&sampler, Overrides { seed: Some(k), sampler: over.clone(), ..Default::default() });
                stats(&render(&job, job.sampler.spp))
            })
            .collect();
        for (i, name) in STATS.iter().enumerate() {
            let m = per_seed.iter().map(|v| v[i]).sum::<f64>() / K as f64;
            let s2 = per_seed.iter().map(|v| (v[i] - m).powi(2)).sum::<f64>() / (K - 1) as f64;
            let se = (s2 / K as f64 + ref_var[i]).sqrt();
            eprintln!(
                "{s} {name}: {m:.4} vs reference {:.4} (difference {:+.4}, se {se:.4}; detects a bias > {:.4})",
                reference[i],
                m - reference[i],
                (T + 3.0) * se
            );
            assert!((m - reference[i]).abs() < T * se, "{s} {name}: {m} vs {} ± {se}", reference[i]);
        }
    }
}

/// `blendbsdf` (tested here with the other plugins of this change).
#[test]
fn blendbsdf_parses_weight_and_two_nested_bsdfs() {
    use penumbra_render::material::Material;
    let with = |bsdf: &str| {
        let xml = format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
<shape type="sphere">{bsdf}</shape></scene>"#
        );
        job_of(&xml).map(|j| j.scene.materials[j.scene.shape_info[0].material as usize].clone())
    };
    let two = r#"<bsdf type="diffuse"/><bsdf type="conductor"/>"#;
    match with(&format!(r#"<bsdf type="blendbsdf"><float name="weight" value="0.25"/>{two}</bsdf>"#)).unwrap() {
        Material::Blend { weight, first, second } => {
            assert_eq!(weight.constant(), Some(glam::Vec3::splat(0.25)));
            assert!(matches!(*first, Material::Diffuse(..)) && matches!(*second, Material::Conductor(..)));
        }
        m => panic!("{m:?}"),
    }
    let tex = r#"<texture type="checkerboard" name="weight"/>"#;
    assert!(matches!(with(&format!(r#"<bsdf type="blendbsdf">{tex}{two}</bsdf>"#)).unwrap(), Material::Blend { .. }));
    let e = with(&format!(r#"<bsdf type="blendbsdf">{two}</bsdf>"#)).unwrap_err().to_string();
    assert!(e.contains("weight") && e.contains("sensors.xml:2"), "{e}");
    let e = with(r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/></bsdf>"#);
    assert!(e.unwrap_err().to_string().contains("two nested"));
}

#[test]
fn a_top_level_sampler_can_be_referenced_by_the_sensor() {
    // As in Mitsuba's documentation scenes (sampler_*.xml).
    let xml = r#"<scene version="3.0.0">
<sampler type="ldsampler" id="my_sampler"><integer name="sample_count" value="16"/></sampler>
<sensor type="perspective"><ref id="my_sampler"/><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
</scene>"#;
    let j = job_of(xml).unwrap();
    assert_eq!((j.sampler.kind, j.sampler.spp), (SamplerKind::LowDiscrepancy, 16));
}

/// `radiancemeter` measures the radiance along its one ray: a grey diffuse
/// sphere (ρ = 0.8) in a uniform environment reflects ρ·L (the furnace's
/// closed form), the environment itself L; placed by `origin`/`direction`
/// or by `to_world`; films larger than 1x1 in both directions are refused.
#[test]
fn radiancemeter_measures_one_ray() {
    let meter = |sensor: &str, film: &str| {
        format!(
            r#"<scene version="3.0.0">
<integrator type="path"/>
<sensor type="radiancemeter">{sensor}<sampler type="independent"><integer name="sample_count" value="4096"/></sampler>
  <film type="hdrfilm">{film}<rfilter type="box"/></film></sensor>
<emitter type="constant"><rgb name="radiance" value="0.3, 0.5, 0.7"/></emitter>
<shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="0.8"/></bsdf></shape>
</scene>"#
        )
    };
    let one = r#"<integer name="width" value="1"/><integer name="height" value="1"/>"#;
    let at_sphere = r#"<point name="origin" x="0" y="0" z="5"/><vector name="direction" x="0" y="0" z="-1"/>"#;
    let job = job_of(&meter(at_sphere, one)).unwrap();
    assert_eq!(job.camera.projection, Projection::RadianceMeter);
    // 8 batches of 512 samples: the mean and its standard error.
    let batches: Vec<[f32; 3]> = (0..8)
        .map(|b| {
            let mut film = Film::new(1, 1);
            job.render_into(&mut film, b * 512..(b + 1) * 512, &|_| {});
            film.develop()[0]
        })
        .collect();
    for (c, want) in [0.3f64, 0.5, 0.7].iter().enumerate() {
        let v: Vec<f64> = batches.iter().map(|p| p[c] as f64).collect();
        let mean = v.iter().sum::<f64>() / 8.0;
        let se = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 7.0 / 8.0).sqrt();
        assert!((mean - 0.8 * want).abs() < 4.5 * se + 1e-6, "channel {c}: {mean} ± {se}, want {}", 0.8 * want);
        assert!(se < 0.005 * want, "channel {c}: too noisy ({se})");
    }
    let away = r#"<transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 9" up="0, 1, 0"/></transform>"#;
    assert_eq!(render(&job_of(&meter(away, one)).unwrap(), 16)[0], [0.3, 0.5, 0.7]);
    let e = job_of(&meter(at_sphere, r#"<integer name="width" value="2"/><integer name="height" value="2"/>"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("sensors.xml:") && e.contains("1x1"), "{e}");
    let e = job_of(&meter(r#"<point name="origin" x="0" y="0" z="5"/>"#, one)).unwrap_err().to_string();
    assert!(e.contains("both 'origin' and 'direction'"), "{e}");
}

/// `depth`: the distance from where the camera ray starts (the near clip
/// plane) to the first surface, 0 for escaping rays; checked with an
/// orthographic camera on a plane, where it is the same in every pixel.
#[test]
fn depth_integrator_gives_the_distance() {
    let xml = r#"<scene version="3.0.0">
<integrator type="depth"/>
<sensor type="orthographic"><float name="near_clip" value="0.5"/>
  <transform name="to_world"><scale x="2" y="2"/><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film></sensor>
<shape type="rectangle"/>
</scene>"#;
    let img = render(&job_of(xml).unwrap(), 4);
    // The rectangle [-1, 1]² covers the central 8x8 pixels of the [-2, 2]² view.
    for (i, p) in img.iter().enumerate() {
        let (x, y) = (i % 16, i / 16);
        let inside = (4..12).contains(&x) && (4..12).contains(&y);
        let want = if inside { 3.5 } else { 0.0 };
        assert!((p[0] - want).abs() < 1e-5 && p[0] == p[1] && p[1] == p[2], "pixel ({x}, {y}): {p:?}");
    }
    // --integrator depth takes none of the scene integrator's parameters.
    let ov = Overrides { integrator: Some("depth".into()), ..Default::default() };
    let path = xml.replace(
        r#"<integrator type="depth"/>"#,
        r#"<integrator type="path"><integer name="max_depth" value="3"/></integrator>"#,
    );
    assert!(build(&parse_str(&path, Path::new("sensors.xml"), &[]).unwrap(), &ov).is_ok());
}

/// Batch means of a 1x1 job: (mean, standard error) per channel from 8
/// independently seeded batches of `per_batch` samples.
fn meter_estimate(job: &RenderJob, per_batch: u32) -> [(f64, f64); 3] {
    let batches: Vec<[f32; 3]> = (0..8)
        .map(|b| {
            let mut film = Film::new(1, 1);
            job.render_into(&mut film, b * per_batch..(b + 1) * per_batch, &|_| {});
            film.develop()[0]
        })
        .collect();
    [0, 1, 2].map(|c| {
        let v: Vec<f64> = batches.iter().map(|p| p[c] as f64).collect();
        let mean = v.iter().sum::<f64>() / 8.0;
        (mean, (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 7.0 / 8.0).sqrt())
    })
}

/// `irradiancemeter` gives the mean irradiance over its shape: a tiny
/// upward disk under a coaxial disk emitter of radius R at height h
/// receives E = π L R² / (h² + R²) (the view factor of a coaxial disk), a
/// constant sky the exact π L on every sample; nested only in a shape, with
/// no `to_world`, and as the one sensor.
#[test]
fn irradiancemeter_measures_irradiance() {
    let meter = |sensor_extra: &str, top: &str| {
        format!(
            r#"<scene version="3.0.0">{top}
<shape type="disk"><transform name="to_world"><scale value="0.001"/></transform>
  <sensor type="irradiancemeter">{sensor_extra}<sampler type="independent"/>
    <film type="hdrfilm"><integer name="width" value="1"/><integer name="height" value="1"/><rfilter type="box"/></film></sensor></shape>
</scene>"#
        )
    };
    let lamp = r#"<shape type="disk"><transform name="to_world"><scale value="1.5"/><rotate x="1" angle="180"/><translate z="2"/></transform>
  <emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>"#;
    let job = job_of(&meter("", lamp)).unwrap();
    assert_eq!(job.camera.projection, Projection::IrradianceMeter);
    let view = 1.5f64 * 1.5 / (4.0 + 1.5 * 1.5);
    for (c, (mean, se)) in meter_estimate(&job, 4096).into_iter().enumerate() {
        let want = std::f64::consts::PI * (c + 1) as f64 * view;
        assert!((mean - want).abs() < 4.5 * se, "channel {c}: {mean} ± {se}, want {want}");
        assert!(se < 0.02 * want, "channel {c}: too noisy ({se})");
    }
    let sky = r#"<emitter type="constant"><rgb name="radiance" value="0.5, 1, 2"/></emitter>"#;
    let img = render(&job_of(&meter("", sky)).unwrap(), 64);
    for (c, want) in [0.5f32, 1.0, 2.0].iter().enumerate() {
        assert!((img[0][c] - std::f32::consts::PI * want).abs() < 1e-5 * want, "{:?}", img[0]);
    }
    let e =
        job_of(&meter(r#"<transform name="to_world"><translate x="1"/></transform>"#, sky)).unwrap_err().to_string();
    assert!(e.contains("sensors.xml:3") && e.contains("to_world"), "{e}");
    let top_level = r#"<sensor type="irradiancemeter"><film type="hdrfilm"/></sensor>"#;
    let e = job_of(&format!(r#"<scene version="3.0.0">{top_level}</scene>"#)).unwrap_err().to_string();
    assert!(e.contains("sensors.xml:1") && e.contains("nested inside the shape"), "{e}");
    let e = job_of(&meter("", &format!("{sky}{top_level}"))).unwrap_err().to_string();
    assert!(e.contains("more than one sensor"), "{e}");
    let nested = r#"<shape type="sphere"><sensor type="perspective"><film type="hdrfilm"/></sensor></shape>"#;
    let e = job_of(&format!(r#"<scene version="3.0.0">{nested}</scene>"#)).unwrap_err().to_string();
    assert!(e.contains("only an irradiancemeter"), "{e}");
}

const METER_FILM: &str = r#"<sampler type="independent"><integer name="sample_count" value="4096"/></sampler><film type="hdrfilm"><integer name="width" value="1"/><integer name="height" value="1"/><rfilter type="box"/></film>"#;

/// tools/meter_refs.py's `DISTANT` scene with `target`: a 2x2 rectangle
/// emitter at z = 0 facing +z (radiance 1, 2, 3) above a diffuse sphere,
/// seen along -z.
fn distant_scene(target: &str) -> String {
    format!(
        r#"<scene version="3.0.0"><integrator type="path"/>
<sensor type="distant"><vector name="direction" x="0" y="0" z="-1"/>{target}{METER_FILM}</sensor>
<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>
<shape type="sphere"><point name="center" x="0" y="0" z="-3"/><float name="radius" value="0.5"/></shape>
</scene>"#
    )
}

/// Mitsuba 3.9.1's means and standard errors (8 x 4096 spp) from
/// tools/meter_refs.py, per channel.
const MITSUBA_DISTANT_SHAPE: [(f64, f64); 3] = [(0.246155, 0.002418), (0.49231, 0.004835), (0.738464, 0.007253)];
const MITSUBA_DISTANT_NONE: [(f64, f64); 3] = [(0.248901, 0.002349), (0.497803, 0.004698), (0.746704, 0.007047)];
const MITSUBA_IRRADIANCEMETER: [(f64, f64); 3] = [(1.151805, 0.003605), (2.303611, 0.00721), (3.455346, 0.010814)];

/// Our estimate agrees with the closed form `want` (per channel) and with
/// Mitsuba's `mitsuba` within 4.5 standard errors of each difference.
fn check_meter(name: &str, ours: [(f64, f64); 3], want: Option<[f64; 3]>, mitsuba: Option<[(f64, f64); 3]>) {
    for c in 0..3 {
        let (m, se) = ours[c];
        if let Some(w) = want {
            assert!((m - w[c]).abs() < 4.5 * se, "{name} channel {c}: {m} ± {se}, closed form {}", w[c]);
        }
        if let Some(mi) = mitsuba {
            let (mm, mse) = mi[c];
            let s = (se * se + mse * mse).sqrt();
            eprintln!("{name} channel {c}: {m:.5} vs Mitsuba {mm:.5}, z {:.2}", (m - mm) / s);
            assert!((m - mm).abs() < 4.5 * s, "{name} channel {c}: {m} ± {se}, Mitsuba {mm} ± {mse}");
        }
    }
}

/// `distant` records the radiance leaving the scene towards -`direction`,
/// averaged over its target: at a target point, exactly the emitter's L; over
/// a 4x4 target shape of which the 2x2 emitter covers a quarter, L/4; with
/// no target, over the cross section of the scene's bounding sphere (the box
/// [-1, 1]² x [-3.5, 0]: radius 2.25), 4 / (π 2.25²) of L. Mitsuba's numbers
/// agree. Films of more than one pixel each way, and `direction` together
/// with `to_world`, are refused.
#[test]
fn distant_averages_over_its_target() {
    let l = [1.0, 2.0, 3.0];
    let job = job_of(&distant_scene(r#"<point name="target" x="0.3" y="-0.2" z="0"/>"#)).unwrap();
    assert!(matches!(job.camera.projection, Projection::Distant { target: Some(_), .. }));
    assert_eq!(render(&job, 16)[0], [1.0, 2.0, 3.0]);
    let target = r#"<shape type="rectangle" name="target"><transform name="to_world"><scale value="2"/><translate x="0.5"/></transform></shape>"#;
    let job = job_of(&distant_scene(target)).unwrap();
    assert_eq!(job.scene.shapes.len(), 2, "the target is not part of the scene");
    check_meter("distant shape", meter_estimate(&job, 4096), Some(l.map(|x| x / 4.0)), Some(MITSUBA_DISTANT_SHAPE));
    let job = job_of(&distant_scene("")).unwrap();
    let frac = 4.0 / (std::f64::consts::PI * 2.25 * 2.25);
    check_meter("distant none", meter_estimate(&job, 4096), Some(l.map(|x| x * frac)), Some(MITSUBA_DISTANT_NONE));

    let big = distant_scene("")
        .replace(r#"name="width" value="1""#, r#"name="width" value="2""#)
        .replace(r#"name="height" value="1""#, r#"name="height" value="2""#);
    let e = job_of(&big).unwrap_err().to_string();
    assert!(e.contains("sensors.xml:2") && e.contains("1x1"), "{e}");
    let both = distant_scene(r#"<transform name="to_world"><rotate x="1" angle="90"/></transform>"#);
    let e = job_of(&both).unwrap_err().to_string();
    assert!(e.contains("sensors.xml:2") && e.contains("not both"), "{e}");
    let e = job_of(&distant_scene(r#"<shape type="sphere" name="aim"/>"#)).unwrap_err().to_string();
    assert!(e.contains("sensors.xml:2") && e.contains("named 'target'"), "{e}");
    let e = job_of(&distant_scene(r#"<float name="fov" value="30"/>"#)).unwrap_err().to_string();
    assert!(e.contains("sensors.xml:2") && e.contains("fov"), "{e}");
}

/// tools/meter_refs.py's `irradiancemeter` scene: a tilted rectangle meter
/// under a disk lamp, partly shadowed from the lamp by a diffuse sphere that
/// also reflects onto it, in a dim sky; the same as Mitsuba's number.
#[test]
fn irradiancemeter_matches_mitsuba() {
    let xml = format!(
        r#"<scene version="3.0.0"><integrator type="path"/>
<emitter type="constant"><rgb name="radiance" value="0.1, 0.2, 0.3"/></emitter>
<shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="30"/></transform><sensor type="irradiancemeter">{METER_FILM}</sensor></shape>
<shape type="disk"><transform name="to_world"><scale value="1.5"/><rotate x="1" angle="180"/><translate z="2"/></transform><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>
<shape type="sphere"><point name="center" x="1" y="0" z="0.5"/><float name="radius" value="0.5"/></shape>
</scene>"#
    );
    let job = job_of(&xml).unwrap();
    check_meter("irradiancemeter", meter_estimate(&job, 4096), None, Some(MITSUBA_IRRADIANCEMETER));
}

/// Mitsuba's `batch`: nested sensors side by side, each built for its
/// strip of the film (width / n), the batch's film and sampler used; the
/// left strip of a batch renders what the nested sensor alone renders on
/// a film of the strip's size; errors at file:line.
#[test]
fn batch_sensor_places_its_sensors_side_by_side() {
    let persp = |origin: &str| {
        format!(
            r#"<sensor type="perspective"><float name="fov" value="50"/>
<transform name="to_world"><lookat origin="{origin}" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>"#
        )
    };
    let body = |subs: &str, width: u32, extra: &str| {
        format!(
            r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="1"/></integrator>
<sensor type="batch">{extra}
{subs}
  <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="8"/><rfilter type="box"/></film>
</sensor>
<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"#
        )
    };
    let two = format!("{}{}", persp("0.5, 0, 4"), persp("-1, 0.3, 3"));
    let job = job_of(&body(&two, 16, "")).unwrap();
    assert_eq!(job.camera.projection, Projection::Batch);
    assert_eq!(job.camera.batch.len(), 2);
    // Each strip is 8x8: the fov (along x) spans 8 pixels, aspect 1.
    let t = (25f32).to_radians().tan();
    for c in &job.camera.batch {
        assert!((c.tan_half.x - t).abs() < 1e-6 && (c.tan_half.y - t).abs() < 1e-6, "{:?}", c.tan_half);
    }
    // The left strip is the first sensor alone on an 8x8 film, bitwise.
    let alone = job_of(
        &scene(
            "perspective",
            &persp("0.5, 0, 4").replace("<sensor type=\"perspective\">", "").replace("</sensor>", ""),
            "",
        )
        .replace("value=\"16\"", "value=\"8\""),
    )
    .unwrap();
    let (a, b) = (render(&job, 16), render(&alone, 16));
    assert_eq!(alone.width, 8);
    for y in 0..8 {
        for x in 0..8 {
            assert_eq!(a[y * 16 + x], b[y * 8 + x], "pixel ({x}, {y})");
        }
    }
    // The right strip sees the square from elsewhere: a different image.
    assert!((0..8).any(|y| (0..8).any(|x| a[y * 16 + 8 + x] != b[y * 8 + x])));

    let err = |xml: String| job_of(&xml).map(|_| ()).unwrap_err().to_string();
    let e = err(body(&two, 15, ""));
    assert!(e.contains("sensors.xml:3") && e.contains("divisible"), "{e}");
    let e = err(body("", 16, ""));
    assert!(e.contains("sensors.xml:3") && e.contains("at least one nested sensor"), "{e}");
    let e = err(body(&two, 16, r#"<spectrum name="srf" value="1"/>"#));
    assert!(e.contains("sensors.xml:3") && e.contains("srf"), "{e}");
    let e = err(body(&two, 16, r#"<float name="fov" value="30"/>"#));
    assert!(e.contains("sensors.xml:3") && e.contains("'fov'"), "{e}");
    let e = err(body(
        &two.replacen("<float name=\"fov\" value=\"50\"/>", "<float name=\"fovv\" value=\"50\"/>", 1),
        16,
        "",
    ));
    assert!(e.contains("sensors.xml:4") && e.contains("'fovv'"), "{e}");
    let with_medium = persp("0, 0, 4").replace("</sensor>", r#"<medium type="homogeneous"/></sensor>"#);
    let e = err(body(&with_medium, 16, ""));
    assert!(e.contains("sensors.xml:5") && e.contains("medium"), "{e}");
    let e = err(body(&two, 16, "").replace(
        r#"<integrator type="path"><integer name="max_depth" value="1"/></integrator>"#,
        r#"<integrator type="ptracer"/>"#,
    ));
    assert!(e.contains("ptracer"), "{e}");
}
