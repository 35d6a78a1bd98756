//! The pass loop: a render proceeds in passes over the whole image, each
//! adding a range of sample indices to every pixel. The [`Schedule`] of
//! ranges is fixed (1, 1, 2, 4, 8, ... samples, at most `max_pass_spp` per pass), and
//! the film only ever receives whole passes in that order, so the image after
//! k passes is bitwise the same however often the render was stopped and
//! resumed. Between passes the loop checks the time budget, and writes
//! checkpoints and partial images when they are due; a signal cancels the
//! current pass (it is discarded) at the next tile.

use crate::progress::Progress;
use anyhow::Result;
use penumbra_render::film::Film;
use penumbra_render::guiding::Guide;
use penumbra_render::render::{RenderJob, RenderStats};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

pub const DEFAULT_MAX_PASS_SPP: u32 = 16;

/// The fixed schedule of a render's passes: the sample indices `samples`,
/// added in passes of 1, 1, 2, 4, 8, ... samples, at most `max_pass_spp`
/// each (0 counts as 1), except those that start within the first
/// `uncapped` samples: a guide's training passes keep doubling, so that
/// each learns from as many samples as all before it (Müller et al. 2017).
///
/// A part of a guided render (`--part`) first renders the guide's training
/// passes over samples [0, `prelude`), as the whole render would: every
/// part trains the same guide, and only the part with `keep_prelude` keeps
/// those samples in its image. Its own share of the rest follows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schedule {
    pub samples: Range<u32>,
    pub max_pass_spp: u32,
    pub uncapped: u32,
    pub prelude: u32,
    pub keep_prelude: bool,
}

impl Schedule {
    /// The schedule of `samples`, without a prelude.
    pub fn new(samples: Range<u32>, max_pass_spp: u32, uncapped: u32) -> Schedule {
        Schedule { samples, max_pass_spp, uncapped, prelude: 0, keep_prelude: true }
    }

    /// Where the training passes of a whole render of `spp` samples whose
    /// first `uncapped` train a guide end: the end of the last pass that
    /// starts below `uncapped`.
    pub fn training_end(spp: u32, uncapped: u32) -> u32 {
        let whole = Schedule::new(0..spp, 1, uncapped);
        (0..).map_while(|p| whole.pass(p)).take_while(|r| r.start < uncapped).last().map_or(0, |r| r.end)
    }

    /// Part `index` of `count` of a guided render of `spp` samples whose
    /// first `uncapped` train the guide: the training passes as a prelude
    /// (kept by part 0), then the part's share of the samples after them.
    pub fn guided_part(spp: u32, uncapped: u32, max_pass_spp: u32, part: crate::part::Part) -> Schedule {
        let t = Schedule::training_end(spp, uncapped);
        let share = part.samples(spp - t);
        Schedule {
            samples: t + share.start..t + share.end,
            max_pass_spp,
            uncapped: 0,
            prelude: t,
            keep_prelude: part.index == 0,
        }
    }

    /// Passes of the prelude.
    fn prelude_passes(&self) -> u32 {
        let prelude = Schedule::new(0..self.prelude, 1, self.prelude);
        (0..).map_while(|p| prelude.pass_in(p)).count() as u32
    }

    /// Whether pass `pass` is one of the prelude's (a guide's training pass
    /// of a part).
    pub fn in_prelude(&self, pass: u32) -> bool {
        pass < self.prelude_passes()
    }

    /// The sample indices of pass `pass`, or `None` once all are done.
    pub fn pass(&self, pass: u32) -> Option<Range<u32>> {
        if self.prelude == 0 {
            return self.pass_in(pass);
        }
        let n = self.prelude_passes();
        if pass < n {
            return Schedule::new(0..self.prelude, 1, self.prelude).pass_in(pass);
        }
        Schedule::new(self.samples.clone(), self.max_pass_spp, 0).pass_in(pass - n)
    }

    /// [`Self::pass`] without a prelude.
    fn pass_in(&self, pass: u32) -> Option<Range<u32>> {
        let cap = self.max_pass_spp.max(1) as u64;
        let first = self.samples.start as u64;
        let size = |p: u32, start: u64| {
            let doubled = if p == 0 { 1 } else { 1u64.checked_shl(p - 1).unwrap_or(u64::MAX) };
            if start - first < self.uncapped as u64 {
                doubled
            } else {
                doubled.min(cap)
            }
        };
        let mut start = first;
        for p in 0..pass {
            start = start.saturating_add(size(p, start));
            if start >= self.samples.end as u64 {
                return None;
            }
        }
        let end = start.saturating_add(size(pass, start)).min(self.samples.end as u64);
        (start < end).then_some(start as u32..end as u32)
    }

    /// Samples per pixel in the image once every pass is done.
    pub fn spp(&self) -> u32 {
        self.samples.end - self.samples.start + if self.keep_prelude { self.prelude } else { 0 }
    }
}

/// The state a render can be resumed from.
#[derive(Debug, Clone)]
pub struct State {
    pub film: Film,
    /// Whole passes added to the film.
    pub passes: u32,
    /// Samples per pixel in the film.
    pub spp: u32,
    /// Render time so far, over all runs (seconds).
    pub seconds: f64,
    /// The path guide learnt so far (`None` without guiding).
    pub guide: Option<Guide>,
}

/// Why the loop stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// Every sample was rendered.
    Complete,
    /// The next pass would not fit the time budget.
    TimeUp,
    /// `cancel` was set (a signal): the pass under way was discarded.
    Cancelled,
    /// The estimated relative error fell below `--noise-threshold`.
    NoiseReached,
}

/// Time limits, in seconds.
#[derive(Debug, Clone, Copy, Default)]
pub struct Budget {
    /// Stop after the last pass that fits (this run's wall time).
    pub time: Option<f64>,
    pub checkpoint_every: Option<f64>,
    pub partial_every: Option<f64>,
    /// Stop once the film's estimated relMSE is at most this (needs a film
    /// with variance moments); see [`crate::adaptive`].
    pub noise_threshold: Option<f64>,
    /// With `noise_threshold`: later passes render only the pixels above it.
    pub adaptive: bool,
}

/// What the loop did besides rendering.
#[derive(Debug, Clone, Copy, Default)]
pub struct Extras {
    pub checkpoints: u32,
    pub checkpoint_seconds: f64,
    pub partials: u32,
    pub partial_seconds: f64,
}

/// Called between passes when due.
pub struct Hooks<'a> {
    pub checkpoint: &'a mut dyn FnMut(&State) -> Result<()>,
    pub partial: &'a mut dyn FnMut(&State) -> Result<()>,
    /// After every pass, the last one included (the `--preview` window, tev).
    pub after_pass: Option<&'a mut dyn FnMut(&State)>,
}

/// How a run proceeds: its passes, when it stops early, how it reports.
pub struct Options<'a> {
    pub schedule: Schedule,
    pub budget: Budget,
    /// Set by a signal: the pass under way is discarded and the loop stops.
    pub cancel: &'a AtomicBool,
    /// No progress bar.
    pub quiet: bool,
    /// Also told of the samples of every tile as they are added (Python's
    /// progress bar): called from the worker threads.
    pub on_samples: Option<&'a (dyn Fn(u64) + Sync)>,
}

/// How a run ended.
#[derive(Debug, Clone, Copy)]
pub struct Outcome {
    pub stop: Stop,
    /// This run's passes only.
    pub stats: RenderStats,
    pub extras: Extras,
}

/// Renders the passes of `opts.schedule` that `state` lacks, until done,
/// out of time or cancelled.
pub fn run(
    job: &RenderJob,
    pool: &rayon::ThreadPool,
    opts: &Options,
    state: &mut State,
    mut hooks: Hooks,
) -> Result<Outcome> {
    let (budget, cancel) = (&opts.budget, opts.cancel);
    // Under a time budget a guide's training may end early (below).
    let mut schedule = opts.schedule.clone();
    let pixels = job.width as u64 * job.height as u64;
    let left = schedule.spp().saturating_sub(state.spp) as u64;
    let progress = Progress::new(left * pixels, opts.quiet);
    let start = Instant::now();
    let base_seconds = state.seconds;
    let (mut last_checkpoint, mut last_partial) = (start, start);
    // Seconds per sample per pixel, from the previous pass; every run
    // renders at least one pass, so that it makes progress.
    let mut per_spp: Option<f64> = None;
    let tick = |k: u64| {
        progress.inc(k);
        if let Some(f) = opts.on_samples {
            f(k);
        }
    };
    let mut stats = RenderStats::default();
    let mut extras = Extras::default();
    let stop = loop {
        let Some(mut range) = schedule.pass(state.passes) else {
            break Stop::Complete;
        };
        let mut active = None;
        if let Some(x) = budget.noise_threshold {
            if crate::adaptive::reached(&state.film, state.spp, x) {
                break Stop::NoiseReached;
            }
            if budget.adaptive {
                active = crate::adaptive::active_pixels(&state.film, state.spp, x);
            }
        }
        if let (Some(limit), Some(per)) = (budget.time, per_spp) {
            let ends_at = |r: &Range<u32>| start.elapsed().as_secs_f64() + per * (r.end - r.start) as f64;
            // A guide trains for its budget's share of the time: once the
            // next (doubled) training pass would end later, training stops
            // and the time left goes to guided passes of the usual size.
            if state.spp < schedule.uncapped && ends_at(&range) > job.guide_training_share() * limit {
                schedule.uncapped = state.spp;
                match schedule.pass(state.passes) {
                    Some(r) => range = r,
                    None => break Stop::Complete,
                }
            }
            if ends_at(&range) > limit {
                break Stop::TimeUp;
            }
        }
        if cancel.load(Ordering::Relaxed) {
            break Stop::Cancelled;
        }
        let t0 = Instant::now();
        let n = range.end - range.start;
        let active = active.as_deref();
        let prelude = schedule.in_prelude(state.passes);
        let train =
            if schedule.prelude > 0 { prelude } else { job.trains_guide(state.spp) && state.spp < schedule.uncapped };
        let guide = state.guide.as_mut().map(|g| (g, train));
        // A prelude this part does not keep trains the guide on a film thrown away.
        let mut scratch = (prelude && !schedule.keep_prelude)
            .then(|| Film::with_layers(state.film.width, state.film.height, &state.film.layers()));
        let film = scratch.as_mut().unwrap_or(&mut state.film);
        let r = pool.install(|| job.render_pass_guided(film, range, active, guide, &tick, cancel));
        let Some(s) = r else {
            break Stop::Cancelled;
        };
        stats.add(&s);
        state.passes += 1;
        if scratch.is_none() {
            state.spp += n;
        }
        state.seconds = base_seconds + start.elapsed().as_secs_f64();
        per_spp = Some(t0.elapsed().as_secs_f64() / n as f64);
        if let Some(f) = hooks.after_pass.as_mut() {
            f(state);
        }
        if schedule.pass(state.passes).is_none()
            || budget.noise_threshold.is_some_and(|x| crate::adaptive::reached(&state.film, state.spp, x))
        {
            continue; // Complete: the caller writes the final image.
        }
        if budget.checkpoint_every.is_some_and(|e| last_checkpoint.elapsed().as_secs_f64() >= e) {
            let t = Instant::now();
            (hooks.checkpoint)(state)?;
            last_checkpoint = Instant::now();
            extras.checkpoints += 1;
            extras.checkpoint_seconds += (last_checkpoint - t).as_secs_f64();
        }
        if budget.partial_every.is_some_and(|e| last_partial.elapsed().as_secs_f64() >= e) {
            let t = Instant::now();
            (hooks.partial)(state)?;
            last_partial = Instant::now();
            extras.partials += 1;
            extras.partial_seconds += (last_partial - t).as_secs_f64();
        }
    };
    progress.finish();
    Ok(Outcome { stop, stats, extras })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedule_doubles_up_to_the_cap_and_covers_the_range() {
        let schedule = Schedule::new(3..40, 8, 0);
        let passes: Vec<Range<u32>> = (0..).map_while(|p| schedule.pass(p)).collect();
        let sizes: Vec<u32> = passes.iter().map(|p| p.end - p.start).collect();
        assert_eq!(sizes, [1, 1, 2, 4, 8, 8, 8, 5]);
        assert_eq!(passes[0].start, 3);
        for w in passes.windows(2) {
            assert_eq!(w[0].end, w[1].start);
        }
        assert_eq!(passes.last().unwrap().end, 40);
        assert_eq!(schedule.spp(), 37);
        assert_eq!(Schedule::new(0..1, 16, 0).pass(1), None);
        assert_eq!(Schedule::new(0..0, 16, 0).pass(0), None);
        // A cap of 0 counts as 1.
        let sizes: Vec<u32> = (0..).map_while(|p| Schedule::new(0..4, 0, 0).pass(p)).map(|r| r.len() as u32).collect();
        assert_eq!(sizes, [1, 1, 1, 1]);
    }

    #[test]
    fn training_passes_keep_doubling_past_the_cap() {
        let schedule = Schedule::new(0..200, 8, 50);
        let sizes: Vec<u32> = (0..).map_while(|p| schedule.pass(p)).map(|r| r.len() as u32).collect();
        // Passes starting below 50 double (the last one starts at 32); then 8 at a time.
        let mut expected = vec![1, 1, 2, 4, 8, 16, 32];
        expected.extend([8; 17]);
        assert_eq!(sizes, expected);
    }

    /// Parts of a guided render each run the whole render's training passes
    /// first, then their own share of the samples after those.
    #[test]
    fn guided_parts_share_the_training_passes() {
        // 6 of 40 samples train: the passes starting below 6 end at 8.
        assert_eq!(Schedule::training_end(40, 6), 8);
        assert_eq!(Schedule::training_end(40, 0), 0);
        let whole = Schedule::new(0..40, 4, 6);
        let training: Vec<Range<u32>> = (0..).map_while(|p| whole.pass(p)).take_while(|r| r.start < 6).collect();
        let mut shares = Vec::new();
        for i in 0..3 {
            let s = Schedule::guided_part(40, 6, 4, crate::part::Part { index: i, count: 3 });
            let passes: Vec<Range<u32>> = (0..).map_while(|p| s.pass(p)).collect();
            assert_eq!(passes[..training.len()], training[..], "part {i}");
            assert!((0..passes.len() as u32).all(|p| s.in_prelude(p) == (p < training.len() as u32)));
            shares.extend(passes[training.len()..].iter().cloned());
            assert_eq!(s.spp(), s.samples.len() as u32 + if i == 0 { 8 } else { 0 });
        }
        // The shares tile [8, 40) in order.
        assert_eq!(shares.first().unwrap().start, 8);
        assert_eq!(shares.last().unwrap().end, 40);
        assert!(shares.windows(2).all(|w| w[0].end == w[1].start));
    }
}
