//! Mitsuba's `linearcurve` and `bsplinecurve`: tubes of varying radius
//! through control points (x, y, z, r), one BVH primitive per segment.
//!
//! ## Linear curves
//!
//! Mitsuba 3.9.1 (`src/shapes/linearcurve.cpp`) hands the control points
//! to Embree as round linear curves (`RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE`,
//! built with `EMBREE_BACKFACE_CULLING_CURVES`). Each segment from p0/r0 to
//! p1/r1 is then the cone touching both spheres tangentially, with the
//! spheres as caps: the convex hull of the two spheres (the larger sphere
//! alone when it holds the other). A curve is the union of its segments, so
//! joints are round and the ends are spherical caps. Embree gives each
//! point of the surface to one segment (from the neighbour flags it derives
//! from the index buffer): a joint's sphere belongs to the segment ending
//! there, the start sphere only to a curve's first segment. Back faces are
//! culled: a segment is hit only where a ray enters it, never from inside.
//!
//! Embree reports the hit's curve parameter u (the centre of the sphere
//! touching the surface there: y / (|Δp|² − Δr²) with y = (h − p0)·Δp +
//! r0 Δr on the cone, 0 and 1 on the caps), from which Mitsuba derives the
//! normal n = normalize(p − c(u)), c(u) = (1 − u) p0 + u p1, and its uv:
//! u_tex = the angle about the segment's axis (from a frame whose rotation
//! axis leans towards +z) / 2π, v_tex = (u + segment) / segments, with
//! dp/du = 2π axis × (p − c) and dp/dv = segments · (Δp + Δr n).
//!
//! ## B-spline curves
//!
//! Mitsuba 3.9.1 (`src/shapes/bsplinecurve.cpp`) hands the control points
//! to Embree as round B-spline curves (`RTC_GEOMETRY_TYPE_ROUND_BSPLINE_CURVE`):
//! segment k is the uniform cubic B-spline of points k..k+3, centre c(v)
//! and radius r(v) interpolated alike, and the surface is swept by the
//! circle of radius r(v) about c(v) perpendicular to c'(v), open at the
//! curve's ends (no caps), back faces culled. A hit solves
//! |o + t d − c(v)|² = r(v)² and (o + t d − c(v)) · c'(v) = 0 for (t, v):
//! here by Newton's method, started from the entries of the ray into a
//! chain of 16 round linear pieces through c and r (the linear curve above),
//! each widened to hold the tube, kept where v lies in [0, 1] and the ray
//! enters the surface. Mitsuba's
//! normal is ∝ (|c'|² − (p − c)·c'') (p − c) − r r' c', its uv the angle
//! about c' (from the frame of the linear curves) / 2π and (v + segment) /
//! segments, its dp/du and dp/dv from the Frenet frame.

use super::{Aabb, Ray};
use glam::{DVec3, Vec2, Vec3, Vec4};

/// Curves: control points and the segments between them.
#[derive(Debug, Clone)]
pub struct Curves {
    /// Control points in world space (x, y, z) with their radius (w).
    pub points: Vec<Vec4>,
    /// Each segment's first control point (linear: it and the next one;
    /// B-spline: it and the next three).
    pub segments: Vec<u32>,
    /// How the control points are interpolated.
    pub basis: Basis,
}

/// The interpolation of a curve's control points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Basis {
    /// Mitsuba `linearcurve`.
    Linear,
    /// Mitsuba `bsplinecurve` (uniform cubic B-spline).
    BSpline,
}

/// Pieces per B-spline segment in the linear chain that seeds Newton's method.
const PIECES: usize = 16;

/// A B-spline segment at v: centre, c', c'', c''', radius, r', r''
/// (Mitsuba's `cubic_interpolation`).
#[derive(Debug, Clone, Copy)]
struct Spline {
    c: DVec3,
    dc: DVec3,
    ddc: DVec3,
    dddc: DVec3,
    r: f64,
    dr: f64,
}

fn spline(p: &[Vec4; 4], v: f64) -> Spline {
    let (v2, v3) = (v * v, v * v * v);
    let b = [
        (-v3 + 3.0 * v2 - 3.0 * v + 1.0) / 6.0,
        (3.0 * v3 - 6.0 * v2 + 4.0) / 6.0,
        (-3.0 * v3 + 3.0 * v2 + 3.0 * v + 1.0) / 6.0,
        v3 / 6.0,
    ];
    let db = [
        (-3.0 * v2 + 6.0 * v - 3.0) / 6.0,
        (9.0 * v2 - 12.0 * v) / 6.0,
        (-9.0 * v2 + 6.0 * v + 3.0) / 6.0,
        3.0 * v2 / 6.0,
    ];
    let ddb = [1.0 - v, 3.0 * v - 2.0, 1.0 - 3.0 * v, v];
    let dddb = [-1.0, 3.0, -3.0, 1.0];
    let mut s = Spline { c: DVec3::ZERO, dc: DVec3::ZERO, ddc: DVec3::ZERO, dddc: DVec3::ZERO, r: 0.0, dr: 0.0 };
    for k in 0..4 {
        let (q, w) = (p[k].truncate().as_dvec3(), p[k].w as f64);
        s.c += b[k] * q;
        s.dc += db[k] * q;
        s.ddc += ddb[k] * q;
        s.dddc += dddb[k] * q;
        s.r += b[k] * w;
        s.dr += db[k] * w;
    }
    s
}

/// Which part of a segment a hit is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    Cone,
    Start,
    End,
}

impl Curves {
    /// Number of segments (the BVH's primitives).
    pub fn segment_count(&self) -> usize {
        self.segments.len()
    }

    fn ends(&self, i: usize) -> (Vec4, Vec4) {
        let k = self.segments[i] as usize;
        (self.points[k], self.points[k + 1])
    }

    fn controls(&self, i: usize) -> [Vec4; 4] {
        let k = self.segments[i] as usize;
        [self.points[k], self.points[k + 1], self.points[k + 2], self.points[k + 3]]
    }

    /// The box of segment `i`: the boxes of its end spheres (linear), or of
    /// the chain of widened pieces that seeds the B-spline's intersection.
    pub fn bounds(&self, i: usize) -> Aabb {
        if self.basis == Basis::BSpline {
            // The seeding chain holds all that can be hit, tighter than the controls.
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for (a, b) in chain(&self.controls(i)) {
                for s in [a, b] {
                    lo = lo.min(s.truncate() - Vec3::splat(s.w));
                    hi = hi.max(s.truncate() + Vec3::splat(s.w));
                }
            }
            let pad = 1e-6 * (lo.abs().max(hi.abs()).max_element());
            return Aabb { min: lo - Vec3::splat(pad), max: hi + Vec3::splat(pad) };
        }
        let (a, b) = self.ends(i);
        let lo = (a.truncate() - Vec3::splat(a.w)).min(b.truncate() - Vec3::splat(b.w));
        let hi = (a.truncate() + Vec3::splat(a.w)).max(b.truncate() + Vec3::splat(b.w));
        let pad = 1e-6 * (lo.abs().max(hi.abs()).max_element());
        Aabb { min: lo - Vec3::splat(pad), max: hi + Vec3::splat(pad) }
    }

    /// Where the ray enters segment `i` (0 < t < ray.t_max), with Embree's
    /// curve parameter in the result's x (see the module docs); None for a
    /// miss or a ray starting inside the segment (culled).
    pub fn intersect(&self, i: usize, ray: &Ray) -> Option<(f32, Vec2)> {
        let (o, d) = (ray.o.as_dvec3(), ray.d.as_dvec3());
        let (t, u) = match self.basis {
            Basis::Linear => {
                let (a, b) = self.ends(i);
                let k = self.segments[i];
                let left = i > 0 && self.segments[i - 1] + 1 == k;
                let right = self.segments.get(i + 1).is_some_and(|&n| n == k + 1);
                let next = right.then(|| self.points[k as usize + 2]);
                enter_segment(a, b, !left, next, o, d)?
            }
            Basis::BSpline => enter_bspline(&self.controls(i), o, d, ray.t_max as f64)?,
        };
        let tf = t as f32;
        (t > 0.0 && tf > 0.0 && tf < ray.t_max).then_some((tf, Vec2::new(u as f32, 0.0)))
    }

    /// (p, normal, uv, dp/du, dp/dv) of the hit at `t` with curve parameter
    /// `u` on segment `i`, as Mitsuba's `linearcurve` and `bsplinecurve` compute them.
    pub fn interaction(&self, i: usize, ray: &Ray, t: f32, u: f32) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        if self.basis == Basis::BSpline {
            return self.bspline_interaction(i, ray, t, u);
        }
        let (a, b) = self.ends(i);
        let (p0, p1) = (a.truncate(), b.truncate());
        let p = ray.o + ray.d * t;
        let c = p0 * (1.0 - u) + p1 * u;
        let n = (p - c).normalize_or_zero();
        let axis = (p1 - p0).normalize_or_zero();
        let (rot, rad) = local_frame(axis);
        let mut phi = rot.dot(n).atan2(rad.dot(n));
        if phi < 0.0 {
            phi += std::f32::consts::TAU;
        }
        let count = self.segments.len() as f32;
        let uv = Vec2::new(phi / std::f32::consts::TAU, (u + i as f32) / count);
        let dpdu = std::f32::consts::TAU * axis.cross(p - c);
        let dpdv = count * ((p1 - p0) + (b.w - a.w) * n);
        (p, n, uv, dpdu, dpdv)
    }
}

impl Curves {
    fn bspline_interaction(&self, i: usize, ray: &Ray, t: f32, v: f32) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        let sp = spline(&self.controls(i), v as f64);
        let p = ray.o + ray.d * t;
        let q = p.as_dvec3() - sp.c;
        let n = ((sp.dc.length_squared() - q.dot(sp.ddc)) * q - (sp.dr * sp.r) * sp.dc).normalize_or_zero();
        let axis = sp.dc.normalize_or_zero();
        let (rot, rad_dir) = local_frame(axis.as_vec3());
        let (rot, rad_dir) = (rot.as_dvec3(), rad_dir.as_dvec3());
        let qn = q.normalize_or_zero();
        let mut phi = rot.dot(qn).atan2(rad_dir.dot(qn));
        if phi < 0.0 {
            phi += std::f64::consts::TAU;
        }
        let count = self.segments.len() as f64;
        let u = phi / std::f64::consts::TAU;
        let uv = Vec2::new(u as f32, ((v as f64 + i as f64) / count) as f32);
        // Mitsuba's `partials`: the Frenet frame, its curvature and torsion.
        let len = sp.dc.length();
        let cross = sp.dc.cross(sp.ddc);
        let cross_len = cross.length();
        let mut kappa = cross_len / (len * len * len);
        let mut tau = if cross_len < 1e-6 || sp.dddc.length() < 1e-6 {
            0.0
        } else {
            sp.dddc.dot(cross) / (cross_len * cross_len)
        };
        let ft = sp.dc / len;
        let (mut fn_, mut fb) = (cross.cross(sp.dc).normalize(), DVec3::ZERO);
        fb = if kappa < f32::EPSILON as f64 { fb } else { ft.cross(fn_).normalize() };
        if kappa < f32::EPSILON as f64 {
            kappa = 0.0;
            tau = 0.0;
            let f = crate::math::Frame::from_normal(ft.as_vec3());
            (fn_, fb) = (f.s.as_dvec3(), f.t.as_dvec3());
        }
        let (s_, c_) = (u * std::f64::consts::TAU).sin_cos();
        let rad = c_ * rad_dir + s_ * rot;
        let (cos_t, sin_t) = (fn_.dot(rad), fb.dot(rad));
        let radu = -sin_t * fn_ + cos_t * fb;
        let radv = len * cos_t * (-kappa * ft + tau * fb) + len * sin_t * (-tau * fn_);
        let dpdu = std::f64::consts::TAU * sp.r * radu;
        let dpdv = count * (sp.dc + sp.dr * rad + sp.r * radv);
        (p, n.as_vec3(), uv, dpdu.as_vec3(), dpdv.as_vec3())
    }
}

/// The entry (t, v) of the line o + t d into B-spline segment `p`: Newton's
/// method on (t, v) from each entry into the chain of linear pieces (see
/// the module docs); the closest solution with v in [0, 1], 0 < t < t_max,
/// where the ray enters the surface.
fn enter_bspline(p: &[Vec4; 4], o: DVec3, d: DVec3, t_max: f64) -> Option<(f64, f64)> {
    let pieces = chain(p);
    let mut best: Option<(f64, f64)> = None;
    for (j, &(a, b)) in pieces.iter().enumerate() {
        // Skip pieces whose bounding sphere the line misses (most of them).
        let (ac, bc) = (a.truncate().as_dvec3(), b.truncate().as_dvec3());
        let reach = 0.5 * (ac - bc).length() + a.w.max(b.w) as f64;
        let m = 0.5 * (ac + bc) - o;
        let off = m - d * (m.dot(d) / d.length_squared());
        if off.length_squared() > 1.0001 * reach * reach + 1e-12 {
            continue;
        }
        let Some((t0, u0)) = enter_piece(a, b, o, d) else { continue };
        let (mut t, mut v) = (t0, (j as f64 + u0) / PIECES as f64);
        let mut converged = false;
        for _ in 0..24 {
            let s = spline(p, v);
            let q = o + d * t - s.c;
            let f = q.length_squared() - s.r * s.r;
            let g = q.dot(s.dc);
            // Jacobian of (f, g) in (t, v).
            let (ft, fv) = (2.0 * q.dot(d), -2.0 * g - 2.0 * s.r * s.dr);
            let (gt, gv) = (d.dot(s.dc), q.dot(s.ddc) - s.dc.length_squared());
            let det = ft * gv - fv * gt;
            if det == 0.0 || !det.is_finite() {
                break;
            }
            let dt = (f * gv - fv * g) / det;
            let dv = (ft * g - gt * f) / det;
            t -= dt;
            v -= dv.clamp(-0.5, 0.5);
            if dt.abs() < 1e-9 * (1.0 + t.abs()) && dv.abs() < 1e-9 {
                converged = true;
                break;
            }
        }
        if !converged || !(0.0..=1.0).contains(&v) || t <= 0.0 || t >= t_max || best.is_some_and(|b| b.0 <= t) {
            continue;
        }
        let s = spline(p, v);
        let q = o + d * t - s.c;
        let n = (s.dc.length_squared() - q.dot(s.ddc)) * q - (s.dr * s.r) * s.dc;
        if n.dot(d) < 0.0 {
            best = Some((t, v));
        }
    }
    best
}

/// The chain of round linear pieces that seeds Newton's method on B-spline
/// segment `p`: the spheres (centre, radius) at v = j / PIECES, each piece
/// widened by 1.5 times how far the curve strays from it at its middle (and
/// a little), so that the chain holds the whole tube.
fn chain(p: &[Vec4; 4]) -> [(Vec4, Vec4); PIECES] {
    let node = |j: usize| spline(p, j as f64 / PIECES as f64);
    let mut a = node(0);
    std::array::from_fn(|j| {
        let b = node(j + 1);
        let mid = spline(p, (j as f64 + 0.5) / PIECES as f64);
        let sag = (mid.c - 0.5 * (a.c + b.c)).length() + (mid.r - 0.5 * (a.r + b.r)).abs();
        let sphere = |s: &Spline| s.c.as_vec3().extend((s.r + 1.5 * sag) as f32 * (1.0 + 1e-5) + 1e-7);
        let piece = (sphere(&a), sphere(&b));
        a = b;
        piece
    })
}

/// [`enter_segment`] without culling: the entry (t, u) of the line into the
/// hull of two spheres, also behind the origin or from inside (a start for
/// Newton's method).
fn enter_piece(a: Vec4, b: Vec4, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let back = 4.0 * (a.w.max(b.w) as f64 + (a - b).truncate().length() as f64) / d.length();
    let (t, u) = enter_segment(a, b, true, None, o - d * back, d)?;
    Some((t - back, u))
}

/// Mitsuba's `local_frame`: a rotation axis in the plane of `axis` and +z
/// (+y when `axis` is ±z), and the radial direction rot × axis.
fn local_frame(axis: Vec3) -> (Vec3, Vec3) {
    let guide = Vec3::Z;
    let rot = if guide.dot(axis).abs() == 1.0 { Vec3::Y } else { (guide - axis * axis.dot(guide)).normalize() };
    (rot, rot.cross(axis))
}

/// The entry of the line o + t d into a sphere (smaller root), if it meets it.
fn sphere_entry(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<f64> {
    let dd = d.length_squared();
    let f = o - c;
    let b = f.dot(d);
    // The foot of the perpendicular, for precision (Haines et al. 2019).
    let l = f - (b / dd) * d;
    let disc = dd * (r * r - l.length_squared());
    if disc < 0.0 {
        return None;
    }
    Some((-b - disc.sqrt()) / dd)
}

/// The entry (t, u) of the line o + t d into the convex hull of the
/// spheres a (centre xyz, radius w) and b, t > 0 (None for an origin inside).
///
/// As Embree splits a curve among its segments, so that each point of
/// the surface belongs to one segment (and the hits at a joint to the
/// segment that ends there): the start sphere counts only with `start`
/// (a segment without a left neighbour), and with the right neighbour's
/// end point `next` the end sphere's hits past the plane where the next
/// segment's cone starts are left to that segment.
fn enter_segment(a: Vec4, b: Vec4, start: bool, next: Option<Vec4>, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let (p0, r0) = (a.truncate().as_dvec3(), a.w as f64);
    let (p1, r1) = (b.truncate().as_dvec3(), b.w as f64);
    // Work from the point of the line nearest the segment's middle.
    let dd = d.length_squared();
    let mid = 0.5 * (p0 + p1);
    let dt = (mid - o).dot(d) / dd;
    let o = o + d * dt;
    let dp = p1 - p0;
    let dr = r1 - r0;
    let g = dp.length_squared() - dr * dr;
    let mut best: Option<(f64, Part)> = None;
    let mut consider = |t: f64, part: Part| {
        if best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, part));
        }
    };
    // y of a point h: 0 on the start sphere's tangent circle, g on the end one's.
    let y_of = |h: DVec3| (h - p0).dot(dp) + r0 * dr;
    if g <= 0.0 {
        // One sphere holds the other: the segment is the larger sphere.
        let (c, r, part) = if r0 >= r1 { (p0, r0, Part::Start) } else { (p1, r1, Part::End) };
        if let Some(t) = sphere_entry(o, d, c, r) {
            consider(t, part);
        }
    } else {
        // The cone's lateral surface: (dP² − dr²)|h|² − (h·dP)² − r0² dP² − 2 r0 dr (h·dP) = 0
        // for h relative to p0 (Embree's derivation), between the tangent circles.
        let h0 = o - p0;
        let (od, odp, hdp) = (d.dot(h0), d.dot(dp), h0.dot(dp));
        let qa = g * dd - odp * odp;
        let qb = 2.0 * (g * od - odp * (hdp + r0 * dr));
        let qc = g * h0.length_squared() - hdp * hdp - r0 * r0 * dp.length_squared() - 2.0 * r0 * dr * hdp;
        let disc = qb * qb - 4.0 * qa * qc;
        if qa.abs() > 1e-300 && disc >= 0.0 {
            let q = -0.5 * (qb + disc.sqrt().copysign(qb));
            for t in [q / qa, qc / q] {
                if !t.is_finite() {
                    continue;
                }
                let h = o + d * t;
                let y = y_of(h);
                // The outward normal g (h − p0) − dP y; an entry faces the ray.
                let n = g * (h - p0) - dp * y;
                if (0.0..=g).contains(&y) && n.dot(d) < 0.0 {
                    consider(t, Part::Cone);
                }
            }
        }
        // The caps: the parts of the spheres beyond the tangent circles.
        if start {
            if let Some(t) = sphere_entry(o, d, p0, r0) {
                if y_of(o + d * t) <= 0.0 {
                    consider(t, Part::Start);
                }
            }
        }
        if let Some(t) = sphere_entry(o, d, p1, r1) {
            let h = o + d * t;
            let past_next = next.is_some_and(|n| {
                let (p2, r2) = (n.truncate().as_dvec3(), n.w as f64);
                (h - p1).dot(p2 - p1) + r1 * (r2 - r1) > 0.0
            });
            if y_of(h) >= g && !past_next {
                consider(t, Part::End);
            }
        }
    }
    let (t, part) = best?;
    let u = match part {
        Part::Start => 0.0,
        Part::End => 1.0,
        Part::Cone => (y_of(o + d * t) / g).clamp(0.0, 1.0),
    };
    // Entries behind the origin mean the origin is inside: culled.
    let t = t + dt;
    (t > 0.0).then_some((t, u))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use crate::sampling::rng::{hash_words, to_unit_f32};

    fn rnd(i: u64, k: u64) -> f32 {
        to_unit_f32(hash_words(&[i, 33, k]))
    }

    fn curves(points: &[[f32; 4]]) -> Shape {
        let points: Vec<Vec4> = points.iter().map(|p| Vec4::from_array(*p)).collect();
        let segments = (0..points.len() as u32 - 1).collect();
        Shape::Curves(Curves { points, segments, basis: Basis::Linear })
    }

    fn closest(s: &Shape, ray: &Ray) -> Option<(f32, usize, Vec2)> {
        (0..s.prim_count())
            .filter_map(|i| s.intersect_prim(i, ray).map(|(t, uv)| (t, i, uv)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    // Values printed by Mitsuba 3.9.1 (llvm_ad_rgb) for the curve file
    //   0 0 0 0.5 / 2 0.5 0 0.25 / 2 2 1 0.3
    // s = mi.load_dict({'type': 'scene', 'c': {'type': 'linearcurve', 'filename': ...}})
    // si = s.ray_intersect(mi.Ray3f(o, d)); si.t, si.n, si.uv, si.prim_index. The
    // last two rays start inside (culled: t = inf).
    #[test]
    fn hits_match_mitsuba() {
        let s = curves(&[[0.0, 0.0, 0.0, 0.5], [2.0, 0.5, 0.0, 0.25], [2.0, 2.0, 1.0, 0.3]]);
        let cases = [
            ([1.0, 0.2, 5.0], [0.0, 0.0, -1.0], 4.62385, [0.148438, -0.0937499, 0.984468], [0.270411, 0.235821], 0),
            ([-3.0, 0.1, 0.05], [1.0, 0.0, 0.0], 2.51266, [-0.974679, 0.2, 0.1], [0.0363319, 0.0], 0),
            ([2.1, 1.2, -4.0], [0.0, 0.0, 1.0], 4.16677, [0.371849, 0.491618, -0.787427], [0.689337, 0.689264], 1),
            ([2.0, 2.5, 1.2], [0.0, -1.0, 0.0], 0.276393, [0.0, 0.745356, 0.666667], [0.25, 1.0], 1),
        ];
        for (o, d, t, n, uv, prim) in cases {
            let ray = Ray::new(Vec3::from_array(o), Vec3::from_array(d), f32::INFINITY);
            let (th, i, puv) = closest(&s, &ray).expect("missed");
            assert_eq!(i, prim);
            assert!((th - t).abs() < 2e-5, "t {th} vs {t}");
            let si = s.interaction(0, i, &ray, th, puv);
            assert!((si.n - Vec3::from_array(n)).abs().max_element() < 2e-5, "n {} vs {n:?}", si.n);
            assert!((si.uv - Vec2::from_array(uv)).abs().max_element() < 2e-5, "uv {} vs {uv:?}", si.uv);
            assert_eq!(si.sh_frame.n, si.n);
            // dp/du runs around the tube: orthogonal to the normal and the axis.
            assert!(si.dpdu.dot(si.n).abs() < 1e-4 && si.sh_frame.s.dot(si.dpdu.normalize()) > 0.9999);
        }
        for o in [[0.0, 0.0, 0.0], [1.0, 0.2, 0.0]] {
            let d = if o[0] == 0.0 { Vec3::Y } else { Vec3::Z };
            assert!(closest(&s, &Ray::new(Vec3::from_array(o), d, f32::INFINITY)).is_none(), "a hit from inside");
        }
        let b = (0..2).fold(crate::geometry::Aabb::EMPTY, |b, i| b.union(s.prim_bounds(i)));
        assert!(
            (b.min - Vec3::splat(-0.5)).abs().max_element() < 1e-5
                && (b.max - Vec3::new(2.3, 2.3, 1.3)).abs().max_element() < 1e-5
        );
    }

    /// The signed distance-like function of a segment's hull: min over s of
    /// |x − c(s)| − r(s), sampled densely (the union of the interpolated spheres).
    fn hull(a: Vec4, b: Vec4, x: Vec3) -> f32 {
        (0..=2000)
            .map(|k| {
                let s = k as f32 / 2000.0;
                let c = a.lerp(b, s);
                (x - c.truncate()).length() - c.w
            })
            .fold(f32::INFINITY, f32::min)
    }

    /// Rays from outside hit where a march along the ray first enters the
    /// hull of the two end spheres; the normal there is the hull's outward
    /// normal (the distance to c(u) is r(u)); rays from inside are culled;
    /// rays that pass outside miss.
    #[test]
    fn segments_are_hulls_of_their_spheres() {
        let (mut hits, mut cone_hits) = (0, 0);
        for i in 0..300u64 {
            let a = Vec4::new(rnd(i, 0), rnd(i, 1), rnd(i, 2), 0.05 + 0.3 * rnd(i, 3));
            let b = Vec4::new(rnd(i, 4) + 0.5, rnd(i, 5), rnd(i, 6), 0.05 + 0.3 * rnd(i, 7));
            let s = Shape::Curves(Curves { points: vec![a, b], segments: vec![0], basis: Basis::Linear });
            for k in 0..10u64 {
                let target = a.truncate().lerp(b.truncate(), rnd(k, 8 + i));
                let o = target
                    + Vec3::new(rnd(k, 20 + i) - 0.5, rnd(k, 30 + i) - 0.5, rnd(k, 40 + i) - 0.5).normalize() * 2.0;
                let d =
                    (target + 0.2 * Vec3::new(rnd(k, 50 + i), rnd(k, 60 + i), rnd(k, 70 + i)) - 0.1 - o).normalize();
                let ray = Ray::new(o, d, f32::INFINITY);
                let f = |t: f32| hull(a, b, o + d * t);
                let mut expected = None;
                let steps = 400;
                for j in 1..=steps {
                    let t = 4.0 * j as f32 / steps as f32;
                    if f(t) <= 0.0 {
                        let (mut lo, mut hi) = (t - 4.0 / steps as f32, t);
                        for _ in 0..30 {
                            let mid = 0.5 * (lo + hi);
                            if f(mid) <= 0.0 {
                                hi = mid
                            } else {
                                lo = mid
                            }
                        }
                        expected = Some(hi);
                        break;
                    }
                }
                let got = s.intersect_prim(0, &ray);
                match (got, expected) {
                    (Some((t, uv)), Some(e)) => {
                        assert!((t - e).abs() < 2e-3, "{i}/{k}: {t} vs {e}");
                        let si = s.interaction(0, 0, &ray, t, uv);
                        let c = a.lerp(b, uv.x);
                        assert!(((si.p - c.truncate()).length() - c.w).abs() < 1e-3, "{i}/{k}: not tangent at u");
                        assert!(si.n.dot(d) < 0.0, "{i}/{k}: the normal faces away from the ray");
                        // Culled from just inside.
                        let inside = Ray::new(si.p - si.n * 1e-3, d, f32::INFINITY);
                        assert!(s.intersect_prim(0, &inside).is_none(), "{i}/{k}: hit from inside");
                        hits += 1;
                        cone_hits += (uv.x > 0.0 && uv.x < 1.0) as usize;
                    }
                    (None, None) => {}
                    // A grazing ray may tip either way.
                    (g, e) => {
                        let t = g.map(|h| h.0).or(e).unwrap();
                        assert!(f(t).abs() < 1e-3, "{i}/{k}: {g:?} vs {e:?}");
                    }
                }
            }
        }
        assert!(hits > 1500 && cone_hits > 500, "{hits} hits, {cone_hits} on cones");
    }

    /// A cylinder-like segment (equal radii): closed-form distance for a ray
    /// perpendicular to the axis, tangent rays graze, caps are hemispheres.
    #[test]
    fn equal_radii_match_closed_form() {
        let s = curves(&[[0.0, 0.0, 0.0, 0.5], [3.0, 0.0, 0.0, 0.5]]);
        let hit = |o: [f32; 3], d: [f32; 3]| {
            s.intersect_prim(0, &Ray::new(Vec3::from_array(o), Vec3::from_array(d), f32::INFINITY))
        };
        let (t, uv) = hit([1.2, 0.3, 5.0], [0.0, 0.0, -1.0]).unwrap();
        assert!((t - (5.0 - (0.25f32 - 0.09).sqrt())).abs() < 1e-5 && (uv.x - 0.4).abs() < 1e-5, "{t} {uv}");
        assert!(hit([1.2, 0.5001, 5.0], [0.0, 0.0, -1.0]).is_none());
        assert!(hit([1.2, 0.4999, 5.0], [0.0, 0.0, -1.0]).is_some());
        // The end cap: along the axis from beyond p1.
        let (t, uv) = hit([5.0, 0.0, 0.0], [-1.0, 0.0, 0.0]).unwrap();
        assert!((t - 1.5).abs() < 1e-5 && uv.x == 1.0, "{t} {uv}");
        let (t, uv) = hit([-2.0, 0.1, 0.0], [1.0, 0.0, 0.0]).unwrap();
        assert!((t - (2.0 - (0.25f32 - 0.01).sqrt())).abs() < 1e-5 && uv.x == 0.0, "{t} {uv}");
        // Ending before the surface: no hit.
        assert!(s.intersect_prim(0, &Ray::new(Vec3::new(1.2, 0.3, 5.0), Vec3::NEG_Z, 4.5)).is_none());
    }

    fn bspline(points: &[[f32; 4]]) -> Shape {
        let points: Vec<Vec4> = points.iter().map(|p| Vec4::from_array(*p)).collect();
        let segments = (0..points.len() as u32 - 3).collect();
        Shape::Curves(Curves { points, segments, basis: Basis::BSpline })
    }

    // Values printed by Mitsuba 3.9.1 (llvm_ad_rgb) for the bsplinecurve file
    //   0 0 0 0.3 / 1 0.5 0 0.4 / 2 0 0.5 0.2 / 3 1 0 0.3 / 4 0 0 0.3
    // si = s.ray_intersect(mi.Ray3f(o, d)); si.t, si.n, si.uv, si.prim_index.
    // The third ray misses, the fourth starts inside (culled), the fifth
    // enters the open start of the tube (no cap: it sees only back faces).
    #[test]
    fn bspline_hits_match_mitsuba() {
        let s = bspline(&[
            [0.0, 0.0, 0.0, 0.3],
            [1.0, 0.5, 0.0, 0.4],
            [2.0, 0.0, 0.5, 0.2],
            [3.0, 1.0, 0.0, 0.3],
            [4.0, 0.0, 0.0, 0.3],
        ]);
        let cases = [
            ([1.5, 0.3, 5.0], [0.0, 0.0, -1.0], 4.46156, [-0.142625, 0.161726, 0.976475], [0.228048, 0.286003], 0),
            ([2.0, 3.0, 0.2], [0.0, -1.0, 0.0], 2.53155, [-0.285379, 0.798552, -0.529975], [0.911279, 0.539606], 1),
        ];
        for (o, d, t, n, uv, prim) in cases {
            let ray = Ray::new(Vec3::from_array(o), Vec3::from_array(d), f32::INFINITY);
            let (th, i, puv) = closest(&s, &ray).expect("missed");
            assert_eq!(i, prim);
            assert!((th - t).abs() < 2e-5, "t {th} vs {t}");
            let si = s.interaction(0, i, &ray, th, puv);
            assert!((si.n - Vec3::from_array(n)).abs().max_element() < 2e-5, "n {} vs {n:?}", si.n);
            assert!((si.uv - Vec2::from_array(uv)).abs().max_element() < 2e-5, "uv {} vs {uv:?}", si.uv);
            assert!(si.dpdu.dot(si.n).abs() < 1e-3 * si.dpdu.length(), "dp/du is not tangent");
        }
        for (o, d) in [
            ([2.6, 0.5, -4.0], [0.1, 0.0, 1.0]),
            ([1.0, 0.35, 0.1], [0.0, 0.0, 1.0]),
            ([-3.0, 0.2, 0.0], [1.0, 0.0, 0.0]),
        ] {
            let ray = Ray::new(Vec3::from_array(o), Vec3::from_array(d).normalize(), f32::INFINITY);
            assert!(closest(&s, &ray).is_none(), "{o:?} {d:?} hit");
        }
    }

    /// Hits lie on the swept circles (|p − c(v)| = r(v), (p − c(v)) · c'(v) = 0)
    /// and face the ray; a straight tube of constant radius is a cylinder
    /// (closed-form distance, open ends); rays from just inside are culled.
    #[test]
    fn bspline_hits_lie_on_the_sweep() {
        let tube = bspline(&[[0.0, 0.0, 0.0, 0.5], [1.0, 0.0, 0.0, 0.5], [2.0, 0.0, 0.0, 0.5], [3.0, 0.0, 0.0, 0.5]]);
        // The segment runs over x in [1, 2] (the B-spline of collinear, evenly spaced points).
        let ray = Ray::new(Vec3::new(1.4, 0.3, 5.0), Vec3::NEG_Z, f32::INFINITY);
        let (t, _, uv) = closest(&tube, &ray).unwrap();
        assert!((t - (5.0 - 0.4)).abs() < 1e-5 && (uv.x - 0.4).abs() < 1e-4, "{t} {uv}");
        assert!(closest(&tube, &Ray::new(Vec3::new(0.5, 0.3, 5.0), Vec3::NEG_Z, f32::INFINITY)).is_none());
        assert!(closest(&tube, &Ray::new(Vec3::new(-2.0, 0.1, 0.0), Vec3::X, f32::INFINITY)).is_none());
        let mut hits = 0;
        for i in 0..200u64 {
            let pts: Vec<[f32; 4]> = (0..6)
                .map(|k| [k as f32 * 0.6, rnd(i, k) - 0.5, rnd(i, 10 + k) - 0.5, 0.05 + 0.15 * rnd(i, 20 + k)])
                .collect();
            let s = bspline(&pts);
            let Shape::Curves(c) = &s else { unreachable!() };
            for k in 0..10u64 {
                let target = Vec3::new(0.6 + 1.8 * rnd(k, 30 + i), 0.0, 0.0);
                let o = target + Vec3::new(rnd(k, 40 + i) - 0.5, 2.0, rnd(k, 50 + i) - 0.5) * 2.0;
                let ray = Ray::new(o, (target - o).normalize(), f32::INFINITY);
                let Some((t, seg, uv)) = closest(&s, &ray) else { continue };
                let sp = spline(&c.controls(seg), uv.x as f64);
                let q = ray.at(t).as_dvec3() - sp.c;
                assert!((q.length() - sp.r).abs() < 1e-4, "{i}/{k}: off the circle by {}", q.length() - sp.r);
                assert!(q.dot(sp.dc).abs() < 1e-4 * sp.dc.length(), "{i}/{k}: not on the perpendicular circle");
                let si = s.interaction(0, seg, &ray, t, uv);
                assert!(si.n.dot(ray.d) < 0.0, "{i}/{k}: a back face");
                let inside = Ray::new(si.p - si.n * 1e-3, ray.d, f32::INFINITY);
                let again = closest(&s, &inside);
                assert!(again.is_none_or(|h| h.0 > 1e-2), "{i}/{k}: hit from inside at {again:?}");
                hits += 1;
            }
        }
        assert!(hits > 300, "{hits}");
    }

    // Mitsuba 3.9.1 (llvm_ad_rgb) on the bent curve 0 0 0 0.3 / 2 0 0 0.3 / 2 2 0 0.3:
    // rays aimed at the joint from around its outside, (si.t, si.prim_index,
    // si.uv): the joint's sphere belongs to the segment ending there (u = 1).
    // (A ninth ray, at angle 0, meets the joint's sphere exactly where the
    // second segment's cone starts: a tie either segment may report.)
    #[test]
    fn joints_belong_to_the_segment_ending_there() {
        let s = curves(&[[0.0, 0.0, 0.0, 0.3], [2.0, 0.0, 0.0, 0.3], [2.0, 2.0, 0.0, 0.3]]);
        let want = [
            (4.77639, 0, 0.61614),
            (4.74019, 0, 0.584677),
            (4.71716, 0, 0.558169),
            (4.7042, 0, 0.53192),
            (4.7, 0, 0.5),
            (4.7042, 0, 0.452994),
            (4.71716, 0, 0.381294),
            (4.74019, 0, 0.301862),
        ];
        for (k, (t, prim, u)) in want.into_iter().enumerate() {
            let a = (-90.0 + 11.25 * k as f32).to_radians();
            let o = Vec3::new(2.0 + 5.0 * a.cos(), 5.0 * a.sin(), 0.05 * k as f32 - 0.2);
            let ray = Ray::new(o, Vec3::new(-a.cos(), -a.sin(), 0.0), f32::INFINITY);
            let (th, i, uv) = closest(&s, &ray).expect("missed");
            assert_eq!(i, prim, "ray {k}");
            assert!((th - t).abs() < 2e-5, "ray {k}: t {th} vs {t}");
            let si = s.interaction(0, i, &ray, th, uv);
            assert!((si.uv - Vec2::new(u, 0.5)).abs().max_element() < 2e-5, "ray {k}: uv {}", si.uv);
            // Only one segment reports a joint hit.
            let both = (0..2).filter(|&j| s.intersect_prim(j, &ray).is_some_and(|h| h.0 == th)).count();
            assert_eq!(both, 1, "ray {k}");
        }
    }

    /// Rays aimed head-on, and at a slant, at points of strongly bent swept
    /// tubes hit them (the seeding chain holds the whole tube), including
    /// points near the silhouette seen from the ray.
    #[test]
    fn bspline_points_of_the_sweep_are_hit() {
        let mut slanted = 0;
        for i in 0..100u64 {
            let pts: Vec<[f32; 4]> = (0..4)
                .map(|k| {
                    [k as f32 * 0.8, 0.6 * (rnd(i, k) - 0.5), 0.6 * (rnd(i, 10 + k) - 0.5), 0.05 + 0.1 * rnd(i, 20 + k)]
                })
                .collect();
            let s = bspline(&pts);
            let Shape::Curves(c) = &s else { unreachable!() };
            for k in 0..20u64 {
                let v = 0.02 + 0.96 * rnd(k, 30 + i) as f64;
                let sp = spline(&c.controls(0), v);
                let tan = sp.dc.normalize();
                let a = tan.any_orthonormal_vector();
                let b = tan.cross(a);
                let th = std::f64::consts::TAU * rnd(k, 40 + i) as f64;
                let q = sp.r * (th.cos() * a + th.sin() * b);
                let p = sp.c + q;
                let n = ((sp.dc.length_squared() - q.dot(sp.ddc)) * q - (sp.dr * sp.r) * sp.dc).normalize();
                // Head-on, and tilted towards the tangent plane (up to 88 degrees off the normal).
                let tilt = 88f64.to_radians() * rnd(k, 50 + i) as f64;
                let side = n.cross(tan).normalize();
                let dir = -(n * tilt.cos() + side * tilt.sin());
                let o = p - dir * 1.0;
                let ray = Ray::new(o.as_vec3(), dir.as_vec3(), f32::INFINITY);
                let got = closest(&s, &ray).map(|h| h.0);
                // Another part of the tube may come first; the hit is never later.
                assert!(got.is_some_and(|t| t <= 1.0 + 1e-4), "{i}/{k}: {got:?} for a surface point at 1");
                slanted += (tilt > 60f64.to_radians() && got.is_some_and(|t| (t - 1.0).abs() < 1e-4)) as usize;
            }
        }
        assert!(slanted > 200, "{slanted}");
    }
}
