//! BSDF plugins in scene files: parameters and defaults as Mitsuba 3.9.1
//! reads them, errors naming file and line, and behaviour of the wrappers
//! (`twosided`, `mask`, `null`) checked by rendering.

use crate::common::{assert_agree, render_with_variance};
use penumbra_render::bsdf::MicrofacetType;
use penumbra_render::material::Material;
use penumbra_render::math::Spectrum;
use penumbra_render::texture::Texture;
use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::mitsuba::parse_str;
use std::path::{Path, PathBuf};

const SENSOR: &str = r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>
<integer name="height" value="4"/></film></sensor>"#;

/// Builds a scene with one sphere carrying `bsdf`; returns its material.
fn material(bsdf: &str) -> Result<Material, penumbra_scene::LoadError> {
    let xml = format!("<scene version=\"3.0.0\">{SENSOR}\n<shape type=\"sphere\">\n{bsdf}\n</shape></scene>");
    let job = build(&parse_str(&xml, Path::new("mat.xml"), &[])?, &Overrides::default())?;
    Ok(job.scene.materials[job.scene.shape_info[0].material as usize].clone())
}

fn error(bsdf: &str) -> String {
    material(bsdf).err().expect("the scene should be rejected").to_string()
}

fn constant(t: &Texture) -> Spectrum {
    t.constant().expect("a constant")
}

#[test]
fn defaults_follow_mitsuba() {
    match material(r#"<bsdf type="roughconductor"/>"#).unwrap() {
        Material::RoughConductor(penumbra_render::bsdf::RoughConductorParams {
            roughness,
            eta,
            k,
            specular_reflectance,
        }) => {
            assert_eq!(roughness.kind, MicrofacetType::Beckmann);
            assert_eq!(constant(&roughness.alpha_u), Spectrum::splat(0.1));
            assert_eq!(constant(&roughness.alpha_v), Spectrum::splat(0.1));
            // material "none": eta 0, k 1, a perfect mirror
            assert_eq!((constant(&eta), constant(&k)), (Spectrum::ZERO, Spectrum::ONE));
            assert_eq!(constant(&specular_reflectance), Spectrum::ONE);
        }
        m => panic!("{m:?}"),
    }
    match material(r#"<bsdf type="roughdielectric"/>"#).unwrap() {
        // bk7 / air
        Material::RoughDielectric(penumbra_render::bsdf::RoughDielectricParams { eta, .. }) => {
            assert!((eta - 1.5046 / 1.000277).abs() < 1e-5)
        }
        m => panic!("{m:?}"),
    }
    match material(r#"<bsdf type="plastic"/>"#).unwrap() {
        Material::Plastic(penumbra_render::bsdf::PlasticParams {
            eta,
            diffuse_reflectance,
            nonlinear,
            specular_sampling_weight,
            fdr_int,
            ..
        }) => {
            // polypropylene / air; weight = s_mean / (d_mean + s_mean) = 1 / 1.5
            assert!((eta - 1.49 / 1.000277).abs() < 1e-5);
            assert_eq!(constant(&diffuse_reflectance), Spectrum::splat(0.5));
            assert!(!nonlinear);
            assert!((specular_sampling_weight - 1.0 / 1.5).abs() < 1e-6);
            assert!(fdr_int > 0.5 && fdr_int < 0.7, "internal diffuse Fresnel reflectance {fdr_int}");
        }
        m => panic!("{m:?}"),
    }
    match material(r#"<bsdf type="mask"><bsdf type="diffuse"/></bsdf>"#).unwrap() {
        Material::Mask { opacity, inner } => {
            assert_eq!(constant(&opacity), Spectrum::splat(0.5));
            assert!(matches!(*inner, Material::Diffuse(..)));
        }
        m => panic!("{m:?}"),
    }
    match material(r#"<bsdf type="pplastic"/>"#).unwrap() {
        Material::PPlastic(penumbra_render::bsdf::PPlasticParams {
            roughness,
            eta,
            diffuse_reflectance,
            specular_reflectance,
            specular_sampling_weight,
        }) => {
            // Beckmann, α 0.1, polypropylene / air, ρ 0.5, s 1.
            assert_eq!(roughness.kind, MicrofacetType::Beckmann);
            assert_eq!(constant(&roughness.alpha_u), Spectrum::splat(0.1));
            assert!((constant(&eta).x - 1.49 / 1.000277).abs() < 1e-5);
            assert_eq!(constant(&diffuse_reflectance), Spectrum::splat(0.5));
            assert_eq!(constant(&specular_reflectance), Spectrum::ONE);
            assert!((specular_sampling_weight - 1.0 / 1.5).abs() < 1e-6);
        }
        m => panic!("{m:?}"),
    }
    assert!(matches!(material(r#"<bsdf type="thindielectric"/>"#).unwrap(), Material::ThinDielectric(..)));
    assert!(matches!(material(r#"<bsdf type="null"/>"#).unwrap(), Material::Null));
}

#[test]
fn parameters_are_read() {
    let m = material(
        r#"<bsdf type="roughconductor"><string name="distribution" value="GGX"/>
           <float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/>
           <rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3, 2.5, 2"/></bsdf>"#,
    )
    .unwrap();
    match m {
        Material::RoughConductor(penumbra_render::bsdf::RoughConductorParams { roughness, eta, .. }) => {
            assert_eq!(roughness.kind, MicrofacetType::Ggx);
            assert_eq!(constant(&roughness.alpha_u).x, 0.05);
            assert_eq!(constant(&roughness.alpha_v).x, 0.3);
            assert_eq!(constant(&eta), Spectrum::new(0.2, 0.9, 1.1));
        }
        m => panic!("{m:?}"),
    }
    match material(r#"<bsdf type="roughplastic"><string name="int_ior" value="water"/><float name="alpha" value="0.3"/><boolean name="nonlinear" value="true"/></bsdf>"#).unwrap() {
        Material::RoughPlastic(penumbra_render::bsdf::RoughPlasticParams { eta, distr, nonlinear, .. }) => {
            assert!((eta - 1.333 / 1.000277).abs() < 1e-4);
            assert_eq!((distr.alpha_u, distr.alpha_v), (0.3, 0.3));
            assert!(nonlinear);
        }
        m => panic!("{m:?}"),
    }
    // A named conductor (Mitsuba's RGB eta/k for gold)
    match material(r#"<bsdf type="roughconductor"><string name="material" value="Au"/></bsdf>"#).unwrap() {
        Material::RoughConductor(penumbra_render::bsdf::RoughConductorParams { eta, k, .. }) => {
            let (e, k) = (constant(&eta), constant(&k));
            assert!(e.x < 0.5 && e.z > 1.0 && k.x > 2.0, "gold eta {e} k {k}");
        }
        m => panic!("{m:?}"),
    }
}

#[test]
fn errors_name_the_line_and_what_to_do() {
    let cases: &[(&str, &[&str])] = &[
        (r#"<bsdf type="roughconductor"><float name="alpha_u" value="0.1"/></bsdf>"#, &["mat.xml:4", "alpha_v"]),
        (
            r#"<bsdf type="roughconductor"><float name="alpha" value="0.1"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.1"/></bsdf>"#,
            &["mat.xml:4", "either 'alpha'"],
        ),
        (
            r#"<bsdf type="roughdielectric"><string name="distribution" value="phong"/></bsdf>"#,
            &["mat.xml:4", "beckmann, ggx"],
        ),
        (
            r#"<bsdf type="roughplastic"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf>"#,
            &["mat.xml:4", "anisotropic"],
        ),
        (
            r#"<bsdf type="roughconductor"><string name="material" value="Unobtainium"/></bsdf>"#,
            &["mat.xml:4", "Unobtainium", "Au"],
        ),
        (
            r#"<bsdf type="roughdielectric"><float name="int_ior" value="1.0"/><float name="ext_ior" value="1.0"/></bsdf>"#,
            &["mat.xml:4", "differ"],
        ),
        (r#"<bsdf type="mask"><float name="opacity" value="0.5"/></bsdf>"#, &["mat.xml:4", "nested BSDF"]),
        (
            r#"<bsdf type="plastic"><float name="roughness" value="0.5"/></bsdf>"#,
            &["mat.xml:4", "roughness", "not supported"],
        ),
        (
            r#"<bsdf type="normalmap"><boolean name="flip_invalid_normals" value="false"/><texture type="bitmap" name="normalmap"><string name="filename" value="../../tests/scenes/textures/bumps.png"/></texture><bsdf type="diffuse"/></bsdf>"#,
            &["mat.xml:4", "flip_invalid_normals", "not supported"],
        ),
        (
            r#"<bsdf type="bumpmap"><texture type="checkerboard"/><bsdf type="diffuse"/></bsdf>"#,
            &["mat.xml:4", "no gradient"],
        ),
        (r#"<bsdf type="polarizer"/>"#, &["mat.xml:4", "polarizer", "roughconductor", "mask"]),
        (
            r#"<bsdf type="pplastic"><float name="eta" value="1.5"/><float name="int_ior" value="1.6"/></bsdf>"#,
            &["mat.xml:4", "either 'eta' or 'int_ior'"],
        ),
        (
            r#"<bsdf type="hair"><float name="longitudinal_roughness" value="1.5"/></bsdf>"#,
            &["mat.xml:4", "longitudinal_roughness must be in [0, 1]"],
        ),
        (
            r#"<bsdf type="hair"><rgb name="sigma_a" value="0.2"/><float name="eumelanin" value="1"/></bsdf>"#,
            &["mat.xml:4", "not both"],
        ),
        (r#"<bsdf type="hair"><float name="int_ior" value="1.000277"/></bsdf>"#, &["mat.xml:4", "differ"]),
        (r#"<bsdf type="pplastic"><float name="eta" value="-1"/></bsdf>"#, &["mat.xml:4", "eta must be positive"]),
        (r#"<bsdf type="pplastic"><float name="alpha_u" value="0.1"/></bsdf>"#, &["mat.xml:4", "alpha_v"]),
        (r#"<bsdf type="pplastic"><float name="nonlinear" value="1"/></bsdf>"#, &["mat.xml:4", "nonlinear"]),
        (
            r#"<bsdf type="twosided"><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf>"#,
            &["mat.xml:4", "twosided"],
        ),
    ];
    for (bsdf, words) in cases {
        let e = error(bsdf);
        for w in *words {
            assert!(e.contains(w), "error for {bsdf}\n  was: {e}\n  should mention: {w}");
        }
    }
}

fn temp_scene(name: &str, xml: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-materials-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, xml).unwrap();
    p
}

/// A camera looking at a rectangle (facing +z, the camera at +z or −z),
/// lit by a uniform white environment.
fn plane_scene(camera_z: f32, bsdf: &str, extra: &str) -> String {
    plane_scene_with(
        camera_z,
        bsdf,
        extra,
        r#"<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>"#,
    )
}

fn plane_scene_with(camera_z: f32, bsdf: &str, extra: &str, env: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="4"/></integrator>
<sensor type="perspective"><float name="fov" value="30"/>
  <transform name="to_world"><lookat origin="0, 0, {camera_z}" target="0, 0, 0" up="0, 1, 0"/></transform>
  <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
  <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
</sensor>
{env}
<shape type="rectangle"><transform name="to_world"><scale value="3"/></transform>{bsdf}</shape>
{extra}
</scene>"#
    )
}

/// `twosided` in every pixel: a lone rectangle, tilted 50° about y so that
/// the view's angle to the normal spans about 35° to 65° across the image,
/// filling the 16x16 view in a white furnace, so that each pixel shows the
/// albedo of the side it sees, exactly. One-sided from behind: black in every
/// pixel. Twosided: the front's (0.8, 0.2, 0.2) from the front, the back's
/// (0.2, 0.2, 0.8) from behind, per pixel and on average.
///
/// The diffuse estimator's distribution is the same in every pixel (it does
/// not depend on the view direction), so a pixel's variance is pooled over
/// the image (256 pixels × 15 degrees of freedom from 16 batches: σ known to
/// about 1 %). The three channels differ only by their reflectance (the
/// same random numbers), so each image gives 256 independent checks, not
/// 768. Per pixel |x − ρ| < 5σ: two-sided 5.7e-7 under normality (the mean
/// of 256 bounded samples), 2.9e-4 for the 512 pixels of both images. Image
/// mean |x̄ − ρ| < 4σ/√256: 6.3e-5 each, 1.3e-4 for both.
/// A fault confined to a few pixels shifts them by ≥ 0.4 (0.2 against 0.8
/// swapped), about 100σ; the image mean resolves 4σ/16 ≈ 0.001.
#[test]
fn twosided_shows_the_back_material_from_behind() {
    const SPP: u32 = 256;
    const BATCHES: u32 = 16;
    const Z_PIXEL: f64 = 5.0;
    const Z_MEAN: f64 = 4.0;
    let tilted = |camera_z: f32, bsdf: &str| {
        let xml = plane_scene(camera_z, bsdf, "");
        let scale = r#"<scale value="3"/></transform>"#;
        assert!(xml.contains(scale));
        xml.replace(scale, r#"<scale value="3"/><rotate y="1" angle="50"/></transform>"#)
    };
    let diffuse = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>"#;
    let twosided = r#"<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.2"/></bsdf><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.2, 0.8"/></bsdf></bsdf>"#;
    // One-sided from behind: black everywhere (the plane fills the view).
    let back = render_with_variance(&temp_scene("back.xml", &tilted(-4.0, diffuse)), 16, 4, None, 1);
    let lit: Vec<usize> = (0..back.mean.len()).filter(|&i| back.mean[i] != [0.0; 3]).collect();
    assert!(lit.is_empty(), "one-sided diffuse seen from behind is not black in pixels {lit:?}");
    let front = render_with_variance(&temp_scene("front.xml", &tilted(4.0, twosided)), SPP, BATCHES, None, 1);
    let behind = render_with_variance(&temp_scene("behind.xml", &tilted(-4.0, twosided)), SPP, BATCHES, None, 2);
    for (label, e, want) in [("front", &front, [0.8, 0.2, 0.2]), ("behind", &behind, [0.2, 0.2, 0.8])] {
        let n = e.mean.len();
        for c in 0..3 {
            let sigma = (e.var.iter().map(|v| v[c]).sum::<f64>() / n as f64).sqrt();
            let z: Vec<f64> = e.mean.iter().map(|m| (m[c] - want[c]) / sigma).collect();
            let (worst, at) = z.iter().enumerate().fold(
                (0.0f64, 0),
                |(w, at), (i, z)| {
                    if z.abs() > w {
                        (z.abs(), i)
                    } else {
                        (w, at)
                    }
                },
            );
            let mean = e.mean.iter().map(|m| m[c]).sum::<f64>() / n as f64;
            let se = sigma / (n as f64).sqrt();
            eprintln!(
                "twosided {label} channel {c}: image mean {mean:.5} vs {} (se {se:.5}), pixel σ {sigma:.5}, largest |z| {worst:.2} at pixel {at}",
                want[c]
            );
            assert!(
                worst < Z_PIXEL,
                "twosided {label} channel {c}: pixel ({}, {}) is {} vs {} (σ {sigma})",
                at % 16,
                at / 16,
                e.mean[at][c],
                want[c]
            );
            assert!(
                (mean - want[c]).abs() < Z_MEAN * se,
                "twosided {label} channel {c}: mean {mean} vs {} ± {se}",
                want[c]
            );
        }
    }
}

#[test]
fn masks_and_null_let_light_through_in_expectation() {
    // A red emitting plane seen through a second plane in front of it that
    // is (a) absent, (b) a null BSDF, (c) a mask of opacity 0, (d) opacity
    // 0.4 over black: (d) must be 0.6 of (a); (b) and (c) must equal (a).
    let red = r#"<emitter type="area"><rgb name="radiance" value="0.8, 0.3, 0.2"/></emitter>"#;
    let cover = |bsdf: &str| {
        format!(
            r#"<shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="1"/></transform>{bsdf}</shape>"#
        )
    };
    let black = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>"#;
    let render_spp = |name: &str, extra: &str, seed: u64, spp: u32| {
        render_with_variance(&temp_scene(name, &plane_scene_with(4.0, red, extra, "")), spp, 8, None, seed)
    };
    let render = |name: &str, extra: &str, seed: u64| render_spp(name, extra, seed, 64);
    let plain = render("plain.xml", "", 1);
    let null = render("null.xml", &cover(r#"<bsdf type="null"/>"#), 2);
    let clear = render(
        "clear.xml",
        &cover(&format!(r#"<bsdf type="mask"><float name="opacity" value="0"/>{black}</bsdf>"#)),
        3,
    );
    // Every path passes straight through: no noise at all.
    for (name, e) in [("null", &null), ("mask opacity 0", &clear)] {
        for (a, b) in e.mean.iter().zip(&plain.mean) {
            assert!((0..3).all(|c| (a[c] - b[c]).abs() < 1e-6), "{name}: {a:?} vs {b:?}");
        }
    }
    assert_eq!(plain.mean[8 * 16 + 8], [0.8f32 as f64, 0.3f32 as f64, 0.2f32 as f64]);
    // Enough samples for the comparison to resolve 1 % of the mean.
    let partial = render_spp(
        "partial.xml",
        &cover(&format!(r#"<bsdf type="mask"><float name="opacity" value="0.4"/>{black}</bsdf>"#)),
        4,
        1024,
    );
    let mut scaled = plain.clone();
    for (m, v) in scaled.mean.iter_mut().zip(scaled.var.iter_mut()) {
        for c in 0..3 {
            m[c] *= 0.6;
            v[c] *= 0.36;
        }
    }
    assert_agree("mask opacity 0.4", &partial, &scaled, 0.01);
}

#[test]
fn principled_parameters() {
    use penumbra_render::bsdf::PrincipledParams;
    let get = |xml: &str| match material(xml).unwrap() {
        Material::Principled(p) => *p,
        m => panic!("{m:?}"),
    };
    // Defaults: specular 0.5 ↦ η = 2 / (1 − √0.04) − 1 = 1.5; absent
    // parameters (and the float 0, Mitsuba's get_flag) are off.
    let p: PrincipledParams = get(r#"<bsdf type="principled"><float name="spec_trans" value="0"/></bsdf>"#);
    assert!((p.eta - 1.5).abs() < 1e-6);
    assert_eq!(constant(&p.base_color), Spectrum::splat(0.5));
    assert_eq!(constant(&p.roughness), Spectrum::splat(0.5));
    assert!(p.spec_trans.is_none() && p.metallic.is_none() && p.clearcoat.is_none() && p.sheen.is_none());
    // eta = 1 with transmission becomes 1.001, as in Mitsuba.
    let p = get(r#"<bsdf type="principled"><float name="eta" value="1"/><float name="spec_trans" value="0.5"/>
        <texture type="checkerboard" name="metallic"/><float name="clearcoat" value="0.3"/></bsdf>"#);
    assert!((p.eta - 1.001).abs() < 1e-6);
    assert!(p.spec_trans.is_some() && p.metallic.is_some() && p.clearcoat.is_some());
    let e =
        error(r#"<bsdf type="principled"><float name="eta" value="1.3"/><float name="specular" value="0.3"/></bsdf>"#);
    assert!(e.contains("either 'eta' or 'specular'"), "{e}");
    let e = error(r#"<bsdf type="principled"><float name="sample_visible" value="1"/></bsdf>"#);
    assert!(e.contains("sample_visible"), "{e}");
}
