//! Penumbra against Mitsuba 3: each scene in tests/scenes/ is rendered and
//! compared with its converged Mitsuba reference in tests/refs/ (regenerate
//! with tools/make_refs.py) by `common::compare`: per-channel means, 8x8-block
//! χ² and largest block deviation at a false-alarm rate of 1e-4 per scene,
//! each comparison resolving 2 % of the image mean. On the noisy scenes each comparison also shows its power: the
//! same render with a local error injected (a wider lobe, a mirror image,
//! 10 % more light over a fifth of the image) must fail it. At the end, the same
//! comparisons with path guiding on.

use crate::common;

use crate::common::{
    assert_agree, compare as compare_estimates, compare_path, injected_errors, reference, render_with_sampler,
    render_with_variance, root,
};

/// Every comparison must resolve an error of this fraction in each
/// channel's image mean (the mean z-test's limit, 4.5 standard errors at
/// its false-alarm rate, may not exceed it).
const RESOLUTION: f64 = 0.02;

/// Scenes whose noise could hide a local error from a weaker comparison:
/// here each injected error must be caught.
const NOISY: &[&str] = &["envmap_sun", "many_lights", "rough_spheres", "spot_light", "ptracer_box"];

fn compare(name: &str, spp: u32) {
    let scene = root().join("tests/scenes").join(format!("{name}.xml"));
    let ours = render_with_variance(&scene, spp, 8, None, 1);
    let reference = reference(name);
    assert_agree(name, &ours, &reference, RESOLUTION);
    for (error, bad) in injected_errors(&ours) {
        let caught =
            !compare_estimates(&format!("{name} with {error}"), &bad, &reference, RESOLUTION).failures.is_empty();
        eprintln!("{name}: injected error '{error}' caught: {caught}");
        assert!(caught || !NOISY.contains(&name), "{name}: the comparison missed an injected error: {error}");
    }
}

#[test]
fn cbox_diffuse_matches_mitsuba() {
    compare("cbox_diffuse", 256);
}

#[test]
fn spheres_env_matches_mitsuba() {
    compare("spheres_env", 256);
}

#[test]
fn mesh_ply_obj_matches_mitsuba() {
    compare("mesh_ply_obj", 256);
}

#[test]
fn glass_caustic_matches_mitsuba() {
    compare("glass_caustic", 512);
}

#[test]
fn direct_light_matches_mitsuba() {
    compare("direct_light", 256);
}

#[test]
fn hidden_emitters_matches_mitsuba() {
    compare("hidden_emitters", 256);
}

#[test]
fn point_light_matches_mitsuba() {
    compare("point_light", 256);
}

#[test]
fn spot_and_directional_lights_match_mitsuba() {
    compare("spot_light", 256);
}

#[test]
fn envmap_sun_matches_mitsuba() {
    compare("envmap_sun", 512);
}

/// A room lit by the sun and sky through a thindielectric window.
#[test]
fn window_matches_mitsuba() {
    compare("window", 2048);
}

/// A room lit by a uniform sky through a thindielectric window.
#[test]
fn window_sky_matches_mitsuba() {
    compare("window_sky", 512);
}

/// The sky alone: pinhole rays and envmap escapes evaluated in lanes.
#[test]
fn sky_matches_mitsuba() {
    compare("sky", 64);
}

#[test]
fn many_lights_match_mitsuba() {
    compare("many_lights", 256);
}

#[test]
fn direct_integrator_matches_mitsuba() {
    compare("direct_integrator", 256);
}

#[test]
fn rough_spheres_match_mitsuba() {
    compare("rough_spheres", 256);
}

#[test]
fn textured_matches_mitsuba() {
    compare("textured", 256);
}

#[test]
fn thinlens_and_multijitter_match_mitsuba() {
    compare("sensors_samplers", 256);
}

#[test]
fn orthographic_and_ldsampler_match_mitsuba() {
    compare("orthographic", 256);
}

#[test]
fn format_features_match_mitsuba() {
    // <path>, sampled and .spd spectra, serialized meshes, a cylinder, instances.
    compare("format_features", 256);
}

#[test]
fn principled_matches_mitsuba() {
    compare("principled", 256);
}

#[test]
fn vertex_colors_match_mitsuba() {
    // PLY vertex and face attributes through mesh_attribute.
    compare("vertex_colors", 256);
}

#[test]
fn principledthin_matches_mitsuba() {
    compare("principledthin", 256);
}

#[test]
fn sobol_sampler_matches_mitsuba() {
    // `--sampler sobol` on scenes Mitsuba rendered with its own samplers:
    // a different sampler must not change the image's expectation.
    for name in ["cbox_diffuse", "envmap_sun"] {
        let scene = root().join("tests/scenes").join(format!("{name}.xml"));
        let ours = render_with_sampler(&scene, 256, 8, "sobol", 1);
        assert_agree(name, &ours, &reference(name), RESOLUTION);
    }
}

#[test]
fn fog_with_a_spot_light_matches_mitsuba() {
    // Chromatic homogeneous fog around the camera (sensor medium), hg phase.
    compare("fog_spot", 2048);
}

#[test]
fn heterogeneous_smoke_matches_mitsuba() {
    // A gridvolume (.vol) under the sun-and-sky map: delta and ratio tracking.
    compare("smoke_grid", 256);
}

#[test]
fn media_inside_glass_match_mitsuba() {
    // Dense media behind dielectric interfaces; blendphase; sample_emitters false; volpathmis.
    // Long paths through glass into a dense medium and back to a small
    // light are heavy-tailed: enough samples for each batch's spread to show it.
    compare("glass_medium", 2048);
}

#[test]
fn emitters_inside_a_medium_match_mitsuba() {
    // An area emitter and a point light in a medium seen from vacuum; hide_emitters.
    compare("emitter_in_medium", 256);
}

#[test]
fn textured_spot_light_matches_mitsuba() {
    // spot_light.xml with a bitmap projected through the cone (`texture`).
    compare("spot_texture", 256);
}

#[test]
fn pplastic_matches_mitsuba() {
    // Beckmann, anisotropic GGX with `eta`, textured roughness with a
    // specular tint and a named IOR.
    compare("pplastic", 256);
}

#[test]
fn hair_matches_mitsuba() {
    // Pigments and sigma_a, on cylinders (fibres along the axis) and a
    // sphere (along the meridians).
    compare("hair", 256);
}

#[test]
fn measured_matches_mitsuba() {
    // An isotropic and a half-turn anisotropic RGL .bsdf file, the latter
    // also on a sphere turned about the view axis.
    compare("measured", 256);
}

#[test]
fn textured_area_lights_match_mitsuba() {
    // `area` emitters with a bitmap and a checkerboard `radiance`.
    compare("area_texture", 256);
}

#[test]
fn projector_lights_match_mitsuba() {
    // A bitmap and a constant image projected by `projector` emitters.
    compare("projector", 256);
}

#[test]
fn directionalarea_emitters_match_mitsuba() {
    // `directionalarea` shapes: their BSDF (or a black one), no emission.
    compare("directionalarea", 256);
}

#[test]
fn sunsky_matches_mitsuba() {
    // Mitsuba's Hosek-Wilkie `sunsky` (from a date, time and place) over diffuse shapes.
    if let Some(why) = common::sunsky_data_missing() {
        return common::skip("sunsky_matches_mitsuba", &why);
    }
    compare("sunsky", 256);
}

#[test]
fn timed_sunsky_matches_mitsuba() {
    // `timed_sunsky` at one instant, with the complex (limb-darkened) sun.
    if let Some(why) = common::sunsky_data_missing() {
        return common::skip("timed_sunsky_matches_mitsuba", &why);
    }
    compare("timed_sunsky", 256);
}

/// Mitsuba's `ellipsoids` (analytic) and `ellipsoidsmesh` (icosahedral
/// shells) from one PLY file, two of the ellipsoids overlapping (back faces culled).
#[test]
fn ellipsoids_match_mitsuba() {
    compare("ellipsoids", 256);
}

/// Mitsuba's `sdfgrid`: a 20³ signed distance grid with smooth shading
/// normals (diffuse) and with analytic ones (rough copper), one scaled unevenly.
#[test]
fn sdfgrid_matches_mitsuba() {
    compare("sdfgrid", 256);
}

/// Mitsuba's `linearcurve` (Embree's round linear curves): a tapering
/// helix, a zigzag with jumping radii and a single segment, textured on the
/// curves' uv by a checkerboard.
#[test]
fn linearcurve_matches_mitsuba() {
    compare("linearcurve", 256);
}

/// Mitsuba's `bsplinecurve` (Embree's round B-spline curves, open ends): the
/// helix and zigzag of linearcurve.xml as B-splines, and a curve whose end
/// radii are zero, textured on the curves' uv.
#[test]
fn bsplinecurve_matches_mitsuba() {
    compare("bsplinecurve", 256);
}

#[test]
fn particle_tracer_matches_mitsuba() {
    // The diffuse Cornell box rendered by `ptracer` (light paths splatted
    // through the tent filter) against Mitsuba's `ptracer`.
    compare("ptracer_box", 256);
}

/// A Mitsuba 0.6 file (version 0.6.0: camelCase names, diffuseReflectance,
/// a checkerboard's uoffset/voffset/uscale/vscale), upgraded in memory by
/// both renderers: Mitsuba 3 renders the same old file for the reference.
#[test]
fn old_format_scene_matches_mitsuba() {
    compare("old_format", 256);
}

#[test]
fn rayleigh_phase_matches_mitsuba() {
    // A homogeneous sphere of Rayleigh-scattering medium, lit from behind.
    compare("phase_rayleigh", 256);
}

#[test]
fn tabulated_phase_matches_mitsuba() {
    // tabphase: a forward peak, a backward bump (the sign of cos θ matters).
    compare("phase_tabphase", 256);
}

#[test]
fn sggx_phase_matches_mitsuba() {
    // sggx with S from a 6-channel gridvolume, varying over the medium.
    compare("phase_sggx", 256);
}

#[test]
fn volume_texture_matches_mitsuba() {
    // The volume texture: a colour grid, a constvolume, a grid's luminance as roughness.
    compare("volume_texture", 256);
}

#[test]
fn batch_sensor_matches_mitsuba() {
    // Two sensors (perspective, thin lens) side by side on one film.
    compare("batch_sensor", 256);
}

#[test]
fn sggx_in_a_heterogeneous_medium_matches_mitsuba() {
    // sggx's projected area scales the extinction at each tracked point.
    compare("phase_sggx_heterogeneous", 256);
}

// Path guiding is unbiased: scenes rendered with `guiding = true` (each
// batch trains its own guide on its first quarter of samples, so batches
// stay independent) match the same references by the same comparison.
// α = 0.3, so most directions at guided vertices come from the guide.

fn compare_guided(name: &str, max_depth: u32, spp: u32) {
    compare_path(name, max_depth, spp, "guiding=true,guiding_bsdf_fraction=0.3");
}

#[test]
fn guided_cbox_diffuse_matches_mitsuba() {
    compare_guided("cbox_diffuse", 8, 256);
}

/// With guiding's roulette by expected contribution off: by throughput, as
/// without guiding (the other guided tests have it on, the default).
#[test]
fn guided_cbox_diffuse_with_roulette_by_throughput_matches_mitsuba() {
    compare_path("cbox_diffuse", 8, 256, "guiding=true,guiding_bsdf_fraction=0.3,guiding_roulette=false");
}

#[test]
fn guided_glass_caustic_matches_mitsuba() {
    compare_guided("glass_caustic", 16, 512);
}

#[test]
fn guided_rough_spheres_match_mitsuba() {
    compare_guided("rough_spheres", 8, 256);
}

#[test]
fn guided_many_lights_match_mitsuba() {
    compare_guided("many_lights", 4, 256);
}

#[test]
fn guided_envmap_sun_matches_mitsuba() {
    // 1024 spp: with roulette by expected contribution the guided image is
    // noisier here (see README, Path guiding), and 512 spp could no longer
    // resolve the comparison's 2 % error in the mean.
    compare_guided("envmap_sun", 8, 1024);
}

// Resampled light selection is unbiased: scenes rendered with
// `light_candidates` > 1 match the same references by the same comparison;
// with delta lights (point and spot), each light selection, environment
// maps and glossy BSDFs (whose value is in the resampling's target), and
// with a guide as well.

#[test]
fn resampled_many_lights_match_mitsuba() {
    // Its default is 4 candidates (`many_lights_match_mitsuba`).
    compare_path("many_lights", 4, 128, "light_candidates=1");
    compare_path("many_lights", 4, 128, "light_candidates=8");
    compare_path("many_lights", 4, 128, "light_candidates=4,light_selection=bvh");
    compare_path("many_lights", 4, 128, "light_candidates=3,light_selection=power,guiding=true");
}

#[test]
fn resampled_point_and_spot_lights_match_mitsuba() {
    compare_path("point_light", 4, 128, "light_candidates=4");
    // Where the spot is blocked, its unshadowed target wins most picks and
    // the rare unblocked pick of the fill light carries a large weight:
    // heavy tails, which batches of 128 samples resolve too roughly for
    // their spread to estimate the error.
    compare_path("spot_light", 3, 512, "light_candidates=4");
    compare_path("direct_light", 2, 128, "light_candidates=4");
}

#[test]
fn resampled_rough_spheres_and_cbox_match_mitsuba() {
    compare_path("rough_spheres", 8, 256, "light_candidates=4");
    compare_path("cbox_diffuse", 8, 256, "light_candidates=2");
}

/// BSDFs whose density is not a closed form of their sampling: a guided
/// vertex divides by α p_bsdf + (1 − α) p_guide, so a pdf that disagreed
/// with the BSDF's sampling would bias these (unguided renders only weigh
/// MIS by it).
#[test]
fn guided_principled_matches_mitsuba() {
    compare_guided("principled", 8, 256);
}

#[test]
fn guided_principledthin_matches_mitsuba() {
    // Noisier guided than not (its delta transmission keeps a weight over α):
    // 512 samples to resolve 2 % of the image mean.
    compare_guided("principledthin", 8, 512);
}

#[test]
fn guided_pplastic_matches_mitsuba() {
    compare_guided("pplastic", 6, 256);
}

#[test]
fn guided_hair_matches_mitsuba() {
    compare_guided("hair", 8, 256);
}

#[test]
fn guided_measured_matches_mitsuba() {
    compare_guided("measured", 6, 256);
}

#[test]
fn guided_textured_matches_mitsuba() {
    compare_guided("textured", 6, 256);
}
