//! The shapes whose BVH primitives are parts of one plugin: Mitsuba's
//! `ellipsoids` and `ellipsoidsmesh` (each reading a PLY file of
//! ellipsoids), `sdfgrid`, `linearcurve` and `bsplinecurve`. Only
//! `ellipsoidsmesh` (a mesh in Mitsuba) can carry an `area` emitter: Mitsuba
//! 3.9.1 cannot sample points on the others ([`Shape::can_emit`]).

use super::resolve;
use super::Geometry;
use crate::desc::Node;
use crate::error::{LoadError, Result};
use crate::ply;
use glam::Vec4;
use glam::{DMat3, DMat4, DVec3};
use penumbra_render::geometry::curves::Basis;
use penumbra_render::geometry::ellipsoids::quat_to_matrix;
use penumbra_render::geometry::{Curves, Ellipsoid, Ellipsoids, Mesh, SdfGrid, Shape, Shell};

/// Mitsuba's `ellipsoids`: analytic ellipsoids with back faces culled.
///
/// | parameter | type | default | meaning |
/// |---|---|---|---|
/// | `filename` | string | required | PLY file: the first element's float columns `x y z nx ny nz`, any extra columns, then `scale_0 scale_1 scale_2 rot_0 rot_1 rot_2 rot_3` (log radii; quaternion with its real part first) |
/// | `scale_factor` | float | 1 | multiplies every radius (> 0) |
/// | `extent` | float | 3 | multiplies every radius (> 0) |
/// | `extent_adaptive_clamping` | boolean | false | scales each extent by sqrt(2 ln(opacity / 0.01)) / 3, the opacity from a 3D Gaussian Splatting file's `opacity` (through a sigmoid) or an `opacities` column |
/// | `to_world` | transform | identity | moves the centres; its rotation turns and its (uniform) scale scales the ellipsoids |
///
/// The tensor parameters `data`, `centers`, `scales` and `quaternions`
/// cannot be written in XML; an area emitter is refused. Radii are
/// exp(scale_k) clamped below at 1e-6, as Mitsuba reads them.
pub(super) fn ellipsoids(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    let items = load_ellipsoids(node, to_world, flip)?;
    Ok((Shape::Ellipsoids(Ellipsoids { items }), Vec::new()))
}

/// Mitsuba's `ellipsoidsmesh`: the ellipsoids of [`ellipsoids`] as shells
/// of flat triangles whose back faces are culled.
///
/// | parameter | type | default | meaning |
/// |---|---|---|---|
/// | `filename`, `scale_factor`, `extent`, `extent_adaptive_clamping`, `to_world` | | | as for `ellipsoids` |
/// | `shell` | string | `ico_sphere` | the shell per ellipsoid: `ico_sphere` (or `default`, 20 triangles), `box` (12), `uv_sphere` (72), scaled so that its vertices and face centres lie on or outside the ellipsoid |
///
/// An `area` emitter emits from the shells' front faces, sampled by area as
/// on any mesh. A nested mesh as the shell is not supported (an error).
pub(super) fn ellipsoidsmesh(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    let shell = match node.get_string("shell")? {
        None => Shell::IcoSphere,
        Some((s, loc)) => match s.as_str() {
            "default" | "ico_sphere" => Shell::IcoSphere,
            "box" => Shell::Box,
            "uv_sphere" => Shell::UvSphere,
            _ => {
                return Err(LoadError::at(
                    &loc,
                    format!("shell type '{s}' is not supported; use one of default, box, ico_sphere, uv_sphere"),
                ))
            }
        },
    };
    let items = load_ellipsoids(node, to_world, flip)?;
    let mesh = shell.mesh(&items);
    Ok((Shape::CulledMesh(Mesh::new(mesh, true)), Vec::new()))
}

/// The rotation R and scale s of a linear map s·R, or None when it shears,
/// scales unevenly or mirrors.
fn similarity(m: &DMat4) -> Option<(DMat3, f64)> {
    let a = DMat3::from_mat4(*m);
    let s = a.determinant().cbrt();
    if !(s > 0.0 && s.is_finite()) {
        return None;
    }
    let r = a * (1.0 / s);
    let err = (r.transpose() * r - DMat3::IDENTITY).to_cols_array().iter().fold(0.0f64, |e, x| e.max(x.abs()));
    (err < 1e-5).then_some((r, s))
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0)` is also true for NaN, on purpose
fn load_ellipsoids(node: &Node, to_world: &DMat4, flip: bool) -> Result<Vec<Ellipsoid>> {
    let what = node.plugin.as_str();
    for tensor in ["data", "centers", "scales", "quaternions"] {
        if node.has(tensor) {
            return Err(LoadError::at(
                node.loc_of(tensor),
                format!(
                    "'{tensor}' of {what} is a tensor, which a scene file cannot give; use 'filename' (a PLY file)"
                ),
            ));
        }
    }
    if flip {
        return Err(LoadError::at(node.loc_of("flip_normals"), format!("{what} has no parameter 'flip_normals'")));
    }
    let (file, loc) = node.get_string("filename")?.ok_or_else(|| node.error(format!("{what} needs a 'filename'")))?;
    let scale_factor = node.float("scale_factor", 1.0)?;
    if !(scale_factor > 0.0) {
        return Err(LoadError::at(node.loc_of("scale_factor"), "scale_factor must be positive"));
    }
    let extent = node.float("extent", 3.0)?;
    if !(extent > 0.0) {
        return Err(LoadError::at(node.loc_of("extent"), "extent must be positive"));
    }
    let adaptive = node.bool("extent_adaptive_clamping", false)?;
    let (world_rot, world_scale) = similarity(to_world).ok_or_else(|| {
        LoadError::at(
            node.loc_of("to_world"),
            format!("{what}: to_world may only rotate, translate and scale uniformly"),
        )
    })?;
    let path = resolve(&loc, &file, "PLY file")?;
    let table = ply::load_ply_table(&path)?;
    let in_file = |msg: String| LoadError::at(&loc, format!("'{}': {msg}", path.display()));
    let names = &table.names;
    let n = names.len();
    let head = ["x", "y", "z", "nx", "ny", "nz"];
    let tail = ["scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"];
    if n < 13 || names[..6] != head || names[n - 7..] != tail {
        return Err(in_file(format!(
            "the columns must be {} (extras) {}; found {}",
            head.join(" "),
            tail.join(" "),
            names.join(" ")
        )));
    }
    // Opacities for adaptive clamping: a 3D Gaussian Splatting file's
    // `opacity` (through a sigmoid), or an extra column named `opacities`.
    let is_3dgs = names[6] == "f_dc_0" && names[n - 8] == "opacity";
    let opacity_column =
        if is_3dgs { Some(n - 8) } else { names[6..n - 7].iter().position(|c| c == "opacities").map(|i| i + 6) };
    if adaptive && opacity_column.is_none() {
        return Err(LoadError::at(
            node.loc_of("extent_adaptive_clamping"),
            "extent_adaptive_clamping needs opacities (an 'opacities' column, or a 3D Gaussian Splatting file)",
        ));
    }
    let mut items = Vec::with_capacity(table.rows());
    for (i, row) in table.values.chunks_exact(n).enumerate() {
        if let Some(k) = row.iter().position(|v| !v.is_finite()) {
            return Err(in_file(format!("ellipsoid {i}: column '{}' is not a finite number", names[k])));
        }
        let center = to_world.transform_point3(DVec3::new(row[0] as f64, row[1] as f64, row[2] as f64));
        let mut ext = extent;
        if adaptive {
            let raw = row[opacity_column.unwrap_or_default()] as f64;
            let opacity = if is_3dgs { (1.0 / (1.0 + (-raw).exp())).clamp(1e-8, 1.0 - 1e-8) } else { raw };
            ext *= (2.0 * (opacity / 0.01).ln()).sqrt() / 3.0;
            // Mitsuba's radii become NaN or zero here: nothing is hit.
            if !(ext > 0.0) {
                continue;
            }
        }
        let s = DVec3::new(row[n - 7] as f64, row[n - 6] as f64, row[n - 5] as f64).exp().max(DVec3::splat(1e-6));
        let scale = s * scale_factor * world_scale * ext;
        let q = [row[n - 3] as f64, row[n - 2] as f64, row[n - 1] as f64, row[n - 4] as f64];
        let len = q.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(len > 0.0) {
            return Err(in_file(format!("ellipsoid {i}: the quaternion rot_0..rot_3 is zero")));
        }
        let rot = world_rot * quat_to_matrix(q.map(|x| x / len));
        if !scale.is_finite() || !center.is_finite() {
            return Err(in_file(format!("ellipsoid {i}: its radii or centre overflow")));
        }
        items.push(Ellipsoid { center: center.as_vec3(), scale: scale.as_vec3(), rot: rot.as_mat3() });
    }
    if items.is_empty() {
        return Err(in_file("the file holds no ellipsoids".into()));
    }
    Ok(items)
}

/// Mitsuba's `sdfgrid`: a signed distance grid over the object-space unit
/// cube, its zero set the surface.
///
/// | parameter | type | default | meaning |
/// |---|---|---|---|
/// | `filename` | string | required | a Mitsuba `.vol` file with one channel, at least 2 values per axis (the header's box is ignored: the grid spans [0, 1]³) |
/// | `normals` | string | `smooth` | shading normals: `smooth` (blended across voxels) or `analytic` (the gradient) |
/// | `to_world` | transform | identity | places the unit cube; it may scale (also unevenly) and translate but not rotate (Mitsuba's voxel boxes are then wrong: use `shapegroup` and `instance`) |
///
/// The tensor parameter `grid` cannot be written in XML; an area emitter is refused.
pub(super) fn sdfgrid(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    if node.has("grid") {
        return Err(LoadError::at(
            node.loc_of("grid"),
            "'grid' of sdfgrid is a tensor, which a scene file cannot give; use 'filename' (a .vol file)",
        ));
    }
    if flip {
        return Err(LoadError::at(node.loc_of("flip_normals"), "sdfgrid has no parameter 'flip_normals'"));
    }
    let smooth = match node.get_string("normals")? {
        None => true,
        Some((s, loc)) => match s.as_str() {
            "smooth" => true,
            "analytic" => false,
            _ => {
                return Err(LoadError::at(
                    &loc,
                    format!("invalid normals mode '{s}'; it must be 'analytic' or 'smooth'"),
                ))
            }
        },
    };
    let a = DMat3::from_mat4(*to_world);
    let off_diagonal = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)];
    let size = a.to_cols_array().iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if off_diagonal.iter().any(|&(c, r)| a.col(c)[r].abs() > 1e-6 * size) {
        return Err(LoadError::at(
            node.loc_of("to_world"),
            "sdfgrid: to_world must not rotate the grid (use a shapegroup and an instance)",
        ));
    }
    let (file, loc) = node.get_string("filename")?.ok_or_else(|| node.error("sdfgrid needs a 'filename'"))?;
    let path = resolve(&loc, &file, "SDF grid file")?;
    let in_file = |msg: String| LoadError::at(&loc, format!("'{}': {msg}", path.display()));
    let vol = crate::vol::read(&path).map_err(in_file)?;
    if vol.grid.channels != 1 {
        return Err(in_file(format!("the grid has {} channels; an SDF grid has 1", vol.grid.channels)));
    }
    let res = vol.grid.res.map(|r| r as usize);
    let g = SdfGrid::new(res, vol.grid.data, *to_world, smooth).map_err(in_file)?;
    Ok((Shape::SdfGrid(g), Vec::new()))
}

/// Mitsuba's `linearcurve`: round tubes through control points (Embree's
/// round linear curves: cones between spheres at the control points), back
/// faces culled.
///
/// | parameter | type | default | meaning |
/// |---|---|---|---|
/// | `filename` | string | required | a text file, one control point per line: `x y z radius`; an empty line starts a new curve; each curve has at least 2 points |
/// | `to_world` | transform | identity | moves the control points (the radii are not transformed, as in Mitsuba) |
///
/// Radii must be finite and not negative; an area emitter is refused.
pub(super) fn linearcurve(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    if flip {
        return Err(LoadError::at(node.loc_of("flip_normals"), "linearcurve has no parameter 'flip_normals'"));
    }
    let (points, curves) = load_curves(node, to_world, 2)?;
    let mut segments = Vec::new();
    for (first, n) in curves {
        segments.extend((first..first + n - 1).map(|k| k as u32));
    }
    Ok((Shape::Curves(Curves { points, segments, basis: Basis::Linear }), Vec::new()))
}

/// Mitsuba's `bsplinecurve`: tubes along uniform cubic B-splines (Embree's
/// round B-spline curves: circles of the interpolated radius swept
/// perpendicular to the curve), open at the ends, back faces culled.
///
/// | parameter | type | default | meaning |
/// |---|---|---|---|
/// | `filename` | string | required | a text file, one control point per line: `x y z radius`; an empty line starts a new curve; each curve has at least 4 points (n points make n − 3 segments) |
/// | `to_world` | transform | identity | moves the control points (the radii are not transformed, as in Mitsuba) |
///
/// Radii must be finite and not negative; an area emitter is refused.
pub(super) fn bsplinecurve(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    if flip {
        return Err(LoadError::at(node.loc_of("flip_normals"), "bsplinecurve has no parameter 'flip_normals'"));
    }
    let (points, curves) = load_curves(node, to_world, 4)?;
    let mut segments = Vec::new();
    for (first, n) in curves {
        segments.extend((first..first + n - 3).map(|k| k as u32));
    }
    Ok((Shape::Curves(Curves { points, segments, basis: Basis::BSpline }), Vec::new()))
}

/// A curve file's control points (x, y, z, radius) and each curve's
/// (first point, point count).
type CurveFile = (Vec<Vec4>, Vec<(usize, usize)>);

/// The control points of a curve file (positions placed by `to_world`,
/// radii as written) and each curve's (first point, point count); every
/// curve needs `min_points`.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(r >= 0)` is also true for NaN, on purpose
fn load_curves(node: &Node, to_world: &DMat4, min_points: usize) -> Result<CurveFile> {
    let what = node.plugin.as_str();
    let (file, loc) = node.get_string("filename")?.ok_or_else(|| node.error(format!("{what} needs a 'filename'")))?;
    let path = resolve(&loc, &file, "curve file")?;
    let in_file = |msg: String| LoadError::at(&loc, format!("'{}': {msg}", path.display()));
    let bytes = std::fs::read(&path).map_err(|e| in_file(format!("cannot read: {e}")))?;
    let text = crate::error::utf8_text(bytes).map_err(in_file)?;
    let mut points = Vec::new();
    let mut curves: Vec<(usize, usize)> = Vec::new();
    // (first point, line it starts on) of the curve being read.
    let mut open: Option<(usize, usize)> = None;
    let mut close = |open: &mut Option<(usize, usize)>, points: &Vec<Vec4>| -> Result<()> {
        if let Some((first, line)) = open.take() {
            let n = points.len() - first;
            if n < min_points {
                return Err(in_file(format!(
                    "line {line}: the curve starting here has {n} control point{}; a {what} needs at least {min_points}",
                    if n == 1 { "" } else { "s" }
                )));
            }
            curves.push((first, n));
        }
        Ok(())
    };
    for (i, raw) in text.split('\n').enumerate() {
        let line = i + 1;
        let words: Vec<&str> = raw.split([' ', '\t', '\r']).filter(|w| !w.is_empty()).collect();
        if words.is_empty() {
            close(&mut open, &points)?;
            continue;
        }
        let values: Vec<f64> = words.iter().filter_map(|w| w.parse::<f64>().ok()).collect();
        if words.len() != 4 || values.len() != 4 {
            return Err(in_file(format!("line {line}: expected 4 numbers (x y z radius), found '{}'", raw.trim())));
        }
        if values.iter().any(|v| !v.is_finite()) {
            return Err(in_file(format!("line {line}: '{}' holds a NaN or infinite value", raw.trim())));
        }
        let r = values[3];
        if !(r >= 0.0) {
            return Err(in_file(format!("line {line}: the radius {r} is negative")));
        }
        let p = to_world.transform_point3(DVec3::new(values[0], values[1], values[2]));
        if !p.as_vec3().is_finite() {
            return Err(in_file(format!("line {line}: the placed point overflows")));
        }
        open.get_or_insert((points.len(), line));
        points.push(p.as_vec3().extend(r as f32));
    }
    close(&mut open, &points)?;
    if points.is_empty() {
        return Err(in_file("the file holds no control points".into()));
    }
    Ok((points, curves))
}
