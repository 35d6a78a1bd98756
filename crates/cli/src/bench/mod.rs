//! `penumbra bench`: renders the bundled scenes and prints samples/s and
//! rays/s; with Mitsuba 3 available, times it on the same scene file and
//! prints the ratio.

mod efficiency;
#[cfg(feature = "embree")]
mod embree;
mod packets;
mod rays;
mod scale;
mod soak;
mod trace_only;

use crate::args::BenchArgs;
use anyhow::{anyhow, Result};
use penumbra_scene::Overrides;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The standard scenes with the `-D` parameters they are timed at.
const DEFAULT_SCENES: &[(&str, &[(&str, &str)])] = &[
    ("scenes/cornell-box.xml", &[]),
    ("tests/scenes/envmap_sun.xml", &[("res", "256"), ("spp", "64")]),
    // The sun-and-sky map again, over rough metals, frosted glass and plastics.
    ("tests/scenes/rough_spheres.xml", &[("width", "384"), ("height", "160"), ("spp", "64")]),
    ("tests/scenes/many_lights.xml", &[("res", "256"), ("spp", "64")]),
    // Glossy and textured: rough metals and glass, plastics, a normal map.
    ("scenes/material-showcase.xml", &[("width", "384"), ("height", "160"), ("spp", "64")]),
    // Participating media (volpath): chromatic fog with a spot light, a smoke grid under the sky.
    ("tests/scenes/fog_spot.xml", &[("res", "256"), ("spp", "64")]),
    ("tests/scenes/smoke_grid.xml", &[("res", "256"), ("spp", "64")]),
];

/// Samples per pixel whose rays the trace-only columns record, at most...
const TRACE_SPP: u32 = 8;
/// ...and camera samples in all (about 10 rays and 320 bytes of log each).
const TRACE_SAMPLES: u64 = 1 << 20;

/// Light-selection comparison: this scene against its converged reference.
const SELECTION_SCENE: &str = "tests/scenes/many_lights.xml";
const SELECTION_REF: &str = "tests/refs/many_lights.exr";
const SELECTION_SPP: u32 = 256;

fn mitsuba_python(a: &BenchArgs) -> Option<PathBuf> {
    if let Some(p) = &a.mitsuba {
        return Some(p.clone());
    }
    if let Ok(p) = std::env::var("PENUMBRA_MITSUBA_PYTHON") {
        return Some(PathBuf::from(p));
    }
    let local = Path::new(".venv-mitsuba/bin/python");
    local.exists().then(|| local.to_path_buf())
}

/// Runs tools/mitsuba_bench.py; returns Mitsuba's seconds for the render
/// that excludes its JIT warm-up.
fn time_mitsuba(
    python: &Path,
    variant: &str,
    scene: &Path,
    defines: &[(String, String)],
    spp: u32,
    threads: usize,
) -> Result<f64> {
    let mut cmd = Command::new(python);
    cmd.args(["tools/mitsuba_bench.py", "--variant", variant, "--spp", &spp.to_string()])
        .arg("--threads")
        .arg(threads.to_string());
    for (k, v) in defines {
        cmd.arg("-D").arg(format!("{k}={v}"));
    }
    let out = cmd.arg(scene).output().map_err(|e| anyhow!("cannot run {}: {e}", python.display()))?;
    let text = String::from_utf8_lossy(&out.stdout);
    // The last machine-readable line is the warm (second) render.
    let line = text
        .lines()
        .rfind(|l| l.starts_with("mitsuba "))
        .ok_or_else(|| anyhow!("Mitsuba benchmark printed no result: {}", String::from_utf8_lossy(&out.stderr)))?;
    line.split_whitespace()
        .find_map(|kv| kv.strip_prefix("seconds="))
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| anyhow!("cannot parse Mitsuba's timing line: {line}"))
}

pub fn run(a: &BenchArgs) -> Result<()> {
    let pool = crate::thread_pool(a.threads)?;
    if a.suite == "all" || a.suite == "scenes" {
        scenes(a, &pool)?;
    }
    if a.suite == "all" || a.suite == "rays" {
        rays::table(&pool, a.triangles.unwrap_or(1_000_000), a.rays);
    }
    if a.suite == "all" || a.suite == "efficiency" {
        let py = mitsuba_python(a);
        if let Err(e) = efficiency::table(py.as_deref(), &a.mitsuba_variant, a.budget, pool.current_num_threads()) {
            println!("equal-time error: skipped ({e:#})");
        }
    }
    if a.suite == "packets" {
        packets::table(&pool)?;
    }
    if a.suite == "soak" {
        let scene = a.scenes.first().cloned().unwrap_or_else(|| PathBuf::from("scenes/cornell-box.xml"));
        soak::run(&scene, a.soak_minutes, pool.current_num_threads())?;
    }
    if a.suite == "scale" {
        scale::run(a.triangles.unwrap_or(10_000_000), pool.current_num_threads())?;
    }
    Ok(())
}

fn scenes(a: &BenchArgs, pool: &rayon::ThreadPool) -> Result<()> {
    let scenes: Vec<(PathBuf, Vec<(String, String)>)> = if a.scenes.is_empty() {
        DEFAULT_SCENES
            .iter()
            .map(|(p, d)| (PathBuf::from(p), d.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect()))
            .collect()
    } else {
        a.scenes.iter().map(|p| (p.clone(), Vec::new())).collect()
    };
    let threads = pool.current_num_threads();
    let mitsuba = mitsuba_python(a);
    println!(
        "{:<20} {:>9} {:>5} {:>9} {:>10} {:>9} {:>10} {:>9} {:>8} {:>8} {:>8}",
        "scene",
        "size",
        "spp",
        "process s",
        "Msamples/s",
        "one-path s",
        "stream gain",
        "mitsuba s",
        "speedup",
        "trace s",
        "embree s"
    );
    let mut embree_skipped = None;
    for (scene, defines) in &scenes {
        let ov = Overrides { spp: a.spp, ..Default::default() };
        let job = penumbra_scene::load_scene(scene, defines, &ov).map_err(|e| anyhow!(e))?;
        let spp = job.sampler.spp;
        // Alternating rounds: the stream integrator's whole process, the
        // one-path loop's whole process, Mitsuba's warm render.
        let (mut ours, mut one_path, mut mi, mut ratio, mut gain) = (vec![], vec![], vec![], vec![], vec![]);
        for _ in 0..a.rounds.max(1) {
            let t = time_process(scene, defines, spp, threads, false)?;
            let t1 = time_process(scene, defines, spp, threads, true)?;
            ours.push(t);
            one_path.push(t1);
            gain.push(t1 / t);
            if let Some(py) = &mitsuba {
                match time_mitsuba(py, &a.mitsuba_variant, scene, defines, spp, threads) {
                    Ok(m) => {
                        mi.push(m);
                        ratio.push(m / t);
                    }
                    Err(e) => eprintln!("note: Mitsuba timing skipped: {e}"),
                }
            }
        }
        let fmt = |v: &mut Vec<f64>, unit: &str| {
            if v.is_empty() {
                "-".to_string()
            } else {
                format!("{:.2}{unit}", median(v))
            }
        };
        // Fewer recorded samples on large films: the log holds 32 bytes a ray.
        let pixels = job.width as u64 * job.height as u64;
        let trace_spp = (TRACE_SAMPLES / pixels.max(1)).clamp(1, TRACE_SPP as u64) as u32;
        let trace = trace_only::measure(&job, pool, trace_spp);
        match &trace.embree_s {
            Err(e) => embree_skipped = Some(e.clone()),
            Ok(_) => eprintln!(
                "note: {}: {:.1} M rays at {} spp; of those recorded, closest hits / blocked shadow rays {:?} (penumbra) vs {:?} (embree)",
                scene.display(),
                trace.rays / 1e6,
                spp,
                trace.counts[0],
                trace.counts[1]
            ),
        }
        let t = median(&mut ours);
        println!(
            "{:<20} {:>9} {:>5} {:>9.2} {:>10.3} {:>9} {:>10} {:>9} {:>8} {:>8.2} {:>8}",
            scene.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            format!("{}x{}", job.width, job.height),
            spp,
            t,
            (pixels * spp as u64) as f64 / t / 1e6,
            fmt(&mut one_path, ""),
            fmt(&mut gain, "x"),
            fmt(&mut mi, ""),
            fmt(&mut ratio, "x"),
            trace.penumbra_s,
            trace.embree_s.map(|s| format!("{s:.2}")).unwrap_or_else(|_| "-".into())
        );
    }
    if mitsuba.is_none() {
        println!("(Mitsuba 3 not found: pass --mitsuba PYTHON or set PENUMBRA_MITSUBA_PYTHON to compare)");
    }
    println!(
        "threads: {threads}; medians of {} alternating rounds; process s: `penumbra render` start to exit (stream \
         integrator), one-path s: the same with --no-stream; stream gain and speedup (Mitsuba's warm render / \
         process s, {}) are medians of per-round ratios",
        a.rounds.max(1),
        a.mitsuba_variant
    );
    if let Some(e) = embree_skipped {
        println!("(embree trace-only column: {e})");
    }
    println!(
        "trace s / embree s: the render's own rays (recorded at up to {TRACE_SPP} spp, scaled) traced alone, without shading, by Penumbra's BVH / by Embree"
    );
    if a.scenes.is_empty() {
        light_selection_table(pool)?;
    }
    Ok(())
}

/// The median of `v` (sorted in place); the mean of the middle two for an even count.
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Wall seconds of a whole `penumbra render` process (this executable) on
/// `scene`, start to exit; `one_path` adds --no-stream.
fn time_process(scene: &Path, defines: &[(String, String)], spp: u32, threads: usize, one_path: bool) -> Result<f64> {
    let exe = std::env::current_exe()?;
    let out = std::env::temp_dir().join(format!("penumbra-bench-{}.exr", std::process::id()));
    let mut cmd = Command::new(exe);
    cmd.arg("render").arg(scene).arg("-o").arg(&out).arg("--quiet");
    cmd.args(["--spp", &spp.to_string(), "--threads", &threads.to_string()]);
    for (k, v) in defines {
        cmd.arg("-D").arg(format!("{k}={v}"));
    }
    if one_path {
        cmd.arg("--no-stream");
    }
    let t0 = std::time::Instant::now();
    let o = cmd.output()?;
    let secs = t0.elapsed().as_secs_f64();
    let _ = std::fs::remove_file(&out);
    if !o.status.success() {
        return Err(anyhow!("penumbra render {} failed: {}", scene.display(), String::from_utf8_lossy(&o.stderr)));
    }
    Ok(secs)
}

/// Each light-selection strategy on the many-lights scene: time and error
/// against the converged reference. For unbiased estimators relMSE falls as
/// 1/time, so relMSE x seconds is the error at equal time (lower is better).
fn light_selection_table(pool: &rayon::ThreadPool) -> Result<()> {
    let reference = penumbra_scene::image_io::read_exr(Path::new(SELECTION_REF)).map_err(|e| anyhow!(e))?;
    println!("\nlight selection on {SELECTION_SCENE} (64x64, vs {SELECTION_REF}):");
    println!(
        "{:<10} {:>10} {:>6} {:>9} {:>12} {:>16}",
        "strategy", "candidates", "spp", "time s", "relMSE", "relMSE x time"
    );
    for (strategy, candidates) in ["uniform", "power", "bvh"].into_iter().flat_map(|s| [(s, 1), (s, 4), (s, 8)]) {
        let ov = Overrides {
            spp: Some(SELECTION_SPP),
            integrator: Some(format!("path:light_selection={strategy},light_candidates={candidates}")),
            ..Default::default()
        };
        let job = match penumbra_scene::load_scene(Path::new(SELECTION_SCENE), &[], &ov) {
            Ok(j) => j,
            Err(e) => {
                println!("{strategy:<10} skipped: {e}");
                continue;
            }
        };
        let (film, _, elapsed) = crate::render_job(&job, pool, true);
        let img = penumbra_scene::image_io::RgbImage { width: job.width, height: job.height, pixels: film.develop() };
        let rel = crate::imgtool::diff(&img, &reference)?.rel_mse;
        let secs = elapsed.as_secs_f64();
        println!(
            "{strategy:<10} {candidates:>10} {:>6} {secs:>9.3} {rel:>12.4e} {:>16.4e}",
            job.sampler.spp,
            rel * secs
        );
    }
    Ok(())
}
