//! Path guiding is unbiased: scenes of tests/scenes rendered with
//! `guiding = true` (each batch trains its own guide on its first quarter
//! of samples, so batches stay independent) match their Mitsuba references
//! by the same comparison as `references.rs` (`common::compare`: channel
//! means, 8x8-block χ² and largest block deviation, false-alarm rate 1e-4).
//! α = 0.3 here, so most directions at guided vertices come from the guide.

mod common;

use common::{assert_agree, reference, render_with_variance, root};

fn compare(name: &str, max_depth: u32, spp: u32) {
    let scene = root().join("tests/scenes").join(format!("{name}.xml"));
    let integrator = format!("path:max_depth={max_depth},guiding=true,guiding_bsdf_fraction=0.3");
    let ours = render_with_variance(&scene, spp, 8, Some(&integrator), 3);
    assert_agree(&format!("{name} (guided)"), &ours, &reference(name), 0.02);
}

#[test]
fn guided_cbox_diffuse_matches_mitsuba() {
    compare("cbox_diffuse", 8, 256);
}

#[test]
fn guided_glass_caustic_matches_mitsuba() {
    compare("glass_caustic", 16, 512);
}

#[test]
fn guided_rough_spheres_match_mitsuba() {
    compare("rough_spheres", 8, 256);
}

#[test]
fn guided_many_lights_match_mitsuba() {
    compare("many_lights", 4, 256);
}

#[test]
fn guided_envmap_sun_matches_mitsuba() {
    compare("envmap_sun", 8, 512);
}

/// BSDFs whose density is not a closed form of their sampling: a guided
/// vertex divides by α p_bsdf + (1 − α) p_guide, so a pdf that disagreed
/// with the BSDF's sampling would bias these (unguided renders only weigh
/// MIS by it).
#[test]
fn guided_principled_matches_mitsuba() {
    compare("principled", 8, 256);
}

#[test]
fn guided_principledthin_matches_mitsuba() {
    // Noisier guided than not (its delta transmission keeps a weight over α):
    // 512 samples to resolve 2 % of the image mean.
    compare("principledthin", 8, 512);
}

#[test]
fn guided_pplastic_matches_mitsuba() {
    compare("pplastic", 6, 256);
}

#[test]
fn guided_hair_matches_mitsuba() {
    compare("hair", 8, 256);
}

#[test]
fn guided_measured_matches_mitsuba() {
    compare("measured", 6, 256);
}

#[test]
fn guided_textured_matches_mitsuba() {
    compare("textured", 6, 256);
}
