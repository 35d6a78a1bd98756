//! `<shape>` nodes → [`Shape`]s of the scene: geometry (analytic shapes and
//! meshes read from OBJ, PLY and Mitsuba `.serialized` files), each with its
//! BSDF and optional area emitter, and Mitsuba's `shapegroup` / `instance`.

use super::Geometry;
use super::{emitter, find_plugin, multipart, plugin, resolve, Builder, Plugins};
use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use crate::scene_builder::{GroupId, MeshData, ShapeDesc};
use crate::{obj, ply};
use glam::{DMat4, DVec3};
use penumbra_render::bsdf::DiffuseParams;
use penumbra_render::geometry::{Mesh, Shape, TriangleMesh};
use penumbra_render::material::Material;
use penumbra_render::math::Spectrum;
use penumbra_render::scene::ShapeMedia;
use std::rc::Rc;

/// How a shape plugin is built.
#[derive(Clone, Copy)]
pub(super) enum ShapeBuilder {
    /// A shape with geometry of its own, from its node, `to_world` and
    /// `flip_normals`.
    Geometry(fn(&Node, &DMat4, bool) -> Result<Geometry>),
    /// Mitsuba's `shapegroup` ([`Builder::shape_group`]).
    Group,
    /// Mitsuba's `instance` ([`Builder::instance`]).
    Instance,
    /// Mitsuba's `merge`: its shapes, placed as they are. Mitsuba joins
    /// meshes that share a BSDF, media and emitter into one to save memory;
    /// the image is the same.
    Merge,
}

pub(super) const SHAPES: &Plugins<ShapeBuilder> = &[
    ("rectangle", ShapeBuilder::Geometry(rectangle)),
    ("cube", ShapeBuilder::Geometry(cube)),
    ("sphere", ShapeBuilder::Geometry(sphere)),
    ("disk", ShapeBuilder::Geometry(disk)),
    ("cylinder", ShapeBuilder::Geometry(cylinder)),
    ("ellipsoids", ShapeBuilder::Geometry(multipart::ellipsoids)),
    ("ellipsoidsmesh", ShapeBuilder::Geometry(multipart::ellipsoidsmesh)),
    ("sdfgrid", ShapeBuilder::Geometry(multipart::sdfgrid)),
    ("linearcurve", ShapeBuilder::Geometry(multipart::linearcurve)),
    ("bsplinecurve", ShapeBuilder::Geometry(multipart::bsplinecurve)),
    ("obj", ShapeBuilder::Geometry(mesh_file)),
    ("ply", ShapeBuilder::Geometry(mesh_file)),
    ("serialized", ShapeBuilder::Geometry(serialized)),
    ("shapegroup", ShapeBuilder::Group),
    ("instance", ShapeBuilder::Instance),
    ("merge", ShapeBuilder::Merge),
];

impl Builder {
    /// A top-level shape: placed directly, placed by an instance, or a
    /// shape group (placed only by instances).
    pub(super) fn shape(&mut self, node: &Rc<Node>) -> Result<()> {
        match find_plugin(SHAPES, &node.plugin) {
            Some(ShapeBuilder::Group) => {
                self.shape_group(node)?;
            }
            Some(ShapeBuilder::Instance) => self.instance(node)?,
            Some(ShapeBuilder::Merge) => {
                for child in node.children_of(Kind::Shape) {
                    self.shape(&child.node)?;
                }
                node.check_all_used(&[Kind::Shape])?;
            }
            _ => {
                let id = self.plain_shape(node)?;
                self.scene.place_shape(id);
            }
        }
        Ok(())
    }

    /// Mitsuba's `shapegroup`: its shapes are built once, as shapes of the
    /// scene (with ids, materials and object-space geometry), into a group
    /// that instances place.
    fn shape_group(&mut self, node: &Rc<Node>) -> Result<GroupId> {
        let key = Rc::as_ptr(node);
        if let Some(&g) = self.groups.get(&key) {
            return Ok(g);
        }
        let mut members = Vec::new();
        for child in &node.children {
            let c = &child.node;
            if c.kind != Kind::Shape {
                continue; // reported by check_all_used below
            }
            if c.plugin == "shapegroup" || c.plugin == "instance" {
                return Err(LoadError::at(
                    &child.loc,
                    format!("a {} inside a shapegroup is not supported (nested instancing)", c.plugin),
                ));
            }
            if c.single_child(Kind::Sensor)?.is_some() {
                return Err(LoadError::at(&child.loc, "a sensor inside a shapegroup is not supported"));
            }
            if c.single_child(Kind::Emitter)?.is_some() {
                return Err(LoadError::at(
                    &child.loc,
                    "emitters inside a shapegroup are not allowed (Mitsuba 3 forbids them too)",
                ));
            }
            members.push(self.plain_shape(c)?);
        }
        node.check_all_used(&[Kind::Shape])?;
        if members.is_empty() {
            return Err(node.error("the shapegroup holds no shapes"));
        }
        let group = self.scene.add_group(members, &node.loc)?;
        self.groups.insert(key, group);
        Ok(group)
    }

    /// Mitsuba's `instance`: a shapegroup (by reference) placed by `to_world`.
    fn instance(&mut self, node: &Rc<Node>) -> Result<()> {
        let to_world = node.transform("to_world")?;
        if node.single_child(Kind::Emitter)?.is_some() || node.single_child(Kind::Bsdf)?.is_some() {
            return Err(node.error("an instance takes no emitter or bsdf; its shapegroup's shapes carry their own"));
        }
        let group_node = node
            .single_child(Kind::Shape)?
            .filter(|g| g.plugin == "shapegroup")
            .ok_or_else(|| node.error("an instance needs one shapegroup, e.g. <ref id=\"my_group\"/>"))?;
        let group = self.shape_group(&group_node)?;
        if to_world.as_mat4().determinant() == 0.0 {
            return Err(LoadError::at(node.loc_of("to_world"), "the instance's to_world is singular"));
        }
        node.check_all_used(&[Kind::Shape])?;
        self.scene.add_instance(group, to_world.as_mat4(), node.loc_of("to_world"))
    }

    /// Every other shape: geometry, BSDF and an optional area emitter.
    /// Adds it to the scene's shapes; returns its id.
    fn plain_shape(&mut self, node: &Rc<Node>) -> Result<u32> {
        let to_world = node.transform("to_world")?;
        let flip = node.bool("flip_normals", false)?;
        let ShapeBuilder::Geometry(geometry) = plugin(SHAPES, node)? else {
            // Builder::shape places these, and shape groups refuse them.
            return Err(node.error(format!("a {} cannot be placed here", node.plugin)));
        };
        let (geometry, key) = self.geometry(node, geometry, &to_world, flip)?;
        let (shape, attributes) = &geometry;
        if shape.prim_count() == 0 {
            return Err(node.error(format!("{} has no triangles", node.describe())));
        }

        let emitter = node.single_child(Kind::Emitter)?;
        let bsdf_node = node.single_child(Kind::Bsdf)?;
        let bsdf = match &bsdf_node {
            Some(bn) => self.bsdf(bn)?,
            // Mitsuba's default: diffuse with reflectance 0.5, but black for
            // emitters (checked against Mitsuba 3.9: an emitter without a BSDF
            // reflects nothing).
            None if emitter.is_some() => *self.default_emitter_bsdf.get_or_insert_with(|| {
                self.scene.add_material(Material::Diffuse(DiffuseParams { reflectance: Spectrum::ZERO.into() }))
            }),
            None => *self.default_bsdf.get_or_insert_with(|| {
                self.scene.add_material(Material::Diffuse(DiffuseParams { reflectance: Spectrum::splat(0.5).into() }))
            }),
        };
        let shape_id = self.scene.shape_count() as u32;
        if let Some(bn) = &bsdf_node {
            let indices = if let Shape::Mesh(m) = shape { Some(&m.mesh.indices[..]) } else { None };
            self.textures.bind_mesh_attributes(bn, shape_id, node, attributes, indices)?;
        }
        let emission = match emitter {
            Some(en) if !shape.can_emit() => {
                return Err(LoadError::at(
                    &en.loc,
                    format!("{} cannot carry an area emitter (Mitsuba 3.9.1 cannot sample points on it)", node.plugin),
                ))
            }
            Some(en) => Some(emitter::area(&en, node, shape, &mut self.textures)?),
            None => None,
        };
        if let Some(sensor) = node.single_child(Kind::Sensor)? {
            self.shape_sensors.push((sensor, shape_id));
        }
        let media = self.shape_media(node)?;
        node.check_all_used(&[Kind::Bsdf, Kind::Emitter, Kind::Medium, Kind::Sensor])?;
        let desc = ShapeDesc { geometry, material: bsdf, emission, media, cache_key: Some(key) };
        self.scene.add_shape(desc, &node.loc)
    }

    /// The media a shape bounds: nested or referenced `<medium>`s named
    /// `interior` and `exterior` (Mitsuba's attachment).
    fn shape_media(&mut self, node: &Node) -> Result<ShapeMedia> {
        let mut m = ShapeMedia::default();
        for c in node.children_of(Kind::Medium) {
            let slot = match c.name.as_deref() {
                Some("interior") => &mut m.interior,
                Some("exterior") => &mut m.exterior,
                other => {
                    return Err(LoadError::at(
                        &c.loc,
                        format!(
                            "a medium inside a shape needs name=\"interior\" or name=\"exterior\" (found {})",
                            other.map_or("no name".to_string(), |n| format!("'{n}'"))
                        ),
                    ))
                }
            };
            if slot.is_some() {
                return Err(LoadError::at(
                    &c.loc,
                    format!("only one {} medium can be given per shape", c.name.as_deref().unwrap_or_default()),
                ));
            }
            *slot = Some(self.media.get(&c.node, &mut self.scene)?);
        }
        Ok(m)
    }

    /// `node`'s geometry from the [`super::GeometryCache`], or built and
    /// cached, with its cache key. A reused entry marks the properties its
    /// builder read, as a build would.
    fn geometry(
        &mut self,
        node: &Node,
        build: fn(&Node, &DMat4, bool) -> Result<Geometry>,
        to_world: &DMat4,
        flip: bool,
    ) -> Result<(Geometry, String)> {
        let props: Vec<String> = node.props.iter().map(|p| format!("{}={:?}", p.name, p.value)).collect();
        let key = format!("{}|{}|{}", node.loc, node.plugin, props.join(";"));
        let (geometry, read) = self.scene.cached_geometry(&key, || {
            let unread: Vec<bool> = node.props.iter().map(|p| !p.used.get()).collect();
            let geometry = build(node, to_world, flip)?;
            let read = node.props.iter().zip(unread).filter(|(p, u)| *u && p.used.get()).map(|(p, _)| p.name.clone());
            Ok((geometry, read.collect()))
        })?;
        for p in node.props.iter().filter(|p| read.contains(&p.name)) {
            p.used.set(true);
        }
        Ok((geometry, key))
    }
}

/// A shape's geometry alone, outside the scene (a `distant` sensor's
/// target): a plain shape of positive area with no BSDF, emitter or media.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
pub(super) fn detached_shape(node: &Node) -> Result<Shape> {
    let Some(ShapeBuilder::Geometry(build)) = find_plugin(SHAPES, &node.plugin) else {
        return Err(node.error(format!("a {} cannot be a sensor's target; give a plain shape", node.plugin)));
    };
    let to_world = node.transform("to_world")?;
    let flip = node.bool("flip_normals", false)?;
    let (shape, _) = build(node, &to_world, flip)?;
    node.check_all_used(&[])?;
    if !(shape.area() > 0.0) {
        return Err(node.error("the target shape has zero area"));
    }
    Ok(shape)
}

/// A mesh of `m`'s triangles placed by `to_world`.
fn placed_mesh(mut m: TriangleMesh, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    m.transform(&to_world.as_mat4());
    if flip {
        m.flip();
    }
    Ok((Shape::Mesh(Mesh::new(m, false)), Vec::new()))
}

fn rectangle(_: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    let (mut shape, attributes) = placed_mesh(TriangleMesh::rectangle(), to_world, flip)?;
    if let Shape::Mesh(m) = &mut shape {
        m.rectangle = true;
    }
    Ok((shape, attributes))
}

fn cube(_: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    placed_mesh(TriangleMesh::cube(), to_world, flip)
}

/// Mitsuba's `obj` and `ply`.
fn mesh_file(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    let (file, loc) =
        node.get_string("filename")?.ok_or_else(|| node.error(format!("{} needs a 'filename'", node.describe())))?;
    let path = resolve(&loc, &file, "mesh file")?;
    // Mitsuba flips v for OBJ by default, not for PLY.
    let flip_uv = node.bool("flip_tex_coords", node.plugin == "obj")?;
    let (m, attributes) = if node.plugin == "obj" {
        (obj::load_obj_with(&path, flip_uv)?, Vec::new())
    } else {
        ply::load_ply_with_attributes(&path, flip_uv)?
    };
    let face_normals = node.bool("face_normals", false)?;
    let TriangleMesh { positions, normals, uvs, indices } = m;
    let data = MeshData { positions, indices, normals, uvs, colors: Vec::new(), attributes };
    data.into_geometry(&to_world.as_mat4(), flip, face_normals, &loc)
        .map_err(|e| LoadError::at(&loc, format!("mesh '{}': {}", path.display(), e.message)))
}

fn sphere(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    let c = node.get_point("center")?.unwrap_or(DVec3::ZERO);
    let r = node.float("radius", 1.0)?;
    // The sphere's own parameters compose with to_world, as in Mitsuba.
    let m = *to_world * DMat4::from_translation(c) * DMat4::from_scale(DVec3::splat(r));
    let center = m.transform_point3(DVec3::ZERO);
    let axes = [DVec3::X, DVec3::Y, DVec3::Z].map(|a| m.transform_vector3(a).length());
    if (axes[0] - axes[1]).abs() > 1e-6 * axes[0] || (axes[0] - axes[2]).abs() > 1e-6 * axes[0] {
        return Err(node.error("sphere: to_world must not scale non-uniformly (use a mesh for ellipsoids)"));
    }
    let rot = glam::DMat3::from_mat4(m) * (1.0 / axes[0]);
    Ok((Shape::sphere_rotated(center.as_vec3(), axes[0] as f32, rot.as_mat3(), flip), Vec::new()))
}

fn disk(_: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    Ok((Shape::disk(to_world.as_mat4(), flip), Vec::new()))
}

fn cylinder(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    let p0 = node.get_point("p0")?.unwrap_or(DVec3::ZERO);
    let p1 = node.get_point("p1")?.unwrap_or(DVec3::Z);
    let r = node.float("radius", 1.0)?;
    let c = penumbra_render::geometry::Cylinder::new(*to_world, p0, p1, r, flip).map_err(|e| node.error(e))?;
    Ok((Shape::Cylinder(c), Vec::new()))
}

/// Mitsuba's `serialized` shape: one mesh (`shape_index`) of a `.serialized` file.
fn serialized(node: &Node, to_world: &DMat4, flip: bool) -> Result<Geometry> {
    let (file, loc) =
        node.get_string("filename")?.ok_or_else(|| node.error("serialized needs a 'filename'".to_string()))?;
    let path = resolve(&loc, &file, "mesh file")?;
    let index = node.int("shape_index", 0)?;
    if index < 0 {
        return Err(LoadError::at(node.loc_of("shape_index"), "shape_index must be nonnegative"));
    }
    let s = crate::serialized::load_serialized(&path, index as usize)
        .map_err(|e| LoadError::at(&loc, format!("'{}': {}", path.display(), e.message)))?;
    // Mitsuba 3.9.1 ignores the file's face-normals flag (0x0010); so do we.
    let face_normals = node.bool("face_normals", false)?;
    let mut m = s.mesh;
    m.transform(&to_world.as_mat4());
    if !face_normals && m.normals.is_empty() {
        // As Mitsuba: smooth normals from the (world-space) faces.
        m.recompute_vertex_normals();
    }
    if flip {
        m.flip();
    }
    Ok((Shape::Mesh(Mesh::new(m, face_normals)), Vec::new()))
}
