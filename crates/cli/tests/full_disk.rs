//! Failing writes: a render whose checkpoint or image cannot be written
//! (here because of a file-size limit, `prlimit --fsize`, which behaves as a
//! full disk does for the writer) stops with a clear error naming the file,
//! keeps the previous checkpoint and image byte for byte, leaves no
//! temporary file, and the next run resumes from the kept checkpoint (and
//! removes temporary files that a killed run left).

use crate::common;

use crate::common::{bin, ok};
use std::fs;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::Command;

/// `penumbra render` of the bundled box at 24 x 24, one pass per run.
fn render(out: &Path, ck: &Path) -> Command {
    let mut c = bin();
    c.arg("render")
        .arg(common::cornell())
        .args(["-D", "res=24", "--spp", "64", "--seed", "5", "--max-pass-spp", "1", "--time", "0", "--quiet"])
        .arg("-o")
        .arg(out)
        .arg("--checkpoint")
        .arg(ck);
    c
}

/// `c` with every file it writes limited to `bytes` (RLIMIT_FSIZE).
fn limited(mut c: Command, bytes: u64) -> Command {
    // SAFETY: setrlimit is async-signal-safe and touches only the child.
    unsafe {
        c.pre_exec(move || {
            let lim = libc::rlimit { rlim_cur: bytes as libc::rlim_t, rlim_max: bytes as libc::rlim_t };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    c
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn writes_past_a_file_size_limit_fail_cleanly_and_keep_the_previous_files() {
    let d = common::tmpdir("fulldisk", "limit");
    let (out, ck) = (d.join("out.exr"), d.join("render.ck"));
    // A first pass, stopped by --time 0: a checkpoint and a partial image.
    ok(render(&out, &ck).output().unwrap());
    let (ck_before, out_before) = (fs::read(&ck).unwrap(), fs::read(&out).unwrap());
    assert!(ck_before.len() > 4096 && out_before.len() > 1024);

    // The next pass cannot write its checkpoint (nor its image): an error
    // naming the file and the cause, not a death by SIGXFSZ.
    let o = limited(render(&out, &ck), 1024).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{:?}: {err}", o.status);
    assert!(err.contains("cannot write") && err.contains("File too large"), "{err}");
    assert!(err.contains("render.ck") || err.contains("out.exr"), "{err}");
    // Nothing half-written, nothing left behind, the previous files intact.
    assert_eq!(files(&d), ["out.exr", "render.ck"]);
    assert!(fs::read(&ck).unwrap() == ck_before, "the previous checkpoint changed");
    assert!(fs::read(&out).unwrap() == out_before, "the previous image changed");

    // Without the limit, the next run resumes from the kept checkpoint.
    let o = ok(render(&out, &ck).output().unwrap());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(fs::read(&ck).unwrap() != ck_before, "no new checkpoint: {err}");
    assert_eq!(files(&d), ["out.exr", "render.ck"]);

    // Temporary files left by a run killed mid-write are removed by the
    // next run, even one that writes nothing (here: refused by --max-memory).
    fs::write(d.join("out.exr.tmp"), b"half an image").unwrap();
    fs::write(d.join("render.ck.tmp"), b"half a checkpoint").unwrap();
    let o = render(&out, &ck).args(["--max-memory", "1K"]).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("removed") && err.contains("render.ck.tmp") && err.contains("out.exr.tmp"), "{err}");
    assert_eq!(files(&d), ["out.exr", "render.ck"]);
    fs::remove_dir_all(&d).ok();
}

/// A film predicted to exceed --max-memory, alone or with the scene as
/// loaded, is refused before anything is allocated or written, with the
/// sizes asked for and the limit.
#[test]
fn a_film_past_max_memory_is_refused_before_rendering() {
    let d = common::tmpdir("fulldisk", "memory");
    let out = d.join("out.exr");
    let o = bin()
        .arg("render")
        .arg(common::cornell())
        .args(["-D", "res=400", "--spp", "1", "--quiet", "--max-memory", "4M", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("400 x 400 film needs about 6.71 MiB") && err.contains("--max-memory, 4.00 MiB"), "{err}");
    assert!(files(&d).is_empty());
    let o = bin().arg("render").arg(common::cornell()).args(["--max-memory", "5Q", "-o"]).arg(&out).output().unwrap();
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown unit"));
    // The scene as loaded counts against the limit too: a 40 x 40 film
    // needs 69 KiB, the process with its scene more than 2 MiB.
    let o = bin()
        .arg("render")
        .arg(common::cornell())
        .args(["-D", "res=40", "--spp", "1", "--quiet", "--max-memory", "2M", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("40 x 40 film needs about 68.75 KiB") && err.contains("the scene as loaded"), "{err}");
    assert!(files(&d).is_empty());
    ok(bin()
        .arg("render")
        .arg(common::cornell())
        .args(["-D", "res=40", "--spp", "1", "--quiet", "--max-memory", "256M", "-o"])
        .arg(&out)
        .output()
        .unwrap());
    fs::remove_dir_all(&d).ok();
}
