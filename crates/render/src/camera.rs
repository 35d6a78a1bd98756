//! Cameras. Mitsuba `perspective`: a pinhole looking down its local +z, with
//! +y up and image x growing towards local -x (Mitsuba's convention, which
//! makes `lookat` images come out unmirrored).
//!
//! | parameter | type      | default |
//! |-----------|-----------|---------|
//! | fov       | float     | (required, degrees, full angle) |
//! | fov_axis  | string    | x (or y, diagonal, smaller, larger) |
//! | to_world  | transform | identity |
//! | near_clip | float     | 0.01    |
//! | far_clip  | float     | 10000   |

use crate::geometry::Ray;
use crate::math::Mat4;
use glam::{Vec2, Vec3};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

#[derive(Debug, Clone)]
pub struct PerspectiveCamera {
    pub world_from_camera: Mat4,
    /// tan of the half field of view along x and y.
    pub tan_half: Vec2,
    pub near_clip: f32,
    pub far_clip: f32,
}

impl PerspectiveCamera {
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
        let t = (0.5 * fov_deg.to_radians()).tan();
        // Express the given fov as tan_half along x.
        let tan_x = match axis {
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
        };
        PerspectiveCamera {
            world_from_camera,
            tan_half: Vec2::new(tan_x, tan_x / aspect),
            near_clip: near,
            far_clip: far,
        }
    }

    /// Ray through film position `s` in [0,1]² (x right, y down).
    #[inline]
    pub fn generate_ray(&self, s: Vec2) -> Ray {
        let local =
            Vec3::new((1.0 - 2.0 * s.x) * self.tan_half.x, (1.0 - 2.0 * s.y) * self.tan_half.y, 1.0).normalize();
        let o = self.world_from_camera.transform_point3(Vec3::ZERO);
        let d = self.world_from_camera.transform_vector3(local).normalize();
        // The clip planes are perpendicular to the view axis.
        let inv_z = 1.0 / local.z;
        Ray::new(o + d * (self.near_clip * inv_z), d, (self.far_clip - self.near_clip) * inv_z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
