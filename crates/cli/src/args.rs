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
#[allow(clippy::large_enum_variant)] // parsed once per run; boxing buys nothing
pub enum Command {
    /// Render a Mitsuba 3 XML, pbrt-v4 (.pbrt, .pbrt.gz) or glTF 2.0 (.gltf, .glb) scene to an image (.exr, .png, .pfm or .hdr).
    Render(RenderArgs),
    /// Describe a scene without rendering: plugins by kind, triangles,
    /// emitters, resolution, samples, integrator and approximated features.
    Info(InfoArgs),
    /// Time the bundled scenes: samples/s and rays/s (and Mitsuba 3, if installed).
    Bench(BenchArgs),
    /// Merge the EXRs of `render --part I/N` and/or `--crop` into one image:
    /// the image one machine would render with all samples (up to float rounding).
    Merge(MergeArgs),
    /// Denoise an EXR rendered with `--aov albedo,normal` (Intel Open Image
    /// Denoise; needs a build with `--features denoise`).
    Denoise(DenoiseArgs),
    /// Compare an image with a reference: per-channel means, MSE and relMSE
    /// (mean of (a-b)²/(b²+0.01), B the reference), optionally a false-colour error image.
    Diff(DiffArgs),
}

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scene file (Mitsuba 3 XML, pbrt-v4: .pbrt, .pbrt.gz, or glTF 2.0: .gltf, .glb).
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
    /// Add an environment map (.exr, .hdr, .png, .jpg; latitude-longitude,
    /// +y up, as Mitsuba's `envmap`) to the scene's lights; for a glTF scene
    /// it replaces the white environment given to scenes without lights.
    #[arg(long, value_name = "FILE")]
    pub envmap: Option<PathBuf>,
    /// Define a scene parameter, as Mitsuba's -D: fills $name.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub define: Vec<(String, String)>,
    /// Replace the scene's integrator: NAME[:key=value,...], e.g.
    /// `bruteforce:sampling=cosine` or `path:mis=false,light_selection=power`.
    /// max_depth, rr_depth and hide_emitters carry over unless given.
    #[arg(long, value_name = "NAME[:key=value,...]")]
    pub integrator: Option<String>,
    /// Replace the scene's sampler type, keeping its sample count and seed:
    /// a Mitsuba sampler (independent, stratified, multijitter, orthogonal,
    /// ldsampler) or `sobol`, Owen-scrambled Sobol' (Burley 2020), which
    /// stratifies at any sample count and so suits --time and progressive renders.
    #[arg(long, value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(penumbra_scene::builder::SAMPLER_OVERRIDES))]
    pub sampler: Option<String>,
    /// Never show the progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Time budget in seconds: stop after the last pass that fits (estimated
    /// from the previous pass). The spp target (--spp or the scene's
    /// sample_count) still applies: whichever comes first. The output's
    /// metadata records the spp reached. With --checkpoint, each run gets
    /// this budget anew.
    #[arg(long, value_name = "SECONDS")]
    pub time: Option<f64>,
    /// Rewrite the output image every SECONDS (atomically: temporary file,
    /// then rename) so a viewer can watch the render progress.
    #[arg(long, value_name = "SECONDS")]
    pub write_partial_images: Option<f64>,
    /// Save the render's state to FILE every --checkpoint-every seconds and on
    /// SIGINT/SIGTERM; running the same command again resumes from it, and
    /// gives an image bitwise identical to an uninterrupted render. A checkpoint
    /// of another scene, other settings or another version is refused. The
    /// checkpoint is deleted once the render is complete and its image written
    /// (unless --keep-checkpoint); a render stopped by --time keeps it.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints.
    #[arg(long, value_name = "SECONDS", default_value_t = 300.0)]
    pub checkpoint_every: f64,
    /// Ignore (and replace) an existing checkpoint: start over.
    #[arg(long)]
    pub fresh: bool,
    /// The memory the render may take: the scene as loaded (meshes,
    /// textures, acceleration structures) and the film (its sums, the image
    /// and the checkpoint's encoding), as bytes or with K, M, G or T: 512M,
    /// 8G. A render predicted to need more is refused before its film is
    /// allocated. Default: the film may take the memory the system reports
    /// as available.
    #[arg(long, value_name = "SIZE", value_parser = crate::memory::parse_size)]
    pub max_memory: Option<u64>,
    /// Keep the checkpoint after the render completes.
    #[arg(long)]
    pub keep_checkpoint: bool,
    /// Render part I (0-based) of N: sample indices [I·spp/N, (I+1)·spp/N) of
    /// every pixel; `penumbra merge` adds the parts into the full render.
    /// `auto` takes I and N from a Slurm job array (SLURM_ARRAY_TASK_ID and
    /// SLURM_ARRAY_TASK_COUNT; the array must be numbered 0..N-1), `auto/N`
    /// also from a Kubernetes Indexed Job (JOB_COMPLETION_INDEX). Part EXRs
    /// carry the weight sums as channel `penumbra.weight`.
    #[arg(long, value_name = "I/N|auto|auto/N")]
    pub part: Option<String>,
    /// Render only the window x0 <= x < x1, y0 <= y < y1 of the full frame
    /// (overrides the scene's crop); `penumbra merge` assembles crops.
    #[arg(long, value_name = "x0,y0,x1,y1", value_parser = parse_crop)]
    pub crop: Option<[u32; 4]>,
    /// Most samples per pixel in one pass (passes have 1, 1, 2, 4, ... samples
    /// up to this). Part of the render's identity: it sets the order in which
    /// samples are summed.
    #[arg(long, value_name = "N", default_value_t = crate::driver::DEFAULT_MAX_PASS_SPP)]
    pub max_pass_spp: u32,
    /// Show the image in a window, refreshed after every pass (sRGB, clamped).
    /// Without a display the render goes on without it.
    /// PENUMBRA_PREVIEW_HOLD=SECONDS keeps the window open after the last pass.
    #[arg(long)]
    pub preview: bool,
    /// Stream the image (and its AOVs as layers) to a running tev image
    /// viewer after every pass, e.g. localhost:14158 (tev's default port).
    /// If tev cannot be reached, or goes away, the render goes on without it.
    #[arg(long, value_name = "HOST:PORT", value_parser = crate::tev::parse_address)]
    pub display_server: Option<String>,
    /// Render `path` one path at a time instead of as a stream of paths
    /// traced in packets (the same image, bit for bit; for comparison).
    #[arg(long)]
    pub no_stream: bool,
    /// Extra EXR layers beside the beauty image, comma-separated: albedo,
    /// normal (taken through specular surfaces), depth, position (of the
    /// first hit), variance (of each pixel's mean).
    #[arg(long, value_name = "LIST")]
    pub aov: Option<String>,
    /// Stop once the image's estimated relMSE (against the converged image,
    /// from per-pixel variances) is at most X, checked after each pass once
    /// every pixel has 16 samples; the spp target still caps the render.
    #[arg(long, value_name = "X")]
    pub noise_threshold: Option<f64>,
    /// With --noise-threshold: after 16 spp, passes render only the pixels
    /// (and their neighbours) whose estimated error is still above X.
    #[arg(long, requires = "noise_threshold")]
    pub adaptive: bool,
    /// Denoise the result with Intel Open Image Denoise (albedo and normal
    /// guides); the noisy image is kept as layer `noisy`. Needs a build with
    /// `--features denoise`.
    #[arg(long)]
    pub denoise: bool,
}

#[derive(Debug, Args)]
pub struct DenoiseArgs {
    /// EXR with the beauty image and, ideally, albedo and normal layers.
    pub input: PathBuf,
    /// The denoised EXR (the input's beauty kept as layer `noisy`).
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(Debug, Args)]
pub struct MergeArgs {
    /// EXRs written by `penumbra render --part I/N` and/or `--crop`.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// The merged EXR.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Merge the parts that exist when some are missing (the metadata records
    /// the spp reached); pixels of missing crops stay black.
    #[arg(long)]
    pub allow_missing: bool,
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
    /// built with `--features embree`), `efficiency` (relMSE after equal
    /// render time, against Mitsuba 3), `all` (these three), or `scale`
    /// (build and render a mesh of `--triangles` triangles, default 10
    /// million, and report peak memory), or `packets` (the Cornell box's and
    /// envmap_sun's recorded rays traced one at a time against packets of 8
    /// and 16), or `soak` (a render of the first given scene, default the
    /// Cornell box, sized to last --soak-minutes, killed at random and
    /// resumed until it completes; its image must be bitwise the
    /// uninterrupted render's).
    #[arg(long, default_value = "all", value_parser = ["all", "scenes", "rays", "efficiency", "scale", "packets", "soak"])]
    pub suite: String,
    /// Minutes of rendering in the `soak` suite (the uninterrupted render's length).
    #[arg(long, default_value_t = 10.0)]
    pub soak_minutes: f64,
    /// Render seconds per renderer and scene in the `efficiency` suite.
    #[arg(long, default_value_t = 4.0)]
    pub budget: f64,
    /// Alternating rounds per scene in the scenes table (medians reported).
    #[arg(long, default_value_t = 3)]
    pub rounds: u32,
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
    /// Fail (exit status 1) if the largest relative difference |a-b|/|b| over
    /// all pixels and channels is above this (e.g. 1e-6 for a merge).
    #[arg(long, value_name = "X")]
    pub max_rel: Option<f64>,
}

fn parse_crop(s: &str) -> Result<[u32; 4], String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|t| t.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not of the form x0,y0,x1,y1 (pixels, non-negative integers)"))?;
    match v[..] {
        [x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Ok([x0, y0, x1, y1]),
        [_, _, _, _] => Err(format!("crop '{s}' is empty: it needs x0 < x1 and y0 < y1")),
        _ => Err(format!("'{s}' is not of the form x0,y0,x1,y1")),
    }
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("'{s}' is not of the form NAME=VALUE")),
    }
}
