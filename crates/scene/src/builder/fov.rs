//! The field of view of pinhole projections (the `perspective` and
//! `thinlens` sensors, the `projector` emitter): `fov` and `fov_axis`, or
//! a `focal_length`, read as Mitsuba 3.9.1 reads them.

use crate::desc::Node;
use crate::error::{LoadError, Result};
use penumbra_render::camera::FovAxis;

/// Field of view in degrees along `fov_axis`: `fov`, or Mitsuba's
/// `focal_length` ("50mm" by default), a 35 mm-equivalent focal length that
/// fixes the diagonal field of view (the 36x24 mm frame's diagonal is 43.27 mm).
fn field_of_view(node: &Node) -> Result<(f64, Option<FovAxis>)> {
    let fov = node.get_float("fov")?;
    let focal = node.get_string("focal_length")?;
    match (fov, focal) {
        (Some(_), Some((_, loc))) => Err(LoadError::at(&loc, "give either 'fov' or 'focal_length', not both")),
        (Some(f), None) => {
            if !(f > 0.0 && f < 180.0) {
                return Err(LoadError::at(node.loc_of("fov"), "fov must lie in (0, 180) degrees"));
            }
            Ok((f, None))
        }
        (None, focal) => {
            let (text, loc) = focal.unwrap_or_else(|| ("50mm".to_string(), node.loc.clone()));
            let mm: f64 = text
                .trim()
                .strip_suffix("mm")
                .and_then(|v| v.trim().parse().ok())
                .filter(|v: &f64| *v > 0.0)
                .ok_or_else(|| LoadError::at(&loc, format!("focal_length '{text}' is not of the form '50mm'")))?;
            let diagonal = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
            Ok((2.0 * (diagonal / (2.0 * mm)).atan().to_degrees(), Some(FovAxis::Diagonal)))
        }
    }
}

/// The field of view in degrees and the axis it spans.
pub(super) fn fov_and_axis(node: &Node) -> Result<(f64, FovAxis)> {
    let (fov, forced_axis) = field_of_view(node)?;
    let axis = match node.string("fov_axis", "x")?.as_str() {
        _ if forced_axis.is_some() => forced_axis.unwrap_or(FovAxis::X),
        "x" => FovAxis::X,
        "y" => FovAxis::Y,
        "diagonal" => FovAxis::Diagonal,
        "smaller" => FovAxis::Smaller,
        "larger" => FovAxis::Larger,
        other => {
            return Err(LoadError::at(
                node.loc_of("fov_axis"),
                format!("fov_axis '{other}' is not one of x, y, diagonal, smaller, larger"),
            ))
        }
    };
    Ok((fov, axis))
}
