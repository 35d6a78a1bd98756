//! Indexed triangle meshes, stored as a struct of arrays.

use glam::{Mat4, Vec2, Vec3};

/// A triangle mesh as loaded from a file or generated from a shape.
///
/// `normals` and `uvs` are either empty or hold one entry per position.
/// Loaders produce object-space meshes; the scene builder calls
/// [`TriangleMesh::transform`] to bake `to_world` in.
#[derive(Debug, Clone, Default)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Applies `world_from_object` to positions and its inverse transpose to normals.
    pub fn transform(&mut self, world_from_object: &Mat4) {
        let normal_m = world_from_object.inverse().transpose();
        for p in &mut self.positions {
            *p = world_from_object.transform_point3(*p);
        }
        for n in &mut self.normals {
            *n = normal_m.transform_vector3(*n).normalize_or_zero();
        }
    }

    /// Reverses the orientation: swaps the winding and negates shading normals.
    pub fn flip(&mut self) {
        for t in &mut self.indices {
            t.swap(1, 2);
        }
        for n in &mut self.normals {
            *n = -*n;
        }
    }

    /// Checks that every index is in range and that attribute arrays match.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.positions.len();
        if !self.normals.is_empty() && self.normals.len() != n {
            return Err(format!("{} normals for {} vertices", self.normals.len(), n));
        }
        if !self.uvs.is_empty() && self.uvs.len() != n {
            return Err(format!("{} texture coordinates for {} vertices", self.uvs.len(), n));
        }
        for (i, t) in self.indices.iter().enumerate() {
            if t.iter().any(|&v| v as usize >= n) {
                return Err(format!("face {i} refers to a vertex past the {n} vertices"));
            }
        }
        if self.positions.iter().any(|p| !p.is_finite()) {
            return Err("a vertex position is not finite".into());
        }
        Ok(())
    }
}
