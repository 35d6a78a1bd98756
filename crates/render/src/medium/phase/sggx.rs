//! Mitsuba 3.9.1's `sggx` (src/phase/sggx.cpp, include/mitsuba/render/microflake.h):
//! the specular SGGX microflake phase function (Heitz et al. 2015, "The
//! SGGX microflake distribution"). The flakes' normal distribution is that
//! of an ellipsoid given by a symmetric positive-definite matrix S, read
//! at each scattering point from a 6-channel volume (S_xx, S_yy, S_zz,
//! S_xy, S_xz, S_yz). Light reflects specularly off a flake:
//! f(wi, wo) = D(h) / (4 σ(wi)), h = normalize(wi + wo), with D the SGGX
//! normal distribution (eq. 9) and σ(wi) = sqrt(wiᵀ S wi) its projected
//! area (eq. 7). Sampling picks a visible normal (§5.2, Heitz et al.'s
//! Appendix) and reflects `wi` about it, so a sample's weight is 1.
//! (Mitsuba's diffuse variant is disabled in its source and absent here.)

use crate::math::{safe_sqrt, Frame, PI};
use crate::sampling::warp::sample_cosine_hemisphere;
use crate::texture::volume::GridVolume;
use glam::{Vec2, Vec3};

/// S_xx, S_yy, S_zz, S_xy, S_xz, S_yz.
pub type SggxParams = [f32; 6];
const XX: usize = 0;
const YY: usize = 1;
const ZZ: usize = 2;
const XY: usize = 3;
const XZ: usize = 4;
const YZ: usize = 5;

/// The SGGX phase function over a 6-channel volume.
#[derive(Debug, Clone, PartialEq)]
pub struct Sggx {
    /// S per point (6 channels).
    pub s: GridVolume,
}

impl Sggx {
    /// The value (and density) at `p` for scattering from `wi` into `wo`.
    #[inline]
    pub fn eval(&self, p: Vec3, wi: Vec3, wo: Vec3) -> f32 {
        eval(&self.s.eval6(p), wi, wo)
    }

    /// An upper bound of σ(w) = sqrt(wᵀ S w) over all points and
    /// directions: σ² ≤ λ_max(S), which is convex in S (so a trilinear
    /// blend of voxels stays below the largest voxel's) and at most the
    /// largest absolute row sum (Gershgorin).
    pub fn projected_area_bound(&self) -> f32 {
        let rows = self.s.grid.data.chunks_exact(6).map(|s| {
            let r0 = s[XX].abs() + s[XY].abs() + s[XZ].abs();
            let r1 = s[XY].abs() + s[YY].abs() + s[YZ].abs();
            let r2 = s[XZ].abs() + s[YZ].abs() + s[ZZ].abs();
            r0.max(r1).max(r2)
        });
        rows.fold(0.0f32, f32::max).sqrt()
    }

    /// A direction reflected about a visible normal at `p`.
    #[inline]
    pub fn sample(&self, p: Vec3, wi: Vec3, u: Vec2) -> Vec3 {
        sample(&self.s.eval6(p), wi, u)
    }
}

/// D(m) = |S|^{3/2} / (π (mᵀ S⁻¹ m)² |S|²) = |S|^{3/2} / (π (mᵀ adj(S) m)²)
/// (Heitz et al. eq. 9 with S⁻¹ = adj(S) / |S|).
pub fn ndf(m: Vec3, s: &SggxParams) -> f32 {
    let det = (s[XX] * s[YY] * s[ZZ] - s[XX] * s[YZ] * s[YZ] - s[YY] * s[XZ] * s[XZ] - s[ZZ] * s[XY] * s[XY]
        + 2.0 * s[XY] * s[XZ] * s[YZ])
        .abs();
    let den = m.x * m.x * (s[YY] * s[ZZ] - s[YZ] * s[YZ])
        + m.y * m.y * (s[XX] * s[ZZ] - s[XZ] * s[XZ])
        + m.z * m.z * (s[XX] * s[YY] - s[XY] * s[XY])
        + 2.0
            * (m.x * m.y * (s[XZ] * s[YZ] - s[ZZ] * s[XY])
                + m.x * m.z * (s[XY] * s[YZ] - s[YY] * s[XZ])
                + m.y * m.z * (s[XY] * s[XZ] - s[XX] * s[YZ]));
    det.max(0.0) * safe_sqrt(det) / (PI * den * den)
}

/// σ(w) = sqrt(wᵀ S w), the flakes' area projected along `w` (eq. 7).
pub fn projected_area(w: Vec3, s: &SggxParams) -> f32 {
    let sigma2 = w.x * w.x * s[XX]
        + w.y * w.y * s[YY]
        + w.z * w.z * s[ZZ]
        + 2.0 * (w.x * w.y * s[XY] + w.x * w.z * s[XZ] + w.y * w.z * s[YZ]);
    safe_sqrt(sigma2)
}

/// The specular microflake phase function D(h) / (4 σ(wi)); 0 for exact
/// forward scattering (wo = −wi), where h is undefined.
pub fn eval(s: &SggxParams, wi: Vec3, wo: Vec3) -> f32 {
    let h = wo + wi;
    let len = h.length();
    if len == 0.0 {
        return 0.0;
    }
    0.25 * ndf(h / len, s) / projected_area(wi, s)
}

/// A normal from the distribution of normals visible from `wi`
/// (Heitz et al.'s Appendix, Mitsuba's `sggx_sample`): S in a frame
/// around `wi`, a cosine-distributed point mapped by the Cholesky-like
/// factor of that matrix.
pub fn sample_visible_normal(s: &SggxParams, wi: Vec3, u: Vec2) -> Vec3 {
    let frame = Frame::from_normal(wi);
    let e = [frame.s, frame.t, frame.n];
    let sw = |v: Vec3| {
        Vec3::new(
            s[XX] * v.x + s[XY] * v.y + s[XZ] * v.z,
            s[XY] * v.x + s[YY] * v.y + s[YZ] * v.z,
            s[XZ] * v.x + s[YZ] * v.y + s[ZZ] * v.z,
        )
    };
    // S in the frame: s2[a][b] = e_a · S e_b.
    let se = [sw(e[0]), sw(e[1]), sw(e[2])];
    visible_normal_in_frame(&frame, |a, b| e[a].dot(se[b]), u)
}

/// The sampling of [`sample_visible_normal`] given S in `frame` as `s2`.
fn visible_normal_in_frame(frame: &Frame, s2: impl Fn(usize, usize) -> f32, u: Vec2) -> Vec3 {
    let (k, j, i) = (0, 1, 2);
    let det = glam::Mat3::from_cols(
        Vec3::new(s2(0, 0), s2(1, 0), s2(2, 0)),
        Vec3::new(s2(0, 1), s2(1, 1), s2(2, 1)),
        Vec3::new(s2(0, 2), s2(1, 2), s2(2, 2)),
    )
    .determinant();
    let inv_sqrt_s_ii = 1.0 / safe_sqrt(s2(i, i));
    let tmp = safe_sqrt(s2(j, j) * s2(i, i) - s2(j, i) * s2(j, i));
    let m_k = Vec3::new(safe_sqrt(det.abs()) / tmp, 0.0, 0.0);
    let m_j = Vec3::new(-inv_sqrt_s_ii * (s2(k, i) * s2(j, i) - s2(k, j) * s2(i, i)) / tmp, inv_sqrt_s_ii * tmp, 0.0);
    let m_i = inv_sqrt_s_ii * Vec3::new(s2(k, i), s2(j, i), s2(i, i));
    let uvw = sample_cosine_hemisphere(u);
    frame.to_world((uvw.x * m_k + uvw.y * m_j + uvw.z * m_i).normalize())
}

/// `wi` reflected about a visible normal.
pub fn sample(s: &SggxParams, wi: Vec3, u: Vec2) -> Vec3 {
    let m = sample_visible_normal(s, wi, u);
    (2.0 * wi.dot(m) * m - wi).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{chi2_cases, chi2_test, integrate_over_sphere};

    /// S = R diag(a², b², c²) Rᵀ for a rotation R (an ellipsoid's axes).
    fn rotated(diag: Vec3, axis: Vec3, angle: f32) -> SggxParams {
        let r = glam::Mat3::from_axis_angle(axis.normalize(), angle);
        let m = r * glam::Mat3::from_diagonal(diag) * r.transpose();
        [m.x_axis.x, m.y_axis.y, m.z_axis.z, m.y_axis.x, m.z_axis.x, m.z_axis.y]
    }

    fn cases() -> Vec<(SggxParams, Vec3)> {
        let wi = Vec3::new(0.3, -0.5, 0.8).normalize();
        vec![
            // A sphere: isotropic normals.
            ([1.0, 1.0, 1.0, 0.0, 0.0, 0.0], wi),
            // Surface-like flakes (normals near ±z), seen from the side and from above.
            ([0.05, 0.05, 1.0, 0.0, 0.0, 0.0], Vec3::X),
            ([0.05, 0.05, 1.0, 0.0, 0.0, 0.0], wi),
            // Fibre-like (normals near the xy plane).
            ([1.0, 1.0, 0.02, 0.0, 0.0, 0.0], wi),
            // Off-diagonal terms: a rotated, anisotropic ellipsoid.
            (rotated(Vec3::new(1.0, 0.3, 0.05), Vec3::new(1.0, 2.0, -0.5), 0.9), wi),
            (rotated(Vec3::new(0.2, 1.0, 0.6), Vec3::new(-0.3, 0.2, 1.0), 2.1), -Vec3::Z),
        ]
    }

    /// Visible-normal sampling reflected about the normal follows
    /// D(h) / (4 σ(wi)) (chi-square), and a wrong S is rejected (power).
    #[test]
    fn sampling_matches_the_density_chi2() {
        let a = chi2_cases(
            "sggx",
            300_000,
            9100,
            &cases(),
            |s, wi, _, u| Some(sample(s, wi, u)),
            |s, wi, wo| eval(s, wi, wo) as f64,
        );
        let wi = Vec3::new(0.3, -0.5, 0.8).normalize();
        let s = rotated(Vec3::new(1.0, 0.3, 0.05), Vec3::new(1.0, 2.0, -0.5), 0.9);
        let wrong = rotated(Vec3::new(1.0, 0.3, 0.05), Vec3::new(1.0, 2.0, -0.5), 1.0);
        let p = chi2_test(300_000, 1, |_, u| Some(sample(&s, wi, u)), |wo| eval(&wrong, wi, wo) as f64);
        assert!(p < a, "S rotated by 0.1 rad was not detected: p = {p}");
        // Mitsuba 3.9.1's sggx_sample: S taken into the frame with the
        // transposed rotation (s2 = E S Eᵀ, E's columns the frame's axes,
        // where Eᵀ S E is meant) samples another density than its pdf.
        let mitsuba = |wi: Vec3, u: Vec2| {
            let f = Frame::from_normal(wi);
            let e = glam::Mat3::from_cols(f.s, f.t, f.n);
            let m = glam::Mat3::from_cols(
                Vec3::new(s[XX], s[XY], s[XZ]),
                Vec3::new(s[XY], s[YY], s[YZ]),
                Vec3::new(s[XZ], s[YZ], s[ZZ]),
            );
            let s2 = e * m * e.transpose();
            let n = visible_normal_in_frame(&f, |a, b| s2.col(b)[a], u);
            (2.0 * wi.dot(n) * n - wi).normalize()
        };
        let p = chi2_test(300_000, 2, |_, u| Some(mitsuba(wi, u)), |wo| eval(&s, wi, wo) as f64);
        assert!(p < a, "Mitsuba's transposed frame was not detected: p = {p}");
    }

    /// The phase function integrates to 1, and σ is D's projected area,
    /// σ(w) = ∫ ⟨w, m⟩₊ D(m) dm (eq. 7), for a few directions; a
    /// sphere's S gives D = 1/π and σ = 1.
    #[test]
    fn normalised() {
        for (s, wi) in cases() {
            let total = integrate_over_sphere(|wo| eval(&s, wi, wo) as f64);
            assert!((total - 1.0).abs() < 5e-3, "{s:?}: integral of f = {total}");
            for w in [wi, Vec3::X, Vec3::new(-0.2, 0.9, 0.4).normalize()] {
                let area = integrate_over_sphere(|m| (w.dot(m).max(0.0) * ndf(m, &s)) as f64);
                let sigma = projected_area(w, &s) as f64;
                assert!((area - sigma).abs() < 5e-3 * sigma, "{s:?}: projected area {area}, sigma {sigma}");
            }
        }
        let iso = [1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
        assert!((ndf(Vec3::Y, &iso) - 1.0 / PI).abs() < 1e-6);
        assert!((projected_area(Vec3::new(0.6, 0.0, 0.8), &iso) - 1.0).abs() < 1e-6);
    }
}
