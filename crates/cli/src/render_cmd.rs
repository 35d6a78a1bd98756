//! `penumbra render`: loads the scene, applies --crop and --part, resumes
//! from a checkpoint, runs the pass loop (driver.rs) and writes the image
//! with its metadata.

use crate::args::RenderArgs;
use crate::checkpoint::Checkpoint;
use crate::driver::{self, Budget, Hooks, Outcome, Schedule, State, Stop};
use crate::exrmeta::{self, ExrImage};
use crate::part::{self, Part};
use crate::settings::{RenderIdentity, Settings, VERSION};
use crate::signals::Signals;
use anyhow::{anyhow, bail, Context, Result};
use penumbra_render::film::{Film, FilmLayers, Filter, FilterKind};
use penumbra_render::render::RenderJob;
use penumbra_scene::image_io::{self, Format, RgbImage};
use penumbra_scene::Overrides;
use std::collections::BTreeMap;
use std::ops::Range;
use std::path::Path;
use std::process::ExitCode;

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

/// What the output image's metadata says besides the settings.
struct Output<'a> {
    job: &'a RenderJob,
    settings: &'a Settings,
    part: Option<Part>,
    samples: Range<u32>,
    command: String,
    /// Denoise the final image (--denoise).
    denoise: bool,
}

impl Output<'_> {
    fn write(&self, path: &Path, state: &State, complete: bool) -> Result<()> {
        let pixels = state.film.develop();
        let is_exr = Format::from_path(path).map_err(|e| anyhow!(e))? == Format::Exr;
        if !(is_exr || (self.denoise && complete)) {
            let img = RgbImage { width: state.film.width, height: state.film.height, pixels };
            return image_io::write_image(path, &img).map_err(|e| anyhow!(e));
        }
        let job = self.job;
        let s = self.settings;
        let mut meta = BTreeMap::new();
        let mut put = |k: &str, v: String| {
            meta.insert(k.to_string(), v);
        };
        put("spp", state.spp.to_string());
        put("sppTarget", (self.samples.end - self.samples.start).to_string());
        put("samples", format!("{}..{}", self.samples.start, self.samples.start + state.spp));
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
        if self.denoise && complete {
            crate::denoise::denoise_image(&mut img)?;
        }
        if !is_exr {
            let img = RgbImage { width: img.width, height: img.height, pixels: img.rgb };
            return image_io::write_image(path, &img).map_err(|e| anyhow!(e));
        }
        exrmeta::write(path, &img)
    }
}

pub fn run(a: &RenderArgs) -> Result<ExitCode> {
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
    let ov = Overrides { spp: a.spp, seed: a.seed, integrator: a.integrator.clone(), sampler: a.sampler.clone() };
    let mut job = penumbra_scene::load_scene(&a.scene, &a.define, &ov).map_err(|e| anyhow!(e))?;
    if let Some(c) = a.crop {
        apply_crop(&mut job, c)?;
    }
    if a.denoise {
        // A wide filter's splats make neighbouring pixels' noise correlated,
        // which the denoiser keeps as detail (measured: a 16 spp Cornell box
        // with the Gaussian went from relMSE 0.065 to only 0.062). Denoised
        // renders use the box filter: independent noise per pixel.
        job.filter = Filter::new(FilterKind::Box);
    }
    let crop = ((job.width, job.height) != job.full_size).then(|| {
        let (x, y) = job.crop_offset;
        [x, y, x + job.width, y + job.height]
    });
    let spp = job.sampler.spp;
    let samples = part.map_or(0..spp, |p| p.samples(spp));
    if samples.is_empty() {
        bail!("--part {}: with {spp} spp this part has no samples; use at most {spp} parts", part.unwrap());
    }
    let settings = Settings::new(&RenderIdentity {
        scene_bytes: &scene_bytes,
        spp,
        seed: job.sampler.seed,
        integrator: a.integrator.as_deref(),
        defines: &a.define,
        full_size: job.full_size,
        crop,
        part,
        max_pass_spp: a.max_pass_spp.max(1),
    });
    let mut settings = settings;
    // Only when used, so that other renders keep their identity.
    if layers != FilmLayers::default() {
        settings.set("aov", &crate::layers::describe(&layers));
    }
    if let Some(sampler) = &a.sampler {
        settings.set("sampler", sampler);
    }
    if a.denoise {
        settings.set("filter", "box (--denoise)");
    }
    if let Some(x) = a.noise_threshold {
        settings.set("noise_threshold", &x.to_string());
        settings.set("adaptive", &a.adaptive.to_string());
    }
    let settings = settings;
    let out = Output {
        job: &job,
        settings: &settings,
        part,
        samples: samples.clone(),
        command: command_line(),
        denoise: a.denoise,
    };

    let mut state = State { film: Film::with_layers(job.width, job.height, &layers), passes: 0, spp: 0, seconds: 0.0 };
    if let Some(ck) = &a.checkpoint {
        if a.fresh {
            let _ = std::fs::remove_file(ck);
        } else if let Some(c) = Checkpoint::load_matching(ck, &settings)? {
            eprintln!("resuming from '{}': {} passes, {} spp, {:.2} s", ck.display(), c.passes, c.spp, c.seconds);
            if c.film.layers() != layers || (c.film.width, c.film.height) != (job.width, job.height) {
                bail!("checkpoint '{}' holds other image layers or another size; use --fresh", ck.display());
            }
            state = State { film: c.film, passes: c.passes, spp: c.spp, seconds: c.seconds };
        }
    }
    let save_checkpoint = |st: &State| -> Result<()> {
        let Some(path) = &a.checkpoint else { return Ok(()) };
        let ck = Checkpoint {
            version: VERSION.to_string(),
            settings: settings.clone(),
            seed: job.sampler.seed,
            passes: st.passes,
            spp: st.spp,
            seconds: st.seconds,
            film: st.film.clone(),
        };
        ck.save(path)
    };

    let signals = Signals::install()?;
    let pool = crate::thread_pool(threads)?;
    let budget = Budget {
        time: a.time,
        checkpoint_every: a.checkpoint.as_ref().map(|_| a.checkpoint_every),
        partial_every: a.write_partial_images,
        noise_threshold: a.noise_threshold,
        adaptive: a.adaptive,
    };
    let mut ck_hook = |st: &State| save_checkpoint(st);
    let mut partial_hook = |st: &State| out.write(&a.output, st, false);
    let mut preview = a.preview.then(|| {
        let name = a.scene.file_name().map_or("scene".into(), |n| n.to_string_lossy().into_owned());
        crate::preview::Preview::open(&name, job.width, job.height)
    });
    let target = samples.end - samples.start;
    if let Some(p) = preview.as_mut().filter(|_| state.spp > 0) {
        p.show(&state.film.develop(), state.spp, target); // resumed
    }
    let mut preview_hook = |st: &State| {
        if let Some(p) = preview.as_mut() {
            p.show(&st.film.develop(), st.spp, target);
        }
    };
    let hooks = Hooks {
        checkpoint: &mut ck_hook,
        partial: &mut partial_hook,
        after_pass: if a.preview { Some(&mut preview_hook) } else { None },
    };
    let run_start = std::time::Instant::now();
    let seconds_before = state.seconds;
    let opts = driver::Options {
        schedule: Schedule { samples: samples.clone(), max_pass_spp: a.max_pass_spp.max(1) },
        budget,
        cancel: &signals.cancel,
        quiet: a.quiet,
    };
    let Outcome { stop, stats, extras } = driver::run(&job, &pool, &opts, &mut state, hooks)?;

    let complete = matches!(stop, Stop::Complete | Stop::NoiseReached);
    // Cancelled: resume from here; --time: the next run goes on from here;
    // complete: only if asked to keep it.
    if !complete || a.keep_checkpoint {
        save_checkpoint(&state)?;
    }
    if state.spp > 0 {
        out.write(&a.output, &state, complete)?;
    }
    if complete && !a.keep_checkpoint {
        if let Some(ck) = &a.checkpoint {
            let _ = std::fs::remove_file(ck);
        }
    }
    if let Some(p) = preview.as_mut() {
        p.hold(&signals.cancel);
    }
    let secs = run_start.elapsed().as_secs_f64().max(1e-9);
    let this_run = state.seconds - seconds_before;
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
        "{what} {} ({}x{}, {} spp{}) in {:.2} s (this run {:.2} s): {:.3} M samples/s, {:.2} M rays/s{}",
        a.output.display(),
        job.width,
        job.height,
        state.spp,
        part.map_or(String::new(), |p| format!(", part {p}")),
        state.seconds,
        this_run,
        stats.samples as f64 / secs / 1e6,
        rays as f64 / secs / 1e6,
        crate::peak_memory_mb().map(|m| format!(", peak memory {m:.0} MB")).unwrap_or_default()
    );
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
    Ok(match (stop, signals.received()) {
        (Stop::Cancelled, Some(sig)) => ExitCode::from((128 + sig) as u8),
        (Stop::Cancelled, None) => ExitCode::from(130),
        _ => ExitCode::SUCCESS,
    })
}
