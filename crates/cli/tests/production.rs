//! Production rendering, end to end through the `penumbra` binary: kill and
//! resume at random moments (bitwise equality), refused checkpoints, time
//! budgets, partial images, signals, parts and crops merged into the single
//! render, and the metadata that `merge` relies on.

use crate::common;

use crate::common::{bin, ok, read_exr, Exr};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn scene() -> PathBuf {
    common::cornell()
}

fn tmpdir(name: &str) -> PathBuf {
    common::tmpdir("prod", name)
}

fn render_cmd(out: &Path, extra: &[&str]) -> Command {
    let mut c = bin();
    c.arg("render").arg(scene()).arg("-o").arg(out).arg("--quiet").args(extra);
    c
}

fn fails(o: Output) -> String {
    assert!(!o.status.success(), "should fail: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Bit patterns of R, G, B.
fn rgb_bits(e: &Exr) -> Vec<u32> {
    ["R", "G", "B"].iter().flat_map(|c| e.channels[*c].iter().map(|v| v.to_bits())).collect()
}

/// Largest |a-b|/|b| over R, G, B (pixels where b is 0 must be 0 in a).
fn max_rel_diff(a: &Exr, b: &Exr) -> f64 {
    let mut m: f64 = 0.0;
    for c in ["R", "G", "B"] {
        for (x, y) in a.channels[c].iter().zip(&b.channels[c]) {
            let d = (*x as f64 - *y as f64).abs();
            m = m.max(if *y == 0.0 { d * 1e30 } else { d / (*y as f64).abs() });
        }
    }
    m
}

/// A small deterministic generator for the kill moments (SplitMix64).
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

fn signal(pid: u32, sig: &str) {
    let _ = Command::new("kill").arg(format!("-{sig}")).arg(pid.to_string()).status();
}

const SMALL: [&str; 8] = ["-D", "res=40", "--spp", "96", "--seed", "11", "--max-pass-spp", "2"];

#[test]
fn killed_at_random_moments_and_resumed_gives_the_uninterrupted_image() {
    let d = tmpdir("kill");
    let reference = d.join("ref.exr");
    let t0 = Instant::now();
    ok(render_cmd(&reference, &SMALL).output().unwrap());
    let t_ref = t0.elapsed().as_secs_f64();
    let want = read_exr(&reference);

    let (out, ck) = (d.join("out.exr"), d.join("render.ck"));
    let ck_s = ck.to_str().unwrap();
    // --keep-checkpoint: a run that completes before its kill leaves a
    // complete checkpoint, and later runs (killed or not) resume from it.
    let args: Vec<&str> =
        [&SMALL[..], &["--checkpoint", ck_s, "--checkpoint-every", "0.01", "--keep-checkpoint"]].concat();
    let mut rng = Rng(2024);
    let (mut interrupted, mut resumes, mut mid_write) = (0, 0, 0);
    const KILLS: u32 = 24;
    for round in 0..=KILLS {
        let mut child = render_cmd(&out, &args).stderr(Stdio::piped()).spawn().unwrap();
        let last = round == KILLS;
        if !last {
            // Kill somewhere in the first 15% of a full render's time.
            std::thread::sleep(Duration::from_secs_f64(rng.next() * 0.15 * t_ref));
            match (rng.next() * 4.0) as u32 {
                0 => signal(child.id(), "TERM"),
                1 => signal(child.id(), "INT"),
                _ => child.kill().unwrap(), // SIGKILL
            }
        }
        let o = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        resumes += err.contains("resuming from") as u32;
        if o.status.success() && !err.contains("interrupted") {
            continue; // completed before the kill
        }
        assert!(!last, "the last run must complete: {err}");
        interrupted += 1;
        // A temporary checkpoint left behind: killed during a checkpoint write.
        let tmp = d.join("render.ck.tmp");
        if tmp.exists() {
            mid_write += 1;
            fs::remove_file(&tmp).unwrap();
        }
        // A handled signal exits 130 / 143; otherwise the signal killed it.
        assert!(matches!(o.status.code(), None | Some(130) | Some(143)), "{:?}: {err}", o.status);
    }
    eprintln!(
        "{interrupted} of {KILLS} runs interrupted ({mid_write} during a checkpoint write), {resumes} resumes, \
         reference render {t_ref:.2} s"
    );
    assert!(interrupted >= 8 && resumes >= 8, "too few interruptions to test anything");
    let got = read_exr(&out);
    assert_eq!(got.meta["spp"], "96");
    assert_eq!(got.meta["complete"], "yes");
    assert!(rgb_bits(&got) == rgb_bits(&want), "resumed image differs from the uninterrupted one");
    assert_eq!(got.meta["settingsHash"], want.meta["settingsHash"]);
    fs::remove_dir_all(&d).ok();
}

#[test]
fn time_budget_stops_after_a_pass_and_checkpoints_resume_it_pass_by_pass() {
    let d = tmpdir("time");
    let reference = d.join("ref.exr");
    let args = ["-D", "res=16", "--spp", "8", "--seed", "5"];
    ok(render_cmd(&reference, &args).output().unwrap());
    let (out, ck) = (d.join("out.exr"), d.join("t.ck"));
    // --time 0: every run renders one pass (1, 1, 2, 4 samples) and stops.
    let mut spp_seen = vec![];
    for _ in 0..4 {
        let o = ok(render_cmd(&out, &[&args[..], &["--time", "0", "--checkpoint", ck.to_str().unwrap()]].concat())
            .output()
            .unwrap());
        let e = read_exr(&out);
        spp_seen.push(e.meta["spp"].clone());
        if e.meta["complete"] == "no" {
            assert!(String::from_utf8_lossy(&o.stderr).contains("time budget reached"));
            assert!(ck.exists());
        }
    }
    assert_eq!(spp_seen, ["1", "2", "4", "8"]);
    assert_eq!(rgb_bits(&read_exr(&out)), rgb_bits(&read_exr(&reference)));
    assert!(!ck.exists());
    fs::remove_dir_all(&d).ok();
}

#[test]
fn a_checkpoint_of_another_render_is_refused_and_fresh_starts_over() {
    let d = tmpdir("refuse");
    let (out, ck) = (d.join("a.exr"), d.join("a.ck"));
    let ck_s = ck.to_str().unwrap();
    let base = ["-D", "res=16", "--spp", "4", "--checkpoint", ck_s];
    ok(render_cmd(&out, &[&base[..], &["--seed", "3", "--keep-checkpoint"]].concat()).output().unwrap());
    assert!(ck.exists());
    let first = read_exr(&out);
    // The same command finds a complete checkpoint and writes the same image.
    let o = ok(render_cmd(&out, &[&base[..], &["--seed", "3"]].concat()).output().unwrap());
    assert!(String::from_utf8_lossy(&o.stderr).contains("resuming from"));
    assert_eq!(rgb_bits(&read_exr(&out)), rgb_bits(&first));
    ok(render_cmd(&out, &[&base[..], &["--seed", "3", "--keep-checkpoint"]].concat()).output().unwrap());
    let e = fails(render_cmd(&out, &[&base[..], &["--seed", "4"]].concat()).output().unwrap());
    assert!(e.contains("belongs to another render") && e.contains("seed: 4 now, 3 in the checkpoint"), "{e}");
    let e =
        fails(render_cmd(&out, &["-D", "res=16", "--spp", "8", "--checkpoint", ck_s, "--seed", "3"]).output().unwrap());
    assert!(e.contains("spp: 8 now, 4 in the checkpoint"), "{e}");
    let e =
        fails(render_cmd(&out, &[&base[..], &["--seed", "3", "--integrator", "direct"]].concat()).output().unwrap());
    assert!(e.contains("integrator: direct now"), "{e}");
    // Another scene file (same settings): its contents hash differs.
    let other = d.join("scene.xml");
    fs::write(&other, fs::read_to_string(scene()).unwrap() + "\n<!-- edited -->\n").unwrap();
    let mut c = bin();
    c.arg("render").arg(&other).arg("-o").arg(&out).arg("--quiet").args(base).args(["--seed", "3"]);
    let e = fails(c.output().unwrap());
    assert!(e.contains("scene file contents"), "{e}");
    // A damaged checkpoint is refused too.
    let mut bytes = fs::read(&ck).unwrap();
    let n = bytes.len();
    bytes[n / 2] ^= 0x40;
    fs::write(&ck, &bytes).unwrap();
    let e = fails(render_cmd(&out, &[&base[..], &["--seed", "3"]].concat()).output().unwrap());
    assert!(e.contains("checksum") && e.contains("--fresh"), "{e}");
    // --fresh starts over.
    ok(render_cmd(&out, &[&base[..], &["--seed", "4", "--fresh"]].concat()).output().unwrap());
    assert_eq!(read_exr(&out).meta["seed"], "4");
    fs::remove_dir_all(&d).ok();
}

#[test]
fn sigint_writes_the_checkpoint_and_the_partial_image_and_exits_130() {
    let d = tmpdir("sigint");
    let (out, ck) = (d.join("s.exr"), d.join("s.ck"));
    let args = ["-D", "res=64", "--spp", "100000", "--max-pass-spp", "1", "--write-partial-images", "0"];
    let mut child = render_cmd(&out, &[&args[..], &["--checkpoint", ck.to_str().unwrap()]].concat()).spawn().unwrap();
    // The partial image shows that the handlers are installed and a pass is done.
    let start = Instant::now();
    while !out.exists() {
        assert!(start.elapsed() < Duration::from_secs(60));
        std::thread::sleep(Duration::from_millis(10));
    }
    signal(child.id(), "INT");
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    let e = read_exr(&out);
    assert_eq!(e.meta["complete"], "no");
    let spp: u32 = e.meta["spp"].parse().unwrap();
    assert!((1..100000).contains(&spp));
    assert!(ck.exists());
    fs::remove_dir_all(&d).ok();
}

#[test]
fn partial_images_are_always_whole_files() {
    let d = tmpdir("partial");
    let out = d.join("p.exr");
    let args = ["-D", "res=48", "--spp", "300", "--max-pass-spp", "2", "--write-partial-images", "0"];
    let mut child = render_cmd(&out, &args).spawn().unwrap();
    let mut seen = std::collections::BTreeSet::new();
    while child.try_wait().unwrap().is_none() {
        if out.exists() {
            // Every read must succeed: a file is replaced only by rename.
            seen.insert(read_exr(&out).meta["spp"].parse::<u32>().unwrap());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(child.wait().unwrap().success());
    assert_eq!(read_exr(&out).meta["spp"], "300");
    assert!(seen.iter().any(|&s| s < 300), "no partial image was seen: {seen:?}");
    let leftovers: Vec<_> = fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(leftovers.len(), 1, "temporary files left: {leftovers:?}");
    fs::remove_dir_all(&d).ok();
}

#[test]
fn exr_metadata_records_the_render() {
    let d = tmpdir("meta");
    let out = d.join("m.exr");
    ok(render_cmd(&out, &["-D", "res=16", "--spp", "3", "--seed", "77", "-D", "unused=1"])
        .output()
        .unwrap_or_else(|e| panic!("{e}")));
    let e = read_exr(&out);
    assert_eq!(e.meta["spp"], "3");
    assert_eq!(e.meta["seed"], "77");
    assert_eq!(e.meta["version"], env!("CARGO_PKG_VERSION"));
    assert!(e.meta["commandLine"].contains("--seed 77"));
    assert!(e.meta["renderTime"].parse::<f64>().unwrap() > 0.0);
    assert_eq!(e.meta["settingsHash"].len(), 16);
    assert!(e.meta["settings"].contains("defines=res=16 unused=1"));
    // Beauty only (no weight channel) outside --part: a plain RGB EXR.
    let mut names: Vec<_> = e.channels.keys().cloned().collect();
    names.sort();
    assert_eq!(names, ["B", "G", "R"]);
    // The existing reader reads it.
    let img = penumbra_scene_read(&out);
    assert_eq!(img, (16, 16));
    fs::remove_dir_all(&d).ok();
}

fn penumbra_scene_read(path: &Path) -> (usize, usize) {
    let o = ok(bin().arg("diff").arg(path).arg(path).output().unwrap());
    assert!(String::from_utf8_lossy(&o.stdout).contains("MSE"));
    let e = read_exr(path);
    e.size
}

fn parts(d: &Path, n: u32, args: &[&str]) -> Vec<PathBuf> {
    (0..n)
        .map(|i| {
            let p = d.join(format!("part{i}.exr"));
            ok(render_cmd(&p, &[args, &["--part", &format!("{i}/{n}")]].concat()).output().unwrap());
            p
        })
        .collect()
}

fn merge(inputs: &[&PathBuf], out: &Path, extra: &[&str]) -> Output {
    bin().arg("merge").args(inputs).arg("-o").arg(out).args(extra).output().unwrap()
}

#[test]
fn parts_merge_into_the_single_machine_render() {
    let d = tmpdir("parts");
    let args = ["-D", "res=32", "--spp", "24", "--seed", "9"];
    let single = d.join("single.exr");
    ok(render_cmd(&single, &args).output().unwrap());
    let p = parts(&d, 4, &args);
    let out = d.join("merged.exr");
    ok(merge(&p.iter().collect::<Vec<_>>(), &out, &[]));
    let (m, s) = (read_exr(&out), read_exr(&single));
    let rel = max_rel_diff(&m, &s);
    eprintln!("largest relative difference merged vs single render: {rel:e}");
    assert!(rel < 1e-6, "{rel}");
    assert_eq!(m.meta["spp"], "24");
    assert_eq!(m.meta["settingsHash"], s.meta["settingsHash"]);
    assert!(read_exr(&p[1]).channels.contains_key("penumbra.weight"));
    assert_eq!(read_exr(&p[1]).meta["samples"], "6..12");

    // Missing, duplicate and foreign parts are named.
    let e = String::from_utf8_lossy(&merge(&[&p[0], &p[1], &p[3]], &out, &[]).stderr).into_owned();
    assert!(e.contains("part 2/4 of window 0,0,32,32 missing"), "{e}");
    let e = String::from_utf8_lossy(&merge(&[&p[0], &p[1], &p[1], &p[2], &p[3]], &out, &[]).stderr).into_owned();
    assert!(e.contains("part1.exr") && e.contains("duplicate"), "{e}");
    let foreign = d.join("foreign.exr");
    ok(render_cmd(&foreign, &["-D", "res=32", "--spp", "24", "--seed", "10", "--part", "3/4"]).output().unwrap());
    let e = String::from_utf8_lossy(&merge(&[&p[0], &p[1], &p[2], &foreign], &out, &[]).stderr).into_owned();
    assert!(e.contains("foreign.exr") && e.contains("seed: 10 there, 9 in"), "{e}");
    let other_n = d.join("n3.exr");
    ok(render_cmd(&other_n, &[&args[..], &["--part", "2/3"]].concat()).output().unwrap());
    let e = String::from_utf8_lossy(&merge(&[&p[0], &p[1], &other_n, &p[3]], &out, &[]).stderr).into_owned();
    assert!(e.contains("n3.exr") && e.contains("same N"), "{e}");
    // --allow-missing merges what exists and records the spp reached.
    ok(merge(&[&p[0], &p[1], &p[3]], &out, &["--allow-missing"]));
    let m = read_exr(&out);
    assert_eq!(m.meta["spp"], "18");
    assert_eq!(m.meta["complete"], "no");
    fs::remove_dir_all(&d).ok();
}

#[test]
fn crops_merge_into_the_full_frame() {
    let d = tmpdir("crops");
    let args = ["-D", "res=32", "--spp", "8", "--seed", "2"];
    let full = d.join("full.exr");
    ok(render_cmd(&full, &args).output().unwrap());
    let left = d.join("left.exr");
    ok(render_cmd(&left, &[&args[..], &["--crop", "0,0,13,32"]].concat()).output().unwrap());
    let l = read_exr(&left);
    assert_eq!(l.size, (13, 32));
    assert_eq!(l.meta["crop"], "0,0,13,32");
    // The right side in two parts.
    let r: Vec<PathBuf> = (0..2)
        .map(|i| {
            let p = d.join(format!("right{i}.exr"));
            let part = format!("{i}/2");
            ok(render_cmd(&p, &[&args[..], &["--crop", "13,0,32,32", "--part", &part]].concat()).output().unwrap());
            p
        })
        .collect();
    let out = d.join("merged.exr");
    ok(merge(&[&left, &r[0], &r[1]], &out, &[]));
    let (m, f) = (read_exr(&out), read_exr(&full));
    assert_eq!(m.size, (32, 32));
    assert!(max_rel_diff(&m, &f) < 1e-6);
    // The whole crop is pasted bit for bit.
    for c in ["R", "G", "B"] {
        for y in 0..32 {
            for x in 0..13 {
                assert_eq!(m.channels[c][y * 32 + x].to_bits(), f.channels[c][y * 32 + x].to_bits());
            }
        }
    }
    assert_eq!(m.meta["settingsHash"], f.meta["settingsHash"]);
    // A missing window and overlapping windows are errors.
    ok(merge(&[&left], &out, &[])); // a single crop merges into itself
    assert_eq!(read_exr(&out).size, (13, 32));
    let e = String::from_utf8_lossy(&merge(&[&left, &r[0]], &out, &[]).stderr).into_owned();
    assert!(e.contains("part 1/2 of window 13,0,32,32 missing"), "{e}");
    let over = d.join("over.exr");
    ok(render_cmd(&over, &[&args[..], &["--crop", "10,0,20,8"]].concat()).output().unwrap());
    let e = String::from_utf8_lossy(&merge(&[&left, &over, &r[0], &r[1]], &out, &[]).stderr).into_owned();
    assert!(e.contains("overlap") && e.contains("over.exr"), "{e}");
    let e = fails(render_cmd(&over, &[&args[..], &["--crop", "0,0,40,8"]].concat()).output().unwrap());
    assert!(e.contains("outside the 32x32 image"), "{e}");
    fs::remove_dir_all(&d).ok();
}

#[test]
fn part_auto_follows_slurm_and_kubernetes() {
    let d = tmpdir("auto");
    let out = d.join("a.exr");
    let args = ["-D", "res=8", "--spp", "4", "--part", "auto"];
    let slurm = [
        ("SLURM_ARRAY_TASK_ID", "1"),
        ("SLURM_ARRAY_TASK_COUNT", "2"),
        ("SLURM_ARRAY_TASK_MIN", "0"),
        ("SLURM_ARRAY_TASK_MAX", "1"),
        ("SLURM_ARRAY_TASK_STEP", "1"),
        ("SLURM_CPUS_PER_TASK", "1"),
    ];
    ok(render_cmd(&out, &args).envs(slurm).output().unwrap());
    assert_eq!(read_exr(&out).meta["part"], "1/2");
    let shifted = [("SLURM_ARRAY_TASK_ID", "2"), ("SLURM_ARRAY_TASK_COUNT", "2"), ("SLURM_ARRAY_TASK_MIN", "1")];
    let e = fails(render_cmd(&out, &args).envs(shifted).output().unwrap());
    assert!(e.contains("not numbered 0..1") && e.contains("--array=0-1"), "{e}");
    let e = fails(render_cmd(&out, &args).env("JOB_COMPLETION_INDEX", "1").output().unwrap());
    assert!(e.contains("auto/N"), "{e}");
    let mut k8s = render_cmd(&out, &["-D", "res=8", "--spp", "4", "--part", "auto/4"]);
    ok(k8s.env("JOB_COMPLETION_INDEX", "3").output().unwrap());
    assert_eq!(read_exr(&out).meta["part"], "3/4");
    fs::remove_dir_all(&d).ok();
}
