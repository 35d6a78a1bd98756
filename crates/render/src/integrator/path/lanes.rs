//! The `path` integrator's vertex in lanes for the commonest vertices: a
//! hit on a mesh (flat-shaded, or with vertex normals interpolated), a
//! sphere or a disk (an emitter's too: its emission is added as the vertex
//! is prepared, as `vertex` adds it) with a plain `diffuse`,
//! `conductor`, `dielectric`, `plastic`, `roughconductor` or
//! `roughdielectric` (GGX or Beckmann; anisotropic ones on spheres, whose
//! frame then follows the uv parameterisation) material of constant parameters,
//! alone or in `twosided` ([`Scene::lane_site`]); the non-specular ones lit by an area light
//! on a mesh or a sphere ([`Scene::lane_light`]) or by the scene's one
//! environment map, or resampled from up to [`MAX_LANE_CANDIDATES`] light
//! candidates that are all such area lights (`resample_light`: the
//! candidates, the reservoir and the pick's scale in lanes, triangles and
//! spheres mixed in a batch). With uniform selection and only such lights,
//! the kernel picks each lane's light (each candidate's) and its triangle
//! from the scene's [`LaneLightTable`]; otherwise the preparation picks
//! them and writes their fields into the batch. A
//! stream prepares such vertices of many paths into a [`LaneBatch`] per
//! [`LaneKind`] (shape, material and light; structure of arrays, so the
//! kernel loads each field as one vector), runs a batch once it holds
//! [`Float::WIDTH`] of them, and reads each path's lane back from the
//! [`LaneOutcomes`] (stored the same way); every other vertex runs
//! [`PathIntegrator::vertex`].
//!
//! **Bitwise [`PathIntegrator::vertex`].** The random numbers are drawn per
//! path in the scalar order ([`PathIntegrator::lane_vertex`] draws the light
//! and BSDF numbers, [`PathIntegrator::lane_vertex_done`] Russian
//! roulette's). The light's pick and the triangle's pick by area are the
//! scalar operations lane by lane (`LaneLightTable::pick`) or scalar; the
//! environment map's cell is picked in lanes
//! ([`EnvMapLight::sample_cell_lanes`], its tables gathered). The arithmetic in between is the scalar
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
//! GGX and Beckmann microfacet terms and visible-normal sampling
//! (`Microfacet`, Beckmann's Newton steps per lane), the
//! rough conductor's and dielectric's values, densities and samples, and
//! plastic's (`Plastic`, its lobe chosen per lane); the next ray
//! (`Scene::spawn_ray`). With a trained path guide, the vertex is
//! `vertex_guided`'s: the direction the guide or the BSDF draws
//! (`sample_guided`), the mixed density in every MIS weight, looked up in
//! lanes ([`crate::guiding::GuideLanes`]); a lane whose lobe is narrower
//! than `guiding_min_roughness` samples as without a guide.

use super::{PathIntegrator, PathState, Sampled};
use crate::accel::Hit;
use crate::bsdf::microfacet::{beckmann_slope_x_lanes, beckmann_slope_y_lanes, smith_g1_lanes};
use crate::bsdf::roughplastic::TRANSMITTANCE_RES;
use crate::geometry::SurfaceInteraction;
use crate::geometry::{Ray, Shape};
use crate::guiding::Guide;
use crate::light::lane_table::LaneLightTable;
use crate::light::{EnvMapLight, LightSelection};
use crate::material::{LaneMaterial, Material};
use crate::math::{Spectrum, INV_PI, PI, RAY_EPSILON, SHADOW_EPSILON};
use crate::sampling::distrib1d::alias_pick;
use crate::sampling::SampleStream;
use crate::scene::{LaneLight, Scene};
use crate::simd::{self, sin_cos, Float, Int, Mask, V3};
use glam::{Vec2, Vec3};

/// The shape, material and light of a lane vertex: vertices of one kind
/// run together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LaneKind {
    /// The geometry, numbered as [`crate::scene::LaneSite::geometry`].
    shape: u8,
    /// The material's kernel, numbered as [`LaneMaterial::kernel`] (all but
    /// 2 and 3, the smooth conductor and dielectric, sample a light).
    bsdf: u8,
    /// The light sampled: 0: an area light on a mesh, 1: the environment
    /// map, 2: an area light on a sphere (0 where none is).
    light: u8,
}

impl LaneKind {
    /// How many kinds there are.
    pub const COUNT: usize = 7 * 10 * 3;

    /// A number in 0..[`Self::COUNT`], for bins.
    #[inline]
    pub fn index(self) -> usize {
        ((self.shape * 10 + self.bsdf) * 3 + self.light) as usize
    }

    /// Whether its microfacets are Beckmann's (else GGX's, or none).
    #[inline(always)]
    fn beckmann(self) -> bool {
        matches!(self.bsdf, 6 | 7 | 9)
    }
}

/// The rows of a [`LaneBatch`]: a field's lanes side by side, a vector's
/// components in consecutive rows.
mod row {
    /// The direction of the ray that hit (3 rows).
    pub const D: usize = 0;
    /// The hit (5 × 3 rows): a mesh's triangle corners; a sphere's centre,
    /// rotation z axis and the ray's origin; a disk's world-from-object
    /// columns x, y, z, w and its normal.
    pub const GEO: usize = 3;
    /// A mesh's barycentrics (b1, b2); a sphere's distance t (first row); a
    /// disk's local (x, y).
    pub const B: usize = 18;
    /// A textured mesh's texture coordinates at the corners (3 × 2 rows).
    pub const UVS: usize = 20;
    /// A sphere's radius.
    pub const RADIUS: usize = 26;
    /// 1 where a sphere's normals are flipped.
    pub const FLIP: usize = 27;
    /// The material's constants (3 × 3 rows): diffuse: the reflectance;
    /// conductors: η, k and the specular reflectance; dielectric: the
    /// specular reflectance and transmittance.
    pub const MAT: usize = 28;
    /// A rough conductor's α; a dielectric's η.
    pub const PARAM: usize = 37;
    /// The path's throughput (3 rows).
    pub const BETA: usize = 38;
    /// An area light's picked triangle's corners (3 × 3 rows); a sphere
    /// light's centre, then (radius, 1 / area, 1 if its normals are flipped).
    pub const LIGHT_TRI: usize = 41;
    /// The light's area density.
    pub const AREA_PDF: usize = 50;
    /// The light's selection probability.
    pub const PMF: usize = 51;
    /// An area light's radiance (3 rows).
    pub const LI: usize = 52;
    /// 1 where the area light emits from both sides.
    pub const TWO_SIDED: usize = 55;
    /// The light sample's numbers (the first rescaled by the triangle's
    /// pick, except where the kernel picks the light: `U_SEL`).
    pub const U_LIGHT: usize = 56;
    /// The BSDF sample's numbers: the 1D one, then the 2D one.
    pub const U_BSDF1: usize = 58;
    pub const U_BSDF: usize = 59;
    /// A rough material's roughness along v (`PARAM` holds it along u).
    pub const PARAM_V: usize = 61;
    /// A smooth mesh's vertex normals at the corners (3 × 3 rows).
    pub const NS: usize = 62;
    /// 1 where the material is two-sided (every kind reads it).
    pub const TWO_SIDED_BSDF: usize = 71;
    /// With a path guide (lit kinds only): 1 where the next direction is
    /// the guide's (drawn in lanes with `U_BSDF`), else the BSDF's, its
    /// `U_BSDF1` rescaled.
    pub const GUIDE_PICK: usize = 72;
    /// With resampled light selection: the number that picks among the
    /// candidates (their rows are [`cand_row`]'s).
    pub const U_PICK: usize = 73;
    /// Where the kernel picks the light from the scene's
    /// [`LaneLightTable`]: the selection's number (`U_LIGHT` then holds
    /// the light's numbers as drawn, and the candidates' rows are unused).
    pub const U_SEL: usize = 74;
    /// With a path guide (lit kinds only): 1 where the vertex is guided,
    /// 0 where its lobe is too narrow for the guide
    /// (`LaneMaterial::narrower_than`) and it samples as without one.
    pub const GUIDED: usize = 75;
    /// How many rows there are.
    pub const COUNT: usize = 76;
}

/// The most light candidates a lane vertex resamples from (more run the
/// scalar vertex): a batch keeps 18 rows of 16 lanes per candidate, unless
/// the kernel picks them from the scene's [`LaneLightTable`].
pub const MAX_LANE_CANDIDATES: u32 = 8;

/// The rows of one light candidate in [`LaneBatch`]'s candidate block
/// (resampled light selection), as [`row`]'s for one light.
mod cand_row {
    /// 0: an area light on a mesh, 1: on a sphere, 2: none (the selection
    /// found no light).
    pub const KIND: usize = 0;
    /// A mesh light's picked triangle's corners (3 × 3 rows); a sphere
    /// light's centre, then (radius, 1 / area, 1 if its normals are flipped).
    pub const GEO: usize = 1;
    /// A mesh light's area density.
    pub const AREA_PDF: usize = 10;
    /// The light's selection probability.
    pub const PMF: usize = 11;
    /// Its radiance (3 rows).
    pub const LI: usize = 12;
    /// 1 where it emits from both sides.
    pub const TWO_SIDED: usize = 15;
    /// The candidate's numbers (on a mesh, the first rescaled by the
    /// triangle's pick).
    pub const U: usize = 16;
    /// How many rows a candidate takes.
    pub const COUNT: usize = 18;
}

/// Up to [`LaneBatch::LANES`] prepared vertices of one [`LaneKind`], as
/// the lane kernel loads them: structure of arrays, a row per field
/// (`row`), filled by [`PathIntegrator::lane_vertex`] one lane at a time
/// and run by [`PathIntegrator::lane_vertices`]. Rows a kind does not read
/// are left as they are.
#[derive(Clone)]
pub struct LaneBatch {
    kind: LaneKind,
    len: usize,
    /// The light candidates of every lane (1: no resampling).
    candidates: u32,
    /// Whether the kernel picks the lights from the scene's
    /// [`LaneLightTable`] (the batch then holds `U_SEL` and the drawn
    /// `U_LIGHT`, not the light's fields or candidate rows).
    table_picks: bool,
    /// The caller's number for each lane's path.
    slots: [u32; LaneBatch::LANES],
    rows: [[f32; LaneBatch::LANES]; row::COUNT],
    /// With resampled light selection picked in the preparation,
    /// [`cand_row::COUNT`] rows per candidate (empty until a batch first
    /// needs them).
    cands: Vec<[[f32; LaneBatch::LANES]; cand_row::COUNT]>,
}

impl LaneBatch {
    /// Lanes in a batch (the widest [`Float`]).
    pub const LANES: usize = 16;

    fn new(kind: LaneKind) -> LaneBatch {
        LaneBatch {
            kind,
            len: 0,
            candidates: 1,
            table_picks: false,
            slots: [0; Self::LANES],
            rows: [[0.0; Self::LANES]; row::COUNT],
            cands: Vec::new(),
        }
    }

    /// Vertices in the batch.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it holds none.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The number the caller gave lane `l`'s path.
    #[inline]
    pub fn slot(&self, l: usize) -> usize {
        self.slots[l] as usize
    }

    /// Empties the batch (its rows are overwritten as lanes are added).
    #[inline]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// The lane being added (a full batch is run before another is added;
    /// the mask spares the bounds checks).
    #[inline(always)]
    fn lane(&self) -> usize {
        debug_assert!(self.len < Self::LANES);
        self.len & (Self::LANES - 1)
    }

    /// Row `r` of lane `l` (the lane being added, [`Self::lane`], found
    /// once per vertex: found per row, it was loaded again after every store).
    #[inline(always)]
    fn set(&mut self, l: usize, r: usize, x: f32) {
        put(&mut self.rows, l, r, x);
    }

    /// Rows `r..r + 3` of lane `l`.
    #[inline(always)]
    fn set3(&mut self, l: usize, r: usize, v: Vec3) {
        put3(&mut self.rows, l, r, v);
    }

    /// Row `r` of candidate `c` in lanes.
    #[inline(always)]
    fn cand<F: Float>(&self, c: usize, r: usize) -> F {
        F::load(&self.cands[c][r])
    }

    /// Rows `r..r + 3` of candidate `c` in lanes.
    #[inline(always)]
    fn cand3<F: Float>(&self, c: usize, r: usize) -> V3<F> {
        V3::new(self.cand(c, r), self.cand(c, r + 1), self.cand(c, r + 2))
    }

    /// Row `r` in lanes.
    #[inline(always)]
    fn get<F: Float>(&self, r: usize) -> F {
        F::load(&self.rows[r])
    }

    /// Rows `r..r + 3` in lanes.
    #[inline(always)]
    fn get3<F: Float>(&self, r: usize) -> V3<F> {
        V3::new(self.get(r), self.get(r + 1), self.get(r + 2))
    }

    /// Row `r` (0 or 1) as a mask.
    #[inline(always)]
    fn mask<F: Float>(&self, r: usize) -> F::Mask {
        self.get::<F>(r).cmp_eq(F::splat(1.0))
    }

    /// Repeats the last lane in lanes `len..F::WIDTH`, so a short batch
    /// runs on valid inputs. A full batch returns at once: walking all its
    /// rows to fill nothing cost a tenth of the Cornell box's instructions.
    #[inline(always)]
    fn pad<F: Float>(&mut self) {
        if self.len < F::WIDTH {
            self.pad_rows::<F>();
        }
    }

    /// [`Self::pad`]'s fill: per row one select of the row against its last
    /// lane broadcast (a `fill` per row cost 50 instructions a row).
    #[inline(never)]
    fn pad_rows<F: Float>(&mut self) {
        let (len, last) = (self.len, self.len - 1);
        let mut index = F::Array::default();
        for (l, x) in index.as_mut().iter_mut().enumerate() {
            *x = l as f32;
        }
        let keep = F::from_array(index).cmp_lt(F::splat(len as f32));
        let pad = |r: &mut [f32; Self::LANES]| F::select(keep, F::load(r), F::splat(r[last])).store(r);
        self.rows.iter_mut().for_each(pad);
        // (Candidates picked from the scene's table have no rows.)
        let cands = if self.candidates > 1 && !self.table_picks { self.candidates as usize } else { 0 };
        self.cands[..cands].iter_mut().flatten().for_each(pad);
    }
}

/// Row `r` of lane `l` in `rows` (a batch's, or one candidate's).
#[inline(always)]
fn put(rows: &mut [[f32; LaneBatch::LANES]], l: usize, r: usize, x: f32) {
    rows[r][l] = x;
}

/// Rows `r..r + 3` of lane `l` in `rows`.
#[inline(always)]
fn put3(rows: &mut [[f32; LaneBatch::LANES]], l: usize, r: usize, v: Vec3) {
    (rows[r][l], rows[r + 1][l], rows[r + 2][l]) = (v.x, v.y, v.z);
}

/// The open [`LaneBatch`]es of a stream, one per kind met so far.
#[derive(Clone)]
pub struct LaneBins {
    /// Per [`LaneKind::index`]: its batch's position in `batches`, or `u8::MAX`.
    of_kind: [u8; LaneKind::COUNT],
    batches: Vec<LaneBatch>,
}

impl Default for LaneBins {
    fn default() -> Self {
        LaneBins { of_kind: [u8::MAX; LaneKind::COUNT], batches: Vec::new() }
    }
}

impl LaneBins {
    /// The batch at `i` (as [`PathIntegrator::lane_vertex`] returns it).
    #[inline]
    pub fn batch(&mut self, i: usize) -> &mut LaneBatch {
        &mut self.batches[i]
    }

    /// How many batches there are (positions `0..count`).
    #[inline]
    pub fn count(&self) -> usize {
        self.batches.len()
    }

    /// The position of `kind`'s batch, made on first use.
    #[inline(always)]
    fn of(&mut self, kind: LaneKind) -> usize {
        let k = kind.index();
        if self.of_kind[k] == u8::MAX {
            self.add(kind);
        }
        self.of_kind[k] as usize
    }

    /// A new batch for `kind` (a stream meets a few kinds).
    #[cold]
    #[inline(never)]
    fn add(&mut self, kind: LaneKind) {
        self.of_kind[kind.index()] = self.batches.len() as u8;
        self.batches.push(LaneBatch::new(kind));
    }
}

/// The rows of [`LaneOutcomes`], as [`row`] for a batch.
mod out_row {
    /// The light sample's contribution if unblocked (3 rows).
    pub const PENDING: usize = 0;
    /// Its shadow ray: origin, direction (3 rows each), length.
    pub const SHADOW_O: usize = 3;
    pub const SHADOW_D: usize = 6;
    pub const SHADOW_T: usize = 9;
    /// The BSDF sample's next ray: origin and direction (3 rows each).
    pub const O: usize = 10;
    pub const WI: usize = 13;
    /// The vertex's point and normal (3 rows each).
    pub const P: usize = 16;
    pub const N: usize = 19;
    /// The sample's density, weight (3 rows) and relative IOR.
    pub const PDF: usize = 22;
    pub const WEIGHT: usize = 23;
    pub const ETA: usize = 26;
    /// The guide's density of the next direction (0: not guided, or a delta
    /// lobe) and its quadtree's mean record Φ (for roulette, read only
    /// where that density is positive).
    pub const GUIDE_PDF: usize = 27;
    pub const GUIDE_FLUX: usize = 28;
    /// How many rows there are.
    pub const COUNT: usize = 29;
}

/// What the lane kernel found at the vertices of a [`LaneBatch`], stored
/// a row per field as the lanes hold it (`out_row`) and read a lane at
/// a time by [`PathIntegrator::lane_vertex_done`].
#[derive(Clone)]
pub struct LaneOutcomes {
    /// Lanes with a light sample whose shadow ray is to be traced.
    shadow: u32,
    /// Lanes whose BSDF sample goes on (elsewhere sampling failed: the path ends).
    go: u32,
    /// Lanes whose BSDF sample is specular.
    delta: u32,
    rows: [[f32; LaneBatch::LANES]; out_row::COUNT],
}

impl Default for LaneOutcomes {
    fn default() -> Self {
        LaneOutcomes { shadow: 0, go: 0, delta: 0, rows: [[0.0; LaneBatch::LANES]; out_row::COUNT] }
    }
}

impl LaneOutcomes {
    #[inline(always)]
    fn put<F: Float>(&mut self, r: usize, x: F) {
        x.store(&mut self.rows[r]);
    }

    #[inline(always)]
    fn put3<F: Float>(&mut self, r: usize, v: V3<F>) {
        self.put(r, v.x);
        self.put(r + 1, v.y);
        self.put(r + 2, v.z);
    }

    /// Row `r` of lane `l` (`l` < [`LaneBatch::LANES`]; the mask spares the bounds checks).
    #[inline(always)]
    fn at(&self, r: usize, l: usize) -> f32 {
        self.rows[r][l & (LaneBatch::LANES - 1)]
    }

    /// Rows `r..r + 3` of lane `l`.
    #[inline(always)]
    fn at3(&self, r: usize, l: usize) -> Vec3 {
        let l = l & (LaneBatch::LANES - 1);
        Vec3::new(self.rows[r][l], self.rows[r + 1][l], self.rows[r + 2][l])
    }

    /// Lane `l`'s shadow ray, where [`PathIntegrator::lane_vertex_done`]
    /// says there is one.
    #[inline]
    pub fn shadow_ray(&self, l: usize) -> Ray {
        use out_row::*;
        Ray::new(self.at3(SHADOW_O, l), self.at3(SHADOW_D, l), self.at(SHADOW_T, l))
    }

    /// Lane `l`'s non-delta direction drawn, as [`Vertex::sampled`] has it
    /// (for a guide's training records); `None` where sampling failed or
    /// the direction is specular.
    ///
    /// [`Vertex::sampled`]: super::Vertex::sampled
    #[inline]
    pub fn sampled(&self, l: usize) -> Option<Sampled> {
        use out_row::*;
        (self.go >> l & 1 != 0 && self.delta >> l & 1 == 0).then(|| Sampled {
            p: self.at3(P, l),
            d: self.at3(WI, l),
            pdf: self.at(PDF, l),
        })
    }
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

/// A number drawn but never read: the stream moves past it (0 stands in).
#[inline(always)]
fn skipped_1d(rng: &mut SampleStream) -> f32 {
    rng.skip_1d();
    0.0
}

/// [`skipped_1d`] for a 2D number.
#[inline(always)]
fn skipped_2d(rng: &mut SampleStream) -> Vec2 {
    rng.skip_2d();
    Vec2::ZERO
}

/// `mulsign`: `v` times the sign of `s` (−1 where s < 0, else 1).
#[inline(always)]
fn mulsign<F: Float>(v: V3<F>, s: F) -> V3<F> {
    let k = F::select(s.cmp_lt(F::splat(0.0)), F::splat(-1.0), F::splat(1.0));
    V3::new(v.x * k, v.y * k, v.z * k)
}

/// `Plastic::prob_specular` in lanes: the specular lobe's probability
/// given the Fresnel reflectance `f_i` and the sampling weight.
#[inline(always)]
fn plastic_specular_probability<F: Float>(f_i: F, weight: F) -> F {
    let one = F::splat(1.0);
    let s = f_i * weight;
    let d = (one - f_i) * (one - weight);
    s / (s + d)
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

/// `AreaLight::sample_li` in lanes, on a mesh light's triangle (corners
/// `geo`, area density `area_pdf`, `Shape::sample_point` and
/// `area_to_solid_angle`) or, where `sphere`, a sphere light (`geo[0]` its
/// centre, `geo[1]` as [`sphere_sample`]'s `r`), with the light's numbers
/// `u` and selection probability `pmf`: (direction, distance, density,
/// whether there is a sample). `kinds` says whether any lane is on a
/// triangle and whether any is on a sphere: only those are computed.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn area_light_sample<F: Float>(
    p: V3<F>,
    geo: [V3<F>; 3],
    area_pdf: F,
    u: (F, F),
    pmf: F,
    two_sided: F::Mask,
    sphere: F::Mask,
    kinds: (bool, bool),
) -> (V3<F>, F, F, F::Mask) {
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let on_tri = kinds.0.then(|| {
        let [q0, q1, q2] = geo;
        let su = u.0.sqrt();
        let (lb1, lb2) = (one - su, u.1 * su);
        let lp = q0 * (one - lb1 - lb2) + q1 * lb1 + q2 * lb2;
        let ln = (q1 - q0).cross(q2 - q0).normalize();
        let (pdf, ok) = area_to_solid_angle(area_pdf, p, lp, ln);
        (lp, ln, pdf, ok)
    });
    let on_sphere = kinds.1.then(|| sphere_sample(geo[0], geo[1], p, u.0, u.1));
    let (lp, ln, pdf, ok) = match (on_tri, on_sphere) {
        (Some(t), Some(s)) => (
            V3::select(sphere, s.0, t.0),
            V3::select(sphere, s.1, t.1),
            F::select(sphere, s.2, t.2),
            (sphere & s.3) | (!sphere & t.3),
        ),
        (Some(t), None) => t,
        (None, Some(s)) => s,
        (None, None) => (V3::splat(Vec3::ZERO), V3::splat(Vec3::ZERO), zero, F::Mask::splat(false)),
    };
    let d = lp - p;
    let dist = d.length();
    let wi = d / dist;
    let n_wi = ln.dot(wi);
    let facing = !(n_wi.cmp_ge(zero) & !(two_sided & n_wi.cmp_gt(zero)));
    let sampled = ok & dist.cmp_ne(zero) & pdf.cmp_gt(zero) & finite(pdf) & facing;
    (wi, dist, pdf * pmf, sampled)
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
    // The area (sample_uniform_sphere), where a lane is inside.
    let (area_p, area_n, area_pdf, area_ok) = if outside.all() {
        (V3::splat(Vec3::ZERO), V3::splat(Vec3::ZERO), zero, F::Mask::splat(false))
    } else {
        let z = one - two * u0;
        let rr = (one - z * z).max(zero).sqrt();
        let (s, co) = sin_cos(F::splat(2.0 * PI) * u1);
        let dir = V3::new(rr * co, rr * s, z);
        let area_p = c + dir * radius;
        let area_n = V3::select(flip, -dir, dir);
        let (area_pdf, area_ok) = area_to_solid_angle(inv_area, p_ref, area_p, area_n);
        (area_p, area_n, area_pdf, area_ok)
    };
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

/// A GGX or Beckmann `Microfacet` (α floored at 1e-4 as `alphas`) and the
/// rough conductor and dielectric on it (`RoughConductor`,
/// `RoughDielectric`), in lanes.
struct Micro<F> {
    au: F,
    av: F,
    /// Beckmann (else GGX), the same for a whole batch.
    beckmann: bool,
}

impl<F: Float> Micro<F> {
    /// `Microfacet::alphas`: the roughnesses floored at 1e-4.
    #[inline(always)]
    fn new(alpha_u: F, alpha_v: F, beckmann: bool) -> Self {
        Micro { au: alpha_u.max(F::splat(1e-4)), av: alpha_v.max(F::splat(1e-4)), beckmann }
    }

    /// `Microfacet::eval`: D(m).
    #[inline(always)]
    fn d(&self, m: V3<F>) -> F {
        let (au, av) = (self.au, self.av);
        let cos2 = m.z * m.z;
        let (x, y) = (m.x / au, m.y / av);
        let r = if self.beckmann {
            simd::exp(-(x * x + y * y) / cos2) / (F::splat(PI) * au * av * cos2 * cos2)
        } else {
            let s = x * x + y * y + cos2;
            F::splat(1.0) / (F::splat(PI) * au * av * (s * s))
        };
        F::select((r * m.z).cmp_gt(F::splat(1e-20)), r, F::splat(0.0))
    }

    /// `Microfacet::smith_g1`.
    #[inline(always)]
    fn g1(&self, v: V3<F>, m: V3<F>) -> F {
        smith_g1_lanes(self.au, self.av, self.beckmann, v, m)
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

    /// `Microfacet::sample`'s normal (visible normals, Heitz 2018) for `wo`
    /// in the upper hemisphere.
    #[inline(always)]
    fn visible_normal(&self, wo: V3<F>, u0: F, u1: F) -> V3<F> {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        // Microfacet::stretch.
        let wp = V3::new(self.au * wo.x, self.av * wo.y, wo.z).normalize();
        let sin_t = (one - wp.z * wp.z).max(zero).sqrt();
        let pole = sin_t.cmp_eq(zero);
        let sin_p = F::select(pole, zero, clamp_unit(wp.y / sin_t));
        let cos_p = F::select(pole, one, clamp_unit(wp.x / sin_t));
        let ci = wp.z;
        let (slope_x, slope_y) = if self.beckmann {
            (beckmann_slope_x_lanes(ci, u0), beckmann_slope_y_lanes(u1))
        } else {
            ggx_slopes(ci, u0, u1)
        };
        // normal_from_slope.
        let sx = (cos_p * slope_x - sin_p * slope_y) * self.au;
        let sy = (sin_p * slope_x + cos_p * slope_y) * self.av;
        V3::new(-sx, -sy, one).normalize()
    }
}

/// `sample_visible_11` for GGX: the slopes for α = 1 at incidence cos θ = `ci`.
#[inline(always)]
fn ggx_slopes<F: Float>(ci: F, u0: F, u1: F) -> (F, F) {
    {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let (px, py) = concentric_disk(u0, u1);
        let s = F::splat(0.5) * (one + ci);
        let hh = (one - px * px).max(zero).sqrt();
        let y = hh + (py - hh) * s;
        let x = px;
        let z = (one - x * x - y * y).max(zero).sqrt();
        let si = (one - ci * ci).max(zero).sqrt();
        let norm = one / (si * y + ci * z);
        ((ci * y - si * z) * norm, x * norm)
    }
}

impl<F: Float> Micro<F> {
    /// `Microfacet::pdf`: the visible normal density of `m` for `w`.
    #[inline(always)]
    fn pdf_m(&self, w: V3<F>, m: V3<F>) -> F {
        let d = self.d(m);
        F::select(d.cmp_eq(F::splat(0.0)), F::splat(0.0), d * self.g1(w, m) * w.dot(m).abs() / w.z)
    }

    /// `RoughDielectric::eval` and `pdf`: (f, density), with relative IOR
    /// `eta` and the reflectance and transmittance multipliers.
    #[inline(always)]
    fn dielectric_eval_pdf(&self, wo: V3<F>, wi: V3<F>, eta: F, spec_r: V3<F>, spec_t: V3<F>) -> (V3<F>, F) {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let (cos_o, cos_i) = (wo.z, wi.z);
        // half_vector.
        let reflect = (cos_o * cos_i).cmp_gt(zero);
        let eta_side = F::select(cos_o.cmp_gt(zero), eta, one / eta);
        let m = (wo + wi * F::select(reflect, one, eta_side)).normalize();
        let m = mulsign(m, m.z);
        let none = cos_o.cmp_eq(zero) | cos_i.cmp_eq(zero) | !(finite(m.x) & finite(m.y) & finite(m.z));
        let d = self.d(m);
        let g = self.g1(wo, m) * self.g1(wi, m);
        let f = fresnel_dielectric(wo.dot(m), eta).0;
        let (dom, dim) = (wo.dot(m), wi.dot(m));
        let fr = spec_r * (f * d * g / (F::splat(4.0) * cos_o.abs() * cos_i.abs()));
        let denom = dom + eta_side * dim;
        let ft = spec_t * ((one - f) * d * g * dom * dim / (cos_o * cos_i * denom * denom)).abs();
        let value = V3::select(none | d.cmp_eq(zero), V3::splat(Vec3::ZERO), V3::select(reflect, fr, ft));
        let t = dom + eta_side * dim;
        let dwh_dwi = F::select(reflect, one / (F::splat(4.0) * dim), eta_side * eta_side * dim / (t * t));
        let prob = self.pdf_m(mulsign(wo, cos_o), m) * F::select(reflect, f, one - f);
        let pdf_none = none | (dom * cos_o).cmp_le(zero) | (dim * cos_i).cmp_le(zero);
        (value, F::select(pdf_none, zero, prob * dwh_dwi.abs()))
    }

    /// `RoughDielectric::sample`: (direction, density, weight, relative
    /// IOR, whether there is one); `u` picks reflection or refraction.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn dielectric_sample(
        &self,
        wo: V3<F>,
        u: F,
        u0: F,
        u1: F,
        eta: F,
        spec_r: V3<F>,
        spec_t: V3<F>,
    ) -> (V3<F>, F, V3<F>, F, F::Mask) {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let cos_o = wo.z;
        let wo_up = mulsign(wo, cos_o);
        let m = self.visible_normal(wo_up, u0, u1);
        let pdf_m = self.pdf_m(wo_up, m);
        let dom = wo.dot(m);
        let (f, cos_t, eta_it, eta_ti) = fresnel_dielectric(dom, eta);
        let refl = u.cmp_le(f);
        // reflect_m and refract_m.
        let wi_r = m * (F::splat(2.0) * dom) - wo;
        let wi_t = m * (dom * eta_ti + cos_t) - wo * eta_ti;
        let wi = V3::select(refl, wi_r, wi_t);
        let weight = V3::select(refl, spec_r, spec_t * (eta_ti * eta_ti));
        let pdf = pdf_m * F::select(refl, f, one - f);
        let dim = wi.dot(m);
        let t = dom + eta_it * dim;
        let dwh_dwi = F::select(refl, one / (F::splat(4.0) * dim), eta_it * eta_it * dim / (t * t));
        let g1 = self.g1(wi, m);
        let pdf = pdf * dwh_dwi.abs();
        let go = !cos_o.cmp_eq(zero) & !pdf_m.cmp_eq(zero) & !g1.cmp_eq(zero) & pdf.cmp_gt(zero);
        (wi, pdf, weight * g1, F::select(refl, one, eta_it), go)
    }

    /// `RoughConductor::sample` (visible normals, Heitz 2018): (direction,
    /// density, weight, whether there is one).
    #[inline(always)]
    fn sample(&self, wo: V3<F>, u0: F, u1: F, eta: V3<F>, k: V3<F>, spec: V3<F>) -> (V3<F>, F, V3<F>, F::Mask) {
        let zero = F::splat(0.0);
        let m = self.visible_normal(wo, u0, u1);
        let cos_om = wo.dot(m);
        let pdf_m = self.pdf_m(wo, m);
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

/// A `roughplastic` (`RoughPlastic`) in lanes: its microfacets, constants
/// and each lane's transmittance table.
struct LaneRoughPlastic<'a, F> {
    micro: Micro<F>,
    eta: F,
    diffuse: V3<F>,
    spec: V3<F>,
    weight: F,
    tables: &'a [[f32; TRANSMITTANCE_RES]],
    table: [f32; LaneBatch::LANES],
}

impl<'a, F: Float> LaneRoughPlastic<'a, F> {
    /// The material of batch `v` (rows as `lane_vertex` fills them).
    #[inline(always)]
    fn new(v: &LaneBatch, tables: &'a [[f32; TRANSMITTANCE_RES]]) -> Self {
        LaneRoughPlastic {
            micro: Micro::new(v.get::<F>(row::PARAM), v.get::<F>(row::PARAM_V), v.kind.beckmann()),
            eta: v.get::<F>(row::MAT + 7),
            diffuse: v.get3::<F>(row::MAT),
            spec: v.get3::<F>(row::MAT + 3),
            weight: v.get::<F>(row::MAT + 6),
            tables,
            table: v.rows[row::MAT + 8],
        }
    }

    /// `RoughPlasticTables::transmittance` at `cos_theta`: each lane's
    /// table, linearly interpolated with the same operations.
    #[inline(always)]
    fn transmittance(&self, cos_theta: F) -> F {
        let last = (TRANSMITTANCE_RES - 2) as f32;
        let x = cos_theta * F::splat((TRANSMITTANCE_RES - 1) as f32);
        // `(x.max(0.0) as usize).min(len − 2)`; the index is clamped again
        // for lanes whose x is NaN (their result is not used).
        let i = x.max(F::splat(0.0)).min(F::splat(last)).to_int_trunc();
        let t = x - F::from_int(i);
        let i = i.to_array();
        let at = |l: usize, k: usize| {
            let j = i.as_ref()[l].clamp(0, last as i32) as usize;
            self.tables[self.table[l] as usize][j + k]
        };
        let (a, b) = (simd::gather::<F>(|l| at(l, 0)), simd::gather::<F>(|l| at(l, 1)));
        a + (b - a) * t
    }

    /// `RoughPlastic::prob_specular` given t(θ_o).
    #[inline(always)]
    fn prob_specular(&self, t_o: F) -> F {
        let one = F::splat(1.0);
        let s = (one - t_o) * self.weight;
        let d = t_o * (one - self.weight);
        s / (s + d)
    }

    /// `RoughPlastic::eval` and `pdf`: (f, density), given t(θ_o).
    #[inline(always)]
    fn eval_pdf(&self, wo: V3<F>, wi: V3<F>, t_o: F) -> (V3<F>, F) {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let up = !wo.z.cmp_le(zero) & !wi.z.cmp_le(zero);
        let h = (wo + wi).normalize();
        let d = self.micro.d(h);
        let f = fresnel_dielectric(wo.dot(h), self.eta).0;
        let g1o = self.micro.g1(wo, h);
        let g = g1o * self.micro.g1(wi, h);
        let specular = self.spec * (f * d * g / (F::splat(4.0) * wo.z * wi.z));
        let specular = V3::select(d.cmp_eq(zero), V3::splat(Vec3::ZERO), specular);
        let t_i = self.transmittance(wi.z);
        let value = specular + self.diffuse * (F::splat(INV_PI) / (self.eta * self.eta) * t_o * t_i);
        let p_spec = self.prob_specular(t_o);
        let spec_pdf = d * g1o / (F::splat(4.0) * wo.z);
        let pdf = p_spec * spec_pdf + (one - p_spec) * (wi.z.max(zero) * F::splat(INV_PI));
        (V3::select(up, value, V3::splat(Vec3::ZERO)), F::select(up, pdf, zero))
    }

    /// `RoughPlastic::sample`: (direction, density, weight, whether there
    /// is one), given t(θ_o); `u` picks the lobe.
    #[inline(always)]
    fn sample(&self, wo: V3<F>, t_o: F, u: F, u0: F, u1: F) -> (V3<F>, F, V3<F>, F::Mask) {
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        let specular = u.cmp_lt(self.prob_specular(t_o));
        // reflect_m of a visible normal, or sample_cosine_hemisphere.
        let m = self.micro.visible_normal(wo, u0, u1);
        let wi_s = m * (F::splat(2.0) * wo.dot(m)) - wo;
        let (dx, dy) = concentric_disk(u0, u1);
        let dz = (one - (dx * dx + dy * dy)).max(zero).sqrt();
        let wi = V3::select(specular, wi_s, V3::new(dx, dy, dz));
        let (f, pdf) = self.eval_pdf(wo, wi, t_o);
        let go = !wo.z.cmp_le(zero) & pdf.cmp_gt(zero);
        (wi, pdf, f * (wi.z / pdf), go)
    }
}

/// The hit of a lane vertex: point, geometric normal, shading frame (s, t;
/// its normal is the geometric one) and the outgoing direction in it.
struct LaneHit<F> {
    p: V3<F>,
    /// The geometric normal (where rays leave from).
    n: V3<F>,
    /// The shading frame: `fs`, `ft` and its normal `sn`.
    fs: V3<F>,
    ft: V3<F>,
    sn: V3<F>,
    wo: V3<F>,
}

impl<F: Float> LaneHit<F> {
    /// A world direction in the shading frame (`Frame::to_local`).
    #[inline(always)]
    fn to_local(&self, w: V3<F>) -> V3<F> {
        V3::new(w.dot(self.fs), w.dot(self.ft), w.dot(self.sn))
    }

    /// A shading-frame direction in the world (`Frame::to_world`).
    #[inline(always)]
    fn to_world(&self, w: V3<F>) -> V3<F> {
        self.fs * w.x + self.ft * w.y + self.sn * w.z
    }
}

/// What [`PathIntegrator::lane_vertex`] reads of the scene and the
/// integrator the same way at every vertex, found once per stream
/// ([`PathIntegrator::lane_setup`]).
pub struct LaneSetup<'a> {
    /// Light candidates of a lit vertex ([`PathIntegrator::light_candidates_for`]).
    candidates: u32,
    /// Whether lit vertices can run in lanes: not with the light BVH, whose
    /// choice depends on the point, nor with more than
    /// [`MAX_LANE_CANDIDATES`] candidates.
    lit_in_lanes: bool,
    /// Whether a lit vertex draws the light selection's number.
    reads_sel: bool,
    /// The scene's [`LaneLightTable`], where the kernel picks lights.
    table: Option<&'a LaneLightTable>,
    /// With a table whose lights are all of one kind: whether they are
    /// spheres (else meshes).
    table_kind: Option<bool>,
    /// The scene's one environment map, with its light index.
    env: Option<(usize, &'a EnvMapLight)>,
    /// The trained path guide.
    guide: Option<&'a Guide>,
    /// `guiding_min_roughness`.
    guide_min_roughness: f32,
}

impl PathIntegrator {
    /// The [`LaneSetup`] of a stream over `scene` guided by `guide` (a
    /// trained path guide); `env` is the scene's one environment map
    /// ([`Scene::single_envmap`]).
    pub fn lane_setup<'a>(
        &self,
        scene: &'a Scene,
        env: Option<(usize, &'a EnvMapLight)>,
        guide: Option<&'a Guide>,
    ) -> LaneSetup<'a> {
        let candidates = self.light_candidates_for(scene.lights.len());
        let table = scene.lane_light_table();
        LaneSetup {
            candidates,
            lit_in_lanes: scene.light_sampler().kind() != LightSelection::Bvh && candidates <= MAX_LANE_CANDIDATES,
            reads_sel: candidates > 1 || !scene.light_sampler().picks_without_number(),
            table,
            table_kind: match table.map(LaneLightTable::kinds) {
                Some((true, false)) => Some(false),
                Some((false, true)) => Some(true),
                _ => None,
            },
            env,
            guide,
            guide_min_roughness: self.guide_min_roughness(),
        }
    }

    /// The vertex of `st` at `hit` (the closest hit of `st.ray`) added to
    /// its kind's batch in `bins` when it qualifies: a non-instanced hit on
    /// a [`Scene::lane_site`] shape, before the last segment; for a
    /// diffuse one, with a light picked (uniformly or by power) that is a
    /// [`Scene::lane_light`] or `env`, the scene's one environment map
    /// ([`Scene::single_envmap`]). Its light and BSDF random numbers are
    /// drawn here, as `vertex` draws them; `slot` is the caller's number for
    /// the path ([`LaneBatch::slot`]). With `guide` (a trained path guide)
    /// the vertex is [`Self::vertex_guided`]'s: the guide's density at the
    /// hit and, where it is picked, its direction are found here, its
    /// density at other directions per lane in the kernel. Returns the batch's position
    /// ([`LaneBins::batch`]), with an emitter's emission at the hit added to
    /// `st` as `vertex` adds it; `None`, with `st` and `rng` as they were,
    /// otherwise: run [`Self::vertex`] (or `vertex_guided`).
    #[allow(clippy::too_many_arguments)]
    pub fn lane_vertex(
        &self,
        scene: &Scene,
        setup: &LaneSetup,
        st: &mut PathState,
        hit: &Hit,
        rng: &mut SampleStream,
        slot: usize,
        bins: &mut LaneBins,
    ) -> Option<usize> {
        let LaneSetup { env, guide, table, .. } = *setup;
        if hit.instance != Hit::NOT_INSTANCED || st.depth + 1 >= self.term.max_depth {
            return None;
        }
        // The kind first, then the rows of its batch.
        let site = scene.lane_site(hit.shape)?;
        // An emitter's emission is added here (after the last way back to
        // `vertex`, below), one path at a time; hidden from the camera, it is
        // `vertex`'s.
        if site.emitter && st.depth == 0 && self.hide_emitters {
            return None;
        }
        let (surface, shape_kind, bsdf) = (&site.surface, site.geometry, site.kernel);
        // By reference: a copy of the material cost 22 instructions a vertex.
        let material = &surface.material;
        let lit = bsdf != 2 && bsdf != 3;
        let m = if lit { setup.candidates } else { 1 };
        if lit && !setup.lit_in_lanes {
            return None;
        }
        let shape = &scene.shapes[hit.shape as usize];
        let reflectance = match *material {
            LaneMaterial::TexturedDiffuse => {
                let m = &scene.materials[scene.shape_info[hit.shape as usize].material as usize];
                let Material::Diffuse(d) = m else { return None };
                Some(&d.reflectance)
            }
            _ => None,
        };
        // The light: its kind and what its rows need.
        enum Picked<'a> {
            None,
            /// Resampled from `m` candidates (picked below into the
            /// batch's candidate rows, or by the kernel from the table).
            Candidates,
            Env,
            Sphere(Vec3, Vec3),
            Tri(&'a [Vec3; 3], f32, f32),
            /// Picked in the kernel from the scene's table (true: on a sphere).
            Table(bool),
        }
        // The numbers `vertex` draws, in its order; those this vertex never
        // reads are skipped, not computed (specular BSDFs sample no light, and
        // a lone light is picked without a number).
        let dim = rng.dim();
        let reads_sel = lit && setup.reads_sel;
        let u_sel = if reads_sel { rng.next_1d() } else { skipped_1d(rng) };
        let u_light = if lit { rng.next_2d() } else { skipped_2d(rng) };
        let u_pick = if lit && m > 1 { rng.next_1d() } else { 0.0 };
        // A block, not a closure: LLVM kept the closure out of line and
        // returned its tuple through memory.
        let light = 'pick: {
            if !lit {
                break 'pick Some((Picked::None, 0.0, Spectrum::ZERO, false));
            }
            if m > 1 {
                break 'pick Some((Picked::Candidates, 0.0, Spectrum::ZERO, false));
            }
            // The kernel picks from a table (uniformly, so never failing);
            // here only the light's kind is needed, which a table of one
            // kind gives without a pick.
            if let Some(sphere) = setup.table_kind {
                break 'pick Some((Picked::Table(sphere), 0.0, Spectrum::ZERO, false));
            }
            // Uniform and power selection ignore the receiver.
            let Some((i, pmf)) = scene.select_light(Vec3::ZERO, Vec3::ZERO, u_sel) else { break 'pick None };
            if let Some((_, e)) = env.filter(|&(e_index, _)| e_index == i) {
                // Its cell is found in lanes (EnvMapLight::sample_cell_lanes).
                if !e.samples() {
                    break 'pick None;
                }
                break 'pick Some((Picked::Env, pmf, Spectrum::ZERO, false));
            }
            let Some(&light) = scene.lane_light(i) else { break 'pick None };
            if table.is_some() {
                let sphere = matches!(light, LaneLight::Sphere { .. });
                break 'pick Some((Picked::Table(sphere), pmf, Spectrum::ZERO, false));
            }
            match light {
                LaneLight::Sphere { center, params, li, two_sided } => {
                    Some((Picked::Sphere(center, params), pmf, li, two_sided))
                }
                LaneLight::Mesh { first, count, area_pdf, li, two_sided } => {
                    // Mesh::pick_triangle's pick, on the light's own table.
                    let tris = scene.lane_light_tris(first, count);
                    let (t, ux) = alias_pick(u_light.x, tris.len(), |b| (tris[b].keep, tris[b].other));
                    Some((Picked::Tri(&tris[t].p, ux, area_pdf), pmf, li, two_sided))
                }
            }
        };
        let Some(light) = light else {
            rng.rewind(dim);
            return None;
        };
        let light_kind = match light.0 {
            Picked::Env => 1,
            Picked::Sphere(..) | Picked::Table(true) => 2,
            _ => 0,
        };
        let at = bins.of(LaneKind { shape: shape_kind, bsdf, light: light_kind });
        let b = &mut bins.batches[at];
        // The lane, found once (its rows are written below).
        let l = b.lane();
        b.set3(l, row::D, st.ray.d);
        b.set(l, row::B, hit.uv.x);
        b.set(l, row::B + 1, hit.uv.y);
        b.set3(l, row::BETA, st.beta);
        b.set(l, row::TWO_SIDED_BSDF, if surface.two_sided { 1.0 } else { 0.0 });
        match *material {
            LaneMaterial::Diffuse(r) => b.set3(l, row::MAT, r),
            LaneMaterial::TexturedDiffuse => {}
            LaneMaterial::RoughConductor { alpha_u, alpha_v, eta, k, specular_reflectance, .. } => {
                b.set3(l, row::MAT, eta);
                b.set3(l, row::MAT + 3, k);
                b.set3(l, row::MAT + 6, specular_reflectance);
                b.set(l, row::PARAM, alpha_u);
                b.set(l, row::PARAM_V, alpha_v);
            }
            LaneMaterial::Conductor { eta, k, specular_reflectance } => {
                b.set3(l, row::MAT, eta);
                b.set3(l, row::MAT + 3, k);
                b.set3(l, row::MAT + 6, specular_reflectance);
            }
            LaneMaterial::Dielectric { eta, specular_reflectance, specular_transmittance } => {
                b.set3(l, row::MAT, specular_reflectance);
                b.set3(l, row::MAT + 3, specular_transmittance);
                b.set(l, row::PARAM, eta);
            }
            LaneMaterial::RoughDielectric {
                alpha_u,
                alpha_v,
                eta,
                specular_reflectance,
                specular_transmittance,
                ..
            } => {
                b.set3(l, row::MAT, specular_reflectance);
                b.set3(l, row::MAT + 3, specular_transmittance);
                b.set(l, row::MAT + 6, eta);
                b.set(l, row::PARAM, alpha_u);
                b.set(l, row::PARAM_V, alpha_v);
            }
            LaneMaterial::Plastic { eta, diffuse, specular_reflectance, specular_sampling_weight } => {
                b.set3(l, row::MAT, diffuse);
                b.set3(l, row::MAT + 3, specular_reflectance);
                b.set(l, row::MAT + 6, specular_sampling_weight);
                b.set(l, row::PARAM, eta);
            }
            LaneMaterial::RoughPlastic {
                alpha_u,
                alpha_v,
                eta,
                diffuse,
                specular_reflectance,
                specular_sampling_weight,
                table,
                ..
            } => {
                b.set3(l, row::MAT, diffuse);
                b.set3(l, row::MAT + 3, specular_reflectance);
                b.set(l, row::MAT + 6, specular_sampling_weight);
                b.set(l, row::MAT + 7, eta);
                // Exact: there are far fewer than 2^24 tables.
                b.set(l, row::MAT + 8, table as f32);
                b.set(l, row::PARAM, alpha_u);
                b.set(l, row::PARAM_V, alpha_v);
            }
        }
        match shape {
            Shape::Mesh(m) | Shape::CulledMesh(m) => {
                let [p0, p1, p2] = m.vertices(hit.index as usize);
                b.set3(l, row::GEO, p0);
                b.set3(l, row::GEO + 3, p1);
                b.set3(l, row::GEO + 6, p2);
                if let Some(reflectance) = reflectance {
                    // The hit's uv as Shape::interaction_with finds it (barycentric without texture coordinates).
                    let (b1, b2) = (hit.uv.x, hit.uv.y);
                    let mut tex = Vec2::new(b1, b2);
                    if shape_kind == 3 || shape_kind == 6 {
                        let (u, t) = (&m.mesh.uvs, m.mesh.indices[hit.index as usize]);
                        let uvs = [u[t[0] as usize], u[t[1] as usize], u[t[2] as usize]];
                        for (k, uv) in uvs.iter().enumerate() {
                            b.set(l, row::UVS + 2 * k, uv.x);
                            b.set(l, row::UVS + 2 * k + 1, uv.y);
                        }
                        let b0 = 1.0 - b1 - b2;
                        tex = b0 * uvs[0] + b1 * uvs[1] + b2 * uvs[2];
                    }
                    b.set3(l, row::MAT, reflectance.eval(&SurfaceInteraction::at_uv(tex)));
                }
                if shape_kind >= 5 {
                    let (ns, t) = (&m.mesh.normals, m.mesh.indices[hit.index as usize]);
                    for (k, &i) in t.iter().enumerate() {
                        b.set3(l, row::NS + 3 * k, ns[i as usize]);
                    }
                }
            }
            Shape::Sphere(s) => {
                b.set3(l, row::GEO, s.center);
                b.set3(l, row::GEO + 3, s.rot.z_axis);
                b.set3(l, row::GEO + 6, st.ray.o);
                b.set(l, row::RADIUS, s.radius);
                b.set(l, row::B, hit.t);
                b.set(l, row::FLIP, if s.flip { 1.0 } else { 0.0 });
                if shape_kind == 4 {
                    b.set3(l, row::GEO + 9, s.rot.x_axis);
                    b.set3(l, row::GEO + 12, s.rot.y_axis);
                }
            }
            Shape::Disk(d) => {
                let m = &d.world_from_object;
                b.set3(l, row::GEO, m.x_axis.truncate());
                b.set3(l, row::GEO + 3, m.y_axis.truncate());
                b.set3(l, row::GEO + 6, m.z_axis.truncate());
                b.set3(l, row::GEO + 9, m.w_axis.truncate());
                b.set3(l, row::GEO + 12, d.n);
            }
            _ => unreachable!("the shape kind was found above"),
        }
        b.candidates = 1;
        b.table_picks = table.is_some();
        if let (Picked::Candidates, ..) = light {
            // `resample_light`'s candidates: picked by the kernel from the
            // scene's table, or here as `sample_light` picks each (a light
            // that has no lane kernel sends the vertex back).
            b.candidates = m;
            b.set(l, row::U_PICK, u_pick);
            if table.is_some() {
                b.set(l, row::U_SEL, u_sel);
                b.set(l, row::U_LIGHT, u_light.x);
                b.set(l, row::U_LIGHT + 1, u_light.y);
            } else {
                if b.cands.len() < m as usize {
                    b.cands.resize(m as usize, [[0.0; LaneBatch::LANES]; cand_row::COUNT]);
                }
                for i in 0..m {
                    let (u_i, u2_i) = super::candidate_numbers(u_sel, u_light, i, m);
                    let c = i as usize;
                    let cand = &mut b.cands[c];
                    let Some((k, pmf)) = scene.select_light(Vec3::ZERO, Vec3::ZERO, u_i) else {
                        put(cand, l, cand_row::KIND, 2.0);
                        continue;
                    };
                    let Some(&light) = scene.lane_light(k) else {
                        rng.rewind(dim);
                        return None;
                    };
                    put(cand, l, cand_row::PMF, pmf);
                    match light {
                        LaneLight::Sphere { center, params, li, two_sided } => {
                            put(cand, l, cand_row::KIND, 1.0);
                            put3(cand, l, cand_row::GEO, center);
                            put3(cand, l, cand_row::GEO + 3, params);
                            put3(cand, l, cand_row::LI, li);
                            put(cand, l, cand_row::TWO_SIDED, if two_sided { 1.0 } else { 0.0 });
                            put(cand, l, cand_row::U, u2_i.x);
                        }
                        LaneLight::Mesh { first, count, area_pdf, li, two_sided } => {
                            let tris = scene.lane_light_tris(first, count);
                            let (t, ux) = alias_pick(u2_i.x, tris.len(), |b| (tris[b].keep, tris[b].other));
                            let [q0, q1, q2] = tris[t].p;
                            put(cand, l, cand_row::KIND, 0.0);
                            put3(cand, l, cand_row::GEO, q0);
                            put3(cand, l, cand_row::GEO + 3, q1);
                            put3(cand, l, cand_row::GEO + 6, q2);
                            put(cand, l, cand_row::AREA_PDF, area_pdf);
                            put3(cand, l, cand_row::LI, li);
                            put(cand, l, cand_row::TWO_SIDED, if two_sided { 1.0 } else { 0.0 });
                            put(cand, l, cand_row::U, ux);
                        }
                    }
                    put(cand, l, cand_row::U + 1, u2_i.y);
                }
            }
        } else if let (Picked::Table(_), ..) = light {
            b.set(l, row::U_SEL, u_sel);
            b.set(l, row::U_LIGHT, u_light.x);
            b.set(l, row::U_LIGHT + 1, u_light.y);
        } else if lit {
            let (picked, pmf, li, two_sided) = light;
            b.set(l, row::PMF, pmf);
            b.set3(l, row::LI, li);
            b.set(l, row::TWO_SIDED, if two_sided { 1.0 } else { 0.0 });
            match picked {
                Picked::Env => {
                    b.set(l, row::U_LIGHT, u_light.x);
                    b.set(l, row::U_LIGHT + 1, u_light.y);
                }
                Picked::Sphere(center, params) => {
                    b.set3(l, row::LIGHT_TRI, center);
                    b.set3(l, row::LIGHT_TRI + 3, params);
                    b.set(l, row::U_LIGHT, u_light.x);
                    b.set(l, row::U_LIGHT + 1, u_light.y);
                }
                Picked::Tri(&[q0, q1, q2], ux, area_pdf) => {
                    b.set3(l, row::LIGHT_TRI, q0);
                    b.set3(l, row::LIGHT_TRI + 3, q1);
                    b.set3(l, row::LIGHT_TRI + 6, q2);
                    b.set(l, row::AREA_PDF, area_pdf);
                    b.set(l, row::U_LIGHT, ux);
                    b.set(l, row::U_LIGHT + 1, u_light.y);
                }
                Picked::None | Picked::Candidates | Picked::Table(_) => unreachable!("a lit vertex has its light"),
            }
        }
        // The BSDF's numbers: diffuse and rough conductors sample with the 2D
        // one alone, smooth dielectrics with the 1D one alone, smooth
        // conductors with neither; a guided vertex reads both.
        let guided = lit && guide.is_some() && !material.narrower_than(setup.guide_min_roughness);
        // By kernel ([`LaneMaterial::kernel`]).
        let (reads_u1, reads_u) = match bsdf {
            0 | 1 | 6 => (false, true),
            2 => (false, false),
            3 => (true, false),
            _ => (true, true),
        };
        let u1 = if reads_u1 || guided { rng.next_1d() } else { skipped_1d(rng) };
        let u = if reads_u || guided { rng.next_2d() } else { skipped_2d(rng) };
        b.set(l, row::U_BSDF, u.x);
        b.set(l, row::U_BSDF + 1, u.y);
        if guided {
            // `sample_guided`: the BSDF's direction with probability α
            // (its number rescaled), else the guide's (drawn in lanes,
            // where the hit's point and frame are).
            let alpha = self.guide_bsdf_fraction();
            let pick = u1 >= alpha;
            b.set(l, row::U_BSDF1, if pick { u1 } else { u1 / alpha });
            b.set(l, row::GUIDE_PICK, if pick { 1.0 } else { 0.0 });
            b.set(l, row::GUIDED, 1.0);
        } else {
            b.set(l, row::U_BSDF1, u1);
            if lit && guide.is_some() {
                b.set(l, row::GUIDE_PICK, 0.0);
                b.set(l, row::GUIDED, 0.0);
            }
        }
        if site.emitter {
            self.add_emitted(scene, st, &scene.interaction(&st.ray, hit));
        }
        // For `lane_vertex_done`'s `bounced`, as `vertex` sets it.
        st.on_carrier = site.carries_caustics;
        b.slots[l] = slot as u32;
        b.len += 1;
        Some(at)
    }

    /// Runs the vertices of `b` (at most `F::WIDTH`, all of one [`LaneKind`])
    /// at once; `out[l]` is lane `l`'s outcome. `env` as for
    /// [`Self::lane_vertex`].
    pub fn lane_vertices<F: Float>(
        &self,
        env: Option<&EnvMapLight>,
        tables: &[[f32; TRANSMITTANCE_RES]],
        lights: Option<&LaneLightTable>,
        guide: Option<&Guide>,
        b: &mut LaneBatch,
        out: &mut LaneOutcomes,
    ) {
        if b.is_empty() {
            return;
        }
        debug_assert!(b.len() <= F::WIDTH);
        b.pad::<F>();
        let (v, k) = (&*b, b.kind);
        macro_rules! lit_b {
            ($s:literal, $b:literal) => {
                match k.light {
                    0 => self.lit::<F, $s, 0, $b>(None, tables, lights, guide, v, out),
                    1 => self.lit::<F, $s, 1, $b>(env, tables, lights, guide, v, out),
                    _ => self.lit::<F, $s, 2, $b>(None, tables, lights, guide, v, out),
                }
            };
        }
        macro_rules! lit {
            ($s:literal) => {
                match k.bsdf {
                    0 => lit_b!($s, 0),
                    1 | 6 => lit_b!($s, 1),
                    4 => lit_b!($s, 2),
                    8 | 9 => lit_b!($s, 4),
                    _ => lit_b!($s, 3),
                }
            };
        }
        match (k.shape, k.bsdf) {
            (0, 0 | 1 | 4..) => lit!(0),
            (1, 0 | 1 | 4..) => lit!(1),
            (2, 0 | 1 | 4..) => lit!(2),
            (3, 0 | 1 | 4..) => lit!(3),
            (5, 0 | 1 | 4..) => lit!(5),
            // Textured meshes have diffuse materials only.
            (6, _) => lit_b!(6, 0),
            // Anisotropic rough conductors, dielectrics and plastics only.
            (_, 1 | 5..) => {
                let micro = |b| match b {
                    1 | 6 => 1,
                    8 | 9 => 4,
                    _ => 3,
                };
                match (k.light, micro(k.bsdf)) {
                    (0, 1) => self.lit::<F, 4, 0, 1>(None, tables, lights, guide, v, out),
                    (1, 1) => self.lit::<F, 4, 1, 1>(env, tables, lights, guide, v, out),
                    (_, 1) => self.lit::<F, 4, 2, 1>(None, tables, lights, guide, v, out),
                    (0, 4) => self.lit::<F, 4, 0, 4>(None, tables, lights, guide, v, out),
                    (1, 4) => self.lit::<F, 4, 1, 4>(env, tables, lights, guide, v, out),
                    (_, 4) => self.lit::<F, 4, 2, 4>(None, tables, lights, guide, v, out),
                    (0, _) => self.lit::<F, 4, 0, 3>(None, tables, lights, guide, v, out),
                    (1, _) => self.lit::<F, 4, 1, 3>(env, tables, lights, guide, v, out),
                    (_, _) => self.lit::<F, 4, 2, 3>(None, tables, lights, guide, v, out),
                }
            }
            (0, b) => specular::<F, 0>(b == 3, v, out),
            (1, b) => specular::<F, 1>(b == 3, v, out),
            (2, b) => specular::<F, 2>(b == 3, v, out),
            (5, b) => specular::<F, 5>(b == 3, v, out),
            (_, b) => specular::<F, 3>(b == 3, v, out),
        }
    }

    /// [`Self::lane_vertices`] for a vertex with light sampling on shape
    /// kind `S`, lit by light kind `L` (0: an area light on a mesh, 1: the
    /// environment map, 2: an area light on a sphere), with BSDF `B` (0:
    /// diffuse, 1: rough conductor, 2: plastic, 3: rough dielectric, 4:
    /// rough plastic, its transmittance tables in `tables`).
    // Not inlined: `lane_vertices` instantiates this for about 100 (shape,
    // light, BSDF) kinds per lane width, and inlined into one function they
    // made LLVM's loop unrolling spend most of a build (its dominator-tree
    // updates grow with the function's size). One call per batch costs nothing.
    #[inline(never)]
    fn lit<F: Float, const S: u8, const L: u8, const B: u8>(
        &self,
        env: Option<&EnvMapLight>,
        tables: &[[f32; TRANSMITTANCE_RES]],
        lights: Option<&LaneLightTable>,
        guide: Option<&Guide>,
        v: &LaneBatch,
        out: &mut LaneOutcomes,
    ) {
        let g = |r: usize| v.get::<F>(r);
        let gv = |r: usize| v.get3::<F>(r);
        let (zero, one) = (F::splat(0.0), F::splat(1.0));
        // The batch says whether its lights are picked here (its rows are
        // written for one way only); the caller passes the scene's table.
        let lights =
            v.table_picks.then(|| lights.expect("a batch prepared for the scene's light table runs without it"));
        let h = hit::<F, S>(v);
        let (p, n) = (h.p, h.n);
        // With a guide, each lane's density as `vertex_guided` finds it: the
        // quadtree of the point's spatial leaf, folded onto wo's side where
        // the BSDF only reflects (all but rough dielectrics), about the
        // normal of the frame `Material::bsdf` leaves (`h`'s: a two-sided
        // material's flipped below its normal).
        let guided = guide.map(|g| {
            let leaves = g.leaves_of(p);
            let fold = (B != 3).then(|| {
                let side = F::select(h.wo.z.cmp_lt(zero), -one, one);
                h.to_world(V3::new(zero, zero, side))
            });
            (g, leaves, g.lanes::<F>(&leaves, fold))
        });
        let density = || &guided.as_ref().expect("a guided lane without its guide").2;

        // A rough plastic's material and its transmittance at wo, shared by
        // its evaluation and its sample.
        let plastic = (B == 4).then(|| {
            let rp = LaneRoughPlastic::new(v, tables);
            let t_o = rp.transmittance(h.wo.z);
            (rp, t_o)
        });
        // The BSDF's value and density (Bsdf::eval_pdf), MIS-weighted.
        let eval_pdf = |wi_l: V3<F>| {
            if B == 0 {
                let front = h.wo.z.cmp_gt(zero) & wi_l.z.cmp_gt(zero);
                let f = V3::select(front, gv(row::MAT) * F::splat(INV_PI), V3::splat(Vec3::ZERO));
                (f, F::select(front, wi_l.z.max(zero) * F::splat(INV_PI), zero))
            } else if B == 2 {
                // Plastic::eval and Plastic::pdf.
                let eta = g(row::PARAM);
                let front = !h.wo.z.cmp_le(zero) & !wi_l.z.cmp_le(zero);
                let f_i = fresnel_dielectric(h.wo.z, eta).0;
                let f_o = fresnel_dielectric(wi_l.z, eta).0;
                let f = gv(row::MAT) * (F::splat(INV_PI) / (eta * eta) * (one - f_i) * (one - f_o));
                let pdf =
                    (one - plastic_specular_probability(f_i, g(row::MAT + 6))) * (wi_l.z.max(zero) * F::splat(INV_PI));
                (V3::select(front, f, V3::splat(Vec3::ZERO)), F::select(front, pdf, zero))
            } else if B == 3 {
                let micro = Micro::new(g(row::PARAM), g(row::PARAM_V), v.kind.beckmann());
                micro.dielectric_eval_pdf(h.wo, wi_l, g(row::MAT + 6), gv(row::MAT), gv(row::MAT + 3))
            } else if let Some((rp, t_o)) = &plastic {
                rp.eval_pdf(h.wo, wi_l, *t_o)
            } else {
                let micro = Micro::new(g(row::PARAM), g(row::PARAM_V), v.kind.beckmann());
                let (eta, k, spec) = (gv(row::MAT), gv(row::MAT + 3), gv(row::MAT + 6));
                micro.eval_pdf(h.wo, wi_l, eta, k, spec)
            }
        };
        // `light_value`: f cos θ towards the world direction `wi`, and the BSDF's density.
        let value = |wi: V3<F>| {
            let wi_l = h.to_local(wi);
            let (f, bsdf_pdf) = eval_pdf(wi_l);
            (f * wi_l.z.abs(), bsdf_pdf)
        };

        // The light sample, its selection included: (direction, distance,
        // density, radiance, whether there is one), f cos θ and the BSDF's
        // density there, and the estimate's scale (resampling's Σw / M / w_y).
        let (wi, dist, light_pdf, li, sampled, f, bsdf_pdf, scale) = if L == 1 {
            let env = env.expect("an environment vertex without the environment");
            let (x, cos_t, pdf_row) = env.sample_cell_lanes(g(row::U_LIGHT), g(row::U_LIGHT + 1));
            let (wi, pdf) = env.sample_direction(x, cos_t, pdf_row);
            let li = env.eval_lanes(wi.x, wi.y, wi.z);
            let (f, bsdf_pdf) = value(wi);
            (wi, F::splat(f32::INFINITY), pdf * g(row::PMF), li, F::Mask::splat(true), f, bsdf_pdf, one)
        } else if v.candidates > 1 {
            // `resample_light`: each candidate offered to a reservoir per lane
            // (`Reservoir::add`'s operations), the pick's values kept.
            const ONE_MINUS_EPS: f32 = crate::sampling::reservoir::ONE_MINUS_EPSILON;
            let m = v.candidates as usize;
            let mut u = g(row::U_PICK);
            let (mut sum, mut w_y) = (zero, zero);
            let mut picked = F::Mask::splat(false);
            let v0 = V3::splat(Vec3::ZERO);
            let (mut y_wi, mut y_dist, mut y_pdf, mut y_li, mut y_f, mut y_bsdf_pdf) = (v0, zero, zero, v0, v0, zero);
            for c in 0..m {
                let (tri, sphere, (wi, dist, pdf, sampled), li) = match lights {
                    // The candidate's light and triangle picked here, as
                    // `lane_vertex` picks them otherwise.
                    Some(t) => {
                        let (u_i, u2x, u2y) = super::candidate_numbers_lanes(
                            g(row::U_SEL),
                            (g(row::U_LIGHT), g(row::U_LIGHT + 1)),
                            c as u32,
                            m as u32,
                        );
                        let (k, pmf) = t.select_uniform(u_i);
                        let pick = t.pick(k, (u2x, u2y), t.kinds());
                        let sphere = pick.sphere;
                        let kinds = ((!sphere).any(), sphere.any());
                        let sample =
                            area_light_sample(p, pick.geo, pick.area_pdf, pick.u, pmf, pick.two_sided, sphere, kinds);
                        (!sphere, sphere, sample, pick.li)
                    }
                    None => {
                        let kind = v.cand::<F>(c, cand_row::KIND);
                        let (tri, sphere) = (kind.cmp_eq(zero), kind.cmp_eq(one));
                        let geo =
                            [v.cand3(c, cand_row::GEO), v.cand3(c, cand_row::GEO + 3), v.cand3(c, cand_row::GEO + 6)];
                        let sample = area_light_sample(
                            p,
                            geo,
                            v.cand(c, cand_row::AREA_PDF),
                            (v.cand(c, cand_row::U), v.cand(c, cand_row::U + 1)),
                            v.cand(c, cand_row::PMF),
                            v.cand::<F>(c, cand_row::TWO_SIDED).cmp_eq(one),
                            sphere,
                            (tri.any(), sphere.any()),
                        );
                        (tri, sphere, sample, v.cand3::<F>(c, cand_row::LI))
                    }
                };
                let (f, bsdf_pdf) = value(wi);
                let contribution = f.mul_elem(li);
                let target = contribution.x.abs() + contribution.y.abs() + contribution.z.abs();
                let w = target / pdf;
                let offered = (tri | sphere) & sampled & f.ne_zero() & w.cmp_gt(zero) & finite(w);
                let s = sum + w;
                let q = w / s;
                let take = offered & u.cmp_lt(q);
                let u_next = F::select(take, u / q, (u - q) / (one - q)).min(F::splat(ONE_MINUS_EPS));
                u = F::select(offered, u_next, u);
                sum = F::select(offered, s, sum);
                w_y = F::select(take, w, w_y);
                y_wi = V3::select(take, wi, y_wi);
                y_dist = F::select(take, dist, y_dist);
                y_pdf = F::select(take, pdf, y_pdf);
                y_li = V3::select(take, li, y_li);
                y_f = V3::select(take, f, y_f);
                y_bsdf_pdf = F::select(take, bsdf_pdf, y_bsdf_pdf);
                picked = picked | take;
            }
            let scale = sum / F::splat(m as f32) / w_y;
            (y_wi, y_dist, y_pdf, y_li, picked, y_f, y_bsdf_pdf, scale)
        } else if let Some(t) = lights {
            // The light and its triangle picked here, as `lane_vertex`
            // picks them otherwise (the batch's light kind is the pick's).
            let kinds = (L == 0, L == 2);
            let (k, pmf) = t.select_uniform(g(row::U_SEL));
            let pick = t.pick(k, (g(row::U_LIGHT), g(row::U_LIGHT + 1)), kinds);
            let (wi, dist, pdf, sampled) =
                area_light_sample(p, pick.geo, pick.area_pdf, pick.u, pmf, pick.two_sided, pick.sphere, kinds);
            let (f, bsdf_pdf) = value(wi);
            (wi, dist, pdf, pick.li, sampled, f, bsdf_pdf, one)
        } else {
            let geo = [gv(row::LIGHT_TRI), gv(row::LIGHT_TRI + 3), gv(row::LIGHT_TRI + 6)];
            let (wi, dist, pdf, sampled) = area_light_sample(
                p,
                geo,
                g(row::AREA_PDF),
                (g(row::U_LIGHT), g(row::U_LIGHT + 1)),
                g(row::PMF),
                v.mask::<F>(row::TWO_SIDED),
                F::Mask::splat(L == 2),
                (L == 0, L == 2),
            );
            let (f, bsdf_pdf) = value(wi);
            (wi, dist, pdf, gv(row::LI), sampled, f, bsdf_pdf, one)
        };
        let contributes = sampled & f.ne_zero();
        // With a guide, the density of the direction is the mix of the
        // BSDF's and the guide's (`vertex_guided`); the guide's is looked up
        // per lane, where the sample contributes.
        // Lanes whose lobe is too narrow for the guide sample as without one.
        let alpha = self.guide_bsdf_fraction();
        let guide_pdf = |d: V3<F>, need: F::Mask| density().pdf(d, need);
        let guided_lanes = match guide {
            Some(_) => v.mask::<F>(row::GUIDED),
            None => F::Mask::splat(false),
        };
        let bsdf_pdf = match guide {
            Some(_) => F::select(
                guided_lanes,
                F::splat(alpha) * bsdf_pdf + F::splat(1.0 - alpha) * guide_pdf(wi, contributes & guided_lanes),
                bsdf_pdf,
            ),
            None => bsdf_pdf,
        };
        let w = if self.mis { power_heuristic(light_pdf, bsdf_pdf) } else { one };
        // Without resampling the scale is 1, which leaves the product's bits as they are.
        let pending = gv(row::BETA).mul_elem(f).mul_elem(li) * (w / light_pdf * scale);
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
        let (u0, u1) = (g(row::U_BSDF), g(row::U_BSDF + 1));
        let mut delta = F::Mask::splat(false);
        let mut eta_next = one;
        let (wi_next, bsdf_pdf, weight, go) = if B == 0 {
            // Diffuse::sample: sample_cosine_hemisphere.
            let (dx, dy) = concentric_disk(u0, u1);
            let dz = (one - (dx * dx + dy * dy)).max(zero).sqrt();
            let bsdf_pdf = dz.max(zero) * F::splat(INV_PI);
            let go = !h.wo.z.cmp_le(zero) & !bsdf_pdf.cmp_le(zero);
            (V3::new(dx, dy, dz), bsdf_pdf, gv(row::MAT), go)
        } else if B == 2 {
            // Plastic::sample: the mirror with probability p_spec, else cosine-weighted.
            let eta = g(row::PARAM);
            let f_i = fresnel_dielectric(h.wo.z, eta).0;
            let p_spec = plastic_specular_probability(f_i, g(row::MAT + 6));
            delta = g(row::U_BSDF1).cmp_lt(p_spec);
            let (dx, dy) = concentric_disk(u0, u1);
            let dz = (one - (dx * dx + dy * dy)).max(zero).sqrt();
            let pdf_d = (one - p_spec) * (dz.max(zero) * F::splat(INV_PI));
            let f_o = fresnel_dielectric(dz, eta).0;
            let weight_d = gv(row::MAT) * ((one - f_i) * (one - f_o) / (eta * eta * (one - p_spec)));
            let weight_s = gv(row::MAT + 3) * (f_i / p_spec);
            let wi = V3::select(delta, V3::new(-h.wo.x, -h.wo.y, h.wo.z), V3::new(dx, dy, dz));
            let go = !h.wo.z.cmp_le(zero) & (delta | !pdf_d.cmp_le(zero));
            (wi, F::select(delta, p_spec, pdf_d), V3::select(delta, weight_s, weight_d), go)
        } else if let Some((rp, t_o)) = &plastic {
            rp.sample(h.wo, *t_o, g(row::U_BSDF1), u0, u1)
        } else if B == 3 {
            let micro = Micro::new(g(row::PARAM), g(row::PARAM_V), v.kind.beckmann());
            let (wi, pdf, weight, eta, go) =
                micro.dielectric_sample(h.wo, g(row::U_BSDF1), u0, u1, g(row::MAT + 6), gv(row::MAT), gv(row::MAT + 3));
            eta_next = eta;
            (wi, pdf, weight, go)
        } else {
            let micro = Micro::new(g(row::PARAM), g(row::PARAM_V), v.kind.beckmann());
            let (eta, k, spec) = (gv(row::MAT), gv(row::MAT + 3), gv(row::MAT + 6));
            micro.sample(h.wo, u0, u1, eta, k, spec)
        };
        // With a guide (`sample_guided`): the guide's direction where it was
        // picked; either way (a specular lobe aside) the value and the mixed
        // density at the direction, and a failed sample ends the path.
        let (wi_next, bsdf_pdf, weight, go, delta, eta_next, guide_next) = match guide {
            None => (wi_next, bsdf_pdf, weight, go, delta, eta_next, zero),
            Some(_) => {
                let pick = v.mask::<F>(row::GUIDE_PICK);
                // The guide's direction (world) and density where it was picked.
                let (drawn, drawn_pdf) = density().sample(g(row::U_BSDF), g(row::U_BSDF + 1), pick);
                let specular = !pick & delta;
                let wi = V3::select(pick, h.to_local(drawn), wi_next);
                let (f, pdf_bsdf) = eval_pdf(wi);
                let need = !pick & !delta & go & guided_lanes;
                let pdf_guide = F::select(pick, drawn_pdf, guide_pdf(h.to_world(wi_next), need));
                let pdf = F::splat(alpha) * pdf_bsdf + F::splat(1.0 - alpha) * pdf_guide;
                let f = f * wi.z.abs();
                let ok = !(pdf.cmp_ne(pdf) | pdf.cmp_le(zero)) & f.ne_zero();
                let gl = guided_lanes;
                (
                    V3::select(gl & !specular, wi, wi_next),
                    F::select(gl, F::select(specular, bsdf_pdf * F::splat(alpha), pdf), bsdf_pdf),
                    V3::select(gl, V3::select(specular, weight / F::splat(alpha), f / pdf), weight),
                    (gl & ((pick & ok) | (!pick & go & (delta | ok)))) | (!gl & go),
                    (gl & specular) | (!gl & delta),
                    F::select(gl & pick, one, eta_next),
                    F::select(gl & !specular, pdf_guide, zero),
                )
            }
        };
        let wi_next = h.to_world(wi_next);
        out.shadow = contributes.bitmask();
        out.put3(out_row::PENDING, pending);
        out.put3(out_row::SHADOW_O, o);
        out.put3(out_row::SHADOW_D, shadow_d);
        out.put(out_row::SHADOW_T, shadow_t);
        next_rays(&h, wi_next, bsdf_pdf, go, weight, eta_next, delta, out);
        out.put(out_row::GUIDE_PDF, guide_next);
        if let Some((g, leaves, _)) = &guided {
            out.put(out_row::GUIDE_FLUX, simd::gather::<F>(|l| g.leaf(leaves[l]).flux()));
        }
    }

    /// The rest of lane `l`'s vertex of a batch, one path at a time: its
    /// outcome applied to `st` and Russian roulette, as at the end of
    /// [`Self::vertex`]: whether there is a shadow ray
    /// ([`LaneOutcomes::shadow_ray`], [`Vertex::shadow`]) and whether the
    /// path goes on.
    ///
    /// [`Vertex::shadow`]: super::Vertex::shadow
    #[inline]
    pub fn lane_vertex_done(
        &self,
        st: &mut PathState,
        out: &LaneOutcomes,
        l: usize,
        rng: &mut SampleStream,
    ) -> (bool, bool) {
        use out_row::*;
        let shadow = out.shadow >> l & 1 != 0;
        if shadow {
            st.pending = out.at3(PENDING, l);
        }
        if out.go >> l & 1 == 0 {
            return (shadow, false);
        }
        st.beta *= out.at3(WEIGHT, l);
        st.eta *= out.at(ETA, l);
        st.prev_p = out.at3(P, l);
        st.prev_n = out.at3(N, l);
        st.prev_bsdf_pdf = out.at(PDF, l);
        st.prev_delta = out.delta >> l & 1 != 0;
        st.ray = Ray::new(out.at3(O, l), out.at3(WI, l), f32::INFINITY);
        st.bounced(st.prev_delta);
        st.depth += 1;
        let guide_pdf = out.at(GUIDE_PDF, l);
        if guide_pdf > 0.0 {
            st.flux = out.at(GUIDE_FLUX, l);
        }
        (shadow, self.roulette(st, rng, guide_pdf))
    }
}

/// The hit of lane vertices on shape kind `S` (0: a mesh, 1: a sphere, 2: a
/// disk): point, normal and dp/du as `Shape::interaction_with` finds them
/// without the uv parameterisation, and the frame of `frame_from_dpdu`.
#[inline(always)]
fn hit<F: Float, const S: u8>(v: &LaneBatch) -> LaneHit<F> {
    let g = |r: usize| v.get::<F>(r);
    let gv = |r: usize| v.get3::<F>(r);
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let wo = -gv(row::D).normalize();
    let (p, n, dpdu) = match S {
        0 | 3 | 5 | 6 => {
            let (p0, p1, p2) = (gv(row::GEO), gv(row::GEO + 3), gv(row::GEO + 6));
            let (b1, b2) = (g(row::B), g(row::B + 1));
            let b0 = one - b1 - b2;
            let p = p0 * b0 + p1 * b1 + p2 * b2;
            let (dp0, dp1) = (p1 - p0, p2 - p0);
            let n = dp0.cross(dp1).normalize();
            if S == 0 || S == 5 {
                (p, n, dp0)
            } else {
                // dp/du from the texture coordinates; Mitsuba's arbitrary
                // basis where they are degenerate.
                let uv = |k: usize| (g(row::UVS + 2 * k), g(row::UVS + 2 * k + 1));
                let (uv0, uv1, uv2) = (uv(0), uv(1), uv(2));
                let (duv0, duv1) = ((uv1.0 - uv0.0, uv1.1 - uv0.1), (uv2.0 - uv0.0, uv2.1 - uv0.1));
                let det = duv0.0 * duv1.1 - duv0.1 * duv1.0;
                let inv = one / det;
                let dpdu = (dp0 * duv1.1 - dp1 * duv0.1) * inv;
                let (fs, _) = frame_from_normal(n);
                (p, n, V3::select(det.cmp_ne(zero), dpdu, fs))
            }
        }
        1 | 4 => {
            // Sphere::interaction: the point re-projected onto the surface.
            let (c, z_axis, o) = (gv(row::GEO), gv(row::GEO + 3), gv(row::GEO + 6));
            let at_t = o + gv(row::D) * g(row::B);
            let n = (at_t - c).normalize();
            let p = c + n * g(row::RADIUS);
            let dpdu = if S == 4 {
                // With the uv parameterisation: l = rotᵀ n, dp/du = rot (−l.y, l.x, 0) · 2π r.
                let (x_axis, y_axis) = (gv(row::GEO + 9), gv(row::GEO + 12));
                let (lx, ly) = (x_axis.dot(n), y_axis.dot(n));
                let w = x_axis * -ly + y_axis * lx + z_axis * zero;
                w * (g(row::RADIUS) * F::splat(2.0) * F::splat(PI))
            } else {
                z_axis.cross(n)
            };
            (p, V3::select(v.mask::<F>(row::FLIP), -n, n), dpdu)
        }
        _ => {
            // Disk::interaction: the local (x, y) placed.
            let c = [gv(row::GEO), gv(row::GEO + 3), gv(row::GEO + 6), gv(row::GEO + 9)];
            let (x, y) = (g(row::B), g(row::B + 1));
            (transform_xy0(c, x, y, true), gv(row::GEO + 12), transform_xy0(c, x, y, false))
        }
    };
    // The shading normal: a smooth mesh's vertex normals interpolated
    // where they do not cancel (Shape::interaction_with), else n.
    let sn = if S >= 5 {
        let (b1, b2) = (g(row::B), g(row::B + 1));
        let b0 = one - b1 - b2;
        let s = gv(row::NS) * b0 + gv(row::NS + 3) * b1 + gv(row::NS + 6) * b2;
        V3::select(s.dot(s).cmp_gt(zero), s.normalize(), n)
    } else {
        n
    };
    // The shading frame (frame_from_dpdu).
    let s = dpdu - sn * sn.dot(dpdu);
    let len2 = s.dot(s);
    let s = s / len2.sqrt();
    let (fs, ft) = frame_from_normal(sn);
    let dpdu_ok = len2.cmp_gt(zero) & finite(len2);
    let (fs, ft) = (V3::select(dpdu_ok, s, fs), V3::select(dpdu_ok, sn.cross(s), ft));
    let mut h = LaneHit { p, n, fs, ft, sn, wo };
    h.wo = h.to_local(wo);
    // Seen from below, a two-sided material is shaded in the frame whose
    // normal is negated (Material::bsdf): wo's z and the normal flip, exactly.
    let below = v.mask::<F>(row::TWO_SIDED_BSDF) & h.wo.z.cmp_lt(zero);
    h.sn = V3::select(below, -h.sn, h.sn);
    h.wo.z = F::select(below, -h.wo.z, h.wo.z);
    h
}

/// Lane vertices with a smooth conductor (`dielectric` false) or
/// dielectric on shape kind `S`: `Conductor::sample` or
/// `Dielectric::sample` and the next ray; no light sample.
#[inline(never)] // As `lit`: its own function, not part of `lane_vertices`.
fn specular<F: Float, const S: u8>(dielectric: bool, v: &LaneBatch, out: &mut LaneOutcomes) {
    let g = |r: usize| v.get::<F>(r);
    let gv = |r: usize| v.get3::<F>(r);
    let (zero, one) = (F::splat(0.0), F::splat(1.0));
    let h = hit::<F, S>(v);
    let wo = h.wo;
    let reflected = V3::new(-wo.x, -wo.y, wo.z);
    out.shadow = 0;
    if !dielectric {
        let (eta, k) = (gv(row::MAT), gv(row::MAT + 3));
        let f = V3::new(
            fresnel_conductor(wo.z, eta.x, k.x),
            fresnel_conductor(wo.z, eta.y, k.y),
            fresnel_conductor(wo.z, eta.z, k.z),
        );
        let weight = gv(row::MAT + 6).mul_elem(f);
        let go = !wo.z.cmp_le(zero);
        next_rays(&h, h.to_world(reflected), one, go, weight, one, F::Mask::splat(true), out);
        return;
    }
    let (r, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.z, g(row::PARAM));
    let reflect = g(row::U_BSDF1).cmp_le(r);
    let refracted = V3::new(-eta_ti * wo.x, -eta_ti * wo.y, cos_t);
    let wi = V3::select(reflect, reflected, refracted);
    let pdf = F::select(reflect, r, one - r);
    let t = gv(row::MAT + 3) * (eta_ti * eta_ti);
    let weight = V3::select(reflect, gv(row::MAT), t);
    let eta = F::select(reflect, one, eta_it);
    next_rays(&h, h.to_world(wi), pdf, F::Mask::splat(true), weight, eta, F::Mask::splat(true), out);
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
    weight: V3<F>,
    eta: F,
    delta: F::Mask,
    out: &mut LaneOutcomes,
) {
    let o = offset_origin(h.p, h.n, wi);
    (out.go, out.delta) = (go.bitmask(), delta.bitmask());
    out.put3(out_row::O, o);
    out.put3(out_row::WI, wi);
    out.put3(out_row::P, h.p);
    out.put3(out_row::N, h.n);
    out.put(out_row::PDF, pdf);
    out.put3(out_row::WEIGHT, weight);
    out.put(out_row::ETA, eta);
    out.put(out_row::GUIDE_PDF, F::splat(0.0));
}
