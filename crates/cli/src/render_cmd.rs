//! `penumbra render`, in four steps: `plan` checks the arguments, loads
//! the scene and applies --crop and --part (everything decided before the
//! first pass); `resume` opens the checkpoint or starts an empty film;
//! `run_passes` drives the pass loop (driver.rs) with its checkpoint,
//! partial-image, preview and tev hooks; `report` writes the image with its
//! metadata, settles the checkpoint, prints the summary and picks the exit
//! code.

use crate::args::RenderArgs;
use crate::checkpoint::Checkpoint;
use crate::driver::{self, Budget, Hooks, Outcome, Schedule, State, Stop};
use crate::exrmeta::{self, ExrImage};
use crate::part::{self, Part};
use crate::preview::Preview;
use crate::settings::{RenderIdentity, Settings, VERSION};
use crate::signals::Signals;
use crate::tev::Display;
use anyhow::{anyhow, bail, Context, Result};
use penumbra_render::film::{Film, FilmLayers, Filter, FilterKind};
use penumbra_render::render::RenderJob;
use penumbra_scene::image_io::{self, Format, RgbImage};
use penumbra_scene::Overrides;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

/// The command line as one string, arguments with spaces or quotes quoted.
pub fn command_line() -> String {
    std::env::args()
        .map(|a| {
            if !a.is_empty() && a.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c)) {
                a
            } else {
                format!("'{}'", a.replace('\'', "'\\''"))
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Restricts `job` to the window [x0, x1) × [y0, y1) of the full frame.
pub fn apply_crop(job: &mut RenderJob, c: [u32; 4]) -> Result<()> {
    let (fw, fh) = job.full_size;
    if c[2] > fw || c[3] > fh {
        bail!("--crop {},{},{},{} reaches outside the {fw}x{fh} image", c[0], c[1], c[2], c[3]);
    }
    job.crop_offset = (c[0], c[1]);
    job.width = c[2] - c[0];
    job.height = c[3] - c[1];
    Ok(())
}

/// Everything decided before the first pass.
struct Plan<'a> {
    args: &'a RenderArgs,
    /// The scene, cropped, with the box filter for --denoise.
    job: RenderJob,
    part: Option<Part>,
    threads: Option<usize>,
    layers: FilmLayers,
    /// This part's sample indices (all of them without --part) and the pass cap.
    schedule: Schedule,
    /// The render's identity, in checkpoints and the image's metadata.
    settings: Settings,
    /// The command line, for the image's metadata.
    command: String,
}

/// Checks the arguments, loads the scene and settles what the render is.
fn plan(a: &RenderArgs) -> Result<Plan<'_>> {
    // Check the output name before spending time on the render.
    Format::from_path(&a.output).map_err(|e| anyhow!(e))?;
    let env = |k: &str| std::env::var(k).ok();
    let part = a.part.as_deref().map(|s| part::parse(s, &env)).transpose()?;
    let threads = part::threads(a.threads, &env)?;
    for (name, v) in [("--time", a.time), ("--write-partial-images", a.write_partial_images)] {
        if v.is_some_and(|v| !(v >= 0.0 && v.is_finite())) {
            bail!("{name} needs a number of seconds >= 0");
        }
    }
    if !(a.checkpoint_every >= 0.0 && a.checkpoint_every.is_finite()) {
        bail!("--checkpoint-every needs a number of seconds >= 0");
    }
    let mut layers = film_layers(a)?;
    if a.part.is_some() {
        for (on, name, why) in [
            (a.noise_threshold.is_some(), "--noise-threshold", "each part would stop on its own noise"),
            (a.denoise, "--denoise", "denoise the merged image with `penumbra denoise`"),
        ] {
            if on {
                bail!("{name} cannot be combined with --part: {why}");
            }
        }
    }
    let scene_bytes = std::fs::read(&a.scene).with_context(|| format!("cannot read '{}'", a.scene.display()))?;
    let ov = Overrides {
        spp: a.spp,
        seed: a.seed,
        integrator: a.integrator.clone(),
        sampler: a.sampler.clone(),
        envmap: a.envmap.clone(),
    };
    let (mut job, notes) = penumbra_scene::load_scene_noted(&a.scene, &a.define, &ov).map_err(|e| anyhow!(e))?;
    for n in notes {
        eprintln!("note: {n}");
    }
    if let Some(c) = a.crop {
        apply_crop(&mut job, c)?;
    }
    job.stream = !a.no_stream;
    // The integrator's own output channels (`aov`, `moment`): EXR layers.
    layers.channels = job.integrator.channel_names();
    if matches!(job.integrator, penumbra_render::integrator::Integrator::PTracer(_))
        && (layers.variance || !layers.aovs.is_empty() || a.adaptive)
    {
        bail!(
            "ptracer: --aov, --noise-threshold, --adaptive and --denoise need per-pixel samples, \
             which a particle tracer's splats are not (as Mitsuba's ptracer, which refuses AOVs)"
        );
    }
    if !job.scene.media.is_empty() && !matches!(job.integrator, penumbra_render::integrator::Integrator::VolPath(_)) {
        eprintln!(
            "note: the scene's participating media are ignored by its integrator (as in Mitsuba); \
             render them with --integrator volpath"
        );
    }
    if a.denoise {
        // A wide filter's splats make neighbouring pixels' noise correlated,
        // which the denoiser keeps as detail (measured: a 16 spp Cornell box
        // with the Gaussian went from relMSE 0.065 to only 0.062). Denoised
        // renders use the box filter: independent noise per pixel.
        job.filter = Filter::new(FilterKind::Box);
    }
    let spp = job.sampler.spp;
    let (cap, uncapped) = (a.max_pass_spp.max(1), job.guide_training_spp());
    // With guiding, every part renders the training passes (see `Schedule`).
    let schedule = match part {
        Some(p) if job.new_guide().is_some() => Schedule::guided_part(spp, uncapped, cap, p),
        Some(p) => Schedule::new(p.samples(spp), cap, uncapped),
        None => Schedule::new(0..spp, cap, uncapped),
    };
    if schedule.spp() == 0 {
        bail!("--part {}: with {spp} spp this part has no samples; use at most {spp} parts", part.unwrap());
    }
    let settings = settings(a, &scene_bytes, &job, part, &layers);
    Ok(Plan { args: a, job, part, threads, layers, schedule, settings, command: command_line() })
}

/// The film's layers: --aov, plus variance for --noise-threshold and
/// albedo and normal for --denoise.
fn film_layers(a: &RenderArgs) -> Result<FilmLayers> {
    let mut layers = crate::layers::parse(a.aov.as_deref().unwrap_or(""))?;
    if a.aov.is_some() && Format::from_path(&a.output).map_err(|e| anyhow!(e))? != Format::Exr {
        bail!("--aov writes layers of a multi-layer EXR: name the output '*.exr', not '{}'", a.output.display());
    }
    if let Some(x) = a.noise_threshold {
        if !(x > 0.0 && x.is_finite()) {
            bail!("--noise-threshold needs a relative error > 0 (e.g. 0.01)");
        }
        layers.variance = true;
    }
    if a.denoise {
        if cfg!(not(feature = "denoise")) {
            bail!("--denoise: {}", crate::denoise::UNAVAILABLE);
        }
        let list = format!("{},albedo,normal", crate::layers::describe(&layers));
        layers = crate::layers::parse(&list)?;
    }
    Ok(layers)
}

/// The render's identity: what a checkpoint must match and the image records.
fn settings(a: &RenderArgs, scene_bytes: &[u8], job: &RenderJob, part: Option<Part>, layers: &FilmLayers) -> Settings {
    let crop = ((job.width, job.height) != job.full_size).then(|| {
        let (x, y) = job.crop_offset;
        [x, y, x + job.width, y + job.height]
    });
    let mut settings = Settings::new(&RenderIdentity {
        scene_bytes,
        spp: job.sampler.spp,
        seed: job.sampler.seed,
        integrator: a.integrator.as_deref(),
        defines: &a.define,
        full_size: job.full_size,
        crop,
        part,
        max_pass_spp: a.max_pass_spp.max(1),
    });
    // Only when used, so that other renders keep their identity.
    if *layers != FilmLayers::default() {
        settings.set("aov", &crate::layers::describe(layers));
    }
    if let Some(sampler) = &a.sampler {
        settings.set("sampler", sampler);
    }
    if let Some(env) = &a.envmap {
        // The file's name and contents (an unreadable file failed loading).
        let bytes = std::fs::read(env).unwrap_or_default();
        settings.set("envmap", &format!("{} crc32 {:08x}", env.display(), crc32fast::hash(&bytes)));
    }
    if a.denoise {
        settings.set("filter", "box (--denoise)");
    }
    if let Some(x) = a.noise_threshold {
        settings.set("noise_threshold", &x.to_string());
        settings.set("adaptive", &a.adaptive.to_string());
    }
    settings
}

impl Plan<'_> {
    /// Saves `st` to --checkpoint, if given.
    fn save_checkpoint(&self, st: &State) -> Result<()> {
        let Some(path) = &self.args.checkpoint else { return Ok(()) };
        let ck = Checkpoint {
            version: VERSION.to_string(),
            settings: self.settings.clone(),
            seed: self.job.sampler.seed,
            passes: st.passes,
            spp: st.spp,
            seconds: st.seconds,
            film: st.film.clone(),
            guide: st.guide.clone(),
        };
        ck.save(path)
    }

    /// Writes the image of `state` to `path`: EXR with the metadata
    /// (`penumbra:*`), AOV layers and, for parts, the weight channel; other
    /// formats as plain RGB. A complete render is denoised with --denoise.
    fn write_image(&self, path: &Path, state: &State, complete: bool) -> Result<()> {
        let denoise = self.args.denoise;
        let pixels = state.film.develop();
        let is_exr = Format::from_path(path).map_err(|e| anyhow!(e))? == Format::Exr;
        if !(is_exr || (denoise && complete)) {
            let img = RgbImage { width: state.film.width, height: state.film.height, pixels };
            return image_io::write_image(path, &img).map_err(|e| anyhow!(e));
        }
        let job = &self.job;
        let s = &self.settings;
        let samples = &self.schedule.samples;
        let mut meta = BTreeMap::new();
        let mut put = |k: &str, v: String| {
            meta.insert(k.to_string(), v);
        };
        put("spp", state.spp.to_string());
        put("sppTarget", self.schedule.spp().to_string());
        put("samples", format!("{}..{}", samples.start, samples.start + state.spp));
        put("complete", if complete { "yes" } else { "no" }.into());
        put("passes", state.passes.to_string());
        put("seed", job.sampler.seed.to_string());
        put("renderTime", format!("{:.3}", state.seconds));
        put("version", VERSION.to_string());
        put("commandLine", self.command.clone());
        put("settingsHash", s.hash());
        put("renderHash", s.render_hash());
        put("settings", s.to_text());
        put("part", self.part.map_or("whole".into(), |p| p.to_string()));
        put("crop", s.get("crop").unwrap_or("full").to_string());
        if let Some(p) = crate::info::path_summary(job) {
            put("path", p);
        }
        if let Some(e) = state.film.rel_error() {
            put("relErrorEstimate", format!("{e:.6e}"));
        }
        let weight = self.part.map(|_| state.film.acc.iter().map(|a| a[3] as f32).collect());
        let mut img = ExrImage {
            width: state.film.width,
            height: state.film.height,
            offset: job.crop_offset,
            full_size: job.full_size,
            rgb: pixels,
            weight,
            layers: crate::layers::channels(&state.film, self.part.is_some()),
            meta,
        };
        if denoise && complete {
            crate::denoise::denoise_image(&mut img)?;
        }
        if !is_exr {
            let img = RgbImage { width: img.width, height: img.height, pixels: img.rgb };
            return image_io::write_image(path, &img).map_err(|e| anyhow!(e));
        }
        exrmeta::write(path, &img)
    }
}

/// The state to go on from: the checkpoint's if it matches this render,
/// else an empty film (--fresh deletes the checkpoint first).
fn resume(plan: &Plan) -> Result<State> {
    let (a, job, layers) = (plan.args, &plan.job, &plan.layers);
    // A temporary file beside an output is what a run killed while writing
    // that output left behind: nothing else writes it.
    for path in std::iter::once(&a.output).chain(&a.checkpoint) {
        let tmp = penumbra_scene::atomic::temp_path(path);
        if tmp.is_file() && std::fs::remove_file(&tmp).is_ok() {
            eprintln!("removed '{}', left by a run killed while writing", tmp.display());
        }
    }
    let scene = crate::memory::resident().unwrap_or(0);
    crate::memory::check(job.width, job.height, layers, a.checkpoint.is_some(), a.max_memory, scene)?;
    let empty = State {
        film: Film::with_layers(job.width, job.height, layers),
        passes: 0,
        spp: 0,
        seconds: 0.0,
        guide: job.new_guide(),
    };
    let Some(ck) = &a.checkpoint else { return Ok(empty) };
    if a.fresh {
        let _ = std::fs::remove_file(ck);
        return Ok(empty);
    }
    let Some(c) = Checkpoint::load_matching(ck, &plan.settings)? else { return Ok(empty) };
    eprintln!("resuming from '{}': {} passes, {} spp, {:.2} s", ck.display(), c.passes, c.spp, c.seconds);
    if c.film.layers() != *layers || (c.film.width, c.film.height) != (job.width, job.height) {
        bail!("checkpoint '{}' holds other image layers or another size; use --fresh", ck.display());
    }
    let mut c = c;
    let guide =
        c.resume_guide(job.new_guide()).map_err(|e| anyhow!("checkpoint '{}': {e}; use --fresh", ck.display()))?;
    Ok(State { film: c.film, passes: c.passes, spp: c.spp, seconds: c.seconds, guide })
}

/// What the pass loop leaves for the report.
struct Run {
    outcome: Outcome,
    signals: Signals,
    preview: Option<Preview>,
    /// When the loop began, and the render time before it (from the checkpoint).
    start: Instant,
    seconds_before: f64,
}

/// Renders the passes `state` lacks, with checkpoints, partial images and
/// the preview window between them, until done, out of time or cancelled.
fn run_passes(plan: &Plan, state: &mut State) -> Result<Run> {
    let (a, job) = (plan.args, &plan.job);
    let signals = Signals::install()?;
    let pool = crate::thread_pool(plan.threads)?;
    let budget = Budget {
        time: a.time,
        checkpoint_every: a.checkpoint.as_ref().map(|_| a.checkpoint_every),
        partial_every: a.write_partial_images,
        noise_threshold: a.noise_threshold,
        adaptive: a.adaptive,
    };
    let mut ck_hook = |st: &State| plan.save_checkpoint(st);
    let mut partial_hook = |st: &State| plan.write_image(&a.output, st, false);
    let mut preview = a.preview.then(|| {
        let name = a.scene.file_name().map_or("scene".into(), |n| n.to_string_lossy().into_owned());
        Preview::open(&name, job.width, job.height)
    });
    let target = plan.schedule.spp();
    if let Some(p) = preview.as_mut().filter(|_| state.spp > 0) {
        p.show(&state.film.develop(), state.spp, target); // resumed
    }
    let mut display = a.display_server.as_deref().map(|addr| {
        let name = a.output.file_name().map_or("penumbra".into(), |n| n.to_string_lossy().into_owned());
        Display::connect(addr, &name)
    });
    if let Some(d) = display.as_mut().filter(|_| state.spp > 0) {
        d.show(&state.film); // resumed
    }
    let mut after_pass = |st: &State| {
        if let Some(p) = preview.as_mut() {
            p.show(&st.film.develop(), st.spp, target);
        }
        if let Some(d) = display.as_mut() {
            d.show(&st.film);
        }
    };
    let hooks = Hooks {
        checkpoint: &mut ck_hook,
        partial: &mut partial_hook,
        after_pass: if a.preview || a.display_server.is_some() { Some(&mut after_pass) } else { None },
    };
    let start = Instant::now();
    let seconds_before = state.seconds;
    let opts = driver::Options {
        schedule: plan.schedule.clone(),
        budget,
        cancel: &signals.cancel,
        quiet: a.quiet,
        on_samples: None,
    };
    let outcome = driver::run(job, &pool, &opts, state, hooks)?;
    Ok(Run { outcome, signals, preview, start, seconds_before })
}

/// Writes the image and settles the checkpoint, keeps the preview window
/// open if asked, prints the summary and returns the exit code: 128 + the
/// signal's number when one stopped the render.
fn report(plan: &Plan, state: &State, mut run: Run) -> Result<ExitCode> {
    let a = plan.args;
    let stop = run.outcome.stop;
    let complete = matches!(stop, Stop::Complete | Stop::NoiseReached);
    // Cancelled: resume from here; --time: the next run goes on from here;
    // complete: only if asked to keep it.
    if !complete || a.keep_checkpoint {
        plan.save_checkpoint(state)?;
    }
    if state.spp > 0 {
        plan.write_image(&a.output, state, complete)?;
    }
    if complete && !a.keep_checkpoint {
        if let Some(ck) = &a.checkpoint {
            let _ = std::fs::remove_file(ck);
        }
    }
    if let Some(p) = run.preview.as_mut() {
        p.hold(&run.signals.cancel);
    }
    print_summary(plan, state, &run, complete);
    Ok(match (stop, run.signals.received()) {
        (Stop::Cancelled, Some(sig)) => ExitCode::from((128 + sig) as u8),
        (Stop::Cancelled, None) => ExitCode::from(130),
        _ => ExitCode::SUCCESS,
    })
}

/// The lines on stderr after a render: what was rendered, how fast, the
/// time spent on checkpoints and partial images, warnings.
fn print_summary(plan: &Plan, state: &State, run: &Run, complete: bool) {
    let a = plan.args;
    let Outcome { stop, stats, extras } = run.outcome;
    let target = plan.schedule.spp();
    let secs = run.start.elapsed().as_secs_f64().max(1e-9);
    let this_run = state.seconds - run.seconds_before;
    let rays = stats.rays.rays + stats.rays.shadow_rays;
    let what = match stop {
        Stop::Complete => "rendered".to_string(),
        Stop::NoiseReached => format!(
            "noise threshold reached (estimated relMSE {:.3e}) at {} of {target} spp: rendered",
            state.film.rel_error().unwrap_or(f64::NAN),
            state.spp
        ),
        Stop::TimeUp => format!("time budget reached: rendered {} of {target} spp to", state.spp),
        Stop::Cancelled => format!("interrupted: wrote {} of {target} spp to", state.spp),
    };
    eprintln!(
        "{what} {} ({}x{}, {} spp{}) in {:.2} s (this run {:.2} s): {:.3} M samples/s, {:.2} M rays/s{}{}",
        a.output.display(),
        plan.job.width,
        plan.job.height,
        state.spp,
        plan.part.map_or(String::new(), |p| format!(", part {p}")),
        state.seconds,
        this_run,
        stats.samples as f64 / secs / 1e6,
        rays as f64 / secs / 1e6,
        // The stream integrator's packets: the share of their lanes that held a ray.
        match stats.rays.packet_lanes.checked_div(stats.rays.packets) {
            Some(width) => format!(
                " ({:.0} % of {width}-ray packet lanes used, {:.0} % of vertices shaded in lanes, {:.0} % of their lanes used)",
                100.0 * stats.rays.packet_rays as f64 / stats.rays.packet_lanes as f64,
                100.0 * stats.rays.lane_vertices as f64 / stats.rays.rays.max(1) as f64,
                100.0 * stats.rays.lane_vertices as f64 / stats.rays.vertex_lanes.max(1) as f64
            ),
            None => String::new(),
        },
        crate::peak_memory_mb().map(|m| format!(", peak memory {m:.0} MB")).unwrap_or_default()
    );
    if let Some(g) = &state.guide {
        let (leaves, nodes) = g.size();
        eprintln!(
            "path guide: {leaves} spatial leaves, {nodes} quadtree nodes, {} KiB; learnt from {} records in {:.3} s this run",
            g.memory() / 1024,
            stats.guide_records,
            stats.guide_seconds
        );
    }
    if extras.checkpoints > 0 {
        eprintln!(
            "{} checkpoints in {:.3} s ({:.2}% of this run)",
            extras.checkpoints,
            extras.checkpoint_seconds,
            100.0 * extras.checkpoint_seconds / this_run.max(1e-9)
        );
    }
    if extras.partials > 0 {
        eprintln!(
            "{} partial images in {:.3} s ({:.2}% of this run)",
            extras.partials,
            extras.partial_seconds,
            100.0 * extras.partial_seconds / this_run.max(1e-9)
        );
    }
    if state.spp == 0 {
        eprintln!("no pass was complete: no image written");
    }
    if stats.non_finite > 0 {
        eprintln!("warning: {} samples were NaN or infinite and were dropped", stats.non_finite);
    }
    if let Some(ck) = &a.checkpoint {
        if !complete {
            eprintln!("checkpoint: '{}' (run the same command again to go on)", ck.display());
        }
    }
}

pub fn run(a: &RenderArgs) -> Result<ExitCode> {
    let plan = plan(a)?;
    let mut state = resume(&plan)?;
    let run = run_passes(&plan, &mut state)?;
    report(&plan, &state, run)
}
