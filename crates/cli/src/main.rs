//! The `penumbra` command: `render` a scene, describe it (`info`), `bench`
//! the bundled scenes, or `diff` an image against a reference.

mod adaptive;
mod args;
mod bench;
mod checkpoint;
mod denoise;
mod driver;
mod exrmeta;
mod imgtool;
mod info;
mod layers;
mod merge;
mod part;
mod preview;
mod progress;
mod render_cmd;
mod settings;
mod signals;

use anyhow::{anyhow, Context, Result};
use args::{Cli, Command};
use clap::Parser;
use penumbra_render::film::Film;
use penumbra_render::render::{RenderJob, RenderStats};
use std::process::ExitCode;
use std::time::{Duration, Instant};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render_cmd::run(&a),
        Command::Info(a) => info::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Bench(a) => bench::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Diff(a) => imgtool::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Merge(a) => merge::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Denoise(a) => denoise::run(&a).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
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
