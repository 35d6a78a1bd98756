//! `penumbra bench`: renders the bundled scenes and prints samples/s and
//! rays/s; with Mitsuba 3 available, times it on the same scene file and
//! prints the ratio.

use crate::args::BenchArgs;
use anyhow::{anyhow, Result};
use penumbra_scene::Overrides;
use std::path::{Path, PathBuf};
use std::process::Command;

const DEFAULT_SCENES: &[&str] = &["scenes/cornell-box.xml"];

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
fn time_mitsuba(python: &Path, variant: &str, scene: &Path, spp: u32, threads: usize) -> Result<f64> {
    let out = Command::new(python)
        .args(["tools/mitsuba_bench.py", "--variant", variant, "--spp", &spp.to_string()])
        .arg("--threads")
        .arg(threads.to_string())
        .arg(scene)
        .output()
        .map_err(|e| anyhow!("cannot run {}: {e}", python.display()))?;
    let text = String::from_utf8_lossy(&out.stdout);
    // The last machine-readable line is the warm (second) render.
    let line = text
        .lines()
        .filter(|l| l.starts_with("mitsuba "))
        .last()
        .ok_or_else(|| anyhow!("Mitsuba benchmark printed no result: {}", String::from_utf8_lossy(&out.stderr)))?;
    line.split_whitespace()
        .find_map(|kv| kv.strip_prefix("seconds="))
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| anyhow!("cannot parse Mitsuba's timing line: {line}"))
}

pub fn run(a: &BenchArgs) -> Result<()> {
    let scenes: Vec<PathBuf> =
        if a.scenes.is_empty() { DEFAULT_SCENES.iter().map(PathBuf::from).collect() } else { a.scenes.clone() };
    let pool = crate::thread_pool(a.threads)?;
    let threads = pool.current_num_threads();
    let mitsuba = mitsuba_python(a);
    println!(
        "{:<28} {:>9} {:>6} {:>9} {:>11} {:>10} {:>11} {:>8}",
        "scene", "size", "spp", "time s", "Msamples/s", "Mrays/s", "mitsuba s", "speedup"
    );
    for scene in &scenes {
        let job = penumbra_scene::load_scene(scene, &[], &Overrides { spp: a.spp, ..Default::default() })
            .map_err(|e| anyhow!(e))?;
        // One untimed warm-up pass at 1 spp (page faults, thread start-up).
        let mut warm = job.clone();
        warm.sampler.spp = 1;
        crate::render_job(&warm, &pool, true);
        let (_, stats, elapsed) = crate::render_job(&job, &pool, true);
        let secs = elapsed.as_secs_f64();
        let rays = (stats.rays.rays + stats.rays.shadow_rays) as f64;
        let (mi, ratio) = match &mitsuba {
            Some(py) => match time_mitsuba(py, &a.mitsuba_variant, scene, job.sampler.spp, threads) {
                Ok(t) => (format!("{t:.2}"), format!("{:.2}x", t / secs)),
                Err(e) => {
                    eprintln!("note: Mitsuba timing skipped: {e}");
                    ("-".into(), "-".into())
                }
            },
            None => ("-".into(), "-".into()),
        };
        println!(
            "{:<28} {:>9} {:>6} {:>9.2} {:>11.3} {:>10.2} {:>11} {:>8}",
            scene.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            format!("{}x{}", job.width, job.height),
            job.sampler.spp,
            secs,
            stats.samples as f64 / secs / 1e6,
            rays / secs / 1e6,
            mi,
            ratio
        );
    }
    if mitsuba.is_none() {
        println!("(Mitsuba 3 not found: pass --mitsuba PYTHON or set PENUMBRA_MITSUBA_PYTHON to compare)");
    }
    println!("threads: {threads}; speedup = Mitsuba seconds / Penumbra seconds at equal spp ({})", a.mitsuba_variant);
    Ok(())
}
