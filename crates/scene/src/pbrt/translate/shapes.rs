//! pbrt-v4's shapes as Penumbra's geometry, oriented as pbrt-v4 orients
//! them: a surface's normal is reversed by `ReverseOrientation` and by a
//! transform that swaps handedness (pbrt-v4's `reverseOrientation ^
//! transformSwapsHandedness`), except that a mesh with normals `N` faces
//! them (pbrt-v4's `FaceForward(n, ns)`); that side is the one an area
//! light emits from.
//!
//! | shape        | parameters read                                                  |
//! |--------------|------------------------------------------------------------------|
//! | trianglemesh | indices, P, N, uv, faceIndices (unused)                           |
//! | plymesh      | filename (.ply or .ply.gz; quads split into triangles)            |
//! | bilinearmesh | indices, P, N, uv: each patch split into two triangles (a non-planar patch is approximated by them) |
//! | loopsubdiv   | levels (3), indices, P                                            |
//! | sphere       | radius (1); zmin, zmax, phimax only at their full-sphere values   |
//! | disk         | radius (1), height (0); innerradius 0, phimax 360 only            |
//! | cylinder     | radius (1), zmin (-1), zmax (1); phimax 360 only                  |
//! | (any)        | alpha (1; a float or a float texture): a cut-out mask             |
//!
//! Spheres and cylinders have pbrt-v4's (u, v) (a cylinder's, Mitsuba's
//! with p0 and p1 on the z axis, is the same); a disk takes Mitsuba's
//! (r, φ / 2π), where pbrt-v4 has (φ / 2π, 1 − r).

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose

use super::super::params::{ParamList, ParamType};
use super::super::parser::ShapeEntity;
use crate::error::{FileLoc, LoadError, Result};
use crate::scene_builder::{Geometry, MeshData};
use glam::{DMat3, DMat4, DVec3, Mat4, Vec2, Vec3};
use penumbra_render::geometry::{Cylinder, Shape};

/// Shapes Penumbra translates, for error messages.
pub const SHAPES: &[&str] = &["trianglemesh", "plymesh", "bilinearmesh", "loopsubdiv", "sphere", "disk", "cylinder"];

fn swaps_handedness(m: &DMat4) -> bool {
    DMat3::from_mat4(*m).determinant() < 0.0
}

/// A mesh in object space placed by `m` and oriented as pbrt-v4 orients it.
fn mesh(mut data: MeshData, m: &DMat4, reverse: bool, at: &FileLoc) -> Result<Geometry> {
    let mf = m.as_mat4();
    let normal_m = glam::Mat3::from_mat4(mf).inverse().transpose();
    for p in &mut data.positions {
        *p = mf.transform_point3(*p);
    }
    let flip = if data.normals.is_empty() {
        reverse ^ swaps_handedness(m)
    } else {
        if data.normals.len() != data.positions.len() {
            return Err(LoadError::at(
                at,
                format!("{} normals for {} positions: give one per vertex", data.normals.len(), data.positions.len()),
            ));
        }
        for n in &mut data.normals {
            *n = (normal_m * *n).normalize_or_zero() * if reverse { -1.0 } else { 1.0 };
        }
        // The geometric normal faces the shading normals.
        for t in &mut data.indices {
            let (a, b, c) = (t[0] as usize, t[1] as usize, t[2] as usize);
            if a.max(b).max(c) >= data.positions.len() {
                continue; // into_geometry names the bad index
            }
            let p = &data.positions;
            let g = (p[b] - p[a]).cross(p[c] - p[a]);
            if g.dot(data.normals[a] + data.normals[b] + data.normals[c]) < 0.0 {
                t.swap(1, 2);
            }
        }
        false
    };
    data.into_geometry(&Mat4::IDENTITY, flip, false, at)
}

fn vec3s(v: Vec<[f64; 3]>) -> Vec<Vec3> {
    v.into_iter().map(|[x, y, z]| Vec3::new(x as f32, y as f32, z as f32)).collect()
}

/// `indices` as triangles (or as groups of `n`), checked against `count` vertices.
fn indices(p: &ParamList, n: usize, count: usize, at: &FileLoc) -> Result<Vec<u32>> {
    let idx = match p.ints("indices")? {
        Some(i) => i,
        None if count == n => (0..n as i64).collect(),
        None => return Err(LoadError::at(at, format!("\"integer indices\" is required (there are {count} vertices)"))),
    };
    if idx.len() % n != 0 {
        return Err(LoadError::at(at, format!("{} indices are not a multiple of {n}", idx.len())));
    }
    if let Some(bad) = idx.iter().find(|&&i| i < 0 || i as usize >= count) {
        return Err(LoadError::at(at, format!("index {bad} is out of range: there are {count} vertices")));
    }
    Ok(idx.into_iter().map(|i| i as u32).collect())
}

fn full(p: &ParamList, name: &str, full: f64, at: &FileLoc, what: &str) -> Result<()> {
    let v = p.float(name, full)?;
    if v != full {
        return Err(LoadError::at(
            at,
            format!("{what}: \"float {name}\" {v} (a partial shape) is not supported; only {full}"),
        ));
    }
    Ok(())
}

/// The geometry of `s` (with `world_from_object` as its transform).
pub fn geometry(s: &ShapeEntity) -> Result<Geometry> {
    let e = &s.entity;
    let (p, at) = (&e.params, &e.loc);
    let m = &s.world_from_object;
    let rev = s.reverse_orientation;
    let g = match e.kind.as_str() {
        "trianglemesh" => {
            let positions = vec3s(p.triples("P", ParamType::Point3)?.unwrap_or_default());
            if positions.is_empty() {
                return Err(LoadError::at(at, "trianglemesh needs \"point3 P\""));
            }
            let idx = indices(p, 3, positions.len(), at)?;
            let normals = vec3s(p.triples("N", ParamType::Normal3)?.unwrap_or_default());
            let uvs: Vec<Vec2> = p
                .pairs("uv", ParamType::Point2)?
                .unwrap_or_default()
                .into_iter()
                .map(|[u, v]| Vec2::new(u as f32, v as f32))
                .collect();
            if !uvs.is_empty() && uvs.len() != positions.len() {
                return Err(LoadError::at(at, format!("{} uvs for {} positions", uvs.len(), positions.len())));
            }
            p.ints("faceIndices")?;
            let indices = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            mesh(MeshData { positions, indices, normals, uvs, ..Default::default() }, m, rev, at)?
        }
        "bilinearmesh" => {
            let positions = vec3s(p.triples("P", ParamType::Point3)?.unwrap_or_default());
            let idx = indices(p, 4, positions.len(), at)?;
            let normals = vec3s(p.triples("N", ParamType::Normal3)?.unwrap_or_default());
            let uvs: Vec<Vec2> = p
                .pairs("uv", ParamType::Point2)?
                .unwrap_or_default()
                .into_iter()
                .map(|[u, v]| Vec2::new(u as f32, v as f32))
                .collect();
            // pbrt's patch (p00, p10, p01, p11): corners in order p00 p10 p11 p01.
            let indices = idx.chunks_exact(4).flat_map(|c| [[c[0], c[1], c[3]], [c[0], c[3], c[2]]]).collect();
            mesh(MeshData { positions, indices, normals, uvs, ..Default::default() }, m, rev, at)?
        }
        "loopsubdiv" => {
            let positions = vec3s(p.triples("P", ParamType::Point3)?.unwrap_or_default());
            let idx = indices(p, 3, positions.len(), at)?;
            let levels = p.int("levels", 3)?;
            if !(0..=10).contains(&levels) {
                return Err(LoadError::at(at, format!("loopsubdiv: levels {levels} must lie in 0..=10")));
            }
            let tris: Vec<[u32; 3]> = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            let (positions, normals, indices) =
                penumbra_render::geometry::loop_subdiv::loop_subdivide(levels as u32, &positions, &tris)
                    .map_err(|e| LoadError::at(at, format!("loopsubdiv: {e}")))?;
            mesh(MeshData { positions, indices, normals, ..Default::default() }, m, rev, at)?
        }
        "plymesh" => {
            let file = p.string("filename")?.ok_or_else(|| LoadError::at(at, "plymesh needs a \"string filename\""))?;
            let path = at.file.parent().map(|d| d.join(&file)).unwrap_or_else(|| file.clone().into());
            let bytes = std::fs::read(&path)
                .map_err(|e| LoadError::at(at, format!("cannot read PLY file '{}': {e}", path.display())))?;
            let bytes = if file.ends_with(".gz") {
                let mut out = Vec::new();
                std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(&bytes[..]), &mut out)
                    .map_err(|e| LoadError::at(at, format!("'{}': not a valid gzip file: {e}", path.display())))?;
                out
            } else {
                bytes
            };
            let tm = crate::ply::parse_ply(&bytes, &path, false)
                .map_err(|e| LoadError::at(at, format!("PLY file '{}': {}", path.display(), e.message)))?;
            let data = MeshData {
                positions: tm.positions,
                indices: tm.indices,
                normals: tm.normals,
                uvs: tm.uvs,
                ..Default::default()
            };
            mesh(data, m, rev, at)?
        }
        "sphere" => {
            let r = p.float("radius", 1.0)?;
            full(p, "zmin", -r, at, "sphere")?;
            full(p, "zmax", r, at, "sphere")?;
            full(p, "phimax", 360.0, at, "sphere")?;
            let mm = *m * DMat4::from_scale(DVec3::splat(r));
            let axes = [DVec3::X, DVec3::Y, DVec3::Z].map(|a| mm.transform_vector3(a).length());
            if !(axes[0] > 0.0)
                || (axes[0] - axes[1]).abs() > 1e-6 * axes[0]
                || (axes[0] - axes[2]).abs() > 1e-6 * axes[0]
            {
                return Err(LoadError::at(
                    at,
                    "sphere: the transform must scale uniformly (an ellipsoid is not supported)",
                ));
            }
            // pbrt-v4's v runs from the -z pole (0) to the +z pole (1),
            // Mitsuba's from +z (0) to -z (1), u alike: the local frame is
            // mirrored in z, which maps one onto the other.
            let rot = DMat3::from_mat4(mm) * (1.0 / axes[0]) * DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0));
            let center = mm.transform_point3(DVec3::ZERO).as_vec3();
            let flip = rev ^ swaps_handedness(m);
            (Shape::sphere_rotated(center, axes[0] as f32, rot.as_mat3(), flip), Vec::new())
        }
        "disk" => {
            let r = p.float("radius", 1.0)?;
            let h = p.float("height", 0.0)?;
            full(p, "innerradius", 0.0, at, "disk")?;
            full(p, "phimax", 360.0, at, "disk")?;
            let mm = *m * DMat4::from_translation(DVec3::new(0.0, 0.0, h)) * DMat4::from_scale(DVec3::new(r, r, 1.0));
            // Penumbra's disk normal, X × Y of the placed axes, already turns
            // with a handedness swap as pbrt-v4's flipped normal does.
            (Shape::disk(mm.as_mat4(), rev), Vec::new())
        }
        "cylinder" => {
            let r = p.float("radius", 1.0)?;
            let (z0, z1) = (p.float("zmin", -1.0)?, p.float("zmax", 1.0)?);
            full(p, "phimax", 360.0, at, "cylinder")?;
            let (lo, hi) = (z0.min(z1), z0.max(z1));
            let c = Cylinder::new(*m, DVec3::new(0.0, 0.0, lo), DVec3::new(0.0, 0.0, hi), r, rev ^ swaps_handedness(m))
                .map_err(|e| LoadError::at(at, e))?;
            (Shape::Cylinder(c), Vec::new())
        }
        other => {
            return Err(LoadError::at(
                at,
                format!("shape \"{other}\" is not supported; supported: {}", SHAPES.join(", ")),
            ))
        }
    };
    Ok(g)
}
