//! Command-line interface definition.

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(name = "penumbra", version, about = "Penumbra: a physically based path tracer for Mitsuba 3 scenes")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a Mitsuba 3 XML scene to an image (.exr, .png, .pfm or .hdr).
    Render(RenderArgs),
    /// Describe a scene without rendering: plugins by kind, triangles,
    /// emitters, resolution, samples, integrator and approximated features.
    Info(InfoArgs),
    /// Time the bundled scenes: samples/s and rays/s (and Mitsuba 3, if installed).
    Bench(BenchArgs),
    /// Compare an image with a reference: per-channel means, MSE and relMSE
    /// (mean of (a-b)²/(b²+0.01), B the reference), optionally a false-colour error image.
    Diff(DiffArgs),
}

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scene file (Mitsuba 3 XML).
    pub scene: PathBuf,
    /// Output image; the extension selects the format.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel (overrides the scene's sample_count).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the random sequences (overrides the sampler's seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Define a scene parameter, as Mitsuba's -D: fills $name.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub define: Vec<(String, String)>,
    /// Replace the scene's integrator: NAME[:key=value,...], e.g.
    /// `bruteforce:sampling=cosine` or `path:mis=false,light_selection=power`.
    /// max_depth, rr_depth and hide_emitters carry over unless given.
    #[arg(long, value_name = "NAME[:key=value,...]")]
    pub integrator: Option<String>,
    /// Never show the progress bar.
    #[arg(long)]
    pub quiet: bool,
}

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The scene file (Mitsuba 3 XML).
    pub scene: PathBuf,
    /// Define a scene parameter, as Mitsuba's -D: fills $name.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub define: Vec<(String, String)>,
}

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Samples per pixel for each scene (default: the scene's own).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Scenes to time (default: the bundled scenes/cornell-box.xml).
    pub scenes: Vec<PathBuf>,
    /// Python interpreter with the `mitsuba` package, to time Mitsuba 3 on the
    /// same scenes (default: $PENUMBRA_MITSUBA_PYTHON, else .venv-mitsuba/bin/python if present).
    #[arg(long)]
    pub mitsuba: Option<PathBuf>,
    /// Mitsuba variant for the comparison.
    #[arg(long, default_value = "llvm_ad_rgb")]
    pub mitsuba_variant: String,
    /// What to time: `scenes` (render the standard scenes), `rays` (BVH build
    /// and incoherent-ray throughput on a procedural mesh, with Embree when
    /// built with `--features embree`), `all` (both), or `scale` (build and
    /// render a mesh of `--triangles` triangles, default 10 million, and
    /// report peak memory).
    #[arg(long, default_value = "all", value_parser = ["all", "scenes", "rays", "scale"])]
    pub suite: String,
    /// Triangles of the procedural mesh (default: 1 million for `rays`, 10 million for `scale`).
    #[arg(long)]
    pub triangles: Option<usize>,
    /// Rays of each kind in the `rays` suite.
    #[arg(long, default_value_t = 2_000_000)]
    pub rays: usize,
}

#[derive(Debug, Args)]
pub struct DiffArgs {
    /// The image to measure (.exr, .hdr, .png or .jpg).
    pub a: PathBuf,
    /// The reference image, same size.
    pub b: PathBuf,
    /// Write a false-colour image of the per-pixel relMSE (log scale) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("'{s}' is not of the form NAME=VALUE")),
    }
}
