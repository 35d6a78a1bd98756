//! The `penumbra` application: everything the command line and the Python
//! package share above the scene and render crates. A render session's pass
//! loop (`driver`), checkpoints, the render's identity (`settings`), EXR
//! files with metadata (`exrmeta`), film layers as channels (`layers`),
//! `--part` and `merge`; the binary (`main.rs`) only parses the command line
//! and dispatches.

pub mod adaptive;
pub mod args;
pub mod bench;
pub mod checkpoint;
pub mod denoise;
pub mod driver;
pub mod exrmeta;
pub mod fuzzing;
pub mod imgtool;
pub mod info;
pub mod layers;
pub mod memory;
pub mod merge;
pub mod part;
pub mod preview;
pub mod progress;
pub mod render_cmd;
pub mod settings;
pub mod signals;
pub mod tev;

use anyhow::{anyhow, Context, Result};
use penumbra_render::film::Film;
use penumbra_render::render::{RenderJob, RenderStats};
use std::time::{Duration, Instant};

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
