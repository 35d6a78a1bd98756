//! The stream integrator (paths in flight per tile, rays traced in packets)
//! against the one-path-at-a-time loop it replaces: on every scene of
//! tests/scenes and the bundled scenes, the film (beauty, every AOV layer,
//! variance moments) and the ray counts must be bitwise equal, for a first
//! pass and for a later sample range, with packets of every lane width the
//! build has (16 with AVX-512, 8 with AVX2, and 1, scalar, on any CPU).

mod common;

use common::root;
use penumbra_render::film::{AovKind, Film, FilmLayers};
use penumbra_render::render::LANE_WIDTHS;
use penumbra_scene::{load_scene, Overrides};
use std::path::Path;

fn bits(v: impl IntoIterator<Item = f32>) -> Vec<u32> {
    v.into_iter().map(f32::to_bits).collect()
}

/// Renders `scene` both ways; panics at the first difference. Returns
/// whether the scene's integrator is `path` (the others render one way),
/// and how many vertices the packets of more than one lane shaded in lanes.
fn check(scene: &Path, defines: &[(String, String)], spp: u32) -> (bool, u64) {
    let ov = Overrides { spp: Some(spp), ..Default::default() };
    let mut job = load_scene(scene, defines, &ov).unwrap_or_else(|e| panic!("{e}"));
    let layers = FilmLayers { aovs: AovKind::ALL.to_vec(), variance: true, ..Default::default() };
    let name = scene.file_name().unwrap().to_string_lossy();
    let is_path = matches!(job.integrator, penumbra_render::integrator::Integrator::Path(_));
    let mut lane_vertices = 0;
    for range in [0..spp, 3..spp] {
        let render = |job: &penumbra_render::render::RenderJob| {
            let mut film = Film::with_layers(job.width, job.height, &layers);
            let stats = job.render_into(&mut film, range.clone(), &|_| {});
            (film, stats)
        };
        job.stream = false;
        let (a, sa) = render(&job);
        for &lanes in LANE_WIDTHS {
            job.stream = true;
            job.packet_lanes = lanes;
            let (b, sb) = render(&job);
            if lanes > 1 {
                lane_vertices += sb.rays.lane_vertices;
            }
            let (a, sa, b, sb) = (&a, &sa, &b, &sb);
            let what = format!("{name}, samples {range:?}, packets of {lanes}");
            assert_eq!(
                (sa.samples, sa.rays.rays, sa.rays.shadow_rays, sa.non_finite),
                (sb.samples, sb.rays.rays, sb.rays.shadow_rays, sb.non_finite),
                "{what}: ray counts"
            );
            assert!(bits(a.develop().concat()) == bits(b.develop().concat()), "{what}: beauty differs");
            for k in AovKind::ALL {
                assert!(
                    bits(a.develop_aov(k).unwrap()) == bits(b.develop_aov(k).unwrap()),
                    "{what}: AOV {} differs",
                    k.name()
                );
            }
            assert!(
                bits(a.develop_variance().unwrap().concat()) == bits(b.develop_variance().unwrap().concat()),
                "{what}: variance differs"
            );
            assert!(a.develop().iter().flatten().any(|&c| c > 0.0), "{what}: a black image proves little");
        }
    }
    (is_path, lane_vertices)
}

#[test]
fn stream_is_bitwise_the_scalar_loop_on_every_test_scene() {
    let mut scenes: Vec<_> = std::fs::read_dir(root().join("tests/scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 15, "tests/scenes has {} scenes", scenes.len());
    let res = |n: &str| vec![("res".to_string(), n.to_string())];
    let (mut path_scenes, mut lane_scenes) = (0, 0);
    let mut tally = |(is_path, lane_vertices): (bool, u64)| {
        path_scenes += is_path as usize;
        lane_scenes += (lane_vertices > 0) as usize;
    };
    for s in &scenes {
        tally(check(s, &[], 8));
    }
    for s in ["scenes/cornell-box.xml", "scenes/material-showcase.xml"] {
        tally(check(&root().join(s), &res("48"), 8));
    }
    eprintln!(
        "{} scenes, {path_scenes} rendered by `path` both ways (packets of {LANE_WIDTHS:?}), \
         {lane_scenes} with vertices shaded in lanes: bitwise equal",
        scenes.len() + 2
    );
    assert!(path_scenes >= 10);
    // Diffuse vertices (the Cornell boxes') run in lanes where packets are wider than 1.
    assert!(LANE_WIDTHS.len() == 1 || lane_scenes >= 3, "{lane_scenes} scenes had lane vertices");
}
