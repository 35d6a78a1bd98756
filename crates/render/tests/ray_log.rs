//! `Scene::ray_log` records exactly the queries a render makes (the rays
//! `penumbra bench` replays to time traversal alone) and changes nothing
//! in the image.

use penumbra_render::camera::{FovAxis, PerspectiveCamera};
use penumbra_render::film::{Film, Filter, FilterKind};
use penumbra_render::geometry::Shape;
use penumbra_render::integrator::{Integrator, PathIntegrator};
use penumbra_render::light::{ConstantLight, Light};
use penumbra_render::material::Material;
use penumbra_render::math::{look_at, Vec3};
use penumbra_render::render::RenderJob;
use penumbra_render::sampling::{Sampler, SamplerKind};
use penumbra_render::scene::{RayLog, Scene, ShapeInfo};

#[test]
fn the_log_holds_every_query_and_changes_nothing() {
    // Two diffuse spheres under a constant sky: bounces, escapes and
    // shadow rays, some of them blocked by the other sphere.
    let scene = Scene::new(
        vec![Shape::sphere(Vec3::ZERO, 1.0, false), Shape::sphere(Vec3::new(1.6, 0.0, 0.0), 0.5, false)],
        vec![ShapeInfo { material: 0, light: None }; 2],
        vec![Material::Diffuse(penumbra_render::bsdf::DiffuseParams { reflectance: Vec3::splat(0.8).into() })],
        vec![Light::Constant(ConstantLight { radiance: Vec3::ONE })],
    );
    let mut job = RenderJob {
        scene,
        camera: PerspectiveCamera::new(
            look_at(Vec3::new(0.5, 0.5, 5.0), Vec3::ZERO, Vec3::Y),
            50.0,
            FovAxis::X,
            12,
            12,
            1e-3,
            1e4,
        ),
        integrator: Integrator::Path(PathIntegrator::default()),
        sampler: Sampler::new(SamplerKind::Independent, 3, 4),
        filter: Filter::new(FilterKind::Box),
        width: 12,
        height: 12,
        crop_offset: (0, 0),
        full_size: (12, 12),
        stream: false,
        packet_lanes: 0,
    };
    let mut plain = Film::new(12, 12);
    let plain_stats = job.render_into(&mut plain, 0..4, &|_| {});

    let log = RayLog::default();
    job.scene.ray_log = Some(log.clone());
    let mut logged = Film::new(12, 12);
    let stats = job.render_into(&mut logged, 0..4, &|_| {});

    assert_eq!(plain.develop(), logged.develop(), "logging must not change the image");
    let log = log.lock().unwrap();
    let shadow = log.iter().filter(|l| l.shadow).count() as u64;
    let closest = log.len() as u64 - shadow;
    assert_eq!((closest, shadow), (stats.rays.rays, stats.rays.shadow_rays));
    assert_eq!((plain_stats.rays.rays, plain_stats.rays.shadow_rays), (stats.rays.rays, stats.rays.shadow_rays));
    assert!(closest > 12 * 12 * 4 && shadow > 0, "{closest} closest, {shadow} shadow");
    // Rays are logged as traced: unit directions, positive extents.
    assert!(log.iter().all(|l| (l.ray.d.length() - 1.0).abs() < 1e-4 && l.ray.t_max > 0.0));
}
