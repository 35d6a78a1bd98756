//! Cameras: Mitsuba's `perspective`, `thinlens`, `orthographic`,
//! `radiancemeter`, `irradiancemeter` and `distant` sensors.
//! All look down their local +z, with +y up and image x growing towards
//! local -x (Mitsuba's convention, which makes `lookat` images come out
//! unmirrored).
//!
//! | parameter       | type      | default |
//! |-----------------|-----------|---------|
//! | fov             | float     | (perspective, thinlens; degrees, full angle) |
//! | fov_axis        | string    | x (or y, diagonal, smaller, larger) |
//! | to_world        | transform | identity (orthographic: its scale sets the view size) |
//! | near_clip       | float     | 0.01    |
//! | far_clip        | float     | 10000   |
//! | aperture_radius | float     | (thinlens, required) |
//! | focus_distance  | float     | far_clip (thinlens) |
//!
//! Ray generation follows Mitsuba 3.9.1 (`src/sensors/*.cpp`): the perspective
//! and thin-lens rays start on the near plane (at distance `near_clip` along
//! the view axis) and end on the far plane; the thin lens samples its
//! aperture with the concentric disk map and aims at the point of the focal
//! plane that the pinhole ray through the same film position hits; the
//! orthographic camera maps the film to [-1, 1] x [-1/aspect, 1/aspect] on
//! the near plane (z = `near_clip`) in camera space, then through `to_world`.

use crate::geometry::{offset_origin, Ray, RayLanes, Shape};
use crate::math::{Frame, Mat4, PI};
use crate::sampling::warp::{sample_concentric_disk, sample_cosine_hemisphere};
use crate::sampling::SampleStream;
use crate::simd::{Float, V3};
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// Mitsuba's `fov_axis`: which film extent `fov` spans.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FovAxis {
    /// The horizontal extent.
    X,
    /// The vertical extent.
    Y,
    /// The film diagonal.
    Diagonal,
    /// The smaller of width and height.
    Smaller,
    /// The larger of width and height.
    Larger,
}

/// How film positions turn into rays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// Mitsuba `perspective`.
    Pinhole,
    /// Mitsuba `thinlens`.
    ThinLens {
        /// Radius of the lens aperture, in world units.
        aperture_radius: f32,
        /// Distance to the plane in focus along the view axis.
        focus_distance: f32,
    },
    /// Mitsuba `orthographic` (`tan_half` is unused).
    Orthographic {
        /// Reciprocal of the film's aspect ratio.
        inv_aspect: f32,
    },
    /// Mitsuba `radiancemeter`: every sample is the one ray along the
    /// sensor's local +z from its origin (nudged forward by the ray epsilon).
    RadianceMeter,
    /// Mitsuba `irradiancemeter`: a point of [`Camera::shape`] uniform by
    /// area (from the film position), a cosine-weighted direction about its
    /// normal (from the aperture sample), each ray weighted π
    /// ([`Camera::ray_weight`]): the mean over the shape of the irradiance
    /// E = ∫ L cos θ dω = π E_cos\[L\].
    IrradianceMeter,
    /// Mitsuba `distant`: rays along the sensor's local +z, starting outside
    /// the scene's bounding sphere (centre `center`, radius `radius`) and
    /// aimed at `target`, at a point of [`Camera::shape`] uniform by area
    /// (when set), or at a point of the sphere's cross section uniform by
    /// area (otherwise), from the aperture sample: the radiance leaving the
    /// scene towards -z, averaged over the target.
    Distant {
        /// A target point, for `target` given as a point.
        target: Option<Vec3>,
        /// Centre of the scene's bounding sphere.
        center: Vec3,
        /// Its radius, as Mitsuba widens it: max(ε, r (1 + ε)), ε the ray epsilon.
        radius: f32,
    },
    /// Mitsuba `batch`: the sensors of [`Camera::batch`] side by side, each
    /// over an equal vertical strip of the film (film x in [i/n, (i+1)/n)
    /// is sensor i's x in [0, 1)), each built for the strip's size.
    Batch,
}

/// A camera: placement, field of view, clip range and projection.
#[derive(Debug, Clone)]
pub struct Camera {
    /// Camera-to-world transform (Mitsuba `to_world`).
    pub world_from_camera: Mat4,
    /// tan of the half field of view along x and y.
    pub tan_half: Vec2,
    /// Distance of the near clip plane along the view axis.
    pub near_clip: f32,
    /// Distance of the far clip plane along the view axis.
    pub far_clip: f32,
    /// How film positions turn into rays.
    pub projection: Projection,
    /// The shape an `irradiancemeter` measures over, or a `distant` sensor's
    /// target shape (world space; not part of the scene for `distant`).
    pub shape: Option<Arc<Shape>>,
    /// The sensors of a `batch` (empty otherwise).
    pub batch: Vec<Camera>,
}

/// Mitsuba's `math::RayEpsilon<float>`.
const RAY_EPS: f32 = crate::math::RAY_EPSILON;

/// The name the pinhole camera had before the other projections existed.
pub type PerspectiveCamera = Camera;

/// tan of the half field of view along x for `fov_deg` along `axis`, on an
/// image of width / height `aspect`.
pub fn tan_half_x(fov_deg: f32, axis: FovAxis, aspect: f32) -> f32 {
    let t = (0.5 * fov_deg.to_radians()).tan();
    match axis {
        FovAxis::X => t,
        FovAxis::Y => t * aspect,
        FovAxis::Diagonal => t * aspect / (1.0 + aspect * aspect).sqrt(),
        FovAxis::Smaller => {
            if aspect >= 1.0 {
                t * aspect
            } else {
                t
            }
        }
        FovAxis::Larger => {
            if aspect >= 1.0 {
                t
            } else {
                t * aspect
            }
        }
    }
}

impl Camera {
    /// Mitsuba `perspective`.
    pub fn new(
        world_from_camera: Mat4,
        fov_deg: f32,
        axis: FovAxis,
        width: u32,
        height: u32,
        near: f32,
        far: f32,
    ) -> Self {
        let aspect = width as f32 / height as f32;
        let tan_x = tan_half_x(fov_deg, axis, aspect);
        Camera {
            world_from_camera,
            tan_half: Vec2::new(tan_x, tan_x / aspect),
            near_clip: near,
            far_clip: far,
            projection: Projection::Pinhole,
            shape: None,
            batch: Vec::new(),
        }
    }

    /// Mitsuba `thinlens`: a perspective camera with a lens of radius
    /// `aperture_radius` focused at distance `focus_distance` (along the
    /// view axis). `world_from_camera` must not scale (Mitsuba refuses it).
    #[allow(clippy::too_many_arguments)]
    pub fn thin_lens(
        world_from_camera: Mat4,
        fov_deg: f32,
        axis: FovAxis,
        width: u32,
        height: u32,
        near: f32,
        far: f32,
        aperture_radius: f32,
        focus_distance: f32,
    ) -> Self {
        let mut c = Camera::new(world_from_camera, fov_deg, axis, width, height, near, far);
        c.projection = Projection::ThinLens { aperture_radius, focus_distance };
        c
    }

    /// Mitsuba `orthographic`: the film spans [-1, 1] x [-1/aspect, 1/aspect]
    /// in camera space, scaled by `world_from_camera`.
    pub fn orthographic(world_from_camera: Mat4, width: u32, height: u32, near: f32, far: f32) -> Self {
        let aspect = width as f32 / height as f32;
        Camera {
            world_from_camera,
            tan_half: Vec2::ZERO,
            near_clip: near,
            far_clip: far,
            projection: Projection::Orthographic { inv_aspect: 1.0 / aspect },
            shape: None,
            batch: Vec::new(),
        }
    }

    /// Mitsuba's `radiancemeter`: the radiance along one ray, from
    /// `world_from_camera`'s origin along its +z.
    pub fn radiance_meter(world_from_camera: Mat4) -> Self {
        Camera {
            world_from_camera,
            tan_half: Vec2::ZERO,
            near_clip: 0.0,
            far_clip: f32::INFINITY,
            projection: Projection::RadianceMeter,
            shape: None,
            batch: Vec::new(),
        }
    }

    /// Mitsuba's `irradiancemeter` on `shape` (world space, positive area).
    pub fn irradiance_meter(shape: Shape) -> Self {
        Camera {
            world_from_camera: Mat4::IDENTITY,
            tan_half: Vec2::ZERO,
            near_clip: 0.0,
            far_clip: f32::INFINITY,
            projection: Projection::IrradianceMeter,
            shape: Some(Arc::new(shape)),
            batch: Vec::new(),
        }
    }

    /// Mitsuba's `distant`, looking along `world_from_camera`'s +z, at
    /// `target` (a point, or else `shape` when given, or else the whole
    /// cross section); [`Camera::set_scene_bounds`] must give it the
    /// scene's bounding sphere before rendering.
    pub fn distant(world_from_camera: Mat4, target: Option<Vec3>, shape: Option<Shape>) -> Self {
        Camera {
            world_from_camera,
            tan_half: Vec2::ZERO,
            near_clip: 0.0,
            far_clip: f32::INFINITY,
            projection: Projection::Distant { target, center: Vec3::ZERO, radius: RAY_EPS },
            shape: shape.map(Arc::new),
            batch: Vec::new(),
        }
    }

    /// Mitsuba's `batch`: `sensors` side by side (each built for its strip
    /// of the film, width / n by height), placed by `world_from_camera` (the
    /// batch's own `to_world`, which no ray uses).
    pub fn batch(world_from_camera: Mat4, sensors: Vec<Camera>) -> Self {
        Camera {
            world_from_camera,
            tan_half: Vec2::ZERO,
            near_clip: 0.0,
            far_clip: f32::INFINITY,
            projection: Projection::Batch,
            shape: None,
            batch: sensors,
        }
    }

    /// The sensor that film position `s` falls to and `s` in its strip
    /// (Mitsuba's batch.cpp: index ⌊x n⌋, clamped, and the fraction);
    /// the camera itself and `s` unless it is a batch.
    #[inline]
    pub fn sensor_at(&self, s: Vec2) -> (&Camera, Vec2) {
        if self.batch.is_empty() {
            return (self, s);
        }
        let n = self.batch.len();
        let x = s.x * n as f32;
        let i = x as usize;
        (&self.batch[i.min(n - 1)], Vec2::new(x - i as f32, s.y))
    }

    /// For a `distant` sensor: the scene's bounding box `[min, max]`, whose
    /// bounding sphere (Mitsuba's `bbox().bounding_sphere()`, widened as in
    /// its `set_scene`) places the rays' origins. Other cameras ignore it.
    pub fn set_scene_bounds(&mut self, min: Vec3, max: Vec3) {
        for c in &mut self.batch {
            c.set_scene_bounds(min, max);
        }
        if let Projection::Distant { center, radius, .. } = &mut self.projection {
            let c = 0.5 * (min + max);
            let r = if (max - min).cmpge(Vec3::ZERO).all() { (max - c).length() } else { 0.0 };
            *center = if c.is_finite() { c } else { Vec3::ZERO };
            *radius = RAY_EPS.max(r * (1.0 + RAY_EPS));
        }
    }

    /// The weight of the radiance of a camera ray through film position `s`:
    /// π for `irradiancemeter` (cosine-weighted directions), 1 otherwise.
    #[inline]
    pub fn ray_weight(&self, s: Vec2) -> f32 {
        let (c, _) = self.sensor_at(s);
        if c.projection == Projection::IrradianceMeter {
            PI
        } else {
            1.0
        }
    }

    /// Whether rays need an aperture sample (two more dimensions).
    #[inline]
    pub fn needs_aperture_sample(&self) -> bool {
        matches!(
            self.projection,
            Projection::ThinLens { .. } | Projection::IrradianceMeter | Projection::Distant { .. }
        ) || self.batch.iter().any(Camera::needs_aperture_sample)
    }

    /// Ray through film position `s` in [0, 1)² (x right, y down), drawing
    /// the aperture sample from `rng` after the film position (as Mitsuba).
    #[inline]
    pub fn sample_ray(&self, s: Vec2, rng: &mut SampleStream) -> Ray {
        let aperture = if self.needs_aperture_sample() { rng.next_2d() } else { Vec2::splat(0.5) };
        self.generate_ray_with_aperture(s, aperture)
    }

    /// Ray through film position `s` with the lens at its centre.
    #[inline]
    pub fn generate_ray(&self, s: Vec2) -> Ray {
        self.generate_ray_with_aperture(s, Vec2::splat(0.5))
    }

    /// Whether [`Self::pinhole_rays`] serves this camera: a pinhole, not a batch.
    #[inline]
    pub fn has_pinhole_lanes(&self) -> bool {
        matches!(self.projection, Projection::Pinhole)
    }

    /// The pinhole rays through film positions (`sx`, `sy`), `F::WIDTH` at
    /// once: bitwise [`Self::generate_ray_with_aperture`] lane by lane (the
    /// same operations in the same order, glam's included: a normalisation
    /// is v · (1 / √((x² + y²) + z²)), a matrix-vector product
    /// (x_axis x + y_axis y) + z_axis z). Only for [`Self::has_pinhole_lanes`].
    pub fn pinhole_rays<F: Float>(&self, sx: F, sy: F) -> RayLanes<F> {
        debug_assert!(self.has_pinhole_lanes());
        let one = F::splat(1.0);
        let lx = (one - F::splat(2.0) * sx) * F::splat(self.tan_half.x);
        let ly = (one - F::splat(2.0) * sy) * F::splat(self.tan_half.y);
        let r = one / ((lx * lx + ly * ly) + one).sqrt();
        let (lx, ly, lz) = (lx * r, ly * r, one * r);
        let m = &self.world_from_camera;
        let t = |a: f32, b: f32, c: f32| (F::splat(a) * lx + F::splat(b) * ly) + F::splat(c) * lz;
        let (tx, ty, tz) = (
            t(m.x_axis.x, m.y_axis.x, m.z_axis.x),
            t(m.x_axis.y, m.y_axis.y, m.z_axis.y),
            t(m.x_axis.z, m.y_axis.z, m.z_axis.z),
        );
        let r = one / ((tx * tx + ty * ty) + tz * tz).sqrt();
        let (dx, dy, dz) = (tx * r, ty * r, tz * r);
        let inv_z = one / lz;
        let near = F::splat(self.near_clip) * inv_z;
        let o = self.world_from_camera.transform_point3(Vec3::ZERO);
        let (ox, oy, oz) = (F::splat(o.x) + dx * near, F::splat(o.y) + dy * near, F::splat(o.z) + dz * near);
        let t_max = F::splat(self.far_clip - self.near_clip) * inv_z;
        RayLanes { o: V3::new(ox, oy, oz), d: V3::new(dx, dy, dz), t_max }
    }

    /// Ray through film position `s` in [0, 1)² and aperture sample `a` in [0, 1)².
    #[inline]
    pub fn generate_ray_with_aperture(&self, s: Vec2, a: Vec2) -> Ray {
        match self.projection {
            Projection::Batch => {
                let (c, s) = self.sensor_at(s);
                c.generate_ray_with_aperture(s, a)
            }
            Projection::Pinhole => {
                let local = Vec3::new((1.0 - 2.0 * s.x) * self.tan_half.x, (1.0 - 2.0 * s.y) * self.tan_half.y, 1.0)
                    .normalize();
                let o = self.world_from_camera.transform_point3(Vec3::ZERO);
                let d = self.world_from_camera.transform_vector3(local).normalize();
                // The clip planes are perpendicular to the view axis.
                let inv_z = 1.0 / local.z;
                Ray::new(o + d * (self.near_clip * inv_z), d, (self.far_clip - self.near_clip) * inv_z)
            }
            Projection::ThinLens { aperture_radius, focus_distance } => {
                let lens = aperture_radius * sample_concentric_disk(a);
                let aperture_p = Vec3::new(lens.x, lens.y, 0.0);
                let focus_p = Vec3::new(
                    (1.0 - 2.0 * s.x) * self.tan_half.x * focus_distance,
                    (1.0 - 2.0 * s.y) * self.tan_half.y * focus_distance,
                    focus_distance,
                );
                let local = (focus_p - aperture_p).normalize();
                let o = self.world_from_camera.transform_point3(aperture_p);
                let d = self.world_from_camera.transform_vector3(local);
                let inv_z = 1.0 / local.z;
                Ray::new(o + d * (self.near_clip * inv_z), d, (self.far_clip - self.near_clip) * inv_z)
            }
            Projection::Orthographic { inv_aspect } => {
                let near_p = Vec3::new(1.0 - 2.0 * s.x, (1.0 - 2.0 * s.y) * inv_aspect, self.near_clip);
                let o = self.world_from_camera.transform_point3(near_p);
                let d = self.world_from_camera.transform_vector3(Vec3::Z).normalize();
                Ray::new(o, d, self.far_clip - self.near_clip)
            }
            Projection::RadianceMeter => {
                let d = self.world_from_camera.transform_vector3(Vec3::Z).normalize();
                let o = self.world_from_camera.transform_point3(Vec3::ZERO) + d * crate::math::RAY_EPSILON;
                Ray::new(o, d, f32::INFINITY)
            }
            Projection::IrradianceMeter => {
                let Some(shape) = self.shape.as_deref() else { return Ray::new(Vec3::ZERO, Vec3::Z, 0.0) };
                let ps = shape.sample_point(s);
                // About the shading normal where a mesh interpolates one, as
                // Mitsuba's `sample_position`; the geometric one otherwise.
                let n = match shape {
                    Shape::Mesh(m) if !m.face_normals && !m.mesh.normals.is_empty() => {
                        let t = m.mesh.indices[ps.prim as usize].map(|i| m.mesh.normals[i as usize]);
                        let b = ps.param;
                        ((1.0 - b.x - b.y) * t[0] + b.x * t[1] + b.y * t[2]).normalize_or(ps.n)
                    }
                    _ => ps.n,
                };
                let d = Frame::from_normal(n).to_world(sample_cosine_hemisphere(a));
                Ray::new(offset_origin(ps.p, ps.n, d), d, f32::INFINITY)
            }
            Projection::Distant { target, center, radius } => {
                let d = self.world_from_camera.transform_vector3(Vec3::Z).normalize();
                // Mitsuba: 2r behind a target, or r behind the cross section.
                let o = match (target, self.shape.as_deref()) {
                    (Some(t), _) => t - 2.0 * radius * d,
                    (None, Some(shape)) => shape.sample_point(a).p - 2.0 * radius * d,
                    (None, None) => {
                        let q = sample_concentric_disk(a);
                        let perp = self.world_from_camera.transform_vector3(Vec3::new(q.x, q.y, 0.0));
                        center + perp * radius - d * radius
                    }
                };
                Ray::new(o, d, f32::INFINITY)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `pinhole_rays` is `generate_ray_with_aperture` lane by lane, bit for
    /// bit, with every lane width built: random film positions, the film's
    /// corners and centre, under a rotated, scaled and translated camera.
    #[test]
    fn pinhole_lanes_are_the_scalar_rays_bitwise() {
        use crate::simd::check::{each_simd, Visit};
        use crate::simd::gather;
        struct V(Vec<PerspectiveCamera>, Vec<Vec2>);
        impl Visit for V {
            fn visit<F: Float>(&mut self) {
                for c in &self.0 {
                    assert!(c.has_pinhole_lanes());
                    for chunk in self.1.chunks_exact(F::WIDTH) {
                        let rays = c.pinhole_rays::<F>(gather(|l| chunk[l].x), gather(|l| chunk[l].y));
                        for (s, r) in chunk.iter().zip(rays.rays()) {
                            let want = c.generate_ray_with_aperture(*s, Vec2::splat(0.5));
                            let bits = |r: &Ray| {
                                (r.o.to_array().map(f32::to_bits), r.d.to_array().map(f32::to_bits), r.t_max.to_bits())
                            };
                            assert_eq!(bits(&r), bits(&want), "{} at {s}", F::NAME);
                        }
                    }
                }
            }
        }
        let mut rng = crate::testing::TestRng::new(11);
        let mut s: Vec<Vec2> = (0..2048).map(|_| rng.next_2d()).collect();
        s.extend([Vec2::ZERO, Vec2::ONE, Vec2::new(0.0, 1.0), Vec2::new(1.0, 0.0), Vec2::splat(0.5)]);
        s.resize(s.len().next_multiple_of(16), Vec2::new(0.25, 0.75));
        let to_world = Mat4::from_scale_rotation_translation(
            Vec3::new(1.0, 1.0, 1.0),
            glam::Quat::from_euler(glam::EulerRot::YXZ, 0.7, -0.3, 0.2),
            Vec3::new(3.0, -1.5, 8.25),
        );
        let cams = vec![
            PerspectiveCamera::new(Mat4::IDENTITY, 39.3, FovAxis::X, 64, 48, 0.01, 1e4),
            PerspectiveCamera::new(to_world, 70.0, FovAxis::Y, 30, 64, 0.5, 100.0),
            PerspectiveCamera::new(
                to_world * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
                20.0,
                FovAxis::X,
                64,
                64,
                1e-3,
                1e3,
            ),
        ];
        let mut v = V(cams, s);
        v.visit::<f32>();
        each_simd(&mut v);
    }

    #[test]
    fn fov_axes_agree_on_square_images() {
        for axis in [FovAxis::X, FovAxis::Y, FovAxis::Smaller, FovAxis::Larger] {
            let c = PerspectiveCamera::new(Mat4::IDENTITY, 90.0, axis, 64, 64, 0.0, 1e4);
            assert!((c.tan_half - Vec2::ONE).abs().max_element() < 1e-5);
        }
        // Diagonal fov of 90° on a square image: tan_half_x = 1/√2.
        let c = PerspectiveCamera::new(Mat4::IDENTITY, 90.0, FovAxis::Diagonal, 64, 64, 0.0, 1e4);
        assert!((c.tan_half.x - 0.5f32.sqrt()).abs() < 1e-5);
    }

    #[test]
    fn image_left_is_local_plus_x() {
        let c = PerspectiveCamera::new(Mat4::IDENTITY, 60.0, FovAxis::X, 100, 50, 0.0, 1e4);
        let left = c.generate_ray(Vec2::new(0.0, 0.5));
        assert!(left.d.x > 0.0 && left.d.y.abs() < 1e-6);
        let top = c.generate_ray(Vec2::new(0.5, 0.0));
        assert!(top.d.y > 0.0);
        // Half-angle along y is derived from x and the aspect ratio.
        assert!((top.d.y / top.d.z - (30f32.to_radians().tan() / 2.0)).abs() < 1e-5);
    }

    /// Rays printed by Mitsuba 3.9.1 (scalar_rgb, `T = mi.ScalarTransform4f`):
    /// ```python
    /// s = mi.load_dict({'type': 'thinlens', 'fov': 40, 'aperture_radius': 0.2, 'focus_distance': 5.0,
    ///     'near_clip': 0.1, 'far_clip': 100, 'to_world': T().look_at(origin=[1,2,3], target=[0,0,0], up=[0,1,0]),
    ///     'film': {'type': 'hdrfilm', 'width': 40, 'height': 20}})
    /// r, _ = s.sample_ray(0.0, 0.0, mi.Point2f(*pos), mi.Point2f(*aperture))
    /// ```
    /// for each (pos, aperture) in POS, and the same for the other sensors below.
    fn check(c: &Camera, cases: &[([f32; 4], [f32; 3], [f32; 3], f32)]) {
        for (i, &(sa, o, d, maxt)) in cases.iter().enumerate() {
            let r = c.generate_ray_with_aperture(Vec2::new(sa[0], sa[1]), Vec2::new(sa[2], sa[3]));
            let (o, d) = (Vec3::from(o), Vec3::from(d));
            assert!((r.o - o).abs().max_element() < 2e-5 * (1.0 + o.abs().max_element()), "case {i}: o {} vs {o}", r.o);
            assert!((r.d - d).abs().max_element() < 2e-6, "case {i}: d {} vs {d}", r.d);
            assert!((r.t_max - maxt).abs() < 2e-5 * maxt, "case {i}: maxt {} vs {maxt}", r.t_max);
        }
    }

    const POS: [[f32; 4]; 3] = [[0.5, 0.5, 0.5, 0.5], [0.1, 0.8, 0.3, 0.9], [0.9, 0.25, 0.75, 0.1]];

    #[test]
    fn thin_lens_rays_match_mitsuba() {
        let to_world = crate::math::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
        let c = Camera::thin_lens(to_world, 40.0, FovAxis::X, 40, 20, 0.1, 100.0, 0.2, 5.0);
        check(
            &c,
            &[
                (POS[0], [0.97327387, 1.94654775, 2.91982174], [-0.26726127, -0.53452247, -0.80178368], 99.9),
                (POS[1], [0.97993511, 2.05975223, 2.84213161], [-0.50432885, -0.61828667, -0.60280508], 105.31364),
                (POS[2], [0.95261168, 1.83736563, 2.99949694], [0.00297587, -0.41208455, -0.91114068], 105.15668),
            ],
        );
        // Default focus distance (far_clip), fov along y, no rotation.
        let to_world = Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0));
        let c = Camera::thin_lens(to_world, 30.0, FovAxis::Y, 40, 20, 0.01, 1e4, 0.05, 1e4);
        check(
            &c,
            &[
                (POS[0], [0.0, 0.0, -1.99], [0.0, 0.0, 1.0], 9999.99),
                (POS[1], [-0.01102014, 0.03534745, -1.99], [0.38980216, -0.1461786, 0.90922278], 10998.393),
                (POS[2], [0.01456867, -0.03393707, -1.99], [-0.39108112, 0.12221558, 0.91220552], 10962.432),
            ],
        );
    }

    #[test]
    fn orthographic_rays_match_mitsuba() {
        // to_world = look_at(...) @ scale([2, 3, 4]); near 0.5, far 50.
        let to_world = crate::math::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y)
            * Mat4::from_scale(Vec3::new(2.0, 3.0, 4.0));
        let c = Camera::orthographic(to_world, 40, 20, 0.5, 50.0);
        let d = [-0.26726127, -0.53452253, -0.8017838];
        check(
            &c,
            &[
                (POS[0], [0.46547723, 0.93095529, 1.39643264], d, 49.5),
                (POS[1], [-0.9002881, 0.17031646, 2.35878038], d, 49.5),
                (POS[2], [1.85659719, 1.56482089, 0.510149], d, 49.5),
            ],
        );
        let c = Camera::orthographic(Mat4::IDENTITY, 40, 20, 0.01, 1e4);
        check(
            &c,
            &[
                (POS[0], [0.0, 0.0, 0.01], [0.0, 0.0, 1.0], 9999.99),
                (POS[1], [0.8, -0.3, 0.01], [0.0, 0.0, 1.0], 9999.99),
                (POS[2], [-0.8, 0.25, 0.01], [0.0, 0.0, 1.0], 9999.99),
            ],
        );
    }
}
