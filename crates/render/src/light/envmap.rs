//! Mitsuba `envmap`: radiance at infinity from a latitude-longitude image.
//!
//! | parameter | type      | default  |
//! |-----------|-----------|----------|
//! | filename  | string    | —        |
//! | scale     | float     | 1        |
//! | to_world  | transform | identity |
//!
//! Mapping, as Mitsuba 3.9.1 (`src/emitters/envmap.cpp`): a light-space
//! direction d has u = atan2(d.x, -d.z) / 2π and v = acos(d.y) / π. Texel
//! (row i, column j) of a W × H map sits at u = (j + ½) / W, v = i / (H - 1),
//! i.e. at θ = πi / (H - 1), φ = 2π(j + ½) / W, direction
//! (sin φ sin θ, cos θ, -cos φ sin θ): row 0 is the +y zenith, the last row
//! the nadir. Radiance is the bilinear interpolation of the four surrounding
//! texels, periodic in u and clamped in v, times `scale`. World directions
//! reach light space through the inverse of `to_world`, without
//! renormalising (as Mitsuba; this only matters for a non-rigid `to_world`).
//! Maps smaller than 2 × 3 are padded by repeating the last column / row.
//!
//! Sampling: a cell is picked from the W × (H - 1) cells between texel
//! centres (Mitsuba's warp grid) with probability proportional to its power,
//! the exact integral of the bilinear luminance over its solid angle; then a
//! direction uniform in (φ, cos θ) within the cell, so the solid-angle density
//! is constant per cell: p_ω = p_uv / (2π (H - 1) (cos θ_r - cos θ_r+1)),
//! with p_uv the cell's density on the unit square. (Mitsuba places the
//! direction uniformly in (u, v), for p_ω = p_uv / (2π² sin θ), which is
//! unbounded at the poles; its bilinear warp cancels that there, a
//! piecewise-constant one would not.)

use super::LightSample;
use crate::math::{fast, luminance, Mat3, Mat4, Spectrum, INV_2PI, INV_PI, PI};
use crate::sampling::distrib2d::index_lanes;
use crate::sampling::Distribution2D;
use crate::simd::{self, Float, Int as _, V3};
use glam::{Vec2, Vec3};

/// Mitsuba's `envmap` emitter (mapping and sampling in the module docs).
#[derive(Debug, Clone)]
pub struct EnvMapLight {
    width: usize,
    height: usize,
    /// Linear RGB, row-major, row 0 = zenith (after padding to at least 2 × 3).
    texels: Vec<Spectrum>,
    world_from_light: Mat3,
    light_from_world: Mat3,
    /// |det world_from_light|, for the solid-angle Jacobian of a non-rigid `to_world`.
    abs_det: f32,
    scale: f32,
    /// Over the cells in (u - ½/W, v); `None` for a black map.
    distribution: Option<Distribution2D>,
    /// cos θ of the H texel rows (the cell rows' edges).
    cos_theta: Vec<f32>,
    /// 1 / (2π (H - 1) (cos θ_r - cos θ_r+1)) per cell row: p_ω / p_uv.
    inv_row_solid_angle: Vec<f32>,
    mean: Spectrum,
}

impl EnvMapLight {
    /// `texels`: linear RGB, row-major, top row first (row 0 = +Y zenith).
    /// `world_from_light`: Mitsuba `to_world` (its translation is ignored).
    /// `scale`: Mitsuba `scale`.
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<[f32; 3]>,
        world_from_light: Mat4,
        scale: f32,
    ) -> Result<EnvMapLight, String> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return Err(format!("environment map: {} texels do not make a {width} x {height} image", texels.len()));
        }
        let bad = |t: &[f32; 3]| t.iter().any(|c| !c.is_finite());
        let n_bad = texels.iter().filter(|t| bad(t)).count();
        if n_bad > 0 {
            let first = texels.iter().position(bad).unwrap();
            return Err(format!(
                "environment map: {n_bad} of {} texels are NaN or infinite (the first at row {}, column {}); \
                 radiance must be finite",
                texels.len(),
                first / width,
                first % width
            ));
        }
        if !scale.is_finite() {
            return Err(format!("environment map: scale {scale} is not finite"));
        }
        let world_from_light = Mat3::from_mat4(world_from_light);
        let abs_det = world_from_light.determinant().abs();
        if !(abs_det.is_finite() && abs_det > 0.0) {
            return Err("environment map: to_world is singular (or not finite)".into());
        }
        let light_from_world = world_from_light.as_dmat3().inverse().as_mat3();

        // Mitsuba's Bitmap::pad_to(2, 3): repeat the last column, then the last row.
        let (w, h) = (width.max(2), height.max(3));
        let texels: Vec<Spectrum> = (0..h)
            .flat_map(|i| (0..w).map(move |j| (i.min(height - 1), j.min(width - 1))))
            .map(|(i, j)| Vec3::from(texels[i * width + j]))
            .collect();

        // Cell (r, c) spans texel rows r, r+1 and columns c, c+1 (mod W). With
        // t = (θ - θ_r) / Δθ, its luminance integral is
        // Δφ · [½(L_r,c + L_r,c+1) · a_r + ½(L_r+1,c + L_r+1,c+1) · b_r],
        // a_r = ∫(1 - t) sin θ dθ, b_r = ∫ t sin θ dθ over [θ_r, θ_r+1].
        let rows = h - 1;
        let dtheta = std::f64::consts::PI / rows as f64;
        let cos_theta: Vec<f64> = (0..h).map(|i| (i as f64 * dtheta).cos()).collect();
        let inv_row_solid_angle = cos_theta
            .windows(2)
            .map(|c| (1.0 / (2.0 * std::f64::consts::PI * rows as f64 * (c[0] - c[1]))) as f32)
            .collect();
        let row_weights = |r: usize| {
            let (t0, t1) = (r as f64 * dtheta, (r + 1) as f64 * dtheta);
            let b = ((t1.sin() - t0.sin()) / dtheta - t1.cos()).max(0.0);
            ((t0.cos() - t1.cos() - b).max(0.0), b)
        };
        // Mitsuba clamps negative luminance to 0 for sampling.
        let lum: Vec<f64> = texels.iter().map(|&t| luminance(t).max(0.0) as f64).collect();
        let mut weights = Vec::with_capacity(w * rows);
        let mut sum = glam::DVec3::ZERO;
        let row_sum = |i: usize| texels[i * w..(i + 1) * w].iter().map(|t| t.as_dvec3()).sum::<glam::DVec3>();
        for r in 0..rows {
            let (a, b) = row_weights(r);
            for c in 0..w {
                let c1 = (c + 1) % w;
                let top = lum[r * w + c] + lum[r * w + c1];
                let bottom = lum[(r + 1) * w + c] + lum[(r + 1) * w + c1];
                weights.push((0.5 * (top * a + bottom * b)) as f32);
            }
            // Σ_c ½(L_c + L_c+1) = Σ_c L_c by periodicity.
            sum += row_sum(r) * a + row_sum(r + 1) * b;
        }
        // Mean over the sphere: (1 / 4π) · (2π / W) · Σ.
        let mean = (sum * (scale as f64 / (2.0 * w as f64))).as_vec3();
        let distribution = Distribution2D::new(&weights, w, rows);

        Ok(EnvMapLight {
            width: w,
            height: h,
            texels,
            world_from_light,
            light_from_world,
            abs_det,
            scale,
            distribution,
            cos_theta: cos_theta.iter().map(|&c| c as f32).collect(),
            inv_row_solid_angle,
            mean,
        })
    }

    /// Radiance arriving from world direction `wi` (pointing from the scene
    /// out towards the environment). Mitsuba's `eval` with `si.wi = -wi`.
    pub fn eval(&self, wi: Vec3) -> Spectrum {
        let d = self.light_from_world * wi;
        let u = fast::atan2(d.x, -d.z) * INV_2PI;
        let v = fast::acos(d.y) * INV_PI;
        self.lookup(u, v) * self.scale
    }

    /// [`Self::eval`] of `F::WIDTH` directions (x, y and z lanes), bitwise
    /// lane by lane: the rotation, the inverse trigonometry (the lane forms
    /// of `math::fast`) and the texel coordinates in lanes, the bilinear
    /// blend of each lane's four texels gathered (`blend_lanes`), as `eval`.
    pub fn eval_lanes<F: Float>(&self, wx: F, wy: F, wz: F) -> V3<F> {
        let (_, u, theta) = self.local_lanes(wx, wy, wz);
        let (x, y) = self.texel_lanes(u, theta);
        self.blend_lanes(x, y) * F::splat(self.scale)
    }

    /// [`Self::eval_pdf`] of `F::WIDTH` directions, bitwise lane by lane as
    /// [`Self::eval_lanes`]; each lane's density by `pdf_local`.
    pub fn eval_pdf_lanes<F: Float>(&self, wx: F, wy: F, wz: F) -> (V3<F>, F) {
        let (d, u, theta) = self.local_lanes(wx, wy, wz);
        let (x, y) = self.texel_lanes(u, theta);
        let pdf = self.pdf_local_lanes(V3 { x: d[0], y: d[1], z: d[2] }, u, theta);
        (self.blend_lanes(x, y) * F::splat(self.scale), pdf)
    }

    /// The light-space direction d = A⁻¹ w, u = atan2(d.x, −d.z) / 2π and
    /// θ = acos(d.y) in lanes, as `eval` and `eval_pdf` form them (glam's
    /// Mat3 · Vec3: x_axis·x + y_axis·y + z_axis·z, left to right).
    #[inline(always)]
    fn local_lanes<F: Float>(&self, wx: F, wy: F, wz: F) -> ([F; 3], F, F) {
        let m = &self.light_from_world;
        let row = |a: f32, b: f32, c: f32| F::splat(a) * wx + F::splat(b) * wy + F::splat(c) * wz;
        let (dx, dy, dz) = (
            row(m.x_axis.x, m.y_axis.x, m.z_axis.x),
            row(m.x_axis.y, m.y_axis.y, m.z_axis.y),
            row(m.x_axis.z, m.y_axis.z, m.z_axis.z),
        );
        ([dx, dy, dz], simd::atan2(dx, -dz) * F::splat(INV_2PI), simd::acos(dy))
    }

    /// The texel coordinates of `lookup(u, θ/π)` in lanes.
    #[inline(always)]
    fn texel_lanes<F: Float>(&self, u: F, theta: F) -> (F, F) {
        let v = theta * F::splat(INV_PI);
        // As `lookup`; f32::clamp's NaN passes through minps / maxps too.
        let x = (u - u.floor()) * F::splat(self.width as f32) - F::splat(0.5);
        let y = F::splat(1.0).min(F::splat(0.0).max(v)) * F::splat((self.height - 1) as f32);
        (x, y)
    }

    /// [`Self::blend`] in lanes, bitwise lane by lane: the texel indices in
    /// lanes, each texel's channels read by a gather, the same products and
    /// sums per channel (glam's `f32 * Vec3` and `Vec3 + Vec3` are per
    /// component).
    #[inline(always)]
    fn blend_lanes<F: Float>(&self, x: F, y: F) -> V3<F> {
        let (w, h) = (self.width, self.height);
        let x0 = x.floor();
        let i0 = index_lanes(y, h - 2);
        let (fx, fy) = (x - x0, y - F::from_int(i0));
        let last = F::Int::splat(w as i32 - 1);
        let j0 = F::Int::select(x0.cmp_lt(F::splat(0.0)), last, index_lanes(x0, w - 1));
        let j1 = F::Int::select(j0.cmp_eq(last), F::Int::splat(0), j0.wrapping_add(F::Int::splat(1)));
        // Float k of texel (i, j) is at 3 (i W + j) + k (`texels` is packed).
        let floats = self.texel_floats();
        let (three, width) = (F::Int::splat(3), F::Int::splat(w as i32));
        let row0 = i0.wrapping_mul(width);
        let row1 = row0.wrapping_add(width);
        let at = |row: F::Int, j: F::Int| {
            let i = row.wrapping_add(j).wrapping_mul(three);
            let c = |k: i32| F::gather_table(floats, i.wrapping_add(F::Int::splat(k)));
            V3 { x: c(0), y: c(1), z: c(2) }
        };
        let one = F::splat(1.0);
        let top = at(row0, j0) * (one - fx) + at(row0, j1) * fx;
        let bottom = at(row1, j0) * (one - fx) + at(row1, j1) * fx;
        top * (one - fy) + bottom * fy
    }

    /// The texels as one slice of floats, 3 per texel.
    #[inline(always)]
    fn texel_floats(&self) -> &[f32] {
        const { assert!(std::mem::size_of::<Spectrum>() == 12 && std::mem::align_of::<Spectrum>() == 4) };
        // SAFETY: `Spectrum` (glam's `Vec3`) is `#[repr(C)]` of three f32
        // with no padding (asserted above), so `n` texels are `3 n` floats
        // in the same allocation, borrowed as long as `self`.
        unsafe { std::slice::from_raw_parts(self.texels.as_ptr().cast::<f32>(), 3 * self.texels.len()) }
    }

    /// Bilinear lookup, texel (i, j) at (u, v) = ((j + ½) / W, i / (H - 1)).
    fn lookup(&self, u: f32, v: f32) -> Spectrum {
        let (w, h) = (self.width, self.height);
        let x = (u - u.floor()) * w as f32 - 0.5;
        let y = v.clamp(0.0, 1.0) * (h - 1) as f32;
        self.blend(x, y)
    }

    /// The bilinear blend at texel coordinates (x, y) = (u W − ½, v (H − 1)).
    #[inline(always)]
    fn blend(&self, x: f32, y: f32) -> Spectrum {
        let (w, h) = (self.width, self.height);
        let x0 = x.floor();
        let i0 = fast::index(y).min(h - 2);
        let (fx, fy) = (x - x0, y - i0 as f32);
        // x0 ∈ [-1, W - 1]: wrap without integer division.
        let j0 = if x0 < 0.0 { w - 1 } else { fast::index(x0).min(w - 1) };
        let j1 = if j0 + 1 == w { 0 } else { j0 + 1 };
        let t = |i: usize, j: usize| self.texels[i * w + j];
        let top = (1.0 - fx) * t(i0, j0) + fx * t(i0, j1);
        let bottom = (1.0 - fx) * t(i0 + 1, j0) + fx * t(i0 + 1, j1);
        (1.0 - fy) * top + fy * bottom
    }

    /// Importance-samples a direction by luminance (see the module docs).
    /// `None` for a black map.
    pub fn sample_li(&self, u2: Vec2) -> Option<LightSample> {
        let (x, cos_t, pdf_row) = self.sample_cell(u2)?;
        let (w, pdf) = self.sample_direction::<f32>(x, cos_t, pdf_row);
        let wi = Vec3::new(w.x, w.y, w.z);
        Some(LightSample { wi, dist: f32::INFINITY, pdf, li: self.eval(wi), delta: false })
    }

    /// The table lookups of [`Self::sample_li`]: the sampled point's u, its
    /// cos θ (interpolated between the row's edges) and its density over
    /// the square times the row's 1 / solid angle; `None` for a black map.
    #[inline]
    pub fn sample_cell(&self, u2: Vec2) -> Option<(f32, f32, f32)> {
        let (p, pdf_uv) = self.distribution.as_ref()?.sample(u2);
        let rows = self.height - 1;
        let y = p.y * rows as f32;
        let r = fast::index(y).min(rows - 1);
        let (c0, c1) = (self.cos_theta[r], self.cos_theta[r + 1]);
        let cos_t = (c0 + (y - r as f32) * (c1 - c0)).clamp(-1.0, 1.0);
        Some((p.x, cos_t, pdf_uv * self.inv_row_solid_angle[r]))
    }

    /// [`Self::sample_cell`] of `F::WIDTH` pairs of numbers, bitwise lane
    /// by lane, for a map with a distribution ([`Self::samples`]).
    #[inline(always)]
    pub fn sample_cell_lanes<F: Float>(&self, ux: F, uy: F) -> (F, F, F) {
        let distribution = self.distribution.as_ref().expect("a black map is never sampled");
        let (px, py, pdf_uv) = distribution.sample_lanes(ux, uy);
        let rows = self.height - 1;
        let y = py * F::splat(rows as f32);
        let r = index_lanes(y, rows - 1);
        let at = |t: &[f32], k: i32| F::gather_table(t, r.wrapping_add(F::Int::splat(k)));
        let (c0, c1) = (at(&self.cos_theta, 0), at(&self.cos_theta, 1));
        let cos_t = c0 + (y - F::from_int(r)) * (c1 - c0);
        let cos_t = F::splat(1.0).min(F::splat(-1.0).max(cos_t));
        (px, cos_t, pdf_uv * at(&self.inv_row_solid_angle, 0))
    }

    /// Whether its tables are small enough to be gathered in lanes (every
    /// float index fits an i32): the lane forms (`eval_lanes`,
    /// `sample_cell_lanes`, ...) need it.
    pub fn gathers(&self) -> bool {
        3 * self.texels.len() <= i32::MAX as usize
    }

    /// Whether the map can be sampled (it is not black): [`Self::sample_cell`] never gives `None`.
    pub fn samples(&self) -> bool {
        self.distribution.is_some()
    }

    /// The arithmetic of [`Self::sample_li`] after [`Self::sample_cell`],
    /// for any number of lanes: the unit direction and its solid-angle density.
    #[inline(always)]
    pub fn sample_direction<F: Float>(&self, x: F, cos_t: F, pdf_row: F) -> (V3<F>, F) {
        let sin_t = (F::splat(1.0) - cos_t * cos_t).max(F::splat(0.0)).sqrt();
        let (sin_p, cos_p) = simd::sin_cos((x + F::splat(0.5 / self.width as f32)) * F::splat(2.0 * PI));
        let m = &self.world_from_light;
        let (ax, ay, az) = (V3::splat(m.x_axis), V3::splat(m.y_axis), V3::splat(m.z_axis));
        // glam's Mat3 * Vec3: (x_axis x + y_axis y) + z_axis z.
        let w = ax * (sin_p * sin_t) + ay * cos_t + az * (-cos_p * sin_t);
        let len = w.length();
        // Times |A d|³ / |det A|, the solid-angle Jacobian of d ↦ A d / |A d|
        // (1 for a rotation).
        (w / len, pdf_row * (len * len * len / F::splat(self.abs_det)))
    }

    /// `(eval(wi), pdf(wi))`, sharing the change of frame and the atan2 /
    /// acos: a ray that escapes the scene needs both (for MIS).
    pub fn eval_pdf(&self, wi: Vec3) -> (Spectrum, f32) {
        let d = self.light_from_world * wi;
        let u = fast::atan2(d.x, -d.z) * INV_2PI;
        let theta = fast::acos(d.y);
        (self.lookup(u, theta * INV_PI) * self.scale, self.pdf_local(d, u, theta))
    }

    /// Solid-angle density with which `sample_li` produces the unit direction `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let d = self.light_from_world * wi;
        self.pdf_local(d, fast::atan2(d.x, -d.z) * INV_2PI, fast::acos(d.y))
    }

    /// [`Self::pdf`] for the light-space direction `d = A⁻¹ wi`, given
    /// u = atan2(d.x, -d.z) / 2π and θ = acos(d.y) (of d as it is, not normalised).
    #[inline]
    fn pdf_local(&self, d: Vec3, u: f32, theta: f32) -> f32 {
        let Some(distribution) = &self.distribution else { return 0.0 };
        let m = d.length();
        // The cell row is that of the unit direction (m = 1 for most rotations).
        let theta = if m == 1.0 { theta } else { fast::acos(d.y / m) };
        let rows = self.height - 1;
        let r = fast::index(theta * INV_PI * rows as f32).min(rows - 1);
        let u = u - 0.5 / self.width as f32;
        let pdf_uv = distribution.pdf(Vec2::new(u - u.floor(), (r as f32 + 0.5) / rows as f32));
        // |A d| = 1 / m for d = A⁻¹ wi / m.
        pdf_uv * self.inv_row_solid_angle[r] / (m * m * m * self.abs_det)
    }

    /// `pdf_local` in lanes, bitwise lane by lane (the tables gathered).
    #[inline(always)]
    fn pdf_local_lanes<F: Float>(&self, d: V3<F>, u: F, theta: F) -> F {
        let Some(distribution) = &self.distribution else { return F::splat(0.0) };
        let m = d.length();
        let theta = F::select(m.cmp_eq(F::splat(1.0)), theta, simd::acos(d.y / m));
        let rows = self.height - 1;
        let r = index_lanes(theta * F::splat(INV_PI) * F::splat(rows as f32), rows - 1);
        let u = u - F::splat(0.5 / self.width as f32);
        let v = (F::from_int(r) + F::splat(0.5)) / F::splat(rows as f32);
        let pdf_uv = distribution.pdf_lanes(u - u.floor(), v);
        let inv_row = F::gather_table(&self.inv_row_solid_angle, r);
        pdf_uv * inv_row / (m * m * m * F::splat(self.abs_det))
    }

    /// Radiance averaged over the sphere (of the bilinear map, times `scale`).
    pub fn mean_radiance(&self) -> Spectrum {
        self.mean
    }

    /// Φ = π (π r²) L̄ through the scene's bounding disk, from every
    /// direction: 4π² r² L̄ with L̄ the mean radiance, for a scene of
    /// bounding radius `scene_radius`.
    pub fn power(&self, scene_radius: f32) -> Spectrum {
        4.0 * PI * PI * scene_radius * scene_radius * self.mean_radiance()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::gather;
    use crate::testing::chi2::{alpha, chi2_test};

    fn deg(a: f32) -> f32 {
        a.to_radians()
    }

    /// Mitsuba's `ScalarTransform4f().rotate([0, 1, 0], 30).rotate([1, 0, 0], 40)`.
    fn rotation() -> Mat4 {
        Mat4::from_rotation_y(deg(30.0)) * Mat4::from_rotation_x(deg(40.0))
    }

    /// The 6 × 4 map of `eval_matches_mitsuba`.
    fn ramp_map() -> Vec<[f32; 3]> {
        let (w, h) = (6, 4);
        (0..w * h)
            .map(|k| {
                let (i, j) = ((k / w) as f32, (k % w) as f32);
                [1.0 + j + 10.0 * i, 0.5 * (j + 1.0) + 0.25 * i, 0.1 * (i + 1.0) * ((k % w) % 3 + 1) as f32]
            })
            .collect()
    }

    fn assert_close(a: Vec3, b: [f32; 3], what: &str) {
        let b = Vec3::from(b);
        assert!((a - b).abs().max_element() <= 2e-5 * b.abs().max_element().max(1.0), "{what}: {a} vs Mitsuba {b}");
    }

    /// `eval_lanes` is `eval` and `eval_pdf_lanes` is `eval_pdf` lane by
    /// lane, bit for bit, with every lane
    /// width (f32 and each SIMD instance built): random directions, the
    /// poles, the u = 0/1 seam, axis directions and NaN.
    #[test]
    fn lanes_are_eval_bitwise() {
        use crate::simd::check::{each_simd, Visit};
        struct V(Vec<EnvMapLight>, Vec<Vec3>);
        impl Visit for V {
            fn visit<F: Float>(&mut self) {
                for light in &self.0 {
                    for chunk in self.1.chunks(F::WIDTH).filter(|c| c.len() == F::WIDTH) {
                        let lane = |f: fn(&Vec3) -> f32| crate::simd::gather::<F>(|l| f(&chunk[l]));
                        let got = light.eval_lanes(lane(|d| d.x), lane(|d| d.y), lane(|d| d.z)).to_lanes();
                        let (le, pdf) = light.eval_pdf_lanes(lane(|d| d.x), lane(|d| d.y), lane(|d| d.z));
                        let got_pdf = le.to_lanes().into_iter().zip(pdf.to_array().as_ref().to_vec());
                        let f = |c: f32| if c.is_nan() { u32::MAX } else { c.to_bits() };
                        let bits = |v: Vec3| v.to_array().map(f);
                        for ((g, (gp, p)), d) in got.iter().zip(got_pdf).zip(chunk) {
                            let want = light.eval(*d);
                            assert_eq!(bits(*g), bits(want), "{} at {d}: {g} vs {want}", F::NAME);
                            let (wl, wp) = light.eval_pdf(*d);
                            assert_eq!((bits(gp), f(p)), (bits(wl), f(wp)), "{} eval_pdf at {d}", F::NAME);
                        }
                    }
                }
            }
        }
        let mut rng = crate::testing::TestRng::new(3);
        let mut dirs: Vec<Vec3> =
            (0..4096).map(|_| crate::sampling::warp::sample_uniform_sphere(rng.next_2d())).collect();
        dirs.extend([Vec3::Y, -Vec3::Y, Vec3::X, -Vec3::X, Vec3::Z, -Vec3::Z, Vec3::new(0.0, 0.5, -0.0)]);
        dirs.extend([Vec3::new(1e-30, 0.3, -1.0), Vec3::new(-1e-30, 0.3, -1.0), Vec3::splat(f32::NAN)]);
        while dirs.len() % 16 != 0 {
            dirs.push(Vec3::new(0.1, 0.2, 0.3));
        }
        let lights = vec![
            EnvMapLight::new(6, 4, ramp_map(), rotation(), 1.5).unwrap(),
            EnvMapLight::new(6, 4, ramp_map(), Mat4::from_scale(Vec3::new(1.0, 3.0, 1.0)), 1.0).unwrap(),
            EnvMapLight::new(1, 2, vec![[1.0, 2.0, 3.0], [5.0, 6.0, 7.0]], Mat4::IDENTITY, 1.0).unwrap(),
        ];
        let mut v = V(lights, dirs);
        v.visit::<f32>();
        each_simd(&mut v);
    }

    /// `sample_cell_lanes` is `sample_cell` lane by lane, bit for bit, at
    /// every lane width built (random numbers and the corners).
    #[test]
    fn cell_sampling_in_lanes_is_bitwise() {
        use crate::simd::check::{each_simd, Visit};
        struct V(Vec<EnvMapLight>, Vec<Vec2>);
        impl Visit for V {
            fn visit<F: Float>(&mut self) {
                for light in &self.0 {
                    for c in self.1.chunks(F::WIDTH).filter(|c| c.len() == F::WIDTH) {
                        let (x, cos_t, pdf) = light.sample_cell_lanes(gather::<F>(|l| c[l].x), gather::<F>(|l| c[l].y));
                        let (x, cos_t, pdf) = (x.to_array(), cos_t.to_array(), pdf.to_array());
                        for (l, u) in c.iter().enumerate() {
                            let want = light.sample_cell(*u).unwrap();
                            let got = (x.as_ref()[l], cos_t.as_ref()[l], pdf.as_ref()[l]);
                            let bits = |v: (f32, f32, f32)| (v.0.to_bits(), v.1.to_bits(), v.2.to_bits());
                            assert_eq!(bits(got), bits(want), "{} at {u}", F::NAME);
                        }
                    }
                }
            }
        }
        let mut rng = crate::testing::TestRng::new(9);
        let mut us: Vec<Vec2> = (0..4096).map(|_| rng.next_2d()).collect();
        us.extend([Vec2::ZERO, Vec2::new(1.0 - f32::EPSILON / 2.0, 0.0), Vec2::new(0.0, 1.0 - f32::EPSILON / 2.0)]);
        while us.len() % 16 != 0 {
            us.push(Vec2::new(0.3, 0.7));
        }
        let lights = vec![
            EnvMapLight::new(6, 4, ramp_map(), rotation(), 1.5).unwrap(),
            EnvMapLight::new(SUN_W, SUN_H, sun_map(), Mat4::IDENTITY, 1.0).unwrap(),
        ];
        let mut v = V(lights, us);
        v.visit::<f32>();
        each_simd(&mut v);
    }

    /// Values printed by Mitsuba 3.9.1 (scalar_rgb):
    /// ```python
    /// import mitsuba as mi, numpy as np
    /// mi.set_variant('scalar_rgb')
    /// W, H = 6, 4
    /// i, j = np.meshgrid(np.arange(H), np.arange(W), indexing='ij')
    /// arr = np.stack([1 + j + 10 * i, 0.5 * (j + 1) + 0.25 * i, 0.1 * (i + 1) * (j % 3 + 1)], -1).astype(np.float32)
    /// DIRS = [[0.3, 0.9, -0.2], [0.01, 1, 0], [0.1, -0.99, 0.05], [-0.5, 0.2, -0.8], [0.05, 0.3, -0.9],
    ///         [-0.05, 0.3, -0.9], [0.6, -0.4, 0.7]]
    /// def ev(em, d):
    ///     d = np.array(d) / np.linalg.norm(d)
    ///     si = mi.SurfaceInteraction3f(); si.wi = mi.Vector3f(-d)  # si.wi points back into the scene
    ///     return em.eval(si)
    /// for tw in [mi.ScalarTransform4f(), mi.ScalarTransform4f().rotate([0, 1, 0], 30).rotate([1, 0, 0], 40)]:
    ///     em = mi.load_dict({'type': 'envmap', 'bitmap': mi.Bitmap(arr), 'to_world': tw, 'scale': 1.5})
    ///     for d in DIRS: print(ev(em, d))
    /// for tw in [mi.ScalarTransform4f().scale(2), mi.ScalarTransform4f().scale([1, 3, 1])]:  # scale 1
    ///     print(ev(mi.load_dict({'type': 'envmap', 'bitmap': mi.Bitmap(arr), 'to_world': tw}), DIRS[0]))
    /// small = np.array([[[1, 2, 3]], [[5, 6, 7]]], dtype=np.float32)  # 1 x 2: padded to 2 x 3
    /// em = mi.load_dict({'type': 'envmap', 'bitmap': mi.Bitmap(small)})
    /// for d in [[0, 1, 0], [1, 0, 0], [0.3, -0.5, 0.2]]: print(ev(em, d))
    /// ```
    #[test]
    #[allow(clippy::excessive_precision)] // Mitsuba's output, verbatim
    fn eval_matches_mitsuba() {
        // Unit directions as numpy normalises them in f64 (Mitsuba rounds them to f32).
        const DIRS: [[f64; 3]; 7] = [
            [0.309426373877638, 0.928279121632914, -0.20628424925175867], // (0.3, 0.9, -0.2)
            [0.009999500037496877, 0.9999500037496877, 0.0],              // next to the zenith
            [0.10037206624579437, -0.9936834558333641, 0.05018603312289718], // next to the nadir
            [-0.5184758473652126, 0.20739033894608505, -0.8295613557843402],
            [0.05263157894736842, 0.3157894736842105, -0.9473684210526315], // either side of the u = 0 seam
            [-0.05263157894736842, 0.3157894736842105, -0.9473684210526315],
            [0.5970223141259935, -0.3980148760839957, 0.6965260331469924],
        ];
        let dir = |d: [f64; 3]| Vec3::new(d[0] as f32, d[1] as f32, d[2] as f32);
        const IDENTITY: [[f32; 3]; 7] = [
            [7.615715980529785, 1.2153233289718628, 0.29428762197494507],
            [3.14325213432312, 1.5035812854766846, 0.30286505818367004],
            [47.053306579589844, 2.916792392730713, 1.4263020753860474],
            [28.457500457763672, 4.962623119354248, 1.023695468902588],
            [22.750402450561523, 2.8737080097198486, 0.6230877637863159],
            [23.545358657836914, 3.271185874938965, 0.6928274631500244],
            [32.59850311279297, 2.8265721797943115, 1.224287748336792],
        ];
        const ROTATED: [[f32; 3]; 7] = [
            [13.006561279296875, 1.0508151054382324, 0.269676148891449],
            [15.081960678100586, 2.824692964553833, 0.4921278953552246],
            [38.75267028808594, 3.403501510620117, 1.053162693977356],
            [35.029144287109375, 3.5014138221740723, 0.9229894876480103],
            [27.959972381591797, 1.4426132440567017, 0.4320211410522461],
            [28.81415557861328, 1.629516839981079, 0.46526211500167847],
            [23.510971069335938, 2.9614760875701904, 0.7832077145576477],
        ];
        for (to_world, expected) in [(Mat4::IDENTITY, IDENTITY), (rotation(), ROTATED)] {
            let light = EnvMapLight::new(6, 4, ramp_map(), to_world, 1.5).unwrap();
            for (d, e) in DIRS.iter().zip(expected) {
                assert_close(light.eval(dir(*d)), e, &format!("direction {d:?}"));
            }
        }
        // Mitsuba does not renormalise the light-space direction of a non-rigid to_world.
        let d = dir(DIRS[0]);
        for (to_world, e) in [
            (Mat4::from_scale(Vec3::splat(2.0)), [11.829407691955566, 0.9790220856666565, 0.29332298040390015]),
            (Mat4::from_scale(Vec3::new(1.0, 3.0, 1.0)), [13.43438720703125, 1.0191465616226196, 0.3164106011390686]),
        ] {
            assert_close(EnvMapLight::new(6, 4, ramp_map(), to_world, 1.0).unwrap().eval(d), e, "scaled to_world");
        }
        let small = EnvMapLight::new(1, 2, vec![[1.0, 2.0, 3.0], [5.0, 6.0, 7.0]], Mat4::IDENTITY, 1.0).unwrap();
        assert_close(small.eval(Vec3::Y), [1.0, 2.0, 3.0], "padded map, zenith");
        assert_close(small.eval(Vec3::X), [5.0, 6.0, 7.0], "padded map, horizon");
        assert_close(small.eval(Vec3::new(0.3, -0.5, 0.2).normalize()), [5.0, 6.0, 7.0], "padded map, below");
    }

    #[test]
    fn texels_sit_where_mitsuba_places_them() {
        let (w, h) = (6, 4);
        let light = EnvMapLight::new(w, h, ramp_map(), Mat4::IDENTITY, 1.0).unwrap();
        for i in 1..h - 1 {
            for j in 0..w {
                let (theta, phi) = (PI * i as f32 / (h - 1) as f32, 2.0 * PI * (j as f32 + 0.5) / w as f32);
                let d = Vec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin());
                assert_close(light.eval(d), ramp_map()[i * w + j], &format!("texel ({i}, {j})"));
            }
        }
    }

    const SUN_W: usize = 24;
    const SUN_H: usize = 7;

    /// 24 × 7: a dim sky gradient, black ground rows 5 and 6 (θ ≥ 150°), and
    /// a sun of two texels about 10⁴ times brighter on the horizon row 3.
    fn sun_map() -> Vec<[f32; 3]> {
        (0..SUN_W * SUN_H)
            .map(|k| {
                let (i, j) = (k / SUN_W, k % SUN_W);
                if i >= 5 {
                    [0.0; 3]
                } else if i == 3 && (j == 7 || j == 8) {
                    [4000.0, 3600.0, 3000.0]
                } else {
                    let s = 1.0 - i as f32 / 6.0;
                    [0.2 * s, 0.3 * s, 0.6 + 0.01 * j as f32]
                }
            })
            .collect()
    }

    /// Light-space +y to +z: bins the harness's (cos θ, φ) cells in the map's frame.
    fn y_to_z() -> Mat3 {
        Mat3::from_rotation_x(deg(90.0))
    }

    #[test]
    fn sampling_matches_pdf_chi_square() {
        // The harness integrates the pdf over its 24 × 48 (cos θ, φ) cells by an
        // 8 × 8 midpoint rule, which misjudges cells cut by a strong pdf edge.
        // Binned in the map's frame (`y_to_z`), the sun's cells, spanning
        // θ ∈ [60°, 120°] (z = ±0.5) and φ edges at 2π(j + ½)/24, line up with
        // the harness's, so the bright edges are integrated exactly. Binned in
        // the world frame, the sun is dimmed to 1 (about 6× the sky): with the
        // full sun the harness's own error outgrows the noise (p ≈ 0 at 10⁶
        // samples, where an otherwise identical 32 × 32 rule gives p ≈ 0.3).
        let sky: Vec<[f32; 3]> = sun_map().iter().map(|t| t.map(|c| c.min(1.0))).collect();
        let non_rigid = Mat4::from_scale(Vec3::new(1.0, 2.0, 0.7)) * rotation();
        let cases = [
            ("sun, identity, map frame", sun_map(), Mat4::IDENTITY, y_to_z(), 1_000_000),
            (
                "sun, rotated, map frame",
                sun_map(),
                rotation(),
                y_to_z() * Mat3::from_mat4(rotation()).transpose(),
                1_000_000,
            ),
            ("sky, identity, world frame", sky.clone(), Mat4::IDENTITY, Mat3::IDENTITY, 400_000),
            ("sky, rotated, world frame", sky.clone(), rotation(), Mat3::IDENTITY, 400_000),
            ("sky, non-rigid to_world, world frame", sky, non_rigid, Mat3::IDENTITY, 400_000),
        ];
        let a = alpha(cases.len());
        for (k, (name, texels, to_world, frame, n)) in cases.into_iter().enumerate() {
            let light = EnvMapLight::new(SUN_W, SUN_H, texels, to_world, 1.0).unwrap();
            let inv = frame.transpose();
            let p = chi2_test(
                n,
                40 + k as u64,
                |_, u| light.sample_li(u).map(|s| frame * s.wi),
                |w| light.pdf(inv * w) as f64,
            );
            eprintln!("envmap chi-square, {name}: p = {p}");
            assert!(p > a, "{name}: p = {p}");
        }
        // The test has power: the density of (u, v) uniform within each cell,
        // p_uv / (2π² sin θ), also integrates to 1 but is not what is sampled.
        let light = EnvMapLight::new(SUN_W, SUN_H, sun_map(), Mat4::IDENTITY, 1.0).unwrap();
        let frame = y_to_z();
        let uniform_uv_pdf = |w: Vec3| {
            let d = frame.transpose() * w;
            let u = d.x.atan2(-d.z) * INV_2PI - 0.5 / SUN_W as f32;
            let uv = Vec2::new(u - u.floor(), d.y.clamp(-1.0, 1.0).acos() * INV_PI);
            let sin_t = d.x.hypot(d.z);
            if sin_t > 0.0 {
                (light.distribution.as_ref().unwrap().pdf(uv) / (2.0 * PI * PI * sin_t)) as f64
            } else {
                0.0
            }
        };
        let p = chi2_test(1_000_000, 50, |_, u| light.sample_li(u).map(|s| frame * s.wi), uniform_uv_pdf);
        eprintln!("envmap chi-square, wrong pdf: p = {p}");
        assert!(p < a, "a wrong pdf passed (p = {p})");
    }

    #[test]
    fn samples_carry_eval_and_their_pdf() {
        for to_world in [Mat4::IDENTITY, rotation(), Mat4::from_scale(Vec3::new(1.0, 2.0, 0.7))] {
            let light = EnvMapLight::new(SUN_W, SUN_H, sun_map(), to_world, 2.0).unwrap();
            let mut in_sun = 0;
            for i in 0..4096 {
                let u = Vec2::new((i % 64) as f32 + 0.5, (i / 64) as f32 + 0.5) / 64.0;
                let s = light.sample_li(u).unwrap();
                assert!((s.wi.length() - 1.0).abs() < 1e-5 && s.dist == f32::INFINITY && !s.delta);
                assert_eq!(s.li, light.eval(s.wi));
                let pdf = light.pdf(s.wi);
                assert_eq!(light.eval_pdf(s.wi), (s.li, pdf));
                assert!((s.pdf - pdf).abs() <= 1e-3 * pdf, "u {u}: sampled pdf {} vs pdf() {pdf}", s.pdf);
                in_sun += (s.li.x > 100.0) as usize;
            }
            // The sun has about 0.998 of the luminance power.
            assert!(in_sun > 3900, "{in_sun} of 4096 samples near the sun");
        }
    }

    /// ∫ f dω over the sphere by the midpoint rule in (θ, φ).
    fn integrate_sphere(f: impl Fn(Vec3) -> f64) -> f64 {
        let (nt, np) = (720, 1440);
        let (dt, dp) = (std::f64::consts::PI / nt as f64, 2.0 * std::f64::consts::PI / np as f64);
        let mut acc = 0.0;
        for a in 0..nt {
            let theta = (a as f64 + 0.5) * dt;
            for b in 0..np {
                let phi = (b as f64 + 0.5) * dp;
                let w =
                    Vec3::new((theta.sin() * phi.cos()) as f32, (theta.sin() * phi.sin()) as f32, theta.cos() as f32);
                acc += f(w) * theta.sin();
            }
        }
        acc * dt * dp
    }

    #[test]
    fn pdf_integrates_to_one() {
        let mild: Vec<[f32; 3]> = sun_map().iter().map(|t| t.map(|c| c.min(30.0))).collect();
        for to_world in [Mat4::IDENTITY, rotation(), Mat4::from_scale(Vec3::new(1.0, 2.0, 0.7)) * rotation()] {
            let light = EnvMapLight::new(SUN_W, SUN_H, mild.clone(), to_world, 1.0).unwrap();
            let integral = integrate_sphere(|w| light.pdf(w) as f64);
            assert!((integral - 1.0).abs() < 2e-3, "∫ pdf dω = {integral}");
        }
    }

    #[test]
    fn mean_radiance_is_the_sphere_average() {
        let c = [0.25, 1.0, 3.0];
        let constant = EnvMapLight::new(5, 3, vec![c; 15], rotation(), 2.0).unwrap();
        assert_close(constant.mean_radiance(), c.map(|v| 2.0 * v), "constant map");
        let light = EnvMapLight::new(6, 4, ramp_map(), rotation(), 1.5).unwrap();
        let numeric: [f32; 3] = std::array::from_fn(|k| {
            (integrate_sphere(|w| light.eval(w)[k] as f64) / (4.0 * std::f64::consts::PI)) as f32
        });
        let mean = light.mean_radiance();
        assert!((mean - Vec3::from(numeric)).abs().max_element() < 1e-3 * mean.max_element(), "{mean} vs {numeric:?}");
    }

    #[test]
    fn black_map_is_valid_and_never_sampled() {
        let light = EnvMapLight::new(8, 4, vec![[0.0; 3]; 32], Mat4::IDENTITY, 1.0).unwrap();
        assert_eq!(light.eval(Vec3::new(0.2, 0.3, -0.9).normalize()), Vec3::ZERO);
        assert!(light.sample_li(Vec2::new(0.3, 0.7)).is_none());
        assert_eq!(light.pdf(Vec3::Z), 0.0);
        assert_eq!(light.mean_radiance(), Vec3::ZERO);
    }

    #[test]
    fn bad_input_is_an_error() {
        let mut texels = vec![[1.0; 3]; 12];
        texels[5][1] = f32::NAN;
        texels[9][2] = f32::INFINITY;
        let err = EnvMapLight::new(4, 3, texels, Mat4::IDENTITY, 1.0).unwrap_err();
        assert!(err.contains("2 of 12 texels are NaN or infinite") && err.contains("row 1, column 1"), "{err}");
        let err = EnvMapLight::new(4, 3, vec![[1.0; 3]; 11], Mat4::IDENTITY, 1.0).unwrap_err();
        assert!(err.contains("11 texels do not make a 4 x 3 image"), "{err}");
        assert!(EnvMapLight::new(4, 3, vec![[1.0; 3]; 12], Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)), 1.0).is_err());
    }

    #[test]
    fn poles_give_finite_values() {
        let light = EnvMapLight::new(SUN_W, SUN_H, sun_map(), Mat4::IDENTITY, 1.0).unwrap();
        // Bounded density at the zenith; none at the nadir (black ground).
        assert!(light.eval(Vec3::Y).is_finite() && light.pdf(Vec3::Y).is_finite() && light.pdf(Vec3::Y) > 0.0);
        assert_eq!((light.eval(-Vec3::Y), light.pdf(-Vec3::Y)), (Vec3::ZERO, 0.0));
        for u in [Vec2::ZERO, Vec2::ONE, Vec2::new(0.5, 0.0), Vec2::new(0.5, 1.0 - f32::EPSILON)] {
            let s = light.sample_li(u).unwrap();
            assert!(s.pdf.is_finite() && s.pdf > 0.0 && s.li.is_finite(), "{u}: {s:?}");
        }
    }
}
