//! Participating media against closed forms: furnaces (lossless media and
//! boundaries inside a uniform environment render the environment's
//! radiance) and attenuation (an absorbing medium between a lit floor,
//! its point light and the camera gives the exact exp(−σ_t d) factors on
//! both the camera ray and the shadow ray). Tolerances come from each
//! render's measured spread (4.5 standard errors of the image mean).

use glam::Mat4;
use penumbra_render::bsdf::{DielectricParams, DiffuseParams};
use penumbra_render::camera::{FovAxis, PerspectiveCamera};
use penumbra_render::film::{Film, Filter, FilterKind};
use penumbra_render::geometry::Shape;
use penumbra_render::integrator::{Integrator, Termination, VolPathIntegrator};
use penumbra_render::light::{ConstantLight, Light, PointLight};
use penumbra_render::material::Material;
use penumbra_render::math::{look_at, Spectrum, Vec3, PI};
use penumbra_render::medium::volume::unit_cube_bounds;
use penumbra_render::medium::{Grid, GridVolume, Medium, MediumKind, PhaseFunction, Volume, VolumeFilter, WrapMode};
use penumbra_render::render::RenderJob;
use penumbra_render::sampling::{Sampler, SamplerKind};
use penumbra_render::scene::{Scene, ShapeInfo, ShapeMedia};
use std::sync::Arc;

const RES: u32 = 16;

fn job(scene: Scene, from: Vec3, at: Vec3, up: Vec3, fov: f32, max_depth: u32, spp: u32) -> RenderJob {
    RenderJob {
        scene,
        camera: PerspectiveCamera::new(look_at(from, at, up), fov, FovAxis::X, RES, RES, 1e-3, 1e4),
        integrator: Integrator::VolPath(VolPathIntegrator {
            term: Termination { max_depth, ..Termination::default() },
            hide_emitters: false,
        }),
        sampler: Sampler::new(SamplerKind::Independent, 5, spp),
        filter: Filter::new(FilterKind::Box),
        width: RES,
        height: RES,
        crop_offset: (0, 0),
        full_size: (RES, RES),
        stream: true,
        packet_lanes: 0,
    }
}

/// The image, and per channel its mean and the standard error of that
/// mean (from the spread between 8 independent batches).
fn render(job: &RenderJob, spp: u32) -> (Vec<[f32; 3]>, [f64; 3], [f64; 3]) {
    let batches = 8;
    let per = spp / batches;
    let mut total = Film::new(job.width, job.height);
    let mut means = Vec::new();
    for b in 0..batches {
        let mut f = Film::new(job.width, job.height);
        job.render_into(&mut f, b * per..(b + 1) * per, &|_| {});
        let img = f.develop();
        let n = img.len() as f64;
        means.push([0, 1, 2].map(|c| img.iter().map(|p| p[c] as f64).sum::<f64>() / n));
        total.merge(&f);
    }
    let k = batches as f64;
    let mean = [0, 1, 2].map(|c| means.iter().map(|m| m[c]).sum::<f64>() / k);
    let se = [0, 1, 2].map(|c| (means.iter().map(|m| (m[c] - mean[c]).powi(2)).sum::<f64>() / (k - 1.0) / k).sqrt());
    (total.develop(), mean, se)
}

fn assert_mean(what: &str, (mean, se): ([f64; 3], [f64; 3]), want: [f64; 3], rel: f64) {
    for c in 0..3 {
        let tol = 4.5 * se[c] + rel * want[c] + 1e-6;
        assert!((mean[c] - want[c]).abs() <= tol, "{what}: channel {c}: {} vs {} (± {tol})", mean[c], want[c]);
    }
}

fn homogeneous(sigma_t: Spectrum, albedo: Spectrum, phase: PhaseFunction) -> Medium {
    Medium { kind: MediumKind::Homogeneous { sigma_t, albedo }, phase, sample_emitters: true }
}

/// A 5³ grid of densities 0.5..4 over the cube [-0.8, 0.8]³, albedo 1.
fn grid_medium() -> Medium {
    let data: Vec<f32> = (0..125).map(|i| 0.5 + 3.5 * ((i * 37 % 125) as f32 / 124.0)).collect();
    let grid = Arc::new(Grid { res: [5, 5, 5], channels: 1, data });
    let to_world = Mat4::from_translation(Vec3::splat(-0.8)) * Mat4::from_scale(Vec3::splat(1.6));
    let gv = GridVolume {
        grid: grid.clone(),
        to_local: to_world.inverse(),
        filter: VolumeFilter::Trilinear,
        wrap: WrapMode::Clamp,
        max: grid.max(),
    };
    Medium {
        kind: MediumKind::Heterogeneous {
            sigma_t: Box::new(Volume::Grid { grid: gv, bounds: unit_cube_bounds(to_world) }),
            albedo: Box::new(Volume::constant(Spectrum::ONE)),
            scale: 1.5,
            majorant: 1.5 * grid.max(),
        },
        phase: PhaseFunction::HenyeyGreenstein { g: -0.3 },
        sample_emitters: true,
    }
}

/// A unit sphere of `material` holding `medium`, in a uniform environment of radiance 1.
fn furnace(material: Material, medium: Medium) -> Scene {
    let mut scene = Scene::new(
        vec![Shape::sphere(Vec3::ZERO, 1.0, false)],
        vec![ShapeInfo { material: 0, light: None }],
        vec![material],
        vec![Light::Constant(ConstantLight { radiance: Vec3::ONE })],
    );
    scene.set_media(vec![medium], vec![ShapeMedia { interior: Some(0), exterior: None }], None);
    scene
}

/// Lossless media behind lossless boundaries (null and glass) in a white
/// furnace: every path ends in the environment with its energy intact, so
/// the image is 1 in every channel, whatever the phase function, the
/// chromatic extinction (one-sample spectral MIS) or the grid (delta and
/// ratio tracking).
#[test]
fn lossless_media_in_a_furnace_render_the_environment() {
    let glass = || {
        Material::Dielectric(DielectricParams {
            eta: 1.5,
            specular_reflectance: Spectrum::ONE.into(),
            specular_transmittance: Spectrum::ONE.into(),
        })
    };
    let cases: Vec<(&str, Material, Medium)> = vec![
        (
            "grey, isotropic, null boundary",
            Material::Null,
            homogeneous(Spectrum::splat(2.0), Spectrum::ONE, PhaseFunction::Isotropic),
        ),
        (
            "chromatic, hg 0.7, null boundary",
            Material::Null,
            homogeneous(Spectrum::new(0.5, 2.0, 4.0), Spectrum::ONE, PhaseFunction::HenyeyGreenstein { g: 0.7 }),
        ),
        ("grid, hg -0.3, null boundary", Material::Null, grid_medium()),
        (
            "chromatic, blend, glass boundary",
            glass(),
            homogeneous(
                Spectrum::new(3.0, 1.0, 0.3),
                Spectrum::ONE,
                PhaseFunction::Blend {
                    weight: 0.4,
                    first: Box::new(PhaseFunction::Isotropic),
                    second: Box::new(PhaseFunction::HenyeyGreenstein { g: 0.8 }),
                },
            ),
        ),
        ("grid, glass boundary", glass(), grid_medium()),
    ];
    for (what, material, medium) in cases {
        let spp = 1024;
        let j = job(furnace(material, medium), Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 45.0, u32::MAX, spp);
        let (img, mean, se) = render(&j, spp);
        eprintln!("{what}: mean {mean:?} ± {se:?}");
        assert_mean(what, (mean, se), [1.0; 3], 0.0);
        // The test resolves a 2 % error in every channel.
        assert!(se.iter().all(|&e| 4.5 * e < 0.02), "{what}: too noisy to resolve 2 %: se {se:?}");
        assert!(img.iter().all(|p| p.iter().all(|v| v.is_finite())), "{what}: a non-finite pixel");
    }
}

/// A diffuse floor (ρ) under a point light (I) at height h, all inside an
/// absorbing medium (albedo 0), seen from straight above at height H:
/// L(x) = ρ/π · I cos θ / r² · e^{−σ r} · e^{−σ t_cam}, the first factor
/// from the shadow ray's transmittance, the second from the camera ray's
/// free flight. Checked per channel on the image mean against the mean of
/// L over the pixel centres (a narrow field of view keeps the pixel
/// footprint's curvature error far below the tolerance).
#[test]
fn absorbing_media_attenuate_camera_and_shadow_rays_exactly() {
    let (rho, intensity, h, cam_h) = (0.7f32, 4.0f32, 1.2f32, 3.0f32);
    let sigma = Spectrum::new(0.2, 0.5, 0.9);
    let floor = Shape::disk(Mat4::from_rotation_x(-PI / 2.0) * Mat4::from_scale(Vec3::splat(10.0)), false);
    let media: Vec<(&str, Medium)> = vec![
        ("homogeneous", homogeneous(sigma, Spectrum::ZERO, PhaseFunction::Isotropic)),
        ("heterogeneous (constant grid)", {
            let to_world = Mat4::from_translation(Vec3::new(-20.0, -1.0, -20.0)) * Mat4::from_scale(Vec3::splat(40.0));
            Medium {
                kind: MediumKind::Heterogeneous {
                    sigma_t: Box::new(Volume::Constant { value: sigma / 2.0, bounds: unit_cube_bounds(to_world) }),
                    albedo: Box::new(Volume::constant(Spectrum::ZERO)),
                    scale: 2.0,
                    majorant: 2.0 * (sigma / 2.0).max_element(),
                },
                phase: PhaseFunction::Isotropic,
                sample_emitters: true,
            }
        }),
    ];
    for (what, medium) in media {
        let mut scene = Scene::new(
            vec![floor.clone()],
            vec![ShapeInfo { material: 0, light: None }],
            vec![Material::Diffuse(DiffuseParams { reflectance: Spectrum::splat(rho).into() })],
            vec![Light::Point(PointLight { position: Vec3::new(0.2, h, 0.1), intensity: Spectrum::splat(intensity) })],
        );
        scene.set_media(vec![medium], Vec::new(), Some(0));
        let fov = 20.0f32;
        let j = job(scene, Vec3::new(0.0, cam_h, 0.0), Vec3::ZERO, Vec3::Z, fov, 2, 256);
        let (_, mean, se) = render(&j, 256);
        // Expected: L at each pixel centre's floor point.
        let mut want = [0f64; 3];
        for py in 0..RES {
            for px in 0..RES {
                let ray = j
                    .camera
                    .generate_ray(glam::Vec2::new((px as f32 + 0.5) / RES as f32, (py as f32 + 0.5) / RES as f32));
                let t = -ray.o.y / ray.d.y;
                let x = ray.at(t);
                let to_light = Vec3::new(0.2, h, 0.1) - x;
                let r = to_light.length();
                let cos = to_light.y / r;
                for c in 0..3 {
                    let l = rho / PI * intensity * cos / (r * r) * (-sigma[c] * r).exp() * (-sigma[c] * t).exp();
                    want[c] += l as f64 / (RES * RES) as f64;
                }
            }
        }
        eprintln!("{what}: mean {mean:?} ± {se:?}, expected {want:?}");
        assert_mean(what, (mean, se), want, 2e-3);
    }
}
