//! Fresnel equations for dielectrics and conductors (unpolarised light).

use crate::math::{safe_sqrt, Spectrum};
use glam::Vec3;

/// Dielectric Fresnel reflectance for relative IOR `eta` = n_inside / n_outside.
///
/// `cos_i` is signed: negative when the incident direction is inside.
/// Returns (R, cos_t, eta_it, eta_ti) with `cos_t` signed opposite to `cos_i`
/// (the transmitted direction's cosine), exactly as Mitsuba's `fresnel()`.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_t_sqr = (-(-cos_i).mul_add(cos_i, 1.0)).mul_add(eta_ti * eta_ti, 1.0);
    let ci = cos_i.abs();
    let ct = safe_sqrt(cos_t_sqr);
    let r = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        // Amplitudes of the s- and p-polarised components (total internal
        // reflection gives ct = 0, hence |a_s| = |a_p| = 1).
        let a_s = (eta_it * ct - ci) / (eta_it * ct + ci);
        let a_p = (eta_it * ci - ct) / (eta_it * ci + ct);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    (r, if outside { -ct } else { ct }, eta_it, eta_ti)
}

/// Conductor Fresnel reflectance for complex IOR eta + i k, per channel
/// (the exact unpolarised formula, as Mitsuba's `fresnel_conductor`).
#[inline]
pub fn fresnel_conductor(cos_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    Vec3::new(
        fresnel_conductor_1(cos_i, eta.x, k.x),
        fresnel_conductor_1(cos_i, eta.y, k.y),
        fresnel_conductor_1(cos_i, eta.z, k.z),
    )
}

fn fresnel_conductor_1(cos_i: f32, eta_r: f32, eta_i: f32) -> f32 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let temp1 = eta_r * eta_r - eta_i * eta_i - s2;
    let a2pb2 = safe_sqrt(temp1 * temp1 + 4.0 * eta_i * eta_i * eta_r * eta_r);
    let a = safe_sqrt(0.5 * (a2pb2 + temp1));
    let term1 = a2pb2 + c2;
    let term2 = 2.0 * cos_i * a;
    let r_s = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * c2 + s4;
    let term4 = term2 * s2;
    let r_p = r_s * (term3 - term4) / (term3 + term4);
    0.5 * (r_s + r_p)
}

/// Mirror reflection about the local +z axis.
#[inline]
pub fn reflect(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// Refraction in local coordinates given the signed transmitted cosine.
#[inline]
pub fn refract(w: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    Vec3::new(-eta_ti * w.x, -eta_ti * w.y, cos_t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_limits() {
        // Normal incidence: ((n-1)/(n+1))².
        let (r, ct, eta_it, _) = fresnel_dielectric(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-6 && (ct + 1.0).abs() < 1e-6 && eta_it == 1.5);
        // Grazing: total reflection; inside beyond the critical angle: TIR.
        assert_eq!(fresnel_dielectric(0.0, 1.5).0, 1.0);
        assert!((fresnel_dielectric(-0.3, 1.5).0 - 1.0).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(0.5, 1.0).0, 0.0);
        // Reciprocity of the transmitted energy: T(θ_i) seen from both sides.
        let (r1, ct, _, _) = fresnel_dielectric(0.7, 1.5);
        let (r2, _, _, _) = fresnel_dielectric(ct, 1.5);
        assert!((r1 - r2).abs() < 1e-5);
    }

    #[test]
    fn conductor_limits() {
        // k = 0 reduces to the dielectric formula; eta = 0, k = 1 is a perfect mirror.
        for c in [1.0, 0.6, 0.2] {
            let d = fresnel_dielectric(c, 1.5).0;
            let f = fresnel_conductor(c, Vec3::splat(1.5), Vec3::ZERO);
            assert!((f.x - d).abs() < 1e-5, "{c}: {} vs {d}", f.x);
            let m = fresnel_conductor(c, Vec3::ZERO, Vec3::ONE);
            assert!((m.x - 1.0).abs() < 1e-6);
        }
    }
}
