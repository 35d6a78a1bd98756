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

    /// Mitsuba's `cube`: [-1, 1]³ with outward-facing flat faces.
    pub fn cube() -> TriangleMesh {
        let mut m = TriangleMesh::default();
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut n = Vec3::ZERO;
                n[axis] = sign;
                // Two tangents spanning the face, ordered so that (u × v) = n.
                let mut u = Vec3::ZERO;
                u[(axis + 1) % 3] = 1.0;
                let mut v = Vec3::ZERO;
                v[(axis + 2) % 3] = sign;
                let base = m.positions.len() as u32;
                for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    m.positions.push(n + u * a + v * b);
                    m.normals.push(n);
                    m.uvs.push(Vec2::new((a + 1.0) / 2.0, (b + 1.0) / 2.0));
                }
                m.indices.push([base, base + 1, base + 2]);
                m.indices.push([base + 2, base + 3, base]);
            }
        }
        m
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
