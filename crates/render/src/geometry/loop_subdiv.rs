//! Loop subdivision of a triangle mesh (Loop 1987), as pbrt-v4's
//! `loopsubdiv` shape refines it: `levels` rounds of 1-to-4 splits with
//! Loop's even (one-ring, weight β(n) = 3/16 for valence 3, else 3/(8n))
//! and odd (3/8, 3/8, 1/8, 1/8) rules, crease rules on boundaries (1/8 and
//! 1/2), then every vertex moved to its limit position (weight
//! 1/(n + 3/(8β)) for interior vertices, 1/5 on boundaries) with the limit
//! surface's normal from its two tangents (pbrt-v3 §3.8 / pbrt-v4's
//! `LoopSubdivide`).
//!
//! Orientation, as in pbrt-v4: the one-ring runs clockwise as seen from
//! the side where the triangles run counter-clockwise, so the normals
//! point to the side from which the triangles appear clockwise (inwards
//! for a closed mesh wound counter-clockwise seen from outside). pbrt-v4
//! then turns each hit's geometric normal to agree with these normals.
//!
//! The mesh must be an orientable manifold (each edge shared by at most
//! two faces, fans around vertices consistently oriented); anything else is
//! an error naming the edge or vertex, never an endless walk.

use glam::Vec3;
use std::collections::HashMap;

const NONE: u32 = u32::MAX;

#[inline]
fn next(i: usize) -> usize {
    (i + 1) % 3
}

#[inline]
fn prev(i: usize) -> usize {
    (i + 2) % 3
}

#[derive(Debug, Clone, Copy)]
struct Vert {
    p: Vec3,
    start_face: u32,
    child: u32,
    regular: bool,
    boundary: bool,
}

#[derive(Debug, Clone, Copy)]
struct Face {
    v: [u32; 3],
    /// The neighbour across edge (v[i], v[next(i)]), or NONE.
    f: [u32; 3],
}

struct Mesh {
    verts: Vec<Vert>,
    faces: Vec<Face>,
}

impl Mesh {
    fn vnum(&self, f: u32, v: u32) -> usize {
        let face = &self.faces[f as usize];
        (0..3).find(|&i| face.v[i] == v).expect("vertex of its face")
    }
    fn next_face(&self, f: u32, v: u32) -> u32 {
        self.faces[f as usize].f[self.vnum(f, v)]
    }
    fn prev_face(&self, f: u32, v: u32) -> u32 {
        self.faces[f as usize].f[prev(self.vnum(f, v))]
    }
    fn next_vert(&self, f: u32, v: u32) -> u32 {
        self.faces[f as usize].v[next(self.vnum(f, v))]
    }
    fn prev_vert(&self, f: u32, v: u32) -> u32 {
        self.faces[f as usize].v[prev(self.vnum(f, v))]
    }
    fn other_vert(&self, f: u32, v0: u32, v1: u32) -> u32 {
        let face = &self.faces[f as usize];
        *face.v.iter().find(|&&v| v != v0 && v != v1).expect("a triangle has a third vertex")
    }

    /// Faces around `v`, counted as pbrt-v4's `SDVertex::valence` (for a
    /// boundary vertex, one more than the faces: its ring has n + 1 vertices).
    fn valence(&self, v: u32) -> usize {
        let vert = &self.verts[v as usize];
        let start = vert.start_face;
        let mut nf = 1;
        let mut f = self.next_face(start, v);
        if !vert.boundary {
            while f != start {
                nf += 1;
                f = self.next_face(f, v);
            }
            nf
        } else {
            while f != NONE {
                nf += 1;
                f = self.next_face(f, v);
            }
            f = self.prev_face(start, v);
            while f != NONE {
                nf += 1;
                f = self.prev_face(f, v);
            }
            nf + 1
        }
    }

    /// The one-ring's positions, in order around `v`.
    fn one_ring(&self, v: u32) -> Vec<Vec3> {
        let vert = &self.verts[v as usize];
        let mut ring = Vec::new();
        if !vert.boundary {
            let mut f = vert.start_face;
            loop {
                ring.push(self.verts[self.next_vert(f, v) as usize].p);
                f = self.next_face(f, v);
                if f == vert.start_face {
                    break;
                }
            }
        } else {
            let mut f = vert.start_face;
            loop {
                let f2 = self.next_face(f, v);
                if f2 == NONE {
                    break;
                }
                f = f2;
            }
            ring.push(self.verts[self.next_vert(f, v) as usize].p);
            while f != NONE {
                ring.push(self.verts[self.prev_vert(f, v) as usize].p);
                f = self.prev_face(f, v);
            }
        }
        ring
    }

    fn weight_one_ring(&self, v: u32, beta: f32) -> Vec3 {
        let ring = self.one_ring(v);
        let mut p = (1.0 - ring.len() as f32 * beta) * self.verts[v as usize].p;
        for q in ring {
            p += beta * q;
        }
        p
    }

    fn weight_boundary(&self, v: u32, beta: f32) -> Vec3 {
        let ring = self.one_ring(v);
        let mut p = (1.0 - 2.0 * beta) * self.verts[v as usize].p;
        p += beta * ring[0];
        p += beta * ring[ring.len() - 1];
        p
    }
}

fn beta(valence: usize) -> f32 {
    if valence == 3 {
        3.0 / 16.0
    } else {
        3.0 / (8.0 * valence as f32)
    }
}

fn loop_gamma(valence: usize) -> f32 {
    1.0 / (valence as f32 + 3.0 / (8.0 * beta(valence)))
}

/// The edge key: its two vertices, smaller first.
fn edge(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// The refined mesh: positions, normals (of the limit surface, not
/// normalised: pbrt-v4 stores them so) and triangles.
pub type Refined = (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>);

/// Subdivides `levels` times and moves the vertices to the limit surface.
/// Vertices used by no triangle are dropped.
pub fn loop_subdivide(levels: u32, positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<Refined, String> {
    if levels > 10 {
        return Err(format!("{levels} levels of subdivision: at most 10 (each level quadruples the triangles)"));
    }
    if triangles.is_empty() {
        return Err("no triangles to subdivide".into());
    }
    let mut verts: Vec<Vert> =
        positions.iter().map(|&p| Vert { p, start_face: NONE, child: NONE, regular: false, boundary: false }).collect();
    let mut faces = Vec::with_capacity(triangles.len());
    for (i, t) in triangles.iter().enumerate() {
        for &v in t {
            if v as usize >= verts.len() {
                return Err(format!("triangle {i} uses vertex {v}, but there are {} vertices", verts.len()));
            }
        }
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return Err(format!("triangle {i} repeats a vertex ({} {} {})", t[0], t[1], t[2]));
        }
        for &v in t {
            verts[v as usize].start_face = i as u32;
        }
        faces.push(Face { v: *t, f: [NONE; 3] });
    }
    // Neighbours across edges; a third face on an edge is not a manifold.
    let mut open: HashMap<(u32, u32), (u32, usize)> = HashMap::new();
    let mut closed: HashMap<(u32, u32), ()> = HashMap::new();
    for fi in 0..faces.len() {
        for e in 0..3 {
            let (a, b) = (faces[fi].v[e], faces[fi].v[next(e)]);
            let key = edge(a, b);
            if closed.contains_key(&key) {
                return Err(format!(
                    "edge ({}, {}) is shared by more than two triangles (triangle {fi} is the third): \
                     Loop subdivision needs a manifold mesh",
                    key.0, key.1
                ));
            }
            match open.remove(&key) {
                None => {
                    open.insert(key, (fi as u32, e));
                }
                Some((f0, e0)) => {
                    // Consistent orientation: the neighbour runs the edge the other way.
                    if faces[f0 as usize].v[e0] != b {
                        return Err(format!(
                            "triangles {f0} and {fi} run their shared edge ({a}, {b}) the same way: \
                             orient all triangles consistently"
                        ));
                    }
                    faces[f0 as usize].f[e0] = fi as u32;
                    faces[fi].f[e] = f0;
                    closed.insert(key, ());
                }
            }
        }
    }
    let mut faces_at = vec![0usize; verts.len()];
    for t in triangles {
        for &v in t {
            faces_at[v as usize] += 1;
        }
    }
    let mut m = Mesh { verts, faces };
    // Boundary and regularity, walking each fan with a bound on its length.
    let n_faces = m.faces.len();
    for v in 0..m.verts.len() as u32 {
        let start = m.verts[v as usize].start_face;
        if start == NONE {
            continue;
        }
        let mut f = start;
        let mut steps = 0;
        loop {
            f = m.next_face(f, v);
            steps += 1;
            if f == NONE || f == start {
                break;
            }
            if steps > n_faces {
                return Err(format!(
                    "the triangles around vertex {v} do not form one fan (a non-manifold vertex): \
                     Loop subdivision needs a manifold mesh"
                ));
            }
        }
        m.verts[v as usize].boundary = f == NONE;
        let valence = m.valence(v);
        // Every face at the vertex must be on its one fan.
        let used = faces_at[v as usize];
        let fan = if f == NONE { valence - 1 } else { valence };
        if fan != used {
            return Err(format!(
                "vertex {v} joins {used} triangles in more than one fan (a non-manifold vertex): \
                 Loop subdivision needs a manifold mesh"
            ));
        }
        let b = m.verts[v as usize].boundary;
        m.verts[v as usize].regular = (!b && valence == 6) || (b && valence == 4);
    }

    for _ in 0..levels {
        m = refine(&m);
    }

    // Limit positions, then normals from the limit tangents.
    let live: Vec<u32> = (0..m.verts.len() as u32).filter(|&v| m.verts[v as usize].start_face != NONE).collect();
    let limit: Vec<Vec3> = live
        .iter()
        .map(|&v| {
            if m.verts[v as usize].boundary {
                m.weight_boundary(v, 1.0 / 5.0)
            } else {
                m.weight_one_ring(v, loop_gamma(m.valence(v)))
            }
        })
        .collect();
    for (&v, &p) in live.iter().zip(&limit) {
        m.verts[v as usize].p = p;
    }
    let mut normals = Vec::with_capacity(live.len());
    for &v in &live {
        let ring = m.one_ring(v);
        let valence = m.valence(v);
        let p = m.verts[v as usize].p;
        let (mut s, mut t) = (Vec3::ZERO, Vec3::ZERO);
        if !m.verts[v as usize].boundary {
            for (j, q) in ring.iter().enumerate() {
                let a = 2.0 * std::f32::consts::PI * j as f32 / valence as f32;
                s += a.cos() * *q;
                t += a.sin() * *q;
            }
        } else {
            s = ring[valence - 1] - ring[0];
            t = match valence {
                2 => ring[0] + ring[1] - 2.0 * p,
                3 => ring[1] - p,
                4 => -ring[0] + 2.0 * ring[1] + 2.0 * ring[2] - ring[3] - 2.0 * p,
                _ => {
                    let theta = std::f32::consts::PI / (valence - 1) as f32;
                    let mut t = theta.sin() * (ring[0] + ring[valence - 1]);
                    for (k, q) in ring.iter().enumerate().take(valence - 1).skip(1) {
                        t += (2.0 * theta.cos() - 2.0) * (k as f32 * theta).sin() * *q;
                    }
                    -t
                }
            };
        }
        normals.push(s.cross(t));
    }
    let mut index = vec![NONE; m.verts.len()];
    for (i, &v) in live.iter().enumerate() {
        index[v as usize] = i as u32;
    }
    let tris = m.faces.iter().map(|f| f.v.map(|v| index[v as usize])).collect();
    Ok((limit, normals, tris))
}

/// One round: every face split into four (three at the corners, child 3 in the middle).
fn refine(m: &Mesh) -> Mesh {
    let mut verts: Vec<Vert> = Vec::with_capacity(m.verts.len() * 4);
    let mut parent = m.verts.clone();
    // Even vertices: the old ones, moved.
    for (v, pv) in parent.iter_mut().enumerate() {
        if pv.start_face == NONE {
            continue;
        }
        let v = v as u32;
        let p = if !pv.boundary {
            let beta = if pv.regular { 1.0 / 16.0 } else { beta(m.valence(v)) };
            m.weight_one_ring(v, beta)
        } else {
            m.weight_boundary(v, 1.0 / 8.0)
        };
        pv.child = verts.len() as u32;
        verts.push(Vert { p, start_face: NONE, child: NONE, regular: pv.regular, boundary: pv.boundary });
    }
    let mut faces: Vec<Face> = Vec::with_capacity(m.faces.len() * 4);
    let mut children = Vec::with_capacity(m.faces.len());
    for _ in &m.faces {
        let c = faces.len() as u32;
        children.push([c, c + 1, c + 2, c + 3]);
        for _ in 0..4 {
            faces.push(Face { v: [NONE; 3], f: [NONE; 3] });
        }
    }
    // Odd vertices, one per edge.
    let mut edge_verts: HashMap<(u32, u32), u32> = HashMap::new();
    for (fi, f) in m.faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f.v[k], f.v[next(k)]);
            let key = edge(a, b);
            if edge_verts.contains_key(&key) {
                continue;
            }
            let boundary = f.f[k] == NONE;
            let (pa, pb) = (m.verts[key.0 as usize].p, m.verts[key.1 as usize].p);
            let p = if boundary {
                0.5 * pa + 0.5 * pb
            } else {
                let c = m.verts[m.other_vert(fi as u32, key.0, key.1) as usize].p;
                let d = m.verts[m.other_vert(f.f[k], key.0, key.1) as usize].p;
                (3.0 / 8.0) * pa + (3.0 / 8.0) * pb + (1.0 / 8.0) * c + (1.0 / 8.0) * d
            };
            edge_verts.insert(key, verts.len() as u32);
            verts.push(Vert { p, start_face: children[fi][3], child: NONE, regular: true, boundary });
        }
    }
    // Even vertices' faces: the corner child at their place.
    for (v, pv) in parent.iter().enumerate() {
        if pv.start_face == NONE {
            continue;
        }
        let vn = m.vnum(pv.start_face, v as u32);
        verts[pv.child as usize].start_face = children[pv.start_face as usize][vn];
    }
    // Neighbours and vertices of the children.
    for (fi, f) in m.faces.iter().enumerate() {
        let ch = children[fi];
        for j in 0..3 {
            faces[ch[3] as usize].f[j] = ch[next(j)];
            faces[ch[j] as usize].f[next(j)] = ch[3];
            let f2 = f.f[j];
            faces[ch[j] as usize].f[j] = if f2 == NONE { NONE } else { children[f2 as usize][m.vnum(f2, f.v[j])] };
            let f2 = f.f[prev(j)];
            faces[ch[j] as usize].f[prev(j)] =
                if f2 == NONE { NONE } else { children[f2 as usize][m.vnum(f2, f.v[j])] };
        }
        for j in 0..3 {
            faces[ch[j] as usize].v[j] = parent[f.v[j] as usize].child;
            let ev = edge_verts[&edge(f.v[j], f.v[next(j)])];
            faces[ch[j] as usize].v[next(j)] = ev;
            faces[ch[next(j)] as usize].v[j] = ev;
            faces[ch[3] as usize].v[j] = ev;
        }
    }
    Mesh { verts, faces }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn octahedron() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        // Counter-clockwise seen from outside.
        let t = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        (p, t)
    }

    #[test]
    fn counts_follow_the_one_to_four_split() {
        let (p, t) = octahedron();
        for levels in 0..4 {
            let (v, n, f) = loop_subdivide(levels, &p, &t).unwrap();
            assert_eq!(f.len(), 8 * 4usize.pow(levels));
            // Euler: V - E + F = 2 on a sphere, with E = 3F/2.
            assert_eq!(v.len() as i64 - 3 * f.len() as i64 / 2 + f.len() as i64, 2);
            assert_eq!(n.len(), v.len());
        }
    }

    #[test]
    fn closed_convex_mesh_gives_a_symmetric_surface_with_its_limit_points() {
        let (p, t) = octahedron();
        let (v, n, f) = loop_subdivide(3, &p, &t).unwrap();
        // Every triangle keeps its counter-clockwise winding seen from outside,
        // and the normals point inwards (pbrt-v4's orientation, see the module docs).
        for tri in &f {
            let [a, b, c] = tri.map(|i| v[i as usize]);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
        for (q, m) in v.iter().zip(&n) {
            assert!(m.normalize().dot(q.normalize()) < -0.9, "{q} {m}");
        }
        // The octahedron's symmetry survives: every mirrored vertex is a vertex.
        for q in &v {
            let m = Vec3::new(-q.x, q.y, q.z);
            assert!(v.iter().any(|r| (*r - m).length() < 1e-5), "{q}");
        }
        // Limit positions do not change with further subdivision: the six
        // original vertices (valence 4, gamma = 1/8) sit at (1 - 4/8) p + (1/8) x
        // (their ring, which sums to 0) = p/2, whatever the level.
        for (q, p0) in v[..6].iter().zip(&p) {
            assert!((*q - 0.5 * *p0).length() < 1e-6, "{q} vs {p0}");
        }
        // The first level's vertex on edge XY: odd rule (3/8, 3/8, 0); its ring
        // X' = 5X/8, Y' = 5Y/8 (even rule, beta = 3/32) and four odd vertices
        // summing to (3/4, 3/4, 0); regular, so gamma = 1/12: the limit is
        // (3/8, 3/8, 0)/2 + (11/8, 11/8, 0)/12 = (29/96, 29/96, 0).
        let want = Vec3::new(29.0 / 96.0, 29.0 / 96.0, 0.0);
        assert!(v.iter().any(|q| (*q - want).length() < 1e-6), "no vertex at {want}");
        for q in &v {
            assert!(q.x.abs() + q.y.abs() + q.z.abs() <= 1.0 + 1e-5);
        }
    }

    #[test]
    fn a_flat_patch_stays_flat_with_its_boundary() {
        // A 4 x 4 grid of quads in z = 0.
        let n = 5;
        let p: Vec<Vec3> = (0..n * n).map(|i| Vec3::new((i % n) as f32, (i / n) as f32, 0.0)).collect();
        let mut t = Vec::new();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let i = (y * n + x) as u32;
                t.push([i, i + 1, i + n as u32 + 1]);
                t.push([i, i + n as u32 + 1, i + n as u32]);
            }
        }
        let (v, nrm, _) = loop_subdivide(2, &p, &t).unwrap();
        for (q, m) in v.iter().zip(&nrm) {
            assert!(q.z.abs() < 1e-6, "{q}");
            // Wound counter-clockwise seen from +z: normals along -z (module docs).
            assert!(m.x.abs() < 1e-4 * m.length() && m.y.abs() < 1e-4 * m.length() && m.z < 0.0, "{q}: {m}");
            // Boundary vertices stay on the square's boundary (the crease rules).
            assert!(q.x >= -1e-6 && q.x <= 4.0 + 1e-6 && q.y >= -1e-6 && q.y <= 4.0 + 1e-6);
        }
        // The bottom edge's vertices stay on it (its crease rule uses only its own vertices).
        assert!(v.iter().filter(|q| q.y.abs() < 1e-6).count() > 8);
    }

    #[test]
    fn bad_meshes_are_refused_with_the_reason() {
        let (p, mut t) = octahedron();
        t.push([0, 2, 1]);
        let e = loop_subdivide(1, &p, &t).unwrap_err();
        assert!(e.contains("more than two triangles") || e.contains("same way"), "{e}");
        let (p, mut t) = octahedron();
        t[0] = [0, 4, 2];
        assert!(loop_subdivide(1, &p, &t).unwrap_err().contains("same way"));
        assert!(loop_subdivide(1, &p, &[[0, 1, 9]]).unwrap_err().contains("vertex 9"));
        assert!(loop_subdivide(1, &p, &[[0, 0, 1]]).unwrap_err().contains("repeats"));
        assert!(loop_subdivide(11, &p, &[[0, 1, 2]]).unwrap_err().contains("at most 10"));
        // Two fans touching at one vertex (a bow tie).
        let q = vec![Vec3::ZERO, Vec3::X, Vec3::Y, -Vec3::X, -Vec3::Y];
        let e = loop_subdivide(1, &q, &[[0, 1, 2], [0, 3, 4]]).unwrap_err();
        assert!(e.contains("vertex 0") && e.contains("non-manifold"), "{e}");
    }
}
