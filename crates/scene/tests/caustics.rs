//! `path`'s caustics carried by light paths (`integrator::path::caustics`):
//! unbiased at any rate of light paths and without them (against Mitsuba,
//! whose `path` has none), and what they are for, a caustic's variance
//! cut several-fold. The other scene tests run them too, by default on.

use crate::common::{compare_path, reference, render_with_variance, root, Estimate};
use penumbra_render::film::Film;
use penumbra_render::integrator::Integrator;
use penumbra_scene::{load_scene, Overrides};

/// A caustic of an area light through a glass sphere: with a light path
/// for every camera sample, a quarter of them, and none (512 spp, as the
/// scene's reference test).
#[test]
fn glass_caustic_matches_mitsuba_at_every_rate_of_light_paths() {
    compare_path("glass_caustic", 16, 512, "caustic_paths=1");
    compare_path("glass_caustic", 16, 512, "caustic_paths=0.25");
    compare_path("glass_caustic", 16, 512, "caustics=false");
}

/// Light paths that go on through non-delta bounces after their first
/// delta chain (`caustic_bounces`), so that they also carry the caustic's
/// light reflected by diffuse surfaces before the camera sees it: one such
/// bounce, and as many as the depth allows, at a light path per camera
/// sample and at a quarter.
#[test]
fn glass_caustic_matches_mitsuba_with_light_paths_bouncing() {
    compare_path("glass_caustic", 16, 512, "caustic_paths=1,caustic_bounces=1");
    compare_path("glass_caustic", 16, 512, "caustic_paths=1,caustic_bounces=64");
    compare_path("glass_caustic", 16, 512, "caustic_paths=0.25,caustic_bounces=64");
}

/// The sun's caustic through a glass sphere and its glints off a mirror
/// sphere: light paths from an emitter at infinity (512 spp, as the
/// scene's reference test).
#[test]
fn envmap_sun_matches_mitsuba_with_a_light_path_per_sample() {
    compare_path("envmap_sun", 8, 512, "caustic_paths=1");
    compare_path("envmap_sun", 8, 512, "caustic_paths=1,caustic_bounces=64");
}

/// A room lit through a window by the sun and sky of `envmap_sun`: the
/// light paths carry the sun's caustics (its patch on the floor, through
/// the pane) and leave the sky's to camera paths, which together count
/// every path once (a light path per camera sample, 1024 spp; the
/// scene's reference test renders the default at 2048).
#[test]
fn window_matches_mitsuba_with_the_sky_on_camera_paths() {
    compare_path("window", 8, 1024, "caustic_paths=1");
}

/// A uniform sky is no concentrated source (`Light::caustics_by_light_paths`):
/// camera paths keep all of its light through the window, so light paths
/// add nothing and the image with caustics on is the one without, bit for
/// bit. (With every environment on light paths, which carried every path
/// through the pane, this room had 18x the variance of camera paths alone.)
#[test]
fn a_uniform_sky_through_a_window_stays_on_camera_paths() {
    let scene = root().join("tests/scenes/window_sky.xml");
    let image = |spec: &str| {
        let ov = Overrides { spp: Some(16), integrator: Some(spec.to_string()), ..Default::default() };
        let job = load_scene(&scene, &[], &ov).unwrap_or_else(|e| panic!("{e}"));
        let caustics = matches!(&job.integrator, Integrator::Path(p) if p.caustics);
        let mut film = Film::new(job.width, job.height);
        job.render_into(&mut film, 0..job.sampler.spp, &|_| {});
        (caustics, film.develop())
    };
    let (on, with) = image("path:max_depth=8,caustic_paths=1");
    let (off, without) = image("path:max_depth=8,caustics=false");
    assert!(on && !off, "caustics {on} / {off}");
    assert!(without.iter().any(|p| p[0] > 0.0), "the room is dark");
    assert!(with == without, "light paths changed the image");
}

/// relMSE of `e`'s mean against the reference `r`, less the reference's
/// own share (its variance over the same denominator): the error of the
/// image itself.
fn rel_mse(e: &Estimate, r: &Estimate) -> f64 {
    let n = (3 * e.mean.len()) as f64;
    let mut sum = 0.0;
    for ((m, rm), rv) in e.mean.iter().zip(&r.mean).zip(&r.var) {
        for c in 0..3 {
            sum += ((m[c] - rm[c]).powi(2) - rv[c]) / (rm[c] * rm[c] + 0.01);
        }
    }
    sum / n
}

/// The sun's caustic under the glass sphere is fireflies for camera paths
/// and smooth for light paths: against the converged reference, the
/// image's relMSE falls by more than half at equal samples (5.6x at
/// 128x128 and 256 spp against the bench's reference; see the README).
#[test]
fn light_paths_cut_the_error_of_caustics() {
    let scene = root().join("tests/scenes/envmap_sun.xml");
    let r = reference("envmap_sun");
    let on = rel_mse(&render_with_variance(&scene, 256, 8, Some("path:max_depth=8"), 1), &r);
    let off = rel_mse(&render_with_variance(&scene, 256, 8, Some("path:max_depth=8,caustics=false"), 1), &r);
    eprintln!("relMSE: {on:.4e} with light paths, {off:.4e} without");
    assert!(off > 2.0 * on, "with light paths {on:.4e}, without {off:.4e}");
}

/// Where light paths cannot reach the camera as its rays leave it (hidden
/// emitters that camera rays pass through, an orthographic camera) or run
/// nested in another integrator, the camera paths keep the caustics.
#[test]
fn caustics_are_off_where_light_paths_cannot_carry_them() {
    let caustics = |name: &str, integrator: Option<&str>| {
        let ov = Overrides { integrator: integrator.map(str::to_string), ..Default::default() };
        let job = load_scene(&root().join("tests/scenes").join(name), &[], &ov).unwrap_or_else(|e| panic!("{e}"));
        match job.integrator {
            Integrator::Path(p) => p.caustics,
            Integrator::Aov(a) => a.integrators.iter().any(|(_, i)| matches!(i, Integrator::Path(p) if p.caustics)),
            _ => panic!("{name}: not a path or aov integrator"),
        }
    };
    assert!(caustics("glass_caustic.xml", None));
    assert!(!caustics("glass_caustic.xml", Some("path:caustics=false")));
    assert!(!caustics("hidden_emitters.xml", None));
    assert!(!caustics("orthographic.xml", Some("path")));
    assert!(!caustics("aov_channels.xml", None));
}

/// `caustic_bounces` is -1 (unbounded, the default) or 0 to 64; anything
/// else is refused with its meaning.
#[test]
fn caustic_bounces_is_read_and_checked() {
    let scene = root().join("tests/scenes/glass_caustic.xml");
    let load = |spec: Option<&str>| {
        let ov = Overrides { integrator: spec.map(str::to_string), ..Default::default() };
        load_scene(&scene, &[], &ov)
    };
    let bounces = |spec: Option<&str>| match load(spec).unwrap_or_else(|e| panic!("{e}")).integrator {
        Integrator::Path(p) => p.caustic_bounces,
        _ => panic!("not a path integrator"),
    };
    assert_eq!(bounces(None), u32::MAX);
    assert_eq!(bounces(Some("path:caustic_bounces=-1")), u32::MAX);
    assert_eq!(bounces(Some("path:caustic_bounces=0")), 0);
    assert_eq!(bounces(Some("path:caustic_bounces=64")), 64);
    for m in ["65", "-2", "1000"] {
        let err = load(Some(&format!("path:caustic_bounces={m}"))).err().unwrap_or_else(|| panic!("{m} was accepted"));
        assert!(err.to_string().contains("caustic_bounces must be -1"), "{m}: {err}");
    }
}

/// Which shapes' delta lobes light paths carry, through the wrappers
/// (`twosided`, `blendbsdf`, `mask`) to the materials inside: glass and
/// mirrors do, a specular coat over a diffuse base and rough or diffuse
/// materials do not, and a wrapper does where any material inside it does.
#[test]
fn carriers_are_found_through_wrappers() {
    let bsdfs = [
        (r#"<bsdf type="dielectric"/>"#, true),
        (r#"<bsdf type="conductor"/>"#, true),
        (r#"<bsdf type="thindielectric"/>"#, true),
        (r#"<bsdf type="diffuse"/>"#, false),
        (r#"<bsdf type="roughconductor"/>"#, false),
        (r#"<bsdf type="plastic"/>"#, false),
        (r#"<bsdf type="twosided"><bsdf type="plastic"/></bsdf>"#, false),
        (r#"<bsdf type="twosided"><bsdf type="conductor"/></bsdf>"#, true),
        (
            r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/><bsdf type="dielectric"/></bsdf>"#,
            true,
        ),
        (
            r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/><bsdf type="plastic"/></bsdf>"#,
            false,
        ),
        (r#"<bsdf type="mask"><float name="opacity" value="0.5"/><bsdf type="diffuse"/></bsdf>"#, true),
    ];
    let shapes: String = bsdfs
        .iter()
        .enumerate()
        .map(|(i, (b, _))| format!(r#"<shape type="sphere"><point name="center" x="{i}" y="0" z="0"/><float name="radius" value="0.3"/>{b}</shape>"#))
        .collect();
    let xml = format!(
        r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"/></sensor><emitter type="constant"/>{shapes}</scene>"#
    );
    let desc = penumbra_scene::mitsuba::parse_str(&xml, std::path::Path::new("carriers.xml"), &[])
        .unwrap_or_else(|e| panic!("{e}"));
    let job = penumbra_scene::builder::build(&desc, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    for (i, (b, carries)) in bsdfs.iter().enumerate() {
        assert_eq!(job.scene.carries_caustics(i as u32), *carries, "{b}");
    }
}
