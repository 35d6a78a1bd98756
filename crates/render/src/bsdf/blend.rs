//! Mitsuba `blendbsdf` at a hit: (1 − weight) · first + weight · second,
//! with Mitsuba 3.9.1's sampling (src/bsdfs/blendbsdf.cpp): `u` picks the
//! second BSDF when u ≤ weight, the chosen one samples a direction, and the
//! sample carries the mixture's pdf, w₀·p₀ + w₁·p₁, and the mixture's value
//! over it: (w₀·f₀·cos + w₁·f₁·cos) / pdf. For a delta sample Mitsuba mixes
//! the lobe's discrete probability with the other BSDF's density in the same
//! way; Penumbra does exactly the same, to render the same image.
//!
//! The two nested BSDFs are resolved once per hit, with their own shading
//! frames (nested wrappers may change it: `twosided`, `normalmap`, ...),
//! into the sample's scratch memory (see `material::Scratch`). Directions
//! are mapped between the blend's shading frame and each nested one's, and
//! cosines are taken in the nested frame, as Mitsuba's nested BSDFs do.

use super::{Bsdf, BsdfModel, BsdfSample};
use crate::math::{Frame, Spectrum, ONE_MINUS_EPS};
use glam::{Vec2, Vec3};

/// The per-hit blend: two nested BSDFs and the second one's weight.
#[derive(Debug, Clone, Copy)]
pub struct Blend<'a> {
    /// The second BSDF's weight, clamped to [0, 1].
    pub weight: f32,
    /// Weighted by 1 − `weight`.
    pub first: &'a Nested<'a>,
    /// Weighted by `weight`.
    pub second: &'a Nested<'a>,
}

/// A nested BSDF and the map from the blend's local frame to its own.
#[derive(Debug, Clone, Copy)]
pub struct Nested<'a> {
    /// The nested BSDF, working in its own shading frame.
    pub bsdf: Bsdf<'a>,
    /// Rows of the change of basis (None when the frames agree).
    map: Option<[Vec3; 3]>,
}

impl<'a> Nested<'a> {
    /// `bsdf`, resolved in shading frame `nested` at a hit whose blend is
    /// evaluated in frame `blend`.
    pub fn new(bsdf: Bsdf<'a>, blend: Frame, nested: Frame) -> Nested<'a> {
        let (a, b) = (blend, nested);
        let map = if a.s == b.s && a.t == b.t && a.n == b.n {
            None
        } else {
            // Row k: nested axis k in blend-local coordinates.
            Some([a.to_local(b.s), a.to_local(b.t), a.to_local(b.n)])
        };
        Nested { bsdf, map }
    }

    #[inline]
    fn in_nested(&self, w: Vec3) -> Vec3 {
        match self.map {
            None => w,
            Some(m) => Vec3::new(m[0].dot(w), m[1].dot(w), m[2].dot(w)),
        }
    }

    #[inline]
    fn in_blend(&self, w: Vec3) -> Vec3 {
        match self.map {
            None => w,
            Some(m) => m[0] * w.x + m[1] * w.y + m[2] * w.z,
        }
    }

    /// f · |cos θ_i| in the nested frame, and the pdf, for blend-local directions.
    #[inline]
    fn eval_cos_pdf(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        let (wo, wi) = (self.in_nested(wo), self.in_nested(wi));
        (self.bsdf.eval(wo, wi) * wi.z.abs(), self.bsdf.pdf(wo, wi))
    }
}

impl Blend<'_> {
    /// f · |cos θ_i| of the mixture (cosines in each nested frame) and its pdf.
    fn eval_cos_pdf(&self, wo: Vec3, wi: Vec3) -> (Spectrum, f32) {
        let w = self.weight;
        let mut f = Spectrum::ZERO;
        let mut p = 0.0;
        if w < 1.0 {
            let (f0, p0) = self.first.eval_cos_pdf(wo, wi);
            f += f0 * (1.0 - w);
            p += p0 * (1.0 - w);
        }
        if w > 0.0 {
            let (f1, p1) = self.second.eval_cos_pdf(wo, wi);
            f += f1 * w;
            p += p1 * w;
        }
        (f, p)
    }
}

impl Blend<'_> {
    /// The mixture's straight-through part (see [`Bsdf::null_transmission`]).
    pub fn null_transmission(&self, wo: Vec3) -> Spectrum {
        let w = self.weight;
        self.first.bsdf.null_transmission(self.first.in_nested(wo)) * (1.0 - w)
            + self.second.bsdf.null_transmission(self.second.in_nested(wo)) * w
    }
}

impl BsdfModel for Blend<'_> {
    /// Whether either nested BSDF has a non-delta lobe.
    fn has_smooth(&self) -> bool {
        (self.weight < 1.0 && self.first.bsdf.has_smooth()) || (self.weight > 0.0 && self.second.bsdf.has_smooth())
    }

    /// f without the cosine of the blend's frame (Penumbra's contract).
    fn eval(&self, wo: Vec3, wi: Vec3) -> Spectrum {
        if wi.z == 0.0 {
            return Spectrum::ZERO;
        }
        self.eval_cos_pdf(wo, wi).0 / wi.z.abs()
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval_cos_pdf(wo, wi).1
    }

    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    fn sample(&self, wo: Vec3, u: f32, u2: Vec2) -> Option<BsdfSample> {
        let w = self.weight;
        // Mitsuba: the second BSDF when u ≤ weight, its number rescaled.
        let (chosen, other, w_chosen, u) = if u > w {
            (self.first, self.second, 1.0 - w, (u - w) / (1.0 - w))
        } else {
            (self.second, self.first, w, if w > 0.0 { u / w } else { 0.0 })
        };
        let s = chosen.bsdf.sample(chosen.in_nested(wo), u.min(ONE_MINUS_EPS), u2)?;
        let wi = chosen.in_blend(s.wi);
        let w_other = 1.0 - w_chosen;
        let (f_other, p_other) = if w_other > 0.0 { other.eval_cos_pdf(wo, wi) } else { (Spectrum::ZERO, 0.0) };
        let pdf = w_chosen * s.pdf + w_other * p_other;
        if !(pdf > 0.0) {
            return None;
        }
        let weight = (s.weight * (w_chosen * s.pdf) + f_other * w_other) / pdf;
        Some(BsdfSample { wi, pdf, weight, delta: s.delta, null: s.null, eta: s.eta })
    }
}
