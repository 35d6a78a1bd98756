//! The `path` integrator's vertex in lanes for the commonest vertex: a hit
//! with a plain `diffuse` material on a flat-shaded mesh, a sphere or a disk
//! ([`Scene::lane_diffuse`]), lit by an area light on a mesh
//! ([`Scene::lane_area_light`]) or by the scene's one environment map. A
//! stream gathers such vertices of many paths, bins them by [`LaneKind`]
//! (shape and light) and runs each bin [`Float::WIDTH`] at a time; every
//! other vertex runs [`PathIntegrator::vertex`].
//!
//! **Bitwise [`PathIntegrator::vertex`].** The random numbers are drawn per
//! path in the scalar order ([`PathIntegrator::lane_vertex`] draws the light
//! and BSDF numbers, [`PathIntegrator::lane_vertex_done`] Russian
//! roulette's). The table lookups stay scalar (the light's pick, the
//! triangle's pick by area). The arithmetic in between is the scalar
//! code's, operation for operation in glam's order ([`V3`]), both branches
//! computed and selected per lane: the hit's interaction
//! (`Shape::interaction_with` without the uv parameterisation and
//! `SurfaceInteraction::frame_from_dpdu`), the light's point and
//! solid-angle density (`Shape::sample_point`, `area_to_solid_angle`,
//! `AreaLight::sample_li`) or the environment's direction
//! ([`EnvMapLight::sample_direction`], the code of its `sample_li`), the Lambertian value and
//! density with the power heuristic, the shadow ray (`Scene::shadow_ray`)
//! and the cosine-weighted sample (`warp::sample_cosine_hemisphere`) with
//! the next ray (`Scene::spawn_ray`).

use super::{PathIntegrator, PathState, Vertex};
use crate::accel::Hit;
use crate::geometry::{Ray, Shape};
use crate::light::{EnvMapLight, LightSelection};
use crate::math::{Spectrum, INV_PI, PI, RAY_EPSILON, SHADOW_EPSILON};
use crate::sampling::SampleStream;
use crate::scene::Scene;
use crate::simd::{gather, sin_cos, Float, Mask, V3};
use glam::{Vec2, Vec3};

/// The shape and light of a lane vertex: vertices of one kind run together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LaneKind {
    /// 0: a flat-shaded mesh, 1: a sphere, 2: a disk.
    shape: u8,
    /// 0: an area light on a mesh, 1: the environment map.
    light: u8,
}

impl LaneKind {
    /// How many kinds there are.
    pub const COUNT: usize = 6;

    /// A number in 0..[`Self::COUNT`], for bins.
    #[inline]
    pub fn index(self) -> usize {
        (self.shape * 2 + self.light) as usize
    }
}

/// One path's vertex as the lane kernel needs it, prepared by
/// [`PathIntegrator::lane_vertex`].
#[derive(Debug, Clone, Copy)]
pub struct LaneVertex {
    kind: LaneKind,
    /// The direction of the ray that hit.
    d: Vec3,
    /// The hit: a mesh's triangle corners and barycentrics (b1, b2); a
    /// sphere's centre, rotation z axis and the ray's origin, its radius,
    /// distance t (in `b.x`) and flip; a disk's world-from-object columns
    /// x, y, z, w and normal, and the hit's local (x, y).
    geo: [Vec3; 5],
    b: Vec2,
    radius: f32,
    flip: bool,
    /// The reflectance there.
    reflectance: Spectrum,
    /// The path's throughput.
    beta: Spectrum,
    /// An area light: its picked triangle's corners, (area density,
    /// selection probability, radiance, two-sidedness), and the sample's
    /// numbers (the first rescaled by the triangle's pick). The environment:
    /// [`EnvMapLight::sample_cell`]'s (u, cos θ) in `u_light`, its density
    /// in `area_pdf`.
    light_tri: [Vec3; 3],
    area_pdf: f32,
    pmf: f32,
    li: Spectrum,
    two_sided: bool,
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

/// glam's `Mat4::transform_point3` (`w`: 1) or `transform_vector3` (`w`:
/// 0) of (x, y, 0) by the columns `c`, in glam's order: ((x·c0 then y·c1 +
/// that) then 0·c2 + that) then c3 + that.
#[inline(always)]
fn transform_xy0<F: Float>(c: [V3<F>; 4], x: F, y: F, point: bool) -> V3<F> {
    let r = c[1] * y + c[0] * x;
    let r = c[2] * F::splat(0.0) + r;
    if point {
        c[3] + r
    } else {
        r
    }
}

impl PathIntegrator {
    /// The vertex of `st` at `hit` (the closest hit of `st.ray`) prepared
    /// for [`Self::lane_vertices`] when it qualifies: a non-instanced hit on
    /// a [`Scene::lane_diffuse`] shape, before the last segment, with a light
    /// picked (uniformly or by power) that is a [`Scene::lane_area_light`] or
    /// `env`, the scene's one environment map ([`Scene::single_envmap`]).
    /// Its light and BSDF random numbers are drawn here, as `vertex` draws
    /// them. `None`, with `rng` as it was, otherwise: run [`Self::vertex`].
    pub fn lane_vertex(
        &self,
        scene: &Scene,
        env: Option<(usize, &EnvMapLight)>,
        st: &PathState,
        hit: &Hit,
        rng: &mut SampleStream,
    ) -> Option<LaneVertex> {
        if hit.instance != Hit::NOT_INSTANCED || st.depth + 1 >= self.term.max_depth {
            return None;
        }
        let reflectance = scene.lane_diffuse(hit.shape)?;
        // The light BVH's choice depends on the point, found in lanes.
        if scene.light_sampler().kind() == LightSelection::Bvh {
            return None;
        }
        let mut v = LaneVertex {
            kind: LaneKind { shape: 0, light: 0 },
            d: st.ray.d,
            geo: [Vec3::ZERO; 5],
            b: hit.uv,
            radius: 0.0,
            flip: false,
            reflectance,
            beta: st.beta,
            light_tri: [Vec3::ZERO; 3],
            area_pdf: 0.0,
            pmf: 0.0,
            li: Spectrum::ZERO,
            two_sided: false,
            u_light: Vec2::ZERO,
            u_bsdf: Vec2::ZERO,
        };
        match &scene.shapes[hit.shape as usize] {
            Shape::Mesh(m) | Shape::CulledMesh(m) => {
                let [p0, p1, p2] = m.vertices(hit.index as usize);
                v.geo[..3].copy_from_slice(&[p0, p1, p2]);
            }
            Shape::Sphere(s) => {
                v.kind.shape = 1;
                v.geo[..3].copy_from_slice(&[s.center, s.rot.z_axis, st.ray.o]);
                (v.radius, v.b.x, v.flip) = (s.radius, hit.t, s.flip);
            }
            Shape::Disk(d) => {
                v.kind.shape = 2;
                let m = &d.world_from_object;
                v.geo = [m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate(), m.w_axis.truncate(), d.n];
            }
            _ => return None,
        }
        let saved = rng.clone();
        let (u_sel, u_light) = (rng.next_1d(), rng.next_2d());
        // Uniform and power selection ignore the receiver.
        let picked = scene.select_light(Vec3::ZERO, Vec3::ZERO, u_sel).and_then(|(i, pmf)| {
            v.pmf = pmf;
            if let Some((_, e)) = env.filter(|&(e_index, _)| e_index == i) {
                let (x, cos_t, pdf_row) = e.sample_cell(u_light)?;
                v.kind.light = 1;
                (v.u_light, v.area_pdf) = (Vec2::new(x, cos_t), pdf_row);
                return Some(());
            }
            let (mesh, li, two_sided) = scene.lane_area_light(i)?;
            let (t, ux) = mesh.pick_triangle(u_light.x)?;
            v.light_tri = mesh.vertices(t);
            (v.area_pdf, v.li, v.two_sided, v.u_light) = (mesh.area_pdf(), li, two_sided, Vec2::new(ux, u_light.y));
            Some(())
        });
        if picked.is_none() {
            *rng = saved;
            return None;
        }
        // `vertex` draws the BSDF's 1D number too; a diffuse sample ignores it.
        let _ = rng.next_1d();
        v.u_bsdf = rng.next_2d();
        Some(v)
    }

    /// The kind of a prepared vertex: [`Self::lane_vertices`] takes vertices of one kind.
    #[inline]
    pub fn lane_kind(v: &LaneVertex) -> LaneKind {
        v.kind
    }

    /// Runs up to `F::WIDTH` prepared vertices of one [`LaneKind`] at once;
    /// `out[k]` is the outcome of `v[k]`. `env` as for [`Self::lane_vertex`].
    pub fn lane_vertices<F: Float>(&self, env: Option<&EnvMapLight>, v: &[LaneVertex], out: &mut [LaneOutcome]) {
        let Some(first) = v.first() else { return };
        debug_assert!(v.len() <= F::WIDTH && out.len() >= v.len() && v.iter().all(|w| w.kind == first.kind));
        match (first.kind.shape, first.kind.light) {
            (0, 0) => self.kernel::<F, 0, 0>(None, v, out),
            (1, 0) => self.kernel::<F, 1, 0>(None, v, out),
            (2, 0) => self.kernel::<F, 2, 0>(None, v, out),
            (0, _) => self.kernel::<F, 0, 1>(env, v, out),
            (1, _) => self.kernel::<F, 1, 1>(env, v, out),
            _ => self.kernel::<F, 2, 1>(env, v, out),
        }
    }

    /// [`Self::lane_vertices`] for shape kind `S` and light kind `L`.
    #[inline(always)]
    fn kernel<F: Float, const S: u8, const L: u8>(
        &self,
        env: Option<&EnvMapLight>,
        v: &[LaneVertex],
        out: &mut [LaneOutcome],
    ) {
        let n_in = v.len();
        // Short groups repeat their last vertex.
        let at = |l: usize| &v[l.min(n_in - 1)];
        let g = |f: fn(&LaneVertex) -> f32| gather::<F>(|l| f(at(l)));
        let gv = |f: fn(&LaneVertex) -> Vec3| V3::<F>::gather(|l| f(at(l)));
        let (zero, one) = (F::splat(0.0), F::splat(1.0));

        // The hit: point, normal and dp/du as Shape::interaction_with finds
        // them without the uv parameterisation.
        let wo = -gv(|v| v.d).normalize();
        let (p, n, dpdu) = match S {
            0 => {
                let (p0, p1, p2) = (gv(|v| v.geo[0]), gv(|v| v.geo[1]), gv(|v| v.geo[2]));
                let (b1, b2) = (g(|v| v.b.x), g(|v| v.b.y));
                let b0 = one - b1 - b2;
                let p = p0 * b0 + p1 * b1 + p2 * b2;
                let (dp0, dp1) = (p1 - p0, p2 - p0);
                (p, dp0.cross(dp1).normalize(), dp0)
            }
            1 => {
                // Sphere::interaction: the point re-projected onto the surface.
                let (c, z_axis, o) = (gv(|v| v.geo[0]), gv(|v| v.geo[1]), gv(|v| v.geo[2]));
                let at_t = o + gv(|v| v.d) * g(|v| v.b.x);
                let n = (at_t - c).normalize();
                let p = c + n * g(|v| v.radius);
                let dpdu = z_axis.cross(n);
                let flip = g(|v| if v.flip { 1.0 } else { 0.0 }).cmp_eq(one);
                (p, V3::select(flip, -n, n), dpdu)
            }
            _ => {
                // Disk::interaction: the local (x, y) placed.
                let c = [gv(|v| v.geo[0]), gv(|v| v.geo[1]), gv(|v| v.geo[2]), gv(|v| v.geo[3])];
                let (x, y) = (g(|v| v.b.x), g(|v| v.b.y));
                (transform_xy0(c, x, y, true), gv(|v| v.geo[4]), transform_xy0(c, x, y, false))
            }
        };
        // The shading frame (frame_from_dpdu, the shading normal being n).
        let s = dpdu - n * n.dot(dpdu);
        let len2 = s.dot(s);
        let s = s / len2.sqrt();
        let (fs, ft) = frame_from_normal(n);
        let dpdu_ok = len2.cmp_gt(zero) & finite(len2);
        let (fs, ft) = (V3::select(dpdu_ok, s, fs), V3::select(dpdu_ok, n.cross(s), ft));
        let to_local = |w: V3<F>| V3::new(w.dot(fs), w.dot(ft), w.dot(n));
        let wo = to_local(wo);

        // The light sample, its selection included: (direction, distance,
        // density, radiance, whether there is one).
        let (wi, dist, light_pdf, li, sampled) = if L == 0 {
            // Shape::sample_point on the picked triangle, area_to_solid_angle, AreaLight::sample_li.
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
            (wi, dist, pdf * g(|v| v.pmf), gv(|v| v.li), sampled)
        } else {
            let env = env.expect("an environment vertex without the environment");
            let (wi, pdf) = env.sample_direction(g(|v| v.u_light.x), g(|v| v.u_light.y), g(|v| v.area_pdf));
            let li = env.eval_lanes(wi.x, wi.y, wi.z);
            (wi, F::splat(f32::INFINITY), pdf * g(|v| v.pmf), V3::gather(|l| li[l]), F::Mask::splat(true))
        };
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
        let pending = gv(|v| v.beta).mul_elem(f).mul_elem(li) * (w / light_pdf);
        // Its shadow ray (Scene::shadow_ray).
        let o = offset_origin(p, n, wi);
        let (shadow_d, shadow_t) = if L == 0 {
            let to_light = p + wi * dist - o;
            let len = to_light.length();
            (to_light / len, len * F::splat(1.0 - SHADOW_EPSILON))
        } else {
            (wi, dist)
        };

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

        let (pending, o, shadow_d, p, n, wi_next, o_next) = (
            pending.to_lanes(),
            o.to_lanes(),
            shadow_d.to_lanes(),
            p.to_lanes(),
            n.to_lanes(),
            wi_next.to_lanes(),
            o_next.to_lanes(),
        );
        let (shadow_t, bsdf_pdf) = (shadow_t.to_array(), bsdf_pdf.to_array());
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
