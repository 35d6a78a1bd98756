//! Mitsuba 3.9.1's `measured` BSDF (Dupuy & Jakob 2018, RGL `.bsdf`
//! files) as its RGB variants evaluate it: a one-sided glossy reflection
//! tabulated over the incident direction (φ_i, θ_i) and a warped
//! half-vector domain. The tables (`MeasuredTables`) come from the file's
//! fields `theta_i`, `phi_i`, `ndf`, `sigma`, `vndf`, `luminance`, `rgb`
//! and `jacobian` (`description` is only checked). The value for a pair
//! of directions is the `rgb` table at the VNDF-inverted half vector,
//! times NDF(h) / (4 σ(wi)) when `jacobian` is set; it includes the cosine
//! of the sampled direction (Mitsuba's `eval`; [`BsdfModel::eval`] divides
//! it out). Sampling warps by the luminance table, then the VNDF, as with
//! `MI_SAMPLE_LUMINANCE = 1`, `MI_SAMPLE_DIFFUSE = 0`.
//! Files whose `phi_i` spans a half or a quarter turn are mirrored into
//! that range (`m_reduction` 2 or 4); `phi_i` of one or two values marks
//! an isotropic material, which is never mirrored. (Mitsuba 3.9.1 leaves
//! `m_reduction` unset for those, mitsuba3 pull request #1850, and may
//! mirror them by chance; that changes only the lookups at the absolute
//! φ_i, of σ and, in a file with two `phi_i` values, of the other tables,
//! none of which an isotropic material's values depend on.)
//!
//! | parameter | type   | default  |
//! |-----------|--------|----------|
//! | filename  | string | required: an RGL `.bsdf` file in RGB form (field `rgb`); spectral files (field `wavelengths`) are refused, as Mitsuba's RGB variants refuse them |
//!
//! The `mitsuba_*` methods take Mitsuba's directions: `wi` towards the
//! viewer (the contract's `wo`), `wo` sampled (the contract's `wi`).
//!
//! Done: RGB files, isotropic or mirrored into a half or quarter turn,
//! eval / pdf / sample as Mitsuba's. Remains: spectral files (Penumbra
//! renders RGB only).

use super::{BsdfModel, BsdfParams, BsdfSample};
use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use crate::sampling::marginal2d::Marginal2D;
use crate::texture::Texture;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

/// The float32 tables of a `.bsdf` file, C order, with their shapes.
#[derive(Debug, Clone, Default)]
pub struct MeasuredTables {
    /// Incident elevations, `[n_theta]`.
    pub theta_i: Vec<f32>,
    /// Incident azimuths, `[n_phi]`.
    pub phi_i: Vec<f32>,
    /// Microfacet distribution, shape `[h, w]`.
    pub ndf: (Vec<f32>, Vec<usize>),
    /// Projected microfacet area, shape `[h, w]`.
    pub sigma: (Vec<f32>, Vec<usize>),
    /// Visible normals, shape `[n_phi, n_theta, h, w]`.
    pub vndf: (Vec<f32>, Vec<usize>),
    /// Luminance, shape `[n_phi, n_theta, h, w]`.
    pub luminance: (Vec<f32>, Vec<usize>),
    /// RGB values, shape `[n_phi, n_theta, 3, h, w]`.
    pub rgb: (Vec<f32>, Vec<usize>),
    /// Whether the `rgb` table omits the NDF / (4 σ) factor.
    pub jacobian: bool,
}

/// A loaded `measured` BSDF.
#[derive(Debug, Clone)]
pub struct Measured {
    ndf: Marginal2D,
    sigma: Marginal2D,
    vndf: Marginal2D,
    luminance: Marginal2D,
    rgb: Marginal2D,
    isotropic: bool,
    jacobian: bool,
    reduction: i32,
}

/// `dr::mulsign_neg(x, y)`: x times the negated sign of y (sign bit).
/// A multiplication, not a branch returning `-x` (see [`super::mulsign`]).
fn mulsign_neg(x: f32, y: f32) -> f32 {
    x * if y.is_sign_negative() { 1.0 } else { -1.0 }
}

/// The elevation of a unit vector, stable near the pole.
fn elevation(d: Vec3) -> f32 {
    let dist = (d.x * d.x + d.y * d.y + (d.z - 1.0) * (d.z - 1.0)).sqrt();
    2.0 * (0.5 * dist).clamp(-1.0, 1.0).asin()
}

fn u2theta(u: f32) -> f32 {
    u * u * (PI / 2.0)
}
fn u2phi(u: f32) -> f32 {
    (2.0 * u - 1.0) * PI
}
fn theta2u(theta: f32) -> f32 {
    (theta * (2.0 / PI)).sqrt()
}
fn phi2u(phi: f32) -> f32 {
    (phi + PI) * (0.5 / PI)
}

impl Measured {
    /// Checks the shapes as Mitsuba does and builds the warps.
    pub fn new(t: MeasuredTables) -> Result<Measured, String> {
        let (n_phi, n_theta) = (t.phi_i.len(), t.theta_i.len());
        let bad = |what: &str| Err(format!("invalid .bsdf file structure: {what}"));
        if t.ndf.1.len() != 2 || t.sigma.1.len() != 2 {
            return bad("'ndf' and 'sigma' must have two dimensions");
        }
        let (v, l, s) = (&t.vndf.1, &t.luminance.1, &t.rgb.1);
        if v.len() != 4 || v[0] != n_phi || v[1] != n_theta {
            return bad("'vndf' must have the shape [phi_i, theta_i, h, w]");
        }
        if l.len() != 4 || l[0] != n_phi || l[1] != n_theta || l[2] != l[3] {
            return bad("'luminance' must have the shape [phi_i, theta_i, n, n]");
        }
        if s.len() != 5 || s[0] != n_phi || s[1] != n_theta || s[2] != 3 || s[3] != s[4] || l[2] != s[3] {
            return bad("'rgb' must have the shape [phi_i, theta_i, 3, n, n] with the n of 'luminance'");
        }
        if n_phi == 0 || n_theta == 0 {
            return bad("'phi_i' and 'theta_i' must not be empty");
        }
        let isotropic = n_phi <= 2;
        let reduction =
            if isotropic { 0 } else { (2.0 * PI / (t.phi_i[n_phi - 1] - t.phi_i[0])).round_ties_even() as i32 };
        let params = || vec![t.phi_i.clone(), t.theta_i.clone()];
        let warp = |name: &str, (data, shape): &(Vec<f32>, Vec<usize>), params: Vec<Vec<f32>>, normalize: bool| {
            let (h, w) = (shape[shape.len() - 2], shape[shape.len() - 1]);
            Marginal2D::new(data, w, h, params, normalize).map_err(|e| format!("field '{name}': {e}"))
        };
        Ok(Measured {
            ndf: warp("ndf", &t.ndf, vec![], false)?,
            sigma: warp("sigma", &t.sigma, vec![], false)?,
            vndf: warp("vndf", &t.vndf, params(), true)?,
            luminance: warp("luminance", &t.luminance, params(), true)?,
            rgb: warp("rgb", &t.rgb, vec![t.phi_i.clone(), t.theta_i.clone(), vec![0.0, 1.0, 2.0]], false)?,
            isotropic,
            jacobian: t.jacobian,
            reduction,
        })
    }

    fn reduce(&self, wi: &mut Vec3, other: Option<&mut Vec3>) -> (f32, f32) {
        if self.reduction < 2 {
            return (-1.0, -1.0);
        }
        let sy = wi.y;
        let sx = if self.reduction == 4 { wi.x } else { sy };
        wi.x = mulsign_neg(wi.x, sx);
        wi.y = mulsign_neg(wi.y, sy);
        if let Some(o) = other {
            o.x = mulsign_neg(o.x, sx);
            o.y = mulsign_neg(o.y, sy);
        }
        (sx, sy)
    }

    fn spectrum(&self, sample: [f32; 2], phi_i: f32, theta_i: f32, u_m: [f32; 2], u_wi: [f32; 2]) -> Spectrum {
        let mut spec = Vec3::new(
            self.rgb.eval(sample, &[phi_i, theta_i, 0.0]),
            self.rgb.eval(sample, &[phi_i, theta_i, 1.0]),
            self.rgb.eval(sample, &[phi_i, theta_i, 2.0]),
        );
        if self.jacobian {
            spec *= self.ndf.eval(u_m, &[]) / (4.0 * self.sigma.eval(u_wi, &[]));
        }
        spec
    }

    /// Half-vector coordinates of (wi, wo), both already reduced.
    fn half(&self, wi: Vec3, wo: Vec3) -> (Vec3, f32, f32, [f32; 2], [f32; 2]) {
        let m = (wo + wi).normalize();
        let (theta_i, phi_i) = (elevation(wi), wi.y.atan2(wi.x));
        let (theta_m, phi_m) = (elevation(m), m.y.atan2(m.x));
        let u_wi = [theta2u(theta_i), phi2u(phi_i)];
        let mut u_m = [theta2u(theta_m), phi2u(if self.isotropic { phi_m - phi_i } else { phi_m })];
        u_m[1] -= u_m[1].floor();
        (m, phi_i, theta_i, u_wi, u_m)
    }

    /// Mitsuba's `eval`: the BSDF times cos θ_o, RGB.
    pub fn mitsuba_eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        if !(wi.z > 0.0 && wo.z > 0.0) {
            return Spectrum::ZERO;
        }
        let (mut wi, mut wo) = (wi, wo);
        self.reduce(&mut wi, Some(&mut wo));
        let (_, phi_i, theta_i, u_wi, u_m) = self.half(wi, wo);
        let (sample, _) = self.vndf.invert(u_m, &[phi_i, theta_i]);
        let s = self.spectrum(sample, phi_i, theta_i, u_m, u_wi);
        if s.is_finite() {
            s
        } else {
            Spectrum::ZERO
        }
    }

    /// Mitsuba's `pdf`: the density of `sample` per unit solid angle.
    pub fn mitsuba_pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if !(wi.z > 0.0 && wo.z > 0.0) {
            return 0.0;
        }
        let (mut wi, mut wo) = (wi, wo);
        self.reduce(&mut wi, Some(&mut wo));
        let (m, phi_i, theta_i, _, u_m) = self.half(wi, wo);
        let params = [phi_i, theta_i];
        let (sample, vndf_pdf) = self.vndf.invert(u_m, &params);
        let lum = self.luminance.eval(sample, &params);
        // Frame3f::sin_theta: safe_sqrt(fnmadd(z, z, 1)).
        let sin_theta_m = (-m.z).mul_add(m.z, 1.0).max(0.0).sqrt();
        let jacobian = (2.0 * PI * PI * u_m[0] * sin_theta_m).max(1e-6) * 4.0 * wi.dot(m);
        let pdf = vndf_pdf * lum / jacobian;
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// Mitsuba's `sample`: the sampled `wo`, its pdf, and eval / pdf.
    pub fn mitsuba_sample(&self, wi: Vec3, u: Vec2) -> Option<(Vec3, f32, Spectrum)> {
        if wi.z <= 0.0 {
            return None;
        }
        let mut wi = wi;
        let (sx, sy) = self.reduce(&mut wi, None);
        let (theta_i, phi_i) = (elevation(wi), wi.y.atan2(wi.x));
        let params = [phi_i, theta_i];
        let u_wi = [theta2u(theta_i), phi2u(phi_i)];
        let (sample, lum_pdf) = self.luminance.sample([u.y, u.x], &params);
        let (u_m, ndf_pdf) = self.vndf.sample(sample, &params);
        let mut phi_m = u2phi(u_m[1]);
        let theta_m = u2theta(u_m[0]);
        if self.isotropic {
            phi_m += phi_i;
        }
        let (sin_phi, cos_phi) = phi_m.sin_cos();
        let (sin_theta, cos_theta) = theta_m.sin_cos();
        let m = Vec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta);
        let jacobian = (2.0 * PI * PI * u_m[0] * sin_theta).max(1e-6) * 4.0 * wi.dot(m);
        let mut wo = m * (2.0 * m.dot(wi)) - wi;
        let pdf = ndf_pdf * lum_pdf / jacobian;
        let spec = self.spectrum(sample, phi_i, theta_i, u_m, u_wi);
        wo.x = mulsign_neg(wo.x, sx);
        wo.y = mulsign_neg(wo.y, sy);
        if !(wo.z > 0.0 && pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        let weight = spec / pdf;
        weight.is_finite().then_some((wo, pdf, weight))
    }
}

/// Mitsuba `measured` as the scene stores it: the loaded file, shared.
#[derive(Debug, Clone)]
pub struct MeasuredParams(pub Arc<Measured>);

impl BsdfParams for MeasuredParams {
    type Model<'a> = &'a Measured;

    #[inline]
    fn at(&self, _si: &SurfaceInteraction) -> &Measured {
        &self.0
    }

    fn textures(&self) -> Vec<&Texture> {
        Vec::new()
    }

    /// The tables are looked up at the azimuth φ_i of the frame (an
    /// isotropic file's σ too), so the frame's orientation matters.
    fn anisotropic(&self) -> bool {
        true
    }
}

impl BsdfModel for &Measured {
    #[inline]
    fn has_smooth(&self) -> bool {
        true
    }

    /// Mitsuba's value, which includes cos θ_i, divided by it.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.mitsuba_eval(wo, wi) / wi.z
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.mitsuba_pdf(wo, wi)
    }

    fn sample(&self, wo: Vec3, _u: f32, u2: Vec2) -> Option<BsdfSample> {
        let (wi, pdf, weight) = self.mitsuba_sample(wo, u2)?;
        Some(BsdfSample { wi, pdf, weight, delta: false, null: false, eta: 1.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{alpha, chi2_test};

    fn table(shape: &[usize], f: impl Fn(&[usize]) -> f64) -> (Vec<f32>, Vec<usize>) {
        let n: usize = shape.iter().product();
        let mut idx = vec![0; shape.len()];
        let mut out = Vec::with_capacity(n);
        for mut k in 0..n {
            for d in (0..shape.len()).rev() {
                idx[d] = k % shape[d];
                k /= shape[d];
            }
            out.push(f(&idx) as f32);
        }
        (out, shape.to_vec())
    }

    /// The tables of tools/make_measured_bsdf.py's `bsdf()`.
    fn synthetic(phi_i: &[f32], theta_i: &[f32], (h, w): (usize, usize), n: usize, jacobian: bool) -> Measured {
        let (p, t) = (phi_i.len(), theta_i.len());
        let (hf, wf, nf, tf) = ((h - 1) as f64, (w - 1) as f64, (n - 1) as f64, (t.max(2) - 1) as f64);
        let lum = move |p: f64, t: f64, y: f64, x: f64| {
            0.3 + (1.0 + 0.5 * p + 0.3 * t) * (-2.0 * ((x / nf).powi(2) + (y / nf - 0.3).powi(2))).exp()
        };
        let i = |v: usize| v as f64;
        Measured::new(MeasuredTables {
            theta_i: theta_i.to_vec(),
            phi_i: phi_i.to_vec(),
            ndf: table(&[h, w], |k| {
                0.2 + (-4.0 * (i(k[1]) / wf).powi(2)).exp()
                    * (1.0 + 0.3 * (2.0 * std::f64::consts::PI * i(k[0]) / hf).cos())
            }),
            sigma: table(&[h, w], |k| 0.5 + 0.4 * (i(k[1]) / wf) + 0.05 * (3.0 * i(k[0]) / hf).sin()),
            // Zero at θ_m = 0, as a measured VNDF in the warped domain is
            // (its density in u_m carries the Jacobian 2π² u sin θ_m).
            vndf: table(&[p, t, h, w], |k| {
                i(k[3]) / wf
                    * (0.1
                        + (-3.0 * (i(k[3]) / wf - 0.2 * i(k[1]) / tf).powi(2)).exp()
                            * (1.2 + (i(k[2]) * 0.7 + i(k[0])).sin()))
            }),
            luminance: table(&[p, t, n, n], |k| lum(i(k[0]), i(k[1]), i(k[2]), i(k[3]))),
            rgb: table(&[p, t, 3, n, n], |k| {
                (0.5 + 0.2 * i(k[2])) * lum(i(k[0]), i(k[1]), i(k[3]), i(k[4])) * (1.0 + 0.1 * i(k[2]) * i(k[4]) / nf)
            }),
            jacobian,
        })
        .unwrap()
    }

    fn d(theta: f32, phi: f32) -> Vec3 {
        Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    /// Sampling against the pdf by chi-square (the pdf integrates to the
    /// probability that the reflected direction stays above the surface).
    #[test]
    fn chi2_of_sampling() {
        let iso = synthetic(&[0.0], &[0.0, 0.4, 0.9, 1.4], (9, 7), 8, true);
        let half = synthetic(&[-PI, -PI / 2.0, 0.0], &[0.0, 0.7, 1.4], (6, 5), 6, false);
        let quarter = synthetic(&[-PI, -0.75 * PI, -PI / 2.0], &[0.0, 0.5, 1.0, 1.5], (7, 6), 7, true);
        let cases = [
            (&iso, d(0.3, 0.5)),
            (&iso, d(1.1, -2.0)),
            (&half, d(0.7, 2.8)),
            (&half, d(0.4, -0.6)),
            (&quarter, d(0.9, -0.3)),
            (&quarter, d(0.5, 2.2)),
        ];
        for (b, wi) in cases {
            let p =
                chi2_test(200_000, 11, |_, u| b.mitsuba_sample(wi, u).map(|s| s.0), |wo| b.mitsuba_pdf(wi, wo) as f64);
            assert!(p > alpha(cases.len()), "wi {wi}: p = {p}");
        }
    }

    #[test]
    fn sample_weight_is_eval_cos_over_pdf() {
        // Through the BsdfModel contract: `wo` the viewer's side, `wi` sampled.
        let b = synthetic(&[-PI, -PI / 2.0, 0.0], &[0.0, 0.7, 1.4], (6, 5), 6, true);
        let m: &Measured = &b;
        let mut rng = crate::testing::TestRng::new(3);
        let mut checked = 0;
        for wo in [d(0.6, 1.9), d(1.2, -0.4), d(0.1, 2.9)] {
            for _ in 0..2000 {
                let Some(s) = BsdfModel::sample(&m, wo, 0.5, rng.next_2d()) else { continue };
                let (e, p) = (BsdfModel::eval(&m, wo, s.wi) * s.wi.z, BsdfModel::pdf(&m, wo, s.wi));
                assert!(!s.delta && s.eta == 1.0 && s.wi.z > 0.0, "{s:?}");
                assert!((s.weight * s.pdf - e).abs().max_element() <= 1e-3 * e.max_element(), "{s:?} vs {e}");
                // pdf() takes sin θ_m as sqrt(1 - cos² θ_m) (Mitsuba's
                // Frame3f::sin_theta), whose f32 relative error is about
                // 3e-8 / θ_m²; sample() has it from sincos. They agree away
                // from the pole.
                let h = (wo + s.wi).normalize();
                if (h.z as f64).acos() > 0.01 {
                    assert!((s.pdf - p).abs() <= 1e-3 * p, "wo {wo} wi {}: pdf {} vs {p}", s.wi, s.pdf);
                    checked += 1;
                }
            }
        }
        assert!(checked > 4000, "{checked} samples checked");
    }

    #[test]
    fn bad_shapes_are_refused() {
        let mut t = MeasuredTables { phi_i: vec![0.0], theta_i: vec![0.0, 1.0], ..Default::default() };
        t.ndf = (vec![1.0; 4], vec![2, 2]);
        t.sigma = t.ndf.clone();
        t.vndf = (vec![1.0; 8], vec![1, 2, 2, 2]);
        t.luminance = (vec![1.0; 8], vec![1, 2, 2, 2]);
        t.rgb = (vec![1.0; 24], vec![1, 2, 3, 2, 2]);
        assert!(Measured::new(t.clone()).is_ok());
        let mut u = t.clone();
        u.vndf.1 = vec![1, 1, 4, 2];
        assert!(Measured::new(u).unwrap_err().contains("'vndf'"));
        let mut u = t.clone();
        u.rgb = (vec![1.0; 16], vec![1, 2, 2, 2, 2]);
        assert!(Measured::new(u).unwrap_err().contains("'rgb'"));
        let mut u = t;
        u.luminance.0.pop();
        assert!(Measured::new(u).unwrap_err().contains("'luminance'"));
    }
}
