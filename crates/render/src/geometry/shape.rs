//! Shapes: triangle meshes, the analytic sphere, disk and cylinder, and the
//! multi-part shapes (ellipsoid clouds, culled shell meshes) whose parts the
//! BVH bounds one by one (each in its own module). A shape answers the
//! geometric questions (bounds of its primitives, the interaction at a hit,
//! area and direction sampling); the BVH intersects its primitives.

use super::{Aabb, Curves, Cylinder, Disk, Ellipsoids, Ray, SdfGrid, Sphere, SurfaceInteraction, TriangleMesh};
use crate::math::{Frame, Mat3, Mat4};
use crate::sampling::{warp, Distribution1D};
use glam::{Vec2, Vec3};

/// A point sampled on a shape, as seen from a reference point.
#[derive(Debug, Clone, Copy)]
pub struct ShapeSample {
    /// Position of the sampled point.
    pub p: Vec3,
    /// Front-side geometric normal at `p`.
    pub n: Vec3,
    /// Density per unit solid angle at the reference point.
    pub pdf: f32,
    /// The primitive holding `p` and its parameter, as
    /// [`Shape::interaction`] takes them (see [`AreaSample`]).
    pub prim: u32,
    /// See [`AreaSample::param`].
    pub param: Vec2,
}

/// A point sampled uniformly by area, with what [`Shape::interaction`]
/// needs to complete it (for emitters whose radiance is a texture, and
/// sensors that sample shapes).
#[derive(Debug, Clone, Copy)]
pub struct AreaSample {
    /// Position of the sampled point.
    pub p: Vec3,
    /// Front-side geometric normal at `p`.
    pub n: Vec3,
    /// Density per unit area.
    pub pdf: f32,
    /// The triangle of a mesh (0 for analytic shapes).
    pub prim: u32,
    /// The triangle's barycentrics (b1, b2), the disk's local (x, y); unused
    /// by spheres and cylinders, whose interaction follows from the point.
    pub param: Vec2,
}

/// A triangle mesh shape with its area distribution for sampling.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// The triangles: positions, optional normals and UVs, indices.
    pub mesh: TriangleMesh,
    /// Ignore vertex normals and shade with the flat face normal (also set
    /// when the vertex normals are the face normals, e.g. `rectangle` and
    /// `cube`: the same shading without interpolating them per hit).
    pub face_normals: bool,
    /// Mitsuba's `rectangle` (two triangles there too, split along the
    /// other diagonal): hits report Mitsuba's primitive index, 0 where
    /// u + v ≤ 1, else 1 (the aov integrator's `prim_index`).
    pub rectangle: bool,
    area_distrib: Option<Distribution1D>,
}

impl Mesh {
    /// The mesh shape, with its per-triangle area distribution.
    pub fn new(mesh: TriangleMesh, face_normals: bool) -> Mesh {
        let areas: Vec<f32> = (0..mesh.indices.len()).map(|i| tri_area(&mesh, i)).collect();
        let face_normals = face_normals || normals_are_flat(&mesh);
        Mesh { area_distrib: Distribution1D::new(&areas), mesh, face_normals, rectangle: false }
    }
    /// A triangle chosen with probability proportional to its area with
    /// `u`, and `u` rescaled for reuse, as [`Shape::sample_point`] picks it;
    /// `None` for a mesh without area.
    #[inline(always)]
    pub fn pick_triangle(&self, u: f32) -> Option<(usize, f32)> {
        let (i, _, ux) = self.area_distrib.as_ref()?.sample_discrete(u);
        Some((i, ux))
    }

    /// The alias table behind [`Self::pick_triangle`] (a bucket per
    /// triangle), for tables that copy it; `None` for a mesh without area.
    pub(crate) fn area_alias(&self) -> Option<&[(f32, u32)]> {
        self.area_distrib.as_ref().map(|d| d.alias())
    }

    /// The density per unit area of [`Shape::sample_point`] on this mesh.
    #[inline]
    pub fn area_pdf(&self) -> f32 {
        self.area_distrib.as_ref().map_or(0.0, |d| 1.0 / d.total as f32)
    }

    /// Corner positions of triangle `i`.
    #[inline(always)]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        let t = self.mesh.indices[i];
        [self.mesh.positions[t[0] as usize], self.mesh.positions[t[1] as usize], self.mesh.positions[t[2] as usize]]
    }
}

/// Whether every triangle's vertex normals equal its face normal (to well
/// below a shading difference: 1e-5 rad); false without normals.
fn normals_are_flat(m: &TriangleMesh) -> bool {
    !m.normals.is_empty()
        && m.indices.iter().all(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            t.iter().all(|&i| (m.normals[i as usize] - n).length_squared() < 1e-10)
        })
}

fn tri_area(m: &TriangleMesh, i: usize) -> f32 {
    let t = m.indices[i];
    let (a, b, c) = (m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// A geometric shape: a mesh or an analytic primitive.
#[derive(Debug, Clone)]
pub enum Shape {
    /// A triangle mesh (Mitsuba `obj`, `ply`, `serialized`, `rectangle`, `cube`).
    Mesh(Mesh),
    /// Mitsuba `sphere` (see [`Sphere`]).
    Sphere(Sphere),
    /// Mitsuba `disk` (see [`Disk`]).
    Disk(Disk),
    /// Mitsuba `cylinder`: an open tube (see [`Cylinder`]).
    Cylinder(Cylinder),
    /// Mitsuba `ellipsoids`: analytic ellipsoids, back faces culled (see [`Ellipsoids`]).
    Ellipsoids(Ellipsoids),
    /// A triangle mesh whose back faces are culled (d · N_g > 0 never hits),
    /// intersected triangle by triangle: Mitsuba `ellipsoidsmesh` (see
    /// [`super::ellipsoids`]). Hits are completed as a [`Shape::Mesh`]'s.
    CulledMesh(Mesh),
    /// Mitsuba `sdfgrid`: a signed distance grid, one part per voxel the
    /// surface crosses (see [`SdfGrid`]).
    SdfGrid(SdfGrid),
    /// Mitsuba `linearcurve` and `bsplinecurve`: round tubes through
    /// control points, one part per segment, back faces culled (see [`Curves`]).
    Curves(Curves),
}

impl Shape {
    /// A sphere; `flip` flips the normals (Mitsuba `flip_normals`).
    pub fn sphere(center: Vec3, radius: f32, flip: bool) -> Shape {
        Shape::Sphere(Sphere::new(center, radius, Mat3::IDENTITY, flip))
    }

    /// A sphere whose local frame is rotated by `rot` (see [`Sphere::new`]).
    pub fn sphere_rotated(center: Vec3, radius: f32, rot: Mat3, flip: bool) -> Shape {
        Shape::Sphere(Sphere::new(center, radius, rot, flip))
    }

    /// A disk placed by `world_from_object`; `flip` flips the normals.
    pub fn disk(world_from_object: Mat4, flip: bool) -> Shape {
        Shape::Disk(Disk::new(world_from_object, flip))
    }

    /// Number of primitives the BVH sees.
    pub fn prim_count(&self) -> usize {
        match self {
            Shape::Mesh(m) | Shape::CulledMesh(m) => m.mesh.indices.len(),
            Shape::Ellipsoids(e) => e.items.len(),
            Shape::SdfGrid(g) => g.voxel_count(),
            Shape::Curves(c) => c.segment_count(),
            Shape::Sphere(_) | Shape::Disk(_) | Shape::Cylinder(_) => 1,
        }
    }

    /// Whether the BVH bounds and intersects this shape part by part
    /// ([`Shape::intersect_prim`]), rather than as one analytic primitive
    /// or as triangles of the shared 4-wide blocks.
    pub fn is_multi_part(&self) -> bool {
        matches!(self, Shape::Ellipsoids(_) | Shape::CulledMesh(_) | Shape::SdfGrid(_) | Shape::Curves(_))
    }

    /// Whether Mitsuba 3.9.1 can sample points on this shape, which an
    /// `area` emitter needs (it cannot on analytic ellipsoids, SDF grids and
    /// curves; it can on `ellipsoidsmesh`, a mesh).
    pub fn can_emit(&self) -> bool {
        matches!(self, Shape::Mesh(_) | Shape::CulledMesh(_) | Shape::Sphere(_) | Shape::Disk(_) | Shape::Cylinder(_))
    }

    /// Bounds of primitive `i` in the shape's space.
    pub fn prim_bounds(&self, i: usize) -> Aabb {
        match self {
            Shape::Mesh(m) | Shape::CulledMesh(m) => Aabb::from_points(&m.vertices(i)),
            Shape::Sphere(s) => s.bounds(),
            Shape::Disk(d) => d.bounds(),
            Shape::Cylinder(c) => c.bounds(),
            Shape::Ellipsoids(e) => e.items[i].bounds(),
            Shape::SdfGrid(g) => g.bounds(i),
            Shape::Curves(c) => c.bounds(i),
        }
    }

    /// Total surface area (0 for the shapes that cannot emit, see [`Shape::can_emit`]).
    pub fn area(&self) -> f32 {
        match self {
            Shape::Mesh(m) | Shape::CulledMesh(m) => m.area_distrib.as_ref().map_or(0.0, |d| d.total as f32),
            Shape::Sphere(s) => s.area(),
            Shape::Disk(d) => d.area(),
            Shape::Cylinder(c) => c.area(),
            Shape::Ellipsoids(_) | Shape::SdfGrid(_) | Shape::Curves(_) => 0.0,
        }
    }

    /// Intersects an analytic shape (meshes are intersected per triangle by
    /// the BVH); a multi-part shape's part 0.
    #[inline]
    pub fn intersect_analytic(&self, ray: &Ray) -> Option<(f32, Vec2)> {
        self.intersect_prim(0, ray)
    }

    /// Intersects primitive `i` of an analytic or multi-part shape (None for
    /// a [`Shape::Mesh`], whose triangles the BVH tests in blocks). `uv` as
    /// in [`Shape::interaction`].
    #[inline]
    pub fn intersect_prim(&self, i: usize, ray: &Ray) -> Option<(f32, Vec2)> {
        match self {
            Shape::Sphere(s) => s.intersect(ray).map(|t| (t, Vec2::ZERO)),
            Shape::Disk(d) => d.intersect(ray),
            Shape::Cylinder(c) => c.intersect(ray).map(|t| (t, Vec2::ZERO)),
            Shape::Ellipsoids(e) => e.items[i].intersect(ray).map(|t| (t, Vec2::ZERO)),
            Shape::SdfGrid(g) => g.intersect(i, ray).map(|t| (t, Vec2::ZERO)),
            Shape::Curves(c) => c.intersect(i, ray),
            Shape::CulledMesh(m) => {
                let v = m.vertices(i);
                if ray.d.dot((v[1] - v[0]).cross(v[2] - v[0])) > 0.0 {
                    return None;
                }
                let sh = super::triangle::RayShear::new(ray.d);
                super::triangle::intersect_triangle(ray, &sh, &v).map(|(t, b1, b2)| (t, Vec2::new(b1, b2)))
            }
            Shape::Mesh(_) => None,
        }
    }

    /// Completes a hit on primitive `prim` at distance `t`; `uv` holds the
    /// triangle barycentrics (b1, b2), the disk's local (x, y), or a curve's
    /// parameter along its segment (x). Fills in
    /// Mitsuba's uv, dp/du, dp/dv and a shading frame aligned with dp/du;
    /// `shape_id` becomes the result's `shape`.
    pub fn interaction(&self, shape_id: u32, prim: usize, ray: &Ray, t: f32, uv: Vec2) -> SurfaceInteraction {
        self.interaction_with(shape_id, prim, ray, t, uv, true)
    }

    /// [`Shape::interaction`]; with `param` false (for materials where
    /// [`Material::reads_uv`](crate::material::Material::reads_uv) is false)
    /// it skips Mitsuba's uv and dp/dv: `uv` and `dpdv` are then meaningless,
    /// and `dpdu` is a cheap tangent that only orients `sh_frame` about the
    /// normal, which such materials do not see.
    #[inline]
    pub fn interaction_with(
        &self,
        shape_id: u32,
        prim: usize,
        ray: &Ray,
        t: f32,
        uv: Vec2,
        param: bool,
    ) -> SurfaceInteraction {
        let wo = -ray.d.normalize();
        let (p, n, sh_n, tex, dpdu, dpdv) = match self {
            Shape::Mesh(m) | Shape::CulledMesh(m) => {
                let t_idx = m.mesh.indices[prim];
                let [p0, p1, p2] = m.vertices(prim);
                let (b1, b2) = (uv.x, uv.y);
                let b0 = 1.0 - b1 - b2;
                let p = b0 * p0 + b1 * p1 + b2 * p2;
                let (dp0, dp1) = (p1 - p0, p2 - p0);
                let n = dp0.cross(dp1).normalize();
                let mut sh_n = n;
                if !m.face_normals && !m.mesh.normals.is_empty() {
                    let ns = &m.mesh.normals;
                    let s = b0 * ns[t_idx[0] as usize] + b1 * ns[t_idx[1] as usize] + b2 * ns[t_idx[2] as usize];
                    if s.length_squared() > 0.0 {
                        sh_n = s.normalize();
                    }
                }
                // Without texture coordinates the parameterisation is barycentric.
                let (mut tex, mut dpdu, mut dpdv) = (Vec2::new(b1, b2), dp0, dp1);
                if param && !m.mesh.uvs.is_empty() {
                    let u = &m.mesh.uvs;
                    let (uv0, uv1, uv2) = (u[t_idx[0] as usize], u[t_idx[1] as usize], u[t_idx[2] as usize]);
                    tex = b0 * uv0 + b1 * uv1 + b2 * uv2;
                    let (duv0, duv1) = (uv1 - uv0, uv2 - uv0);
                    let det = duv0.x * duv1.y - duv0.y * duv1.x;
                    if det != 0.0 {
                        let inv = 1.0 / det;
                        dpdu = (duv1.y * dp0 - duv0.y * dp1) * inv;
                        dpdv = (duv0.x * dp1 - duv1.x * dp0) * inv;
                    } else {
                        // Degenerate uvs: Mitsuba falls back to an arbitrary basis.
                        let f = Frame::from_normal(n);
                        (dpdu, dpdv) = (f.s, f.t);
                    }
                }
                (p, n, sh_n, tex, dpdu, dpdv)
            }
            Shape::Sphere(s) => {
                let (p, n, tex, dpdu, dpdv) = s.interaction(ray, t, param);
                (p, n, n, tex, dpdu, dpdv)
            }
            Shape::Disk(d) => {
                let (p, n, tex, dpdu, dpdv) = d.interaction(uv, param);
                (p, n, n, tex, dpdu, dpdv)
            }
            Shape::Cylinder(c) => {
                let (p, n, tex, dpdu, dpdv) = c.interaction(ray, t);
                (p, n, n, tex, dpdu, dpdv)
            }
            Shape::Ellipsoids(e) => {
                let (p, n) = e.items[prim].interaction(ray, t);
                (p, n, n, Vec2::ZERO, Vec3::ZERO, Vec3::ZERO)
            }
            Shape::SdfGrid(g) => {
                let (p, n, sh_n) = g.interaction(ray, t);
                (p, n, sh_n, Vec2::ZERO, Vec3::ZERO, Vec3::ZERO)
            }
            Shape::Curves(c) => {
                let (p, n, tex, dpdu, dpdv) = c.interaction(prim, ray, t, uv.x);
                (p, n, n, tex, dpdu, dpdv)
            }
        };
        SurfaceInteraction {
            p,
            t,
            n,
            sh_frame: SurfaceInteraction::frame_from_dpdu(sh_n, dpdu),
            uv: tex,
            dpdu,
            dpdv,
            shape: shape_id,
            prim: prim as u32,
            bary: if matches!(self, Shape::Mesh(_) | Shape::CulledMesh(_)) { uv } else { Vec2::ZERO },
            wo,
        }
    }

    /// Uniform point on the surface: (point, front normal, density per unit area).
    pub fn sample_area(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        let s = self.sample_point(u);
        (s.p, s.n, s.pdf)
    }

    /// [`Shape::sample_area`] with the primitive and parameter of the point.
    pub fn sample_point(&self, u: Vec2) -> AreaSample {
        let (prim, param) = (0, Vec2::ZERO);
        let ((p, n, pdf), prim, param) = match self {
            Shape::Mesh(m) | Shape::CulledMesh(m) => {
                let d = m.area_distrib.as_ref().expect("sampling a mesh without area");
                let (i, _, ux) = d.sample_discrete(u.x);
                let b = warp::sample_uniform_triangle(Vec2::new(ux, u.y));
                let [p0, p1, p2] = m.vertices(i);
                let p = (1.0 - b.x - b.y) * p0 + b.x * p1 + b.y * p2;
                let n = (p1 - p0).cross(p2 - p0).normalize();
                ((p, n, 1.0 / d.total as f32), i as u32, b)
            }
            Shape::Sphere(s) => (s.sample_area(u), prim, param),
            Shape::Disk(d) => {
                let q = warp::sample_concentric_disk(u);
                (d.sample_area(u), prim, q)
            }
            Shape::Cylinder(c) => (c.sample_area(u), prim, param),
            // Never emitters (the scene builder refuses them): a zero density.
            Shape::Ellipsoids(_) | Shape::SdfGrid(_) | Shape::Curves(_) => ((Vec3::ZERO, Vec3::Z, 0.0), prim, param),
        };
        AreaSample { p, n, pdf, prim, param }
    }

    /// Samples a point of the shape as seen from `p_ref`, with the density per
    /// unit solid angle at `p_ref`. Spheres seen from outside sample the cone
    /// they subtend (pbrt-v4 §6.2.4); other shapes sample their area.
    pub fn sample_direction(&self, p_ref: Vec3, u: Vec2) -> Option<ShapeSample> {
        if let Shape::Sphere(s) = self {
            if let Some(x) = s.sample_cone(p_ref, u) {
                return Some(x);
            }
        }
        let a = self.sample_point(u);
        let pdf = area_to_solid_angle(a.pdf, p_ref, a.p, a.n)?;
        Some(ShapeSample { p: a.p, n: a.n, pdf, prim: a.prim, param: a.param })
    }

    /// Density per unit solid angle with which [`Shape::sample_direction`]
    /// from `p_ref` yields the point `p` (normal `n`) of this shape.
    pub fn pdf_direction(&self, p_ref: Vec3, p: Vec3, n: Vec3) -> f32 {
        if let Shape::Sphere(s) = self {
            if let Some(pdf) = s.pdf_cone(p_ref) {
                return pdf;
            }
        }
        area_to_solid_angle(1.0 / self.area(), p_ref, p, n).unwrap_or(0.0)
    }
}

/// Converts an area density at `p` to a solid-angle density at `p_ref`:
/// p_ω = p_A · d² / |cos θ_light| (pbrt-v4 eq. 4.11).
#[inline]
fn area_to_solid_angle(pdf_area: f32, p_ref: Vec3, p: Vec3, n: Vec3) -> Option<f32> {
    let d = p - p_ref;
    let dist2 = d.length_squared();
    if dist2 == 0.0 {
        return None;
    }
    let cos = (n.dot(d) / dist2.sqrt()).abs();
    if cos == 0.0 {
        return None;
    }
    Some(pdf_area * dist2 / cos)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The interaction for the closest hit of a ray (analytic shapes and meshes).
    pub(crate) fn hit(s: &Shape, o: [f32; 3], d: [f32; 3]) -> SurfaceInteraction {
        let ray = Ray::new(Vec3::from_array(o), Vec3::from_array(d), f32::INFINITY);
        if let Some((t, uv)) = s.intersect_analytic(&ray) {
            return s.interaction(0, 0, &ray, t, uv);
        }
        let Shape::Mesh(m) = s else { panic!("missed") };
        let sh = super::super::triangle::RayShear::new(ray.d);
        let best = (0..m.mesh.indices.len())
            .filter_map(|i| super::super::triangle::intersect_triangle(&ray, &sh, &m.vertices(i)).map(|h| (i, h)))
            .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
            .expect("missed");
        let (i, (t, b1, b2)) = best;
        s.interaction(0, i, &ray, t, Vec2::new(b1, b2))
    }

    fn close(a: Vec3, b: [f32; 3], tol: f32, what: &str) {
        assert!((a - Vec3::from_array(b)).abs().max_element() < tol, "{what}: {a} vs {b:?}");
    }

    /// Checks uv, dp/du, dp/dv, the frame's tangent s and normal against
    /// values printed by Mitsuba 3.9.1 (scalar_rgb):
    ///   s = mi.load_dict({'type': 'scene', 's': shape})
    ///   si = s.ray_intersect(mi.Ray3f(o, d)); si.uv, si.dp_du, si.dp_dv, si.sh_frame
    pub(crate) fn check(
        si: &SurfaceInteraction,
        uv: [f32; 2],
        dpdu: [f32; 3],
        dpdv: [f32; 3],
        s: [f32; 3],
        n: [f32; 3],
    ) {
        let tol = 1e-4 * (1.0 + Vec3::from_array(dpdu).length().max(Vec3::from_array(dpdv).length()));
        assert!((si.uv - Vec2::from_array(uv)).abs().max_element() < 1e-5, "uv {} vs {uv:?}", si.uv);
        close(si.dpdu, dpdu, tol, "dp_du");
        close(si.dpdv, dpdv, tol, "dp_dv");
        close(si.sh_frame.s, s, 1e-5, "s");
        close(si.sh_frame.n, n, 1e-5, "n");
        close(si.sh_frame.t, si.sh_frame.n.cross(si.sh_frame.s).to_array(), 1e-6, "t = n x s");
    }

    // {'type': 'rectangle', 'to_world': T.translate([0,0,1]).rotate([0,0,1],30).scale([2,3,1])}
    #[test]
    fn rectangle_uv_and_frame_match_mitsuba() {
        let mut m = TriangleMesh::rectangle();
        let to_world = Mat4::from_translation(Vec3::Z)
            * Mat4::from_rotation_z(30f32.to_radians())
            * Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0));
        m.transform(&to_world);
        let s = Shape::Mesh(Mesh::new(m, false));
        let si = hit(&s, [0.5, 0.7, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.6957532, 0.5593697],
            [3.4641018, 2.0, 0.0],
            [-3.0, 5.196152, 0.0],
            [0.86602545, 0.5, 0.0],
            [0.0, 0.0, 1.0],
        );
        let si = hit(&s, [-1.0, 0.2, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.30849367, 0.61220086],
            [3.4641018, 2.0, 0.0],
            [-3.0, 5.196152, 0.0],
            [0.86602545, 0.5, 0.0],
            [0.0, 0.0, 1.0],
        );
    }

    // {'type': 'cube'}, one ray per face
    #[test]
    fn cube_uv_and_frame_match_mitsuba() {
        let s = Shape::Mesh(Mesh::new(TriangleMesh::cube(), false));
        let cases: [([f32; 3], [f32; 3], [f32; 2], [f32; 3], [f32; 3], [f32; 3]); 6] = [
            ([0.3, -0.6, 5.0], [0.0, 0.0, -1.0], [0.2, 0.65], [0.0, 2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            ([0.3, -0.6, -5.0], [0.0, 0.0, 1.0], [0.8, 0.65], [0.0, -2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
            ([5.0, 0.2, 0.7], [-1.0, 0.0, 0.0], [0.6, 0.15], [0.0, 2.0, 0.0], [0.0, 0.0, -2.0], [1.0, 0.0, 0.0]),
            ([-5.0, 0.2, 0.7], [1.0, 0.0, 0.0], [0.6, 0.85], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0], [-1.0, 0.0, 0.0]),
            ([0.2, 5.0, 0.7], [0.0, -1.0, 0.0], [0.4, 0.15], [-2.0, 0.0, 0.0], [0.0, 0.0, -2.0], [0.0, 1.0, 0.0]),
            ([0.2, -5.0, 0.7], [0.0, 1.0, 0.0], [0.85, 0.6], [0.0, 0.0, 2.0], [2.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
        ];
        for (o, d, uv, dpdu, dpdv, n) in cases {
            let si = hit(&s, o, d);
            check(&si, uv, dpdu, dpdv, (Vec3::from_array(dpdu) / 2.0).to_array(), n);
        }
    }

    // mi.Mesh with vertex_positions [0,0,0, 2,0,0.5, 0,1,0], faces [0,1,2], with and
    // without vertex_texcoords [0.1,0.2, 0.9,0.4, 0.3,0.8]; ray from (0.5,0.25,5) along -z
    #[test]
    fn mesh_uv_and_frame_match_mitsuba() {
        let mut m = TriangleMesh {
            positions: vec![Vec3::ZERO, Vec3::new(2.0, 0.0, 0.5), Vec3::Y],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        };
        let si = hit(&Shape::Mesh(Mesh::new(m.clone(), false)), [0.5, 0.25, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.25, 0.25],
            [2.0, 0.0, 0.5],
            [0.0, 1.0, 0.0],
            [0.97014254, 0.0, 0.24253564],
            [-0.24253564, 0.0, 0.97014254],
        );
        m.uvs = vec![Vec2::new(0.1, 0.2), Vec2::new(0.9, 0.4), Vec2::new(0.3, 0.8)];
        let si = hit(&Shape::Mesh(Mesh::new(m, false)), [0.5, 0.25, 5.0], [0.0, 0.0, -1.0]);
        check(
            &si,
            [0.35, 0.4],
            [2.7272727, -0.45454547, 0.6818182],
            [-0.909091, 1.8181816, -0.22727275],
            [0.95770437, -0.1596174, 0.2394261],
            [-0.24253564, 0.0, 0.97014254],
        );
    }
}
