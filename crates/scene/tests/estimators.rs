//! Every estimator converges to the same image: brute force (uniform,
//! cosine and BSDF sampling), path tracing with and without MIS, with power
//! light selection, and `direct` against `path` at max_depth 2.

use crate::common::{assert_agree, render_with_variance, root};

/// Each comparison must resolve an error of this fraction of the image mean
/// (see `common::compare`).
const RESOLUTION: f64 = 0.02;

#[test]
fn all_estimators_agree_on_the_diffuse_box() {
    let scene = root().join("tests/scenes/cbox_diffuse.xml");
    let reference = render_with_variance(&scene, 256, 8, Some("path"), 1);
    for (spec, spp) in [
        ("path:mis=false", 256),
        ("path:light_selection=power", 256),
        ("path:light_selection=bvh", 256),
        ("bruteforce:sampling=bsdf", 1024),
        ("bruteforce:sampling=cosine", 1024),
        ("bruteforce:sampling=uniform", 1024),
    ] {
        let est = render_with_variance(&scene, spp, 8, Some(spec), 2);
        assert_agree(spec, &est, &reference, RESOLUTION);
    }
}

#[test]
fn direct_matches_path_at_depth_two() {
    let scene = root().join("tests/scenes/direct_light.xml");
    let path = render_with_variance(&scene, 256, 8, Some("path:max_depth=2"), 1);
    for spec in ["direct", "direct:emitter_samples=4,bsdf_samples=0", "direct:emitter_samples=0,bsdf_samples=4"] {
        let est = render_with_variance(&scene, 256, 8, Some(spec), 2);
        assert_agree(spec, &est, &path, RESOLUTION);
    }
}

#[test]
fn light_selection_strategies_agree_on_many_lights() {
    let scene = root().join("tests/scenes/many_lights.xml");
    let uniform = render_with_variance(&scene, 256, 16, Some("path:light_selection=uniform"), 1);
    for spec in ["path:light_selection=power", "path:light_selection=bvh", "direct:light_selection=bvh"] {
        let reference = if spec.starts_with("direct") {
            render_with_variance(&scene, 256, 16, Some("path:max_depth=2,light_selection=power"), 1)
        } else {
            uniform.clone()
        };
        let est = render_with_variance(&scene, 256, 16, Some(spec), 2);
        assert_agree(spec, &est, &reference, RESOLUTION);
    }
}

#[test]
fn delta_lights_agree_between_direct_and_path() {
    for name in ["point_light", "spot_light"] {
        let scene = root().join("tests/scenes").join(format!("{name}.xml"));
        let path = render_with_variance(&scene, 256, 16, Some("path:max_depth=2"), 1);
        let direct = render_with_variance(&scene, 256, 16, Some("direct:emitter_samples=2"), 2);
        assert_agree(name, &direct, &path, RESOLUTION);
    }
}

#[test]
fn throughput_threshold_only_removes_energy() {
    // The threshold cuts paths whose weight max(β) fell below it: a tiny one
    // changes nothing, a large one loses the energy of the cut paths (biased
    // dark), and the loss grows with the threshold.
    let scene = root().join("tests/scenes/cbox_diffuse.xml");
    let mean = |spec: &str| {
        let e = render_with_variance(&scene, 64, 4, Some(spec), 3);
        e.mean.iter().map(|p| p[0] + p[1] + p[2]).sum::<f64>()
    };
    let full = mean("path");
    assert_eq!(mean("path:throughput_threshold=1e-12"), full);
    let cut_low = mean("path:throughput_threshold=0.05");
    let cut_high = mean("path:throughput_threshold=0.5");
    assert!(cut_low < full && cut_high < cut_low, "{full} {cut_low} {cut_high}");
    // A threshold above any path weight keeps only emission and direct light at the first hit.
    assert!(cut_high > 0.3 * full, "{full} {cut_high}");
}

#[test]
fn estimators_agree_on_hidden_emitters() {
    // Camera rays pass through hidden emitters in every integrator alike.
    let scene = root().join("tests/scenes/hidden_emitters.xml");
    let path = render_with_variance(&scene, 256, 16, Some("path"), 1);
    let brute = render_with_variance(&scene, 1024, 16, Some("bruteforce:sampling=bsdf"), 2);
    assert_agree("hidden_emitters bruteforce", &brute, &path, RESOLUTION);
}

#[test]
fn light_candidates_outside_one_to_sixty_four_are_refused() {
    let scene = root().join("tests/scenes/many_lights.xml");
    for m in ["0", "65", "-3"] {
        let ov =
            penumbra_scene::Overrides { integrator: Some(format!("path:light_candidates={m}")), ..Default::default() };
        let err = penumbra_scene::load_scene(&scene, &[], &ov).err().unwrap_or_else(|| panic!("{m} was accepted"));
        assert!(err.to_string().contains("light_candidates must be from 1"), "{m}: {err}");
    }
    let ov = penumbra_scene::Overrides { integrator: Some("path:light_candidates=64".into()), ..Default::default() };
    assert!(penumbra_scene::load_scene(&scene, &[], &ov).is_ok());
}

#[test]
fn guiding_spatial_threshold_is_read_and_checked() {
    use penumbra_render::integrator::Integrator;
    let scene = root().join("tests/scenes/many_lights.xml");
    let load = |v: &str| {
        let ov = penumbra_scene::Overrides {
            integrator: Some(format!("path:guiding=true,guiding_spatial_threshold={v}")),
            ..Default::default()
        };
        penumbra_scene::load_scene(&scene, &[], &ov)
    };
    for v in ["0", "0.5", "-3"] {
        let err = load(v).err().unwrap_or_else(|| panic!("{v} was accepted"));
        assert!(err.to_string().contains("guiding_spatial_threshold must be at least 1"), "{v}: {err}");
    }
    // Non-finite numbers are refused by the parameter reader, naming the parameter.
    for v in ["inf", "nan"] {
        let err = load(v).err().unwrap_or_else(|| panic!("{v} was accepted"));
        assert!(err.to_string().contains("'guiding_spatial_threshold'"), "{v}: {err}");
    }
    let job = load("3000").expect("3000 is valid");
    let Integrator::Path(p) = &job.integrator else { panic!("not path") };
    assert_eq!(p.guiding.map(|g| g.spatial_threshold), Some(3000.0));
}

#[test]
fn light_candidates_default_to_four_from_eight_lights_on() {
    use penumbra_render::integrator::{Integrator, DEFAULT_LIGHT_CANDIDATES};
    for (scene, expected) in
        [("many_lights.xml", DEFAULT_LIGHT_CANDIDATES), ("spot_light.xml", 1), ("cbox_diffuse.xml", 1)]
    {
        let job = penumbra_scene::load_scene(&root().join("tests/scenes").join(scene), &[], &Default::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let Integrator::Path(p) = &job.integrator else { panic!("{scene}: not path") };
        assert_eq!(p.light_candidates_for(job.scene.lights.len()), expected, "{scene}");
    }
}
