//! Mitsuba `aov`: arbitrary output variables of the surface each camera ray
//! sees, beside the images of nested integrators (not to be confused with
//! the `--aov` layers of [`super::aov`], which any integrator can add).
//!
//! | parameter        | type       | default  |
//! |------------------|------------|----------|
//! | aovs             | string     | (required) comma-separated `<name>:<type>` pairs |
//! | (nested)         | integrator | none; each one's image comes first, named by the nested tag's `name` (`_arg_N` when unnamed) |
//!
//! Output channels, in Mitsuba 3.9.1's order: for each nested integrator
//! `NAME`, `NAME.R`, `NAME.G`, `NAME.B`, `NAME.A` and then its own output
//! channels as `NAME.<channel>`; then the AOVs, each `<name>.<suffix>`:
//!
//! | type          | channels    | value at the first hit (0 where the ray escapes) |
//! |---------------|-------------|-------|
//! | `albedo`      | R, G, B     | the material's diffuse reflectance (Mitsuba's `eval_diffuse_reflectance`, see [`Material::diffuse_reflectance`](crate::material::Material::diffuse_reflectance)) |
//! | `depth`       | T           | distance along the camera ray (which starts on the near clip plane) |
//! | `position`    | X, Y, Z     | world-space position |
//! | `uv`          | U, V        | surface coordinates |
//! | `geo_normal`  | X, Y, Z     | geometric normal |
//! | `sh_normal`   | X, Y, Z     | shading normal (perturbed by a top-level `normalmap`/`bumpmap`) |
//! | `dp_du`, `dp_dv` | X, Y, Z  | position derivatives with respect to u and v |
//! | `duv_dx`, `duv_dy` | U, V   | uv derivatives per pixel in x and y (ray differentials scaled by 1/√spp, as Mitsuba's) |
//! | `prim_index`  | I           | triangle index within its mesh (0 for spheres, disks, cylinders; a `rectangle`'s as Mitsuba splits it) |
//! | `shape_index` | I           | 1 + the shape's index in the scene, in file order (Mitsuba numbers shapes its own way: the scalar variants by its scene's shape list, the JIT ones by registry id; the partition of the image agrees) |
//!
//! The beauty image is the first nested integrator's (black without one).
//! Each nested integrator takes the camera sample's random numbers as if it
//! rendered alone (Mitsuba renders each with the same seed), so its image
//! is bitwise the one it gives by itself. `NAME.A` is Mitsuba's alpha: 1
//! where the camera ray finds a surface that is not a pure pass-through
//! (`null`, `mask`, `thindielectric` are looked through), or, unless
//! `hide_emitters`, where an environment emitter lies behind it.

use super::{Integrator, RayDiff, RayStats};
use crate::geometry::{Ray, SurfaceInteraction};
use crate::material::{Material, Scratch};
use crate::math::Spectrum;
use crate::sampling::SampleStream;
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// One AOV type of Mitsuba's `aov` integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AovType {
    /// `albedo`: diffuse reflectance (R, G, B).
    Albedo,
    /// `depth`: ray distance (T).
    Depth,
    /// `position`: world position (X, Y, Z).
    Position,
    /// `uv`: surface coordinates (U, V).
    Uv,
    /// `geo_normal`: geometric normal (X, Y, Z).
    GeoNormal,
    /// `sh_normal`: shading normal (X, Y, Z).
    ShNormal,
    /// `dp_du` (X, Y, Z).
    DpDu,
    /// `dp_dv` (X, Y, Z).
    DpDv,
    /// `duv_dx` (U, V).
    DuvDx,
    /// `duv_dy` (U, V).
    DuvDy,
    /// `prim_index` (I).
    PrimIndex,
    /// `shape_index` (I).
    ShapeIndex,
}

impl AovType {
    /// Every type with its Mitsuba name.
    pub const ALL: [(&'static str, AovType); 12] = [
        ("albedo", AovType::Albedo),
        ("depth", AovType::Depth),
        ("position", AovType::Position),
        ("uv", AovType::Uv),
        ("geo_normal", AovType::GeoNormal),
        ("sh_normal", AovType::ShNormal),
        ("dp_du", AovType::DpDu),
        ("dp_dv", AovType::DpDv),
        ("duv_dx", AovType::DuvDx),
        ("duv_dy", AovType::DuvDy),
        ("prim_index", AovType::PrimIndex),
        ("shape_index", AovType::ShapeIndex),
    ];

    /// The type Mitsuba calls `name`.
    pub fn from_name(name: &str) -> Option<AovType> {
        AovType::ALL.iter().find(|(n, _)| *n == name).map(|&(_, t)| t)
    }

    /// The channel suffixes, in order.
    pub fn suffixes(self) -> &'static [&'static str] {
        match self {
            AovType::Albedo => &["R", "G", "B"],
            AovType::Depth => &["T"],
            AovType::Position | AovType::GeoNormal | AovType::ShNormal | AovType::DpDu | AovType::DpDv => {
                &["X", "Y", "Z"]
            }
            AovType::Uv | AovType::DuvDx | AovType::DuvDy => &["U", "V"],
            AovType::PrimIndex | AovType::ShapeIndex => &["I"],
        }
    }
}

/// The `aov` integrator: nested integrators and AOVs.
#[derive(Debug, Clone, Default)]
pub struct AovIntegrator {
    /// Nested integrators with their names, in document order.
    pub integrators: Vec<(String, Integrator)>,
    /// The AOVs: name and type, in the order of the `aovs` string.
    pub aovs: Vec<(String, AovType)>,
}

impl AovIntegrator {
    /// The output channels (Mitsuba's `aov_names()`).
    pub fn channel_names(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (name, integrator) in &self.integrators {
            for c in ["R", "G", "B", "A"] {
                out.push(format!("{name}.{c}"));
            }
            out.extend(integrator.channel_names().into_iter().map(|c| format!("{name}.{c}")));
        }
        for (name, t) in &self.aovs {
            out.extend(t.suffixes().iter().map(|s| format!("{name}.{s}")));
        }
        out
    }

    /// The beauty of camera ray `ray` and its channels written to `out`
    /// (`channel_names().len()` values).
    #[allow(clippy::too_many_arguments)]
    pub fn sample(
        &self,
        scene: &Scene,
        ray: &Ray,
        diff: Option<&RayDiff>,
        rng: &mut SampleStream,
        stats: &mut RayStats,
        scratch: &Scratch,
        out: &mut [f32],
    ) -> Spectrum {
        let mut beauty = Spectrum::ZERO;
        let mut at = 0;
        for (i, (_, integrator)) in self.integrators.iter().enumerate() {
            // The random numbers it would take rendering alone.
            let mut own = rng.clone();
            let n = integrator.channel_names().len();
            let (rgba, rest) = out[at..].split_at_mut(4);
            let l = integrator.sample(scene, ray, diff, &mut own, stats, scratch, &mut rest[..n]);
            rgba.copy_from_slice(&[l.x, l.y, l.z, integrator.alpha(scene, ray, stats)]);
            if i == 0 {
                beauty = l;
            }
            at += 4 + n;
        }
        if self.aovs.is_empty() {
            return beauty;
        }
        stats.rays += 1;
        let si = scene.intersect_full(ray);
        for (_, t) in &self.aovs {
            let v = si.as_ref().map_or([0.0; 3], |si| value(scene, *t, si, ray, diff, scratch));
            let n = t.suffixes().len();
            out[at..at + n].copy_from_slice(&v[..n]);
            at += n;
        }
        beauty
    }
}

/// The value of AOV type `t` at hit `si` of `ray` (the first channels of the result).
fn value(
    scene: &Scene,
    t: AovType,
    si: &SurfaceInteraction,
    ray: &Ray,
    diff: Option<&RayDiff>,
    scratch: &Scratch,
) -> [f32; 3] {
    let material = || -> &Material { &scene.materials[scene.shape_info[si.shape as usize].material as usize] };
    match t {
        AovType::Albedo => material().diffuse_reflectance(si, scratch).to_array(),
        AovType::Depth => [si.t, 0.0, 0.0],
        AovType::Position => si.p.to_array(),
        AovType::Uv => [si.uv.x, si.uv.y, 0.0],
        AovType::GeoNormal => si.n.to_array(),
        AovType::ShNormal => material().sh_frame(si).n.to_array(),
        AovType::DpDu => si.dpdu.to_array(),
        AovType::DpDv => si.dpdv.to_array(),
        AovType::DuvDx | AovType::DuvDy => {
            let (dx, dy) = diff.map_or((Vec2::ZERO, Vec2::ZERO), |d| uv_partials(si, ray, d));
            let v = if t == AovType::DuvDx { dx } else { dy };
            [v.x, v.y, 0.0]
        }
        AovType::PrimIndex => {
            let rect = matches!(&scene.shapes[si.shape as usize], crate::geometry::Shape::Mesh(m) if m.rectangle);
            let prim = if rect { (si.uv.x + si.uv.y > 1.0) as u32 } else { si.prim };
            [prim as f32, 0.0, 0.0]
        }
        AovType::ShapeIndex => [(si.shape + 1) as f32, 0.0, 0.0],
    }
}

/// Mitsuba's `SurfaceInteraction::compute_uv_partials`: the offset rays
/// meet the tangent plane, and the position offsets are turned into uv ones
/// by least squares on dp/du, dp/dv (zero where those are degenerate).
fn uv_partials(si: &SurfaceInteraction, _ray: &Ray, d: &RayDiff) -> (Vec2, Vec2) {
    let n = si.n;
    let dn = n.dot(si.p);
    let t_x = (dn - n.dot(d.o_x)) / n.dot(d.d_x);
    let t_y = (dn - n.dot(d.o_y)) / n.dot(d.d_y);
    let dp_dx = d.d_x * t_x - (si.p - d.o_x);
    let dp_dy = d.d_y * t_y - (si.p - d.o_y);
    let (a00, a01, a11) = (si.dpdu.dot(si.dpdu), si.dpdu.dot(si.dpdv), si.dpdv.dot(si.dpdv));
    let inv_det = 1.0 / (a00 * a11 - a01 * a01);
    let inv_det = if inv_det.is_finite() { inv_det } else { 0.0 };
    let solve = |dp: Vec3| {
        let (b0, b1) = (si.dpdu.dot(dp), si.dpdv.dot(dp));
        Vec2::new(a11 * b0 - a01 * b1, a00 * b1 - a01 * b0) * inv_det
    };
    (solve(dp_dx), solve(dp_dy))
}
