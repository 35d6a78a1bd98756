//! The `penumbra` command: `render` a scene, describe it (`info`), `bench`
//! the bundled scenes, or `diff` an image against a reference.

mod args;
mod bench;
mod imgtool;
mod info;
mod progress;

use anyhow::{anyhow, Context, Result};
use args::{Cli, Command, RenderArgs};
use clap::Parser;
use penumbra_render::film::Film;
use penumbra_render::render::{RenderJob, RenderStats};
use penumbra_scene::image_io::{self, RgbImage};
use penumbra_scene::Overrides;
use std::process::ExitCode;
use std::time::{Duration, Instant};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render(&a),
        Command::Info(a) => info::run(&a),
        Command::Bench(a) => bench::run(&a),
        Command::Diff(a) => imgtool::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Builds the thread pool for `--threads` (default: all cores).
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        if n == 0 {
            return Err(anyhow!("--threads must be at least 1"));
        }
        b = b.num_threads(n);
    }
    b.build().context("cannot start the worker threads")
}

/// Renders all samples of a job; returns the film, stats and wall time.
pub fn render_job(job: &RenderJob, pool: &rayon::ThreadPool, quiet: bool) -> (Film, RenderStats, Duration) {
    let spp = job.sampler.spp;
    let progress = progress::Progress::new(spp as u64 * job.width as u64 * job.height as u64, quiet);
    let start = Instant::now();
    let mut film = Film::new(job.width, job.height);
    let stats = pool.install(|| job.render_into(&mut film, 0..spp, &|n| progress.inc(n)));
    progress.finish();
    (film, stats, start.elapsed())
}

/// The process's peak resident memory (Linux VmHWM), in MB.
pub fn peak_memory_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

fn render(a: &RenderArgs) -> Result<()> {
    // Check the output name before spending time on the render.
    image_io::Format::from_path(&a.output).map_err(|e| anyhow!(e))?;
    let ov = Overrides { spp: a.spp, seed: a.seed, integrator: a.integrator.clone() };
    let job = penumbra_scene::load_scene(&a.scene, &a.define, &ov).map_err(|e| anyhow!(e))?;
    let pool = thread_pool(a.threads)?;
    let (film, stats, elapsed) = render_job(&job, &pool, a.quiet);
    let img = RgbImage { width: job.width, height: job.height, pixels: film.develop() };
    image_io::write_image(&a.output, &img).map_err(|e| anyhow!(e))?;
    let secs = elapsed.as_secs_f64();
    let rays = stats.rays.rays + stats.rays.shadow_rays;
    eprintln!(
        "rendered {} ({}x{}, {} spp) in {:.2} s: {:.3} M samples/s, {:.2} M rays/s{}",
        a.output.display(),
        job.width,
        job.height,
        job.sampler.spp,
        secs,
        stats.samples as f64 / secs / 1e6,
        rays as f64 / secs / 1e6,
        peak_memory_mb().map(|m| format!(", peak memory {m:.0} MB")).unwrap_or_default()
    );
    if stats.non_finite > 0 {
        eprintln!("warning: {} samples were NaN or infinite and were dropped", stats.non_finite);
    }
    Ok(())
}
