//! The `path` integrator's vertex in lanes for the commonest vertices: a
//! hit on a flat-shaded mesh, a sphere or a disk with a plain `diffuse`,
//! `conductor` or `dielectric` material of constant parameters
//! ([`Scene::lane_material`]); a diffuse one lit by an area light on a mesh
//! ([`Scene::lane_area_light`]) or by the scene's one environment map. A
//! stream gathers such vertices of many paths, bins them by [`LaneKind`]
//! (shape, material and light) and runs each bin [`Float::WIDTH`] at a
//! time; every other vertex runs [`PathIntegrator::vertex`].
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
//! and the cosine-weighted sample (`warp::sample_cosine_hemisphere`); the
//! smooth conductor's and dielectric's Fresnel terms and mirror or
//! refracted directions (`fresnel_conductor`, `fresnel_dielectric`); the
//! next ray (`Scene::spawn_ray`).

use super::{PathIntegrator, PathState, Vertex};
use crate::accel::Hit;
use crate::geometry::SurfaceInteraction;
use crate::geometry::{Ray, Shape};
use crate::light::{EnvMapLight, LightSelection};
use crate::material::{LaneMaterial, Material};
use crate::math::{Spectrum, INV_PI, PI, RAY_EPSILON, SHADOW_EPSILON};
use crate::sampling::SampleStream;
use crate::scene::Scene;
use crate::simd::{gather, sin_cos, Float, Mask, V3};
use glam::{Vec2, Vec3};

/// The shape, material and light of a lane vertex: vertices of one kind
/// run together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LaneKind {
    /// 0: a flat-shaded mesh, 1: a sphere, 2: a disk, 3: a flat-shaded
    /// mesh whose frame follows its texture coordinates (a textured material).
    shape: u8,
    /// 0: diffuse, 1: GGX rough conductor (these two sample a light), 2:
    /// smooth conductor, 3: smooth dielectric.
    bsdf: u8,
    /// The light sampled: 0: an area light on a mesh, 1: the environment
    /// map, 2: an area light on a sphere (0 where none is).
    light: u8,
}

impl LaneKind {
    /// How many kinds there are.
    pub const COUNT: usize = 48;

    /// A number in 0..[`Self::COUNT`], for bins.
    #[inline]
    pub fn index(self) -> usize {
        ((self.shape * 4 + self.bsdf) * 3 + self.light) as usize
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
    /// A textured mesh's texture coordinates at the triangle's corners.
    uvs: [Vec2; 3],
    radius: f32,
    flip: bool,
    /// The material's constants: diffuse: the reflectance; conductors: η,
    /// k and the specular reflectance (and α in `param` when rough);
    /// dielectric: the specular reflectance and transmittance, and η in
    /// `param`.
    mat: [Spectrum; 3],
    param: f32,
    /// The path's throughput.
    beta: Spectrum,
    /// An area light: its picked triangle's corners (a sphere: its centre,
    /// then (radius, 1 / area, 1 if its normals are flipped)), (area density,
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
    /// The BSDF sample's numbers.
    u_bsdf1: f32,
    u_bsdf: Vec2,
}

impl LaneVertex {
    /// A vertex to fill ([`PathIntegrator::lane_vertex`]).
    pub const EMPTY: LaneVertex = LaneVertex {
        kind: LaneKind { shape: 0, bsdf: 0, light: 0 },
        d: Vec3::ZERO,
        geo: [Vec3::ZERO; 5],
        b: Vec2::ZERO,
        uvs: [Vec2::ZERO; 3],
        radius: 0.0,
        flip: false,
        mat: [Spectrum::ZERO; 3],
        param: 1.0,
        beta: Spectrum::ZERO,
        light_tri: [Vec3::ZERO; 3],
        area_pdf: 0.0,
        pmf: 0.0,
        li: Spectrum::ZERO,
        two_sided: false,
        u_light: Vec2::ZERO,
        u_bsdf1: 0.0,
        u_bsdf: Vec2::ZERO,
    };

    /// Its kind: [`PathIntegrator::lane_vertices`] takes vertices of one kind.
    #[inline]
    pub fn kind(&self) -> LaneKind {
        self.kind
    }
}

/// What the lane kernel found at one vertex.
#[derive(Debug, Clone, Copy)]
pub struct LaneOutcome {
    /// The light sample's contribution if unblocked, and its shadow ray.
    shadow: Option<(Spectrum, Ray)>,
    /// The BSDF sample: the next ray, the vertex's point and normal, the
    /// sample's density, weight and relative IOR, and whether it is
    /// specular; `None` when sampling failed (the path ends).
    next: Option<LaneSample>,
}

/// A BSDF sample of [`LaneOutcome`].
#[derive(Debug, Clone, Copy)]
struct LaneSample {
    ray: Ray,
    p: Vec3,
    n: Vec3,
    pdf: f32,
    weight: Spectrum,
    eta: f32,
    delta: bool,
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

/// Lane `l` set where `f(l)` holds.
#[inline(always)]
fn gather_mask<F: Float>(f: impl Fn(usize) -> bool) -> F::Mask {
    gather::<F>(|l| if f(l) { 1.0 } else { 0.0 }).cmp_eq(F::splat(1.0))
}

/// `fresnel_conductor_1` in lanes, for one channel.
#[inline(always)]
fn fresnel_conductor<F: Float>(cos_i: F, eta_r: F, eta_i: F) -> F {
    let (zero, half) = (F::splat(0.0), F::splat(0.5));
    let c2 = cos_i * cos_i;
    let s2 = F::splat(1.0) - c2;
    let s4 = s2 * s2;
    let temp1 = eta_r * eta_r - eta_i * eta_i - s2;
    let a2pb2 = (temp1 * temp1 + F::splat(4.0) * eta_i * eta_i * eta_r * eta_r).max(zero).sqrt();
    let a = (half * (a2pb2 + temp1)).max(zero).sqrt();
    let term1 = a2pb2 + c2;
    let term2 = F::splat(2.0) * cos_i * a;
    let r_s = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * c2 + s4;
    let term4 = term2 * s2;
    let r_p = r_s * (term3 - term4) / (term3 + term4);
    half * (r_s + r_p)
}

/// `fresnel_dielectric` in lanes: (R, cos θ_t signed, η_it, η_ti).
#[inline(always)]
fn fresnel_dielectric<F: Float>(cos_i: F, eta: F) -> (F, F, F, F) {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let outside = cos_i.cmp_ge(zero);
    let inv = one / eta;
    let (eta_it, eta_ti) = (F::select(outside, eta, inv), F::select(outside, inv, eta));
    let cos_t_sqr = (-(-cos_i).mul_add(cos_i, one)).mul_add(eta_ti * eta_ti, one);
    let ci = cos_i.abs();
    let ct = cos_t_sqr.max(zero).sqrt();
    let a_s = (eta_it * ct - ci) / (eta_it * ct + ci);
    let a_p = (eta_it * ci - ct) / (eta_it * ci + ct);
    let r = F::splat(0.5) * (a_s * a_s + a_p * a_p);
    let r = F::select(eta.cmp_eq(one), zero, F::select(ci.cmp_eq(zero), one, r));
    (r, F::select(outside, -ct, ct), eta_it, eta_ti)
}

/// The vertices of a lane group: lane l is `all[idx[l]]`; short groups
/// repeat their last vertex.
#[derive(Clone, Copy)]
struct Lanes<'a> {
    all: &'a [LaneVertex],
    idx: &'a [u16],
}

impl Lanes<'_> {
    #[inline(always)]
    fn at(&self, l: usize) -> &LaneVertex {
        &self.all[self.idx[l.min(self.idx.len() - 1)] as usize]
    }
}

/// `area_to_solid_angle` in lanes: the density and whether there is one.
#[inline(always)]
fn area_to_solid_angle<F: Float>(pdf_area: F, p_ref: V3<F>, p: V3<F>, n: V3<F>) -> (F, F::Mask) {
    let zero = F::splat(0.0);
    let d = p - p_ref;
    let dist2 = d.dot(d);
    let cos = (n.dot(d) / dist2.sqrt()).abs();
    (pdf_area * dist2 / cos, dist2.cmp_ne(zero) & cos.cmp_ne(zero))
}

/// `Shape::sample_direction` on a sphere in lanes: `Sphere::sample_cone`
/// from outside, uniform area sampling (`Sphere::sample_area`,
/// `area_to_solid_angle`) from inside. `c` is the centre, `r` (radius, 1 /
/// area, 1 where the normals are flipped). (point, normal, density, whether
/// there is one).
#[inline(always)]
fn sphere_sample<F: Float>(c: V3<F>, r: V3<F>, p_ref: V3<F>, u0: F, u1: F) -> (V3<F>, V3<F>, F, F::Mask) {
    let (zero, one, two) = (F::splat(0.0), F::splat(1.0), F::splat(2.0));
    let (radius, inv_area, flip) = (r.x, r.y, r.z.cmp_eq(one));
    let to_c = p_ref - c;
    let dc2 = to_c.dot(to_c);
    let r2 = radius * radius;
    let outside = dc2.cmp_gt(r2 * F::splat(1.0001));
    // The cone.
    let sin2_max = r2 / dc2;
    let sin_max = sin2_max.sqrt();
    let cos_max = (one - sin2_max).max(zero).sqrt();
    let small = sin2_max.cmp_lt(F::splat(0.000_685_23));
    let cos_t = (cos_max - one) * u0 + one;
    let sin2_t = one - cos_t * cos_t;
    // Small cones: Taylor expansion.
    let sin2_t_small = sin2_max * u0;
    let (sin2_t, cos_t) =
        (F::select(small, sin2_t_small, sin2_t), F::select(small, (one - sin2_t_small).sqrt(), cos_t));
    let one_minus_cos_max = F::select(small, sin2_max / two, one - cos_max);
    let cos_alpha = sin2_t / sin_max + cos_t * (one - sin2_t / sin2_max).max(zero).sqrt();
    let sin_alpha = (one - cos_alpha * cos_alpha).max(zero).sqrt();
    let (sin_phi, cos_phi) = sin_cos(u1 * two * F::splat(PI));
    let w = V3::new(sin_alpha * cos_phi, sin_alpha * sin_phi, cos_alpha);
    let nc = (c - p_ref).normalize();
    let (fs, ft) = frame_from_normal(nc);
    let nd = fs * -w.x + ft * -w.y + nc * -w.z;
    let cone_p = c + nd * radius;
    let cone_pdf = one / (F::splat(2.0 * PI) * one_minus_cos_max);
    // The area (sample_uniform_sphere).
    let z = one - two * u0;
    let rr = (one - z * z).max(zero).sqrt();
    let (s, co) = sin_cos(F::splat(2.0 * PI) * u1);
    let dir = V3::new(rr * co, rr * s, z);
    let area_p = c + dir * radius;
    let area_n = V3::select(flip, -dir, dir);
    let (area_pdf, area_ok) = area_to_solid_angle(inv_area, p_ref, area_p, area_n);
    let p = V3::select(outside, cone_p, area_p);
    let n = V3::select(outside, V3::select(flip, -nd, nd), area_n);
    (p, n, F::select(outside, cone_pdf, area_pdf), outside | area_ok)
}

/// `warp::sample_concentric_disk` in lanes.
#[inline(always)]
fn concentric_disk<F: Float>(u0: F, u1: F) -> (F, F) {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let (ox, oy) = (F::splat(2.0) * u0 - one, F::splat(2.0) * u1 - one);
    let x_major = ox.abs().cmp_gt(oy.abs());
    let r = F::select(x_major, ox, oy);
    let quarter = F::splat(PI / 4.0);
    let theta = F::select(x_major, quarter * (oy / ox), F::splat(PI / 2.0) - quarter * (ox / oy));
    let (sin, cos) = sin_cos(theta);
    let centre = ox.cmp_eq(zero) & oy.cmp_eq(zero);
    (F::select(centre, zero, r * cos), F::select(centre, zero, r * sin))
}

/// `f32::clamp(x, -1, 1)` in lanes (NaN stays NaN).
#[inline(always)]
fn clamp_unit<F: Float>(x: F) -> F {
    let one = F::splat(1.0);
    F::select(x.cmp_lt(-one), -one, F::select(x.cmp_gt(one), one, x))
}

/// An isotropic GGX `Microfacet` (α floored at 1e-4 as `alphas`) and the
/// rough conductor on it (`RoughConductor`), in lanes.
struct Ggx<F> {
    a: F,
}

impl<F: Float> Ggx<F> {
    #[inline(always)]
    fn new(alpha: F) -> Self {
        Ggx { a: alpha.max(F::splat(1e-4)) }
    }

    /// `Microfacet::eval`: D(m).
    #[inline(always)]
    fn d(&self, m: V3<F>) -> F {
        let a = self.a;
        let cos2 = m.z * m.z;
        let (x, y) = (m.x / a, m.y / a);
        let s = x * x + y * y + cos2;
        let r = F::splat(1.0) / (F::splat(PI) * a * a * (s * s));
        F::select((r * m.z).cmp_gt(F::splat(1e-20)), r, F::splat(0.0))
    }

    /// `Microfacet::smith_g1`.
    #[inline(always)]
    fn g1(&self, v: V3<F>, m: V3<F>) -> F {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let (ax, ay) = (self.a * v.x, self.a * v.y);
        let xy = ax * ax + ay * ay;
        let t = xy / (v.z * v.z);
        let g = F::splat(2.0) / (one + (one + t).sqrt());
        let g = F::select(xy.cmp_eq(zero), one, g);
        F::select((v.dot(m) * v.z).cmp_le(zero), zero, g)
    }

    /// `RoughConductor::eval` and `pdf`: (f, density).
    #[inline(always)]
    fn eval_pdf(&self, wo: V3<F>, wi: V3<F>, eta: V3<F>, k: V3<F>, spec: V3<F>) -> (V3<F>, F) {
        let zero = F::splat(0.0);
        let up = !wo.z.cmp_le(zero) & !wi.z.cmp_le(zero);
        let h = (wo + wi).normalize();
        let d = self.d(h);
        let (g1o, g1i) = (self.g1(wo, h), self.g1(wi, h));
        let cos = wo.dot(h);
        let fr = V3::new(
            fresnel_conductor(cos, eta.x, k.x),
            fresnel_conductor(cos, eta.y, k.y),
            fresnel_conductor(cos, eta.z, k.z),
        );
        let f = fr.mul_elem(spec) * (d * (g1o * g1i) / (F::splat(4.0) * wo.z * wi.z));
        let f = V3::select(up & !d.cmp_eq(zero), f, V3::splat(Vec3::ZERO));
        let pdf = d * g1o / (F::splat(4.0) * wo.z);
        let pdf_ok = up & !cos.cmp_le(zero) & !wi.dot(h).cmp_le(zero);
        (f, F::select(pdf_ok, pdf, zero))
    }

    /// `RoughConductor::sample` (visible normals, Heitz 2018): (direction,
    /// density, weight, whether there is one).
    #[inline(always)]
    fn sample(&self, wo: V3<F>, u0: F, u1: F, eta: V3<F>, k: V3<F>, spec: V3<F>) -> (V3<F>, F, V3<F>, F::Mask) {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let a = self.a;
        // Microfacet::stretch.
        let wp = V3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let sin_t = (one - wp.z * wp.z).max(zero).sqrt();
        let pole = sin_t.cmp_eq(zero);
        let sin_p = F::select(pole, zero, clamp_unit(wp.y / sin_t));
        let cos_p = F::select(pole, one, clamp_unit(wp.x / sin_t));
        let ci = wp.z;
        // sample_visible_11 (GGX).
        let (px, py) = concentric_disk(u0, u1);
        let s = F::splat(0.5) * (one + ci);
        let hh = (one - px * px).max(zero).sqrt();
        let y = hh + (py - hh) * s;
        let x = px;
        let z = (one - x * x - y * y).max(zero).sqrt();
        let si = (one - ci * ci).max(zero).sqrt();
        let norm = one / (si * y + ci * z);
        let (slope_x, slope_y) = ((ci * y - si * z) * norm, x * norm);
        // normal_from_slope.
        let sx = (cos_p * slope_x - sin_p * slope_y) * a;
        let sy = (sin_p * slope_x + cos_p * slope_y) * a;
        let m = V3::new(-sx, -sy, one).normalize();
        // Microfacet::pdf.
        let d = self.d(m);
        let g1o = self.g1(wo, m);
        let cos_om = wo.dot(m);
        let pdf_m = F::select(d.cmp_eq(zero), zero, d * g1o * cos_om.abs() / wo.z);
        // reflect_m: 2 (wo·m) m − wo.
        let wi = m * (F::splat(2.0) * cos_om) - wo;
        let g1 = self.g1(wi, m);
        let pdf = pdf_m / (F::splat(4.0) * wi.dot(m));
        let fr = V3::new(
            fresnel_conductor(cos_om, eta.x, k.x),
            fresnel_conductor(cos_om, eta.y, k.y),
            fresnel_conductor(cos_om, eta.z, k.z),
        );
        let weight = fr.mul_elem(spec) * g1;
        let go = !wo.z.cmp_le(zero) & !pdf_m.cmp_eq(zero) & !wi.z.cmp_le(zero) & !g1.cmp_eq(zero);
        (wi, pdf, weight, go)
    }
}

/// The hit of a lane vertex: point, geometric normal, shading frame (s, t;
/// its normal is the geometric one) and the outgoing direction in it.
struct LaneHit<F> {
    p: V3<F>,
    n: V3<F>,
    fs: V3<F>,
    ft: V3<F>,
    wo: V3<F>,
}

impl<F: Float> LaneHit<F> {
    /// A world direction in the shading frame (`Frame::to_local`).
    #[inline(always)]
    fn to_local(&self, w: V3<F>) -> V3<F> {
        V3::new(w.dot(self.fs), w.dot(self.ft), w.dot(self.n))
    }

    /// A shading-frame direction in the world (`Frame::to_world`).
    #[inline(always)]
    fn to_world(&self, w: V3<F>) -> V3<F> {
        self.fs * w.x + self.ft * w.y + self.n * w.z
    }
}

impl PathIntegrator {
    /// The vertex of `st` at `hit` (the closest hit of `st.ray`) prepared
    /// for [`Self::lane_vertices`] when it qualifies: a non-instanced hit on
    /// a [`Scene::lane_material`] shape, before the last segment; for a
    /// diffuse one, with a light picked (uniformly or by power) that is a
    /// [`Scene::lane_area_light`] or `env`, the scene's one environment map
    /// ([`Scene::single_envmap`]). Its light and BSDF random numbers are
    /// drawn here, as `vertex` draws them, and `v` is filled. False, with
    /// `rng` as it was, otherwise: run [`Self::vertex`].
    pub fn lane_vertex(
        &self,
        scene: &Scene,
        env: Option<(usize, &EnvMapLight)>,
        st: &PathState,
        hit: &Hit,
        rng: &mut SampleStream,
        v: &mut LaneVertex,
    ) -> bool {
        if hit.instance != Hit::NOT_INSTANCED || st.depth + 1 >= self.term.max_depth {
            return false;
        }
        let Some(material) = scene.lane_material(hit.shape) else { return false };
        let (bsdf, mat, param) = match material {
            LaneMaterial::Diffuse(r) => (0, [r, Spectrum::ZERO, Spectrum::ZERO], 1.0),
            // The reflectance is looked up below, once the uv is known.
            LaneMaterial::TexturedDiffuse => (0, [Spectrum::ZERO; 3], 1.0),
            LaneMaterial::RoughConductor { alpha, eta, k, specular_reflectance } => {
                (1, [eta, k, specular_reflectance], alpha)
            }
            LaneMaterial::Conductor { eta, k, specular_reflectance } => (2, [eta, k, specular_reflectance], 1.0),
            LaneMaterial::Dielectric { eta, specular_reflectance, specular_transmittance } => {
                (3, [specular_reflectance, specular_transmittance, Spectrum::ZERO], eta)
            }
        };
        let lit = bsdf < 2;
        // The light BVH's choice depends on the point, found in lanes.
        if lit && scene.light_sampler().kind() == LightSelection::Bvh {
            return false;
        }
        v.kind = LaneKind { shape: 0, bsdf, light: 0 };
        (v.d, v.b, v.mat, v.param, v.beta) = (st.ray.d, hit.uv, mat, param, st.beta);
        match &scene.shapes[hit.shape as usize] {
            Shape::Mesh(m) | Shape::CulledMesh(m) => {
                let [p0, p1, p2] = m.vertices(hit.index as usize);
                v.geo[..3].copy_from_slice(&[p0, p1, p2]);
                if let LaneMaterial::TexturedDiffuse = material {
                    // The hit's uv as Shape::interaction_with finds it (barycentric without texture coordinates).
                    let (b1, b2) = (hit.uv.x, hit.uv.y);
                    let mut tex = Vec2::new(b1, b2);
                    if !m.mesh.uvs.is_empty() {
                        let (u, t) = (&m.mesh.uvs, m.mesh.indices[hit.index as usize]);
                        v.uvs = [u[t[0] as usize], u[t[1] as usize], u[t[2] as usize]];
                        let b0 = 1.0 - b1 - b2;
                        tex = b0 * v.uvs[0] + b1 * v.uvs[1] + b2 * v.uvs[2];
                        v.kind.shape = 3;
                    }
                    let Material::Diffuse(d) = &scene.materials[scene.shape_info[hit.shape as usize].material as usize]
                    else {
                        return false;
                    };
                    v.mat[0] = d.reflectance.eval(&SurfaceInteraction::at_uv(tex));
                }
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
            _ => return false,
        }
        let saved = if lit { Some(rng.clone()) } else { None };
        let (u_sel, u_light) = (rng.next_1d(), rng.next_2d());
        if let Some(saved) = saved {
            // Uniform and power selection ignore the receiver.
            let picked = scene.select_light(Vec3::ZERO, Vec3::ZERO, u_sel).and_then(|(i, pmf)| {
                v.pmf = pmf;
                if let Some((_, e)) = env.filter(|&(e_index, _)| e_index == i) {
                    let (x, cos_t, pdf_row) = e.sample_cell(u_light)?;
                    v.kind.light = 1;
                    (v.u_light, v.area_pdf) = (Vec2::new(x, cos_t), pdf_row);
                    return Some(());
                }
                let (shape, li, two_sided) = scene.lane_area_light(i)?;
                (v.li, v.two_sided) = (li, two_sided);
                match shape {
                    Shape::Sphere(s) => {
                        v.kind.light = 2;
                        let flip = if s.flip { 1.0 } else { 0.0 };
                        v.light_tri[..2].copy_from_slice(&[s.center, Vec3::new(s.radius, 1.0 / s.area(), flip)]);
                        v.u_light = u_light;
                    }
                    Shape::Mesh(mesh) | Shape::CulledMesh(mesh) => {
                        let (t, ux) = mesh.pick_triangle(u_light.x)?;
                        v.light_tri = mesh.vertices(t);
                        (v.area_pdf, v.u_light) = (mesh.area_pdf(), Vec2::new(ux, u_light.y));
                    }
                    _ => return None,
                }
                Some(())
            });
            if picked.is_none() {
                *rng = saved;
                return false;
            }
        }
        // Specular BSDFs sample no light, but `vertex` draws its numbers all the same.
        v.u_bsdf1 = rng.next_1d();
        v.u_bsdf = rng.next_2d();
        true
    }

    /// Runs up to `F::WIDTH` prepared vertices of one [`LaneKind`] at once,
    /// `all[idx[k]]` for each k; `out[k]` is its outcome. `env` as for
    /// [`Self::lane_vertex`].
    pub fn lane_vertices<F: Float>(
        &self,
        env: Option<&EnvMapLight>,
        all: &[LaneVertex],
        idx: &[u16],
        out: &mut [LaneOutcome],
    ) {
        let Some(&first) = idx.first() else { return };
        let first = &all[first as usize];
        debug_assert!(idx.len() <= F::WIDTH && out.len() >= idx.len());
        debug_assert!(idx.iter().all(|&i| all[i as usize].kind == first.kind));
        let v = Lanes { all, idx };
        let k = first.kind;
        macro_rules! lit {
            ($s:literal) => {
                match (k.light, k.bsdf) {
                    (0, 0) => self.lit::<F, $s, 0, 0>(None, v, out),
                    (1, 0) => self.lit::<F, $s, 1, 0>(env, v, out),
                    (_, 0) => self.lit::<F, $s, 2, 0>(None, v, out),
                    (0, _) => self.lit::<F, $s, 0, 1>(None, v, out),
                    (1, _) => self.lit::<F, $s, 1, 1>(env, v, out),
                    (_, _) => self.lit::<F, $s, 2, 1>(None, v, out),
                }
            };
        }
        match (k.shape, k.bsdf) {
            (0, 0 | 1) => lit!(0),
            (1, 0 | 1) => lit!(1),
            (2, 0 | 1) => lit!(2),
            (_, 0 | 1) => lit!(3),
            (0, b) => specular::<F, 0>(b == 3, v, out),
            (1, b) => specular::<F, 1>(b == 3, v, out),
            (2, b) => specular::<F, 2>(b == 3, v, out),
            (_, b) => specular::<F, 3>(b == 3, v, out),
        }
    }

    /// [`Self::lane_vertices`] for a vertex with light sampling on shape
    /// kind `S`, lit by light kind `L` (0: an area light on a mesh, 1: the
    /// environment map, 2: an area light on a sphere), with BSDF `B` (0:
    /// diffuse, 1: GGX rough conductor).
    #[inline(always)]
    fn lit<F: Float, const S: u8, const L: u8, const B: u8>(
        &self,
        env: Option<&EnvMapLight>,
        v: Lanes,
        out: &mut [LaneOutcome],
    ) {
        let n_in = v.idx.len();
        let at = |l: usize| v.at(l);
        let g = |f: fn(&LaneVertex) -> f32| gather::<F>(|l| f(at(l)));
        let gv = |f: fn(&LaneVertex) -> Vec3| V3::<F>::gather(|l| f(at(l)));
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let h = hit::<F, S>(v);
        let (p, n) = (h.p, h.n);

        // The light sample, its selection included: (direction, distance,
        // density, radiance, whether there is one).
        let (wi, dist, light_pdf, li, sampled) = if L == 1 {
            let env = env.expect("an environment vertex without the environment");
            let (wi, pdf) = env.sample_direction(g(|v| v.u_light.x), g(|v| v.u_light.y), g(|v| v.area_pdf));
            let li = env.eval_lanes(wi.x, wi.y, wi.z);
            (wi, F::splat(f32::INFINITY), pdf * g(|v| v.pmf), V3::gather(|l| li[l]), F::Mask::splat(true))
        } else {
            // The point, its normal and solid-angle density (Shape::sample_direction).
            let (lp, ln, pdf, ok) = if L == 0 {
                // Shape::sample_point on the picked triangle, area_to_solid_angle.
                let (q0, q1, q2) = (gv(|v| v.light_tri[0]), gv(|v| v.light_tri[1]), gv(|v| v.light_tri[2]));
                let su = g(|v| v.u_light.x).sqrt();
                let (lb1, lb2) = (one - su, g(|v| v.u_light.y) * su);
                let lp = q0 * (one - lb1 - lb2) + q1 * lb1 + q2 * lb2;
                let ln = (q1 - q0).cross(q2 - q0).normalize();
                let (pdf, ok) = area_to_solid_angle(g(|v| v.area_pdf), p, lp, ln);
                (lp, ln, pdf, ok)
            } else {
                sphere_sample(gv(|v| v.light_tri[0]), gv(|v| v.light_tri[1]), p, g(|v| v.u_light.x), g(|v| v.u_light.y))
            };
            // AreaLight::sample_li.
            let d = lp - p;
            let dist = d.length();
            let wi = d / dist;
            let n_wi = ln.dot(wi);
            let two_sided = gather_mask::<F>(|l| at(l).two_sided);
            let facing = !(n_wi.cmp_ge(zero) & !(two_sided & n_wi.cmp_gt(zero)));
            let sampled = ok & dist.cmp_ne(zero) & pdf.cmp_gt(zero) & finite(pdf) & facing;
            (wi, dist, pdf * g(|v| v.pmf), gv(|v| v.li), sampled)
        };
        // The BSDF's value and density (Bsdf::eval_pdf), MIS-weighted.
        let wi_l = h.to_local(wi);
        let (f, bsdf_pdf) = if B == 0 {
            let front = h.wo.z.cmp_gt(zero) & wi_l.z.cmp_gt(zero);
            let f = V3::select(front, gv(|v| v.mat[0]) * F::splat(INV_PI), V3::splat(Vec3::ZERO));
            (f, F::select(front, wi_l.z.max(zero) * F::splat(INV_PI), zero))
        } else {
            let ggx = Ggx::new(g(|v| v.param));
            let (eta, k, spec) = (gv(|v| v.mat[0]), gv(|v| v.mat[1]), gv(|v| v.mat[2]));
            ggx.eval_pdf(h.wo, wi_l, eta, k, spec)
        };
        let f = f * wi_l.z.abs();
        let contributes = sampled & f.ne_zero();
        let w = if self.mis { power_heuristic(light_pdf, bsdf_pdf) } else { one };
        let pending = gv(|v| v.beta).mul_elem(f).mul_elem(li) * (w / light_pdf);
        // Its shadow ray (Scene::shadow_ray).
        let o = offset_origin(p, n, wi);
        let (shadow_d, shadow_t) = if L != 1 {
            let to_light = p + wi * dist - o;
            let len = to_light.length();
            (to_light / len, len * F::splat(1.0 - SHADOW_EPSILON))
        } else {
            (wi, dist)
        };

        // The BSDF sample (Bsdf::sample).
        let (u0, u1) = (g(|v| v.u_bsdf.x), g(|v| v.u_bsdf.y));
        let (wi_next, bsdf_pdf, weight, go) = if B == 0 {
            // Diffuse::sample: sample_cosine_hemisphere.
            let (dx, dy) = concentric_disk(u0, u1);
            let dz = (one - (dx * dx + dy * dy)).max(zero).sqrt();
            let bsdf_pdf = dz.max(zero) * F::splat(INV_PI);
            let go = !h.wo.z.cmp_le(zero) & !bsdf_pdf.cmp_le(zero);
            (V3::new(dx, dy, dz), bsdf_pdf, gv(|v| v.mat[0]), go)
        } else {
            let ggx = Ggx::new(g(|v| v.param));
            let (eta, k, spec) = (gv(|v| v.mat[0]), gv(|v| v.mat[1]), gv(|v| v.mat[2]));
            ggx.sample(h.wo, u0, u1, eta, k, spec)
        };
        let wi_next = h.to_world(wi_next);
        let (pending, o, shadow_d) = (pending.to_lanes(), o.to_lanes(), shadow_d.to_lanes());
        let shadow_t = shadow_t.to_array();
        let contributes = contributes.bitmask();
        for (l, out) in out.iter_mut().enumerate().take(n_in) {
            out.shadow =
                (contributes >> l & 1 != 0).then(|| (pending[l], Ray::new(o[l], shadow_d[l], shadow_t.as_ref()[l])));
        }
        let weight = weight.to_lanes();
        next_rays(&h, wi_next, bsdf_pdf, go, |l| weight[l], |_| 1.0, false, n_in, out);
    }

    /// The rest of a lane vertex, one path at a time: its outcome applied
    /// to `st` and Russian roulette, as at the end of [`Self::vertex`].
    pub fn lane_vertex_done(&self, st: &mut PathState, out: &LaneOutcome, rng: &mut SampleStream) -> Vertex {
        let shadow = out.shadow.map(|(c, ray)| {
            st.pending = c;
            ray
        });
        let Some(s) = out.next else { return Vertex { shadow, go_on: false } };
        st.beta *= s.weight;
        st.eta *= s.eta;
        st.prev_p = s.p;
        st.prev_n = s.n;
        st.prev_bsdf_pdf = s.pdf;
        st.prev_delta = s.delta;
        st.ray = s.ray;
        st.depth += 1;
        Vertex { shadow, go_on: self.roulette(st, rng) }
    }
}

/// The hit of lane vertices on shape kind `S` (0: a mesh, 1: a sphere, 2: a
/// disk): point, normal and dp/du as `Shape::interaction_with` finds them
/// without the uv parameterisation, and the frame of `frame_from_dpdu`.
#[inline(always)]
fn hit<F: Float, const S: u8>(v: Lanes) -> LaneHit<F> {
    let at = |l: usize| v.at(l);
    let g = |f: fn(&LaneVertex) -> f32| gather::<F>(|l| f(at(l)));
    let gv = |f: fn(&LaneVertex) -> Vec3| V3::<F>::gather(|l| f(at(l)));
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let wo = -gv(|v| v.d).normalize();
    let (p, n, dpdu) = match S {
        0 | 3 => {
            let (p0, p1, p2) = (gv(|v| v.geo[0]), gv(|v| v.geo[1]), gv(|v| v.geo[2]));
            let (b1, b2) = (g(|v| v.b.x), g(|v| v.b.y));
            let b0 = one - b1 - b2;
            let p = p0 * b0 + p1 * b1 + p2 * b2;
            let (dp0, dp1) = (p1 - p0, p2 - p0);
            let n = dp0.cross(dp1).normalize();
            if S == 0 {
                (p, n, dp0)
            } else {
                // dp/du from the texture coordinates; Mitsuba's arbitrary
                // basis where they are degenerate.
                let uv = |k: usize| (gather::<F>(|l| at(l).uvs[k].x), gather::<F>(|l| at(l).uvs[k].y));
                let (uv0, uv1, uv2) = (uv(0), uv(1), uv(2));
                let (duv0, duv1) = ((uv1.0 - uv0.0, uv1.1 - uv0.1), (uv2.0 - uv0.0, uv2.1 - uv0.1));
                let det = duv0.0 * duv1.1 - duv0.1 * duv1.0;
                let inv = one / det;
                let dpdu = (dp0 * duv1.1 - dp1 * duv0.1) * inv;
                let (fs, _) = frame_from_normal(n);
                (p, n, V3::select(det.cmp_ne(zero), dpdu, fs))
            }
        }
        1 => {
            // Sphere::interaction: the point re-projected onto the surface.
            let (c, z_axis, o) = (gv(|v| v.geo[0]), gv(|v| v.geo[1]), gv(|v| v.geo[2]));
            let at_t = o + gv(|v| v.d) * g(|v| v.b.x);
            let n = (at_t - c).normalize();
            let p = c + n * g(|v| v.radius);
            let dpdu = z_axis.cross(n);
            (p, V3::select(gather_mask::<F>(|l| at(l).flip), -n, n), dpdu)
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
    let mut h = LaneHit { p, n, fs, ft, wo };
    h.wo = h.to_local(wo);
    h
}

/// Lane vertices with a smooth conductor (`dielectric` false) or
/// dielectric on shape kind `S`: `Conductor::sample` or
/// `Dielectric::sample` and the next ray; no light sample.
#[inline(always)]
fn specular<F: Float, const S: u8>(dielectric: bool, v: Lanes, out: &mut [LaneOutcome]) {
    let n_in = v.idx.len();
    let at = |l: usize| v.at(l);
    let g = |f: fn(&LaneVertex) -> f32| gather::<F>(|l| f(at(l)));
    let gv = |f: fn(&LaneVertex) -> Vec3| V3::<F>::gather(|l| f(at(l)));
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let h = hit::<F, S>(v);
    let wo = h.wo;
    let reflected = V3::new(-wo.x, -wo.y, wo.z);
    for out in out.iter_mut().take(n_in) {
        out.shadow = None;
    }
    if !dielectric {
        let (eta, k) = (gv(|v| v.mat[0]), gv(|v| v.mat[1]));
        let f = V3::new(
            fresnel_conductor(wo.z, eta.x, k.x),
            fresnel_conductor(wo.z, eta.y, k.y),
            fresnel_conductor(wo.z, eta.z, k.z),
        );
        let weight = gv(|v| v.mat[2]).mul_elem(f).to_lanes();
        let go = !wo.z.cmp_le(zero);
        next_rays(&h, h.to_world(reflected), one, go, |l| weight[l], |_| 1.0, true, n_in, out);
        return;
    }
    let (r, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.z, g(|v| v.param));
    let reflect = g(|v| v.u_bsdf1).cmp_le(r);
    let refracted = V3::new(-eta_ti * wo.x, -eta_ti * wo.y, cos_t);
    let wi = V3::select(reflect, reflected, refracted);
    let pdf = F::select(reflect, r, one - r);
    let t = gv(|v| v.mat[1]) * (eta_ti * eta_ti);
    let weight = V3::select(reflect, gv(|v| v.mat[0]), t).to_lanes();
    let eta = F::select(reflect, one, eta_it).to_array();
    next_rays(&h, h.to_world(wi), pdf, F::Mask::splat(true), |l| weight[l], |l| eta.as_ref()[l], true, n_in, out);
}

/// The BSDF samples of lane vertices: where `go` holds, the ray leaving
/// the hit along the world direction `wi` (`Scene::spawn_ray`) with its
/// density, weight, relative IOR and specularity; elsewhere none.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn next_rays<F: Float>(
    h: &LaneHit<F>,
    wi: V3<F>,
    pdf: F,
    go: F::Mask,
    weight: impl Fn(usize) -> Spectrum,
    eta: impl Fn(usize) -> f32,
    delta: bool,
    n_in: usize,
    out: &mut [LaneOutcome],
) {
    let o = offset_origin(h.p, h.n, wi);
    let (o, wi, p, n, pdf) = (o.to_lanes(), wi.to_lanes(), h.p.to_lanes(), h.n.to_lanes(), pdf.to_array());
    let go = go.bitmask();
    for (l, out) in out.iter_mut().enumerate().take(n_in) {
        out.next = (go >> l & 1 != 0).then(|| LaneSample {
            ray: Ray::new(o[l], wi[l], f32::INFINITY),
            p: p[l],
            n: n[l],
            pdf: pdf.as_ref()[l],
            weight: weight(l),
            eta: eta(l),
            delta,
        });
    }
}

/// Where `Default` is needed for buffers of outcomes.
impl Default for LaneOutcome {
    fn default() -> Self {
        LaneOutcome::NONE
    }
}
