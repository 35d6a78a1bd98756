//! Indexed triangle meshes, stored as a struct of arrays.

use glam::{Mat4, Vec2, Vec3};

/// A triangle mesh as loaded from a file or generated from a shape.
///
/// `normals` and `uvs` are either empty or hold one entry per position.
/// Loaders produce object-space meshes; the scene builder calls
/// [`TriangleMesh::transform`] to bake `to_world` in.
#[derive(Debug, Clone, Default)]
pub struct TriangleMesh {
    /// Vertex positions (object space as loaded, world space once transformed).
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, or empty (then shading uses the face normal).
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, or empty.
    pub uvs: Vec<Vec2>,
    /// Vertex indices of each triangle; the winding (v0, v1, v2) makes the
    /// geometric normal (v1 − v0) × (v2 − v0).
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

    /// Replaces the vertex normals by Mitsuba's: each face's normal weighted
    /// by its angle at the vertex (Thürmer and Wüthrich 1998), as
    /// `Mesh::recompute_vertex_normals` in Mitsuba 3.9.1. Vertices that no
    /// valid face touches get (1, 0, 0), as there.
    pub fn recompute_vertex_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.indices {
            let v = t.map(|i| self.positions[i as usize]);
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            if n.length_squared() > 0.0 {
                let n = n.normalize();
                for j in 0..3 {
                    let a = (v[(j + 1) % 3] - v[j]).normalize();
                    let b = (v[(j + 2) % 3] - v[j]).normalize();
                    acc[t[j] as usize] += n * unit_angle(a, b);
                }
            }
        }
        self.normals = acc.into_iter().map(|n| if n.length() != 0.0 { n.normalize() } else { Vec3::X }).collect();
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

/// The angle between unit vectors, accurate for small and large angles.
fn unit_angle(a: Vec3, b: Vec3) -> f32 {
    if a.dot(b) < 0.0 {
        std::f32::consts::PI - 2.0 * ((a + b).length() / 2.0).min(1.0).asin()
    } else {
        2.0 * ((a - b).length() / 2.0).min(1.0).asin()
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
    fn recomputed_normals_weight_faces_by_angle() {
        // A vertex shared by a face in z = 0 (angle 90°) and one in x = 0 (angle 45°).
        let mut m = TriangleMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.0, 1.0, 1.0), Vec3::splat(5.0)],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        };
        m.recompute_vertex_normals();
        let w = (Vec3::Z * 0.5 + Vec3::X * 0.25).normalize();
        assert!((m.normals[0] - w).length() < 1e-6, "{}", m.normals[0]);
        assert_eq!(m.normals[1], Vec3::Z);
        assert_eq!(m.normals[4], Vec3::X, "unreferenced vertex");
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
