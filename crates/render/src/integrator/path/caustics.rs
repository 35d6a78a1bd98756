//! Caustics carried by light paths (`path`'s `caustics`).
//!
//! A camera path finds a caustic (the light's image through glass or in a
//! mirror, cast on a diffuse surface) only when its BSDF sample at that
//! surface happens to go through the specular chain to the light: with a
//! small light, rarely, and then with a large weight, so the caustic is
//! fireflies, and so is all the light it sends on (the ceiling lit by a
//! caustic on the floor). A path traced from the light finds the caustic
//! every time its first bounces hit the specular object, and is connected
//! to the camera at each later vertex (light tracing, Veach 1997 sec.
//! 10.2; the `t = 1` strategy of bidirectional path tracing).
//!
//! The two estimators split path space rather than weighing each other:
//! a path x₀ (camera) x₁ … x_k (on an emitter) is **the light paths'** when
//! k ≥ 3, x₁'s direction was drawn from a non-delta lobe, x_{k-1}'s from a
//! delta lobe, every delta lobe drawn at x₂ … x_{k-1} is of a shape that
//! carries caustics (not a faint specular coat over a diffuse base:
//! `Material::carries_caustics`), at most `caustic_bounces` of x₂ …
//! x_{k-1} drew non-delta directions, and x_k is on an area light, or on a
//! light at infinity in a direction where it is concentrated (a sun, not a
//! sky: `Light::caustics_by_light_paths`); every other path is the camera
//! paths'. The camera path drops emission it finds after a delta bounce
//! with that history ([`PathState::bounced`] keeps it), and of an
//! environment only the concentrated lights' part. The light path leaves
//! a light at infinity only in directions where it is concentrated (else
//! it stops), starts with a delta bounce on a carrier (else it stops), goes on
//! through delta bounces on carriers and up to `caustic_bounces`
//! non-delta ones, and connects to the camera at every vertex after the
//! first, through the BSDF's non-delta part (a delta lobe evaluates to 0
//! towards the camera). Each part is unbiased, and together they count
//! every path once: the image's expectation is the camera paths' alone.
//! Delta emitters are left out (a camera path can never reach them, so
//! neither may the light paths).
//!
//! One light path per full-film pixel and sample, its random numbers from a
//! stream of its own ([`RenderJob`]'s `CAUSTIC_STREAM` pixels), as the
//! particle tracer's; its splats land where the connection does and go into
//! the film's Σ w·L with the filter's weights, like a camera sample there,
//! without adding to Σ w (see `render::particles`).
//!
//! [`PathState::bounced`]: super::PathState
//! [`RenderJob`]: crate::render::RenderJob

use super::PathIntegrator;
use crate::accel::Primitive;
use crate::geometry::ray::offset_origin;
use crate::geometry::Ray;
use crate::integrator::ptracer::{connect_vertex, light_roulette, scatter_adjoint, CameraConnection, Splat};
use crate::integrator::RayStats;
use crate::light::Light;
use crate::material::Scratch;
use crate::math::{Frame, Spectrum, PI};
use crate::sampling::{warp, SampleStream};
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// The most targets light paths aim at; a scene with more aims at none
/// (every direction is drawn as the particle tracer draws it).
const MAX_TARGETS: usize = 64;

/// Where light paths for the caustics go: the bounding spheres of the
/// placed shapes (and instances) whose delta lobes light paths carry
/// ([`Material::carries_caustics`]). A light path whose first segment misses
/// all of them hits no such surface first and connects to nothing, so the
/// paths are drawn towards them only, with the density of that draw (an
/// estimator restricted to where its integrand may be non-zero stays
/// unbiased).
///
/// [`Material::carries_caustics`]: crate::material::Material::carries_caustics
#[derive(Debug, Clone)]
pub struct CausticTargets {
    /// Centre and radius of each sphere; `None`: too many, aim at nothing.
    spheres: Option<Vec<(Vec3, f32)>>,
}

impl CausticTargets {
    /// The targets of `scene`'s shapes.
    pub fn new(scene: &Scene) -> CausticTargets {
        let delta = |shape: u32| scene.carries_caustics(shape);
        let mut spheres = Vec::new();
        for p in &scene.placed {
            let bounds = match *p {
                Primitive::Shape(id) | Primitive::Part(id, _) => {
                    if !delta(id) {
                        continue;
                    }
                    let shape = &scene.shapes[id as usize];
                    let mut b = crate::geometry::Aabb::EMPTY;
                    for i in 0..shape.prim_count() {
                        b = b.union(shape.prim_bounds(i));
                    }
                    b
                }
                Primitive::Instance(i) => {
                    let inst = &scene.instances[i as usize];
                    if !inst.group.members.iter().any(|&m| delta(m)) {
                        continue;
                    }
                    inst.bounds()
                }
            };
            if spheres.len() == MAX_TARGETS {
                return CausticTargets { spheres: None };
            }
            let r = bounds.bounding_radius() * (1.0 + 1e-4) + 1e-6;
            spheres.push((bounds.center(), r));
        }
        spheres.dedup();
        CausticTargets { spheres: Some(spheres) }
    }

    /// Whether no light path can find a caustic (no surface may be delta).
    pub fn is_empty(&self) -> bool {
        self.spheres.as_ref().is_some_and(|s| s.is_empty())
    }
}

impl PathIntegrator {
    /// Traces one light path for the caustics (see the module notes),
    /// appending its connections to the camera to `out`.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    #[allow(clippy::too_many_arguments)]
    pub fn trace_caustic(
        &self,
        scene: &Scene,
        cam: &CameraConnection,
        targets: &CausticTargets,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &mut Scratch,
        out: &mut Vec<Splat>,
    ) {
        let n_lights = scene.lights.len();
        // A caustic seen directly has at least 3 segments.
        if n_lights == 0 || self.term.max_depth < 3 {
            return;
        }
        // Traced with probability `caustic_paths`, weighted by its inverse.
        if rng.next_1d() >= self.caustic_paths {
            return;
        }
        let (u_sel, u_pos, u_dir) = (rng.next_1d(), rng.next_2d(), rng.next_2d());
        let light = &scene.lights[((u_sel * n_lights as f32) as usize).min(n_lights - 1)];
        if light.is_delta() {
            return;
        }
        let Some((ray, mut beta)) = (match &targets.spheres {
            Some(spheres) => emit_towards(scene, light, spheres, u_pos, u_dir),
            None => crate::integrator::ptracer::emit(scene, light, u_pos, u_dir),
        }) else {
            return;
        };
        // Where the light is not concentrated, its caustics are the camera paths'.
        if !light.caustics_by_light_paths(-ray.d) {
            return;
        }
        beta *= n_lights as f32 / self.caustic_paths;
        let mut eta = 1.0f32;
        // Segments so far, and non-delta bounces after the first delta chain.
        let mut depth = 1u32;
        let mut smooth = 0u32;
        stats.rays += 1;
        let mut hit = scene.intersect(&ray);
        while let Some(mut si) = hit {
            scratch.reset();
            let bsdf = scene.bsdf(&mut si, scratch);
            let wi = si.to_local(si.wo);
            // A vertex after the first delta bounce: connect it to the
            // camera (one more segment).
            if depth >= 2 && depth < self.term.max_depth && bsdf.has_smooth() {
                let u_lens = rng.next_2d();
                out.extend(connect_vertex(scene, cam, &si, &bsdf, beta, u_lens, stats));
            }
            if depth + 2 > self.term.max_depth {
                break;
            }
            let (u, u2) = (rng.next_1d(), rng.next_2d());
            let Some(bs) = bsdf.sample(wi, u, u2) else { break };
            // Delta bounces go on on carriers only (camera paths keep the
            // rest); non-delta ones after the first delta chain, up to
            // `caustic_bounces` of them.
            if bs.delta {
                if !scene.carries_caustics(si.shape) {
                    break;
                }
            } else {
                smooth += 1;
                if depth == 1 || smooth > self.caustic_bounces {
                    break;
                }
            }
            let Some(d) = scatter_adjoint(&si, wi, &bs, &mut beta, &mut eta) else { break };
            depth += 1;
            if depth > self.term.rr_depth && !light_roulette(&mut beta, eta, rng) {
                break;
            }
            stats.rays += 1;
            hit = scene.intersect(&scene.spawn_ray(&si, d));
        }
    }
}

/// A ray leaving the non-delta emitter `light` towards one of `spheres`
/// and its weight (emitted radiance over the ray's density, light
/// selection excluded), as `ptracer::emit` but drawn within the spheres.
///
/// From a point of an area light, a sphere is picked with probability
/// proportional to the solid angle Ω_i it subtends and a direction drawn
/// uniformly in its cone: the direction's density is (the number of cones
/// holding it) / ΣΩ. From an emitter at infinity, a direction is drawn as
/// `ptracer::emit` draws it, then a sphere with probability ∝ r_i² and a
/// point of its disk across the direction: the ray's density in the
/// plane across it is (the number of disks it crosses) / (π Σ r_i²).
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn emit_towards(
    scene: &Scene,
    light: &Light,
    spheres: &[(Vec3, f32)],
    u_pos: Vec2,
    u_dir: Vec2,
) -> Option<(Ray, Spectrum)> {
    if spheres.is_empty() {
        return None;
    }
    match light {
        Light::Area(a) => {
            let shape = &scene.shapes[a.shape as usize];
            let s = shape.sample_point(u_pos);
            let (p, n, pdf) = (s.p, s.n, s.pdf);
            if !(pdf > 0.0) {
                return None;
            }
            let (d, pdf_dir) = sample_cones(p, spheres, u_dir)?;
            let mut cos = n.dot(d);
            let n = if cos < 0.0 && a.two_sided {
                cos = -cos;
                -n
            } else {
                n
            };
            if !(cos > 0.0) {
                return None;
            }
            let le = a.radiance_at(shape, &s);
            Some((Ray::new(offset_origin(p, n, d), d, f32::INFINITY), le * (cos / (pdf * pdf_dir))))
        }
        l if l.is_environment() => {
            let b = scene.bounds();
            if b.is_empty() {
                return None;
            }
            let (c, r) = (b.center(), b.bounding_radius().max(1e-4) * (1.0 + 1e-4));
            let ls = l.sample_li(c, u_dir, &scene.shapes)?;
            if !(ls.pdf > 0.0) {
                return None;
            }
            let (q, pdf_area) = sample_disks(ls.wi, spheres, u_pos);
            // Start outside the scene's bounding sphere.
            let o = q + ls.wi * (r + (q - c).length());
            Some((Ray::new(o, -ls.wi, f32::INFINITY), ls.li / (ls.pdf * pdf_area)))
        }
        _ => None,
    }
}

/// A sphere's cone of directions from `p`: cos θ_max and its solid angle
/// (the whole sphere of directions from inside it).
fn cone(p: Vec3, (c, r): (Vec3, f32)) -> (f32, f32) {
    let d2 = (c - p).length_squared();
    let cos_max = if d2 <= r * r { -1.0 } else { (1.0 - r * r / d2).max(0.0).sqrt() };
    (cos_max, 2.0 * PI * (1.0 - cos_max))
}

/// A direction from `p` towards one of `spheres`: the sphere picked with
/// probability ∝ its cone's solid angle Ω_i, the direction uniform in its
/// cone; with its density [`cones_pdf`].
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn sample_cones(p: Vec3, spheres: &[(Vec3, f32)], u: Vec2) -> Option<(Vec3, f32)> {
    let total: f32 = spheres.iter().map(|&t| cone(p, t).1).sum();
    if !(total > 0.0) {
        return None;
    }
    let (i, ux) = pick_by_weight(spheres.iter().map(|&t| cone(p, t).1), total, u.x);
    let (c, _) = spheres[i];
    let (cos_max, _) = cone(p, spheres[i]);
    let local = warp::sample_uniform_cone(Vec2::new(ux, u.y), cos_max);
    let d = Frame::from_normal((c - p).normalize()).to_world(local).normalize();
    // At least its own cone's share, should rounding put d just outside it.
    Some((d, cones_pdf(p, spheres, d).max(1.0 / total)))
}

/// The density of [`sample_cones`]' direction `d` (solid angle): Σ over the
/// cones holding it of (Ω_i / ΣΩ) / Ω_i = (the number of cones holding it) / ΣΩ.
fn cones_pdf(p: Vec3, spheres: &[(Vec3, f32)], d: Vec3) -> f32 {
    let total: f32 = spheres.iter().map(|&t| cone(p, t).1).sum();
    let held = spheres
        .iter()
        .filter(|&&t| {
            let (cos_max, _) = cone(p, t);
            cos_max <= -1.0 || d.dot((t.0 - p).normalize()) >= cos_max
        })
        .count();
    held as f32 / total
}

/// A point of one of the disks across `w` through `spheres` (centre c_i,
/// radius r_i): the disk picked with probability ∝ r_i², the point uniform
/// on it; with its density [`disks_pdf`] in the plane across `w`.
fn sample_disks(w: Vec3, spheres: &[(Vec3, f32)], u: Vec2) -> (Vec3, f32) {
    let total: f32 = spheres.iter().map(|t| t.1 * t.1).sum();
    let (i, ux) = pick_by_weight(spheres.iter().map(|t| t.1 * t.1), total, u.x);
    let (c, r) = spheres[i];
    let disk = warp::sample_concentric_disk(Vec2::new(ux, u.y)) * r;
    let q = c + Frame::from_normal(w).to_world(Vec3::new(disk.x, disk.y, 0.0));
    // At least its own disk's share, should rounding put q just outside it.
    (q, disks_pdf(w, spheres, q).max(1.0 / (PI * total)))
}

/// The density of [`sample_disks`]' point `q` (area across `w`): the line
/// through q along w crosses some of the disks, each drawn with probability
/// r_i² / Σr² and then uniform over π r_i², so (the number crossed) / (π Σr²).
fn disks_pdf(w: Vec3, spheres: &[(Vec3, f32)], q: Vec3) -> f32 {
    let total: f32 = spheres.iter().map(|t| t.1 * t.1).sum();
    let crossed = spheres
        .iter()
        .filter(|(c, r)| {
            let v = q - *c;
            (v - w * v.dot(w)).length_squared() <= r * r
        })
        .count();
    crossed as f32 / (PI * total)
}

/// An index drawn with probability ∝ `weights` (summing to `total`) by
/// `u`, and `u` rescaled to [0, 1) within its interval.
fn pick_by_weight(weights: impl Iterator<Item = f32>, total: f32, u: f32) -> (usize, f32) {
    let t = u * total;
    let (mut acc, mut last) = (0.0, (0, 0.0, 0.0));
    for (i, w) in weights.enumerate() {
        if w > 0.0 {
            last = (i, acc, w);
            if t < acc + w {
                return (i, ((t - acc) / w).clamp(0.0, ONE_BELOW));
            }
        }
        acc += w;
    }
    (last.0, ((t - last.1) / last.2).clamp(0.0, ONE_BELOW))
}

/// The largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::chi2_test;

    /// The cones' directions follow their density (χ², the sphere of
    /// directions in cells): disjoint cones, overlapping ones (a direction
    /// in both counts twice), and a point inside one sphere (its cone is
    /// every direction) beside another.
    #[test]
    fn cone_directions_follow_their_density() {
        let p = Vec3::new(0.1, 0.9, -0.2);
        let cases: [&[(Vec3, f32)]; 3] = [
            &[(Vec3::new(-0.4, -0.6, 0.3), 0.37), (Vec3::new(0.5, -0.6, -0.4), 0.3)],
            &[(Vec3::new(0.0, -0.5, 0.0), 0.5), (Vec3::new(0.3, -0.4, 0.1), 0.45)],
            &[(Vec3::new(0.0, 0.8, 0.0), 0.5), (Vec3::new(0.4, -0.6, 0.3), 0.3)],
        ];
        for (k, spheres) in cases.iter().enumerate() {
            let pv = chi2_test(
                200_000,
                17 + k as u64,
                |_, u| sample_cones(p, spheres, u).map(|(d, _)| d),
                |d| cones_pdf(p, spheres, d) as f64,
            );
            assert!(pv > 1e-4, "case {k}: p-value {pv}");
            // The density a draw reports is the density of its direction.
            let (d, pdf) = sample_cones(p, spheres, Vec2::new(0.3, 0.7)).unwrap();
            assert_eq!(pdf, cones_pdf(p, spheres, d));
        }
    }

    /// The disks' points follow their density: E[1 / pdf] over the draws is
    /// the area of the disks' union, here two overlapping disks (a lens
    /// counted once) seen along z, within 4 standard errors.
    #[test]
    fn disk_points_follow_their_density() {
        let w = Vec3::new(0.0, 0.0, 1.0);
        let (r1, r2, dist) = (0.5f64, 0.3f64, 0.6f64);
        let spheres = [(Vec3::new(0.0, 0.0, 2.0), r1 as f32), (Vec3::new(dist as f32, 0.0, -1.0), r2 as f32)];
        // The union: both areas less the lens of their overlap.
        let lens = r1 * r1 * ((dist * dist + r1 * r1 - r2 * r2) / (2.0 * dist * r1)).acos()
            + r2 * r2 * ((dist * dist + r2 * r2 - r1 * r1) / (2.0 * dist * r2)).acos()
            - 0.5 * ((-dist + r1 + r2) * (dist + r1 - r2) * (dist - r1 + r2) * (dist + r1 + r2)).sqrt();
        let union = std::f64::consts::PI * (r1 * r1 + r2 * r2) - lens;
        let mut rng = crate::testing::TestRng::new(5);
        let n = 200_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (_, pdf) = sample_disks(w, &spheres, rng.next_2d());
            let x = 1.0 / pdf as f64;
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - union).abs() < 4.0 * se, "E[1/pdf] {mean} against the union's area {union} (se {se})");
    }
}
