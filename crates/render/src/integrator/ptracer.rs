//! Mitsuba `ptracer`: the particle tracer. Paths start at the emitters and
//! every surface vertex is connected to the camera; the contribution lands
//! wherever on the film the connection does, not in the pixel the path was
//! started for.
//!
//! | parameter        | type    | default |
//! |------------------|---------|---------|
//! | max_depth        | integer | -1 (unbounded; Mitsuba's count, 1 = emitters seen directly) |
//! | rr_depth         | integer | 5 (Russian roulette once a path has more segments than this) |
//! | hide_emitters    | boolean | false (no direct connections of emitters to the camera) |
//! | samples_per_pass | integer | -1 (accepted as Mitsuba's; Penumbra's passes come from the render schedule, and the image does not depend on them) |
//!
//! Light paths per render: one per full-film pixel and sample index (as
//! Mitsuba: width × height × spp particles), the path of pixel (x, y) and
//! sample s drawing its random numbers from that pixel sample's stream, so
//! every random number stays a function of (seed, pixel, sample index,
//! dimension). Each sample first connects a point sampled on one
//! (uniformly chosen) non-delta emitter to the camera (Mitsuba's
//! `sample_visible_emitters`, unless `hide_emitters` or `max_depth` = 0),
//! then traces one light path from a uniformly chosen emitter with BSDF
//! sampling in importance transport (refraction's 1/η² radiance scale
//! undone; the adjoint shading-normal correction of Veach, p. 155),
//! connecting each vertex to the camera through the BSDF evaluated as
//! f(towards the camera ← from the light): in Penumbra's radiance-mode
//! convention that is already the adjoint the connection needs, refraction
//! included. Splats go into
//! the film with the filter's weights normalised to sum to 1 (Mitsuba's
//! normalised `ImageBlock`); each pixel's weight sum counts the samples per
//! pixel instead, so the developed image is Σ splats / spp as Mitsuba's.
//!
//! Emitters at infinity (`constant`, `envmap`, `directional`) start their
//! paths on the disk of the scene's bounding sphere that faces the sampled
//! direction, and the non-delta ones are seen directly through a direction
//! sampled from the camera (Mitsuba's `sample_ray` and `sample_direction`).
//! Supported: the perspective and thin-lens cameras (a connection samples
//! the aperture, as Mitsuba's `thinlens` does); other sensors are refused
//! when the scene is loaded.

use super::{RayStats, Termination};
use crate::camera::{Camera, Projection};
use crate::geometry::ray::offset_origin;
use crate::geometry::Ray;
use crate::light::Light;
use crate::material::Scratch;
use crate::math::{Spectrum, PI};
use crate::sampling::{warp, SampleStream};
use crate::scene::Scene;
use glam::{Mat4, Vec2, Vec3};

/// The `ptracer` integrator.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleTracer {
    /// Longest path (Mitsuba's count) and the roulette depth.
    pub term: Termination,
    /// No direct connections of emitters to the camera.
    pub hide_emitters: bool,
    /// Mitsuba's `samples_per_pass` (None: -1, all); must divide the
    /// sample count, as Mitsuba requires. The image does not depend on it.
    pub samples_per_pass: Option<u32>,
}

/// One contribution to the film: where on the full film it lands (in
/// pixels, continuous) and its value (already divided by nothing: the
/// film's weight sum holds the sample count).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Splat {
    /// Full-film position in pixels (x right, y down).
    pub pos: Vec2,
    /// The contribution.
    pub value: Spectrum,
}

/// The camera as the light paths connect to it (Mitsuba's
/// `sample_direction` of `perspective` and `thinlens`).
#[derive(Debug, Clone)]
pub struct CameraConnection {
    camera_from_world: Mat4,
    world_from_camera: Mat4,
    /// The camera's position (the lens centre).
    pub eye: Vec3,
    tan_half: Vec2,
    near: f32,
    far: f32,
    /// 1 / the area of the film's rectangle on the plane z = 1.
    normalization: f32,
    full_size: Vec2,
    /// The thin lens: aperture radius and focus distance.
    lens: Option<(f32, f32)>,
}

/// A connection to the camera: where it lands on the film, its weight
/// (the importance W_e over the squared distance: the aperture's density
/// cancels the lens area in W_e), and the point on the lens it reaches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraPoint {
    /// Full-film position in pixels.
    pub pos: Vec2,
    /// W_e / d².
    pub weight: f32,
    /// The lens point (the pinhole, or the sampled aperture point).
    pub at: Vec3,
}

impl CameraConnection {
    /// The connection of a perspective or thin-lens camera with a film of
    /// `full_size` pixels; None for other projections.
    pub fn new(camera: &Camera, full_size: (u32, u32)) -> Option<CameraConnection> {
        let lens = match camera.projection {
            Projection::Pinhole => None,
            Projection::ThinLens { aperture_radius, focus_distance } => Some((aperture_radius, focus_distance)),
            _ => return None,
        };
        Some(CameraConnection {
            camera_from_world: camera.world_from_camera.inverse(),
            world_from_camera: camera.world_from_camera,
            eye: camera.world_from_camera.transform_point3(Vec3::ZERO),
            tan_half: camera.tan_half,
            near: camera.near_clip,
            far: camera.far_clip,
            normalization: 1.0 / (4.0 * camera.tan_half.x * camera.tan_half.y),
            full_size: Vec2::new(full_size.0 as f32, full_size.1 as f32),
            lens,
        })
    }

    /// Connects the world point `p` to the camera, with `u` sampling the
    /// aperture of a thin lens; None outside the view or the clip range.
    #[inline]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn connect(&self, p: Vec3, u: Vec2) -> Option<CameraPoint> {
        let local = self.camera_from_world.transform_point3(p);
        if !(local.z >= self.near && local.z <= self.far) {
            return None;
        }
        let a = match self.lens {
            Some((radius, _)) => (warp::sample_concentric_disk(u) * radius).extend(0.0),
            None => Vec3::ZERO,
        };
        let to = local - a;
        let dist2 = to.length_squared();
        let d = to / dist2.sqrt();
        if !(d.z > 0.0) {
            return None;
        }
        // The film position of the direction: through the pinhole, or
        // through the point of the focal plane the lens sends it to.
        let f = match self.lens {
            Some((_, focus)) => (a + d * (focus / d.z)) / focus,
            None => d / d.z,
        };
        let s = Vec2::new(0.5 * (1.0 - f.x / self.tan_half.x), 0.5 * (1.0 - f.y / self.tan_half.y));
        if !(s.x >= 0.0 && s.x <= 1.0 && s.y >= 0.0 && s.y <= 1.0) {
            return None;
        }
        let importance = self.normalization / (d.z * d.z * d.z);
        let at = if self.lens.is_some() { self.world_from_camera.transform_point3(a) } else { self.eye };
        Some(CameraPoint { pos: s * self.full_size, weight: importance / dist2, at })
    }
}

impl ParticleTracer {
    /// Traces the particle of one pixel sample, appending its splats to `out`.
    #[allow(clippy::too_many_arguments)]
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn trace(
        &self,
        scene: &Scene,
        cam: &CameraConnection,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &mut Scratch,
        out: &mut Vec<Splat>,
    ) {
        let n_lights = scene.lights.len();
        if n_lights == 0 || self.term.max_depth == 0 {
            return;
        }
        let pick = |u: f32| ((u * n_lights as f32) as usize).min(n_lights - 1);
        // Emitters seen directly: a point on one, connected to the camera.
        let (u_sel, u_pos) = (rng.next_1d(), rng.next_2d());
        let u_lens = rng.next_2d();
        if !self.hide_emitters {
            match &scene.lights[pick(u_sel)] {
                Light::Area(a) => {
                    let shape = &scene.shapes[a.shape as usize];
                    let s = shape.sample_point(u_pos);
                    let (p, mut n, pdf) = (s.p, s.n, s.pdf);
                    if let Some(c) = cam.connect(p, u_lens) {
                        let to_cam = c.at - p;
                        let mut cos = n.dot(to_cam.normalize());
                        if a.two_sided && cos < 0.0 {
                            (cos, n) = (-cos, -n);
                        }
                        if cos > 0.0 && pdf > 0.0 && self.visible(scene, p, n, c.at, stats) {
                            let value = a.radiance_at(shape, &s) * (n_lights as f32 * c.weight * cos / pdf);
                            out.push(Splat { pos: c.pos, value });
                        }
                    }
                }
                // Emitters at infinity: a direction sampled from the camera,
                // its point at twice the scene's radius (as Mitsuba's).
                l if l.is_environment() => {
                    if let Some(ls) = l.sample_li(cam.eye, u_pos, &scene.shapes) {
                        let b = scene.bounds();
                        let r = b.bounding_radius().max((cam.eye - b.center()).length()).max(1e-4);
                        let far = 2.0 * r;
                        let p = cam.eye + ls.wi * far;
                        if let Some(c) = cam.connect(p, u_lens) {
                            stats.shadow_rays += 1;
                            let d = (p - c.at).normalize();
                            if ls.pdf > 0.0 && !scene.occluded_ray(&Ray::new(c.at, d, f32::INFINITY)) {
                                let value = ls.li * (n_lights as f32 * c.weight * (p - c.at).length_squared() / ls.pdf);
                                out.push(Splat { pos: c.pos, value });
                            }
                        }
                    }
                }
                // Delta emitters are never seen directly.
                _ => {}
            }
        }

        // One light path.
        let (u_sel, u_pos, u_dir) = (rng.next_1d(), rng.next_2d(), rng.next_2d());
        let Some((ray, mut beta)) = emit(scene, &scene.lights[pick(u_sel)], u_pos, u_dir) else { return };
        beta *= n_lights as f32;
        let mut eta = 1.0f32;
        let mut depth = 1u32;
        stats.rays += 1;
        let mut hit = scene.intersect(&ray);
        while let Some(mut si) = hit {
            if depth >= self.term.max_depth {
                break;
            }
            scratch.reset();
            let bsdf = scene.bsdf(&mut si, scratch);
            let wi = si.to_local(si.wo);
            // Connect this vertex to the camera.
            let u_lens = rng.next_2d();
            out.extend(connect_vertex(scene, cam, &si, &bsdf, beta, u_lens, stats));
            // Continue by sampling the BSDF from the light's side.
            let (u, u2) = (rng.next_1d(), rng.next_2d());
            let Some(bs) = bsdf.sample(wi, u, u2) else { break };
            let Some(d) = scatter_adjoint(&si, wi, &bs, &mut beta, &mut eta) else { break };
            depth += 1;
            if depth >= self.term.max_depth {
                break;
            }
            if depth > self.term.rr_depth && !light_roulette(&mut beta, eta, rng) {
                break;
            }
            stats.rays += 1;
            hit = scene.intersect(&scene.spawn_ray(&si, d));
        }
    }

    /// Whether the camera at `eye` sees the emitter point `p` (normal `n`).
    fn visible(&self, scene: &Scene, p: Vec3, n: Vec3, eye: Vec3, stats: &mut RayStats) -> bool {
        stats.shadow_rays += 1;
        let o = offset_origin(p, n, eye - p);
        let d = eye - o;
        let len = d.length();
        !scene.occluded_ray(&Ray::new(o, d / len, len * (1.0 - crate::math::SHADOW_EPSILON)))
    }
}

/// The splat of light-path vertex `si` (BSDF `bsdf`, throughput `beta`)
/// connected to the camera through the lens point `u_lens` draws: f
/// (towards the camera ← from the light) cos θ W_e / d², with the adjoint
/// shading-normal correction (Veach, p. 155); None where the camera does not
/// see the point, the connection is occluded or the value is zero.
pub(crate) fn connect_vertex(
    scene: &Scene,
    cam: &CameraConnection,
    si: &crate::geometry::SurfaceInteraction,
    bsdf: &crate::bsdf::Bsdf,
    beta: Spectrum,
    u_lens: Vec2,
    stats: &mut RayStats,
) -> Option<Splat> {
    let wi = si.to_local(si.wo);
    let wi_geo = si.n.dot(si.wo);
    let c = cam.connect(si.p, u_lens)?;
    let to_cam = c.at - si.p;
    let dist = to_cam.length();
    let d = to_cam / dist;
    let local = si.to_local(d);
    let d_geo = si.n.dot(d);
    if !(wi_geo * wi.z > 0.0 && d_geo * local.z > 0.0) {
        return None;
    }
    stats.shadow_rays += 1;
    if scene.occluded(si, d, dist) {
        return None;
    }
    let correction = ((wi.z * d_geo) / (local.z * wi_geo)).abs();
    let f = bsdf.eval(local, wi) * local.z.abs();
    let value = beta * f * (c.weight * correction);
    (value != Spectrum::ZERO).then_some(Splat { pos: c.pos, value })
}

/// A light path's bounce `bs` at `si` (reached along `si.wo`, `wi` in the
/// local frame) in importance transport: the direction it leaves along,
/// with `beta` and `eta` updated: refraction's 1/η² radiance scale undone
/// and the adjoint shading-normal correction |wi·n_s d·n_g / d·n_s wi·n_g|
/// applied (Veach 1997, p. 155). None where the path ends: a direction on
/// opposite sides of the shading and geometric normals, or a throughput
/// that is zero or not finite.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
pub(crate) fn scatter_adjoint(
    si: &crate::geometry::SurfaceInteraction,
    wi: Vec3,
    bs: &crate::bsdf::BsdfSample,
    beta: &mut Spectrum,
    eta: &mut f32,
) -> Option<Vec3> {
    let wi_geo = si.n.dot(si.wo);
    let d = si.to_world(bs.wi);
    let d_geo = si.n.dot(d);
    if !(wi_geo * wi.z > 0.0 && d_geo * bs.wi.z > 0.0) {
        return None;
    }
    let correction = ((wi.z * d_geo) / (bs.wi.z * wi_geo)).abs();
    *beta *= bs.weight * (bs.eta * bs.eta * correction);
    *eta *= bs.eta;
    if !(beta.max_element() > 0.0) || !beta.is_finite() {
        return None;
    }
    Some(d)
}

/// Russian roulette of a light path past `rr_depth`: it survives with
/// probability q = min(max(β) η², 0.95), η the product of its bounces'
/// relative indices, and its throughput is divided by q.
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
pub(crate) fn light_roulette(beta: &mut Spectrum, eta: f32, rng: &mut SampleStream) -> bool {
    let q = (beta.max_element() * eta * eta).min(0.95);
    if !(rng.next_1d() < q) {
        return false;
    }
    *beta /= q;
    true
}

/// A ray leaving `light` and its weight (emitted power over the density of
/// the ray, light selection excluded); None for a zero-weight ray.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
pub(crate) fn emit(scene: &Scene, light: &Light, u_pos: Vec2, u_dir: Vec2) -> Option<(Ray, Spectrum)> {
    match light {
        Light::Area(a) => {
            let shape = &scene.shapes[a.shape as usize];
            let s = shape.sample_point(u_pos);
            let (p, n, pdf) = (s.p, s.n, s.pdf);
            if !(pdf > 0.0) {
                return None;
            }
            // A two-sided emitter: either side with probability ½, u reused.
            let (n, u_dir, sides) = match (a.two_sided, u_dir.x < 0.5) {
                (false, _) => (n, u_dir, 1.0),
                (true, true) => (n, Vec2::new(2.0 * u_dir.x, u_dir.y), 2.0),
                (true, false) => (-n, Vec2::new(2.0 * u_dir.x - 1.0, u_dir.y), 2.0),
            };
            let local = warp::sample_cosine_hemisphere(u_dir);
            let frame = crate::math::Frame::from_normal(n);
            let d = frame.to_world(local);
            Some((Ray::new(offset_origin(p, n, d), d, f32::INFINITY), a.radiance_at(shape, &s) * (sides * PI / pdf)))
        }
        Light::Point(l) => {
            let d = warp::sample_uniform_sphere(u_dir);
            Some((Ray::new(l.position, d, f32::INFINITY), l.intensity * (4.0 * PI)))
        }
        Light::Spot(s) => {
            let local = warp::sample_uniform_cone(u_dir, s.cos_cutoff);
            let pdf = warp::uniform_cone_pdf(s.cos_cutoff);
            let world_from_light = s.light_from_world.inverse();
            let d = world_from_light.transform_vector3(local).normalize();
            // The intensity towards d, as the spot's own sample_li evaluates it.
            let ls = s.sample_li(s.position + d)?;
            let intensity = ls.li; // at distance 1
            Some((Ray::new(s.position, d, f32::INFINITY), intensity / pdf))
        }
        // Emitters at infinity (constant, envmap, directional): a direction
        // towards the scene, from a point of the disk of the scene's bounding
        // sphere facing it (Mitsuba's `sample_ray` of envmap and directional).
        l => {
            let b = scene.bounds();
            if b.is_empty() {
                return None;
            }
            let (c, r) = (b.center(), b.bounding_radius().max(1e-4) * (1.0 + 1e-4));
            let ls = l.sample_li(c, u_dir, &scene.shapes)?;
            if !(ls.pdf > 0.0) {
                return None;
            }
            let disk = warp::sample_concentric_disk(u_pos);
            let perp = crate::math::Frame::from_normal(ls.wi).to_world(Vec3::new(disk.x, disk.y, 0.0));
            let o = c + (perp + ls.wi) * r;
            Some((Ray::new(o, -ls.wi, f32::INFINITY), ls.li * (PI * r * r / ls.pdf)))
        }
    }
}
