//! The `aov`, `moment` and `ptracer` integrators end to end through the
//! `penumbra` binary: their EXR channels, and that checkpoints (resume
//! bitwise) and `--part`/`merge` (equal up to f32 rounding) keep working.

use crate::common;

use crate::common::{bin, ok, read_exr, Exr};
use std::fs;
use std::path::{Path, PathBuf};

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes").join(format!("{name}.xml"))
}

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Exr {
    ok(bin().arg("render").arg(scene).arg("-o").arg(out).arg("--quiet").args(extra).output().unwrap());
    read_exr(out)
}

/// Renders `name` whole; stopped after its first pass and resumed from the
/// checkpoint (must be bitwise the whole render); in three parts merged
/// (every channel within 1e-4, relative, of the whole render).
fn resume_and_parts(name: &str, args: &[&str], channels: &[&str]) {
    let d = common::tmpdir("integrators", name);
    let whole = render(&scene(name), &d.join("whole.exr"), args);
    for c in channels {
        assert!(whole.channels.contains_key(*c), "{name}: no channel {c}: {:?}", whole.channels.keys());
    }
    let ck = d.join("ck.bin");
    let resumed_path = d.join("resumed.exr");
    let ck_args = [args, &["--checkpoint", ck.to_str().unwrap()]].concat();
    let first = render(&scene(name), &resumed_path, &[&ck_args[..], &["--time", "0"]].concat());
    assert_ne!(first.meta["complete"], "yes", "{name}: the first run should stop early");
    let resumed = render(&scene(name), &resumed_path, &ck_args);
    assert_eq!(resumed.meta["complete"], "yes");
    for (c, v) in &whole.channels {
        let r = resumed.ch(c);
        assert!(v.iter().zip(r).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}: {c} differs after resume");
    }
    let parts: Vec<PathBuf> = (0..3)
        .map(|i| {
            let p = d.join(format!("p{i}.exr"));
            render(&scene(name), &p, &[args, &["--part", &format!("{i}/3")]].concat());
            p
        })
        .collect();
    let merged = d.join("merged.exr");
    ok(bin().arg("merge").args(&parts).arg("-o").arg(&merged).output().unwrap());
    let m = read_exr(&merged);
    for (c, v) in &whole.channels {
        let worst = m.ch(c).iter().zip(v).map(|(a, b)| ((a - b).abs() / b.abs().max(1e-3)) as f64).fold(0.0, f64::max);
        assert!(worst < 1e-4, "{name}: {c} of the merged parts differs by {worst}");
    }
    fs::remove_dir_all(&d).ok();
}

#[test]
fn aov_channels_survive_resume_and_parts() {
    let args = ["--spp", "12", "--max-pass-spp", "2", "--seed", "3", "--aov", "depth"];
    resume_and_parts("aov_channels", &args, &["R", "my_image.A", "dd.y.T", "nn.X", "dx.U", "shape.I", "depth.Z"]);
}

#[test]
fn moment_channels_survive_resume_and_parts() {
    let args = ["--spp", "12", "--max-pass-spp", "2", "--seed", "3"];
    resume_and_parts("moment_cbox", &args, &["R", "p.X", "m2_p.Y", "d.Z", "m2_d.Z"]);
}

#[test]
fn particle_tracer_survives_resume_and_parts() {
    let args = ["--spp", "12", "--max-pass-spp", "2", "--seed", "3"];
    resume_and_parts("ptracer_box", &args, &["R", "G", "B"]);
    // Per-pixel layers are refused with the reason.
    let d = common::tmpdir("integrators", "ptracer-aov");
    let mut cmd = bin();
    cmd.arg("render").arg(scene("ptracer_box")).arg("-o").arg(d.join("x.exr")).args(["--aov", "albedo"]);
    let o = cmd.output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("ptracer"));
    fs::remove_dir_all(&d).ok();
}

/// Path guiding end to end: the guided image is the same for any thread
/// count and pass cap (the guide learns from records in tile order, and
/// its training passes double whatever `--max-pass-spp` says); it resumes
/// bitwise from a checkpoint, and its parts merge into the whole render.
#[test]
fn guided_path_is_deterministic_resumes_and_merges_parts() {
    let d = common::tmpdir("integrators", "guided");
    let args = ["--integrator", "path:max_depth=6,guiding=true", "--spp", "24"];
    let one = render(&scene("cbox_diffuse"), &d.join("one.exr"), &[&args[..], &["--threads", "1"]].concat());
    let two = render(
        &scene("cbox_diffuse"),
        &d.join("two.exr"),
        &[&args[..], &["--threads", "2", "--max-pass-spp", "2"]].concat(),
    );
    let plain =
        render(&scene("cbox_diffuse"), &d.join("plain.exr"), &["--integrator", "path:max_depth=6", "--spp", "24"]);
    // Guided passes that do not train run in the stream: bitwise the one-path loop.
    let scalar = render(&scene("cbox_diffuse"), &d.join("scalar.exr"), &[&args[..], &["--no-stream"]].concat());
    for (c, v) in &one.channels {
        assert!(v.iter().zip(two.ch(c)).all(|(a, b)| a.to_bits() == b.to_bits()), "{c} depends on the threads");
        assert!(v.iter().zip(scalar.ch(c)).all(|(a, b)| a.to_bits() == b.to_bits()), "{c}: stream and loop differ");
    }
    assert_ne!(one.ch("R"), plain.ch("R"), "guiding changed nothing");
    // After training, roulette goes by each path's expected share of its
    // pixel (guiding_roulette, on by default), not by throughput.
    let by_throughput = render(
        &scene("cbox_diffuse"),
        &d.join("by-throughput.exr"),
        &["--integrator", "path:max_depth=6,guiding=true,guiding_roulette=false", "--spp", "24"],
    );
    assert_ne!(one.ch("R"), by_throughput.ch("R"), "roulette by expected contribution changed nothing");
    // Parts each train the same guide on the whole render's training
    // passes (kept by part 0 only): merged, they are the whole render.
    resume_and_parts("cbox_diffuse", &args, &["R", "G", "B"]);
    // Stopped after every pass (--time 0 renders one) and resumed from the
    // checkpoint, guide and all, until done: bitwise the uninterrupted render.
    let ck = d.join("ck.bin");
    let ck_args = [&args[..], &["--threads", "1", "--checkpoint", ck.to_str().unwrap(), "--time", "0"]].concat();
    let mut runs = 0;
    let resumed = loop {
        let img = render(&scene("cbox_diffuse"), &d.join("resumed.exr"), &ck_args);
        runs += 1;
        if !ck.exists() {
            break img;
        }
        assert!(runs < 20, "the render never completed");
    };
    assert!(runs >= 5, "{runs} runs: training and guided passes were not both resumed");
    for (c, v) in &one.channels {
        assert!(v.iter().zip(resumed.ch(c)).all(|(a, b)| a.to_bits() == b.to_bits()), "{c}: resumed differs");
    }
}
