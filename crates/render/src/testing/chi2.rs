//! Chi-square goodness-of-fit test of a direction sampler against its pdf
//! (the method of Mitsuba's `chi2.py` and pbrt's tests): histogram many
//! samples over a (cos θ, φ) grid of the sphere, integrate the claimed pdf
//! over each cell for the expected counts, pool sparse cells, and reject
//! when the p-value falls below a significance level.

use crate::math::PI;
use crate::sampling::rng::{hash_words, to_unit_f32};
use glam::{Vec2, Vec3};
use statrs::distribution::{ChiSquared, ContinuousCDF};

const THETA_BINS: usize = 24;
const PHI_BINS: usize = 48;

fn cell(w: Vec3) -> usize {
    let z = w.z.clamp(-1.0, 1.0);
    let iz = (((z + 1.0) * 0.5) * THETA_BINS as f32) as usize;
    let phi = w.y.atan2(w.x);
    let phi = if phi < 0.0 { phi + 2.0 * PI } else { phi };
    let ip = ((phi / (2.0 * PI)) * PHI_BINS as f32) as usize;
    iz.min(THETA_BINS - 1) * PHI_BINS + ip.min(PHI_BINS - 1)
}

/// Runs the test. `sample` maps (u1, u2) to a direction and its claimed
/// weight (None = no sample); a sampler that may fail must have a pdf that
/// integrates to the success probability. Returns the p-value.
pub fn chi2_test(
    n: usize,
    seed: u64,
    mut sample: impl FnMut(f32, Vec2) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> f64 {
    let cells = THETA_BINS * PHI_BINS;
    let mut observed = vec![0f64; cells];
    for i in 0..n as u64 {
        let h = hash_words(&[seed, i]);
        let u = Vec2::new(to_unit_f32(h), to_unit_f32(h << 24));
        let u1 = to_unit_f32(hash_words(&[seed, i, 1]));
        if let Some(w) = sample(u1, u) {
            assert!(w.is_finite() && (w.length() - 1.0).abs() < 1e-3, "sample {w} is not a unit direction");
            observed[cell(w)] += 1.0;
        }
    }
    // Expected counts: midpoint rule on a sub-grid of each cell in (z, φ),
    // where dz dφ is the solid-angle measure. Cells the pdf's support cuts
    // through (some sub-samples zero, some not), or empty ones that received
    // samples, are integrated again on a much finer grid.
    let mut expected = vec![0f64; cells];
    let dz = 2.0 / THETA_BINS as f64;
    let dp = 2.0 * std::f64::consts::PI / PHI_BINS as f64;
    let integrate = |iz: usize, ip: usize, sub: usize| -> (f64, bool) {
        let (mut acc, mut zeros) = (0.0, 0);
        for a in 0..sub {
            for b in 0..sub {
                let z = -1.0 + (iz as f64 + (a as f64 + 0.5) / sub as f64) * dz;
                let phi = (ip as f64 + (b as f64 + 0.5) / sub as f64) * dp;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let v = pdf(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
                zeros += (v == 0.0) as usize;
                acc += v;
            }
        }
        (acc / (sub * sub) as f64 * dz * dp * n as f64, zeros > 0 && zeros < sub * sub)
    };
    for iz in 0..THETA_BINS {
        for ip in 0..PHI_BINS {
            let c = iz * PHI_BINS + ip;
            let (e8, mixed) = integrate(iz, ip, 8);
            let e = integrate(iz, ip, 16).0;
            // Jumps inside the cell (support edges, or the density switching
            // between surfaces) show as disagreement between the two grids.
            let rough = (e - e8).abs() > 1e-3 * e.max(1e-9);
            expected[c] = if mixed || rough || (e == 0.0 && observed[c] > 0.0) {
                // A support edge inside the cell: refine, and refine further
                // if the cell still looks empty (a thin sliver of support).
                match integrate(iz, ip, 96).0 {
                    0.0 if observed[c] > 0.0 => integrate(iz, ip, 512).0,
                    v => v,
                }
            } else {
                e
            };
        }
    }
    // Pool cells with small expectation (they make the statistic unreliable).
    let mut order: Vec<usize> = (0..cells).collect();
    order.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
    let (mut chi2, mut dof) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for &c in &order {
        if expected[c] == 0.0 {
            assert!(observed[c] == 0.0, "{} samples landed where the pdf is zero (cell {c})", observed[c]);
            continue;
        }
        if expected[c] < 5.0 {
            pool_o += observed[c];
            pool_e += expected[c];
            if pool_e >= 5.0 {
                chi2 += (pool_o - pool_e).powi(2) / pool_e;
                dof += 1;
                pool_o = 0.0;
                pool_e = 0.0;
            }
            continue;
        }
        chi2 += (observed[c] - expected[c]).powi(2) / expected[c];
        dof += 1;
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e).powi(2) / pool_e;
        dof += 1;
    }
    let dist = ChiSquared::new((dof.max(2) - 1) as f64).unwrap();
    1.0 - dist.cdf(chi2)
}

/// ∫ pdf dω over the sphere by the midpoint rule on a fine (cos θ, φ) grid.
pub fn integrate_over_sphere(pdf: impl Fn(Vec3) -> f64) -> f64 {
    let (nz, np) = (400, 800);
    let (dz, dp) = (2.0 / nz as f64, 2.0 * std::f64::consts::PI / np as f64);
    let mut acc = 0.0;
    for i in 0..nz {
        let z = -1.0 + (i as f64 + 0.5) * dz;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for j in 0..np {
            let phi = (j as f64 + 0.5) * dp;
            acc += pdf(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
        }
    }
    acc * dz * dp
}

/// Significance level per test (1 %, Šidák-corrected for the number of
/// tests a module runs).
pub fn alpha(tests: usize) -> f64 {
    1.0 - (1.0 - 0.01f64).powf(1.0 / tests as f64)
}

/// Runs `chi2_test` on every `(bsdf, wo)` case (seeds `seed0 + i`, `n`
/// samples each) at the significance `alpha(cases + 1)` (one more test is
/// left for the caller's wrong-pdf power check), asserts each passes,
/// prints the smallest p-value and returns that significance.
pub fn chi2_cases<B: std::fmt::Debug>(
    name: &str,
    n: usize,
    seed0: u64,
    cases: &[(B, Vec3)],
    sample: impl Fn(&B, Vec3, f32, Vec2) -> Option<Vec3>,
    pdf: impl Fn(&B, Vec3, Vec3) -> f64,
) -> f64 {
    let a = alpha(cases.len() + 1);
    let mut worst = 1.0f64;
    for (i, (b, wo)) in cases.iter().enumerate() {
        let p = chi2_test(n, seed0 + i as u64, |u1, u| sample(b, *wo, u1, u), |wi| pdf(b, *wo, wi));
        worst = worst.min(p);
        assert!(p > a, "{name} case {i} {b:?} wo={wo}: p = {p}");
    }
    println!("{name} chi2: {} cases, min p = {worst:.4} (alpha {a:.2e})", cases.len());
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Bsdf, BsdfKind, Diffuse};
    use crate::geometry::Shape;
    use crate::sampling::warp;

    const N: usize = 400_000;

    #[test]
    fn warps_match_their_densities() {
        let a = alpha(4);
        let p =
            chi2_test(N, 1, |_, u| Some(warp::sample_cosine_hemisphere(u)), |w| warp::cosine_hemisphere_pdf(w) as f64);
        assert!(p > a, "cosine hemisphere p = {p}");
        let p = chi2_test(N, 2, |_, u| Some(warp::sample_uniform_sphere(u)), |_| warp::uniform_sphere_pdf() as f64);
        assert!(p > a, "uniform sphere p = {p}");
        let cm = 0.7;
        let p = chi2_test(
            N,
            3,
            |_, u| Some(warp::sample_uniform_cone(u, cm)),
            |w| if w.z >= cm { warp::uniform_cone_pdf(cm) as f64 } else { 0.0 },
        );
        assert!(p > a, "cone p = {p}");
        // Equal-area: uniform on the square gives uniform directions.
        let p =
            chi2_test(N, 5, |_, u| Some(warp::equal_area_square_to_sphere(u)), |_| warp::uniform_sphere_pdf() as f64);
        assert!(p > a, "equal-area octahedral map p = {p}");
        // A deliberately wrong pdf must be rejected: the test can fail.
        let p = chi2_test(
            N,
            4,
            |_, u| Some(warp::sample_cosine_hemisphere(u)),
            |w| if w.z > 0.0 { 0.5 / PI as f64 } else { 0.0 },
        );
        assert!(p < a, "uniform pdf accepted for cosine samples (p = {p})");
    }

    #[test]
    fn diffuse_bsdf_sampling_matches_its_pdf() {
        let b = Bsdf::from(BsdfKind::Diffuse(Diffuse { reflectance: Vec3::splat(0.7) }));
        // A mask of opacity 0.6 samples the model with probability 0.6 and
        // a delta pass-through otherwise: the smooth part integrates to 0.6.
        let b2 = Bsdf { opacity: 0.6, ..b };
        let a = alpha(4);
        for (k, wo) in
            [Vec3::new(0.3, 0.1, 0.9).normalize(), Vec3::new(0.99, 0.0, 0.05).normalize()].into_iter().enumerate()
        {
            for (j, bsdf) in [&b, &b2].into_iter().enumerate() {
                let p = chi2_test(
                    N,
                    10 + k as u64 * 2 + j as u64,
                    |u1, u| bsdf.sample(wo, u1, u).filter(|s| !s.delta).map(|s| s.wi),
                    |wi| bsdf.pdf(wo, wi) as f64,
                );
                assert!(p > a, "diffuse (masked={j}) wo={wo}: p = {p}");
                // The sample weight equals f cos / pdf.
                let s = bsdf.sample(wo, 0.3, Vec2::new(0.2, 0.6)).unwrap();
                assert!(!s.delta);
                let expect = bsdf.eval(wo, s.wi) * s.wi.z.abs() / s.pdf;
                assert!((s.weight - expect).abs().max_element() < 1e-5);
            }
        }
    }

    #[test]
    fn sphere_light_sampling_matches_its_pdf() {
        let a = alpha(2);
        for (k, (c, r)) in
            [(Vec3::new(0.3, -0.2, 2.0), 0.8f32), (Vec3::new(0.0, 0.0, 0.3), 1.0)].into_iter().enumerate()
        {
            // Second case: the reference point is inside the sphere (area sampling).
            let s = Shape::sphere(c, r, false);
            let p = chi2_test(
                N,
                20 + k as u64,
                |_, u| s.sample_direction(Vec3::ZERO, u).map(|x| x.p.normalize()),
                |w| {
                    // Density of the first hit of the ray from the origin along w.
                    let ray = crate::geometry::Ray::new(Vec3::ZERO, w, f32::INFINITY);
                    match s.intersect_analytic(&ray) {
                        Some((t, _)) => {
                            let p = ray.at(t);
                            let n = (p - c).normalize();
                            s.pdf_direction(Vec3::ZERO, p, n) as f64
                        }
                        None => 0.0,
                    }
                },
            );
            assert!(p > a, "sphere {k}: p = {p}");
        }
    }

    /// Density of `sample_direction` from `p_ref` along `w`: the sum over
    /// every point of the shape on that ray (a closed mesh is crossed twice,
    /// and area sampling picks front and back faces alike).
    fn direction_density(shape: &Shape, p_ref: Vec3, w: Vec3) -> f64 {
        use crate::geometry::triangle::{intersect_triangle, RayShear};
        let ray = crate::geometry::Ray::new(p_ref, w, f32::INFINITY);
        match shape {
            Shape::Mesh(m) => {
                let sh = RayShear::new(w);
                (0..m.mesh.indices.len())
                    .filter_map(|i| {
                        let v = m.vertices(i);
                        intersect_triangle(&ray, &sh, &v).map(|(t, _, _)| {
                            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                            shape.pdf_direction(p_ref, ray.at(t), n) as f64
                        })
                    })
                    .sum()
            }
            _ => shape
                .intersect_analytic(&ray)
                .map(|(t, uv)| {
                    let si = shape.interaction(0, 0, &ray, t, uv);
                    shape.pdf_direction(p_ref, si.p, si.n) as f64
                })
                .unwrap_or(0.0),
        }
    }

    #[test]
    fn pdfs_integrate_to_one() {
        let cases: Vec<(&str, Box<dyn Fn(Vec3) -> f64>)> = vec![
            ("uniform hemisphere", Box::new(|w: Vec3| if w.z >= 0.0 { 0.5 / PI as f64 } else { 0.0 })),
            ("cosine hemisphere", Box::new(|w| warp::cosine_hemisphere_pdf(w) as f64)),
            ("uniform sphere", Box::new(|_| warp::uniform_sphere_pdf() as f64)),
            ("cone", Box::new(|w: Vec3| if w.z >= 0.6 { warp::uniform_cone_pdf(0.6) as f64 } else { 0.0 })),
            (
                "diffuse BSDF",
                Box::new(|w| {
                    Bsdf::from(BsdfKind::Diffuse(Diffuse { reflectance: Vec3::ONE }))
                        .pdf(Vec3::new(0.3, 0.0, 0.95).normalize(), w) as f64
                }),
            ),
        ];
        for (name, pdf) in cases {
            let total = integrate_over_sphere(pdf);
            // The grid's error at the support edge is below 1e-2 of a row.
            assert!((total - 1.0).abs() < 5e-3, "{name}: ∫ pdf = {total}");
        }
        let s = Shape::sphere(Vec3::new(0.3, -0.2, 2.0), 0.8, false);
        let total = integrate_over_sphere(|w| {
            let ray = crate::geometry::Ray::new(Vec3::ZERO, w, f32::INFINITY);
            s.intersect_analytic(&ray).map_or(0.0, |(t, _)| {
                let p = ray.at(t);
                s.pdf_direction(Vec3::ZERO, p, (p - Vec3::new(0.3, -0.2, 2.0)).normalize()) as f64
            })
        });
        assert!((total - 1.0).abs() < 5e-3, "sphere light: ∫ pdf = {total}");
    }

    #[test]
    fn area_light_sampling_matches_its_pdf() {
        use crate::geometry::{Mesh, TriangleMesh};
        use crate::math::Mat4;
        let rot = Mat4::from_rotation_x(0.6) * Mat4::from_rotation_z(0.3);
        let place = Mat4::from_translation(Vec3::new(0.2, -0.1, 1.5)) * rot;
        let mut rect = TriangleMesh::rectangle();
        rect.transform(&(place * Mat4::from_scale(Vec3::new(0.8, 0.4, 1.0))));
        let mut cube = TriangleMesh::cube();
        cube.transform(&(place * Mat4::from_scale(Vec3::splat(0.5))));
        let shapes = [
            ("rectangle", Shape::Mesh(Mesh::new(rect, false))),
            ("cube", Shape::Mesh(Mesh::new(cube, false))),
            ("disk", Shape::disk(place * Mat4::from_scale(Vec3::new(0.7, 0.5, 1.0)), false)),
        ];
        let a = alpha(shapes.len());
        for (k, (name, shape)) in shapes.iter().enumerate() {
            let p = chi2_test(
                N,
                40 + k as u64,
                |_, u| shape.sample_direction(Vec3::ZERO, u).map(|s| s.p.normalize()),
                |w| direction_density(shape, Vec3::ZERO, w),
            );
            assert!(p > a, "{name}: p = {p}");
        }
    }
}
