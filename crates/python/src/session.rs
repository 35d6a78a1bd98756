//! `render`: the command line's pass loop (`penumbra::driver::run`, the same
//! fixed schedule of passes, so the image is bitwise the command line's)
//! on a thread of its own while the calling thread, with the GIL released
//! between polls, watches for Ctrl-C and reports progress. A signal sets the
//! loop's cancel flag: the pass under way stops at its next tile, every
//! worker thread is joined before `render` returns, and the
//! KeyboardInterrupt is raised (after saving the checkpoint, if one was
//! asked for).

use crate::scene::Scene;
use crate::{anyhow_error, error, load_error};
use numpy::{PyArray1, PyArrayMethods};
use penumbra::checkpoint::Checkpoint;
use penumbra::driver::{self, Budget, Hooks, Schedule, State, Stop, DEFAULT_MAX_PASS_SPP};
use penumbra::settings::{RenderIdentity, Settings, VERSION};
use penumbra::tev::Display;
use penumbra_render::film::{AovKind, Film};
use penumbra_scene::Overrides;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

/// How often the calling thread takes the GIL to check for signals and
/// report progress.
const POLL: Duration = Duration::from_millis(50);

/// A flat image as a numpy float32 array of shape (height, width, channels).
fn array<'py>(py: Python<'py>, v: Vec<f32>, h: u32, w: u32, c: usize) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, v).reshape([h as usize, w as usize, c])?.into_any())
}

/// Renders `scene`; returns `{"image": (h, w, 3) float32, <aov>: ...}`.
/// `progress(done, total)` is called with sample counts (in pixels × spp)
/// from the calling thread; `checkpoint` names a file to resume from when
/// it matches this render, saved when the render is interrupted and
/// deleted once it completes (as the command line's `--checkpoint`);
/// `display_server` (`HOST:PORT`) streams every pass to tev (as
/// `--display-server`).
#[pyfunction]
#[pyo3(signature = (scene, spp=None, seed=0, threads=None, integrator=None, aovs=Vec::new(), progress=None, checkpoint=None, max_pass_spp=DEFAULT_MAX_PASS_SPP, display_server=None))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    scene: &mut Scene,
    spp: Option<u32>,
    seed: u64,
    threads: Option<usize>,
    integrator: Option<String>,
    aovs: Vec<String>,
    progress: Option<Bound<'py, PyAny>>,
    checkpoint: Option<PathBuf>,
    max_pass_spp: u32,
    display_server: Option<String>,
) -> PyResult<Bound<'py, PyDict>> {
    if let Some(a) = &display_server {
        penumbra::tev::parse_address(a).map_err(|e| error(format!("display_server: {e}")))?;
    }
    let ov = Overrides { spp, seed: Some(seed), integrator: integrator.clone(), sampler: None, envmap: None };
    let job = scene.job(&ov).map_err(|e| load_error(py, &e))?;
    let mut layers = penumbra::layers::parse(&aovs.join(",")).map_err(anyhow_error)?;
    // The integrator's own output channels (`aov`, `moment`), as the command line's EXR layers.
    layers.channels = job.integrator.channel_names();
    if matches!(job.integrator, penumbra_render::integrator::Integrator::PTracer(_)) && !aovs.is_empty() {
        return Err(error("ptracer: aovs need per-pixel samples, which a particle tracer's splats are not"));
    }
    let pool = penumbra::thread_pool(threads).map_err(anyhow_error)?;
    let schedule = Schedule::new(0..job.sampler.spp, max_pass_spp.max(1), job.guide_training_spp());
    let bytes = scene.source_bytes();
    let mut settings = Settings::new(&RenderIdentity {
        scene_bytes: &bytes,
        spp: job.sampler.spp,
        seed: job.sampler.seed,
        integrator: integrator.as_deref(),
        defines: scene.defines(),
        full_size: job.full_size,
        crop: None,
        part: None,
        max_pass_spp: schedule.max_pass_spp,
    });
    if !aovs.is_empty() {
        settings.set("aov", &penumbra::layers::describe(&layers));
    }
    let params = scene.overrides_text();
    if !params.is_empty() {
        settings.set("params", &params);
    }
    let mut state = State {
        film: Film::with_layers(job.width, job.height, &layers),
        passes: 0,
        spp: 0,
        seconds: 0.0,
        guide: job.new_guide(),
    };
    if let Some(path) = &checkpoint {
        if let Some(mut c) = Checkpoint::load_matching(path, &settings).map_err(anyhow_error)? {
            if c.film.layers() != layers || (c.film.width, c.film.height) != (job.width, job.height) {
                return Err(error(format!("checkpoint '{}' holds other layers or another size", path.display())));
            }
            let guide = c
                .resume_guide(state.guide.take())
                .map_err(|e| error(format!("checkpoint '{}': {e}; delete it to start over", path.display())))?;
            state = State { film: c.film, passes: c.passes, spp: c.spp, seconds: c.seconds, guide };
        }
    }
    let save = |st: &State| -> anyhow::Result<()> {
        let Some(path) = &checkpoint else { return Ok(()) };
        let ck = Checkpoint {
            version: VERSION.to_string(),
            settings: settings.clone(),
            seed: job.sampler.seed,
            passes: st.passes,
            spp: st.spp,
            seconds: st.seconds,
            film: st.film.clone(),
            guide: st.guide.clone(),
        };
        ck.save(path)
    };

    let cancel = AtomicBool::new(false);
    let done = AtomicU64::new(state.spp as u64 * job.width as u64 * job.height as u64);
    let total = schedule.spp() as u64 * job.width as u64 * job.height as u64;
    let on_samples = |k: u64| {
        done.fetch_add(k, Ordering::Relaxed);
    };
    let opts = driver::Options {
        schedule,
        budget: Budget::default(),
        cancel: &cancel,
        quiet: true,
        on_samples: Some(&on_samples),
    };
    let mut raised: Option<PyErr> = None;
    let report = |raised: &mut Option<PyErr>| {
        if let Some(f) = progress.as_ref().filter(|_| raised.is_none()) {
            if let Err(e) = f.call1((done.load(Ordering::Relaxed), total)) {
                cancel.store(true, Ordering::Relaxed);
                *raised = Some(e);
            }
        }
    };
    let finished = (Mutex::new(false), Condvar::new());
    let outcome = std::thread::scope(|s| {
        let worker = s.spawn(|| {
            let mut none = |_: &State| Ok(());
            let mut none2 = |_: &State| Ok(());
            let mut display = display_server.as_deref().map(|a| Display::connect(a, "penumbra"));
            let streaming = display.is_some();
            let mut show = |st: &State| {
                if let Some(d) = display.as_mut() {
                    d.show(&st.film);
                }
            };
            if state.spp > 0 {
                show(&state); // resumed
            }
            let after_pass: Option<&mut dyn FnMut(&State)> = streaming.then_some(&mut show);
            let hooks = Hooks { checkpoint: &mut none, partial: &mut none2, after_pass };
            let r = driver::run(&job, &pool, &opts, &mut state, hooks);
            *finished.0.lock().unwrap_or_else(|e| e.into_inner()) = true;
            finished.1.notify_all();
            (r, state)
        });
        // Woken by the worker's message or every POLL: no busy waiting.
        let wait = || {
            let done = finished.0.lock().unwrap_or_else(|e| e.into_inner());
            let (done, _) = finished.1.wait_timeout_while(done, POLL, |d| !*d).unwrap_or_else(|e| e.into_inner());
            !*done
        };
        while py.detach(wait) {
            if raised.is_none() {
                if let Err(e) = py.check_signals() {
                    cancel.store(true, Ordering::Relaxed);
                    raised = Some(e);
                }
            }
            report(&mut raised);
        }
        worker.join()
    });
    let (result, state) = outcome.map_err(|_| error("the render thread panicked"))?;
    drop(pool); // its threads exit before we return
    let outcome = result.map_err(anyhow_error)?;
    match outcome.stop {
        Stop::Complete | Stop::NoiseReached => {
            report(&mut raised);
            if let Some(p) = &checkpoint {
                let _ = std::fs::remove_file(p);
            }
        }
        Stop::Cancelled | Stop::TimeUp => {
            if state.spp > 0 {
                save(&state).map_err(anyhow_error)?;
            }
        }
    }
    if let Some(e) = raised {
        return Err(e);
    }
    let film = &state.film;
    let (w, h) = (film.width, film.height);
    let out = PyDict::new(py);
    let rgb: Vec<f32> = film.develop().into_iter().flatten().collect();
    out.set_item("image", array(py, rgb, h, w, 3)?)?;
    for &k in &film.aov_kinds {
        let v = film.develop_aov(k).expect("layer");
        out.set_item(k.name(), array(py, v, h, w, AovKind::channels(k).len())?)?;
    }
    if let Some(v) = film.develop_variance() {
        out.set_item(penumbra::layers::VARIANCE, array(py, v.into_iter().flatten().collect(), h, w, 3)?)?;
    }
    // Integrator channels "name.C": one array per name, channels in the integrator's order.
    let mut groups: Vec<(&str, Vec<usize>)> = Vec::new();
    for (c, name) in film.channels.iter().enumerate() {
        let layer = name.rsplit_once('.').map_or(name.as_str(), |(l, _)| l);
        match groups.iter_mut().find(|(l, _)| *l == layer) {
            Some((_, list)) => list.push(c),
            None => groups.push((layer, vec![c])),
        }
    }
    for (layer, list) in groups {
        let planes: Vec<Vec<f32>> = list.iter().map(|&c| film.develop_channel(c)).collect();
        let n = (w * h) as usize;
        let v: Vec<f32> = (0..n).flat_map(|i| planes.iter().map(move |p| p[i])).collect();
        out.set_item(layer, array(py, v, h, w, list.len())?)?;
    }
    Ok(out)
}
