//! The area lights of a scene whose every light has a lane kernel, as one
//! table of floats ([`LaneLightTable`]): a lane kernel picks each lane's
//! light, and on a mesh light its triangle, by gathers
//! ([`crate::simd::Float::gather_table`]) instead of a scalar pick per
//! vertex and per candidate written into its batch.
//!
//! The table copies the mesh lights' triangles (44 bytes each) beside
//! `Scene::lane_light_tris`, which the per-vertex picks of the other
//! selections read; meshes of more than 2^16 triangles have no lane light.
//!
//! The picks are bitwise the scalar ones: the uniform selection is
//! `LightSampler::Uniform`'s (`fast::index(u n).min(n - 1)`, probability
//! 1 / n), and the triangle pick is `alias_pick` on the mesh's alias
//! table (`Mesh::pick_triangle`'s), its operations lane by lane.

use crate::sampling::distrib2d::{alias_pick_lanes, index_lanes};
use crate::simd::{Float, Int, Mask, V3};
use glam::Vec3;

/// Where a light's fields are among its [`light::STRIDE`] floats.
mod light {
    /// 1 on a sphere, 0 on a mesh.
    pub const KIND: usize = 0;
    /// A sphere's centre, then (radius, 1 / area, 1 if its normals are flipped).
    pub const SPHERE: usize = 1;
    /// A mesh's first triangle in the triangle table (its bits).
    pub const FIRST: usize = 7;
    /// A mesh's triangle count (as a float: exact, at most 2^16).
    pub const COUNT: usize = 8;
    /// A mesh's density per unit area.
    pub const AREA_PDF: usize = 9;
    /// The radiance (3 floats).
    pub const LI: usize = 10;
    /// 1 where it emits from both sides.
    pub const TWO_SIDED: usize = 13;
    /// Floats per light.
    pub const STRIDE: usize = 14;
}

/// Where a triangle's fields are among its [`tri::STRIDE`] floats.
mod tri {
    /// Bucket `b` of its mesh's alias table: the share kept, then the bits
    /// of the triangle (an index among the mesh's own) taking the rest.
    pub const KEEP: usize = 0;
    /// Triangle `b`'s corners (9 floats).
    pub const P: usize = 2;
    /// Floats per triangle.
    pub const STRIDE: usize = 11;
}

/// Area lights on meshes and spheres with constant radiance, in the
/// scene's light order (see the module notes).
#[derive(Debug, Clone, Default)]
pub struct LaneLightTable {
    lights: Vec<f32>,
    tris: Vec<f32>,
    /// Whether any light is on a sphere.
    spheres: bool,
}

/// What each lane's picked light gives the area light's sample.
pub struct LanePick<F: Float> {
    /// Lanes on a sphere (the others on a mesh).
    pub sphere: F::Mask,
    /// A triangle's corners, or a sphere's centre and (radius, 1 / area, flip).
    pub geo: [V3<F>; 3],
    /// A mesh's density per unit area.
    pub area_pdf: F,
    /// The light's numbers, on a mesh the first rescaled by the triangle's pick.
    pub u: (F, F),
    /// The radiance.
    pub li: V3<F>,
    /// Lanes whose light emits from both sides.
    pub two_sided: F::Mask,
}

impl LaneLightTable {
    /// How many lights.
    pub fn len(&self) -> usize {
        self.lights.len() / light::STRIDE
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Whether every float of the table has an i32 index (for gathers).
    pub fn gathers(&self) -> bool {
        self.lights.len().max(self.tris.len()) <= i32::MAX as usize
    }

    /// Whether any light is on a mesh, and whether any is on a sphere.
    #[inline]
    pub fn kinds(&self) -> (bool, bool) {
        (!self.tris.is_empty(), self.spheres)
    }

    /// Adds a light on a mesh: its alias table's buckets (share kept,
    /// triangle taking the rest) with triangle `b`'s corners.
    pub fn push_mesh(&mut self, tris: &[(f32, u32, [Vec3; 3])], area_pdf: f32, li: Vec3, two_sided: bool) {
        let first = (self.tris.len() / tri::STRIDE) as u32;
        let mut l = [0.0; light::STRIDE];
        l[light::FIRST] = f32::from_bits(first);
        l[light::COUNT] = tris.len() as f32;
        l[light::AREA_PDF] = area_pdf;
        self.push(l, li, two_sided);
        for &(keep, other, p) in tris {
            let mut t = [0.0; tri::STRIDE];
            t[tri::KEEP] = keep;
            t[tri::KEEP + 1] = f32::from_bits(other);
            for (k, c) in p.iter().enumerate() {
                t[tri::P + 3 * k..][..3].copy_from_slice(&c.to_array());
            }
            self.tris.extend(t);
        }
    }

    /// Adds a light on a sphere: its centre and (radius, 1 / area, 1 if
    /// its normals are flipped).
    pub fn push_sphere(&mut self, center: Vec3, params: Vec3, li: Vec3, two_sided: bool) {
        let mut l = [0.0; light::STRIDE];
        l[light::KIND] = 1.0;
        self.spheres = true;
        l[light::SPHERE..][..3].copy_from_slice(&center.to_array());
        l[light::SPHERE + 3..][..3].copy_from_slice(&params.to_array());
        self.push(l, li, two_sided);
    }

    fn push(&mut self, mut l: [f32; light::STRIDE], li: Vec3, two_sided: bool) {
        l[light::LI..][..3].copy_from_slice(&li.to_array());
        l[light::TWO_SIDED] = if two_sided { 1.0 } else { 0.0 };
        self.lights.extend(l);
    }

    /// `LightSampler::Uniform`'s pick in lanes: light `min(⌊u n⌋, n - 1)`,
    /// and its probability 1 / n.
    #[inline(always)]
    pub fn select_uniform<F: Float>(&self, u: F) -> (F::Int, F) {
        let n = self.len();
        (index_lanes(u * F::splat(n as f32), n - 1), F::splat(1.0 / n as f32))
    }

    /// Lane `l`'s light `k[l]` with its numbers `u`, its triangle picked on
    /// a mesh. `kinds`: whether any lane may be on a mesh and whether any
    /// may be on a sphere (only those fields are read).
    #[inline(always)]
    pub fn pick<F: Float>(&self, k: F::Int, u: (F, F), kinds: (bool, bool)) -> LanePick<F> {
        let lights = &self.lights[..];
        let base = k.wrapping_mul(F::Int::splat(light::STRIDE as i32));
        let at = |f: usize| F::gather_table(lights, base.wrapping_add(F::Int::splat(f as i32)));
        let at3 = |f: usize| V3 { x: at(f), y: at(f + 1), z: at(f + 2) };
        let sphere = if kinds.0 && kinds.1 { at(light::KIND).cmp_eq(F::splat(1.0)) } else { F::Mask::splat(kinds.1) };
        let zero = V3::splat(Vec3::ZERO);
        let (mut geo, mut u) = ([zero; 3], u);
        if kinds.0 && !self.tris.is_empty() {
            // `alias_pick` on the mesh's table, its size per lane.
            let first = at(light::FIRST).to_bits();
            let stride = F::Int::splat(tri::STRIDE as i32);
            let start = first.wrapping_mul(stride).wrapping_add(F::Int::splat(tri::KEEP as i32));
            let (b, u_re) = alias_pick_lanes(u.0, at(light::COUNT), &self.tris, start, tri::STRIDE as i32);
            let t = first.wrapping_add(b).wrapping_mul(stride);
            let c = |f: usize| F::gather_table(&self.tris, t.wrapping_add(F::Int::splat(f as i32)));
            geo = std::array::from_fn(|k| V3 {
                x: c(tri::P + 3 * k),
                y: c(tri::P + 3 * k + 1),
                z: c(tri::P + 3 * k + 2),
            });
            u.0 = F::select(sphere, u.0, u_re);
        }
        if kinds.1 {
            let (center, params) = (at3(light::SPHERE), at3(light::SPHERE + 3));
            geo[0] = V3::select(sphere, center, geo[0]);
            geo[1] = V3::select(sphere, params, geo[1]);
        }
        LanePick {
            sphere,
            geo,
            area_pdf: at(light::AREA_PDF),
            u,
            li: at3(light::LI),
            two_sided: at(light::TWO_SIDED).cmp_eq(F::splat(1.0)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::LightSampler;
    use crate::sampling::distrib1d::alias_pick;
    use crate::sampling::Distribution1D;
    use crate::simd::check::{each_simd, Visit};
    use crate::simd::gather;
    use crate::testing::TestRng;

    /// A mesh light (its alias table and corners) or a sphere light, as the
    /// scalar lane vertex reads them.
    enum Scalar {
        Mesh(Vec<(f32, u32, [Vec3; 3])>, f32),
        Sphere(Vec3, Vec3),
    }

    /// Lights of both kinds, meshes of 1 to 40 triangles of uneven areas.
    fn lights(rng: &mut TestRng, n: usize, spheres: bool) -> (LaneLightTable, Vec<(Scalar, Vec3, bool)>) {
        let (mut table, mut scalar) = (LaneLightTable::default(), Vec::new());
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0;
        for i in 0..n {
            let (li, two_sided) = (v().abs(), i % 3 == 0);
            if spheres && i % 2 == 1 {
                let (c, params) = (v(), v().abs());
                table.push_sphere(c, params, li, two_sided);
                scalar.push((Scalar::Sphere(c, params), li, two_sided));
            } else {
                let tris: Vec<[Vec3; 3]> = (0..1 + (i * 7) % 40).map(|_| [v(), v(), v()]).collect();
                let areas: Vec<f32> = tris.iter().map(|t| (t[1] - t[0]).cross(t[2] - t[0]).length()).collect();
                let d = Distribution1D::new(&areas).unwrap();
                let rows: Vec<_> = d.alias().iter().enumerate().map(|(b, &(k, o))| (k, o, tris[b])).collect();
                let area_pdf = 1.0 / (i as f32 + 1.5);
                table.push_mesh(&rows, area_pdf, li, two_sided);
                scalar.push((Scalar::Mesh(rows, area_pdf), li, two_sided));
            }
        }
        (table, scalar)
    }

    /// `select_uniform` then `pick` give, lane by lane and bit for bit, the
    /// light `LightSampler::Uniform` selects and the triangle and rescaled
    /// number `alias_pick` gives on its table, with its fields, at every
    /// lane width built.
    #[test]
    fn picks_are_the_scalar_picks() {
        struct V(TestRng);
        impl Visit for V {
            fn visit<F: Float>(&mut self) {
                for (n, spheres) in [(1, false), (2, false), (7, true), (100, true)] {
                    let (table, scalar) = lights(&mut self.0, n, spheres);
                    assert_eq!(table.len(), n);
                    let sampler = LightSampler::Uniform { count: n };
                    for round in 0..300 {
                        let mut us: Vec<[f32; 3]> =
                            (0..F::WIDTH).map(|_| [self.0.next_f32(), self.0.next_f32(), self.0.next_f32()]).collect();
                        if round == 0 {
                            us[0] = [0.0, 0.0, 0.0];
                            us[F::WIDTH - 1] = [1.0 - f32::EPSILON / 2.0; 3];
                        }
                        let lane = |c: usize| gather::<F>(|l| us[l][c]);
                        let (k, pmf_lanes) = table.select_uniform(lane(0));
                        let pick = table.pick(k, (lane(1), lane(2)), table.kinds());
                        let (k, sphere, two_sided) = (k.to_array(), pick.sphere.bitmask(), pick.two_sided.bitmask());
                        let at = |x: F, l: usize| x.to_array().as_ref()[l].to_bits();
                        let at3 = |v: V3<F>, l: usize| [at(v.x, l), at(v.y, l), at(v.z, l)];
                        let bits3 = |v: Vec3| v.to_array().map(f32::to_bits);
                        for (l, u) in us.iter().enumerate() {
                            let (i, pmf) = sampler.sample(Vec3::ZERO, Vec3::ZERO, u[0]).unwrap();
                            assert_eq!((k.as_ref()[l] as usize, pmf), (i, 1.0 / n as f32), "{} lane {l}", F::NAME);
                            assert_eq!(at(pmf_lanes, l), pmf.to_bits());
                            let (light, li, ts) = &scalar[i];
                            assert_eq!(at3(pick.li, l), bits3(*li));
                            assert_eq!(two_sided >> l & 1 == 1, *ts);
                            match light {
                                Scalar::Sphere(c, params) => {
                                    assert_eq!(sphere >> l & 1, 1);
                                    assert_eq!((at3(pick.geo[0], l), at3(pick.geo[1], l)), (bits3(*c), bits3(*params)));
                                    assert_eq!(at(pick.u.0, l), u[1].to_bits());
                                }
                                Scalar::Mesh(rows, area_pdf) => {
                                    assert_eq!(sphere >> l & 1, 0);
                                    let (t, ux) = alias_pick(u[1], rows.len(), |b| (rows[b].0, rows[b].1));
                                    for c in 0..3 {
                                        assert_eq!(at3(pick.geo[c], l), bits3(rows[t].2[c]), "{} corner {c}", F::NAME);
                                    }
                                    assert_eq!(
                                        (at(pick.u.0, l), at(pick.area_pdf, l)),
                                        (ux.to_bits(), area_pdf.to_bits())
                                    );
                                }
                            }
                            assert_eq!(at(pick.u.1, l), u[2].to_bits());
                        }
                    }
                }
            }
        }
        let mut v = V(TestRng::new(11));
        v.visit::<f32>();
        let ran = each_simd(&mut v);
        println!("lane light picks: f32 and {ran:?}");
    }
}
