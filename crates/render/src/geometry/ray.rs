//! Rays and the offsets that keep spawned rays from re-hitting their surface.

use crate::math::RAY_EPSILON;
use crate::simd::{Float, V3};
use glam::Vec3;

/// A ray `o + t d` for t in (0, t_max). `d` need not be normalised for
/// intersection, but integrators keep it unit length so `t` is a distance.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Direction.
    pub d: Vec3,
    /// Upper bound of the open interval of t searched for hits.
    pub t_max: f32,
}

impl Ray {
    /// The ray `o + t d`, t in (0, t_max).
    #[inline]
    pub fn new(o: Vec3, d: Vec3, t_max: f32) -> Ray {
        Ray { o, d, t_max }
    }
    /// The point `o + t d`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// Offsets a surface point along the geometric normal `n`, to the side that
/// `d` leaves towards, by a margin relative to the point's magnitude
/// (Mitsuba's `spawn_ray`: RayEpsilon · (1 + max |p_i|)).
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, d: Vec3) -> Vec3 {
    let mag = (1.0 + p.abs().max_element()) * RAY_EPSILON;
    let off = n * mag;
    if d.dot(n) < 0.0 {
        p - off
    } else {
        p + off
    }
}

/// `F::WIDTH` rays side by side, a component per vector.
#[derive(Debug, Clone, Copy)]
pub struct RayLanes<F> {
    /// The origins.
    pub o: V3<F>,
    /// The directions.
    pub d: V3<F>,
    /// The upper bounds of t.
    pub t_max: F,
}

impl<F: Float> RayLanes<F> {
    /// Each lane's ray, in lane order (every row stored to an array once).
    #[inline(always)]
    pub fn rays(&self) -> impl Iterator<Item = Ray> {
        let a = |v: F| v.to_array();
        let (o, d) = ([a(self.o.x), a(self.o.y), a(self.o.z)], [a(self.d.x), a(self.d.y), a(self.d.z)]);
        let t_max = a(self.t_max);
        (0..F::WIDTH).map(move |l| {
            let at = |v: &[F::Array; 3]| Vec3::new(v[0].as_ref()[l], v[1].as_ref()[l], v[2].as_ref()[l]);
            Ray::new(at(&o), at(&d), t_max.as_ref()[l])
        })
    }
}
