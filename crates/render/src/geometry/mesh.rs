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

impl TriangleMesh {
    /// Mitsuba's `rectangle`: [-1, 1]² in the z = 0 plane, normal +z.
    pub fn rectangle() -> TriangleMesh {
        TriangleMesh {
            positions: vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
            indices: vec![[0, 1, 2], [2, 3, 0]],
        }
    }

    /// Mitsuba's `cube`: [-1, 1]³ with outward-facing flat faces, with
    /// Mitsuba 3.9.1's vertices, texture coordinates and triangles (each
    /// face maps onto [0, 1]² in uv).
    pub fn cube() -> TriangleMesh {
        const P: [[f32; 3]; 24] = [
            [1., -1., -1.],
            [1., -1., 1.],
            [-1., -1., 1.],
            [-1., -1., -1.],
            [1., 1., -1.],
            [-1., 1., -1.],
            [-1., 1., 1.],
            [1., 1., 1.],
            [1., -1., -1.],
            [1., 1., -1.],
            [1., 1., 1.],
            [1., -1., 1.],
            [1., -1., 1.],
            [1., 1., 1.],
            [-1., 1., 1.],
            [-1., -1., 1.],
            [-1., -1., 1.],
            [-1., 1., 1.],
            [-1., 1., -1.],
            [-1., -1., -1.],
            [1., 1., -1.],
            [1., -1., -1.],
            [-1., -1., -1.],
            [-1., 1., -1.],
        ];
        const N: [[f32; 3]; 6] =
            [[0., -1., 0.], [0., 1., 0.], [1., 0., 0.], [0., 0., 1.], [-1., 0., 0.], [0., 0., -1.]];
        const UV: [[f32; 2]; 4] = [[0., 1.], [1., 1.], [1., 0.], [0., 0.]];
        TriangleMesh {
            positions: P.iter().map(|&p| Vec3::from_array(p)).collect(),
            normals: (0..24).map(|i| Vec3::from_array(N[i / 4])).collect(),
            uvs: (0..24).map(|i| Vec2::from_array(UV[i % 4])).collect(),
            indices: (0..6u32).flat_map(|f| [[4 * f, 4 * f + 1, 4 * f + 2], [4 * f + 3, 4 * f, 4 * f + 2]]).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_faces_point_outwards() {
        let m = TriangleMesh::cube();
        assert_eq!(m.indices.len(), 12);
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a);
            let centre = (a + b + c) / 3.0;
            assert!(n.dot(centre) > 0.0, "face normal must point away from the centre");
        }
    }

    #[test]
    fn rectangle_faces_plus_z() {
        let m = TriangleMesh::rectangle();
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            assert!((b - a).cross(c - a).z > 0.0);
        }
    }
}
