//! `penumbra bench --suite soak`: a long render with checkpoints, killed at
//! random moments (SIGKILL, SIGTERM, SIGINT, some during a checkpoint
//! write) and resumed until it completes; its image must be bitwise the
//! uninterrupted render's. Not part of the tests (it runs for minutes);
//! `crates/cli/tests/production.rs` is its short version.

use crate::exrmeta;
use anyhow::{anyhow, bail, Context, Result};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// SplitMix64: the kill moments and signals, reproducible from the seed.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn render(scene: &Path, out: &Path, spp: u32, threads: usize, extra: &[&str]) -> Command {
    let exe = std::env::current_exe().expect("the running executable");
    let mut c = Command::new(exe);
    c.arg("render").arg(scene).arg("-o").arg(out).arg("--quiet");
    c.args(["--spp", &spp.to_string(), "--seed", "7", "--threads", &threads.to_string(), "--max-pass-spp", "4"]);
    c.args(extra);
    c
}

fn run_ok(mut c: Command) -> Result<()> {
    let o = c.output().context("cannot start penumbra render")?;
    if !o.status.success() {
        bail!("penumbra render failed: {}", String::from_utf8_lossy(&o.stderr));
    }
    Ok(())
}

fn bits(p: &Path) -> Result<Vec<u32>> {
    Ok(exrmeta::read(p)?.rgb.iter().flatten().map(|v| v.to_bits()).collect())
}

/// Soaks `scene` for about `minutes` of rendering with `threads` threads.
pub fn run(scene: &Path, minutes: f64, threads: usize) -> Result<()> {
    let dir: PathBuf = std::env::temp_dir().join(format!("penumbra-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    // The sample count that makes the uninterrupted render last about
    // `minutes`, from a short timing render.
    let probe = dir.join("probe.exr");
    let t = Instant::now();
    run_ok(render(scene, &probe, 8, threads, &[]))?;
    let per_spp = t.elapsed().as_secs_f64() / 8.0;
    let spp = ((minutes * 60.0 / per_spp) as u32).clamp(8, 1 << 20);
    println!("soak: {} at {spp} spp ({:.3} s per sample per pixel), {threads} threads", scene.display(), per_spp);
    let reference = dir.join("reference.exr");
    let t = Instant::now();
    run_ok(render(scene, &reference, spp, threads, &[]))?;
    let t_ref = t.elapsed().as_secs_f64();
    println!("soak: uninterrupted render {t_ref:.1} s");

    let (out, ck) = (dir.join("out.exr"), dir.join("soak.ck"));
    let ck_s = ck.to_str().ok_or_else(|| anyhow!("temporary path is not UTF-8"))?;
    let extra = ["--checkpoint", ck_s, "--checkpoint-every", "0.5"];
    let mut rng = Rng(0x50a4);
    let (mut kills, mut resumes, mut mid_write, mut runs) = (0u32, 0u32, 0u32, 0u32);
    let (mut by_signal, start) = ([0u32; 3], Instant::now());
    loop {
        runs += 1;
        let mut child = render(scene, &out, spp, threads, &extra).stderr(Stdio::piped()).spawn()?;
        // Runs of 0.3-8 s: short ones test kills at start-up and in the
        // first checkpoint write, long ones make progress.
        let wait = Duration::from_secs_f64(0.3 + 7.7 * rng.next() * rng.next());
        let t0 = Instant::now();
        let mut done = None;
        while t0.elapsed() < wait {
            if let Some(s) = child.try_wait()? {
                done = Some(s);
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        if done.is_none() {
            let which = (rng.next() * 3.0) as usize;
            let sig = [libc::SIGKILL, libc::SIGTERM, libc::SIGINT][which];
            // SAFETY: kill(2) on our own child's pid.
            unsafe { libc::kill(child.id() as i32, sig) };
            by_signal[which] += 1;
        }
        let o = child.wait_with_output()?;
        let err = String::from_utf8_lossy(&o.stderr);
        resumes += err.contains("resuming from") as u32;
        let tmp = dir.join("soak.ck.tmp");
        if tmp.exists() {
            mid_write += 1;
        }
        if done.is_some() {
            if !o.status.success() {
                bail!("run {runs} failed: {err}");
            }
            if !err.contains("interrupted") {
                break;
            }
        } else {
            kills += 1;
            if o.status.success() && !err.contains("interrupted") {
                break; // it completed just as it was signalled
            }
        }
        if runs > 100_000 {
            bail!("no completion after {runs} runs");
        }
    }
    let total = start.elapsed().as_secs_f64();
    let same = bits(&out)? == bits(&reference)?;
    println!(
        "soak: {kills} kills survived (SIGKILL {}, SIGTERM {}, SIGINT {}), {mid_write} with a temporary checkpoint \
         left (killed mid-write), {resumes} resumes, {runs} runs, {total:.1} s in all against {t_ref:.1} s \
         uninterrupted: image {}",
        by_signal[0],
        by_signal[1],
        by_signal[2],
        if same { "bitwise equal" } else { "DIFFERENT" }
    );
    std::fs::remove_dir_all(&dir).ok();
    if !same {
        bail!("the resumed image differs from the uninterrupted render");
    }
    Ok(())
}
