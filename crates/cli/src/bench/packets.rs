//! Packet against single-ray traversal (`penumbra bench --suite packets`):
//! a render's own rays, recorded on one thread so that consecutive queries
//! are one pixel's samples in order, replayed through the BVH one at a time
//! and as packets of 8 and 16 consecutive rays of one kind
//! ([`Accel::intersect_packet`], [`Accel::occluded_packet`]).
//!
//! Kinds: camera rays (the closest-hit queries leaving the camera's near
//! plane, which for the pinhole cameras of the bench scenes are exactly the
//! first ray of each sample), shadow rays (any-hit), and all rays (every
//! closest-hit query in log order in packets, then every shadow query).

use penumbra_render::accel::packet::MAX_PACKET;
use penumbra_render::accel::{Accel, Hit, Instance};
use penumbra_render::geometry::{Ray, Shape};
use penumbra_render::render::RenderJob;
use penumbra_render::scene::{LoggedRay, RayLog};
use penumbra_render::simd::Float;
use rayon::prelude::*;
use std::time::Instant;

/// Timed rounds per figure; the median is printed.
const ROUNDS: usize = 5;

/// The scenes compared, with their `-D` parameters, and the samples per
/// pixel recorded.
const SCENES: &[Bench] =
    &[("scenes/cornell-box.xml", &[("res", "256")], 4), ("tests/scenes/envmap_sun.xml", &[("res", "256")], 4)];

/// (scene file, `-D` parameters, samples per pixel recorded).
type Bench = (&'static str, &'static [(&'static str, &'static str)], u32);

/// A render's rays by kind, in log order.
pub struct Recorded {
    /// Closest-hit queries from the camera's near plane (first rays of samples).
    pub camera: Vec<Ray>,
    /// Every closest-hit query.
    pub closest: Vec<Ray>,
    /// Every any-hit (shadow) query.
    pub shadow: Vec<Ray>,
}

/// Renders `spp` samples per pixel of `job` on one thread with a ray log.
pub fn record(job: &RenderJob, spp: u32) -> Recorded {
    let log = RayLog::default();
    let mut rec = job.clone();
    rec.scene.ray_log = Some(log.clone());
    rec.sampler.spp = spp.max(1);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    crate::render_job(&rec, &one, true);
    let logged: Vec<LoggedRay> = std::mem::take(&mut *log.lock().unwrap_or_else(|e| e.into_inner()));
    // Camera rays start on the near plane: within near_clip / cos(angle
    // off the view axis) of the eye; no surface of the scenes is that near.
    let cam = &job.camera;
    let eye = cam.world_from_camera.transform_point3(glam::Vec3::ZERO);
    let reach = 2.0 * cam.near_clip * (1.0 + cam.tan_half.length());
    let closest: Vec<Ray> = logged.iter().filter(|l| !l.shadow).map(|l| l.ray).collect();
    Recorded {
        camera: closest.iter().copied().filter(|r| r.o.distance(eye) <= reach).collect(),
        shadow: logged.iter().filter(|l| l.shadow).map(|l| l.ray).collect(),
        closest,
    }
}

/// A scene's BVH and what it was built over.
#[derive(Clone, Copy)]
pub struct Target<'a> {
    pub accel: &'a Accel,
    pub shapes: &'a [Shape],
    pub instances: &'a [Instance],
}

/// Closest hits found among `rays`, traced one at a time (`width` 1) or in
/// packets of `width` consecutive rays with lanes `F`.
fn closest<F: Float>(t: Target, rays: &[Ray], width: usize) -> u64 {
    if width == 1 {
        return rays.iter().filter(|r| t.accel.intersect(r, t.shapes, t.instances).is_some()).count() as u64;
    }
    let mut out = [None::<Hit>; MAX_PACKET];
    rays.chunks(width)
        .map(|c| {
            t.accel.intersect_packet::<F>(c, t.shapes, t.instances, &mut out);
            out[..c.len()].iter().filter(|h| h.is_some()).count() as u64
        })
        .sum()
}

/// Blocked segments among `rays`, as [`closest`].
fn occluded<F: Float>(t: Target, rays: &[Ray], width: usize) -> u64 {
    if width == 1 {
        return rays.iter().filter(|r| t.accel.occluded(r, t.shapes, t.instances)).count() as u64;
    }
    rays.chunks(width).map(|c| t.accel.occluded_packet::<F>(c, t.shapes, t.instances).count_ones() as u64).sum()
}

/// Seconds and hits for the closest-hit rays `c` and shadow rays `s`, in
/// parallel chunks of 4096 rays.
fn time<F: Float>(t: Target, c: &[Ray], s: &[Ray], width: usize) -> (f64, u64) {
    let start = Instant::now();
    let hits = c.par_chunks(4096).map(|k| closest::<F>(t, k, width)).sum::<u64>()
        + s.par_chunks(4096).map(|k| occluded::<F>(t, k, width)).sum::<u64>();
    (start.elapsed().as_secs_f64(), hits)
}

/// The median of `v`'s seconds, with the hits (the same in every round).
fn median(mut v: Vec<(f64, u64)>) -> Option<(f64, u64)> {
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v.get(v.len() / 2).copied()
}

/// One row per scene and ray kind: rays/s single and in packets, and the ratio.
pub fn table(pool: &rayon::ThreadPool) -> anyhow::Result<()> {
    println!(
        "\npacket traversal (rays recorded on one thread, replayed on {} threads; median of {ROUNDS} alternating rounds):",
        pool.current_num_threads()
    );
    println!(
        "{:<16} {:<7} {:>9} {:>10} {:>10} {:>10} {:>7} {:>7}",
        "scene", "rays", "count", "single M/s", "x8 M/s", "x16 M/s", "x8", "x16"
    );
    for (scene, defines, spp) in SCENES {
        let defines: Vec<(String, String)> = defines.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        let job = penumbra_scene::load_scene(std::path::Path::new(scene), &defines, &Default::default())
            .map_err(|e| anyhow::anyhow!(e))?;
        let rec = record(&job, *spp);
        let t = Target { accel: &job.scene.accel, shapes: &job.scene.shapes, instances: &job.scene.instances };
        let kinds: [(&str, &[Ray], &[Ray]); 3] =
            [("camera", &rec.camera, &[]), ("shadow", &[], &rec.shadow), ("all", &rec.closest, &rec.shadow)];
        for (kind, c, s) in kinds {
            let n = (c.len() + s.len()) as f64;
            // Rounds alternate between the kernels, so that they share
            // the machine's load (it is noisy); medians are compared.
            let (mut single, mut p8, mut p16) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..ROUNDS {
                single.push(pool.install(|| time::<f32>(t, c, s, 1)));
                p8.extend(x8(pool, t, c, s));
                p16.extend(x16(pool, t, c, s));
            }
            let (t1, h1) = median(single).expect("ROUNDS > 0");
            let (x8, x16) = (median(p8), median(p16));
            for (w, h) in [(8, x8.map(|x| x.1)), (16, x16.map(|x| x.1))] {
                if let Some(h) = h {
                    anyhow::ensure!(h == h1, "{scene} {kind}: packets of {w} found {h} hits, single rays {h1}");
                }
            }
            let mrays = |s: Option<(f64, u64)>| s.map(|(s, _)| format!("{:.2}", n / s / 1e6)).unwrap_or("-".into());
            let ratio = |s: Option<(f64, u64)>| s.map(|(s, _)| format!("{:.2}x", t1 / s)).unwrap_or("-".into());
            println!(
                "{:<16} {:<7} {:>9} {:>10.2} {:>10} {:>10} {:>7} {:>7}",
                std::path::Path::new(scene).file_name().unwrap_or_default().to_string_lossy(),
                kind,
                n,
                n / t1 / 1e6,
                mrays(x8),
                mrays(x16),
                ratio(x8),
                ratio(x16)
            );
        }
    }
    println!(
        "x8, x16: single-ray seconds / packet seconds for the same rays (packets of consecutive rays of one kind)"
    );
    Ok(())
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
fn x8(pool: &rayon::ThreadPool, t: Target, c: &[Ray], s: &[Ray]) -> Option<(f64, u64)> {
    Some(pool.install(|| time::<penumbra_render::simd::F32x8>(t, c, s, 8)))
}
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma")))]
fn x8(_: &rayon::ThreadPool, _: Target, _: &[Ray], _: &[Ray]) -> Option<(f64, u64)> {
    None
}
#[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
fn x16(pool: &rayon::ThreadPool, t: Target, c: &[Ray], s: &[Ray]) -> Option<(f64, u64)> {
    Some(pool.install(|| time::<penumbra_render::simd::F32x16>(t, c, s, 16)))
}
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
fn x16(_: &rayon::ThreadPool, _: Target, _: &[Ray], _: &[Ray]) -> Option<(f64, u64)> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use penumbra_render::accel::packet::same_hit;

    /// Every logged ray of small renders of the two scenes, replayed in
    /// packets of consecutive rays as the bench forms them, gets the
    /// single-ray answer, bit for bit (closest hits and occlusion).
    fn check<F: Float>() {
        for (scene, _, _) in SCENES {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(scene);
            let defines = vec![("res".to_string(), "64".to_string())];
            let job = penumbra_scene::load_scene(&path, &defines, &Default::default()).unwrap();
            let rec = record(&job, 2);
            let (accel, shapes, inst) = (&job.scene.accel, &job.scene.shapes[..], &job.scene.instances[..]);
            assert_eq!(rec.camera.len(), 64 * 64 * 2, "{scene}");
            assert!(!rec.shadow.is_empty(), "{scene}");
            let mut out = [None; MAX_PACKET];
            let mut hits = 0;
            for c in rec.closest.chunks(F::WIDTH).chain(rec.camera.chunks(F::WIDTH)) {
                accel.intersect_packet::<F>(c, shapes, inst, &mut out);
                for (r, ray) in c.iter().enumerate() {
                    let single = accel.intersect(ray, shapes, inst);
                    assert!(same_hit(out[r], single), "{scene}: {ray:?}: {:?} vs {single:?}", out[r]);
                    hits += single.is_some() as u32;
                }
            }
            for c in rec.shadow.chunks(F::WIDTH) {
                let blocked = accel.occluded_packet::<F>(c, shapes, inst);
                for (r, ray) in c.iter().enumerate() {
                    assert_eq!(blocked & (1 << r) != 0, accel.occluded(ray, shapes, inst), "{scene}: {ray:?}");
                }
            }
            assert!(hits > 0);
            eprintln!("{scene} {}: {} closest, {} shadow, {hits} hits", F::NAME, rec.closest.len(), rec.shadow.len());
        }
    }

    #[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma"))]
    #[test]
    fn logged_rays_in_packets_of_8_match_single_rays() {
        check::<penumbra_render::simd::F32x8>();
    }

    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    #[test]
    fn logged_rays_in_packets_of_16_match_single_rays() {
        check::<penumbra_render::simd::F32x16>();
    }
}
