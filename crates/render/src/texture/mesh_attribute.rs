//! Mitsuba's `mesh_attribute` texture: a per-vertex or per-face value stored
//! with a mesh (a PLY file's vertex colours or other properties), scaled.
//!
//! As in Mitsuba 3.9.1 (`src/textures/mesh_attribute.cpp`,
//! `Mesh::eval_attribute`), vertex attributes are interpolated with the
//! hit's barycentric coordinates and face attributes are constant over a
//! triangle. The attribute belongs to the hit shape, so the texture holds
//! one [`AttributeTable`] per scene shape id, filled by the scene builder
//! once every shape exists; evaluation is an index into it (no allocation,
//! no lookup by name).

use crate::geometry::SurfaceInteraction;
use crate::math::Spectrum;
use std::sync::OnceLock;

/// One attribute of a mesh as a loader reads it (Mitsuba's `vertex_<name>`
/// or `face_<name>`): `dim` floats per vertex or per triangle.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshAttributeData {
    /// With its prefix, as `mesh_attribute` names it: `vertex_color`, `face_<name>`.
    pub name: String,
    /// One value per vertex (`vertex_`), else per triangle (`face_`).
    pub per_vertex: bool,
    /// Components per value.
    pub dim: usize,
    /// The values, `dim` floats each, in vertex or face order.
    pub data: Vec<f32>,
}

/// An attribute laid out for evaluation: per triangle, its three corners'
/// values (vertex attributes) or its one value (face attributes), each of
/// one or three components.
#[derive(Debug, Clone)]
pub struct AttributeTable {
    per_vertex: bool,
    dim: usize,
    values: Vec<f32>,
}

impl AttributeTable {
    /// Lays `attr` out over the triangles `indices` (in their final
    /// winding). `attr.dim` must be 1 or 3.
    pub fn new(attr: &MeshAttributeData, indices: &[[u32; 3]]) -> AttributeTable {
        let dim = attr.dim;
        assert!(dim == 1 || dim == 3, "attribute tables hold 1 or 3 components");
        let values = if attr.per_vertex {
            let mut v = Vec::with_capacity(indices.len() * 3 * dim);
            for t in indices {
                for &i in t {
                    let i = i as usize * dim;
                    v.extend_from_slice(&attr.data[i..i + dim]);
                }
            }
            v
        } else {
            attr.data[..indices.len() * dim].to_vec()
        };
        AttributeTable { per_vertex: attr.per_vertex, dim, values }
    }

    /// The value on triangle `prim` at barycentrics (b1, b2), as three
    /// channels (a one-component attribute is broadcast, as Mitsuba's
    /// `eval_attribute` does for RGB variants).
    #[inline]
    pub fn eval(&self, prim: u32, b1: f32, b2: f32) -> Spectrum {
        let d = self.dim;
        let get = |k: usize| {
            let i = k * d;
            if d == 1 {
                Spectrum::splat(self.values[i])
            } else {
                Spectrum::new(self.values[i], self.values[i + 1], self.values[i + 2])
            }
        };
        if self.per_vertex {
            let base = prim as usize * 3;
            let b0 = 1.0 - b1 - b2;
            get(base) * b0 + get(base + 1) * b1 + get(base + 2) * b2
        } else {
            get(prim as usize)
        }
    }
}

/// Mitsuba's `mesh_attribute` texture (`name`, `scale`).
#[derive(Debug)]
pub struct MeshAttribute {
    /// The attribute read, with its prefix (`vertex_color`, `face_<name>`).
    pub name: String,
    /// Factor applied to every value.
    pub scale: f32,
    /// Per scene shape id; `None` for shapes that never use this texture.
    tables: OnceLock<Vec<Option<AttributeTable>>>,
}

impl MeshAttribute {
    /// The texture before its tables are installed ([`MeshAttribute::set_tables`]).
    pub fn new(name: String, scale: f32) -> MeshAttribute {
        MeshAttribute { name, scale, tables: OnceLock::new() }
    }

    /// Installs the per-shape tables (once, when the scene is built).
    pub fn set_tables(&self, tables: Vec<Option<AttributeTable>>) {
        // A second call would be a builder bug; keep the first.
        let _ = self.tables.set(tables);
    }

    #[inline]
    fn table(&self, shape: u32) -> Option<&AttributeTable> {
        self.tables.get()?.get(shape as usize)?.as_ref()
    }

    /// Mitsuba's `eval`: the interpolated attribute times `scale`; black
    /// where the shape has no table (the builder rejects such scenes).
    #[inline]
    pub fn eval(&self, si: &SurfaceInteraction) -> Spectrum {
        match self.table(si.shape) {
            Some(t) => t.eval(si.prim, si.bary.x, si.bary.y) * self.scale,
            None => Spectrum::ZERO,
        }
    }

    /// Mitsuba's `eval_1` (one-component attributes only; the builder
    /// checks this).
    #[inline]
    pub fn eval_1(&self, si: &SurfaceInteraction) -> f32 {
        self.eval(si).x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_attributes_interpolate_and_face_attributes_are_constant() {
        let indices = [[0, 1, 2], [2, 1, 3]];
        let colors = MeshAttributeData {
            name: "vertex_color".into(),
            per_vertex: true,
            dim: 3,
            data: vec![1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.],
        };
        let t = AttributeTable::new(&colors, &indices);
        assert_eq!(t.eval(0, 0.0, 0.0), Spectrum::new(1., 0., 0.));
        assert_eq!(t.eval(1, 0.0, 1.0), Spectrum::ONE);
        let m = t.eval(1, 0.25, 0.5);
        assert!((m - Spectrum::new(0.5, 0.75, 0.75)).abs().max_element() < 1e-6, "{m}");
        let face = MeshAttributeData { name: "face_id".into(), per_vertex: false, dim: 1, data: vec![3., 7.] };
        let t = AttributeTable::new(&face, &indices);
        assert_eq!(t.eval(1, 0.3, 0.3), Spectrum::splat(7.0));
        assert_eq!(t.eval(0, 0.9, 0.0), Spectrum::splat(3.0));
    }
}
