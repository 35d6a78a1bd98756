//! The operations of a Mitsuba `<transform>` block, in f64 as Mitsuba's
//! parser stores them (Mitsuba's `AffineTransform` and drjit's
//! `transform.h`). Each returns the matrix of one operation; the parser
//! left-multiplies them in the order written (`M = op * M`), so the first
//! operation in the file is applied to the points first.

use glam::{DMat4, DVec3, DVec4};

/// Translation by `v`.
pub fn translate(v: DVec3) -> DMat4 {
    DMat4::from_translation(v)
}

/// Scale by `v` along x, y, z.
pub fn scale(v: DVec3) -> DMat4 {
    DMat4::from_scale(v)
}

/// A right-handed rotation by `angle_deg` degrees about `axis`.
///
/// The axis is normalised here. Mitsuba 3 (drjit's `rotate`) feeds it to
/// Rodrigues' formula as given, so a non-unit axis there yields a matrix
/// that is not a rotation; normalising is what such scenes mean.
pub fn rotate(axis: DVec3, angle_deg: f64) -> DMat4 {
    DMat4::from_axis_angle(axis.normalize(), angle_deg.to_radians())
}

/// A matrix from its entries in row-major order: 16 for the full matrix,
/// or 9 for the upper-left 3×3 block of an otherwise identity matrix.
pub fn matrix(row_major: &[f64]) -> Option<DMat4> {
    let n = match row_major.len() {
        16 => 4,
        9 => 3,
        _ => return None,
    };
    let mut cols = DMat4::IDENTITY.to_cols_array_2d();
    for (i, row) in row_major.chunks(n).enumerate() {
        for (j, &v) in row.iter().enumerate() {
            cols[j][i] = v;
        }
    }
    Some(DMat4::from_cols_array_2d(&cols))
}

/// Mitsuba's `look_at`: maps local +z to the view direction, +y to the
/// (re-orthogonalised) up vector, +x to `cross(up, dir)` ("left") and the
/// local origin to `origin`. Degenerate input gives NaN entries, which the
/// parser reports.
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> DMat4 {
    let dir = (target - origin).normalize();
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        DVec4::new(origin.x, origin.y, origin.z, 1.0),
    )
}

/// Two unit vectors completing the unit vector `n` to an orthonormal basis
/// (Duff et al. 2017, as Mitsuba's `coordinate_system`). The parser uses
/// the first one as the up vector of a `<lookat>` that gives none.
pub fn coordinate_system(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(n.x * n.x * a * sign + 1.0, b * sign, -n.x * sign), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).abs().max_element() < 1e-12
    }

    #[test]
    fn rotate_about_z_maps_x_to_y() {
        let m = rotate(DVec3::Z, 90.0);
        assert!(close(m.transform_vector3(DVec3::X), DVec3::Y));
        assert!(close(m.transform_vector3(DVec3::Y), -DVec3::X));
        assert!(close(m.transform_vector3(DVec3::Z), DVec3::Z));
    }

    #[test]
    fn rotate_normalises_the_axis() {
        let m = rotate(DVec3::new(0.0, 0.0, 5.0), 90.0);
        assert!(close(m.transform_vector3(DVec3::X), DVec3::Y));
        // About (1,1,1) by 120°: a cyclic permutation of the axes.
        let m = rotate(DVec3::ONE, 120.0);
        assert!(close(m.transform_vector3(DVec3::X), DVec3::Y));
        assert!(close(m.transform_vector3(DVec3::Y), DVec3::Z));
    }

    #[test]
    fn translate_and_scale() {
        let t = translate(DVec3::new(1.0, 2.0, 3.0));
        assert!(close(t.transform_point3(DVec3::ONE), DVec3::new(2.0, 3.0, 4.0)));
        assert!(close(t.transform_vector3(DVec3::ONE), DVec3::ONE));
        let s = scale(DVec3::new(2.0, 3.0, 4.0));
        assert!(close(s.transform_point3(DVec3::ONE), DVec3::new(2.0, 3.0, 4.0)));
    }

    /// The parser composes `M = op * M`: translate-then-scale scales the
    /// translation too, scale-then-translate does not.
    #[test]
    fn composition_order() {
        let t = translate(DVec3::X);
        let s = scale(DVec3::splat(2.0));
        let translate_then_scale = s * t;
        let scale_then_translate = t * s;
        assert!(close(translate_then_scale.transform_point3(DVec3::ZERO), DVec3::new(2.0, 0.0, 0.0)));
        assert!(close(scale_then_translate.transform_point3(DVec3::ZERO), DVec3::X));
    }

    #[test]
    fn matrix_is_row_major() {
        let v: Vec<f64> = (0..16).map(f64::from).collect();
        let m = matrix(&v).unwrap();
        assert_eq!(m.row(0), DVec4::new(0.0, 1.0, 2.0, 3.0));
        assert_eq!(m.row(3), DVec4::new(12.0, 13.0, 14.0, 15.0));
        // Row-major translation column lands in the last column.
        let t = matrix(&[1., 0., 0., 5., 0., 1., 0., 6., 0., 0., 1., 7., 0., 0., 0., 1.]).unwrap();
        assert!(close(t.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0)));
        let m3 = matrix(&[1., 2., 3., 4., 5., 6., 7., 8., 9.]).unwrap();
        assert_eq!(m3.row(1), DVec4::new(4.0, 5.0, 6.0, 0.0));
        assert_eq!(m3.row(3), DVec4::new(0.0, 0.0, 0.0, 1.0));
        assert!(matrix(&[1.0; 12]).is_none());
    }

    #[test]
    fn look_at_frame() {
        let origin = DVec3::new(1.0, 2.0, 3.0);
        let target = DVec3::new(1.0, 2.0, -7.0);
        let m = look_at(origin, target, DVec3::Y);
        assert!(close(m.transform_point3(DVec3::ZERO), origin));
        assert!(close(m.transform_vector3(DVec3::Z), -DVec3::Z));
        assert!(close(m.transform_vector3(DVec3::Y), DVec3::Y));
        // left = cross(up, dir) = cross(y, -z) = -x
        assert!(close(m.transform_vector3(DVec3::X), -DVec3::X));
        assert!(close(m.transform_point3(DVec3::new(0.0, 0.0, 10.0)), target));
        // A non-orthogonal up is re-orthogonalised.
        let m = look_at(DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0));
        assert!(close(m.transform_vector3(DVec3::Y), DVec3::Y));
        assert!(look_at(DVec3::ZERO, DVec3::X, DVec3::X).is_nan());
    }

    #[test]
    fn coordinate_system_is_orthonormal() {
        for n in [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Z, DVec3::new(0.3, -0.5, 0.8).normalize()] {
            let (s, t) = coordinate_system(n);
            assert!((s.length() - 1.0).abs() < 1e-12 && (t.length() - 1.0).abs() < 1e-12);
            assert!(s.dot(t).abs() < 1e-12 && s.dot(n).abs() < 1e-12 && t.dot(n).abs() < 1e-12);
            assert!(close(s.cross(t), n));
        }
    }
}
