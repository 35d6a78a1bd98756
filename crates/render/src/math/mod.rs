//! Vector math (glam re-exports), constants, colour and small helpers.

pub mod fast;
pub mod frame;

pub use frame::Frame;
pub use glam::{DMat4, Mat3, Mat4, Vec2, Vec3};

/// Linear-sRGB radiance or reflectance. A named alias so that a spectral
/// representation can replace it later without touching the integrators.
pub type Spectrum = Vec3;

/// π.
pub const PI: f32 = std::f32::consts::PI;
/// 1/π.
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
/// 1/(2π).
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
/// 1/(4π): the pdf of a uniform direction on the sphere.
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Relative offset for spawning rays off a surface (Mitsuba's `math::RayEpsilon`).
pub const RAY_EPSILON: f32 = f32::EPSILON * 0.5 * 1500.0;
/// Shadow rays stop this fraction short of the light (Mitsuba's `math::ShadowEpsilon`).
pub const SHADOW_EPSILON: f32 = RAY_EPSILON * 10.0;

/// A stable counting sort of `keys` (each below `buckets`): where each
/// key's group starts (`buckets + 1` offsets, the last the count) and the
/// indices of `keys` grouped by key in key order, each group in index
/// order. Linear, and moves indices rather than what they index.
///
/// ```
/// let (start, order) = penumbra_render::math::counting_order([2, 0, 2, 1].into_iter(), 3);
/// assert_eq!(start, [0, 1, 2, 4]);
/// assert_eq!(order, [1, 3, 0, 2]);
/// ```
pub fn counting_order(keys: impl Iterator<Item = usize> + Clone, buckets: usize) -> (Vec<usize>, Vec<u32>) {
    let mut start = vec![0usize; buckets + 1];
    for k in keys.clone() {
        start[k + 1] += 1;
    }
    for i in 0..buckets {
        start[i + 1] += start[i];
    }
    let mut order = vec![0u32; start[buckets]];
    let mut fill = start.clone();
    for (i, k) in keys.enumerate() {
        order[fill[k]] = i as u32;
        fill[k] += 1;
    }
    (start, order)
}

/// x².
#[inline]
pub fn sqr(x: f32) -> f32 {
    x * x
}

/// √x with negative `x` (from rounding) clamped to 0.
#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// acos of `x` clamped to [-1, 1] (rounding may push a cosine just outside).
#[inline]
pub fn safe_acos(x: f32) -> f32 {
    x.clamp(-1.0, 1.0).acos()
}

/// asin of `x` clamped to [-1, 1].
#[inline]
pub fn safe_asin(x: f32) -> f32 {
    x.clamp(-1.0, 1.0).asin()
}

/// The largest f32 below 1: clamps a uniform number to [0, 1) (Mitsuba's
/// `OneMinusEpsilon`).
pub const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// Rec. 709 luminance of a linear-sRGB colour, with Mitsuba's coefficients.
#[inline]
pub fn luminance(c: Spectrum) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// Converts an f64 scene-description matrix to the f32 one used for rendering.
pub fn mat4_from_f64(m: &DMat4) -> Mat4 {
    m.as_mat4()
}

/// Mitsuba's `look_at`: a camera-to-world matrix whose local +z points from
/// `origin` to `target` and local +y towards `up` (local +x is the image's left).
pub fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let dir = (target - origin).normalize();
    let left = up.normalize().cross(dir).normalize();
    let new_up = dir.cross(left);
    Mat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0))
}
