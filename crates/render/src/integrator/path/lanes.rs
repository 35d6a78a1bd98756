//! The `path` integrator's vertex in lanes for the commonest vertex of
//! interior scenes: a hit on a flat-shaded mesh with a plain `diffuse`
//! material, lit by an area light on a mesh ([`Scene::lane_diffuse`],
//! [`Scene::lane_area_light`]). A stream gathers such vertices of many paths
//! and runs them [`Float::WIDTH`] at a time; every other vertex runs
//! [`PathIntegrator::vertex`].
//!
//! **Bitwise [`PathIntegrator::vertex`].** The random numbers are drawn per
//! path in the scalar order ([`PathIntegrator::lane_vertex`] draws the light
//! and BSDF numbers, [`PathIntegrator::lane_vertex_done`] Russian
//! roulette's). The table lookups stay scalar (the light's pick, the
//! triangle's pick by area). The arithmetic in between is the scalar
//! code's, operation for operation in glam's order ([`V3`]), both branches
//! computed and selected per lane: the hit's interaction
//! (`Shape::interaction_with` and `SurfaceInteraction::frame_from_dpdu`), the
//! light's point and solid-angle density (`Shape::sample_point`,
//! `area_to_solid_angle`, `AreaLight::sample_li`), the Lambertian value and
//! density with the power heuristic, the shadow ray (`Scene::shadow_ray`)
//! and the cosine-weighted sample (`warp::sample_cosine_hemisphere`) with
//! the next ray (`Scene::spawn_ray`).

use super::{PathIntegrator, PathState, Vertex};
use crate::accel::Hit;
use crate::geometry::{Ray, Shape};
use crate::light::LightSelection;
use crate::math::{Spectrum, INV_PI, PI, RAY_EPSILON, SHADOW_EPSILON};
use crate::sampling::SampleStream;
use crate::scene::Scene;
use crate::simd::{gather, sin_cos, Float, Mask, V3};
use glam::{Vec2, Vec3};

/// One path's vertex as the lane kernel needs it, prepared by
/// [`PathIntegrator::lane_vertex`].
#[derive(Debug, Clone, Copy)]
pub struct LaneVertex {
    /// The direction of the ray that hit.
    d: Vec3,
    /// The hit triangle's corners and the hit's barycentrics (b1, b2).
    tri: [Vec3; 3],
    b: Vec2,
    /// The reflectance there.
    reflectance: Spectrum,
    /// The path's throughput.
    beta: Spectrum,
    /// The picked light's picked triangle, the light's (area density,
    /// selection probability, radiance, two-sidedness).
    light_tri: [Vec3; 3],
    area_pdf: f32,
    pmf: f32,
    li: Spectrum,
    two_sided: bool,
    /// The light sample's numbers (the first rescaled by the triangle's pick).
    u_light: Vec2,
    /// The BSDF sample's 2D number.
    u_bsdf: Vec2,
}

/// What the lane kernel found at one vertex.
#[derive(Debug, Clone, Copy)]
pub struct LaneOutcome {
    /// The light sample's contribution if unblocked, and its shadow ray.
    shadow: Option<(Spectrum, Ray)>,
    /// The BSDF sample: the next ray, the vertex's point and normal, and
    /// the sample's density; `None` when sampling failed (the path ends).
    next: Option<(Ray, Vec3, Vec3, f32)>,
}

impl LaneOutcome {
    const NONE: LaneOutcome = LaneOutcome { shadow: None, next: None };
}

/// `x.is_finite()` per lane (false for NaN).
#[inline(always)]
fn finite<F: Float>(x: F) -> F::Mask {
    x.abs().cmp_lt(F::splat(f32::INFINITY))
}

/// `offset_origin` in lanes.
#[inline(always)]
fn offset_origin<F: Float>(p: V3<F>, n: V3<F>, d: V3<F>) -> V3<F> {
    let mag = (F::splat(1.0) + p.abs().max_element()) * F::splat(RAY_EPSILON);
    let off = n * mag;
    V3::select(d.dot(n).cmp_lt(F::splat(0.0)), p - off, p + off)
}

/// `power_heuristic` in lanes.
#[inline(always)]
fn power_heuristic<F: Float>(pdf_a: F, pdf_b: F) -> F {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    let sum = a + b;
    let inf = F::select(a.cmp_eq(F::splat(f32::INFINITY)), F::splat(1.0), F::splat(0.0));
    F::select(sum.cmp_gt(F::splat(0.0)) & finite(a), a / sum, inf)
}

/// `Frame::from_normal` in lanes: (s, t).
#[inline(always)]
fn frame_from_normal<F: Float>(n: V3<F>) -> (V3<F>, V3<F>) {
    let one = F::splat(1.0);
    let sign = one.copysign(n.z);
    let a = F::splat(-1.0) / (sign + n.z);
    let b = n.x * n.y * a;
    let s = V3::new(one + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let t = V3::new(b, sign + n.y * n.y * a, -n.y);
    (s, t)
}

impl PathIntegrator {
    /// The vertex of `st` at `hit` (the closest hit of `st.ray`) prepared
    /// for [`Self::lane_vertices`] when it qualifies: a non-instanced hit on
    /// a [`Scene::lane_diffuse`] shape, before the last segment, with a light
    /// picked (uniformly or by power) that is a [`Scene::lane_area_light`].
    /// Its light and BSDF random numbers are drawn here, as `vertex` draws
    /// them. `None`, with `rng` as it was, otherwise: run [`Self::vertex`].
    pub fn lane_vertex(&self, scene: &Scene, st: &PathState, hit: &Hit, rng: &mut SampleStream) -> Option<LaneVertex> {
        if hit.instance != Hit::NOT_INSTANCED || st.depth + 1 >= self.term.max_depth {
            return None;
        }
        let reflectance = scene.lane_diffuse(hit.shape)?;
        // The light BVH's choice depends on the point, found in lanes.
        if scene.light_sampler().kind() == LightSelection::Bvh {
            return None;
        }
        let (Shape::Mesh(m) | Shape::CulledMesh(m)) = &scene.shapes[hit.shape as usize] else { return None };
        let saved = rng.clone();
        let (u_sel, u_light) = (rng.next_1d(), rng.next_2d());
        // Uniform and power selection ignore the receiver.
        let light = scene.select_light(Vec3::ZERO, Vec3::ZERO, u_sel).and_then(|(i, pmf)| {
            let (mesh, li, two_sided) = scene.lane_area_light(i)?;
            let (t, ux) = mesh.pick_triangle(u_light.x)?;
            Some((mesh.vertices(t), mesh.area_pdf(), pmf, li, two_sided, ux))
        });
        let Some((light_tri, area_pdf, pmf, li, two_sided, ux)) = light else {
            *rng = saved;
            return None;
        };
        // `vertex` draws the BSDF's 1D number too; a diffuse sample ignores it.
        let _ = rng.next_1d();
        let u_bsdf = rng.next_2d();
        Some(LaneVertex {
            d: st.ray.d,
            tri: m.vertices(hit.index as usize),
            b: hit.uv,
            reflectance,
            beta: st.beta,
            light_tri,
            area_pdf,
            pmf,
            li,
            two_sided,
            u_light: Vec2::new(ux, u_light.y),
            u_bsdf,
        })
    }

    /// Runs up to `F::WIDTH` prepared vertices at once; `out[k]` is the
    /// outcome of `v[k]`.
    pub fn lane_vertices<F: Float>(&self, v: &[LaneVertex], out: &mut [LaneOutcome]) {
        let n_in = v.len();
        debug_assert!(n_in <= F::WIDTH && out.len() >= n_in);
        if n_in == 0 {
            return;
        }
        // Short groups repeat their last vertex.
        let at = |l: usize| &v[l.min(n_in - 1)];
        let g = |f: fn(&LaneVertex) -> f32| gather::<F>(|l| f(at(l)));
        let gv = |f: fn(&LaneVertex) -> Vec3| V3::<F>::gather(|l| f(at(l)));
        let (zero, one) = (F::splat(0.0), F::splat(1.0));

        // The hit (Shape::interaction_with for a face-normal mesh without uv).
        let wo = -gv(|v| v.d).normalize();
        let (p0, p1, p2) = (gv(|v| v.tri[0]), gv(|v| v.tri[1]), gv(|v| v.tri[2]));
        let (b1, b2) = (g(|v| v.b.x), g(|v| v.b.y));
        let b0 = one - b1 - b2;
        let p = p0 * b0 + p1 * b1 + p2 * b2;
        let (dp0, dp1) = (p1 - p0, p2 - p0);
        let n = dp0.cross(dp1).normalize();
        // Its shading frame (frame_from_dpdu with dpdu = dp0).
        let s = dp0 - n * n.dot(dp0);
        let len2 = s.dot(s);
        let s = s / len2.sqrt();
        let (fs, ft) = frame_from_normal(n);
        let dpdu_ok = len2.cmp_gt(zero) & finite(len2);
        let (fs, ft) = (V3::select(dpdu_ok, s, fs), V3::select(dpdu_ok, n.cross(s), ft));
        let to_local = |w: V3<F>| V3::new(w.dot(fs), w.dot(ft), w.dot(n));
        let wo = to_local(wo);

        // The light sample (Shape::sample_point on the picked triangle,
        // area_to_solid_angle, AreaLight::sample_li), its selection included.
        let (q0, q1, q2) = (gv(|v| v.light_tri[0]), gv(|v| v.light_tri[1]), gv(|v| v.light_tri[2]));
        let su = g(|v| v.u_light.x).sqrt();
        let (lb1, lb2) = (one - su, g(|v| v.u_light.y) * su);
        let lp = q0 * (one - lb1 - lb2) + q1 * lb1 + q2 * lb2;
        let ln = (q1 - q0).cross(q2 - q0).normalize();
        let d = lp - p;
        let dist2 = d.dot(d);
        let cos = (ln.dot(d) / dist2.sqrt()).abs();
        let pdf = g(|v| v.area_pdf) * dist2 / cos;
        let dist = d.length();
        let wi = d / dist;
        let n_wi = ln.dot(wi);
        let two_sided = g(|v| if v.two_sided { 1.0 } else { 0.0 }).cmp_eq(one);
        let facing = !(n_wi.cmp_ge(zero) & !(two_sided & n_wi.cmp_gt(zero)));
        let sampled =
            dist2.cmp_ne(zero) & cos.cmp_ne(zero) & dist.cmp_ne(zero) & pdf.cmp_gt(zero) & finite(pdf) & facing;
        let light_pdf = pdf * g(|v| v.pmf);
        // The Lambertian value and density, MIS-weighted.
        let wi_l = to_local(wi);
        let front = wo.z.cmp_gt(zero) & wi_l.z.cmp_gt(zero);
        let refl = gv(|v| v.reflectance);
        let f = V3::select(front, refl * F::splat(INV_PI), V3::splat(Vec3::ZERO)) * wi_l.z.abs();
        let contributes = sampled & f.ne_zero();
        let w = if self.mis {
            let bsdf_pdf = F::select(front, wi_l.z.max(zero) * F::splat(INV_PI), zero);
            power_heuristic(light_pdf, bsdf_pdf)
        } else {
            one
        };
        let pending = gv(|v| v.beta).mul_elem(f).mul_elem(gv(|v| v.li)) * (w / light_pdf);
        // Its shadow ray (Scene::shadow_ray, a finite distance).
        let o = offset_origin(p, n, wi);
        let to_light = p + wi * dist - o;
        let len = to_light.length();
        let shadow_d = to_light / len;
        let shadow_t = len * F::splat(1.0 - SHADOW_EPSILON);

        // The BSDF sample (Diffuse::sample: sample_cosine_hemisphere).
        let (ox, oy) = (F::splat(2.0) * g(|v| v.u_bsdf.x) - one, F::splat(2.0) * g(|v| v.u_bsdf.y) - one);
        let x_major = ox.abs().cmp_gt(oy.abs());
        let r = F::select(x_major, ox, oy);
        let quarter = F::splat(PI / 4.0);
        let theta = F::select(x_major, quarter * (oy / ox), F::splat(PI / 2.0) - quarter * (ox / oy));
        let (sin, cos_t) = sin_cos(theta);
        let centre = ox.cmp_eq(zero) & oy.cmp_eq(zero);
        let (dx, dy) = (F::select(centre, zero, r * cos_t), F::select(centre, zero, r * sin));
        let dz = (one - (dx * dx + dy * dy)).max(zero).sqrt();
        let bsdf_pdf = dz.max(zero) * F::splat(INV_PI);
        let go = !wo.z.cmp_le(zero) & !bsdf_pdf.cmp_le(zero);
        let wi_next = fs * dx + ft * dy + n * dz;
        let o_next = offset_origin(p, n, wi_next);

        let lanes = |v: V3<F>| v.to_lanes();
        let arr = |x: F| x.to_array();
        let (pending, o, shadow_d, p, n, wi_next, o_next) =
            (lanes(pending), lanes(o), lanes(shadow_d), lanes(p), lanes(n), lanes(wi_next), lanes(o_next));
        let (shadow_t, bsdf_pdf) = (arr(shadow_t), arr(bsdf_pdf));
        let (contributes, go) = (contributes.bitmask(), go.bitmask());
        for (l, out) in out.iter_mut().enumerate().take(n_in) {
            *out = LaneOutcome::NONE;
            if contributes >> l & 1 != 0 {
                out.shadow = Some((pending[l], Ray::new(o[l], shadow_d[l], shadow_t.as_ref()[l])));
            }
            if go >> l & 1 != 0 {
                let ray = Ray::new(o_next[l], wi_next[l], f32::INFINITY);
                out.next = Some((ray, p[l], n[l], bsdf_pdf.as_ref()[l]));
            }
        }
    }

    /// The rest of a lane vertex, one path at a time: its outcome applied
    /// to `st` and Russian roulette, as at the end of [`Self::vertex`].
    pub fn lane_vertex_done(
        &self,
        st: &mut PathState,
        v: &LaneVertex,
        out: &LaneOutcome,
        rng: &mut SampleStream,
    ) -> Vertex {
        let shadow = out.shadow.map(|(c, ray)| {
            st.pending = c;
            ray
        });
        let Some((ray, p, n, pdf)) = out.next else { return Vertex { shadow, go_on: false } };
        // The sample's weight is the reflectance, its η 1 (η unchanged).
        st.beta *= v.reflectance;
        st.prev_p = p;
        st.prev_n = n;
        st.prev_bsdf_pdf = pdf;
        st.prev_delta = false;
        st.ray = ray;
        st.depth += 1;
        Vertex { shadow, go_on: self.roulette(st, rng) }
    }
}

/// Where `Default` is needed for buffers of outcomes.
impl Default for LaneOutcome {
    fn default() -> Self {
        LaneOutcome::NONE
    }
}
