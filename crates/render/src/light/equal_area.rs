//! pbrt-v4's image `infinite` light: radiance from a square image in the
//! equal-area octahedral parameterisation (Clarberg 2008;
//! [`warp::equal_area_sphere_to_square`]), looked up at the nearest texel
//! as pbrt-v4's `ImageInfiniteLight::ImageLe` does, times `scale`.
//!
//! Every texel covers the same solid angle, 4π / N², so sampling a texel in
//! proportion to its channel mean (pbrt-v4's sampling distribution) and a
//! point uniformly inside it has the solid-angle density
//! p(ω) = p_uv(u, v) / (4π).
//!
//! The image's first row is v = 0 (pbrt-v4's image coordinates). The light
//! frame is carried by a rotation or reflection (`world_from_light` must be
//! orthogonal: pbrt-v4 normalises directions without a Jacobian).

use super::LightSample;
use crate::math::{Spectrum, PI};
use crate::sampling::distrib2d::Distribution2D;
use crate::sampling::warp;
use glam::{Mat3, Mat4, Vec2, Vec3};

/// pbrt-v4 `infinite` with an equal-area image.
#[derive(Debug, Clone)]
pub struct EqualAreaEnvLight {
    res: usize,
    texels: Vec<Spectrum>,
    world_from_light: Mat3,
    light_from_world: Mat3,
    scale: f32,
    distribution: Option<Distribution2D>,
    mean: Spectrum,
}

impl EqualAreaEnvLight {
    /// A light from `res` x `res` texels (row by row, first row at v = 0);
    /// negative values are clamped to zero (as pbrt-v4's `ClampZero`).
    pub fn new(
        res: usize,
        texels: Vec<[f32; 3]>,
        world_from_light: Mat4,
        scale: f32,
    ) -> Result<EqualAreaEnvLight, String> {
        if res == 0 || texels.len() != res * res {
            return Err(format!(
                "equal-area environment map: {} texels do not make a square image of {res} x {res} \
                 (pbrt-v4's equal-area images are square)",
                texels.len()
            ));
        }
        if let Some(i) = texels.iter().position(|t| t.iter().any(|c| !c.is_finite())) {
            return Err(format!(
                "equal-area environment map: texel at row {}, column {} is NaN or infinite; radiance must be finite",
                i / res,
                i % res
            ));
        }
        if !scale.is_finite() {
            return Err(format!("equal-area environment map: scale {scale} is not finite"));
        }
        let m = Mat3::from_mat4(world_from_light);
        let gram = m.transpose() * m;
        if !gram.abs_diff_eq(Mat3::IDENTITY, 1e-4) {
            return Err("equal-area environment map: its transform must be a rotation (or a reflection); \
                 pbrt-v4 applies no scale or shear to directions"
                .into());
        }
        let texels: Vec<Spectrum> = texels.iter().map(|t| Vec3::from(*t).max(Vec3::ZERO)).collect();
        let weights: Vec<f32> = texels.iter().map(|t| (t.x + t.y + t.z) / 3.0).collect();
        let mean = texels.iter().fold(Vec3::ZERO, |a, t| a + *t) / texels.len() as f32 * scale;
        Ok(EqualAreaEnvLight {
            res,
            texels,
            world_from_light: m,
            light_from_world: m.transpose(),
            scale,
            distribution: Distribution2D::new(&weights, res, res),
            mean,
        })
    }

    /// The texel nearest to (u, v), with pbrt-v4's octahedral wrap for
    /// coordinates on the square's far edges.
    fn lookup(&self, uv: Vec2) -> Spectrum {
        let n = self.res as i64;
        let (mut x, mut y) = ((uv.x * n as f32) as i64, (uv.y * n as f32) as i64);
        if x < 0 {
            (x, y) = (-x - 1, n - 1 - y);
        } else if x >= n {
            (x, y) = (2 * n - 1 - x, n - 1 - y);
        }
        if y < 0 {
            (x, y) = (n - 1 - x, -y - 1);
        } else if y >= n {
            (x, y) = (n - 1 - x, 2 * n - 1 - y);
        }
        let (x, y) = (x.clamp(0, n - 1) as usize, y.clamp(0, n - 1) as usize);
        self.texels[y * self.res + x] * self.scale
    }

    fn uv(&self, wi: Vec3) -> Vec2 {
        warp::equal_area_sphere_to_square((self.light_from_world * wi).normalize())
    }

    /// Radiance arriving along `-wi` from direction `wi`.
    pub fn eval(&self, wi: Vec3) -> Spectrum {
        self.lookup(self.uv(wi))
    }

    /// Solid-angle density with which [`Self::sample_li`] produces `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        match &self.distribution {
            Some(d) => d.pdf(self.uv(wi)) / (4.0 * PI),
            None => 0.0,
        }
    }

    /// `(eval(wi), pdf(wi))` from one change of frame.
    pub fn eval_pdf(&self, wi: Vec3) -> (Spectrum, f32) {
        let uv = self.uv(wi);
        let pdf = self.distribution.as_ref().map_or(0.0, |d| d.pdf(uv) / (4.0 * PI));
        (self.lookup(uv), pdf)
    }

    /// A direction drawn in proportion to the texels' channel means; `None`
    /// for a black image.
    pub fn sample_li(&self, u2: Vec2) -> Option<LightSample> {
        let (uv, pdf_uv) = self.distribution.as_ref()?.sample(u2);
        let wi = (self.world_from_light * warp::equal_area_square_to_sphere(uv)).normalize();
        Some(LightSample { wi, dist: f32::INFINITY, pdf: pdf_uv / (4.0 * PI), li: self.lookup(uv), delta: false })
    }

    /// Radiance averaged over the sphere (every texel has the same solid angle).
    pub fn mean_radiance(&self) -> Spectrum {
        self.mean
    }

    /// Φ = 4π² r² L̄ through the scene's bounding disk of radius `scene_radius`
    /// (as [`super::EnvMapLight::power`]).
    pub fn power(&self, scene_radius: f32) -> Spectrum {
        4.0 * PI * PI * scene_radius * scene_radius * self.mean
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{alpha, chi2_test};

    /// A 16 x 16 map: dim everywhere, a bright 2 x 3 patch, colours varying by texel.
    fn map() -> Vec<[f32; 3]> {
        (0..256)
            .map(|i| {
                let (y, x) = (i / 16, i % 16);
                let b = if (4..6).contains(&y) && (9..12).contains(&x) { 40.0 } else { 0.1 };
                [b * (1.0 + x as f32 / 16.0), b, b * (1.0 + y as f32 / 16.0)]
            })
            .collect()
    }

    fn light() -> EqualAreaEnvLight {
        // A rotation and a reflection, as pbrt scenes often carry.
        let m = Mat4::from_rotation_x(0.7) * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        EqualAreaEnvLight::new(16, map(), m, 2.0).unwrap()
    }

    #[test]
    fn sampling_matches_its_pdf_and_the_radiance_is_the_texels() {
        let l = light();
        let p = chi2_test(400_000, 7, |_, u| l.sample_li(u).map(|s| s.wi), |w| l.pdf(w) as f64);
        assert!(p > alpha(2), "p = {p}");
        // Power: a uniform pdf is rejected.
        let p = chi2_test(400_000, 8, |_, u| l.sample_li(u).map(|s| s.wi), |_| 1.0 / (4.0 * std::f64::consts::PI));
        assert!(p < alpha(2), "uniform pdf accepted (p = {p})");
        for k in 0..1000 {
            let u = Vec2::new((k % 37) as f32 / 37.0 + 0.01, (k / 37) as f32 / 28.0 + 0.013);
            let s = l.sample_li(u).unwrap();
            let (le, pdf) = l.eval_pdf(s.wi);
            assert!((le - s.li).abs().max_element() <= 1e-5 * s.li.max_element(), "{le} vs {}", s.li);
            assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{pdf} vs {}", s.pdf);
        }
        // Texel centres map to their own texels.
        for (i, t) in map().iter().enumerate() {
            let uv = Vec2::new(((i % 16) as f32 + 0.5) / 16.0, ((i / 16) as f32 + 0.5) / 16.0);
            let w = l.world_from_light * warp::equal_area_square_to_sphere(uv);
            assert_eq!(l.eval(w), Vec3::from(*t) * 2.0, "texel {i}");
        }
    }

    #[test]
    fn mean_is_the_sphere_average_and_bad_input_is_refused() {
        let l = light();
        // Monte Carlo over uniform directions (independent of the map) estimates
        // the mean radiance; each texel covers 1/N² of the sphere, so it is the
        // texel mean. Tolerance: 5 standard errors of the estimate.
        use crate::sampling::rng::{mix64, to_unit_f32};
        let n = 200_000u64;
        let (mut s1, mut s2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for k in 0..n {
            let u = Vec2::new(to_unit_f32(mix64(2 * k + 1)), to_unit_f32(mix64(2 * k + 2)));
            let v = l.eval(warp::sample_uniform_sphere(u)).as_dvec3();
            s1 += v;
            s2 += v * v;
        }
        let m = s1 / n as f64;
        let se = ((s2 / n as f64 - m * m) / n as f64).powf(0.5);
        let z = ((m - l.mean_radiance().as_dvec3()) / se).abs().max_element();
        assert!(z < 5.0, "{m} vs {} (z {z})", l.mean_radiance());
        assert!(EqualAreaEnvLight::new(4, vec![[1.0; 3]; 12], Mat4::IDENTITY, 1.0).unwrap_err().contains("square"));
        let mut t = vec![[1.0; 3]; 16];
        t[5][1] = f32::NAN;
        assert!(EqualAreaEnvLight::new(4, t, Mat4::IDENTITY, 1.0).unwrap_err().contains("row 1, column 1"));
        let e = EqualAreaEnvLight::new(4, vec![[1.0; 3]; 16], Mat4::from_scale(Vec3::splat(2.0)), 1.0).unwrap_err();
        assert!(e.contains("rotation"), "{e}");
        // Black: nothing to sample.
        assert!(EqualAreaEnvLight::new(2, vec![[0.0; 3]; 4], Mat4::IDENTITY, 1.0)
            .unwrap()
            .sample_li(Vec2::splat(0.5))
            .is_none());
    }
}
